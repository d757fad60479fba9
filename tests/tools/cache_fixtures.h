/* Test fixtures for .bbc caches, shared by tests/unit/test_cache.c and the test tool
 * tests/tools/bbc_test_cache.c: a tiny hand-made scene, the minimal cache of the spec's
 * Appendix A, a re-layout helper that rebuilds a file from edited sections with valid
 * checksums (so a test can break exactly one rule), and the invalid corpus
 * (tests/corpus/invalid/<expected_error>--<what>.bbc).
 *
 * Everything is static: each including program gets its own copy. */
#ifndef BBC_TEST_CACHE_FIXTURES_H
#define BBC_TEST_CACHE_FIXTURES_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <zstd.h>

#include "bbc/cache.h"

/* ------------------------------------------------------------------ tiny scene */

/* Mesh 0: a mirror triangle above the floor (caster). Mesh 1: the floor quad
 * [0,1] x {0} x [0,1] as two triangles with uvs = (x, z) (receiver). One point light. */
static float fx_positions[] = {0.2f, 1, 0.2f, 0.8f, 1, 0.2f, 0.5f, 1, 0.8f, 0, 0,
                               0,    1, 0,    0,    1, 0,    1,    0, 0,    1};
static float fx_normals[] = {0, -1, 0, 0, -1, 0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
static float fx_uvs[] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 0, 1};
static uint32_t fx_indices[] = {0, 1, 2, 3, 5, 4, 3, 6, 5};
static uint32_t fx_triangle_mesh[] = {0, 1, 1};
static bbc_mesh fx_meshes[] = {
    {"mirror", 0, 3, 0, 1, 0, BBC_ROLE_CASTER, 1, 0, 0, 1, 0, {{0, 0, 0}}, 0},
    {"floor", 3, 4, 1, 2, 1, BBC_ROLE_RECEIVER, 1, 1, 0, 1, 0, {{0, 0, 0}}, 0},
};
static bbc_material fx_materials[] = {
    {.name = "mirror", .type = BBC_MATERIAL_MIRROR, .base_color = {1, 1, 1}, .ior = 1.5f},
    {.name = "floor", .type = BBC_MATERIAL_DIFFUSE, .base_color = {0.8f, 0.8f, 0.8f}, .ior = 1.5f},
};
static bbc_point_light fx_lights[] = {{.position = {0.5, 2, 0.5}, .intensity = {10, 10, 10}}};

static bbc_scene fx_tiny_scene(void) {
  bbc_scene s;
  memset(&s, 0, sizeof s);
  snprintf(s.path, sizeof s.path, "tiny");
  s.vertex_count = 7;
  s.positions = fx_positions;
  s.normals = fx_normals;
  s.uvs = fx_uvs;
  s.triangle_count = 3;
  s.indices = fx_indices;
  s.triangle_mesh = fx_triangle_mesh;
  s.mesh_count = 2;
  s.meshes = fx_meshes;
  s.material_count = 2;
  s.materials = fx_materials;
  s.point_light_count = 1;
  s.point_lights = fx_lights;
  return s;
}

/* The minimal valid file of spec Appendix A: a 2 x 2 grid, one R tuple splatted over the
 * whole receiver triangle 1 with bound 1, no INFO. */
static bbc_result fx_minimal_cache(void **bytes, size_t *size) {
  bbc_scene scene = fx_tiny_scene();
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.chains = BBC_CHAIN_BIT(BBC_CHAIN_R);
  p.grid_resolution = 2;
  bbc_cache_builder *b = NULL;
  bbc_result r = bbc_cache_builder_create(&b, &scene, &p);
  if (r != BBC_OK) return r;
  bbc_tuple t = {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 1};
  uint32_t id = 0;
  r = bbc_cache_builder_add_tuple(b, &t, &id);
  if (r == BBC_OK) r = bbc_cache_builder_splat(b, id, 1, 0, 1, 0, 1, 1.0);
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.omit_info = 1;
  if (r == BBC_OK) r = bbc_cache_builder_write_memory(b, bytes, size, &o);
  bbc_cache_builder_free(b);
  return r;
}

/* A richer base for the corpus: an 8 x 8 grid, 6 tuples of two chain types, splats of
 * several bounds including +inf, small chunks (several of them), with INFO. */
static bbc_result fx_base_cache(void **bytes, size_t *size) {
  bbc_scene scene = fx_tiny_scene();
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = 8;
  bbc_cache_builder *b = NULL;
  bbc_result r = bbc_cache_builder_create(&b, &scene, &p);
  if (r != BBC_OK) return r;
  for (uint32_t i = 0; i < 6 && r == BBC_OK; i++) {
    bbc_tuple t = {
        0, i % 2 ? BBC_CHAIN_TT : BBC_CHAIN_R, {0, i % 2 ? 0 : BBC_NO_TRIANGLE}, 1 + i % 2};
    uint32_t id;
    r = bbc_cache_builder_add_tuple(b, &t, &id);
    double lo = 0.1 * i, bound = i == 3 ? INFINITY : 0.5 + i;
    if (r == BBC_OK) r = bbc_cache_builder_splat(b, id, t.receiver, lo, lo + 0.2, 0, 0.3, bound);
    if (r == BBC_OK) r = bbc_cache_builder_splat(b, id, t.receiver, 0, 0.1, lo, 0.6, bound * 2);
  }
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.chunk_bytes = 24; /* 4 entries per chunk */
  if (r == BBC_OK) r = bbc_cache_builder_write_memory(b, bytes, size, &o);
  bbc_cache_builder_free(b);
  return r;
}

/* ------------------------------------------------------------------ synthetic content */

/* One recorded splat, so tests can compute what every cell must hold. */
typedef struct fx_splat {
  uint32_t tuple, triangle;
  double b1_lo, b1_hi, b2_lo, b2_hi, bound;
} fx_splat;

typedef struct fx_record {
  fx_splat *splats;
  size_t count, cap;
} fx_record;

static double fx_random(uint64_t *state) {
  *state = *state * 6364136223846793005ull + 1442695040888963407ull;
  return (double)(*state >> 11) * (1.0 / 9007199254740992.0);
}

/* A builder for `scene` filled with synthetic but plausible content: tuples in runs of
 * neighbouring caster triangles, R and TT chains, a few pieces per tuple with boxes
 * around a point of the receiver triangle (partly outside it) and smooth bounds, one
 * tuple in 50 with an infinite bound. With `record`, every splat is appended to it. */
static bbc_result fx_synthetic_builder(bbc_cache_builder **out, const bbc_scene *scene,
                                       uint32_t resolution, uint64_t seed, fx_record *record) {
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = resolution;
  bbc_result r = bbc_cache_builder_create(out, scene, &p);
  if (r != BBC_OK) return r;
  bbc_cache_builder *b = *out;
  uint32_t *casters = malloc(sizeof(uint32_t) * scene->triangle_count);
  uint32_t *receivers = malloc(sizeof(uint32_t) * scene->triangle_count);
  uint32_t nc = 0, nr = 0;
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    const uint32_t m = scene->triangle_mesh[t];
    bbc_role role = scene->meshes[m].role;
    if (role == BBC_ROLE_CASTER) casters[nc++] = t;
    /* A receiver plane's tuples end on the plane (tuple.h). */
    if (role == BBC_ROLE_RECEIVER && !scene->meshes[m].plane) receivers[nr++] = t;
    if (role == BBC_ROLE_RECEIVER && scene->meshes[m].plane && t == scene->meshes[m].first_triangle)
      receivers[nr++] = BBC_RECEIVER_PLANE(m);
  }
  if (nc == 0) {
    for (uint32_t t = 0; t < scene->triangle_count; t++)
      if (scene->meshes[scene->triangle_mesh[t]].role == BBC_ROLE_RECEIVER) casters[nc++] = t;
  }
  uint64_t state = seed;
  uint32_t tuples = nc * 2 < 3000 ? nc * 2 : 3000;
  for (uint32_t i = 0; i < tuples && r == BBC_OK; i++) {
    int two = i % 3 == 2;
    uint32_t t1 = casters[(i / 3) % nc];
    bbc_tuple t = {i % scene->point_light_count,
                   two ? BBC_CHAIN_TT : BBC_CHAIN_R,
                   {t1, two ? casters[(i / 3 + 1) % nc] : BBC_NO_TRIANGLE},
                   receivers[((uint64_t)(i / 3) * 7 + i % 3) % nr]};
    uint32_t id;
    r = bbc_cache_builder_add_tuple(b, &t, &id);
    int pieces = 1 + (int)(fx_random(&state) * 6);
    double base = 1.0 + 0.5 * sin(0.01 * i);
    for (int k = 0; k < pieces && r == BBC_OK; k++) {
      double c1 = fx_random(&state) * 0.8, c2 = fx_random(&state) * (0.9 - c1);
      double h = 0.02 + 0.3 * fx_random(&state);
      fx_splat sp = {id,
                     t.receiver,
                     c1 - h,
                     c1 + h,
                     c2 - h,
                     c2 + 0.5 * h,
                     i % 50 == 7 && k == 0 ? INFINITY : base * (1.0 + 0.2 * k)};
      r = bbc_cache_builder_splat(b, id, t.receiver, sp.b1_lo, sp.b1_hi, sp.b2_lo, sp.b2_hi,
                                  sp.bound);
      if (record) {
        if (record->count == record->cap) {
          record->cap = record->cap ? record->cap * 2 : 1024;
          record->splats = realloc(record->splats, sizeof(fx_splat) * record->cap);
        }
        record->splats[record->count++] = sp;
      }
    }
  }
  free(casters);
  free(receivers);
  if (r != BBC_OK) {
    bbc_cache_builder_free(b);
    *out = NULL;
  }
  return r;
}

/* ------------------------------------------------------------------ re-layout */

static uint32_t fx_crc(const void *p, size_t n) {
  return (uint32_t)crc32_z(crc32_z(0, NULL, 0), p, n);
}

typedef struct fx_section {
  uint32_t type, flags;
  uint8_t *data;
  size_t size;
} fx_section;

typedef struct fx_file {
  uint16_t major, minor;
  uint32_t count;
  fx_section sec[64];
} fx_file;

static uint64_t fx_ld64(const uint8_t *p) {
  uint64_t v;
  memcpy(&v, p, 8);
  return v;
}
static uint32_t fx_ld32(const uint8_t *p) {
  uint32_t v;
  memcpy(&v, p, 4);
  return v;
}
static void fx_st32(uint8_t *p, uint32_t v) {
  memcpy(p, &v, 4);
}
static void fx_st64(uint8_t *p, uint64_t v) {
  memcpy(p, &v, 8);
}
static uint64_t fx_align(uint64_t x) {
  return (x + 63) & ~(uint64_t)63;
}

/* Parses a valid file into its sections (copies). */
static void fx_parse(const uint8_t *bytes, fx_file *f) {
  memset(f, 0, sizeof *f);
  memcpy(&f->major, bytes + 8, 2);
  memcpy(&f->minor, bytes + 10, 2);
  f->count = fx_ld32(bytes + 12);
  for (uint32_t i = 0; i < f->count; i++) {
    const uint8_t *e = bytes + 64 + 32 * i;
    f->sec[i].type = fx_ld32(e);
    f->sec[i].flags = fx_ld32(e + 4);
    f->sec[i].size = fx_ld64(e + 16);
    f->sec[i].data = malloc(f->sec[i].size + 1);
    memcpy(f->sec[i].data, bytes + fx_ld64(e + 8), f->sec[i].size);
  }
}

static fx_section *fx_find(fx_file *f, const char *name) {
  uint32_t type;
  memcpy(&type, name, 4);
  for (uint32_t i = 0; i < f->count; i++)
    if (f->sec[i].type == type) return &f->sec[i];
  return NULL;
}

static void fx_replace(fx_section *s, const void *data, size_t size) {
  free(s->data);
  s->data = malloc(size + 1);
  memcpy(s->data, data, size);
  s->size = size;
}

/* Recomputes the directory and header checksums of a file in place. */
static void fx_fix_crcs(uint8_t *bytes) {
  uint32_t n = fx_ld32(bytes + 12);
  if (n > 64) n = 64;
  fx_st32(bytes + 28, fx_crc(bytes + 64, 32 * (size_t)n));
  fx_st32(bytes + 60, fx_crc(bytes, 60));
}

/* Writes the sections with the placement of R-LAY-1 and every checksum valid. */
static uint8_t *fx_serialize(const fx_file *f, size_t *size) {
  uint64_t end = 64 + 32 * (uint64_t)f->count, off[64];
  for (uint32_t i = 0; i < f->count; i++) {
    off[i] = fx_align(end + 16);
    end = off[i] + f->sec[i].size;
  }
  uint64_t file_size = fx_align(end + 16);
  uint8_t *b = calloc(1, file_size);
  memcpy(b,
         "\x89"
         "BBC\r\n\x1a\n",
         8);
  memcpy(b + 8, &f->major, 2);
  memcpy(b + 10, &f->minor, 2);
  fx_st32(b + 12, f->count);
  fx_st64(b + 16, file_size);
  for (uint32_t i = 0; i < f->count; i++) {
    uint8_t *e = b + 64 + 32 * i;
    fx_st32(e, f->sec[i].type);
    fx_st32(e + 4, f->sec[i].flags);
    fx_st64(e + 8, off[i]);
    fx_st64(e + 16, f->sec[i].size);
    fx_st32(e + 24, fx_crc(f->sec[i].data, f->sec[i].size));
    if (f->sec[i].size) memcpy(b + off[i], f->sec[i].data, f->sec[i].size);
  }
  fx_fix_crcs(b);
  *size = file_size;
  return b;
}

static void fx_free(fx_file *f) {
  for (uint32_t i = 0; i < f->count; i++) free(f->sec[i].data);
}

/* Offset of section `name` in a file (its directory entry), or 0. */
static uint64_t fx_section_offset(const uint8_t *bytes, const char *name, uint64_t *size,
                                  uint32_t *index) {
  uint32_t type, n = fx_ld32(bytes + 12);
  memcpy(&type, name, 4);
  for (uint32_t i = 0; i < n && i < 64; i++) {
    const uint8_t *e = bytes + 64 + 32 * i;
    if (fx_ld32(e) == type) {
      if (size) *size = fx_ld64(e + 16);
      if (index) *index = i;
      return fx_ld64(e + 8);
    }
  }
  return 0;
}

/* Replaces the chunk data of a one-chunk file by the given bytes, as a chunk of
 * `entries` entries with a valid checksum. */
static uint8_t *fx_with_frame(const uint8_t *bytes, const uint8_t *frame, size_t n,
                              uint32_t entries, size_t *size) {
  fx_file f;
  fx_parse(bytes, &f);
  fx_replace(fx_find(&f, "CDAT"), frame, n);
  uint8_t rec[24] = {0};
  fx_st64(rec, 0);
  fx_st32(rec + 8, (uint32_t)n);
  fx_st32(rec + 12, entries);
  fx_st32(rec + 16, fx_crc(frame, n));
  fx_replace(fx_find(&f, "CHNK"), rec, 24);
  uint8_t *out = fx_serialize(&f, size);
  fx_free(&f);
  return out;
}

/* The same with one frame of the given planes (n entries), compressed at level 3 with
 * the content checksum flag `checksum`. */
static uint8_t *fx_with_chunk_flags(const uint8_t *bytes, const void *planes, size_t planes_size,
                                    uint32_t entries, int checksum, size_t *size) {
  size_t cap = ZSTD_compressBound(planes_size);
  uint8_t *frame = malloc(cap);
  ZSTD_CCtx *cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, 3);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, checksum);
  size_t n = ZSTD_compress2(cctx, frame, cap, planes, planes_size);
  ZSTD_freeCCtx(cctx);
  uint8_t *out = fx_with_frame(bytes, frame, n, entries, size);
  free(frame);
  return out;
}

static uint8_t *fx_with_chunk(const uint8_t *bytes, const void *planes, size_t planes_size,
                              uint32_t entries, size_t *size) {
  return fx_with_chunk_flags(bytes, planes, planes_size, entries, 0, size);
}

/* The one frame of the minimal file (Appendix A: single segment, 1-byte content size)
 * with a Dictionary_ID field of one byte holding `id` inserted after the frame header
 * descriptor; *n is its size. */
static uint8_t *fx_minimal_frame_with_dict_id(const uint8_t *mini, uint8_t id, size_t *n) {
  uint64_t csize = 0, off = fx_section_offset(mini, "CDAT", &csize, NULL);
  uint8_t *frame = malloc(csize + 1);
  memcpy(frame, mini + off, 5);
  frame[4] |= 1; /* Dictionary_ID_flag 1: a 1-byte field */
  frame[5] = id;
  memcpy(frame + 6, mini + off + 5, csize - 5);
  *n = csize + 1;
  return frame;
}

/* ------------------------------------------------------------------ invalid corpus */

typedef struct fx_case {
  char name[96]; /* <expected_error>--<what>, the corpus file name without .bbc */
  bbc_result expected;
  uint8_t *bytes;
  size_t size;
} fx_case;

static const char *fx_code_name(bbc_result r) {
  switch (r) {
    case BBC_ERR_NOT_BBC:
      return "not_bbc";
    case BBC_ERR_VERSION_UNSUPPORTED:
      return "version_unsupported";
    case BBC_ERR_TRUNCATED:
      return "truncated";
    case BBC_ERR_CORRUPT:
      return "corrupt";
    case BBC_ERR_CHECKSUM:
      return "checksum";
    default:
      return "other";
  }
}

static void fx_add(fx_case *cases, int *n, bbc_result expected, const char *what, uint8_t *bytes,
                   size_t size) {
  fx_case *c = &cases[(*n)++];
  snprintf(c->name, sizeof c->name, "%s--%s", fx_code_name(expected), what);
  c->expected = expected;
  c->bytes = bytes;
  c->size = size;
}

static uint8_t *fx_copy(const void *p, size_t n) {
  uint8_t *b = malloc(n ? n : 1);
  if (n) memcpy(b, p, n);
  return b;
}

/* Every invalid case, each breaking exactly one rule of the spec; at most 96. */
static int fx_invalid_corpus(fx_case *cases) {
  void *base_v = NULL, *min_v = NULL;
  size_t size = 0, min_size = 0;
  if (fx_base_cache(&base_v, &size) != BBC_OK || fx_minimal_cache(&min_v, &min_size) != BBC_OK)
    return 0;
  const uint8_t *base = base_v, *mini = min_v;
  int n = 0;
  uint8_t *b;
  char what[80];
  size_t s;

  /* R-HDR-1 */
  b = fx_copy(base, size);
  b[1] = 'X';
  fx_add(cases, &n, BBC_ERR_NOT_BBC, "wrong-magic", b, size);
  fx_add(cases, &n, BBC_ERR_NOT_BBC, "text-file", fx_copy("hello, world\n", 13), 13);
  fx_add(cases, &n, BBC_ERR_NOT_BBC, "short-non-magic", fx_copy("BBC", 3), 3);
  /* Truncations (R-HDR-1, -2, -4, -7) at offsets in every part of the file. */
  uint64_t cuts[] = {0, 3, 8, 11, 12, 40, 63, 64, 100, 300};
  for (size_t i = 0; i < sizeof cuts / sizeof *cuts; i++) {
    snprintf(what, sizeof what, "cut-at-%llu", (unsigned long long)cuts[i]);
    fx_add(cases, &n, BBC_ERR_TRUNCATED, what, fx_copy(base, cuts[i]), cuts[i]);
  }
  const char *names[] = {"INFO", "PARM", "FPRT", "RCVR", "TRUV", "TUPL", "CIDX", "CDAT", "CHNK"};
  for (int i = 0; i < 9; i++) {
    uint64_t ssize = 0, off = fx_section_offset(base, names[i], &ssize, NULL);
    uint64_t cut = off + ssize / 2;
    snprintf(what, sizeof what, "cut-in-%s", names[i]);
    fx_add(cases, &n, BBC_ERR_TRUNCATED, what, fx_copy(base, cut), cut);
    /* A flipped byte in each section (R-DIR-6, R-CHK-3). */
    b = fx_copy(base, size);
    b[off + ssize / 2] ^= 0x20;
    snprintf(what, sizeof what, "flipped-byte-in-%s", names[i]);
    fx_add(cases, &n, BBC_ERR_CHECKSUM, what, b, size);
  }
  fx_add(cases, &n, BBC_ERR_TRUNCATED, "cut-before-end", fx_copy(base, size - 1), size - 1);
  /* R-HDR-2 */
  b = fx_copy(base, size);
  b[8] = 2;
  fx_add(cases, &n, BBC_ERR_VERSION_UNSUPPORTED, "major-version-2", b, size);
  b = fx_copy(base, size);
  b[8] = 0;
  fx_add(cases, &n, BBC_ERR_CORRUPT, "major-version-0", b, size);
  /* R-HDR-5, R-DIR-1 */
  b = fx_copy(base, size);
  b[20] ^= 1;
  fx_add(cases, &n, BBC_ERR_CHECKSUM, "flipped-byte-in-header", b, size);
  b = fx_copy(base, size);
  b[64 + 32 + 9] ^= 1;
  fx_add(cases, &n, BBC_ERR_CHECKSUM, "flipped-byte-in-directory", b, size);
  /* R-HDR-6 */
  b = fx_copy(base, size);
  b[40] = 1;
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "nonzero-reserved-header", b, size);
  b = fx_copy(base, size);
  b[24] = 1;
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "nonzero-header-flags", b, size);
  /* R-HDR-7 */
  b = calloc(1, size + 64);
  memcpy(b, base, size);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "trailing-bytes", b, size + 64);
  /* R-HDR-8 */
  b = fx_copy(base, size);
  fx_st32(b + 12, 1000);
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "absurd-section-count", b, size);
  b = fx_copy(base, size);
  fx_st32(b + 12, 0);
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "zero-sections", b, size);
  /* R-DIR-2 */
  b = fx_copy(base, size);
  b[64 + 32 + 4] |= 2;
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "reserved-section-flag", b, size);
  b = fx_copy(base, size);
  b[64 + 32 + 28] = 7;
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "nonzero-reserved-directory-field", b, size);
  /* R-LAY-1: overlapping sections, a section past the end, an absurd size, a gap. */
  {
    uint32_t i2 = 0;
    uint64_t off2 = fx_section_offset(base, "FPRT", NULL, &i2);
    uint64_t off1 = fx_section_offset(base, "PARM", NULL, NULL);
    (void)off2;
    b = fx_copy(base, size);
    fx_st64(b + 64 + 32 * i2 + 8, off1);
    fx_fix_crcs(b);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "overlapping-sections", b, size);
    b = fx_copy(base, size);
    fx_st64(b + 64 + 32 * i2 + 8, size + 64);
    fx_fix_crcs(b);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "section-offset-past-end", b, size);
    b = fx_copy(base, size);
    fx_st64(b + 64 + 32 * i2 + 16, UINT64_MAX - 8);
    fx_fix_crcs(b);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "absurd-section-size", b, size);
    b = fx_copy(base, size);
    fx_st64(b + 64 + 32 * i2 + 8, fx_ld64(b + 64 + 32 * i2 + 8) + 64);
    fx_fix_crcs(b);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "gap-between-sections", b, size);
  }
  /* Content rules, through re-layout so all checksums are valid. */
  {
    fx_file f;
    fx_section *sec;
#define FX_EDIT(code, label, section, stmt) \
  do {                                      \
    fx_parse(base, &f);                     \
    sec = fx_find(&f, section);             \
    stmt;                                   \
    b = fx_serialize(&f, &s);               \
    fx_free(&f);                            \
    fx_add(cases, &n, code, label, b, s);   \
  } while (0)
    FX_EDIT(BBC_ERR_CORRUPT, "duplicate-section", "INFO", free(sec->data); f.sec[0] = f.sec[1];
            f.sec[0].data = fx_copy(f.sec[1].data, f.sec[1].size));
    FX_EDIT(BBC_ERR_VERSION_UNSUPPORTED, "unknown-required-section", "INFO",
            memcpy(&sec->type, "ZZZZ", 4);
            sec->flags = 1);
    FX_EDIT(BBC_ERR_CORRUPT, "missing-section-TUPL", "TUPL", memcpy(&sec->type, "ZZZZ", 4);
            sec->flags = 0);
    FX_EDIT(BBC_ERR_CORRUPT, "required-section-marked-optional", "PARM", sec->flags = 0);
    FX_EDIT(BBC_ERR_CORRUPT, "short-PARM", "PARM", sec->size = 60);
    FX_EDIT(BBC_ERR_CORRUPT, "nonzero-reserved-PARM", "PARM", sec->data[58] = 1);
    /* R-PAR-1 (1.5): alpha_area is 0 without area lights; this file has none. */
    FX_EDIT(BBC_ERR_CORRUPT, "alpha-area-without-area-lights", "PARM", {
      double a = 100.0;
      memcpy(sec->data + 48, &a, 8);
    });
    FX_EDIT(BBC_ERR_CORRUPT, "unknown-chain-bit", "PARM", sec->data[0] = 0x7F);
    /* R-PAR-1 (1.9): the two-bounce level is at most 64, and 0 without a two-bounce
     * chain type. */
    FX_EDIT(BBC_ERR_CORRUPT, "absurd-max-level-double", "PARM", fx_st32(sec->data + 60, 65));
    FX_EDIT(BBC_ERR_CORRUPT, "max-level-double-without-two-bounce", "PARM", {
      fx_st32(sec->data, 1u << BBC_CHAIN_R | 1u << BBC_CHAIN_T);
      fx_st32(sec->data + 60, 3);
    });
    FX_EDIT(BBC_ERR_CORRUPT, "nan-sigma", "PARM", memset(sec->data + 8, 0xFF, 8));
    FX_EDIT(BBC_ERR_CORRUPT, "absurd-grid-resolution", "PARM",
            fx_st32(sec->data + 40, 0x80000000u));
    FX_EDIT(BBC_ERR_CORRUPT, "fingerprint-not-hash-of-parts", "FPRT", sec->data[0] ^= 1);
    FX_EDIT(BBC_ERR_CORRUPT, "no-receiver", "RCVR", sec->size = 0);
    FX_EDIT(BBC_ERR_CORRUPT, "absurd-grid-width", "RCVR", fx_st32(sec->data + 16, 1u << 31));
    FX_EDIT(BBC_ERR_CORRUPT, "receiver-past-scene", "RCVR", fx_st32(sec->data + 8, 1000));
    FX_EDIT(BBC_ERR_CORRUPT, "bad-parameterisation", "RCVR", fx_st32(sec->data + 4, 7));
    FX_EDIT(BBC_ERR_CORRUPT, "nonzero-reserved-RCVR", "RCVR", sec->data[125] = 1);
    FX_EDIT(BBC_ERR_CORRUPT, "truv-count-mismatch", "TRUV", sec->size -= 24);
    FX_EDIT(BBC_ERR_CORRUPT, "truv-out-of-grid", "TRUV", {
      float v = 1e9f;
      memcpy(sec->data + 4, &v, 4);
    });
    FX_EDIT(BBC_ERR_CORRUPT, "tuple-bad-chain", "TUPL", fx_st32(sec->data + 4, 9));
    FX_EDIT(BBC_ERR_CORRUPT, "tuple-bad-light", "TUPL", fx_st32(sec->data, 5));
    FX_EDIT(BBC_ERR_CORRUPT, "tuple-receiver-not-receiver", "TUPL", fx_st32(sec->data + 16, 0));
    FX_EDIT(BBC_ERR_CORRUPT, "tuple-table-not-multiple", "TUPL", sec->size -= 3);
    FX_EDIT(BBC_ERR_CORRUPT, "cidx-count-mismatch", "CIDX", sec->size -= 12);
    FX_EDIT(BBC_ERR_CORRUPT, "cidx-list-gap", "CIDX", {
      for (size_t i = 0; i < sec->size; i += 12)
        if (fx_ld32(sec->data + i + 8)) {
          fx_st32(sec->data + i + 4, 1);
          break;
        }
    });
    FX_EDIT(BBC_ERR_CORRUPT, "cidx-empty-cell-nonzero", "CIDX", {
      for (size_t i = 0; i < sec->size; i += 12)
        if (!fx_ld32(sec->data + i + 8)) {
          fx_st32(sec->data + i, 1);
          break;
        }
    });
    FX_EDIT(BBC_ERR_CORRUPT, "chunk-frames-do-not-tile", "CHNK", fx_st64(sec->data + 24, 1));
    FX_EDIT(BBC_ERR_CORRUPT, "absurd-chunk-entries", "CHNK", fx_st32(sec->data + 12, 1u << 30));
    FX_EDIT(BBC_ERR_CORRUPT, "zero-size-frame", "CHNK", fx_st32(sec->data + 8, 0));
    FX_EDIT(BBC_ERR_CORRUPT, "nonzero-reserved-CHNK", "CHNK", sec->data[20] = 1);
    FX_EDIT(BBC_ERR_CORRUPT, "chunk-crc-valid-garbage-frame", "CDAT", {
      memset(sec->data, 0x5A, sec->size);
      uint8_t *chnk = fx_find(&f, "CHNK")->data;
      size_t nchunks = fx_find(&f, "CHNK")->size / 24;
      for (size_t i = 0; i < nchunks; i++) {
        uint64_t o = fx_ld64(chnk + 24 * i);
        uint32_t cs = fx_ld32(chnk + 24 * i + 8);
        fx_st32(chnk + 24 * i + 16, fx_crc(sec->data + o, cs));
      }
    });
#undef FX_EDIT
  }
  /* R-LAY-2: padding. */
  {
    uint64_t ssize = 0, off = fx_section_offset(base, "PARM", &ssize, NULL);
    b = fx_copy(base, size);
    b[off + ssize + 3] = 1;
    fx_add(cases, &n, BBC_ERR_CORRUPT, "nonzero-padding", b, size);
  }
  /* Chunk content (R-CHK-4, R-CHK-5, R-BND-1) on the minimal file's single entry. */
  {
    uint8_t planes[12] = {5, 0, 0, 0, 0x00, 0x7F}; /* id 5, there is 1 tuple */
    b = fx_with_chunk(mini, planes, 6, 1, &s);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "tuple-id-past-table", b, s);
    uint8_t nan_code[6] = {0, 0, 0, 0, 0xFF, 0xFF};
    b = fx_with_chunk(mini, nan_code, 6, 1, &s);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "bound-code-nan", b, s);
    b = fx_with_chunk(mini, planes, 12, 1, &s); /* 12 bytes for 1 entry */
    fx_add(cases, &n, BBC_ERR_CORRUPT, "frame-size-mismatch", b, s);
  }
  /* R-CHK-4 and R-CHK-6: zstd frame details, on the minimal file's chunk of 4 entries. */
  {
    uint64_t csize = 0, off = fx_section_offset(mini, "CDAT", &csize, NULL);
    uint8_t frame[256], planes[24] = {0, 0, 0, 0, 0, 0x7F, 0, 0, 0, 0, 0, 0x7F,
                                      0, 0, 0, 0, 0, 0x7F, 0, 0, 0, 0, 0, 0x7F};
    size_t fn;
    /* A skippable frame (magic 0x184D2A50) holding the 24 bytes. */
    fx_st32(frame, 0x184D2A50u);
    fx_st32(frame + 4, 24);
    memcpy(frame + 8, planes, 24);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-skippable-frame", fx_with_frame(mini, frame, 32, 4, &s),
           s);
    /* The frame followed by an empty skippable frame, and by one stray byte. */
    memcpy(frame, mini + off, csize);
    fx_st32(frame + csize, 0x184D2A5Fu);
    fx_st32(frame + csize + 4, 0);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-frame-then-skippable-frame",
           fx_with_frame(mini, frame, csize + 8, 4, &s), s);
    frame[csize] = 0;
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-frame-then-trailing-byte",
           fx_with_frame(mini, frame, csize + 1, 4, &s), s);
    /* Two frames of 12 bytes each (each declares half the chunk). */
    size_t h = ZSTD_compress(frame, 128, planes, 12, 3);
    h += ZSTD_compress(frame + h, 128, planes + 12, 12, 3);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-two-frames", fx_with_frame(mini, frame, h, 4, &s), s);
    /* No Frame_Content_Size field (a non-single-segment frame with FCS flag 0). */
    {
      ZSTD_CCtx *cctx = ZSTD_createCCtx();
      ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 0);
      fn = ZSTD_compress2(cctx, frame, sizeof frame, planes, 24);
      ZSTD_freeCCtx(cctx);
      fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-frame-without-content-size",
             fx_with_frame(mini, frame, fn, 4, &s), s);
    }
    /* A frame that names dictionary 7. */
    uint8_t *d = fx_minimal_frame_with_dict_id(mini, 7, &fn);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-frame-needs-dictionary",
           fx_with_frame(mini, d, fn, 4, &s), s);
    free(d);
    /* The zstd magic with a legacy (v0.7) magic instead. */
    memcpy(frame, mini + off, csize);
    fx_st32(frame, 0xFD2FB527u);
    fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-legacy-zstd-magic",
           fx_with_frame(mini, frame, csize, 4, &s), s);
    /* A content checksum that does not match the content. */
    b = fx_with_chunk_flags(mini, planes, 24, 4, 1, &s);
    {
      uint64_t o2 = fx_section_offset(b, "CDAT", &csize, NULL);
      memcpy(frame, b + o2, csize);
      free(b);
      frame[csize - 1] ^= 0x55;
      fx_add(cases, &n, BBC_ERR_CORRUPT, "chunk-frame-content-checksum-mismatch",
             fx_with_frame(mini, frame, csize, 4, &s), s);
    }
  }
  /* R-HDR-7: file_size not a multiple of 64, for a file as long as it says and for a
   * shorter one (truncation is told first). */
  b = calloc(1, size + 13);
  memcpy(b, base, size);
  fx_st64(b + 16, size + 13);
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "file-size-not-multiple-of-64", b, size + 13);
  b = fx_copy(base, size);
  fx_st64(b + 16, size + 13);
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_TRUNCATED, "short-and-file-size-not-multiple-of-64", b, size);
  /* R-HDR-9: a directory that runs past the end of the file (40 entries, 1344 bytes, in
   * the 1152-byte minimal file). */
  b = fx_copy(mini, min_size);
  fx_st32(b + 12, 40);
  fx_fix_crcs(b);
  fx_add(cases, &n, BBC_ERR_CORRUPT, "directory-past-end", b, min_size);
  {
    fx_file f;
    fx_section *sec;
#define FX_EDIT2(code, label, section, stmt) \
  do {                                       \
    fx_parse(base, &f);                      \
    sec = fx_find(&f, section);              \
    stmt;                                    \
    b = fx_serialize(&f, &s);                \
    fx_free(&f);                             \
    fx_add(cases, &n, code, label, b, s);    \
  } while (0)
    /* R-DIR-7 */
    FX_EDIT2(BBC_ERR_CORRUPT, "non-ascii-section-type", "INFO", memcpy(&sec->type, "\xC9NFO", 4));
    FX_EDIT2(BBC_ERR_CORRUPT, "section-type-with-space", "INFO", memcpy(&sec->type, "IN O", 4));
    /* R-INF-1 */
    FX_EDIT2(BBC_ERR_CORRUPT, "info-invalid-utf8", "INFO", sec->data[1] = 0xC0);
    FX_EDIT2(BBC_ERR_CORRUPT, "info-control-character", "INFO", sec->data[1] = '\n');
    /* R-RCV-5 */
    FX_EDIT2(BBC_ERR_CORRUPT, "texcoord-receiver-with-axes", "RCVR", {
      double one = 1.0;
      memcpy(sec->data + 72, &one, 8);
    });
    /* R-DIR-6 covers unknown optional sections too. */
    fx_parse(base, &f);
    memcpy(&fx_find(&f, "INFO")->type, "ZZZZ", 4);
    b = fx_serialize(&f, &s);
    fx_free(&f);
    {
      uint64_t zs = 0, zo = fx_section_offset(b, "ZZZZ", &zs, NULL);
      b[zo + zs / 2] ^= 0x20;
    }
    fx_add(cases, &n, BBC_ERR_CHECKSUM, "flipped-byte-in-unknown-optional-section", b, s);
#undef FX_EDIT2
  }
  free(base_v);
  free(min_v);
  return n;
}

#endif
