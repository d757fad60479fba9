/* Bounds against true paths (Fig. 17): sampling, the renderer's admissibility rule, the
 * piece lookup and the accumulator with its printers. */
#include "bbc/validate.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/specular_path.h"
#include "bbc/texture.h"
#include "rng_internal.h"
#include "light_internal.h"
#include "tuple_search_internal.h"
#include "vec_internal.h"

/* ---- the leaves of one tuple and a grid to find the one holding u1 ------------------ */

/* The leaves are the cells of a quadtree of varying depth, so a lookup by linear search
 * would cost O(leaves) per sample (thousands at the default depth). A uniform grid over
 * their bounding box, each cell listing the leaves whose closed box touches it, brings
 * that down to a handful. */
typedef struct leaf_set {
  bbc_piece *items;
  size_t count, capacity;
  int failed; /* out of memory while collecting */
  /* The grid: G x G cells over [x0, x0 + G / sx] x [y0, y0 + G / sy]; cell c lists
   * index[start[c] .. start[c + 1]). */
  int grid;
  double x0, y0, sx, sy;
  uint32_t *start, *index;
} leaf_set;

static int collect_leaf(void *user, const bbc_piece *piece) {
  leaf_set *l = user;
  if (l->count == l->capacity) {
    size_t capacity = l->capacity ? 2 * l->capacity : 256;
    bbc_piece *grown = realloc(l->items, capacity * sizeof *grown);
    if (!grown) {
      l->failed = 1;
      return 1; /* stops the bounder, which then reports BBC_ERR_CANCELLED */
    }
    l->items = grown;
    l->capacity = capacity;
  }
  l->items[l->count++] = *piece;
  return 0;
}

/* The grid cell of a coordinate, clamped to the grid. The map (x - x0) * s followed by
 * floor is monotonic in x under IEEE rounding, so a point inside a closed leaf box gets
 * a cell between the cells of the box's two edges: exactly the cells the leaf is listed
 * in, and no containing leaf can be missed. */
static int cell_of(double x, double x0, double s, int grid) {
  double f = floor((x - x0) * s);
  if (!(f >= 0)) return 0; /* also catches NaN */
  if (f >= grid - 1) return grid - 1;
  return (int)f;
}

static int build_grid(leaf_set *l) {
  if (l->count == 0) return 1;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (size_t i = 0; i < l->count; i++) {
    x0 = fmin(x0, l->items[i].u_lo), x1 = fmax(x1, l->items[i].u_hi);
    y0 = fmin(y0, l->items[i].v_lo), y1 = fmax(y1, l->items[i].v_hi);
  }
  int grid = (int)ceil(sqrt((double)l->count));
  if (grid < 1) grid = 1;
  if (grid > 256) grid = 256;
  l->grid = grid;
  l->x0 = x0, l->y0 = y0;
  /* A zero-width extent maps everything to cell 0 rather than dividing by zero. */
  l->sx = x1 > x0 ? grid / (x1 - x0) : 0.0;
  l->sy = y1 > y0 ? grid / (y1 - y0) : 0.0;
  size_t cells = (size_t)grid * (size_t)grid;
  l->start = calloc(cells + 1, sizeof *l->start);
  if (!l->start) return 0;
  /* Two passes: count the entries of every cell, then fill them in leaf order, so a
   * cell lists its leaves in the bounder's breadth-first order. */
  size_t total = 0;
  for (int pass = 0; pass < 2; pass++) {
    for (size_t i = 0; i < l->count; i++) {
      const bbc_piece *q = &l->items[i];
      int cx0 = cell_of(q->u_lo, l->x0, l->sx, grid), cx1 = cell_of(q->u_hi, l->x0, l->sx, grid);
      int cy0 = cell_of(q->v_lo, l->y0, l->sy, grid), cy1 = cell_of(q->v_hi, l->y0, l->sy, grid);
      for (int cy = cy0; cy <= cy1; cy++)
        for (int cx = cx0; cx <= cx1; cx++) {
          size_t c = (size_t)cy * grid + cx;
          if (pass == 0)
            l->start[c + 1]++;
          else
            l->index[l->start[c]++] = (uint32_t)i;
        }
    }
    if (pass == 0) {
      for (size_t c = 0; c < cells; c++) l->start[c + 1] += l->start[c];
      total = l->start[cells];
      l->index = malloc((total ? total : 1) * sizeof *l->index);
      if (!l->index) return 0;
    } else {
      /* The fill advanced every start to the next cell's; shift them back. */
      memmove(l->start + 1, l->start, cells * sizeof *l->start);
      l->start[0] = 0;
    }
  }
  return 1;
}

/* The leaf holding (u, v): the first kept leaf whose closed box contains it, else the
 * first discarded one, else NULL. Kept leaves win on shared edges because their bounds
 * hold on their whole closed box, while a discarded neighbour only proves its own
 * interior empty of paths up to the edge. */
static const bbc_piece *find_leaf(const leaf_set *l, double u, double v, const double *ab) {
  if (l->count == 0) return NULL;
  size_t c = (size_t)cell_of(v, l->y0, l->sy, l->grid) * l->grid +
             (size_t)cell_of(u, l->x0, l->sx, l->grid);
  const bbc_piece *discarded = NULL;
  for (uint32_t k = l->start[c]; k < l->start[c + 1]; k++) {
    const bbc_piece *q = &l->items[l->index[k]];
    if (!(u >= q->u_lo && u <= q->u_hi && v >= q->v_lo && v <= q->v_hi)) continue;
    /* Area lights: the piece's light box must hold the emitter point's (a, b) too. */
    if (ab && !(ab[0] >= q->a_lo && ab[0] <= q->a_hi && ab[1] >= q->b_lo && ab[1] <= q->b_hi))
      continue;
    if (q->status == BBC_PIECE_KEPT) return q;
    if (!discarded) discarded = q;
  }
  return discarded;
}

static void free_leaves(leaf_set *l) {
  free(l->items);
  free(l->start);
  free(l->index);
}

/* ---- the accumulator ---------------------------------------------------------------- */

void bbc_validation_reset(bbc_validation *acc) {
  if (acc) memset(acc, 0, sizeof *acc);
}

void bbc_validation_merge(bbc_validation *dst, const bbc_validation *src) {
  if (!dst || !src || dst == src) return;
  if (src->failing && !dst->failing) dst->first_failure = src->first_failure;
  if (src->ratio_count) {
    dst->min_log_ratio =
        dst->ratio_count ? fmin(dst->min_log_ratio, src->min_log_ratio) : src->min_log_ratio;
    dst->max_log_ratio =
        dst->ratio_count ? fmax(dst->max_log_ratio, src->max_log_ratio) : src->max_log_ratio;
    dst->sum_log_ratio += src->sum_log_ratio;
  }
  dst->tuples += src->tuples;
  dst->samples += src->samples;
  dst->admissible += src->admissible;
  dst->position_violations += src->position_violations;
  dst->upper_violations += src->upper_violations;
  dst->lower_violations += src->lower_violations;
  dst->in_discarded += src->in_discarded;
  dst->uncovered += src->uncovered;
  dst->failing += src->failing;
  dst->unbounded += src->unbounded;
  dst->ratio_count += src->ratio_count;
  dst->underflow += src->underflow;
  dst->overflow += src->overflow;
  for (int i = 0; i < BBC_VALIDATION_BINS; i++) dst->bins[i] += src->bins[i];
}

uint64_t bbc_validation_failures(const bbc_validation *acc) {
  return acc ? acc->failing : 0;
}

static void add_ratio(bbc_validation *acc, double lr) {
  if (acc->ratio_count == 0) {
    acc->min_log_ratio = acc->max_log_ratio = lr;
  } else {
    acc->min_log_ratio = fmin(acc->min_log_ratio, lr);
    acc->max_log_ratio = fmax(acc->max_log_ratio, lr);
  }
  acc->ratio_count++;
  acc->sum_log_ratio += lr;
  double f = floor((lr - BBC_VALIDATION_LOG_MIN) * BBC_VALIDATION_BINS_PER_DECADE);
  if (f < 0)
    acc->underflow++;
  else if (f >= BBC_VALIDATION_BINS)
    acc->overflow++;
  else
    acc->bins[(int)f]++;
}

/* The histogram position LOG_MIN + (numerator / denominator) bin widths, computed from
 * integers with one rounding so that edges and midpoints print as the round decimals
 * they are (0.105, not 0.10499999999999998). */
static double bin_edge(int numerator, int denominator) {
  const double per_decade = (double)BBC_VALIDATION_BINS_PER_DECADE * denominator;
  return (BBC_VALIDATION_LOG_MIN * per_decade + numerator) / per_decade;
}

double bbc_validation_log_ratio_quantile(const bbc_validation *acc, double q) {
  if (!acc || acc->ratio_count == 0 || !(q >= 0 && q <= 1)) return NAN;
  /* The rank (1-based) of the wanted ratio in sorted order. */
  uint64_t n = acc->ratio_count;
  uint64_t rank = (uint64_t)ceil(q * (double)n);
  if (rank < 1) rank = 1;
  if (rank > n) rank = n;
  uint64_t seen = acc->underflow;
  if (rank <= seen) return acc->min_log_ratio;
  for (int i = 0; i < BBC_VALIDATION_BINS; i++) {
    seen += acc->bins[i];
    if (rank <= seen) return bin_edge(2 * i + 1, 2);
  }
  return acc->max_log_ratio;
}

/* ---- validating a tuple ------------------------------------------------------------- */

void bbc_validation_sample_u1(uint64_t seed, const bbc_tuple *tuple, uint32_t sample,
                              double u1[2]) {
  /* The tuple's own indices, not its position in some list, key the stream: the same
   * tuple gets the same samples whichever subset of tuples a tool validates. */
  uint64_t key = bbc__mix64(((uint64_t)tuple->light << 32) ^ tuple->chain) ^
                 (((uint64_t)tuple->specular[0] << 32) | tuple->receiver);
  if (bbc_chain_length((bbc_chain)tuple->chain) == 2) key = bbc__mix64(key ^ tuple->specular[1]);
  bbc_rng rng = bbc_rng_make(seed, sample, key);
  double a = bbc_rng_next(&rng), c = bbc_rng_next(&rng);
  /* Folding the unit square's upper triangle onto the lower one keeps the density
   * uniform over T1. */
  if (a + c > 1) {
    a = 1 - a;
    c = 1 - c;
  }
  u1[0] = a;
  u1[1] = c;
}

/* Area lights: the emitter point of sample `sample`, (a, b) = (sqrt r1, r2) with uniform
 * r1, r2 from a stream of its own (uniform by area, scene.h), a pure function of (seed,
 * tuple, sample). */
static void sample_emitter(uint64_t seed, const bbc_tuple *tuple, uint32_t sample, double ab[2]) {
  uint64_t key = bbc__mix64(((uint64_t)tuple->light << 32) ^ 0xA5EA11u) ^
                 (((uint64_t)tuple->specular[0] << 32) | tuple->receiver);
  bbc_rng rng = bbc_rng_make(seed, sample, key);
  ab[0] = sqrt(bbc_rng_next(&rng));
  ab[1] = bbc_rng_next(&rng);
}

static void record_failure(bbc_validation *acc, const bbc_tuple *tuple, uint32_t sample,
                           uint32_t kinds, const bbc_specular_path *path, const bbc_piece *piece) {
  if (acc->failing++ > 0) return;
  bbc_validation_failure *f = &acc->first_failure;
  memset(f, 0, sizeof *f);
  f->tuple = *tuple;
  f->sample = sample;
  f->kinds = kinds;
  f->u1[0] = path->u1[0], f->u1[1] = path->u1[1];
  f->uk[0] = path->uk[0], f->uk[1] = path->uk[1];
  f->irradiance = path->irradiance;
  if (piece) f->piece = *piece;
}

/* The bounder turned T1's normals toward the light and T2's toward T1 (bounds.h), while
 * the path geometry keeps a refracting triangle's normals as loaded. The bounder negates
 * all three normals of a triangle or none, so the sign of the summed dot products says
 * whether the two agree. */
typedef struct orientation {
  int t1, t2; /* +1 where bounds and path geometry agree, -1 where they are opposite */
} orientation;

static orientation orientation_of(const bbc_tuple_geometry *tg, const bbc_path_geometry *pg) {
  double a1 = 0, a2 = 0;
  for (int i = 0; i < 3; i++) {
    a1 += v3_dot(tg->n[i], pg->specular[0].n[i]);
    if (pg->length == 2) a2 += v3_dot(tg->n2[i], pg->specular[1].n[i]);
  }
  orientation o = {a1 > 0 ? 1 : -1, a2 > 0 ? 1 : -1};
  return o;
}

/* Whether a point of the tuple's path is cut out (bbc_scene_coverage 0): a specular
 * vertex there is no vertex, an emitter point there emits nothing. Partial coverage
 * (BLEND) scales a path like Fresnel does and is not part of the check. */
static int cut_out(const bbc_scene *scene, uint32_t triangle, const double b[2]) {
  return !(bbc_scene_coverage(scene, triangle, b[0], b[1]) > 0);
}

/* Traces u1 and applies the renderer's rule (caustics.c): no rejecting flag, no vertex
 * in a cut-out and, at a refracting vertex, the light arriving from the side the bounds
 * were computed for. */
static int admissible_path(const bbc_scene *scene, const bbc_tuple *tuple,
                           const bbc_path_geometry *pg, orientation o, const double u1[2],
                           bbc_specular_path *path) {
  if (bbc_specular_path_trace(pg, u1[0], u1[1], path) != BBC_OK) return 0;
  if (path->flags & BBC_PATH_REJECT) return 0;
  if (cut_out(scene, tuple->specular[0], path->u1) ||
      (pg->length == 2 && cut_out(scene, tuple->specular[1], path->u2)))
    return 0;
  double b[2];
  if (pg->light_model.kind == BBC_LIGHT_AREA &&
      bbc_triangle_barycentrics(pg->light_model.emitter, pg->light, b) &&
      cut_out(scene, scene->emitters[tuple->light - scene->point_light_count], b))
    return 0;
  if (pg->light_model.kind == BBC_LIGHT_AREA) {
    /* pg->light is the emitter point: the path's value per unit radiance is A_e
     * cos(theta_e) times its point-light irradiance, 0 behind the emitter. */
    double w = bbc__area_weight(&pg->light_model, pg->light, path->x1);
    if (!(w > 0)) return 0;
    path->irradiance *= w;
  }
  if (pg->specular[0].refract &&
      o.t1 * v3_dot(bbc__light_d0(pg->light, &pg->light_model, path->x1), path->n1) >= 0)
    return 0;
  if (pg->length == 2 && pg->specular[1].refract &&
      o.t2 * v3_dot(v3_sub(path->x2, path->x1), path->n2) >= 0)
    return 0;
  return 1;
}

/* The first receiver triangle not on a plane, or UINT32_MAX. */
static uint32_t first_beam_triangle(const bbc_scene *scene) {
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    if (scene->meshes[m].role == BBC_ROLE_RECEIVER && !scene->meshes[m].plane &&
        scene->meshes[m].triangle_count > 0)
      return scene->meshes[m].first_triangle;
  return UINT32_MAX;
}

/* Whether the ray o + t d, t > 0, can meet the box of triangle t (grown by a margin far
 * above the rounding of the test): a filter only, every landing is then traced. */
static int ray_may_meet(const bbc_scene *scene, uint32_t t, bbc_vec3 o, bbc_vec3 d) {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int j = 0; j < 3; j++) {
    const float *p = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + j];
    for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], p[a]), hi[a] = fmax(hi[a], p[a]);
  }
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  double t0 = 0, t1 = INFINITY;
  for (int a = 0; a < 3; a++) {
    const double m = 1e-6 * (1 + fabs(lo[a]) + fabs(hi[a]));
    const double l = lo[a] - m, h = hi[a] + m;
    if (dd[a] == 0) {
      if (oo[a] < l || oo[a] > h) return 0;
      continue;
    }
    double ta = (l - oo[a]) / dd[a], tb = (h - oo[a]) / dd[a];
    if (ta > tb) {
      const double x = ta;
      ta = tb, tb = x;
    }
    t0 = fmax(t0, ta), t1 = fmin(t1, tb);
  }
  return t0 <= t1 * (1 + 1e-9) + 1e-12;
}

/* Called for each landing of a beam tuple's path on a receiver triangle; non-zero stops
 * with that result. */
typedef bbc_result (*landing_fn)(void *user, uint32_t triangle, const bbc_specular_path *path);

/* The landings of the path of beam tuple `tuple` through u1 (pgi: its path geometry with
 * any receiver; light point drawn): every receiver triangle not on a plane that the
 * last segment meets, traced with that triangle as the receiver and admissible there. */
static bbc_result beam_landings(const bbc_scene *scene, const bbc_tuple *tuple,
                                const bbc_path_geometry *pgi, orientation o, const double u1[2],
                                landing_fn fn, void *user) {
  /* The last segment's line, from a trace to the first triangle's plane, to skip the
   * triangles it cannot meet; every triangle when that trace says nothing. */
  bbc_specular_path probe;
  int filter = 0;
  bbc_vec3 from = v3(0, 0, 0), dir = v3(0, 0, 0);
  if (bbc_specular_path_trace(pgi, u1[0], u1[1], &probe) == BBC_OK && probe.complete &&
      !(probe.flags & (BBC_PATH_TIR | BBC_PATH_DEGENERATE))) {
    from = pgi->length == 2 ? probe.x2 : probe.x1;
    dir = v3_sub(probe.xk, from);
    /* xk behind the last vertex: the ray goes the other way (one vertex; with two the
     * flag may be x2's, and then every triangle is traced). */
    if (probe.flags & BBC_PATH_BACKWARD && pgi->length == 1) dir = v3_scale(dir, -1);
    filter = v3_dot(dir, dir) > 0 && !(probe.flags & BBC_PATH_BACKWARD && pgi->length == 2);
  }
  /* Where the light can land: a landing outside that box crosses the closed mesh the
   * light is in, so it is no path of the chain (the search's medium rule). */
  double lo[3] = {-INFINITY, -INFINITY, -INFINITY}, hi[3] = {INFINITY, INFINITY, INFINITY};
  bbc__tuple_landing_box(scene, tuple, lo, hi);
  bbc_tuple ended = *tuple;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER || mesh->plane) continue;
    for (uint32_t t = mesh->first_triangle; t < mesh->first_triangle + mesh->triangle_count; t++) {
      if (filter && !ray_may_meet(scene, t, from, dir)) continue;
      bbc_path_geometry pgt = *pgi;
      ended.receiver = t;
      if (!bbc_receiver_triangle(scene, t, pgt.receiver)) continue;
      bbc_specular_path path;
      if (!admissible_path(scene, &ended, &pgt, o, u1, &path)) continue;
      const double x[3] = {path.xk.x, path.xk.y, path.xk.z};
      int outside = 0;
      for (int a = 0; a < 3; a++) outside |= !(x[a] >= lo[a] && x[a] <= hi[a]);
      if (outside) continue;
      bbc_result r = fn(user, t, &path);
      if (r != BBC_OK) return r;
    }
  }
  return BBC_OK;
}

/* A beam tuple's geometries, with the first receiver triangle not on a plane standing
 * in for the receiver (the bounds ignore it; each landing is traced to its own). */
static bbc_result beam_geometries(const bbc_scene *scene, const bbc_tuple *tuple,
                                  bbc_tuple_geometry *tg, bbc_path_geometry *pg) {
  bbc_tuple ended = *tuple;
  ended.receiver = first_beam_triangle(scene);
  if (ended.receiver == UINT32_MAX) return BBC_ERR_INVALID_ARGUMENT;
  bbc_result r = bbc_tuple_geometry_init(tg, scene, &ended);
  return r == BBC_OK ? bbc_path_geometry_init(pg, scene, &ended) : r;
}

typedef struct cached_landing {
  bbc_validation *acc;
  bbc_cache_cursor *cursor;
  const bbc_tuple *tuple;
  int64_t tuple_id;
  uint32_t sample;
  double scale;
} cached_landing;

static bbc_result check_cached_landing(void *user, uint32_t t, const bbc_specular_path *path) {
  cached_landing *c = user;
  bbc_validation *v = c->acc;
  v->admissible++;
  if (c->tuple_id < 0) {
    v->in_discarded++;
    record_failure(v, c->tuple, c->sample, BBC_VALIDATION_DISCARDED, path, NULL);
    return BBC_OK;
  }
  const bbc_cache_entry *entries = NULL;
  uint32_t n = 0;
  bbc_result r = bbc_cache_lookup(c->cursor, t, path->uk[0], path->uk[1], &path->xk, &entries, &n);
  if (r != BBC_OK) return r;
  const bbc_cache_entry *found = NULL;
  for (uint32_t k = 0; k < n && !found; k++)
    if (entries[k].tuple == (uint32_t)c->tuple_id) found = &entries[k];
  if (!found) {
    v->position_violations++;
    record_failure(v, c->tuple, c->sample, BBC_VALIDATION_POSITION, path, NULL);
    return BBC_OK;
  }
  const double e = path->irradiance * c->scale;
  if (!(e <= (double)found->bound)) {
    v->upper_violations++;
    record_failure(v, c->tuple, c->sample, BBC_VALIDATION_UPPER, path, NULL);
  }
  if (!isfinite(found->bound))
    v->unbounded++;
  else if (e >= 0 && e < INFINITY)
    add_ratio(v, e > 0 ? log10(found->bound / e) : INFINITY);
  return BBC_OK;
}

/* A beam tuple's true paths: each sampled path lands on every receiver triangle not on
 * a plane that its last segment meets, and each landing must be listed in its cell with
 * a bound of at least its irradiance on that triangle. */
static bbc_result validate_cached_beam(const bbc_cache *cache, bbc_cache_cursor *cursor,
                                       const bbc_scene *scene, const bbc_tuple *tuple,
                                       int64_t tuple_id, uint32_t samples, uint64_t seed,
                                       bbc_validation *acc) {
  bbc_tuple_geometry tg;
  bbc_path_geometry pg;
  bbc_result r = beam_geometries(scene, tuple, &tg, &pg);
  if (r != BBC_OK) return r;
  const orientation o = orientation_of(&tg, &pg);
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  float radiance[3];
  const float *intensity = bbc__cache_light_intensity(scene, tuple->light, radiance);
  const int area = tg.light_model.kind == BBC_LIGHT_AREA;
  bbc_validation local;
  bbc_validation_reset(&local);
  local.tuples = 1;
  cached_landing c = {&local, cursor,
                      tuple,  tuple_id,
                      0,      fmax(intensity[0], fmax(intensity[1], intensity[2])) * info.params.m};
  for (uint32_t i = 0; i < samples && r == BBC_OK; i++) {
    double u1[2];
    bbc_validation_sample_u1(seed, tuple, i, u1);
    local.samples++;
    bbc_path_geometry pgi = pg;
    if (area) {
      double ab[2];
      sample_emitter(seed, tuple, i, ab);
      pgi.light = bbc__area_point(&pg.light_model, ab[0], ab[1]);
    }
    c.sample = i;
    r = beam_landings(scene, tuple, &pgi, o, u1, check_cached_landing, &c);
  }
  if (r != BBC_OK) return r;
  bbc_validation_merge(acc, &local);
  return BBC_OK;
}

/* ---- the bounds of a beam tuple (bbc_bound_beam) against its true paths ---------------- */

/* The kept pieces of a beam, in the order reported. */
typedef struct beam_leaves {
  bbc_beam_piece *items;
  size_t count, capacity;
  int failed;
} beam_leaves;

static int collect_beam_leaf(void *user, const bbc_beam_piece *piece) {
  beam_leaves *l = user;
  if (piece->status != BBC_PIECE_KEPT) return 0;
  if (l->count == l->capacity) {
    const size_t capacity = l->capacity ? 2 * l->capacity : 64;
    bbc_beam_piece *grown = realloc(l->items, capacity * sizeof *grown);
    if (!grown) {
      l->failed = 1;
      return 1;
    }
    l->items = grown;
    l->capacity = capacity;
  }
  l->items[l->count++] = *piece;
  return 0;
}

/* A landing and the kept pieces whose u1 boxes hold its u1 (one per slab of the
 * distance along the ray when the beam split it). */
typedef struct bound_landing {
  bbc_validation *acc;
  const bbc_tuple *tuple;
  const bbc_beam_piece **pieces;
  size_t count;
  uint32_t sample;
} bound_landing;

/* A landing must lie in the box of one of the pieces, with its irradiance at most that
 * piece's e_hi. (e_lo bounds the irradiance on the surface normal to the ray from
 * below, not on the surface it lands on: it is not checked.) */
static bbc_result check_bound_landing(void *user, uint32_t t, const bbc_specular_path *path) {
  (void)t;
  bound_landing *c = user;
  bbc_validation *v = c->acc;
  v->admissible++;
  const double x[3] = {path->xk.x, path->xk.y, path->xk.z};
  double e_hi = -INFINITY;
  int inside = 0;
  for (size_t k = 0; k < c->count; k++) {
    const bbc_beam_piece *q = c->pieces[k];
    int in = 1;
    for (int a = 0; a < 3; a++)
      if (!(x[a] >= q->box_lo[a] && x[a] <= q->box_hi[a])) in = 0;
    if (in) inside = 1, e_hi = fmax(e_hi, q->e_hi);
  }
  uint32_t kinds = 0;
  const double e = path->irradiance;
  if (!inside) {
    kinds = BBC_VALIDATION_POSITION;
    v->position_violations++;
  } else if (!(e <= e_hi)) {
    kinds = BBC_VALIDATION_UPPER;
    v->upper_violations++;
  }
  if (kinds) record_failure(v, c->tuple, c->sample, kinds, path, NULL);
  if (!inside) return BBC_OK;
  if (!isfinite(e_hi))
    v->unbounded++;
  else if (e >= 0 && e < INFINITY)
    add_ratio(v, e > 0 ? log10(e_hi / e) : INFINITY);
  return BBC_OK;
}

static bbc_result count_landing(void *user, uint32_t t, const bbc_specular_path *path) {
  (void)t, (void)path;
  ((bbc_validation *)user)->admissible++;
  return BBC_OK;
}

/* bbc_validate_tuple for a beam tuple: bbc_bound_beam over the box of the receivers not
 * on a plane (narrowed to where its light can land, bbc__tuple_landing_box); every landing of a
 * sampled true path must lie in the box of the kept piece holding its u1, with its irradiance on
 * the triangle it lands on in [e_lo, e_hi]. */
static bbc_result validate_beam(bbc_bounder *bounder, const bbc_scene *scene,
                                const bbc_tuple *tuple, const bbc_bound_params *params,
                                uint32_t samples, uint64_t seed, bbc_validation *acc) {
  bbc_tuple_geometry tg;
  bbc_path_geometry pg;
  bbc_result r = beam_geometries(scene, tuple, &tg, &pg);
  if (r != BBC_OK) return r;
  const orientation o = orientation_of(&tg, &pg);
  const int area = tg.light_model.kind == BBC_LIGHT_AREA;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER || mesh->plane) continue;
    for (uint32_t v = 0; v < mesh->vertex_count; v++) {
      const float *p = scene->positions + 3 * (size_t)(mesh->first_vertex + v);
      for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], p[a]), hi[a] = fmax(hi[a], p[a]);
    }
  }
  bbc_bound_params defaults;
  if (!params) {
    memset(&defaults, 0, sizeof defaults);
    params = &defaults;
  }
  beam_leaves leaves;
  memset(&leaves, 0, sizeof leaves);
  /* Narrowed as bbc_precompute narrows it (nothing left: no piece, and no landing). */
  if (bbc__tuple_landing_box(scene, tuple, lo, hi))
    r = bbc_bound_beam(bounder, &tg, lo, hi, params, collect_beam_leaf, &leaves, NULL);
  if (leaves.failed) r = BBC_ERR_OUT_OF_MEMORY;
  const bbc_beam_piece **held = malloc((leaves.count ? leaves.count : 1) * sizeof *held);
  if (r == BBC_OK && !held) r = BBC_ERR_OUT_OF_MEMORY;
  bbc_validation local;
  bbc_validation_reset(&local);
  local.tuples = 1;
  for (uint32_t i = 0; i < samples && r == BBC_OK; i++) {
    double u1[2], ab[2] = {0, 0};
    bbc_validation_sample_u1(seed, tuple, i, u1);
    local.samples++;
    bbc_path_geometry pgi = pg;
    if (area) {
      sample_emitter(seed, tuple, i, ab);
      pgi.light = bbc__area_point(&pg.light_model, ab[0], ab[1]);
    }
    bound_landing c = {&local, tuple, held, 0, i};
    for (size_t k = 0; k < leaves.count; k++) {
      const bbc_beam_piece *q = &leaves.items[k];
      if (u1[0] >= q->u_lo && u1[0] <= q->u_hi && u1[1] >= q->v_lo && u1[1] <= q->v_hi &&
          (!area || (ab[0] >= q->a_lo && ab[0] <= q->a_hi && ab[1] >= q->b_lo && ab[1] <= q->b_hi)))
        held[c.count++] = q;
    }
    if (c.count) {
      r = beam_landings(scene, tuple, &pgi, o, u1, check_bound_landing, &c);
      continue;
    }
    /* No kept piece: every landing is a violation. */
    bbc_validation before = local;
    r = beam_landings(scene, tuple, &pgi, o, u1, count_landing, &local);
    const uint64_t landed = local.admissible - before.admissible;
    if (landed) {
      local.uncovered += landed;
      record_failure(&local, tuple, i, BBC_VALIDATION_UNCOVERED, &(bbc_specular_path){0}, NULL);
    }
  }
  free(held);
  free(leaves.items);
  if (r != BBC_OK) return r;
  bbc_validation_merge(acc, &local);
  return BBC_OK;
}

bbc_result bbc_validate_tuple(bbc_bounder *bounder, const bbc_scene *scene, const bbc_tuple *tuple,
                              const bbc_bound_params *params, uint32_t samples, uint64_t seed,
                              bbc_validation *acc) {
  if (!bounder || !scene || !tuple || !acc) return BBC_ERR_INVALID_ARGUMENT;
  if (tuple->chain >= BBC_CHAIN_COUNT) return BBC_ERR_INVALID_ARGUMENT;
  if (bbc_receiver_is_beam(tuple->receiver))
    return validate_beam(bounder, scene, tuple, params, samples, seed, acc);
  bbc_tuple_geometry tg;
  bbc_path_geometry pg;
  bbc_result r = bbc_tuple_geometry_init(&tg, scene, tuple);
  if (r != BBC_OK) return r;
  if ((r = bbc_path_geometry_init(&pg, scene, tuple)) != BBC_OK) return r;

  const orientation o = orientation_of(&tg, &pg);
  const int area = tg.light_model.kind == BBC_LIGHT_AREA;

  bbc_bound_params defaults;
  if (!params) {
    memset(&defaults, 0, sizeof defaults);
    params = &defaults;
  }
  leaf_set leaves;
  memset(&leaves, 0, sizeof leaves);
  r = bbc_bound_tuple(bounder, &tg, params, collect_leaf, &leaves, NULL);
  if (leaves.failed) r = BBC_ERR_OUT_OF_MEMORY;
  if (r == BBC_OK && !build_grid(&leaves)) r = BBC_ERR_OUT_OF_MEMORY;
  if (r != BBC_OK) {
    free_leaves(&leaves);
    return r;
  }

  /* Every failure is behind us: from here on only counts are added, so a failing call
   * leaves *acc as it was. */
  acc->tuples++;
  for (uint32_t i = 0; i < samples; i++) {
    double u1[2];
    bbc_validation_sample_u1(seed, tuple, i, u1);
    acc->samples++;
    bbc_specular_path path;
    double ab[2] = {0, 0};
    bbc_path_geometry pgi = pg;
    if (area) {
      sample_emitter(seed, tuple, i, ab);
      pgi.light = bbc__area_point(&pg.light_model, ab[0], ab[1]);
    }
    if (!admissible_path(scene, tuple, &pgi, o, u1, &path)) continue;
    acc->admissible++;

    const bbc_piece *piece = find_leaf(&leaves, u1[0], u1[1], area ? ab : NULL);
    if (!piece) {
      acc->uncovered++;
      record_failure(acc, tuple, i, BBC_VALIDATION_UNCOVERED, &path, NULL);
      continue;
    }
    if (piece->status == BBC_PIECE_DISCARDED) {
      acc->in_discarded++;
      record_failure(acc, tuple, i, BBC_VALIDATION_DISCARDED, &path, piece);
      continue;
    }
    uint32_t kinds = 0;
    if (!bbc_piece_position_contains(piece, path.uk[0], path.uk[1])) {
      kinds |= BBC_VALIDATION_POSITION;
      acc->position_violations++;
    }
    /* Written as negations so that a NaN irradiance fails both tests. */
    const double e = path.irradiance;
    if (!(e <= piece->e_hi)) {
      kinds |= BBC_VALIDATION_UPPER;
      acc->upper_violations++;
    }
    if (!(e >= piece->e_lo)) {
      kinds |= BBC_VALIDATION_LOWER;
      acc->lower_violations++;
    }
    if (kinds) record_failure(acc, tuple, i, kinds, &path, piece);

    if (!isfinite(piece->e_hi)) {
      acc->unbounded++;
    } else if (e >= 0 && e < INFINITY) {
      /* e = 0 makes the ratio +inf, which lands in the overflow count. */
      add_ratio(acc, e > 0 ? log10(piece->e_hi / e) : INFINITY);
    }
  }
  free_leaves(&leaves);
  return BBC_OK;
}

bbc_result bbc_validate_cached_tuple(const bbc_cache *cache, bbc_cache_cursor *cursor,
                                     const bbc_scene *scene, const bbc_tuple *tuple,
                                     int64_t tuple_id, uint32_t samples, uint64_t seed,
                                     bbc_validation *acc) {
  if (!cache || !cursor || !scene || !tuple || !acc) return BBC_ERR_INVALID_ARGUMENT;
  if (tuple->chain >= BBC_CHAIN_COUNT) return BBC_ERR_INVALID_ARGUMENT;
  if (bbc_receiver_is_beam(tuple->receiver))
    return validate_cached_beam(cache, cursor, scene, tuple, tuple_id, samples, seed, acc);
  bbc_tuple_geometry tg;
  bbc_path_geometry pg;
  bbc_result r = bbc_tuple_geometry_init(&tg, scene, tuple);
  if (r != BBC_OK) return r;
  if ((r = bbc_path_geometry_init(&pg, scene, tuple)) != BBC_OK) return r;
  const orientation o = orientation_of(&tg, &pg);
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  const bbc_precompute_params params = info.params;
  /* The stored bound is per tuple and cell, with the light's brightest channel and m. */
  float radiance[3];
  const float *intensity = bbc__cache_light_intensity(scene, tuple->light, radiance);
  const double scale = fmax(intensity[0], fmax(intensity[1], intensity[2])) * params.m;
  const int area = tg.light_model.kind == BBC_LIGHT_AREA;
  bbc_validation local;
  bbc_validation_reset(&local);
  local.tuples = 1;
  for (uint32_t i = 0; i < samples; i++) {
    double u1[2];
    bbc_validation_sample_u1(seed, tuple, i, u1);
    local.samples++;
    bbc_specular_path path;
    bbc_path_geometry pgi = pg;
    if (area) {
      double ab[2];
      sample_emitter(seed, tuple, i, ab);
      pgi.light = bbc__area_point(&pg.light_model, ab[0], ab[1]);
    }
    if (!admissible_path(scene, tuple, &pgi, o, u1, &path)) continue;
    /* A path to a receiver's plane past its grid misses the mesh: no path. */
    bbc_cell cell;
    if (bbc_receiver_is_plane(tuple->receiver) &&
        !bbc_grid_locate(bbc_cache_grid(cache), tuple->receiver, path.uk[0], path.uk[1], NULL,
                         &cell))
      continue;
    local.admissible++;
    if (tuple_id < 0) {
      /* The precompute proved this tuple empty and stored nothing. */
      local.in_discarded++;
      record_failure(&local, tuple, i, BBC_VALIDATION_DISCARDED, &path, NULL);
      continue;
    }
    /* The renderer's lookup: a plane's point is located by its position, whichever of
     * the plane's triangles it lies on. */
    const uint32_t at = bbc_receiver_is_plane(tuple->receiver)
                            ? scene->meshes[bbc_receiver_plane_mesh(tuple->receiver)].first_triangle
                            : tuple->receiver;
    const bbc_cache_entry *entries = NULL;
    uint32_t n = 0;
    if ((r = bbc_cache_lookup(cursor, at, path.uk[0], path.uk[1], &path.xk, &entries, &n)) !=
        BBC_OK)
      return r;
    const bbc_cache_entry *found = NULL;
    for (uint32_t k = 0; k < n && !found; k++)
      if (entries[k].tuple == (uint32_t)tuple_id) found = &entries[k];
    if (!found) {
      local.position_violations++;
      record_failure(&local, tuple, i, BBC_VALIDATION_POSITION, &path, NULL);
      continue;
    }
    const double e = path.irradiance * scale;
    if (!(e <= (double)found->bound)) {
      local.upper_violations++;
      record_failure(&local, tuple, i, BBC_VALIDATION_UPPER, &path, NULL);
    }
    if (!isfinite(found->bound)) local.unbounded++;
    else if (e >= 0 && e < INFINITY) add_ratio(&local, e > 0 ? log10(found->bound / e) : INFINITY);
  }
  bbc_validation_merge(acc, &local);
  return BBC_OK;
}

/* ---- printing ----------------------------------------------------------------------- */

bbc_result bbc_validation_print_summary(const bbc_validation *acc, const char *label, FILE *out) {
  if (!acc || !out) return BBC_ERR_INVALID_ARGUMENT;
  if (label) fprintf(out, "%s: ", label);
  fprintf(
      out,
      "%" PRIu64 " tuples, %" PRIu64 " samples, %" PRIu64 " admissible paths; violations: %" PRIu64
      " position, %" PRIu64 " upper, %" PRIu64 " lower, %" PRIu64 " in discarded pieces, %" PRIu64
      " uncovered (%" PRIu64 " failing paths); %" PRIu64 " unbounded",
      acc->tuples, acc->samples, acc->admissible, acc->position_violations, acc->upper_violations,
      acc->lower_violations, acc->in_discarded, acc->uncovered, acc->failing, acc->unbounded);
  if (acc->ratio_count)
    fprintf(out,
            "; log10(E_hi/E) over %" PRIu64 " paths: median %.3f, p99 %.3f, min %.3g, max %.3g",
            acc->ratio_count, bbc_validation_log_ratio_quantile(acc, 0.5),
            bbc_validation_log_ratio_quantile(acc, 0.99), acc->min_log_ratio, acc->max_log_ratio);
  fputc('\n', out);
  return ferror(out) ? BBC_ERR_IO : BBC_OK;
}

/* One row of the text histogram: its label, count and a bar scaled to the peak row. A
 * non-zero count gets at least one mark, so rare rows (a few violations below 0) stay
 * visible. */
static void histogram_row(FILE *out, const char *label, uint64_t n, uint64_t peak) {
  static const char marks[] = "##################################################";
  const uint64_t width = sizeof marks - 1;
  int bar = n && peak ? (int)((width * n + peak - 1) / peak) : 0;
  fprintf(out, "  %-18s %10" PRIu64 "%s%.*s\n", label, n, bar ? " " : "", bar, marks);
}

bbc_result bbc_validation_print_histogram(const bbc_validation *acc, FILE *out) {
  if (!acc || !out) return BBC_ERR_INVALID_ARGUMENT;
  enum { MAX_ROWS = 40 };
  int first = -1, last = -1;
  for (int i = 0; i < BBC_VALIDATION_BINS; i++)
    if (acc->bins[i]) {
      if (first < 0) first = i;
      last = i;
    }
  /* Rows group a round number of bins, aligned to multiples of it, so their edges are
   * round numbers too. */
  static const int groups[] = {1, 2, 5, 10, 20, 50, 100, 200, 500, 1000};
  int group = 1;
  if (first >= 0)
    for (size_t g = 0; g < sizeof groups / sizeof *groups; g++) {
      group = groups[g];
      if (last / group - first / group + 1 <= MAX_ROWS) break;
    }
  const int rows = first >= 0 ? last / group - first / group + 1 : 0;
  uint64_t peak = acc->underflow > acc->overflow ? acc->underflow : acc->overflow;
  for (int pass = 0; pass < 2; pass++) {
    if (pass == 1) {
      fprintf(out, "log10(E_hi / E), %" PRIu64 " paths:\n", acc->ratio_count);
      if (acc->underflow) {
        char label[32];
        snprintf(label, sizeof label, "< %.2f", BBC_VALIDATION_LOG_MIN);
        histogram_row(out, label, acc->underflow, peak);
      }
    }
    /* The first pass finds the peak row, the second prints. */
    for (int row = first / group; row < first / group + rows; row++) {
      uint64_t n = 0;
      for (int i = row * group; i < (row + 1) * group && i < BBC_VALIDATION_BINS; i++)
        n += acc->bins[i];
      if (pass == 0) {
        if (n > peak) peak = n;
        continue;
      }
      char label[32];
      snprintf(label, sizeof label, "[%.2f, %.2f)", bin_edge(row * group, 1),
               bin_edge((row + 1) * group, 1));
      histogram_row(out, label, n, peak);
    }
  }
  if (acc->overflow) {
    char label[32];
    snprintf(label, sizeof label, ">= %.2f", bin_edge(BBC_VALIDATION_BINS, 1));
    histogram_row(out, label, acc->overflow, peak);
  }
  return ferror(out) ? BBC_ERR_IO : BBC_OK;
}

/* A JSON number, or null for NaN and infinities (JSON has neither). */
static void json_number(FILE *out, double x) {
  if (!isfinite(x)) {
    fputs("null", out);
    return;
  }
  /* The shortest of %.15g and %.17g that reads back as x: 0.01 stays "0.01". */
  char text[32];
  snprintf(text, sizeof text, "%.15g", x);
  if (strtod(text, NULL) != x) snprintf(text, sizeof text, "%.17g", x);
  fputs(text, out);
}

bbc_result bbc_validation_write_json(const bbc_validation *acc, FILE *out) {
  if (!acc || !out) return BBC_ERR_INVALID_ARGUMENT;
  fprintf(out,
          "{\"tuples\":%" PRIu64 ",\"samples\":%" PRIu64 ",\"admissible\":%" PRIu64
          ",\"position_violations\":%" PRIu64 ",\"upper_violations\":%" PRIu64
          ",\"lower_violations\":%" PRIu64 ",\"in_discarded\":%" PRIu64 ",\"uncovered\":%" PRIu64
          ",\"failing\":%" PRIu64 ",\"unbounded\":%" PRIu64,
          acc->tuples, acc->samples, acc->admissible, acc->position_violations,
          acc->upper_violations, acc->lower_violations, acc->in_discarded, acc->uncovered,
          acc->failing, acc->unbounded);
  int any = acc->ratio_count > 0;
  fprintf(out, ",\"log10_ratio\":{\"count\":%" PRIu64 ",\"min\":", acc->ratio_count);
  json_number(out, any ? acc->min_log_ratio : NAN);
  fputs(",\"max\":", out);
  json_number(out, any ? acc->max_log_ratio : NAN);
  fputs(",\"mean\":", out);
  json_number(out, any ? acc->sum_log_ratio / (double)acc->ratio_count : NAN);
  fputs(",\"median\":", out);
  json_number(out, bbc_validation_log_ratio_quantile(acc, 0.5));
  fputs(",\"p99\":", out);
  json_number(out, bbc_validation_log_ratio_quantile(acc, 0.99));
  fputs("}", out);
  fputs(",\"first_failure\":", out);
  if (acc->failing) {
    const bbc_validation_failure *f = &acc->first_failure;
    fprintf(out,
            "{\"light\":%" PRIu32 ",\"chain\":\"%s\",\"caster\":%" PRIu32 ",\"receiver\":%" PRIu32
            ",\"sample\":%" PRIu32 ",\"kinds\":%" PRIu32 ",\"u1\":[",
            f->tuple.light, bbc_chain_name((bbc_chain)f->tuple.chain), f->tuple.specular[0],
            f->tuple.receiver, f->sample, f->kinds);
    json_number(out, f->u1[0]);
    fputc(',', out);
    json_number(out, f->u1[1]);
    fputs("],\"uk\":[", out);
    json_number(out, f->uk[0]);
    fputc(',', out);
    json_number(out, f->uk[1]);
    fputs("],\"irradiance\":", out);
    json_number(out, f->irradiance);
    const bbc_piece *p = &f->piece;
    const double box[] = {p->u_lo,  p->u_hi,  p->v_lo,  p->v_hi,  p->uk_lo, p->uk_hi, p->vk_lo,
                          p->vk_hi, p->sk_lo, p->sk_hi, p->dk_lo, p->dk_hi, p->e_lo,  p->e_hi};
    static const char *const names[] = {"u_lo",  "u_hi",  "v_lo",  "v_hi",  "uk_lo",
                                        "uk_hi", "vk_lo", "vk_hi", "sk_lo", "sk_hi",
                                        "dk_lo", "dk_hi", "e_lo",  "e_hi"};
    fprintf(out, ",\"piece\":{\"level\":%d,\"kept\":%s", p->level,
            p->status == BBC_PIECE_KEPT ? "true" : "false");
    for (int i = 0; i < 14; i++) {
      fprintf(out, ",\"%s\":", names[i]);
      json_number(out, box[i]);
    }
    fputs("}}", out);
  } else {
    fputs("null", out);
  }
  fprintf(out, ",\"histogram\":{\"log10_min\":");
  json_number(out, BBC_VALIDATION_LOG_MIN);
  fputs(",\"bin_width\":", out);
  json_number(out, BBC_VALIDATION_BIN_WIDTH);
  fprintf(out, ",\"underflow\":%" PRIu64 ",\"overflow\":%" PRIu64 ",\"counts\":[", acc->underflow,
          acc->overflow);
  for (int i = 0; i < BBC_VALIDATION_BINS; i++)
    fprintf(out, i ? ",%" PRIu64 : "%" PRIu64, acc->bins[i]);
  fputs("]}}", out);
  return ferror(out) ? BBC_ERR_IO : BBC_OK;
}
