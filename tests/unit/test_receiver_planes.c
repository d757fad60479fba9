/* Receiver planes (tuple.h, format-spec Sec. 6.5): a receiver in an axis-aligned plane is
 * one tuple end whatever its tessellation. Oracles: the same casters over a floor of two
 * triangles and over that floor cut into ~3,000 (identical tuples and cell lists, the
 * same image), and true paths traced to the tessellated floor, looked up as the
 * renderer looks up (by the triangle they land on and the point). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "render_fixture.h"
#include "media_internal.h"
#include "vec_internal.h"

static uint32_t floor_mesh(const bbc_scene *s) {
  for (uint32_t m = 0; m < s->mesh_count; m++)
    if (s->meshes[m].role == BBC_ROLE_RECEIVER) return m;
  return UINT32_MAX;
}

/* The floors are planes on y; their plane triangle holds every vertex; one vertex moved
 * off the plane by one ulp makes the mesh a receiver of triangles again. */
TEST(floors_are_planes_holding_their_mesh) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("plane-wavy-mirror-3k.gltf"), NULL) == BBC_OK);
  const uint32_t m = floor_mesh(s);
  REQUIRE(m != UINT32_MAX);
  bbc_mesh *mesh = &s->meshes[m];
  CHECK_INT(mesh->plane, 2);
  CHECK(mesh->triangle_count > 2500);
  const bbc_vec3 *q = mesh->plane_triangle;
  int outside = 0;
  for (uint32_t v = 0; v < mesh->vertex_count; v++) {
    const float *p = s->positions + 3 * (size_t)(mesh->first_vertex + v);
    /* Barycentrics in the plane x, z of the right triangle q0 q1 q2. */
    double b1 = (p[0] - q[0].x) / (q[1].x - q[0].x), b2 = (p[2] - q[0].z) / (q[2].z - q[0].z);
    if (!(p[1] == q[0].y && b1 >= 0 && b2 >= 0 && b1 + b2 <= 1)) outside++;
  }
  CHECK_INT(outside, 0);
  for (uint32_t i = 0; i < s->mesh_count; i++)
    if (s->meshes[i].role != BBC_ROLE_RECEIVER) CHECK_INT(s->meshes[i].plane, 0);
  float *y = &s->positions[3 * (size_t)(mesh->first_vertex + mesh->vertex_count / 2) + 1];
  *y = nextafterf(*y, INFINITY);
  bbc__scene_planes(s);
  CHECK_INT(mesh->plane, 0);
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  REQUIRE(bbc_tuples_find(s, BBC_CHAIN_BIT(BBC_CHAIN_R), &tuples, &count) == BBC_OK);
  CHECK(count > 0);
  for (size_t i = 0; i < count; i++) CHECK(!bbc_receiver_is_plane(tuples[i].receiver));
  free(tuples);
  bbc_scene_free(s);
}

/* The floor's tessellation changes no tuple and no cell list. */
static void same_cache(const char *coarse, const char *fine, uint32_t chains, uint32_t level) {
  fixture a, b;
  REQUIRE(fixture_setup(&a, coarse, chains, level, 0));
  REQUIRE(fixture_setup(&b, fine, chains, level, 0));
  CHECK(b.scene->triangle_count > a.scene->triangle_count + 2500);
  bbc_cache_info ia, ib;
  bbc_cache_get_info(a.cache, &ia);
  bbc_cache_get_info(b.cache, &ib);
  CHECK(ia.tuple_count > 20);
  CHECK_INT(ib.tuple_count, ia.tuple_count);
  CHECK_INT(ib.entry_count, ia.entry_count);
  REQUIRE(ia.tuple_count == ib.tuple_count);
  CHECK(memcmp(bbc_cache_tuples(a.cache), bbc_cache_tuples(b.cache),
               ia.tuple_count * sizeof(bbc_tuple)) == 0);
  const bbc_grid *ga = bbc_cache_grid(a.cache), *gb = bbc_cache_grid(b.cache);
  REQUIRE(ga->cell_count == gb->cell_count);
  bbc_cache_cursor *ca = NULL, *cb = NULL;
  REQUIRE(bbc_cache_cursor_create(&ca, a.cache) == BBC_OK);
  REQUIRE(bbc_cache_cursor_create(&cb, b.cache) == BBC_OK);
  uint64_t differ = 0, listed = 0;
  for (uint64_t c = 0; c < ga->cell_count; c++) {
    const bbc_cache_entry *ea, *eb;
    uint32_t na, nb;
    REQUIRE(bbc_cache_cell(ca, c, &ea, &na) == BBC_OK);
    REQUIRE(bbc_cache_cell(cb, c, &eb, &nb) == BBC_OK);
    listed += na;
    if (na != nb || (na && memcmp(ea, eb, na * sizeof *ea) != 0)) differ++;
  }
  fprintf(stderr, "%s: %u tuples, %llu entries; %u and %u floor triangles\n", coarse,
          ia.tuple_count, (unsigned long long)listed,
          a.scene->meshes[floor_mesh(a.scene)].triangle_count,
          b.scene->meshes[floor_mesh(b.scene)].triangle_count);
  CHECK(listed > 1000);
  CHECK_INT(differ, 0);
  bbc_cache_cursor_free(ca);
  bbc_cache_cursor_free(cb);
  teardown(&a);
  teardown(&b);
}

TEST(tessellation_changes_nothing_r) {
  same_cache(TEST_SCENE("plane-wavy-mirror.gltf"), TEST_SCENE("plane-wavy-mirror-3k.gltf"),
             BBC_CHAIN_BIT(BBC_CHAIN_R), 6);
}

TEST(tessellation_changes_nothing_t) {
  same_cache(TEST_SCENE("plane-pool.gltf"), TEST_SCENE("plane-pool-3k.gltf"),
             BBC_CHAIN_BIT(BBC_CHAIN_T), 6);
}

TEST(tessellation_changes_nothing_tt) {
  same_cache(TEST_SCENE("plane-glass-sphere.gltf"), TEST_SCENE("plane-glass-sphere-3k.gltf"),
             BBC_CHAIN_BIT(BBC_CHAIN_TT), 4);
}

/* True paths to the tessellated floor, looked up as the renderer looks up a point of a
 * plane (bbc_validate_cached_tuple): every one is in a cell listing its tuple with a
 * bound of at least its irradiance. */
static void bounds_hold(const char *path, uint32_t chains, uint32_t level, uint32_t samples) {
  fixture b;
  REQUIRE(fixture_setup(&b, path, chains, level, 0));
  bbc_cache_info info;
  bbc_cache_get_info(b.cache, &info);
  bbc_cache_cursor *cursor = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, b.cache) == BBC_OK);
  bbc_validation v;
  bbc_validation_reset(&v);
  const bbc_tuple *tuples = bbc_cache_tuples(b.cache);
  for (uint32_t i = 0; i < info.tuple_count; i++) {
    CHECK(bbc_receiver_is_plane(tuples[i].receiver));
    REQUIRE(bbc_validate_cached_tuple(b.cache, cursor, b.scene, &tuples[i], i,
                                      samples / info.tuple_count + 1, 7, &v) == BBC_OK);
  }
  fprintf(stderr, "%s: %llu tuples, %llu admissible paths, %llu failing\n", path,
          (unsigned long long)v.tuples, (unsigned long long)v.admissible,
          (unsigned long long)v.failing);
  CHECK(v.admissible > samples / 20);
  CHECK_INT(v.failing, 0);
  bbc_cache_cursor_free(cursor);
  teardown(&b);
}

TEST(tessellated_floor_bounds_hold_r) {
  bounds_hold(TEST_SCENE("plane-wavy-mirror-3k.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 200000);
}

TEST(tessellated_floor_bounds_hold_t) {
  bounds_hold(TEST_SCENE("plane-pool-3k.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_T), 6, 200000);
}

TEST(tessellated_floor_bounds_hold_tt) {
  bounds_hold(TEST_SCENE("plane-glass-sphere-3k.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_TT), 4, 200000);
}

/* The renderer sees the same caustic on both floors: the same cells and tuples, solved at
 * hit points that differ by rounding only. */
TEST(render_is_the_same_on_both_floors) {
  fixture a, b;
  REQUIRE(
      fixture_setup(&a, TEST_SCENE("plane-wavy-mirror.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0));
  REQUIRE(
      fixture_setup(&b, TEST_SCENE("plane-wavy-mirror-3k.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0));
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_BBC;
  o.spp = 4;
  o.components = BBC_COMPONENT_CAUSTICS;
  bbc_image *img[2] = {fixture_render(&a, o, 48, 36, NULL), fixture_render(&b, o, 48, 36, NULL)};
  REQUIRE(img[0] && img[1]);
  double sum[2] = {0, 0}, diff = 0;
  int far = 0;
  const size_t n = 3 * (size_t)48 * 36;
  for (size_t i = 0; i < n; i++) {
    const double x = img[0]->rgb[i], y = img[1]->rgb[i];
    sum[0] += x, sum[1] += y;
    diff += (x - y) * (x - y);
    if (fabs(x - y) > 1e-3 * (fabs(x) + fabs(y)) + 1e-12) far++;
  }
  double norm = 0;
  for (size_t i = 0; i < n; i++) norm += (double)img[0]->rgb[i] * img[0]->rgb[i];
  fprintf(stderr, "means %.9g and %.9g; relative squared difference %.3g; %d values apart\n",
          sum[0] / n, sum[1] / n, diff / norm, far);
  CHECK(sum[0] > 0);
  CHECK(fabs(sum[1] - sum[0]) <= 1e-3 * sum[0]);
  CHECK(diff <= 1e-4 * norm);
  CHECK(far <= (int)(n / 100));
  bbc_image_free(img[0]);
  bbc_image_free(img[1]);
  teardown(&a);
  teardown(&b);
}
