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
 * The scene may have, instead of its point light, an area light (bbc-scenegen flat-mirror
 * --area-light SIDE: emissive triangles of radiance L making a horizontal rectangle that
 * faces down, within the mirror's extent); then only --caustic --seen-directly is made:
 * albedo/pi R L times the integral over the mirrored emitter of cos(theta) cos(theta_e)/r^2
 * dA, every floor point seeing all of it through the mirror, and zero where the emitter
 * hides the floor from the camera (the emitter's shadow from the camera, a rectangle of
 * the floor plane: the pixel is cut along its edges too). The emitter integral is
 * Gauss-Legendre on each triangle's map from the unit square, 6 nodes per axis with the
 * pixel's 8 and 10 with its 16.
 *
 * The scene may also have a sun instead (bbc-scenegen flat-mirror --sun E [--sun-angle
 * DEG]), for --caustic --seen-directly only: with w a direction toward the sun, the floor
 * point p (x >= 0) sees the sun through the mirror where the ray from p toward the mirror
 * image of w meets the mirror rectangle, a convex polygon R(w) of the floor plane (half-
 * planes: x <= top w.x / w.y and z + x w.z / w.x within the mirror's width). A pixel's mean
 * is then albedo/pi R times the integral over the sun's cone of L w.y |pixel & R(w)| /
 * |pixel| dw (L = E / (pi sin^2 h), h half the angular diameter), or for a delta sun
 * E w.y |pixel & R(w)| / |pixel| with w = -D. The area of the pixel's footprint within R(w)
 * is exact (the rectangle clipped by the half-planes); the cone is integrated by
 * Gauss-Legendre in 1 - cos(theta) and the midpoint rule in the azimuth, which converge
 * only algebraically here (the clipped area has kinks in w): the program compares 16 x 64
 * nodes with 32 x 128 and fails unless they agree to 1e-3 of the image's largest value
 * (the light tracer's calibration needs far less: its lit-mean ratio to 0.5 %).
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
  /* Area light: its triangles (already mirrored to x < 0), their number (0 for a point
   * light), the floor rectangle the emitter hides from the camera, and the emitter
   * quadrature's Gauss-Legendre rule on [-1, 1]. */
  double emitter[8][3][3];
  int emitters;
  double hide_x0, hide_x1, hide_z0, hide_z1;
  int en;
  const double *ex, *ew;
} geometry;

/* The integral over the mirrored emitter of cos(theta) cos(theta_e) / r^2 dA at floor
 * point (x, 0, z): the emitter faces down, so both cosines are (its height) / r. */
static double area_value(const geometry *g, double x, double z) {
  double sum = 0;
  for (int t = 0; t < g->emitters; t++) {
    const double(*q)[3] = g->emitter[t];
    double e1[3], f[3];
    for (int k = 0; k < 3; k++) e1[k] = q[1][k] - q[0][k], f[k] = q[2][k] - q[1][k];
    /* |d(point)/d(a, b)| = a |e1 x f| = a 2 area. */
    double c[3] = {e1[1] * f[2] - e1[2] * f[1], e1[2] * f[0] - e1[0] * f[2],
                   e1[0] * f[1] - e1[1] * f[0]};
    double twice_area = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    for (int i = 0; i < g->en; i++) {
      double a = 0.5 * (1 + g->ex[i]);
      for (int j = 0; j < g->en; j++) {
        double b = 0.5 * (1 + g->ex[j]);
        double dx = q[0][0] + a * e1[0] + a * b * f[0] - x;
        double dy = q[0][1] + a * e1[1] + a * b * f[1];
        double dz = q[0][2] + a * e1[2] + a * b * f[2] - z;
        double r2 = dx * dx + dy * dy + dz * dz;
        sum += 0.25 * g->ew[i] * g->ew[j] * a * twice_area * dy * dy / (r2 * r2);
      }
    }
  }
  return sum;
}

/* The value, per unit of scale, at the point where a camera ray meets the floor plane at
 * (x, z); 0 off the floor. */
static double value(const geometry *g, double x, double z) {
  if (z < g->z0 || z > g->z1 || x > g->floor_x1) return 0;
  if (g->emitters) {
    if (x < 0 || (x > g->hide_x0 && x < g->hide_x1 && z > g->hide_z0 && z < g->hide_z1)) return 0;
    return area_value(g, x, z);
  }
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
  /* Increasing: the mirror's top's image < 0 < the emitter's shadow < the floor's edge. */
  const double xcuts[5] = {g->mirror_x_min, 0, g->hide_x0, g->hide_x1, g->floor_x1};
  for (int i = 0; i < 5; i++)
    if (xcuts[i] > xa && xcuts[i] < xb && (i < 2 || i == 4 || g->emitters)) xs[nx++] = xcuts[i];
  xs[nx++] = xb;
  const double zcuts[4] = {g->z0, g->hide_z0, g->hide_z1, g->z1};
  zs[nz++] = za;
  for (int i = 0; i < 4; i++)
    if (zcuts[i] > za && zcuts[i] < zb && (i == 0 || i == 3 || g->emitters)) zs[nz++] = zcuts[i];
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

/* The area of the rectangle [xa, xb] x [za, zb] of the (x, z) plane within the half-planes
 * a x + b z <= c of cut[0..n) (a convex polygon clipped edge by edge, Sutherland-Hodgman). */
static double clipped_area(double xa, double xb, double za, double zb, const double (*cut)[3],
                           int n) {
  double px[16], pz[16], qx[16], qz[16];
  int m = 4;
  px[0] = xa, pz[0] = za, px[1] = xb, pz[1] = za, px[2] = xb, pz[2] = zb, px[3] = xa, pz[3] = zb;
  for (int k = 0; k < n && m > 0; k++) {
    int q = 0;
    for (int i = 0; i < m; i++) {
      int j = (i + 1) % m;
      double si = cut[k][0] * px[i] + cut[k][1] * pz[i] - cut[k][2];
      double sj = cut[k][0] * px[j] + cut[k][1] * pz[j] - cut[k][2];
      if (si <= 0) qx[q] = px[i], qz[q] = pz[i], q++;
      if ((si < 0 && sj > 0) || (si > 0 && sj < 0)) {
        double t = si / (si - sj);
        qx[q] = px[i] + t * (px[j] - px[i]), qz[q] = pz[i] + t * (pz[j] - pz[i]), q++;
      }
    }
    m = q;
    memcpy(px, qx, sizeof(double) * (size_t)m);
    memcpy(pz, qz, sizeof(double) * (size_t)m);
  }
  double a = 0;
  for (int i = 0; i < m; i++) a += px[i] * pz[(i + 1) % m] - px[(i + 1) % m] * pz[i];
  return 0.5 * fabs(a);
}

/* A sun over the flat mirror (see the top): the floor x in [0, x1], z in [z0, z1], the
 * mirror's top and width, the sun's axis toward it, half-angle and irradiance. */
typedef struct sun_geometry {
  double x1, z0, z1, top, mz0, mz1;
  double axis[3], half, e;
} sun_geometry;

/* The mean over the footprint [xa, xb] x [za, zb] of the irradiance through the mirror,
 * with n Gauss-Legendre nodes (gx, gw) in 1 - cos(theta) and m azimuths. */
static double sun_pixel(const sun_geometry *s, double xa, double xb, double za, double zb, int n,
                        const double *gx, const double *gw, int m) {
  const double pixel = (xb - xa) * (zb - za);
  double sum = 0;
  /* Directions: the axis a and two unit vectors across it. */
  const double *a = s->axis;
  double b1[3] = {-a[1], a[0], 0};
  double l1 = sqrt(b1[0] * b1[0] + b1[1] * b1[1]);
  if (l1 < 1e-9) b1[0] = 1, b1[1] = 0, l1 = 1;
  for (int k = 0; k < 3; k++) b1[k] /= l1;
  double b2[3] = {a[1] * b1[2] - a[2] * b1[1], a[2] * b1[0] - a[0] * b1[2],
                  a[0] * b1[1] - a[1] * b1[0]};
  const int delta = !(s->half > 0);
  const double one_minus_cos = delta ? 0 : 2 * sin(0.5 * s->half) * sin(0.5 * s->half);
  const double radiance = delta ? 0 : s->e / (PI * sin(s->half) * sin(s->half));
  for (int i = 0; i < (delta ? 1 : n); i++) {
    double u = delta ? 0 : 0.5 * (1 + gx[i]) * one_minus_cos;
    double cz = 1 - u, sz = sqrt(fmax(0, u * (2 - u)));
    for (int j = 0; j < (delta ? 1 : m); j++) {
      double phi = 2 * PI * (j + 0.5) / m;
      double w[3];
      for (int k = 0; k < 3; k++) w[k] = a[k] * cz + sz * (cos(phi) * b1[k] + sin(phi) * b2[k]);
      if (!(w[0] > 0 && w[1] > 0)) continue;
      /* R(w) within the floor, seen directly (x >= 0). */
      const double cut[7][3] = {{-1, 0, 0},
                                {1, 0, s->x1},
                                {0, -1, -s->z0},
                                {0, 1, s->z1},
                                {1, 0, s->top * w[0] / w[1]},
                                {-w[2] / w[0], -1, -s->mz0},
                                {w[2] / w[0], 1, s->mz1}};
      double f = clipped_area(xa, xb, za, zb, cut, 7) / pixel;
      /* Weight: E for the delta sun; else L d omega, d omega = d(1 - cos) d phi. */
      double weight = delta ? s->e : radiance * 0.5 * gw[i] * one_minus_cos * 2 * PI / m;
      sum += weight * w[1] * f;
    }
  }
  return sum;
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
  const int area = scene->emitter_count > 0;
  const int sun = !area && scene->point_light_count == 1 &&
                  scene->point_lights[0].model.kind == BBC_LIGHT_DIRECTIONAL;
  if (sun && !(caustic && seen_directly))
    return fail("a sun's image is made with --caustic --seen-directly only");
  if (area ? scene->point_light_count != 0 || scene->emitter_count > 8
           : scene->point_light_count != 1)
    return fail(
        "the scene must have exactly one point light or sun, or an area light of at most 8 "
        "triangles and no other light");
  if (area && !(caustic && seen_directly))
    return fail("an area light's image is made with --caustic --seen-directly only");
  /* Area: the emitter's rectangle (y = height, facing down) and radiance. */
  double ex0 = 1e300, ex1 = -1e300, ez0 = 1e300, ez1 = -1e300, ey = 0, emitter_area = 0;
  float radiance[3] = {0, 0, 0};
  for (uint32_t e = 0; e < scene->emitter_count; e++) {
    bbc_light_model model;
    float le[3];
    bbc_scene_area_light(scene, e, &model, le);
    if (e > 0 && memcmp(le, radiance, sizeof le)) return fail("one emitter radiance");
    memcpy(radiance, le, sizeof le);
    const bbc_vec3 n = model.emitter_normal;
    if (!(n.y < 0 && n.x == 0 && n.z == 0)) return fail("the area light must face straight down");
    if (e == 0) ey = model.emitter[0].y;
    for (int k = 0; k < 3; k++) {
      const bbc_vec3 q = model.emitter[k];
      if (q.y != ey) return fail("the area light must be horizontal");
      ex0 = fmin(ex0, q.x), ex1 = fmax(ex1, q.x), ez0 = fmin(ez0, q.z), ez1 = fmax(ez1, q.z);
      /* Mirrored across x = 0. */
      g.emitter[e][k][0] = -q.x, g.emitter[e][k][1] = q.y, g.emitter[e][k][2] = q.z;
    }
    emitter_area += -0.5 * n.y;
  }
  g.emitters = (int)scene->emitter_count;
  if (area && fabs(emitter_area - (ex1 - ex0) * (ez1 - ez0)) > 1e-9 * emitter_area)
    return fail("the area light must be a rectangle x in [X0, X1], z in [Z0, Z1]");
  const bbc_point_light *light = area ? NULL : &scene->point_lights[0];
  if (area) /* the layout test below takes the emitter's corners' extremes */
    g.light[0] = ex0, g.light[1] = ey, g.light[2] = ez0;
  else
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
      if (mesh->role == BBC_ROLE_NONE &&
          (mat->emission[0] > 0 || mat->emission[1] > 0 || mat->emission[2] > 0))
        break; /* the area light, checked above */
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
    if (mesh->role == BBC_ROLE_NONE &&
        (mat->emission[0] > 0 || mat->emission[1] > 0 || mat->emission[2] > 0))
      continue;
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
    const bbc_material *tm = bbc_scene_triangle_material(scene, t);
    if (tm->type != BBC_MATERIAL_DIFFUSE || tm->emission[0] > 0 || tm->emission[1] > 0 ||
        tm->emission[2] > 0)
      continue;
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
  if (!((sun || (g.light[0] > 0 && g.light[1] > 0 && g.light[1] <= my1 && g.light[2] >= mz0 &&
                 g.light[2] <= mz1)) &&
        my0 == 0 && g.z0 >= mz0 && g.z1 <= mz1 && o.x > 0 && o.y > my1 && o.z >= g.z0 &&
        o.z <= g.z1))
    return fail("unexpected layout of light, mirror, floor and camera");
  if (sun) {
    /* The sun must shine on the mirror's front from above, and the camera see the floor
     * unhidden by the mirror (it stands at x = 0, the floor at x >= 0). */
    const bbc_point_light *l = &scene->point_lights[0];
    sun_geometry sg = {g.floor_x1,
                       g.z0,
                       g.z1,
                       my1,
                       mz0,
                       mz1,
                       {-l->model.direction.x, -l->model.direction.y, -l->model.direction.z},
                       0.5 * l->model.angular_diameter,
                       1.0};
    double half = sg.half;
    if (!(sg.axis[0] * cos(half) - sin(half) > 0 && sg.axis[1] * cos(half) - sin(half) > 0))
      return fail("the sun's whole disk must be in front of the mirror and above the floor");
    for (int c = 0; c < 3; c++) g.scale[c] = albedo[c] / PI * l->intensity[c] * reflectance[c];
    const uint32_t sw = (uint32_t)width, sh = (uint32_t)height;
    bbc_image *image = NULL;
    if (bbc_image_create(&image, sw, sh) != BBC_OK) return fail("out of memory");
    double gx16[16], gw16[16], gx32[32], gw32[32], largest = 0, worst = 0;
    gauss_legendre(16, gx16, gw16);
    gauss_legendre(32, gx32, gw32);
    for (uint32_t y = 0; y < sh; y++) {
      for (uint32_t x = 0; x < sw; x++) {
        double xa, za, xb, zb;
        floor_point(cam, sw, sh, x, y, &xa, &za);
        floor_point(cam, sw, sh, x + 1.0, y + 1.0, &xb, &zb);
        if (xa > xb) {
          double t = xa;
          xa = xb;
          xb = t;
        }
        if (za > zb) {
          double t = za;
          za = zb;
          zb = t;
        }
        double v = sun_pixel(&sg, xa, xb, za, zb, 16, gx16, gw16, 64);
        double v2 = sg.half > 0 ? sun_pixel(&sg, xa, xb, za, zb, 32, gx32, gw32, 128) : v;
        worst = fmax(worst, fabs(v - v2));
        largest = fmax(largest, v2);
        for (int c = 0; c < 3; c++)
          image->rgb[3 * ((size_t)y * sw + x) + c] = (float)(v2 * g.scale[c]);
      }
    }
    if (!(largest > 0)) return fail("the sun's caustic misses the floor");
    if (worst > 1e-3 * largest) {
      fprintf(stderr,
              "flat_mirror_exact: the cone quadrature differs by %.2g of the largest value\n",
              worst / largest);
      return fail("the quadrature over the sun's cone has not converged");
    }
    if (bbc_image_write_exr(image, out, NULL, NULL) != BBC_OK)
      return fail("cannot write the image");
    fprintf(stderr,
            "flat_mirror_exact: sun's caustic (box filter), angular diameter %g deg, %ux%u, "
            "cone quadrature 16x64 vs 32x128 nodes: %.2g of the largest value\n",
            l->model.angular_diameter * 180 / PI, sw, sh, worst / largest);
    bbc_image_free(image);
    bbc_scene_free(scene);
    return 0;
  }
  if (area) {
    /* Every corner of the emitter within the mirror's extent (then all of it is seen
     * through the mirror from every floor point), below the camera; the floor it hides
     * from the camera is its projection from the camera onto y = 0. */
    if (!(ex0 > 0 && ez0 >= mz0 && ez1 <= mz1 && ey < o.y))
      return fail("unexpected layout of the area light");
    double k = o.y / (o.y - ey);
    g.hide_x0 = o.x + (ex0 - o.x) * k, g.hide_x1 = o.x + (ex1 - o.x) * k;
    g.hide_z0 = o.z + (ez0 - o.z) * k, g.hide_z1 = o.z + (ez1 - o.z) * k;
    if (!(g.hide_x0 > 0 && g.hide_x1 < g.floor_x1 && g.hide_z0 > g.z0 && g.hide_z1 < g.z1))
      return fail("unexpected layout of the area light");
  }
  /* A ray towards floor-plane point (x < 0, z) crosses x = 0 at height o.y (-x)/(o.x - x),
   * at most the mirror's top when x >= -o.x top / (o.y - top). */
  g.mirror_x_min = -o.x * my1 / (o.y - my1);
  for (int c = 0; c < 3; c++)
    g.scale[c] = albedo[c] / PI * (area ? radiance[c] : light->intensity[c]) *
                 (caustic ? reflectance[c] : 1.0f);

  const uint32_t w = (uint32_t)width, h = (uint32_t)height;
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return fail("out of memory");
  double gx8[8], gw8[8], gx16[16], gw16[16], gx6[6], gw6[6], gx10[10], gw10[10];
  gauss_legendre(8, gx8, gw8);
  gauss_legendre(16, gx16, gw16);
  gauss_legendre(6, gx6, gw6);
  gauss_legendre(10, gx10, gw10);
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
        g.en = 6, g.ex = gx6, g.ew = gw6;
        v = rect_mean(&g, xa, xb, za, zb, 8, gx8, gw8);
        g.en = 10, g.ex = gx10, g.ew = gw10;
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
          caustic ? (area ? "area light's caustic (box filter)" : "caustic (box filter)")
                  : "direct (pixel centres)",
          w, h, worst);
  bbc_image_free(image);
  bbc_scene_free(scene);
  return 0;
}
