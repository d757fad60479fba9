/* Rendering: a unidirectional path tracer with next-event estimation, the integrator
 * the caustic estimator plugs into. */
#ifndef BBC_RENDER_H
#define BBC_RENDER_H

#include "bbc/accel.h"
#include "bbc/cache.h"
#include "bbc/image.h"
#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* How light from point lights through specular chains (caustics) is found. */
typedef enum bbc_method {
  BBC_METHOD_PT = 0,        /* plain path tracing: point-light caustics are missed */
  BBC_METHOD_BBC = 1,       /* tuples sampled with P = min(gamma E~, 1) (paper Sec. 5) */
  BBC_METHOD_ENUMERATE = 2, /* every tuple whose position bound covers the point */
  BBC_METHOD_UNIFORM = 3,   /* the same expected number of tuples, uniform P */
  BBC_METHOD_ONE_SAMPLE = 4 /* one tuple, P proportional to E~ (Eq. 23) */
} bbc_method;

/* How gamma of BBC_METHOD_BBC is chosen (Supp. 2.3); UNIFORM uses the expected count
 * the same choice gives. */
typedef enum bbc_gamma_mode {
  BBC_GAMMA_FIXED = 0,    /* gamma = gamma_value (when 0: 300, 100 for two-vertex tuples) */
  BBC_GAMMA_EXPECTED = 1, /* per cell, gamma such that gamma_value (default 4) of the
                             tuples with a finite bound are expected; tuples with an
                             infinite bound are always taken on top */
  BBC_GAMMA_VARIANCE = 2  /* per cell, gamma such that the variance bound is gamma_value */
} bbc_gamma_mode;
/* As in the paper (Supp. Table 1), gamma and the variance target are stated for a light
 * of unit intensity: with lights of intensity I (the brightest channel of the brightest
 * point light) the probabilities are min(gamma E~ / I, 1) and the variance target is
 * gamma_value I^2. */

/* How the paths of a double-scattering tuple (RR, RT, TR, TT) are found at a shading
 * point (paper Sec. 6.1, "Root-finding"; DESIGN 3.10): Newton's method on the chain
 * (bbc_solver_newton), u1 clamped back onto T1. Single scattering (R, T) always uses
 * the specular polynomials, which find every solution. */
typedef enum bbc_solver_method {
  /* One start drawn uniformly on T1; a solution it reaches is weighted by K, the number
   * of further independent starts drawn until one reaches the same solution again
   * (geometric, E[K] = 1 / its probability): the reciprocal-probability estimate of
   * specular manifold sampling (Zeltner et al. 2020). Unbiased for the sum over every
   * solution some start on T1 reaches, but adds variance. The default. */
  BBC_SOLVER_NEWTON_STOCH = 0,
  /* One start at T1's centre, weight 1: deterministic and free of variance, biased
   * (too dark) wherever the centre does not lead to every solution. */
  BBC_SOLVER_NEWTON_DET = 1
} bbc_solver_method;

/* The cap on K of BBC_SOLVER_NEWTON_STOCH when bbc_render_options.newton_max_trials is
 * 0. K reaches it only for a solution whose start-point basin covers less than about
 * 1/65536 of T1; a capped estimate is biased low and counted in the stats. */
#define BBC_NEWTON_MAX_TRIALS_DEFAULT 65536u

/* Where a path's random decisions (film position, diffuse directions, points on area
 * lights, Fresnel choices, Russian roulette, the caustic estimator's first tuple bins)
 * come from. Either way every number is a function of (seed, pixel, sample index,
 * decision), so images do not depend on the thread count. */
typedef enum bbc_sampler {
  /* Per pixel, Owen-scrambled Sobol points (padded: each decision its own scramble and
   * sample order). Stratified over any power-of-two number of samples; other counts
   * (and time limits) work too, a little less evenly. The default. */
  BBC_SAMPLER_SOBOL = 0,
  /* Independent uniform numbers (a counter-based hash). */
  BBC_SAMPLER_INDEPENDENT = 1
} bbc_sampler;

/* Parts of the image, for comparisons; a mask, 0 = everything. */
#define BBC_COMPONENT_CAUSTICS 1u /* the caustic estimator's contributions, at any depth */
#define BBC_COMPONENT_DIRECT 2u   /* emission and lights seen before any diffuse bounce */
#define BBC_COMPONENT_INDIRECT 4u /* everything after a diffuse bounce but caustics */
/* The caustic estimator's contributions at the first surface the camera sees (no
 * specular vertex before it) and light tracing's: the caustic a light tracer can render,
 * for comparisons against one. Within BBC_COMPONENT_CAUSTICS. */
#define BBC_COMPONENT_SEEN_CAUSTICS 8u

/* Options; a zero-initialised struct means the defaults given per field. */
typedef struct bbc_render_options {
  uint32_t spp;           /* samples per pixel; 0 = 16 unless time_limit is set */
  double time_limit;      /* seconds of rendering; 0 = none. With both spp and
                             time_limit, whichever is reached first stops. */
  uint32_t max_depth;     /* maximum number of segments of a path from the camera
                             to a light, the connection to the light included;
                             0 = 16 */
  int threads;            /* 0 = every core */
  uint64_t seed;          /* the same seed gives the same image */
  int no_fresnel;         /* dielectrics always transmit (reflect only on total
                             internal reflection), the paper's assumption */
  bbc_method method;      /* default BBC_METHOD_PT; the others need `cache` */
  const bbc_cache *cache; /* the precomputed bounds (checked against the scene by the
                             caller with bbc_cache_check_scene) */
  bbc_gamma_mode gamma_mode;
  double gamma_value;
  uint32_t components;        /* BBC_COMPONENT_* mask; 0 = all */
  uint32_t chains;            /* BBC_CHAIN_BIT mask of chain types the caustic estimator
                                 uses; 0 = all in the cache */
  bbc_solver_method solver;   /* double-scattering tuples; default BBC_SOLVER_NEWTON_STOCH */
  uint32_t newton_max_trials; /* BBC_SOLVER_NEWTON_STOCH: K stops at this many draws (the
                                 estimate is then biased low; stats count it); 0 =
                                 BBC_NEWTON_MAX_TRIALS_DEFAULT */
  const bbc_camera *camera;   /* the camera to render; NULL = the scene's first */
  bbc_sampler sampler;        /* default BBC_SAMPLER_SOBOL */
  /* The pixels rendered: x0 <= x < x1 and y0 <= y < y1 of region {x0, y0, x1, y1}; the
   * others are left black. Each rendered pixel is bit-identical to the same pixel of a
   * whole-image render (its samples depend on the seed, the pixel and the sample index
   * only). All zero = the whole image; otherwise 0 <= x0 < x1 <= width and
   * 0 <= y0 < y1 <= height (BBC_ERR_INVALID_ARGUMENT otherwise). */
  uint32_t region[4];
  bbc_progress_fn progress;   /* optional; called between passes on the calling thread
                                 with samples per pixel done / planned (planned is 0
                                 under a pure time limit) */
  void *progress_user;
  /* Light tracing of caustic paths (docs/light-tracing.md), with a cache: photons from
   * the point, spot and delta-sun lights through one or more specular casters to a
   * diffuse point the camera sees directly. It counts the paths of three or more
   * specular vertices and of chain types the cache does not hold, and, for points seen
   * directly in a cell whose tuples of a chain type include one with a bound (per unit
   * intensity, as stored) of at least light_trace_bound, that chain type's paths, which
   * the caustic estimator then leaves out there: each path counted once. Without a cache
   * (BBC_METHOD_PT), it counts every such path, of any number of specular vertices: the
   * path tracer counts none of them (a point light is met by no sampled direction). */
  int light_trace;          /* 1: on; default 0 */
  double light_trace_bound; /* the cells' threshold: INFINITY (or 0) only cells with an
                               unbounded tuple, a negative value every cell, NaN
                               none (only the chains the cache cannot hold) */
  uint32_t photons_per_spp; /* photons traced per sample; 0 = the image's pixel
                               count (one per pixel per sample; the same for a region,
                               so that its pixels stay those of the whole image), a
                               sixteenth of it
                               when there is a cache, no caster is a dielectric and
                               no cell is light-traced (only chains of 3+ mirrors
                               remain) */
  /* Aimed photons per sample: photons that start on the first specular triangles of
   * the tuples in the light-traced cells; 0 = photons_per_spp if set, else the image's
   * pixel count, then after the first sample down to an eighth of it when few of them
   * reach a pixel (docs/light-tracing.md); BBC_AIMED_PHOTONS_OFF: none. */
  uint32_t aimed_photons_per_spp;
} bbc_render_options;

#define BBC_AIMED_PHOTONS_OFF UINT32_MAX

typedef struct bbc_render_stats {
  double seconds;   /* wall time of rendering */
  uint32_t spp;     /* samples per pixel completed */
  uint64_t samples; /* camera samples traced (spp times the region's pixels) */
  uint64_t rays;    /* closest-hit plus occlusion rays */
  int threads;      /* threads used */
  /* The caustic estimator (the paper's Table 2 render columns). */
  uint64_t lookups;    /* shading points that looked up a cell */
  uint64_t candidates; /* sum of |U| (tuples of the cell on the point's triangle) */
  uint64_t bins;       /* sum of |B| */
  uint64_t sampled;    /* sum of |S| */
  uint64_t solutions;  /* admissible paths found in sampled tuples (for newton-stoch,
                          the first start's solution of each tuple) */
  uint64_t excluded;   /* sampled single-scattering tuples that the exact pre-test
                          (bbc_solver_single_possible) showed to hold no path at the
                          point, so they were not solved */
  /* Newton's method on double-scattering tuples. */
  uint64_t newton_solves;    /* Newton runs: every start, those drawn for K included */
  uint64_t newton_converged; /* runs that ended on an admissible path */
  uint64_t newton_estimates; /* reciprocal-probability estimates made (newton-stoch) */
  uint64_t newton_trials;    /* the sum of their K: mean K = trials / estimates */
  uint64_t newton_cap_hits;  /* estimates whose K reached newton_max_trials */
  /* The next three are estimates: each thread times every 8th lookup and scales. */
  double sampling_seconds;   /* thread time preparing the cells' lists (sum over threads) */
  double decoding_seconds;   /* thread time decoding cells */
  double solving_seconds;    /* thread time drawing tuples, solving them and tracing
                                the paths' visibility */
  double thread_seconds;     /* thread time rendering, for the shares above */
  uint64_t photons;          /* light tracing: photons traced */
  uint64_t photon_splats;    /* ... and those that added to a pixel */
} bbc_render_stats;

/* Renders options->camera (else the scene's first camera) into image (whose size sets the resolution and the
 * aspect ratio, see bbc_camera_ray). The image receives the mean radiance per pixel (box
 * filter). accel must have been built for scene. stats may be NULL. Deterministic:
 * with an spp budget the image is bit-identical for any thread count. Returns
 * BBC_ERR_CANCELLED if the progress callback asks to stop; the image then holds the
 * mean of the completed passes. A lookup that meets a damaged chunk of the cache stops
 * the render at the end of the current pass with that lookup's result (BBC_ERR_CHECKSUM
 * or BBC_ERR_CORRUPT, reported once per thread at most through the cache's error
 * callback) and an all-zero image: no image is made from damaged data. To refuse a
 * damaged cache before the first pixel, call bbc_cache_validate first. */
BBC_API bbc_result bbc_render(const bbc_scene *scene, const bbc_accel *accel,
                              const bbc_render_options *options, bbc_image *image,
                              bbc_render_stats *stats);

#ifdef __cplusplus
}
#endif

#endif
