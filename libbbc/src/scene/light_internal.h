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

/* Suns with an angular size (bbc_light_model.angular_diameter > 0): a disk of directions
 * around -direction of half-angle h = delta / 2, radiance E x
 * bbc_light_sun_radiance_scale(delta). bbc__sun_is_disk says whether a model is one;
 * bbc__sun_solid_angle is the cone's 2 pi (1 - cos h); bbc__sun_sample maps u in [0, 1)^2
 * to a unit direction toward the sun, uniform over the cone (density 1 / solid angle);
 * bbc__sun_contains says whether unit direction w (toward the sky) lies in the cone. */
int bbc__sun_is_disk(const bbc_light_model *model);
double bbc__sun_solid_angle(const bbc_light_model *model);
bbc_vec3 bbc__sun_sample(const bbc_light_model *model, const double u[2]);
int bbc__sun_contains(const bbc_light_model *model, bbc_vec3 w);

/* Area lights (kind BBC_LIGHT_AREA, scene.h): the emitter point of (a, b) in [0, 1]^2,
 * the centroid (which stands for the light in side tests, as a point light's position
 * does), and A_e cos(theta_e) for light leaving y toward x1: the factor that turns the
 * irradiance per unit intensity of a point light at y into the estimate per unit
 * radiance of y drawn uniformly by area (0 behind the emitter's front). */
bbc_vec3 bbc__area_point(const bbc_light_model *model, double a, double b);
bbc_vec3 bbc__area_centroid(const bbc_light_model *model);
double bbc__area_weight(const bbc_light_model *model, bbc_vec3 y, bbc_vec3 x1);

/* Cache light `light` (scene.h; in range) as the point that stands for it: a punctual
 * light itself; an emitter as a light in air at its centroid, with its model. */
bbc_point_light bbc__cache_light_point(const bbc_scene *scene, uint32_t light);

/* The brightness per RGB channel of cache light `light` (scene.h): a punctual light's
 * intensity (W/sr; W/m^2 for a sun) or an emitter's radiance (W/sr/m^2, written into
 * buffer). Zero for an index out of range. */
const float *bbc__cache_light_intensity(const bbc_scene *scene, uint32_t light, float buffer[3]);

/* The radiance of emitter light `light` (l >= point_light_count, in range) at its point
 * y: the material's emission times its emissive texture at y (bbc_scene_emission), at
 * most bbc__cache_light_intensity's. */
void bbc__area_radiance(const bbc_scene *scene, uint32_t light, bbc_vec3 y, float out[3]);

#endif
