/* Bound-driven tuple sampling (paper Sec. 5.3-5.4, Alg. 1 with bins). */
#include "sampler_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void bbc__sampler_free(bbc__tuple_sampler *s) {
  if (!s) return;
  free(s->tuple);
  free(s->p);
  free(s->prefix);
  free(s->bin_end);
  free(s->scratch);
  memset(s, 0, sizeof *s);
}

static int reserve(bbc__tuple_sampler *s, uint32_t n) {
  if (n <= s->capacity) return 1;
  uint32_t capacity = s->capacity ? s->capacity : 64;
  while (capacity < n) capacity *= 2;
  uint32_t *tuple = realloc(s->tuple, capacity * sizeof *tuple);
  if (tuple) s->tuple = tuple;
  double *p = realloc(s->p, capacity * sizeof *p);
  if (p) s->p = p;
  double *prefix = realloc(s->prefix, capacity * sizeof *prefix);
  if (prefix) s->prefix = prefix;
  uint32_t *bin_end = realloc(s->bin_end, capacity * sizeof *bin_end);
  if (bin_end) s->bin_end = bin_end;
  double *scratch = realloc(s->scratch, capacity * sizeof *scratch);
  if (scratch) s->scratch = scratch;
  if (!tuple || !p || !prefix || !bin_end || !scratch) return 0;
  s->capacity = capacity;
  return 1;
}

/* Expected number of tuples with a finite bound chosen for gamma: sum min(gamma E, 1).
 * Tuples with an infinite bound (irradiance unbounded near focal points) have P = 1 for
 * every gamma, so they are left out of the target: were they counted, a cell with W of
 * them would drive gamma to 0 and starve every finite tuple (P ~ 1e-24: unbiased, but
 * its variance is unusable). *infinite (may be NULL) receives their number. */
static double expected_count(const bbc_cache_entry *e, uint32_t n, double gamma,
                             uint32_t *infinite) {
  double sum = 0;
  uint32_t inf = 0;
  for (uint32_t i = 0; i < n; i++) {
    double b = e[i].bound;
    if (isfinite(b))
      sum += fmin(gamma * b, 1.0);
    else
      inf++;
  }
  if (infinite) *infinite = inf;
  return sum;
}

/* The variance bound of Eq. 25, sum E^2 / min(gamma E, 1), over finite bounds (an
 * infinite bound has P = 1 and its term is unknown either way). */
static double variance_bound(const bbc_cache_entry *e, uint32_t n, double gamma) {
  double sum = 0;
  for (uint32_t i = 0; i < n; i++) {
    double b = e[i].bound;
    if (!isfinite(b) || b <= 0) continue;
    sum += b * b / fmin(gamma * b, 1.0);
  }
  return sum;
}

double bbc__sampler_gamma(const bbc_cache_entry *entries, uint32_t n, bbc__gamma_source source,
                          double value) {
  if (source == BBC__GAMMA_FIXED) return value;
  uint32_t infinite = 0;
  expected_count(entries, n, 0.0, &infinite);
  if (source == BBC__GAMMA_EXPECTED && value >= n - infinite) return INFINITY;
  /* Bisection in log space between tiny and huge gamma: both functions are monotonic
   * (the count increases, the variance bound decreases with gamma). */
  double lo = -80, hi = 80;
  if (source == BBC__GAMMA_VARIANCE && variance_bound(entries, n, exp2(hi)) > value)
    return INFINITY;
  for (int it = 0; it < 60; it++) {
    double mid = 0.5 * (lo + hi);
    double g = exp2(mid);
    int too_small = source == BBC__GAMMA_EXPECTED ? expected_count(entries, n, g, NULL) < value
                                                  : variance_bound(entries, n, g) > value;
    if (too_small)
      lo = mid;
    else
      hi = mid;
  }
  return exp2(hi);
}

int bbc__sampler_prepare(bbc__tuple_sampler *s, const bbc_cache_entry *entries, uint32_t n,
                         const bbc__sampling *sampling) {
  s->n = s->bins = 0;
  s->one_sample = 0;
  if (n == 0) return 1;
  if (!reserve(s, n)) return 0;
  s->n = n;
  if (sampling->method == BBC__SAMPLE_ONE) {
    /* Eq. 23: one tuple, proportional to E~. Infinite bounds cannot be weighed, so they
     * are always taken (P = 1) and the finite ones share one draw. */
    s->one_sample = 1;
    double total = 0;
    uint32_t finite = 0;
    for (uint32_t i = 0; i < n; i++) {
      double b = entries[i].bound;
      if (isfinite(b)) {
        total += b;
        s->tuple[finite] = entries[i].tuple;
        s->prefix[finite++] = total;
      }
    }
    uint32_t k = finite;
    for (uint32_t i = 0; i < n; i++)
      if (!isfinite(entries[i].bound)) s->tuple[k++] = entries[i].tuple;
    for (uint32_t i = 0; i < finite; i++)
      s->p[i] = total > 0 ? (s->prefix[i] - (i ? s->prefix[i - 1] : 0)) / total : 0;
    s->bins = finite; /* the first `bins` tuples share the draw */
    s->total = total;
    return 1;
  }
  double gamma = INFINITY;
  if (sampling->method != BBC__SAMPLE_ENUMERATE)
    gamma = bbc__sampler_gamma(entries, n, sampling->source, sampling->value);
  double *p = s->scratch;
  if (sampling->method == BBC__SAMPLE_UNIFORM) {
    /* The same expected count as the bbc method: the finite tuples' and every infinite
     * one. */
    uint32_t infinite = 0;
    double w = isfinite(gamma) ? expected_count(entries, n, gamma, &infinite) + infinite : n;
    for (uint32_t i = 0; i < n; i++) p[i] = fmin(w / n, 1.0);
  } else {
    for (uint32_t i = 0; i < n; i++) {
      double b = entries[i].bound;
      p[i] = sampling->method == BBC__SAMPLE_ENUMERATE ? 1.0 : fmin(gamma * b, 1.0);
      if (!(p[i] >= 0)) p[i] = 1.0; /* inf * 0 and the like: take it */
    }
  }
  /* Bins: every tuple with P = 1 alone, then next-fit packing of the others in list
   * order into bins of total probability <= 1. Any packing chooses each tuple with
   * exactly its P (a tuple's slice of its bin's prefix sums has length P); next fit
   * needs no sort and uses at most twice the bins of the best packing (two consecutive
   * bins hold more than 1). */
  uint32_t k = 0;
  for (uint32_t i = 0; i < n; i++) {
    if (!(p[i] >= 1.0)) continue;
    s->tuple[k] = entries[i].tuple;
    s->p[k] = 1.0;
    s->prefix[k] = 1.0;
    s->bin_end[s->bins++] = ++k;
  }
  double in_bin = 0;
  uint32_t open = k;
  for (uint32_t i = 0; i < n; i++) {
    if (!(p[i] > 0) || p[i] >= 1.0) continue; /* zero bounds carry no light */
    if (k > open && in_bin + p[i] > 1.0) {
      s->bin_end[s->bins++] = k;
      open = k;
      in_bin = 0;
    }
    in_bin += p[i];
    s->tuple[k] = entries[i].tuple;
    s->p[k] = p[i];
    s->prefix[k] = in_bin;
    k++;
  }
  if (k > open) s->bin_end[s->bins++] = k;
  s->n = k;
  return 1;
}

static double next_uniform(const bbc__bin_uniforms *given, uint32_t *used, bbc_rng *rng) {
  if (given && *used < given->count) return given->get(given->user, (*used)++);
  return bbc_rng_next(rng);
}

uint32_t bbc__sampler_draw(const bbc__tuple_sampler *s, const bbc__bin_uniforms *given,
                           bbc_rng *rng, void (*emit)(void *user, uint32_t tuple, double p),
                           void *user) {
  uint32_t chosen = 0, used = 0;
  if (s->one_sample) {
    if (s->bins > 0 && s->total > 0) {
      double u = next_uniform(given, &used, rng) * s->total;
      uint32_t lo = 0, hi = s->bins - 1;
      while (lo < hi) {
        uint32_t mid = (lo + hi) / 2;
        if (s->prefix[mid] > u)
          hi = mid;
        else
          lo = mid + 1;
      }
      if (s->p[lo] > 0) {
        emit(user, s->tuple[lo], s->p[lo]);
        chosen++;
      }
    }
    for (uint32_t i = s->bins; i < s->n; i++, chosen++) emit(user, s->tuple[i], 1.0);
    return chosen;
  }
  uint32_t start = 0;
  for (uint32_t b = 0; b < s->bins; b++) {
    uint32_t end = s->bin_end[b];
    /* One uniform per bin: tuple j is chosen when u falls in its slice of the bin's
     * prefix sums, an event of probability exactly p[j]. */
    double u = 0; /* a lone tuple with P = 1 is chosen whatever u is */
    if (end - start > 1 || s->prefix[end - 1] < 1.0)
      u = next_uniform(given, &used, rng);
    if (u < s->prefix[end - 1]) {
      uint32_t lo = start, hi = end - 1;
      while (lo < hi) {
        uint32_t mid = (lo + hi) / 2;
        if (s->prefix[mid] > u)
          hi = mid;
        else
          lo = mid + 1;
      }
      emit(user, s->tuple[lo], s->p[lo]);
      chosen++;
    }
    start = end;
  }
  return chosen;
}
