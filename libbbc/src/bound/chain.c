/* Rational forms of a chain (paper Sec. 4.3): on a piece of T1's barycentrics, the first
 * vertex x1 and its interpolated normal n1 are affine in the piece's variables (Eq. 6-7);
 * the outgoing direction d1 follows Eq. 10, the next vertex Eq. 9, and for two bounces
 * the second vertex, its normal and direction the same way with a rational origin.
 * Everything is built with the Bernstein engine, whose error radii keep rounding
 * accounted for. */
#include "chain_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "vec_internal.h"

#define TRY(expr)                \
  do {                           \
    bbc_result r_ = (expr);      \
    if (r_ != BBC_OK) return r_; \
  } while (0)

/* A constant vector whose coordinates are rounded results (differences of exact
 * inputs): widened by one ulp of each. */
static bbc_result rounded_constant(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 v) {
  TRY(bbc_poly3_constant(arena, out, v));
  bbc_poly *c[3] = {&out->x, &out->y, &out->z};
  for (int i = 0; i < 3; i++) bbc_poly_widen(c[i], DBL_EPSILON * fabs(c[i]->coef[0]));
  return BBC_OK;
}

/* The scattered direction of Eq. 10 for the incident direction d at a vertex with the
 * unnormalised normal n (on the incident side), given d_dot_n = d . n (the caller has it
 * for the facing condition): reflection, or refraction with ratio eta, whose part before
 * sqrt(beta) (scatter_tangent) and whose sqrt (scatter_root) are two steps, so that the
 * forms of another sqrt mode can start from the first (bbc__chain_forms_rescatter). */
static bbc_result scatter_root(bbc_arena *arena, bbc_space *space, const bbc_poly3 *n,
                               const bbc_poly3 *tangent, const bbc_poly *beta,
                               chain_sqrt_mode mode, bbc_poly3 *out, int *slope_enclosed,
                               double *value_radius);

/* Refraction's tangent = eta ((n.n) d - (d.n) n) and beta (Eq. 11); reflection's direction
 * (n.n) d - 2 (d.n) n in *out (tangent and beta untouched). */
static bbc_result scatter_tangent(bbc_arena *arena, const bbc_poly3 *d, const bbc_poly3 *n,
                                  const bbc_poly *d_dot_n, int refract, double eta,
                                  bbc_poly3 *out, bbc_poly3 *tangent, bbc_poly *beta) {
  bbc_poly nn, dn = *d_dot_n;
  TRY(bbc_poly3_dot(arena, &nn, n, n));
  /* (n.n) d - k (d.n) n: the tangential part shared by both cases of Eq. 10. */
  bbc_poly3 nn_d, dn_n;
  TRY(bbc_poly3_scale(arena, &nn_d, &nn, d));
  TRY(bbc_poly3_scale(arena, &dn_n, &dn, n));
  if (!refract) {
    bbc_poly3 two_dn_n;
    TRY(bbc_poly3_scale_const(arena, &two_dn_n, 2.0, &dn_n));
    return bbc_poly3_sub(arena, out, &nn_d, &two_dn_n);
  }
  /* beta = (1 - eta^2)(n.n)(d.d) + eta^2 (d.n)^2 (Eq. 11). */
  const double eta2 = eta * eta;
  bbc_poly dd, nn_dd, dn2, a, b;
  TRY(bbc_poly3_dot(arena, &dd, d, d));
  TRY(bbc_poly_mul(arena, &nn_dd, &nn, &dd));
  TRY(bbc_poly_mul(arena, &dn2, &dn, &dn));
  /* 1 - eta^2 and eta^2 are rounded; the products' relative error is covered by
   * widening with a few ulps of the terms' magnitudes. */
  TRY(bbc_poly_scale(arena, &a, &nn_dd, 1.0 - eta2));
  TRY(bbc_poly_scale(arena, &b, &dn2, eta2));
  TRY(bbc_poly_add(arena, beta, &a, &b));
  {
    bbc_interval ra = bbc_poly_bound(&nn_dd), rb = bbc_poly_bound(&dn2);
    double m = fmax(fabs(ra.lo), fabs(ra.hi)) + fmax(fabs(rb.lo), fabs(rb.hi)) * eta2;
    bbc_poly_widen(beta, 4 * DBL_EPSILON * m);
  }
  /* eta ((n.n) d - (d.n) n), with n on the incident side. */
  bbc_poly3 tangential;
  TRY(bbc_poly3_sub(arena, &tangential, &nn_d, &dn_n));
  return bbc_poly3_scale_const(arena, tangent, eta, &tangential);
}

/* d1 = tangent - sqrt(beta) n, with sqrt(beta) entering as `mode` says; *slope_enclosed is
 * cleared when a derivative-aware sqrt lost its slope, *value_radius receives its value
 * remainder's radius (chain_forms.value_radius). */
static bbc_result scatter_root(bbc_arena *arena, bbc_space *space, const bbc_poly3 *n,
                               const bbc_poly3 *tangent, const bbc_poly *beta,
                               chain_sqrt_mode mode, bbc_poly3 *out, int *slope_enclosed,
                               double *value_radius) {
  bbc_poly root;
  if (mode == CHAIN_SQRT_PRIMAL) {
    TRY(bbc_poly_sqrt_primal(arena, space, &root, beta, NULL, NULL, NULL));
  } else if (mode == CHAIN_SQRT_DERIVATIVE_AWARE) {
    /* The value remainder (zeta of Supp. Eq. 16) stays out of the forms: on an axis of its
     * own it made the Jacobian's determinant cubic in one more variable, four times the
     * coefficients; beside them it is one constant for the whole piece. */
    bbc_sqrt_derivative_aware fit;
    TRY(bbc_poly_sqrt_derivative_centred(arena, space, &root, NULL, value_radius, beta, NULL, 0.0,
                                         &fit, NULL));
    if (!fit.slope_enclosed) *slope_enclosed = 0;
  } else {
    bbc_sqrt_primal fit;
    bbc_interval rb = bbc_poly_bound(beta);
    TRY(bbc_sqrt_primal_fit(fmax(rb.lo, 0.0), fmax(rb.hi, 0.0), &fit));
    bbc_poly scaled;
    TRY(bbc_poly_scale(arena, &scaled, beta, fit.a));
    TRY(bbc_poly_add_scalar(arena, &root, &scaled, fit.b));
  }
  bbc_poly3 root_n;
  TRY(bbc_poly3_scale(arena, &root_n, &root, n));
  return bbc_poly3_sub(arena, out, tangent, &root_n);
}

/* Moller-Trumbore (Eq. 9) for the ray o + t d against the triangle tri:
 * u = up / kappa, v = vp / kappa and t = tnum / kappa, where kappa = (d x e2) . e1. */
/* b - a, and whether the double difference is exact (its TwoSum error term is 0). */
static double exact_difference(double b, double a, int *exact) {
  double s = b - a, bv = s + a, av = bv - s;
  double t = (b - bv) + (-a - (-av));
  if (t != 0 || !isfinite(s)) *exact = 0;
  return s;
}

static bbc_result hit(bbc_arena *arena, const bbc_poly3 *o, const bbc_poly3 *d,
                      const bbc_vec3 tri[3], bbc_poly *up, bbc_poly *vp, bbc_poly *kappa,
                      bbc_poly *tnum) {
  bbc_poly3 p0, e1, e2, rel, pvec, qvec;
  /* The receiver's vertices are floats, so its edges are almost always exact in double:
   * then they enter as exact constants and the products with them are linear
   * combinations, which are cheaper than products of polynomials and carry their own
   * rounding in err. Otherwise they are rounded constants with a radius, as below. */
  int exact = 1;
  const bbc_vec3 x1 = {exact_difference(tri[1].x, tri[0].x, &exact),
                       exact_difference(tri[1].y, tri[0].y, &exact),
                       exact_difference(tri[1].z, tri[0].z, &exact)};
  const bbc_vec3 x2 = {exact_difference(tri[2].x, tri[0].x, &exact),
                       exact_difference(tri[2].y, tri[0].y, &exact),
                       exact_difference(tri[2].z, tri[0].z, &exact)};
  TRY(bbc_poly3_constant(arena, &p0, tri[0]));
  if (exact) {
    TRY(bbc_poly3_sub(arena, &rel, o, &p0));
    TRY(bbc_poly3_cross_vec(arena, &pvec, d, x2));
    TRY(bbc_poly3_dot_vec(arena, kappa, &pvec, x1));
    TRY(bbc_poly3_dot(arena, up, &pvec, &rel));
    TRY(bbc_poly3_cross_vec(arena, &qvec, &rel, x1));
    TRY(bbc_poly3_dot(arena, vp, &qvec, d));
    TRY(bbc_poly3_dot_vec(arena, tnum, &qvec, x2));
    return BBC_OK;
  }
  TRY(rounded_constant(arena, &e1, v3_sub(tri[1], tri[0])));
  TRY(rounded_constant(arena, &e2, v3_sub(tri[2], tri[0])));
  TRY(bbc_poly3_sub(arena, &rel, o, &p0));
  TRY(bbc_poly3_cross(arena, &pvec, d, &e2));
  TRY(bbc_poly3_dot(arena, kappa, &pvec, &e1));
  TRY(bbc_poly3_dot(arena, up, &pvec, &rel));
  TRY(bbc_poly3_cross(arena, &qvec, &rel, &e1));
  TRY(bbc_poly3_dot(arena, vp, &qvec, d));
  TRY(bbc_poly3_dot(arena, tnum, &qvec, &e2));
  return BBC_OK;
}

bbc_result bbc__chain_forms_rest(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                 chain_sqrt_mode mode, chain_forms *out) {
  if (out->length == 2)
    return bbc__chain_double_rest(arena, space, g, mode == CHAIN_SQRT_DERIVATIVE_AWARE, out);
  TRY(hit(arena, &out->x1, &out->d1, g->r, &out->up, &out->vp, &out->kappa, &out->tnum));
  if (mode == CHAIN_SQRT_DERIVATIVE_AWARE && out->has_beta && out->value_radius > 0) {
    /* Eq. 9 is linear in the direction: the forms of d1 - delta n1 are those of d1 minus
     * delta times those of n1 (tnum does not depend on the direction). */
    bbc_poly tnum_n;
    TRY(hit(arena, &out->x1, &out->n1, g->r, &out->up_n, &out->vp_n, &out->kappa_n, &tnum_n));
    out->has_value_fold = 1;
  }
  return BBC_OK;
}

bbc_result bbc__chain_forms_retarget(bbc_arena *arena, bbc_space *space, const bbc_vec3 tri[3],
                                     const chain_forms *from, chain_forms *out) {
  *out = *from;
  if (from->length == 2) return bbc__chain_double_retarget(arena, space, tri, out);
  TRY(hit(arena, &from->x1, &from->d1, tri, &out->up, &out->vp, &out->kappa, &out->tnum));
  if (from->has_value_fold) {
    bbc_poly tnum_n;
    TRY(hit(arena, &from->x1, &from->n1, tri, &out->up_n, &out->vp_n, &out->kappa_n, &tnum_n));
  }
  return BBC_OK;
}

void bbc__chain_direction(const chain_forms *f, bbc_poly3 *out) {
  if (f->length == 2)
    bbc__chain_double_direction(f, out);
  else
    *out = f->d1;
}

bbc_result bbc__chain_forms_rescatter(bbc_arena *arena, bbc_space *space,
                                      const bbc_tuple_geometry *g, const chain_forms *from,
                                      chain_sqrt_mode mode, chain_forms *out) {
  if (from->length != 1 || !from->has_beta) return BBC_ERR_INVALID_ARGUMENT;
  /* What does not depend on sqrt: the forms before it, by value (their coefficients stay
   * where they are, in the arena). */
  memset(out, 0, sizeof *out);
  out->length = 1;
  out->has_beta = 1;
  out->slope_enclosed = 1;
  out->x1 = from->x1, out->n1 = from->n1, out->tangent = from->tangent;
  out->beta = from->beta, out->facing = from->facing, out->dist2 = from->dist2;
  out->emit = from->emit;
  TRY(scatter_root(arena, space, &out->n1, &out->tangent, &out->beta, mode, &out->d1,
                   &out->slope_enclosed, &out->value_radius));
  return bbc__chain_forms_rest(arena, space, g, mode, out);
}

bbc_result bbc__chain_forms(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                            const double box[4], int s_axis, int t_axis, chain_sqrt_mode mode,
                            chain_forms *out) {
  TRY(bbc__chain_forms_prefix(arena, space, g, box, s_axis, t_axis, mode, out));
  return bbc__chain_forms_rest(arena, space, g, mode, out);
}

bbc_result bbc__chain_area_axes(bbc_space *space, int s_axis, int t_axis, int axes[2]) {
  int n = 0;
  for (int j = BBC_POLY_MAX_AXES - 1; j >= 0 && n < 2; j--)
    if (space->kind[j] == BBC_AXIS_GEOMETRIC && j != s_axis && j != t_axis) axes[n++] = j;
  while (n < 2) TRY(bbc_space_add_axis(space, BBC_AXIS_GEOMETRIC, &axes[n++]));
  return BBC_OK;
}

void bbc__chain_light_box(const bbc_tuple_geometry *g, double box[4]) {
  const double *b = g->light_box;
  if (b[0] == 0 && b[1] == 0 && b[2] == 0 && b[3] == 0) {
    box[0] = 0, box[1] = 1, box[2] = 0, box[3] = 1;
  } else {
    for (int i = 0; i < 4; i++) box[i] = b[i];
  }
}

bbc_result bbc__chain_area_light(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                 int s_axis, int t_axis, bbc_poly3 *out) {
  /* x0 = q0 + a e1 + a b f with e1 = q1 - q0, f = q2 - q1 (scene.h), a and b linear in
   * their axes over the light box: exact Bernstein coefficients (bbc_poly_linear), the
   * product a b exact in real arithmetic. e1 and f are rounded differences of the exact
   * vertices (one ulp each), which with |a|, |ab| <= 1 widens each coordinate by an ulp
   * of |e1| + |f|; the scalings and sums account for their own rounding. */
  int axes[2];
  TRY(bbc__chain_area_axes(space, s_axis, t_axis, axes));
  double lb[4];
  bbc__chain_light_box(g, lb);
  const bbc_vec3 *q = g->light_model.emitter;
  bbc_poly a, b, ab;
  TRY(bbc_poly_linear(arena, &a, axes[0], lb[0], lb[1]));
  TRY(bbc_poly_linear(arena, &b, axes[1], lb[2], lb[3]));
  TRY(bbc_poly_mul(arena, &ab, &a, &b));
  const bbc_vec3 e1 = v3_sub(q[1], q[0]), f = v3_sub(q[2], q[1]);
  const double qc[3] = {q[0].x, q[0].y, q[0].z}, ec[3] = {e1.x, e1.y, e1.z}, fc[3] = {f.x, f.y, f.z};
  bbc_poly *c[3] = {&out->x, &out->y, &out->z};
  for (int i = 0; i < 3; i++) {
    bbc_poly ta, tb;
    TRY(bbc_poly_scale(arena, &ta, &a, ec[i]));
    TRY(bbc_poly_scale(arena, &tb, &ab, fc[i]));
    TRY(bbc_poly_add(arena, c[i], &ta, &tb));
    TRY(bbc_poly_add_scalar(arena, c[i], c[i], qc[i]));
    bbc_poly_widen(c[i], DBL_EPSILON * (fabs(ec[i]) + fabs(fc[i])));
  }
  return BBC_OK;
}

bbc_result bbc__chain_forms_prefix(bbc_arena *arena, bbc_space *space,
                                   const bbc_tuple_geometry *g, const double box[4], int s_axis,
                                   int t_axis, chain_sqrt_mode mode, chain_forms *out) {
  const double u_lo = box[0], u_hi = box[1], v_lo = box[2], v_hi = box[3];
  const double su = u_hi - u_lo, sv = v_hi - v_lo;
  bbc_poly3 n1, d0;
  bbc_poly3 *x1 = &out->x1, *d1 = &out->d1;
  memset(out, 0, sizeof *out);
  out->length = g->length == 2 ? 2 : 1;
  out->has_beta = g->refract;
  out->slope_enclosed = 1;
  if (out->length == 2)
    return bbc__chain_double_prefix(arena, space, g, box, s_axis, t_axis,
                                    mode == CHAIN_SQRT_DERIVATIVE_AWARE, out);
  /* Edges are rounded differences of the exact vertices; affine3 widens by their
   * rounding too. */
  TRY(bbc__chain_affine(arena, x1, g->p[0], v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0]), u_lo, v_lo,
              su, sv, s_axis, t_axis));
  TRY(bbc__chain_affine(arena, &n1, g->n[0], v3_sub(g->n[1], g->n[0]), v3_sub(g->n[2], g->n[0]), u_lo, v_lo,
              su, sv, s_axis, t_axis));
  bbc_poly dn;
  if (g->light_model.kind == BBC_LIGHT_DIRECTIONAL) {
    /* A sun: d0 is its constant direction (exact input) and dist2 = 1, the factor
     * 1 / |d0|^2 being absent for parallel light (docs/lights.md). */
    TRY(bbc_poly3_constant(arena, &d0, g->light_model.direction));
    TRY(bbc_poly_constant(arena, &out->dist2, 1.0));
  } else if (g->light_model.kind == BBC_LIGHT_AREA) {
    bbc_poly3 light;
    TRY(bbc__chain_area_light(arena, space, g, s_axis, t_axis, &light));
    TRY(bbc__chain_area_axes(space, s_axis, t_axis, out->light_axes));
    out->light_axis_count = 2;
    TRY(bbc_poly3_sub(arena, &d0, x1, &light));
    TRY(bbc_poly3_dot(arena, &out->dist2, &d0, &d0));
    TRY(bbc_poly3_dot_vec(arena, &out->emit, &d0, g->light_model.emitter_normal));
  } else {
    bbc_poly3 light;
    TRY(bbc_poly3_constant(arena, &light, g->light));
    TRY(bbc_poly3_sub(arena, &d0, x1, &light));
    TRY(bbc_poly3_dot(arena, &out->dist2, &d0, &d0));
  }
  if (g->light_model.kind != BBC_LIGHT_AREA) TRY(bbc_poly_constant(arena, &out->emit, 1.0));
  TRY(bbc_poly3_dot(arena, &dn, &d0, &n1));
  TRY(bbc_poly_scale(arena, &out->facing, &dn, -1.0));
  out->n1 = n1;
  TRY(scatter_tangent(arena, &d0, &n1, &dn, g->refract, g->eta, d1, &out->tangent, &out->beta));
  if (g->refract)
    TRY(scatter_root(arena, space, &n1, &out->tangent, &out->beta, mode, d1, &out->slope_enclosed,
                     &out->value_radius));
  return BBC_OK;
}
