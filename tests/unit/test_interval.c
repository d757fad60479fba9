/* Tests of the outward-rounded interval arithmetic (bbc/interval.h) against long double
 * evaluation at random points of the operand intervals. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>

#include "bbc/interval.h"
#include "harness.h"

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

/* Values over many magnitudes, both signs, sometimes exactly 0. */
static double rng_value(rng *r) {
  if (rng_next(r) % 16 == 0) return 0.0;
  double m = pow(10.0, -20.0 + 40.0 * rng_unit(r)) * (1.0 + rng_unit(r));
  return (rng_next(r) & 1) ? m : -m;
}

static bbc_interval rng_interval(rng *r) {
  double a = rng_value(r), b = (rng_next(r) % 4 == 0) ? a : rng_value(r);
  return bbc_interval_make(a, b);
}

static double rng_in(rng *r, bbc_interval a) {
  switch (rng_next(r) % 4) {
    case 0:
      return a.lo;
    case 1:
      return a.hi;
    default: {
      double v = a.lo + (a.hi - a.lo) * rng_unit(r);
      return v < a.lo ? a.lo : (v > a.hi ? a.hi : v);
    }
  }
}

/* The exact result of one double operation is within 2^-64 relative in long double; an
 * outward-rounded double endpoint is at least one double ulp away, so a long double result
 * outside means a real violation. */
static int contains_ld(bbc_interval a, long double v) {
  return (long double)a.lo <= v && v <= (long double)a.hi;
}

TEST(operations_enclose) {
  rng r = {42};
  long n = harness_scale(200000, 2000000), bad = 0;
  for (long i = 0; i < n; i++) {
    bbc_interval a = rng_interval(&r), b = rng_interval(&r);
    long double x = rng_in(&r, a), y = rng_in(&r, b);
    if (!contains_ld(bbc_interval_add(a, b), x + y)) bad++;
    if (!contains_ld(bbc_interval_sub(a, b), x - y)) bad++;
    if (!contains_ld(bbc_interval_mul(a, b), x * y)) bad++;
    if (!contains_ld(bbc_interval_sqr(a), x * x)) bad++;
    if (y != 0 && !contains_ld(bbc_interval_div(a, b), x / y)) bad++;
    if (x >= 0 && !contains_ld(bbc_interval_sqrt(a), sqrtl(x))) bad++;
    if (!contains_ld(bbc_interval_scale(a, (double)y), x * y)) bad++;
  }
  CHECK_INT(bad, 0);
}

TEST(dependency_problem) {
  /* x (4 - x) on [0, 1]: interval arithmetic treats the two factors as independent. */
  bbc_interval x = bbc_interval_make(0.0, 1.0);
  bbc_interval f = bbc_interval_mul(x, bbc_interval_sub(bbc_interval_point(4.0), x));
  CHECK(f.lo <= 0.0 && f.lo > -1e-300);
  CHECK(f.hi >= 4.0 && f.hi < 4.0 + 1e-14);
  /* x * x versus the square. */
  bbc_interval m = bbc_interval_make(-1.0, 2.0);
  CHECK(bbc_interval_mul(m, m).lo <= -2.0);
  CHECK(bbc_interval_sqr(m).lo == 0.0);
}

TEST(special_values) {
  bbc_interval e = bbc_interval_div(bbc_interval_point(1.0), bbc_interval_make(-1.0, 1.0));
  CHECK(e.lo == -INFINITY && e.hi == INFINITY);
  bbc_interval s = bbc_interval_sqrt(bbc_interval_make(-4.0, 9.0));
  CHECK(s.lo == 0.0 && s.hi >= 3.0 && s.hi < 3.0 + 1e-14);
  bbc_interval inf =
      bbc_interval_sub(bbc_interval_make(0.0, INFINITY), bbc_interval_make(0.0, INFINITY));
  CHECK(inf.lo == -INFINITY && inf.hi == INFINITY);
  bbc_interval z =
      bbc_interval_mul(bbc_interval_point(0.0), bbc_interval_make(-INFINITY, INFINITY));
  CHECK(z.lo <= 0.0 && z.hi >= 0.0 && !isnan(z.lo) && !isnan(z.hi));
  CHECK(bbc_interval_width(bbc_interval_make(1.0, 3.0)) >= 2.0);
  CHECK(bbc_interval_contains(bbc_interval_make(1.0, 3.0), 2.0));
  CHECK(!bbc_interval_contains(bbc_interval_make(1.0, 3.0), 3.5));
  /* Outward: a rounded sum never claims the rounded-to-nearest value is exact. */
  bbc_interval t = bbc_interval_add(bbc_interval_point(0.1), bbc_interval_point(0.2));
  CHECK(t.lo < 0.1 + 0.2 && t.hi > 0.1 + 0.2);
}

TEST(vectors_enclose) {
  rng r = {43};
  long n = harness_scale(50000, 1000000), bad = 0;
  for (long i = 0; i < n; i++) {
    bbc_ivec3 a, b;
    bbc_interval *pa = &a.x, *pb = &b.x;
    long double x[3], y[3];
    for (int k = 0; k < 3; k++) {
      double c = 10.0 * (2 * rng_unit(&r) - 1), d = 10.0 * (2 * rng_unit(&r) - 1);
      double w = rng_unit(&r), v = rng_unit(&r);
      pa[k] = bbc_interval_make(c, c + w);
      pb[k] = bbc_interval_make(d, d + v);
      x[k] = rng_in(&r, pa[k]);
      y[k] = rng_in(&r, pb[k]);
    }
    bbc_interval dot = bbc_ivec3_dot(a, b);
    if (!contains_ld(dot, x[0] * y[0] + x[1] * y[1] + x[2] * y[2])) bad++;
    bbc_ivec3 c = bbc_ivec3_cross(a, b);
    if (!contains_ld(c.x, x[1] * y[2] - x[2] * y[1])) bad++;
    if (!contains_ld(c.y, x[2] * y[0] - x[0] * y[2])) bad++;
    if (!contains_ld(c.z, x[0] * y[1] - x[1] * y[0])) bad++;
  }
  CHECK_INT(bad, 0);
}
