/* The affine forms of a chain (paper Eq. 6-7): a vertex attribute interpolated over a
 * piece of a triangle's barycentrics, x = c + du u + dv v, as a Bernstein polynomial in
 * the piece's variables with the rounding of its set-up in the error radius. Shared by
 * the one- and two-bounce forms (chain.c, chain_double.c). */
#include <float.h>
#include <math.h>

#include "chain_internal.h"
#include "vec_internal.h"

#define TRY(expr)                \
  do {                           \
    bbc_result r_ = (expr);      \
    if (r_ != BBC_OK) return r_; \
  } while (0)

/* c + gs s + gt t per coordinate, widened by the rounding of c and the gradients, which
 * the caller computed in double from the exact float inputs. */
bbc_result bbc__chain_affine(bbc_arena *arena, bbc_poly3 *out, bbc_vec3 base, bbc_vec3 du,
                             bbc_vec3 dv, double u_lo, double v_lo, double su, double sv, int s_axis,
                             int t_axis) {
  bbc_vec3 c = v3_add(base, v3_add(v3_scale(du, u_lo), v3_scale(dv, v_lo)));
  bbc_vec3 grad[BBC_POLY_MAX_AXES] = {{0, 0, 0}};
  grad[s_axis] = v3_scale(du, su);
  grad[t_axis] = v3_scale(dv, sv);
  TRY(bbc_poly3_affine(arena, out, c, grad));
  /* Each coordinate of c is a sum of three rounded terms; 4 ulps of the magnitudes
   * cover it, and of the gradients (products by powers of two are exact, by other
   * scales one rounding). */
  double radius[3] = {4 * DBL_EPSILON * (fabs(base.x) + fabs(du.x * u_lo) + fabs(dv.x * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].x) + fabs(grad[t_axis].x)),
                      4 * DBL_EPSILON * (fabs(base.y) + fabs(du.y * u_lo) + fabs(dv.y * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].y) + fabs(grad[t_axis].y)),
                      4 * DBL_EPSILON * (fabs(base.z) + fabs(du.z * u_lo) + fabs(dv.z * v_lo)) +
                          2 * DBL_EPSILON * (fabs(grad[s_axis].z) + fabs(grad[t_axis].z))};
  bbc_poly_widen(&out->x, radius[0]);
  bbc_poly_widen(&out->y, radius[1]);
  bbc_poly_widen(&out->z, radius[2]);
  return BBC_OK;
}
