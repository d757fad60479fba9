/* The exact caustic image of bbc-scenegen's flat-mirror scene, for relMSE figures that a
 * reference render cannot floor.
 *
 *   bench_flat_mirror_reference SCENE.gltf OUT.exr WIDTH HEIGHT [N]
 *
 * The scene: a mirror wall in the plane x = 0 facing +x (a rectangle, reflectance 1), a
 * rectangular diffuse floor at y = 0, one point light at x > 0. A floor point p with
 * x > 0 receives the light of the mirrored source L' = (-Lx, Ly, Lz) when the segment
 * L' -> p crosses the wall's rectangle: radiance albedo / pi * I * cos(theta) / r^2.
 * Camera rays (bbc_camera_ray, as bbc-render's) are traced analytically against the two
 * rectangles, reflecting off the mirror. Each pixel is the mean over N x N stratum
 * centres of its area (default 128): the midpoint rule, whose error on a pixel crossed
 * by a caustic edge is O(N^-1.5) of the jump. The image is bbc-render --only caustics's
 * expectation (box filter, mean over the pixel). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bbc/bbc.h"

#define PI 3.14159265358979323846

typedef struct flat_scene {
  double wall_y[2], wall_z[2];           /* the mirror rectangle at x = 0 */
  double floor_x[2], floor_z[2];         /* the floor rectangle at y = 0 */
  bbc_vec3 image;                        /* the mirrored light */
  double scale;                          /* albedo / pi * I */
} flat_scene;

static int describe(const bbc_scene *s, flat_scene *f) {
  double box[2][3][2];
  int seen[2] = {0, 0};
  f->scale = 0;
  for (uint32_t m = 0; m < s->mesh_count; m++) {
    const bbc_mesh *mesh = &s->meshes[m];
    const bbc_material *mat = &s->materials[mesh->material];
    int k = mat->type == BBC_MATERIAL_MIRROR ? 0 : mat->type == BBC_MATERIAL_DIFFUSE ? 1 : -1;
    if (k < 0) return 0;
    if (k == 1) f->scale = mat->base_color[0] / PI;
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = s->positions + 3 * (size_t)v;
      for (int a = 0; a < 3; a++) {
        if (!seen[k] || p[a] < box[k][a][0]) box[k][a][0] = p[a];
        if (!seen[k] || p[a] > box[k][a][1]) box[k][a][1] = p[a];
      }
      seen[k] = 1;
    }
  }
  if (!seen[0] || !seen[1] || s->point_light_count != 1 || box[0][0][0] != 0 ||
      box[0][0][1] != 0 || box[1][1][0] != 0 || box[1][1][1] != 0)
    return 0;
  const bbc_point_light *l = &s->point_lights[0];
  if (!(l->position.x > 0)) return 0;
  f->wall_y[0] = box[0][1][0], f->wall_y[1] = box[0][1][1];
  f->wall_z[0] = box[0][2][0], f->wall_z[1] = box[0][2][1];
  f->floor_x[0] = box[1][0][0], f->floor_x[1] = box[1][0][1];
  f->floor_z[0] = box[1][2][0], f->floor_z[1] = box[1][2][1];
  f->image = (bbc_vec3){-l->position.x, l->position.y, l->position.z};
  f->scale *= l->intensity[0];
  return 1;
}

/* The caustic radiance at floor point p. */
static double floor_value(const flat_scene *f, bbc_vec3 p) {
  if (!(p.x > 0)) return 0;
  bbc_vec3 d = {f->image.x - p.x, f->image.y - p.y, f->image.z - p.z};
  double t = -p.x / d.x; /* where p + t d crosses x = 0 */
  double y = p.y + t * d.y, z = p.z + t * d.z;
  if (!(y > f->wall_y[0] && y < f->wall_y[1] && z > f->wall_z[0] && z < f->wall_z[1])) return 0;
  double r2 = d.x * d.x + d.y * d.y + d.z * d.z;
  return f->scale * (d.y / sqrt(r2)) / r2;
}

/* The radiance along a camera ray: at most a few mirror bounces, then the floor. */
static double trace(const flat_scene *f, bbc_vec3 o, bbc_vec3 d) {
  for (int bounce = 0; bounce < 4; bounce++) {
    double tw = d.x != 0 ? -o.x / d.x : -1, tf = d.y != 0 ? -o.y / d.y : -1;
    int wall = 0, floor = 0;
    if (tw > 1e-9) {
      double y = o.y + tw * d.y, z = o.z + tw * d.z;
      wall = y > f->wall_y[0] && y < f->wall_y[1] && z > f->wall_z[0] && z < f->wall_z[1];
    }
    if (tf > 1e-9) {
      double x = o.x + tf * d.x, z = o.z + tf * d.z;
      floor = x > f->floor_x[0] && x < f->floor_x[1] && z > f->floor_z[0] && z < f->floor_z[1];
    }
    if (wall && (!floor || tw < tf)) {
      o = (bbc_vec3){0, o.y + tw * d.y, o.z + tw * d.z};
      d.x = -d.x;
      continue;
    }
    if (!floor) return 0;
    return floor_value(f, (bbc_vec3){o.x + tf * d.x, 0, o.z + tf * d.z});
  }
  return 0;
}

int main(int argc, char **argv) {
  if (argc < 5 || argc > 6) {
    fprintf(stderr, "usage: %s SCENE.gltf OUT.exr WIDTH HEIGHT [N]\n", argv[0]);
    return 2;
  }
  uint32_t w = (uint32_t)atoi(argv[3]), h = (uint32_t)atoi(argv[4]);
  int n = argc == 6 ? atoi(argv[5]) : 128;
  if (w == 0 || h == 0 || n <= 0) {
    fprintf(stderr, "%s: bad size\n", argv[0]);
    return 2;
  }
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, argv[1], NULL) != BBC_OK) {
    fprintf(stderr, "%s: cannot load %s\n", argv[0], argv[1]);
    return 1;
  }
  flat_scene f;
  if (!describe(scene, &f)) {
    fprintf(stderr, "%s: %s is not a flat-mirror scene\n", argv[0], argv[1]);
    bbc_scene_free(scene);
    return 1;
  }
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return 1;
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++) {
      double sum = 0;
      for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
          bbc_vec3 o, d;
          bbc_camera_ray(&scene->camera, w, h, x + (i + 0.5) / n, y + (j + 0.5) / n, &o, &d);
          sum += trace(&f, o, d);
        }
      float v = (float)(sum / ((double)n * n));
      float *px = image->rgb + 3 * ((size_t)y * w + x);
      px[0] = px[1] = px[2] = v;
    }
  bbc_result r = bbc_image_write_exr(image, argv[2], NULL, NULL);
  bbc_image_free(image);
  bbc_scene_free(scene);
  if (r != BBC_OK) {
    fprintf(stderr, "%s: cannot write %s\n", argv[0], argv[2]);
    return 1;
  }
  return 0;
}
