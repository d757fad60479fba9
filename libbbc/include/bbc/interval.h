/* Plain interval arithmetic with outward rounding: the baseline that the Bernstein bounds of
 * bernstein.h are compared against (paper Fig. 4, "interval arithmetic" after Wang et al.).
 *
 * Every operation returns an interval that contains the exact real result of the operation
 * applied to any points of its operands: each computed endpoint is pushed outward by at least
 * one unit in the last place after the round-to-nearest operation, so no rounding mode has to
 * be changed and the functions are safe to call from any thread.
 *
 * Conventions shared by all functions here:
 *  - An interval is [lo, hi] with lo <= hi; endpoints may be -INFINITY / +INFINITY.
 *  - A result that cannot be bounded (division by an interval containing 0, inf - inf, a NaN
 *    operand) is the whole line [-INFINITY, +INFINITY]; NaN never escapes these functions.
 *  - All functions are pure: no global state, no allocation, thread-safe. */
#ifndef BBC_INTERVAL_H
#define BBC_INTERVAL_H

#include "bbc/common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct bbc_interval {
  double lo, hi;
} bbc_interval;

/* An interval of three coordinates, for the vector expressions of the chain (reflection,
 * Möller–Trumbore) evaluated the interval way. */
typedef struct bbc_ivec3 {
  bbc_interval x, y, z;
} bbc_ivec3;

/* [lo, hi]; the endpoints are swapped when given in the wrong order. */
BBC_API bbc_interval bbc_interval_make(double lo, double hi);
/* The degenerate interval [v, v]. */
BBC_API bbc_interval bbc_interval_point(double v);
/* The whole line [-inf, +inf]. */
BBC_API bbc_interval bbc_interval_entire(void);

BBC_API bbc_interval bbc_interval_add(bbc_interval a, bbc_interval b);
BBC_API bbc_interval bbc_interval_sub(bbc_interval a, bbc_interval b);
BBC_API bbc_interval bbc_interval_neg(bbc_interval a);
BBC_API bbc_interval bbc_interval_mul(bbc_interval a, bbc_interval b);
/* a * s for a scalar s (exact s, as if [s, s]). */
BBC_API bbc_interval bbc_interval_scale(bbc_interval a, double s);
/* a / b; the whole line when b contains 0. */
BBC_API bbc_interval bbc_interval_div(bbc_interval a, bbc_interval b);
/* The range of x^2 over a (tighter than a * a, which treats the factors as independent). */
BBC_API bbc_interval bbc_interval_sqr(bbc_interval a);
/* Encloses sqrt(max(x, 0)) for x in a: the negative part of a is treated as 0, the
 * convention of the refraction term (Eq. 11), whose negative values mean total internal
 * reflection and are never evaluated by a path. */
BBC_API bbc_interval bbc_interval_sqrt(bbc_interval a);

/* The smallest interval containing a and b. */
BBC_API bbc_interval bbc_interval_hull(bbc_interval a, bbc_interval b);
/* hi - lo rounded up (+inf for unbounded intervals). */
BBC_API double bbc_interval_width(bbc_interval a);
/* 1 when lo <= v <= hi, else 0. */
BBC_API int bbc_interval_contains(bbc_interval a, double v);

BBC_API bbc_ivec3 bbc_ivec3_point(bbc_vec3 v);
BBC_API bbc_ivec3 bbc_ivec3_add(bbc_ivec3 a, bbc_ivec3 b);
BBC_API bbc_ivec3 bbc_ivec3_sub(bbc_ivec3 a, bbc_ivec3 b);
/* s * v with an interval factor s. */
BBC_API bbc_ivec3 bbc_ivec3_scale(bbc_interval s, bbc_ivec3 v);
BBC_API bbc_interval bbc_ivec3_dot(bbc_ivec3 a, bbc_ivec3 b);
BBC_API bbc_ivec3 bbc_ivec3_cross(bbc_ivec3 a, bbc_ivec3 b);

#ifdef __cplusplus
}
#endif

#endif
