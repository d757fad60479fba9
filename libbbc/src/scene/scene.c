/* Scene loading: turns the C view of a glTF file (gltf_shim.cpp) into a bbc_scene of
 * world-space triangles with bbc's materials, roles, lights and camera.
 *
 * The shim guarantees that every count, index and pointer it returns is consistent;
 * this file judges whether the content is something bbc can render (triangles only,
 * finite positions, a light, a camera) and reports the first problem it finds. */
#include "bbc/scene.h"
#include "bbc/bsdf.h"
#include "bbc/texture.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_internal.h"
#include "gltf_shim_internal.h"
#include "media_internal.h"
#include "scene_internal.h"
#include "surface_class_internal.h"

#define PI 3.14159265358979323846

/* Film sizes outside this range are certainly typing mistakes, and staying below it
 * keeps width * height far from overflowing anything downstream. */
#define MAX_FILM_SIZE 65536

typedef struct loader {
  const char *path; /* what messages call the file */
  bbc_message_fn error_fn, warning_fn;
  void *user;
  bbc_light_units light_units; /* the caller's override, or BBC_LIGHT_UNITS_FILE */
} loader;

static void send(bbc_message_fn fn, void *user, bbc_result code, const char *path, const char *fmt,
                 va_list ap) {
  char line[1024];
  int n = snprintf(line, sizeof line, "%s: ", path);
  if (n < 0 || (size_t)n >= sizeof line) n = 0;
  vsnprintf(line + n, sizeof line - (size_t)n, fmt, ap);
  /* Names come from the file and may hold anything; the message must stay one line. */
  for (char *c = line; *c; c++)
    if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
  fn(user, code, line);
}

/* Reports a failure through error_fn and returns its code. */
static bbc_result fail(const loader *ld, bbc_result code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static bbc_result fail(const loader *ld, bbc_result code, const char *fmt, ...) {
  if (ld->error_fn) {
    va_list ap;
    va_start(ap, fmt);
    send(ld->error_fn, ld->user, code, ld->path, fmt, ap);
    va_end(ap);
  }
  return code;
}

static void warn(const loader *ld, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void warn(const loader *ld, const char *fmt, ...) {
  if (ld->warning_fn) {
    va_list ap;
    va_start(ap, fmt);
    send(ld->warning_fn, ld->user, BBC_OK, ld->path, fmt, ap);
    va_end(ap);
  }
}

/* Copies a name into a fixed 64-byte field, cutting it on a UTF-8 character boundary
 * when it is too long. */
static void copy_name(char dst[64], const char *src) {
  size_t n = strlen(src);
  if (n > 63) {
    n = 63;
    while (n > 0 && ((unsigned char)src[n] & 0xC0) == 0x80) n--;
  }
  memcpy(dst, src, n);
  dst[n] = '\0';
}

/* Zeroed memory for count elements; never NULL for count 0, so a NULL result always
 * means out of memory. */
static void *alloc(size_t count, size_t size) {
  return calloc(count ? count : 1, size);
}

static int finite3(const double v[3]) {
  return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static double dot3(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double c[3]) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Normalises v in place; returns 0 (leaving v unchanged) when it has no direction. */
static int normalize3(double v[3]) {
  double len = sqrt(dot3(v, v));
  if (!(len > 0.0) || !isfinite(len)) return 0;
  v[0] /= len;
  v[1] /= len;
  v[2] /= len;
  return 1;
}

/* An affine transform split out of a column-major glTF matrix: p' = a p + t, and the
 * normal matrix (a^-1)^T, computed as the cofactor matrix divided by the determinant. */
typedef struct xform {
  double a[3][3], t[3];
  double normal[3][3];
  double det;
} xform;

static int make_xform(const double m[16], xform *x) {
  for (int r = 0; r < 3; r++) {
    for (int c = 0; c < 3; c++) x->a[r][c] = m[4 * c + r];
    x->t[r] = m[12 + r];
  }
  double(*a)[3] = x->a;
  double cof[3][3];
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) {
      int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
      cof[r][c] = a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1];
    }
  x->det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
  if (!(x->det != 0.0) || !isfinite(x->det) || !finite3(x->t)) return 0;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) x->normal[r][c] = cof[r][c] / x->det;
  return 1;
}

static void apply(const double m[3][3], const double offset[3], const float in[3], double out[3]) {
  for (int r = 0; r < 3; r++)
    out[r] = m[r][0] * in[0] + m[r][1] * in[1] + m[r][2] * in[2] + (offset ? offset[r] : 0.0);
}

/* Whether a double survives conversion to a finite float (false for NaN); tested
 * before converting, because converting an out-of-range value is undefined in C. */
static int fits_float(double v) {
  return fabs(v) <= FLT_MAX;
}

static int finite_float3(const double v[3]) {
  return fits_float(v[0]) && fits_float(v[1]) && fits_float(v[2]);
}

static const char *material_label(const bbc__gltf_material *m, uint32_t index, char *buf,
                                  size_t size) {
  /* With its index, as the shim names it: files reuse names (three materials of one
   * sample asset are all "BlueTransWithMask"). */
  if (m->name[0])
    snprintf(buf, size, "material %u (\"%s\")", index, m->name);
  else
    snprintf(buf, size, "material %u", index);
  return buf;
}

static const char *class_name(bbc_material_type type) {
  return type == BBC_MATERIAL_MIRROR       ? "an ideal mirror"
         : type == BBC_MATERIAL_DIELECTRIC ? "a smooth dielectric"
                                           : "a receiver";
}

/* The alpha mode, cutoff and factor alpha of a material (bbc_alpha_mode). BLEND is read
 * as coverage (docs/materials.md); the warning says so once per material, because files
 * often use it to imitate glass, which it does not make. */
static bbc_result classify_alpha(const loader *ld, const bbc__gltf_material *g, const char *label,
                                 bbc_material *m) {
  m->alpha_mode = g->alpha_mode;
  m->alpha_cutoff = fits_float(g->alpha_cutoff) ? (float)g->alpha_cutoff : FLT_MAX;
  if (!fits_float(g->base_color[3]))
    return fail(ld, BBC_ERR_SCENE, "%s: baseColorFactor's alpha must be finite", label);
  m->alpha = (float)g->base_color[3];
  if (g->alpha_mode == BBC_ALPHA_BLEND)
    warn(ld,
         "%s: alphaMode BLEND is rendered as coverage: a ray meets the surface with "
         "probability alpha (baseColorFactor alpha %g%s) and passes straight through "
         "otherwise; it does not refract (smooth glass is KHR_materials_transmission)",
         label, g->base_color[3], g->base_color_texture.texture >= 0 ? " times the texture's" : "");
  return BBC_OK;
}

/* A dielectric's Beer-Lambert coefficient from KHR_materials_volume: -ln(c) / d per
 * channel (bbc_material.absorption), checked: the colour within [0, 1] and the distance
 * positive (an infinite one, glTF's default, absorbs nothing). A channel of colour 0
 * would be an infinite coefficient; it becomes FLT_MAX, so that exp(-absorption x) is 0
 * for any x > 0 and a length of 0 never meets 0 x inf. Also warns of a base colour above
 * 1, which tints transmission by 1 at most (the bounds hold for factors up to 1). */
static bbc_result volume_absorption(const loader *ld, const bbc__gltf_material *g,
                                    const char *label, bbc_material *m) {
  const double *c = g->attenuation_color, d = g->attenuation_distance;
  for (int k = 0; k < 3; k++)
    if (!(c[k] >= 0.0 && c[k] <= 1.0))
      return fail(ld, BBC_ERR_SCENE, "%s: attenuationColor (%g, %g, %g) must lie in [0, 1]", label,
                  c[0], c[1], c[2]);
  if (!(d > 0.0))
    return fail(ld, BBC_ERR_SCENE, "%s: attenuationDistance %g is not a positive number", label, d);
  int opaque = 0;
  for (int k = 0; k < 3; k++) {
    double s = isinf(d) ? 0.0 : c[k] == 0.0 ? INFINITY : -log(c[k]) / d;
    opaque |= s > FLT_MAX;
    m->absorption[k] = s > FLT_MAX ? FLT_MAX : s > 0.0 ? (float)s : 0.0f;
  }
  if (opaque)
    warn(ld,
         "%s: attenuationColor (%g, %g, %g) over distance %g absorbs some channel entirely "
         "(any path inside it loses that channel)",
         label, c[0], c[1], c[2], d);
  if (m->base_color[0] > 1.0f || m->base_color[1] > 1.0f || m->base_color[2] > 1.0f)
    warn(ld, "%s: baseColorFactor above 1 tints transmitted light by 1 at most", label);
  return BBC_OK;
}

/* The classification is exact on purpose: bbc renders only ideal surfaces, and a
 * slightly rough mirror is not a mirror. */

/* The class from the factors (surface_class_internal.h): values within
 * BBC_IDEAL_TOLERANCE of ideal are rendered ideal, with a note when not exactly so. A
 * material with a metallic-roughness or transmission texture is classified again per
 * triangle (classify_triangles); its factors are kept for that and for the glossy
 * model. */
static bbc_result classify(const loader *ld, const bbc__gltf_material *g, uint32_t index,
                           bbc_material *m) {
  char label[128];
  material_label(g, index, label, sizeof label);
  if (g->name[0])
    copy_name(m->name, g->name);
  else
    snprintf(m->name, sizeof m->name, "material %u", index);
  m->source = (int32_t)index;

  double emission[3];
  for (int k = 0; k < 3; k++) {
    if (!fits_float(g->base_color[k]) || g->base_color[k] < 0.0)
      return fail(ld, BBC_ERR_SCENE, "%s: baseColorFactor must be finite and non-negative", label);
    emission[k] = g->emissive[k] * g->emissive_strength;
    if (!fits_float(emission[k]) || emission[k] < 0.0)
      return fail(ld, BBC_ERR_SCENE,
                  "%s: emissiveFactor x emissiveStrength must be finite and non-negative", label);
    m->base_color[k] = (float)g->base_color[k];
    m->emission[k] = (float)emission[k];
  }
  m->ior = 1.5f;
  m->uv_transform[0] = m->uv_transform[4] = 1.0;
  m->metallic_roughness.uv_transform[0] = m->metallic_roughness.uv_transform[4] = 1.0;
  m->transmission.uv_transform[0] = m->transmission.uv_transform[4] = 1.0;
  m->emissive.uv_transform[0] = m->emissive.uv_transform[4] = 1.0;
  if (!(g->metallic >= 0.0 && g->metallic <= 1.0 && g->roughness >= 0.0 && g->roughness <= 1.0 &&
        g->transmission >= 0.0 && g->transmission <= 1.0))
    return fail(ld, BBC_ERR_SCENE,
                "%s: metallic %g, roughness %g and transmission %g must lie in [0, 1]", label,
                g->metallic, g->roughness, g->transmission);
  m->metallic = (float)g->metallic;
  m->roughness = (float)g->roughness;
  bbc_result ar = classify_alpha(ld, g, label, m);
  if (ar != BBC_OK) return ar;

  const double mr[2] = {g->metallic, g->metallic}, rr[2] = {g->roughness, g->roughness},
               tr[2] = {g->transmission, g->transmission};
  int mixed;
  m->type = bbc__class_of_ranges(mr, rr, tr, &mixed);
  if (m->type == BBC_MATERIAL_DIELECTRIC) {
    /* Without KHR_materials_volume (thickness 0) glTF means a thin wall; Blender's
     * exporter writes glass and water that way. bbc renders it as a volume all the same
     * and says so per mesh (volume_warnings). */
    if (!fits_float(g->ior) || !(g->ior > 0.0))
      return fail(ld, BBC_ERR_SCENE, "%s: ior %g is not a positive number", label, g->ior);
    m->ior = (float)g->ior;
    bbc_result r = volume_absorption(ld, g, label, m);
    if (r != BBC_OK) return r;
  }
  if (m->type != BBC_MATERIAL_DIFFUSE) {
    int exact = g->roughness == 0.0 &&
                (m->type == BBC_MATERIAL_MIRROR ? g->metallic == 1.0
                                                : g->metallic == 0.0 && g->transmission == 1.0);
    if (!exact)
      warn(ld,
           "%s (metallic %g, roughness %g, transmission %g) is rendered as %s (within %g of "
           "ideal)",
           label, g->metallic, g->roughness, g->transmission, class_name(m->type),
           BBC_IDEAL_TOLERANCE);
  } else if (g->transmission <= BBC_IDEAL_TOLERANCE) {
    /* Lambertian for glTF's metallic 0 with roughness 1; otherwise a glossy receiver,
     * glTF's metallic-roughness BRDF (bsdf.h). */
    m->glossy = !(g->metallic == 0.0 && g->roughness == 1.0);
    if (m->glossy && g->roughness < BBC_BSDF_MIN_ROUGHNESS) {
      warn(ld,
           "%s (metallic %g, roughness %g) is a glossy receiver; roughness below %g is "
           "rendered as %g (the caustic estimator has no specular receivers)",
           label, g->metallic, g->roughness, BBC_BSDF_MIN_ROUGHNESS, BBC_BSDF_MIN_ROUGHNESS);
      m->roughness = (float)BBC_BSDF_MIN_ROUGHNESS;
    }
  } else if (g->metallic_roughness_texture.texture < 0 && g->transmission_texture.texture < 0) {
    m->metallic = m->roughness = 0.0f;
    warn(ld,
         "%s (metallic %g, roughness %g, transmission %g, thickness %g) is neither diffuse, "
         "an ideal mirror nor a smooth dielectric; it is treated as diffuse",
         label, g->metallic, g->roughness, g->transmission, g->thickness);
  }
  return BBC_OK;
}

/* ------------------------------------------------------------------ textures */

static bbc_result wrap_mode(const loader *ld, const char *label, const char *key, int value,
                            bbc_wrap *out) {
  switch (value) {
    case 10497: *out = BBC_WRAP_REPEAT; return BBC_OK;
    case 33071: *out = BBC_WRAP_CLAMP; return BBC_OK;
    case 33648: *out = BBC_WRAP_MIRROR; return BBC_OK;
    default:
      return fail(ld, BBC_ERR_GLTF,
                  "%s: sampler %s %d is not REPEAT (10497), CLAMP_TO_EDGE (33071) or "
                  "MIRRORED_REPEAT (33648)",
                  label, key, value);
  }
}

/* Decodes glTF texture `index` into *out: sRGB to linear for a colour texture, the
 * stored values over their maximum for a data texture; the alpha channel (linear) when
 * keep_alpha is set and some texel is not opaque, else none. */
static bbc_result decode_texture(const loader *ld, const bbc__gltf_data *g, uint32_t index,
                                 int data, const char *label, int keep_alpha, bbc_texture *out) {
  const bbc__gltf_texture *t = &g->textures[index];
  const bbc__gltf_image *im = &g->images[t->image];
  bbc_result r = wrap_mode(ld, label, "wrapS", t->wrap_s, &out->wrap_s);
  if (r == BBC_OK) r = wrap_mode(ld, label, "wrapT", t->wrap_t, &out->wrap_t);
  if (r != BBC_OK) return r;
  out->nearest = t->mag_filter == 9728;
  size_t texels = (size_t)im->width * im->height;
  out->rgb = alloc(3 * texels, sizeof *out->rgb);
  if (!out->rgb) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory for a %ux%u texture",
                             im->width, im->height);
  out->width = im->width;
  out->height = im->height;
  if (im->bits == 8) {
    float table[256];
    for (int i = 0; i < 256; i++)
      table[i] = data ? (float)(i / 255.0) : (float)bbc_srgb_to_linear(i / 255.0);
    const uint8_t *p = im->rgba;
    for (size_t i = 0; i < texels; i++)
      for (int k = 0; k < 3; k++) out->rgb[3 * i + k] = table[p[4 * i + k]];
  } else {
    const uint16_t *p = im->rgba;
    for (size_t i = 0; i < texels; i++)
      for (int k = 0; k < 3; k++) {
        double v = p[4 * i + k] / 65535.0;
        out->rgb[3 * i + k] = (float)(data ? v : bbc_srgb_to_linear(v));
      }
  }
  if (!keep_alpha) return BBC_OK;
  const uint8_t *p8 = im->rgba;
  const uint16_t *p16 = im->rgba;
  int opaque = 1;
  for (size_t i = 0; i < texels && opaque; i++)
    opaque = im->bits == 8 ? p8[4 * i + 3] == 255 : p16[4 * i + 3] == 65535;
  if (opaque) return BBC_OK;
  out->alpha = alloc(texels, sizeof *out->alpha);
  if (!out->alpha)
    return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory for a %ux%u texture", im->width,
                im->height);
  for (size_t i = 0; i < texels; i++)
    out->alpha[i] =
        im->bits == 8 ? (float)(p8[4 * i + 3] / 255.0) : (float)(p16[4 * i + 3] / 65535.0);
  return BBC_OK;
}

/* The texture a material uses in one slot, decoded once per glTF texture and kind
 * (slot[2 i + data]), into *use. A texture bbc cannot use (no image, an image that
 * cannot be read or decoded, another TEXCOORD set than 0) is dropped with a warning,
 * leaving the material its factor. */
static bbc_result use_texture(const loader *ld, const bbc__gltf_data *g, bbc_scene *s,
                              int32_t *slot, uint32_t material, const bbc__gltf_texture_ref *ref,
                              const char *slot_name, int data, bbc_texture_use *use) {
  if (ref->texture < 0) return BBC_OK;
  char label[128], what[192];
  material_label(&g->materials[material], material, label, sizeof label);
  snprintf(what, sizeof what, "%s: %s (texture %d)", label, slot_name, ref->texture);
  const char *alone = data ? "its factor alone" : "its baseColorFactor alone";
  const bbc__gltf_texture *t = &g->textures[ref->texture];
  if (ref->texcoord != 0) {
    warn(ld,
         "%s uses TEXCOORD_%d; bbc reads TEXCOORD_0 only, so the surface has %s (as "
         "under a white texture)",
         what, ref->texcoord, alone);
    return BBC_OK;
  }
  if (t->image < 0) {
    warn(ld, "%s has no image; the surface has %s (as under a white texture)", what, alone);
    return BBC_OK;
  }
  const bbc__gltf_image *im = &g->images[t->image];
  if (!im->rgba) {
    warn(ld, "%s: image %d%s%s%s: %s; the surface has %s (as under a white texture)", what,
         t->image, im->name[0] ? " (\"" : "", im->name, im->name[0] ? "\")" : "",
         im->problem ? im->problem : "not decoded", alone);
    return BBC_OK;
  }
  int32_t *k = &slot[2 * (size_t)ref->texture + (data ? 1 : 0)];
  if (*k < 0) {
    bbc_result r = decode_texture(ld, g, (uint32_t)ref->texture, data, what, *k == -2,
                                  &s->textures[s->texture_count]);
    if (r != BBC_OK) return r;
    *k = (int32_t)s->texture_count++;
  }
  use->texture = (uint32_t)*k + 1;
  /* KHR_texture_transform: T(offset) R(rotation) S(scale), the rotation turning the
   * coordinates counter-clockwise as the image is seen (s right, t down), as in the
   * extension's example (offset [0, 1], rotation pi/2, scale 0.5 shows the image's
   * lower left quadrant turned clockwise). */
  double c = cos(ref->rotation), sn = sin(ref->rotation);
  use->uv_transform[0] = c * ref->scale[0];
  use->uv_transform[1] = sn * ref->scale[1];
  use->uv_transform[2] = ref->offset[0];
  use->uv_transform[3] = -sn * ref->scale[0];
  use->uv_transform[4] = c * ref->scale[1];
  use->uv_transform[5] = ref->offset[1];
  return BBC_OK;
}

/* The materials' textures: base colour (colour), metallic-roughness and transmission
 * (data). */
static bbc_result load_textures(const loader *ld, const bbc__gltf_data *g, bbc_scene *s) {
  int32_t *slot = alloc(2 * (size_t)g->texture_count, sizeof *slot);
  s->textures = alloc(2 * (size_t)g->texture_count, sizeof *s->textures);
  if (!slot || !s->textures) {
    free(slot);
    return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  }
  for (uint32_t i = 0; i < 2 * g->texture_count; i++) slot[i] = -1;
  /* The alpha channel of a colour texture is kept when a MASK or BLEND material uses it
   * (slot -2 marks those before any is decoded). */
  for (uint32_t i = 0; i < g->material_count; i++) {
    const bbc__gltf_texture_ref *ref = &g->materials[i].base_color_texture;
    if (ref->texture >= 0 && g->materials[i].alpha_mode != BBC_ALPHA_OPAQUE)
      slot[2 * (size_t)ref->texture] = -2;
  }
  bbc_result r = BBC_OK;
  for (uint32_t i = 0; i < g->material_count && r == BBC_OK; i++) {
    const bbc__gltf_material *gm = &g->materials[i];
    bbc_material *m = &s->materials[i];
    bbc_texture_use base = {0, {1, 0, 0, 0, 1, 0}};
    r = use_texture(ld, g, s, slot, i, &gm->base_color_texture, "baseColorTexture", 0, &base);
    m->base_color_texture = base.texture;
    memcpy(m->uv_transform, base.uv_transform, sizeof base.uv_transform);
    if (r == BBC_OK)
      r = use_texture(ld, g, s, slot, i, &gm->metallic_roughness_texture,
                      "metallicRoughnessTexture", 1, &m->metallic_roughness);
    if (r == BBC_OK)
      r = use_texture(ld, g, s, slot, i, &gm->transmission_texture, "transmissionTexture", 1,
                      &m->transmission);
    if (r == BBC_OK && (m->emission[0] > 0 || m->emission[1] > 0 || m->emission[2] > 0))
      r = use_texture(ld, g, s, slot, i, &gm->emissive_texture, "emissiveTexture", 0, &m->emissive);
  }
  free(slot);
  return r;
}

static const char *mesh_label(const bbc__gltf_primitive *p, char *buf, size_t size) {
  /* The same wording as the shim's messages, so one mesh is always named alike. */
  if (p->mesh_name[0])
    snprintf(buf, size, "mesh %u (\"%s\") primitive %u", p->mesh_index, p->mesh_name,
             p->primitive_index);
  else
    snprintf(buf, size, "mesh %u primitive %u", p->mesh_index, p->primitive_index);
  return buf;
}

static const char *mode_name(int mode) {
  static const char *const names[] = {"points",    "lines",          "line loop",   "line strip",
                                      "triangles", "triangle strip", "triangle fan"};
  return mode >= 0 && mode < 7 ? names[mode] : "unknown";
}

static bbc_result canonical_order(bbc_scene *s, const bbc_mesh *mesh);

/* Fills scene mesh mesh_index from one primitive: its world-space vertices and
 * triangles go at the ends of the scene arrays, whose fill levels are the counters. */
static bbc_result add_mesh(const loader *ld, const bbc__gltf_primitive *p, bbc_scene *s,
                           uint32_t mesh_index, uint32_t material, bbc_role role,
                           uint32_t *next_vertex, uint32_t *next_triangle) {
  char label[256];
  mesh_label(p, label, sizeof label);
  xform x;
  if (!make_xform(p->world, &x))
    return fail(ld, BBC_ERR_SCENE, "%s: node %u has a singular or non-finite transform", label,
                p->node_index);
  /* A mirroring transform turns counter-clockwise triangles clockwise (glTF 2.0, section
   * 3.7.2.1); swapping two corners keeps the winding consistent with the normals. */
  int flip = x.det < 0.0;

  for (uint32_t v = 0; v < p->vertex_count; v++) {
    double w[3];
    apply(x.a, x.t, &p->positions[3 * (size_t)v], w);
    if (!finite_float3(w))
      return fail(ld, BBC_ERR_SCENE, "%s: vertex %u has a NaN or infinite position", label, v);
  }

  bbc_mesh *mesh = &s->meshes[mesh_index];
  if (p->mesh_name[0])
    copy_name(mesh->name, p->mesh_name);
  else if (p->node_name[0])
    copy_name(mesh->name, p->node_name);
  else
    snprintf(mesh->name, sizeof mesh->name, "mesh %u", p->mesh_index);
  mesh->first_vertex = *next_vertex;
  mesh->first_triangle = *next_triangle;
  mesh->triangle_count = p->index_count / 3;
  mesh->material = material;
  mesh->role = role;
  mesh->has_normals = p->normals != NULL;
  mesh->has_uvs = p->uvs != NULL;

  uint32_t base = *next_vertex;
  for (uint32_t t = 0; t < mesh->triangle_count; t++) {
    uint32_t corner[3] = {p->indices[3 * (size_t)t], p->indices[3 * (size_t)t + 1],
                          p->indices[3 * (size_t)t + 2]};
    if (flip) {
      uint32_t tmp = corner[1];
      corner[1] = corner[2];
      corner[2] = tmp;
    }
    size_t tri = (size_t)*next_triangle + t;
    s->triangle_mesh[tri] = mesh_index;
    if (p->normals) {
      for (int k = 0; k < 3; k++) s->indices[3 * tri + (size_t)k] = base + corner[k];
      continue;
    }
    /* Without normals every triangle gets its own three vertices, so that each can
     * carry the triangle's flat normal. */
    double w[3][3], e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) {
      uint32_t dst = base + 3 * t + (uint32_t)k;
      apply(x.a, x.t, &p->positions[3 * (size_t)corner[k]], w[k]);
      for (int c = 0; c < 3; c++) s->positions[3 * (size_t)dst + c] = (float)w[k][c];
      for (int c = 0; c < 2; c++)
        s->uvs[2 * (size_t)dst + c] = p->uvs ? p->uvs[2 * (size_t)corner[k] + c] : 0.0f;
      s->indices[3 * tri + (size_t)k] = dst;
    }
    for (int c = 0; c < 3; c++) {
      e1[c] = w[1][c] - w[0][c];
      e2[c] = w[2][c] - w[0][c];
    }
    cross3(e1, e2, n);
    if (!normalize3(n)) {
      /* A degenerate triangle has no area, so no ray ever hits it and its normal is
       * never used; any unit vector keeps the promise that normals are unit length. */
      n[0] = 0.0;
      n[1] = 0.0;
      n[2] = 1.0;
    }
    for (int k = 0; k < 3; k++)
      for (int c = 0; c < 3; c++)
        s->normals[3 * ((size_t)base + 3 * t + (size_t)k) + c] = (float)n[c];
  }

  if (p->normals) {
    for (uint32_t v = 0; v < p->vertex_count; v++) {
      size_t dst = (size_t)base + v;
      double w[3], n[3];
      apply(x.a, x.t, &p->positions[3 * (size_t)v], w);
      apply(x.normal, NULL, &p->normals[3 * (size_t)v], n);
      if (!normalize3(n))
        return fail(ld, BBC_ERR_SCENE, "%s: vertex %u has a zero or non-finite normal", label, v);
      for (int c = 0; c < 3; c++) {
        s->positions[3 * dst + c] = (float)w[c];
        s->normals[3 * dst + c] = (float)n[c];
      }
      for (int c = 0; c < 2; c++) s->uvs[2 * dst + c] = p->uvs ? p->uvs[2 * (size_t)v + c] : 0.0f;
    }
    mesh->vertex_count = p->vertex_count;
  } else {
    mesh->vertex_count = 3 * mesh->triangle_count;
  }
  if (canonical_order(s, mesh) != BBC_OK) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  *next_vertex += mesh->vertex_count;
  *next_triangle += mesh->triangle_count;
  return BBC_OK;
}

/* ------------------------------------------------------------------ canonical order */

/* A stable merge sort of n indices under less(ctx, a, b); tmp holds n entries. */
static void sort_indices(uint32_t *v, uint32_t *tmp, uint32_t n, const void *ctx,
                         int (*less)(const void *, uint32_t, uint32_t)) {
  for (uint32_t width = 1; width < n; width *= 2) {
    for (uint32_t lo = 0; lo < n; lo += 2 * width) {
      uint32_t mid = lo + width < n ? lo + width : n, hi = lo + 2 * width < n ? lo + 2 * width : n;
      uint32_t i = lo, j = mid, k = lo;
      while (i < mid && j < hi) tmp[k++] = less(ctx, v[j], v[i]) ? v[j++] : v[i++];
      while (i < mid) tmp[k++] = v[i++];
      while (j < hi) tmp[k++] = v[j++];
    }
    memcpy(v, tmp, n * sizeof *v);
  }
}

typedef struct vertex_keys {
  const float *p, *n, *uv;
} vertex_keys;

/* Vertices by position, then normal, then uv, each compared as exact floats. */
static int vertex_less(const void *ctx, uint32_t a, uint32_t b) {
  const vertex_keys *k = ctx;
  for (int c = 0; c < 8; c++) {
    float x = c < 3 ? k->p[3 * (size_t)a + c] : c < 6 ? k->n[3 * (size_t)a + c - 3] : k->uv[2 * (size_t)a + c - 6];
    float y = c < 3 ? k->p[3 * (size_t)b + c] : c < 6 ? k->n[3 * (size_t)b + c - 3] : k->uv[2 * (size_t)b + c - 6];
    if (x != y) return x < y;
  }
  return 0;
}

static int triangle_less(const void *ctx, uint32_t a, uint32_t b) {
  const uint32_t *idx = ctx;
  for (int c = 0; c < 3; c++)
    if (idx[3 * (size_t)a + c] != idx[3 * (size_t)b + c])
      return idx[3 * (size_t)a + c] < idx[3 * (size_t)b + c];
  return 0;
}

/* Puts a mesh's vertices and triangles into an order that depends only on its geometry,
 * not on the file's order: vertices sorted by (position, normal, uv), each triangle's
 * corners rotated (keeping its winding) to start at its smallest vertex, triangles
 * sorted by their corners. Exporters such as Blender's do not keep triangle or vertex
 * order from one export to the next; in canonical order the same mesh gives the same
 * scene arrays, hence the same fingerprint and the same tuples in a cache. */
static bbc_result canonical_order(bbc_scene *s, const bbc_mesh *mesh) {
  uint32_t nv = mesh->vertex_count, nt = mesh->triangle_count, base = mesh->first_vertex;
  uint32_t *order = alloc(nv > nt ? nv : nt, sizeof *order);
  uint32_t *tmp = alloc(nv > nt ? nv : nt, sizeof *tmp);
  uint32_t *new_of = alloc(nv, sizeof *new_of);
  float *copy = alloc(8 * (size_t)nv, sizeof *copy);
  uint32_t *tri = alloc(3 * (size_t)nt, sizeof *tri);
  bbc_result r = BBC_ERR_OUT_OF_MEMORY;
  if (!order || !tmp || !new_of || !copy || !tri) goto done;
  float *p = s->positions + 3 * (size_t)base, *n = s->normals + 3 * (size_t)base,
        *uv = s->uvs + 2 * (size_t)base;
  vertex_keys keys = {p, n, uv};
  for (uint32_t i = 0; i < nv; i++) order[i] = i;
  sort_indices(order, tmp, nv, &keys, vertex_less);
  for (uint32_t i = 0; i < nv; i++) new_of[order[i]] = i;
  memcpy(copy, p, 3 * (size_t)nv * sizeof *copy);
  memcpy(copy + 3 * (size_t)nv, n, 3 * (size_t)nv * sizeof *copy);
  memcpy(copy + 6 * (size_t)nv, uv, 2 * (size_t)nv * sizeof *copy);
  for (uint32_t i = 0; i < nv; i++) {
    uint32_t o = order[i];
    memcpy(p + 3 * (size_t)i, copy + 3 * (size_t)o, 3 * sizeof *copy);
    memcpy(n + 3 * (size_t)i, copy + 3 * (size_t)nv + 3 * (size_t)o, 3 * sizeof *copy);
    memcpy(uv + 2 * (size_t)i, copy + 6 * (size_t)nv + 2 * (size_t)o, 2 * sizeof *copy);
  }
  uint32_t *idx = s->indices + 3 * (size_t)mesh->first_triangle;
  for (uint32_t t = 0; t < nt; t++) {
    uint32_t c[3];
    for (int k = 0; k < 3; k++) c[k] = new_of[idx[3 * (size_t)t + k] - base];
    int first = c[1] < c[0] ? (c[2] < c[1] ? 2 : 1) : (c[2] < c[0] ? 2 : 0);
    for (int k = 0; k < 3; k++) tri[3 * (size_t)t + k] = c[(first + k) % 3];
  }
  for (uint32_t t = 0; t < nt; t++) order[t] = t;
  sort_indices(order, tmp, nt, tri, triangle_less);
  for (uint32_t t = 0; t < nt; t++)
    for (int k = 0; k < 3; k++) idx[3 * (size_t)t + k] = base + tri[3 * (size_t)order[t] + k];
  r = BBC_OK;
done:
  free(order);
  free(tmp);
  free(new_of);
  free(copy);
  free(tri);
  return r;
}

static bbc_result parse_role(const loader *ld, const bbc__gltf_primitive *p, bbc_material_type type,
                             bbc_role *role) {
  if (!p->role) {
    *role = type == BBC_MATERIAL_DIFFUSE ? BBC_ROLE_RECEIVER : BBC_ROLE_CASTER;
  } else if (strcmp(p->role, "caster") == 0) {
    *role = BBC_ROLE_CASTER;
  } else if (strcmp(p->role, "receiver") == 0) {
    *role = BBC_ROLE_RECEIVER;
  } else if (strcmp(p->role, "none") == 0) {
    *role = BBC_ROLE_NONE;
  } else {
    if (p->node_name[0])
      return fail(ld, BBC_ERR_SCENE,
                  "node \"%s\": extras.bbc.role \"%s\" is not caster, receiver or none",
                  p->node_name, p->role);
    return fail(ld, BBC_ERR_SCENE,
                "node %u: extras.bbc.role \"%s\" is not caster, receiver or none", p->node_index,
                p->role);
  }
  return BBC_OK;
}

/* ------------------------------------------------------------------ surface classes */

/* Whether material m decides its class per triangle from textures. */
static int textured_class(const bbc_material *m) {
  return m->source >= 0 && (m->metallic_roughness.texture || m->transmission.texture);
}

/* The class of every triangle of primitive p, whose material m (glTF material gm) has a
 * metallic-roughness or transmission texture: its factors times the texels its UVs
 * cover (bbc__texture_range). Returns the mask of classes met (bit 1 << type) and adds
 * the triangles whose texels disagree to *mixed. */
static unsigned triangle_classes(const bbc_scene *s, const bbc_material *m,
                                 const bbc__gltf_material *gm, const bbc__gltf_primitive *p,
                                 uint8_t *cls, uint64_t *mixed) {
  static const float origin[2] = {0.0f, 0.0f};
  unsigned mask = 0;
  for (uint32_t t = 0; t < p->index_count / 3; t++) {
    const float *uv[3];
    for (int k = 0; k < 3; k++)
      uv[k] = p->uvs ? p->uvs + 2 * (size_t)p->indices[3 * (size_t)t + (size_t)k] : origin;
    double mr[2] = {gm->metallic, gm->metallic}, rr[2] = {gm->roughness, gm->roughness};
    double tr[2] = {gm->transmission, gm->transmission};
    double lo, hi;
    if (m->metallic_roughness.texture) {
      const bbc_texture *tex = &s->textures[m->metallic_roughness.texture - 1];
      bbc__texture_range(tex, m->metallic_roughness.uv_transform, uv, 1, &lo, &hi);
      rr[0] *= lo, rr[1] *= hi;
      bbc__texture_range(tex, m->metallic_roughness.uv_transform, uv, 2, &lo, &hi);
      mr[0] *= lo, mr[1] *= hi;
    }
    if (m->transmission.texture) {
      bbc__texture_range(&s->textures[m->transmission.texture - 1], m->transmission.uv_transform,
                         uv, 0, &lo, &hi);
      tr[0] *= lo, tr[1] *= hi;
    }
    int disagree;
    cls[t] = (uint8_t)bbc__class_of_ranges(mr, rr, tr, &disagree);
    *mixed += (uint64_t)disagree;
    mask |= 1u << cls[t];
  }
  return mask;
}

/* Material `base` as a material of class `type` (a part of its triangles). */
static bbc_result class_variant(const loader *ld, const bbc__gltf_data *g, const bbc_material *base,
                                bbc_material_type type, bbc_material *out) {
  static const char *const part[] = {" (receiver part)", " (mirror part)", " (dielectric part)"};
  const bbc__gltf_material *gm = &g->materials[base->source];
  char name[sizeof out->name];
  memcpy(name, base->name, sizeof name);
  *out = *base;
  out->type = type;
  snprintf(out->name, sizeof out->name, "%.*s%s", (int)(sizeof name - 20), name, part[type]);
  if (type == BBC_MATERIAL_DIELECTRIC) {
    if (!fits_float(gm->ior) || !(gm->ior > 0.0)) {
      char label[128];
      return fail(ld, BBC_ERR_SCENE, "%s: ior %g is not a positive number",
                  material_label(gm, (uint32_t)base->source, label, sizeof label), gm->ior);
    }
    out->ior = (float)gm->ior;
    char label[128];
    bbc_result r = volume_absorption(
        ld, gm, material_label(gm, (uint32_t)base->source, label, sizeof label), out);
    if (r != BBC_OK) return r;
  }
  if (type == BBC_MATERIAL_DIFFUSE) {
    /* The glossy model with the factors, times the texture at each point when it has
     * one (bbc_bsdf_at); transmission of a rough surface is not rendered. */
    out->glossy =
        base->metallic_roughness.texture || !(gm->metallic == 0.0 && gm->roughness == 1.0);
    out->metallic = (float)gm->metallic;
    out->roughness = (float)gm->roughness;
    if (!base->metallic_roughness.texture && out->roughness < BBC_BSDF_MIN_ROUGHNESS)
      out->roughness = (float)BBC_BSDF_MIN_ROUGHNESS;
  }
  return BBC_OK;
}

/* One note per material whose textures decided its triangles' classes. */
static void class_notes(const loader *ld, const bbc__gltf_data *g, const bbc_scene *s,
                        const uint64_t (*count)[3], const uint64_t *mixed) {
  for (uint32_t i = 0; i < g->material_count; i++) {
    const bbc_material *m = &s->materials[i];
    uint64_t all = count[i][0] + count[i][1] + count[i][2];
    if (!textured_class(m) || all == 0) continue;
    char label[128], why[96] = "";
    material_label(&g->materials[i], i, label, sizeof label);
    if (mixed[i])
      snprintf(why, sizeof why, " (%llu of them because their texels disagree)",
               (unsigned long long)mixed[i]);
    warn(ld,
         "%s: by its %s%s%s, %llu triangles are ideal mirrors, %llu smooth dielectrics and "
         "%llu receivers%s",
         label, m->metallic_roughness.texture ? "metallicRoughnessTexture" : "",
         m->metallic_roughness.texture && m->transmission.texture ? " and " : "",
         m->transmission.texture ? "transmissionTexture" : "", (unsigned long long)count[i][1],
         (unsigned long long)count[i][2], (unsigned long long)count[i][0], why);
  }
}

static bbc_result load_geometry(const loader *ld, const bbc__gltf_data *g, bbc_scene *s) {
  /* Materials: those of the file, then a default one for primitives without. */
  int need_default = 0;
  for (uint32_t i = 0; i < g->primitive_count; i++) need_default |= g->primitives[i].material < 0;
  const uint32_t file_materials = g->material_count + (need_default ? 1u : 0u);
  s->material_count = file_materials;
  s->materials = alloc(s->material_count, sizeof *s->materials);
  if (!s->materials) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  for (uint32_t i = 0; i < g->material_count; i++) {
    bbc_result r = classify(ld, &g->materials[i], i, &s->materials[i]);
    if (r != BBC_OK) return r;
  }
  if (need_default) {
    bbc_material *m = &s->materials[g->material_count];
    copy_name(m->name, "default");
    m->type = BBC_MATERIAL_DIFFUSE;
    m->base_color[0] = m->base_color[1] = m->base_color[2] = 0.8f;
    m->ior = 1.5f;
    m->uv_transform[0] = m->uv_transform[4] = 1.0;
    m->alpha = 1.0f;
    m->source = -1;
  }
  bbc_result r = load_textures(ld, g, s);
  if (r != BBC_OK) return r;

  /* Surface classes per triangle where textures decide them: a primitive whose
   * triangles fall in several classes becomes one mesh per class, and its material one
   * material per class (the variant of class c of material i is variant[3 i + c]). */
  const uint32_t np = g->primitive_count;
  uint8_t **cls = alloc(np, sizeof *cls);
  unsigned *mask = alloc(np, sizeof *mask);
  uint32_t *variant = alloc(3 * (size_t)file_materials, sizeof *variant);
  uint64_t(*count)[3] = alloc(file_materials, sizeof *count);
  uint64_t *mixed = alloc(file_materials, sizeof *mixed);
  uint32_t *filtered = NULL;
  if (!cls || !mask || !variant || !count || !mixed) {
    r = fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
    goto done;
  }
  uint32_t max_triangles = 0;
  for (uint32_t i = 0; i < np; i++) {
    const bbc__gltf_primitive *p = &g->primitives[i];
    uint32_t material = p->material < 0 ? g->material_count : (uint32_t)p->material;
    const bbc_material *m = &s->materials[material];
    char label[256];
    if (p->mode != 4) {
      r = fail(ld, BBC_ERR_SCENE, "%s has mode %d (%s); only triangles (mode 4) are supported",
               mesh_label(p, label, sizeof label), p->mode, mode_name(p->mode));
      goto done;
    }
    if (p->index_count % 3 != 0) {
      r = fail(ld, BBC_ERR_GLTF, "%s: %u indices do not make whole triangles",
               mesh_label(p, label, sizeof label), p->index_count);
      goto done;
    }
    const uint32_t nt = p->index_count / 3;
    max_triangles = nt > max_triangles ? nt : max_triangles;
    mask[i] = 1u << m->type;
    if (textured_class(m)) {
      cls[i] = alloc(nt ? nt : 1, 1);
      if (!cls[i]) {
        r = fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
        goto done;
      }
      mask[i] = triangle_classes(s, m, &g->materials[material], p, cls[i], &mixed[material]);
      for (uint32_t t = 0; t < nt; t++) count[material][cls[i][t]]++;
    }
    for (unsigned c = 0; c < 3; c++)
      if ((mask[i] >> c & 1u) && c != (unsigned)m->type) variant[3 * (size_t)material + c] = 1;
  }
  class_notes(ld, g, s, (const uint64_t(*)[3])count, mixed);
  uint32_t variants = 0;
  for (size_t k = 0; k < 3 * (size_t)file_materials; k++) variants += variant[k];
  if (variants) {
    bbc_material *grown = realloc(s->materials, (file_materials + variants) * sizeof *grown);
    if (!grown) {
      r = fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
      goto done;
    }
    s->materials = grown;
    for (size_t k = 0; k < 3 * (size_t)file_materials && r == BBC_OK; k++) {
      if (!variant[k]) continue;
      variant[k] = s->material_count;
      r = class_variant(ld, g, &s->materials[k / 3], (bbc_material_type)(k % 3),
                        &s->materials[s->material_count++]);
    }
    if (r != BBC_OK) goto done;
  }

  /* Sizes first, so that every array is allocated once. */
  uint64_t vertices = 0, triangles = 0, meshes = 0;
  for (uint32_t i = 0; i < np; i++) {
    const bbc__gltf_primitive *p = &g->primitives[i];
    for (unsigned c = 0; c < 3; c++) {
      if (!(mask[i] >> c & 1u)) continue;
      uint64_t nt = 0;
      for (uint32_t t = 0; t < p->index_count / 3; t++) nt += !cls[i] || cls[i][t] == c;
      triangles += nt;
      vertices += p->normals ? p->vertex_count : 3 * nt;
      meshes++;
    }
  }
  if (triangles == 0) {
    r = fail(ld, BBC_ERR_SCENE, "no triangles: the default scene has no triangle mesh");
    goto done;
  }
  if (vertices > UINT32_MAX || triangles > UINT32_MAX / 3 || meshes > UINT32_MAX) {
    r = fail(ld, BBC_ERR_SCENE, "too many vertices or triangles for 32-bit indices");
    goto done;
  }

  s->vertex_count = (uint32_t)vertices;
  s->triangle_count = (uint32_t)triangles;
  s->mesh_count = (uint32_t)meshes;
  s->positions = alloc(3 * (size_t)vertices, sizeof(float));
  s->normals = alloc(3 * (size_t)vertices, sizeof(float));
  s->uvs = alloc(2 * (size_t)vertices, sizeof(float));
  s->indices = alloc(3 * (size_t)triangles, sizeof(uint32_t));
  s->triangle_mesh = alloc((size_t)triangles, sizeof(uint32_t));
  s->meshes = alloc(s->mesh_count, sizeof *s->meshes);
  filtered = alloc(3 * (size_t)max_triangles + 1, sizeof *filtered);
  if (!s->positions || !s->normals || !s->uvs || !s->indices || !s->triangle_mesh || !s->meshes ||
      !filtered) {
    r = fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory for %llu vertices",
             (unsigned long long)vertices);
    goto done;
  }

  uint32_t next_vertex = 0, next_triangle = 0, mesh = 0;
  for (uint32_t i = 0; i < np && r == BBC_OK; i++) {
    const bbc__gltf_primitive *p = &g->primitives[i];
    uint32_t material = p->material < 0 ? g->material_count : (uint32_t)p->material;
    for (unsigned c = 0; c < 3 && r == BBC_OK; c++) {
      if (!(mask[i] >> c & 1u)) continue;
      /* The primitive's triangles of class c, over all its vertices. */
      bbc__gltf_primitive part = *p;
      if (cls[i]) {
        uint32_t n = 0;
        for (uint32_t t = 0; t < p->index_count / 3; t++)
          if (cls[i][t] == c)
            for (int k = 0; k < 3; k++) filtered[n++] = p->indices[3 * (size_t)t + (size_t)k];
        part.indices = filtered;
        part.index_count = n;
      }
      uint32_t mm =
          c == (unsigned)s->materials[material].type ? material : variant[3 * (size_t)material + c];
      bbc_role role = BBC_ROLE_NONE;
      r = parse_role(ld, &part, s->materials[mm].type, &role);
      if (r == BBC_OK) r = add_mesh(ld, &part, s, mesh++, mm, role, &next_vertex, &next_triangle);
    }
    if (r == BBC_OK && s->materials[material].base_color_texture && !p->uvs) {
      char label[256];
      warn(ld, "%s has a base colour texture but no TEXCOORD_0; the texture is read at (0, 0)",
           mesh_label(p, label, sizeof label));
    }
  }
done:
  if (cls)
    for (uint32_t i = 0; i < np; i++) free(cls[i]);
  free(cls);
  free(mask);
  free(variant);
  free(count);
  free(mixed);
  free(filtered);
  return r;
}

/* The units of the file's light intensities: the caller's override, else the asset's
 * extras.bbc.light_units, else photometric as the glTF specification says. */
static bbc_result light_units(const loader *ld, const bbc__gltf_data *g, bbc_scene *s) {
  if (ld->light_units != BBC_LIGHT_UNITS_FILE && ld->light_units != BBC_LIGHT_UNITS_PHOTOMETRIC &&
      ld->light_units != BBC_LIGHT_UNITS_RADIOMETRIC)
    return fail(ld, BBC_ERR_INVALID_ARGUMENT, "light_units option %d is not a bbc_light_units",
                (int)ld->light_units);
  if (ld->light_units != BBC_LIGHT_UNITS_FILE)
    s->light_units = ld->light_units;
  else if (!g->light_units || strcmp(g->light_units, "photometric") == 0)
    s->light_units = BBC_LIGHT_UNITS_PHOTOMETRIC;
  else if (strcmp(g->light_units, "radiometric") == 0)
    s->light_units = BBC_LIGHT_UNITS_RADIOMETRIC;
  else
    return fail(ld, BBC_ERR_SCENE,
                "asset.extras.bbc.light_units \"%s\" is not \"photometric\" or \"radiometric\"",
                g->light_units);
  return BBC_OK;
}

/* The kind-specific part of a light (scene.h): the direction of spots and suns from the
 * node's -Z axis, the cone of spots, the angular diameter of suns. */
static bbc_result light_model(const loader *ld, const bbc__gltf_light *l, bbc_light_model *m) {
  memset(m, 0, sizeof *m);
  m->kind = strcmp(l->type, "spot") == 0          ? BBC_LIGHT_SPOT
            : strcmp(l->type, "directional") == 0 ? BBC_LIGHT_DIRECTIONAL
                                                  : BBC_LIGHT_POINT;
  if (m->kind == BBC_LIGHT_POINT) return BBC_OK;
  double d[3] = {l->direction[0], l->direction[1], l->direction[2]};
  if (!finite3(d) || !normalize3(d))
    return fail(ld, BBC_ERR_SCENE, "light \"%s\" (node %u): its node's -Z axis has no direction",
                l->name, l->node_index);
  m->direction = (bbc_vec3){d[0], d[1], d[2]};
  if (m->kind == BBC_LIGHT_SPOT) {
    /* KHR_lights_punctual: 0 <= inner < outer <= pi/2. */
    if (!(l->inner_cone >= 0 && l->inner_cone < l->outer_cone && l->outer_cone <= PI / 2))
      return fail(ld, BBC_ERR_SCENE,
                  "light \"%s\" (node %u): spot cone angles need 0 <= innerConeAngle < "
                  "outerConeAngle <= pi/2 (have %g and %g)",
                  l->name, l->node_index, l->inner_cone, l->outer_cone);
    m->cos_outer = cos(l->outer_cone);
    m->cone_scale = 1.0 / fmax(0.001, cos(l->inner_cone) - m->cos_outer);
  }
  if (m->kind == BBC_LIGHT_DIRECTIONAL && l->has_angular_diameter) {
    if (!(l->angular_diameter >= 0 && l->angular_diameter <= BBC_SUN_MAX_ANGULAR_DIAMETER))
      return fail(ld, BBC_ERR_SCENE,
                  "light \"%s\" (node %u): extras.bbc.angular_diameter must be from 0 to %g "
                  "degrees (the sun's is 0.53), not %g",
                  l->name, l->node_index, BBC_SUN_MAX_ANGULAR_DIAMETER, l->angular_diameter);
    m->angular_diameter = l->angular_diameter * (PI / 180.0);
  }
  return BBC_OK;
}

/* Area lights: every emissive triangle, sampled in proportion to its power
 * (scene->emitters, emitter_cdf, emitter_power, replacing earlier ones). */
static bbc_result find_emitters(bbc_scene *s) {
  free(s->emitters);
  free(s->emitter_cdf);
  s->emitters = NULL;
  s->emitter_cdf = NULL;
  s->emitter_count = 0;
  s->emitter_power = 0.0;
  uint32_t emissive = 0;
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    const float *e = bbc_scene_triangle_material(s, t)->emission;
    emissive += (e[0] > 0.0f || e[1] > 0.0f || e[2] > 0.0f);
  }
  s->emitters = alloc(emissive, sizeof *s->emitters);
  s->emitter_cdf = alloc(emissive, sizeof *s->emitter_cdf);
  if (!s->emitters || !s->emitter_cdf) return BBC_ERR_OUT_OF_MEMORY;
  double total = 0.0;
  for (uint32_t t = 0; t < s->triangle_count && emissive > 0; t++) {
    const float *e = bbc_scene_triangle_material(s, t)->emission;
    double mean = ((double)e[0] + e[1] + e[2]) / 3.0;
    if (!(mean > 0.0)) continue;
    double p[3][3], e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++)
      for (int c = 0; c < 3; c++)
        p[k][c] = s->positions[3 * (size_t)s->indices[3 * (size_t)t + k] + c];
    for (int c = 0; c < 3; c++) {
      e1[c] = p[1][c] - p[0][c];
      e2[c] = p[2][c] - p[0][c];
    }
    cross3(e1, e2, n);
    double weight = 0.5 * sqrt(dot3(n, n)) * mean;
    /* A degenerate emitter emits nothing and must never be sampled. */
    if (!(weight > 0.0)) continue;
    total += weight;
    s->emitters[s->emitter_count] = t;
    s->emitter_cdf[s->emitter_count] = total;
    s->emitter_count++;
  }
  for (uint32_t i = 0; i < s->emitter_count; i++) s->emitter_cdf[i] /= total;
  if (s->emitter_count > 0) s->emitter_cdf[s->emitter_count - 1] = 1.0;
  s->emitter_power = total * PI;
  return BBC_OK;
}

static bbc_result load_lights(const loader *ld, const bbc__gltf_data *g, bbc_scene *s) {
  bbc_result r = light_units(ld, g, s);
  if (r != BBC_OK) return r;
  s->point_lights = alloc(g->light_count, sizeof *s->point_lights);
  if (!s->point_lights) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  uint32_t ignored = 0;
  for (uint32_t i = 0; i < g->light_count; i++) {
    const bbc__gltf_light *l = &g->lights[i];
    if (strcmp(l->type, "point") != 0 && strcmp(l->type, "spot") != 0 &&
        strcmp(l->type, "directional") != 0) {
      warn(ld, "light \"%s\" (node %u) is a %s light and is ignored", l->name, l->node_index,
           l->type);
      ignored++;
      continue;
    }
    bbc_point_light *out = &s->point_lights[s->point_light_count++];
    double power[3];
    double intensity = bbc_light_radiometric(l->intensity, s->light_units);
    for (int k = 0; k < 3; k++) power[k] = intensity * l->color[k];
    if (!finite3(l->position))
      return fail(ld, BBC_ERR_SCENE, "light \"%s\" (node %u) has a non-finite position", l->name,
                  l->node_index);
    if (!finite_float3(power) || power[0] < 0.0 || power[1] < 0.0 || power[2] < 0.0)
      return fail(ld, BBC_ERR_SCENE,
                  "light \"%s\" (node %u): intensity x color must be finite and non-negative",
                  l->name, l->node_index);
    out->position = (bbc_vec3){l->position[0], l->position[1], l->position[2]};
    for (int k = 0; k < 3; k++) out->intensity[k] = (float)power[k];
    if ((r = light_model(ld, l, &out->model)) != BBC_OK) return r;
  }

  if (find_emitters(s) != BBC_OK) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");

  if (s->point_light_count == 0 && s->emitter_count == 0)
    return fail(ld, BBC_ERR_SCENE,
                "no light: the scene has neither a punctual light nor an emissive triangle%s",
                ignored ? " (lights of unknown types were ignored)" : "");
  return BBC_OK;
}

static bbc_result film_size(const loader *ld, const bbc__gltf_camera *c, double value,
                            const char *key, uint32_t *out) {
  if (!(value >= 1.0 && value <= MAX_FILM_SIZE && value == floor(value)))
    return fail(ld, BBC_ERR_SCENE, "camera \"%s\": extras.bbc.%s must be an integer from 1 to %d",
                c->name, key, MAX_FILM_SIZE);
  *out = (uint32_t)value;
  return BBC_OK;
}

/* A side of the film from the other and the aspect ratio, at least one pixel. */
static uint32_t film_side(double other, double ratio) {
  double v = floor(other * ratio + 0.5);
  return v < 1.0 ? 1u : v > MAX_FILM_SIZE ? MAX_FILM_SIZE : (uint32_t)v;
}

/* Copies the motion of a camera out of the view (which is freed after loading). */
static bbc_result copy_motion(const bbc__gltf_camera *c, bbc__camera_motion *m) {
  m->path = alloc(c->path_length, sizeof *m->path);
  if (!m->path) return BBC_ERR_OUT_OF_MEMORY;
  m->path_length = c->path_length;
  for (uint32_t k = 0; k < c->path_length; k++) {
    const bbc__gltf_node_motion *in = &c->path[k];
    bbc__node_motion *out = &m->path[k];
    out->has_matrix = in->has_matrix;
    memcpy(out->matrix, in->matrix, sizeof out->matrix);
    memcpy(out->translation, in->translation, sizeof out->translation);
    memcpy(out->rotation, in->rotation, sizeof out->rotation);
    memcpy(out->scale, in->scale, sizeof out->scale);
    for (int p = 0; p < 3; p++) {
      const bbc__gltf_channel *ch = in->channels[p];
      if (!ch) continue;
      size_t values = (size_t)ch->key_count * (ch->interpolation == 2 ? 3 : 1) * (p == 1 ? 4 : 3);
      bbc__channel *oc = &out->channels[p];
      oc->times = alloc(ch->key_count, sizeof(float));
      oc->values = alloc(values, sizeof(float));
      if (!oc->times || !oc->values) return BBC_ERR_OUT_OF_MEMORY;
      memcpy(oc->times, ch->times, ch->key_count * sizeof(float));
      memcpy(oc->values, ch->values, values * sizeof(float));
      oc->path = p;
      oc->interpolation = ch->interpolation;
      oc->key_count = ch->key_count;
    }
  }
  return BBC_OK;
}

/* One perspective camera of the file into *out (its rest placement, size, animation
 * range). */
static bbc_result load_camera(const loader *ld, const bbc__gltf_camera *c, uint32_t index,
                              bbc_camera *out) {
  if (c->name[0])
    copy_name(out->name, c->name);
  else
    snprintf(out->name, sizeof out->name, "camera %u", index);
  if (!(c->yfov > 0.0 && c->yfov < PI))
    return fail(ld, BBC_ERR_SCENE, "camera \"%s\": yfov %g is not in (0, pi)", c->name, c->yfov);
  /* tinygltf reports an absent aspectRatio as 0, which the glTF schema forbids. */
  double aspect = c->aspect_ratio;
  if (aspect != 0.0 && !(aspect > 0.0 && aspect <= MAX_FILM_SIZE))
    return fail(ld, BBC_ERR_SCENE, "camera \"%s\": aspectRatio %g is not positive", c->name,
                c->aspect_ratio);
  bbc_result r = BBC_OK;
  if (c->has_width) r = film_size(ld, c, c->width, "width", &out->width);
  if (r == BBC_OK && c->has_height) r = film_size(ld, c, c->height, "height", &out->height);
  if (r != BBC_OK) return r;
  /* A side not given follows the aspect ratio (4:3 without one); with neither, the
   * longer side is 640 pixels. */
  double ratio = aspect > 0.0 ? aspect : 4.0 / 3.0;
  if (!c->has_width && !c->has_height) {
    out->width = ratio >= 1.0 ? 640u : film_side(640.0, ratio);
    out->height = ratio >= 1.0 ? film_side(640.0, 1.0 / ratio) : 640u;
  } else if (!c->has_height) {
    out->height = film_side(out->width, 1.0 / ratio);
  } else if (!c->has_width) {
    out->width = film_side(out->height, ratio);
  } else if (aspect > 0.0 && fabs(out->width - aspect * out->height) >= 1.0) {
    warn(ld,
         "camera \"%s\": the image is %ux%u but aspectRatio is %g; the image keeps yfov and "
         "shows a horizontal field of view of aspect %g",
         c->name, out->width, out->height, aspect, (double)out->width / out->height);
  }
  out->yfov = c->yfov;
  out->aspect = aspect > 0.0 ? aspect : (double)out->width / (double)out->height;
  if (!bbc__camera_frame(c->world, out))
    return fail(ld, BBC_ERR_SCENE, "camera \"%s\" (node %u) has a degenerate transform", c->name,
                c->node_index);
  out->animated = c->animated;
  if (c->animated) {
    /* The key range over every channel that moves the camera. */
    out->time_start = INFINITY;
    out->time_end = -INFINITY;
    for (uint32_t k = 0; k < c->path_length; k++)
      for (int p = 0; p < 3; p++) {
        const bbc__gltf_channel *ch = c->path[k].channels[p];
        if (!ch) continue;
        if (ch->times[0] < out->time_start) out->time_start = ch->times[0];
        if (ch->times[ch->key_count - 1] > out->time_end)
          out->time_end = ch->times[ch->key_count - 1];
      }
  }
  return BBC_OK;
}

/* Every perspective camera; other kinds are skipped with a warning. */
static bbc_result load_cameras(const loader *ld, const bbc__gltf_data *g, bbc_scene *s) {
  s->cameras = alloc(g->camera_count, sizeof *s->cameras);
  s->camera_motion = alloc(g->camera_count, sizeof *s->camera_motion);
  if (!s->cameras || !s->camera_motion) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  uint32_t skipped = 0;
  for (uint32_t i = 0; i < g->camera_count; i++) {
    const bbc__gltf_camera *c = &g->cameras[i];
    if (strcmp(c->type, "perspective") != 0) {
      warn(ld, "camera \"%s\" (node %u) is %s and is skipped; only perspective cameras are "
               "supported", c->name, c->node_index, c->type);
      skipped++;
      continue;
    }
    uint32_t k = s->camera_count;
    bbc_result r = load_camera(ld, c, i, &s->cameras[k]);
    if (r != BBC_OK) return r;
    s->camera_count++; /* counted before the motion, so bbc_scene_free frees it */
    if (c->animated && copy_motion(c, &s->camera_motion[k]) != BBC_OK)
      return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  }
  if (s->camera_count == 0)
    return fail(ld, BBC_ERR_SCENE, "no camera: no node of the default scene has a %scamera",
                skipped ? "perspective " : "");
  s->camera = s->cameras[0];
  return BBC_OK;
}

/* A dielectric whose material has no KHR_materials_volume (thickness 0) is, for glTF, a
 * thin wall that transmits without bending light. bbc has no thin walls: a closed mesh
 * is rendered as the solid it encloses, an open one as a single refracting surface with
 * the dielectric behind its vertex normals (the media rule, media_internal.h); where
 * dielectrics meet, the medium in front comes from the geometry, and a closed mesh may
 * be a cavity's wall (docs/materials.md, "Media"). One warning per mesh says which. */
static void volume_warnings(const loader *ld, const bbc__gltf_data *g, const bbc_scene *s) {
  for (uint32_t i = 0; i < s->mesh_count; i++) {
    const bbc_mesh *mesh = &s->meshes[i];
    const bbc_material *m = &s->materials[mesh->material];
    if (m->type != BBC_MATERIAL_DIELECTRIC || m->source < 0 ||
        g->materials[m->source].thickness > 0.0)
      continue;
    char label[128];
    material_label(&g->materials[m->source], (uint32_t)m->source, label, sizeof label);
    if (mesh->cavity)
      warn(ld,
           "mesh \"%s\" (%s): KHR_materials_transmission without KHR_materials_volume; the "
           "mesh is closed, inside another dielectric and its normals point into it, so it "
           "is rendered as the wall of a cavity: a dielectric of ior %g behind its vertex "
           "normals, air inside",
           mesh->name, label, (double)m->ior);
    else if (mesh->closed)
      warn(ld,
           "mesh \"%s\" (%s): KHR_materials_transmission without KHR_materials_volume; the "
           "mesh is closed, so it is rendered as a solid dielectric of ior %g",
           mesh->name, label, (double)m->ior);
    else
      warn(ld,
           "mesh \"%s\" (%s): KHR_materials_transmission without KHR_materials_volume on an "
           "open mesh; it is rendered as one refracting surface with a dielectric of ior %g "
           "behind its vertex normals and %s in front, not as the thin wall glTF means",
           mesh->name, label, (double)m->ior,
           s->media ? "the medium the geometry puts there" : "air");
  }
}

/* Builds the scene from the view; on failure *out stays NULL. */
static bbc_result build(bbc_scene **out, const loader *ld, const bbc__gltf_data *g) {
  bbc_scene *s = calloc(1, sizeof *s);
  if (!s) return fail(ld, BBC_ERR_OUT_OF_MEMORY, "out of memory");
  /* The path is informational; a longer one is kept cut rather than refused. */
  snprintf(s->path, sizeof s->path, "%s", ld->path);
  bbc_result r = load_geometry(ld, g, s);
  if (r == BBC_OK) r = load_lights(ld, g, s);
  if (r == BBC_OK) r = load_cameras(ld, g, s);
  if (r == BBC_OK) r = bbc__scene_media(s);
  if (r == BBC_OK) bbc__scene_planes(s);
  if (r == BBC_OK) volume_warnings(ld, g, s);
  for (uint32_t i = 0; r == BBC_OK && i < g->note_count; i++) warn(ld, "%s", g->notes[i]);
  if (r != BBC_OK) {
    bbc_scene_free(s);
    return r;
  }
  *out = s;
  return BBC_OK;
}

static loader make_loader(const char *path, const bbc_scene_options *options) {
  loader ld = {path, NULL, NULL, NULL, BBC_LIGHT_UNITS_FILE};
  if (options) {
    ld.error_fn = options->error_fn;
    ld.warning_fn = options->warning_fn;
    ld.user = options->user;
    ld.light_units = options->light_units;
  }
  return ld;
}

bbc_result bbc_scene_load(bbc_scene **out, const char *path, const bbc_scene_options *options) {
  loader ld = make_loader(path ? path : "(null)", options);
  if (out) *out = NULL;
  if (!out || !path)
    return fail(&ld, BBC_ERR_INVALID_ARGUMENT, "bbc_scene_load needs an output and a path");
  bbc__gltf_options gopts = {ld.error_fn, ld.user};
  bbc__gltf_data *g = NULL;
  bbc_result r = bbc__gltf_parse(&g, path, &gopts);
  if (r == BBC_OK) r = build(out, &ld, g);
  bbc__gltf_free(g);
  return r;
}

bbc_result bbc__scene_load_memory(bbc_scene **out, const void *bytes, size_t size, const char *name,
                                  const char *base_dir, const bbc_scene_options *options) {
  loader ld = make_loader(name ? name : "(memory)", options);
  if (out) *out = NULL;
  if (!out || (!bytes && size > 0))
    return fail(&ld, BBC_ERR_INVALID_ARGUMENT, "bbc__scene_load_memory needs an output and data");
  bbc__gltf_options gopts = {ld.error_fn, ld.user};
  bbc__gltf_data *g = NULL;
  bbc_result r = bbc__gltf_parse_memory(&g, bytes, size, ld.path, base_dir, &gopts);
  if (r == BBC_OK) r = build(out, &ld, g);
  bbc__gltf_free(g);
  return r;
}

bbc_result bbc__scene_adopt_geometry(bbc_scene *s, float *positions, float *normals, float *uvs,
                                     uint32_t *indices) {
  free(s->positions);
  free(s->normals);
  free(s->uvs);
  free(s->indices);
  s->positions = positions;
  s->normals = normals;
  s->uvs = uvs;
  s->indices = indices;
  bbc_result r = find_emitters(s);
  if (r == BBC_OK) r = bbc__scene_media(s);
  if (r == BBC_OK) bbc__scene_planes(s);
  return r;
}

void bbc_scene_free(bbc_scene *scene) {
  if (!scene) return;
  free(scene->positions);
  free(scene->normals);
  free(scene->uvs);
  free(scene->indices);
  free(scene->triangle_mesh);
  free(scene->meshes);
  free(scene->materials);
  for (uint32_t i = 0; i < scene->texture_count; i++) {
    free(scene->textures[i].rgb);
    free(scene->textures[i].alpha);
  }
  free(scene->textures);
  free(scene->point_lights);
  free(scene->emitters);
  free(scene->emitter_cdf);
  bbc__camera_motion_free(scene->camera_motion, scene->camera_count);
  free(scene->cameras);
  free(scene->media);
  free(scene);
}
