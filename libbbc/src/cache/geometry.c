/* The GEOM section (format-spec Sec. 5.11) and the scene match within the quanta
 * (Sec. 8.1): a re-export of an unchanged scene keeps its cache, a real change does not.
 *
 * Exact hashes cannot tell float noise from a change, and hashes of quantised values
 * break wherever noise crosses a quantisation boundary (a 2,880-vertex sphere would
 * almost always have one such vertex). So the cache stores the geometry it was computed
 * for, and a scene whose geometry hash differs is compared with it triangle by
 * triangle, in any order. A scene that matches is then given the cache's geometry
 * exactly (bbc_cache_match_scene), so that every bound in the cache holds for what is
 * rendered. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#include "geometry_internal.h"

/* Bytes of the geometry stream after its two counts (Sec. 8): positions, normals, uvs,
 * indices, triangle_mesh. */
static uint64_t stream_size(uint64_t vertices, uint64_t triangles) {
  return 32 * vertices + 16 * triangles;
}

static uint8_t *put(uint8_t *p, const void *data, size_t size) {
  if (data)
    memcpy(p, data, size);
  else
    memset(p, 0, size);
  return p + size;
}

bbc_result bbc__geometry_encode(const bbc_scene *s, uint8_t **out, size_t *size) {
  *out = NULL;
  *size = 0;
  size_t v = s->vertex_count, t = s->triangle_count, raw = (size_t)stream_size(v, t);
  uint8_t *buf = malloc(raw ? raw : 1);
  size_t bound = ZSTD_compressBound(raw);
  uint8_t *sec = malloc(BBC__GEOM_HEAD_SIZE + bound);
  if (!buf || !sec) {
    free(buf);
    free(sec);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  uint8_t *p = put(buf, s->positions, 12 * v);
  p = put(p, s->normals, 12 * v);
  p = put(p, s->uvs, 8 * v);
  p = put(p, s->indices, 12 * t);
  put(p, s->triangle_mesh, 4 * t);
  size_t n = ZSTD_compress(sec + BBC__GEOM_HEAD_SIZE, bound, buf, raw, BBC__GEOM_LEVEL);
  free(buf);
  if (ZSTD_isError(n)) {
    free(sec);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  memset(sec, 0, BBC__GEOM_HEAD_SIZE);
  bbc__st32(sec, (uint32_t)v);
  bbc__st32(sec + 4, (uint32_t)t);
  bbc__st64(sec + 8, stream_size(v, t));
  *out = sec;
  *size = BBC__GEOM_HEAD_SIZE + n;
  return BBC_OK;
}

const char *bbc__geometry_check_head(const uint8_t *sec, uint64_t size, uint32_t vertex_count,
                                     uint32_t triangle_count) {
  if (size <= BBC__GEOM_HEAD_SIZE) return "no geometry frame after the head (R-GEO-1)";
  if (bbc__ld32(sec) != vertex_count || bbc__ld32(sec + 4) != triangle_count)
    return "vertex or triangle count differs from FPRT's (R-GEO-1)";
  if (bbc__ld64(sec + 8) != stream_size(vertex_count, triangle_count))
    return "stream size is not 32 per vertex plus 16 per triangle (R-GEO-1)";
  for (uint32_t i = 16; i < BBC__GEOM_HEAD_SIZE; i++)
    if (sec[i]) return "reserved bytes not zero (R-FILE-2)";
  return NULL;
}

void bbc__geometry_free(bbc__geometry *g) {
  free(g->positions);
  free(g->normals);
  free(g->uvs);
  free(g->indices);
  free(g->triangle_mesh);
  memset(g, 0, sizeof *g);
}

static void *take(const uint8_t **p, size_t size) {
  void *a = malloc(size ? size : 1);
  if (a) memcpy(a, *p, size);
  *p += size;
  return a;
}

bbc_result bbc__geometry_decode(const uint8_t *sec, uint64_t size, uint64_t geometry_hash,
                                bbc__geometry *out, const char **why) {
  memset(out, 0, sizeof *out);
  *why = NULL;
  uint32_t v = bbc__ld32(sec), t = bbc__ld32(sec + 4);
  uint64_t raw = bbc__ld64(sec + 8);
  const uint8_t *src = sec + BBC__GEOM_HEAD_SIZE;
  size_t csize = (size_t)(size - BBC__GEOM_HEAD_SIZE);
  /* R-GEO-2: one zstd data frame without dictionary that declares and holds the stream. */
  if (csize < 4 || bbc__ld32(src) != ZSTD_MAGICNUMBER || ZSTD_getDictID_fromFrame(src, csize) != 0 ||
      ZSTD_getFrameContentSize(src, csize) != raw ||
      ZSTD_findFrameCompressedSize(src, csize) != csize) {
    *why = "not one zstd frame declaring the geometry stream's size (R-GEO-2)";
    return BBC_ERR_CORRUPT;
  }
  if (raw > SIZE_MAX) return BBC_ERR_OUT_OF_MEMORY;
  uint8_t *buf = malloc(raw ? (size_t)raw : 1);
  if (!buf) return BBC_ERR_OUT_OF_MEMORY;
  size_t got = ZSTD_decompress(buf, (size_t)raw, src, csize);
  if (ZSTD_isError(got) || got != raw) {
    free(buf);
    *why = "the geometry frame does not decode (R-GEO-2)";
    return BBC_ERR_CORRUPT;
  }
  /* R-GEO-3: the stream is the one FPRT's geometry hash was computed over. */
  bbc__xxh64_state h;
  bbc__xxh64_init(&h);
  bbc__xxh64_update(&h, sec, 8);
  bbc__xxh64_update(&h, buf, (size_t)raw);
  if (bbc__xxh64_final(&h) != geometry_hash) {
    free(buf);
    *why = "the geometry does not hash to FPRT's geometry hash (R-GEO-3)";
    return BBC_ERR_CORRUPT;
  }
  const uint8_t *p = buf;
  out->vertex_count = v;
  out->triangle_count = t;
  out->positions = take(&p, 12 * (size_t)v);
  out->normals = take(&p, 12 * (size_t)v);
  out->uvs = take(&p, 8 * (size_t)v);
  out->indices = take(&p, 12 * (size_t)t);
  out->triangle_mesh = take(&p, 4 * (size_t)t);
  free(buf);
  if (!out->positions || !out->normals || !out->uvs || !out->indices || !out->triangle_mesh) {
    bbc__geometry_free(out);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  return BBC_OK;
}

/* ------------------------------------------------------------------ the match */

/* Sec. 8.1: the quanta are 2^-17 of a mesh's largest coordinate magnitude for positions,
 * 2^-17 for normals, and 2^-17 of max(1, the largest uv magnitude) for uvs. */
#define QUANTUM_EXP (-17)

typedef struct matcher {
  const bbc__geometry *g;
  const bbc_scene *s;
  double qp, qn, qu;
  bbc_scene_match *m;
} matcher;

static int close_to(const float *a, const float *b, int n, double q) {
  for (int k = 0; k < n; k++)
    if (!(fabs((double)a[k] - (double)b[k]) <= q)) return 0;
  return 1;
}

/* The rotation r (0..2) for which corner (k + r) mod 3 of scene triangle a lies within
 * the quanta of corner k of cached triangle b, for every k; or -1. */
static int rotation(const matcher *mt, uint32_t a, uint32_t b) {
  const uint32_t *ia = mt->s->indices + 3 * (size_t)a, *ib = mt->g->indices + 3 * (size_t)b;
  for (int r = 0; r < 3; r++) {
    int k = 0;
    for (; k < 3; k++) {
      size_t va = ia[(k + r) % 3], vb = ib[k];
      if (!close_to(mt->s->positions + 3 * va, mt->g->positions + 3 * vb, 3, mt->qp) ||
          !close_to(mt->s->normals + 3 * va, mt->g->normals + 3 * vb, 3, mt->qn) ||
          !close_to(mt->s->uvs + 2 * va, mt->g->uvs + 2 * vb, 2, mt->qu))
        break;
    }
    if (k == 3) return r;
  }
  return -1;
}

static void record(const matcher *mt, uint32_t a, uint32_t b, int r) {
  const uint32_t *ia = mt->s->indices + 3 * (size_t)a, *ib = mt->g->indices + 3 * (size_t)b;
  bbc_scene_match *m = mt->m;
  m->triangles_moved += a != b || r != 0;
  for (int k = 0; k < 3; k++) {
    size_t va = ia[(k + r) % 3], vb = ib[k];
    for (int c = 0; c < 3; c++) {
      double dp = fabs((double)mt->s->positions[3 * va + c] - mt->g->positions[3 * vb + c]);
      double dn = fabs((double)mt->s->normals[3 * va + c] - mt->g->normals[3 * vb + c]);
      if (dp > m->position_error) m->position_error = dp;
      if (dn > m->normal_error) m->normal_error = dn;
    }
    for (int c = 0; c < 2; c++) {
      double du = fabs((double)mt->s->uvs[2 * va + c] - mt->g->uvs[2 * vb + c]);
      if (du > m->uv_error) m->uv_error = du;
    }
  }
}

/* A cached triangle by the cell of its centroid, cells 4 position quanta wide: a scene
 * triangle within the quanta has its centroid in the same or a neighbouring cell. */
typedef struct keyed {
  int64_t cell[3];
  uint32_t triangle;
} keyed;

static void centroid_cell(const float *positions, const uint32_t *idx, double h, int64_t cell[3]) {
  for (int c = 0; c < 3; c++) {
    double sum = (double)positions[3 * (size_t)idx[0] + c] + positions[3 * (size_t)idx[1] + c] +
                 positions[3 * (size_t)idx[2] + c];
    cell[c] = (int64_t)floor(sum / 3.0 / h);
  }
}

static int cell_cmp(const int64_t a[3], const int64_t b[3]) {
  for (int c = 0; c < 3; c++)
    if (a[c] != b[c]) return a[c] < b[c] ? -1 : 1;
  return 0;
}

static int keyed_cmp(const void *x, const void *y) {
  const keyed *a = x, *b = y;
  int c = cell_cmp(a->cell, b->cell);
  return c ? c : (a->triangle > b->triangle) - (a->triangle < b->triangle);
}

/* The first entry of keys[0, n) whose cell is not below `cell`. */
static size_t lower_bound(const keyed *keys, size_t n, const int64_t cell[3]) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (cell_cmp(keys[mid].cell, cell) < 0)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

static double max_abs(const float *v, size_t n) {
  double m = 0.0;
  for (size_t i = 0; i < n; i++)
    if (fabs((double)v[i]) > m) m = fabs((double)v[i]);
  return m;
}

/* Mesh i: every scene triangle paired with a distinct cached one, first at the same
 * index, then by centroid cell. */
static bbc_result match_mesh(matcher *mt, uint32_t i, uint8_t *used, char *why, size_t why_size) {
  const bbc_mesh *mesh = &mt->s->meshes[i];
  const bbc__geometry *g = mt->g;
  uint32_t ft = mesh->first_triangle, nt = mesh->triangle_count;
  uint32_t fv = mesh->first_vertex, nv = mesh->vertex_count;
  for (size_t k = 3 * (size_t)ft; k < 3 * ((size_t)ft + nt); k++)
    if (g->indices[k] < fv || g->indices[k] - fv >= nv) {
      snprintf(why, why_size, "cached triangle %zu indexes a vertex outside its mesh", k / 3);
      return BBC_ERR_CORRUPT;
    }
  double mp = max_abs(g->positions + 3 * (size_t)fv, 3 * (size_t)nv);
  double mu = max_abs(g->uvs + 2 * (size_t)fv, 2 * (size_t)nv);
  mt->qp = ldexp(mp, QUANTUM_EXP);
  mt->qn = ldexp(1.0, QUANTUM_EXP);
  mt->qu = ldexp(mu > 1.0 ? mu : 1.0, QUANTUM_EXP);

  uint32_t pending = 0;
  for (uint32_t a = ft; a < ft + nt; a++) {
    int r = rotation(mt, a, a);
    if (r >= 0) {
      used[a] = 1;
      record(mt, a, a, r);
    } else {
      pending++;
    }
  }
  if (pending == 0) return BBC_OK;

  /* The cached triangles not taken yet, sorted by cell. */
  double h = 4.0 * mt->qp;
  if (!(h > 0.0) || !isfinite(h)) h = 1.0;
  keyed *keys = malloc(sizeof *keys * pending);
  uint32_t *left = malloc(sizeof *left * pending);
  if (!keys || !left) {
    free(keys);
    free(left);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  size_t nk = 0, nl = 0;
  for (uint32_t b = ft; b < ft + nt; b++)
    if (!used[b]) {
      keys[nk].triangle = b;
      centroid_cell(g->positions, g->indices + 3 * (size_t)b, h, keys[nk++].cell);
    }
  for (uint32_t a = ft; a < ft + nt; a++)
    if (!used[a]) left[nl++] = a; /* pass 1 took cached triangle a only with scene triangle a */
  qsort(keys, nk, sizeof *keys, keyed_cmp);

  bbc_result result = BBC_OK;
  for (size_t j = 0; j < nl && result == BBC_OK; j++) {
    uint32_t a = left[j];
    int64_t cell[3], probe[3];
    centroid_cell(mt->s->positions, mt->s->indices + 3 * (size_t)a, h, cell);
    int found = 0;
    for (int d = 0; d < 27 && !found; d++) {
      probe[0] = cell[0] + d % 3 - 1;
      probe[1] = cell[1] + d / 3 % 3 - 1;
      probe[2] = cell[2] + d / 9 - 1;
      for (size_t e = lower_bound(keys, nk, probe); e < nk && !cell_cmp(keys[e].cell, probe);
           e++) {
        uint32_t b = keys[e].triangle;
        int r = used[b] ? -1 : rotation(mt, a, b);
        if (r >= 0) {
          used[b] = 1;
          record(mt, a, b, r);
          found = 1;
          break;
        }
      }
    }
    if (!found) {
      snprintf(why, why_size,
               "triangle %u of mesh \"%s\" is not within the quanta of any of the cache's "
               "(positions %.3g, normals %.3g, uvs %.3g; format-spec Sec. 8.1)",
               a - ft, mesh->name, mt->qp, mt->qn, mt->qu);
      result = BBC_ERR_SCENE_MISMATCH;
    }
  }
  free(keys);
  free(left);
  return result;
}

bbc_result bbc__geometry_match(const bbc__geometry *g, const bbc_scene *s, bbc_scene_match *m,
                               char *why, size_t why_size) {
  memset(m, 0, sizeof *m);
  if (g->vertex_count != s->vertex_count || g->triangle_count != s->triangle_count ||
      memcmp(g->triangle_mesh, s->triangle_mesh, 4 * (size_t)s->triangle_count) != 0) {
    snprintf(why, why_size, "vertex or triangle counts, or the meshes of triangles, differ");
    return BBC_ERR_SCENE_MISMATCH;
  }
  uint8_t *used = calloc(s->triangle_count ? s->triangle_count : 1, 1);
  if (!used) return BBC_ERR_OUT_OF_MEMORY;
  matcher mt = {g, s, 0.0, 0.0, 0.0, m};
  bbc_result r = BBC_OK;
  for (uint32_t i = 0; i < s->mesh_count && r == BBC_OK; i++) r = match_mesh(&mt, i, used, why, why_size);
  free(used);
  return r;
}
