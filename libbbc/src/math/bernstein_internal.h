/* Internals shared by bernstein.c, bernstein_bound.c, remainder.c and interval.c. Private. */
#ifndef BBC_BERNSTEIN_INTERNAL_H
#define BBC_BERNSTEIN_INTERNAL_H

#include "bbc/bernstein.h"

/* Early return on failure, as zstd's FORWARD_IF_ERROR. */
#define BBC__TRY(expr)                     \
  do {                                     \
    bbc_result bbc__r_ = (expr);           \
    if (bbc__r_ != BBC_OK) return bbc__r_; \
  } while (0)

/* Row n of Pascal's triangle, C(n, k) for k = 0..n, each the correctly rounded double of the
 * exact integer (exact up to n = 56). 0 <= n <= BBC_POLY_MAX_DEGREE. Thread-safe. */
const double *bbc__binomial_row(int n);

/* prod(deg[j] + 1). */
size_t bbc__size(const unsigned char deg[BBC_POLY_MAX_AXES]);
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
