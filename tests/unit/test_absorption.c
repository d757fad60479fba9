/* Beer-Lambert absorption inside dielectrics (KHR_materials_volume attenuationColor and
 * attenuationDistance) and the base-colour tint of transmission (KHR_materials_transmission),
 * in the loader, the caustic estimator and the path tracer.
 *
 * The scene, written here: a glass box (ior 1.5, faces flat with flat normals, x and z in
 * [-1, 1], y in [0.5, 0.5 + d]) over a diffuse floor (y = 0, [-0.8, 0.8]^2, albedo a,
 * wholly in the box's shadow even for a sun 20 degrees across), under a sun travelling
 * straight down (-y) with irradiance E; a camera at (0, 0.3, 0) between floor and glass
 * looks straight down at the floor, so that what it sees is lit through the glass only.
 * At normal incidence the light is not bent and its beam keeps its cross-section, so the
 * floor receives exactly
 *   E_floor = E (1 - R)^2 tint^2 exp(-sigma d),  R = ((n - 1) / (n + 1))^2 = 0.04,
 * one Fresnel transmission and one tint each way in and out, sigma = -ln(c) / D per
 * channel, and a floor pixel's radiance is a / pi E_floor. The oracle's Fresnel is the
 * textbook one, not the library's. */
#include <float.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "box_mesh.h"
#include "gltf_shim_internal.h"
#include "harness.h"
#include "json_text.h"
#include "render_fixture.h"

#define PI 3.14159265358979323846

/* ------------------------------------------------------------------ the scene */

typedef struct slab_scene {
  double d;           /* the box's thickness */
  double tint[3];     /* its baseColorFactor */
  const char *volume; /* members of its KHR_materials_volume after thicknessFactor, e.g.
                         "\"attenuationColor\":[0.1,0.5,0.9],\"attenuationDistance\":0.4";
                         NULL for none */
  double sun_angle;   /* the sun's angular diameter in degrees; 0: a delta sun */
  double albedo;      /* the floor's */
  uint32_t size;      /* the film's width and height */
} slab_scene;

/* The glTF text of the scene (malloc'd). */
static char *slab_gltf(const slab_scene *q) {
  box_mesh floor, box;
  memset(&floor, 0, sizeof floor);
  memset(&box, 0, sizeof box);
  const double flo[3] = {-0.8, 0, -0.8}, fhi[3] = {0.8, 0, 0.8};
  add_face(&floor, 1, 1, flo, fhi);
  const double blo[3] = {-1, 0.5, -1}, bhi[3] = {1, 0.5 + q->d, 1};
  for (int a = 0; a < 3; a++)
    for (int s = -1; s <= 1; s += 2) add_face(&box, a, s, blo, bhi);
  /* Buffer: floor positions, normals, indices; then the box's. */
  unsigned char buf[2 * sizeof(box_mesh)];
  size_t view[6][2];
  const box_mesh *m[2] = {&floor, &box};
  const size_t at = box_meshes_pack(m, 2, buf, view);
  const char *turn = "\"rotation\":[-0.7071067811865476,0,0,0.7071067811865476]";
  json_text t = {0};
  json_printf(
      &t,
      "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"bbc\":{\"light_units\":\"radiometric\"}}},"
      "\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_materials_transmission\","
      "\"KHR_materials_volume\",\"KHR_materials_ior\"],"
      "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":\"sun\","
      "\"type\":\"directional\",\"color\":[1,1,1],\"intensity\":1");
  if (q->sun_angle > 0)
    json_printf(&t, ",\"extras\":{\"bbc\":{\"angular_diameter\":%.17g}}", q->sun_angle);
  json_printf(&t,
              "}]}},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2,3]}],\"nodes\":["
              "{\"name\":\"floor\",\"mesh\":0,\"extras\":{\"bbc\":{\"role\":\"receiver\"}}},"
              "{\"name\":\"glass\",\"mesh\":1,\"extras\":{\"bbc\":{\"role\":\"caster\"}}},"
              "{\"name\":\"sun\",%s,\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
              "{\"name\":\"camera\",\"camera\":0,\"translation\":[0,0.3,0],%s,"
              "\"extras\":{\"bbc\":{\"width\":%u,\"height\":%u}}}],",
              turn, turn, q->size, q->size);
  json_printf(&t,
              "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.6,"
              "\"aspectRatio\":1,\"znear\":0.01}}],");
  json_printf(&t,
              "\"materials\":[{\"name\":\"floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
              "[%.17g,%.17g,%.17g,1],\"metallicFactor\":0,\"roughnessFactor\":1}},",
              q->albedo, q->albedo, q->albedo);
  json_printf(&t,
              "{\"name\":\"tinted glass\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
              "[%.17g,%.17g,%.17g,1],\"metallicFactor\":0,\"roughnessFactor\":0},\"extensions\":{"
              "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
              "\"KHR_materials_volume\":{\"thicknessFactor\":%.17g%s%s},"
              "\"KHR_materials_ior\":{\"ior\":1.5}}}],",
              q->tint[0], q->tint[1], q->tint[2], q->d, q->volume ? "," : "",
              q->volume ? q->volume : "");
  json_printf(&t, "\"meshes\":[");
  for (int k = 0; k < 2; k++)
    json_printf(&t,
                "%s{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d},\"indices\":%d,"
                "\"material\":%d,\"mode\":4}]}",
                k ? "," : "", 3 * k, 3 * k + 1, 3 * k + 2, k);
  json_printf(&t, "],\"accessors\":[");
  for (int k = 0; k < 2; k++) {
    const double *lo = k ? blo : flo, *hi = k ? bhi : fhi;
    int nv = 4 * m[k]->faces;
    json_printf(&t,
                "%s{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\","
                "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},"
                "{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"},"
                "{\"bufferView\":%d,\"componentType\":5125,\"count\":%d,\"type\":\"SCALAR\"}",
                k ? "," : "", 3 * k, nv, (float)lo[0], (float)lo[1], (float)lo[2], (float)hi[0],
                (float)hi[1], (float)hi[2], 3 * k + 1, nv, 3 * k + 2, 6 * m[k]->faces);
  }
  json_printf(&t, "],\"bufferViews\":[");
  for (int v = 0; v < 6; v++)
    json_printf(&t, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", v ? "," : "",
                view[v][0], view[v][1]);
  json_printf(
      &t, "],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", at);
  json_base64(&t, buf, at);
  json_printf(&t, "\"}]}");
  return t.data;
}

typedef struct messages {
  int errors, warnings;
  char error[1024], warning[1024];
} messages;

static void on_error(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  m->errors++;
  snprintf(m->error, sizeof m->error, "%s", message);
}

static void on_warning(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  m->warnings++;
  snprintf(m->warning, sizeof m->warning, "%s", message);
}

static bbc_result load(const slab_scene *q, bbc_scene **out, messages *m) {
  char *json = slab_gltf(q);
  memset(m, 0, sizeof *m);
  bbc_scene_options o = {on_error, on_warning, m, BBC_LIGHT_UNITS_FILE};
  bbc_result r = bbc__scene_load_memory(out, json, strlen(json), "slab.gltf", NULL, &o);
  free(json);
  return r;
}

/* A delta sun, an absorbing tinted box of thickness 0.2: c^(d / D) = c^0.5. */
static slab_scene default_slab(void) {
  slab_scene q = {0.2, {0.9, 0.8, 0.7}, NULL, 0, 0.5, 8};
  q.volume = "\"attenuationColor\":[0.1,0.5,0.9],\"attenuationDistance\":0.4";
  return q;
}

/* The glass material of a loaded slab scene. */
static const bbc_material *glass(const bbc_scene *s) {
  for (uint32_t i = 0; i < s->material_count; i++)
    if (s->materials[i].type == BBC_MATERIAL_DIELECTRIC) return &s->materials[i];
  return NULL;
}

/* ------------------------------------------------------------------ the loader */

/* absorption = -ln(attenuationColor) / attenuationDistance, as floats. */
TEST(loader_reads_attenuation) {
  slab_scene q = default_slab();
  bbc_scene *s = NULL;
  messages m;
  REQUIRE(load(&q, &s, &m) == BBC_OK);
  const bbc_material *g = glass(s);
  REQUIRE(g != NULL);
  const double c[3] = {0.1, 0.5, 0.9};
  for (int k = 0; k < 3; k++) CHECK(g->absorption[k] == (float)(-log(c[k]) / 0.4));
  CHECK_INT(m.warnings, 0);
  /* The floor, a diffuse material, absorbs nothing. */
  for (uint32_t i = 0; i < s->material_count; i++)
    if (s->materials[i].type != BBC_MATERIAL_DIELECTRIC)
      for (int k = 0; k < 3; k++) CHECK(s->materials[i].absorption[k] == 0.0f);
  bbc_scene_free(s);

  /* No attenuationDistance (glTF: infinite), or no attenuation at all: nothing absorbed;
   * a colour of 1 neither. */
  const char *none[] = {NULL, "\"attenuationColor\":[0.1,0.5,0.9]",
                        "\"attenuationColor\":[1,1,1],\"attenuationDistance\":0.01",
                        "\"attenuationDistance\":2"};
  for (int v = 0; v < 4; v++) {
    q.volume = none[v];
    s = NULL;
    REQUIRE(load(&q, &s, &m) == BBC_OK);
    for (int k = 0; k < 3; k++) CHECK(glass(s)->absorption[k] == 0.0f);
    CHECK_INT(m.warnings, 0);
    bbc_scene_free(s);
  }
}

/* A colour channel of 0 absorbs that channel entirely: FLT_MAX, with a warning naming
 * the material; the other channels keep their coefficients. */
TEST(loader_zero_attenuation_channel_is_opaque) {
  slab_scene q = default_slab();
  q.volume = "\"attenuationColor\":[0,0.5,1],\"attenuationDistance\":2";
  bbc_scene *s = NULL;
  messages m;
  REQUIRE(load(&q, &s, &m) == BBC_OK);
  CHECK(glass(s)->absorption[0] == FLT_MAX);
  CHECK(glass(s)->absorption[1] == (float)(log(2.0) / 2));
  CHECK(glass(s)->absorption[2] == 0.0f);
  CHECK_INT(m.warnings, 1);
  CHECK_STR_CONTAINS(m.warning, "\"tinted glass\"");
  CHECK_STR_CONTAINS(m.warning, "attenuationColor");
  bbc_scene_free(s);
}

/* Out-of-range values are refused in one line naming the material. */
TEST(loader_rejects_bad_attenuation) {
  static const struct {
    const char *volume, *what;
    bbc_result code;
  } bad[] = {
      {"\"attenuationColor\":[0.1,1.5,0.9],\"attenuationDistance\":1", "attenuationColor",
       BBC_ERR_SCENE},
      {"\"attenuationColor\":[-0.1,0.5,0.9],\"attenuationDistance\":1", "attenuationColor",
       BBC_ERR_SCENE},
      {"\"attenuationColor\":[0.1,0.5,0.9],\"attenuationDistance\":0", "attenuationDistance",
       BBC_ERR_SCENE},
      {"\"attenuationColor\":[0.1,0.5,0.9],\"attenuationDistance\":-3", "attenuationDistance",
       BBC_ERR_SCENE},
      {"\"attenuationColor\":[0.1,0.5],\"attenuationDistance\":1", "attenuationColor",
       BBC_ERR_GLTF},
      {"\"attenuationColor\":[0.1,\"x\",0.5],\"attenuationDistance\":1", "attenuationColor",
       BBC_ERR_GLTF},
      {"\"attenuationDistance\":\"far\"", "attenuationDistance", BBC_ERR_GLTF},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    slab_scene q = default_slab();
    q.volume = bad[i].volume;
    bbc_scene *s = (bbc_scene *)1;
    messages m;
    bbc_result r = load(&q, &s, &m);
    CHECK_INT(r, bad[i].code);
    CHECK(s == NULL);
    CHECK_INT(m.errors, 1);
    CHECK(strchr(m.error, '\n') == NULL);
    CHECK_STR_CONTAINS(m.error, "tinted glass");
    CHECK_STR_CONTAINS(m.error, bad[i].what);
  }
}

/* ------------------------------------------------------------------ the oracle */

/* Fresnel reflectance of unpolarised light from index n1 into n2 at incidence cosine
 * cos_i (the textbook formulas; 1 beyond the critical angle). */
static double fresnel(double cos_i, double n1, double n2) {
  double sin_t = n1 / n2 * sqrt(fmax(0.0, 1 - cos_i * cos_i));
  if (sin_t >= 1) return 1;
  double cos_t = sqrt(1 - sin_t * sin_t);
  double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
  double rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

/* What the oracle includes: everything, or a control with a term left out. */
enum { WITH_ALL = 0, NO_ABSORPTION = 1, NO_TINT = 2 };

/* sigma d per channel of q's attenuation (c, D given as numbers). */
typedef struct attenuation {
  double c[3], distance;
} attenuation;

/* The fraction of the sun's light that crosses the box at incidence angle theta (in air)
 * and reaches the floor: two Fresnel transmissions, two tints, absorption over the
 * refracted path d / cos(theta_t). */
static double through_box(const slab_scene *q, const attenuation *a, int k, double theta,
                          int model) {
  const double n = 1.5, ci = cos(theta);
  const double st = sin(theta) / n, ct = sqrt(1 - st * st);
  double f = (1 - fresnel(ci, 1, n)) * (1 - fresnel(ct, n, 1));
  if (model != NO_TINT) f *= q->tint[k] * q->tint[k];
  if (model != NO_ABSORPTION) f *= pow(a->c[k], q->d / ct / a->distance);
  return f;
}

/* The floor's radiance under the box from a delta sun of irradiance 1. */
static double delta_radiance(const slab_scene *q, const attenuation *a, int k, int model) {
  return q->albedo / PI * through_box(q, a, k, 0.0, model);
}

/* From a sun disk of angular diameter delta and irradiance 1 (radiance
 * L = 1 / (pi sin^2(delta / 2))): a / pi L 2 pi integral over [0, delta / 2] of
 * through_box cos sin dtheta, by Simpson's rule on 4000 intervals (error ~1e-13). */
static double disk_radiance(const slab_scene *q, const attenuation *a, int k, int model) {
  const double half = q->sun_angle * PI / 360, L = 1 / (PI * sin(half) * sin(half));
  const int n = 4000;
  double sum = 0;
  for (int i = 0; i <= n; i++) {
    double th = half * i / n, w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
    sum += w * through_box(q, a, k, th, model) * cos(th) * sin(th);
  }
  return q->albedo / PI * L * 2 * PI * sum * half / (3 * n);
}

/* ------------------------------------------------------------------ rendering */

/* Loads q; with cache_of (may be q itself) precomputes a TT cache of that scene (which
 * may differ from q in its colours) and checks it against q's. */
static int setup(fixture *f, const slab_scene *q, const slab_scene *cache_of) {
  memset(f, 0, sizeof *f);
  messages m;
  if (load(q, &f->scene, &m) != BBC_OK) return 0;
  if (bbc_accel_create(&f->accel, f->scene, NULL, NULL) != BBC_OK) return 0;
  if (!cache_of) return 1;
  bbc_scene *source = NULL;
  if (load(cache_of, &source, &m) != BBC_OK) return 0;
  int ok = fixture_cache(f, source, BBC_CHAIN_BIT(BBC_CHAIN_TT), 4, 64, 0);
  bbc_scene_free(source);
  return ok;
}

static bbc_image *render(const fixture *f, bbc_method method, uint32_t spp, uint32_t max_depth,
                         int threads) {
  bbc_image *image = NULL;
  const uint32_t n = f->scene->camera.width;
  if (bbc_image_create(&image, n, n) != BBC_OK) return NULL;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.cache = method == BBC_METHOD_PT ? NULL : f->cache;
  o.spp = spp;
  o.seed = 7;
  o.max_depth = max_depth;
  o.threads = threads;
  o.components = method == BBC_METHOD_PT ? 0 : BBC_COMPONENT_CAUSTICS;
  if (bbc_render(f->scene, f->accel, &o, image, NULL) != BBC_OK) {
    bbc_image_free(image);
    return NULL;
  }
  return image;
}

/* The largest relative difference between channel k of every pixel and want. */
static double worst_pixel(const bbc_image *im, int k, double want) {
  double worst = 0;
  for (size_t i = 0; i < (size_t)im->width * im->height; i++)
    worst = fmax(worst, fabs(im->rgb[3 * i + k] - want) / want);
  return worst;
}

static const attenuation CHROMATIC = {{0.1, 0.5, 0.9}, 0.4};

/* The caustic estimator (enumerating every tuple, so no sampling noise) under a delta
 * sun, at the camera's floor points only (max_depth 4: the caustic that light reflected
 * off the glass shows at further floor points is left out): every pixel must equal
 * a / pi E (1 - R)^2 tint^2 c^(d / D) per channel. Each camera sample is exact at its
 * point, so the tolerance is float rounding (the image and the scene are single
 * precision: about 1e-7 relative per operation) and the Newton solver's convergence
 * test: 1e-5 relative, while leaving out the absorption changes the value by at least
 * 5 % (blue, 0.9^0.5) and leaving out the tint by 19 % (red, 0.9^2): both controls
 * fail. */
TEST(estimator_slab_is_exact) {
  slab_scene q = default_slab();
  fixture f;
  REQUIRE(setup(&f, &q, &q));
  bbc_image *im = render(&f, BBC_METHOD_ENUMERATE, 2, 4, 0);
  REQUIRE(im != NULL);
  const double tol = 1e-5;
  for (int k = 0; k < 3; k++) {
    const double want = delta_radiance(&q, &CHROMATIC, k, WITH_ALL);
    const double got = worst_pixel(im, k, want);
    fprintf(stderr, "channel %d: want %.9g, pixel 0 %.9g, worst relative error %.3g\n", k, want,
            im->rgb[k], got);
    CHECK(got <= tol);
    /* The controls: without absorption, or without the tint, the test would fail. */
    CHECK(worst_pixel(im, k, delta_radiance(&q, &CHROMATIC, k, NO_ABSORPTION)) > 100 * tol);
    CHECK(worst_pixel(im, k, delta_radiance(&q, &CHROMATIC, k, NO_TINT)) > 100 * tol);
  }
  bbc_image_free(im);
  teardown(&f);
}

/* A coloured glass casts a caustic of its colour: with attenuationColor (0.1, 0.5, 0.9),
 * attenuationDistance D and a white base colour, the caustic's blue-to-red ratio is
 * (0.9 / 0.1)^(d / D) for the path length d through the glass: 9^0.25 = 1.732 at
 * d = 0.1 and 9^1 = 9 at d = 0.4 (D = 0.4), within the same 1e-5 (per channel, so 2e-5 for
 * the ratio); the ratio without absorption would be 1. */
TEST(coloured_glass_casts_its_colour) {
  const double thickness[2] = {0.1, 0.4};
  for (int i = 0; i < 2; i++) {
    slab_scene q = {thickness[i], {1, 1, 1}, NULL, 0, 0.5, 8};
    q.volume = "\"attenuationColor\":[0.1,0.5,0.9],\"attenuationDistance\":0.4";
    fixture f;
    REQUIRE(setup(&f, &q, &q));
    bbc_image *im = render(&f, BBC_METHOD_ENUMERATE, 2, 4, 0);
    REQUIRE(im != NULL);
    const double want = pow(0.9 / 0.1, thickness[i] / 0.4);
    double worst = 0;
    for (size_t p = 0; p < (size_t)im->width * im->height; p++)
      worst = fmax(worst, fabs(im->rgb[3 * p + 2] / im->rgb[3 * p] / want - 1));
    fprintf(stderr, "d = %g: blue / red %.9g, want %.9g, worst relative error %.3g\n", thickness[i],
            im->rgb[2] / im->rgb[0], want, worst);
    CHECK(worst <= 2e-5);
    CHECK(fabs(want - 1) > 0.5); /* the control: no absorption gives a ratio of 1 */
    bbc_image_free(im);
    teardown(&f);
  }
}

/* The cache leaves absorption out of its fingerprint (its bounds hold for any factor up
 * to 1): a cache computed for the box without attenuation serves the absorbing one, and
 * the render follows the scene it is given, exactly as with its own cache. (The base
 * colour, hashed since the first format version, still has to match.) */
TEST(cache_without_absorption_renders_absorbing_glass) {
  slab_scene coloured = default_slab();
  slab_scene clear = coloured;
  clear.volume = NULL;
  fixture f;
  REQUIRE(setup(&f, &coloured, &clear));
  bbc_image *im = render(&f, BBC_METHOD_ENUMERATE, 2, 4, 0);
  REQUIRE(im != NULL);
  for (int k = 0; k < 3; k++)
    CHECK(worst_pixel(im, k, delta_radiance(&coloured, &CHROMATIC, k, WITH_ALL)) <= 1e-5);
  bbc_image_free(im);
  teardown(&f);
}

/* Mean and standard error of the mean of channel k over the pixels. */
static void pixel_mean(const bbc_image *im, int k, double *mean, double *error) {
  const size_t n = (size_t)im->width * im->height;
  double s = 0, s2 = 0;
  for (size_t i = 0; i < n; i++) {
    double v = im->rgb[3 * i + k];
    s += v;
    s2 += v * v;
  }
  *mean = s / n;
  *error = sqrt(fmax(0.0, s2 / n - *mean * *mean) / (n - 1));
}

/* The path tracer, which finds the box's light only through a sun with a disk (here 20
 * degrees across) by bouncing off the floor through the box: max_depth 4 keeps exactly
 * the paths floor -> box bottom -> box top -> sky (no internal reflection; and since the
 * whole floor lies in the box's shadow, no light reflected off the glass onto a sunlit
 * floor either), whose mean the oracle integrates over the disk, each direction with
 * its own Fresnel factors and path length d / cos(theta_t). 32 x 32 pixels x 1024
 * samples give a standard error of about 0.2 % per channel, measured from the pixels'
 * spread (the independent sampler converges to the same mean); the tolerance is 4
 * of them plus 1e-4 for the Fresnel-sampled refraction's float rounding. Without absorption red
 * would be 3.2 times brighter and blue 5 % (many standard errors: the check below says so); the
 * blue-to-red ratio, nearly free of noise because every path carries all three channels, must match
 * within 0.2 %. */
TEST(path_tracer_slab_follows_beer_lambert) {
  slab_scene q = default_slab();
  q.sun_angle = 20;
  q.size = 32;
  fixture f;
  REQUIRE(setup(&f, &q, NULL));
  bbc_image *im = render(&f, BBC_METHOD_PT, 1024, 4, 0);
  REQUIRE(im != NULL);
  double mean[3];
  for (int k = 0; k < 3; k++) {
    double error;
    pixel_mean(im, k, &mean[k], &error);
    const double want = disk_radiance(&q, &CHROMATIC, k, WITH_ALL);
    const double tol = 4 * error + 1e-4 * want;
    fprintf(stderr, "channel %d: mean %.6g +- %.2g, want %.6g (tolerance %.2g)\n", k, mean[k],
            error, want, tol);
    CHECK_NEAR(mean[k], want, tol);
    CHECK(error < 0.01 * want);
    CHECK(fabs(mean[k] - disk_radiance(&q, &CHROMATIC, k, NO_ABSORPTION)) > 2 * tol);
  }
  const double ratio = mean[2] / mean[0];
  const double want =
      disk_radiance(&q, &CHROMATIC, 2, WITH_ALL) / disk_radiance(&q, &CHROMATIC, 0, WITH_ALL);
  fprintf(stderr, "blue / red %.6g, want %.6g\n", ratio, want);
  CHECK_NEAR(ratio, want, 2e-3 * want);
  bbc_image_free(im);
  teardown(&f);
}

/* Absorption adds no randomness: the same render on 1 and 2 threads is identical, for
 * the path tracer and through the cache. */
TEST(absorption_is_deterministic) {
  slab_scene q = default_slab();
  q.sun_angle = 20;
  fixture f;
  REQUIRE(setup(&f, &q, &q));
  for (int method = 0; method < 2; method++) {
    bbc_method mth = method ? BBC_METHOD_BBC : BBC_METHOD_PT;
    bbc_image *a = render(&f, mth, 16, 0, 1), *b = render(&f, mth, 16, 0, 2);
    REQUIRE(a != NULL && b != NULL);
    CHECK(memcmp(a->rgb, b->rgb, sizeof(float) * 3 * a->width * a->height) == 0);
    bbc_image_free(a);
    bbc_image_free(b);
  }
  teardown(&f);
}
