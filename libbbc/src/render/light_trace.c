/* Light tracing of caustic paths light -> S+ -> x -> camera (docs/light-tracing.md).
 *
 * A photon leaves a point or spot light in a direction uniform over the cone that holds
 * the bounding sphere of the specular casters (density 1 / Omega), or a delta sun from a
 * point uniform on a disk across its beam that covers that sphere (density 1 / A). Its
 * flux I falloff Omega (E A for a sun), over the probability of picking its light, is
 * what one photon carries. At each mirror or dielectric of a caster it scatters as a
 * camera path does (bbc__scatter_specular: Fresnel's choice, the mirror's reflectance,
 * the tint; flux is not scaled by eta^2), absorbed along every segment inside a medium.
 * At the first diffuse point x after one or more specular vertices the photon stops; if
 * the camera sees x directly, in pixel j, it adds
 *   flux f(x, toward the camera, toward the light) |d(film) / dA(x)| tau
 * to j, tau the absorption of the segment to the camera in its medium. With a box pixel
 * of unit area in film coordinates, |d(film) / dA(x)| = cos_x / (r^2 cos_c^3) (pixels per
 * unit of film at distance 1)^2, r the distance from the camera, cos_x the cosine at x,
 * cos_c the angle off the optical axis: the pinhole camera's importance W_e (Veach 1997,
 * Sec. 10.2; pbrt-v4's PerspectiveCamera::We) with the lens area and the film's
 * normalisation cancelled, for a pixel value that is the mean radiance over the pixel.
 * The expectation of the contribution is then the pixel's mean radiance from these
 * paths. */
#include "light_trace_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bsdf.h"
#include "light_internal.h"
#include "media_internal.h"
#include "rng_internal.h"
#include "specular_internal.h"
#include "vec_internal.h"

#define BBC_PI 3.14159265358979323846

int bbc__light_traced_light(const bbc_scene *scene, uint32_t light) {
  if (light >= scene->point_light_count) return 0;
  return !bbc__sun_is_disk(&scene->point_lights[light].model);
}

uint32_t bbc__light_traced_chains(const bbc__caustics *c, const bbc_cache_entry *e, uint32_t n,
                                  uint32_t triangle) {
  if (!c || !c->light_trace || isnan(c->light_trace_bound)) return 0;
  const uint32_t mesh = c->scene->triangle_mesh[triangle];
  const uint32_t plane = BBC_RECEIVER_PLANE(mesh);
  /* Beam tuples reach every receiver triangle not on a plane (caustics.c). */
  const uint32_t beam = c->scene->meshes[mesh].plane ? plane : BBC_RECEIVER_BEAM;
  uint32_t mask = 0;
  for (uint32_t i = 0; i < n; i++) {
    const bbc_tuple *t = &c->tuples[e[i].tuple];
    if ((t->receiver == triangle || t->receiver == plane || t->receiver == beam) &&
        bbc__light_traced_light(c->scene, t->light) && !(e[i].bound < c->light_trace_bound))
      mask |= 1u << t->chain;
  }
  return mask;
}

/* An orthonormal frame around unit axis. */
static void frame(bbc_vec3 axis, bbc_vec3 *b1, bbc_vec3 *b2) {
  *b1 = v3_normalize(v3_cross(fabs(axis.x) > 0.5 ? v3(0, 1, 0) : v3(1, 0, 0), axis));
  *b2 = v3_cross(axis, *b1);
}

bbc_result bbc__light_tracer_init(bbc__light_tracer *lt, const bbc_scene *scene,
                                  const bbc_accel *accel, const bbc__caustics *caustics,
                                  const bbc_camera *camera, uint32_t width, uint32_t height,
                                  const uint32_t region[4], uint32_t max_depth, int no_fresnel,
                                  uint32_t chains, uint64_t seed) {
  memset(lt, 0, sizeof *lt);
  lt->scene = scene;
  lt->accel = accel;
  lt->passable = bbc__media_passable(scene);
  lt->caustics = caustics;
  lt->camera = camera;
  lt->width = width;
  lt->height = height;
  memcpy(lt->region, region, sizeof lt->region);
  lt->tan_half = tan(0.5 * camera->yfov);
  lt->aspect = (double)width / height;
  lt->max_depth = max_depth;
  lt->no_fresnel = no_fresnel;
  lt->chains = chains;
  lt->camera_medium = bbc__media_at(scene, camera->position);
  lt->key = bbc__mix64(bbc_rng_make(seed, 0, 0).key ^ 0x6C62272E07BB0142ull);
  /* The casters' bounding sphere: their mirrors and dielectrics. */
  bbc_vec3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
  bbc_vec3 all_lo = lo, all_hi = hi;
  for (uint32_t mi = 0; mi < scene->mesh_count; mi++) {
    const bbc_mesh *mesh = &scene->meshes[mi];
    const bbc_material *m = &scene->materials[mesh->material];
    const int caster = mesh->role == BBC_ROLE_CASTER &&
                       (m->type == BBC_MATERIAL_MIRROR || m->type == BBC_MATERIAL_DIELECTRIC);
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      bbc_vec3 p = v3_load(scene->positions + 3 * (size_t)v);
      all_lo = v3(fmin(all_lo.x, p.x), fmin(all_lo.y, p.y), fmin(all_lo.z, p.z));
      all_hi = v3(fmax(all_hi.x, p.x), fmax(all_hi.y, p.y), fmax(all_hi.z, p.z));
      if (!caster) continue;
      lo = v3(fmin(lo.x, p.x), fmin(lo.y, p.y), fmin(lo.z, p.z));
      hi = v3(fmax(hi.x, p.x), fmax(hi.y, p.y), fmax(hi.z, p.z));
    }
  }
  if (!(lo.x <= hi.x) || scene->point_light_count == 0) return BBC_OK;
  const bbc_vec3 centre = v3_scale(v3_add(lo, hi), 0.5);
  /* A margin for the rounding of the vertices' positions. */
  const double radius = 0.5 * v3_length(v3_sub(hi, lo)) * (1 + 1e-6) + 1e-9;
  /* Suns' disks stand beyond every vertex of the scene, seen from the sphere's centre. */
  const double beyond =
      2 * fmax(v3_length(v3_sub(all_hi, centre)), v3_length(v3_sub(all_lo, centre))) + 1;
  lt->sources = calloc(scene->point_light_count, sizeof *lt->sources);
  if (!lt->sources) return BBC_ERR_OUT_OF_MEMORY;
  double total = 0;
  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    const bbc_point_light *light = &scene->point_lights[l];
    if (!bbc__light_traced_light(scene, l)) continue;
    bbc__photon_source *s = &lt->sources[lt->source_count];
    s->light = l;
    if (light->model.kind == BBC_LIGHT_DIRECTIONAL) {
      s->sun = 1;
      s->axis = v3_normalize(light->model.direction);
      s->origin = v3_madd(centre, s->axis, -beyond);
      s->cos_max = radius; /* the disk's radius */
      s->omega = BBC_PI * radius * radius;
    } else {
      bbc_vec3 to = v3_sub(centre, light->position);
      double dist = v3_length(to);
      s->origin = light->position;
      s->cos_max = dist > radius ? sqrt(1 - (radius / dist) * (radius / dist)) : -1;
      s->axis = dist > 0 ? v3_scale(to, 1 / dist) : v3(0, 0, 1);
      s->omega = 2 * BBC_PI * (1 - s->cos_max);
    }
    frame(s->axis, &s->b1, &s->b2);
    /* Picked in proportion to the flux sent toward the sphere, by the brightest channel
     * (a spot's falloff ignored). */
    double i = fmax(light->intensity[0], fmax(light->intensity[1], light->intensity[2]));
    s->probability = i * s->omega;
    if (!(s->probability > 0)) continue;
    total += s->probability;
    lt->source_count++;
  }
  for (uint32_t k = 0; k < lt->source_count; k++) lt->sources[k].probability /= total;
  return BBC_OK;
}

uint64_t bbc__light_tracer_default_photons(const bbc__light_tracer *lt, bbc_cache_cursor *cursor,
                                           uint64_t pixels) {
  const bbc_scene *scene = lt->scene;
  const bbc__caustics *c = lt->caustics;
  if (!c) return pixels; /* no cache: every caustic path is light-traced */
  for (uint32_t mi = 0; mi < scene->mesh_count; mi++)
    if (scene->meshes[mi].role == BBC_ROLE_CASTER &&
        scene->materials[scene->meshes[mi].material].type == BBC_MATERIAL_DIELECTRIC)
      return pixels;
  /* A cache without R or RR (left out by --chains or the precompute's default, see
   * bbc_precompute_choose_chains) leaves those mirror chains to the photons. */
  const uint32_t mirror_chains = BBC_CHAIN_BIT(BBC_CHAIN_R) | BBC_CHAIN_BIT(BBC_CHAIN_RR);
  if ((c->cache_chains & mirror_chains) != mirror_chains) return pixels;
  if (c->light_trace && !isnan(c->light_trace_bound)) {
    bbc_cache_info info;
    bbc_cache_get_info(c->cache, &info);
    for (uint64_t cell = 0; cell < info.cell_count; cell++) {
      const bbc_cache_entry *e = NULL;
      uint32_t n = 0;
      if (bbc_cache_cell(cursor, cell, &e, &n) != BBC_OK) return pixels;
      for (uint32_t i = 0; i < n; i++)
        if (bbc__light_traced_light(scene, c->tuples[e[i].tuple].light) &&
            !(e[i].bound < c->light_trace_bound))
          return pixels;
    }
  }
  return pixels / 16 ? pixels / 16 : 1;
}

static void corners(const bbc_scene *scene, uint32_t t, bbc_vec3 p[3]) {
  const uint32_t *idx = scene->indices + 3 * (size_t)t;
  for (int k = 0; k < 3; k++) p[k] = v3_load(scene->positions + 3 * (size_t)idx[k]);
}

/* The mark of the pair (source, triangle): set to `on` when on >= 0; returns the old. */
static int mark(const bbc__light_tracer *lt, uint32_t source, uint32_t triangle, int on) {
  const uint64_t bit = (uint64_t)source * lt->scene->triangle_count + triangle;
  uint64_t *word = &lt->aimed[bit >> 6];
  const int was = (*word >> (bit & 63)) & 1;
  if (on >= 0) *word = on ? *word | 1ull << (bit & 63) : *word & ~(1ull << (bit & 63));
  return was;
}

static int is_aimed(const bbc__light_tracer *lt, uint32_t source, uint32_t triangle) {
  return mark(lt, source, triangle, -1);
}

bbc_result bbc__light_tracer_aim(bbc__light_tracer *lt, bbc_cache_cursor *cursor) {
  const bbc_scene *scene = lt->scene;
  const bbc__caustics *c = lt->caustics;
  lt->aim_count = 0;
  if (!c || !c->light_trace || isnan(c->light_trace_bound) || lt->source_count == 0) return BBC_OK;
  const uint64_t bits = (uint64_t)lt->source_count * scene->triangle_count;
  if (bits > (uint64_t)64 << 23) return BBC_OK;
  uint32_t *source_of = malloc(scene->point_light_count * sizeof *source_of);
  lt->aimed = calloc((size_t)(bits + 63) / 64, sizeof *lt->aimed);
  if (!source_of || !lt->aimed) {
    free(source_of);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  for (uint32_t l = 0; l < scene->point_light_count; l++) source_of[l] = UINT32_MAX;
  for (uint32_t k = 0; k < lt->source_count; k++) source_of[lt->sources[k].light] = k;
  /* Mark the first triangles of the tuples of light-traced chain types in light-traced
   * cells (a cell's chain types as bbc__light_traced_chains's, over all its triangles). */
  bbc_cache_info info;
  bbc_cache_get_info(c->cache, &info);
  uint64_t marked = 0;
  bbc_result r = BBC_OK;
  for (uint64_t cell = 0; cell < info.cell_count && r == BBC_OK; cell++) {
    const bbc_cache_entry *e = NULL;
    uint32_t n = 0;
    if ((r = bbc_cache_cell(cursor, cell, &e, &n)) != BBC_OK) break;
    uint32_t mask = 0;
    for (uint32_t i = 0; i < n; i++)
      if (source_of[c->tuples[e[i].tuple].light] != UINT32_MAX &&
          !(e[i].bound < c->light_trace_bound))
        mask |= 1u << c->tuples[e[i].tuple].chain;
    mask &= c->chains; /* the chain types asked for */
    for (uint32_t i = 0; mask && i < n; i++) {
      const bbc_tuple *t = &c->tuples[e[i].tuple];
      const uint32_t s = source_of[t->light];
      if (s == UINT32_MAX || !(mask & (1u << t->chain))) continue;
      marked += !mark(lt, s, t->specular[0], 1);
    }
  }
  free(source_of);
  if (r == BBC_OK && marked) {
    lt->aims = malloc(marked * sizeof *lt->aims);
    if (!lt->aims) r = BBC_ERR_OUT_OF_MEMORY;
  }
  if (r != BBC_OK || !marked) {
    free(lt->aimed);
    lt->aimed = NULL;
    return r;
  }
  /* In mark order (source, then triangle), each weighted by the flux its light sends the
   * triangle, as at its centroid (brightest channel; the cosine kept off 0, so that every
   * pair can be picked). */
  double total = 0;
  for (uint32_t s = 0; s < lt->source_count; s++) {
    const bbc__photon_source *src = &lt->sources[s];
    const bbc_point_light *light = &scene->point_lights[src->light];
    const double i = fmax(light->intensity[0], fmax(light->intensity[1], light->intensity[2]));
    for (uint32_t t = 0; t < scene->triangle_count; t++) {
      if (!is_aimed(lt, s, t)) continue;
      bbc_vec3 p[3];
      corners(scene, t, p);
      const bbc_vec3 n = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
      const double area = 0.5 * v3_length(n);
      if (!(area > 0)) { /* never hit: the other photons may keep it */
        mark(lt, s, t, 0);
        continue;
      }
      const bbc_vec3 centroid = v3_scale(v3_add(p[0], v3_add(p[1], p[2])), 1.0 / 3);
      const bbc_vec3 d = src->sun ? src->axis : v3_sub(centroid, src->origin);
      const double r2 = src->sun ? 1 : fmax(v3_dot(d, d), area);
      const double cosine = fabs(v3_dot(d, n)) / (2 * area * sqrt(v3_dot(d, d)));
      const double w = i * area * (cosine + 0.1) / r2;
      if (!(w > 0) || !isfinite(w)) {
        mark(lt, s, t, 0);
        continue;
      }
      bbc__aim *a = &lt->aims[lt->aim_count++];
      a->source = s;
      a->triangle = t;
      a->probability = w;
      total += w;
    }
  }
  double run = 0;
  for (uint32_t k = 0; k < lt->aim_count; k++) {
    lt->aims[k].probability /= total;
    run += lt->aims[k].probability;
    lt->aims[k].cdf = run;
  }
  if (lt->aim_count) lt->aims[lt->aim_count - 1].cdf = 1;
  return BBC_OK;
}

void bbc__light_tracer_budget(bbc__light_tracer *lt, const uint64_t defaults[2],
                              const uint64_t given[2]) {
  for (int i = 0; i < 2; i++) {
    lt->fixed[i] = given[i] != 0;
    const uint64_t n = given[i] ? given[i] : defaults[i];
    lt->pilot[i] = lt->rest[i] = n ? n : 1;
  }
  lt->aiming = lt->aim_count > 0 && given[1] != UINT64_MAX;
  if (!lt->aiming) lt->pilot[1] = lt->rest[1] = 0;
}

/* Aimed photons are worth tracing in proportion to the share of them that reaches a
 * pixel (docs/light-tracing.md, "How many photons"): at a share of 1/32 or more, the
 * pilot's count; below, fewer in proportion, down to an eighth. The cones' photons keep
 * their count: they alone find the paths no cache holds, and cut to a 64th where few of
 * them landed, the few that did made fireflies. */
void bbc__light_tracer_adapt(bbc__light_tracer *lt, uint64_t aimed_reached) {
  if (lt->fixed[1] || lt->pilot[1] == 0) return;
  const double share = (double)aimed_reached / lt->pilot[1];
  const double factor = fmax(1.0 / 8, fmin(1.0, 32 * share));
  const uint64_t n = (uint64_t)ceil(factor * lt->pilot[1]);
  lt->rest[1] = n ? n : 1;
}

uint64_t bbc__light_tracer_first_photon(const bbc__light_tracer *lt, uint64_t k) {
  if (k == 0) return 0;
  return lt->pilot[0] + lt->pilot[1] + (k - 1) * (lt->rest[0] + lt->rest[1]);
}

void bbc__light_tracer_free(bbc__light_tracer *lt) {
  if (!lt) return;
  free(lt->sources);
  free(lt->aims);
  free(lt->aimed);
  memset(lt, 0, sizeof *lt);
}

/* The chain type of specular vertices of letters[0..k) (light order), or -1 when no
 * cached chain type has them (more than two, or a reflection off a dielectric). */
static int chain_of(int k, const int letters[2]) {
  if (k < 1 || k > 2 || letters[0] < 0 || (k == 2 && letters[1] < 0)) return -1;
  return k == 1 ? letters[0] : 2 + 2 * letters[0] + letters[1];
}

/* The photon with `flux` lands at diffuse point s arriving along unit d, after k specular
 * vertices of chain type `chain` (-1: none cached); returns 1 and the splat if it counts. */
static int land(const bbc__light_tracer *lt, bbc__caustics_thread *ct, const bbc__surface *s,
                bbc_vec3 d, const double flux[3], int chain, int pilot, bbc__splat *out,
                uint64_t *rays) {
  const bbc_scene *scene = lt->scene;
  const bbc_camera *cam = lt->camera;
  bbc_vec3 to_x = v3_sub(s->p, cam->position);
  /* The light must arrive on the side the camera sees. */
  if ((v3_dot(d, s->ng) < 0) != (v3_dot(to_x, s->ng) < 0)) return 0;
  /* The pixel (bbc_camera_ray inverted). */
  double z = -v3_dot(to_x, cam->w);
  if (!(z > 0)) return 0;
  double sx = v3_dot(to_x, cam->u) / z, sy = v3_dot(to_x, cam->v) / z;
  double px = (sx / (lt->tan_half * lt->aspect) + 1) * 0.5 * lt->width;
  double py = (1 - sy / lt->tan_half) * 0.5 * lt->height;
  if (!(px >= 0 && px < lt->width && py >= 0 && py < lt->height)) return 0;
  const int inside =
      px >= lt->region[0] && px < lt->region[2] && py >= lt->region[1] && py < lt->region[3];
  if (!inside && !pilot) return 0;
  if (lt->chains && !(chain >= 0 && (lt->chains & (1u << chain)))) return 0;
  /* Seen directly: nothing between the camera and x (before the cache's lookup, which
   * costs more than this ray). */
  (*rays)++;
  bbc_vec3 target = v3_offset_origin(s->p, s->ng, v3_neg(to_x));
  if (!bbc__media_clear(scene, lt->accel, lt->passable, cam->position,
                        v3_sub(target, cam->position), 1.0 - 1e-6, lt->camera_medium, 0))
    return 0;
  /* The partition with the caustic estimator. */
  const bbc_mesh *mesh = &scene->meshes[scene->triangle_mesh[s->triangle]];
  const bbc__caustics *c = lt->caustics;
  const int cached =
      chain >= 0 && c && (c->cache_chains & (1u << chain)) && mesh->role == BBC_ROLE_RECEIVER;
  if (cached) {
    if (ct->damage != BBC_OK) return 0;
    const bbc_cache_entry *entries = NULL;
    uint32_t n = 0;
    bbc_vec3 p = s->p;
    bbc_result looked = bbc_cache_lookup(ct->cursor, s->triangle, s->b1, s->b2, &p, &entries, &n);
    if (looked != BBC_OK) {
      ct->damage = looked;
      return 0;
    }
    if (!(bbc__light_traced_chains(c, entries, n, s->triangle) & (1u << chain))) return 0;
  }
  double r2 = v3_dot(to_x, to_x), r = sqrt(r2);
  double cos_x = fabs(v3_dot(to_x, s->ng)) / r, cos_c = z / r;
  double pixels_per_film = lt->height / (2 * lt->tan_half);
  double jacobian = cos_x / (r2 * cos_c * cos_c * cos_c) * pixels_per_film * pixels_per_film;
  /* The BSDF, its normals turned toward the camera as the path tracer turns them. */
  bbc_bsdf bsdf;
  bbc_bsdf_at(scene, s->triangle, s->b1, s->b2, &bsdf);
  double f[3];
  if (bsdf.glossy) {
    const int front = v3_dot(to_x, s->ng) < 0;
    bbc_vec3 ns = front ? s->ns : v3_neg(s->ns);
    bbc_bsdf_eval(&bsdf, ns, v3_scale(to_x, -1 / r), v3_neg(d), f);
  } else {
    for (int k = 0; k < 3; k++) f[k] = bsdf.base[k] / BBC_PI;
  }
  double tau[3];
  bbc__media_transmittance(scene, lt->camera_medium, r, tau);
  uint32_t x = (uint32_t)px, y = (uint32_t)py;
  if (x >= lt->width || y >= lt->height) return 0;
  out->pixel = inside ? y * lt->width + x : BBC__SPLAT_OUTSIDE;
  for (int k = 0; k < 3; k++) out->rgb[k] = flux[k] * f[k] * jacobian * tau[k];
  return isfinite(out->rgb[0]) && isfinite(out->rgb[1]) && isfinite(out->rgb[2]);
}

int bbc__light_trace_photon(const bbc__light_tracer *lt, bbc__caustics_thread *ct, uint64_t index,
                            bbc__splat *out, uint64_t *rays) {
  if (lt->source_count == 0 || lt->max_depth < 3) return 0;
  const bbc_scene *scene = lt->scene;
  bbc_rng rng = {bbc__mix64(lt->key ^ bbc__mix64(index + 0x2545F4914F6CDD1Dull)), 0};
  /* Which kind of photon, and how many of its kind its sample has. */
  const uint64_t first_rest = lt->pilot[0] + lt->pilot[1];
  const uint64_t *count = index < first_rest ? lt->pilot : lt->rest;
  const uint64_t j = index < first_rest ? index : (index - first_rest) % (count[0] + count[1]);
  const bbc__aim *aim = NULL;
  if (j >= count[0]) {
    /* An aimed photon: a pair by its probability (bisection on the running sums). */
    double u = bbc_rng_next(&rng);
    uint32_t lo = 0, hi = lt->aim_count - 1;
    while (lo < hi) {
      uint32_t mid = lo + (hi - lo) / 2;
      if (u < lt->aims[mid].cdf)
        hi = mid;
      else
        lo = mid + 1;
    }
    aim = &lt->aims[lo];
  }
  /* The light, by its share of the flux (an aimed photon's is its pair's). */
  double u = bbc_rng_next(&rng);
  uint32_t k = 0;
  if (aim) {
    k = aim->source;
  } else {
    while (k + 1 < lt->source_count && u >= lt->sources[k].probability) {
      u -= lt->sources[k].probability;
      k++;
    }
  }
  const bbc__photon_source *src = &lt->sources[k];
  const bbc_point_light *light = &scene->point_lights[src->light];
  double r1 = bbc_rng_next(&rng), r2 = bbc_rng_next(&rng);
  bbc_vec3 origin, dir;
  double flux[3];
  double carried; /* intensity to flux over the photon's odds */
  if (aim) {
    /* A point y uniform on the triangle, density probability / area: the light's
     * intensity times the solid angle of dA(y), cos_y / r^2 (a sun's irradiance times
     * cos_y), over that density. */
    bbc_vec3 p[3];
    corners(scene, aim->triangle, p);
    const double s1 = sqrt(r1);
    const bbc_vec3 y = v3_add(v3_scale(p[0], 1 - s1),
                              v3_add(v3_scale(p[1], s1 * (1 - r2)), v3_scale(p[2], s1 * r2)));
    const bbc_vec3 n = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0])); /* 2 area */
    if (src->sun) {
      dir = src->axis;
      origin = v3_madd(y, dir, -v3_dot(v3_sub(y, src->origin), dir));
      carried = fabs(v3_dot(dir, n)) * 0.5 / aim->probability;
    } else {
      const bbc_vec3 d = v3_sub(y, src->origin);
      const double dist2 = v3_dot(d, d);
      dir = v3_scale(d, 1 / sqrt(dist2));
      const double falloff = bbc_light_falloff(&light->model, dir);
      if (!(falloff > 0)) return 0;
      origin = src->origin;
      carried = falloff * fabs(v3_dot(dir, n)) * 0.5 / (dist2 * aim->probability);
    }
    if (!(carried > 0) || !isfinite(carried)) return 0;
  } else if (src->sun) {
    double rad = src->cos_max * sqrt(r1), phi = 2 * BBC_PI * r2;
    origin = v3_add(src->origin,
                    v3_add(v3_scale(src->b1, rad * cos(phi)), v3_scale(src->b2, rad * sin(phi))));
    dir = src->axis;
    carried = src->omega / src->probability;
  } else {
    double cz = 1 - r1 * (1 - src->cos_max), phi = 2 * BBC_PI * r2;
    double sz = sqrt(fmax(0, 1 - cz * cz));
    dir = v3_add(v3_scale(src->axis, cz),
                 v3_add(v3_scale(src->b1, sz * cos(phi)), v3_scale(src->b2, sz * sin(phi))));
    double falloff = bbc_light_falloff(&light->model, dir);
    if (!(falloff > 0)) return 0;
    origin = src->origin;
    carried = falloff * src->omega / src->probability;
  }
  carried /= (double)count[aim != NULL];
  for (int c = 0; c < 3; c++) flux[c] = light->intensity[c] * carried;
  uint32_t medium = src->sun ? 0 : light->medium;
  bbc_vec3 from = origin;
  int letters[2] = {-1, -1};
  uint32_t made = 0; /* specular vertices so far */
  int origin_is_light = 1;
  for (;;) {
    bbc_hit hit;
    (*rays)++;
    if (!bbc_accel_intersect(lt->accel, origin, dir, 0.0, DBL_MAX, &hit)) return 0;
    /* The partition between aimed photons and the others, by the first surface met:
     * an aimed photon counts only paths that start on its triangle, the others only
     * those that start on no marked one. */
    if (origin_is_light) {
      origin_is_light = 0;
      if (aim ? hit.triangle != aim->triangle : lt->aiming && is_aimed(lt, k, hit.triangle))
        return 0;
    }
    bbc__surface s = bbc__surface_at(scene, &hit);
    if (medium) {
      double t[3];
      bbc__media_transmittance(scene, medium, v3_length(v3_sub(s.p, from)), t);
      for (int c = 0; c < 3; c++) flux[c] *= t[c];
    }
    from = s.p;
    const bbc_material *m = s.material;
    if (m->type == BBC_MATERIAL_DIFFUSE) {
      /* Straight from the light is next-event estimation's. The path is made of made + 2
       * segments (to x and on to the camera); the depth limit was checked at the last
       * specular vertex. */
      if (made == 0) return 0;
      out->aimed = aim != NULL;
      return land(lt, ct, &s, dir, flux, made <= 2 ? chain_of((int)made, letters) : -1,
                  index < first_rest, out, rays);
    }
    /* Specular vertices on the casters only (the photons are aimed at them), while a
     * path through one more would stay within the depth limit (a surface the photon
     * passes straight through is no vertex and no segment of its own). */
    if (scene->meshes[scene->triangle_mesh[s.triangle]].role != BBC_ROLE_CASTER) return 0;
    double uf = bbc_rng_next(&rng);
    bbc__scatter sc;
    const int scattered = bbc__scatter_specular(scene, &s, dir, medium, uf, lt->no_fresnel, &sc);
    if (scattered == BBC__SCATTER_ENDS) return 0;
    if (scattered == BBC__SCATTER_PASSES) {
      origin = v3_offset_origin(s.p, s.ng, dir);
      continue;
    }
    if (made + 3 > lt->max_depth) return 0;
    if (made < 2) letters[made] = sc.letter;
    made++;
    for (int c = 0; c < 3; c++) flux[c] *= sc.weight[c];
    if (!(flux[0] > 0 || flux[1] > 0 || flux[2] > 0)) return 0;
    medium = sc.medium;
    dir = sc.dir;
    origin = v3_offset_origin(s.p, s.ng, dir);
  }
}
