/* Bound-driven sampling of triangle tuples (paper Sec. 5, Alg. 1, Supp. 2.3): for the
 * tuples U of a cell with irradiance bounds E~, choose a subset S where each tuple is in
 * S with probability P_T, so that sum over S of E(T) / P_T estimates sum over U of E(T)
 * without bias. */
#ifndef BBC_SAMPLER_INTERNAL_H
#define BBC_SAMPLER_INTERNAL_H

#include <stdint.h>

#include "bbc/cache.h"
#include "rng_internal.h"

typedef enum bbc__sampling_method {
  BBC__SAMPLE_BOUND,     /* P = min(gamma E~, 1) (Eq. 28) */
  BBC__SAMPLE_ENUMERATE, /* P = 1 for every tuple (position bound only) */
  BBC__SAMPLE_UNIFORM,   /* the same expected count as BOUND, uniform P */
  BBC__SAMPLE_ONE        /* one tuple, P proportional to E~ (Eq. 23) */
} bbc__sampling_method;

typedef enum bbc__gamma_source {
  BBC__GAMMA_FIXED,    /* gamma given */
  BBC__GAMMA_EXPECTED, /* gamma such that sum min(gamma E~, 1) = W */
  BBC__GAMMA_VARIANCE  /* gamma such that sum E~^2 / min(gamma E~, 1) = V (Eq. 31) */
} bbc__gamma_source;

typedef struct bbc__sampling {
  bbc__sampling_method method;
  bbc__gamma_source source;
  double value; /* gamma, W or V */
} bbc__sampling;

/* A cell prepared for sampling: tuples packed into bins whose probabilities sum to at
 * most 1 (first the tuples with P = 1, one per bin). Owned by one thread; arrays grow as
 * needed and are reused between cells. */
typedef struct bbc__tuple_sampler {
  uint32_t n, bins, capacity;
  uint32_t *tuple;   /* tuple ids, in bin order */
  double *p;         /* their selection probabilities */
  double *prefix;    /* running sum of p within the tuple's bin, inclusive */
  uint32_t *bin_end; /* bin b holds [bin_end[b-1], bin_end[b]) */
  double *scratch;
  int one_sample; /* ONE: draw a single tuple from the whole list */
  double total;   /* ONE: sum of the weights */
} bbc__tuple_sampler;

void bbc__sampler_free(bbc__tuple_sampler *s);

/* Prepares the cell's list. Returns 0 on allocation failure. */
int bbc__sampler_prepare(bbc__tuple_sampler *s, const bbc_cache_entry *entries, uint32_t n,
                         const bbc__sampling *sampling);

/* Uniform numbers for the first bins whose draw is random, from the path tracer's
 * stratified sampler: get(user, j) for j < count, called only when needed. */
typedef struct bbc__bin_uniforms {
  double (*get)(const void *user, uint32_t j);
  const void *user;
  uint32_t count;
} bbc__bin_uniforms;

/* Draws S: calls emit(user, tuple, P) for every chosen tuple, P its probability of
 * being chosen. Uses one uniform number per bin but for a bin of one tuple with P = 1
 * (ONE: one for the single draw): the first given->count come from given (may be NULL),
 * the rest from rng. Returns the number chosen. */
uint32_t bbc__sampler_draw(const bbc__tuple_sampler *s, const bbc__bin_uniforms *given,
                           bbc_rng *rng, void (*emit)(void *user, uint32_t tuple, double p),
                           void *user);

/* gamma for a list of bounds from the source (bisection, Supp. 2.3); +inf when every
 * tuple must be taken. */
double bbc__sampler_gamma(const bbc_cache_entry *entries, uint32_t n, bbc__gamma_source source,
                          double value);

#endif
