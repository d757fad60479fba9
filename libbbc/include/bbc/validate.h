/* Validation of single-scattering bounds against true paths (the paper's Fig. 17 and
 * Fig. 18): sample u1 uniformly in T1, trace the exact path (specular_path.h), find the
 * piece of the subdivision (bounds.h) that holds u1 and check that the path lands inside
 * the piece's position bound and carries an irradiance inside its irradiance bound.
 *
 * A path counts when the renderer would count it: its trace has no BBC_PATH_REJECT flag,
 * no vertex of it (nor an area light's emitter point) is cut out by its material's alpha
 * (bbc_scene_coverage 0, texture.h) and, for refraction, the light arrives on the side
 * of T1 the bounder oriented it to (the side its vertex normals say the light is on;
 * bounds.h). The receiver's shading side, visibility, Fresnel and partial (BLEND)
 * coverage are not part of the check: the bounds do not model them.
 *
 * The results go into a bbc_validation accumulator, a plain struct with a fixed-size
 * histogram of log10(E_hi / E), so per-thread accumulators can be merged without any
 * allocation. The library only prints when asked to, through the FILE* functions below
 * (for bbc-inspect and the tests). */
#ifndef BBC_VALIDATE_H
#define BBC_VALIDATE_H

#include <stdio.h>

#include "bbc/bounds.h"
#include "bbc/cache.h"
#include "bbc/scene.h"
#include "bbc/tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The histogram of log10(E_hi / E): BBC_VALIDATION_BINS bins of width
 * BBC_VALIDATION_BIN_WIDTH starting at BBC_VALIDATION_LOG_MIN (so it covers [-1, 6):
 * a tenth of the true value up to a million times it), plus an underflow and an overflow
 * count. Bin i holds [LOG_MIN + i WIDTH, LOG_MIN + (i + 1) WIDTH). A hundredth of a
 * decade (2.3 %) resolves the typical tightness of a few percent (Table 2's medians are
 * around 0.03 to 0.1 decades), where 0.05-wide bins would not. Values below 0 are
 * upper-bound violations; they are binned too, to show how far they miss (Fig. 18). */
#define BBC_VALIDATION_LOG_MIN (-1.0)
#define BBC_VALIDATION_BINS_PER_DECADE 100
#define BBC_VALIDATION_BIN_WIDTH (1.0 / BBC_VALIDATION_BINS_PER_DECADE)
#define BBC_VALIDATION_BINS 700

/* One sampled path that broke a guarantee, kept for diagnostics. */
typedef struct bbc_validation_failure {
  bbc_tuple tuple;
  uint32_t sample;   /* the sample index, for bbc_validation_sample_u1 */
  uint32_t kinds;    /* bbc_validation_kind bits */
  double u1[2];      /* T1 barycentrics */
  double uk[2];      /* receiver barycentrics of the true path */
  double irradiance; /* true irradiance per unit intensity */
  bbc_piece piece;   /* the piece that holds u1 (zeroed when no piece does) */
} bbc_validation_failure;

/* Ways a path can break the bounds (bit flags of bbc_validation_failure.kinds). */
typedef enum bbc_validation_kind {
  BBC_VALIDATION_POSITION = 1u << 0,  /* u_k outside the piece's position bound */
  BBC_VALIDATION_UPPER = 1u << 1,     /* E above e_hi (or E not a number) */
  BBC_VALIDATION_LOWER = 1u << 2,     /* E below e_lo (or E not a number) */
  BBC_VALIDATION_DISCARDED = 1u << 3, /* an admissible path in a piece proved empty */
  BBC_VALIDATION_UNCOVERED = 1u << 4  /* u1 in no leaf piece at all */
} bbc_validation_kind;

/* The accumulator. A plain struct: zero-initialise it (or call bbc_validation_reset) to
 * start empty; every count is summed over calls. It owns no memory. Not thread-safe:
 * give each thread its own and merge them with bbc_validation_merge. */
typedef struct bbc_validation {
  uint64_t tuples;     /* tuples validated */
  uint64_t samples;    /* u1 drawn (all inside T1) */
  uint64_t admissible; /* samples whose path the renderer would count */

  /* Admissible paths that broke a guarantee, by kind. A path may count in several of
   * the first three; `failing` counts each failing path once. */
  uint64_t position_violations;
  uint64_t upper_violations;
  uint64_t lower_violations;
  uint64_t in_discarded; /* admissible paths in discarded pieces */
  uint64_t uncovered;    /* admissible paths in no piece */
  uint64_t failing;

  /* Admissible paths in kept pieces whose e_hi is +inf (near focal points): no ratio. */
  uint64_t unbounded;

  /* log10(e_hi / E) of admissible paths in kept pieces with finite e_hi. ratio_count
   * counts them (underflow and overflow included); min, max and sum are exact and only
   * meaningful when ratio_count > 0. E = 0 gives +inf (overflow); a path with E = +inf
   * (a focal point) under a finite e_hi is an upper violation and is not binned. */
  uint64_t ratio_count;
  double min_log_ratio, max_log_ratio, sum_log_ratio;
  uint64_t underflow, overflow;
  uint64_t bins[BBC_VALIDATION_BINS];

  /* The first failing path met (in call order, then sample order); valid when
   * failing > 0. */
  bbc_validation_failure first_failure;
} bbc_validation;

/* Empties the accumulator (the same as zero-initialising it). NULL is allowed. */
BBC_API void bbc_validation_reset(bbc_validation *acc);

/* Adds src to dst: counts and histograms add, min/max combine, and dst keeps its own
 * first failure unless it has none, so merging per-thread accumulators in thread (or
 * tuple) order gives the same result as one accumulator fed in that order. dst and src
 * must not be the same object; NULL for either does nothing. */
BBC_API void bbc_validation_merge(bbc_validation *dst, const bbc_validation *src);

/* The u1 = (u, v) of sample `sample` of a tuple: uniform in T1, a pure function of
 * (seed, tuple, sample), so any sample, e.g. a failing one, can be reproduced and
 * traced again. */
BBC_API void bbc_validation_sample_u1(uint64_t seed, const bbc_tuple *tuple, uint32_t sample,
                                      double u1[2]);

/* Validates the bounds of one single-scattering tuple (chain R or T) of the scene:
 * builds its bound geometry (bbc_tuple_geometry_init) and its path geometry
 * (bbc_path_geometry_init, unit intensity, so all irradiances are per unit intensity),
 * bounds it with params (NULL means the defaults), draws `samples` u1 with
 * bbc_validation_sample_u1(seed, tuple, i) and adds the outcome to *acc.
 *
 * The piece that holds u1 is a kept leaf whose closed box contains it, or, when none
 * does, a discarded one. Thread safety: reads scene, tuple and params only and writes
 * only *bounder and *acc, so threads may validate at once with a bounder and an
 * accumulator each. Returns BBC_ERR_INVALID_ARGUMENT for NULL pointers or a tuple that
 * is not R or T, BBC_ERR_OUT_OF_MEMORY, or the bounder's error; *acc is then unchanged.
 *
 * A beam tuple (receiver BBC_RECEIVER_BEAM, any chain type) is bounded by bbc_bound_beam
 * over the box of the scene's receivers that are not planes; each sampled path is traced
 * to every such receiver triangle its last segment meets (admissible there), and each
 * landing counts as an admissible path: outside the box of the kept piece holding u1 a
 * position violation, its irradiance on that triangle outside [e_lo, e_hi] an upper or
 * lower one, and with no kept piece uncovered or in a discarded piece. */
BBC_API bbc_result bbc_validate_tuple(bbc_bounder *bounder, const bbc_scene *scene,
                                      const bbc_tuple *tuple, const bbc_bound_params *params,
                                      uint32_t samples, uint64_t seed, bbc_validation *acc);

/* Validates what a cache stores for one single-scattering tuple of its scene: for each
 * of `samples` true paths (drawn and judged admissible as by bbc_validate_tuple), the
 * path's cell (bbc_cache_lookup at its u_k; for a receiver plane, at its position, as
 * the renderer looks up any triangle of the plane, and only for paths landing on the
 * plane's grid: the others miss the mesh) must list the tuple with a bound of at
 * least the path's irradiance times the light's brightest channel and the cache's m.
 * tuple_id is the tuple's id in the cache, or -1 for a candidate tuple the precompute
 * did not store, which must then have no admissible path at all. A missing entry counts
 * as a position violation, a low bound as an upper violation, an admissible path of an
 * unstored tuple as in_discarded; the ratio histogram is of log10(stored / true).
 * cursor is the caller's (one per thread). Thread safety as bbc_validate_tuple.
 * A beam tuple's paths are traced to every receiver triangle not on a plane they meet
 * (as bbc_validate_tuple does) and each landing is looked up at that triangle. */
BBC_API bbc_result bbc_validate_cached_tuple(const bbc_cache *cache, bbc_cache_cursor *cursor,
                                             const bbc_scene *scene, const bbc_tuple *tuple,
                                             int64_t tuple_id, uint32_t samples, uint64_t seed,
                                             bbc_validation *acc);

/* Violations of any kind (the `failing` count): 0 means the bounds held on every
 * sampled path. */
BBC_API uint64_t bbc_validation_failures(const bbc_validation *acc);

/* The q-quantile (0 <= q <= 1) of log10(e_hi / E) at bin resolution: the midpoint of
 * the bin holding the ceil(q n)-th smallest ratio (the first for q = 0). When that
 * ratio is in the underflow or overflow count, the exact minimum or maximum is returned
 * instead. NaN when no ratio was recorded or q is outside [0, 1]. */
BBC_API double bbc_validation_log_ratio_quantile(const bbc_validation *acc, double q);

/* Writes one line (ending in a newline) summarising acc, prefixed with "label: " when
 * label is not NULL: samples, admissible paths, violations by kind, unbounded count and
 * the median, 99th percentile and minimum of log10(e_hi / E). Returns BBC_ERR_IO if the
 * stream reports an error. */
BBC_API bbc_result bbc_validation_print_summary(const bbc_validation *acc, const char *label,
                                                FILE *out);

/* Writes a text histogram of log10(e_hi / E), one row per group of bins between the
 * first and last non-empty one (at most about 40 rows; groups are whole multiples of
 * the bin width), each with its range, count and a bar, plus rows for underflow and
 * overflow when non-empty. Returns BBC_ERR_IO on a stream error. */
BBC_API bbc_result bbc_validation_print_histogram(const bbc_validation *acc, FILE *out);

/* Writes acc as one JSON object (no trailing newline): every count, the ratio summary
 * (min, max, mean, median, p99; null when undefined) and the histogram
 * {"log10_min", "bin_width", "underflow", "overflow", "counts": [...]} with all
 * BBC_VALIDATION_BINS counts. Returns BBC_ERR_IO on a stream error. */
BBC_API bbc_result bbc_validation_write_json(const bbc_validation *acc, FILE *out);

#ifdef __cplusplus
}
#endif

#endif
