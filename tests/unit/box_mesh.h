/* Axis-aligned boxes (and single faces of them) as glTF mesh arrays, for tests that
 * write small scenes in memory: 4 vertices and 2 triangles per face, flat normals.
 * Header-only with static functions, like the other test fixtures. */
#ifndef BBC_TEST_BOX_MESH_H
#define BBC_TEST_BOX_MESH_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* A mesh's arrays: room for two boxes. */
typedef struct box_mesh {
  float p[48][3], n[48][3];
  uint32_t i[72];
  int faces;
} box_mesh;

/* Adds the face of box [lo, hi] on axis a at side s (+1: hi, normal +e_a; -1: lo),
 * counter-clockwise seen from where its normal points. */
static void add_face(box_mesh *m, int a, int s, const double lo[3], const double hi[3]) {
  const int b = (a + 1) % 3, c = (a + 2) % 3;
  const int corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  uint32_t v0 = 4 * (uint32_t)m->faces;
  for (int k = 0; k < 4; k++) {
    float *p = m->p[v0 + k], *n = m->n[v0 + k];
    p[a] = (float)(s > 0 ? hi[a] : lo[a]);
    p[b] = (float)(corner[k][0] ? hi[b] : lo[b]);
    p[c] = (float)(corner[k][1] ? hi[c] : lo[c]);
    n[a] = (float)s, n[b] = 0, n[c] = 0;
  }
  static const uint32_t ccw[6] = {0, 1, 2, 0, 2, 3}, cw[6] = {0, 2, 1, 0, 3, 2};
  for (int k = 0; k < 6; k++) m->i[6 * m->faces + k] = v0 + (s > 0 ? ccw : cw)[k];
  m->faces++;
}

/* Packs meshes m[0..n) into buf (room for n box_mesh): for each, its positions, normals
 * and indices, whose (offset, length) go to view[3k], view[3k + 1], view[3k + 2].
 * Returns the bytes written. */
static size_t box_meshes_pack(const box_mesh *const *m, int n, unsigned char *buf,
                              size_t view[][2]) {
  size_t at = 0;
  for (int k = 0; k < n; k++) {
    size_t nv = 4 * (size_t)m[k]->faces, ni = 6 * (size_t)m[k]->faces;
    view[3 * k][0] = at, view[3 * k][1] = 12 * nv;
    memcpy(buf + at, m[k]->p, 12 * nv), at += 12 * nv;
    view[3 * k + 1][0] = at, view[3 * k + 1][1] = 12 * nv;
    memcpy(buf + at, m[k]->n, 12 * nv), at += 12 * nv;
    view[3 * k + 2][0] = at, view[3 * k + 2][1] = 4 * ni;
    memcpy(buf + at, m[k]->i, 4 * ni), at += 4 * ni;
  }
  return at;
}

#endif
