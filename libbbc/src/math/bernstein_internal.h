/* Internals shared by bernstein.c, bernstein_bound.c, remainder.c and interval.c. Private. */
#ifndef BBC_BERNSTEIN_INTERNAL_H
#define BBC_BERNSTEIN_INTERNAL_H

#include "bbc/bernstein.h"

#include <stdint.h>
#include <string.h>

/* Early return on failure, as zstd's FORWARD_IF_ERROR. */
#define BBC__TRY(expr)                     \
  do {                                     \
    bbc_result bbc__r_ = (expr);           \
    if (bbc__r_ != BBC_OK) return bbc__r_; \
  } while (0)

/* Row n of Pascal's triangle, C(n, k) for k = 0..n, each the correctly rounded double of the
 * exact integer (exact up to n = 56). 0 <= n <= BBC_POLY_MAX_DEGREE. Thread-safe. */
const double *bbc__binomial_row(int n);

/* prod(deg[j] + 1), written out: it is asked for on every operation. */
static inline size_t bbc__size(const unsigned char deg[BBC_POLY_MAX_AXES]) {
  _Static_assert(BBC_POLY_MAX_AXES == 8, "bbc__size multiplies eight degrees");
  return (((size_t)deg[0] + 1) * ((size_t)deg[1] + 1)) *
         (((size_t)deg[2] + 1) * ((size_t)deg[3] + 1)) *
         ((((size_t)deg[4] + 1) * ((size_t)deg[5] + 1)) *
          (((size_t)deg[6] + 1) * ((size_t)deg[7] + 1)));
}

/* Whether p has coefficients and every degree at most BBC_POLY_MAX_DEGREE, the eight
 * degrees tested at once: a byte above 120 has its top bit set or gets it from + 7, and
 * + 7 carries into the next byte only from a byte whose top bit is set already. */
static inline int bbc__poly_ok(const bbc_poly *p) {
  _Static_assert(BBC_POLY_MAX_AXES == 8 && BBC_POLY_MAX_DEGREE == 120,
                 "bbc__poly_ok tests eight degrees against 120");
  if (!p || !p->coef) return 0;
  uint64_t d;
  memcpy(&d, p->deg, sizeof d);
  return ((d | (d + 0x0707070707070707u)) & 0x8080808080808080u) == 0;
}

/* Strides of the tensor (last axis fastest); returns the size. */
size_t bbc__strides(const unsigned char deg[BBC_POLY_MAX_AXES], size_t stride[BBC_POLY_MAX_AXES]);
/* max |c_i|, or +inf when some c_i is not finite. */
double bbc__maxabs(const double *c, size_t n);
/* Coefficient storage for the given degrees. */
bbc_result bbc__alloc_coef(bbc_arena *arena, const unsigned char deg[BBC_POLY_MAX_AXES],
                           double **out);
/* Applies the (rows x (deg[axis]+1)) matrix m along `axis`: out has degree rows-1 there.
 * rows <= BBC_POLY_MAX_DEGREE + 1. */
void bbc__axis_apply(const double *in, const unsigned char deg[BBC_POLY_MAX_AXES], int axis,
                     const double *m, int rows, double *out);
/* p elevated to deg (>= p->deg per axis) into dst (size of deg); *err receives the radius of
 * the result, p->err included. dst may be p->coef when no axis changes. */
bbc_result bbc__elevate_into(bbc_arena *arena, const bbc_poly *p,
                             const unsigned char deg[BBC_POLY_MAX_AXES], double *dst, double *err);
/* sum_k alpha[k] p[k] at degree deg (>= every p[k]->deg) into dst; *err as above. */
bbc_result bbc__lincomb_into(bbc_arena *arena, int n, const double *alpha, const bbc_poly *const *p,
                             const unsigned char deg[BBC_POLY_MAX_AXES], double *dst, double *err);

/* bbc_poly_reduce_split with a degree limit per axis (max_degree[j] for geometric axis
 * j): the same fit and enclosure, axis by axis. bbc_poly_reduce_split is this with one
 * limit for every axis. */
bbc_result bbc__poly_reduce_split_to(bbc_arena *arena, const bbc_space *space, bbc_poly *fit,
                                     bbc_interval *error, const bbc_poly *p,
                                     const unsigned char max_degree[BBC_POLY_MAX_AXES]);

#endif
