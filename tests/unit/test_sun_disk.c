/* Suns with an angular size (extras.bbc.angular_diameter, docs/lights.md): the path
 * tracer's disk of directions against an independent quadrature on the flat mirror, the
 * split with the cache (nothing counted twice), and an angular diameter of 0 changing
 * nothing.
 *
 * The scene is bbc-scenegen flat-mirror --sun 3 --sun-angle 16: the mirror x = 0 facing
 * +x on the floor y = 0, the sun travelling along (-1, -1, 0) / sqrt 2 with a disk 16
 * degrees across. The floor's caustic is the mirrored disk: at floor point p,
 *   E(p) = R L integral over the sun's cone of cos(theta_p) [the mirror's aperture] d omega,
 * L = E_sun / (pi sin^2(delta / 2)), theta_p against the floor's normal, and a direction
 * omega toward the sun counting where the ray from p toward its mirror image
 * (-omega.x, omega.y, omega.z) meets the mirror rectangle. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "render_fixture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

/* The mirror (plane x = mx, facing +x) spans [my0, my1] x [mz0, mz1]; the floor y = 0
 * spans [fx0, fx1] x [fz0, fz1]. */
typedef struct layout {
  double mx, my0, my1, mz0, mz1;
  double fx0, fx1, fz0, fz1;
  double albedo, reflectance;
} layout;

static int measure(const bbc_scene *s, layout *l) {
  int mirror = 0, floor = 0;
  l->my0 = l->mz0 = l->fx0 = l->fz0 = 1e30;
  l->my1 = l->mz1 = l->fx1 = l->fz1 = -1e30;
  for (uint32_t k = 0; k < s->mesh_count; k++) {
    const bbc_mesh *mesh = &s->meshes[k];
    const bbc_material *m = &s->materials[mesh->material];
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      const float *p = s->positions + 3 * (size_t)v;
      if (mesh->role == BBC_ROLE_RECEIVER) {
        floor = 1;
        l->albedo = m->base_color[0];
        l->fx0 = fmin(l->fx0, p[0]), l->fx1 = fmax(l->fx1, p[0]);
        l->fz0 = fmin(l->fz0, p[2]), l->fz1 = fmax(l->fz1, p[2]);
      } else if (m->type == BBC_MATERIAL_MIRROR) {
        mirror = 1;
        l->mx = p[0];
        l->reflectance = m->base_color[0];
        l->my0 = fmin(l->my0, p[1]), l->my1 = fmax(l->my1, p[1]);
        l->mz0 = fmin(l->mz0, p[2]), l->mz1 = fmax(l->mz1, p[2]);
      }
    }
  }
  return mirror && floor;
}

/* What the oracle computes: the right value, or a control with a term dropped. */
typedef enum model {
  RIGHT = 0,
  DELTA = 1,    /* E_sun cos(theta) from the centre direction: E instead of L Omega */
  NO_COSINE = 2 /* L times the solid angle, without cos(theta_p) */
} model;

typedef struct sun_disk {
  layout l;
  bbc_vec3 axis; /* unit, toward the sun */
  double half_angle, e_sun;
} sun_disk;

/* 1 when the direction omega toward the sun, seen from floor point p through the mirror,
 * passes through the mirror rectangle. */
static int through_mirror(const layout *l, bbc_vec3 p, bbc_vec3 omega) {
  if (!(omega.x > 0)) return 0;
  double t = (p.x - l->mx) / omega.x;
  double y = t * omega.y, z = p.z + t * omega.z;
  return t > 0 && y > l->my0 && y < l->my1 && z > l->mz0 && z < l->mz1;
}

/* The irradiance at floor point p from the sun's disk (mirrored: through the mirror,
 * times its reflectance; else straight from the sky, which nothing occludes here), by the
 * midpoint rule on 16 rings of equal solid angle times 64 sectors. */
static double irradiance(const sun_disk *s, bbc_vec3 p, int mirrored, model m) {
  const double radiance = s->e_sun / (PI * sin(s->half_angle) * sin(s->half_angle));
  const double r = mirrored ? s->l.reflectance : 1.0;
  if (m == DELTA) {
    if (mirrored && !through_mirror(&s->l, p, s->axis)) return 0;
    return r * s->e_sun * s->axis.y;
  }
  bbc_vec3 t, b;
  v3_basis(s->axis, &t, &b);
  const int rings = 16, sectors = 64;
  const double one_minus_cos = 1 - cos(s->half_angle);
  const double cell = 2 * PI * one_minus_cos / (rings * sectors);
  double sum = 0;
  for (int i = 0; i < rings; i++) {
    double cos_t = 1 - one_minus_cos * (i + 0.5) / rings, sin_t = sqrt(1 - cos_t * cos_t);
    for (int j = 0; j < sectors; j++) {
      double phi = 2 * PI * (j + 0.5) / sectors;
      bbc_vec3 omega = v3_add(v3_scale(s->axis, cos_t),
                              v3_add(v3_scale(t, sin_t * cos(phi)), v3_scale(b, sin_t * sin(phi))));
      if (!(omega.y > 0)) continue;
      if (mirrored && !through_mirror(&s->l, p, omega)) continue;
      sum += (m == NO_COSINE ? 1.0 : omega.y) * cell;
    }
  }
  return r * radiance * sum;
}

/* The expected radiance albedo/pi E of every pixel of a w x h image (the mean over 3 x 3
 * film points of the pixel), or -1 where a film point misses the floor's interior (0.05
 * clear of its edges, as the other mirror tests) or the camera does not see it. */
static double *expected_image(const fixture *f, const sun_disk *s, uint32_t w, uint32_t h,
                              int direct, int mirrored, model m) {
  double *out = malloc(sizeof *out * w * h);
  for (uint32_t py = 0; py < h; py++)
    for (uint32_t px = 0; px < w; px++) {
      double sum = 0;
      const int n = 3;
      int usable = 1;
      for (int j = 0; j < n && usable; j++)
        for (int i = 0; i < n && usable; i++) {
          bbc_vec3 o, d;
          bbc_camera_ray(&f->scene->camera, w, h, px + (i + 0.5) / n, py + (j + 0.5) / n, &o, &d);
          double t = -o.y / d.y;
          bbc_vec3 p = v3_madd(o, d, t);
          if (!(d.y < 0 && p.x > s->l.fx0 + 0.05 && p.x < s->l.fx1 - 0.05 &&
                p.z > s->l.fz0 + 0.05 && p.z < s->l.fz1 - 0.05) ||
              bbc_accel_occluded(f->accel, o, d, 0, t * (1 - 1e-6))) {
            usable = 0;
            break;
          }
          double e =
              (direct ? irradiance(s, p, 0, m) : 0) + (mirrored ? irradiance(s, p, 1, m) : 0);
          sum += s->l.albedo / PI * e / (n * n);
        }
      out[(size_t)py * w + px] = usable ? sum : -1;
    }
  return out;
}

/* Two renders a, b with different seeds against the expectation: chi is the sum over the
 * usable pixels of (mean - expected)^2 over the sum of (a - b)^2 / 4, each an unbiased
 * estimate of the summed variance of the mean when the expectation is right (chi about 1;
 * a wrong expectation adds its squared error); z is the summed residual over its standard
 * deviation. */
static void compare(const bbc_image *a, const bbc_image *b, const double *expected, double *chi,
                    double *z, int *pixels, double *lit) {
  double res = 0, res2 = 0, var = 0;
  *pixels = 0, *lit = 0;
  for (size_t i = 0; i < (size_t)a->width * a->height; i++) {
    if (expected[i] < 0) continue;
    double va = a->rgb[3 * i], vb = b->rgb[3 * i];
    double r = 0.5 * (va + vb) - expected[i];
    res += r, res2 += r * r, var += 0.25 * (va - vb) * (va - vb);
    (*pixels)++;
    *lit += expected[i] > 0;
  }
  *chi = res2 / var;
  *z = res / sqrt(var);
}

static bbc_image *render(const fixture *f, bbc_method method, uint32_t components, uint32_t spp,
                         uint32_t w, uint32_t h, uint64_t seed) {
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.spp = spp;
  o.seed = seed;
  o.components = components;
  o.max_depth = 3;
  o.gamma_value = 2;
  return fixture_render(f, o, w, h, NULL);
}

static int setup_disk(fixture *f, sun_disk *s) {
  if (!fixture_setup(f, TEST_SCENE("flat-mirror-disk-sun.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0))
    return 0;
  const bbc_point_light *sun = &f->scene->point_lights[0];
  if (sun->model.kind != BBC_LIGHT_DIRECTIONAL || !measure(f->scene, &s->l)) return 0;
  s->axis = v3_neg(sun->model.direction);
  s->half_angle = 0.5 * sun->model.angular_diameter;
  s->e_sun = sun->intensity[0];
  return 1;
}

/* The loader reads the angular diameter in degrees into radians. */
TEST(disk_sun_loads_its_angular_diameter) {
  fixture f;
  sun_disk s;
  REQUIRE(setup_disk(&f, &s));
  CHECK_NEAR(f.scene->point_lights[0].model.angular_diameter, 16 * PI / 180, 1e-15);
  CHECK_NEAR(s.e_sun, 3, 0);
  /* L / E, written out: 1 / (pi sin^2(8 degrees)). */
  CHECK_NEAR(bbc_light_sun_radiance_scale(16 * PI / 180),
             1 / (PI * 0.13917310096006544 * 0.13917310096006544), 1e-12);
  CHECK_NEAR(bbc_light_sun_radiance_scale(0), 0, 0);
  teardown(&f);
}

/* Plain path tracing at depth 3: its light after the first diffuse vertex is exactly the
 * floor -> mirror -> sky paths that escape within the disk, the mirrored disk's caustic;
 * its direct light is next-event estimation over the disk. Both against the quadrature;
 * the controls (the delta sun's E cos(theta) instead of L Omega, and no cosine) must fail. */
TEST(disk_sun_flat_mirror_caustic_by_path_tracing) {
  fixture f;
  sun_disk s;
  REQUIRE(setup_disk(&f, &s));
  const uint32_t w = 64, h = 48, spp = (uint32_t)harness_scale(1024, 4096);
  bbc_image *a = render(&f, BBC_METHOD_PT, BBC_COMPONENT_INDIRECT, spp, w, h, 11);
  bbc_image *b = render(&f, BBC_METHOD_PT, BBC_COMPONENT_INDIRECT, spp, w, h, 12);
  REQUIRE(a && b);
  static const char *const names[3] = {"right", "delta (E instead of L Omega)", "no cosine"};
  double chi[3], z[3], lit;
  int pixels;
  for (int m = 0; m < 3; m++) {
    double *e = expected_image(&f, &s, w, h, 0, 1, (model)m);
    compare(a, b, e, &chi[m], &z[m], &pixels, &lit);
    fprintf(stderr, "caustic, %s: chi %.3f, z %.2f (%d pixels, %.0f lit)\n", names[m], chi[m], z[m],
            pixels, lit);
    free(e);
  }
  CHECK(pixels > 1000 && lit > 300 && lit < pixels - 100); /* the aperture's edge is seen */
  CHECK(chi[RIGHT] < 1.3 && fabs(z[RIGHT]) < 4.5);
  CHECK(chi[DELTA] > 2);
  CHECK(chi[NO_COSINE] > 2 && fabs(z[NO_COSINE]) > 10);
  bbc_image_free(a);
  bbc_image_free(b);

  a = render(&f, BBC_METHOD_PT, BBC_COMPONENT_DIRECT, 64, w, h, 13);
  b = render(&f, BBC_METHOD_PT, BBC_COMPONENT_DIRECT, 64, w, h, 14);
  REQUIRE(a && b);
  for (int m = 0; m < 3; m += 2) {
    double *e = expected_image(&f, &s, w, h, 1, 0, (model)m);
    compare(a, b, e, &chi[m], &z[m], &pixels, &lit);
    fprintf(stderr, "direct, %s: chi %.3f, z %.2f (%d pixels)\n", names[m], chi[m], z[m], pixels);
    free(e);
  }
  CHECK(chi[RIGHT] < 1.3 && fabs(z[RIGHT]) < 4.5);
  CHECK(chi[NO_COSINE] > 100);
  bbc_image_free(a);
  bbc_image_free(b);
  teardown(&f);
}

/* With the cache, the estimator counts the mirror's caustic with the sun's centre
 * direction, so the path tracer must not count it again: at depth 3 the light after the
 * first diffuse vertex is black. The estimator's caustic is the delta sun's, the same
 * image as for the scene without an angular size (the cache does not depend on it). */
TEST(disk_sun_split_with_the_cache) {
  fixture f, g;
  sun_disk s;
  REQUIRE(setup_disk(&f, &s));
  REQUIRE(fixture_setup(&g, TEST_SCENE("flat-mirror-sun.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0));
  const uint32_t w = 64, h = 48;
  bbc_image *rest = render(&f, BBC_METHOD_BBC, BBC_COMPONENT_INDIRECT, 64, w, h, 5);
  bbc_image *pt = render(&f, BBC_METHOD_PT, BBC_COMPONENT_INDIRECT, 64, w, h, 5);
  REQUIRE(rest && pt);
  double sum_rest = 0, sum_pt = 0;
  for (size_t i = 0; i < (size_t)w * h * 3; i++) sum_rest += rest->rgb[i], sum_pt += pt->rgb[i];
  CHECK(sum_rest == 0);
  CHECK(sum_pt > 0);
  bbc_image *disk = render(&f, BBC_METHOD_BBC, BBC_COMPONENT_CAUSTICS, 4, w, h, 6);
  bbc_image *delta = render(&g, BBC_METHOD_BBC, BBC_COMPONENT_CAUSTICS, 4, w, h, 6);
  REQUIRE(disk && delta);
  CHECK(memcmp(disk->rgb, delta->rgb, sizeof(float) * 3 * w * h) == 0);
  /* The cache of one opens for the other: the angular size is not in the fingerprint. */
  CHECK(bbc_cache_check_scene(f.cache, g.scene) == BBC_OK);
  bbc_image_free(rest);
  bbc_image_free(pt);
  bbc_image_free(disk);
  bbc_image_free(delta);
  teardown(&f);
  teardown(&g);
}

/* An angular diameter of 0 written out is the delta sun of a file without it: the same
 * model and byte-identical images (path tracing and the cache); and a delta sun cannot be
 * hit, so plain path tracing's light after the first diffuse vertex stays black. */
TEST(disk_sun_zero_diameter_is_the_delta_sun) {
  fixture f, g;
  REQUIRE(fixture_setup(&f, TEST_SCENE("flat-mirror-sun.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0));
  REQUIRE(
      fixture_setup(&g, TEST_SCENE("flat-mirror-sun-zero.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0));
  CHECK(g.scene->point_lights[0].model.angular_diameter == 0);
  CHECK(memcmp(&f.scene->point_lights[0].model, &g.scene->point_lights[0].model,
               sizeof(bbc_light_model)) == 0);
  const uint32_t w = 48, h = 36;
  const uint32_t all = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT;
  for (int method = 0; method < 2; method++) {
    bbc_method m = method ? BBC_METHOD_BBC : BBC_METHOD_PT;
    bbc_image *a = render(&f, m, all, 8, w, h, 9);
    bbc_image *b = render(&g, m, all, 8, w, h, 9);
    REQUIRE(a && b);
    CHECK(memcmp(a->rgb, b->rgb, sizeof(float) * 3 * w * h) == 0);
    bbc_image_free(a);
    bbc_image_free(b);
  }
  bbc_image *pt = render(&g, BBC_METHOD_PT, BBC_COMPONENT_INDIRECT, 64, w, h, 5);
  REQUIRE(pt);
  double sum = 0;
  for (size_t i = 0; i < (size_t)w * h * 3; i++) sum += pt->rgb[i];
  CHECK(sum == 0);
  bbc_image_free(pt);
  teardown(&f);
  teardown(&g);
}
