/* The ray-tracing acceleration structure of a scene (Embree 3, wrapped in one module so
 * that a move to Embree 4 touches one file). */
#ifndef BBC_ACCEL_H
#define BBC_ACCEL_H

#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Opaque; built once per scene, then read-only: any number of threads may trace rays
 * through it at once. It keeps a pointer to the scene, which must outlive it. */
typedef struct bbc_accel bbc_accel;

/* Builds the structure over every triangle of the scene. Details of a failure go to
 * error_fn (may be NULL). *out is NULL on failure. */
BBC_API bbc_result bbc_accel_create(bbc_accel **out, const bbc_scene *scene,
                                    bbc_message_fn error_fn, void *user);
/* NULL is allowed. */
BBC_API void bbc_accel_free(bbc_accel *accel);

/* A ray hit: distance t, the triangle, and its barycentrics: the hit point is
 * (1-u-v) p0 + u p1 + v p2. */
typedef struct bbc_hit {
  double t;
  uint32_t triangle;
  double u, v;
} bbc_hit;

/* Closest hit along origin + t dir for t in (tmin, tmax); returns 1 and fills *hit, or
 * returns 0. dir need not be normalised (t is then in units of |dir|).
 * Both queries see a surface only where it is there (bbc_scene_coverage, texture.h): a
 * MASK material's cut-outs are skipped, and a BLEND surface of coverage c is met with
 * probability c, decided by a hash of the ray and the hit, so the same ray always gets
 * the same answer. */
BBC_API int bbc_accel_intersect(const bbc_accel *accel, bbc_vec3 origin, bbc_vec3 dir, double tmin,
                                double tmax, bbc_hit *hit);
/* 1 if anything blocks the segment origin + t dir, t in (tmin, tmax). */
BBC_API int bbc_accel_occluded(const bbc_accel *accel, bbc_vec3 origin, bbc_vec3 dir, double tmin,
                               double tmax);

#ifdef __cplusplus
}
#endif

#endif
