/* Tuple construction (paper Sec. 6.1, DESIGN 3.7): from a prefix (light, T1), bound the
 * first vertex x1 and the outgoing direction d1 over all of T1, then walk a BVH over the
 * next triangles (receivers, or specular casters for a second bounce) keeping every node
 * whose box B can meet the beam: the bound of (x - x1) x d1 over x in B must contain
 * zero, and (x - x1) . d1 must be able to be positive. A second triangle is searched
 * with the beams of sixteenths of T1, and each one the walk finds is then tested
 * exactly, by Bernstein bounds of the ray's Plucker edge functions (beam_hits). A prefix
 * (light, T1, T2) extends the same way with the beam of T2: x2 over T2's box and d2
 * scattered by T2's normals from the d1 of the parts of T1 that reach T2, in interval
 * arithmetic. Never all pairs: the work follows the beam. A pair with a closed surface
 * between every point of T1 and of T2 is dropped (occlusion_internal.h). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "bbc/interval.h"
#include "bbc/bounds.h"
#include "bbc/texture.h"
#include "chain_internal.h"
#include "light_internal.h"
#include "media_internal.h"
#include "occlusion_internal.h"
#include "orient_internal.h"
#include "scene_internal.h"
#include "tuple_search_internal.h"
#include "vec_internal.h"

/* T2 is searched with the beams of the BEAM_BOXES boxes of a BEAM_SPLIT x BEAM_SPLIT
 * grid over T1's unit box that meet the triangle (at most 16: a uint16_t mask each). */
#define BEAM_SPLIT 4
#define BEAM_BOXES (BEAM_SPLIT * (BEAM_SPLIT + 1) / 2)

typedef struct bvh_node {
  double lo[3], hi[3];
  uint32_t first, count; /* leaf: triangles order[first, first + count) */
  uint32_t left, right;  /* inner node children (count == 0) */
} bvh_node;

/* A BVH over items: scene triangles, and for receivers the planes
 * (BBC_RECEIVER_PLANE(mesh)) that stand for all the triangles of a receiver plane. */
typedef struct bvh {
  bvh_node *nodes;
  uint32_t node_count;
  uint32_t *order;
  double (*mesh_box)[6]; /* per mesh: lo, hi of its triangles */
  /* per mesh, bit k (k < 6, as mesh_box): some triangle lies wholly in the box's face k,
   * the plane x_a = mesh_box[k] (a = k % 3) */
  uint8_t *mesh_faces;
} bvh;

static void item_bounds(const bvh *b, const bbc_scene *scene, uint32_t item, double lo[3],
                        double hi[3]) {
  if (!bbc_receiver_is_plane(item)) {
    bbc__triangle_box(scene, item, lo, hi);
    return;
  }
  const double *box = b->mesh_box[bbc_receiver_plane_mesh(item)];
  for (int a = 0; a < 3; a++) lo[a] = box[a], hi[a] = box[3 + a];
}

/* Midpoint split on the longest axis of the node (supplement Sec. 4.1). */
static uint32_t bvh_build(bvh *b, const bbc_scene *scene, uint32_t first, uint32_t count) {
  uint32_t index = b->node_count++;
  bvh_node node;
  memset(&node, 0, sizeof node);
  for (int a = 0; a < 3; a++) {
    node.lo[a] = INFINITY;
    node.hi[a] = -INFINITY;
  }
  for (uint32_t i = first; i < first + count; i++) {
    double lo[3], hi[3];
    item_bounds(b, scene, b->order[i], lo, hi);
    for (int a = 0; a < 3; a++) {
      node.lo[a] = fmin(node.lo[a], lo[a]);
      node.hi[a] = fmax(node.hi[a], hi[a]);
    }
  }
  int axis = 0;
  for (int a = 1; a < 3; a++)
    if (node.hi[a] - node.lo[a] > node.hi[axis] - node.lo[axis]) axis = a;
  double mid = 0.5 * (node.lo[axis] + node.hi[axis]);
  uint32_t split = first;
  if (count > 4) {
    for (uint32_t i = first; i < first + count; i++) {
      double lo[3], hi[3];
      item_bounds(b, scene, b->order[i], lo, hi);
      if (0.5 * (lo[axis] + hi[axis]) < mid) {
        uint32_t tmp = b->order[i];
        b->order[i] = b->order[split];
        b->order[split++] = tmp;
      }
    }
    if (split == first || split == first + count) split = first + count / 2;
  }
  if (count <= 4) {
    node.first = first;
    node.count = count;
  } else {
    node.left = bvh_build(b, scene, first, split - first);
    node.right = bvh_build(b, scene, split, first + count - split);
  }
  b->nodes[index] = node;
  return index;
}

/* The tuples of a chunk of prefixes, at most `limit` of them (the search stops there and
 * carries on once they are handed out). */
typedef struct tuple_list {
  bbc_tuple *items;
  size_t count, capacity, limit;
} tuple_list;

/* Appends t, growing the list up to its limit; 0 when memory ran out. The caller checks
 * count < limit first. */
static int tuple_push(tuple_list *l, const bbc_tuple *t) {
  if (l->count == l->capacity) {
    size_t capacity = l->capacity ? 2 * l->capacity : 1024;
    if (capacity > l->limit) capacity = l->limit;
    bbc_tuple *items = realloc(l->items, capacity * sizeof *items);
    if (!items) return 0;
    l->items = items;
    l->capacity = capacity;
  }
  l->items[l->count++] = *t;
  return 1;
}

static int compare_u32(const void *a, const void *b) {
  uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
  return (x > y) - (x < y);
}

/* The beam of a box of T1's unit box: the interval boxes of x1 and d1 (for the BVH walk)
 * and, for the exact test against one triangle (beam_hits), the Bernstein forms of x1,
 * of d1 and of the moment m = x1 x d1 (the ray's Plucker coordinates; d1e is d1 at m's
 * degrees) with the magnitudes of their bounds, from the chain forms of the box (the
 * receiver is irrelevant here; T1 stands in). The forms live in the arena until it is
 * reset below them. */
typedef struct beam {
  bbc_ivec3 x, d;
  const bbc_poly *forms[12]; /* d1e, m, d1, x1 (three coordinates each) */
  double size[12];           /* the larger magnitude of each one's bound */
  bbc_poly3 x1, d1, d1e, m;
} beam;

static bbc_result beam_of(bbc_arena *arena, const bbc_tuple_geometry *g, const double box[4],
                          beam *out) {
  bbc_space space;
  memset(&space, 0, sizeof space);
  int s_axis, t_axis;
  bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &s_axis);
  bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &t_axis);
  chain_forms f;
  bbc_result r =
      bbc__chain_forms_prefix(arena, &space, g, box, s_axis, t_axis, CHAIN_SQRT_PRIMAL, &f);
  if (r == BBC_OK) r = bbc_poly3_cross(arena, &out->m, &f.x1, &f.d1);
  out->x1 = f.x1;
  out->d1 = f.d1;
  /* d1 and m at their common degrees, so that no combination of them elevates. */
  bbc_poly *e[6] = {&out->d1e.x, &out->d1e.y, &out->d1e.z, &out->m.x, &out->m.y, &out->m.z};
  const bbc_poly *d[3] = {&f.d1.x, &f.d1.y, &f.d1.z};
  unsigned char deg[BBC_POLY_MAX_AXES];
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++) {
    deg[j] = 0;
    for (int k = 0; k < 6; k++) {
      const bbc_poly *p = k < 3 ? d[k] : e[k];
      if (p->deg[j] > deg[j]) deg[j] = p->deg[j];
    }
  }
  for (int k = 0; k < 6 && r == BBC_OK; k++) r = bbc_poly_elevate(arena, e[k], k < 3 ? d[k] : e[k], deg);
  if (r != BBC_OK) return r;
  const bbc_poly *x[3] = {&out->x1.x, &out->x1.y, &out->x1.z};
  const bbc_poly *dd[3] = {&out->d1.x, &out->d1.y, &out->d1.z};
  const bbc_poly *mm[3] = {&out->m.x, &out->m.y, &out->m.z};
  for (int k = 0; k < 3; k++) {
    out->forms[k] = e[k];
    out->forms[3 + k] = mm[k];
    out->forms[6 + k] = dd[k];
    out->forms[9 + k] = x[k];
  }
  for (int k = 0; k < 12; k++) {
    bbc_interval range = bbc_poly_bound(out->forms[k]);
    out->size[k] = fmax(fabs(range.lo), fabs(range.hi));
  }
  out->x = (bbc_ivec3){bbc_poly_bound(x[0]), bbc_poly_bound(x[1]), bbc_poly_bound(x[2])};
  out->d = (bbc_ivec3){bbc_poly_bound(dd[0]), bbc_poly_bound(dd[1]), bbc_poly_bound(dd[2])};
  return BBC_OK;
}

/* What beam_hits needs of a triangle q (edges ab in cyclic order, n = (q1 - q0) x
 * (q2 - q0)), in outward-rounded interval arithmetic on the exact vertices: per edge
 * a x b and b - a, then n and n . q0. */
typedef struct triangle_planes {
  bbc_ivec3 cross[3], edge[3], n;
  bbc_interval offset;
} triangle_planes;

static void triangle_planes_of(const bbc_scene *scene, uint32_t t, triangle_planes *out) {
  bbc_ivec3 q[3];
  for (int c = 0; c < 3; c++)
    q[c] = bbc_ivec3_point(v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + c]));
  for (int e = 0; e < 3; e++) {
    out->cross[e] = bbc_ivec3_cross(q[e], q[(e + 1) % 3]);
    out->edge[e] = bbc_ivec3_sub(q[(e + 1) % 3], q[e]);
  }
  out->n = bbc_ivec3_cross(out->edge[0], bbc_ivec3_sub(q[2], q[0]));
  out->offset = bbc_ivec3_dot(out->n, q[0]);
}

/* The bound of c + sum_k v[k] forms[first + k] over the beam's box for enclosures v[k],
 * c of constants: their midpoints enter the Bernstein form (one linear combination),
 * what the midpoints may miss the error radius. */
static bbc_result combination_bound(bbc_arena *arena, const beam *b, int first, int n,
                                    const bbc_interval *v, bbc_interval c, bbc_interval *out) {
  double mid[6], radius = 0;
  for (int k = 0; k < n; k++) {
    mid[k] = 0.5 * v[k].lo + 0.5 * v[k].hi;
    radius += fmax(v[k].hi - mid[k], mid[k] - v[k].lo) * b->size[first + k];
  }
  const double cm = 0.5 * c.lo + 0.5 * c.hi;
  radius += fmax(c.hi - cm, cm - c.lo);
  bbc_poly p;
  size_t mark = bbc_arena_mark(arena);
  bbc_result r = bbc_poly_lincomb(arena, &p, n, mid, b->forms + first);
  if (r == BBC_OK && cm != 0) r = bbc_poly_add_scalar(arena, &p, &p, cm);
  if (r == BBC_OK) {
    /* The radii, their products and sums rounded: a few ulps more cover them. */
    bbc_poly_widen(&p, radius * (1 + 16 * DBL_EPSILON) + DBL_EPSILON * fabs(cm) + DBL_MIN);
    *out = bbc_poly_bound(&p);
  }
  bbc_arena_reset(arena, mark);
  return r;
}

/* Whether some ray of the beam (x1 + t d1, t > 0, over the beam's box of T1) can meet
 * the triangle, by Bernstein bounds of the exact conditions (Plucker's test): the line
 * meets the triangle where the three edge functions
 *   S_ab = d1 . ((a - x1) x (b - x1)) = d1 . (a x b) + (b - a) . m
 * of its edges ab in cyclic order have one sign, and then their sum is kappa = d1 . n
 * and the hit lies ahead of x1 where tau = n . (q0 - x1) has kappa's sign. The triangle
 * is missed when neither sign can hold for all five at once at any point, which is
 * proved when, for each sign, one of them is bounded away from it over the whole box.
 * tau is affine on T1, so the sign it can take strictly somewhere on T1 is that of a
 * vertex of T1, which plane_sides decides exactly: sides bit 0 when tau > 0 somewhere,
 * bit 1 when tau < 0 somewhere. Where tau = 0 the hit
 * would be x1 itself, no path (a neighbour of T1 seen from their shared vertex). The
 * constants are enclosed in interval arithmetic, so the test never rejects a triangle
 * some ray meets. */
static bbc_result beam_hits(bbc_arena *arena, const beam *b, const triangle_planes *q, int sides,
                            int *hit) {
  /* tau and kappa first (the cheapest), then the edge functions, until both signs
   * are ruled out. */
  const bbc_interval zero = bbc_interval_point(0);
  const bbc_interval vn[3] = {q->n.x, q->n.y, q->n.z};
  const bbc_interval vm[3] = {bbc_interval_neg(q->n.x), bbc_interval_neg(q->n.y),
                              bbc_interval_neg(q->n.z)};
  int positive = (sides & 1) != 0, negative = (sides & 2) != 0, unknown = 0;
  for (int k = 0; k < 5 && (positive || negative) && !unknown; k++) {
    bbc_interval f;
    bbc_result r;
    if (k == 0) {
      r = combination_bound(arena, b, 9, 3, vm, q->offset, &f);
    } else if (k == 1) {
      r = combination_bound(arena, b, 6, 3, vn, zero, &f);
    } else {
      const int e = k - 2;
      const bbc_interval v[6] = {q->cross[e].x, q->cross[e].y, q->cross[e].z,
                                 q->edge[e].x,  q->edge[e].y,  q->edge[e].z};
      r = combination_bound(arena, b, 0, 6, v, zero, &f);
    }
    if (r != BBC_OK) return r;
    unknown |= isnan(f.lo) || isnan(f.hi);
    positive &= f.hi >= 0;
    negative &= f.lo <= 0;
  }
  *hit = unknown || positive || negative;
  return BBC_OK;
}

/* A BVH over the triangles of meshes with the given role; a receiver plane
 * (bbc_mesh.plane) is one item, its plane, boxed by its triangles. With `whole_meshes`
 * (beam receivers) every mesh is one such item, BBC_RECEIVER_PLANE(mesh) whether it is a
 * plane or not (beam_items tells them apart): a beam tuple then depends on the boxes of
 * the receivers, not on how finely they are cut. */
static bbc_result bvh_init(bvh *b, const bbc_scene *scene, bbc_role role, int whole_meshes) {
  memset(b, 0, sizeof *b);
  b->mesh_box = malloc((scene->mesh_count ? scene->mesh_count : 1) * sizeof *b->mesh_box);
  b->mesh_faces = calloc(scene->mesh_count ? scene->mesh_count : 1, 1);
  if (!b->mesh_box || !b->mesh_faces) return BBC_ERR_OUT_OF_MEMORY;
  uint32_t n = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    double *box = b->mesh_box[m];
    for (int a = 0; a < 3; a++) box[a] = INFINITY, box[3 + a] = -INFINITY;
    for (uint32_t t = mesh->first_triangle; t < mesh->first_triangle + mesh->triangle_count; t++) {
      double lo[3], hi[3];
      bbc__triangle_box(scene, t, lo, hi);
      for (int a = 0; a < 3; a++)
        box[a] = fmin(box[a], lo[a]), box[3 + a] = fmax(box[3 + a], hi[a]);
    }
    for (uint32_t t = mesh->first_triangle; t < mesh->first_triangle + mesh->triangle_count; t++) {
      double lo[3], hi[3];
      bbc__triangle_box(scene, t, lo, hi);
      for (int k = 0; k < 6; k++)
        if (lo[k % 3] == box[k] && hi[k % 3] == box[k]) b->mesh_faces[m] |= (uint8_t)(1u << k);
    }
    if (mesh->role == role) n += mesh->plane || whole_meshes ? 1 : mesh->triangle_count;
  }
  if (n == 0) return BBC_OK;
  b->order = malloc(n * sizeof *b->order);
  b->nodes = malloc(2 * (size_t)n * sizeof *b->nodes);
  if (!b->order || !b->nodes) return BBC_ERR_OUT_OF_MEMORY;
  n = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != role) continue;
    if (mesh->plane != 0 || whole_meshes) {
      b->order[n++] = BBC_RECEIVER_PLANE(m);
      continue;
    }
    for (uint32_t t = mesh->first_triangle; t < mesh->first_triangle + mesh->triangle_count; t++)
      b->order[n++] = t;
  }
  bvh_build(b, scene, 0, n);
  return BBC_OK;
}

static void bvh_free(bvh *b) {
  free(b->nodes);
  free(b->order);
  free(b->mesh_box);
  free(b->mesh_faces);
}

/* The triangles of b the beam (x, d) can meet, sorted, into found; returns their number.
 * stack holds b->node_count entries. */
static uint32_t bvh_beam(const bvh *b, const bbc_scene *scene, const bbc_ivec3 *x,
                         const bbc_ivec3 *d, uint32_t *stack, uint32_t *found) {
  uint32_t n = 0, top = 0;
  if (b->node_count == 0) return 0;
  stack[top++] = 0;
  while (top) {
    const bvh_node *node = &b->nodes[stack[--top]];
    if (!bbc__ray_may_meet_box(x, d, node->lo, node->hi)) continue;
    if (node->count) {
      for (uint32_t i = node->first; i < node->first + node->count; i++) {
        double lo[3], hi[3];
        item_bounds(b, scene, b->order[i], lo, hi);
        if (bbc__ray_may_meet_box(x, d, lo, hi)) found[n++] = b->order[i];
      }
    } else {
      stack[top++] = node->right;
      stack[top++] = node->left;
    }
  }
  qsort(found, n, sizeof *found, compare_u32);
  return n;
}

/* Whether `medium` (0 nothing, m + 1 inside mesh m) holds the light it encloses: m is
 * closed and has no cut-outs (bbc_material_partial), through which light would leave. */
static int encloses(const bbc_scene *scene, uint32_t medium) {
  if (medium == 0) return 0;
  const bbc_mesh *m = &scene->meshes[medium - 1];
  return m->closed && !bbc_material_partial(scene, &scene->materials[m->material]);
}

/* Whether light enclosed by `medium` (0 nothing, m + 1 inside the volume closed mesh m
 * encloses, bbc__media_enclosure) after the last specular vertex can reach receiver item
 * r. Inside a closed mesh it reaches only what may lie inside: a receiver whose box
 * misses the mesh's box lies wholly outside, and every segment to it crosses the mesh, a
 * specular vertex more than the chain has (the medium rule, media_internal.h). A flat
 * receiver in the plane of a face of the mesh's box (a floor under a ball resting on it)
 * meets the closed volume only on the mesh's surface there, an area of zero unless a
 * triangle of the mesh lies in that plane (the bottom of a pool's water on its floor):
 * without one, no light lands on it with an area to be seen. Exact on the float data. */
int bbc__tuple_face_rule = 1;

static int medium_reaches(const bvh *b, const bbc_scene *scene, uint32_t medium, uint32_t r) {
  if (!encloses(scene, medium)) return 1;
  double lo[3], hi[3];
  item_bounds(b, scene, r, lo, hi);
  const double *box = b->mesh_box[medium - 1];
  for (int a = 0; a < 3; a++)
    if (hi[a] < box[a] || lo[a] > box[3 + a]) return 0;
  for (int k = 0; k < 6 && bbc__tuple_face_rule; k++)
    if (lo[k % 3] == hi[k % 3] && lo[k % 3] == box[k] && !(b->mesh_faces[medium - 1] & (1u << k)))
      return 0;
  return 1;
}

/* Beam receivers (bbc_tuples_find_beam): the n items the walk found, sorted (whole
 * meshes, bvh_init), with the receivers that are not planes replaced by one
 * BBC_RECEIVER_BEAM after the planes (the largest value, so the list stays sorted) when
 * any of them is reachable in `medium`; the items the medium rule drops are dropped
 * here. Returns the new count. */
static uint32_t beam_items(const bvh *b, const bbc_scene *scene, uint32_t medium, uint32_t *found,
                           uint32_t n) {
  uint32_t k = 0;
  int any = 0;
  for (uint32_t i = 0; i < n; i++) {
    if (!medium_reaches(b, scene, medium, found[i])) continue;
    if (scene->meshes[bbc_receiver_plane_mesh(found[i])].plane)
      found[k++] = found[i];
    else
      any = 1;
  }
  if (any) found[k++] = BBC_RECEIVER_BEAM;
  return k;
}

/* Whether the walk's item r is a tuple's receiver in `medium`. */
static int item_reaches(const bvh *b, const bbc_scene *scene, uint32_t medium, uint32_t r) {
  return bbc_receiver_is_beam(r) || medium_reaches(b, scene, medium, r);
}

/* The chain letter of a specular material: 0 mirror (R), 1 dielectric (T), -1 neither. */
static int scattering_of(const bbc_scene *scene, uint32_t t) {
  const bbc_mesh *mesh = &scene->meshes[scene->triangle_mesh[t]];
  if (mesh->role != BBC_ROLE_CASTER) return -1;
  const bbc_material *m = &scene->materials[mesh->material];
  return m->type == BBC_MATERIAL_MIRROR ? 0 : m->type == BBC_MATERIAL_DIELECTRIC ? 1 : -1;
}

/* The beam of T2 for the prefix (light, T1, T2): x2 anywhere on T2's box, and d2 the
 * scattering (Eq. 10-11, unnormalised) of any d1 of T1's beam by any normal in the box
 * of T2's oriented vertex normals (their convex hull holds every interpolated normal).
 * Returns 0 when no direction leaves (total internal reflection everywhere). */
static int second_beam(const bbc_tuple_geometry *g, const bbc_ivec3 *d1, bbc_ivec3 *x,
                       bbc_ivec3 *d) {
  bbc_ivec3 n = bbc_ivec3_point(g->n2[0]), lo_hi;
  for (int i = 1; i < 3; i++) {
    lo_hi = bbc_ivec3_point(g->n2[i]);
    n.x = bbc_interval_hull(n.x, lo_hi.x);
    n.y = bbc_interval_hull(n.y, lo_hi.y);
    n.z = bbc_interval_hull(n.z, lo_hi.z);
  }
  *x = bbc_ivec3_point(g->p2[0]);
  for (int i = 1; i < 3; i++) {
    lo_hi = bbc_ivec3_point(g->p2[i]);
    x->x = bbc_interval_hull(x->x, lo_hi.x);
    x->y = bbc_interval_hull(x->y, lo_hi.y);
    x->z = bbc_interval_hull(x->z, lo_hi.z);
  }
  bbc_interval nn = bbc_ivec3_dot(n, n), dn = bbc_ivec3_dot(*d1, n);
  bbc_ivec3 nn_d = bbc_ivec3_scale(nn, *d1);
  if (!g->refract2) {
    *d = bbc_ivec3_sub(nn_d, bbc_ivec3_scale(bbc_interval_scale(dn, 2.0), n));
    return 1;
  }
  const double eta = g->eta2;
  bbc_interval e2 = bbc_interval_mul(bbc_interval_point(eta), bbc_interval_point(eta));
  bbc_interval beta = bbc_interval_add(
      bbc_interval_mul(bbc_interval_sub(bbc_interval_point(1.0), e2),
                       bbc_interval_mul(nn, bbc_ivec3_dot(*d1, *d1))),
      bbc_interval_mul(e2, bbc_interval_sqr(dn)));
  if (beta.hi < 0) return 0;
  if (beta.lo < 0) beta.lo = 0;
  bbc_ivec3 tangential = bbc_ivec3_sub(nn_d, bbc_ivec3_scale(dn, n));
  *d = bbc_ivec3_sub(bbc_ivec3_scale(bbc_interval_point(eta), tangential),
                     bbc_ivec3_scale(bbc_interval_sqrt(beta), n));
  return 1;
}

/* The sides of T2's plane that T1's vertices lie strictly on (exactly, on the float
 * data): bit 0 behind (tau > 0 in beam_hits: orient3d has the sign of n . (p - q0) =
 * -tau(p)), bit 1 in front. 0 when T1 lies in T2's plane: a segment from a point of that
 * plane to another one lies in the plane, so it meets T2 edge-on or not at all, and no
 * path goes from T1 to T2, whatever the shading normals. */
static int plane_sides(const bbc_scene *scene, uint32_t t1, uint32_t t2) {
  const float *q[3];
  for (int k = 0; k < 3; k++) q[k] = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t2 + k];
  int sides = 0;
  for (int k = 0; k < 3; k++) {
    const float *p = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t1 + k];
    int o = bbc__orient3d(q[0], q[1], q[2], p);
    sides |= o < 0 ? 1 : o > 0 ? 2 : 0;
  }
  return sides;
}

/* The medium rule (media_internal.h) for T2, over every x1 of T1: the sides of T2 (1
 * front, 2 behind) from which light in `medium` may refract at dielectric T2 coming from
 * some point of T1; 0 when none. A side is possible when some vertex of T1 lies strictly
 * on it (light from a point in T2's plane never meets T2 elsewhere). */
static int second_refraction_possible(const bbc_scene *scene, uint32_t medium, uint32_t t1,
                                      uint32_t t2) {
  const uint32_t *idx = scene->indices + 3 * (size_t)t1;
  int front = 0, behind = 0;
  for (int k = 0; k < 3; k++) {
    int side = bbc__media_side(scene, t2, v3_load(scene->positions + 3 * (size_t)idx[k]));
    front |= side > 0;
    behind |= side < 0;
  }
  uint32_t after;
  return (front && bbc__media_refract(scene, medium, t2, 1, &after) ? 1 : 0) |
         (behind && bbc__media_refract(scene, medium, t2, -1, &after) ? 2 : 0);
}

/* 0 only when the outer cone of a spot light provably misses triangle t: the cone of
 * half-angle outer around the axis against the triangle's bounding sphere (centre c,
 * radius r, at distance L from the light), which it misses when the angle between the
 * axis and c exceeds outer + asin(r / L). A margin of 1e-6 radians covers the rounding
 * of this test many times over; every other light kind lights every triangle. */
static int spot_may_light(const bbc_point_light *light, const bbc_scene *scene, uint32_t t) {
  if (light->model.kind != BBC_LIGHT_SPOT) return 1;
  bbc_vec3 p[3];
  for (int k = 0; k < 3; k++) p[k] = v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + k]);
  bbc_vec3 c = v3_scale(v3_add(p[0], v3_add(p[1], p[2])), 1.0 / 3.0);
  double r = fmax(v3_length(v3_sub(p[0], c)), fmax(v3_length(v3_sub(p[1], c)), v3_length(v3_sub(p[2], c))));
  bbc_vec3 w = v3_sub(c, light->position);
  double L = v3_length(w);
  if (!(L > 1.001 * r)) return 1; /* the light is (nearly) inside the sphere */
  double angle = acos(fmax(-1.0, fmin(1.0, v3_dot(w, light->model.direction) / L)));
  double outer = acos(fmax(-1.0, fmin(1.0, light->model.cos_outer)));
  return angle <= outer + asin(fmin(1.0, 1.001 * r / L)) + 1e-6;
}

/* Whether emitter model m can light some point of triangle t: a vertex of t strictly in
 * front of the emitter's plane (exact on the float data, orient3d), and the emitter not
 * entirely in t's plane (it would see t edge-on). */
static int area_may_light(const bbc_scene *scene, const bbc_light_model *m, uint32_t e,
                          uint32_t t) {
  const uint32_t et = scene->emitters[e];
  const float *q[3], *p[3];
  for (int k = 0; k < 3; k++) {
    q[k] = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)et + k];
    p[k] = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + k];
  }
  /* orient3d's sign against the front normal: the sign of the emitter's winding normal
   * dotted with the front one. */
  bbc_vec3 qv[3] = {v3_load(q[0]), v3_load(q[1]), v3_load(q[2])};
  double wind = v3_dot(v3_cross(v3_sub(qv[1], qv[0]), v3_sub(qv[2], qv[0])), m->emitter_normal);
  int front = 0;
  for (int k = 0; k < 3 && !front; k++) {
    int o = bbc__orient3d(q[0], q[1], q[2], p[k]);
    front = o != 0 && (o > 0) == (wind > 0);
  }
  if (!front) return 0;
  for (int k = 0; k < 3; k++)
    if (bbc__orient3d(p[0], p[1], p[2], q[k]) != 0) return 1;
  return 0;
}

/* Per-thread working memory of the tuple search: the arena of the beams, the BVH walk's
 * stack and results, and for second bounces the marks of the T2 found per prefix. */
typedef struct search_scratch {
  void *arena_memory;
  bbc_arena arena;
  uint32_t *found, *found2, *seen, *stack;
  bbc_ivec3 *reach;
  uint16_t *boxes;
  uint32_t stamp; /* one per (light, T1) prefix, for `seen` */
  /* found2[0, n2) and their reach are the second triangles of the prefix (light, T1)
   * when `listed`: a search that stopped inside that prefix carries on without finding
   * them again (when it carries on on this thread). */
  int listed;
  uint32_t listed_light, listed_t1, n2;
} search_scratch;

/* Where a search stands inside the prefixes: the next T1, and inside its prefix the
 * next tuple: stage 0 the single-scattering receivers, stage j > 0 the receivers of the
 * j-th second triangle found (counting from 1), and index the next receiver of that
 * stage's walk. */
typedef struct search_place {
  uint32_t t1, stage, index;
} search_place;

#define SEARCH_ARENA_BYTES ((size_t)4 << 20)
#define SEARCH_CHUNK 16

static bbc_result scratch_init(search_scratch *s, const bbc_scene *scene, int doubles) {
  memset(s, 0, sizeof *s);
  const size_t n = (size_t)scene->triangle_count + 1;
  s->arena_memory = malloc(SEARCH_ARENA_BYTES);
  s->found = malloc(n * sizeof *s->found);
  s->stack = malloc(2 * n * sizeof *s->stack);
  if (doubles) {
    s->found2 = malloc(n * sizeof *s->found2);
    s->seen = calloc(n, sizeof *s->seen);
    s->reach = malloc(n * sizeof *s->reach);
    s->boxes = malloc(n * sizeof *s->boxes);
  }
  if (!s->arena_memory || !s->found || !s->stack ||
      (doubles && (!s->found2 || !s->seen || !s->reach || !s->boxes)))
    return BBC_ERR_OUT_OF_MEMORY;
  bbc_arena_init(&s->arena, s->arena_memory, SEARCH_ARENA_BYTES);
  return BBC_OK;
}

static void scratch_free(search_scratch *s) {
  free(s->arena_memory);
  free(s->found);
  free(s->found2);
  free(s->seen);
  free(s->reach);
  free(s->boxes);
  free(s->stack);
}

/* What encloses the light beyond T1 (`first` its scattering, 1: refraction, met from
 * `side`): a light's own medium bounds nothing where media are found per triangle (its
 * mesh may be any of the medium's). */
static uint32_t first_enclosure(const bbc_scene *scene, const bbc_point_light *light, uint32_t t1,
                                int first, int side) {
  return first == 1 ? bbc__media_enclosure(scene, t1, side) : scene->media ? 0 : light->medium;
}

/* What encloses the light after T2 (`second` its scattering, `sides` as
 * second_refraction_possible says): a reflection keeps `enclosure`, a refraction decides
 * it from the side T2 is met from (of both, when they agree). */
static uint32_t second_enclosure(const bbc_scene *scene, uint32_t enclosure, uint32_t t2,
                                 int second, int sides) {
  if (second != 1) return enclosure;
  const uint32_t a = bbc__media_enclosure(scene, t2, 1), b = bbc__media_enclosure(scene, t2, -1);
  return sides == 1 ? a : sides == 2 ? b : a == b ? a : 0;
}

int bbc__tuple_landing_box(const bbc_scene *scene, const bbc_tuple *t, double lo[3], double hi[3]) {
  const uint32_t t1 = t->specular[0];
  const int first = scattering_of(scene, t1);
  if (first < 0) return 1;
  const bbc_point_light light = bbc__cache_light_point(scene, t->light);
  const bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t1]);
  const int side = bbc__media_side(scene, t1, bbc__light_source(light.position, &light.model, p0));
  uint32_t medium = light.medium;
  if (first == 1 && !bbc__media_refract(scene, light.medium, t1, side, &medium)) return 1;
  uint32_t enclosure = first_enclosure(scene, &light, t1, first, side);
  if (bbc_chain_length((bbc_chain)t->chain) == 2) {
    const uint32_t t2 = t->specular[1];
    const int second = scattering_of(scene, t2);
    if (second < 0) return 1;
    const int sides = second == 1 ? second_refraction_possible(scene, medium, t1, t2) : 0;
    enclosure = second_enclosure(scene, enclosure, t2, second, sides);
  }
  if (!encloses(scene, enclosure)) return 1;
  /* Inside the closed mesh the light lands only inside it (medium_reaches). */
  const bbc_mesh *mesh = &scene->meshes[enclosure - 1];
  double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  for (uint32_t k = mesh->first_triangle; k < mesh->first_triangle + mesh->triangle_count; k++) {
    double tlo[3], thi[3];
    bbc__triangle_box(scene, k, tlo, thi);
    for (int a = 0; a < 3; a++)
      box[a] = fmin(box[a], tlo[a]), box[3 + a] = fmax(box[3 + a], thi[a]);
  }
  int meets = 1;
  for (int a = 0; a < 3; a++) {
    lo[a] = fmax(lo[a], box[a]), hi[a] = fmin(hi[a], box[3 + a]);
    meets &= lo[a] <= hi[a];
  }
  return meets;
}

/* The tuples of the second triangles of a prefix (s->found2[0, s->n2) with their reach),
 * from the place *at on, as prefix_tuples says. `tuple` is the prefix's single
 * scattering tuple, `first` its scattering at T1 (1: refraction), medium the one
 * beyond T1 and enclosure what encloses it there (bbc__media_enclosure). */
static bbc_result second_tuples(const bbc_scene *scene, uint32_t chains, int beam_receivers,
                                const bvh *receivers, uint32_t medium, uint32_t enclosure,
                                const bbc_tuple *tuple, int first, search_place *at,
                                search_scratch *s, tuple_list *list, int *stopped) {
  const uint32_t after[2] = {1u << (first ? BBC_CHAIN_TR : BBC_CHAIN_RR),
                             1u << (first ? BBC_CHAIN_TT : BBC_CHAIN_RT)};
  for (uint32_t j = at->stage ? at->stage - 1 : 0; j < s->n2; j++) {
    const uint32_t start = j + 1 == at->stage ? at->index : 0;
    const uint32_t t1 = tuple->specular[0], t2 = s->found2[j];
    int second = scattering_of(scene, t2);
    if (second < 0 || !(chains & after[second])) continue;
    const int sides = second == 1 ? second_refraction_possible(scene, medium, t1, t2) : 0;
    if (second == 1 && !sides) continue;
    bbc_tuple pair = *tuple;
    pair.chain = (uint32_t)(first ? (second ? BBC_CHAIN_TT : BBC_CHAIN_TR)
                                  : (second ? BBC_CHAIN_RT : BBC_CHAIN_RR));
    pair.specular[1] = t2;
    bbc_tuple_geometry g2;
    bbc_result result = bbc_tuple_geometry_init(&g2, scene, &pair);
    if (result != BBC_OK) return result;
    bbc_ivec3 x2, d2;
    if (!second_beam(&g2, &s->reach[t2], &x2, &d2)) continue;
    const uint32_t last = second_enclosure(scene, enclosure, t2, second, sides);
    uint32_t n = bvh_beam(receivers, scene, &x2, &d2, s->stack, s->found);
    if (beam_receivers) n = beam_items(receivers, scene, last, s->found, n);
    for (uint32_t i = start; i < n; i++) {
      if (!item_reaches(receivers, scene, last, s->found[i])) continue;
      if (list->count == list->limit) {
        at->stage = j + 1;
        at->index = i;
        *stopped = 1;
        return BBC_OK;
      }
      pair.receiver = s->found[i];
      if (!tuple_push(list, &pair)) return BBC_ERR_OUT_OF_MEMORY;
    }
  }
  return BBC_OK;
}

/* The candidate tuples of the prefix (light l, T1 = at->t1) from the place *at, appended
 * to list in the order (T2, receiver), single scattering first. When the list reaches
 * its limit before the prefix ends, *stopped is 1 and *at the place of the next tuple,
 * from which a later call carries on (the stages are found again in the same order). */
static bbc_result prefix_tuples(const bbc_scene *scene, uint32_t chains, int beam_receivers,
                                const bvh *receivers, const bvh *casters,
                                const bbc__occluders *occluders, const bbc_point_light *light,
                                uint32_t l, search_place *at, search_scratch *s, tuple_list *list,
                                int *stopped) {
  bbc_result result = BBC_OK;
  const uint32_t t = at->t1;
  *stopped = 0;
  int first = scattering_of(scene, t);
  if (first < 0) return BBC_OK;
  if (l >= scene->point_light_count &&
      !area_may_light(scene, &light->model, l - scene->point_light_count, t))
    return BBC_OK;
  /* The medium beyond T1 (media_internal.h). */
  uint32_t medium = light->medium;
  const bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t]);
  const bbc_vec3 source = bbc__light_source(light->position, &light->model, p0);
  const int side = bbc__media_side(scene, t, source);
  if (first == 1 && !bbc__media_refract(scene, light->medium, t, side, &medium)) return BBC_OK;
  const uint32_t enclosure = first_enclosure(scene, light, t, first, side);
  /* A spot whose cone misses T1's bounding sphere lights none of it. */
  if (!spot_may_light(light, scene, t)) return BBC_OK;
  const bbc_chain single = first ? BBC_CHAIN_T : BBC_CHAIN_R;
  const uint32_t after[2] = {1u << (first ? BBC_CHAIN_TR : BBC_CHAIN_RR),
                             1u << (first ? BBC_CHAIN_TT : BBC_CHAIN_RT)};
  if (!(chains & ((1u << single) | after[0] | after[1]))) return BBC_OK;
  /* The beam does not depend on the receiver: use any as a stand-in (a beam's, which
   * names no triangle, with whole meshes in the walk). */
  const uint32_t stand_in = beam_receivers ? BBC_RECEIVER_BEAM : receivers->order[0];
  bbc_tuple tuple = {l, (uint32_t)single, {t, BBC_NO_TRIANGLE}, stand_in};
  bbc_tuple_geometry g;
  if ((result = bbc_tuple_geometry_init(&g, scene, &tuple)) != BBC_OK) return result;
  /* A light in T1's plane sees it edge-on: no light passes through. */
  bbc_vec3 ng = v3_cross(v3_sub(g.p[1], g.p[0]), v3_sub(g.p[2], g.p[0]));
  if (g.light_model.kind != BBC_LIGHT_AREA &&
      v3_dot(ng, bbc__light_d0(g.light, &g.light_model, g.p[0])) == 0)
    return BBC_OK;
  /* Tuples in the order (T2, receiver) with single scattering first (T2 = none). */
  if (at->stage == 0 && (chains & (1u << single))) {
    beam whole_beam;
    static const double whole[4] = {0, 1, 0, 1};
    bbc_arena_reset(&s->arena, 0);
    if ((result = beam_of(&s->arena, &g, whole, &whole_beam)) != BBC_OK) return result;
    uint32_t n = bvh_beam(receivers, scene, &whole_beam.x, &whole_beam.d, s->stack, s->found);
    if (beam_receivers) n = beam_items(receivers, scene, enclosure, s->found, n);
    for (uint32_t i = at->index; i < n; i++) {
      if (!item_reaches(receivers, scene, enclosure, s->found[i])) continue;
      if (list->count == list->limit) {
        at->index = i;
        *stopped = 1;
        return BBC_OK;
      }
      tuple.receiver = s->found[i];
      if (!tuple_push(list, &tuple)) return BBC_ERR_OUT_OF_MEMORY;
    }
  }
  if (!(chains & (after[0] | after[1])) || casters->node_count == 0) return BBC_OK;
  if (s->listed && s->listed_light == l && s->listed_t1 == t)
    return second_tuples(scene, chains, beam_receivers, receivers, medium, enclosure, &tuple, first,
                         at, s, list, stopped);
  s->listed = 0;
  /* T2 from the beams of the BEAM_SPLIT x BEAM_SPLIT s->boxes of T1's unit box that
   * meet the triangle (far tighter than T1's whole beam, whose box of u1 is twice
   * the triangle): the BVH walk with each box's interval beam finds candidates
   * (s->boxes[T2] marks the s->boxes whose walk s->found T2; `seen` the T2 s->found for this
   * prefix), then each box's rays are tested exactly against each of its candidates
   * (beam_hits). A T2 is kept when some box reaches it, and s->reach[T2] gathers the
   * d1 s->boxes of those that do: the only directions in which light from T1 arrives
   * at T2. */
  uint32_t n2 = 0;
  if (++s->stamp == 0) { /* wrapped: start the marks afresh */
    memset(s->seen, 0, ((size_t)scene->triangle_count + 1) * sizeof *s->seen);
    s->stamp = 1;
  }
  beam beams[BEAM_BOXES];
  int nb = 0;
  bbc_arena_reset(&s->arena, 0);
  for (int i = 0; i < BEAM_SPLIT && result == BBC_OK; i++) {
    for (int j = 0; i + j < BEAM_SPLIT && result == BBC_OK; j++, nb++) {
      const double box[4] = {(double)i / BEAM_SPLIT, (double)(i + 1) / BEAM_SPLIT,
                             (double)j / BEAM_SPLIT, (double)(j + 1) / BEAM_SPLIT};
      if ((result = beam_of(&s->arena, &g, box, &beams[nb])) != BBC_OK) break;
      uint32_t n = bvh_beam(casters, scene, &beams[nb].x, &beams[nb].d, s->stack, s->found);
      for (uint32_t k = 0; k < n; k++) {
        const uint32_t t2 = s->found[k];
        if (t2 == t) continue;
        if (s->seen[t2] != s->stamp) {
          s->seen[t2] = s->stamp;
          s->boxes[t2] = 0;
          s->found2[n2++] = t2;
        }
        s->boxes[t2] |= 1u << nb;
      }
    }
  }
  if (result != BBC_OK) return result;
  uint32_t kept = 0;
  for (uint32_t k = 0; k < n2 && result == BBC_OK; k++) {
    const uint32_t t2 = s->found2[k];
    const int sides = plane_sides(scene, t, t2);
    if (!sides) continue;
    triangle_planes planes;
    triangle_planes_of(scene, t2, &planes);
    int reached = 0;
    for (int bi = 0; bi < nb && result == BBC_OK; bi++) {
      if (!(s->boxes[t2] & (1u << bi))) continue;
      int hit = 0;
      if ((result = beam_hits(&s->arena, &beams[bi], &planes, sides, &hit)) != BBC_OK || !hit)
        continue;
      if (!reached) {
        s->reach[t2] = beams[bi].d;
      } else {
        s->reach[t2].x = bbc_interval_hull(s->reach[t2].x, beams[bi].d.x);
        s->reach[t2].y = bbc_interval_hull(s->reach[t2].y, beams[bi].d.y);
        s->reach[t2].z = bbc_interval_hull(s->reach[t2].z, beams[bi].d.z);
      }
      reached = 1;
    }
    /* A closed mesh between every point of T1 and every point of T2: no path. */
    if (reached && !bbc__occluders_block(occluders, t, t2)) s->found2[kept++] = t2;
  }
  if (result != BBC_OK) return result;
  qsort(s->found2, kept, sizeof *s->found2, compare_u32);
  s->n2 = kept;
  s->listed = 1;
  s->listed_light = l;
  s->listed_t1 = t;
  return second_tuples(scene, chains, beam_receivers, receivers, medium, enclosure, &tuple, first,
                       at, s, list, stopped);
}

/* Prefixes are searched in chunks of SEARCH_CHUNK T1, a window of chunks in parallel;
 * each chunk's tuples go to a list of its own, handed out in chunk order, so the order
 * does not depend on the threads. A window has between `threads` and WINDOW_MAX chunks,
 * and each chunk's list at most the window's share of the block budget: a chunk whose
 * tuples do not fit stops where its list is full (search_place) and carries on, alone,
 * once its list has been handed out, so however many tuples one prefix has, the search
 * never holds more than the budget. */
#define WINDOW_MAX 256
#define DEFAULT_BLOCK_BYTES ((size_t)16 << 20)

typedef struct search_chunk {
  tuple_list part;     /* its tuples not yet handed out */
  search_place at;     /* where its search stands; done when at.t1 == end */
  uint32_t begin, end; /* its T1 */
  bbc_result why;
} search_chunk;

struct bbc__tuple_search {
  const bbc_scene *scene;
  uint32_t chains, area_chains;
  int beam; /* beam receivers (beam_items) */
  int threads;
  bvh receivers, casters;
  bbc__occluders *occluders; /* two bounces only */
  search_scratch *scratch;
  search_chunk chunk[WINDOW_MAX];
  size_t chunks;             /* per light */
  uint32_t light, light_end; /* the light searched, and the end of the lights */
  bbc_point_light point;     /* the light as the search sees it */
  size_t next_chunk;         /* the first chunk of the light not yet searched */
  size_t window, target;     /* chunks per window; the most bytes of a block */
  size_t window_max;         /* the widest window: one tuple per chunk fits target */
  size_t head, used;         /* the chunk whose tuples are next, of the window's chunks */
  int handed;                /* the head's list was handed out by the last call */
  size_t peak;               /* the most bytes of lists held at once */
  uint64_t done, total;      /* prefixes */
  bbc_result failed;
};

static uint32_t light_chains(const bbc__tuple_search *s, uint32_t l) {
  return l < s->scene->point_light_count ? s->chains : s->area_chains;
}

/* The chain types the casters can form: a vertex of a class no caster has ends the
 * type, and its search would walk for nothing. */
static uint32_t formable_chains(const bbc_scene *scene) {
  int has[2] = {0, 0};
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    if (scene->meshes[m].triangle_count) {
      const int k = scattering_of(scene, scene->meshes[m].first_triangle);
      if (k >= 0) has[k] = 1;
    }
  uint32_t chains = 0;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    int ok = 1;
    for (int v = 0; v < bbc_chain_length((bbc_chain)c); v++)
      ok &= has[bbc_chain_refracts((bbc_chain)c, v)];
    if (ok) chains |= BBC_CHAIN_BIT(c);
  }
  return chains;
}

bbc_result bbc__tuple_search_create(bbc__tuple_search **out, const bbc_scene *scene,
                                    uint32_t chains, uint32_t area_chains, int beam, int threads,
                                    size_t block_bytes) {
  *out = NULL;
  bbc__tuple_search *s = calloc(1, sizeof *s);
  if (!s) return BBC_ERR_OUT_OF_MEMORY;
  s->scene = scene;
  const uint32_t formable = formable_chains(scene);
  s->chains = chains & formable;
  s->beam = beam != 0;
  s->area_chains = scene->emitter_count ? area_chains & formable : 0;
  s->threads = threads > 0 ? threads : omp_get_max_threads();
  s->target = block_bytes ? block_bytes : DEFAULT_BLOCK_BYTES;
  s->window = (size_t)s->threads < WINDOW_MAX ? (size_t)s->threads : WINDOW_MAX;
  s->window_max = s->target / sizeof(bbc_tuple);
  if (s->window_max > WINDOW_MAX) s->window_max = WINDOW_MAX;
  if (s->window_max < s->window) s->window_max = s->window;
  s->chunks = ((size_t)scene->triangle_count + SEARCH_CHUNK - 1) / SEARCH_CHUNK;
  s->light_end = scene->point_light_count + (s->area_chains ? scene->emitter_count : 0);
  for (uint32_t l = 0; l < s->light_end; l++)
    if (light_chains(s, l)) s->total += scene->triangle_count;
  const uint32_t doubles = (1u << BBC_CHAIN_RR) | (1u << BBC_CHAIN_RT) | (1u << BBC_CHAIN_TR) |
                           (1u << BBC_CHAIN_TT);
  const int two = ((s->chains | s->area_chains) & doubles) != 0;
  s->scratch = calloc((size_t)s->threads, sizeof *s->scratch);
  bbc_result r = s->scratch ? BBC_OK : BBC_ERR_OUT_OF_MEMORY;
  if (r == BBC_OK) r = bvh_init(&s->receivers, scene, BBC_ROLE_RECEIVER, s->beam);
  if (r == BBC_OK && two) r = bvh_init(&s->casters, scene, BBC_ROLE_CASTER, 0);
  if (r == BBC_OK && two) r = bbc__occluders_create(&s->occluders, scene);
  for (int i = 0; i < s->threads && r == BBC_OK; i++) r = scratch_init(&s->scratch[i], scene, two);
  if (r != BBC_OK) {
    bbc__tuple_search_free(s);
    return r;
  }
  /* No receiver: no tuple. Otherwise start before the first light. */
  s->light = s->receivers.node_count == 0 ? s->light_end : 0;
  if (s->light == s->light_end) s->done = s->total;
  s->next_chunk = s->chunks; /* the light's chunks are "done": the first call moves on */
  s->light = s->light == 0 ? UINT32_MAX : s->light;
  *out = s;
  return BBC_OK;
}

void bbc__tuple_search_free(bbc__tuple_search *s) {
  if (!s) return;
  bvh_free(&s->receivers);
  bvh_free(&s->casters);
  bbc__occluders_free(s->occluders);
  for (int i = 0; s->scratch && i < s->threads; i++) scratch_free(&s->scratch[i]);
  free(s->scratch);
  for (size_t c = 0; c < WINDOW_MAX; c++) free(s->chunk[c].part.items);
  free(s);
}

void bbc__tuple_search_progress(const bbc__tuple_search *s, uint64_t *done, uint64_t *total) {
  *done = s->done;
  *total = s->total;
}

size_t bbc__tuple_search_peak_bytes(const bbc__tuple_search *s) {
  return s->peak;
}

/* Searches chunk c from where it stands until it is done or its list is full. */
static bbc_result chunk_search(bbc__tuple_search *s, search_chunk *c, search_scratch *w) {
  const uint32_t chains = light_chains(s, s->light);
  for (; c->at.t1 < c->end; c->at.t1++, c->at.stage = c->at.index = 0) {
    int stopped = 0;
    bbc_result r = prefix_tuples(s->scene, chains, s->beam, &s->receivers, &s->casters,
                                 s->occluders, &s->point, s->light, &c->at, w, &c->part, &stopped);
    if (r != BBC_OK || stopped) return r;
  }
  return BBC_OK;
}

/* The bytes the window's lists hold now, for the peak. */
static void note_held(bbc__tuple_search *s) {
  size_t held = 0;
  for (size_t c = 0; c < s->used; c++) held += s->chunk[c].part.capacity * sizeof(bbc_tuple);
  if (held > s->peak) s->peak = held;
}

/* Searches the next window of the light's chunks in parallel. */
static bbc_result search_window(bbc__tuple_search *s) {
  const bbc_scene *scene = s->scene;
  const size_t first = s->next_chunk;
  const size_t n = s->chunks - first < s->window ? s->chunks - first : s->window;
  /* Each chunk's share of the budget, at least one tuple. */
  size_t limit = s->target / (n * sizeof(bbc_tuple));
  if (limit == 0) limit = 1;
  for (size_t c = 0; c < WINDOW_MAX; c++) {
    search_chunk *k = &s->chunk[c];
    /* A list larger than this window's share, or beyond the window, gives its memory
     * back. */
    if (k->part.capacity > limit || (c >= n && k->part.capacity)) {
      free(k->part.items);
      k->part.items = NULL;
      k->part.capacity = 0;
    }
    k->part.count = 0;
    k->part.limit = limit;
    if (c >= n) continue;
    const size_t begin = (first + c) * SEARCH_CHUNK;
    k->begin = (uint32_t)begin;
    k->end = begin + SEARCH_CHUNK < scene->triangle_count ? (uint32_t)(begin + SEARCH_CHUNK)
                                                          : scene->triangle_count;
    k->at = (search_place){k->begin, 0, 0};
    k->why = BBC_OK;
  }
  s->used = n;
  s->head = 0;
  s->handed = 0;
  int failed = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(s->threads) reduction(| : failed)
  for (size_t c = 0; c < n; c++) {
    search_chunk *k = &s->chunk[c];
    k->why = chunk_search(s, k, &s->scratch[omp_get_thread_num()]);
    if (k->why != BBC_OK) failed = 1;
  }
  /* The first failure in prefix order, as a serial search would meet it. */
  for (size_t c = 0; failed && c < n; c++)
    if (s->chunk[c].why != BBC_OK) return s->chunk[c].why;
  note_held(s);
  size_t bytes = 0;
  int full = 0;
  for (size_t c = 0; c < n; c++) {
    bytes += s->chunk[c].part.count * sizeof(bbc_tuple);
    full |= s->chunk[c].at.t1 < s->chunk[c].end;
  }
  /* The next window: half as wide when a chunk's tuples did not fit its share (so that
   * each has a larger one), twice as wide when the tuples were under a quarter of the
   * aim. */
  if (full && s->window > (size_t)s->threads)
    s->window = s->window / 2 > (size_t)s->threads ? s->window / 2 : (size_t)s->threads;
  else if (!full && 4 * bytes < s->target && s->window < s->window_max)
    s->window = 2 * s->window < s->window_max ? 2 * s->window : s->window_max;
  s->next_chunk = first + n;
  return BBC_OK;
}

bbc_result bbc__tuple_search_next(bbc__tuple_search *s, const bbc_tuple **tuples, size_t *count) {
  *tuples = NULL;
  *count = 0;
  if (s->failed != BBC_OK) return s->failed;
  bbc_result r = BBC_OK;
  if (s->handed) s->chunk[s->head].part.count = 0;
  s->handed = 0;
  for (;;) {
    while (s->head < s->used) {
      search_chunk *k = &s->chunk[s->head];
      if (k->part.count) {
        s->handed = 1;
        *tuples = k->part.items;
        *count = k->part.count;
        return BBC_OK;
      }
      if (k->at.t1 < k->end) {
        /* Its list was full: it carries on (the chunks after it are full or done). */
        if ((r = chunk_search(s, k, &s->scratch[0])) != BBC_OK) break;
        note_held(s);
        continue;
      }
      s->done += k->end - k->begin;
      s->head++;
    }
    if (r != BBC_OK) break;
    if (s->next_chunk >= s->chunks) {
      /* The next light with a chain type to search. */
      uint32_t l = s->light == UINT32_MAX ? 0 : s->light + 1;
      while (l < s->light_end && !light_chains(s, l)) l++;
      s->light = l;
      if (l >= s->light_end) {
        s->light = s->light_end;
        return BBC_OK;
      }
      /* An emitter stands as a light in air at its centroid for the medium rule (the
       * bounds orient T1 by it; bounds.h). */
      s->point = bbc__cache_light_point(s->scene, l);
      s->next_chunk = 0;
    }
    if ((r = search_window(s)) != BBC_OK) break;
  }
  s->failed = r;
  return r;
}

static bbc_result tuples_collect(const bbc_scene *scene, uint32_t chains, uint32_t area_chains,
                                 int beam, bbc_tuple **out, size_t *count) {
  *out = NULL;
  *count = 0;
  bbc__tuple_search *s = NULL;
  bbc_result r = bbc__tuple_search_create(&s, scene, chains, area_chains, beam, 0, 0);
  tuple_list list = {NULL, 0, 0, SIZE_MAX};
  while (r == BBC_OK) {
    const bbc_tuple *block;
    size_t n;
    if ((r = bbc__tuple_search_next(s, &block, &n)) != BBC_OK || n == 0) break;
    if (list.count + n > list.capacity) {
      size_t capacity = list.capacity ? list.capacity : 1024;
      while (capacity < list.count + n) capacity *= 2;
      bbc_tuple *items = realloc(list.items, capacity * sizeof *items);
      if (!items) {
        r = BBC_ERR_OUT_OF_MEMORY;
        break;
      }
      list.items = items;
      list.capacity = capacity;
    }
    memcpy(list.items + list.count, block, n * sizeof *block);
    list.count += n;
  }
  bbc__tuple_search_free(s);
  if (r != BBC_OK) {
    free(list.items);
    return r;
  }
  *out = list.items;
  *count = list.count;
  return BBC_OK;
}

bbc_result bbc_tuples_find(const bbc_scene *scene, uint32_t chains, bbc_tuple **out,
                           size_t *count) {
  return tuples_collect(scene, chains, 0, 0, out, count);
}

bbc_result bbc_tuples_find_beam(const bbc_scene *scene, uint32_t chains, uint32_t area_chains,
                                bbc_tuple **out, size_t *count) {
  return tuples_collect(scene, chains, area_chains, 1, out, count);
}

bbc_result bbc_tuples_find_area(const bbc_scene *scene, uint32_t chains, bbc_tuple **out,
                                size_t *count) {
  return tuples_collect(scene, 0, chains, 0, out, count);
}
