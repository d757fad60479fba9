/* The caustic estimator (paper Sec. 5, Alg. 1): at a diffuse shading point, the light of
 * point lights arriving through specular chains, estimated from the tuples of the
 * point's cache cell. */
#ifndef BBC_CAUSTICS_INTERNAL_H
#define BBC_CAUSTICS_INTERNAL_H

#include "bbc/render.h"
#include "rng_internal.h"
#include "sampler_internal.h"

typedef struct bbc__caustics {
  const bbc_scene *scene;
  const bbc_accel *accel;
  const bbc_cache *cache;
  const bbc_tuple *tuples;
  bbc__sampling sampling;
  uint32_t chains; /* BBC_CHAIN_BIT mask */
  int no_fresnel;
} bbc__caustics;

/* Per-thread state: the cache cursor (it keeps decoded chunks), the sampler's arrays
 * and counters. */
typedef struct bbc__caustics_thread {
  bbc_cache_cursor *cursor;
  bbc__tuple_sampler sampler;
  bbc_cache_entry *candidates;
  uint32_t candidate_capacity;
  uint64_t lookups, candidate_count, bins, sampled, solutions;
  double sampling_seconds, decoding_seconds, solving_seconds;
} bbc__caustics_thread;

bbc_result bbc__caustics_thread_init(bbc__caustics_thread *t, const bbc_cache *cache);
void bbc__caustics_thread_free(bbc__caustics_thread *t);

/* The irradiance (RGB, W/m^2) arriving at point p of receiver triangle `triangle` (with
 * barycentrics b1, b2 of its vertices 1 and 2) from the side the unit geometric normal
 * ng points to, through the cached chains. Unbiased: the expectation over rng is the
 * sum over every admissible path of its irradiance times visibility and Fresnel. */
bbc_vec3 bbc__caustics_estimate(const bbc__caustics *c, bbc__caustics_thread *t, bbc_vec3 p,
                                bbc_vec3 ng, uint32_t triangle, double b1, double b2, bbc_rng *rng);

#endif
