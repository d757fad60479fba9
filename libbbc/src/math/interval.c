/* Plain interval arithmetic with outward rounding, the baseline of paper Fig. 4. Every
 * endpoint is one correctly rounded operation pushed outward (rounding_internal.h), so each
 * result contains the exact real result; NaN (inf - inf, 0 * inf) becomes the unbounded end. */
#include "bbc/interval.h"

#include <math.h>

#include "bbc/bernstein.h"
#include "bernstein_internal.h"
#include "rounding_internal.h"

static bbc_interval make_safe(double lo, double hi) {
  bbc_interval r;
  r.lo = (lo == lo) ? lo : -INFINITY;
  r.hi = (hi == hi) ? hi : INFINITY;
  return r;
}

bbc_interval bbc_interval_make(double lo, double hi) {
  if (hi < lo) {
    double t = lo;
    lo = hi;
    hi = t;
  }
  return make_safe(lo, hi);
}

bbc_interval bbc_interval_point(double v) {
  return make_safe(v, v);
}

bbc_interval bbc_interval_entire(void) {
  return make_safe(-INFINITY, INFINITY);
}

bbc_interval bbc_interval_add(bbc_interval a, bbc_interval b) {
  return make_safe(bbc__add_down(a.lo, b.lo), bbc__add_up(a.hi, b.hi));
}

bbc_interval bbc_interval_sub(bbc_interval a, bbc_interval b) {
  return make_safe(bbc__sub_down(a.lo, b.hi), bbc__sub_up(a.hi, b.lo));
}

bbc_interval bbc_interval_neg(bbc_interval a) {
  return make_safe(-a.hi, -a.lo);
}

static double min4(double a, double b, double c, double d) {
  double m = a;
  if (b < m || b != b) m = b;
  if (c < m || c != c) m = c;
  if (d < m || d != d) m = d;
  return m;
}

static double max4(double a, double b, double c, double d) {
  double m = a;
  if (b > m || b != b) m = b;
  if (c > m || c != c) m = c;
  if (d > m || d != d) m = d;
  return m;
}

bbc_interval bbc_interval_mul(bbc_interval a, bbc_interval b) {
  double p0 = a.lo * b.lo, p1 = a.lo * b.hi, p2 = a.hi * b.lo, p3 = a.hi * b.hi;
  /* 0 * inf: the factor 0 is exact and wins (the limit of x * y over the box is finite
   * there), so a NaN product is replaced by 0 before the hull is taken. */
  if (p0 != p0) p0 = 0.0;
  if (p1 != p1) p1 = 0.0;
  if (p2 != p2) p2 = 0.0;
  if (p3 != p3) p3 = 0.0;
  return make_safe(bbc__down(min4(p0, p1, p2, p3)), bbc__up(max4(p0, p1, p2, p3)));
}

bbc_interval bbc_interval_scale(bbc_interval a, double s) {
  return bbc_interval_mul(a, bbc_interval_point(s));
}

bbc_interval bbc_interval_div(bbc_interval a, bbc_interval b) {
  if (!(b.lo > 0.0 || b.hi < 0.0)) return bbc_interval_entire(); /* 0 in b, or NaN */
  double q0 = a.lo / b.lo, q1 = a.lo / b.hi, q2 = a.hi / b.lo, q3 = a.hi / b.hi;
  /* inf / inf: both infinite quotients mean the numerator is unbounded; be conservative. */
  if (q0 != q0 || q1 != q1 || q2 != q2 || q3 != q3) return bbc_interval_entire();
  return make_safe(bbc__down(min4(q0, q1, q2, q3)), bbc__up(max4(q0, q1, q2, q3)));
}

bbc_interval bbc_interval_sqr(bbc_interval a) {
  double l = fabs(a.lo), h = fabs(a.hi);
  double big = l > h ? l : h;
  double small = (a.lo <= 0.0 && a.hi >= 0.0) ? 0.0 : (l < h ? l : h);
  double lo = small == 0.0 ? 0.0 : bbc__mul_down(small, small);
  if (lo < 0.0) lo = 0.0;
  return make_safe(lo, bbc__mul_up(big, big));
}

bbc_interval bbc_interval_sqrt(bbc_interval a) {
  double l = a.lo > 0.0 ? a.lo : 0.0, h = a.hi > 0.0 ? a.hi : 0.0;
  double lo = l == 0.0 ? 0.0 : bbc__down(sqrt(l));
  if (lo < 0.0) lo = 0.0;
  return make_safe(lo, bbc__up(sqrt(h)));
}

bbc_interval bbc_interval_hull(bbc_interval a, bbc_interval b) {
  return make_safe(a.lo < b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi);
}

double bbc_interval_width(bbc_interval a) {
  return bbc__sub_up(a.hi, a.lo);
}

int bbc_interval_contains(bbc_interval a, double v) {
  return a.lo <= v && v <= a.hi;
}

bbc_ivec3 bbc_ivec3_point(bbc_vec3 v) {
  bbc_ivec3 r = {bbc_interval_point(v.x), bbc_interval_point(v.y), bbc_interval_point(v.z)};
  return r;
}

bbc_ivec3 bbc_ivec3_add(bbc_ivec3 a, bbc_ivec3 b) {
  bbc_ivec3 r = {bbc_interval_add(a.x, b.x), bbc_interval_add(a.y, b.y),
                 bbc_interval_add(a.z, b.z)};
  return r;
}

bbc_ivec3 bbc_ivec3_sub(bbc_ivec3 a, bbc_ivec3 b) {
  bbc_ivec3 r = {bbc_interval_sub(a.x, b.x), bbc_interval_sub(a.y, b.y),
                 bbc_interval_sub(a.z, b.z)};
  return r;
}

bbc_ivec3 bbc_ivec3_scale(bbc_interval s, bbc_ivec3 v) {
  bbc_ivec3 r = {bbc_interval_mul(s, v.x), bbc_interval_mul(s, v.y), bbc_interval_mul(s, v.z)};
  return r;
}

bbc_interval bbc_ivec3_dot(bbc_ivec3 a, bbc_ivec3 b) {
  return bbc_interval_add(bbc_interval_add(bbc_interval_mul(a.x, b.x), bbc_interval_mul(a.y, b.y)),
                          bbc_interval_mul(a.z, b.z));
}

bbc_ivec3 bbc_ivec3_cross(bbc_ivec3 a, bbc_ivec3 b) {
  bbc_ivec3 r = {bbc_interval_sub(bbc_interval_mul(a.y, b.z), bbc_interval_mul(a.z, b.y)),
                 bbc_interval_sub(bbc_interval_mul(a.z, b.x), bbc_interval_mul(a.x, b.z)),
                 bbc_interval_sub(bbc_interval_mul(a.x, b.y), bbc_interval_mul(a.y, b.x))};
  return r;
}

/* x^k over [lo, hi] within [0, 1] (monotone), by repeated outward-rounded products. */
static bbc_interval pow_unit(double lo, double hi, int k) {
  double l = 1.0, h = 1.0;
  for (int i = 0; i < k; i++) {
    l = bbc__mul_down(l, lo);
    h = bbc__mul_up(h, hi);
  }
  if (l < 0.0) l = 0.0;
  return make_safe(l, h);
}

bbc_interval bbc_interval_eval_poly(const bbc_poly *p, const bbc_interval box[BBC_POLY_MAX_AXES]) {
  if (!p || !p->coef || !box) return bbc_interval_entire();
  /* Per axis, the interval of each basis function C(n,i) X^i (1-X)^(n-i) over box[j]. */
  bbc_interval basis[BBC_POLY_MAX_AXES][BBC_POLY_MAX_DEGREE + 1];
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++) {
    int n = p->deg[j];
    if (n > BBC_POLY_MAX_DEGREE) return bbc_interval_entire();
    if (n == 0) continue;
    double xl = box[j].lo > 0.0 ? box[j].lo : 0.0, xh = box[j].hi < 1.0 ? box[j].hi : 1.0;
    if (!(xl <= xh)) return bbc_interval_entire();
    double yl = bbc__sub_down(1.0, xh), yh = bbc__sub_up(1.0, xl);
    if (yl < 0.0) yl = 0.0;
    const double *row = bbc__binomial_row(n);
    for (int i = 0; i <= n; i++) {
      /* row[i] is the binomial rounded to nearest; widen it before use. */
      bbc_interval c = make_safe(i == 0 || i == n ? 1.0 : bbc__down(row[i]),
                                 i == 0 || i == n ? 1.0 : bbc__up(row[i]));
      basis[j][i] =
          bbc_interval_mul(c, bbc_interval_mul(pow_unit(xl, xh, i), pow_unit(yl, yh, n - i)));
    }
  }
  size_t size = bbc__size(p->deg);
  int idx[BBC_POLY_MAX_AXES] = {0};
  bbc_interval sum = bbc_interval_point(0.0);
  for (size_t i = 0; i < size; i++) {
    bbc_interval term = bbc_interval_point(p->coef[i]);
    for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
      if (p->deg[j]) term = bbc_interval_mul(term, basis[j][idx[j]]);
    sum = bbc_interval_add(sum, term);
    for (int j = BBC_POLY_MAX_AXES - 1; j >= 0; j--) {
      if (p->deg[j] == 0) continue;
      if (idx[j] < p->deg[j]) {
        idx[j]++;
        break;
      }
      idx[j] = 0;
    }
  }
  double e = bbc__radius(p->err);
  return make_safe(bbc__sub_down(sum.lo, e), bbc__add_up(sum.hi, e));
}
