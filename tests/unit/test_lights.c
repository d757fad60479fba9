/* Sun (directional) and spot lights end to end: exact images of a flat mirror under a
 * sun and under a spot whose cone edge crosses the caustic (cache, bounds, solver and
 * path tracer at once), each with a control that drops a term and must fail, and the
 * bounds validated against true paths for every light kind and chain type. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "floor_footprint.h"
#include "harness.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

static int setup(fixture *f, const char *path, uint32_t chains) {
  return fixture_setup(f, path, chains, 6, 0);
}

static bbc_image *render(const fixture *f, bbc_method method, uint32_t components, uint32_t spp,
                         uint32_t w, uint32_t h) {
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.spp = spp;
  o.seed = 3;
  o.components = components;
  o.gamma_value = 2;
  return fixture_render(f, o, w, h, NULL);
}

/* The flat mirror (x = 0, facing +x) spans y in [y0, y1], z in [z0, z1]; the floor is
 * y = 0. */
typedef struct mirror_scene {
  double y0, y1, z0, z1;
  double box[4]; /* the floor's interior, clear of its edges */
  double albedo;
} mirror_scene;

static mirror_scene measure(const bbc_scene *s) {
  mirror_scene m = {1e30, -1e30, 1e30, -1e30, {1e30, -1e30, 1e30, -1e30}, 0};
  for (uint32_t k = 0; k < s->mesh_count; k++) {
    const bbc_mesh *mesh = &s->meshes[k];
    int floor = mesh->role == BBC_ROLE_RECEIVER;
    if (floor) m.albedo = s->materials[mesh->material].base_color[0];
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = s->positions + 3 * (size_t)v;
      if (floor) {
        m.box[0] = fmin(m.box[0], p[0]), m.box[1] = fmax(m.box[1], p[0]);
        m.box[2] = fmin(m.box[2], p[2]), m.box[3] = fmax(m.box[3], p[2]);
      } else {
        m.y0 = fmin(m.y0, p[1]), m.y1 = fmax(m.y1, p[1]);
        m.z0 = fmin(m.z0, p[2]), m.z1 = fmax(m.z1, p[2]);
      }
    }
  }
  m.box[0] += 0.05, m.box[1] -= 0.05, m.box[2] += 0.05, m.box[3] -= 0.05;
  return m;
}

/* Compares every usable pixel of the image with the analytic value over its footprint
 * and returns the number of pixels outside [lo, hi] (up to the ray offsets, 1e-4). */
static int count_bad(const fixture *f, const bbc_image *image, const double box[4],
                     floor_value_fn value, const void *user, int *checked, int *dark, int *lit,
                     int verbose) {
  int bad = 0;
  *checked = *dark = *lit = 0;
  for (uint32_t y = 0; y < image->height; y++) {
    for (uint32_t x = 0; x < image->width; x++) {
      double lo, hi;
      if (!floor_footprint_range(f->scene, f->accel, image->width, image->height, x, y, box, value,
                                 user, &lo, &hi))
        continue;
      (*checked)++;
      *dark += hi == 0;
      *lit += lo > 0;
      double got = image->rgb[3 * ((size_t)y * image->width + x)];
      if (!(got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4))) {
        if (verbose && bad < 5)
          fprintf(stderr, "pixel (%u,%u): %.9g not in [%.9g, %.9g]\n", x, y, got, lo, hi);
        bad++;
      }
    }
  }
  return bad;
}

/* ---- the sun ------------------------------------------------------------------------- */

typedef struct sun_model {
  mirror_scene m;
  bbc_vec3 d;      /* the sun's direction of travel */
  double e;        /* its irradiance */
  int caustic;     /* 1: the mirrored sun; 0: the sun itself (direct light) */
  int drop_cosine; /* the control: E instead of E cos(theta) */
} sun_model;

/* Radiance albedo/pi E cos(theta) of the floor from the sun (direct) or from its mirror
 * image, the parallel beam of direction (-d.x, d.y, d.z) that leaves the mirror where
 * the ray from p back along it meets x = 0 inside the mirror. Points within 0.03 of the
 * reflected aperture's edges are not used (a pixel there is partly lit). */
static double sun_value(const void *user, bbc_vec3 p) {
  const sun_model *s = user;
  bbc_vec3 d = s->caustic ? v3(-s->d.x, s->d.y, s->d.z) : s->d;
  double value = s->m.albedo / PI * s->e * (s->drop_cosine ? 1.0 : -d.y);
  if (!s->caustic) return value;
  /* p - t d reaches x = 0 at t = p.x / d.x. */
  double t = p.x / d.x;
  double y = p.y - t * d.y, z = p.z - t * d.z;
  const double margin = 0.03;
  if (y > s->m.y0 + margin && y < s->m.y1 - margin && z > s->m.z0 + margin && z < s->m.z1 - margin)
    return value;
  if (y < s->m.y0 - margin || y > s->m.y1 + margin || z < s->m.z0 - margin || z > s->m.z1 + margin)
    return 0;
  return -1;
}

/* A flat mirror under a sun: the caustic is the mirrored sun's irradiance E cos(theta)
 * within the mirror's reflected aperture and nothing outside it (enumeration of the
 * cache: every sample is exact), and the path tracer's direct light is the sun's own
 * E cos(theta) everywhere on the floor. Dropping the cosine must fail both checks. */
TEST(sun_flat_mirror_is_the_mirrored_sun) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-sun.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R)));
  const bbc_point_light *sun = &f.scene->point_lights[0];
  REQUIRE(sun->model.kind == BBC_LIGHT_DIRECTIONAL);
  sun_model s = {measure(f.scene), sun->model.direction, sun->intensity[0], 1, 0};
  const uint32_t w = 40, h = 30;
  bbc_image *caustic = render(&f, BBC_METHOD_ENUMERATE, BBC_COMPONENT_CAUSTICS, 2, w, h);
  bbc_image *direct = render(&f, BBC_METHOD_PT, BBC_COMPONENT_DIRECT, 2, w, h);
  REQUIRE(caustic && direct);
  int checked, dark, lit;
  CHECK_INT(count_bad(&f, caustic, s.m.box, sun_value, &s, &checked, &dark, &lit, 1), 0);
  fprintf(stderr, "caustic: %d pixels checked, %d dark, %d lit\n", checked, dark, lit);
  CHECK(lit > 100 && dark > 100); /* the aperture's edge crosses the floor */
  s.drop_cosine = 1;
  int bad = count_bad(&f, caustic, s.m.box, sun_value, &s, &checked, &dark, &lit, 0);
  fprintf(stderr, "control without the cosine: %d of %d pixels off\n", bad, checked);
  CHECK(bad > 100);
  s.caustic = 0, s.drop_cosine = 0;
  CHECK_INT(count_bad(&f, direct, s.m.box, sun_value, &s, &checked, &dark, &lit, 1), 0);
  CHECK(checked > 300);
  s.drop_cosine = 1;
  CHECK(count_bad(&f, direct, s.m.box, sun_value, &s, &checked, &dark, &lit, 0) > 100);
  bbc_image_free(caustic);
  bbc_image_free(direct);
  teardown(&f);
}

/* ---- the spot ------------------------------------------------------------------------ */

typedef struct spot_model {
  mirror_scene m;
  bbc_vec3 position, axis;
  double intensity, cos_inner, cos_outer;
  int caustic;
  int drop_falloff; /* the control */
} spot_model;

/* glTF's reference falloff (KHR_lights_punctual), written out independently of
 * bbc_light_falloff. */
static double spot_falloff(const spot_model *s, bbc_vec3 w) {
  double scale = 1.0 / fmax(0.001, s->cos_inner - s->cos_outer);
  double t = v3_dot(w, s->axis) * scale - s->cos_outer * scale;
  t = fmin(fmax(t, 0.0), 1.0);
  return t * t;
}

/* Radiance albedo/pi I F cos(theta) / r^2 of the floor from the spot (direct) or from
 * its mirror image at (-x, y, z), F taken in the direction the spot sends the light
 * (toward the mirror point x1 for the caustic). */
static double spot_value(const void *user, bbc_vec3 p) {
  const spot_model *s = user;
  bbc_vec3 src = s->caustic ? v3(-s->position.x, s->position.y, s->position.z) : s->position;
  bbc_vec3 l = v3_sub(src, p);
  double r2 = v3_dot(l, l);
  bbc_vec3 toward = v3_sub(p, s->position);
  if (s->caustic) {
    /* x1: where the segment from the image to p crosses x = 0. */
    double t = -src.x / (p.x - src.x);
    bbc_vec3 x1 = v3_add(src, v3_scale(v3_sub(p, src), t));
    const double margin = 0.03;
    if (x1.y < s->m.y0 - margin || x1.y > s->m.y1 + margin || x1.z < s->m.z0 - margin ||
        x1.z > s->m.z1 + margin)
      return 0;
    if (!(x1.y > s->m.y0 + margin && x1.y < s->m.y1 - margin && x1.z > s->m.z0 + margin &&
          x1.z < s->m.z1 - margin))
      return -1;
    toward = v3_sub(x1, s->position);
  }
  double falloff = s->drop_falloff ? 1.0 : spot_falloff(s, v3_normalize(toward));
  return s->m.albedo / PI * s->intensity * falloff * (l.y / sqrt(r2)) / r2;
}

/* A spot aimed at the foot of a flat mirror, its outer cone's edge crossing the
 * caustic: the caustic is the mirrored spot with the falloff of the direction toward
 * the mirror, dark beyond the edge; the direct light is the spot's own. Dropping the
 * falloff must fail. */
TEST(spot_flat_mirror_cone_edge) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-spot.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R)));
  const bbc_point_light *spot = &f.scene->point_lights[0];
  REQUIRE(spot->model.kind == BBC_LIGHT_SPOT);
  /* The scene's cone: innerConeAngle 0.25, outerConeAngle 0.5 (make_test_scenes.sh). */
  spot_model s = {measure(f.scene), spot->position, spot->model.direction, spot->intensity[0],
                  cos(0.25), cos(0.5), 1, 0};
  const uint32_t w = 40, h = 30;
  bbc_image *caustic = render(&f, BBC_METHOD_ENUMERATE, BBC_COMPONENT_CAUSTICS, 2, w, h);
  bbc_image *direct = render(&f, BBC_METHOD_PT, BBC_COMPONENT_DIRECT, 2, w, h);
  REQUIRE(caustic && direct);
  int checked, dark, lit;
  CHECK_INT(count_bad(&f, caustic, s.m.box, spot_value, &s, &checked, &dark, &lit, 1), 0);
  fprintf(stderr, "caustic: %d pixels checked, %d dark, %d lit\n", checked, dark, lit);
  CHECK(lit > 100 && dark > 50); /* the cone's edge crosses the caustic */
  s.drop_falloff = 1;
  int bad = count_bad(&f, caustic, s.m.box, spot_value, &s, &checked, &dark, &lit, 0);
  fprintf(stderr, "control without the falloff: %d of %d pixels off\n", bad, checked);
  CHECK(bad > 100);
  s.caustic = 0, s.drop_falloff = 0;
  CHECK_INT(count_bad(&f, direct, s.m.box, spot_value, &s, &checked, &dark, &lit, 1), 0);
  fprintf(stderr, "direct: %d pixels checked, %d dark, %d lit\n", checked, dark, lit);
  CHECK(checked > 300 && lit > 10 && dark > 50); /* the cone meets the floor near the foot */
  s.drop_falloff = 1;
  CHECK(count_bad(&f, direct, s.m.box, spot_value, &s, &checked, &dark, &lit, 0) > 50);
  bbc_image_free(caustic);
  bbc_image_free(direct);
  teardown(&f);
}

/* ---- bounds against true paths, per light kind and chain type ------------------------- */

/* Validates every candidate tuple of one chain type of the scene with `samples` true
 * paths each, into *acc. */
static void validate_chain(const char *path, bbc_chain chain, uint32_t samples,
                           bbc_validation *acc) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, path, NULL) == BBC_OK);
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE(bbc_tuples_find(scene, BBC_CHAIN_BIT(chain), &tuples, &count) == BBC_OK);
  bbc_bounder *b = NULL;
  REQUIRE(bbc_bounder_create(&b) == BBC_OK);
  /* Level 6 keeps the suite quick; pieces of every level must hold their paths. */
  bbc_bound_params params;
  memset(&params, 0, sizeof params);
  params.max_level = 6;
  for (size_t i = 0; i < count; i++) {
    bbc_result r = bbc_validate_tuple(b, scene, &tuples[i], &params, samples, 23, acc);
    if (r != BBC_OK) harness_fail(__FILE__, __LINE__, "bbc_validate_tuple: %d", (int)r);
  }
  bbc_bounder_free(b);
  free(tuples);
  bbc_scene_free(scene);
}

/* At least `paths` admissible true paths of the chain under each of a sun and a spot,
 * none outside its piece's bounds: `first` samples per tuple, and when that is not
 * enough (BBC_TEST_FULL=1), a second pass with as many as the first pass's share of
 * admissible samples asks for. */
static void validate_kinds(const char *base, bbc_chain chain, long paths, uint32_t first) {
  static const char *const kinds[2] = {"sun", "spot"};
  for (int k = 0; k < 2; k++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s-%s.gltf", BBC_TEST_SCENES, base, kinds[k]);
    bbc_validation acc;
    bbc_validation_reset(&acc);
    validate_chain(path, chain, first, &acc);
    if ((long)acc.admissible < paths && acc.admissible > 0) {
      double need = 1.25 * (double)paths / (double)acc.admissible * first;
      uint32_t samples = need < (double)(1u << 22) ? (uint32_t)need + 1 : 1u << 22;
      bbc_validation_reset(&acc);
      validate_chain(path, chain, samples, &acc);
    }
    char label[64];
    snprintf(label, sizeof label, "%s %s %s", base, kinds[k], bbc_chain_name(chain));
    bbc_validation_print_summary(&acc, label, stderr);
    CHECK((long)acc.admissible >= paths);
    CHECK_INT(bbc_validation_failures(&acc), 0);
    CHECK_INT(acc.position_violations + acc.upper_violations + acc.lower_violations, 0);
    CHECK_INT(acc.in_discarded + acc.uncovered, 0);
  }
}

/* BBC_TEST_FULL=1: 10^6 true paths per light kind and chain type. */
TEST(bounds_hold_for_suns_and_spots_r) {
  validate_kinds("wavy-mirror", BBC_CHAIN_R, harness_scale(5000, 1000000), 40);
}
TEST(bounds_hold_for_suns_and_spots_t) {
  validate_kinds("pool", BBC_CHAIN_T, harness_scale(5000, 1000000), 64);
}
TEST(bounds_hold_for_suns_and_spots_rr) {
  validate_kinds("two-mirrors", BBC_CHAIN_RR, harness_scale(5000, 1000000), 20000);
}
TEST(bounds_hold_for_suns_and_spots_tt) {
  validate_kinds("glass-slab", BBC_CHAIN_TT, harness_scale(1000, 1000000), 48);
}

/* ---- several lights in one cache ----------------------------------------------------- */

/* A cache (of the emitters too when area_lights is set), and the caustic images it
 * gives (enumeration, spp samples per pixel) for seeds 5, 6, ...: images[0..count). */
static int cache_and_render_seeds(const bbc_scene *scene, const bbc_accel *accel, int area_lights,
                                  uint32_t spp, int count, bbc_image **images, uint32_t *tuples) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.chains = BBC_CHAIN_BIT(BBC_CHAIN_R);
  o.params.max_level = 5;
  o.params.grid_resolution = 64;
  o.params.area_lights = area_lights ? 1 : 0;
  bbc_cache_builder *b = NULL;
  void *bytes = NULL;
  size_t size = 0;
  bbc_cache *cache = NULL;
  if (bbc_precompute(&b, scene, &o, NULL) != BBC_OK) return 0;
  bbc_result r = bbc_cache_builder_write_memory(b, &bytes, &size, NULL);
  bbc_cache_builder_free(b);
  if (r != BBC_OK || bbc_cache_open_memory(&cache, bytes, size, NULL) != BBC_OK) {
    free(bytes);
    return 0;
  }
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  *tuples = info.tuple_count;
  int ok = 1;
  for (int k = 0; k < count; k++) {
    bbc_render_options ro;
    memset(&ro, 0, sizeof ro);
    ro.method = BBC_METHOD_ENUMERATE;
    ro.cache = cache;
    ro.spp = spp;
    ro.seed = 5 + (uint64_t)k;
    ro.components = BBC_COMPONENT_CAUSTICS;
    images[k] = NULL;
    if (bbc_image_create(&images[k], 40, 30) != BBC_OK ||
        bbc_render(scene, accel, &ro, images[k], NULL) != BBC_OK)
      ok = 0;
  }
  bbc_cache_close(cache);
  free(bytes);
  return ok;
}

/* The caustic image of a cache of the scene's point, spot and sun lights (enumeration, 2
 * spp, seed 5). */
static bbc_image *cache_and_render(const bbc_scene *scene, const bbc_accel *accel,
                                   uint32_t *tuples) {
  bbc_image *image = NULL;
  if (!cache_and_render_seeds(scene, accel, 0, 2, 1, &image, tuples)) {
    bbc_image_free(image);
    return NULL;
  }
  return image;
}

/* lights[0] a sun and lights[1] a spot (intensities left to the caller), both lighting
 * the flat mirror, the spot's cone edge across its caustic. */
static void sun_and_spot(bbc_point_light lights[2]) {
  lights[0].model.kind = BBC_LIGHT_DIRECTIONAL;
  lights[0].model.direction = v3_normalize(v3(-1, -1.5, 0.2));
  lights[1].model.kind = BBC_LIGHT_SPOT;
  lights[1].position = v3(1.2, 1.0, 0.5);
  lights[1].model.direction = v3_normalize(v3(-1.2, -0.6, -0.5));
  lights[1].model.cos_outer = cos(0.6);
  lights[1].model.cone_scale = 1.0 / (cos(0.3) - cos(0.6));
}

/* A sun, a spot and two point lights in one cache: it stores each light's tuples (the
 * union of the single-light caches) and its caustic image is the sum of the four
 * single-light images, pixel for pixel. The lights are set on the loaded flat mirror's
 * scene in memory. */
TEST(several_lights_in_one_cache) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, scene, NULL, NULL) == BBC_OK);
  bbc_point_light lights[4];
  memset(lights, 0, sizeof lights);
  sun_and_spot(lights);
  lights[2].position = v3(1, 1, 0);
  lights[3].position = v3(1.5, 0.7, -0.6);
  const float power[4][3] = {{2, 2, 2}, {8, 4, 2}, {5, 5, 5}, {1, 3, 2}};
  for (int i = 0; i < 4; i++) memcpy(lights[i].intensity, power[i], sizeof power[i]);
  bbc_point_light *own = scene->point_lights;
  const uint32_t own_count = scene->point_light_count;

  scene->point_lights = lights;
  scene->point_light_count = 4;
  uint32_t all_tuples = 0, sum_tuples = 0;
  bbc_image *all = cache_and_render(scene, accel, &all_tuples);
  REQUIRE(all);
  bbc_image *parts[4] = {NULL};
  for (int i = 0; i < 4; i++) {
    uint32_t n = 0;
    scene->point_lights = &lights[i];
    scene->point_light_count = 1;
    parts[i] = cache_and_render(scene, accel, &n);
    REQUIRE(parts[i]);
    CHECK(n > 0);
    sum_tuples += n;
  }
  scene->point_lights = own;
  scene->point_light_count = own_count;
  CHECK_INT(all_tuples, sum_tuples);
  double max_rel = 0, total = 0, lit[4] = {0};
  for (size_t k = 0; k < (size_t)all->width * all->height * 3; k++) {
    double sum = 0;
    for (int i = 0; i < 4; i++) sum += parts[i]->rgb[k], lit[i] += parts[i]->rgb[k];
    total += all->rgb[k];
    max_rel = fmax(max_rel, fabs(all->rgb[k] - sum) / fmax(sum, 1e-6));
  }
  fprintf(stderr, "%u tuples; per-light image sums %.4g %.4g %.4g %.4g; max relative diff %.3g\n",
          all_tuples, lit[0], lit[1], lit[2], lit[3], max_rel);
  for (int i = 0; i < 4; i++) CHECK(lit[i] > 0); /* every light has a caustic */
  CHECK(max_rel < 1e-5);
  CHECK(total > 0);
  for (int i = 0; i < 4; i++) bbc_image_free(parts[i]);
  bbc_image_free(all);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
}

/* A sun, a spot and two area lights (the two emissive triangles of the square lamp, each
 * a light of the cache) in one cache: its tuples are the union of the single-light
 * caches' and its caustic image the sum of the four single-light images. The lights are
 * set on the loaded area-light flat mirror's scene in memory; a single area light is the
 * scene with only that emitter. Area lights are estimated from random emitter points,
 * whose streams follow the tuple ids, so the images agree in expectation only: the sums
 * over each quarter of the image and over the whole are compared, by their means over
 * SEEDS seeds and the standard errors of those means. Dropping either area light from
 * the sum must fail. */
#define SEEDS 12
TEST(sun_spot_and_two_area_lights_in_one_cache) {
  bbc_scene *scene = NULL;
  REQUIRE(bbc_scene_load(&scene, TEST_SCENE("flat-mirror-area.gltf"), NULL) == BBC_OK);
  REQUIRE(scene->emitter_count == 2);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, scene, NULL, NULL) == BBC_OK);
  bbc_point_light lights[2];
  memset(lights, 0, sizeof lights);
  sun_and_spot(lights);
  const float power[2][3] = {{2, 2, 2}, {8, 4, 2}};
  for (int i = 0; i < 2; i++) memcpy(lights[i].intensity, power[i], sizeof power[i]);
  bbc_point_light *own = scene->point_lights;
  const uint32_t own_count = scene->point_light_count;
  uint32_t *own_emitters = scene->emitters;
  double *own_cdf = scene->emitter_cdf;
  double one = 1.0;

  /* sums[j][k][q]: image j (0 all lights, 1..4 one light each), seed k, region q (the
   * four quarters, then the whole image). */
  static double sums[5][SEEDS][5];
  uint32_t tuples[5] = {0};
  for (int j = 0; j < 5; j++) {
    const int i = j - 1; /* the single light, when j > 0 */
    scene->point_lights = j == 0 ? lights : i < 2 ? &lights[i] : NULL;
    scene->point_light_count = j == 0 ? 2 : i < 2 ? 1 : 0;
    scene->emitters = j == 0 ? own_emitters : i < 2 ? NULL : &own_emitters[i - 2];
    scene->emitter_count = j == 0 ? 2 : i < 2 ? 0 : 1;
    scene->emitter_cdf = j == 0 ? own_cdf : i < 2 ? NULL : &one;
    bbc_image *images[SEEDS] = {NULL};
    int ok = cache_and_render_seeds(scene, accel, j == 0 || i >= 2, 8, SEEDS, images, &tuples[j]);
    for (int k = 0; k < SEEDS; k++) {
      for (int q = 0; q < 5; q++) sums[j][k][q] = 0;
      for (uint32_t y = 0; ok && y < 30; y++)
        for (uint32_t x = 0; x < 40; x++) {
          const float *p = images[k]->rgb + 3 * ((size_t)y * 40 + x);
          double v = (double)p[0] + p[1] + p[2];
          sums[j][k][(y >= 15) * 2 + (x >= 20)] += v;
          sums[j][k][4] += v;
        }
      bbc_image_free(images[k]);
    }
    REQUIRE(ok);
    CHECK(tuples[j] > 0);
  }
  scene->point_lights = own;
  scene->point_light_count = own_count;
  scene->emitters = own_emitters;
  scene->emitter_count = 2;
  scene->emitter_cdf = own_cdf;
  CHECK_INT(tuples[0], tuples[1] + tuples[2] + tuples[3] + tuples[4]);

  /* z of (all - the sum of the parts but `drop`, 0 for none) in region q. */
  double worst = 0, dropped[2] = {1e30, 1e30};
  for (int drop = 0; drop <= 4; drop += (drop == 0 ? 3 : 1)) {
    for (int q = 0; q < 5; q++) {
      double diff = 0, var = 0;
      for (int j = 0; j < 5; j++) {
        if (j == drop && j > 0) continue;
        double mean = 0, m2 = 0;
        for (int k = 0; k < SEEDS; k++) mean += sums[j][k][q] / SEEDS;
        for (int k = 0; k < SEEDS; k++) m2 += (sums[j][k][q] - mean) * (sums[j][k][q] - mean);
        diff += j == 0 ? mean : -mean;
        var += m2 / (SEEDS - 1) / SEEDS;
      }
      double z = fabs(diff) / sqrt(var > 0 ? var : 1e-300);
      if (drop == 0) worst = fmax(worst, z);
      if (drop > 0 && q == 4) dropped[drop - 3] = z;
    }
  }
  double total[5] = {0};
  for (int j = 0; j < 5; j++)
    for (int k = 0; k < SEEDS; k++) total[j] += sums[j][k][4] / SEEDS;
  fprintf(stderr,
          "%u tuples; image sums: all %.4g, sun %.4g, spot %.4g, area lights %.4g %.4g; worst |z| "
          "%.2f; dropping area light 1 / 2: |z| %.1f / %.1f\n",
          tuples[0], total[0], total[1], total[2], total[3], total[4], worst, dropped[0],
          dropped[1]);
  for (int j = 1; j < 5; j++) CHECK(total[j] > 0); /* every light has a caustic */
  CHECK(worst < 5);
  CHECK(dropped[0] > 10 && dropped[1] > 10); /* the controls */
  bbc_accel_free(accel);
  bbc_scene_free(scene);
}
#undef SEEDS
