/* The precompute driver: candidate tuples (tuples.c), bounded in parallel batches; each
 * tuple's cells and bounds are read off the raster its subdivision keeps (coverage) by
 * the thread that bounded it, and the batch's cells are recorded in tuple order, so
 * tuple ids and the written cache do not depend on the number of threads. Only tuples
 * with a kept piece are stored. Memory stays bounded by one batch of pieces and cells
 * and the builder's entry budget: between batches, the builder spills its cell lists to
 * a temporary file when they exceed it. */
#define _POSIX_C_SOURCE 200809L
#include "bbc/precompute.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <omp.h>

#include "beam_cells_internal.h"
#include "candidates_internal.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "light_internal.h"
#include "report_internal.h"
#include "rng_internal.h"
#include "spill_internal.h"

#define BATCH_TUPLES 256
/* The most candidates bounded for the estimate before the others (at most a batch). */
#define SAMPLE_MAX 256
#define SAMPLE_MIN 16

static double thread_cpu_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct piece_list {
  bbc_piece *items;
  size_t count, capacity;
  int failed;
} piece_list;

/* A per-thread raster of one tuple's bounds over the cells of its receiver triangle,
 * kept up to date while the tuple is bounded, so that the subdivision can stop where a
 * piece changes nothing recorded (bbc_piece_need_fn). Cells hold the largest E_hi per
 * unit intensity of the kept pieces reaching them, 0 where none does; only the touched
 * rectangle is cleared after the tuple. */
typedef struct coverage {
  double *cells;
  size_t capacity;
  uint32_t receiver;     /* the receiver (grid) the triangle is in */
  uint32_t x0, y0, w, h; /* the receiver triangle's cell rectangle */
  uint32_t tx0, ty0, tx1, ty1;
  int touched;
  /* A piece's columns per row (bbc_grid_splat_polygon), for each of the two regions
   * remembered (tuple_sink). */
  uint32_t *row_x0[2], *row_x1[2];
  size_t rows[2];
} coverage;

/* A piece's position bound as bbc_grid_splat_polygon takes it. */
typedef struct footprint {
  double region[8];
  double cut[2][4];
} footprint;

static void piece_footprint(const bbc_piece *p, footprint *f) {
  double *region = f->region;
  region[0] = p->uk_lo, region[1] = p->uk_hi, region[2] = p->vk_lo, region[3] = p->vk_hi;
  region[4] = p->sk_lo, region[5] = p->sk_hi, region[6] = p->dk_lo, region[7] = p->dk_hi;
  memcpy(f->cut, p->cut, sizeof f->cut);
}

static int splat_footprint(const bbc_grid *grid, uint32_t receiver, const footprint *f,
                           bbc_cell_range *r, uint32_t *x0, uint32_t *x1) {
  return bbc_grid_splat_polygon(grid, receiver, f->region, (const double(*)[4])f->cut, r, x0, x1);
}

/* Room for a row per cell row of the grid's tallest receiver. */
static bbc_result rows_reserve(const bbc_grid *grid, uint32_t **x0, uint32_t **x1, size_t *rows) {
  uint32_t height = 1;
  for (uint32_t i = 0; i < grid->receiver_count; i++)
    if (grid->receivers[i].height > height) height = grid->receivers[i].height;
  if (*rows >= height) return BBC_OK;
  free(*x0);
  free(*x1);
  *x0 = malloc(height * sizeof **x0);
  *x1 = malloc(height * sizeof **x1);
  *rows = *x0 && *x1 ? height : 0;
  return *rows ? BBC_OK : BBC_ERR_OUT_OF_MEMORY;
}

/* A region splatted and its result (coverage_range). */
typedef struct splat_memo {
  int valid, hit, escaped;
  footprint footprint;
  bbc_cell_range range;
} splat_memo;

typedef struct tuple_sink {
  piece_list *pieces;
  coverage *cover;
  const bbc_grid *grid;
  uint32_t receiver;
  /* The last two regions splatted (coverage_range), the older one replaced first: a
   * piece is judged on its parent's region, then after its position bound, again after
   * its irradiance bound and then kept on its own, and its three siblings come next,
   * judged on the same parent's region first. */
  splat_memo memo[2];
  int newest;
  /* A piece was stored whose cells the raster does not hold (its polygon reaches cells
   * outside the raster, or its E_hi is not positive): the tuple's cells are then
   * splatted again from its pieces (tuple_cells_from_pieces). */
  int escaped;
  /* The precompute's cancel_fn and its user (NULL: none); cancelled once it said stop. */
  int (*cancel_fn)(void *user);
  void *cancel_user;
  int cancelled;
} tuple_sink;

static bbc_result coverage_begin(coverage *c, const bbc_grid *grid, uint32_t receiver) {
  bbc_cell_range t;
  c->touched = 0;
  c->w = c->h = 0;
  for (int i = 0; i < 2; i++) {
    bbc_result res = rows_reserve(grid, &c->row_x0[i], &c->row_x1[i], &c->rows[i]);
    if (res != BBC_OK) return res;
  }
  if (!bbc_grid_splat_range(grid, receiver, 0, 1, 0, 1, &t)) return BBC_OK;
  size_t w = (size_t)t.x1 - t.x0 + 1, h = (size_t)t.y1 - t.y0 + 1;
  if (w * h > c->capacity) {
    free(c->cells);
    c->cells = calloc(w * h, sizeof *c->cells);
    c->capacity = c->cells ? w * h : 0;
    if (!c->cells) return BBC_ERR_OUT_OF_MEMORY;
  }
  c->receiver = t.receiver;
  c->x0 = t.x0, c->y0 = t.y0, c->w = (uint32_t)w, c->h = (uint32_t)h;
  return BBC_OK;
}

static void coverage_end(coverage *c) {
  if (!c->touched) return;
  for (uint32_t y = c->ty0; y <= c->ty1; y++)
    memset(c->cells + (size_t)(y - c->y0) * c->w + (c->tx0 - c->x0), 0,
           ((size_t)c->tx1 - c->tx0 + 1) * sizeof *c->cells);
  c->touched = 0;
}

/* The piece's cells (rows r->y0..r->y1, columns in (*x0)[y - r->y0] ..
 * (*x1)[y - r->y0], arrays valid until the second-next call); 0 when it reaches none.
 * Splats of the triangle's points stay in its rectangle, the raster's; *escaped is set
 * when the piece reaches cells but the raster does not hold them all (not expected). */
static int coverage_range(tuple_sink *s, const bbc_piece *p, bbc_cell_range *r,
                          const uint32_t **x0, const uint32_t **x1, int *escaped) {
  const coverage *c = s->cover;
  footprint f;
  piece_footprint(p, &f);
  for (int k = 0; k < 2; k++) {
    const int i = (s->newest + k) & 1;
    splat_memo *m = &s->memo[i];
    if (m->valid && memcmp(&f, &m->footprint, sizeof f) == 0) {
      *r = m->range;
      *x0 = c->row_x0[i], *x1 = c->row_x1[i];
      s->newest = i;
      *escaped = m->escaped;
      return m->hit;
    }
  }
  const int i = s->newest ^ 1; /* the older one */
  splat_memo *m = &s->memo[i];
  const int reaches =
      c->w != 0 && splat_footprint(s->grid, s->receiver, &f, r, c->row_x0[i], c->row_x1[i]);
  int hit =
      reaches && r->x0 >= c->x0 && r->y0 >= c->y0 && r->x1 < c->x0 + c->w && r->y1 < c->y0 + c->h;
  /* The row arrays hold this region's columns until they are reused. */
  m->valid = c->w != 0;
  m->hit = hit;
  m->escaped = *escaped = c->w == 0 || (reaches && !hit);
  m->footprint = f;
  if (hit) m->range = *r;
  s->newest = i;
  *x0 = c->row_x0[i], *x1 = c->row_x1[i];
  return hit;
}

static bbc_piece_need piece_need(void *user, const bbc_piece *piece) {
  tuple_sink *s = user;
  const coverage *c = s->cover;
  bbc_cell_range r;
  const uint32_t *rx0, *rx1;
  int escaped;
  if (!coverage_range(s, piece, &r, &rx0, &rx1, &escaped))
    return BBC_NEED_NONE; /* it reaches no cell */
  int dominated = 1, cells = 0;
  for (uint32_t y = r.y0; y <= r.y1 && dominated; y++) {
    const double *row = c->cells + (size_t)(y - c->y0) * c->w - c->x0;
    const uint32_t x0 = rx0[y - r.y0], x1 = rx1[y - r.y0];
    cells += x0 <= x1 ? (int)(x1 - x0 + 1) : 0;
    for (uint32_t x = x0; x <= x1; x++)
      if (!(row[x] > 0 && row[x] >= piece->e_hi)) {
        dominated = 0;
        break;
      }
  }
  if (dominated) return BBC_NEED_NONE;
  return cells == 1 ? BBC_NEED_KEEP : BBC_NEED_SPLIT;
}

static int keep_piece(void *user, const bbc_piece *piece) {
  tuple_sink *s = user;
  piece_list *l = s->pieces;
  if (s->cancel_fn && s->cancel_fn(s->cancel_user)) return s->cancelled = 1;
  if (piece->status != BBC_PIECE_KEPT) return 0;
  coverage *c = s->cover;
  bbc_cell_range r;
  const uint32_t *rx0, *rx1;
  int escaped = 0;
  if (coverage_range(s, piece, &r, &rx0, &rx1, &escaped)) {
    /* A piece that raises no cell (each already holds a positive bound at least its
     * E_hi, from pieces kept before it) changes nothing the tuple's cells hold, the
     * maximum per cell: it is not stored. The first piece kept always raises a cell, so
     * the tuple is stored exactly when some piece is kept. */
    int raises = 0;
    for (uint32_t y = r.y0; y <= r.y1; y++) {
      double *row = c->cells + (size_t)(y - c->y0) * c->w - c->x0;
      for (uint32_t x = rx0[y - r.y0]; x <= rx1[y - r.y0]; x++)
        if (!(row[x] > 0 && row[x] >= piece->e_hi)) {
          raises = 1;
          if (!(row[x] >= piece->e_hi)) row[x] = piece->e_hi;
        }
    }
    if (!raises) return 0;
    if (!(piece->e_hi > 0)) s->escaped = 1; /* the raster does not tell it from none */
    if (!c->touched) {
      c->tx0 = r.x0, c->ty0 = r.y0, c->tx1 = r.x1, c->ty1 = r.y1;
      c->touched = 1;
    } else {
      if (r.x0 < c->tx0) c->tx0 = r.x0;
      if (r.y0 < c->ty0) c->ty0 = r.y0;
      if (r.x1 > c->tx1) c->tx1 = r.x1;
      if (r.y1 > c->ty1) c->ty1 = r.y1;
    }
  }
  if (escaped) s->escaped = 1;
  if (l->count == l->capacity) {
    size_t capacity = l->capacity ? 2 * l->capacity : 16;
    bbc_piece *items = realloc(l->items, capacity * sizeof *items);
    if (!items) {
      l->failed = 1;
      return 1;
    }
    l->items = items;
    l->capacity = capacity;
  }
  l->items[l->count++] = *piece;
  return 0;
}

/* A beam tuple's kept pieces and their cell bounds (cell_bound of E_hi). */
typedef struct beam_list {
  bbc_beam_piece *items;
  double *bound;
  size_t count, capacity;
  int failed;
} beam_list;

/* A per-thread raster of one tuple's bounds over the cells its pieces cover. */
typedef struct raster {
  double *cells;
  size_t capacity;
  uint32_t *row_x0, *row_x1;
  size_t rows;
} raster;

/* A rectangle of a tuple's cells in one receiver: h rows from row y0, its codes and
 * spans from these indices of its arena on. */
typedef struct cell_segment {
  uint32_t receiver, level, y0, h;
  size_t codes, spans;
} cell_segment;

/* The cells of a batch's tuples as the builder takes them (bbc__cache_builder_add_rows),
 * per bounding thread: for each row of a tuple's cell rectangle, the span from its first
 * to its last cell with an entry, and the codes of the span, 0 for no entry. Emptied
 * before each batch, so it holds one batch, about its entries. A tuple's cells are one
 * segment (a rectangle of its receiver), or for a beam tuple one per receiver reached. */
typedef struct cell_arena {
  uint16_t *codes;
  uint32_t *spans; /* per row: first column, count */
  cell_segment *segments;
  size_t codes_used, codes_cap, spans_used, spans_cap, segments_used, segments_cap;
} cell_arena;

static void arena_clear(cell_arena *a) {
  a->codes_used = a->spans_used = a->segments_used = 0;
}

/* One tuple's cells: `segments` segments from index `segment` on in arena `arena`
 * (consecutive: one thread appends them); none when it has no cells. */
typedef struct tuple_cells {
  int stored; /* the tuple has a stored piece (it is stored even with no cells) */
  int arena;
  size_t segment;
  uint32_t segments;
  uint64_t entries; /* codes not 0 */
} tuple_cells;

static int arena_reserve(void **p, size_t *cap, size_t need, size_t size) {
  if (need <= *cap) return 1;
  size_t c = *cap ? *cap : 4096;
  while (c < need) c *= 2;
  void *q = realloc(*p, c * size);
  if (!q) return 0;
  *p = q;
  *cap = c;
  return 1;
}

/* Appends a tuple's cells from a rectangle of bounds per cell (w x h from cell x0, y0 of
 * the receiver, rows `stride` apart): a cell has an entry where its value is positive,
 * with the code of the value itself, or with that of cell_bound(value, power) when
 * `scaled`. */
static double cell_bound(double e_hi, double power);
static bbc_result arena_add(cell_arena *a, int arena, tuple_cells *out, uint32_t receiver,
                            uint32_t level, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h,
                            const double *cells, size_t stride, int scaled, double power) {
  if (!arena_reserve((void **)&a->codes, &a->codes_cap, a->codes_used + (size_t)w * h,
                     sizeof *a->codes) ||
      !arena_reserve((void **)&a->spans, &a->spans_cap, a->spans_used + 2 * (size_t)h,
                     sizeof *a->spans) ||
      !arena_reserve((void **)&a->segments, &a->segments_cap, a->segments_used + 1,
                     sizeof *a->segments))
    return BBC_ERR_OUT_OF_MEMORY;
  out->arena = arena;
  if (out->segments == 0) out->segment = a->segments_used;
  cell_segment *seg = &a->segments[a->segments_used];
  seg->codes = a->codes_used, seg->spans = a->spans_used;
  seg->receiver = receiver, seg->level = level, seg->y0 = y0, seg->h = h;
  uint64_t entries = 0;
  uint16_t *codes = a->codes + a->codes_used;
  uint32_t *spans = a->spans + a->spans_used;
  /* Neighbouring cells often hold the same value: its code is kept. */
  double last_value = 0;
  uint16_t last_code = 0;
  for (uint32_t y = 0; y < h; y++) {
    const double *row = cells + y * stride;
    uint32_t first = 0, last = w;
    while (first < w && row[first] == 0) first++;
    while (last > first && row[last - 1] == 0) last--;
    spans[2 * y] = x0 + (first < w ? first : 0);
    spans[2 * y + 1] = last - first;
    for (uint32_t x = first; x < last; x++) {
      const double v = row[x];
      if (v == 0) {
        *codes++ = 0;
        continue;
      }
      if (!(v > 0)) return BBC_ERR_INVALID_ARGUMENT; /* negative or NaN */
      if (v != last_value) {
        const double e = scaled ? cell_bound(v, power) : v;
        if (isnan(e)) return BBC_ERR_INVALID_ARGUMENT;
        last_value = v;
        last_code = bbc__bound_encode(e);
      }
      *codes++ = last_code;
      entries++;
    }
  }
  a->codes_used = (size_t)(codes - a->codes);
  a->spans_used += 2 * (size_t)h;
  a->segments_used++;
  out->segments++;
  out->entries += entries;
  return BBC_OK;
}

/* The light's brightest channel (W/sr, W/m^2 for a sun, or an emitter's radiance) times
 * Eq. 21's m: what a piece's E_hi per unit intensity is multiplied by. */
static double tuple_power(const bbc_scene *scene, const bbc_precompute_params *params,
                          const bbc_tuple *tuple) {
  float radiance[3];
  const float *intensity = bbc__cache_light_intensity(scene, tuple->light, radiance);
  return fmax(intensity[0], fmax(intensity[1], intensity[2])) * params->m;
}

/* A cell's stored bound from the largest E_hi of the pieces reaching it: the product of
 * non-negative doubles, pushed up by an ulp, so that the stored bound stays above the
 * true one. It does not decrease as e_hi grows, so the bound of the largest E_hi is the
 * largest of the pieces' bounds (Eq. 21). */
static double cell_bound(double e_hi, double power) {
  return isfinite(e_hi) ? nextafter(e_hi * power, INFINITY) : INFINITY;
}

/* The tuple's cells from the coverage raster, which holds, per cell, the largest E_hi of
 * the stored pieces reaching it (keep_piece), over the rectangle they touched: the same
 * cells and bounds as splatting the stored pieces again (tuple_cells_from_pieces) when
 * every stored piece's cells are in the raster and its E_hi is positive (tuple_sink's
 * `escaped` says when not). */
static bbc_result tuple_cells_from_coverage(cell_arena *a, int arena, tuple_cells *out,
                                            const coverage *c, double power) {
  out->segments = 0;
  out->entries = 0;
  if (!c->touched) return BBC_OK;
  return arena_add(a, arena, out, c->receiver, 0, c->tx0, c->ty0, c->tx1 - c->tx0 + 1,
                   c->ty1 - c->ty0 + 1,
                   c->cells + (size_t)(c->ty0 - c->y0) * c->w + (c->tx0 - c->x0), c->w, 1, power);
}

/* Rasterises the kept pieces of one tuple into the cells they cover, keeping the
 * maximum bound per cell (Eq. 21), and gives the tuple's cells. */
static bbc_result tuple_cells_from_pieces(cell_arena *a, int arena, tuple_cells *out,
                                          const bbc_grid *grid, double power,
                                          const bbc_tuple *tuple, const piece_list *pieces,
                                          raster *r) {
  out->segments = 0;
  out->entries = 0;
  bbc_cell_range all = {0, UINT32_MAX, UINT32_MAX, 0, 0};
  int any = 0;
  for (size_t k = 0; k < pieces->count; k++) {
    const bbc_piece *p = &pieces->items[k];
    bbc_cell_range c;
    if (!bbc_grid_splat_range(grid, tuple->receiver, p->uk_lo, p->uk_hi, p->vk_lo, p->vk_hi, &c))
      continue;
    all.receiver = c.receiver;
    all.x0 = c.x0 < all.x0 ? c.x0 : all.x0;
    all.y0 = c.y0 < all.y0 ? c.y0 : all.y0;
    all.x1 = c.x1 > all.x1 ? c.x1 : all.x1;
    all.y1 = c.y1 > all.y1 ? c.y1 : all.y1;
    any = 1;
  }
  if (!any) return BBC_OK;
  size_t w = (size_t)all.x1 - all.x0 + 1, h = (size_t)all.y1 - all.y0 + 1;
  if (w * h > r->capacity) {
    double *cells = realloc(r->cells, w * h * sizeof *cells);
    if (!cells) return BBC_ERR_OUT_OF_MEMORY;
    r->cells = cells;
    r->capacity = w * h;
  }
  memset(r->cells, 0, w * h * sizeof *r->cells);
  bbc_result res = rows_reserve(grid, &r->row_x0, &r->row_x1, &r->rows);
  if (res != BBC_OK) return res;
  for (size_t k = 0; k < pieces->count; k++) {
    const bbc_piece *p = &pieces->items[k];
    bbc_cell_range c;
    footprint f;
    piece_footprint(p, &f);
    if (!splat_footprint(grid, tuple->receiver, &f, &c, r->row_x0, r->row_x1)) continue;
    double e = cell_bound(p->e_hi, power);
    for (uint32_t y = c.y0; y <= c.y1; y++) {
      double *row = r->cells + (y - all.y0) * w - all.x0;
      for (uint32_t x = r->row_x0[y - c.y0]; x <= r->row_x1[y - c.y0]; x++)
        if (e > row[x]) row[x] = e;
    }
  }
  return arena_add(a, arena, out, all.receiver, 0, all.x0, all.y0, (uint32_t)w, (uint32_t)h,
                   r->cells, w, 0, 0.0);
}

/* A batch of tuples: bounded, then given ids and recorded while the next batch is
 * bounded. */
typedef struct batch {
  size_t n;           /* its tuples */
  bbc_tuple *tuples;  /* the candidates, in order */
  uint64_t *candidate; /* and their candidate indices */
  uint32_t *ids;      /* per tuple its id, UINT32_MAX when not stored */
  tuple_cells *cells;
  cell_arena *arenas; /* per bounding thread */
} batch;

/* Row classes of the recording per thread: more classes than threads, so that a thread
 * that ends its share of the bounding early takes more of them. */
#define RECORD_PARTS_PER_THREAD 4

/* Records the batch's cells in the rows of class `part` of `parts`, from its tuple
 * *resume on, in tuple order; 1 when it stopped (*resume then says where) because the
 * builder is over its entry budget, -1 on failure, 0 when done. */
static int record_part(bbc_cache_builder *builder, const batch *b, uint32_t part, uint32_t parts,
                       size_t *resume) {
  size_t i = *resume;
  int status = 0;
  for (; i < b->n; i++) {
    const tuple_cells *t = &b->cells[i];
    if (b->ids[i] == UINT32_MAX || t->segments == 0) continue;
    if (bbc__cache_builder_full(builder)) {
      status = 1;
      break;
    }
    const cell_arena *a = &b->arenas[t->arena];
    for (uint32_t k = 0; k < t->segments && status == 0; k++) {
      const cell_segment *s = &a->segments[t->segment + k];
      if (bbc__cache_builder_add_rows(builder, b->ids[i], s->receiver, s->level, s->y0, s->h,
                                      a->spans + s->spans, a->codes + s->codes, part,
                                      parts) != BBC_OK)
        status = -1;
    }
    if (status) break;
  }
  *resume = i;
  return status;
}

/* A per-thread raster of one beam tuple's bounds over the cells of each receiver that
 * is not a plane (allocated when first reached), kept up to date while the tuple is
 * bounded, as `coverage` is for other tuples: per cell the largest E_hi per unit
 * intensity of the stored pieces reaching it (at least DBL_TRUE_MIN), 0 where none does.
 * Only the touched rectangles are cleared after the tuple. */
typedef struct beam_plane {
  double *cells; /* width x height of its receiver */
  int touched;
  uint32_t tx0, ty0, tx1, ty1;
} beam_plane;

typedef struct beam_cover {
  beam_plane *planes; /* per beam receiver (bbc__beam_receivers.items) */
  uint32_t count;
  double *coarse, *coarse2; /* rectangles of two levels (beam_plane_record) */
  size_t coarse_cap, coarse2_cap;
  uint8_t *full; /* the levels' unbounded blocks (beam_plane_record_unbounded) */
  size_t full_cap;
} beam_cover;

/* What bounding a tuple needs: the scene, the parameters and per thread its bounder,
 * pieces, raster and coverage. */
typedef struct bound_context {
  const bbc_scene *scene;
  const bbc_precompute_params *params;
  const bbc_grid *grid;
  bbc_bound_params bound, bound2, bound_area;
  bbc_bounder **bounders;
  piece_list *pieces;
  raster *rasters;
  coverage *covers;
  /* Beam tuples: the receivers that are not planes, and per thread the kept pieces,
   * their cell bounds and the working memory of their cells. */
  const bbc__beam_receivers *beams;
  beam_list *beam_pieces;
  bbc__beam_scratch *beam_scratch;
  beam_cover *beam_covers;
  int (*cancel_fn)(void *user);
  void *cancel_user;
} bound_context;

/* What a beam tuple's cell test and keeper share (bbc_bound_params.beam_need). */
typedef struct beam_sink {
  const bbc__beam_receivers *beams;
  const bbc_scene *scene;
  const bbc_grid *grid;
  bbc__beam_scratch *scratch;
  beam_cover *cover;
  beam_list *list;
  /* The piece being looked at: its value, the cells seen (0, 1 or 2 for more), the
   * first one, and whether every cell seen holds at least the value. */
  double value;
  int cells, dominated, raises, failed, cancelled;
  uint32_t fk, fx, fy;
  int (*cancel_fn)(void *user);
  void *cancel_user;
} beam_sink;

static double beam_value(double e_hi) {
  return e_hi > 0 ? e_hi : DBL_TRUE_MIN; /* 0 would read as no entry */
}

static int beam_plane_reserve(beam_sink *s, uint32_t k) {
  beam_plane *pl = &s->cover->planes[k];
  if (pl->cells) return 1;
  const bbc_receiver *rc = &s->grid->receivers[s->beams->items[k].receiver];
  pl->cells = calloc((size_t)rc->width * rc->height, sizeof *pl->cells);
  return pl->cells != NULL;
}

static int beam_need_row(void *user, uint32_t k, uint32_t y, uint32_t x0, uint32_t x1,
                         const uint8_t *mask) {
  beam_sink *s = user;
  const beam_plane *pl = &s->cover->planes[k];
  const size_t w = s->grid->receivers[s->beams->items[k].receiver].width;
  for (uint32_t x = x0; x <= x1; x++) {
    if (mask && !mask[x]) continue;
    if (s->cells == 0) {
      s->cells = 1, s->fk = k, s->fx = x, s->fy = y;
    } else if (s->cells == 1 && (k != s->fk || x != s->fx || y != s->fy)) {
      s->cells = 2;
    }
    const double v = pl->cells ? pl->cells[y * w + x] : 0;
    if (!(v > 0 && v >= s->value)) s->dominated = 0;
    if (!s->dominated && s->cells > 1) return 1; /* the answer is known: split */
  }
  return 0;
}

/* bbc_bound_params.beam_depth: the depths of the receivers in a piece's box. */
static int beam_depth(void *user, int axis, const double lo[3], const double hi[3],
                      double *depth_lo, double *depth_hi) {
  beam_sink *s = user;
  return bbc__beam_depth(s->beams, s->scene, s->scratch, axis, lo, hi, depth_lo, depth_hi);
}

/* The beam counterpart of piece_need: NONE when the piece reaches no cell or every cell
 * it reaches already holds at least its E_hi, KEEP when it reaches one cell, else SPLIT. */
static bbc_piece_need beam_need(void *user, const bbc_beam_piece *piece) {
  beam_sink *s = user;
  s->value = beam_value(piece->e_hi);
  s->cells = 0, s->dominated = 1;
  bbc__beam_piece_rows(s->beams, s->scene, s->grid, piece, s->scratch, beam_need_row, s);
  if (s->cells == 0 || s->dominated) return BBC_NEED_NONE;
  return s->cells == 1 ? BBC_NEED_KEEP : BBC_NEED_SPLIT;
}

static int beam_keep_row(void *user, uint32_t k, uint32_t y, uint32_t x0, uint32_t x1,
                         const uint8_t *mask) {
  beam_sink *s = user;
  if (!beam_plane_reserve(s, k)) {
    s->failed = 1;
    return 1;
  }
  beam_plane *pl = &s->cover->planes[k];
  const size_t w = s->grid->receivers[s->beams->items[k].receiver].width;
  double *row = pl->cells + y * w;
  int any = 0;
  uint32_t lo = x1, hi = x0;
  for (uint32_t x = x0; x <= x1; x++) {
    if (mask && !mask[x]) continue;
    if (!(row[x] > 0 && row[x] >= s->value)) {
      row[x] = s->value;
      any = 1;
      if (x < lo) lo = x;
      if (x > hi) hi = x;
    }
  }
  if (!any) return 0;
  s->raises = 1;
  if (!pl->touched) {
    pl->touched = 1, pl->tx0 = lo, pl->tx1 = hi, pl->ty0 = pl->ty1 = y;
  } else {
    if (lo < pl->tx0) pl->tx0 = lo;
    if (hi > pl->tx1) pl->tx1 = hi;
    if (y < pl->ty0) pl->ty0 = y;
    if (y > pl->ty1) pl->ty1 = y;
  }
  return 0;
}

/* A kept piece raises the cells it reaches to its E_hi; one that raises none changes
 * nothing recorded and is not stored (the tuple is stored when some piece is). */
static int keep_beam_piece(void *user, const bbc_beam_piece *piece) {
  beam_sink *s = user;
  beam_list *l = s->list;
  if (s->cancel_fn && s->cancel_fn(s->cancel_user)) return s->cancelled = 1;
  if (piece->status != BBC_PIECE_KEPT) return 0;
  s->value = beam_value(piece->e_hi);
  s->raises = 0;
  bbc__beam_piece_rows(s->beams, s->scene, s->grid, piece, s->scratch, beam_keep_row, s);
  if (s->failed) {
    l->failed = 1;
    return 1;
  }
  if (!s->raises) return 0;
  l->count++;
  return 0;
}

/* A beam tuple's cells of one receiver are recorded at the coarsest level of cells (spec
 * Sec. 6.6) at which they keep their shape: each coarse cell takes the largest bound of
 * its cells, so the bounds summed over the grid's cells grow with the level, and the
 * level is the last before that sum exceeds BEAM_LEVEL_GROWTH times the cells' own. The
 * renderer samples tuples in proportion to their bounds, so that sum is what its work
 * follows. A caustic spread smoothly over much of a receiver (a convex mirror's) then
 * costs a few entries, not one per cell it reaches; one with folds or a focus keeps
 * fine cells. Unbounded cells (+inf) are never merged with bounded ones: they send their
 * points' chain type to light tracing (docs/light-tracing.md), which must not spread. */
#define BEAM_LEVEL_GROWTH 1.25

/* A rectangle of bounds at level k of a receiver's cells: w x h coarse cells from (x0, y0). */
typedef struct beam_level {
  double *v;
  uint32_t k, x0, y0, w, h;
} beam_level;

/* The sum of l's bounds over the grid's cells (a coarse cell counts once per cell of the
 * grid it holds). */
static double beam_level_sum(const bbc_receiver *rc, const beam_level *l) {
  double sum = 0;
  const uint32_t side = 1u << l->k;
  for (uint32_t y = 0; y < l->h; y++) {
    const uint32_t gy = (l->y0 + y) << l->k, ny = rc->height - gy < side ? rc->height - gy : side;
    for (uint32_t x = 0; x < l->w; x++) {
      const uint32_t gx = (l->x0 + x) << l->k, nx = rc->width - gx < side ? rc->width - gx : side;
      sum += l->v[(size_t)y * l->w + x] * nx * ny;
    }
  }
  return sum;
}

/* out, at level in->k + 1: each cell the largest of the (up to four) cells of `in` it
 * holds, which is the largest of its cells of the grid. */
static void beam_level_up(const beam_level *in, beam_level *out) {
  out->k = in->k + 1;
  out->x0 = in->x0 >> 1, out->y0 = in->y0 >> 1;
  out->w = ((in->x0 + in->w - 1) >> 1) - out->x0 + 1;
  out->h = ((in->y0 + in->h - 1) >> 1) - out->y0 + 1;
  memset(out->v, 0, (size_t)out->w * out->h * sizeof *out->v);
  for (uint32_t y = 0; y < in->h; y++) {
    const double *row = in->v + (size_t)y * in->w;
    double *o = out->v + (size_t)(((in->y0 + y) >> 1) - out->y0) * out->w;
    for (uint32_t x = 0; x < in->w; x++) {
      double *c = o + (((in->x0 + x) >> 1) - out->x0);
      if (row[x] > *c) *c = row[x];
    }
  }
}

/* The unbounded cells of pl as the union of the largest aligned blocks of cells, of any
 * level, whose cells are all unbounded (a quadtree): a tuple unbounded over a whole
 * receiver then costs a few entries, and no cell that was bounded becomes unbounded. */
static bbc_result beam_plane_record_unbounded(const bbc_grid *grid, uint32_t receiver,
                                              const beam_plane *pl, beam_cover *cover,
                                              cell_arena *a, int id, tuple_cells *c, double power) {
  const bbc_receiver *rc = &grid->receivers[receiver];
  const uint32_t levels = grid->levels;
  /* full[k]: per cell of the rectangle at level k, 1 when all its cells are unbounded. */
  size_t at[BBC__MAX_CELL_LEVELS + 1], total = 0;
  for (uint32_t k = 0; k < levels; k++) {
    at[k] = total;
    total += (size_t)((pl->tx1 >> k) - (pl->tx0 >> k) + 1) * ((pl->ty1 >> k) - (pl->ty0 >> k) + 1);
  }
  if (!arena_reserve((void **)&cover->full, &cover->full_cap, total, 1))
    return BBC_ERR_OUT_OF_MEMORY;
  for (uint32_t k = 0; k < levels; k++) {
    const uint32_t x0 = pl->tx0 >> k, y0 = pl->ty0 >> k, x1 = pl->tx1 >> k, y1 = pl->ty1 >> k;
    const uint32_t w = x1 - x0 + 1;
    uint8_t *full = cover->full + at[k];
    /* Level k - 1: the grid's size and the rectangle there. */
    const uint32_t q = k ? k - 1 : 0;
    const uint32_t gw = ((rc->width - 1) >> q) + 1, gh = ((rc->height - 1) >> q) + 1;
    const uint32_t px0 = pl->tx0 >> q, py0 = pl->ty0 >> q, px1 = pl->tx1 >> q,
                   py1 = pl->ty1 >> q;
    for (uint32_t y = y0; y <= y1; y++)
      for (uint32_t x = x0; x <= x1; x++) {
        uint8_t f = 1;
        if (k == 0) {
          f = pl->cells[(size_t)y * rc->width + x] == INFINITY;
        } else {
          /* Its children of level k - 1 inside the grid, each inside the rectangle and
           * full (one outside holds no cell of the rectangle, so none unbounded). */
          for (uint32_t j = 0; j < 2 && f; j++)
            for (uint32_t i = 0; i < 2 && f; i++) {
              const uint32_t cx = 2 * x + i, cy = 2 * y + j;
              if (cx >= gw || cy >= gh) continue;
              f = cx >= px0 && cx <= px1 && cy >= py0 && cy <= py1 &&
                  cover->full[at[k - 1] + (size_t)(cy - py0) * (px1 - px0 + 1) + (cx - px0)];
            }
        }
        full[(size_t)(y - y0) * w + (x - x0)] = f;
      }
  }
  /* From the coarsest level down: a full cell whose parent is not full. */
  for (uint32_t k = levels; k-- > 0;) {
    const uint32_t x0 = pl->tx0 >> k, y0 = pl->ty0 >> k, x1 = pl->tx1 >> k, y1 = pl->ty1 >> k;
    const uint32_t w = x1 - x0 + 1, h = y1 - y0 + 1;
    if (!arena_reserve((void **)&cover->coarse, &cover->coarse_cap, (size_t)w * h,
                       sizeof *cover->coarse))
      return BBC_ERR_OUT_OF_MEMORY;
    int any = 0;
    for (uint32_t y = y0; y <= y1; y++)
      for (uint32_t x = x0; x <= x1; x++) {
        int f = cover->full[at[k] + (size_t)(y - y0) * w + (x - x0)];
        if (f && k + 1 < levels) {
          const uint32_t qx0 = pl->tx0 >> (k + 1), qy0 = pl->ty0 >> (k + 1);
          const uint32_t qw = (pl->tx1 >> (k + 1)) - qx0 + 1;
          f = !cover->full[at[k + 1] + (size_t)((y >> 1) - qy0) * qw + ((x >> 1) - qx0)];
        }
        cover->coarse[(size_t)(y - y0) * w + (x - x0)] = f ? INFINITY : 0;
        any |= f;
      }
    if (!any) continue;
    bbc_result r = arena_add(a, id, c, receiver, k, x0, y0, w, h, cover->coarse, w, 1, power);
    if (r != BBC_OK) return r;
  }
  return BBC_OK;
}

static bbc_result beam_plane_record(const bbc_grid *grid, uint32_t receiver, const beam_plane *pl,
                                    beam_cover *cover, cell_arena *a, int id, tuple_cells *c,
                                    double power) {
  const bbc_receiver *rc = &grid->receivers[receiver];
  const size_t w = rc->width;
  if (grid->levels == 1)
    return arena_add(a, id, c, receiver, 0, pl->tx0, pl->ty0, pl->tx1 - pl->tx0 + 1,
                     pl->ty1 - pl->ty0 + 1, pl->cells + pl->ty0 * w + pl->tx0, w, 1, power);
  /* The finite bounds at level 0 (in coarse2: the unbounded blocks use coarse), their
   * sum, and whether any cell is unbounded, in one pass. */
  const size_t n = ((size_t)pl->tx1 - pl->tx0 + 1) * ((size_t)pl->ty1 - pl->ty0 + 1);
  if (!arena_reserve((void **)&cover->coarse, &cover->coarse_cap, n, sizeof *cover->coarse) ||
      !arena_reserve((void **)&cover->coarse2, &cover->coarse2_cap, n, sizeof *cover->coarse2))
    return BBC_ERR_OUT_OF_MEMORY;
  beam_level cur = {cover->coarse2, 0, pl->tx0, pl->ty0, pl->tx1 - pl->tx0 + 1, pl->ty1 - pl->ty0 + 1};
  double own = 0;
  int unbounded = 0;
  for (uint32_t y = 0; y < cur.h; y++) {
    const double *row = pl->cells + (size_t)(cur.y0 + y) * w + cur.x0;
    for (uint32_t x = 0; x < cur.w; x++) {
      const double v = row[x] < INFINITY ? row[x] : 0;
      own += v;
      unbounded |= row[x] == INFINITY;
      cur.v[(size_t)y * cur.w + x] = v;
    }
  }
  if (unbounded) {
    bbc_result r = beam_plane_record_unbounded(grid, receiver, pl, cover, a, id, c, power);
    if (r != BBC_OK || own == 0) return r;
  }
  /* Each level from the one below, kept while the sum grows by at most
   * BEAM_LEVEL_GROWTH. */
  beam_level up = {cover->coarse, 0, 0, 0, 0, 0};
  while (cur.k + 1 < grid->levels) {
    beam_level_up(&cur, &up);
    if (!(beam_level_sum(rc, &up) <= BEAM_LEVEL_GROWTH * own)) break;
    const beam_level t = cur;
    cur = up, up = t;
  }
  return arena_add(a, id, c, receiver, cur.k, cur.x0, cur.y0, cur.w, cur.h, cur.v, cur.w, 1, power);
}

/* Bounds beam tuple t (receiver BBC_RECEIVER_BEAM) on thread `id`: its kept pieces'
 * bounds go to the cells of every receiver triangle not on a plane that their boxes
 * meet, the largest per cell, one segment per receiver reached. 0 on failure. */
static int bound_beam_one(const bound_context *x, int id, const bbc_tuple *t, cell_arena *a,
                          tuple_cells *c, bbc_bound_stats *stats) {
  bbc_tuple_geometry g;
  beam_list *list = &x->beam_pieces[id];
  list->count = 0;
  list->failed = 0;
  c->stored = 0;
  c->segments = 0;
  c->entries = 0;
  if (x->cancel_fn && x->cancel_fn(x->cancel_user)) return -1;
  if (bbc_tuple_geometry_init(&g, x->scene, t) != BBC_OK) return 0;
  if (bbc__beam_scratch_reserve(&x->beam_scratch[id], x->beams) != BBC_OK) return 0;
  beam_sink sink;
  memset(&sink, 0, sizeof sink);
  sink.beams = x->beams, sink.scene = x->scene, sink.grid = x->grid;
  sink.scratch = &x->beam_scratch[id], sink.cover = &x->beam_covers[id], sink.list = list;
  sink.cancel_fn = x->cancel_fn, sink.cancel_user = x->cancel_user;
  bbc_bound_params prm = g.light_model.kind == BBC_LIGHT_AREA ? x->bound_area
                         : g.length == 2                      ? x->bound2
                                                              : x->bound;
  prm.beam_need = beam_need;
  prm.beam_depth = beam_depth;
  prm.need_user = &sink;
  /* The box where its light can land: inside a closed mesh, that mesh's. */
  double lo[3], hi[3];
  for (int k = 0; k < 3; k++) lo[k] = x->beams->lo[k], hi[k] = x->beams->hi[k];
  if (!bbc__tuple_landing_box(x->scene, t, lo, hi)) return 1; /* it reaches no receiver */
  int ok =
      bbc_bound_beam(x->bounders[id], &g, lo, hi, &prm, keep_beam_piece, &sink, stats) == BBC_OK &&
      !list->failed;
  c->stored = ok && list->count > 0;
  const double power = tuple_power(x->scene, x->params, t);
  beam_cover *cover = &x->beam_covers[id];
  for (uint32_t k = 0; k < cover->count; k++) {
    beam_plane *pl = &cover->planes[k];
    if (!pl->touched) continue;
    const uint32_t receiver = x->beams->items[k].receiver;
    const size_t w = x->grid->receivers[receiver].width;
    if (ok && c->stored &&
        beam_plane_record(x->grid, receiver, pl, cover, a, id, c, power) != BBC_OK)
      ok = 0;
    for (uint32_t y = pl->ty0; y <= pl->ty1; y++)
      memset(pl->cells + y * w + pl->tx0, 0, ((size_t)pl->tx1 - pl->tx0 + 1) * sizeof *pl->cells);
    pl->touched = 0;
  }
  if (sink.cancelled) {
    c->stored = 0, c->segments = 0, c->entries = 0;
    return -1;
  }
  return ok;
}

/* Bounds tuple t on thread `id` and gives its cells (in arena a, thread id's); 0 on
 * failure, -1 when cancel_fn said stop. */
static int bound_one(const bound_context *x, int id, const bbc_tuple *t, cell_arena *a,
                     tuple_cells *c, bbc_bound_stats *stats) {
  if (bbc_receiver_is_beam(t->receiver)) return bound_beam_one(x, id, t, a, c, stats);
  bbc_tuple_geometry g;
  piece_list *list = &x->pieces[id];
  list->count = 0;
  list->failed = 0;
  if (x->cancel_fn && x->cancel_fn(x->cancel_user)) return -1;
  tuple_sink sink;
  memset(&sink, 0, sizeof sink);
  sink.pieces = list, sink.cover = &x->covers[id], sink.grid = x->grid;
  sink.receiver = t->receiver;
  sink.cancel_fn = x->cancel_fn, sink.cancel_user = x->cancel_user;
  int ok = bbc_tuple_geometry_init(&g, x->scene, t) == BBC_OK &&
           coverage_begin(&x->covers[id], x->grid, sink.receiver) == BBC_OK;
  if (ok) {
    /* Area lights stop at a ratio of their own (docs/lights.md). */
    bbc_bound_params prm = g.light_model.kind == BBC_LIGHT_AREA ? x->bound_area
                           : g.length == 2                      ? x->bound2
                                                                : x->bound;
    prm.need = piece_need;
    prm.need_user = &sink;
    ok = bbc_bound_tuple(x->bounders[id], &g, &prm, keep_piece, &sink, stats) == BBC_OK &&
         !list->failed;
    if (sink.cancelled) {
      coverage_end(&x->covers[id]);
      c->stored = 0, c->segments = 0, c->entries = 0;
      return -1;
    }
  }
  /* The tuple's cells, while the raster holds them (a tuple is stored when it has a
   * stored piece). */
  c->stored = ok && list->count > 0;
  c->segments = 0;
  c->entries = 0;
  if (c->stored) {
    const double power = tuple_power(x->scene, x->params, t);
    ok = (sink.escaped ? tuple_cells_from_pieces(a, id, c, x->grid, power, t, list,
                                                 &x->rasters[id])
                       : tuple_cells_from_coverage(a, id, c, &x->covers[id], power)) == BBC_OK;
  }
  coverage_end(&x->covers[id]);
  return ok;
}

/* Bounds the census's sample (timing it) into the estimate; its cells go to `arenas`,
 * its pieces to throwaway statistics. */
static bbc_result bound_sample(const bound_context *x, int threads, const bbc__census *census,
                               cell_arena *arenas, tuple_cells *cells,
                               bbc_precompute_estimate *e) {
  const size_t n = census->sample_count;
  double cpu = 0;
  uint64_t stored = 0, entries = 0;
  uint64_t *pieces = calloc(n ? n : 1, sizeof *pieces); /* per sampled tuple */
  if (!pieces) return BBC_ERR_OUT_OF_MEMORY;
  int failed = 0, cancelled = 0;
  for (int i = 0; i < threads; i++) arena_clear(&arenas[i]);
#pragma omp parallel num_threads(threads) reduction(+ : cpu, stored, entries) \
    reduction(| : failed, cancelled)
  {
    const int id = omp_get_thread_num();
    const double cpu0 = thread_cpu_seconds();
#pragma omp for schedule(dynamic, 1)
    for (size_t i = 0; i < n; i++) {
      bbc_bound_stats one;
      memset(&one, 0, sizeof one);
      const int r = bound_one(x, id, &census->sample[i], &arenas[id], &cells[i], &one);
      if (r == 0) failed = 1;
      if (r < 0) cancelled = 1;
      stored += cells[i].stored;
      entries += cells[i].stored ? cells[i].entries : 0;
      pieces[i] = one.position_pieces + one.irradiance_pieces;
      arena_clear(&arenas[id]); /* only the counts are needed: one tuple's cells at a time */
    }
    cpu += thread_cpu_seconds() - cpu0;
  }
  for (int i = 0; i < threads; i++) arena_clear(&arenas[i]);
  /* Pieces per chain type: the sample's mean per candidate of that type times the
   * type's candidates in the shard, summed in sample order (the same for any thread
   * count). A type the sample missed counts its candidates at the sample's overall
   * mean. */
  double sum[BBC_CHAIN_COUNT] = {0}, all = 0;
  uint64_t drawn[BBC_CHAIN_COUNT] = {0};
  for (size_t i = 0; i < n; i++) {
    const int c = census->sample[i].chain < BBC_CHAIN_COUNT ? census->sample[i].chain : 0;
    sum[c] += (double)pieces[i];
    drawn[c]++;
    all += (double)pieces[i];
  }
  free(pieces);
  if (cancelled) return BBC_ERR_CANCELLED;
  if (failed) return BBC_ERR_OUT_OF_MEMORY;
  const double shard = census->count ? (double)census->bounded / (double)census->count : 0;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    const double mean = drawn[c] ? sum[c] / (double)drawn[c] : n ? all / (double)n : 0;
    e->pieces_per_chain[c] = mean * (double)census->per_chain[c] * shard;
  }
  e->sample_tuples = (uint32_t)n;
  e->sample_cpu_seconds = cpu;
  e->stored_fraction = n ? (double)stored / (double)n : 0;
  e->entries_per_tuple = stored ? (double)entries / (double)stored : 0;
  return BBC_OK;
}

/* Every cell of the receivers that are not planes: what a beam tuple's rasters hold. */
static double beam_cells_total(const bbc__beam_receivers *beams, const bbc_grid *grid) {
  double cells = 0;
  for (uint32_t k = 0; k < beams->count; k++) {
    const bbc_receiver *rc = &grid->receivers[beams->items[k].receiver];
    cells += (double)rc->width * rc->height;
  }
  return cells;
}

/* The most a beam tuple's cells take in a batch's arena: a code per cell of each
 * receiver's mask rectangle, a span per row and a segment per receiver; with levels of
 * cells, the unbounded cells' rectangles of every level too (at most 4/3 of the grid's)
 * besides the bounded cells' one. */
static double beam_tuple_bytes(const bbc__beam_receivers *beams, const bbc_grid *grid) {
  const double levels = grid->levels > 1 ? 1 + 4.0 / 3.0 : 1;
  double bytes = 0;
  for (uint32_t k = 0; k < beams->count; k++) {
    const bbc__beam_receiver *item = &beams->items[k];
    if (item->mx0 > item->mx1) continue;
    const double w = (double)item->mx1 - item->mx0 + 1, h = (double)item->my1 - item->my0 + 1;
    bytes += levels * (w * h * sizeof(uint16_t) + h * 2 * sizeof(uint32_t) +
                       grid->levels * sizeof(cell_segment));
  }
  return bytes;
}

/* Tuples per batch: BATCH_TUPLES, fewer when beam tuples could fill the two batches'
 * arenas beyond the entry budget (each may reach every cell of the receivers that are
 * not planes), at least BEAM_BATCH_MIN. It does not depend on the thread count. */
#define BEAM_BATCH_MIN 8
static size_t beam_batch_tuples(const bbc__beam_receivers *beams, const bbc_grid *grid,
                                const bbc_precompute_options *o) {
  if (!beams->count) return BATCH_TUPLES;
  const double per = beam_tuple_bytes(beams, grid);
  const double budget = o->entry_memory ? (double)o->entry_memory : 8.0 * 1048576.0;
  const double n = per > 0 ? floor(budget / (2 * per)) : BATCH_TUPLES;
  return n >= BATCH_TUPLES ? BATCH_TUPLES : n <= BEAM_BATCH_MIN ? BEAM_BATCH_MIN : (size_t)n;
}

/* The rest of the estimate, from the census and the sample: see precompute.h. */
static void estimate_costs(const bbc__census *census, const bbc_precompute_options *o,
                           const bbc_grid *grid, int threads, const bbc__beam_receivers *beams,
                           bbc_precompute_estimate *e) {
  const double tuple = sizeof(bbc_tuple);
  e->candidate_tuples = census->count;
  memcpy(e->candidates_per_chain, census->per_chain, sizeof e->candidates_per_chain);
  e->bounded_tuples = census->bounded;
  e->list_bytes = census->count * sizeof(bbc_tuple);
  e->list_held = census->held != NULL;
  e->search_bytes = census->block_peak;
  e->search_seconds = census->seconds;
  const double n = (double)census->bounded, k = e->sample_tuples;
  e->bounding_cpu_seconds = k ? n * e->sample_cpu_seconds / k : 0;
  e->seconds = e->bounding_cpu_seconds / threads + (e->list_held ? 0 : census->seconds);
  /* Stored tuples: the sample's fraction at three standard errors (a binomial's), and
   * 3 / k more so that a sample with none stored does not promise none. */
  const double p = e->stored_fraction;
  double upper = k ? p + 3 * sqrt(p * (1 - p) / k) + 3 / k : 1;
  if (upper > 1) upper = 1;
  e->stored_tuples = (uint64_t)ceil(upper * n);
  /* Memory from here on: the builder's tuple array (doubling: up to twice its tuples)
   * and, for a shard, their candidate indices likewise; the grid entries up to their
   * budget, twice while a full list is merged; the second search's blocks (the census's
   * largest, twice: a block is handed out while the next window fills); the writer's
   * cell index. What is held already (the scene, the grids, a held list) is not. */
  const double stored = (double)e->stored_tuples;
  double entry_memory = o->entry_memory ? (double)o->entry_memory : 8.0 * 1048576.0;
  const double entries = stored * e->entries_per_tuple * sizeof(bbc__cell_entry);
  if (k && entries < entry_memory) entry_memory = entries;
  double memory = stored * 2 * tuple + (o->shard_count ? stored * 2 * 8 : 0) + 2 * entry_memory;
  if (!e->list_held) memory += 2 * (double)census->block_peak;
  memory += (double)grid->cell_count * BBC__CIDX_SIZE;
  /* Beam receivers: their BVHs and masks, and per thread a raster of each receiver.
   * A beam tuple may reach every cell of those receivers, so the two batches' cells
   * (codes of 2 bytes over the tuples' rectangles, about their entries) count too. */
  if (beams->count) {
    memory += (double)beams->bytes;
    memory += threads * (double)beam_cells_total(beams, grid) * sizeof(double);
    memory += 2.0 * beam_batch_tuples(beams, grid, o) * beam_tuple_bytes(beams, grid);
  }
  e->memory_bytes = (uint64_t)memory;
  /* The file: its fixed sections (as bbc_cache_check_resources counts them), the
   * tuples and the cell lists at about 1.7 bytes per entry once compressed (measured
   * on the benchmark scenes: 1.3 to 2.1). */
  const double fixed = 64 + 32.0 * 10 + 80 * 10 + BBC__PARM_SIZE + BBC__FPRT_SIZE +
                       (double)grid->receiver_count * BBC__RCVR_SIZE +
                       (double)grid->uv_triangle_count * BBC__TRUV_SIZE +
                       (double)grid->cell_count * BBC__CIDX_SIZE;
  const double expected = k ? p * n : n;
  e->file_bytes = (uint64_t)(fixed + expected * (tuple + (o->shard_count ? 8 : 0)) +
                             expected * e->entries_per_tuple * 1.7);
}

uint32_t bbc_beam_receivers_auto(const bbc_scene *scene, uint64_t *triangles) {
  uint64_t n = 0;
  for (uint32_t m = 0; scene && m < scene->mesh_count; m++)
    if (scene->meshes[m].role == BBC_ROLE_RECEIVER && !scene->meshes[m].plane)
      n += scene->meshes[m].triangle_count;
  if (triangles) *triangles = n;
  return n >= BBC_BEAM_RECEIVER_TRIANGLES;
}

/* The precompute, or with `probe` its estimate alone from a sample of PROBE_PER_CHAIN
 * candidates of each chain type (bbc_precompute_choose_chains): *out stays NULL and
 * stats gets the estimate. */
#define PROBE_PER_CHAIN 16
static bbc_result precompute(bbc_cache_builder **out, const bbc_scene *scene,
                             const bbc_precompute_options *options, bbc_precompute_stats *stats,
                             int probe) {
  *out = NULL;
  if (!scene || !options) return BBC_ERR_INVALID_ARGUMENT;
  const bbc_precompute_params *params = &options->params;
  bbc_precompute_stats st;
  memset(&st, 0, sizeof st);
  st.threads = options->threads > 0 ? options->threads : omp_get_max_threads();

  bbc_cache_builder *builder = NULL;
  bbc_result result = bbc_cache_builder_create(&builder, scene, params);
  if (result != BBC_OK)
    return bbc__report(options->error_fn, options->user, result,
                       "%s: cannot set up the receiver grids: %s", scene->path,
                       bbc_result_string(result));
  bbc__cache_builder_set_entry_memory(builder, options->entry_memory);

  /* The census: the candidates counted (and the list held when it is small), before
   * anything is bounded. Area lights come after the punctual ones (their light indices
   * are higher), their double-scattering chain types only when asked for
   * (area_double). */
  bbc__census_request request;
  memset(&request, 0, sizeof request);
  request.chains = params->chains;
  request.beam = params->beam_receivers != 0;
  request.area_chains = !params->area_lights ? 0
                        : params->area_double ? params->chains
                                              : params->chains & ~BBC_CHAIN_MASK_DOUBLE;
  request.threads = st.threads;
  request.shard_index = options->shard_index;
  request.shard_count = options->shard_count;
  request.hold_bytes = options->candidate_memory ? options->candidate_memory : (size_t)64 << 20;
  /* Blocks of an eighth of what may be held: a window's lists stay small beside it. */
  request.block_bytes = request.hold_bytes / 8 > 4096 ? request.hold_bytes / 8 : 4096;
  request.sample_max = probe ? PROBE_PER_CHAIN : SAMPLE_MAX;
  request.sample_per_chain = probe;
  request.progress = options->search_progress;
  request.progress_user = options->progress_user;
  bbc__census census;
  memset(&census, 0, sizeof census);
  bbc__candidates source;
  memset(&source, 0, sizeof source);
  if (options->shard_count && options->shard_index >= options->shard_count)
    result = BBC_ERR_INVALID_ARGUMENT;
  if (result == BBC_OK) result = bbc__census_take(&census, scene, &request);
  /* The sample: 1 in 64 of the candidates, at least SAMPLE_MIN (all of them when they
   * are fewer) and at most SAMPLE_MAX. */
  if (result == BBC_OK && !probe) {
    size_t k = (size_t)(census.bounded / 64);
    if (k < SAMPLE_MIN) k = SAMPLE_MIN;
    /* k of the reservoir drawn uniformly (a partial Fisher-Yates shuffle, a hash for
     * the dice): its first slots alone favour the first candidates. */
    const size_t m = census.sample_count;
    for (size_t i = 0; i < k && i < m; i++) {
      const size_t j = i + (size_t)(bbc__mix64(i + 0x2545F4914F6CDD1Dull) % (m - i));
      const bbc_tuple t = census.sample[i];
      census.sample[i] = census.sample[j];
      census.sample[j] = t;
    }
    census.sample_count = k < m ? k : m;
  }
  st.construction_seconds = census.seconds;
  st.candidate_tuples = census.count;
  st.second_per_first = census.second_per_first;
  /* A shard (spec Sec. 5.10) bounds the candidates k % N == i, remembering each k. */
  if (result == BBC_OK && options->shard_count)
    result = bbc__cache_builder_set_shard(builder, options->shard_index, options->shard_count,
                                          census.count, census.hash);

  bbc_bound_params bound;
  memset(&bound, 0, sizeof bound);
  bound.max_level = params->max_level ? (int)params->max_level : -1; /* 0: the root only */
  bound.sigma = params->sigma;
  bound.alpha = params->alpha_single;
  bound.no_remainder = !params->remainder;
  bound.jacobian = options->jacobian;
  bbc_bound_params bound2 = bound; /* two bounces: their own alpha and level */
  bound2.alpha = params->alpha_double;
  const uint32_t level2 = bbc__params_max_level_double(params);
  bound2.max_level = level2 ? (int)level2 : -1;
  bbc_bound_params bound_area = bound; /* every tuple of an area light: its own alpha */
  bound_area.alpha = bbc__params_alpha_area(params);

  const int threads = st.threads;
  bbc_bounder **bounders = calloc((size_t)threads, sizeof *bounders);
  /* Per thread: the stored pieces of the tuple it bounds. */
  piece_list *pieces = calloc((size_t)threads, sizeof *pieces);
  const uint32_t parts = RECORD_PARTS_PER_THREAD * (uint32_t)threads;
  size_t *resume = calloc(parts, sizeof *resume);
  batch batches[2];
  memset(batches, 0, sizeof batches);
  int batches_ok = 1;
  for (int k = 0; k < 2; k++) {
    batches[k].tuples = calloc(BATCH_TUPLES, sizeof *batches[k].tuples);
    batches[k].candidate = calloc(BATCH_TUPLES, sizeof *batches[k].candidate);
    batches[k].ids = calloc(BATCH_TUPLES, sizeof *batches[k].ids);
    batches[k].cells = calloc(BATCH_TUPLES, sizeof *batches[k].cells);
    batches[k].arenas = calloc((size_t)threads, sizeof *batches[k].arenas);
    batches_ok &= batches[k].tuples && batches[k].candidate && batches[k].ids &&
                  batches[k].cells && batches[k].arenas;
  }
  raster *rasters = calloc((size_t)threads, sizeof *rasters);
  coverage *covers = calloc((size_t)threads, sizeof *covers);
  const bbc_grid *grid = bbc_cache_builder_grid(builder);
  bbc_bound_stats *thread_stats = calloc((size_t)threads, sizeof *thread_stats);
  bbc_bound_stats *cpu_split = calloc((size_t)threads, sizeof *cpu_split);
  if (result == BBC_OK && (!bounders || !pieces || !resume || !batches_ok || !rasters || !covers ||
                           !thread_stats || !cpu_split))
    result = BBC_ERR_OUT_OF_MEMORY;
  for (int i = 0; i < threads && result == BBC_OK; i++) result = bbc_bounder_create(&bounders[i]);
  /* Beam receivers: the receivers that are not planes, for the cells of beam tuples. */
  bbc__beam_receivers beams;
  memset(&beams, 0, sizeof beams);
  beam_list *beam_pieces = calloc((size_t)threads, sizeof *beam_pieces);
  bbc__beam_scratch *beam_scratch = calloc((size_t)threads, sizeof *beam_scratch);
  if (result == BBC_OK && (!beam_pieces || !beam_scratch)) result = BBC_ERR_OUT_OF_MEMORY;
  if (result == BBC_OK && params->beam_receivers)
    result = bbc__beam_receivers_init(&beams, scene, grid);
  beam_cover *beam_covers = calloc((size_t)threads, sizeof *beam_covers);
  if (result == BBC_OK && !beam_covers) result = BBC_ERR_OUT_OF_MEMORY;
  for (int i = 0; i < threads && result == BBC_OK && beams.count; i++) {
    beam_covers[i].planes = calloc(beams.count, sizeof *beam_covers[i].planes);
    beam_covers[i].count = beam_covers[i].planes ? beams.count : 0;
    if (!beam_covers[i].planes) result = BBC_ERR_OUT_OF_MEMORY;
  }
  const size_t batch_tuples = beam_batch_tuples(&beams, grid, options);
  const bound_context context = {
      scene,        params,      grid,         bound,       bound2,
      bound_area,   bounders,    pieces,       rasters,     covers,
      &beams,       beam_pieces, beam_scratch, beam_covers, options->cancel_fn,
      options->user};

  /* The estimate, from the census and its sample bounded first (SAMPLE_MAX tuples
   * fit a batch's cells), before the bounding: the caller may stop there. */
  if (result == BBC_OK)
    result = bound_sample(&context, threads, &census, batches[0].arenas, batches[0].cells,
                          &st.estimate);
  if (result == BBC_OK) {
    estimate_costs(&census, options, grid, threads, &beams, &st.estimate);
    if (!probe && options->estimate_fn && options->estimate_fn(options->user, &st.estimate))
      result = BBC_ERR_CANCELLED;
  }
  if (result == BBC_OK && !probe) result = bbc__candidates_begin(&source, scene, &census, &request);
  const uint64_t tuple_count = census.bounded;

  /* Batch k is bounded while batch k - 1, its ids given in tuple order, is recorded (so
   * ids and the file are the same for any thread count): a thread done with its share
   * of the bounding records rows instead of waiting for the others. */
  size_t first = 0;
  for (size_t k = 0; result == BBC_OK && !probe; k++) {
    batch *cur = &batches[k & 1], *prev = &batches[(k + 1) & 1];
    size_t n = 0;
    if ((result = bbc__candidates_next(&source, cur->tuples, cur->candidate, batch_tuples, &n)) !=
        BBC_OK)
      break;
    const int pending = k > 0 && prev->n > 0;
    if (n == 0 && !pending) break;
    cur->n = n;
    for (int i = 0; i < threads; i++) arena_clear(&cur->arenas[i]);
    for (uint32_t p = 0; p < parts; p++) resume[p] = 0;
    double b0 = omp_get_wtime();
    int failed = 0, stopped = 0, cancelled = 0;
#pragma omp parallel num_threads(threads) reduction(| : failed, stopped, cancelled)
    {
      /* The thread's CPU time over its bounding (one system call at each end, not per
       * tuple), split between position and irradiance bounds as their clocked times
       * were. */
      const int self = omp_get_thread_num();
      const double cpu0 = thread_cpu_seconds();
      const double pos0 = thread_stats[self].position_seconds;
      const double irr0 = thread_stats[self].irradiance_seconds;
#pragma omp for schedule(dynamic, 1) nowait
      for (size_t i = 0; i < n; i++) {
        const int id = omp_get_thread_num();
        const int r = bound_one(&context, id, &cur->tuples[i], &cur->arenas[id], &cur->cells[i],
                                &thread_stats[id]);
        if (r == 0) failed = 1;
        if (r < 0) cancelled = 1;
      }
      const double cpu = thread_cpu_seconds() - cpu0;
      const double pos = thread_stats[self].position_seconds - pos0;
      const double clocked = pos + (thread_stats[self].irradiance_seconds - irr0);
      const double share = clocked > 0 ? pos / clocked : 1.0;
      cpu_split[self].position_seconds += cpu * share;
      cpu_split[self].irradiance_seconds += cpu - cpu * share;
      /* The previous batch's cells go to the builder in tuple order, so that every
       * cell's list stays sorted; its rows are shared out by class
       * (bbc__cache_builder_add_rows), so no two threads touch a cell and none waits for
       * a lock. A class that finds the builder over its entry budget stops there and
       * resumes after the spill. */
      if (pending) {
#pragma omp for schedule(dynamic, 1) nowait
        for (uint32_t p = 0; p < parts; p++) {
          const int r = record_part(builder, prev, p, parts, &resume[p]);
          if (r > 0) stopped = 1;
          if (r < 0) failed = 1;
        }
      }
    }
    double b1 = omp_get_wtime();
    st.bounding_seconds += b1 - b0;
    if (cancelled) {
      result = BBC_ERR_CANCELLED;
      break;
    }
    if (failed) {
      result = BBC_ERR_OUT_OF_MEMORY;
      break;
    }
    if (pending) {
      result = bbc__cache_builder_spill_if_full(builder);
      while (stopped && result == BBC_OK) {
        int splat_failed = 0;
        stopped = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) \
    reduction(|                                                    \
              : splat_failed, stopped)
        for (uint32_t p = 0; p < parts; p++) {
          const int r = record_part(builder, prev, p, parts, &resume[p]);
          if (r > 0) stopped = 1;
          if (r < 0) splat_failed = 1;
        }
        result = splat_failed ? BBC_ERR_OUT_OF_MEMORY : bbc__cache_builder_spill_if_full(builder);
      }
      for (size_t i = 0; i < prev->n; i++)
        if (prev->ids[i] != UINT32_MAX) st.entries += prev->cells[i].entries;
    }
    /* Ids are given in tuple order, so they (and the file) are the same for any thread
     * count. */
    for (size_t i = 0; i < n && result == BBC_OK; i++) {
      cur->ids[i] = UINT32_MAX;
      if (!cur->cells[i].stored) continue;
      const bbc_tuple *tuple = &cur->tuples[i];
      if ((result = bbc_cache_builder_add_tuple(builder, tuple, &cur->ids[i])) != BBC_OK) break;
      if (options->shard_count &&
          (result = bbc__cache_builder_set_candidate(builder, cur->ids[i], cur->candidate[i])) !=
              BBC_OK)
        break;
      st.tuples++;
      st.tuples_per_chain[tuple->chain]++;
    }
    st.recording_seconds += omp_get_wtime() - b1;
    first += n;
    if (n && result == BBC_OK && options->progress &&
        options->progress(options->progress_user, first, tuple_count))
      result = BBC_ERR_CANCELLED;
  }

  for (int i = 0; i < threads; i++) {
    if (bounders) bbc_bounder_free(bounders[i]);
    if (thread_stats && cpu_split) {
      st.position_pieces += thread_stats[i].position_pieces;
      st.irradiance_pieces += thread_stats[i].irradiance_pieces;
      st.kept_pieces += thread_stats[i].kept_pieces;
      st.position_cpu_seconds += cpu_split[i].position_seconds;
      st.irradiance_cpu_seconds += cpu_split[i].irradiance_seconds;
    }
  }
  for (int i = 0; pieces && i < threads; i++) free(pieces[i].items);
  free(bounders);
  free(pieces);
  for (int k = 0; k < 2; k++) {
    for (int i = 0; batches[k].arenas && i < threads; i++) {
      free(batches[k].arenas[i].codes);
      free(batches[k].arenas[i].spans);
      free(batches[k].arenas[i].segments);
    }
    free(batches[k].arenas);
    free(batches[k].cells);
    free(batches[k].ids);
    free(batches[k].tuples);
    free(batches[k].candidate);
  }
  free(resume);
  for (int i = 0; rasters && i < threads; i++) {
    free(rasters[i].cells);
    free(rasters[i].row_x0);
    free(rasters[i].row_x1);
  }
  free(rasters);
  for (int i = 0; covers && i < threads; i++) {
    free(covers[i].cells);
    for (int k = 0; k < 2; k++) {
      free(covers[i].row_x0[k]);
      free(covers[i].row_x1[k]);
    }
  }
  free(covers);
  for (int i = 0; i < threads; i++) {
    if (beam_pieces) free(beam_pieces[i].items), free(beam_pieces[i].bound);
    if (beam_scratch) bbc__beam_scratch_free(&beam_scratch[i]);
  }
  for (int i = 0; beam_covers && i < threads; i++) {
    for (uint32_t k = 0; k < beam_covers[i].count; k++) free(beam_covers[i].planes[k].cells);
    free(beam_covers[i].planes);
    free(beam_covers[i].coarse);
    free(beam_covers[i].coarse2);
    free(beam_covers[i].full);
  }
  free(beam_covers);
  free(beam_pieces);
  free(beam_scratch);
  bbc__beam_receivers_free(&beams);
  free(thread_stats);
  free(cpu_split);
  st.construction_seconds += source.search_seconds;
  bbc__candidates_end(&source);
  bbc__census_free(&census);
  if (result != BBC_OK) {
    const char *why = bbc__cache_builder_error(builder);
    if (result != BBC_ERR_CANCELLED)
      bbc__report(options->error_fn, options->user, result, "%s: precompute failed: %s",
                  scene->path, why ? why : bbc_result_string(result));
    bbc_cache_builder_free(builder);
    return result;
  }
  bbc__cache_builder_spill_stats(builder, &st.spill_runs, &st.spill_bytes);
  if (stats) *stats = st;
  if (probe)
    bbc_cache_builder_free(builder);
  else
    *out = builder;
  return BBC_OK;
}

bbc_result bbc_precompute(bbc_cache_builder **out, const bbc_scene *scene,
                          const bbc_precompute_options *options, bbc_precompute_stats *stats) {
  return precompute(out, scene, options, stats, 0);
}

bbc_result bbc_precompute_choose_chains(const bbc_scene *scene,
                                        const bbc_precompute_options *options, double max_pieces,
                                        bbc_chain_choice *choice) {
  if (!scene || !options || !choice) return BBC_ERR_INVALID_ARGUMENT;
  memset(choice, 0, sizeof *choice);
  choice->chains = options->params.chains;
  if (!(options->params.chains & BBC_CHAIN_MASK_DOUBLE)) return BBC_OK;
  /* Every two-bounce type out, nothing to weigh: with a budget of 0, and with beam
   * receivers, where a cached two-bounce type costs the render more than light tracing
   * its caustic (see precompute.h). */
  if (!(max_pieces > 0) || options->params.beam_receivers) {
    choice->left_out = choice->chains & BBC_CHAIN_MASK_DOUBLE;
    choice->chains &= ~BBC_CHAIN_MASK_DOUBLE;
    return BBC_OK;
  }
  /* The probe: the two-bounce chain types alone, every candidate (no shard, so that
   * every shard chooses alike), no estimate callback. */
  bbc_precompute_options probe = *options;
  probe.params.chains &= BBC_CHAIN_MASK_DOUBLE;
  probe.shard_index = probe.shard_count = 0;
  probe.estimate_fn = NULL;
  probe.progress = NULL;
  bbc_cache_builder *none = NULL;
  bbc_precompute_stats st;
  const bbc_result r = precompute(&none, scene, &probe, &st, 1);
  if (r != BBC_OK) return r;
  const bbc_precompute_estimate *e = &st.estimate;
  double total = 0;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    if (!(probe.params.chains & BBC_CHAIN_BIT(c))) continue;
    choice->candidates[c] = e->candidates_per_chain[c];
    choice->pieces[c] = e->pieces_per_chain[c];
    total += e->pieces_per_chain[c];
  }
  /* The costliest type out first, until the rest fit. */
  while (total > max_pieces) {
    int worst = -1;
    for (int c = 0; c < BBC_CHAIN_COUNT; c++)
      if ((choice->chains & BBC_CHAIN_MASK_DOUBLE & BBC_CHAIN_BIT(c)) &&
          (worst < 0 || choice->pieces[c] > choice->pieces[worst]))
        worst = c;
    if (worst < 0) break;
    choice->chains &= ~BBC_CHAIN_BIT(worst);
    choice->left_out |= BBC_CHAIN_BIT(worst);
    total -= choice->pieces[worst];
  }
  return BBC_OK;
}
