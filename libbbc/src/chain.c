/* Rational forms of a single-scattering chain (paper Sec. 4.3): on a piece of T1's
 * barycentrics, the first vertex x1 and its interpolated normal n1 are affine in the
 * piece's variables (Eq. 6-7); the outgoing direction d1 follows Eq. 10, and the receiver
 * barycentrics Eq. 9. Everything is built with the Bernstein engine, whose error radii
 * keep rounding accounted for. */
#include "chain_internal.h"

#include <float.h>
#include <math.h>

#include "vec_internal.h"

#define TRY(expr)                \
  do {                           \
    bbc_result r_ = (expr);      \
    if (r_ != BBC_OK) return r_; \
  } while (0)

/* c + gs s + gt t per coordinate, widened by the rounding of c and the gradients, which
 * the caller computed in double from the exact float inputs. */
static bbc_result affine3(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 base, bbc_vec3 du, bbc_vec3 dv,
                          double u_lo, double v_lo, double su, double sv, int s_axis, int t_axis) {
  bbc_vec3 c = v3_add(base, v3_add(v3_scale(du, u_lo), v3_scale(dv, v_lo)));
  bbc_vec3 grad[BBC_POLY_MAX_AXES] = {{0, 0, 0}};
  grad[s_axis] = v3_scale(du, su);
  grad[t_axis] = v3_scale(dv, sv);
  TRY(bbc_poly3_affine(arena, out, c, grad));
  /* Each coordinate of c is a sum of three rounded terms; 4 ulps of the magnitudes
   * cover it, and of the gradients (products by powers of two are exact, by other
   * scales one rounding). */
  double radius[3] = {4 * DBL_EPSILON * (fabs(base.x) + fabs(du.x * u_lo) + fabs(dv.x * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].x) + fabs(grad[t_axis].x)),
                      4 * DBL_EPSILON * (fabs(base.y) + fabs(du.y * u_lo) + fabs(dv.y * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].y) + fabs(grad[t_axis].y)),
                      4 * DBL_EPSILON * (fabs(base.z) + fabs(du.z * u_lo) + fabs(dv.z * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].z) + fabs(grad[t_axis].z))};
  bbc_poly_widen(&out->x, radius[0]);
  bbc_poly_widen(&out->y, radius[1]);
  bbc_poly_widen(&out->z, radius[2]);
  return BBC_OK;
}

bbc_result bbc__chain_forms(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                            const double box[4], int s_axis, int t_axis, chain_sqrt_mode mode,
                            chain_forms *out) {
  const double u_lo = box[0], u_hi = box[1], v_lo = box[2], v_hi = box[3];
  const double su = u_hi - u_lo, sv = v_hi - v_lo;
  bbc_poly3 n1, d0;
  bbc_poly3 *x1 = &out->x1, *d1 = &out->d1;
  /* Edges are rounded differences of the exact vertices; affine3 widens by their
   * rounding too. */
  TRY(affine3(arena, x1, g->p[0], v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0]), u_lo, v_lo,
              su, sv, s_axis, t_axis));
  TRY(affine3(arena, &n1, g->n[0], v3_sub(g->n[1], g->n[0]), v3_sub(g->n[2], g->n[0]), u_lo, v_lo,
              su, sv, s_axis, t_axis));
  bbc_poly3 light;
  TRY(bbc_poly3_constant(arena, &light, g->light));
  TRY(bbc_poly3_sub(arena, &d0, x1, &light));

  bbc_poly nn, dn;
  TRY(bbc_poly3_dot(arena, &nn, &n1, &n1));
  TRY(bbc_poly3_dot(arena, &dn, &d0, &n1));
  TRY(bbc_poly3_dot(arena, &out->dist2, &d0, &d0));
  TRY(bbc_poly_scale(arena, &out->facing, &dn, -1.0));
  out->has_beta = 0;
  out->slope_enclosed = 1;

  /* (n.n) d0 - k (d0.n) n: the tangential part shared by both cases of Eq. 10. */
  bbc_poly3 nn_d0, dn_n;
  TRY(bbc_poly3_scale(arena, &nn_d0, &nn, &d0));
  TRY(bbc_poly3_scale(arena, &dn_n, &dn, &n1));
  if (!g->refract) {
    bbc_poly3 two_dn_n;
    TRY(bbc_poly3_scale_const(arena, &two_dn_n, 2.0, &dn_n));
    TRY(bbc_poly3_sub(arena, d1, &nn_d0, &two_dn_n));
  } else {
    /* beta = (1 - eta^2)(n.n)(d0.d0) + eta^2 (d0.n)^2 (Eq. 11). */
    const double eta = g->eta, eta2 = eta * eta;
    bbc_poly nn_dd, dn2, a, b;
    TRY(bbc_poly_mul(arena, &nn_dd, &nn, &out->dist2));
    TRY(bbc_poly_mul(arena, &dn2, &dn, &dn));
    /* 1 - eta^2 and eta^2 are rounded; the products' relative error is covered by
     * widening with a few ulps of the terms' magnitudes. */
    TRY(bbc_poly_scale(arena, &a, &nn_dd, 1.0 - eta2));
    TRY(bbc_poly_scale(arena, &b, &dn2, eta2));
    TRY(bbc_poly_add(arena, &out->beta, &a, &b));
    {
      bbc_interval ra = bbc_poly_bound(&nn_dd), rb = bbc_poly_bound(&dn2);
      double m = fmax(fabs(ra.lo), fabs(ra.hi)) + fmax(fabs(rb.lo), fabs(rb.hi)) * eta2;
      bbc_poly_widen(&out->beta, 4 * DBL_EPSILON * m);
    }
    out->has_beta = 1;

    bbc_poly root;
    if (mode == CHAIN_SQRT_PRIMAL) {
      TRY(bbc_poly_sqrt_primal(arena, space, &root, &out->beta, NULL, NULL, NULL));
    } else if (mode == CHAIN_SQRT_DERIVATIVE_AWARE) {
      bbc_sqrt_derivative_aware fit;
      TRY(bbc_poly_sqrt_derivative_aware(arena, space, &root, NULL, &out->beta, NULL, 0.0, &fit,
                                         NULL));
      out->slope_enclosed = fit.slope_enclosed;
    } else {
      bbc_sqrt_primal fit;
      bbc_interval rb = bbc_poly_bound(&out->beta);
      TRY(bbc_sqrt_primal_fit(fmax(rb.lo, 0.0), fmax(rb.hi, 0.0), &fit));
      bbc_poly scaled;
      TRY(bbc_poly_scale(arena, &scaled, &out->beta, fit.a));
      TRY(bbc_poly_add_scalar(arena, &root, &scaled, fit.b));
    }
    /* d1 = eta ((n.n) d0 - (d0.n) n) - sqrt(beta) n, with n on the incident side. */
    bbc_poly3 tangential, scaled, root_n;
    TRY(bbc_poly3_sub(arena, &tangential, &nn_d0, &dn_n));
    TRY(bbc_poly3_scale_const(arena, &scaled, eta, &tangential));
    TRY(bbc_poly3_scale(arena, &root_n, &root, &n1));
    TRY(bbc_poly3_sub(arena, d1, &scaled, &root_n));
  }

  /* Moller-Trumbore against the receiver (Eq. 9). Its edges are constant polynomials
   * widened by their rounding (half an ulp of each coordinate). */
  bbc_poly3 rp0, re1, re2, w, pvec, qvec;
  TRY(bbc_poly3_constant(arena, &rp0, g->r[0]));
  TRY(bbc_poly3_constant(arena, &re1, v3_sub(g->r[1], g->r[0])));
  TRY(bbc_poly3_constant(arena, &re2, v3_sub(g->r[2], g->r[0])));
  bbc_poly *edge_coords[6] = {&re1.x, &re1.y, &re1.z, &re2.x, &re2.y, &re2.z};
  for (int i = 0; i < 6; i++)
    bbc_poly_widen(edge_coords[i], DBL_EPSILON * fabs(edge_coords[i]->coef[0]));
  TRY(bbc_poly3_sub(arena, &w, x1, &rp0));
  TRY(bbc_poly3_cross(arena, &pvec, d1, &re2));
  TRY(bbc_poly3_dot(arena, &out->kappa, &pvec, &re1));
  TRY(bbc_poly3_dot(arena, &out->up, &pvec, &w));
  TRY(bbc_poly3_cross(arena, &qvec, &w, &re1));
  TRY(bbc_poly3_dot(arena, &out->vp, &qvec, d1));
  TRY(bbc_poly3_dot(arena, &out->tnum, &qvec, &re2));
  return BBC_OK;
}
