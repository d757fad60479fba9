/* Merging the shards of a sharded precompute (format-spec/bbc-format.md Sec. 5.10, 7.4):
 * the shards are checked to be the N parts of one computation, their tuples are
 * renumbered in candidate order (the order the unsharded precompute gives ids in) and
 * every cell's lists are joined into a builder, whose file is then the unsharded one. */
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "report_internal.h"

/* Cells merged between two progress reports (and cancellation checks). */
#define MERGE_BATCH_CELLS 65536

typedef struct shard_ref {
  const bbc_cache *cache;
  bbc_cache_shard shard;
  uint32_t tuple_count;
  uint32_t *new_id; /* per tuple of the shard: its id in the merged cache */
} shard_ref;

typedef struct merged_tuple {
  uint64_t candidate;
  uint32_t shard, id;
} merged_tuple;

static int by_candidate(const void *a, const void *b) {
  uint64_t x = ((const merged_tuple *)a)->candidate, y = ((const merged_tuple *)b)->candidate;
  return (x > y) - (x < y);
}

static int by_index(const void *a, const void *b) {
  uint32_t x = (*(const shard_ref *const *)a)->shard.index;
  uint32_t y = (*(const shard_ref *const *)b)->shard.index;
  return (x > y) - (x < y);
}

/* Why two shards are not parts of one computation, or NULL if they may be. The
 * fingerprint covers the scene and the parameters; the candidate list and the writer's
 * INFO the program that computed the bounds; the grids are implied by the fingerprint
 * and compared for safety. */
static const char *incompatible(const shard_ref *a, const shard_ref *b, bbc_result *code) {
  bbc_cache_info x, y;
  bbc_cache_get_info(a->cache, &x);
  bbc_cache_get_info(b->cache, &y);
  *code = BBC_ERR_SCENE_MISMATCH;
  if (x.fingerprint.params != y.fingerprint.params) return "were computed with other parameters";
  if (x.fingerprint.total != y.fingerprint.total) return "were computed for different scenes";
  const bbc_grid *g = bbc_cache_grid(a->cache), *h = bbc_cache_grid(b->cache);
  if (g->receiver_count != h->receiver_count || g->uv_triangle_count != h->uv_triangle_count ||
      memcmp(g->receivers, h->receivers, sizeof *g->receivers * g->receiver_count) != 0 ||
      memcmp(g->triangle_uv, h->triangle_uv, sizeof(float) * 6 * g->uv_triangle_count) != 0)
    return "have different receiver grids";
  *code = BBC_ERR_INVALID_ARGUMENT;
  if (a->shard.count != b->shard.count) return "are shards of different splits";
  *code = BBC_ERR_SCENE_MISMATCH;
  if (a->shard.candidate_count != b->shard.candidate_count ||
      a->shard.candidates_hash != b->shard.candidates_hash)
    return "have different candidate tuple lists (computed by different versions of bbc?)";
  uint64_t na, nb;
  const uint8_t *ia = bbc__cache_info_bytes(a->cache, &na);
  const uint8_t *ib = bbc__cache_info_bytes(b->cache, &nb);
  if ((ia == NULL) != (ib == NULL) || na != nb || (na && memcmp(ia, ib, (size_t)na) != 0))
    return "were written by different programs (their INFO texts differ)";
  return NULL;
}

/* The lists of cells [begin, end) of every shard, renumbered, into the builder. Each
 * thread takes whole cells, so no two threads touch one cell; the builder sorts every
 * list by id before writing, so the result does not depend on the threads. Cursors
 * live for one batch, which bounds the decoded chunks kept in memory. */
static bbc_result merge_cells(bbc_cache_builder *b, const shard_ref *refs, size_t n, uint64_t begin,
                              uint64_t end, int threads) {
  bbc_result result = BBC_OK;
#pragma omp parallel num_threads(threads)
  {
    bbc_cache_cursor **cur = calloc(n, sizeof *cur);
    uint32_t *ids = NULL;
    uint16_t *codes = NULL;
    uint32_t cap = 0;
    bbc_result r = cur ? BBC_OK : BBC_ERR_OUT_OF_MEMORY;
    for (size_t s = 0; s < n && r == BBC_OK; s++)
      r = bbc_cache_cursor_create(&cur[s], refs[s].cache);
#pragma omp for schedule(static)
    for (uint64_t cell = begin; cell < end; cell++) {
      for (size_t s = 0; s < n && r == BBC_OK; s++) {
        const bbc_cache_entry *e;
        uint32_t count;
        /* A damaged chunk is reported by the cache's own error callback. */
        if ((r = bbc_cache_cell(cur[s], cell, &e, &count)) != BBC_OK) break;
        if (count > cap) {
          uint32_t *ni = realloc(ids, sizeof *ids * (size_t)count);
          if (ni) ids = ni;
          uint16_t *nc = realloc(codes, sizeof *codes * (size_t)count);
          if (nc) codes = nc;
          if (!ni || !nc) {
            r = BBC_ERR_OUT_OF_MEMORY;
            break;
          }
          cap = count;
        }
        /* Decoded bounds are exact code values, so encoding gives the stored code. */
        for (uint32_t k = 0; k < count; k++) {
          ids[k] = refs[s].new_id[e[k].tuple];
          codes[k] = bbc__bound_encode((double)e[k].bound);
        }
        r = bbc__cache_builder_add_codes(b, cell, ids, codes, count);
      }
    }
    for (size_t s = 0; cur && s < n; s++) bbc_cache_cursor_free(cur[s]);
    free(cur);
    free(ids);
    free(codes);
    if (r != BBC_OK) {
#pragma omp critical(bbc_merge_error)
      if (result == BBC_OK) result = r;
    }
  }
  return result;
}

/* Forwards the first problem of a validation only: one line per failed merge. */
typedef struct first_problem {
  const bbc_cache_merge_options *o;
  int reported;
} first_problem;

static void report_first(void *user, bbc_result code, const char *message) {
  first_problem *f = user;
  if (f->reported++ == 0 && f->o->error_fn) f->o->error_fn(f->o->user, code, message);
}

static bbc_result out_of_memory(const bbc_cache_merge_options *o) {
  return bbc__report(o->error_fn, o->user, BBC_ERR_OUT_OF_MEMORY, "merge: out of memory");
}

bbc_result bbc_cache_merge(bbc_cache_builder **out, const bbc_cache *const *shards,
                           size_t shard_count, const bbc_cache_merge_options *options) {
  if (out) *out = NULL;
  bbc_cache_merge_options defaults;
  memset(&defaults, 0, sizeof defaults);
  const bbc_cache_merge_options *o = options ? options : &defaults;
  if (!out || !shards || shard_count == 0)
    return bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT, "merge: no shard given");
  for (size_t s = 0; s < shard_count; s++)
    if (!shards[s]) return BBC_ERR_INVALID_ARGUMENT;

  shard_ref *refs = calloc(shard_count, sizeof *refs);
  shard_ref **sorted = calloc(shard_count, sizeof *sorted);
  merged_tuple *order = NULL;
  bbc_cache_builder *b = NULL;
  int threads = o->threads > 0 ? o->threads : omp_get_max_threads();
  bbc_result r = refs && sorted ? BBC_OK : out_of_memory(o);

  /* Every cache is a shard, of the same computation as the first. */
  uint64_t total = 0;
  for (size_t s = 0; s < shard_count && r == BBC_OK; s++) {
    shard_ref *ref = &refs[s];
    ref->cache = shards[s];
    sorted[s] = ref;
    const char *path = bbc__cache_path(ref->cache);
    if (!bbc_cache_get_shard(ref->cache, &ref->shard)) {
      r = bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT,
                      "%s: not a shard cache (it has no SHRD section; shards are written by "
                      "bbc-precompute --shard I/N)",
                      path);
      break;
    }
    bbc_cache_info in;
    bbc_cache_get_info(ref->cache, &in);
    ref->tuple_count = in.tuple_count;
    total += in.tuple_count;
    const char *why;
    bbc_result code = BBC_OK;
    if (s > 0 && (why = incompatible(&refs[0], ref, &code)) != NULL)
      r = bbc__report(o->error_fn, o->user, code, "%s (shard %u/%u) and %s (shard %u/%u) %s",
                      bbc__cache_path(refs[0].cache), refs[0].shard.index, refs[0].shard.count,
                      path, ref->shard.index, ref->shard.count, why);
  }

  /* The indices are 0 .. N-1, each once. */
  if (r == BBC_OK) {
    uint32_t count = refs[0].shard.count;
    qsort(sorted, shard_count, sizeof *sorted, by_index);
    for (size_t s = 1; s < shard_count && r == BBC_OK; s++)
      if (sorted[s]->shard.index == sorted[s - 1]->shard.index)
        r = bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT,
                        "%s and %s are both shard %u/%u", bbc__cache_path(sorted[s - 1]->cache),
                        bbc__cache_path(sorted[s]->cache), sorted[s]->shard.index, count);
    /* Distinct indices below count: fewer than count shards means some are missing. */
    if (r == BBC_OK && shard_count != count) {
      uint32_t missing = 0;
      while (missing < shard_count && sorted[missing]->shard.index == missing) missing++;
      r = bbc__report(o->error_fn, o->user, BBC_ERR_INVALID_ARGUMENT,
                      "shard %u/%u is missing (%llu of the %u shards given)", missing, count,
                      (unsigned long long)shard_count, count);
    }
  }
  /* Every chunk of every shard, before anything is merged: a damaged shard is refused
   * with one line, and never half merged. */
  for (size_t s = 0; s < shard_count && r == BBC_OK; s++) {
    first_problem f = {o, 0};
    r = bbc_cache_validate(refs[s].cache, report_first, &f);
    if (r == BBC_ERR_OUT_OF_MEMORY && !f.reported) r = out_of_memory(o);
  }
  if (r == BBC_OK && total > BBC__MAX_TUPLES)
    r = bbc__report(o->error_fn, o->user, BBC_ERR_UNSUPPORTED,
                    "merge: %llu tuples in all, more than a cache holds",
                    (unsigned long long)total);

  /* Tuples in candidate order: the ids the unsharded precompute gives. */
  if (r == BBC_OK && !(order = malloc(sizeof *order * (total ? total : 1)))) r = out_of_memory(o);
  for (size_t s = 0; s < shard_count && r == BBC_OK; s++) {
    size_t n = refs[s].tuple_count ? refs[s].tuple_count : 1;
    if (!(refs[s].new_id = malloc(sizeof *refs[s].new_id * n))) r = out_of_memory(o);
  }
  if (r == BBC_OK) {
    uint64_t at = 0;
    for (size_t s = 0; s < shard_count; s++)
      for (uint32_t t = 0; t < refs[s].tuple_count; t++)
        order[at++] = (merged_tuple){refs[s].shard.candidates[t], (uint32_t)s, t};
    /* Candidate indices of different shards differ (their residues differ), so the
     * order is total. */
    qsort(order, total, sizeof *order, by_candidate);
    bbc_cache_info info;
    bbc_cache_get_info(refs[0].cache, &info);
    if (bbc__cache_builder_from_parts(&b, &info, bbc_cache_grid(refs[0].cache)) != BBC_OK)
      r = out_of_memory(o);
  }
  for (uint64_t i = 0; i < total && r == BBC_OK; i++) {
    const merged_tuple *m = &order[i];
    const bbc_tuple *t = &bbc_cache_tuples(refs[m->shard].cache)[m->id];
    /* The tuples passed R-TUP-1 against the same scene counts and grid. */
    r = bbc_cache_builder_add_tuple(b, t, &refs[m->shard].new_id[m->id]);
    if (r != BBC_OK)
      r = bbc__report(o->error_fn, o->user, r, "%s: tuple %u cannot be merged: %s",
                      bbc__cache_path(refs[m->shard].cache), m->id, bbc_result_string(r));
  }
  /* The merged file names the program that computed the bounds, as the unsharded one. */
  if (r == BBC_OK) {
    uint64_t info_size;
    const uint8_t *info = bbc__cache_info_bytes(refs[0].cache, &info_size);
    if (bbc__cache_builder_set_info(b, info, (size_t)info_size) != BBC_OK) r = out_of_memory(o);
  }
  /* And the geometry of the first shard that holds it: the shards' fingerprints are
   * equal, so every GEOM present is the same stream (R-GEO-3). */
  for (size_t s = 0; s < shard_count && r == BBC_OK; s++) {
    uint64_t size;
    const uint8_t *geom = bbc__cache_geometry_bytes(sorted[s]->cache, &size);
    if (!geom) continue;
    if (bbc__cache_builder_set_geometry(b, geom, (size_t)size) != BBC_OK) r = out_of_memory(o);
    break;
  }

  /* The cell lists, in batches of cells between progress reports. */
  uint64_t cells = r == BBC_OK ? bbc_cache_builder_grid(b)->cell_count : 0;
  for (uint64_t begin = 0; begin < cells && r == BBC_OK; begin += MERGE_BATCH_CELLS) {
    uint64_t end = cells - begin < MERGE_BATCH_CELLS ? cells : begin + MERGE_BATCH_CELLS;
    r = merge_cells(b, refs, shard_count, begin, end, threads);
    if (r == BBC_OK && (r = bbc__cache_builder_spill_if_full(b)) == BBC_ERR_IO)
      r = bbc__report(o->error_fn, o->user, r, "merge: %s", bbc__cache_builder_error(b));
    if (r == BBC_ERR_OUT_OF_MEMORY) r = out_of_memory(o);
    /* A cancellation is the caller's own request: no message. */
    if (r == BBC_OK && o->progress_fn && o->progress_fn(o->progress_user, end, cells) != 0)
      r = BBC_ERR_CANCELLED;
  }

  if (refs)
    for (size_t s = 0; s < shard_count; s++) free(refs[s].new_id);
  free(refs);
  free(sorted);
  free(order);
  if (r != BBC_OK) {
    bbc_cache_builder_free(b);
    return r;
  }
  *out = b;
  return BBC_OK;
}
