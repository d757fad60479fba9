/* The single-scattering solver: specular polynomials (Fan et al. 2024; paper Sec. 6.1;
 * DESIGN 3.10). See bbc/solver.h.
 *
 * The constraint. With x1(u, v) on T1 (Eq. 6), the unnormalised interpolated normal
 * n(u, v) (Eq. 7), d0 = x1 - x0, d1 = x_k - x1 and w = x_k - x0 (constant), a path
 * x0 -> x1 -> x_k is specular when
 *   C = (d0 x w) . n = 0                               (coplanarity, "endpoint
 *        difference form" of the slides: d0 x d1 = d0 x w, so C has degree 2) and
 *   reflection:  A = (r x d1) . t = 0, r = (n.n) d0 - 2 (d0.n) n   (Eq. 10's reflected
 *        direction must be parallel to d1; with d0 x d1 = d0 x w this has degree 4), or
 *   refraction:  A = eta_i^2 |d1|^2 |d0 x n|^2 - eta_o^2 |d0|^2 |d1 x n|^2 = 0
 *        (the slides' "square form" of Snell's law eta_i sin(theta_i) = eta_o sin(theta_o),
 *        without the projection on a basis vector b: with C = 0 both cross products are
 *        parallel to the plane of incidence's normal, and leaving b out removes the
 *        spurious zeros where that normal is orthogonal to b; degree 6).
 * The reflection form needs a vector t with a component along the plane of incidence's
 * normal; t = w x n_avg is that normal for the average normal n_avg. Where w is nearly
 * parallel to n_avg (light and shading point on one normal line) t is unreliable and the
 * square form with eta_i = eta_o = 1 (degree 6) is used instead.
 *
 * The squared and product forms admit wrong branches: the reflected ray running
 * backwards, refraction into the wrong side or with the tangential direction reversed,
 * the straight line x0 -> x_k itself. Every candidate is therefore polished by Newton's
 * method on the exact constraint with normalised vectors and no squaring (the
 * generalised half-vector must be parallel to the shading normal; bbc_solver_newton) and
 * then checked by bbc_solver_verify, which traces the exact path: the wrong branches fail
 * there.
 *
 * Elimination. Both polynomials are written in u with coefficients that are polynomials
 * in v. Their resultant with respect to u (v hidden) vanishes at the v of every common
 * root and has degree at most deg C * deg A <= 12 in v (Bezout). Rather than expanding a
 * determinant of polynomials, it is sampled at deg + 1 Chebyshev nodes of the v range and
 * interpolated in the Bernstein basis, where Descartes' rule of signs with de Casteljau
 * subdivision isolates its roots. Each sample is the Sylvester determinant when C is
 * linear in u, and a^n A(u+) A(u-) divided by the constant a^n when C is quadratic in u
 * (leading coefficient a, roots u+-): on nearly flat triangles a is tiny, and the
 * Sylvester (or Bezout) determinant's a^n then drowns in its own rounding. Coefficients at
 * rounding level are zeroed first (a sphere's normals are affine in position, which makes
 * C exactly linear; computed, its u^2 term is noise). Which variable is hidden is chosen
 * per tuple: see solve_system.
 *
 * Back-substitution. For each root v*, C(u, v*) is a quadratic in u; its real roots in
 * the u range are the candidates, ranked by |A(u, v*)| (a common root makes A vanish
 * too).
 *
 * Flat mirrors (three equal vertex normals) skip all this: their paths have a closed
 * form (solve_flat_mirror).
 *
 * Degenerate systems (C or A vanishing identically, e.g. light and x_k on one normal
 * line of a flat mirror, or a resultant that vanishes at every node) fall back to Newton
 * from four seeds. Everything here is numerical; the tests measure how often it misses
 * (round trips on scenes and on random triangles, BBC_TEST_FULL=1 for millions). */
#include <assert.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <threads.h>

#include "bbc/solver.h"
#include "solver_internal.h"
#include "vec_internal.h"

/* The highest total degree of the constraint polynomials. */
#define BP_MAXD 6
/* The highest degree of the resultant (Bezout: 2 x 6). */
#define RES_MAXD (2 * BP_MAXD)
/* Margins of the root search beyond the triangle, in barycentric units: candidates there
 * may still polish into a root on the edge. */
#define SEARCH_PAD 1e-6
/* Two solutions closer than this (barycentric units, max norm) are the same. */
#define DUPLICATE_TOLERANCE 1e-9
/* How many times the reflection pre-test splits T1 into four where the whole does not
 * decide (plane1k at 64 spp: 0, 1, 2, 3 splits leave 0.36, 0.43, 0.54, 0.71 solutions
 * per solved tuple, at equal render CPU within the machine's noise up to 2). */
#define REFLECTION_SPLITS 2

/* ------------------------------------------------------------------------------------ */
/* Bivariate polynomials in the power basis: c[i][j] multiplies u^i v^j (i + j <= deg).
 * On the unit triangle |u^i v^j| <= 1, so the power basis is well conditioned for these
 * low degrees. */

typedef struct bpoly {
  int deg;
  double c[BP_MAXD + 1][BP_MAXD + 1];
} bpoly;

typedef struct bvec {
  bpoly x, y, z;
} bvec;

/* Coefficients beyond deg are kept zero, so sums need only raise deg. */
static void bp_zero(bpoly *p) {
  memset(p, 0, sizeof *p);
}

/* a + bu u + bv v */
static void bp_linear(bpoly *p, double a, double bu, double bv) {
  bp_zero(p);
  p->deg = 1;
  p->c[0][0] = a, p->c[1][0] = bu, p->c[0][1] = bv;
}

/* r += s a */
static void bp_axpy(bpoly *r, const bpoly *a, double s) {
  for (int i = 0; i <= a->deg; i++)
    for (int j = 0; i + j <= a->deg; j++) r->c[i][j] += s * a->c[i][j];
  if (a->deg > r->deg) r->deg = a->deg;
}

/* r += s a b for a of degree da and b of degree db; inlined where the degrees are
 * constants, so that the loops unroll. */
static inline __attribute__((always_inline)) void bp_muladd_kernel(bpoly *r, const bpoly *a,
                                                                   const bpoly *b, double s,
                                                                   int da, int db) {
  for (int i = 0; i <= da; i++)
    for (int j = 0; i + j <= da; j++) {
      double ac = s * a->c[i][j];
      if (ac == 0) continue;
      for (int k = 0; k <= db; k++)
        for (int l = 0; k + l <= db; l++) r->c[i + k][j + l] += ac * b->c[k][l];
    }
}

/* r += s a b (r distinct from a and b). Callers never exceed BP_MAXD: the forms have
 * degree at most 6. Products of two affine forms, the most frequent, take the unrolled
 * kernel (the same operations in the same order). */
static void bp_muladd(bpoly *r, const bpoly *a, const bpoly *b, double s) {
  assert(a->deg + b->deg <= BP_MAXD && r != a && r != b);
  if (a->deg == 1 && b->deg == 1)
    bp_muladd_kernel(r, a, b, s, 1, 1);
  else
    bp_muladd_kernel(r, a, b, s, a->deg, b->deg);
  if (a->deg + b->deg > r->deg) r->deg = a->deg + b->deg;
}

static void bp_scale(bpoly *p, double s) {
  for (int i = 0; i <= p->deg; i++)
    for (int j = 0; i + j <= p->deg; j++) p->c[i][j] *= s;
}

static double bp_max_abs(const bpoly *p) {
  double m = 0;
  for (int i = 0; i <= p->deg; i++)
    for (int j = 0; i + j <= p->deg; j++) m = fmax(m, fabs(p->c[i][j]));
  return m;
}

/* Exchanges u and v. */
static void bp_transpose(bpoly *p) {
  for (int i = 0; i <= p->deg; i++)
    for (int j = i + 1; i + j <= p->deg; j++) {
      double t = p->c[i][j];
      p->c[i][j] = p->c[j][i];
      p->c[j][i] = t;
    }
}

/* Lowers deg to the true total degree (exact zeros only: flat triangles give exact zeros
 * in the normal's differences, so their forms drop degree without any threshold). */
static void bp_trim(bpoly *p) {
  while (p->deg > 0) {
    int nonzero = 0;
    for (int i = 0; i <= p->deg; i++) nonzero |= p->c[i][p->deg - i] != 0;
    if (nonzero) break;
    p->deg--;
  }
}

/* The degree in u. */
static int bp_deg_u(const bpoly *p) {
  for (int i = p->deg; i > 0; i--)
    for (int j = 0; i + j <= p->deg; j++)
      if (p->c[i][j] != 0) return i;
  return 0;
}

/* The coefficients of u^0..u^deg_u at v, into out. */
static void bp_at_v(const bpoly *p, double v, int deg_u, double *out) {
  for (int i = 0; i <= deg_u; i++) {
    double s = 0;
    for (int j = p->deg - i; j >= 0; j--) s = s * v + p->c[i][j];
    out[i] = s;
  }
}

static void bv_linear(bvec *r, bbc_vec3 a, bbc_vec3 bu, bbc_vec3 bv) {
  bp_linear(&r->x, a.x, bu.x, bv.x);
  bp_linear(&r->y, a.y, bu.y, bv.y);
  bp_linear(&r->z, a.z, bu.z, bv.z);
}

/* r = a . b */
static void bv_dot(bpoly *r, const bvec *a, const bvec *b) {
  bp_zero(r);
  bp_muladd(r, &a->x, &b->x, 1.0);
  bp_muladd(r, &a->y, &b->y, 1.0);
  bp_muladd(r, &a->z, &b->z, 1.0);
}

/* r = a . b for a constant b */
static void bv_dotc(bpoly *r, const bvec *a, bbc_vec3 b) {
  bp_zero(r);
  bp_axpy(r, &a->x, b.x);
  bp_axpy(r, &a->y, b.y);
  bp_axpy(r, &a->z, b.z);
}

/* r = a x b */
static void bv_cross(bvec *r, const bvec *a, const bvec *b) {
  bp_zero(&r->x), bp_zero(&r->y), bp_zero(&r->z);
  bp_muladd(&r->x, &a->y, &b->z, 1.0), bp_muladd(&r->x, &a->z, &b->y, -1.0);
  bp_muladd(&r->y, &a->z, &b->x, 1.0), bp_muladd(&r->y, &a->x, &b->z, -1.0);
  bp_muladd(&r->z, &a->x, &b->y, 1.0), bp_muladd(&r->z, &a->y, &b->x, -1.0);
}

/* r = a x b for a constant b */
static void bv_crossc(bvec *r, const bvec *a, bbc_vec3 b) {
  bp_zero(&r->x), bp_zero(&r->y), bp_zero(&r->z);
  bp_axpy(&r->x, &a->y, b.z), bp_axpy(&r->x, &a->z, -b.y);
  bp_axpy(&r->y, &a->z, b.x), bp_axpy(&r->y, &a->x, -b.z);
  bp_axpy(&r->z, &a->x, b.y), bp_axpy(&r->z, &a->y, -b.x);
}

/* ------------------------------------------------------------------------------------ */
/* Small dense linear algebra. */

/* The determinant of the n x n matrix a (row-major, destroyed) by Gaussian elimination
 * with partial pivoting. */
static double det_lu(double *a, int n) {
  double det = 1.0;
  for (int k = 0; k < n; k++) {
    int p = k;
    for (int i = k + 1; i < n; i++)
      if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
    if (a[p * n + k] == 0) return 0.0;
    if (p != k) {
      for (int j = 0; j < n; j++) {
        double t = a[k * n + j];
        a[k * n + j] = a[p * n + j];
        a[p * n + j] = t;
      }
      det = -det;
    }
    double piv = a[k * n + k];
    det *= piv;
    for (int i = k + 1; i < n; i++) {
      double f = a[i * n + k] / piv;
      if (f == 0) continue;
      for (int j = k + 1; j < n; j++) a[i * n + j] -= f * a[k * n + j];
    }
  }
  return det;
}

/* Solves a x = b in place (a n x n row-major, destroyed; b becomes x). Returns 0 if a is
 * singular. */
static int solve_lu(double *a, double *b, int n) {
  for (int k = 0; k < n; k++) {
    int p = k;
    for (int i = k + 1; i < n; i++)
      if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
    if (a[p * n + k] == 0) return 0;
    if (p != k) {
      for (int j = 0; j < n; j++) {
        double t = a[k * n + j];
        a[k * n + j] = a[p * n + j];
        a[p * n + j] = t;
      }
      double t = b[k];
      b[k] = b[p];
      b[p] = t;
    }
    for (int i = k + 1; i < n; i++) {
      double f = a[i * n + k] / a[k * n + k];
      for (int j = k; j < n; j++) a[i * n + j] -= f * a[k * n + j];
      b[i] -= f * b[k];
    }
  }
  for (int k = n - 1; k >= 0; k--) {
    double s = b[k];
    for (int j = k + 1; j < n; j++) s -= a[k * n + j] * b[j];
    b[k] = s / a[k * n + k];
  }
  return 1;
}

static double binomial(int n, int k) {
  double r = 1;
  for (int i = 1; i <= k; i++) r = r * (n - k + i) / i;
  return r;
}

/* ------------------------------------------------------------------------------------ */
/* Univariate polynomials in the Bernstein basis of [0, 1]: root isolation by Descartes'
 * rule of signs (the number of sign changes of the coefficients bounds the number of
 * roots in (0, 1) and has its parity) and de Casteljau halving. */

typedef struct root_list {
  int count;
  double t[RES_MAXD + 4];
} root_list;

static void roots_push(root_list *r, double t) {
  if (r->count < (int)(sizeof r->t / sizeof r->t[0])) r->t[r->count++] = t;
}

static int sign_changes(const double *b, int n) {
  int changes = 0, last = 0;
  for (int i = 0; i <= n; i++) {
    int s = b[i] > 0 ? 1 : (b[i] < 0 ? -1 : 0);
    if (s == 0) continue;
    if (last != 0 && s != last) changes++;
    last = s;
  }
  return changes;
}

/* Splits b at t = 1/2 into the coefficients of both halves (each again on [0, 1]). */
static void bernstein_halve(const double *b, int n, double *left, double *right) {
  double w[RES_MAXD + 1];
  memcpy(w, b, sizeof(double) * (size_t)(n + 1));
  left[0] = w[0];
  right[n] = w[n];
  for (int r = 1; r <= n; r++) {
    for (int i = 0; i <= n - r; i++) w[i] = 0.5 * (w[i] + w[i + 1]);
    left[r] = w[0];
    right[n - r] = w[n - r];
  }
}

/* The value at t in O(n) (for the many evaluations of root refinement): with s the
 * smaller of t / (1 - t) and (1 - t) / t, p(t) is (1 - t)^n or t^n times a polynomial in s
 * with |s| <= 1, evaluated by Horner's scheme. binom holds C(n, j). */
static double bernstein_eval_fast(const double *b, const double *binom, int n, double t) {
  double acc = 0, w = t <= 0.5 ? 1 - t : t, wn = 1;
  for (int j = 0; j < n; j++) wn *= w;
  if (t <= 0.5) {
    double s = t / (1 - t);
    for (int j = n; j >= 0; j--) acc = acc * s + binom[j] * b[j];
  } else {
    double s = (1 - t) / t;
    for (int j = 0; j <= n; j++) acc = acc * s + binom[j] * b[j];
  }
  return acc * wn;
}

/* The single root of b in (0, 1) when Descartes counts one sign change, to 1e-10 of the
 * interval (Newton's method on the exact constraint polishes it afterwards), by the
 * Illinois variant of regula falsi (superlinear; bisection-safe). The signs just inside
 * the ends are those of the first and last non-zero coefficients. */
static double refine_single_root(const double *b, int n) {
  int s_lo = 0, s_hi = 0;
  for (int i = 0; i <= n && !s_lo; i++) s_lo = b[i] > 0 ? 1 : (b[i] < 0 ? -1 : 0);
  for (int i = n; i >= 0 && !s_hi; i--) s_hi = b[i] > 0 ? 1 : (b[i] < 0 ? -1 : 0);
  double binom[RES_MAXD + 1];
  binom[0] = 1;
  for (int j = 1; j <= n; j++) binom[j] = binom[j - 1] * (n - j + 1) / j;
  double a = 0, c = 1, fa = b[0], fc = b[n];
  if (fa == 0) fa = s_lo * DBL_MIN;
  if (fc == 0) fc = s_hi * DBL_MIN;
  int side = 0;
  for (int it = 0; it < 100 && c - a > 1e-10; it++) {
    double m = (a * fc - c * fa) / (fc - fa);
    /* Keep the iterate strictly inside and fall back to bisection when regula falsi
     * stalls at an end. */
    if (!(m > a && m < c)) m = 0.5 * (a + c);
    double fm = bernstein_eval_fast(b, binom, n, m);
    if (fm == 0) return m;
    if ((fm > 0) == (fa > 0)) {
      a = m, fa = fm;
      if (side == -1) fc *= 0.5;
      side = -1;
    } else {
      c = m, fc = fm;
      if (side == 1) fa *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (a + c);
}

/* Appends the roots of b in (0, 1), mapped to [t0, t1], to out. Clusters narrower than
 * about 1e-13 (multiple or nearly multiple roots, e.g. near a fold of the caustic) are
 * reported once, at their middle. */
static void isolate_roots(const double *b, int n, double t0, double t1, int depth, root_list *out) {
  int changes = sign_changes(b, n);
  if (changes == 0) return;
  if (changes == 1) {
    roots_push(out, t0 + (t1 - t0) * refine_single_root(b, n));
    return;
  }
  double mid = 0.5 * (t0 + t1);
  if (depth >= 44 || t1 - t0 < 1e-13) {
    roots_push(out, mid);
    return;
  }
  double left[RES_MAXD + 1], right[RES_MAXD + 1];
  bernstein_halve(b, n, left, right);
  /* A root exactly at the split point is invisible to both halves' sign counts. */
  if (left[n] == 0) roots_push(out, mid);
  isolate_roots(left, n, t0, mid, depth + 1, out);
  isolate_roots(right, n, mid, t1, depth + 1, out);
}

/* The roots in [lo, hi] of the power-basis polynomial a[0] + a[1] x + ... + a[n] x^n,
 * through its Bernstein form on [lo, hi]. */
static void power_roots(const double *a, int n, double lo, double hi, root_list *out) {
  while (n > 0 && a[n] == 0) n--;
  if (n == 0) return;
  /* q(t) = p(lo + w t) in the power basis of t, by Horner's scheme on polynomials. */
  double w = hi - lo, q[RES_MAXD + 1] = {0};
  for (int i = n; i >= 0; i--) {
    for (int k = n; k >= 1; k--) q[k] = q[k] * lo + q[k - 1] * w;
    q[0] = q[0] * lo + a[i];
  }
  /* Power to Bernstein: b_k = sum_{i <= k} C(k, i) / C(n, i) q_i. */
  double b[RES_MAXD + 1];
  for (int k = 0; k <= n; k++) {
    double s = 0;
    for (int i = 0; i <= k; i++) s += binomial(k, i) / binomial(n, i) * q[i];
    b[k] = s;
  }
  root_list r = {0};
  if (b[0] == 0) roots_push(&r, 0.0);
  if (b[n] == 0) roots_push(&r, 1.0);
  isolate_roots(b, n, 0.0, 1.0, 0, &r);
  for (int i = 0; i < r.count; i++) roots_push(out, lo + w * r.t[i]);
}

/* ------------------------------------------------------------------------------------ */
/* The resultant of C and A with respect to u, as a polynomial in v on [lo, hi]. */

/* The Sylvester matrix of f (degree m in u) and g (degree n) at one v: n shifted rows of
 * f's coefficients (highest power first) above m shifted rows of g's. Returns the
 * determinant and, in *scale, Hadamard's bound on it (the product of the row norms),
 * against which "zero" is judged. */
static double sylvester_det(const double *f, int m, const double *g, int n, double *scale) {
  int size = m + n;
  double a[(2 * BP_MAXD) * (2 * BP_MAXD)];
  memset(a, 0, sizeof(double) * (size_t)(size * size));
  for (int r = 0; r < n; r++)
    for (int i = 0; i <= m; i++) a[r * size + r + (m - i)] = f[i];
  for (int r = 0; r < m; r++)
    for (int i = 0; i <= n; i++) a[(n + r) * size + r + (n - i)] = g[i];
  double hadamard = 1;
  for (int r = 0; r < size; r++) {
    double s = 0;
    for (int j = 0; j < size; j++) s += a[r * size + j] * a[r * size + j];
    hadamard *= sqrt(s);
  }
  *scale = hadamard;
  return det_lu(a, size);
}

/* A(u) at complex u = (re, im) for the power-basis coefficients g[0..n]: the real and
 * imaginary parts, by Horner's scheme. */
static void complex_eval(const double *g, int n, double re, double im, double *out_re,
                         double *out_im) {
  double pr = 0, pi = 0;
  for (int k = n; k >= 0; k--) {
    double t = pr * re - pi * im + g[k];
    pi = pr * im + pi * re;
    pr = t;
  }
  *out_re = pr, *out_im = pi;
}

/* One sample of the resultant at v, with the magnitude against which "zero" is judged.
 * C has total degree 2, so when it is quadratic in u its leading coefficient a is a
 * constant, and Res_u(C, A) = a^n A(u+) A(u-) over the two roots u+- of C(., v) (real or
 * complex conjugate). The sample is A(u+) A(u-) = Res / a^n: the same polynomial in v up
 * to a constant factor, but evaluated without the Sylvester determinant's rounding, which
 * swamps the tiny a^n on nearly flat triangles. When C is linear in u the Sylvester
 * determinant has no such factor and is used directly. */
static double resultant_sample(const double *fc, int m, const double *gc, int n, double *scale) {
  if (m != 2) return sylvester_det(fc, m, gc, n, scale);
  double a = fc[2], b = fc[1], c = fc[0];
  double disc = b * b - 4 * a * c;
  double re[2], im[2];
  if (disc >= 0) {
    /* The stable pair: q = -(b + sign(b) sqrt(disc)) / 2, roots q / a and c / q. */
    double q = -0.5 * (b + copysign(sqrt(disc), b));
    re[0] = q / a, im[0] = 0;
    re[1] = q != 0 ? c / q : 0, im[1] = 0;
  } else {
    re[0] = re[1] = -b / (2 * a);
    im[0] = sqrt(-disc) / (2 * fabs(a));
    im[1] = -im[0];
  }
  double pr = 1, pi = 0, mag = 1;
  for (int i = 0; i < 2; i++) {
    double ar, ai;
    complex_eval(gc, n, re[i], im[i], &ar, &ai);
    double t = pr * ar - pi * ai;
    pi = pr * ai + pi * ar;
    pr = t;
    double r = hypot(re[i], im[i]), bound = 0;
    for (int k = n; k >= 0; k--) bound = bound * r + fabs(gc[k]);
    mag *= bound;
  }
  *scale = mag;
  return pr; /* the imaginary part is rounding: the roots are real or conjugate */
}

/* Interpolation of the resultant's samples in the Bernstein basis: for every degree, the
 * Chebyshev nodes of [0, 1] and the inverse of the collocation matrix B_j(t_s). They
 * depend on the degree only, so they are computed once per process (call_once makes that
 * safe from any number of threads) instead of factorising the matrix in every solve. */
typedef struct collocation {
  double t[RES_MAXD + 1];
  double inv[(RES_MAXD + 1) * (RES_MAXD + 1)];
  int ok;
} collocation;

static collocation collocations[RES_MAXD + 1];
static once_flag collocations_once = ONCE_FLAG_INIT;

static void collocations_init(void) {
  for (int deg = 1; deg <= RES_MAXD; deg++) {
    collocation *c = &collocations[deg];
    int n = deg + 1;
    double mat[(RES_MAXD + 1) * (RES_MAXD + 1)];
    for (int s = 0; s < n; s++)
      c->t[s] = 0.5 - 0.5 * cos((2.0 * s + 1.0) * 3.14159265358979323846 / (2.0 * n));
    c->ok = 1;
    for (int col = 0; col < n && c->ok; col++) {
      for (int s = 0; s < n; s++)
        for (int j = 0; j < n; j++)
          mat[s * n + j] = binomial(deg, j) * pow(c->t[s], j) * pow(1.0 - c->t[s], deg - j);
      double e[RES_MAXD + 1] = {0};
      e[col] = 1;
      c->ok = solve_lu(mat, e, n);
      for (int r = 0; r < n; r++) c->inv[r * n + col] = e[r];
    }
  }
}

/* Finds the roots v in [lo, hi] of Res_u(C, A)(v). Returns 0 when the resultant vanishes
 * identically (to rounding), i.e. the system is degenerate; else 1. */
static int resultant_roots(const bpoly *c, const bpoly *a, double lo, double hi, root_list *out) {
  int m = bp_deg_u(c), n = bp_deg_u(a);
  int deg = c->deg * a->deg;
  if (deg > RES_MAXD) deg = RES_MAXD;
  if (deg == 0) return 0;
  /* Sample at the Chebyshev nodes of [lo, hi]: they keep the interpolation well
   * conditioned. */
  call_once(&collocations_once, collocations_init);
  const collocation *col = &collocations[deg];
  if (!col->ok) return 0;
  double val[RES_MAXD + 1];
  int big = 0;
  for (int s = 0; s <= deg; s++) {
    double v = lo + (hi - lo) * col->t[s];
    double fc[BP_MAXD + 1], gc[BP_MAXD + 1], scale;
    bp_at_v(c, v, m, fc);
    bp_at_v(a, v, n, gc);
    val[s] = resultant_sample(fc, m, gc, n, &scale);
    if (!isfinite(val[s])) return 0;
    if (fabs(val[s]) > 1e-13 * scale) big = 1;
  }
  if (!big) return 0;
  /* Bernstein coefficients: b = M^-1 val for the collocation matrix M_sj = B_j(t_s). */
  double b[RES_MAXD + 1];
  for (int r = 0; r <= deg; r++) {
    double acc = 0;
    for (int s = 0; s <= deg; s++) acc += col->inv[r * (deg + 1) + s] * val[s];
    b[r] = acc;
  }
  memcpy(val, b, sizeof(double) * (size_t)(deg + 1));
  isolate_roots(val, deg, lo, hi, 0, out);
  return 1;
}

/* ------------------------------------------------------------------------------------ */

typedef struct solve_state {
  const bbc_path_geometry *g;
  bbc_vec3 xk;
  int swapped; /* the polynomials' u and v are T1's v and u (see solve_system) */
  const bbc_solver_options *options;
  bbc_solver_stats stats;
  bbc_solution found[BBC_SOLVER_MAX_SOLUTIONS];
  int count;
} solve_state;

/* Polishes a candidate with Newton's method on the exact constraint (bbc_solver_newton,
 * which also verifies the result) and keeps it if it is new. */
static void try_candidate(solve_state *st, double u, double v) {
  st->stats.candidates++;
  bbc_solver_options polish;
  if (st->options)
    polish = *st->options;
  else
    memset(&polish, 0, sizeof polish);
  bbc_solver_stats counts;
  memset(&counts, 0, sizeof counts);
  polish.stats = &counts;
  double start[2] = {u, v};
  bbc_solution s;
  int found = 0;
  if (bbc_solver_newton(st->g, st->xk, start, &polish, &s, &found) != BBC_OK) found = 0;
  st->stats.newton_iterations += counts.newton_iterations;
  st->stats.rejected_not_converged += counts.rejected_not_converged;
  st->stats.rejected_inadmissible += counts.rejected_inadmissible;
  if (!found) return;
  for (int i = 0; i < st->count; i++) {
    if (fabs(st->found[i].u1[0] - s.u1[0]) <= DUPLICATE_TOLERANCE &&
        fabs(st->found[i].u1[1] - s.u1[1]) <= DUPLICATE_TOLERANCE) {
      st->stats.duplicates++;
      return;
    }
  }
  if (st->count < BBC_SOLVER_MAX_SOLUTIONS) st->found[st->count++] = s;
}

/* ------------------------------------------------------------------------------------ */
/* The reflection pre-test. A reflected path through x1 has r x d1 = 0, with d0 = x1 - x0,
 * d1 = x_k - x1 and r = (n.n) d0 - 2 (d0.n) n the reflected direction (unnormalised):
 *   F = (n.n) (d0 x d1) - 2 (d0.n) (n x d1) = 0,
 * three polynomials of degree 4 on T1 (products of the affine d0, d1 and n). Written in
 * the Bernstein basis of a triangle's barycentrics, each is enclosed by its 15
 * coefficients; where one component's coefficients all exceed the margin (or all lie
 * below minus it) on a triangle, F has no zero there. T1 (grown by the triangle
 * tolerance) is tested whole, then in its four halves and their quarters: a path is ruled
 * out when every piece is. The margin is the verifier's own: a path it accepts misses
 * x_k by an angle whose sine is at most angle_tolerance, so |F| <= angle_tolerance
 * |r| |d1| <= angle_tolerance 3 N^2 D0 D1 there (N, D0, D1 the largest |n|, |d0|, |d1|
 * over the piece, reached at a corner since each is affine). */

/* Scaled Bernstein coefficients on a triangle: the coefficient of the multi-index
 * (k0, k1, k2) (powers of the corners' barycentrics) times its multinomial, so that a
 * product is the plain convolution. Degree 2: the six multi-indices in the order
 * 200, 020, 002, 110, 101, 011; degree 4: the fifteen (k1, k2), k1 + k2 <= 4, in the
 * order k1 * (11 - k1) / 2 + k2. tp4_product[6 a + b] is where the product of degree-2
 * coefficients a and b lands; tp4_multinomial[k] is 4! / (k0! k1! k2!). Constants, so
 * that the compiler unrolls the convolution with fixed indices. */
static const unsigned char tp4_product[36] = {
    0, 9, 2, 5, 1, 6,
    9, 14, 11, 12, 10, 13,
    2, 11, 4, 7, 3, 8,
    5, 12, 7, 9, 6, 10,
    1, 10, 3, 6, 2, 7,
    6, 13, 8, 10, 7, 11,
};
static const double tp4_multinomial[15] = {1, 4, 6, 4, 1, 4, 12, 12, 4, 6, 12, 6, 4, 4, 1};

/* out (degree 2, scaled) += s a b for affine a, b given by their corner values. */
static inline __attribute__((always_inline)) void tp2_muladd(double out[6], const double a[3],
                                                              const double b[3], double s) {
  out[0] += s * a[0] * b[0];
  out[1] += s * a[1] * b[1];
  out[2] += s * a[2] * b[2];
  out[3] += s * (a[0] * b[1] + a[1] * b[0]);
  out[4] += s * (a[0] * b[2] + a[2] * b[0]);
  out[5] += s * (a[1] * b[2] + a[2] * b[1]);
}

/* The affine factors of F at a triangle's three corners: component c at corner k in
 * [c][k]. */
/* The corner values (component c at corner k in [c][k]) of an affine factor on piece s of
 * a triangle split into four: corner k of piece s is the midpoint of the parent's corners
 * PIECE[s][k] (a corner itself when both are equal), the three corner pieces first, then
 * the middle one. */
static const int PIECE[4][3][2] = {{{0, 0}, {0, 1}, {0, 2}},
                                   {{0, 1}, {1, 1}, {1, 2}},
                                   {{0, 2}, {1, 2}, {2, 2}},
                                   {{1, 2}, {0, 2}, {0, 1}}};
static void piece_corners(double out[3][3], const double in[3][3], int s) {
  for (int k = 0; k < 3; k++) {
    const int a = PIECE[s][k][0], b = PIECE[s][k][1];
    for (int c = 0; c < 3; c++) out[c][k] = 0.5 * (in[c][a] + in[c][b]);
  }
}

typedef struct reflection_corners {
  double d0[3][3], d1[3][3], n[3][3];
} reflection_corners;

/* 1 if F has no zero on the triangle with corner values r: some component's Bernstein
 * coefficients all exceed margin, or all lie below -margin. */
static int reflection_ruled_out(const reflection_corners *r, double margin) {
  double nn[6] = {0}, an[6] = {0};
  for (int c = 0; c < 3; c++) {
    tp2_muladd(nn, r->n[c], r->n[c], 1.0);
    tp2_muladd(an, r->d0[c], r->n[c], -2.0);
  }
  for (int c = 0; c < 3; c++) {
    const int y = (c + 1) % 3, z = (c + 2) % 3;
    double ab[6] = {0}, nb[6] = {0}, f[15] = {0};
    tp2_muladd(ab, r->d0[y], r->d1[z], 1.0);
    tp2_muladd(ab, r->d0[z], r->d1[y], -1.0);
    tp2_muladd(nb, r->n[y], r->d1[z], 1.0);
    tp2_muladd(nb, r->n[z], r->d1[y], -1.0);
#pragma GCC unroll 36
    for (int k = 0; k < 36; k++) f[tp4_product[k]] += nn[k / 6] * ab[k % 6] + an[k / 6] * nb[k % 6];
    int positive = 1, negative = 1;
    for (int k = 0; k < 15 && (positive || negative); k++) {
      const double m = margin * tp4_multinomial[k];
      if (!(f[k] > m)) positive = 0;
      if (!(f[k] < -m)) negative = 0;
    }
    if (positive || negative) return 1;
  }
  return 0;
}

/* 1 if reflection_ruled_out holds on every piece of the triangle r split `depth` times
 * into four. The pieces' corner values are means of their parent's (the factors are
 * affine); the margin stays the whole triangle's, at least each piece's own. */
static int reflection_ruled_out_split(const reflection_corners *r, double margin, int depth) {
  if (reflection_ruled_out(r, margin)) return 1;
  if (depth == 0) return 0;
  for (int s = 0; s < 4; s++) {
    reflection_corners q;
    piece_corners(q.d0, r->d0, s);
    piece_corners(q.d1, r->d1, s);
    piece_corners(q.n, r->n, s);
    if (!reflection_ruled_out_split(&q, margin, depth - 1)) return 0;
  }
  return 1;
}

/* T1's corners grown by the verifier's tolerance (at least the root search's pad), in
 * barycentrics: (-d, -d), (1 + 2d, -d), (-d, 1 + 2d). */
static void grown_corners(const bbc_solver_options *options, double corner[3][2]) {
  double d = fmax(SEARCH_PAD, bbc__solver_triangle_tolerance(options));
  corner[0][0] = -d, corner[0][1] = -d;
  corner[1][0] = 1 + 2 * d, corner[1][1] = -d;
  corner[2][0] = -d, corner[2][1] = 1 + 2 * d;
}

/* The coplanarity half of bbc_solver_single_possible. */
static int coplanar_possible(const bbc_path_geometry *g, bbc_vec3 xk,
                             const bbc_solver_options *options) {
  const bbc_specular_triangle *t = &g->specular[0];
  double corner[3][2];
  grown_corners(options, corner);
  bbc_vec3 e1 = v3_sub(t->p[1], t->p[0]), e2 = v3_sub(t->p[2], t->p[0]);
  bbc_vec3 m1 = v3_sub(t->n[1], t->n[0]), m2 = v3_sub(t->n[2], t->n[0]);
  /* A sun's light arrives along the constant D: its plane of incidence holds D and
   * x_k - x1 (solve_polynomials does the same). */
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  bbc_vec3 w = v3_sub(xk, g->light), f[3], n[3];
  double fmax_len = 0, nmax_len = 0;
  for (int i = 0; i < 3; i++) {
    double u = corner[i][0], v = corner[i][1];
    bbc_vec3 x1 = v3_add(t->p[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
    f[i] = sun ? v3_cross(g->light_model.direction, v3_sub(xk, x1))
               : v3_cross(v3_sub(x1, g->light), w);
    n[i] = v3_add(t->n[0], v3_add(v3_scale(m1, u), v3_scale(m2, v)));
    fmax_len = fmax(fmax_len, v3_length(f[i]));
    nmax_len = fmax(nmax_len, v3_length(n[i]));
  }
  double margin = 1e-9 * fmax_len * nmax_len;
  if (!isfinite(margin)) return 1;
  int positive = 1, negative = 1;
  for (int i = 0; i < 3; i++)
    for (int j = i; j < 3; j++) {
      double b = 0.5 * (v3_dot(f[i], n[j]) + v3_dot(f[j], n[i]));
      if (!(b > margin)) positive = 0;
      if (!(b < -margin)) negative = 0;
    }
  return !(positive || negative);
}

/* The reflection half: 0 when F has no zero on T1 (grown), split REFLECTION_SPLITS
 * times where needed. */
static int reflection_possible(const bbc_path_geometry *g, bbc_vec3 xk,
                               const bbc_solver_options *options) {
  const bbc_specular_triangle *t = &g->specular[0];
  if (t->refract) return 1;
  double corner[3][2];
  grown_corners(options, corner);
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  bbc_vec3 e1 = v3_sub(t->p[1], t->p[0]), e2 = v3_sub(t->p[2], t->p[0]);
  bbc_vec3 m1 = v3_sub(t->n[1], t->n[0]), m2 = v3_sub(t->n[2], t->n[0]);
  reflection_corners r;
  double nmax = 0, d0max = 0, d1max = 0;
  for (int k = 0; k < 3; k++) {
    const double u = corner[k][0], v = corner[k][1];
    bbc_vec3 x1 = v3_add(t->p[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
    bbc_vec3 a = sun ? g->light_model.direction : v3_sub(x1, g->light);
    bbc_vec3 b = v3_sub(xk, x1);
    bbc_vec3 n = v3_add(t->n[0], v3_add(v3_scale(m1, u), v3_scale(m2, v)));
    r.d0[0][k] = a.x, r.d0[1][k] = a.y, r.d0[2][k] = a.z;
    r.d1[0][k] = b.x, r.d1[1][k] = b.y, r.d1[2][k] = b.z;
    r.n[0][k] = n.x, r.n[1][k] = n.y, r.n[2][k] = n.z;
    nmax = fmax(nmax, v3_length(n));
    d0max = fmax(d0max, v3_length(a));
    d1max = fmax(d1max, v3_length(b));
  }
  /* |F| <= tolerance |r| |d1| <= tolerance 3 N^2 D0 D1 at an accepted path. */
  double margin = bbc__solver_angle_tolerance(options) * 3 * nmax * nmax * d0max * d1max;
  if (!isfinite(margin) || !(margin > 0)) return 1;
  return !reflection_ruled_out_split(&r, margin, REFLECTION_SPLITS);
}

/* ------------------------------------------------------------------------------------ */
/* The refraction pre-test. A refracted path through x1, with d0 = x1 - x0 (for a sun its
 * direction D), d1 = x_k - x1 and n the interpolated normal (unnormalised, affine on T1),
 * obeys, at the side where d0 . n has the sign s (the trace's eta: the ior when the ray
 * leaves with the normal, s > 0, 1 / ior when it enters against it):
 *   coplanarity  C = (d0 x d1) . n = 0                          (degree 2: d0 x d1 is
 *                affine, (x1 - x0) x (x_k - x0) or D x (x_k - x1)),
 *   transmission s (d1 . n) > 0: the ray goes on through the surface (degree 2),
 *   Snell        G = eta^2 |d0 x n|^2 |d1|^2 - |d1 x n|^2 |d0|^2 = 0, the squared
 *                sin(theta_t) = eta sin(theta_i) times |d0|^2 |d1|^2 |n|^2 (degree 6).
 * A piece of T1 where C or G keeps a sign, or s (d1 . n) stays negative, beyond the
 * margins below, holds no path. T1 (grown by the triangle tolerance) is tested whole,
 * then in its four halves and their quarters, as the reflection pre-test is. The
 * margins are the verifier's: an accepted path's last segment d1 makes an angle of at
 * most asin(tol) <= (pi / 2) tol with the traced refracted direction t, for which C = 0,
 * s (t . n) > 0 and |t x n| / |n| = eta |d0 x n| / (|d0| |n|) hold exactly; so there
 * |C| <= 2 tol D0 D1 N, s (d1 . n) >= -2 tol D1 N and, the sines differing by at most
 * that angle, |G| <= 4 tol N^2 D0^2 D1^2 (N, D0, D1 the largest |n|, |d0|, |d1| over the
 * triangle, reached at a corner since each is affine). The side s must be one over the
 * whole triangle (every coefficient of d0 . n of one sign), else the test answers "a
 * path may exist". */
#define REFRACTION_SPLITS 1

/* tp6_multinomial[k] is 6! / (k0! k1! k2!) for the 28 multi-indices of degree 6 in the
 * order k1 * (15 - k1) / 2 + k2; tp6_product[6 a + b] is where the product of the
 * degree-4 coefficient a (tp4's order) and the degree-2 one b (tp2_muladd's) lands;
 * tp2_multinomial is 2! / (k0! k1! k2!) in tp2_muladd's order. */
static const double tp6_multinomial[28] = {1,  6,  15, 20, 15, 6,  1,  6,  30, 60,
                                           60, 30, 6,  15, 60, 90, 60, 15, 20, 60,
                                           60, 20, 15, 30, 15, 6,  6,  1};
static const unsigned char tp6_product[90] = {
    0,  13, 2,  7,  1,  8,  1,  14, 3,  8,  2,  9,  2,  15, 4,  9,  3,  10,
    3,  16, 5,  10, 4,  11, 4,  17, 6,  11, 5,  12, 7,  18, 9,  13, 8,  14,
    8,  19, 10, 14, 9,  15, 9,  20, 11, 15, 10, 16, 10, 21, 12, 16, 11, 17,
    13, 22, 15, 18, 14, 19, 14, 23, 16, 19, 15, 20, 15, 24, 17, 20, 16, 21,
    18, 25, 20, 22, 19, 23, 19, 26, 21, 23, 20, 24, 22, 27, 24, 25, 23, 26};
static const double tp2_multinomial[6] = {1, 1, 1, 2, 2, 2};

/* The affine factors at a triangle's three corners: component c at corner k in [c][k];
 * f is the coplanarity factor d0 x d1. */
typedef struct refraction_corners {
  double d0[3][3], d1[3][3], n[3][3], f[3][3];
} refraction_corners;

typedef struct refraction_margins {
  double eta2;     /* eta^2 */
  double side;     /* s */
  double coplanar; /* of C */
  double through;  /* of s (d1 . n) */
  double snell;    /* of G */
} refraction_margins;

/* 1 if every scaled coefficient c[k] exceeds margin times mult[k], or every one lies
 * below minus that. */
static int keeps_sign(const double *c, const double *mult, int count, double margin) {
  int positive = 1, negative = 1;
  for (int k = 0; k < count && (positive || negative); k++) {
    const double m = margin * mult[k];
    if (!(c[k] > m)) positive = 0;
    if (!(c[k] < -m)) negative = 0;
  }
  return positive || negative;
}

/* 1 if no refracted path crosses the triangle with corner values r. */
static int refraction_ruled_out(const refraction_corners *r, const refraction_margins *m) {
  double cop[6] = {0}, through[6] = {0};
  for (int c = 0; c < 3; c++) {
    tp2_muladd(cop, r->f[c], r->n[c], 1.0);
    tp2_muladd(through, r->d1[c], r->n[c], m->side);
  }
  if (keeps_sign(cop, tp2_multinomial, 6, m->coplanar)) return 1;
  int behind = 1;
  for (int k = 0; k < 6 && behind; k++)
    if (!(through[k] < -m->through * tp2_multinomial[k])) behind = 0;
  if (behind) return 1;
  double a2[15] = {0}, b2[15] = {0}, d0sq[6] = {0}, d1sq[6] = {0};
  for (int c = 0; c < 3; c++) {
    const int y = (c + 1) % 3, z = (c + 2) % 3;
    double a[6] = {0}, b[6] = {0};
    tp2_muladd(a, r->d0[y], r->n[z], 1.0);
    tp2_muladd(a, r->d0[z], r->n[y], -1.0);
    tp2_muladd(b, r->d1[y], r->n[z], 1.0);
    tp2_muladd(b, r->d1[z], r->n[y], -1.0);
    /* The squares, each product of two distinct coefficients once, doubled. */
#pragma GCC unroll 6
    for (int i = 0; i < 6; i++) {
      a2[tp4_product[7 * i]] += a[i] * a[i];
      b2[tp4_product[7 * i]] += b[i] * b[i];
#pragma GCC unroll 6
      for (int j = i + 1; j < 6; j++) {
        a2[tp4_product[6 * i + j]] += 2 * (a[i] * a[j]);
        b2[tp4_product[6 * i + j]] += 2 * (b[i] * b[j]);
      }
    }
    tp2_muladd(d0sq, r->d0[c], r->d0[c], 1.0);
    tp2_muladd(d1sq, r->d1[c], r->d1[c], 1.0);
  }
  double gq[28] = {0};
#pragma GCC unroll 15
  for (int i = 0; i < 15; i++) {
    const double ea = m->eta2 * a2[i], eb = b2[i];
#pragma GCC unroll 6
    for (int j = 0; j < 6; j++) gq[tp6_product[6 * i + j]] += ea * d1sq[j] - eb * d0sq[j];
  }
  return keeps_sign(gq, tp6_multinomial, 28, m->snell);
}

/* 1 if refraction_ruled_out holds on every piece of r split `depth` times into four
 * (the pieces as in reflection_ruled_out_split). */
static int refraction_ruled_out_split(const refraction_corners *r, const refraction_margins *m,
                                      int depth) {
  if (refraction_ruled_out(r, m)) return 1;
  if (depth == 0) return 0;
  for (int s = 0; s < 4; s++) {
    refraction_corners q;
    piece_corners(q.d0, r->d0, s);
    piece_corners(q.d1, r->d1, s);
    piece_corners(q.n, r->n, s);
    piece_corners(q.f, r->f, s);
    if (!refraction_ruled_out_split(&q, m, depth - 1)) return 0;
  }
  return 1;
}

/* The refraction half: 0 when no refracted path crosses T1 (grown). */
static int refraction_possible(const bbc_path_geometry *g, bbc_vec3 xk,
                               const bbc_solver_options *options) {
  const bbc_specular_triangle *t = &g->specular[0];
  if (!t->refract || !(t->ior > 0)) return 1;
  double corner[3][2];
  grown_corners(options, corner);
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  bbc_vec3 e1 = v3_sub(t->p[1], t->p[0]), e2 = v3_sub(t->p[2], t->p[0]);
  bbc_vec3 m1 = v3_sub(t->n[1], t->n[0]), m2 = v3_sub(t->n[2], t->n[0]);
  bbc_vec3 w = v3_sub(xk, g->light);
  refraction_corners r;
  double nmax = 0, d0max = 0, d1max = 0;
  for (int k = 0; k < 3; k++) {
    const double u = corner[k][0], v = corner[k][1];
    bbc_vec3 x1 = v3_add(t->p[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
    bbc_vec3 a = sun ? g->light_model.direction : v3_sub(x1, g->light);
    bbc_vec3 b = v3_sub(xk, x1);
    bbc_vec3 n = v3_add(t->n[0], v3_add(v3_scale(m1, u), v3_scale(m2, v)));
    bbc_vec3 f = sun ? v3_cross(a, b) : v3_cross(a, w);
    r.d0[0][k] = a.x, r.d0[1][k] = a.y, r.d0[2][k] = a.z;
    r.d1[0][k] = b.x, r.d1[1][k] = b.y, r.d1[2][k] = b.z;
    r.n[0][k] = n.x, r.n[1][k] = n.y, r.n[2][k] = n.z;
    r.f[0][k] = f.x, r.f[1][k] = f.y, r.f[2][k] = f.z;
    nmax = fmax(nmax, v3_length(n));
    d0max = fmax(d0max, v3_length(a));
    d1max = fmax(d1max, v3_length(b));
  }
  const double tol = bbc__solver_angle_tolerance(options);
  /* The side: d0 . n of one sign over the whole triangle, beyond its rounding. */
  double dn[6] = {0};
  for (int c = 0; c < 3; c++) tp2_muladd(dn, r.d0[c], r.n[c], 1.0);
  const double rounding = 1e-12 * d0max * nmax;
  int positive = 1, negative = 1;
  for (int k = 0; k < 6; k++) {
    if (!(dn[k] > rounding * tp2_multinomial[k])) positive = 0;
    if (!(dn[k] < -rounding * tp2_multinomial[k])) negative = 0;
  }
  if (!positive && !negative) return 1;
  refraction_margins m;
  const double eta = positive ? t->ior : 1.0 / t->ior;
  m.eta2 = eta * eta;
  m.side = positive ? 1.0 : -1.0;
  m.coplanar = 2 * tol * d0max * d1max * nmax;
  m.through = 2 * tol * d1max * nmax;
  m.snell = 4 * tol * nmax * nmax * d0max * d0max * d1max * d1max;
  if (!isfinite(m.snell) || !(m.snell > 0) || !isfinite(m.eta2)) return 1;
  return !refraction_ruled_out_split(&r, &m, REFRACTION_SPLITS);
}

int bbc_solver_single_possible(const bbc_path_geometry *g, bbc_vec3 xk,
                               const bbc_solver_options *options) {
  if (!g || g->length != 1) return 1;
  return coplanar_possible(g, xk, options) && reflection_possible(g, xk, options) &&
         refraction_possible(g, xk, options);
}

/* A mirror whose three vertex normals are equal reflects with one unit normal n
 * everywhere (the normalised interpolation of equal vectors is constant), so its paths
 * have a closed form and need no polynomial. Reflection about n is H = I - 2 n n^T; with
 * a = x1 - x0, w = x_k - x0 and the reflected ray reaching x_k = x1 + t H a (t > 0),
 * w = (I + t H) a, whose parts across and along n give a = w_p / (1 + t) + w_n n / (1 - t).
 * x1 lies on T1's plane (normal g): (x0 + a - p0) . g = 0, that is
 *   c t^2 + (B - A) t + (A + B - c) = 0,  c = (p0 - x0) . g, A = w_p . g, B = w_n (n . g).
 * When n is T1's geometric normal, A = 0 and the roots are t = -1 and t = 1 - B / c: x1 is
 * where the segment from the mirrored light to x_k crosses the mirror's plane. Each root
 * with t > 0 is verified by the exact trace (bbc_solver_verify), as the polynomial
 * solver's candidates are. Returns 0 when the normals differ or the light lies in T1's
 * plane (then the general solver runs). */
static int solve_flat_mirror(solve_state *st) {
  const bbc_specular_triangle *t = &st->g->specular[0];
  for (int i = 1; i < 3; i++)
    if (t->refract || t->n[i].x != t->n[0].x || t->n[i].y != t->n[0].y || t->n[i].z != t->n[0].z)
      return 0;
  bbc_vec3 n = v3_normalize(t->n[0]);
  bbc_vec3 g = v3_cross(v3_sub(t->p[1], t->p[0]), v3_sub(t->p[2], t->p[0]));
  if (st->g->light_model.kind == BBC_LIGHT_DIRECTIONAL) {
    /* A sun's parallel light D leaves the mirror along r = H D: x1 = x_k - s r on T1's
     * plane, s = (x_k - p0) . g / (r . g) > 0. */
    bbc_vec3 d = st->g->light_model.direction;
    bbc_vec3 r = v3_madd(d, n, -2 * v3_dot(d, n));
    double den = v3_dot(r, g), s = v3_dot(v3_sub(st->xk, t->p[0]), g) / den;
    if (!(v3_length(n) > 0) || !(den != 0)) return 0;
    if (!(s > 0) || !isfinite(s)) return 1;
    double uv[2];
    bbc_solution sol;
    st->stats.candidates++;
    if (!bbc_triangle_barycentrics(t->p, v3_madd(st->xk, r, -s), uv) ||
        !bbc_solver_verify(st->g, st->xk, uv[0], uv[1], st->options, &sol))
      st->stats.rejected_inadmissible++;
    else if (st->count < BBC_SOLVER_MAX_SOLUTIONS)
      st->found[st->count++] = sol;
    return 1;
  }
  bbc_vec3 x0 = st->g->light, w = v3_sub(st->xk, x0);
  double wn = v3_dot(w, n);
  bbc_vec3 wp = v3_madd(w, n, -wn);
  double c = v3_dot(v3_sub(t->p[0], x0), g), A = v3_dot(wp, g), B = wn * v3_dot(n, g);
  if (!(v3_length(n) > 0) || !(c != 0) || !isfinite(c)) return 0;
  double b = B - A, k = A + B - c, disc = b * b - 4 * c * k;
  if (disc < 0) return 1;
  double q = -0.5 * (b + copysign(sqrt(disc), b));
  double roots[2] = {q / c, q != 0 ? k / q : NAN};
  for (int r = 0; r < 2; r++) {
    double tr = roots[r];
    if (!(tr > 0) || !isfinite(tr) || tr == 1 || (r == 1 && tr == roots[0])) continue;
    bbc_vec3 x1 = v3_add(x0, v3_madd(v3_scale(wp, 1.0 / (1.0 + tr)), n, wn / (1.0 - tr)));
    double uv[2];
    st->stats.candidates++;
    bbc_solution s;
    if (!bbc_triangle_barycentrics(t->p, x1, uv) ||
        !bbc_solver_verify(st->g, st->xk, uv[0], uv[1], st->options, &s)) {
      st->stats.rejected_inadmissible++;
      continue;
    }
    if (st->count < BBC_SOLVER_MAX_SOLUTIONS) st->found[st->count++] = s;
  }
  return 1;
}

/* Back-substitution at one root v* of the resultant: the real roots u of the
 * lower-degree polynomial in the u range, ranked by how nearly the other vanishes. */
static void back_substitute(solve_state *st, const bpoly *c, const bpoly *a, double v) {
  int m = bp_deg_u(c), n = bp_deg_u(a);
  double fc[BP_MAXD + 1], gc[BP_MAXD + 1];
  bp_at_v(c, v, m, fc);
  bp_at_v(a, v, n, gc);
  /* Solve the polynomial of lower (non-zero) degree in u, unless it vanishes at this v;
   * both were normalised to a largest coefficient of 1 by solve_system. */
  double fnorm = 0, hnorm = 0;
  for (int i = 0; i <= m; i++) fnorm += fabs(fc[i]);
  for (int i = 0; i <= n; i++) hnorm += fabs(gc[i]);
  int use_c = m > 0 && (n == 0 || m <= n);
  if (use_c && fnorm <= 1e-12) use_c = 0;
  if (!use_c && (n == 0 || hnorm <= 1e-12)) use_c = m > 0 && fnorm > 1e-12;
  const double *f = use_c ? fc : gc, *h = use_c ? gc : fc;
  int fd = use_c ? m : n, hd = use_c ? n : m;
  if (!use_c) {
    double t = fnorm;
    fnorm = hnorm, hnorm = t;
  }
  if (fd == 0) return;
  root_list us = {0};
  power_roots(f, fd, -SEARCH_PAD, 1.0 - v + SEARCH_PAD, &us);
  if (us.count == 0) return;
  /* Rank by the residual of the other polynomial; keep the best and any that come close
   * (a common root makes it vanish up to the error of v*). */
  double res[RES_MAXD + 4], best = INFINITY;
  for (int i = 0; i < us.count; i++) {
    double s = 0;
    for (int k = hd; k >= 0; k--) s = s * us.t[i] + h[k];
    res[i] = fabs(s) / (hnorm > 0 ? hnorm : 1.0);
    best = fmin(best, res[i]);
  }
  for (int i = 0; i < us.count; i++)
    if (res[i] == best || res[i] <= 1e-4) {
      if (st->swapped)
        try_candidate(st, v, us.t[i]);
      else
        try_candidate(st, us.t[i], v);
    }
}

/* Zeroes the coefficients of p below tol: they are rounding noise (a coefficient that
 * vanishes analytically, e.g. the u^2 term of C on a sphere, whose normals are an affine
 * function of position, comes out as a few ulps of the others), and a noisy leading
 * coefficient would give the resultant a spurious huge factor. */
static void bp_chop(bpoly *p, double tol) {
  for (int i = 0; i <= p->deg; i++)
    for (int j = 0; i + j <= p->deg; j++)
      if (fabs(p->c[i][j]) <= tol) p->c[i][j] = 0;
}

/* Solves the system {c = 0, a = 0} on T1 and feeds every candidate to try_candidate.
 * scale_c and scale_a are the natural magnitudes of the two polynomials (products of the
 * lengths they are made of), against which an identically vanishing one is recognised.
 * Returns 0 if the system is degenerate; else 1. */
static int solve_system(solve_state *st, bpoly *c, bpoly *a, double scale_c, double scale_a) {
  double cm = bp_max_abs(c), am = bp_max_abs(a);
  if (!isfinite(cm) || !isfinite(am) || cm <= 1e-12 * scale_c || am <= 1e-12 * scale_a) return 0;
  bp_chop(c, 1e-12 * cm);
  bp_chop(a, 1e-12 * am);
  bp_trim(c);
  bp_trim(a);
  /* The roots are isolated in v and then found in u along the curve C = 0. Where that
   * curve runs nearly along the u axis, roots far apart on it have nearly equal v: they
   * cluster in the resultant, which then places them poorly, and back-substitution along
   * the flat curve amplifies the error. So the variable C changes fastest along (at T1's
   * centre) is the one eliminated: if that is v, u and v are exchanged (the triangle's
   * domain is symmetric in them). The curve's direction then makes at most 45 degrees
   * with the v axis. */
  double cu = c->deg >= 1 ? c->c[1][0] : 0, cv = c->deg >= 1 ? c->c[0][1] : 0;
  if (c->deg >= 2) {
    cu += (2 * c->c[2][0] + c->c[1][1]) / 3.0;
    cv += (2 * c->c[0][2] + c->c[1][1]) / 3.0;
  }
  st->swapped = fabs(cv) > fabs(cu);
  if (st->swapped) {
    bp_transpose(c);
    bp_transpose(a);
  }
  /* Normalising keeps the resultant's magnitude near 1. */
  bp_scale(c, 1.0 / cm);
  bp_scale(a, 1.0 / am);
  const double lo = -SEARCH_PAD, hi = 1.0 + SEARCH_PAD;
  root_list vs = {0};
  int m = bp_deg_u(c), n = bp_deg_u(a);
  if (m == 0 || n == 0) {
    /* One polynomial does not involve u: its own roots in v are the candidates' v (the
     * resultant would be a power of it, with multiple roots). */
    const bpoly *p = m == 0 ? c : a;
    double coef[BP_MAXD + 1];
    for (int j = 0; j <= p->deg; j++) coef[j] = p->c[0][j];
    power_roots(coef, p->deg, lo, hi, &vs);
  } else if (!resultant_roots(c, a, lo, hi, &vs)) {
    return 0;
  }
  st->stats.resultant_roots += (uint64_t)vs.count;
  for (int i = 0; i < vs.count; i++) back_substitute(st, c, a, vs.t[i]);
  return 1;
}

/* Seeds for the degenerate case: the centre and the centres of the three corner
 * sub-triangles. */
static void fallback(solve_state *st) {
  static const double seeds[4][2] = {
      {1.0 / 3, 1.0 / 3}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}, {1.0 / 6, 1.0 / 6}};
  st->stats.fallbacks++;
  for (int i = 0; i < 4; i++) try_candidate(st, seeds[i][0], seeds[i][1]);
}

static int solution_less(const bbc_solution *a, const bbc_solution *b) {
  return a->u1[0] < b->u1[0] || (a->u1[0] == b->u1[0] && a->u1[1] < b->u1[1]);
}

static void add_stats(bbc_solver_stats *to, const bbc_solver_stats *from) {
  to->solves += from->solves;
  to->resultant_roots += from->resultant_roots;
  to->candidates += from->candidates;
  to->newton_iterations += from->newton_iterations;
  to->rejected_not_converged += from->rejected_not_converged;
  to->rejected_inadmissible += from->rejected_inadmissible;
  to->duplicates += from->duplicates;
  to->fallbacks += from->fallbacks;
  to->solutions += from->solutions;
  to->excluded += from->excluded;
}

/* The general case: the constraint polynomials and their resultant (top of the file). */
static void solve_polynomials(solve_state *st) {
  const bbc_path_geometry *g = st->g;
  const bbc_vec3 xk = st->xk;
  const bbc_specular_triangle *t = &g->specular[0];
  bbc_vec3 e1 = v3_sub(t->p[1], t->p[0]), e2 = v3_sub(t->p[2], t->p[0]);
  /* The polynomial vectors of Eq. 6-8 (x1 itself only through d0 and d1). */
  /* A sun (directional light) has the constant d0 = D: then d0 x d1 = D x d1 takes the
   * place of d0 x w, still of degree 1, and D itself that of w in the plane of incidence. */
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  const bbc_vec3 zero = {0, 0, 0};
  bvec d0, d1, n;
  if (sun)
    bv_linear(&d0, g->light_model.direction, zero, zero);
  else
    bv_linear(&d0, v3_sub(t->p[0], g->light), e1, e2);
  bv_linear(&d1, v3_sub(xk, t->p[0]), v3_neg(e1), v3_neg(e2));
  bv_linear(&n, t->n[0], v3_sub(t->n[1], t->n[0]), v3_sub(t->n[2], t->n[0]));
  bbc_vec3 w = sun ? g->light_model.direction : v3_sub(xk, g->light);

  /* Coplanarity C = (d0 x w) . n (degree 2). */
  bvec d0w;
  if (sun)
    bv_cross(&d0w, &d0, &d1);
  else
    bv_crossc(&d0w, &d0, w);
  bpoly c;
  bv_dot(&c, &d0w, &n);

  /* Natural magnitudes: lengths from the light (L0) and to x_k (L1) over T1, and of the
   * normals (N). A polynomial far below its magnitude vanishes identically. */
  double le = v3_length(e1) + v3_length(e2);
  double L0 = sun ? 1.0 : v3_length(v3_sub(t->p[0], g->light)) + le;
  double L1 = v3_length(v3_sub(xk, t->p[0])) + le;
  double N = v3_length(t->n[0]) + v3_length(v3_sub(t->n[1], t->n[0])) +
             v3_length(v3_sub(t->n[2], t->n[0]));
  double W = sun ? L1 : v3_length(w);
  double scale_c = L0 * W * N;

  int solved = 1;
  bbc_vec3 navg = v3_normalize(v3_add(t->n[0], v3_add(t->n[1], t->n[2])));
  bbc_vec3 tv = v3_cross(w, navg);
  if (!t->refract && v3_length(tv) > 0.05 * v3_length(w)) {
    /* A = (r x d1) . t with r x d1 = (n.n)(d0 x w) - 2 (d0.n)(n x d1) (degree 4). */
    tv = v3_scale(tv, 1.0 / v3_length(tv));
    bpoly nn, d0n, p1, p2, a;
    bvec nd1;
    bv_dot(&nn, &n, &n);
    bv_dot(&d0n, &d0, &n);
    bv_dotc(&p1, &d0w, tv);
    bv_cross(&nd1, &n, &d1);
    bv_dotc(&p2, &nd1, tv);
    bp_zero(&a);
    bp_muladd(&a, &nn, &p1, 1.0);
    bp_muladd(&a, &d0n, &p2, -2.0);
    bpoly cc = c;
    solved = solve_system(st, &cc, &a, scale_c, N * N * L0 * (W + L1));
  } else {
    /* The square form eta_i^2 |d1|^2 |d0 x n|^2 - eta_o^2 |d0|^2 |d1 x n|^2: refraction,
     * and reflection (eta_i = eta_o) where light and x_k lie on one normal line. */
    bvec d0xn, d1xn;
    bv_cross(&d0xn, &d0, &n);
    bv_cross(&d1xn, &d1, &n);
    bpoly s0, s1, l0, l1;
    bv_dot(&s0, &d0xn, &d0xn);
    bv_dot(&s1, &d1xn, &d1xn);
    bv_dot(&l0, &d0, &d0);
    bv_dot(&l1, &d1, &d1);
    /* For refraction, which side the light arrives from decides eta_i and eta_o. The side
     * is the sign of s(u, v) = (x0 - x1) . n, a quadratic on T1. Its six Bernstein
     * coefficients on the triangle (the values at the corners, and 2 s(mid) - (s(a) +
     * s(b)) / 2 for each edge a-b) enclose it, so the cases it can take are known for
     * certain; where it may change sign inside T1 both are solved and verification keeps
     * the consistent roots. (Probing a few points instead missed sides on triangles with
     * strongly varying normals.) */
    int front = !t->refract, back = 0;
    if (t->refract) {
      static const double corner[3][2] = {{0, 0}, {1, 0}, {0, 1}};
      double sc[3];
      for (int i = 0; i < 6; i++) {
        int a = i < 3 ? i : i - 3, b = i < 3 ? i : (i - 2) % 3;
        double pu = 0.5 * (corner[a][0] + corner[b][0]), pv = 0.5 * (corner[a][1] + corner[b][1]);
        bbc_vec3 x = v3_add(t->p[0], v3_add(v3_scale(e1, pu), v3_scale(e2, pv)));
        bbc_vec3 nrm = v3_add(t->n[0], v3_add(v3_scale(v3_sub(t->n[1], t->n[0]), pu),
                                              v3_scale(v3_sub(t->n[2], t->n[0]), pv)));
        double side = sun ? -v3_dot(g->light_model.direction, nrm) : v3_dot(v3_sub(g->light, x), nrm);
        if (i < 3)
          sc[i] = side;
        else
          side = 2 * side - 0.5 * (sc[a] + sc[b]);
        if (side >= 0) front = 1;
        if (side <= 0) back = 1;
      }
    }
    double ior = t->refract ? t->ior : 1.0;
    for (int side = 0; side < 2; side++) {
      if ((side == 0 && !front) || (side == 1 && !back)) continue;
      /* Entering from the front: eta_i = 1, eta_o = ior; leaving: the reverse. */
      double ei = side == 0 ? 1.0 : ior, eo = side == 0 ? ior : 1.0;
      bpoly a;
      bp_zero(&a);
      bp_muladd(&a, &l1, &s0, ei * ei);
      bp_muladd(&a, &l0, &s1, -(eo * eo));
      bpoly cc = c;
      solved &= solve_system(st, &cc, &a, scale_c, L0 * L0 * L1 * L1 * N * N * ior * ior);
    }
  }
  if (!solved) fallback(st);
}

bbc_result bbc_solver_single(const bbc_path_geometry *g, bbc_vec3 xk,
                             const bbc_solver_options *options, bbc_solution *out, size_t capacity,
                             size_t *count) {
  if (count) *count = 0;
  if (!g || !count || (!out && capacity > 0) || g->length != 1 || !isfinite(xk.x) ||
      !isfinite(xk.y) || !isfinite(xk.z))
    return BBC_ERR_INVALID_ARGUMENT;

  solve_state st;
  memset(&st.stats, 0, sizeof st.stats);
  st.g = g;
  st.xk = xk;
  st.options = options;
  st.count = 0;
  st.swapped = 0;
  st.stats.solves = 1;

  /* The pre-test's halves around the closed form, which is cheaper than the second. */
  const int pretest = !(options && options->no_pretest);
  if (pretest && !coplanar_possible(g, xk, options))
    st.stats.excluded = 1;
  else if (!(options && options->no_closed_form) && solve_flat_mirror(&st))
    ;
  else if (pretest && (!reflection_possible(g, xk, options) || !refraction_possible(g, xk, options)))
    st.stats.excluded = 1;
  else
    solve_polynomials(&st);

  /* Sorted by u1 so the output does not depend on the order roots were found in. */
  for (int i = 1; i < st.count; i++) {
    bbc_solution s = st.found[i];
    int j = i - 1;
    while (j >= 0 && solution_less(&s, &st.found[j])) {
      st.found[j + 1] = st.found[j];
      j--;
    }
    st.found[j + 1] = s;
  }
  size_t n_out = (size_t)st.count < capacity ? (size_t)st.count : capacity;
  for (size_t i = 0; i < n_out; i++) out[i] = st.found[i];
  *count = n_out;
  st.stats.solutions = (uint64_t)st.count;
  if (options && options->stats) add_stats(options->stats, &st.stats);
  return BBC_OK;
}
