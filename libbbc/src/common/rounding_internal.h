/* Outward rounding without changing the rounding mode. Private to libbbc.
 *
 * Every helper here takes the round-to-nearest result x of ONE correctly rounded operation
 * (+, -, *, /, sqrt, or an exact value) and returns a value on the safe side of the exact
 * result z. Round to nearest gives |x - z| <= u |x| (u = 2^-53) for normal results and an
 * absolute error <= 2^-1075 in the subnormal range. bbc__down returns
 * x - (4u|x| + 2^-1060), whose own rounding error is at most u(|x| + 4u|x| + ...), so the
 * result is below x - u|x| - 2^-1075 <= z. bbc__up is symmetric. This costs about two ulps
 * per operation and works with the default floating-point environment, so it is thread-safe
 * and immune to a library that changes the rounding mode behind our back.
 *
 * Infinities: down(+inf) = DBL_MAX (an overflowed result is still >= DBL_MAX), up(-inf) =
 * -DBL_MAX; NaN is returned unchanged and callers turn it into an unbounded answer. */
#ifndef BBC_ROUNDING_INTERNAL_H
#define BBC_ROUNDING_INTERNAL_H

#include <float.h>
#include <math.h>

#define BBC__U 0x1p-53
/* An absolute allowance that covers the error of any subnormal result. */
#define BBC__ETA 0x1p-1060

static inline double bbc__down(double x) {
  if (x == INFINITY) return DBL_MAX;
  if (!(x > -INFINITY)) return x; /* -inf stays, NaN stays */
  return x - (fabs(x) * 0x1p-51 + BBC__ETA);
}

static inline double bbc__up(double x) {
  if (x == -INFINITY) return -DBL_MAX;
  if (!(x < INFINITY)) return x;
  return x + (fabs(x) * 0x1p-51 + BBC__ETA);
}

static inline double bbc__add_down(double a, double b) {
  return bbc__down(a + b);
}
static inline double bbc__add_up(double a, double b) {
  return bbc__up(a + b);
}
static inline double bbc__sub_down(double a, double b) {
  return bbc__down(a - b);
}
static inline double bbc__sub_up(double a, double b) {
  return bbc__up(a - b);
}
static inline double bbc__mul_down(double a, double b) {
  return bbc__down(a * b);
}
static inline double bbc__mul_up(double a, double b) {
  return bbc__up(a * b);
}
static inline double bbc__div_down(double a, double b) {
  return bbc__down(a / b);
}
static inline double bbc__div_up(double a, double b) {
  return bbc__up(a / b);
}

/* Error radii are non-negative; a NaN radius (0 * inf, inf - inf) means "unknown" and is
 * replaced by +inf so that every bound computed from it is unbounded. */
static inline double bbc__radius(double e) {
  return (e >= 0.0) ? e : INFINITY;
}

/* gamma_n = n u / (1 - n u) (Higham, Accuracy and Stability, Lemma 3.1), rounded up: the
 * relative error of a product of n factors (1 + delta_i)^(+-1), |delta_i| <= u. Infinite
 * when n u is not small. */
static inline double bbc__gamma(double n) {
  if (!(n >= 0.0)) return INFINITY;
  double nu = n * BBC__U; /* exact for integral n below 2^53: a power-of-two scaling */
  if (nu >= 0.25) return INFINITY;
  return bbc__div_up(nu, bbc__sub_down(1.0, nu));
}

#endif
