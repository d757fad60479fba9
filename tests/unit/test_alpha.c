/* glTF alphaMode: cut-outs (MASK) and coverage (BLEND) for every ray query, the caustic
 * estimator's specular vertices, the path tracer's shadows and the bound validation.
 *
 * The scene, written here as glTF: a floor at y = 0 (albedo 0.8), a unit square mirror
 * in the plane x = 0 (y in [0, 1], z in [-0.5, 0.5]) and a sun of irradiance E travelling
 * along (1, -1, 0) / sqrt 2. The mirror's texture is an 8 x 8 checker of alpha (texel
 * (i, j), column i from z = -0.5, row j from the top y = 1, has alpha 200/255 where
 * i + j is even and 60/255 where it is odd), NEAREST. Mirror point (0, y, z) reflects
 * the sun onto floor point (-y, 0, z) with irradiance E / sqrt 2, and shadows floor point
 * (y, 0, z). Expected values come from this geometry and the checker's rule, never from
 * the library's alpha lookups. A mirror's reflectance follows its base colour texture the
 * same way (an opaque colour checker). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "caustics_internal.h"
#include "floor_footprint.h"
#include "gltf_shim_internal.h"
#include "harness.h"
#include "media_internal.h"
#include "json_text.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846
#define SUN_E 2.0

/* 8 x 8 RGBA, white, alpha 200 where column + row is even, else 60. Written by Python's
 * zlib. */
#define PNG_CHECKER                                                                              \
  "iVBORw0KGgoAAAANSUhEUgAAAAgAAAAICAYAAADED76LAAAAGklEQVR42mP4////CSC2wUUz4JME0QzDwgQAlaXfwXz2" \
  "8YIAAAAASUVORK5CYII="
/* 2 x 1 RGBA: (255, 255, 255, 100), (0, 0, 0, 255). */
#define PNG_ALPHA_100                                                                            \
  "iVBORw0KGgoAAAANSUhEUgAAAAIAAAABCAYAAAD0In+KAAAAEUlEQVR42mP4//9/CgMDw38AF+cEYWQ3WlsAAAAASUVO" \
  "RK5CYII="
/* 2 x 1 RGBA, both texels (255, 255, 255, 255): an alpha channel with nothing in it. */
#define PNG_OPAQUE_RGBA                                                                  \
  "iVBORw0KGgoAAAANSUhEUgAAAAIAAAABCAYAAAD0In+KAAAAC0lEQVR42mP4DwUAI+UH+RmQD1QAAAAASUVO" \
  "RK5CYII="

/* 8 x 8 RGBA, opaque, (255, 64, 0) where column + row is even, else (32, 255, 128). */
#define PNG_COLOUR_CHECKER                                                                         \
  "iVBORw0KGgoAAAANSUhEUgAAAAgAAAAICAYAAADED76LAAAAHElEQVR42mP478DwX+F/w39cNAM+SRDNMCxMAAAV2JuBMj" \
  "dqpwAAAABJRU5ErkJggg=="

/* Whether mirror point (0, y, z) is there under MASK with cutoff 0.5: the checker's rule. */
static int present(double y, double z) {
  int i = (int)floor((z + 0.5) * 8), j = (int)floor((1 - y) * 8);
  return (i + j) % 2 == 0;
}

/* The sRGB curve, written out independently of the library. */
static double srgb(double c) {
  return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* Its alpha (BLEND coverage). */
static double checker_alpha(double y, double z) {
  return (present(y, z) ? 200 : 60) / 255.0;
}

/* ------------------------------------------------------------------ the scene */

/* The glTF text of the scene with the mirror's material given as JSON members after
 * its name (alphaMode, alphaCutoff, ...) and its baseColorFactor alpha; the texture's
 * PNG (base64) is the checker unless png says otherwise. Malloc'd. */
static char *scene_json(const char *mirror_members, double factor_alpha, const char *png) {
  static const float floor_p[4][3] = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}};
  static const float floor_n[4][3] = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  static const uint16_t floor_i[6] = {0, 2, 1, 0, 3, 2};
  static const float mirror_p[4][3] = {{0, 0, -0.5f}, {0, 0, 0.5f}, {0, 1, 0.5f}, {0, 1, -0.5f}};
  static const float mirror_n[4][3] = {{-1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}};
  /* s = z + 0.5, t = 1 - y: the image's top row at the mirror's top edge. */
  static const float mirror_uv[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  static const uint16_t mirror_i[6] = {0, 1, 2, 0, 2, 3};
  unsigned char buf[512];
  size_t at = 0, view[8], len[8];
  const void *parts[8] = {floor_p, floor_n, floor_i, mirror_p, mirror_n, mirror_uv, mirror_i, 0};
  const size_t sizes[7] = {sizeof floor_p,  sizeof floor_n,   sizeof floor_i, sizeof mirror_p,
                           sizeof mirror_n, sizeof mirror_uv, sizeof mirror_i};
  for (int k = 0; k < 7; k++) {
    view[k] = at, len[k] = sizes[k];
    memcpy(buf + at, parts[k], sizes[k]);
    at = (at + sizes[k] + 3) & ~(size_t)3;
  }
  json_text t = {0};
  json_printf(
      &t,
      "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"bbc\":{\"light_units\":\"radiometric\"}}},"
      "\"extensionsUsed\":[\"KHR_lights_punctual\"],\"extensions\":{\"KHR_lights_punctual\":"
      "{\"lights\":[{\"type\":\"directional\",\"intensity\":%g}]}},",
      SUN_E);
  /* The sun's -Z is (1, -1, 0) / sqrt 2; the camera at (0.5, 3, 0) looks straight down. */
  const double s = sqrt(0.5);
  json_printf(
      &t,
      "\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2,3]}],\"nodes\":[{\"name\":\"Floor\",\"mesh\":0},"
      "{\"name\":\"Mirror\",\"mesh\":1},{\"name\":\"Sun\",\"matrix\":[0,0,1,0,%.17g,%.17g,0,0,"
      "%.17g,%.17g,0,0,0,0,0,1],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
      "{\"name\":\"Camera\",\"camera\":0,\"matrix\":[1,0,0,0,0,0,-1,0,0,1,0,0,0.5,3,0,1]}],",
      s, s, -s, s);
  json_printf(&t,
              "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.3,\"znear\":0.01,"
              "\"aspectRatio\":1}}],");
  json_printf(&t,
              "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},"
              "\"indices\":2,\"material\":0}]},{\"primitives\":[{\"attributes\":{\"POSITION\":3,"
              "\"NORMAL\":4,\"TEXCOORD_0\":5},\"indices\":6,\"material\":1}]}],");
  json_printf(&t,
              "\"materials\":[{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
              "[0.8,0.8,0.8,1],\"metallicFactor\":0,\"roughnessFactor\":1}},{\"name\":\"Mirror\"%s,"
              "\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,%g],\"metallicFactor\":1,"
              "\"roughnessFactor\":0,\"baseColorTexture\":{\"index\":0}}}],",
              mirror_members, factor_alpha);
  json_printf(
      &t,
      "\"images\":[{\"uri\":\"data:image/png;base64,%s\"}],\"samplers\":[{\"magFilter\":9728,"
      "\"minFilter\":9728}],\"textures\":[{\"source\":0,\"sampler\":0}],",
      png ? png : PNG_CHECKER);
  json_printf(
      &t, "\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", at);
  json_base64(&t, buf, at);
  json_printf(&t, "\"}],\"bufferViews\":[");
  for (int k = 0; k < 7; k++)
    json_printf(&t, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", k ? "," : "", view[k],
                len[k]);
  json_printf(&t, "],\"accessors\":[");
  static const char *const types[7] = {"VEC3", "VEC3", "SCALAR", "VEC3", "VEC3", "VEC2", "SCALAR"};
  static const int counts[7] = {4, 4, 6, 4, 4, 4, 6};
  for (int k = 0; k < 7; k++) {
    int index = k == 2 || k == 6;
    json_printf(&t, "%s{\"bufferView\":%d,\"componentType\":%d,\"count\":%d,\"type\":\"%s\"",
                k ? "," : "", k, index ? 5123 : 5126, counts[k], types[k]);
    if (k == 0) json_printf(&t, ",\"min\":[-2,0,-2],\"max\":[2,0,2]");
    if (k == 3) json_printf(&t, ",\"min\":[0,0,-0.5],\"max\":[0,1,0.5]");
    json_printf(&t, "}");
  }
  json_printf(&t, "]}");
  return t.data;
}

typedef struct messages {
  int warnings;
  char warning[4][1024];
  char error[1024];
} messages;

static void on_warning(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  if (m->warnings < 4) snprintf(m->warning[m->warnings], sizeof m->warning[0], "%s", message);
  m->warnings++;
}

static void on_error(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  snprintf(m->error, sizeof m->error, "%s", message);
}

static bbc_scene *load(const char *mirror_members, double factor_alpha, const char *png,
                       messages *m, bbc_result *r) {
  char *json = scene_json(mirror_members, factor_alpha, png);
  memset(m, 0, sizeof *m);
  bbc_scene_options options = {on_error, on_warning, m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *s = NULL;
  *r = bbc__scene_load_memory(&s, json, strlen(json), "alpha.gltf", NULL, &options);
  free(json);
  return s;
}

/* The scene, its ray tracer and a cache of its R tuples (level 6, 128 x 128 grid). */
static int setup_png(fixture *f, const char *mirror_members, double factor_alpha, const char *png) {
  memset(f, 0, sizeof *f);
  messages m;
  bbc_result r;
  f->scene = load(mirror_members, factor_alpha, png, &m, &r);
  if (r != BBC_OK) {
    fprintf(stderr, "load: %s\n", m.error);
    return 0;
  }
  return bbc_accel_create(&f->accel, f->scene, NULL, NULL) == BBC_OK &&
         fixture_cache(f, f->scene, BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 128, 0);
}

static int setup(fixture *f, const char *mirror_members, double factor_alpha) {
  return setup_png(f, mirror_members, factor_alpha, NULL);
}

static uint32_t tuple_count(const bbc_cache *cache) {
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  return info.tuple_count;
}

#define MASK ",\"alphaMode\":\"MASK\""
#define BLEND ",\"alphaMode\":\"BLEND\""
#define OPAQUE ",\"alphaMode\":\"OPAQUE\""

/* ------------------------------------------------------------------ loading */

/* alphaMode, alphaCutoff (default 0.5) and the factor's alpha reach the material; the
 * texture's alpha channel is kept for MASK and BLEND only, in linear units: alpha 100
 * is 100/255 = 0.392 (decoded as sRGB it would be 0.127, below a cutoff of 0.3). */
TEST(alpha_mode_cutoff_and_linear_alpha_are_read) {
  messages m;
  bbc_result r;
  bbc_scene *s = load(MASK ",\"alphaCutoff\":0.3", 0.9, PNG_ALPHA_100, &m, &r);
  REQUIRE(r == BBC_OK);
  const bbc_material *mat = &s->materials[1];
  CHECK_INT(mat->alpha_mode, BBC_ALPHA_MASK);
  CHECK_NEAR(mat->alpha_cutoff, 0.3, 1e-7);
  CHECK_NEAR(mat->alpha, 0.9, 1e-7);
  REQUIRE(s->texture_count == 1 && s->textures[0].alpha != NULL);
  CHECK_NEAR(s->textures[0].alpha[0], 100 / 255.0, 1e-7);
  CHECK_NEAR(s->textures[0].alpha[1], 1.0, 0);
  /* Mirror point (0, 0.5, -0.25) has s = 0.25: texel 0. */
  uint32_t t = s->meshes[1].first_triangle;
  bbc_hit hit;
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  REQUIRE(bbc_accel_intersect(accel, v3(-1, 0.5, -0.25), v3(1, 0, 0), 0, 10, &hit));
  t = hit.triangle;
  CHECK_INT(s->meshes[s->triangle_mesh[t]].material, 1);
  CHECK_NEAR(bbc_scene_alpha(s, t, hit.u, hit.v), 0.9 * 100 / 255.0, 1e-6);
  CHECK_NEAR(bbc_scene_coverage(s, t, hit.u, hit.v), 1.0, 0); /* 0.353 >= 0.3 */
  bbc_accel_free(accel);
  bbc_scene_free(s);

  s = load(MASK, 1, PNG_ALPHA_100, &m, &r);
  REQUIRE(r == BBC_OK);
  CHECK_NEAR(s->materials[1].alpha_cutoff, 0.5, 0);
  CHECK_INT(m.warnings, 0);
  bbc_scene_free(s);

  /* OPAQUE (also the default) drops the channel; so does a channel of 255s. */
  const char *opaque[2] = {OPAQUE, ""};
  for (int k = 0; k < 2; k++) {
    s = load(opaque[k], 0.2, PNG_ALPHA_100, &m, &r);
    REQUIRE(r == BBC_OK);
    CHECK_INT(s->materials[1].alpha_mode, BBC_ALPHA_OPAQUE);
    CHECK(s->textures[0].alpha == NULL);
    CHECK_NEAR(bbc_scene_coverage(s, s->meshes[1].first_triangle, 0.2, 0.2), 1.0, 0);
    bbc_scene_free(s);
  }
  s = load(MASK, 1, PNG_OPAQUE_RGBA, &m, &r);
  REQUIRE(r == BBC_OK);
  CHECK(s->textures[0].alpha == NULL);
  bbc_scene_free(s);

  /* BLEND is read as coverage and says so, once, naming the material. */
  s = load(BLEND, 0.3, PNG_OPAQUE_RGBA, &m, &r);
  REQUIRE(r == BBC_OK);
  CHECK_INT(s->materials[1].alpha_mode, BBC_ALPHA_BLEND);
  CHECK_INT(m.warnings, 1);
  CHECK_STR_CONTAINS(m.warning[0],
                     "material 1 (\"Mirror\"): alphaMode BLEND is rendered as coverage");
  CHECK_NEAR(bbc_scene_coverage(s, s->meshes[1].first_triangle, 0.2, 0.2), 0.3, 1e-7);
  bbc_scene_free(s);

  /* What glTF does not allow. */
  s = load(",\"alphaMode\":\"CLIP\"", 1, NULL, &m, &r);
  CHECK_INT(r, BBC_ERR_GLTF);
  CHECK(s == NULL);
  CHECK_STR_CONTAINS(m.error, "material 1 (\"Mirror\"): alphaMode \"CLIP\" is not OPAQUE, MASK");
  s = load(MASK ",\"alphaCutoff\":-0.5", 1, NULL, &m, &r);
  CHECK_INT(r, BBC_ERR_GLTF);
  CHECK_STR_CONTAINS(m.error, "alphaCutoff -0.5 is not a number >= 0");
}

/* ------------------------------------------------------------------ ray queries */

/* Rays through the mirror's plane along +x at the centres of a 32 x 32 grid of points:
 * under MASK, intersect and occluded meet the mirror exactly where the checker says it
 * is there (the control: OPAQUE meets it everywhere); under BLEND a ray is stopped with
 * probability alpha, measured over many rays per cell. */
TEST(masked_surface_is_skipped_by_every_query) {
  messages m;
  bbc_result r;
  const char *modes[2] = {MASK, OPAQUE};
  for (int k = 0; k < 2; k++) {
    bbc_scene *s = load(modes[k], 1, NULL, &m, &r);
    REQUIRE(r == BBC_OK);
    bbc_accel *accel = NULL;
    REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
    int hits = 0, wrong = 0, n = 0;
    for (int a = 0; a < 32; a++)
      for (int b = 0; b < 32; b++) {
        double y = (a + 0.5) / 32, z = (b + 0.5) / 32 - 0.5;
        bbc_hit hit;
        int h = bbc_accel_intersect(accel, v3(-1, y, z), v3(1, 0, 0), 0, 10, &hit);
        int o = bbc_accel_occluded(accel, v3(-1, y, z), v3(1, 0, 0), 0, 10);
        int expect = k == 1 || present(y, z);
        wrong += h != expect || o != expect || (h && !(fabs(hit.t - 1) < 1e-6));
        hits += h;
        n++;
      }
    fprintf(stderr, "%s: %d of %d rays meet the mirror, %d wrong\n", k ? "OPAQUE" : "MASK", hits, n,
            wrong);
    CHECK_INT(wrong, 0);
    CHECK_INT(hits, k ? n : n / 2);
    bbc_accel_free(accel);
    bbc_scene_free(s);
  }

  /* BLEND: per cell, 400 rays from slightly different origins; the share stopped is the
   * cell's alpha (200/255 or 60/255) within 5 standard deviations of a binomial count. */
  bbc_scene *s = load(BLEND, 1, NULL, &m, &r);
  REQUIRE(r == BBC_OK);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  double worst = 0;
  long stopped_total = 0, n_total = 0;
  double expected_total = 0;
  for (int a = 0; a < 8; a++)
    for (int b = 0; b < 8; b++) {
      double y = (a + 0.5) / 8, z = (b + 0.5) / 8 - 0.5, alpha = checker_alpha(y, z);
      int stopped = 0;
      const int n = 400;
      for (int i = 0; i < n; i++) {
        bbc_vec3 o = v3(-1, y + 0.05 * ((i % 20) / 20.0 - 0.5), z + 0.05 * ((i / 20) / 20.0 - 0.5));
        stopped += bbc_accel_occluded(accel, o, v3(1, 0, 0), 0, 10);
        /* One ray always decides alike. */
        if (i == 0) CHECK_INT(bbc_accel_occluded(accel, o, v3(1, 0, 0), 0, 10), stopped);
      }
      double zscore = (stopped - n * alpha) / sqrt(n * alpha * (1 - alpha));
      worst = fmax(worst, fabs(zscore));
      stopped_total += stopped, n_total += n, expected_total += n * alpha;
    }
  fprintf(stderr, "BLEND: %ld of %ld rays stopped (expected %.1f), worst cell |z| %.2f\n",
          stopped_total, n_total, expected_total, worst);
  CHECK(worst < 5);
  bbc_accel_free(accel);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ caustics */

/* The floor point mirror point (0, y, z) reflects the sun to, with its triangle and
 * barycentrics (the floor's hit seen from above). */
typedef struct floor_point {
  bbc_vec3 p;
  uint32_t triangle;
  double b1, b2;
} floor_point;

static floor_point floor_below(const fixture *f, double y, double z) {
  floor_point q;
  bbc_hit hit;
  q.p = v3(-y, 0, z);
  if (!bbc_accel_intersect(f->accel, v3(-y, 5, z), v3(0, -1, 0), 0, 10, &hit))
    harness_fail(__FILE__, __LINE__, "no floor under (%g, %g)", -y, z);
  q.triangle = hit.triangle, q.b1 = hit.u, q.b2 = hit.v;
  return q;
}

/* The caustic irradiance at q (red channel), every tuple of its cell enumerated: exact. */
static double caustic_at(const fixture *f, bbc__caustics_thread *t, floor_point q) {
  bbc__caustics c;
  memset(&c, 0, sizeof c);
  c.scene = f->scene;
  c.accel = f->accel;
  c.passable = bbc__media_passable(c.scene);
  c.cache = f->cache;
  c.tuples = bbc_cache_tuples(f->cache);
  c.chains = BBC_CHAIN_MASK_ALL;
  c.sampling.method = BBC__SAMPLE_ENUMERATE;
  return bbc__caustics_estimate(&c, t, q.p, v3(0, 1, 0), q.triangle, q.b1, q.b2, 2, 1, NULL).x;
}

/* The masked mirror's caustic against the exact answer. At 9 points per checker cell
 * the unmasked mirror (OPAQUE) gives E / sqrt 2; the masked one
 * (MASK) gives exactly that where the cell is there and 0 where it is cut out, and
 * BLEND gives it times the cell's alpha. So over each quadrant of the mirror's image on
 * the floor (a union of 16 whole cells' images) the average is the unmasked average
 * times the mask's average there, 1/2 (BLEND: (200 + 60) / 2 / 255). The control: the
 * unmasked mirror's ratio is 1, which the check rejects. */
TEST(masked_mirror_caustic_is_unmasked_times_mask_average) {
  fixture f[3];
  const char *modes[3] = {OPAQUE, MASK, BLEND}, *names[3] = {"OPAQUE", "MASK", "BLEND"};
  for (int k = 0; k < 3; k++) REQUIRE(setup(&f[k], modes[k], 1));
  bbc__caustics_thread t[3];
  for (int k = 0; k < 3; k++) REQUIRE(bbc__caustics_thread_init(&t[k], f[k].cache) == BBC_OK);
  const double full = SUN_E * sqrt(0.5);
  double sum[3][4] = {{0}}, mask_sum[2][4] = {{0}};
  int bad[3] = {0, 0, 0}, points = 0;
  for (int j = 0; j < 8; j++)
    for (int i = 0; i < 8; i++)
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
          /* Off-centre, so that no point lies on the diagonal the mirror's two
           * triangles share (where both would count it). */
          double y = 1 - (j + (b + 0.3) / 3) / 8, z = (i + (a + 0.3) / 3) / 8 - 0.5;
          int quadrant = (i >= 4) + 2 * (j >= 4);
          const double expect[3] = {full, full * present(y, z), full * checker_alpha(y, z)};
          for (int k = 0; k < 3; k++) {
            double e = caustic_at(&f[k], &t[k], floor_below(&f[k], y, z));
            sum[k][quadrant] += e;
            if (!(fabs(e - expect[k]) <= 1e-6 * full) && bad[k]++ < 3)
              fprintf(stderr, "%s at mirror (%g, %g): %.9g, expected %.9g\n", names[k], y, z, e,
                      expect[k]);
          }
          mask_sum[0][quadrant] += present(y, z);
          mask_sum[1][quadrant] += checker_alpha(y, z);
          points++;
        }
  fprintf(stderr, "%d points; off: OPAQUE %d, MASK %d, BLEND %d\n", points, bad[0], bad[1], bad[2]);
  for (int k = 0; k < 3; k++) CHECK_INT(bad[k], 0);
  for (int q = 0; q < 4; q++) {
    const double n = points / 4.0;
    const double mask_avg = mask_sum[0][q] / n, blend_avg = mask_sum[1][q] / n;
    CHECK_NEAR(mask_avg, 0.5, 1e-12);
    CHECK_NEAR(blend_avg, 130 / 255.0, 1e-12);
    const double unmasked = sum[0][q] / n;
    CHECK_NEAR(unmasked, full, 1e-6 * full);
    fprintf(stderr,
            "quadrant %d: unmasked %.9g, MASK %.9g (ratio %.9f, mask average %.3f), BLEND "
            "%.9g (ratio %.9f, alpha average %.6f)\n",
            q, unmasked, sum[1][q] / n, sum[1][q] / sum[0][q], mask_avg, sum[2][q] / n,
            sum[2][q] / sum[0][q], blend_avg);
    CHECK_NEAR(sum[1][q] / n, unmasked * mask_avg, 1e-6 * full);
    CHECK_NEAR(sum[2][q] / n, unmasked * blend_avg, 1e-6 * full);
    /* Control: a renderer that ignored the mask would give the unmasked average. */
    CHECK(fabs(sum[0][q] / n - unmasked * mask_avg) > 0.4 * full);
  }
  for (int k = 0; k < 3; k++) {
    bbc__caustics_thread_free(&t[k]);
    teardown(&f[k]);
  }
}

/* A mirror's reflectance is its base colour at the reflecting point, texture included:
 * with the opaque colour checker, the caustic at every point is E / sqrt 2 times the
 * sRGB-decoded colour of the cell it comes from. The control: the factor alone (white)
 * would give E / sqrt 2 in every channel, which the check rejects. */
TEST(mirror_reflectance_follows_its_base_colour_texture) {
  fixture f;
  REQUIRE(setup_png(&f, OPAQUE, 1, PNG_COLOUR_CHECKER));
  bbc__caustics_thread t;
  REQUIRE(bbc__caustics_thread_init(&t, f.cache) == BBC_OK);
  bbc__caustics c;
  memset(&c, 0, sizeof c);
  c.scene = f.scene;
  c.accel = f.accel;
  c.passable = bbc__media_passable(c.scene);
  c.cache = f.cache;
  c.tuples = bbc_cache_tuples(f.cache);
  c.chains = BBC_CHAIN_MASK_ALL;
  c.sampling.method = BBC__SAMPLE_ENUMERATE;
  const double full = SUN_E * sqrt(0.5);
  const double even[3] = {1.0, srgb(64 / 255.0), 0.0};
  const double odd[3] = {srgb(32 / 255.0), 1.0, srgb(128 / 255.0)};
  int bad = 0, points = 0;
  for (int j = 0; j < 8; j++)
    for (int i = 0; i < 8; i++) {
      double y = 1 - (j + 0.37) / 8, z = (i + 0.41) / 8 - 0.5;
      floor_point q = floor_below(&f, y, z);
      bbc_vec3 e =
          bbc__caustics_estimate(&c, &t, q.p, v3(0, 1, 0), q.triangle, q.b1, q.b2, 2, 1, NULL);
      const double *want = present(y, z) ? even : odd;
      const double got[3] = {e.x, e.y, e.z};
      for (int k = 0; k < 3; k++) {
        if (!(fabs(got[k] - full * want[k]) <= 1e-6 * full) && bad++ < 3)
          fprintf(stderr, "mirror (%g, %g) channel %d: %.9g, expected %.9g\n", y, z, k, got[k],
                  full * want[k]);
        /* Control: the factor alone would reflect every channel whole. */
        if (want[k] < 0.9) CHECK(fabs(full - full * want[k]) > 0.1 * full);
      }
      points++;
    }
  CHECK_INT(points, 64);
  CHECK_INT(bad, 0);
  bbc__caustics_thread_free(&t);
  teardown(&f);
}

/* ------------------------------------------------------------------ shadows and renders */

/* The floor's direct light behind the mirror (x > 0), seen from above: the sun's
 * E / sqrt 2 times albedo / pi where the mirror point (0, x, z) in front of it is cut
 * out, 0 where the mirror is there. `ignore` (the control) treats the mirror as whole. */
typedef struct shadow_case {
  int ignore;
} shadow_case;

static double shadow_value(const void *user, bbc_vec3 p) {
  const shadow_case *c = user;
  if (!(p.x > 0 && p.x < 1 && p.z > -0.5 && p.z < 0.5)) return -1;
  int lit = !c->ignore && !present(p.x, p.z);
  return lit ? SUN_E * sqrt(0.5) * 0.8 / PI : 0.0;
}

/* A path-traced render of the floor behind the masked mirror (direct light only; a delta
 * sun makes every sample exact): each pixel lies between the least and greatest exact
 * value over its footprint, and pixels wholly inside one cell's shadow are either fully
 * lit or black. The control (the mirror taken as whole) fails for the lit ones. */
TEST(masked_occluder_shadows_only_where_present) {
  fixture f;
  REQUIRE(setup(&f, MASK, 1));
  const uint32_t w = 32, h = 32;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_PT;
  o.spp = 1;
  o.seed = 3;
  o.components = BBC_COMPONENT_DIRECT;
  bbc_image *image = NULL;
  REQUIRE(bbc_image_create(&image, w, h) == BBC_OK);
  REQUIRE(bbc_render(f.scene, f.accel, &o, image, NULL) == BBC_OK);
  const double box[4] = {0.01, 0.99, -0.49, 0.49};
  int checked = 0, bad = 0, lit = 0, dark = 0, control_bad = 0;
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++) {
      double lo, hi, clo, chi;
      shadow_case sc = {0}, control = {1};
      if (!floor_footprint_range(f.scene, f.accel, w, h, x, y, box, shadow_value, &sc, &lo, &hi))
        continue;
      floor_footprint_range(f.scene, f.accel, w, h, x, y, box, shadow_value, &control, &clo, &chi);
      double got = image->rgb[3 * ((size_t)y * w + x)];
      checked++;
      int ok = got >= lo * (1 - 1e-4) - 1e-12 && got <= hi * (1 + 1e-4) + 1e-12;
      if (!ok && bad++ < 5)
        fprintf(stderr, "pixel (%u,%u): %.9g not in [%.9g, %.9g]\n", x, y, got, lo, hi);
      if (lo == hi) {
        lit += lo > 0;
        dark += lo == 0;
      }
      control_bad += !(got >= clo * (1 - 1e-4) - 1e-12 && got <= chi * (1 + 1e-4) + 1e-12);
    }
  fprintf(stderr, "%d pixels checked, %d off; %d wholly lit, %d wholly shadowed; control: %d off\n",
          checked, bad, lit, dark, control_bad);
  CHECK(checked > 700);
  CHECK_INT(bad, 0);
  CHECK(lit > 100 && dark > 100);
  CHECK(control_bad >= lit);
  bbc_image_free(image);
  teardown(&f);
}

/* The whole render (camera rays, shadows, the caustic estimator, BLEND's coin flips) is
 * bit-identical for 1 and 2 threads, with MASK and with BLEND. The camera looks down on
 * the mirror's top edge from (0, 2.5, 0), seeing its caustic (x < 0) and its shadow. */
TEST(render_is_thread_independent) {
  const char *modes[2] = {MASK, BLEND};
  for (int k = 0; k < 2; k++) {
    fixture f;
    REQUIRE(setup(&f, modes[k], 1));
    bbc_image *images[2] = {NULL, NULL};
    bbc_camera camera = f.scene->camera;
    camera.position = v3(0, 2.5, 0);
    camera.yfov = 0.8;
    for (int threads = 1; threads <= 2; threads++) {
      bbc_render_options o;
      memset(&o, 0, sizeof o);
      o.method = BBC_METHOD_BBC;
      o.spp = 4;
      o.seed = 11;
      o.threads = threads;
      o.cache = f.cache;
      o.camera = &camera;
      REQUIRE(bbc_image_create(&images[threads - 1], 24, 24) == BBC_OK);
      REQUIRE(bbc_render(f.scene, f.accel, &o, images[threads - 1], NULL) == BBC_OK);
    }
    CHECK(memcmp(images[0]->rgb, images[1]->rgb, sizeof(float) * 3 * 24 * 24) == 0);
    /* The caustic is in view: the left half (x < 0) is brighter than the right, which has
     * the sun alone, in part shadowed. */
    double left = 0, right = 0;
    for (uint32_t y = 0; y < 24; y++)
      for (uint32_t x = 0; x < 24; x++)
        *(x < 12 ? &left : &right) += images[0]->rgb[3 * (y * 24 + x)];
    fprintf(stderr, "%s: left half %.4g, right half %.4g\n", k ? "BLEND" : "MASK", left, right);
    CHECK(left > right && right > 0);
    for (int i = 0; i < 2; i++) bbc_image_free(images[i]);
    teardown(&f);
  }
}

/* ------------------------------------------------------------------ validation */

/* bbc-inspect check-bounds counts a true path only where its vertex is there: for every
 * tuple of the masked mirror's cache and 200 samples, a sample is admissible exactly
 * when it is admissible for the unmasked mirror and its mirror point is not cut out
 * (samples told apart by validating the first n and the first n + 1), and no path breaks
 * a bound. */
TEST(validation_skips_paths_through_cut_outs) {
  fixture f[2];
  REQUIRE(setup(&f[0], OPAQUE, 1));
  REQUIRE(setup(&f[1], MASK, 1));
  REQUIRE(tuple_count(f[0].cache) == tuple_count(f[1].cache));
  bbc_cache_cursor *cursor[2];
  for (int k = 0; k < 2; k++) REQUIRE(bbc_cache_cursor_create(&cursor[k], f[k].cache) == BBC_OK);
  const uint32_t samples = 200;
  uint64_t expected = 0, admissible[2] = {0, 0}, failing = 0;
  const bbc_tuple *tuples = bbc_cache_tuples(f[0].cache);
  for (uint32_t id = 0; id < tuple_count(f[0].cache); id++) {
    const bbc_tuple *tuple = &tuples[id];
    uint64_t before = 0;
    for (uint32_t n = 1; n <= samples; n++) {
      bbc_validation acc;
      bbc_validation_reset(&acc);
      REQUIRE(bbc_validate_cached_tuple(f[0].cache, cursor[0], f[0].scene, tuple, id, n, 9, &acc) ==
              BBC_OK);
      if (acc.admissible > before) {
        double u1[2];
        bbc_validation_sample_u1(9, tuple, n - 1, u1);
        const uint32_t *idx = f[0].scene->indices + 3 * (size_t)tuple->specular[0];
        bbc_vec3 p[3];
        for (int c = 0; c < 3; c++) p[c] = v3_load(f[0].scene->positions + 3 * (size_t)idx[c]);
        bbc_vec3 x = v3_add(
            p[0], v3_add(v3_scale(v3_sub(p[1], p[0]), u1[0]), v3_scale(v3_sub(p[2], p[0]), u1[1])));
        expected += present(x.y, x.z);
      }
      before = acc.admissible;
    }
    for (int k = 0; k < 2; k++) {
      bbc_validation acc;
      bbc_validation_reset(&acc);
      REQUIRE(bbc_validate_cached_tuple(f[k].cache, cursor[k], f[k].scene, tuple, id, samples, 9,
                                        &acc) == BBC_OK);
      admissible[k] += acc.admissible;
      failing += acc.failing;
    }
  }
  fprintf(stderr, "admissible paths: unmasked %llu, masked %llu (expected %llu); %llu failing\n",
          (unsigned long long)admissible[0], (unsigned long long)admissible[1],
          (unsigned long long)expected, (unsigned long long)failing);
  CHECK(admissible[0] > 200);
  CHECK_INT(admissible[1], expected);
  CHECK(admissible[1] < admissible[0] * 0.7 && admissible[1] > admissible[0] * 0.3);
  CHECK_INT(failing, 0);
  for (int k = 0; k < 2; k++) {
    bbc_cache_cursor_free(cursor[k]);
    teardown(&f[k]);
  }
}
