/* Receiver planes: the receivers that lie in a plane x, y or z = constant, whose
 * tuples end on the plane rather than on one of its triangles (scene.h, bbc_mesh). */
#include <math.h>

#include "bbc/tuple.h"
#include "media_internal.h"
#include "vec_internal.h"

/* The axis every vertex of the mesh shares its coordinate on (the lowest such one), or
 * -1. Exact on the float data: a plane found here holds every vertex exactly. */
static int shared_axis(const bbc_scene *scene, const bbc_mesh *m) {
  if (m->vertex_count == 0 || m->triangle_count == 0) return -1;
  const float *first = scene->positions + 3 * (size_t)m->first_vertex;
  for (int axis = 0; axis < 3; axis++) {
    uint32_t i = 1;
    while (i < m->vertex_count && first[3 * (size_t)i + axis] == first[axis]) i++;
    if (i == m->vertex_count) return axis;
  }
  return -1;
}

void bbc__scene_planes(bbc_scene *scene) {
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    bbc_mesh *m = &scene->meshes[i];
    m->plane = 0;
    for (int k = 0; k < 3; k++) m->plane_triangle[k] = v3(0, 0, 0);
    if (m->role != BBC_ROLE_RECEIVER) continue;
    const int axis = shared_axis(scene, m);
    if (axis < 0) continue;
    const int a = axis == 0 ? 1 : 0, b = axis == 2 ? 1 : 2;
    const float *p = scene->positions + 3 * (size_t)m->first_vertex;
    double lo[2] = {p[a], p[b]}, hi[2] = {p[a], p[b]};
    for (uint32_t v = 1; v < m->vertex_count; v++) {
      const float *q = p + 3 * (size_t)v;
      lo[0] = fmin(lo[0], q[a]), hi[0] = fmax(hi[0], q[a]);
      lo[1] = fmin(lo[1], q[b]), hi[1] = fmax(hi[1], q[b]);
    }
    /* A mesh that is a segment or a point in its plane holds no area to light. */
    if (!(hi[0] > lo[0] && hi[1] > lo[1])) continue;
    const double L = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    double c[3][3];
    for (int k = 0; k < 3; k++) {
      c[k][axis] = p[axis];
      c[k][a] = lo[0] + (k == 1 ? 2 * L : 0);
      c[k][b] = lo[1] + (k == 2 ? 2 * L : 0);
      m->plane_triangle[k] = v3(c[k][0], c[k][1], c[k][2]);
    }
    m->plane = 1 + axis;
  }
}

int bbc_receiver_triangle(const bbc_scene *scene, uint32_t receiver, bbc_vec3 out[3]) {
  if (bbc_receiver_is_plane(receiver)) {
    const uint32_t m = bbc_receiver_plane_mesh(receiver);
    if (m >= scene->mesh_count || scene->meshes[m].plane == 0) return 0;
    for (int k = 0; k < 3; k++) out[k] = scene->meshes[m].plane_triangle[k];
    return 1;
  }
  if (receiver >= scene->triangle_count) return 0;
  for (int k = 0; k < 3; k++)
    out[k] = v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)receiver + k]);
  return 1;
}
