/* Glossy receivers: glTF's metallic-roughness BRDF (bsdf.c) against a value worked out by
 * hand, reciprocity and a deterministic quadrature of its sampling; and end to end on a
 * flat mirror over a glossy floor, the caustic (enumeration of the cache) and the path
 * tracer's direct light within the analytic values, pixel by pixel: the mirrored light
 * (or the light) times the BRDF for its direction. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "floor_footprint.h"
#include "harness.h"
#include "render_fixture.h"
#include "rng_internal.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

static bbc_bsdf glossy(double base, double metallic, double roughness) {
  bbc_bsdf b;
  memset(&b, 0, sizeof b);
  b.base[0] = base, b.base[1] = 0.5 * base, b.base[2] = 0.25 * base;
  b.glossy = 1;
  b.metallic = metallic;
  b.alpha = roughness * roughness;
  return b;
}

static bbc_vec3 dir(double theta, double phi) {
  return v3(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

/* At normal incidence (wo = wi = n) h = n: D = 1 / (pi a^2), Vis = 1/4, so
 * f = (1 - m)(0.96 base / pi + 0.04 / (4 pi a^2)) + m base / (4 pi a^2), with a the GGX
 * width roughness^2, so a^2 = roughness^4. */
TEST(normal_incidence_by_hand) {
  const bbc_vec3 n = v3(0, 1, 0);
  const double ms[3] = {0, 0.5, 1}, rs[3] = {0.2, 0.5, 1};
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      bbc_bsdf b = glossy(0.8, ms[i], rs[j]);
      double f[3];
      bbc_bsdf_eval(&b, n, n, n, f);
      double a2 = pow(rs[j], 4), spec = 1.0 / (4 * PI * a2);
      for (int k = 0; k < 3; k++) {
        double want = (1 - ms[i]) * (0.96 * b.base[k] / PI + 0.04 * spec) + ms[i] * b.base[k] * spec;
        CHECK_NEAR(f[k], want, 1e-12 * want);
      }
    }
  /* Lambertian: base / pi whatever the directions; nothing below the surface. */
  bbc_bsdf l = glossy(0.8, 0, 1);
  l.glossy = 0;
  double f[3];
  bbc_bsdf_eval(&l, n, dir(1.2, 0.3), dir(0.4, 2.0), f);
  CHECK_NEAR(f[1], 0.4 / PI, 1e-15);
  bbc_bsdf_eval(&l, n, dir(1.2, 0.3), dir(2.0, 2.0), f);
  CHECK_NEAR(f[0], 0, 0);
}

/* f(wo, wi) = f(wi, wo), and an off-specular value against the formulas written out. */
TEST(reciprocity_and_formula) {
  const bbc_vec3 n = v3(0, 1, 0);
  bbc_rng rng = {12345, 0};
  for (int i = 0; i < 200; i++) {
    bbc_bsdf b = glossy(bbc_rng_next(&rng), bbc_rng_next(&rng), 0.05 + 0.95 * bbc_rng_next(&rng));
    bbc_vec3 wo = dir(1.5 * bbc_rng_next(&rng), 6.28 * bbc_rng_next(&rng));
    bbc_vec3 wi = dir(1.5 * bbc_rng_next(&rng), 6.28 * bbc_rng_next(&rng));
    double f[3], g[3];
    bbc_bsdf_eval(&b, n, wo, wi, f);
    bbc_bsdf_eval(&b, n, wi, wo, g);
    /* The formula: h, D, Vis and Fresnel from their definitions. */
    bbc_vec3 h = v3_normalize(v3_add(wo, wi));
    double nh = h.y, vh = v3_dot(wo, h), nl = wi.y, nv = wo.y, a2 = b.alpha * b.alpha;
    double d = a2 / (PI * pow(nh * nh * (a2 - 1) + 1, 2));
    double vis = 0.5 / (nl * sqrt(nv * nv * (1 - a2) + a2) + nv * sqrt(nl * nl * (1 - a2) + a2));
    double s5 = pow(1 - vh, 5);
    for (int k = 0; k < 3; k++) {
      CHECK_NEAR(f[k], g[k], 1e-12 * fabs(f[k]) + 1e-300);
      double fd = 0.04 + 0.96 * s5, fm = b.base[k] + (1 - b.base[k]) * s5;
      double want = (1 - b.metallic) * ((1 - fd) * b.base[k] / PI + fd * d * vis) +
                    b.metallic * fm * d * vis;
      CHECK_NEAR(f[k], want, 1e-9 * want + 1e-300);
    }
  }
}

/* The sampler's weights average to the integral of f cos over the hemisphere, computed
 * by a deterministic quadrature that does not use the sampler: the path tracer's
 * bounces are unbiased. Also the density integrates to at most 1. */
TEST(sampling_matches_quadrature) {
  const bbc_vec3 n = v3(0, 1, 0);
  const double cases[4][3] = {{0.8, 0, 0.5}, {0.8, 1, 0.3}, {0.5, 0.5, 0.8}, {0.9, 0, 0.2}};
  for (int c = 0; c < 4; c++) {
    bbc_bsdf b = glossy(cases[c][0], cases[c][1], cases[c][2]);
    bbc_vec3 wo = dir(0.7, 0.4);
    /* Quadrature in (cos theta, phi), fine near the specular lobe by sheer count. */
    const int nt = 2000, np = 1000;
    double integral = 0, pdf_total = 0;
    for (int i = 0; i < nt; i++) {
      double mu = (i + 0.5) / nt;
      for (int j = 0; j < np; j++) {
        double phi = 2 * PI * (j + 0.5) / np;
        double s = sqrt(1 - mu * mu);
        bbc_vec3 wi = v3(s * cos(phi), mu, s * sin(phi));
        double f[3];
        bbc_bsdf_eval(&b, n, wo, wi, f);
        integral += f[0] * mu;
        pdf_total += bbc_bsdf_pdf(&b, n, wo, wi);
      }
    }
    integral *= 2 * PI / ((double)nt * np);
    pdf_total *= 2 * PI / ((double)nt * np);
    /* Stratified samples of the sampler. */
    const int ns = 400;
    double mean = 0;
    for (int i = 0; i < ns; i++)
      for (int j = 0; j < ns; j++)
        for (int lobe = 0; lobe < 2; lobe++) {
          double u[2] = {(i + 0.5) / ns, (j + 0.5) / ns};
          /* Both lobes with their probabilities: u_lobe below or above the split. */
          double ps = 0.5 * (1 + b.metallic);
          double w[3];
          bbc_vec3 wi;
          bbc_bsdf_sample(&b, n, wo, lobe ? (ps + 1) / 2 : ps / 2, u, &wi, w);
          mean += (lobe ? 1 - ps : ps) * w[0];
        }
    mean /= (double)ns * ns;
    fprintf(stderr, "base %.2f metallic %.2f roughness %.2f: quadrature %.6f, sampled %.6f, "
                    "density total %.6f\n",
            cases[c][0], cases[c][1], cases[c][2], integral, mean, pdf_total);
    CHECK_NEAR(mean, integral, 2e-3 * integral);
    CHECK(pdf_total <= 1 + 1e-3);
    CHECK(integral <= 1.0); /* no energy gain */
  }
}

/* ------------------------------------------------------------------ end to end */

static int setup(fixture *f, const char *path) {
  return fixture_setup(f, path, BBC_CHAIN_BIT(BBC_CHAIN_R), 6, 0);
}

/* The floor's radiance toward the camera from a point source at `position` of
 * intensity I: f(wo, wi) I cos / r^2, wo toward the camera's eye. `lambert` replaces
 * the BRDF with base / pi (the control). */
typedef struct glossy_light {
  const bbc_bsdf *bsdf;
  bbc_vec3 position, eye;
  double intensity;
  int channel, lambert;
} glossy_light;

static double glossy_value(const void *user, bbc_vec3 p) {
  const glossy_light *g = user;
  bbc_vec3 l = v3_sub(g->position, p);
  double r2 = v3_dot(l, l);
  bbc_bsdf b = *g->bsdf;
  b.glossy = !g->lambert;
  double f[3];
  bbc_bsdf_eval(&b, v3(0, 1, 0), v3_normalize(v3_sub(g->eye, p)), v3_normalize(l), f);
  return f[g->channel] * g->intensity * (l.y / sqrt(r2)) / r2;
}

static int count_off(const fixture *f, const bbc_image *image, const glossy_light *model,
                     const double box[4], int *checked) {
  int bad = 0;
  *checked = 0;
  for (uint32_t y = 0; y < image->height; y++)
    for (uint32_t x = 0; x < image->width; x++) {
      double lo, hi;
      if (!floor_footprint_range(f->scene, f->accel, image->width, image->height, x, y, box,
                                 glossy_value, model, &lo, &hi))
        continue;
      (*checked)++;
      double got = image->rgb[3 * ((size_t)y * image->width + x) + (size_t)model->channel];
      bad += !(got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4));
    }
  return bad;
}

/* The flat mirror over a glossy floor (bbc-scenegen --roughness 0.3 --metallic 0.5):
 * the caustic-only image (enumeration) is the mirrored light times the BRDF for the
 * mirrored direction, and the path tracer's direct light the light times the BRDF for
 * its own, within each pixel's footprint range in every channel. With the Lambertian
 * BRDF instead, most pixels fail. */
TEST(glossy_floor_under_flat_mirror_is_exact) {
  fixture f;
  REQUIRE(setup(&f, TEST_SCENE("flat-mirror-glossy.gltf")));
  uint32_t floor_triangle = UINT32_MAX;
  for (uint32_t t = 0; t < f.scene->triangle_count; t++)
    if (f.scene->meshes[f.scene->triangle_mesh[t]].role == BBC_ROLE_RECEIVER) floor_triangle = t;
  REQUIRE(floor_triangle != UINT32_MAX);
  bbc_bsdf bsdf;
  bbc_bsdf_at(f.scene, floor_triangle, 0.3, 0.3, &bsdf);
  REQUIRE(bsdf.glossy);
  CHECK_NEAR(bsdf.metallic, 0.5, 0);
  CHECK_NEAR(bsdf.alpha, 0.09, 1e-7);
  const uint32_t w = 40, h = 30;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_ENUMERATE;
  o.spp = 2;
  o.seed = 9;
  o.components = BBC_COMPONENT_CAUSTICS;
  bbc_image *image = fixture_render(&f, o, w, h, NULL);
  REQUIRE(image);
  const bbc_point_light *light = &f.scene->point_lights[0];
  const double box[4] = {0.05, 3.95, -1.95, 1.95};
  int checked = 0, bad = 0, control = 0, n;
  for (int k = 0; k < 3; k++) {
    glossy_light g = {&bsdf, v3(-light->position.x, light->position.y, light->position.z),
                      f.scene->camera.position, light->intensity[k], k, 0};
    bad += count_off(&f, image, &g, box, &n);
    checked += n;
    g.lambert = 1;
    control += count_off(&f, image, &g, box, &n);
  }
  fprintf(stderr, "caustic: %d pixel channels checked, %d off; Lambertian: %d off\n", checked,
          bad, control);
  CHECK(checked > 900);
  CHECK_INT(bad, 0);
  CHECK(control > checked / 2);

  o.method = BBC_METHOD_PT;
  o.components = BBC_COMPONENT_DIRECT;
  bbc_image_free(image);
  image = fixture_render(&f, o, w, h, NULL);
  REQUIRE(image);
  checked = bad = 0;
  for (int k = 0; k < 3; k++) {
    glossy_light g = {&bsdf, light->position, f.scene->camera.position, light->intensity[k], k, 0};
    bad += count_off(&f, image, &g, box, &n);
    checked += n;
  }
  fprintf(stderr, "direct: %d pixel channels checked, %d off\n", checked, bad);
  CHECK(checked > 900);
  CHECK_INT(bad, 0);
  bbc_image_free(image);
  teardown(&f);
}

/* The radiance toward eye from floor point p through the BRDF, from the scene's
 * emitters mirrored in the plane x = 0 (where the segment crosses the mirror
 * [y0, y1] x [z0, z1]), by midpoint quadrature on a k x k grid of each emitting triangle
 * (the square's halves). */
static double mirrored_area_radiance(const bbc_scene *s, const bbc_bsdf *b, bbc_vec3 p,
                                     bbc_vec3 eye, const double mirror[4], int channel) {
  const int k = 10;
  double sum = 0;
  bbc_vec3 wo = v3_normalize(v3_sub(eye, p));
  for (uint32_t i = 0; i < s->emitter_count; i++) {
    const uint32_t *idx = s->indices + 3 * (size_t)s->emitters[i];
    bbc_vec3 q[3];
    for (int j = 0; j < 3; j++) {
      q[j] = v3_load(s->positions + 3 * (size_t)idx[j]);
      q[j].x = -q[j].x;
    }
    bbc_vec3 e1 = v3_sub(q[1], q[0]), e2 = v3_sub(q[2], q[0]);
    double area = 0.5 * v3_length(v3_cross(e1, e2));
    double le = bbc_scene_triangle_material(s, s->emitters[i])->emission[channel];
    for (int a = 0; a < k; a++)
      for (int c = 0; a + c < k; c++)
        for (int flip = 0; flip < 2; flip++) {
          if (flip && a + c + 1 >= k) continue;
          double u = (a + (flip ? 2.0 : 1.0) / 3.0) / k, v = (c + (flip ? 2.0 : 1.0) / 3.0) / k;
          bbc_vec3 x = v3_add(q[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
          bbc_vec3 d = v3_sub(x, p);
          double r2 = v3_dot(d, d), r = sqrt(r2);
          double cos_p = d.y / r, cos_l = d.y / r; /* the lamp faces down */
          if (cos_p <= 0) continue;
          double t = -p.x / d.x;
          bbc_vec3 m = v3_madd(p, d, t);
          if (!(t > 0 && t < 1 && m.y > mirror[0] && m.y < mirror[1] && m.z > mirror[2] &&
                m.z < mirror[3]))
            continue;
          double f[3];
          bbc_bsdf_eval(b, v3(0, 1, 0), wo, v3_scale(d, 1 / r), f);
          sum += f[channel] * le * cos_p * cos_l / r2 * area / (k * k);
        }
  }
  return sum;
}

/* Where path tracing sees the caustic (an area light): on the glossy floor under the flat
 * mirror with the area light (--area-light 0.25), the path tracer's light reflected by
 * the mirror (paths of 3 segments, the indirect component: camera, floor, mirror, lamp,
 * found by sampling the BRDF) converges to the quadrature of the BRDF over the mirrored
 * lamp. The z-score of the floor's total stays small; against the Lambertian BRDF it is
 * large. */
TEST(glossy_path_tracing_sees_the_mirrored_area_light) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("flat-mirror-glossy-area.gltf"), NULL) == BBC_OK);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  double mirror[4] = {1e30, -1e30, 1e30, -1e30};
  uint32_t floor_triangle = 0;
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    const bbc_material *m = bbc_scene_triangle_material(s, t);
    if (m->type == BBC_MATERIAL_DIFFUSE && s->meshes[s->triangle_mesh[t]].role == BBC_ROLE_RECEIVER)
      floor_triangle = t;
    if (m->type != BBC_MATERIAL_MIRROR) continue;
    for (int j = 0; j < 3; j++) {
      bbc_vec3 q = v3_load(s->positions + 3 * (size_t)s->indices[3 * t + j]);
      mirror[0] = fmin(mirror[0], q.y), mirror[1] = fmax(mirror[1], q.y);
      mirror[2] = fmin(mirror[2], q.z), mirror[3] = fmax(mirror[3], q.z);
    }
  }
  bbc_bsdf bsdf;
  bbc_bsdf_at(s, floor_triangle, 0.3, 0.3, &bsdf);
  REQUIRE(bsdf.glossy);
  const uint32_t w = 48, h = 36;
  bbc_image *image = NULL;
  REQUIRE(bbc_image_create(&image, w, h) == BBC_OK);
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.spp = (uint32_t)harness_scale(2048, 16384);
  o.max_depth = 3;
  o.seed = 4;
  o.components = BBC_COMPONENT_INDIRECT;
  REQUIRE(bbc_render(s, accel, &o, image, NULL) == BBC_OK);
  const double box[4] = {0.05, 3.95, -1.95, 1.95};
  double sum_residual = 0, sum_sq = 0, sum_analytic = 0, sum_lambert = 0;
  int pixels = 0;
  bbc_bsdf lambert = bsdf;
  lambert.glossy = 0;
  for (uint32_t y = 0; y < h; y++)
    for (uint32_t x = 0; x < w; x++) {
      const int n = 3;
      double analytic = 0, lambert_analytic = 0;
      int inside = 1;
      for (int j = 0; j < n && inside; j++)
        for (int i = 0; i < n && inside; i++) {
          bbc_vec3 org, d;
          bbc_camera_ray(&s->camera, w, h, x + (i + 0.5) / n, y + (j + 0.5) / n, &org, &d);
          double t = -org.y / d.y;
          bbc_vec3 p = v3_madd(org, d, t);
          if (!(d.y < 0 && p.x > box[0] && p.x < box[1] && p.z > box[2] && p.z < box[3]) ||
              bbc_accel_occluded(accel, org, d, 0, t * (1 - 1e-6))) {
            inside = 0;
            break;
          }
          analytic += mirrored_area_radiance(s, &bsdf, p, s->camera.position, mirror, 0) / (n * n);
          lambert_analytic +=
              mirrored_area_radiance(s, &lambert, p, s->camera.position, mirror, 0) / (n * n);
        }
      if (!inside) continue;
      pixels++;
      double residual = image->rgb[3 * ((size_t)y * w + x)] - analytic;
      sum_residual += residual;
      sum_sq += residual * residual;
      sum_analytic += analytic;
      sum_lambert += lambert_analytic;
    }
  double z = sum_residual / sqrt(sum_sq), sigma = sqrt(sum_sq) / sum_analytic;
  /* The control: the Lambertian BRDF's total, in the same noise units. */
  double z_lambert = (sum_residual + sum_analytic - sum_lambert) / sqrt(sum_sq);
  fprintf(stderr, "against the Lambertian BRDF: z = %.1f\n", z_lambert);
  fprintf(stderr, "%d floor pixels, %u spp: relative error of the total %.5f +- %.5f, z = %.2f\n",
          pixels, o.spp, sum_residual / sum_analytic, sigma, z);
  CHECK(pixels > 500);
  CHECK(sum_analytic > 0);
  CHECK(fabs(z) < 4.5);
  CHECK(sigma < 0.02); /* an error of 9 % would show at 4.5 sigma */
  CHECK(fabs(z_lambert) > 10);
  bbc_image_free(image);
  bbc_accel_free(accel);
  bbc_scene_free(s);
}
