/* Newton's method on the specular chain (paper Sec. 6.1 "Root-finding"; DESIGN 3.10),
 * mainly for double scattering, where specular polynomials become impractical (the
 * slides' bivariate degrees reach 18 and 48 for TT). See bbc/solver.h.
 *
 * The constraint. At a specular vertex x with neighbours x_prev and x_next, unit
 * directions w_i = (x_prev - x)/|.| and w_o = (x_next - x)/|.| and unit shading normal n,
 * the law of reflection and Snell's law both say that the generalised half-vector
 * h = eta_i w_i + eta_o w_o is parallel to n (eta_i = eta_o = 1 for reflection; for
 * refraction the indices of the two sides, the light's side judged by the sign of w_i . n
 * as in bbc_specular_path_trace). The constraint is h x n = 0, of which two components are
 * independent: we take its projections on an orthonormal basis (g1, g2) of the
 * triangle's plane, which vanish together only when h x n = 0, because h x n is
 * orthogonal to n and n never lies in that plane.
 *
 * The unknowns ("reduced" formulation). Only u1 is unknown. Every later specular vertex
 * follows by tracing the exact path from x0 through u1 (as the manifold walks of specular
 * manifold sampling do), so the constraints at all vertices but the last hold by
 * construction, and the residual is the half-vector constraint at the last specular
 * vertex, toward x_k. Its Jacobian with respect to u1 comes from dual numbers (one slot
 * per barycentric of x1 and of x2) and the chain rule through d u2 / d u1 of the trace.
 * Two alternatives were measured: Newton on all vertices' half-vector constraints over
 * (u1, u2) at once converged from the triangle centres for only 95 % of the generated
 * glass slab's TT paths (100 % here) and oscillated on a flat slab with large triangles;
 * Newton on where the traced path lands on the receiver (u_k(u1) - u_k*) runs through
 * the caustic's focusing and missed 2 % of plane1k's R paths (0 % here), and was dropped.
 * The first is kept as a second chance (full_newton): the reduced residual is singular
 * where the ray leaving x1 runs parallel to T2's plane (x2 passes through infinity), so
 * from a start whose ray meets that plane behind x1 the reduced iteration cannot reach a
 * root on the other side. In a corner of two flat mirrors most of T1 is such a start
 * (the centre too), and there the reduced form also stalls where x1 and x2 meet on the
 * shared edge. Only those failures get the second run (see bbc_solver_newton): on the
 * glass ball a second run after every failure costs 60 % more render time for 0.02 %
 * more solutions.
 *
 * Globalisation. Steps are limited to half a triangle and then halved until the
 * residual shrinks (backtracking); a u1 that leaves T1 is moved back to the triangle's
 * nearest point (Li et al., supplement, "Finding the reflector point within a
 * triangle"). The converged point must then pass bbc_solver_verify, which rejects the
 * wrong branches h || n also admits (the straight line through a mirror, refraction
 * back into the light's side). The dual numbers are a four-slot kind local to this
 * file; bbc_specular_path_trace uses its own two-slot kind. */
#include <math.h>
#include <string.h>

#include "bbc/solver.h"
#include "specular_path_internal.h"
#include "vec_internal.h"

#define NVAR 4

typedef struct dual4 {
  double v, d[NVAR];
} dual4;

typedef struct dvec4 {
  dual4 x, y, z;
} dvec4;

static inline dual4 q_const(double a) {
  dual4 r = {a, {0, 0, 0, 0}};
  return r;
}
static inline dual4 q_add(dual4 a, dual4 b) {
  dual4 r = {a.v + b.v, {0}};
  for (int i = 0; i < NVAR; i++) r.d[i] = a.d[i] + b.d[i];
  return r;
}
static inline dual4 q_sub(dual4 a, dual4 b) {
  dual4 r = {a.v - b.v, {0}};
  for (int i = 0; i < NVAR; i++) r.d[i] = a.d[i] - b.d[i];
  return r;
}
static inline dual4 q_mul(dual4 a, dual4 b) {
  dual4 r = {a.v * b.v, {0}};
  for (int i = 0; i < NVAR; i++) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
static inline dual4 q_scale(dual4 a, double s) {
  dual4 r = {a.v * s, {0}};
  for (int i = 0; i < NVAR; i++) r.d[i] = a.d[i] * s;
  return r;
}
/* 1 / sqrt(a) for a > 0 (the callers check). */
static inline dual4 q_rsqrt(dual4 a) {
  double s = 1.0 / sqrt(a.v);
  double ds = -0.5 * s / a.v;
  dual4 r = {s, {0}};
  for (int i = 0; i < NVAR; i++) r.d[i] = a.d[i] * ds;
  return r;
}

static inline dvec4 qv_add(dvec4 a, dvec4 b) {
  return (dvec4){q_add(a.x, b.x), q_add(a.y, b.y), q_add(a.z, b.z)};
}
static inline dvec4 qv_sub(dvec4 a, dvec4 b) {
  return (dvec4){q_sub(a.x, b.x), q_sub(a.y, b.y), q_sub(a.z, b.z)};
}
static inline dvec4 qv_mul(dvec4 a, dual4 s) {
  return (dvec4){q_mul(a.x, s), q_mul(a.y, s), q_mul(a.z, s)};
}
static inline dvec4 qv_scale(dvec4 a, double s) {
  return (dvec4){q_scale(a.x, s), q_scale(a.y, s), q_scale(a.z, s)};
}
static inline dual4 qv_dot(dvec4 a, dvec4 b) {
  return q_add(q_add(q_mul(a.x, b.x), q_mul(a.y, b.y)), q_mul(a.z, b.z));
}
static inline dual4 qv_dotc(dvec4 a, bbc_vec3 b) {
  return q_add(q_add(q_scale(a.x, b.x), q_scale(a.y, b.y)), q_scale(a.z, b.z));
}
static inline dvec4 qv_cross(dvec4 a, dvec4 b) {
  return (dvec4){q_sub(q_mul(a.y, b.z), q_mul(a.z, b.y)), q_sub(q_mul(a.z, b.x), q_mul(a.x, b.z)),
                 q_sub(q_mul(a.x, b.y), q_mul(a.y, b.x))};
}
static inline dvec4 qv_const(bbc_vec3 a) {
  return (dvec4){q_const(a.x), q_const(a.y), q_const(a.z)};
}

/* Returns 0 for a vanishing vector. */
static int qv_normalize(dvec4 a, dvec4 *out) {
  dual4 l2 = qv_dot(a, a);
  if (!(l2.v > 0) || !isfinite(l2.v)) return 0;
  *out = qv_mul(a, q_rsqrt(l2));
  return 1;
}

/* a0 + u (a1 - a0) + v (a2 - a0), with u and v the unknowns in slots su and su + 1. */
static dvec4 qv_affine(const bbc_vec3 a[3], double u, double v, int su) {
  bbc_vec3 e1 = v3_sub(a[1], a[0]), e2 = v3_sub(a[2], a[0]);
  bbc_vec3 val = v3_add(a[0], v3_add(v3_scale(e1, u), v3_scale(e2, v)));
  dvec4 r = qv_const(val);
  r.x.d[su] = e1.x, r.x.d[su + 1] = e2.x;
  r.y.d[su] = e1.y, r.y.d[su + 1] = e2.y;
  r.z.d[su] = e1.z, r.z.d[su + 1] = e2.z;
  return r;
}

/* An orthonormal basis of a triangle's plane. Returns 0 for a degenerate triangle. */
static int plane_basis(const bbc_specular_triangle *t, bbc_vec3 g[2]) {
  bbc_vec3 e1 = v3_sub(t->p[1], t->p[0]), e2 = v3_sub(t->p[2], t->p[0]);
  bbc_vec3 ng = v3_cross(e1, e2);
  if (!(v3_dot(ng, ng) > 0) || !(v3_dot(e1, e1) > 0)) return 0;
  g[0] = v3_normalize(e1);
  g[1] = v3_normalize(v3_cross(v3_normalize(ng), g[0]));
  return 1;
}

/* What one solve iterates on: the chain, the receiver point and each specular
 * triangle's plane basis (computed once per solve, not per evaluation). */
typedef struct newton_chain {
  const bbc_path_geometry *g;
  bbc_vec3 xk;
  bbc_vec3 basis[2][2];
  int basis_ok[2];
} newton_chain;

/* The two constraint values of one vertex with their derivatives (see the top). Returns
 * 0 where they are undefined (coincident vertices, vanishing normal). */
static int vertex_constraint(const newton_chain *q, int i, dvec4 prev, dvec4 x, dvec4 next,
                             dvec4 n, dual4 out[2]) {
  const bbc_specular_triangle *t = &q->g->specular[i];
  dvec4 wi, wo, nh;
  if (!qv_normalize(qv_sub(prev, x), &wi) || !qv_normalize(qv_sub(next, x), &wo) ||
      !qv_normalize(n, &nh))
    return 0;
  double ei = 1.0, eo = 1.0;
  if (t->refract) {
    int front = qv_dot(wi, nh).v > 0;
    ei = front ? 1.0 : t->ior;
    eo = front ? t->ior : 1.0;
  }
  dvec4 h = qv_add(qv_scale(wi, ei), qv_scale(wo, eo));
  dvec4 c = qv_cross(h, nh);
  if (!q->basis_ok[i]) return 0;
  out[0] = qv_dotc(c, q->basis[i][0]);
  out[1] = qv_dotc(c, q->basis[i][1]);
  return 1;
}

/* The vertex before x1: the light, or for a sun a point against its direction from x1,
 * so that x1 - x0 is its constant direction. */
static dvec4 light_vertex(const bbc_path_geometry *g, dvec4 x1) {
  if (g->light_model.kind == BBC_LIGHT_DIRECTIONAL) return qv_sub(x1, qv_const(g->light_model.direction));
  return qv_const(g->light);
}

/* Moves (u, v) to the nearest point of the triangle (in world-space distance, so the
 * result does not depend on the triangle's vertex order) if it lies outside by more than
 * CLAMP_MARGIN. The margin lets Newton reach a root just beyond an edge, which
 * bbc_solver_verify then accepts or rejects with its own, smaller tolerance. Returns 1
 * if it moved. */
#define CLAMP_MARGIN 1e-6
static int clamp_to_triangle(const bbc_specular_triangle *t, double *u, double *v) {
  const bbc_vec3 *p = t->p;
  if (*u >= -CLAMP_MARGIN && *v >= -CLAMP_MARGIN && *u + *v <= 1 + CLAMP_MARGIN) return 0;
  bbc_vec3 e1 = v3_sub(p[1], p[0]), e2 = v3_sub(p[2], p[0]), e3 = v3_sub(p[2], p[1]);
  bbc_vec3 q = v3_add(p[0], v3_add(v3_scale(e1, *u), v3_scale(e2, *v)));
  /* The nearest point of each edge, as barycentrics, and the closest of the three. */
  double cand[3][2];
  double s = v3_dot(v3_sub(q, p[0]), e1) / v3_dot(e1, e1);
  s = fmin(1, fmax(0, s));
  cand[0][0] = s, cand[0][1] = 0;
  s = v3_dot(v3_sub(q, p[0]), e2) / v3_dot(e2, e2);
  s = fmin(1, fmax(0, s));
  cand[1][0] = 0, cand[1][1] = s;
  s = v3_dot(v3_sub(q, p[1]), e3) / v3_dot(e3, e3);
  s = fmin(1, fmax(0, s));
  cand[2][0] = 1 - s, cand[2][1] = s;
  double best = INFINITY;
  int bi = 0;
  for (int i = 0; i < 3; i++) {
    bbc_vec3 c = v3_add(p[0], v3_add(v3_scale(e1, cand[i][0]), v3_scale(e2, cand[i][1])));
    bbc_vec3 d = v3_sub(c, q);
    double d2 = v3_dot(d, d);
    if (d2 < best) best = d2, bi = i;
  }
  *u = cand[bi][0];
  *v = cand[bi][1];
  return 1;
}

/* The reduced constraint: u1 is the only unknown, earlier vertices than the last follow
 * by tracing, and the residual is the half-vector constraint at the last specular vertex
 * (toward x_k). The trace stops at that vertex: how the traced ray would scatter there
 * and where it would land say nothing about the residual, and skipping them saves about
 * a tenth of a two-bounce render (the verification traces the whole path). Fills f (2
 * values) and jac (2 x 2, d f / d u1) and the traced path up to the last vertex. Returns
 * 0 where the trace breaks off before it or the constraint is undefined; p is only
 * filled for chains of length 2. */
static int reduced_constraint(const newton_chain *q, const double z[2], double f[2], double jac[4],
                              bbc_specular_path *p) {
  const bbc_path_geometry *g = q->g;
  const bbc_vec3 xk = q->xk;
  int last = g->length - 1;
  /* One vertex needs no trace: its neighbours are the light and x_k. */
  if (last > 0 && (bbc__specular_path_trace_to_last_vertex(g, z[0], z[1], p) != BBC_OK ||
                   !p->complete))
    return 0;
  dvec4 x1 = qv_affine(g->specular[0].p, z[0], z[1], 0);
  dual4 c[2];
  if (last == 0) {
    dvec4 n1 = qv_affine(g->specular[0].n, z[0], z[1], 0);
    if (!vertex_constraint(q, 0, light_vertex(g, x1), x1, qv_const(xk), n1, c)) return 0;
    for (int r = 0; r < 2; r++) {
      f[r] = c[r].v;
      jac[2 * r] = c[r].d[0], jac[2 * r + 1] = c[r].d[1];
    }
    return 1;
  }
  /* x2 and n2 in slots 2 and 3 (u2, v2), then the chain rule through d u2 / d u1. */
  dvec4 x2 = qv_affine(g->specular[1].p, p->u2[0], p->u2[1], 2);
  dvec4 n2 = qv_affine(g->specular[1].n, p->u2[0], p->u2[1], 2);
  if (!vertex_constraint(q, 1, x1, x2, qv_const(xk), n2, c)) return 0;
  for (int r = 0; r < 2; r++) {
    f[r] = c[r].v;
    for (int k = 0; k < 2; k++)
      jac[2 * r + k] = c[r].d[k] + c[r].d[2] * p->du2[0][k] + c[r].d[3] * p->du2[1][k];
  }
  return 1;
}

/* Damped Newton on the reduced constraint, u1 clamped into T1. Returns 1 when the steps
 * became negligible (converged), 0 when it stopped otherwise (no descent along the Newton
 * direction, a singular Jacobian, or the iteration limit), -1 when the constraint could
 * not be evaluated at the start. Either way z holds the last iterate, and the caller's
 * verification decides: near a fold of the caustic the Jacobian is nearly singular, the
 * residual's rounding floor turns into steps that cannot lower it, and yet z is the root
 * to the precision the data allow. */
static int reduced_newton(const newton_chain *q, double z[2], int max_it, int *iterations) {
  const bbc_path_geometry *g = q->g;
  clamp_to_triangle(&g->specular[0], &z[0], &z[1]);
  double f[2], jac[4];
  bbc_specular_path p;
  if (!reduced_constraint(q, z, f, jac, &p)) return -1;
  double norm = fabs(f[0]) + fabs(f[1]);
  for (int it = 0; it < max_it; it++) {
    *iterations = it + 1;
    if (norm == 0) return 1;
    double det = jac[0] * jac[3] - jac[1] * jac[2];
    if (!(det != 0) || !isfinite(det)) return 0;
    double du = -(jac[3] * f[0] - jac[1] * f[1]) / det;
    double dv = -(jac[0] * f[1] - jac[2] * f[0]) / det;
    if (!isfinite(du) || !isfinite(dv)) return 0;
    double len = fabs(du) + fabs(dv);
    /* The residual's rounding floor depends on the geometry (directions over short
     * segments are only as precise as the positions), so convergence is judged by the
     * step: a correction this small is below what the data can resolve. */
    if (len <= 1e-13) return 1;
    if (len > 0.5) du *= 0.5 / len, dv *= 0.5 / len;
    double lambda = 1, zn[2], fn[2], jn[4];
    int accepted = 0;
    for (int k = 0; k < 12 && !accepted; k++, lambda *= 0.5) {
      zn[0] = z[0] + lambda * du, zn[1] = z[1] + lambda * dv;
      clamp_to_triangle(&g->specular[0], &zn[0], &zn[1]);
      if (!reduced_constraint(q, zn, fn, jn, &p)) continue;
      double nn = fabs(fn[0]) + fabs(fn[1]);
      /* A step at rounding level need not lower the residual. */
      if (nn < norm || lambda * len <= 1e-12) accepted = 1, norm = nn;
    }
    /* No lower residual along the Newton direction: converged if the correction is tiny
     * (the rounding floor); else stuck, at a local minimum of the residual (e.g. against
     * an edge with the root beyond it) or on the rounding floor near a fold. */
    if (!accepted) return len <= 1e-9 ? 1 : 0;
    double step = fabs(zn[0] - z[0]) + fabs(zn[1] - z[1]);
    z[0] = zn[0], z[1] = zn[1];
    memcpy(f, fn, sizeof f);
    memcpy(jac, jn, sizeof jac);
    if (step <= 1e-12) return 1;
  }
  return 0;
}

/* The full constraint of a two-vertex chain: the half-vector constraints at x1 (toward
 * the light and x2) and at x2 (toward x1 and x_k), with u1 and u2 both unknown (slots 0-1
 * and 2-3). Every point stays on its (clamped) triangle, so unlike the reduced form it
 * has no singularity where the ray leaving x1 runs parallel to T2's plane: the reduced
 * form's residual jumps there (x2 passes through infinity), and from a start whose ray
 * meets T2's plane behind x1 (common in a mirror corner, where only part of T1 sends
 * light toward T2) it cannot reach the root. Returns 0 where undefined. */
static int full_constraint(const newton_chain *q, const double z[4], double f[4], double jac[16]) {
  const bbc_path_geometry *g = q->g;
  dvec4 x1 = qv_affine(g->specular[0].p, z[0], z[1], 0);
  dvec4 n1 = qv_affine(g->specular[0].n, z[0], z[1], 0);
  dvec4 x2 = qv_affine(g->specular[1].p, z[2], z[3], 2);
  dvec4 n2 = qv_affine(g->specular[1].n, z[2], z[3], 2);
  dual4 c[4];
  if (!vertex_constraint(q, 0, light_vertex(g, x1), x1, x2, n1, c) ||
      !vertex_constraint(q, 1, x1, x2, qv_const(q->xk), n2, c + 2))
    return 0;
  for (int r = 0; r < 4; r++) {
    f[r] = c[r].v;
    for (int k = 0; k < 4; k++) jac[4 * r + k] = c[r].d[k];
  }
  return 1;
}

/* Solves the 4 x 4 system a x = b by Gaussian elimination with partial pivoting (a and b
 * are overwritten). Returns 0 if a is singular. */
static int solve4(double a[16], double b[4], double x[4]) {
  for (int col = 0; col < 4; col++) {
    int pivot = col;
    for (int r = col + 1; r < 4; r++)
      if (fabs(a[4 * r + col]) > fabs(a[4 * pivot + col])) pivot = r;
    if (!(a[4 * pivot + col] != 0) || !isfinite(a[4 * pivot + col])) return 0;
    if (pivot != col) {
      for (int k = 0; k < 4; k++) {
        double t = a[4 * col + k];
        a[4 * col + k] = a[4 * pivot + k];
        a[4 * pivot + k] = t;
      }
      double t = b[col];
      b[col] = b[pivot];
      b[pivot] = t;
    }
    for (int r = col + 1; r < 4; r++) {
      double m = a[4 * r + col] / a[4 * col + col];
      for (int k = col; k < 4; k++) a[4 * r + k] -= m * a[4 * col + k];
      b[r] -= m * b[col];
    }
  }
  for (int r = 3; r >= 0; r--) {
    double sum = b[r];
    for (int k = r + 1; k < 4; k++) sum -= a[4 * r + k] * x[k];
    x[r] = sum / a[4 * r + r];
    if (!isfinite(x[r])) return 0;
  }
  return 1;
}

/* Damped Newton on the full constraint, u1 and u2 clamped into their triangles; the same
 * step control and return values as reduced_newton. */
static int full_newton(const newton_chain *q, double z[4], int max_it, int *iterations) {
  const bbc_path_geometry *g = q->g;
  clamp_to_triangle(&g->specular[0], &z[0], &z[1]);
  clamp_to_triangle(&g->specular[1], &z[2], &z[3]);
  double f[4], jac[16];
  if (!full_constraint(q, z, f, jac)) return -1;
  double norm = fabs(f[0]) + fabs(f[1]) + fabs(f[2]) + fabs(f[3]);
  for (int it = 0; it < max_it; it++) {
    *iterations = it + 1;
    if (norm == 0) return 1;
    double a[16], b[4], dz[4];
    memcpy(a, jac, sizeof a);
    for (int r = 0; r < 4; r++) b[r] = -f[r];
    if (!solve4(a, b, dz)) return 0;
    double len = fabs(dz[0]) + fabs(dz[1]) + fabs(dz[2]) + fabs(dz[3]);
    if (len <= 1e-13) return 1;
    if (len > 0.5)
      for (int r = 0; r < 4; r++) dz[r] *= 0.5 / len;
    double lambda = 1, zn[4], fn[4], jn[16];
    int accepted = 0;
    for (int k = 0; k < 12 && !accepted; k++, lambda *= 0.5) {
      for (int r = 0; r < 4; r++) zn[r] = z[r] + lambda * dz[r];
      clamp_to_triangle(&g->specular[0], &zn[0], &zn[1]);
      clamp_to_triangle(&g->specular[1], &zn[2], &zn[3]);
      if (!full_constraint(q, zn, fn, jn)) continue;
      double nn = fabs(fn[0]) + fabs(fn[1]) + fabs(fn[2]) + fabs(fn[3]);
      if (nn < norm || lambda * len <= 1e-12) accepted = 1, norm = nn;
    }
    if (!accepted) return len <= 1e-9 ? 1 : 0;
    double step = 0;
    for (int r = 0; r < 4; r++) step += fabs(zn[r] - z[r]);
    memcpy(z, zn, sizeof zn);
    memcpy(f, fn, sizeof fn);
    memcpy(jac, jn, sizeof jn);
    if (step <= 1e-12) return 1;
  }
  return 0;
}

bbc_result bbc_solver_newton(const bbc_path_geometry *g, bbc_vec3 xk, const double u1_init[2],
                             const bbc_solver_options *options, bbc_solution *out, int *found) {
  if (found) *found = 0;
  if (!g || !u1_init || !out || !found || (g->length != 1 && g->length != 2) ||
      !isfinite(u1_init[0]) || !isfinite(u1_init[1]) || !isfinite(xk.x) || !isfinite(xk.y) ||
      !isfinite(xk.z))
    return BBC_ERR_INVALID_ARGUMENT;
  bbc_solver_stats *stats = options ? options->stats : NULL;
  if (stats) stats->solves++;
  double z[2] = {u1_init[0], u1_init[1]};
  int max_it = options && options->max_iterations > 0 ? options->max_iterations : 30;
  int its = 0;
  newton_chain q;
  memset(&q, 0, sizeof q);
  q.g = g;
  q.xk = xk;
  for (int i = 0; i < g->length; i++) q.basis_ok[i] = plane_basis(&g->specular[i], q.basis[i]);
  int status = reduced_newton(&q, z, max_it, &its);
  if (stats) stats->newton_iterations += (uint64_t)its;
  int ok = status >= 0 && bbc_solver_verify(g, xk, z[0], z[1], options, out);
  /* A second chance where the reduced iteration ended on the far side of its
   * singularity (backward, parallel or cut off by total internal reflection) or stalled
   * where x1 and x2 meet: the full constraint from the same u1 and T2's centre (see the
   * top of the file). The result stays a deterministic function of the start. */
  int second_chance = 0;
  if (!ok && g->length == 2) {
    const uint32_t far_side = BBC_PATH_BACKWARD | BBC_PATH_DEGENERATE | BBC_PATH_TIR;
    const bbc_specular_path *p = &out->path;
    bbc_vec3 e = v3_sub(g->specular[0].p[1], g->specular[0].p[0]);
    second_chance = status < 0 || !p->complete || (p->flags & far_side) ||
                    v3_length(v3_sub(p->x2, p->x1)) <= 1e-3 * v3_length(e);
  }
  if (second_chance) {
    double w[4] = {u1_init[0], u1_init[1], 1.0 / 3.0, 1.0 / 3.0};
    int full_its = 0;
    int full_status = full_newton(&q, w, max_it, &full_its);
    if (stats) stats->newton_iterations += (uint64_t)full_its;
    its += full_its;
    if (full_status >= 0 && bbc_solver_verify(g, xk, w[0], w[1], options, out)) {
      ok = 1;
      status = full_status;
    } else if (full_status == 1) {
      status = 1;
    }
  }
  if (!ok) {
    if (stats) {
      if (status == 1)
        stats->rejected_inadmissible++;
      else
        stats->rejected_not_converged++;
    }
    return BBC_OK;
  }
  out->iterations = its;
  *found = 1;
  if (stats) stats->solutions++;
  return BBC_OK;
}

bbc_result bbc_solver_newton_centre(const bbc_path_geometry *g, bbc_vec3 xk,
                                    const bbc_solver_options *options, bbc_solution *out,
                                    int *found) {
  static const double centre[2] = {1.0 / 3.0, 1.0 / 3.0};
  return bbc_solver_newton(g, xk, centre, options, out, found);
}
