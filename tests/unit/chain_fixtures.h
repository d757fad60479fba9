/* Fixtures shared by the exact-path and solver tests: a deterministic generator, points
 * of the unit triangle, hand-made specular triangles, mirror images and a scene's
 * triangles by role. Header-only (static), one copy per test runner.
 *
 * Define CHAIN_FIXTURES_SEED before including to choose the generator's start, so each
 * runner keeps its own reproducible sequence. */
#ifndef BBC_CHAIN_FIXTURES_H
#define BBC_CHAIN_FIXTURES_H

#include <stdint.h>
#include <stdlib.h>

#include "bbc/scene.h"
#include "bbc/specular_path.h"
#include "vec_internal.h"

#ifndef CHAIN_FIXTURES_SEED
#define CHAIN_FIXTURES_SEED 0x9e3779b97f4a7c15ull
#endif

static uint64_t rng_state = CHAIN_FIXTURES_SEED;

/* splitmix64 in [0, 1): deterministic, so failures reproduce. */
static inline double rnd(void) {
  uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

/* A uniform point of the unit triangle. */
static inline void rnd_bary(double *u, double *v) {
  double a = rnd(), b = rnd();
  if (a + b > 1) a = 1 - a, b = 1 - b;
  *u = a, *v = b;
}

static inline void set_tri(bbc_vec3 p[3], bbc_vec3 a, bbc_vec3 b, bbc_vec3 c) {
  p[0] = a, p[1] = b, p[2] = c;
}

/* A specular triangle with one normal n at every vertex. */
static inline void flat_specular(bbc_specular_triangle *t, bbc_vec3 a, bbc_vec3 b, bbc_vec3 c,
                                 bbc_vec3 n, int refract, double ior) {
  set_tri(t->p, a, b, c);
  t->n[0] = t->n[1] = t->n[2] = n;
  t->refract = refract;
  t->ior = ior;
}

/* The mirror image of x in the plane through p with unit normal n. */
static inline bbc_vec3 mirror_point(bbc_vec3 x, bbc_vec3 p, bbc_vec3 n) {
  return v3_sub(x, v3_scale(n, 2.0 * v3_dot(v3_sub(x, p), n)));
}

/* The scene triangles of meshes with the given role, in *out (free with free()). */
static inline uint32_t role_triangles(const bbc_scene *s, bbc_role role, uint32_t **out) {
  uint32_t n = 0;
  *out = malloc(sizeof(uint32_t) * (s->triangle_count ? s->triangle_count : 1));
  for (uint32_t t = 0; t < s->triangle_count; t++)
    if (s->meshes[s->triangle_mesh[t]].role == role) (*out)[n++] = t;
  return n;
}

#endif
