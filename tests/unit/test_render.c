/* The path tracer against analytic results: a diffuse floor under a point light, a
 * flat mirror with a small area light, plus camera rays and determinism. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

static bbc_scene *load(const char *path) {
  bbc_scene *scene = NULL;
  bbc_result r = bbc_scene_load(&scene, path, NULL);
  if (r != BBC_OK) harness_fail(__FILE__, __LINE__, "cannot load %s: %d", path, (int)r);
  return scene;
}

/* The receiver's plane y = height and its x/z extent, from the scene's receiver mesh. */
typedef struct floor_info {
  double y, x0, x1, z0, z1;
  float albedo;
} floor_info;

static int find_floor(const bbc_scene *scene, floor_info *f) {
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER) continue;
    f->x0 = f->z0 = 1e30;
    f->x1 = f->z1 = -1e30;
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = scene->positions + 3 * (size_t)v;
      f->y = p[1];
      f->x0 = fmin(f->x0, p[0]);
      f->x1 = fmax(f->x1, p[0]);
      f->z0 = fmin(f->z0, p[2]);
      f->z1 = fmax(f->z1, p[2]);
    }
    f->albedo = scene->materials[mesh->material].base_color[0];
    return 1;
  }
  return 0;
}

/* Where the primary ray through film point (px, py) meets the floor plane; 0 if it
 * misses the floor's extent or something else (the light, say) is in front of it. */
static int floor_point(const bbc_scene *scene, const bbc_accel *accel, const floor_info *f,
                       uint32_t w, uint32_t h, double px, double py, bbc_vec3 *p) {
  bbc_vec3 o, d;
  bbc_camera_ray(&scene->camera, w, h, px, py, &o, &d);
  if (!(d.y < 0)) return 0;
  double t = (f->y - o.y) / d.y;
  *p = v3_madd(o, d, t);
  double margin = 1e-3;
  if (!(p->x > f->x0 + margin && p->x < f->x1 - margin && p->z > f->z0 + margin &&
        p->z < f->z1 - margin))
    return 0;
  return !bbc_accel_occluded(accel, o, d, 0.0, t * (1.0 - 1e-6));
}

TEST(camera_rays) {
  bbc_camera camera;
  memset(&camera, 0, sizeof camera);
  camera.position = v3(1, 2, 3);
  camera.u = v3(1, 0, 0);
  camera.v = v3(0, 1, 0);
  camera.w = v3(0, 0, 1);
  camera.yfov = 0.8;
  bbc_vec3 o, d;
  bbc_camera_ray(&camera, 200, 100, 100, 50, &o, &d);
  CHECK_NEAR(o.x, 1, 0);
  CHECK_NEAR(d.z, -1, 1e-15);
  /* The top edge of the film is yfov/2 above the axis, the right edge at the angle
   * given by the aspect ratio 2. */
  bbc_camera_ray(&camera, 200, 100, 100, 0, &o, &d);
  CHECK_NEAR(atan2(d.y, -d.z), 0.4, 1e-12);
  bbc_camera_ray(&camera, 200, 100, 200, 50, &o, &d);
  CHECK_NEAR(d.x / -d.z, 2 * tan(0.4), 1e-12);
  CHECK_NEAR(v3_length(d), 1, 1e-15);
}

/* A diffuse floor under a point light: radiance albedo/pi * I cos(theta) / r^2 at every
 * point. The floor is alone, so each sample's value is exact at its jittered film
 * position; the pixel mean must therefore lie between the least and greatest exact
 * value over the pixel (sampled on a fine grid), up to the relative 1e-4 by which the
 * shadow ray's origin offset (2e-5 of the coordinates) can move the result. */
TEST(floor_point_light_analytic) {
  bbc_scene *scene = load(TEST_SCENE("floor.gltf"));
  REQUIRE(scene);
  floor_info f;
  REQUIRE(find_floor(scene, &f));
  REQUIRE(scene->point_light_count == 1);
  const bbc_point_light *light = &scene->point_lights[0];
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, scene, NULL, NULL) == BBC_OK);
  const uint32_t w = 48, h = 36;
  bbc_image *image = NULL;
  REQUIRE(bbc_image_create(&image, w, h) == BBC_OK);
  bbc_render_options options;
  memset(&options, 0, sizeof options);
  options.spp = 8;
  REQUIRE(bbc_render(scene, accel, &options, image, NULL) == BBC_OK);

  int checked = 0;
  for (uint32_t y = 0; y < h; y++) {
    for (uint32_t x = 0; x < w; x++) {
      double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
      int inside = 1;
      const int n = 9;
      for (int j = 0; j <= n && inside; j++) {
        for (int i = 0; i <= n && inside; i++) {
          bbc_vec3 p;
          if (!floor_point(scene, accel, &f, w, h, x + (double)i / n, y + (double)j / n, &p)) {
            inside = 0;
            break;
          }
          bbc_vec3 l = v3_sub(light->position, p);
          double r2 = v3_dot(l, l);
          double cos_t = l.y / sqrt(r2);
          for (int c = 0; c < 3; c++) {
            double value = f.albedo / PI * light->intensity[c] * cos_t / r2;
            lo[c] = fmin(lo[c], value);
            hi[c] = fmax(hi[c], value);
          }
        }
      }
      if (!inside) continue;
      checked++;
      for (int c = 0; c < 3; c++) {
        double got = image->rgb[3 * ((size_t)y * w + x) + c];
        double slack = 1e-4 * hi[c];
        if (!(got >= lo[c] - slack && got <= hi[c] + slack))
          harness_fail(__FILE__, __LINE__, "pixel (%u,%u) channel %d: %.9g not in [%.9g, %.9g]", x,
                       y, c, got, lo[c], hi[c]);
      }
    }
  }
  CHECK(checked > (int)(w * h) / 4);
  bbc_image_free(image);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
}

/* Irradiance at floor point p (normal +y) from the emitting triangles, each optionally
 * mirrored across the plane through m with normal n, by midpoint quadrature on a
 * k x k subdivision of each triangle. Mirrored light counts only where the segment to
 * it crosses the mirror rectangle [y0,y1] x [z0,z1] of the plane x = m.x. */
typedef struct mirror_info {
  bbc_vec3 m, n;
  double y0, y1, z0, z1;
} mirror_info;

static bbc_vec3 mirror_point(const mirror_info *mi, bbc_vec3 q) {
  return v3_madd(q, mi->n, -2.0 * v3_dot(v3_sub(q, mi->m), mi->n));
}

static double area_light_irradiance(const bbc_scene *scene, bbc_vec3 p, const mirror_info *mi) {
  const int k = 12;
  double e = 0;
  for (uint32_t i = 0; i < scene->emitter_count; i++) {
    const uint32_t *idx = scene->indices + 3 * (size_t)scene->emitters[i];
    bbc_vec3 q[3];
    for (int j = 0; j < 3; j++) {
      q[j] = v3_load(scene->positions + 3 * (size_t)idx[j]);
      if (mi) q[j] = mirror_point(mi, q[j]);
    }
    bbc_vec3 e1 = v3_sub(q[1], q[0]), e2 = v3_sub(q[2], q[0]);
    bbc_vec3 nl = v3_normalize(v3_load(scene->normals + 3 * (size_t)idx[0]));
    if (mi) nl = v3_sub(nl, v3_scale(mi->n, 2.0 * v3_dot(nl, mi->n)));
    double area = 0.5 * v3_length(v3_cross(e1, e2));
    double radiance = bbc_scene_triangle_material(scene, scene->emitters[i])->emission[0];
    /* Midpoint rule over the k^2 sub-triangles (upward and downward ones). */
    for (int a = 0; a < k; a++) {
      for (int b = 0; a + b < k; b++) {
        for (int flip = 0; flip < 2; flip++) {
          if (flip && a + b + 1 >= k) continue;
          double s = flip ? (a + 2.0 / 3.0) / k : (a + 1.0 / 3.0) / k;
          double t = flip ? (b + 2.0 / 3.0) / k : (b + 1.0 / 3.0) / k;
          bbc_vec3 x = v3_add(q[0], v3_add(v3_scale(e1, s), v3_scale(e2, t)));
          bbc_vec3 d = v3_sub(x, p);
          double r2 = v3_dot(d, d), r = sqrt(r2);
          double cos_p = d.y / r, cos_l = -v3_dot(nl, d) / r;
          if (cos_p <= 0 || cos_l <= 0) continue;
          if (mi) {
            double u = (mi->m.x - p.x) / d.x;
            bbc_vec3 c = v3_madd(p, d, u);
            if (!(u > 0 && u < 1 && c.y > mi->y0 && c.y < mi->y1 && c.z > mi->z0 && c.z < mi->z1))
              continue;
          }
          e += radiance * cos_p * cos_l / r2 * area / (k * k);
        }
      }
    }
  }
  return e;
}

/* Renders flat-mirror-area with paths of at most max_depth segments and returns the
 * z-score of the sum over floor pixels of (rendered - analytic), where analytic is the
 * direct light plus the mirrored light. The variance of the sum is estimated from the
 * squared per-pixel residuals (independent pixels, unbiased renderer). */
static double mirror_z_score(uint32_t max_depth, double *relative_std) {
  bbc_scene *scene = load(TEST_SCENE("flat-mirror-area.gltf"));
  if (!scene) return NAN;
  floor_info f;
  mirror_info mi = {v3(0, 0, 0), v3(1, 0, 0), 1e30, -1e30, 1e30, -1e30};
  int have_mirror = 0;
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    if (bbc_scene_triangle_material(scene, t)->type != BBC_MATERIAL_MIRROR) continue;
    for (int j = 0; j < 3; j++) {
      bbc_vec3 q = v3_load(scene->positions + 3 * (size_t)scene->indices[3 * t + j]);
      mi.m = q;
      mi.y0 = fmin(mi.y0, q.y);
      mi.y1 = fmax(mi.y1, q.y);
      mi.z0 = fmin(mi.z0, q.z);
      mi.z1 = fmax(mi.z1, q.z);
    }
    have_mirror = 1;
  }
  if (!have_mirror || !find_floor(scene, &f) || scene->emitter_count == 0) {
    harness_fail(__FILE__, __LINE__, "flat-mirror-area.gltf lacks mirror, floor or light");
    bbc_scene_free(scene);
    return NAN;
  }
  bbc_accel *accel = NULL;
  bbc_image *image = NULL;
  const uint32_t w = 64, h = 48;
  bbc_accel_create(&accel, scene, NULL, NULL);
  bbc_image_create(&image, w, h);
  bbc_render_options options;
  memset(&options, 0, sizeof options);
  options.spp = (uint32_t)harness_scale(1024, 8192);
  options.max_depth = max_depth;
  bbc_render(scene, accel, &options, image, NULL);

  double sum_residual = 0, sum_sq = 0, sum_analytic = 0;
  for (uint32_t y = 0; y < h; y++) {
    for (uint32_t x = 0; x < w; x++) {
      const int n = 3;
      double analytic = 0;
      int inside = 1;
      for (int j = 0; j < n && inside; j++) {
        for (int i = 0; i < n && inside; i++) {
          bbc_vec3 p;
          if (!floor_point(scene, accel, &f, w, h, x + (i + 0.5) / n, y + (j + 0.5) / n, &p)) {
            inside = 0;
            break;
          }
          double e = area_light_irradiance(scene, p, NULL) + area_light_irradiance(scene, p, &mi);
          analytic += f.albedo / PI * e / (n * n);
        }
      }
      if (!inside) continue;
      double residual = image->rgb[3 * ((size_t)y * w + x)] - analytic;
      sum_residual += residual;
      sum_sq += residual * residual;
      sum_analytic += analytic;
    }
  }
  bbc_image_free(image);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
  *relative_std = sqrt(sum_sq) / sum_analytic;
  fprintf(stderr,
          "max_depth %u: relative error of the floor's total %.5f +- %.5f (1 sigma), z = %.2f\n",
          max_depth, sum_residual / sum_analytic, *relative_std, sum_residual / sqrt(sum_sq));
  return sum_residual / sqrt(sum_sq);
}

/* With paths of at most 3 segments the floor receives exactly the direct and the
 * mirrored light (light reflected by the floor onto the mirror and back needs 4). */
TEST(flat_mirror_area_light_analytic) {
  double sigma;
  double z = mirror_z_score(3, &sigma);
  CHECK(fabs(z) < 4.5);
  /* The noise must be small enough for the test to see an error of a fifth of the
   * mirrored light (which is about 13 % of the total) at 4.5 sigma. */
  CHECK(sigma < 0.005);
}

/* The same comparison must fail when the mirrored light is missing (2 segments): the
 * test above can tell a renderer without mirror paths from a correct one. */
TEST(flat_mirror_test_detects_missing_mirror_light) {
  double sigma;
  double z = mirror_z_score(2, &sigma);
  CHECK(z < -10);
}

static bbc_image *render_with_threads(const char *path, int threads, uint64_t seed) {
  bbc_scene *scene = load(path);
  if (!scene) return NULL;
  bbc_accel *accel = NULL;
  bbc_image *image = NULL;
  bbc_accel_create(&accel, scene, NULL, NULL);
  bbc_image_create(&image, 40, 30);
  bbc_render_options options;
  memset(&options, 0, sizeof options);
  options.spp = 6;
  options.threads = threads;
  options.seed = seed;
  bbc_render(scene, accel, &options, image, NULL);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
  return image;
}

TEST(deterministic_across_thread_counts) {
  const char *scenes[] = {TEST_SCENE("glass-sphere.gltf"), TEST_SCENE("wavy-mirror.gltf")};
  for (int s = 0; s < 2; s++) {
    bbc_image *a = render_with_threads(scenes[s], 1, 7);
    bbc_image *b = render_with_threads(scenes[s], 2, 7);
    bbc_image *c = render_with_threads(scenes[s], 3, 7);
    bbc_image *d = render_with_threads(scenes[s], 2, 8);
    REQUIRE(a && b && c && d);
    size_t bytes = (size_t)a->width * a->height * 3 * sizeof(float);
    CHECK(memcmp(a->rgb, b->rgb, bytes) == 0);
    CHECK(memcmp(a->rgb, c->rgb, bytes) == 0);
    /* Another seed gives another image: the comparison above is not vacuous. */
    CHECK(memcmp(a->rgb, d->rgb, bytes) != 0);
    bbc_image_free(a);
    bbc_image_free(b);
    bbc_image_free(c);
    bbc_image_free(d);
  }
}

TEST(time_budget_stops) {
  bbc_scene *scene = load(TEST_SCENE("glass-sphere.gltf"));
  REQUIRE(scene);
  bbc_accel *accel = NULL;
  bbc_image *image = NULL;
  REQUIRE(bbc_accel_create(&accel, scene, NULL, NULL) == BBC_OK);
  REQUIRE(bbc_image_create(&image, 32, 24) == BBC_OK);
  bbc_render_options options;
  memset(&options, 0, sizeof options);
  options.time_limit = 0.3;
  bbc_render_stats stats;
  CHECK(bbc_render(scene, accel, &options, image, &stats) == BBC_OK);
  CHECK(stats.spp >= 1);
  CHECK(stats.seconds < 1.5);
  CHECK(stats.rays >= stats.samples);
  bbc_image_free(image);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
}
