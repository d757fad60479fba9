/* Exact specular paths: from a point light through one or two specular triangles (a
 * chain of reflections and refractions) to a receiver triangle, parameterised by the
 * barycentrics u1 = (u, v) of the first specular vertex (paper Sec. 3 and 4.3), with the
 * irradiance the path carries (Sec. 4.4, Eq. 14-16) and its exact derivatives.
 *
 * This is the ground truth the rest of bbc is checked against and built on: the bound
 * validation traces it at sampled u1 and checks that the bounds hold, the solvers
 * (solver.h) polish and verify their roots with it, and the renderer takes the
 * irradiance of every solution from it. It uses the exact normalised reflection and
 * refraction formulas in double precision, not the rational forms of Eq. 9-13, so it is
 * an independent oracle for them.
 *
 * Conventions.
 *   - Barycentrics (u, v) put a point at p0 + u (p1 - p0) + v (p2 - p0) (Eq. 6).
 *   - The shading normal at (u, v) is the normalised interpolation
 *     n(u, v) = (1 - u - v) n0 + u n1 + v n2 (Eq. 7, normalised). Eq. 10 keeps it
 *     unnormalised; the directions it gives are the same.
 *   - Reflection: d' = d - 2 (d . n) n. The light must arrive on the side the shading
 *     normal points to (d . n < 0), otherwise the path is flagged BBC_PATH_BACK_SIDE.
 *   - Refraction: eta = n_incident / n_transmitted. The ray enters the material when it
 *     travels against the shading normal (d . n < 0): eta = 1 / ior; otherwise it leaves
 *     it: eta = ior. Either side is admissible. When 1 - eta^2 (1 - cos_i^2) < 0 there is
 *     no refracted ray (total internal reflection, BBC_PATH_TIR).
 *   - Every later vertex is the intersection of the ray with the *plane* of its
 *     triangle (so u_k is the rational function of Eq. 9 even outside the triangle);
 *     whether it falls inside is a flag, not a stop.
 *
 * Irradiance (Eq. 14-15, Fresnel and visibility excluded, both at most 1):
 *   E_k = I dOmega0/dA_k = I (dOmega0/du1) / (dA_k/du1), with
 *   dOmega0/du1 = |n1g . d0| |e11 x e12| / |d0|^3 (solid angle at the light per unit
 *   barycentric area; n1g T1's unit geometric normal, d0 = x1 - x0) and
 *   dA_k/du1 = |(dx_k/du x dx_k/dv) . n_kg| = |det(du_k/du1)| |e_k1 x e_k2| (Eq. 16).
 * The derivatives are computed in forward mode with dual numbers carrying d/du and
 * d/dv beside every value: exact up to rounding, no finite differences.
 *
 * All functions here are pure: they read their arguments only, keep no state and may be
 * called from any number of threads at once. */
#ifndef BBC_SPECULAR_PATH_H
#define BBC_SPECULAR_PATH_H

#include "bbc/scene.h"
#include "bbc/tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One specular triangle of a chain. */
typedef struct bbc_specular_triangle {
  bbc_vec3 p[3]; /* vertex positions p_{i,0..2} */
  bbc_vec3 n[3]; /* vertex normals n_{i,0..2}; need not be unit length, but their
                    interpolation must not vanish inside the triangle */
  int refract;   /* 0: mirror reflection (R), 1: refraction (T) */
  double ior;    /* refraction only: index of the material behind the normals relative
                    to the medium in front of them (1.5 for glass in air) */
} bbc_specular_triangle;

/* The geometry of a chain: a point light, 1 or 2 specular triangles in light-to-receiver
 * order and the receiver triangle. A plain struct; fill it with bbc_path_geometry_init or
 * by hand for synthetic set-ups. */
typedef struct bbc_path_geometry {
  bbc_vec3 light;   /* x0 */
  double intensity; /* I (W/sr); bbc_path_geometry_init sets 1, so the irradiance is per
                       unit intensity and the renderer scales it by the light's RGB */
  int length;       /* number of specular vertices: 1 or 2 */
  bbc_specular_triangle specular[2]; /* T1 and, for length 2, T2 */
  bbc_vec3 receiver[3];              /* Tk's vertex positions */
  /* The light's kind (scene.h; zero: a point light). A sun (directional) sends the
   * parallel light d0 = light_model.direction (unit) from infinity, `light` is unused,
   * intensity is an irradiance (W/m^2) on a surface facing the sun, and domega_du becomes
   * the beam's cross-section per unit barycentric area |n1g . d0| |e11 x e12|. A spot
   * multiplies the irradiance by bbc_light_falloff in the direction of d0. */
  bbc_light_model light_model;
} bbc_path_geometry;

/* Fills g from a scene tuple of any chain type (R, T, RR, RT, TR, TT): positions and
 * vertex normals as loaded, refraction from the chain type, ior from the material,
 * intensity 1.
 *
 * Mirrors in the scene are two-sided (the path tracer reflects on whichever side a ray
 * arrives), so the normals of a *reflecting* triangle are turned to face its incoming
 * light: T1's toward the side of its plane the light is on (the rule the bounds of
 * bounds.h use), T2's toward the side T1's centroid is on. The normals of refracting
 * triangles are never turned: they say which side is outside.
 * BBC_ERR_INVALID_ARGUMENT for NULL pointers, an unknown chain type, out-of-range
 * indices or a missing second triangle. */
BBC_API bbc_result bbc_path_geometry_init(bbc_path_geometry *g, const bbc_scene *scene,
                                          const bbc_tuple *tuple);

/* Why a traced path is not an admissible specular path (bit flags, several may be set).
 * The values are fixed. */
typedef enum bbc_path_flag {
  BBC_PATH_OUTSIDE_T1 = 1u << 0,       /* u1 is not in T1 (u < 0, v < 0 or u + v > 1) */
  BBC_PATH_BACK_SIDE = 1u << 1,        /* at a reflecting vertex the light arrives from
                                          behind the shading normal (d . n >= 0) */
  BBC_PATH_TIR = 1u << 2,              /* total internal reflection at a refracting vertex:
                                          the trace stops there */
  BBC_PATH_BACKWARD = 1u << 3,         /* a later vertex lies behind the ray (t <= 0) */
  BBC_PATH_OUTSIDE_T2 = 1u << 4,       /* x2 is not inside T2 */
  BBC_PATH_OUTSIDE_RECEIVER = 1u << 5, /* x_k is not inside the receiver triangle */
  BBC_PATH_DEGENERATE = 1u << 6,       /* x1 = x0, a vanishing normal, or a ray parallel
                                          to the next plane: the trace stops there */
  BBC_PATH_GEOMETRIC_SIDE = 1u << 7,   /* informational, not part of BBC_PATH_REJECT: the
                                          shading normal disagrees with the geometric one
                                          about the side a ray arrives from or leaves to
                                          (the path tracer absorbs such paths) */
  BBC_PATH_OUTSIDE_CONE = 1u << 8      /* a spot light's falloff is 0 along d0 */
} bbc_path_flag;

/* The flags that make a path inadmissible. */
#define BBC_PATH_REJECT                                                          \
  (BBC_PATH_OUTSIDE_T1 | BBC_PATH_BACK_SIDE | BBC_PATH_TIR | BBC_PATH_BACKWARD | \
   BBC_PATH_OUTSIDE_T2 | BBC_PATH_OUTSIDE_RECEIVER | BBC_PATH_DEGENERATE | BBC_PATH_OUTSIDE_CONE)

/* A traced path. Fields of vertices the trace did not reach (after BBC_PATH_TIR or
 * BBC_PATH_DEGENERATE, or x2 of a one-vertex chain) are zero; `complete` says whether
 * x_k and everything after it were computed. */
typedef struct bbc_specular_path {
  uint32_t flags;          /* bbc_path_flag bits; admissible iff (flags & BBC_PATH_REJECT) == 0 */
  int complete;            /* 1 if the trace reached the receiver's plane */
  int length;              /* number of specular vertices, 1 or 2 */
  bbc_vec3 x0, x1, x2, xk; /* vertices (x2 only for length 2) */
  double u1[2], u2[2], uk[2]; /* barycentrics of x1, x2 (length 2) and x_k */
  bbc_vec3 n1, n2;            /* unit shading normals at x1, x2 as given (not turned
                                 toward the ray) */
  double du2[2][2];           /* d u2 / d u1 (length 2): du2[r][c] = d(u2, v2)[r] / d(u, v)[c] */
  double duk[2][2];           /* d u_k / d u1, same layout: the receiver barycentric derivatives */
  double dxk[2][3];           /* d x_k / du and d x_k / dv (world space) */
  double jacobian;            /* |det(d u_k / d u1)| (Eq. 16) */
  double domega_du;           /* dOmega0/du1 = |n1g . d0| |e11 x e12| / |d0|^3 (a sun:
                                 |n1g . d0| |e11 x e12| with unit d0) */
  double darea_du;            /* dA_k/du1 = |(dx_k/du x dx_k/dv) . n_kg| */
  double irradiance;          /* E_k = I falloff domega_du / darea_du; +inf where darea_du = 0 (a focal
                                 point); 0 if the path is not complete */
} bbc_specular_path;

/* Traces the path of g through u1 = (u, v) and fills *out. The trace runs for any (u, v),
 * also outside T1, so bounds can be checked on pieces that stick out of the triangle;
 * admissibility is reported in out->flags. BBC_ERR_INVALID_ARGUMENT for NULL pointers, a
 * length other than 1 or 2, or non-finite (u, v); *out is then zeroed when non-NULL. */
BBC_API bbc_result bbc_specular_path_trace(const bbc_path_geometry *g, double u, double v,
                                           bbc_specular_path *out);

/* The barycentrics of the projection of point x onto the plane of triangle p[0..2],
 * in the convention above. Returns 0 for a degenerate triangle, else 1. */
BBC_API int bbc_triangle_barycentrics(const bbc_vec3 p[3], bbc_vec3 x, double out[2]);

#ifdef __cplusplus
}
#endif

#endif
