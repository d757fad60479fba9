/* The precomputation (paper Sec. 6.1): tuples of a light, specular triangles and a
 * receiver triangle, found by following beam bounds through a BVH; for each tuple the
 * subdivision of its domain with position and irradiance bounds; and the recording of
 * every kept piece's bound into the receiver grids of a cache builder. */
#ifndef BBC_PRECOMPUTE_H
#define BBC_PRECOMPUTE_H

#include "bbc/bounds.h"
#include "bbc/cache.h"
#include "bbc/scene.h"
#include "bbc/tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A zero-initialised struct is not valid: start from bbc_precompute_params_default. */
typedef struct bbc_precompute_options {
  bbc_precompute_params params;
  int threads;                /* 0 = every core; the result does not depend on it */
  bbc_jacobian_form jacobian; /* irradiance Jacobian form (default: determinant) */
  bbc_progress_fn progress;   /* optional: tuples bounded / total; non-zero cancels */
  void *progress_user;
  bbc_message_fn error_fn; /* optional: details of a failure */
  void *user;
  /* A sharded precompute (bbc_cache_shard): with shard_count N >= 1, only the candidate
   * tuples k with k % N == shard_index are bounded and the builder writes a shard cache
   * (SHRD section). shard_count 0 (the default): the whole precompute, no SHRD.
   * shard_index >= shard_count is BBC_ERR_INVALID_ARGUMENT. */
  uint32_t shard_index, shard_count;
  /* Bytes of (cell, tuple) entries kept in memory; beyond, the cell lists are spilled as
   * sorted runs to an unlinked temporary file in $TMPDIR (or /tmp) and merged back when
   * the cache is written. 0: 8 MiB. The written file does not depend on it. */
  size_t entry_memory;
} bbc_precompute_options;

/* The paper's Table 2 precompute columns and more. Times are wall-clock seconds of
 * the phases; position_cpu_seconds + irradiance_cpu_seconds is the bounding threads' CPU
 * time over the bounding phase, split as the bounder's clocked times of the two were. */
typedef struct bbc_precompute_stats {
  uint64_t candidate_tuples; /* tuples found by the beam bounds */
  uint64_t tuples;           /* tuples with at least one kept piece (stored) */
  uint64_t tuples_per_chain[BBC_CHAIN_COUNT];
  double second_per_first; /* candidate T2 per (light, T1) prefix that has any (DESIGN 3.7) */
  uint64_t position_pieces, irradiance_pieces, kept_pieces;
  uint64_t entries;            /* (cell, tuple) entries in the grids */
  uint32_t spill_runs;         /* sorted runs written to the spill file */
  uint64_t spill_bytes;        /* and their size */
  double construction_seconds; /* finding tuples */
  double bounding_seconds;     /* bounding (position + irradiance), and recording the
                                  previous batch's cells alongside */
  double position_cpu_seconds, irradiance_cpu_seconds;
  double recording_seconds; /* what is left of recording: giving ids, spilling, the part
                               of a batch past the entry budget */
  int threads;
} bbc_precompute_stats;

/* Precomputes the scene's bounds into a new cache builder (*out, free with
 * bbc_cache_builder_free), ready to be written. The chain types of params.chains are
 * computed, each specular vertex reflecting on mirrors and refracting through
 * dielectrics (R, T, RR, RT, TR, TT). The tuples are stored in a deterministic order,
 * so the written file does not depend on the number of threads. stats may be NULL. */
BBC_API bbc_result bbc_precompute(bbc_cache_builder **out, const bbc_scene *scene,
                                  const bbc_precompute_options *options,
                                  bbc_precompute_stats *stats);

#ifdef __cplusplus
}
#endif

#endif
