/* What the solvers share (solver_poly.c, solver_newton.c, solver_verify.c): the
 * tolerances of bbc_solver_options with their defaults (solver.h). */
#ifndef BBC_SOLVER_INTERNAL_H
#define BBC_SOLVER_INTERNAL_H

#include "bbc/solver.h"

static inline double bbc__solver_triangle_tolerance(const bbc_solver_options *o) {
  return o && o->triangle_tolerance > 0 ? o->triangle_tolerance : 1e-9;
}
static inline double bbc__solver_angle_tolerance(const bbc_solver_options *o) {
  return o && o->angle_tolerance > 0 ? o->angle_tolerance : 1e-7;
}

#endif
