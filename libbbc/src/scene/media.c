/* Media of dielectric meshes and the medium rule (media_internal.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/accel.h"
#include "bbc/texture.h"
#include "media_internal.h"
#include "vec_internal.h"

typedef struct edge {
  float a[3], b[3]; /* endpoints, ordered */
} edge;

static int compare_edge(const void *x, const void *y) {
  return memcmp(x, y, sizeof(edge));
}

/* 1 when every edge of the mesh (by vertex positions) is shared by exactly two of its
 * triangles; -1 when out of memory. */
static int mesh_closed(const bbc_scene *scene, const bbc_mesh *m) {
  size_t n = 3 * (size_t)m->triangle_count;
  if (m->triangle_count < 4) return 0;
  edge *e = malloc(n * sizeof *e);
  if (!e) return -1;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    for (int k = 0; k < 3; k++) {
      const float *p = scene->positions + 3 * (size_t)idx[k];
      const float *q = scene->positions + 3 * (size_t)idx[(k + 1) % 3];
      edge *x = &e[3 * (size_t)t + k];
      memset(x, 0, sizeof *x);
      int swap = memcmp(p, q, 3 * sizeof(float)) > 0;
      memcpy(x->a, swap ? q : p, 3 * sizeof(float));
      memcpy(x->b, swap ? p : q, 3 * sizeof(float));
    }
  }
  qsort(e, n, sizeof *e, compare_edge);
  int closed = 1;
  for (size_t i = 0; i < n && closed;) {
    size_t j = i;
    while (j < n && compare_edge(&e[i], &e[j]) == 0) j++;
    if (j - i != 2) closed = 0;
    i = j;
  }
  free(e);
  return closed;
}

/* +1 when the winding's normals point out of the closed mesh, -1 when in. */
static int winding_outward(const bbc_scene *scene, const bbc_mesh *m) {
  double volume = 0;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    bbc_vec3 p[3];
    for (int k = 0; k < 3; k++) p[k] = v3_load(scene->positions + 3 * (size_t)idx[k]);
    volume += v3_dot(p[0], v3_cross(p[1], p[2]));
  }
  return volume >= 0 ? 1 : -1;
}

/* Whether x lies inside the closed mesh: the parity of the crossings of a ray. */
static int point_inside(const bbc_scene *scene, const bbc_mesh *m, bbc_vec3 x) {
  const bbc_vec3 d = v3_normalize(v3(0.5773, 0.5779, 0.5768));
  int crossings = 0;
  for (uint32_t t = 0; t < m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * ((size_t)m->first_triangle + t);
    bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)idx[0]);
    bbc_vec3 e1 = v3_sub(v3_load(scene->positions + 3 * (size_t)idx[1]), p0);
    bbc_vec3 e2 = v3_sub(v3_load(scene->positions + 3 * (size_t)idx[2]), p0);
    bbc_vec3 pv = v3_cross(d, e2);
    double det = v3_dot(e1, pv);
    if (det == 0) continue;
    bbc_vec3 w = v3_sub(x, p0);
    double u = v3_dot(w, pv) / det;
    bbc_vec3 qv = v3_cross(w, e1);
    double v = v3_dot(d, qv) / det, h = v3_dot(e2, qv) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && h > 0) crossings++;
  }
  return crossings & 1;
}

static int is_dielectric(const bbc_scene *scene, uint32_t t) {
  return scene->materials[scene->meshes[scene->triangle_mesh[t]].material].type ==
         BBC_MATERIAL_DIELECTRIC;
}

static bbc_vec3 corner(const bbc_scene *scene, uint32_t t, int k) {
  return v3_load(scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + k]);
}

/* The winding normal of dielectric triangle t turned to its front (not normalised). */
static bbc_vec3 front_normal(const bbc_scene *scene, uint32_t t) {
  const bbc_mesh *m = &scene->meshes[scene->triangle_mesh[t]];
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  bbc_vec3 p0 = corner(scene, t, 0);
  bbc_vec3 ng = v3_cross(v3_sub(corner(scene, t, 1), p0), v3_sub(corner(scene, t, 2), p0));
  double front = m->outward;
  if (!m->closed) {
    bbc_vec3 nsum = v3(0, 0, 0);
    for (int k = 0; k < 3; k++) nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[k]));
    front = v3_dot(ng, nsum) >= 0 ? 1 : -1;
  }
  return v3_scale(ng, front);
}

/* Whether most triangles of mesh m have vertex normals on the side of their winding
 * normals. */
static int normals_follow_winding(const bbc_scene *scene, const bbc_mesh *m) {
  long agree = 0;
  for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++) {
    const uint32_t *idx = scene->indices + 3 * (size_t)t;
    bbc_vec3 p0 = corner(scene, t, 0);
    bbc_vec3 ng = v3_cross(v3_sub(corner(scene, t, 1), p0), v3_sub(corner(scene, t, 2), p0));
    bbc_vec3 nsum = v3(0, 0, 0);
    for (int k = 0; k < 3; k++) nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[k]));
    agree += v3_dot(ng, nsum) >= 0 ? 1 : -1;
  }
  return agree >= 0;
}

static void mesh_box(const bbc_scene *scene, const bbc_mesh *m, bbc_vec3 *lo, bbc_vec3 *hi) {
  *lo = v3(INFINITY, INFINITY, INFINITY);
  *hi = v3(-INFINITY, -INFINITY, -INFINITY);
  for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++)
    for (int k = 0; k < 3; k++) {
      bbc_vec3 p = corner(scene, t, k);
      *lo = v3(fmin(lo->x, p.x), fmin(lo->y, p.y), fmin(lo->z, p.z));
      *hi = v3(fmax(hi->x, p.x), fmax(hi->y, p.y), fmax(hi->z, p.z));
    }
}

/* The first dielectric triangle other than `self` along o + s d, s > tmin, with the side
 * of it o lies on in *side; BBC_NO_TRIANGLE (UINT32_MAX) when none. Other surfaces are
 * passed through: only dielectrics bound media. */
static uint32_t probe(const bbc_scene *scene, const bbc_accel *accel, uint32_t self, bbc_vec3 o,
                      bbc_vec3 d, double tmin, int *side) {
  for (int k = 0; k < 1024; k++) {
    bbc_hit hit;
    if (!bbc_accel_intersect(accel, o, d, tmin, INFINITY, &hit)) return UINT32_MAX;
    if (hit.triangle != self && is_dielectric(scene, hit.triangle)) {
      *side = bbc__media_side(scene, hit.triangle, o);
      if (*side) return hit.triangle;
    }
    tmin = hit.t + fmax(tmin, 1e-7 * hit.t);
  }
  return UINT32_MAX;
}

static uint32_t find_root(uint32_t *parent, uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

static void join(uint32_t *parent, uint32_t a, uint32_t b) {
  uint32_t ra = find_root(parent, a), rb = find_root(parent, b);
  if (ra < rb)
    parent[rb] = ra;
  else
    parent[ra] = rb;
}

typedef struct mesh_edge {
  edge e;
  uint32_t mesh;
} mesh_edge;

static int compare_mesh_edge(const void *x, const void *y) {
  return memcmp(x, y, sizeof(edge));
}

/* Joins dielectric meshes of one material that share an edge (by vertex positions): the
 * pieces of one surface held in several primitives. 0 when out of memory. */
static int join_neighbours(const bbc_scene *scene, uint32_t *parent) {
  size_t n = 0;
  for (uint32_t t = 0; t < scene->triangle_count; t++) n += 3 * (size_t)is_dielectric(scene, t);
  mesh_edge *e = malloc((n ? n : 1) * sizeof *e);
  if (!e) return 0;
  size_t k = 0;
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    if (!is_dielectric(scene, t)) continue;
    const uint32_t *idx = scene->indices + 3 * (size_t)t;
    for (int j = 0; j < 3; j++) {
      const float *p = scene->positions + 3 * (size_t)idx[j];
      const float *q = scene->positions + 3 * (size_t)idx[(j + 1) % 3];
      mesh_edge *x = &e[k++];
      memset(x, 0, sizeof *x);
      int swap = memcmp(p, q, 3 * sizeof(float)) > 0;
      memcpy(x->e.a, swap ? q : p, 3 * sizeof(float));
      memcpy(x->e.b, swap ? p : q, 3 * sizeof(float));
      x->mesh = scene->triangle_mesh[t];
    }
  }
  qsort(e, n, sizeof *e, compare_mesh_edge);
  for (size_t i = 1; i < n; i++)
    if (compare_mesh_edge(&e[i - 1], &e[i]) == 0 && e[i - 1].mesh != e[i].mesh &&
        scene->meshes[e[i - 1].mesh].material == scene->meshes[e[i].mesh].material)
      join(parent, e[i - 1].mesh, e[i].mesh);
  free(e);
  return 1;
}

/* The media on both sides of every dielectric triangle, from the geometry (docs/
 * materials.md, "Media"). Behind a triangle lies its own mesh's material, named by the
 * least mesh of that material whose inside a ray from behind reaches or which shares an
 * edge with it (the outer and inner surfaces of one glass are one medium, and so are the
 * pieces of one surface). In front lies the medium whose closed
 * meshes hold a point just in front of its centroid (an odd number of their crossings
 * along a ray; the nearest crossed when several do); when no closed medium holds it,
 * the cavity's own air in front of a cavity's wall (mesh_count + 1 + the wall's mesh),
 * else what a ray along the front normal meets first: the inside of the dielectric it meets
 * from behind, else the medium in front of the one it meets from the front, else (no
 * dielectric, or a cycle of fronts: an enclosed cavity) air. */
static bbc_result find_media(bbc_scene *scene, double extent) {
  const uint32_t n = scene->triangle_count;
  bbc_accel *accel = NULL;
  bbc_result r = bbc_accel_create(&accel, scene, NULL, NULL);
  if (r != BBC_OK) return r;
  uint32_t *parent = malloc((scene->mesh_count + 1) * sizeof *parent);
  uint32_t *crossings = malloc((scene->mesh_count + 1) * sizeof *crossings);
  double *nearest = malloc((scene->mesh_count + 1) * sizeof *nearest);
  int *closed = malloc((scene->mesh_count + 1) * sizeof *closed);
  uint32_t *link = malloc(((size_t)n + 1) * sizeof *link);
  uint32_t *value = malloc(((size_t)n + 1) * sizeof *value);
  uint32_t *stamp = malloc(((size_t)n + 1) * sizeof *stamp);
  uint32_t *media = calloc(2 * (size_t)n + 1, sizeof *media);
  if (!parent || !crossings || !nearest || !closed || !link || !value || !stamp || !media) {
    r = BBC_ERR_OUT_OF_MEMORY;
    goto done;
  }
  const double tmin = 1e-6 * extent;
  for (uint32_t i = 0; i < scene->mesh_count; i++) parent[i] = i;
  /* Meshes of one material whose insides meet are one medium. */
  for (uint32_t t = 0; t < n; t++) {
    if (!is_dielectric(scene, t)) continue;
    bbc_vec3 c = v3_scale(
        v3_add(corner(scene, t, 0), v3_add(corner(scene, t, 1), corner(scene, t, 2))), 1.0 / 3.0);
    int side = 0;
    uint32_t hit =
        probe(scene, accel, t, c, v3_neg(v3_normalize(front_normal(scene, t))), tmin, &side);
    const uint32_t a = scene->triangle_mesh[t];
    if (hit == UINT32_MAX || side > 0) continue;
    const uint32_t b = scene->triangle_mesh[hit];
    if (scene->meshes[a].material != scene->meshes[b].material) continue; /* overlapping */
    join(parent, a, b);
  }
  if (!join_neighbours(scene, parent)) {
    r = BBC_ERR_OUT_OF_MEMORY;
    goto done;
  }
  /* A medium is closed when all its meshes are. */
  for (uint32_t i = 0; i < scene->mesh_count; i++) closed[i] = 1;
  for (uint32_t i = 0; i < scene->mesh_count; i++)
    if (scene->materials[scene->meshes[i].material].type == BBC_MATERIAL_DIELECTRIC)
      closed[find_root(parent, i)] &= scene->meshes[i].closed;
  const bbc_vec3 skew = v3_normalize(v3(0.5773, 0.5779, 0.5768));
  /* The fronts: resolved values, or links to the front of another triangle. */
  for (uint32_t t = 0; t < n; t++) {
    link[t] = UINT32_MAX;
    value[t] = 0;
    stamp[t] = UINT32_MAX;
    if (!is_dielectric(scene, t)) continue;
    bbc_vec3 c = v3_scale(
        v3_add(corner(scene, t, 0), v3_add(corner(scene, t, 1), corner(scene, t, 2))), 1.0 / 3.0);
    const bbc_vec3 nf = v3_normalize(front_normal(scene, t));
    /* The closed media holding the point just in front. */
    const bbc_vec3 x = v3_add(c, v3_scale(nf, tmin));
    for (uint32_t i = 0; i < scene->mesh_count; i++) crossings[i] = 0, nearest[i] = INFINITY;
    double from = 0;
    for (int k = 0; k < 4096; k++) {
      bbc_hit h;
      if (!bbc_accel_intersect(accel, x, skew, from, INFINITY, &h)) break;
      from = h.t + fmax(tmin, 1e-7 * h.t);
      if (!is_dielectric(scene, h.triangle)) continue;
      const uint32_t g = find_root(parent, scene->triangle_mesh[h.triangle]);
      if (!closed[g]) continue;
      crossings[g]++;
      nearest[g] = fmin(nearest[g], h.t);
    }
    uint32_t held = UINT32_MAX;
    for (uint32_t i = 0; i < scene->mesh_count; i++)
      if ((crossings[i] & 1) && (held == UINT32_MAX || nearest[i] < nearest[held])) held = i;
    if (held != UINT32_MAX) {
      value[t] = held + 1;
      continue;
    }
    /* In front of a cavity's wall with no closed medium in it: the cavity, air of its
     * own (so that light outside the glass is not taken to be in it). */
    if (scene->meshes[scene->triangle_mesh[t]].cavity) {
      value[t] = scene->mesh_count + 1 + scene->triangle_mesh[t];
      continue;
    }
    int side = 0;
    uint32_t hit = probe(scene, accel, t, c, nf, tmin, &side);
    if (hit == UINT32_MAX) continue;
    if (side < 0)
      value[t] = find_root(parent, scene->triangle_mesh[hit]) + 1;
    else
      link[t] = hit;
  }
  for (uint32_t t = 0; t < n; t++) {
    uint32_t u = t;
    while (link[u] != UINT32_MAX && stamp[u] != t) {
      stamp[u] = t;
      u = link[u];
    }
    /* Ends at a resolved front, or runs around a cycle (a cavity: air). */
    const uint32_t v = link[u] == UINT32_MAX ? value[u] : 0;
    for (uint32_t w = t; link[w] != UINT32_MAX;) {
      uint32_t next = link[w];
      link[w] = UINT32_MAX;
      value[w] = v;
      w = next;
    }
  }
  for (uint32_t t = 0; t < n; t++) {
    if (!is_dielectric(scene, t)) continue;
    media[2 * (size_t)t] = value[t];
    media[2 * (size_t)t + 1] = find_root(parent, scene->triangle_mesh[t]) + 1;
  }
  scene->media = media;
  media = NULL;
done:
  free(parent);
  free(crossings);
  free(nearest);
  free(closed);
  free(link);
  free(value);
  free(stamp);
  free(media);
  bbc_accel_free(accel);
  return r;
}

bbc_result bbc__scene_media(bbc_scene *scene) {
  free(scene->media);
  scene->media = NULL;
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    bbc_mesh *m = &scene->meshes[i];
    m->closed = 0;
    m->outward = 1;
    m->cavity = 0;
    if (scene->materials[m->material].type != BBC_MATERIAL_DIELECTRIC) continue;
    int closed = mesh_closed(scene, m);
    if (closed < 0) return BBC_ERR_OUT_OF_MEMORY;
    m->closed = closed;
    if (closed) m->outward = winding_outward(scene, m);
  }
  /* Several dielectrics whose boxes meet (a hollow glass of two surfaces, a liquid in a
   * glass): the media from the geometry. */
  int meet = 0;
  bbc_vec3 all_lo = v3(INFINITY, INFINITY, INFINITY), all_hi = v3(-INFINITY, -INFINITY, -INFINITY);
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    const bbc_mesh *a = &scene->meshes[i];
    if (scene->materials[a->material].type != BBC_MATERIAL_DIELECTRIC) continue;
    bbc_vec3 lo, hi;
    mesh_box(scene, a, &lo, &hi);
    all_lo = v3(fmin(all_lo.x, lo.x), fmin(all_lo.y, lo.y), fmin(all_lo.z, lo.z));
    all_hi = v3(fmax(all_hi.x, hi.x), fmax(all_hi.y, hi.y), fmax(all_hi.z, hi.z));
    for (uint32_t j = 0; j < i; j++) {
      const bbc_mesh *b = &scene->meshes[j];
      if (scene->materials[b->material].type != BBC_MATERIAL_DIELECTRIC) continue;
      bbc_vec3 lo2, hi2;
      mesh_box(scene, b, &lo2, &hi2);
      meet |= lo.x <= hi2.x && lo2.x <= hi.x && lo.y <= hi2.y && lo2.y <= hi.y && lo.z <= hi2.z &&
              lo2.z <= hi.z;
    }
  }
  if (meet) {
    /* A closed mesh inside another closed dielectric, with vertex normals into it, is
     * a cavity's wall: its front is its inside. */
    for (uint32_t i = 0; i < scene->mesh_count; i++) {
      bbc_mesh *m = &scene->meshes[i];
      if (!m->closed || m->triangle_count == 0) continue;
      const int normals_out = (normals_follow_winding(scene, m) ? 1 : -1) * m->outward > 0;
      if (normals_out) continue;
      const bbc_vec3 x = corner(scene, m->first_triangle, 0);
      for (uint32_t j = 0; j < scene->mesh_count; j++)
        if (j != i && scene->meshes[j].closed && point_inside(scene, &scene->meshes[j], x)) {
          m->outward = -m->outward;
          m->cavity = 1;
          break;
        }
    }
    bbc_result r = find_media(scene, v3_length(v3_sub(all_hi, all_lo)));
    if (r != BBC_OK) return r;
  }
  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    bbc_point_light *light = &scene->point_lights[l];
    light->medium = 0;
    if (light->model.kind == BBC_LIGHT_DIRECTIONAL) continue; /* a sun shines from outside */
    light->medium = bbc__media_at(scene, light->position);
  }
  return BBC_OK;
}

uint32_t bbc__media_at(const bbc_scene *scene, bbc_vec3 x) {
  if (scene->media) {
    /* The medium on the side of the first dielectric a ray from x meets. */
    const bbc_vec3 d = v3_normalize(v3(0.5773, 0.5779, 0.5768));
    double best = INFINITY;
    uint32_t medium = 0;
    for (uint32_t t = 0; t < scene->triangle_count; t++) {
      if (!is_dielectric(scene, t)) continue;
      bbc_vec3 p0 = corner(scene, t, 0);
      bbc_vec3 e1 = v3_sub(corner(scene, t, 1), p0), e2 = v3_sub(corner(scene, t, 2), p0);
      bbc_vec3 pv = v3_cross(d, e2);
      double det = v3_dot(e1, pv);
      if (det == 0) continue;
      bbc_vec3 w = v3_sub(x, p0);
      double u = v3_dot(w, pv) / det;
      bbc_vec3 qv = v3_cross(w, e1);
      double v = v3_dot(d, qv) / det, h = v3_dot(e2, qv) / det;
      if (!(u >= 0 && v >= 0 && u + v <= 1 && h > 0 && h < best)) continue;
      int side = bbc__media_side(scene, t, x);
      if (!side) continue;
      best = h;
      medium = scene->media[2 * (size_t)t + (side < 0)];
    }
    return medium;
  }
  for (uint32_t i = 0; i < scene->mesh_count; i++)
    if (scene->meshes[i].closed && point_inside(scene, &scene->meshes[i], x)) return i + 1;
  return 0;
}

int bbc__media_side(const bbc_scene *scene, uint32_t t, bbc_vec3 q) {
  double s = v3_dot(front_normal(scene, t), v3_sub(q, corner(scene, t, 0)));
  return (s > 0) - (s < 0);
}

int bbc__media_refract(const bbc_scene *scene, uint32_t medium, uint32_t t, int side,
                       uint32_t *after) {
  if (scene->media) {
    const uint32_t *m = scene->media + 2 * (size_t)t;
    if (side == 0 || medium != m[side < 0]) return 0;
    *after = m[side > 0];
    return 1;
  }
  const uint32_t mesh = scene->triangle_mesh[t];
  if (medium == 0 && side > 0) {
    *after = mesh + 1;
    return 1;
  }
  if (medium == mesh + 1 && side < 0) {
    *after = 0;
    return 1;
  }
  return 0;
}

int bbc__media_passable(const bbc_scene *scene) {
  if (scene->media) return 1;
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    const bbc_material *m = &scene->materials[scene->meshes[i].material];
    if (m->type == BBC_MATERIAL_DIELECTRIC &&
        (!scene->meshes[i].closed || bbc_material_partial(scene, m)))
      return 1;
  }
  return 0;
}

int bbc__media_clear(const bbc_scene *scene, const bbc_accel *accel, int passable, bbc_vec3 origin,
                     bbc_vec3 d, double tmax, uint32_t medium, int against) {
  if (!bbc_accel_occluded(accel, origin, d, 0.0, tmax)) return 1;
  if (!passable) return 0;
  double from = 0.0;
  for (int k = 0; k < BBC__MEDIA_MAX_PASSES; k++) {
    bbc_hit h;
    if (!bbc_accel_intersect(accel, origin, d, from, tmax, &h)) return 1;
    if (bbc_scene_triangle_material(scene, h.triangle)->type != BBC_MATERIAL_DIELECTRIC) return 0;
    const int side = bbc__media_side(scene, h.triangle, origin);
    uint32_t after;
    if (side == 0 || bbc__media_refract(scene, medium, h.triangle, against ? -side : side, &after))
      return 0;
    from = h.t + 1e-7;
  }
  return 0;
}

/* The index of refraction of medium `medium` (1 for air). */
static double medium_ior(const bbc_scene *scene, uint32_t medium) {
  if (!medium || medium > scene->mesh_count) return 1.0;
  return (double)scene->materials[scene->meshes[medium - 1].material].ior;
}

double bbc__media_ior(const bbc_scene *scene, uint32_t t) {
  if (!scene->media) return (double)bbc_scene_triangle_material(scene, t)->ior;
  const uint32_t *m = scene->media + 2 * (size_t)t;
  return medium_ior(scene, m[1]) / medium_ior(scene, m[0]);
}

double bbc__media_eta(const bbc_scene *scene, uint32_t t, int side) {
  if (!scene->media) {
    const double ior = (double)bbc_scene_triangle_material(scene, t)->ior;
    return side > 0 ? 1.0 / ior : ior;
  }
  const uint32_t *m = scene->media + 2 * (size_t)t;
  return medium_ior(scene, m[side < 0]) / medium_ior(scene, m[side > 0]);
}

int bbc__media_interface(const bbc_scene *scene, uint32_t medium, uint32_t t, int front,
                         double *eta, uint32_t *after) {
  const int side = front ? 1 : -1;
  if (!bbc__media_refract(scene, medium, t, side, after)) return 0;
  *eta = bbc__media_eta(scene, t, side);
  return 1;
}

uint32_t bbc__media_enclosure(const bbc_scene *scene, uint32_t t, int side) {
  const uint32_t mesh = scene->triangle_mesh[t];
  const bbc_mesh *m = &scene->meshes[mesh];
  if (!m->closed || side == 0 || bbc_material_partial(scene, &scene->materials[m->material]))
    return 0;
  return (side > 0) != (m->cavity != 0) ? mesh + 1 : 0;
}
