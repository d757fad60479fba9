/* Light kinds (scene.h's bbc_light_model) as the bounds, the exact paths and the
 * renderer see them: where light comes from relative to a surface, and the spot falloff
 * in interval arithmetic. */
#ifndef BBC_LIGHT_INTERNAL_H
#define BBC_LIGHT_INTERNAL_H

#include "bbc/interval.h"
#include "bbc/scene.h"

/* A point that stands for the light when judging which side of a plane through `near`
 * the light is on: the light's position, or for a sun near - direction (the sun lies
 * infinitely far against its direction of travel). */
bbc_vec3 bbc__light_source(bbc_vec3 position, const bbc_light_model *model, bbc_vec3 near);

/* The direction light travels from the light to x (not normalised): x - position, or a
 * sun's direction. */
bbc_vec3 bbc__light_d0(bbc_vec3 position, const bbc_light_model *model, bbc_vec3 x);

/* An enclosure of bbc_light_falloff over every point x1 of the box of barycentrics
 * box = {u_lo, u_hi, v_lo, v_hi} of the triangle p[0..2] (x1 = p0 + u e1 + v e2), for a
 * light at `position`: outward rounded, within [0, 1]; [1, 1] for kinds without falloff.
 * hi = 0 proves that no point of the box is lit. */
bbc_interval bbc__light_falloff_over_box(bbc_vec3 position, const bbc_light_model *model,
                                         const bbc_vec3 p[3], const double box[4]);

#endif
