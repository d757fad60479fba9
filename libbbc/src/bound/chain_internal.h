/* Rational forms of a chain of one or two specular vertices on one piece of T1's
 * barycentric domain (paper Sec. 4.3, Eq. 6-11), as Bernstein polynomials in the piece's
 * box variables. */
#ifndef BBC_CHAIN_INTERNAL_H
#define BBC_CHAIN_INTERNAL_H

#include "bbc/bernstein.h"
#include "bbc/bounds.h"

/* How sqrt(beta) of refraction (Eq. 10-11) enters the forms. */
typedef enum chain_sqrt_mode {
  CHAIN_SQRT_PRIMAL,           /* linearisation + one remainder variable (Supp. Eq. 6-12):
                                  encloses values, for position bounds */
  CHAIN_SQRT_DERIVATIVE_AWARE, /* the slope remainder of Supp. Eq. 15-25 as a variable and
                                  the value remainder as a constant beside the forms
                                  (chain_forms.value_radius; two bounces: chain_double.c):
                                  encloses values and first derivatives, for irradiance */
  CHAIN_SQRT_NO_REMAINDER      /* the bare linearisation: not conservative (Fig. 18) */
} chain_sqrt_mode;

/* u_k = up / kappa and v_k = vp / kappa (Eq. 9, Moller-Trumbore with a common
 * denominator: kappa = (d1 x e_k2) . e_k1 for one bounce, kappa2 kappa_k for two); the
 * ray reaches the receiver ahead of its last vertex where tnum kappa > 0.
 * facing = -(n1 . d0) must be positive for light arriving on the normal's side; beta
 * (refraction only) must be non-negative (no total internal reflection); dist2 = d0 . d0.
 *
 * Two bounces: u2 = up2 / kappa2, v2 = vp2 / kappa2 on T2, ahead of x1 where
 * tnum2 kappa2 > 0; facing2 (the same sign as -(n2 . d1)) and beta2 as at the first
 * vertex. */
typedef struct chain_forms {
  bbc_poly up, vp, kappa, tnum, facing, dist2;
  /* Area lights: emit = d0 . n_e (n_e the emitter's front normal, scene.h), positive
   * where the emitter point sends light toward x1; the constant 1 for other lights. */
  bbc_poly emit;
  bbc_poly beta;
  bbc_poly3 x1, d1; /* the first vertex and the unnormalised outgoing direction (Eq. 10) */
  int length;       /* specular vertices: 1 or 2 */
  int has_beta;
  int slope_enclosed; /* derivative-aware mode: 0 when a beta came too close to 0 for the
                         slope of sqrt to be enclosed (irradiance is then unbounded) */
  /* One bounce, derivative-aware mode: sqrt(beta)'s value remainder is not an axis of the
   * forms but a constant delta, |delta| <= value_radius (bbc_poly_sqrt_derivative_centred):
   * the exact up, vp and kappa are up - delta up_n, vp - delta vp_n and kappa - delta kappa_n,
   * the forms of Eq. 9 with d1 replaced by n1 (Eq. 10: d1 = ... - sqrt(beta) n1), for the
   * same delta in all three and their derivatives. has_value_fold says that up_n, vp_n and
   * kappa_n are set (only when value_radius > 0). */
  double value_radius;
  int has_value_fold;
  bbc_poly3 n1;
  bbc_poly up_n, vp_n, kappa_n;
  /* One bounce, refraction: eta ((n1.n1) d0 - (d0.n1) n1), d1 but for its sqrt term. */
  bbc_poly3 tangent;
  bbc_poly up2, vp2, kappa2, tnum2, facing2, beta2;
  int has_beta2;
  int slope_enclosed2; /* derivative mode: 0 when beta2 came too close to 0 for the slope
                          of its sqrt (the explicit Jacobian, not the implicit one) */
  /* Two bounces, irradiance: the derivatives of up, vp and kappa with respect to the
   * piece's variables, carried in forward mode (chain_double.c). */
  int has_derivatives;
  bbc_poly up_s, up_t, vp_s, vp_t, kappa_s, kappa_t;
  /* An area light: the axes of the emitter's (a, b); light_axis_count is 2 then, else
   * 0. Two bounces cap every reduction on them at CHAIN_LIGHT_DEGREE
   * (bbc__flatten_light), one bounce the Jacobian's products (bounder.c). */
  int light_axes[2];
  int light_axis_count;
  void *scratch; /* state between the two steps below, in the arena */
} chain_forms;

/* Area lights: the emitter's parameters (a, b) over g->light_box are the two geometric
 * axes of space other than s_axis and t_axis (the highest ones), claimed here when the
 * caller has not claimed them. */
/* The box of the piece: u = u_lo + (u_hi - u_lo) s, v = v_lo + (v_hi - v_lo) t with s on
 * axis s_axis and t on axis t_axis of space. Remainder axes are claimed from space. */
bbc_result bbc__chain_forms(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                            const double box[4], int s_axis, int t_axis, chain_sqrt_mode mode,
                            chain_forms *out);

/* The forms of one refraction in `mode` from those `from` of another mode on the same piece
 * and light box (computed in this arena, which must still hold them; space has their
 * remainder axes claimed): sqrt(beta) and what follows it (d1, up, vp, kappa, tnum) are
 * computed, the rest is shared. The same polynomials as bbc__chain_forms in `mode` with
 * the same space gives. */
bbc_result bbc__chain_forms_rescatter(bbc_arena *arena, bbc_space *space,
                                      const bbc_tuple_geometry *g, const chain_forms *from,
                                      chain_sqrt_mode mode, chain_forms *out);

/* The forms of `from` (complete, computed for g->r) for another receiver triangle tri
 * whose edges are g->r's (a plane of the same family, docs/beams.md): up, vp, kappa,
 * tnum, the value fold's and the two-bounce derivatives of the same ray against tri, in
 * the same space; the rest is shared. Two bounces: from's scratch must still live. */
bbc_result bbc__chain_forms_retarget(bbc_arena *arena, bbc_space *space, const bbc_vec3 tri[3],
                                     const chain_forms *from, chain_forms *out);
bbc_result bbc__chain_double_retarget(bbc_arena *arena, bbc_space *space, const bbc_vec3 tri[3],
                                      chain_forms *out);
/* The last vertex's unnormalised outgoing direction (d1, or d2 for two bounces: its
 * value, which encloses the direction in the primal modes). */
void bbc__chain_direction(const chain_forms *f, bbc_poly3 *out);
void bbc__chain_double_direction(const chain_forms *f, bbc_poly3 *out);

/* bbc__chain_forms in two steps, so that a piece whose light provably misses T2 is
 * discarded before the costly rest is built: the prefix computes x1, d1, facing, beta,
 * dist2 and (two bounces) up2, vp2, kappa2, tnum2; the rest everything else. */
bbc_result bbc__chain_forms_prefix(bbc_arena *arena, bbc_space *space,
                                   const bbc_tuple_geometry *g, const double box[4], int s_axis,
                                   int t_axis, chain_sqrt_mode mode, chain_forms *out);
bbc_result bbc__chain_forms_rest(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                 chain_sqrt_mode mode, chain_forms *out);

/* The two axes of an area light's (a, b) (see above), the light box (g->light_box, or
 * [0, 1]^2 when it is all zero) and x0 as a polynomial over them. */
bbc_result bbc__chain_area_axes(bbc_space *space, int s_axis, int t_axis, int axes[2]);
void bbc__chain_light_box(const bbc_tuple_geometry *g, double box[4]);
bbc_result bbc__chain_area_light(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                 int s_axis, int t_axis, bbc_poly3 *out);

/* c + du (u_lo + su s) + dv (v_lo + sv t) per coordinate, widened by the rounding of the
 * caller-side setup (Eq. 6-7 on a piece). */
bbc_result bbc__chain_affine(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 base, bbc_vec3 du,
                             bbc_vec3 dv, double u_lo, double v_lo, double su, double sv, int s_axis,
                             int t_axis);

/* The two steps for two bounces (chain_double.c), in forward mode: with derivatives set
 * (irradiance), up, vp and kappa come with their derivatives. */
bbc_result bbc__chain_double_prefix(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                    const double box[4], int s_axis, int t_axis, int derivatives,
                                    chain_forms *out);
bbc_result bbc__chain_double_rest(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                  int derivatives, chain_forms *out);

/* Whether a point of the box lo..hi can lie on a ray x1 + t d1, t > 0, for some x1 in x
 * and d1 in d (intervals, outward rounded): 0 proves that none does. */
int bbc__ray_may_meet_box(const bbc_ivec3 *x, const bbc_ivec3 *d, const double lo[3],
                          const double hi[3]);

/* 1 when no light of the box of T1's barycentrics box = {u_lo, u_hi, v_lo, v_hi} can
 * reach T2 (g->length 2, a point, spot or sun): x1 and the scattered d1 in interval
 * arithmetic over the box (the vertex normals interpolated as in the forms), their rays
 * against T2's bounding box. A proof: such a piece holds no path. Far cheaper than the
 * two-bounce forms, it lets the bounders discard the parts of T1 that miss T2 first. */
int bbc__chain_second_unreachable(const bbc_tuple_geometry *g, const double box[4]);

/* Implicit differentiation of the last refraction (Eq. 17-19) for two bounces whose
 * second vertex refracts, on forms computed with derivatives: with the receiver
 * barycentrics as two more variables over uk_box = {u_lo, u_hi, v_lo, v_hi} (alpha,
 * beta on [0, 1]) and the constraints F, G built with the vector b,
 * |det d(s,t)/d(alpha,beta)| = |det_ab / det_st| at every path of the piece.
 * bbc__chain_double_implicit_prepare computes, in the arena, what does not depend on b
 * (*out points there); bbc__chain_double_implicit then takes any b, as often as needed,
 * while that part of the arena lives. */
typedef struct chain_implicit chain_implicit;
bbc_result bbc__chain_double_implicit_prepare(bbc_arena *arena, const bbc_space *space,
                                              const bbc_tuple_geometry *g, const chain_forms *f,
                                              const double uk_box[4], chain_implicit **out);
bbc_result bbc__chain_double_implicit(bbc_arena *arena, const chain_implicit *prep,
                                      const bbc_tuple_geometry *g, const chain_forms *f,
                                      bbc_vec3 b, bbc_poly *det_ab, bbc_poly *det_st);

/* p reduced to at most max_degree on every geometric axis and without remainder axes,
 * what the reduction misses folded into the error radius (see chain_double.c). */
bbc_result bbc__flatten(bbc_arena *arena, const bbc_space *space, bbc_poly *out,
                        const bbc_poly *p, int max_degree);

/* The degree an area light's axes (a, b) are reduced to in two-bounce forms. The
 * emitter point enters d0 linearly in each, and an emitter part is small against its
 * distance to T1, so the forms vary little along them; without the cap the explicit
 * determinant would reach degree 39 on four axes (40^4 coefficients). */
#define CHAIN_LIGHT_DEGREE 2
/* ... and in the implicit form (Eq. 17-19), whose polynomials have two more axes (the
 * receiver's): 0, the emitter part entering as an interval of the error radius. With
 * degree 1 there one TT tuple of the generated glass sphere (80 triangles, area light
 * 0.25) took 7.0 s of irradiance bounds instead of 2.1 s, 60 % of it in the implicit form. */
#define CHAIN_LIGHT_DEGREE_IMPLICIT 0

/* bbc__flatten with the axes light_axes[0..1] (NULL: none) reduced to at most
 * min(max_degree, light_degree). The same enclosure argument: what the fit misses
 * over every axis goes into the error radius. */
bbc_result bbc__flatten_light(bbc_arena *arena, const bbc_space *space, bbc_poly *out,
                              const bbc_poly *p, int max_degree, const int *light_axes,
                              int light_degree);

#endif
