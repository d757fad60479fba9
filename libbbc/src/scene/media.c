/* Media of dielectric meshes and the medium rule (media_internal.h). */
#include <stdlib.h>
#include <string.h>

#include "media_internal.h"
#include "vec_internal.h"

typedef struct edge {
  float a[3], b[3]; /* endpoints, ordered */
} edge;

static int compare_edge(const void *x, const void *y) {
  return memcmp(x, y, sizeof(edge));
}

/* 1 when every edge of the mesh (by vertex positions) is shared by exactly two of its
 * triangles; -1 when out of memory. */
static int mesh_closed(const bbc_scene *scene, const bbc_mesh *m) {
  size_t n = 3 * (size_t)m->triangle_count;
  if (m->triangle_count < 4) return 0;
  edge *e = malloc(n * sizeof *e);
  if (!e) return -1;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    for (int k = 0; k < 3; k++) {
      const float *p = scene->positions + 3 * (size_t)idx[k];
      const float *q = scene->positions + 3 * (size_t)idx[(k + 1) % 3];
      edge *x = &e[3 * (size_t)t + k];
      memset(x, 0, sizeof *x);
      int swap = memcmp(p, q, 3 * sizeof(float)) > 0;
      memcpy(x->a, swap ? q : p, 3 * sizeof(float));
      memcpy(x->b, swap ? p : q, 3 * sizeof(float));
    }
  }
  qsort(e, n, sizeof *e, compare_edge);
  int closed = 1;
  for (size_t i = 0; i < n && closed;) {
    size_t j = i;
    while (j < n && compare_edge(&e[i], &e[j]) == 0) j++;
    if (j - i != 2) closed = 0;
    i = j;
  }
  free(e);
  return closed;
}

/* +1 when the winding's normals point out of the closed mesh, -1 when in. */
static int winding_outward(const bbc_scene *scene, const bbc_mesh *m) {
  double volume = 0;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    bbc_vec3 p[3];
    for (int k = 0; k < 3; k++) p[k] = v3_load(scene->positions + 3 * (size_t)idx[k]);
    volume += v3_dot(p[0], v3_cross(p[1], p[2]));
  }
  return volume >= 0 ? 1 : -1;
}

/* Whether x lies inside the closed mesh: the parity of the crossings of a ray. */
static int point_inside(const bbc_scene *scene, const bbc_mesh *m, bbc_vec3 x) {
  const bbc_vec3 d = v3_normalize(v3(0.5773, 0.5779, 0.5768));
  int crossings = 0;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)idx[0]);
    bbc_vec3 e1 = v3_sub(v3_load(scene->positions + 3 * (size_t)idx[1]), p0);
    bbc_vec3 e2 = v3_sub(v3_load(scene->positions + 3 * (size_t)idx[2]), p0);
    bbc_vec3 pv = v3_cross(d, e2);
    double det = v3_dot(e1, pv);
    if (det == 0) continue;
    bbc_vec3 w = v3_sub(x, p0);
    double u = v3_dot(w, pv) / det;
    bbc_vec3 qv = v3_cross(w, e1);
    double v = v3_dot(d, qv) / det, h = v3_dot(e2, qv) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && h > 0) crossings++;
  }
  return crossings & 1;
}

bbc_result bbc__scene_media(bbc_scene *scene) {
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    bbc_mesh *m = &scene->meshes[i];
    m->closed = 0;
    m->outward = 1;
    if (scene->materials[m->material].type != BBC_MATERIAL_DIELECTRIC) continue;
    int closed = mesh_closed(scene, m);
    if (closed < 0) return BBC_ERR_OUT_OF_MEMORY;
    m->closed = closed;
    if (closed) m->outward = winding_outward(scene, m);
  }
  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    bbc_point_light *light = &scene->point_lights[l];
    light->medium = 0;
    if (light->model.kind == BBC_LIGHT_DIRECTIONAL) continue; /* a sun shines from outside */
    light->medium = bbc__media_at(scene, light->position);
  }
  return BBC_OK;
}

uint32_t bbc__media_at(const bbc_scene *scene, bbc_vec3 x) {
  for (uint32_t i = 0; i < scene->mesh_count; i++)
    if (scene->meshes[i].closed && point_inside(scene, &scene->meshes[i], x)) return i + 1;
  return 0;
}

int bbc__media_side(const bbc_scene *scene, uint32_t t, bbc_vec3 q) {
  const bbc_mesh *m = &scene->meshes[scene->triangle_mesh[t]];
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)idx[0]);
  bbc_vec3 ng = v3_cross(v3_sub(v3_load(scene->positions + 3 * (size_t)idx[1]), p0),
                         v3_sub(v3_load(scene->positions + 3 * (size_t)idx[2]), p0));
  double front = m->outward;
  if (!m->closed) {
    bbc_vec3 nsum = v3(0, 0, 0);
    for (int k = 0; k < 3; k++) nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[k]));
    front = v3_dot(ng, nsum) >= 0 ? 1 : -1;
  }
  double s = front * v3_dot(ng, v3_sub(q, p0));
  return (s > 0) - (s < 0);
}

int bbc__media_refract(const bbc_scene *scene, uint32_t medium, uint32_t t, int side,
                       uint32_t *after) {
  const uint32_t mesh = scene->triangle_mesh[t];
  if (medium == 0 && side > 0) {
    *after = mesh + 1;
    return 1;
  }
  if (medium == mesh + 1 && side < 0) {
    *after = 0;
    return 1;
  }
  return 0;
}
