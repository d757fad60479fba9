/* What later stages may change in a loaded scene, and what they read of it. */
#ifndef BBC_SCENE_INTERNAL_H
#define BBC_SCENE_INTERNAL_H

#include <math.h>

#include "bbc/scene.h"

/* The bounding box of scene triangle t (exact: the float vertices as doubles). */
static inline void bbc__triangle_box(const bbc_scene *scene, uint32_t t, double lo[3],
                                     double hi[3]) {
  for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
  for (int j = 0; j < 3; j++) {
    const float *p = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + j];
    for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], p[a]), hi[a] = fmax(hi[a], p[a]);
  }
}

/* Replaces the scene's vertex and index arrays (malloc'ed; the scene takes them and frees
 * the old ones) by others of the same counts and mesh ranges, and recomputes what
 * depends on them: the emitters and their distribution, and the media (closed meshes,
 * lights inside them). NULL normals or uvs mean none, as after loading. For a scene
 * made the cache's (bbc_cache_match_scene). */
bbc_result bbc__scene_adopt_geometry(bbc_scene *scene, float *positions, float *normals,
                                     float *uvs, uint32_t *indices);

#endif
