/* Single-scattering bounds against true paths: an exact tracer written here (normalised
 * reflection and refraction, forward-mode derivatives for the Jacobian, independent of
 * the polynomial forms) samples u1, and every valid path must lie inside the position
 * bound and between the irradiance bounds of the piece containing it. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "bbc/bounds.h"
#include "harness.h"
#include "rng_internal.h"
#include "vec_internal.h"

#include "exact_tracer_oracle.h"

/* ---- bounds vs the oracle ---------------------------------------------------------- */

typedef struct leaves {
  bbc_piece *items;
  size_t count, capacity;
} leaves;

static int collect(void *user, const bbc_piece *piece) {
  leaves *l = user;
  if (l->count == l->capacity) {
    l->capacity = l->capacity ? 2 * l->capacity : 64;
    l->items = realloc(l->items, l->capacity * sizeof *l->items);
  }
  l->items[l->count++] = *piece;
  return 0;
}

typedef struct tally {
  long samples, valid, violations, lower_violations, in_discarded, uncovered;
  long finite, unbounded;
  double log_ratio_sum;
  double *log_ratios; /* for percentiles */
  long log_count, log_capacity;
  double worst_log_ratio;
} tally;

static void record_ratio(tally *t, double lr) {
  if (t->log_count == t->log_capacity) {
    t->log_capacity = t->log_capacity ? 2 * t->log_capacity : 4096;
    t->log_ratios = realloc(t->log_ratios, t->log_capacity * sizeof(double));
  }
  t->log_ratios[t->log_count++] = lr;
}

/* Bounds one tuple and checks samples true paths against its leaves. */
static void check_tuple(bbc_bounder *b, const bbc_tuple_geometry *g, const bbc_bound_params *p,
                        long samples, uint64_t seed, tally *t) {
  leaves l = {NULL, 0, 0};
  bbc_result r = bbc_bound_tuple(b, g, p, collect, &l, NULL);
  if (r != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "bbc_bound_tuple: %d", (int)r);
    return;
  }
  for (long i = 0; i < samples; i++) {
    bbc_rng rng = bbc_rng_make(seed, (uint64_t)i, 0);
    double a = bbc_rng_next(&rng), c = bbc_rng_next(&rng);
    if (a + c > 1) {
      a = 1 - a;
      c = 1 - c;
    }
    t->samples++;
    true_path path = trace(g, a, c);
    if (!path.valid) continue;
    t->valid++;
    const bbc_piece *hit = NULL;
    for (size_t k = 0; k < l.count; k++) {
      const bbc_piece *q = &l.items[k];
      if (a >= q->u_lo && a <= q->u_hi && c >= q->v_lo && c <= q->v_hi) {
        hit = q;
        if (q->status == BBC_PIECE_KEPT) break;
      }
    }
    if (!hit) {
      t->uncovered++;
      continue;
    }
    if (hit->status == BBC_PIECE_DISCARDED) {
      if (t->in_discarded++ < 5)
        fprintf(stderr, "valid path at u1=(%.17g, %.17g) in a discarded piece\n", a, c);
      continue;
    }
    int inside = bbc_piece_position_contains(hit, path.uk, path.vk);
    int upper = path.irradiance <= hit->e_hi;
    int lower = path.irradiance >= hit->e_lo;
    if (!inside || !upper) {
      if (t->violations++ < 5)
        fprintf(stderr,
                "violation at u1=(%.17g, %.17g): uk=(%.17g, %.17g) box [%.17g,%.17g]x[%.17g,%.17g]"
                " E=%.17g bound [%.17g, %.17g]\n",
                a, c, path.uk, path.vk, hit->uk_lo, hit->uk_hi, hit->vk_lo, hit->vk_hi,
                path.irradiance, hit->e_lo, hit->e_hi);
    }
    if (!lower) t->lower_violations++;
    if (isfinite(hit->e_hi)) {
      double lr = log10(hit->e_hi / path.irradiance);
      t->finite++;
      t->log_ratio_sum += lr;
      record_ratio(t, lr);
      if (lr < t->worst_log_ratio) t->worst_log_ratio = lr;
    } else {
      t->unbounded++;
    }
  }
  free(l.items);
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void report(const char *name, tally *t) {
  double median = NAN, p99 = NAN;
  if (t->log_count) {
    qsort(t->log_ratios, t->log_count, sizeof(double), compare_double);
    median = t->log_ratios[t->log_count / 2];
    p99 = t->log_ratios[(long)(0.99 * (t->log_count - 1))];
  }
  fprintf(stderr,
          "%s: %ld samples, %ld valid paths, %ld violations (%ld of the lower bound), "
          "%ld in discarded pieces, %ld uncovered; log10(bound/true) median %.3f, p99 %.3f, "
          "min %.3g; %ld unbounded\n",
          name, t->samples, t->valid, t->violations, t->lower_violations, t->in_discarded,
          t->uncovered, median, p99, t->log_count ? t->log_ratios[0] : NAN, t->unbounded);
  free(t->log_ratios);
  t->log_ratios = NULL;
}

static bbc_vec3 random_unit(bbc_rng *rng) {
  double z = 2 * bbc_rng_next(rng) - 1, phi = 2 * 3.14159265358979 * bbc_rng_next(rng);
  double s = sqrt(fmax(0, 1 - z * z));
  return v3(s * cos(phi), s * sin(phi), z);
}

/* A random tuple: T1 near the origin facing roughly +y with perturbed vertex normals, a
 * light above it, and a receiver triangle that the reflected or refracted light can
 * reach (below for refraction, above for reflection). */
static void random_tuple(bbc_rng *rng, int refract, bbc_tuple_geometry *g) {
  memset(g, 0, sizeof *g);
  for (int i = 0; i < 3; i++) {
    double ang = 2 * 3.14159265358979 * (i / 3.0 + 0.2 * bbc_rng_next(rng));
    double rad = 0.3 + 0.7 * bbc_rng_next(rng);
    g->p[i] = v3(rad * cos(ang), 0.2 * (bbc_rng_next(rng) - 0.5), rad * sin(ang));
  }
  bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0])));
  if (ng.y < 0) {
    bbc_vec3 tmp = g->p[1];
    g->p[1] = g->p[2];
    g->p[2] = tmp;
    ng = v3_neg(ng);
  }
  double tilt = 0.3 * bbc_rng_next(rng);
  for (int i = 0; i < 3; i++) g->n[i] = v3_normalize(v3_madd(ng, random_unit(rng), tilt));
  g->light =
      v3(4 * (bbc_rng_next(rng) - 0.5), 1.5 + 3 * bbc_rng_next(rng), 4 * (bbc_rng_next(rng) - 0.5));
  g->refract = refract;
  g->eta = 1.0 / (1.2 + 0.6 * bbc_rng_next(rng));
  double y = refract ? -(0.5 + 2 * bbc_rng_next(rng)) : 1.0 + 2 * bbc_rng_next(rng);
  /* Aim the receiver at where the central path goes, give or take. */
  bbc_vec3 centre = v3_scale(v3_add(g->p[0], v3_add(g->p[1], g->p[2])), 1.0 / 3);
  bbc_vec3 d = v3_normalize(v3_sub(centre, g->light));
  bbc_vec3 out;
  if (!refract) {
    out = v3_madd(d, ng, -2 * v3_dot(d, ng));
  } else {
    double c = -v3_dot(d, ng), k = 1 - g->eta * g->eta * (1 - c * c);
    out = v3_add(v3_scale(d, g->eta), v3_scale(ng, g->eta * c - sqrt(k)));
  }
  double t = (y - centre.y) / out.y;
  if (!(t > 0)) t = 1;
  bbc_vec3 target = v3_madd(centre, out, t);
  double size = 0.5 + 3 * bbc_rng_next(rng);
  for (int i = 0; i < 3; i++) {
    double ang = 2 * 3.14159265358979 * (i / 3.0 + 0.1 * bbc_rng_next(rng));
    g->r[i] = v3(target.x + size * cos(ang) + 0.5 * (bbc_rng_next(rng) - 0.5),
                 y + 0.3 * (bbc_rng_next(rng) - 0.5), target.z + size * sin(ang));
  }
}

static void random_tuples(int refract, bbc_jacobian_form form, const char *name) {
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  p.max_level = 6;
  p.jacobian = form;
  tally t;
  memset(&t, 0, sizeof t);
  long tuples = harness_scale(60, 500), samples = harness_scale(2000, 2000);
  for (long i = 0; i < tuples; i++) {
    bbc_rng rng = bbc_rng_make(1234 + refract, (uint64_t)i, 1);
    bbc_tuple_geometry g;
    random_tuple(&rng, refract, &g);
    check_tuple(b, &g, &p, samples, 99 + i, &t);
  }
  report(name, &t);
  CHECK(t.valid > t.samples / 20);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.lower_violations, 0);
  CHECK_INT(t.in_discarded, 0);
  CHECK_INT(t.uncovered, 0);
  bbc_bounder_free(b);
}

TEST(random_reflection_tuples) {
  random_tuples(0, BBC_JACOBIAN_DETERMINANT, "random R");
}
TEST(random_refraction_tuples) {
  random_tuples(1, BBC_JACOBIAN_DETERMINANT, "random T");
}
TEST(random_reflection_tuples_quotient_form) {
  random_tuples(0, BBC_JACOBIAN_QUOTIENT, "random R (quotient form)");
}
TEST(random_refraction_tuples_quotient_form) {
  random_tuples(1, BBC_JACOBIAN_QUOTIENT, "random T (quotient form)");
}

/* Every (light, caster triangle, receiver triangle) tuple of a scene, every stride-th one
 * checked with `samples` true paths. */
static void scene_tuples(const char *path, bbc_chain chain, long stride, long samples,
                         const bbc_bound_params *p, tally *t) {
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", path);
    return;
  }
  bbc_bounder *b = NULL;
  bbc_bounder_create(&b);
  long index = 0;
  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    for (uint32_t i = 0; i < scene->triangle_count; i++) {
      if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
      for (uint32_t k = 0; k < scene->triangle_count; k++) {
        if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
        if (index++ % stride) continue;
        bbc_tuple tuple = {l, chain, {i, BBC_NO_TRIANGLE}, k};
        bbc_tuple_geometry g;
        if (bbc_tuple_geometry_init(&g, scene, &tuple) != BBC_OK) {
          harness_fail(__FILE__, __LINE__, "geometry of tuple %u/%u", i, k);
          continue;
        }
        check_tuple(b, &g, p, samples, 7 + index, t);
      }
    }
  }
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}

static void scene_test(const char *path, bbc_chain chain, int no_remainder, long ci_stride,
                       long ci_samples, long full_samples, tally *t) {
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  p.no_remainder = no_remainder;
  memset(t, 0, sizeof *t);
  scene_tuples(path, chain, harness_scale(ci_stride, 1), harness_scale(ci_samples, full_samples),
               &p, t);
}

/* plane1k: single reflection off a plane with interpolated normals (the paper's Plane). */
TEST(plane1k_reflection) {
  tally t;
  scene_test(TEST_SCENE("plane1k.gltf"), BBC_CHAIN_R, 0, 12, 200, 420, &t);
  report("plane1k R", &t);
  CHECK(t.valid > 1000);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.lower_violations, 0);
  CHECK_INT(t.in_discarded, 0);
  CHECK_INT(t.uncovered, 0);
}

/* pool4k: single refraction through a water surface onto the pool floor. */
TEST(pool4k_refraction) {
  tally t;
  scene_test(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, 0, 40, 100, 125, &t);
  report("pool4k T", &t);
  CHECK(t.valid > 1000);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.lower_violations, 0);
  CHECK_INT(t.in_discarded, 0);
  CHECK_INT(t.uncovered, 0);
}

/* Without remainder variables the linearised square root is not an enclosure and
 * refraction bounds fail for some paths (the paper's Fig. 18). */
TEST(pool4k_without_remainders_violates) {
  tally t;
  scene_test(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, 1, 40, 100, 125, &t);
  report("pool4k T without remainder variables", &t);
  CHECK(t.violations > 0);
}

/* The flat mirror: the oracle's irradiance must be exactly that of the mirrored light,
 * I cos(theta) / r^2 (an analytic check of the harness itself), and the bounds hold. */
TEST(flat_mirror_analytic) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  tally t;
  memset(&t, 0, sizeof t);
  long checked = 0;
  double worst = 0;
  for (uint32_t i = 0; i < scene->triangle_count; i++) {
    if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
    for (uint32_t k = 0; k < scene->triangle_count; k++) {
      if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
      bbc_tuple tuple = {0, BBC_CHAIN_R, {i, BBC_NO_TRIANGLE}, k};
      bbc_tuple_geometry g;
      REQUIRE(bbc_tuple_geometry_init(&g, scene, &tuple) == BBC_OK);
      /* The mirror image of the light in T1's plane. */
      bbc_vec3 n = v3_normalize(v3_cross(v3_sub(g.p[1], g.p[0]), v3_sub(g.p[2], g.p[0])));
      bbc_vec3 image = v3_madd(g.light, n, -2 * v3_dot(v3_sub(g.light, g.p[0]), n));
      bbc_vec3 nk = v3_normalize(v3_cross(v3_sub(g.r[1], g.r[0]), v3_sub(g.r[2], g.r[0])));
      for (int s = 0; s < 2000; s++) {
        bbc_rng rng = bbc_rng_make(5, s, i * 64 + k);
        double a = bbc_rng_next(&rng), c = bbc_rng_next(&rng);
        if (a + c > 1) {
          a = 1 - a;
          c = 1 - c;
        }
        true_path path = trace(&g, a, c);
        if (!path.valid) continue;
        bbc_vec3 xk = v3_add(g.r[0], v3_add(v3_scale(v3_sub(g.r[1], g.r[0]), path.uk),
                                            v3_scale(v3_sub(g.r[2], g.r[0]), path.vk)));
        bbc_vec3 to = v3_sub(image, xk);
        double r2 = v3_dot(to, to);
        double analytic = fabs(v3_dot(to, nk)) / sqrt(r2) / r2;
        worst = fmax(worst, fabs(path.irradiance / analytic - 1));
        checked++;
      }
      check_tuple(b, &g, NULL, 2000, 11 + i * 64 + k, &t);
    }
  }
  fprintf(stderr, "flat mirror: %ld paths, worst relative deviation from the mirrored light %.3g\n",
          checked, worst);
  report("flat mirror R", &t);
  CHECK(checked > 1000);
  CHECK(worst < 1e-12);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.lower_violations, 0);
  CHECK_INT(t.in_discarded, 0);
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}

/* The level limit: negative means the root piece only (bbc-precompute --max-level 0),
 * 0 the default of 10, else that level; kept and discarded leaves never go deeper. */
TEST(max_level) {
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  static const int asked[4] = {-1, 1, 3, 0}, deepest[4] = {0, 1, 3, 10};
  for (int k = 0; k < 4; k++) {
    bbc_rng rng = bbc_rng_make(77, 0, 1);
    bbc_tuple_geometry g;
    random_tuple(&rng, 0, &g);
    bbc_bound_params p;
    memset(&p, 0, sizeof p);
    p.max_level = asked[k];
    p.sigma = 1e-12; /* never stop on area: the level limit decides */
    p.alpha = 1.0;
    leaves l = {NULL, 0, 0};
    REQUIRE(bbc_bound_tuple(b, &g, &p, collect, &l, NULL) == BBC_OK);
    int top = 0;
    for (size_t i = 0; i < l.count; i++)
      if (l.items[i].level > top) top = l.items[i].level;
    CHECK(l.count > 0);
    CHECK(top <= deepest[k]);
    if (k < 3) CHECK_INT(top, deepest[k]);
    free(l.items);
  }
  bbc_bounder_free(b);
}
