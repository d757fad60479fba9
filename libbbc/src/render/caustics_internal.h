/* The caustic estimator (paper Sec. 5, Alg. 1): at a diffuse shading point, the light of
 * point lights arriving through specular chains, estimated from the tuples of the
 * point's cache cell. */
#ifndef BBC_CAUSTICS_INTERNAL_H
#define BBC_CAUSTICS_INTERNAL_H

#include "bbc/bsdf.h"
#include "bbc/render.h"
#include "bbc/solver.h"
#include "rng_internal.h"
#include "sampler_internal.h"

/* Two Newton results are the same solution when their u1 differ by at most this much
 * (barycentric units, max norm; specular manifold sampling uses a world-space threshold
 * of the same order). Newton stops where the data stop resolving the root, and near a
 * fold of the caustic (where two solutions merge and the Jacobian is singular) the set
 * of u1 whose paths pass within the verifier's angle tolerance of x_k is elongated:
 * starts there converge to points a few 1e-6 apart, and a tighter threshold would count
 * one solution as several (K, and the estimate, too large). Two genuinely distinct
 * solutions this close lie at a fold, in a band of negligible width. */
#define BBC__NEWTON_SAME_SOLUTION 1e-4

typedef struct bbc__caustics {
  const bbc_scene *scene;
  const bbc_accel *accel;
  int passable; /* bbc__media_passable */
  const bbc_cache *cache;
  const bbc_tuple *tuples;
  bbc__sampling sampling;
  /* Two-vertex tuples are drawn as if their bounds were this many times theirs (0: as
   * they are; 1/3 for the default gamma, docs/render.md): their solves cost more. */
  double double_weight;
  uint32_t chains; /* BBC_CHAIN_BIT mask */
  int no_fresnel;
  bbc_solver_method solver;   /* double scattering: deterministic or stochastic Newton */
  uint32_t newton_max_trials; /* cap on K (newton-stoch); 0 = BBC_NEWTON_MAX_TRIALS_DEFAULT */
  int area_lights;            /* the cache holds the emitters' tuples (R, T) */
  int area_double;            /* ... and their double-scattering ones (PARM flags bit 2) */
  uint32_t cache_chains;      /* BBC_CHAIN_BIT mask of the chain types the cache holds */
  /* Light tracing counts some of the paths seen directly by the camera
   * (light_trace_internal.h, docs/light-tracing.md): a receiver cell's chain type goes to
   * it when a tuple of the chain type has a bound of at least light_trace_bound. */
  int light_trace;
  double light_trace_bound;
} bbc__caustics;

/* A glossy receiver's reflectance at the shading point: each solution's value is
 * multiplied by f(wo, wi) for its own light direction wi (bsdf.h). */
typedef struct bbc__receiver_shading {
  const bbc_bsdf *bsdf;
  bbc_vec3 n;  /* unit shading normal, on the side being shaded */
  bbc_vec3 wo; /* unit direction toward the viewer */
} bbc__receiver_shading;

/* Per-thread state: the cache cursor (it keeps decoded chunks), the sampler's arrays
 * and counters. */
typedef struct bbc__caustics_thread {
  /* Set by the caller around an estimate: with it the estimate is radiance (each
   * solution times the BSDF), without it (NULL) irradiance. */
  const bbc__receiver_shading *shading;
  /* Set by the caller around an estimate at a point the camera sees directly: with
   * light tracing, the chain types light tracing counts there are skipped. */
  int seen_directly;
  bbc_cache_cursor *cursor;
  bbc__tuple_sampler sampler;
  bbc_cache_entry *candidates;
  uint32_t candidate_capacity;
  uint64_t lookups, candidate_count, bins, sampled, solutions, excluded;
  /* Newton on double-scattering tuples: runs, runs ending on an admissible path,
   * reciprocal-probability estimates, the sum of their K and those stopped at the cap. */
  uint64_t newton_solves, newton_converged, newton_estimates, newton_trials, newton_cap_hits;
  double sampling_seconds, decoding_seconds, solving_seconds;
  uint64_t timing_tick; /* lookups asked for, to time every TIMING_STRIDE-th (caustics.c) */
  /* The first failed lookup (a damaged chunk: BBC_ERR_CHECKSUM or BBC_ERR_CORRUPT), or
   * BBC_OK. Once set, this thread looks nothing up any more and the render stops: no
   * image is made from a damaged cache (format-spec Sec. 9, R-REN-1). */
  bbc_result damage;
} bbc__caustics_thread;

bbc_result bbc__caustics_thread_init(bbc__caustics_thread *t, const bbc_cache *cache);
void bbc__caustics_thread_free(bbc__caustics_thread *t);

/* The irradiance (RGB, W/m^2) arriving at point p of receiver triangle `triangle` (with
 * barycentrics b1, b2 of its vertices 1 and 2) from the side the unit geometric normal
 * ng points to, through the cached chains of at most max_vertices specular vertices
 * (so the path stays within the render's depth limit). Unbiased with newton-stoch (up
 * to the cap on K): the expectation over rng is the sum over every admissible path of
 * its irradiance times visibility and Fresnel (for double scattering, every path
 * Newton reaches from some start on T1). The expectation is over bin_u (uniforms for
 * the tuple sampler's first bins, see bbc__sampler_draw; may be
 * NULL) and the streams keyed by `key` (the rest of the bins, and each tuple's own stream),
 * which the caller must make unique per shading point of each path. */
bbc_vec3 bbc__caustics_estimate(const bbc__caustics *c, bbc__caustics_thread *t, bbc_vec3 p,
                                bbc_vec3 ng, uint32_t triangle, double b1, double b2,
                                int max_vertices, uint64_t key,
                                const bbc__bin_uniforms *bin_u);

/* The contribution of one tuple at p, before division by its selection probability:
 * every solution's value for single scattering (specular polynomials); for double
 * scattering the Newton estimate of c->solver, random starts drawn from the stream
 * keyed by `key` (any 64-bit value; the estimator derives it from the pixel, sample,
 * dimension and tuple id). Needs c->scene, c->accel, c->no_fresnel, c->solver and
 * c->newton_max_trials only (no cache). Exposed for the tests. */
bbc_vec3 bbc__caustics_tuple(const bbc__caustics *c, bbc__caustics_thread *t,
                             const bbc_tuple *tuple, bbc_vec3 p, bbc_vec3 ng, uint64_t key);

/* The value of one solution of a tuple at p: its irradiance per unit intensity times the
 * light's RGB intensity, the Fresnel transmittance of every refraction (unless
 * c->no_fresnel) and its base-colour tint, the reflectance of every mirror and the
 * Beer-Lambert transmittance of every segment inside a dielectric (media_internal.h; all
 * at most 1, so the cached bounds still hold), if every segment is unoccluded,
 * the light arrives at p from the side ng points to and every refraction agrees with
 * the side the bounds assume; else 0. g must be bbc_path_geometry_init of the tuple.
 * Exposed for the tests. */
/* The clean split between the estimator and path tracing for area lights
 * (docs/lights.md): 1 when the path tracer's path p (on receiver triangle `receiver`)
 * -> its `length` (1 or 2) specular vertices -> the front of emitter triangle `emitter`
 * at y is one the estimator counts, so that path tracing must not. The specular vertices
 * are given in the light's order: x[i] on triangle tri[i] with unit shading normal n[i]
 * as loaded, letter[i] 0 for a mirror reflection, 1 for a refraction, -1 for anything
 * else (a Fresnel reflection off glass). Counted by the estimator: the cache holds the
 * emitter's tuples of this chain type (double scattering only with c->area_double), the
 * chain type is rendered, each tri[i] is a caster of its letter, the light arrives on
 * the side of T1 the bounds orient it to (toward the emitter's centroid) and on the side
 * of T2 they orient it to (toward T1's centroid), and the medium rule lets it refract
 * where it does. */
int bbc__caustics_area_covers(const bbc__caustics *c, uint32_t receiver, int length,
                              const uint32_t tri[2], const int letter[2], uint32_t emitter,
                              bbc_vec3 y, const bbc_vec3 x[2], const bbc_vec3 n[2]);

/* The same split for a sun with an angular size (docs/lights.md): 1 when the path
 * tracer's path from receiver triangle `receiver` through `count` (1 or 2) specular
 * vertices that escapes toward punctual light `light`, a sun whose disk the escape
 * direction w (unit, toward the sky) lies in, is one the estimator counts with the sun's
 * centre direction, so that path tracing must not. The specular vertices are given in
 * the order the camera path met them: triangle[i], letter[i] (0 a mirror reflection, 1 a
 * refraction, -1 anything else), point x[i] and unit shading normal n[i] as loaded. 1
 * when the chain type (in light order: the last vertex met is T1) is rendered and in the
 * cache, every vertex lies on a caster of its letter's kind, the receiver is one, and
 * each refraction passes the side and medium rules the estimator applies. */
int bbc__caustics_sun_covers(const bbc__caustics *c, uint32_t light, uint32_t receiver, int count,
                             const uint32_t triangle[2], const int letter[2], const bbc_vec3 x[2],
                             const bbc_vec3 n[2], bbc_vec3 w);

bbc_vec3 bbc__caustics_solution_value(const bbc__caustics *c, const bbc_tuple *tuple,
                                      const bbc_path_geometry *g, const bbc_solution *s, bbc_vec3 p,
                                      bbc_vec3 ng);

#endif
