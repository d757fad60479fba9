/* Area lights (emissive triangles) through the cache: a flat mirror under a small
 * square area light, whose caustic on the floor is the mirrored emitter's irradiance,
 * computed here by independent quadrature over the mirrored emitter. The cached
 * estimator's caustic must match it, the full image (cache + path tracing) must match
 * direct + mirrored light (nothing counted twice, nothing lost), a control that drops
 * the emitter's cosine must fail, and the cached bounds must hold for sampled true paths
 * over random emitter points. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

static int setup(fixture *f, const char *path, uint32_t chains) {
  return fixture_setup(f, path, chains, 6, 1);
}

/* The mirror (plane x = mx, normal +x) spans [y0, y1] x [z0, z1]; the floor y = fy
 * spans [x0, x1] x [z0, z1] with albedo `albedo`. */
typedef struct layout {
  double mx, my0, my1, mz0, mz1;
  double fy, fx0, fx1, fz0, fz1;
  double albedo;
} layout;

static int measure(const bbc_scene *s, layout *l) {
  int mirror = 0, floor = 0;
  l->my0 = l->mz0 = l->fx0 = l->fz0 = 1e30;
  l->my1 = l->mz1 = l->fx1 = l->fz1 = -1e30;
  for (uint32_t k = 0; k < s->mesh_count; k++) {
    const bbc_mesh *mesh = &s->meshes[k];
    const bbc_material *m = &s->materials[mesh->material];
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = s->positions + 3 * (size_t)v;
      if (mesh->role == BBC_ROLE_RECEIVER) {
        floor = 1;
        l->fy = p[1], l->albedo = m->base_color[0];
        l->fx0 = fmin(l->fx0, p[0]), l->fx1 = fmax(l->fx1, p[0]);
        l->fz0 = fmin(l->fz0, p[2]), l->fz1 = fmax(l->fz1, p[2]);
      } else if (m->type == BBC_MATERIAL_MIRROR) {
        mirror = 1;
        l->mx = p[0];
        l->my0 = fmin(l->my0, p[1]), l->my1 = fmax(l->my1, p[1]);
        l->mz0 = fmin(l->mz0, p[2]), l->mz1 = fmax(l->mz1, p[2]);
      }
    }
  }
  return mirror && floor && s->emitter_count > 0;
}

/* Irradiance at floor point p from the emitters mirrored across x = mx (or, direct, not
 * mirrored), by the midpoint rule on a k x k subdivision of each emitter triangle; a
 * mirrored point counts only where the segment to it crosses the mirror rectangle.
 * drop_cosine: the control, without the emitter's cosine. */
static double oracle(const bbc_scene *s, const layout *l, bbc_vec3 p, int mirrored, int drop_cosine) {
  const int k = 16;
  double e = 0;
  for (uint32_t i = 0; i < s->emitter_count; i++) {
    const uint32_t *idx = s->indices + 3 * (size_t)s->emitters[i];
    bbc_vec3 q[3];
    for (int j = 0; j < 3; j++) {
      q[j] = v3_load(s->positions + 3 * (size_t)idx[j]);
      if (mirrored) q[j].x = 2 * l->mx - q[j].x;
    }
    bbc_vec3 nl = v3_normalize(v3_load(s->normals + 3 * (size_t)idx[0]));
    if (mirrored) nl.x = -nl.x;
    bbc_vec3 e1 = v3_sub(q[1], q[0]), e2 = v3_sub(q[2], q[0]);
    double area = 0.5 * v3_length(v3_cross(e1, e2));
    double radiance = bbc_scene_triangle_material(s, s->emitters[i])->emission[0];
    for (int a = 0; a < k; a++)
      for (int b = 0; a + b < k; b++)
        for (int flip = 0; flip < 2; flip++) {
          if (flip && a + b + 1 >= k) continue;
          double u = flip ? (a + 2.0 / 3.0) / k : (a + 1.0 / 3.0) / k;
          double v = flip ? (b + 2.0 / 3.0) / k : (b + 1.0 / 3.0) / k;
          bbc_vec3 x = v3_add(q[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
          bbc_vec3 d = v3_sub(x, p);
          double r2 = v3_dot(d, d), r = sqrt(r2);
          double cos_p = d.y / r, cos_l = -v3_dot(nl, d) / r;
          if (cos_p <= 0 || cos_l <= 0) continue;
          if (mirrored) {
            double t = (l->mx - p.x) / d.x;
            bbc_vec3 c = v3_madd(p, d, t);
            if (!(t > 0 && t < 1 && c.y > l->my0 && c.y < l->my1 && c.z > l->mz0 && c.z < l->mz1))
              continue;
          }
          e += radiance * cos_p * (drop_cosine ? 1.0 : cos_l) / r2 * area / (k * k);
        }
  }
  return e;
}

static bbc_image *render(const fixture *f, bbc_method method, uint32_t components, uint32_t spp,
                         uint32_t w, uint32_t h, uint64_t seed) {
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.spp = spp;
  o.seed = seed;
  o.components = components;
  o.max_depth = 3;
  return fixture_render(f, o, w, h, NULL);
}

/* The z-score of sum over floor pixels of (rendered - expected), the expectation being
 * albedo/pi times (direct ? direct light : 0) + (mirrored ? mirrored light : 0) at 6 x 6
 * film points of the pixel; the variance of the sum from the squared residuals. */
typedef struct expectation {
  int direct, mirrored, drop_cosine;
  double mirrored_weight; /* 1, or 2 for the "counted twice" control */
} expectation;

static double z_score(const fixture *f, const layout *l, const bbc_image *image, expectation x,
                      double *relative_std) {
  const uint32_t w = image->width, h = image->height;
  double sum = 0, sum_sq = 0, total = 0;
  for (uint32_t py = 0; py < h; py++)
    for (uint32_t px = 0; px < w; px++) {
      double expected = 0;
      int inside = 1;
      const int n = 6;
      for (int j = 0; j < n && inside; j++)
        for (int i = 0; i < n && inside; i++) {
          bbc_vec3 o, d;
          bbc_camera_ray(&f->scene->camera, w, h, px + (i + 0.5) / n, py + (j + 0.5) / n, &o, &d);
          double t = (l->fy - o.y) / d.y;
          bbc_vec3 p = v3_madd(o, d, t);
          /* Clear of the floor's edges by 0.05, as the point-light mirror tests are: at the
           * mirror's foot the paths graze it. */
          if (!(d.y < 0 && p.x > l->fx0 + 0.05 && p.x < l->fx1 - 0.05 && p.z > l->fz0 + 0.05 &&
                p.z < l->fz1 - 0.05) ||
              bbc_accel_occluded(f->accel, o, d, 0, t * (1 - 1e-6))) {
            inside = 0;
            break;
          }
          double e = 0;
          if (x.direct) e += oracle(f->scene, l, p, 0, 0);
          if (x.mirrored) e += x.mirrored_weight * oracle(f->scene, l, p, 1, x.drop_cosine);
          expected += l->albedo / PI * e / (n * n);
        }
      if (!inside) continue;
      double r = image->rgb[3 * ((size_t)py * w + px)] - expected;
      sum += r, sum_sq += r * r, total += expected;
    }
  *relative_std = sqrt(sum_sq) / total;
  return sum / sqrt(sum_sq);
}

/* The cached estimator alone (the caustic part) against the mirrored emitter, and the
 * control without the emitter's cosine (A_e cos(theta_e) / r^2 is the density change
 * from the emitter's area to the solid angle at x1), which must be far off. */
TEST(area_flat_mirror_caustic_is_the_mirrored_emitter) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-area.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R)));
  layout l;
  REQUIRE(measure(f.scene, &l));
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  CHECK(info.version_minor == 6 && info.params.area_lights == 1 && info.params.alpha_area == 100);
  CHECK(info.scene_emitter_count == f.scene->emitter_count);
  CHECK(info.tuple_count > 0);
  bbc_image *image = render(&f, BBC_METHOD_BBC, BBC_COMPONENT_CAUSTICS,
                            (uint32_t)harness_scale(64, 512), 64, 48, 5);
  REQUIRE(image);
  double sigma;
  expectation right = {0, 1, 0, 1.0}, control = {0, 1, 1, 1.0};
  double z = z_score(&f, &l, image, right, &sigma);
  double zc = z_score(&f, &l, image, control, &sigma);
  fprintf(stderr, "caustic vs mirrored emitter: z = %.2f (relative std %.5f); without cos: z = %.2f\n",
          z, sigma, zc);
  CHECK(fabs(z) < 4.5);
  CHECK(sigma < 0.03); /* the per-pixel residuals include the quadrature of sharp edges */
  CHECK(fabs(zc) > 10);
  bbc_image_free(image);
  teardown(&f);
}

/* The flat mirror under its emitter at level 6, bounded with alpha_area a (alpha_double
 * 10); returns the cache (its bytes in *bytes) and the precompute's statistics. */
static bbc_cache *area_alpha_cache(const bbc_scene *scene, double a, void **bytes,
                                   bbc_precompute_stats *st) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.chains = BBC_CHAIN_BIT(BBC_CHAIN_R);
  o.params.max_level = 6;
  o.params.grid_resolution = 64;
  o.params.area_lights = 1;
  o.params.alpha_area = a;
  o.threads = 1;
  bbc_cache_builder *b = NULL;
  size_t size = 0;
  bbc_cache *c = NULL;
  *bytes = NULL;
  if (bbc_precompute(&b, scene, &o, st) == BBC_OK &&
      bbc_cache_builder_write_memory(b, bytes, &size, NULL) == BBC_OK)
    bbc_cache_open_memory(&c, *bytes, size, NULL);
  bbc_cache_builder_free(b);
  return c;
}

/* Area lights have their own ratio (PARM alpha_area, format 1.5): 0 bounds them at
 * alpha_double as before 1.5 (minor version 3 here: GEOM) and gives the same cells as
 * alpha_area = alpha_double; a looser ratio stops earlier (fewer pieces). */
TEST(area_alpha_is_stored_and_used) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("flat-mirror-area.gltf"), NULL) == BBC_OK);
  const double alphas[3] = {0, 10, 100};
  void *bytes[3];
  bbc_precompute_stats st[3];
  bbc_cache *c[3];
  bbc_cache_info in[3];
  for (int k = 0; k < 3; k++) {
    memset(&st[k], 0, sizeof st[k]);
    c[k] = area_alpha_cache(scene, alphas[k], &bytes[k], &st[k]);
    REQUIRE(c[k]);
    bbc_cache_get_info(c[k], &in[k]);
    CHECK(in[k].params.alpha_area == alphas[k]);
    CHECK_INT(in[k].version_minor, 6);
    CHECK_INT(bbc_cache_validate(c[k], NULL, NULL), BBC_OK);
  }
  /* 0 and 10: the same pieces and the same entries, cell by cell. */
  CHECK(st[0].irradiance_pieces == st[1].irradiance_pieces && st[0].entries == st[1].entries);
  CHECK(in[0].entry_count == in[1].entry_count && in[0].entry_count > 0);
  bbc_cache_cursor *cur[2] = {NULL, NULL};
  REQUIRE(bbc_cache_cursor_create(&cur[0], c[0]) == BBC_OK &&
          bbc_cache_cursor_create(&cur[1], c[1]) == BBC_OK);
  uint64_t differ = 0, cells = in[0].cell_count;
  for (uint64_t cell = 0; cell < cells; cell++) {
    const bbc_cache_entry *e0, *e1;
    uint32_t n0 = 0, n1 = 0;
    if (bbc_cache_cell(cur[0], cell, &e0, &n0) != BBC_OK) {
      differ++;
      continue;
    }
    /* e0 stays valid: the next call is on the other cursor. */
    if (bbc_cache_cell(cur[1], cell, &e1, &n1) != BBC_OK || n0 != n1 ||
        (n0 && memcmp(e0, e1, n0 * sizeof *e0) != 0))
      differ++;
  }
  CHECK(cells > 0);
  CHECK_INT(differ, 0);
  /* 100: fewer irradiance pieces than 10. */
  fprintf(stderr, "irradiance pieces: alpha_area 10: %llu, 100: %llu\n",
          (unsigned long long)st[1].irradiance_pieces, (unsigned long long)st[2].irradiance_pieces);
  CHECK(st[2].irradiance_pieces < st[1].irradiance_pieces);
  for (int k = 0; k < 2; k++) bbc_cache_cursor_free(cur[k]);
  for (int k = 0; k < 3; k++) {
    bbc_cache_close(c[k]);
    free(bytes[k]);
  }
  bbc_scene_free(scene);
}

/* Cache and path tracing together: the floor gets the direct light plus the mirrored
 * light exactly once. The path tracer must skip the caustic paths the cache counts
 * (docs/lights.md); counting them twice, or neither, must show. */
TEST(area_flat_mirror_split_counts_each_path_once) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-area.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R)));
  layout l;
  REQUIRE(measure(f.scene, &l));
  const uint32_t all = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  bbc_image *image = render(&f, BBC_METHOD_BBC, all, (uint32_t)harness_scale(256, 2048), 64, 48, 7);
  REQUIRE(image);
  double sigma;
  expectation once = {1, 1, 0, 1.0}, twice = {1, 1, 0, 2.0}, never = {1, 0, 0, 1.0};
  double z = z_score(&f, &l, image, once, &sigma);
  double z2 = z_score(&f, &l, image, twice, &sigma);
  double z0 = z_score(&f, &l, image, never, &sigma);
  fprintf(stderr, "full image: z = %.2f (relative std %.5f); twice: %.2f; never: %.2f\n", z, sigma,
          z2, z0);
  CHECK(fabs(z) < 4.5);
  CHECK(z2 < -10);
  CHECK(z0 > 10);
  /* Without the caustic part the path tracer alone must lack the mirrored light: the
   * cache's paths are not counted by it any more. */
  bbc_image *rest = render(&f, BBC_METHOD_BBC, BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT,
                           (uint32_t)harness_scale(256, 2048), 64, 48, 7);
  REQUIRE(rest);
  double zr = z_score(&f, &l, rest, never, &sigma);
  fprintf(stderr, "without the caustic part: z = %.2f against direct light alone\n", zr);
  CHECK(fabs(zr) < 4.5);
  bbc_image_free(rest);
  bbc_image_free(image);
  teardown(&f);
}

/* The cached bounds of every area-light tuple hold for true paths through random
 * emitter points (bbc_validate_cached_tuple), and the piece bounds too
 * (bbc_validate_tuple); 0 violations. */
TEST(area_bounds_hold_over_random_emitter_points) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-area.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R)));
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  const bbc_tuple *tuples = bbc_cache_tuples(f.cache);
  bbc_cache_cursor *cursor = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, f.cache) == BBC_OK);
  bbc_bounder *bounder = NULL;
  REQUIRE(bbc_bounder_create(&bounder) == BBC_OK);
  bbc_validation cached, pieces;
  bbc_validation_reset(&cached);
  bbc_validation_reset(&pieces);
  const uint32_t samples = (uint32_t)harness_scale(4000, 40000);
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  prm.max_level = 6;
  prm.alpha = 10;
  for (uint32_t i = 0; i < info.tuple_count; i++) {
    CHECK(tuples[i].light >= f.scene->point_light_count);
    CHECK(bbc_validate_cached_tuple(f.cache, cursor, f.scene, &tuples[i], i, samples, 1, &cached) ==
          BBC_OK);
    CHECK(bbc_validate_tuple(bounder, f.scene, &tuples[i], &prm, samples / 4, 2, &pieces) == BBC_OK);
  }
  fprintf(stderr, "cached: %llu admissible of %llu; pieces: %llu admissible\n",
          (unsigned long long)cached.admissible, (unsigned long long)cached.samples,
          (unsigned long long)pieces.admissible);
  CHECK(cached.admissible > 1000);
  CHECK(pieces.admissible > 250);
  CHECK(bbc_validation_failures(&cached) == 0);
  CHECK(bbc_validation_failures(&pieces) == 0);
  bbc_bounder_free(bounder);
  bbc_cache_cursor_free(cursor);
  teardown(&f);
}

/* A cache without area lights leaves area-light caustics to path tracing as before: the
 * full image still has the mirrored light once. */
TEST(area_without_area_lights_path_tracing_keeps_them) {
  fixture f;
  memset(&f, 0, sizeof f);
  REQUIRE(bbc_scene_load(&f.scene, TEST_SCENE("flat-mirror-area.gltf"), NULL) == BBC_OK);
  REQUIRE(bbc_accel_create(&f.accel, f.scene, NULL, NULL) == BBC_OK);
  layout l;
  REQUIRE(measure(f.scene, &l));
  const uint32_t all = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  bbc_image *image = render(&f, BBC_METHOD_PT, all, (uint32_t)harness_scale(512, 4096), 64, 48, 9);
  REQUIRE(image);
  double sigma;
  expectation once = {1, 1, 0, 1.0};
  double z = z_score(&f, &l, image, once, &sigma);
  fprintf(stderr, "path tracing: z = %.2f (relative std %.5f)\n", z, sigma);
  CHECK(fabs(z) < 4.5);
  bbc_image_free(image);
  bbc_accel_free(f.accel);
  bbc_scene_free(f.scene);
}

/* A cache of the emitters that holds no R chains (--chains T) leaves the mirror's
 * area-light caustic to path tracing: the full image has the mirrored light once. The
 * split must ask which chain types the cache holds, not only which are rendered. */
TEST(area_cache_without_the_chain_path_tracing_keeps_it) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-area.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_T)));
  layout l;
  REQUIRE(measure(f.scene, &l));
  const uint32_t all = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  bbc_image *image = render(&f, BBC_METHOD_BBC, all, (uint32_t)harness_scale(512, 4096), 64, 48, 9);
  REQUIRE(image);
  double sigma;
  expectation once = {1, 1, 0, 1.0}, never = {1, 0, 0, 1.0};
  double z = z_score(&f, &l, image, once, &sigma);
  double z0 = z_score(&f, &l, image, never, &sigma);
  fprintf(stderr, "T-only cache: z = %.2f (relative std %.5f); never: %.2f\n", z, sigma, z0);
  CHECK(fabs(z) < 4.5);
  CHECK(z0 > 10);
  bbc_image_free(image);
  teardown(&f);
}

/* Double scattering from an area light (two flat mirrors in a corner, RR, under an
 * emissive square of side 0.25; the cache holds R and RR of the emitters): the whole
 * image through the cache (the estimator for R and RR, path tracing for the rest, which
 * skips exactly the paths the estimator counts) must match plain path tracing of the
 * same scene, which finds the mirrored light by hitting the emitter. Controls on the RR
 * part of the estimator (rendered alone with chains RR): counted twice, lost, and
 * without the 1 / pdf of the emitter point (multiplied by the density 1 / A_e, so each
 * estimate is the value f(y) alone) must all fail. Pixel sums of (cache - path tracing) over independent seeds; their variance from
 * the squared differences. */
static double difference_z(const bbc_image *a, const bbc_image *b, const bbc_image *add,
                           double add_weight, const bbc_image *mask) {
  const size_t n = (size_t)a->width * a->height;
  double sum = 0, sum_sq = 0;
  for (size_t i = 0; i < n; i++) {
    if (mask && !(mask->rgb[3 * i] > 0)) continue;
    double r = a->rgb[3 * i] + (add ? add_weight * add->rgb[3 * i] : 0) - b->rgb[3 * i];
    sum += r, sum_sq += r * r;
  }
  return sum_sq > 0 ? sum / sqrt(sum_sq) : 0;
}

TEST(area_two_mirrors_rr_matches_path_tracing) {
  fixture f;
  REQUIRE(fixture_setup(&f, TEST_SCENE("two-mirrors-area.gltf"),
                        BBC_CHAIN_BIT(BBC_CHAIN_R) | BBC_CHAIN_BIT(BBC_CHAIN_RR), 5, 1));
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  /* 1.9: the default parameters' two-bounce level (for point lights; it has none). */
  CHECK(info.version_minor == 9 && info.params.area_lights == 1 && info.params.area_double == 1);
  uint64_t rr = 0;
  const bbc_tuple *tuples = bbc_cache_tuples(f.cache);
  for (uint32_t i = 0; i < info.tuple_count; i++) rr += tuples[i].chain == BBC_CHAIN_RR;
  CHECK(rr > 0);
  const uint32_t all = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.max_depth = 4; /* camera, floor, mirror, mirror, emitter */
  o.components = all;
  o.method = BBC_METHOD_BBC;
  o.spp = (uint32_t)harness_scale(256, 2048);
  o.seed = 11;
  bbc_image *cached = fixture_render(&f, o, 48, 36, NULL);
  o.components = BBC_COMPONENT_CAUSTICS;
  bbc_image *caustic = fixture_render(&f, o, 48, 36, NULL);
  o.chains = BBC_CHAIN_BIT(BBC_CHAIN_RR); /* the double-scattering part alone */
  bbc_image *caustic_rr = fixture_render(&f, o, 48, 36, NULL);
  o.chains = 0;
  o.components = BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  bbc_image *rest = fixture_render(&f, o, 48, 36, NULL);
  o.components = all;
  o.method = BBC_METHOD_PT;
  o.spp = (uint32_t)harness_scale(4096, 32768);
  o.seed = 12;
  bbc_image *traced = fixture_render(&f, o, 48, 36, NULL);
  REQUIRE(cached && caustic && caustic_rr && rest && traced);
  /* A_e of the emitters (all of one square). */
  double area = 0;
  for (uint32_t i = 0; i < f.scene->emitter_count; i++) {
    bbc_light_model model;
    bbc_scene_area_light(f.scene, i, &model, NULL);
    area += 0.5 * v3_length(model.emitter_normal);
  }
  const double a_e = area / f.scene->emitter_count;
  double z = difference_z(cached, traced, NULL, 0, NULL);
  double z_split = difference_z(rest, traced, caustic, 1.0, NULL);
  double z_rr = difference_z(cached, traced, NULL, 0, caustic_rr);
  /* The controls over the pixels the RR caustic reaches (where the RR part is not 0). */
  double z_twice = difference_z(cached, traced, caustic_rr, 1.0, caustic_rr);
  double z_never = difference_z(cached, traced, caustic_rr, -1.0, caustic_rr);
  double z_pdf = difference_z(cached, traced, caustic_rr, 1.0 / a_e - 1.0, caustic_rr);
  fprintf(stderr,
          "cache vs path tracing: z = %.2f (parts %.2f, where RR lands %.2f); RR caustic "
          "twice %.2f, never %.2f, without 1/pdf (x %.3g) %.2f\n",
          z, z_split, z_rr, z_twice, z_never, 1.0 / a_e, z_pdf);
  CHECK(fabs(z) < 4.5);
  CHECK(fabs(z_split) < 4.5);
  CHECK(fabs(z_rr) < 4.5);
  /* The RR part is a few percent of the image and path tracing's noise dominates the
   * differences: counting it twice or not at all shows at about 8 sigma (CI sampling),
   * so the controls must exceed 6 (a chance of 1e-9 under the null). */
  CHECK(z_twice > 6);
  CHECK(z_never < -6);
  CHECK(z_pdf > 6);
  bbc_image_free(cached);
  bbc_image_free(caustic);
  bbc_image_free(caustic_rr);
  bbc_image_free(rest);
  bbc_image_free(traced);
  teardown(&f);
}
