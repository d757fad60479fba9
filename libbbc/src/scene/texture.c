/* Base colour textures (bbc/texture.h): wrap modes, nearest and bilinear lookups, the
 * albedo of a surface point, and its alpha and coverage. */
#include "bbc/texture.h"

#include <math.h>

double bbc_srgb_to_linear(double c) {
  return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* A coordinate in texture units [0, 1) (repeat), [0, 2) (mirror) or [0, 1] (clamp). */
static double reduce(double x, bbc_wrap wrap) {
  if (!isfinite(x)) return 0.0;
  if (wrap == BBC_WRAP_CLAMP) return x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
  double period = wrap == BBC_WRAP_MIRROR ? 2.0 : 1.0;
  double r = x - period * floor(x / period);
  return r >= period || r < 0.0 ? 0.0 : r; /* rounding of floor near a period's end */
}

/* Texel index i (any integer in [-1, 2n]) wrapped into [0, n). */
static int64_t wrap_index(int64_t i, int64_t n, bbc_wrap wrap) {
  if (wrap == BBC_WRAP_CLAMP) return i < 0 ? 0 : i >= n ? n - 1 : i;
  if (wrap == BBC_WRAP_REPEAT) return ((i % n) + n) % n;
  int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
  return m < n ? m : 2 * n - 1 - m;
}

/* Adds w times texel (x, y) of `channels`-float texels to out[0 .. channels). */
static void texel(const bbc_texture *tex, const float *data, int channels, int64_t x, int64_t y,
                  double w, double *out) {
  const float *p = data + (size_t)channels * ((size_t)y * tex->width + (size_t)x);
  for (int k = 0; k < channels; k++) out[k] += w * p[k];
}

/* The lookup of bbc_texture_lookup over texels of `channels` floats each. */
static void lookup(const bbc_texture *tex, const float *data, int channels, double s, double t,
                   double *out) {
  for (int k = 0; k < channels; k++) out[k] = 0.0;
  const int64_t w = tex->width, h = tex->height;
  /* In texel units: texel i covers [i, i + 1), its centre is i + 1/2. */
  double x = reduce(s, tex->wrap_s) * (double)w, y = reduce(t, tex->wrap_t) * (double)h;
  if (tex->nearest) {
    int64_t i = (int64_t)floor(x), j = (int64_t)floor(y);
    texel(tex, data, channels, wrap_index(i, w, tex->wrap_s), wrap_index(j, h, tex->wrap_t), 1.0,
          out);
    return;
  }
  x -= 0.5;
  y -= 0.5;
  double fx = floor(x), fy = floor(y);
  double ax = x - fx, ay = y - fy;
  int64_t i = (int64_t)fx, j = (int64_t)fy;
  int64_t i0 = wrap_index(i, w, tex->wrap_s), i1 = wrap_index(i + 1, w, tex->wrap_s);
  int64_t j0 = wrap_index(j, h, tex->wrap_t), j1 = wrap_index(j + 1, h, tex->wrap_t);
  texel(tex, data, channels, i0, j0, (1 - ax) * (1 - ay), out);
  texel(tex, data, channels, i1, j0, ax * (1 - ay), out);
  texel(tex, data, channels, i0, j1, (1 - ax) * ay, out);
  texel(tex, data, channels, i1, j1, ax * ay, out);
}

void bbc_texture_lookup(const bbc_texture *tex, double s, double t, double out[3]) {
  lookup(tex, tex->rgb, 3, s, t, out);
}

double bbc_texture_lookup_alpha(const bbc_texture *tex, double s, double t) {
  if (!tex->alpha) return 1.0;
  double a;
  lookup(tex, tex->alpha, 1, s, t, &a);
  return a;
}

/* The texture coordinates of scene triangle `triangle` at barycentrics b1, b2: its
 * interpolated TEXCOORD_0 through the transform x (a bbc_texture_use's uv_transform). */
static void texture_coords(const bbc_scene *scene, const double x[6], uint32_t triangle,
                           double b1, double b2, double *s, double *t) {
  const uint32_t *idx = scene->indices + 3 * (size_t)triangle;
  const float *uv0 = scene->uvs + 2 * (size_t)idx[0], *uv1 = scene->uvs + 2 * (size_t)idx[1],
              *uv2 = scene->uvs + 2 * (size_t)idx[2];
  double b0 = 1.0 - b1 - b2;
  double u = b0 * uv0[0] + b1 * uv1[0] + b2 * uv2[0];
  double v = b0 * uv0[1] + b1 * uv1[1] + b2 * uv2[1];
  *s = x[0] * u + x[1] * v + x[2];
  *t = x[3] * u + x[4] * v + x[5];
}

void bbc_scene_base_color(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                          double out[3]) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  for (int k = 0; k < 3; k++) out[k] = m->base_color[k];
  if (m->base_color_texture == 0) return;
  double s, t, c[3];
  texture_coords(scene, m->uv_transform, triangle, b1, b2, &s, &t);
  bbc_texture_lookup(&scene->textures[m->base_color_texture - 1], s, t, c);
  for (int k = 0; k < 3; k++) out[k] *= c[k];
}

void bbc_scene_metallic_roughness(const bbc_scene *scene, uint32_t triangle, double b1,
                                  double b2, double *metallic, double *roughness) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  *metallic = m->metallic;
  *roughness = m->roughness;
  if (m->metallic_roughness.texture == 0) return;
  double s, t, c[3];
  texture_coords(scene, m->metallic_roughness.uv_transform, triangle, b1, b2, &s, &t);
  bbc_texture_lookup(&scene->textures[m->metallic_roughness.texture - 1], s, t, c);
  *roughness *= c[1];
  *metallic *= c[2];
}

void bbc_scene_emission(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                        double out[3]) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  for (int k = 0; k < 3; k++) out[k] = m->emission[k];
  if (m->emissive.texture == 0) return;
  double s, t, c[3];
  texture_coords(scene, m->emissive.uv_transform, triangle, b1, b2, &s, &t);
  bbc_texture_lookup(&scene->textures[m->emissive.texture - 1], s, t, c);
  for (int k = 0; k < 3; k++) out[k] *= c[k];
}

double bbc_scene_alpha(const bbc_scene *scene, uint32_t triangle, double b1, double b2) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  if (m->base_color_texture == 0 || !scene->textures[m->base_color_texture - 1].alpha)
    return m->alpha;
  double s, t;
  texture_coords(scene, m->uv_transform, triangle, b1, b2, &s, &t);
  return m->alpha * bbc_texture_lookup_alpha(&scene->textures[m->base_color_texture - 1], s, t);
}

double bbc_scene_coverage(const bbc_scene *scene, uint32_t triangle, double b1, double b2) {
  const bbc_material *m = bbc_scene_triangle_material(scene, triangle);
  if (m->alpha_mode == BBC_ALPHA_OPAQUE) return 1.0;
  double a = bbc_scene_alpha(scene, triangle, b1, b2);
  if (m->alpha_mode == BBC_ALPHA_MASK) return a >= m->alpha_cutoff ? 1.0 : 0.0;
  return a >= 1.0 ? 1.0 : a > 0.0 ? a : 0.0; /* NaN reads as 0 */
}

int bbc_material_partial(const bbc_scene *scene, const bbc_material *m) {
  if (m->alpha_mode == BBC_ALPHA_OPAQUE) return 0;
  if (m->base_color_texture && scene->textures[m->base_color_texture - 1].alpha) return 1;
  return m->alpha_mode == BBC_ALPHA_MASK ? !(m->alpha >= m->alpha_cutoff) : !(m->alpha >= 1.0f);
}
