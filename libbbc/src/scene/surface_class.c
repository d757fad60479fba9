/* Surface classes: whether a glTF metallic-roughness material, with its transmission,
 * is a mirror, a dielectric or a receiver, from its factors alone or from the texels of
 * its textures that a triangle covers (docs/materials.md). */
#include "surface_class_internal.h"

#include <math.h>

/* The first texel index a coordinate range can read and how many (at most n: then every
 * texel), texel i covering [i, i + 1) in texel units. Bilinear filtering blends the two
 * texels whose centres are nearest, so a point x reads texels floor(x - 1/2) and the
 * next; nearest filtering reads floor(x), which is one of them. */
static void texel_span(double lo, double hi, int64_t n, int64_t *first, int64_t *count) {
  /* Beyond 2^52 texels a coordinate has no fraction left (and would not fit the index). */
  if (!(fabs(lo) < 0x1p52) || !(fabs(hi) < 0x1p52) || hi - lo >= (double)n) {
    *first = 0;
    *count = n;
    return;
  }
  *first = (int64_t)floor(lo - 0.5);
  int64_t last = (int64_t)floor(hi - 0.5) + 1;
  *count = last - *first + 1 < n ? last - *first + 1 : n;
}

static int64_t wrap_index(int64_t i, int64_t n, bbc_wrap wrap) {
  if (wrap == BBC_WRAP_CLAMP) return i < 0 ? 0 : i >= n ? n - 1 : i;
  if (wrap == BBC_WRAP_REPEAT) return ((i % n) + n) % n;
  int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
  return m < n ? m : 2 * n - 1 - m;
}

void bbc__texture_range(const bbc_texture *tex, const double x[6], const float *uv[3],
                        int channel, double *lo, double *hi) {
  double s_lo = INFINITY, s_hi = -INFINITY, t_lo = INFINITY, t_hi = -INFINITY;
  for (int k = 0; k < 3; k++) {
    double s = x[0] * uv[k][0] + x[1] * uv[k][1] + x[2];
    double t = x[3] * uv[k][0] + x[4] * uv[k][1] + x[5];
    s_lo = fmin(s_lo, s), s_hi = fmax(s_hi, s);
    t_lo = fmin(t_lo, t), t_hi = fmax(t_hi, t);
  }
  /* Clamping reads the edge texels past [0, 1]: the range's clamped image is what counts;
   * the mirrored and repeated ones are wrapped texel by texel below. A non-finite
   * coordinate reads as 0 (texture.h): every texel covers that too. */
  const int64_t w = tex->width, h = tex->height;
  int64_t i0, ni, j0, nj;
  texel_span(s_lo * (double)w, s_hi * (double)w, w, &i0, &ni);
  texel_span(t_lo * (double)h, t_hi * (double)h, h, &j0, &nj);
  *lo = INFINITY;
  *hi = -INFINITY;
  for (int64_t j = 0; j < nj; j++) {
    const int64_t y = nj == h ? j : wrap_index(j0 + j, h, tex->wrap_t);
    for (int64_t i = 0; i < ni; i++) {
      const int64_t xi = ni == w ? i : wrap_index(i0 + i, w, tex->wrap_s);
      const double v = tex->rgb[3 * ((size_t)y * (size_t)w + (size_t)xi) + (size_t)channel];
      *lo = fmin(*lo, v);
      *hi = fmax(*hi, v);
    }
  }
}

bbc_material_type bbc__class_of_ranges(const double metallic[2], const double roughness[2],
                                       const double transmission[2], int *mixed) {
  const double tol = BBC_IDEAL_TOLERANCE;
  *mixed = 0;
  if (roughness[1] < tol && metallic[0] >= 1.0 - tol) return BBC_MATERIAL_MIRROR;
  if (roughness[1] < tol && metallic[1] <= tol && transmission[0] >= 1.0 - tol)
    return BBC_MATERIAL_DIELECTRIC;
  /* Not every texel is ideal: a receiver, with some texels of an ideal class if each
   * condition of one holds for some texel (counted as mixed, conservatively). */
  *mixed = roughness[0] < tol &&
           (metallic[1] >= 1.0 - tol || (metallic[0] <= tol && transmission[1] >= 1.0 - tol));
  return BBC_MATERIAL_DIFFUSE;
}
