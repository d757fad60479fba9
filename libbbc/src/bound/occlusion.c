/* Occlusion between two specular vertices by a closed mesh (occlusion_internal.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/texture.h"
#include "occlusion_internal.h"
#include "orient_internal.h"
#include "scene_internal.h"
#include "vec_internal.h"

#define LEAF_SIZE 4
#define STACK_SIZE 128
/* The most closed meshes one ray's parity keeps count of; more, and nothing is proven. */
#define TALLY_SIZE 32
/* Relative tolerances: far above the rounding of the products they guard (about 1e-15
 * relative), so that a decision taken outside them is the exact one. */
#define REL_TOL 1e-10

typedef struct node {
  double lo[3], hi[3];
  uint32_t first, count; /* leaf: order[first, first + count) */
  uint32_t left, right;  /* inner node (count == 0) */
} node;

struct bbc__occluders {
  const bbc_scene *scene;
  node *nodes;
  uint32_t node_count;
  uint32_t *order;  /* the closed meshes' triangles */
  double (*key)[2]; /* build scratch: centroid coordinate, triangle */
  double margin;    /* 1e-9 of the scene's size: far above the rounding of coordinates */
};

int bbc__occlusion_control = 0;

static const float *corner(const bbc_scene *s, uint32_t t, int k) {
  return s->positions + 3 * (size_t)s->indices[3 * (size_t)t + k];
}

static int compare_key(const void *x, const void *y) {
  const double *a = x, *b = y;
  return a[0] < b[0] ? -1 : a[0] > b[0] ? 1 : a[1] < b[1] ? -1 : a[1] > b[1];
}

/* Builds the subtree of order[first, first + count); returns its node. */
static uint32_t build(bbc__occluders *o, uint32_t first, uint32_t count) {
  const bbc_scene *s = o->scene;
  const uint32_t id = o->node_count++;
  node *n = &o->nodes[id];
  double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int a = 0; a < 3; a++) n->lo[a] = INFINITY, n->hi[a] = -INFINITY;
  for (uint32_t i = first; i < first + count; i++) {
    double lo[3], hi[3];
    bbc__triangle_box(s, o->order[i], lo, hi);
    for (int a = 0; a < 3; a++) {
      n->lo[a] = fmin(n->lo[a], lo[a]), n->hi[a] = fmax(n->hi[a], hi[a]);
      clo[a] = fmin(clo[a], lo[a] + hi[a]), chi[a] = fmax(chi[a], lo[a] + hi[a]);
    }
  }
  if (count <= LEAF_SIZE) {
    n->first = first, n->count = count;
    return id;
  }
  int axis = 0;
  for (int a = 1; a < 3; a++)
    if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
  for (uint32_t i = 0; i < count; i++) {
    double lo[3], hi[3];
    bbc__triangle_box(s, o->order[first + i], lo, hi);
    o->key[i][0] = lo[axis] + hi[axis];
    o->key[i][1] = o->order[first + i];
  }
  qsort(o->key, count, sizeof *o->key, compare_key);
  for (uint32_t i = 0; i < count; i++) o->order[first + i] = (uint32_t)o->key[i][1];
  const uint32_t half = count / 2;
  n->count = 0;
  const uint32_t left = build(o, first, half);
  const uint32_t right = build(o, first + half, count - half);
  o->nodes[id].left = left, o->nodes[id].right = right;
  return id;
}

/* The closed meshes a ray crosses, with the number of crossings of each, and whether a
 * crossing was too close to an edge (or the ray's origin) to count. */
typedef struct tally {
  uint32_t mesh[TALLY_SIZE], hits[TALLY_SIZE];
  uint8_t unsure[TALLY_SIZE];
  int count, overflow;
} tally;

static void tally_add(tally *t, uint32_t mesh, int unsure) {
  int i = 0;
  while (i < t->count && t->mesh[i] != mesh) i++;
  if (i == t->count) {
    if (t->count == TALLY_SIZE) {
      t->overflow = 1;
      return;
    }
    t->mesh[i] = mesh, t->hits[i] = 0, t->unsure[i] = 0;
    t->count++;
  }
  if (unsure)
    t->unsure[i] = 1;
  else
    t->hits[i]++;
}

/* How ray o + s d, s > 0, meets triangle p: 1 it crosses its interior, 0 it misses,
 * -1 too close to an edge or to the plane at o to tell. The line passes through the
 * interior when the three edge functions (Plucker) share a strict sign; the crossing is
 * ahead when n . (p0 - o) has the sign of n . d. */
static int ray_meets(bbc_vec3 o, bbc_vec3 d, const bbc_vec3 p[3]) {
  bbc_vec3 r[3];
  for (int k = 0; k < 3; k++) r[k] = v3_sub(p[k], o);
  const double ld = v3_length(d);
  int pos = 0, neg = 0, near = 0;
  for (int k = 0; k < 3; k++) {
    const bbc_vec3 a = r[k], b = r[(k + 1) % 3];
    const double e = v3_dot(d, v3_cross(a, b));
    const double tol = REL_TOL * ld * v3_length(a) * v3_length(b);
    if (e > tol)
      pos = 1;
    else if (e < -tol)
      neg = 1;
    else
      near = 1;
  }
  if (pos && neg) return 0;
  const bbc_vec3 n = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
  const double ln = v3_length(n);
  const double s0 = v3_dot(n, r[0]), sd = v3_dot(n, d);
  const double tol0 = REL_TOL * ln * v3_length(r[0]), told = REL_TOL * ln * ld;
  const int ahead_sure = fabs(s0) > tol0 && fabs(sd) > told;
  if (ahead_sure && (s0 > 0) != (sd > 0)) return 0; /* the plane is behind */
  if (near || !ahead_sure) return -1;
  return 1;
}

static int ray_box(const node *n, bbc_vec3 o, bbc_vec3 d, double margin) {
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  double t0 = 0, t1 = INFINITY;
  for (int a = 0; a < 3; a++) {
    const double lo = n->lo[a] - margin, hi = n->hi[a] + margin;
    if (dd[a] == 0) {
      if (oo[a] < lo || oo[a] > hi) return 0;
      continue;
    }
    double u = (lo - oo[a]) / dd[a], v = (hi - oo[a]) / dd[a];
    if (u > v) {
      double w = u;
      u = v, v = w;
    }
    /* Widened for the rounding of the divisions. */
    u -= 1e-12 * fabs(u), v += 1e-12 * fabs(v);
    t0 = fmax(t0, u), t1 = fmin(t1, v);
    if (t0 > t1) return 0;
  }
  return 1;
}

static bbc_vec3 vertex(const bbc_scene *s, uint32_t t, int k) {
  return v3_load(corner(s, t, k));
}

/* The crossings of ray o + s d (s > 0) with every closed mesh, triangle `skip` left out. */
static void ray_tally(const bbc__occluders *o, bbc_vec3 org, bbc_vec3 d, uint32_t skip, tally *t) {
  const bbc_scene *s = o->scene;
  memset(t, 0, sizeof *t);
  uint32_t stack[STACK_SIZE];
  int top = 0;
  stack[top++] = 0;
  while (top > 0 && !t->overflow) {
    const node *n = &o->nodes[stack[--top]];
    if (!ray_box(n, org, d, o->margin)) continue;
    if (n->count == 0) {
      if (top + 2 > STACK_SIZE) {
        t->overflow = 1;
        break;
      }
      stack[top++] = n->left, stack[top++] = n->right;
      continue;
    }
    for (uint32_t i = n->first; i < n->first + n->count; i++) {
      const uint32_t tri = o->order[i];
      if (tri == skip) continue;
      const bbc_vec3 p[3] = {vertex(s, tri, 0), vertex(s, tri, 1), vertex(s, tri, 2)};
      const int m = ray_meets(org, d, p);
      if (m != 0) tally_add(t, s->triangle_mesh[tri], m < 0);
    }
  }
}

/* Whether triangle p may meet the box lo..hi (separating axes: the box's, the
 * triangle's normal, and the nine products of their edges; each test widened by a
 * tolerance, so that 0 is certain). */
static int triangle_may_meet_box(const bbc_vec3 p[3], const double lo[3], const double hi[3]) {
  const bbc_vec3 c = v3(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]));
  const double h[3] = {0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1]), 0.5 * (hi[2] - lo[2])};
  bbc_vec3 v[3];
  for (int k = 0; k < 3; k++) v[k] = v3_sub(p[k], c);
  const bbc_vec3 e[3] = {v3_sub(v[1], v[0]), v3_sub(v[2], v[1]), v3_sub(v[0], v[2])};
  const double size =
      fmax(v3_max_abs(v[0]), fmax(v3_max_abs(v[1]), v3_max_abs(v[2]))) + h[0] + h[1] + h[2];
  bbc_vec3 axes[13];
  int n = 0;
  axes[n++] = v3(1, 0, 0), axes[n++] = v3(0, 1, 0), axes[n++] = v3(0, 0, 1);
  axes[n++] = v3_cross(e[0], e[1]);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) axes[n++] = v3_cross(e[i], axes[j]);
  for (int i = 0; i < n; i++) {
    const bbc_vec3 L = axes[i];
    const double a = v3_dot(v[0], L), b = v3_dot(v[1], L), q = v3_dot(v[2], L);
    const double r = h[0] * fabs(L.x) + h[1] * fabs(L.y) + h[2] * fabs(L.z);
    const double tol = REL_TOL * v3_length(L) * size;
    if (fmin(a, fmin(b, q)) > r + tol || fmax(a, fmax(b, q)) < -r - tol) return 0;
  }
  return 1;
}

/* Whether some triangle of mesh m (of any mesh: UINT32_MAX), other than `skip`, whose box
 * meets lo..hi passes `test`; the walk stops at the first. */
static int mesh_box_any(const bbc__occluders *o, uint32_t m, uint32_t skip, const double lo[3],
                        const double hi[3],
                        int (*test)(const bbc__occluders *, uint32_t, const void *),
                        const void *arg) {
  const bbc_scene *s = o->scene;
  uint32_t stack[STACK_SIZE];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const node *n = &o->nodes[stack[--top]];
    int meets = 1;
    for (int a = 0; a < 3; a++) meets &= n->lo[a] <= hi[a] && n->hi[a] >= lo[a];
    if (!meets) continue;
    if (n->count == 0) {
      if (top + 2 > STACK_SIZE) return 1; /* cannot tell: as if one did */
      stack[top++] = n->left, stack[top++] = n->right;
      continue;
    }
    for (uint32_t i = n->first; i < n->first + n->count; i++) {
      const uint32_t tri = o->order[i];
      if (tri == skip || (m != UINT32_MAX && s->triangle_mesh[tri] != m)) continue;
      double tlo[3], thi[3];
      bbc__triangle_box(s, tri, tlo, thi);
      int overlap = 1;
      for (int a = 0; a < 3; a++) overlap &= tlo[a] <= hi[a] && thi[a] >= lo[a];
      if (overlap && test(o, tri, arg)) return 1;
    }
  }
  return 0;
}

static int meets_box(const bbc__occluders *o, uint32_t tri, const void *arg) {
  const double *box = arg;
  const bbc_vec3 p[3] = {vertex(o->scene, tri, 0), vertex(o->scene, tri, 1),
                         vertex(o->scene, tri, 2)};
  return triangle_may_meet_box(p, box, box + 3);
}

/* Whether the vertices of triangle u that are not vertices of t lie strictly on one side
 * of t's plane (exact); 0 when u has no such vertex. */
static int strictly_aside(const bbc_scene *s, uint32_t u, uint32_t t) {
  int sign = 0, any = 0;
  for (int k = 0; k < 3; k++) {
    const float *q = corner(s, u, k);
    int shared = 0;
    for (int j = 0; j < 3; j++) shared |= memcmp(q, corner(s, t, j), 3 * sizeof(float)) == 0;
    if (shared) continue;
    const int o = bbc__orient3d(corner(s, t, 0), corner(s, t, 1), corner(s, t, 2), q);
    if (o == 0 || (any && o != sign)) return 0;
    sign = o, any = 1;
  }
  return any;
}

/* The side of x from the line through p and q in the projection along axis k (exact:
 * orient3d with a fourth point s that differs from p by one ulp along k alone, so that
 * s - p is exactly along k): 0 when x is on the line, or the projection degenerate. */
static int side_2d(const float p[3], const float q[3], const float x[3], int k) {
  float s[3] = {p[0], p[1], p[2]};
  s[k] = nextafterf(p[k], INFINITY);
  return bbc__orient3d(p, q, s, x);
}

/* Whether coplanar triangles u and t have disjoint interiors, exactly: some edge's line
 * has the other triangle's vertices on it or on the side away from its own third
 * vertex (a separating line, which for two triangles lies along an edge). */
static int coplanar_disjoint(const bbc_scene *s, uint32_t u, uint32_t t) {
  for (int k = 0; k < 3; k++) {
    for (int w = 0; w < 2; w++) {
      const uint32_t x = w ? t : u, y = w ? u : t;
      for (int e = 0; e < 3; e++) {
        const float *p = corner(s, x, e), *q = corner(s, x, (e + 1) % 3);
        const int own = side_2d(p, q, corner(s, x, (e + 2) % 3), k);
        if (own == 0) break; /* this projection flattens the triangle: the next axis */
        int separates = 1;
        for (int j = 0; j < 3 && separates; j++)
          separates = side_2d(p, q, corner(s, y, j), k) != own;
        if (separates) return 1;
      }
    }
  }
  return 0;
}

/* Whether triangle u meets the plane of triangle t in one point at most: one vertex on
 * it, the other two strictly on one side (exact). */
static int touches_at_a_point(const bbc_scene *s, uint32_t u, uint32_t t) {
  int on = 0, sign = 0;
  for (int k = 0; k < 3; k++) {
    const int o = bbc__orient3d(corner(s, t, 0), corner(s, t, 1), corner(s, t, 2), corner(s, u, k));
    if (o == 0)
      on++;
    else if (sign && o != sign)
      return 0;
    else
      sign = o;
  }
  return on <= 1;
}

/* Whether the segment z0 z1, in the plane of triangle t, misses t's interior (exact): a
 * line separates them, along an edge of t (both ends on it or beyond) or along the
 * segment (t's vertices on one side of it, not all on it). */
static int segment_misses(const bbc_scene *s, uint32_t t, const float *z0, const float *z1) {
  for (int k = 0; k < 3; k++) {
    int flat = 0;
    for (int e = 0; e < 3 && !flat; e++) {
      const float *p = corner(s, t, e), *q = corner(s, t, (e + 1) % 3);
      const int own = side_2d(p, q, corner(s, t, (e + 2) % 3), k);
      if (own == 0)
        flat = 1; /* this projection flattens t: the next axis */
      else if (side_2d(p, q, z0, k) != own && side_2d(p, q, z1, k) != own)
        return 1;
    }
    if (flat) continue;
    int pos = 0, neg = 0;
    for (int j = 0; j < 3; j++) {
      const int o = side_2d(z0, z1, corner(s, t, j), k);
      pos |= o > 0, neg |= o < 0;
    }
    return pos != neg;
  }
  return 0;
}

/* Whether triangle u may pass through the interior of triangle *arg along more than a
 * point: not when one lies strictly aside the other's plane (leaving out shared
 * vertices, where they touch on the border only) or meets it in one point, nor when
 * they are coplanar and apart in the plane, nor when u meets t's plane in an edge of u
 * that misses t's interior. A single point of contact leaves the side of *arg one
 * region. */
static int may_cross(const bbc__occluders *o, uint32_t u, const void *arg) {
  const uint32_t t = *(const uint32_t *)arg;
  const bbc_scene *s = o->scene;
  if (strictly_aside(s, u, t) || strictly_aside(s, t, u) || touches_at_a_point(s, u, t) ||
      touches_at_a_point(s, t, u))
    return 0;
  int on[3], count = 0, sign = 0, both = 0;
  for (int k = 0; k < 3; k++) {
    const int r = bbc__orient3d(corner(s, t, 0), corner(s, t, 1), corner(s, t, 2), corner(s, u, k));
    if (r == 0)
      on[count++] = k;
    else if (sign && r != sign)
      both = 1;
    else
      sign = r;
  }
  if (count == 3) return !coplanar_disjoint(s, u, t);
  if (count == 2 && !both) return !segment_misses(s, t, corner(s, u, on[0]), corner(s, u, on[1]));
  return 1;
}

static int closed_dielectric(const bbc_scene *scene, const bbc_mesh *mesh) {
  return mesh->closed && scene->materials[mesh->material].type == BBC_MATERIAL_DIELECTRIC;
}

/* Fills o->order with the triangles of the meshes `use` marks and builds the BVH. */
static bbc_result build_over(bbc__occluders *o, const uint8_t *use) {
  const bbc_scene *scene = o->scene;
  size_t n = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    if (use[m]) n += scene->meshes[m].triangle_count;
  free(o->order);
  free(o->nodes);
  o->order = malloc((n ? n : 1) * sizeof *o->order);
  o->nodes = malloc((n ? 2 * n : 1) * sizeof *o->nodes);
  o->key = malloc((n ? n : 1) * sizeof *o->key);
  o->node_count = 0;
  if (!o->order || !o->nodes || !o->key) return BBC_ERR_OUT_OF_MEMORY;
  size_t k = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    for (uint32_t t = 0; use[m] && t < scene->meshes[m].triangle_count; t++)
      o->order[k++] = scene->meshes[m].first_triangle + t;
  if (n) build(o, 0, (uint32_t)n);
  free(o->key);
  o->key = NULL;
  return BBC_OK;
}

/* Whether triangle u, of another mesh than *arg's, may meet triangle t (neither lies
 * strictly on one side of the other's plane). */
static int other_mesh_meets(const bbc__occluders *o, uint32_t u, const void *arg) {
  const uint32_t t = *(const uint32_t *)arg;
  const bbc_scene *s = o->scene;
  return s->triangle_mesh[u] != s->triangle_mesh[t] && !strictly_aside(s, u, t) &&
         !strictly_aside(s, t, u);
}

bbc_result bbc__occluders_create(bbc__occluders **out, const bbc_scene *scene) {
  *out = NULL;
  int any = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    any |= closed_dielectric(scene, &scene->meshes[m]);
  if (!any) return BBC_OK;
  bbc__occluders *o = calloc(1, sizeof *o);
  uint8_t *use = calloc(scene->mesh_count, 1);
  bbc_result r = o && use ? BBC_OK : BBC_ERR_OUT_OF_MEMORY;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < scene->vertex_count; v++)
    for (int a = 0; a < 3; a++) {
      lo[a] = fmin(lo[a], scene->positions[3 * v + a]);
      hi[a] = fmax(hi[a], scene->positions[3 * v + a]);
    }
  double size = 0;
  for (int a = 0; a < 3; a++)
    size = fmax(size, fmax(hi[a] - lo[a], fmax(fabs(lo[a]), fabs(hi[a]))));
  if (r == BBC_OK) {
    o->scene = scene;
    o->margin = 1e-9 * size;
    /* Every closed dielectric first, to find those that meet another one. */
    for (uint32_t m = 0; m < scene->mesh_count; m++)
      use[m] = closed_dielectric(scene, &scene->meshes[m]);
    r = build_over(o, use);
  }
  /* An occluder's every crossing must be an interface, as the renderer's rays see it: a
   * mesh without cut-outs, with two media on every triangle, that meets no other closed
   * dielectric (a liquid reaching into its glass makes surfaces the path tracer goes
   * through: docs/materials.md, "Media"). */
  uint8_t *occluder = r == BBC_OK ? calloc(scene->mesh_count, 1) : NULL;
  if (r == BBC_OK && !occluder) r = BBC_ERR_OUT_OF_MEMORY;
  for (uint32_t m = 0; r == BBC_OK && m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (!use[m] || bbc_material_partial(scene, &scene->materials[mesh->material])) continue;
    int ok = 1;
    for (uint32_t t = mesh->first_triangle; ok && t < mesh->first_triangle + mesh->triangle_count;
         t++) {
      if (scene->media && scene->media[2 * (size_t)t] == scene->media[2 * (size_t)t + 1]) ok = 0;
      double tlo[3], thi[3];
      bbc__triangle_box(scene, t, tlo, thi);
      if (ok && mesh_box_any(o, UINT32_MAX, UINT32_MAX, tlo, thi, other_mesh_meets, &t)) ok = 0;
    }
    occluder[m] = (uint8_t)ok;
  }
  int kept = 0;
  for (uint32_t m = 0; r == BBC_OK && m < scene->mesh_count; m++) kept |= occluder[m];
  if (r == BBC_OK && kept) r = build_over(o, occluder);
  free(use);
  free(occluder);
  if (r != BBC_OK || !kept) {
    bbc__occluders_free(o);
    return r;
  }
  *out = o;
  return BBC_OK;
}

void bbc__occluders_free(bbc__occluders *o) {
  if (!o) return;
  free(o->order);
  free(o->nodes);
  free(o->key);
  free(o);
}

/* Whether every segment from a to b crosses a closed mesh, proven on the plane
 * x_axis = c between them, given the parities just off a on b's side (at_a). */
/* Whether no triangle of mesh `mesh` passes through triangle a, asked once per call of
 * bbc__occluders_block whatever the planes tried (it depends on a and the mesh only). */
typedef struct side_check {
  uint32_t mesh; /* UINT32_MAX: not asked yet */
  int clear;
} side_check;

static int blocked_at(const bbc__occluders *o, uint32_t a, uint32_t b, int axis, double c,
                      const tally *at_a, const double alo[3], const double ahi[3],
                      side_check *asked) {
  const bbc_scene *s = o->scene;
  /* R: the box of the nine crossings, widened by the margin. */
  const bbc_vec3 pa[3] = {vertex(s, a, 0), vertex(s, a, 1), vertex(s, a, 2)};
  const bbc_vec3 pb[3] = {vertex(s, b, 0), vertex(s, b, 1), vertex(s, b, 2)};
  double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      const double *x = &pa[i].x, *y = &pb[j].x;
      const double t = (c - x[axis]) / (y[axis] - x[axis]);
      for (int k = 0; k < 3; k++) {
        const double v = k == axis ? c : x[k] + t * (y[k] - x[k]);
        box[k] = fmin(box[k], v), box[3 + k] = fmax(box[3 + k], v);
      }
    }
  for (int k = 0; k < 3; k++) box[k] -= o->margin, box[3 + k] += o->margin;
  /* R's parities, at its centre along a fixed oblique direction. */
  const bbc_vec3 q = v3(0.5 * (box[0] + box[3]), 0.5 * (box[1] + box[4]), 0.5 * (box[2] + box[5]));
  tally at_r;
  ray_tally(o, q, v3(0.5773, 0.5779, 0.5768), UINT32_MAX, &at_r);
  if (at_r.overflow) return 0;
  for (int pass = 0; pass < 2; pass++) {
    const tally *t = pass ? at_a : &at_r, *other = pass ? &at_r : at_a;
    for (int i = 0; i < t->count; i++) {
      const uint32_t m = t->mesh[i];
      int j = 0;
      while (j < other->count && other->mesh[j] != m) j++;
      if (pass && j < other->count) continue; /* seen in the first pass */
      const uint32_t hits_other = j < other->count ? other->hits[j] : 0;
      if (t->unsure[i] || (j < other->count && other->unsure[j])) continue;
      if (((t->hits[i] + hits_other) & 1) == 0) continue; /* one parity */
      /* R meets none of m's triangles, and none of them passes through A. */
      if (bbc__occlusion_control != 1 &&
          mesh_box_any(o, m, UINT32_MAX, box, box + 3, meets_box, box))
        continue;
      if (asked->mesh != m) {
        double lo[3], hi[3];
        for (int k = 0; k < 3; k++) lo[k] = alo[k] - o->margin, hi[k] = ahi[k] + o->margin;
        asked->mesh = m;
        asked->clear = !mesh_box_any(o, m, a, lo, hi, may_cross, &a);
      }
      if (asked->clear) return 1;
    }
  }
  return 0;
}

int bbc__occluders_block(const bbc__occluders *o, uint32_t a, uint32_t b) {
  if (!o || bbc__occlusion_control == 2) return 0;
  const bbc_scene *s = o->scene;
  /* B strictly on one side of A's plane (exact): the segments leave A to that side. */
  int side = 0;
  for (int k = 0; k < 3; k++) {
    const int r = bbc__orient3d(corner(s, a, 0), corner(s, a, 1), corner(s, a, 2), corner(s, b, k));
    if (r == 0 || (side && r != side)) return 0;
    side = r;
  }
  /* The axis of the widest gap between them. */
  double alo[3], ahi[3], blo[3], bhi[3];
  bbc__triangle_box(s, a, alo, ahi);
  bbc__triangle_box(s, b, blo, bhi);
  int axis = -1;
  double gap = 0, from = 0, step = 0; /* the planes are x_axis = from + f step, f in (0, 1) */
  for (int k = 0; k < 3; k++) {
    const double g1 = blo[k] - ahi[k], g2 = alo[k] - bhi[k];
    if (g1 > gap) gap = g1, axis = k, from = ahi[k], step = g1;
    if (g2 > gap) gap = g2, axis = k, from = alo[k], step = -g2;
  }
  if (axis < 0) return 0;
  /* The parities just off A's centroid on B's side, along A's normal. */
  const bbc_vec3 pa[3] = {vertex(s, a, 0), vertex(s, a, 1), vertex(s, a, 2)};
  const bbc_vec3 normal = v3_cross(v3_sub(pa[1], pa[0]), v3_sub(pa[2], pa[0]));
  const bbc_vec3 centroid = v3_scale(v3_add(pa[0], v3_add(pa[1], pa[2])), 1.0 / 3.0);
  tally at_a;
  ray_tally(o, centroid, v3_scale(normal, side > 0 ? 1.0 : -1.0), a, &at_a);
  if (at_a.overflow) return 0;
  /* Planes across the gap: its middle, then a quarter from either side (where the middle
   * one's R meets the mesh, a vase's neck, another may not). */
  static const double at[3] = {0.5, 0.25, 0.75};
  side_check asked = {UINT32_MAX, 0};
  for (int i = 0; i < 3; i++)
    if (blocked_at(o, a, b, axis, from + at[i] * step, &at_a, alo, ahi, &asked)) return 1;
  return 0;
}
