/* The exact images of bbc-scenegen's flat-mirror scene (a mirror wall in the plane x = 0
 * standing on a floor y = 0, a point light in front of it, the camera looking straight
 * down), for the comparison benchmark (bench/compare.sh).
 *
 *   flat_mirror_exact SCENE.gltf --width W --height H --caustic -o OUT.exr
 *       the caustic as bbc-render --only caustics shows it: the floor lit by the mirror
 *       image of the light, albedo/pi R I cos(theta)/r^2, seen directly and in the
 *       mirror, box-filtered over each pixel (bbc's camera jitters each sample uniformly
 *       over its pixel);
 *   flat_mirror_exact SCENE.gltf --width W --height H --caustic --seen-directly -o OUT.exr
 *       the same without the floor seen in the mirror: what bbc-render --only caustics
 *       --max-depth 3 shows, and bench/light_trace's calibration target;
 *   flat_mirror_exact SCENE.gltf --width W --height H --direct -o OUT.exr
 *       the floor lit by the light alone (no mirror), albedo/pi I cos(theta)/r^2, at the
 *       pixel centres: the calibration target of a renderer's translation of the scene.
 *
 * With the camera looking straight down, film coordinates map affinely to the floor
 * plane, so a pixel's footprint is a rectangle there and the box filter is the mean over
 * it. The image is smooth except across the floor's edges and the mirror's foot (the
 * crease x = 0 between the floor and its reflection), so the rectangle is cut along them
 * and each piece integrated by Gauss-Legendre quadrature; the program checks the result
 * against twice the nodes and fails unless they agree to 1e-12. The scene's geometry
 * (mirror plane, floor rectangle, camera) is checked, not assumed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"

#define PI 3.14159265358979323846

static int fail(const char *msg) {
  fprintf(stderr, "flat_mirror_exact: %s\n", msg);
  return 1;
}

/* Gauss-Legendre nodes and weights on [-1, 1] by Newton's method on P_n. */
static void gauss_legendre(int n, double *x, double *w) {
  for (int i = 0; i < n; i++) {
    double z = cos(PI * (i + 0.75) / (n + 0.5)), dp = 0;
    for (int it = 0; it < 100; it++) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; k++) {
        double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1);
      double dz = p1 / dp;
      z -= dz;
      if (fabs(dz) < 1e-16) break;
    }
    x[i] = z;
    w[i] = 2 / ((1 - z * z) * dp * dp);
  }
}

typedef struct geometry {
  double light[3];        /* the point light */
  double scale[3];        /* albedo / pi * I (* R for the caustic), per channel */
  double floor_x1;        /* floor: x in [0, floor_x1], z in [z0, z1] */
  double z0, z1;
  double mirror_x_min;    /* the image x below which a ray passes over the mirror's top */
  int caustic;            /* 1: the mirrored light, seen directly and in the mirror */
  int seen_directly;      /* caustic only: not in the mirror */
} geometry;

/* The value, per unit of scale, at the point where a camera ray meets the floor plane at
 * (x, z); 0 off the floor. */
static double value(const geometry *g, double x, double z) {
  if (z < g->z0 || z > g->z1 || x > g->floor_x1) return 0;
  double lx = g->light[0], ly = g->light[1], lz = g->light[2];
  if (g->caustic) {
    if (x < g->mirror_x_min || (g->seen_directly && x < 0)) return 0;
    x = fabs(x); /* in the mirror: the reflected floor point (-x, z) */
    lx = -lx;    /* the mirror image of the light */
  } else if (x < 0) {
    return 0;
  }
  double dx = lx - x, dz = lz - z, r2 = dx * dx + ly * ly + dz * dz;
  return ly / (r2 * sqrt(r2));
}

/* The mean of value over [xa, xb] x [za, zb], cut at the breakpoints. */
static double rect_mean(const geometry *g, double xa, double xb, double za, double zb, int n,
                        const double *gx, const double *gw) {
  double xs[8], zs[8];
  int nx = 0, nz = 0;
  xs[nx++] = xa;
  const double xcuts[3] = {g->mirror_x_min, 0, g->floor_x1};
  for (int i = 0; i < 3; i++)
    if (xcuts[i] > xa && xcuts[i] < xb) xs[nx++] = xcuts[i];
  xs[nx++] = xb;
  zs[nz++] = za;
  if (g->z0 > za && g->z0 < zb) zs[nz++] = g->z0;
  if (g->z1 > za && g->z1 < zb) zs[nz++] = g->z1;
  zs[nz++] = zb;
  double sum = 0;
  for (int i = 0; i + 1 < nx; i++) {
    for (int j = 0; j + 1 < nz; j++) {
      double cx = 0.5 * (xs[i] + xs[i + 1]), hx = 0.5 * (xs[i + 1] - xs[i]);
      double cz = 0.5 * (zs[j] + zs[j + 1]), hz = 0.5 * (zs[j + 1] - zs[j]);
      double s = 0;
      for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) s += gw[a] * gw[b] * value(g, cx + hx * gx[a], cz + hz * gx[b]);
      sum += s * hx * hz;
    }
  }
  return sum / ((xb - xa) * (zb - za));
}

/* Where the camera ray through film position (px, py) meets the plane y = 0. */
static void floor_point(const bbc_camera *c, uint32_t w, uint32_t h, double px, double py,
                        double *x, double *z) {
  bbc_vec3 o, d;
  bbc_camera_ray(c, w, h, px, py, &o, &d);
  double t = -o.y / d.y;
  *x = o.x + t * d.x;
  *z = o.z + t * d.z;
}

int main(int argc, char **argv) {
  const char *scene_path = NULL, *out = NULL;
  long width = 0, height = 0;
  int caustic = -1, seen_directly = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--width") && i + 1 < argc) width = atol(argv[++i]);
    else if (!strcmp(argv[i], "--height") && i + 1 < argc) height = atol(argv[++i]);
    else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
    else if (!strcmp(argv[i], "--caustic")) caustic = 1;
    else if (!strcmp(argv[i], "--direct")) caustic = 0;
    else if (!strcmp(argv[i], "--seen-directly")) seen_directly = 1;
    else if (argv[i][0] != '-' && !scene_path) scene_path = argv[i];
    else return fail("usage: flat_mirror_exact SCENE.gltf --width W --height H "
                     "--caustic [--seen-directly]|--direct -o OUT.exr");
  }
  if (!scene_path || !out || width <= 0 || height <= 0 || caustic < 0 || width > 100000 ||
      height > 100000)
    return fail("usage: flat_mirror_exact SCENE.gltf --width W --height H "
                "--caustic [--seen-directly]|--direct -o OUT.exr");
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, scene_path, NULL) != BBC_OK) return fail("cannot load the scene");

  /* Check the scene is the flat-mirror kind: one point light in front of a mirror in
   * the plane x = 0, a floor rectangle at y = 0 from the mirror's foot, nothing else. */
  geometry g;
  memset(&g, 0, sizeof g);
  g.caustic = caustic;
  g.seen_directly = caustic && seen_directly;
  if (scene->point_light_count != 1 || scene->emitter_count != 0)
    return fail("the scene must have exactly one point light");
  const bbc_point_light *light = &scene->point_lights[0];
  g.light[0] = light->position.x, g.light[1] = light->position.y, g.light[2] = light->position.z;
  double my0 = 1e300, my1 = -1e300, mz0 = 1e300, mz1 = -1e300, fx0 = 1e300;
  g.floor_x1 = -1e300, g.z0 = 1e300, g.z1 = -1e300;
  float albedo[3] = {0, 0, 0}, reflectance[3] = {0, 0, 0};
  int mirrors = 0, floors = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    const bbc_material *mat = &scene->materials[mesh->material];
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = scene->positions + 3 * (size_t)v;
      const float *nrm = scene->normals + 3 * (size_t)v;
      if (mat->type == BBC_MATERIAL_MIRROR) {
        if (p[0] != 0 || nrm[0] != 1) return fail("the mirror must be the plane x = 0 facing +x");
        my0 = fmin(my0, p[1]), my1 = fmax(my1, p[1]);
        mz0 = fmin(mz0, p[2]), mz1 = fmax(mz1, p[2]);
      } else if (mat->type == BBC_MATERIAL_DIFFUSE) {
        if (p[1] != 0 || nrm[1] != 1) return fail("the floor must be the plane y = 0 facing up");
        fx0 = fmin(fx0, p[0]), g.floor_x1 = fmax(g.floor_x1, p[0]);
        g.z0 = fmin(g.z0, p[2]), g.z1 = fmax(g.z1, p[2]);
      } else {
        return fail("only a mirror and a diffuse floor are allowed");
      }
    }
    if (mat->type == BBC_MATERIAL_MIRROR) {
      if (mirrors++ && memcmp(reflectance, mat->base_color, sizeof reflectance))
        return fail("one mirror material");
      memcpy(reflectance, mat->base_color, sizeof reflectance);
    } else {
      if (floors++ && memcmp(albedo, mat->base_color, sizeof albedo))
        return fail("one floor material");
      memcpy(albedo, mat->base_color, sizeof albedo);
    }
  }
  if (!mirrors || !floors) return fail("the scene needs a mirror and a floor");
  /* The floor is one rectangle (its triangles' area is that of its bounding box). */
  double floor_area = 0;
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    if (bbc_scene_triangle_material(scene, t)->type != BBC_MATERIAL_DIFFUSE) continue;
    const float *a = scene->positions + 3 * (size_t)scene->indices[3 * t];
    const float *b = scene->positions + 3 * (size_t)scene->indices[3 * t + 1];
    const float *c = scene->positions + 3 * (size_t)scene->indices[3 * t + 2];
    floor_area += 0.5 * fabs((b[0] - a[0]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[0] - a[0]));
  }
  if (fx0 != 0 || fabs(floor_area - g.floor_x1 * (g.z1 - g.z0)) > 1e-9 * floor_area)
    return fail("the floor must be a rectangle x in [0, X], z in [Z0, Z1]");
  const bbc_camera *cam = &scene->camera;
  bbc_vec3 o = cam->position;
  if (fabs(cam->w.y - 1) > 1e-12 || fabs(cam->u.y) > 1e-12 || fabs(cam->v.y) > 1e-12)
    return fail("the camera must look straight down");
  if (!(fabs(cam->u.x) > 1 - 1e-12 || fabs(cam->u.z) > 1 - 1e-12))
    return fail("the camera's film axes must be the floor's axes");
  /* The light in front of the mirror, below its top, within its width; the camera in
   * front of it, above its top, within the floor's width: then every floor point sees
   * the light's mirror image through the mirror, and a camera ray meeting the plane
   * x = 0 between the floor and the mirror's top does so within the mirror's width. */
  if (!(g.light[0] > 0 && g.light[1] > 0 && g.light[1] <= my1 && my0 == 0 &&
        g.light[2] >= mz0 && g.light[2] <= mz1 && g.z0 >= mz0 && g.z1 <= mz1 && o.x > 0 &&
        o.y > my1 && o.z >= g.z0 && o.z <= g.z1))
    return fail("unexpected layout of light, mirror, floor and camera");
  /* A ray towards floor-plane point (x < 0, z) crosses x = 0 at height o.y (-x)/(o.x - x),
   * at most the mirror's top when x >= -o.x top / (o.y - top). */
  g.mirror_x_min = -o.x * my1 / (o.y - my1);
  for (int c = 0; c < 3; c++)
    g.scale[c] = albedo[c] / PI * light->intensity[c] * (caustic ? reflectance[c] : 1.0f);

  const uint32_t w = (uint32_t)width, h = (uint32_t)height;
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return fail("out of memory");
  double gx8[8], gw8[8], gx16[16], gw16[16];
  gauss_legendre(8, gx8, gw8);
  gauss_legendre(16, gx16, gw16);
  double worst = 0;
  for (uint32_t y = 0; y < h; y++) {
    for (uint32_t x = 0; x < w; x++) {
      double v;
      if (caustic) {
        double xa, za, xb, zb;
        floor_point(cam, w, h, x, y, &xa, &za);
        floor_point(cam, w, h, x + 1.0, y + 1.0, &xb, &zb);
        if (xa > xb) { double t = xa; xa = xb; xb = t; }
        if (za > zb) { double t = za; za = zb; zb = t; }
        v = rect_mean(&g, xa, xb, za, zb, 8, gx8, gw8);
        double v16 = rect_mean(&g, xa, xb, za, zb, 16, gx16, gw16);
        if (v16 > 0) worst = fmax(worst, fabs(v - v16) / v16);
        v = v16;
      } else {
        double xc, zc;
        floor_point(cam, w, h, x + 0.5, y + 0.5, &xc, &zc);
        v = value(&g, xc, zc);
      }
      for (int c = 0; c < 3; c++) image->rgb[3 * ((size_t)y * w + x) + c] = (float)(v * g.scale[c]);
    }
  }
  if (worst > 1e-12) return fail("the quadrature has not converged");
  if (bbc_image_write_exr(image, out, NULL, NULL) != BBC_OK) return fail("cannot write the image");
  fprintf(stderr, "flat_mirror_exact: %s, %ux%u, quadrature 8 vs 16 nodes: %.2g relative\n",
          caustic ? "caustic (box filter)" : "direct (pixel centres)", w, h, worst);
  bbc_image_free(image);
  bbc_scene_free(scene);
  return 0;
}
