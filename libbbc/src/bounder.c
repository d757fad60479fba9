/* The single-scattering bounder (paper Sec. 4.2-4.5 and 6.1): for one tuple, a
 * breadth-first subdivision of T1's barycentric domain; on each piece the position bound
 * (Eq. 4-5) and, where needed, the irradiance bound (Eq. 14-16), with the sign conditions
 * of the supplement's pseudo code (Supp. Sec. 4.1) deciding discard / subdivide / keep. */
#define _POSIX_C_SOURCE 200809L
#include "bbc/bounds.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/interval.h"
#include "chain_internal.h"
#include "vec_internal.h"

/* Working memory per piece: the largest single-refraction irradiance forms need a few
 * MB; 64 MB leaves room for every intermediate without reuse. */
#define BOUNDER_ARENA_BYTES ((size_t)64 << 20)
/* The supplement's U_TOL: a position bound reaching this far outside the receiver's
 * [0,1] range asks for subdivision. */
#define POSITION_TOLERANCE 1.0

struct bbc_bounder {
  bbc_arena arena;
  void *memory;
  bbc_piece *queue; /* breadth-first queue of pieces to examine */
  size_t queue_capacity;
};

bbc_result bbc_bounder_create(bbc_bounder **out) {
  *out = NULL;
  bbc_bounder *b = calloc(1, sizeof *b);
  if (!b) return BBC_ERR_OUT_OF_MEMORY;
  b->memory = malloc(BOUNDER_ARENA_BYTES);
  b->queue_capacity = 1024;
  b->queue = malloc(b->queue_capacity * sizeof *b->queue);
  if (!b->memory || !b->queue) {
    bbc_bounder_free(b);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  bbc_arena_init(&b->arena, b->memory, BOUNDER_ARENA_BYTES);
  *out = b;
  return BBC_OK;
}

void bbc_bounder_free(bbc_bounder *b) {
  if (!b) return;
  free(b->memory);
  free(b->queue);
  free(b);
}

bbc_result bbc_tuple_geometry_init(bbc_tuple_geometry *g, const bbc_scene *scene,
                                   const bbc_tuple *tuple) {
  if (tuple->chain != BBC_CHAIN_R && tuple->chain != BBC_CHAIN_T) return BBC_ERR_INVALID_ARGUMENT;
  if (tuple->light >= scene->point_light_count || tuple->specular[0] >= scene->triangle_count ||
      tuple->receiver >= scene->triangle_count)
    return BBC_ERR_INVALID_ARGUMENT;
  memset(g, 0, sizeof *g);
  g->light = scene->point_lights[tuple->light].position;
  const uint32_t *a = scene->indices + 3 * (size_t)tuple->specular[0];
  const uint32_t *b = scene->indices + 3 * (size_t)tuple->receiver;
  for (int i = 0; i < 3; i++) {
    g->p[i] = v3_load(scene->positions + 3 * (size_t)a[i]);
    g->n[i] = v3_load(scene->normals + 3 * (size_t)a[i]);
    g->r[i] = v3_load(scene->positions + 3 * (size_t)b[i]);
  }
  /* Which side of T1 the light is on, with "front" taken from the vertex normals. */
  bbc_vec3 ng = v3_cross(v3_sub(g->p[1], g->p[0]), v3_sub(g->p[2], g->p[0]));
  bbc_vec3 nsum = v3_add(g->n[0], v3_add(g->n[1], g->n[2]));
  if (v3_dot(ng, nsum) < 0) ng = v3_neg(ng);
  int front = v3_dot(ng, v3_sub(g->light, g->p[0])) > 0;
  if (!front)
    for (int i = 0; i < 3; i++) g->n[i] = v3_neg(g->n[i]);
  g->refract = tuple->chain == BBC_CHAIN_T;
  if (g->refract) {
    double ior = bbc_scene_triangle_material(scene, tuple->specular[0])->ior;
    g->eta = front ? 1.0 / ior : ior;
  }
  return BBC_OK;
}

static double cpu_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The range of a receiver coordinate, intersected with [0, 1]. Returns 0 when it cannot
 * lie in [0, 1]; *wide is set when the range reaches beyond the tolerance band. */
static int clip_unit(const bbc_range *r, double *lo, double *hi, int *wide) {
  const double tol = POSITION_TOLERANCE;
  /* Only a bounded range (a denominator of one sign) asks for subdivision by its width,
   * as the supplement's pbad_u2 does; near a sign change of the denominator the bound is
   * a complement or unbounded at every level, and splitting cannot cure that. */
  if (r->kind == BBC_RANGE_UNBOUNDED) {
    *lo = 0;
    *hi = 1;
    return 1;
  }
  if (r->kind == BBC_RANGE_BOUNDED) {
    if (r->hi < 0 || r->lo > 1) return 0;
    *lo = fmax(r->lo, 0.0);
    *hi = fmin(r->hi, 1.0);
    if (r->lo < -tol || r->hi > 1 + tol) *wide = 1;
    return 1;
  }
  /* COMPLEMENT: f <= r->lo or f >= r->hi; keep the bounding box of what is left of
   * [0, 1]. */
  int low_part = r->lo >= 0, high_part = r->hi <= 1;
  if (!low_part && !high_part) return 0;
  *lo = low_part ? 0.0 : fmax(r->hi, 0.0);
  *hi = high_part ? 1.0 : fmin(r->lo, 1.0);
  return 1;
}

typedef enum verdict { VERDICT_DISCARD, VERDICT_PARTIAL, VERDICT_FULL } verdict;

/* Position bound and sign conditions of a piece (Supp. Sec. 4.1 "positional check"). A
 * condition proved false everywhere discards the piece; one that may fail somewhere
 * makes it partial (subdivided while the level allows). */
static bbc_result position_check(bbc_arena *arena, const chain_forms *f, const double box[4],
                                 bbc_piece *piece, verdict *out, int *contained) {
  *out = VERDICT_DISCARD;
  if (contained) *contained = 0;
  /* The box must meet T1: u + v <= 1 somewhere. A box straddling T1's hypotenuse is
   * not subdivided for that alone (every level would have such boxes along it); its
   * bounds simply cover the part outside T1 too, which only loosens them (the
   * supplement's pbad_u1 with its tolerance U_TOL = 1 never fires either). */
  if (box[0] + box[2] > 1.0) return BBC_OK;
  int partial = 0;

  bbc_interval facing = bbc_poly_bound(&f->facing);
  if (facing.hi < 0) return BBC_OK;
  if (facing.lo < 0) partial = 1;
  if (f->has_beta) {
    bbc_interval beta = bbc_poly_bound(&f->beta);
    if (beta.hi < 0) return BBC_OK;
    if (beta.lo < 0) partial = 1;
  }
  /* The ray moves forward: t = tnum / kappa > 0, i.e. tnum kappa > 0. */
  bbc_poly forward;
  bbc_result r = bbc_poly_mul(arena, &forward, &f->tnum, &f->kappa);
  if (r != BBC_OK) return r;
  bbc_interval fw = bbc_poly_bound(&forward);
  if (fw.hi < 0) return BBC_OK;
  if (fw.lo < 0) partial = 1;

  bbc_range ru, rv, rw;
  bbc_poly w;
  if ((r = bbc_poly_add(arena, &w, &f->up, &f->vp)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, &f->up, &f->kappa, &ru)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, &f->vp, &f->kappa, &rv)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, &w, &f->kappa, &rw)) != BBC_OK) return r;
  int wide = 0;
  double w_lo, w_hi;
  if (!clip_unit(&ru, &piece->uk_lo, &piece->uk_hi, &wide)) return BBC_OK;
  if (!clip_unit(&rv, &piece->vk_lo, &piece->vk_hi, &wide)) return BBC_OK;
  /* u_k + v_k <= 1 inside the receiver. */
  if (!clip_unit(&rw, &w_lo, &w_hi, &wide)) return BBC_OK;
  if (piece->uk_lo + piece->vk_lo > 1.0) return BBC_OK;
  /* Every path of the piece lands inside the receiver: nothing to trim off. */
  if (contained)
    *contained = ru.kind == BBC_RANGE_BOUNDED && rv.kind == BBC_RANGE_BOUNDED &&
                 rw.kind == BBC_RANGE_BOUNDED && ru.lo >= 0 && rv.lo >= 0 && rw.hi <= 1;
  *out = partial || wide ? VERDICT_PARTIAL : VERDICT_FULL;
  return BBC_OK;
}

/* |E| per unit intensity from the signed rational form P/Q: the magnitude's range. */
static void magnitude(const bbc_range *r, double *lo, double *hi) {
  if (r->kind != BBC_RANGE_BOUNDED) {
    *lo = 0;
    *hi = INFINITY;
  } else if (r->lo >= 0) {
    *lo = r->lo;
    *hi = r->hi;
  } else if (r->hi <= 0) {
    *lo = -r->hi;
    *hi = -r->lo;
  } else {
    *lo = 0;
    *hi = fmax(-r->lo, r->hi);
  }
}

/* The irradiance bound of a piece per unit intensity (Eq. 14-16, Supp. 2.1):
 * E = cos(theta0) / |d0|^2 * |e11 x e12| * |du1/duk| / |ek1 x ek2|, with
 * |du1/duk| = |q|^3 / |D_uv| and D_uv = D_st / (du dv) (DESIGN 3.5). cos(theta0) = h/|d0|
 * is factored out and bounded by intervals (Supp. 2.1); the rest is the rational
 * q^3 / (|d0|^2 D_st) (or q^4 / (|d0|^2 N) in the quotient-rule form). */
static bbc_result irradiance_bound(bbc_arena *arena, const bbc_tuple_geometry *g,
                                   const chain_forms *f, const double box[4], int s_axis,
                                   int t_axis, bbc_jacobian_form form, double *e_lo, double *e_hi) {
  *e_lo = 0;
  *e_hi = INFINITY;
  if (!f->slope_enclosed) return BBC_OK;
  const bbc_poly *q = &f->kappa, *p = &f->up, *r = &f->vp;
  bbc_poly qs, qt, ps, pt, rs, rt;
  bbc_result res;
#define TRY(expr)                             \
  do {                                        \
    if ((res = (expr)) != BBC_OK) return res; \
  } while (0)
  TRY(bbc_poly_derivative(arena, &qs, q, s_axis));
  TRY(bbc_poly_derivative(arena, &qt, q, t_axis));
  TRY(bbc_poly_derivative(arena, &ps, p, s_axis));
  TRY(bbc_poly_derivative(arena, &pt, p, t_axis));
  TRY(bbc_poly_derivative(arena, &rs, r, s_axis));
  TRY(bbc_poly_derivative(arena, &rt, r, t_axis));
  bbc_poly num, den, jac, q2, a, b, c;
  TRY(bbc_poly_mul(arena, &q2, q, q));
  if (form == BBC_JACOBIAN_DETERMINANT) {
    /* D = q (p_s r_t - p_t r_s) - p (q_s r_t - q_t r_s) + r (q_s p_t - q_t p_s). */
    bbc_poly m1, m2, t1, t2, t3;
    TRY(bbc_poly_mul(arena, &m1, &ps, &rt));
    TRY(bbc_poly_mul(arena, &m2, &pt, &rs));
    TRY(bbc_poly_sub(arena, &a, &m1, &m2));
    TRY(bbc_poly_mul(arena, &t1, q, &a));
    TRY(bbc_poly_mul(arena, &m1, &qs, &rt));
    TRY(bbc_poly_mul(arena, &m2, &qt, &rs));
    TRY(bbc_poly_sub(arena, &b, &m1, &m2));
    TRY(bbc_poly_mul(arena, &t2, p, &b));
    TRY(bbc_poly_mul(arena, &m1, &qs, &pt));
    TRY(bbc_poly_mul(arena, &m2, &qt, &ps));
    TRY(bbc_poly_sub(arena, &c, &m1, &m2));
    TRY(bbc_poly_mul(arena, &t3, r, &c));
    TRY(bbc_poly_sub(arena, &jac, &t1, &t2));
    TRY(bbc_poly_add(arena, &jac, &jac, &t3));
    TRY(bbc_poly_mul(arena, &num, &q2, q));
  } else {
    /* N = (p_s q - p q_s)(r_t q - r q_t) - (p_t q - p q_t)(r_s q - r q_s). */
    bbc_poly m1, m2, us, ut, vs, vt, x, y;
    TRY(bbc_poly_mul(arena, &m1, &ps, q));
    TRY(bbc_poly_mul(arena, &m2, p, &qs));
    TRY(bbc_poly_sub(arena, &us, &m1, &m2));
    TRY(bbc_poly_mul(arena, &m1, &pt, q));
    TRY(bbc_poly_mul(arena, &m2, p, &qt));
    TRY(bbc_poly_sub(arena, &ut, &m1, &m2));
    TRY(bbc_poly_mul(arena, &m1, &rs, q));
    TRY(bbc_poly_mul(arena, &m2, r, &qs));
    TRY(bbc_poly_sub(arena, &vs, &m1, &m2));
    TRY(bbc_poly_mul(arena, &m1, &rt, q));
    TRY(bbc_poly_mul(arena, &m2, r, &qt));
    TRY(bbc_poly_sub(arena, &vt, &m1, &m2));
    TRY(bbc_poly_mul(arena, &x, &us, &vt));
    TRY(bbc_poly_mul(arena, &y, &ut, &vs));
    TRY(bbc_poly_sub(arena, &jac, &x, &y));
    TRY(bbc_poly_mul(arena, &num, &q2, &q2));
  }
  TRY(bbc_poly_mul(arena, &den, &f->dist2, &jac));
  bbc_range ratio;
  TRY(bbc_rational_bound(arena, &num, &den, &ratio));
#undef TRY
  double lo, hi;
  magnitude(&ratio, &lo, &hi);

  /* Constant factors, in outward-rounded interval arithmetic from the exact vertices:
   * |e11 x e12| du dv / |ek1 x ek2|, and cos(theta0) = h / |d0| with h the distance from
   * the light to T1's plane and |d0| bounded through d0 . d0. */
  bbc_ivec3 p0 = bbc_ivec3_point(g->p[0]);
  bbc_ivec3 c1 = bbc_ivec3_cross(bbc_ivec3_sub(bbc_ivec3_point(g->p[1]), p0),
                                 bbc_ivec3_sub(bbc_ivec3_point(g->p[2]), p0));
  bbc_ivec3 r0 = bbc_ivec3_point(g->r[0]);
  bbc_ivec3 ck = bbc_ivec3_cross(bbc_ivec3_sub(bbc_ivec3_point(g->r[1]), r0),
                                 bbc_ivec3_sub(bbc_ivec3_point(g->r[2]), r0));
  bbc_interval a1 = bbc_interval_sqrt(bbc_ivec3_dot(c1, c1));
  bbc_interval ak = bbc_interval_sqrt(bbc_ivec3_dot(ck, ck));
  bbc_interval h =
      bbc_interval_div(bbc_ivec3_dot(c1, bbc_ivec3_sub(p0, bbc_ivec3_point(g->light))), a1);
  h = bbc_interval_make(fabs(h.lo), fabs(h.hi));
  if (h.lo > h.hi) h = bbc_interval_make(h.hi, h.lo);
  bbc_interval dist2 = bbc_poly_bound(&f->dist2);
  if (dist2.lo < 0) dist2.lo = 0;
  bbc_interval cos0 = bbc_interval_div(h, bbc_interval_sqrt(dist2));
  if (cos0.hi > 1) cos0.hi = 1;
  bbc_interval k =
      bbc_interval_div(bbc_interval_scale(a1, (box[1] - box[0]) * (box[3] - box[2])), ak);
  bbc_interval scale = bbc_interval_mul(k, cos0);
  if (!(scale.lo >= 0)) scale.lo = 0;
  /* Rounded products of positive numbers, pushed a few ulps outward. */
  *e_lo = lo > 0 && isfinite(scale.lo) ? lo * scale.lo * (1 - 4 * DBL_EPSILON) : 0;
  *e_hi = isfinite(hi) ? hi * scale.hi * (1 + 4 * DBL_EPSILON) : INFINITY;
  if (!(*e_hi >= 0)) *e_hi = INFINITY; /* NaN from an unbounded scale */
  return BBC_OK;
}

static bbc_result push(bbc_bounder *b, size_t *count, const bbc_piece *piece) {
  if (*count == b->queue_capacity) {
    size_t capacity = b->queue_capacity * 2;
    bbc_piece *queue = realloc(b->queue, capacity * sizeof *queue);
    if (!queue) return BBC_ERR_OUT_OF_MEMORY;
    b->queue = queue;
    b->queue_capacity = capacity;
  }
  b->queue[(*count)++] = *piece;
  return BBC_OK;
}

/* The forms of a piece in a fresh arena and variable space, and its position check. */
typedef struct piece_forms {
  double box[4];
  bbc_space space;
  int s_axis, t_axis;
  chain_forms forms;
} piece_forms;

static bbc_result examine_position(bbc_bounder *b, const bbc_tuple_geometry *g,
                                   chain_sqrt_mode mode, bbc_piece *piece, piece_forms *pf,
                                   verdict *v, int *contained) {
  pf->box[0] = piece->u_lo, pf->box[1] = piece->u_hi;
  pf->box[2] = piece->v_lo, pf->box[3] = piece->v_hi;
  bbc_arena_reset(&b->arena, 0);
  memset(&pf->space, 0, sizeof pf->space);
  bbc_space_add_axis(&pf->space, BBC_AXIS_GEOMETRIC, &pf->s_axis);
  bbc_space_add_axis(&pf->space, BBC_AXIS_GEOMETRIC, &pf->t_axis);
  bbc_result r =
      bbc__chain_forms(&b->arena, &pf->space, g, pf->box, pf->s_axis, pf->t_axis, mode, &pf->forms);
  if (r == BBC_OK) r = position_check(&b->arena, &pf->forms, pf->box, piece, v, contained);
  return r;
}

/* Domain initialisation (paper Sec. 6.1): a breadth-first pass of position checks alone,
 * down to DOMAIN_INIT_LEVELS (at most 4 + 16 + 64 pieces), finds where u1 can send light
 * into the receiver; the subdivision then starts from the bounding box of those pieces.
 * Only a piece whose position bound reaches past the receiver's edges is split here: a
 * piece whose light all lands inside cannot be trimmed. Pieces proved empty are
 * reported as discarded leaves (with the later leaves they cover all of T1). *root is
 * the box, or marked discarded when nothing survives. */
#define DOMAIN_INIT_LEVELS 3

static bbc_result domain_init(bbc_bounder *b, const bbc_tuple_geometry *g, chain_sqrt_mode mode,
                              bbc_piece_fn fn, void *user, bbc_piece *root,
                              bbc_bound_stats *local) {
  memset(root, 0, sizeof *root);
  root->status = BBC_PIECE_DISCARDED;
  double lo_u = 1, lo_v = 1, hi_u = 0, hi_v = 0;
  double t0 = cpu_seconds();
  bbc_piece stack[4 * DOMAIN_INIT_LEVELS + 1];
  int top = 0;
  memset(&stack[0], 0, sizeof stack[0]);
  stack[0].u_hi = stack[0].v_hi = 1;
  top = 1;
  bbc_result result = BBC_OK;
  while (top > 0 && result == BBC_OK) {
    bbc_piece piece = stack[--top];
    piece_forms pf;
    verdict v = VERDICT_PARTIAL;
    int contained = 0;
    result = examine_position(b, g, mode, &piece, &pf, &v, &contained);
    local->position_pieces++;
    if (result != BBC_OK) break;
    if (v == VERDICT_DISCARD) {
      piece.status = BBC_PIECE_DISCARDED;
      local->discarded_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    if (!contained && piece.level < DOMAIN_INIT_LEVELS) {
      /* Depth first, so the stack holds at most 3 siblings per level plus one. */
      double um = 0.5 * (piece.u_lo + piece.u_hi), vm = 0.5 * (piece.v_lo + piece.v_hi);
      const double us[3] = {piece.u_lo, um, piece.u_hi}, vs[3] = {piece.v_lo, vm, piece.v_hi};
      for (int q = 0; q < 4; q++) {
        bbc_piece child;
        memset(&child, 0, sizeof child);
        child.level = piece.level + 1;
        child.u_lo = us[q & 1], child.u_hi = us[(q & 1) + 1];
        child.v_lo = vs[q >> 1], child.v_hi = vs[(q >> 1) + 1];
        if (child.u_lo + child.v_lo >= 1.0) continue; /* outside T1 but for a corner */
        stack[top++] = child;
      }
      continue;
    }
    lo_u = fmin(lo_u, piece.u_lo);
    lo_v = fmin(lo_v, piece.v_lo);
    hi_u = fmax(hi_u, piece.u_hi);
    hi_v = fmax(hi_v, piece.v_hi);
  }
  local->position_seconds += cpu_seconds() - t0;
  if (result != BBC_OK || hi_u <= lo_u) return result;
  root->status = BBC_PIECE_KEPT;
  root->u_lo = lo_u, root->u_hi = hi_u, root->v_lo = lo_v, root->v_hi = hi_v;
  /* Levels count halvings of T1's unit box: the box's longer side is 2^-level. */
  double span = fmax(hi_u - lo_u, hi_v - lo_v);
  while (root->level < DOMAIN_INIT_LEVELS && span <= ldexp(1.0, -(root->level + 1))) root->level++;
  return BBC_OK;
}

bbc_result bbc_bound_tuple(bbc_bounder *b, const bbc_tuple_geometry *g,
                           const bbc_bound_params *params, bbc_piece_fn fn, void *user,
                           bbc_bound_stats *stats) {
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  if (params) prm = *params;
  const int max_level = prm.max_level > 0 ? prm.max_level : 10;
  const double sigma = prm.sigma > 0 ? prm.sigma : 1e-4;
  const double alpha = prm.alpha > 0 ? prm.alpha : 2.0;
  const chain_sqrt_mode position_mode =
      prm.no_remainder ? CHAIN_SQRT_NO_REMAINDER : CHAIN_SQRT_PRIMAL;
  const chain_sqrt_mode irradiance_mode =
      prm.no_remainder ? CHAIN_SQRT_NO_REMAINDER : CHAIN_SQRT_DERIVATIVE_AWARE;
  bbc_bound_stats local;
  memset(&local, 0, sizeof local);
  local.tuples = 1;

  bbc_piece root;
  bbc_result result = domain_init(b, g, position_mode, fn, user, &root, &local);
  if (result != BBC_OK || root.status == BBC_PIECE_DISCARDED) goto done;

  /* Breadth-first: a FIFO over the queue array, compacted when it drains. */
  size_t head = 0, count = 0;
  result = push(b, &count, &root);
  while (result == BBC_OK && head < count) {
    bbc_piece piece = b->queue[head++];
    if (head == count) head = count = 0;
    double t0 = cpu_seconds();
    piece_forms pf;
    verdict v = VERDICT_PARTIAL;
    result = examine_position(b, g, position_mode, &piece, &pf, &v, NULL);
    const double *box = pf.box;
    const int s_axis = pf.s_axis, t_axis = pf.t_axis;
    bbc_space space = pf.space;
    const chain_forms forms = pf.forms;
    local.position_pieces++;
    double t1 = cpu_seconds();
    local.position_seconds += t1 - t0;
    if (result != BBC_OK) break;

    if (v == VERDICT_DISCARD) {
      piece.status = BBC_PIECE_DISCARDED;
      local.discarded_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    int can_split = piece.level < max_level;
    double area = (piece.uk_hi - piece.uk_lo) * (piece.vk_hi - piece.vk_lo);
    int split = 0;
    piece.e_lo = 0;
    piece.e_hi = INFINITY;
    if (can_split && v == VERDICT_PARTIAL) {
      split = 1;
    } else if (!prm.positions_only) {
      /* Reflection has no remainder variables: its position forms serve as they are. */
      const chain_forms *irr = &forms;
      chain_forms irr_forms;
      if (g->refract && irradiance_mode != position_mode) {
        result = bbc__chain_forms(&b->arena, &space, g, box, s_axis, t_axis, irradiance_mode,
                                  &irr_forms);
        irr = &irr_forms;
      }
      if (result == BBC_OK)
        result = irradiance_bound(&b->arena, g, irr, box, s_axis, t_axis, prm.jacobian, &piece.e_lo,
                                  &piece.e_hi);
      local.irradiance_pieces++;
      local.irradiance_seconds += cpu_seconds() - t1;
      if (result != BBC_OK) break;
      split = can_split && area >= sigma && !(piece.e_hi < alpha * piece.e_lo);
    } else {
      split = can_split && area >= sigma;
    }

    if (split) {
      double um = 0.5 * (piece.u_lo + piece.u_hi), vm = 0.5 * (piece.v_lo + piece.v_hi);
      bbc_piece child;
      memset(&child, 0, sizeof child);
      child.level = piece.level + 1;
      const double us[3] = {piece.u_lo, um, piece.u_hi}, vs[3] = {piece.v_lo, vm, piece.v_hi};
      for (int j = 0; j < 2 && result == BBC_OK; j++) {
        for (int i = 0; i < 2 && result == BBC_OK; i++) {
          child.u_lo = us[i];
          child.u_hi = us[i + 1];
          child.v_lo = vs[j];
          child.v_hi = vs[j + 1];
          result = push(b, &count, &child);
        }
      }
      continue;
    }
    piece.status = BBC_PIECE_KEPT;
    local.kept_pieces++;
    if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
  }
done:
  if (stats) {
    stats->tuples += local.tuples;
    stats->position_pieces += local.position_pieces;
    stats->irradiance_pieces += local.irradiance_pieces;
    stats->kept_pieces += local.kept_pieces;
    stats->discarded_pieces += local.discarded_pieces;
    stats->position_seconds += local.position_seconds;
    stats->irradiance_seconds += local.irradiance_seconds;
  }
  return result;
}
