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
#include "bounder_internal.h"
#include "chain_internal.h"
#include "light_internal.h"
#include "media_internal.h"
#include "rounding_internal.h"
#include "vec_internal.h"

/* Working memory per piece: the largest single-refraction irradiance forms need a few
 * MB, double refraction with interpolated normals tens of MB; 256 MB of address space
 * leaves room for every intermediate without reuse (only what is touched is resident). */
#define BOUNDER_ARENA_BYTES ((size_t)256 << 20)
/* The supplement's U_TOL: a position bound reaching this far outside the receiver's
 * [0,1] range asks for subdivision. */
#define POSITION_TOLERANCE 1.0

/* Single reflection from a point, spot or directional light: a piece's forms are those
 * of its parent halved (polys_quadrants) instead of being computed again. The forms a
 * piece needs for its position and irradiance bounds (Eq. 4-5, 16): */
#define PIECE_FORMS 6 /* up, vp, kappa, tnum, facing, dist2 */
/* Then the numerator and denominator of the explicit irradiance bound's rational
 * (jacobian_rational), carried alike: halving re-parameterises them exactly too. */
#define PIECE_POLYS (PIECE_FORMS + 2)
/* Room for their coefficients, one after the other: with interpolated normals up and vp
 * have degree 4 on both axes, kappa 3, facing and dist2 2, tnum 1 (25 + 25 + 16 + 9 + 9 +
 * 4 = 88); the Jacobian's numerator kappa^3 degree 9 (100) and denominator dist2 D
 * degree 12 (169). */
#define PIECE_FORM_COEFS 357

/* A queued piece's forms, by value (degrees, radii, coefficients). */
typedef struct piece_polys {
  int count; /* PIECE_FORMS, or PIECE_POLYS with the Jacobian's rational */
  /* The area of the (u, v) box on whose (s, t) the Jacobian's derivatives were taken:
   * a quadrant's derivatives are its parent's over 2 on each axis, which the carried
   * polynomials keep, so the irradiance scale takes this area, not the piece's. */
  double jacobian_area;
  unsigned char deg[PIECE_POLYS][BBC_POLY_MAX_AXES];
  double err[PIECE_POLYS];
  double coef[PIECE_FORM_COEFS];
} piece_polys;

struct bbc_bounder {
  bbc_arena arena;
  void *memory;
  bbc_piece *queue; /* breadth-first queue of pieces to examine */
  size_t queue_capacity;
  /* With split_forms, queued piece i's forms are quadrant origin[i] % 8 of parent
   * forms[origin[i] / 8 - forms_base] (0-3, polys_quadrants' order; 4: the parent's
   * whole, for the root). The parents are a FIFO too, since pieces are queued and
   * examined in their parents' order. Siblings are examined one after the other, so the
   * four quadrants of parent quadrants_of are made once, for the first of them. */
  int split_forms;
  uint64_t *origin;
  piece_polys *forms;
  size_t forms_capacity, forms_head, forms_count;
  uint64_t forms_base;
  uint64_t quadrants_of; /* UINT64_MAX: none */
  piece_polys quadrants[4];
  /* Two reflections: the position forms of the tuple's pieces split by the position
   * refinement, for their quarters (refined_store); a quarter's origin is 8 (k + 1) + q
   * for parent k and quarter q (origins below 8 carry nothing). */
  struct refined_parent *refined;
  size_t refined_count, refined_capacity;
  double *refined_coef;
  size_t refined_coef_used, refined_coef_capacity;
};

bbc_result bbc_bounder_create(bbc_bounder **out) {
  *out = NULL;
  bbc_bounder *b = calloc(1, sizeof *b);
  if (!b) return BBC_ERR_OUT_OF_MEMORY;
  b->memory = malloc(BOUNDER_ARENA_BYTES);
  b->queue_capacity = 1024;
  b->queue = malloc(b->queue_capacity * sizeof *b->queue);
  b->origin = malloc(b->queue_capacity * sizeof *b->origin);
  b->forms_capacity = 256;
  b->forms = malloc(b->forms_capacity * sizeof *b->forms);
  if (!b->memory || !b->queue || !b->origin || !b->forms) {
    bbc_bounder_free(b);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  bbc_arena_init(&b->arena, b->memory, BOUNDER_ARENA_BYTES);
  *out = b;
  return BBC_OK;
}

void bbc_bounder_free(bbc_bounder *b) {
  if (!b) return;
  free(b->refined);
  free(b->refined_coef);
  free(b->memory);
  free(b->queue);
  free(b->origin);
  free(b->forms);
  free(b);
}

/* Loads triangle t's vertices and normals and orients the normals toward the side of its
 * plane that `from` lies on ("front" taken from the vertex normals). Returns whether that
 * side is the front. */
static int load_oriented(const bbc_scene *scene, uint32_t t, bbc_vec3 from, bbc_vec3 p[3],
                         bbc_vec3 n[3]) {
  const uint32_t *a = scene->indices + 3 * (size_t)t;
  for (int i = 0; i < 3; i++) {
    p[i] = v3_load(scene->positions + 3 * (size_t)a[i]);
    n[i] = v3_load(scene->normals + 3 * (size_t)a[i]);
  }
  bbc_vec3 ng = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
  bbc_vec3 nsum = v3_add(n[0], v3_add(n[1], n[2]));
  if (v3_dot(ng, nsum) < 0) ng = v3_neg(ng);
  int front = v3_dot(ng, v3_sub(from, p[0])) > 0;
  if (!front)
    for (int i = 0; i < 3; i++) n[i] = v3_neg(n[i]);
  return front;
}

bbc_result bbc_tuple_geometry_init(bbc_tuple_geometry *g, const bbc_scene *scene,
                                   const bbc_tuple *tuple) {
  if (tuple->chain >= BBC_CHAIN_COUNT) return BBC_ERR_INVALID_ARGUMENT;
  const int length = bbc_chain_length((bbc_chain)tuple->chain);
  const int64_t emitter = bbc_scene_light_emitter(scene, tuple->light);
  if ((tuple->light >= scene->point_light_count && emitter < 0) ||
      tuple->specular[0] >= scene->triangle_count ||
      (length == 2 && (tuple->specular[1] >= scene->triangle_count ||
                       tuple->specular[1] == tuple->specular[0])))
    return BBC_ERR_INVALID_ARGUMENT;
  memset(g, 0, sizeof *g);
  /* An area light stands at its centroid for orienting T1 (bounds.h). */
  const bbc_point_light light = bbc__cache_light_point(scene, tuple->light);
  g->light = light.position;
  g->light_model = light.model;
  g->length = length;
  /* A beam tuple ends on no triangle: its r stays zero (bbc_bound_beam ignores it). */
  if (!bbc_receiver_is_beam(tuple->receiver) &&
      !bbc_receiver_triangle(scene, tuple->receiver, g->r))
    return BBC_ERR_INVALID_ARGUMENT;
  const uint32_t *a = scene->indices + 3 * (size_t)tuple->specular[0];
  bbc_vec3 source =
      bbc__light_source(g->light, &g->light_model, v3_load(scene->positions + 3 * (size_t)a[0]));
  int front = load_oriented(scene, tuple->specular[0], source, g->p, g->n);
  g->refract = bbc_chain_refracts((bbc_chain)tuple->chain, 0);
  if (g->refract) {
    g->eta = bbc__media_eta(scene, tuple->specular[0], front ? 1 : -1);
  }
  if (length == 2) {
    bbc_vec3 centroid = v3_scale(v3_add(g->p[0], v3_add(g->p[1], g->p[2])), 1.0 / 3.0);
    int front2 = load_oriented(scene, tuple->specular[1], centroid, g->p2, g->n2);
    g->refract2 = bbc_chain_refracts((bbc_chain)tuple->chain, 1);
    if (g->refract2) {
      g->eta2 = bbc__media_eta(scene, tuple->specular[1], front2 ? 1 : -1);
    }
  }
  return BBC_OK;
}

/* Timing: the position and irradiance bounds' time on the monotonic clock, read per
 * piece (no system call, unlike a thread's CPU clock); bbc_precompute turns it into CPU
 * time per batch of tuples. */
static double clock_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
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

/* p at x, a corner of the axes s and t (x[s], x[t] in {0, 1}): when p depends on no
 * other axis, its coefficients are finite (`finite`, coefficients_finite) and the
 * corner's is not zero, that corner
 * coefficient, which is exactly what de Casteljau's evaluation (bbc_poly_eval) returns
 * there (each step adds a product by 0, a finite zero, to the corner's value); otherwise
 * bbc_poly_eval (whose zeros' signs and NaNs this does not reproduce). */
static double corner_value(const bbc_poly *p, int finite, int s_axis, int t_axis, const double *x) {
  size_t stride_s = 1, stride_t = 1;
  for (int j = BBC_POLY_MAX_AXES - 1; j >= 0; j--) {
    if (j == s_axis || j == t_axis || p->deg[j] == 0) continue;
    return bbc_poly_eval(p, x);
  }
  /* Last axis fastest: the stride of an axis is the product of the later axes' sizes. */
  for (int j = BBC_POLY_MAX_AXES - 1; j > s_axis; j--) stride_s *= (size_t)p->deg[j] + 1;
  for (int j = BBC_POLY_MAX_AXES - 1; j > t_axis; j--) stride_t *= (size_t)p->deg[j] + 1;
  const size_t at = (x[s_axis] != 0 ? p->deg[s_axis] * stride_s : 0) +
                    (x[t_axis] != 0 ? p->deg[t_axis] * stride_t : 0);
  const double v = p->coef[at];
  return finite && v != 0 ? v : bbc_poly_eval(p, x);
}

/* Whether every coefficient of p is finite (corner_value's condition). */
static int coefficients_finite(const bbc_poly *p) {
  const size_t n = bbc_poly_size(p);
  int finite = 1;
  for (size_t i = 0; i < n; i++) finite &= isfinite(p->coef[i]);
  return finite;
}

/* The cuts of a position bound (bbc_piece.cut) across the two sides of the image of the
 * piece, u_k = up / kappa, v_k = vp / kappa over the axes s and t: their directions are
 * taken from the image of the box's corners (plain floating point: they only choose
 * where to cut), their ranges bounded like the octagon's. */
static bbc_result side_cuts(bbc_arena *arena, const bbc_poly *up, const bbc_poly *vp,
                            const bbc_poly *kappa, const bbc_poly *kappa_up, int s_axis,
                            int t_axis, double cut[2][4]) {
  memset(cut, 0, 2 * sizeof cut[0]);
  double x[BBC_POLY_MAX_AXES], c[4][2];
  for (int i = 0; i < BBC_POLY_MAX_AXES; i++) x[i] = 0.5;
  const int fq = coefficients_finite(kappa), fu = coefficients_finite(up),
            fv = coefficients_finite(vp);
  for (int k = 0; k < 4; k++) {
    x[s_axis] = k & 1, x[t_axis] = k >> 1;
    double q = corner_value(kappa, fq, s_axis, t_axis, x),
           pu = corner_value(up, fu, s_axis, t_axis, x),
           pv = corner_value(vp, fv, s_axis, t_axis, x);
    c[k][0] = pu / q, c[k][1] = pv / q;
  }
  /* The sides along s and along t, each the mean of its two opposite edges. */
  const double side[2][2] = {{c[1][0] - c[0][0] + c[3][0] - c[2][0], c[1][1] - c[0][1] + c[3][1] - c[2][1]},
                             {c[2][0] - c[0][0] + c[3][0] - c[1][0], c[2][1] - c[0][1] + c[3][1] - c[1][1]}};
  for (int j = 0; j < 2; j++) {
    /* The normal of the side, scaled to a largest component of 1. */
    double a = -side[j][1], b = side[j][0], m = fmax(fabs(a), fabs(b));
    if (!(m > 0 && m < INFINITY)) continue;
    a /= m, b /= m;
    const double alpha[2] = {a, b};
    const bbc_poly *terms[2] = {up, vp};
    size_t mark = bbc_arena_mark(arena);
    bbc_poly w;
    bbc_range rw;
    bbc_result r = bbc_poly_lincomb(arena, &w, 2, alpha, terms);
    if (r == BBC_OK) r = bbc_rational_bound(arena, &w, kappa_up, &rw);
    bbc_arena_reset(arena, mark);
    if (r != BBC_OK) return r;
    if (rw.kind != BBC_RANGE_BOUNDED) continue;
    cut[j][0] = a, cut[j][1] = b, cut[j][2] = rw.lo, cut[j][3] = rw.hi;
  }
  return BBC_OK;
}

/* kappa in the degrees of up and vp where those are the same and at least kappa's
 * (elevated once for the several rational bounds over it, which would each elevate it
 * alike: bbc_rational_bound's result is the same), else kappa itself. */
static bbc_result denominator_for(bbc_arena *arena, const bbc_poly *up, const bbc_poly *vp,
                                  const bbc_poly *kappa, bbc_poly *out) {
  *out = *kappa;
  if (memcmp(up->deg, vp->deg, sizeof up->deg) != 0) return BBC_OK;
  for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
    if (up->deg[j] < kappa->deg[j]) return BBC_OK;
  if (memcmp(up->deg, kappa->deg, sizeof up->deg) == 0) return BBC_OK;
  return bbc_poly_elevate(arena, out, kappa, up->deg);
}

/* Where a ray lands on a triangle with u = up / kappa, v = vp / kappa, moving forward
 * where tnum kappa > 0: sets *partial to -1 when no path of the piece can land inside
 * (forward), to 1 when some may move backward; *wide when the bound reaches past the
 * tolerance band.
 * box (may be NULL) receives the (u, v) bound clipped to the triangle's range, and
 * *inside (may be NULL) whether every path provably lands inside. kappa_up (may be NULL)
 * receives kappa as denominator_for gives it. */
static bbc_result ray_lands(bbc_arena *arena, const bbc_poly *up, const bbc_poly *vp,
                            const bbc_poly *kappa, const bbc_poly *tnum, double box[8],
                            int *partial, int *wide, int *inside, bbc_poly *kappa_up) {
  bbc_poly forward, w;
  bbc_result r = bbc_poly_mul(arena, &forward, tnum, kappa);
  if (r != BBC_OK) return r;
  bbc_interval fw = bbc_poly_bound(&forward);
  if (fw.hi < 0) {
    *partial = -1;
    return BBC_OK;
  }
  if (fw.lo < 0) *partial = 1;
  bbc_range ru, rv, rw;
  bbc_poly ku;
  if ((r = denominator_for(arena, up, vp, kappa, &ku)) != BBC_OK) return r;
  if (kappa_up) *kappa_up = ku;
  kappa = &ku;
  if ((r = bbc_poly_add(arena, &w, up, vp)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, up, kappa, &ru)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, vp, kappa, &rv)) != BBC_OK) return r;
  if ((r = bbc_rational_bound(arena, &w, kappa, &rw)) != BBC_OK) return r;
  double b[4], w_lo, w_hi;
  /* u + v <= 1 inside the triangle. */
  if (!clip_unit(&ru, &b[0], &b[1], wide) || !clip_unit(&rv, &b[2], &b[3], wide) ||
      !clip_unit(&rw, &w_lo, &w_hi, wide) || b[0] + b[2] > 1.0) {
    *partial = -1;
    return BBC_OK;
  }
  int in = ru.kind == BBC_RANGE_BOUNDED && rv.kind == BBC_RANGE_BOUNDED &&
           rw.kind == BBC_RANGE_BOUNDED && ru.lo >= 0 && rv.lo >= 0 && rw.hi <= 1;
  if (box) {
    /* The receiver's box, then the bounds of u + v and u - v (the octagon's diagonals;
     * u - v lies in [-1, 1] inside the triangle). */
    memcpy(box, b, sizeof b);
    box[4] = w_lo, box[5] = w_hi, box[6] = -1, box[7] = 1;
    bbc_poly d;
    bbc_range rd;
    if ((r = bbc_poly_sub(arena, &d, up, vp)) != BBC_OK) return r;
    if ((r = bbc_rational_bound(arena, &d, kappa, &rd)) != BBC_OK) return r;
    if (rd.kind == BBC_RANGE_BOUNDED) {
      if (rd.hi < -1 || rd.lo > 1) {
        *partial = -1;
        return BBC_OK;
      }
      box[6] = fmax(rd.lo, -1.0), box[7] = fmin(rd.hi, 1.0);
    }
  }
  if (inside) *inside = in;
  return BBC_OK;
}

/* Whether a tuple's pieces take their forms from their parents' (polys_quadrants): single
 * reflection from a point, spot or directional light, whose forms are polynomials in
 * T1's barycentrics (no remainder variables, no light box), so the root's forms hold
 * those of every piece exactly, but for rounding. (A remainder variable's
 * linearisation is tighter on a smaller box: refraction computes its forms per piece.) */
static int carries_forms(const bbc_tuple_geometry *g) {
  return g->length == 1 && !g->refract && g->light_model.kind != BBC_LIGHT_AREA;
}

/* Polynomial k of a piece's carried ones: the forms, then jac[0] and jac[1]. */
static bbc_poly *form_of(chain_forms *f, bbc_poly *jac, int k) {
  bbc_poly *polys[PIECE_FORMS] = {&f->up, &f->vp, &f->kappa, &f->tnum, &f->facing, &f->dist2};
  return k < PIECE_FORMS ? polys[k] : &jac[k - PIECE_FORMS];
}

/* The forms as a queued piece carries them, with the Jacobian's rational when jac is not
 * NULL (taken on a box of that area); 0 when they need more than PIECE_FORM_COEFS
 * coefficients or one depends on an axis other than s and t. */
static int polys_store(chain_forms *f, bbc_poly *jac, double area, int s_axis, int t_axis,
                       piece_polys *out) {
  size_t at = 0;
  out->count = jac ? PIECE_POLYS : PIECE_FORMS;
  out->jacobian_area = area;
  for (int k = 0; k < out->count; k++) {
    const bbc_poly *p = form_of(f, jac, k);
    for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
      if (p->deg[j] != 0 && j != s_axis && j != t_axis) return 0;
    const size_t n = bbc_poly_size(p);
    if (n > PIECE_FORM_COEFS - at) return 0;
    memcpy(out->deg[k], p->deg, sizeof out->deg[k]);
    out->err[k] = p->err;
    memcpy(out->coef + at, p->coef, n * sizeof *p->coef);
    at += n;
  }
  return 1;
}

/* The carried forms as chain_forms of single reflection (the polynomials borrow polys'
 * coefficients; the other members are empty, as no bound of reflection uses them), and
 * in jac (when polys has them) the Jacobian's rational. */
static void polys_view(const piece_polys *polys, chain_forms *f, bbc_poly jac[2]) {
  memset(f, 0, sizeof *f);
  f->length = 1;
  f->slope_enclosed = 1;
  size_t at = 0;
  for (int k = 0; k < (jac ? polys->count : PIECE_FORMS); k++) {
    bbc_poly *p = form_of(f, jac, k);
    memcpy(p->deg, polys->deg[k], sizeof p->deg);
    p->err = polys->err[k];
    p->coef = (double *)polys->coef + at;
    at += bbc_poly_size(p);
  }
}

/* The forms of the four quadrants of a piece (out[q]: u half q & 1, v half q >> 1, the
 * order in which the subdivision queues them) from the piece's: each form halved along s,
 * then each half along t, by de Casteljau subdivisions at 1/2 (one pass gives both
 * halves), exact re-parameterisations whose rounding bbc_poly_split adds to the radius.
 * A quadrant's forms thus hold its paths as the forms computed on its own box would, up
 * to rounding. */
static bbc_result polys_quadrants(bbc_arena *arena, const piece_polys *parent, int s_axis,
                                  int t_axis, piece_polys out[4]) {
  size_t mark = bbc_arena_mark(arena), at = 0;
  chain_forms f;
  bbc_poly jac[2];
  polys_view(parent, &f, jac);
  bbc_result r = BBC_OK;
  for (int q = 0; q < 4; q++)
    out[q].count = parent->count, out[q].jacobian_area = parent->jacobian_area;
  for (int k = 0; k < parent->count && r == BBC_OK; k++) {
    bbc_poly half[2], quarter[4];
    r = bbc_poly_split(arena, form_of(&f, jac, k), s_axis, &half[0], &half[1]);
    for (int i = 0; i < 2 && r == BBC_OK; i++)
      r = bbc_poly_split(arena, &half[i], t_axis, &quarter[i], &quarter[2 + i]);
    if (r != BBC_OK) break;
    /* Halving keeps the degrees, so the layout stays the parent's. */
    const size_t n = bbc_poly_size(&quarter[0]);
    for (int q = 0; q < 4; q++) {
      memcpy(out[q].deg[k], quarter[q].deg, sizeof out[q].deg[k]);
      out[q].err[k] = quarter[q].err;
      memcpy(out[q].coef + at, quarter[q].coef, n * sizeof *quarter[q].coef);
    }
    at += n;
  }
  bbc_arena_reset(arena, mark);
  return r;
}

/* Two reflections: the forms the position check reads (position_check), which the
 * position refinement carries from a piece to its quarters. Halving re-parameterises
 * each exactly (bbc_poly_split adds the rounding to its radius); the radius each form got
 * when it was computed (the flattening's, chain_double.c) stays the parent's. That costs
 * nothing measurable for reflection (wavy-corner RR: the same cells for half the
 * refinement's cost), but refraction's forms carry the linearised square roots' radii,
 * and their quarters' boxes would stay wide (ball320 TT level 3: 190,810 cell entries
 * instead of 137,886): refracting chains compute each quarter's forms. */
#define REFINED_FORMS 10

typedef struct refined_parent {
  unsigned char deg[REFINED_FORMS][BBC_POLY_MAX_AXES];
  double err[REFINED_FORMS];
  size_t at; /* its coefficients in bbc_bounder.refined_coef */
} refined_parent;

static bbc_poly *refined_form(chain_forms *f, int k) {
  bbc_poly *forms[REFINED_FORMS] = {&f->facing, &f->up2,     &f->vp2, &f->kappa2, &f->tnum2,
                                    &f->facing2, &f->up,     &f->vp,  &f->kappa,  &f->tnum};
  return forms[k];
}

static const bbc_poly *refined_form_of(const chain_forms *f, int k) {
  return refined_form((chain_forms *)f, k);
}

/* Keeps a two-reflection piece's position forms for its quarters; *origin receives the
 * first quarter's origin, or 0 (the quarters compute their own) for refraction (forms
 * with a beta) or when a form depends on an axis other than s and t. */
static bbc_result refined_store(bbc_bounder *b, const chain_forms *f, int s_axis, int t_axis,
                                uint64_t *origin) {
  *origin = 0;
  if (f->has_beta || f->has_beta2) return BBC_OK;
  size_t need = 0;
  for (int k = 0; k < REFINED_FORMS; k++) {
    const bbc_poly *p = refined_form_of(f, k);
    for (int j = 0; j < BBC_POLY_MAX_AXES; j++)
      if (p->deg[j] != 0 && j != s_axis && j != t_axis) return BBC_OK;
    need += bbc_poly_size(p);
  }
  if (b->refined_count == b->refined_capacity) {
    size_t capacity = b->refined_capacity ? 2 * b->refined_capacity : 64;
    refined_parent *r = realloc(b->refined, capacity * sizeof *r);
    if (!r) return BBC_ERR_OUT_OF_MEMORY;
    b->refined = r;
    b->refined_capacity = capacity;
  }
  if (need > b->refined_coef_capacity - b->refined_coef_used) {
    size_t capacity = b->refined_coef_capacity ? b->refined_coef_capacity : 1 << 16;
    while (capacity - b->refined_coef_used < need) capacity *= 2;
    double *c = realloc(b->refined_coef, capacity * sizeof *c);
    if (!c) return BBC_ERR_OUT_OF_MEMORY;
    b->refined_coef = c;
    b->refined_coef_capacity = capacity;
  }
  refined_parent *r = &b->refined[b->refined_count];
  r->at = b->refined_coef_used;
  for (int k = 0; k < REFINED_FORMS; k++) {
    const bbc_poly *p = refined_form_of(f, k);
    memcpy(r->deg[k], p->deg, sizeof r->deg[k]);
    r->err[k] = p->err;
    const size_t n = bbc_poly_size(p);
    memcpy(b->refined_coef + b->refined_coef_used, p->coef, n * sizeof *p->coef);
    b->refined_coef_used += n;
  }
  *origin = 8 * (uint64_t)(++b->refined_count);
  return BBC_OK;
}

/* The position forms of the quarter of this origin (refined_store), in the arena. */
static bbc_result refined_forms(bbc_bounder *b, uint64_t origin, int s_axis, int t_axis,
                                chain_forms *f) {
  const refined_parent *r = &b->refined[origin / 8 - 1];
  const int q = (int)(origin % 8);
  memset(f, 0, sizeof *f);
  f->length = 2;
  f->slope_enclosed = f->slope_enclosed2 = 1;
  size_t at = r->at;
  for (int k = 0; k < REFINED_FORMS; k++) {
    bbc_poly parent;
    memcpy(parent.deg, r->deg[k], sizeof parent.deg);
    parent.err = r->err[k];
    parent.coef = b->refined_coef + at;
    at += bbc_poly_size(&parent);
    bbc_poly half[2], quarter[2];
    bbc_result res = bbc_poly_split(&b->arena, &parent, s_axis, &half[0], &half[1]);
    if (res == BBC_OK) res = bbc_poly_split(&b->arena, &half[q & 1], t_axis, &quarter[0], &quarter[1]);
    if (res != BBC_OK) return res;
    *refined_form(f, k) = quarter[q >> 1];
  }
  return BBC_OK;
}

/* The forms of a piece with its position bound and sign conditions (Supp. Sec. 4.1
 * "positional check"). A condition proved false everywhere discards the piece; one that
 * may fail somewhere makes it partial (subdivided while the level allows). The forms
 * are built in two steps, so that a piece whose light misses T2 costs only the first. */
static bbc_result position_check(bbc_arena *arena, bbc_space *space, const bbc_tuple_geometry *g,
                                 const double box[4], int s_axis, int t_axis, chain_sqrt_mode mode,
                                 const piece_polys *polys, int carried, chain_forms *f,
                                 bbc_piece *piece, verdict *out, int *contained) {
  *out = VERDICT_DISCARD;
  if (contained) *contained = 0;
  /* The box must meet T1: u + v <= 1 somewhere. A box straddling T1's hypotenuse is
   * not subdivided for that alone (every level would have such boxes along it); its
   * bounds simply cover the part outside T1 too, which only loosens them (the
   * supplement's pbad_u1 with its tolerance U_TOL = 1 never fires either). */
  if (box[0] + box[2] > 1.0) return BBC_OK;
  /* A spot lights nothing of the piece where its falloff is 0 everywhere. */
  if (bbc__light_falloff_over_box(g->light, &g->light_model, g->p, box).hi <= 0) return BBC_OK;
  /* Two bounces: a part of T1 whose light provably misses T2 holds no path. */
  if (bbc__chain_second_unreachable(g, box)) return BBC_OK;
  /* Carried forms come whole (in polys, or already in f); computed ones in two steps. */
  bbc_result r = BBC_OK;
  if (polys)
    polys_view(polys, f, NULL);
  else if (!carried)
    r = bbc__chain_forms_prefix(arena, space, g, box, s_axis, t_axis, mode, f);
  if (r != BBC_OK) return r;
  int partial = 0, wide = 0, inside = 0, inside2 = 1;

  bbc_interval facing = bbc_poly_bound(&f->facing);
  if (facing.hi < 0) return BBC_OK;
  if (facing.lo < 0) partial = 1;
  if (g->light_model.kind == BBC_LIGHT_AREA) {
    /* The emitter sends light only to its front. */
    bbc_interval emit = bbc_poly_bound(&f->emit);
    if (emit.hi <= 0) return BBC_OK;
    if (emit.lo <= 0) partial = 1;
  }
  if (f->has_beta) {
    bbc_interval beta = bbc_poly_bound(&f->beta);
    if (beta.hi < 0) return BBC_OK;
    if (beta.lo < 0) partial = 1;
  }
  if (f->length == 2) {
    /* The second vertex: ahead of x1 and inside T2, then (below) lit from the side its
     * normals face and, for refraction, not totally reflected. */
    if ((r = ray_lands(arena, &f->up2, &f->vp2, &f->kappa2, &f->tnum2, NULL, &partial, &wide,
                       &inside2, NULL)) != BBC_OK)
      return r;
    if (partial < 0) return BBC_OK;
  }
  if (!polys && !carried && (r = bbc__chain_forms_rest(arena, space, g, mode, f)) != BBC_OK)
    return r;
  if (f->length == 2) {
    bbc_interval facing2 = bbc_poly_bound(&f->facing2);
    if (facing2.hi < 0) return BBC_OK;
    if (facing2.lo < 0) partial = 1;
    if (f->has_beta2) {
      bbc_interval beta2 = bbc_poly_bound(&f->beta2);
      if (beta2.hi < 0) return BBC_OK;
      if (beta2.lo < 0) partial = 1;
    }
  }
  double box_k[8];
  bbc_poly kappa_up = f->kappa;
  if ((r = ray_lands(arena, &f->up, &f->vp, &f->kappa, &f->tnum, box_k, &partial, &wide,
                     &inside, &kappa_up)) != BBC_OK)
    return r;
  if (partial < 0) return BBC_OK;
  piece->uk_lo = box_k[0], piece->uk_hi = box_k[1], piece->vk_lo = box_k[2], piece->vk_hi = box_k[3];
  piece->sk_lo = box_k[4], piece->sk_hi = box_k[5], piece->dk_lo = box_k[6], piece->dk_hi = box_k[7];
  if ((r = side_cuts(arena, &f->up, &f->vp, &f->kappa, &kappa_up, s_axis, t_axis, piece->cut)) !=
      BBC_OK)
    return r;
  /* Every path of the piece lands inside T2 and the receiver: nothing to trim off. */
  if (contained) *contained = inside && inside2;
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

/* Degree control (Sec. 6.1, DESIGN 3.4): the Jacobian determinant is cubic in the
 * receiver forms, so for two bounces the forms and their derivatives are reduced to at
 * most REDUCED_DEGREE first (bbc__flatten), keeping every axis of the determinant at or
 * below 3 x 13 = 39 (the paper's limit is about 40). */
#define REDUCED_DEGREE 13

/* The constant factors of the irradiance bound, in outward-rounded interval arithmetic
 * from the exact vertices: |e11 x e12| du dv / |ek1 x ek2| and cos(theta0) = h / |d0|,
 * with h the distance from the light to T1's plane and |d0| bounded through d0 . d0. */
static bbc_interval irradiance_scale(const bbc_tuple_geometry *g, const chain_forms *f,
                                     double area) {
  bbc_ivec3 p0 = bbc_ivec3_point(g->p[0]);
  bbc_ivec3 c1 = bbc_ivec3_cross(bbc_ivec3_sub(bbc_ivec3_point(g->p[1]), p0),
                                 bbc_ivec3_sub(bbc_ivec3_point(g->p[2]), p0));
  bbc_ivec3 r0 = bbc_ivec3_point(g->r[0]);
  bbc_ivec3 ck = bbc_ivec3_cross(bbc_ivec3_sub(bbc_ivec3_point(g->r[1]), r0),
                                 bbc_ivec3_sub(bbc_ivec3_point(g->r[2]), r0));
  bbc_interval a1 = bbc_interval_sqrt(bbc_ivec3_dot(c1, c1));
  bbc_interval ak = bbc_interval_sqrt(bbc_ivec3_dot(ck, ck));
  /* A sun: d0 is its constant direction D and dist2 the constant 1 (chain.c), so
   * cos(theta0) = |n1g . D| / |D| and the factor 1 / |d0|^2 is 1 (docs/lights.md). */
  const int sun = g->light_model.kind == BBC_LIGHT_DIRECTIONAL;
  const bbc_ivec3 dir = bbc_ivec3_point(g->light_model.direction);
  bbc_interval h = bbc_interval_div(
      bbc_ivec3_dot(c1, sun ? dir : bbc_ivec3_sub(p0, bbc_ivec3_point(g->light))), a1);
  if (h.hi < 0) h = bbc_interval_neg(h);
  else if (h.lo < 0) h = bbc_interval_make(0, fmax(-h.lo, h.hi));
  bbc_interval dist2 = sun ? bbc_ivec3_dot(dir, dir) : bbc_poly_bound(&f->dist2);
  if (dist2.lo < 0) dist2.lo = 0;
  bbc_interval cos0 = bbc_interval_div(h, bbc_interval_sqrt(dist2));
  if (cos0.hi > 1) cos0.hi = 1;
  if (g->light_model.kind == BBC_LIGHT_AREA) {
    /* x0 ranges over the emitter's light box: h and the emitter's A_e cos(theta_e) =
     * (d0 . n_e) / (2 |d0|) by intervals (docs/lights.md). */
    double lb[4];
    bbc__chain_light_box(g, lb);
    const bbc_vec3 *q = g->light_model.emitter;
    bbc_ivec3 q0 = bbc_ivec3_point(q[0]);
    bbc_ivec3 e1 = bbc_ivec3_sub(bbc_ivec3_point(q[1]), q0);
    bbc_ivec3 fq = bbc_ivec3_sub(bbc_ivec3_point(q[2]), bbc_ivec3_point(q[1]));
    bbc_interval ia = bbc_interval_make(lb[0], lb[1]), ib = bbc_interval_make(lb[2], lb[3]);
    bbc_ivec3 x0 = bbc_ivec3_add(q0, bbc_ivec3_add(bbc_ivec3_scale(ia, e1),
                                                   bbc_ivec3_scale(bbc_interval_mul(ia, ib), fq)));
    h = bbc_interval_div(bbc_ivec3_dot(c1, bbc_ivec3_sub(p0, x0)), a1);
    if (h.hi < 0) h = bbc_interval_neg(h);
    else if (h.lo < 0) h = bbc_interval_make(0, fmax(-h.lo, h.hi));
    cos0 = bbc_interval_div(h, bbc_interval_sqrt(dist2));
    if (cos0.hi > 1) cos0.hi = 1;
    bbc_interval emit = bbc_poly_bound(&f->emit);
    if (emit.lo < 0) emit.lo = 0;
    bbc_interval w = bbc_interval_scale(bbc_interval_div(emit, bbc_interval_sqrt(dist2)), 0.5);
    /* The exact weight (bbc__area_weight) rounds a dot product, a length and a quotient:
     * a few ulps, covered by 8. */
    w = bbc_interval_make(fmax(w.lo * (1 - 8 * DBL_EPSILON), 0.0), w.hi * (1 + 8 * DBL_EPSILON));
    if (!(w.hi >= 0)) w = bbc_interval_make(0, INFINITY);
    cos0 = bbc_interval_mul(cos0, w);
    if (!(cos0.lo >= 0)) cos0.lo = 0;
  }
  bbc_interval k = bbc_interval_div(bbc_interval_scale(a1, area), ak);
  bbc_interval scale = bbc_interval_mul(k, cos0);
  if (!(scale.lo >= 0)) scale.lo = 0;
  return scale;
}

/* The irradiance bound by implicit differentiation of the last refraction (Eq. 17-19):
 * |du1/duk| = du dv / (wa wb) |det_ab / det_st|, with the receiver's barycentrics free
 * over the piece's position box (widths wa, wb), intersected over b = x and b = y (Sec.
 * 4.4; the second is skipped when the first is within alpha). [lo, hi] = [0, inf] when
 * nothing is learnt. */
static bbc_result implicit_bound(bbc_arena *arena, const bbc_space *space,
                                 const bbc_tuple_geometry *g, const chain_forms *f,
                                 const double uk_box[4], bbc_interval scale, double alpha,
                                 double *e_lo, double *e_hi) {
  *e_lo = 0;
  *e_hi = INFINITY;
  const double wa = uk_box[1] - uk_box[0], wb = uk_box[3] - uk_box[2];
  if (!(wa > 0) || !(wb > 0)) return BBC_OK;
  static const bbc_vec3 bs[2] = {{1, 0, 0}, {0, 1, 0}};
  double lo = 0, hi = INFINITY;
  /* What does not depend on b is computed once for both. */
  size_t outer = bbc_arena_mark(arena);
  chain_implicit *prep = NULL;
  bbc_result pr = bbc__chain_double_implicit_prepare(arena, space, g, f, uk_box, &prep);
  if (pr != BBC_OK) {
    bbc_arena_reset(arena, outer);
    return pr;
  }
  for (int i = 0; i < 2; i++) {
    size_t mark = bbc_arena_mark(arena);
    bbc_poly det_ab, det_st, den;
    bbc_range ratio;
    bbc_result r = bbc__chain_double_implicit(arena, prep, g, f, bs[i], &det_ab, &det_st);
    if (r == BBC_OK) r = bbc_poly_mul(arena, &den, &f->dist2, &det_st);
    if (r == BBC_OK) r = bbc_rational_bound(arena, &det_ab, &den, &ratio);
    bbc_arena_reset(arena, mark);
    if (r != BBC_OK) {
      bbc_arena_reset(arena, outer);
      return r;
    }
    double l, h;
    magnitude(&ratio, &l, &h);
    lo = fmax(lo, l);
    hi = fmin(hi, h);
    if (hi <= alpha * lo) break; /* tight enough: the second b could only tighten it */
  }
  bbc_arena_reset(arena, outer);
  bbc_interval k = bbc_interval_div(scale, bbc_interval_mul(bbc_interval_point(wa),
                                                              bbc_interval_point(wb)));
  if (!(k.lo >= 0)) k.lo = 0;
  *e_lo = lo > 0 && isfinite(k.lo) ? lo * k.lo * (1 - 4 * DBL_EPSILON) : 0;
  *e_hi = isfinite(hi) && isfinite(k.hi) ? hi * k.hi * (1 + 4 * DBL_EPSILON) : INFINITY;
  return BBC_OK;
}

static bbc_result explicit_bound(bbc_arena *arena, const bbc_space *space, const chain_forms *f,
                                 const bbc_poly *carried, int s_axis, int t_axis,
                                 bbc_jacobian_form form, bbc_interval scale, double *e_lo,
                                 double *e_hi, int *fold);

/* The irradiance bound of a piece per unit intensity (Eq. 14-16, Supp. 2.1):
 * E = cos(theta0) / |d0|^2 * |e11 x e12| * |du1/duk| / |ek1 x ek2|, with
 * |du1/duk| = |q|^3 / |D_uv| and D_uv = D_st / (du dv) (DESIGN 3.5). cos(theta0) = h/|d0|
 * is factored out and bounded by intervals (Supp. 2.1); the rest is the rational
 * q^3 / (|d0|^2 D_st) (or q^4 / (|d0|^2 N) in the quotient-rule form). The same holds
 * for two bounces, with q, p, r the receiver forms after T2. Where the explicit
 * Jacobian's determinant changes sign at sample points of the piece (a fold of the
 * caustic seems to cross it; explicit_bound's *fold) the implicit form is not tried,
 * since its denominator F_s G_t - F_t G_s vanishes on the same fold (du1/duk = -(dFG/du1)^-1
 * dFG/duk): on ball80 at level 4 it bounded 4 of 786 such pieces. */
static bbc_result irradiance_bound(bbc_arena *arena, const bbc_space *space,
                                   const bbc_tuple_geometry *g, const chain_forms *f,
                                   const bbc_poly *carried, double carried_area,
                                   const double box[4], const double uk_box[4], int s_axis,
                                   int t_axis, bbc_jacobian_form form, double alpha, double *e_lo,
                                   double *e_hi) {
  *e_lo = 0;
  *e_hi = INFINITY;
  if (!f->slope_enclosed) return BBC_OK;
  bbc_interval scale =
      irradiance_scale(g, f, carried ? carried_area : (box[1] - box[0]) * (box[3] - box[2]));
  bbc_result res;
  if (f->length == 2 && g->refract2 && f->has_derivatives) {
    /* Explicit, then where it is loose (near total internal reflection at T2, Fig. 7,
     * where beta2 nears 0 and the slope of its sqrt is unbounded) intersected with the
     * implicit bound. */
    if (f->slope_enclosed2) {
      int fold = 0;
      if ((res = explicit_bound(arena, space, f, NULL, s_axis, t_axis, form, scale, e_lo, e_hi,
                                &fold)) != BBC_OK)
        return res;
      if (*e_hi <= alpha * *e_lo || fold) return BBC_OK;
    }
    double ilo, ihi;
    if ((res = implicit_bound(arena, space, g, f, uk_box, scale, alpha, &ilo, &ihi)) != BBC_OK) return res;
    *e_lo = fmax(*e_lo, ilo);
    *e_hi = fmin(*e_hi, ihi);
    return BBC_OK;
  }
  if (f->length == 2 && !f->slope_enclosed2) return BBC_OK;
  return explicit_bound(arena, space, f, carried, s_axis, t_axis, form, scale, e_lo, e_hi, NULL);
}

/* One reflection from an area light: the degree on the emitter's axes (a, b) to which
 * the Jacobian's products are reduced (the 2 x 2 minors, the determinant, q^2 and q^3,
 * and |d0|^2), what each fit misses entering its radius (bbc__flatten_light). q, p, r
 * and their derivatives have degree 1 on these axes, and without the cap the
 * denominator reaches degree 5 on each (6084 coefficients on four axes where 1521
 * remain): on a wavy plane of 100 triangles under a 0.5 emitter the precompute took 95
 * CPU-s instead of 55, with the same check-bounds counts and a median log10(E_hi/E) of
 * 0.515 against 0.525 (docs/lights.md). Degree 0 made 46 % of the paths unbounded.
 * Refraction is left as it is: the reduction also folds its remainder axes into the
 * radius, and the generated pool's T bounds, 2x cheaper, left 1.7 % of the paths
 * unbounded (none are) at any cap from 1 to 3; and two bounces too, whose forms are
 * already reduced to CHAIN_LIGHT_DEGREE: capped, two flat mirrors under a 0.25 emitter
 * (RR) had 2,731 of 15,273 paths in unbounded cells instead of none. */
#define JACOBIAN_LIGHT_DEGREE 1

/* p reduced in place to JACOBIAN_LIGHT_DEGREE on light[0..1]; nothing when light is NULL. */
static bbc_result cap_light(bbc_arena *arena, const bbc_space *space, bbc_poly *p,
                            const int *light) {
  if (!light) return BBC_OK;
  return bbc__flatten_light(arena, space, p, p, BBC_POLY_MAX_DEGREE, light, JACOBIAN_LIGHT_DEGREE);
}

/* The explicit bound's rational (Eq. 16): *num = q^3 and *den = |d0|^2 D_st (or q^4 and
 * |d0|^2 N in the quotient-rule form), D_st over the piece's s and t. With fold
 * non-NULL, also whether the determinant seems to change sign in the piece. */
static bbc_result jacobian_rational(bbc_arena *arena, const bbc_space *space, const chain_forms *f,
                                    int s_axis, int t_axis, bbc_jacobian_form form, bbc_poly *num,
                                    bbc_poly *den, int *fold) {
  const bbc_poly *q = &f->kappa, *p = &f->up, *r = &f->vp;
  bbc_poly qs, qt, ps, pt, rs, rt, qq, pp, rr;
  bbc_result res;
#define TRY(expr)                             \
  do {                                        \
    if ((res = (expr)) != BBC_OK) return res; \
  } while (0)
  bbc_poly jac, q2, a, b, c;
  if (f->has_derivatives) {
    /* Two bounces: the derivatives came along in forward mode (chain_double.c). */
    const bbc_poly *in[9] = {q, p, r, &f->kappa_s, &f->kappa_t, &f->up_s, &f->up_t, &f->vp_s,
                             &f->vp_t};
    bbc_poly *flat[9] = {&qq, &pp, &rr, &qs, &qt, &ps, &pt, &rs, &rt};
    /* An area light's axes (a, b) at CHAIN_LIGHT_DEGREE at most (chain_internal.h). */
    const int *light_axes = f->light_axis_count ? f->light_axes : NULL;
    for (int i = 0; i < 9; i++)
      TRY(bbc__flatten_light(arena, space, flat[i], in[i], REDUCED_DEGREE, light_axes,
                             CHAIN_LIGHT_DEGREE));
    q = &qq, p = &pp, r = &rr;
    /* (p, r) -> (p - u0 q, r - v0 q) with constants u0, v0 (the hit at the piece's
     * centre): the same Jacobian exactly, as a determinant is unchanged by adding a
     * multiple of one column to another (and u_s = (p_s q - p q_s) / q^2 likewise), but
     * the shifted forms are small where p/q is near u0, so the error radii that multiply
     * them no longer swamp the cancelling terms. */
    double centre[BBC_POLY_MAX_AXES];
    for (int j = 0; j < BBC_POLY_MAX_AXES; j++) centre[j] = 0.5;
    double qc = bbc_poly_eval(q, centre);
    double shift[2] = {bbc_poly_eval(p, centre) / qc, bbc_poly_eval(r, centre) / qc};
    bbc_poly *cols[2][3] = {{&pp, &ps, &pt}, {&rr, &rs, &rt}};
    const bbc_poly *base[3] = {&qq, &qs, &qt};
    for (int k = 0; k < 2; k++) {
      if (!isfinite(shift[k])) continue;
      const double alpha[2] = {1.0, -shift[k]};
      for (int i = 0; i < 3; i++) {
        const bbc_poly *terms[2] = {cols[k][i], base[i]};
        TRY(bbc_poly_lincomb(arena, cols[k][i], 2, alpha, terms));
      }
    }
  } else {
    TRY(bbc_poly_derivative(arena, &qs, q, s_axis));
    TRY(bbc_poly_derivative(arena, &qt, q, t_axis));
    TRY(bbc_poly_derivative(arena, &ps, p, s_axis));
    TRY(bbc_poly_derivative(arena, &pt, p, t_axis));
    TRY(bbc_poly_derivative(arena, &rs, r, s_axis));
    TRY(bbc_poly_derivative(arena, &rt, r, t_axis));
    if (f->has_value_fold) {
      /* sqrt(beta)'s value remainder, a constant delta with |delta| <= value_radius beside
       * the forms (chain_internal.h): the exact q, p, r are q - delta q_n, ... and their
       * derivatives q_s - delta q_n,s, ... for the same delta. First the shift of the
       * two-bounce case below, (p, r) -> (p - u0 q, r - v0 q), which leaves the
       * determinant as it is and makes the terms that the radii multiply small; the
       * delta terms shift alike. Then every form is widened by value_radius times a bound
       * of the coefficients of its delta term (the largest end of bbc_poly_bound, which
       * includes their radius; elevation to the form's degrees keeps coefficients within
       * it), so that each exact polynomial lies within the radius of the stored one, and
       * the determinant below bounds every delta at once. The derivative terms are those
       * of n1, small where the normal turns slowly, where a radius on the forms before
       * differentiation would cost 2n times the radius. */
      bbc_poly terms[3] = {f->kappa_n, f->up_n, f->vp_n};
      bbc_poly *val[3] = {&qq, &pp, &rr}, *ds[3] = {&qs, &ps, &rs}, *dt[3] = {&qt, &pt, &rt};
      qq = *q, pp = *p, rr = *r; /* the same coefficients, radii of their own */
      double centre[BBC_POLY_MAX_AXES];
      for (int j = 0; j < BBC_POLY_MAX_AXES; j++) centre[j] = 0.5;
      const double qc = bbc_poly_eval(q, centre);
      const double shift[2] = {bbc_poly_eval(p, centre) / qc, bbc_poly_eval(r, centre) / qc};
      /* The q-column at the degrees of the p- and r-columns (the same, as up and vp have
       * the same degrees), elevated once for both: bbc_poly_lincomb would elevate it
       * alike (the same coefficients and radius). */
      bbc_poly base[4] = {qq, qs, qt, terms[0]};
      {
        bbc_poly *cp[4] = {&pp, &ps, &pt, &terms[1]}, *cr[4] = {&rr, &rs, &rt, &terms[2]};
        for (int i = 0; i < 4; i++) {
          unsigned char deg[BBC_POLY_MAX_AXES];
          int fits = memcmp(cp[i]->deg, cr[i]->deg, sizeof deg) == 0, grows = 0;
          for (int j = 0; j < BBC_POLY_MAX_AXES; j++) {
            deg[j] = cp[i]->deg[j];
            fits &= base[i].deg[j] <= deg[j];
            grows |= base[i].deg[j] < deg[j];
          }
          if (fits && grows) TRY(bbc_poly_elevate(arena, &base[i], &base[i], deg));
        }
      }
      for (int k = 0; k < 2; k++) {
        if (!isfinite(shift[k])) continue;
        const double alpha[2] = {1.0, -shift[k]};
        bbc_poly *col[4] = {val[k + 1], ds[k + 1], dt[k + 1], &terms[k + 1]};
        for (int i = 0; i < 4; i++) {
          const bbc_poly *in[2] = {col[i], &base[i]};
          TRY(bbc_poly_lincomb(arena, col[i], 2, alpha, in));
        }
      }
      for (int i = 0; i < 3; i++) {
        bbc_poly ns, nt;
        TRY(bbc_poly_derivative(arena, &ns, &terms[i], s_axis));
        TRY(bbc_poly_derivative(arena, &nt, &terms[i], t_axis));
        const bbc_poly *of[3] = {&terms[i], &ns, &nt};
        bbc_poly *to[3] = {val[i], ds[i], dt[i]};
        for (int k = 0; k < 3; k++) {
          bbc_interval b = bbc_poly_bound(of[k]);
          double m = fmax(fabs(b.lo), fabs(b.hi));
          if (!(m < INFINITY)) m = INFINITY; /* NaN */
          bbc_poly_widen(to[k], bbc__mul_up(f->value_radius, m));
        }
      }
      q = &qq, p = &pp, r = &rr;
    }
  }
  /* One reflection from an area light: products capped on the emitter's axes. */
  const int *light =
      f->length == 1 && f->light_axis_count && !f->has_beta ? f->light_axes : NULL;
  TRY(bbc_poly_mul(arena, &q2, q, q));
  TRY(cap_light(arena, space, &q2, light));
  if (form == BBC_JACOBIAN_DETERMINANT) {
    /* D = q (p_s r_t - p_t r_s) - p (q_s r_t - q_t r_s) + r (q_s p_t - q_t p_s). */
    bbc_poly m1, m2, t1, t2, t3;
    TRY(bbc_poly_mul(arena, &m1, &ps, &rt));
    TRY(bbc_poly_mul(arena, &m2, &pt, &rs));
    TRY(bbc_poly_sub(arena, &a, &m1, &m2));
    TRY(cap_light(arena, space, &a, light));
    TRY(bbc_poly_mul(arena, &t1, q, &a));
    TRY(bbc_poly_mul(arena, &m1, &qs, &rt));
    TRY(bbc_poly_mul(arena, &m2, &qt, &rs));
    TRY(bbc_poly_sub(arena, &b, &m1, &m2));
    TRY(cap_light(arena, space, &b, light));
    TRY(bbc_poly_mul(arena, &t2, p, &b));
    TRY(bbc_poly_mul(arena, &m1, &qs, &pt));
    TRY(bbc_poly_mul(arena, &m2, &qt, &ps));
    TRY(bbc_poly_sub(arena, &c, &m1, &m2));
    TRY(cap_light(arena, space, &c, light));
    TRY(bbc_poly_mul(arena, &t3, r, &c));
    TRY(bbc_poly_sub(arena, &jac, &t1, &t2));
    TRY(bbc_poly_add(arena, &jac, &jac, &t3));
    TRY(bbc_poly_mul(arena, num, &q2, q));
  } else {
    /* N = (p_s q - p q_s)(r_t q - r q_t) - (p_t q - p q_t)(r_s q - r q_s). */
    bbc_poly m1, m2, us, ut, vs, vt, x, y;
    TRY(bbc_poly_mul(arena, &m1, &ps, q));
    TRY(bbc_poly_mul(arena, &m2, p, &qs));
    TRY(bbc_poly_sub(arena, &us, &m1, &m2));
    TRY(cap_light(arena, space, &us, light));
    TRY(bbc_poly_mul(arena, &m1, &pt, q));
    TRY(bbc_poly_mul(arena, &m2, p, &qt));
    TRY(bbc_poly_sub(arena, &ut, &m1, &m2));
    TRY(cap_light(arena, space, &ut, light));
    TRY(bbc_poly_mul(arena, &m1, &rs, q));
    TRY(bbc_poly_mul(arena, &m2, r, &qs));
    TRY(bbc_poly_sub(arena, &vs, &m1, &m2));
    TRY(cap_light(arena, space, &vs, light));
    TRY(bbc_poly_mul(arena, &m1, &rt, q));
    TRY(bbc_poly_mul(arena, &m2, r, &qt));
    TRY(bbc_poly_sub(arena, &vt, &m1, &m2));
    TRY(cap_light(arena, space, &vt, light));
    TRY(bbc_poly_mul(arena, &x, &us, &vt));
    TRY(bbc_poly_mul(arena, &y, &ut, &vs));
    TRY(bbc_poly_sub(arena, &jac, &x, &y));
    TRY(bbc_poly_mul(arena, num, &q2, &q2));
  }
  TRY(cap_light(arena, space, &jac, light));
  TRY(cap_light(arena, space, num, light));
  if (fold) {
    /* Whether the determinant seems to vanish inside the piece: its signs at a 3 x 3
     * grid of (s, t) (every other axis at its middle), in plain floating point, from the
     * nine factors (of degree 13 at most, where the determinant's is 39). It only guides
     * the caller, which asks only where an implicit bound may follow; no bound depends
     * on it. */
    double x[BBC_POLY_MAX_AXES];
    for (int j = 0; j < BBC_POLY_MAX_AXES; j++) x[j] = 0.5;
    int pos = 0, neg = 0;
    for (int k = 0; k < 9; k++) {
      x[s_axis] = 0.5 * (k % 3), x[t_axis] = 0.5 * (k / 3);
      const double q0 = bbc_poly_eval(q, x), p0 = bbc_poly_eval(p, x), r0 = bbc_poly_eval(r, x);
      const double q1 = bbc_poly_eval(&qs, x), q2 = bbc_poly_eval(&qt, x);
      const double p1 = bbc_poly_eval(&ps, x), p2 = bbc_poly_eval(&pt, x);
      const double r1 = bbc_poly_eval(&rs, x), r2 = bbc_poly_eval(&rt, x);
      double d = q0 * (p1 * r2 - p2 * r1) - p0 * (q1 * r2 - q2 * r1) + r0 * (q1 * p2 - q2 * p1);
      if (form != BBC_JACOBIAN_DETERMINANT) d *= q0; /* N = q D */
      pos |= d > 0, neg |= d < 0;
    }
    *fold = pos && neg;
  }
  bbc_poly dist2 = f->dist2;
  TRY(cap_light(arena, space, &dist2, light));
  TRY(bbc_poly_mul(arena, den, &dist2, &jac));
  return BBC_OK;
#undef TRY
}

/* The explicit bound (Eq. 16): the rational part by Bernstein bounds, times scale; the
 * rational is carried[0] / carried[1] when carried is not NULL, else jacobian_rational's
 * (with its fold). */
static bbc_result explicit_bound(bbc_arena *arena, const bbc_space *space, const chain_forms *f,
                                 const bbc_poly *carried, int s_axis, int t_axis,
                                 bbc_jacobian_form form, bbc_interval scale, double *e_lo,
                                 double *e_hi, int *fold) {
  bbc_poly rational[2];
  if (!carried) {
    bbc_result res =
        jacobian_rational(arena, space, f, s_axis, t_axis, form, &rational[0], &rational[1], fold);
    if (res != BBC_OK) return res;
    carried = rational;
  }
  bbc_range ratio;
  bbc_result res = bbc_rational_bound(arena, &carried[0], &carried[1], &ratio);
  if (res != BBC_OK) return res;
  double lo, hi;
  magnitude(&ratio, &lo, &hi);
  /* Rounded products of positive numbers, pushed a few ulps outward. */
  *e_lo = lo > 0 && isfinite(scale.lo) ? lo * scale.lo * (1 - 4 * DBL_EPSILON) : 0;
  *e_hi = isfinite(hi) ? hi * scale.hi * (1 + 4 * DBL_EPSILON) : INFINITY;
  if (!(*e_hi >= 0)) *e_hi = INFINITY; /* NaN from an unbounded scale */
  return BBC_OK;
}

/* Queues a piece with its origin (see bbc_bounder; ignored without split_forms). */
static bbc_result push(bbc_bounder *b, size_t *count, const bbc_piece *piece, uint64_t origin) {
  if (*count == b->queue_capacity) {
    size_t capacity = b->queue_capacity * 2;
    bbc_piece *queue = realloc(b->queue, capacity * sizeof *queue);
    if (!queue) return BBC_ERR_OUT_OF_MEMORY;
    b->queue = queue;
    uint64_t *o = realloc(b->origin, capacity * sizeof *o);
    if (!o) return BBC_ERR_OUT_OF_MEMORY;
    b->origin = o;
    b->queue_capacity = capacity;
  }
  b->origin[*count] = origin;
  b->queue[(*count)++] = *piece;
  return BBC_OK;
}

/* Adds a parent's forms; *origin receives the first of its quadrants' origins. */
static bbc_result push_parent(bbc_bounder *b, const piece_polys *polys, uint64_t *origin) {
  if (b->forms_count == b->forms_capacity) {
    size_t capacity = b->forms_capacity * 2;
    piece_polys *p = realloc(b->forms, capacity * sizeof *p);
    if (!p) return BBC_ERR_OUT_OF_MEMORY;
    b->forms = p;
    b->forms_capacity = capacity;
  }
  *origin = 8 * (b->forms_base + b->forms_count);
  b->forms[b->forms_count++] = *polys;
  return BBC_OK;
}

/* The forms of the piece of this origin. Parents before its own have no more children
 * waiting (the FIFO order), so they are given back once they are half the array. */
static bbc_result origin_polys(bbc_bounder *b, uint64_t origin, int s_axis, int t_axis,
                               piece_polys *out) {
  const size_t k = (size_t)(origin / 8 - b->forms_base);
  const int q = (int)(origin % 8);
  bbc_result r = BBC_OK;
  if (q == 4) {
    *out = b->forms[k];
  } else {
    if (b->quadrants_of != origin / 8) {
      r = polys_quadrants(&b->arena, &b->forms[k], s_axis, t_axis, b->quadrants);
      b->quadrants_of = r == BBC_OK ? origin / 8 : UINT64_MAX;
    }
    if (r == BBC_OK) *out = b->quadrants[q];
  }
  b->forms_head = k;
  if (b->forms_head >= 256 && 2 * b->forms_head >= b->forms_count) {
    memmove(b->forms, b->forms + b->forms_head,
            (b->forms_count - b->forms_head) * sizeof *b->forms);
    b->forms_count -= b->forms_head;
    b->forms_base += b->forms_head;
    b->forms_head = 0;
  }
  return r;
}

/* The forms of a piece in a fresh arena and variable space, and its position check. */
typedef struct piece_forms {
  double box[4];
  bbc_space space;
  int s_axis, t_axis;
  chain_forms forms;
  bbc_tuple_geometry g; /* the tuple's, with the piece's light box */
} piece_forms;

/* polys: the piece's carried forms, or NULL to compute them; refined: the origin of a
 * quarter whose two-bounce forms are its parent's (refined_store), else below 8. */
static bbc_result examine_position(bbc_bounder *b, const bbc_tuple_geometry *g,
                                   chain_sqrt_mode mode, bbc_piece *piece,
                                   const piece_polys *polys, uint64_t refined, piece_forms *pf,
                                   verdict *v, int *contained) {
  pf->box[0] = piece->u_lo, pf->box[1] = piece->u_hi;
  pf->box[2] = piece->v_lo, pf->box[3] = piece->v_hi;
  pf->g = *g;
  bbc_arena_reset(&b->arena, 0);
  memset(&pf->space, 0, sizeof pf->space);
  bbc_space_add_axis(&pf->space, BBC_AXIS_GEOMETRIC, &pf->s_axis);
  bbc_space_add_axis(&pf->space, BBC_AXIS_GEOMETRIC, &pf->t_axis);
  if (g->light_model.kind == BBC_LIGHT_AREA) {
    /* The emitter's (a, b) over the piece's light box: the next two geometric axes,
     * claimed here so that the irradiance forms use the same ones. */
    int axes[2];
    bbc_result r = bbc__chain_area_axes(&pf->space, pf->s_axis, pf->t_axis, axes);
    if (r != BBC_OK) return r;
    pf->g.light_box[0] = piece->a_lo, pf->g.light_box[1] = piece->a_hi;
    pf->g.light_box[2] = piece->b_lo, pf->g.light_box[3] = piece->b_hi;
  }
  if (refined >= 8) {
    bbc_result r = refined_forms(b, refined, pf->s_axis, pf->t_axis, &pf->forms);
    if (r != BBC_OK) return r;
  }
  return position_check(&b->arena, &pf->space, &pf->g, pf->box, pf->s_axis, pf->t_axis, mode,
                        polys, refined >= 8, &pf->forms, piece, v, contained);
}

/* The whole light box on a fresh piece. */
static void whole_light(bbc_piece *p) {
  p->a_lo = p->b_lo = 0;
  p->a_hi = p->b_hi = 1;
  p->light_level = 0;
}

/* prm->need for the piece as it stands (BBC_NEED_SPLIT without one), asked once while its
 * bounds do not change: *memo holds the answer, or -1 before it is asked. */
static bbc_piece_need ask_need(const bbc_bound_params *prm, const bbc_piece *piece, int *memo) {
  if (*memo < 0) *memo = prm->need ? (int)prm->need(prm->need_user, piece) : (int)BBC_NEED_SPLIT;
  return (bbc_piece_need)*memo;
}

/* The deepest level of an area light's box: a few halvings (BBC_LIGHT_MAX_LEVEL) make
 * the footprint of one emitter part small against the emitter's whole, and every
 * further one quadruples the pieces of all four variables. */
#define LIGHT_MAX_LEVEL 3
/* How many levels below max_level a two-bounce piece whose irradiance bound is
 * unbounded may still be split (bbc_bound_tuple). */
#define UNBOUNDED_LEVELS 1

static int light_max_level(int max_level) {
  return max_level < LIGHT_MAX_LEVEL ? max_level : LIGHT_MAX_LEVEL;
}

/* Area lights: a split pays when it shrinks the piece's footprint or its bound; one that
 * did neither (the piece's position bound keeps more than SPENT_AREA of its parent's
 * area and its irradiance bound more than SPENT_BOUND of the parent's upper end) marks
 * its box spent until a split pays again, and a piece both of whose boxes are spent (or
 * cannot split) is kept as it is (docs/lights.md, "Subdivision"). */
#define SPENT_AREA 0.5
#define SPENT_BOUND 0.5
enum {
  SPLIT_LAST_U1 = 1,      /* the piece is a quarter of its parent's u1 box */
  SPLIT_LAST_LIGHT = 2,   /* ... of its parent's light box */
  SPLIT_U1_SPENT = 4,     /* a u1 split did not pay */
  SPLIT_LIGHT_SPENT = 8,  /* a light split did not pay */
  SPLIT_POSITION_ONLY = 16 /* refined for its position bound alone (below) */
};

/* Two bounces from a point, spot or sun: a piece the rules above keep may still have a
 * position bound many cells wide (alpha stops the subdivision where the irradiance
 * bound is tight enough, whatever its footprint). It is then split further for its
 * position bound alone, down to POSITION_LEVELS (bbc_bound_params.position_levels)
 * below the level limit while the area of its position bound is at least
 * POSITION_SIGMAS times sigma: its quarters inherit its irradiance bound (valid on any
 * part of its domain) and get position checks only, about a tenth of an irradiance
 * bound's cost, so the cells listing the tuple shrink toward those its caustic reaches.
 * Below 4 sigma a split buys few cells for its checks (docs/double-scattering.md,
 * "Position refinement"). */
#define POSITION_LEVELS 4
#define POSITION_SIGMAS 4.0

/* Area lights: whether a piece to be split splits its light box rather than its u1 box:
 * the one whose world-space extent is larger (the u1 box's sides times T1's edges, the
 * light box's times the emitter's), while its level allows. */
static int split_light(const bbc_tuple_geometry *g, const bbc_piece *p, int max_level) {
  if (g->light_model.kind != BBC_LIGHT_AREA) return 0;
  if (p->light_level >= light_max_level(max_level)) return 0;
  if (p->level >= max_level) return 1;
  const bbc_vec3 *q = g->light_model.emitter;
  double el = fmax(v3_length(v3_sub(q[1], q[0])), fmax(v3_length(v3_sub(q[2], q[1])),
                                                       v3_length(v3_sub(q[0], q[2]))));
  double tl = fmax(v3_length(v3_sub(g->p[1], g->p[0])), v3_length(v3_sub(g->p[2], g->p[0])));
  double light = el * fmax(p->a_hi - p->a_lo, p->b_hi - p->b_lo);
  double u1 = tl * fmax(p->u_hi - p->u_lo, p->v_hi - p->v_lo);
  return light > u1;
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
  double t0 = clock_seconds();
  bbc_piece stack[4 * DOMAIN_INIT_LEVELS + 1];
  /* Where the forms can be carried (carries_forms), a piece's are a quadrant of its
   * parent's, as in the subdivision: only T1's whole box computes them. */
  piece_polys stack_polys[4 * DOMAIN_INIT_LEVELS + 1];
  unsigned char carried[4 * DOMAIN_INIT_LEVELS + 1];
  const int carry = carries_forms(g);
  int top = 0;
  memset(&stack[0], 0, sizeof stack[0]);
  stack[0].u_hi = stack[0].v_hi = 1;
  whole_light(&stack[0]);
  carried[0] = 0;
  top = 1;
  bbc_result result = BBC_OK;
  while (top > 0 && result == BBC_OK) {
    --top;
    bbc_piece piece = stack[top];
    piece_polys own;
    const int has_own = carried[top];
    if (has_own) own = stack_polys[top];
    piece_forms pf;
    verdict v = VERDICT_PARTIAL;
    int contained = 0;
    result = examine_position(b, g, mode, &piece, has_own ? &own : NULL, 0, &pf, &v, &contained);
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
      const int split =
          carry && (has_own || polys_store(&pf.forms, NULL, 0, pf.s_axis, pf.t_axis, &own));
      piece_polys quadrants[4];
      if (split) result = polys_quadrants(&b->arena, &own, pf.s_axis, pf.t_axis, quadrants);
      for (int q = 0; q < 4 && result == BBC_OK; q++) {
        bbc_piece child;
        memset(&child, 0, sizeof child);
        whole_light(&child);
        child.level = piece.level + 1;
        child.u_lo = us[q & 1], child.u_hi = us[(q & 1) + 1];
        child.v_lo = vs[q >> 1], child.v_hi = vs[(q >> 1) + 1];
        if (child.u_lo + child.v_lo >= 1.0) continue; /* outside T1 but for a corner */
        carried[top] = (unsigned char)split;
        if (split) stack_polys[top] = quadrants[q];
        stack[top++] = child;
      }
      continue;
    }
    lo_u = fmin(lo_u, piece.u_lo);
    lo_v = fmin(lo_v, piece.v_lo);
    hi_u = fmax(hi_u, piece.u_hi);
    hi_v = fmax(hi_v, piece.v_hi);
  }
  local->position_seconds += clock_seconds() - t0;
  if (result != BBC_OK || hi_u <= lo_u) return result;
  root->status = BBC_PIECE_KEPT;
  whole_light(root);
  root->u_lo = lo_u, root->u_hi = hi_u, root->v_lo = lo_v, root->v_hi = hi_v;
  /* What the subdivision inherits at the root: nothing is known yet. */
  root->uk_lo = root->vk_lo = root->sk_lo = 0, root->uk_hi = root->vk_hi = root->sk_hi = 1;
  root->dk_lo = -1, root->dk_hi = 1;
  root->e_lo = 0, root->e_hi = INFINITY;
  /* Levels count halvings of T1's unit box: the box's longer side is 2^-level. */
  double span = fmax(hi_u - lo_u, hi_v - lo_v);
  while (root->level < DOMAIN_INIT_LEVELS && span <= ldexp(1.0, -(root->level + 1))) root->level++;
  return BBC_OK;
}

int bbc_piece_position_contains(const bbc_piece *p, double u, double v) {
  const double s = u + v, d = u - v;
  if (!(u >= p->uk_lo && u <= p->uk_hi && v >= p->vk_lo && v <= p->vk_hi && s >= p->sk_lo &&
        s <= p->sk_hi && d >= p->dk_lo && d <= p->dk_hi))
    return 0;
  for (int j = 0; j < 2; j++) {
    const double *c = p->cut[j];
    if (c[0] == 0 && c[1] == 0) continue;
    const double w = c[0] * u + c[1] * v;
    if (!(w >= c[2] && w <= c[3])) return 0;
  }
  return 1;
}

bbc_result bbc_bound_tuple(bbc_bounder *b, const bbc_tuple_geometry *g,
                           const bbc_bound_params *params, bbc_piece_fn fn, void *user,
                           bbc_bound_stats *stats) {
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  if (params) prm = *params;
  const int max_level = prm.max_level > 0 ? prm.max_level : prm.max_level < 0 ? 0 : 10;
  /* An area light's pieces split by the irradiance ratio alone: the footprint of an
   * emitter part does not shrink with u1, and the position rule sent every piece to the
   * deepest level (docs/lights.md). */
  const double sigma = g->light_model.kind == BBC_LIGHT_AREA ? INFINITY
                       : prm.sigma > 0                       ? prm.sigma
                                                             : 1e-4;
  const double alpha = prm.alpha > 0 ? prm.alpha : g->length == 2 ? 10.0 : 2.0;
  const int position_levels = prm.position_levels > 0   ? prm.position_levels
                              : prm.position_levels < 0 ? 0
                                                        : POSITION_LEVELS;
  const chain_sqrt_mode position_mode =
      prm.no_remainder ? CHAIN_SQRT_NO_REMAINDER : CHAIN_SQRT_PRIMAL;
  const chain_sqrt_mode irradiance_mode =
      prm.no_remainder ? CHAIN_SQRT_NO_REMAINDER : CHAIN_SQRT_DERIVATIVE_AWARE;
  bbc_bound_stats local;
  memset(&local, 0, sizeof local);
  local.tuples = 1;

  bbc_piece root;
  b->split_forms = 0;
  b->forms_head = b->forms_count = 0;
  b->forms_base = 0;
  b->quadrants_of = UINT64_MAX;
  b->refined_count = b->refined_coef_used = 0;
  uint64_t root_origin = 0;
  bbc_result result = domain_init(b, g, position_mode, fn, user, &root, &local);
  if (result != BBC_OK || root.status == BBC_PIECE_DISCARDED) goto done;
  piece_polys root_polys;
  if (carries_forms(g)) {
    /* The root's forms; every piece's follow from its parent's (polys_quadrants). */
    double t0 = clock_seconds();
    piece_forms pf;
    bbc_arena_reset(&b->arena, 0);
    memset(&pf.space, 0, sizeof pf.space);
    bbc_space_add_axis(&pf.space, BBC_AXIS_GEOMETRIC, &pf.s_axis);
    bbc_space_add_axis(&pf.space, BBC_AXIS_GEOMETRIC, &pf.t_axis);
    const double box[4] = {root.u_lo, root.u_hi, root.v_lo, root.v_hi};
    result = bbc__chain_forms(&b->arena, &pf.space, g, box, pf.s_axis, pf.t_axis, position_mode,
                              &pf.forms);
    local.position_seconds += clock_seconds() - t0;
    if (result != BBC_OK) goto done;
    /* With the Jacobian's rational, which the pieces' irradiance bounds then take from
     * it as they take their forms (unless only positions are asked for). */
    bbc_poly jac[2];
    const double area = (box[1] - box[0]) * (box[3] - box[2]);
    b->split_forms = 0;
    if (!prm.positions_only &&
        jacobian_rational(&b->arena, &pf.space, &pf.forms, pf.s_axis, pf.t_axis, prm.jacobian,
                          &jac[0], &jac[1], NULL) == BBC_OK)
      b->split_forms = polys_store(&pf.forms, jac, area, pf.s_axis, pf.t_axis, &root_polys);
    if (!b->split_forms)
      b->split_forms = polys_store(&pf.forms, NULL, 0, pf.s_axis, pf.t_axis, &root_polys);
    if (b->split_forms) {
      if ((result = push_parent(b, &root_polys, &root_origin)) != BBC_OK) goto done;
      root_origin += 4; /* the root's forms whole */
    }
  }

  /* Breadth-first: a FIFO over the queue array, compacted when it drains or is half
   * examined. */
  size_t head = 0, count = 0;
  result = push(b, &count, &root, root_origin);
  while (result == BBC_OK && head < count) {
    piece_polys own; /* the piece's forms, with split_forms */
    const uint64_t origin = b->origin[head];
    bbc_piece piece = b->queue[head++];
    if (head == count) {
      head = count = 0;
    } else if (head >= 1024 && 2 * head >= count) {
      /* The examined half of the queue is given back (the order is kept), so the queue
       * holds what waits, about two levels, not every piece of the tuple. */
      memmove(b->queue, b->queue + head, (count - head) * sizeof *b->queue);
      memmove(b->origin, b->origin + head, (count - head) * sizeof *b->origin);
      count -= head;
      head = 0;
    }
    const bbc_piece inherited = piece;
    /* Pieces kept since the parent was judged may already cover every cell of the
     * parent's position bound with at least its E_hi: the piece then changes nothing
     * recorded and is kept on its inherited bounds, without a position check. */
    if (prm.need && piece.level > root.level && prm.need(prm.need_user, &piece) == BBC_NEED_NONE) {
      piece.status = BBC_PIECE_KEPT;
      local.kept_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    double t0 = clock_seconds();
    piece_forms pf;
    verdict v = VERDICT_PARTIAL;
    /* The forms from the parent's (the axes are those examine_position claims). */
    if (b->split_forms) {
      bbc_arena_reset(&b->arena, 0);
      result = origin_polys(b, origin, BBC_POLY_MAX_AXES - 1, BBC_POLY_MAX_AXES - 2, &own);
    }
    if (result == BBC_OK)
      result = examine_position(b, g, position_mode, &piece, b->split_forms ? &own : NULL,
                                b->split_forms ? 0 : origin, &pf, &v, NULL);
    const double *box = pf.box;
    const bbc_tuple_geometry *gp = &pf.g; /* with the piece's light box */
    const int s_axis = pf.s_axis, t_axis = pf.t_axis;
    bbc_space space = pf.space;
    const chain_forms forms = pf.forms;
    local.position_pieces++;
    double t1 = clock_seconds();
    local.position_seconds += t1 - t0;
    if (result != BBC_OK) break;

    if (v == VERDICT_DISCARD) {
      piece.status = BBC_PIECE_DISCARDED;
      local.discarded_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    /* The parent's position bound holds every path of the piece too. */
    piece.uk_lo = fmax(piece.uk_lo, inherited.uk_lo), piece.uk_hi = fmin(piece.uk_hi, inherited.uk_hi);
    piece.vk_lo = fmax(piece.vk_lo, inherited.vk_lo), piece.vk_hi = fmin(piece.vk_hi, inherited.vk_hi);
    piece.sk_lo = fmax(piece.sk_lo, inherited.sk_lo), piece.sk_hi = fmin(piece.sk_hi, inherited.sk_hi);
    piece.dk_lo = fmax(piece.dk_lo, inherited.dk_lo), piece.dk_hi = fmin(piece.dk_hi, inherited.dk_hi);
    if (piece.uk_lo > piece.uk_hi || piece.vk_lo > piece.vk_hi || piece.sk_lo > piece.sk_hi ||
        piece.dk_lo > piece.dk_hi) {
      /* Two bounds of the same paths that do not meet: the piece holds none. */
      piece.status = BBC_PIECE_DISCARDED;
      local.discarded_pieces++;
      if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
      continue;
    }
    /* The inherited irradiance bound (the parent's) is valid for the piece as it is. */
    bbc_piece_need need = prm.need ? prm.need(prm.need_user, &piece) : BBC_NEED_SPLIT;
    /* A partial piece in one cell may still turn out to hold no path there. */
    if (need == BBC_NEED_KEEP && v == VERDICT_PARTIAL) need = BBC_NEED_SPLIT;
    int can_split = (piece.level < max_level || (g->light_model.kind == BBC_LIGHT_AREA &&
                                                  piece.light_level < light_max_level(max_level))) &&
                    need == BBC_NEED_SPLIT;
    double area = (piece.uk_hi - piece.uk_lo) * (piece.vk_hi - piece.vk_lo);
    const int refining = piece.split_state & SPLIT_POSITION_ONLY;
    int need_memo = (int)need; /* ask_need's answer for the piece's current bounds */
    int split = 0;
    if (need == BBC_NEED_NONE || refining) {
      split = 0; /* a refined piece keeps its inherited irradiance bound (below) */
    } else if (can_split && v == VERDICT_PARTIAL && area >= sigma) {
      split = 1;
    } else if (!prm.positions_only) {
      /* Reflection has no remainder variables: its position forms serve as they are. */
      const chain_forms *irr = &forms;
      chain_forms irr_forms;
      if ((g->refract || (g->length == 2 && g->refract2)) && irradiance_mode != position_mode) {
        /* One bounce: only sqrt(beta) and what follows differ from the position forms. */
        if (g->length == 1)
          result = bbc__chain_forms_rescatter(&b->arena, &space, gp, &forms, irradiance_mode,
                                              &irr_forms);
        else
          result = bbc__chain_forms(&b->arena, &space, gp, box, s_axis, t_axis, irradiance_mode,
                                    &irr_forms);
        irr = &irr_forms;
      }
      const double uk_box[4] = {piece.uk_lo, piece.uk_hi, piece.vk_lo, piece.vk_hi};
      double e_lo = 0, e_hi = INFINITY;
      /* The Jacobian's rational where the piece carries it. */
      bbc_poly jac[2];
      const int carried = b->split_forms && own.count == PIECE_POLYS;
      if (carried) {
        chain_forms view;
        polys_view(&own, &view, jac);
      }
      if (result == BBC_OK)
        result = irradiance_bound(&b->arena, &space, gp, irr, carried ? jac : NULL,
                                  carried ? own.jacobian_area : 0, box, uk_box, s_axis, t_axis,
                                  prm.jacobian, alpha, &e_lo, &e_hi);
      local.irradiance_pieces++;
      local.irradiance_seconds += clock_seconds() - t1;
      if (result != BBC_OK) break;
      /* Both the piece's own bound and the inherited one hold: keep the tighter ends. */
      piece.e_lo = fmax(piece.e_lo, e_lo);
      piece.e_hi = fmin(piece.e_hi, e_hi);
      need_memo = -1;
      if (can_split) can_split = ask_need(&prm, &piece, &need_memo) == BBC_NEED_SPLIT;
      split = can_split && (area >= sigma || g->light_model.kind == BBC_LIGHT_AREA) &&
              !(piece.e_hi < alpha * piece.e_lo);
      /* Two bounces: a piece whose irradiance bound is unbounded is split whatever the
       * area of its position bound and even when that falls in one cell, and down to
       * UNBOUNDED_LEVELS below the level limit, unless nothing it could hold changes
       * what is recorded (docs/double-scattering.md, "Unbounded pieces"). Its +inf
       * would otherwise cover every cell its position bound reaches. */
      if (!split && g->length == 2 && !(piece.e_hi < INFINITY) && max_level > 0 &&
          piece.level < max_level + UNBOUNDED_LEVELS)
        split = ask_need(&prm, &piece, &need_memo) != BBC_NEED_NONE;
    } else {
      split = can_split && area >= sigma;
    }
    /* The position refinement (POSITION_LEVELS). */
    if (!split && g->length == 2 && g->light_model.kind != BBC_LIGHT_AREA && !prm.positions_only &&
        max_level > 0 && piece.level < max_level + position_levels &&
        area >= POSITION_SIGMAS * sigma &&
        need == BBC_NEED_SPLIT && ask_need(&prm, &piece, &need_memo) == BBC_NEED_SPLIT) {
      split = 1;
      piece.split_state |= SPLIT_POSITION_ONLY;
    }
    /* A spot's falloff over the piece's directions (1 for other lights) multiplies the
     * bound of a kept piece, after the stopping rule, which judges the geometric factors
     * alone: near the cone's edge the falloff's lower end is 0 at every level
     * (docs/lights.md). Inherited bounds are geometric too (a split piece's bound never
     * has the falloff), so it is applied exactly once. */
    if (!split && g->light_model.kind == BBC_LIGHT_SPOT) {
      bbc_interval fall = bbc__light_falloff_over_box(g->light, &g->light_model, g->p, box);
      piece.e_lo = piece.e_lo > 0 ? piece.e_lo * fall.lo * (1 - 4 * DBL_EPSILON) : 0;
      if (isfinite(piece.e_hi) && piece.e_hi > 0) {
        double hi = piece.e_hi * fall.hi * (1 + 4 * DBL_EPSILON);
        piece.e_hi = hi > 0 ? hi : DBL_TRUE_MIN; /* never rounded down to 0 */
      }
    }

    int light_split = split && split_light(g, &piece, max_level);
    if (split && g->light_model.kind == BBC_LIGHT_AREA && g->length == 2 &&
        !(piece.e_hi < INFINITY)) {
      /* Two bounces, unbounded: the +inf comes from u1 (rays grazing T2's plane, a fold
       * of the caustic) far more than from the emitter part, so u1 is split first, as for
       * a point light (down to UNBOUNDED_LEVELS below the limit), and the light box only
       * then. The rule of the spent boxes below would stop at once: a split of such a
       * piece rarely halves its position bound, and +inf never halves. */
      const int u1_ok = max_level > 0 && piece.level < max_level + UNBOUNDED_LEVELS;
      const int light_ok = piece.light_level < light_max_level(max_level);
      light_split = !u1_ok;
      if (!u1_ok && !light_ok) split = 0;
    } else if (split && g->light_model.kind == BBC_LIGHT_AREA) {
      /* Whether the split that made the piece paid (the parent's bounds are inherited). */
      const int last = piece.split_state & (SPLIT_LAST_U1 | SPLIT_LAST_LIGHT);
      double parent_area = (inherited.uk_hi - inherited.uk_lo) * (inherited.vk_hi - inherited.vk_lo);
      if (last) {
        const int spent = area > SPENT_AREA * parent_area && !(piece.e_hi < SPENT_BOUND * inherited.e_hi);
        if (!spent)
          piece.split_state &= ~(SPLIT_U1_SPENT | SPLIT_LIGHT_SPENT);
        else
          piece.split_state |= last == SPLIT_LAST_U1 ? SPLIT_U1_SPENT : SPLIT_LIGHT_SPENT;
      }
      const int u1_ok = piece.level < max_level && !(piece.split_state & SPLIT_U1_SPENT);
      const int light_ok = piece.light_level < light_max_level(max_level) &&
                           !(piece.split_state & SPLIT_LIGHT_SPENT);
      if (light_split ? light_ok : u1_ok) {
      } else if (light_split ? u1_ok : light_ok) {
        light_split = !light_split;
      } else {
        split = 0;
      }
    }
    if (split && light_split) {
      /* An area light's box is split instead (the u1 box stays). */
      double am = 0.5 * (piece.a_lo + piece.a_hi), bm = 0.5 * (piece.b_lo + piece.b_hi);
      bbc_piece child = piece;
      child.light_level = piece.light_level + 1;
      child.split_state = (piece.split_state & ~SPLIT_LAST_U1) | SPLIT_LAST_LIGHT;
      const double as[3] = {piece.a_lo, am, piece.a_hi}, bs[3] = {piece.b_lo, bm, piece.b_hi};
      for (int j = 0; j < 2 && result == BBC_OK; j++) {
        for (int i = 0; i < 2 && result == BBC_OK; i++) {
          child.a_lo = as[i], child.a_hi = as[i + 1];
          child.b_lo = bs[j], child.b_hi = bs[j + 1];
          result = push(b, &count, &child, 0);
        }
      }
      continue;
    }
    uint64_t first_child = 0;
    if (split && b->split_forms && (result = push_parent(b, &own, &first_child)) != BBC_OK) break;
    if (split && (piece.split_state & SPLIT_POSITION_ONLY) &&
        (result = refined_store(b, &forms, s_axis, t_axis, &first_child)) != BBC_OK)
      break;
    if (split) {
      double um = 0.5 * (piece.u_lo + piece.u_hi), vm = 0.5 * (piece.v_lo + piece.v_hi);
      bbc_piece child = piece; /* inherits the position and irradiance bounds */
      child.level = piece.level + 1;
      if (g->light_model.kind == BBC_LIGHT_AREA)
        child.split_state = (piece.split_state & ~SPLIT_LAST_LIGHT) | SPLIT_LAST_U1;
      const double us[3] = {piece.u_lo, um, piece.u_hi}, vs[3] = {piece.v_lo, vm, piece.v_hi};
      for (int j = 0; j < 2 && result == BBC_OK; j++) {
        for (int i = 0; i < 2 && result == BBC_OK; i++) {
          child.u_lo = us[i];
          child.u_hi = us[i + 1];
          child.v_lo = vs[j];
          child.v_hi = vs[j + 1];
          result = push(b, &count, &child, first_child + (uint64_t)(2 * j + i));
        }
      }
      continue;
    }
    piece.status = BBC_PIECE_KEPT;
    local.kept_pieces++;
    if (fn && fn(user, &piece)) result = BBC_ERR_CANCELLED;
  }
done:
  b->split_forms = 0;
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

bbc_arena *bbc__bounder_arena(bbc_bounder *b) {
  return &b->arena;
}

bbc_result bbc__ray_lands(bbc_arena *arena, const bbc_poly *up, const bbc_poly *vp,
                          const bbc_poly *kappa, const bbc_poly *tnum, double box[8], int *partial,
                          int *wide, int *inside) {
  return ray_lands(arena, up, vp, kappa, tnum, box, partial, wide, inside, NULL);
}

bbc_result bbc__irradiance_bound_explicit(bbc_arena *arena, const bbc_space *space,
                                          const bbc_tuple_geometry *g, const chain_forms *f,
                                          const double box[4], int s_axis, int t_axis,
                                          bbc_jacobian_form form, double *e_lo, double *e_hi) {
  *e_lo = 0;
  *e_hi = INFINITY;
  if (!f->slope_enclosed || (f->length == 2 && !f->slope_enclosed2)) return BBC_OK;
  bbc_interval scale = irradiance_scale(g, f, (box[1] - box[0]) * (box[3] - box[2]));
  return explicit_bound(arena, space, f, NULL, s_axis, t_axis, form, scale, e_lo, e_hi, NULL);
}
