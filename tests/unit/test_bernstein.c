/* Tests of the Bernstein engine (bbc/bernstein.h) against independent oracles: expressions
 * evaluated directly in long double from their explicit form, exact rational arithmetic
 * (rational_oracle.h), and closed-form facts. Nothing here compares the library with its
 * own earlier output.
 *
 * Random families sample harness_scale(ci, full) points; BBC_TEST_FULL=1 runs at least 10^6
 * points per family. A sampled value counts as outside a bound only when it is outside by
 * more than the oracle's own rounding allowance (2^-56 times the sum of the magnitudes of
 * the terms it added), far below the library's outward widening of about 1e-16. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bernstein.h"
#include "bbc/interval.h"
#include "harness.h"
#include "rational_oracle.h"

#define NAX BBC_POLY_MAX_AXES

/* ---- Shared helpers ------------------------------------------------------------------- */

static unsigned char arena_buffer[16u << 20];

static bbc_arena fresh_arena(void) {
  bbc_arena a;
  bbc_arena_init(&a, arena_buffer, sizeof arena_buffer);
  return a;
}

typedef struct rng {
  uint64_t s;
} rng;

static uint64_t rng_next(rng *r) {
  uint64_t z = (r->s += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

static double rng_unit(rng *r) {
  return (double)(rng_next(r) >> 11) * 0x1p-53;
}
static int rng_int(rng *r, int lo, int hi) {
  return lo + (int)(rng_next(r) % (uint64_t)(hi - lo + 1));
}
/* A dyadic number k / 2^frac_bits in [-limit, limit]: exact in double, so that the inputs the
 * library sees are exactly the inputs the oracle uses. */
static double rng_dyadic(rng *r, double limit, int frac_bits) {
  long long range = (long long)(limit * (double)(1ll << frac_bits));
  long long k = (long long)(rng_next(r) % (uint64_t)(2 * range + 1)) - range;
  return ldexp((double)k, -frac_bits);
}
/* A point in [lo, hi], sometimes exactly at an end (bounds are often tight at corners). */
static double rng_in(rng *r, double lo, double hi) {
  int pick = rng_int(r, 0, 7);
  if (pick == 0) return lo;
  if (pick == 1) return hi;
  double v = lo + (hi - lo) * rng_unit(r);
  return v < lo ? lo : (v > hi ? hi : v);
}

/* Two geometric axes claimed the way a piece's (s, t) are. */
typedef struct axes2 {
  bbc_space space;
  int x, y;
} axes2;

static axes2 make_axes(void) {
  axes2 a;
  memset(&a, 0, sizeof a);
  bbc_space_add_axis(&a.space, BBC_AXIS_GEOMETRIC, &a.x);
  bbc_space_add_axis(&a.space, BBC_AXIS_GEOMETRIC, &a.y);
  return a;
}

static void point2(const axes2 *ax, double x, double y, double out[NAX]) {
  for (int j = 0; j < NAX; j++) out[j] = 0.0;
  out[ax->x] = x;
  out[ax->y] = y;
}

static double maxabs_coef(const bbc_poly *p) {
  double m = 0.0;
  size_t n = bbc_poly_size(p);
  for (size_t i = 0; i < n; i++)
    if (fabs(p->coef[i]) > m) m = fabs(p->coef[i]);
  return m;
}

static int degree_sum(const bbc_poly *p) {
  int s = 0;
  for (int j = 0; j < NAX; j++) s += p->deg[j];
  return s;
}

/* Slack for an oracle value built from terms of total magnitude mag. */
static long double oracle_slack(long double mag) {
  return mag * 0x1p-56L;
}

static int in_interval(bbc_interval b, long double v, long double slack) {
  return (long double)b.lo - slack <= v && v <= (long double)b.hi + slack;
}

/* ---- Expressions: sums of products of affine factors in two variables ------------------ */

typedef struct affine2 {
  double a, b, c; /* a + b x + c y */
} affine2;

#define EXPR_TERMS 4
#define EXPR_FACTORS 16

typedef struct expr2 {
  int nterms;
  int nf[EXPR_TERMS];
  affine2 f[EXPR_TERMS][EXPR_FACTORS];
} expr2;

static void expr_random(rng *r, expr2 *e, int max_terms, int max_factors, int frac_bits) {
  memset(e, 0, sizeof *e);
  e->nterms = rng_int(r, 1, max_terms);
  for (int t = 0; t < e->nterms; t++) {
    e->nf[t] = rng_int(r, 1, max_factors);
    for (int k = 0; k < e->nf[t]; k++) {
      affine2 *f = &e->f[t][k];
      f->a = rng_dyadic(r, 2.0, frac_bits);
      f->b = rng_int(r, 0, 3) ? rng_dyadic(r, 2.0, frac_bits) : 0.0;
      f->c = rng_int(r, 0, 3) ? rng_dyadic(r, 2.0, frac_bits) : 0.0;
    }
  }
}

/* Adds the constant term `v` as a term of its own. */
static void expr_add_constant(expr2 *e, double v) {
  int t = e->nterms++;
  e->nf[t] = 1;
  e->f[t][0].a = v;
  e->f[t][0].b = e->f[t][0].c = 0.0;
}

static long double expr_eval(const expr2 *e, double x, double y, long double *mag) {
  long double s = 0.0L, m = 0.0L;
  for (int t = 0; t < e->nterms; t++) {
    long double p = 1.0L, pm = 1.0L;
    for (int k = 0; k < e->nf[t]; k++) {
      const affine2 *f = &e->f[t][k];
      p *= (long double)f->a + (long double)f->b * x + (long double)f->c * y;
      pm *= fabsl(f->a) + fabsl((long double)f->b * x) + fabsl((long double)f->c * y);
    }
    s += p;
    m += pm;
  }
  if (mag) *mag = m;
  return s;
}

/* d/dx (wrt = 0) or d/dy (wrt = 1) by the product rule. */
static long double expr_deriv(const expr2 *e, double x, double y, int wrt, long double *mag) {
  long double s = 0.0L, m = 0.0L;
  for (int t = 0; t < e->nterms; t++) {
    for (int k = 0; k < e->nf[t]; k++) {
      const affine2 *fk = &e->f[t][k];
      long double p = wrt ? fk->c : fk->b, pm = fabsl(p);
      for (int l = 0; l < e->nf[t]; l++) {
        if (l == k) continue;
        const affine2 *f = &e->f[t][l];
        p *= (long double)f->a + (long double)f->b * x + (long double)f->c * y;
        pm *= fabsl(f->a) + fabsl((long double)f->b * x) + fabsl((long double)f->c * y);
      }
      s += p;
      m += pm;
    }
  }
  if (mag) *mag = m;
  return s;
}

static bbc_result expr_build(bbc_arena *A, const expr2 *e, const axes2 *ax, bbc_poly *out) {
  bbc_poly sum;
  for (int t = 0; t < e->nterms; t++) {
    bbc_poly prod;
    for (int k = 0; k < e->nf[t]; k++) {
      double grad[NAX] = {0};
      grad[ax->x] = e->f[t][k].b;
      grad[ax->y] = e->f[t][k].c;
      bbc_poly fac;
      bbc_result r = bbc_poly_affine(A, &fac, e->f[t][k].a, grad);
      if (r != BBC_OK) return r;
      if (k == 0) {
        prod = fac;
      } else {
        r = bbc_poly_mul(A, &prod, &prod, &fac);
        if (r != BBC_OK) return r;
      }
    }
    if (t == 0) {
      sum = prod;
    } else {
      bbc_result r = bbc_poly_add(A, &sum, &sum, &prod);
      if (r != BBC_OK) return r;
    }
  }
  *out = sum;
  return BBC_OK;
}

/* A random sub-box [x0, x1] x [y0, y1] of the unit square, of random size. */
static void random_box(rng *r, double lo[NAX], double hi[NAX], const axes2 *ax) {
  for (int j = 0; j < NAX; j++) {
    lo[j] = 0.0;
    hi[j] = 1.0;
  }
  for (int k = 0; k < 2; k++) {
    int j = k ? ax->y : ax->x;
    double w = ldexp(1.0, -rng_int(r, 0, 8)) * (0.5 + 0.5 * rng_unit(r));
    double a = (1.0 - w) * rng_unit(r);
    lo[j] = a;
    hi[j] = a + w > 1.0 ? 1.0 : a + w;
  }
}

/* ---- Exact small cases ---------------------------------------------------------------- */

TEST(exact_x_times_4_minus_x) {
  /* Paper footnote 2: x (4 - x) on [0, 1] has Bernstein coefficients 0, 2, 3, so the bound
   * is [0, 3], while interval arithmetic gives [0, 1] x [3, 4] = [0, 4]. */
  bbc_arena A = fresh_arena();
  bbc_poly x, four_minus_x, p;
  REQUIRE(bbc_poly_linear(&A, &x, 0, 0.0, 1.0) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &four_minus_x, 0, 4.0, 3.0) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &p, &x, &four_minus_x) == BBC_OK);
  CHECK_INT(p.deg[0], 2);
  /* Exact Bernstein coefficients of 4x - x^2 from the power basis, in rationals. */
  ro_rat power[3] = {ro_int(0), ro_int(4), ro_int(-1)}, bern[3];
  ro_power_to_bernstein_1d(power, 2, bern);
  CHECK(bern[0].num == 0 && bern[1].num == 2 && bern[1].den == 1 && bern[2].num == 3);
  for (int k = 0; k < 3; k++) CHECK(ro_within(bern[k], p.coef[k], p.err));
  bbc_interval b = bbc_poly_bound(&p);
  CHECK(b.lo <= 0.0 && b.lo > -1e-14);
  CHECK(b.hi >= 3.0 && b.hi < 3.0 + 1e-14);
  bbc_interval ia = bbc_interval_mul(bbc_interval_make(0.0, 1.0), bbc_interval_make(3.0, 4.0));
  CHECK(ia.lo <= 0.0 && ia.hi >= 4.0 && ia.hi < 4.0 + 1e-14);
  printf("x(4-x) on [0,1]: bernstein [%.17g, %.17g], interval [%.17g, %.17g]\n", b.lo, b.hi, ia.lo,
         ia.hi);
}

TEST(exact_rational_sign_change) {
  bbc_arena A = fresh_arena();
  bbc_poly p, q, one;
  bbc_range r;
  /* (x + 1) / (x - 1/2): q's coefficients -1/2, 1/2 change sign, p's 1, 2 do not. q/p has
   * coefficients -1/2 and 1/4, so p/q avoids (-2, 4); the true range is (-inf, -2] u [4, inf),
   * so the excluded interval is exactly (-2, 4) and must be returned shrunk, never grown. */
  REQUIRE(bbc_poly_linear(&A, &p, 0, 1.0, 2.0) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &q, 0, -0.5, 0.5) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &p, &q, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_COMPLEMENT);
  CHECK(r.lo >= -2.0 && r.lo < -2.0 + 1e-14);
  CHECK(r.hi <= 4.0 && r.hi > 4.0 - 1e-14);
  CHECK(bbc_range_contains(&r, -2.0) && bbc_range_contains(&r, 4.0));
  CHECK(!bbc_range_contains(&r, 0.0));
  /* The same ratio the other way round: q/p is bounded by [-1/2, 1/4] directly. */
  REQUIRE(bbc_rational_bound(&A, &q, &p, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_BOUNDED);
  CHECK(r.lo <= -0.5 && r.lo > -0.5 - 1e-14 && r.hi >= 0.25 && r.hi < 0.25 + 1e-14);
  /* Both sign-changing: (x - 1/2) / (x - 1/3) is unbounded (pole at 1/3). */
  bbc_poly p2, q2;
  REQUIRE(bbc_poly_linear(&A, &p2, 0, -0.5, 0.5) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &q2, 0, -1.0 / 3.0, 2.0 / 3.0) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &p2, &q2, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_UNBOUNDED);
  /* 1/x on [0, 1]: q has a zero coefficient, q/p in [0, 1], so 1/x >= 1: the half line. */
  REQUIRE(bbc_poly_constant(&A, &one, 1.0) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &q, 0, 0.0, 1.0) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &one, &q, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_COMPLEMENT);
  CHECK(r.lo == -INFINITY && r.hi <= 1.0 && r.hi > 1.0 - 1e-14);
  /* -1/x: the other half line, p/q <= -1. */
  REQUIRE(bbc_poly_linear(&A, &q, 0, 0.0, -1.0) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &one, &q, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_COMPLEMENT);
  CHECK(r.hi == INFINITY && r.lo >= -1.0 && r.lo < -1.0 + 1e-14);
  /* A denominator that is positive but whose degree-2 coefficients change sign:
   * (x - 1/2)^2 + 1/100 has coefficients 0.26, -0.24, 0.26; with p = 1 the reciprocal
   * gives the complement of (1/-0.24, 1/0.26). The true range is [1/0.26, 100]. */
  bbc_poly h, h2, q3;
  REQUIRE(bbc_poly_linear(&A, &h, 0, -0.5, 0.5) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &h2, &h, &h) == BBC_OK);
  REQUIRE(bbc_poly_add_scalar(&A, &q3, &h2, 0.01) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &one, &q3, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_COMPLEMENT);
  CHECK(bbc_range_contains(&r, 100.0) && bbc_range_contains(&r, 1.0 / 0.26));
  /* After one split each half has a positive denominator polynomial in Bernstein form. */
  bbc_poly ql, qr;
  REQUIRE(bbc_poly_split(&A, &q3, 0, &ql, &qr) == BBC_OK);
  REQUIRE(bbc_rational_bound(&A, &one, &ql, &r) == BBC_OK);
  CHECK_INT(r.kind, BBC_RANGE_BOUNDED);
  CHECK(r.lo <= 1.0 / 0.26 && r.hi >= 100.0);
}

/* Random small-integer products checked coefficient by coefficient against the exact
 * Bernstein coefficients: the stored coefficients must be within err of the truth. */
typedef ro_rat ro_poly2[RO_MAXD + 1][RO_MAXD + 1];

static void ro_poly_from_expr(const expr2 *e, int frac_bits, ro_poly2 out, int *ok) {
  memset(out, 0, sizeof(ro_poly2));
  for (int i = 0; i <= RO_MAXD; i++)
    for (int j = 0; j <= RO_MAXD; j++) out[i][j] = ro_int(0);
  for (int t = 0; t < e->nterms; t++) {
    static ro_poly2 prod, next;
    for (int i = 0; i <= RO_MAXD; i++)
      for (int j = 0; j <= RO_MAXD; j++) prod[i][j] = ro_int(i == 0 && j == 0);
    for (int k = 0; k < e->nf[t]; k++) {
      /* Factors are k / 2^frac: exact as rationals through ldexp of integers. */
      long long den = 1ll << frac_bits;
      ro_rat fa = ro_frac((long long)ldexp(e->f[t][k].a, frac_bits), den);
      ro_rat fb = ro_frac((long long)ldexp(e->f[t][k].b, frac_bits), den);
      ro_rat fc = ro_frac((long long)ldexp(e->f[t][k].c, frac_bits), den);
      for (int i = 0; i <= RO_MAXD; i++)
        for (int j = 0; j <= RO_MAXD; j++) {
          ro_rat v = ro_mul(fa, prod[i][j]);
          if (i > 0) v = ro_add(v, ro_mul(fb, prod[i - 1][j]));
          if (j > 0) v = ro_add(v, ro_mul(fc, prod[i][j - 1]));
          next[i][j] = v;
        }
      memcpy(prod, next, sizeof prod);
    }
    for (int i = 0; i <= RO_MAXD; i++)
      for (int j = 0; j <= RO_MAXD; j++) out[i][j] = ro_add(out[i][j], prod[i][j]);
  }
  *ok = 1;
  for (int i = 0; i <= RO_MAXD; i++)
    for (int j = 0; j <= RO_MAXD; j++)
      if (!out[i][j].ok) *ok = 0;
}

/* Substitutes x -> (x + shift) / 2 (shift 0: left half, 1: right half) exactly. */
static void ro_poly_half(ro_poly2 in, int shift, ro_poly2 out) {
  for (int i = 0; i <= RO_MAXD; i++)
    for (int j = 0; j <= RO_MAXD; j++) out[i][j] = ro_int(0);
  for (int i = 0; i <= RO_MAXD; i++) {
    /* ((x + shift)/2)^i = 2^-i sum_k C(i,k) shift^(i-k) x^k */
    for (int k = 0; k <= i; k++) {
      if (!shift && k != i) continue;
      ro_rat w = ro_div(ro_binom(i, k), ro_norm((ro_i128)1 << i, 1));
      for (int j = 0; j <= RO_MAXD; j++) out[k][j] = ro_add(out[k][j], ro_mul(w, in[i][j]));
    }
  }
}

/* The largest |stored - exact| / err seen, for the report: how much of the radius the
 * actual rounding used. */
static double radius_use_max;

/* Checks every coefficient of p (axes x, y) against the power-basis polynomial a. */
static int ro_check_poly(const bbc_poly *p, const axes2 *ax, ro_poly2 a, long *checked) {
  static ro_poly2 bern;
  int nx = p->deg[ax->x], ny = p->deg[ax->y];
  if (nx > RO_MAXD || ny > RO_MAXD) return 0;
  /* The power polynomial must not exceed the stored degree (higher entries zero). */
  for (int i = 0; i <= RO_MAXD; i++)
    for (int j = 0; j <= RO_MAXD; j++)
      if ((i > nx || j > ny) && a[i][j].num != 0) return 0;
  ro_power_to_bernstein_2d(a, nx, ny, bern);
  size_t stride_x = 1, stride_y = 1;
  for (int j = ax->x + 1; j < NAX; j++) stride_x *= (size_t)p->deg[j] + 1;
  for (int j = ax->y + 1; j < NAX; j++) stride_y *= (size_t)p->deg[j] + 1;
  int bad = 0;
  for (int i = 0; i <= nx; i++)
    for (int j = 0; j <= ny; j++) {
      if (!bern[i][j].ok) return bad ? -bad : 0;
      double c = p->coef[(size_t)i * stride_x + (size_t)j * stride_y];
      long double diff =
          fabsl((long double)c - (long double)bern[i][j].num / (long double)bern[i][j].den);
      if (p->err > 0 && diff / p->err > radius_use_max) radius_use_max = (double)(diff / p->err);
      if (!ro_within(bern[i][j], c, p->err)) {
        if (bad < 3)
          fprintf(stderr, "coefficient (%d,%d): stored %.17g exact %.17g err %.3g\n", i, j, c,
                  ro_to_double(bern[i][j]), p->err);
        bad++;
      }
      (*checked)++;
    }
  return -bad;
}

TEST(exact_error_radius) {
  rng r = {101};
  long checked = 0, skipped = 0;
  int bad = 0;
  int cases = (int)harness_scale(150, 3000);
  static ro_poly2 a, h, da;
  for (int c = 0; c < cases; c++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 e;
    /* Short inputs reach higher degrees; 20-bit inputs make the products round. */
    int fb = (c & 1) ? 20 : 8;
    expr_random(&r, &e, 3, fb == 8 ? 7 : 4, fb);
    int ok;
    ro_poly_from_expr(&e, fb, a, &ok);
    bbc_poly p;
    REQUIRE(expr_build(&A, &e, &ax, &p) == BBC_OK);
    if (!ok) {
      skipped++;
      continue;
    }
    int res = ro_check_poly(&p, &ax, a, &checked);
    if (res < 0) bad -= res;
    if (res == 0 && checked == 0) skipped++;
    /* Halves (de Casteljau at 1/2) against exact substitution. */
    bbc_poly left, right;
    REQUIRE(bbc_poly_split(&A, &p, ax.x, &left, &right) == BBC_OK);
    ro_poly_half(a, 0, h);
    res = ro_check_poly(&left, &ax, h, &checked);
    if (res < 0) bad -= res;
    ro_poly_half(a, 1, h);
    res = ro_check_poly(&right, &ax, h, &checked);
    if (res < 0) bad -= res;
    /* Derivative along x against the exact power-basis derivative. */
    bbc_poly d;
    REQUIRE(bbc_poly_derivative(&A, &d, &p, ax.x) == BBC_OK);
    for (int i = 0; i <= RO_MAXD; i++)
      for (int j = 0; j <= RO_MAXD; j++)
        da[i][j] = i < RO_MAXD ? ro_mul(ro_int(i + 1), a[i + 1][j]) : ro_int(0);
    res = ro_check_poly(&d, &ax, da, &checked);
    if (res < 0) bad -= res;
    /* Elevation by 3 on both axes, then a linear combination with dyadic weights. */
    unsigned char deg[NAX];
    memcpy(deg, p.deg, NAX);
    deg[ax.x] += 3;
    deg[ax.y] += 3;
    bbc_poly el;
    REQUIRE(bbc_poly_elevate(&A, &el, &p, deg) == BBC_OK);
    res = ro_check_poly(&el, &ax, a, &checked);
    if (res < 0) bad -= res;
    bbc_poly lc;
    const bbc_poly *terms[2] = {&el, &d};
    const double alpha[2] = {0.75, -1.5};
    REQUIRE(bbc_poly_lincomb(&A, &lc, 2, alpha, terms) == BBC_OK);
    for (int i = 0; i <= RO_MAXD; i++)
      for (int j = 0; j <= RO_MAXD; j++)
        h[i][j] = ro_sub(ro_mul(ro_frac(3, 4), a[i][j]), ro_mul(ro_frac(3, 2), da[i][j]));
    res = ro_check_poly(&lc, &ax, h, &checked);
    if (res < 0) bad -= res;
  }
  printf(
      "exact error radius: %ld coefficients checked, %ld cases skipped (overflow); "
      "largest |error| / err %.3g\n",
      checked, skipped, radius_use_max);
  CHECK_INT(bad, 0);
  CHECK(checked > 1000);
}

/* ---- Single operations in exact arithmetic ------------------------------------------- */

/* Each operation in isolation, on inputs whose coefficients have full mantissas (so that
 * the floating-point operation really rounds) and a deliberately large radius e. The exact
 * result is computed in rationals from the textbook Bernstein formulas, applied to an
 * adversarial "ideal" input c + e s with signs s from a pattern (all +1, all -1,
 * alternating, random): the stored output must lie within the output radius of it. This is
 * the check that catches a missing term in any error-propagation formula. */
typedef struct ro_bpoly {
  int nx, ny;
  ro_rat c[RO_MAXD + 1][RO_MAXD + 1]; /* c[i][j]: i indexes x, j indexes y */
} ro_bpoly;

static size_t lib_index(const bbc_poly *p, const axes2 *ax, int i, int j) {
  size_t sx = 1, sy = 1;
  for (int k = ax->x + 1; k < NAX; k++) sx *= (size_t)p->deg[k] + 1;
  for (int k = ax->y + 1; k < NAX; k++) sy *= (size_t)p->deg[k] + 1;
  return (size_t)i * sx + (size_t)j * sy;
}

/* A coefficient with `bits` significant bits in +-[1/2, 1) times 2^(0..1). */
static double full_mantissa(rng *r, int bits, int positive) {
  uint64_t k = (rng_next(r) >> (64 - bits + 1)) | (1ull << (bits - 1));
  double v = ldexp((double)k, -bits + rng_int(r, 0, 1));
  return (positive || (rng_next(r) & 1)) ? v : -v;
}

static void make_input(bbc_arena *A, const axes2 *ax, rng *r, int nx, int ny, int bits,
                       int positive, double err, int pattern, bbc_poly *p, ro_bpoly *ideal) {
  memset(p, 0, sizeof *p);
  p->deg[ax->x] = (unsigned char)nx;
  p->deg[ax->y] = (unsigned char)ny;
  p->coef = (double *)bbc_arena_alloc(A, bbc_poly_size(p) * sizeof(double));
  p->err = err;
  ideal->nx = nx;
  ideal->ny = ny;
  ro_rat e = ro_from_double(err);
  for (int i = 0; i <= nx; i++)
    for (int j = 0; j <= ny; j++) {
      double v = full_mantissa(r, bits, positive);
      p->coef[lib_index(p, ax, i, j)] = v;
      int sgn = pattern == 0   ? 1
                : pattern == 1 ? -1
                : pattern == 2 ? ((i + j) % 2 ? 1 : -1)
                               : ((rng_next(r) & 1) ? 1 : -1);
      ideal->c[i][j] = ro_add(ro_from_double(v), sgn > 0 ? e : ro_neg(e));
    }
}

static void ro_elev1(const ro_rat *c, int n, int t, ro_rat *out) {
  for (int k = 0; k <= t; k++) {
    ro_rat s = ro_int(0);
    for (int j = 0; j <= n; j++)
      if (j <= k && k - j <= t - n)
        s = ro_add(s, ro_mul(ro_div(ro_mul(ro_binom(n, j), ro_binom(t - n, k - j)), ro_binom(t, k)),
                             c[j]));
    out[k] = s;
  }
}

static void ro_casteljau1(const ro_rat *c, int n, ro_rat t, ro_rat *left, ro_rat *right) {
  ro_rat w[RO_MAXD + 1];
  for (int i = 0; i <= n; i++) w[i] = c[i];
  ro_rat s = ro_sub(ro_int(1), t);
  if (left) left[0] = w[0];
  if (right) right[n] = w[n];
  for (int level = 1; level <= n; level++) {
    for (int i = 0; i <= n - level; i++) w[i] = ro_add(ro_mul(s, w[i]), ro_mul(t, w[i + 1]));
    if (left) left[level] = w[0];
    if (right) right[n - level] = w[n - level];
  }
}

/* Applies a 1-D map along x (axis 0) or y (axis 1). kind: 0 elevate to t, 1 derivative,
 * 2 left part at t, 3 right part at t. */
static void ro_apply(const ro_bpoly *a, int axis, int kind, int target, ro_rat t, ro_bpoly *out) {
  int n = axis ? a->ny : a->nx, m = axis ? a->nx : a->ny;
  int nn = kind == 0 ? target : kind == 1 ? (n > 0 ? n - 1 : 0) : n;
  ro_bpoly r;
  r.nx = axis ? a->nx : nn;
  r.ny = axis ? nn : a->ny;
  for (int o = 0; o <= m; o++) {
    ro_rat line[RO_MAXD + 1], res[RO_MAXD + 1];
    for (int i = 0; i <= n; i++) line[i] = axis ? a->c[o][i] : a->c[i][o];
    if (kind == 0) {
      ro_elev1(line, n, target, res);
    } else if (kind == 1) {
      if (n == 0) res[0] = ro_int(0);
      for (int i = 0; i < n; i++) res[i] = ro_mul(ro_int(n), ro_sub(line[i + 1], line[i]));
    } else {
      ro_casteljau1(line, n, t, kind == 2 ? res : NULL, kind == 3 ? res : NULL);
    }
    for (int i = 0; i <= nn; i++) {
      if (axis)
        r.c[o][i] = res[i];
      else
        r.c[i][o] = res[i];
    }
  }
  *out = r;
}

static void ro_bmul(const ro_bpoly *a, const ro_bpoly *b, ro_bpoly *out) {
  out->nx = a->nx + b->nx;
  out->ny = a->ny + b->ny;
  for (int k = 0; k <= out->nx; k++)
    for (int l = 0; l <= out->ny; l++) {
      ro_rat s = ro_int(0);
      for (int i = 0; i <= a->nx; i++)
        for (int j = 0; j <= a->ny; j++) {
          int i2 = k - i, j2 = l - j;
          if (i2 < 0 || i2 > b->nx || j2 < 0 || j2 > b->ny) continue;
          ro_rat wx = ro_div(ro_mul(ro_binom(a->nx, i), ro_binom(b->nx, i2)), ro_binom(out->nx, k));
          ro_rat wy = ro_div(ro_mul(ro_binom(a->ny, j), ro_binom(b->ny, j2)), ro_binom(out->ny, l));
          s = ro_add(s, ro_mul(ro_mul(wx, wy), ro_mul(a->c[i][j], b->c[i2][j2])));
        }
      out->c[k][l] = s;
    }
}

/* 1: all within err; 0: some coefficient outside; -1: the oracle overflowed. */
static int ro_check_b(const bbc_poly *p, const axes2 *ax, const ro_bpoly *x, int xi_axis,
                      int xi_index) {
  if (p->deg[ax->x] != x->nx || p->deg[ax->y] != x->ny) return 0;
  for (int i = 0; i <= x->nx; i++)
    for (int j = 0; j <= x->ny; j++) {
      if (!x->c[i][j].ok) return -1;
      size_t at = lib_index(p, ax, i, j);
      if (xi_axis >= 0) {
        size_t st = 1;
        for (int k = xi_axis + 1; k < NAX; k++) st *= (size_t)p->deg[k] + 1;
        at += (size_t)xi_index * st;
      }
      if (!ro_within(x->c[i][j], p->coef[at], p->err)) {
        fprintf(stderr, "  (%d,%d): stored %.17g, exact %.17g, err %.3g\n", i, j, p->coef[at],
                ro_to_double(x->c[i][j]), p->err);
        return 0;
      }
    }
  return 1;
}

TEST(exact_error_propagation) {
  rng r = {131};
  static const char *names[] = {
      "elevate",  "mul",    "derivative", "split",     "restrict",
      "lincomb",  "scale",  "add_scalar", "remainder", "sqrt_derivative_aware",
      "rational", "affine", "reduce"};
  long counts[13] = {0}, bad[13] = {0}, overflow = 0;
  long cases = harness_scale(1500, 30000);
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    int op = (int)(n % 13), pattern = rng_int(&r, 0, 3);
    double err = ldexp((double)rng_int(&r, 1, 7), -36);
    bbc_poly p, q, out;
    ro_bpoly a, b, x, y;
    int res = 1;
    switch (op) {
      case 0: { /* elevation */
        make_input(&A, &ax, &r, rng_int(&r, 0, 6), rng_int(&r, 0, 6), 53, 0, err, pattern, &p, &a);
        unsigned char deg[NAX] = {0};
        deg[ax.x] = (unsigned char)(a.nx + rng_int(&r, 0, 4));
        deg[ax.y] = (unsigned char)(a.ny + rng_int(&r, 0, 4));
        REQUIRE(bbc_poly_elevate(&A, &out, &p, deg) == BBC_OK);
        ro_apply(&a, 0, 0, deg[ax.x], ro_int(0), &y);
        ro_apply(&y, 1, 0, deg[ax.y], ro_int(0), &x);
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 1: { /* product */
        int positive = pattern < 2;
        make_input(&A, &ax, &r, rng_int(&r, 0, 4), rng_int(&r, 0, 4), 40, positive, err, pattern,
                   &p, &a);
        make_input(&A, &ax, &r, rng_int(&r, 0, 4), rng_int(&r, 0, 4), 40, positive, err * 2,
                   pattern, &q, &b);
        REQUIRE(bbc_poly_mul(&A, &out, &p, &q) == BBC_OK);
        ro_bmul(&a, &b, &x);
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 2: { /* derivative */
        make_input(&A, &ax, &r, rng_int(&r, 0, 8), rng_int(&r, 0, 8), 53, 0, err, pattern, &p, &a);
        int axis = rng_int(&r, 0, 1);
        REQUIRE(bbc_poly_derivative(&A, &out, &p, axis ? ax.y : ax.x) == BBC_OK);
        ro_apply(&a, axis, 1, 0, ro_int(0), &x);
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 3: { /* split at 1/2 */
        make_input(&A, &ax, &r, rng_int(&r, 0, 8), rng_int(&r, 0, 8), 53, 0, err, pattern, &p, &a);
        int axis = rng_int(&r, 0, 1);
        bbc_poly left, right;
        REQUIRE(bbc_poly_split(&A, &p, axis ? ax.y : ax.x, &left, &right) == BBC_OK);
        ro_apply(&a, axis, 2, 0, ro_frac(1, 2), &x);
        ro_apply(&a, axis, 3, 0, ro_frac(1, 2), &y);
        res = ro_check_b(&left, &ax, &x, -1, 0);
        if (res == 1) res = ro_check_b(&right, &ax, &y, -1, 0);
        break;
      }
      case 4: { /* restriction to a dyadic box whose lo/hi is a double (no domain change) */
        make_input(&A, &ax, &r, rng_int(&r, 0, 7), rng_int(&r, 0, 7), 53, 0, err, pattern, &p, &a);
        double lo[NAX] = {0}, hi[NAX] = {0};
        int hk[2], lk[2];
        for (int k = 0; k < 2; k++) {
          hk[k] = rng_int(&r, 1, 16);
          lk[k] = rng_int(&r, 0, 7);
          int j = k ? ax.y : ax.x;
          hi[j] = hk[k] / 16.0;
          lo[j] = hi[j] * lk[k] / 8.0;
        }
        REQUIRE(bbc_poly_restrict(&A, &out, &p, lo, hi) == BBC_OK);
        ro_bpoly t1, t2, t3;
        ro_apply(&a, 0, 2, 0, ro_frac(hk[0], 16), &t1);
        ro_apply(&t1, 0, 3, 0, ro_frac(lk[0], 8), &t2);
        ro_apply(&t2, 1, 2, 0, ro_frac(hk[1], 16), &t3);
        ro_apply(&t3, 1, 3, 0, ro_frac(lk[1], 8), &x);
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 5: { /* linear combination with full-mantissa weights and elevation */
        make_input(&A, &ax, &r, rng_int(&r, 0, 5), rng_int(&r, 0, 5), 53, 0, err, pattern, &p, &a);
        make_input(&A, &ax, &r, rng_int(&r, 0, 5), rng_int(&r, 0, 5), 53, 0, err * 3, pattern, &q,
                   &b);
        double alpha[2] = {full_mantissa(&r, 53, 0), full_mantissa(&r, 53, 0)};
        const bbc_poly *terms[2] = {&p, &q};
        REQUIRE(bbc_poly_lincomb(&A, &out, 2, alpha, terms) == BBC_OK);
        int tx = a.nx > b.nx ? a.nx : b.nx, ty = a.ny > b.ny ? a.ny : b.ny;
        ro_bpoly ea, eb, t;
        ro_apply(&a, 0, 0, tx, ro_int(0), &t);
        ro_apply(&t, 1, 0, ty, ro_int(0), &ea);
        ro_apply(&b, 0, 0, tx, ro_int(0), &t);
        ro_apply(&t, 1, 0, ty, ro_int(0), &eb);
        x.nx = tx;
        x.ny = ty;
        for (int i = 0; i <= tx; i++)
          for (int j = 0; j <= ty; j++)
            x.c[i][j] = ro_add(ro_mul(ro_from_double(alpha[0]), ea.c[i][j]),
                               ro_mul(ro_from_double(alpha[1]), eb.c[i][j]));
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 6:
      case 7: { /* scale and add_scalar */
        make_input(&A, &ax, &r, rng_int(&r, 0, 6), rng_int(&r, 0, 6), 53, 0, err, pattern, &p, &a);
        double s = full_mantissa(&r, 53, 0);
        if (op == 6)
          REQUIRE(bbc_poly_scale(&A, &out, &p, s) == BBC_OK);
        else
          REQUIRE(bbc_poly_add_scalar(&A, &out, &p, s) == BBC_OK);
        x = a;
        for (int i = 0; i <= a.nx; i++)
          for (int j = 0; j <= a.ny; j++)
            x.c[i][j] = op == 6 ? ro_mul(ro_from_double(s), a.c[i][j])
                                : ro_add(ro_from_double(s), a.c[i][j]);
        res = ro_check_b(&out, &ax, &x, -1, 0);
        break;
      }
      case 8: { /* remainder: f + (1 - xi) lo + xi hi */
        make_input(&A, &ax, &r, rng_int(&r, 0, 6), rng_int(&r, 0, 6), 53, 0, err, pattern, &p, &a);
        double l = full_mantissa(&r, 53, 0), h = l + fabs(full_mantissa(&r, 53, 0));
        int xi;
        REQUIRE(bbc_poly_remainder(&A, &ax.space, &out, &p, l, h, &xi) == BBC_OK);
        x = a;
        y = a;
        for (int i = 0; i <= a.nx; i++)
          for (int j = 0; j <= a.ny; j++) {
            x.c[i][j] = ro_add(a.c[i][j], ro_from_double(l));
            y.c[i][j] = ro_add(a.c[i][j], ro_from_double(h));
          }
        res = ro_check_b(&out, &ax, &x, xi, 0);
        if (res == 1) res = ro_check_b(&out, &ax, &y, xi, 1);
        break;
      }
      case 9: { /* the derivative-aware square root: a b_i + b + S_k (b_i - c) + D_m */
        make_input(&A, &ax, &r, rng_int(&r, 0, 5), rng_int(&r, 0, 5), 53, 1, err, pattern, &p, &a);
        bbc_poly slope;
        bbc_sqrt_derivative_aware f;
        int axes[2];
        REQUIRE(bbc_poly_sqrt_derivative_aware(&A, &ax.space, &out, &slope, &p, NULL, 0.0, &f,
                                               axes) == BBC_OK);
        ro_rat fa = ro_from_double(f.a), fb = ro_from_double(f.b), fc = ro_from_double(f.c);
        ro_rat S[2] = {ro_from_double(f.slope_lo), ro_from_double(f.slope_hi)};
        ro_rat D[2] = {ro_from_double(f.delta_lo), ro_from_double(f.delta_hi)};
        for (int k = 0; k < 2 && res == 1; k++)
          for (int m = 0; m < 2 && res == 1; m++) {
            x = a;
            for (int i = 0; i <= a.nx; i++)
              for (int j = 0; j <= a.ny; j++)
                x.c[i][j] = ro_add(
                    ro_add(ro_add(ro_mul(fa, a.c[i][j]), fb), ro_mul(S[k], ro_sub(a.c[i][j], fc))),
                    D[m]);
            /* xi = axes[0] at index k and zeta = axes[1] at index m. */
            bbc_poly view = out;
            size_t sz = 1;
            for (int j2 = axes[1] + 1; j2 < NAX; j2++) sz *= (size_t)out.deg[j2] + 1;
            view.coef = out.coef + (size_t)m * sz;
            res = ro_check_b(&view, &ax, &x, axes[0], k);
          }
        ro_rat want0 = ro_add(fa, S[0]), want1 = ro_add(fa, S[1]);
        if (res == 1 && !(ro_within(want0, slope.coef[0], slope.err) &&
                          ro_within(want1, slope.coef[1], slope.err)))
          res = 0;
        break;
      }
      case 10: { /* rational bound: every exact ideal ratio inside, complement shrunk */
        int nx = rng_int(&r, 0, 4), ny = rng_int(&r, 0, 4);
        double e = pattern == 3 ? 0.0 : err;
        make_input(&A, &ax, &r, nx, ny, 53, 1, e, pattern, &p, &a);
        make_input(&A, &ax, &r, nx, ny, 53, rng_int(&r, 0, 1), e, pattern, &q, &b);
        if (e > 0 && rng_int(&r, 0, 1)) {
          /* A denominator coefficient within err of 0 whose ideal value is negative while the
           * stored one is positive: the sign test must not trust it. */
          int i = rng_int(&r, 0, nx), j = rng_int(&r, 0, ny);
          for (int i2 = 0; i2 <= nx; i2++)
            for (int j2 = 0; j2 <= ny; j2++) {
              double v = fabs(q.coef[lib_index(&q, &ax, i2, j2)]);
              if (i2 == i && j2 == j) v = e / 2;
              q.coef[lib_index(&q, &ax, i2, j2)] = v;
              b.c[i2][j2] =
                  ro_add(ro_from_double(v),
                         (i2 == i && j2 == j) ? ro_neg(ro_from_double(e)) : ro_from_double(e));
            }
        }
        bbc_range range;
        REQUIRE(bbc_rational_bound(&A, &p, &q, &range) == BBC_OK);
        if (range.kind == BBC_RANGE_BOUNDED) {
          /* Eq. 3 needs every exact denominator coefficient to have one sign. */
          int pos = 0, neg = 0;
          for (int i = 0; i <= nx; i++)
            for (int j = 0; j <= ny; j++) {
              pos += b.c[i][j].num > 0;
              neg += b.c[i][j].num <= 0;
            }
          if (pos && neg) res = 0;
          for (int i = 0; i <= nx && res == 1; i++)
            for (int j = 0; j <= ny && res == 1; j++) {
              ro_rat ratio = ro_div(a.c[i][j], b.c[i][j]);
              if (!ratio.ok)
                res = -1;
              else if (ro_cmp_sum(ratio, range.lo, 0.0) < 0 || ro_cmp_sum(ratio, range.hi, 0.0) > 0)
                res = 0;
            }
        } else if (range.kind == BBC_RANGE_COMPLEMENT) {
          /* q/p in [L, H] with L < 0 < H (p > 0 here): p/q avoids (1/L, 1/H) exactly. */
          ro_rat L = ro_int(0), H = ro_int(0);
          for (int i = 0; i <= nx; i++)
            for (int j = 0; j <= ny; j++) {
              ro_rat t = ro_div(b.c[i][j], a.c[i][j]);
              if (!t.ok)
                res = -1;
              else {
                if ((i == 0 && j == 0) || ro_cmp_sum(ro_sub(t, L), 0.0, 0.0) < 0) L = t;
                if ((i == 0 && j == 0) || ro_cmp_sum(ro_sub(t, H), 0.0, 0.0) > 0) H = t;
              }
            }
          if (res == 1 && L.num < 0 && H.num > 0) {
            if (ro_cmp_sum(ro_div(ro_int(1), L), range.lo, 0.0) > 0 ||
                ro_cmp_sum(ro_div(ro_int(1), H), range.hi, 0.0) < 0)
              res = 0;
          }
        }
        break;
      }
    }
    if (op == 11) { /* affine: the corners c + sum of gradients, exactly */
      double c = full_mantissa(&r, 53, 0), grad[NAX] = {0};
      grad[ax.x] = full_mantissa(&r, 53, 0);
      grad[ax.y] = rng_int(&r, 0, 2) ? full_mantissa(&r, 53, 0) : 0.0;
      REQUIRE(bbc_poly_affine(&A, &out, c, grad) == BBC_OK);
      x.nx = out.deg[ax.x];
      x.ny = out.deg[ax.y];
      for (int i = 0; i <= x.nx; i++)
        for (int j = 0; j <= x.ny; j++)
          x.c[i][j] = ro_add(ro_from_double(c), ro_add(i ? ro_from_double(grad[ax.x]) : ro_int(0),
                                                       j ? ro_from_double(grad[ax.y]) : ro_int(0)));
      res = ro_check_b(&out, &ax, &x, -1, 0);
    }
    if (op == 12) {
      /* Reduction of a polynomial with a large radius: the exact ideal input must lie,
       * coefficient by coefficient at its own degree, between the exactly elevated lower
       * (zeta = 0) and upper (zeta = 1) surfaces of the result, widened by its radius;
       * that implies the enclosure everywhere. */
      make_input(&A, &ax, &r, rng_int(&r, 2, 7), rng_int(&r, 2, 7), 53, 0, ldexp(err, 16), pattern,
                 &p, &a);
      int zeta, d = rng_int(&r, 0, 2);
      REQUIRE(bbc_poly_reduce(&A, &ax.space, &out, &p, d, &zeta) == BBC_OK);
      ro_bpoly lo_s, hi_s, t, el, eh;
      lo_s.nx = hi_s.nx = out.deg[ax.x];
      lo_s.ny = hi_s.ny = out.deg[ax.y];
      size_t sz = 1;
      for (int j2 = zeta + 1; j2 < NAX; j2++) sz *= (size_t)out.deg[j2] + 1;
      ro_rat er = ro_from_double(out.err);
      for (int i = 0; i <= lo_s.nx; i++)
        for (int j = 0; j <= lo_s.ny; j++) {
          size_t at = 0, sx = 1, sy = 1;
          for (int k = ax.x + 1; k < NAX; k++) sx *= (size_t)out.deg[k] + 1;
          for (int k = ax.y + 1; k < NAX; k++) sy *= (size_t)out.deg[k] + 1;
          at = (size_t)i * sx + (size_t)j * sy;
          lo_s.c[i][j] = ro_sub(ro_from_double(out.coef[at]), er);
          hi_s.c[i][j] = ro_add(ro_from_double(out.coef[at + sz]), er);
        }
      ro_apply(&lo_s, 0, 0, a.nx, ro_int(0), &t);
      ro_apply(&t, 1, 0, a.ny, ro_int(0), &el);
      ro_apply(&hi_s, 0, 0, a.nx, ro_int(0), &t);
      ro_apply(&t, 1, 0, a.ny, ro_int(0), &eh);
      for (int i = 0; i <= a.nx && res == 1; i++)
        for (int j = 0; j <= a.ny && res == 1; j++) {
          ro_rat below = ro_sub(a.c[i][j], el.c[i][j]), above = ro_sub(eh.c[i][j], a.c[i][j]);
          if (!below.ok || !above.ok)
            res = -1;
          else if (below.num < 0 || above.num < 0)
            res = 0;
        }
    }
    counts[op]++;
    if (res == 0) {
      if (bad[op] < 3)
        fprintf(stderr, "exact %s: pattern %d outside the radius\n", names[op], pattern);
      bad[op]++;
    }
    if (res < 0) overflow++;
  }
  long total_bad = 0;
  for (int op = 0; op < 13; op++) {
    total_bad += bad[op];
    CHECK(counts[op] > 0);
  }
  printf("exact single operations: %ld cases, %ld oracle overflows\n", cases, overflow);
  CHECK_INT(total_bad, 0);
  CHECK(overflow < cases / 20);
}

/* ---- Random enclosure families ---------------------------------------------------------- */

TEST(enclosure_polynomials) {
  rng r = {202};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0, bad_eval = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 e;
    expr_random(&r, &e, 3, 8, 6);
    bbc_poly p, sub;
    REQUIRE(expr_build(&A, &e, &ax, &p) == BBC_OK);
    double lo[NAX], hi[NAX];
    random_box(&r, lo, hi, &ax);
    REQUIRE(bbc_poly_restrict(&A, &sub, &p, lo, hi) == BBC_OK);
    bbc_interval whole = bbc_poly_bound(&p), part = bbc_poly_bound(&sub);
    double m = maxabs_coef(&p);
    for (int k = 0; k < 200; k++, done++) {
      double x = rng_in(&r, lo[ax.x], hi[ax.x]), y = rng_in(&r, lo[ax.y], hi[ax.y]);
      long double mag, v = expr_eval(&e, x, y, &mag), sl = oracle_slack(mag);
      if (!in_interval(part, v, sl) || !in_interval(whole, v, sl)) {
        if (bad < 5)
          fprintf(stderr, "value %.17Lg outside [%.17g, %.17g] / [%.17g, %.17g]\n", v, part.lo,
                  part.hi, whole.lo, whole.hi);
        bad++;
      }
      /* de Casteljau evaluation against the oracle, within err plus evaluation rounding. */
      double pt[NAX];
      point2(&ax, x, y, pt);
      double ev = bbc_poly_eval(&p, pt);
      long double tol = p.err + 4.0L * (degree_sum(&p) + 2) * DBL_EPSILON * m + sl;
      if (fabsl(ev - v) > tol) bad_eval++;
    }
  }
  printf("polynomials: %ld points\n", done);
  CHECK_INT(bad, 0);
  CHECK_INT(bad_eval, 0);
}

TEST(enclosure_derivatives) {
  rng r = {303};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 e;
    expr_random(&r, &e, 3, 7, 6);
    bbc_poly p, dx, dy, dxs, left, dleft;
    REQUIRE(expr_build(&A, &e, &ax, &p) == BBC_OK);
    REQUIRE(bbc_poly_derivative(&A, &dx, &p, ax.x) == BBC_OK);
    REQUIRE(bbc_poly_derivative(&A, &dy, &p, ax.y) == BBC_OK);
    double lo[NAX], hi[NAX];
    random_box(&r, lo, hi, &ax);
    REQUIRE(bbc_poly_restrict(&A, &dxs, &dx, lo, hi) == BBC_OK);
    /* The derivative of the left half with respect to its own variable is half the
     * derivative of p (an exact re-parameterisation x = s / 2). */
    REQUIRE(bbc_poly_split(&A, &p, ax.x, &left, NULL) == BBC_OK);
    REQUIRE(bbc_poly_derivative(&A, &dleft, &left, ax.x) == BBC_OK);
    bbc_interval bx = bbc_poly_bound(&dx), by = bbc_poly_bound(&dy), bs = bbc_poly_bound(&dxs),
                 bl = bbc_poly_bound(&dleft);
    for (int k = 0; k < 100; k++, done += 4) {
      double x = rng_in(&r, 0.0, 1.0), y = rng_in(&r, 0.0, 1.0);
      long double mag, v = expr_deriv(&e, x, y, 0, &mag);
      if (!in_interval(bx, v, oracle_slack(mag))) bad++;
      v = expr_deriv(&e, x, y, 1, &mag);
      if (!in_interval(by, v, oracle_slack(mag))) bad++;
      x = rng_in(&r, lo[ax.x], hi[ax.x]);
      y = rng_in(&r, lo[ax.y], hi[ax.y]);
      v = expr_deriv(&e, x, y, 0, &mag);
      if (!in_interval(bs, v, oracle_slack(mag))) bad++;
      x = rng_in(&r, 0.0, 0.5);
      v = 0.5L * expr_deriv(&e, x, y, 0, &mag);
      if (!in_interval(bl, v, oracle_slack(mag))) bad++;
    }
  }
  printf("derivatives: %ld points\n", done);
  CHECK_INT(bad, 0);
}

TEST(enclosure_rationals) {
  rng r = {404};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0;
  long kinds[3] = {0, 0, 0};
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 ep, eq;
    expr_random(&r, &ep, 2, 5, 6);
    expr_random(&r, &eq, 2, 4, 6);
    expr_add_constant(&eq, rng_dyadic(&r, 4.0, 4));
    if (rng_int(&r, 0, 2) == 0) expr_add_constant(&ep, rng_dyadic(&r, 6.0, 4));
    bbc_poly p, q, ps, qs;
    REQUIRE(expr_build(&A, &ep, &ax, &p) == BBC_OK);
    REQUIRE(expr_build(&A, &eq, &ax, &q) == BBC_OK);
    double lo[NAX], hi[NAX];
    random_box(&r, lo, hi, &ax);
    REQUIRE(bbc_poly_restrict(&A, &ps, &p, lo, hi) == BBC_OK);
    REQUIRE(bbc_poly_restrict(&A, &qs, &q, lo, hi) == BBC_OK);
    bbc_range range;
    REQUIRE(bbc_rational_bound(&A, &ps, &qs, &range) == BBC_OK);
    kinds[range.kind]++;
    for (int k = 0; k < 100; k++, done++) {
      double x = rng_in(&r, lo[ax.x], hi[ax.x]), y = rng_in(&r, lo[ax.y], hi[ax.y]);
      long double mp, mq, pv = expr_eval(&ep, x, y, &mp), qv = expr_eval(&eq, x, y, &mq);
      long double sq = oracle_slack(mq);
      if (fabsl(qv) <= 4 * sq) continue; /* at a pole: p/q is not defined */
      long double v = pv / qv;
      long double sl = (oracle_slack(mp) + fabsl(v) * sq) / (fabsl(qv) - sq) + fabsl(v) * 0x1p-60L;
      int inside = 1;
      if (range.kind == BBC_RANGE_BOUNDED)
        inside = (long double)range.lo - sl <= v && v <= (long double)range.hi + sl;
      else if (range.kind == BBC_RANGE_COMPLEMENT)
        inside = !((long double)range.lo + sl < v && v < (long double)range.hi - sl);
      if (!inside) {
        if (bad < 5)
          fprintf(stderr, "p/q = %.17Lg not in kind %d [%.17g, %.17g]\n", v, range.kind, range.lo,
                  range.hi);
        bad++;
      }
    }
  }
  printf("rationals: %ld points; bounded %ld, complement %ld, unbounded %ld boxes\n", done,
         kinds[0], kinds[1], kinds[2]);
  CHECK_INT(bad, 0);
  CHECK(kinds[BBC_RANGE_BOUNDED] > 0);
  CHECK(kinds[BBC_RANGE_COMPLEMENT] > 0);
  CHECK(kinds[BBC_RANGE_UNBOUNDED] > 0);
}

/* Products and sums of polynomials that carry remainder variables: whatever value in its
 * interval each remainder quantity takes, the bound must contain the result. */
TEST(enclosure_remainder_products) {
  rng r = {505};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 eg, eh, ek;
    expr_random(&r, &eg, 2, 4, 6);
    expr_random(&r, &eh, 2, 3, 6);
    expr_random(&r, &ek, 1, 3, 6);
    double l1 = rng_dyadic(&r, 1.0, 8), w1 = fabs(rng_dyadic(&r, 1.0, 8));
    double l2 = rng_dyadic(&r, 1.0, 8), w2 = fabs(rng_dyadic(&r, 1.0, 8));
    /* f = g + (h + delta1) * (k + delta2) + delta1^2 with two independent remainders; delta1
     * used twice keeps its one axis. */
    bbc_poly g, h, k, hr, kr, prod, d1sq, f, tmp;
    REQUIRE(expr_build(&A, &eg, &ax, &g) == BBC_OK);
    REQUIRE(expr_build(&A, &eh, &ax, &h) == BBC_OK);
    REQUIRE(expr_build(&A, &ek, &ax, &k) == BBC_OK);
    bbc_poly d1, d2;
    int a1, a2;
    REQUIRE(bbc_poly_remainder(&A, &ax.space, &d1, NULL, l1, l1 + w1, &a1) == BBC_OK);
    REQUIRE(bbc_poly_remainder(&A, &ax.space, &d2, NULL, l2, l2 + w2, &a2) == BBC_OK);
    CHECK(a1 != a2 && a1 != ax.x && a1 != ax.y && a2 != ax.x && a2 != ax.y);
    REQUIRE(bbc_poly_add(&A, &hr, &h, &d1) == BBC_OK);
    REQUIRE(bbc_poly_add(&A, &kr, &k, &d2) == BBC_OK);
    REQUIRE(bbc_poly_mul(&A, &prod, &hr, &kr) == BBC_OK);
    REQUIRE(bbc_poly_mul(&A, &d1sq, &d1, &d1) == BBC_OK);
    REQUIRE(bbc_poly_add(&A, &tmp, &g, &prod) == BBC_OK);
    REQUIRE(bbc_poly_add(&A, &f, &tmp, &d1sq) == BBC_OK);
    double lo[NAX], hi[NAX];
    random_box(&r, lo, hi, &ax);
    bbc_poly fs;
    REQUIRE(bbc_poly_restrict(&A, &fs, &f, lo, hi) == BBC_OK);
    bbc_interval b = bbc_poly_bound(&fs);
    for (int n = 0; n < 100; n++, done++) {
      double x = rng_in(&r, lo[ax.x], hi[ax.x]), y = rng_in(&r, lo[ax.y], hi[ax.y]);
      long double d1v = rng_in(&r, l1, l1 + w1), d2v = rng_in(&r, l2, l2 + w2);
      long double mg, mh, mk;
      long double gv = expr_eval(&eg, x, y, &mg), hv = expr_eval(&eh, x, y, &mh),
                  kv = expr_eval(&ek, x, y, &mk);
      long double v = gv + (hv + d1v) * (kv + d2v) + d1v * d1v;
      long double mag = mg + (mh + fabsl(d1v)) * (mk + fabsl(d2v)) + d1v * d1v;
      if (!in_interval(b, v, oracle_slack(mag))) bad++;
    }
  }
  printf("remainder products: %ld points\n", done);
  CHECK_INT(bad, 0);
}

/* Degree reduction: f = g + h sqrt(beta) with a high-degree g and the square root as a
 * primal remainder; reduced to a low degree, the result must still enclose the true f. */
TEST(enclosure_reductions) {
  rng r = {606};
  long points = harness_scale(20000, 1000000), done = 0, bad = 0, bad_point = 0;
  double width_ratio_sum = 0.0;
  long width_count = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 eg, eh, eb;
    expr_random(&r, &eg, 2, 14, 6);
    expr_random(&r, &eh, 1, 3, 6);
    expr_random(&r, &eb, 1, 2, 6);
    bbc_poly g, h, bq, beta, s, hs, f, red;
    REQUIRE(expr_build(&A, &eg, &ax, &g) == BBC_OK);
    REQUIRE(expr_build(&A, &eh, &ax, &h) == BBC_OK);
    REQUIRE(expr_build(&A, &eb, &ax, &bq) == BBC_OK);
    /* beta = b^2 + 1/64 > 0. */
    REQUIRE(bbc_poly_mul(&A, &beta, &bq, &bq) == BBC_OK);
    REQUIRE(bbc_poly_add_scalar(&A, &beta, &beta, 1.0 / 64.0) == BBC_OK);
    REQUIRE(bbc_poly_sqrt_primal(&A, &ax.space, &s, &beta, NULL, NULL, NULL) == BBC_OK);
    REQUIRE(bbc_poly_mul(&A, &hs, &h, &s) == BBC_OK);
    REQUIRE(bbc_poly_add(&A, &f, &g, &hs) == BBC_OK);
    static const int targets[] = {0, 1, 2, 3, 5, 40};
    int d = targets[rng_int(&r, 0, 5)];
    int zeta;
    REQUIRE(bbc_poly_reduce(&A, &ax.space, &red, &f, d, &zeta) == BBC_OK);
    for (int j = 0; j < NAX; j++) {
      if (j == ax.x || j == ax.y) {
        CHECK(red.deg[j] <= d && red.deg[j] <= f.deg[j]);
      } else if (j == zeta) {
        CHECK_INT(red.deg[j], 1);
      } else {
        CHECK_INT(red.deg[j], 0); /* old remainder axes are gone */
      }
    }
    bbc_interval b = bbc_poly_bound(&red), bf = bbc_poly_bound(&f);
    if (isfinite(b.hi) && bf.hi > bf.lo) {
      width_ratio_sum += (b.hi - b.lo) / (bf.hi - bf.lo);
      width_count++;
    }
    double m = maxabs_coef(&red);
    for (int n = 0; n < 100; n++, done++) {
      double x = rng_in(&r, 0.0, 1.0), y = rng_in(&r, 0.0, 1.0);
      long double mg, mh, mb;
      long double gv = expr_eval(&eg, x, y, &mg), hv = expr_eval(&eh, x, y, &mh),
                  bv = expr_eval(&eb, x, y, &mb);
      long double betav = bv * bv + 1.0L / 64.0L;
      long double v = gv + hv * sqrtl(betav);
      long double mag = mg + mh * sqrtl(mb * mb + 1.0L / 64.0L);
      long double sl = oracle_slack(mag);
      if (!in_interval(b, v, sl)) bad++;
      /* Pointwise: some zeta in [0, 1] reproduces v, so v lies between zeta = 0 and 1. */
      double pt[NAX];
      point2(&ax, x, y, pt);
      pt[zeta] = 0.0;
      double v0 = bbc_poly_eval(&red, pt);
      pt[zeta] = 1.0;
      double v1 = bbc_poly_eval(&red, pt);
      long double tol = red.err + 4.0L * (degree_sum(&red) + 2) * DBL_EPSILON * m + sl;
      if (v < fminl(v0, v1) - tol || v > fmaxl(v0, v1) + tol) {
        if (bad_point < 5)
          fprintf(stderr, "reduced: %.17Lg not between %.17g and %.17g\n", v, v0, v1);
        bad_point++;
      }
    }
  }
  printf("reductions: %ld points; mean bound width reduced/original %.3f\n", done,
         width_count ? width_ratio_sum / width_count : 0.0);
  CHECK_INT(bad, 0);
  CHECK_INT(bad_point, 0);
}

TEST(reduction_fit_quality) {
  /* A polynomial of degree (d, d) elevated to (n, n) is its own best fit: reducing it back to
   * d must leave a remainder interval of rounding size only. For x^n reduced to degree
   * n - 1 the Chebyshev-weighted least-squares fit is the Chebyshev truncation, which for x^n
   * is the minimax fit: the true error x^n - F must equioscillate with amplitude 2^(1-2n).
   * The remainder interval, which bounds that error by Bernstein coefficients (Sec. 6.1), is
   * wider; how much wider is printed. */
  rng r = {1313};
  int bad = 0;
  for (int n = 0; n < 60; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    int d = rng_int(&r, 0, 4), up = rng_int(&r, d + 1, 40);
    bbc_poly p, el, red;
    memset(&p, 0, sizeof p);
    p.deg[ax.x] = p.deg[ax.y] = (unsigned char)d;
    p.coef = (double *)bbc_arena_alloc(&A, bbc_poly_size(&p) * sizeof(double));
    for (size_t i = 0; i < bbc_poly_size(&p); i++) p.coef[i] = 2 * rng_unit(&r) - 1;
    unsigned char deg[NAX] = {0};
    deg[ax.x] = deg[ax.y] = (unsigned char)up;
    REQUIRE(bbc_poly_elevate(&A, &el, &p, deg) == BBC_OK);
    int zeta;
    REQUIRE(bbc_poly_reduce(&A, &ax.space, &red, &el, d, &zeta) == BBC_OK);
    /* The remainder width is the difference of the zeta = 1 and zeta = 0 coefficients. */
    size_t st = 1;
    for (int j = zeta + 1; j < NAX; j++) st *= (size_t)red.deg[j] + 1;
    double w = red.coef[st] - red.coef[0];
    if (!(w >= 0 && w < 1e-9)) {
      fprintf(stderr, "reduce %d -> %d: remainder width %.3g\n", up, d, w);
      bad++;
    }
  }
  for (int n = 2; n <= 12; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    bbc_poly x, xn, red;
    REQUIRE(bbc_poly_linear(&A, &x, ax.x, 0.0, 1.0) == BBC_OK);
    xn = x;
    for (int k = 1; k < n; k++) REQUIRE(bbc_poly_mul(&A, &xn, &xn, &x) == BBC_OK);
    int zeta;
    REQUIRE(bbc_poly_reduce(&A, &ax.space, &red, &xn, n - 1, &zeta) == BBC_OK);
    size_t st = 1;
    for (int j = zeta + 1; j < NAX; j++) st *= (size_t)red.deg[j] + 1;
    double w = red.coef[st] - red.coef[0], best = ldexp(1.0, 2 - 2 * n); /* 2 x 2^(1-2n) */
    /* The true error x^n - F(x) = x^n - R(x, zeta = 0) + e_lo, sampled: its spread. */
    long double lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i <= 4000; i++) {
      double pt[NAX] = {0};
      pt[ax.x] = i / 4000.0;
      long double e = powl(pt[ax.x], n) - bbc_poly_eval(&red, pt);
      if (e < lo) lo = e;
      if (e > hi) hi = e;
    }
    double spread = (double)(hi - lo);
    printf(
        "reduce x^%d to degree %d: fit error spread %.4g x minimax, remainder interval %.4g x "
        "minimax\n",
        n, n - 1, spread / best, w / best);
    if (!(spread > 0.99 * best && spread < 1.01 * best && w >= spread)) bad++;
  }
  CHECK_INT(bad, 0);
}

/* ---- Square roots --------------------------------------------------------------------- */

/* A random interval [l, r] of the kinds the refraction term produces: l = 0, l < 0 (total
 * internal reflection somewhere), narrow and wide spans from 1e-12 to 1e6. */
static void random_sqrt_interval(rng *r, double *l, double *hi) {
  int kind = rng_int(r, 0, 4);
  double span = pow(10.0, -12.0 + 18.0 * rng_unit(r));
  if (kind == 0) {
    *l = 0.0;
    *hi = span;
  } else if (kind == 1) {
    *hi = span;
    *l = -span * rng_unit(r);
  } else if (kind == 2) {
    *l = pow(10.0, -12.0 + 18.0 * rng_unit(r));
    *hi = *l + span;
  } else if (kind == 3) {
    *l = pow(10.0, -12.0 + 18.0 * rng_unit(r));
    *hi = *l; /* degenerate */
  } else {
    *l = span * rng_unit(r) * 1e-6; /* a tiny positive lower end */
    *hi = span;
  }
}

/* x in [l0, r]: ends, uniform, and log-uniform near the low end where sqrt bends most. */
static double random_sqrt_point(rng *r, double l0, double hi) {
  int pick = rng_int(r, 0, 5);
  if (pick == 0) return l0;
  if (pick == 1) return hi;
  double t = pick <= 3 ? rng_unit(r) : pow(10.0, -16.0 * rng_unit(r));
  double x = l0 + (hi - l0) * t;
  return x < l0 ? l0 : (x > hi ? hi : x);
}

TEST(sqrt_scalar_enclosure) {
  rng r = {707};
  long points = harness_scale(100000, 2000000), done = 0, bad_p = 0, bad_s = 0, bad_v = 0;
  long below_clamp = 0;
  while (done < points) {
    double l, hi;
    random_sqrt_interval(&r, &l, &hi);
    bbc_sqrt_primal p;
    bbc_sqrt_derivative_aware d;
    REQUIRE(bbc_sqrt_primal_fit(l, hi, &p) == BBC_OK);
    double clamp = rng_int(&r, 0, 3) ? 0.0 : hi * pow(10.0, -8.0 * rng_unit(&r));
    REQUIRE(bbc_sqrt_derivative_aware_fit(l, hi, clamp, &d) == BBC_OK);
    CHECK(p.delta_lo <= p.delta_hi && d.slope_lo <= d.slope_hi && d.delta_lo <= d.delta_hi);
    double l0 = l > 0.0 ? l : 0.0;
    CHECK_INT(d.slope_enclosed, d.clamp <= l0);
    for (int k = 0; k < 100; k++, done++) {
      long double x = random_sqrt_point(&r, l0, hi);
      long double sx = sqrtl(x);
      /* Primal: sqrt x - (a x + b) within [delta_lo, delta_hi]. */
      long double e = sx - ((long double)p.a * x + p.b);
      long double sl = (sx + fabsl((long double)p.a * x) + fabsl(p.b)) * 0x1p-60L;
      if (e < p.delta_lo - sl || e > p.delta_hi + sl) {
        if (bad_p < 5)
          fprintf(stderr, "primal [%.17g, %.17g] x=%.17Lg: err %.6Lg not in [%.6g, %.6g]\n", l, hi,
                  x, e, p.delta_lo, p.delta_hi);
        bad_p++;
      }
      /* Derivative-aware: with the true slope 1/(2 sqrt x) (when x >= clamp) or the steepest
       * one (below the clamp), the value error lies in [delta_lo, delta_hi]. */
      long double slope, ds;
      if (x >= d.clamp) {
        slope = 0.5L / sx;
        ds = slope - (long double)d.a;
        long double ssl = slope * 0x1p-60L;
        if (x > 0 && (ds < d.slope_lo - ssl || ds > d.slope_hi + ssl)) bad_s++;
      } else {
        below_clamp++;
        ds = d.slope_hi;
      }
      long double val = (long double)d.a * x + d.b + ds * (x - (long double)d.c);
      long double ev = sx - val;
      long double vsl =
          (sx + fabsl((long double)d.a * x) + fabsl(d.b) + fabsl(ds * (x - (long double)d.c))) *
          0x1p-60L;
      if (x > 0 || d.clamp > 0) {
        if (ev < d.delta_lo - vsl || ev > d.delta_hi + vsl) {
          if (bad_v < 5)
            fprintf(stderr, "two-stage [%.17g, %.17g] x=%.17Lg: err %.6Lg not in [%.6g, %.6g]\n", l,
                    hi, x, ev, d.delta_lo, d.delta_hi);
          bad_v++;
        }
      }
    }
  }
  printf("sqrt scalar: %ld points (%ld below the clamp)\n", done, below_clamp);
  CHECK_INT(bad_p, 0);
  CHECK_INT(bad_s, 0);
  CHECK_INT(bad_v, 0);
  CHECK(below_clamp > 0);
}

TEST(sqrt_supplement_eq24_is_too_small) {
  /* The printed Supp. Eq. 24 bound (1 - sqrt(l/r))^2 / 2 misses a factor sqrt(x); for r > 1
   * it is smaller than the true error. On [1, 100] the true maximum error at x = 100 is
   * (10 - 1)^2 / (2 * 10) = 4.05, the printed bound 0.405. Our delta_hi must cover 4.05. */
  bbc_sqrt_derivative_aware d;
  REQUIRE(bbc_sqrt_derivative_aware_fit(1.0, 100.0, 0.0, &d) == BBC_OK);
  CHECK(d.slope_enclosed);
  CHECK(d.delta_hi >= 4.05);
  CHECK(d.delta_hi < 4.05 + 1e-12);
  CHECK(d.delta_lo <= 0.0 && d.delta_lo > -1e-12);
}

/* The xi at which the derivative-aware surrogate's slope a + S(xi) is the true slope
 * 1 / (2 sqrt x), clamped to [0, 1]; 1 below the clamp (where the slope is not claimed). */
static long double true_slope_xi(const bbc_sqrt_derivative_aware *df, long double x,
                                 long double sx) {
  if (!(x >= df->clamp && x > 0)) return 1.0L;
  long double want = 0.5L / sx - df->a;
  long double xs = df->slope_hi > df->slope_lo
                       ? (want - df->slope_lo) / ((long double)df->slope_hi - df->slope_lo)
                       : 0.5L;
  return xs < 0 ? 0 : xs > 1 ? 1 : xs;
}

TEST(sqrt_poly_enclosure) {
  rng r = {808};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0, bad_slope = 0, bad_der = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    double l, hi;
    random_sqrt_interval(&r, &l, &hi);
    bbc_poly beta, s, v, sl, dv;
    REQUIRE(bbc_poly_linear(&A, &beta, ax.x, l, hi) == BBC_OK);
    int xi, axes[2];
    bbc_sqrt_primal pf;
    bbc_sqrt_derivative_aware df;
    REQUIRE(bbc_poly_sqrt_primal(&A, &ax.space, &s, &beta, NULL, &pf, &xi) == BBC_OK);
    REQUIRE(bbc_poly_sqrt_derivative_aware(&A, &ax.space, &v, &sl, &beta, NULL, 0.0, &df, axes) ==
            BBC_OK);
    CHECK(xi != axes[0] && xi != axes[1] && axes[0] != axes[1]);
    REQUIRE(bbc_poly_derivative(&A, &dv, &v, ax.x) == BBC_OK);
    bbc_interval bs = bbc_poly_bound(&s), bv = bbc_poly_bound(&v), bd = bbc_poly_bound(&dv);
    double ms = maxabs_coef(&s), mv = maxabs_coef(&v), md = maxabs_coef(&dv);
    for (int k = 0; k < 100; k++, done++) {
      double t = rng_in(&r, 0.0, 1.0);
      long double x = (long double)l + ((long double)hi - l) * t;
      if (x < 0) continue; /* sqrt is not needed where beta < 0 */
      long double sx = sqrtl(x), slack = (sx + fabsl(x)) * 0x1p-56L;
      double pt[NAX] = {0};
      pt[ax.x] = t;
      /* Primal: sqrt(beta) between xi = 0 and xi = 1, and inside the bound. */
      pt[xi] = 0.0;
      double s0 = bbc_poly_eval(&s, pt);
      pt[xi] = 1.0;
      double s1 = bbc_poly_eval(&s, pt);
      long double tol = s.err + 16 * DBL_EPSILON * ms + slack;
      if (sx < fminl(s0, s1) - tol || sx > fmaxl(s0, s1) + tol || !in_interval(bs, sx, slack))
        bad++;
      pt[xi] = 0.0;
      /* Derivative-aware: the xi that gives the true slope, then zeta spans the value. */
      long double xs = true_slope_xi(&df, x, sx);
      pt[axes[0]] = (double)xs;
      pt[axes[1]] = 0.0;
      double v0 = bbc_poly_eval(&v, pt);
      pt[axes[1]] = 1.0;
      double v1 = bbc_poly_eval(&v, pt);
      tol = v.err + 16 * DBL_EPSILON * mv + slack +
            fabsl(x - df.c) * 1e-15L * (df.slope_hi - df.slope_lo);
      if (sx < fminl(v0, v1) - tol || sx > fmaxl(v0, v1) + tol || !in_interval(bv, sx, slack))
        bad++;
      if (x >= df.clamp && x > 0) {
        /* The slope polynomial at that xi is the true derivative d sqrt / d beta, and the
         * derivative of the value along the piece is it times d beta / dt = hi - l. */
        double spt[NAX] = {0};
        spt[axes[0]] = (double)xs;
        long double want = 0.5L / sx;
        if (fabsl(bbc_poly_eval(&sl, spt) - want) > 1e-12L * want + sl.err) bad_slope++;
        long double dwant = want * ((long double)hi - l);
        double dev = bbc_poly_eval(&dv, pt);
        if (fabsl(dev - dwant) > 1e-11L * fabsl(dwant) + dv.err + 16 * DBL_EPSILON * md) bad_der++;
        if (!in_interval(bd, dwant, fabsl(dwant) * 0x1p-56L)) bad_der++;
      }
    }
  }
  printf("sqrt polynomials: %ld points\n", done);
  CHECK_INT(bad, 0);
  CHECK_INT(bad_slope, 0);
  CHECK_INT(bad_der, 0);
}

/* bbc_poly_sqrt_derivative_centred: the coefficients a b_i + b + S_k (b_i - c) + m within
 * the radius of the exact ones (rational oracle), the slope likewise, and m +- radius
 * covering [delta_lo, delta_hi]. */
TEST(exact_sqrt_centred) {
  rng r = {919};
  long cases = harness_scale(400, 8000), bad = 0, overflow = 0;
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    int pattern = rng_int(&r, 0, 3);
    double err = ldexp((double)rng_int(&r, 1, 7), -36);
    bbc_poly p, out, slope;
    ro_bpoly a, x;
    make_input(&A, &ax, &r, rng_int(&r, 0, 5), rng_int(&r, 0, 5), 53, 1, err, pattern, &p, &a);
    bbc_sqrt_derivative_aware f;
    double radius = -1;
    int xi = -1;
    REQUIRE(bbc_poly_sqrt_derivative_centred(&A, &ax.space, &out, &slope, &radius, &p, NULL, 0.0,
                                             &f, &xi) == BBC_OK);
    CHECK(xi >= 0 && xi != ax.x && xi != ax.y);
    double m = 0.5 * f.delta_lo + 0.5 * f.delta_hi;
    CHECK(m - radius <= f.delta_lo && m + radius >= f.delta_hi);
    ro_rat fa = ro_from_double(f.a), fb = ro_from_double(f.b), fc = ro_from_double(f.c);
    ro_rat S[2] = {ro_from_double(f.slope_lo), ro_from_double(f.slope_hi)};
    ro_rat M = ro_from_double(m);
    int res = 1;
    for (int k = 0; k < 2 && res == 1; k++) {
      x = a;
      for (int i = 0; i <= a.nx; i++)
        for (int j = 0; j <= a.ny; j++)
          x.c[i][j] =
              ro_add(ro_add(ro_add(ro_mul(fa, a.c[i][j]), fb), ro_mul(S[k], ro_sub(a.c[i][j], fc))),
                     M);
      res = ro_check_b(&out, &ax, &x, xi, k);
    }
    ro_rat want0 = ro_add(fa, S[0]), want1 = ro_add(fa, S[1]);
    if (res == 1 && !(ro_within(want0, slope.coef[0], slope.err) &&
                      ro_within(want1, slope.coef[1], slope.err)))
      res = 0;
    if (res == 0) bad++;
    if (res < 0) overflow++;
  }
  printf("exact centred sqrt: %ld cases, %ld oracle overflows\n", cases, overflow);
  CHECK_INT(bad, 0);
  CHECK(overflow < cases / 20);
}

/* bbc_poly_sqrt_derivative_centred against long double: at the xi of the true slope,
 * sqrt(beta) within the value's radius plus *radius, the slope and the derivative along
 * the piece as for the two-axis form; below the clamp the value at xi = 1. And its value
 * interval is never wider than the two-axis form's, and about a quarter as wide when the
 * range is narrow. */
TEST(sqrt_centred_enclosure) {
  rng r = {919};
  long points = harness_scale(40000, 1000000), done = 0, bad = 0, bad_slope = 0, bad_der = 0;
  long narrow = 0, narrow_quarter = 0, wider = 0;
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    double l, hi;
    random_sqrt_interval(&r, &l, &hi);
    bbc_poly beta, v, sl, dv;
    REQUIRE(bbc_poly_linear(&A, &beta, ax.x, l, hi) == BBC_OK);
    int xi = -1;
    double radius = -1;
    bbc_sqrt_derivative_aware df, paper;
    REQUIRE(bbc_poly_sqrt_derivative_centred(&A, &ax.space, &v, &sl, &radius, &beta, NULL, 0.0,
                                             &df, &xi) == BBC_OK);
    REQUIRE(bbc_sqrt_derivative_aware_fit(l, hi, 0.0, &paper) == BBC_OK);
    /* Where the widths are the mathematics' and not their rounding (about 1e-16 sqrt(hi)). */
    const double pw = paper.delta_hi - paper.delta_lo;
    if (pw > 1e-12 * sqrt(hi) && 2 * radius > pw * (1 + 1e-6)) wider++;
    if (l > 0 && hi > l * (1 + 1e-4) && hi < l * 1.01) {
      narrow++;
      if (2 * radius < 0.3 * (paper.delta_hi - paper.delta_lo)) narrow_quarter++;
    }
    REQUIRE(bbc_poly_derivative(&A, &dv, &v, ax.x) == BBC_OK);
    double mv = maxabs_coef(&v), md = maxabs_coef(&dv);
    for (int k = 0; k < 100; k++, done++) {
      double t = rng_in(&r, 0.0, 1.0);
      long double x = (long double)l + ((long double)hi - l) * t;
      if (x < 0) continue;
      long double sx = sqrtl(x), slack = (sx + fabsl(x)) * 0x1p-56L;
      double pt[NAX] = {0};
      pt[ax.x] = t;
      long double xs = true_slope_xi(&df, x, sx);
      pt[xi] = (double)xs;
      double v0 = bbc_poly_eval(&v, pt);
      long double tol = v.err + radius + 16 * DBL_EPSILON * mv + slack +
                        fabsl(x - df.c) * 1e-15L * (df.slope_hi - df.slope_lo);
      if (fabsl(sx - v0) > tol) bad++;
      if (x >= df.clamp && x > 0) {
        double spt[NAX] = {0};
        spt[xi] = (double)xs;
        long double want = 0.5L / sx;
        if (fabsl(bbc_poly_eval(&sl, spt) - want) > 1e-12L * want + sl.err) bad_slope++;
        long double dwant = want * ((long double)hi - l);
        double dev = bbc_poly_eval(&dv, pt);
        if (fabsl(dev - dwant) > 1e-11L * fabsl(dwant) + dv.err + 16 * DBL_EPSILON * md) bad_der++;
      }
    }
  }
  printf("centred sqrt: %ld points; %ld narrow ranges, %ld of them under 0.3 of the two-axis "
         "width\n",
         done, narrow, narrow_quarter);
  CHECK_INT(bad, 0);
  CHECK_INT(bad_slope, 0);
  CHECK_INT(bad_der, 0);
  CHECK_INT(wider, 0);
  CHECK(narrow > 0);
  CHECK_INT(narrow_quarter, narrow);
}

/* ---- Convergence ---------------------------------------------------------------------- */

/* The exact range of an expression over a box, from below: a 201 x 201 grid in long double.
 * It underestimates the range by O((h/200)^2), negligible next to the excesses measured. */
typedef long double (*fn2)(long double x, long double y);

static void sampled_range(fn2 f, long double x0, long double x1, long double y0, long double y1,
                          long double *lo, long double *hi) {
  *lo = INFINITY;
  *hi = -INFINITY;
  for (int i = 0; i <= 200; i++)
    for (int j = 0; j <= 200; j++) {
      long double v = f(x0 + (x1 - x0) * i / 200.0L, y0 + (y1 - y0) * j / 200.0L);
      if (v < *lo) *lo = v;
      if (v > *hi) *hi = v;
    }
}

#define CONV_C 0.3L
/* (x + 1/2)^3 (y + 1)^2 - lambda x - mu y: a critical point at (c, c), not homogeneous. */
static const long double conv_lambda = 3.0L * 0.64L * 1.69L, conv_mu = 2.0L * 0.512L * 1.3L;
static long double conv_poly(long double x, long double y) {
  return powl(x + 0.5L, 3) * powl(y + 1.0L, 2) - conv_lambda * x - conv_mu * y;
}
/* ((x - c)^2 + 1) / ((y - c)^2 + 2): a critical point at (c, c). */
static long double conv_rational(long double x, long double y) {
  return ((x - CONV_C) * (x - CONV_C) + 1.0L) / ((y - CONV_C) * (y - CONV_C) + 2.0L);
}

TEST(convergence_quadratic) {
  /* Garloff (1986): the excess of the Bernstein bound over the true range is O(h^2) for a box
   * of size h, so it shrinks by about 4 per halving. Near a critical point (where the excess
   * is not zero) both the width and the excess must shrink that way; the rational bound of
   * Eq. 3 does the same. A function monotone on the box is bounded exactly (its extreme
   * coefficients are corner values), which is checked as well. */
  bbc_arena A = fresh_arena();
  axes2 ax = make_axes();
  const double c = (double)CONV_C;
  bbc_poly xp, yp, x3, y2, f, lx, ly, t, g, mono, np, dq;
  REQUIRE(bbc_poly_linear(&A, &xp, ax.x, 0.5, 1.5) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &yp, ax.y, 1.0, 2.0) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &x3, &xp, &xp) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &x3, &x3, &xp) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &y2, &yp, &yp) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &mono, &x3, &y2) == BBC_OK);
  /* lambda and mu rounded to doubles move the critical point by ~1e-16: irrelevant. */
  double grad[NAX] = {0};
  grad[ax.x] = -(double)conv_lambda;
  grad[ax.y] = -(double)conv_mu;
  REQUIRE(bbc_poly_affine(&A, &t, 0.0, grad) == BBC_OK);
  REQUIRE(bbc_poly_add(&A, &f, &mono, &t) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &lx, ax.x, -c, 1.0 - c) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &ly, ax.y, -c, 1.0 - c) == BBC_OK);
  bbc_poly lx2, ly2;
  REQUIRE(bbc_poly_mul(&A, &lx2, &lx, &lx) == BBC_OK);
  REQUIRE(bbc_poly_mul(&A, &ly2, &ly, &ly) == BBC_OK);
  REQUIRE(bbc_poly_add(&A, &g, &lx2, &ly2) == BBC_OK);
  REQUIRE(bbc_poly_add_scalar(&A, &np, &lx2, 1.0) == BBC_OK);
  REQUIRE(bbc_poly_add_scalar(&A, &dq, &ly2, 2.0) == BBC_OK);
  double prev[3] = {0, 0, 0};
  int ok[3] = {0, 0, 0}, steps = 0, exact_mono = 1;
  for (int k = 1; k <= 9; k++) {
    double h = ldexp(1.0, -k);
    double lo[NAX] = {0}, hi[NAX] = {0};
    /* Off-centre boxes around the critical point. */
    lo[ax.x] = c - 0.375 * h;
    hi[ax.x] = c + 0.625 * h;
    lo[ax.y] = c - 0.4375 * h;
    hi[ax.y] = c + 0.5625 * h;
    bbc_poly fs, gs, ms, ps, qs;
    REQUIRE(bbc_poly_restrict(&A, &fs, &f, lo, hi) == BBC_OK);
    REQUIRE(bbc_poly_restrict(&A, &gs, &g, lo, hi) == BBC_OK);
    REQUIRE(bbc_poly_restrict(&A, &ms, &mono, lo, hi) == BBC_OK);
    REQUIRE(bbc_poly_restrict(&A, &ps, &np, lo, hi) == BBC_OK);
    REQUIRE(bbc_poly_restrict(&A, &qs, &dq, lo, hi) == BBC_OK);
    bbc_interval bf = bbc_poly_bound(&fs), bg = bbc_poly_bound(&gs), bm = bbc_poly_bound(&ms);
    bbc_range br;
    REQUIRE(bbc_rational_bound(&A, &ps, &qs, &br) == BBC_OK);
    REQUIRE(br.kind == BBC_RANGE_BOUNDED);
    long double flo, fhi, rlo, rhi;
    sampled_range(conv_poly, lo[ax.x], hi[ax.x], lo[ax.y], hi[ax.y], &flo, &fhi);
    sampled_range(conv_rational, lo[ax.x], hi[ax.x], lo[ax.y], hi[ax.y], &rlo, &rhi);
    CHECK(bf.lo <= flo && bf.hi >= fhi && br.lo <= rlo && br.hi >= rhi);
    double excess[3] = {(double)((bf.hi - bf.lo) - (fhi - flo)), bg.hi - bg.lo,
                        (double)((br.hi - br.lo) - (rhi - rlo))};
    /* Monotone: the exact range is spanned by two corners. */
    long double a = lo[ax.x], b = hi[ax.x], ay = lo[ax.y], by = hi[ax.y];
    long double mlo = powl(a + 0.5L, 3) * powl(ay + 1.0L, 2),
                mhi = powl(b + 0.5L, 3) * powl(by + 1.0L, 2);
    /* Exact up to the tracked error radius (which carries the unit-box magnitude). */
    long double allowed = 2.0L * ms.err * (1.0L + 1e-6L) + 1e-14L * mhi;
    if (!(bm.lo <= mlo && bm.hi >= mhi && (bm.hi - bm.lo) - (mhi - mlo) <= allowed)) {
      exact_mono = 0;
      fprintf(stderr,
              "monotone k=%d: [%.17g, %.17g] vs [%.17Lg, %.17Lg], excess %.6Lg allowed %.6Lg\n", k,
              bm.lo, bm.hi, mlo, mhi, (bm.hi - bm.lo) - (mhi - mlo), allowed);
    }
    if (k > 1) {
      double q[3];
      for (int i = 0; i < 3; i++) q[i] = excess[i] / prev[i];
      printf(
          "h=2^-%d: excess ratio (critical point) %.4f, width ratio (minimum) %.4f, rational "
          "excess ratio %.4f\n",
          k, q[0], q[1], q[2]);
      if (k >= 4) {
        steps++;
        ok[0] += q[0] > 0.2 && q[0] < 0.3;
        ok[1] += q[1] > 0.2 && q[1] < 0.3;
        ok[2] += q[2] > 0.15 && q[2] < 0.35;
      }
    }
    for (int i = 0; i < 3; i++) prev[i] = excess[i];
  }
  CHECK_INT(ok[0], steps);
  CHECK_INT(ok[1], steps);
  CHECK_INT(ok[2], steps);
  CHECK(exact_mono);
}

/* ---- Bernstein versus interval arithmetic on the chain ----------------------------------- */

typedef struct lvec {
  long double x, y, z;
} lvec;

static lvec lv(bbc_vec3 v) {
  lvec r = {v.x, v.y, v.z};
  return r;
}
static lvec lv_add(lvec a, lvec b) {
  lvec r = {a.x + b.x, a.y + b.y, a.z + b.z};
  return r;
}
static lvec lv_sub(lvec a, lvec b) {
  lvec r = {a.x - b.x, a.y - b.y, a.z - b.z};
  return r;
}
static lvec lv_scale(long double s, lvec a) {
  lvec r = {s * a.x, s * a.y, s * a.z};
  return r;
}
static long double lv_dot(lvec a, lvec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
static lvec lv_cross(lvec a, lvec b) {
  lvec r = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
  return r;
}
static long double lv_norm1(lvec a) {
  return fabsl(a.x) + fabsl(a.y) + fabsl(a.z);
}

static bbc_vec3 v3(double x, double y, double z) {
  bbc_vec3 r = {x, y, z};
  return r;
}
static bbc_vec3 v3_add(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static bbc_vec3 v3_sub(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static bbc_vec3 v3_scale(double s, bbc_vec3 a) {
  return v3(s * a.x, s * a.y, s * a.z);
}
static bbc_vec3 v3_rand(rng *r, double sx, double sy, double sz) {
  return v3(sx * (2 * rng_unit(r) - 1), sy * (2 * rng_unit(r) - 1), sz * (2 * rng_unit(r) - 1));
}

/* One reflection off an interpolated-normal triangle, hit coordinate u2 on a receiver
 * (Eq. 9-10): u2 = ((d1 x e22) . (x1 - p20)) / ((d1 x e22) . e21). The inputs of the piece
 * (corner point and gradients) are doubles shared by all three evaluations. */
typedef struct chain_case {
  bbc_vec3 x0, cx, gxs, gxt, cn, gns, gnt, p20, e21, e22;
} chain_case;

static void chain_random(rng *r, chain_case *c) {
  c->x0 = v3_add(v3(0, 3, 0), v3_rand(r, 1, 0.5, 1));
  bbc_vec3 p10 = v3_rand(r, 1, 0.2, 1), p11 = v3_rand(r, 1, 0.2, 1), p12 = v3_rand(r, 1, 0.2, 1);
  bbc_vec3 n10 = v3_add(v3(0, 1, 0), v3_rand(r, 0.3, 0.1, 0.3));
  bbc_vec3 n11 = v3_add(v3(0, 1, 0), v3_rand(r, 0.3, 0.1, 0.3));
  bbc_vec3 n12 = v3_add(v3(0, 1, 0), v3_rand(r, 0.3, 0.1, 0.3));
  double h = ldexp(1.0, -rng_int(r, 0, 7));
  double u0 = (1.0 - h) * rng_unit(r), v0 = (1.0 - h) * rng_unit(r);
  bbc_vec3 e11 = v3_sub(p11, p10), e12 = v3_sub(p12, p10);
  c->cx = v3_add(p10, v3_add(v3_scale(u0, e11), v3_scale(v0, e12)));
  c->gxs = v3_scale(h, e11);
  c->gxt = v3_scale(h, e12);
  bbc_vec3 f11 = v3_sub(n11, n10), f12 = v3_sub(n12, n10);
  c->cn = v3_add(n10, v3_add(v3_scale(u0, f11), v3_scale(v0, f12)));
  c->gns = v3_scale(h, f11);
  c->gnt = v3_scale(h, f12);
  c->p20 = v3_add(v3(-4, 2, -4), v3_rand(r, 0.5, 0.5, 0.5));
  c->e21 = v3_add(v3(8, 0, 0), v3_rand(r, 1, 0.5, 1));
  c->e22 = v3_add(v3(0, 0, 8), v3_rand(r, 1, 0.5, 1));
}

static long double chain_oracle(const chain_case *c, double s, double t, long double *mag_num,
                                long double *den_out, long double *mag_den) {
  lvec x1 = lv_add(lv(c->cx), lv_add(lv_scale(s, lv(c->gxs)), lv_scale(t, lv(c->gxt))));
  lvec n1 = lv_add(lv(c->cn), lv_add(lv_scale(s, lv(c->gns)), lv_scale(t, lv(c->gnt))));
  lvec d0 = lv_sub(x1, lv(c->x0));
  lvec d1 = lv_sub(lv_scale(lv_dot(n1, n1), d0), lv_scale(2.0L * lv_dot(d0, n1), n1));
  lvec cr = lv_cross(d1, lv(c->e22));
  long double num = lv_dot(cr, lv_sub(x1, lv(c->p20)));
  long double den = lv_dot(cr, lv(c->e21));
  /* Magnitudes: the same expression on absolute values bounds the sum of |terms|. */
  long double md1 = lv_norm1(n1) * lv_norm1(n1) * lv_norm1(d0) * 3;
  *mag_num = md1 * lv_norm1(lv(c->e22)) * lv_norm1(lv_sub(x1, lv(c->p20))) * 2;
  *mag_den = md1 * lv_norm1(lv(c->e22)) * lv_norm1(lv(c->e21)) * 2;
  *den_out = den;
  return num;
}

static bbc_result chain_bernstein(bbc_arena *A, const axes2 *ax, const chain_case *c,
                                  bbc_range *out) {
  bbc_vec3 gx[NAX], gn[NAX];
  memset(gx, 0, sizeof gx);
  memset(gn, 0, sizeof gn);
  gx[ax->x] = c->gxs;
  gx[ax->y] = c->gxt;
  gn[ax->x] = c->gns;
  gn[ax->y] = c->gnt;
  bbc_poly3 x1, n1, x0, d0, t1, t2, d1, cr, p20, rel;
  bbc_poly nn, dn, num, den;
  bbc_result r = bbc_poly3_affine(A, &x1, c->cx, gx);
  if (r == BBC_OK) r = bbc_poly3_affine(A, &n1, c->cn, gn);
  if (r == BBC_OK) r = bbc_poly3_constant(A, &x0, c->x0);
  if (r == BBC_OK) r = bbc_poly3_sub(A, &d0, &x1, &x0);
  if (r == BBC_OK) r = bbc_poly3_dot(A, &nn, &n1, &n1);
  if (r == BBC_OK) r = bbc_poly3_dot(A, &dn, &d0, &n1);
  if (r == BBC_OK) r = bbc_poly3_scale(A, &t1, &nn, &d0);
  if (r == BBC_OK) r = bbc_poly3_scale(A, &t2, &dn, &n1);
  if (r == BBC_OK) r = bbc_poly3_scale_const(A, &t2, 2.0, &t2);
  if (r == BBC_OK) r = bbc_poly3_sub(A, &d1, &t1, &t2);
  if (r == BBC_OK) r = bbc_poly3_cross_vec(A, &cr, &d1, c->e22);
  if (r == BBC_OK) r = bbc_poly3_constant(A, &p20, c->p20);
  if (r == BBC_OK) r = bbc_poly3_sub(A, &rel, &x1, &p20);
  if (r == BBC_OK) r = bbc_poly3_dot(A, &num, &cr, &rel);
  if (r == BBC_OK) r = bbc_poly3_dot_vec(A, &den, &cr, c->e21);
  if (r == BBC_OK) r = bbc_rational_bound(A, &num, &den, out);
  return r;
}

static bbc_interval chain_interval(const chain_case *c) {
  bbc_interval unit = bbc_interval_make(0.0, 1.0);
  bbc_ivec3 x1 = bbc_ivec3_add(bbc_ivec3_point(c->cx),
                               bbc_ivec3_add(bbc_ivec3_scale(unit, bbc_ivec3_point(c->gxs)),
                                             bbc_ivec3_scale(unit, bbc_ivec3_point(c->gxt))));
  bbc_ivec3 n1 = bbc_ivec3_add(bbc_ivec3_point(c->cn),
                               bbc_ivec3_add(bbc_ivec3_scale(unit, bbc_ivec3_point(c->gns)),
                                             bbc_ivec3_scale(unit, bbc_ivec3_point(c->gnt))));
  bbc_ivec3 d0 = bbc_ivec3_sub(x1, bbc_ivec3_point(c->x0));
  bbc_ivec3 d1 = bbc_ivec3_sub(bbc_ivec3_scale(bbc_ivec3_dot(n1, n1), d0),
                               bbc_ivec3_scale(bbc_interval_scale(bbc_ivec3_dot(d0, n1), 2.0), n1));
  bbc_ivec3 cr = bbc_ivec3_cross(d1, bbc_ivec3_point(c->e22));
  bbc_interval num = bbc_ivec3_dot(cr, bbc_ivec3_sub(x1, bbc_ivec3_point(c->p20)));
  bbc_interval den = bbc_ivec3_dot(cr, bbc_ivec3_point(c->e21));
  return bbc_interval_div(num, den);
}

TEST(tighter_than_interval_arithmetic) {
  rng r = {909};
  long cases = harness_scale(3000, 20000), bad = 0, looser = 0, both = 0, ours_only = 0,
       ia_only = 0, neither = 0, points = 0;
  double ratio_sum = 0.0, log_ratio_sum = 0.0;
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    chain_case c;
    chain_random(&r, &c);
    bbc_range br;
    REQUIRE(chain_bernstein(&A, &ax, &c, &br) == BBC_OK);
    bbc_interval ia = chain_interval(&c);
    int ia_bounded = isfinite(ia.lo) && isfinite(ia.hi);
    int b_bounded = br.kind == BBC_RANGE_BOUNDED;
    if (b_bounded && ia_bounded) {
      both++;
      double wb = br.hi - br.lo, wi = ia.hi - ia.lo;
      if (wb > wi * (1.0 + 1e-9) + 1e-300) looser++;
      ratio_sum += wb / wi;
      log_ratio_sum += log(wb / wi);
    } else if (b_bounded) {
      ours_only++;
    } else if (ia_bounded) {
      ia_only++;
    } else {
      neither++;
    }
    for (int k = 0; k < 50; k++, points++) {
      double s = rng_in(&r, 0.0, 1.0), t = rng_in(&r, 0.0, 1.0);
      long double mn, md, den;
      long double num = chain_oracle(&c, s, t, &mn, &den, &md);
      long double sq = md * 0x1p-56L;
      if (fabsl(den) <= 4 * sq) continue;
      long double v = num / den;
      long double sl = (mn * 0x1p-56L + fabsl(v) * sq) / (fabsl(den) - sq);
      int inside = 1;
      if (br.kind == BBC_RANGE_BOUNDED)
        inside = (long double)br.lo - sl <= v && v <= (long double)br.hi + sl;
      else if (br.kind == BBC_RANGE_COMPLEMENT)
        inside = !((long double)br.lo + sl < v && v < (long double)br.hi - sl);
      if (!inside) bad++;
      if (ia_bounded && !((long double)ia.lo - sl <= v && v <= (long double)ia.hi + sl)) bad++;
    }
  }
  printf(
      "chain u2 (reflection, %ld pieces, %ld points): both bounded %ld, bernstein only %ld, "
      "interval only %ld, neither %ld\n",
      cases, points, both, ours_only, ia_only, neither);
  printf("bernstein/interval width ratio: mean %.4f, geometric mean %.4f\n",
         both ? ratio_sum / both : 0.0, both ? exp(log_ratio_sum / both) : 0.0);
  CHECK_INT(bad, 0);
  CHECK_INT(looser, 0);
  CHECK_INT(ia_only, 0);
  CHECK(both > cases / 4);
  CHECK(both == 0 || ratio_sum / both < 0.8);
}

/* ---- Vectors, the interval baseline, API contracts ------------------------------------- */

TEST(vec3_helpers) {
  rng r = {1010};
  long bad = 0, done = 0, points = harness_scale(20000, 1000000);
  while (done < points) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    chain_case c;
    chain_random(&r, &c);
    bbc_vec3 gx[NAX] = {{0}}, gn[NAX] = {{0}};
    gx[ax.x] = c.gxs;
    gx[ax.y] = c.gxt;
    gn[ax.x] = c.gns;
    gn[ax.y] = c.gnt;
    bbc_poly3 a, b, cr, crv, sc;
    bbc_poly dot, dotv, s;
    REQUIRE(bbc_poly3_affine(&A, &a, c.cx, gx) == BBC_OK);
    REQUIRE(bbc_poly3_affine(&A, &b, c.cn, gn) == BBC_OK);
    REQUIRE(bbc_poly3_cross(&A, &cr, &a, &b) == BBC_OK);
    REQUIRE(bbc_poly3_cross_vec(&A, &crv, &a, c.e21) == BBC_OK);
    REQUIRE(bbc_poly3_dot(&A, &dot, &a, &b) == BBC_OK);
    REQUIRE(bbc_poly3_dot_vec(&A, &dotv, &a, c.e22) == BBC_OK);
    REQUIRE(bbc_poly3_dot(&A, &s, &b, &b) == BBC_OK);
    REQUIRE(bbc_poly3_scale(&A, &sc, &s, &a) == BBC_OK);
    /* Aliasing: the output may be an input. */
    bbc_poly3 al = a;
    REQUIRE(bbc_poly3_cross(&A, &al, &al, &b) == BBC_OK);
    bbc_interval bcr[3] = {bbc_poly_bound(&cr.x), bbc_poly_bound(&cr.y), bbc_poly_bound(&cr.z)};
    bbc_interval bcv[3] = {bbc_poly_bound(&crv.x), bbc_poly_bound(&crv.y), bbc_poly_bound(&crv.z)};
    bbc_interval bal[3] = {bbc_poly_bound(&al.x), bbc_poly_bound(&al.y), bbc_poly_bound(&al.z)};
    bbc_interval bsc[3] = {bbc_poly_bound(&sc.x), bbc_poly_bound(&sc.y), bbc_poly_bound(&sc.z)};
    bbc_interval bd = bbc_poly_bound(&dot), bdv = bbc_poly_bound(&dotv);
    for (int k = 0; k < 50; k++, done++) {
      double s_ = rng_in(&r, 0, 1), t_ = rng_in(&r, 0, 1);
      lvec x = lv_add(lv(c.cx), lv_add(lv_scale(s_, lv(c.gxs)), lv_scale(t_, lv(c.gxt))));
      lvec n = lv_add(lv(c.cn), lv_add(lv_scale(s_, lv(c.gns)), lv_scale(t_, lv(c.gnt))));
      long double mag = (lv_norm1(x) + 1) * (lv_norm1(n) + 1) *
                        (lv_norm1(lv(c.e21)) + lv_norm1(lv(c.e22)) + lv_norm1(n) + 1);
      long double sl = oracle_slack(mag * 4);
      lvec xc = lv_cross(x, n), xv = lv_cross(x, lv(c.e21));
      lvec xs = lv_scale(lv_dot(n, n), x);
      long double vals[3][4] = {
          {xc.x, xv.x, xs.x, 0}, {xc.y, xv.y, xs.y, 0}, {xc.z, xv.z, xs.z, 0}};
      for (int i = 0; i < 3; i++) {
        if (!in_interval(bcr[i], vals[i][0], sl) || !in_interval(bal[i], vals[i][0], sl)) bad++;
        if (!in_interval(bcv[i], vals[i][1], sl)) bad++;
        if (!in_interval(bsc[i], vals[i][2], sl * (lv_norm1(n) + 1))) bad++;
      }
      if (!in_interval(bd, lv_dot(x, n), sl)) bad++;
      if (!in_interval(bdv, lv_dot(x, lv(c.e22)), sl)) bad++;
    }
  }
  printf("vec3 helpers: %ld points\n", done);
  CHECK_INT(bad, 0);
}

TEST(interval_baseline_on_polynomials) {
  rng r = {1111};
  long bad = 0, looser = 0, cases = harness_scale(300, 5000);
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 e;
    expr_random(&r, &e, 2, 5, 6);
    bbc_poly p, sub;
    REQUIRE(expr_build(&A, &e, &ax, &p) == BBC_OK);
    double lo[NAX], hi[NAX];
    random_box(&r, lo, hi, &ax);
    bbc_interval box[NAX];
    for (int j = 0; j < NAX; j++) box[j] = bbc_interval_make(lo[j], hi[j]);
    bbc_interval ia = bbc_interval_eval_poly(&p, box);
    REQUIRE(bbc_poly_restrict(&A, &sub, &p, lo, hi) == BBC_OK);
    bbc_interval bb = bbc_poly_bound(&sub);
    if (bb.hi - bb.lo > (ia.hi - ia.lo) * (1 + 1e-9) + 1e-300) looser++;
    for (int k = 0; k < 50; k++) {
      double x = rng_in(&r, lo[ax.x], hi[ax.x]), y = rng_in(&r, lo[ax.y], hi[ax.y]);
      long double mag, v = expr_eval(&e, x, y, &mag);
      if (!in_interval(ia, v, oracle_slack(mag))) bad++;
    }
  }
  CHECK_INT(bad, 0);
  CHECK_INT(looser, 0);
}

TEST(arena_and_contracts) {
  /* A full arena fails cleanly and leaves the arena and the output untouched. */
  static unsigned char small[256];
  bbc_arena A;
  bbc_arena_init(&A, small, sizeof small);
  bbc_poly a, b, out;
  REQUIRE(bbc_poly_linear(&A, &a, 7, 1.0, 2.0) == BBC_OK);
  REQUIRE(bbc_poly_linear(&A, &b, 6, 3.0, 5.0) == BBC_OK);
  CHECK(((uintptr_t)a.coef & 15u) == 0);
  size_t used = A.used;
  bbc_poly big = a;
  for (int i = 0; i < 6; i++) {
    bbc_result res = bbc_poly_mul(&A, &big, &big, &b);
    if (res != BBC_OK) {
      CHECK_INT(res, BBC_ERR_OUT_OF_MEMORY);
      break;
    }
  }
  used = A.used;
  memset(&out, 0x5a, sizeof out);
  bbc_poly before = out;
  CHECK_INT(bbc_poly_mul(&A, &out, &big, &big), BBC_ERR_OUT_OF_MEMORY);
  CHECK(A.used == used);
  CHECK(memcmp(&out, &before, sizeof out) == 0);
  bbc_arena_reset(&A, 0);
  CHECK(A.used == 0 && A.peak > 0);
  bbc_arena_reset(NULL, 0);

  /* Degree and argument limits. */
  bbc_arena B = fresh_arena();
  bbc_poly x, x100;
  REQUIRE(bbc_poly_linear(&B, &x, 0, 0.0, 1.0) == BBC_OK);
  unsigned char deg[NAX] = {100};
  REQUIRE(bbc_poly_elevate(&B, &x100, &x, deg) == BBC_OK);
  CHECK_INT(bbc_poly_mul(&B, &out, &x100, &x100), BBC_ERR_UNSUPPORTED);
  double lo[NAX] = {0.6}, hi[NAX] = {0.4, 1, 1, 1, 1, 1, 1, 1};
  CHECK_INT(bbc_poly_restrict(&B, &out, &x, lo, hi), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_poly_derivative(&B, &out, &x, NAX), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_poly_mul(&B, &out, NULL, &x), BBC_ERR_INVALID_ARGUMENT);
  /* A degree above BBC_POLY_MAX_DEGREE on any axis makes an operand invalid (the eight
   * degrees are tested at once): 120 passes, 121, 127, 128 and 255 do not. */
  bbc_poly one, top;
  REQUIRE(bbc_poly_constant(&B, &one, 1.0) == BBC_OK);
  for (int j = 0; j < NAX; j++) {
    unsigned char d[NAX] = {0};
    d[j] = BBC_POLY_MAX_DEGREE;
    REQUIRE(bbc_poly_elevate(&B, &top, &one, d) == BBC_OK);
    CHECK_INT(bbc_poly_scale(&B, &out, &top, 2.0), BBC_OK);
    const unsigned char bad[4] = {121, 127, 128, 255};
    for (int k = 0; k < 4; k++) {
      bbc_poly p = top; /* its coefficients are never read on refusal */
      p.deg[j] = bad[k];
      CHECK_INT(bbc_poly_scale(&B, &out, &p, 2.0), BBC_ERR_INVALID_ARGUMENT);
      CHECK_INT(bbc_poly_mul(&B, &out, &p, &one), BBC_ERR_INVALID_ARGUMENT);
      CHECK_INT(bbc_poly_mul(&B, &out, &one, &p), BBC_ERR_INVALID_ARGUMENT);
    }
  }
  CHECK_INT(bbc_sqrt_primal_fit(2.0, 1.0, NULL), BBC_ERR_INVALID_ARGUMENT);
  bbc_sqrt_primal sp;
  CHECK_INT(bbc_sqrt_primal_fit(2.0, 1.0, &sp), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_sqrt_primal_fit(0.0, INFINITY, &sp), BBC_ERR_INVALID_ARGUMENT);

  /* A space hands out distinct axes and runs out cleanly. */
  bbc_space sp8;
  memset(&sp8, 0, sizeof sp8);
  int seen = 0, axis;
  for (int i = 0; i < NAX; i++) {
    REQUIRE(bbc_space_add_axis(&sp8, i < 2 ? BBC_AXIS_GEOMETRIC : BBC_AXIS_REMAINDER, &axis) ==
            BBC_OK);
    CHECK(!(seen & (1 << axis)));
    seen |= 1 << axis;
  }
  CHECK_INT(bbc_space_add_axis(&sp8, BBC_AXIS_REMAINDER, &axis), BBC_ERR_UNSUPPORTED);
  bbc_poly rem;
  CHECK_INT(bbc_poly_remainder(&B, &sp8, &rem, NULL, 0.0, 1.0, NULL), BBC_ERR_UNSUPPORTED);
  bbc_space_release_axis(&sp8, 3);
  REQUIRE(bbc_poly_remainder(&B, &sp8, &rem, NULL, -1.0, 2.0, &axis) == BBC_OK);
  CHECK_INT(axis, 3);
  bbc_interval rb = bbc_poly_bound(&rem);
  CHECK(rb.lo <= -1.0 && rb.hi >= 2.0);

  /* Overflow turns into an unbounded answer, never a wrong finite one. */
  bbc_poly hugep, hsq;
  REQUIRE(bbc_poly_linear(&B, &hugep, 0, 1e200, 1e300) == BBC_OK);
  REQUIRE(bbc_poly_mul(&B, &hsq, &hugep, &hugep) == BBC_OK);
  bbc_interval hb = bbc_poly_bound(&hsq);
  CHECK(hb.hi == INFINITY);
  bbc_range hr;
  REQUIRE(bbc_rational_bound(&B, &x, &hsq, &hr) == BBC_OK);
  CHECK_INT(hr.kind, BBC_RANGE_UNBOUNDED);
}

TEST(elevation_keeps_values) {
  rng r = {1212};
  long bad = 0, cases = harness_scale(300, 5000);
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    axes2 ax = make_axes();
    expr2 e;
    expr_random(&r, &e, 2, 6, 6);
    bbc_poly p, el;
    REQUIRE(expr_build(&A, &e, &ax, &p) == BBC_OK);
    unsigned char deg[NAX];
    memcpy(deg, p.deg, NAX);
    deg[ax.x] = (unsigned char)(deg[ax.x] + rng_int(&r, 0, 30));
    deg[ax.y] = (unsigned char)(deg[ax.y] + rng_int(&r, 0, 30));
    REQUIRE(bbc_poly_elevate(&A, &el, &p, deg) == BBC_OK);
    bbc_interval b = bbc_poly_bound(&el), b0 = bbc_poly_bound(&p);
    /* Elevated coefficients are convex combinations: the hull can only shrink (up to err). */
    if (b.lo < b0.lo - 2 * el.err || b.hi > b0.hi + 2 * el.err) bad++;
    for (int k = 0; k < 50; k++) {
      double x = rng_in(&r, 0, 1), y = rng_in(&r, 0, 1);
      long double mag, v = expr_eval(&e, x, y, &mag);
      if (!in_interval(b, v, oracle_slack(mag))) bad++;
    }
  }
  CHECK_INT(bad, 0);
}

/* Products on any set of up to five axes (the kernels specialise on the last two axes and
 * on up to four active axes; five go the general way), with degree-0 axes, exact zero
 * coefficients and non-zero input radii: every coefficient within err of the exact
 * product in rational arithmetic. The same factors moved to other axes (same order) give
 * the same doubles, since an axis of degree 0 must cost nothing and change nothing. */
TEST(exact_products_any_axes) {
  rng r = {4242};
  long cases = harness_scale(400, 8000), bad = 0, moved = 0, overflow = 0;
  for (long n = 0; n < cases; n++) {
    bbc_arena A = fresh_arena();
    int m = rng_int(&r, 1, 5), axes[5], used[NAX] = {0};
    /* Distinct axes in increasing order, the last two often among them. */
    for (int k = 0; k < m; k++) {
      int j;
      do j = (n % 2 == 0 && k < 2) ? NAX - 1 - k : rng_int(&r, 0, NAX - 1);
      while (used[j]);
      used[j] = 1;
    }
    for (int j = 0, k = 0; j < NAX; j++)
      if (used[j]) axes[k++] = j;
    int da[5], db[5];
    size_t na = 1, nb = 1;
    for (int k = 0; k < m; k++) {
      da[k] = rng_int(&r, 0, m <= 2 ? 6 : 3);
      db[k] = rng_int(&r, 0, m <= 2 ? 6 : 2);
      na *= (size_t)da[k] + 1;
      nb *= (size_t)db[k] + 1;
    }
    bbc_poly p[2];
    const int *dd[2] = {da, db};
    size_t nn[2] = {na, nb};
    for (int w = 0; w < 2; w++) {
      memset(&p[w], 0, sizeof p[w]);
      for (int k = 0; k < m; k++) p[w].deg[axes[k]] = (unsigned char)dd[w][k];
      p[w].coef = (double *)bbc_arena_alloc(&A, nn[w] * sizeof(double));
      REQUIRE(p[w].coef != NULL);
      for (size_t i = 0; i < nn[w]; i++)
        p[w].coef[i] = rng_int(&r, 0, 4) == 0 ? 0.0 : rng_dyadic(&r, 4.0, 6);
      p[w].err = rng_int(&r, 0, 1) ? 0.0 : ldexp((double)rng_int(&r, 1, 7), -30);
    }
    bbc_poly out;
    REQUIRE(bbc_poly_mul(&A, &out, &p[0], &p[1]) == BBC_OK);
    int dout[5];
    size_t no = 1;
    for (int k = 0; k < m; k++) {
      dout[k] = da[k] + db[k];
      CHECK_INT(out.deg[axes[k]], dout[k]);
      no *= (size_t)dout[k] + 1;
    }
    /* The exact coefficient of every output index (row-major over the m axes). */
    for (size_t o = 0; o < no; o++) {
      int ko[5];
      size_t rest = o;
      for (int k = m - 1; k >= 0; k--) {
        ko[k] = (int)(rest % (size_t)(dout[k] + 1));
        rest /= (size_t)(dout[k] + 1);
      }
      ro_rat s = ro_int(0);
      for (size_t ia = 0; ia < na; ia++) {
        int ki[5];
        size_t ra = ia;
        for (int k = m - 1; k >= 0; k--) {
          ki[k] = (int)(ra % (size_t)(da[k] + 1));
          ra /= (size_t)(da[k] + 1);
        }
        size_t ib = 0;
        ro_rat wgt = ro_int(1);
        int ok = 1;
        for (int k = 0; k < m && ok; k++) {
          int j = ko[k] - ki[k];
          if (j < 0 || j > db[k]) ok = 0;
          ib = ib * (size_t)(db[k] + 1) + (size_t)(j < 0 ? 0 : j);
          if (ok)
            wgt = ro_mul(wgt, ro_div(ro_mul(ro_binom(da[k], ki[k]), ro_binom(db[k], j)),
                                     ro_binom(dout[k], ko[k])));
        }
        if (!ok) continue;
        s = ro_add(s, ro_mul(wgt, ro_mul(ro_from_double(p[0].coef[ia]),
                                          ro_from_double(p[1].coef[ib]))));
      }
      if (!s.ok) {
        overflow++;
        continue;
      }
      /* The exact product of the exact operands (within err of the stored ones) moves by at
       * most max|a| eb + max|b| ea + ea eb, which err covers; here the stored operands are
       * taken as exact, so the stored result must be within err of s. */
      if (!ro_within(s, out.coef[o], out.err)) bad++;
    }
    /* The same factors on the first m axes instead. */
    if (axes[0] != 0 || axes[m - 1] != m - 1) {
      bbc_poly q[2], qout;
      for (int w = 0; w < 2; w++) {
        q[w] = p[w];
        memset(q[w].deg, 0, NAX);
        for (int k = 0; k < m; k++) q[w].deg[k] = p[w].deg[axes[k]];
      }
      REQUIRE(bbc_poly_mul(&A, &qout, &q[0], &q[1]) == BBC_OK);
      if (memcmp(qout.coef, out.coef, no * sizeof(double)) != 0 || qout.err != out.err) moved++;
    }
  }
  CHECK_INT(bad, 0);
  CHECK_INT(moved, 0);
  CHECK(overflow < cases / 10);
}
