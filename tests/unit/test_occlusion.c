/* Occlusion between two specular vertices (occlusion_internal.h): the oracle is Embree.
 * A true segment, from a random point of a closed mesh's triangle A in a random
 * direction to the first surface it meets (bbc_accel_intersect), a triangle B of a
 * closed mesh, crosses nothing between: the pair (A, B) must never be proven blocked.
 * Pairs the test does block are checked the other way too: every random segment between
 * them is occluded. Where Embree and the test disagree, a second opinion decides: plain
 * Moller-Trumbore in double precision against every triangle (Embree, in single
 * precision, misses a crossing within rounding of an edge, and one closer than its tmin
 * to the segment's start). The control that takes the parity of the box R at its centre
 * alone, without checking that R meets no triangle, blocks true segments. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/accel.h"
#include "bbc/bbc.h"
#include "harness.h"
#include "occlusion_internal.h"
#include "vec_internal.h"

static uint64_t next(uint64_t *state) {
  uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

static double uniform(uint64_t *state) {
  return (double)(next(state) >> 11) * 0x1.0p-53;
}

static bbc_vec3 vertex(const bbc_scene *s, uint32_t t, int k) {
  return v3_load(s->positions + 3 * (size_t)s->indices[3 * (size_t)t + k]);
}

/* A uniform point of triangle t; with `inner`, of the part whose barycentrics are all at
 * least 0.05 (a segment from a point at an edge may leave through the neighbour at once,
 * closer than the oracle's tmin). */
static bbc_vec3 point_on(const bbc_scene *s, uint32_t t, int inner, uint64_t *state) {
  double r = sqrt(uniform(state)), u = uniform(state);
  double a = 1 - r, b = r * (1 - u), c = r * u;
  if (inner) a = 0.05 + 0.85 * a, b = 0.05 + 0.85 * b, c = 0.05 + 0.85 * c;
  return v3_add(v3_add(v3_scale(vertex(s, t, 0), a), v3_scale(vertex(s, t, 1), b)),
                v3_scale(vertex(s, t, 2), c));
}

static int closed_dielectric(const bbc_scene *s, uint32_t t) {
  const bbc_mesh *m = &s->meshes[s->triangle_mesh[t]];
  return m->closed && s->materials[m->material].type == BBC_MATERIAL_DIELECTRIC;
}

/* The triangles (other than a and b) that segment x y crosses strictly inside, by plain
 * Moller-Trumbore in double precision over every triangle: the second opinion where
 * Embree (single precision) and the test disagree, at a crossing within rounding of an
 * edge or of the segment's start. */
static int crossings(const bbc_scene *s, bbc_vec3 x, bbc_vec3 y, uint32_t a, uint32_t b) {
  int hits = 0;
  const bbc_vec3 d = v3_sub(y, x);
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    if (t == a || t == b) continue;
    const bbc_vec3 p0 = vertex(s, t, 0), e1 = v3_sub(vertex(s, t, 1), p0),
                   e2 = v3_sub(vertex(s, t, 2), p0);
    const bbc_vec3 pv = v3_cross(d, e2), w = v3_sub(x, p0), qv = v3_cross(w, e1);
    const double det = v3_dot(e1, pv);
    if (det == 0) continue;
    const double u = v3_dot(w, pv) / det, v = v3_dot(d, qv) / det, h = v3_dot(e2, qv) / det;
    hits += u >= 0 && v >= 0 && u + v <= 1 && h > 0 && h < 1;
  }
  return hits;
}

typedef struct counts {
  long segments, wrongly_blocked, blocked_pairs, pair_segments, free_in_blocked;
} counts;

/* n true segments between closed meshes' triangles, and n random pairs of them, in the
 * test scene `file`; with `empty_water`, the mesh "water" is moved to one point far away
 * (a glass without its water, as a vase). *has receives whether the scene has occluders. */
static void check_scene(const char *file, int empty_water, long n, counts *out, int *has) {
  counts c = {0, 0, 0, 0, 0};
  *out = c;
  *has = 0;
  char path[512];
  snprintf(path, sizeof path, "%s/%s", BBC_TEST_SCENES, file);
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, path, NULL) == BBC_OK);
  for (uint32_t m = 0; empty_water && m < s->mesh_count; m++) {
    const bbc_mesh *mesh = &s->meshes[m];
    if (strcmp(mesh->name, "water") != 0) continue;
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++)
      for (int a = 0; a < 3; a++) s->positions[3 * (size_t)v + a] = 50.0f;
  }
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  bbc__occluders *o = NULL;
  REQUIRE(bbc__occluders_create(&o, s) == BBC_OK);
  *has = o != NULL;
  uint32_t *tri = malloc(s->triangle_count * sizeof *tri);
  REQUIRE(tri != NULL);
  uint32_t k = 0;
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    const bbc_vec3 n = v3_cross(v3_sub(vertex(s, t, 1), vertex(s, t, 0)),
                                v3_sub(vertex(s, t, 2), vertex(s, t, 0)));
    if (closed_dielectric(s, t) && v3_dot(n, n) > 0) tri[k++] = t; /* not the moved water */
  }
  REQUIRE(k > 0);
  uint64_t state = 12345;
  for (long i = 0; i < n; i++) {
    const uint32_t a = tri[next(&state) % k];
    const bbc_vec3 x = point_on(s, a, 0, &state);
    bbc_vec3 d;
    do d = v3(2 * uniform(&state) - 1, 2 * uniform(&state) - 1, 2 * uniform(&state) - 1);
    while (v3_dot(d, d) > 1 || v3_dot(d, d) < 1e-6);
    bbc_hit h;
    if (!bbc_accel_intersect(accel, x, v3_normalize(d), 1e-6, INFINITY, &h)) continue;
    if (h.triangle == a || !closed_dielectric(s, h.triangle)) continue;
    c.segments++;
    /* Embree skips a crossing closer than tmin: one within a micrometre of x, through a
     * neighbour folded against A, makes no true segment. */
    if (bbc__occluders_block(o, a, h.triangle) &&
        !crossings(s, x, v3_madd(x, v3_normalize(d), h.t), a, h.triangle))
      c.wrongly_blocked++;
  }
  for (long i = 0; i < n; i++) {
    const uint32_t a = tri[next(&state) % k], b = tri[next(&state) % k];
    if (a == b || !bbc__occluders_block(o, a, b)) continue;
    c.blocked_pairs++;
    for (int j = 0; j < 4; j++) {
      const bbc_vec3 x = point_on(s, a, 1, &state), y = point_on(s, b, 1, &state);
      c.pair_segments++;
      if (!bbc_accel_occluded(accel, x, v3_sub(y, x), 1e-6, 1 - 1e-6) && !crossings(s, x, y, a, b))
        c.free_in_blocked++;
    }
  }
  free(tri);
  bbc__occluders_free(o);
  bbc_accel_free(accel);
  bbc_scene_free(s);
  *out = c;
}

TEST(true_segments_are_never_blocked) {
  /* The hollow ball (two meshes) and a glass without its water (a vase: one mesh, its
   * inner wall between its near and far sides) have pairs with a surface between; the
   * glass of water has no occluder (the water reaches into the glass: surfaces the path
   * tracer goes through); a solid convex ball has nothing between two of its points. */
  static const struct {
    const char *file;
    int empty_water, occluders, blocks;
  } scenes[] = {{"hollow-sphere-small.gltf", 0, 1, 1},
                {"glass-of-water.gltf", 1, 1, 1},
                {"glass-of-water.gltf", 0, 0, 0},
                {"glass-sphere.gltf", 0, 1, 0}};
  const long n = harness_scale(100000, 2000000);
  for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
    counts c;
    int has;
    check_scene(scenes[i].file, scenes[i].empty_water, n, &c, &has);
    fprintf(stderr,
            "%s%s: %ld true segments, %ld blocked; %ld random pairs blocked, %ld of their %ld "
            "segments free\n",
            scenes[i].file, scenes[i].empty_water ? " without water" : "", c.segments,
            c.wrongly_blocked, c.blocked_pairs, c.free_in_blocked, c.pair_segments);
    CHECK_INT(has, scenes[i].occluders);
    CHECK(c.segments > n / 10);
    CHECK_INT(c.wrongly_blocked, 0);
    CHECK_INT(c.free_in_blocked, 0);
    if (scenes[i].blocks)
      CHECK(c.blocked_pairs > n / 100);
    else
      CHECK_INT(c.blocked_pairs, 0);
  }
}

TEST(control_without_the_box_check_blocks_true_segments) {
  bbc__occlusion_control = 1;
  long wrong = 0;
  for (int empty_water = 0; empty_water < 2; empty_water++) {
    counts c;
    int has;
    check_scene(empty_water ? "glass-of-water.gltf" : "hollow-sphere-small.gltf", empty_water,
                harness_scale(100000, 2000000), &c, &has);
    wrong += c.wrongly_blocked;
  }
  bbc__occlusion_control = 0;
  fprintf(stderr, "control: %ld true segments blocked\n", wrong);
  CHECK(wrong > 0);
}
