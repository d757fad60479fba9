/* The validation harness (validate.h) against an independent tally: the exact tracer
 * oracle of exact_tracer_oracle.h, written apart from bbc_specular_path_trace, traces
 * the very same u1 (bbc_validation_sample_u1), a linear search finds the piece, and the
 * admissible counts, unbounded counts, minimum ratios and percentiles must come out the
 * same as the harness's. On top: the bounds hold on the test scenes, and do not without
 * remainder variables (Fig. 18). */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "bbc/bounds.h"
#include "bbc/specular_path.h"
#include "bbc/validate.h"
#include "exact_tracer_oracle.h"
#include "harness.h"

/* ---- the independent tally ---------------------------------------------------------- */

typedef struct oracle_tally {
  long samples, admissible, failing, unbounded;
  double *ratios; /* log10(e_hi / E) of admissible paths in kept pieces, finite e_hi */
  long ratio_count, ratio_capacity;
} oracle_tally;

typedef struct piece_list {
  bbc_piece *items;
  size_t count, capacity;
} piece_list;

static int collect(void *user, const bbc_piece *piece) {
  piece_list *l = user;
  if (l->count == l->capacity) {
    l->capacity = l->capacity ? 2 * l->capacity : 64;
    l->items = realloc(l->items, l->capacity * sizeof *l->items);
  }
  l->items[l->count++] = *piece;
  return 0;
}

static void add_ratio(oracle_tally *t, double lr) {
  if (t->ratio_count == t->ratio_capacity) {
    t->ratio_capacity = t->ratio_capacity ? 2 * t->ratio_capacity : 4096;
    t->ratios = realloc(t->ratios, t->ratio_capacity * sizeof(double));
  }
  t->ratios[t->ratio_count++] = lr;
}

/* The same tuple and the same samples as bbc_validate_tuple, checked the way
 * test_bounds.c checks them: oracle paths, pieces found by linear search. */
static void oracle_tuple(bbc_bounder *b, const bbc_scene *scene, const bbc_tuple *tuple,
                         const bbc_bound_params *p, uint32_t samples, uint64_t seed,
                         oracle_tally *t) {
  bbc_tuple_geometry g;
  if (bbc_tuple_geometry_init(&g, scene, tuple) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "geometry of tuple %u/%u", tuple->specular[0],
                 tuple->receiver);
    return;
  }
  piece_list l = {NULL, 0, 0};
  if (bbc_bound_tuple(b, &g, p, collect, &l, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "bbc_bound_tuple failed");
    free(l.items);
    return;
  }
  for (uint32_t i = 0; i < samples; i++) {
    double u1[2];
    bbc_validation_sample_u1(seed, tuple, i, u1);
    t->samples++;
    true_path path = trace(&g, u1[0], u1[1]);
    if (!path.valid) continue;
    t->admissible++;
    const bbc_piece *hit = NULL;
    for (size_t k = 0; k < l.count; k++) {
      const bbc_piece *q = &l.items[k];
      if (u1[0] >= q->u_lo && u1[0] <= q->u_hi && u1[1] >= q->v_lo && u1[1] <= q->v_hi) {
        hit = q;
        if (q->status == BBC_PIECE_KEPT) break;
      }
    }
    if (!hit || hit->status == BBC_PIECE_DISCARDED) {
      t->failing++;
      continue;
    }
    int inside = path.uk >= hit->uk_lo && path.uk <= hit->uk_hi && path.vk >= hit->vk_lo &&
                 path.vk <= hit->vk_hi;
    /* The position bound's cuts across the image's sides (a = b = 0: none). */
    for (int j = 0; j < 2; j++) {
      const double *c = hit->cut[j], w = c[0] * path.uk + c[1] * path.vk;
      if ((c[0] != 0 || c[1] != 0) && !(w >= c[2] && w <= c[3])) inside = 0;
    }
    if (!inside || !(path.irradiance <= hit->e_hi) || !(path.irradiance >= hit->e_lo)) t->failing++;
    if (isfinite(hit->e_hi))
      add_ratio(t, log10(hit->e_hi / path.irradiance));
    else
      t->unbounded++;
  }
  free(l.items);
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The exact q-quantile by the harness's rank rule: the ceil(q n)-th smallest ratio. */
static double exact_quantile(const oracle_tally *t, double q) {
  long rank = (long)ceil(q * (double)t->ratio_count);
  if (rank < 1) rank = 1;
  return t->ratios[rank - 1];
}

/* Compares the harness's accumulator with the oracle's tally of the same samples. */
static void compare_with_oracle(const char *name, const bbc_validation *acc, oracle_tally *t) {
  CHECK_INT(acc->samples, t->samples);
  CHECK_INT(acc->admissible, t->admissible);
  CHECK_INT(acc->failing, t->failing);
  CHECK_INT(acc->unbounded, t->unbounded);
  CHECK_INT(acc->ratio_count, t->ratio_count);
  if (t->ratio_count > 0 && acc->ratio_count > 0) {
    qsort(t->ratios, t->ratio_count, sizeof(double), compare_double);
    /* The two tracers agree to a few ulps, so the ratios agree far below the bin width;
     * the histogram's quantiles are bin midpoints, within half a bin of the exact ones. */
    CHECK_NEAR(acc->min_log_ratio, t->ratios[0], 1e-9);
    CHECK_NEAR(acc->max_log_ratio, t->ratios[t->ratio_count - 1], 1e-9);
    const double half = 0.5 * BBC_VALIDATION_BIN_WIDTH + 1e-9;
    double median = bbc_validation_log_ratio_quantile(acc, 0.5);
    double p99 = bbc_validation_log_ratio_quantile(acc, 0.99);
    CHECK_NEAR(median, exact_quantile(t, 0.5), half);
    CHECK_NEAR(p99, exact_quantile(t, 0.99), half);
    fprintf(stderr,
            "%s: oracle agrees: %ld admissible of %ld samples; exact median %.4f p99 %.4f, "
            "histogram median %.3f p99 %.3f\n",
            name, t->admissible, t->samples, exact_quantile(t, 0.5), exact_quantile(t, 0.99),
            median, p99);
  }
  free(t->ratios);
  t->ratios = NULL;
}

/* ---- scenes --------------------------------------------------------------------------- */

/* Every stride-th (light, caster, receiver) tuple in the order of test_bounds.c's
 * scene_tuples, validated into *acc and, when t is not NULL, tallied by the oracle. */
static void validate_scene(const char *path, bbc_chain chain, long stride, uint32_t samples,
                           const bbc_bound_params *p, bbc_validation *acc, oracle_tally *t) {
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", path);
    return;
  }
  bbc_bounder *b = NULL;
  if (bbc_bounder_create(&b) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "bbc_bounder_create failed");
    bbc_scene_free(scene);
    return;
  }
  long index = 0;
  for (uint32_t l = 0; l < scene->point_light_count; l++)
    for (uint32_t i = 0; i < scene->triangle_count; i++) {
      if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
      for (uint32_t k = 0; k < scene->triangle_count; k++) {
        if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
        if (index++ % stride) continue;
        bbc_tuple tuple = {l, chain, {i, BBC_NO_TRIANGLE}, k};
        bbc_result r = bbc_validate_tuple(b, scene, &tuple, p, samples, 17, acc);
        if (r != BBC_OK) harness_fail(__FILE__, __LINE__, "bbc_validate_tuple: %d", (int)r);
        if (t) oracle_tuple(b, scene, &tuple, p, samples, 17, t);
      }
    }
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}

static void report(const char *name, const bbc_validation *acc) {
  bbc_validation_print_summary(acc, name, stderr);
  bbc_validation_print_histogram(acc, stderr);
}

static void expect_no_failures(const bbc_validation *acc) {
  CHECK_INT(bbc_validation_failures(acc), 0);
  CHECK_INT(acc->position_violations, 0);
  CHECK_INT(acc->upper_violations, 0);
  CHECK_INT(acc->lower_violations, 0);
  CHECK_INT(acc->in_discarded, 0);
  CHECK_INT(acc->uncovered, 0);
}

/* Every tuple of the flat mirror, at the default parameters. */
TEST(flat_mirror_every_tuple) {
  bbc_validation acc;
  bbc_validation_reset(&acc);
  oracle_tally t;
  memset(&t, 0, sizeof t);
  validate_scene(TEST_SCENE("flat-mirror.gltf"), BBC_CHAIN_R, 1,
                 (uint32_t)harness_scale(2000, 10000), NULL, &acc, &t);
  report("flat mirror R", &acc);
  CHECK(acc.tuples > 0);
  CHECK(acc.admissible > 1000);
  expect_no_failures(&acc);
  compare_with_oracle("flat mirror R", &acc, &t);
}

/* plane1k: one reflection off a plane with interpolated normals (the paper's Plane). */
TEST(plane1k_reflection) {
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  bbc_validation acc;
  bbc_validation_reset(&acc);
  oracle_tally t;
  memset(&t, 0, sizeof t);
  validate_scene(TEST_SCENE("plane1k.gltf"), BBC_CHAIN_R, harness_scale(12, 1),
                 (uint32_t)harness_scale(200, 420), &p, &acc, &t);
  report("plane1k R", &acc);
  CHECK(acc.admissible > 1000);
  expect_no_failures(&acc);
  compare_with_oracle("plane1k R", &acc, &t);
}

/* pool4k: one refraction through a water surface onto the pool floor. */
TEST(pool4k_refraction) {
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  bbc_validation acc;
  bbc_validation_reset(&acc);
  oracle_tally t;
  memset(&t, 0, sizeof t);
  validate_scene(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, harness_scale(40, 1),
                 (uint32_t)harness_scale(100, 125), &p, &acc, &t);
  report("pool4k T", &acc);
  CHECK(acc.admissible > 1000);
  expect_no_failures(&acc);
  compare_with_oracle("pool4k T", &acc, &t);
}

/* Without remainder variables the linearised square root is no enclosure, and some
 * refracted paths escape their bounds (Fig. 18): the harness must see it. */
TEST(pool4k_without_remainders_violates) {
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  p.no_remainder = 1;
  bbc_validation acc;
  bbc_validation_reset(&acc);
  oracle_tally t;
  memset(&t, 0, sizeof t);
  validate_scene(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, harness_scale(40, 1),
                 (uint32_t)harness_scale(100, 125), &p, &acc, &t);
  report("pool4k T without remainder variables", &acc);
  CHECK(bbc_validation_failures(&acc) > 0);
  CHECK(acc.upper_violations + acc.position_violations > 0);
  /* An upper violation is a ratio below 0, so the minimum must show it. */
  if (acc.upper_violations) CHECK(acc.min_log_ratio < 0);
  CHECK(acc.first_failure.kinds != 0);
  compare_with_oracle("pool4k T without remainder variables", &acc, &t);
}

/* ---- the two tracers, point by point ------------------------------------------------ */

/* The library's tracer (the harness's) and the oracle on the same u1: the same verdict
 * on admissibility, and the same landing point and irradiance where both accept. */
static void compare_tracers(const char *path, bbc_chain chain, long stride, uint32_t samples,
                            long *compared, long *verdicts) {
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", path);
    return;
  }
  long index = 0, disagreements = 0;
  double worst_uk = 0, worst_e = 0;
  for (uint32_t i = 0; i < scene->triangle_count; i++) {
    if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
    for (uint32_t k = 0; k < scene->triangle_count; k++) {
      if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
      if (index++ % stride) continue;
      bbc_tuple tuple = {0, chain, {i, BBC_NO_TRIANGLE}, k};
      bbc_tuple_geometry tg;
      bbc_path_geometry pg;
      if (bbc_tuple_geometry_init(&tg, scene, &tuple) != BBC_OK ||
          bbc_path_geometry_init(&pg, scene, &tuple) != BBC_OK) {
        harness_fail(__FILE__, __LINE__, "geometry of tuple %u/%u", i, k);
        continue;
      }
      for (uint32_t s = 0; s < samples; s++) {
        double u1[2];
        bbc_validation_sample_u1(3, &tuple, s, u1);
        true_path o = trace(&tg, u1[0], u1[1]);
        bbc_specular_path lp;
        if (bbc_specular_path_trace(&pg, u1[0], u1[1], &lp) != BBC_OK) {
          harness_fail(__FILE__, __LINE__, "bbc_specular_path_trace failed");
          continue;
        }
        /* The oracle's refraction side is the bounder's orientation, which for the
         * library's unturned normals means: against them iff the light is in front. */
        int accepted = (lp.flags & BBC_PATH_REJECT) == 0;
        if (accepted && chain == BBC_CHAIN_T) {
          int front = v3_dot(tg.n[0], pg.specular[0].n[0]) > 0;
          accepted = (v3_dot(v3_sub(lp.x1, pg.light), lp.n1) < 0) == front;
        }
        (*verdicts)++;
        if (accepted != o.valid) {
          if (disagreements++ < 5)
            fprintf(stderr,
                    "%s: tuple %u/%u u1=(%.17g, %.17g): library %d (flags %#x), oracle %d\n", path,
                    i, k, u1[0], u1[1], accepted, lp.flags, o.valid);
          continue;
        }
        if (!accepted) continue;
        (*compared)++;
        worst_uk = fmax(worst_uk, fmax(fabs(lp.uk[0] - o.uk), fabs(lp.uk[1] - o.vk)));
        worst_e = fmax(worst_e, fabs(lp.irradiance / o.irradiance - 1));
      }
    }
  }
  fprintf(stderr,
          "%s: %ld verdicts, %ld disagreements; worst |du_k| %.3g, worst relative dE %.3g\n", path,
          *verdicts, disagreements, worst_uk, worst_e);
  CHECK_INT(disagreements, 0);
  CHECK(worst_uk < 1e-9);
  CHECK(worst_e < 1e-9);
  bbc_scene_free(scene);
}

TEST(tracers_agree) {
  long compared = 0, verdicts = 0;
  compare_tracers(TEST_SCENE("flat-mirror.gltf"), BBC_CHAIN_R, 1, 50, &compared, &verdicts);
  compare_tracers(TEST_SCENE("plane1k.gltf"), BBC_CHAIN_R, 97, 20, &compared, &verdicts);
  compare_tracers(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, 211, 20, &compared, &verdicts);
  fprintf(stderr, "tracers agree on %ld admissible paths\n", compared);
  CHECK(compared >= 300);
}

/* ---- the accumulator itself ----------------------------------------------------------- */

/* Splitting the tuples over two accumulators and merging gives what one accumulator
 * fed everything gives, as per-thread accumulators rely on. */
TEST(merge_matches_one_accumulator) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("pool4k.gltf"), NULL) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  p.no_remainder = 1; /* so that failures, and first_failure, take part too */
  bbc_validation all, part[2];
  bbc_validation_reset(&all);
  bbc_validation_reset(&part[0]);
  bbc_validation_reset(&part[1]);
  long index = 0, used = 0;
  for (uint32_t i = 0; i < scene->triangle_count && used < 150; i++) {
    if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
    for (uint32_t k = 0; k < scene->triangle_count && used < 150; k++) {
      if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
      if (index++ % 53) continue;
      bbc_tuple tuple = {0, BBC_CHAIN_T, {i, BBC_NO_TRIANGLE}, k};
      CHECK(bbc_validate_tuple(b, scene, &tuple, &p, 60, 5, &all) == BBC_OK);
      /* The first half of the tuples to one part, the rest to the other, so merging
       * part 1 into part 0 keeps the order of `all`. */
      CHECK(bbc_validate_tuple(b, scene, &tuple, &p, 60, 5, &part[used >= 75]) == BBC_OK);
      used++;
    }
  }
  bbc_validation merged = part[0];
  bbc_validation_merge(&merged, &part[1]);
  CHECK(all.admissible > 0);
  CHECK_INT(merged.tuples, all.tuples);
  CHECK_INT(merged.samples, all.samples);
  CHECK_INT(merged.admissible, all.admissible);
  CHECK_INT(merged.position_violations, all.position_violations);
  CHECK_INT(merged.upper_violations, all.upper_violations);
  CHECK_INT(merged.lower_violations, all.lower_violations);
  CHECK_INT(merged.failing, all.failing);
  CHECK_INT(merged.unbounded, all.unbounded);
  CHECK_INT(merged.ratio_count, all.ratio_count);
  CHECK_INT(merged.underflow, all.underflow);
  CHECK_INT(merged.overflow, all.overflow);
  CHECK(memcmp(merged.bins, all.bins, sizeof all.bins) == 0);
  CHECK(merged.min_log_ratio == all.min_log_ratio);
  CHECK(merged.max_log_ratio == all.max_log_ratio);
  CHECK_NEAR(merged.sum_log_ratio, all.sum_log_ratio, 1e-9 * fabs(all.sum_log_ratio) + 1e-12);
  CHECK(memcmp(&merged.first_failure, &all.first_failure, sizeof all.first_failure) == 0);
  /* Merging into an empty accumulator copies. */
  bbc_validation empty;
  bbc_validation_reset(&empty);
  bbc_validation_merge(&empty, &all);
  CHECK(memcmp(&empty, &all, sizeof all) == 0);
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}

/* Quantiles at bin resolution on a hand-made histogram. */
TEST(quantiles_by_hand) {
  bbc_validation acc;
  bbc_validation_reset(&acc);
  CHECK(isnan(bbc_validation_log_ratio_quantile(&acc, 0.5)));
  acc.ratio_count = 100;
  acc.underflow = 1;
  acc.bins[100] = 97; /* [0.00, 0.01) */
  acc.bins[350] = 1;  /* [2.50, 2.51) */
  acc.overflow = 1;
  acc.min_log_ratio = -3;
  acc.max_log_ratio = 7.5;
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.0), -3, 0);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.01), -3, 0);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.02), 0.005, 1e-12);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.5), 0.005, 1e-12);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.98), 0.005, 1e-12);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 0.99), 2.505, 1e-12);
  CHECK_NEAR(bbc_validation_log_ratio_quantile(&acc, 1.0), 7.5, 0);
  CHECK(isnan(bbc_validation_log_ratio_quantile(&acc, 1.5)));
  CHECK(isnan(bbc_validation_log_ratio_quantile(&acc, NAN)));
  CHECK(isnan(bbc_validation_log_ratio_quantile(NULL, 0.5)));
}

/* Reads a whole temporary stream back into a string (freed by the caller). */
static char *slurp(FILE *f) {
  long n = ftell(f);
  rewind(f);
  char *text = calloc((size_t)n + 1, 1);
  if (text && fread(text, 1, (size_t)n, f) != (size_t)n) text[0] = 0;
  return text;
}

/* The printers on an empty and on a real accumulator: the fields are there, JSON has
 * every bin and no bare NaN or inf, and a rare bin still gets a bar. */
TEST(printers) {
  bbc_validation acc;
  bbc_validation_reset(&acc);
  FILE *f = tmpfile();
  REQUIRE(f != NULL);
  CHECK(bbc_validation_write_json(&acc, f) == BBC_OK);
  char *text = slurp(f);
  CHECK_STR_CONTAINS(text, "\"median\":null");
  CHECK_STR_CONTAINS(text, "\"first_failure\":null");
  CHECK_STR_CONTAINS(text, "\"log10_min\":-1,\"bin_width\":0.01,");
  free(text);
  fclose(f);

  acc.tuples = 2, acc.samples = 10, acc.admissible = 8, acc.ratio_count = 8;
  acc.bins[110] = 7;
  acc.bins[90] = 1; /* one path 0.1 decades above its bound */
  acc.upper_violations = 1, acc.failing = 1;
  acc.first_failure.tuple = (bbc_tuple){0, BBC_CHAIN_T, {4, BBC_NO_TRIANGLE}, 9};
  acc.first_failure.kinds = BBC_VALIDATION_UPPER;
  acc.min_log_ratio = -0.095, acc.max_log_ratio = 0.105, acc.sum_log_ratio = 0.6;
  f = tmpfile();
  REQUIRE(f != NULL);
  CHECK(bbc_validation_print_summary(&acc, "demo", f) == BBC_OK);
  CHECK(bbc_validation_print_histogram(&acc, f) == BBC_OK);
  CHECK(bbc_validation_write_json(&acc, f) == BBC_OK);
  text = slurp(f);
  fputs(text, stderr);
  fputc('\n', stderr);
  CHECK_STR_CONTAINS(text, "demo: 2 tuples, 10 samples, 8 admissible paths");
  CHECK_STR_CONTAINS(text, "1 upper");
  CHECK_STR_CONTAINS(text, "median 0.105");
  CHECK_STR_CONTAINS(text, "[-0.10, -0.09)              1 ########\n");
  CHECK_STR_CONTAINS(text, "[0.10, 0.11)                7 #####");
  CHECK_STR_CONTAINS(text, "\"median\":0.105,\"p99\":0.105}");
  CHECK_STR_CONTAINS(text, "\"chain\":\"T\",\"caster\":4,\"receiver\":9");
  const char *counts = text ? strstr(text, "\"counts\":[") : NULL;
  CHECK(counts != NULL);
  if (counts) {
    long commas = 0;
    for (const char *c = counts; *c && *c != ']'; c++) commas += *c == ',';
    CHECK_INT(commas, BBC_VALIDATION_BINS - 1);
  }
  CHECK(text && !strstr(text, "nan") && !strstr(text, "inf"));
  free(text);
  fclose(f);
}

TEST(invalid_arguments) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  bbc_validation acc, before;
  bbc_validation_reset(&acc);
  bbc_tuple tuple = {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 0};
  for (uint32_t k = 0; k < scene->triangle_count; k++)
    if (scene->meshes[scene->triangle_mesh[k]].role == BBC_ROLE_RECEIVER) tuple.receiver = k;
  CHECK(bbc_validate_tuple(b, scene, &tuple, NULL, 10, 1, &acc) == BBC_OK);
  before = acc;
  bbc_tuple rr = {0, BBC_CHAIN_RR, {0, 0}, tuple.receiver};
  bbc_tuple far = {0, BBC_CHAIN_R, {scene->triangle_count, BBC_NO_TRIANGLE}, tuple.receiver};
  CHECK(bbc_validate_tuple(NULL, scene, &tuple, NULL, 10, 1, &acc) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_validate_tuple(b, NULL, &tuple, NULL, 10, 1, &acc) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_validate_tuple(b, scene, NULL, NULL, 10, 1, &acc) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_validate_tuple(b, scene, &tuple, NULL, 10, 1, NULL) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_validate_tuple(b, scene, &rr, NULL, 10, 1, &acc) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_validate_tuple(b, scene, &far, NULL, 10, 1, &acc) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(memcmp(&acc, &before, sizeof acc) == 0);
  CHECK(bbc_validation_print_summary(NULL, NULL, stderr) == BBC_ERR_INVALID_ARGUMENT);
  bbc_validation_merge(NULL, &acc);
  bbc_validation_merge(&acc, NULL);
  bbc_validation_reset(NULL);
  CHECK_INT(bbc_validation_failures(NULL), 0);
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}
