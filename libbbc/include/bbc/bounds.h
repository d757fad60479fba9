/* Caustic bounds (paper Sec. 4.2-4.5): for a tuple (light, one or two specular
 * triangles T1 (T2), a receiver triangle Tk) and boxes ("pieces") of T1's barycentrics
 * u1, conservative bounds of where on the receiver the caustic lands (the position bound,
 * a box of receiver barycentrics u_k) and of the irradiance it carries there (the
 * irradiance bound), refined by breadth-first subdivision of u1. */
#ifndef BBC_BOUNDS_H
#define BBC_BOUNDS_H

#include "bbc/scene.h"
#include "bbc/tuple.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The geometry of a tuple in the form the bounds use (doubles; plain struct, fill it with
 * bbc_tuple_geometry_init or by hand for synthetic tuples).
 *
 * T1's normals are oriented toward the light: if the light lies behind T1's plane (as
 * seen from the vertex normals), they are negated, so mirrors reflect on whichever side
 * the light is and a dielectric is entered from the light's side. eta is then the ratio
 * n_incident / n_transmitted (1/ior entering the front side, ior leaving through the
 * back); it is unused for reflection.
 *
 * Double scattering (length 2): T2's normals are oriented the same way toward the side
 * of T2's plane that T1's centroid lies on (the light's side for the second vertex), and
 * eta2 follows from that side. Light reaching T2 from the other side is not part of the
 * tuple. */
typedef struct bbc_tuple_geometry {
  bbc_vec3 light; /* x0 */
  int refract;    /* 0: reflection (R), 1: refraction (T) */
  double eta;     /* eta' of Eq. 10-11 */
  bbc_vec3 p[3];  /* T1's vertices p_{1,0..2} (Eq. 6) */
  bbc_vec3 n[3];  /* T1's vertex normals n_{1,0..2}, oriented as described and
                     interpolated unnormalised (Eq. 7) */
  bbc_vec3 r[3];  /* Tk's vertices */
  int length;     /* specular vertices: 1 (0 is read as 1) or 2 */
  int refract2;   /* length 2: the second vertex refracts */
  double eta2;    /* length 2: eta' at the second vertex */
  bbc_vec3 p2[3]; /* length 2: T2's vertices */
  bbc_vec3 n2[3]; /* length 2: T2's vertex normals, oriented as described */
  /* The light's kind (scene.h; zero: a point light at `light`). A sun (directional)
   * sends d0 = light_model.direction to every x1, and "the light's side" of T1 is the
   * side that direction comes from; its irradiance bounds are per unit irradiance
   * (W/m^2 per W/m^2). A spot's bounds include its falloff. */
  bbc_light_model light_model;
  /* An area light (light_model.kind BBC_LIGHT_AREA; `light` is then the emitter's
   * centroid, which orients T1 as a point light's position does): the box
   * {a_lo, a_hi, b_lo, b_hi} of the emitter's square parameters (scene.h) the bounds
   * are taken over; all zero means the whole square. The irradiance bounds of an area
   * light are of A_e cos(theta_e) times the irradiance per unit intensity of a point
   * light at the emitter point: per unit radiance (W/m^2 per W/sr/m^2), the value of a
   * path whose emitter point is drawn uniformly by area (docs/lights.md). */
  double light_box[4];
} bbc_tuple_geometry;

/* Fills g for a tuple of the scene (any chain type).
 * BBC_ERR_INVALID_ARGUMENT for an unknown chain, out-of-range indices or T2 = T1. */
BBC_API bbc_result bbc_tuple_geometry_init(bbc_tuple_geometry *g, const bbc_scene *scene,
                                           const bbc_tuple *tuple);

typedef enum bbc_jacobian_form {
  BBC_JACOBIAN_DETERMINANT = 0, /* |det du_k/du_1| = |D| / |q|^3 (DESIGN 3.5), default */
  BBC_JACOBIAN_QUOTIENT = 1     /* the quotient-rule form, |N| / q^4 with N = q D expanded */
} bbc_jacobian_form;

/* What the caller (the precompute, which records pieces into receiver cells) still
 * needs from a piece whose position bound is known (see bbc_bound_params.need). */
typedef enum bbc_piece_need {
  BBC_NEED_SPLIT = 0, /* subdivide it as the stopping rules say */
  BBC_NEED_KEEP = 1,  /* finer position bounds change nothing recorded (the piece falls
                         in one cell): bound its irradiance and keep it unsplit */
  BBC_NEED_NONE = 2   /* nothing it or its subpieces can hold changes what is recorded
                         (every cell it reaches already holds at least its E_hi): keep
                         it as it is */
} bbc_piece_need;

struct bbc_piece;
struct bbc_beam_piece;
typedef bbc_piece_need (*bbc_piece_need_fn)(void *user, const struct bbc_piece *piece);

/* Parameters of the subdivision; a zero-initialised struct means the defaults. */
typedef struct bbc_bound_params {
  int max_level;    /* deepest subdivision level of the u1 box; 0 = 10, negative = 0
                     * (the root piece only). Two bounces: a piece whose irradiance
                     * bound is unbounded may be split once more (if max_level > 0) */
  double sigma;     /* stop when the position bound's area is below this; 0 = 1e-4 */
  double alpha;     /* stop when E_hi / E_lo is below this; 0 = 2 for one specular
                       vertex, 10 for two (Sec. 6.1) */
  int no_remainder; /* replace sqrt by its linearisation without remainder variables
                       (NOT conservative: the paper's Fig. 18 ablation) */
  bbc_jacobian_form jacobian;
  int positions_only; /* skip irradiance bounds (E_hi = +inf, E_lo = 0) */
  /* Two bounces from a point, spot or sun: how many levels below the level limit a kept
   * piece whose position bound is still at least 4 sigma in area is split for its
   * position bound alone, its quarters inheriting its irradiance bound; 0 = 4, negative =
   * none */
  int position_levels;
  /* Optional (NULL: always split by the rules): asked for every piece whose position
   * bound is known, with the E_lo, E_hi it inherits from its parent (a bound of its
   * paths too) and again once its own irradiance bound is known. It may stop the
   * subdivision early but never changes a bound, so every reported leaf stays valid. */
  bbc_piece_need_fn need;
  void *need_user;
  /* bbc_bound_beam: the same question for a beam's pieces (their world boxes), with
   * need_user; NULL: always split by the rules. */
  bbc_piece_need (*beam_need)(void *user, const struct bbc_beam_piece *piece);
  /* bbc_bound_beam: the range [*depth_lo, *depth_hi] along `axis` of the receivers'
   * points inside the box lo..hi (with need_user), or 0 when the box holds none; the
   * beam then narrows a piece's slab to the receivers it can meet (docs/beams.md). NULL:
   * every point of the receivers' box may be a receiver's. */
  int (*beam_depth)(void *user, int axis, const double lo[3], const double hi[3], double *depth_lo,
                    double *depth_hi);
} bbc_bound_params;

typedef enum bbc_piece_status {
  BBC_PIECE_KEPT = 0,     /* may hold valid paths; its bounds are valid for all of them */
  BBC_PIECE_DISCARDED = 1 /* proved to hold no valid path */
} bbc_piece_status;

/* A leaf of the subdivision: the box [u_lo, u_hi] x [v_lo, v_hi] of T1's barycentrics
 * (it may stick out of the triangle, u + v > 1, which holds no path) and, when kept, its
 * position bound (a box of receiver barycentrics clipped to [0,1]^2) and irradiance bound
 * per unit light intensity (W/m^2 per W/sr), E_hi possibly +inf near focal points. */
typedef struct bbc_piece {
  double u_lo, u_hi, v_lo, v_hi;
  int level;
  bbc_piece_status status;
  double uk_lo, uk_hi, vk_lo, vk_hi;
  /* Kept pieces: bounds of u_k + v_k and u_k - v_k (clipped to [0, 1] and [-1, 1]),
   * which cut the box's corners: the position bound is the octagon of all three. */
  double sk_lo, sk_hi, dk_lo, dk_hi;
  /* Kept pieces: two more cuts of the position bound, across the sides of the piece's
   * image, {a, b, lo, hi} for lo <= a u_k + b v_k <= hi (|a|, |b| <= 1; a = b = 0: no
   * cut). They make the octagon's slanted images a tight polygon. */
  double cut[2][4];
  double e_lo, e_hi;
  /* Area lights: the box of the emitter's square parameters (a, b) the piece covers, and
   * its subdivision level (the u1 box's is `level`); [0, 1]^2 and 0 for other lights. */
  double a_lo, a_hi, b_lo, b_hi;
  int light_level;
  /* The subdivision's bookkeeping: for area lights, which box the last split halved and
   * which splits were found not to pay (docs/lights.md "Subdivision"); for two bounces
   * from other lights, whether the piece was split for its position bound alone
   * (bbc_bound_params.position_levels). */
  int split_state;
} bbc_piece;

/* Whether the receiver barycentrics (u, v) lie in the piece's position bound (its box,
 * octagon and cuts). */
BBC_API int bbc_piece_position_contains(const bbc_piece *piece, double u, double v);

/* Statistics of bounding, summed over calls (the paper's Table 2 precompute columns). */
typedef struct bbc_bound_stats {
  uint64_t tuples;
  uint64_t position_pieces;   /* pieces whose position bound was computed */
  uint64_t irradiance_pieces; /* pieces whose irradiance bound was computed */
  uint64_t kept_pieces, discarded_pieces;
  /* Time in the position and irradiance bounds on the monotonic clock (the thread's CPU
   * time while it has a core to itself; read without a system call). */
  double position_seconds, irradiance_seconds;
} bbc_bound_stats;

/* Called for every leaf piece, in breadth-first order. A non-zero return stops. */
typedef int (*bbc_piece_fn)(void *user, const bbc_piece *piece);

/* Per-thread working memory of the bounder. Opaque; one per thread. */
typedef struct bbc_bounder bbc_bounder;
BBC_API bbc_result bbc_bounder_create(bbc_bounder **out);
BBC_API void bbc_bounder_free(bbc_bounder *bounder); /* NULL is allowed */

/* Subdivides T1's barycentric domain breadth-first and reports every leaf: discarded
 * pieces (proved empty), and kept ones with their bounds. stats may be NULL and is added
 * to. Returns BBC_ERR_CANCELLED if fn returned non-zero. */
BBC_API bbc_result bbc_bound_tuple(bbc_bounder *bounder, const bbc_tuple_geometry *g,
                                   const bbc_bound_params *params, bbc_piece_fn fn, void *user,
                                   bbc_bound_stats *stats);

/* A piece of a beam (bbc_bound_beam): the light leaving the last specular vertex of the
 * paths of T1's box [u_lo, u_hi] x [v_lo, v_hi] (the light's box [a_lo, a_hi] x [b_lo,
 * b_hi] for area lights), bounded without a receiver: every point x those paths reach
 * (forward along the ray) with x[axis] in [lambda_lo, lambda_hi] and x in the receivers'
 * box lies in [box_lo, box_hi] (world space), and the irradiance there on a receiving
 * surface of any orientation is at most e_hi (per unit light intensity, as
 * bbc_piece.e_hi; +inf near a focus). e_lo is a lower bound of the irradiance on the
 * surface normal to the ray (0 when unknown); a surface at an angle receives less.
 * axis is -1 when no axis separates the rays from the planes (the box is then the
 * receivers' box and e_hi is +inf). Discarded pieces hold no path reaching the box. */
typedef struct bbc_beam_piece {
  double u_lo, u_hi, v_lo, v_hi;
  int level;
  bbc_piece_status status;
  int axis; /* 0, 1, 2 (x, y, z) or -1 */
  double lambda_lo, lambda_hi;
  int lambda_level; /* halvings of the receivers' range on the axis */
  double box_lo[3], box_hi[3];
  double e_lo, e_hi;
  double a_lo, a_hi, b_lo, b_hi; /* area lights; [0, 1]^2 for the others */
  int light_level;
} bbc_beam_piece;

/* Asked for every piece of a beam whose box is known (see bbc_bound_params.beam_need). */
typedef bbc_piece_need (*bbc_beam_need_fn)(void *user, const struct bbc_beam_piece *piece);
typedef int (*bbc_beam_piece_fn)(void *user, const bbc_beam_piece *piece);

/* Bounds the beam of a tuple (g's receiver is unused) over the receivers' world box
 * [receivers_lo, receivers_hi]: subdivides T1's barycentric box and the distance along
 * the ray (the coordinate lambda of a dominant axis) breadth-first and reports every leaf
 * (docs/beams.md). params as for bbc_bound_tuple (max_level caps both subdivisions; sigma
 * is the box's area across the axis as a fraction of the receivers' box's; need is not
 * used, beam_need is). BBC_ERR_INVALID_ARGUMENT for an empty or non-finite receivers'
 * box; BBC_ERR_CANCELLED if fn returned non-zero. */
BBC_API bbc_result bbc_bound_beam(bbc_bounder *bounder, const bbc_tuple_geometry *g,
                                  const double receivers_lo[3], const double receivers_hi[3],
                                  const bbc_bound_params *params, bbc_beam_piece_fn fn, void *user,
                                  bbc_bound_stats *stats);

/* The candidate tuples with beam receivers (bbc_precompute_params.beam_receivers), in
 * bbc_precompute's order: those of bbc_tuples_find for `chains`, then those of
 * bbc_tuples_find_area for `area_chains` (0: none), but with the receiver triangles
 * that are not on a receiver plane replaced, per (light, T1[, T2]) prefix whose beam
 * can reach one, by one tuple whose receiver is BBC_RECEIVER_BEAM (after the prefix's
 * plane tuples). */
BBC_API bbc_result bbc_tuples_find_beam(const bbc_scene *scene, uint32_t chains,
                                        uint32_t area_chains, bbc_tuple **out, size_t *count);

/* The candidate tuples of the scene for the chain types in `chains` (a mask of
 * BBC_CHAIN_BIT), in the deterministic order bbc_precompute uses: by light, then first
 * specular triangle, then second specular triangle (none first), then receiver. *out
 * is allocated with malloc. */
BBC_API bbc_result bbc_tuples_find(const bbc_scene *scene, uint32_t chains, bbc_tuple **out,
                                   size_t *count);

/* The candidate tuples of the scene's area lights (emissive triangles; their light
 * index is point_light_count + the emitter's index, scene.h) for the chain types of
 * `chains`, single and double scattering, in the same order. (Caches of format 1.2 and
 * 1.3 hold the R and T ones only: pass those alone to match them.) */
BBC_API bbc_result bbc_tuples_find_area(const bbc_scene *scene, uint32_t chains,
                                        bbc_tuple **out, size_t *count);

#ifdef __cplusplus
}
#endif

#endif
