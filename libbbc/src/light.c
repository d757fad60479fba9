/* Light kinds: the glTF spot falloff, exactly and in interval arithmetic, and the
 * direction light arrives from for each kind (light_internal.h). */
#include <float.h>
#include <math.h>

#include "light_internal.h"
#include "vec_internal.h"

double bbc_light_falloff(const bbc_light_model *m, bbc_vec3 w) {
  if (m->kind != BBC_LIGHT_SPOT) return 1.0;
  double t = (v3_dot(w, m->direction) - m->cos_outer) * m->cone_scale;
  if (!(t > 0)) return 0.0; /* also NaN */
  if (t >= 1) return 1.0;
  return t * t;
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
