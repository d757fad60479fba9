/* Exact specular paths (bbc/specular_path.h) against independent oracles: mirrored lights
 * for flat mirrors, Snell's law in closed form for flat interfaces and slabs, and central
 * differences for the dual-number derivatives on curved triangles. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/scene.h"
#include "bbc/specular_path.h"
#define CHAIN_FIXTURES_SEED 0x9e3779b97f4a7c15ull
#include "chain_fixtures.h"
#include "harness.h"
#include "vec_internal.h"

/* ------------------------------------------------------------------------------------ */
/* Helpers. */

static double rel_err(double a, double b) {
  return fabs(a - b) / fmax(fabs(b), 1e-300);
}

/* ------------------------------------------------------------------------------------ */

/* A flat mirror: the receiver sees exactly the mirrored light, E = I cos(theta) / r^2. */
TEST(flat_mirror_mirrored_light) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 1.2, 0.3);
  g.intensity = 7.5;
  g.length = 1;
  /* The wall x = 0 facing +x, and a floor y = 0 facing up. */
  flat_specular(&g.specular[0], v3(0, 0, -2), v3(0, 0, 2), v3(0, 2.5, 0), v3(1, 0, 0), 0, 1.5);
  set_tri(g.receiver, v3(-1, 0, -6), v3(6, 0, 0), v3(-1, 0, 6));
  bbc_vec3 image = mirror_point(g.light, v3(0, 0, 0), v3(1, 0, 0));
  int valid = 0;
  for (int i = 0; i < 2000; i++) {
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & BBC_PATH_REJECT) continue;
    valid++;
    bbc_vec3 d = v3_sub(image, p.xk);
    double r = v3_length(d);
    double expect = g.intensity * fabs(d.y) / (r * r * r);
    CHECK(rel_err(p.irradiance, expect) < 1e-12);
    /* x_k lies on the line from the image through x1. */
    bbc_vec3 a = v3_normalize(v3_sub(p.x1, image)), b = v3_normalize(v3_sub(p.xk, image));
    CHECK(v3_length(v3_cross(a, b)) < 1e-13);
    /* dA_k/du1 and the Jacobian agree: dA_k = |det| |e_k1 x e_k2|. */
    double area = v3_length(
        v3_cross(v3_sub(g.receiver[1], g.receiver[0]), v3_sub(g.receiver[2], g.receiver[0])));
    CHECK(rel_err(p.darea_du, p.jacobian * area) < 1e-12);
  }
  CHECK(valid > 500);
}

/* The generated flat-mirror scene: the same oracle with the scene loader's tuples. */
TEST(flat_mirror_scene) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  REQUIRE(nc > 0 && nr > 0);
  bbc_vec3 image = mirror_point(s->point_lights[0].position, v3(0, 0, 0), v3(1, 0, 0));
  int valid = 0;
  long samples = harness_scale(4000, 100000);
  for (long i = 0; i < samples; i++) {
    bbc_tuple t = {0,
                   BBC_CHAIN_R,
                   {casters[(uint32_t)(rnd() * nc)], BBC_NO_TRIANGLE},
                   receivers[(uint32_t)(rnd() * nr)]};
    bbc_path_geometry g;
    REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
    g.intensity = s->point_lights[0].intensity[0];
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & BBC_PATH_REJECT) continue;
    valid++;
    bbc_vec3 d = v3_sub(image, p.xk);
    double r = v3_length(d);
    CHECK(rel_err(p.irradiance, g.intensity * fabs(d.y) / (r * r * r)) < 1e-11);
  }
  CHECK(valid > samples / 10);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

/* The closed form of refraction at a flat interface y = 0 (ior n below, light at height h
 * above) onto a parallel receiver at depth D: a ray at angle theta0 from the normal meets
 * the receiver at radius R = h tan(theta0) + D tan(theta1), sin(theta0) = n sin(theta1),
 * and E = I dOmega/dA = I sin(theta0) dtheta0 dphi / (R dR dphi). */
static void snell_flat(double h, double depth, double n, double theta0, double *radius,
                       double *irradiance_per_i) {
  double theta1 = asin(sin(theta0) / n);
  *radius = h * tan(theta0) + depth * tan(theta1);
  double dtheta1 = cos(theta0) / (n * cos(theta1));
  double dr = h / (cos(theta0) * cos(theta0)) + depth / (cos(theta1) * cos(theta1)) * dtheta1;
  *irradiance_per_i = sin(theta0) / (*radius * dr);
}

TEST(flat_refraction_closed_form) {
  const double h = 1.3, depth = 0.9, ior = 1.33;
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(0.2, h, -0.1);
  g.intensity = 3.0;
  g.length = 1;
  flat_specular(&g.specular[0], v3(-3, 0, -3), v3(3, 0, -3), v3(0, 0, 4), v3(0, 1, 0), 1, ior);
  set_tri(g.receiver, v3(-9, -depth, -9), v3(9, -depth, -9), v3(0, -depth, 9));
  int valid = 0;
  for (int i = 0; i < 2000; i++) {
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & BBC_PATH_REJECT) continue;
    valid++;
    /* The oracle: the radial offset of x1 gives theta0; Snell gives R and E. */
    double dx = p.x1.x - g.light.x, dz = p.x1.z - g.light.z;
    double r1 = sqrt(dx * dx + dz * dz);
    if (r1 < 1e-6) continue; /* the formula's 0/0 at normal incidence */
    double theta0 = atan2(r1, h), radius, e;
    snell_flat(h, depth, ior, theta0, &radius, &e);
    double kx = p.xk.x - g.light.x, kz = p.xk.z - g.light.z;
    CHECK(rel_err(sqrt(kx * kx + kz * kz), radius) < 1e-12);
    CHECK(fabs(kx * dz - kz * dx) < 1e-12 * (radius * r1 + 1)); /* same azimuth */
    CHECK(rel_err(p.irradiance, g.intensity * e) < 1e-10);
    CHECK(fabs(p.xk.y + depth) < 1e-12);
  }
  CHECK(valid > 1500);
}

/* Leaving the denser medium: past the critical angle there is no refracted ray. */
TEST(total_internal_reflection) {
  const double ior = 1.5;
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(0, -1, 0); /* below the interface, inside the glass */
  g.intensity = 1;
  g.length = 1;
  flat_specular(&g.specular[0], v3(-5, 0, -5), v3(5, 0, -5), v3(0, 0, 5), v3(0, 1, 0), 1, ior);
  set_tri(g.receiver, v3(-20, 3, -20), v3(0, 3, 20), v3(20, 3, -20));
  int tir = 0, through = 0;
  for (int i = 0; i < 3000; i++) {
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    double r = hypot(p.x1.x, p.x1.z), sin_i = r / sqrt(r * r + 1);
    if (sin_i * ior > 1 + 1e-12) {
      CHECK(p.flags & BBC_PATH_TIR);
      CHECK(!p.complete);
      tir++;
    } else if (sin_i * ior < 1 - 1e-12) {
      CHECK(!(p.flags & BBC_PATH_TIR));
      CHECK(p.complete);
      /* Leaving: sin(theta_out) = ior sin(theta_in). */
      bbc_vec3 d = v3_normalize(v3_sub(p.xk, p.x1));
      CHECK_NEAR(hypot(d.x, d.z), ior * sin_i, 1e-12);
      through++;
    }
  }
  CHECK(tir > 100 && through > 100);
}

/* Two flat mirrors (RR): the receiver sees the light mirrored twice. */
TEST(double_mirror_rr) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 2.5, 3.0);
  g.intensity = 2.0;
  g.length = 2;
  /* Mirror A: the wall x = 0 facing +x; mirror B: the wall z = 0 facing +z, so light
   * bounces off A toward -z onto B and from B down onto the floor. */
  flat_specular(&g.specular[0], v3(0, 0, 0.2), v3(0, 0, 3), v3(0, 3, 1.5), v3(1, 0, 0), 0, 1);
  flat_specular(&g.specular[1], v3(-1, 0, 0), v3(8, 0, 0), v3(3, 5, 0), v3(0, 0, 1), 0, 1);
  set_tri(g.receiver, v3(-10, 0, -10), v3(-10, 0, 10), v3(10, 0, 0));
  bbc_vec3 image =
      mirror_point(mirror_point(g.light, v3(0, 0, 0), v3(1, 0, 0)), v3(0, 0, 0), v3(0, 0, 1));
  int valid = 0;
  for (int i = 0; i < 4000; i++) {
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & BBC_PATH_REJECT) continue;
    valid++;
    bbc_vec3 d = v3_sub(image, p.xk);
    double r = v3_length(d);
    CHECK(rel_err(p.irradiance, g.intensity * fabs(d.y) / (r * r * r)) < 1e-11);
    /* x2 and x_k lie on the line from the double image. */
    bbc_vec3 a = v3_normalize(v3_sub(p.x2, image)), b = v3_normalize(v3_sub(p.xk, image));
    CHECK(v3_length(v3_cross(a, b)) < 1e-12);
  }
  CHECK(valid > 600);
}

/* A glass slab with flat faces (TT): the ray leaves parallel to the incoming one,
 * displaced, with R = (h + D) tan(theta0) + T tan(theta1). */
TEST(flat_slab_tt) {
  const double h = 1.1, thick = 0.4, depth = 0.7, ior = 1.5;
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(-0.2, h, 0.3);
  g.intensity = 5.0;
  g.length = 2;
  flat_specular(&g.specular[0], v3(-4, 0, -4), v3(4, 0, -4), v3(0, 0, 4), v3(0, 1, 0), 1, ior);
  /* The bottom face's normals point out of the glass, down. */
  flat_specular(&g.specular[1], v3(-9, -thick, -9), v3(0, -thick, 9), v3(9, -thick, -9),
                v3(0, -1, 0), 1, ior);
  double yk = -thick - depth;
  set_tri(g.receiver, v3(-20, yk, -20), v3(20, yk, -20), v3(0, yk, 20));
  int valid = 0;
  for (int i = 0; i < 3000; i++) {
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & BBC_PATH_REJECT) continue;
    valid++;
    bbc_vec3 din = v3_normalize(v3_sub(p.x1, g.light)), dout = v3_normalize(v3_sub(p.xk, p.x2));
    CHECK(v3_length(v3_sub(din, dout)) < 1e-13);
    double dx = p.x1.x - g.light.x, dz = p.x1.z - g.light.z, r1 = hypot(dx, dz);
    if (r1 < 1e-6) continue;
    double t0 = atan2(r1, h), t1 = asin(sin(t0) / ior);
    double radius = (h + depth) * tan(t0) + thick * tan(t1);
    double dr =
        (h + depth) / (cos(t0) * cos(t0)) + thick / (cos(t1) * cos(t1)) * cos(t0) / (ior * cos(t1));
    double e = g.intensity * sin(t0) / (radius * dr);
    CHECK(rel_err(hypot(p.xk.x - g.light.x, p.xk.z - g.light.z), radius) < 1e-12);
    CHECK(rel_err(p.irradiance, e) < 1e-10);
  }
  CHECK(valid > 2000);
  /* Normal incidence: E = I / (h + D + T / ior)^2 (the paraxial limit of the above). */
  bbc_path_geometry g2 = g;
  g2.light = v3(0, h, 0);
  double bu[2];
  REQUIRE(bbc_triangle_barycentrics(g2.specular[0].p, v3(0, 0, 0), bu));
  bbc_specular_path p;
  REQUIRE(bbc_specular_path_trace(&g2, bu[0], bu[1], &p) == BBC_OK);
  CHECK(!(p.flags & BBC_PATH_REJECT));
  double l = h + depth + thick / ior;
  CHECK(rel_err(p.irradiance, g2.intensity / (l * l)) < 1e-12);
}

/* ------------------------------------------------------------------------------------ */
/* Dual numbers against central differences on curved triangles. */

/* Compares d u_k / d u1 (and d u2 / d u1) of the trace at (u, v) with central
 * differences, and the irradiance with the one the differenced Jacobian gives. Returns 1
 * if the comparison was made. */
typedef struct worst_errors {
  double jacobian;   /* relative error of d u_k / d u1 and d u2 / d u1 */
  double irradiance; /* relative error of E_k against the differenced Jacobian's */
} worst_errors;

static int check_derivatives(const bbc_path_geometry *g, double u, double v, worst_errors *worst) {
  bbc_specular_path p, a, b;
  if (bbc_specular_path_trace(g, u, v, &p) != BBC_OK || !p.complete) return 0;
  const double h = 1e-6;
  double fd[2][2], fd2[2][2];
  for (int c = 0; c < 2; c++) {
    double du = c == 0 ? h : 0, dv = c == 1 ? h : 0;
    if (bbc_specular_path_trace(g, u + du, v + dv, &a) != BBC_OK || !a.complete) return 0;
    if (bbc_specular_path_trace(g, u - du, v - dv, &b) != BBC_OK || !b.complete) return 0;
    for (int r = 0; r < 2; r++) {
      fd[r][c] = (a.uk[r] - b.uk[r]) / (2 * h);
      fd2[r][c] = (a.u2[r] - b.u2[r]) / (2 * h);
    }
  }
  double scale = 0;
  for (int r = 0; r < 2; r++)
    for (int c = 0; c < 2; c++) scale = fmax(scale, fabs(p.duk[r][c]));
  double err = 0;
  for (int r = 0; r < 2; r++)
    for (int c = 0; c < 2; c++) {
      err = fmax(err, fabs(fd[r][c] - p.duk[r][c]) / scale);
      if (g->length == 2) {
        double s2 = fmax(fabs(p.du2[0][0]) + fabs(p.du2[1][1]), 1e-300);
        err = fmax(err, fabs(fd2[r][c] - p.du2[r][c]) / s2);
      }
    }
  double det = fabs(fd[0][0] * fd[1][1] - fd[0][1] * fd[1][0]);
  double area = v3_length(
      v3_cross(v3_sub(g->receiver[1], g->receiver[0]), v3_sub(g->receiver[2], g->receiver[0])));
  double e_fd = g->intensity * p.domega_du / (det * area);
  /* The irradiance is compared where the Jacobian is not nearly singular (a focal point
   * amplifies the differences' error without bound). */
  if (p.jacobian > 1e-3 * scale * scale)
    worst->irradiance = fmax(worst->irradiance, rel_err(e_fd, p.irradiance));
  worst->jacobian = fmax(worst->jacobian, err);
  return 1;
}

/* The receiver triangle (of the receiver triangles listed) that the path through u1 lands
 * inside, with g's specular part fixed; -1 if none. */
static int find_receiver(bbc_path_geometry *g, const bbc_scene *s, const uint32_t *recv,
                         uint32_t nr, double u, double v) {
  for (uint32_t k = 0; k < nr; k++) {
    const uint32_t *idx = s->indices + 3 * (size_t)recv[k];
    for (int j = 0; j < 3; j++) g->receiver[j] = v3_load(s->positions + 3 * (size_t)idx[j]);
    bbc_specular_path p;
    if (bbc_specular_path_trace(g, u, v, &p) == BBC_OK && p.complete &&
        !(p.flags & BBC_PATH_REJECT))
      return (int)k;
  }
  return -1;
}

static void derivative_scene(const char *path, bbc_chain chain, long samples) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, path, NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  int curved = 0, compared = 0;
  worst_errors worst = {0, 0};
  for (long i = 0; i < samples; i++) {
    uint32_t t1 = casters[(uint32_t)(rnd() * nc)];
    bbc_tuple t = {0, chain, {t1, BBC_NO_TRIANGLE}, receivers[0]};
    bbc_path_geometry g;
    REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
    const bbc_specular_triangle *st = &g.specular[0];
    if (v3_length(v3_sub(st->n[0], st->n[1])) + v3_length(v3_sub(st->n[0], st->n[2])) > 1e-6)
      curved++;
    double u, v;
    rnd_bary(&u, &v);
    if (find_receiver(&g, s, receivers, nr, u, v) < 0) continue;
    compared += check_derivatives(&g, u, v, &worst);
  }
  fprintf(stderr,
          "%s %s: %d compared (%d curved triangles), worst relative error %.3g (Jacobian), "
          "%.3g (irradiance)\n",
          path, bbc_chain_name(chain), compared, curved, worst.jacobian, worst.irradiance);
  CHECK(compared > samples / 10);
  CHECK(curved > samples / 2);
  CHECK(worst.jacobian < 1e-6);
  CHECK(worst.irradiance < 1e-5);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

TEST(derivatives_wavy_mirror) {
  derivative_scene(TEST_SCENE("wavy-mirror.gltf"), BBC_CHAIN_R, harness_scale(2000, 50000));
}

TEST(derivatives_pool) {
  derivative_scene(TEST_SCENE("pool.gltf"), BBC_CHAIN_T, harness_scale(2000, 50000));
}

/* Double refraction through the glass sphere: T2 is found by tracing the first refraction
 * against every sphere triangle as a receiver (brute force). */
TEST(derivatives_sphere_tt) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-sphere.gltf"), NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  long samples = harness_scale(300, 5000);
  int compared = 0;
  worst_errors worst = {0, 0};
  for (long i = 0; i < samples; i++) {
    uint32_t t1 = casters[(uint32_t)(rnd() * nc)];
    double u, v;
    rnd_bary(&u, &v);
    /* The first refraction as a length-1 chain aimed at each candidate T2. */
    bbc_tuple one = {0, BBC_CHAIN_T, {t1, BBC_NO_TRIANGLE}, t1};
    bbc_path_geometry g1;
    REQUIRE(bbc_path_geometry_init(&g1, s, &one) == BBC_OK);
    int best = -1;
    double best_t = INFINITY;
    for (uint32_t k = 0; k < nc; k++) {
      if (casters[k] == t1) continue;
      const uint32_t *idx = s->indices + 3 * (size_t)casters[k];
      for (int j = 0; j < 3; j++) g1.receiver[j] = v3_load(s->positions + 3 * (size_t)idx[j]);
      bbc_specular_path p;
      if (bbc_specular_path_trace(&g1, u, v, &p) != BBC_OK || !p.complete) continue;
      if (p.flags & (BBC_PATH_REJECT & ~(uint32_t)BBC_PATH_GEOMETRIC_SIDE)) continue;
      double dist = v3_length(v3_sub(p.xk, p.x1));
      if (dist > 1e-9 && dist < best_t) best_t = dist, best = (int)k;
    }
    if (best < 0) continue;
    bbc_tuple two = {0, BBC_CHAIN_TT, {t1, casters[best]}, receivers[0]};
    bbc_path_geometry g;
    REQUIRE(bbc_path_geometry_init(&g, s, &two) == BBC_OK);
    if (find_receiver(&g, s, receivers, nr, u, v) < 0) continue;
    compared += check_derivatives(&g, u, v, &worst);
  }
  fprintf(stderr, "glass-sphere TT: %d compared, worst relative error %.3g (Jacobian), %.3g (E)\n",
          compared, worst.jacobian, worst.irradiance);
  CHECK(compared > samples / 10);
  CHECK(worst.jacobian < 1e-6);
  CHECK(worst.irradiance < 1e-5);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

/* Random curved triangles in a double reflection: exercises u2's normal interpolation in
 * the derivative chain with strongly varying normals. */
TEST(derivatives_curved_rr) {
  int compared = 0;
  worst_errors worst = {0, 0};
  for (int i = 0; i < 2000; i++) {
    bbc_path_geometry g;
    memset(&g, 0, sizeof g);
    g.light = v3(0.5, 2, 0.5);
    g.intensity = 1;
    g.length = 2;
    /* T1 near the floor facing up-ish, T2 above facing down-ish, wobbly normals. */
    bbc_specular_triangle *a = &g.specular[0], *b = &g.specular[1];
    set_tri(a->p, v3(-1, 0, -1), v3(2, 0.1, -1), v3(0, -0.1, 2));
    set_tri(b->p, v3(-3, 3, -3), v3(0, 3.2, 4), v3(4, 2.9, -3));
    for (int j = 0; j < 3; j++) {
      a->n[j] = v3(0.3 * (rnd() - 0.5), 1, 0.3 * (rnd() - 0.5));
      b->n[j] = v3(0.3 * (rnd() - 0.5), -1, 0.3 * (rnd() - 0.5));
    }
    set_tri(g.receiver, v3(-30, 0.5, -30), v3(30, 0.5, -30), v3(0, 0.5, 30));
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.flags & (BBC_PATH_TIR | BBC_PATH_DEGENERATE | BBC_PATH_BACK_SIDE)) continue;
    compared += check_derivatives(&g, u, v, &worst);
  }
  fprintf(stderr, "curved RR: %d compared, worst relative error %.3g (Jacobian), %.3g (E)\n",
          compared, worst.jacobian, worst.irradiance);
  CHECK(compared > 1000);
  CHECK(worst.jacobian < 1e-6);
  CHECK(worst.irradiance < 1e-5);
}

/* ------------------------------------------------------------------------------------ */

TEST(validity_flags) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1, 1, 0);
  g.intensity = 1;
  g.length = 1;
  flat_specular(&g.specular[0], v3(0, 0, -1), v3(0, 0, 1), v3(0, 2, 0), v3(1, 0, 0), 0, 1.5);
  set_tri(g.receiver, v3(-1, 0, -3), v3(5, 0, 0), v3(-1, 0, 3));
  bbc_specular_path p;
  /* An admissible path. */
  REQUIRE(bbc_specular_path_trace(&g, 0.25, 0.25, &p) == BBC_OK);
  CHECK_INT(p.flags & BBC_PATH_REJECT, 0);
  CHECK(p.complete);
  /* Outside T1 (but still traced through the plane). */
  REQUIRE(bbc_specular_path_trace(&g, 0.8, 0.4, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_OUTSIDE_T1);
  CHECK(p.complete);
  /* The light behind the mirror. */
  bbc_path_geometry back = g;
  back.light = v3(-1, 1, 0);
  REQUIRE(bbc_specular_path_trace(&back, 0.25, 0.25, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_BACK_SIDE);
  /* A receiver the reflected ray moves away from: y = 3 while x1 is below it and the
   * ray descends. */
  bbc_path_geometry high = g;
  set_tri(high.receiver, v3(-1, 3, -3), v3(5, 3, 0), v3(-1, 3, 3));
  REQUIRE(bbc_specular_path_trace(&high, 0.1, 0.1, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_BACKWARD);
  /* Landing beyond a small receiver. */
  bbc_path_geometry small = g;
  set_tri(small.receiver, v3(10, 0, 0), v3(10.1, 0, 0), v3(10, 0, 0.1));
  REQUIRE(bbc_specular_path_trace(&small, 0.25, 0.25, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_OUTSIDE_RECEIVER);
  /* A ray parallel to the receiver's plane. */
  bbc_path_geometry par = g;
  set_tri(par.receiver, v3(-1, 3, -3), v3(5, 3, 0), v3(-1, 3, 3));
  par.light = v3(1, 0.5, 0); /* level with x1 = (0, 0.5, 0): the ray runs along +x */
  REQUIRE(bbc_specular_path_trace(&par, 0.375, 0.25, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_DEGENERATE);
  /* A second vertex missed. */
  bbc_path_geometry two;
  memset(&two, 0, sizeof two);
  two.light = v3(1.0, 1.5, 1.4);
  two.intensity = 1;
  two.length = 2;
  flat_specular(&two.specular[0], v3(0, 0, 0.5), v3(0, 0, 4), v3(0, 3, 2), v3(1, 0, 0), 0, 1);
  flat_specular(&two.specular[1], v3(5, 0, 0), v3(6, 0, 0), v3(5, 1, 0), v3(0, 0, 1), 0, 1);
  set_tri(two.receiver, v3(-10, 0, -10), v3(-10, 0, 10), v3(10, 0, 0));
  REQUIRE(bbc_specular_path_trace(&two, 0.3, 0.3, &p) == BBC_OK);
  CHECK(p.flags & BBC_PATH_OUTSIDE_T2);
  /* Refraction is admissible from either side. */
  bbc_path_geometry glass = g;
  glass.specular[0].refract = 1;
  glass.light = v3(-1, 1, 0);
  set_tri(glass.receiver, v3(1, -5, -5), v3(1, 5, 0), v3(1, -5, 5));
  REQUIRE(bbc_specular_path_trace(&glass, 0.25, 0.25, &p) == BBC_OK);
  CHECK_INT(p.flags & BBC_PATH_REJECT, 0);
}

TEST(geometry_from_scene) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("pool.gltf"), NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  REQUIRE(role_triangles(s, BBC_ROLE_RECEIVER, &receivers) > 0);
  REQUIRE(nc > 1);
  bbc_tuple t = {0, BBC_CHAIN_T, {casters[0], BBC_NO_TRIANGLE}, receivers[0]};
  bbc_path_geometry g;
  REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
  CHECK_INT(g.length, 1);
  CHECK_INT(g.specular[0].refract, 1);
  CHECK_NEAR(g.specular[0].ior, 1.33, 1e-6);
  CHECK_NEAR(g.intensity, 1.0, 0);
  /* Refracting normals keep their direction (the water faces up). */
  CHECK(g.specular[0].n[0].y > 0);
  bbc_tuple tt = {0, BBC_CHAIN_TR, {casters[0], casters[1]}, receivers[0]};
  REQUIRE(bbc_path_geometry_init(&g, s, &tt) == BBC_OK);
  CHECK_INT(g.length, 2);
  CHECK_INT(g.specular[0].refract, 1);
  CHECK_INT(g.specular[1].refract, 0);
  /* Errors. */
  bbc_tuple bad = t;
  bad.chain = BBC_CHAIN_COUNT;
  CHECK_INT(bbc_path_geometry_init(&g, s, &bad), BBC_ERR_INVALID_ARGUMENT);
  bad = tt;
  bad.specular[1] = BBC_NO_TRIANGLE;
  CHECK_INT(bbc_path_geometry_init(&g, s, &bad), BBC_ERR_INVALID_ARGUMENT);
  bad = t;
  bad.light = 7;
  CHECK_INT(bbc_path_geometry_init(&g, s, &bad), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_path_geometry_init(NULL, s, &t), BBC_ERR_INVALID_ARGUMENT);
  free(casters);
  free(receivers);
  bbc_scene_free(s);

  /* A mirror lit from behind its normals is turned to face the light (two-sided). */
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("flat-mirror.gltf"), NULL) == BBC_OK);
  nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  REQUIRE(role_triangles(s, BBC_ROLE_RECEIVER, &receivers) > 0);
  s->point_lights[0].position = v3(-1, 1, 0); /* behind the wall x = 0 facing +x */
  bbc_tuple r = {0, BBC_CHAIN_R, {casters[0], BBC_NO_TRIANGLE}, receivers[0]};
  REQUIRE(bbc_path_geometry_init(&g, s, &r) == BBC_OK);
  CHECK(g.specular[0].n[0].x < 0);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

TEST(invalid_arguments) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  bbc_specular_path p;
  g.length = 3;
  CHECK_INT(bbc_specular_path_trace(&g, 0.2, 0.2, &p), BBC_ERR_INVALID_ARGUMENT);
  g.length = 1;
  CHECK_INT(bbc_specular_path_trace(&g, NAN, 0.2, &p), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_specular_path_trace(NULL, 0.2, 0.2, &p), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_specular_path_trace(&g, 0.2, 0.2, NULL), BBC_ERR_INVALID_ARGUMENT);
  /* All-zero geometry: a degenerate path, not a crash. */
  CHECK_INT(bbc_specular_path_trace(&g, 0.2, 0.2, &p), BBC_OK);
  CHECK(p.flags & BBC_PATH_DEGENERATE);
}
