/* A reference image of the caustic alone by light tracing, for the comparison benchmark
 * (bench/compare.sh): an estimator that shares nothing with bbc's cache, bounds or
 * solvers.
 *
 *   light_trace SCENE.gltf --chains LIST --width W --photons N [--seed K] [--threads T]
 *               [--no-fresnel] [--any-chain K] [--punctual-only] -o OUT.exr
 *
 * --punctual-only: the point, spot and directional lights alone, no emissive triangle
 * (the caustic of a cache precomputed without --area-lights, bench/real-assets.sh).
 *
 * --any-chain K (for hollow glass and liquids in glass, bench/transport.sh): instead of
 * the chain types of LIST, every path of one to K specular vertices, dielectrics
 * reflecting with the Fresnel probability or refracting, the media tracked by the
 * photon itself (follow_any below) rather than read from the scene's media.
 *
 * Photons leave each point or spot light uniformly over the cone of directions that holds
 * the bounding sphere of the scene's casters (the mirrors and glass that bbc-precompute
 * bounds), N per light, each with flux I * falloff * Omega / N. From an area light (an
 * emissive triangle, scene->emitters, bbc_scene_area_light) of radiance L_e and area A,
 * N photons per emitter triangle each start at a point y drawn uniformly by area and leave
 * it uniformly over the cone from y that holds the casters' sphere (solid angle Omega(y)),
 * with flux L_e * max(0, cos theta_e) * A * Omega(y) / N, theta_e against the emitter's
 * front normal (the side its vertex normals point to, the only side it emits to,
 * docs/lights.md): the density of (y, direction) is 1 / (A Omega(y)). They follow exactly the
 * chain types of LIST (R reflects on a mirror, weighted by its base colour; T refracts
 * through a dielectric, weighted by 1 - Fresnel unless --no-fresnel and tinted by its
 * base colour up to 1; base colours with their textures), then land on a
 * receiver. A landing point x that the camera sees directly adds
 * flux * f * |d(pixel) / dA(x)| to its pixel (f the receiver's BSDF, albedo / pi when
 * Lambertian): that is the pixel's mean radiance
 * (a box filter) of the caustic where the camera sees it directly, the quantity
 * `bbc-render --only seen-caustics --max-depth 2 + chain length` estimates. The same
 * admissibility rules as bbc's caustic estimator apply: a refraction's shading normal must
 * agree with its geometric side, a reflection's light must arrive on its shading normal's
 * side, the scattered light must leave on the geometric side of its event (back for a
 * reflection, across for a refraction; a shading normal can tilt it the other way), and
 * the light must reach the receiver on the side the camera sees. The variance of a pixel
 * is finite even at a caustic's focus, where the irradiance (and so every estimator that
 * samples points of the pixel) has an integrable singularity.
 *
 * From a sun (a directional light of irradiance E travelling along D) N photons start
 * uniformly on a disk perpendicular to D, beyond every vertex of the scene against D,
 * whose radius covers the casters' bounding sphere from every direction of the sun's cone.
 * A delta sun (angular diameter 0) sends them along D, each with flux E A / N (A the
 * disk's area); a sun of angular diameter delta sends each along a direction w drawn
 * uniformly over the cone of half-angle h = delta / 2 around -D (solid angle Omega), with
 * flux L cos(w, -D) A Omega / N, L = E / (pi sin^2 h) the disk's radiance.
 *
 * Deterministic: photons are split into batches with their own random streams, summed
 * into 64 lanes in a fixed order, whatever the thread count. Receivers Lambertian or
 * glossy, textured or not: their BSDF at the landing point is bbc's (bbc_bsdf_at,
 * bbc_bsdf_eval), the one thing this shares with the renderer. Point, spot and
 * directional lights in air and area lights. */
#define _POSIX_C_SOURCE 200809L /* strtok_r */
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"

#define PI 3.14159265358979323846
#define LANES 64
#define BATCH 65536

static bbc_vec3 add(bbc_vec3 a, bbc_vec3 b) { return (bbc_vec3){a.x + b.x, a.y + b.y, a.z + b.z}; }
static bbc_vec3 sub(bbc_vec3 a, bbc_vec3 b) { return (bbc_vec3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static bbc_vec3 scale(bbc_vec3 a, double s) { return (bbc_vec3){a.x * s, a.y * s, a.z * s}; }
static double dot(bbc_vec3 a, bbc_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static bbc_vec3 cross(bbc_vec3 a, bbc_vec3 b) {
  return (bbc_vec3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static bbc_vec3 unit(bbc_vec3 a) { return scale(a, 1.0 / sqrt(dot(a, a))); }
static bbc_vec3 load(const float *p) { return (bbc_vec3){p[0], p[1], p[2]}; }

/* SplitMix64: a stream per (seed, light, batch). */
static uint64_t mix(uint64_t *state) {
  uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
static double uniform(uint64_t *state) { return (mix(state) >> 11) * 0x1.0p-53; }

/* Fresnel reflectance of a smooth dielectric for unpolarised light (as bbc's caustic
 * estimator has it). */
static double fresnel(double cos_i, double eta) {
  double sin2_t = eta * eta * (1 - cos_i * cos_i);
  if (sin2_t >= 1) return 1;
  double cos_t = sqrt(1 - sin2_t);
  double rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  double rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

typedef struct tracer {
  const bbc_scene *scene;
  const bbc_accel *accel;
  const bbc_camera *camera;
  uint32_t width, height;
  double tan_half, aspect;
  uint32_t chains; /* BBC_CHAIN_BIT mask */
  int no_fresnel;
  int any_chain; /* --any-chain K: every specular path of 1..K vertices (follow_any) */
} tracer;

/* Triangle t's unit geometric normal turned to the side its vertex normals point to,
 * and its unit shading normal at barycentrics (u, v). */
static void normals(const bbc_scene *s, uint32_t t, double u, double v, bbc_vec3 *ng,
                    bbc_vec3 *ns) {
  const uint32_t *idx = s->indices + 3 * (size_t)t;
  bbc_vec3 p0 = load(s->positions + 3 * (size_t)idx[0]);
  bbc_vec3 p1 = load(s->positions + 3 * (size_t)idx[1]);
  bbc_vec3 p2 = load(s->positions + 3 * (size_t)idx[2]);
  bbc_vec3 n0 = load(s->normals + 3 * (size_t)idx[0]);
  bbc_vec3 n1 = load(s->normals + 3 * (size_t)idx[1]);
  bbc_vec3 n2 = load(s->normals + 3 * (size_t)idx[2]);
  bbc_vec3 g = unit(cross(sub(p1, p0), sub(p2, p0)));
  if (dot(g, add(n0, add(n1, n2))) < 0) g = scale(g, -1);
  *ng = g;
  *ns = unit(add(scale(n0, 1 - u - v), add(scale(n1, u), scale(n2, v))));
}

/* The tint of light refracted at a hit: the base colour there (its texture's too), at
 * most 1 (glTF's KHR_materials_transmission). */
static void tint(const bbc_scene *s, const bbc_hit *h, double w[3]) {
  bbc_scene_base_color(s, h->triangle, h->u, h->v, w);
  for (int k = 0; k < 3; k++) w[k] = w[k] < 1 ? w[k] : 1;
}

/* The photon lands on receiver triangle t at x, coming along d from the last specular
 * vertex, with flux[3]: adds its pixel's share to lane. */
static void land(const tracer *tr, const bbc_hit *h, bbc_vec3 x, bbc_vec3 d, const double flux[3],
                 double *lane) {
  const bbc_scene *s = tr->scene;
  const uint32_t t = h->triangle;
  bbc_vec3 ng, ns;
  normals(s, t, h->u, h->v, &ng, &ns);
  const bbc_camera *c = tr->camera;
  bbc_vec3 to_x = sub(x, c->position);
  /* The light must arrive on the side the camera sees. */
  if ((dot(d, ng) < 0) != (dot(to_x, ng) < 0)) return;
  double z = -dot(to_x, c->w);
  if (!(z > 0)) return;
  double sx = dot(to_x, c->u) / z, sy = dot(to_x, c->v) / z;
  double px = (sx / (tr->tan_half * tr->aspect) + 1) * 0.5 * tr->width;
  double py = (1 - sy / tr->tan_half) * 0.5 * tr->height;
  if (!(px >= 0 && px < tr->width && py >= 0 && py < tr->height)) return;
  /* Seen directly: the camera's ray toward x first hits t, at x, but for glass it meets
   * from behind, which light in air goes through (follow's rule; the camera is in air). */
  bbc_hit hit;
  double from = 0;
  for (;;) {
    if (!bbc_accel_intersect(tr->accel, c->position, to_x, from, 1 + 1e-6, &hit)) return;
    if (hit.triangle == t) break;
    bbc_vec3 hng, hns;
    normals(s, hit.triangle, hit.u, hit.v, &hng, &hns);
    if (s->materials[s->meshes[s->triangle_mesh[hit.triangle]].material].type !=
            BBC_MATERIAL_DIELECTRIC ||
        !(dot(to_x, hng) > 0))
      return;
    from = hit.t * (1 + 1e-6) + 1e-9;
  }
  /* |d(px, py) / dA(x)|: the film at distance 1 has d(film)/dA = cos_x / (r^2 cos_c^3),
   * and a film unit is width / (2 tan_half aspect) = height / (2 tan_half) pixels. */
  double r2 = dot(to_x, to_x), r = sqrt(r2);
  double cos_x = fabs(dot(to_x, ng)) / r, cos_c = z / r;
  double pixels_per_film = tr->height / (2 * tr->tan_half);
  double jacobian = cos_x / (r2 * cos_c * cos_c * cos_c) * pixels_per_film * pixels_per_film;
  /* The receiver's BSDF (bbc's, the one thing this shares with the renderer): Lambertian
   * base / pi, or the glossy lobe with the shading normal turned to the camera's side. */
  bbc_bsdf bsdf;
  bbc_bsdf_at(s, t, h->u, h->v, &bsdf);
  double f[3];
  if (bsdf.glossy) {
    const bbc_vec3 n = dot(to_x, ng) < 0 ? ns : scale(ns, -1);
    bbc_bsdf_eval(&bsdf, n, scale(to_x, -1 / r), scale(d, -1), f);
  } else {
    for (int k = 0; k < 3; k++) f[k] = bsdf.base[k] / PI;
  }
  size_t pixel = (size_t)(uint32_t)py * tr->width + (uint32_t)px;
  for (int k = 0; k < 3; k++) lane[3 * pixel + k] += flux[k] * f[k] * jacobian;
}

/* Chain types R, T, RR, RT, TR, TT are the values 0..5 (bbc/tuple.h); letter i of
 * chain c is 0 for a reflection, 1 for a refraction. */
static int chain_length(int c) { return c < 2 ? 1 : 2; }
static int letter_at(int c, int i) { return c < 2 ? c : i == 0 ? (c - 2) >> 1 : (c - 2) & 1; }

/* The first hit along d from origin, on a triangle other than `from`: a ray that leaves
 * a triangle cannot meet its plane again, so a hit on `from` is the rounding of the start
 * point (Embree's are in single precision), and the search looks past it. 0: none. */
static int next_hit(const tracer *tr, bbc_vec3 origin, uint32_t from, bbc_vec3 d, bbc_hit *hit) {
  double tmin = 0;
  for (int tries = 0; tries < 4; tries++) {
    if (!bbc_accel_intersect(tr->accel, origin, d, tmin, INFINITY, hit)) return 0;
    if (hit->triangle != from) return 1;
    tmin = hit->t * (1 + 1e-6) + 1e-9;
  }
  return 0;
}

/* Whether the scattered direction `next` leaves the geometric surface (normal ng) on the
 * side its event implies: back to the side d came from for a reflection (through = 0),
 * across for a refraction (through = 1). A shading normal can tilt a reflection into the
 * surface or a refraction back out of it; such a photon ends, as in bbc's scattering. */
static int leaves_as(bbc_vec3 d, bbc_vec3 next, bbc_vec3 ng, int through) {
  double in = dot(d, ng), out = dot(next, ng);
  return through ? (in < 0) == (out < 0) && out != 0 : (in < 0) != (out < 0) && out != 0;
}

/* Follows a photon from origin along d (unit) that has made `made` specular vertices of
 * the chain letters[0..made) (0 R, 1 T), in air (inside 0) or inside the glass of material
 * inside - 1. A dielectric surface refracts light in air met from its front (into the
 * glass behind it) and light in that glass met from behind (out into air); any other
 * crossing (glass met from behind by light in air, which came in through a cut-out or
 * round an open mesh's edge) goes straight on and is no vertex: docs/materials.md's rule
 * for media, which glTF leaves open for a solid with holes. */
static void follow(const tracer *tr, bbc_vec3 origin, uint32_t from, bbc_vec3 d, double flux[3],
                   int made, int letters, uint32_t inside, double *lane) {
  const bbc_scene *s = tr->scene;
  bbc_hit hit;
  if (!next_hit(tr, origin, from, d, &hit)) return;
  uint32_t t = hit.triangle;
  const bbc_mesh *mesh = &s->meshes[s->triangle_mesh[t]];
  const bbc_material *m = &s->materials[mesh->material];
  bbc_vec3 x = add(origin, scale(d, hit.t));
  if (mesh->role == BBC_ROLE_RECEIVER && m->type == BBC_MATERIAL_DIFFUSE) {
    if (made == 0) return;
    int chain = made == 1 ? letters : 2 + letters;
    if (tr->chains & (1u << chain)) land(tr, &hit, x, d, flux, lane);
    return;
  }
  if (mesh->role != BBC_ROLE_CASTER ||
      (m->type != BBC_MATERIAL_MIRROR && m->type != BBC_MATERIAL_DIELECTRIC))
    return;
  bbc_vec3 ng, ns;
  normals(s, t, hit.u, hit.v, &ng, &ns);
  /* Off the surface to the side the photon leaves to, beyond the rounding of x (a float
   * hit distance times the ray's length). */
  double off = 1e-6 * (1 + fmax(fabs(x.x), fmax(fabs(x.y), fabs(x.z))));
  int letter = m->type == BBC_MATERIAL_DIELECTRIC;
  const int back = dot(d, ng) > 0;
  if (letter && !(back ? inside == mesh->material + 1 : inside == 0)) {
    follow(tr, add(x, scale(ng, back ? off : -off)), t, d, flux, made, letters, inside, lane);
    return;
  }
  if (made == 2) return;
  int goes_on = 0; /* some wanted chain has this letter here after the letters made */
  for (int c = 0; c < 6; c++)
    if ((tr->chains & (1u << c)) && chain_length(c) > made &&
        (made == 0 || letter_at(c, 0) == letters) && letter_at(c, made) == letter)
      goes_on = 1;
  if (!goes_on) return;
  double weight[3];
  bbc_vec3 next;
  double dn = dot(d, ns);
  if (letter) {
    /* Refraction: the shading normal's side must be the geometric one. */
    if ((dn < 0) != (dot(d, ng) < 0)) return;
    double eta = dn < 0 ? 1.0 / m->ior : m->ior;
    double cos_i = fabs(dn);
    double sin2_t = eta * eta * (1 - cos_i * cos_i);
    if (sin2_t >= 1) return; /* total internal reflection */
    double cos_t = sqrt(1 - sin2_t);
    bbc_vec3 n = dn < 0 ? ns : scale(ns, -1); /* against d */
    next = unit(add(scale(d, eta), scale(n, eta * cos_i - cos_t)));
    if (!leaves_as(d, next, ng, 1)) return;
    double f = tr->no_fresnel ? 0 : fresnel(cos_i, eta);
    tint(s, &hit, weight);
    for (int k = 0; k < 3; k++) weight[k] *= 1 - f;
  } else {
    /* Reflection on a two-sided mirror: its normals turned to the light's side, which the
     * shading normal must then face. */
    if (dot(d, ng) > 0) {
      ng = scale(ng, -1);
      ns = scale(ns, -1);
      dn = -dn;
    }
    if (!(dn < 0)) return;
    next = sub(d, scale(ns, 2 * dn));
    if (!leaves_as(d, next, ng, 0)) return;
    bbc_scene_base_color(s, t, hit.u, hit.v, weight);
  }
  double f2[3] = {flux[0] * weight[0], flux[1] * weight[1], flux[2] * weight[2]};
  x = add(x, scale(ng, dot(next, ng) > 0 ? off : -off));
  if (letter) inside = back ? 0 : mesh->material + 1;
  follow(tr, x, t, next, f2, made + 1, made == 0 ? letter : (letters << 1) | letter, inside, lane);
}

/* --any-chain K: every path of one to K specular vertices, with media of its own.
 * The medium a photon is in follows from which closed dielectric meshes it is inside,
 * tracked by parity per material: each crossing of a triangle of material m flips bit m
 * (the photon starts in air, outside every mesh). The medium of a parity set is the
 * dielectric material with an odd count and the highest index (a liquid that reaches into
 * its glass is glass there: the container wins), air (index 1) when none. A crossing
 * that leaves the medium unchanged (a liquid's side inside its glass, met from either
 * side) goes straight on and is no vertex, and so does one against the surface's
 * orientation: a triangle of material m met from behind while bit m is clear (glass met
 * by light in air, in through a cut-out) or from its front while bit m is set; its bit
 * stays as it was (follow's rule, docs/materials.md). Otherwise the interface's ratio is
 * n(before) / n(after), and the photon reflects with the Fresnel probability F (always
 * under total internal reflection, the parity unchanged) or refracts, tinted by the base
 * colour. Mirrors reflect on either side, weighted by their base colour. None of this
 * asks the scene's own media (bbc_scene.media, the renderer's per-triangle fronts): the
 * parity gives the media, a triangle's orientation only whether it bounds them here.
 * Absorbing media are not supported (refused in main). */
static double medium_ior(const bbc_scene *s, uint64_t parity) {
  double n = 1;
  for (uint32_t m = 0; m < s->material_count && m < 64; m++)
    if ((parity >> m & 1) && s->materials[m].type == BBC_MATERIAL_DIELECTRIC &&
        s->materials[m].ior > n)
      n = s->materials[m].ior;
  return n;
}

static void follow_any(const tracer *tr, bbc_vec3 origin, uint32_t from, bbc_vec3 d,
                       double flux[3], uint64_t *state, double *lane) {
  const bbc_scene *s = tr->scene;
  uint64_t parity = 0;
  int made = 0;
  for (int steps = 0; steps < 4 * tr->any_chain + 16; steps++) {
    bbc_hit hit;
    if (!next_hit(tr, origin, from, d, &hit)) return;
    uint32_t t = hit.triangle;
    const bbc_mesh *mesh = &s->meshes[s->triangle_mesh[t]];
    const bbc_material *m = &s->materials[mesh->material];
    bbc_vec3 x = add(origin, scale(d, hit.t));
    if (mesh->role == BBC_ROLE_RECEIVER && m->type == BBC_MATERIAL_DIFFUSE) {
      if (made > 0) land(tr, &hit, x, d, flux, lane);
      return;
    }
    if (mesh->role != BBC_ROLE_CASTER ||
        (m->type != BBC_MATERIAL_MIRROR && m->type != BBC_MATERIAL_DIELECTRIC))
      return;
    bbc_vec3 ng, ns;
    normals(s, t, hit.u, hit.v, &ng, &ns);
    double off = 1e-6 * (1 + fmax(fabs(x.x), fmax(fabs(x.y), fabs(x.z))));
    double dn = dot(d, ns);
    bbc_vec3 next;
    if (m->type == BBC_MATERIAL_DIELECTRIC) {
      uint64_t after = parity ^ (1ull << mesh->material);
      double n1 = medium_ior(s, parity), n2 = medium_ior(s, after);
      if ((parity >> mesh->material & 1) != (dot(d, ng) > 0)) after = parity;
      if (after == parity || n1 == n2) { /* no interface here: straight on */
        parity = after;
        origin = add(x, scale(ng, dot(d, ng) > 0 ? off : -off));
        from = t;
        continue;
      }
      if (made == tr->any_chain) return;
      if ((dn < 0) != (dot(d, ng) < 0)) return; /* shading normal against its side */
      double eta = n1 / n2, cos_i = fabs(dn);
      double sin2_t = eta * eta * (1 - cos_i * cos_i);
      double f = tr->no_fresnel ? 0 : fresnel(cos_i, eta);
      bbc_vec3 n = dn < 0 ? ns : scale(ns, -1); /* against d */
      if (sin2_t >= 1 || uniform(state) < f) {
        next = sub(d, scale(ns, 2 * dn)); /* reflection, probability F: flux unchanged */
        if (!leaves_as(d, next, ng, 0)) return;
      } else {
        double cos_t = sqrt(1 - sin2_t);
        next = unit(add(scale(d, eta), scale(n, eta * cos_i - cos_t)));
        if (!leaves_as(d, next, ng, 1)) return;
        double w[3];
        tint(s, &hit, w);
        for (int k = 0; k < 3; k++) flux[k] *= w[k];
        parity = after;
      }
    } else {
      if (made == tr->any_chain) return;
      if (dot(d, ng) > 0) {
        ng = scale(ng, -1);
        ns = scale(ns, -1);
        dn = -dn;
      }
      if (!(dn < 0)) return;
      next = sub(d, scale(ns, 2 * dn));
      if (!leaves_as(d, next, ng, 0)) return;
      double w[3];
      bbc_scene_base_color(s, t, hit.u, hit.v, w);
      for (int k = 0; k < 3; k++) flux[k] *= w[k];
    }
    made++;
    origin = add(x, scale(ng, dot(next, ng) > 0 ? off : -off));
    from = t;
    d = next;
  }
}

/* The cone of directions from p that holds the sphere (centre, radius): every direction
 * when p is inside it. */
typedef struct cone {
  bbc_vec3 axis, b1, b2;
  double cos_max, omega;
} cone;

static cone cone_toward(bbc_vec3 p, bbc_vec3 centre, double radius) {
  cone c;
  bbc_vec3 axis = sub(centre, p);
  double dist = sqrt(dot(axis, axis));
  c.cos_max = dist > radius ? sqrt(1 - (radius / dist) * (radius / dist)) : -1;
  c.axis = dist > 0 ? scale(axis, 1 / dist) : (bbc_vec3){0, 0, 1};
  c.b1 = unit(cross(fabs(c.axis.x) > 0.5 ? (bbc_vec3){0, 1, 0} : (bbc_vec3){1, 0, 0}, c.axis));
  c.b2 = cross(c.axis, c.b1);
  c.omega = 2 * PI * (1 - c.cos_max);
  return c;
}

int main(int argc, char **argv) {
  const char *scene_path = NULL, *out = NULL, *chain_list = NULL;
  long width = 0, threads = 0;
  double photons = 0;
  uint64_t seed = 0;
  int no_fresnel = 0, any_chain = 0, punctual_only = 0;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "--chains") && i + 1 < argc) chain_list = argv[++i];
    else if (!strcmp(a, "--width") && i + 1 < argc) width = atol(argv[++i]);
    else if (!strcmp(a, "--photons") && i + 1 < argc) photons = atof(argv[++i]);
    else if (!strcmp(a, "--seed") && i + 1 < argc) seed = strtoull(argv[++i], NULL, 10);
    else if (!strcmp(a, "--threads") && i + 1 < argc) threads = atol(argv[++i]);
    else if (!strcmp(a, "--no-fresnel")) no_fresnel = 1;
    else if (!strcmp(a, "--punctual-only")) punctual_only = 1;
    else if (!strcmp(a, "--any-chain") && i + 1 < argc) any_chain = atoi(argv[++i]);
    else if (!strcmp(a, "-o") && i + 1 < argc) out = argv[++i];
    else if (a[0] != '-' && !scene_path) scene_path = a;
    else scene_path = NULL, i = argc;
  }
  if (any_chain > 0 && !chain_list) chain_list = "T";
  if (!scene_path || !out || !chain_list || any_chain < 0 || width < 1 || width > 16384 || !(photons >= 1) ||
      threads < 0) {
    fprintf(stderr, "usage: light_trace SCENE.gltf --chains LIST --width W --photons N "
                    "[--seed K] [--threads T] [--no-fresnel] [--any-chain K] [--punctual-only] "
                    "-o OUT.exr\n");
    return 1;
  }
  uint32_t chains = 0;
  {
    static const char *names[] = {"R", "T", "RR", "RT", "TR", "TT"};
    char buffer[128];
    snprintf(buffer, sizeof buffer, "%s", chain_list);
    for (char *save = NULL, *c = strtok_r(buffer, ",", &save); c; c = strtok_r(NULL, ",", &save)) {
      int found = -1;
      for (int k = 0; k < 6; k++)
        if (!strcmp(c, names[k])) found = k;
      if (found < 0) {
        fprintf(stderr, "light_trace: unknown chain type '%s'\n", c);
        return 1;
      }
      chains |= 1u << found;
    }
  }
  bbc_scene_options options;
  memset(&options, 0, sizeof options);
  bbc_scene *scene = NULL;
  bbc_accel *accel = NULL;
  if (bbc_scene_load(&scene, scene_path, &options) != BBC_OK ||
      bbc_accel_create(&accel, scene, NULL, NULL) != BBC_OK) {
    fprintf(stderr, "light_trace: cannot load %s\n", scene_path);
    return 1;
  }
  /* The casters' bounding sphere. */
  bbc_vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t mi = 0; mi < scene->mesh_count; mi++) {
    const bbc_mesh *mesh = &scene->meshes[mi];
    const bbc_material *m = &scene->materials[mesh->material];
    if (any_chain && m->type == BBC_MATERIAL_DIELECTRIC &&
        (m->absorption[0] > 0 || m->absorption[1] > 0 || m->absorption[2] > 0)) {
      fprintf(stderr, "light_trace: --any-chain: %s absorbs: not supported\n", mesh->name);
      return 1;
    }
    if (mesh->role != BBC_ROLE_CASTER) continue;
    for (uint32_t v = mesh->first_vertex; v < mesh->first_vertex + mesh->vertex_count; v++) {
      bbc_vec3 p = load(scene->positions + 3 * (size_t)v);
      lo = (bbc_vec3){fmin(lo.x, p.x), fmin(lo.y, p.y), fmin(lo.z, p.z)};
      hi = (bbc_vec3){fmax(hi.x, p.x), fmax(hi.y, p.y), fmax(hi.z, p.z)};
    }
  }
  if (!(lo.x <= hi.x)) {
    fprintf(stderr, "light_trace: %s has no casters\n", scene_path);
    return 1;
  }
  bbc_vec3 centre = scale(add(lo, hi), 0.5);
  double radius = 0.5 * sqrt(dot(sub(hi, lo), sub(hi, lo))) * (1 + 1e-6);
  /* A sun's photons start beyond the farthest vertex of the scene from the casters'
   * centre, so that nothing lies between their disk and the scene. */
  double farthest = 0;
  for (uint32_t v = 0; v < scene->vertex_count; v++) {
    bbc_vec3 d = sub(load(scene->positions + 3 * (size_t)v), centre);
    farthest = fmax(farthest, sqrt(dot(d, d)));
  }
  const double sun_distance = 2 * farthest + 1;

  const bbc_camera *camera = &scene->camera;
  uint32_t height = (uint32_t)(width / camera->aspect + 0.5);
  if (height < 1) height = 1;
  tracer tr = {scene,  accel,      camera, (uint32_t)width, height, tan(0.5 * camera->yfov),
               (double)width / height, chains, no_fresnel, any_chain};
  const size_t pixels = (size_t)width * height;
  double *lanes = calloc(LANES * pixels * 3, sizeof *lanes);
  if (!lanes) return 1;
  const uint64_t per_light = (uint64_t)photons;
  const uint64_t batches = (per_light + BATCH - 1) / BATCH;
  if (threads > 0) omp_set_num_threads((int)threads);
  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    const bbc_point_light *light = &scene->point_lights[l];
    if (light->medium != 0) {
      fprintf(stderr, "light_trace: light %u is not in air\n", l);
      return 1;
    }
  }
  /* Lights 0 .. point_light_count - 1 are the punctual ones, then one per emitter
   * triangle (the cache's numbering); each has its own random streams. */
  const uint32_t light_count =
      scene->point_light_count + (punctual_only ? 0 : scene->emitter_count);
  for (uint32_t l = 0; l < light_count; l++) {
    const int area = l >= scene->point_light_count;
    const bbc_point_light *light = area ? NULL : &scene->point_lights[l];
    bbc_light_model model;
    float radiance[3] = {0, 0, 0};
    double emitter_area = 0;
    bbc_vec3 front = {0, 0, 0};
    if (area) {
      if (!bbc_scene_area_light(scene, l - scene->point_light_count, &model, radiance)) return 1;
      emitter_area = 0.5 * sqrt(dot(model.emitter_normal, model.emitter_normal));
      front = unit(model.emitter_normal);
    }
    /* A point light's cone is the same for every photon; an emitter's depends on y. */
    const int sun = !area && light->model.kind == BBC_LIGHT_DIRECTIONAL;
    const cone fixed = area || sun ? (cone){{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 0, 0}
                                   : cone_toward(light->position, centre, radius);
    /* A sun: its disk of starting points (centre, axes, radius) and its cone of
     * directions (half-angle, 1 - cos of it, solid angle, radiance per unit irradiance). */
    bbc_vec3 sun_axis = {0, 0, 0}, sun_b1 = {0, 0, 0}, sun_b2 = {0, 0, 0}, sun_centre = {0, 0, 0};
    double sun_radius = 0, sun_half = 0, sun_one_minus_cos = 0, sun_omega = 0, sun_scale = 0;
    if (sun) {
      sun_axis = scale(unit(light->model.direction), -1); /* toward the sun */
      sun_half = 0.5 * light->model.angular_diameter;
      sun_one_minus_cos = 2 * sin(0.5 * sun_half) * sin(0.5 * sun_half);
      sun_omega = 2 * PI * sun_one_minus_cos;
      sun_scale = sun_half > 0 ? 1 / (PI * sin(sun_half) * sin(sun_half)) : 0;
      sun_b1 =
          unit(cross(fabs(sun_axis.x) > 0.5 ? (bbc_vec3){0, 1, 0} : (bbc_vec3){1, 0, 0}, sun_axis));
      sun_b2 = cross(sun_axis, sun_b1);
      sun_centre = add(centre, scale(sun_axis, sun_distance));
      /* A ray of the cone that meets the casters' sphere crosses the disk's plane within
       * (radius + distance tan h) / cos h of its centre. */
      sun_radius = (radius + sun_distance * tan(sun_half)) / cos(sun_half) * (1 + 1e-6);
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int lane = 0; lane < LANES; lane++) {
      double *image = lanes + (size_t)lane * pixels * 3;
      for (uint64_t b = (uint64_t)lane; b < batches; b += LANES) {
        uint64_t state = seed * 0x100000001B3ull ^ ((uint64_t)l << 40) ^ b;
        mix(&state);
        uint64_t count = b + 1 < batches ? BATCH : per_light - b * BATCH;
        for (uint64_t i = 0; i < count; i++) {
          bbc_vec3 origin;
          if (sun) {
            /* A point uniform on the disk, then a direction uniform over the cone. */
            double r = sun_radius * sqrt(uniform(&state)), phi = 2 * PI * uniform(&state);
            origin = add(sun_centre, add(scale(sun_b1, r * cos(phi)), scale(sun_b2, r * sin(phi))));
            double one_minus = uniform(&state) * sun_one_minus_cos, psi = 2 * PI * uniform(&state);
            double cz = 1 - one_minus, sz = sqrt(fmax(0, one_minus * (2 - one_minus)));
            bbc_vec3 d = scale(add(scale(sun_axis, cz),
                                   add(scale(sun_b1, sz * cos(psi)), scale(sun_b2, sz * sin(psi)))),
                               -1);
            double flux[3], disk = PI * sun_radius * sun_radius;
            for (int k = 0; k < 3; k++)
              flux[k] = light->intensity[k] * disk *
                        (sun_half > 0 ? sun_scale * cz * sun_omega : 1.0) / (double)per_light;
            if (any_chain) follow_any(&tr, origin, UINT32_MAX, d, flux, &state, image);
            else
              follow(&tr, origin, UINT32_MAX, d, flux, 0, 0, 0, image);
            continue;
          }
          if (area) {
            /* A point uniform by area: q0 + a (q1 - q0) + a b (q2 - q1), a = sqrt(r1). */
            double a = sqrt(uniform(&state)), bb = uniform(&state);
            const bbc_vec3 *q = model.emitter;
            origin = add(q[0], add(scale(sub(q[1], q[0]), a), scale(sub(q[2], q[1]), a * bb)));
          } else {
            origin = light->position;
          }
          const cone c = area ? cone_toward(origin, centre, radius) : fixed;
          double cz = 1 - uniform(&state) * (1 - c.cos_max), phi = 2 * PI * uniform(&state);
          double sz = sqrt(fmax(0, 1 - cz * cz));
          bbc_vec3 d =
              add(scale(c.axis, cz), add(scale(c.b1, sz * cos(phi)), scale(c.b2, sz * sin(phi))));
          double flux[3];
          if (area) {
            double cos_e = dot(front, d);
            if (!(cos_e > 0)) continue; /* the emitter's back emits nothing */
            for (int k = 0; k < 3; k++)
              flux[k] = radiance[k] * cos_e * emitter_area * c.omega / (double)per_light;
            /* Off the emitter's plane to its front, beyond the rounding of the point (its
             * own triangle is skipped by follow, its neighbours in the plane are not). */
            double off = 1e-6 * (1 + fmax(fabs(origin.x), fmax(fabs(origin.y), fabs(origin.z))));
            origin = add(origin, scale(front, off));
          } else {
            double falloff = bbc_light_falloff(&light->model, d);
            if (!(falloff > 0)) continue;
            for (int k = 0; k < 3; k++)
              flux[k] = light->intensity[k] * falloff * c.omega / (double)per_light;
          }
          uint32_t start = area ? scene->emitters[l - scene->point_light_count] : UINT32_MAX;
          if (any_chain) follow_any(&tr, origin, start, d, flux, &state, image);
          else
            follow(&tr, origin, start, d, flux, 0, 0, 0, image);
        }
      }
    }
  }
  bbc_image *image = NULL;
  if (bbc_image_create(&image, (uint32_t)width, height) != BBC_OK) return 1;
  for (size_t i = 0; i < pixels * 3; i++) {
    double sum = 0;
    for (int lane = 0; lane < LANES; lane++) sum += lanes[(size_t)lane * pixels * 3 + i];
    image->rgb[i] = (float)sum;
  }
  if (bbc_image_write_exr(image, out, NULL, NULL) != BBC_OK) {
    fprintf(stderr, "light_trace: cannot write %s\n", out);
    return 1;
  }
  bbc_image_free(image);
  free(lanes);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
  return 0;
}
