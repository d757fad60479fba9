/* Tests of the .bbc cache (cache_write.c, cache_read.c) and the receiver grids (grid.c)
 * against format-spec/bbc-format.md.
 *
 * Oracles are independent of the code under test: hash vectors from the reference
 * xxhsum, quantisation checked in exact double comparisons, grid cells from the uvs or
 * the geometry directly, splats against dense point sampling, cell contents against the
 * recorded splats, error codes against the corpus file names, merged shard caches
 * against the complete cache written from the same content. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "bbc/cache.h"
#include "bbc/grid.h"
#include "cache_fixtures.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "harness.h"

#define INVALID_DIR SOURCE_PATH("tests/corpus/invalid")

/* ------------------------------------------------------------------ helpers */

typedef struct messages {
  int count;
  bbc_result last_code;
  char last[1024];
} messages;

static void on_message(void *user, bbc_result code, const char *message) {
  messages *m = user;
  m->count++;
  m->last_code = code;
  snprintf(m->last, sizeof m->last, "%s", message);
}

/* Opens and fully validates bytes: the first failure's code, as a reader sees it. */
static bbc_result open_and_validate(const void *bytes, size_t size, messages *m) {
  bbc_cache_options o = {on_message, m, 0};
  bbc_cache *c = NULL;
  bbc_result r = bbc_cache_open_memory(&c, bytes, size, &o);
  if (r == BBC_OK) {
    CHECK(c != NULL);
    r = bbc_cache_validate(c, on_message, m);
  } else {
    CHECK(c == NULL);
  }
  bbc_cache_close(c);
  return r;
}

static bbc_scene *load(const char *path) {
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, NULL) != BBC_OK) return NULL;
  return s;
}

/* ------------------------------------------------------------------ hashing, bounds */

TEST(xxh64_reference_vectors) {
  /* Values printed by the reference `xxhsum -H1` (xxHash 0.8.1). */
  CHECK(bbc__xxh64("", 0) == 0xEF46DB3751D8E999ull);
  CHECK(bbc__xxh64("a", 1) == 0xD24EC4F1A98C6E5Bull);
  CHECK(bbc__xxh64("abc", 3) == 0x44BC2CF5AD770999ull);
  uint8_t data[1000];
  for (int i = 0; i < 1000; i++) data[i] = (uint8_t)(i * 7 + 3);
  CHECK(bbc__xxh64(data, 1000) == 0x5F235FA033F1A3FBull);
  /* Streaming in uneven pieces gives the one-shot value. */
  for (size_t step = 1; step < 70; step += 3) {
    bbc__xxh64_state s;
    bbc__xxh64_init(&s);
    for (size_t at = 0; at < 1000; at += step)
      bbc__xxh64_update(&s, data + at, at + step > 1000 ? 1000 - at : step);
    CHECK(bbc__xxh64_final(&s) == 0x5F235FA033F1A3FBull);
  }
}

TEST(bound_quantisation_rounds_up) {
  CHECK(bbc_cache_quantize_bound(0.0) == 0.0f);
  CHECK(isinf(bbc_cache_quantize_bound(INFINITY)));
  CHECK(isinf(bbc_cache_quantize_bound(3.5e38))); /* above the largest code: +inf */
  CHECK(isnan(bbc_cache_quantize_bound(NAN)));
  CHECK(bbc__bound_encode(INFINITY) == BBC__CODE_INF);
  CHECK(bbc_cache_quantize_bound(1.0) == 1.0f);
  uint64_t state = 42;
  double prev_b = 0;
  float prev_q = 0;
  int violations = 0, loose = 0, unordered = 0;
  for (int i = 0; i < 200000; i++) {
    double b = exp((fx_random(&state) - 0.5) * 120.0); /* 1e-26 .. 1e26 */
    float q = bbc_cache_quantize_bound(b);
    if (!((double)q >= b)) violations++;
    if (!((double)q <= b * (1.0 + 1.0 / 256.0))) loose++;
    /* Monotone: a larger bound never gets a smaller value. */
    if ((b > prev_b && q < prev_q) || (b < prev_b && q > prev_q)) unordered++;
    prev_b = b;
    prev_q = q;
  }
  CHECK_INT(violations, 0);
  CHECK_INT(loose, 0);
  CHECK_INT(unordered, 0);
  /* Subnormal and tiny values stay above the input. */
  CHECK((double)bbc_cache_quantize_bound(1e-44) >= 1e-44);
  CHECK((double)bbc_cache_quantize_bound(1e-300) >= 1e-300);
}

/* ------------------------------------------------------------------ grids */

/* The point of scene triangle t with barycentrics (b1, b2). */
static bbc_vec3 point_on(const bbc_scene *s, uint32_t t, double b1, double b2) {
  bbc_vec3 p[3];
  CHECK(bbc_receiver_triangle(s, t, p));
  const double b0 = 1 - b1 - b2;
  return (bbc_vec3){b0 * p[0].x + b1 * p[1].x + b2 * p[2].x, b0 * p[0].y + b1 * p[1].y + b2 * p[2].y,
                    b0 * p[0].z + b1 * p[1].z + b2 * p[2].z};
}

TEST(grid_texcoord_cells_follow_uvs) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  /* The pool's floor is a receiver plane (Sec. 6.5); as a textured mesh of any shape
   * it would take its uvs. */
  for (uint32_t m = 0; m < scene->mesh_count; m++) scene->meshes[m].plane = 0;
  bbc_grid *g = NULL;
  REQUIRE(bbc_grid_create(&g, scene, 64, NULL, NULL) == BBC_OK);
  CHECK(g->receiver_count >= 1);
  int checked = 0, wrong = 0;
  uint64_t state = 7;
  for (uint32_t ri = 0; ri < g->receiver_count; ri++) {
    const bbc_receiver *r = &g->receivers[ri];
    const bbc_mesh *mesh = &scene->meshes[r->mesh];
    CHECK_INT(mesh->role, BBC_ROLE_RECEIVER);
    CHECK_INT(r->parameterisation, BBC_PARAM_TEXCOORD);
    CHECK_INT(r->width, 64);
    CHECK_INT(r->height, 64);
    for (int sample = 0; sample < 4000; sample++) {
      uint32_t t = r->first_triangle + (uint32_t)(fx_random(&state) * r->triangle_count);
      const uint32_t *idx = &scene->indices[3 * (size_t)t];
      double b1 = fx_random(&state), b2 = fx_random(&state) * (1 - b1);
      /* The oracle: the uv of the point, normalised by the domain, times 64. */
      double uv[2];
      for (int k = 0; k < 2; k++) {
        double a = scene->uvs[2 * idx[0] + k], b = scene->uvs[2 * idx[1] + k],
               c = scene->uvs[2 * idx[2] + k];
        uv[k] = a + b1 * (b - a) + b2 * (c - a);
      }
      double fx = (uv[0] - r->domain[0]) / (r->domain[2] - r->domain[0]) * 64;
      double fy = (uv[1] - r->domain[1]) / (r->domain[3] - r->domain[1]) * 64;
      /* Skip points within rounding distance of a cell border. */
      if (fabs(fx - floor(fx + 0.5)) < 1e-4 || fabs(fy - floor(fy + 0.5)) < 1e-4) continue;
      bbc_cell cell;
      REQUIRE(bbc_grid_locate(g, t, b1, b2, NULL, &cell));
      uint32_t ex = fx >= 64 ? 63 : (uint32_t)fx, ey = fy >= 64 ? 63 : (uint32_t)fy;
      if (cell.receiver != ri || cell.x != ex || cell.y != ey) wrong++;
      checked++;
    }
  }
  CHECK(checked > 100);
  CHECK_INT(wrong, 0);
  /* Triangles of casters are not on any grid. */
  bbc_cell cell;
  for (uint32_t t = 0; t < scene->triangle_count; t++)
    if (scene->meshes[scene->triangle_mesh[t]].role != BBC_ROLE_RECEIVER) {
      CHECK(!bbc_grid_locate(g, t, 0.2, 0.2, NULL, &cell));
      CHECK(bbc_grid_receiver_of(g, t) < 0);
      break;
    }
  bbc_grid_free(g);
  bbc_scene_free(scene);
}

/* A receiver-only scene built in memory: `n` x `n` quads of a height field
 * y = h(x, z), without uvs, rotated by `tilt` radians about the x axis. */
typedef struct field_scene {
  bbc_scene s;
  float *positions, *normals, *uvs;
  uint32_t *indices, *tmesh;
  bbc_mesh mesh;
  bbc_material material;
  bbc_point_light light;
} field_scene;

static void make_field(field_scene *f, int n, double width, double depth, double bump,
                       double tilt) {
  memset(f, 0, sizeof *f);
  uint32_t v = (uint32_t)((n + 1) * (n + 1)), t = (uint32_t)(2 * n * n);
  f->positions = calloc(3 * v, sizeof(float));
  f->normals = calloc(3 * v, sizeof(float));
  f->uvs = calloc(2 * v, sizeof(float));
  f->indices = calloc(3 * t, sizeof(uint32_t));
  f->tmesh = calloc(t, sizeof(uint32_t));
  for (int j = 0; j <= n; j++)
    for (int i = 0; i <= n; i++) {
      double x = width * i / n, z = depth * j / n;
      double y = bump * sin(3.0 * x) * cos(2.0 * z);
      float *p = &f->positions[3 * (j * (n + 1) + i)];
      p[0] = (float)x;
      p[1] = (float)(y * cos(tilt) - z * sin(tilt));
      p[2] = (float)(y * sin(tilt) + z * cos(tilt));
      f->normals[3 * (j * (n + 1) + i) + 1] = 1;
    }
  uint32_t k = 0;
  for (int j = 0; j < n; j++)
    for (int i = 0; i < n; i++) {
      uint32_t a = (uint32_t)(j * (n + 1) + i), b = a + 1, c = a + (uint32_t)n + 1, d = c + 1;
      uint32_t tri[6] = {a, c, b, b, c, d};
      memcpy(&f->indices[3 * k], tri, sizeof tri);
      k += 2;
    }
  f->mesh = (bbc_mesh){"field", 0, v, 0, t, 0, BBC_ROLE_RECEIVER, 1, 0, 0, 1, 0, {{0, 0, 0}}, 0};
  f->material = (bbc_material){
      .name = "floor", .type = BBC_MATERIAL_DIFFUSE, .base_color = {1, 1, 1}, .ior = 1.5f};
  f->light = (bbc_point_light){.position = {0, 5, 0}, .intensity = {1, 1, 1}};
  snprintf(f->s.path, sizeof f->s.path, "field");
  f->s.vertex_count = v;
  f->s.positions = f->positions;
  f->s.normals = f->normals;
  f->s.uvs = f->uvs;
  f->s.triangle_count = t;
  f->s.indices = f->indices;
  f->s.triangle_mesh = f->tmesh;
  f->s.mesh_count = 1;
  f->s.meshes = &f->mesh;
  f->s.material_count = 1;
  f->s.materials = &f->material;
  f->s.point_light_count = 1;
  f->s.point_lights = &f->light;
}

static void free_field(field_scene *f) {
  free(f->positions);
  free(f->normals);
  free(f->uvs);
  free(f->indices);
  free(f->tmesh);
}

TEST(grid_planar_projection_is_isometric) {
  /* A 4 x 1 rectangle tilted by 0.3 rad, no uvs: planar projection, 64 x 16 cells, and
   * the projection keeps distances (cells are squares of side 4/64 on the surface). */
  field_scene f;
  make_field(&f, 8, 4.0, 1.0, 0.0, 0.3);
  bbc_grid *g = NULL;
  REQUIRE(bbc_grid_create(&g, &f.s, 64, NULL, NULL) == BBC_OK);
  REQUIRE(g->receiver_count == 1);
  const bbc_receiver *r = &g->receivers[0];
  CHECK_INT(r->parameterisation, BBC_PARAM_PLANAR);
  CHECK_INT(r->width, 64);
  CHECK(r->height == 16 || r->height == 17); /* ceil(64 * 1/4) up to float rounding */
  /* Axes orthonormal and in the plane (normal (0, cos .3, sin .3) rotated). */
  double n[3] = {0, -sin(0.3) * 0 + cos(0.3), sin(0.3)};
  CHECK_NEAR(
      r->axis_u[0] * r->axis_u[0] + r->axis_u[1] * r->axis_u[1] + r->axis_u[2] * r->axis_u[2], 1.0,
      1e-12);
  CHECK_NEAR(
      r->axis_u[0] * r->axis_v[0] + r->axis_u[1] * r->axis_v[1] + r->axis_u[2] * r->axis_v[2], 0.0,
      1e-12);
  CHECK_NEAR(fabs(r->axis_u[0] * n[0] + r->axis_u[1] * n[1] + r->axis_u[2] * n[2]), 0, 1e-6);
  CHECK_NEAR(fabs(r->axis_v[0] * n[0] + r->axis_v[1] * n[1] + r->axis_v[2] * n[2]), 0, 1e-6);
  double cell = 4.0 / 64;
  int bad = 0;
  for (uint32_t t = 0; t < f.s.triangle_count; t++) {
    const float *gc = &g->triangle_uv[6 * t];
    const uint32_t *idx = &f.indices[3 * t];
    for (int a = 0; a < 3; a++)
      for (int b = a + 1; b < 3; b++) {
        const float *p = &f.positions[3 * idx[a]], *q = &f.positions[3 * idx[b]];
        double d3 = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                         (p[2] - q[2]) * (p[2] - q[2]));
        double d2 = sqrt((gc[2 * a] - gc[2 * b]) * (gc[2 * a] - gc[2 * b]) +
                         (gc[2 * a + 1] - gc[2 * b + 1]) * (gc[2 * a + 1] - gc[2 * b + 1]));
        if (fabs(d2 * cell - d3) > 1e-5) bad++;
      }
  }
  CHECK_INT(bad, 0);
  bbc_grid_free(g);
  free_field(&f);
}

TEST(grid_box_projection_for_curved_meshes) {
  /* A bumpy 3 x 2 field without uvs is not planar: projection on x and z. */
  field_scene f;
  make_field(&f, 12, 3.0, 2.0, 0.2, 0.0);
  bbc_grid *g = NULL;
  REQUIRE(bbc_grid_create(&g, &f.s, 30, NULL, NULL) == BBC_OK);
  const bbc_receiver *r = &g->receivers[0];
  CHECK_INT(r->parameterisation, BBC_PARAM_BOX);
  CHECK(r->axis_u[0] == 1 && r->axis_u[1] == 0 && r->axis_u[2] == 0);
  CHECK(r->axis_v[0] == 0 && r->axis_v[1] == 0 && r->axis_v[2] == 1);
  CHECK_INT(r->width, 30);
  CHECK_INT(r->height, 20);
  /* The cell of a vertex is its (x, z) over the cell size 0.1. */
  int bad = 0;
  for (uint32_t t = 0; t < f.s.triangle_count; t++) {
    bbc_cell c;
    REQUIRE(bbc_grid_locate(g, t, 1.0 / 3, 1.0 / 3, NULL, &c));
    const uint32_t *idx = &f.indices[3 * t];
    double x = 0, z = 0;
    for (int k = 0; k < 3; k++) {
      x += f.positions[3 * idx[k]] / 3.0;
      z += f.positions[3 * idx[k] + 2] / 3.0;
    }
    if (c.x != (uint32_t)(x / 0.1) || c.y != (uint32_t)(z / 0.1)) bad++;
  }
  CHECK_INT(bad, 0);
  bbc_grid_free(g);
  free_field(&f);
  /* A scene without receivers has no grid; a bad resolution is refused. */
  bbc_scene s = fx_tiny_scene();
  CHECK_INT(bbc_grid_create(&g, &s, 0, NULL, NULL), BBC_ERR_INVALID_ARGUMENT);
  CHECK(g == NULL);
  CHECK_INT(bbc_grid_create(&g, &s, 65537, NULL, NULL), BBC_ERR_INVALID_ARGUMENT);
}

/* The brute-force oracle of the splat: every densely sampled point of the box that lies
 * in the triangle is located in a cell of the range. */
static void check_splats(const bbc_grid *g, uint32_t first, uint32_t count, uint64_t seed,
                         int boxes, int *missed, int *tested) {
  uint64_t state = seed;
  for (int i = 0; i < boxes; i++) {
    uint32_t t = first + (uint32_t)(fx_random(&state) * count);
    double c1 = fx_random(&state) * 1.2 - 0.1, c2 = fx_random(&state) * 1.2 - 0.1;
    double h1 = fx_random(&state) * 0.4, h2 = fx_random(&state) * 0.4;
    double lo1 = c1 - h1, hi1 = c1 + h1, lo2 = c2 - h2, hi2 = c2 + h2;
    if (i % 17 == 0) lo1 = -INFINITY;
    if (i % 23 == 0) hi2 = INFINITY;
    if (i % 29 == 0) hi1 = lo1 = c1; /* a degenerate box: a segment */
    bbc_cell_range range;
    int any = bbc_grid_splat_range(g, t, lo1, hi1, lo2, hi2, &range);
    double a0 = lo1 < 0 ? 0 : lo1, a1 = hi1 > 1 ? 1 : hi1;
    double b0 = lo2 < 0 ? 0 : lo2, b1 = hi2 > 1 ? 1 : hi2;
    for (int s = 0; s <= 40; s++)
      for (int u = 0; u <= 40; u++) {
        double p1 = a0 + (a1 - a0) * s / 40.0, p2 = b0 + (b1 - b0) * u / 40.0;
        /* Only points of the box that lie in the triangle are real. */
        if (!(p1 >= 0 && p2 >= 0 && p1 + p2 <= 1 && p1 >= lo1 && p1 <= hi1 && p2 >= lo2 &&
              p2 <= hi2))
          continue;
        bbc_cell cell;
        if (!bbc_grid_locate(g, t, p1, p2, NULL, &cell)) continue;
        (*tested)++;
        if (!any || cell.receiver != range.receiver || cell.x < range.x0 || cell.x > range.x1 ||
            cell.y < range.y0 || cell.y > range.y1)
          (*missed)++;
      }
  }
}

TEST(grid_splat_covers_every_sampled_point) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  bbc_grid *g = NULL;
  REQUIRE(bbc_grid_create(&g, scene, 512, NULL, NULL) == BBC_OK);
  int missed = 0, tested = 0;
  const bbc_receiver *r = &g->receivers[0];
  check_splats(g, r->first_triangle, r->triangle_count, 3, (int)harness_scale(3000, 30000), &missed,
               &tested);
  bbc_grid_free(g);
  bbc_scene_free(scene);
  /* Also the projections, with cells far smaller than the triangles. */
  field_scene f;
  make_field(&f, 6, 3.0, 2.0, 0.2, 0.0);
  REQUIRE(bbc_grid_create(&g, &f.s, 1000, NULL, NULL) == BBC_OK);
  check_splats(g, 0, f.s.triangle_count, 5, (int)harness_scale(2000, 20000), &missed, &tested);
  bbc_grid_free(g);
  free_field(&f);
  CHECK(tested > 100000);
  CHECK_INT(missed, 0);
}

/* The same oracle for polygonal position bounds (bbc_grid_splat_polygon): boxes cut by
 * b1 + b2, b1 - b2 and two random lines; every sampled point of the region that lies in
 * the triangle is located in a listed cell of its row. */
static void check_polygon_splats(const bbc_grid *g, uint32_t first, uint32_t count, uint64_t seed,
                                 int regions, int *missed, int *tested) {
  uint64_t state = seed;
  uint32_t height = 1;
  for (uint32_t i = 0; i < g->receiver_count; i++)
    if (g->receivers[i].height > height) height = g->receivers[i].height;
  uint32_t *x0 = malloc(height * sizeof *x0), *x1 = malloc(height * sizeof *x1);
  REQUIRE(x0 && x1);
  for (int i = 0; i < regions; i++) {
    uint32_t t = first + (uint32_t)(fx_random(&state) * count);
    double c1 = fx_random(&state) * 1.2 - 0.1, c2 = fx_random(&state) * 1.2 - 0.1;
    double h1 = fx_random(&state) * 0.5, h2 = fx_random(&state) * 0.5;
    double region[8] = {c1 - h1, c1 + h1, c2 - h2, c2 + h2, 0, 0, 0, 0};
    double s = c1 + c2, d = c1 - c2, hs = fx_random(&state) * 0.6, hd = fx_random(&state) * 0.6;
    region[4] = s - hs, region[5] = s + hs, region[6] = d - hd, region[7] = d + hd;
    double cut[2][4];
    for (int j = 0; j < 2; j++) {
      double a = fx_random(&state) * 2 - 1, b = fx_random(&state) * 2 - 1;
      double mid = a * c1 + b * c2, half = fx_random(&state) * 0.4;
      cut[j][0] = a, cut[j][1] = b, cut[j][2] = mid - half, cut[j][3] = mid + half;
    }
    if (i % 13 == 0) cut[1][0] = cut[1][1] = 0; /* no second cut */
    if (i % 17 == 0) region[0] = -INFINITY;
    if (i % 19 == 0) region[4] = NAN;
    bbc_cell_range range;
    int any = bbc_grid_splat_polygon(g, t, region, (const double(*)[4])cut, &range, x0, x1);
    for (int si = 0; si <= 60; si++)
      for (int ui = 0; ui <= 60; ui++) {
        double p1 = si / 60.0, p2 = ui / 60.0;
        double q = p1 + p2, e = p1 - p2;
        if (!(p1 + p2 <= 1 && p1 >= region[0] && p1 <= region[1] && p2 >= region[2] &&
              p2 <= region[3] && !(q < region[4]) && q <= region[5] && e >= region[6] &&
              e <= region[7]))
          continue;
        int inside = 1;
        for (int j = 0; j < 2; j++) {
          double v = cut[j][0] * p1 + cut[j][1] * p2;
          if ((cut[j][0] != 0 || cut[j][1] != 0) && !(v >= cut[j][2] && v <= cut[j][3])) inside = 0;
        }
        if (!inside) continue;
        bbc_cell cell;
        if (!bbc_grid_locate(g, t, p1, p2, NULL, &cell)) continue;
        (*tested)++;
        if (!any || cell.receiver != range.receiver || cell.y < range.y0 || cell.y > range.y1 ||
            cell.x < x0[cell.y - range.y0] || cell.x > x1[cell.y - range.y0])
          (*missed)++;
      }
  }
  free(x0);
  free(x1);
}

TEST(grid_polygon_splat_covers_every_sampled_point) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  bbc_grid *g = NULL;
  int missed = 0, tested = 0;
  /* 2048 rows: polygons taller than the row sweep's limit too. */
  const uint32_t resolutions[2] = {512, 2048};
  for (int k = 0; k < 2; k++) {
    REQUIRE(bbc_grid_create(&g, scene, resolutions[k], NULL, NULL) == BBC_OK);
    const bbc_receiver *r = &g->receivers[0];
    check_polygon_splats(g, r->first_triangle, r->triangle_count, 7 + (uint64_t)k,
                         (int)harness_scale(1500, 15000), &missed, &tested);
    bbc_grid_free(g);
  }
  bbc_scene_free(scene);
  field_scene f;
  make_field(&f, 6, 3.0, 2.0, 0.2, 0.0);
  REQUIRE(bbc_grid_create(&g, &f.s, 1000, NULL, NULL) == BBC_OK);
  check_polygon_splats(g, 0, f.s.triangle_count, 11, (int)harness_scale(1500, 15000), &missed,
                       &tested);
  bbc_grid_free(g);
  free_field(&f);
  CHECK(tested > 100000);
  CHECK_INT(missed, 0);
}

TEST(grid_splat_is_tight_and_clipped) {
  bbc_scene s = fx_tiny_scene();
  bbc_grid *g = NULL;
  REQUIRE(bbc_grid_create(&g, &s, 100, NULL, NULL) == BBC_OK);
  /* Triangle 1 is (0,0),(1,1),(1,0) in uv (indices 3,5,4): the box b1 in [0.2,0.3],
   * b2 in [0.1,0.2] maps to u = b1 + b2 in [0.3,0.5], v = b1 in [0.2,0.3]. */
  bbc_cell_range r;
  REQUIRE(bbc_grid_splat_range(g, 1, 0.2, 0.3, 0.1, 0.2, &r));
  CHECK_INT(r.x0, 29); /* 30 - margin rounds down into the neighbour: conservative */
  CHECK_INT(r.x1, 50);
  CHECK_INT(r.y0, 19);
  CHECK_INT(r.y1, 30);
  /* A box entirely outside the triangle covers nothing. */
  CHECK(!bbc_grid_splat_range(g, 1, 0.7, 0.9, 0.7, 0.9, &r));
  CHECK(!bbc_grid_splat_range(g, 1, -0.5, -0.1, 0.2, 0.3, &r));
  /* An unbounded box covers the triangle's own rectangle, not the whole grid. */
  REQUIRE(bbc_grid_splat_range(g, 1, -INFINITY, INFINITY, NAN, NAN, &r));
  CHECK_INT(r.x0, 0);
  CHECK_INT(r.x1, 99);
  CHECK_INT(r.y0, 0);
  CHECK_INT(r.y1, 99);
  /* The caster triangle is not a receiver. */
  CHECK(!bbc_grid_splat_range(g, 0, 0, 1, 0, 1, &r));
  bbc_grid_free(g);
}

/* ------------------------------------------------------------------ round trip */

typedef struct expected_cell {
  uint32_t count, cap;
  bbc_cache_entry *e;
} expected_cell;

static int cmp_entry(const void *a, const void *b) {
  uint32_t x = ((const bbc_cache_entry *)a)->tuple, y = ((const bbc_cache_entry *)b)->tuple;
  return (x > y) - (x < y);
}

/* What every cell must hold, from the recorded splats: per (cell, tuple) the maximum
 * bound, unquantised. */
static expected_cell *expected_cells(const bbc_grid *g, const fx_record *rec) {
  expected_cell *cells = calloc(g->cell_count, sizeof *cells);
  for (size_t i = 0; i < rec->count; i++) {
    const fx_splat *s = &rec->splats[i];
    bbc_cell_range r;
    if (!bbc_grid_splat_range(g, s->triangle, s->b1_lo, s->b1_hi, s->b2_lo, s->b2_hi, &r)) continue;
    for (uint32_t y = r.y0; y <= r.y1; y++)
      for (uint32_t x = r.x0; x <= r.x1; x++) {
        expected_cell *c = &cells[bbc_grid_cell_index(g, (bbc_cell){r.receiver, x, y})];
        uint32_t j = 0;
        while (j < c->count && c->e[j].tuple != s->tuple) j++;
        if (j == c->count) {
          if (c->count == c->cap) {
            c->cap = c->cap ? 2 * c->cap : 8;
            c->e = realloc(c->e, sizeof *c->e * c->cap);
          }
          c->e[c->count++] = (bbc_cache_entry){s->tuple, -1.0f};
        }
        /* Kept as float for the comparison; the bounds here are exact in float. */
        if ((double)c->e[j].bound < s->bound) c->e[j].bound = (float)s->bound;
      }
  }
  for (uint64_t i = 0; i < g->cell_count; i++)
    qsort(cells[i].e, cells[i].count, sizeof *cells[i].e, cmp_entry);
  return cells;
}

static void free_expected(expected_cell *cells, uint64_t n) {
  for (uint64_t i = 0; i < n; i++) free(cells[i].e);
  free(cells);
}

/* Every cell's list equals the expected one: same ids in order, bounds >= the maximum
 * splatted and within the quantisation step. */
static void compare_cells(bbc_cache *c, const expected_cell *want, uint64_t *entries) {
  bbc_cache_cursor *cur = NULL;
  REQUIRE(bbc_cache_cursor_create(&cur, c) == BBC_OK);
  const bbc_grid *g = bbc_cache_grid(c);
  int wrong_count = 0, wrong_id = 0, below = 0, loose = 0;
  *entries = 0;
  for (uint64_t i = 0; i < g->cell_count; i++) {
    const bbc_cache_entry *e;
    uint32_t n;
    REQUIRE(bbc_cache_cell(cur, i, &e, &n) == BBC_OK);
    *entries += n;
    if (n != want[i].count) {
      wrong_count++;
      continue;
    }
    for (uint32_t j = 0; j < n; j++) {
      if (e[j].tuple != want[i].e[j].tuple) wrong_id++;
      double b = want[i].e[j].bound;
      if (!((double)e[j].bound >= b)) below++;
      if (isfinite(b) && !((double)e[j].bound <= b * (1 + 1.0 / 256))) loose++;
    }
  }
  CHECK_INT(wrong_count, 0);
  CHECK_INT(wrong_id, 0);
  CHECK_INT(below, 0);
  CHECK_INT(loose, 0);
  bbc_cache_cursor_free(cur);
}

TEST(round_trip_file_and_memory) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  fx_record rec = {0};
  bbc_cache_builder *b = NULL;
  REQUIRE(fx_synthetic_builder(&b, scene, 64, 11, &rec) == BBC_OK);
  /* A name of this process's own: test suites may run side by side. */
  char path[64];
  snprintf(path, sizeof path, "/tmp/bbc-test-cache-roundtrip-%ld.bbc", (long)getpid());
  bbc_cache_write_options wo;
  memset(&wo, 0, sizeof wo);
  wo.chunk_bytes = 4096; /* many chunks, so the cursor's cache is exercised */
  REQUIRE(bbc_cache_builder_write(b, path, &wo) == BBC_OK);
  void *bytes = NULL;
  size_t size = 0;
  REQUIRE(bbc_cache_builder_write_memory(b, &bytes, &size, &wo) == BBC_OK);
  uint64_t built_entries = bbc_cache_builder_entry_count(b);
  uint32_t tuples = bbc_cache_builder_tuple_count(b);

  expected_cell *want = expected_cells(bbc_cache_builder_grid(b), &rec);
  bbc_cache *from_file = NULL, *from_memory = NULL;
  messages m = {0};
  bbc_cache_options o = {on_message, &m, 0};
  REQUIRE(bbc_cache_open(&from_file, path, &o) == BBC_OK);
  REQUIRE(bbc_cache_open_memory(&from_memory, bytes, size, &o) == BBC_OK);
  for (int which = 0; which < 2; which++) {
    bbc_cache *c = which ? from_memory : from_file;
    bbc_cache_info info;
    bbc_cache_get_info(c, &info);
    CHECK_INT(info.version_major, 1);
    /* The default parameters' two-bounce level (its floor, a receiver plane, is 1.6). */
    CHECK_INT(info.version_minor, BBC__MINOR_DOUBLE_LEVEL);
    CHECK_INT(info.tuple_count, tuples);
    CHECK_INT(info.entry_count, built_entries);
    CHECK(info.chunk_count > 10);
    CHECK_INT(info.scene_triangle_count, scene->triangle_count);
    CHECK_INT(info.params.grid_resolution, 64);
    CHECK_STR_CONTAINS(info.writer, "bbc ");
    uint64_t entries = 0;
    compare_cells(c, want, &entries);
    CHECK_INT(entries, built_entries);
    CHECK(entries > 10000);
    CHECK_INT(bbc_cache_validate(c, on_message, &m), BBC_OK);
    CHECK_INT(bbc_cache_check_scene(c, scene), BBC_OK);
    /* The tuple table is the one added, in order. */
    const bbc_tuple *t = bbc_cache_tuples(c);
    CHECK_INT(t[2].chain, BBC_CHAIN_TT);
    CHECK(t[0].specular[1] == BBC_NO_TRIANGLE);
  }
  CHECK_INT(m.count, 0);
  /* Chunks kept for all cursors (keep_decoded) give the same lists: kept by the
   * validation before any lookup (as bbc-render does), or by the first lookup, with a
   * budget for every chunk and one for about half of them (the rest decoded by the
   * cursor itself). */
  uint64_t decoded_bytes = 0;
  {
    bbc_cache_info info;
    bbc_cache_get_info(from_memory, &info);
    decoded_bytes = info.decoded_bytes;
  }
  CHECK(decoded_bytes > 0);
  for (int variant = 0; variant < 4; variant++) {
    bbc_cache_options ko = o;
    ko.keep_decoded = variant < 2 ? (size_t)decoded_bytes : (size_t)decoded_bytes / 2;
    bbc_cache *c = NULL;
    REQUIRE(bbc_cache_open_memory(&c, bytes, size, &ko) == BBC_OK);
    if (variant % 2 == 0) CHECK_INT(bbc_cache_validate(c, on_message, &m), BBC_OK);
    uint64_t entries = 0;
    compare_cells(c, want, &entries);
    CHECK_INT(entries, built_entries);
    CHECK_INT(bbc_cache_validate(c, on_message, &m), BBC_OK);
    bbc_cache_close(c);
  }
  CHECK_INT(m.count, 0);
  /* The file and the memory image are the same bytes. */
  FILE *f = fopen(path, "rb");
  REQUIRE(f);
  uint8_t *file_bytes = malloc(size + 1);
  size_t got = fread(file_bytes, 1, size + 1, f);
  fclose(f);
  CHECK_INT(got, size);
  CHECK(memcmp(file_bytes, bytes, size) == 0);
  free(file_bytes);

  /* Lookups by point agree with lookups by cell. */
  bbc_cache_cursor *cur = NULL;
  REQUIRE(bbc_cache_cursor_create(&cur, from_file) == BBC_OK);
  uint64_t state = 1;
  int disagree = 0;
  const bbc_grid *g = bbc_cache_grid(from_file);
  for (int i = 0; i < 2000; i++) {
    const bbc_receiver *r = &g->receivers[0];
    uint32_t tri = r->first_triangle + (uint32_t)(fx_random(&state) * r->triangle_count);
    double b1 = fx_random(&state), b2 = fx_random(&state) * (1 - b1);
    bbc_cell cell;
    const bbc_vec3 point = point_on(scene, tri, b1, b2);
    REQUIRE(bbc_grid_locate(g, tri, b1, b2, &point, &cell));
    const bbc_cache_entry *e;
    uint32_t n;
    REQUIRE(bbc_cache_lookup(cur, tri, b1, b2, &point, &e, &n) == BBC_OK);
    uint64_t index = bbc_grid_cell_index(g, cell);
    if (n != want[index].count) disagree++;
  }
  CHECK_INT(disagree, 0);
  const bbc_cache_entry *e;
  uint32_t n = 7;
  CHECK_INT(bbc_cache_cell(cur, g->cell_count, &e, &n), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(n, 0);
  bbc_cache_cursor_free(cur);

  free_expected(want, bbc_cache_builder_grid(b)->cell_count);
  bbc_cache_close(from_file);
  bbc_cache_close(from_memory);
  bbc_cache_builder_free(b);
  free(bytes);
  free(rec.splats);
  unlink(path);
  bbc_scene_free(scene);
}

TEST(max_bound_per_cell_and_tuple) {
  bbc_scene s = fx_tiny_scene();
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = 8;
  p.m = 2.0;
  bbc_cache_builder *b = NULL;
  REQUIRE(bbc_cache_builder_create(&b, &s, &p) == BBC_OK);
  bbc_tuple t = {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 1};
  uint32_t a, c;
  REQUIRE(bbc_cache_builder_add_tuple(b, &t, &a) == BBC_OK);
  REQUIRE(bbc_cache_builder_add_tuple(b, &t, &c) == BBC_OK);
  CHECK_INT(a, 0);
  CHECK_INT(c, 1);
  /* Three pieces of tuple 0 over one point, a fourth elsewhere; tuple 1 once. */
  double pts[4][2] = {{0.3, 0.1}, {0.3, 0.1}, {0.3, 0.1}, {0.9, 0.05}};
  double bounds[4] = {1.0, 3.0, 2.0, 100.0};
  for (int i = 0; i < 4; i++)
    REQUIRE(bbc_cache_builder_splat(b, a, 1, pts[i][0], pts[i][0], pts[i][1], pts[i][1],
                                    bounds[i]) == BBC_OK);
  REQUIRE(bbc_cache_builder_splat(b, c, 1, 0.3, 0.3, 0.1, 0.1, 0.5) == BBC_OK);
  void *bytes;
  size_t size;
  REQUIRE(bbc_cache_builder_write_memory(b, &bytes, &size, NULL) == BBC_OK);
  bbc_cache *cache = NULL;
  REQUIRE(bbc_cache_open_memory(&cache, bytes, size, NULL) == BBC_OK);
  bbc_cache_cursor *cur = NULL;
  REQUIRE(bbc_cache_cursor_create(&cur, cache) == BBC_OK);
  const bbc_cache_entry *e;
  uint32_t n;
  REQUIRE(bbc_cache_lookup(cur, 1, 0.3, 0.1, NULL, &e, &n) == BBC_OK);
  REQUIRE(n == 2);
  CHECK_INT(e[0].tuple, 0);
  CHECK(e[0].bound == 3.0f); /* max(1, 3, 2), stored as given (m is the caller's) */
  CHECK_INT(e[1].tuple, 1);
  CHECK(e[1].bound == 0.5f);
  REQUIRE(bbc_cache_lookup(cur, 1, 0.9, 0.05, NULL, &e, &n) == BBC_OK);
  REQUIRE(n == 1);
  CHECK(e[0].bound == 100.0f);
  /* The caster triangle has no list. */
  REQUIRE(bbc_cache_lookup(cur, 0, 0.3, 0.1, NULL, &e, &n) == BBC_OK);
  CHECK_INT(n, 0);
  bbc_cache_cursor_free(cur);
  bbc_cache_close(cache);
  free(bytes);
  bbc_cache_builder_free(b);
}

TEST(builder_rejects_invalid_input) {
  bbc_scene s = fx_tiny_scene();
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  bbc_cache_builder *b = (bbc_cache_builder *)&s;
  p.grid_resolution = 0;
  CHECK_INT(bbc_cache_builder_create(&b, &s, &p), BBC_ERR_INVALID_ARGUMENT);
  CHECK(b == NULL);
  bbc_precompute_params_default(&p);
  p.alpha_single = NAN;
  CHECK_INT(bbc_cache_builder_create(&b, &s, &p), BBC_ERR_INVALID_ARGUMENT);
  bbc_precompute_params_default(&p);
  p.chains = BBC_CHAIN_BIT(BBC_CHAIN_R);
  REQUIRE(bbc_cache_builder_create(&b, &s, &p) == BBC_OK);
  uint32_t id = 99;
  bbc_tuple bad[] = {
      {1, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 1}, /* no light 1 */
      {0, BBC_CHAIN_TT, {0, 0}, 1},              /* chain not computed */
      {0, BBC_CHAIN_R, {0, 0}, 1},               /* one bounce with a T2 */
      {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 0}, /* receiver is a caster */
      {0, BBC_CHAIN_R, {9, BBC_NO_TRIANGLE}, 1}, /* no triangle 9 */
      {0, 6, {0, BBC_NO_TRIANGLE}, 1},           /* no chain 6 */
  };
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
    CHECK_INT(bbc_cache_builder_add_tuple(b, &bad[i], &id), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_tuple_count(b), 0);
  bbc_tuple t = {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 1};
  REQUIRE(bbc_cache_builder_add_tuple(b, &t, &id) == BBC_OK);
  CHECK_INT(bbc_cache_builder_splat(b, 1, 1, 0, 1, 0, 1, 1.0), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_splat(b, 0, 2, 0, 1, 0, 1, 1.0), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_splat(b, 0, 1, 0, 1, 0, 1, NAN), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_splat(b, 0, 1, 0, 1, 0, 1, -1.0), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_splat(b, 0, 1, 0, 1, 0, 1, INFINITY), BBC_OK);
  CHECK_INT(bbc_cache_builder_splat(b, 0, 1, 5, 6, 5, 6, 1.0), BBC_OK); /* misses: no-op */
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.compression_level = 40;
  void *bytes = NULL;
  size_t size;
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_ERR_INVALID_ARGUMENT);
  CHECK(bytes == NULL);
  messages m = {0};
  o.compression_level = 0;
  o.error_fn = on_message;
  o.user = &m;
  CHECK_INT(bbc_cache_builder_write(b, "/tmp/no/such/dir/x.bbc", &o), BBC_ERR_IO);
  CHECK_STR_CONTAINS(m.last, "x.bbc");
  bbc_cache_builder_free(b);
  bbc_cache_builder_free(NULL);
  /* A scene without receiver meshes cannot have a cache. */
  bbc_scene none = fx_tiny_scene();
  bbc_mesh meshes[2];
  memcpy(meshes, none.meshes, sizeof meshes);
  meshes[1].role = BBC_ROLE_NONE;
  none.meshes = meshes;
  CHECK_INT(bbc_cache_builder_create(&b, &none, &p), BBC_ERR_SCENE);
}

/* ------------------------------------------------------------------ determinism */

/* The recorded splats into a new builder: in their order (0), reversed (1), from four
 * threads (2), or strided and single-threaded with the builder told to spill after
 * every `spill_every` splats (3; *runs receives the runs it wrote). */
static void *write_with_order(const bbc_scene *scene, const fx_record *rec, int order,
                              size_t spill_every, uint32_t *runs, size_t *size) {
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = 64;
  bbc_cache_builder *b = NULL;
  if (bbc_cache_builder_create(&b, scene, &p) != BBC_OK) return NULL;
  /* The tuples of the recorded run, in the same order. */
  bbc_cache_builder *ref = NULL;
  fx_record dummy = {0};
  fx_synthetic_builder(&ref, scene, 64, 11, &dummy);
  free(dummy.splats);
  const bbc_cache_write_options wo = {0};
  void *tmp;
  size_t tmp_size;
  bbc_cache_builder_write_memory(ref, &tmp, &tmp_size, &wo);
  bbc_cache *c = NULL;
  bbc_cache_open_memory(&c, tmp, tmp_size, NULL);
  bbc_cache_info info;
  bbc_cache_get_info(c, &info);
  for (uint32_t i = 0; i < info.tuple_count; i++) {
    uint32_t id;
    bbc_cache_builder_add_tuple(b, &bbc_cache_tuples(c)[i], &id);
  }
  bbc_cache_close(c);
  free(tmp);
  bbc_cache_builder_free(ref);

  size_t n = rec->count;
  long long failures = 0;
  if (order == 0) {
    for (size_t i = 0; i < n; i++) {
      const fx_splat *s = &rec->splats[i];
      failures += bbc_cache_builder_splat(b, s->tuple, s->triangle, s->b1_lo, s->b1_hi, s->b2_lo,
                                          s->b2_hi, s->bound) != BBC_OK;
    }
  } else if (order == 1) {
    for (size_t i = n; i-- > 0;) {
      const fx_splat *s = &rec->splats[i];
      failures += bbc_cache_builder_splat(b, s->tuple, s->triangle, s->b1_lo, s->b1_hi, s->b2_lo,
                                          s->b2_hi, s->bound) != BBC_OK;
    }
  } else if (order == 3) {
    /* A budget of one byte: every spill point writes a run, so a (cell, tuple) may sit
     * in several runs and in memory with different bounds. */
    bbc__cache_builder_set_entry_memory(b, 1);
    for (size_t i = 0; i < n; i++) {
      const fx_splat *s = &rec->splats[(i * 7919) % n];
      failures += bbc_cache_builder_splat(b, s->tuple, s->triangle, s->b1_lo, s->b1_hi, s->b2_lo,
                                          s->b2_hi, s->bound) != BBC_OK;
      if ((i + 1) % spill_every == 0) failures += bbc__cache_builder_spill_if_full(b) != BBC_OK;
    }
  } else {
    /* Interleaved from several threads, each taking a strided share. */
#pragma omp parallel for schedule(dynamic, 7) num_threads(4) reduction(+ : failures)
    for (long long i = 0; i < (long long)n; i++) {
      const fx_splat *s = &rec->splats[(size_t)(i * 7919) % n];
      failures += bbc_cache_builder_splat(b, s->tuple, s->triangle, s->b1_lo, s->b1_hi, s->b2_lo,
                                          s->b2_hi, s->bound) != BBC_OK;
    }
  }
  CHECK_INT(failures, 0);
  if (runs) {
    uint64_t spilled;
    bbc__cache_builder_spill_stats(b, runs, &spilled);
  }
  void *bytes = NULL;
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.chunk_bytes = 8192;
  if (bbc_cache_builder_write_memory(b, &bytes, size, &o) != BBC_OK) bytes = NULL;
  bbc_cache_builder_free(b);
  return bytes;
}

TEST(byte_identical_whatever_the_splat_order) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  fx_record rec = {0};
  bbc_cache_builder *b = NULL;
  REQUIRE(fx_synthetic_builder(&b, scene, 64, 11, &rec) == BBC_OK);
  bbc_cache_builder_free(b);
  REQUIRE(rec.count % 7919 != 0);
  size_t s0, s1, s2;
  void *a = write_with_order(scene, &rec, 0, 0, NULL, &s0);
  void *r = write_with_order(scene, &rec, 1, 0, NULL, &s1);
  void *t = write_with_order(scene, &rec, 2, 0, NULL, &s2);
  REQUIRE(a && r && t);
  CHECK_INT(s0, s1);
  CHECK_INT(s0, s2);
  CHECK(s0 == s1 && memcmp(a, r, s0) == 0);
  CHECK(s0 == s2 && memcmp(a, t, s0) == 0);
  free(a);
  free(r);
  free(t);
  free(rec.splats);
  bbc_scene_free(scene);
}

/* The spill store: lists written out as sorted runs and merged back give the bytes of
 * the in-memory builder (the oracle: no spill, no merge), for a few runs and for a run
 * every few splats, where most lists are joined from many runs. */
TEST(spilled_lists_give_the_same_bytes) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  fx_record rec = {0};
  bbc_cache_builder *b = NULL;
  REQUIRE(fx_synthetic_builder(&b, scene, 64, 11, &rec) == BBC_OK);
  bbc_cache_builder_free(b);
  size_t s0, s1, s2;
  uint32_t few = 0, many = 0;
  void *a = write_with_order(scene, &rec, 0, 0, NULL, &s0);
  void *f = write_with_order(scene, &rec, 3, rec.count / 3, &few, &s1);
  void *m = write_with_order(scene, &rec, 3, 5, &many, &s2);
  REQUIRE(a && f && m);
  /* The control: the spilling builders did spill. */
  CHECK_INT(few, 3);
  CHECK(many > 1000);
  CHECK(s0 == s1 && memcmp(a, f, s0) == 0);
  CHECK(s0 == s2 && memcmp(a, m, s0) == 0);
  free(a);
  free(f);
  free(m);
  free(rec.splats);
  bbc_scene_free(scene);
}

/* A spill file that cannot be created or written fails the spill with BBC_ERR_IO and a
 * line naming the folder and the reason; the builder then refuses to write rather than
 * write a cache that lacks the lost entries. The writes are made to fail by the file
 * size limit (EFBIG), as a full disk would (ENOSPC). */
static void spill_failure(const char *tmpdir, size_t file_limit, const char *reason) {
  bbc_scene *scene = load(TEST_SCENE("pool.gltf"));
  REQUIRE(scene);
  bbc_cache_builder *b = NULL;
  fx_record rec = {0};
  REQUIRE(fx_synthetic_builder(&b, scene, 64, 11, &rec) == BBC_OK);
  free(rec.splats);
  char *old = getenv("TMPDIR") ? strdup(getenv("TMPDIR")) : NULL;
  setenv("TMPDIR", tmpdir, 1);
  struct rlimit saved;
  getrlimit(RLIMIT_FSIZE, &saved);
  void (*handler)(int) = signal(SIGXFSZ, SIG_IGN);
  if (file_limit) {
    struct rlimit l = {file_limit, saved.rlim_max};
    setrlimit(RLIMIT_FSIZE, &l);
  }
  bbc__cache_builder_set_entry_memory(b, 1);
  bbc_result r = bbc__cache_builder_spill_if_full(b);
  setrlimit(RLIMIT_FSIZE, &saved);
  signal(SIGXFSZ, handler);
  if (old) {
    setenv("TMPDIR", old, 1);
    free(old);
  } else {
    unsetenv("TMPDIR");
  }
  CHECK_INT(r, BBC_ERR_IO);
  const char *why = bbc__cache_builder_error(b);
  REQUIRE(why);
  CHECK_STR_CONTAINS(why, tmpdir);
  CHECK_STR_CONTAINS(why, reason);
  messages msg = {0};
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.error_fn = on_message;
  o.user = &msg;
  void *bytes = NULL;
  size_t size = 0;
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_ERR_IO);
  CHECK(bytes == NULL);
  CHECK_STR_CONTAINS(msg.last, reason);
  bbc_cache_builder_free(b);
  bbc_scene_free(scene);
}

TEST(spill_to_a_full_disk_fails_cleanly) {
  spill_failure("/tmp", 4096, strerror(EFBIG));
}

TEST(spill_without_a_folder_fails_cleanly) {
  spill_failure("/nonexistent-bbc-spill-dir", 0, strerror(ENOENT));
}

/* ------------------------------------------------------------------ invalid files */

/* Opening and validating c gives its expected code; every failure says where in one
 * line, naming the file. */
static void check_case(const fx_case *c) {
  messages m = {0};
  bbc_result r = open_and_validate(c->bytes, c->size, &m);
  if (r != c->expected)
    harness_fail(__FILE__, __LINE__, "%s: got %s (%s)", c->name, bbc_result_string(r), m.last);
  if (r != BBC_OK && (m.count < 1 || !strstr(m.last, "(memory)") || strchr(m.last, '\n')))
    harness_fail(__FILE__, __LINE__, "%s: message \"%s\"", c->name, m.last);
}

TEST(invalid_corpus_fails_with_the_named_code) {
  static fx_case cases[128];
  int n = fx_invalid_corpus(cases);
  CHECK(n > 60);
  for (int i = 0; i < n; i++) {
    check_case(&cases[i]);
    free(cases[i].bytes);
  }
}

static bbc_result code_of_name(const char *name) {
  static const struct {
    const char *prefix;
    bbc_result code;
  } codes[] = {{"not_bbc--", BBC_ERR_NOT_BBC},
               {"version_unsupported--", BBC_ERR_VERSION_UNSUPPORTED},
               {"truncated--", BBC_ERR_TRUNCATED},
               {"corrupt--", BBC_ERR_CORRUPT},
               {"checksum--", BBC_ERR_CHECKSUM}};
  for (size_t i = 0; i < sizeof codes / sizeof *codes; i++)
    if (strncmp(name, codes[i].prefix, strlen(codes[i].prefix)) == 0) return codes[i].code;
  return BBC_OK;
}

TEST(invalid_corpus_files_replayed) {
  DIR *d = opendir(INVALID_DIR);
  REQUIRE(d);
  struct dirent *e;
  int files = 0;
  while ((e = readdir(d))) {
    size_t len = strlen(e->d_name);
    if (len < 4 || strcmp(e->d_name + len - 4, ".bbc") != 0) continue;
    bbc_result want = code_of_name(e->d_name);
    if (want == BBC_OK) {
      harness_fail(__FILE__, __LINE__, "%s: no expected code in the name", e->d_name);
      continue;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", INVALID_DIR, e->d_name);
    messages m = {0};
    bbc_cache_options o = {on_message, &m, 0};
    bbc_cache *c = NULL;
    bbc_result r = bbc_cache_open(&c, path, &o);
    if (r == BBC_OK) r = bbc_cache_validate(c, on_message, &m);
    bbc_cache_close(c);
    if (r != want)
      harness_fail(__FILE__, __LINE__, "%s: got %s (%s)", e->d_name, bbc_result_string(r), m.last);
    else if (!strstr(m.last, e->d_name))
      harness_fail(__FILE__, __LINE__, "%s: message does not name the file: %s", e->d_name, m.last);
    files++;
  }
  closedir(d);
  CHECK(files > 60);
}

TEST(random_damage_never_crashes) {
  void *base = NULL;
  size_t size = 0;
  REQUIRE(fx_base_cache(&base, &size) == BBC_OK);
  uint8_t *b = malloc(size);
  uint64_t state = 99;
  long iterations = harness_scale(3000, 100000);
  int unexpected = 0;
  for (long i = 0; i < iterations; i++) {
    memcpy(b, base, size);
    int flips = 1 + (int)(fx_random(&state) * 4);
    for (int k = 0; k < flips; k++) {
      size_t at = (size_t)(fx_random(&state) * size);
      b[at] = (uint8_t)(fx_random(&state) * 256);
    }
    size_t len = i % 5 == 0 ? (size_t)(fx_random(&state) * size) : size;
    messages m = {0};
    bbc_result r = open_and_validate(b, len, &m);
    if (r != BBC_OK && r != BBC_ERR_NOT_BBC && r != BBC_ERR_VERSION_UNSUPPORTED &&
        r != BBC_ERR_TRUNCATED && r != BBC_ERR_CORRUPT && r != BBC_ERR_CHECKSUM)
      unexpected++;
  }
  CHECK_INT(unexpected, 0);
  free(b);
  free(base);
}

/* Every single-byte change of a cache and every truncation is refused by open plus full
 * validation: what bbc-render (which validates before the first pixel) and every
 * bbc-inspect command rely on. Each of the file's bytes is XORed with 0xFF and with 0x01
 * in turn; the count of changes that went unnoticed must be 0. (Open alone, without the
 * validation, accepts 2,020 of them: the chunk data.) */
TEST(every_byte_flip_and_truncation_is_refused) {
  void *base = NULL;
  size_t size = 0;
  REQUIRE(fx_base_cache(&base, &size) == BBC_OK);
  messages m = {0};
  REQUIRE(open_and_validate(base, size, &m) == BBC_OK);
  uint8_t *b = malloc(size);
  REQUIRE(b);
  long flips = 0, accepted = 0, cuts_accepted = 0;
  static const uint8_t masks[2] = {0xFF, 0x01};
  for (size_t at = 0; at < size; at++) {
    for (int k = 0; k < 2; k++) {
      memcpy(b, base, size);
      b[at] ^= masks[k];
      messages mm = {0};
      flips++;
      if (open_and_validate(b, size, &mm) == BBC_OK && accepted++ < 5)
        fprintf(stderr, "byte %zu ^ 0x%02x accepted\n", at, masks[k]);
    }
  }
  for (size_t len = 0; len < size; len++) {
    messages mm = {0};
    if (open_and_validate(base, len, &mm) == BBC_OK && cuts_accepted++ < 5)
      fprintf(stderr, "cut at %zu accepted\n", len);
  }
  fprintf(stderr, "%zu-byte cache: %ld of %ld single-byte changes and %ld of %zu truncations "
          "accepted\n", size, accepted, flips, cuts_accepted, size);
  CHECK_INT(accepted, 0);
  CHECK_INT(cuts_accepted, 0);
  free(b);
  free(base);
}

TEST(unknown_optional_section_and_newer_minor_accepted) {
  void *base = NULL;
  size_t size = 0;
  REQUIRE(fx_base_cache(&base, &size) == BBC_OK);
  fx_file f;
  fx_parse(base, &f);
  memcpy(&fx_find(&f, "INFO")->type, "ZZZZ", 4); /* R-DIR-5: skipped */
  f.minor = 7;                                   /* R-HDR-3: accepted */
  size_t s;
  uint8_t *b = fx_serialize(&f, &s);
  fx_free(&f);
  messages m = {0};
  CHECK_INT(open_and_validate(b, s, &m), BBC_OK);
  bbc_cache *c = NULL;
  REQUIRE(bbc_cache_open_memory(&c, b, s, NULL) == BBC_OK);
  bbc_cache_info info;
  bbc_cache_get_info(c, &info);
  CHECK_INT(info.version_minor, 7);
  CHECK(info.writer[0] == '\0');
  bbc_cache_close(c);
  free(b);
  /* A misaligned copy of a valid file opens too (it is copied). */
  uint8_t *mis = malloc(size + 1);
  memcpy(mis + 1, base, size);
  CHECK_INT(open_and_validate(mis + 1, size, &m), BBC_OK);
  free(mis);
  free(base);
}

/* R-CHK-6: what a reader accepts of the zstd frame beyond what bbc-precompute writes: a
 * content checksum, a Dictionary_ID field holding 0, a frame without the single-segment
 * form; INFO in UTF-8 beyond ASCII (R-INF-1). The controls are the corpus files
 * chunk-frame-content-checksum-mismatch, chunk-frame-needs-dictionary and
 * info-invalid-utf8. */
TEST(frame_variants_and_utf8_info_accepted) {
  void *mini_v = NULL;
  size_t mini_size = 0, s = 0, fn = 0;
  REQUIRE(fx_minimal_cache(&mini_v, &mini_size) == BBC_OK);
  const uint8_t *mini = mini_v;
  uint8_t planes[24] = {0, 0, 0, 0, 0, 0x7F, 0, 0, 0, 0, 0, 0x7F,
                        0, 0, 0, 0, 0, 0x7F, 0, 0, 0, 0, 0, 0x7F};
  messages m = {0};
  uint8_t *b = fx_with_chunk_flags(mini, planes, 24, 4, 1, &s);
  CHECK_INT(open_and_validate(b, s, &m), BBC_OK);
  free(b);
  uint8_t *frame = fx_minimal_frame_with_dict_id(mini, 0, &fn);
  b = fx_with_frame(mini, frame, fn, 4, &s);
  CHECK_INT(open_and_validate(b, s, &m), BBC_OK);
  free(b);
  free(frame);
  /* A frame with a window descriptor and an 8-byte content size (hand-made header). */
  uint64_t csize = 0, off = fx_section_offset(mini, "CDAT", &csize, NULL);
  frame = malloc(csize + 8);
  memcpy(frame, mini + off, 4);
  frame[4] = 0xC0; /* FCS flag 3 (8 bytes), not single segment */
  frame[5] = 0x00; /* window 1 KiB */
  uint64_t content = 24;
  memcpy(frame + 6, &content, 8);
  memcpy(frame + 14, mini + off + 6, csize - 6); /* the blocks */
  b = fx_with_frame(mini, frame, csize + 8, 4, &s);
  CHECK_INT(open_and_validate(b, s, &m), BBC_OK);
  free(b);
  free(frame);
  /* INFO with a two-, three- and four-byte character. */
  void *base = NULL;
  size_t size = 0;
  REQUIRE(fx_base_cache(&base, &size) == BBC_OK);
  fx_file f;
  fx_parse(base, &f);
  static const char text[] = "bbc \xC3\xA9t\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80";
  fx_replace(fx_find(&f, "INFO"), text, sizeof text - 1);
  b = fx_serialize(&f, &s);
  fx_free(&f);
  CHECK_INT(open_and_validate(b, s, &m), BBC_OK);
  free(b);
  free(base);
  free(mini_v);
}

TEST(validate_reports_every_damaged_chunk) {
  void *base = NULL;
  size_t size = 0;
  REQUIRE(fx_base_cache(&base, &size) == BBC_OK);
  uint8_t *b = base;
  uint64_t cdat_size, cdat = fx_section_offset(b, "CDAT", &cdat_size, NULL);
  uint64_t chnk = fx_section_offset(b, "CHNK", NULL, NULL);
  REQUIRE(cdat && chnk);
  /* Damage the first byte of chunks 0 and 2. */
  b[cdat + fx_ld64(b + chnk)] ^= 0xFF;
  b[cdat + fx_ld64(b + chnk + 48)] ^= 0xFF;
  /* Without kept chunks, with them (lookups first), and with them after a validation
   * (as bbc-render does): a damaged chunk is never kept, so every lookup in it fails. */
  for (int variant = 0; variant < 3; variant++) {
    messages m = {0};
    bbc_cache_options o = {on_message, &m, variant ? (size_t)1 << 30 : 0};
    bbc_cache *c = NULL;
    REQUIRE(bbc_cache_open_memory(&c, b, size, &o) == BBC_OK);
    if (variant == 2) {
      messages v = {0};
      CHECK_INT(bbc_cache_validate(c, on_message, &v), BBC_ERR_CHECKSUM);
      CHECK_INT(v.count, 3);
    }
    /* A lookup in the damaged chunk fails with the checksum error; others work. */
    bbc_cache_cursor *cur = NULL;
    REQUIRE(bbc_cache_cursor_create(&cur, c) == BBC_OK);
    const bbc_grid *g = bbc_cache_grid(c);
    int checksum = 0, ok = 0;
    for (int pass = 0; pass < 2; pass++)
      for (uint64_t i = 0; i < g->cell_count; i++) {
        const bbc_cache_entry *e;
        uint32_t n;
        bbc_result r = bbc_cache_cell(cur, i, &e, &n);
        if (r == BBC_ERR_CHECKSUM) checksum++;
        if (r == BBC_OK && n > 0) ok++;
      }
    CHECK(checksum > 0 && checksum % 2 == 0);
    CHECK(ok > 0 && ok % 2 == 0);
    CHECK_STR_CONTAINS(m.last, "R-CHK-3");
    bbc_cache_cursor_free(cur);
    messages v = {0};
    CHECK_INT(bbc_cache_validate(c, on_message, &v), BBC_ERR_CHECKSUM);
    CHECK_INT(v.count, 3); /* the CDAT section and the two chunks */
    bbc_cache_close(c);
  }
  free(base);
}

TEST(open_reports_io_errors) {
  messages m = {0};
  bbc_cache_options o = {on_message, &m, 0};
  bbc_cache *c = (bbc_cache *)&m;
  CHECK_INT(bbc_cache_open(&c, "/tmp/no-such-file.bbc", &o), BBC_ERR_IO);
  CHECK(c == NULL);
  CHECK_STR_CONTAINS(m.last, "no-such-file.bbc");
  CHECK_INT(bbc_cache_open(&c, "/tmp", &o), BBC_ERR_IO);
  bbc_cache_close(NULL);
  bbc_cache_cursor_free(NULL);
}

/* ------------------------------------------------------------------ scene checks */

TEST(check_scene_rejects_another_scene_or_parameters) {
  bbc_scene *pool = load(TEST_SCENE("pool.gltf"));
  bbc_scene *sphere = load(TEST_SCENE("glass-sphere.gltf"));
  REQUIRE(pool && sphere);
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = 16;
  bbc_cache_builder *b = NULL;
  REQUIRE(bbc_cache_builder_create(&b, pool, &p) == BBC_OK);
  void *bytes;
  size_t size;
  REQUIRE(bbc_cache_builder_write_memory(b, &bytes, &size, NULL) == BBC_OK);
  bbc_cache_builder_free(b);
  messages m = {0};
  bbc_cache_options o = {on_message, &m, 0};
  bbc_cache *c = NULL;
  REQUIRE(bbc_cache_open_memory(&c, bytes, size, &o) == BBC_OK);
  CHECK_INT(bbc_cache_check_scene(c, pool), BBC_OK);
  CHECK_INT(bbc_cache_check_params(c, &p), BBC_OK);
  CHECK_INT(m.count, 0);
  CHECK_INT(bbc_cache_check_scene(c, sphere), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "geometry");
  CHECK_STR_CONTAINS(m.last, "glass-sphere.gltf");

  /* The same geometry with a moved light, then with another material. */
  bbc_point_light moved = pool->point_lights[0];
  bbc_point_light *saved_lights = pool->point_lights;
  moved.position.y += 0.5;
  pool->point_lights = &moved;
  CHECK_INT(bbc_cache_check_scene(c, pool), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "point lights");
  pool->point_lights = saved_lights;
  float ior = pool->materials[0].ior;
  pool->materials[0].ior = ior + 0.1f;
  CHECK_INT(bbc_cache_check_scene(c, pool), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "materials");
  pool->materials[0].ior = ior;
  bbc_role role = pool->meshes[0].role;
  pool->meshes[0].role = BBC_ROLE_NONE;
  CHECK_INT(bbc_cache_check_scene(c, pool), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "roles");
  pool->meshes[0].role = role;
  CHECK_INT(bbc_cache_check_scene(c, pool), BBC_OK);

  /* Same scene, other parameters. */
  bbc_precompute_params q = p;
  q.max_level = 4;
  CHECK_INT(bbc_cache_check_params(c, &q), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "max_level 10, expected 4");
  /* The two-bounce level (3 by default): its own, or max_level where it is 0. */
  bbc_cache_info stored;
  bbc_cache_get_info(c, &stored);
  CHECK_INT((int)stored.params.max_level_double, 3);
  CHECK_INT((int)stored.version_minor, 9); /* R-HDR-3: the field is a 1.9 feature */
  q = p;
  q.max_level_double = 0;
  CHECK_INT(bbc_cache_check_params(c, &q), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "max_level_double 3, expected 10");
  q.max_level = 3;
  q.max_level_double = 3;
  CHECK_INT(bbc_cache_check_params(c, &q), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "max_level 10, expected 3");
  q = p;
  q.sigma = 2e-4;
  CHECK_INT(bbc_cache_check_params(c, &q), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "sigma");
  /* The fingerprints differ too, so a stored fingerprint tells them apart. */
  bbc_fingerprint f1, f2;
  REQUIRE(bbc_fingerprint_compute(pool, &p, &f1) == BBC_OK);
  REQUIRE(bbc_fingerprint_compute(pool, &q, &f2) == BBC_OK);
  CHECK(f1.total != f2.total);
  CHECK(f1.geometry == f2.geometry);
  bbc_cache_info info;
  bbc_cache_get_info(c, &info);
  CHECK(info.fingerprint.total == f1.total);

  bbc_cache_close(c);
  free(bytes);
  bbc_scene_free(pool);
  bbc_scene_free(sphere);
}

/* ------------------------------------------------------------------ layout measurement */

/* Synthetic cell lists shaped like a caustic precomputation (for the rationale of spec
 * Appendix B): a 512 x 512 receiver, a 96 x 96 caster grid whose tuples are numbered in
 * caster order and focus through a lens (footprints move smoothly with the id and
 * shrink near the focus), several pieces per tuple with smooth bounds, a few +inf. */
static void synthetic_lists(uint32_t ***ids, uint16_t ***codes, uint32_t **counts) {
  const int res = 512, caster = 96;
  uint32_t *count = calloc((size_t)res * res, sizeof *count);
  uint32_t **id = calloc((size_t)res * res, sizeof *id);
  uint16_t **code = calloc((size_t)res * res, sizeof *code);
  uint32_t *cap = calloc((size_t)res * res, sizeof *cap);
  uint64_t state = 5;
  for (int j = 0; j < caster; j++)
    for (int i = 0; i < caster; i++) {
      uint32_t tuple = (uint32_t)(j * caster + i);
      double x = (i + 0.5) / caster - 0.5, z = (j + 0.5) / caster - 0.5;
      double r2 = x * x + z * z, focus = 0.35 + 0.65 * fabs(r2 - 0.08) / 0.42;
      double cx = 256 + 400 * x * focus, cz = 256 + 400 * z * focus;
      double half = 1.5 + 6 * focus;
      double e = 1.0 / (focus * focus + 1e-3);
      int pieces = 2 + (int)(fx_random(&state) * 4);
      for (int k = 0; k < pieces; k++) {
        double ox = (fx_random(&state) - 0.5) * half, oz = (fx_random(&state) - 0.5) * half;
        int x0 = (int)(cx + ox - half / 2), x1 = (int)(cx + ox + half / 2);
        int z0 = (int)(cz + oz - half / 2), z1 = (int)(cz + oz + half / 2);
        double bound = (tuple % 211 == 0 && k == 0) ? INFINITY : e * (1 + 0.3 * k);
        uint16_t c = bbc__bound_encode(bound);
        for (int zz = z0 < 0 ? 0 : z0; zz <= z1 && zz < res; zz++)
          for (int xx = x0 < 0 ? 0 : x0; xx <= x1 && xx < res; xx++) {
            size_t cell = (size_t)zz * res + xx;
            uint32_t n = count[cell];
            if (n && id[cell][n - 1] == tuple) {
              if (c > code[cell][n - 1]) code[cell][n - 1] = c;
              continue;
            }
            if (n == cap[cell]) {
              cap[cell] = cap[cell] ? 2 * cap[cell] : 8;
              id[cell] = realloc(id[cell], sizeof **id * cap[cell]);
              code[cell] = realloc(code[cell], sizeof **code * cap[cell]);
            }
            id[cell][n] = tuple;
            code[cell][n] = c;
            count[cell] = n + 1;
          }
      }
    }
  free(cap);
  *ids = id;
  *codes = code;
  *counts = count;
}

TEST(layout_compression_ratios) {
  uint32_t **ids, *counts;
  uint16_t **codes;
  synthetic_lists(&ids, &codes, &counts);
  const size_t cells = 512 * 512, target = BBC__DEFAULT_CHUNK_BYTES / 6;
  size_t total = 0;
  for (size_t i = 0; i < cells; i++) total += counts[i];
  uint32_t *delta = malloc(sizeof *delta * total);
  uint16_t *code = malloc(sizeof *code * total);
  size_t at = 0;
  for (size_t i = 0; i < cells; i++)
    for (uint32_t j = 0; j < counts[i]; j++, at++) {
      delta[at] = j == 0 ? ids[i][0] : ids[i][j] - ids[i][j - 1] - 1;
      code[at] = codes[i][j];
    }
  /* Chunks of about `target` entries, cut at cell boundaries as the writer does. */
  uint8_t *raw = malloc(6 * (target + 4096) * 2),
          *out = malloc(ZSTD_compressBound(6 * (target + 4096) * 2));
  const int levels[2] = {3, 9};
  size_t compressed[2][3] = {{0}};
  size_t start = 0, cell = 0;
  while (cell < cells) {
    size_t n = 0;
    while (cell < cells && (n == 0 || n + counts[cell] <= target)) n += counts[cell++];
    const uint32_t *d = delta + start;
    const uint16_t *c = code + start;
    for (int l = 0; l < 2; l++) {
      /* Row-interleaved records: the format's layout. */
      bbc__cache_encode_records(d, c, n, raw);
      compressed[l][0] +=
          bbc__cache_compress(out, ZSTD_compressBound(6 * n), raw, 6 * n, levels[l]);
      /* Byte-shuffled columns: byte k of every delta, then byte k of every code. */
      for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 4; k++) raw[k * n + i] = (uint8_t)(d[i] >> (8 * k));
        raw[4 * n + i] = (uint8_t)c[i];
        raw[5 * n + i] = (uint8_t)(c[i] >> 8);
      }
      compressed[l][1] +=
          bbc__cache_compress(out, ZSTD_compressBound(6 * n), raw, 6 * n, levels[l]);
      /* Columns without byte shuffling: all deltas, then all codes. */
      memcpy(raw, d, 4 * n);
      memcpy(raw + 4 * n, c, 2 * n);
      compressed[l][2] +=
          bbc__cache_compress(out, ZSTD_compressBound(6 * n), raw, 6 * n, levels[l]);
    }
    start += n;
  }
  double decoded = 6.0 * (double)total;
  for (int l = 0; l < 2; l++)
    fprintf(stderr,
            "layout: %zu entries, %.1f MB decoded; zstd %d: row %.2fx, column %.2fx, "
            "byte-shuffled column %.2fx\n",
            total, decoded / 1e6, levels[l], decoded / (double)compressed[l][0],
            decoded / (double)compressed[l][2], decoded / (double)compressed[l][1]);
  /* The format's choice must stay the better one on this data. */
  CHECK(compressed[1][0] < compressed[1][1]);
  CHECK(compressed[1][0] < compressed[1][2]);
  for (size_t i = 0; i < cells; i++) {
    free(ids[i]);
    free(codes[i]);
  }
  free(ids);
  free(codes);
  free(counts);
  free(delta);
  free(code);
  free(raw);
  free(out);
}

/* ------------------------------------------------------------------ shards */

/* A synthetic sharded precompute on a real scene, without the bounder: candidates are
 * (light 0, R, caster triangle, receiver triangle) in a fixed order, a fixed
 * pseudo-random two thirds of them are "stored", and the splats of candidate k depend
 * on k alone. The complete cache written from all candidates is the oracle the merge
 * of the shard caches must reproduce byte for byte. */
typedef struct shard_setup {
  bbc_scene *scene;
  bbc_tuple *candidates;
  size_t count;
  uint32_t resolution;
} shard_setup;

static int shard_setup_init(shard_setup *s) {
  memset(s, 0, sizeof *s);
  s->resolution = 24;
  s->scene = load(TEST_SCENE("pool.gltf"));
  if (!s->scene) return 0;
  const bbc_scene *sc = s->scene;
  s->candidates = malloc(sizeof *s->candidates * sc->triangle_count * 4);
  for (uint32_t t = 0; t < sc->triangle_count && s->count < 120; t++) {
    if (sc->meshes[sc->triangle_mesh[t]].role != BBC_ROLE_CASTER) continue;
    for (uint32_t r = 0; r < sc->triangle_count; r++) {
      const uint32_t m = sc->triangle_mesh[r];
      if (sc->meshes[m].role != BBC_ROLE_RECEIVER) continue;
      /* A receiver plane's tuples end on the plane: one candidate per plane. */
      if (sc->meshes[m].plane && r != sc->meshes[m].first_triangle) continue;
      const uint32_t end = sc->meshes[m].plane ? BBC_RECEIVER_PLANE(m) : r;
      s->candidates[s->count++] = (bbc_tuple){0, BBC_CHAIN_R, {t, BBC_NO_TRIANGLE}, end};
    }
  }
  return s->count >= 120;
}

static void shard_setup_free(shard_setup *s) {
  free(s->candidates);
  bbc_scene_free(s->scene);
}

static int candidate_stored(size_t k) {
  return ((uint64_t)k * 2654435761u >> 7) % 3 != 0;
}

/* Writes the cache of the candidates, complete (shards 0) or shard index/shards. */
static bbc_result write_candidates(const shard_setup *s, uint32_t index, uint32_t shards,
                                   int omit_info, void **bytes, size_t *size) {
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = s->resolution;
  bbc_cache_builder *b = NULL;
  bbc_result r = bbc_cache_builder_create(&b, s->scene, &p);
  if (r != BBC_OK) return r;
  bbc_tuple *work = malloc(sizeof *work * s->count);
  memcpy(work, s->candidates, sizeof *work * s->count);
  size_t n = s->count;
  uint64_t *k = NULL;
  if (shards) r = bbc__cache_builder_shard(b, index, shards, work, &n, &k);
  for (size_t i = 0; i < n && r == BBC_OK; i++) {
    size_t cand = shards ? k[i] : i;
    if (!candidate_stored(cand)) continue;
    uint32_t id;
    r = bbc_cache_builder_add_tuple(b, &work[i], &id);
    if (r == BBC_OK && shards) r = bbc__cache_builder_set_candidate(b, id, cand);
    uint64_t state = cand + 1;
    for (int piece = 0; piece < 3 && r == BBC_OK; piece++) {
      double c1 = fx_random(&state) * 0.8, c2 = fx_random(&state) * (0.9 - c1);
      double h = 0.05 + 0.3 * fx_random(&state);
      double bound = cand % 37 == 5 && piece == 0 ? INFINITY : 0.5 + fx_random(&state);
      r = bbc_cache_builder_splat(b, id, work[i].receiver, c1 - h, c1 + h, c2 - h, c2 + h, bound);
    }
  }
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.omit_info = omit_info;
  o.chunk_bytes = 600; /* several chunks */
  if (r == BBC_OK) r = bbc_cache_builder_write_memory(b, bytes, size, &o);
  free(k);
  free(work);
  bbc_cache_builder_free(b);
  return r;
}

/* Opens and merges shard files given as bytes; the merged file in *bytes. */
static bbc_result merge_bytes(void *const *shard_bytes, const size_t *shard_sizes, size_t n,
                              int threads, messages *m, void **bytes, size_t *size) {
  bbc_cache **c = calloc(n, sizeof *c);
  bbc_cache_options co = {on_message, m, 0};
  bbc_result r = BBC_OK;
  for (size_t i = 0; i < n && r == BBC_OK; i++)
    r = bbc_cache_open_memory(&c[i], shard_bytes[i], shard_sizes[i], &co);
  bbc_cache_builder *b = NULL;
  bbc_cache_merge_options mo;
  memset(&mo, 0, sizeof mo);
  mo.error_fn = on_message;
  mo.user = m;
  mo.threads = threads;
  if (r == BBC_OK) r = bbc_cache_merge(&b, (const bbc_cache *const *)c, n, &mo);
  for (size_t i = 0; i < n; i++) bbc_cache_close(c[i]);
  free(c);
  /* The chunk size of write_candidates; INFO as the shards have it. */
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.chunk_bytes = 600;
  if (r == BBC_OK) r = bbc_cache_builder_write_memory(b, bytes, size, &o);
  bbc_cache_builder_free(b);
  return r;
}

TEST(merged_shards_equal_the_complete_cache) {
  shard_setup s;
  REQUIRE(shard_setup_init(&s));
  const uint32_t splits[] = {1, 2, 3, 7, 150}; /* 150: more shards than candidates */
  for (int omit = 0; omit < 2; omit++) {
    void *full = NULL;
    size_t full_size = 0;
    REQUIRE(write_candidates(&s, 0, 0, omit, &full, &full_size) == BBC_OK);
    for (size_t k = 0; k < sizeof splits / sizeof *splits; k++) {
      uint32_t n = splits[k];
      if (omit && n != 3) continue; /* without INFO, one split is enough */
      void **bytes = calloc(n, sizeof *bytes);
      size_t *sizes = calloc(n, sizeof *sizes);
      /* The shards in reverse order: the merge sorts them. */
      for (uint32_t i = 0; i < n; i++)
        CHECK_INT(write_candidates(&s, n - 1 - i, n, omit, &bytes[i], &sizes[i]), BBC_OK);
      for (int threads = 1; threads <= 3; threads += 2) {
        messages m = {0};
        void *merged = NULL;
        size_t merged_size = 0;
        CHECK_INT(merge_bytes(bytes, sizes, n, threads, &m, &merged, &merged_size), BBC_OK);
        if (merged_size != full_size || memcmp(merged, full, full_size) != 0)
          harness_fail(__FILE__, __LINE__,
                       "%u shards, %d threads, INFO %s: merged (%zu bytes) "
                       "differs from the complete cache (%zu bytes)",
                       n, threads, omit ? "omitted" : "kept", merged_size, full_size);
        CHECK_INT(m.count, 0);
        free(merged);
      }
      for (uint32_t i = 0; i < n; i++) free(bytes[i]);
      free(bytes);
      free(sizes);
    }
    free(full);
  }
  shard_setup_free(&s);
}

TEST(shard_section_is_read_back) {
  shard_setup s;
  REQUIRE(shard_setup_init(&s));
  void *bytes = NULL, *full = NULL;
  size_t size = 0, full_size = 0;
  REQUIRE(write_candidates(&s, 2, 5, 0, &bytes, &size) == BBC_OK);
  REQUIRE(write_candidates(&s, 0, 0, 0, &full, &full_size) == BBC_OK);
  messages m = {0};
  CHECK_INT(open_and_validate(bytes, size, &m), BBC_OK);
  bbc_cache *c = NULL, *f = NULL;
  REQUIRE(bbc_cache_open_memory(&c, bytes, size, NULL) == BBC_OK);
  REQUIRE(bbc_cache_open_memory(&f, full, full_size, NULL) == BBC_OK);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  /* The default two-bounce level (a receiver plane alone: 1.6, 1.1 without it). */
  CHECK_INT(in.version_minor, BBC__MINOR_DOUBLE_LEVEL);
  bbc_cache_shard sh;
  CHECK_INT(bbc_cache_get_shard(c, &sh), 1);
  CHECK_INT(sh.index, 2);
  CHECK_INT(sh.count, 5);
  CHECK_INT(sh.candidate_count, s.count);
  CHECK(sh.candidates_hash == bbc__xxh64(s.candidates, sizeof *s.candidates * s.count));
  /* The stored tuples are the candidates 2, 7, 12, ... that are stored, in order. */
  uint32_t expect = 0;
  for (size_t k = 2; k < s.count; k += 5)
    if (candidate_stored(k)) {
      if (expect < in.tuple_count) {
        CHECK_INT(sh.candidates[expect], k);
        CHECK(memcmp(&bbc_cache_tuples(c)[expect], &s.candidates[k], sizeof(bbc_tuple)) == 0);
      }
      expect++;
    }
  CHECK_INT(in.tuple_count, expect);
  /* A complete cache has no SHRD. */
  bbc_cache_get_info(f, &in);
  CHECK_INT(in.version_minor, BBC__MINOR_DOUBLE_LEVEL);
  CHECK_INT(bbc_cache_get_shard(f, &sh), 0);
  CHECK(sh.candidates == NULL && sh.count == 0);
  CHECK_INT(bbc_cache_get_shard(f, NULL), 0);
  bbc_cache_close(c);
  bbc_cache_close(f);
  free(bytes);
  free(full);
  shard_setup_free(&s);
}

TEST(writer_refuses_a_shard_without_candidate_indices) {
  shard_setup s;
  REQUIRE(shard_setup_init(&s));
  bbc_precompute_params p;
  bbc_precompute_params_default(&p);
  p.grid_resolution = 8;
  bbc_cache_builder *b = NULL;
  REQUIRE(bbc_cache_builder_create(&b, s.scene, &p) == BBC_OK);
  bbc_tuple *work = malloc(sizeof *work * s.count);
  memcpy(work, s.candidates, sizeof *work * s.count);
  size_t n = s.count;
  uint64_t *k = NULL;
  CHECK_INT(bbc__cache_builder_shard(b, 3, 3, work, &n, &k), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc__cache_builder_shard(b, 0, 0, work, &n, &k), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(n, s.count);
  REQUIRE(bbc__cache_builder_shard(b, 1, 2, work, &n, &k) == BBC_OK);
  CHECK_INT(n, s.count / 2);
  uint32_t id0, id1;
  REQUIRE(bbc_cache_builder_add_tuple(b, &work[0], &id0) == BBC_OK);
  REQUIRE(bbc_cache_builder_add_tuple(b, &work[1], &id1) == BBC_OK);
  messages m = {0};
  bbc_cache_write_options o;
  memset(&o, 0, sizeof o);
  o.error_fn = on_message;
  o.user = &m;
  void *bytes = NULL;
  size_t size = 0;
  /* No candidate index, then a wrong residue, then decreasing ones: R-SHR-3. */
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_ERR_INVALID_ARGUMENT);
  CHECK_STR_CONTAINS(m.last, "R-SHR-3");
  CHECK_INT(bbc__cache_builder_set_candidate(b, id0, 1), BBC_OK);
  CHECK_INT(bbc__cache_builder_set_candidate(b, id1, 4), BBC_OK);
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc__cache_builder_set_candidate(b, id0, 3), BBC_OK);
  CHECK_INT(bbc__cache_builder_set_candidate(b, id1, 1), BBC_OK);
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc__cache_builder_set_candidate(b, id1, 5), BBC_OK);
  CHECK_INT(bbc__cache_builder_set_candidate(b, 7, 9), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_cache_builder_write_memory(b, &bytes, &size, &o), BBC_OK);
  free(bytes);
  free(k);
  free(work);
  bbc_cache_builder_free(b);
  shard_setup_free(&s);
}

/* Shard files that break one rule of spec Sec. 5.10 each (with valid checksums, through
 * the re-layout of cache_fixtures.h), named like the invalid corpus. */
static int shard_invalid_cases(fx_case *cases) {
  void *base_v = NULL;
  size_t size = 0;
  shard_setup s;
  if (!shard_setup_init(&s)) return 0;
  /* Small files: 16 candidates, a 4 x 4 grid, no INFO (no version text in the corpus). */
  s.count = 16;
  s.resolution = 4;
  bbc_result wr = write_candidates(&s, 1, 3, 1, &base_v, &size);
  shard_setup_free(&s);
  if (wr != BBC_OK) return 0;
  const uint8_t *base = base_v;
  uint64_t shrd_size = 0;
  /* The edits below need at least two tuples. */
  if (!fx_section_offset(base, "SHRD", &shrd_size, NULL) || shrd_size < 48) {
    free(base_v);
    return 0;
  }
  int n = 0;
  uint8_t *b;
  size_t sz;
  fx_file f;
  fx_section *sec;
#define SHARD_EDIT(code, label, ...)       \
  do {                                     \
    fx_parse(base, &f);                    \
    sec = fx_find(&f, "SHRD");             \
    __VA_ARGS__;                           \
    b = fx_serialize(&f, &sz);             \
    fx_free(&f);                           \
    fx_add(cases, &n, code, label, b, sz); \
  } while (0)
  /* R-DIR-4: SHRD is optional. */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-section-marked-required", sec->flags = 1);
  /* R-SEC-1: head and whole entries. */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-section-shorter-than-head", sec->size = 24);
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-section-not-whole-entries", sec->size -= 3);
  /* R-SHR-1: one entry per tuple. */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-entries-not-tuple-count", sec->size -= 8);
  /* R-FILE-2 */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-nonzero-reserved", sec->data[28] = 1);
  /* R-SHR-2 */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-index-not-below-count", fx_st32(sec->data, 3));
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-count-zero", {
    fx_st32(sec->data, 0);
    fx_st32(sec->data + 4, 0);
  });
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-fewer-candidates-than-tuples", fx_st64(sec->data + 8, 2));
  /* R-SHR-3 */
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-candidates-not-increasing", {
    uint64_t a = fx_ld64(sec->data + 32), c = fx_ld64(sec->data + 40);
    fx_st64(sec->data + 32, c);
    fx_st64(sec->data + 40, a);
  });
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-candidate-of-another-shard",
             fx_st64(sec->data + 32, fx_ld64(sec->data + 32) - 1));
  SHARD_EDIT(BBC_ERR_CORRUPT, "shard-candidate-past-list",
             fx_st64(sec->data + sec->size - 8, fx_ld64(sec->data + 8) + 1));
#undef SHARD_EDIT
  /* R-DIR-6: a flipped byte. */
  uint64_t ssize = 0, off = fx_section_offset(base, "SHRD", &ssize, NULL);
  b = fx_copy(base, size);
  b[off + ssize / 2] ^= 0x20;
  fx_add(cases, &n, BBC_ERR_CHECKSUM, "flipped-byte-in-SHRD", b, size);
  free(base_v);
  return n;
}

TEST(shard_section_rules_fail_with_the_named_code) {
  static fx_case cases[32];
  int n = shard_invalid_cases(cases);
  CHECK(n >= 12);
  /* BBC_WRITE_SHARD_CORPUS=DIR writes the cases as DIR/<name>.bbc: this is how the
   * shard files of tests/corpus/invalid were made. */
  const char *dir = getenv("BBC_WRITE_SHARD_CORPUS");
  for (int i = 0; i < n; i++) {
    CHECK(cases[i].expected != BBC_OK);
    check_case(&cases[i]);
    if (dir) {
      char path[4096];
      snprintf(path, sizeof path, "%s/%s.bbc", dir, cases[i].name);
      FILE *out = fopen(path, "wb");
      CHECK(out && fwrite(cases[i].bytes, 1, cases[i].size, out) == cases[i].size);
      if (out) fclose(out);
    }
    free(cases[i].bytes);
  }
}

TEST(merge_refuses_shards_that_do_not_belong_together) {
  shard_setup s;
  REQUIRE(shard_setup_init(&s));
  void *b[4] = {0}, *full = NULL, *other = NULL, *split = NULL, *out = NULL;
  size_t z[4] = {0}, full_size = 0, other_size = 0, split_size = 0, out_size = 0;
  for (uint32_t i = 0; i < 3; i++) REQUIRE(write_candidates(&s, i, 3, 0, &b[i], &z[i]) == BBC_OK);
  REQUIRE(write_candidates(&s, 0, 0, 0, &full, &full_size) == BBC_OK);
  REQUIRE(write_candidates(&s, 1, 2, 0, &split, &split_size) == BBC_OK);
  /* The same shard 2/3 of a list with one candidate less: another candidate list. */
  s.count--;
  REQUIRE(write_candidates(&s, 2, 3, 0, &other, &other_size) == BBC_OK);
  s.count++;
  struct {
    void *bytes[3];
    size_t sizes[3];
    size_t n;
    bbc_result code;
    const char *words;
  } cases[] = {
      {{b[0], b[1]}, {z[0], z[1]}, 2, BBC_ERR_INVALID_ARGUMENT, "shard 2/3 is missing"},
      {{b[1], b[2]}, {z[1], z[2]}, 2, BBC_ERR_INVALID_ARGUMENT, "shard 0/3 is missing"},
      {{b[0], b[1], b[1]}, {z[0], z[1], z[1]}, 3, BBC_ERR_INVALID_ARGUMENT, "both shard 1/3"},
      {{b[0], b[1], full},
       {z[0], z[1], full_size},
       3,
       BBC_ERR_INVALID_ARGUMENT,
       "not a shard cache"},
      {{b[0], split}, {z[0], split_size}, 2, BBC_ERR_INVALID_ARGUMENT, "different splits"},
      {{b[0], b[1], other},
       {z[0], z[1], other_size},
       3,
       BBC_ERR_SCENE_MISMATCH,
       "different candidate tuple lists"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    messages m = {0};
    bbc_result r = merge_bytes(cases[i].bytes, cases[i].sizes, cases[i].n, 0, &m, &out, &out_size);
    if (r != cases[i].code || m.count != 1 || !strstr(m.last, cases[i].words))
      harness_fail(__FILE__, __LINE__, "case %zu: %s, %d messages, last \"%s\"", i,
                   bbc_result_string(r), m.count, m.last);
    CHECK(out == NULL);
  }
  /* Another scene: the sphere's grid and fingerprint. */
  bbc_scene *sphere = load(TEST_SCENE("glass-sphere.gltf"));
  REQUIRE(sphere);
  bbc_scene *pool = s.scene;
  s.scene = sphere;
  void *sb = NULL;
  size_t ss = 0;
  bbc_tuple *keep = s.candidates;
  size_t keep_count = s.count;
  /* Tuples valid for the sphere: its first caster and receiver triangles. */
  bbc_tuple t = {0, BBC_CHAIN_R, {0, BBC_NO_TRIANGLE}, 0};
  for (uint32_t k = 0; k < sphere->triangle_count; k++) {
    const uint32_t m = sphere->triangle_mesh[k];
    bbc_role role = sphere->meshes[m].role;
    if (role == BBC_ROLE_CASTER) t.specular[0] = k;
    if (role == BBC_ROLE_RECEIVER) t.receiver = sphere->meshes[m].plane ? BBC_RECEIVER_PLANE(m) : k;
  }
  bbc_tuple list[6] = {t, t, t, t, t, t};
  s.candidates = list;
  s.count = 6;
  REQUIRE(write_candidates(&s, 2, 3, 0, &sb, &ss) == BBC_OK);
  s.candidates = keep;
  s.count = keep_count;
  s.scene = pool;
  bbc_scene_free(sphere);
  void *mixed[3] = {b[0], b[1], sb};
  size_t mixed_sizes[3] = {z[0], z[1], ss};
  messages m = {0};
  CHECK_INT(merge_bytes(mixed, mixed_sizes, 3, 0, &m, &out, &out_size), BBC_ERR_SCENE_MISMATCH);
  CHECK_STR_CONTAINS(m.last, "different scenes");
  CHECK_INT(m.count, 1);
  free(sb);
  for (int i = 0; i < 3; i++) free(b[i]);
  free(full);
  free(other);
  free(split);
  shard_setup_free(&s);
}
