/* Tensor-product Bernstein polynomials with conservative range bounds (paper Sec. 4.1,
 * DESIGN 3.1, 3.3, 3.4). This is the arithmetic the position and irradiance bounds of a
 * piece are computed with.
 *
 * A polynomial lives on the unit box [0,1]^BBC_POLY_MAX_AXES. Every polynomial has all
 * BBC_POLY_MAX_AXES axes; an axis it does not depend on has degree 0 and costs nothing, so
 * axis j means the same variable in every polynomial of one computation and operands never
 * need to be re-indexed. The coefficients are the dense Bernstein coefficient tensor (Eq. 1-2)
 * in doubles, contiguous, last axis fastest.
 *
 * THE GUARANTEE. Each polynomial carries an error radius `err`: whatever sequence of
 * operations produced it, every stored coefficient differs by at most `err` from the
 * coefficient the same operations would have produced in exact real arithmetic on the same
 * inputs (inputs are the doubles handed to the constructors, taken as exact). Operations
 * propagate `err` with standard floating-point error bounds (gamma_n = n u / (1 - n u),
 * u = 2^-53) computed with upward rounding, so rounding can make bounds wider, never wrong:
 *  - bbc_poly_bound() encloses the exact polynomial's range on the box;
 *  - bbc_rational_bound() encloses the range of the exact p/q wherever q != 0;
 *  - the derivative of the exact polynomial is within the derivative's `err`.
 * A non-finite coefficient (overflow) makes `err` infinite, and every bound unbounded.
 * The library must be compiled without -ffast-math and with -ffp-contract=off (CMake does).
 *
 * Remainder variables (Sec. 4.3, Eq. 12; Supp. Sec. 1.1): a quantity known only up to an
 * interval [lo, hi] is written as f + (1 - xi) lo + xi hi with xi in [0, 1] its own axis of
 * degree 1. The bound of anything computed from it then covers every value the quantity can
 * take (Supp. Theorem 1.1). Independence rule: two independent remainders must never share an
 * axis, while one remainder used twice keeps its single axis (the correlation is real). A
 * bbc_space records which axes are geometric and which are remainders, and hands out fresh
 * axes; the remainder-producing functions below always take a fresh one.
 *
 * Memory: polynomials are carved from a caller-owned bbc_arena (a fixed buffer with a bump
 * pointer, reset per piece); nothing here calls malloc. A bbc_poly is a small value struct
 * that points into the arena; it stays valid until the arena is reset below the point where
 * it was allocated.
 *
 * Threads: no function keeps global mutable state (a binomial table is built once, thread-
 * safely, on first use). One arena and the polynomials in it belong to one thread at a time;
 * different threads use different arenas.
 *
 * Errors: functions that allocate return bbc_result: BBC_ERR_INVALID_ARGUMENT for NULL
 * pointers or out-of-range parameters, BBC_ERR_OUT_OF_MEMORY when the arena is full,
 * BBC_ERR_UNSUPPORTED when a degree would exceed BBC_POLY_MAX_DEGREE or a space has no free
 * axis. On failure the output is left unchanged and the arena is as it was before the call.
 * Output structs may alias inputs (bbc_poly_add(a, &s, &s, &t) is fine). */
#ifndef BBC_BERNSTEIN_H
#define BBC_BERNSTEIN_H

#include "bbc/common.h"
#include "bbc/interval.h"

#ifdef __cplusplus
extern "C" {
#endif

#define BBC_POLY_MAX_AXES 8
/* Per-axis degree limit. Products of two degree-40 factors (the paper's reduction threshold)
 * reach 80; binomials up to this size are exact in 128-bit integers and correctly rounded. */
#define BBC_POLY_MAX_DEGREE 120

/* ---- Arena ---------------------------------------------------------------------------- */

/* A bump allocator over a caller-provided buffer. Plain struct: initialise with
 * bbc_arena_init; the fields are read-only for callers. `peak` is the largest `used` seen,
 * to size buffers. */
typedef struct bbc_arena {
  unsigned char *base;
  size_t capacity;
  size_t used;
  size_t peak;
} bbc_arena;

/* Uses `buffer` (capacity bytes, any alignment, owned by the caller and outliving the arena). */
BBC_API void bbc_arena_init(bbc_arena *arena, void *buffer, size_t capacity);
/* 16-byte aligned memory, or NULL when the arena is full (or arena is NULL). */
BBC_API void *bbc_arena_alloc(bbc_arena *arena, size_t bytes);
/* The current fill level, to be passed to bbc_arena_reset to free everything allocated since. */
BBC_API size_t bbc_arena_mark(const bbc_arena *arena);
/* Frees everything allocated after `mark` (0 frees all). Polynomials allocated after the
 * mark become invalid. NULL-safe. */
BBC_API void bbc_arena_reset(bbc_arena *arena, size_t mark);

/* ---- Variable space ------------------------------------------------------------------- */

typedef enum bbc_axis_kind {
  BBC_AXIS_FREE = 0,      /* not in use; polynomials must have degree 0 on it */
  BBC_AXIS_GEOMETRIC = 1, /* a variable of the piece (s, t of u1, receiver or light variables) */
  BBC_AXIS_REMAINDER = 2  /* a remainder variable xi in [0, 1] */
} bbc_axis_kind;

/* Which axis means what, shared by all polynomials of one computation. Plain struct; a
 * zero-initialised space has every axis free. Geometric axes are handed out from the last
 * axis downwards and remainder axes from axis 0 upwards, so that the geometric axes (high
 * degree) are the contiguous, fastest-varying ones in the coefficient tensors. */
typedef struct bbc_space {
  unsigned char kind[BBC_POLY_MAX_AXES];
} bbc_space;

/* Claims a free axis of the given kind (GEOMETRIC or REMAINDER) and stores its index in
 * *axis. BBC_ERR_UNSUPPORTED when all axes are in use. */
BBC_API bbc_result bbc_space_add_axis(bbc_space *space, bbc_axis_kind kind, int *axis);
/* Marks an axis free again. Only legal when no live polynomial still depends on it (degree
 * > 0): reusing the axis of a live remainder for a new one would break the independence
 * rule and with it the bound. */
BBC_API void bbc_space_release_axis(bbc_space *space, int axis);

/* ---- Polynomials ---------------------------------------------------------------------- */

/* See the guarantee above. Plain struct; `coef` points into an arena. */
typedef struct bbc_poly {
  double *coef;                         /* prod(deg[j] + 1) coefficients, last axis fastest */
  double err;                           /* coefficient error radius, >= 0 */
  unsigned char deg[BBC_POLY_MAX_AXES]; /* degree per axis */
} bbc_poly;

/* A vector of three polynomials, for the chain formulas (Eq. 9-10). */
typedef struct bbc_poly3 {
  bbc_poly x, y, z;
} bbc_poly3;

/* Number of coefficients, prod(deg[j] + 1). */
BBC_API size_t bbc_poly_size(const bbc_poly *p);

/* The constant `value` (all degrees 0, exact). */
BBC_API bbc_result bbc_poly_constant(bbc_arena *arena, bbc_poly *out, double value);
/* The degree-1 function of one axis with value v0 at x_axis = 0 and v1 at x_axis = 1
 * (v0 + (v1 - v0) x_axis); exact, since its Bernstein coefficients are v0 and v1. */
BBC_API bbc_result bbc_poly_linear(bbc_arena *arena, bbc_poly *out, int axis, double v0, double v1);
/* The affine function c + sum_j grad[j] x_j (degree 1 where grad[j] != 0). The corner
 * sums are rounded; the rounding goes into err. */
BBC_API bbc_result bbc_poly_affine(bbc_arena *arena, bbc_poly *out, double c,
                                   const double grad[BBC_POLY_MAX_AXES]);
/* A copy with fresh storage. */
BBC_API bbc_result bbc_poly_copy(bbc_arena *arena, bbc_poly *out, const bbc_poly *p);
/* Adds `radius` to p->err (rounded up): the way to account for uncertainty in the inputs,
 * e.g. rounding in the caller's computation of a vertex position. */
BBC_API void bbc_poly_widen(bbc_poly *p, double radius);

/* a + b and a - b, after elevating both to the per-axis maximum degree. */
BBC_API bbc_result bbc_poly_add(bbc_arena *arena, bbc_poly *out, const bbc_poly *a,
                                const bbc_poly *b);
BBC_API bbc_result bbc_poly_sub(bbc_arena *arena, bbc_poly *out, const bbc_poly *a,
                                const bbc_poly *b);
/* sum_k alpha[k] p[k] for n >= 1 terms, at the per-axis maximum degree. */
BBC_API bbc_result bbc_poly_lincomb(bbc_arena *arena, bbc_poly *out, int n, const double *alpha,
                                    const bbc_poly *const *p);
/* s * p. */
BBC_API bbc_result bbc_poly_scale(bbc_arena *arena, bbc_poly *out, const bbc_poly *p, double s);
/* p + s (a constant is s in every Bernstein coefficient, so no elevation is needed). */
BBC_API bbc_result bbc_poly_add_scalar(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                                       double s);
/* a * b, degree a.deg + b.deg per axis, in the scaled Bernstein form: coefficients times
 * binomials, tensor convolution, division by C(n1 + n2, k). Exact in real arithmetic; never
 * goes through the power basis (Supp. Sec. 3.2). */
BBC_API bbc_result bbc_poly_mul(bbc_arena *arena, bbc_poly *out, const bbc_poly *a,
                                const bbc_poly *b);
/* The partial derivative along `axis` with respect to the unit-box variable x_axis (degree
 * n - 1, coefficients n (c_{i+1} - c_i)). For a piece [lo, hi] of an outer variable the
 * derivative with respect to that variable is this divided by (hi - lo). For a polynomial
 * with remainder axes this is the derivative of the surrogate, which encloses the derivative
 * of the true function only when the remainders were built derivative-aware
 * (bbc_poly_sqrt_derivative_aware); take derivatives before bbc_poly_reduce. */
BBC_API bbc_result bbc_poly_derivative(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                                       int axis);
/* The same polynomial at higher degree: deg[j] >= p->deg[j] for every axis. */
BBC_API bbc_result bbc_poly_elevate(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                                    const unsigned char deg[BBC_POLY_MAX_AXES]);
/* The polynomial on the sub-box prod_j [lo[j], hi[j]] of [0,1]^m, re-parameterised to the
 * unit box (de Casteljau). 0 <= lo[j] <= hi[j] <= 1. So that bounds stay conservative when
 * lo/hi is not a double, the covered interval may start up to one ulp of lo/hi below lo[j];
 * it always contains [lo[j], hi[j]]. Axes of degree 0 are ignored. */
BBC_API bbc_result bbc_poly_restrict(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                                     const double lo[BBC_POLY_MAX_AXES],
                                     const double hi[BBC_POLY_MAX_AXES]);
/* Halves along `axis`: left covers x_axis in [0, 1/2], right [1/2, 1] (both exact
 * re-parameterisations). Either output may be NULL. */
BBC_API bbc_result bbc_poly_split(bbc_arena *arena, const bbc_poly *p, int axis, bbc_poly *left,
                                  bbc_poly *right);
/* The value at x (de Casteljau; entries for degree-0 axes are ignored; x in [0,1]). Plain
 * floating point: the true value is within about p->err + (sum of degrees) * 3u * max|coef|.
 * NaN when p or x is NULL. For tests and diagnostics; bounds never use it. */
BBC_API double bbc_poly_eval(const bbc_poly *p, const double x[BBC_POLY_MAX_AXES]);

/* ---- Bounds --------------------------------------------------------------------------- */

/* [min coef - err, max coef + err], rounded outward: encloses the exact polynomial on the
 * whole box (convex hull property). [-inf, +inf] when a coefficient or err is not finite. */
BBC_API bbc_interval bbc_poly_bound(const bbc_poly *p);

typedef enum bbc_range_kind {
  BBC_RANGE_BOUNDED = 0,    /* lo <= f <= hi */
  BBC_RANGE_COMPLEMENT = 1, /* f <= lo or f >= hi: f avoids the open interval (lo, hi); lo may
                               be -inf (then f >= hi) and hi may be +inf (then f <= lo) */
  BBC_RANGE_UNBOUNDED = 2   /* nothing is known: a normal answer near focal points and
                               grazing angles, not an error */
} bbc_range_kind;

typedef struct bbc_range {
  bbc_range_kind kind;
  double lo, hi;
} bbc_range;

/* 1 when v is allowed by r (always 1 for UNBOUNDED). */
BBC_API int bbc_range_contains(const bbc_range *r, double v);

/* The range of p/q over the box (Eq. 3), at points where q != 0. Both are elevated to the
 * common degree. If every coefficient of q provably has one sign (its coefficient interval
 * [c - err, c + err] excludes 0), the result is BOUNDED by the extreme coefficient ratios.
 * Otherwise, if every coefficient of p has one sign, the reciprocal q/p is bounded by [L, H]
 * the same way and inverted: [L, H] on one side of 0 gives BOUNDED [1/H, 1/L]; L < 0 < H gives
 * COMPLEMENT (1/L, 1/H); L = 0 < H gives COMPLEMENT (-inf, 1/H); L < 0 = H gives COMPLEMENT
 * (1/L, +inf). Otherwise (or when L = H = 0) UNBOUNDED. Every ratio is computed with interval
 * division on the coefficient intervals and rounded outward; excluded intervals are shrunk
 * inward. Needs arena space only for the elevation. */
BBC_API bbc_result bbc_rational_bound(bbc_arena *arena, const bbc_poly *p, const bbc_poly *q,
                                      bbc_range *out);

/* ---- Remainder variables, degree reduction, square roots ------------------------------ */

/* out = f + (1 - xi) lo + xi hi on a fresh remainder axis xi claimed from `space`
 * (Supp. Eq. 2); *axis receives it (axis may be NULL). f may be NULL for 0: the quantity is
 * then known only by its interval [lo, hi]. lo <= hi. */
BBC_API bbc_result bbc_poly_remainder(bbc_arena *arena, bbc_space *space, bbc_poly *out,
                                      const bbc_poly *f, double lo, double hi, int *axis);

/* Degree reduction (Sec. 6.1, DESIGN 3.4). Fits F, a polynomial of the geometric axes only,
 * with degree min(p->deg[j], max_degree) on each geometric axis, to p by discrete least
 * squares (tensor Chebyshev nodes, Householder QR, per axis; remainder axes are averaged
 * out). Then bounds the difference p - F with its Bernstein coefficients over every axis,
 * old remainder axes included, as [e_lo, e_hi] (p->err included) and returns
 * F + (1 - zeta) e_lo + zeta e_hi with zeta a fresh remainder axis (*axis, may be NULL).
 * The result does not depend on p's old remainder axes; release them in the space when no
 * other live polynomial uses them. The fit only has to be good, not exact: the
 * enclosure comes from the error bound. max_degree >= 0. */
BBC_API bbc_result bbc_poly_reduce(bbc_arena *arena, bbc_space *space, bbc_poly *out,
                                   const bbc_poly *p, int max_degree, int *axis);

/* The two halves of bbc_poly_reduce: the fit F (geometric axes only) in *fit and the
 * enclosure of p - F over every axis in *error, without claiming an axis;
 * bbc_poly_remainder(F, error->lo, error->hi) then gives what bbc_poly_reduce returns. A
 * caller reducing several quantities can so finish with their old remainder axes, release
 * them, and only then give each reduced quantity its own fresh axis. */
BBC_API bbc_result bbc_poly_reduce_split(bbc_arena *arena, const bbc_space *space, bbc_poly *fit,
                                         bbc_interval *error, const bbc_poly *p, int max_degree);

/* Primal square-root linearisation on [l, r] (Supp. Eq. 6-12): sqrt(x) = a x + b + delta
 * with delta in [delta_lo, delta_hi] for every x in [max(l, 0), max(r, 0)]. a is the secant
 * slope (Eq. 8, computed as 1/(sqrt r + sqrt l)), b matches sqrt at the left end (Eq. 9).
 * The error bounds are computed rigorously for the stored a and b (Eq. 10-12: the error is
 * concave, so its minimum is at an end and its maximum at most 1/(4a) - b). No clamping is
 * needed: l = 0 gives a = 1/sqrt(r), b = 0. */
typedef struct bbc_sqrt_primal {
  double a, b;
  double delta_lo, delta_hi;
} bbc_sqrt_primal;

/* Derivative-aware two-stage linearisation (Supp. Eq. 15-25): with
 * s(xi) = a + (1 - xi) slope_lo + xi slope_hi and
 * value(x, xi, zeta) = a x + b + (s(xi) - a) (x - c) + (1 - zeta) delta_lo + zeta delta_hi,
 * for every x in [max(l,0), max(r,0)] there are xi, zeta in [0,1] with value = sqrt(x), and
 * when x >= clamp that same xi also gives s(xi) = 1/(2 sqrt x), the derivative.
 *
 * The lower end used for the slopes is `clamp` = max(l, requested clamp): 1/(2 sqrt x) is
 * unbounded at 0, so no finite slope interval exists when l = 0. Points below the clamp
 * keep an exact VALUE enclosure (delta_lo is widened to cover them, using the steepest
 * slope) but their slope is not enclosed: slope_enclosed is then 0, and a caller bounding
 * something that depends on the slope (irradiance) must treat that piece as unbounded.
 *
 * Note: Supp. Eq. 23-24 as printed give the primal error as (1 - sqrt(l/x))^2 / 2, which
 * is missing a factor sqrt(x): the error is (sqrt x - sqrt l)^2 / (2 sqrt x), at most
 * (sqrt r - sqrt l)^2 / (2 sqrt r). The printed bound is too small whenever r > 1. We bound
 * the error of the stored coefficients directly, which gives the correct value. */
typedef struct bbc_sqrt_derivative_aware {
  double a, b, c;            /* Eq. 18, 21, 22 */
  double slope_lo, slope_hi; /* Eq. 19-20 (delta_i) */
  double delta_lo, delta_hi; /* Eq. 25 (delta'_i), corrected as above */
  double clamp;              /* lower end used for the slopes */
  int slope_enclosed;        /* 1 when clamp <= max(l, 0): slopes enclosed everywhere */
} bbc_sqrt_derivative_aware;

/* Fits on [l, r] (l <= r, finite). BBC_ERR_INVALID_ARGUMENT otherwise. */
BBC_API bbc_result bbc_sqrt_primal_fit(double l, double r, bbc_sqrt_primal *out);
/* clamp <= 0 selects the default max(r, 0) * 2^-20. */
BBC_API bbc_result bbc_sqrt_derivative_aware_fit(double l, double r, double clamp,
                                                 bbc_sqrt_derivative_aware *out);

/* out = a beta + b + (1 - xi) delta_lo + xi delta_hi (Eq. 12-13): encloses sqrt(beta) at
 * every point where beta >= 0, with xi a fresh remainder axis (*axis, may be NULL). The
 * range of beta is bbc_poly_bound(beta), intersected with *known when known is not NULL
 * (which must then be a true enclosure). fit may be NULL. */
BBC_API bbc_result bbc_poly_sqrt_primal(bbc_arena *arena, bbc_space *space, bbc_poly *out,
                                        const bbc_poly *beta, const bbc_interval *known,
                                        bbc_sqrt_primal *fit, int *axis);
/* value = derivative-aware surrogate of sqrt(beta) (Supp. Eq. 16) and slope = its derivative
 * with respect to beta, a + (1 - xi) slope_lo + xi slope_hi (Eq. 17), a polynomial of xi only.
 * The chain rule d sqrt(beta)/du = slope * d beta/du then holds with the same xi. Two fresh
 * remainder axes: axes[0] = xi (slope), axes[1] = zeta (value); axes may be NULL. slope may
 * be NULL. See bbc_sqrt_derivative_aware for the clamp. */
BBC_API bbc_result bbc_poly_sqrt_derivative_aware(bbc_arena *arena, bbc_space *space,
                                                  bbc_poly *value, bbc_poly *slope,
                                                  const bbc_poly *beta, const bbc_interval *known,
                                                  double clamp, bbc_sqrt_derivative_aware *fit,
                                                  int axes[2]);
/* The same surrogate with c = sqrt(clamp r) (the geometric mean of beta's range above the
 * clamp, not its left end, Supp. Eq. 22: the value error is then about a quarter as wide)
 * and its value remainder taken at its centre instead of on an axis of its own:
 * value = a beta + b + S(xi) (beta - c) + m with m the middle of
 * [delta_lo, delta_hi] and *radius >= its half-width, so that at every point where
 * beta >= 0 (and beta >= clamp for the slope) some xi gives both
 * sqrt(beta) = value + delta for one constant delta with |delta| <= *radius and the slope as
 * above. The derivatives of value along the other axes are therefore those of
 * sqrt(beta) - delta: a caller carries delta as a constant of its own (at the least as an
 * error radius of *radius on value, which is valid for values but, differentiated, costs
 * 2n *radius where the true derivative of a constant is 0). One fresh remainder axis, xi
 * (*axis, may be NULL); slope and fit may be NULL. */
BBC_API bbc_result bbc_poly_sqrt_derivative_centred(bbc_arena *arena, bbc_space *space,
                                                    bbc_poly *value, bbc_poly *slope,
                                                    double *radius, const bbc_poly *beta,
                                                    const bbc_interval *known, double clamp,
                                                    bbc_sqrt_derivative_aware *fit, int *axis);

/* ---- Interval baseline on polynomials ------------------------------------------------- */

/* The natural interval extension of the Bernstein form sum_i c_i B_i(x) over the box
 * prod_j box[j] (each within [0, 1]), widened by p->err: the interval-arithmetic baseline
 * for a polynomial that is only available in Bernstein form. Axes of degree 0 are ignored. */
BBC_API bbc_interval bbc_interval_eval_poly(const bbc_poly *p,
                                            const bbc_interval box[BBC_POLY_MAX_AXES]);

/* ---- Vectors of polynomials ----------------------------------------------------------- */

BBC_API bbc_result bbc_poly3_constant(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 v);
/* c + sum_j grad[j] x_j per coordinate (x1 = p0 + e1 u + e2 v on a piece, Eq. 6-7). */
BBC_API bbc_result bbc_poly3_affine(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 c,
                                    const bbc_vec3 grad[BBC_POLY_MAX_AXES]);
BBC_API bbc_result bbc_poly3_add(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                                 const bbc_poly3 *b);
BBC_API bbc_result bbc_poly3_sub(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                                 const bbc_poly3 *b);
/* s * v for a polynomial factor s, e.g. (n.n) d in Eq. 10. */
BBC_API bbc_result bbc_poly3_scale(bbc_arena *arena, bbc_poly3 *out, const bbc_poly *s,
                                   const bbc_poly3 *v);
/* s * v for a constant factor. */
BBC_API bbc_result bbc_poly3_scale_const(bbc_arena *arena, bbc_poly3 *out, double s,
                                         const bbc_poly3 *v);
BBC_API bbc_result bbc_poly3_dot(bbc_arena *arena, bbc_poly *out, const bbc_poly3 *a,
                                 const bbc_poly3 *b);
/* a . v with a constant vector (no degree increase), e.g. kappa = (d x e2) . e1 (Eq. 9). */
BBC_API bbc_result bbc_poly3_dot_vec(bbc_arena *arena, bbc_poly *out, const bbc_poly3 *a,
                                     bbc_vec3 v);
BBC_API bbc_result bbc_poly3_cross(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                                   const bbc_poly3 *b);
/* a x v with a constant vector. */
BBC_API bbc_result bbc_poly3_cross_vec(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                                       bbc_vec3 v);

#ifdef __cplusplus
}
#endif

#endif
