/* Tests of the glTF scene loader (scene.c over gltf_shim.cpp).
 *
 * Expected values come from the files themselves or are worked out by hand from the
 * small corpus files in tests/corpus/valid (their geometry is described next to each
 * test), never from the loader's own output. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "bbc/cache.h"
#include "bbc/precompute.h"
#include "bbc/scene.h"
#include "blender_style.h"
#include "gltf_shim_internal.h"
#include "harness.h"

#define VALID_DIR SOURCE_PATH("tests/corpus/valid")
#define INVALID_DIR SOURCE_PATH("tests/corpus/invalid-gltf")
#define PI 3.14159265358979323846

/* ------------------------------------------------------------------ helpers */

typedef struct messages {
  int errors, warnings;
  bbc_result error_code;
  bbc_result warning_code;
  char error[1024];
  char warning[8][1024];
} messages;

static void on_error(void *user, bbc_result code, const char *message) {
  messages *m = user;
  m->errors++;
  m->error_code = code;
  snprintf(m->error, sizeof m->error, "%s", message);
}

static void on_warning(void *user, bbc_result code, const char *message) {
  messages *m = user;
  m->warning_code = code;
  if (m->warnings < 8) snprintf(m->warning[m->warnings], sizeof m->warning[0], "%s", message);
  m->warnings++;
}

static bbc_scene *load(const char *path, messages *m, bbc_result *result) {
  memset(m, 0, sizeof *m);
  bbc_scene_options options = {on_error, on_warning, m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *scene = (bbc_scene *)1; /* must be overwritten, also on failure */
  *result = bbc_scene_load(&scene, path, &options);
  if (*result != BBC_OK && scene != NULL) harness_fail(__FILE__, __LINE__, "*out not NULL");
  if (*result != BBC_OK) return NULL;
  return scene;
}

/* Loads a file that must load without errors; warnings are allowed and kept in m. */
static bbc_scene *load_ok(const char *path, messages *m) {
  bbc_result r;
  bbc_scene *scene = load(path, m, &r);
  if (r != BBC_OK)
    harness_fail(__FILE__, __LINE__, "loading %s: %s (%s)", path, bbc_result_string(r), m->error);
  if (m->errors != 0) harness_fail(__FILE__, __LINE__, "error_fn called on success");
  return scene;
}

static char *read_file(const char *path, size_t *size) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  size_t cap = 1 << 16, n = 0, got;
  char *data = malloc(cap + 1);
  while (data && (got = fread(data + n, 1, cap - n, f)) > 0) {
    n += got;
    if (n == cap) {
      char *bigger = realloc(data, 2 * cap + 1);
      if (!bigger) {
        free(data);
        data = NULL;
        break;
      }
      data = bigger;
      cap *= 2;
    }
  }
  fclose(f);
  if (data) data[n] = '\0';
  *size = n;
  return data;
}

/* The number after the first occurrence of "key": in a JSON text, or -1: enough of a
 * parser for the generated and shared scenes, whose keys are each written once. */
static double json_number_after(const char *text, const char *key) {
  char pattern[64];
  snprintf(pattern, sizeof pattern, "\"%s\":", key);
  const char *at = strstr(text, pattern);
  return at ? strtod(at + strlen(pattern), NULL) : -1.0;
}

static int compare_names(const void *a, const void *b) {
  return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The names in a folder that end with one of the suffixes, sorted; NULL-terminated. */
static char **list_dir(const char *dir, const char *suffix1, const char *suffix2, int *count) {
  DIR *d = opendir(dir);
  char **names = calloc(256, sizeof *names);
  *count = 0;
  if (!d || !names) {
    if (d) closedir(d);
    return names;
  }
  struct dirent *e;
  while ((e = readdir(d)) != NULL && *count < 255) {
    size_t n = strlen(e->d_name);
    int match = 0;
    for (int k = 0; k < 2; k++) {
      const char *suffix = k ? suffix2 : suffix1;
      size_t s = suffix ? strlen(suffix) : 0;
      if (suffix && n > s && strcmp(e->d_name + n - s, suffix) == 0) match = 1;
    }
    if (match) names[(*count)++] = strdup(e->d_name);
  }
  closedir(d);
  qsort(names, (size_t)*count, sizeof *names, compare_names);
  return names;
}

static void free_list(char **names) {
  for (int i = 0; names && names[i]; i++) free(names[i]);
  free(names);
}

static void vec_sub(const float *a, const float *b, double out[3]) {
  for (int k = 0; k < 3; k++) out[k] = (double)a[k] - (double)b[k];
}

static void vec_cross(const double a[3], const double b[3], double c[3]) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

static void vec_normalize(double v[3]) {
  double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int k = 0; k < 3; k++) v[k] /= len;
}

/* The unnormalised geometric normal of a triangle from its stored winding. */
static void triangle_normal(const bbc_scene *s, uint32_t t, double n[3]) {
  const float *p0 = &s->positions[3 * s->indices[3 * t]];
  const float *p1 = &s->positions[3 * s->indices[3 * t + 1]];
  const float *p2 = &s->positions[3 * s->indices[3 * t + 2]];
  double e1[3], e2[3];
  vec_sub(p1, p0, e1);
  vec_sub(p2, p0, e2);
  vec_cross(e1, e2, n);
}

static const bbc_mesh *find_mesh(const bbc_scene *s, const char *name) {
  for (uint32_t i = 0; i < s->mesh_count; i++)
    if (strcmp(s->meshes[i].name, name) == 0) return &s->meshes[i];
  return NULL;
}

static int same_position(const bbc_scene *s, uint32_t vertex, const double p[3]) {
  for (int c = 0; c < 3; c++)
    if (!(fabs(s->positions[3 * (size_t)vertex + c] - p[c]) <= 1e-5)) return 0;
  return 1;
}

/* The loader numbers vertices and triangles in its canonical order (by geometry, not
 * by file order), so tests find a triangle by its corners: the triangle of the mesh
 * whose corners are p[0], p[1], p[2] in this cyclic (winding) order; *corner0 receives
 * the scene vertex at p[0]'s corner offset: corners[k] is the vertex at p[k]. Returns 0
 * (after a failed check) when there is none. */
static int find_triangle(const bbc_scene *s, const bbc_mesh *mesh, const double p[3][3],
                         uint32_t corners[3]) {
  for (uint32_t t = mesh->first_triangle; t < mesh->first_triangle + mesh->triangle_count; t++)
    for (int r = 0; r < 3; r++) {
      int ok = 1;
      for (int k = 0; k < 3 && ok; k++) ok = same_position(s, s->indices[3 * t + (r + k) % 3], p[k]);
      if (!ok) continue;
      for (int k = 0; k < 3; k++) corners[k] = s->indices[3 * t + (r + k) % 3];
      return 1;
    }
  harness_fail(__FILE__, __LINE__, "mesh %s has no triangle (%g,%g,%g) (%g,%g,%g) (%g,%g,%g)",
               mesh->name, p[0][0], p[0][1], p[0][2], p[1][0], p[1][1], p[1][2], p[2][0], p[2][1],
               p[2][2]);
  return 0;
}

/* Invariants every loaded scene must satisfy, whatever the file. */
static void check_invariants(const bbc_scene *s) {
  REQUIRE(s != NULL);
  CHECK(s->vertex_count > 0);
  CHECK(s->triangle_count > 0);
  for (uint32_t v = 0; v < s->vertex_count; v++) {
    const float *n = &s->normals[3 * v];
    for (int k = 0; k < 3; k++) CHECK(isfinite(s->positions[3 * v + k]));
    double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
    if (fabs(len - 1.0) > 1e-5) {
      CHECK_NEAR(len, 1.0, 1e-5);
      break;
    }
  }
  uint32_t expected_first = 0;
  for (uint32_t i = 0; i < s->mesh_count; i++) {
    const bbc_mesh *m = &s->meshes[i];
    CHECK_INT(m->first_triangle, expected_first);
    expected_first += m->triangle_count;
    CHECK(m->material < s->material_count);
    CHECK(m->first_vertex + m->vertex_count <= s->vertex_count);
    for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++) {
      CHECK_INT(s->triangle_mesh[t], i);
      for (int k = 0; k < 3; k++) {
        uint32_t v = s->indices[3 * t + (uint32_t)k];
        if (v < m->first_vertex || v >= m->first_vertex + m->vertex_count) {
          harness_fail(__FILE__, __LINE__, "triangle %u uses vertex %u outside its mesh", t, v);
          return;
        }
      }
    }
  }
  CHECK_INT(expected_first, s->triangle_count);
  CHECK(s->point_light_count > 0 || s->emitter_count > 0);
  /* The camera frame must be orthonormal and right-handed. */
  const bbc_camera *c = &s->camera;
  double u[3] = {c->u.x, c->u.y, c->u.z}, v[3] = {c->v.x, c->v.y, c->v.z};
  double w[3] = {c->w.x, c->w.y, c->w.z}, uxv[3];
  vec_cross(u, v, uxv);
  for (int k = 0; k < 3; k++) CHECK_NEAR(uxv[k], w[k], 1e-12);
  CHECK_NEAR(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], 1.0, 1e-12);
  CHECK_NEAR(v[0] * v[0] + v[1] * v[1] + v[2] * v[2], 1.0, 1e-12);
  CHECK_NEAR(u[0] * v[0] + u[1] * v[1] + u[2] * v[2], 0.0, 1e-12);
}

/* ------------------------------------------------------------------ research scenes */

/* One scene in a research set-up (a caster over a floor of two triangles) loads with the
 * caster's triangle count its extras declare, a caster of the right material (mirror
 * base colour `mirror_green`), a diffuse receiver, the point light and the camera written
 * in the file. */
static void check_research_scene(const char *path, const char *name, double mirror_green) {
  size_t size;
  char *text = read_file(path, &size);
  messages m;
  bbc_scene *s = load_ok(path, &m);
  if (!s || !text) {
    harness_fail(__FILE__, __LINE__, "%s did not load", path);
    free(text);
    bbc_scene_free(s);
    return;
  }
  fprintf(stderr, "  %s: %u triangles, %u vertices\n", name, s->triangle_count, s->vertex_count);
  check_invariants(s);
  CHECK_INT(m.warnings, 0);
  /* extras.bbc.triangles counts the caster's triangles (the first node); the floor
   * adds its own two. */
  double triangles = json_number_after(text, "triangles");
  if (triangles >= 0) CHECK_INT(s->meshes[0].triangle_count, (long long)triangles);
  CHECK_INT(s->mesh_count, 2);
  const bbc_mesh *caster = &s->meshes[0], *floor = &s->meshes[1];
  CHECK_INT(caster->role, BBC_ROLE_CASTER);
  CHECK_INT(floor->role, BBC_ROLE_RECEIVER);
  CHECK_INT(floor->triangle_count, 2);
  CHECK(floor->has_uvs);
  const bbc_material *cm = &s->materials[caster->material];
  const bbc_material *fm = &s->materials[floor->material];
  CHECK_INT(fm->type, BBC_MATERIAL_DIFFUSE);
  CHECK_NEAR(fm->base_color[0], 0.8, 1e-7);
  if (strncmp(name, "plane", 5) == 0) {
    CHECK_INT(cm->type, BBC_MATERIAL_MIRROR);
    CHECK_NEAR(cm->base_color[1], mirror_green, 1e-7);
  } else {
    double ior = strncmp(name, "diamond", 7) == 0 ? 2.42
                 : strncmp(name, "pool", 4) == 0  ? 1.33
                                                  : 1.5;
    CHECK_INT(cm->type, BBC_MATERIAL_DIELECTRIC);
    CHECK_NEAR(cm->ior, ior, 1e-6);
  }
  CHECK_INT(s->point_light_count, 1);
  CHECK_NEAR(s->point_lights[0].intensity[0], json_number_after(text, "intensity"), 1e-6);
  CHECK_INT(s->emitter_count, 0);
  CHECK_NEAR(s->emitter_power, 0.0, 0.0);
  CHECK_INT(s->camera.width, (long long)json_number_after(text, "width"));
  CHECK_INT(s->camera.height, (long long)json_number_after(text, "height"));
  CHECK_NEAR(s->camera.aspect, json_number_after(text, "aspectRatio"), 1e-12);
  CHECK_NEAR(s->camera.yfov, json_number_after(text, "yfov"), 1e-12);
  CHECK(strcmp(s->path, path) == 0);
  free(text);
  bbc_scene_free(s);
}

/* The research set-ups the build generates (tests/make_test_scenes.sh): the wavy plane,
 * the pool, the four balls, the slab's two sheets and the diamond. */
TEST(research_scenes) {
  static const char *const names[] = {"plane1k.gltf", "pool4k.gltf",   "ball80.gltf",
                                      "ball320.gltf", "ball1280.gltf", "ball5120.gltf",
                                      "slab10k.gltf", "diamond.gltf"};
  for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
    char path[2048];
    snprintf(path, sizeof path, "%s%s", TEST_SCENE(""), names[i]);
    check_research_scene(path, names[i], 1.0);
  }
}

/* Opt-in: every scene in the shared folder's scenes/ (BBC_SHARED_DIR), the research
 * meshes of the paper's set-ups with their gold mirrors, loads the same way. */
TEST(shared_folder_scenes) {
  const char *shared = harness_shared_dir();
  if (!shared) SKIP("no shared scenes (set BBC_SHARED_DIR to the folder holding scenes/)");
  char dir[2048];
  snprintf(dir, sizeof dir, "%s/scenes/", shared);
  int count = 0;
  char **names = list_dir(dir, ".gltf", NULL, &count);
  CHECK(count >= 1);
  for (int i = 0; i < count; i++) {
    char path[4096];
    snprintf(path, sizeof path, "%s%s", dir, names[i]);
    check_research_scene(path, names[i], 0.78);
  }
  free_list(names);
}

/* diamond.gltf (the research set-up, as generated) in detail: light at (1,3,-2); camera
 * at (0,6,6) rotated about x by the
 * quaternion (qx,0,0,qw), so it looks along -w with w = (0, -sin a, cos a), a = 2
 * atan2(qx, qw), and u = x. */
TEST(diamond_light_and_camera) {
  messages m;
  bbc_scene *s = load_ok(TEST_SCENE("diamond.gltf"), &m);
  REQUIRE(s != NULL);
  CHECK_NEAR(s->point_lights[0].position.x, 1.0, 0.0);
  CHECK_NEAR(s->point_lights[0].position.y, 3.0, 0.0);
  CHECK_NEAR(s->point_lights[0].position.z, -2.0, 0.0);
  for (int k = 0; k < 3; k++) CHECK_NEAR(s->point_lights[0].intensity[k], 50.0, 0.0);
  double a = 2.0 * atan2(-0.41537300200070665, 0.9096511799634632);
  CHECK_NEAR(s->camera.position.x, 0.0, 0.0);
  CHECK_NEAR(s->camera.position.y, 6.0, 0.0);
  CHECK_NEAR(s->camera.position.z, 6.0, 0.0);
  CHECK_NEAR(s->camera.w.x, 0.0, 1e-12);
  CHECK_NEAR(s->camera.w.y, -sin(a), 1e-12);
  CHECK_NEAR(s->camera.w.z, cos(a), 1e-12);
  CHECK_NEAR(s->camera.u.x, 1.0, 1e-12);
  CHECK_NEAR(s->camera.v.y, cos(a), 1e-12);
  CHECK_NEAR(s->camera.v.z, sin(a), 1e-12);
  /* The camera looks down at the origin: -w points from it towards the scene. */
  CHECK(-s->camera.w.y < 0 && -s->camera.w.z < 0);
  CHECK_INT(s->meshes[0].has_normals, 1);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ transforms */

/* transform.gltf holds the triangle (1,0,0), (0,1,0), (0,0,1) with vertex normals
 * (1,1,1)/sqrt 3 under three nodes:
 *  - "child" of a parent translated by (1,2,3), itself rotated 90 degrees about z and
 *    scaled by (2,3,4): p -> (1 - 3 y, 2 + 2 x, 3 + 4 z), so the corners go to
 *    (1,4,3), (-2,2,3), (1,2,7); the normal goes to R S^-1 n ~ (-1/3, 1/2, 1/4),
 *    parallel to the cross product of the world edges, (-8, 12, 6);
 *  - "by_matrix", the same world transform written as a matrix;
 *  - "mirrored", scaled by (-1,1,1) and moved by (0,0,-5), whose normal is (-1,1,1)/sqrt 3
 *    and whose winding must flip to stay consistent with it. */
static void check_transformed_triangle(const bbc_scene *s, const bbc_mesh *mesh) {
  REQUIRE(mesh != NULL);
  CHECK_INT(mesh->vertex_count, 3);
  CHECK_INT(mesh->triangle_count, 1);
  static const double p[3][3] = {{1, 4, 3}, {-2, 2, 3}, {1, 2, 7}};
  uint32_t corners[3];
  if (!find_triangle(s, mesh, p, corners)) return;
  double n[3] = {-8, 12, 6};
  vec_normalize(n);
  for (uint32_t i = 0; i < 3; i++)
    for (int k = 0; k < 3; k++) CHECK_NEAR(s->normals[3 * corners[i] + (uint32_t)k], n[k], 1e-6);
  double g[3];
  triangle_normal(s, mesh->first_triangle, g);
  vec_normalize(g);
  for (int k = 0; k < 3; k++) CHECK_NEAR(g[k], n[k], 1e-6);
}

TEST(transform_trs_hierarchy) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/transform.gltf"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  CHECK_INT(s->mesh_count, 3);
  /* Meshes come in node order: the parent's child first, then the other roots. */
  check_transformed_triangle(s, &s->meshes[0]);
  CHECK_INT(s->meshes[0].role, BBC_ROLE_NONE);
  bbc_scene_free(s);
}

TEST(transform_matrix) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/transform.gltf"), &m);
  REQUIRE(s != NULL);
  check_transformed_triangle(s, &s->meshes[1]);
  /* No role given and a diffuse material: a receiver. */
  CHECK_INT(s->meshes[1].role, BBC_ROLE_RECEIVER);
  bbc_scene_free(s);
}

TEST(transform_mirrored_keeps_winding) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/transform.gltf"), &m);
  REQUIRE(s != NULL && s->mesh_count == 3);
  const bbc_mesh *mesh = &s->meshes[2];
  CHECK_INT(mesh->role, BBC_ROLE_CASTER);
  /* The file's corners are (-1,0,-5), (0,1,-5), (0,0,-4); the second and third are
   * swapped so the winding agrees with the normal. */
  static const double p[3][3] = {{-1, 0, -5}, {0, 0, -4}, {0, 1, -5}};
  uint32_t corners[3];
  if (!find_triangle(s, mesh, p, corners)) return;
  double n[3] = {-1, 1, 1};
  vec_normalize(n);
  for (int k = 0; k < 3; k++) CHECK_NEAR(s->normals[3 * corners[0] + (uint32_t)k], n[k], 1e-6);
  uint32_t t = mesh->first_triangle;
  double g[3];
  triangle_normal(s, t, g);
  CHECK(g[0] * n[0] + g[1] * n[1] + g[2] * n[2] > 0.0);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ accessors */

/* indices.gltf: the quad (0,0,0), (1,0,0), (1,0,1), (0,0,1) with triangles (0,2,1) and
 * (0,3,2), facing +y, in five meshes shifted by 10 k along x: 8-, 16- and 32-bit
 * indices, non-indexed, and an interleaved buffer (position, normal, uv; stride 32). */
static const double quad[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}};
static const double quad_uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
static const int quad_indices[6] = {0, 2, 1, 0, 3, 2};

static void check_quad_mesh(const bbc_scene *s, const char *name, int k, int expect_uvs) {
  const bbc_mesh *mesh = find_mesh(s, name);
  if (!mesh) {
    harness_fail(__FILE__, __LINE__, "no mesh named %s", name);
    return;
  }
  CHECK_INT(mesh->triangle_count, 2);
  CHECK_INT(mesh->has_normals, 1);
  CHECK_INT(mesh->has_uvs, expect_uvs);
  for (uint32_t t = 0; t < 2; t++) {
    double p[3][3];
    for (int c = 0; c < 3; c++)
      for (int d = 0; d < 3; d++) p[c][d] = quad[quad_indices[3 * t + c]][d] + (d == 0 ? 10.0 * k : 0.0);
    uint32_t corners[3];
    if (!find_triangle(s, mesh, p, corners)) continue;
    for (int c = 0; c < 3; c++) {
      uint32_t v = corners[c];
      CHECK_NEAR(s->normals[3 * v + 1], 1.0, 0.0);
      CHECK_NEAR(s->uvs[2 * v], expect_uvs ? quad_uv[quad_indices[3 * t + c]][0] : 0.0, 0.0);
      CHECK_NEAR(s->uvs[2 * v + 1], expect_uvs ? quad_uv[quad_indices[3 * t + c]][1] : 0.0, 0.0);
    }
  }
}

TEST(indices_8_16_32_bit) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/indices.gltf"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  CHECK_INT(s->mesh_count, 5);
  CHECK_INT(s->triangle_count, 10);
  check_quad_mesh(s, "u8", 0, 0);
  check_quad_mesh(s, "u16", 1, 0);
  check_quad_mesh(s, "u32", 2, 0);
  bbc_scene_free(s);
}

TEST(non_indexed_and_interleaved) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/indices.gltf"), &m);
  REQUIRE(s != NULL);
  check_quad_mesh(s, "non_indexed", 3, 0);
  check_quad_mesh(s, "interleaved", 4, 1);
  const bbc_mesh *flat = find_mesh(s, "non_indexed");
  REQUIRE(flat != NULL);
  CHECK_INT(flat->vertex_count, 6);
  bbc_scene_free(s);
}

/* small.glb: the quad scaled to [-1,1]^2 in the BIN chunk of a binary glTF, with uvs;
 * its camera gives only a film size, so aspect = 320 / 240. */
TEST(glb_file) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/small.glb"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  CHECK_INT(s->mesh_count, 1);
  CHECK_INT(s->vertex_count, 4);
  CHECK_INT(s->triangle_count, 2);
  CHECK_INT(s->meshes[0].has_uvs, 1);
  /* The corners (-1,0,-1) and (1,0,1) with their uvs. */
  static const double a[3] = {-1, 0, -1}, b[3] = {1, 0, 1};
  int found = 0;
  for (uint32_t v = 0; v < 4; v++) {
    if (same_position(s, v, a)) {
      found++;
      CHECK_NEAR(s->uvs[2 * v], 0.0, 0.0);
    }
    if (same_position(s, v, b)) {
      found++;
      CHECK_NEAR(s->uvs[2 * v], 1.0, 0.0);
    }
  }
  CHECK_INT(found, 2);
  CHECK_INT(s->camera.width, 320);
  CHECK_INT(s->camera.height, 240);
  CHECK_NEAR(s->camera.aspect, 320.0 / 240.0, 1e-15);
  CHECK_NEAR(s->camera.yfov, 0.7, 1e-15);
  bbc_scene_free(s);
}

/* The same bytes given to the memory loader, which must find nothing on disk. */
TEST(glb_from_memory) {
  size_t size;
  char *bytes = read_file(SOURCE_PATH("tests/corpus/valid/small.glb"), &size);
  REQUIRE(bytes != NULL);
  messages m = {0};
  bbc_scene_options options = {on_error, on_warning, &m, BBC_LIGHT_UNITS_FILE};
  bbc_scene *s = NULL;
  bbc_result r = bbc__scene_load_memory(&s, bytes, size, "small.glb", NULL, &options);
  CHECK_INT(r, BBC_OK);
  CHECK_INT(m.errors, 0);
  if (s) {
    CHECK_INT(s->triangle_count, 2);
    CHECK(strcmp(s->path, "small.glb") == 0);
  }
  bbc_scene_free(s);
  free(bytes);
}

/* ------------------------------------------------------------------ normals, materials */

/* no_normals.gltf: the bent quad (0,0,0), (1,0,0), (1,0.5,1), (0,0,1) without NORMAL,
 * TEXCOORD_0 or material. Each triangle gets its own vertices and its flat normal. */
TEST(missing_normals_are_flat) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/no_normals.gltf"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  static const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0.5, 1}, {0, 0, 1}};
  CHECK_INT(s->vertex_count, 6);
  CHECK_INT(s->triangle_count, 2);
  CHECK_INT(s->meshes[0].has_normals, 0);
  CHECK_INT(s->meshes[0].has_uvs, 0);
  double normals[2][3];
  for (uint32_t t = 0; t < 2; t++) {
    const double *a = p[quad_indices[3 * t]], *b = p[quad_indices[3 * t + 1]],
                 *c = p[quad_indices[3 * t + 2]];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    vec_cross(e1, e2, normals[t]);
    vec_normalize(normals[t]);
    CHECK(normals[t][1] > 0.0);
    double corner[3][3];
    for (int k = 0; k < 3; k++) memcpy(corner[k], p[quad_indices[3 * t + k]], sizeof corner[k]);
    uint32_t corners[3];
    if (!find_triangle(s, &s->meshes[0], (const double(*)[3])corner, corners)) continue;
    for (uint32_t k = 0; k < 3; k++) {
      uint32_t v = corners[k];
      for (int c2 = 0; c2 < 3; c2++)
        CHECK_NEAR(s->normals[3 * v + (uint32_t)c2], normals[t][c2], 1e-6);
      CHECK_NEAR(s->uvs[2 * v], 0.0, 0.0);
      CHECK_NEAR(s->uvs[2 * v + 1], 0.0, 0.0);
    }
  }
  /* The quad is bent, so the two flat normals differ and no vertex may be shared. */
  CHECK(fabs(normals[0][0] - normals[1][0]) > 0.1 || fabs(normals[0][2] - normals[1][2]) > 0.1);
  for (uint32_t i = 0; i < 6; i++)
    for (uint32_t j = i + 1; j < 6; j++) CHECK(s->indices[i] != s->indices[j]);
  bbc_scene_free(s);
}

TEST(default_material) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/no_normals.gltf"), &m);
  REQUIRE(s != NULL);
  CHECK_INT(s->material_count, 1);
  const bbc_material *mat = bbc_scene_triangle_material(s, 0);
  CHECK_INT(mat->type, BBC_MATERIAL_DIFFUSE);
  for (int k = 0; k < 3; k++) {
    CHECK_NEAR(mat->base_color[k], 0.8, 1e-7);
    CHECK_NEAR(mat->emission[k], 0.0, 0.0);
  }
  CHECK_INT(s->meshes[0].role, BBC_ROLE_RECEIVER);
  CHECK_INT(m.warnings, 0);
  bbc_scene_free(s);
}

/* materials.gltf: one triangle per material, mesh named after its material. */
TEST(material_classification) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/materials.gltf"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  static const struct {
    const char *name;
    bbc_material_type type;
    bbc_role role;
    double ior;
  } expected[] = {
      {"silver", BBC_MATERIAL_MIRROR, BBC_ROLE_CASTER, 1.5},
      {"glass_1.7", BBC_MATERIAL_DIELECTRIC, BBC_ROLE_CASTER, 1.7},
      {"glass_default", BBC_MATERIAL_DIELECTRIC, BBC_ROLE_CASTER, 1.5},
      {"thin_glass", BBC_MATERIAL_DIELECTRIC, BBC_ROLE_CASTER, 1.5},
      {"brushed_steel", BBC_MATERIAL_DIFFUSE, BBC_ROLE_RECEIVER, 1.5},
      {"white", BBC_MATERIAL_DIFFUSE, BBC_ROLE_RECEIVER, 1.5},
  };
  CHECK_INT(s->material_count, 6);
  for (size_t i = 0; i < sizeof expected / sizeof expected[0]; i++) {
    const bbc_mesh *mesh = find_mesh(s, expected[i].name);
    if (!mesh) {
      harness_fail(__FILE__, __LINE__, "no mesh %s", expected[i].name);
      continue;
    }
    const bbc_material *mat = &s->materials[mesh->material];
    CHECK(strcmp(mat->name, expected[i].name) == 0);
    CHECK_INT(mat->type, expected[i].type);
    CHECK_INT(mesh->role, expected[i].role);
    if (mat->type == BBC_MATERIAL_DIELECTRIC) CHECK_NEAR(mat->ior, expected[i].ior, 1e-6);
  }
  const bbc_material *silver = &s->materials[find_mesh(s, "silver")->material];
  CHECK_NEAR(silver->base_color[0], 0.9, 1e-7);
  CHECK_NEAR(silver->base_color[2], 0.7, 1e-7);
  const bbc_material *white = &s->materials[find_mesh(s, "white")->material];
  CHECK_NEAR(white->base_color[1], 0.6, 1e-7);
  bbc_scene_free(s);
}

/* Glass without a volume (thin_glass, on one triangle) is a refracting surface, with a
 * warning naming it, sent with code BBC_OK; brushed_steel (metallic 1, roughness 0.3) is
 * a glossy receiver and loads silently. */
TEST(unknown_material_warns) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/materials.gltf"), &m);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 1);
  CHECK_INT(m.warning_code, BBC_OK);
  CHECK_STR_CONTAINS(m.warning[0], "materials.gltf");
  CHECK_STR_CONTAINS(m.warning[0], "\"thin_glass\"");
  CHECK_STR_CONTAINS(m.warning[0], "without KHR_materials_volume on an open mesh");
  CHECK(strchr(m.warning[0], '\n') == NULL);
  const bbc_material *steel = &s->materials[find_mesh(s, "brushed_steel")->material];
  CHECK_INT(steel->type, BBC_MATERIAL_DIFFUSE);
  CHECK_INT(steel->glossy, 1);
  CHECK_NEAR(steel->metallic, 1.0, 0.0);
  CHECK_NEAR(steel->roughness, 0.3, 1e-7);
  const bbc_material *white = &s->materials[find_mesh(s, "white")->material];
  CHECK_INT(white->glossy, 0);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ lights */

/* emissive.gltf: a floor quad (triangles 0, 1) and two emissive triangles of areas 0.5
 * and 2 (triangles 2, 3) with emissiveFactor (1, 0.5, 0.25) x emissiveStrength 4, so
 * radiance (4, 2, 1) with mean 7/3; its only punctual light is a spot light. */
TEST(emissive_triangles) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/emissive.gltf"), &m);
  REQUIRE(s != NULL);
  check_invariants(s);
  CHECK_INT(s->point_light_count, 1); /* a spot */
  REQUIRE(s->emitter_count == 2);
  CHECK_INT(s->emitters[0], 2);
  CHECK_INT(s->emitters[1], 3);
  CHECK_NEAR(s->emitter_cdf[0], 0.5 / 2.5, 1e-12);
  CHECK_NEAR(s->emitter_cdf[1], 1.0, 0.0);
  CHECK_NEAR(s->emitter_power, 2.5 * (7.0 / 3.0) * PI, 1e-9);
  const bbc_material *lamp = bbc_scene_triangle_material(s, 2);
  CHECK_NEAR(lamp->emission[0], 4.0, 0.0);
  CHECK_NEAR(lamp->emission[1], 2.0, 0.0);
  CHECK_NEAR(lamp->emission[2], 1.0, 0.0);
  CHECK_INT(bbc_scene_triangle_material(s, 0)->type, BBC_MATERIAL_DIFFUSE);
  bbc_scene_free(s);
}

/* Spot and directional lights (KHR_lights_punctual) are loaded with their kind, the
 * node's -Z axis as direction and the spot's cone (defaults 0 and pi/4). */
TEST(spot_and_directional_lights) {
  messages m;
  bbc_scene *s = load_ok(SOURCE_PATH("tests/corpus/valid/spot-and-sun.gltf"), &m);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 0);
  REQUIRE(s->point_light_count == 2);
  /* Node order: the sun's node comes first. */
  const bbc_point_light *sun = &s->point_lights[0], *spot = &s->point_lights[1];
  CHECK_INT(sun->model.kind, BBC_LIGHT_DIRECTIONAL);
  CHECK_INT(spot->model.kind, BBC_LIGHT_SPOT);
  CHECK_NEAR(sun->model.direction.z, -1.0, 0.0);
  CHECK_NEAR(spot->model.direction.z, -1.0, 0.0);
  CHECK_NEAR(spot->model.cos_outer, cos(PI / 4), 1e-9);
  CHECK_NEAR(spot->model.cone_scale, 1.0 / (1.0 - cos(PI / 4)), 1e-6);
  CHECK_INT(sun->medium, 0);
  /* The falloff: 1 inside the inner cone, 0 outside the outer one, t^2 between. */
  CHECK_NEAR(bbc_light_falloff(&spot->model, (bbc_vec3){0, 0, -1}), 1.0, 0.0);
  CHECK_NEAR(bbc_light_falloff(&spot->model, (bbc_vec3){0, sin(0.8), -cos(0.8)}), 0.0, 0.0);
  double t = (cos(0.5) - cos(PI / 4)) / (1.0 - cos(PI / 4));
  /* tinygltf's default outer angle is 0.7853981634, not pi/4 exactly. */
  CHECK_NEAR(bbc_light_falloff(&spot->model, (bbc_vec3){0, sin(0.5), -cos(0.5)}), t * t, 1e-8);
  CHECK_NEAR(bbc_light_falloff(&sun->model, (bbc_vec3){1, 0, 0}), 1.0, 0.0);
  bbc_scene_free(s);
}

/* ------------------------------------------------------------------ Blender-style files */

/* Loads a blender_style scene from memory with the given light-units override. */
static bbc_scene *load_blender(const blender_style *b, bbc_light_units units, messages *m,
                               bbc_result *result) {
  char *text = blender_style_write(b);
  memset(m, 0, sizeof *m);
  bbc_scene_options options = {on_error, on_warning, m, units};
  bbc_scene *s = NULL;
  *result = bbc__scene_load_memory(&s, text, strlen(text), "blender.gltf", NULL, &options);
  free(text);
  return s;
}

#define BLENDER_CAMERA                                                              \
  "[{\"name\":\"Camera\",\"type\":\"perspective\",\"perspective\":{\"aspectRatio\":1.7777777777777777," \
  "\"yfov\":0.39959652046304894,\"zfar\":100,\"znear\":0.10000000149011612}}]"

/* Blender's exporter writes a 1000 W point light as 1000 / (4 pi) * 683 candela, with
 * color; bbc must read back 1000 / (4 pi) W/sr per unit of color. */
TEST(light_units_candela_by_default) {
  double cd = 1000.0 / (4.0 * PI) * 683.0;
  char lights[256];
  snprintf(lights, sizeof lights,
           "[{\"name\":\"Light\",\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":%.17g}]",
           cd);
  blender_style b = {0};
  b.lights = lights;
  b.cameras = BLENDER_CAMERA;
  messages m;
  bbc_result r;
  bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  CHECK_INT(s->light_units, BBC_LIGHT_UNITS_PHOTOMETRIC);
  double watts_per_sr = 1000.0 / (4.0 * PI);
  CHECK_NEAR(s->point_lights[0].intensity[0], watts_per_sr, 1e-4);
  CHECK_NEAR(s->point_lights[0].intensity[1], 0.5 * watts_per_sr, 1e-4);
  CHECK_NEAR(s->point_lights[0].intensity[2], 0.25 * watts_per_sr, 1e-4);
  bbc_scene_free(s);

  /* The override reads the same number as W/sr. */
  s = load_blender(&b, BBC_LIGHT_UNITS_RADIOMETRIC, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(s->light_units, BBC_LIGHT_UNITS_RADIOMETRIC);
  CHECK_NEAR(s->point_lights[0].intensity[0], (float)cd, 0.0);
  bbc_scene_free(s);
}

/* asset.extras.bbc.light_units "radiometric" keeps the number; the photometric
 * override divides it again; a value of another kind is refused in one line. */
TEST(light_units_from_the_asset) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":50}]";
  b.cameras = BLENDER_CAMERA;
  b.asset_extras = "{\"bbc\":{\"light_units\":\"radiometric\"}}";
  messages m;
  bbc_result r;
  bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_NEAR(s->point_lights[0].intensity[0], 50.0, 0.0);
  bbc_scene_free(s);
  s = load_blender(&b, BBC_LIGHT_UNITS_PHOTOMETRIC, &m, &r);
  REQUIRE(s != NULL);
  CHECK_NEAR(s->point_lights[0].intensity[0], (float)(50.0 / 683.0), 0.0);
  bbc_scene_free(s);
  b.asset_extras = "{\"bbc\":{\"light_units\":\"photometric\"}}";
  s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_NEAR(s->point_lights[0].intensity[0], (float)(50.0 / 683.0), 0.0);
  bbc_scene_free(s);

  const char *bad[2] = {"{\"bbc\":{\"light_units\":\"watts\"}}", "{\"bbc\":{\"light_units\":1}}"};
  for (int k = 0; k < 2; k++) {
    b.asset_extras = bad[k];
    s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
    CHECK(s == NULL);
    CHECK_INT(r, BBC_ERR_SCENE);
    CHECK_INT(m.errors, 1);
    CHECK_STR_CONTAINS(m.error, "blender.gltf: asset.extras.bbc.light_units");
    bbc_scene_free(s);
  }
}

/* Blender's glass: Principled BSDF transmission 1, roughness 0, exported with
 * KHR_materials_transmission and no KHR_materials_volume. On the closed octahedron it is
 * a solid dielectric, on the open half a refracting surface; each says so once. */
#define BLENDER_GLASS                                                                         \
  "[{\"name\":\"Floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.8,0.8,1],"              \
  "\"metallicFactor\":0,\"roughnessFactor\":0.5}},"                                             \
  "{\"name\":\"Glass\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":0},"       \
  "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},"                    \
  "\"KHR_materials_ior\":{\"ior\":1.45}}}]"

TEST(transmission_without_volume) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = BLENDER_CAMERA;
  b.materials = BLENDER_GLASS;
  for (int open = 0; open < 2; open++) {
    b.caster = open ? 2 : 1;
    messages m;
    bbc_result r;
    bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
    CHECK_INT(r, BBC_OK);
    REQUIRE(s != NULL);
    const bbc_mesh *ico = find_mesh(s, "Ico");
    REQUIRE(ico != NULL);
    CHECK_INT(ico->triangle_count, open ? 4 : 8);
    CHECK_INT(s->materials[ico->material].type, BBC_MATERIAL_DIELECTRIC);
    CHECK_NEAR(s->materials[ico->material].ior, 1.45, 1e-6);
    CHECK_INT(ico->role, BBC_ROLE_CASTER);
    CHECK_INT(ico->closed, !open);
    CHECK_INT(m.warnings, 1);
    int glass = -1;
    for (int i = 0; i < m.warnings && i < 8; i++)
      if (strstr(m.warning[i], "KHR_materials_volume")) glass = i;
    REQUIRE(glass >= 0);
    CHECK_STR_CONTAINS(m.warning[glass], "mesh \"Ico\" (material 1 (\"Glass\"))");
    CHECK_STR_CONTAINS(m.warning[glass], open ? "open mesh; it is rendered as one refracting surface"
                                              : "closed, so it is rendered as a solid dielectric");
    bbc_scene_free(s);
  }
}

/* Blender's camera: aspectRatio 16:9 and no image size. The image follows the aspect
 * ratio (longer side 640) instead of 640x480 cropping its sides; a size given on the
 * camera data (cameras[i].extras, where Blender writes camera custom properties) is
 * read, and the node's extras take precedence. */
TEST(camera_aspect_and_camera_extras) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = BLENDER_CAMERA;
  messages m;
  bbc_result r;
  bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 0);
  CHECK_INT(s->camera.width, 640);
  CHECK_INT(s->camera.height, 360);
  CHECK_NEAR(s->camera.aspect, 16.0 / 9.0, 1e-15);
  bbc_scene_free(s);

  b.cameras = "[{\"type\":\"perspective\",\"perspective\":{\"aspectRatio\":0.5,\"yfov\":0.5,"
              "\"znear\":0.1}}]";
  s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(s->camera.width, 320);
  CHECK_INT(s->camera.height, 640);
  bbc_scene_free(s);

  /* Camera-data extras: a width alone gives the height from the aspect ratio. */
  b.cameras = "[{\"name\":\"Cam\",\"type\":\"perspective\",\"extras\":{\"bbc\":{\"width\":1280}},"
              "\"perspective\":{\"aspectRatio\":1.7777777777777777,\"yfov\":0.4,\"znear\":0.1}}]";
  s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(m.warnings, 0);
  CHECK_INT(s->camera.width, 1280);
  CHECK_INT(s->camera.height, 720);
  bbc_scene_free(s);

  /* The node's extras win over the camera's; a size against the aspect ratio warns. */
  b.camera_node_extras = "{\"bbc\":{\"width\":200,\"height\":100}}";
  s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(s->camera.width, 200);
  CHECK_INT(s->camera.height, 100);
  CHECK_INT(m.warnings, 1);
  CHECK_STR_CONTAINS(m.warning[0], "the image is 200x100 but aspectRatio is 1.77778");
  bbc_scene_free(s);
}

/* Extras that look meant for bbc but cannot be read: one warning each, naming the
 * object and the key, and the scene still loads. */
TEST(unreadable_bbc_extras_warn) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = "[{\"name\":\"Cam\",\"type\":\"perspective\",\"extras\":{\"bbc\":{\"width\":\"1280\","
              "\"fov\":1}},\"perspective\":{\"aspectRatio\":1.5,\"yfov\":0.4,\"znear\":0.1}}]";
  b.camera_node_extras = "{\"bbc.role\":\"caster\",\"bbc_width\":100,\"other\":1}";
  b.asset_extras = "{\"bbc\":\"{\\\"light_units\\\":\\\"radiometric\\\"}\"}";
  messages m;
  bbc_result r;
  bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  CHECK_INT(s->camera.width, 640); /* the string was not read */
  CHECK_INT(s->camera.height, 427);
  const char *expected[] = {
      "asset: extras.bbc is not a JSON object and is ignored",
      "camera 0 (\"Cam\"): extras.bbc.fov is not read here (bbc reads width, height)",
      "camera 0 (\"Cam\"): extras.bbc.width is not a number and is ignored (it is the string \"1280\")",
      "node 3 (\"Camera\"): extras key \"bbc.role\" is not read; bbc reads the object extras.bbc",
      "node 3 (\"Camera\"): extras key \"bbc_width\" is not read",
  };
  int n = (int)(sizeof expected / sizeof expected[0]);
  CHECK_INT(m.warnings, n);
  for (int k = 0; k < n; k++) {
    int found = 0;
    for (int i = 0; i < m.warnings && i < 8; i++) found |= strstr(m.warning[i], expected[k]) != NULL;
    if (!found) harness_fail(__FILE__, __LINE__, "no warning \"%s\"", expected[k]);
  }
  bbc_scene_free(s);
}

/* Camera animation: key times [0, 1]; translations (0,1,4) -> (2,1,4); rotations identity
 * -> 90 degrees about y; and a cubic spline of two keys at (0,1,4) whose first out-tangent
 * is (1,0,0), so x(u) = u^3 - 2u^2 + u. */
static const float ANIM_DATA[] = {
    0, 1,                                           /* 0: times */
    0, 1, 4, 2, 1, 4,                               /* 8: translations */
    0, 0, 0, 1, 0, 0.70710678f, 0, 0.70710678f,     /* 32: rotations */
    0, 0, 0, 0, 1, 4, 1, 0, 0, 0, 0, 0, 0, 1, 4, 0, 0, 0, /* 64: cubic in, value, out */
};
#define ANIM_ACCESSORS                                                                          \
  "{\"bufferView\":7,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\",\"min\":[0],\"max\":[1]}," \
  "{\"bufferView\":7,\"byteOffset\":8,\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"},"       \
  "{\"bufferView\":7,\"byteOffset\":32,\"componentType\":5126,\"count\":2,\"type\":\"VEC4\"},"      \
  "{\"bufferView\":7,\"byteOffset\":64,\"componentType\":5126,\"count\":6,\"type\":\"VEC3\"}"

static bbc_scene *load_animated(const char *animations, int rig, messages *m, bbc_result *r) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = "[{\"name\":\"Main\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1}},"
              "{\"name\":\"TopCam\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.6,\"znear\":0.1}}]";
  b.more_cameras = "{\"name\":\"Top\",\"camera\":1,\"translation\":[0,5,0]}";
  b.anim_data = ANIM_DATA;
  b.anim_floats = sizeof ANIM_DATA / sizeof ANIM_DATA[0];
  b.anim_accessors = ANIM_ACCESSORS;
  b.animations = animations;
  b.rig = rig;
  return load_blender(&b, BBC_LIGHT_UNITS_FILE, m, r);
}

static void check_camera_at(const bbc_scene *s, uint32_t index, double t, double x, double y,
                            double z, double angle) {
  bbc_camera c;
  CHECK_INT(bbc_scene_camera_at(s, index, t, &c), BBC_OK);
  CHECK_NEAR(c.position.x, x, 1e-6);
  CHECK_NEAR(c.position.y, y, 1e-6);
  CHECK_NEAR(c.position.z, z, 1e-6);
  /* The camera looks along -w; a turn by angle about y takes w = z to (sin, 0, cos). */
  CHECK_NEAR(c.w.x, sin(angle), 1e-6);
  CHECK_NEAR(c.w.y, 0.0, 1e-6);
  CHECK_NEAR(c.w.z, cos(angle), 1e-6);
}

TEST(cameras_and_animation_channels) {
  messages m;
  bbc_result r;
  bbc_scene *s = load_animated(
      "[{\"name\":\"CameraAction\",\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,"
      "\"path\":\"translation\"}},{\"sampler\":1,\"target\":{\"node\":3,\"path\":\"rotation\"}}],"
      "\"samplers\":[{\"input\":7,\"output\":8},{\"input\":7,\"output\":9,"
      "\"interpolation\":\"LINEAR\"}]}]",
      0, &m, &r);
  CHECK_INT(r, BBC_OK);
  REQUIRE(s != NULL);
  CHECK_INT(s->camera_count, 2);
  CHECK(strcmp(s->cameras[0].name, "Main") == 0);
  CHECK(strcmp(s->cameras[1].name, "TopCam") == 0);
  CHECK(strcmp(s->camera.name, "Main") == 0);
  CHECK_INT(s->cameras[0].animated, 1);
  CHECK_INT(s->cameras[1].animated, 0);
  CHECK_NEAR(s->cameras[0].time_start, 0.0, 0.0);
  CHECK_NEAR(s->cameras[0].time_end, 1.0, 0.0);
  CHECK_NEAR(s->cameras[1].yfov, 0.6, 1e-15);
  CHECK_NEAR(s->cameras[1].position.y, 5.0, 0.0);
  check_camera_at(s, 0, 0.25, 0.5, 1, 4, 0.25 * PI / 2);
  check_camera_at(s, 0, -1.0, 0, 1, 4, 0.0);
  check_camera_at(s, 0, 5.0, 2, 1, 4, PI / 2);
  check_camera_at(s, 1, 0.5, 0, 5, 0, 0.0);
  bbc_camera c;
  CHECK_INT(bbc_scene_camera_at(s, 2, 0.0, &c), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_scene_camera_at(s, 0, NAN, &c), BBC_ERR_INVALID_ARGUMENT);
  bbc_scene_free(s);

  /* STEP holds the key until the next one. */
  s = load_animated("[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
                    "\"samplers\":[{\"input\":7,\"output\":8,\"interpolation\":\"STEP\"}]}]",
                    0, &m, &r);
  REQUIRE(s != NULL);
  check_camera_at(s, 0, 0.99, 0, 1, 4, 0.0);
  check_camera_at(s, 0, 1.0, 2, 1, 4, 0.0);
  bbc_scene_free(s);

  /* CUBICSPLINE: x(1/2) = 1/8 - 1/2 + 1/2 = 0.125 (tangents scale with the key interval). */
  s = load_animated("[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
                    "\"samplers\":[{\"input\":7,\"output\":10,\"interpolation\":\"CUBICSPLINE\"}]}]",
                    0, &m, &r);
  REQUIRE(s != NULL);
  check_camera_at(s, 0, 0.5, 0.125, 1, 4, 0.0);
  bbc_scene_free(s);

  /* An animated parent moves the camera: the rig's (1,1,4) at t = 1/2 plus the
   * camera's own (0,1,4). */
  s = load_animated("[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":4,\"path\":\"translation\"}}],"
                    "\"samplers\":[{\"input\":7,\"output\":8}]}]",
                    1, &m, &r);
  REQUIRE(s != NULL);
  CHECK_INT(s->cameras[0].animated, 1);
  check_camera_at(s, 0, 0.5, 1, 2, 8, 0.0);
  bbc_scene_free(s);
}

/* Broken animations are refused in one line naming the animation. */
TEST(bad_animations_fail_cleanly) {
  static const struct {
    const char *animations, *message;
  } cases[] = {
      {"[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":9,\"path\":\"translation\"}}],"
       "\"samplers\":[{\"input\":7,\"output\":8}]}]",
       "animation 0 channel 0 targets node 9, but the file has 6 nodes"},
      {"[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
       "\"samplers\":[{\"input\":7,\"output\":9}]}]",
       "animation 0 channel 0 output: accessor 9 has the wrong type"},
      {"[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
       "\"samplers\":[{\"input\":7,\"output\":10}]}]",
       "animation 0 channel 0: 2 key times need 2 values, the output has 6"},
      {"[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
       "\"samplers\":[{\"input\":8,\"output\":8}]}]",
       "animation 0 channel 0 input: accessor 8 has the wrong type"},
      {"[{\"channels\":[{\"sampler\":3,\"target\":{\"node\":3,\"path\":\"translation\"}}],"
       "\"samplers\":[{\"input\":7,\"output\":8}]}]",
       "animation 0 channel 0 uses sampler 3, but it has 1"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    messages m;
    bbc_result r;
    bbc_scene *s = load_animated(cases[i].animations, 0, &m, &r);
    CHECK(s == NULL);
    CHECK_INT(r, BBC_ERR_GLTF);
    CHECK_INT(m.errors, 1);
    CHECK_STR_CONTAINS(m.error, cases[i].message);
    bbc_scene_free(s);
  }
}

/* A re-export that permutes vertices and triangles and rotates corners (as Blender's
 * does) loads into the same scene arrays, so its fingerprint, and the triangle indices
 * a cache stores, are those of the first export; moving one vertex changes them. */
TEST(shuffled_reexport_keeps_the_scene_identity) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = BLENDER_CAMERA;
  b.materials = BLENDER_GLASS;
  b.caster = 1;
  bbc_precompute_params params;
  bbc_precompute_params_default(&params);
  messages m;
  bbc_result r;
  bbc_scene *first = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(first != NULL);
  bbc_fingerprint f0, f;
  REQUIRE(bbc_fingerprint_compute(first, &params, &f0) == BBC_OK);
  for (unsigned k = 1; k <= 3; k++) {
    b.shuffle = k;
    char *text = blender_style_write(&b);
    char *plain = (b.shuffle = 0, blender_style_write(&b));
    b.shuffle = k;
    CHECK(strcmp(text, plain) != 0); /* the control: the files do differ */
    free(text);
    free(plain);
    bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
    REQUIRE(s != NULL);
    REQUIRE(s->vertex_count == first->vertex_count && s->triangle_count == first->triangle_count);
    CHECK(memcmp(s->positions, first->positions, 12 * (size_t)s->vertex_count) == 0);
    CHECK(memcmp(s->normals, first->normals, 12 * (size_t)s->vertex_count) == 0);
    CHECK(memcmp(s->indices, first->indices, 12 * (size_t)s->triangle_count) == 0);
    REQUIRE(bbc_fingerprint_compute(s, &params, &f) == BBC_OK);
    CHECK(f.total == f0.total);
    bbc_scene_free(s);
  }
  b.shuffle = 2;
  b.moved = 1e-3f;
  bbc_scene *s = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(s != NULL);
  REQUIRE(bbc_fingerprint_compute(s, &params, &f) == BBC_OK);
  CHECK(f.geometry != f0.geometry);
  CHECK(f.total != f0.total);
  bbc_scene_free(s);
  bbc_scene_free(first);
}

/* A cache of the Blender-style glass scene (TT, small), in memory. */
static void *blender_cache(const bbc_scene *scene, int omit_geometry, size_t *size) {
  bbc_precompute_options options;
  memset(&options, 0, sizeof options);
  bbc_precompute_params_default(&options.params);
  options.params.max_level = 2;
  options.params.grid_resolution = 16;
  options.params.chains = BBC_CHAIN_BIT(BBC_CHAIN_TT);
  options.threads = 1;
  bbc_cache_builder *builder = NULL;
  bbc_precompute_stats stats;
  if (bbc_precompute(&builder, scene, &options, &stats) != BBC_OK) return NULL;
  void *bytes = NULL;
  bbc_cache_write_options wo;
  memset(&wo, 0, sizeof wo);
  wo.omit_geometry = omit_geometry;
  if (bbc_cache_builder_write_memory(builder, &bytes, size, &wo) != BBC_OK) bytes = NULL;
  bbc_cache_builder_free(builder);
  return bytes;
}

/* End to end, as the issue found it: Blender's glass (no KHR_materials_volume) under a
 * candela light gives a cache with tuples; that cache accepts a shuffled re-export of
 * the same file and refuses one with a moved vertex. */
TEST(blender_glass_cache_survives_a_reexport) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = BLENDER_CAMERA;
  b.materials = BLENDER_GLASS;
  b.caster = 1;
  messages m;
  bbc_result r;
  bbc_scene *first = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(first != NULL);
  size_t size = 0;
  void *bytes = blender_cache(first, 0, &size);
  REQUIRE(bytes != NULL);
  bbc_cache *cache = NULL;
  REQUIRE(bbc_cache_open_memory(&cache, bytes, size, NULL) == BBC_OK);
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  CHECK(info.tuple_count > 0);
  CHECK_INT(bbc_cache_check_scene(cache, first), BBC_OK);
  b.shuffle = 2;
  bbc_scene *again = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(again != NULL);
  CHECK_INT(bbc_cache_check_scene(cache, again), BBC_OK);
  b.moved = 1e-4f;
  bbc_scene *moved = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(moved != NULL);
  CHECK_INT(bbc_cache_check_scene(cache, moved), BBC_ERR_SCENE_MISMATCH);
  bbc_cache_close(cache);
  free(bytes);
  bbc_scene_free(moved);
  bbc_scene_free(again);
  bbc_scene_free(first);
}

/* Flips byte `at` of section GEOM (at < 0: from its end) and reseals the file's
 * checksums (section, directory, header), so that only GEOM's own rules can tell. */
static void damage_geometry(uint8_t *file, long at) {
  uint32_t n;
  memcpy(&n, file + 12, 4);
  for (uint32_t i = 0; i < n; i++) {
    uint8_t *e = file + 64 + 32 * i;
    if (memcmp(e, "GEOM", 4) != 0) continue;
    uint64_t off, size;
    memcpy(&off, e + 8, 8);
    memcpy(&size, e + 16, 8);
    file[off + (at < 0 ? (long)size + at : at)] ^= 0x01;
    uint32_t crc = (uint32_t)crc32(0, file + off, (uInt)size);
    memcpy(e + 24, &crc, 4);
  }
  uint32_t crc = (uint32_t)crc32(0, file + 64, 32 * n);
  memcpy(file + 28, &crc, 4);
  crc = (uint32_t)crc32(0, file, 60);
  memcpy(file + 60, &crc, 4);
}

/* Sec. 8.1: a re-export whose floats moved in their last bits (and whose canonical order
 * changed with them) is matched within the quanta and given the cache's geometry
 * exactly; a moved vertex, noise above the quanta, a cache without GEOM and a damaged
 * GEOM are refused. */
TEST(float_noise_reexport_is_matched_within_the_quanta) {
  blender_style b = {0};
  b.lights = "[{\"type\":\"point\",\"intensity\":5435}]";
  b.cameras = BLENDER_CAMERA;
  b.materials = BLENDER_GLASS;
  b.caster = 1;
  messages m;
  bbc_result r;
  bbc_scene *first = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(first != NULL);
  size_t size = 0, bare_size = 0;
  uint8_t *bytes = blender_cache(first, 0, &size);
  uint8_t *bare = blender_cache(first, 1, &bare_size);
  REQUIRE(bytes != NULL && bare != NULL);
  CHECK(size > bare_size);
  bbc_cache *cache = NULL, *no_geom = NULL;
  REQUIRE(bbc_cache_open_memory(&cache, bytes, size, NULL) == BBC_OK);
  REQUIRE(bbc_cache_open_memory(&no_geom, bare, bare_size, NULL) == BBC_OK);
  CHECK_INT(bbc_cache_validate(cache, NULL, NULL), BBC_OK);
  bbc_scene_match match;
  CHECK_INT(bbc_cache_match_scene(cache, first, &match), BBC_OK);
  CHECK_INT(match.adopted, 0);

  b.shuffle = 3;
  b.noise = 2e-7f;
  bbc_scene *noisy = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(noisy != NULL);
  CHECK_INT(bbc_cache_check_scene(cache, noisy), BBC_ERR_SCENE_MISMATCH); /* exact */
  CHECK_INT(bbc_cache_match_scene(no_geom, noisy, &match), BBC_ERR_SCENE_MISMATCH);
  CHECK_INT(bbc_cache_match_scene(cache, noisy, &match), BBC_OK);
  CHECK_INT(match.adopted, 1);
  CHECK(match.triangles_moved > 0);
  CHECK(match.position_error > 0.0 && match.position_error <= 4e-7);
  CHECK(match.normal_error > 0.0 && match.normal_error <= 1e-6);
  /* Now exactly the scene of the cache. */
  CHECK_INT(bbc_cache_check_scene(cache, noisy), BBC_OK);
  CHECK(memcmp(noisy->positions, first->positions, 12 * (size_t)first->vertex_count) == 0);
  CHECK(memcmp(noisy->normals, first->normals, 12 * (size_t)first->vertex_count) == 0);
  CHECK(memcmp(noisy->indices, first->indices, 12 * (size_t)first->triangle_count) == 0);
  for (uint32_t i = 0; i < first->mesh_count; i++) {
    CHECK_INT(noisy->meshes[i].closed, first->meshes[i].closed);
    CHECK_INT(noisy->meshes[i].outward, first->meshes[i].outward);
  }
  /* The same noise plus a real change of 1e-4, then noise above the quanta. */
  b.moved = 1e-4f;
  bbc_scene *moved = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(moved != NULL);
  CHECK_INT(bbc_cache_match_scene(cache, moved, &match), BBC_ERR_SCENE_MISMATCH);
  CHECK_INT(match.adopted, 0);
  b.moved = 0.0f;
  b.noise = 1e-4f;
  bbc_scene *loud = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(loud != NULL);
  CHECK_INT(bbc_cache_match_scene(cache, loud, &match), BBC_ERR_SCENE_MISMATCH);

  /* A damaged frame behind valid checksums: open passes (R-GEO-1 holds), full
   * validation and the match refuse it. A damaged head is refused at open. */
  b.noise = 2e-7f;
  bbc_scene *again = load_blender(&b, BBC_LIGHT_UNITS_FILE, &m, &r);
  REQUIRE(again != NULL);
  uint8_t *bad = malloc(size);
  memcpy(bad, bytes, size);
  damage_geometry(bad, -40);
  bbc_cache *damaged = NULL;
  REQUIRE(bbc_cache_open_memory(&damaged, bad, size, NULL) == BBC_OK);
  CHECK_INT(bbc_cache_validate(damaged, NULL, NULL), BBC_ERR_CORRUPT);
  CHECK_INT(bbc_cache_match_scene(damaged, again, &match), BBC_ERR_CORRUPT);
  CHECK_INT(match.adopted, 0);
  bbc_cache_close(damaged);
  memcpy(bad, bytes, size);
  damage_geometry(bad, 0); /* the vertex count */
  damaged = NULL;
  CHECK_INT(bbc_cache_open_memory(&damaged, bad, size, NULL), BBC_ERR_CORRUPT);
  bbc_cache_close(damaged);
  free(bad);

  bbc_cache_close(cache);
  bbc_cache_close(no_geom);
  free(bytes);
  free(bare);
  bbc_scene_free(again);
  bbc_scene_free(loud);
  bbc_scene_free(moved);
  bbc_scene_free(noisy);
  bbc_scene_free(first);
}

/* ------------------------------------------------------------------ failures */

static bbc_result code_from_name(const char *name, int *known) {
  static const struct {
    const char *prefix;
    bbc_result code;
  } codes[] = {{"gltf--", BBC_ERR_GLTF}, {"scene--", BBC_ERR_SCENE}, {"io--", BBC_ERR_IO}};
  *known = 1;
  for (size_t i = 0; i < sizeof codes / sizeof codes[0]; i++)
    if (strncmp(name, codes[i].prefix, strlen(codes[i].prefix)) == 0) return codes[i].code;
  *known = 0;
  return BBC_OK;
}

/* Each file of tests/corpus/invalid-gltf fails with exactly the code its name starts
 * with, one error line naming the file, no warnings about it afterwards, and the same
 * code when given to the memory loader. */
TEST(invalid_corpus) {
  int count = 0;
  char **names = list_dir(INVALID_DIR, ".gltf", ".glb", &count);
  CHECK(count >= 20);
  for (int i = 0; i < count; i++) {
    int known;
    bbc_result expected = code_from_name(names[i], &known);
    if (!known) {
      harness_fail(__FILE__, __LINE__, "%s: name does not start with a result code", names[i]);
      continue;
    }
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", INVALID_DIR, names[i]);
    messages m;
    bbc_result r;
    bbc_scene *s = load(path, &m, &r);
    fprintf(stderr, "  %s: %s\n", names[i], m.error);
    if (r != expected)
      harness_fail(__FILE__, __LINE__, "%s: got %s, expected %s", names[i], bbc_result_string(r),
                   bbc_result_string(expected));
    CHECK(s == NULL);
    CHECK_INT(m.errors, 1);
    CHECK_INT(m.error_code, expected);
    CHECK_STR_CONTAINS(m.error, path);
    CHECK(strchr(m.error, '\n') == NULL);
    bbc_scene_free(s);

    size_t size;
    char *bytes = read_file(path, &size);
    REQUIRE(bytes != NULL);
    messages mm = {0};
    bbc_scene_options options = {on_error, on_warning, &mm, BBC_LIGHT_UNITS_FILE};
    bbc_scene *ms = NULL;
    r = bbc__scene_load_memory(&ms, bytes, size, names[i], INVALID_DIR "/", &options);
    if (r != expected)
      harness_fail(__FILE__, __LINE__, "%s from memory: got %s, expected %s", names[i],
                   bbc_result_string(r), bbc_result_string(expected));
    CHECK_INT(mm.errors, 1);
    CHECK_STR_CONTAINS(mm.error, names[i]);
    bbc_scene_free(ms);
    free(bytes);
  }
  free_list(names);
}

/* A missing file is named whole, however long its name; only data URIs are cut short. */
TEST(missing_buffer_named_whole) {
  messages m;
  bbc_result r;
  bbc_scene *s = load(INVALID_DIR "/gltf--missing-buffer-long-name.gltf", &m, &r);
  CHECK_INT(r, BBC_ERR_GLTF);
  CHECK(s == NULL);
  CHECK_STR_CONTAINS(m.error,
                     "a_buffer_whose_name_is_longer_than_sixty_characters_like_TransmissionTest_"
                     "binary.bin");
  s = load(INVALID_DIR "/gltf--buffer-shorter-than-declared.gltf", &m, &r);
  CHECK(s == NULL);
  CHECK_STR_CONTAINS(m.error, "base64,AAAAAAAAAAAAAAAAAACAPwA...");
}

TEST(io_missing_file) {
  const char *path = INVALID_DIR "/io--does-not-exist.gltf";
  messages m;
  bbc_result r;
  bbc_scene *s = load(path, &m, &r);
  CHECK_INT(r, BBC_ERR_IO);
  CHECK(s == NULL);
  CHECK_INT(m.errors, 1);
  CHECK_INT(m.error_code, BBC_ERR_IO);
  CHECK_STR_CONTAINS(m.error, path);
}

TEST(io_directory) {
  const char *path = VALID_DIR;
  messages m;
  bbc_result r;
  bbc_scene *s = load(path, &m, &r);
  CHECK_INT(r, BBC_ERR_IO);
  CHECK(s == NULL);
  CHECK_INT(m.errors, 1);
  CHECK_STR_CONTAINS(m.error, path);
}

TEST(null_arguments) {
  messages m = {0};
  bbc_scene_options options = {on_error, on_warning, &m, BBC_LIGHT_UNITS_FILE};
  CHECK_INT(bbc_scene_load(NULL, TEST_SCENE("plane1k.gltf"), &options), BBC_ERR_INVALID_ARGUMENT);
  bbc_scene *s = (bbc_scene *)1;
  CHECK_INT(bbc_scene_load(&s, NULL, &options), BBC_ERR_INVALID_ARGUMENT);
  CHECK(s == NULL);
  CHECK_INT(m.errors, 2);
  /* Without options nothing is reported, and the result is the same. */
  CHECK_INT(bbc_scene_load(&s, INVALID_DIR "/io--does-not-exist.gltf", NULL), BBC_ERR_IO);
  CHECK(s == NULL);
  bbc_scene_free(NULL);
  bbc__gltf_free(NULL);
}

/* Every truncation and many single-byte corruptions of two small files either load or
 * fail cleanly, always with exactly one error line on failure and none on success.
 * Under ASan or valgrind this also proves the failure paths free everything. */
static void mutate_file(const char *path, const char *base_dir) {
  size_t size;
  unsigned char *bytes = (unsigned char *)read_file(path, &size);
  REQUIRE(bytes != NULL);
  unsigned char *copy = malloc(size ? size : 1);
  REQUIRE(copy != NULL);
  size_t step = (size_t)harness_scale(7, 1);
  int loaded = 0, failed = 0;
  for (size_t pass = 0; pass < 2; pass++) {
    for (size_t i = 0; i < size; i += (pass == 0 ? 1 : step)) {
      size_t n = size;
      memcpy(copy, bytes, size);
      if (pass == 0)
        n = i; /* truncated to i bytes */
      else
        copy[i] ^= (unsigned char)(0x5A + i); /* one corrupted byte */
      messages m = {0};
      bbc_scene_options options = {on_error, on_warning, &m, BBC_LIGHT_UNITS_FILE};
      bbc_scene *s = NULL;
      bbc_result r = bbc__scene_load_memory(&s, copy, n, "mutant", base_dir, &options);
      if (r == BBC_OK) {
        loaded++;
        CHECK(s != NULL);
        CHECK_INT(m.errors, 0);
      } else {
        failed++;
        CHECK(s == NULL);
        if (m.errors != 1) {
          harness_fail(__FILE__, __LINE__, "%s pass %zu at %zu: %d error lines", path, pass, i,
                       m.errors);
          break;
        }
      }
      bbc_scene_free(s);
    }
  }
  fprintf(stderr, "  %s: %d loaded, %d failed\n", path, loaded, failed);
  CHECK(failed > 0);
  free(copy);
  free(bytes);
}

TEST(mutated_inputs_fail_cleanly) {
  mutate_file(SOURCE_PATH("tests/corpus/valid/small.glb"), NULL);
  mutate_file(SOURCE_PATH("tests/corpus/valid/no_normals.gltf"), NULL);
}

/* ------------------------------------------------------------------ result strings */

TEST(result_strings) {
  for (int code = 0; code <= BBC_ERR_SCENE; code++) {
    const char *s = bbc_result_string((bbc_result)code);
    REQUIRE(s != NULL);
    CHECK(strlen(s) > 0);
    CHECK(strcmp(s, "unknown result code") != 0);
    for (int other = 0; other < code; other++)
      CHECK(strcmp(s, bbc_result_string((bbc_result)other)) != 0);
  }
  CHECK(strcmp(bbc_result_string((bbc_result)9999), "unknown result code") == 0);
  CHECK(bbc_version_string() != NULL && bbc_version_string()[0] != '\0');
}
