/* The path tracer (Kajiya-style, unidirectional) with next-event estimation.
 *
 * Light reaches the camera along three kinds of paths, each counted exactly once:
 * - emitters seen directly or through specular bounces (an emitter hit right after a
 *   camera or specular vertex);
 * - light arriving at a diffuse vertex straight from a light (next-event estimation in
 *   shade_diffuse_vertex; an emitter hit after a diffuse bounce is therefore ignored);
 * - light arriving at a diffuse vertex through specular vertices from an area light
 *   (found by the specular bounces that follow), except, with a cache holding area
 *   lights, the paths the caustic estimator counts (bbc__caustics_area_covers: one
 *   specular vertex, or two with the emitters' double scattering cached, from a
 *   receiver, docs/lights.md). From point lights such caustic paths
 *   cannot be found by path tracing at all: that is the caustic estimator's job, and
 *   shade_diffuse_vertex is where it plugs in.
 * A sun with an angular size (docs/lights.md) is an area light at infinity: next-event
 * estimation samples its disk, and a path that escapes the scene right after a camera or
 * specular vertex within the disk picks up its radiance, the same split as for emissive
 * triangles; with a cache, escapes the estimator counts with the sun's centre direction
 * are skipped (bbc__caustics_sun_covers). A delta sun (angular diameter 0) cannot be hit. */
#include "bbc/bsdf.h"
#include "bbc/render.h"
#include "bbc/texture.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "caustics_internal.h"
#include "light_internal.h"
#include "light_trace_internal.h"
#include "media_internal.h"
#include "rng_internal.h"
#include "sobol_internal.h"
#include "specular_internal.h"
#include "vec_internal.h"

#define BBC_PI 3.14159265358979323846

typedef struct render_ctx {
  const bbc_scene *scene;
  const bbc_accel *accel;
  uint32_t max_depth;
  int no_fresnel;
  uint32_t components;           /* BBC_COMPONENT_* to accumulate */
  const bbc__caustics *caustics; /* NULL: plain path tracing */
  int disk_suns;                 /* some sun has an angular size */
  uint32_t camera_medium;        /* the camera's medium (media_internal.h) */
  int passable;                  /* bbc__media_passable */
} render_ctx;

/* The random decisions of one path. Each has a slot: the film position, then per path
 * vertex (depth d) a block of VERTEX_SLOTS, so a decision's slot does not depend on how
 * many numbers earlier ones used. With BBC_SAMPLER_SOBOL a slot's values over a pixel's
 * samples are padded, Owen-scrambled Sobol points (sobol_internal.h); with
 * BBC_SAMPLER_INDEPENDENT, independent hashes of (seed, pixel, sample, slot). */
#define TUPLE_BIN_SLOTS 2
enum {
  SLOT_EMITTER_PICK, /* 1D: which emissive triangle */
  SLOT_EMITTER_POINT, /* 2D: the point on it */
  SLOT_DIRECTION,     /* 2D: the diffuse bounce */
  SLOT_FRESNEL,       /* 1D: reflect or refract at a dielectric */
  SLOT_ROULETTE,      /* 1D: Russian roulette */
  SLOT_TUPLE_BINS,    /* TUPLE_BIN_SLOTS 2D slots: the caustic estimator's first bins,
                         two per slot */
  VERTEX_SLOTS = SLOT_TUPLE_BINS + TUPLE_BIN_SLOTS
};

typedef struct path_sampler {
  int sobol;
  bbc_sobol points; /* BBC_SAMPLER_SOBOL */
  uint64_t key;     /* BBC_SAMPLER_INDEPENDENT, and the caustic estimator's own streams */
} path_sampler;

/* The first n (1 or 2) coordinates of slot `which` of vertex `depth` (depth -1: the
 * film position). */
static void sample_n(const path_sampler *ps, int depth, int which, int n, double out[]) {
  uint32_t slot = depth < 0 ? 0 : 1 + (uint32_t)depth * VERTEX_SLOTS + (uint32_t)which;
  if (ps->sobol) {
    bbc_sobol_get(&ps->points, slot, n, out);
    return;
  }
  bbc_rng r = {ps->key, 2 * (uint64_t)slot};
  for (int c = 0; c < n; c++) out[c] = bbc_rng_next(&r);
}

/* The 2D sample for the disk of punctual light `light` at vertex `depth`: slots far above
 * the vertices' (1 + depth x VERTEX_SLOTS + which stays below 2^30 for any depth under
 * 10^8), so that scenes without a disk sun keep every sample they had. Lights beyond
 * SUN_SLOTS_PER_VERTEX share slots: correlated, still unbiased. */
#define SUN_SLOT_BASE 0x40000000u
#define SUN_SLOTS_PER_VERTEX 64u
static void sample_sun(const path_sampler *ps, int depth, uint32_t light, double out[2]) {
  uint32_t slot =
      SUN_SLOT_BASE + (uint32_t)depth * SUN_SLOTS_PER_VERTEX + light % SUN_SLOTS_PER_VERTEX;
  if (ps->sobol) {
    bbc_sobol_get(&ps->points, slot, 2, out);
    return;
  }
  bbc_rng r = {ps->key, 2 * (uint64_t)slot};
  for (int c = 0; c < 2; c++) out[c] = bbc_rng_next(&r);
}

static double sample(const path_sampler *ps, int depth, int which) {
  double u;
  sample_n(ps, depth, which, 1, &u);
  return u;
}

/* The caustic estimator's bin uniforms j = 0, 1, ... of one vertex. */
typedef struct vertex_bins {
  const path_sampler *ps;
  int depth;
} vertex_bins;

static double bin_uniform(const void *user, uint32_t j) {
  const vertex_bins *v = user;
  double u[2];
  sample_n(v->ps, v->depth, SLOT_TUPLE_BINS + (int)(j / 2), 2, u);
  return u[j % 2];
}

typedef bbc__surface surface;

static bbc_vec3 v3_mul(bbc_vec3 a, bbc_vec3 b) {
  return v3(a.x * b.x, a.y * b.y, a.z * b.z);
}

/* Irradiance e arriving along to_light (any length) times the glossy BSDF. */
static bbc_vec3 glossy_weight(const bbc_bsdf *bsdf, const surface *s, bbc_vec3 wo,
                              bbc_vec3 to_light, bbc_vec3 e) {
  double f[3];
  bbc_bsdf_eval(bsdf, s->ns, wo, v3_normalize(to_light), f);
  return v3(e.x * f[0], e.y * f[1], e.z * f[2]);
}

static surface surface_at(const bbc_scene *scene, const bbc_hit *hit) {
  return bbc__surface_at(scene, hit);
}

/* e after a length x (may be infinite) inside medium (media_internal.h). */
static bbc_vec3 absorbed(const bbc_scene *scene, uint32_t medium, double x, bbc_vec3 e) {
  if (!medium) return e;
  double t[3];
  bbc__media_transmittance(scene, medium, x, t);
  return v3(e.x * t[0], e.y * t[1], e.z * t[2]);
}

/* Picks an emissive triangle by its share of power (bisection on the CDF). */
static uint32_t pick_emitter(const bbc_scene *scene, double u, double *probability) {
  uint32_t lo = 0, hi = scene->emitter_count - 1;
  while (lo < hi) {
    uint32_t mid = (lo + hi) / 2;
    if (scene->emitter_cdf[mid] > u)
      hi = mid;
    else
      lo = mid + 1;
  }
  *probability = scene->emitter_cdf[lo] - (lo ? scene->emitter_cdf[lo - 1] : 0.0);
  return lo;
}

/* Radiance reflected toward the previous vertex by a diffuse point, by the kind of
 * path it arrived along; still to be multiplied by the path's throughput. */
typedef struct vertex_light {
  bbc_vec3 direct;  /* straight from the lights (next-event estimation) */
  bbc_vec3 caustic; /* from point lights through specular chains (the caustic estimator) */
} vertex_light;

/* What happens at a diffuse vertex: next-event estimation for every point light and one
 * sampled point on an area light, and, with a cache, the caustic estimator for the
 * point lights' specular chains. `segments` is the number of path segments so far; a
 * light path may not make the whole exceed max_depth. `medium` is the vertex's
 * (media_internal.h): light reaching it straight from a light travels through it (an
 * unoccluded light in another medium can only be met through open meshes). */
static vertex_light shade_diffuse_vertex(const render_ctx *ctx, bbc__caustics_thread *ct,
                                         const surface *s, const bbc_bsdf *bsdf, bbc_vec3 wo,
                                         uint32_t segments, uint32_t medium, const path_sampler *ps,
                                         uint64_t *rays) {
  const int depth = (int)segments - 1;
  const bbc_scene *scene = ctx->scene;
  const double *albedo = bsdf->base;
  /* Lambertian: the irradiance, times albedo / pi at the end; glossy: each light's
   * irradiance times the BSDF for its direction. */
  bbc_vec3 sum = v3(0, 0, 0);

  for (uint32_t i = 0; i < scene->point_light_count && segments + 1 <= ctx->max_depth; i++) {
    const bbc_point_light *light = &scene->point_lights[i];
    /* A sun: irradiance E cos from the direction against its travel, unoccluded to
     * infinity; point and spot lights: I cos / r^2, a spot times its falloff. */
    const int sun = light->model.kind == BBC_LIGHT_DIRECTIONAL;
    const int disk = sun && bbc__sun_is_disk(&light->model);
    bbc_vec3 to_light = sun ? v3_neg(light->model.direction) : v3_sub(light->position, s->p);
    if (disk) {
      /* A direction uniform over the disk's cone (density 1 / Omega): the irradiance
       * estimate L cos Omega, L = E scale. */
      double u[2];
      sample_sun(ps, depth, i, u);
      to_light = bbc__sun_sample(&light->model, u);
    }
    double dist2 = v3_dot(to_light, to_light);
    double cos_s = v3_dot(s->ns, to_light);
    if (!(cos_s > 0) || v3_dot(s->ng, to_light) <= 0) continue;
    cos_s /= sqrt(dist2);
    double falloff = bbc_light_falloff(&light->model, v3_scale(to_light, -1.0 / sqrt(dist2)));
    if (!(falloff > 0)) continue;
    bbc_vec3 origin = v3_offset_origin(s->p, s->ng, to_light);
    (*rays)++;
    if (!(sun ? bbc__media_clear(scene, ctx->accel, ctx->passable, origin, to_light, INFINITY,
                                 medium, 1)
              : bbc__media_clear(scene, ctx->accel, ctx->passable, origin,
                                 v3_sub(light->position, origin), 1.0 - 1e-6, medium, 1)))
      continue;
    double g = disk ? cos_s * bbc__sun_solid_angle(&light->model) *
                          bbc_light_sun_radiance_scale(light->model.angular_diameter)
               : sun ? cos_s
                     : falloff * cos_s / dist2;
    bbc_vec3 e = v3(light->intensity[0] * g, light->intensity[1] * g, light->intensity[2] * g);
    e = absorbed(scene, medium, sun ? INFINITY : sqrt(dist2), e);
    sum = v3_add(sum, bsdf->glossy ? glossy_weight(bsdf, s, wo, to_light, e) : e);
  }

  if (scene->emitter_count > 0 && segments + 1 <= ctx->max_depth) {
    double probability;
    uint32_t e =
        scene->emitters[pick_emitter(scene, sample(ps, depth, SLOT_EMITTER_PICK), &probability)];
    double r[2];
    sample_n(ps, depth, SLOT_EMITTER_POINT, 2, r);
    double r1 = sqrt(r[0]), r2 = r[1];
    const uint32_t *idx = scene->indices + 3 * (size_t)e;
    bbc_vec3 p0 = v3_load(scene->positions + 3 * (size_t)idx[0]);
    bbc_vec3 p1 = v3_load(scene->positions + 3 * (size_t)idx[1]);
    bbc_vec3 p2 = v3_load(scene->positions + 3 * (size_t)idx[2]);
    bbc_vec3 q = v3_add(v3_add(v3_scale(p0, 1.0 - r1), v3_scale(p1, r1 * (1.0 - r2))),
                        v3_scale(p2, r1 * r2));
    bbc_vec3 cross = v3_cross(v3_sub(p1, p0), v3_sub(p2, p0));
    double area = 0.5 * v3_length(cross);
    bbc_hit at = {0, e, r1 * (1.0 - r2), r1 * r2};
    surface light = surface_at(scene, &at);
    /* A cut-out part of an emitter emits nothing; a partly covered one (BLEND) its share. */
    const double cover = bbc_scene_coverage(scene, e, at.u, at.v);
    bbc_vec3 to_light = v3_sub(q, s->p);
    double dist2 = v3_dot(to_light, to_light);
    double dist = sqrt(dist2);
    double cos_s = v3_dot(s->ns, to_light) / dist;
    double cos_l = -v3_dot(light.ns, to_light) / dist;
    if (cos_s > 0 && cos_l > 0 && v3_dot(s->ng, to_light) > 0 && probability > 0 && cover > 0) {
      bbc_vec3 origin = v3_offset_origin(s->p, s->ng, to_light);
      bbc_vec3 target = v3_offset_origin(q, light.ng, v3_neg(to_light));
      (*rays)++;
      if (bbc__media_clear(scene, ctx->accel, ctx->passable, origin, v3_sub(target, origin),
                           1.0 - 1e-6, medium, 1)) {
        double le[3];
        bbc_scene_emission(scene, e, at.u, at.v, le);
        double g = cos_s * cos_l / dist2 * area / probability * cover;
        bbc_vec3 e = absorbed(scene, medium, dist, v3(le[0] * g, le[1] * g, le[2] * g));
        sum = v3_add(sum, bsdf->glossy ? glossy_weight(bsdf, s, wo, to_light, e) : e);
      }
    }
  }
  vertex_light out;
  out.direct = bsdf->glossy ? sum
                            : v3(sum.x * albedo[0] / BBC_PI, sum.y * albedo[1] / BBC_PI,
                                 sum.z * albedo[2] / BBC_PI);
  out.caustic = v3(0, 0, 0);
  /* A caustic path of n specular vertices adds n + 1 segments to the point. */
  if (ctx->caustics && segments + 2 <= ctx->max_depth) {
    vertex_bins vb = {ps, depth};
    bbc__bin_uniforms bins = {bin_uniform, &vb, 2 * TUPLE_BIN_SLOTS};
    /* A glossy receiver: the estimator weighs each solution by the BSDF itself. */
    bbc__receiver_shading shading = {bsdf, s->ns, wo};
    ct->shading = bsdf->glossy ? &shading : NULL;
    ct->seen_directly = segments == 1;
    bbc_vec3 e = bbc__caustics_estimate(ctx->caustics, ct, s->p, s->ng, s->triangle, s->b1, s->b2,
                                        (int)(ctx->max_depth - segments - 1),
                                        bbc__mix64(ps->key ^ bbc__mix64(segments + 0xE7037ED1A0B428DBull)),
                                        &bins);
    ct->shading = NULL;
    ct->seen_directly = 0;
    out.caustic = bsdf->glossy ? e
                               : v3(e.x * albedo[0] / BBC_PI, e.y * albedo[1] / BBC_PI,
                                    e.z * albedo[2] / BBC_PI);
  }
  return out;
}

/* The specular vertices a camera path met since its last diffuse vertex (at most the
 * first two are kept): what the clean splits with the caustic estimator look at. */
typedef struct specular_run {
  int count;
  uint32_t triangle[2];
  int letter[2]; /* 0 mirror reflection, 1 refraction, -1 other (a Fresnel reflection) */
  bbc_vec3 point[2], normal[2];
} specular_run;

/* Records specular vertex s (of kind `letter`) in the run; vertices after the second are
 * counted only. */
static void note_specular(specular_run *run, const surface *s, int letter) {
  if (run->count < 2) {
    run->triangle[run->count] = s->triangle;
    run->letter[run->count] = letter;
    run->point[run->count] = s->p;
    run->normal[run->count] = s->ns;
  }
  run->count++;
}

/* The radiance of the suns' disks that a ray escaping the scene along unit dir sees, for a
 * path whose last diffuse vertex lay on `diffuse_triangle` (UINT32_MAX: none) followed by
 * the specular vertices `run`: every disk holding dir, but those whose light the caustic
 * estimator counts. */
static bbc_vec3 escaped_sun_radiance(const render_ctx *ctx, bbc_vec3 dir, uint32_t diffuse_triangle,
                                     const specular_run *run) {
  const bbc_scene *scene = ctx->scene;
  bbc_vec3 sum = v3(0, 0, 0);
  for (uint32_t i = 0; i < scene->point_light_count; i++) {
    const bbc_point_light *light = &scene->point_lights[i];
    if (!bbc__sun_is_disk(&light->model) || !bbc__sun_contains(&light->model, dir)) continue;
    if (ctx->caustics && diffuse_triangle != UINT32_MAX &&
        bbc__caustics_sun_covers(ctx->caustics, i, diffuse_triangle, run->count, run->triangle,
                                 run->letter, run->point, run->normal, dir))
      continue;
    double scale = bbc_light_sun_radiance_scale(light->model.angular_diameter);
    sum = v3_add(sum, v3(light->intensity[0] * scale, light->intensity[1] * scale,
                         light->intensity[2] * scale));
  }
  return sum;
}

/* The radiance arriving at the camera along one path started in direction dir. */
static bbc_vec3 trace_path(const render_ctx *ctx, bbc__caustics_thread *ct, bbc_vec3 origin,
                           bbc_vec3 dir, const path_sampler *ps, uint64_t *rays) {
  const bbc_scene *scene = ctx->scene;
  bbc_vec3 radiance = v3(0, 0, 0);
  bbc_vec3 throughput = v3(1, 1, 1);
  int count_emission = 1; /* camera ray or specular bounce: an emitter hit counts */
  /* Since the last diffuse vertex (area lights' split, docs/lights.md): its triangle,
   * the specular vertices met since (specular_run: the first two, in the order met), which
   * the splits with the caustic estimator for area lights and suns look at. */
  uint32_t diffuse_triangle = UINT32_MAX;
  specular_run run;
  run.count = 0;
  /* Light found before the first diffuse bounce is "direct", after it "indirect". */
  uint32_t lit_component = BBC_COMPONENT_DIRECT;
  /* The caustics counted here: at any vertex, or (BBC_COMPONENT_SEEN_CAUSTICS alone) at
   * the first, while no specular vertex lies between it and the camera. */
  uint32_t caustic_component = BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_SEEN_CAUSTICS;
  /* The medium the ray travels in (media_internal.h) and the point it left: every
   * segment inside a dielectric is absorbed (Beer-Lambert), an escape from one entirely
   * where it absorbs. Refractions switch the medium as the estimator's medium rule does:
   * into the mesh met from its front, out to air when met from behind. */
  uint32_t medium = ctx->camera_medium;
  bbc_vec3 from = origin;
  uint32_t passes = 0; /* surfaces gone straight through */
  for (uint32_t depth = 0; depth < ctx->max_depth; depth++) {
    bbc_hit hit;
    (*rays)++;
    if (!bbc_accel_intersect(ctx->accel, origin, dir, 0.0, DBL_MAX, &hit)) {
      /* Escaped: a sun's disk counts after a camera or specular vertex (after a diffuse
       * one, next-event estimation has counted it). */
      if (count_emission && (ctx->components & lit_component) && ctx->disk_suns)
        radiance = v3_add(radiance, v3_mul(absorbed(scene, medium, INFINITY, throughput),
                                           escaped_sun_radiance(ctx, dir, diffuse_triangle, &run)));
      break;
    }
    surface s = surface_at(scene, &hit);
    throughput = absorbed(scene, medium, v3_length(v3_sub(s.p, from)), throughput);
    from = s.p;
    const bbc_material *m = s.material;
    int front = v3_dot(dir, s.ng) < 0;

    /* A caustic path the estimator counts (receiver -> one or two specular vertices ->
     * the emitter of an area light of the cache) is not counted here as well. The
     * vertices go to the test in the light's order (the reverse of the order met). */
    int covered = 0;
    if (count_emission && front && ctx->caustics && ctx->caustics->area_lights &&
        diffuse_triangle != UINT32_MAX && (run.count == 1 || run.count == 2) &&
        (m->emission[0] > 0 || m->emission[1] > 0 || m->emission[2] > 0)) {
      const int last = run.count - 1;
      const uint32_t tri[2] = {run.triangle[last], run.triangle[0]};
      const int letter[2] = {run.letter[last], run.letter[0]};
      const bbc_vec3 xs[2] = {run.point[last], run.point[0]};
      const bbc_vec3 ns[2] = {run.normal[last], run.normal[0]};
      covered = bbc__caustics_area_covers(ctx->caustics, diffuse_triangle, run.count, tri, letter,
                                          hit.triangle, s.p, xs, ns);
    }
    if (count_emission && front && !covered && (ctx->components & lit_component)) {
      double le[3];
      bbc_scene_emission(scene, s.triangle, s.b1, s.b2, le);
      radiance = v3_add(radiance, v3_mul(throughput, v3(le[0], le[1], le[2])));
    }

    if (m->type == BBC_MATERIAL_DIFFUSE) {
      /* Diffuse surfaces are two-sided: face the normals toward the incoming ray. */
      if (!front) {
        s.ng = v3_neg(s.ng);
        s.ns = v3_neg(s.ns);
      }
      /* The path so far has depth + 1 segments. */
      bbc_bsdf bsdf;
      bbc_bsdf_at(scene, s.triangle, s.b1, s.b2, &bsdf);
      const bbc_vec3 wo = v3_neg(dir);
      vertex_light light =
          shade_diffuse_vertex(ctx, ct, &s, &bsdf, wo, depth + 1, medium, ps, rays);
      if (ctx->components & lit_component)
        radiance = v3_add(radiance, v3_mul(throughput, light.direct));
      if (ctx->components & caustic_component)
        radiance = v3_add(radiance, v3_mul(throughput, light.caustic));
      lit_component = BBC_COMPONENT_INDIRECT;
      caustic_component = BBC_COMPONENT_CAUSTICS;
      diffuse_triangle = s.triangle;
      run.count = 0;
      double u[2];
      sample_n(ps, (int)depth, SLOT_DIRECTION, 2, u);
      count_emission = 0;
      if (bsdf.glossy) {
        /* The BSDF's own sampling; the lobe choice takes the Fresnel slot, which a
         * receiver does not otherwise use. */
        double w[3];
        bbc_bsdf_sample(&bsdf, s.ns, wo, sample(ps, (int)depth, SLOT_FRESNEL), u, &dir, w);
        if (!(w[0] > 0 || w[1] > 0 || w[2] > 0) || v3_dot(dir, s.ng) <= 0) break;
        throughput = v3_mul(throughput, v3(w[0], w[1], w[2]));
      } else {
        /* Cosine-weighted sampling: the pdf cancels cos/pi, leaving the albedo. */
        double r = sqrt(u[0]), phi = 2.0 * BBC_PI * u[1];
        bbc_vec3 t, b;
        v3_basis(s.ns, &t, &b);
        double z = sqrt(fmax(0.0, 1.0 - r * r));
        dir = v3_add(v3_add(v3_scale(t, r * cos(phi)), v3_scale(b, r * sin(phi))),
                     v3_scale(s.ns, z));
        if (v3_dot(dir, s.ng) <= 0) break; /* below the geometric surface */
        throughput = v3_mul(throughput, v3(bsdf.base[0], bsdf.base[1], bsdf.base[2]));
      }
    } else {
      double u = m->type == BBC_MATERIAL_DIELECTRIC ? sample(ps, (int)depth, SLOT_FRESNEL) : 0.0;
      bbc__scatter sc;
      int goes_on = bbc__scatter_specular(scene, &s, dir, medium, u, ctx->no_fresnel, &sc);
      if (goes_on == BBC__SCATTER_PASSES) {
        /* No vertex: the segment goes on and still counts once toward max_depth. */
        origin = v3_offset_origin(s.p, s.ng, dir);
        if (++passes > BBC__MEDIA_MAX_PASSES) break;
        depth--;
        continue;
      }
      note_specular(&run, &s, sc.letter);
      caustic_component = BBC_COMPONENT_CAUSTICS;
      if (goes_on == BBC__SCATTER_ENDS) break;
      dir = sc.dir;
      /* Radiance is scaled by (n_t / n_i)^2 across a refraction; along a camera path the
       * factor is its inverse, eta^2. */
      if (sc.letter == 1) throughput = v3_scale(throughput, sc.eta * sc.eta);
      if (sc.letter >= 0)
        throughput = v3_mul(throughput, v3(sc.weight[0], sc.weight[1], sc.weight[2]));
      medium = sc.medium;
      count_emission = 1;
    }
    origin = v3_offset_origin(s.p, s.ng, dir);

    if (depth >= 3) { /* Russian roulette */
      double q = fmin(0.95, fmax(throughput.x, fmax(throughput.y, throughput.z)));
      if (sample(ps, (int)depth, SLOT_ROULETTE) >= q) break;
      throughput = v3_scale(throughput, 1.0 / q);
    }
  }
  return radiance;
}

/* Light tracing's photons go in rounds of PHOTON_BATCHES batches of PHOTON_BATCH
 * consecutive indices, each batch traced by one thread into its own splat list. */
#define PHOTON_BATCH 4096
#define PHOTON_BATCHES 64

/* Traces photons [at, end) into traced, each batch's splats added in index order, so
 * that the sum does not depend on the thread count or on how passes were cut; counts
 * the photons that reached a pixel of the image by kind (from the cones, aimed) and
 * those added to a rendered one. */
static void trace_photons(const bbc__light_tracer *tracer, bbc__caustics_thread *thread_state,
                          int threads, bbc__splat *splats, uint32_t *splat_count, uint64_t at,
                          uint64_t end, double *traced, uint64_t reached[2], uint64_t *added,
                          uint64_t *rays) {
  uint64_t batch_rays = 0;
  while (at < end) {
    const uint64_t round_end = at + (uint64_t)PHOTON_BATCHES * PHOTON_BATCH < end
                                   ? at + (uint64_t)PHOTON_BATCHES * PHOTON_BATCH
                                   : end;
    const int batches = (int)((round_end - at + PHOTON_BATCH - 1) / PHOTON_BATCH);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) reduction(+ : batch_rays)
    for (int b = 0; b < batches; b++) {
      bbc__caustics_thread *ct = &thread_state[omp_get_thread_num()];
      const uint64_t lo = at + (uint64_t)b * PHOTON_BATCH;
      const uint64_t hi = lo + PHOTON_BATCH < round_end ? lo + PHOTON_BATCH : round_end;
      bbc__splat *out = splats + (size_t)b * PHOTON_BATCH;
      uint32_t count = 0;
      for (uint64_t i = lo; i < hi; i++)
        count += (uint32_t)bbc__light_trace_photon(tracer, ct, i, &out[count], &batch_rays);
      splat_count[b] = count;
    }
    for (int b = 0; b < batches; b++) {
      const bbc__splat *out = splats + (size_t)b * PHOTON_BATCH;
      for (uint32_t j = 0; j < splat_count[b]; j++) {
        reached[out[j].aimed]++;
        if (out[j].pixel == BBC__SPLAT_OUTSIDE) continue;
        (*added)++;
        for (int k = 0; k < 3; k++) traced[3 * (size_t)out[j].pixel + k] += out[j].rgb[k];
      }
    }
    at = round_end;
  }
  *rays += batch_rays;
}

bbc_result bbc_render(const bbc_scene *scene, const bbc_accel *accel,
                      const bbc_render_options *options, bbc_image *image,
                      bbc_render_stats *stats) {
  bbc_render_options opts;
  memset(&opts, 0, sizeof opts);
  if (options) opts = *options;
  if (!scene || !accel || !image) return BBC_ERR_INVALID_ARGUMENT;
  if (opts.time_limit < 0 || !isfinite(opts.time_limit)) return BBC_ERR_INVALID_ARGUMENT;
  if (opts.solver != BBC_SOLVER_NEWTON_STOCH && opts.solver != BBC_SOLVER_NEWTON_DET)
    return BBC_ERR_INVALID_ARGUMENT;
  if (opts.sampler != BBC_SAMPLER_SOBOL && opts.sampler != BBC_SAMPLER_INDEPENDENT)
    return BBC_ERR_INVALID_ARGUMENT;
  uint32_t planned = opts.spp ? opts.spp : (opts.time_limit > 0 ? UINT32_MAX : 16);
  render_ctx ctx = {scene,
                    accel,
                    opts.max_depth ? opts.max_depth : 16,
                    opts.no_fresnel,
                    opts.components
                        ? opts.components
                        : BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_DIRECT | BBC_COMPONENT_INDIRECT,
                    NULL,
                    0,
                    0,
                    bbc__media_passable(scene)};
  for (uint32_t i = 0; i < scene->point_light_count; i++)
    ctx.disk_suns |= bbc__sun_is_disk(&scene->point_lights[i].model);
  ctx.camera_medium = bbc__media_at(scene, (opts.camera ? opts.camera : &scene->camera)->position);
  int threads = opts.threads > 0 ? opts.threads : omp_get_max_threads();
  const uint32_t width = image->width, height = image->height;
  const size_t pixels = (size_t)width * height;
  uint32_t x0 = 0, y0 = 0, x1 = width, y1 = height;
  if (opts.region[0] | opts.region[1] | opts.region[2] | opts.region[3]) {
    x0 = opts.region[0];
    y0 = opts.region[1];
    x1 = opts.region[2];
    y1 = opts.region[3];
    if (!(x0 < x1 && x1 <= width && y0 < y1 && y1 <= height)) return BBC_ERR_INVALID_ARGUMENT;
  }
  const size_t region_pixels = (size_t)(x1 - x0) * (y1 - y0);

  /* The caustic estimator and its per-thread state. */
  bbc__caustics caustics;
  bbc__caustics_thread *thread_state = calloc((size_t)threads, sizeof *thread_state);
  if (!thread_state) return BBC_ERR_OUT_OF_MEMORY;
  if (opts.method != BBC_METHOD_PT) {
    if (!opts.cache) {
      free(thread_state);
      return BBC_ERR_INVALID_ARGUMENT;
    }
    memset(&caustics, 0, sizeof caustics);
    caustics.scene = scene;
    caustics.accel = accel;
    caustics.passable = ctx.passable;
    caustics.cache = opts.cache;
    caustics.tuples = bbc_cache_tuples(opts.cache);
    caustics.chains = opts.chains ? opts.chains : BBC_CHAIN_MASK_ALL;
    caustics.no_fresnel = opts.no_fresnel;
    caustics.solver = opts.solver;
    caustics.newton_max_trials = opts.newton_max_trials;
    {
      bbc_cache_info info;
      bbc_cache_get_info(opts.cache, &info);
      caustics.area_lights = info.params.area_lights && info.scene_emitter_count > 0;
      caustics.area_double = caustics.area_lights && info.params.area_double;
      caustics.cache_chains = info.params.chains;
    }
    static const bbc__sampling_method methods[] = {BBC__SAMPLE_BOUND, BBC__SAMPLE_BOUND,
                                                   BBC__SAMPLE_ENUMERATE, BBC__SAMPLE_UNIFORM,
                                                   BBC__SAMPLE_ONE};
    static const bbc__gamma_source sources[] = {BBC__GAMMA_FIXED, BBC__GAMMA_EXPECTED,
                                                BBC__GAMMA_VARIANCE};
    caustics.sampling.method = methods[opts.method];
    caustics.sampling.source = sources[opts.gamma_mode];
    /* As in the paper's Table 1, gamma and the variance target are given for a light
     * of unit intensity: the bounds are scaled by the brightest light. */
    double reference = 0;
    for (uint32_t i = 0; i < scene->point_light_count; i++)
      for (int k = 0; k < 3; k++) reference = fmax(reference, scene->point_lights[i].intensity[k]);
    /* An emitter of the cache counts with its radiance times its area (W/sr facing it). */
    for (uint32_t i = 0; caustics.area_lights && i < scene->emitter_count; i++) {
      bbc_light_model model;
      float le[3];
      bbc_scene_area_light(scene, i, &model, le);
      double area = 0.5 * v3_length(model.emitter_normal);
      for (int k = 0; k < 3; k++) reference = fmax(reference, le[k] * area);
    }
    if (!(reference > 0)) reference = 1;
    /* The default gamma: 300 for tuples of one specular vertex, 100 for two, whose
     * Newton solves cost several times a polynomial's (docs/render.md). */
    const int default_gamma = opts.gamma_mode == BBC_GAMMA_FIXED && !(opts.gamma_value > 0);
    double value =
        opts.gamma_value > 0 ? opts.gamma_value : (opts.gamma_mode == BBC_GAMMA_FIXED ? 300 : 4);
    caustics.double_weight = default_gamma ? 1.0 / 3 : 0;
    if (opts.gamma_mode == BBC_GAMMA_FIXED) value /= reference;
    if (opts.gamma_mode == BBC_GAMMA_VARIANCE) value *= reference * reference;
    caustics.sampling.value = value;
    caustics.light_trace = opts.light_trace;
    caustics.light_trace_bound = opts.light_trace_bound == 0 ? INFINITY : opts.light_trace_bound;
    ctx.caustics = &caustics;
    for (int i = 0; i < threads; i++) {
      if (bbc__caustics_thread_init(&thread_state[i], opts.cache) != BBC_OK) {
        for (int j = 0; j <= i; j++) bbc__caustics_thread_free(&thread_state[j]);
        free(thread_state);
        return BBC_ERR_OUT_OF_MEMORY;
      }
    }
  }
  double *sum = calloc(pixels * 3, sizeof *sum);
  /* Light tracing: its own sum, its photons' splats per batch. */
  bbc__light_tracer tracer;
  memset(&tracer, 0, sizeof tracer);
  double *traced = NULL;
  bbc__splat *splats = NULL;
  uint32_t *splat_count = NULL;
  /* Without a cache (the path tracer alone), every caustic path of a point, spot or
   * delta sun is light-traced: the path tracer counts none of them (docs/light-tracing.md,
   * "Without a cache"). */
  const int light_trace = (ctx.caustics || opts.method == BBC_METHOD_PT) && opts.light_trace &&
                          (ctx.components & (BBC_COMPONENT_CAUSTICS | BBC_COMPONENT_SEEN_CAUSTICS));
  bbc_result lt_ok = BBC_OK;
  if (sum && light_trace) {
    const uint32_t region[4] = {x0, y0, x1, y1};
    lt_ok = bbc__light_tracer_init(&tracer, scene, accel, ctx.caustics,
                                   opts.camera ? opts.camera : &scene->camera, width, height,
                                   region, ctx.max_depth, opts.no_fresnel, opts.chains, opts.seed);
    traced = calloc(pixels * 3, sizeof *traced);
    splats = malloc((size_t)PHOTON_BATCHES * PHOTON_BATCH * sizeof *splats);
    splat_count = calloc(PHOTON_BATCHES, sizeof *splat_count);
    const uint64_t defaults[2] = {
        bbc__light_tracer_default_photons(&tracer, thread_state[0].cursor, pixels),
        opts.photons_per_spp ? opts.photons_per_spp : pixels};
    const uint64_t given[2] = {opts.photons_per_spp,
                               opts.aimed_photons_per_spp == BBC_AIMED_PHOTONS_OFF
                                   ? UINT64_MAX
                                   : opts.aimed_photons_per_spp};
    if (lt_ok == BBC_OK && ctx.caustics && given[1] != UINT64_MAX)
      lt_ok = bbc__light_tracer_aim(&tracer, thread_state[0].cursor);
    bbc__light_tracer_budget(&tracer, defaults, given);
  }
  if (!sum || lt_ok != BBC_OK || (light_trace && (!traced || !splats || !splat_count))) {
    free(sum);
    free(traced);
    free(splats);
    free(splat_count);
    bbc__light_tracer_free(&tracer);
    for (int i = 0; i < threads; i++) bbc__caustics_thread_free(&thread_state[i]);
    free(thread_state);
    return lt_ok != BBC_OK ? lt_ok : BBC_ERR_OUT_OF_MEMORY; /* lt_ok: a damaged cell */
  }
  uint64_t photons = 0, photon_splats = 0;

  bbc_result result = BBC_OK;
  uint64_t rays = 0;
  uint32_t done = 0, pass = 1;
  double busy = 0; /* thread-seconds of rendering */
  double start = omp_get_wtime();
  int damaged = 0; /* set once a thread's lookup met a damaged chunk */
  while (done < planned) {
    uint32_t first = done, last = done + (pass < planned - done ? pass : planned - done);
    double pass_start = omp_get_wtime();
    uint64_t pass_rays = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) reduction(+ : pass_rays)
    for (uint32_t y = y0; y < y1; y++) {
      bbc__caustics_thread *ct = &thread_state[omp_get_thread_num()];
      int stop;
#pragma omp atomic read
      stop = damaged;
      if (stop) continue;
      for (uint32_t x = x0; x < x1; x++) {
        size_t pixel = (size_t)y * width + x;
        double *acc = sum + 3 * pixel;
        for (uint32_t k = first; k < last; k++) {
          path_sampler ps = {opts.sampler == BBC_SAMPLER_SOBOL,
                             bbc_sobol_make(opts.seed, pixel, k),
                             bbc_rng_make(opts.seed, pixel, k).key};
          double film[2];
          sample_n(&ps, -1, 0, 2, film);
          double px = x + film[0], py = y + film[1];
          bbc_vec3 origin, dir;
          bbc_camera_ray(opts.camera ? opts.camera : &scene->camera, width, height, px, py,
                         &origin, &dir);
          bbc_vec3 l = trace_path(&ctx, ct, origin, dir, &ps, &pass_rays);
          /* A non-finite sample would poison the pixel forever; it can only come from
           * a degenerate triangle, so drop it. */
          if (isfinite(l.x) && isfinite(l.y) && isfinite(l.z)) {
            acc[0] += l.x;
            acc[1] += l.y;
            acc[2] += l.z;
          }
        }
      }
      if (ct->damage != BBC_OK) {
#pragma omp atomic write
        damaged = 1;
      }
    }
    /* The photons of samples first .. last - 1; after sample 0's, the counts of the
     * others are set from how many of its photons reached a pixel. */
    if (light_trace && !damaged) {
      uint64_t reached[2] = {0, 0}, added = 0;
      uint32_t from = first;
      if (first == 0) {
        trace_photons(&tracer, thread_state, threads, splats, splat_count, 0,
                      bbc__light_tracer_first_photon(&tracer, 1), traced, reached, &added,
                      &pass_rays);
        bbc__light_tracer_adapt(&tracer, reached[1]);
        from = 1;
      }
      if (from < last)
        trace_photons(&tracer, thread_state, threads, splats, splat_count,
                      bbc__light_tracer_first_photon(&tracer, from),
                      bbc__light_tracer_first_photon(&tracer, last), traced, reached, &added,
                      &pass_rays);
      photons = bbc__light_tracer_first_photon(&tracer, last);
      photon_splats += added;
      for (int i = 0; i < threads; i++)
        if (thread_state[i].damage != BBC_OK) damaged = 1;
    }
    rays += pass_rays;
    if (damaged) {
      for (int i = 0; i < threads && result == BBC_OK; i++) result = thread_state[i].damage;
      break;
    }
    done = last;
    double now = omp_get_wtime();
    double per_spp = (now - pass_start) / (last - first);
    busy += (now - pass_start) * threads;
    if (opts.progress &&
        opts.progress(opts.progress_user, done, planned == UINT32_MAX ? 0 : planned)) {
      result = BBC_ERR_CANCELLED;
      break;
    }
    /* Size the next pass to take about half a second, and stop before the time limit
     * would be overrun by it. */
    double target = 0.5;
    if (opts.time_limit > 0) {
      double left = opts.time_limit - (now - start);
      if (left < per_spp) break;
      if (target > left) target = left;
    }
    double next = per_spp > 0 ? floor(target / per_spp) : 1.0;
    pass = next < 1 ? 1 : next > 1e6 ? 1000000 : (uint32_t)next;
  }

  /* Nothing of a damaged cache reaches the image. */
  double scale = done && !damaged ? 1.0 / done : 0.0;
  /* Each sample's splats estimate the pixels' mean radiance, as its camera paths do. */
  for (size_t i = 0; i < pixels * 3; i++)
    image->rgb[i] = (float)((sum[i] + (traced ? traced[i] : 0.0)) * scale);
  free(sum);
  free(traced);
  free(splats);
  free(splat_count);
  bbc__light_tracer_free(&tracer);
  if (stats) {
    memset(stats, 0, sizeof *stats);
    for (int i = 0; i < threads; i++) {
      const bbc__caustics_thread *t = &thread_state[i];
      stats->lookups += t->lookups;
      stats->candidates += t->candidate_count;
      stats->bins += t->bins;
      stats->sampled += t->sampled;
      stats->solutions += t->solutions;
      stats->excluded += t->excluded;
      stats->newton_solves += t->newton_solves;
      stats->newton_converged += t->newton_converged;
      stats->newton_estimates += t->newton_estimates;
      stats->newton_trials += t->newton_trials;
      stats->newton_cap_hits += t->newton_cap_hits;
      stats->sampling_seconds += t->sampling_seconds;
      stats->decoding_seconds += t->decoding_seconds;
      stats->solving_seconds += t->solving_seconds;
    }
    stats->thread_seconds = busy;
    stats->seconds = omp_get_wtime() - start;
    stats->spp = done;
    stats->samples = (uint64_t)done * region_pixels;
    stats->rays = rays;
    stats->threads = threads;
    stats->photons = photons;
    stats->photon_splats = photon_splats;
  }
  for (int i = 0; i < threads; i++) bbc__caustics_thread_free(&thread_state[i]);
  free(thread_state);
  return result;
}
