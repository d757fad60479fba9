/* The receivers' BRDF (bbc/bsdf.h): Lambertian or glTF's metallic-roughness model. */
#include "bbc/bsdf.h"

#include <math.h>

#include "bbc/texture.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

void bbc_bsdf_at(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                 bbc_bsdf *out) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  bbc_scene_base_color(scene, triangle, b1, b2, out->base);
  double metallic, r;
  bbc_scene_metallic_roughness(scene, triangle, b1, b2, &metallic, &r);
  /* Lambertian where glTF's metallic 0 and roughness 1 hold at the point. */
  out->glossy = m->glossy && !(metallic == 0.0 && r == 1.0);
  out->metallic = metallic;
  r = r < BBC_BSDF_MIN_ROUGHNESS ? BBC_BSDF_MIN_ROUGHNESS : r;
  out->alpha = r * r;
}

static double ggx_d(double a2, double nh) {
  double t = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (PI * t * t);
}

static double smith_vis(double a2, double nl, double nv) {
  double gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
  double gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
  return 0.5 / (gv + gl);
}

void bbc_bsdf_eval(const bbc_bsdf *b, bbc_vec3 n, bbc_vec3 wo, bbc_vec3 wi, double f[3]) {
  f[0] = f[1] = f[2] = 0.0;
  double nv = v3_dot(n, wo), nl = v3_dot(n, wi);
  if (!(nv > 0.0) || !(nl > 0.0)) return;
  if (!b->glossy) {
    for (int k = 0; k < 3; k++) f[k] = b->base[k] / PI;
    return;
  }
  bbc_vec3 h = v3_normalize(v3_add(wo, wi));
  double nh = fmax(0.0, v3_dot(n, h)), vh = fabs(v3_dot(wo, h));
  double a2 = b->alpha * b->alpha;
  double spec = ggx_d(a2, nh) * smith_vis(a2, nl, nv);
  double s = 1.0 - vh, s5 = s * s * s * s * s;
  double fd = 0.04 + 0.96 * s5;
  for (int k = 0; k < 3; k++) {
    double fm = b->base[k] + (1.0 - b->base[k]) * s5;
    f[k] = (1.0 - b->metallic) * ((1.0 - fd) * b->base[k] / PI + fd * spec) +
           b->metallic * fm * spec;
  }
}

static double spec_probability(const bbc_bsdf *b) {
  return b->glossy ? 0.5 * (1.0 + b->metallic) : 0.0;
}

double bbc_bsdf_pdf(const bbc_bsdf *b, bbc_vec3 n, bbc_vec3 wo, bbc_vec3 wi) {
  double nl = v3_dot(n, wi);
  if (!(nl > 0.0) || !(v3_dot(n, wo) > 0.0)) return 0.0;
  double ps = spec_probability(b);
  double pdf = (1.0 - ps) * nl / PI;
  if (ps > 0.0) {
    bbc_vec3 h = v3_normalize(v3_add(wo, wi));
    double nh = fmax(0.0, v3_dot(n, h)), vh = fabs(v3_dot(wo, h));
    if (vh > 0.0) pdf += ps * ggx_d(b->alpha * b->alpha, nh) * nh / (4.0 * vh);
  }
  return pdf;
}

void bbc_bsdf_sample(const bbc_bsdf *b, bbc_vec3 n, bbc_vec3 wo, double u_lobe, const double u[2],
                     bbc_vec3 *wi, double weight[3]) {
  weight[0] = weight[1] = weight[2] = 0.0;
  bbc_vec3 t, bt;
  v3_basis(n, &t, &bt);
  double phi = 2.0 * PI * u[1];
  if (u_lobe < spec_probability(b)) {
    /* A GGX half vector: tan^2(theta) = a^2 u / (1 - u), density D(h) n.h. */
    double a2 = b->alpha * b->alpha;
    double cos2 = (1.0 - u[0]) / (1.0 + (a2 - 1.0) * u[0]);
    double ct = sqrt(fmax(0.0, cos2)), st = sqrt(fmax(0.0, 1.0 - cos2));
    bbc_vec3 h = v3_add(v3_add(v3_scale(t, st * cos(phi)), v3_scale(bt, st * sin(phi))),
                        v3_scale(n, ct));
    *wi = v3_sub(v3_scale(h, 2.0 * v3_dot(wo, h)), wo);
  } else {
    double r = sqrt(u[0]);
    double z = sqrt(fmax(0.0, 1.0 - u[0]));
    *wi = v3_add(v3_add(v3_scale(t, r * cos(phi)), v3_scale(bt, r * sin(phi))), v3_scale(n, z));
  }
  double nl = v3_dot(n, *wi);
  if (!(nl > 0.0)) return;
  if (!b->glossy) {
    /* The cosine's density cancels cos / pi: the weight is the base colour. */
    for (int k = 0; k < 3; k++) weight[k] = b->base[k];
    return;
  }
  double pdf = bbc_bsdf_pdf(b, n, wo, *wi);
  if (!(pdf > 0.0)) return;
  double f[3];
  bbc_bsdf_eval(b, n, wo, *wi, f);
  for (int k = 0; k < 3; k++) weight[k] = f[k] * nl / pdf;
}
