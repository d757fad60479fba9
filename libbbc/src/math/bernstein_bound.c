/* Range bounds of Bernstein polynomials and of their ratios (paper Eq. 3, DESIGN 3.1).
 *
 * The exact polynomial P = sum_i P_i B_i has |P_i - c_i| <= err for the stored c_i. Since the
 * B_i are non-negative and sum to 1 on the box, P(x) lies in [min_i P_i, max_i P_i], hence in
 * [min c - err, max c + err]. For a ratio, each exact coefficient pair lies in the intervals
 * [p_i - e_p, p_i + e_p] and [q_i - e_q, q_i + e_q]; when every q interval excludes 0 with
 * one sign, P/Q at any point is a weighted mean of the ratios P_i/Q_i with positive weights
 * Q_i B_i / Q, so the hull of the interval quotients encloses it (Narkawicz et al. 2012). All
 * endpoints are rounded outward (rounding_internal.h). */
#include "bbc/bernstein.h"

#include <float.h>
#include <math.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "bernstein_internal.h"
#include "rounding_internal.h"

#define NAX BBC_POLY_MAX_AXES

static bbc_range range_unbounded(void) {
  bbc_range r;
  r.kind = BBC_RANGE_UNBOUNDED;
  r.lo = -INFINITY;
  r.hi = INFINITY;
  return r;
}

bbc_interval bbc_poly_bound(const bbc_poly *p) {
  bbc_interval whole = {-INFINITY, INFINITY};
  if (!p || !p->coef) return whole;
  size_t n = bbc__size(p->deg);
  double e = bbc__radius(p->err);
  if (!(e < INFINITY)) return whole;
  double lo = p->coef[0], hi = p->coef[0];
  size_t i = 0;
#ifdef __SSE2__
  /* Two lanes at a time; the extremes of finite values do not depend on the order. */
  {
    const __m128d absmask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
    const __m128d inf = _mm_set1_pd(INFINITY);
    __m128d vlo = _mm_set1_pd(lo), vhi = vlo, finite = _mm_cmpeq_pd(vlo, vlo);
    for (; i + 2 <= n; i += 2) {
      __m128d c = _mm_loadu_pd(p->coef + i);
      finite = _mm_and_pd(finite, _mm_cmplt_pd(_mm_and_pd(c, absmask), inf));
      vlo = _mm_min_pd(vlo, c);
      vhi = _mm_max_pd(vhi, c);
    }
    if (_mm_movemask_pd(finite) != 3) return whole;
    double l[2], h[2];
    _mm_storeu_pd(l, vlo);
    _mm_storeu_pd(h, vhi);
    lo = l[0] < l[1] ? l[0] : l[1];
    hi = h[0] > h[1] ? h[0] : h[1];
  }
#endif
  for (; i < n; i++) {
    double c = p->coef[i];
    if (!(c > -INFINITY && c < INFINITY)) return whole; /* inf or NaN */
    if (c < lo) lo = c;
    if (c > hi) hi = c;
  }
  bbc_interval r;
  r.lo = bbc__sub_down(lo, e);
  r.hi = bbc__add_up(hi, e);
  return r;
}

int bbc_range_contains(const bbc_range *r, double v) {
  if (!r) return 0;
  switch (r->kind) {
    case BBC_RANGE_BOUNDED:
      return r->lo <= v && v <= r->hi;
    case BBC_RANGE_COMPLEMENT:
      return !(r->lo < v && v < r->hi);
    default:
      return 1;
  }
}

/* The two loops below work on four coefficients at a time without branches, the special
 * cases of outward rounding selected after the arithmetic; they are compiled for AVX2
 * too and chosen at load time where the processor has it (no fused multiply-add:
 * -ffp-contract=off). Each coefficient goes through the same operations as in a plain
 * loop, so the results are the same doubles. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(BBC_NO_CLONES)
#define BBC__BOUND_KERNEL __attribute__((noinline, target_clones("avx2", "default")))
#else
#define BBC__BOUND_KERNEL __attribute__((noinline))
#endif

/* (The helpers are always inlined, at -O0 too, so that each clone has its own copy: the
 * warning about passing AVX vectors between functions compiled without AVX does not
 * apply; GCC gives it at the end of the file. A call to a helper of the default target
 * from the AVX2 clone, as -O0 made, passes the vectors in another way and crashed.) */
#pragma GCC diagnostic ignored "-Wpsabi"
/* Four lanes of doubles (GCC's vector extension; two SSE2 registers without AVX2) and
 * their masks. */
typedef double v4d __attribute__((vector_size(32)));
typedef long long v4m __attribute__((vector_size(32)));

static inline __attribute__((always_inline)) v4d v4_select(v4m mask, v4d a, v4d b) {
  return (v4d)(((v4m)a & mask) | ((v4m)b & ~mask));
}
static inline __attribute__((always_inline)) v4d v4_splat(double x) {
  return (v4d){x, x, x, x};
}
static inline __attribute__((always_inline)) v4d v4_down(v4d x) {
  const v4d t = x - ((v4d)((v4m)x & 0x7fffffffffffffffLL) * 0x1p-51 + BBC__ETA);
  const v4d r = v4_select(x > v4_splat(-INFINITY), t, x);
  return v4_select(x == v4_splat(INFINITY), v4_splat(DBL_MAX), r);
}
static inline __attribute__((always_inline)) v4d v4_up(v4d x) {
  const v4d t = x + ((v4d)((v4m)x & 0x7fffffffffffffffLL) * 0x1p-51 + BBC__ETA);
  const v4d r = v4_select(x < v4_splat(INFINITY), t, x);
  return v4_select(x == v4_splat(-INFINITY), v4_splat(-DBL_MAX), r);
}

/* 1 when every coefficient interval [c - e, c + e] is strictly positive, -1 when strictly
 * negative, 0 otherwise (or when something is not finite). With e = 0 the coefficient is
 * exact and needs no rounding allowance. Four coefficients at a time (rounded as
 * bbc__sub_down and bbc__add_up do), in blocks of 64, stopping after a block where both
 * signs have failed. */
static BBC__BOUND_KERNEL int coefficient_sign(const double *c, size_t n, double e) {
  if (!(e < INFINITY)) return 0;
  const v4d ve = v4_splat(e), zero = v4_splat(0.0);
  const v4m exact = e == 0.0 ? (v4m){-1, -1, -1, -1} : (v4m){0, 0, 0, 0};
  v4m pos = {-1, -1, -1, -1}, neg = pos;
  size_t i = 0;
  while (i + 4 <= n) {
    const size_t block = n - i < 64 ? n - i : 64;
    for (size_t k = 0; k + 4 <= block; k += 4, i += 4) {
      v4d x;
      memcpy(&x, c + i, sizeof x);
      pos &= v4_select(exact, x, v4_down(x - ve)) > zero;
      neg &= v4_select(exact, x, v4_up(x + ve)) < zero;
    }
    if (!(pos[0] & pos[1] & pos[2] & pos[3]) && !(neg[0] & neg[1] & neg[2] & neg[3])) return 0;
  }
  int p = (pos[0] & pos[1] & pos[2] & pos[3]) != 0, q = (neg[0] & neg[1] & neg[2] & neg[3]) != 0;
  for (; i < n && (p || q); i++) {
    double lo = e == 0.0 ? c[i] : bbc__sub_down(c[i], e);
    double hi = e == 0.0 ? c[i] : bbc__add_up(c[i], e);
    if (!(lo > 0.0)) p = 0;
    if (!(hi < 0.0)) q = 0;
  }
  if (p) return 1;
  if (q) return -1;
  return 0;
}

/* The hull of the interval quotients [num_i +- en] / [den_i +- ed] over all i, where every
 * denominator interval has sign `sign` (non-zero) and excludes 0. Flipping both signs for
 * negative denominators leaves the quotient alone, so only positive denominators need the
 * case analysis: for D = [dl, dh] with dl > 0, N / D = [nl / (nl >= 0 ? dh : dl),
 * nh / (nh >= 0 ? dl : dh)]. Returns 0 when a quotient is not finite.
 * Exact operands (radius 0) and exact zero quotients are kept exact, so that a zero
 * coefficient gives the ratio 0 itself (the half-line cases of the reciprocal). Four
 * coefficients at a time, each through the operations of the scalar tail; a NaN
 * quotient is passed over (q < lo fails) in both, and the extremes of the others do not
 * depend on the order. */
static BBC__BOUND_KERNEL int ratio_hull(const double *num, const double *den, size_t n,
                                        double en, double ed, int sign, double *lo_out,
                                        double *hi_out) {
  const double s = (double)sign;
  const int exact_n = en == 0.0, exact_d = ed == 0.0;
  const v4m all_n = exact_n ? (v4m){-1, -1, -1, -1} : (v4m){0, 0, 0, 0};
  const v4m all_d = exact_d ? (v4m){-1, -1, -1, -1} : (v4m){0, 0, 0, 0};
  const v4d vs = v4_splat(s), ven = v4_splat(en), ved = v4_splat(ed), zero = v4_splat(0.0);
  v4d vlo = v4_splat(INFINITY), vhi = v4_splat(-INFINITY);
  size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    v4d a, b;
    memcpy(&a, num + i, sizeof a);
    memcpy(&b, den + i, sizeof b);
    const v4d nm = vs * a, dm = vs * b; /* exact sign flips */
    const v4d nl = v4_select(all_n, nm, v4_down(nm - ven)), nh = v4_select(all_n, nm, v4_up(nm + ven));
    const v4d dl = v4_select(all_d, dm, v4_down(dm - ved)), dh = v4_select(all_d, dm, v4_up(dm + ved));
    const v4d l = v4_down(nl / v4_select(nl >= zero, dh, dl));
    const v4d h = v4_up(nh / v4_select(nh >= zero, dl, dh));
    const v4d ql = v4_select(nl == zero, zero, l), qh = v4_select(nh == zero, zero, h);
    vlo = v4_select(ql < vlo, ql, vlo);
    vhi = v4_select(qh > vhi, qh, vhi);
  }
  double lo = INFINITY, hi = -INFINITY;
  for (int k = 0; k < 4; k++) {
    if (vlo[k] < lo) lo = vlo[k];
    if (vhi[k] > hi) hi = vhi[k];
  }
  for (; i < n; i++) {
    double nm = s * num[i], dm = s * den[i];
    double nl = exact_n ? nm : bbc__sub_down(nm, en), nh = exact_n ? nm : bbc__add_up(nm, en);
    double dl = exact_d ? dm : bbc__sub_down(dm, ed), dh = exact_d ? dm : bbc__add_up(dm, ed);
    double ql = nl == 0.0 ? 0.0 : bbc__div_down(nl, nl >= 0.0 ? dh : dl);
    double qh = nh == 0.0 ? 0.0 : bbc__div_up(nh, nh >= 0.0 ? dl : dh);
    if (ql < lo) lo = ql;
    if (qh > hi) hi = qh;
  }
  if (!(lo > -INFINITY && hi < INFINITY)) return 0; /* also rejects NaN */
  *lo_out = lo;
  *hi_out = hi;
  return 1;
}

bbc_result bbc_rational_bound(bbc_arena *arena, const bbc_poly *p, const bbc_poly *q,
                              bbc_range *out) {
  if (!out || !p || !p->coef || !q || !q->coef) return BBC_ERR_INVALID_ARGUMENT;
  unsigned char deg[NAX];
  for (int j = 0; j < NAX; j++) {
    if (p->deg[j] > BBC_POLY_MAX_DEGREE || q->deg[j] > BBC_POLY_MAX_DEGREE)
      return BBC_ERR_INVALID_ARGUMENT;
    deg[j] = p->deg[j] > q->deg[j] ? p->deg[j] : q->deg[j];
  }
  size_t n = bbc__size(deg);
  size_t mark = bbc_arena_mark(arena);
  const double *pc = p->coef, *qc = q->coef;
  double ep = bbc__radius(p->err), eq = bbc__radius(q->err);
  /* Eq. 3 needs both in the same degree; elevation keeps the exact polynomials and adds its
   * rounding to the radii. */
  if (memcmp(p->deg, deg, NAX) != 0) {
    double *t = (double *)bbc_arena_alloc(arena, n * sizeof(double));
    if (!t) return BBC_ERR_OUT_OF_MEMORY;
    bbc_result r = bbc__elevate_into(arena, p, deg, t, &ep);
    if (r != BBC_OK) {
      bbc_arena_reset(arena, mark);
      return r;
    }
    pc = t;
  }
  if (memcmp(q->deg, deg, NAX) != 0) {
    double *t = (double *)bbc_arena_alloc(arena, n * sizeof(double));
    if (!t) {
      bbc_arena_reset(arena, mark);
      return BBC_ERR_OUT_OF_MEMORY;
    }
    bbc_result r = bbc__elevate_into(arena, q, deg, t, &eq);
    if (r != BBC_OK) {
      bbc_arena_reset(arena, mark);
      return r;
    }
    qc = t;
  }

  bbc_range res = range_unbounded();
  double lo, hi;
  int qs = coefficient_sign(qc, n, eq);
  if (qs != 0) {
    /* Eq. 3 directly. */
    if (ratio_hull(pc, qc, n, ep, eq, qs, &lo, &hi)) {
      res.kind = BBC_RANGE_BOUNDED;
      res.lo = lo;
      res.hi = hi;
    }
  } else {
    int ps = coefficient_sign(pc, n, ep);
    /* The reciprocal (Sec. 4.1): y = q/p lies in [L, H]; p/q = 1/y wherever q != 0, and
     * 1/y is decreasing on each side of 0. */
    if (ps != 0 && ratio_hull(qc, pc, n, eq, ep, ps, &lo, &hi)) {
      if (lo > 0.0 || hi < 0.0) {
        /* y keeps one sign: 1/y in [1/H, 1/L]. (Unusual: q then has one sign although its
         * coefficients failed the test.) */
        res.kind = BBC_RANGE_BOUNDED;
        res.lo = bbc__div_down(1.0, hi);
        res.hi = bbc__div_up(1.0, lo);
      } else if (lo < 0.0 && hi > 0.0) {
        /* y in [L, 0) gives 1/y <= 1/L; y in (0, H] gives 1/y >= 1/H. The excluded open
         * interval (1/L, 1/H) is shrunk: its ends are rounded towards its inside. */
        res.kind = BBC_RANGE_COMPLEMENT;
        res.lo = bbc__div_up(1.0, lo);
        res.hi = bbc__div_down(1.0, hi);
      } else if (lo == 0.0 && hi > 0.0) {
        res.kind = BBC_RANGE_COMPLEMENT; /* y in (0, H]: p/q >= 1/H */
        res.lo = -INFINITY;
        res.hi = bbc__div_down(1.0, hi);
      } else if (lo < 0.0 && hi == 0.0) {
        res.kind = BBC_RANGE_COMPLEMENT; /* y in [L, 0): p/q <= 1/L */
        res.lo = bbc__div_up(1.0, lo);
        res.hi = INFINITY;
      }
      /* lo == hi == 0: q vanishes wherever it is defined; nothing is known. */
      if (res.kind == BBC_RANGE_COMPLEMENT && !(res.lo < res.hi)) res = range_unbounded();
    }
  }
  bbc_arena_reset(arena, mark);
  *out = res;
  return BBC_OK;
}
