/* Exact orient3d on float inputs by expansion arithmetic (Shewchuk 1997, "Adaptive
 * precision floating-point arithmetic and fast robust geometric predicates"): every
 * double below is an exact sum of non-overlapping components, so the determinant's sign
 * is that of its largest non-zero component. Differences of floats are exact as
 * two-component expansions; a product of expansions is the sum of the first scaled by
 * each component of the second. Sizes stay small (at most 192 components), and float
 * inputs keep every product and error term far from overflow and underflow. */
#include "orient_internal.h"

#include <math.h>

#define MAX_TERMS 256

/* x + y = a + b exactly, x = fl(a + b). */
static void two_sum(double a, double b, double *x, double *y) {
  double s = a + b, bv = s - a, av = s - bv;
  *x = s;
  *y = (a - av) + (b - bv);
}

/* x + y = a * b exactly (fma gives the rounding error of the product). */
static void two_product(double a, double b, double *x, double *y) {
  double p = a * b;
  *x = p;
  *y = fma(a, b, -p);
}

/* h = e + f (Shewchuk's Expansion-Sum, zero components dropped); returns |h|. */
static int expansion_sum(const double *e, int ne, const double *f, int nf, double *h) {
  double tmp[MAX_TERMS];
  int n = 0;
  for (int i = 0; i < ne; i++) tmp[n++] = e[i];
  for (int j = 0; j < nf; j++) {
    double q = f[j];
    int m = 0;
    for (int i = 0; i < n; i++) {
      double hi, lo;
      two_sum(q, tmp[i], &hi, &lo);
      q = hi;
      if (lo != 0) tmp[m++] = lo;
    }
    tmp[m++] = q;
    n = m;
  }
  for (int i = 0; i < n; i++) h[i] = tmp[i];
  return n;
}

/* h = e * b (Scale-Expansion); returns |h|. */
static int scale_expansion(const double *e, int ne, double b, double *h) {
  int n = 0;
  double q, lo;
  if (ne == 0) return 0;
  two_product(e[0], b, &q, &lo);
  if (lo != 0) h[n++] = lo;
  for (int i = 1; i < ne; i++) {
    double p_hi, p_lo, s, s_lo;
    two_product(e[i], b, &p_hi, &p_lo);
    two_sum(q, p_lo, &s, &s_lo);
    if (s_lo != 0) h[n++] = s_lo;
    two_sum(p_hi, s, &q, &s_lo);
    if (s_lo != 0) h[n++] = s_lo;
  }
  if (q != 0 || n == 0) h[n++] = q;
  return n;
}

/* h = e * f; returns |h|. */
static int expansion_product(const double *e, int ne, const double *f, int nf, double *h) {
  double acc[MAX_TERMS], part[MAX_TERMS], next[MAX_TERMS];
  int n = 0;
  for (int j = 0; j < nf; j++) {
    int np = scale_expansion(e, ne, f[j], part);
    n = expansion_sum(acc, n, part, np, next);
    for (int i = 0; i < n; i++) acc[i] = next[i];
  }
  for (int i = 0; i < n; i++) h[i] = acc[i];
  return n;
}

static int negate(double *e, int n) {
  for (int i = 0; i < n; i++) e[i] = -e[i];
  return n;
}

int bbc__orient3d(const float a[3], const float b[3], const float c[3], const float d[3]) {
  double u[3][2], v[3][2], w[3][2];
  for (int k = 0; k < 3; k++) {
    two_sum(b[k], -(double)a[k], &u[k][1], &u[k][0]);
    two_sum(c[k], -(double)a[k], &v[k][1], &v[k][0]);
    two_sum(d[k], -(double)a[k], &w[k][1], &w[k][0]);
  }
  /* det = u . (v x w), the cross product's components first. */
  double total[MAX_TERMS];
  int nt = 0;
  for (int k = 0; k < 3; k++) {
    int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    double p[8], q[8], cross[16], term[64], sum[MAX_TERMS];
    int np = expansion_product(v[k1], 2, w[k2], 2, p);
    int nq = negate(q, expansion_product(v[k2], 2, w[k1], 2, q));
    int nc = expansion_sum(p, np, q, nq, cross);
    int nm = expansion_product(cross, nc, u[k], 2, term);
    nt = expansion_sum(total, nt, term, nm, sum);
    for (int i = 0; i < nt; i++) total[i] = sum[i];
  }
  for (int i = nt - 1; i >= 0; i--)
    if (total[i] != 0) return total[i] > 0 ? 1 : -1;
  return 0;
}
