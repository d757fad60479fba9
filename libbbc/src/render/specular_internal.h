/* What a ray does where it meets a surface: the point's frame, and the scattering at a
 * perfect mirror or a smooth dielectric (Fresnel's choice between reflection and
 * refraction, the tint of transmitted light, the medium the ray travels in next). One
 * definition for both directions of transport: the path tracer follows camera paths
 * with it (integrator.c), the light tracer photons (light_trace.c). */
#ifndef BBC_SPECULAR_INTERNAL_H
#define BBC_SPECULAR_INTERNAL_H

#include <math.h>

#include "bbc/accel.h"
#include "bbc/scene.h"
#include "media_internal.h"
#include "vec_internal.h"

/* A surface point where a ray hit: normals oriented so that ns and ng agree. */
typedef struct bbc__surface {
  bbc_vec3 p;
  double b1, b2; /* barycentrics of vertices 1 and 2 */
  bbc_vec3 ng;   /* unit geometric normal */
  bbc_vec3 ns;   /* unit shading normal (interpolated vertex normal) */
  uint32_t triangle;
  const bbc_material *material;
} bbc__surface;

static inline bbc__surface bbc__surface_at(const bbc_scene *scene, const bbc_hit *hit) {
  const uint32_t *idx = scene->indices + 3 * (size_t)hit->triangle;
  bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)idx[0]);
  bbc_vec3 p1 = v3_load(scene->positions + 3 * (size_t)idx[1]);
  bbc_vec3 p2 = v3_load(scene->positions + 3 * (size_t)idx[2]);
  bbc_vec3 n0 = v3_load(scene->normals + 3 * (size_t)idx[0]);
  bbc_vec3 n1 = v3_load(scene->normals + 3 * (size_t)idx[1]);
  bbc_vec3 n2 = v3_load(scene->normals + 3 * (size_t)idx[2]);
  double w = 1.0 - hit->u - hit->v;
  bbc__surface s;
  s.p = v3_add(v3_add(v3_scale(p0, w), v3_scale(p1, hit->u)), v3_scale(p2, hit->v));
  s.ng = v3_normalize(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
  s.ns = v3_normalize(v3_add(v3_add(v3_scale(n0, w), v3_scale(n1, hit->u)), v3_scale(n2, hit->v)));
  /* The vertex normals say which side is the front; the winding may disagree. */
  if (v3_dot(s.ng, s.ns) < 0) s.ng = v3_neg(s.ng);
  s.b1 = hit->u;
  s.b2 = hit->v;
  s.triangle = hit->triangle;
  s.material = bbc_scene_triangle_material(scene, hit->triangle);
  return s;
}

static inline bbc_vec3 bbc__reflect(bbc_vec3 d, bbc_vec3 n) {
  return v3_madd(d, n, -2.0 * v3_dot(d, n));
}

/* Fresnel reflectance of a smooth dielectric boundary for unpolarised light, given the
 * cosines on both sides and eta = n_incident / n_transmitted. */
static inline double bbc__fresnel_dielectric(double cos_i, double cos_t, double eta) {
  double rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  double rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

/* A specular scattering event: the new direction, the factor on what is carried (a
 * mirror's reflectance; the tint of a refraction; 1 for a Fresnel reflection), the kind
 * (letter 0 a mirror reflection, 1 a refraction, -1 a reflection off a dielectric), the
 * medium beyond, and for a refraction eta = n_incident / n_transmitted (radiance carried
 * along a camera path is scaled by eta^2 across it; flux along a photon's path is not). */
typedef struct bbc__scatter {
  bbc_vec3 dir;
  double weight[3];
  int letter;
  uint32_t medium;
  double eta;
} bbc__scatter;

/* What bbc__scatter_specular did: the path ends, it scattered, or it passes the surface
 * unchanged (a dielectric surface that does not bound the ray's medium, as the part of a
 * liquid's wall inside its glass: no vertex, the ray goes on). */
enum { BBC__SCATTER_ENDS = 0, BBC__SCATTER_SCATTERS = 1, BBC__SCATTER_PASSES = 2 };

/* Scatters the ray arriving along unit dir, travelling in `medium`, at mirror or
 * dielectric point s; u is the uniform number that chooses reflection with the Fresnel
 * probability (unused at a mirror and at total internal reflection; no_fresnel: refract
 * unless totally reflected). Returns BBC__SCATTER_ENDS where the path ends (the shading
 * normal sends it to the wrong side of the geometric surface). Refraction switches the
 * medium as bbc__media_interface says (the rule of the media, media_internal.h). */
static inline int bbc__scatter_specular(const bbc_scene *scene, const bbc__surface *s, bbc_vec3 dir,
                                        uint32_t medium, double u, int no_fresnel,
                                        bbc__scatter *out) {
  const bbc_material *m = s->material;
  const int front = v3_dot(dir, s->ng) < 0;
  bbc_vec3 n = front ? s->ns : v3_neg(s->ns);
  bbc_vec3 ng = front ? s->ng : v3_neg(s->ng);
  out->medium = medium;
  out->eta = 1.0;
  out->letter = -1;
  if (m->type == BBC_MATERIAL_MIRROR) {
    out->letter = 0;
    out->dir = bbc__reflect(dir, n);
    if (v3_dot(out->dir, ng) <= 0) return 0; /* shading normal sent it into the surface */
    bbc_scene_base_color(scene, s->triangle, s->b1, s->b2, out->weight);
    return 1;
  }
  double eta;
  uint32_t after;
  if (!bbc__media_interface(scene, medium, s->triangle, front, &eta, &after)) {
    out->dir = dir;
    out->weight[0] = out->weight[1] = out->weight[2] = 1.0;
    return BBC__SCATTER_PASSES;
  }
  double cos_i = -v3_dot(dir, n);
  if (cos_i <= 0) return 0;
  double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
  int reflect_it;
  double cos_t = 0;
  if (sin2_t >= 1.0) {
    reflect_it = 1; /* total internal reflection */
  } else {
    cos_t = sqrt(1.0 - sin2_t);
    double f = no_fresnel ? 0.0 : bbc__fresnel_dielectric(cos_i, cos_t, eta);
    reflect_it = u < f;
  }
  out->letter = reflect_it ? -1 : 1;
  if (reflect_it) {
    out->dir = bbc__reflect(dir, n);
    out->weight[0] = out->weight[1] = out->weight[2] = 1.0;
    return v3_dot(out->dir, ng) > 0;
  }
  out->dir = v3_normalize(v3_add(v3_scale(dir, eta), v3_scale(n, eta * cos_i - cos_t)));
  if (v3_dot(out->dir, ng) >= 0) return 0;
  /* The transmitted light is tinted by the base colour (reflected light is not). */
  out->eta = eta;
  bbc__media_tint(scene, s->triangle, s->b1, s->b2, out->weight);
  out->medium = after;
  return BBC__SCATTER_SCATTERS;
}

#endif
