/* Small inline 3-vector arithmetic on bbc_vec3 (double). */
#ifndef BBC_VEC_INTERNAL_H
#define BBC_VEC_INTERNAL_H

#include <math.h>

#include "bbc/common.h"

static inline bbc_vec3 v3(double x, double y, double z) {
  return (bbc_vec3){x, y, z};
}
static inline bbc_vec3 v3_add(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline bbc_vec3 v3_sub(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline bbc_vec3 v3_scale(bbc_vec3 a, double s) {
  return v3(a.x * s, a.y * s, a.z * s);
}
static inline bbc_vec3 v3_neg(bbc_vec3 a) {
  return v3(-a.x, -a.y, -a.z);
}
static inline double v3_dot(bbc_vec3 a, bbc_vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline bbc_vec3 v3_cross(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_length(bbc_vec3 a) {
  return sqrt(v3_dot(a, a));
}
static inline bbc_vec3 v3_normalize(bbc_vec3 a) {
  double l = v3_length(a);
  return l > 0 ? v3_scale(a, 1.0 / l) : a;
}
static inline double v3_max_abs(bbc_vec3 a) {
  return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z)));
}
/* a + s * b */
static inline bbc_vec3 v3_madd(bbc_vec3 a, bbc_vec3 b, double s) {
  return v3(a.x + s * b.x, a.y + s * b.y, a.z + s * b.z);
}
static inline bbc_vec3 v3_load(const float *p) {
  return v3(p[0], p[1], p[2]);
}

/* The origin of a ray leaving surface point p in direction dir, pushed off the surface
 * along its geometric normal ng to the side dir goes to, so the ray does not hit the
 * surface it starts on. */
static inline bbc_vec3 v3_offset_origin(bbc_vec3 p, bbc_vec3 ng, bbc_vec3 dir) {
  double eps = 2e-5 * (1.0 + v3_max_abs(p));
  return v3_madd(p, ng, v3_dot(dir, ng) > 0 ? eps : -eps);
}

/* An orthonormal basis (t, b) around the unit vector n (Duff et al. 2017). */
static inline void v3_basis(bbc_vec3 n, bbc_vec3 *t, bbc_vec3 *b) {
  double sign = copysign(1.0, n.z);
  double a = -1.0 / (sign + n.z);
  double c = n.x * n.y * a;
  *t = v3(1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x);
  *b = v3(c, sign + n.y * n.y * a, -n.y);
}

#endif
