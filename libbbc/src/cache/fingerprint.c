/* The scene fingerprint (format-spec Sec. 8): what a cache was computed from, so that a
 * cache of another scene or other parameters is refused. */
#include <string.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"

static void hash_u32(bbc__xxh64_state *s, uint32_t v) {
  uint8_t b[4];
  bbc__st32(b, v);
  bbc__xxh64_update(s, b, 4);
}

static void hash_f32(bbc__xxh64_state *s, float v) {
  uint8_t b[4];
  memcpy(b, &v, 4);
  bbc__xxh64_update(s, b, 4);
}

/* An array of 4-byte values, or the same number of zero bytes when it is absent. */
static void hash_array(bbc__xxh64_state *s, const void *data, size_t size) {
  if (data) {
    bbc__xxh64_update(s, data, size);
    return;
  }
  static const uint8_t zeros[256];
  while (size) {
    size_t n = size < sizeof zeros ? size : sizeof zeros;
    bbc__xxh64_update(s, zeros, n);
    size -= n;
  }
}

bbc_result bbc_fingerprint_compute(const bbc_scene *scene, const bbc_precompute_params *params,
                                   bbc_fingerprint *out) {
  if (!scene || !params || !out) return BBC_ERR_INVALID_ARGUMENT;
  bbc__xxh64_state s;
  size_t v = scene->vertex_count, t = scene->triangle_count;

  bbc__xxh64_init(&s);
  hash_u32(&s, scene->vertex_count);
  hash_u32(&s, scene->triangle_count);
  hash_array(&s, scene->positions, 12 * v);
  hash_array(&s, scene->normals, 12 * v);
  hash_array(&s, scene->uvs, 8 * v);
  hash_array(&s, scene->indices, 12 * t);
  hash_array(&s, scene->triangle_mesh, 4 * t);
  out->geometry = bbc__xxh64_final(&s);

  bbc__xxh64_init(&s);
  hash_u32(&s, scene->material_count);
  for (uint32_t i = 0; i < scene->material_count; i++) {
    const bbc_material *m = &scene->materials[i];
    hash_u32(&s, (uint32_t)m->type);
    for (int k = 0; k < 3; k++) hash_f32(&s, m->base_color[k]);
    hash_f32(&s, m->ior);
    for (int k = 0; k < 3; k++) hash_f32(&s, m->emission[k]);
  }
  out->materials = bbc__xxh64_final(&s);

  bbc__xxh64_init(&s);
  hash_u32(&s, scene->mesh_count);
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    const bbc_mesh *m = &scene->meshes[i];
    uint32_t f[8] = {m->first_vertex,          m->vertex_count,     m->first_triangle,
                     m->triangle_count,        m->material,         (uint32_t)m->role,
                     (uint32_t)m->has_normals, (uint32_t)m->has_uvs};
    for (int k = 0; k < 8; k++) hash_u32(&s, f[k]);
  }
  out->meshes = bbc__xxh64_final(&s);

  bbc__xxh64_init(&s);
  hash_u32(&s, scene->point_light_count);
  for (uint32_t i = 0; i < scene->point_light_count; i++) {
    const bbc_point_light *l = &scene->point_lights[i];
    uint8_t b[24];
    bbc__stf64(b, l->position.x);
    bbc__stf64(b + 8, l->position.y);
    bbc__stf64(b + 16, l->position.z);
    bbc__xxh64_update(&s, b, 24);
    for (int k = 0; k < 3; k++) hash_f32(&s, l->intensity[k]);
    /* Spots and suns add their kind, direction and cone; point lights add nothing, so
     * caches of point-light scenes written before these kinds existed still match. */
    if (l->model.kind != BBC_LIGHT_POINT) {
      hash_u32(&s, (uint32_t)l->model.kind);
      const double m[5] = {l->model.direction.x, l->model.direction.y, l->model.direction.z,
                           l->model.cos_outer, l->model.cone_scale};
      for (int k = 0; k < 5; k++) {
        bbc__stf64(b, m[k]);
        bbc__xxh64_update(&s, b, 8);
      }
    }
  }
  out->lights = bbc__xxh64_final(&s);

  uint8_t parm[BBC__PARM_SIZE];
  bbc__params_encode(params, parm);
  out->params = bbc__xxh64(parm, sizeof parm);

  uint8_t all[40];
  bbc__st64(all, out->geometry);
  bbc__st64(all + 8, out->materials);
  bbc__st64(all + 16, out->meshes);
  bbc__st64(all + 24, out->lights);
  bbc__st64(all + 32, out->params);
  out->total = bbc__xxh64(all, sizeof all);
  return BBC_OK;
}
