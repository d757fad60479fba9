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

struct bbc_precompute_estimate;

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
  /* Optional: progress of the search for the candidate tuples, (light, first specular
   * triangle) prefixes searched / total, with progress_user; non-zero cancels. */
  bbc_progress_fn search_progress;
  /* Optional: called once with what the precompute will cost (bbc_precompute_estimate),
   * after the candidates are counted and before any is bounded, with `user`; a non-zero
   * return stops the precompute there with BBC_ERR_CANCELLED. */
  int (*estimate_fn)(void *user, const struct bbc_precompute_estimate *estimate);
  /* Bytes of candidate tuples the precompute may hold as one list (20 bytes each). A
   * longer list is never held: it is counted, then searched again a block at a time
   * while it is bounded (the search twice, its memory bounded). 0: 64 MiB. The written
   * file does not depend on it. */
  size_t candidate_memory;
  /* Optional: asked by the bounding threads before each tuple and at each piece they
   * keep, with `user` (often, from several threads at once: it must only read, e.g. a
   * flag a signal handler sets); non-zero stops the precompute with BBC_ERR_CANCELLED
   * within a piece's bounding, where `progress` is asked only between batches. */
  int (*cancel_fn)(void *user);
} bbc_precompute_options;

/* What a precompute will cost, known before its bounding starts (estimate_fn): the
 * candidate tuples exactly, the rest estimated from a sample of them bounded first. */
typedef struct bbc_precompute_estimate {
  uint64_t candidate_tuples; /* exact: every candidate (of every shard) */
  uint64_t candidates_per_chain[BBC_CHAIN_COUNT]; /* exact */
  uint64_t bounded_tuples;   /* exact: the candidates this run bounds (its shard's) */
  uint64_t list_bytes;       /* to hold the whole candidate list */
  int list_held;             /* 1: it is held; 0: it is searched again while bounding */
  uint64_t search_bytes;     /* the most bytes of candidates the search held at once */
  double search_seconds;     /* wall time of the search that counted them */
  /* The sample: candidates drawn uniformly from the bounded ones, bounded and timed
   * before the rest: 1 in 64, at least 16 (all of them when fewer), at most 256. */
  uint32_t sample_tuples;
  double sample_cpu_seconds; /* the threads' CPU time bounding the sample */
  double stored_fraction;    /* of the sample, the tuples stored (with a kept piece) */
  /* The bounding's work per chain type, in pieces (position and irradiance bounds
   * computed): the sample's mean per candidate of the type times its candidates in this
   * run's shard. Counted, not clocked: the same on any machine and for any thread
   * count. */
  double pieces_per_chain[BBC_CHAIN_COUNT];
  double entries_per_tuple;  /* grid entries per stored tuple of the sample */
  /* Estimates: the bounding's CPU time (bounded_tuples times the sample's mean), the
   * wall time left (that over the threads, plus the second search when the list is
   * not held), the stored tuples (the sample's fraction at three standard errors, all
   * of them without a sample), the most memory the precompute allocates from here on
   * (the stored tuples, the grid entries before they spill, the search's blocks, the
   * writer's cell index) and the file's size. */
  double bounding_cpu_seconds, seconds;
  uint64_t stored_tuples, memory_bytes, file_bytes;
} bbc_precompute_estimate;

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
  double construction_seconds; /* finding tuples: counting them, and finding them again
                                  while bounding when the list was not held */
  double bounding_seconds;     /* bounding (position + irradiance), and recording the
                                  previous batch's cells alongside */
  double position_cpu_seconds, irradiance_cpu_seconds;
  double recording_seconds; /* what is left of recording: giving ids, spilling, the part
                               of a batch past the entry budget */
  int threads;
  bbc_precompute_estimate estimate; /* as estimate_fn was given it */
} bbc_precompute_stats;

/* The receivers a cache of this scene should have (bbc-precompute --receivers auto):
 * 1, beam receivers (bbc_precompute_params.beam_receivers), when the receiver meshes
 * that are not receiver planes hold at least BBC_BEAM_RECEIVER_TRIANGLES triangles in
 * all; else 0, a tuple per receiver triangle. Measured on a wavy mirror over a bent
 * floor (docs/receivers.md): per-triangle tuples cost less to precompute below about a
 * thousand floor triangles, beams far less above (2,000: 2x; 20,000: 13x), and the
 * beams' render was better at equal CPU there. *triangles (may be NULL) receives that
 * count. */
#define BBC_BEAM_RECEIVER_TRIANGLES 1000u
BBC_API uint32_t bbc_beam_receivers_auto(const bbc_scene *scene, uint64_t *triangles);

/* Precomputes the scene's bounds into a new cache builder (*out, free with
 * bbc_cache_builder_free), ready to be written. The chain types of params.chains are
 * computed, each specular vertex reflecting on mirrors and refracting through
 * dielectrics (R, T, RR, RT, TR, TT). The tuples are stored in a deterministic order,
 * so the written file does not depend on the number of threads. stats may be NULL. */
BBC_API bbc_result bbc_precompute(bbc_cache_builder **out, const bbc_scene *scene,
                                  const bbc_precompute_options *options,
                                  bbc_precompute_stats *stats);

/* The chain types a precompute bounds by default (bbc-precompute without --chains):
 * those of options->params.chains less the two-bounce types whose bounding would cost
 * more than max_pieces pieces in all, the costliest left out first. Bounding one piece
 * of a two-bounce tuple costs about 1 / BBC_DOUBLE_PIECES_PER_SECOND CPU-s (measured:
 * 180-600 us on the real assets and the glass spheres); counting pieces instead of
 * clocking them makes the choice, and so the cache, the same on any machine, under any
 * load and for any thread count or shard. A chain type left out is not lost to the
 * image: bbc-render light-traces every caustic path whose chain type its cache lacks,
 * where the camera sees it directly (docs/light-tracing.md); seen in a mirror or
 * through glass, it is missing. The estimate comes from a probe: the two-bounce
 * candidates counted and PROBE_PER_CHAIN (16) of each type bounded (the options'
 * memory, cancel and search-progress callbacks hold; the estimate callback is not
 * called). With max_pieces 0, and with beam receivers (params.beam_receivers), every
 * two-bounce type is left out without a probe (candidates and pieces stay 0): there
 * each cell of a curved receiver lists many two-bounce beam tuples, nearly none with a
 * path at the point, and the render of the cached types cost more than light tracing
 * them at equal error (measured on TransmissionTest's cloth: 33x the CPU per sample for
 * 1.75x lower relMSE; on a glass ball over a bent floor of 2,048 triangles light tracing
 * reached the same error in less than half the CPU, where over a flat floor the cache
 * did; docs/precompute.md). */
#define BBC_DOUBLE_PIECES_PER_SECOND 4000.0
typedef struct bbc_chain_choice {
  uint32_t chains;                      /* to bound: options->params.chains less left_out */
  uint32_t left_out;                    /* the two-bounce chain types over the budget */
  uint64_t candidates[BBC_CHAIN_COUNT]; /* per two-bounce chain type, exact */
  double pieces[BBC_CHAIN_COUNT];       /* per two-bounce chain type, estimated */
} bbc_chain_choice;
BBC_API bbc_result bbc_precompute_choose_chains(const bbc_scene *scene,
                                                const bbc_precompute_options *options,
                                                double max_pieces, bbc_chain_choice *choice);

#ifdef __cplusplus
}
#endif

#endif
