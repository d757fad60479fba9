/* Analytic caustic images on a floor at y = 0: a pixel of a render whose samples are
 * exact at their film positions must lie between the least and the greatest analytic
 * value over its footprint. Header-only with static functions, like the other test
 * fixtures; it includes vec_internal.h (libbbc/src on the include path). */
#ifndef BBC_TEST_FLOOR_FOOTPRINT_H
#define BBC_TEST_FLOOR_FOOTPRINT_H

#include <math.h>

#include "bbc/bbc.h"
#include "vec_internal.h"

/* The analytic value at floor point p; negative means "not usable here". */
typedef double (*floor_value_fn)(const void *user, bbc_vec3 p);

/* The least (*lo) and greatest (*hi) value over pixel (x, y) of a w x h render, from 7 x 7
 * film positions across it, each traced to the floor. Returns 0 when the footprint is
 * not usable: a point is off the floor box [box[0], box[1]] x [box[2], box[3]] (x, z),
 * hidden from the camera, or value() is negative there. */
static int floor_footprint_range(const bbc_scene *scene, const bbc_accel *accel, uint32_t w,
                                 uint32_t h, uint32_t x, uint32_t y, const double box[4],
                                 floor_value_fn value, const void *user, double *lo, double *hi) {
  *lo = 1e30;
  *hi = -1e30;
  for (int j = 0; j <= 6; j++) {
    for (int i = 0; i <= 6; i++) {
      bbc_vec3 o, d;
      bbc_camera_ray(&scene->camera, w, h, x + i / 6.0, y + j / 6.0, &o, &d);
      double t = -o.y / d.y;
      bbc_vec3 p = v3_madd(o, d, t);
      if (!(d.y < 0 && p.x > box[0] && p.x < box[1] && p.z > box[2] && p.z < box[3]) ||
          bbc_accel_occluded(accel, o, d, 0, t * (1 - 1e-6)))
        return 0;
      double v = value(user, p);
      if (v < 0) return 0;
      *lo = fmin(*lo, v);
      *hi = fmax(*hi, v);
    }
  }
  return 1;
}

#endif
