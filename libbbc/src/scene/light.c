/* Light kinds: the glTF spot falloff, exactly and in interval arithmetic, and the
 * direction light arrives from for each kind, and an emitter's radiance at a point
 * (light_internal.h). */
#include <float.h>
#include <math.h>
#include <string.h>

#include "bbc/texture.h"
#include "light_internal.h"
#include "vec_internal.h"

#define SUN_PI 3.14159265358979323846

double bbc_light_falloff(const bbc_light_model *m, bbc_vec3 w) {
  if (m->kind != BBC_LIGHT_SPOT) return 1.0;
  double t = (v3_dot(w, m->direction) - m->cos_outer) * m->cone_scale;
  if (!(t > 0)) return 0.0; /* also NaN */
  if (t >= 1) return 1.0;
  return t * t;
}

double bbc_light_sun_radiance_scale(double delta) {
  if (!(delta > 0)) return 0.0;
  double s = sin(0.5 * delta);
  return 1.0 / (SUN_PI * s * s);
}

int bbc__sun_is_disk(const bbc_light_model *m) {
  return m->kind == BBC_LIGHT_DIRECTIONAL && m->angular_diameter > 0;
}

/* 1 - cos(h) for the half-angle h = delta / 2, as 2 sin^2(h / 2): exact to rounding for
 * the tiny angles of real suns, where 1 - cos(h) would cancel (0.53 degrees: 1.07e-5). */
static double one_minus_cos_half(const bbc_light_model *m) {
  double s = sin(0.25 * m->angular_diameter);
  return 2.0 * s * s;
}

double bbc__sun_solid_angle(const bbc_light_model *m) {
  return 2.0 * SUN_PI * one_minus_cos_half(m);
}

bbc_vec3 bbc__sun_sample(const bbc_light_model *m, const double u[2]) {
  const bbc_vec3 axis = v3_neg(m->direction);
  /* Uniform in the cone: cos(theta) uniform on [cos h, 1]; 1 - cos(theta) = u0 (1 - cos h)
   * keeps the small angles exact. */
  double one_minus = u[0] * one_minus_cos_half(m);
  double cos_t = 1.0 - one_minus;
  double sin_t = sqrt(fmax(0.0, one_minus * (2.0 - one_minus)));
  double phi = 2.0 * SUN_PI * u[1];
  bbc_vec3 t, b;
  v3_basis(axis, &t, &b);
  return v3_normalize(v3_add(v3_scale(axis, cos_t),
                             v3_add(v3_scale(t, sin_t * cos(phi)), v3_scale(b, sin_t * sin(phi)))));
}

int bbc__sun_contains(const bbc_light_model *m, bbc_vec3 w) {
  /* 1 - cos(theta) = |w - axis|^2 / 2 for unit w and axis: no cancellation. */
  bbc_vec3 d = v3_add(w, m->direction);
  return 0.5 * v3_dot(d, d) <= one_minus_cos_half(m);
}

bbc_vec3 bbc__light_source(bbc_vec3 position, const bbc_light_model *m, bbc_vec3 near) {
  return m->kind == BBC_LIGHT_DIRECTIONAL ? v3_sub(near, m->direction) : position;
}

bbc_vec3 bbc__light_d0(bbc_vec3 position, const bbc_light_model *m, bbc_vec3 x) {
  return m->kind == BBC_LIGHT_DIRECTIONAL ? m->direction : v3_sub(x, position);
}

/* The falloff's enclosure for cosines in cd: t^2 with t = clamp((cd - cos_outer) scale,
 * 0, 1) is non-decreasing in cd, so its ends give the range. cd is widened first by the
 * rounding the exact function makes when it computes the cosine (normalising w and a
 * dot product: a few ulps of 1). */
static bbc_interval falloff_of_cosine(const bbc_light_model *m, bbc_interval cd) {
  const double slack = 8 * DBL_EPSILON;
  cd = bbc_interval_make(fmax(cd.lo - slack, -1.0), fmin(cd.hi + slack, 1.0));
  bbc_interval t = bbc_interval_scale(bbc_interval_sub(cd, bbc_interval_point(m->cos_outer)),
                                      m->cone_scale);
  double lo = fmin(fmax(t.lo, 0.0), 1.0), hi = fmin(fmax(t.hi, 0.0), 1.0);
  if (!(t.hi == t.hi)) return bbc_interval_make(0, 1); /* NaN: nothing known */
  bbc_interval f = bbc_interval_sqr(bbc_interval_make(lo, hi));
  return bbc_interval_make(fmax(f.lo, 0.0), fmin(f.hi, 1.0));
}

bbc_interval bbc__light_falloff_over_box(bbc_vec3 position, const bbc_light_model *m,
                                         const bbc_vec3 p[3], const double box[4]) {
  if (m->kind != BBC_LIGHT_SPOT) return bbc_interval_point(1.0);
  bbc_ivec3 p0 = bbc_ivec3_point(p[0]);
  bbc_ivec3 e1 = bbc_ivec3_sub(bbc_ivec3_point(p[1]), p0);
  bbc_ivec3 e2 = bbc_ivec3_sub(bbc_ivec3_point(p[2]), p0);
  bbc_ivec3 x = bbc_ivec3_add(p0, bbc_ivec3_add(bbc_ivec3_scale(bbc_interval_make(box[0], box[1]), e1),
                                                bbc_ivec3_scale(bbc_interval_make(box[2], box[3]), e2)));
  bbc_ivec3 d = bbc_ivec3_sub(x, bbc_ivec3_point(position));
  bbc_interval num = bbc_ivec3_dot(d, bbc_ivec3_point(m->direction));
  bbc_interval dist2 = bbc_interval_add(bbc_interval_sqr(d.x),
                                        bbc_interval_add(bbc_interval_sqr(d.y), bbc_interval_sqr(d.z)));
  bbc_interval cd = bbc_interval_make(-1, 1);
  if (dist2.lo > 0) {
    bbc_interval c = bbc_interval_div(num, bbc_interval_sqrt(dist2));
    if (c.lo == c.lo && c.hi == c.hi) cd = bbc_interval_make(fmax(c.lo, -1.0), fmin(c.hi, 1.0));
  } else if (num.hi <= 0) {
    /* The light may sit on the box, but every direction into it points away from the axis
     * (or along its normal plane): the cosine is at most 0. */
    cd = bbc_interval_make(-1, 0);
  }
  if (cd.lo > cd.hi) cd = bbc_interval_make(-1, 1);
  return falloff_of_cosine(m, cd);
}

int bbc_scene_area_light(const bbc_scene *scene, uint32_t e, bbc_light_model *m,
                         float radiance[3]) {
  if (!scene || e >= scene->emitter_count) return 0;
  const uint32_t t = scene->emitters[e];
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  memset(m, 0, sizeof *m);
  m->kind = BBC_LIGHT_AREA;
  bbc_vec3 nsum = v3(0, 0, 0);
  for (int k = 0; k < 3; k++) {
    m->emitter[k] = v3_load(scene->positions + 3 * (size_t)idx[k]);
    nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[k]));
  }
  bbc_vec3 c = v3_cross(v3_sub(m->emitter[1], m->emitter[0]), v3_sub(m->emitter[2], m->emitter[0]));
  /* The front is where the vertex normals point, as the path tracer's (surface_at). */
  m->emitter_normal = v3_dot(c, nsum) < 0 ? v3_neg(c) : c;
  const float *le = bbc_scene_triangle_material(scene, t)->emission;
  if (radiance)
    for (int k = 0; k < 3; k++) radiance[k] = le[k];
  return 1;
}

bbc_vec3 bbc__area_point(const bbc_light_model *m, double a, double b) {
  const bbc_vec3 *q = m->emitter;
  return v3_add(q[0], v3_add(v3_scale(v3_sub(q[1], q[0]), a), v3_scale(v3_sub(q[2], q[1]), a * b)));
}

bbc_vec3 bbc__area_centroid(const bbc_light_model *m) {
  return v3_scale(v3_add(m->emitter[0], v3_add(m->emitter[1], m->emitter[2])), 1.0 / 3.0);
}

bbc_point_light bbc__cache_light_point(const bbc_scene *scene, uint32_t light) {
  if (light < scene->point_light_count) return scene->point_lights[light];
  bbc_point_light p;
  memset(&p, 0, sizeof p);
  bbc_scene_area_light(scene, light - scene->point_light_count, &p.model, NULL);
  p.position = bbc__area_centroid(&p.model);
  return p;
}

double bbc__area_weight(const bbc_light_model *m, bbc_vec3 y, bbc_vec3 x1) {
  bbc_vec3 d = v3_sub(x1, y);
  double len = v3_length(d);
  double c = v3_dot(m->emitter_normal, d);
  if (!(c > 0) || !(len > 0)) return 0.0;
  /* A_e cos(theta_e): |n| / 2 is the area, c / (|n| |d|) the cosine. */
  return 0.5 * c / len;
}

void bbc__area_radiance(const bbc_scene *scene, uint32_t light, bbc_vec3 y, float out[3]) {
  const uint32_t t = scene->emitters[light - scene->point_light_count];
  const uint32_t *a = scene->indices + 3 * (size_t)t;
  bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)a[0]);
  bbc_vec3 e1 = v3_sub(v3_load(scene->positions + 3 * (size_t)a[1]), p0);
  bbc_vec3 e2 = v3_sub(v3_load(scene->positions + 3 * (size_t)a[2]), p0);
  bbc_vec3 d = v3_sub(y, p0);
  /* The barycentrics of y's projection on the triangle's plane (y lies on it up to
   * rounding), clamped into the triangle. */
  double d11 = v3_dot(e1, e1), d12 = v3_dot(e1, e2), d22 = v3_dot(e2, e2);
  double r1 = v3_dot(d, e1), r2 = v3_dot(d, e2), det = d11 * d22 - d12 * d12;
  double b1 = det > 0 ? (d22 * r1 - d12 * r2) / det : 0.0;
  double b2 = det > 0 ? (d11 * r2 - d12 * r1) / det : 0.0;
  b1 = b1 > 0 ? b1 : 0.0, b2 = b2 > 0 ? b2 : 0.0;
  if (b1 + b2 > 1) b1 /= b1 + b2, b2 = 1 - b1;
  double le[3];
  bbc_scene_emission(scene, t, b1, b2, le);
  for (int k = 0; k < 3; k++) out[k] = (float)le[k];
}

const float *bbc__cache_light_intensity(const bbc_scene *scene, uint32_t light, float buffer[3]) {
  if (light < scene->point_light_count) return scene->point_lights[light].intensity;
  bbc_light_model m;
  buffer[0] = buffer[1] = buffer[2] = 0;
  bbc_scene_area_light(scene, light - scene->point_light_count, &m, buffer);
  return buffer;
}
