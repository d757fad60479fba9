/* The caustic estimator: cell lookup, tuple sampling, the solver inside each sampled
 * tuple, and each solution's visibility, Fresnel, tint, absorption and irradiance divided
 * by the tuple's probability (Eq. 24). The probability comes from the irradiance bounds
 * alone: Fresnel, tint and absorption, all at most 1, are left out of it.
 *
 * Single scattering (R, T) is solved by the specular polynomials, which return every
 * solution. Double scattering (RR, RT, TR, TT) is solved by Newton's method on the chain
 * (DESIGN 3.10), in one of two ways (bbc_solver_method):
 *   - deterministic: one run from T1's centre; the value of the solution it reaches, if
 *     any. No variance, but solutions the centre does not lead to are missed (bias).
 *   - stochastic: one run from a start u1 drawn uniformly on T1. It reaches solution s
 *     with some probability p_s (the share of T1 in s's basin of attraction, clamping
 *     included). Its value is then multiplied by K, the number of further independent
 *     uniform starts drawn until one reaches s again: K is geometric with mean 1 / p_s,
 *     so E[value x K] = sum over s of p_s f(s) / p_s = sum over s of f(s), the sum over
 *     every solution some start reaches (specular manifold sampling's reciprocal
 *     probability estimate, Zeltner et al. 2020, Sec. 4.3). The expected cost is one
 *     run plus, per solution, p_s x 1 / p_s = 1 run: bounded by the number of
 *     solutions. K is capped (bbc_render_options.newton_max_trials); a capped estimate
 *     is biased low and counted in the stats. A solution of value 0 (occluded, on the
 *     wrong side) needs no K.
 * Random starts come from a stream keyed by the shading point's key (from the path's
 * seed, pixel, sample and depth) and the tuple id: the image
 * stays a pure function of the seed, whatever thread rendered what, and the variable
 * number of draws of K does not shift the path's later random numbers. */
#include "caustics_internal.h"
#include "light_internal.h"
#include "light_trace_internal.h"
#include "media_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "bbc/texture.h"
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

/* The unit geometric normal of a scene triangle, and its vertex 0. */
static bbc_vec3 geometric_normal(const bbc_scene *scene, uint32_t t, bbc_vec3 *p0) {
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  bbc_vec3 a = v3_load(scene->positions + 3 * (size_t)idx[0]);
  bbc_vec3 b = v3_load(scene->positions + 3 * (size_t)idx[1]);
  bbc_vec3 c = v3_load(scene->positions + 3 * (size_t)idx[2]);
  if (p0) *p0 = a;
  return v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

/* 1 if point q lies in front of scene triangle t's geometric plane, the front being
 * the side its vertex normals point to (the orientation the bounds use, bounds.h). */
static int in_front_of(const bbc_scene *scene, uint32_t t, bbc_vec3 q) {
  bbc_vec3 p0;
  bbc_vec3 ng = geometric_normal(scene, t, &p0);
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  bbc_vec3 nsum = v3(0, 0, 0);
  for (int j = 0; j < 3; j++) nsum = v3_add(nsum, v3_load(scene->normals + 3 * (size_t)idx[j]));
  return (v3_dot(ng, q) - v3_dot(ng, p0)) * (v3_dot(ng, nsum) >= 0 ? 1 : -1) > 0;
}

/* Multiplies factor by the transmittance of the segment from a to b inside medium. */
static void absorb(const bbc_scene *scene, uint32_t medium, bbc_vec3 a, bbc_vec3 b,
                   double factor[3]) {
  if (!medium) return;
  double t[3];
  bbc__media_transmittance(scene, medium, v3_length(v3_sub(b, a)), t);
  for (int k = 0; k < 3; k++) factor[k] *= t[k];
}

/* 1 if the segment from a (on the surface with unit geometric normal na) to b (on the
 * surface with normal nb) is unoccluded. Both ends are pushed off their surfaces toward
 * the segment, as the path tracer's rays are. */
static int segment_visible(const bbc__caustics *c, bbc_vec3 a, bbc_vec3 na, bbc_vec3 b, bbc_vec3 nb,
                           uint32_t medium) {
  bbc_vec3 d = v3_sub(b, a);
  bbc_vec3 origin = v3_offset_origin(a, na, d);
  bbc_vec3 target = v3_offset_origin(b, nb, v3_neg(d));
  return bbc__media_clear(c->scene, c->accel, c->passable, origin, v3_sub(target, origin),
                          1.0 - 1e-6, medium, 0);
}

/* See bbc__caustics_solution_value; returns 0 for an inadmissible or invisible path
 * (out is then zero), 1 otherwise. */
static int solution_value(const bbc__caustics *c, const bbc__receiver_shading *shading,
                          const bbc_tuple *tuple, const bbc_path_geometry *g,
                          const bbc_solution *s, bbc_vec3 p, bbc_vec3 ng, bbc_vec3 *out) {
  const bbc_scene *scene = c->scene;
  *out = v3(0, 0, 0);
  if (!(s->irradiance > 0) || !isfinite(s->irradiance)) return 0;
  /* An area light is the point light at the emitter point g->light (in air) with the
   * emitter's radiance, the value times A_e cos(theta_e) (docs/lights.md). */
  bbc_point_light area_light;
  const bbc_point_light *light = &area_light;
  double weight = 1.0;
  const int area = g->light_model.kind == BBC_LIGHT_AREA;
  if (area) {
    memset(&area_light, 0, sizeof area_light);
    area_light.position = g->light;
    area_light.model = g->light_model;
    bbc__area_radiance(scene, tuple->light, g->light, area_light.intensity);
    weight = bbc__area_weight(&g->light_model, g->light, s->x1);
    /* An emitter point in a cut-out emits nothing (bbc_scene_coverage). */
    double b[2];
    if (weight > 0 && bbc_triangle_barycentrics(g->light_model.emitter, g->light, b))
      weight *= bbc_scene_coverage(scene, scene->emitters[tuple->light - scene->point_light_count],
                                   b[0], b[1]);
    if (!(weight > 0)) return 0;
  } else {
    light = &scene->point_lights[tuple->light];
  }
  const int length = g->length;
  /* The path's vertices: x[0] the light, x[1..length] the specular ones, then p. */
  const int sun = light->model.kind == BBC_LIGHT_DIRECTIONAL;
  /* A sun stands at x1 - D for the side tests below (light_internal.h). */
  bbc_vec3 x[4] = {bbc__light_source(light->position, &light->model, s->x1), s->x1, s->x2, s->x2};
  x[length + 1] = p;
  /* The light must reach the receiver on the side being shaded. */
  if (v3_dot(v3_sub(p, x[length]), ng) >= 0) return 0;
  double factor[3] = {1, 1, 1};
  bbc_vec3 ngeo[2];
  uint32_t medium = light->medium;
  uint32_t segment_medium[3] = {medium, medium, medium}; /* of x[i] -> x[i + 1] */
  /* Beer-Lambert absorption along each segment inside a dielectric, starting with the
   * light's own medium (air for suns and emitters). */
  absorb(scene, medium, x[0], x[1], factor);
  for (int i = 0; i < length; i++) {
    const uint32_t tri = tuple->specular[i];
    /* A specular vertex in a cut-out is no vertex: the path does not exist. Partial
     * coverage (BLEND) scales it, the expectation of the path tracer's coin flip. */
    const double *u = i == 0 ? s->u1 : s->u2;
    const double cover = bbc_scene_coverage(scene, tri, u[0], u[1]);
    if (!(cover > 0)) return 0;
    for (int k = 0; k < 3; k++) factor[k] *= cover;
    ngeo[i] = geometric_normal(scene, tri, NULL);
    if (g->specular[i].refract) {
      /* Side consistency: the bounds orient a refraction by the side of the triangle's
       * geometric plane its light comes from (the light itself for T1, T1's centroid for
       * T2; bounds.h, specular_path.h). A path whose shading normal says the ray arrives
       * from the other side is outside the bounded set: skipped (a documented
       * limitation, which only bites where shading and geometric normals disagree). */
      bbc_vec3 source = area ? bbc__area_centroid(&light->model)
                             : bbc__light_source(light->position, &light->model, g->specular[0].p[0]);
      if (i == 1) {
        const bbc_specular_triangle *t1 = &g->specular[0];
        source = v3_scale(v3_add(t1->p[0], v3_add(t1->p[1], t1->p[2])), 1.0 / 3.0);
      }
      int source_in_front = in_front_of(scene, tri, source);
      bbc_vec3 n = i == 0 ? s->path.n1 : s->path.n2;
      double dn = v3_dot(v3_normalize(v3_sub(x[i + 1], x[i])), n);
      if ((dn < 0) != source_in_front) return 0;
      /* The medium rule (media_internal.h), for the point the light comes from. */
      if (!bbc__media_refract(scene, medium, tri, bbc__media_side(scene, tri, x[i]), &medium))
        return 0;
      double eta = bbc__media_eta(scene, tri, dn < 0 ? 1 : -1);
      double f = c->no_fresnel ? 0.0 : fresnel(fabs(dn), eta);
      /* Transmitted light is tinted by the base colour at every refraction. */
      double tint[3];
      bbc__media_tint(scene, tri, u[0], u[1], tint);
      for (int k = 0; k < 3; k++) factor[k] *= (1.0 - f) * tint[k];
    } else {
      double reflectance[3];
      bbc_scene_base_color(scene, tri, u[0], u[1], reflectance);
      for (int k = 0; k < 3; k++) factor[k] *= reflectance[k];
    }
    absorb(scene, medium, x[i + 1], x[i + 2], factor);
    segment_medium[i + 1] = medium;
  }
  /* Visibility of every segment: light -> x1 (traced from the light, which needs no
   * offset), x1 -> x2, x_last -> p. */
  bbc_vec3 x1_light_side = v3_offset_origin(x[1], ngeo[0], v3_sub(x[0], x[1]));
  if (sun) {
    /* The sun's light comes from infinity: nothing may lie on the ray from x1 back
     * against its direction. */
    if (!bbc__media_clear(c->scene, c->accel, c->passable, x1_light_side,
                          v3_neg(light->model.direction), INFINITY, segment_medium[0], 1))
      return 0;
  } else if (area) {
    /* From the emitter point, pushed off the emitter toward x1. */
    bbc_vec3 ne = v3_normalize(light->model.emitter_normal);
    bbc_vec3 y = v3_offset_origin(x[0], ne, v3_sub(x[1], x[0]));
    if (!bbc__media_clear(c->scene, c->accel, c->passable, y, v3_sub(x1_light_side, y), 1.0 - 1e-6,
                          segment_medium[0], 0))
      return 0;
  } else if (!bbc__media_clear(c->scene, c->accel, c->passable, x[0], v3_sub(x1_light_side, x[0]),
                               1.0 - 1e-6, segment_medium[0], 0)) {
    return 0;
  }
  for (int i = 1; i <= length; i++) {
    bbc_vec3 nb = i < length ? ngeo[i] : ng;
    if (!segment_visible(c, x[i], ngeo[i - 1], x[i + 1], nb, segment_medium[i])) return 0;
  }
  for (int k = 0; k < 3; k++) factor[k] *= light->intensity[k] * s->irradiance * weight;
  if (shading) {
    /* A glossy receiver: the BSDF for this solution's light direction. */
    double f[3];
    bbc_bsdf_eval(shading->bsdf, shading->n, shading->wo, v3_normalize(v3_sub(x[length], p)), f);
    for (int k = 0; k < 3; k++) factor[k] *= f[k];
  }
  *out = v3(factor[0], factor[1], factor[2]);
  return 1;
}

int bbc__caustics_area_covers(const bbc__caustics *c, uint32_t receiver, int length,
                              const uint32_t tri[2], const int letter[2], uint32_t emitter,
                              bbc_vec3 y, const bbc_vec3 x[2], const bbc_vec3 n[2]) {
  if (!c || !c->area_lights || length < 1 || length > 2 || (length == 2 && !c->area_double))
    return 0;
  const bbc_scene *scene = c->scene;
  for (int i = 0; i < length; i++) {
    if (letter[i] < 0) return 0;
    const bbc_mesh *mesh = &scene->meshes[scene->triangle_mesh[tri[i]]];
    const bbc_material *m = &scene->materials[mesh->material];
    if (mesh->role != BBC_ROLE_CASTER ||
        m->type != (letter[i] ? BBC_MATERIAL_DIELECTRIC : BBC_MATERIAL_MIRROR))
      return 0;
  }
  if (length == 2 && tri[0] == tri[1]) return 0; /* no tuple has T1 = T2 */
  const bbc_chain chain = length == 1 ? (letter[0] ? BBC_CHAIN_T : BBC_CHAIN_R)
                          : letter[0] ? (letter[1] ? BBC_CHAIN_TT : BBC_CHAIN_TR)
                                      : (letter[1] ? BBC_CHAIN_RT : BBC_CHAIN_RR);
  /* Rendered, and computed for the cache (a chain type the cache lacks stays with path
   * tracing). */
  if (!(c->chains & c->cache_chains & (1u << chain))) return 0;
  if (scene->meshes[scene->triangle_mesh[receiver]].role != BBC_ROLE_RECEIVER) return 0;
  const uint32_t t1 = tri[0];
  const bbc_vec3 x1 = x[0], n1 = n[0];
  /* The emitter's index (scene->emitters is in increasing triangle order). */
  uint32_t lo = 0, hi = scene->emitter_count;
  while (lo < hi) {
    uint32_t mid = lo + (hi - lo) / 2;
    if (scene->emitters[mid] < emitter) lo = mid + 1;
    else hi = mid;
  }
  if (lo == scene->emitter_count || scene->emitters[lo] != emitter) return 0;
  bbc_light_model model;
  bbc_scene_area_light(scene, lo, &model, NULL);
  /* The side: T1's normals turned toward the emitter's centroid (bounds.h), and the
   * light must arrive against them. */
  const bbc_vec3 centroid = bbc__area_centroid(&model);
  const int toward = in_front_of(scene, t1, centroid) ? 1 : -1;
  if (toward * v3_dot(v3_sub(x1, y), n1) >= 0) return 0;
  uint32_t medium = 0; /* an emitter is in air (docs/lights.md) */
  if (letter[0]) {
    if (!bbc__media_refract(scene, 0, t1, bbc__media_side(scene, t1, centroid), &medium) ||
        !bbc__media_refract(scene, 0, t1, bbc__media_side(scene, t1, y), &medium))
      return 0;
  }
  if (length == 2) {
    /* T2: its normals turned toward T1's centroid (bounds.h), the light arriving against
     * them, and the medium rule from x1 (solution_value's tests of the same path). */
    const uint32_t t2 = tri[1];
    const uint32_t *v = scene->indices + 3 * (size_t)t1;
    bbc_vec3 p[3];
    for (int j = 0; j < 3; j++) p[j] = v3_load(scene->positions + 3 * (size_t)v[j]);
    /* The same expression as solution_value's, so that both decide alike. */
    const bbc_vec3 c1 = v3_scale(v3_add(p[0], v3_add(p[1], p[2])), 1.0 / 3.0);
    const int toward2 = in_front_of(scene, t2, c1) ? 1 : -1;
    if (toward2 * v3_dot(v3_sub(x[1], x1), n[1]) >= 0) return 0;
    uint32_t after;
    if (letter[1] && !bbc__media_refract(scene, medium, t2, bbc__media_side(scene, t2, x1), &after))
      return 0;
  }
  return 1;
}

int bbc__caustics_sun_covers(const bbc__caustics *c, uint32_t light, uint32_t receiver, int count,
                             const uint32_t triangle[2], const int letter[2], const bbc_vec3 x[2],
                             const bbc_vec3 n[2], bbc_vec3 w) {
  if (!c || count < 1 || count > 2) return 0;
  const bbc_scene *scene = c->scene;
  if (light >= scene->point_light_count) return 0;
  const bbc_light_model *model = &scene->point_lights[light].model;
  if (model->kind != BBC_LIGHT_DIRECTIONAL) return 0;
  /* Light order: vertex k of the chain is the camera path's vertex count - 1 - k. */
  uint32_t tri[2];
  int let[2];
  bbc_vec3 pos[2], nrm[2];
  for (int k = 0; k < count; k++) {
    const int i = count - 1 - k;
    if (letter[i] < 0) return 0;
    tri[k] = triangle[i], let[k] = letter[i], pos[k] = x[i], nrm[k] = n[i];
  }
  const bbc_chain chain = count == 1 ? (bbc_chain)let[0] : (bbc_chain)(2 + (let[0] << 1) + let[1]);
  if (!(c->chains & c->cache_chains & (1u << chain))) return 0;
  if (scene->meshes[scene->triangle_mesh[receiver]].role != BBC_ROLE_RECEIVER) return 0;
  uint32_t medium = scene->point_lights[light].medium;
  for (int k = 0; k < count; k++) {
    const bbc_mesh *mesh = &scene->meshes[scene->triangle_mesh[tri[k]]];
    const bbc_material *m = &scene->materials[mesh->material];
    if (mesh->role != BBC_ROLE_CASTER ||
        m->type != (let[k] ? BBC_MATERIAL_DIELECTRIC : BBC_MATERIAL_MIRROR))
      return 0;
    if (!let[k]) continue;
    /* The estimator's rules for a refraction (solution_value): the side the bounds assume
     * the light comes from (the sun's centre direction for T1, T1's centroid for T2) must
     * be the side the shading normal says it arrives from, and the medium rule must let
     * it through. */
    bbc_vec3 from = k == 0 ? v3_add(pos[0], w) : pos[0];
    bbc_vec3 source = bbc__light_source(v3(0, 0, 0), model, pos[0]);
    if (k == 1) {
      const uint32_t *idx = scene->indices + 3 * (size_t)tri[0];
      source = v3_scale(v3_add(v3_load(scene->positions + 3 * (size_t)idx[0]),
                               v3_add(v3_load(scene->positions + 3 * (size_t)idx[1]),
                                      v3_load(scene->positions + 3 * (size_t)idx[2]))),
                        1.0 / 3.0);
    }
    double dn = v3_dot(v3_normalize(v3_sub(pos[k], from)), nrm[k]);
    if ((dn < 0) != in_front_of(scene, tri[k], source)) return 0;
    if (!bbc__media_refract(scene, medium, tri[k], bbc__media_side(scene, tri[k], from), &medium))
      return 0;
  }
  return 1;
}

bbc_vec3 bbc__caustics_solution_value(const bbc__caustics *c, const bbc_tuple *tuple,
                                      const bbc_path_geometry *g, const bbc_solution *s, bbc_vec3 p,
                                      bbc_vec3 ng) {
  bbc_vec3 v;
  solution_value(c, NULL, tuple, g, s, p, ng, &v);
  return v;
}

/* A start drawn uniformly on T1 (barycentrics, the unit triangle folded onto itself). */
static void uniform_start(bbc_rng *rng, double u1[2]) {
  double a = bbc_rng_next(rng), b = bbc_rng_next(rng);
  if (a + b > 1) a = 1 - a, b = 1 - b;
  u1[0] = a, u1[1] = b;
}

/* One Newton run from u1 on a double-scattering chain, counted. */
static int newton_run(bbc__caustics_thread *t, const bbc_path_geometry *g, bbc_vec3 p,
                      const double u1[2], bbc_solution *s) {
  int found = 0;
  t->newton_solves++;
  if (bbc_solver_newton(g, p, u1, NULL, s, &found) != BBC_OK) found = 0;
  if (found) t->newton_converged++;
  return found;
}

/* The contribution of a double-scattering tuple (see the top of the file). */
static bbc_vec3 double_contribution(const bbc__caustics *c, bbc__caustics_thread *t,
                                    const bbc_tuple *tuple, const bbc_path_geometry *g, bbc_vec3 p,
                                    bbc_vec3 ng, uint64_t key) {
  bbc_vec3 value = v3(0, 0, 0);
  bbc_solution s;
  if (c->solver == BBC_SOLVER_NEWTON_DET) {
    static const double centre[2] = {1.0 / 3.0, 1.0 / 3.0};
    if (newton_run(t, g, p, centre, &s) &&
        solution_value(c, t->shading, tuple, g, &s, p, ng, &value))
      t->solutions++;
    return value;
  }
  bbc_rng rng = {key, 0};
  double u1[2];
  uniform_start(&rng, u1);
  if (!newton_run(t, g, p, u1, &s) || !solution_value(c, t->shading, tuple, g, &s, p, ng, &value))
    return value;
  t->solutions++;
  if (value.x == 0 && value.y == 0 && value.z == 0) return value;
  /* K: further starts until one reaches s again. */
  const uint32_t cap = c->newton_max_trials ? c->newton_max_trials : BBC_NEWTON_MAX_TRIALS_DEFAULT;
  uint32_t k = 0;
  int again = 0;
  while (!again && k < cap) {
    k++;
    bbc_solution trial;
    uniform_start(&rng, u1);
    again = newton_run(t, g, p, u1, &trial) &&
            fabs(trial.u1[0] - s.u1[0]) <= BBC__NEWTON_SAME_SOLUTION &&
            fabs(trial.u1[1] - s.u1[1]) <= BBC__NEWTON_SAME_SOLUTION;
  }
  t->newton_estimates++;
  t->newton_trials += k;
  if (!again) t->newton_cap_hits++;
  return v3_scale(value, (double)k);
}

bbc_vec3 bbc__caustics_tuple(const bbc__caustics *c, bbc__caustics_thread *t,
                             const bbc_tuple *tuple, bbc_vec3 p, bbc_vec3 ng, uint64_t key) {
  bbc_vec3 sum = v3(0, 0, 0);
  bbc_path_geometry g;
  if (bbc_path_geometry_init(&g, c->scene, tuple) != BBC_OK) return sum;
  if (g.light_model.kind == BBC_LIGHT_AREA) {
    /* One emitter point, uniform by area (scene.h's map with a = sqrt r1, b = r2), from
     * the tuple's own stream: the bound sampled the tuple for A_e times the most any
     * point gives, so the estimate is the point's value over its density 1 / A_e. The
     * stream is not the one of double scattering's Newton starts (keyed by `key`
     * itself), so the point and the starts are independent; the starts' estimate is
     * then unbiased for the sum over the solutions from this point, and the point's
     * average is the integral over the emitter. */
    bbc_rng rng = {bbc__mix64(key ^ 0x5A4E3C2B1A09F8E7ull), 0};
    double r1 = bbc_rng_next(&rng), r2 = bbc_rng_next(&rng);
    g.light = bbc__area_point(&g.light_model, sqrt(r1), r2);
  }
  if (g.length == 2) return double_contribution(c, t, tuple, &g, p, ng, key);
  /* The solver runs the pre-test (bbc_solver_single_possible) first; its count of the
   * tuples it excluded is the stats'. */
  bbc_solver_stats stats;
  memset(&stats, 0, sizeof stats);
  bbc_solver_options options;
  memset(&options, 0, sizeof options);
  options.stats = &stats;
  bbc_solution solutions[BBC_SOLVER_MAX_SOLUTIONS];
  size_t count = 0;
  bbc_result solved = bbc_solver_single(&g, p, &options, solutions, BBC_SOLVER_MAX_SOLUTIONS, &count);
  t->excluded += stats.excluded;
  if (solved != BBC_OK) return sum;
  for (size_t i = 0; i < count; i++) {
    bbc_vec3 v;
    if (!solution_value(c, t->shading, tuple, &g, &solutions[i], p, ng, &v)) continue;
    t->solutions++;
    sum = v3_add(sum, v);
  }
  return sum;
}

typedef struct estimate_state {
  const bbc__caustics *c;
  bbc__caustics_thread *t;
  bbc_vec3 p, ng;
  uint64_t key; /* this shading point's key for the tuples' random streams */
  uint32_t triangle; /* the shading point's */
  bbc_vec3 sum;
} estimate_state;

/* Alg. 1, line 6: the contribution of every solution of the tuple, over its P. */
static void on_chosen(void *user, uint32_t tuple, double p) {
  estimate_state *s = user;
  uint64_t key = bbc__mix64(s->key ^ bbc__mix64(tuple + 0xA0761D6478BD642Full));
  /* A beam tuple ends on the triangle of the shading point: the solver measures the
   * irradiance on that triangle's plane. */
  bbc_tuple ended = s->c->tuples[tuple];
  if (bbc_receiver_is_beam(ended.receiver)) ended.receiver = s->triangle;
  bbc_vec3 e = bbc__caustics_tuple(s->c, s->t, &ended, s->p, s->ng, key);
  s->sum = v3_add(s->sum, v3_scale(e, 1.0 / p));
}

/* The time shares (bbc_render_stats) are measured on every TIMING_STRIDE-th lookup of a
 * thread and scaled by it: reading the clock four times per lookup cost 2-4 % of a
 * render. */
#define TIMING_STRIDE 8
static double clock_if(int timed) {
  return timed ? omp_get_wtime() : 0.0;
}

bbc_vec3 bbc__caustics_estimate(const bbc__caustics *c, bbc__caustics_thread *t, bbc_vec3 p,
                                bbc_vec3 ng, uint32_t triangle, double b1, double b2,
                                int max_vertices, uint64_t key,
                                const bbc__bin_uniforms *bin_u) {
  bbc_vec3 sum = v3(0, 0, 0);
  if (max_vertices < 1 || t->damage != BBC_OK) return sum;
  const int timed = t->timing_tick++ % TIMING_STRIDE == 0;
  double t0 = clock_if(timed);
  const bbc_cache_entry *entries = NULL;
  uint32_t n = 0;
  bbc_result looked = bbc_cache_lookup(t->cursor, triangle, b1, b2, &p, &entries, &n);
  if (looked != BBC_OK || n == 0) {
    t->damage = looked;
    t->decoding_seconds += TIMING_STRIDE * (clock_if(timed) - t0);
    return sum;
  }
  double t1 = clock_if(timed);
  t->decoding_seconds += TIMING_STRIDE * (t1 - t0);
  t->lookups++;
  /* U: the cell's tuples that end on this very triangle, on its plane or, for a
   * triangle not on a plane, on a beam (a cell may span several receivers' triangles),
   * of the chain types asked for and short enough for the depth limit. */
  const uint32_t mesh = c->scene->triangle_mesh[triangle];
  const uint32_t plane = BBC_RECEIVER_PLANE(mesh);
  const uint32_t beam = c->scene->meshes[mesh].plane ? plane : BBC_RECEIVER_BEAM;
  if (n > t->candidate_capacity) {
    uint32_t capacity = t->candidate_capacity ? t->candidate_capacity : 64;
    while (capacity < n) capacity *= 2;
    bbc_cache_entry *grown = realloc(t->candidates, capacity * sizeof *grown);
    if (!grown) return sum;
    t->candidates = grown;
    t->candidate_capacity = capacity;
  }
  /* The chain types light tracing counts here, from the lights it handles
   * (docs/light-tracing.md). */
  const uint32_t traced = t->seen_directly ? bbc__light_traced_chains(c, entries, n, triangle) : 0;
  uint32_t m = 0;
  for (uint32_t i = 0; i < n; i++) {
    const bbc_tuple *tuple = &c->tuples[entries[i].tuple];
    if ((tuple->receiver == triangle || tuple->receiver == plane || tuple->receiver == beam) &&
        (c->chains & (1u << tuple->chain)) &&
        bbc_chain_length((bbc_chain)tuple->chain) <= max_vertices &&
        !((traced & (1u << tuple->chain)) && bbc__light_traced_light(c->scene, tuple->light))) {
      t->candidates[m] = entries[i];
      if (tuple->specular[1] != BBC_NO_TRIANGLE && c->double_weight > 0)
        t->candidates[m].bound *= c->double_weight;
      m++;
    }
  }
  t->candidate_count += m;
  /* Each chosen tuple is solved as it is drawn: no list, no limit on |S|. The clock is
   * read once per lookup, not per tuple: drawing (one uniform and a bisection per bin)
   * counts as solving. */
  estimate_state state = {c, t, p, ng, key, triangle, v3(0, 0, 0)};
  uint32_t drawn = 0;
  if (m > 0 && bbc__sampler_prepare(&t->sampler, t->candidates, m, &c->sampling)) {
    double t2 = clock_if(timed);
    t->sampling_seconds += TIMING_STRIDE * (t2 - t1);
    t->bins += t->sampler.one_sample ? 1 : t->sampler.bins;
    bbc_rng rng = {key, 0};
    drawn = bbc__sampler_draw(&t->sampler, bin_u, &rng, on_chosen, &state);
    t->solving_seconds += TIMING_STRIDE * (clock_if(timed) - t2);
  } else {
    t->sampling_seconds += TIMING_STRIDE * (clock_if(timed) - t1);
  }
  t->sampled += drawn;
  return state.sum;
}
