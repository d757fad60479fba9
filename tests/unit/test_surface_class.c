/* Surface classes from textures: a material whose metallic-roughness or transmission
 * texture, not its factors, says what it is.
 *
 * The scene is a strip of 8 quads (16 triangles) at y = 1, x in [-1, 1], z in
 * [-0.25, 0.25], TEXCOORD_0 u = (x + 1) / 2 (quad k covers u in [k/8, (k+1)/8]), over a
 * diffuse floor at y = 0, a point light above. Expected classes are worked out here
 * from the stated texels and the footprint rule (docs/materials.md: a triangle reads the
 * texels of its UV box widened by one for bilinear filtering), never from the loader. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "json_text.h"
#include "render_fixture.h"

/* 8 x 1, 8-bit RGB: texels 0-3 (0, 0, 255) (roughness 0, metallic 1), texels 4-7
 * (0, 255, 0) (roughness 1, metallic 0). Written by Python's zlib. */
#define PNG_HALF_MIRROR                                                            \
  "iVBORw0KGgoAAAANSUhEUgAAAAgAAAABCAIAAABsYngUAAAAD0lEQVR42mNgYPiPQEhMAF+5B/kEnq" \
  "fEAAAAAElFTkSuQmCC"
/* 1 x 1, 8-bit RGB (0, 5, 0): roughness 5/255 = 0.0196, metallic 0. */
#define PNG_SMOOTH \
  "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR42mNgYGUAAAAOAAYJIdQrAAAAAElFTkSuQmCC"

#define STRIP_QUADS 8
#define STRIP_VERTICES (2 * (STRIP_QUADS + 1))

typedef struct messages {
  int warnings;
  char warning[8][1024];
} messages;

static void on_warning(void *user, bbc_result code, const char *message) {
  (void)code;
  messages *m = user;
  if (m->warnings < 8) snprintf(m->warning[m->warnings], sizeof m->warning[0], "%s", message);
  m->warnings++;
}

/* Writes the scene with the strip's material `strip_material` (JSON object) and the
 * top-level members `more` (images, textures, samplers) to a temporary file. */
static void write_scene(char *path, size_t size, const char *strip_material, const char *more) {
  static int serial;
  snprintf(path, size, "/tmp/bbc-test-surface-class-%ld-%d.gltf", (long)getpid(), serial++);
  /* Buffer: strip positions, normals, uvs, indices; floor positions, normals, indices. */
  float sp[STRIP_VERTICES][3], sn[STRIP_VERTICES][3], su[STRIP_VERTICES][2];
  uint16_t si[STRIP_QUADS * 6];
  for (int k = 0; k <= STRIP_QUADS; k++)
    for (int j = 0; j < 2; j++) {
      int v = 2 * k + j;
      sp[v][0] = -1.0f + 2.0f * (float)k / STRIP_QUADS;
      sp[v][1] = 1.0f;
      sp[v][2] = j ? 0.25f : -0.25f;
      sn[v][0] = 0.0f, sn[v][1] = 1.0f, sn[v][2] = 0.0f;
      su[v][0] = (float)k / STRIP_QUADS;
      su[v][1] = (float)j;
    }
  for (int k = 0; k < STRIP_QUADS; k++) {
    uint16_t a = (uint16_t)(2 * k), q[6] = {a,
                                            (uint16_t)(a + 1),
                                            (uint16_t)(a + 2),
                                            (uint16_t)(a + 1),
                                            (uint16_t)(a + 3),
                                            (uint16_t)(a + 2)};
    memcpy(si + 6 * k, q, sizeof q);
  }
  float fp[4][3] = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}};
  float fn[4][3] = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  uint16_t fi[6] = {0, 2, 1, 0, 3, 2};
  unsigned char buf[1024];
  size_t off[8], n = 0;
  const void *part[7] = {sp, sn, su, si, fp, fn, fi};
  size_t len[7] = {sizeof sp, sizeof sn, sizeof su, sizeof si, sizeof fp, sizeof fn, sizeof fi};
  for (int i = 0; i < 7; i++) {
    off[i] = n;
    memcpy(buf + n, part[i], len[i]);
    n += (len[i] + 3) & ~(size_t)3;
  }
  json_text t = {0};
  json_printf(
      &t,
      "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"bbc\":{\"light_units\":\"radiometric\"}}},"
      "\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_materials_transmission\"],"
      "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\","
      "\"intensity\":10}]}},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2,3]}],"
      "\"nodes\":[{\"mesh\":0,\"name\":\"Strip\"},{\"mesh\":1,\"name\":\"Floor\"},"
      "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}},\"translation\":[0.1,3,0.05]},"
      "{\"camera\":0,\"translation\":[0,4,0],\"rotation\":[-0.7071068,0,0,0.7071068]}],"
      "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.0,\"znear\":0.1,"
      "\"aspectRatio\":1}}],"
      "\"materials\":[%s,{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"metallicFactor\":0}}],"
      "\"meshes\":[{\"name\":\"Strip\",\"primitives\":[{\"attributes\":{\"POSITION\":0,"
      "\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"material\":0}]},"
      "{\"name\":\"Floor\",\"primitives\":[{\"attributes\":{\"POSITION\":4,\"NORMAL\":5},"
      "\"indices\":6,\"material\":1}]}],",
      strip_material);
  json_printf(&t, "\"accessors\":[");
  const int type3[7] = {1, 1, 0, -1, 1, 1, -1};
  const size_t count[7] = {
      STRIP_VERTICES, STRIP_VERTICES, STRIP_VERTICES, STRIP_QUADS * 6, 4, 4, 6};
  for (int i = 0; i < 7; i++) {
    json_printf(&t, "%s{\"bufferView\":%d,\"componentType\":%d,\"count\":%zu,\"type\":\"%s\"",
                i ? "," : "", i, type3[i] < 0 ? 5123 : 5126, count[i],
                type3[i] < 0 ? "SCALAR"
                : type3[i]   ? "VEC3"
                             : "VEC2");
    if (i == 0 || i == 4)
      json_printf(&t, ",\"min\":[%d,%d,%d],\"max\":[%d,%d,%d]", i ? -2 : -1, i ? 0 : 1, i ? -2 : -1,
                  i ? 2 : 1, i ? 0 : 1, i ? 2 : 1);
    json_printf(&t, "}");
  }
  json_printf(&t, "],\"bufferViews\":[");
  for (int i = 0; i < 7; i++)
    json_printf(&t, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", i ? "," : "", off[i],
                len[i]);
  json_printf(
      &t, "],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", n);
  json_base64(&t, buf, n);
  json_printf(&t, "\"}]%s%s}", more ? "," : "", more ? more : "");
  FILE *f = fopen(path, "w");
  if (!f || fwrite(t.data, 1, t.size, f) != t.size || fclose(f) != 0)
    harness_fail(__FILE__, __LINE__, "cannot write %s", path);
  free(t.data);
}

static bbc_scene *load(const char *path, messages *m) {
  memset(m, 0, sizeof *m);
  bbc_scene_options o = {NULL, on_warning, m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, &o) != BBC_OK) harness_fail(__FILE__, __LINE__, "%s: no load", path);
  return s;
}

/* Triangles of the strip per class, over every mesh named "Strip". */
static void strip_classes(const bbc_scene *s, uint32_t out[3]) {
  out[0] = out[1] = out[2] = 0;
  for (uint32_t i = 0; i < s->mesh_count; i++)
    if (strcmp(s->meshes[i].name, "Strip") == 0)
      out[s->materials[s->meshes[i].material].type] += s->meshes[i].triangle_count;
}

static const char *warning_with(const messages *m, const char *what) {
  for (int i = 0; i < m->warnings && i < 8; i++)
    if (strstr(m->warning[i], what)) return m->warning[i];
  return NULL;
}

#define TEXTURES(png, sampler)                        \
  "\"images\":[{\"uri\":\"data:image/png;base64," png \
  "\"}],\"textures\":[{\"source\":0,"                 \
  "\"sampler\":0}],\"samplers\":[" sampler "]"

TEST(half_mirror_texture_splits_the_strip) {
  /* Factors metallic 1, roughness 1: a glossy receiver by the factors alone. With the
   * texture (clamped at the edges), quad k's u box [k/8, (k+1)/8] is [k, k+1] in texels,
   * widened to texels k-1 .. k+1 (k-1 clamped to 0): quads 0-2 read mirror texels only
   * (6 mirror triangles); quads 3 and 4 read texel 3 or 4 across the boundary (4 mixed
   * receivers); quads 5-7 rough texels only. */
  char path[256];
  write_scene(path, sizeof path,
              "{\"name\":\"Half\",\"pbrMetallicRoughness\":{\"metallicFactor\":1,"
              "\"roughnessFactor\":1,\"metallicRoughnessTexture\":{\"index\":0}}}",
              TEXTURES(PNG_HALF_MIRROR, "{\"wrapS\":33071,\"wrapT\":33071}"));
  messages m;
  bbc_scene *s = load(path, &m);
  uint32_t c[3];
  strip_classes(s, c);
  CHECK_INT(c[BBC_MATERIAL_MIRROR], 6);
  CHECK_INT(c[BBC_MATERIAL_DIFFUSE], 10);
  CHECK_INT(c[BBC_MATERIAL_DIELECTRIC], 0);
  const char *w = warning_with(&m, "metallicRoughnessTexture");
  REQUIRE(w != NULL);
  CHECK_STR_CONTAINS(w, "material 0 (\"Half\")");
  CHECK_STR_CONTAINS(w,
                     "6 triangles are ideal mirrors, 0 smooth dielectrics and 10 receivers "
                     "(4 of them because their texels disagree)");
  /* Each mirror triangle lies in u <= 3/8; the mirror part is a caster, the rest a
   * glossy receiver whose roughness at a point is the texture's. */
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    const bbc_mesh *mesh = &s->meshes[s->triangle_mesh[t]];
    if (strcmp(mesh->name, "Strip") != 0) continue;
    const bbc_material *mat = &s->materials[mesh->material];
    double umax = 0;
    for (int k = 0; k < 3; k++) umax = fmax(umax, s->uvs[2 * s->indices[3 * t + k]]);
    if (mat->type == BBC_MATERIAL_MIRROR) {
      CHECK(umax <= 3.0 / 8.0);
      CHECK_INT(mesh->role, BBC_ROLE_CASTER);
    } else {
      CHECK(umax >= 4.0 / 8.0);
      CHECK_INT(mesh->role, BBC_ROLE_RECEIVER);
      double metallic, roughness;
      bbc_scene_metallic_roughness(s, t, 1.0 / 3.0, 1.0 / 3.0, &metallic, &roughness);
      CHECK(mat->glossy);
      CHECK(roughness >= 0.0 && roughness <= 1.0);
    }
  }
  /* The same texture repeated (the default wrap): quad 0 now also reads texel 7 across
   * u = 0, so it is mixed too; quad 7 reads texel 0. */
  bbc_scene_free(s);
  remove(path);
  write_scene(path, sizeof path,
              "{\"name\":\"Half\",\"pbrMetallicRoughness\":{\"metallicFactor\":1,"
              "\"roughnessFactor\":1,\"metallicRoughnessTexture\":{\"index\":0}}}",
              TEXTURES(PNG_HALF_MIRROR, "{}"));
  s = load(path, &m);
  strip_classes(s, c);
  CHECK_INT(c[BBC_MATERIAL_MIRROR], 4);
  CHECK_INT(c[BBC_MATERIAL_DIFFUSE], 12);
  bbc_scene_free(s);
  remove(path);
}

TEST(factors_alone_decide_without_texture) {
  /* The control: the same factors with no texture make the whole strip a receiver. */
  char path[256];
  write_scene(path, sizeof path,
              "{\"name\":\"Half\",\"pbrMetallicRoughness\":{\"metallicFactor\":1,"
              "\"roughnessFactor\":1}}",
              NULL);
  messages m;
  bbc_scene *s = load(path, &m);
  uint32_t c[3];
  strip_classes(s, c);
  CHECK_INT(c[BBC_MATERIAL_DIFFUSE], 16);
  CHECK_INT(c[BBC_MATERIAL_MIRROR], 0);
  bbc_scene_free(s);
  remove(path);
}

/* The strip as glass whose smoothness is in its texture (roughness factor 1 times
 * 5/255), or in its factor (roughness 0, no texture), or rough (factor 1, no texture). */
static const char *const GLASS_TEXTURED =
    "{\"name\":\"Glass\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":1,"
    "\"metallicRoughnessTexture\":{\"index\":0}},"
    "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}}}";
static const char *const GLASS_SMOOTH =
    "{\"name\":\"Glass\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":0},"
    "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}}}";
static const char *const GLASS_ROUGH =
    "{\"name\":\"Glass\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":1},"
    "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}}}";

static size_t t_tuples(const char *material, const char *more, bbc_tuple **out) {
  char path[256];
  write_scene(path, sizeof path, material, more);
  messages m;
  bbc_scene *s = load(path, &m);
  size_t n = 0;
  if (bbc_tuples_find(s, BBC_CHAIN_BIT(BBC_CHAIN_T), out, &n) != BBC_OK)
    harness_fail(__FILE__, __LINE__, "tuple search failed");
  bbc_scene_free(s);
  remove(path);
  return n;
}

TEST(glass_smooth_by_its_texture_casts_its_caustic) {
  bbc_tuple *textured = NULL, *smooth = NULL, *rough = NULL;
  size_t nt = t_tuples(GLASS_TEXTURED, TEXTURES(PNG_SMOOTH, "{}"), &textured);
  size_t ns = t_tuples(GLASS_SMOOTH, NULL, &smooth);
  size_t nr = t_tuples(GLASS_ROUGH, NULL, &rough);
  /* Every strip triangle refracts onto the floor: the same tuples as the glass smooth by
   * its factor; the control, rough glass, has none. */
  CHECK(nt > 0);
  CHECK_INT(nt, ns);
  CHECK(nt == ns && memcmp(textured, smooth, nt * sizeof *textured) == 0);
  CHECK_INT(nr, 0);
  free(textured);
  free(smooth);
  free(rough);

  /* The render shows it: the caustic-only image through the cache is that of the
   * factor-smooth glass, and lit. */
  char pt[256], ps[256];
  write_scene(pt, sizeof pt, GLASS_TEXTURED, TEXTURES(PNG_SMOOTH, "{}"));
  write_scene(ps, sizeof ps, GLASS_SMOOTH, NULL);
  fixture ft, fs;
  REQUIRE(fixture_setup(&ft, pt, BBC_CHAIN_BIT(BBC_CHAIN_T), 4, 0));
  REQUIRE(fixture_setup(&fs, ps, BBC_CHAIN_BIT(BBC_CHAIN_T), 4, 0));
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_BBC;
  o.spp = 4;
  o.seed = 3;
  o.threads = 1;
  o.components = BBC_COMPONENT_CAUSTICS;
  bbc_image *it = fixture_render(&ft, o, 32, 32, NULL), *is = fixture_render(&fs, o, 32, 32, NULL);
  REQUIRE(it && is);
  double sum = 0;
  int same = 1;
  for (size_t i = 0; i < 3 * 32 * 32; i++) {
    sum += it->rgb[i];
    same &= it->rgb[i] == is->rgb[i];
  }
  CHECK(sum > 0);
  CHECK(same);
  bbc_image_free(it);
  bbc_image_free(is);
  teardown(&ft);
  teardown(&fs);
  remove(pt);
  remove(ps);
}
