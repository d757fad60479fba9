/* Base colour textures: decoding (sRGB, 8 and 16 bits), wrap modes, filters and
 * KHR_texture_transform on small hand-made PNGs whose texels are known, the warnings and
 * errors of bad texture input, and end to end the caustic of a flat mirror on a
 * checker-textured floor: exactly the mirrored light times the texture.
 *
 * Expected values are worked out here from the PNGs' stated texels and the sRGB curve,
 * never from the loader's output. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "blender_style.h"
#include "floor_footprint.h"
#include "gltf_shim_internal.h"
#include "harness.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

/* 2 x 2, 8-bit RGB: row 0 (top) red (255, 0, 0), green (0, 255, 0); row 1 blue (0, 0, 255),
 * grey (128, 128, 128). Written by Python's zlib. */
#define PNG_2X2                                                                              \
  "iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAIAAAD91JpzAAAAE0lEQVR4nGP4z8DAAMIM/xsaGgAc9AR+KYBA2AAAAABJ" \
  "RU5ErkJggg=="
/* 2 x 1, 16-bit RGBA: (65535, 32768, 0, 65535), (1000, 0, 65535, 0). */
#define PNG_16BIT                                                                            \
  "iVBORw0KGgoAAAANSUhEUgAAAAIAAAABEAYAAACksqPJAAAAF0lEQVR4nGP4/7+BgYHh/3/mFyCSgQEARkgHZpBT6HAA" \
  "AAAASUVORK5CYII="

/* The sRGB curve, written out independently of the library. */
static double srgb(double c) {
  return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

typedef struct messages {
  int errors, warnings;
  bbc_result error_code;
  char error[1024];
  char warning[8][1024];
} messages;

static void on_error(void *user, bbc_result code, const char *message) {
  messages *m = user;
  m->errors++;
  m->error_code = code;
  snprintf(m->error, sizeof m->error, "%s", message);
}

static void on_warning(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  if (m->warnings < 8) snprintf(m->warning[m->warnings], sizeof m->warning[0], "%s", message);
  m->warnings++;
}

/* The blender-style floor ([-1, 1]^2 at y = 0, TEXCOORD_0 u = (x + 1) / 2,
 * v = (z + 1) / 2) with material 0 `floor_material` and the given images, textures and
 * samplers (top-level JSON members). */
static bbc_scene *load_textured(const char *floor_material, const char *more, messages *m,
                                bbc_result *r) {
  char materials[2048];
  snprintf(materials, sizeof materials, "[%s]", floor_material);
  blender_style b = {0};
  b.lights = "[{\"name\":\"Light\",\"type\":\"point\",\"intensity\":100}]";
  b.cameras = "[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.7,\"znear\":0.1}}]";
  b.materials = materials;
  b.more_json = more;
  char *text = blender_style_write(&b);
  memset(m, 0, sizeof *m);
  bbc_scene_options options = {on_error, on_warning, m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *s = (bbc_scene *)1;
  *r = bbc__scene_load_memory(&s, text, strlen(text), "textured.gltf", NULL, &options);
  free(text);
  if (*r != BBC_OK && s != NULL) harness_fail(__FILE__, __LINE__, "*out not NULL on failure");
  return s;
}

#define TEXTURED_FLOOR(extension)                                                    \
  "{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0.5,1,1],"   \
  "\"metallicFactor\":0,\"roughnessFactor\":1,\"baseColorTexture\":{\"index\":0" extension "}}}"

static char *images_json(const char *png, const char *sampler) {
  static char text[4096];
  snprintf(text, sizeof text,
           "\"images\":[{\"uri\":\"data:image/png;base64,%s\"}],\"textures\":[{\"source\":0%s}]"
           "%s%s%s",
           png, sampler ? ",\"sampler\":0" : "", sampler ? ",\"samplers\":[" : "",
           sampler ? sampler : "", sampler ? "]" : "");
  return text;
}

/* The base colour of the loaded floor at world point (x, 0, z), through the library's
 * lookup: finds the floor triangle and barycentrics by hand. */
static void floor_color(const bbc_scene *s, double x, double z, double out[3]) {
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    if (s->meshes[s->triangle_mesh[t]].role != BBC_ROLE_RECEIVER) continue;
    const uint32_t *idx = s->indices + 3 * (size_t)t;
    const float *a = s->positions + 3 * (size_t)idx[0], *b = s->positions + 3 * (size_t)idx[1],
                *c = s->positions + 3 * (size_t)idx[2];
    double d = (b[0] - a[0]) * (c[2] - a[2]) - (c[0] - a[0]) * (b[2] - a[2]);
    double b1 = ((x - a[0]) * (c[2] - a[2]) - (c[0] - a[0]) * (z - a[2])) / d;
    double b2 = ((b[0] - a[0]) * (z - a[2]) - (x - a[0]) * (b[2] - a[2])) / d;
    if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) {
      bbc_scene_base_color(s, t, b1, b2, out);
      return;
    }
  }
  harness_fail(__FILE__, __LINE__, "no floor triangle under (%g, %g)", x, z);
}

static void check_color(const double got[3], double r, double g, double b) {
  CHECK_NEAR(got[0], r, 1e-6);
  CHECK_NEAR(got[1], g, 1e-6);
  CHECK_NEAR(got[2], b, 1e-6);
}

/* ------------------------------------------------------------------ decoding */

TEST(srgb_curve) {
  CHECK_NEAR(bbc_srgb_to_linear(0.0), 0.0, 0.0);
  CHECK_NEAR(bbc_srgb_to_linear(1.0), 1.0, 1e-15);
  CHECK_NEAR(bbc_srgb_to_linear(0.04045), 0.04045 / 12.92, 1e-17);
  CHECK_NEAR(bbc_srgb_to_linear(0.5), 0.21404114048223255, 1e-15);
}

/* The 2 x 2 PNG on the floor (factor (1, 0.5, 1)), NEAREST: each quarter of the floor has
 * its texel's decoded colour times the factor; the image's top row is at v = 0. */
TEST(texels_decode_srgb_top_row_first) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(TEXTURED_FLOOR(""),
                               images_json(PNG_2X2, "{\"magFilter\":9728,\"minFilter\":9728}"),
                               &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 0);
  CHECK_INT(s->texture_count, 1);
  CHECK_INT(s->textures[0].width, 2);
  CHECK_INT(s->textures[0].height, 2);
  double c[3];
  floor_color(s, -0.5, -0.5, c); /* u, v = 0.25, 0.25: red */
  check_color(c, 1, 0, 0);
  floor_color(s, 0.5, -0.5, c); /* 0.75, 0.25: green */
  check_color(c, 0, 0.5, 0);
  floor_color(s, -0.5, 0.5, c); /* 0.25, 0.75: blue */
  check_color(c, 0, 0, 1);
  double grey = srgb(128 / 255.0);
  floor_color(s, 0.9, 0.9, c); /* grey */
  check_color(c, grey, 0.5 * grey, grey);
  bbc_scene_free(s);
}

TEST(sixteen_bit_rgba) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(TEXTURED_FLOOR(""),
                               images_json(PNG_16BIT, "{\"magFilter\":9728}"), &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  double c[3];
  bbc_texture_lookup(&s->textures[0], 0.25, 0.5, c);
  check_color(c, 1, srgb(32768 / 65535.0), 0);
  bbc_texture_lookup(&s->textures[0], 0.75, 0.5, c);
  check_color(c, srgb(1000 / 65535.0), 0, 1); /* alpha 0 is ignored */
  bbc_scene_free(s);
}

/* Wrap modes and filters on the 2 x 2 texture, by texture coordinates. */
TEST(wrap_modes_and_filters) {
  const double red[3] = {1, 0, 0}, green[3] = {0, 1, 0};
  static const char *const samplers[3] = {
      "{\"magFilter\":9728,\"wrapS\":10497,\"wrapT\":10497}",
      "{\"magFilter\":9728,\"wrapS\":33071,\"wrapT\":33071}",
      "{\"magFilter\":9728,\"wrapS\":33648,\"wrapT\":33648}"};
  /* s along row 0 (t = 0.25): red is column 0, green column 1. */
  static const double s_values[] = {1.25, -0.25, 1.75, -3.0, 7.0, 2.25};
  /* repeat: 1.25 -> 0.25 red; -0.25 -> 0.75 green; 1.75 -> green; -3 -> 0 red; 7 -> red;
   * 2.25 -> red. clamp: 1.25 green (edge), -0.25 red, 1.75 green, -3 red, 7 green,
   * 2.25 green. mirror (period 2, [1, 2) reversed): 1.25 -> 0.75 green; -0.25 -> 0.25
   * red; 1.75 -> 0.25 red; -3 -> 1 -> the reversed copy's start, green; 7 -> 1 green;
   * 2.25 -> 0.25 red. */
  static const int expect_green[3][6] = {
      {0, 1, 1, 0, 0, 0}, {1, 0, 1, 0, 1, 1}, {1, 0, 0, 1, 1, 0}};
  for (int k = 0; k < 3; k++) {
    messages m;
    bbc_result r;
    bbc_scene *s = load_textured(TEXTURED_FLOOR(""), images_json(PNG_2X2, samplers[k]), &m, &r);
    REQUIRE(s != NULL);
    CHECK_INT(s->textures[0].wrap_s, k);
    for (int i = 0; i < 6; i++) {
      double c[3];
      bbc_texture_lookup(&s->textures[0], s_values[i], 0.25, c);
      const double *want = expect_green[k][i] ? green : red;
      if (fabs(c[0] - want[0]) > 1e-7 || fabs(c[1] - want[1]) > 1e-7)
        harness_fail(__FILE__, __LINE__, "wrap %d, s = %g: got (%g, %g, %g)", k, s_values[i],
                     c[0], c[1], c[2]);
    }
    bbc_scene_free(s);
  }
  /* Bilinear (no sampler: LINEAR): halfway between the texel centres of red and green
   * (s = 0.5) the mean; at s = 0 with REPEAT the mean of column 0 and the wrapped column
   * 1; at a texel centre the texel itself. */
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(TEXTURED_FLOOR(""), images_json(PNG_2X2, NULL), &m, &r);
  REQUIRE(s != NULL);
  CHECK(!s->textures[0].nearest);
  double c[3];
  bbc_texture_lookup(&s->textures[0], 0.5, 0.25, c);
  check_color(c, 0.5, 0.5, 0);
  bbc_texture_lookup(&s->textures[0], 0.0, 0.25, c);
  check_color(c, 0.5, 0.5, 0);
  bbc_texture_lookup(&s->textures[0], 0.25, 0.25, c);
  check_color(c, 1, 0, 0);
  /* Between the centres of red (0.25, 0.25) and blue (0.25, 0.75), a quarter of the way. */
  bbc_texture_lookup(&s->textures[0], 0.25, 0.375, c);
  check_color(c, 0.75, 0, 0.25);
  bbc_scene_free(s);
}

/* KHR_texture_transform as in the extension's example: offset [0, 1], rotation pi/2,
 * scale [0.5, 0.5] shows the lower left quadrant of the image (the blue texel) turned
 * clockwise: uv (1, 0) -> (0, 0.5), (0, 1) -> (0.5, 1), (0, 0) -> (0, 1). */
TEST(texture_transform_example) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(
      TEXTURED_FLOOR(",\"extensions\":{\"KHR_texture_transform\":{\"offset\":[0,1],"
                     "\"rotation\":1.57079632679,\"scale\":[0.5,0.5]}}"),
      images_json(PNG_2X2, "{\"magFilter\":9728}"), &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  const bbc_material *mat = &s->materials[0];
  REQUIRE(mat->base_color_texture == 1);
  const double *x = mat->uv_transform;
  const double uv[3][2] = {{1, 0}, {0, 1}, {0, 0}}, want[3][2] = {{0, 0.5}, {0.5, 1}, {0, 1}};
  for (int i = 0; i < 3; i++) {
    CHECK_NEAR(x[0] * uv[i][0] + x[1] * uv[i][1] + x[2], want[i][0], 1e-11);
    CHECK_NEAR(x[3] * uv[i][0] + x[4] * uv[i][1] + x[5], want[i][1], 1e-11);
  }
  /* Every floor point shows the quadrant's only texel, blue. */
  double c[3];
  floor_color(s, -0.9, -0.9, c);
  check_color(c, 0, 0, 1);
  floor_color(s, 0.9, 0.3, c);
  check_color(c, 0, 0, 1);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ bad input */

/* A texture or image reference out of range and an unknown wrap mode are invalid glTF:
 * one line naming the material or texture, nothing loaded. */
TEST(bad_references_fail_in_one_line) {
  struct {
    const char *material, *more, *expect;
  } cases[] = {
      {"{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":3}}}",
       "\"images\":[{\"uri\":\"data:image/png;base64," PNG_2X2 "\"}],\"textures\":[{\"source\":0}]",
       "material 0 (\"Floor\"): baseColorTexture uses texture 3, but the file has 1 textures"},
      {TEXTURED_FLOOR(""), "\"textures\":[{\"source\":2}]",
       "texture 0: source 2, but the file has 0 images"},
      {TEXTURED_FLOOR(""), images_json(PNG_2X2, "{\"wrapS\":12345}"),
       "sampler wrapS 12345 is not REPEAT"},
      {TEXTURED_FLOOR(""),
       "\"images\":[{\"uri\":\"data:image/png;base64," PNG_2X2 "\"}],\"textures\":[{\"source\":0,"
       "\"sampler\":4}]",
       "texture 0: sampler 4, but the file has 0 samplers"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    messages m;
    bbc_result r;
    bbc_scene *s = load_textured(cases[i].material, cases[i].more, &m, &r);
    CHECK(s == NULL);
    CHECK_INT(r, BBC_ERR_GLTF);
    CHECK_INT(m.errors, 1);
    CHECK_STR_CONTAINS(m.error, cases[i].expect);
    CHECK_STR_CONTAINS(m.error, "textured.gltf");
    CHECK(strchr(m.error, '\n') == NULL);
    bbc_scene_free(s);
  }
}

/* An image that cannot be read or decoded leaves the scene loadable: one warning naming
 * the material, the image and the reason, and the surface keeps its factor alone (a
 * neutral, white texture). So does a texture on another TEXCOORD set. */
TEST(missing_or_broken_images_warn_and_go_neutral) {
  struct {
    const char *material, *more, *expect;
  } cases[] = {
      {TEXTURED_FLOOR(""), "\"images\":[{\"uri\":\"wood.png\"}],\"textures\":[{\"source\":0}]",
       "image 0 (\"wood.png\"): cannot read wood.png"},
      {TEXTURED_FLOOR(""),
       "\"images\":[{\"name\":\"junk\",\"uri\":\"data:image/png;base64,AAAAAAAAAAAA\"}],"
       "\"textures\":[{\"source\":0}]",
       "image 0 (\"junk\"): it cannot be decoded"},
      {TEXTURED_FLOOR(""),
       "\"images\":[{\"bufferView\":2,\"mimeType\":\"image/png\"}],\"textures\":[{\"source\":0}]",
       "it cannot be decoded"},
      {"{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0.5,1,1],"
       "\"metallicFactor\":0,\"baseColorTexture\":{\"index\":0,\"texCoord\":1}}}",
       images_json(PNG_2X2, NULL), "uses TEXCOORD_1; bbc reads TEXCOORD_0 only"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    messages m;
    bbc_result r;
    bbc_scene *s = load_textured(cases[i].material, cases[i].more, &m, &r);
    CHECK_INT(r, BBC_OK);
    REQUIRE(s != NULL);
    CHECK_INT(m.errors, 0);
    CHECK_INT(m.warnings, 1);
    CHECK_STR_CONTAINS(m.warning[0], cases[i].expect);
    CHECK_STR_CONTAINS(m.warning[0], "(\"Floor\")");
    CHECK_STR_CONTAINS(m.warning[0], "as under a white texture");
    CHECK(strchr(m.warning[0], '\n') == NULL);
    CHECK_INT(s->materials[0].base_color_texture, 0);
    double c[3];
    floor_color(s, 0.3, 0.3, c);
    check_color(c, 1, 0.5, 1);
    bbc_scene_free(s);
  }
}

/* Unused images are not decoded, so a broken one does no harm and says nothing. */
TEST(unused_broken_image_is_silent) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(
      "{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"metallicFactor\":0}}",
      "\"images\":[{\"uri\":\"data:image/png;base64,AAAA\"}],\"textures\":[{\"source\":0}]", &m,
      &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 0);
  CHECK_INT(s->texture_count, 0);
  bbc_scene_free(s);
}

/* An animation in a file without any camera: one line saying there is no camera. */
TEST(animation_without_camera_fails_in_one_line) {
  static const float data[] = {0, 1, 0, 1, 4, 0, 2, 4};
  blender_style b = {0};
  b.lights = "[{\"name\":\"Light\",\"type\":\"point\",\"intensity\":100}]";
  b.anim_data = data;
  b.anim_floats = 8;
  b.anim_accessors =
      "{\"bufferView\":7,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\","
      "\"min\":[0],\"max\":[1]},"
      "{\"bufferView\":7,\"byteOffset\":8,\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"}";
  b.animations =
      "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
      "\"samplers\":[{\"input\":7,\"output\":8}]}]";
  char *text = blender_style_write(&b);
  messages m;
  memset(&m, 0, sizeof m);
  bbc_scene_options options = {on_error, on_warning, &m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *s = NULL;
  bbc_result r = bbc__scene_load_memory(&s, text, strlen(text), "anim.gltf", NULL, &options);
  free(text);
  CHECK(s == NULL);
  CHECK_INT(r, BBC_ERR_SCENE);
  CHECK_INT(m.errors, 1);
  CHECK_STR_CONTAINS(m.error, "anim.gltf: no camera");
  CHECK(strchr(m.error, '\n') == NULL);
}

/* ------------------------------------------------------------------ end to end */

static int setup(fixture *f, const char *path) {
  return fixture_setup(f, path, BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0);
}

/* The textured floor's radiance from the mirrored light: albedo(p)/pi I cos/r^2, the
 * albedo from the checker's rule (texel (i, j) of the 8 x 8 checker is light where
 * i + j is even; u = x / 4, v = (z + 2) / 4 on the floor [0, 4] x [-2, 2]) and its stated
 * sRGB colours; `swapped` exchanges the two colours (the control). */
typedef struct checker_light {
  bbc_vec3 position;
  double intensity;
  int channel, swapped;
} checker_light;

static double checker_value(const void *user, bbc_vec3 p) {
  const checker_light *c = user;
  static const int light[3] = {235, 222, 190}, dark[3] = {40, 96, 160};
  int i = (int)floor(p.x / 4 * 8), j = (int)floor((p.z + 2) / 4 * 8);
  int is_light = ((i + j) % 2 == 0) != c->swapped;
  double albedo = srgb((is_light ? light : dark)[c->channel] / 255.0);
  bbc_vec3 l = v3_sub(c->position, p);
  double r2 = v3_dot(l, l);
  return albedo / PI * c->intensity * (l.y / sqrt(r2)) / r2;
}

/* A flat mirror beside a floor with an 8 x 8 checker texture (bbc-scenegen --checker 8,
 * NEAREST): the caustic-only image (enumeration: every sample exact) lies, pixel by
 * pixel and in each channel, within the analytic values over the pixel's footprint (up
 * to the ray offsets, 1e-4 relative). With the checker's colours swapped the same check
 * fails for most pixels. */
TEST(checker_floor_caustic_is_mirrored_light_times_texture) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-checker.gltf")));
  REQUIRE(f.scene->texture_count == 1);
  const uint32_t w = 40, h = 30;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_ENUMERATE;
  o.spp = 2;
  o.seed = 5;
  o.components = BBC_COMPONENT_CAUSTICS;
  bbc_image *image = fixture_render(&f, o, w, h, NULL);
  REQUIRE(image);
  const bbc_point_light *light = &f.scene->point_lights[0];
  double box[4] = {0.05, 3.95, -1.95, 1.95};
  int checked = 0, bad = 0, control_bad = 0;
  for (int channel = 0; channel < 3; channel++) {
    for (int flat = 0; flat < 2; flat++) {
      checker_light cl = {v3(-light->position.x, light->position.y, light->position.z),
                          light->intensity[channel], channel, flat};
      for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
          double lo, hi;
          if (!floor_footprint_range(f.scene, f.accel, w, h, x, y, box, checker_value, &cl, &lo,
                                     &hi))
            continue;
          double got = image->rgb[3 * ((size_t)y * w + x) + (size_t)channel];
          int ok = got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4);
          if (flat) {
            control_bad += !ok;
            continue;
          }
          checked++;
          if (!ok && bad++ < 5)
            fprintf(stderr, "pixel (%u,%u) channel %d: %.9g not in [%.9g, %.9g]\n", x, y, channel,
                    got, lo, hi);
        }
    }
  }
  fprintf(stderr, "%d pixel channels checked, %d off; swapped colours: %d off\n", checked, bad,
          control_bad);
  CHECK(checked > 900);
  CHECK_INT(bad, 0);
  CHECK(control_bad > checked / 2);

  /* The path tracer's direct light uses the same albedo: the light itself times the
   * texture (the mirror does not shadow the floor). */
  o.method = BBC_METHOD_PT;
  o.components = BBC_COMPONENT_DIRECT;
  bbc_image_free(image);
  image = fixture_render(&f, o, w, h, NULL);
  REQUIRE(image);
  int direct_checked = 0, direct_bad = 0;
  for (int channel = 0; channel < 3; channel++) {
    checker_light cl = {light->position, light->intensity[channel], channel, 0};
    for (uint32_t y = 0; y < h; y++)
      for (uint32_t x = 0; x < w; x++) {
        double lo, hi;
        if (!floor_footprint_range(f.scene, f.accel, w, h, x, y, box, checker_value, &cl, &lo,
                                   &hi))
          continue;
        direct_checked++;
        double got = image->rgb[3 * ((size_t)y * w + x) + (size_t)channel];
        direct_bad += !(got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4));
      }
  }
  fprintf(stderr, "direct light: %d pixel channels checked, %d off\n", direct_checked,
          direct_bad);
  CHECK(direct_checked > 900);
  CHECK_INT(direct_bad, 0);
  bbc_image_free(image);
  teardown(&f);
}

/* ------------------------------------------------------------------ emissive textures */

/* PNG_2X2 on the blender-style floor (u = (x + 1) / 2, v = (z + 1) / 2, NEAREST): the
 * texel's sRGB colour at floor point p, channel c; `flat` (the control) reads white. */
typedef struct emissive_case {
  double factor;
  int channel, flat;
} emissive_case;

static double emissive_value(const void *user, bbc_vec3 p) {
  const emissive_case *e = user;
  static const int texel[2][2][3] = {{{255, 0, 0}, {0, 255, 0}}, {{0, 0, 255}, {128, 128, 128}}};
  int i = p.x < 0 ? 0 : 1, j = p.z < 0 ? 0 : 1;
  return e->factor * (e->flat ? 1.0 : srgb(texel[j][i][e->channel] / 255.0));
}

/* An emitter's radiance is its emission times its emissiveTexture (sRGB colour) at the
 * point: seen directly by the camera, each pixel of a black floor emitting through
 * PNG_2X2 lies within the emission over its footprint (up to float rounding); the
 * control, the factor alone, does not. The path tracer's next-event estimation and the
 * cached area lights read the same function (bbc_scene_emission). */
TEST(emissive_texture_scales_emission) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_textured(
      "{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0,0,0,1],"
      "\"metallicFactor\":0,\"roughnessFactor\":1},\"emissiveFactor\":[1,1,1],"
      "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":3}},"
      "\"emissiveTexture\":{\"index\":0}}",
      images_json(PNG_2X2, "{\"magFilter\":9728}"), &m, &r);
  REQUIRE(r == BBC_OK && s);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  const uint32_t w = 64, h = 48;
  bbc_image *image = NULL;
  REQUIRE(bbc_image_create(&image, w, h) == BBC_OK);
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.spp = 4;
  o.seed = 1;
  o.max_depth = 1;
  o.components = BBC_COMPONENT_DIRECT;
  REQUIRE(bbc_render(s, accel, &o, image, NULL) == BBC_OK);
  const double box[4] = {-0.99, 0.99, -0.99, 0.99};
  int checked = 0, bad = 0, control_bad = 0;
  for (int channel = 0; channel < 3; channel++)
    for (uint32_t y = 0; y < h; y++)
      for (uint32_t x = 0; x < w; x++) {
        emissive_case e = {3.0, channel, 0}, flat = {3.0, channel, 1};
        double lo, hi, flo, fhi;
        if (!floor_footprint_range(s, accel, w, h, x, y, box, emissive_value, &e, &lo, &hi) ||
            !floor_footprint_range(s, accel, w, h, x, y, box, emissive_value, &flat, &flo, &fhi))
          continue;
        double got = image->rgb[3 * ((size_t)y * w + x) + (size_t)channel];
        checked++;
        bad += !(got >= lo * (1 - 1e-5) - 1e-6 && got <= hi * (1 + 1e-5) + 1e-6);
        control_bad += !(got >= flo * (1 - 1e-5) - 1e-6 && got <= fhi * (1 + 1e-5) + 1e-6);
      }
  fprintf(stderr, "%d pixel channels checked, %d off; factor alone: %d off\n", checked, bad,
          control_bad);
  CHECK(checked > 600); /* 224 pixels see the floor wholly inside the box */
  CHECK_INT(bad, 0);
  CHECK(control_bad > checked / 2);
  bbc_image_free(image);
  bbc_accel_free(accel);
  bbc_scene_free(s);
}
