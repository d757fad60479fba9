/* Media: which side of a dielectric surface is glass, and which media light may pass
 * through on its way along a specular chain.
 *
 * A dielectric mesh is a volume (glTF KHR_materials_volume): its inside lies behind its
 * surface and its outside, air, in front. Front is where the winding normals of a
 * closed (watertight) mesh point once oriented out of the enclosed volume, and where
 * the vertex normals of an open mesh point. A point light is in air unless it lies
 * inside a closed dielectric mesh (bbc_point_light.medium).
 *
 * The medium rule: light in air refracts only where it meets a dielectric from the
 * front (and is then inside that mesh); light inside a mesh refracts only where it
 * meets a triangle of that same mesh from behind (and is then in air). Reflections keep
 * the medium. For closed meshes the rule only restates visibility (any other path
 * crosses the surface first); for open meshes it is the volume convention. The tuple
 * finder applies it to whole triangles, the renderer to each path, so a path the
 * renderer counts always belongs to a candidate tuple. */
#ifndef BBC_MEDIA_INTERNAL_H
#define BBC_MEDIA_INTERNAL_H

#include <math.h>

#include "bbc/accel.h"
#include "bbc/scene.h"
#include "bbc/texture.h"
#include "vec_internal.h"

/* Fills every mesh's closed/outward and every point light's medium. */
bbc_result bbc__scene_media(bbc_scene *scene);

/* Fills every mesh's plane and plane_triangle (receiver_plane.c). */
void bbc__scene_planes(bbc_scene *scene);

/* The side of dielectric triangle t's plane point q lies on: +1 front (outside), -1
 * behind (inside), 0 in the plane. */
int bbc__media_side(const bbc_scene *scene, uint32_t t, bbc_vec3 q);

/* The medium rule at dielectric triangle t, met from `side` (+1 front, -1 behind) by
 * light in `medium` (0 air, m + 1 inside mesh m): returns 1 and the medium beyond in
 * *after when the light may refract there, else 0. */
int bbc__media_refract(const bbc_scene *scene, uint32_t medium, uint32_t t, int side,
                       uint32_t *after);

/* The medium at point x: m + 1 for the first closed dielectric mesh m holding it (by
 * the parity of a ray's crossings), else 0 (air); with scene->media, the medium on the
 * side of the first dielectric a ray from x meets. What a point light's medium is, and
 * the path tracer's camera's. */
uint32_t bbc__media_at(const bbc_scene *scene, bbc_vec3 x);

/* Where light refracted at dielectric triangle t, met from `side`, is enclosed: m + 1
 * when t's mesh m is closed, has no cut-outs (bbc_material_partial: light leaves through
 * them) and the light goes into the volume it encloses (through the front of a solid,
 * through the back of a cavity's wall), else 0. Such light reaches
 * only what may lie inside that volume (the tuple search's receivers, whose boxes must
 * meet the mesh's) before it meets another specular surface. */
uint32_t bbc__media_enclosure(const bbc_scene *scene, uint32_t t, int side);

/* The index of refraction of dielectric triangle t relative to its front: the index of
 * the medium behind it over that of the medium in front (the material's ior for glass
 * in air, 1.5 / 1.33 for glass behind water). */
double bbc__media_ior(const bbc_scene *scene, uint32_t t);

/* eta = n_incident / n_transmitted for light meeting dielectric triangle t from `side`
 * (+1 front, -1 behind): 1 / bbc__media_ior from the front, bbc__media_ior from behind
 * (each computed from the two indices, so 1.33 / 1.5 is that quotient). Every place
 * that refracts at a dielectric asks this: the path tracer, the caustic estimator, the
 * bounds (bbc_tuple_geometry_init) and the solvers (through bbc_specular_triangle.ior =
 * bbc__media_ior). */
double bbc__media_eta(const bbc_scene *scene, uint32_t t, int side);

/* A ray in `medium` meets dielectric triangle t from its front (front = 1) or behind:
 * returns 1 with *eta (bbc__media_eta) and *after, the medium it is in once refracted,
 * or 0 when the medium rule (bbc__media_refract) does not let it refract there, where a
 * tracer goes on unchanged: the part of a mesh that reaches into another (a liquid's
 * wall into its glass), or glass met from behind by light in air, which came in
 * through a cut-out or round an open mesh's edge. The path tracer and the light tracer
 * thus count exactly the paths the caustic estimator can (on TransmissionTest's
 * cut-out glass spheres they had counted a third more single-refraction light, every
 * watt of it through a back face that light in air met through a hole). */
int bbc__media_interface(const bbc_scene *scene, uint32_t medium, uint32_t t, int front,
                         double *eta, uint32_t *after);

/* Whether a ray in `medium` goes unstopped along origin + t d, t in (0, tmax): what a
 * shadow or camera ray asks. A dielectric it meets where the medium rule lets it pass
 * (bbc__media_interface returns 0: a liquid's wall inside its glass, glass met from
 * behind by light in air) is gone through, as the path and light tracers go through it;
 * every other surface stops it. The rule is one-way, so it is applied in the direction
 * the tracer that this ray stands for travels: along d (light from a point light toward
 * its first vertex, between specular vertices, a camera ray as the path tracer's), or,
 * with `against`, opposite to d (a shadow ray from a lit point back to the light). The
 * caustic estimator, next-event estimation and light tracing's camera rays all ask this,
 * so that they agree with the tracers. `passable`: bbc__media_passable(scene), computed
 * once by the caller; 0 takes every surface as stopping the ray. */
/* The most surfaces one ray goes straight through (bbc__media_clear, the path tracer's
 * camera paths): a bound against coincident surfaces. */
#define BBC__MEDIA_MAX_PASSES 64
int bbc__media_clear(const bbc_scene *scene, const bbc_accel *accel, int passable, bbc_vec3 origin,
                     bbc_vec3 d, double tmax, uint32_t medium, int against);

/* Whether a ray can meet a surface it goes through (bbc__media_clear's `passable`): the
 * scene has media of its own or a dielectric mesh that is open or has cut-outs. Where
 * every dielectric mesh is a closed solid, light in air meets each from its front and
 * light inside from behind, so every surface stops a shadow ray, and one any-hit query
 * answers it. */
int bbc__media_passable(const bbc_scene *scene);

/* Snell's law: the refracted unit direction of unit dir at shading normal n (unit, on
 * the incident side), cos_i = -dir . n > 0 and cos_t = sqrt(1 - eta^2 (1 - cos_i^2)). */
static inline bbc_vec3 bbc__media_transmit(bbc_vec3 dir, bbc_vec3 n, double eta, double cos_i,
                                           double cos_t) {
  return v3_normalize(v3_add(v3_scale(dir, eta), v3_scale(n, eta * cos_i - cos_t)));
}

/* Beer-Lambert: the fraction of light per RGB channel left after a length x (>= 0, may
 * be infinite) inside `medium` (0 air, m + 1 inside mesh m, above mesh_count an air
 * cavity), exp(-absorption x) with the mesh material's absorption (bbc_material); 1 in
 * air and where nothing is absorbed.
 * Each factor lies in [0, 1], so the cache's irradiance bounds, which leave it out,
 * stay bounds. */
static inline void bbc__media_transmittance(const bbc_scene *scene, uint32_t medium, double x,
                                            double t[3]) {
  const bbc_material *m = medium && medium <= scene->mesh_count
                              ? &scene->materials[scene->meshes[medium - 1].material]
                              : NULL;
  for (int k = 0; k < 3; k++) {
    const double a = m ? m->absorption[k] : 0.0;
    t[k] = a > 0.0 ? exp(-a * x) : 1.0;
  }
}

/* The tint of light refracted through the surface of dielectric triangle `triangle` at
 * barycentrics b1, b2, entering or leaving: its base colour there (the factor times the
 * base colour texture, bbc_scene_base_color), at most 1 per channel (glTF's
 * KHR_materials_transmission tints the specular BTDF by baseColor; its reflection, the
 * specular BRDF, is untinted). */
static inline void bbc__media_tint(const bbc_scene *scene, uint32_t triangle, double b1,
                                   double b2, double out[3]) {
  bbc_scene_base_color(scene, triangle, b1, b2, out);
  for (int k = 0; k < 3; k++) out[k] = out[k] < 1.0 ? out[k] : 1.0;
}

#endif
