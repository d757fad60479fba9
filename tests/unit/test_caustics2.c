/* The caustic estimator on double-scattering tuples (RR, RT, TR, TT), solved by Newton's
 * method on the chain (bbc_render_options.solver). The caches here are built by the
 * tests themselves with the cache builder, independently of the precompute:
 *   - two-mirrors: every ordered pair of mirror triangles with every receiver triangle,
 *     bound +inf over the whole receiver triangle (nothing can be missed);
 *   - traced: the tuples physical rays from the light reach (ray casting through the
 *     scene, not the solver), each splatted over its footprint, dilated, with twice the
 *     greatest irradiance seen. Not conservative, but the renders compared here all use
 *     the same cache, so they estimate the same sum.
 * Oracles: the twice-mirrored light in a right-angled mirror corner (closed form), and
 * exhaustive multi-start Newton (a dense grid of starts, deduplicated) for the
 * unbiasedness of the stochastic estimate. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "caustics_internal.h"
#include "floor_footprint.h"
#include "harness.h"
#include "media_internal.h"
#include "vec_internal.h"

#define PI 3.14159265358979323846

typedef struct fixture {
  bbc_scene *scene;
  bbc_accel *accel;
  bbc_cache *cache;
  void *bytes;
} fixture;

static int load(fixture *f, const char *path) {
  memset(f, 0, sizeof *f);
  return bbc_scene_load(&f->scene, path, NULL) == BBC_OK &&
         bbc_accel_create(&f->accel, f->scene, NULL, NULL) == BBC_OK;
}

static void teardown(fixture *f) {
  bbc_cache_close(f->cache);
  free(f->bytes);
  bbc_accel_free(f->accel);
  bbc_scene_free(f->scene);
}

static int open_built(fixture *f, bbc_cache_builder *b) {
  size_t size = 0;
  bbc_result r = bbc_cache_builder_write_memory(b, &f->bytes, &size, NULL);
  bbc_cache_builder_free(b);
  if (r != BBC_OK) return 0;
  return bbc_cache_open_memory(&f->cache, f->bytes, size, NULL) == BBC_OK &&
         bbc_cache_check_scene(f->cache, f->scene) == BBC_OK;
}

/* Where a tuple of receiver triangle t ends: the triangle, or its mesh's plane. */
static uint32_t tuple_end(const bbc_scene *s, uint32_t t) {
  const uint32_t m = s->triangle_mesh[t];
  return s->meshes[m].plane ? BBC_RECEIVER_PLANE(m) : t;
}

static int is_role(const bbc_scene *s, uint32_t t, bbc_role role) {
  return s->meshes[s->triangle_mesh[t]].role == role;
}

static int chain_of(const bbc_scene *s, uint32_t t1, uint32_t t2, uint32_t *chain) {
  int r1 = bbc_scene_triangle_material(s, t1)->type == BBC_MATERIAL_MIRROR;
  int r2 = bbc_scene_triangle_material(s, t2)->type == BBC_MATERIAL_MIRROR;
  *chain = r1 ? (r2 ? BBC_CHAIN_RR : BBC_CHAIN_RT) : (r2 ? BBC_CHAIN_TR : BBC_CHAIN_TT);
  return 1;
}

/* Every (light, T1, T2 != T1, receiver) tuple over casters, +inf in every cell of its
 * receiver triangle. */
static int cache_all_pairs(fixture *f) {
  const bbc_scene *s = f->scene;
  bbc_precompute_params params;
  bbc_precompute_params_default(&params);
  params.grid_resolution = 16;
  bbc_cache_builder *b = NULL;
  if (bbc_cache_builder_create(&b, s, &params) != BBC_OK) return 0;
  for (uint32_t l = 0; l < s->point_light_count; l++)
    for (uint32_t t1 = 0; t1 < s->triangle_count; t1++)
      for (uint32_t t2 = 0; t2 < s->triangle_count; t2++)
        for (uint32_t r = 0; r < s->triangle_count; r++) {
          if (t1 == t2 || !is_role(s, t1, BBC_ROLE_CASTER) || !is_role(s, t2, BBC_ROLE_CASTER) ||
              !is_role(s, r, BBC_ROLE_RECEIVER))
            continue;
          /* A plane's tuples end on its plane: once per plane. */
          const uint32_t end = tuple_end(s, r);
          if (end != r && r != s->meshes[s->triangle_mesh[r]].first_triangle) continue;
          bbc_tuple t = {l, 0, {t1, t2}, end};
          chain_of(s, t1, t2, &t.chain);
          uint32_t id;
          if (bbc_cache_builder_add_tuple(b, &t, &id) != BBC_OK ||
              bbc_cache_builder_splat(b, id, end, -0.01, 1.01, -0.01, 1.01, INFINITY) != BBC_OK) {
            bbc_cache_builder_free(b);
            return 0;
          }
        }
  return open_built(f, b);
}

/* The precompute's own cache of the given chain types (conservative bounds). */
static int cache_precomputed(fixture *f, uint32_t chains, uint32_t level, uint32_t resolution) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.chains = chains;
  o.params.max_level = level;
  o.params.grid_resolution = resolution;
  bbc_cache_builder *b = NULL;
  if (bbc_precompute(&b, f->scene, &o, NULL) != BBC_OK) return 0;
  return open_built(f, b);
}

/* ------------------------------------------------------------------------------------ */
/* Traced caches: which tuples do physical rays from the light follow? */

static bbc_vec3 vertex(const bbc_scene *s, uint32_t t, int j) {
  return v3_load(s->positions + 3 * (size_t)s->indices[3 * (size_t)t + j]);
}
static bbc_vec3 vertex_normal(const bbc_scene *s, uint32_t t, int j) {
  return v3_load(s->normals + 3 * (size_t)s->indices[3 * (size_t)t + j]);
}
static bbc_vec3 at(const bbc_scene *s, uint32_t t, double u, double v, int normal) {
  bbc_vec3 (*get)(const bbc_scene *, uint32_t, int) = normal ? vertex_normal : vertex;
  bbc_vec3 a = get(s, t, 0), b = get(s, t, 1), c = get(s, t, 2);
  return v3_add(v3_scale(a, 1 - u - v), v3_add(v3_scale(b, u), v3_scale(c, v)));
}

/* Mirror reflection or refraction of unit direction d at unit normal n (either side). */
static int scatter(const bbc_material *m, bbc_vec3 d, bbc_vec3 n, bbc_vec3 *out) {
  double c = v3_dot(d, n);
  if (m->type == BBC_MATERIAL_MIRROR) {
    *out = v3_madd(d, n, -2 * c);
    return 1;
  }
  double eta = 1.0 / m->ior;
  if (c > 0) eta = m->ior, n = v3_neg(n), c = -c;
  double k = 1 - eta * eta * (1 - c * c);
  if (k <= 0) return 0;
  *out = v3_normalize(v3_add(v3_scale(d, eta), v3_scale(n, -eta * c - sqrt(k))));
  return 1;
}

typedef struct record {
  bbc_tuple tuple;
  double b1, b2, e; /* barycentrics on the tuple's receiver triangle (a plane's own) */
  uint32_t hit;     /* the receiver triangle the path reached, at barycentrics: */
  double hit_b1, hit_b2;
} record;

static int compare_records(const void *pa, const void *pb) {
  const bbc_tuple *a = &((const record *)pa)->tuple, *b = &((const record *)pb)->tuple;
  uint32_t ka[5] = {a->light, a->chain, a->specular[0], a->specular[1], a->receiver};
  uint32_t kb[5] = {b->light, b->chain, b->specular[0], b->specular[1], b->receiver};
  for (int i = 0; i < 5; i++)
    if (ka[i] != kb[i]) return ka[i] < kb[i] ? -1 : 1;
  return 0;
}

/* Casts the ray light -> (u, v) on caster t1 through the scene; on reaching a receiver
 * after exactly two caster hits, fills the record from the exact path of the tuple.
 * Returns 1 then. */
static int trace_one(const fixture *f, uint32_t light, uint32_t t1, double u, double v,
                     record *out) {
  const bbc_scene *s = f->scene;
  bbc_vec3 x = at(s, t1, u, v, 0), l = s->point_lights[light].position;
  bbc_vec3 d = v3_normalize(v3_sub(x, l));
  if (bbc_accel_occluded(f->accel, l, v3_sub(x, l), 0, 1 - 1e-6)) return 0;
  uint32_t tri[3] = {t1, 0, 0};
  bbc_hit hit = {0, t1, u, v};
  for (int i = 0; i < 2; i++) {
    bbc_vec3 n = v3_normalize(at(s, hit.triangle, hit.u, hit.v, 1));
    bbc_vec3 ng =
        v3_normalize(v3_cross(v3_sub(vertex(s, hit.triangle, 1), vertex(s, hit.triangle, 0)),
                              v3_sub(vertex(s, hit.triangle, 2), vertex(s, hit.triangle, 0))));
    if (!scatter(bbc_scene_triangle_material(s, hit.triangle), d, n, &d)) return 0;
    if (!bbc_accel_intersect(f->accel, v3_offset_origin(x, ng, d), d, 0, 1e30, &hit)) return 0;
    tri[i + 1] = hit.triangle;
    x = at(s, hit.triangle, hit.u, hit.v, 0);
    if (i == 0 && !is_role(s, hit.triangle, BBC_ROLE_CASTER)) return 0;
  }
  if (!is_role(s, tri[2], BBC_ROLE_RECEIVER) || tri[1] == t1) return 0;
  bbc_tuple t = {light, 0, {t1, tri[1]}, tuple_end(s, tri[2])};
  chain_of(s, t1, tri[1], &t.chain);
  bbc_path_geometry g;
  bbc_specular_path p;
  if (bbc_path_geometry_init(&g, s, &t) != BBC_OK ||
      bbc_specular_path_trace(&g, u, v, &p) != BBC_OK)
    return 0;
  if (!p.complete || (p.flags & BBC_PATH_REJECT & ~(uint32_t)BBC_PATH_OUTSIDE_RECEIVER) ||
      !isfinite(p.irradiance))
    return 0;
  out->tuple = t;
  out->b1 = p.uk[0], out->b2 = p.uk[1], out->e = p.irradiance;
  out->hit = hit.triangle, out->hit_b1 = hit.u, out->hit_b2 = hit.v;
  return 1;
}

/* All traced records of the scene: n x n starts per caster triangle and light. The
 * caller frees *out. */
static size_t trace_records(const fixture *f, int n, record **out) {
  const bbc_scene *s = f->scene;
  size_t count = 0, cap = 1024;
  record *r = malloc(cap * sizeof *r);
  for (uint32_t l = 0; l < s->point_light_count; l++)
    for (uint32_t t1 = 0; t1 < s->triangle_count; t1++) {
      if (!is_role(s, t1, BBC_ROLE_CASTER)) continue;
      for (int j = 0; j < n; j++)
        for (int i = 0; i + j < n; i++) {
          if (count == cap) r = realloc(r, (cap *= 2) * sizeof *r);
          if (trace_one(f, l, t1, (i + 1.0 / 3) / n, (j + 1.0 / 3) / n, &r[count])) count++;
          if (i + j + 1 < n) {
            if (count == cap) r = realloc(r, (cap *= 2) * sizeof *r);
            if (trace_one(f, l, t1, (i + 2.0 / 3) / n, (j + 2.0 / 3) / n, &r[count])) count++;
          }
        }
    }
  qsort(r, count, sizeof *r, compare_records);
  *out = r;
  return count;
}

/* A cache of the traced tuples: each one's footprint (receiver barycentrics) widened by
 * `dilate`, bound twice the greatest traced irradiance times the light's intensity. */
static int cache_traced(fixture *f, int n, double dilate, uint32_t resolution) {
  record *r = NULL;
  size_t count = trace_records(f, n, &r);
  bbc_precompute_params params;
  bbc_precompute_params_default(&params);
  params.grid_resolution = resolution;
  bbc_cache_builder *b = NULL;
  int ok = count > 0 && bbc_cache_builder_create(&b, f->scene, &params) == BBC_OK;
  for (size_t i = 0; ok && i < count;) {
    size_t j = i;
    double lo1 = 1e30, hi1 = -1e30, lo2 = 1e30, hi2 = -1e30, e = 0;
    for (; j < count && compare_records(&r[i], &r[j]) == 0; j++) {
      lo1 = fmin(lo1, r[j].b1), hi1 = fmax(hi1, r[j].b1);
      lo2 = fmin(lo2, r[j].b2), hi2 = fmax(hi2, r[j].b2);
      e = fmax(e, r[j].e);
    }
    const float *intensity = f->scene->point_lights[r[i].tuple.light].intensity;
    double bound = 2 * e * fmax(intensity[0], fmax(intensity[1], intensity[2]));
    uint32_t id;
    ok = bbc_cache_builder_add_tuple(b, &r[i].tuple, &id) == BBC_OK &&
         bbc_cache_builder_splat(b, id, r[i].tuple.receiver, lo1 - dilate, hi1 + dilate,
                                 lo2 - dilate, hi2 + dilate, bound) == BBC_OK;
    i = j;
  }
  free(r);
  if (!ok) {
    bbc_cache_builder_free(b);
    return 0;
  }
  bbc_cache_info info;
  int opened = open_built(f, b);
  if (opened) {
    bbc_cache_get_info(f->cache, &info);
    fprintf(stderr, "traced cache: %u tuples\n", info.tuple_count);
  }
  return opened;
}

static bbc_image *render(const fixture *f, bbc_method method, bbc_solver_method solver,
                         uint32_t spp, uint64_t seed, int threads, uint32_t w, uint32_t h,
                         bbc_render_stats *stats) {
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return NULL;
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = method;
  o.solver = solver;
  o.cache = f->cache;
  o.spp = spp;
  o.seed = seed;
  o.threads = threads;
  o.components = BBC_COMPONENT_CAUSTICS;
  o.gamma_mode = BBC_GAMMA_EXPECTED;
  o.gamma_value = 2; /* two tuples expected per point: P < 1 for most */
  if (bbc_render(f->scene, f->accel, &o, image, stats) != BBC_OK) {
    bbc_image_free(image);
    return NULL;
  }
  return image;
}

static double mean_of(const bbc_image *a) {
  double s = 0;
  for (size_t i = 0; i < (size_t)a->width * a->height * 3; i++) s += a->rgb[i];
  return s / ((double)a->width * a->height * 3);
}

/* ------------------------------------------------------------------------------------ */
/* The mirror corner: A in x = 0, B in z = 0 (z and x in [0, 2], y in [0, 1.5]), floor
 * [0,4]^2 at y = 0 (scenes/scenegen.c, two-mirrors). Light reflected by both mirrors, in
 * either order, comes from the light's double image L'' = (-x, y, -z): from p, the
 * segment to L'' crosses both planes x = 0 and z = 0 (p is in the quadrant, L'' in the
 * opposite one); the first crossing is the last mirror, where the other horizontal
 * coordinate is still positive, the second is the first mirror unfolded, where it is
 * negative. The path exists iff both crossings lie within the mirrors (height is
 * automatic: y = t L''.y < 1.5), i.e. the other coordinate's magnitude is at most 2. The
 * floor then receives I cos / r^2 from L'' (both mirrors reflect 1). Returns -1 where the
 * point is too close to a crossing's limit to decide. */
static double corner_irradiance(bbc_vec3 light, double intensity, bbc_vec3 p) {
  bbc_vec3 image = v3(-light.x, light.y, -light.z);
  double ta = p.x / (p.x + light.x), tb = p.z / (p.z + light.z); /* from p to L'' */
  double za = p.z + ta * (image.z - p.z), xb = p.x + tb * (image.x - p.x);
  const double margin = 1e-3;
  if (fabs(fabs(za) - 2) < margin || fabs(fabs(xb) - 2) < margin) return -1;
  if (fabs(za) > 2 || fabs(xb) > 2) return 0;
  bbc_vec3 l = v3_sub(image, p);
  double r2 = v3_dot(l, l);
  return intensity * (l.y / sqrt(r2)) / r2;
}

/* The floor's radiance in the corner: albedo / pi times the double image's irradiance
 * (negative where corner_irradiance says so). */
typedef struct corner_light {
  bbc_vec3 position;
  double intensity, albedo_over_pi;
} corner_light;

static double corner_value(const void *user, bbc_vec3 p) {
  const corner_light *c = user;
  double e = corner_irradiance(c->position, c->intensity, p);
  return e < 0 ? e : c->albedo_over_pi * e;
}

/* Both Newton variants find the unique solution of a flat-mirror pair: the caustic-only
 * render is the analytic double image per pixel, in every order of the corner, and zero
 * where no double reflection reaches; with the precompute's RR bounds too (they must
 * cover every path). Each sample is exact at its film position, so a
 * pixel lies between the least and greatest analytic value over its footprint. */
TEST(rr_corner_is_the_double_image) {
  fixture f, pre;
  REQUIRE(load(&f, TEST_SCENE("two-mirrors.gltf")));
  REQUIRE(cache_all_pairs(&f));
  /* The same with the precompute's bounds: they must cover every path. */
  REQUIRE(load(&pre, TEST_SCENE("two-mirrors.gltf")));
  REQUIRE(cache_precomputed(&pre, BBC_CHAIN_BIT(BBC_CHAIN_RR), 6, 128));
  const uint32_t w = 40, h = 30;
  const bbc_point_light *light = &f.scene->point_lights[0];
  float albedo = 0;
  for (uint32_t m = 0; m < f.scene->mesh_count; m++)
    if (f.scene->meshes[m].role == BBC_ROLE_RECEIVER)
      albedo = f.scene->materials[f.scene->meshes[m].material].base_color[0];
  const corner_light corner = {light->position, light->intensity[0], albedo / PI};
  static const double box[4] = {0.05, 3.95, 0.05, 3.95};
  static const char *const names[3] = {"newton-det", "newton-stoch",
                                       "newton-stoch, precomputed cache"};
  for (int variant = 0; variant < 3; variant++) {
    bbc_solver_method solver = variant ? BBC_SOLVER_NEWTON_STOCH : BBC_SOLVER_NEWTON_DET;
    bbc_render_stats stats;
    bbc_image *image =
        render(variant == 2 ? &pre : &f, BBC_METHOD_ENUMERATE, solver, 2, 3, 0, w, h, &stats);
    REQUIRE(image);
    int lit = 0, dark = 0, bad = 0, low = 0;
    for (uint32_t y = 0; y < h; y++) {
      for (uint32_t x = 0; x < w; x++) {
        double lo, hi;
        int usable = floor_footprint_range(f.scene, f.accel, w, h, x, y, box, corner_value,
                                           &corner, &lo, &hi);
        if (!usable || (lo == 0) != (hi == 0)) continue;
        double got = image->rgb[3 * ((size_t)y * w + x)];
        hi == 0 ? dark++ : lit++;
        /* newton-stoch: a sample whose random start on T1 does not reach the path gives 0
         * for it, and one whose reciprocal estimate needed K = 2 trials counts it twice
         * (unbiased over starts, not exact): such a pixel of 2 samples lies below the
         * range, or above it by at most half, and must be rare. */
        if (variant > 0 && ((got < lo * (1 - 1e-4) && got >= 0.5 * lo * (1 - 1e-4)) ||
                            (got > hi * (1 + 1e-4) && got <= 1.5 * hi * (1 + 1e-4)))) {
          low++;
          continue;
        }
        if (!(got >= lo * (1 - 1e-4) && got <= hi * (1 + 1e-4)) && bad++ < 5)
          fprintf(stderr, "%s: pixel (%u,%u): %.9g not in [%.9g, %.9g]\n", names[variant], x, y,
                  got, lo, hi);
      }
    }
    fprintf(stderr,
            "%s: %d lit and %d dark pixels checked; mean |U| %.1f, %llu solves, %llu "
            "converged, mean K %.4f\n",
            names[variant], lit, dark, stats.candidates / (double)stats.lookups,
            (unsigned long long)stats.newton_solves, (unsigned long long)stats.newton_converged,
            stats.newton_estimates ? stats.newton_trials / (double)stats.newton_estimates : 0.0);
    if (low) fprintf(stderr, "%s: %d pixels with one sample's start missing the path or K = 2\n",
                     names[variant], low);
    CHECK(lit > 300);
    CHECK(dark > 5);
    CHECK_INT(bad, 0);
    CHECK(low <= lit / 100);
    CHECK_INT(stats.newton_cap_hits, 0);
    bbc_image_free(image);
  }
  teardown(&pre);
  teardown(&f);
}

/* ------------------------------------------------------------------------------------ */
/* Unbiasedness of newton-stoch against exhaustive multi-start Newton. */

typedef struct test_case {
  bbc_tuple tuple;
  bbc_vec3 p;
  double reference;  /* sum of the values (red) of every distinct solution of the grid */
  double min_basin;  /* the smallest share of grid starts reaching one of them */
  double separation; /* the least distance (u1, max norm) between two solutions */
  int solutions;     /* distinct solutions of nonzero value */
} test_case;

/* Exhaustive multi-start Newton: n^2 starts, the centroids of the n^2 equal triangles
 * T1 splits into, the solutions deduplicated by u1 (with the estimator's threshold,
 * which defines "the same solution"); their values summed. The solver and the value
 * are the estimator's own (the corner test checks them against the closed form): what
 * this oracle checks is the reciprocal-probability machinery. Returns the number of
 * distinct solutions of nonzero value. */
static int exhaustive(const bbc__caustics *c, test_case *tc, int n) {
  bbc_path_geometry g;
  if (bbc_path_geometry_init(&g, c->scene, &tc->tuple) != BBC_OK) return 0;
  enum { MAX = 64 };
  double u[MAX][2], value[MAX];
  int hits[MAX], count = 0, starts = 0;
  bbc_vec3 ng = v3(0, 1, 0);
  for (int j = 0; j < n; j++)
    for (int i = 0; i + j < n; i++)
      for (int half = 0; half < 2; half++) {
        if (half && i + j + 1 >= n) continue;
        double start[2] = {(i + (half ? 2.0 : 1.0) / 3) / n, (j + (half ? 2.0 : 1.0) / 3) / n};
        bbc_solution s;
        int found = 0;
        starts++;
        if (bbc_solver_newton(&g, tc->p, start, NULL, &s, &found) != BBC_OK || !found) continue;
        int k = 0;
        while (k < count && !(fabs(u[k][0] - s.u1[0]) <= BBC__NEWTON_SAME_SOLUTION &&
                              fabs(u[k][1] - s.u1[1]) <= BBC__NEWTON_SAME_SOLUTION))
          k++;
        if (k == count && count < MAX) {
          u[k][0] = s.u1[0], u[k][1] = s.u1[1];
          value[k] = bbc__caustics_solution_value(c, &tc->tuple, &g, &s, tc->p, ng).x;
          hits[k] = 0;
          count++;
        }
        if (k < count) hits[k]++;
      }
  tc->reference = 0;
  tc->min_basin = 1;
  tc->separation = INFINITY;
  tc->solutions = 0;
  for (int k = 0; k < count; k++) {
    for (int j = 0; j < k; j++)
      tc->separation = fmin(tc->separation, fmax(fabs(u[k][0] - u[j][0]), fabs(u[k][1] - u[j][1])));
    if (!(value[k] > 0)) continue;
    tc->reference += value[k];
    tc->min_basin = fmin(tc->min_basin, hits[k] / (double)starts);
    tc->solutions++;
  }
  return tc->solutions;
}

/* On the glass ball (TT), at points where a traced path lands: the mean over many
 * independent keys of the newton-stoch estimate equals the exhaustive sum over
 * solutions (a z-test over all cases), whereas the same estimates without their K (the
 * control) are significantly too dark, so the test can fail. newton-det never exceeds
 * the reference. */
TEST(stoch_is_unbiased) {
  fixture f;
  REQUIRE(load(&f, TEST_SCENE("glass-sphere.gltf")));
  record *r = NULL;
  size_t count = trace_records(&f, 6, &r);
  REQUIRE(count > 100);
  bbc__caustics c;
  memset(&c, 0, sizeof c);
  c.scene = f.scene;
  c.accel = f.accel;
  c.passable = bbc__media_passable(c.scene);
  c.solver = BBC_SOLVER_NEWTON_STOCH;
  bbc__caustics_thread t;
  memset(&t, 0, sizeof t);
  /* Cases: traced landing points whose tuples have a solution some starts miss (else K
   * is always 1 and the test shows nothing), spread over the records. */
  enum { CASES = 16 };
  test_case cases[CASES];
  int n_cases = 0, tried = 0;
  uint64_t state = 12345;
  while (n_cases < CASES && tried < 4000) {
    state = bbc__mix64(state + 1);
    const record *rec = &r[state % count];
    tried++;
    test_case tc;
    memset(&tc, 0, sizeof tc);
    tc.tuple = rec->tuple;
    bbc_path_geometry g;
    bbc_path_geometry_init(&g, f.scene, &rec->tuple);
    tc.p = v3_add(v3_scale(g.receiver[0], 1 - rec->b1 - rec->b2),
                  v3_add(v3_scale(g.receiver[1], rec->b1), v3_scale(g.receiver[2], rec->b2)));
    /* Solutions closer than 1e-2 lie near a fold, where "distinct" depends on the
     * threshold (see BBC__NEWTON_SAME_SOLUTION): no oracle there. */
    int seen = 0;
    for (int i = 0; i < n_cases; i++)
      seen |= memcmp(&cases[i].tuple, &tc.tuple, sizeof tc.tuple) == 0 && cases[i].p.x == tc.p.x &&
              cases[i].p.z == tc.p.z;
    if (seen || exhaustive(&c, &tc, 24) == 0 || tc.min_basin > 0.7 || tc.separation < 1e-2)
      continue;
    cases[n_cases++] = tc;
  }
  fprintf(stderr, "%d cases from %d traced points\n", n_cases, tried);
  REQUIRE(n_cases >= 8);
  const long n = harness_scale(400, 4000);
  double z_num = 0, z_den = 0, c_num = 0, c_den = 0;
  for (int i = 0; i < n_cases; i++) {
    test_case *tc = &cases[i];
    /* A denser grid for the reference: solutions with small basins are found. */
    exhaustive(&c, tc, 96);
    double sum = 0, sum2 = 0, csum = 0, csum2 = 0, det = 0;
    for (long k = 0; k < n; k++) {
      uint64_t trials = t.newton_trials, estimates = t.newton_estimates;
      double x = bbc__caustics_tuple(&c, &t, &tc->tuple, tc->p, v3(0, 1, 0),
                                     bbc__mix64((uint64_t)k * 1000 + (uint64_t)i))
                     .x;
      double kk = t.newton_estimates > estimates ? (double)(t.newton_trials - trials) : 1.0;
      sum += x, sum2 += x * x;
      csum += x / kk, csum2 += (x / kk) * (x / kk);
    }
    double mean = sum / n, var = (sum2 / n - mean * mean) / (n - 1);
    double cmean = csum / n, cvar = (csum2 / n - cmean * cmean) / (n - 1);
    bbc__caustics cd = c;
    cd.solver = BBC_SOLVER_NEWTON_DET;
    det = bbc__caustics_tuple(&cd, &t, &tc->tuple, tc->p, v3(0, 1, 0), 0).x;
    double rel = tc->reference;
    fprintf(stderr,
            "case %2d: %d solutions, min basin %.3f: reference %.6g, stoch %.6g +- %.2g, "
            "without K %.6g, det %.6g\n",
            i, tc->solutions, tc->min_basin, rel, mean, sqrt(var), cmean, det);
    CHECK(det <= rel * (1 + 1e-9));
    z_num += (mean - rel) / rel, z_den += var / (rel * rel);
    c_num += (cmean - rel) / rel, c_den += cvar / (rel * rel);
  }
  double z = z_num / sqrt(z_den), zc = c_num / sqrt(c_den);
  fprintf(stderr, "z = %.3f (newton-stoch), %.3f (control without K); mean K %.3f\n", z, zc,
          t.newton_trials / (double)t.newton_estimates);
  CHECK(fabs(z) < 4);
  CHECK(zc < -6);
  CHECK_INT(t.newton_cap_hits, 0);

  /* A cap of one trial is hit (and counted) whenever the first extra start misses. */
  c.newton_max_trials = 1;
  bbc__caustics_thread capped;
  memset(&capped, 0, sizeof capped);
  int smallest = 0;
  for (int i = 1; i < n_cases; i++)
    if (cases[i].min_basin < cases[smallest].min_basin) smallest = i;
  for (int k = 0; k < 200; k++)
    bbc__caustics_tuple(&c, &capped, &cases[smallest].tuple, cases[smallest].p, v3(0, 1, 0),
                        (uint64_t)k);
  CHECK(capped.newton_cap_hits > 0);
  CHECK(capped.newton_trials == capped.newton_estimates);
  free(r);
  teardown(&f);
}

/* ------------------------------------------------------------------------------------ */

/* Images with double-scattering tuples, sampled (P < 1) and solved with random starts,
 * are bit-identical for any number of threads. */
TEST(two_bounce_render_is_thread_independent) {
  fixture f;
  REQUIRE(load(&f, TEST_SCENE("glass-sphere.gltf")));
  REQUIRE(cache_traced(&f, 4, 0.01, 64));
  const uint32_t w = 32, h = 24;
  bbc_render_stats s1, s3;
  bbc_image *a = render(&f, BBC_METHOD_BBC, BBC_SOLVER_NEWTON_STOCH, 2, 5, 1, w, h, &s1);
  bbc_image *b = render(&f, BBC_METHOD_BBC, BBC_SOLVER_NEWTON_STOCH, 2, 5, 3, w, h, &s3);
  REQUIRE(a && b);
  CHECK(s1.newton_estimates > 100);
  CHECK(s1.sampled < s1.candidates);
  CHECK(mean_of(a) > 0);
  CHECK(memcmp(a->rgb, b->rgb, sizeof(float) * 3 * w * h) == 0);
  CHECK_INT(s1.newton_solves, s3.newton_solves);
  CHECK_INT(s1.newton_trials, s3.newton_trials);
  bbc_image_free(a);
  bbc_image_free(b);
  teardown(&f);
}

/* The render's depth limit: a double-scattering path needs three segments after the
 * shading point's own, so with max_depth 3 (camera -> floor, then light -> x1 -> p) the
 * two-bounce tuples are left out, and with 4 they count. */
TEST(two_bounce_respects_max_depth) {
  fixture f;
  REQUIRE(load(&f, TEST_SCENE("two-mirrors.gltf")));
  REQUIRE(cache_all_pairs(&f));
  bbc_image *image = NULL;
  REQUIRE(bbc_image_create(&image, 16, 12) == BBC_OK);
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_ENUMERATE;
  o.cache = f.cache;
  o.spp = 1;
  o.components = BBC_COMPONENT_CAUSTICS;
  o.max_depth = 3;
  REQUIRE(bbc_render(f.scene, f.accel, &o, image, NULL) == BBC_OK);
  CHECK(mean_of(image) == 0);
  o.max_depth = 4;
  REQUIRE(bbc_render(f.scene, f.accel, &o, image, NULL) == BBC_OK);
  CHECK(mean_of(image) > 0);
  o.solver = (bbc_solver_method)7;
  CHECK_INT(bbc_render(f.scene, f.accel, &o, image, NULL), BBC_ERR_INVALID_ARGUMENT);
  bbc_image_free(image);
  teardown(&f);
}

/* ------------------------------------------------------------------------------------ */
/* The whole estimator at fixed points (cell lookup, sampling, Newton, K), where the
 * reference is exact: the sum over the cell's tuples of every solution exhaustive
 * multi-start Newton finds. Points are traced landing points, jittered, so they lie in
 * the caustic. Averages of N independent estimates converge like 1 / N in relMSE and
 * are unbiased (z-test over all points); newton-det is never above the reference and
 * its bias is reported. */
static void estimator_converges(const char *path, int trace_n, int n_wanted, int grid,
                                int checked) {
  fixture f;
  REQUIRE(load(&f, path));
  REQUIRE(cache_traced(&f, trace_n, 0.01, 64));
  record *r = NULL;
  size_t count = trace_records(&f, trace_n, &r);
  REQUIRE(count > 50);
  bbc__caustics c;
  memset(&c, 0, sizeof c);
  c.scene = f.scene;
  c.accel = f.accel;
  c.passable = bbc__media_passable(c.scene);
  c.cache = f.cache;
  c.tuples = bbc_cache_tuples(f.cache);
  c.chains = BBC_CHAIN_MASK_ALL;
  c.solver = BBC_SOLVER_NEWTON_STOCH;
  bbc__caustics_thread t;
  REQUIRE(bbc__caustics_thread_init(&t, f.cache) == BBC_OK);
  enum { POINTS = 64 };
  typedef struct point {
    uint32_t triangle;
    double b1, b2, reference, det, min_basin;
    bbc_vec3 p;
  } point;
  point pts[POINTS];
  int n_points = 0;
  uint64_t state = 99;
  const bbc_vec3 up = v3(0, 1, 0);
  if (n_wanted > POINTS) n_wanted = POINTS;
  while (n_points < n_wanted) {
    state = bbc__mix64(state + 1);
    const record *rec = &r[state % count];
    point *q = &pts[n_points];
    q->triangle = rec->hit;
    q->b1 = rec->hit_b1 + 0.004 * ((state >> 8 & 0xFF) / 255.0 - 0.5);
    q->b2 = rec->hit_b2 + 0.004 * ((state >> 16 & 0xFF) / 255.0 - 0.5);
    if (!(q->b1 > 0 && q->b2 > 0 && q->b1 + q->b2 < 1)) continue;
    bbc_vec3 a = vertex(f.scene, q->triangle, 0), b = vertex(f.scene, q->triangle, 1),
             cc = vertex(f.scene, q->triangle, 2);
    q->p = v3_add(v3_scale(a, 1 - q->b1 - q->b2), v3_add(v3_scale(b, q->b1), v3_scale(cc, q->b2)));
    const bbc_cache_entry *entries;
    uint32_t n = 0;
    REQUIRE(bbc_cache_lookup(t.cursor, q->triangle, q->b1, q->b2, &q->p, &entries, &n) == BBC_OK);
    q->reference = 0;
    q->det = 0;
    q->min_basin = 1;
    bbc__caustics cd = c;
    cd.solver = BBC_SOLVER_NEWTON_DET;
    for (uint32_t i = 0; i < n; i++) {
      test_case tc;
      memset(&tc, 0, sizeof tc);
      tc.tuple = c.tuples[entries[i].tuple];
      tc.p = q->p;
      if (tc.tuple.receiver != tuple_end(f.scene, q->triangle)) continue;
      exhaustive(&c, &tc, grid);
      q->reference += tc.reference;
      if (tc.solutions) q->min_basin = fmin(q->min_basin, tc.min_basin);
      q->det += bbc__caustics_tuple(&cd, &t, &tc.tuple, q->p, up, 0).x;
    }
    if (q->reference > 0) n_points++;
  }
  /* Every tuple of the cell (the tuple sampler is tested on its own, and its random
   * numbers are independent of the starts'). */
  c.sampling.method = BBC__SAMPLE_ENUMERATE;
  const int ns[3] = {4, 16, 64};
  double errors[3], z = 0;
  for (int k = 0; k < 3; k++) {
    double e = 0, z_num = 0, z_den = 0;
    for (int i = 0; i < n_points; i++) {
      const point *q = &pts[i];
      double sum = 0, sum2 = 0;
      for (int j = 0; j < ns[k]; j++) {
        bbc_rng rng = bbc_rng_make(1000 * (uint64_t)k, (uint64_t)i, (uint64_t)j);
        double x =
            bbc__caustics_estimate(&c, &t, q->p, up, q->triangle, q->b1, q->b2, 2, rng.key, NULL)
                .x;
        sum += x, sum2 += x * x;
      }
      double mean = sum / ns[k], var = fmax(0, sum2 / ns[k] - mean * mean) / (ns[k] - 1);
      e += (mean - q->reference) * (mean - q->reference) / (q->reference * q->reference);
      z_num += (mean - q->reference) / q->reference;
      z_den += var / (q->reference * q->reference);
    }
    errors[k] = e / n_points;
    z = z_den > 0 ? z_num / sqrt(z_den) : (z_num == 0 ? 0 : INFINITY);
    fprintf(stderr, "%s, %d points: N = %2d estimates per point: relMSE %.5g, z %.2f\n", path,
            n_points, ns[k], errors[k], z);
  }
  /* 16x the estimates: 16x less error (4x is asked). A solution whose basin is a small
   * share of T1 is found rarely and then weighted by a large K, so the estimates are
   * skewed and the sample variance understates the noise until N is large: on the
   * research set-ups (full run) the error falls unevenly with N, the z-test is looser,
   * and only their figures are printed (checked = 0). */
  if (checked) {
    CHECK(errors[2] < errors[0] / 4);
    CHECK(fabs(z) < 4);
  }
  double ref = 0, det = 0;
  int det_low = 0, small_basin = 0;
  for (int i = 0; i < n_points; i++) {
    ref += pts[i].reference, det += pts[i].det;
    det_low += pts[i].det < pts[i].reference * (1 - 1e-6);
    small_basin += pts[i].min_basin < 0.3;
    CHECK(pts[i].det <= pts[i].reference * (1 + 1e-9));
  }
  fprintf(stderr,
          "newton-det: %d of %d points below the reference; sum %.6g vs %.6g (%+.2f%%); "
          "%d points have a solution reached from under 30 %% of T1; mean K %.3f\n",
          det_low, n_points, det, ref, 100 * (det / ref - 1), small_basin,
          t.newton_trials / (double)t.newton_estimates);
  bbc__caustics_thread_free(&t);
  free(r);
  teardown(&f);
}

TEST(stoch_estimator_converges) {
  estimator_converges(TEST_SCENE("glass-sphere.gltf"), 4, 12, 32, 1);
}

/* The same on the research set-ups and with more points, in the full run only. */
TEST(stoch_estimator_converges_research_scenes) {
  if (!harness_scale(0, 1)) SKIP("a full-run measurement: set BBC_TEST_FULL=1");
  estimator_converges(TEST_SCENE("glass-sphere.gltf"), 8, 48, 48, 1);
  estimator_converges(TEST_SCENE("ball320.gltf"), 8, 48, 48, 0);
  estimator_converges(TEST_SCENE("slab10k.gltf"), 3, 24, 32, 0);
}

/* Caustic-only renders, in the full run (minutes): newton-stoch and newton-det
 * against an enumerate newton-stoch reference of many samples. Each image also carries
 * pixel-sampling noise, heavy-tailed where the caustic is singular (its folds and
 * focus), so newton-det's bias is measured where that noise cancels: against
 * newton-stoch with the same seed, whose camera samples are the very same (the starts'
 * random streams are separate), the difference being the solutions the centre start
 * misses. bbc sampling (two tuples expected per point) is reported too; the traced
 * bounds are not conservative near the folds, so it shows fireflies there. A measurement
 * more than a test: it checks only that the images exist. */
static void converges(const char *path, int trace_n, uint32_t w, uint32_t h, uint32_t ref_spp) {
  fixture f;
  REQUIRE(load(&f, path));
  REQUIRE(cache_traced(&f, trace_n, 0.01, 128));
  bbc_render_stats stats;
  bbc_image *reference =
      render(&f, BBC_METHOD_ENUMERATE, BBC_SOLVER_NEWTON_STOCH, ref_spp, 1000, 0, w, h, &stats);
  REQUIRE(reference);
  double ref_mean = mean_of(reference);
  fprintf(stderr,
          "%s, %ux%u: reference enumerate newton-stoch %u spp, %.1f s; mean %.6g; mean |U| "
          "%.1f; %.3g Newton runs per lookup, %.1f%% converged, mean K %.4f, %llu capped\n",
          path, w, h, ref_spp, stats.seconds, ref_mean, stats.candidates / (double)stats.lookups,
          stats.newton_solves / (double)stats.lookups,
          100.0 * stats.newton_converged / stats.newton_solves,
          stats.newton_trials / (double)stats.newton_estimates,
          (unsigned long long)stats.newton_cap_hits);
  fprintf(stderr,
          "  relMSE (eps 1e-2) against it, and in brackets without the worst 0.1 %% of "
          "pixels:\n");
  const uint32_t spps[3] = {4, 16, 64};
  for (int k = 0; k < 3; k++) {
    bbc_render_stats ds;
    bbc_image *image =
        render(&f, BBC_METHOD_ENUMERATE, BBC_SOLVER_NEWTON_STOCH, spps[k], 7 + k, 0, w, h, &stats);
    bbc_image *det =
        render(&f, BBC_METHOD_ENUMERATE, BBC_SOLVER_NEWTON_DET, spps[k], 7 + k, 0, w, h, &ds);
    REQUIRE(image && det);
    double e[2], d[2];
    for (int r = 0; r < 2; r++) {
      bbc_image_relmse(image, reference, 1e-2, r ? 1e-3 : 0, &e[r]);
      bbc_image_relmse(det, reference, 1e-2, r ? 1e-3 : 0, &d[r]);
    }
    fprintf(stderr,
            "  %2u spp enumerate: newton-stoch %.4g [%.4g] mean %+.2f%% %.1f s | newton-det "
            "%.4g [%.4g] mean %+.2f%% %.1f s | det / stoch, same camera samples, %+.2f%%\n",
            spps[k], e[0], e[1], 100 * (mean_of(image) / ref_mean - 1), stats.seconds, d[0], d[1],
            100 * (mean_of(det) / ref_mean - 1), ds.seconds,
            100 * (mean_of(det) / mean_of(image) - 1));
    bbc_image_free(image);
    bbc_image_free(det);
  }
  for (int k = 0; k < 3; k++) {
    bbc_image *image =
        render(&f, BBC_METHOD_BBC, BBC_SOLVER_NEWTON_STOCH, spps[k], 7 + k, 0, w, h, &stats);
    REQUIRE(image);
    double e[2];
    for (int r = 0; r < 2; r++) bbc_image_relmse(image, reference, 1e-2, r ? 1e-3 : 0, &e[r]);
    fprintf(stderr,
            "  %2u spp bbc (W = 2, |S| %.2f): newton-stoch %.4g [%.4g] mean %+.2f%% %.1f s\n",
            spps[k], stats.sampled / (double)stats.lookups, e[0], e[1],
            100 * (mean_of(image) / ref_mean - 1), stats.seconds);
    bbc_image_free(image);
  }
  bbc_image_free(reference);
  teardown(&f);
}

TEST(render_convergence_measurement) {
  if (!harness_scale(0, 1)) SKIP("a full-run measurement: set BBC_TEST_FULL=1");
  converges(TEST_SCENE("glass-sphere.gltf"), 16, 128, 96, 1024);
  converges(TEST_SCENE("ball320.gltf"), 16, 128, 96, 1024);
  converges(TEST_SCENE("slab10k.gltf"), 3, 96, 72, 256);
}
