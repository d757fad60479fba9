/* The persistent cache (.bbc): per receiver cell, the list of (tuple, irradiance bound)
 * pairs of the precomputation (paper Sec. 6.1, Eq. 21). The format is specified in
 * format-spec/bbc-format.md; this header is its C interface.
 *
 * Writing: a bbc_cache_builder collects tuples and splats and writes the file.
 * Reading: bbc_cache_open maps a file; cells are decoded on demand through a
 * per-thread bbc_cache_cursor. */
#ifndef BBC_CACHE_H
#define BBC_CACHE_H

#include "bbc/common.h"
#include "bbc/grid.h"
#include "bbc/scene.h"
#include "bbc/tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------ parameters */

/* The precompute parameters a cache was computed with, stored as given (spec Sec. 5.1)
 * and part of its fingerprint. A plain value type. */
typedef struct bbc_precompute_params {
  uint32_t chains;          /* BBC_CHAIN_BIT() of every chain type computed; not 0 */
  uint32_t max_level;       /* maximal subdivision level of the u1 domain, <= 64 */
  double sigma;             /* position-bound area threshold (>= 0) */
  double alpha_single;      /* bound/lower-bound threshold, one bounce (>= 1) */
  double alpha_double;      /* the same, two bounces (>= 1) */
  double m;                 /* solutions assumed per tuple, Eq. 21 (> 0) */
  uint32_t grid_resolution; /* cells along a receiver grid's longer side, 1..65536 */
  uint32_t remainder;       /* 1 if remainder variables were used, else 0 */
  /* 1: the scene's emissive triangles are lights of the cache too (area lights, light
   * index point_light_count + emitter), else 0 (the default): their caustics are then
   * left to path tracing. PARM flags bit 1. */
  uint32_t area_lights;
  /* 1: the area lights' tuples include the double-scattering chains of `chains` (RR, RT,
   * TR, TT; format 1.4, PARM flags bit 2; bbc-precompute --area-double); 0 (the default):
   * they are single scattering (R, T) only, as every cache of format 1.2 and 1.3, and
   * the emitters' double-scattering caustics are left to path tracing. Needs area_lights
   * and a double-scattering chain type in `chains`. Bounding them costs far more than
   * single scattering (docs/lights.md), hence opt-in. */
  uint32_t area_double;
  /* The bound/lower-bound threshold for every tuple of an area light (>= 1; format 1.5,
   * PARM bytes 48-55; bbc-precompute --alpha-area, default 100). 0 means alpha_double:
   * what the area lights of caches before 1.5 used, and what a cache without area lights
   * stores. */
  double alpha_area;
  /* 1: beam receivers (format 1.7, PARM flags bit 3; bbc-precompute --receivers beam):
   * the tuples of receiver triangles that are not on a receiver plane are one per
   * (light, T1[, T2]) prefix, with receiver BBC_RECEIVER_BEAM (tuple.h), bounded by
   * bbc_bound_beam and recorded in the cells of every such triangle the light can reach.
   * 0 (the default): one tuple per such triangle, as every cache before 1.7. */
  uint32_t beam_receivers;
  /* Levels of cells (format 1.8, PARM bytes 56-59; spec Sec. 6.6): in a file 0, the
   * grids' cells alone, or L >= 2, the grids and L - 1 coarser levels, where a beam
   * tuple whose bounds are smooth over many cells is recorded. Given to a writer: 0 (the
   * default) lets it choose, L with 2^(L-1) >= grid_resolution / 8 for beam receivers,
   * else one level; 1 asks for one level; 2..17 for that many. */
  uint32_t cell_levels;
  /* The deepest subdivision level of the two-bounce tuples (RR, RT, TR, TT) of point,
   * spot and sun lights (format 1.9, PARM bytes 60-63; bbc-precompute --max-level2,
   * default 3): 0 means max_level, what every cache before 1.9 used. Deeper levels cost
   * far more and rendered no better (docs/double-scattering.md, "How deep"). A cache
   * without a two-bounce chain type stores 0. */
  uint32_t max_level_double;
} bbc_precompute_params;

/* The defaults: all chains, level 10 (3 for two-bounce tuples), sigma 1e-4, alpha 2 and
 * 10, m 1, 512 cells, remainder variables on; alpha 100 for area lights
 * (docs/lights.md). The paper's settings are those with max_level_double 0. */
BBC_API void bbc_precompute_params_default(bbc_precompute_params *params);

/* ------------------------------------------------------------------ fingerprint */

/* XXH64 hashes of the canonical byte streams of spec Sec. 8. */
typedef struct bbc_fingerprint {
  uint64_t total;    /* of the five below */
  uint64_t geometry; /* positions, normals, uvs, indices, triangle meshes */
  uint64_t materials;
  uint64_t meshes; /* mesh table, including roles */
  uint64_t lights; /* point lights */
  uint64_t params; /* the precompute parameters */
} bbc_fingerprint;

/* Computes the fingerprint a cache of this scene and these parameters carries. Both
 * must be non-NULL (BBC_ERR_INVALID_ARGUMENT). Thread-safe. */
BBC_API bbc_result bbc_fingerprint_compute(const bbc_scene *scene,
                                           const bbc_precompute_params *params,
                                           bbc_fingerprint *out);

/* The value a bound is stored as (spec R-BND-1): the smallest representable value that
 * is >= bound (+inf stays +inf). A bound the cache returns is never below the bound
 * given to the builder, and at most 2^-8 relatively above it. NaN gives NaN. */
BBC_API float bbc_cache_quantize_bound(double bound);

/* ------------------------------------------------------------------ writing */

typedef struct bbc_cache_builder bbc_cache_builder;

/* Creates a builder for a scene: the grids of its receivers at params->grid_resolution
 * (bbc_grid_create) and its fingerprint. The scene is not referenced after the call.
 * Fails with BBC_ERR_INVALID_ARGUMENT (NULL, parameters outside the ranges of
 * bbc_precompute_params), BBC_ERR_SCENE (no receiver mesh) or BBC_ERR_OUT_OF_MEMORY;
 * *out is NULL then.
 *
 * Thread-safety: bbc_cache_builder_splat may be called from any number of threads at
 * once (cells are locked internally). Every other call on the builder, including
 * bbc_cache_builder_add_tuple, must not overlap with any other call on it. */
BBC_API bbc_result bbc_cache_builder_create(bbc_cache_builder **out, const bbc_scene *scene,
                                            const bbc_precompute_params *params);

/* Appends a tuple and returns its id in *id (ids are 0, 1, 2, ... in the order of the
 * calls: add tuples in a deterministic order for a reproducible file). The tuple must
 * be valid for the scene: light < point_light_count, chain in params->chains,
 * specular[0] a scene triangle, specular[1] BBC_NO_TRIANGLE exactly for one-bounce
 * chains, receiver a triangle of a receiver mesh (BBC_ERR_INVALID_ARGUMENT). */
BBC_API bbc_result bbc_cache_builder_add_tuple(bbc_cache_builder *b, const bbc_tuple *tuple,
                                               uint32_t *id);

/* Records that the piece of tuple `tuple_id` whose position bound is the barycentric box
 * [b1_lo, b1_hi] x [b2_lo, b2_hi] on `receiver_triangle` (which must be the tuple's
 * receiver) has irradiance bound `bound` (>= 0, +inf allowed, NaN not): the value to
 * store, with Eq. 21's m (params.m) and the light's intensity already applied by the
 * caller and rounded upward. Every cell the box covers (bbc_grid_splat_range) keeps, per
 * tuple, the maximum bound it was given (Eq. 21), quantised upward (spec R-BND-1).
 * Splats may arrive in any order and from any thread: the result does not depend on it.
 * A box that misses the triangle is no error and changes nothing. */
BBC_API bbc_result bbc_cache_builder_splat(bbc_cache_builder *b, uint32_t tuple_id,
                                           uint32_t receiver_triangle, double b1_lo, double b1_hi,
                                           double b2_lo, double b2_hi, double bound);

/* Records a tuple's bounds already rasterised by the caller: `bounds` holds one value
 * per cell of `range` (row-major, (x1 - x0 + 1) per row), 0 meaning "no entry". Each
 * cell keeps, per tuple, the maximum it was given, as with bbc_cache_builder_splat, and
 * the same thread-safety applies. BBC_ERR_INVALID_ARGUMENT for a range outside the
 * receiver's grid, NaN or negative values. */
BBC_API bbc_result bbc_cache_builder_splat_cells(bbc_cache_builder *b, uint32_t tuple_id,
                                                 const bbc_cell_range *range,
                                                 const double *bounds);

/* The builder's grids (owned by the builder) and counts. */
BBC_API const bbc_grid *bbc_cache_builder_grid(const bbc_cache_builder *b);
BBC_API uint32_t bbc_cache_builder_tuple_count(const bbc_cache_builder *b);
/* Distinct (cell, tuple) entries so far. Not to be called during splats. */
BBC_API uint64_t bbc_cache_builder_entry_count(bbc_cache_builder *b);

/* Refuses, before anything large is allocated, a precompute of `scene` with `params`
 * whose cache cannot fit: the least memory it needs (the builder's list head per cell
 * and the writer's cell index, 12 bytes per cell, whatever the tuples) against
 * `memory_budget` bytes (0: the machine's physical memory), and the least file size
 * (the sections without any cell list; the cell index alone is 12 bytes per cell)
 * against the free space of the directory of `output` (skipped when output is NULL).
 * One line with the estimates through error_fn; BBC_ERR_OUT_OF_MEMORY or BBC_ERR_IO.
 * The actual need grows with the entries, so passing is no guarantee. */
BBC_API bbc_result bbc_cache_check_resources(const bbc_scene *scene,
                                             const bbc_precompute_params *params,
                                             const char *output, uint64_t memory_budget,
                                             bbc_message_fn error_fn, void *user);

typedef struct bbc_cache_write_options {
  bbc_message_fn error_fn; /* optional: details of a failure */
  void *user;
  int compression_level;       /* zstd level 1..19; 0 means 6 */
  uint32_t chunk_bytes;        /* target decoded chunk size; 0 means 256 KiB */
  int omit_info;               /* non-zero: no INFO section (writer name) */
  bbc_progress_fn progress_fn; /* optional; counts cells */
  void *progress_user;
  int omit_geometry; /* non-zero: no GEOM section (so no bbc_cache_match_scene) */
} bbc_cache_write_options;

/* Writes the cache to path through a temporary file in the same folder, checks that
 * file with the reader (bbc_cache_open and bbc_cache_validate) and renames it on
 * success; a file that fails its own validation is never left behind. The bytes depend only on the scene, the parameters, the tuples in id order,
 * the set of splats (not their order or threads) and the options (spec Sec. 7.3).
 * The builder of a sharded precompute (bbc_precompute_options.shard_count) writes a
 * shard cache with the SHRD section (spec Sec. 5.10). Unless omit_geometry is set, the
 * file holds the scene's geometry (GEOM, Sec. 5.11) and is format version 1.3; the
 * version is otherwise the smallest whose features the file uses (R-HDR-3).
 * May be called more than once; the builder stays usable. options may be NULL. */
BBC_API bbc_result bbc_cache_builder_write(bbc_cache_builder *b, const char *path,
                                           const bbc_cache_write_options *options);

/* The same into memory: *bytes (free with free()) and *size. */
BBC_API bbc_result bbc_cache_builder_write_memory(bbc_cache_builder *b, void **bytes, size_t *size,
                                                  const bbc_cache_write_options *options);

/* NULL is allowed. */
BBC_API void bbc_cache_builder_free(bbc_cache_builder *b);

/* ------------------------------------------------------------------ reading */

typedef struct bbc_cache bbc_cache;

typedef struct bbc_cache_options {
  bbc_message_fn error_fn; /* optional: one line per failure (file, section, offset) */
  void *user;
  /* Bytes of decoded chunks the cache may keep for every cursor to share (0: none, each
   * cursor decodes what it needs for itself). A chunk is kept the first time it decodes
   * without a fault, by bbc_cache_validate or by a cursor, while the total stays within
   * this budget; chunks beyond it are decoded by each cursor that needs them. A render
   * that validates first then decodes each chunk once, not once more per thread. */
  size_t keep_decoded;
} bbc_cache_options;

/* Maps a .bbc file read-only and checks its structure and every checksum except the
 * chunk data's (spec Sec. 9). On failure *out is NULL and the result is BBC_ERR_IO,
 * BBC_ERR_NOT_BBC, BBC_ERR_VERSION_UNSUPPORTED, BBC_ERR_TRUNCATED, BBC_ERR_CHECKSUM,
 * BBC_ERR_CORRUPT or BBC_ERR_OUT_OF_MEMORY, with one line to options->error_fn.
 * options may be NULL; the options are kept for later messages (lookups, checks).
 *
 * Thread-safety: an open cache is immutable but for the decoded chunks it keeps
 * (options->keep_decoded), which are published atomically and never change once kept;
 * any number of threads may use it at once, each through its own cursor. */
BBC_API bbc_result bbc_cache_open(bbc_cache **out, const char *path,
                                  const bbc_cache_options *options);

/* The same over bytes in memory, which the cache borrows: they must stay unchanged until
 * bbc_cache_close. Bytes not aligned to 64 are copied (the format's alignment rules
 * assume an aligned base). For tests and fuzzers. */
BBC_API bbc_result bbc_cache_open_memory(bbc_cache **out, const void *bytes, size_t size,
                                         const bbc_cache_options *options);

/* Unmaps and frees; NULL is allowed. Every pointer obtained from the cache (tuples,
 * grid, cursor entries) dies with it; cursors must be freed first. */
BBC_API void bbc_cache_close(bbc_cache *cache);

typedef struct bbc_cache_info {
  uint32_t version_major, version_minor;
  uint64_t file_size;
  uint32_t section_count;
  bbc_precompute_params params;
  bbc_fingerprint fingerprint;
  /* Counts of the scene the cache was computed for. */
  uint32_t scene_vertex_count, scene_triangle_count, scene_mesh_count;
  uint32_t scene_material_count, scene_light_count;
  uint32_t scene_emitter_count; /* area-light caches: the scene's emitter_count, else 0 */
  uint32_t tuple_count;
  uint32_t receiver_count;
  uint64_t cell_count, nonempty_cell_count;
  uint32_t chunk_count;
  uint64_t entry_count;      /* (cell, tuple) entries over all cells */
  uint64_t decoded_bytes;    /* 6 * entry_count */
  uint64_t compressed_bytes; /* size of the chunk data */
  char writer[128];          /* INFO text (truncated), or "" */
} bbc_cache_info;

/* Fills *out; cheap (no decoding). */
BBC_API void bbc_cache_get_info(const bbc_cache *cache, bbc_cache_info *out);

typedef struct bbc_cache_section {
  uint32_t type;  /* four characters, first in the lowest byte */
  char name[5];   /* the same as a string */
  uint32_t flags; /* bit 0: required */
  uint64_t offset, size;
  uint32_t checksum;
} bbc_cache_section;

/* Section i (< info.section_count) of the directory, in file order. */
BBC_API void bbc_cache_get_section(const bbc_cache *cache, uint32_t i, bbc_cache_section *out);

/* The tuple table (info.tuple_count entries), borrowed from the mapping. */
BBC_API const bbc_tuple *bbc_cache_tuples(const bbc_cache *cache);

/* The grids stored in the cache, owned by the cache (do not bbc_grid_free it). Lookups
 * must use this grid, not one rebuilt from the scene. */
BBC_API const bbc_grid *bbc_cache_grid(const bbc_cache *cache);

/* BBC_OK if the cache was computed for this scene (its geometry, materials, meshes and
 * lights hash as stored), else BBC_ERR_SCENE_MISMATCH with a line to the error callback
 * saying which part differs. The camera is not compared. */
BBC_API bbc_result bbc_cache_check_scene(const bbc_cache *cache, const bbc_scene *scene);

/* What bbc_cache_match_scene found. */
typedef struct bbc_scene_match {
  int adopted;              /* 1: the geometry differed within the quanta and the scene now
                               holds the cache's; 0: it was the cache's already */
  uint32_t triangles_moved; /* triangles found at another index or corner order */
  double position_error;    /* largest difference of a coordinate (scene units) */
  double normal_error;      /* of a normal component */
  double uv_error;          /* of a texture coordinate */
} bbc_scene_match;

/* bbc_cache_check_scene, tolerant of float noise (format-spec Sec. 8.1): a scene whose
 * geometry hash differs from the cache's, but whose meshes, materials and lights do not,
 * is compared triangle by triangle, in any order, with the geometry the cache stores
 * (its GEOM section; caches written with omit_geometry have none). When every triangle
 * lies within the quanta of a distinct cached one (positions to 2^-17 of their mesh's
 * largest coordinate, normals and uvs to 2^-17), the scene's vertices and triangles are
 * replaced by the cache's, so that what is rendered is exactly what the cache bounds,
 * and BBC_OK is returned with match->adopted = 1. Otherwise as bbc_cache_check_scene:
 * BBC_ERR_SCENE_MISMATCH with one line through the error callback naming the first
 * triangle without a counterpart; BBC_ERR_CORRUPT for a damaged GEOM section. Call it
 * before anything is built from the scene (the ray-tracing structure). match may be
 * NULL. */
BBC_API bbc_result bbc_cache_match_scene(const bbc_cache *cache, bbc_scene *scene,
                                         bbc_scene_match *match);

/* BBC_OK if the cache was computed with these parameters, else BBC_ERR_SCENE_MISMATCH
 * with a line naming the first parameter that differs. */
BBC_API bbc_result bbc_cache_check_params(const bbc_cache *cache,
                                          const bbc_precompute_params *params);

/* Full validation: the CDAT checksum, every chunk's checksum, every frame and every
 * cell list (spec Sec. 9). Every problem is reported as one line to report (may be NULL)
 * and validation goes on with the next chunk; returns the first problem's code or
 * BBC_OK. Structural rules were already checked by open. Thread-safe. */
BBC_API bbc_result bbc_cache_validate(const bbc_cache *cache, bbc_message_fn report, void *user);

/* One entry of a cell's list: the tuple id (index into bbc_cache_tuples) and its
 * irradiance bound E~ (Eq. 21, quantised upward, possibly +inf). */
typedef struct bbc_cache_entry {
  uint32_t tuple;
  float bound;
} bbc_cache_entry;

/* A per-thread decoding context: it reads the chunks the cache keeps
 * (bbc_cache_options.keep_decoded) and keeps up to 256 decoded chunks of its own for the
 * rest (least recently used ones are replaced). One cursor must not be used by two
 * threads at once; make one per thread. */
typedef struct bbc_cache_cursor bbc_cache_cursor;

BBC_API bbc_result bbc_cache_cursor_create(bbc_cache_cursor **out, const bbc_cache *cache);
/* NULL is allowed. */
BBC_API void bbc_cache_cursor_free(bbc_cache_cursor *cursor);

/* The list of global cell `cell` (< info.cell_count), sorted by tuple id. *entries
 * points into the cursor and stays valid until the next call with this cursor. An
 * empty cell gives count 0. A damaged chunk gives BBC_ERR_CHECKSUM or BBC_ERR_CORRUPT
 * (with a line to the cache's error callback) and count 0; an index out of range
 * BBC_ERR_INVALID_ARGUMENT. */
BBC_API bbc_result bbc_cache_cell(bbc_cache_cursor *cursor, uint64_t cell,
                                  const bbc_cache_entry **entries, uint32_t *count);

/* What a point of cell `cell` of a receiver's grid sees: the lists of the cell and of
 * the cells of every coarser level holding it (spec Sec. 6.6), merged: sorted by tuple
 * id, a tuple listed at several levels once with its largest bound. With one level it
 * is bbc_cache_cell's list. *entries stays valid until the next call with the cursor;
 * errors as bbc_cache_cell's. */
BBC_API bbc_result bbc_cache_leaf(bbc_cache_cursor *cursor, bbc_cell cell,
                                  const bbc_cache_entry **entries, uint32_t *count);

/* The list that a point (b1, b2) of scene triangle `triangle` at position *point sees:
 * bbc_cache_leaf of its cell (bbc_grid_locate on the cache's grid: the position locates
 * the points of a receiver plane's triangles; NULL gives them an empty list). A triangle
 * that is not a receiver gives an empty list and BBC_OK. */
BBC_API bbc_result bbc_cache_lookup(bbc_cache_cursor *cursor, uint32_t triangle, double b1,
                                    double b2, const bbc_vec3 *point,
                                    const bbc_cache_entry **entries, uint32_t *count);

/* ------------------------------------------------------------------ shards */

/* A sharded precompute (bbc-precompute --shard i/N, bbc_precompute_options.shard_*)
 * bounds only the candidate tuples whose index k in the deterministic candidate list
 * (bbc_tuples_find) has k % N == i, and writes a shard cache: a cache whose optional
 * SHRD section (spec Sec. 5.10) says which shard it is and gives, per stored tuple, its
 * candidate index. The N shards merge (bbc_cache_merge) into the cache the unsharded
 * precompute writes, byte for byte. A shard alone is incomplete: renderers refuse it. */
typedef struct bbc_cache_shard {
  uint32_t index;           /* i, below count */
  uint32_t count;           /* N >= 1 */
  uint64_t candidate_count; /* candidate tuples of the whole precompute */
  uint64_t candidates_hash; /* XXH64 of the whole candidate list (spec Sec. 5.10) */
  /* Per stored tuple (bbc_cache_info.tuple_count of them, in id order), its candidate
   * index: strictly increasing, below candidate_count, each one % count == index.
   * Borrowed from the mapping: valid until bbc_cache_close. */
  const uint64_t *candidates;
} bbc_cache_shard;

/* Returns 1 and fills *out (may be NULL) if the cache is a shard cache (it has a SHRD
 * section), else returns 0 and zeroes *out. Cheap; thread-safe. */
BBC_API int bbc_cache_get_shard(const bbc_cache *cache, bbc_cache_shard *out);

typedef struct bbc_cache_merge_options {
  bbc_message_fn error_fn; /* optional: one line naming the shard(s) and the problem */
  void *user;
  bbc_progress_fn progress_fn; /* optional: cells merged / total; non-zero cancels */
  void *progress_user;
  int threads; /* 0: every core; the result does not depend on it */
} bbc_cache_merge_options;

/* Merges the shards of one sharded precompute into a builder holding the complete
 * cache (*out, free with bbc_cache_builder_free; NULL on failure): the tuples of all
 * shards renumbered in candidate order and every cell's lists joined. Written with
 * bbc_cache_builder_write and default write options, the file is byte-identical to the
 * cache of the unsharded precompute of the same scene and parameters (spec Sec. 7.4);
 * it keeps the shards' INFO text (the program that computed the bounds) unless
 * omit_info is set, and has no SHRD section.
 *
 * The shards may come in any order. Fails, with one line to options->error_fn, with
 * BBC_ERR_INVALID_ARGUMENT when a cache is not a shard cache, when the shards are of
 * different splits (N), when a shard is given twice or one is missing;
 * BBC_ERR_SCENE_MISMATCH when the shards were computed for different scenes or
 * parameters, from different candidate lists or by different programs (INFO);
 * BBC_ERR_CHECKSUM or BBC_ERR_CORRUPT for a damaged shard (every shard is fully
 * validated first, as by bbc_cache_validate; the first problem is the line);
 * BBC_ERR_UNSUPPORTED when the tuples exceed a cache's limit; BBC_ERR_CANCELLED (no
 * line); BBC_ERR_OUT_OF_MEMORY. options may be NULL. The caches are only read; they
 * may be closed once the call returns. Thread-safe for distinct builders. */
BBC_API bbc_result bbc_cache_merge(bbc_cache_builder **out, const bbc_cache *const *shards,
                                   size_t shard_count, const bbc_cache_merge_options *options);

/* Refuses, before a merge (bbc_cache_merge) into `output`, shards whose merged cache
 * cannot fit: the builder's memory per cell against the machine's physical memory, and
 * the merged file's estimated size (the sections the shards share, once, plus their
 * tuples, chunk records and compressed cell lists, summed) against the free space of the
 * directory of `output` (skipped when output is NULL). One line with the estimates
 * through error_fn; BBC_ERR_OUT_OF_MEMORY or BBC_ERR_IO. */
BBC_API bbc_result bbc_cache_merge_check_resources(const bbc_cache *const *shards, size_t n,
                                                   const char *output, bbc_message_fn error_fn,
                                                   void *user);

#ifdef __cplusplus
}
#endif

#endif
