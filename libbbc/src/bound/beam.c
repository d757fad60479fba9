/* Beams (docs/beams.md): the light leaving a tuple's last specular vertex bounded without
 * a receiver. For a piece of T1's barycentric box, an axis a whose coordinate of the
 * outgoing direction is bounded away from 0 over the piece makes the planes a = lambda
 * a family of receivers: on the plane triangle at lambda (vertices (lambda, lo_b, lo_c),
 * + L e_b, + L e_c), Moller-Trumbore's numerators up, vp and tnum are affine in lambda and
 * kappa does not depend on it (Eq. 9). With lambda = lambda_lo + l (lambda_hi - lambda_lo)
 * a third Bernstein variable l, the forms on the two end planes are the two Bernstein
 * coefficients of the forms on every plane between, and the bounder's position and
 * explicit irradiance bounds (Eq. 4-5, 14-16) hold over the whole slab: the Jacobian's
 * determinant D becomes quadratic in l, and a focus inside the slab, where D vanishes
 * between planes whose own D does not, leaves its sign mixed (+inf). The irradiance on
 * the planes, divided by the cosine between the ray and the axis, is the irradiance on a
 * surface normal to the ray, which bounds it on a surface of any orientation. */
#include "bbc/bounds.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/interval.h"
#include "bounder_internal.h"
#include "light_internal.h"

#define TRY(expr)                \
  do {                           \
    bbc_result r_ = (expr);      \
    if (r_ != BBC_OK) return r_; \
  } while (0)

int bbc__beam_ablation = 0;

/* The most times a piece's box is taken over a slab its receivers narrowed. */
#define BEAM_PASSES 4

typedef struct beam_ctx {
  bbc_bounder *bounder;
  const bbc_tuple_geometry *g;
  double lo[3], hi[3]; /* the receivers' box */
  bbc_bound_params prm;
  int max_level;
  double sigma, alpha;
  bbc_bound_stats local;
} beam_ctx;

static double clock_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The side of the plane triangles across axis a: a power of two at least the receivers'
 * box's extent on the two other axes (the triangle's legs cover the box). */
static double plane_side(const beam_ctx *c, int a) {
  const int b = (a + 1) % 3, d = (a + 2) % 3;
  double extent = fmax(c->hi[b] - c->lo[b], c->hi[d] - c->lo[d]);
  double side = 1.0;
  while (side < extent) side *= 2;
  while (side > 2 * extent && side > 0x1p-20) side *= 0.5;
  return side;
}

/* The plane triangle at a = lambda. Its edges are the same at every lambda. */
static void plane_triangle(const beam_ctx *c, int a, double lambda, bbc_vec3 tri[3]) {
  const int b = (a + 1) % 3, d = (a + 2) % 3;
  const double side = plane_side(c, a);
  double v[3][3];
  for (int k = 0; k < 3; k++) {
    v[k][a] = lambda;
    v[k][b] = c->lo[b];
    v[k][d] = c->lo[d];
  }
  v[1][b] += side;
  v[2][d] += side;
  for (int k = 0; k < 3; k++) tri[k] = (bbc_vec3){v[k][0], v[k][1], v[k][2]};
}

/* p0 (1 - l) + p1 l on the axis l (the forms on the two end planes as the Bernstein
 * coefficients of an affine function of l); the radius is the sum of theirs. */
static bbc_result stack(bbc_arena *arena, int l_axis, const bbc_poly *p0, const bbc_poly *p1,
                        bbc_poly *out) {
  bbc_poly down, up, a, b;
  TRY(bbc_poly_linear(arena, &down, l_axis, 1.0, 0.0));
  TRY(bbc_poly_linear(arena, &up, l_axis, 0.0, 1.0));
  TRY(bbc_poly_mul(arena, &a, p0, &down));
  TRY(bbc_poly_mul(arena, &b, p1, &up));
  return bbc_poly_add(arena, out, &a, &b);
}

/* The forms over the slab from those on its end planes (f0, f1: bbc__chain_forms_retarget
 * of one another): what depends on the plane stacked, the rest f0's. */
static bbc_result stack_forms(bbc_arena *arena, int l_axis, const chain_forms *f0,
                              const chain_forms *f1, chain_forms *out) {
  *out = *f0;
  TRY(stack(arena, l_axis, &f0->up, &f1->up, &out->up));
  TRY(stack(arena, l_axis, &f0->vp, &f1->vp, &out->vp));
  TRY(stack(arena, l_axis, &f0->tnum, &f1->tnum, &out->tnum));
  if (f0->has_value_fold) {
    TRY(stack(arena, l_axis, &f0->up_n, &f1->up_n, &out->up_n));
    TRY(stack(arena, l_axis, &f0->vp_n, &f1->vp_n, &out->vp_n));
  }
  if (f0->has_derivatives) {
    TRY(stack(arena, l_axis, &f0->up_s, &f1->up_s, &out->up_s));
    TRY(stack(arena, l_axis, &f0->up_t, &f1->up_t, &out->up_t));
    TRY(stack(arena, l_axis, &f0->vp_s, &f1->vp_s, &out->vp_s));
    TRY(stack(arena, l_axis, &f0->vp_t, &f1->vp_t, &out->vp_t));
  }
  return BBC_OK;
}

/* The bounds of |d_a| / |d| over the piece for every axis a (0 where d_a may vanish). */
static void axis_cosines(const bbc_poly3 *d, double cos_lo[3], double cos_hi[3]) {
  bbc_interval c[3] = {bbc_poly_bound(&d->x), bbc_poly_bound(&d->y), bbc_poly_bound(&d->z)};
  bbc_interval dd = bbc_interval_add(
      bbc_interval_add(bbc_interval_sqr(c[0]), bbc_interval_sqr(c[1])), bbc_interval_sqr(c[2]));
  bbc_interval len = bbc_interval_sqrt(dd);
  for (int a = 0; a < 3; a++) {
    cos_lo[a] = 0, cos_hi[a] = 1;
    const double m = c[a].lo > 0 ? c[a].lo : c[a].hi < 0 ? -c[a].hi : 0;
    const double big = fmax(fabs(c[a].lo), fabs(c[a].hi));
    if (len.lo > 0 && big < INFINITY)
      cos_hi[a] =
          fmin(1.0, bbc_interval_div(bbc_interval_point(big), bbc_interval_point(len.lo)).hi);
    if (!(m > 0) || !(len.hi < INFINITY)) continue;
    bbc_interval q = bbc_interval_div(bbc_interval_point(m), bbc_interval_make(len.hi, len.hi));
    cos_lo[a] = q.lo > 0 ? q.lo : 0;
  }
}

/* The axis of a piece: among those along which the directions are bounded away from 0
 * (-1: none), the one whose slab through the receivers' box costs least, the box's
 * extent along it over the cosine (a flat box's own axis first; then the steepest). */
static int dominant_axis(const double cos_lo[3], const double lo[3], const double hi[3]) {
  int best = -1;
  double best_cost = INFINITY;
  for (int a = 0; a < 3; a++) {
    if (!(cos_lo[a] > 0)) continue;
    const double cost = (hi[a] - lo[a]) / cos_lo[a];
    if (best < 0 || cost < best_cost || (cost == best_cost && cos_lo[a] > cos_lo[best]))
      best = a, best_cost = cost;
  }
  return best;
}

/* The world coordinate lo_b + side x over a range of x, rounded outward. */
static bbc_interval world(double base, double side, double x_lo, double x_hi) {
  return bbc_interval_add(
      bbc_interval_point(base),
      bbc_interval_mul(bbc_interval_point(side), bbc_interval_make(x_lo, x_hi)));
}

static double coord(bbc_vec3 p, int a) {
  return a == 0 ? p.x : a == 1 ? p.y : p.z;
}

/* The range on axis a of the last specular vertex of a piece's paths: T2's for two
 * vertices; for one, that of x1 = p0 + u (p1 - p0) + v (p2 - p0) over the piece's box
 * {u_lo, u_hi, v_lo, v_hi} (affine, so the box's corners bound it), rounded outward. */
static bbc_interval last_vertex_range(const bbc_tuple_geometry *g, int a, const double box[4]) {
  if (g->length == 2) {
    double lo = coord(g->p2[0], a), hi = lo;
    for (int k = 1; k < 3; k++)
      lo = fmin(lo, coord(g->p2[k], a)), hi = fmax(hi, coord(g->p2[k], a));
    return bbc_interval_make(lo, hi);
  }
  const bbc_interval c0 = bbc_interval_point(coord(g->p[0], a));
  const bbc_interval e1 = bbc_interval_sub(bbc_interval_point(coord(g->p[1], a)), c0);
  const bbc_interval e2 = bbc_interval_sub(bbc_interval_point(coord(g->p[2], a)), c0);
  double lo = INFINITY, hi = -INFINITY;
  for (int k = 0; k < 4; k++) {
    const bbc_interval x = bbc_interval_add(
        c0, bbc_interval_add(bbc_interval_mul(bbc_interval_point(box[k & 1]), e1),
                             bbc_interval_mul(bbc_interval_point(box[2 + (k >> 1)]), e2)));
    lo = fmin(lo, x.lo), hi = fmax(hi, x.hi);
  }
  return bbc_interval_make(lo, hi);
}

typedef enum outcome { OUT_DISCARD, OUT_PARTIAL, OUT_FULL } outcome;

/* The range [*depth_lo, *depth_hi] on the piece's axis of the receivers in the part of
 * its box (its parent's) within its slab; 0 when none lies there. */
static int slab_depths(const beam_ctx *c, const bbc_beam_piece *piece, double *depth_lo,
                       double *depth_hi) {
  const int a = piece->axis;
  double lo[3], hi[3];
  for (int i = 0; i < 3; i++) lo[i] = piece->box_lo[i], hi[i] = piece->box_hi[i];
  lo[a] = fmax(lo[a], piece->lambda_lo), hi[a] = fmin(hi[a], piece->lambda_hi);
  return lo[a] <= hi[a] && c->prm.beam_depth(c->prm.need_user, a, lo, hi, depth_lo, depth_hi);
}

/* The piece's checks (Supp. Sec. 4.1's, without a receiver triangle), its axis when it
 * has none yet, its box, and with irradiance its bound. *cos_lo receives the lower bound
 * of |cos| between the ray and the axis. */
static double cross_fraction(const beam_ctx *c, const bbc_beam_piece *p);

/* What the caller asks of a piece whose box is known (bbc_bound_params.beam_need), and
 * whether it needs the piece's irradiance bound: not when nothing it holds changes what
 * is recorded, nor when it is split for its box alone (partial and large). */
static int wants_irradiance(const beam_ctx *c, const bbc_beam_piece *piece, int partial,
                            bbc_piece_need *need) {
  *need = c->prm.beam_need ? c->prm.beam_need(c->prm.need_user, piece) : BBC_NEED_SPLIT;
  if (*need == BBC_NEED_KEEP && partial) *need = BBC_NEED_SPLIT;
  if (c->prm.positions_only || *need == BBC_NEED_NONE) return 0;
  const int can_split = *need == BBC_NEED_SPLIT &&
                        (piece->level < c->max_level || (piece->lambda_level < c->max_level &&
                                                         piece->lambda_hi > piece->lambda_lo));
  return !(can_split && partial && cross_fraction(c, piece) >= c->sigma);
}

/* The piece's checks, axis and box, then (when wants_irradiance says so, *irradiance set)
 * its irradiance bound in the same forms; *need receives the caller's answer. */
static bbc_result examine(beam_ctx *c, bbc_beam_piece *piece, int *irradiance, bbc_piece_need *need,
                          outcome *out, int *no_axis, double *tan_hi) {
  *irradiance = 0;
  *need = BBC_NEED_SPLIT;
  const bbc_tuple_geometry *g = c->g;
  bbc_arena *arena = bbc__bounder_arena(c->bounder);
  bbc_arena_reset(arena, 0);
  *out = OUT_DISCARD;
  *no_axis = 0;
  const double box[4] = {piece->u_lo, piece->u_hi, piece->v_lo, piece->v_hi};
  if (box[0] + box[2] >= 1.0) return BBC_OK;
  if (bbc__light_falloff_over_box(g->light, &g->light_model, g->p, box).hi <= 0) return BBC_OK;
  /* Two bounces: a part of T1 whose light provably misses T2 holds no path. */
  if (bbc__chain_second_unreachable(g, box)) return BBC_OK;
  /* A piece with an axis (its parent's) is tested against the receivers of its slab
   * before its forms, so that the half of a slab holding none costs none. */
  double depth_lo, depth_hi, early_lo = NAN, early_hi = NAN;
  if (piece->axis >= 0 && c->prm.beam_depth) {
    if (!slab_depths(c, piece, &depth_lo, &depth_hi)) return BBC_OK;
    early_lo = piece->lambda_lo, early_hi = piece->lambda_hi;
  }
  bbc_space space;
  int s_axis, t_axis;
  memset(&space, 0, sizeof space);
  TRY(bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &s_axis));
  TRY(bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &t_axis));
  /* The forms against a provisional plane of the piece's axis (x if it has none). */
  const int axis0 = piece->axis >= 0 ? piece->axis : 0;
  bbc_tuple_geometry g0 = *g;
  plane_triangle(c, axis0, piece->axis >= 0 ? piece->lambda_lo : c->lo[0], g0.r);
  chain_forms f;
  TRY(bbc__chain_forms_prefix(arena, &space, &g0, box, s_axis, t_axis, CHAIN_SQRT_PRIMAL, &f));
  int partial = 0, wide = 0, inside = 0;
  bbc_interval iv = bbc_poly_bound(&f.facing);
  if (iv.hi < 0) return BBC_OK;
  if (iv.lo < 0) partial = 1;
  if (f.has_beta) {
    iv = bbc_poly_bound(&f.beta);
    if (iv.hi < 0) return BBC_OK;
    if (iv.lo < 0) partial = 1;
  }
  if (f.length == 2) {
    TRY(bbc__ray_lands(arena, &f.up2, &f.vp2, &f.kappa2, &f.tnum2, NULL, &partial, &wide, &inside));
    if (partial < 0) return BBC_OK;
  }
  TRY(bbc__chain_forms_rest(arena, &space, &g0, CHAIN_SQRT_PRIMAL, &f));
  if (f.length == 2) {
    iv = bbc_poly_bound(&f.facing2);
    if (iv.hi < 0) return BBC_OK;
    if (iv.lo < 0) partial = 1;
    if (f.has_beta2) {
      iv = bbc_poly_bound(&f.beta2);
      if (iv.hi < 0) return BBC_OK;
      if (iv.lo < 0) partial = 1;
    }
  }
  bbc_poly3 dir;
  bbc__chain_direction(&f, &dir);
  double cos_lo3[3], cos_hi3[3];
  axis_cosines(&dir, cos_lo3, cos_hi3);
  if (piece->axis < 0) {
    const int best = dominant_axis(cos_lo3, c->lo, c->hi);
    if (best < 0) {
      /* No plane family separates the piece's rays: its box is the receivers'. */
      *no_axis = 1;
      *out = OUT_PARTIAL;
      for (int i = 0; i < 3; i++) piece->box_lo[i] = c->lo[i], piece->box_hi[i] = c->hi[i];
      return BBC_OK;
    }
    piece->axis = best;
    piece->lambda_lo = c->lo[best], piece->lambda_hi = c->hi[best];
    piece->lambda_level = 0;
  }
  const int a = piece->axis, b = (a + 1) % 3, d = (a + 2) % 3;
  /* The cosine between the rays and the axis (which a piece inheriting it may no longer
   * find the best, but which must still separate: a remainder's linearisation may have
   * widened the directions' bound; then no bound but the box is known). */
  const double cos_lo_axis = cos_lo3[a], cos_hi = cos_hi3[a];
  *tan_hi =
      cos_lo_axis > 0 ? sqrt(fmax(0.0, 1 - cos_lo_axis * cos_lo_axis)) / cos_lo_axis : INFINITY;
  if (!(cos_lo_axis > 0)) {
    *no_axis = 1;
    *out = OUT_PARTIAL;
    return BBC_OK;
  }
  /* The slab starts where the rays do, ahead of the last vertex. */
  {
    const bbc_interval dir_a = bbc_poly_bound(a == 0 ? &dir.x : a == 1 ? &dir.y : &dir.z);
    const bbc_interval at = last_vertex_range(g, a, box);
    if (dir_a.lo > 0) piece->lambda_lo = fmax(piece->lambda_lo, at.lo);
    if (dir_a.hi < 0) piece->lambda_hi = fmin(piece->lambda_hi, at.hi);
    if (!(piece->lambda_lo <= piece->lambda_hi)) return BBC_OK; /* no receiver ahead */
  }
  /* The slab narrowed to the depths of the receivers inside the box its paths stay in
   * (the parent's): a path of the piece reaches a receiver only there (found above when
   * the slab has not changed since). */
  if (c->prm.beam_depth) {
    if (!(piece->lambda_lo == early_lo && piece->lambda_hi == early_hi) &&
        !slab_depths(c, piece, &depth_lo, &depth_hi))
      return BBC_OK;
    piece->lambda_lo = fmax(piece->lambda_lo, depth_lo);
    piece->lambda_hi = fmin(piece->lambda_hi, depth_hi);
  }
  /* The forms on the slab's end planes, then over the slab, and the box they give.
   * When the receivers inside that box lie in a much thinner slab, the box is taken
   * again over it (a few times: on a curved receiver crossed at a shallow angle each
   * pass narrows the slab by about the ratio of the slopes). */
  bbc_tuple_geometry g_lo = *g, g_hi = *g;
  chain_forms f0, f1, fs;
  int thin = 0, l_axis = -1;
  const int partial_before = partial;
  double lo[3], hi[3];
  for (int pass = 0;; pass++) {
    partial = partial_before;
    plane_triangle(c, a, piece->lambda_lo, g_lo.r);
    plane_triangle(c, a, piece->lambda_hi, g_hi.r);
    /* A slab of no thickness is one plane: its forms without the axis l. */
    thin = !(piece->lambda_hi > piece->lambda_lo);
    TRY(bbc__chain_forms_retarget(arena, &space, g_lo.r, &f, &f0));
    f1 = f0;
    if (!thin) TRY(bbc__chain_forms_retarget(arena, &space, g_hi.r, &f, &f1));
    if (!thin && l_axis < 0) TRY(bbc_space_add_axis(&space, BBC_AXIS_GEOMETRIC, &l_axis));
    if (thin)
      fs = f0;
    else
      TRY(stack_forms(arena, l_axis, &f0, &f1, &fs));
    /* Ahead of the last vertex where tnum kappa > 0. */
    bbc_poly forward;
    TRY(bbc_poly_mul(arena, &forward, &fs.tnum, &fs.kappa));
    iv = bbc_poly_bound(&forward);
    if (iv.hi < 0) return BBC_OK;
    if (iv.lo < 0) partial = 1;
    /* The box: lambda's range on the axis, the plane triangle's barycentrics mapped to
     * the world on the others, within the receivers' box. */
    bbc_range ru, rv;
    TRY(bbc_rational_bound(arena, &fs.up, &fs.kappa, &ru));
    TRY(bbc_rational_bound(arena, &fs.vp, &fs.kappa, &rv));
    const double side = plane_side(c, a);
    lo[a] = piece->lambda_lo, hi[a] = piece->lambda_hi;
    lo[b] = c->lo[b], hi[b] = c->hi[b], lo[d] = c->lo[d], hi[d] = c->hi[d];
    if (ru.kind == BBC_RANGE_BOUNDED) {
      bbc_interval w = world(c->lo[b], side, ru.lo, ru.hi);
      lo[b] = fmax(lo[b], w.lo), hi[b] = fmin(hi[b], w.hi);
    }
    if (rv.kind == BBC_RANGE_BOUNDED) {
      bbc_interval w = world(c->lo[d], side, rv.lo, rv.hi);
      lo[d] = fmax(lo[d], w.lo), hi[d] = fmin(hi[d], w.hi);
    }
    for (int i = 0; i < 3; i++) {
      /* The parent's box holds the piece's paths too. */
      lo[i] = fmax(lo[i], piece->box_lo[i]), hi[i] = fmin(hi[i], piece->box_hi[i]);
      if (!(lo[i] <= hi[i])) return BBC_OK; /* no receiver is reached */
    }
    if (!c->prm.beam_depth) break;
    /* The receivers inside the box: none, and the piece reaches none; else their
     * depths narrow the box on the axis and the slab. */
    if (!c->prm.beam_depth(c->prm.need_user, a, lo, hi, &depth_lo, &depth_hi)) return BBC_OK;
    const double before = piece->lambda_hi - piece->lambda_lo;
    lo[a] = piece->lambda_lo = fmax(lo[a], depth_lo);
    hi[a] = piece->lambda_hi = fmin(hi[a], depth_hi);
    for (int i = 0; i < 3; i++) piece->box_lo[i] = lo[i], piece->box_hi[i] = hi[i];
    if (pass == BEAM_PASSES - 1 || !(piece->lambda_hi - piece->lambda_lo < 0.5 * before)) break;
  }
  for (int i = 0; i < 3; i++) piece->box_lo[i] = lo[i], piece->box_hi[i] = hi[i];
  *out = partial ? OUT_PARTIAL : OUT_FULL;
  c->local.position_pieces++;
  if (!wants_irradiance(c, piece, partial, need)) return BBC_OK;
  *irradiance = 1;
  c->local.irradiance_pieces++;

  /* The irradiance on the planes: refraction's forms with the derivative-aware sqrt. */
  const chain_forms *irr = &fs, *ends[2] = {&f0, &f1};
  chain_forms i0, i1, is;
  if (g->refract || (g->length == 2 && g->refract2)) {
    if (g->length == 1)
      TRY(bbc__chain_forms_rescatter(arena, &space, &g_lo, &f, CHAIN_SQRT_DERIVATIVE_AWARE, &i0));
    else
      TRY(bbc__chain_forms(arena, &space, &g_lo, box, s_axis, t_axis, CHAIN_SQRT_DERIVATIVE_AWARE,
                           &i0));
    i1 = i0, is = i0;
    if (!thin) {
      TRY(bbc__chain_forms_retarget(arena, &space, g_hi.r, &i0, &i1));
      TRY(stack_forms(arena, l_axis, &i0, &i1, &is));
    }
    irr = &is;
    ends[0] = &i0, ends[1] = &i1;
  }
  double e_lo, e_hi;
  TRY(bbc__irradiance_bound_explicit(arena, &space, &g_lo, irr, box, s_axis, t_axis,
                                     c->prm.jacobian, &e_lo, &e_hi));
  if (bbc__beam_ablation == 2) {
    /* The control: the bounds on the two end planes alone. */
    double l[2], h[2];
    for (int k = 0; k < 2; k++)
      TRY(bbc__irradiance_bound_explicit(arena, &space, k ? &g_hi : &g_lo, ends[k], box, s_axis,
                                         t_axis, c->prm.jacobian, &l[k], &h[k]));
    e_lo = fmin(l[0], l[1]), e_hi = fmax(h[0], h[1]);
  }
  const double cos_lo = bbc__beam_ablation == 1 ? 1.0 : cos_lo_axis; /* control: no 1/|cos| */
  /* On the surface normal to the ray: divided by |cos| between the ray and the axis,
   * which is at least cos_lo (and at most 1, so e_lo stands). */
  if (isfinite(e_hi) && cos_lo > 0) {
    bbc_interval e = bbc_interval_div(bbc_interval_make(e_hi, e_hi), bbc_interval_point(cos_lo));
    e_hi = e.hi;
  } else {
    e_hi = INFINITY;
  }
  /* ... and at least e_lo / cos_hi there. */
  if (e_lo > 0 && cos_hi > 0)
    e_lo = bbc_interval_div(bbc_interval_make(e_lo, e_lo), bbc_interval_point(cos_hi)).lo;
  else
    e_lo = 0;
  if (!(e_lo >= 0)) e_lo = 0;
  piece->e_lo = fmax(piece->e_lo, e_lo);
  piece->e_hi = fmin(piece->e_hi, e_hi);
  return BBC_OK;
}

static bbc_result push(bbc_beam_piece **queue, size_t *count, size_t *capacity,
                       const bbc_beam_piece *p) {
  if (*count == *capacity) {
    size_t n = *capacity ? 2 * *capacity : 256;
    bbc_beam_piece *q = realloc(*queue, n * sizeof *q);
    if (!q) return BBC_ERR_OUT_OF_MEMORY;
    *queue = q;
    *capacity = n;
  }
  (*queue)[(*count)++] = *p;
  return BBC_OK;
}

/* The area of the box across its axis as a fraction of the receivers' box's (sides of
 * zero extent count 1). */
static double cross_fraction(const beam_ctx *c, const bbc_beam_piece *p) {
  double f = 1;
  for (int i = 0; i < 3; i++) {
    if (i == p->axis) continue;
    const double r = c->hi[i] - c->lo[i];
    if (r > 0) f *= (p->box_hi[i] - p->box_lo[i]) / r;
  }
  return f;
}

/* Whether the box is more than twice as long along its axis as across. */
static int elongated(const bbc_beam_piece *p) {
  const int a = p->axis;
  if (a < 0) return 0;
  const double across = fmax(p->box_hi[(a + 1) % 3] - p->box_lo[(a + 1) % 3],
                             p->box_hi[(a + 2) % 3] - p->box_lo[(a + 2) % 3]);
  return p->box_hi[a] - p->box_lo[a] > 2 * across;
}

bbc_result bbc_bound_beam(bbc_bounder *bounder, const bbc_tuple_geometry *g,
                          const double receivers_lo[3], const double receivers_hi[3],
                          const bbc_bound_params *params, bbc_beam_piece_fn fn, void *user,
                          bbc_bound_stats *stats) {
  for (int i = 0; i < 3; i++)
    if (!(receivers_lo[i] <= receivers_hi[i]) || !isfinite(receivers_lo[i]) ||
        !isfinite(receivers_hi[i]))
      return BBC_ERR_INVALID_ARGUMENT;
  beam_ctx c;
  memset(&c, 0, sizeof c);
  c.bounder = bounder;
  c.g = g;
  for (int i = 0; i < 3; i++) c.lo[i] = receivers_lo[i], c.hi[i] = receivers_hi[i];
  if (params) c.prm = *params;
  c.max_level = c.prm.max_level > 0 ? c.prm.max_level : c.prm.max_level < 0 ? 0 : 10;
  c.sigma = c.prm.sigma > 0 ? c.prm.sigma : 1e-4;
  c.alpha = c.prm.alpha > 0 ? c.prm.alpha : g->length == 2 ? 10.0 : 2.0;
  c.local.tuples = 1;

  bbc_beam_piece root;
  memset(&root, 0, sizeof root);
  root.u_hi = root.v_hi = root.a_hi = root.b_hi = 1;
  root.axis = -1;
  root.e_hi = INFINITY;
  for (int i = 0; i < 3; i++) root.box_lo[i] = c.lo[i], root.box_hi[i] = c.hi[i];

  bbc_result result = BBC_OK;
  bbc_beam_piece *queue = NULL;
  size_t head = 0, count = 0, capacity = 0;
  if (g->light_model.kind == BBC_LIGHT_AREA) {
    /* Not bounded yet: the whole receivers' box, unbounded. */
    root.status = BBC_PIECE_KEPT;
    c.local.kept_pieces++;
    if (fn && fn(user, &root)) result = BBC_ERR_CANCELLED;
    goto done;
  }
  result = push(&queue, &count, &capacity, &root);
  while (result == BBC_OK && head < count) {
    bbc_beam_piece piece = queue[head++];
    if (head == count) {
      head = count = 0;
    } else if (head >= 1024 && 2 * head >= count) {
      memmove(queue, queue + head, (count - head) * sizeof *queue);
      count -= head;
      head = 0;
    }
    const bbc_beam_piece inherited = piece;
    bbc_piece_need (*need_fn)(void *, const bbc_beam_piece *) = c.prm.beam_need;
    if (need_fn && piece.level + piece.lambda_level > 0 &&
        need_fn(c.prm.need_user, &piece) == BBC_NEED_NONE) {
      piece.status = BBC_PIECE_KEPT;
      c.local.kept_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    double t0 = clock_seconds();
    outcome v;
    int no_axis, irradiance;
    bbc_piece_need need;
    double tan_hi = INFINITY;
    result = examine(&c, &piece, &irradiance, &need, &v, &no_axis, &tan_hi);
    if (irradiance)
      c.local.irradiance_seconds += clock_seconds() - t0;
    else
      c.local.position_seconds += clock_seconds() - t0;
    if (result != BBC_OK) break;
    if (v == OUT_DISCARD) {
      piece.status = BBC_PIECE_DISCARDED;
      c.local.discarded_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    if (no_axis) need = need_fn ? need_fn(c.prm.need_user, &piece) : BBC_NEED_SPLIT;
    const int u1_ok = piece.level < c.max_level;
    /* A slab of no thickness (a flat receivers' box) is one plane: never split. */
    const int lambda_ok =
        !no_axis && piece.lambda_level < c.max_level && piece.lambda_hi > piece.lambda_lo;
    int split = 0, split_lambda = 0;
    const double area = cross_fraction(&c, &piece);
    if (no_axis) {
      split = u1_ok && need != BBC_NEED_NONE;
      piece.axis = inherited.axis >= 0 ? inherited.axis : -1;
      if (!split) piece.e_lo = 0, piece.e_hi = INFINITY;
    } else if (need == BBC_NEED_NONE) {
      split = 0;
    } else if (!irradiance) {
      /* Split for its box alone, or kept without an irradiance bound of its own. */
      split = (u1_ok || lambda_ok) && need == BBC_NEED_SPLIT && area >= c.sigma;
    } else {
      if (need_fn && need == BBC_NEED_SPLIT) need = need_fn(c.prm.need_user, &piece);
      /* The bounder's rule: split while the box is large and the bound loose; a box
       * long along the axis is large too (a focus is isolated in lambda). */
      split = (u1_ok || lambda_ok) && need == BBC_NEED_SPLIT &&
              (area >= c.sigma || (lambda_ok && elongated(&piece))) &&
              !(piece.e_hi < c.alpha * piece.e_lo);
    }
    if (split && !no_axis) {
      /* The distance along the axis, or T1's box: near a focus (an unbounded bound) the
       * two in turn; otherwise the longer of the box's side along the axis and across. */
      const int a = piece.axis;
      const double along = piece.lambda_hi - piece.lambda_lo;
      const double across = fmax(piece.box_hi[(a + 1) % 3] - piece.box_lo[(a + 1) % 3],
                                 piece.box_hi[(a + 2) % 3] - piece.box_lo[(a + 2) % 3]);
      if (elongated(&piece))
        split_lambda = 1;
      else if (!(piece.e_hi < INFINITY) && v != OUT_PARTIAL)
        split_lambda = piece.lambda_level <= piece.level;
      else
        split_lambda = along * tan_hi > 0.5 * across; /* the slab makes most of the width */
      if (split_lambda && !lambda_ok) split_lambda = 0;
      if (!split_lambda && !u1_ok) split_lambda = 1;
    }
    /* A spot's falloff over the piece's directions, once, on a kept piece. */
    if (!split && g->light_model.kind == BBC_LIGHT_SPOT) {
      const double box[4] = {piece.u_lo, piece.u_hi, piece.v_lo, piece.v_hi};
      bbc_interval fall = bbc__light_falloff_over_box(g->light, &g->light_model, g->p, box);
      piece.e_lo = piece.e_lo > 0 ? piece.e_lo * fall.lo * (1 - 4 * DBL_EPSILON) : 0;
      if (isfinite(piece.e_hi) && piece.e_hi > 0) {
        double hi = piece.e_hi * fall.hi * (1 + 4 * DBL_EPSILON);
        piece.e_hi = hi > 0 ? hi : DBL_TRUE_MIN;
      }
    }
    if (split && split_lambda) {
      bbc_beam_piece child = piece;
      child.lambda_level = piece.lambda_level + 1;
      const double m = 0.5 * (piece.lambda_lo + piece.lambda_hi);
      child.lambda_hi = m;
      child.box_hi[piece.axis] = fmin(child.box_hi[piece.axis], m);
      result = push(&queue, &count, &capacity, &child);
      child = piece;
      child.lambda_level = piece.lambda_level + 1;
      child.lambda_lo = m;
      child.box_lo[piece.axis] = fmax(child.box_lo[piece.axis], m);
      if (result == BBC_OK) result = push(&queue, &count, &capacity, &child);
      continue;
    }
    if (split) {
      const double um = 0.5 * (piece.u_lo + piece.u_hi), vm = 0.5 * (piece.v_lo + piece.v_hi);
      const double us[3] = {piece.u_lo, um, piece.u_hi}, vs[3] = {piece.v_lo, vm, piece.v_hi};
      bbc_beam_piece child = piece;
      child.level = piece.level + 1;
      for (int j = 0; j < 2 && result == BBC_OK; j++) {
        for (int i = 0; i < 2 && result == BBC_OK; i++) {
          child.u_lo = us[i], child.u_hi = us[i + 1];
          child.v_lo = vs[j], child.v_hi = vs[j + 1];
          result = push(&queue, &count, &capacity, &child);
        }
      }
      continue;
    }
    piece.status = BBC_PIECE_KEPT;
    c.local.kept_pieces++;
    if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
  }
done:
  free(queue);
  if (stats) {
    stats->tuples += c.local.tuples;
    stats->position_pieces += c.local.position_pieces;
    stats->irradiance_pieces += c.local.irradiance_pieces;
    stats->kept_pieces += c.local.kept_pieces;
    stats->discarded_pieces += c.local.discarded_pieces;
    stats->position_seconds += c.local.position_seconds;
    stats->irradiance_seconds += c.local.irradiance_seconds;
  }
  return result;
}
