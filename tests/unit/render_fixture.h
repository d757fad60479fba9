/* The set-up of the tests that render through a cache: a scene, its ray tracer and a
 * cache precomputed in memory with the default parameters except chains, level, a
 * 128x128 grid and, when asked, area lights. */
#ifndef BBC_TEST_RENDER_FIXTURE_H
#define BBC_TEST_RENDER_FIXTURE_H

#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"

typedef struct fixture {
  bbc_scene *scene;
  bbc_accel *accel;
  bbc_cache *cache;
  void *bytes;
} fixture;

/* Precomputes a cache of `source` (f->scene itself, or a scene differing from it in what
 * the cache does not hold) with the default parameters but chains, level, grid and area
 * lights into f, and checks it against f->scene. Returns 1 when every step succeeded. */
static inline int fixture_cache(fixture *f, const bbc_scene *source, uint32_t chains,
                         uint32_t max_level, uint32_t grid, int area_lights) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.chains = chains;
  o.params.max_level = max_level;
  o.params.grid_resolution = grid;
  o.params.area_lights = area_lights;
  o.params.area_double = area_lights && (chains & BBC_CHAIN_MASK_DOUBLE);
  bbc_cache_builder *b = NULL;
  if (bbc_precompute(&b, source, &o, NULL) != BBC_OK) return 0;
  size_t size = 0;
  bbc_result r = bbc_cache_builder_write_memory(b, &f->bytes, &size, NULL);
  bbc_cache_builder_free(b);
  if (r != BBC_OK) return 0;
  return bbc_cache_open_memory(&f->cache, f->bytes, size, NULL) == BBC_OK &&
         bbc_cache_check_scene(f->cache, f->scene) == BBC_OK;
}

/* Returns 1 when every step succeeded and the cache matches the scene (grid 128). */
static inline int fixture_setup(fixture *f, const char *path, uint32_t chains, uint32_t max_level,
                                int area_lights) {
  memset(f, 0, sizeof *f);
  if (bbc_scene_load(&f->scene, path, NULL) != BBC_OK) return 0;
  if (bbc_accel_create(&f->accel, f->scene, NULL, NULL) != BBC_OK) return 0;
  return fixture_cache(f, f->scene, chains, max_level, 128, area_lights);
}

static inline void teardown(fixture *f) {
  bbc_cache_close(f->cache);
  free(f->bytes);
  bbc_accel_free(f->accel);
  bbc_scene_free(f->scene);
}

/* A w x h render of f's scene with options o, through f's cache unless o.method is path
 * tracing, its statistics into stats (may be NULL); NULL on failure. */
static inline bbc_image *fixture_render(const fixture *f, bbc_render_options o, uint32_t w,
                                        uint32_t h, bbc_render_stats *stats) {
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return NULL;
  o.cache = o.method == BBC_METHOD_PT ? NULL : f->cache;
  if (bbc_render(f->scene, f->accel, &o, image, stats) != BBC_OK) {
    bbc_image_free(image);
    return NULL;
  }
  return image;
}

#endif
