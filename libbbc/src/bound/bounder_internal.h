/* What the beam bounds (beam.c) share with the tuple bounder (bounder.c). */
#ifndef BBC_BOUNDER_INTERNAL_H
#define BBC_BOUNDER_INTERNAL_H

#include "chain_internal.h"

/* The bounder's working arena (reset by every bound). */
bbc_arena *bbc__bounder_arena(bbc_bounder *b);

/* Where a ray lands on a triangle with u = up / kappa, v = vp / kappa (bounder.c's
 * ray_lands): *partial -1 when no path of the piece lands inside ahead of its vertex, 1
 * when some may not; box (may be NULL) the bound clipped to the triangle's range. */
bbc_result bbc__ray_lands(bbc_arena *arena, const bbc_poly *up, const bbc_poly *vp,
                          const bbc_poly *kappa, const bbc_poly *tnum, double box[8], int *partial,
                          int *wide, int *inside);

/* The explicit irradiance bound (Eq. 14-16) per unit intensity on g->r's plane, for the
 * forms f on the piece box (T1's barycentrics over s_axis and t_axis); forms may depend
 * on more axes than s, t and remainders (the bound is over all of them). The implicit
 * form of two refractions is not tried. [0, +inf] when nothing is learnt. */
bbc_result bbc__irradiance_bound_explicit(bbc_arena *arena, const bbc_space *space,
                                          const bbc_tuple_geometry *g, const chain_forms *f,
                                          const double box[4], int s_axis, int t_axis,
                                          bbc_jacobian_form form, double *e_lo, double *e_hi);

/* Controls for the tests, never set otherwise (0): 1 drops the beam bound's 1 / |cos|
 * factor, 2 bounds the irradiance on the slab's two end planes alone. Both are wrong. */
extern int bbc__beam_ablation;

#endif
