/* Triangle tuples: a light, one or two specular triangles and a receiver triangle —
 * the unit the bounds are computed for, the cache stores and the renderer samples. */
#ifndef BBC_TUPLE_H
#define BBC_TUPLE_H

#include "bbc/common.h"
#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Chain types: R reflection, T refraction (transmission), in light-to-receiver order.
 * The values are stored in .bbc files and never change. */
typedef enum bbc_chain {
  BBC_CHAIN_R = 0,
  BBC_CHAIN_T = 1,
  BBC_CHAIN_RR = 2,
  BBC_CHAIN_RT = 3,
  BBC_CHAIN_TR = 4,
  BBC_CHAIN_TT = 5,
  BBC_CHAIN_COUNT = 6
} bbc_chain;

/* Bit of chain type c in a mask of chain types (bbc_precompute_params.chains). */
#define BBC_CHAIN_BIT(c) (1u << (c))
#define BBC_CHAIN_MASK_ALL 0x3Fu
/* The chain types with two specular vertices: RR, RT, TR, TT. */
#define BBC_CHAIN_MASK_DOUBLE 0x3Cu

/* Marks an unused specular slot (single-scattering chains). */
#define BBC_NO_TRIANGLE UINT32_MAX

typedef struct bbc_tuple {
  uint32_t light;       /* index into scene->point_lights */
  uint32_t chain;       /* a bbc_chain */
  uint32_t specular[2]; /* T1 and T2 (BBC_NO_TRIANGLE for one bounce), scene triangles */
  uint32_t receiver;    /* Tk: a scene triangle of a receiver mesh,
                           BBC_RECEIVER_PLANE(m), the plane of receiver mesh m, or
                           BBC_RECEIVER_BEAM, every receiver triangle not on a plane */
} bbc_tuple;

/* A tuple of a receiver that lies in a plane (bbc_mesh.plane) ends on the plane,
 * not on a triangle: its receiver field is BBC_RECEIVER_PLANE(mesh) and its bounds are
 * taken on the mesh's plane_triangle, which holds every point of the mesh. Its number
 * of tuples, and their cost, do not depend on how finely the plane is cut. */
#define BBC_RECEIVER_PLANE_BIT 0x80000000u
#define BBC_RECEIVER_PLANE(mesh) (BBC_RECEIVER_PLANE_BIT | (uint32_t)(mesh))
/* A beam tuple (light, T1[, T2]) ends on no receiver: its bounds are of the light
 * leaving its last specular vertex (bbc_bound_beam), recorded in the cells of every
 * receiver triangle that is not on a receiver plane and that the light can reach. One
 * such tuple stands for all those triangles, so their number does not multiply the
 * tuples (bbc_precompute_params.beam_receivers; docs/receivers.md). The value is no
 * plane's: meshes are far fewer than 2^31 - 1. */
#define BBC_RECEIVER_BEAM 0xFFFFFFFFu
static inline int bbc_receiver_is_beam(uint32_t receiver) {
  return receiver == BBC_RECEIVER_BEAM;
}
static inline int bbc_receiver_is_plane(uint32_t receiver) {
  return (receiver & BBC_RECEIVER_PLANE_BIT) != 0 && receiver != BBC_RECEIVER_BEAM;
}
static inline uint32_t bbc_receiver_plane_mesh(uint32_t receiver) {
  return receiver & ~BBC_RECEIVER_PLANE_BIT;
}

/* The triangle a tuple's receiver field names, the one its bounds are taken on: the
 * scene triangle, or a plane's plane_triangle. Returns 0 when the field names neither a
 * scene triangle nor the plane of a receiver (a beam names no triangle). */
BBC_API int bbc_receiver_triangle(const bbc_scene *scene, uint32_t receiver, bbc_vec3 out[3]);

/* Number of specular vertices of a chain type (1 or 2). */
static inline int bbc_chain_length(bbc_chain chain) {
  return chain <= BBC_CHAIN_T ? 1 : 2;
}
/* 1 if the i-th specular vertex (0-based) of the chain refracts. */
static inline int bbc_chain_refracts(bbc_chain chain, int i) {
  static const char *const codes[BBC_CHAIN_COUNT] = {"R", "T", "RR", "RT", "TR", "TT"};
  return codes[chain][i] == 'T';
}
/* "R", "T", "RR", ... */
BBC_API const char *bbc_chain_name(bbc_chain chain);
/* Parses a chain name; returns 1 on success. */
BBC_API int bbc_chain_parse(const char *name, bbc_chain *out);

#ifdef __cplusplus
}
#endif

#endif
