/* Rational forms of a double-scattering chain (paper Sec. 4.3-4.4 for two specular
 * vertices), in forward mode: every quantity is carried as its value and its two partial
 * derivatives with respect to the piece's variables s and t, each a Bernstein polynomial.
 *
 * Why forward mode. The Jacobian of Eq. 16 needs the derivatives of the receiver forms,
 * whose degree reaches 34 in s and t for double refraction with interpolated normals,
 * with four remainder axes; the explicit determinant would have degree 102 and millions
 * of coefficients. Degree reduction (Sec. 6.1) cuts that down, but the derivative of a
 * reduced polynomial says nothing about the derivative of the original. Carrying the
 * derivatives alongside the values (product rule at every step) lets every intermediate
 * be reduced: value and derivatives are separate enclosures, each valid on its own.
 *
 * How reduction keeps the bounds conservative. flatten() fits a polynomial of at most
 * FLATTEN_DEGREE in s and t (least squares, bbc_poly_reduce_split), bounds what the fit
 * misses over every axis (old remainder axes included) by [lo, hi], and returns the fit
 * shifted to the middle with the half-width added to its error radius. That radius is a
 * bound on every coefficient's uncertainty: the true quantity at each point is
 * sum_i c_i B_i(s, t) with each c_i within the radius of the stored coefficient, which
 * is exactly what every operation and bound of the engine assumes of `err` (products,
 * sums, elevation and the rational bound of Eq. 3 all hold coefficient-wise, pointwise
 * in s and t). So no remainder axis is claimed, the independence rule cannot be broken,
 * and the axes stay free: a remainder per coefficient instead of one per quantity.
 *
 * Square roots (Eq. 10-11): the value is the primal linearisation with its remainder
 * axis (Supp. Eq. 6-12), flattened at once; the derivative is sqrt'(beta) beta' with
 * sqrt'(beta) = 1 / (2 sqrt(beta)) enclosed by a linear function of beta plus an interval
 * over beta's range (slope_linear). */
#include <float.h>
#include <math.h>
#include <string.h>

#include "bbc/interval.h"
#include "bernstein_internal.h"
#include "chain_internal.h"
#include "vec_internal.h"

#define TRY(expr)                \
  do {                           \
    bbc_result r_ = (expr);      \
    if (r_ != BBC_OK) return r_; \
  } while (0)

/* The degree intermediates are reduced to. The piece is small and the chain smooth, so a
 * low degree loses little; the receiver forms then have degree about twice this. */
#define FLATTEN_DEGREE 3

typedef struct dscal {
  bbc_poly v, s, t; /* value, d/ds, d/dt */
} dscal;

typedef struct dvec {
  dscal x, y, z;
} dvec;

typedef struct dual_ctx {
  bbc_arena *arena;
  bbc_space *space;
  int derivatives;       /* 0: values only (position bounds) */
  const int *light_axes; /* an area light's (a, b) axes (chain_forms.light_axes), or NULL */
  int light_degree;      /* the degree flattening leaves on them */
} dual_ctx;

bbc_result bbc__flatten(bbc_arena *arena, const bbc_space *space, bbc_poly *out,
                        const bbc_poly *p, int max_degree) {
  return bbc__flatten_light(arena, space, out, p, max_degree, NULL, 0);
}

bbc_result bbc__flatten_light(bbc_arena *arena, const bbc_space *space, bbc_poly *out,
                              const bbc_poly *p, int max_degree, const int *light_axes,
                              int light_degree) {
  unsigned char cap[BBC_POLY_MAX_AXES];
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
    cap[j] = (unsigned char)(max_degree < BBC_POLY_MAX_DEGREE ? max_degree : BBC_POLY_MAX_DEGREE);
  for (int k = 0; light_axes && k < 2; k++)
    if (light_axes[k] >= 0 && light_axes[k] < BBC_POLY_MAX_AXES && cap[light_axes[k]] > light_degree)
      cap[light_axes[k]] = (unsigned char)light_degree;
  int plain = 1;
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++) {
    if (p->deg[j] == 0) continue;
    if (space->kind[j] != BBC_AXIS_GEOMETRIC || p->deg[j] > cap[j]) plain = 0;
  }
  if (plain) {
    *out = *p;
    return BBC_OK;
  }
  bbc_poly fit;
  bbc_interval e;
  TRY(bbc__poly_reduce_split_to(arena, space, &fit, &e, p, cap));
  if (!(e.lo <= e.hi) || !isfinite(e.lo) || !isfinite(e.hi)) {
    TRY(bbc_poly_copy(arena, out, &fit));
    out->err = INFINITY;
    return BBC_OK;
  }
  double mid = 0.5 * e.lo + 0.5 * e.hi;
  TRY(bbc_poly_add_scalar(arena, out, &fit, mid));
  /* The half-width, pushed up past the rounding of mid and of the differences. */
  double radius = fmax(e.hi - mid, mid - e.lo);
  bbc_poly_widen(out, radius * (1 + 4 * DBL_EPSILON) + DBL_MIN);
  return BBC_OK;
}

/* ---- scalars and vectors with derivatives ---------------------------------------- */

static bbc_result zero(bbc_arena *arena, bbc_poly *out) {
  return bbc_poly_constant(arena, out, 0.0);
}

/* bbc__flatten in the context's space, an area light's axes capped (chain_internal.h). */
static bbc_result flat(const dual_ctx *c, bbc_poly *out, const bbc_poly *p, int max_degree) {
  return bbc__flatten_light(c->arena, c->space, out, p, max_degree, c->light_axes,
                            c->light_degree);
}

static bbc_result ds_flatten(const dual_ctx *c, dscal *a, int max_degree) {
  TRY(flat(c, &a->v, &a->v, max_degree));
  if (!c->derivatives) return BBC_OK;
  TRY(flat(c, &a->s, &a->s, max_degree));
  return flat(c, &a->t, &a->t, max_degree);
}

static bbc_result dv_flatten(const dual_ctx *c, dvec *a, int max_degree) {
  TRY(ds_flatten(c, &a->x, max_degree));
  TRY(ds_flatten(c, &a->y, max_degree));
  return ds_flatten(c, &a->z, max_degree);
}

/* a + k b (k = 1 or -1: exact). */
static bbc_result ds_add(const dual_ctx *c, dscal *out, const dscal *a, const dscal *b, int k) {
  bbc_result (*op)(bbc_arena *, bbc_poly *, const bbc_poly *, const bbc_poly *) =
      k > 0 ? bbc_poly_add : bbc_poly_sub;
  TRY(op(c->arena, &out->v, &a->v, &b->v));
  if (!c->derivatives) return BBC_OK;
  TRY(op(c->arena, &out->s, &a->s, &b->s));
  return op(c->arena, &out->t, &a->t, &b->t);
}

static bbc_result ds_scale(const dual_ctx *c, dscal *out, const dscal *a, double k) {
  TRY(bbc_poly_scale(c->arena, &out->v, &a->v, k));
  if (!c->derivatives) return BBC_OK;
  TRY(bbc_poly_scale(c->arena, &out->s, &a->s, k));
  return bbc_poly_scale(c->arena, &out->t, &a->t, k);
}

/* Whether p is the exact constant 0 (the derivative of a constant). */
static int is_zero(const bbc_poly *p) {
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
    if (p->deg[j]) return 0;
  return p->coef[0] == 0 && p->err == 0;
}

/* da b + a db, skipping the products with an exactly zero derivative (constants are
 * common: vertices, edges, normals of flat triangles). */
static bbc_result product_rule(bbc_arena *arena, bbc_poly *out, const bbc_poly *da,
                               const bbc_poly *b, const bbc_poly *a, const bbc_poly *db) {
  int za = is_zero(da), zb = is_zero(db);
  if (za && zb) return zero(arena, out);
  if (za) return bbc_poly_mul(arena, out, a, db);
  if (zb) return bbc_poly_mul(arena, out, da, b);
  bbc_poly x, y;
  TRY(bbc_poly_mul(arena, &x, da, b));
  TRY(bbc_poly_mul(arena, &y, a, db));
  return bbc_poly_add(arena, out, &x, &y);
}

/* The product rule. */
static bbc_result ds_mul(const dual_ctx *c, dscal *out, const dscal *a, const dscal *b) {
  dscal r;
  TRY(bbc_poly_mul(c->arena, &r.v, &a->v, &b->v));
  if (c->derivatives) {
    TRY(product_rule(c->arena, &r.s, &a->s, &b->v, &a->v, &b->s));
    TRY(product_rule(c->arena, &r.t, &a->t, &b->v, &a->v, &b->t));
  }
  *out = r;
  return BBC_OK;
}

/* A constant whose value is a rounded result: widened by an ulp. */
static bbc_result ds_constant(const dual_ctx *c, dscal *out, double value, int rounded) {
  TRY(bbc_poly_constant(c->arena, &out->v, value));
  if (rounded) bbc_poly_widen(&out->v, DBL_EPSILON * fabs(value));
  TRY(zero(c->arena, &out->s));
  return zero(c->arena, &out->t);
}

static bbc_result dv_constant(const dual_ctx *c, dvec *out, bbc_vec3 v, int rounded) {
  TRY(ds_constant(c, &out->x, v.x, rounded));
  TRY(ds_constant(c, &out->y, v.y, rounded));
  return ds_constant(c, &out->z, v.z, rounded);
}

static dscal *dv_at(dvec *v, int i) {
  return i == 0 ? &v->x : i == 1 ? &v->y : &v->z;
}
static const dscal *dv_cat(const dvec *v, int i) {
  return i == 0 ? &v->x : i == 1 ? &v->y : &v->z;
}

static bbc_result dv_add(const dual_ctx *c, dvec *out, const dvec *a, const dvec *b, int k) {
  for (int i = 0; i < 3; i++) TRY(ds_add(c, dv_at(out, i), dv_cat(a, i), dv_cat(b, i), k));
  return BBC_OK;
}

static bbc_result dv_scale_const(const dual_ctx *c, dvec *out, const dvec *a, double k) {
  for (int i = 0; i < 3; i++) TRY(ds_scale(c, dv_at(out, i), dv_cat(a, i), k));
  return BBC_OK;
}

/* s a for a scalar s. */
static bbc_result dv_scale(const dual_ctx *c, dvec *out, const dscal *s, const dvec *a) {
  dvec r;
  for (int i = 0; i < 3; i++) TRY(ds_mul(c, dv_at(&r, i), s, dv_cat(a, i)));
  *out = r;
  return BBC_OK;
}

static bbc_result dv_dot(const dual_ctx *c, dscal *out, const dvec *a, const dvec *b) {
  dscal sum, term;
  TRY(ds_mul(c, &sum, &a->x, &b->x));
  TRY(ds_mul(c, &term, &a->y, &b->y));
  TRY(ds_add(c, &sum, &sum, &term, 1));
  TRY(ds_mul(c, &term, &a->z, &b->z));
  return ds_add(c, out, &sum, &term, 1);
}

static bbc_result dv_cross(const dual_ctx *c, dvec *out, const dvec *a, const dvec *b) {
  dvec r;
  for (int i = 0; i < 3; i++) {
    int j = (i + 1) % 3, k = (i + 2) % 3;
    dscal m1, m2;
    TRY(ds_mul(c, &m1, dv_cat(a, j), dv_cat(b, k)));
    TRY(ds_mul(c, &m2, dv_cat(a, k), dv_cat(b, j)));
    TRY(ds_add(c, dv_at(&r, i), &m1, &m2, -1));
  }
  *out = r;
  return BBC_OK;
}

/* base + du u + dv v on the piece (Eq. 6-7): u = u_lo + su s, v = v_lo + sv t. The
 * value is built as in chain.c; the derivatives are the constants du su and dv sv. */
static bbc_result dv_affine(const dual_ctx *c, dvec *out, bbc_vec3 base, bbc_vec3 du, bbc_vec3 dv,
                            const double box[4], int s_axis, int t_axis) {
  const double su = box[1] - box[0], sv = box[3] - box[2];
  bbc_poly3 value;
  TRY(bbc__chain_affine(c->arena, &value, base, du, dv, box[0], box[2], su, sv, s_axis, t_axis));
  out->x.v = value.x, out->y.v = value.y, out->z.v = value.z;
  if (!c->derivatives) return BBC_OK;
  const double ds[3] = {du.x * su, du.y * su, du.z * su}, dt[3] = {dv.x * sv, dv.y * sv, dv.z * sv};
  for (int i = 0; i < 3; i++) {
    dscal *o = dv_at(out, i);
    TRY(bbc_poly_constant(c->arena, &o->s, ds[i]));
    TRY(bbc_poly_constant(c->arena, &o->t, dt[i]));
    /* du, dv are rounded differences and the products rounded once more. */
    bbc_poly_widen(&o->s, 3 * DBL_EPSILON * fabs(ds[i]));
    bbc_poly_widen(&o->t, 3 * DBL_EPSILON * fabs(dt[i]));
  }
  return BBC_OK;
}

/* e(x) = 1 / (2 sqrt(x)) - a x - b for x in the interval X, outward rounded. */
static bbc_interval slope_error(bbc_interval x, double a, double b) {
  bbc_interval f = bbc_interval_div(bbc_interval_point(0.5), bbc_interval_sqrt(x));
  return bbc_interval_sub(bbc_interval_sub(f, bbc_interval_scale(x, a)), bbc_interval_point(b));
}

/* 1 / (2 sqrt(x)) on [l, r] (0 < l <= r) as a x + b + e, e in *err: the chord. The
 * function is convex, so e is convex too: its maximum is at an end, and it lies above its
 * tangent at any x0 (taken where e' is about 0), whose minimum over [l, r] is at an end.
 * Every value is enclosed in interval arithmetic, whatever a, b and x0 are; they only
 * decide how tight. The error is second order in r - l, where a constant interval
 * [1 / (2 sqrt(r)), 1 / (2 sqrt(l))] is first order. */
static void slope_linear(double l, double r, double *a, double *b, bbc_interval *err) {
  double fl = 0.5 / sqrt(l), fr = 0.5 / sqrt(r);
  double A = r > l ? (fr - fl) / (r - l) : 0.0;
  if (!isfinite(A)) A = 0.0;
  double B = fl - A * l;
  bbc_interval el = slope_error(bbc_interval_point(l), A, B);
  bbc_interval er = slope_error(bbc_interval_point(r), A, B);
  double x0 = A < 0 ? pow(-0.25 / A, 2.0 / 3.0) : l;
  if (!(x0 >= l)) x0 = l;
  if (!(x0 <= r)) x0 = r;
  bbc_interval X0 = bbc_interval_point(x0);
  bbc_interval e0 = slope_error(X0, A, B);
  /* e'(x0) = -1 / (4 x0^1.5) - a */
  bbc_interval d0 = bbc_interval_sub(
      bbc_interval_neg(bbc_interval_div(bbc_interval_point(0.25),
                                        bbc_interval_mul(X0, bbc_interval_sqrt(X0)))),
      bbc_interval_point(A));
  bbc_interval tl = bbc_interval_add(e0, bbc_interval_mul(d0, bbc_interval_sub(bbc_interval_point(l), X0)));
  bbc_interval tr = bbc_interval_add(e0, bbc_interval_mul(d0, bbc_interval_sub(bbc_interval_point(r), X0)));
  *a = A;
  *b = B;
  err->lo = fmin(tl.lo, tr.lo);
  err->hi = fmax(el.hi, er.hi);
}

/* The most Newton steps sqrt_newton takes, and the residual at which it stops. */
#define NEWTON_STEPS 6
#define NEWTON_RESIDUAL 1e-9

/* sqrt(beta) and its derivatives where beta's range [l, r] has 0 < l: y ~ 1/sqrt(beta)
 * by Newton's iteration for the inverse square root, y <- y (3 - beta y^2) / 2, in
 * polynomial arithmetic (each iterate reduced to FLATTEN_DEGREE), from the chord of
 * 1/sqrt over [l, r]. The iterates are only approximants and are taken as exact; what
 * makes the result an enclosure is the residual rho = 1 - beta y^2, bounded over the
 * box (beta's error radius included) by [rho_lo, rho_hi] with rho_hi < 1, and y > 0:
 * then at every point 1/sqrt(beta) = y / sqrt(1 - rho) = y (1 + g) with
 * g = 1/sqrt(1 - rho) - 1 in [g(rho_lo), g(rho_hi)] (g increases), so
 *   sqrt(beta) = beta y (1 + g),   (sqrt(beta))' = beta' / (2 sqrt(beta)) = beta' y (1 + g) / 2,
 * the polynomials beta y and beta' y / 2 with their magnitudes times max |g| added to
 * their error radii. The error is that of the fit, where the chord's (first order in
 * r - l) is larger than the quantity itself when beta nears 0 over a wide range (total
 * internal reflection close by). Returns 0 in *ok when the residual does not allow the
 * enclosure (the caller falls back to the linearisations). */
static bbc_result sqrt_newton(const dual_ctx *c, dscal *out, const dscal *beta, double l, double r,
                              int *ok) {
  *ok = 0;
  const double fl = 1 / sqrt(l), fr = 1 / sqrt(r);
  const double A = r > l ? (fr - fl) / (r - l) : 0.0;
  if (!isfinite(A) || !isfinite(fl)) return BBC_OK;
  bbc_poly y, y2, by2;
  TRY(bbc_poly_scale(c->arena, &y, &beta->v, A));
  TRY(bbc_poly_add_scalar(c->arena, &y, &y, fl - A * l));
  bbc_interval rho = bbc_interval_entire();
  for (int step = 0;; step++) {
    TRY(flat(c, &y, &y, FLATTEN_DEGREE));
    y.err = 0; /* an approximant: exact by choice */
    TRY(bbc_poly_mul(c->arena, &y2, &y, &y));
    TRY(bbc_poly_mul(c->arena, &by2, &beta->v, &y2));
    bbc_interval b = bbc_poly_bound(&by2);
    rho = bbc_interval_sub(bbc_interval_point(1.0), b);
    if (step == NEWTON_STEPS || !(fmax(fabs(rho.lo), fabs(rho.hi)) > NEWTON_RESIDUAL)) break;
    bbc_poly t;
    TRY(bbc_poly_scale(c->arena, &t, &by2, -0.5));
    TRY(bbc_poly_add_scalar(c->arena, &t, &t, 1.5));
    TRY(bbc_poly_mul(c->arena, &y, &y, &t));
  }
  if (!(rho.hi < 1) || !(bbc_poly_bound(&y).lo > 0)) return BBC_OK;
  bbc_interval g = bbc_interval_sub(
      bbc_interval_div(bbc_interval_point(1.0),
                       bbc_interval_sqrt(bbc_interval_sub(bbc_interval_point(1.0), rho))),
      bbc_interval_point(1.0));
  const double G = fmax(fabs(g.lo), fabs(g.hi));
  if (!isfinite(G)) return BBC_OK;
  /* |P g| <= max |P| G for P = beta y and beta' y / 2, rounded up a few ulps. */
  bbc_poly *parts[3] = {&out->v, &out->s, &out->t};
  const bbc_poly *factors[3] = {&beta->v, &beta->s, &beta->t};
  for (int k = 0; k < (c->derivatives ? 3 : 1); k++) {
    TRY(bbc_poly_mul(c->arena, parts[k], factors[k], &y));
    if (k) TRY(bbc_poly_scale(c->arena, parts[k], parts[k], 0.5));
    bbc_interval m = bbc_poly_bound(parts[k]);
    bbc_poly_widen(parts[k], fmax(fabs(m.lo), fabs(m.hi)) * G * (1 + 4 * DBL_EPSILON) + DBL_MIN);
  }
  TRY(flat(c, &out->v, &out->v, FLATTEN_DEGREE));
  *ok = 1;
  return BBC_OK;
}

/* sqrt(beta) with beta >= 0 where it matters: the value by the primal linearisation and
 * its remainder axis, flattened so the axis is free again; the derivatives beta' times
 * 1 / (2 sqrt(beta)), linearised in beta over beta's range (slope_linear).
 * *slope_enclosed is cleared when beta's range reaches down to 0, where that slope is
 * unbounded. */
static bbc_result ds_sqrt_linear(const dual_ctx *c, dscal *out, const dscal *beta,
                                 int *slope_enclosed);

/* Both enclosures are valid: each part keeps the one with the smaller error radius. */
static bbc_result ds_sqrt(const dual_ctx *c, dscal *out, const dscal *beta, int *slope_enclosed) {
  int enclosed = 1, ok = 0;
  TRY(ds_sqrt_linear(c, out, beta, &enclosed));
  bbc_interval range = bbc_poly_bound(&beta->v);
  dscal newton;
  if (c->derivatives && range.lo > 0 && isfinite(range.hi))
    TRY(sqrt_newton(c, &newton, beta, range.lo, range.hi, &ok));
  if (ok) {
    if (newton.v.err < out->v.err) out->v = newton.v;
    if (newton.s.err < out->s.err || !enclosed) out->s = newton.s;
    if (newton.t.err < out->t.err || !enclosed) out->t = newton.t;
  } else if (!enclosed) {
    *slope_enclosed = 0;
  }
  return BBC_OK;
}

static bbc_result ds_sqrt_linear(const dual_ctx *c, dscal *out, const dscal *beta,
                                 int *slope_enclosed) {
  bbc_poly root;
  int axis = -1;
  TRY(bbc_poly_sqrt_primal(c->arena, c->space, &root, &beta->v, NULL, NULL, &axis));
  bbc_result r = flat(c, &out->v, &root, FLATTEN_DEGREE);
  if (axis >= 0) bbc_space_release_axis(c->space, axis);
  if (r != BBC_OK || !c->derivatives) return r;
  bbc_interval range = bbc_poly_bound(&beta->v);
  bbc_poly k;
  if (!(range.lo > 0) || !isfinite(range.hi)) {
    *slope_enclosed = 0;
    TRY(zero(c->arena, &k));
  } else {
    double a, b;
    bbc_interval e;
    slope_linear(range.lo, range.hi, &a, &b, &e);
    if (!(e.lo <= e.hi) || !isfinite(e.lo) || !isfinite(e.hi)) {
      *slope_enclosed = 0;
      TRY(zero(c->arena, &k));
    } else {
      double mid = 0.5 * e.lo + 0.5 * e.hi;
      bbc_poly ab;
      TRY(bbc_poly_scale(c->arena, &ab, &beta->v, a));
      TRY(bbc_poly_add_scalar(c->arena, &k, &ab, b + mid));
      /* b + mid is rounded once more: an ulp of it. */
      bbc_poly_widen(&k, fmax(e.hi - mid, mid - e.lo) * (1 + 4 * DBL_EPSILON) +
                             DBL_EPSILON * fabs(b + mid) + DBL_MIN);
    }
  }
  TRY(bbc_poly_mul(c->arena, &out->s, &k, &beta->s));
  return bbc_poly_mul(c->arena, &out->t, &k, &beta->t);
}

/* Eq. 10-11 for the incident direction d and the unnormalised normal n on the incident
 * side; beta (refraction) goes to *beta_value for the sign conditions. */
static bbc_result dv_scatter(const dual_ctx *c, dvec *out, const dvec *d, const dvec *n, int refract,
                             double eta, bbc_poly *beta_value, int *slope_enclosed) {
  dscal nn, dn;
  dvec nn_d, dn_n;
  TRY(dv_dot(c, &nn, n, n));
  TRY(dv_dot(c, &dn, d, n));
  TRY(dv_scale(c, &nn_d, &nn, d));
  TRY(dv_scale(c, &dn_n, &dn, n));
  if (!refract) {
    dvec two;
    TRY(dv_scale_const(c, &two, &dn_n, 2.0));
    TRY(dv_add(c, out, &nn_d, &two, -1));
    return dv_flatten(c, out, FLATTEN_DEGREE);
  }
  const double eta2 = eta * eta;
  dscal dd, a, b, beta, root;
  TRY(dv_dot(c, &dd, d, d));
  TRY(ds_mul(c, &a, &nn, &dd));
  TRY(ds_mul(c, &b, &dn, &dn));
  TRY(ds_scale(c, &a, &a, 1.0 - eta2));
  TRY(ds_scale(c, &b, &b, eta2));
  TRY(ds_add(c, &beta, &a, &b, 1));
  /* The rounded factors 1 - eta^2 and eta^2: a few ulps of the terms' magnitudes. */
  {
    bbc_interval ra = bbc_poly_bound(&a.v), rb = bbc_poly_bound(&b.v);
    double m = fmax(fabs(ra.lo), fabs(ra.hi)) + fmax(fabs(rb.lo), fabs(rb.hi));
    bbc_poly_widen(&beta.v, 4 * DBL_EPSILON * m);
    if (c->derivatives) {
      bbc_interval sa = bbc_poly_bound(&a.s), sb = bbc_poly_bound(&b.s);
      bbc_interval ta = bbc_poly_bound(&a.t), tb = bbc_poly_bound(&b.t);
      bbc_poly_widen(&beta.s, 4 * DBL_EPSILON *
                                  (fmax(fabs(sa.lo), fabs(sa.hi)) + fmax(fabs(sb.lo), fabs(sb.hi))));
      bbc_poly_widen(&beta.t, 4 * DBL_EPSILON *
                                  (fmax(fabs(ta.lo), fabs(ta.hi)) + fmax(fabs(tb.lo), fabs(tb.hi))));
    }
  }
  TRY(ds_flatten(c, &beta, 2 * FLATTEN_DEGREE));
  *beta_value = beta.v;
  TRY(ds_sqrt(c, &root, &beta, slope_enclosed));
  dvec tangential, scaled, root_n;
  TRY(dv_add(c, &tangential, &nn_d, &dn_n, -1));
  TRY(dv_scale_const(c, &scaled, &tangential, eta));
  TRY(dv_scale(c, &root_n, &root, n));
  TRY(dv_add(c, out, &scaled, &root_n, -1));
  return dv_flatten(c, out, FLATTEN_DEGREE);
}

/* Moller-Trumbore (Eq. 9) for the ray o / w + t d against tri (w NULL for 1):
 * u = up / (w kappa), v = vp / (w kappa), t = tnum / (w kappa). */
static bbc_result dv_hit(const dual_ctx *c, const dvec *o, const dscal *w, const dvec *d,
                         const bbc_vec3 tri[3], dscal *up, dscal *vp, dscal *kappa, dscal *tnum) {
  dvec p0, e1, e2, rel, pvec, qvec;
  TRY(dv_constant(c, &p0, tri[0], 0));
  TRY(dv_constant(c, &e1, v3_sub(tri[1], tri[0]), 1));
  TRY(dv_constant(c, &e2, v3_sub(tri[2], tri[0]), 1));
  if (w) {
    dvec wp0;
    TRY(dv_scale(c, &wp0, w, &p0));
    TRY(dv_add(c, &rel, o, &wp0, -1));
  } else {
    TRY(dv_add(c, &rel, o, &p0, -1));
  }
  TRY(dv_cross(c, &pvec, d, &e2));
  TRY(dv_dot(c, kappa, &pvec, &e1));
  TRY(dv_dot(c, up, &pvec, &rel));
  TRY(dv_cross(c, &qvec, &rel, &e1));
  TRY(dv_dot(c, vp, &qvec, d));
  return dv_dot(c, tnum, &qvec, &e2);
}

/* A constant vector of rounded coordinates (one rounding each). */
static bbc_result rounded_vec(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 v) {
  TRY(bbc_poly3_constant(arena, out, v));
  bbc_poly_widen(&out->x, 2 * DBL_EPSILON * fabs(v.x));
  bbc_poly_widen(&out->y, 2 * DBL_EPSILON * fabs(v.y));
  bbc_poly_widen(&out->z, 2 * DBL_EPSILON * fabs(v.z));
  return BBC_OK;
}

static int flat_normals(const bbc_vec3 n[3]) {
  return n[0].x == n[1].x && n[0].y == n[1].y && n[0].z == n[1].z && n[0].x == n[2].x &&
         n[0].y == n[2].y && n[0].z == n[2].z;
}

/* The working state between the two steps (kept in the forms' scratch). */
typedef struct double_state {
  int light_axes[2]; /* an area light's (a, b) axes */
  int area;          /* whether light_axes are set */
  dvec x1, d1;
  dscal up2, vp2, kappa2, tnum2;
  dvec n2, x2; /* N2 and X2, set by the rest */
  dvec d2;     /* the outgoing direction at T2, set by the rest */
  int derivatives;
} double_state;

bbc_result bbc__chain_double_prefix(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                    const double box[4], int s_axis, int t_axis,
                                    int derivatives, chain_forms *out) {
  dual_ctx c = {arena, space, derivatives, NULL, CHAIN_LIGHT_DEGREE};
  double_state *st = bbc_arena_alloc(arena, sizeof *st);
  if (!st) return BBC_ERR_OUT_OF_MEMORY;
  out->scratch = st;
  st->area = g->light_model.kind == BBC_LIGHT_AREA;
  st->light_axes[0] = st->light_axes[1] = -1;
  if (st->area) {
    /* An area light: (a, b) on the two axes single scattering uses (chain.c), capped at
     * CHAIN_LIGHT_DEGREE wherever a form is flattened. */
    TRY(bbc__chain_area_axes(space, s_axis, t_axis, st->light_axes));
    out->light_axes[0] = st->light_axes[0], out->light_axes[1] = st->light_axes[1];
    out->light_axis_count = 2;
    c.light_axes = st->light_axes;
  }
  dvec n1, light, d0;
  TRY(dv_affine(&c, &st->x1, g->p[0], v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0]), box,
                s_axis, t_axis));
  TRY(dv_affine(&c, &n1, g->n[0], v3_sub(g->n[1], g->n[0]), v3_sub(g->n[2], g->n[0]), box, s_axis,
                t_axis));
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  if (sun) {
    /* A sun: the constant direction d0 (exact input), dist2 = 1 (chain.c). */
    TRY(dv_constant(&c, &d0, g->light_model.direction, 0));
  } else if (st->area) {
    /* x0 = q0 + a e1 + a b f over the piece's light box (the map of single scattering,
     * bbc__chain_area_light), constant in s and t: the Jacobian is taken at a fixed
     * emitter point. */
    bbc_poly3 x0;
    TRY(bbc__chain_area_light(arena, space, g, s_axis, t_axis, &x0));
    const bbc_poly *xc[3] = {&x0.x, &x0.y, &x0.z};
    for (int i = 0; i < 3; i++) {
      dscal *o = dv_at(&light, i);
      o->v = *xc[i];
      TRY(zero(arena, &o->s));
      TRY(zero(arena, &o->t));
    }
    TRY(dv_add(&c, &d0, &st->x1, &light, -1));
  } else {
    TRY(dv_constant(&c, &light, g->light, 0));
    TRY(dv_add(&c, &d0, &st->x1, &light, -1));
  }
  out->x1.x = st->x1.x.v, out->x1.y = st->x1.y.v, out->x1.z = st->x1.z.v;
  dscal dn;
  TRY(dv_dot(&c, &dn, &d0, &n1));
  TRY(bbc_poly_scale(arena, &out->facing, &dn.v, -1.0));
  bbc_poly3 d0v = {d0.x.v, d0.y.v, d0.z.v};
  if (sun)
    TRY(bbc_poly_constant(arena, &out->dist2, 1.0));
  else
    TRY(bbc_poly3_dot(arena, &out->dist2, &d0v, &d0v));
  /* Area lights: d0 . n_e, positive where the emitter point lights x1 (chain_internal.h). */
  if (st->area)
    TRY(bbc_poly3_dot_vec(arena, &out->emit, &d0v, g->light_model.emitter_normal));
  else
    TRY(bbc_poly_constant(arena, &out->emit, 1.0));
  TRY(dv_scatter(&c, &st->d1, &d0, &n1, g->refract, g->eta, &out->beta, &out->slope_enclosed));
  out->d1.x = st->d1.x.v, out->d1.y = st->d1.y.v, out->d1.z = st->d1.z.v;
  TRY(dv_hit(&c, &st->x1, NULL, &st->d1, g->p2, &st->up2, &st->vp2, &st->kappa2, &st->tnum2));
  out->up2 = st->up2.v, out->vp2 = st->vp2.v, out->kappa2 = st->kappa2.v, out->tnum2 = st->tnum2.v;
  return BBC_OK;
}

bbc_result bbc__chain_double_rest(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                  int derivatives, chain_forms *out) {
  double_state *st = out->scratch;
  dual_ctx c = {arena, space, derivatives, st->area ? st->light_axes : NULL, CHAIN_LIGHT_DEGREE};
  /* n2 = N2 / kappa2 with N2 = kappa2 n20 + up2 (n21 - n20) + vp2 (n22 - n20); the normal
   * used is kappa2 N2 = kappa2^2 n2, which points where n2 does whatever the sign of
   * kappa2 (Eq. 10-11 take any positive multiple of the normal). x2 = X2 / kappa2 with
   * X2 = kappa2 x1 + tnum2 d1. */
  dvec n2, x2, a, b;
  if (flat_normals(g->n2)) {
    TRY(dv_constant(&c, &n2, g->n2[0], 0));
  } else {
    dvec n20, dn1, dn2, cc;
    TRY(dv_constant(&c, &n20, g->n2[0], 0));
    TRY(dv_constant(&c, &dn1, v3_sub(g->n2[1], g->n2[0]), 1));
    TRY(dv_constant(&c, &dn2, v3_sub(g->n2[2], g->n2[0]), 1));
    TRY(dv_scale(&c, &a, &st->kappa2, &n20));
    TRY(dv_scale(&c, &b, &st->up2, &dn1));
    TRY(dv_scale(&c, &cc, &st->vp2, &dn2));
    TRY(dv_add(&c, &a, &a, &b, 1));
    TRY(dv_add(&c, &n2, &a, &cc, 1));
    TRY(dv_flatten(&c, &n2, FLATTEN_DEGREE));
    TRY(dv_scale(&c, &n2, &st->kappa2, &n2));
    TRY(dv_flatten(&c, &n2, FLATTEN_DEGREE));
  }
  dscal dn;
  TRY(dv_dot(&c, &dn, &st->d1, &n2));
  TRY(bbc_poly_scale(arena, &out->facing2, &dn.v, -1.0));
  dvec d2;
  out->has_beta2 = g->refract2;
  out->slope_enclosed2 = 1;
  TRY(dv_scatter(&c, &d2, &st->d1, &n2, g->refract2, g->eta2, &out->beta2, &out->slope_enclosed2));
  TRY(dv_scale(&c, &a, &st->kappa2, &st->x1));
  TRY(dv_scale(&c, &b, &st->tnum2, &st->d1));
  TRY(dv_add(&c, &x2, &a, &b, 1));
  TRY(dv_flatten(&c, &x2, FLATTEN_DEGREE));

  st->n2 = n2;
  st->x2 = x2;
  st->d2 = d2;
  st->derivatives = derivatives;
  dscal up, vp, kappa_k, tnum, q;
  TRY(dv_hit(&c, &x2, &st->kappa2, &d2, g->r, &up, &vp, &kappa_k, &tnum));
  TRY(ds_mul(&c, &q, &st->kappa2, &kappa_k));
  out->up = up.v, out->vp = vp.v, out->kappa = q.v, out->tnum = tnum.v;
  out->has_derivatives = derivatives;
  if (derivatives) {
    out->up_s = up.s, out->up_t = up.t, out->vp_s = vp.s, out->vp_t = vp.t;
    out->kappa_s = q.s, out->kappa_t = q.t;
  }
  return BBC_OK;
}

bbc_result bbc__chain_double_retarget(bbc_arena *arena, bbc_space *space, const bbc_vec3 tri[3],
                                      chain_forms *out) {
  const double_state *st = out->scratch;
  dual_ctx c = {arena, space, st->derivatives, st->area ? st->light_axes : NULL,
                CHAIN_LIGHT_DEGREE};
  dscal up, vp, kappa_k, tnum, q;
  TRY(dv_hit(&c, &st->x2, &st->kappa2, &st->d2, tri, &up, &vp, &kappa_k, &tnum));
  TRY(ds_mul(&c, &q, &st->kappa2, &kappa_k));
  out->up = up.v, out->vp = vp.v, out->kappa = q.v, out->tnum = tnum.v;
  if (st->derivatives) {
    out->up_s = up.s, out->up_t = up.t, out->vp_s = vp.s, out->vp_t = vp.t;
    out->kappa_s = q.s, out->kappa_t = q.t;
  }
  return BBC_OK;
}

void bbc__chain_double_direction(const chain_forms *f, bbc_poly3 *out) {
  const double_state *st = f->scratch;
  out->x = st->d2.x.v, out->y = st->d2.y.v, out->z = st->d2.z.v;
}

/* ---- implicit differentiation of the last refraction (Eq. 17-19) ------------------- */

/* a . v for a constant vector v (no degree increase). */
static bbc_result ds_dot_const(const dual_ctx *c, dscal *out, const dvec *a, bbc_vec3 v) {
  dvec k;
  TRY(dv_constant(c, &k, v, 0));
  return dv_dot(c, out, a, &k);
}

/* What the implicit form needs that does not depend on b. */
struct chain_implicit {
  bbc_space space; /* with the two receiver axes */
  dvec d2, m;
  dscal G, l1, l2;
  bbc_poly3 d2a, d2b;
  bbc_poly g_ab[2], d2_dir[2]; /* m . D2_a, m . D2_b and D2 . D2_a, D2 . D2_b */
};

bbc_result bbc__chain_double_implicit_prepare(bbc_arena *arena, const bbc_space *space_in,
                                              const bbc_tuple_geometry *g, const chain_forms *f,
                                              const double uk_box[4], chain_implicit **out) {
  const double_state *st = f->scratch;
  if (!st || !f->has_derivatives) return BBC_ERR_INVALID_ARGUMENT;
  chain_implicit *im = bbc_arena_alloc(arena, sizeof *im);
  if (!im) return BBC_ERR_OUT_OF_MEMORY;
  /* The receiver barycentrics become variables of their own: a = uk_lo + wa alpha,
   * b = vk_lo + wb beta on two fresh geometric axes (the 4D superset of Sec. 4.4). */
  im->space = *space_in;
  int a_axis, b_axis;
  TRY(bbc_space_add_axis(&im->space, BBC_AXIS_GEOMETRIC, &a_axis));
  TRY(bbc_space_add_axis(&im->space, BBC_AXIS_GEOMETRIC, &b_axis));
  dual_ctx c = {arena, &im->space, 1, st->area ? st->light_axes : NULL, CHAIN_LIGHT_DEGREE_IMPLICIT};
  const double wa = uk_box[1] - uk_box[0], wb = uk_box[3] - uk_box[2];
  const bbc_vec3 e1 = v3_sub(g->r[1], g->r[0]), e2 = v3_sub(g->r[2], g->r[0]);
  bbc_poly3 xk;
  TRY(bbc__chain_affine(arena, &xk, g->r[0], e1, e2, uk_box[0], uk_box[2], wa, wb, a_axis, b_axis));

  /* D2 = kappa2 xk - X2 = kappa2 (xk - x2): d2 scaled by kappa2, which changes neither
   * the constraints' zero set nor, on it, the Jacobian (F and G are homogeneous in d2 and
   * n2, and the extra terms of their derivatives vanish where F = G = 0). */
  dvec xk_d;
  for (int i = 0; i < 3; i++) {
    dscal *o = dv_at(&xk_d, i);
    o->v = i == 0 ? xk.x : i == 1 ? xk.y : xk.z;
    TRY(zero(arena, &o->s));
    TRY(zero(arena, &o->t));
  }
  TRY(dv_scale(&c, &im->d2, &st->kappa2, &xk_d));
  TRY(dv_add(&c, &im->d2, &im->d2, &st->x2, -1));
  TRY(dv_flatten(&c, &im->d2, FLATTEN_DEGREE));
  /* dD2/dalpha = kappa2 e1 wa and dD2/dbeta = kappa2 e2 wb (values only). */
  bbc_poly3 ca, cb;
  TRY(rounded_vec(arena, &ca, v3_scale(e1, wa)));
  TRY(rounded_vec(arena, &cb, v3_scale(e2, wb)));
  TRY(bbc_poly3_scale(arena, &im->d2a, &st->kappa2.v, &ca));
  TRY(bbc_poly3_scale(arena, &im->d2b, &st->kappa2.v, &cb));

  /* m = d1 x n2, G = m . d2 and the lengths |d1|^2, |d2|^2 of Eq. 17 (below). */
  TRY(dv_cross(&c, &im->m, &st->d1, &st->n2));
  TRY(dv_flatten(&c, &im->m, FLATTEN_DEGREE));
  TRY(dv_dot(&c, &im->G, &im->m, &im->d2));
  TRY(ds_flatten(&c, &im->G, FLATTEN_DEGREE));
  TRY(dv_dot(&c, &im->l1, &st->d1, &st->d1));
  TRY(ds_flatten(&c, &im->l1, FLATTEN_DEGREE));
  TRY(dv_dot(&c, &im->l2, &im->d2, &im->d2));
  TRY(ds_flatten(&c, &im->l2, FLATTEN_DEGREE));

  /* G_a = m . D2_a, and D2 . D2_a for F_a (likewise for beta). */
  bbc_poly3 m_v = {im->m.x.v, im->m.y.v, im->m.z.v};
  bbc_poly3 d2_v = {im->d2.x.v, im->d2.y.v, im->d2.z.v};
  const bbc_poly3 *dirs[2] = {&im->d2a, &im->d2b};
  for (int k = 0; k < 2; k++) {
    TRY(bbc_poly3_dot(arena, &im->g_ab[k], &m_v, dirs[k]));
    TRY(bbc_poly3_dot(arena, &im->d2_dir[k], &d2_v, dirs[k]));
    TRY(flat(&c, &im->g_ab[k], &im->g_ab[k], FLATTEN_DEGREE));
  }
  *out = im;
  return BBC_OK;
}

bbc_result bbc__chain_double_implicit(bbc_arena *arena, const chain_implicit *im,
                                      const bbc_tuple_geometry *g, const chain_forms *f,
                                      bbc_vec3 b, bbc_poly *det_ab, bbc_poly *det_st) {
  const double_state *st = f->scratch;
  if (!st || !im || !f->has_derivatives) return BBC_ERR_INVALID_ARGUMENT;
  bbc_space space = im->space;
  dual_ctx c = {arena, &space, 1, st->area ? st->light_axes : NULL, CHAIN_LIGHT_DEGREE_IMPLICIT};

  /* Eq. 17 with eta' = n_in / n_out: F = eta'^2 |d2|^2 c1^2 - |d1|^2 c2^2 with
   * c1 = (d1 x n2) . b and c2 = (d2 x n2) . b = d2 . (n2 x b); G = (d1 x n2) . d2. */
  dvec w, bd;
  dscal c1, c2, t1, t2, F;
  TRY(dv_constant(&c, &bd, b, 0));
  TRY(dv_cross(&c, &w, &st->n2, &bd));
  TRY(ds_dot_const(&c, &c1, &im->m, b));
  TRY(dv_dot(&c, &c2, &im->d2, &w));
  TRY(ds_flatten(&c, &c2, FLATTEN_DEGREE));
  dscal c1sq, c2sq;
  TRY(ds_mul(&c, &c1sq, &c1, &c1));
  TRY(ds_mul(&c, &c2sq, &c2, &c2));
  const double eta2 = g->eta2 * g->eta2;
  TRY(ds_mul(&c, &t1, &im->l2, &c1sq));
  TRY(ds_scale(&c, &t1, &t1, eta2));
  TRY(ds_mul(&c, &t2, &im->l1, &c2sq));
  TRY(ds_add(&c, &F, &t1, &t2, -1));
  {
    /* eta'^2 is rounded: a few ulps of the first term. */
    bbc_interval r1 = bbc_poly_bound(&t1.v), rs = bbc_poly_bound(&t1.s), rt = bbc_poly_bound(&t1.t);
    bbc_poly_widen(&F.v, 2 * DBL_EPSILON * fmax(fabs(r1.lo), fabs(r1.hi)));
    bbc_poly_widen(&F.s, 2 * DBL_EPSILON * fmax(fabs(rs.lo), fabs(rs.hi)));
    bbc_poly_widen(&F.t, 2 * DBL_EPSILON * fmax(fabs(rt.lo), fabs(rt.hi)));
  }
  TRY(ds_flatten(&c, &F, FLATTEN_DEGREE));

  /* The alpha and beta derivatives, by the product rule on the values:
   * G_a = m . D2_a; F_a = eta'^2 2 (D2 . D2_a) c1^2 - |d1|^2 2 c2 (D2_a . w). */
  bbc_poly3 w_v = {w.x.v, w.y.v, w.z.v};
  bbc_poly f_ab[2];
  const bbc_poly3 *dirs[2] = {&im->d2a, &im->d2b};
  for (int k = 0; k < 2; k++) {
    bbc_poly p, q, r, u;
    TRY(bbc_poly_mul(arena, &q, &im->d2_dir[k], &c1sq.v));
    TRY(bbc_poly_scale(arena, &q, &q, 2 * eta2));
    bbc_interval rq = bbc_poly_bound(&q);
    bbc_poly_widen(&q, 2 * DBL_EPSILON * fmax(fabs(rq.lo), fabs(rq.hi)));
    TRY(bbc_poly3_dot(arena, &p, dirs[k], &w_v));
    TRY(bbc_poly_mul(arena, &r, &p, &c2.v));
    TRY(bbc_poly_mul(arena, &u, &r, &im->l1.v));
    TRY(bbc_poly_scale(arena, &u, &u, 2.0));
    TRY(bbc_poly_sub(arena, &f_ab[k], &q, &u));
    TRY(flat(&c, &f_ab[k], &f_ab[k], FLATTEN_DEGREE));
  }
  /* Eq. 19: |det d(s,t)/d(alpha,beta)| = |F_a G_b - F_b G_a| / |F_s G_t - F_t G_s|. */
  bbc_poly x, y;
  TRY(bbc_poly_mul(arena, &x, &f_ab[0], &im->g_ab[1]));
  TRY(bbc_poly_mul(arena, &y, &f_ab[1], &im->g_ab[0]));
  TRY(bbc_poly_sub(arena, det_ab, &x, &y));
  TRY(bbc_poly_mul(arena, &x, &F.s, &im->G.t));
  TRY(bbc_poly_mul(arena, &y, &F.t, &im->G.s));
  return bbc_poly_sub(arena, det_st, &x, &y);
}

int bbc__ray_may_meet_box(const bbc_ivec3 *x, const bbc_ivec3 *d, const double lo[3],
                          const double hi[3]) {
  bbc_ivec3 box = {bbc_interval_make(lo[0], hi[0]), bbc_interval_make(lo[1], hi[1]),
                   bbc_interval_make(lo[2], hi[2])};
  bbc_ivec3 w = bbc_ivec3_sub(box, *x);
  bbc_ivec3 c = bbc_ivec3_cross(w, *d);
  if (!(bbc_interval_contains(c.x, 0) && bbc_interval_contains(c.y, 0) &&
        bbc_interval_contains(c.z, 0)))
    return 0;
  return bbc_ivec3_dot(w, *d).hi > 0;
}

/* base + u (a - base) + v (b - base) over the intervals u, v, on exact inputs. */
static bbc_ivec3 affine_over(bbc_vec3 base, bbc_vec3 a, bbc_vec3 b, bbc_interval u,
                             bbc_interval v) {
  const bbc_ivec3 o = bbc_ivec3_point(base);
  const bbc_ivec3 e1 = bbc_ivec3_sub(bbc_ivec3_point(a), o),
                  e2 = bbc_ivec3_sub(bbc_ivec3_point(b), o);
  return bbc_ivec3_add(o, bbc_ivec3_add(bbc_ivec3_scale(u, e1), bbc_ivec3_scale(v, e2)));
}

int bbc__chain_second_unreachable(const bbc_tuple_geometry *g, const double box[4]) {
  if (g->length != 2 || g->light_model.kind == BBC_LIGHT_AREA) return 0;
  const bbc_interval u = bbc_interval_make(box[0], box[1]), v = bbc_interval_make(box[2], box[3]);
  const bbc_ivec3 x1 = affine_over(g->p[0], g->p[1], g->p[2], u, v);
  const bbc_ivec3 n = affine_over(g->n[0], g->n[1], g->n[2], u, v);
  const bbc_ivec3 d0 = g->light_model.kind == BBC_LIGHT_DIRECTIONAL
                           ? bbc_ivec3_point(g->light_model.direction)
                           : bbc_ivec3_sub(x1, bbc_ivec3_point(g->light));
  /* Eq. 10-11 unnormalised, as the forms have them (a positive multiple of the ray's
   * direction): reflection (n.n) d0 - 2 (d0.n) n; refraction eta ((n.n) d0 - (d0.n) n)
   * - sqrt(beta) n with beta = (1 - eta^2)(n.n)(d0.d0) + eta^2 (d0.n)^2. */
  const bbc_interval nn = bbc_ivec3_dot(n, n), dn = bbc_ivec3_dot(d0, n);
  const bbc_ivec3 nn_d = bbc_ivec3_scale(nn, d0);
  bbc_ivec3 d1;
  if (!g->refract) {
    d1 = bbc_ivec3_sub(nn_d, bbc_ivec3_scale(bbc_interval_scale(dn, 2.0), n));
  } else {
    const bbc_interval e2 =
        bbc_interval_mul(bbc_interval_point(g->eta), bbc_interval_point(g->eta));
    bbc_interval beta =
        bbc_interval_add(bbc_interval_mul(bbc_interval_sub(bbc_interval_point(1.0), e2),
                                          bbc_interval_mul(nn, bbc_ivec3_dot(d0, d0))),
                         bbc_interval_mul(e2, bbc_interval_sqr(dn)));
    if (beta.hi < 0) return 1; /* totally reflected everywhere: no refracted light */
    if (beta.lo < 0) beta.lo = 0;
    const bbc_ivec3 tangential = bbc_ivec3_sub(nn_d, bbc_ivec3_scale(dn, n));
    d1 = bbc_ivec3_sub(bbc_ivec3_scale(bbc_interval_point(g->eta), tangential),
                       bbc_ivec3_scale(bbc_interval_sqrt(beta), n));
  }
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int k = 0; k < 3; k++) {
    const double c[3] = {g->p2[k].x, g->p2[k].y, g->p2[k].z};
    for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], c[a]), hi[a] = fmax(hi[a], c[a]);
  }
  return !bbc__ray_may_meet_box(&x1, &d1, lo, hi);
}
