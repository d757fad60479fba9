/* The caustic estimator end to end: precompute a cache, map it, render the caustic
 * alone. On the flat mirror the caustic is exactly the light of the mirrored point
 * source (an analytic check of tuples, bounds, grid, cache, solver and visibility at
 * once); and the bound-driven sampler converges to the deterministic enumeration. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "floor_footprint.h"
#include "harness.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

static int setup(fixture *f, const char *path, int max_level) {
  return fixture_setup(f, path, BBC_CHAIN_BIT(BBC_CHAIN_R) | BBC_CHAIN_BIT(BBC_CHAIN_T),
                       (uint32_t)max_level, 0);
}

static bbc_image *render_gamma(const fixture *f, bbc_method method, uint32_t spp, uint64_t seed,
                               uint32_t w, uint32_t h, uint32_t max_depth, double gamma,
                               bbc_render_stats *stats) {
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.spp = spp;
  o.seed = seed;
  o.components = BBC_COMPONENT_CAUSTICS;
  o.gamma_value = gamma;
  o.max_depth = max_depth;
  return fixture_render(f, o, w, h, stats);
}

/* gamma 2: P < 1 for most tuples, so sampling really happens. */
static bbc_image *render(const fixture *f, bbc_method method, uint32_t spp, uint64_t seed,
                         uint32_t w, uint32_t h, uint32_t max_depth, bbc_render_stats *stats) {
  return render_gamma(f, method, spp, seed, w, h, max_depth, 2, stats);
}

/* The floor's radiance from the mirrored point light: scale I cos(theta) / r^2. */
typedef struct mirrored_light {
  bbc_vec3 position;
  double scale;
} mirrored_light;

static double mirrored_value(const void *user, bbc_vec3 p) {
  const mirrored_light *m = user;
  bbc_vec3 l = v3_sub(m->position, p);
  double r2 = v3_dot(l, l);
  return m->scale * (l.y / sqrt(r2)) / r2;
}

/* Flat mirror at x = 0, floor y = 0, point light: every floor point sees the mirror
 * image of the light, so the caustic radiance is albedo/pi I cos(theta)/r^2 from the
 * mirrored source (the whole floor of flat-mirror.gltf is lit that way). Each sample is
 * exact at its jittered film position, so a pixel must lie between the least and the
 * greatest analytic value over its footprint, up to the ray offsets (1e-4 relative). */
TEST(flat_mirror_caustic_is_the_mirrored_light) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror.gltf"), 6));
  const uint32_t w = 40, h = 30;
  bbc_render_stats stats;
  bbc_image *image = render(&f, BBC_METHOD_ENUMERATE, 2, 1, w, h, 0, &stats);
  REQUIRE(image);
  const bbc_point_light *light = &f.scene->point_lights[0];
  bbc_vec3 image_light = v3(-light->position.x, light->position.y, light->position.z);
  float albedo = 0;
  double x0 = 1e30, x1 = -1e30, z0 = 1e30, z1 = -1e30;
  for (uint32_t m = 0; m < f.scene->mesh_count; m++) {
    const bbc_mesh *mesh = &f.scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER) continue;
    albedo = f.scene->materials[mesh->material].base_color[0];
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = f.scene->positions + 3 * (size_t)v;
      x0 = fmin(x0, p[0]);
      x1 = fmax(x1, p[0]);
      z0 = fmin(z0, p[2]);
      z1 = fmax(z1, p[2]);
    }
  }
  /* Clear of the floor's edges and the mirror's foot. */
  const double box[4] = {x0 + 0.05, x1 - 0.05, z0 + 0.05, z1 - 0.05};
  const mirrored_light ml = {image_light, albedo / PI * light->intensity[0]};
  int checked = 0, bad = 0;
  for (uint32_t y = 0; y < h; y++) {
    for (uint32_t x = 0; x < w; x++) {
      double lo, hi;
      int inside =
          floor_footprint_range(f.scene, f.accel, w, h, x, y, box, mirrored_value, &ml, &lo, &hi);
      if (!inside) continue;
      checked++;
      double got = image->rgb[3 * ((size_t)y * w + x)];
      if (!(got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4)) && bad++ < 5)
        fprintf(stderr, "pixel (%u,%u): %.9g not in [%.9g, %.9g]\n", x, y, got, lo, hi);
    }
  }
  fprintf(stderr, "%d floor pixels checked; %llu lookups, mean |U| %.2f\n", checked,
          (unsigned long long)stats.lookups, stats.candidates / (double)stats.lookups);
  CHECK(checked > 300);
  CHECK_INT(bad, 0);
  bbc_image_free(image);
  teardown(&f);
}

/* Mean and relMSE of a against b over pixels where b is lit. */
static double mean_of(const bbc_image *a) {
  double s = 0;
  for (size_t i = 0; i < (size_t)a->width * a->height * 3; i++) s += a->rgb[i];
  return s / ((double)a->width * a->height * 3);
}

/* On a curved caster, images of the bound-driven sampler (gamma small enough that most
 * tuples have P < 1) converge to the enumeration: the relMSE against it falls like
 * 1/spp, and the image means agree within their noise. */
static void converges_to_enumeration(const char *path, int max_level, uint32_t max_depth) {
  fixture f;
  REQUIRE(setup(&f, path, max_level));
  const uint32_t w = 48, h = 36;
  bbc_image *reference = render(&f, BBC_METHOD_ENUMERATE, 64, 99, w, h, max_depth, NULL);
  REQUIRE(reference);
  double errors[3];
  const uint32_t spps[3] = {4, 16, 64};
  bbc_render_stats stats;
  for (int k = 0; k < 3; k++) {
    bbc_image *image = render(&f, BBC_METHOD_BBC, spps[k], 7 + k, w, h, max_depth, &stats);
    REQUIRE(image);
    bbc_image_relmse(image, reference, 1e-2, 0, &errors[k]);
    fprintf(stderr, "%s: %u spp: relMSE %.5g, mean %.6g vs enumeration %.6g; |U| %.2f |S| %.2f\n",
            path, spps[k], errors[k], mean_of(image), mean_of(reference),
            stats.candidates / (double)stats.lookups, stats.sampled / (double)stats.lookups);
    if (k == 2) {
      /* The sampler must really sample, or this test shows nothing. */
      CHECK(stats.sampled < 0.8 * stats.candidates);
      CHECK_NEAR(mean_of(image), mean_of(reference), 0.03 * mean_of(reference));
    }
    bbc_image_free(image);
  }
  /* 16x the samples: relMSE down by well over 4x (1/spp gives 16x; the enumeration's
   * own pixel-sampling noise flattens it a little). */
  CHECK(errors[2] < errors[0] / 4);
  CHECK(mean_of(reference) > 0);
  bbc_image_free(reference);
  teardown(&f);
}

TEST(bbc_converges_to_enumeration_reflection) {
  /* Caustics at the first diffuse vertex only (3 segments): on the wavy mirror deeper
   * ones add the path tracer's own noise (random bounces, shared by both methods), with
   * which the image means at 64 spp scatter by about 3 % over seeds (seen: 0.96 to 1.05
   * of the enumeration's) and the comparison shows nothing; at 3 segments they agree to
   * 0.3-2 % (4 seeds). Every depth is compared paired by seed in
   * bbc_matches_enumeration_at_every_depth. */
  converges_to_enumeration(TEST_SCENE("wavy-mirror.gltf"), 5, 3);
}
/* Caustics at every diffuse vertex of the path (the default depth), behind the path
 * tracer's random bounces: with one seed, bbc and the enumeration trace the same camera
 * paths and bounces (the tuple draws use streams of their own), so the two images differ
 * by the tuple sampling alone, whose mean is zero. Paired by seed, their means agree far
 * better than unpaired images do (whose bounces alone scatter the mean by about 3 % at
 * 64 spp), and a bias of the estimator at any depth shows in the ratio of the means. At
 * gamma 2 the tuple sampling's heavy tail scatters the paired ratio by 1-1.7 % per seed
 * (16 seeds: 1.005 +- 0.003 Sobol, 0.999 +- 0.004 independent samples); at gamma 20,
 * with most tuples still sampled (P < 1), by 0.1 %. */
TEST(bbc_matches_enumeration_at_every_depth) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("wavy-mirror.gltf"), 5));
  const uint32_t w = 48, h = 36;
  enum { seeds = 4 };
  double ratios[seeds], mean = 0, var = 0;
  for (int k = 0; k < seeds; k++) {
    bbc_render_stats stats;
    bbc_image *e = render_gamma(&f, BBC_METHOD_ENUMERATE, 32, 21 + k, w, h, 0, 20, NULL);
    bbc_image *b = render_gamma(&f, BBC_METHOD_BBC, 32, 21 + k, w, h, 0, 20, &stats);
    REQUIRE(e && b);
    ratios[k] = mean_of(b) / mean_of(e);
    fprintf(stderr, "seed %d: mean %.6g, enumeration %.6g: ratio %.5f; |U| %.2f |S| %.2f\n",
            21 + k, mean_of(b), mean_of(e), ratios[k], stats.candidates / (double)stats.lookups,
            stats.sampled / (double)stats.lookups);
    CHECK(stats.sampled < 0.8 * stats.candidates); /* it really samples */
    mean += ratios[k] / seeds;
    bbc_image_free(e);
    bbc_image_free(b);
  }
  for (int k = 0; k < seeds; k++) var += (ratios[k] - mean) * (ratios[k] - mean) / (seeds - 1);
  fprintf(stderr, "mean ratio %.5f, spread over seeds %.5f\n", mean, sqrt(var));
  /* 0.3 %: a 1 % bias on the sampled tuples alone (P < 1) gives 1.0048 here. */
  CHECK_NEAR(mean, 1.0, 0.003);
  teardown(&f);
}

TEST(bbc_converges_to_enumeration_refraction) {
  converges_to_enumeration(TEST_SCENE("pool.glb"), 3, 0);
}

/* Every candidate tuple of a precomputed cache against true paths: for a stored tuple,
 * the path's cell lists it with a bound of at least the path's irradiance; a candidate
 * the precompute dropped has no admissible path. */
static void cache_covers_true_paths(const char *path, int max_level) {
  fixture f;
  REQUIRE(setup(&f, path, max_level));
  bbc_tuple *candidates = NULL;
  size_t count = 0;
  REQUIRE(bbc_tuples_find(f.scene, BBC_CHAIN_MASK_ALL, &candidates, &count) == BBC_OK);
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  const bbc_tuple *stored = bbc_cache_tuples(f.cache);
  bbc_cache_cursor *cursor = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, f.cache) == BBC_OK);
  bbc_validation acc;
  bbc_validation_reset(&acc);
  /* Stored tuples keep the candidates' order, so one pass pairs them up. */
  uint32_t next = 0;
  uint32_t samples = (uint32_t)harness_scale(60, 1000);
  for (size_t i = 0; i < count; i++) {
    int64_t id = -1;
    if (next < info.tuple_count && memcmp(&stored[next], &candidates[i], sizeof *stored) == 0)
      id = next++;
    REQUIRE(bbc_validate_cached_tuple(f.cache, cursor, f.scene, &candidates[i], id, samples, 3,
                                      &acc) == BBC_OK);
  }
  CHECK_INT(next, info.tuple_count);
  bbc_validation_print_summary(&acc, path, stderr);
  CHECK(acc.admissible > 1000);
  CHECK_INT(bbc_validation_failures(&acc), 0);
  bbc_cache_cursor_free(cursor);
  free(candidates);
  teardown(&f);
}

TEST(cache_covers_true_paths_reflection) {
  cache_covers_true_paths(TEST_SCENE("wavy-mirror.gltf"), 5);
}
TEST(cache_covers_true_paths_refraction) {
  cache_covers_true_paths(TEST_SCENE("pool.glb"), 3);
}

/* A region render (bbc_render_options.region) gives each of its pixels bit for bit as
 * the whole-image render does, whatever the thread count, and leaves the others black;
 * a region outside the image is refused. Through the cache at every depth, so that the
 * caustic estimator, the path tracer's bounces and the tuple draws are all keyed by the
 * pixel, not by the order pixels are rendered in. */
TEST(region_pixels_equal_the_whole_image) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("wavy-mirror.gltf"), 4));
  const uint32_t w = 40, h = 30, region[4] = {7, 5, 26, 19};
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_BBC;
  o.spp = 8;
  o.seed = 5;
  o.gamma_value = 2;
  o.threads = 2;
  bbc_image *whole = fixture_render(&f, o, w, h, NULL);
  memcpy(o.region, region, sizeof region);
  o.threads = 1;
  bbc_render_stats stats;
  bbc_image *part = fixture_render(&f, o, w, h, &stats);
  REQUIRE(whole && part);
  size_t differ = 0, lit_outside = 0, lit_inside = 0;
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++) {
      const float *a = whole->rgb + 3 * ((size_t)y * w + x), *b = part->rgb + 3 * ((size_t)y * w + x);
      int inside = x >= region[0] && x < region[2] && y >= region[1] && y < region[3];
      if (inside) {
        differ += memcmp(a, b, 3 * sizeof *a) != 0;
        lit_inside += b[0] > 0;
      } else {
        lit_outside += b[0] != 0 || b[1] != 0 || b[2] != 0;
      }
    }
  CHECK_INT(differ, 0);
  CHECK_INT(lit_outside, 0);
  CHECK(lit_inside > 100); /* the region holds the caustic: the comparison means something */
  CHECK_INT(stats.samples, 8u * (26 - 7) * (19 - 5));
  bbc_image_free(part);
  const uint32_t bad[][4] = {{0, 0, 41, 30}, {0, 0, 40, 31}, {5, 5, 5, 9}, {9, 5, 7, 9}};
  for (int i = 0; i < 4; i++) {
    bbc_image *image = NULL;
    REQUIRE(bbc_image_create(&image, w, h) == BBC_OK);
    memcpy(o.region, bad[i], sizeof bad[i]);
    o.cache = f.cache;
    CHECK_INT(bbc_render(f.scene, f.accel, &o, image, NULL), BBC_ERR_INVALID_ARGUMENT);
    bbc_image_free(image);
  }
  bbc_image_free(whole);
  teardown(&f);
}
