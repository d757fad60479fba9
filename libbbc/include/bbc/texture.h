/* Textures: what a receiver's albedo, metallic and roughness are at a surface point, and
 * how much of a surface is there (glTF alphaMode MASK and BLEND).
 *
 * A texture is sampled where the triangle's interpolated TEXCOORD_0, mapped by the
 * material's KHR_texture_transform, falls: each coordinate is wrapped by the sampler's
 * mode (bbc_wrap), then the texel containing it is taken (magFilter NEAREST) or the four
 * nearest texel centres are blended bilinearly (LINEAR, and when the sampler says
 * nothing). There are no mipmaps: minification is the renderer's pixel supersampling,
 * so a texture much finer than a pixel converges to its mean over the pixel instead of
 * being prefiltered. */
#ifndef BBC_TEXTURE_H
#define BBC_TEXTURE_H

#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* sRGB-encoded value in [0, 1] to linear (IEC 61966-2-1: c / 12.92 up to 0.04045,
 * ((c + 0.055) / 1.055)^2.4 above). */
BBC_API double bbc_srgb_to_linear(double c);

/* The linear RGB of a texture at texture coordinates (s, t) (s across, t down from the
 * top row). Non-finite coordinates read as 0. */
BBC_API void bbc_texture_lookup(const bbc_texture *texture, double s, double t, double out[3]);

/* The base colour (the diffuse albedo, and the glossy model's base colour) of scene
 * triangle `triangle` at barycentrics b1, b2 of its vertices 1 and 2: the material's
 * base_color, times its texture at the interpolated, transformed TEXCOORD_0 when it has
 * one. */
BBC_API void bbc_scene_base_color(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                                  double out[3]);

/* The metallic and roughness of a receiver triangle at barycentrics b1, b2: the
 * material's factors, times the B and G channels of its metallicRoughnessTexture at the
 * point when it has one (bilinear, as base colours; roughness is not yet raised to
 * BBC_BSDF_MIN_ROUGHNESS). */
BBC_API void bbc_scene_metallic_roughness(const bbc_scene *scene, uint32_t triangle, double b1,
                                          double b2, double *metallic, double *roughness);
/* The emitted radiance (W/sr/m^2 per channel) of scene triangle `triangle` at
 * barycentrics b1, b2: its material's emission (emissiveFactor times
 * KHR_materials_emissive_strength), times its emissiveTexture there when it has one.
 * The texture is at most 1, so the material's emission bounds it everywhere (the
 * emitters' sampling and the cached area lights' bounds use that). */
BBC_API void bbc_scene_emission(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                                double out[3]);

/* The alpha channel of a texture at (s, t), looked up like its colour (same wrap modes and
 * filter); 1 when the texture has no alpha channel (bbc_texture.alpha is NULL). */
BBC_API double bbc_texture_lookup_alpha(const bbc_texture *texture, double s, double t);

/* The glTF alpha of scene triangle `triangle` at barycentrics b1, b2 (as for
 * bbc_scene_base_color): its material's baseColorFactor alpha, times its base colour
 * texture's alpha channel there when it has one. Whatever the alpha mode. */
BBC_API double bbc_scene_alpha(const bbc_scene *scene, uint32_t triangle, double b1, double b2);

/* How much of scene triangle `triangle` is there at barycentrics b1, b2, in [0, 1]: 1 for
 * BBC_ALPHA_OPAQUE materials; for BBC_ALPHA_MASK 1 where bbc_scene_alpha >= the material's
 * alpha_cutoff and 0 where the point is cut out; for BBC_ALPHA_BLEND the alpha clamped to
 * [0, 1], the probability that a ray meeting the surface there stops at it. Every ray
 * query (bbc_accel_intersect, bbc_accel_occluded) and every specular vertex of a caustic
 * path applies it. */
BBC_API double bbc_scene_coverage(const bbc_scene *scene, uint32_t triangle, double b1,
                                  double b2);

/* Whether bbc_scene_coverage can be below 1 somewhere on a triangle of material m: a MASK
 * or BLEND material with a texture alpha channel, or whose factor alone makes it so. A
 * closed mesh of such a material does not enclose what is inside it: light leaves
 * through its cut-outs. */
BBC_API int bbc_material_partial(const bbc_scene *scene, const bbc_material *m);

#ifdef __cplusplus
}
#endif

#endif
