/* The exact tracer the bound tests check against: an oracle written independently of
 * the library (normalised reflection and refraction, forward-mode dual numbers for the
 * Jacobian), sharing neither the polynomial forms of the bounder (Eq. 9-13) nor the code
 * of bbc_specular_path_trace, so agreement between them means something.
 *
 * It works on a bbc_tuple_geometry, whose normals the bounder has already turned toward
 * the light (bounds.h): a path is valid when the light arrives against that oriented
 * shading normal (for refraction this is the side rule the renderer applies too), the
 * refracted ray exists, the receiver's plane lies ahead, and both u1 and u_k fall inside
 * their triangles. The irradiance is per unit intensity, E = dOmega0/du1 / dA_k/du1.
 *
 * Header-only with static functions so that every test runner that includes it gets its
 * own copy; it includes vec_internal.h, so the runner needs libbbc/src on its include
 * path (all unit tests have it). */
#ifndef BBC_TEST_EXACT_TRACER_ORACLE_H
#define BBC_TEST_EXACT_TRACER_ORACLE_H

#include <math.h>

#include "bbc/bounds.h"
#include "vec_internal.h"

typedef struct dual {
  double v, du, dv;
} dual;
typedef struct dvec {
  dual x, y, z;
} dvec;

static inline dual d_const(double v) {
  return (dual){v, 0, 0};
}
static inline dual d_add(dual a, dual b) {
  return (dual){a.v + b.v, a.du + b.du, a.dv + b.dv};
}
static inline dual d_sub(dual a, dual b) {
  return (dual){a.v - b.v, a.du - b.du, a.dv - b.dv};
}
static inline dual d_mul(dual a, dual b) {
  return (dual){a.v * b.v, a.du * b.v + a.v * b.du, a.dv * b.v + a.v * b.dv};
}
static inline dual d_div(dual a, dual b) {
  double inv = 1.0 / b.v;
  return (dual){a.v * inv, (a.du - a.v * inv * b.du) * inv, (a.dv - a.v * inv * b.dv) * inv};
}
static inline dual d_sqrt(dual a) {
  double s = sqrt(a.v);
  return (dual){s, a.du / (2 * s), a.dv / (2 * s)};
}
static inline dvec dv_make(bbc_vec3 c, bbc_vec3 du, bbc_vec3 dv) {
  return (dvec){{c.x, du.x, dv.x}, {c.y, du.y, dv.y}, {c.z, du.z, dv.z}};
}
static inline dvec dv_const(bbc_vec3 c) {
  return dv_make(c, v3(0, 0, 0), v3(0, 0, 0));
}
static inline dvec dv_add(dvec a, dvec b) {
  return (dvec){d_add(a.x, b.x), d_add(a.y, b.y), d_add(a.z, b.z)};
}
static inline dvec dv_sub(dvec a, dvec b) {
  return (dvec){d_sub(a.x, b.x), d_sub(a.y, b.y), d_sub(a.z, b.z)};
}
static inline dvec dv_scale(dvec a, dual s) {
  return (dvec){d_mul(a.x, s), d_mul(a.y, s), d_mul(a.z, s)};
}
static inline dual dv_dot(dvec a, dvec b) {
  return d_add(d_add(d_mul(a.x, b.x), d_mul(a.y, b.y)), d_mul(a.z, b.z));
}
static inline dvec dv_cross(dvec a, dvec b) {
  return (dvec){d_sub(d_mul(a.y, b.z), d_mul(a.z, b.y)), d_sub(d_mul(a.z, b.x), d_mul(a.x, b.z)),
                d_sub(d_mul(a.x, b.y), d_mul(a.y, b.x))};
}
static inline bbc_vec3 dv_part(dvec a, int which) {
  return which == 0   ? v3(a.x.v, a.y.v, a.z.v)
         : which == 1 ? v3(a.x.du, a.y.du, a.z.du)
                      : v3(a.x.dv, a.y.dv, a.z.dv);
}

typedef struct true_path {
  int valid;
  double uk, vk;
  double irradiance; /* per unit intensity */
} true_path;

/* The exact path from the light through T1 at barycentrics (u, v) to Tk's plane. */
static inline true_path trace(const bbc_tuple_geometry *g, double u, double v) {
  true_path out = {0, 0, 0, 0};
  bbc_vec3 e1 = v3_sub(g->p[1], g->p[0]), e2 = v3_sub(g->p[2], g->p[0]);
  dvec x1 = dv_add(dv_const(g->p[0]), dv_make(v3_add(v3_scale(e1, u), v3_scale(e2, v)), e1, e2));
  bbc_vec3 dn1 = v3_sub(g->n[1], g->n[0]), dn2 = v3_sub(g->n[2], g->n[0]);
  dvec n = dv_make(v3_add(g->n[0], v3_add(v3_scale(dn1, u), v3_scale(dn2, v))), dn1, dn2);
  dvec d0 = dv_sub(x1, dv_const(g->light));
  dual len0 = d_sqrt(dv_dot(d0, d0)), lenn = d_sqrt(dv_dot(n, n));
  dvec dh = dv_scale(d0, d_div(d_const(1), len0));
  dvec nh = dv_scale(n, d_div(d_const(1), lenn));
  dual c = d_sub(d_const(0), dv_dot(dh, nh));
  if (!(c.v > 0)) return out;
  dvec d1;
  if (!g->refract) {
    d1 = dv_add(dh, dv_scale(nh, d_mul(d_const(2), c)));
  } else {
    dual eta = d_const(g->eta);
    dual k = d_sub(d_const(1), d_mul(d_mul(eta, eta), d_sub(d_const(1), d_mul(c, c))));
    if (!(k.v > 0)) return out;
    d1 = dv_add(dv_scale(dh, eta), dv_scale(nh, d_sub(d_mul(eta, c), d_sqrt(k))));
  }
  /* Moller-Trumbore against Tk's plane. */
  dvec r0 = dv_const(g->r[0]);
  dvec re1 = dv_const(v3_sub(g->r[1], g->r[0])), re2 = dv_const(v3_sub(g->r[2], g->r[0]));
  dvec pvec = dv_cross(d1, re2);
  dual det = dv_dot(re1, pvec);
  dvec w = dv_sub(x1, r0);
  dvec qvec = dv_cross(w, re1);
  dual uk = d_div(dv_dot(w, pvec), det), vk = d_div(dv_dot(d1, qvec), det);
  dual t = d_div(dv_dot(re2, qvec), det);
  if (!(t.v > 0)) return out;
  if (!(uk.v >= 0 && vk.v >= 0 && uk.v + vk.v <= 1)) return out;
  if (!(u >= 0 && v >= 0 && u + v <= 1)) return out;
  dvec xk = dv_add(x1, dv_scale(d1, t));
  /* E = dOmega0/du1 / dA_k/du1 with dOmega0/du1 = |n_g . d0| |e1 x e2| / |d0|^3. */
  bbc_vec3 c1 = v3_cross(e1, e2);
  bbc_vec3 d0v = dv_part(d0, 0);
  double r = v3_length(d0v);
  double domega = fabs(v3_dot(c1, d0v)) / (r * r * r);
  bbc_vec3 nk = v3_normalize(v3_cross(dv_part(re1, 0), dv_part(re2, 0)));
  double darea = fabs(v3_dot(v3_cross(dv_part(xk, 1), dv_part(xk, 2)), nk));
  out.valid = 1;
  out.uk = uk.v;
  out.vk = vk.v;
  out.irradiance = domega / darea;
  return out;
}

#endif
