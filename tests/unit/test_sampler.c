/* Tuple sampling: every tuple is chosen with exactly its probability, the estimator of
 * Eq. 24 is unbiased, and gamma solves the expected-count and variance equations. */
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "sampler_internal.h"

typedef struct draw_log {
  long *count;     /* indexed by tuple id */
  double estimate; /* sum of E / P this draw */
  const double *truth;
  double *p_of; /* probability reported per tuple id */
} draw_log;

static void on_emit(void *user, uint32_t tuple, double p) {
  draw_log *log = user;
  log->count[tuple]++;
  log->estimate += log->truth[tuple] / p;
  log->p_of[tuple] = p;
}

static double given_uniform(const void *user, uint32_t j) {
  bbc_rng r = {*(const uint64_t *)user, j};
  return bbc_rng_next(&r);
}

/* A cell of n tuples with bounds spread over decades, some infinite, some zero. */
static void make_cell(bbc_cache_entry *e, double *truth, uint32_t n, uint64_t seed) {
  for (uint32_t i = 0; i < n; i++) {
    bbc_rng rng = bbc_rng_make(seed, i, 0);
    double b = pow(10.0, -4 + 5 * bbc_rng_next(&rng));
    if (i % 17 == 3) b = INFINITY;
    if (i % 23 == 5) b = 0;
    e[i].tuple = 1000 + i; /* ids are not positions */
    e[i].bound = (float)b;
    /* The true contribution is at most the bound (and 0 where the bound is 0). */
    truth[i] = isfinite(b) ? b * bbc_rng_next(&rng) : 5.0 * bbc_rng_next(&rng);
  }
}

static void check_method(bbc__sampling sampling, const char *name) {
  enum { N = 60 };
  bbc_cache_entry e[N];
  double truth_by_pos[N];
  make_cell(e, truth_by_pos, N, 42);
  double truth[2000] = {0}, p_of[2000] = {0};
  long count[2000] = {0};
  double exact = 0;
  for (int i = 0; i < N; i++) {
    truth[e[i].tuple] = truth_by_pos[i];
    exact += truth_by_pos[i];
  }
  bbc__tuple_sampler s;
  memset(&s, 0, sizeof s);
  REQUIRE(bbc__sampler_prepare(&s, e, N, &sampling));
  /* Bins never hold more than probability 1. */
  uint32_t start = 0;
  for (uint32_t b = 0; b < s.bins && !s.one_sample; b++) {
    CHECK(s.prefix[s.bin_end[b] - 1] <= 1.0 + 1e-12);
    start = s.bin_end[b];
  }
  (void)start;
  const long draws = harness_scale(200000, 2000000);
  draw_log log = {count, 0, truth, p_of};
  double sum = 0, sum_sq = 0;
  for (long d = 0; d < draws; d++) {
    bbc_rng rng = bbc_rng_make(7, (uint64_t)d, 0);
    log.estimate = 0;
    /* Every other draw takes its first bins' uniforms from the caller (as the path
     * tracer's stratified sampler supplies them). */
    uint64_t key = bbc__mix64((uint64_t)d);
    bbc__bin_uniforms given = {given_uniform, &key, 3};
    bbc__sampler_draw(&s, d % 2 ? &given : NULL, &rng, on_emit, &log);
    sum += log.estimate;
    sum_sq += log.estimate * log.estimate;
  }
  /* Each tuple's frequency matches its probability, computed here from Eq. 23/28 (5
   * sigma), and the probability the sampler reported when choosing it is the same. */
  double gamma = bbc__sampler_gamma(e, N, sampling.source, sampling.value);
  double w = 0, finite_total = 0;
  for (int i = 0; i < N; i++) {
    w += fmin(gamma * e[i].bound, 1.0);
    if (isfinite(e[i].bound)) finite_total += e[i].bound;
  }
  int bad = 0;
  for (int i = 0; i < N; i++) {
    uint32_t id = e[i].tuple;
    double b = e[i].bound, p;
    switch (sampling.method) {
      case BBC__SAMPLE_ENUMERATE:
        p = 1;
        break;
      case BBC__SAMPLE_UNIFORM:
        p = fmin(w / N, 1.0);
        break;
      case BBC__SAMPLE_ONE:
        p = isfinite(b) ? b / finite_total : 1;
        break;
      default:
        p = fmin(gamma * b, 1.0);
        break;
    }
    double f = (double)count[id] / draws;
    if (fabs(f - p) > 5 * sqrt(p * (1 - p) / draws) + 1e-12 ||
        (count[id] > 0 && fabs(p_of[id] - p) > 1e-12 * p)) {
      if (bad++ < 5)
        fprintf(stderr, "%s: tuple %u frequency %.6f, P %.6f, reported %.6f\n", name, id, f, p,
                p_of[id]);
    }
  }
  CHECK_INT(bad, 0);
  double mean = sum / draws, var = sum_sq / draws - mean * mean;
  double se = sqrt(fmax(var, 0) / draws);
  fprintf(stderr, "%s: estimate %.6f +- %.6f, exact %.6f, mean |S| over %u tuples\n", name, mean,
          se, exact, N);
  CHECK(fabs(mean - exact) <= 5 * se + 1e-9 * exact);
  bbc__sampler_free(&s);
}

TEST(bound_sampling_fixed_gamma) {
  check_method((bbc__sampling){BBC__SAMPLE_BOUND, BBC__GAMMA_FIXED, 3.0}, "gamma 3");
}
TEST(bound_sampling_expected_count) {
  check_method((bbc__sampling){BBC__SAMPLE_BOUND, BBC__GAMMA_EXPECTED, 8.0}, "W = 8");
}
/* The smallest variance bound reachable (every P = 1) is sum E~^2 over finite bounds. */
static double least_variance(const bbc_cache_entry *e, int n) {
  double v = 0;
  for (int i = 0; i < n; i++)
    if (isfinite(e[i].bound)) v += (double)e[i].bound * e[i].bound;
  return v;
}

TEST(bound_sampling_variance_target) {
  bbc_cache_entry e[60];
  double truth[60];
  make_cell(e, truth, 60, 42);
  check_method((bbc__sampling){BBC__SAMPLE_BOUND, BBC__GAMMA_VARIANCE, 4 * least_variance(e, 60)},
               "V = 4 Vmin");
}
TEST(uniform_sampling) {
  check_method((bbc__sampling){BBC__SAMPLE_UNIFORM, BBC__GAMMA_EXPECTED, 8.0}, "uniform");
}
TEST(enumerate_takes_everything) {
  check_method((bbc__sampling){BBC__SAMPLE_ENUMERATE, BBC__GAMMA_FIXED, 0}, "enumerate");
}
TEST(one_sample) {
  check_method((bbc__sampling){BBC__SAMPLE_ONE, BBC__GAMMA_FIXED, 0}, "one-sample");
}

TEST(gamma_solves_its_equations) {
  enum { N = 200 };
  bbc_cache_entry e[N];
  double truth[N];
  make_cell(e, truth, N, 9);
  /* W is the expected count of the tuples with a finite bound; those with an infinite
   * bound are always taken on top, so that a cell full of them cannot starve the rest. */
  int infinite = 0;
  for (int i = 0; i < N; i++) infinite += isinf(e[i].bound);
  CHECK(infinite > 0);
  for (double w = 0.5; w < N - infinite; w *= 3) {
    double g = bbc__sampler_gamma(e, N, BBC__GAMMA_EXPECTED, w);
    double sum = 0;
    for (int i = 0; i < N; i++)
      if (isfinite(e[i].bound)) sum += fmin(g * e[i].bound, 1.0);
    CHECK_NEAR(sum, w, 1e-6 * w);
  }
  CHECK(isinf(bbc__sampler_gamma(e, N, BBC__GAMMA_EXPECTED, N - infinite)));
  /* Even W below the number of infinite bounds leaves the finite ones their share. */
  double g_small = bbc__sampler_gamma(e, N, BBC__GAMMA_EXPECTED, 0.5);
  CHECK(g_small > 1e-20);
  double target = 3 * least_variance(e, N);
  double g = bbc__sampler_gamma(e, N, BBC__GAMMA_VARIANCE, target);
  CHECK(isfinite(g));
  /* Below the least reachable variance every tuple must be taken. */
  CHECK(isinf(bbc__sampler_gamma(e, N, BBC__GAMMA_VARIANCE, 0.5 * least_variance(e, N))));
  double v = 0;
  for (int i = 0; i < N; i++)
    if (isfinite(e[i].bound) && e[i].bound > 0)
      v += (double)e[i].bound * e[i].bound / fmin(g * e[i].bound, 1.0);
  CHECK_NEAR(v, target, 1e-6 * target);
}
