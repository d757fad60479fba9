/* Rational forms of a single-scattering chain on one piece of T1's barycentric domain
 * (paper Sec. 4.3, Eq. 6-11), as Bernstein polynomials in the piece's box variables. */
#ifndef BBC_CHAIN_INTERNAL_H
#define BBC_CHAIN_INTERNAL_H

#include "bbc/bernstein.h"
#include "bbc/bounds.h"

/* How sqrt(beta) of refraction (Eq. 10-11) enters the forms. */
typedef enum chain_sqrt_mode {
  CHAIN_SQRT_PRIMAL,           /* linearisation + one remainder variable (Supp. Eq. 6-12):
                                  encloses values, for position bounds */
  CHAIN_SQRT_DERIVATIVE_AWARE, /* two remainder variables (Supp. Eq. 15-25): encloses
                                  values and first derivatives, for irradiance */
  CHAIN_SQRT_NO_REMAINDER      /* the bare linearisation: not conservative (Fig. 18) */
} chain_sqrt_mode;

/* u_k = up / kappa and v_k = vp / kappa (Eq. 9, Moller-Trumbore with the common
 * denominator kappa = (d1 x e_k2) . e_k1); the hit distance along d1 is tnum / kappa.
 * facing = -(n1 . d0) must be positive for light arriving on the normal's side; beta
 * (refraction only) must be non-negative (no total internal reflection); dist2 = d0 . d0. */
typedef struct chain_forms {
  bbc_poly up, vp, kappa, tnum, facing, dist2;
  bbc_poly beta;
  bbc_poly3 x1, d1; /* the first vertex and the unnormalised outgoing direction (Eq. 10) */
  int has_beta;
  int slope_enclosed; /* derivative-aware mode: 0 when beta came too close to 0 for the
                         slope of sqrt to be enclosed (irradiance is then unbounded) */
} chain_forms;

/* The box of the piece: u = u_lo + (u_hi - u_lo) s, v = v_lo + (v_hi - v_lo) t with s on
 * axis s_axis and t on axis t_axis of space. Remainder axes are claimed from space. */
bbc_result bbc__chain_forms(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                            const double box[4], int s_axis, int t_axis, chain_sqrt_mode mode,
                            chain_forms *out);

#endif
