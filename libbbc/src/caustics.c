/* The caustic estimator: cell lookup, tuple sampling, the specular-polynomial solver
 * inside each sampled tuple, and each solution's visibility, Fresnel and irradiance
 * divided by the tuple's probability (Eq. 24). */
#include "caustics_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "bbc/solver.h"
#include "vec_internal.h"

bbc_result bbc__caustics_thread_init(bbc__caustics_thread *t, const bbc_cache *cache) {
  memset(t, 0, sizeof *t);
  return bbc_cache_cursor_create(&t->cursor, cache);
}

void bbc__caustics_thread_free(bbc__caustics_thread *t) {
  if (!t) return;
  bbc_cache_cursor_free(t->cursor);
  bbc__sampler_free(&t->sampler);
  free(t->candidates);
  memset(t, 0, sizeof *t);
}

/* Fresnel reflectance of a smooth dielectric for unpolarised light. */
static double fresnel(double cos_i, double eta) {
  double sin2_t = eta * eta * (1 - cos_i * cos_i);
  if (sin2_t >= 1) return 1;
  double cos_t = sqrt(1 - sin2_t);
  double rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  double rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

/* The unit geometric normal of a scene triangle. */
static bbc_vec3 geometric_normal(const bbc_scene *scene, uint32_t t, bbc_vec3 *p0) {
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  bbc_vec3 a = v3_load(scene->positions + 3 * (size_t)idx[0]);
  bbc_vec3 b = v3_load(scene->positions + 3 * (size_t)idx[1]);
  bbc_vec3 c = v3_load(scene->positions + 3 * (size_t)idx[2]);
  if (p0) *p0 = a;
  return v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

/* The contribution of one sampled single-scattering tuple at p. */
static bbc_vec3 tuple_contribution(const bbc__caustics *c, bbc__caustics_thread *t,
                                   const bbc_tuple *tuple, bbc_vec3 p, bbc_vec3 ng) {
  const bbc_scene *scene = c->scene;
  bbc_vec3 sum = v3(0, 0, 0);
  bbc_path_geometry g;
  if (bbc_path_geometry_init(&g, scene, tuple) != BBC_OK || g.length != 1) return sum;
  bbc_solution solutions[BBC_SOLVER_MAX_SOLUTIONS];
  size_t count = 0;
  if (bbc_solver_single(&g, p, NULL, solutions, BBC_SOLVER_MAX_SOLUTIONS, &count) != BBC_OK)
    return sum;
  const bbc_point_light *light = &scene->point_lights[tuple->light];
  const uint32_t t1 = tuple->specular[0];
  const bbc_material *m = bbc_scene_triangle_material(scene, t1);
  bbc_vec3 p0;
  bbc_vec3 n1g = geometric_normal(scene, t1, &p0);
  /* The side of T1 the light is on, as the bounds define it (bounds.h): a refraction
   * whose shading normal says otherwise is outside the bounded set of paths. */
  const uint32_t *idx = scene->indices + 3 * (size_t)t1;
  bbc_vec3 nsum = v3(0, 0, 0);
  for (int j = 0; j < 3; j++) nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[j]));
  int light_in_front =
      (v3_dot(n1g, light->position) - v3_dot(n1g, p0)) * (v3_dot(n1g, nsum) >= 0 ? 1 : -1) > 0;
  for (size_t i = 0; i < count; i++) {
    const bbc_solution *s = &solutions[i];
    if (!(s->irradiance > 0) || !isfinite(s->irradiance)) continue;
    bbc_vec3 d0 = v3_sub(s->x1, light->position);
    bbc_vec3 d1 = v3_sub(p, s->x1);
    /* The light must reach the receiver on the side being shaded. */
    if (v3_dot(d1, ng) >= 0) continue;
    double factor[3] = {1, 1, 1};
    if (tuple->chain == BBC_CHAIN_T) {
      double dn = v3_dot(v3_normalize(d0), s->path.n1);
      if ((dn < 0) != light_in_front) continue;
      double eta = dn < 0 ? 1.0 / m->ior : m->ior;
      double f = c->no_fresnel ? 0.0 : fresnel(fabs(dn), eta);
      factor[0] = factor[1] = factor[2] = 1.0 - f;
    } else {
      for (int k = 0; k < 3; k++) factor[k] = m->base_color[k];
    }
    /* Visibility of both segments. */
    bbc_vec3 x1_light_side = v3_offset_origin(s->x1, n1g, v3_neg(d0));
    if (bbc_accel_occluded(c->accel, light->position, v3_sub(x1_light_side, light->position), 0.0,
                           1.0 - 1e-6))
      continue;
    bbc_vec3 origin = v3_offset_origin(s->x1, n1g, d1);
    bbc_vec3 target = v3_offset_origin(p, ng, v3_neg(d1));
    if (bbc_accel_occluded(c->accel, origin, v3_sub(target, origin), 0.0, 1.0 - 1e-6)) continue;
    t->solutions++;
    for (int k = 0; k < 3; k++) factor[k] *= light->intensity[k] * s->irradiance;
    sum = v3_add(sum, v3(factor[0], factor[1], factor[2]));
  }
  return sum;
}

typedef struct estimate_state {
  const bbc__caustics *c;
  bbc__caustics_thread *t;
  bbc_vec3 p, ng;
  bbc_vec3 sum;
  double solving_seconds;
} estimate_state;

/* Alg. 1, line 6: the contribution of every solution of the tuple, over its P. */
static void on_chosen(void *user, uint32_t tuple, double p) {
  estimate_state *s = user;
  double t0 = omp_get_wtime();
  bbc_vec3 e = tuple_contribution(s->c, s->t, &s->c->tuples[tuple], s->p, s->ng);
  s->sum = v3_add(s->sum, v3_scale(e, 1.0 / p));
  s->solving_seconds += omp_get_wtime() - t0;
}

bbc_vec3 bbc__caustics_estimate(const bbc__caustics *c, bbc__caustics_thread *t, bbc_vec3 p,
                                bbc_vec3 ng, uint32_t triangle, double b1, double b2,
                                bbc_rng *rng) {
  bbc_vec3 sum = v3(0, 0, 0);
  double t0 = omp_get_wtime();
  const bbc_cache_entry *entries = NULL;
  uint32_t n = 0;
  if (bbc_cache_lookup(t->cursor, triangle, b1, b2, &entries, &n) != BBC_OK || n == 0) {
    t->decoding_seconds += omp_get_wtime() - t0;
    return sum;
  }
  double t1 = omp_get_wtime();
  t->decoding_seconds += t1 - t0;
  t->lookups++;
  /* U: the cell's tuples that end on this very triangle (a cell may span several). */
  if (n > t->candidate_capacity) {
    uint32_t capacity = t->candidate_capacity ? t->candidate_capacity : 64;
    while (capacity < n) capacity *= 2;
    bbc_cache_entry *grown = realloc(t->candidates, capacity * sizeof *grown);
    if (!grown) return sum;
    t->candidates = grown;
    t->candidate_capacity = capacity;
  }
  uint32_t m = 0;
  for (uint32_t i = 0; i < n; i++) {
    const bbc_tuple *tuple = &c->tuples[entries[i].tuple];
    if (tuple->receiver == triangle && (c->chains & (1u << tuple->chain)))
      t->candidates[m++] = entries[i];
  }
  t->candidate_count += m;
  /* Each chosen tuple is solved as it is drawn: no list, no limit on |S|. */
  estimate_state state = {c, t, p, ng, v3(0, 0, 0), 0.0};
  uint32_t drawn = 0;
  if (m > 0 && bbc__sampler_prepare(&t->sampler, t->candidates, m, &c->sampling)) {
    t->bins += t->sampler.one_sample ? 1 : t->sampler.bins;
    drawn = bbc__sampler_draw(&t->sampler, rng, on_chosen, &state);
  }
  t->sampled += drawn;
  t->solving_seconds += state.solving_seconds;
  t->sampling_seconds += omp_get_wtime() - t1 - state.solving_seconds;
  sum = state.sum;
  return sum;
}
