/* What later stages may change in a loaded scene. */
#ifndef BBC_SCENE_INTERNAL_H
#define BBC_SCENE_INTERNAL_H

#include "bbc/scene.h"

/* Replaces the scene's vertex and index arrays (malloc'ed; the scene takes them and frees
 * the old ones) by others of the same counts and mesh ranges, and recomputes what
 * depends on them: the emitters and their distribution, and the media (closed meshes,
 * lights inside them). NULL normals or uvs mean none, as after loading. For a scene
 * made the cache's (bbc_cache_match_scene). */
bbc_result bbc__scene_adopt_geometry(bbc_scene *scene, float *positions, float *normals,
                                     float *uvs, uint32_t *indices);

#endif
