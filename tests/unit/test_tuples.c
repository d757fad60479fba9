/* Tuple construction against light tracing: every path that leaves a point light, meets
 * one or two specular triangles and then a receiver, and that the renderer counts
 * (nearest hits only, so every segment is unoccluded; refraction by Snell's law with
 * the shading normal; the medium rule of media_internal.h), must belong to a candidate
 * tuple of bbc_tuples_find. A missing tuple would be a caustic the cache cannot
 * render at all.
 *
 * The tracer here is written from the physics, not from the library's tuple code: rays
 * aimed at random points of random casters, Embree for the nearest hit, and the media
 * tracked as the renderer defines them: a dielectric's outside is the side its vertex
 * normals point to (all the scenes here have consistent normals), light starts in air
 * (or inside the closed mesh that holds it, checked separately below), enters glass
 * only through a front face and leaves only through a back face of the same mesh. Paths at a grazing hit where the shading normal and the geometric side
 * disagree are left out, as the renderer skips them. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/accel.h"
#include "bbc/bbc.h"
#include "bbc/precompute.h"
#include "harness.h"
#include "light_internal.h"
#include "media_internal.h"
#include "orient_internal.h"
#include "rng_internal.h"
#include "vec_internal.h"

static int compare_tuple(const void *a, const void *b) {
  return memcmp(a, b, sizeof(bbc_tuple));
}

static bbc_vec3 vertex(const bbc_scene *s, uint32_t t, int k) {
  return v3_load(s->positions + 3 * (size_t)s->indices[3 * (size_t)t + k]);
}

/* The geometric normal of t turned to the side its vertex normals point to, and the
 * interpolated shading normal at barycentrics (u, v) of vertices 1 and 2. */
static void normals_at(const bbc_scene *s, uint32_t t, double u, double v, bbc_vec3 *ng,
                       bbc_vec3 *ns) {
  bbc_vec3 n[3];
  for (int k = 0; k < 3; k++) n[k] = v3_load(s->normals + 3 * (size_t)s->indices[3 * (size_t)t + k]);
  *ns = v3_normalize(v3_add(v3_scale(n[0], 1 - u - v), v3_add(v3_scale(n[1], u), v3_scale(n[2], v))));
  bbc_vec3 g = v3_normalize(v3_cross(v3_sub(vertex(s, t, 1), vertex(s, t, 0)),
                                     v3_sub(vertex(s, t, 2), vertex(s, t, 0))));
  *ng = v3_dot(g, v3_add(n[0], v3_add(n[1], n[2]))) >= 0 ? g : v3_neg(g);
}

typedef struct trace_totals {
  long paths[BBC_CHAIN_COUNT]; /* counted paths per chain type */
  long missing;                /* of them, not in a candidate tuple */
  long wrong_medium;           /* stopped by the medium rule (for the record) */
  long leaked;                 /* left a closed mesh without meeting it (for the record) */
} trace_totals;

/* Whether a point of triangle t may lie inside closed mesh m: its box meets m's. */
static int boxes_meet(const bbc_scene *s, uint32_t t, uint32_t m) {
  const bbc_mesh *mesh = &s->meshes[m];
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t k = 3 * (size_t)mesh->first_triangle;
       k < 3 * ((size_t)mesh->first_triangle + mesh->triangle_count); k++)
    for (int a = 0; a < 3; a++) {
      const double x = s->positions[3 * (size_t)s->indices[k] + a];
      lo[a] = fmin(lo[a], x), hi[a] = fmax(hi[a], x);
    }
  for (int a = 0; a < 3; a++) {
    double tlo = INFINITY, thi = -INFINITY;
    for (int j = 0; j < 3; j++) {
      const double x = s->positions[3 * (size_t)s->indices[3 * (size_t)t + j] + a];
      tlo = fmin(tlo, x), thi = fmax(thi, x);
    }
    if (thi < lo[a] || tlo > hi[a]) return 0;
  }
  return 1;
}

/* An emitter's light path: its point y (the origin) and the centroid of the emitter,
 * which stands for it in the medium rule of the tuple search (an emitter is in air;
 * docs/lights.md), so that a refraction at T1 counts only where the centroid lies on the
 * same side of T1 as y (the renderer's rule, bbc__caustics_area_covers). */
typedef struct emitter_origin {
  bbc_vec3 y, centroid;
} emitter_origin;

static void trace_path(const bbc_scene *s, const bbc_accel *accel, uint32_t light, bbc_vec3 o,
                       bbc_vec3 d, uint32_t medium, const emitter_origin *area,
                       const bbc_tuple *sorted, size_t count, trace_totals *out);

/* Traces one light path aimed at point `aim`; adds it to the totals. */
static void trace_one(const bbc_scene *s, const bbc_accel *accel, uint32_t light, bbc_vec3 aim,
                      const bbc_tuple *sorted, size_t count, trace_totals *out) {
  const bbc_point_light *l = &s->point_lights[light];
  bbc_vec3 o = l->position, d = v3_normalize(v3_sub(aim, o));
  if (l->model.kind == BBC_LIGHT_DIRECTIONAL) {
    /* A sun's ray toward aim comes from far outside the scene along its direction. */
    d = l->model.direction;
    o = v3_sub(aim, v3_scale(d, 100.0));
  } else if (l->model.kind == BBC_LIGHT_SPOT && !(bbc_light_falloff(&l->model, d) > 0)) {
    return; /* outside the spot's cone: no light */
  }
  trace_path(s, accel, light, o, d, l->medium, NULL, sorted, count, out);
}

static void trace_path(const bbc_scene *s, const bbc_accel *accel, uint32_t light, bbc_vec3 o,
                       bbc_vec3 d, uint32_t medium, const emitter_origin *area,
                       const bbc_tuple *sorted, size_t count, trace_totals *out) {
  /* medium: 0 air, else 1 + the mesh */
  uint32_t specular[2] = {BBC_NO_TRIANGLE, BBC_NO_TRIANGLE};
  int letters[2] = {0, 0}, length = 0;
  for (;;) {
    bbc_hit h;
    if (!bbc_accel_intersect(accel, o, d, 0.0, INFINITY, &h)) return;
    const bbc_mesh *mesh = &s->meshes[s->triangle_mesh[h.triangle]];
    const bbc_material *m = &s->materials[mesh->material];
    bbc_vec3 x = v3_add(o, v3_scale(d, h.t));
    if (mesh->role == BBC_ROLE_RECEIVER) {
      if (length == 0) return;
      /* Inside a closed mesh, a receiver wholly outside it is reached only by a ray that
       * slipped through the mesh (between its triangles, in float): no path. */
      if (!s->media && medium != 0 && s->meshes[medium - 1].closed &&
          !boxes_meet(s, h.triangle, medium - 1)) {
        out->leaked++;
        return;
      }
      static const int two[2][2] = {{BBC_CHAIN_RR, BBC_CHAIN_RT}, {BBC_CHAIN_TR, BBC_CHAIN_TT}};
      int type = length == 1 ? (letters[0] ? BBC_CHAIN_T : BBC_CHAIN_R) : two[letters[0]][letters[1]];
      /* A receiver plane's tuples end on the plane (tuple.h). */
      const uint32_t receiver =
          mesh->plane ? BBC_RECEIVER_PLANE(s->triangle_mesh[h.triangle]) : h.triangle;
      bbc_tuple key = {light, (uint32_t)type, {specular[0], specular[1]}, receiver};
      out->paths[key.chain]++;
      if (!bsearch(&key, sorted, count, sizeof key, compare_tuple)) out->missing++;
      return;
    }
    if (mesh->role != BBC_ROLE_CASTER || length == 2) return;
    if (m->type != BBC_MATERIAL_MIRROR && m->type != BBC_MATERIAL_DIELECTRIC) return;
    bbc_vec3 ng, n;
    normals_at(s, h.triangle, h.u, h.v, &ng, &n);
    double cg = v3_dot(d, ng), c = v3_dot(d, n);
    if (cg == 0 || (cg < 0) != (c < 0)) return; /* grazing: shading and geometry disagree */
    if (c > 0) {
      n = v3_neg(n);
      c = -c;
    }
    if (m->type == BBC_MATERIAL_MIRROR) {
      d = v3_sub(d, v3_scale(n, 2 * c));
      letters[length] = 0;
    } else {
      const uint32_t here = s->triangle_mesh[h.triangle] + 1;
      const int from_front = cg < 0;
      if (area && length == 0) {
        /* The emitter's centroid must be on y's side of T1 (see emitter_origin). */
        const int side = bbc__media_side(s, h.triangle, area->centroid);
        if (side == 0 || (side > 0) != from_front) return;
      }
      double eta = from_front ? 1.0 / m->ior : m->ior;
      if (s->media) {
        /* Media from the geometry (docs/materials.md, "Media"): a surface that does not
         * bound the ray's medium is gone through unchanged, as the path tracer does. */
        uint32_t after;
        if (!bbc__media_refract(s, medium, h.triangle, from_front ? 1 : -1, &after)) {
          out->wrong_medium++;
          o = v3_offset_origin(x, ng, d);
          continue;
        }
        medium = after;
        eta = bbc__media_eta(s, h.triangle, from_front ? 1 : -1);
      } else if (medium == 0 && from_front) {
        medium = here;
      } else if (medium == here && !from_front) {
        medium = 0;
      } else {
        out->wrong_medium++;
        return;
      }
      double k = 1 - eta * eta * (1 - c * c);
      if (k < 0) return; /* total internal reflection: not a refraction chain */
      d = v3_normalize(v3_sub(v3_scale(d, eta), v3_scale(n, eta * c + sqrt(k))));
      letters[length] = 1;
    }
    specular[length++] = h.triangle;
    o = v3_offset_origin(x, ng, d); /* off the surface, as the renderer's rays */
  }
}

/* Traces `rays` light paths aimed at uniform points of area-weighted casters (any aim
 * works: the claim is about every path) and checks each against the candidates. With
 * `area`, the lights are the scene's emitters (bbc_tuples_find_area): each path starts
 * at a point drawn uniformly on an emitter and leaves its front. */
static void check_lights(bbc_scene *s, uint32_t chains, long rays, const long *min_paths,
                         int area) {
  const char *path = s->path;
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE((area ? bbc_tuples_find_area : bbc_tuples_find)(s, chains, &tuples, &count) == BBC_OK);
  REQUIRE(!area || s->emitter_count > 0);
  /* The candidate order of the spec (Sec. 5.10, R-CAN-1): strictly increasing in
   * (light, T1, T2 + 1 mod 2^32, receiver). */
  long out_of_order = 0;
  for (size_t i = 1; i < count; i++) {
    const bbc_tuple *a = &tuples[i - 1], *b = &tuples[i];
    uint32_t ka[4] = {a->light, a->specular[0], a->specular[1] + 1u, a->receiver};
    uint32_t kb[4] = {b->light, b->specular[0], b->specular[1] + 1u, b->receiver};
    int k = 0;
    while (k < 4 && ka[k] == kb[k]) k++;
    if (k == 4 || ka[k] > kb[k]) out_of_order++;
  }
  CHECK_INT(out_of_order, 0);
  qsort(tuples, count, sizeof *tuples, compare_tuple);
  /* Cumulative areas of the casters. */
  double *cdf = malloc(s->triangle_count * sizeof *cdf), total = 0;
  REQUIRE(cdf);
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    if (s->meshes[s->triangle_mesh[t]].role == BBC_ROLE_CASTER)
      total += v3_length(v3_cross(v3_sub(vertex(s, t, 1), vertex(s, t, 0)),
                                  v3_sub(vertex(s, t, 2), vertex(s, t, 0))));
    cdf[t] = total;
  }
  trace_totals totals;
  memset(&totals, 0, sizeof totals);
  bbc_rng rng = bbc_rng_make(0x70ce, 0, 0);
  for (long i = 0; i < rays; i++) {
    double pick = bbc_rng_next(&rng) * total;
    uint32_t lo = 0, hi = s->triangle_count - 1;
    while (lo < hi) {
      uint32_t mid = (lo + hi) / 2;
      if (cdf[mid] > pick) hi = mid;
      else lo = mid + 1;
    }
    double a = bbc_rng_next(&rng), b = bbc_rng_next(&rng);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    bbc_vec3 aim = v3_add(vertex(s, lo, 0), v3_add(v3_scale(v3_sub(vertex(s, lo, 1), vertex(s, lo, 0)), a),
                                                v3_scale(v3_sub(vertex(s, lo, 2), vertex(s, lo, 0)), b)));
    if (!area) {
      trace_one(s, accel, (uint32_t)(i % s->point_light_count), aim, tuples, count, &totals);
      continue;
    }
    /* A point of emitter e, uniform by area (a = sqrt r1, b = r2), toward aim. */
    const uint32_t e = (uint32_t)(i % s->emitter_count);
    bbc_light_model model;
    bbc_scene_area_light(s, e, &model, NULL);
    const double ea = sqrt(bbc_rng_next(&rng)), eb = bbc_rng_next(&rng);
    emitter_origin from;
    from.y = bbc__area_point(&model, ea, eb);
    from.centroid = bbc__area_centroid(&model);
    const bbc_vec3 d = v3_normalize(v3_sub(aim, from.y));
    if (!(v3_dot(d, model.emitter_normal) > 0)) continue; /* behind the emitter: no light */
    const bbc_vec3 o = v3_offset_origin(from.y, v3_normalize(model.emitter_normal), d);
    trace_path(s, accel, s->point_light_count + e, o, d, 0, &from, tuples, count, &totals);
  }
  fprintf(stderr, "%s: %zu candidates, %ld rays:", path, count, rays);
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (totals.paths[c]) fprintf(stderr, " %s %ld", bbc_chain_name((bbc_chain)c), totals.paths[c]);
  fprintf(stderr,
          "; stopped by the medium rule %ld; slipped out of a closed mesh %ld; missing %ld\n",
          totals.wrong_medium, totals.leaked, totals.missing);
  CHECK(totals.leaked * 1000 <= rays); /* rare, or the tracing is wrong */
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (chains & (1u << c)) CHECK(totals.paths[c] >= min_paths[c]);
  CHECK_INT(totals.missing, 0);
  free(cdf);
  free(tuples);
  bbc_accel_free(accel);
}

static void check_loaded(bbc_scene *s, uint32_t chains, long rays, const long *min_paths) {
  check_lights(s, chains, rays, min_paths, 0);
}

static void check_scene_lights(const char *path, uint32_t chains, long rays,
                               const long *min_paths, int area) {
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", path);
    return;
  }
  check_lights(s, chains, rays, min_paths, area);
  bbc_scene_free(s);
}

static void check_scene(const char *path, uint32_t chains, long rays, const long *min_paths) {
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, NULL) != BBC_OK) {
    harness_fail(__FILE__, __LINE__, "cannot load %s", path);
    return;
  }
  check_loaded(s, chains, rays, min_paths);
  bbc_scene_free(s);
}

/* The centre of a mesh's vertices' box. */
static bbc_vec3 mesh_centre(const bbc_scene *s, const bbc_mesh *m) {
  bbc_vec3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
  for (uint32_t i = m->first_vertex; i < m->first_vertex + m->vertex_count; i++) {
    bbc_vec3 p = v3_load(s->positions + 3 * (size_t)i);
    lo = v3(fmin(lo.x, p.x), fmin(lo.y, p.y), fmin(lo.z, p.z));
    hi = v3(fmax(hi.x, p.x), fmax(hi.y, p.y), fmax(hi.z, p.z));
  }
  return v3_scale(v3_add(lo, hi), 0.5);
}

/* The media the loader finds: the glass sphere is closed with its centre behind every
 * triangle, the slab10k sheets are open with the light in front of the light-facing
 * sheet; a light moved into the sphere is inside it, and then light leaves the sphere
 * through the back of its triangles (and every such path has its tuple). */
TEST(media) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-sphere.gltf"), NULL) == BBC_OK);
  uint32_t sphere = BBC_NO_TRIANGLE;
  for (uint32_t i = 0; i < s->mesh_count; i++)
    if (s->materials[s->meshes[i].material].type == BBC_MATERIAL_DIELECTRIC) sphere = i;
  REQUIRE(sphere != BBC_NO_TRIANGLE);
  const bbc_mesh *m = &s->meshes[sphere];
  CHECK_INT(m->closed, 1);
  CHECK_INT(s->point_lights[0].medium, 0);
  bbc_vec3 centre = mesh_centre(s, m);
  long behind = 0;
  for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++)
    behind += bbc__media_side(s, t, centre) < 0;
  CHECK_INT(behind, m->triangle_count);
  s->point_lights[0].position = centre;
  REQUIRE(bbc__scene_media(s) == BBC_OK);
  CHECK_INT(s->point_lights[0].medium, sphere + 1);
  static const long min[BBC_CHAIN_COUNT] = {0, 10000, 0, 0, 0, 0};
  check_loaded(s, BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000), min);
  bbc_scene_free(s);

  REQUIRE(bbc_scene_load(&s, TEST_SCENE("slab10k.gltf"), NULL) == BBC_OK);
  uint32_t slab = s->triangle_mesh[0];
  CHECK_INT(s->meshes[slab].closed, 0);
  CHECK_INT(s->point_lights[0].medium, 0);
  /* The light (z = -2) is in front of the sheet facing it (winding normals toward -z)
   * and behind the other. */
  long front = 0, back = 0;
  for (uint32_t t = 0; t < s->meshes[slab].triangle_count; t++) {
    bbc_vec3 e = v3_cross(v3_sub(vertex(s, t, 1), vertex(s, t, 0)), v3_sub(vertex(s, t, 2), vertex(s, t, 0)));
    int side = bbc__media_side(s, t, s->point_lights[0].position);
    front += e.z < 0 && side > 0;
    back += e.z > 0 && side < 0;
  }
  CHECK_INT(front + back, s->meshes[slab].triangle_count);
  CHECK(front > 7000 && back > 1500);
  bbc_scene_free(s);
}

/* Minimum counted paths per chain type (R, T, RR, RT, TR, TT), so a scene that stopped
 * producing paths cannot pass silently. */
TEST(two_mirrors_rr) {
  static const long min[BBC_CHAIN_COUNT] = {1000, 0, 1000, 0, 0, 0};
  check_scene(TEST_SCENE("two-mirrors.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(wavy_mirror_r) {
  static const long min[BBC_CHAIN_COUNT] = {10000, 0, 0, 0, 0, 0};
  check_scene(TEST_SCENE("wavy-mirror.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(pool_t) {
  static const long min[BBC_CHAIN_COUNT] = {0, 10000, 0, 0, 0, 0};
  check_scene(TEST_SCENE("pool.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000), min);
}
TEST(glass_sphere_closed) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 10000};
  check_scene(TEST_SCENE("glass-sphere.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(ball80_closed) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 10000};
  check_scene(TEST_SCENE("ball80.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(slab10k_open) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 10000};
  check_scene(TEST_SCENE("slab10k.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(200000, 2000000),
              min);
}
TEST(diamond_closed_flat) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 1000};
  check_scene(TEST_SCENE("diamond.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(200000, 2000000),
              min);
}
TEST(mirror_pool_rt_tr) {
  static const long min[BBC_CHAIN_COUNT] = {0, 1000, 0, 1000, 1000, 0};
  check_scene(TEST_SCENE("mirror-pool.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(wavy_corner_rr) {
  static const long min[BBC_CHAIN_COUNT] = {1000, 0, 1000, 0, 0, 0};
  check_scene(TEST_SCENE("wavy-corner.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}
TEST(glass_slab_closed) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 10000};
  check_scene(TEST_SCENE("glass-slab.gltf"), BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000),
              min);
}

/* Area lights: paths from uniform points of the emitters, through every chain type the
 * generated scenes form (the tuples of bbc_tuples_find_area, the T2 search included). */
TEST(area_lights) {
  static const char *const scenes[4] = {"two-mirrors-area", "mirror-pool-area",
                                        "glass-sphere-area", "wavy-corner-area"};
  static const long mins[4][BBC_CHAIN_COUNT] = {{1000, 0, 1000, 0, 0, 0},
                                                {0, 1000, 0, 300, 300, 0},
                                                {0, 0, 0, 0, 0, 3000},
                                                {1000, 0, 1000, 0, 0, 0}};
  for (int i = 0; i < 4; i++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.gltf", BBC_TEST_SCENES, scenes[i]);
    check_scene_lights(path, BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000), mins[i], 1);
  }
}

/* Suns (rays from outside the scene along the light's direction) and spots (rays
 * inside the outer cone only) have their tuples too. */
TEST(suns_and_spots) {
  static const char *const scenes[4] = {"wavy-mirror", "pool", "two-mirrors", "glass-slab"};
  static const long mins[4][BBC_CHAIN_COUNT] = {{3000, 0, 0, 0, 0, 0},
                                                {0, 3000, 0, 0, 0, 0},
                                                {300, 0, 300, 0, 0, 0},
                                                {0, 0, 0, 0, 0, 300}};
  static const char *const kinds[2] = {"sun", "spot"};
  for (int i = 0; i < 4; i++)
    for (int k = 0; k < 2; k++) {
      char path[1024];
      snprintf(path, sizeof path, "%s/%s-%s.gltf", BBC_TEST_SCENES, scenes[i], kinds[k]);
      check_scene(path, BBC_CHAIN_MASK_ALL, harness_scale(30000, 1000000), mins[i]);
    }
}

/* The exact orientation against 128-bit integer determinants: integer coordinates below
 * 2^21 in magnitude (exact floats, times a power of two), exactly coplanar quadruples
 * (d = a + i (b - a) + j (c - a)) and the same with d moved by one unit. Doubles alone
 * get some of these wrong (counted, as the control). */
static int orient_int(const long long p[4][3]) {
  __int128 u[3], v[3], w[3];
  for (int k = 0; k < 3; k++) {
    u[k] = p[1][k] - p[0][k];
    v[k] = p[2][k] - p[0][k];
    w[k] = p[3][k] - p[0][k];
  }
  __int128 det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                 u[2] * (v[0] * w[1] - v[1] * w[0]);
  return (det > 0) - (det < 0);
}

static int orient_double(const float p[4][3]) {
  double u[3], v[3], w[3];
  for (int k = 0; k < 3; k++) {
    u[k] = (double)p[1][k] - p[0][k];
    v[k] = (double)p[2][k] - p[0][k];
    w[k] = (double)p[3][k] - p[0][k];
  }
  double det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
               u[2] * (v[0] * w[1] - v[1] * w[0]);
  return (det > 0) - (det < 0);
}

TEST(orient3d_exact) {
  bbc_rng rng = bbc_rng_make(7, 0, 0);
  long wrong = 0, naive_wrong = 0, zeros = 0;
  const long cases = 30000;
  for (long n = 0; n < cases; n++) {
    long long p[4][3];
    const long long range = 1 << 20;
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++)
        p[i][k] = (long long)(bbc_rng_next(&rng) * 2 * range) - range;
    const int kind = (int)(n % 3);
    if (kind == 2) { /* general position */
      for (int k = 0; k < 3; k++) p[3][k] = (long long)(bbc_rng_next(&rng) * 2 * range) - range;
    } else {
      long long i = (long long)(bbc_rng_next(&rng) * 7) - 3, j = (long long)(bbc_rng_next(&rng) * 7) - 3;
      for (int k = 0; k < 3; k++) p[3][k] = p[0][k] + i * (p[1][k] - p[0][k]) + j * (p[2][k] - p[0][k]);
      if (kind == 1) p[3][n % 9 / 3] += (n & 8) ? 1 : -1;
    }
    const int expect = orient_int(p);
    zeros += expect == 0;
    const float scale = ldexpf(1.0f, (int)(n % 41) - 20);
    float f[4][3];
    for (int i = 0; i < 4; i++)
      for (int k = 0; k < 3; k++) f[i][k] = (float)p[i][k] * scale;
    wrong += bbc__orient3d(f[0], f[1], f[2], f[3]) != expect;
    naive_wrong += orient_double(f) != expect;
  }
  fprintf(stderr, "orient3d: %ld cases, %ld coplanar; exact wrong %ld, doubles wrong %ld\n", cases,
          zeros, wrong, naive_wrong);
  CHECK_INT(wrong, 0);
  CHECK(zeros >= cases / 3);
  CHECK(naive_wrong > 0); /* the cases are hard enough to need the exact predicate */
}

/* A flat mirror: its triangles are coplanar, so no light goes from one to another and
 * no two-bounce candidate may remain; every single-reflection path has its tuple. */
TEST(flat_mirror_coplanar) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  bbc_tuple *tuples = NULL;
  size_t count = 0, pairs = 0;
  REQUIRE(bbc_tuples_find(s, BBC_CHAIN_MASK_ALL, &tuples, &count) == BBC_OK);
  for (size_t i = 0; i < count; i++) pairs += bbc_chain_length((bbc_chain)tuples[i].chain) == 2;
  free(tuples);
  CHECK_INT(pairs, 0);
  static const long min[BBC_CHAIN_COUNT] = {10000, 0, 0, 0, 0, 0};
  check_loaded(s, BBC_CHAIN_MASK_ALL, harness_scale(100000, 1000000), min);
  bbc_scene_free(s);
}

/* Where dielectrics meet, media come from the geometry: every light path of one or two
 * refractions through a glass of water (its water a separate mesh reaching into the
 * glass; rays go on through a surface that does not bound their medium) and through a
 * hollow ball of two meshes has its candidate tuple, so the rules that drop tuples there
 * (the sides of T2, light enclosed by a closed mesh or a cavity) drop no path. */
TEST(media_from_geometry) {
  static const long min[BBC_CHAIN_COUNT] = {0, 0, 0, 0, 0, 100};
  check_scene(TEST_SCENE("glass-of-water.gltf"), (1u << BBC_CHAIN_T) | (1u << BBC_CHAIN_TT),
              harness_scale(100000, 1000000), min);
  static const long none[BBC_CHAIN_COUNT] = {0};
  check_scene(TEST_SCENE("hollow-sphere-small.gltf"), (1u << BBC_CHAIN_T) | (1u << BBC_CHAIN_TT),
              harness_scale(50000, 500000), none);
}
