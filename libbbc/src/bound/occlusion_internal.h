/* Occlusion between two specular vertices (occlusion.c): a proof that every straight
 * segment from a point of triangle A to a point of triangle B crosses the surface of a
 * closed mesh, so that no path goes from A to B without another vertex (a hollow glass's
 * inner sphere between two points of its outer one, the cavity of a vase between its
 * near and far walls, the water in a glass). The tuple search drops such (T1, T2) pairs.
 *
 * The proof: an axis-aligned plane P separates A and B strictly; every segment from A to
 * B crosses P inside the convex hull of the nine crossings of the segments between their
 * vertices (central projection maps a triangle to a convex set whose corners are its
 * vertices' images), so inside the box R of those nine points. If R meets no triangle of
 * a closed mesh M, every point of R has one parity with respect to M (the crossings of a
 * ray, mod 2: inside or outside M); if that parity differs from the parity just off A on
 * B's side (one value when no other triangle of M passes through A's interior), each
 * segment crosses M's surface between A and P. Closed meshes are the closed dielectrics
 * without cut-outs (media_internal.h; a cut-out lets light through). Every decision
 * whose rounding could change it (a ray near a triangle's edge, a triangle near R) gives
 * "not proven": the test only ever drops pairs that are blocked. */
#ifndef BBC_OCCLUSION_INTERNAL_H
#define BBC_OCCLUSION_INTERNAL_H

#include <stdint.h>

#include "bbc/scene.h"

typedef struct bbc__occluders bbc__occluders;

/* The closed meshes of the scene in a BVH. *out is NULL when the scene has none (then
 * nothing is ever blocked). */
bbc_result bbc__occluders_create(bbc__occluders **out, const bbc_scene *scene);
void bbc__occluders_free(bbc__occluders *o); /* NULL is allowed */

/* 1 when every segment from a point of triangle a to a point of triangle b crosses a
 * closed mesh's surface between them (proven); 0 when not proven. o may be NULL.
 * Thread-safe. */
int bbc__occluders_block(const bbc__occluders *o, uint32_t a, uint32_t b);

/* Controls for the tests, never set otherwise (0): 1 skips the check that the box R
 * meets no triangle of the mesh, so that R's parity is taken at its centre alone; 2
 * proves nothing (the search without the test). */
extern int bbc__occlusion_control;

#endif
