/* Exact rational arithmetic for the Bernstein tests, independent of libbbc.
 *
 * ro_rat: a fraction of signed 128-bit integers in lowest terms with a positive denominator.
 * Every operation checks for overflow; an overflowed result has ok = 0 and the tests skip
 * (and count) such cases rather than trusting them.
 *
 * ro_cmp_sum(r, c, e): the exact sign of r - (c + e) for doubles c, e, through a small
 * fixed-size big integer (every double is m 2^k with an integer m), so a test can check
 * |stored coefficient - exact coefficient| <= err without any rounding of its own.
 *
 * ro_power_to_bernstein: exact power-basis -> Bernstein conversion of a tensor polynomial,
 * b_k = sum_{j <= k} C(k, j) / C(n, j) a_j per axis (Farouki & Rajan 1988). */
#ifndef BBC_TEST_RATIONAL_ORACLE_H
#define BBC_TEST_RATIONAL_ORACLE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

__extension__ typedef __int128 ro_i128;
__extension__ typedef unsigned __int128 ro_u128;

typedef struct ro_rat {
  ro_i128 num, den;
  int ok;
} ro_rat;

static ro_u128 ro_uabs(ro_i128 v) {
  return v < 0 ? (ro_u128)0 - (ro_u128)v : (ro_u128)v;
}

static ro_u128 ro_gcd(ro_u128 a, ro_u128 b) {
  while (b) {
    ro_u128 t = a % b;
    a = b;
    b = t;
  }
  return a;
}

static ro_rat ro_bad(void) {
  ro_rat r = {0, 1, 0};
  return r;
}

static ro_rat ro_norm(ro_i128 num, ro_i128 den) {
  if (den == 0) return ro_bad();
  if (den < 0) {
    num = -num;
    den = -den;
  }
  ro_u128 g = ro_gcd(ro_uabs(num), (ro_u128)den);
  if (g > 1) {
    num /= (ro_i128)g;
    den /= (ro_i128)g;
  }
  ro_rat r = {num, den, 1};
  return r;
}

static ro_rat ro_int(long long v) {
  return ro_norm(v, 1);
}
static ro_rat ro_frac(long long n, long long d) {
  return ro_norm(n, d);
}

static ro_rat ro_mul(ro_rat a, ro_rat b) {
  if (!a.ok || !b.ok) return ro_bad();
  /* Cross-reduce first to keep the numbers small. */
  ro_u128 g1 = ro_gcd(ro_uabs(a.num), (ro_u128)b.den), g2 = ro_gcd(ro_uabs(b.num), (ro_u128)a.den);
  if (g1 == 0) g1 = 1;
  if (g2 == 0) g2 = 1;
  ro_i128 an = a.num / (ro_i128)g1, bd = b.den / (ro_i128)g1;
  ro_i128 bn = b.num / (ro_i128)g2, ad = a.den / (ro_i128)g2;
  ro_i128 n, d;
  if (__builtin_mul_overflow(an, bn, &n) || __builtin_mul_overflow(ad, bd, &d)) return ro_bad();
  return ro_norm(n, d);
}

static ro_rat ro_add(ro_rat a, ro_rat b) {
  if (!a.ok || !b.ok) return ro_bad();
  ro_i128 g = (ro_i128)ro_gcd((ro_u128)a.den, (ro_u128)b.den);
  ro_i128 da = a.den / g, db = b.den / g;
  ro_i128 x, y, n, d;
  if (__builtin_mul_overflow(a.num, db, &x) || __builtin_mul_overflow(b.num, da, &y) ||
      __builtin_add_overflow(x, y, &n) || __builtin_mul_overflow(a.den, db, &d))
    return ro_bad();
  return ro_norm(n, d);
}

static ro_rat ro_neg(ro_rat a) {
  a.num = -a.num;
  return a;
}

static ro_rat ro_sub(ro_rat a, ro_rat b) {
  return ro_add(a, ro_neg(b));
}

static ro_rat ro_div(ro_rat a, ro_rat b) {
  if (!b.ok || b.num == 0) return ro_bad();
  ro_rat inv = ro_norm(b.den, b.num);
  return ro_mul(a, inv);
}

/* The exact value of a double, when it fits (|exponent| small enough). */
static ro_rat ro_from_double(double x) {
  if (x == 0.0) return ro_int(0);
  int e;
  double f = frexp(x, &e);
  int64_t m = (int64_t)ldexp(f, 53);
  int k = e - 53;
  if (k >= 0) {
    if (k > 60) return ro_bad();
    return ro_norm((ro_i128)m << k, 1);
  }
  if (-k > 120) return ro_bad();
  return ro_norm(m, (ro_i128)1 << -k);
}

static double ro_to_double(ro_rat a) {
  return (double)((long double)a.num / (long double)a.den);
}

/* ---- A small signed big integer, only for exact comparisons ---------------------------- */

#define RO_LIMBS 96 /* 3072 bits: enough for 128-bit fractions against any double */

typedef struct ro_big {
  uint32_t w[RO_LIMBS];
  int neg;
} ro_big;

static void ro_big_from_u128(ro_big *b, ro_u128 v, int neg) {
  memset(b, 0, sizeof *b);
  for (int i = 0; i < 4; i++) b->w[i] = (uint32_t)(v >> (32 * i));
  b->neg = neg && v != 0;
}

static void ro_big_mul_u64(ro_big *b, uint64_t m) {
  uint64_t lo = m & 0xffffffffu, hi = m >> 32;
  ro_big r;
  memset(&r, 0, sizeof r);
  for (int pass = 0; pass < 2; pass++) {
    uint64_t f = pass ? hi : lo, carry = 0;
    for (int i = 0; i + pass < RO_LIMBS; i++) {
      uint64_t t = (uint64_t)b->w[i] * f + r.w[i + pass] + carry;
      r.w[i + pass] = (uint32_t)t;
      carry = t >> 32;
    }
  }
  r.neg = b->neg;
  *b = r;
}

static void ro_big_shl(ro_big *b, int k) {
  int limbs = k / 32, bits = k % 32;
  for (int i = RO_LIMBS - 1; i >= 0; i--) {
    uint64_t v = 0;
    int s = i - limbs;
    if (s >= 0) v = (uint64_t)b->w[s] << bits;
    if (bits && s - 1 >= 0) v |= (uint64_t)b->w[s - 1] >> (32 - bits);
    b->w[i] = (uint32_t)v;
  }
}

static int ro_big_cmp_mag(const ro_big *a, const ro_big *b) {
  for (int i = RO_LIMBS - 1; i >= 0; i--)
    if (a->w[i] != b->w[i]) return a->w[i] < b->w[i] ? -1 : 1;
  return 0;
}

static int ro_big_is_zero(const ro_big *a) {
  for (int i = 0; i < RO_LIMBS; i++)
    if (a->w[i]) return 0;
  return 1;
}

/* a += b (signed). */
static void ro_big_add(ro_big *a, const ro_big *b) {
  if (a->neg == b->neg) {
    uint64_t carry = 0;
    for (int i = 0; i < RO_LIMBS; i++) {
      uint64_t t = (uint64_t)a->w[i] + b->w[i] + carry;
      a->w[i] = (uint32_t)t;
      carry = t >> 32;
    }
    return;
  }
  const ro_big *big = a, *small = b;
  int neg = a->neg;
  if (ro_big_cmp_mag(a, b) < 0) {
    big = b;
    small = a;
    neg = b->neg;
  }
  ro_big r;
  int64_t borrow = 0;
  for (int i = 0; i < RO_LIMBS; i++) {
    int64_t t = (int64_t)big->w[i] - small->w[i] - borrow;
    borrow = t < 0;
    r.w[i] = (uint32_t)(t + (borrow ? ((int64_t)1 << 32) : 0));
  }
  r.neg = neg;
  if (ro_big_is_zero(&r)) r.neg = 0;
  *a = r;
}

static int ro_big_sign(const ro_big *a) {
  return ro_big_is_zero(a) ? 0 : (a->neg ? -1 : 1);
}

/* x = m 2^k with integer m, |m| < 2^53. */
static void ro_split_double(double x, int64_t *m, int *k) {
  if (x == 0.0) {
    *m = 0;
    *k = 0;
    return;
  }
  int e;
  double f = frexp(x, &e);
  *m = (int64_t)ldexp(f, 53);
  *k = e - 53;
}

/* Sign of r - (c + e), exactly; c and e finite doubles. */
static int ro_cmp_sum(ro_rat r, double c, double e) {
  int64_t mc, me;
  int kc, ke;
  ro_split_double(c, &mc, &kc);
  ro_split_double(e, &me, &ke);
  int k = kc < ke ? kc : ke;
  if (k > 0) k = 0;
  /* Multiply through by den 2^-k > 0: sign(num 2^-k - den mc 2^(kc-k) - den me 2^(ke-k)). */
  ro_big acc, t;
  ro_big_from_u128(&acc, ro_uabs(r.num), r.num < 0);
  ro_big_shl(&acc, -k);
  ro_big_from_u128(&t, (ro_u128)r.den, 0);
  ro_big_mul_u64(&t, (uint64_t)(mc < 0 ? -mc : mc));
  ro_big_shl(&t, kc - k);
  t.neg = mc > 0; /* subtracted */
  ro_big_add(&acc, &t);
  ro_big_from_u128(&t, (ro_u128)r.den, 0);
  ro_big_mul_u64(&t, (uint64_t)(me < 0 ? -me : me));
  ro_big_shl(&t, ke - k);
  t.neg = me > 0;
  ro_big_add(&acc, &t);
  return ro_big_sign(&acc);
}

/* 1 when |d - r| <= e exactly (e >= 0). */
static int ro_within(ro_rat r, double d, double e) {
  return ro_cmp_sum(r, d, -e) >= 0 && ro_cmp_sum(r, d, e) <= 0;
}

/* ---- Polynomials -------------------------------------------------------------------- */

#define RO_MAXD 16

static ro_rat ro_binom(int n, int k) {
  ro_i128 v = 1;
  for (int i = 0; i < k; i++) v = v * (n - i) / (i + 1);
  return ro_norm(v, 1);
}

/* Univariate power -> Bernstein of degree n (a has n+1 entries, b receives n+1). */
static void ro_power_to_bernstein_1d(const ro_rat *a, int n, ro_rat *b) {
  for (int k = 0; k <= n; k++) {
    ro_rat s = ro_int(0);
    for (int j = 0; j <= k; j++)
      s = ro_add(s, ro_mul(ro_div(ro_binom(k, j), ro_binom(n, j)), a[j]));
    b[k] = s;
  }
}

/* Bivariate: a[i][j] the coefficient of x^i y^j, degrees (nx, ny); b[i][j] Bernstein. */
static void ro_power_to_bernstein_2d(ro_rat a[RO_MAXD + 1][RO_MAXD + 1], int nx, int ny,
                                     ro_rat b[RO_MAXD + 1][RO_MAXD + 1]) {
  ro_rat tmp[RO_MAXD + 1][RO_MAXD + 1], col[RO_MAXD + 1], out[RO_MAXD + 1];
  for (int i = 0; i <= nx; i++) ro_power_to_bernstein_1d(a[i], ny, tmp[i]);
  for (int j = 0; j <= ny; j++) {
    for (int i = 0; i <= nx; i++) col[i] = tmp[i][j];
    ro_power_to_bernstein_1d(col, nx, out);
    for (int i = 0; i <= nx; i++) b[i][j] = out[i];
  }
}

#endif
