/* Verification of a solved specular path (bbc_solver_verify, solver.h): the exact trace
 * of specular_path.c from the solved barycentrics must be complete, inside its triangles
 * up to the triangle tolerance, and end at x_k up to the angle tolerance. Every solver's
 * candidate passes through it, so a wrong root is never counted. */
#include <math.h>
#include <string.h>

#include "bbc/solver.h"
#include "bbc/specular_path.h"
#include "solver_internal.h"
#include "vec_internal.h"

int bbc_solver_verify(const bbc_path_geometry *g, bbc_vec3 xk, double u, double v,
                      const bbc_solver_options *options, bbc_solution *out) {
  bbc_solution local;
  bbc_solution *s = out ? out : &local;
  memset(s, 0, sizeof *s);
  if (!g || (g->length != 1 && g->length != 2)) return 0;
  if (bbc_specular_path_trace(g, u, v, &s->path) != BBC_OK) return 0;
  const bbc_specular_path *p = &s->path;
  s->u1[0] = u, s->u1[1] = v;
  s->x1 = p->x1;
  if (g->length == 2) {
    s->u2[0] = p->u2[0], s->u2[1] = p->u2[1];
    s->x2 = p->x2;
  }
  s->irradiance = p->irradiance;
  if (!p->complete) return 0;
  /* Inside tests get a tolerance here instead of the trace's exact ones; x_k is given, so
   * whether it lies in the receiver triangle is the caller's business. */
  uint32_t hard = BBC_PATH_REJECT & ~(uint32_t)(BBC_PATH_OUTSIDE_T1 | BBC_PATH_OUTSIDE_T2 |
                                                BBC_PATH_OUTSIDE_RECEIVER);
  if (p->flags & hard) return 0;
  double tol = bbc__solver_triangle_tolerance(options);
  if (!(u >= -tol && v >= -tol && u + v <= 1 + tol)) return 0;
  if (g->length == 2 && !(p->u2[0] >= -tol && p->u2[1] >= -tol && p->u2[0] + p->u2[1] <= 1 + tol))
    return 0;
  /* The last segment must point at x_k: compare directions from the last specular
   * vertex, which is robust to grazing receivers and to x_k slightly off the plane. */
  bbc_vec3 last = g->length == 2 ? p->x2 : p->x1;
  bbc_vec3 a = v3_sub(p->xk, last), b = v3_sub(xk, last);
  double la = v3_length(a), lb = v3_length(b);
  if (!(la > 0 && lb > 0) || v3_dot(a, b) <= 0) return 0;
  double sine = v3_length(v3_cross(a, b)) / (la * lb);
  return sine <= bbc__solver_angle_tolerance(options);
}
