/* Writing .bbc caches (format-spec/bbc-format.md): the builder that keeps, per cell and
 * tuple, the maximum irradiance bound (Eq. 21), and the writer (Sec. 2-7). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <zlib.h>
#include <zstd.h>

#include <omp.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "grid_internal.h"
#include "report_internal.h"
#include "geometry_internal.h"
#include "spill_internal.h"

_Static_assert(sizeof(bbc_tuple) == BBC__TUPL_SIZE, "bbc_tuple is the TUPL record");

float bbc_cache_quantize_bound(double bound) {
  if (isnan(bound)) return NAN;
  return bbc__bound_decode(bbc__bound_encode(bound));
}

/* ------------------------------------------------------------------ builder */

typedef bbc__cell_entry cell_entry;

/* A cell's entries in memory: appended as splats come, sorted and merged (maximum per
 * tuple) whenever the array fills up and once before spilling or writing, so memory
 * stays within about twice the distinct entries. 16 bytes per cell. */
typedef struct cell_list {
  cell_entry *e;
  uint32_t count, cap;
} cell_list;

size_t bbc__cache_builder_cell_bytes(void) {
  return sizeof(cell_list);
}

/* Splats lock one row of cells at a time; rows map to a fixed set of mutexes. */
#define BUILDER_LOCKS 256

struct bbc_cache_builder {
  bbc_grid *grid;
  bbc_precompute_params params;
  bbc_fingerprint fingerprint;
  uint32_t scene_counts[6]; /* vertices, triangles, meshes, materials, point lights,
                               emitters (area-light caches only, else 0) */
  bbc_tuple *tuples;
  uint32_t tuple_count, tuple_cap;
  cell_list *cells;
  pthread_mutex_t locks[BUILDER_LOCKS];
  /* Bytes of entry arrays held by the cells; past entry_budget, the lists go to the
   * spill store as a sorted run (bbc__cache_builder_spill_if_full). */
  atomic_size_t entry_bytes;
  size_t entry_budget;
  bbc__spill *spill;
  /* A shard cache (SHRD, spec Sec. 5.10) when shard_count > 0. */
  uint32_t shard_index, shard_count;
  uint64_t candidate_count, candidates_hash;
  uint64_t *candidate; /* per tuple id: its candidate index, UINT64_MAX until given */
  uint32_t candidate_cap;
  /* INFO: "bbc <version>" unless info_set; then info_text, or none when it is NULL. */
  int info_set;
  char *info_text;
  size_t info_size;
  /* GEOM (Sec. 5.11): the scene's geometry as the section's bytes, or NULL. */
  uint8_t *geometry;
  size_t geometry_size;
};

/* The cells and locks of a builder whose grid is set; frees the grid on failure. */
static bbc_result builder_finish(bbc_cache_builder *b) {
  b->cells = calloc(b->grid->cell_count ? b->grid->cell_count : 1, sizeof *b->cells);
  if (!b->cells) {
    bbc_grid_free(b->grid);
    b->grid = NULL;
    return BBC_ERR_OUT_OF_MEMORY;
  }
  for (int i = 0; i < BUILDER_LOCKS; i++) pthread_mutex_init(&b->locks[i], NULL);
  atomic_init(&b->entry_bytes, 0);
  b->entry_budget = BBC__DEFAULT_ENTRY_MEMORY;
  return BBC_OK;
}

bbc_result bbc_cache_builder_create(bbc_cache_builder **out, const bbc_scene *scene,
                                    const bbc_precompute_params *params) {
  if (out) *out = NULL;
  if (!out || !scene || !params || !bbc__params_valid(params)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_cache_builder *b = calloc(1, sizeof *b);
  if (!b) return BBC_ERR_OUT_OF_MEMORY;
  bbc_result r = bbc_grid_create(&b->grid, scene, params->grid_resolution, NULL, NULL);
  if (r != BBC_OK) {
    free(b);
    return r;
  }
  if (b->grid->receiver_count == 0) {
    bbc_grid_free(b->grid);
    free(b);
    return BBC_ERR_SCENE;
  }
  b->params = *params;
  b->params.remainder = params->remainder ? 1 : 0;
  b->params.area_lights = params->area_lights ? 1 : 0;
  /* The area lights' double-scattering tuples (format 1.4, PARM flags bit 2). */
  b->params.area_double =
      b->params.area_lights && params->area_double && (params->chains & BBC_CHAIN_MASK_DOUBLE);
  b->params.beam_receivers = params->beam_receivers ? 1 : 0; /* format 1.7, flags bit 3 */
  /* Levels of cells for beam receivers (format 1.8, spec Sec. 6.6). */
  const uint32_t levels = params->cell_levels ? params->cell_levels
                          : b->params.beam_receivers
                              ? bbc__grid_beam_levels(params->grid_resolution)
                              : 1;
  b->params.cell_levels = levels >= 2 ? levels : 0;
  bbc__grid_set_levels(b->grid, (bbc_receiver *)b->grid->receivers, levels);
  bbc_fingerprint_compute(scene, &b->params, &b->fingerprint);
  b->scene_counts[0] = scene->vertex_count;
  b->scene_counts[1] = scene->triangle_count;
  b->scene_counts[2] = scene->mesh_count;
  b->scene_counts[3] = scene->material_count;
  b->scene_counts[4] = scene->point_light_count;
  b->scene_counts[5] = b->params.area_lights ? scene->emitter_count : 0;
  if (bbc__geometry_encode(scene, &b->geometry, &b->geometry_size) != BBC_OK) {
    bbc_grid_free(b->grid);
    free(b);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  if (builder_finish(b) != BBC_OK) {
    free(b->geometry);
    free(b);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  *out = b;
  return BBC_OK;
}

bbc_result bbc__cache_builder_from_parts(bbc_cache_builder **out, const bbc_cache_info *info,
                                         const bbc_grid *g) {
  *out = NULL;
  const bbc_cache_info in = *info;
  bbc_cache_builder *b = calloc(1, sizeof *b);
  bbc_grid *grid = calloc(1, sizeof *grid);
  bbc_receiver *receivers = calloc(g->receiver_count ? g->receiver_count : 1, sizeof *receivers);
  float *uv = malloc(sizeof(float) * 6 * (g->uv_triangle_count ? g->uv_triangle_count : 1));
  if (!b || !grid || !receivers || !uv) {
    free(b);
    free(grid);
    free(receivers);
    free(uv);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  *grid = *g;
  memcpy(receivers, g->receivers, sizeof *receivers * g->receiver_count);
  memcpy(uv, g->triangle_uv, sizeof(float) * 6 * g->uv_triangle_count);
  grid->receivers = receivers;
  grid->triangle_uv = uv;
  b->grid = grid;
  b->params = in.params;
  b->fingerprint = in.fingerprint;
  b->scene_counts[0] = in.scene_vertex_count;
  b->scene_counts[1] = in.scene_triangle_count;
  b->scene_counts[2] = in.scene_mesh_count;
  b->scene_counts[3] = in.scene_material_count;
  b->scene_counts[4] = in.scene_light_count;
  b->scene_counts[5] = in.scene_emitter_count;
  if (builder_finish(b) != BBC_OK) {
    free(b);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  *out = b;
  return BBC_OK;
}

void bbc_cache_builder_free(bbc_cache_builder *b) {
  if (!b) return;
  if (b->cells)
    for (uint64_t i = 0; i < b->grid->cell_count; i++) free(b->cells[i].e);
  free(b->cells);
  bbc__spill_free(b->spill);
  for (int i = 0; i < BUILDER_LOCKS; i++) pthread_mutex_destroy(&b->locks[i]);
  bbc_grid_free(b->grid);
  free(b->tuples);
  free(b->candidate);
  free(b->info_text);
  free(b->geometry);
  free(b);
}

const bbc_grid *bbc_cache_builder_grid(const bbc_cache_builder *b) {
  return b->grid;
}
uint32_t bbc_cache_builder_tuple_count(const bbc_cache_builder *b) {
  return b->tuple_count;
}

bbc_result bbc_cache_builder_add_tuple(bbc_cache_builder *b, const bbc_tuple *t, uint32_t *id) {
  if (!b || !t) return BBC_ERR_INVALID_ARGUMENT;
  uint32_t triangles = b->scene_counts[1];
  if (t->chain >= BBC_CHAIN_COUNT || !(b->params.chains & BBC_CHAIN_BIT(t->chain)) ||
      t->light >= b->scene_counts[4] + b->scene_counts[5] ||
      (t->light >= b->scene_counts[4] && bbc_chain_length((bbc_chain)t->chain) != 1 &&
       !b->params.area_double) ||
      t->specular[0] >= triangles ||
      !(bbc_receiver_is_beam(t->receiver) ? b->params.beam_receivers != 0
                                          : bbc__grid_tuple_end(b->grid, t->receiver)))
    return BBC_ERR_INVALID_ARGUMENT;
  if (bbc_chain_length((bbc_chain)t->chain) == 1 ? t->specular[1] != BBC_NO_TRIANGLE
                                                 : t->specular[1] >= triangles)
    return BBC_ERR_INVALID_ARGUMENT;
  if (b->tuple_count >= BBC__MAX_TUPLES) return BBC_ERR_UNSUPPORTED;
  if (b->tuple_count == b->tuple_cap) {
    uint32_t cap = b->tuple_cap ? b->tuple_cap : 1024;
    cap = cap > BBC__MAX_TUPLES / 2 ? BBC__MAX_TUPLES : cap * 2;
    bbc_tuple *n = realloc(b->tuples, sizeof *n * (size_t)cap);
    if (!n) return BBC_ERR_OUT_OF_MEMORY;
    b->tuples = n;
    b->tuple_cap = cap;
  }
  b->tuples[b->tuple_count] = *t;
  if (id) *id = b->tuple_count;
  b->tuple_count++;
  return BBC_OK;
}

/* ------------------------------------------------------------------ shards */

uint64_t bbc__candidates_hash(const bbc_tuple *tuples, size_t count) {
  /* bbc_tuple is the TUPL record byte for byte (static assertion above). */
  return bbc__xxh64(tuples, sizeof *tuples * count);
}

bbc_result bbc__cache_builder_shard(bbc_cache_builder *b, uint32_t index, uint32_t count,
                                    bbc_tuple *tuples, size_t *tuple_count, uint64_t **candidate) {
  *candidate = NULL;
  if (!b || count == 0 || index >= count || b->tuple_count != 0 || (!tuples && *tuple_count))
    return BBC_ERR_INVALID_ARGUMENT;
  size_t all = *tuple_count, kept = all > index ? (all - index - 1) / count + 1 : 0;
  uint64_t *k = malloc(sizeof *k * (kept ? kept : 1));
  if (!k) return BBC_ERR_OUT_OF_MEMORY;
  bbc__cache_builder_set_shard(b, index, count, all, bbc__candidates_hash(tuples, all));
  /* Interleaved (k % count == index) rather than ranges: neighbouring candidates share
   * a caster and cost alike, so every shard gets a similar mix of work. */
  size_t n = 0;
  for (size_t i = index; i < all; i += count) {
    k[n] = i;
    tuples[n++] = tuples[i];
  }
  *tuple_count = n;
  *candidate = k;
  return BBC_OK;
}

bbc_result bbc__cache_builder_set_shard(bbc_cache_builder *b, uint32_t index, uint32_t count,
                                        uint64_t candidate_count, uint64_t candidates_hash) {
  if (!b || count == 0 || index >= count || b->tuple_count != 0) return BBC_ERR_INVALID_ARGUMENT;
  b->shard_index = index;
  b->shard_count = count;
  b->candidate_count = candidate_count;
  b->candidates_hash = candidates_hash;
  return BBC_OK;
}

bbc_result bbc__cache_builder_set_candidate(bbc_cache_builder *b, uint32_t id, uint64_t candidate) {
  if (!b || b->shard_count == 0 || id >= b->tuple_count) return BBC_ERR_INVALID_ARGUMENT;
  if (id >= b->candidate_cap) {
    uint32_t cap = b->tuple_cap > id ? b->tuple_cap : id + 1;
    uint64_t *n = realloc(b->candidate, sizeof *n * (size_t)cap);
    if (!n) return BBC_ERR_OUT_OF_MEMORY;
    for (uint32_t i = b->candidate_cap; i < cap; i++) n[i] = UINT64_MAX;
    b->candidate = n;
    b->candidate_cap = cap;
  }
  b->candidate[id] = candidate;
  return BBC_OK;
}

bbc_result bbc__cache_builder_set_info(bbc_cache_builder *b, const void *text, size_t size) {
  if (!b || (text && (size > BBC__MAX_INFO || !bbc__info_text_valid(text, size))))
    return BBC_ERR_INVALID_ARGUMENT;
  char *copy = NULL;
  if (text) {
    copy = malloc(size ? size : 1);
    if (!copy) return BBC_ERR_OUT_OF_MEMORY;
    memcpy(copy, text, size);
  }
  free(b->info_text);
  b->info_set = 1;
  b->info_text = copy;
  b->info_size = text ? size : 0;
  return BBC_OK;
}

bbc_result bbc__cache_builder_set_geometry(bbc_cache_builder *b, const void *section, size_t size) {
  if (!b) return BBC_ERR_INVALID_ARGUMENT;
  uint8_t *copy = NULL;
  if (section) {
    copy = malloc(size ? size : 1);
    if (!copy) return BBC_ERR_OUT_OF_MEMORY;
    memcpy(copy, section, size);
  }
  free(b->geometry);
  b->geometry = copy;
  b->geometry_size = section ? size : 0;
  return BBC_OK;
}

/* R-SHR-3 for the tuples of a shard builder: the SHRD section it would write is valid. */
static int shard_candidates_valid(const bbc_cache_builder *b) {
  for (uint32_t i = 0; i < b->tuple_count; i++) {
    uint64_t k = i < b->candidate_cap ? b->candidate[i] : UINT64_MAX;
    if (k >= b->candidate_count || k % b->shard_count != b->shard_index ||
        (i > 0 && k <= b->candidate[i - 1]))
      return 0;
  }
  return 1;
}

static int entry_cmp(const void *a, const void *b) {
  uint32_t x = ((const cell_entry *)a)->tuple, y = ((const cell_entry *)b)->tuple;
  return (x > y) - (x < y);
}

/* Sorts a cell's entries by tuple and keeps the maximum code per tuple. */
static void cell_compact(cell_list *c) {
  if (c->count < 2) return;
  /* Lists filled in tuple order (bbc__cache_builder_add_rows) are sorted already. */
  uint32_t k = 1;
  while (k < c->count && c->e[k - 1].tuple < c->e[k].tuple) k++;
  if (k == c->count) return;
  if (c->count <= 16) {
    for (uint32_t i = 1; i < c->count; i++) {
      cell_entry x = c->e[i];
      uint32_t j = i;
      while (j > 0 && c->e[j - 1].tuple > x.tuple) {
        c->e[j] = c->e[j - 1];
        j--;
      }
      c->e[j] = x;
    }
  } else {
    qsort(c->e, c->count, sizeof *c->e, entry_cmp);
  }
  uint32_t n = 1;
  for (uint32_t i = 1; i < c->count; i++) {
    if (c->e[i].tuple == c->e[n - 1].tuple) {
      if (c->e[i].code > c->e[n - 1].code) c->e[n - 1].code = c->e[i].code;
    } else {
      c->e[n++] = c->e[i];
    }
  }
  c->count = n;
}

static bbc_result cell_add(bbc_cache_builder *b, cell_list *c, uint32_t tuple, uint32_t code) {
  /* Pieces of one tuple usually arrive together, so most repeats hit the last entry. */
  if (c->count > 0 && c->e[c->count - 1].tuple == tuple) {
    if (code > c->e[c->count - 1].code) c->e[c->count - 1].code = code;
    return BBC_OK;
  }
  if (c->count == c->cap) {
    cell_compact(c);
    if (c->count > c->cap / 4 * 3 || c->cap == 0) {
      if (c->cap >= UINT32_MAX / 2) return BBC_ERR_OUT_OF_MEMORY;
      uint32_t cap = c->cap ? c->cap * 2 : 4;
      cell_entry *n = realloc(c->e, sizeof *n * (size_t)cap);
      if (!n) return BBC_ERR_OUT_OF_MEMORY;
      atomic_fetch_add_explicit(&b->entry_bytes, sizeof *n * (size_t)(cap - c->cap),
                                memory_order_relaxed);
      c->e = n;
      c->cap = cap;
    }
  }
  c->e[c->count].tuple = tuple;
  c->e[c->count].code = code;
  c->count++;
  return BBC_OK;
}

bbc_result bbc_cache_builder_splat(bbc_cache_builder *b, uint32_t tuple_id,
                                   uint32_t receiver_triangle, double b1_lo, double b1_hi,
                                   double b2_lo, double b2_hi, double bound) {
  if (!b || tuple_id >= b->tuple_count || b->tuples[tuple_id].receiver != receiver_triangle ||
      isnan(bound) || bound < 0)
    return BBC_ERR_INVALID_ARGUMENT;
  bbc_cell_range range;
  if (!bbc_grid_splat_range(b->grid, receiver_triangle, b1_lo, b1_hi, b2_lo, b2_hi, &range))
    return BBC_OK;
  /* The caller passes E~ with Eq. 21's m (and the light's intensity) already applied,
   * rounded upward; the builder only keeps the maximum, and the code rounds up again
   * (R-BND-1). */
  double e = bound;
  uint32_t code = bbc__bound_encode(e);
  const bbc_receiver *r = &b->grid->receivers[range.receiver];
  for (uint32_t y = range.y0; y <= range.y1; y++) {
    uint64_t row = r->first_cell + (uint64_t)y * r->width;
    pthread_mutex_t *lock = &b->locks[(range.receiver * 7919u + y) % BUILDER_LOCKS];
    pthread_mutex_lock(lock);
    bbc_result res = BBC_OK;
    for (uint32_t x = range.x0; x <= range.x1 && res == BBC_OK; x++)
      res = cell_add(b, &b->cells[row + x], tuple_id, code);
    pthread_mutex_unlock(lock);
    if (res != BBC_OK) return res;
  }
  return BBC_OK;
}

bbc_result bbc_cache_builder_splat_cells(bbc_cache_builder *b, uint32_t tuple_id,
                                         const bbc_cell_range *range, const double *bounds) {
  if (!b || !range || !bounds || tuple_id >= b->tuple_count ||
      range->receiver >= b->grid->receiver_count)
    return BBC_ERR_INVALID_ARGUMENT;
  const bbc_receiver *r = &b->grid->receivers[range->receiver];
  if (range->x0 > range->x1 || range->y0 > range->y1 || range->x1 >= r->width ||
      range->y1 >= r->height)
    return BBC_ERR_INVALID_ARGUMENT;
  const size_t stride = (size_t)range->x1 - range->x0 + 1;
  for (uint32_t y = range->y0; y <= range->y1; y++) {
    const double *in = bounds + (size_t)(y - range->y0) * stride;
    uint64_t row = r->first_cell + (uint64_t)y * r->width;
    pthread_mutex_t *lock = &b->locks[(range->receiver * 7919u + y) % BUILDER_LOCKS];
    pthread_mutex_lock(lock);
    bbc_result res = BBC_OK;
    for (uint32_t x = range->x0; x <= range->x1 && res == BBC_OK; x++) {
      double e = in[x - range->x0];
      if (isnan(e) || e < 0) res = BBC_ERR_INVALID_ARGUMENT;
      else if (e > 0) res = cell_add(b, &b->cells[row + x], tuple_id, bbc__bound_encode(e));
    }
    pthread_mutex_unlock(lock);
    if (res != BBC_OK) return res;
  }
  return BBC_OK;
}

bbc_result bbc__cache_builder_add_rows(bbc_cache_builder *b, uint32_t id, uint32_t receiver,
                                       uint32_t level, uint32_t y0, uint32_t h,
                                       const uint32_t *spans, const uint16_t *codes, uint32_t part,
                                       uint32_t parts) {
  if (!b || (h && (!spans || !codes)) || id >= b->tuple_count ||
      receiver >= b->grid->receiver_count || level >= b->grid->levels || parts == 0 ||
      part >= parts)
    return BBC_ERR_INVALID_ARGUMENT;
  uint32_t width, height;
  const uint64_t first = bbc_grid_level(b->grid, receiver, level, &width, &height);
  if (h == 0) return BBC_OK;
  if (y0 >= height || h > height - y0) return BBC_ERR_INVALID_ARGUMENT;
  /* Rows whose (y + receiver + level) % parts is `part`: the first is `skip` rows in. */
  uint32_t skip = (part + parts - (uint32_t)(((uint64_t)y0 + receiver + level) % parts)) % parts;
  const uint16_t *in = codes;
  for (uint32_t k = 0; k < h; k++) {
    const uint32_t x0 = spans[2 * k], n = spans[2 * k + 1];
    if (k == skip) {
      skip += parts;
      if (n && (x0 >= width || n > width - x0)) return BBC_ERR_INVALID_ARGUMENT;
      cell_list *row = b->cells + first + (uint64_t)(y0 + k) * width + x0;
      for (uint32_t x = 0; x < n; x++) {
        if (in[x] == 0) continue;
        if (in[x] > BBC__CODE_INF) return BBC_ERR_INVALID_ARGUMENT;
        bbc_result res = cell_add(b, &row[x], id, in[x]);
        if (res != BBC_OK) return res;
      }
    }
    in += n;
  }
  return BBC_OK;
}

bbc_result bbc__cache_builder_add_codes(bbc_cache_builder *b, uint64_t cell, const uint32_t *tuples,
                                        const uint16_t *codes, uint32_t n) {
  if (cell >= b->grid->cell_count) return BBC_ERR_INVALID_ARGUMENT;
  bbc_result r = BBC_OK;
  for (uint32_t i = 0; i < n && r == BBC_OK; i++) {
    if (tuples[i] >= b->tuple_count || codes[i] > BBC__CODE_INF) return BBC_ERR_INVALID_ARGUMENT;
    r = cell_add(b, &b->cells[cell], tuples[i], codes[i]);
  }
  return r;
}

static void compact_all(bbc_cache_builder *b) {
  int64_t n = (int64_t)b->grid->cell_count;
#pragma omp parallel for schedule(dynamic, 4096)
  for (int64_t i = 0; i < n; i++) cell_compact(&b->cells[i]);
}

void bbc__cache_builder_set_entry_memory(bbc_cache_builder *b, size_t bytes) {
  b->entry_budget = bytes ? bytes : BBC__DEFAULT_ENTRY_MEMORY;
}

const char *bbc__cache_builder_error(const bbc_cache_builder *b) {
  return bbc__spill_error(b->spill);
}

void bbc__cache_builder_spill_stats(const bbc_cache_builder *b, uint32_t *runs, uint64_t *bytes) {
  *runs = bbc__spill_run_count(b->spill);
  *bytes = bbc__spill_bytes(b->spill);
}

int bbc__cache_builder_full(const bbc_cache_builder *b) {
  return atomic_load_explicit(&b->entry_bytes, memory_order_relaxed) > b->entry_budget;
}

bbc_result bbc__cache_builder_spill_if_full(bbc_cache_builder *b) {
  if (!bbc__cache_builder_full(b)) return BBC_OK;
  if (!b->spill && bbc__spill_create(&b->spill) != BBC_OK) return BBC_ERR_OUT_OF_MEMORY;
  compact_all(b);
  bbc_result r = BBC_OK;
  for (uint64_t i = 0; i < b->grid->cell_count && r == BBC_OK; i++) {
    cell_list *c = &b->cells[i];
    if (c->count) r = bbc__spill_put(b->spill, i, c->e, c->count);
    free(c->e);
    c->e = NULL;
    c->count = c->cap = 0;
  }
  atomic_store_explicit(&b->entry_bytes, 0, memory_order_relaxed);
  if (r == BBC_OK) r = bbc__spill_end_run(b->spill);
  return r;
}

/* The final lists, cell by cell in increasing order: each cell's list in memory merged
 * with its lists in the spill store's runs (sorted by tuple, maximum code per tuple). */
typedef struct list_walk {
  bbc_cache_builder *b;
  bbc__spill_reader *reader;
  cell_list scratch;
  uint64_t cell; /* the next cell to look at */
} list_walk;

static bbc_result walk_open(list_walk *w, bbc_cache_builder *b) {
  memset(w, 0, sizeof *w);
  w->b = b;
  compact_all(b);
  /* A store that failed refuses to open, so a builder that lost entries never writes. */
  if (b->spill && (bbc__spill_run_count(b->spill) || bbc__spill_error(b->spill)))
    return bbc__spill_reader_open(&w->reader, b->spill);
  return BBC_OK;
}

static void walk_close(list_walk *w) {
  bbc__spill_reader_free(w->reader);
  free(w->scratch.e);
}

/* The next non-empty cell and its list (borrowed until the next call); *cell is
 * UINT64_MAX at the end. */
static bbc_result walk_next(list_walk *w, uint64_t *cell, const cell_entry **e, uint32_t *n) {
  const uint64_t cells = w->b->grid->cell_count;
  uint64_t spilled = w->reader ? bbc__spill_reader_next_cell(w->reader) : UINT64_MAX;
  for (; w->cell < cells; w->cell++) {
    uint64_t i = w->cell;
    const cell_list *c = &w->b->cells[i];
    if (spilled != i) {
      if (c->count == 0) continue;
      w->cell++;
      *cell = i, *e = c->e, *n = c->count;
      return BBC_OK;
    }
    /* Runs hold disjoint, increasing tuple ranges in the precompute's order, so the
     * joined list is usually sorted already; otherwise sort and merge it. */
    cell_list *s = &w->scratch;
    s->count = 0;
    int sources = 0;
    bbc_result r = bbc__spill_reader_take(w->reader, i, &s->e, &s->count, &s->cap, &sources);
    if (r == BBC_OK && c->count) {
      sources++;
      if (s->count + c->count > s->cap) {
        cell_entry *m = realloc(s->e, sizeof *m * ((size_t)s->count + c->count));
        if (!m) return BBC_ERR_OUT_OF_MEMORY;
        s->e = m;
        s->cap = s->count + c->count;
      }
      memcpy(s->e + s->count, c->e, sizeof *c->e * c->count);
      s->count += c->count;
    }
    if (r != BBC_OK) return r;
    if (sources > 1) {
      uint32_t k = 1;
      while (k < s->count && s->e[k - 1].tuple < s->e[k].tuple) k++;
      if (k < s->count) cell_compact(s);
    }
    w->cell++;
    *cell = i, *e = s->e, *n = s->count;
    return BBC_OK;
  }
  *cell = UINT64_MAX, *e = NULL, *n = 0;
  return BBC_OK;
}

uint64_t bbc_cache_builder_entry_count(bbc_cache_builder *b) {
  list_walk w;
  uint64_t total = 0, cell;
  const cell_entry *e;
  uint32_t n;
  if (walk_open(&w, b) == BBC_OK)
    while (walk_next(&w, &cell, &e, &n) == BBC_OK && cell != UINT64_MAX) total += n;
  walk_close(&w);
  return total;
}

/* ------------------------------------------------------------------ encoding */

void bbc__cache_encode_records(const uint32_t *deltas, const uint16_t *codes, size_t n,
                               uint8_t *out) {
  for (size_t i = 0; i < n; i++) {
    bbc__st32(out + 6 * i, deltas[i]);
    bbc__st16(out + 6 * i + 4, codes[i]);
  }
}

size_t bbc__cache_compress_bound(size_t size) {
  return ZSTD_compressBound(size);
}

size_t bbc__cache_compress(void *dst, size_t capacity, const void *src, size_t size, int level) {
  size_t n = ZSTD_compress(dst, capacity, src, size, level);
  return ZSTD_isError(n) ? 0 : n;
}

/* ------------------------------------------------------------------ writing */

/* Where the bytes go: a file (positioned writes) or a growing memory buffer. */
typedef struct sink {
  FILE *file;
  const char *path;
  uint64_t pos;
  uint8_t *mem;
  size_t mem_size, mem_cap;
  bbc_message_fn error_fn;
  void *user;
} sink;

static bbc_result sink_write(sink *s, uint64_t offset, const void *data, size_t size) {
  if (size == 0) return BBC_OK;
  if (s->file) {
    if (offset != s->pos && fseeko(s->file, (off_t)offset, SEEK_SET) != 0)
      return bbc__report(s->error_fn, s->user, BBC_ERR_IO, "%s: cannot seek: %s", s->path,
                         strerror(errno));
    if (fwrite(data, 1, size, s->file) != size)
      return bbc__report(s->error_fn, s->user, BBC_ERR_IO, "%s: cannot write: %s", s->path,
                         strerror(errno));
    s->pos = offset + size;
    return BBC_OK;
  }
  if (offset + size > s->mem_cap) {
    size_t cap = s->mem_cap ? s->mem_cap : 4096;
    while (cap < offset + size) cap *= 2;
    uint8_t *n = realloc(s->mem, cap);
    if (!n) return BBC_ERR_OUT_OF_MEMORY;
    s->mem = n;
    s->mem_cap = cap;
  }
  if (offset > s->mem_size) memset(s->mem + s->mem_size, 0, offset - s->mem_size);
  memcpy(s->mem + offset, data, size);
  if (offset + size > s->mem_size) s->mem_size = offset + size;
  return BBC_OK;
}

static uint32_t crc_of(uint32_t crc, const void *data, size_t size) {
  return (uint32_t)crc32_z(crc, data, size);
}

enum {
  SEC_INFO,
  SEC_PARM,
  SEC_FPRT,
  SEC_RCVR,
  SEC_TRUV,
  SEC_TUPL,
  SEC_CIDX,
  SEC_CDAT,
  SEC_CHNK,
  SEC_GEOM, /* unless omitted */
  SEC_SHRD, /* only in shard caches, last */
  SEC_COUNT
};

typedef struct section {
  uint32_t type, flags;
  uint64_t offset, size;
  uint32_t crc;
} section;

/* Writes one section's bytes and the zero padding up to the next section (R-LAY-1/2). */
static bbc_result write_section(sink *s, section *sec, const void *data) {
  sec->crc = crc_of(crc32_z(0, NULL, 0), data, sec->size);
  return sink_write(s, sec->offset, data, sec->size);
}

static bbc_result write_zeros(sink *s, uint64_t from, uint64_t to) {
  static const uint8_t zeros[256];
  while (from < to) {
    size_t n = to - from < sizeof zeros ? (size_t)(to - from) : sizeof zeros;
    bbc_result r = sink_write(s, from, zeros, n);
    if (r != BBC_OK) return r;
    from += n;
  }
  return BBC_OK;
}

/* CDAT and CHNK (Sec. 7.2-7.3), streamed: the final lists come cell by cell (list_walk)
 * and are cut greedily into chunks by one thread, the producer; each chunk is then
 * compressed by a task while the producer goes on, and the task that completes the
 * oldest chunks appends them to CDAT in chunk order, so the bytes do not depend on the
 * number of threads. Memory: a ring of decoded and compressed chunks, whatever the
 * number of entries. */
typedef struct chunk_slot {
  uint8_t *raw, *out; /* decoded records (Sec. 7.2), the zstd frame */
  size_t raw_cap, out_cap, out_size;
  uint32_t entries;
  uint32_t crc; /* of the zstd frame */
  int done;     /* compressed, waiting to be written */
} chunk_slot;

typedef struct chunk_stream {
  sink *s;
  uint64_t offset, size; /* CDAT's start in the file, bytes written */
  uint32_t crc;
  uint8_t *chnk; /* CHNK records of the chunks written */
  uint32_t chunks, cap, started;
  chunk_slot *slots;
  /* The ring: slots[head] is the chunk being filled when open; `queued` chunks from
   * slots[tail] on are being compressed or wait to be written. */
  int slot_count, head, tail, queued, open;
  ZSTD_CCtx **cctx;
  int threads, level;
  omp_lock_t lock;   /* tail, queued, the slots' done, and everything written */
  int locked;        /* the lock is initialised */
  bbc_result result; /* of the tasks */
} chunk_stream;

static int grow(uint8_t **p, size_t *cap, size_t need) {
  if (need <= *cap) return 1;
  size_t c = *cap ? *cap : 4096;
  while (c < need) c *= 2;
  uint8_t *n = realloc(*p, c);
  if (!n) return 0;
  *p = n;
  *cap = c;
  return 1;
}

static bbc_result stream_init(chunk_stream *cs, sink *s, uint64_t offset, int level) {
  memset(cs, 0, sizeof *cs);
  cs->s = s;
  cs->offset = offset;
  cs->crc = (uint32_t)crc32_z(0, NULL, 0);
  cs->level = level;
  cs->threads = omp_get_max_threads();
  cs->slot_count = 8 * cs->threads < 16 ? 16 : 8 * cs->threads > 64 ? 64 : 8 * cs->threads;
  cs->slots = calloc((size_t)cs->slot_count, sizeof *cs->slots);
  cs->cctx = calloc((size_t)cs->threads, sizeof *cs->cctx);
  omp_init_lock(&cs->lock);
  cs->locked = 1;
  return cs->slots && cs->cctx ? BBC_OK : BBC_ERR_OUT_OF_MEMORY;
}

static void stream_free(chunk_stream *cs) {
  for (int i = 0; cs->slots && i < cs->slot_count; i++) {
    free(cs->slots[i].raw);
    free(cs->slots[i].out);
  }
  for (int i = 0; cs->cctx && i < cs->threads; i++) ZSTD_freeCCtx(cs->cctx[i]);
  free(cs->slots);
  free(cs->cctx);
  free(cs->chnk);
  if (cs->locked) omp_destroy_lock(&cs->lock);
}

/* Appends the compressed chunks at the ring's tail to CDAT, in order; under the lock. */
static void stream_write_done(chunk_stream *cs) {
  while (cs->queued > 0 && cs->slots[cs->tail].done) {
    chunk_slot *k = &cs->slots[cs->tail];
    k->done = 0;
    cs->tail = (cs->tail + 1) % cs->slot_count;
    cs->queued--;
    if (cs->result != BBC_OK) continue;
    if (cs->chunks == cs->cap) {
      uint32_t cap = cs->cap ? 2 * cs->cap : 64;
      uint8_t *c = realloc(cs->chnk, (size_t)cap * BBC__CHNK_SIZE);
      if (!c) {
        cs->result = BBC_ERR_OUT_OF_MEMORY;
        continue;
      }
      cs->chnk = c;
      cs->cap = cap;
    }
    uint8_t *rec = cs->chnk + BBC__CHNK_SIZE * (size_t)cs->chunks++;
    memset(rec, 0, BBC__CHNK_SIZE);
    bbc__st64(rec, cs->size);
    bbc__st32(rec + 8, (uint32_t)k->out_size);
    bbc__st32(rec + 12, k->entries);
    bbc__st32(rec + 16, k->crc);
    /* CDAT's CRC from the chunk's, without reading the chunk again. */
    cs->crc = (uint32_t)crc32_combine(cs->crc, k->crc, (z_off_t)k->out_size);
    cs->result = sink_write(cs->s, cs->offset + cs->size, k->out, k->out_size);
    cs->size += k->out_size;
  }
}

/* A task: compresses one chunk, then writes what is ready in order. */
static void stream_compress(chunk_stream *cs, chunk_slot *k) {
  ZSTD_CCtx **ctx = &cs->cctx[omp_get_thread_num()];
  size_t size = 0;
  const size_t raw = (size_t)k->entries * BBC__ENTRY_BYTES;
  int ok = grow(&k->out, &k->out_cap, ZSTD_compressBound(raw));
  if (ok && !*ctx) *ctx = ZSTD_createCCtx();
  if (ok && *ctx) size = ZSTD_compressCCtx(*ctx, k->out, k->out_cap, k->raw, raw, cs->level);
  k->out_size = ok && *ctx && !ZSTD_isError(size) ? size : 0;
  k->crc = crc_of(crc32_z(0, NULL, 0), k->out, k->out_size);
  omp_set_lock(&cs->lock);
  if (k->out_size == 0 && cs->result == BBC_OK) cs->result = BBC_ERR_OUT_OF_MEMORY;
  k->done = 1;
  stream_write_done(cs);
  omp_unset_lock(&cs->lock);
}

/* Waits for every chunk queued (running queued tasks meanwhile): they are written. */
static bbc_result stream_drain(chunk_stream *cs) {
#pragma omp taskwait
  omp_set_lock(&cs->lock);
  bbc_result r = cs->result;
  omp_unset_lock(&cs->lock);
  return r;
}

static bbc_result stream_close_chunk(chunk_stream *cs) {
  if (!cs->open) return BBC_OK;
  cs->open = 0;
  chunk_slot *k = &cs->slots[cs->head];
  cs->head = (cs->head + 1) % cs->slot_count;
  omp_set_lock(&cs->lock);
  cs->queued++;
  bbc_result r = cs->result;
  omp_unset_lock(&cs->lock);
#pragma omp task firstprivate(k, cs)
  stream_compress(cs, k);
  return r;
}

/* Sec. 7.3: a list goes into the current chunk unless that chunk is not empty and would
 * exceed the target; its CIDX record (Sec. 5.6) goes to `rec`. */
static bbc_result stream_list(chunk_stream *cs, uint32_t target, const cell_entry *e, uint32_t n,
                              uint8_t *rec) {
  if (n > BBC__MAX_CHUNK_ENTRIES) return BBC_ERR_UNSUPPORTED;
  bbc_result r = BBC_OK;
  if (cs->open && (uint64_t)cs->slots[cs->head].entries + n > target)
    r = stream_close_chunk(cs);
  if (r != BBC_OK) return r;
  if (!cs->open) {
    /* A free slot: when every slot is queued, wait until they are written. */
    omp_set_lock(&cs->lock);
    int full = cs->queued == cs->slot_count;
    omp_unset_lock(&cs->lock);
    if (full && (r = stream_drain(cs)) != BBC_OK) return r;
  }
  chunk_slot *k = &cs->slots[cs->head];
  if (!cs->open) {
    if (cs->started == UINT32_MAX) return BBC_ERR_UNSUPPORTED;
    cs->started++;
    cs->open = 1;
    k->entries = 0;
  }
  if (!grow(&k->raw, &k->raw_cap, ((size_t)k->entries + n) * BBC__ENTRY_BYTES))
    return BBC_ERR_OUT_OF_MEMORY;
  bbc__st32(rec, cs->started - 1);
  bbc__st32(rec + 4, k->entries);
  bbc__st32(rec + 8, n);
  /* Sec. 7.2: ids delta-coded within the list, then the code. */
  uint8_t *out = k->raw + (size_t)k->entries * BBC__ENTRY_BYTES;
  for (uint32_t i = 0; i < n; i++, out += BBC__ENTRY_BYTES) {
    bbc__st32(out, i == 0 ? e[0].tuple : e[i].tuple - e[i - 1].tuple - 1);
    bbc__st16(out + 4, (uint16_t)e[i].code);
  }
  k->entries += n;
  return BBC_OK;
}

static bbc_result write_cache(bbc_cache_builder *b, sink *s, const bbc_cache_write_options *o) {
  bbc_cache_write_options defaults;
  memset(&defaults, 0, sizeof defaults);
  if (!o) o = &defaults;
  int level = o->compression_level ? o->compression_level : BBC__DEFAULT_LEVEL;
  if (level < 1 || level > 19)
    return bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT,
                       "%s: compression level %d outside [1, 19]", s->path, level);
  uint32_t chunk_bytes = o->chunk_bytes ? o->chunk_bytes : BBC__DEFAULT_CHUNK_BYTES;
  uint32_t target = chunk_bytes / BBC__ENTRY_BYTES;
  if (target < 1) target = 1;
  if (target > BBC__MAX_CHUNK_ENTRIES) target = BBC__MAX_CHUNK_ENTRIES;

  if (b->shard_count && !shard_candidates_valid(b))
    return bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT,
                       "%s: shard %u/%u: tuple candidate indices missing or not increasing "
                       "(R-SHR-3)",
                       s->path, b->shard_index, b->shard_count);
  const bbc_grid *g = b->grid;
  const char *writer = bbc_version_string();
  char info[64];
  snprintf(info, sizeof info, "bbc %s", writer);

  const char *info_text = info;
  size_t info_size = strlen(info);
  if (b->info_set) {
    info_text = b->info_text;
    info_size = b->info_size;
  }

  section sec[SEC_COUNT];
  static const uint32_t types[SEC_COUNT] = {
      BBC__SEC_INFO, BBC__SEC_PARM, BBC__SEC_FPRT, BBC__SEC_RCVR, BBC__SEC_TRUV,
      BBC__SEC_TUPL, BBC__SEC_CIDX, BBC__SEC_CDAT, BBC__SEC_CHNK, BBC__SEC_GEOM,
      BBC__SEC_SHRD};
  /* The sections written are INFO (optional), PARM ... CHNK, GEOM (optional) and SHRD
   * (shards only), in this order; without INFO, GEOM and SHRD a cache is laid out exactly
   * as by a 1.0 writer. */
  uint32_t first = o->omit_info || !info_text ? 1 : 0;
  int geom = !o->omit_geometry && b->geometry;
  uint32_t last = b->shard_count ? SEC_SHRD : geom ? SEC_GEOM : SEC_CHNK;
  uint32_t nsec = last + 1 - first - (uint32_t)(last == SEC_SHRD && !geom);
  memset(sec, 0, sizeof sec);
  for (int i = 0; i < SEC_COUNT; i++) {
    sec[i].type = types[i];
    sec[i].flags = i == SEC_INFO || i == SEC_GEOM || i == SEC_SHRD ? 0 : BBC__SECTION_REQUIRED;
  }
  sec[SEC_INFO].size = info_size;
  sec[SEC_PARM].size = BBC__PARM_SIZE;
  sec[SEC_FPRT].size = BBC__FPRT_SIZE;
  sec[SEC_RCVR].size = (uint64_t)BBC__RCVR_SIZE * g->receiver_count;
  sec[SEC_TRUV].size = (uint64_t)BBC__TRUV_SIZE * g->uv_triangle_count;
  sec[SEC_TUPL].size = (uint64_t)BBC__TUPL_SIZE * b->tuple_count;
  sec[SEC_CIDX].size = (uint64_t)BBC__CIDX_SIZE * g->cell_count;
  /* R-LAY-1: offsets up to CDAT are known now; CDAT's size only after compression. */
  uint64_t end = BBC__HEADER_SIZE + (uint64_t)BBC__DIR_ENTRY_SIZE * nsec;
  for (uint32_t i = first; i <= SEC_CDAT; i++) {
    sec[i].offset = bbc__align64(end + BBC__MIN_PADDING);
    end = sec[i].offset + sec[i].size;
  }

  uint8_t parm[BBC__PARM_SIZE], fprt[BBC__FPRT_SIZE];
  bbc__params_encode(&b->params, parm);
  memset(fprt, 0, sizeof fprt);
  bbc__st64(fprt, b->fingerprint.total);
  bbc__st64(fprt + 8, b->fingerprint.geometry);
  bbc__st64(fprt + 16, b->fingerprint.materials);
  bbc__st64(fprt + 24, b->fingerprint.meshes);
  bbc__st64(fprt + 32, b->fingerprint.lights);
  bbc__st64(fprt + 40, b->fingerprint.params);
  for (int k = 0; k < 6; k++) bbc__st32(fprt + 48 + 4 * k, b->scene_counts[k]);

  uint8_t *rcvr = calloc(g->receiver_count, BBC__RCVR_SIZE);
  uint8_t *cidx = calloc(g->cell_count ? g->cell_count : 1, BBC__CIDX_SIZE);
  if (!rcvr || !cidx) {
    free(rcvr);
    free(cidx);
    return bbc__report(o->error_fn, o->user, BBC_ERR_OUT_OF_MEMORY, "%s: out of memory", s->path);
  }
  for (uint32_t i = 0; i < g->receiver_count; i++) {
    const bbc_receiver *rc = &g->receivers[i];
    uint8_t *p = rcvr + BBC__RCVR_SIZE * i;
    bbc__st32(p, rc->mesh);
    bbc__st32(p + 4, rc->parameterisation);
    bbc__st32(p + 8, rc->first_triangle);
    bbc__st32(p + 12, rc->triangle_count);
    bbc__st32(p + 16, rc->width);
    bbc__st32(p + 20, rc->height);
    bbc__st64(p + 24, rc->first_cell);
    bbc__st64(p + 32, rc->first_uv);
    for (int k = 0; k < 4; k++) bbc__stf64(p + 40 + 8 * k, rc->domain[k]);
    for (int k = 0; k < 3; k++) bbc__stf64(p + 72 + 8 * k, rc->axis_u[k]);
    for (int k = 0; k < 3; k++) bbc__stf64(p + 96 + 8 * k, rc->axis_v[k]);
  }

  bbc_result r = BBC_OK;
  if (first == SEC_INFO) r = write_section(s, &sec[SEC_INFO], info_text);
  if (r == BBC_OK) r = write_section(s, &sec[SEC_PARM], parm);
  if (r == BBC_OK) r = write_section(s, &sec[SEC_FPRT], fprt);
  if (r == BBC_OK) r = write_section(s, &sec[SEC_RCVR], rcvr);
  if (r == BBC_OK) r = write_section(s, &sec[SEC_TRUV], g->triangle_uv);
  if (r == BBC_OK) r = write_section(s, &sec[SEC_TUPL], b->tuples);
  free(rcvr);

  /* CDAT from the final lists, then CIDX before it in the file (positioned writes). */
  chunk_stream cs;
  list_walk w;
  int walking = 0;
  memset(&cs, 0, sizeof cs);
  if (r == BBC_OK && (r = stream_init(&cs, s, sec[SEC_CDAT].offset, level)) == BBC_OK &&
      (r = walk_open(&w, b)) == BBC_OK)
    walking = 1;
  uint64_t cell = 0, reported = 0;
  if (walking) {
    /* This thread walks the lists and cuts the chunks; the others, waiting at the end
     * of the region, compress them (stream_close_chunk's tasks). */
#pragma omp parallel num_threads(cs.threads)
#pragma omp master
    {
      while (r == BBC_OK) {
        const cell_entry *e;
        uint32_t n;
        if ((r = walk_next(&w, &cell, &e, &n)) != BBC_OK || cell == UINT64_MAX) break;
        r = stream_list(&cs, target, e, n, cidx + BBC__CIDX_SIZE * cell);
        /* Progress and cancellation about every million cells. */
        if (r == BBC_OK && o->progress_fn && cell - reported >= (1u << 20)) {
          reported = cell;
          if (o->progress_fn(o->progress_user, cell, g->cell_count) != 0) r = BBC_ERR_CANCELLED;
        }
      }
      if (r == BBC_OK) r = stream_close_chunk(&cs);
      /* Every task ends before the slots they use are freed. */
      bbc_result d = stream_drain(&cs);
      if (r == BBC_OK) r = d;
    }
    walk_close(&w);
  }
  if (r == BBC_OK && o->progress_fn && o->progress_fn(o->progress_user, g->cell_count, g->cell_count))
    r = BBC_ERR_CANCELLED;
  if (r == BBC_OK) r = write_section(s, &sec[SEC_CIDX], cidx);
  free(cidx);
  if (r == BBC_OK) {
    sec[SEC_CDAT].size = cs.size;
    sec[SEC_CDAT].crc = cs.crc;
    sec[SEC_CHNK].size = (uint64_t)BBC__CHNK_SIZE * cs.chunks;
    sec[SEC_CHNK].offset = bbc__align64(sec[SEC_CDAT].offset + cs.size + BBC__MIN_PADDING);
    r = write_section(s, &sec[SEC_CHNK], cs.chnk ? cs.chnk : (const uint8_t *)"");
  }
  stream_free(&cs);
  if (r != BBC_OK && r != BBC_ERR_IO) {
    const char *why = r == BBC_ERR_UNSUPPORTED ? "a cell list exceeds 2^24 entries"
                      : r == BBC_ERR_CANCELLED ? "cancelled"
                                               : bbc__cache_builder_error(b);
    return bbc__report(o->error_fn, o->user, r, "%s: %s", s->path, why ? why : "out of memory");
  }
  if (r == BBC_ERR_IO && bbc__cache_builder_error(b))
    return bbc__report(o->error_fn, o->user, r, "%s: %s", s->path, bbc__cache_builder_error(b));
  uint32_t prev = SEC_CHNK; /* the last section written so far */
  if (r == BBC_OK && geom) {
    sec[SEC_GEOM].size = b->geometry_size;
    sec[SEC_GEOM].offset =
        bbc__align64(sec[SEC_CHNK].offset + sec[SEC_CHNK].size + BBC__MIN_PADDING);
    r = write_section(s, &sec[SEC_GEOM], b->geometry);
    prev = SEC_GEOM;
  }
  if (r == BBC_OK && last == SEC_SHRD) {
    /* SHRD (Sec. 5.10): which shard, the candidate list, each tuple's candidate. */
    sec[SEC_SHRD].size = BBC__SHRD_HEAD_SIZE + (uint64_t)BBC__SHRD_ENTRY_SIZE * b->tuple_count;
    sec[SEC_SHRD].offset = bbc__align64(sec[prev].offset + sec[prev].size + BBC__MIN_PADDING);
    uint8_t *shrd = calloc(1, (size_t)sec[SEC_SHRD].size);
    if (!shrd)
      return bbc__report(o->error_fn, o->user, BBC_ERR_OUT_OF_MEMORY, "%s: out of memory", s->path);
    bbc__st32(shrd, b->shard_index);
    bbc__st32(shrd + 4, b->shard_count);
    bbc__st64(shrd + 8, b->candidate_count);
    bbc__st64(shrd + 16, b->candidates_hash);
    for (uint32_t i = 0; i < b->tuple_count; i++)
      bbc__st64(shrd + BBC__SHRD_HEAD_SIZE + BBC__SHRD_ENTRY_SIZE * (size_t)i, b->candidate[i]);
    r = write_section(s, &sec[SEC_SHRD], shrd);
    free(shrd);
  }
  if (r != BBC_OK) return r;

  /* Padding (R-LAY-2), then the directory and the header, which need every size and
   * checksum. */
  uint64_t file_size = bbc__align64(sec[last].offset + sec[last].size + BBC__MIN_PADDING);
  uint64_t prev_end = BBC__HEADER_SIZE + (uint64_t)BBC__DIR_ENTRY_SIZE * nsec;
  for (uint32_t i = first; i <= last && r == BBC_OK; i++) {
    if (i == SEC_GEOM && !geom) continue;
    r = write_zeros(s, prev_end, sec[i].offset);
    prev_end = sec[i].offset + sec[i].size;
  }
  if (r == BBC_OK) r = write_zeros(s, prev_end, file_size);

  uint8_t dir[BBC__DIR_ENTRY_SIZE * SEC_COUNT];
  memset(dir, 0, sizeof dir);
  for (uint32_t i = first, j = 0; i <= last; i++) {
    if (i == SEC_GEOM && !geom) continue;
    uint8_t *e = dir + BBC__DIR_ENTRY_SIZE * j++;
    bbc__st32(e, sec[i].type);
    bbc__st32(e + 4, sec[i].flags);
    bbc__st64(e + 8, sec[i].offset);
    bbc__st64(e + 16, sec[i].size);
    bbc__st32(e + 24, sec[i].crc);
  }
  uint8_t header[BBC__HEADER_SIZE];
  memset(header, 0, sizeof header);
  memcpy(header, BBC__MAGIC, 8);
  bbc__st16(header + 8, BBC_FORMAT_VERSION_MAJOR);
  /* The smallest minor version whose features the file uses (R-HDR-3). */
  int planes = 0;
  for (uint32_t i = 0; i < b->grid->receiver_count; i++)
    planes |= b->grid->receivers[i].parameterisation == BBC_PARAM_PLANE;
  bbc__st16(header + 10, bbc__params_stored_level_double(&b->params) ? BBC__MINOR_DOUBLE_LEVEL
                         : b->params.cell_levels    ? BBC__MINOR_LEVELS
                         : b->params.beam_receivers ? BBC__MINOR_BEAM
                         : planes                   ? BBC__MINOR_PLANE
                         : b->params.area_lights && b->params.alpha_area != 0
                             ? BBC__MINOR_AREA_ALPHA
                         : b->params.area_double ? BBC__MINOR_AREA_DOUBLE
                         : geom                  ? BBC__MINOR_GEOMETRY
                         : b->params.area_lights ? BBC__MINOR_AREA
                         : b->shard_count        ? BBC__MINOR_SHARD
                                                 : BBC__MINOR_COMPLETE);
  bbc__st32(header + 12, nsec);
  bbc__st64(header + 16, file_size);
  bbc__st32(header + 28, crc_of(crc32_z(0, NULL, 0), dir, BBC__DIR_ENTRY_SIZE * nsec));
  bbc__st32(header + 60, crc_of(crc32_z(0, NULL, 0), header, 60));
  if (r == BBC_OK) r = sink_write(s, BBC__HEADER_SIZE, dir, BBC__DIR_ENTRY_SIZE * nsec);
  if (r == BBC_OK) r = sink_write(s, 0, header, sizeof header);
  return r;
}

bbc_result bbc__cache_builder_write_file(bbc_cache_builder *b, const char *file_path,
                                         const char *path, const bbc_cache_write_options *o) {
  bbc_message_fn fn = o ? o->error_fn : NULL;
  void *user = o ? o->user : NULL;
  sink s;
  memset(&s, 0, sizeof s);
  s.path = path;
  s.error_fn = fn;
  s.user = user;
  s.file = fopen(file_path, "wb");
  if (!s.file)
    return bbc__report(fn, user, BBC_ERR_IO, "%s: cannot create %s: %s", path, file_path,
                       strerror(errno));
  bbc_result r = write_cache(b, &s, o);
  if (fclose(s.file) != 0 && r == BBC_OK)
    r = bbc__report(fn, user, BBC_ERR_IO, "%s: cannot write: %s", path, strerror(errno));
  return r;
}

bbc_result bbc_cache_builder_write_memory(bbc_cache_builder *b, void **bytes, size_t *size,
                                          const bbc_cache_write_options *options) {
  if (bytes) *bytes = NULL;
  if (size) *size = 0;
  if (!b || !bytes || !size) return BBC_ERR_INVALID_ARGUMENT;
  sink s;
  memset(&s, 0, sizeof s);
  s.path = "(memory)";
  s.error_fn = options ? options->error_fn : NULL;
  s.user = options ? options->user : NULL;
  bbc_result r = write_cache(b, &s, options);
  if (r != BBC_OK) {
    free(s.mem);
    return r;
  }
  *bytes = s.mem;
  *size = s.mem_size;
  return BBC_OK;
}
