/* Remainder variables (paper Sec. 4.3, Eq. 12-13; Supp. Sec. 1), degree reduction
 * (Sec. 6.1, DESIGN 3.4) and the square-root linearisations (Supp. Eq. 6-12 and 15-25).
 *
 * All three rest on Supp. Theorem 1.1: if a quantity theta equals a computable surrogate plus
 * an error known to lie in [lo, hi], replacing it by surrogate + (1 - xi) lo + xi hi with xi
 * a NEW variable of its own keeps every range bound valid, because for each point some xi
 * reproduces theta exactly. The constants a, b, c of a surrogate can therefore be any
 * doubles; what must be rigorous is [lo, hi] for those very doubles, which is why every error
 * interval here is evaluated with outward-rounded interval arithmetic from the stored
 * coefficients rather than taken from the closed forms of the supplement. */
#include "bbc/bernstein.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "bernstein_internal.h"
#include "rounding_internal.h"

#define NAX BBC_POLY_MAX_AXES
#define MAXD BBC_POLY_MAX_DEGREE

/* ---- Variable space ----------------------------------------------------------------- */

bbc_result bbc_space_add_axis(bbc_space *space, bbc_axis_kind kind, int *axis) {
  if (!space || !axis) return BBC_ERR_INVALID_ARGUMENT;
  if (kind == BBC_AXIS_GEOMETRIC) {
    for (int j = NAX - 1; j >= 0; j--) {
      if (space->kind[j] == BBC_AXIS_FREE) {
        space->kind[j] = BBC_AXIS_GEOMETRIC;
        *axis = j;
        return BBC_OK;
      }
    }
  } else if (kind == BBC_AXIS_REMAINDER) {
    for (int j = 0; j < NAX; j++) {
      if (space->kind[j] == BBC_AXIS_FREE) {
        space->kind[j] = BBC_AXIS_REMAINDER;
        *axis = j;
        return BBC_OK;
      }
    }
  } else {
    return BBC_ERR_INVALID_ARGUMENT;
  }
  return BBC_ERR_UNSUPPORTED;
}

void bbc_space_release_axis(bbc_space *space, int axis) {
  if (space && axis >= 0 && axis < NAX) space->kind[axis] = BBC_AXIS_FREE;
}

/* ---- Remainder variables ------------------------------------------------------------ */

/* dst = a f + b + (1 - xi) lo + xi hi, with xi on `axis` (where f has degree 0). Each output
 * coefficient is ((a f_i + b) + lo) or ((a f_i + b) + hi): three roundings on terms whose
 * magnitudes sum to at most |a| max|f| + |b| + max(|lo|, |hi|). f's own radius scales by |a|. */
static double fill_affine_remainder(const double *f, const unsigned char fdeg[NAX], double ferr,
                                    int axis, double a, double b, double lo, double hi,
                                    double *dst) {
  size_t pre = 1, post = 1;
  for (int j = 0; j < axis; j++) pre *= (size_t)fdeg[j] + 1;
  for (int j = axis + 1; j < NAX; j++) post *= (size_t)fdeg[j] + 1;
  for (size_t p = 0; p < pre; p++) {
    const double *src = f + p * post;
    double *d0 = dst + p * 2 * post, *d1 = d0 + post;
    for (size_t t = 0; t < post; t++) {
      double v = a * src[t] + b;
      d0[t] = v + lo;
      d1[t] = v + hi;
    }
  }
  double m = bbc__maxabs(f, pre * post);
  double mag = bbc__add_up(bbc__mul_up(fabs(a), m), fabs(b));
  mag = bbc__add_up(mag, fabs(lo) > fabs(hi) ? fabs(lo) : fabs(hi));
  double e = bbc__mul_up(fabs(a), bbc__radius(ferr));
  e = bbc__add_up(e, bbc__mul_up(bbc__gamma(3), mag));
  return bbc__radius(e);
}

/* Claims a remainder axis, allocates `out` with f's degrees plus 1 on that axis and fills it
 * with a f + b + (1 - xi) lo + xi hi. On failure releases the axis and restores the arena. */
static bbc_result affine_remainder(bbc_arena *arena, bbc_space *space, bbc_poly *out,
                                   const bbc_poly *f, double a, double b, double lo, double hi,
                                   int *axis_out) {
  int axis;
  BBC__TRY(bbc_space_add_axis(space, BBC_AXIS_REMAINDER, &axis));
  if (f->deg[axis] != 0) {
    /* f depends on an axis the space calls free: the caller's bookkeeping is broken. */
    bbc_space_release_axis(space, axis);
    return BBC_ERR_INVALID_ARGUMENT;
  }
  bbc_poly r;
  memset(&r, 0, sizeof r);
  memcpy(r.deg, f->deg, NAX);
  r.deg[axis] = 1;
  bbc_result res = bbc__alloc_coef(arena, r.deg, &r.coef);
  if (res != BBC_OK) {
    bbc_space_release_axis(space, axis);
    return res;
  }
  r.err = fill_affine_remainder(f->coef, f->deg, f->err, axis, a, b, lo, hi, r.coef);
  *out = r;
  if (axis_out) *axis_out = axis;
  return BBC_OK;
}

static int poly_ok(const bbc_poly *p) {
  return bbc__poly_ok(p);
}

bbc_result bbc_poly_remainder(bbc_arena *arena, bbc_space *space, bbc_poly *out, const bbc_poly *f,
                              double lo, double hi, int *axis) {
  if (!space || !out || !(lo <= hi)) return BBC_ERR_INVALID_ARGUMENT;
  if (f && !poly_ok(f)) return BBC_ERR_INVALID_ARGUMENT;
  double zero = 0.0;
  bbc_poly z;
  if (!f) {
    memset(&z, 0, sizeof z);
    z.coef = &zero; /* read only, during this call */
    f = &z;
  }
  return affine_remainder(arena, space, out, f, 1.0, 0.0, lo, hi, axis);
}

/* ---- Degree reduction --------------------------------------------------------------- */

/* x^e by binary exponentiation (powl is two orders of magnitude slower and this is only
 * an approximation used to build the fit). */
static long double ipowl(long double x, int e) {
  long double r = 1.0L;
  while (e > 0) {
    if (e & 1) r *= x;
    x *= x;
    e >>= 1;
  }
  return r;
}

/* B_{i,n}(x) in long double. */
static long double bernstein_basis(int n, int i, long double x) {
  const double *row = bbc__binomial_row(n);
  return (long double)row[i] * ipowl(x, i) * ipowl(1.0L - x, n - i);
}

/* The (d+1) x (n+1) matrix that maps the Bernstein coefficients of a degree-n polynomial
 * along one axis to those of its least-squares fit of degree d at the n+1 Chebyshev nodes
 * of [0,1]. Gauss-Chebyshev quadrature with n+1 nodes is exact up to degree 2n+1 >= n+d, so
 * this is the continuous least-squares fit for the Chebyshev weight, which is within a small
 * factor of the best max-norm fit: the error interval of the reduction is what matters.
 * Householder QR in long double on the collocation matrix, deterministic. */
static bbc_result fit_matrix(bbc_arena *arena, int n, int d, double *out) {
  int N = n + 1, C = d + 1;
  size_t mark = bbc_arena_mark(arena);
  long double *V = (long double *)bbc_arena_alloc(arena, sizeof(long double) * (size_t)N * C);
  long double *w = (long double *)bbc_arena_alloc(arena, sizeof(long double) * (size_t)N);
  long double *x = (long double *)bbc_arena_alloc(arena, sizeof(long double) * (size_t)N);
  long double *beta = (long double *)bbc_arena_alloc(arena, sizeof(long double) * (size_t)C);
  if (!V || !w || !x || !beta) {
    bbc_arena_reset(arena, mark);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  const long double pi = 3.141592653589793238462643383279502884L;
  for (int k = 0; k < N; k++) x[k] = 0.5L * (1.0L - cosl((2.0L * k + 1.0L) * pi / (2.0L * N)));
  for (int k = 0; k < N; k++)
    for (int i = 0; i < C; i++) V[(size_t)k * C + i] = bernstein_basis(d, i, x[k]);
  /* Householder: column c's reflector v is stored below the diagonal of V (v_c in V[c][c]
   * replaced at the end by the diagonal of R, kept in the loop as rdiag). */
  long double rdiag[MAXD + 1];
  for (int c = 0; c < C; c++) {
    long double norm = 0.0L;
    for (int k = c; k < N; k++) norm += V[(size_t)k * C + c] * V[(size_t)k * C + c];
    norm = sqrtl(norm);
    long double x0 = V[(size_t)c * C + c];
    long double alpha = x0 > 0 ? -norm : norm;
    V[(size_t)c * C + c] = x0 - alpha; /* v = x - alpha e1 */
    long double vv = 0.0L;
    for (int k = c; k < N; k++) vv += V[(size_t)k * C + c] * V[(size_t)k * C + c];
    beta[c] = vv > 0 ? 2.0L / vv : 0.0L;
    for (int j = c + 1; j < C; j++) {
      long double s = 0.0L;
      for (int k = c; k < N; k++) s += V[(size_t)k * C + c] * V[(size_t)k * C + j];
      s *= beta[c];
      for (int k = c; k < N; k++) V[(size_t)k * C + j] -= s * V[(size_t)k * C + c];
    }
    rdiag[c] = alpha;
  }
  /* Column j of the operator: the fit of the samples of B_{j,n}. */
  for (int j = 0; j <= n; j++) {
    for (int k = 0; k < N; k++) w[k] = bernstein_basis(n, j, x[k]);
    for (int c = 0; c < C; c++) {
      long double s = 0.0L;
      for (int k = c; k < N; k++) s += V[(size_t)k * C + c] * w[k];
      s *= beta[c];
      for (int k = c; k < N; k++) w[k] -= s * V[(size_t)k * C + c];
    }
    for (int i = C - 1; i >= 0; i--) {
      long double s = w[i];
      for (int k = i + 1; k < C; k++) s -= V[(size_t)i * C + k] * w[k];
      w[i] = rdiag[i] != 0 ? s / rdiag[i] : 0.0L;
    }
    for (int i = 0; i < C; i++) out[(size_t)i * (n + 1) + j] = (double)w[i];
  }
  bbc_arena_reset(arena, mark);
  return BBC_OK;
}

/* The fit matrices depend only on (n, d): computed once per process and shared. A slot
 * is published with a compare-and-swap; a thread that loses the race frees its copy. The
 * matrices are deterministic, so which copy wins does not matter. */
static _Atomic(double *) fit_cache[MAXD + 1][MAXD + 1];

static bbc_result cached_fit_matrix(bbc_arena *arena, int n, int d, const double **out) {
  double *m = atomic_load_explicit(&fit_cache[n][d], memory_order_acquire);
  if (!m) {
    double *fresh = malloc(sizeof(double) * (size_t)(d + 1) * (n + 1));
    if (!fresh) return BBC_ERR_OUT_OF_MEMORY;
    bbc_result r = fit_matrix(arena, n, d, fresh);
    if (r != BBC_OK) {
      free(fresh);
      return r;
    }
    double *expected = NULL;
    if (atomic_compare_exchange_strong_explicit(&fit_cache[n][d], &expected, fresh,
                                                memory_order_acq_rel, memory_order_acquire)) {
      m = fresh;
    } else {
      free(fresh);
      m = expected;
    }
  }
  *out = m;
  return BBC_OK;
}

bbc_result bbc_poly_reduce_split(bbc_arena *arena, const bbc_space *space, bbc_poly *fit_out,
                                 bbc_interval *error, const bbc_poly *p, int max_degree) {
  if (max_degree < 0) return BBC_ERR_INVALID_ARGUMENT;
  unsigned char cap[NAX];
  for (int j = 0; j < NAX; j++) cap[j] = (unsigned char)(max_degree < MAXD ? max_degree : MAXD);
  return bbc__poly_reduce_split_to(arena, space, fit_out, error, p, cap);
}

bbc_result bbc__poly_reduce_split_to(bbc_arena *arena, const bbc_space *space, bbc_poly *fit_out,
                                     bbc_interval *error, const bbc_poly *p,
                                     const unsigned char max_degree[BBC_POLY_MAX_AXES]) {
  if (!space || !fit_out || !error || !poly_ok(p) || !max_degree) return BBC_ERR_INVALID_ARGUMENT;
  unsigned char target[NAX];
  for (int j = 0; j < NAX; j++) {
    int n = p->deg[j];
    if (n == 0) {
      target[j] = 0;
    } else if (space->kind[j] == BBC_AXIS_GEOMETRIC) {
      target[j] = (unsigned char)(n < max_degree[j] ? n : max_degree[j]);
    } else if (space->kind[j] == BBC_AXIS_REMAINDER) {
      target[j] = 0; /* old remainders are averaged out of the fit and end in the new one */
    } else {
      return BBC_ERR_INVALID_ARGUMENT;
    }
  }
  size_t outer = bbc_arena_mark(arena);
  bbc_result res = BBC_OK;

  /* The fit F, axis by axis (the tensor least-squares problem on a tensor grid separates). */
  bbc_poly fit;
  memset(&fit, 0, sizeof fit);
  memcpy(fit.deg, p->deg, NAX);
  fit.coef = p->coef;
  for (int j = 0; j < NAX && res == BBC_OK; j++) {
    int n = p->deg[j], d = target[j];
    if (d == n) continue;
    unsigned char next[NAX];
    memcpy(next, fit.deg, NAX);
    next[j] = (unsigned char)d;
    double *dst = (double *)bbc_arena_alloc(arena, sizeof(double) * bbc__size(next));
    if (!dst) {
      res = BBC_ERR_OUT_OF_MEMORY;
      break;
    }
    const double *m;
    if (d == 0) {
      /* Projection onto constants: the mean, since each B_{i,n} integrates to 1/(n+1). */
      double *mean = (double *)bbc_arena_alloc(arena, sizeof(double) * (size_t)(n + 1));
      if (!mean) {
        res = BBC_ERR_OUT_OF_MEMORY;
        break;
      }
      for (int i = 0; i <= n; i++) mean[i] = 1.0 / (n + 1);
      m = mean;
    } else {
      res = cached_fit_matrix(arena, n, d, &m);
      if (res != BBC_OK) break;
    }
    bbc__axis_apply(fit.coef, fit.deg, j, m, d + 1, dst);
    fit.coef = dst;
    memcpy(fit.deg, next, NAX);
  }
  /* F is defined by its stored coefficients: it is exact by definition. */
  fit.err = 0.0;

  /* Bound p - F over every axis, old remainders included (Sec. 6.1). */
  bbc_poly diff;
  if (res == BBC_OK) res = bbc_poly_sub(arena, &diff, p, &fit);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, outer);
    return res;
  }
  bbc_interval e = bbc_poly_bound(&diff);

  /* F is moved down to where this call's allocations began, so that the temporaries
   * can be dropped. */
  size_t bytes = bbc__size(fit.deg) * sizeof(double);
  bbc_arena_reset(arena, outer);
  double *c = (double *)bbc_arena_alloc(arena, bytes);
  /* The new block starts at or below fit.coef, so memmove handles the overlap. */
  memmove(c, fit.coef, bytes);
  fit.coef = c;
  *fit_out = fit;
  *error = e;
  return BBC_OK;
}

bbc_result bbc_poly_reduce(bbc_arena *arena, bbc_space *space, bbc_poly *out, const bbc_poly *p,
                           int max_degree, int *axis) {
  if (!space || !out || !poly_ok(p) || max_degree < 0) return BBC_ERR_INVALID_ARGUMENT;
  size_t outer = bbc_arena_mark(arena);
  bbc_poly fit;
  bbc_interval e;
  bbc_result res = bbc_poly_reduce_split(arena, space, &fit, &e, p, max_degree);
  if (res != BBC_OK) return res;
  /* The result is built above F (it needs it), then moved down over it. */
  bbc_poly r;
  int z;
  res = affine_remainder(arena, space, &r, &fit, 1.0, 0.0, e.lo, e.hi, &z);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, outer);
    return res;
  }
  size_t bytes = bbc__size(r.deg) * sizeof(double);
  bbc_arena_reset(arena, outer);
  double *c = (double *)bbc_arena_alloc(arena, bytes);
  memmove(c, r.coef, bytes);
  r.coef = c;
  *out = r;
  if (axis) *axis = z;
  return BBC_OK;
}

/* ---- Square roots ------------------------------------------------------------------- */

static bbc_interval ipt(double v) {
  return bbc_interval_point(v);
}

bbc_result bbc_sqrt_primal_fit(double l, double r, bbc_sqrt_primal *out) {
  if (!out || !isfinite(l) || !isfinite(r) || !(l <= r)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_sqrt_primal f;
  memset(&f, 0, sizeof f);
  double l0 = l > 0.0 ? l : 0.0, r0 = r > 0.0 ? r : 0.0;
  if (r0 == 0.0) {
    *out = f; /* sqrt(0) = 0 = 0 x + 0 exactly */
    return BBC_OK;
  }
  double sl = sqrt(l0), sr = sqrt(r0);
  f.a = 1.0 / (sr + sl); /* Supp. Eq. 8, (sqrt r - sqrt l)/(r - l) without the cancellation */
  f.b = sl - f.a * l0;   /* Supp. Eq. 9 */
  /* Supp. Eq. 10-12 for the stored a, b: Delta(x) = sqrt x - a x - b is concave, so over
   * [l0, r0] its minimum is at an end and its maximum at most the global maximum
   * 1/(4a) - b, reached at x = 1/(4a^2) (Eq. 11). */
  bbc_interval A = ipt(f.a), B = ipt(f.b);
  bbc_interval dl = bbc_interval_sub(
      bbc_interval_sub(bbc_interval_sqrt(ipt(l0)), bbc_interval_mul(A, ipt(l0))), B);
  bbc_interval dr = bbc_interval_sub(
      bbc_interval_sub(bbc_interval_sqrt(ipt(r0)), bbc_interval_mul(A, ipt(r0))), B);
  bbc_interval top = bbc_interval_sub(bbc_interval_div(ipt(1.0), bbc_interval_scale(A, 4.0)), B);
  f.delta_lo = dl.lo < dr.lo ? dl.lo : dr.lo;
  f.delta_hi = top.hi;
  if (dl.hi > f.delta_hi) f.delta_hi = dl.hi;
  if (dr.hi > f.delta_hi) f.delta_hi = dr.hi;
  *out = f;
  return BBC_OK;
}

/* geometric: c = sqrt(lc r0) instead of the left end (see bbc_poly_sqrt_derivative_centred). */
static bbc_result derivative_aware_fit(double l, double r, double clamp, int geometric,
                                       bbc_sqrt_derivative_aware *out) {
  if (!out || !isfinite(l) || !isfinite(r) || !(l <= r) || isnan(clamp))
    return BBC_ERR_INVALID_ARGUMENT;
  bbc_sqrt_derivative_aware f;
  memset(&f, 0, sizeof f);
  double l0 = l > 0.0 ? l : 0.0, r0 = r > 0.0 ? r : 0.0;
  if (r0 == 0.0) {
    /* beta = 0 everywhere: the value 0 is exact, the slope 1/(2 sqrt 0) has no bound. */
    *out = f;
    return BBC_OK;
  }
  double eps = clamp > 0.0 ? clamp : r0 * 0x1p-20;
  if (!(eps > 0.0) || eps > r0) eps = r0;
  double lc = l0 > eps ? l0 : eps;
  f.clamp = lc;
  f.slope_enclosed = (lc == l0);
  double sl = sqrt(lc), sr = sqrt(r0);
  f.a = 0.5 * (0.5 / sl + 0.5 / sr); /* Supp. Eq. 18 */
  f.b = sl - f.a * lc;               /* Supp. Eq. 21 */
  f.c = lc;                          /* Supp. Eq. 22 */
  if (geometric) {
    /* The value error below is g(x) - K with g(x) = (x + c) / (2 sqrt x), whose ends on
     * [lc, r0] are equal for c = sqrt(lc r0): the error interval is then
     * (r0^(1/4) - lc^(1/4))^2 / 2 wide, a quarter of the width for c = lc,
     * (sqrt r0 - sqrt lc)^2 / (2 sqrt r0), when lc is near r0. Any double c is valid: the
     * bounds below hold for the stored constants. b makes K = b + a c about sqrt(c). */
    const double c = sl * sr;
    f.c = c;
    f.b = sqrt(c) - f.a * c;
  }
  bbc_interval A = ipt(f.a), B = ipt(f.b), C = ipt(f.c);
  bbc_interval half = ipt(0.5);

  /* Supp. Eq. 19-20 for the stored a: the true slope 1/(2 sqrt x) decreases from the left
   * end to the right end of [lc, r0]. */
  bbc_interval gl = bbc_interval_div(half, bbc_interval_sqrt(ipt(lc)));
  bbc_interval gr = bbc_interval_div(half, bbc_interval_sqrt(ipt(r0)));
  f.slope_lo = bbc_interval_sub(gr, A).lo;
  f.slope_hi = bbc_interval_sub(gl, A).hi;

  /* Supp. Eq. 23-25, redone for the stored a, b, c. With xi chosen so that the slope is the
   * true 1/(2 sqrt x), the surrogate is K + (x - c)/(2 sqrt x) with K = b + a c, and the
   * value error is g(x) - K with g(x) = (x + c)/(2 sqrt x) = sqrt(x)/2 + c/(2 sqrt x). g is
   * convex in sqrt x with minimum sqrt(c) (AM-GM), so over [lc, r0] it lies in
   * [sqrt c, max(g(lc), g(r0))]. (The supplement's closed form drops a factor sqrt x.) */
  bbc_interval K = bbc_interval_add(B, bbc_interval_mul(A, C));
  bbc_interval g_lc = bbc_interval_div(bbc_interval_add(ipt(lc), C),
                                       bbc_interval_scale(bbc_interval_sqrt(ipt(lc)), 2.0));
  bbc_interval g_r0 = bbc_interval_div(bbc_interval_add(ipt(r0), C),
                                       bbc_interval_scale(bbc_interval_sqrt(ipt(r0)), 2.0));
  double gmax = g_lc.hi > g_r0.hi ? g_lc.hi : g_r0.hi;
  f.delta_lo = bbc_interval_sub(bbc_interval_sqrt(C), K).lo;
  f.delta_hi = bbc_interval_sub(ipt(gmax), K).hi;

  if (lc > l0) {
    /* Below the clamp the slope cannot be matched; take the steepest available one,
     * s1 = a + slope_hi (xi = 1). The error sqrt x - K - s1 (x - c) is concave in x: its
     * minimum over [l0, lc] is at an end and its maximum at most 1/(4 s1) + s1 c - K. */
    bbc_interval S1 = bbc_interval_add(A, ipt(f.slope_hi));
    bbc_interval e0 = bbc_interval_sub(bbc_interval_sub(bbc_interval_sqrt(ipt(l0)), K),
                                       bbc_interval_mul(S1, bbc_interval_sub(ipt(l0), C)));
    bbc_interval e1 = bbc_interval_sub(bbc_interval_sub(bbc_interval_sqrt(ipt(lc)), K),
                                       bbc_interval_mul(S1, bbc_interval_sub(ipt(lc), C)));
    bbc_interval top =
        bbc_interval_sub(bbc_interval_add(bbc_interval_div(ipt(1.0), bbc_interval_scale(S1, 4.0)),
                                          bbc_interval_mul(S1, C)),
                         K);
    if (e0.lo < f.delta_lo) f.delta_lo = e0.lo;
    if (e1.lo < f.delta_lo) f.delta_lo = e1.lo;
    if (top.hi > f.delta_hi) f.delta_hi = top.hi;
    if (e0.hi > f.delta_hi) f.delta_hi = e0.hi;
    if (e1.hi > f.delta_hi) f.delta_hi = e1.hi;
  }
  *out = f;
  return BBC_OK;
}

bbc_result bbc_sqrt_derivative_aware_fit(double l, double r, double clamp,
                                         bbc_sqrt_derivative_aware *out) {
  return derivative_aware_fit(l, r, clamp, 0, out);
}

/* The range of beta, intersected with the caller's enclosure when given. */
static bbc_result beta_range(const bbc_poly *beta, const bbc_interval *known, double *l,
                             double *r) {
  bbc_interval b = bbc_poly_bound(beta);
  if (known) {
    if (known->lo > b.lo) b.lo = known->lo;
    if (known->hi < b.hi) b.hi = known->hi;
    if (!(b.lo <= b.hi)) return BBC_ERR_INVALID_ARGUMENT; /* known is not an enclosure */
  }
  /* sqrt is needed only where beta >= 0, so an unbounded lower end is as good as 0. */
  if (!(b.hi < INFINITY)) return BBC_ERR_UNSUPPORTED;
  if (!(b.lo > -INFINITY)) b.lo = b.hi < 0.0 ? b.hi : 0.0;
  *l = b.lo;
  *r = b.hi;
  return BBC_OK;
}

bbc_result bbc_poly_sqrt_primal(bbc_arena *arena, bbc_space *space, bbc_poly *out,
                                const bbc_poly *beta, const bbc_interval *known,
                                bbc_sqrt_primal *fit, int *axis) {
  if (!space || !out || !poly_ok(beta)) return BBC_ERR_INVALID_ARGUMENT;
  double l, r;
  BBC__TRY(beta_range(beta, known, &l, &r));
  bbc_sqrt_primal f;
  BBC__TRY(bbc_sqrt_primal_fit(l, r, &f));
  /* Eq. 12-13: a beta + b + (1 - xi) delta_lo + xi delta_hi. */
  BBC__TRY(affine_remainder(arena, space, out, beta, f.a, f.b, f.delta_lo, f.delta_hi, axis));
  if (fit) *fit = f;
  return BBC_OK;
}

/* value (and slope) of the derivative-aware surrogate with nz value corrections D[0..nz-1]
 * on the axis zeta (nz = 2) or a single constant D[0] and no zeta axis (nz = 1, zeta = -1). */
static bbc_result sqrt_derivative_surrogate(bbc_arena *arena, bbc_space *space, bbc_poly *value,
                                            bbc_poly *slope, const bbc_poly *beta,
                                            const bbc_sqrt_derivative_aware *fit, const double *D,
                                            int nz, int axes[2]) {
  const bbc_sqrt_derivative_aware f = *fit;
  int xi, zeta = -1;
  BBC__TRY(bbc_space_add_axis(space, BBC_AXIS_REMAINDER, &xi));
  bbc_result res = BBC_OK;
  if (nz == 2) res = bbc_space_add_axis(space, BBC_AXIS_REMAINDER, &zeta);
  if (res != BBC_OK) {
    bbc_space_release_axis(space, xi);
    return res;
  }
  if (beta->deg[xi] != 0 || (zeta >= 0 && beta->deg[zeta] != 0)) {
    bbc_space_release_axis(space, xi);
    if (zeta >= 0) bbc_space_release_axis(space, zeta);
    return BBC_ERR_INVALID_ARGUMENT;
  }
  size_t mark = bbc_arena_mark(arena);
  bbc_poly v, s;
  memset(&v, 0, sizeof v);
  memset(&s, 0, sizeof s);
  memcpy(v.deg, beta->deg, NAX);
  v.deg[xi] = 1;
  if (zeta >= 0) v.deg[zeta] = 1;
  s.deg[xi] = 1;
  res = bbc__alloc_coef(arena, v.deg, &v.coef);
  if (res == BBC_OK && slope) res = bbc__alloc_coef(arena, s.deg, &s.coef);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    bbc_space_release_axis(space, xi);
    if (zeta >= 0) bbc_space_release_axis(space, zeta);
    return res;
  }

  /* Supp. Eq. 15-16: value = a beta + b + S(xi) (beta - c) + D(zeta) with S the slope
   * correction and D the value correction, both degree 1 on their own axes (D a constant
   * when nz = 1). beta does not depend on xi or zeta, so the tensor coefficients are the
   * plain products a beta_i + b + S_k (beta_i - c) + D_m. */
  const double S[2] = {f.slope_lo, f.slope_hi};
  size_t stride[NAX];
  bbc__strides(v.deg, stride);
  const size_t zstride = zeta >= 0 ? stride[zeta] : 0;
  size_t bstride[NAX];
  size_t nb = bbc__strides(beta->deg, bstride);
  int idx[NAX] = {0};
  for (size_t i = 0; i < nb; i++) {
    size_t off = 0;
    for (int j = 0; j < NAX; j++) off += (size_t)idx[j] * stride[j];
    double bi = beta->coef[i];
    double base = f.a * bi + f.b, centred = bi - f.c;
    for (int k = 0; k < 2; k++)
      for (int m = 0; m < nz; m++)
        v.coef[off + (size_t)k * stride[xi] + (size_t)m * zstride] = (base + S[k] * centred) + D[m];
    for (int j = NAX - 1; j >= 0; j--) {
      if (beta->deg[j] == 0) continue;
      if (idx[j] < beta->deg[j]) {
        idx[j]++;
        break;
      }
      idx[j] = 0;
    }
  }
  /* Every path has at most 4 roundings (a beta_i: product and three sums; S (beta_i - c):
   * difference, product, two sums); beta's radius is multiplied by |a| + max|S|. */
  double mb = bbc__maxabs(beta->coef, nb);
  double smax = fabs(S[0]) > fabs(S[1]) ? fabs(S[0]) : fabs(S[1]);
  double dmax = 0.0;
  for (int m = 0; m < nz; m++)
    if (fabs(D[m]) > dmax) dmax = fabs(D[m]);
  double mag = bbc__add_up(bbc__mul_up(fabs(f.a), mb), fabs(f.b));
  mag = bbc__add_up(mag, bbc__mul_up(smax, bbc__add_up(mb, fabs(f.c))));
  mag = bbc__add_up(mag, dmax);
  double e = bbc__mul_up(bbc__add_up(fabs(f.a), smax), bbc__radius(beta->err));
  v.err = bbc__radius(bbc__add_up(e, bbc__mul_up(bbc__gamma(4), mag)));

  if (slope) {
    /* Supp. Eq. 17: a + S(xi). */
    s.coef[0] = f.a + S[0];
    s.coef[1] = f.a + S[1];
    s.err = bbc__radius(bbc__mul_up(bbc__gamma(1), bbc__add_up(fabs(f.a), smax)));
    *slope = s;
  }
  *value = v;
  if (axes) {
    axes[0] = xi;
    axes[1] = zeta;
  }
  return BBC_OK;
}

bbc_result bbc_poly_sqrt_derivative_aware(bbc_arena *arena, bbc_space *space, bbc_poly *value,
                                          bbc_poly *slope, const bbc_poly *beta,
                                          const bbc_interval *known, double clamp,
                                          bbc_sqrt_derivative_aware *fit, int axes[2]) {
  if (!space || !value || !poly_ok(beta)) return BBC_ERR_INVALID_ARGUMENT;
  double l, r;
  BBC__TRY(beta_range(beta, known, &l, &r));
  bbc_sqrt_derivative_aware f;
  BBC__TRY(bbc_sqrt_derivative_aware_fit(l, r, clamp, &f));
  const double D[2] = {f.delta_lo, f.delta_hi};
  BBC__TRY(sqrt_derivative_surrogate(arena, space, value, slope, beta, &f, D, 2, axes));
  if (fit) *fit = f;
  return BBC_OK;
}

bbc_result bbc_poly_sqrt_derivative_centred(bbc_arena *arena, bbc_space *space, bbc_poly *value,
                                            bbc_poly *slope, double *radius, const bbc_poly *beta,
                                            const bbc_interval *known, double clamp,
                                            bbc_sqrt_derivative_aware *fit, int *axis) {
  if (!space || !value || !radius || !poly_ok(beta)) return BBC_ERR_INVALID_ARGUMENT;
  double l, r;
  BBC__TRY(beta_range(beta, known, &l, &r));
  bbc_sqrt_derivative_aware f;
  BBC__TRY(derivative_aware_fit(l, r, clamp, 1, &f));
  /* The centre m of [delta_lo, delta_hi] is any double (the surrogate's constants are
   * exact by definition); what must hold is delta_lo >= m - radius and delta_hi <= m +
   * radius for the stored m, hence the upward-rounded differences. Halving is exact but
   * for subnormals, whose rounding the differences then absorb. */
  const double m = 0.5 * f.delta_lo + 0.5 * f.delta_hi;
  double rad = bbc__sub_up(f.delta_hi, m), rad_lo = bbc__sub_up(m, f.delta_lo);
  if (rad_lo > rad) rad = rad_lo;
  if (!(rad >= 0.0)) rad = INFINITY;
  int axes[2];
  BBC__TRY(sqrt_derivative_surrogate(arena, space, value, slope, beta, &f, &m, 1, axes));
  *radius = rad;
  if (fit) *fit = f;
  if (axis) *axis = axes[0];
  return BBC_OK;
}
