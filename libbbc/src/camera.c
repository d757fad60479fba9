/* The pinhole camera. */
#include "bbc/render.h"

#include <math.h>

#include "vec_internal.h"

void bbc_camera_ray(const bbc_camera *camera, uint32_t width, uint32_t height, double px, double py,
                    bbc_vec3 *origin, bbc_vec3 *dir) {
  double tan_half = tan(0.5 * camera->yfov);
  double aspect = (double)width / height;
  double sx = (2.0 * px / width - 1.0) * tan_half * aspect;
  double sy = (1.0 - 2.0 * py / height) * tan_half;
  bbc_vec3 d = v3_neg(camera->w);
  d = v3_madd(d, camera->u, sx);
  d = v3_madd(d, camera->v, sy);
  *origin = camera->position;
  *dir = v3_normalize(d);
}
