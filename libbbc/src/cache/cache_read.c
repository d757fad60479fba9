/* Reading .bbc caches (format-spec/bbc-format.md): mapping, the structural checks of
 * Sec. 9 in the order the spec lists them (each cites its requirement ID), cell lookup
 * through per-thread cursors, full validation and the scene checks.
 *
 * Nothing read from the file is trusted before it is checked: every offset and size is
 * compared with the file length and the limits of Sec. 10 before it is used or
 * allocated, and nothing here asserts on input bytes. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "geometry_internal.h"
#include "grid_internal.h"
#include "report_internal.h"
#include "scene_internal.h"

/* Known sections, in the order writers use; INFO, GEOM and SHRD are optional. */
enum {
  K_INFO,
  K_PARM,
  K_FPRT,
  K_RCVR,
  K_TRUV,
  K_TUPL,
  K_CIDX,
  K_CDAT,
  K_CHNK,
  K_GEOM,
  K_SHRD,
  K_COUNT
};
static const uint32_t known_types[K_COUNT] = {
    BBC__SEC_INFO, BBC__SEC_PARM, BBC__SEC_FPRT, BBC__SEC_RCVR, BBC__SEC_TRUV, BBC__SEC_TUPL,
    BBC__SEC_CIDX, BBC__SEC_CDAT, BBC__SEC_CHNK, BBC__SEC_GEOM, BBC__SEC_SHRD};

static int optional_section(int k) {
  return k == K_INFO || k == K_GEOM || k == K_SHRD;
}

struct bbc_cache {
  const uint8_t *base;
  uint64_t size;
  void *map; /* mmap of the file, or NULL */
  size_t map_size;
  void *copy; /* aligned copy of misaligned memory, or NULL */
  char path[1024];
  bbc_cache_options options;

  uint32_t version_major, version_minor;
  uint32_t section_count;
  bbc_cache_section sections[BBC__MAX_SECTIONS];
  const uint8_t *sec[K_COUNT]; /* start of each known section present, else NULL */
  uint64_t sec_size[K_COUNT];
  uint64_t sec_offset[K_COUNT];

  bbc_precompute_params params;
  bbc_fingerprint fingerprint;
  uint32_t scene_counts[6];
  uint32_t tuple_count;
  bbc_grid grid;
  bbc_receiver *receivers;
  uint32_t chunk_count;
  uint64_t nonempty_cells, entry_count;
  atomic_uchar *chunk_verified; /* R-CHK-3: 1 once a chunk's checksum matched */
  /* Decoded chunks kept for every cursor (options.keep_decoded): per chunk its 6N bytes
   * once one decode succeeded, else NULL; the bytes they take, within the budget. */
  _Atomic(uint8_t *) *kept;
  atomic_size_t kept_bytes;
  char writer[128];
  int is_shard; /* SHRD present and checked (R-SHR-*) */
  bbc_cache_shard shard;
};

static const char *section_name(uint32_t type, char out[5]) {
  for (int k = 0; k < 4; k++) {
    char ch = (char)(type >> (8 * k));
    out[k] = (ch >= 32 && ch < 127) ? ch : '?';
  }
  out[4] = '\0';
  return out;
}

/* One line through the error callback: the file, where, what, which rule. */
static bbc_result fail(const bbc_cache *c, bbc_result code, const char *where, uint64_t offset,
                       const char *fmt, ...) __attribute__((format(printf, 5, 6)));
static bbc_result fail(const bbc_cache *c, bbc_result code, const char *where, uint64_t offset,
                       const char *fmt, ...) {
  if (!c->options.error_fn) return code;
  char what[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(what, sizeof what, fmt, ap);
  va_end(ap);
  return bbc__report(c->options.error_fn, c->options.user, code, "%s: %s at byte %llu: %s", c->path,
                     where, (unsigned long long)offset, what);
}

/* A checksum comparison. Fuzzing builds (FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION, as in
 * zstd and OSS-Fuzz) accept every checksum, so that mutated inputs reach the structural
 * checks behind them instead of all failing here; such a build must never read real
 * files. */
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
#define CHECKSUM_DIFFERS(computed, stored) ((void)(computed), (void)(stored), 0)
#else
#define CHECKSUM_DIFFERS(computed, stored) ((computed) != (stored))
#endif

static uint32_t crc_of(const uint8_t *p, uint64_t n) {
  return (uint32_t)crc32_z(crc32_z(0, NULL, 0), p, (size_t)n);
}

static int all_zero(const uint8_t *p, uint64_t n) {
  for (uint64_t i = 0; i < n; i++)
    if (p[i]) return 0;
  return 1;
}

/* ------------------------------------------------------------------ header, directory */

static bbc_result check_header_and_directory(bbc_cache *c) {
  const uint8_t *p = c->base;
  uint64_t size = c->size;

  /* R-HDR-1: the magic; a proper prefix of it is a truncated file. */
  size_t m = size < 8 ? (size_t)size : 8;
  if (memcmp(p, BBC__MAGIC, m) != 0)
    return fail(c, BBC_ERR_NOT_BBC, "header", 0, "wrong magic, not a .bbc file (R-HDR-1)");
  if (size < 8)
    return fail(c, BBC_ERR_TRUNCATED, "header", size,
                "file of %llu bytes ends inside the magic (R-HDR-1)", (unsigned long long)size);
  /* R-HDR-2: the version, before anything else a later major version may move. */
  if (size < 12)
    return fail(c, BBC_ERR_TRUNCATED, "header", size, "file ends inside the version (R-HDR-2)");
  c->version_major = bbc__ld16(p + 8);
  c->version_minor = bbc__ld16(p + 10);
  if (c->version_major > BBC_FORMAT_VERSION_MAJOR)
    return fail(c, BBC_ERR_VERSION_UNSUPPORTED, "header", 8,
                "format version %u.%u is newer than this reader's %d.%d (R-HDR-2)",
                c->version_major, c->version_minor, BBC_FORMAT_VERSION_MAJOR,
                BBC_FORMAT_VERSION_MINOR);
  if (c->version_major == 0)
    return fail(c, BBC_ERR_CORRUPT, "header", 8, "major version 0 (R-HDR-2)");
  /* R-HDR-3: any minor version is accepted. R-HDR-4: the whole header is there. */
  if (size < BBC__HEADER_SIZE)
    return fail(c, BBC_ERR_TRUNCATED, "header", size, "file ends inside the header (R-HDR-4)");
  if (CHECKSUM_DIFFERS(crc_of(p, 60), bbc__ld32(p + 60)))
    return fail(c, BBC_ERR_CHECKSUM, "header", 60, "header checksum mismatch (R-HDR-5)");
  if (bbc__ld32(p + 24) != 0 || !all_zero(p + 32, 28))
    return fail(c, BBC_ERR_CORRUPT, "header", 24, "reserved header field not zero (R-HDR-6)");
  uint32_t n = bbc__ld32(p + 12);
  if (n < 1 || n > BBC__MAX_SECTIONS)
    return fail(c, BBC_ERR_CORRUPT, "header", 12, "section count %u outside [1, %u] (R-HDR-8)", n,
                BBC__MAX_SECTIONS);
  uint64_t file_size = bbc__ld64(p + 16);
  if (size < file_size)
    return fail(c, BBC_ERR_TRUNCATED, "header", 16,
                "file has %llu bytes, its header says %llu (R-HDR-7)", (unsigned long long)size,
                (unsigned long long)file_size);
  if (file_size % BBC__ALIGN != 0)
    return fail(c, BBC_ERR_CORRUPT, "header", 16,
                "file size %llu in the header is not a multiple of 64 (R-HDR-7)",
                (unsigned long long)file_size);
  if (size > file_size)
    return fail(c, BBC_ERR_CORRUPT, "header", 16,
                "file has %llu bytes, its header says %llu (R-HDR-7)", (unsigned long long)size,
                (unsigned long long)file_size);
  uint64_t dir_end = BBC__HEADER_SIZE + (uint64_t)BBC__DIR_ENTRY_SIZE * n;
  if (dir_end > file_size)
    return fail(c, BBC_ERR_CORRUPT, "directory", BBC__HEADER_SIZE,
                "%u entries run past the end of the file (R-HDR-9)", n);
  if (CHECKSUM_DIFFERS(crc_of(p + BBC__HEADER_SIZE, dir_end - BBC__HEADER_SIZE), bbc__ld32(p + 28)))
    return fail(c, BBC_ERR_CHECKSUM, "directory", BBC__HEADER_SIZE,
                "directory checksum mismatch (R-DIR-1)");

  c->section_count = n;
  uint64_t end = dir_end;
  for (uint32_t i = 0; i < n; i++) {
    const uint8_t *e = p + BBC__HEADER_SIZE + BBC__DIR_ENTRY_SIZE * i;
    uint64_t at = BBC__HEADER_SIZE + (uint64_t)BBC__DIR_ENTRY_SIZE * i;
    bbc_cache_section *s = &c->sections[i];
    s->type = bbc__ld32(e);
    section_name(s->type, s->name);
    s->flags = bbc__ld32(e + 4);
    s->offset = bbc__ld64(e + 8);
    s->size = bbc__ld64(e + 16);
    s->checksum = bbc__ld32(e + 24);
    if ((s->flags & ~BBC__SECTION_REQUIRED) != 0 || bbc__ld32(e + 28) != 0)
      return fail(c, BBC_ERR_CORRUPT, "directory", at + 4,
                  "section %s: reserved flag bits or field not zero (R-DIR-2)", s->name);
    for (int k = 0; k < 4; k++)
      if (e[k] < 0x21 || e[k] > 0x7E)
        return fail(c, BBC_ERR_CORRUPT, "directory", at,
                    "section type byte 0x%02x is not printable ASCII (R-DIR-7)", e[k]);
    /* R-LAY-1: the one placement allowed, which also rules out overlaps and sections
     * outside the file. */
    if (s->offset != bbc__align64(end + BBC__MIN_PADDING))
      return fail(c, BBC_ERR_CORRUPT, "directory", at + 8,
                  "section %s at offset %llu, expected %llu (R-LAY-1)", s->name,
                  (unsigned long long)s->offset,
                  (unsigned long long)bbc__align64(end + BBC__MIN_PADDING));
    if (s->offset > file_size || s->size > file_size - s->offset)
      return fail(c, BBC_ERR_CORRUPT, "directory", at + 16,
                  "section %s of %llu bytes ends past the end of the file (R-LAY-1)", s->name,
                  (unsigned long long)s->size);
    end = s->offset + s->size;
  }
  if (bbc__align64(end + BBC__MIN_PADDING) != file_size)
    return fail(c, BBC_ERR_CORRUPT, "directory", 16,
                "file size %llu, expected %llu after the last section (R-LAY-1)",
                (unsigned long long)file_size,
                (unsigned long long)bbc__align64(end + BBC__MIN_PADDING));

  for (uint32_t i = 0; i < n; i++) {
    const bbc_cache_section *s = &c->sections[i];
    uint64_t at = BBC__HEADER_SIZE + (uint64_t)BBC__DIR_ENTRY_SIZE * i;
    for (uint32_t j = 0; j < i; j++)
      if (c->sections[j].type == s->type)
        return fail(c, BBC_ERR_CORRUPT, "directory", at, "section %s appears twice (R-DIR-3)",
                    s->name);
    int k = 0;
    while (k < K_COUNT && known_types[k] != s->type) k++;
    if (k == K_COUNT) {
      if (s->flags & BBC__SECTION_REQUIRED)
        return fail(c, BBC_ERR_VERSION_UNSUPPORTED, "directory", at,
                    "required section %s is unknown to this reader (R-DIR-5)", s->name);
      continue; /* R-DIR-5: an unknown optional section is skipped. */
    }
    uint32_t want = optional_section(k) ? 0 : BBC__SECTION_REQUIRED;
    if (s->flags != want)
      return fail(c, BBC_ERR_CORRUPT, "directory", at + 4, "section %s marked %s (R-DIR-4)",
                  s->name, want ? "optional" : "required");
    c->sec[k] = p + s->offset;
    c->sec_size[k] = s->size;
    c->sec_offset[k] = s->offset;
  }
  for (int k = 0; k < K_COUNT; k++)
    if (!optional_section(k) && !c->sec[k]) {
      char name[5];
      return fail(c, BBC_ERR_CORRUPT, "directory", BBC__HEADER_SIZE,
                  "required section %s is missing (R-DIR-4)", section_name(known_types[k], name));
    }

  /* R-SEC-1: the fixed sizes and record multiples; exact counts come with the content. */
  static const uint64_t record[K_COUNT] = {1,
                                           0,
                                           0,
                                           BBC__RCVR_SIZE,
                                           BBC__TRUV_SIZE,
                                           BBC__TUPL_SIZE,
                                           BBC__CIDX_SIZE,
                                           1,
                                           BBC__CHNK_SIZE,
                                           1,
                                           BBC__SHRD_ENTRY_SIZE};
  for (int k = 0; k < K_COUNT; k++) {
    if (!c->sec[k]) continue;
    char name[5];
    section_name(known_types[k], name);
    uint64_t sz = c->sec_size[k];
    int bad = k == K_PARM   ? sz != BBC__PARM_SIZE
              : k == K_FPRT ? sz != BBC__FPRT_SIZE
              : k == K_INFO ? sz > BBC__MAX_INFO
              : k == K_GEOM ? sz <= BBC__GEOM_HEAD_SIZE
              : k == K_SHRD
                  ? sz < BBC__SHRD_HEAD_SIZE || (sz - BBC__SHRD_HEAD_SIZE) % record[k] != 0
                  : sz % record[k] != 0;
    if (bad)
      return fail(c, BBC_ERR_CORRUPT, name, c->sec_offset[k],
                  "section size %llu is not valid for %s (R-SEC-1)", (unsigned long long)sz, name);
  }

  /* R-LAY-2: the padding is zero. */
  end = dir_end;
  for (uint32_t i = 0; i <= n; i++) {
    uint64_t next = i < n ? c->sections[i].offset : file_size;
    if (!all_zero(p + end, next - end))
      return fail(c, BBC_ERR_CORRUPT, "padding", end, "padding byte not zero (R-LAY-2)");
    if (i < n) end = c->sections[i].offset + c->sections[i].size;
  }

  /* R-DIR-6: every checksum but the chunk data's, which is covered per chunk. */
  for (uint32_t i = 0; i < n; i++) {
    const bbc_cache_section *s = &c->sections[i];
    if (s->type == BBC__SEC_CDAT) continue;
    if (CHECKSUM_DIFFERS(crc_of(p + s->offset, s->size), s->checksum))
      return fail(c, BBC_ERR_CHECKSUM, s->name, s->offset, "section %s checksum mismatch (R-DIR-6)",
                  s->name);
  }
  return BBC_OK;
}

/* ------------------------------------------------------------------ content */

static bbc_result check_params_and_fingerprint(bbc_cache *c) {
  const uint8_t *p = c->sec[K_PARM];
  uint64_t at = c->sec_offset[K_PARM];
  bbc_precompute_params *q = &c->params;
  q->chains = bbc__ld32(p);
  q->max_level = bbc__ld32(p + 4);
  q->sigma = bbc__ldf64(p + 8);
  q->alpha_single = bbc__ldf64(p + 16);
  q->alpha_double = bbc__ldf64(p + 24);
  q->m = bbc__ldf64(p + 32);
  q->grid_resolution = bbc__ld32(p + 40);
  uint32_t flags = bbc__ld32(p + 44);
  q->remainder = flags & 1u;
  q->area_lights = (flags >> 1) & 1u;
  q->area_double = (flags >> 2) & 1u;
  q->beam_receivers = (flags >> 3) & 1u;
  q->alpha_area = bbc__ldf64(p + 48);
  q->cell_levels = bbc__ld32(p + 56);
  q->max_level_double = bbc__ld32(p + 60);
  if ((q->chains & ~BBC_CHAIN_MASK_ALL) != 0)
    return fail(c, BBC_ERR_CORRUPT, "PARM", at, "reserved chain bits 0x%x not zero (R-FILE-2)",
                q->chains & ~BBC_CHAIN_MASK_ALL);
  if ((flags & ~15u) != 0)
    return fail(c, BBC_ERR_CORRUPT, "PARM", at + 44, "reserved bits not zero (R-FILE-2)");
  if (!bbc__params_valid(q) || (!q->area_lights && q->alpha_area != 0) || q->cell_levels == 1 ||
      (!(q->chains & BBC_CHAIN_MASK_DOUBLE) && q->max_level_double != 0))
    return fail(c, BBC_ERR_CORRUPT, "PARM", at, "parameter out of its range (R-PAR-1)");

  p = c->sec[K_FPRT];
  at = c->sec_offset[K_FPRT];
  bbc_fingerprint *f = &c->fingerprint;
  f->total = bbc__ld64(p);
  f->geometry = bbc__ld64(p + 8);
  f->materials = bbc__ld64(p + 16);
  f->meshes = bbc__ld64(p + 24);
  f->lights = bbc__ld64(p + 32);
  f->params = bbc__ld64(p + 40);
  for (int k = 0; k < 6; k++) c->scene_counts[k] = bbc__ld32(p + 48 + 4 * k);
  if (!all_zero(p + 72, 24))
    return fail(c, BBC_ERR_CORRUPT, "FPRT", at + 72, "reserved bytes not zero (R-FILE-2)");
  if (c->scene_counts[5] != 0 && !q->area_lights)
    return fail(c, BBC_ERR_CORRUPT, "FPRT", at + 68,
                "emitter_count %u without area lights in PARM (R-FPR-2)", c->scene_counts[5]);
  if (f->total != bbc__xxh64(p + 8, 40))
    return fail(c, BBC_ERR_CORRUPT, "FPRT", at,
                "fingerprint is not the hash of its parts (R-FPR-1)");
  if (f->params != bbc__xxh64(c->sec[K_PARM], BBC__PARM_SIZE))
    return fail(c, BBC_ERR_CORRUPT, "FPRT", at + 40,
                "parameters hash does not match PARM (R-FPR-1)");
  return BBC_OK;
}

static bbc_result check_receivers(bbc_cache *c) {
  const uint8_t *p = c->sec[K_RCVR];
  uint64_t count = c->sec_size[K_RCVR] / BBC__RCVR_SIZE;
  uint32_t meshes = c->scene_counts[2], triangles = c->scene_counts[1];
  uint32_t res = c->params.grid_resolution;
  if (count == 0)
    return fail(c, BBC_ERR_CORRUPT, "RCVR", c->sec_offset[K_RCVR], "no receiver (R-RCV-1)");
  if (count > meshes)
    return fail(c, BBC_ERR_CORRUPT, "RCVR", c->sec_offset[K_RCVR],
                "%llu receivers for %u meshes (R-RCV-1)", (unsigned long long)count, meshes);
  c->receivers = calloc(count, sizeof *c->receivers);
  if (!c->receivers)
    return fail(c, BBC_ERR_OUT_OF_MEMORY, "RCVR", c->sec_offset[K_RCVR], "out of memory");
  uint64_t cells = 0, uvs = 0, tri_end = 0;
  for (uint64_t i = 0; i < count; i++) {
    const uint8_t *e = p + BBC__RCVR_SIZE * i;
    uint64_t at = c->sec_offset[K_RCVR] + BBC__RCVR_SIZE * i;
    bbc_receiver *r = &c->receivers[i];
    r->mesh = bbc__ld32(e);
    r->parameterisation = bbc__ld32(e + 4);
    r->first_triangle = bbc__ld32(e + 8);
    r->triangle_count = bbc__ld32(e + 12);
    r->width = bbc__ld32(e + 16);
    r->height = bbc__ld32(e + 20);
    r->first_cell = bbc__ld64(e + 24);
    r->first_uv = bbc__ld64(e + 32);
    for (int k = 0; k < 4; k++) r->domain[k] = bbc__ldf64(e + 40 + 8 * k);
    for (int k = 0; k < 3; k++) r->axis_u[k] = bbc__ldf64(e + 72 + 8 * k);
    for (int k = 0; k < 3; k++) r->axis_v[k] = bbc__ldf64(e + 96 + 8 * k);
    if (r->mesh >= meshes || (i > 0 && r->mesh <= c->receivers[i - 1].mesh))
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at,
                  "receiver %llu: mesh %u not increasing or not below %u (R-RCV-1)",
                  (unsigned long long)i, r->mesh, meshes);
    if (r->triangle_count == 0 || r->first_triangle < tri_end ||
        (uint64_t)r->first_triangle + r->triangle_count > triangles)
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 8,
                  "receiver %llu: triangles [%u, +%u) empty, overlapping or past %u (R-RCV-1)",
                  (unsigned long long)i, r->first_triangle, r->triangle_count, triangles);
    tri_end = (uint64_t)r->first_triangle + r->triangle_count;
    uint32_t longer = r->width > r->height ? r->width : r->height;
    /* A projection of vertices that all project to one point has a 1 x 1 grid (6.3). */
    int point = longer == 1 && r->domain[0] == r->domain[2] && r->domain[1] == r->domain[3];
    if (r->parameterisation > BBC_PARAM_PLANE || r->width < 1 || r->height < 1 || r->width > res ||
        r->height > res ||
        (r->parameterisation == BBC_PARAM_TEXCOORD ? (r->width != res || r->height != res)
                                                   : longer != res && !point))
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 4,
                  "receiver %llu: parameterisation %u with a %u x %u grid at resolution %u "
                  "(R-RCV-2)",
                  (unsigned long long)i, r->parameterisation, r->width, r->height, res);
    if (r->first_cell != cells || r->first_uv != uvs)
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 24,
                  "receiver %llu: first cell or first triangle index not the running sum "
                  "(R-RCV-3)",
                  (unsigned long long)i);
    int finite = 1;
    for (int k = 0; k < 4; k++) finite &= isfinite(r->domain[k]);
    for (int k = 0; k < 3; k++) finite &= isfinite(r->axis_u[k]) && isfinite(r->axis_v[k]);
    /* A plane (6.5) has area: its domain has extent along both axes. */
    const int plane = r->parameterisation == BBC_PARAM_PLANE;
    if (!finite || !(r->domain[0] <= r->domain[2]) || !(r->domain[1] <= r->domain[3]) ||
        (plane && !(r->domain[0] < r->domain[2] && r->domain[1] < r->domain[3])))
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 40,
                  "receiver %llu: domain or axes not finite or inverted (R-RCV-4)",
                  (unsigned long long)i);
    /* R-RCV-5: TEXCOORD_0 has no axes; a projection has two non-zero ones. */
    int axes_zero = all_zero(e + 72, 24) + all_zero(e + 96, 24);
    if (r->parameterisation == BBC_PARAM_TEXCOORD
            ? axes_zero != 2
            : (r->axis_u[0] == 0 && r->axis_u[1] == 0 && r->axis_u[2] == 0) ||
                  (r->axis_v[0] == 0 && r->axis_v[1] == 0 && r->axis_v[2] == 0))
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 72,
                  "receiver %llu: axes %s for parameterisation %u (R-RCV-5)",
                  (unsigned long long)i, axes_zero == 2 ? "zero" : "not zero",
                  r->parameterisation);
    if (!all_zero(e + 120, 8))
      return fail(c, BBC_ERR_CORRUPT, "RCVR", at + 120,
                  "receiver %llu: reserved bytes not zero (R-FILE-2)", (unsigned long long)i);
    bbc__grid_plane_coords(r);
    cells += (uint64_t)r->width * r->height;
    if (!plane) uvs += r->triangle_count; /* a plane has no TRUV (5.4) */
  }
  c->grid.resolution = res;
  c->grid.receiver_count = (uint32_t)count;
  c->grid.receivers = c->receivers;
  c->grid.uv_triangle_count = uvs;
  bbc__grid_set_levels(&c->grid, c->receivers, c->params.cell_levels ? c->params.cell_levels : 1);
  cells = c->grid.cell_count;

  /* R-SEC-2: the sizes the verified RCVR implies, then R-UV-1. */
  if (c->sec_size[K_TRUV] != (uint64_t)BBC__TRUV_SIZE * uvs)
    return fail(c, BBC_ERR_CORRUPT, "TRUV", c->sec_offset[K_TRUV],
                "%llu bytes for %llu receiver triangles (R-SEC-2)",
                (unsigned long long)c->sec_size[K_TRUV], (unsigned long long)uvs);
  if (c->sec_size[K_CIDX] != (uint64_t)BBC__CIDX_SIZE * cells)
    return fail(c, BBC_ERR_CORRUPT, "CIDX", c->sec_offset[K_CIDX],
                "%llu bytes for %llu cells (R-SEC-2)", (unsigned long long)c->sec_size[K_CIDX],
                (unsigned long long)cells);
  /* 64-byte aligned section of a 64-byte aligned base: the floats are aligned. */
  const float *uv = (const float *)(const void *)c->sec[K_TRUV];
  for (uint64_t i = 0; i < count; i++) {
    const bbc_receiver *r = &c->receivers[i];
    const uint64_t n = r->parameterisation == BBC_PARAM_PLANE ? 0 : r->triangle_count;
    for (uint64_t t = 0; t < n; t++) {
      const float *g = uv + 6 * (r->first_uv + t);
      for (int k = 0; k < 6; k++) {
        float limit = (float)((k & 1) ? r->height : r->width);
        if (!(g[k] >= 0.0f && g[k] <= limit))
          return fail(c, BBC_ERR_CORRUPT, "TRUV",
                      c->sec_offset[K_TRUV] + 4 * (6 * (r->first_uv + t) + (uint64_t)k),
                      "grid coordinate %g outside [0, %g] (R-UV-1)", (double)g[k], (double)limit);
      }
    }
  }
  c->grid.triangle_uv = uv;
  return BBC_OK;
}

static bbc_result check_tuples(bbc_cache *c) {
  uint64_t count = c->sec_size[K_TUPL] / BBC__TUPL_SIZE;
  if (count > BBC__MAX_TUPLES)
    return fail(c, BBC_ERR_CORRUPT, "TUPL", c->sec_offset[K_TUPL], "%llu tuples (R-TUP-1)",
                (unsigned long long)count);
  c->tuple_count = (uint32_t)count;
  const bbc_tuple *t = (const bbc_tuple *)(const void *)c->sec[K_TUPL];
  uint32_t triangles = c->scene_counts[1], lights = c->scene_counts[4];
  uint64_t all_lights = (uint64_t)lights + c->scene_counts[5];
  for (uint64_t i = 0; i < count; i++) {
    const bbc_tuple *u = &t[i];
    int ok = u->chain < BBC_CHAIN_COUNT && (c->params.chains & BBC_CHAIN_BIT(u->chain)) &&
             u->light < all_lights &&
             (u->light < lights || u->chain == BBC_CHAIN_R || u->chain == BBC_CHAIN_T ||
              c->params.area_double) &&
             u->specular[0] < triangles &&
             (bbc_chain_length((bbc_chain)(u->chain < BBC_CHAIN_COUNT ? u->chain : 0)) == 1
                  ? u->specular[1] == BBC_NO_TRIANGLE
                  : u->specular[1] < triangles) &&
             (bbc_receiver_is_beam(u->receiver) ? c->params.beam_receivers != 0
                                                : bbc__grid_tuple_end(&c->grid, u->receiver));
    if (!ok)
      return fail(c, BBC_ERR_CORRUPT, "TUPL", c->sec_offset[K_TUPL] + BBC__TUPL_SIZE * i,
                  "tuple %llu (light %u, chain %u, triangles %u %u %u) invalid (R-TUP-1)",
                  (unsigned long long)i, u->light, u->chain, u->specular[0], u->specular[1],
                  u->receiver);
  }
  return BBC_OK;
}

/* SHRD (Sec. 5.10): R-SHR-1..3. */
static bbc_result check_shard(bbc_cache *c) {
  const uint8_t *p = c->sec[K_SHRD];
  uint64_t at = c->sec_offset[K_SHRD];
  if (c->sec_size[K_SHRD] != BBC__SHRD_HEAD_SIZE + (uint64_t)BBC__SHRD_ENTRY_SIZE * c->tuple_count)
    return fail(c, BBC_ERR_CORRUPT, "SHRD", at, "%llu bytes for %u tuples (R-SHR-1)",
                (unsigned long long)c->sec_size[K_SHRD], c->tuple_count);
  bbc_cache_shard *s = &c->shard;
  s->index = bbc__ld32(p);
  s->count = bbc__ld32(p + 4);
  s->candidate_count = bbc__ld64(p + 8);
  s->candidates_hash = bbc__ld64(p + 16);
  if (!all_zero(p + 24, 8))
    return fail(c, BBC_ERR_CORRUPT, "SHRD", at + 24, "reserved bytes not zero (R-FILE-2)");
  if (s->count == 0 || s->index >= s->count || c->tuple_count > s->candidate_count)
    return fail(c, BBC_ERR_CORRUPT, "SHRD", at,
                "shard %u/%u with %u tuples of %llu candidates (R-SHR-2)", s->index, s->count,
                c->tuple_count, (unsigned long long)s->candidate_count);
  /* 64-byte aligned section: the u64 array at +32 is aligned. */
  s->candidates = (const uint64_t *)(const void *)(p + BBC__SHRD_HEAD_SIZE);
  for (uint32_t i = 0; i < c->tuple_count; i++) {
    uint64_t k = s->candidates[i];
    if (k >= s->candidate_count || k % s->count != s->index || (i > 0 && k <= s->candidates[i - 1]))
      return fail(
          c, BBC_ERR_CORRUPT, "SHRD", at + BBC__SHRD_HEAD_SIZE + (uint64_t)BBC__SHRD_ENTRY_SIZE * i,
          "tuple %u: candidate %llu not increasing, not below %llu or not in shard "
          "%u/%u (R-SHR-3)",
          i, (unsigned long long)k, (unsigned long long)s->candidate_count, s->index, s->count);
  }
  c->is_shard = 1;
  return BBC_OK;
}

static bbc_result check_chunks_and_cells(bbc_cache *c) {
  const uint8_t *p = c->sec[K_CHNK];
  uint64_t count = c->sec_size[K_CHNK] / BBC__CHNK_SIZE;
  if (count > UINT32_MAX)
    return fail(c, BBC_ERR_CORRUPT, "CHNK", c->sec_offset[K_CHNK], "too many chunks (R-CHK-2)");
  c->chunk_count = (uint32_t)count;
  uint64_t next = 0, entries = 0;
  for (uint64_t k = 0; k < count; k++) {
    const uint8_t *e = p + BBC__CHNK_SIZE * k;
    uint64_t at = c->sec_offset[K_CHNK] + BBC__CHNK_SIZE * k;
    uint64_t off = bbc__ld64(e);
    uint32_t csize = bbc__ld32(e + 8), n = bbc__ld32(e + 12);
    if (bbc__ld32(e + 20) != 0)
      return fail(c, BBC_ERR_CORRUPT, "CHNK", at + 20,
                  "chunk %llu: reserved field not zero (R-FILE-2)", (unsigned long long)k);
    if (off != next || csize < 1 || csize > c->sec_size[K_CDAT] - off || n < 1 ||
        n > BBC__MAX_CHUNK_ENTRIES)
      return fail(c, BBC_ERR_CORRUPT, "CHNK", at,
                  "chunk %llu: frame [%llu, +%u) with %u entries does not tile CDAT "
                  "(R-CHK-1)",
                  (unsigned long long)k, (unsigned long long)off, csize, n);
    next = off + csize;
    entries += n;
  }
  if (next != c->sec_size[K_CDAT])
    return fail(c, BBC_ERR_CORRUPT, "CHNK", c->sec_offset[K_CHNK],
                "frames end at %llu, CDAT has %llu bytes (R-CHK-1)", (unsigned long long)next,
                (unsigned long long)c->sec_size[K_CDAT]);
  c->entry_count = entries;

  /* R-CIX-1..3: the lists tile the chunks in cell order. */
  const uint8_t *x = c->sec[K_CIDX];
  uint64_t chunk = 0, pos = 0, nonempty = 0;
  for (uint64_t i = 0; i < c->grid.cell_count; i++) {
    const uint8_t *e = x + BBC__CIDX_SIZE * i;
    uint64_t at = c->sec_offset[K_CIDX] + BBC__CIDX_SIZE * i;
    uint32_t ck = bbc__ld32(e), first = bbc__ld32(e + 4), n = bbc__ld32(e + 8);
    if (n == 0) {
      if (ck != 0 || first != 0)
        return fail(c, BBC_ERR_CORRUPT, "CIDX", at,
                    "empty cell %llu with chunk %u, first %u (R-CIX-1)", (unsigned long long)i, ck,
                    first);
      continue;
    }
    if (n > c->tuple_count)
      return fail(c, BBC_ERR_CORRUPT, "CIDX", at + 8,
                  "cell %llu lists %u entries, there are %u tuples (R-CIX-3)",
                  (unsigned long long)i, n, c->tuple_count);
    if (chunk < count && pos == bbc__ld32(p + BBC__CHNK_SIZE * chunk + 12)) {
      chunk++;
      pos = 0;
    }
    if (chunk >= count || ck != chunk || first != pos ||
        (uint64_t)n > bbc__ld32(p + BBC__CHNK_SIZE * chunk + 12) - pos)
      return fail(c, BBC_ERR_CORRUPT, "CIDX", at,
                  "cell %llu: list (chunk %u, first %u, count %u) does not continue the "
                  "previous one (R-CIX-2)",
                  (unsigned long long)i, ck, first, n);
    pos += n;
    nonempty++;
  }
  if (count > 0 && (chunk != count - 1 || pos != bbc__ld32(p + BBC__CHNK_SIZE * chunk + 12)))
    return fail(c, BBC_ERR_CORRUPT, "CIDX", c->sec_offset[K_CIDX],
                "the cell lists do not cover every chunk (R-CIX-2)");
  c->nonempty_cells = nonempty;
  return BBC_OK;
}

/* ------------------------------------------------------------------ open, close */

static bbc_result open_bytes(bbc_cache *c) {
  bbc_result r = check_header_and_directory(c);
  if (r == BBC_OK) r = check_params_and_fingerprint(c);
  if (r == BBC_OK) r = check_receivers(c);
  if (r == BBC_OK) r = check_tuples(c);
  if (r == BBC_OK && c->sec[K_SHRD]) r = check_shard(c);
  if (r == BBC_OK && c->sec[K_GEOM]) {
    const char *why = bbc__geometry_check_head(c->sec[K_GEOM], c->sec_size[K_GEOM],
                                               c->scene_counts[0], c->scene_counts[1]);
    if (why) r = fail(c, BBC_ERR_CORRUPT, "GEOM", c->sec_offset[K_GEOM], "%s", why);
  }
  if (r == BBC_OK) r = check_chunks_and_cells(c);
  if (r != BBC_OK) return r;
  c->chunk_verified = calloc(c->chunk_count ? c->chunk_count : 1, sizeof *c->chunk_verified);
  c->kept = calloc(c->chunk_count ? c->chunk_count : 1, sizeof *c->kept);
  if (!c->chunk_verified || !c->kept)
    return fail(c, BBC_ERR_OUT_OF_MEMORY, "CHNK", 0, "out of memory");
  if (c->sec[K_INFO]) {
    size_t n = (size_t)c->sec_size[K_INFO];
    if (!bbc__info_text_valid(c->sec[K_INFO], n))
      return fail(c, BBC_ERR_CORRUPT, "INFO", c->sec_offset[K_INFO],
                  "not UTF-8 text without control characters (R-INF-1)");
    if (n > sizeof c->writer - 1) n = sizeof c->writer - 1;
    while (n < c->sec_size[K_INFO] && (c->sec[K_INFO][n] & 0xC0) == 0x80) n--; /* whole chars */
    memcpy(c->writer, c->sec[K_INFO], n);
    c->writer[n] = '\0';
  }
  return BBC_OK;
}

static bbc_cache *cache_new(const char *path, const bbc_cache_options *options) {
  bbc_cache *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  if (options) c->options = *options;
  snprintf(c->path, sizeof c->path, "%s", path);
  return c;
}

void bbc_cache_close(bbc_cache *c) {
  if (!c) return;
  if (c->map) munmap(c->map, c->map_size);
  free(c->copy);
  free(c->receivers);
  free((void *)c->chunk_verified);
  for (uint32_t k = 0; c->kept && k < c->chunk_count; k++) free(atomic_load(&c->kept[k]));
  free((void *)c->kept);
  free(c);
}

bbc_result bbc_cache_open_memory(bbc_cache **out, const void *bytes, size_t size,
                                 const bbc_cache_options *options) {
  if (out) *out = NULL;
  if (!out || (!bytes && size)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_cache *c = cache_new("(memory)", options);
  if (!c) return BBC_ERR_OUT_OF_MEMORY;
  static const uint8_t empty[64] __attribute__((aligned(64)));
  if (size == 0) {
    c->base = empty;
  } else if ((uintptr_t)bytes % BBC__ALIGN != 0) {
    /* Arrays are used in place; a misaligned base would misalign them. */
    if (posix_memalign(&c->copy, BBC__ALIGN, size) != 0) {
      free(c);
      return BBC_ERR_OUT_OF_MEMORY;
    }
    memcpy(c->copy, bytes, size);
    c->base = c->copy;
  } else {
    c->base = bytes;
  }
  c->size = size;
  bbc_result r = open_bytes(c);
  if (r != BBC_OK) {
    bbc_cache_close(c);
    return r;
  }
  *out = c;
  return BBC_OK;
}

bbc_result bbc_cache_open(bbc_cache **out, const char *path, const bbc_cache_options *options) {
  if (out) *out = NULL;
  if (!out || !path) return BBC_ERR_INVALID_ARGUMENT;
  bbc_message_fn fn = options ? options->error_fn : NULL;
  void *user = options ? options->user : NULL;
  int fd = open(path, O_RDONLY);
  if (fd < 0) return bbc__report(fn, user, BBC_ERR_IO, "%s: %s", path, strerror(errno));
  struct stat st;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    int e = errno;
    close(fd);
    return bbc__report(fn, user, BBC_ERR_IO, "%s: %s", path,
                       S_ISDIR(st.st_mode) ? "is a directory" : strerror(e));
  }
  bbc_cache *c = cache_new(path, options);
  if (!c) {
    close(fd);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  static const uint8_t empty[64] __attribute__((aligned(64)));
  c->size = (uint64_t)st.st_size;
  c->base = empty;
  if (st.st_size > 0) {
    void *m = mmap(NULL, (size_t)st.st_size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      int e = errno;
      close(fd);
      bbc_cache_close(c);
      /* ENOMEM: the address space is full (an RLIMIT_AS such as bbc-precompute's
       * --memory), which is no fault of the file. */
      return bbc__report(fn, user, e == ENOMEM ? BBC_ERR_OUT_OF_MEMORY : BBC_ERR_IO,
                         "%s: cannot map: %s", path, strerror(e));
    }
    c->map = m;
    c->map_size = (size_t)st.st_size;
    c->base = m;
  }
  close(fd);
  bbc_result r = open_bytes(c);
  if (r != BBC_OK) {
    bbc_cache_close(c);
    return r;
  }
  *out = c;
  return BBC_OK;
}

/* ------------------------------------------------------------------ accessors */

void bbc_cache_get_info(const bbc_cache *c, bbc_cache_info *out) {
  memset(out, 0, sizeof *out);
  out->version_major = c->version_major;
  out->version_minor = c->version_minor;
  out->file_size = c->size;
  out->section_count = c->section_count;
  out->params = c->params;
  out->fingerprint = c->fingerprint;
  out->scene_vertex_count = c->scene_counts[0];
  out->scene_triangle_count = c->scene_counts[1];
  out->scene_mesh_count = c->scene_counts[2];
  out->scene_material_count = c->scene_counts[3];
  out->scene_light_count = c->scene_counts[4];
  out->scene_emitter_count = c->scene_counts[5];
  out->tuple_count = c->tuple_count;
  out->receiver_count = c->grid.receiver_count;
  out->cell_count = c->grid.cell_count;
  out->nonempty_cell_count = c->nonempty_cells;
  out->chunk_count = c->chunk_count;
  out->entry_count = c->entry_count;
  out->decoded_bytes = c->entry_count * BBC__ENTRY_BYTES;
  out->compressed_bytes = c->sec_size[K_CDAT];
  snprintf(out->writer, sizeof out->writer, "%s", c->writer);
}

void bbc_cache_get_section(const bbc_cache *c, uint32_t i, bbc_cache_section *out) {
  if (i < c->section_count)
    *out = c->sections[i];
  else
    memset(out, 0, sizeof *out);
}

const bbc_tuple *bbc_cache_tuples(const bbc_cache *c) {
  return (const bbc_tuple *)(const void *)c->sec[K_TUPL];
}

const bbc_grid *bbc_cache_grid(const bbc_cache *c) {
  return &c->grid;
}

int bbc_cache_get_shard(const bbc_cache *c, bbc_cache_shard *out) {
  if (out) {
    if (c && c->is_shard)
      *out = c->shard;
    else
      memset(out, 0, sizeof *out);
  }
  return c && c->is_shard;
}

const char *bbc__cache_path(const bbc_cache *c) {
  return c->path;
}

const uint8_t *bbc__cache_info_bytes(const bbc_cache *c, uint64_t *size) {
  *size = c->sec[K_INFO] ? c->sec_size[K_INFO] : 0;
  return c->sec[K_INFO];
}

const uint8_t *bbc__cache_geometry_bytes(const bbc_cache *c, uint64_t *size) {
  *size = c->sec[K_GEOM] ? c->sec_size[K_GEOM] : 0;
  return c->sec[K_GEOM];
}

/* ------------------------------------------------------------------ scene checks */

bbc_result bbc_cache_check_scene(const bbc_cache *c, const bbc_scene *scene) {
  if (!c || !scene) return BBC_ERR_INVALID_ARGUMENT;
  bbc_fingerprint f;
  bbc_fingerprint_compute(scene, &c->params, &f);
  const char *what = NULL;
  if (f.geometry != c->fingerprint.geometry)
    what = "geometry (positions, normals, uvs or indices; caches written before bbc numbered "
           "triangles in canonical order must be recomputed)";
  else if (f.meshes != c->fingerprint.meshes)
    what = "meshes (ranges, materials or roles)";
  else if (f.materials != c->fingerprint.materials)
    what = "materials";
  else if (f.lights != c->fingerprint.lights)
    what = "point lights";
  else if (c->scene_counts[5] != 0 && c->scene_counts[5] != scene->emitter_count)
    what = "emissive triangles";
  if (!what) return BBC_OK;
  return bbc__report(c->options.error_fn, c->options.user, BBC_ERR_SCENE_MISMATCH,
                     "%s: computed for another scene than %s: its %s differ (cache: %u "
                     "triangles, %u lights; scene: %u triangles, %u lights)",
                     c->path, scene->path, what, c->scene_counts[1], c->scene_counts[4],
                     scene->triangle_count, scene->point_light_count);
}

bbc_result bbc_cache_match_scene(const bbc_cache *c, bbc_scene *scene, bbc_scene_match *match) {
  bbc_scene_match none;
  if (!match) match = &none;
  memset(match, 0, sizeof *match);
  if (!c || !scene) return BBC_ERR_INVALID_ARGUMENT;
  bbc_fingerprint f;
  bbc_fingerprint_compute(scene, &c->params, &f);
  /* Only the geometry may differ, and only when the cache holds its own. */
  if (f.geometry == c->fingerprint.geometry || !c->sec[K_GEOM] ||
      f.meshes != c->fingerprint.meshes || f.materials != c->fingerprint.materials ||
      f.lights != c->fingerprint.lights)
    return bbc_cache_check_scene(c, scene);
  bbc__geometry g;
  const char *why = NULL;
  bbc_result r = bbc__geometry_decode(c->sec[K_GEOM], c->sec_size[K_GEOM], c->fingerprint.geometry,
                                      &g, &why);
  if (r != BBC_OK)
    return fail(c, r, "GEOM", c->sec_offset[K_GEOM], "%s", why ? why : "out of memory");
  char what[256] = "out of memory";
  r = bbc__geometry_match(&g, scene, match, what, sizeof what);
  if (r == BBC_OK) {
    /* The scene takes the cache's arrays; triangle_mesh is the same (checked). */
    r = bbc__scene_adopt_geometry(scene, g.positions, g.normals, g.uvs, g.indices);
    free(g.triangle_mesh);
    memset(&g, 0, sizeof g);
    if (r != BBC_OK) return fail(c, r, "GEOM", c->sec_offset[K_GEOM], "out of memory");
    match->adopted = 1;
    return bbc_cache_check_scene(c, scene);
  }
  bbc__geometry_free(&g);
  if (r == BBC_ERR_SCENE_MISMATCH)
    return bbc__report(c->options.error_fn, c->options.user, r,
                       "%s: computed for another scene than %s: its geometry differs beyond "
                       "float noise: %s",
                       c->path, scene->path, what);
  return fail(c, r, "GEOM", c->sec_offset[K_GEOM], "%s", what);
}

bbc_result bbc_cache_check_params(const bbc_cache *c, const bbc_precompute_params *p) {
  if (!c || !p) return BBC_ERR_INVALID_ARGUMENT;
  const bbc_precompute_params *q = &c->params;
  char diff[160] = "";
  if (q->chains != p->chains)
    snprintf(diff, sizeof diff, "chains 0x%x, expected 0x%x", q->chains, p->chains);
  else if (q->max_level != p->max_level)
    snprintf(diff, sizeof diff, "max_level %u, expected %u", q->max_level, p->max_level);
  else if ((q->chains & BBC_CHAIN_MASK_DOUBLE) &&
           bbc__params_max_level_double(q) != bbc__params_max_level_double(p))
    snprintf(diff, sizeof diff, "max_level_double %u, expected %u", bbc__params_max_level_double(q),
             bbc__params_max_level_double(p));
  else if (q->sigma != p->sigma)
    snprintf(diff, sizeof diff, "sigma %.17g, expected %.17g", q->sigma, p->sigma);
  else if (q->alpha_single != p->alpha_single)
    snprintf(diff, sizeof diff, "alpha_single %.17g, expected %.17g", q->alpha_single,
             p->alpha_single);
  else if (q->alpha_double != p->alpha_double)
    snprintf(diff, sizeof diff, "alpha_double %.17g, expected %.17g", q->alpha_double,
             p->alpha_double);
  else if (q->m != p->m)
    snprintf(diff, sizeof diff, "m %.17g, expected %.17g", q->m, p->m);
  else if (q->grid_resolution != p->grid_resolution)
    snprintf(diff, sizeof diff, "grid_resolution %u, expected %u", q->grid_resolution,
             p->grid_resolution);
  else if (q->remainder != (p->remainder ? 1u : 0u))
    snprintf(diff, sizeof diff, "remainder %u, expected %u", q->remainder, p->remainder);
  else if (q->area_lights != (p->area_lights ? 1u : 0u))
    snprintf(diff, sizeof diff, "area_lights %u, expected %u", q->area_lights, p->area_lights);
  else if (p->area_lights && bbc__params_alpha_area(q) != bbc__params_alpha_area(p))
    snprintf(diff, sizeof diff, "alpha_area %.17g, expected %.17g", bbc__params_alpha_area(q),
             bbc__params_alpha_area(p));
  else if (q->area_double !=
           (p->area_lights && p->area_double && (p->chains & BBC_CHAIN_MASK_DOUBLE) ? 1u : 0u))
    snprintf(diff, sizeof diff, "area_double %u (format %u.%u), expected %u", q->area_double,
             c->version_major, c->version_minor, q->area_double ? 0u : 1u);
  else if (q->beam_receivers != (p->beam_receivers ? 1u : 0u))
    snprintf(diff, sizeof diff, "receivers %s, expected %s",
             q->beam_receivers ? "beam" : "per-triangle",
             p->beam_receivers ? "beam" : "per-triangle");
  if (!diff[0]) return BBC_OK;
  return bbc__report(c->options.error_fn, c->options.user, BBC_ERR_SCENE_MISMATCH,
                     "%s: computed with other parameters: %s", c->path, diff);
}

/* ------------------------------------------------------------------ decoding */

typedef struct reporter {
  const bbc_cache *c;
  bbc_message_fn fn;
  void *user;
} reporter;

static bbc_result rfail(const reporter *rp, bbc_result code, const char *where, uint64_t offset,
                        const char *fmt, ...) __attribute__((format(printf, 5, 6)));
static bbc_result rfail(const reporter *rp, bbc_result code, const char *where, uint64_t offset,
                        const char *fmt, ...) {
  if (!rp->fn) return code;
  char what[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(what, sizeof what, fmt, ap);
  va_end(ap);
  return bbc__report(rp->fn, rp->user, code, "%s: %s at byte %llu: %s", rp->c->path, where,
                     (unsigned long long)offset, what);
}

/* Verifies (once) and decompresses chunk k into planes (6N bytes). */
static bbc_result decode_chunk(const reporter *rp, ZSTD_DCtx *dctx, uint32_t k, uint8_t *planes,
                               int force_crc) {
  const bbc_cache *c = rp->c;
  const uint8_t *rec = c->sec[K_CHNK] + BBC__CHNK_SIZE * (size_t)k;
  uint64_t off = bbc__ld64(rec);
  uint32_t csize = bbc__ld32(rec + 8), n = bbc__ld32(rec + 12);
  const uint8_t *src = c->sec[K_CDAT] + off;
  uint64_t at = c->sec_offset[K_CDAT] + off;
  /* R-CHK-3: the checksum before the first decode; the flag is shared by all cursors. */
  if (force_crc || !atomic_load_explicit(&c->chunk_verified[k], memory_order_relaxed)) {
    if (CHECKSUM_DIFFERS(crc_of(src, csize), bbc__ld32(rec + 16)))
      return rfail(rp, BBC_ERR_CHECKSUM, "CDAT", at, "chunk %u checksum mismatch (R-CHK-3)", k);
    atomic_store_explicit(&c->chunk_verified[k], 1, memory_order_relaxed);
  }
  /* R-CHK-6: a zstd data frame (not skippable, not a legacy format) without dictionary. */
  if (csize < 4 || bbc__ld32(src) != ZSTD_MAGICNUMBER)
    return rfail(rp, BBC_ERR_CORRUPT, "CDAT", at,
                 "chunk %u does not start with the zstd frame magic (R-CHK-6)", k);
  if (ZSTD_getDictID_fromFrame(src, csize) != 0)
    return rfail(rp, BBC_ERR_CORRUPT, "CDAT", at, "chunk %u needs a zstd dictionary (R-CHK-6)", k);
  /* R-CHK-4: one frame, declaring and holding exactly 6N bytes. */
  size_t want = (size_t)n * BBC__ENTRY_BYTES;
  unsigned long long declared = ZSTD_getFrameContentSize(src, csize);
  size_t frame = ZSTD_findFrameCompressedSize(src, csize);
  if (declared != want || ZSTD_isError(frame) || frame != csize)
    return rfail(rp, BBC_ERR_CORRUPT, "CDAT", at,
                 "chunk %u is not one zstd frame of %zu bytes (R-CHK-4)", k, want);
  size_t got = ZSTD_decompressDCtx(dctx, planes, want, src, csize);
  if (ZSTD_isError(got) || got != want)
    return rfail(rp, BBC_ERR_CORRUPT, "CDAT", at, "chunk %u does not decode: %s (R-CHK-4)", k,
                 ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short");
  return BBC_OK;
}

/* Chunk k as kept by the cache, or NULL. */
static const uint8_t *kept_chunk(const bbc_cache *c, uint32_t k) {
  return atomic_load_explicit(&c->kept[k], memory_order_acquire);
}

/* Decodes chunk k into a buffer the cache keeps, if its budget has room; sets *planes to
 * the kept bytes (those another thread kept first, if it won the race), or to NULL when
 * there is no room. A chunk that fails to decode is not kept: every later use decodes
 * it again and fails again. */
static bbc_result decode_kept(const reporter *rp, ZSTD_DCtx *dctx, uint32_t k, int force_crc,
                              const uint8_t **planes) {
  bbc_cache *c = (bbc_cache *)rp->c; /* only its atomics change */
  *planes = NULL;
  size_t need = (size_t)bbc__ld32(c->sec[K_CHNK] + BBC__CHNK_SIZE * (size_t)k + 12) *
                BBC__ENTRY_BYTES;
  size_t before = atomic_fetch_add_explicit(&c->kept_bytes, need, memory_order_relaxed);
  uint8_t *mine = before + need <= c->options.keep_decoded ? malloc(need) : NULL;
  if (!mine) {
    atomic_fetch_sub_explicit(&c->kept_bytes, need, memory_order_relaxed);
    return BBC_OK;
  }
  bbc_result r = decode_chunk(rp, dctx, k, mine, force_crc);
  uint8_t *expected = NULL;
  if (r == BBC_OK &&
      atomic_compare_exchange_strong_explicit(&c->kept[k], &expected, mine, memory_order_acq_rel,
                                              memory_order_acquire)) {
    *planes = mine;
    return BBC_OK;
  }
  free(mine);
  atomic_fetch_sub_explicit(&c->kept_bytes, need, memory_order_relaxed);
  if (r == BBC_OK) *planes = expected;
  return r;
}

/* Decodes one list (Sec. 7.2) from a decoded chunk of n entries into out, or only checks
 * it when out is NULL. The ids grow along the list, so the last one is the largest; the
 * loop keeps the largest code, and only a list that fails is read again for the entry to
 * report. */
static bbc_result decode_list(const reporter *rp, const uint8_t *planes, uint32_t n, uint32_t first,
                              uint32_t count, uint64_t cell, bbc_cache_entry *out) {
  (void)n;
  const uint8_t *list = planes + BBC__ENTRY_BYTES * (size_t)first;
  uint64_t id = 0;
  uint16_t largest = 0;
  for (uint32_t j = 0; j < count; j++) {
    const uint8_t *rec = list + BBC__ENTRY_BYTES * (size_t)j;
    uint64_t d = bbc__ld32(rec);
    uint16_t code = bbc__ld16(rec + 4);
    id = j == 0 ? d : id + 1 + d;
    largest = code > largest ? code : largest;
    if (out) {
      out[j].tuple = (uint32_t)id;
      out[j].bound = bbc__bound_decode(code);
    }
  }
  if (id < rp->c->tuple_count && largest <= BBC__CODE_INF) return BBC_OK;
  id = 0;
  for (uint32_t j = 0; j < count; j++) {
    const uint8_t *rec = list + BBC__ENTRY_BYTES * (size_t)j;
    uint16_t code = bbc__ld16(rec + 4);
    id = j == 0 ? bbc__ld32(rec) : id + 1 + bbc__ld32(rec);
    if (id >= rp->c->tuple_count)
      return rfail(rp, BBC_ERR_CORRUPT, "CIDX", rp->c->sec_offset[K_CIDX] + BBC__CIDX_SIZE * cell,
                   "cell %llu: tuple id %llu not below %u (R-CHK-5)", (unsigned long long)cell,
                   (unsigned long long)id, rp->c->tuple_count);
    if (code > BBC__CODE_INF)
      return rfail(rp, BBC_ERR_CORRUPT, "CIDX", rp->c->sec_offset[K_CIDX] + BBC__CIDX_SIZE * cell,
                   "cell %llu: bound code 0x%04x is not a number (R-BND-1)",
                   (unsigned long long)cell, code);
  }
  return BBC_ERR_CORRUPT; /* not reached: the first pass found a bad entry */
}

/* Decoded chunks a cursor keeps (allocated as they are first used). A render thread
 * visits the cells under its pixels in an order unrelated to the chunk order, so a few
 * slots thrash; 256 chunks of the default 256 KiB cover caches of 64 MiB of decoded
 * lists without decoding anything twice. */
#define CURSOR_SLOTS 256

struct bbc_cache_cursor {
  const bbc_cache *c;
  ZSTD_DCtx *dctx;
  int32_t *slot_of; /* per chunk: the slot holding it, or -1 */
  struct {
    int valid;
    uint32_t chunk;
    uint64_t used; /* clock of the last use, for least-recently-used replacement */
    uint8_t *planes;
    size_t cap;
  } slot[CURSOR_SLOTS];
  uint64_t clock;
  bbc_cache_entry *out;
  uint32_t out_cap;
  bbc_cache_entry *merged; /* bbc_cache_leaf's merge of the levels' lists */
  uint32_t merged_cap;
};

bbc_result bbc_cache_cursor_create(bbc_cache_cursor **out, const bbc_cache *c) {
  if (out) *out = NULL;
  if (!out || !c) return BBC_ERR_INVALID_ARGUMENT;
  bbc_cache_cursor *cur = calloc(1, sizeof *cur);
  if (!cur) return BBC_ERR_OUT_OF_MEMORY;
  cur->c = c;
  cur->dctx = ZSTD_createDCtx();
  cur->slot_of = malloc(sizeof *cur->slot_of * ((size_t)c->chunk_count + 1));
  if (!cur->dctx || !cur->slot_of) {
    ZSTD_freeDCtx(cur->dctx);
    free(cur->slot_of);
    free(cur);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  for (uint32_t k = 0; k < c->chunk_count; k++) cur->slot_of[k] = -1;
  *out = cur;
  return BBC_OK;
}

void bbc_cache_cursor_free(bbc_cache_cursor *cur) {
  if (!cur) return;
  for (int i = 0; i < CURSOR_SLOTS; i++) free(cur->slot[i].planes);
  free(cur->out);
  free(cur->merged);
  free(cur->slot_of);
  ZSTD_freeDCtx(cur->dctx);
  free(cur);
}

/* Chunk k from the cursor's own slots, decoded into the least recently used one if it
 * is not there. */
static bbc_result cursor_chunk(bbc_cache_cursor *cur, const reporter *rp, uint32_t k,
                               uint32_t chunk_entries, const uint8_t **planes) {
  int s = cur->slot_of[k];
  if (s < 0) {
    s = 0;
    for (int i = 1; i < CURSOR_SLOTS; i++)
      if (!cur->slot[i].valid || (cur->slot[s].valid && cur->slot[i].used < cur->slot[s].used))
        s = i;
    size_t need = (size_t)chunk_entries * BBC__ENTRY_BYTES;
    if (cur->slot[s].cap < need) {
      uint8_t *p = realloc(cur->slot[s].planes, need);
      if (!p) return BBC_ERR_OUT_OF_MEMORY;
      cur->slot[s].planes = p;
      cur->slot[s].cap = need;
    }
    if (cur->slot[s].valid) cur->slot_of[cur->slot[s].chunk] = -1;
    cur->slot[s].valid = 0;
    bbc_result r = decode_chunk(rp, cur->dctx, k, cur->slot[s].planes, 0);
    if (r != BBC_OK) return r;
    cur->slot[s].valid = 1;
    cur->slot[s].chunk = k;
    cur->slot_of[k] = s;
  }
  cur->slot[s].used = ++cur->clock;
  *planes = cur->slot[s].planes;
  return BBC_OK;
}

static int grow(bbc_cache_entry **p, uint32_t *cap, uint64_t n) {
  if (n <= *cap) return 1;
  if (n > UINT32_MAX) return 0;
  bbc_cache_entry *o = realloc(*p, sizeof *o * (size_t)n);
  if (!o) return 0;
  *p = o;
  *cap = (uint32_t)n;
  return 1;
}

/* Decodes the list of global cell `cell` into cur->out from index `at` on (growing it);
 * *count its length. */
static bbc_result cell_into(bbc_cache_cursor *cur, uint64_t cell, uint32_t at, uint32_t *count) {
  *count = 0;
  const bbc_cache *c = cur->c;
  const uint8_t *e = c->sec[K_CIDX] + BBC__CIDX_SIZE * cell;
  uint32_t k = bbc__ld32(e), first = bbc__ld32(e + 4), n = bbc__ld32(e + 8);
  if (n == 0) return BBC_OK;
  reporter rp = {c, c->options.error_fn, c->options.user};
  uint32_t chunk_entries = bbc__ld32(c->sec[K_CHNK] + BBC__CHNK_SIZE * (size_t)k + 12);
  const uint8_t *planes = kept_chunk(c, k);
  if (!planes && c->options.keep_decoded) {
    bbc_result r = decode_kept(&rp, cur->dctx, k, 0, &planes);
    if (r != BBC_OK) return r;
  }
  if (!planes) {
    bbc_result r = cursor_chunk(cur, &rp, k, chunk_entries, &planes);
    if (r != BBC_OK) return r;
  }
  if (!grow(&cur->out, &cur->out_cap, (uint64_t)at + n)) return BBC_ERR_OUT_OF_MEMORY;
  /* Open checked first + n <= chunk entries (R-CIX-2). */
  bbc_result r = decode_list(&rp, planes, chunk_entries, first, n, cell, cur->out + at);
  if (r == BBC_OK) *count = n;
  return r;
}

bbc_result bbc_cache_cell(bbc_cache_cursor *cur, uint64_t cell, const bbc_cache_entry **entries,
                          uint32_t *count) {
  if (entries) *entries = NULL;
  if (count) *count = 0;
  if (!cur || !entries || !count) return BBC_ERR_INVALID_ARGUMENT;
  if (cell >= cur->c->grid.cell_count) return BBC_ERR_INVALID_ARGUMENT;
  uint32_t n;
  bbc_result r = cell_into(cur, cell, 0, &n);
  if (r != BBC_OK || n == 0) return r;
  *entries = cur->out;
  *count = n;
  return BBC_OK;
}

bbc_result bbc_cache_leaf(bbc_cache_cursor *cur, bbc_cell cell, const bbc_cache_entry **entries,
                          uint32_t *count) {
  if (entries) *entries = NULL;
  if (count) *count = 0;
  if (!cur || !entries || !count) return BBC_ERR_INVALID_ARGUMENT;
  const bbc_grid *g = &cur->c->grid;
  if (cell.receiver >= g->receiver_count || cell.x >= g->receivers[cell.receiver].width ||
      cell.y >= g->receivers[cell.receiver].height)
    return BBC_ERR_INVALID_ARGUMENT;
  /* Each level's list after the last, strictly increasing in tuple id (Sec. 7.2); then merged. */
  uint32_t start[BBC__MAX_CELL_LEVELS + 1], lists = 0, total = 0;
  for (uint32_t k = 0; k < g->levels; k++) {
    uint32_t n;
    bbc_result r = cell_into(cur, bbc_grid_level_cell(g, cell, k), total, &n);
    if (r != BBC_OK) return r;
    if (n == 0) continue;
    start[lists++] = total;
    total += n;
  }
  start[lists] = total;
  if (lists <= 1) {
    *entries = total ? cur->out : NULL;
    *count = total;
    return BBC_OK;
  }
  if (!grow(&cur->merged, &cur->merged_cap, total)) return BBC_ERR_OUT_OF_MEMORY;
  uint32_t at[BBC__MAX_CELL_LEVELS], n = 0;
  for (uint32_t i = 0; i < lists; i++) at[i] = start[i];
  for (;;) {
    uint32_t best = UINT32_MAX;
    for (uint32_t i = 0; i < lists; i++)
      if (at[i] < start[i + 1] &&
          (best == UINT32_MAX || cur->out[at[i]].tuple < cur->out[at[best]].tuple))
        best = i;
    if (best == UINT32_MAX) break;
    const bbc_cache_entry e = cur->out[at[best]++];
    if (n > 0 && cur->merged[n - 1].tuple == e.tuple) {
      if (e.bound > cur->merged[n - 1].bound) cur->merged[n - 1].bound = e.bound;
    } else {
      cur->merged[n++] = e;
    }
  }
  *entries = cur->merged;
  *count = n;
  return BBC_OK;
}

bbc_result bbc_cache_lookup(bbc_cache_cursor *cur, uint32_t triangle, double b1, double b2,
                            const bbc_vec3 *point, const bbc_cache_entry **entries,
                            uint32_t *count) {
  if (entries) *entries = NULL;
  if (count) *count = 0;
  if (!cur || !entries || !count) return BBC_ERR_INVALID_ARGUMENT;
  bbc_cell cell;
  if (!bbc_grid_locate(&cur->c->grid, triangle, b1, b2, point, &cell)) return BBC_OK;
  return bbc_cache_leaf(cur, cell, entries, count);
}

/* ------------------------------------------------------------------ validation */

bbc_result bbc_cache_validate(const bbc_cache *c, bbc_message_fn report, void *user) {
  if (!c) return BBC_ERR_INVALID_ARGUMENT;
  reporter rp = {c, report, user};
  bbc_result first = BBC_OK;
#define NOTE(r)                                      \
  do {                                               \
    bbc_result r_ = (r);                             \
    if (r_ != BBC_OK && first == BBC_OK) first = r_; \
  } while (0)

  /* R-DIR-6: the whole chunk data. */
  for (uint32_t i = 0; i < c->section_count; i++)
    if (c->sections[i].type == BBC__SEC_CDAT &&
        CHECKSUM_DIFFERS(crc_of(c->sec[K_CDAT], c->sec_size[K_CDAT]), c->sections[i].checksum))
      NOTE(rfail(&rp, BBC_ERR_CHECKSUM, "CDAT", c->sec_offset[K_CDAT],
                 "section CDAT checksum mismatch (R-DIR-6)"));

  /* R-GEO-2, R-GEO-3: the stored geometry decodes and is the fingerprinted one. */
  if (c->sec[K_GEOM]) {
    bbc__geometry g;
    const char *why = NULL;
    bbc_result r = bbc__geometry_decode(c->sec[K_GEOM], c->sec_size[K_GEOM],
                                        c->fingerprint.geometry, &g, &why);
    if (r == BBC_OK) bbc__geometry_free(&g);
    NOTE(r == BBC_OK ? r
                     : rfail(&rp, r, "GEOM", c->sec_offset[K_GEOM], "%s", why ? why : "out of memory"));
  }

  uint32_t max_entries = 0;
  for (uint32_t k = 0; k < c->chunk_count; k++) {
    uint32_t n = bbc__ld32(c->sec[K_CHNK] + BBC__CHNK_SIZE * (size_t)k + 12);
    if (n > max_entries) max_entries = n;
  }
  uint8_t *planes = malloc((size_t)max_entries * BBC__ENTRY_BYTES + 1);
  ZSTD_DCtx *dctx = ZSTD_createDCtx();
  if (!planes || !dctx) {
    free(planes);
    ZSTD_freeDCtx(dctx);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  /* Every chunk, then every list in it; a bad chunk is reported once and its lists
   * skipped. Cells of chunk k are consecutive (R-CIX-2). */
  const uint8_t *x = c->sec[K_CIDX];
  uint64_t cell = 0;
  for (uint32_t k = 0; k < c->chunk_count; k++) {
    uint32_t n = bbc__ld32(c->sec[K_CHNK] + BBC__CHNK_SIZE * (size_t)k + 12);
    /* Into a buffer the cache keeps when it keeps chunks and has room (a chunk kept
     * before is checked again all the same, in the scratch buffer). */
    const uint8_t *decoded = NULL;
    bbc_result r = BBC_OK;
    if (c->options.keep_decoded && !kept_chunk(c, k)) r = decode_kept(&rp, dctx, k, 1, &decoded);
    if (r == BBC_OK && !decoded) {
      r = decode_chunk(&rp, dctx, k, planes, 1);
      decoded = planes;
    }
    NOTE(r);
    for (; cell < c->grid.cell_count; cell++) {
      const uint8_t *e = x + BBC__CIDX_SIZE * cell;
      uint32_t ck = bbc__ld32(e), count = bbc__ld32(e + 8);
      if (count == 0) continue;
      if (ck != k) break;
      if (r == BBC_OK) {
        bbc_result lr = decode_list(&rp, decoded, n, bbc__ld32(e + 4), count, cell, NULL);
        NOTE(lr);
      }
    }
  }
  free(planes);
  ZSTD_freeDCtx(dctx);
  return first;
#undef NOTE
}
