/* The receivers' reflectance: Lambertian, or glTF 2.0's metallic-roughness BRDF.
 *
 * A receiver (BBC_MATERIAL_DIFFUSE) with metallic 0 and roughness 1 (glTF's defaults,
 * what exporters write for a matte surface) is Lambertian, f = base / pi, as before
 * glossy receivers existed. Any other receiver is glossy, with the BRDF of the glTF 2.0
 * specification (Appendix B), evaluated exactly (no approximation beyond the model):
 *
 *   f = (1 - metallic) [(1 - F_d) base / pi + F_d D Vis] + metallic F_m D Vis,
 *   F_d = 0.04 + 0.96 (1 - |wo.h|)^5, F_m = base + (1 - base)(1 - |wo.h|)^5 (Schlick),
 *   D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2)   (GGX / Trowbridge-Reitz, a = roughness^2),
 *   Vis = 1 / (2 (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2)))
 *         (Smith's height-correlated masking-shadowing, G / (4 n.l n.v)),
 *
 * with h the half vector of wo and wi. Roughness below BBC_BSDF_MIN_ROUGHNESS is raised
 * to it (the loader warns): a smooth coat is a specular receiver, which the caustic
 * estimator does not handle. The BRDF is the same for the caustic estimator (at the
 * solved light direction) and the path tracer (next-event estimation and bounces). */
#ifndef BBC_BSDF_H
#define BBC_BSDF_H

#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

#define BBC_BSDF_MIN_ROUGHNESS 0.05

/* The reflectance of one surface point. */
typedef struct bbc_bsdf {
  double base[3]; /* linear base colour (with the texture) */
  int glossy;     /* 0: Lambertian, base / pi */
  double metallic;
  double alpha;   /* GGX width, roughness^2 */
} bbc_bsdf;

/* The BSDF of scene triangle `triangle` at barycentrics b1, b2 (base colour from
 * bbc_scene_base_color). */
BBC_API void bbc_bsdf_at(const bbc_scene *scene, uint32_t triangle, double b1, double b2,
                         bbc_bsdf *out);

/* f(wo, wi) per RGB channel (1/sr, without the cosine) for the unit shading normal n,
 * the unit direction wo toward the viewer and wi toward the light; zero when either
 * lies below the surface (n.wo <= 0 or n.wi <= 0). */
BBC_API void bbc_bsdf_eval(const bbc_bsdf *bsdf, bbc_vec3 n, bbc_vec3 wo, bbc_vec3 wi,
                           double f[3]);

/* The density (per solid angle) with which bbc_bsdf_sample draws wi. */
BBC_API double bbc_bsdf_pdf(const bbc_bsdf *bsdf, bbc_vec3 n, bbc_vec3 wo, bbc_vec3 wi);

/* Draws wi from uniforms u_lobe, u[0], u[1] in [0, 1): Lambertian surfaces by the cosine;
 * glossy ones from a mixture of the cosine and GGX half vectors (density D(h) n.h),
 * the latter chosen with probability (1 + metallic) / 2. Returns the weight
 * f cos / pdf per channel in weight (zero when wi falls below the surface). */
BBC_API void bbc_bsdf_sample(const bbc_bsdf *bsdf, bbc_vec3 n, bbc_vec3 wo, double u_lobe,
                             const double u[2], bbc_vec3 *wi, double weight[3]);

#ifdef __cplusplus
}
#endif

#endif
