/* Light tracing of caustic paths (docs/light-tracing.md): photons from the point, spot and
 * delta-sun lights, aimed at the casters, followed through one or more specular vertices
 * to the first diffuse point x, which, when the camera sees it directly, adds the path's
 * contribution to the pixel it is seen in. Which of those paths it counts and which it
 * leaves to the caustic estimator is a partition both sides evaluate alike
 * (bbc__light_traced_chains). */
#ifndef BBC_LIGHT_TRACE_INTERNAL_H
#define BBC_LIGHT_TRACE_INTERNAL_H

#include <stdint.h>

#include "bbc/render.h"
#include "caustics_internal.h"

/* One light photons leave: its probability of being picked and how its photons start. */
typedef struct bbc__photon_source {
  uint32_t light;     /* index into scene->point_lights */
  double probability; /* of a photon leaving this light */
  int sun;            /* a delta sun: starts on a disk, travels along its direction */
  /* Point and spot lights: the cone toward the casters' sphere (axis, b1, b2 an
   * orthonormal frame; cos_max = -1: every direction), of solid angle omega. A sun: the
   * disk's centre (beyond the scene), its frame and radius, and omega its area. */
  bbc_vec3 origin, axis, b1, b2;
  double cos_max, omega;
} bbc__photon_source;

/* A caster triangle that aimed photons start on (docs/light-tracing.md, "Aimed
 * photons"): a pair of a source and a triangle, picked with `probability`. */
typedef struct bbc__aim {
  uint32_t source;   /* index into sources */
  uint32_t triangle; /* a scene triangle of a caster */
  double cdf;        /* the running sum of the probabilities, inclusive */
  double probability;
} bbc__aim;

typedef struct bbc__light_tracer {
  const bbc_scene *scene;
  const bbc_accel *accel;
  int passable; /* bbc__media_passable */
  const bbc__caustics *caustics;
  const bbc_camera *camera;
  uint32_t width, height;
  uint32_t region[4];      /* x0, y0, x1, y1: the pixels rendered */
  double tan_half, aspect; /* the film (bbc_camera_ray) */
  uint32_t max_depth;
  int no_fresnel;
  uint32_t chains; /* the chain types asked for (BBC_CHAIN_BIT), 0: all, longer ones too */
  uint32_t camera_medium;
  uint64_t key; /* from the seed: the photons' random streams */
  uint32_t source_count;
  bbc__photon_source *sources;
  /* Aimed photons: the pairs they start from, and a bit per (source, triangle) marking
   * them, which the other photons leave alone (when aiming). */
  uint32_t aim_count;
  bbc__aim *aims;
  uint64_t *aimed;
  int aiming;
  /* Photons per sample from the cones ([0]) and aimed ([1]): pilot[] for sample 0,
   * rest[] for the others (bbc__light_tracer_adapt); fixed[] keeps a count as given. */
  uint64_t pilot[2], rest[2];
  int fixed[2];
} bbc__light_tracer;

/* A photon's contribution to one pixel. Photons of sample 0 that land on a pixel
 * outside the region rendered are returned too, with no contribution, so that the
 * counts of the other samples do not depend on the region (bbc__light_tracer_adapt). */
#define BBC__SPLAT_OUTSIDE UINT32_MAX
typedef struct bbc__splat {
  uint32_t pixel; /* y * width + x; BBC__SPLAT_OUTSIDE: outside the region rendered */
  int aimed;      /* from an aimed photon */
  double rgb[3];
} bbc__splat;

/* Sets lt up for the scene, its casters and lights; returns BBC_OK with
 * lt->source_count = 0 when no light sends photons toward a caster. Free with
 * bbc__light_tracer_free. */
bbc_result bbc__light_tracer_init(bbc__light_tracer *lt, const bbc_scene *scene,
                                  const bbc_accel *accel, const bbc__caustics *caustics,
                                  const bbc_camera *camera, uint32_t width, uint32_t height,
                                  const uint32_t region[4], uint32_t max_depth, int no_fresnel,
                                  uint32_t chains, uint64_t seed);
void bbc__light_tracer_free(bbc__light_tracer *lt);

/* The default number of photons per sample for an image of `pixels` rendered pixels:
 * `pixels` (one per pixel per sample), but a sixteenth of it when light tracing can only
 * meet chains of three or more mirrors: no caster is a dielectric (so no Fresnel
 * reflections, no chains through glass) and no cell of the cache is light-traced (read
 * with cursor, every cell once). A function of the scene and the cache alone. */
uint64_t bbc__light_tracer_default_photons(const bbc__light_tracer *lt, bbc_cache_cursor *cursor,
                                           uint64_t pixels);

/* Picks the pairs (source, caster triangle) aimed photons start from: the first specular
 * triangle of every tuple of a light-traced chain type in each cell light tracing takes
 * (read with cursor, every cell once), each picked in proportion to the flux its light
 * sends it. Sets aim_count to 0 when there are none, or when their marks would take more
 * than 64 MB. */
bbc_result bbc__light_tracer_aim(bbc__light_tracer *lt, bbc_cache_cursor *cursor);

/* Sets the photons per sample, from the cones ([0]) and aimed ([1]): given[i], or
 * when it is 0 defaults[i], the aimed ones' adapted after the first sample (at least 1
 * of each; no aimed ones when given[1] is UINT64_MAX or there is no pair to aim at). */
void bbc__light_tracer_budget(bbc__light_tracer *lt, const uint64_t defaults[2],
                              const uint64_t given[2]);

/* After sample 0: sets the default count of aimed photons of the other samples from how
 * many of sample 0's reached a pixel (docs/light-tracing.md, "How many photons"). */
void bbc__light_tracer_adapt(bbc__light_tracer *lt, uint64_t aimed_reached);

/* The index of the first photon of sample k (photons of sample k are those from
 * bbc__light_tracer_first_photon(lt, k) to that of k + 1). */
uint64_t bbc__light_tracer_first_photon(const bbc__light_tracer *lt, uint64_t k);

/* Traces photon `index` (its random numbers a function of the seed and index alone):
 * within its sample, the photons from the cones come first, then the aimed ones.
 * Returns 1 and its contribution to one pixel's radiance in *out, divided by the
 * number of photons of its kind in its sample (so that the splats of one sample sum to
 * its estimate of the pixels' mean radiance), when it lands on a point the camera sees
 * directly after one or more specular vertices and the partitions give the path to this
 * photon; else 0. ct supplies the cache cursor. */
int bbc__light_trace_photon(const bbc__light_tracer *lt, bbc__caustics_thread *ct, uint64_t index,
                            bbc__splat *out, uint64_t *rays);

/* The chain types (BBC_CHAIN_BIT mask) that light tracing counts for points seen directly
 * by the camera on receiver triangle `triangle` whose cell holds entries e[0..n): those of
 * a tuple ending on the triangle (or its plane) from a light the light tracer handles
 * (point, spot or delta sun) whose bound is at least c->light_trace_bound. 0 when c does
 * not light-trace (c->light_trace is 0). The caustic estimator skips these chain
 * types' tuples of such lights at such points, and the light tracer counts exactly
 * their paths: one function, so that both sides put a point in the same class. */
uint32_t bbc__light_traced_chains(const bbc__caustics *c, const bbc_cache_entry *e, uint32_t n,
                                  uint32_t triangle);

/* 1 when light tracing handles punctual light `light` (a point or spot light, or a sun
 * without an angular size). */
int bbc__light_traced_light(const bbc_scene *scene, uint32_t light);

#endif
