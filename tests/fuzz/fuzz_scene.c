/* fuzz_scene: the scene loader (glTF 2.0, .gltf or .glb) over arbitrary bytes
 * (libFuzzer target).
 *
 * Loads the input with bbc__scene_load_memory and frees the scene. base_dir is NULL,
 * so buffers whose uri is not a data URI are refused and the fuzzer never reads the
 * file system. The library must never crash, leak or trip a sanitizer, whatever the
 * bytes; a scene it accepts must be internally consistent (the checks below abort
 * otherwise, so the fuzzer reports a broken contract like a crash).
 *
 * Built as a libFuzzer binary (BBC_BUILD_FUZZERS=ON with clang) and, with replay.c,
 * as an ordinary test that replays tests/corpus/fuzz-scene, tests/corpus/invalid-gltf
 * and tests/corpus/valid. */
#include <stddef.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "bbc/scene.h"
#include "gltf_shim_internal.h"

#define FUZZ_ASSERT(cond) \
  do {                    \
    if (!(cond)) abort(); \
  } while (0)

static void ignore_message(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  (void)message;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  bbc_scene_options options = {0};
  options.error_fn = ignore_message;
  options.warning_fn = ignore_message;
  bbc_scene *scene = NULL;
  bbc_result r = bbc__scene_load_memory(&scene, data, size, "fuzz.gltf", NULL, &options);
  if (r != BBC_OK) {
    FUZZ_ASSERT(scene == NULL);
    return 0;
  }
  FUZZ_ASSERT(scene != NULL);
  FUZZ_ASSERT(scene->triangle_count > 0 && scene->material_count > 0);
  for (uint32_t v = 0; v < 3 * scene->vertex_count; v++) FUZZ_ASSERT(isfinite(scene->positions[v]));
  for (uint32_t i = 0; i < 3 * scene->triangle_count; i++)
    FUZZ_ASSERT(scene->indices[i] < scene->vertex_count);
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    FUZZ_ASSERT(scene->triangle_mesh[t] < scene->mesh_count);
    (void)bbc_scene_triangle_material(scene, t);
  }
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    FUZZ_ASSERT(mesh->material < scene->material_count);
    FUZZ_ASSERT(mesh->first_vertex <= scene->vertex_count &&
                mesh->vertex_count <= scene->vertex_count - mesh->first_vertex);
    FUZZ_ASSERT(mesh->first_triangle <= scene->triangle_count &&
                mesh->triangle_count <= scene->triangle_count - mesh->first_triangle);
  }
  for (uint32_t e = 0; e < scene->emitter_count; e++)
    FUZZ_ASSERT(scene->emitters[e] < scene->triangle_count);
  bbc_scene_free(scene);
  return 0;
}
