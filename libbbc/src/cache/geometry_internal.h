/* The GEOM section (format-spec Sec. 5.11): the scene geometry a cache was computed for,
 * so that a scene that differs from it only by float noise (a re-export) can be
 * recognised and made exactly that geometry (Sec. 8.1). Shared by the writer
 * (cache_write.c), the reader (cache_read.c) and the merge (cache_merge.c). */
#ifndef BBC_GEOMETRY_INTERNAL_H
#define BBC_GEOMETRY_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"

#define BBC__SEC_GEOM BBC__FOURCC('G', 'E', 'O', 'M')
#define BBC__GEOM_HEAD_SIZE 64u
#define BBC__GEOM_LEVEL 3 /* zstd level of the geometry frame */

/* The GEOM section of a scene: a malloc'ed buffer (*out, *size) the caller frees. */
bbc_result bbc__geometry_encode(const bbc_scene *scene, uint8_t **out, size_t *size);

/* R-GEO-1, checked when a file is opened: the head of a GEOM section of `size` bytes
 * against the scene counts of FPRT. NULL when it holds, else what is wrong. */
const char *bbc__geometry_check_head(const uint8_t *sec, uint64_t size, uint32_t vertex_count,
                                     uint32_t triangle_count);

/* The decoded geometry: the arrays of the fingerprint's geometry stream (Sec. 8), in the
 * loader's canonical order. */
typedef struct bbc__geometry {
  uint32_t vertex_count, triangle_count;
  float *positions, *normals, *uvs;
  uint32_t *indices, *triangle_mesh;
} bbc__geometry;

/* R-GEO-2 and R-GEO-3: decodes a section whose head passed R-GEO-1 and checks that it
 * hashes to `geometry_hash` (FPRT's geometry part). BBC_ERR_CORRUPT with *why set, or
 * BBC_ERR_OUT_OF_MEMORY. */
bbc_result bbc__geometry_decode(const uint8_t *sec, uint64_t size, uint64_t geometry_hash,
                                bbc__geometry *out, const char **why);
void bbc__geometry_free(bbc__geometry *g);

/* Sec. 8.1: whether `scene` (whose meshes, materials and lights hash as the cache's)
 * holds the triangles of `g` within the quanta, in any order. BBC_OK and *match filled,
 * or BBC_ERR_SCENE_MISMATCH with a description of the first triangle that has no
 * counterpart in why[why_size], or BBC_ERR_OUT_OF_MEMORY. */
bbc_result bbc__geometry_match(const bbc__geometry *g, const bbc_scene *scene,
                               bbc_scene_match *match, char *why, size_t why_size);

#endif
