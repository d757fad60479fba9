/* Exact specular paths through one or two specular triangles, with forward-mode
 * derivatives (paper Sec. 4.3-4.4, Eq. 6-11 and 14-16). See bbc/specular_path.h. */
#include "bbc/specular_path.h"

#include <math.h>
#include <string.h>

#include "light_internal.h"
#include "media_internal.h"
#include "vec_internal.h"

/* ------------------------------------------------------------------------------------ */
/* Dual numbers: a value with its exact derivatives with respect to u and v of u1. Every
 * operation applies the chain rule to the two derivative slots, so the Jacobian of the
 * whole trace (Eq. 16) comes out exactly, without finite differences. */

typedef struct dual {
  double v, du, dv;
} dual;

typedef struct dvec {
  dual x, y, z;
} dvec;

static inline dual d_const(double a) {
  return (dual){a, 0.0, 0.0};
}
static inline dual d_add(dual a, dual b) {
  return (dual){a.v + b.v, a.du + b.du, a.dv + b.dv};
}
static inline dual d_sub(dual a, dual b) {
  return (dual){a.v - b.v, a.du - b.du, a.dv - b.dv};
}
static inline dual d_neg(dual a) {
  return (dual){-a.v, -a.du, -a.dv};
}
static inline dual d_mul(dual a, dual b) {
  return (dual){a.v * b.v, a.du * b.v + a.v * b.du, a.dv * b.v + a.v * b.dv};
}
static inline dual d_scale(dual a, double s) {
  return (dual){a.v * s, a.du * s, a.dv * s};
}
static inline dual d_div(dual a, dual b) {
  double q = a.v / b.v;
  return (dual){q, (a.du - q * b.du) / b.v, (a.dv - q * b.dv) / b.v};
}
/* Only called with a > 0 (the callers check), so the derivative is finite. */
static inline dual d_sqrt(dual a) {
  double s = sqrt(a.v);
  return (dual){s, a.du / (2.0 * s), a.dv / (2.0 * s)};
}

static inline dvec dv_const(bbc_vec3 a) {
  return (dvec){d_const(a.x), d_const(a.y), d_const(a.z)};
}
static inline bbc_vec3 dv_value(dvec a) {
  return v3(a.x.v, a.y.v, a.z.v);
}
static inline bbc_vec3 dv_du(dvec a) {
  return v3(a.x.du, a.y.du, a.z.du);
}
static inline bbc_vec3 dv_dv(dvec a) {
  return v3(a.x.dv, a.y.dv, a.z.dv);
}
static inline dvec dv_add(dvec a, dvec b) {
  return (dvec){d_add(a.x, b.x), d_add(a.y, b.y), d_add(a.z, b.z)};
}
static inline dvec dv_sub(dvec a, dvec b) {
  return (dvec){d_sub(a.x, b.x), d_sub(a.y, b.y), d_sub(a.z, b.z)};
}
static inline dvec dv_neg(dvec a) {
  return (dvec){d_neg(a.x), d_neg(a.y), d_neg(a.z)};
}
static inline dvec dv_scale(dvec a, dual s) {
  return (dvec){d_mul(a.x, s), d_mul(a.y, s), d_mul(a.z, s)};
}
static inline dual dv_dot(dvec a, dvec b) {
  return d_add(d_add(d_mul(a.x, b.x), d_mul(a.y, b.y)), d_mul(a.z, b.z));
}
/* Dot with a constant vector: cheaper and exact. */
static inline dual dv_dotc(dvec a, bbc_vec3 b) {
  return d_add(d_add(d_scale(a.x, b.x), d_scale(a.y, b.y)), d_scale(a.z, b.z));
}
static inline dvec dv_crossc(dvec a, bbc_vec3 b) {
  return (dvec){d_sub(d_scale(a.y, b.z), d_scale(a.z, b.y)),
                d_sub(d_scale(a.z, b.x), d_scale(a.x, b.z)),
                d_sub(d_scale(a.x, b.y), d_scale(a.y, b.x))};
}
static inline dvec dv_ccross(bbc_vec3 a, dvec b) {
  return dv_neg(dv_crossc(b, a));
}

/* The affine map (u, v) -> a0 + u (a1 - a0) + v (a2 - a0) as a dual vector in u1's
 * variables, given the current (u, v) as duals (which carry their own derivatives). */
static inline dvec dv_affine(const bbc_vec3 a[3], dual u, dual v) {
  bbc_vec3 e1 = v3_sub(a[1], a[0]), e2 = v3_sub(a[2], a[0]);
  dvec r;
  r.x = d_add(d_add(d_const(a[0].x), d_scale(u, e1.x)), d_scale(v, e2.x));
  r.y = d_add(d_add(d_const(a[0].y), d_scale(u, e1.y)), d_scale(v, e2.y));
  r.z = d_add(d_add(d_const(a[0].z), d_scale(u, e1.z)), d_scale(v, e2.z));
  return r;
}

/* ------------------------------------------------------------------------------------ */

int bbc_triangle_barycentrics(const bbc_vec3 p[3], bbc_vec3 x, double out[2]) {
  bbc_vec3 e1 = v3_sub(p[1], p[0]), e2 = v3_sub(p[2], p[0]);
  bbc_vec3 ng = v3_cross(e1, e2);
  double nn = v3_dot(ng, ng);
  if (!(nn > 0)) {
    out[0] = out[1] = 0;
    return 0;
  }
  /* x - p0 = a e1 + b e2 + c ng: crossing with e2 and e1 isolates a and b (the same
   * numerators as Moller-Trumbore, Eq. 9, with the plane normal as the direction). */
  bbc_vec3 r = v3_sub(x, p[0]);
  out[0] = v3_dot(v3_cross(r, e2), ng) / nn;
  out[1] = v3_dot(v3_cross(e1, r), ng) / nn;
  return 1;
}

/* The unit geometric normal of a triangle, turned to agree with the sum of its vertex
 * normals (zero for a degenerate triangle). */
static bbc_vec3 oriented_geometric_normal(const bbc_specular_triangle *t) {
  bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(t->p[1], t->p[0]), v3_sub(t->p[2], t->p[0])));
  bbc_vec3 nsum = v3_add(t->n[0], v3_add(t->n[1], t->n[2]));
  return v3_dot(ng, nsum) < 0 ? v3_neg(ng) : ng;
}

static int inside(double u, double v) {
  return u >= 0 && v >= 0 && u + v <= 1;
}

/* Intersects the ray x + t d (duals) with the plane of triangle p[0..2]. Returns 0 if the
 * ray is parallel to the plane; otherwise the hit point, its barycentrics and t. */
static int hit_plane(const bbc_vec3 p[3], dvec x, dvec d, dvec *hit, dual *bu, dual *bv, dual *t) {
  bbc_vec3 e1 = v3_sub(p[1], p[0]), e2 = v3_sub(p[2], p[0]);
  bbc_vec3 ng = v3_cross(e1, e2);
  double nn = v3_dot(ng, ng);
  dual denom = dv_dotc(d, ng);
  if (!(nn > 0) || denom.v == 0 || !isfinite(denom.v)) return 0;
  dvec to_plane = dv_sub(dv_const(p[0]), x);
  *t = d_div(dv_dotc(to_plane, ng), denom);
  *hit = dv_add(x, dv_scale(d, *t));
  dvec r = dv_sub(*hit, dv_const(p[0]));
  /* The same projection as bbc_triangle_barycentrics, on duals. */
  *bu = d_scale(dv_dotc(dv_crossc(r, e2), ng), 1.0 / nn);
  *bv = d_scale(dv_dotc(dv_ccross(e1, r), ng), 1.0 / nn);
  return 1;
}

/* Scatters the unit direction d (duals) at a vertex with unit shading normal n. Returns 0
 * on total internal reflection. Sets BBC_PATH_BACK_SIDE on reflections from behind. */
static int scatter(const bbc_specular_triangle *tri, dvec d, dvec n, dvec *out, uint32_t *flags) {
  dual c = dv_dot(d, n);
  if (!tri->refract) {
    /* Reflection about the shading normal; the light must arrive against it. */
    if (!(c.v < 0)) *flags |= BBC_PATH_BACK_SIDE;
    *out = dv_sub(d, dv_scale(n, d_scale(c, 2.0)));
    return 1;
  }
  /* Refraction: entering against the normal (eta = 1/ior), leaving with it (eta = ior).
   * With nf the normal turned against d and cos_i = -d . nf >= 0, Snell's law gives
   * t = eta d + (eta cos_i - sqrt(k)) nf, k = 1 - eta^2 (1 - cos_i^2) (Eq. 10-11 with
   * normalised vectors, where beta becomes k). */
  double eta;
  dvec nf;
  dual cos_i;
  if (c.v < 0) {
    eta = 1.0 / tri->ior;
    nf = n;
    cos_i = d_neg(c);
  } else {
    eta = tri->ior;
    nf = dv_neg(n);
    cos_i = c;
  }
  dual k = d_sub(d_const(1.0), d_scale(d_sub(d_const(1.0), d_mul(cos_i, cos_i)), eta * eta));
  if (!(k.v > 0)) {
    /* k = 0 is grazing exit: the refracted ray lies in the tangent plane and its
     * derivative is infinite, so it is treated like total internal reflection. */
    *flags |= BBC_PATH_TIR;
    return 0;
  }
  dual coef = d_sub(d_scale(cos_i, eta), d_sqrt(k));
  dvec scaled = {d_scale(d.x, eta), d_scale(d.y, eta), d_scale(d.z, eta)};
  *out = dv_add(scaled, dv_scale(nf, coef));
  return 1;
}

/* The unit interpolated shading normal of tri at (u, v), as duals. Returns 0 if the
 * interpolated normal vanishes. */
static int shading_normal(const bbc_specular_triangle *tri, dual u, dual v, dvec *out) {
  dvec n = dv_affine(tri->n, u, v);
  dual len2 = dv_dot(n, n);
  if (!(len2.v > 0) || !isfinite(len2.v)) return 0;
  *out = dv_scale(n, d_div(d_const(1.0), d_sqrt(len2)));
  return 1;
}

/* Returns 0 for a vanishing vector. */
static int dv_normalize(dvec a, dvec *out) {
  dual len2 = dv_dot(a, a);
  if (!(len2.v > 0) || !isfinite(len2.v)) return 0;
  *out = dv_scale(a, d_div(d_const(1.0), d_sqrt(len2)));
  return 1;
}

/* Flags a vertex whose shading normal disagrees with its geometric normal about the side
 * the ray arrives from (d_in) or leaves to (d_out): the path tracer absorbs such paths. */
static void check_geometric_side(const bbc_specular_triangle *tri, bbc_vec3 d_in, bbc_vec3 d_out,
                                 bbc_vec3 n, uint32_t *flags) {
  bbc_vec3 ng = oriented_geometric_normal(tri);
  double in_s = v3_dot(d_in, n), in_g = v3_dot(d_in, ng);
  double out_s = v3_dot(d_out, n), out_g = v3_dot(d_out, ng);
  if ((in_s < 0) != (in_g < 0) || (out_s < 0) != (out_g < 0)) *flags |= BBC_PATH_GEOMETRIC_SIDE;
}

/* The trace; with to_last_vertex, it stops at the last specular vertex (complete is then
 * 1 when that vertex was reached). */
static bbc_result trace(const bbc_path_geometry *g, double u, double v, int to_last_vertex,
                        bbc_specular_path *out) {
  if (!out) return BBC_ERR_INVALID_ARGUMENT;
  memset(out, 0, sizeof *out);
  if (!g || (g->length != 1 && g->length != 2) || !isfinite(u) || !isfinite(v))
    return BBC_ERR_INVALID_ARGUMENT;

  out->length = g->length;
  out->x0 = g->light;
  out->u1[0] = u;
  out->u1[1] = v;
  if (!inside(u, v)) out->flags |= BBC_PATH_OUTSIDE_T1;

  /* The first vertex and the light's side of the chain rule (Eq. 15): x1 is affine in
   * u1, so its derivatives are the edges e11, e12. */
  const bbc_specular_triangle *t1 = &g->specular[0];
  dual du = {u, 1.0, 0.0}, dv = {v, 0.0, 1.0};
  dvec x = dv_affine(t1->p, du, dv);
  out->x1 = dv_value(x);
  dvec n;
  if (!shading_normal(t1, du, dv, &n)) {
    out->flags |= BBC_PATH_DEGENERATE;
    return BBC_OK;
  }
  out->n1 = dv_value(n);
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  bbc_vec3 d0 = bbc__light_d0(g->light, &g->light_model, out->x1);
  double dist = v3_length(d0);
  bbc_vec3 area1 = v3_cross(v3_sub(t1->p[1], t1->p[0]), v3_sub(t1->p[2], t1->p[0]));
  if (!(dist > 0) || !(v3_dot(area1, area1) > 0)) {
    out->flags |= BBC_PATH_DEGENERATE;
    return BBC_OK;
  }
  /* |n1g . d0| |e11 x e12| = |(e11 x e12) . d0|: the solid angle at the light per unit
   * barycentric area (dOmega0/dA1 |dx1/du1| of Eq. 15); for a sun (unit d0, constant)
   * the cross-section of the parallel beam per unit barycentric area
   * (docs/lights.md). */
  out->domega_du = sun ? fabs(v3_dot(area1, d0)) / dist
                       : fabs(v3_dot(area1, d0)) / (dist * dist * dist);
  const double falloff = bbc_light_falloff(&g->light_model, v3_scale(d0, 1.0 / dist));
  if (!(falloff > 0)) out->flags |= BBC_PATH_OUTSIDE_CONE;

  dvec d;
  if (!dv_normalize(sun ? dv_const(d0) : dv_sub(x, dv_const(g->light)), &d)) {
    out->flags |= BBC_PATH_DEGENERATE;
    return BBC_OK;
  }

  for (int i = 0; i < g->length; i++) {
    const bbc_specular_triangle *tri = &g->specular[i];
    if (to_last_vertex && i == g->length - 1) { /* one vertex: x1 is the last */
      out->complete = 1;
      return BBC_OK;
    }
    dvec d_next;
    if (!scatter(tri, d, n, &d_next, &out->flags)) return BBC_OK; /* TIR */
    if (!to_last_vertex)
      check_geometric_side(tri, dv_value(d), dv_value(d_next), dv_value(n), &out->flags);

    /* The next vertex: the ray meets the next triangle's plane (Eq. 9). */
    int last = i == g->length - 1;
    const bbc_vec3 *next_p = last ? g->receiver : g->specular[i + 1].p;
    dvec hit;
    dual bu, bv, t;
    if (!hit_plane(next_p, x, d_next, &hit, &bu, &bv, &t)) {
      out->flags |= BBC_PATH_DEGENERATE;
      return BBC_OK;
    }
    if (!(t.v > 0)) out->flags |= BBC_PATH_BACKWARD;
    if (last) {
      if (!inside(bu.v, bv.v)) out->flags |= BBC_PATH_OUTSIDE_RECEIVER;
      out->xk = dv_value(hit);
      out->uk[0] = bu.v;
      out->uk[1] = bv.v;
      out->duk[0][0] = bu.du, out->duk[0][1] = bu.dv;
      out->duk[1][0] = bv.du, out->duk[1][1] = bv.dv;
      bbc_vec3 xu = dv_du(hit), xv = dv_dv(hit);
      out->dxk[0][0] = xu.x, out->dxk[0][1] = xu.y, out->dxk[0][2] = xu.z;
      out->dxk[1][0] = xv.x, out->dxk[1][1] = xv.y, out->dxk[1][2] = xv.z;
      /* dA_k/du1 from the world-space derivatives, with the receiver's unit normal. */
      bbc_vec3 nk = v3_normalize(
          v3_cross(v3_sub(g->receiver[1], g->receiver[0]), v3_sub(g->receiver[2], g->receiver[0])));
      out->darea_du = fabs(v3_dot(v3_cross(xu, xv), nk));
      out->jacobian = fabs(bu.du * bv.dv - bu.dv * bv.du);
      out->irradiance =
          out->darea_du > 0 ? g->intensity * falloff * out->domega_du / out->darea_du : INFINITY;
      out->complete = 1;
    } else {
      if (!inside(bu.v, bv.v)) out->flags |= BBC_PATH_OUTSIDE_T2;
      out->x2 = dv_value(hit);
      out->u2[0] = bu.v;
      out->u2[1] = bv.v;
      out->du2[0][0] = bu.du, out->du2[0][1] = bu.dv;
      out->du2[1][0] = bv.du, out->du2[1][1] = bv.dv;
      if (to_last_vertex && i + 1 == g->length - 1) {
        out->complete = 1;
        return BBC_OK;
      }
      /* The second vertex's normal depends on u1 through u2 = (bu, bv): the duals carry
       * that dependence on. */
      if (!shading_normal(&g->specular[i + 1], bu, bv, &n)) {
        out->flags |= BBC_PATH_DEGENERATE;
        return BBC_OK;
      }
      out->n2 = dv_value(n);
      x = hit;
      d = d_next;
    }
  }
  return BBC_OK;
}

bbc_result bbc_specular_path_trace(const bbc_path_geometry *g, double u, double v,
                                   bbc_specular_path *out) {
  return trace(g, u, v, 0, out);
}

bbc_result bbc__specular_path_trace_to_last_vertex(const bbc_path_geometry *g, double u, double v,
                                                   bbc_specular_path *out) {
  return trace(g, u, v, 1, out);
}

/* ------------------------------------------------------------------------------------ */

bbc_result bbc_path_geometry_init(bbc_path_geometry *g, const bbc_scene *scene,
                                  const bbc_tuple *tuple) {
  if (!g || !scene || !tuple) return BBC_ERR_INVALID_ARGUMENT;
  memset(g, 0, sizeof *g);
  const int64_t emitter = bbc_scene_light_emitter(scene, tuple->light);
  if (tuple->chain >= BBC_CHAIN_COUNT ||
      (tuple->light >= scene->point_light_count && emitter < 0) ||
      !bbc_receiver_triangle(scene, tuple->receiver, g->receiver))
    return BBC_ERR_INVALID_ARGUMENT;
  bbc_chain chain = (bbc_chain)tuple->chain;
  int length = bbc_chain_length(chain);
  for (int i = 0; i < length; i++)
    if (tuple->specular[i] >= scene->triangle_count) return BBC_ERR_INVALID_ARGUMENT;

  /* An area light: its centroid orients the triangles below; a path from emitter point
   * y is traced with `light` set to y (the kind then acts as a point light). */
  const bbc_point_light light = bbc__cache_light_point(scene, tuple->light);
  g->light = light.position;
  g->light_model = light.model;
  g->intensity = 1.0;
  g->length = length;
  for (int i = 0; i < length; i++) {
    bbc_specular_triangle *t = &g->specular[i];
    const uint32_t *idx = scene->indices + 3 * (size_t)tuple->specular[i];
    for (int j = 0; j < 3; j++) {
      t->p[j] = v3_load(scene->positions + 3 * (size_t)idx[j]);
      t->n[j] = v3_load(scene->normals + 3 * (size_t)idx[j]);
    }
    t->refract = bbc_chain_refracts(chain, i);
    t->ior = bbc__media_ior(scene, tuple->specular[i]); /* behind over front */
  }

  /* Two-sided mirrors: turn a reflecting triangle's normals toward the side its light
   * comes from, judged on its geometric plane (oriented by the vertex normals). */
  for (int i = 0; i < length; i++) {
    bbc_specular_triangle *t = &g->specular[i];
    if (t->refract) continue;
    bbc_vec3 source = bbc__light_source(g->light, &g->light_model, t->p[0]);
    if (i == 1) {
      const bbc_specular_triangle *t1 = &g->specular[0];
      source = v3_scale(v3_add(t1->p[0], v3_add(t1->p[1], t1->p[2])), 1.0 / 3.0);
    }
    bbc_vec3 ng = oriented_geometric_normal(t);
    if (v3_dot(ng, v3_sub(source, t->p[0])) < 0)
      for (int j = 0; j < 3; j++) t->n[j] = v3_neg(t->n[j]);
  }
  return BBC_OK;
}
