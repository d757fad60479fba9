/* Throughput of the Bernstein engine, single thread: the operations a piece of the
 * precomputation performs (paper Sec. 4.1, Supp. Sec. 3.1). Each row runs one operation
 * repeatedly (arena reset after every call) in three trials and prints the operations per
 * second of the fastest trial. Usage: bench_bernstein [seconds per row, default 0.6]. */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/bernstein.h"

#define NAX BBC_POLY_MAX_AXES

static double bench_seconds = 0.6;
static unsigned char arena_buffer[64u << 20];
static volatile double sink;

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static uint64_t rng_state = 12345;
static double rnd(void) {
  uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return (double)(z >> 11) * 0x1p-53;
}

/* A polynomial with the given degrees and random coefficients in [lo, hi]. */
static bbc_poly random_poly(bbc_arena *a, const unsigned char deg[NAX], double lo, double hi) {
  bbc_poly p;
  memset(&p, 0, sizeof p);
  memcpy(p.deg, deg, NAX);
  size_t n = bbc_poly_size(&p);
  p.coef = (double *)bbc_arena_alloc(a, n * sizeof(double));
  if (!p.coef) {
    fprintf(stderr, "bench_bernstein: arena too small\n");
    exit(1);
  }
  for (size_t i = 0; i < n; i++) p.coef[i] = lo + (hi - lo) * rnd();
  return p;
}

typedef int (*bench_fn)(bbc_arena *a, void *ctx);

/* Runs fn for three trials of bench_seconds / 3 and reports the fastest trial, which
 * suppresses interference from other processes on a shared machine. */
static void row(const char *name, const char *shape, bench_fn fn, void *ctx, bbc_arena *a) {
  size_t mark = bbc_arena_mark(a);
  double best = INFINITY;
  for (int trial = 0; trial < 3; trial++) {
    long n = 0;
    double start = now(), t = start;
    int batch = 1;
    while (t - start < bench_seconds / 3) {
      for (int i = 0; i < batch; i++) {
        if (fn(a, ctx) != 0) {
          fprintf(stderr, "bench_bernstein: %s failed\n", name);
          exit(1);
        }
        bbc_arena_reset(a, mark);
      }
      n += batch;
      if (batch < (1 << 16)) batch *= 2;
      t = now();
    }
    double per = (t - start) / (double)n;
    if (per < best) best = per;
  }
  printf("| %-38s | %-26s | %12.0f | %10.3f |\n", name, shape, 1.0 / best, best * 1e6);
}

/* ---- Rows ----------------------------------------------------------------------------- */

typedef struct ctx2 {
  bbc_poly p, q;
  bbc_space space;
  int axis;
  double lo[NAX], hi[NAX];
} ctx2;

static int do_mul(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_poly out;
  int r = bbc_poly_mul(a, &out, &x->p, &x->q);
  sink = out.coef[0];
  return r;
}

static int do_add(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_poly out;
  int r = bbc_poly_add(a, &out, &x->p, &x->q);
  sink = out.coef[0];
  return r;
}

static int do_bound(bbc_arena *a, void *c) {
  (void)a;
  ctx2 *x = (ctx2 *)c;
  bbc_interval b = bbc_poly_bound(&x->p);
  sink = b.lo;
  return 0;
}

static int do_rational(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_range r;
  int res = bbc_rational_bound(a, &x->p, &x->q, &r);
  sink = r.lo;
  return res;
}

static int do_split(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_poly l, r;
  int res = bbc_poly_split(a, &x->p, x->axis, &l, &r);
  sink = l.coef[0] + r.coef[0];
  return res;
}

static int do_restrict(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_poly out;
  int res = bbc_poly_restrict(a, &out, &x->p, x->lo, x->hi);
  sink = out.coef[0];
  return res;
}

static int do_derivative(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_poly out;
  int res = bbc_poly_derivative(a, &out, &x->p, x->axis);
  sink = out.coef[0];
  return res;
}

static int do_reduce(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_space s = x->space;
  bbc_poly out;
  int res = bbc_poly_reduce(a, &s, &out, &x->p, 3, NULL);
  sink = out.coef[0];
  return res;
}

static int do_sqrt_primal(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_space s = x->space;
  bbc_poly out;
  int res = bbc_poly_sqrt_primal(a, &s, &out, &x->p, NULL, NULL, NULL);
  sink = out.coef[0];
  return res;
}

static int do_sqrt_two_stage(bbc_arena *a, void *c) {
  ctx2 *x = (ctx2 *)c;
  bbc_space s = x->space;
  bbc_poly v, sl;
  int res = bbc_poly_sqrt_derivative_aware(a, &s, &v, &sl, &x->p, NULL, 0.0, NULL, NULL);
  sink = v.coef[0];
  return res;
}

static int do_sqrt_fit(bbc_arena *a, void *c) {
  (void)a;
  (void)c;
  bbc_sqrt_derivative_aware f;
  int res = bbc_sqrt_derivative_aware_fit(0.25 + rnd(), 4.0, 0.0, &f);
  sink = f.delta_hi;
  return res;
}

/* The whole position bound of one reflection piece: u2 = ((d1 x e22).(x1 - p20)) / kappa. */
typedef struct chain_ctx {
  int sx, sy;
  bbc_vec3 cx, gxs, gxt, cn, gns, gnt, x0, p20, e21, e22;
} chain_ctx;

static int do_chain(bbc_arena *a, void *c) {
  chain_ctx *k = (chain_ctx *)c;
  bbc_vec3 gx[NAX], gn[NAX];
  memset(gx, 0, sizeof gx);
  memset(gn, 0, sizeof gn);
  gx[k->sx] = k->gxs;
  gx[k->sy] = k->gxt;
  gn[k->sx] = k->gns;
  gn[k->sy] = k->gnt;
  bbc_poly3 x1, n1, x0, d0, t1, t2, d1, cr, p20, rel;
  bbc_poly nn, dn, num, den;
  bbc_range u2;
  int r = bbc_poly3_affine(a, &x1, k->cx, gx);
  if (!r) r = bbc_poly3_affine(a, &n1, k->cn, gn);
  if (!r) r = bbc_poly3_constant(a, &x0, k->x0);
  if (!r) r = bbc_poly3_sub(a, &d0, &x1, &x0);
  if (!r) r = bbc_poly3_dot(a, &nn, &n1, &n1);
  if (!r) r = bbc_poly3_dot(a, &dn, &d0, &n1);
  if (!r) r = bbc_poly3_scale(a, &t1, &nn, &d0);
  if (!r) r = bbc_poly3_scale(a, &t2, &dn, &n1);
  if (!r) r = bbc_poly3_scale_const(a, &t2, 2.0, &t2);
  if (!r) r = bbc_poly3_sub(a, &d1, &t1, &t2);
  if (!r) r = bbc_poly3_cross_vec(a, &cr, &d1, k->e22);
  if (!r) r = bbc_poly3_constant(a, &p20, k->p20);
  if (!r) r = bbc_poly3_sub(a, &rel, &x1, &p20);
  if (!r) r = bbc_poly3_dot(a, &num, &cr, &rel);
  if (!r) r = bbc_poly3_dot_vec(a, &den, &cr, k->e21);
  if (!r) r = bbc_rational_bound(a, &num, &den, &u2);
  sink = u2.lo;
  return r;
}

int main(int argc, char **argv) {
  if (argc > 1) {
    char *end;
    double s = strtod(argv[1], &end);
    if (*end || !(s > 0)) {
      fprintf(stderr,
              "bench_bernstein: seconds must be a positive number\nusage: bench_bernstein [seconds "
              "per row]\n");
      return 2;
    }
    bench_seconds = s;
  }
  bbc_arena arena;
  bbc_arena_init(&arena, arena_buffer, sizeof arena_buffer);

  bbc_space space;
  memset(&space, 0, sizeof space);
  int sx, sy, r0, r1;
  bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &sx);
  bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &sy);
  bbc_space_add_axis(&space, BBC_AXIS_REMAINDER, &r0);
  bbc_space_add_axis(&space, BBC_AXIS_REMAINDER, &r1);

  printf("| %-38s | %-26s | %12s | %10s |\n", "operation", "degrees (s,t,xi,zeta)", "ops/s",
         "us/op");
  printf("|%s|%s|%s|%s|\n", "----------------------------------------",
         "----------------------------", "--------------", "------------");

  /* Small: the single-reflection sizes. */
  ctx2 small;
  memset(&small, 0, sizeof small);
  unsigned char d4[NAX] = {0}, d3[NAX] = {0};
  d4[sx] = d4[sy] = 4;
  d3[sx] = d3[sy] = 3;
  small.p = random_poly(&arena, d4, -1.0, 1.0);
  small.q = random_poly(&arena, d3, 0.5, 2.0);
  row("product", "(4,4) x (3,3)", do_mul, &small, &arena);
  row("rational bound p/q (elevates q)", "(4,4) / (3,3)", do_rational, &small, &arena);
  row("polynomial bound", "(4,4)", do_bound, &small, &arena);

  /* The products the two-bounce forms spend their time in (degree-3 intermediates, the
   * 4D implicit forms). */
  {
    static const unsigned char shapes[][2][4] = {
        {{3, 3, 0, 0}, {3, 3, 0, 0}}, {{3, 3, 0, 0}, {6, 6, 0, 0}}, {{6, 6, 0, 0}, {6, 6, 0, 0}},
        {{0, 0, 0, 0}, {3, 3, 0, 0}}, {{3, 3, 1, 1}, {3, 3, 1, 1}}, {{6, 6, 0, 0}, {3, 3, 2, 2}}};
    for (size_t k = 0; k < sizeof shapes / sizeof shapes[0]; k++) {
      ctx2 c;
      memset(&c, 0, sizeof c);
      unsigned char da[NAX] = {0}, db[NAX] = {0};
      const int ax[4] = {sx, sy, NAX - 3, NAX - 4};
      for (int j = 0; j < 4; j++) da[ax[j]] = shapes[k][0][j], db[ax[j]] = shapes[k][1][j];
      c.p = random_poly(&arena, da, -1.0, 1.0);
      c.q = random_poly(&arena, db, 0.5, 2.0);
      char name[64];
      snprintf(name, sizeof name, "(%d,%d,%d,%d) x (%d,%d,%d,%d)", da[ax[0]], da[ax[1]], da[ax[2]],
               da[ax[3]], db[ax[0]], db[ax[1]], db[ax[2]], db[ax[3]]);
      row("product (two-bounce shapes)", name, do_mul, &c, &arena);
    }
  }

  /* Large: two geometric axes of degree 15 and two remainder axes. */
  ctx2 big;
  memset(&big, 0, sizeof big);
  big.space = space;
  unsigned char d15[NAX] = {0}, d15b[NAX] = {0};
  d15[sx] = d15[sy] = 15;
  d15[r0] = d15[r1] = 1;
  d15b[sx] = 12;
  d15b[sy] = 15;
  d15b[r0] = 1;
  big.p = random_poly(&arena, d15, -1.0, 1.0);
  big.q = random_poly(&arena, d15, 0.5, 2.0);
  row("product", "(15,15,1,1) x (15,15,1,1)", do_mul, &big, &arena);
  row("add (same degrees)", "(15,15,1,1) + (15,15,1,1)", do_add, &big, &arena);
  ctx2 mixed = big;
  mixed.q = random_poly(&arena, d15b, 0.5, 2.0);
  row("add (elevates one operand)", "(15,15,1,1) + (12,15,1,0)", do_add, &mixed, &arena);
  row("polynomial bound", "(15,15,1,1)", do_bound, &big, &arena);
  row("rational bound p/q", "(15,15,1,1) / (15,15,1,1)", do_rational, &big, &arena);
  big.axis = sx;
  row("halving (split both halves)", "(15,15,1,1)", do_split, &big, &arena);
  for (int j = 0; j < NAX; j++) {
    big.lo[j] = 0.0;
    big.hi[j] = 1.0;
  }
  big.lo[sx] = 0.3;
  big.hi[sx] = 0.55;
  big.lo[sy] = 0.1;
  big.hi[sy] = 0.4;
  row("restriction to a sub-box", "(15,15,1,1)", do_restrict, &big, &arena);
  row("derivative", "(15,15,1,1)", do_derivative, &big, &arena);
  row("degree reduction to 3", "(15,15,1,1)", do_reduce, &big, &arena);
  ctx2 prod = big;
  {
    bbc_poly out;
    if (bbc_poly_mul(&arena, &out, &big.p, &big.q) != BBC_OK) return 1;
    prod.p = out;
  }
  row("degree reduction to 3", "(30,30,2,2)", do_reduce, &prod, &arena);

  /* Square roots of a positive beta. */
  ctx2 sq;
  memset(&sq, 0, sizeof sq);
  sq.space = space;
  bbc_space_release_axis(&sq.space, r0);
  bbc_space_release_axis(&sq.space, r1);
  sq.p = random_poly(&arena, d4, 0.5, 3.0);
  row("sqrt linearisation, primal", "beta (4,4)", do_sqrt_primal, &sq, &arena);
  row("sqrt linearisation, two-stage", "beta (4,4)", do_sqrt_two_stage, &sq, &arena);
  row("sqrt two-stage fit (scalar)", "-", do_sqrt_fit, &sq, &arena);

  chain_ctx ch = {sx,
                  sy,
                  {0.1, 0.0, -0.2},
                  {0.05, 0.01, 0.0},
                  {0.0, 0.0, 0.05},
                  {0.02, 1.0, 0.01},
                  {0.01, 0.0, 0.0},
                  {0.0, 0.0, 0.01},
                  {0.3, 3.0, 0.2},
                  {-4.0, 2.0, -4.0},
                  {8.0, 0.0, 0.0},
                  {0.0, 0.0, 8.0}};
  row("reflection piece u2 bound (Eq. 9-10)", "num (4,4) / den (3,3)", do_chain, &ch, &arena);
  printf("arena peak: %zu bytes\n", arena.peak);
  return 0;
}
