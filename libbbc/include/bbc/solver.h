/* Solving inside a tuple (paper Sec. 6.1, DESIGN 3.10): given the light x0, the
 * specular triangle(s) of a tuple and a shading point x_k on its receiver, find the
 * admissible specular paths x0 -> x1 (-> x2) -> x_k.
 *
 *  - Single scattering (R, T): specular polynomials [Fan et al. 2024]. The specular
 *    constraint at x1 becomes two bivariate polynomials in u1 = (u, v); their resultant
 *    with respect to one of the two (the other is the hidden variable) is a univariate
 *    polynomial whose roots on [0, 1] are isolated in the Bernstein basis; the other
 *    coordinate follows by back-substitution; a few Newton steps on the exact constraint
 *    polish each root; spurious roots are rejected. This finds every solution up to the
 *    numerical limits discussed in solver_poly.c. A mirror whose three vertex normals
 *    are equal (one normal everywhere) is solved in closed form instead: reflection is
 *    then an affine map, and x1 a root of a quadratic.
 *  - Any chain, in particular double scattering (RR, RT, TR, TT): Newton's method with
 *    u1 as the only unknown, later vertices traced, and the half-vector constraint at the
 *    last specular vertex as the residual (see solver_newton.c for why this
 *    formulation); u1 is clamped back onto T1 when it leaves it by more than 1e-6 (Li et
 *    al., supplement); x2 follows the trace and is only checked at the end. For length
 *    2, a start from which this ends where its residual is singular (the path meets
 *    T2's plane behind x1, or x1 and x2 meet on a shared edge) gets a second run on the
 *    constraints of both vertices over (u1, u2), from u1 and T2's centre, both clamped.
 *    It finds at most one solution per start: from the triangle centre (deterministic,
 *    may miss solutions) or from a caller-supplied start (so an unbiased
 *    reciprocal-probability estimator in the manner of specular manifold sampling can be
 *    built on top: the outcome is a deterministic function of the start).
 *
 * Every solution is verified by tracing its exact path with bbc_specular_path_trace and
 * comes with that path: vertices, receiver barycentrics and the exact irradiance E_k
 * (Fresnel and visibility excluded; the caller adds them).
 *
 * All functions are reentrant and allocate nothing (a few constant interpolation tables
 * are filled once per process, under call_once): any number of threads may call them at
 * once, each with its own stats, if any. */
#ifndef BBC_SOLVER_H
#define BBC_SOLVER_H

#include "bbc/specular_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A buffer of this many solutions always holds every solution the single-scattering
 * solver can return: Bezout's bound on its two polynomials is 2 x 6 = 12, and a refracting
 * triangle whose plane the light nearly touches is solved once for each side. */
#define BBC_SOLVER_MAX_SOLUTIONS 24

/* One admissible path reaching the shading point. */
typedef struct bbc_solution {
  double u1[2];           /* barycentrics of x1 on T1 */
  double u2[2];           /* barycentrics of x2 on T2 (double scattering; else 0) */
  bbc_vec3 x1, x2;        /* the specular vertices (x2 only for double scattering) */
  double irradiance;      /* E_k of the path, = path.irradiance (may be +inf exactly at a
                             focal point) */
  int iterations;         /* Newton iterations spent on this solution */
  bbc_specular_path path; /* the exact path through u1 (x_k on the receiver's plane) */
} bbc_solution;

/* Counters, added to by the solvers when options->stats is non-NULL. */
typedef struct bbc_solver_stats {
  uint64_t solves;          /* calls */
  uint64_t resultant_roots; /* roots of the univariate resultant in the v range */
  uint64_t candidates;      /* (u, v) candidates after back-substitution */
  uint64_t newton_iterations;
  uint64_t rejected_not_converged; /* Newton diverged, stalled (e.g. clamped on an edge
                                      while the root lies beyond it) or hit TIR */
  uint64_t rejected_inadmissible;  /* converged, but on a wrong branch: wrong side,
                                      backward, not reaching x_k */
  uint64_t duplicates;             /* converged onto an already accepted solution */
  uint64_t fallbacks;              /* degenerate resultant: Newton from seeds instead */
  uint64_t solutions;
  uint64_t excluded; /* calls bbc_solver_single_possible answered without a solve */
} bbc_solver_stats;

/* Options; a zero-initialised struct (or NULL) means the defaults. */
typedef struct bbc_solver_options {
  double triangle_tolerance; /* a solution may lie this far outside its triangle, in
                                barycentric units; 0 = 1e-9 */
  double angle_tolerance;    /* a verified path may miss x_k by this angle at its last
                                specular vertex (radians); 0 = 1e-7 */
  int max_iterations;        /* Newton iterations per start (also when polishing the
                                polynomial solver's roots); 0 = 30 */
  bbc_solver_stats *stats;   /* optional counters; not synchronised */
  int no_closed_form;        /* bbc_solver_single: solve a mirror with three equal vertex
                                normals by the polynomials too, not in closed form (for
                                comparisons) */
  int no_pretest;            /* bbc_solver_single: solve even where
                                bbc_solver_single_possible says no path exists (for
                                tests) */
} bbc_solver_options;

/* Traces the exact path through u1 = (u, v) and decides whether it is an admissible
 * solution for the shading point xk: the trace completes, the light arrives on the
 * reflecting side, every hit lies ahead of its ray, u1 and (for length 2) u2 lie in
 * their triangles up to triangle_tolerance, and the last segment points at xk up to
 * angle_tolerance. The receiver-inside flag is ignored (xk is given). Fills *out (when
 * non-NULL) with the path either way and returns 1 if admissible, else 0 (also for NULL
 * g or a bad length). */
BBC_API int bbc_solver_verify(const bbc_path_geometry *g, bbc_vec3 xk, double u, double v,
                              const bbc_solver_options *options, bbc_solution *out);

/* All admissible single-scattering paths from g->light through T1 = g->specular[0] to
 * the shading point xk (g->length must be 1). The receiver triangle g->receiver gives
 * the plane on which the irradiance is measured; xk should lie on it (a shading point),
 * a point slightly off it is projected along the path. Writes at most `capacity`
 * solutions (BBC_SOLVER_MAX_SOLUTIONS is always enough) to out, sorted by u1 and free of
 * duplicates, and their number to *count (0 when no path exists).
 * BBC_ERR_INVALID_ARGUMENT for NULL pointers (out may be NULL when capacity is 0), a
 * length other than 1, or a non-finite xk. */
BBC_API bbc_result bbc_solver_single(const bbc_path_geometry *g, bbc_vec3 xk,
                                     const bbc_solver_options *options, bbc_solution *out,
                                     size_t capacity, size_t *count);

/* A cheap exact test run by bbc_solver_single before it solves: returns 0 when no
 * single-scattering path from g->light through T1 can reach xk, 1 when one may (also
 * for length 2). Every specular path is coplanar with the normal at x1, so
 * C(u1) = ((x1 - x0) x (xk - x0)) . n(u1) (for a sun of direction D,
 * (D x (xk - x1)) . n(u1)), a quadratic on T1 (a product of two affine functions),
 * vanishes at its x1; when the six Bernstein coefficients of C on T1 (grown
 * by the triangle tolerance) share a sign beyond a rounding margin, C has no root there
 * and no path exists. Exact up to that margin (1e-9 of the coefficients' scale).
 * For a reflection, the reflected direction r = (n.n) d0 - 2 (d0.n) n (d0 = x1 - x0)
 * must also be parallel to d1 = xk - x1: the three components of r x d1, of degree 4 on
 * T1, vanish together at x1. When one of them keeps a sign on T1 (grown), or on each of
 * its pieces split up to twice into four, beyond the verifier's angle tolerance times
 * the bound 3 |n|^2 |d0| |d1| of |r| |d1|, no path exists either: a path the verifier
 * would accept has |r x d1| below that. bbc_solver_single skips this second half for
 * mirrors solved in closed form. For a refraction whose d0 . n keeps one sign s on T1
 * (which fixes the trace's eta), a path also needs s (d1 . n) > 0 (the ray goes on
 * through) and Snell's law squared, G = eta^2 |d0 x n|^2 |d1|^2 - |d1 x n|^2 |d0|^2 = 0
 * (degree 6); when on T1 (grown), or on each of its four halves, the coplanarity C or G
 * keeps a sign or s (d1 . n) stays negative beyond the verifier's angle tolerance times
 * 2 |d0| |d1| |n|, 2 |d1| |n| and 4 |n|^2 |d0|^2 |d1|^2 (bounds of |C|, of the side's
 * slack and of |G| at a path the verifier would accept), no path exists. */
BBC_API int bbc_solver_single_possible(const bbc_path_geometry *g, bbc_vec3 xk,
                                       const bbc_solver_options *options);

/* Newton's method on the chain from the start u1_init (barycentrics on T1; later vertices
 * are traced, so they need no start). On convergence to an admissible path that reaches
 * xk, fills *out and sets *found = 1; otherwise *found = 0 (out may then hold partial
 * data). Works for length 1 and 2. The result depends only on the arguments, so a caller
 * drawing random starts from a known density can count trials until a given solution
 * reappears (reciprocal probability estimation). BBC_ERR_INVALID_ARGUMENT for NULL
 * pointers, a bad length or non-finite inputs. */
BBC_API bbc_result bbc_solver_newton(const bbc_path_geometry *g, bbc_vec3 xk,
                                     const double u1_init[2], const bbc_solver_options *options,
                                     bbc_solution *out, int *found);

/* bbc_solver_newton started from T1's centre (1/3, 1/3): deterministic, free of variance,
 * and biased where it misses solutions (paper Sec. 6.1, "Det"). */
BBC_API bbc_result bbc_solver_newton_centre(const bbc_path_geometry *g, bbc_vec3 xk,
                                            const bbc_solver_options *options, bbc_solution *out,
                                            int *found);

#ifdef __cplusplus
}
#endif

#endif
