/* The pinhole camera, its placement from a node's matrix, and camera animation. */
#include "bbc/scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera_internal.h"
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

void bbc__trs_matrix(const double t[3], const double q[4], const double s[3], double m[16]) {
  double x = q[0], y = q[1], z = q[2], w = q[3];
  double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                    {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                    {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
  for (int col = 0; col < 3; col++) {
    for (int row = 0; row < 3; row++) m[4 * col + row] = r[row][col] * s[col];
    m[4 * col + 3] = 0.0;
  }
  for (int row = 0; row < 3; row++) m[12 + row] = t[row];
  m[15] = 1.0;
}

static int unit(double v[3]) {
  double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(len > 0.0) || !isfinite(len)) return 0;
  for (int k = 0; k < 3; k++) v[k] /= len;
  return 1;
}

int bbc__camera_frame(const double m[16], bbc_camera *out) {
  double position[3] = {m[12], m[13], m[14]};
  double x[3] = {m[0], m[1], m[2]}, z[3] = {m[8], m[9], m[10]};
  if (!isfinite(position[0]) || !isfinite(position[1]) || !isfinite(position[2]) || !unit(z))
    return 0;
  double d = x[0] * z[0] + x[1] * z[1] + x[2] * z[2];
  for (int k = 0; k < 3; k++) x[k] -= d * z[k];
  if (!unit(x)) return 0;
  double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
  out->position = (bbc_vec3){position[0], position[1], position[2]};
  out->u = (bbc_vec3){x[0], x[1], x[2]};
  out->v = (bbc_vec3){y[0], y[1], y[2]};
  out->w = (bbc_vec3){z[0], z[1], z[2]};
  return 1;
}

/* The channel's value at time t into v (3 or 4 numbers), glTF 2.0 section 3.11. */
static void sample(const bbc__channel *c, double t, double v[4]) {
  int n = c->path == 1 ? 4 : 3;
  uint32_t keys = c->key_count, stride = c->interpolation == 2 ? 3u : 1u;
  /* The value of key k (the middle element of a cubic key). */
#define VALUE(k, i) ((double)c->values[((size_t)(k) * stride + (stride == 3 ? 1 : 0)) * n + (i)])
  if (keys == 1 || !(t > c->times[0])) {
    for (int i = 0; i < n; i++) v[i] = VALUE(0, i);
    return;
  }
  if (t >= c->times[keys - 1]) {
    for (int i = 0; i < n; i++) v[i] = VALUE(keys - 1, i);
    return;
  }
  uint32_t lo = 0, hi = keys - 1; /* times[lo] <= t < times[hi] */
  while (hi - lo > 1) {
    uint32_t mid = lo + (hi - lo) / 2;
    if (c->times[mid] <= t)
      lo = mid;
    else
      hi = mid;
  }
  double dt = (double)c->times[hi] - c->times[lo], u = (t - c->times[lo]) / dt;
  if (c->interpolation == 1) {
    for (int i = 0; i < n; i++) v[i] = VALUE(lo, i);
  } else if (c->interpolation == 2) {
    double u2 = u * u, u3 = u2 * u;
    const float *out_tangent = &c->values[((size_t)lo * 3 + 2) * n];
    const float *in_tangent = &c->values[((size_t)hi * 3) * n];
    for (int i = 0; i < n; i++)
      v[i] = (2 * u3 - 3 * u2 + 1) * VALUE(lo, i) + (u3 - 2 * u2 + u) * dt * out_tangent[i] +
             (-2 * u3 + 3 * u2) * VALUE(hi, i) + (u3 - u2) * dt * in_tangent[i];
  } else if (n == 4) {
    /* Spherical linear interpolation along the shorter arc. */
    double a[4], b[4], dot = 0.0;
    for (int i = 0; i < 4; i++) {
      a[i] = VALUE(lo, i);
      b[i] = VALUE(hi, i);
      dot += a[i] * b[i];
    }
    double sign = dot < 0.0 ? -1.0 : 1.0;
    dot = fabs(dot);
    double wa = 1.0 - u, wb = u;
    if (dot < 1.0 - 1e-9) {
      double angle = acos(dot > 1.0 ? 1.0 : dot), s = sin(angle);
      wa = sin((1.0 - u) * angle) / s;
      wb = sin(u * angle) / s;
    }
    for (int i = 0; i < 4; i++) v[i] = wa * a[i] + wb * sign * b[i];
  } else {
    for (int i = 0; i < n; i++) v[i] = (1.0 - u) * VALUE(lo, i) + u * VALUE(hi, i);
  }
#undef VALUE
}

bbc_result bbc_scene_camera_at(const bbc_scene *scene, uint32_t index, double time,
                               bbc_camera *out) {
  if (!scene || !out || index >= scene->camera_count || !isfinite(time))
    return BBC_ERR_INVALID_ARGUMENT;
  *out = scene->cameras[index];
  if (!out->animated) return BBC_OK;
  const bbc__camera_motion *motion = &scene->camera_motion[index];
  double world[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (uint32_t k = 0; k < motion->path_length; k++) {
    const bbc__node_motion *node = &motion->path[k];
    double local[16], product[16];
    if (node->has_matrix) {
      memcpy(local, node->matrix, sizeof local);
    } else {
      double trs[3][4];
      memcpy(trs[0], node->translation, sizeof node->translation);
      memcpy(trs[1], node->rotation, sizeof node->rotation);
      memcpy(trs[2], node->scale, sizeof node->scale);
      for (int p = 0; p < 3; p++)
        if (node->channels[p].key_count) sample(&node->channels[p], time, trs[p]);
      double len = sqrt(trs[1][0] * trs[1][0] + trs[1][1] * trs[1][1] + trs[1][2] * trs[1][2] +
                        trs[1][3] * trs[1][3]);
      if (!(len > 0.0)) return BBC_ERR_SCENE;
      for (int i = 0; i < 4; i++) trs[1][i] /= len;
      bbc__trs_matrix(trs[0], trs[1], trs[2], local);
    }
    for (int col = 0; col < 4; col++)
      for (int row = 0; row < 4; row++) {
        double s = 0.0;
        for (int i = 0; i < 4; i++) s += world[4 * i + row] * local[4 * col + i];
        product[4 * col + row] = s;
      }
    memcpy(world, product, sizeof world);
  }
  return bbc__camera_frame(world, out) ? BBC_OK : BBC_ERR_SCENE;
}

void bbc__camera_motion_free(bbc__camera_motion *motion, uint32_t count) {
  if (!motion) return;
  for (uint32_t i = 0; i < count; i++) {
    for (uint32_t k = 0; k < motion[i].path_length; k++)
      for (int p = 0; p < 3; p++) {
        free(motion[i].path[k].channels[p].times);
        free(motion[i].path[k].channels[p].values);
      }
    free(motion[i].path);
  }
  free(motion);
}
