/* Tensor-product Bernstein polynomials: the arena, construction, and the operations that are
 * exact in real arithmetic (add, multiply, elevate, differentiate, subdivide), each with the
 * propagation of the coefficient error radius `err` (paper Sec. 4.1, DESIGN 3.1).
 *
 * Error bookkeeping. Every operation below computes each output coefficient as a sum of
 * products w * c of input coefficients with weights w that, in exact arithmetic, are
 * non-negative and sum to at most 1 (elevation, de Casteljau, the scaled-form product) or
 * are small integers (derivative). In floating point every path of the computation picks up
 * at most K factors (1 + delta), |delta| <= u, so the computed coefficient is within
 * gamma_K * sum |w c| <= gamma_K * max|c| of the exact one (Higham, Lemma 3.1 and
 * Sec. 3.1). That term plus the propagated input radii, all summed with upward rounding,
 * is the output radius. The K of each operation is derived next to it. */
#include "bbc/bernstein.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <threads.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "bernstein_internal.h"
#include "rounding_internal.h"

#define NAX BBC_POLY_MAX_AXES
#define MAXD BBC_POLY_MAX_DEGREE

/* ---- Binomial coefficients ---------------------------------------------------------- */

__extension__ typedef unsigned __int128 bbc__u128;

static double binomial_table[MAXD + 1][MAXD + 1];
static once_flag binomial_once = ONCE_FLAG_INIT;

/* Round-to-nearest-even conversion of a 128-bit integer, written out so that the relative
 * error u per binomial that the error bounds assume does not depend on the compiler's
 * runtime library. */
static double u128_to_double(bbc__u128 v) {
  int bits = 0;
  for (bbc__u128 t = v; t; t >>= 1) bits++;
  if (bits <= 53) return (double)(uint64_t)v;
  int shift = bits - 53;
  bbc__u128 mant = v >> shift;
  bbc__u128 rem = v & ((((bbc__u128)1) << shift) - 1);
  bbc__u128 half = ((bbc__u128)1) << (shift - 1);
  if (rem > half || (rem == half && (mant & 1))) mant++;
  return ldexp((double)(uint64_t)mant, shift);
}

static void binomial_init(void) {
  /* C(n, k+1) = C(n, k) (n - k) / (k + 1) is an exact integer division; the largest
   * intermediate, C(120, 60) * 120 < 1.2e37, fits in 128 bits. */
  for (int n = 0; n <= MAXD; n++) {
    bbc__u128 v = 1;
    for (int k = 0; k <= n; k++) {
      binomial_table[n][k] = u128_to_double(v);
      if (k < n) v = v * (bbc__u128)(n - k) / (bbc__u128)(k + 1);
    }
  }
}

const double *bbc__binomial_row(int n) {
  call_once(&binomial_once, binomial_init);
  return binomial_table[n];
}

/* ---- Arena -------------------------------------------------------------------------- */

void bbc_arena_init(bbc_arena *arena, void *buffer, size_t capacity) {
  if (!arena) return;
  arena->base = (unsigned char *)buffer;
  arena->capacity = buffer ? capacity : 0;
  arena->used = 0;
  arena->peak = 0;
}

void *bbc_arena_alloc(bbc_arena *arena, size_t bytes) {
  if (!arena || !arena->base) return NULL;
  uintptr_t at = (uintptr_t)(arena->base + arena->used);
  size_t pad = (size_t)((16u - (at & 15u)) & 15u);
  if (pad > arena->capacity - arena->used) return NULL;
  size_t off = arena->used + pad;
  if (bytes > arena->capacity - off) return NULL;
  arena->used = off + bytes;
  if (arena->used > arena->peak) arena->peak = arena->used;
  return arena->base + off;
}

size_t bbc_arena_mark(const bbc_arena *arena) {
  return arena ? arena->used : 0;
}

void bbc_arena_reset(bbc_arena *arena, size_t mark) {
  if (arena && mark <= arena->used) arena->used = mark;
}

/* ---- Tensor helpers ----------------------------------------------------------------- */

size_t bbc__strides(const unsigned char deg[NAX], size_t stride[NAX]) {
  size_t s = 1;
  for (int j = NAX - 1; j >= 0; j--) {
    stride[j] = s;
    s *= (size_t)deg[j] + 1;
  }
  return s;
}

double bbc__maxabs(const double *c, size_t n) {
  double m = 0.0;
  size_t i = 0;
#ifdef __SSE2__
  /* Two lanes at a time; the maximum of finite values does not depend on the order. */
  const __m128d absmask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
  const __m128d inf = _mm_set1_pd(INFINITY);
  __m128d vm = _mm_setzero_pd(), finite = _mm_cmpeq_pd(vm, vm);
  __m128d vm2 = vm, finite2 = finite; /* four lanes per step, in two pairs */
  for (; i + 4 <= n; i += 4) {
    __m128d a = _mm_and_pd(_mm_loadu_pd(c + i), absmask);
    __m128d b = _mm_and_pd(_mm_loadu_pd(c + i + 2), absmask);
    finite = _mm_and_pd(finite, _mm_cmplt_pd(a, inf)); /* false for inf and NaN */
    finite2 = _mm_and_pd(finite2, _mm_cmplt_pd(b, inf));
    vm = _mm_max_pd(vm, a);
    vm2 = _mm_max_pd(vm2, b);
  }
  for (; i + 2 <= n; i += 2) {
    __m128d a = _mm_and_pd(_mm_loadu_pd(c + i), absmask);
    finite = _mm_and_pd(finite, _mm_cmplt_pd(a, inf));
    vm = _mm_max_pd(vm, a);
  }
  finite = _mm_and_pd(finite, finite2);
  vm = _mm_max_pd(vm, vm2);
  if (_mm_movemask_pd(finite) != 3) return INFINITY;
  double lanes[2];
  _mm_storeu_pd(lanes, vm);
  m = lanes[0] > lanes[1] ? lanes[0] : lanes[1];
#endif
  for (; i < n; i++) {
    double a = fabs(c[i]);
    if (!(a <= m)) {
      if (!(a < INFINITY)) return INFINITY; /* inf or NaN */
      m = a;
    }
  }
  return m;
}

bbc_result bbc__alloc_coef(bbc_arena *arena, const unsigned char deg[NAX], double **out) {
  size_t n = bbc__size(deg);
  double *c = (double *)bbc_arena_alloc(arena, n * sizeof(double));
  if (!c) return BBC_ERR_OUT_OF_MEMORY;
  *out = c;
  return BBC_OK;
}

/* pre = product of the dimensions before `axis`, post = after it. */
static void split_dims(const unsigned char deg[NAX], int axis, size_t *pre, size_t *post) {
  size_t a = 1, b = 1;
  for (int j = 0; j < axis; j++) a *= (size_t)deg[j] + 1;
  for (int j = axis + 1; j < NAX; j++) b *= (size_t)deg[j] + 1;
  *pre = a;
  *post = b;
}

/* The non-zero band of each row of a rows x cols matrix: columns band_lo[k]..band_hi[k]
 * (an empty band has hi < lo). */
static void find_bands(const double *m, int rows, int cols, int *band_lo, int *band_hi) {
  for (int k = 0; k < rows; k++) {
    const double *w = m + (size_t)k * cols;
    int lo = 0, hi = -1;
    for (int j = 0; j < cols; j++) {
      if (w[j] != 0.0) {
        if (hi < 0) lo = j;
        hi = j;
      }
    }
    band_lo[k] = lo;
    band_hi[k] = hi;
  }
}

/* bbc__axis_apply with the bands of m already found. */
static void axis_apply_banded(const double *in, const unsigned char deg[NAX], int axis,
                              const double *m, int rows, const int *band_lo, const int *band_hi,
                              double *out);

void bbc__axis_apply(const double *in, const unsigned char deg[NAX], int axis, const double *m,
                     int rows, double *out) {
  /* The non-zero band of each row (elevation matrices are banded), found once, so that the
   * inner loops need no test. Adding an exact 0 * x inside a band changes no rounding. */
  int band_lo[MAXD + 1], band_hi[MAXD + 1];
  find_bands(m, rows, (int)deg[axis] + 1, band_lo, band_hi);
  axis_apply_banded(in, deg, axis, m, rows, band_lo, band_hi, out);
}

/* Rows of `post` contiguous coefficients (post a small constant): each output row is
 * accumulated in registers from 0 over the band in column order, the same sums as the
 * general loop below. */
#define APPLY_POST(P)                                                                     \
  static void apply_post_##P(const double *restrict in, const double *m, size_t cols,    \
                             int rows, const int *band_lo, const int *band_hi, size_t pre, \
                             double *restrict out) {                                      \
    for (size_t p = 0; p < pre; p++) {                                                    \
      const double *src = in + p * cols * P;                                              \
      double *dst = out + p * (size_t)rows * P;                                           \
      for (int k = 0; k < rows; k++) {                                                    \
        double acc[P];                                                                    \
        for (int t = 0; t < P; t++) acc[t] = 0.0;                                         \
        for (int j = band_lo[k]; j <= band_hi[k]; j++) {                                  \
          const double w = m[(size_t)k * cols + (size_t)j];                               \
          const double *s = src + (size_t)j * P;                                          \
          for (int t = 0; t < P; t++) acc[t] += w * s[t];                                 \
        }                                                                                 \
        for (int t = 0; t < P; t++) dst[(size_t)k * P + t] = acc[t];                      \
      }                                                                                   \
    }                                                                                     \
  }
APPLY_POST(2)
APPLY_POST(3)
APPLY_POST(4)
APPLY_POST(5)
APPLY_POST(6)
APPLY_POST(7)
APPLY_POST(8)
#define APPLY_POST_CASE(P)                                                \
  case P:                                                                 \
    apply_post_##P(in, m, cols, rows, band_lo, band_hi, pre, out);        \
    return

static void axis_apply_banded(const double *in, const unsigned char deg[NAX], int axis,
                              const double *m, int rows, const int *band_lo, const int *band_hi,
                              double *out) {
  size_t pre, post;
  split_dims(deg, axis, &pre, &post);
  size_t cols = (size_t)deg[axis] + 1;
  if (post == 1) {
    /* The contiguous axis: plain dot products. */
    for (size_t p = 0; p < pre; p++) {
      const double *src = in + p * cols;
      double *dst = out + p * (size_t)rows;
      for (int k = 0; k < rows; k++) {
        const double *w = m + (size_t)k * cols;
        double acc = 0.0;
        for (int j = band_lo[k]; j <= band_hi[k]; j++) acc += w[j] * src[j];
        dst[k] = acc;
      }
    }
    return;
  }
  switch (post) {
    APPLY_POST_CASE(2);
    APPLY_POST_CASE(3);
    APPLY_POST_CASE(4);
    APPLY_POST_CASE(5);
    APPLY_POST_CASE(6);
    APPLY_POST_CASE(7);
    APPLY_POST_CASE(8);
    default:
      break;
  }
  for (size_t p = 0; p < pre; p++) {
    const double *src = in + p * cols * post;
    double *dst = out + p * (size_t)rows * post;
    for (int k = 0; k < rows; k++) {
      double *d = dst + (size_t)k * post;
      for (size_t t = 0; t < post; t++) d[t] = 0.0;
      for (int j = band_lo[k]; j <= band_hi[k]; j++) {
        double w = m[(size_t)k * cols + (size_t)j];
        const double *s = src + (size_t)j * post;
        for (size_t t = 0; t < post; t++) d[t] += w * s[t];
      }
    }
  }
}

static int poly_ok(const bbc_poly *p) {
  return bbc__poly_ok(p);
}

static int axis_ok(int axis) {
  return axis >= 0 && axis < NAX;
}

/* Multiplies (or divides) every coefficient by C(deg[axis], i_axis), for every axis. One
 * rounding for the binomial and one for the product per axis: 2 per active axis. */
static void scale_by_binomials(double *c, const unsigned char deg[NAX], int divide) {
  for (int j = 0; j < NAX; j++) {
    int n = deg[j];
    if (n == 0) continue;
    const double *row = bbc__binomial_row(n);
    size_t pre, post;
    split_dims(deg, j, &pre, &post);
    for (size_t p = 0; p < pre; p++) {
      for (int i = 0; i <= n; i++) {
        double *x = c + (p * (size_t)(n + 1) + (size_t)i) * post;
        double f = row[i];
        if (f == 1.0) continue;
        if (divide) {
          for (size_t t = 0; t < post; t++) x[t] /= f;
        } else {
          for (size_t t = 0; t < post; t++) x[t] *= f;
        }
      }
    }
  }
}

static int count_active(const unsigned char deg[NAX]) {
  int m = 0;
  for (int j = 0; j < NAX; j++) m += deg[j] > 0;
  return m;
}

/* ---- Elevation and linear combinations ----------------------------------------------- */

/* The (t+1) x (n+1) matrix of elevation from degree n to t along one axis:
 * C(n, j) C(t-n, k-j) / C(t, k). Its rows are non-negative and sum to 1. Each entry carries
 * three binomial roundings and two operation roundings. */
static void elevation_matrix(int n, int t, double *m) {
  int r = t - n;
  const double *cn = bbc__binomial_row(n), *cr = bbc__binomial_row(r), *ct = bbc__binomial_row(t);
  for (int k = 0; k <= t; k++)
    for (int j = 0; j <= n; j++)
      m[(size_t)k * (n + 1) + j] = (j <= k && k - j <= r) ? cn[j] * cr[k - j] / ct[k] : 0.0;
}

/* The elevation matrices with their bands depend only on (n, t): computed once per process
 * and shared, published with a compare-and-swap (a thread that loses the race frees its
 * copy; the matrices are deterministic, so which copy wins does not matter). */
typedef struct elevation {
  const double *m;
  const int *band_lo, *band_hi;
} elevation;

static _Atomic(elevation *) elevation_cache[MAXD + 1][MAXD + 1];

/* NULL when memory is short (the caller then builds the matrix itself). */
static const elevation *cached_elevation(int n, int t) {
  elevation *e = atomic_load_explicit(&elevation_cache[n][t], memory_order_acquire);
  if (e) return e;
  size_t rows = (size_t)t + 1, cols = (size_t)n + 1;
  unsigned char *block =
      malloc(sizeof(elevation) + rows * cols * sizeof(double) + 2 * rows * sizeof(int));
  if (!block) return NULL;
  elevation *fresh = (elevation *)block;
  double *m = (double *)(block + sizeof(elevation));
  int *lo = (int *)(m + rows * cols), *hi = lo + rows;
  elevation_matrix(n, t, m);
  find_bands(m, (int)rows, (int)cols, lo, hi);
  fresh->m = m;
  fresh->band_lo = lo;
  fresh->band_hi = hi;
  elevation *expected = NULL;
  if (atomic_compare_exchange_strong_explicit(&elevation_cache[n][t], &expected, fresh,
                                              memory_order_acq_rel, memory_order_acquire))
    return fresh;
  free(block);
  return expected;
}

bbc_result bbc__elevate_into(bbc_arena *arena, const bbc_poly *p, const unsigned char deg[NAX],
                             double *dst, double *err) {
  unsigned char cur[NAX];
  memcpy(cur, p->deg, NAX);
  int axes[NAX], naxes = 0;
  for (int j = 0; j < NAX; j++)
    if (deg[j] > cur[j]) axes[naxes++] = j;
  size_t size = bbc__size(cur);
  if (naxes == 0) {
    if (dst != p->coef) memcpy(dst, p->coef, size * sizeof(double));
    *err = bbc__radius(p->err);
    return BBC_OK;
  }
  size_t mark = bbc_arena_mark(arena);
  const double *src = p->coef;
  double e = bbc__radius(p->err);
  double m = bbc__maxabs(p->coef, size);
  for (int a = 0; a < naxes; a++) {
    int j = axes[a], n = cur[j], t = deg[j];
    unsigned char next[NAX];
    memcpy(next, cur, NAX);
    next[j] = (unsigned char)t;
    const elevation *cached = cached_elevation(n, t);
    double *mat = NULL;
    if (!cached) mat = (double *)bbc_arena_alloc(arena, sizeof(double) * (size_t)(t + 1) * (n + 1));
    double *out = dst;
    if (a + 1 < naxes) out = (double *)bbc_arena_alloc(arena, sizeof(double) * bbc__size(next));
    if ((!cached && !mat) || !out) {
      bbc_arena_reset(arena, mark);
      return BBC_ERR_OUT_OF_MEMORY;
    }
    if (cached) {
      axis_apply_banded(src, cur, j, cached->m, t + 1, cached->band_lo, cached->band_hi, out);
    } else {
      elevation_matrix(n, t, mat);
      bbc__axis_apply(src, cur, j, mat, t + 1, out);
    }
    /* K = 5 (matrix entry) + 1 (product) + (terms - 1) (sum), terms <= min(n, t - n) + 1. */
    int terms = (n < t - n ? n : t - n) + 1;
    double pass = bbc__mul_up(bbc__gamma(5 + terms), m);
    e = bbc__add_up(e, pass);
    m = bbc__add_up(m, pass); /* |computed| <= |exact| + error <= m + pass */
    src = out;
    memcpy(cur, next, NAX);
  }
  bbc_arena_reset(arena, mark);
  *err = bbc__radius(e);
  return BBC_OK;
}

bbc_result bbc__lincomb_into(bbc_arena *arena, int n, const double *alpha, const bbc_poly *const *p,
                             const unsigned char deg[NAX], double *dst, double *err) {
  size_t size = bbc__size(deg);
  double e = 0.0, mt = 0.0;
  for (int k = 0; k < n; k++) {
    size_t mark = bbc_arena_mark(arena);
    const double *src = p[k]->coef;
    double ek = bbc__radius(p[k]->err);
    if (memcmp(p[k]->deg, deg, NAX) != 0) {
      double *tmp = (double *)bbc_arena_alloc(arena, size * sizeof(double));
      if (!tmp) return BBC_ERR_OUT_OF_MEMORY;
      bbc_result r = bbc__elevate_into(arena, p[k], deg, tmp, &ek);
      if (r != BBC_OK) {
        bbc_arena_reset(arena, mark);
        return r;
      }
      src = tmp;
    }
    double a = alpha[k];
    double mk = bbc__maxabs(src, size);
    if (k == 0) {
      for (size_t i = 0; i < size; i++) dst[i] = a * src[i];
    } else {
      for (size_t i = 0; i < size; i++) dst[i] += a * src[i];
    }
    e = bbc__add_up(e, bbc__mul_up(fabs(a), ek));
    mt = bbc__add_up(mt, bbc__mul_up(fabs(a), mk));
    bbc_arena_reset(arena, mark);
  }
  /* Each term passes one product and at most n - 1 sums: K = n. */
  e = bbc__add_up(e, bbc__mul_up(bbc__gamma(n), mt));
  *err = bbc__radius(e);
  return BBC_OK;
}

/* ---- Construction ------------------------------------------------------------------- */

size_t bbc_poly_size(const bbc_poly *p) {
  return p ? bbc__size(p->deg) : 0;
}

bbc_result bbc_poly_constant(bbc_arena *arena, bbc_poly *out, double value) {
  if (!out) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  r.coef[0] = value;
  r.err = isfinite(value) ? 0.0 : INFINITY;
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_linear(bbc_arena *arena, bbc_poly *out, int axis, double v0, double v1) {
  if (!out || !axis_ok(axis)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  r.deg[axis] = 1;
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  r.coef[0] = v0;
  r.coef[1] = v1;
  r.err = (isfinite(v0) && isfinite(v1)) ? 0.0 : INFINITY;
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_affine(bbc_arena *arena, bbc_poly *out, double c, const double grad[NAX]) {
  if (!out || !grad) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  int k = 0;
  double sum_abs = fabs(c);
  for (int j = 0; j < NAX; j++) {
    if (grad[j] != 0.0) {
      r.deg[j] = 1;
      k++;
      sum_abs = bbc__add_up(sum_abs, fabs(grad[j]));
    }
  }
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  size_t size = bbc__size(r.deg);
  /* Coefficient at a corner = c + sum of the gradients of the axes at their 1 end; the
   * index bits of the degree-1 axes, last axis fastest, name the corner. */
  int inexact = 0;
  for (size_t i = 0; i < size; i++) {
    double v = c;
    size_t rest = i;
    for (int j = NAX - 1; j >= 0; j--) {
      if (!r.deg[j]) continue;
      if (rest & 1u) {
        /* TwoSum (Knuth): the rounding error of v + g, exactly; zero means exact. */
        double g = grad[j], s = v + g, gv = s - v;
        if ((v - (s - gv)) + (g - gv) != 0.0) inexact = 1;
        v = s;
      }
      rest >>= 1;
    }
    r.coef[i] = v;
  }
  /* At most k sums per corner: gamma_k times the sum of the magnitudes, or nothing when
   * every sum was exact (the common case of short dyadic inputs, and any k <= 1 with
   * c = 0). */
  r.err = inexact ? bbc__radius(bbc__mul_up(bbc__gamma(k), sum_abs)) : 0.0;
  if (!(sum_abs < INFINITY)) r.err = INFINITY;
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_copy(bbc_arena *arena, bbc_poly *out, const bbc_poly *p) {
  if (!out || !poly_ok(p)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r = *p;
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  memcpy(r.coef, p->coef, bbc__size(r.deg) * sizeof(double));
  *out = r;
  return BBC_OK;
}

void bbc_poly_widen(bbc_poly *p, double radius) {
  if (!p) return;
  p->err = bbc__radius(bbc__add_up(bbc__radius(p->err), bbc__radius(fabs(radius))));
}

/* ---- Arithmetic --------------------------------------------------------------------- */

static void max_degrees(int n, const bbc_poly *const *p, unsigned char deg[NAX]) {
  memset(deg, 0, NAX);
  for (int k = 0; k < n; k++)
    for (int j = 0; j < NAX; j++)
      if (p[k]->deg[j] > deg[j]) deg[j] = p[k]->deg[j];
}

bbc_result bbc_poly_lincomb(bbc_arena *arena, bbc_poly *out, int n, const double *alpha,
                            const bbc_poly *const *p) {
  if (!out || n < 1 || !alpha || !p) return BBC_ERR_INVALID_ARGUMENT;
  for (int k = 0; k < n; k++)
    if (!poly_ok(p[k])) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  max_degrees(n, p, r.deg);
  size_t mark = bbc_arena_mark(arena);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  bbc_result res = bbc__lincomb_into(arena, n, alpha, p, r.deg, r.coef, &r.err);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_add(bbc_arena *arena, bbc_poly *out, const bbc_poly *a, const bbc_poly *b) {
  const bbc_poly *p[2] = {a, b};
  const double alpha[2] = {1.0, 1.0};
  return bbc_poly_lincomb(arena, out, 2, alpha, p);
}

bbc_result bbc_poly_sub(bbc_arena *arena, bbc_poly *out, const bbc_poly *a, const bbc_poly *b) {
  const bbc_poly *p[2] = {a, b};
  const double alpha[2] = {1.0, -1.0};
  return bbc_poly_lincomb(arena, out, 2, alpha, p);
}

bbc_result bbc_poly_scale(bbc_arena *arena, bbc_poly *out, const bbc_poly *p, double s) {
  if (!out || !poly_ok(p)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r = *p;
  size_t size = bbc__size(r.deg);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  for (size_t i = 0; i < size; i++) r.coef[i] = s * p->coef[i];
  if (s == 0.0) {
    r.err = 0.0; /* the exact result is the zero polynomial whatever p is */
  } else {
    double m = bbc__maxabs(p->coef, size);
    double e = bbc__mul_up(fabs(s), bbc__radius(p->err));
    e = bbc__add_up(e, bbc__mul_up(bbc__gamma(1), bbc__mul_up(fabs(s), m)));
    r.err = bbc__radius(e);
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_add_scalar(bbc_arena *arena, bbc_poly *out, const bbc_poly *p, double s) {
  if (!out || !poly_ok(p)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r = *p;
  size_t size = bbc__size(r.deg);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  for (size_t i = 0; i < size; i++) r.coef[i] = p->coef[i] + s;
  double m = bbc__add_up(bbc__maxabs(p->coef, size), fabs(s));
  r.err = bbc__radius(bbc__add_up(bbc__radius(p->err), bbc__mul_up(bbc__gamma(1), m)));
  *out = r;
  return BBC_OK;
}

/* a * b into dst (degree deg = a.deg + b.deg). Scaled Bernstein form: a_i C(n, i) and
 * b_j C(m, j) are convolved and the sum for k divided by C(n + m, k), per axis, which is
 * the exact product (the weights C(n,i) C(m,j) / C(n+m,k) are >= 0 and sum to 1 over
 * i + j = k by Vandermonde's identity). */
static void mul_general(bbc_arena *arena, const bbc_poly *a, const bbc_poly *b,
                        const unsigned char deg[NAX], double *dst, bbc_result *status);

/* ---- Products on the last two axes --------------------------------------------------- */

/* Most products of a piece's computation have every degree on the two geometric axes of
 * the piece (the last two axes; remainders are flattened away). mul2_kernel is the
 * general product below restricted to that case and done with the same operations in the
 * same order, so its coefficients are the same doubles: a_ij C(a0, i) C(a1, j) (axis 6's
 * factor first), likewise b, the convolution accumulated from 0 in a's coefficient order
 * with zero a-coefficients skipped, then the division by C(o0, k) and then by C(o1, l).
 * (x * 1 and x / 1 are exact, so the general code's skipping of unit binomials changes
 * nothing.) The degrees are compile-time constants for the common shapes, whose loops the
 * compiler then unrolls and vectorises; the operands stay on the stack. */
#define MUL2_MAXF 15

/* The kernels are also compiled for AVX2 and chosen at load time where the processor has
 * it: wider vectors for the same operations (no fused multiply-add, which the build
 * forbids with -ffp-contract=off), hence the same bits. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(BBC_NO_CLONES)
#define BBC__KERNEL __attribute__((noinline, target_clones("avx2", "default")))
#else
#define BBC__KERNEL __attribute__((noinline))
#endif

/* The binomials of a tensor of degrees (n0, n1) on the last two axes, one per
 * coefficient in its order: f[m] = C(n0, m / (n1 + 1)) and f[size + m] = C(n1, m % (n1 +
 * 1)). With them the kernel's scalings and divisions are flat loops over the coefficients
 * (vectorised, where the row-by-row loops ran as scalar divisions), the same operations on
 * the same doubles. Built once per process and shape, published with a compare-and-swap
 * like the elevation matrices; built on the caller's stack when memory is short. */
#define MUL2_MAXO (2 * MUL2_MAXF)
static _Atomic(double *) mul2_factor_cache[MUL2_MAXO + 1][MUL2_MAXO + 1];

static void mul2_factors_fill(int n0, int n1, double *f) {
  const int rows = n0 + 1, cols = n1 + 1, size = rows * cols;
  for (int i = 0; i < rows; i++)
    for (int j = 0; j < cols; j++) {
      f[i * cols + j] = binomial_table[n0][i];
      f[size + i * cols + j] = binomial_table[n1][j];
    }
}

static __attribute__((noinline)) const double *mul2_factors_build(int n0, int n1,
                                                                   double *fallback) {
  double *fresh = malloc(2 * (size_t)(n0 + 1) * (size_t)(n1 + 1) * sizeof *fresh);
  if (!fresh) {
    mul2_factors_fill(n0, n1, fallback);
    return fallback;
  }
  mul2_factors_fill(n0, n1, fresh);
  double *expected = NULL;
  if (atomic_compare_exchange_strong_explicit(&mul2_factor_cache[n0][n1], &expected, fresh,
                                              memory_order_acq_rel, memory_order_acquire))
    return fresh;
  free(fresh);
  return expected;
}

static inline const double *mul2_factors(int n0, int n1, double *fallback) {
  double *f = atomic_load_explicit(&mul2_factor_cache[n0][n1], memory_order_acquire);
  return f ? f : mul2_factors_build(n0, n1, fallback);
}

static inline __attribute__((always_inline)) void mul2_kernel(const double *restrict a,
                                                              const double *restrict b,
                                                              double *restrict dst, int a0,
                                                              int a1, int b0, int b1) {
  const int o0 = a0 + b0, o1 = a1 + b1;
  const int ra = a1 + 1, rb = b1 + 1, ro = o1 + 1;
  const int na = (a0 + 1) * ra, nb = (b0 + 1) * rb, no = (o0 + 1) * ro;
  double fa_local[2 * (MUL2_MAXF + 1) * (MUL2_MAXF + 1)];
  double fb_local[2 * (MUL2_MAXF + 1) * (MUL2_MAXF + 1)];
  double fo_local[2 * (MUL2_MAXO + 1) * (MUL2_MAXO + 1)];
  const double *restrict fa = mul2_factors(a0, a1, fa_local);
  const double *restrict fb = mul2_factors(b0, b1, fb_local);
  const double *restrict fo = mul2_factors(o0, o1, fo_local);
  double ta[(MUL2_MAXF + 1) * (MUL2_MAXF + 1)], tb[(MUL2_MAXF + 1) * (MUL2_MAXF + 1)];
  for (int m = 0; m < na; m++) ta[m] = (a[m] * fa[m]) * fa[na + m];
  for (int m = 0; m < nb; m++) tb[m] = (b[m] * fb[m]) * fb[nb + m];
  for (int k = 0; k < no; k++) dst[k] = 0.0;
  for (int i = 0; i <= a0; i++) {
    for (int j = 0; j <= a1; j++) {
      const double va = ta[i * ra + j];
      if (va == 0.0) continue;
      for (int r = 0; r <= b0; r++) {
        double *d = dst + (i + r) * ro + j;
        const double *sb = tb + r * rb;
        for (int t = 0; t <= b1; t++) d[t] += va * sb[t];
      }
    }
  }
  for (int m = 0; m < no; m++) dst[m] = (dst[m] / fo[m]) / fo[no + m];
}

static BBC__KERNEL void mul2_any(const double *a, const double *b, double *dst,
                                               int a0, int a1, int b0, int b1) {
  mul2_kernel(a, b, dst, a0, a1, b0, b1);
}

#define MUL2_KEY(a0, a1, b0, b1) (((a0) << 12) | ((a1) << 8) | ((b0) << 4) | (b1))
#define MUL2_CASE(a0, a1, b0, b1)                    \
  case MUL2_KEY(a0, a1, b0, b1):                     \
    mul2_kernel(a, b, dst, a0, a1, b0, b1);          \
    return

/* The shapes of a double-scattering piece at the flattening degree 3 (products of
 * flattened quantities, their derivatives and constants), most frequent first, then
 * those of single reflection. */
static BBC__KERNEL void mul2(const double *a, const double *b, double *dst, int a0, int a1, int b0, int b1) {
  switch (MUL2_KEY(a0, a1, b0, b1)) {
    MUL2_CASE(3, 3, 3, 3);
    MUL2_CASE(3, 3, 0, 0);
    MUL2_CASE(1, 1, 1, 1);
    MUL2_CASE(1, 1, 0, 0);
    MUL2_CASE(6, 6, 3, 3);
    MUL2_CASE(3, 3, 1, 1);
    MUL2_CASE(1, 1, 3, 3);
    MUL2_CASE(4, 4, 0, 0);
    MUL2_CASE(2, 2, 1, 1);
    MUL2_CASE(0, 0, 1, 1);
    MUL2_CASE(2, 2, 0, 0);
    MUL2_CASE(0, 0, 3, 3);
    MUL2_CASE(2, 2, 2, 2);
    MUL2_CASE(6, 6, 6, 6);
    MUL2_CASE(3, 3, 6, 6);
    MUL2_CASE(7, 7, 1, 1);
    /* Single reflection's irradiance (Eq. 16; an interpolated normal makes p, r of
     * degree 4 and q of degree 3, their derivatives one lower on their axis). */
    MUL2_CASE(4, 4, 6, 6);
    MUL2_CASE(3, 2, 3, 4);
    MUL2_CASE(2, 3, 4, 3);
    MUL2_CASE(4, 3, 3, 4);
    MUL2_CASE(3, 4, 4, 3);
    MUL2_CASE(3, 3, 7, 7);
    MUL2_CASE(2, 2, 10, 10);
    default:
      mul2_any(a, b, dst, a0, a1, b0, b1);
  }
}

/* The same product for operands with at most four active axes in all (any axes), the
 * tensors seen through those axes only (an axis of degree 0 contributes a factor 1 to
 * every size and index). Same operations in the same order as the general code. */
#define MULN_AXES 4

/* ta and tb hold the scaled operands (as many coefficients as a and b). */
static inline __attribute__((always_inline)) void muln_kernel(
    const double *restrict a, const double *restrict b, double *restrict dst,
    double *restrict ta, double *restrict tb, int a0, int a1, int a2, int a3, int b0, int b1,
    int b2, int b3) {
  const int da[MULN_AXES] = {a0, a1, a2, a3}, db[MULN_AXES] = {b0, b1, b2, b3};
  int dout[MULN_AXES];
  for (int k = 0; k < MULN_AXES; k++) dout[k] = da[k] + db[k];
  /* a's and b's coefficients times their binomials, axis by axis in axis order. */
  const double *src[2] = {a, b};
  double *to[2] = {ta, tb};
  const int *dd[2] = {da, db};
  for (int w = 0; w < 2; w++) {
    const int *d = dd[w];
    const double *c0 = binomial_table[d[0]], *c1 = binomial_table[d[1]];
    const double *c2 = binomial_table[d[2]], *c3 = binomial_table[d[3]];
    size_t i = 0;
    for (int i0 = 0; i0 <= d[0]; i0++)
      for (int i1 = 0; i1 <= d[1]; i1++)
        for (int i2 = 0; i2 <= d[2]; i2++)
          for (int i3 = 0; i3 <= d[3]; i3++, i++)
            to[w][i] = (((src[w][i] * c0[i0]) * c1[i1]) * c2[i2]) * c3[i3];
  }
  const size_t s3 = 1, s2 = (size_t)dout[3] + 1, s1 = s2 * ((size_t)dout[2] + 1),
               s0 = s1 * ((size_t)dout[1] + 1), size = s0 * ((size_t)dout[0] + 1);
  (void)s3;
  for (size_t k = 0; k < size; k++) dst[k] = 0.0;
  const int run = db[3] + 1;
  size_t ia = 0;
  for (int i0 = 0; i0 <= da[0]; i0++)
    for (int i1 = 0; i1 <= da[1]; i1++)
      for (int i2 = 0; i2 <= da[2]; i2++)
        for (int i3 = 0; i3 <= da[3]; i3++, ia++) {
          const double va = ta[ia];
          if (va == 0.0) continue;
          const double *sb = tb;
          for (int r0 = 0; r0 <= db[0]; r0++)
            for (int r1 = 0; r1 <= db[1]; r1++)
              for (int r2 = 0; r2 <= db[2]; r2++, sb += run) {
                double *d = dst + (size_t)(i0 + r0) * s0 + (size_t)(i1 + r1) * s1 +
                            (size_t)(i2 + r2) * s2 + (size_t)i3;
                for (int t = 0; t < run; t++) d[t] += va * sb[t];
              }
        }
  const double *c0 = binomial_table[dout[0]], *c1 = binomial_table[dout[1]];
  const double *c2 = binomial_table[dout[2]], *c3 = binomial_table[dout[3]];
  size_t k = 0;
  for (int k0 = 0; k0 <= dout[0]; k0++)
    for (int k1 = 0; k1 <= dout[1]; k1++)
      for (int k2 = 0; k2 <= dout[2]; k2++)
        for (int k3 = 0; k3 <= dout[3]; k3++, k++)
          dst[k] = (((dst[k] / c0[k0]) / c1[k1]) / c2[k2]) / c3[k3];
}

static BBC__KERNEL void muln_any(const double *a, const double *b, double *dst, double *ta,
                                 double *tb, const int da[MULN_AXES], const int db[MULN_AXES]) {
  muln_kernel(a, b, dst, ta, tb, da[0], da[1], da[2], da[3], db[0], db[1], db[2], db[3]);
}

/* Six bits per degree (the shapes below have degrees up to 16). */
#define MULN_KEY(a0, a1, a2, a3, b0, b1, b2, b3)                                             \
  (((uint64_t)(a0) << 42) | ((uint64_t)(a1) << 36) | ((uint64_t)(a2) << 30) |              \
   ((uint64_t)(a3) << 24) | ((uint64_t)(b0) << 18) | ((uint64_t)(b1) << 12) |              \
   ((uint64_t)(b2) << 6) | (uint64_t)(b3))
#define MULN_CASE(a0, a1, a2, a3, b0, b1, b2, b3)            \
  case MULN_KEY(a0, a1, a2, a3, b0, b1, b2, b3):             \
    muln_kernel(a, b, dst, ta, tb, a0, a1, a2, a3, b0, b1, b2, b3); \
    return

/* The common shapes: the explicit Jacobian of single refraction with interpolated normals
 * (the slope remainder of sqrt(beta) and the piece's two axes: the determinant's products,
 * then the products of its forms), the same with the value remainder on an axis too (no
 * longer made by the bounder), then the implicit differentiation (the receiver's two
 * barycentrics as extra axes, Eq. 17-19) at the flattening degree 3, by their share of
 * the work. */
static BBC__KERNEL void muln(const double *a, const double *b, double *dst, double *ta,
                             double *tb, const int da[MULN_AXES], const int db[MULN_AXES]) {
  int small = 1;
  for (int k = 0; k < MULN_AXES; k++) small &= da[k] <= 63 && db[k] <= 63;
  if (small) {
    switch (MULN_KEY(da[0], da[1], da[2], da[3], db[0], db[1], db[2], db[3])) {
      MULN_CASE(0, 1, 6, 6, 0, 2, 10, 10);
      MULN_CASE(0, 1, 5, 5, 0, 2, 11, 11);
      MULN_CASE(0, 2, 10, 10, 0, 1, 5, 5);
      MULN_CASE(0, 0, 2, 2, 0, 3, 16, 16);
      MULN_CASE(0, 1, 5, 4, 0, 1, 5, 6);
      MULN_CASE(0, 1, 4, 5, 0, 1, 6, 5);
      MULN_CASE(0, 1, 6, 5, 0, 1, 5, 6);
      MULN_CASE(0, 1, 5, 6, 0, 1, 6, 5);
      MULN_CASE(0, 1, 5, 5, 0, 1, 5, 5);
      MULN_CASE(0, 0, 1, 1, 0, 1, 5, 5);
      MULN_CASE(0, 1, 4, 4, 0, 0, 1, 1);
      MULN_CASE(0, 1, 5, 5, 0, 0, 1, 1);
      MULN_CASE(0, 0, 1, 0, 0, 1, 5, 5);
      MULN_CASE(0, 0, 0, 1, 0, 1, 5, 5);
      MULN_CASE(0, 1, 5, 5, 0, 0, 1, 0);
      MULN_CASE(0, 1, 5, 5, 0, 0, 0, 1);
      MULN_CASE(1, 1, 6, 6, 2, 2, 10, 10);
      MULN_CASE(1, 1, 5, 5, 2, 2, 11, 11);
      MULN_CASE(2, 2, 10, 10, 1, 1, 5, 5);
      MULN_CASE(1, 1, 5, 4, 1, 1, 5, 6);
      MULN_CASE(1, 1, 4, 5, 1, 1, 6, 5);
      MULN_CASE(1, 1, 6, 5, 1, 1, 5, 6);
      MULN_CASE(1, 1, 5, 6, 1, 1, 6, 5);
      MULN_CASE(1, 1, 5, 5, 1, 1, 5, 5);
      MULN_CASE(1, 1, 3, 3, 1, 1, 3, 3);
      MULN_CASE(0, 0, 3, 3, 2, 2, 6, 6);
      MULN_CASE(2, 2, 3, 3, 0, 0, 6, 6);
      MULN_CASE(1, 1, 6, 6, 0, 0, 6, 6);
      MULN_CASE(2, 2, 3, 3, 1, 1, 3, 3);
      MULN_CASE(1, 1, 9, 9, 0, 0, 3, 3);
      MULN_CASE(1, 1, 3, 3, 0, 0, 3, 3);
      MULN_CASE(0, 0, 3, 3, 1, 1, 3, 3);
      MULN_CASE(0, 0, 6, 6, 1, 1, 3, 3);
      MULN_CASE(0, 1, 3, 3, 0, 1, 3, 3);
      MULN_CASE(0, 1, 3, 3, 0, 0, 3, 3);
      MULN_CASE(0, 0, 3, 3, 0, 1, 3, 3);
      /* Beams (bound/beam.c): the same products with the slab's axis l. Single
       * refraction, */
      MULN_CASE(1, 1, 6, 6, 2, 1, 10, 10);
      MULN_CASE(1, 0, 5, 5, 2, 2, 11, 11);
      MULN_CASE(0, 0, 2, 2, 3, 2, 16, 16);
      MULN_CASE(1, 0, 5, 4, 1, 1, 5, 6);
      MULN_CASE(1, 0, 4, 5, 1, 1, 6, 5);
      MULN_CASE(1, 0, 6, 6, 0, 1, 0, 0);
      MULN_CASE(0, 1, 1, 1, 1, 0, 5, 5);
      /* single reflection, */
      MULN_CASE(0, 1, 4, 4, 0, 1, 6, 6);
      MULN_CASE(0, 0, 2, 2, 0, 2, 10, 10);
      MULN_CASE(0, 0, 3, 3, 0, 2, 7, 7);
      MULN_CASE(0, 1, 4, 3, 0, 1, 3, 4);
      MULN_CASE(0, 1, 3, 4, 0, 1, 4, 3);
      /* two refractions. */
      MULN_CASE(0, 1, 6, 6, 0, 1, 12, 12);
      MULN_CASE(0, 0, 6, 6, 0, 2, 12, 12);
      MULN_CASE(0, 0, 6, 6, 0, 1, 6, 6);
      MULN_CASE(0, 1, 6, 6, 0, 1, 6, 6);
      MULN_CASE(0, 0, 2, 2, 0, 2, 18, 18);
      default:
        break;
    }
  }
  muln_any(a, b, dst, ta, tb, da, db);
}

/* The degrees of a and b on the at most MULN_AXES active axes of the output (deg), in axis
 * order, right-aligned (leading entries 0); 0 when there are more active axes or no active
 * axis (the general code multiplies two constants directly, without the accumulation from
 * 0). */
static int muln_shape(const bbc_poly *a, const bbc_poly *b, const unsigned char deg[NAX],
                      int da[MULN_AXES], int db[MULN_AXES]) {
  int m = 0;
  for (int j = 0; j < NAX; j++) m += deg[j] > 0;
  if (m == 0 || m > MULN_AXES) return 0;
  int k = MULN_AXES - m;
  for (int j = 0; j < k; j++) da[j] = db[j] = 0;
  for (int j = 0; j < NAX; j++) {
    if (!deg[j]) continue;
    da[k] = a->deg[j];
    db[k] = b->deg[j];
    k++;
  }
  return 1;
}

/* Whether a * b (output degrees deg) goes through mul2: degrees only on the last two axes,
 * the factors' within MUL2_MAXF, and not both constant (the general code multiplies two
 * constants directly, without the accumulation from 0). */
static int mul2_applies(const bbc_poly *a, const bbc_poly *b, const unsigned char deg[NAX]) {
  for (int j = 0; j < NAX - 2; j++)
    if (deg[j]) return 0;
  if (deg[NAX - 2] == 0 && deg[NAX - 1] == 0) return 0;
  return a->deg[NAX - 2] <= MUL2_MAXF && a->deg[NAX - 1] <= MUL2_MAXF &&
         b->deg[NAX - 2] <= MUL2_MAXF && b->deg[NAX - 1] <= MUL2_MAXF;
}

static bbc_result mul_into(bbc_arena *arena, const bbc_poly *a, const bbc_poly *b,
                           const unsigned char deg[NAX], double *dst, double *err) {
  size_t na = bbc__size(a->deg), nb = bbc__size(b->deg);
  if (mul2_applies(a, b, deg)) {
    (void)bbc__binomial_row(0); /* the table is built */
    mul2(a->coef, b->coef, dst, a->deg[NAX - 2], a->deg[NAX - 1], b->deg[NAX - 2],
         b->deg[NAX - 1]);
  } else {
    int da[MULN_AXES], db[MULN_AXES];
    if (muln_shape(a, b, deg, da, db)) {
      (void)bbc__binomial_row(0);
      size_t mark = bbc_arena_mark(arena);
      double *ta = (double *)bbc_arena_alloc(arena, na * sizeof(double));
      double *tb = (double *)bbc_arena_alloc(arena, nb * sizeof(double));
      if (!ta || !tb) {
        bbc_arena_reset(arena, mark);
        return BBC_ERR_OUT_OF_MEMORY;
      }
      muln(a->coef, b->coef, dst, ta, tb, da, db);
      bbc_arena_reset(arena, mark);
    } else {
      bbc_result status = BBC_OK;
      mul_general(arena, a, b, deg, dst, &status);
      if (status != BBC_OK) return status;
    }
  }

  /* K: 2 per active axis for scaling a, the same for b and for the final division, 1 for
   * the product and terms - 1 for the sum, terms = prod(min(n_j, m_j) + 1). */
  int active = count_active(deg);
  unsigned char least[NAX];
  for (int j = 0; j < NAX; j++) least[j] = a->deg[j] < b->deg[j] ? a->deg[j] : b->deg[j];
  double terms = (double)bbc__size(least); /* exact: below 2^53 */
  double k = 6.0 * active + terms + 1.0;
  double ma = bbc__maxabs(a->coef, na), mb = bbc__maxabs(b->coef, nb);
  double ea = bbc__radius(a->err), eb = bbc__radius(b->err);
  /* |A B - a b| <= |a| eb + |b| ea + ea eb coefficient-wise before rounding, then the
   * rounding of the convex combination. */
  double e = bbc__add_up(bbc__mul_up(ma, eb), bbc__mul_up(mb, ea));
  e = bbc__add_up(e, bbc__mul_up(ea, eb));
  e = bbc__add_up(e, bbc__mul_up(bbc__gamma(k), bbc__mul_up(ma, mb)));
  e = bbc__add_up(e, k * BBC__ETA);
  *err = bbc__radius(e);
  return BBC_OK;
}

/* The product for any shape (see mul_into); *status receives BBC_ERR_OUT_OF_MEMORY when
 * the arena cannot hold the scaled operands. */
static void mul_general(bbc_arena *arena, const bbc_poly *a, const bbc_poly *b,
                        const unsigned char deg[NAX], double *dst, bbc_result *status) {
  size_t mark = bbc_arena_mark(arena);
  size_t na = bbc__size(a->deg), nb = bbc__size(b->deg);
  size_t so[NAX];
  size_t size = bbc__strides(deg, so);
  double *ta = (double *)bbc_arena_alloc(arena, na * sizeof(double));
  double *tb = (double *)bbc_arena_alloc(arena, nb * sizeof(double));
  if (!ta || !tb) {
    bbc_arena_reset(arena, mark);
    *status = BBC_ERR_OUT_OF_MEMORY;
    return;
  }
  memcpy(ta, a->coef, na * sizeof(double));
  memcpy(tb, b->coef, nb * sizeof(double));
  scale_by_binomials(ta, a->deg, 0);
  scale_by_binomials(tb, b->deg, 0);
  for (size_t i = 0; i < size; i++) dst[i] = 0.0;

  /* The last axis with a non-zero output degree has output stride 1 and, in b, stride 1 as
   * well; runs of b along it map to contiguous output, which keeps the inner loop a plain
   * multiply-add over a contiguous row. */
  int last = -1;
  for (int j = 0; j < NAX; j++)
    if (deg[j] > 0) last = j;
  if (last < 0) {
    dst[0] = ta[0] * tb[0];
  } else {
    size_t run = (size_t)b->deg[last] + 1, rows = nb / run;
    size_t *row_off = (size_t *)bbc_arena_alloc(arena, rows * sizeof(size_t));
    if (!row_off) {
      bbc_arena_reset(arena, mark);
      *status = BBC_ERR_OUT_OF_MEMORY;
      return;
    }
    int idx[NAX] = {0};
    size_t off = 0;
    for (size_t r = 0; r < rows; r++) {
      row_off[r] = off;
      for (int j = NAX - 1; j >= 0; j--) {
        if (j == last || b->deg[j] == 0) continue;
        if (idx[j] < b->deg[j]) {
          idx[j]++;
          off += so[j];
          break;
        }
        off -= (size_t)idx[j] * so[j];
        idx[j] = 0;
      }
    }
    memset(idx, 0, sizeof idx);
    off = 0;
    for (size_t ia = 0; ia < na; ia++) {
      double va = ta[ia];
      if (va != 0.0) {
        for (size_t r = 0; r < rows; r++) {
          double *d = dst + off + row_off[r];
          const double *s = tb + r * run;
          for (size_t t = 0; t < run; t++) d[t] += va * s[t];
        }
      }
      for (int j = NAX - 1; j >= 0; j--) {
        if (a->deg[j] == 0) continue;
        if (idx[j] < a->deg[j]) {
          idx[j]++;
          off += so[j];
          break;
        }
        off -= (size_t)idx[j] * so[j];
        idx[j] = 0;
      }
    }
  }
  scale_by_binomials(dst, deg, 1);
  bbc_arena_reset(arena, mark);
}

bbc_result bbc_poly_mul(bbc_arena *arena, bbc_poly *out, const bbc_poly *a, const bbc_poly *b) {
  if (!out || !poly_ok(a) || !poly_ok(b)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  for (int j = 0; j < NAX; j++) {
    int d = a->deg[j] + b->deg[j];
    if (d > MAXD) return BBC_ERR_UNSUPPORTED;
    r.deg[j] = (unsigned char)d;
  }
  size_t mark = bbc_arena_mark(arena);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  bbc_result res = mul_into(arena, a, b, r.deg, r.coef, &r.err);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_derivative(bbc_arena *arena, bbc_poly *out, const bbc_poly *p, int axis) {
  if (!out || !poly_ok(p) || !axis_ok(axis)) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r = *p;
  int n = p->deg[axis];
  r.deg[axis] = (unsigned char)(n > 0 ? n - 1 : 0);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  if (n == 0) {
    /* Constant along the axis: the exact derivative is the zero polynomial. */
    size_t size = bbc__size(r.deg);
    for (size_t i = 0; i < size; i++) r.coef[i] = 0.0;
    r.err = 0.0;
    *out = r;
    return BBC_OK;
  }
  size_t pre, post;
  split_dims(p->deg, axis, &pre, &post);
  double dn = (double)n;
  for (size_t q = 0; q < pre; q++) {
    const double *src = p->coef + q * (size_t)(n + 1) * post;
    double *dst = r.coef + q * (size_t)n * post;
    for (int i = 0; i < n; i++)
      for (size_t t = 0; t < post; t++)
        dst[(size_t)i * post + t] =
            dn * (src[(size_t)(i + 1) * post + t] - src[(size_t)i * post + t]);
  }
  /* Exact coefficients n (C_{i+1} - C_i) move by at most 2 n err; computing n (c_{i+1} - c_i)
   * costs two roundings on a value of magnitude <= 2 n max|c|. */
  double m = bbc__maxabs(p->coef, bbc__size(p->deg));
  double e = bbc__mul_up(2.0 * dn, bbc__radius(p->err));
  e = bbc__add_up(e, bbc__mul_up(bbc__gamma(2), bbc__mul_up(2.0 * dn, m)));
  r.err = bbc__radius(e);
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_elevate(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                            const unsigned char deg[NAX]) {
  if (!out || !poly_ok(p) || !deg) return BBC_ERR_INVALID_ARGUMENT;
  bbc_poly r;
  memset(&r, 0, sizeof r);
  for (int j = 0; j < NAX; j++) {
    if (deg[j] > MAXD) return BBC_ERR_UNSUPPORTED;
    if (deg[j] < p->deg[j]) return BBC_ERR_INVALID_ARGUMENT;
    r.deg[j] = deg[j];
  }
  size_t mark = bbc_arena_mark(arena);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  bbc_result res = bbc__elevate_into(arena, p, r.deg, r.coef, &r.err);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

/* ---- Subdivision (de Casteljau) ------------------------------------------------------ */

/* One de Casteljau subdivision along `axis` at t in [0, 1]: left gets the coefficients on
 * [0, t], right those on [t, 1] (either may be NULL). work holds one block of (n+1) * post.
 * Each level computes (1-t) x + t y: three roundings (1 - t, two products, the sum counted
 * with the products), so n levels give K = 3n on a convex combination. */
static void casteljau_axis(const double *in, const unsigned char deg[NAX], int axis, double t,
                           double *left, double *right, double *work) {
  int n = deg[axis];
  size_t pre, post;
  split_dims(deg, axis, &pre, &post);
  size_t block = (size_t)(n + 1) * post;
  double s = 1.0 - t;
  if (post == 1) {
    /* The contiguous axis: the same triangle on scalars, without the row copies. */
    double w[MAXD + 1];
    for (size_t q = 0; q < pre; q++) {
      const double *src = in + q * block;
      double *l = left ? left + q * block : NULL;
      double *r = right ? right + q * block : NULL;
      for (int i = 0; i <= n; i++) w[i] = src[i];
      if (l) l[0] = w[0];
      if (r) r[n] = w[n];
      for (int level = 1; level <= n; level++) {
        for (int i = 0; i <= n - level; i++) w[i] = s * w[i] + t * w[i + 1];
        if (l) l[level] = w[0];
        if (r) r[n - level] = w[n - level];
      }
    }
    return;
  }
  for (size_t q = 0; q < pre; q++) {
    memcpy(work, in + q * block, block * sizeof(double));
    double *l = left ? left + q * block : NULL;
    double *r = right ? right + q * block : NULL;
    if (l) memcpy(l, work, post * sizeof(double));
    if (r) memcpy(r + (size_t)n * post, work + (size_t)n * post, post * sizeof(double));
    for (int level = 1; level <= n; level++) {
      for (int i = 0; i <= n - level; i++) {
        double *wi = work + (size_t)i * post;
        const double *wj = wi + post;
        for (size_t k = 0; k < post; k++) wi[k] = s * wi[k] + t * wj[k];
      }
      if (l) memcpy(l + (size_t)level * post, work, post * sizeof(double));
      if (r)
        memcpy(r + (size_t)(n - level) * post, work + (size_t)(n - level) * post,
               post * sizeof(double));
    }
  }
}

/* a / b rounded towards 0, for 0 <= a <= b, b > 0: the left end of the second subdivision in
 * bbc_poly_restrict. Rounding down makes the covered interval [t b, b] contain [a, b]. */
static double ratio_down(double a, double b) {
  if (a <= 0.0) return 0.0;
  double t = a / b;
  /* fma gives the sign of t b - a exactly; very small a guards against an underflowed
   * residual. */
  if (fma(t, b, -a) > 0.0 || a < 0x1p-960) t = nextafter(t, 0.0);
  if (t > 1.0) t = 1.0;
  return t;
}

bbc_result bbc_poly_restrict(bbc_arena *arena, bbc_poly *out, const bbc_poly *p,
                             const double lo[NAX], const double hi[NAX]) {
  if (!out || !poly_ok(p) || !lo || !hi) return BBC_ERR_INVALID_ARGUMENT;
  for (int j = 0; j < NAX; j++) {
    if (p->deg[j] == 0) continue;
    if (!(lo[j] >= 0.0 && lo[j] <= hi[j] && hi[j] <= 1.0)) return BBC_ERR_INVALID_ARGUMENT;
  }
  bbc_poly r = *p;
  size_t size = bbc__size(p->deg);
  size_t outer = bbc_arena_mark(arena);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  size_t mark = bbc_arena_mark(arena);
  double *buf[2], *work;
  buf[0] = (double *)bbc_arena_alloc(arena, size * sizeof(double));
  buf[1] = (double *)bbc_arena_alloc(arena, size * sizeof(double));
  work = (double *)bbc_arena_alloc(arena, size * sizeof(double));
  if (!buf[0] || !buf[1] || !work) {
    bbc_arena_reset(arena, outer);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  const double *cur = p->coef;
  int next = 0;
  double e = bbc__radius(p->err), m = bbc__maxabs(p->coef, size);
  for (int j = 0; j < NAX; j++) {
    int n = p->deg[j];
    if (n == 0) continue;
    double pass_gamma = bbc__gamma(3.0 * n);
    if (hi[j] < 1.0) {
      casteljau_axis(cur, p->deg, j, hi[j], buf[next], NULL, work);
      cur = buf[next];
      next ^= 1;
      double pass = bbc__mul_up(pass_gamma, m);
      e = bbc__add_up(e, pass);
      m = bbc__add_up(m, pass);
    }
    if (lo[j] > 0.0) {
      double t = ratio_down(lo[j], hi[j]);
      casteljau_axis(cur, p->deg, j, t, NULL, buf[next], work);
      cur = buf[next];
      next ^= 1;
      double pass = bbc__mul_up(pass_gamma, m);
      e = bbc__add_up(e, pass);
      m = bbc__add_up(m, pass);
    }
  }
  memcpy(r.coef, cur, size * sizeof(double));
  bbc_arena_reset(arena, mark);
  r.err = bbc__radius(e);
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly_split(bbc_arena *arena, const bbc_poly *p, int axis, bbc_poly *left,
                          bbc_poly *right) {
  if (!poly_ok(p) || !axis_ok(axis) || (!left && !right)) return BBC_ERR_INVALID_ARGUMENT;
  size_t size = bbc__size(p->deg);
  size_t outer = bbc_arena_mark(arena);
  bbc_poly l = *p, r = *p;
  l.coef = r.coef = NULL;
  if (left && bbc__alloc_coef(arena, l.deg, &l.coef) != BBC_OK) goto oom;
  if (right && bbc__alloc_coef(arena, r.deg, &r.coef) != BBC_OK) goto oom;
  int n = p->deg[axis];
  double e = bbc__radius(p->err);
  if (n == 0) {
    if (l.coef) memcpy(l.coef, p->coef, size * sizeof(double));
    if (r.coef) memcpy(r.coef, p->coef, size * sizeof(double));
  } else {
    size_t mark = bbc_arena_mark(arena);
    size_t pre, post;
    split_dims(p->deg, axis, &pre, &post);
    double *work = (double *)bbc_arena_alloc(arena, (size_t)(n + 1) * post * sizeof(double));
    if (!work) goto oom;
    casteljau_axis(p->coef, p->deg, axis, 0.5, l.coef, r.coef, work);
    bbc_arena_reset(arena, mark);
    double m = bbc__maxabs(p->coef, size);
    e = bbc__add_up(e, bbc__mul_up(bbc__gamma(3.0 * n), m));
  }
  l.err = r.err = bbc__radius(e);
  if (left) *left = l;
  if (right) *right = r;
  return BBC_OK;
oom:
  bbc_arena_reset(arena, outer);
  return BBC_ERR_OUT_OF_MEMORY;
}

/* ---- Evaluation --------------------------------------------------------------------- */

/* de Casteljau along each axis in turn, the first axis outermost. With `tame` (every x in
 * [0, 1] and every coefficient finite and at most DBL_MAX / 4, so that every intermediate
 * value is finite: they are convex combinations up to rounding), an axis at x = 0 or 1
 * takes only its end row: there the scheme computes 1 v_0 + 0 v_1 = v_0 (or 0 v_{n-1} +
 * 1 v_n = v_n) at every level, which is v_0 (v_n) exactly when that is not zero (a zero's
 * sign could change); a zero end is computed in full. */
static double eval_rec(const double *c, const unsigned char *deg, const size_t *stride, int axis,
                       const double *x, int tame) {
  while (axis < NAX && deg[axis] == 0) axis++;
  if (axis == NAX) return c[0];
  int n = deg[axis];
  double t = x[axis], s = 1.0 - t;
  if (tame && (t == 0.0 || t == 1.0)) {
    const int end = t == 0.0 ? 0 : n;
    const double e = eval_rec(c + (size_t)end * stride[axis], deg, stride, axis + 1, x, tame);
    if (e != 0.0) return e;
  }
  double v[MAXD + 1];
  for (int i = 0; i <= n; i++)
    v[i] = eval_rec(c + (size_t)i * stride[axis], deg, stride, axis + 1, x, tame);
  for (int level = 1; level <= n; level++)
    for (int i = 0; i <= n - level; i++) v[i] = s * v[i] + t * v[i + 1];
  return v[0];
}

double bbc_poly_eval(const bbc_poly *p, const double x[NAX]) {
  if (!poly_ok(p) || !x) return NAN;
  size_t stride[NAX];
  size_t size = bbc__strides(p->deg, stride);
  int tame = 1, corner = 0;
  for (int j = 0; j < NAX; j++) {
    if (p->deg[j] == 0) continue;
    tame &= x[j] >= 0.0 && x[j] <= 1.0;
    corner |= x[j] == 0.0 || x[j] == 1.0;
  }
  /* The scan for tameness only where it can pay. */
  if (tame && corner) tame = bbc__maxabs(p->coef, size) <= DBL_MAX / 4;
  else tame = 0;
  return eval_rec(p->coef, p->deg, stride, 0, x, tame);
}

/* ---- Vectors of polynomials --------------------------------------------------------- */

bbc_result bbc_poly3_constant(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 v) {
  if (!out) return BBC_ERR_INVALID_ARGUMENT;
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_constant(arena, &r.x, v.x);
  if (res == BBC_OK) res = bbc_poly_constant(arena, &r.y, v.y);
  if (res == BBC_OK) res = bbc_poly_constant(arena, &r.z, v.z);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly3_affine(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 c,
                            const bbc_vec3 grad[NAX]) {
  if (!out || !grad) return BBC_ERR_INVALID_ARGUMENT;
  double gx[NAX], gy[NAX], gz[NAX];
  for (int j = 0; j < NAX; j++) {
    gx[j] = grad[j].x;
    gy[j] = grad[j].y;
    gz[j] = grad[j].z;
  }
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_affine(arena, &r.x, c.x, gx);
  if (res == BBC_OK) res = bbc_poly_affine(arena, &r.y, c.y, gy);
  if (res == BBC_OK) res = bbc_poly_affine(arena, &r.z, c.z, gz);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

/* out = alpha0 a + alpha1 b per coordinate. */
static bbc_result poly3_combine(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                                const bbc_poly3 *b, double alpha0, double alpha1) {
  if (!out || !a || !b) return BBC_ERR_INVALID_ARGUMENT;
  const double alpha[2] = {alpha0, alpha1};
  const bbc_poly *px[2] = {&a->x, &b->x}, *py[2] = {&a->y, &b->y}, *pz[2] = {&a->z, &b->z};
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_lincomb(arena, &r.x, 2, alpha, px);
  if (res == BBC_OK) res = bbc_poly_lincomb(arena, &r.y, 2, alpha, py);
  if (res == BBC_OK) res = bbc_poly_lincomb(arena, &r.z, 2, alpha, pz);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly3_add(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a, const bbc_poly3 *b) {
  return poly3_combine(arena, out, a, b, 1.0, 1.0);
}

bbc_result bbc_poly3_sub(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a, const bbc_poly3 *b) {
  return poly3_combine(arena, out, a, b, 1.0, -1.0);
}

bbc_result bbc_poly3_scale(bbc_arena *arena, bbc_poly3 *out, const bbc_poly *s,
                           const bbc_poly3 *v) {
  if (!out || !s || !v) return BBC_ERR_INVALID_ARGUMENT;
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_mul(arena, &r.x, s, &v->x);
  if (res == BBC_OK) res = bbc_poly_mul(arena, &r.y, s, &v->y);
  if (res == BBC_OK) res = bbc_poly_mul(arena, &r.z, s, &v->z);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly3_scale_const(bbc_arena *arena, bbc_poly3 *out, double s, const bbc_poly3 *v) {
  if (!out || !v) return BBC_ERR_INVALID_ARGUMENT;
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_scale(arena, &r.x, &v->x, s);
  if (res == BBC_OK) res = bbc_poly_scale(arena, &r.y, &v->y, s);
  if (res == BBC_OK) res = bbc_poly_scale(arena, &r.z, &v->z, s);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

/* out = sum_k sign[k] a[k] * b[k] with the products as arena temporaries freed before
 * returning: the output is allocated first, so the temporaries above it can go. */
static bbc_result sum_of_products(bbc_arena *arena, bbc_poly *out, int n, const double *sign,
                                  const bbc_poly *const *a, const bbc_poly *const *b) {
  bbc_poly r;
  memset(&r, 0, sizeof r);
  for (int k = 0; k < n; k++) {
    if (!poly_ok(a[k]) || !poly_ok(b[k])) return BBC_ERR_INVALID_ARGUMENT;
    for (int j = 0; j < NAX; j++) {
      int d = a[k]->deg[j] + b[k]->deg[j];
      if (d > MAXD) return BBC_ERR_UNSUPPORTED;
      if (d > r.deg[j]) r.deg[j] = (unsigned char)d;
    }
  }
  size_t outer = bbc_arena_mark(arena);
  BBC__TRY(bbc__alloc_coef(arena, r.deg, &r.coef));
  size_t mark = bbc_arena_mark(arena);
  bbc_poly prod[3];
  const bbc_poly *pp[3];
  bbc_result res = BBC_OK;
  for (int k = 0; k < n && res == BBC_OK; k++) {
    res = bbc_poly_mul(arena, &prod[k], a[k], b[k]);
    pp[k] = &prod[k];
  }
  if (res == BBC_OK) res = bbc__lincomb_into(arena, n, sign, pp, r.deg, r.coef, &r.err);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, outer);
    return res;
  }
  bbc_arena_reset(arena, mark);
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly3_dot(bbc_arena *arena, bbc_poly *out, const bbc_poly3 *a, const bbc_poly3 *b) {
  if (!out || !a || !b) return BBC_ERR_INVALID_ARGUMENT;
  const double sign[3] = {1.0, 1.0, 1.0};
  const bbc_poly *pa[3] = {&a->x, &a->y, &a->z}, *pb[3] = {&b->x, &b->y, &b->z};
  return sum_of_products(arena, out, 3, sign, pa, pb);
}

bbc_result bbc_poly3_dot_vec(bbc_arena *arena, bbc_poly *out, const bbc_poly3 *a, bbc_vec3 v) {
  if (!out || !a) return BBC_ERR_INVALID_ARGUMENT;
  const double alpha[3] = {v.x, v.y, v.z};
  const bbc_poly *pa[3] = {&a->x, &a->y, &a->z};
  return bbc_poly_lincomb(arena, out, 3, alpha, pa);
}

bbc_result bbc_poly3_cross(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a,
                           const bbc_poly3 *b) {
  if (!out || !a || !b) return BBC_ERR_INVALID_ARGUMENT;
  const double sign[2] = {1.0, -1.0};
  const bbc_poly *ax[2] = {&a->y, &a->z}, *bx[2] = {&b->z, &b->y};
  const bbc_poly *ay[2] = {&a->z, &a->x}, *by[2] = {&b->x, &b->z};
  const bbc_poly *az[2] = {&a->x, &a->y}, *bz[2] = {&b->y, &b->x};
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = sum_of_products(arena, &r.x, 2, sign, ax, bx);
  if (res == BBC_OK) res = sum_of_products(arena, &r.y, 2, sign, ay, by);
  if (res == BBC_OK) res = sum_of_products(arena, &r.z, 2, sign, az, bz);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}

bbc_result bbc_poly3_cross_vec(bbc_arena *arena, bbc_poly3 *out, const bbc_poly3 *a, bbc_vec3 v) {
  if (!out || !a) return BBC_ERR_INVALID_ARGUMENT;
  const double ax[2] = {v.z, -v.y}, ay[2] = {v.x, -v.z}, az[2] = {v.y, -v.x};
  const bbc_poly *px[2] = {&a->y, &a->z}, *py[2] = {&a->z, &a->x}, *pz[2] = {&a->x, &a->y};
  size_t mark = bbc_arena_mark(arena);
  bbc_poly3 r;
  bbc_result res = bbc_poly_lincomb(arena, &r.x, 2, ax, px);
  if (res == BBC_OK) res = bbc_poly_lincomb(arena, &r.y, 2, ay, py);
  if (res == BBC_OK) res = bbc_poly_lincomb(arena, &r.z, 2, az, pz);
  if (res != BBC_OK) {
    bbc_arena_reset(arena, mark);
    return res;
  }
  *out = r;
  return BBC_OK;
}
