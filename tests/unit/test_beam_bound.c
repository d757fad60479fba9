/* Beam bounds (bbc_bound_beam, docs/beams.md) against an independent oracle of true
 * paths: u1 is sampled in T1, the path is traced from the light through T1 (and T2) with
 * unit vectors and Snell's law, and at a random point of the outgoing ray inside the
 * receivers' box, on a receiving plane of random orientation, the true irradiance is
 * computed from the exact Jacobian of the map from u1 to the landing point on that plane
 * (complex-step derivatives: no cancellation, exact to rounding). Every point must lie in
 * the box of every piece of its u1 and slab, and its irradiance must be at most e_hi. */
#include <complex.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bounds.h"
#include "bounder_internal.h"
#include "harness.h"
#include "vec_internal.h"

#define CHAIN_FIXTURES_SEED 0x5eedbea3ull
#include "chain_fixtures.h"

/* ---- the oracle: complex vectors for complex-step derivatives ---------------------- */

typedef struct cvec {
  double complex x, y, z;
} cvec;

static cvec cv(bbc_vec3 a) {
  return (cvec){a.x, a.y, a.z};
}
static cvec cadd(cvec a, cvec b) {
  return (cvec){a.x + b.x, a.y + b.y, a.z + b.z};
}
static cvec csub(cvec a, cvec b) {
  return (cvec){a.x - b.x, a.y - b.y, a.z - b.z};
}
static cvec cscale(cvec a, double complex s) {
  return (cvec){a.x * s, a.y * s, a.z * s};
}
static double complex cdot(cvec a, cvec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
static cvec ccross(cvec a, cvec b) {
  return (cvec){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static cvec cnorm(cvec a) {
  return cscale(a, 1.0 / csqrt(cdot(a, a)));
}

/* The scattered unit direction for the unit incident d at the unit normal n (on the
 * incident side); 0 on total internal reflection. */
static int scatter(cvec d, cvec n, int refract, double eta, cvec *out) {
  double complex dn = cdot(d, n);
  if (!refract) {
    *out = csub(d, cscale(n, 2.0 * dn));
    return 1;
  }
  double complex cosi = -dn;
  double complex k = 1.0 - eta * eta * (1.0 - cosi * cosi);
  if (creal(k) < 0) return 0;
  *out = cadd(cscale(d, eta), cscale(n, eta * cosi - csqrt(k)));
  return 1;
}

/* The path of T1's barycentrics (u, v) (complex for the derivatives): its last vertex x,
 * unit direction d and the weight cos(theta0) / |d0|^2 (a sun: cos(theta0)) with the spot
 * falloff. Returns 0 when it is no valid path (unlit side, total internal reflection,
 * missing T2); `strict` 0 skips the tests (for the derivatives' neighbourhood). */
static int trace(const bbc_tuple_geometry *g, double complex u, double complex v, int strict,
                 cvec *x, cvec *d, double complex *weight) {
  cvec p0 = cv(g->p[0]), e1 = csub(cv(g->p[1]), p0), e2 = csub(cv(g->p[2]), p0);
  cvec x1 = cadd(p0, cadd(cscale(e1, u), cscale(e2, v)));
  cvec n0 = cv(g->n[0]);
  cvec n1 =
      cnorm(cadd(n0, cadd(cscale(csub(cv(g->n[1]), n0), u), cscale(csub(cv(g->n[2]), n0), v))));
  cvec ng = cnorm(ccross(e1, e2));
  cvec d0;
  double complex w;
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  if (sun) {
    d0 = cnorm(cv(g->light_model.direction));
    w = cdot(ng, d0);
  } else {
    cvec r = csub(x1, cv(g->light));
    double complex r2 = cdot(r, r);
    d0 = cscale(r, 1.0 / csqrt(r2));
    w = cdot(ng, d0) / r2;
    if (g->light_model.kind == BBC_LIGHT_SPOT) {
      bbc_vec3 wr = {creal(d0.x), creal(d0.y), creal(d0.z)};
      w *= bbc_light_falloff(&g->light_model, wr); /* constant in the derivatives: see below */
    }
  }
  if (creal(w) < 0) w = -w;
  if (strict && !(creal(cdot(d0, n1)) < 0)) return 0;
  cvec d1;
  if (!scatter(d0, n1, g->refract, g->eta, &d1)) return 0;
  if (g->length == 2) {
    cvec q0 = cv(g->p2[0]), f1 = csub(cv(g->p2[1]), q0), f2 = csub(cv(g->p2[2]), q0);
    /* Moller-Trumbore. */
    cvec pv = ccross(d1, f2);
    double complex det = cdot(pv, f1);
    cvec rel = csub(x1, q0);
    double complex a = cdot(pv, rel) / det;
    cvec qv = ccross(rel, f1);
    double complex b = cdot(qv, d1) / det, t = cdot(qv, f2) / det;
    if (strict && !(creal(t) > 0 && creal(a) >= 0 && creal(b) >= 0 && creal(a + b) <= 1)) return 0;
    cvec x2 = cadd(x1, cscale(d1, t));
    cvec m0 = cv(g->n2[0]);
    cvec n2 =
        cnorm(cadd(m0, cadd(cscale(csub(cv(g->n2[1]), m0), a), cscale(csub(cv(g->n2[2]), m0), b))));
    if (strict && !(creal(cdot(d1, n2)) < 0)) return 0;
    cvec d2;
    if (!scatter(d1, n2, g->refract2, g->eta2, &d2)) return 0;
    *x = x2, *d = cnorm(d2);
  } else {
    *x = x1, *d = cnorm(d1);
  }
  *weight = w;
  return 1;
}

/* The true irradiance per unit intensity at the path (u, v) on the plane through y with
 * unit normal m: weight |e1 x e2| / |dL/du x dL/dv|, L the landing point on that plane.
 * The spot falloff enters as a constant (its own derivative is not needed: the Jacobian
 * is that of the geometry; the falloff is a factor of the intensity). */
static double true_irradiance(const bbc_tuple_geometry *g, double u, double v, bbc_vec3 y,
                              bbc_vec3 m) {
  const double h = 1e-30;
  cvec L[2];
  double complex w = 0;
  for (int k = 0; k < 2; k++) {
    double complex uu = u + (k == 0 ? I * h : 0), vv = v + (k == 1 ? I * h : 0);
    cvec x, d;
    if (!trace(g, uu, vv, 0, &x, &d, &w)) return NAN;
    double complex s = cdot(csub(cv(y), x), cv(m)) / cdot(d, cv(m));
    L[k] = cadd(x, cscale(d, s));
  }
  bbc_vec3 lu = {cimag(L[0].x) / h, cimag(L[0].y) / h, cimag(L[0].z) / h};
  bbc_vec3 lv = {cimag(L[1].x) / h, cimag(L[1].y) / h, cimag(L[1].z) / h};
  double area1 = v3_length(v3_cross(v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0])));
  return creal(w) * area1 / v3_length(v3_cross(lu, lv));
}

/* ---- collecting pieces ------------------------------------------------------------ */

typedef struct pieces {
  bbc_beam_piece *p;
  size_t n, cap;
} pieces;

static int collect(void *user, const bbc_beam_piece *piece) {
  pieces *ps = user;
  if (ps->n == ps->cap) {
    ps->cap = ps->cap ? 2 * ps->cap : 1024;
    ps->p = realloc(ps->p, ps->cap * sizeof *ps->p);
  }
  ps->p[ps->n++] = *piece;
  return 0;
}

typedef struct tally {
  long paths;      /* points checked */
  long violations; /* outside a box, above e_hi, or in a discarded piece */
  long uncovered;  /* no piece holds the point */
  long unbounded;  /* points whose piece has e_hi = +inf */
  double max_true; /* the largest true irradiance met */
} tally;

/* The entry and exit of the ray x + t d (t > 0) through the box; 0 if it misses. */
static int ray_box(bbc_vec3 x, bbc_vec3 d, const double lo[3], const double hi[3], double *t0,
                   double *t1) {
  double a = 0, b = INFINITY;
  const double xs[3] = {x.x, x.y, x.z}, ds[3] = {d.x, d.y, d.z};
  for (int i = 0; i < 3; i++) {
    if (ds[i] == 0) {
      if (xs[i] < lo[i] || xs[i] > hi[i]) return 0;
      continue;
    }
    double ta = (lo[i] - xs[i]) / ds[i], tb = (hi[i] - xs[i]) / ds[i];
    if (ta > tb) {
      double s = ta;
      ta = tb, tb = s;
    }
    a = fmax(a, ta), b = fmin(b, tb);
  }
  *t0 = a, *t1 = b;
  return a < b;
}

static bbc_vec3 random_unit(void) {
  double z = 2 * rnd() - 1, phi = 6.283185307179586 * rnd(), r = sqrt(fmax(0.0, 1 - z * z));
  return (bbc_vec3){r * cos(phi), r * sin(phi), z};
}

/* Checks `paths` true paths against the pieces. `plane_axis` >= 0: the receiving planes
 * are that axis's (normal e_axis) instead of random orientations. */
static tally check_paths(const bbc_tuple_geometry *g, const double lo[3], const double hi[3],
                         const pieces *ps, long paths, int plane_axis) {
  tally t;
  memset(&t, 0, sizeof t);
  const double tol = 1e-9; /* the oracle's rounding in y (scene sizes about 1) */
  long tries = 0;
  while (t.paths < paths && tries < 50 * paths) {
    tries++;
    double u, v;
    rnd_bary(&u, &v);
    cvec cx, cd;
    double complex w;
    if (!trace(g, u, v, 1, &cx, &cd, &w)) continue;
    bbc_vec3 x = {creal(cx.x), creal(cx.y), creal(cx.z)};
    bbc_vec3 d = {creal(cd.x), creal(cd.y), creal(cd.z)};
    double t0, t1;
    if (!ray_box(x, d, lo, hi, &t0, &t1)) continue;
    const double tt = t0 + (t1 - t0) * rnd();
    bbc_vec3 y = v3_add(x, v3_scale(d, tt));
    const double ys[3] = {y.x, y.y, y.z};
    /* A quarter of the planes normal to the ray, where the irradiance is largest. */
    bbc_vec3 m = rnd() < 0.25 ? d : random_unit();
    if (plane_axis >= 0) m = (bbc_vec3){plane_axis == 0, plane_axis == 1, plane_axis == 2};
    const double e = true_irradiance(g, u, v, y, m);
    if (!(e >= 0)) continue;
    t.paths++;
    if (e > t.max_true) t.max_true = e;
    int covered = 0, bad = 0, inf = 0;
    for (size_t k = 0; k < ps->n; k++) {
      const bbc_beam_piece *p = &ps->p[k];
      if (u < p->u_lo || u > p->u_hi || v < p->v_lo || v > p->v_hi) continue;
      if (p->axis >= 0 && (ys[p->axis] < p->lambda_lo || ys[p->axis] > p->lambda_hi)) continue;
      covered = 1;
      if (p->status == BBC_PIECE_DISCARDED) {
        bad = 1;
        continue;
      }
      for (int i = 0; i < 3; i++)
        if (!(ys[i] >= p->box_lo[i] - tol && ys[i] <= p->box_hi[i] + tol)) bad = 1;
      if (!(e <= p->e_hi * (1 + 1e-9))) bad = 1;
      if (!(p->e_hi < INFINITY)) inf = 1;
    }
    if (!covered) t.uncovered++;
    if (bad) t.violations++;
    if (inf) t.unbounded++;
  }
  return t;
}

static pieces bound(const bbc_tuple_geometry *g, const double lo[3], const double hi[3],
                    int max_level, double sigma, bbc_bound_stats *st) {
  pieces ps = {0};
  bbc_bounder *b;
  CHECK(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  prm.max_level = max_level;
  prm.sigma = sigma;
  CHECK(bbc_bound_beam(b, g, lo, hi, &prm, collect, &ps, st) == BBC_OK);
  bbc_bounder_free(b);
  return ps;
}

/* ---- scenes ----------------------------------------------------------------------- */

/* T1 in the plane z = 0 around the origin, normals (-k x, -k y, 1) (k > 0: a concave
 * mirror or converging surface), the light above. */
static void caster(bbc_tuple_geometry *g, double k, int refract, double eta) {
  memset(g, 0, sizeof *g);
  g->light = (bbc_vec3){0.15, 0.1, 3.0};
  g->p[0] = (bbc_vec3){-0.5, -0.4, 0};
  g->p[1] = (bbc_vec3){0.6, -0.35, 0};
  g->p[2] = (bbc_vec3){-0.1, 0.55, 0};
  for (int i = 0; i < 3; i++) g->n[i] = (bbc_vec3){-k * g->p[i].x, -k * g->p[i].y, 1};
  g->refract = refract;
  g->eta = eta;
  g->length = 1;
}

static void report(const char *name, tally t, const pieces *ps, const bbc_bound_stats *st) {
  printf(
      "%s: %ld points, %ld violations, %ld uncovered, %ld in unbounded pieces, max true E "
      "%.3g; %zu pieces, %.3f s\n",
      name, t.paths, t.violations, t.uncovered, t.unbounded, t.max_true, ps->n,
      st->position_seconds + st->irradiance_seconds);
}

/* unbounded: the largest fraction of the points whose piece may be unbounded (0 where no
 * focus is in range), so that the finite bounds are what is checked. */
static void run(const char *name, const bbc_tuple_geometry *g, const double lo[3],
                const double hi[3], int max_level, long paths, double unbounded) {
  bbc_bound_stats st;
  memset(&st, 0, sizeof st);
  pieces ps = bound(g, lo, hi, max_level, 1e-4, &st);
  tally t = check_paths(g, lo, hi, &ps, paths, -1);
  report(name, t, &ps, &st);
  CHECK(t.paths == paths);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.uncovered, 0);
  CHECK(t.unbounded <= unbounded * t.paths);
  free(ps.p);
}

static const double above_lo[3] = {-3, -3, 0.3}, above_hi[3] = {3, 3, 4};
static const double below_lo[3] = {-3, -3, -4}, below_hi[3] = {3, 3, -0.3};

TEST(reflection_flat) {
  bbc_tuple_geometry g;
  caster(&g, 0, 0, 0);
  run("R flat", &g, above_lo, above_hi, 6, 100000, 0);
}

TEST(reflection_concave_focus) {
  /* Normals (-k x, -k y, 1): a mirror of radius about 1/k, focus near z = 1/(2k) = 1. */
  bbc_tuple_geometry g;
  caster(&g, 0.5, 0, 0);
  run("R concave", &g, above_lo, above_hi, 6, 100000, 0.1);
}

TEST(reflection_convex) {
  bbc_tuple_geometry g;
  caster(&g, -0.5, 0, 0);
  run("R convex", &g, above_lo, above_hi, 6, 100000, 0);
}

TEST(refraction_flat) {
  bbc_tuple_geometry g;
  caster(&g, 0, 1, 1 / 1.5);
  run("T flat", &g, below_lo, below_hi, 6, 100000, 0);
}

TEST(refraction_converging) {
  bbc_tuple_geometry g;
  caster(&g, -1.5, 1, 1 / 1.5);
  run("T converging", &g, below_lo, below_hi, 6, 100000, 0.3);
}

/* The controls: each wrong variant of the bound must be caught. */
static long control(int ablation, const bbc_tuple_geometry *g, const double lo[3],
                    const double hi[3]) {
  bbc_bound_stats st;
  memset(&st, 0, sizeof st);
  bbc__beam_ablation = ablation;
  pieces ps = bound(g, lo, hi, 4, 1e-2, &st);
  bbc__beam_ablation = 0;
  tally t = check_paths(g, lo, hi, &ps, 20000, -1);
  printf("control %d: %ld of %ld points violated\n", ablation, t.violations, t.paths);
  free(ps.p);
  return t.violations;
}

TEST(control_without_cosine) {
  bbc_tuple_geometry g;
  caster(&g, 0, 0, 0);
  g.light = (bbc_vec3){-2.5, 0.1, 2.5}; /* rays at about 45 degrees to every axis plane */
  CHECK(control(1, &g, above_lo, above_hi) > 0);
}

TEST(control_end_planes_only) {
  bbc_tuple_geometry g;
  caster(&g, 0.5, 0, 0);
  CHECK(control(2, &g, above_lo, above_hi) > 0);
}

TEST(reflection_oblique) {
  bbc_tuple_geometry g;
  caster(&g, 0.2, 0, 0);
  g.light = (bbc_vec3){-2.5, 0.1, 2.5};
  run("R oblique", &g, above_lo, above_hi, 5, 100000, 0.1);
}

/* ---- two bounces ------------------------------------------------------------------- */

/* T2 at height z (slightly tilted), its normals (k2 x, k2 y, s) with s = -1 (facing T1,
 * below) or +1. */
static void second(bbc_tuple_geometry *g, double z, double k2, double s, int refract2,
                   double eta2) {
  g->length = 2;
  g->p2[0] = (bbc_vec3){-2.0, -2.0, z};
  g->p2[1] = (bbc_vec3){2.5, -1.8, z + 0.3};
  g->p2[2] = (bbc_vec3){-1.9, 2.5, z + 0.15};
  for (int i = 0; i < 3; i++) g->n2[i] = (bbc_vec3){k2 * g->p2[i].x, k2 * g->p2[i].y, s};
  g->refract2 = refract2;
  g->eta2 = eta2;
}

TEST(double_rr) {
  bbc_tuple_geometry g;
  caster(&g, 0.3, 0, 0);
  second(&g, 1.5, 0.1, -1, 0, 0);
  const double lo[3] = {-4, -4, -3}, hi[3] = {4, 4, 1.2};
  run("RR", &g, lo, hi, 6, 100000, 0.75);
}

TEST(double_rt) {
  bbc_tuple_geometry g;
  caster(&g, 0.3, 0, 0);
  second(&g, 1.5, -0.1, -1, 1, 1 / 1.5);
  const double lo[3] = {-4, -4, 2.0}, hi[3] = {4, 4, 6};
  run("RT", &g, lo, hi, 6, 100000, 0.15);
}

TEST(double_tr) {
  bbc_tuple_geometry g;
  caster(&g, -0.3, 1, 1 / 1.5);
  second(&g, -1.5, 0.1, 1, 0, 0);
  const double lo[3] = {-4, -4, -1.2}, hi[3] = {4, 4, -0.1};
  run("TR", &g, lo, hi, 6, 100000, 0);
}

TEST(double_tt) {
  /* A lens: T1 enters the glass, T2 leaves it below (eta = ior). */
  bbc_tuple_geometry g;
  caster(&g, -0.4, 1, 1 / 1.5);
  second(&g, -0.8, -0.3, 1, 1, 1.5);
  const double lo[3] = {-4, -4, -6}, hi[3] = {4, 4, -1.0};
  run("TT", &g, lo, hi, 6, 100000, 0);
}

/* ---- other lights ------------------------------------------------------------------ */

TEST(sun_concave) {
  bbc_tuple_geometry g;
  caster(&g, 0.5, 0, 0);
  g.light_model.kind = BBC_LIGHT_DIRECTIONAL;
  g.light_model.direction = v3_normalize((bbc_vec3){0.2, -0.1, -1});
  g.light = (bbc_vec3){0, 0, 0};
  run("R sun concave", &g, above_lo, above_hi, 6, 100000, 0.1);
}

TEST(sun_lens_tt) {
  bbc_tuple_geometry g;
  caster(&g, -0.4, 1, 1 / 1.5);
  second(&g, -0.8, -0.3, 1, 1, 1.5);
  g.light_model.kind = BBC_LIGHT_DIRECTIONAL;
  g.light_model.direction = v3_normalize((bbc_vec3){-0.1, 0.15, -1});
  const double lo[3] = {-4, -4, -6}, hi[3] = {4, 4, -1.0};
  run("TT sun", &g, lo, hi, 6, 100000, 0.15);
}

TEST(spot_refraction) {
  bbc_tuple_geometry g;
  caster(&g, -1.0, 1, 1 / 1.5);
  g.light_model.kind = BBC_LIGHT_SPOT;
  g.light_model.direction = v3_normalize((bbc_vec3){0.05, 0, -1});
  g.light_model.cos_outer = cos(0.25);
  g.light_model.cone_scale = 1 / fmax(0.001, cos(0.1) - cos(0.25));
  run("T spot", &g, below_lo, below_hi, 6, 100000, 0);
}

/* ---- against the bound on a receiver plane ----------------------------------------- */

typedef struct plane_pieces {
  bbc_piece *p;
  size_t n, cap;
} plane_pieces;

static int collect_plane(void *user, const bbc_piece *piece) {
  plane_pieces *ps = user;
  if (ps->n == ps->cap) {
    ps->cap = ps->cap ? 2 * ps->cap : 1024;
    ps->p = realloc(ps->p, ps->cap * sizeof *ps->p);
  }
  ps->p[ps->n++] = *piece;
  return 0;
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : x > y;
}

/* For paths landing on the plane z = c: the beam's e_hi at that lambda against the
 * plane bound's (bbc_bound_tuple on a triangle of the plane); returns the median ratio
 * of the two and checks the beam against the true irradiance on the plane. */
static double plane_ratio(const char *name, const bbc_tuple_geometry *g0, const double lo[3],
                          const double hi[3], double c, int max_level) {
  bbc_tuple_geometry g = *g0;
  g.r[0] = (bbc_vec3){-8, -8, c}, g.r[1] = (bbc_vec3){8, -8, c}, g.r[2] = (bbc_vec3){-8, 8, c};
  bbc_bounder *b;
  CHECK(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  prm.max_level = max_level;
  plane_pieces pp = {0};
  bbc_bound_stats sp, sb;
  memset(&sp, 0, sizeof sp);
  memset(&sb, 0, sizeof sb);
  CHECK(bbc_bound_tuple(b, &g, &prm, collect_plane, &pp, &sp) == BBC_OK);
  bbc_bounder_free(b);
  pieces ps = bound(g0, lo, hi, max_level, 1e-2, &sb);
  const long n = 20000;
  double *ratio = malloc(n * sizeof *ratio), *slack = malloc(n * sizeof *slack);
  long k = 0, violations = 0, tries = 0;
  while (k < n && tries++ < 100 * n) {
    double u, v;
    rnd_bary(&u, &v);
    cvec cx, cd;
    double complex w;
    if (!trace(g0, u, v, 1, &cx, &cd, &w)) continue;
    bbc_vec3 x = {creal(cx.x), creal(cx.y), creal(cx.z)};
    bbc_vec3 d = {creal(cd.x), creal(cd.y), creal(cd.z)};
    double t = (c - x.z) / d.z;
    if (!(t > 0)) continue;
    bbc_vec3 y = v3_add(x, v3_scale(d, t));
    if (y.x < lo[0] || y.x > hi[0] || y.y < lo[1] || y.y > hi[1]) continue;
    const double e = true_irradiance(g0, u, v, y, (bbc_vec3){0, 0, 1});
    double beam = INFINITY, plane = INFINITY;
    for (size_t i = 0; i < ps.n; i++) {
      const bbc_beam_piece *p = &ps.p[i];
      if (p->status != BBC_PIECE_KEPT || u < p->u_lo || u > p->u_hi || v < p->v_lo || v > p->v_hi)
        continue;
      if (p->axis >= 0 && (y.z < p->lambda_lo || y.z > p->lambda_hi) && p->axis == 2) continue;
      beam = fmin(beam, p->e_hi);
    }
    for (size_t i = 0; i < pp.n; i++) {
      const bbc_piece *p = &pp.p[i];
      if (p->status != BBC_PIECE_KEPT || u < p->u_lo || u > p->u_hi || v < p->v_lo || v > p->v_hi)
        continue;
      plane = fmin(plane, p->e_hi);
    }
    if (!(e <= beam * (1 + 1e-9))) violations++;
    if (!(plane < INFINITY) || !(e > 0)) continue;
    ratio[k] = beam / plane;
    slack[k] = beam / e;
    k++;
  }
  qsort(ratio, (size_t)k, sizeof *ratio, compare_double);
  qsort(slack, (size_t)k, sizeof *slack, compare_double);
  const double median = k ? ratio[k / 2] : NAN;
  printf(
      "%s at z = %g: %ld paths; beam / plane bound: median %.3g, 90th percentile %.3g; "
      "beam / true E: median %.3g; %zu beam pieces (%.3f s), %zu plane pieces (%.3f s)\n",
      name, c, k, median, k ? ratio[9 * k / 10] : NAN, k ? slack[k / 2] : NAN, ps.n,
      sb.position_seconds + sb.irradiance_seconds, pp.n,
      sp.position_seconds + sp.irradiance_seconds);
  CHECK_INT(violations, 0);
  CHECK(k > 1000);
  free(ratio);
  free(slack);
  free(ps.p);
  free(pp.p);
  return median;
}

TEST(against_plane_bound) {
  bbc_tuple_geometry g;
  caster(&g, 0, 0, 0);
  double r1 = plane_ratio("R flat", &g, above_lo, above_hi, 2.0, 4);
  caster(&g, 0.2, 0, 0);
  double r2 = plane_ratio("R concave", &g, above_lo, above_hi, 2.0, 4);
  caster(&g, -0.5, 1, 1 / 1.5);
  double r3 = plane_ratio("T", &g, below_lo, below_hi, -2.0, 4);
  /* Not absurdly looser: within a small factor of the bound that knows the plane. */
  CHECK(r1 < 10 && r2 < 10 && r3 < 10);
}

/* ---- the caller's cell test --------------------------------------------------------- */

static bbc_piece_need need_half(void *user, const bbc_beam_piece *p) {
  long *asked = user;
  ++*asked;
  /* Nothing is recorded where x < 0 (as if no receiver were there): keep such pieces. */
  return p->box_hi[0] < 0 ? BBC_NEED_NONE : BBC_NEED_SPLIT;
}

TEST(need_callback) {
  /* Pieces the callback stops keep their inherited bounds, which still hold their paths;
   * the subdivision is smaller. */
  bbc_tuple_geometry g;
  caster(&g, 0.5, 0, 0);
  bbc_bound_stats st;
  memset(&st, 0, sizeof st);
  pieces all = bound(&g, above_lo, above_hi, 6, 1e-4, &st);
  pieces ps = {0};
  bbc_bounder *b;
  CHECK(bbc_bounder_create(&b) == BBC_OK);
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  prm.max_level = 6;
  prm.sigma = 1e-4;
  long asked = 0;
  prm.beam_need = need_half;
  prm.need_user = &asked;
  CHECK(bbc_bound_beam(b, &g, above_lo, above_hi, &prm, collect, &ps, NULL) == BBC_OK);
  bbc_bounder_free(b);
  tally t = check_paths(&g, above_lo, above_hi, &ps, 100000, -1);
  printf("need: %zu pieces (%zu without), asked %ld times; %ld violations\n", ps.n, all.n, asked,
         t.violations);
  CHECK(asked > 0);
  CHECK(ps.n < all.n);
  CHECK_INT(t.violations, 0);
  CHECK_INT(t.uncovered, 0);
  free(ps.p);
  free(all.p);
}

TEST(bad_receivers_box) {
  bbc_tuple_geometry g;
  caster(&g, 0, 0, 0);
  bbc_bounder *b;
  CHECK(bbc_bounder_create(&b) == BBC_OK);
  const double lo[3] = {0, 0, 1}, hi[3] = {1, 1, 0}, nan_hi[3] = {1, NAN, 2};
  pieces ps = {0};
  CHECK(bbc_bound_beam(b, &g, lo, hi, NULL, collect, &ps, NULL) == BBC_ERR_INVALID_ARGUMENT);
  CHECK(bbc_bound_beam(b, &g, lo, nan_hi, NULL, collect, &ps, NULL) == BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(ps.n, 0);
  bbc_bounder_free(b);
}
