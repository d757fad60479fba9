/* Double-scattering bounds (RR, TT) against true paths: the validation harness
 * (validate.h) traces sampled u1 with the exact tracer of specular_path.c (normalised
 * reflection and refraction, dual-number derivatives, nothing shared with the rational
 * forms of chain_double.c) and every admissible path must lie in the position bound and
 * between the irradiance bounds of the piece that holds it. Zero violations allowed. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "bbc/bounds.h"
#include "bbc/precompute.h"
#include "bbc/specular_path.h"
#include "bbc/validate.h"
#include "chain_fixtures.h"
#include "chain_internal.h"
#include "exact_tracer_oracle.h"
#include "harness.h"

/* Whether any of a coarse grid of paths through T1 is admissible: in the CI variant only
 * such tuples are validated (most candidate tuples of a ball hold no path at all). */
static int holds_paths(const bbc_scene *scene, const bbc_tuple *tuple) {
  bbc_path_geometry g;
  if (bbc_path_geometry_init(&g, scene, tuple) != BBC_OK) return 0;
  const int n = 24;
  for (int i = 0; i < n; i++)
    for (int j = 0; i + j < n; j++) {
      bbc_specular_path p;
      bbc_specular_path_trace(&g, (i + 0.3) / n, (j + 0.3) / n, &p);
      if (!(p.flags & BBC_PATH_REJECT)) return 1;
    }
  return 0;
}

typedef struct scene_case {
  const char *path;
  uint32_t chains;
  int max_level;
  /* CI: up to ci_tuples tuples holding paths among every ci_stride-th candidate, with
   * ci_samples samples each; BBC_TEST_FULL=1: every full_stride-th candidate. */
  long ci_stride, ci_tuples, ci_samples;
  long full_stride, full_samples;
  int area; /* the scene's emitters are the lights (bbc_tuples_find_area) */
} scene_case;

/* Validates the scene's candidate tuples of the chain types and returns the totals. */
static void validate_scene(const scene_case *c, const char *name, bbc_validation *acc) {
  bbc_validation_reset(acc);
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, c->path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", c->path);
    return;
  }
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE((c->area ? bbc_tuples_find_area : bbc_tuples_find)(scene, c->chains, &tuples, &count) ==
          BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params p;
  memset(&p, 0, sizeof p);
  p.max_level = c->max_level;
  const int full = harness_scale(0, 1) == 1;
  long validated = 0;
  for (size_t i = 0; i < count; i++) {
    if (full ? (long)i % c->full_stride != 0
             : (long)i % c->ci_stride != 0 || validated >= c->ci_tuples ||
                   !holds_paths(scene, &tuples[i]))
      continue;
    validated++;
    bbc_result r = bbc_validate_tuple(b, scene, &tuples[i], &p,
                                      (uint32_t)(full ? c->full_samples : c->ci_samples), 11, acc);
    if (r != BBC_OK) harness_fail(__FILE__, __LINE__, "tuple %zu: %s", i, bbc_result_string(r));
  }
  fprintf(stderr, "%s (%zu candidates, %ld validated): ", name, count, validated);
  bbc_validation_print_summary(acc, NULL, stderr);
  fputc('\n', stderr);
  if (acc->failing) {
    const bbc_validation_failure *f = &acc->first_failure;
    fprintf(stderr, "first failure: u1 = (%.17g, %.17g), uk = (%.17g, %.17g), E = %.17g\n",
            f->u1[0], f->u1[1], f->uk[0], f->uk[1], f->irradiance);
  }
  bbc_bounder_free(b);
  free(tuples);
  bbc_scene_free(scene);
}

static void expect_valid(const bbc_validation *acc, uint64_t min_admissible) {
  CHECK(acc->admissible >= min_admissible);
  CHECK_INT(acc->position_violations, 0);
  CHECK_INT(acc->upper_violations, 0);
  CHECK_INT(acc->lower_violations, 0);
  CHECK_INT(acc->in_discarded, 0);
  CHECK_INT(acc->uncovered, 0);
}

#define RR (1u << BBC_CHAIN_RR)
#define TT (1u << BBC_CHAIN_TT)

/* Two flat mirrors in a corner: double reflection with flat normals; every path's
 * irradiance is that of the light's double mirror image, so the bounds must be finite
 * and tight. */
TEST(two_mirrors_rr) {
  const scene_case c = {TEST_SCENE("two-mirrors.gltf"), RR, 6, 1, 50, 4000, 1, 40000, 0};
  bbc_validation acc;
  validate_scene(&c, "two-mirrors RR", &acc);
  expect_valid(&acc, 1000);
  CHECK(acc.ratio_count > acc.admissible / 2);
  if (acc.ratio_count) CHECK(bbc_validation_log_ratio_quantile(&acc, 0.5) < 0.5);
}

/* The same corner with bumpy mirrors: double reflection with interpolated normals. */
TEST(wavy_corner_rr) {
  const scene_case c = {TEST_SCENE("wavy-corner.gltf"), RR, 5, 3, 30, 3000, 1, 20000, 0};
  bbc_validation acc;
  validate_scene(&c, "wavy-corner RR", &acc);
  expect_valid(&acc, 1000);
  CHECK(acc.ratio_count > 0);
}

/* Glass ball with interpolated normals: double refraction (the paper's Ball). */
TEST(glass_sphere_tt) {
  const scene_case c = {TEST_SCENE("glass-sphere.gltf"), TT, 4, 7, 25, 3000, 9, 20000, 0};
  bbc_validation acc;
  validate_scene(&c, "glass-sphere TT", &acc);
  expect_valid(&acc, 2000);
  CHECK(acc.ratio_count > 0);
}

TEST(glass_slab_tt) {
  const scene_case c = {TEST_SCENE("glass-slab.gltf"), TT, 4, 7, 25, 3000, 11, 20000, 0};
  bbc_validation acc;
  validate_scene(&c, "glass-slab TT", &acc);
  expect_valid(&acc, 1000);
}

/* The closed glass box with flat parallel faces: the light it transmits twice is smooth
 * and finite everywhere, so at the paper's level 3 every admissible path must lie in a
 * piece with a finite irradiance bound. (Control: with the slope of sqrt(beta) enclosed by
 * a constant interval, 44 of the 5,134 admissible paths here were in unbounded pieces.) */
TEST(glass_box_tt_bounded) {
  const scene_case c = {TEST_SCENE("glass-box.gltf"), TT, 3, 1, 100, 3000, 1, 30000, 0};
  bbc_validation acc;
  validate_scene(&c, "glass-box TT", &acc);
  expect_valid(&acc, 1000);
  CHECK_INT(acc.unbounded, 0);
}

/* A ball at its level: valid, and fewer than 5 % of its admissible paths in pieces
 * whose irradiance bound is unbounded (such pieces are split on, bounder.c). */
static void expect_ball(const scene_case *c, const char *name, uint64_t min_admissible) {
  bbc_validation acc;
  validate_scene(c, name, &acc);
  expect_valid(&acc, min_admissible);
  CHECK(acc.unbounded * 20 < acc.admissible);
}

/* The paper's set-ups, generated (tests/make_test_scenes.sh). Paths in unbounded pieces
 * on ball80, 1.3 % here (CI); measured on the research meshes these stand in for: ball80
 * 1.6 % (CI), 3.8 % with BBC_TEST_FULL (7.5 % and 15.8 % when such pieces stopped on area
 * and level like the others); ball320 3.2 % (CI), 3.8 % (8.5 % before); ball1280 3.5 %
 * and ball5120 4.1 % with BBC_TEST_FULL. */
TEST(ball80_tt) {
  const scene_case c = {TEST_SCENE("ball80.gltf"), TT, 4, 1, 12, 3000, 1, 2000, 0};
  expect_ball(&c, "ball80 TT", 1000);
}

typedef struct level_count {
  int top[2]; /* deepest kept leaf: finite, unbounded irradiance bound */
  int kept;
} level_count;

static int collect_level(void *user, const bbc_piece *piece) {
  level_count *c = user;
  if (piece->status != BBC_PIECE_KEPT) return 0;
  int *d = &c->top[isfinite(piece->e_hi) ? 0 : 1];
  if (piece->level > *d) *d = piece->level;
  c->kept++;
  return 0;
}

/* The level limit of two bounces: a piece whose irradiance bound is unbounded may be
 * split once more, and no deeper, and only unbounded pieces reach that level; the
 * root-only limit keeps one piece (without the position refinement, tested below). */
TEST(unbounded_pieces_one_level_deeper) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("ball80.gltf"), NULL) == BBC_OK);
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE(bbc_tuples_find(scene, TT, &tuples, &count) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  int top[2] = {-1, -1}, deeper = 0;
  for (size_t i = 0; i < count; i += 2) {
    bbc_tuple_geometry g;
    REQUIRE(bbc_tuple_geometry_init(&g, scene, &tuples[i]) == BBC_OK);
    bbc_bound_params p;
    memset(&p, 0, sizeof p);
    p.max_level = 2;
    p.position_levels = -1;
    level_count c = {{-1, -1}, 0};
    REQUIRE(bbc_bound_tuple(b, &g, &p, collect_level, &c, NULL) == BBC_OK);
    for (int j = 0; j < 2; j++)
      if (c.top[j] > top[j]) top[j] = c.top[j];
    p.max_level = -1; /* the root only */
    level_count root = {{-1, -1}, 0};
    REQUIRE(bbc_bound_tuple(b, &g, &p, collect_level, &root, NULL) == BBC_OK);
    CHECK(root.kept <= 1);
    /* Domain initialisation may start a tuple below level 0; where it starts at 0,
     * level 3 is reached by the rule alone. */
    if (root.kept == 1 && root.top[0] <= 0 && root.top[1] <= 0)
      deeper += c.top[0] > 2 || c.top[1] > 2;
  }
  CHECK(top[0] <= 3 && top[1] <= 3);
  CHECK(deeper > 0); /* the rule is used here */
  bbc_bounder_free(b);
  free(tuples);
  bbc_scene_free(scene);
}

typedef struct leaf_list {
  bbc_piece items[4096];
  int count, overflow;
} leaf_list;

static int collect_leaf(void *user, const bbc_piece *piece) {
  leaf_list *l = user;
  if (piece->status != BBC_PIECE_KEPT) return 0;
  if (l->count == (int)(sizeof l->items / sizeof l->items[0])) {
    l->overflow = 1;
    return 0;
  }
  l->items[l->count++] = *piece;
  return 0;
}

static double box_area(const bbc_piece *p) {
  return (p->uk_hi - p->uk_lo) * (p->vk_hi - p->vk_lo);
}

/* The position refinement of two bounces: each leaf it makes lies in a leaf of the
 * subdivision without it, inherits that leaf's irradiance bound exactly, has a position
 * box inside its box, and stops POSITION_LEVELS (4) below the level limit; the boxes
 * shrink (by area, summed over the tuples, to well under half here). Refraction computes
 * each quarter's forms, reflection halves its parent's (bounder.c, refined_store): a
 * scene of each. Validity of the refined leaves' position bounds is the harness's
 * (ball80_tt, wavy_corner_rr and the others bound with the refinement on). */
static void refinement_nests(const char *path, uint32_t chains, size_t stride) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, path, NULL) == BBC_OK);
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE(bbc_tuples_find(scene, chains, &tuples, &count) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  static leaf_list plain, refined;
  double area_plain = 0, area_refined = 0;
  int deepest = 0, outside = 0, bound_changed = 0, box_grew = 0;
  for (size_t i = 0; i < count; i += stride) {
    bbc_tuple_geometry g;
    REQUIRE(bbc_tuple_geometry_init(&g, scene, &tuples[i]) == BBC_OK);
    bbc_bound_params p;
    memset(&p, 0, sizeof p);
    p.max_level = 2;
    p.position_levels = -1;
    plain.count = refined.count = 0;
    REQUIRE(bbc_bound_tuple(b, &g, &p, collect_leaf, &plain, NULL) == BBC_OK);
    p.position_levels = 0; /* the default */
    REQUIRE(bbc_bound_tuple(b, &g, &p, collect_leaf, &refined, NULL) == BBC_OK);
    REQUIRE(!plain.overflow && !refined.overflow);
    for (int k = 0; k < plain.count; k++) area_plain += box_area(&plain.items[k]);
    for (int k = 0; k < refined.count; k++) {
      const bbc_piece *r = &refined.items[k];
      area_refined += box_area(r);
      if (r->level > deepest) deepest = r->level;
      const bbc_piece *home = NULL;
      for (int j = 0; j < plain.count && !home; j++) {
        const bbc_piece *q = &plain.items[j];
        if (r->u_lo >= q->u_lo && r->u_hi <= q->u_hi && r->v_lo >= q->v_lo && r->v_hi <= q->v_hi)
          home = q;
      }
      if (!home) {
        outside++;
        continue;
      }
      bound_changed += r->e_lo != home->e_lo || r->e_hi != home->e_hi;
      box_grew += r->uk_lo < home->uk_lo || r->uk_hi > home->uk_hi || r->vk_lo < home->vk_lo ||
                  r->vk_hi > home->vk_hi;
    }
  }
  fprintf(stderr, "%s: position boxes' area %.4g -> %.4g, deepest leaf %d\n", path, area_plain,
          area_refined, deepest);
  CHECK(outside == 0);
  CHECK(bound_changed == 0);
  CHECK(box_grew == 0);
  CHECK(deepest > 3 && deepest <= 2 + 4); /* used, and no deeper than its limit */
  CHECK(area_refined < 0.5 * area_plain);
  bbc_bounder_free(b);
  free(tuples);
  bbc_scene_free(scene);
}

TEST(position_refinement_nests_in_the_unrefined_leaves) {
  refinement_nests(TEST_SCENE("ball80.gltf"), TT, 3);
}

TEST(position_refinement_nests_with_carried_forms) {
  refinement_nests(TEST_SCENE("wavy-corner.gltf"), RR, 7);
}

TEST(ball320_tt) {
  const scene_case c = {TEST_SCENE("ball320.gltf"), TT, 3, 13, 10, 3000, 3, 8000, 0};
  expect_ball(&c, "ball320 TT", 500);
}

/* The larger balls at the paper's levels (Table 3): BBC_TEST_FULL=1 validates every
 * 4th (ball1280) and 16th (ball5120) candidate, about 10^6 admissible paths each. */
TEST(ball1280_tt) {
  const scene_case c = {TEST_SCENE("ball1280.gltf"), TT, 2, 53, 10, 3000, 4, 8000, 0};
  expect_ball(&c, "ball1280 TT", 500);
}

TEST(ball5120_tt) {
  const scene_case c = {TEST_SCENE("ball5120.gltf"), TT, 1, 211, 10, 3000, 16, 8000, 0};
  expect_ball(&c, "ball5120 TT", 500);
}

TEST(slab10k_tt) {
  const scene_case c = {TEST_SCENE("slab10k.gltf"), TT, 2, 211, 10, 3000, 40, 6000, 0};
  bbc_validation acc;
  validate_scene(&c, "slab10k TT", &acc);
  expect_valid(&acc, 500);
}

/* The diamond: flat normals, ior 2.42 (total internal reflection is common). */
TEST(diamond_tt) {
  const scene_case c = {TEST_SCENE("diamond.gltf"), TT, 4, 13, 12, 3000, 2, 6000, 0};
  bbc_validation acc;
  validate_scene(&c, "diamond TT", &acc);
  expect_valid(&acc, 300);
}

/* Mixed chains on the mirror pool: a flat mirror then the wavy water (interpolated
 * normals) for RT, the water then a flat mirror under it for TR. */
TEST(mirror_pool_rt) {
  const scene_case c = {TEST_SCENE("mirror-pool.gltf"), 1u << BBC_CHAIN_RT, 4, 3, 20, 3000, 1, 20000, 0};
  bbc_validation acc;
  validate_scene(&c, "mirror-pool RT", &acc);
  expect_valid(&acc, 1000);
  CHECK(acc.ratio_count > 0);
}

TEST(mirror_pool_tr) {
  const scene_case c = {TEST_SCENE("mirror-pool.gltf"), 1u << BBC_CHAIN_TR, 4, 3, 20, 3000, 1, 20000, 0};
  bbc_validation acc;
  validate_scene(&c, "mirror-pool TR", &acc);
  expect_valid(&acc, 1000);
  CHECK(acc.ratio_count > 0);
}

/* Area lights (docs/lights.md): the emitter point is two more variables of every form,
 * and each sampled path starts at an emitter point drawn uniformly by area; its value is
 * A_e cos(theta_e) times the point-light irradiance, which the piece holding both u1
 * and the point must bound (validate.c). Emissive squares of side 0.25 replace the
 * point lights of the generated scenes. */
TEST(two_mirrors_area_rr) {
  const scene_case c = {TEST_SCENE("two-mirrors-area.gltf"), RR, 5, 1, 32, 3000, 1, 100000, 1};
  bbc_validation acc;
  validate_scene(&c, "two-mirrors area RR", &acc);
  expect_valid(&acc, 1000);
  /* Flat mirrors: the double image of the emitter, finite everywhere it lands. */
  CHECK(acc.ratio_count > acc.admissible / 2);
}

TEST(mirror_pool_area_rt_tr) {
  const scene_case rt = {TEST_SCENE("mirror-pool-area.gltf"), 1u << BBC_CHAIN_RT, 3, 1, 4, 3000, 1, 20000, 1};
  const scene_case tr = {TEST_SCENE("mirror-pool-area.gltf"), 1u << BBC_CHAIN_TR, 3, 1, 4, 3000, 1, 20000, 1};
  bbc_validation acc;
  validate_scene(&rt, "mirror-pool area RT", &acc);
  expect_valid(&acc, 200);
  validate_scene(&tr, "mirror-pool area TR", &acc);
  expect_valid(&acc, 200);
}

TEST(glass_sphere_area_tt) {
  const scene_case c = {TEST_SCENE("glass-sphere-area.gltf"), TT, 1, 7, 2, 3000, 7, 20000, 1};
  bbc_validation acc;
  validate_scene(&c, "glass-sphere area TT", &acc);
  expect_valid(&acc, 300);
}

/* The bounders' cheap discard (bbc__chain_second_unreachable): a box of T1 it proves to
 * miss T2 holds no ray that meets T2. The oracle is the exact tracer (exact_tracer_oracle.h:
 * normalised reflection and refraction) with T2 as the receiver, at random points of
 * random boxes of every level 0-6 of RR, TT and RT tuples. The control, the same test on
 * the box's centre alone (the rays of one point, as a tracer's sample would be), misses
 * rays from the rest of the box. */
static void second_unreachable_case(const char *file, uint32_t chains, long *boxes, long *proven,
                                    long *hits, long *wrong, long *control_wrong) {
  bbc_scene *s = NULL;
  char path[512];
  snprintf(path, sizeof path, "%s/%s", BBC_TEST_SCENES, file);
  REQUIRE(bbc_scene_load(&s, path, NULL) == BBC_OK);
  bbc_tuple *t = NULL;
  size_t n = 0;
  REQUIRE(bbc_tuples_find(s, chains, &t, &n) == BBC_OK);
  REQUIRE(n > 0);
  const size_t stride = n / 150 + 1;
  for (size_t i = 0; i < n; i += stride) {
    bbc_tuple_geometry g, g1;
    REQUIRE(bbc_tuple_geometry_init(&g, s, &t[i]) == BBC_OK);
    if (g.length != 2) continue;
    g1 = g;
    g1.length = 1;
    for (int k = 0; k < 3; k++) g1.r[k] = g.p2[k]; /* T2 as the receiver */
    for (int level = 0; level <= 6; level++) {
      const int cells = 1 << level;
      for (int j = 0; j < 8; j++) {
        const int cu = (int)(rnd() * cells), cv = (int)(rnd() * cells);
        if (cu + cv >= cells) continue;
        const double w = 1.0 / cells, box[4] = {cu * w, (cu + 1) * w, cv * w, (cv + 1) * w};
        const double uc = (cu + 0.5) * w, vc = (cv + 0.5) * w;
        const double centre[4] = {uc, uc, vc, vc};
        const int is_proven = bbc__chain_second_unreachable(&g, box);
        const int control = bbc__chain_second_unreachable(&g, centre);
        (*boxes)++;
        *proven += is_proven;
        for (int m = 0; m < 32; m++) {
          const double u = box[0] + rnd() * w, v = box[2] + rnd() * w;
          if (u + v > 1 || !trace(&g1, u, v).valid) continue;
          (*hits)++;
          *wrong += is_proven;
          *control_wrong += control;
        }
      }
    }
  }
  free(t);
  bbc_scene_free(s);
}

TEST(second_unreachable_holds_no_path) {
  long boxes = 0, proven = 0, hits = 0, wrong = 0, control_wrong = 0;
  second_unreachable_case("two-mirrors.gltf", 1u << BBC_CHAIN_RR, &boxes, &proven, &hits, &wrong,
                          &control_wrong);
  second_unreachable_case("wavy-corner.gltf", 1u << BBC_CHAIN_RR, &boxes, &proven, &hits, &wrong,
                          &control_wrong);
  second_unreachable_case("glass-sphere.gltf", 1u << BBC_CHAIN_TT, &boxes, &proven, &hits, &wrong,
                          &control_wrong);
  second_unreachable_case("mirror-pool.gltf", 1u << BBC_CHAIN_RT, &boxes, &proven, &hits, &wrong,
                          &control_wrong);
  fprintf(stderr,
          "second triangle unreachable: %ld of %ld boxes proven; %ld rays meet T2, %ld of them "
          "in a proven box (control: %ld)\n",
          proven, boxes, hits, wrong, control_wrong);
  CHECK(proven > boxes / 10);
  CHECK(hits > 10000);
  CHECK_INT(wrong, 0);
  CHECK(control_wrong > 0);
}
