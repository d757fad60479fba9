/* Media from the geometry (media_internal.h, docs/materials.md "Media"): a hollow glass
 * ball whose outer and inner surfaces are separate closed meshes, and a glass of water
 * whose water reaches into the glass. The media on each side of every triangle, rays
 * traced by the path tracer's refraction step (bbc__media_interface, bbc__media_transmit)
 * against the analytic ray through concentric spheres and the exact Snell direction at a
 * glass-water interface, and controls that fail under the rule of one medium per mesh
 * (scene->media NULL, cavity walls oriented as solids). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/accel.h"
#include "bbc/bbc.h"
#include "bbc/bounds.h"
#include "harness.h"
#include "media_internal.h"
#include "tuple_search_internal.h"
#include "vec_internal.h"

static bbc_vec3 vertex(const bbc_scene *s, uint32_t t, int k) {
  return v3_load(s->positions + 3 * (size_t)s->indices[3 * (size_t)t + k]);
}

static bbc_vec3 centroid(const bbc_scene *s, uint32_t t) {
  return v3_scale(v3_add(vertex(s, t, 0), v3_add(vertex(s, t, 1), vertex(s, t, 2))), 1.0 / 3.0);
}

static uint32_t mesh_named(const bbc_scene *s, const char *name) {
  for (uint32_t i = 0; i < s->mesh_count; i++)
    if (strcmp(s->meshes[i].name, name) == 0) return i;
  return UINT32_MAX;
}

/* The medium on side `side` of triangle t by the rule in force: scene->media, else one
 * medium per mesh (air in front, the mesh behind). */
static uint32_t medium_on(const bbc_scene *s, uint32_t t, int side) {
  if (s->media) return s->media[2 * (size_t)t + (side < 0)];
  return side > 0 ? 0 : s->triangle_mesh[t] + 1;
}

/* The rule of one medium per mesh, as before media were found per triangle: no media
 * array, and every closed mesh's front its outside. */
static void old_rule(bbc_scene *s) {
  free(s->media);
  s->media = NULL;
  for (uint32_t i = 0; i < s->mesh_count; i++) {
    bbc_mesh *m = &s->meshes[i];
    if (!m->closed) continue;
    double volume = 0;
    for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++)
      volume += v3_dot(vertex(s, t, 0), v3_cross(vertex(s, t, 1), vertex(s, t, 2)));
    m->outward = volume >= 0 ? 1 : -1;
    m->cavity = 0;
  }
  for (uint32_t l = 0; l < s->point_light_count; l++)
    s->point_lights[l].medium = bbc__media_at(s, s->point_lights[l].position);
}

/* The hollow ball's media: both surfaces have the glass (one medium, the outer mesh's)
 * behind; air is in front of the outer one and the cavity's own air (mesh_count + 1 +
 * the inner mesh) in front of the inner one; the centre is in front of every inner
 * triangle; light in the glass leaves through the inner surface into the cavity with eta
 * 1.5, and light from outside cannot enter the inner surface. Returns the number of
 * failed checks (the control expects some). */
static long hollow_media_failures(const bbc_scene *s, uint32_t outer, uint32_t inner) {
  long failed = 0;
  const uint32_t glass = outer + 1, cavity = s->mesh_count + 1 + inner;
  const bbc_vec3 centre = v3(0, 1, 0);
  for (uint32_t i = 0; i < 2; i++) {
    const bbc_mesh *m = &s->meshes[i == 0 ? outer : inner];
    for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++) {
      failed += medium_on(s, t, 1) != (i == 0 ? 0 : cavity);
      failed += medium_on(s, t, -1) != glass;
      const int side = bbc__media_side(s, t, centre);
      failed += side != (i == 0 ? -1 : 1);
      uint32_t after = 99;
      if (i == 1) {
        /* From the glass, through the inner surface's back, into the cavity. */
        failed += !bbc__media_refract(s, glass, t, -1, &after) || after != cavity;
        failed += bbc__media_refract(s, 0, t, 1, &after) || bbc__media_refract(s, 0, t, -1, &after);
        failed += bbc__media_eta(s, t, -1) != 1.5;
        failed += bbc__media_eta(s, t, 1) != 1.0 / 1.5;
      }
    }
  }
  failed += bbc__media_at(s, centre) != cavity;
  failed += bbc__media_at(s, v3(0.3, 1.0 + 0.92, 0.1)) != glass;
  failed += bbc__media_at(s, v3(0, 1.0 + 0.925, 0)) != glass;
  failed += bbc__media_at(s, v3(0, 3, 0)) != 0;
  return failed;
}

TEST(hollow_sphere_media) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("hollow-sphere.gltf"), NULL) == BBC_OK);
  const uint32_t outer = mesh_named(s, "hollow_sphere_outer");
  const uint32_t inner = mesh_named(s, "hollow_sphere_inner");
  REQUIRE(outer != UINT32_MAX && inner != UINT32_MAX);
  CHECK_INT(s->meshes[outer].closed, 1);
  CHECK_INT(s->meshes[inner].closed, 1);
  REQUIRE(s->media != NULL);
  CHECK_INT(hollow_media_failures(s, outer, inner), 0);
  /* Control: one medium per mesh takes the inner mesh for a solid ball of its own. */
  old_rule(s);
  CHECK(hollow_media_failures(s, outer, inner) > 1000);
  bbc_scene_free(s);
}

/* The candidate tuples of one and two refractions (T, TT) by the meshes of T1 and T2:
 * count[a][b] for T1 on mesh a and T2 on mesh b (b = mesh_count: none). */
static void tuples_by_mesh(const bbc_scene *s, long count[4][4]) {
  memset(count, 0, 16 * sizeof(long));
  bbc_tuple *t = NULL;
  size_t n = 0;
  REQUIRE(bbc_tuples_find(s, (1u << BBC_CHAIN_T) | (1u << BBC_CHAIN_TT), &t, &n) == BBC_OK);
  REQUIRE(s->mesh_count <= 3);
  for (size_t i = 0; i < n; i++) {
    uint32_t a = s->triangle_mesh[t[i].specular[0]];
    uint32_t b =
        t[i].specular[1] == BBC_NO_TRIANGLE ? s->mesh_count : s->triangle_mesh[t[i].specular[1]];
    count[a][b]++;
  }
  free(t);
}

/* No tuple the media prove empty: light from outside enters the hollow ball only through
 * its outer surface (no T1 on the inner one), and light that went on through the inner
 * one is in the cavity, which no floor triangle reaches (no (outer, inner) pair; it
 * would have to refract twice more). Nor does light inside the glass after one
 * refraction (no T): the ball rests on the floor at its pole, a point. Pairs through the
 * outer surface alone remain (the media cannot rule them out: the geometry does).
 * Control: one medium per mesh keeps tuples that start on the inner surface. */
TEST(hollow_sphere_tuples) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("hollow-sphere-small.gltf"), NULL) == BBC_OK);
  const uint32_t outer = mesh_named(s, "hollow_sphere_outer");
  const uint32_t inner = mesh_named(s, "hollow_sphere_inner");
  long count[4][4];
  tuples_by_mesh(s, count);
  fprintf(stderr, "hollow sphere: T %ld, TT outer-outer %ld, outer-inner %ld, from inner %ld\n",
          count[outer][s->mesh_count], count[outer][outer], count[outer][inner],
          count[inner][outer] + count[inner][inner] + count[inner][s->mesh_count]);
  CHECK_INT(count[outer][s->mesh_count], 0);
  CHECK(count[outer][outer] > 0);
  CHECK_INT(count[outer][inner], 0);
  CHECK_INT(count[inner][outer] + count[inner][inner] + count[inner][s->mesh_count], 0);
  old_rule(s);
  tuples_by_mesh(s, count);
  CHECK(count[inner][outer] + count[inner][inner] + count[inner][s->mesh_count] > 0);
  bbc_scene_free(s);
}

/* The number of candidate T tuples, or SIZE_MAX when the search fails. */
static size_t t_tuples(const bbc_scene *s) {
  bbc_tuple *t = NULL;
  size_t n = 0;
  if (bbc_tuples_find(s, 1u << BBC_CHAIN_T, &t, &n) != BBC_OK) return SIZE_MAX;
  free(t);
  return n;
}

/* A floor in the plane of a face of a closed glass's box receives light from inside the
 * glass only where a face of the glass lies on it: none from the hollow ball resting on
 * its pole (the control without the rule finds T tuples there), and from a glass box
 * moved down onto the floor, as many as without the rule (its bottom face lies on the
 * floor: the light that reaches the bottom lands there). */
TEST(floor_under_a_closed_glass) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("hollow-sphere-small.gltf"), NULL) == BBC_OK);
  CHECK_INT(t_tuples(s), 0);
  bbc__tuple_face_rule = 0;
  const size_t without = t_tuples(s);
  bbc__tuple_face_rule = 1;
  fprintf(stderr, "hollow ball on its pole: T 0 (%zu without the rule)\n", without);
  CHECK(without > 0 && without != SIZE_MAX);
  bbc_scene_free(s);

  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-box.gltf"), NULL) == BBC_OK);
  const uint32_t box = mesh_named(s, "glass_box");
  const bbc_mesh *m = &s->meshes[box];
  float low = INFINITY;
  for (uint32_t v = m->first_vertex; v < m->first_vertex + m->vertex_count; v++)
    low = fminf(low, s->positions[3 * (size_t)v + 1]);
  REQUIRE(low == 0.5f);
  CHECK_INT(t_tuples(s), 0); /* floating above the floor */
  for (uint32_t v = m->first_vertex; v < m->first_vertex + m->vertex_count; v++)
    s->positions[3 * (size_t)v + 1] -= 0.5f; /* exact: its bottom lands on y = 0 */
  const size_t with = t_tuples(s);
  bbc__tuple_face_rule = 0;
  const size_t all = t_tuples(s);
  bbc__tuple_face_rule = 1;
  fprintf(stderr, "glass box on the floor: T %zu (%zu without the rule)\n", with, all);
  CHECK(with > 0 && with != SIZE_MAX);
  CHECK_INT((long)with, (long)all);
  bbc_scene_free(s);
}

/* One interface of a traced ray: the triangle, the media before and after, the
 * direction before and after, the shading normal on the incident side and eta. */
typedef struct crossing {
  uint32_t triangle, before, after;
  bbc_vec3 in, out, n;
  double eta;
  int passed; /* gone through unchanged: not a boundary of the ray's medium */
} crossing;

/* Traces a ray through the dielectrics as the path tracer does (integrator.c: the
 * shading normal turned to the vertex normals' side, bbc__media_interface, Snell by
 * bbc__media_transmit, no Fresnel reflection), until it meets nothing or a
 * non-dielectric. Returns the number of crossings (at most max) and the final direction
 * and medium. */
static int trace(const bbc_scene *s, const bbc_accel *accel, bbc_vec3 o, bbc_vec3 d, crossing *c,
                 int max, bbc_vec3 *final, uint32_t *final_medium) {
  uint32_t medium = bbc__media_at(s, o);
  int count = 0;
  for (int depth = 0; depth < 32 && count < max; depth++) {
    bbc_hit h;
    if (!bbc_accel_intersect(accel, o, d, 0.0, INFINITY, &h)) break;
    const uint32_t t = h.triangle;
    if (bbc_scene_triangle_material(s, t)->type != BBC_MATERIAL_DIELECTRIC) break;
    bbc_vec3 n[3];
    for (int k = 0; k < 3; k++)
      n[k] = v3_load(s->normals + 3 * (size_t)s->indices[3 * (size_t)t + k]);
    const double w = 1.0 - h.u - h.v;
    bbc_vec3 p = v3_add(v3_add(v3_scale(vertex(s, t, 0), w), v3_scale(vertex(s, t, 1), h.u)),
                        v3_scale(vertex(s, t, 2), h.v));
    bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(vertex(s, t, 1), vertex(s, t, 0)),
                                        v3_sub(vertex(s, t, 2), vertex(s, t, 0))));
    bbc_vec3 ns =
        v3_normalize(v3_add(v3_add(v3_scale(n[0], w), v3_scale(n[1], h.u)), v3_scale(n[2], h.v)));
    if (v3_dot(ng, ns) < 0) ng = v3_neg(ng);
    const int front = v3_dot(d, ng) < 0;
    crossing *x = &c[count++];
    x->triangle = t, x->before = medium, x->in = d, x->passed = 0;
    double eta;
    uint32_t after;
    if (!bbc__media_interface(s, medium, t, front, &eta, &after)) {
      x->passed = 1, x->after = medium, x->out = d, x->eta = 1, x->n = ns;
      o = v3_offset_origin(p, ng, d);
      continue;
    }
    bbc_vec3 nn = front ? ns : v3_neg(ns), nng = front ? ng : v3_neg(ng);
    double cos_i = -v3_dot(d, nn);
    double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if (!(cos_i > 0) || sin2_t >= 1.0) break;
    double cos_t = sqrt(1.0 - sin2_t);
    d = bbc__media_transmit(d, nn, eta, cos_i, cos_t);
    medium = after;
    x->after = after, x->out = d, x->n = nn, x->eta = eta;
    o = v3_offset_origin(p, v3_neg(nng), d);
    (void)nng;
  }
  *final = d;
  *final_medium = medium;
  return count;
}

/* The exact ray through concentric spheres about c (radii r[0] > r[1], index of the
 * shell `shell`, air elsewhere) from o along unit d: its direction once out. */
static bbc_vec3 analytic_exit(bbc_vec3 c, const double r[2], double shell, bbc_vec3 o, bbc_vec3 d,
                              int *refractions) {
  double n_here = 1.0;
  *refractions = 0;
  for (int k = 0; k < 8; k++) {
    /* The nearest sphere ahead. */
    double best = INFINITY;
    int which = -1;
    for (int i = 0; i < 2; i++) {
      bbc_vec3 w = v3_sub(o, c);
      double b = v3_dot(w, d), q = v3_dot(w, w) - r[i] * r[i], disc = b * b - q;
      if (disc < 0) continue;
      double s0 = -b - sqrt(disc), s1 = -b + sqrt(disc);
      double t = s0 > 1e-9 ? s0 : s1 > 1e-9 ? s1 : INFINITY;
      if (t < best) best = t, which = i;
    }
    if (which < 0) break;
    bbc_vec3 p = v3_add(o, v3_scale(d, best));
    bbc_vec3 n = v3_scale(v3_sub(p, c), 1.0 / r[which]);
    if (v3_dot(d, n) > 0) n = v3_neg(n);
    /* Outward through the outer sphere or inward through the inner one: into glass
     * from air or out of it, by which side the ray is on. */
    double n_next = n_here == 1.0 ? shell : 1.0;
    double eta = n_here / n_next, ci = -v3_dot(d, n), k2 = 1 - eta * eta * (1 - ci * ci);
    if (k2 < 0) break;
    d = v3_normalize(v3_add(v3_scale(d, eta), v3_scale(n, eta * ci - sqrt(k2))));
    n_here = n_next;
    o = p;
    (*refractions)++;
  }
  return d;
}

/* Snell's law at one crossing, checked exactly: the refracted direction is coplanar with
 * the incident one and the normal, on the far side, and eta |in x n| = |out x n|. */
static double snell_error(const crossing *x, double eta) {
  double si = v3_length(v3_cross(x->in, x->n)), so = v3_length(v3_cross(x->out, x->n));
  double coplanar = fabs(v3_dot(x->out, v3_cross(x->in, x->n)));
  return fabs(eta * si - so) + coplanar + (v3_dot(x->out, x->n) < 0 ? 0 : 1);
}

TEST(hollow_sphere_rays) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("hollow-sphere.gltf"), NULL) == BBC_OK);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  const uint32_t glass = mesh_named(s, "hollow_sphere_outer") + 1;
  const bbc_vec3 c = v3(0, 1, 0);
  crossing x[8];
  bbc_vec3 out;
  uint32_t medium;
  /* Through the centre along an icosahedron vertex's direction, where all four surfaces
   * have a vertex whose normal is radial: straight on. */
  const double phi = 1.61803398874989484820;
  const bbc_vec3 axis = v3_normalize(v3(phi, 0, -1));
  int n = trace(s, accel, v3_add(c, v3_scale(axis, -4)), axis, x, 8, &out, &medium);
  CHECK_INT(n, 4);
  CHECK_INT(medium, 0);
  CHECK(v3_length(v3_sub(out, axis)) < 1e-6);
  const uint32_t cavity = s->mesh_count + 1 + mesh_named(s, "hollow_sphere_inner");
  const uint32_t media[5] = {0, glass, cavity, glass, 0};
  for (int i = 0; i < n && i < 4; i++) {
    CHECK_INT(x[i].before, media[i]);
    CHECK_INT(x[i].after, media[i + 1]);
  }
  /* Off centre, horizontally at heights 0.2 to 0.8 off the axis: four refractions (the
   * sine law at concentric spheres leaves no way past the inner one), each exactly by
   * Snell's law with its normal and eta 1/1.5, 1.5, 1/1.5, 1.5, and the way out within
   * the tessellation's error of the analytic ray's. */
  const double r[2] = {1.0, 0.85};
  double worst = 0;
  for (int k = 1; k <= 4; k++) {
    const double b = 0.2 * k;
    const bbc_vec3 o = v3(-4, 1 + b, 0.013 * k), d = v3(1, 0, 0);
    n = trace(s, accel, o, d, x, 8, &out, &medium);
    CHECK_INT(n, 4);
    CHECK_INT(medium, 0);
    for (int i = 0; i < n && i < 4; i++) {
      CHECK_INT(x[i].passed, 0);
      CHECK_NEAR(x[i].eta, (i % 2 == 0) ? 1.0 / 1.5 : 1.5, 1e-15);
      CHECK(snell_error(&x[i], x[i].eta) < 1e-12);
      CHECK_INT(x[i].before, media[i]);
    }
    int refractions = 0;
    bbc_vec3 exact = analytic_exit(c, r, 1.5, o, d, &refractions);
    CHECK_INT(refractions, 4);
    worst = fmax(worst, v3_length(v3_sub(out, exact)));
    /* The deviation is real: the ray does not go straight. */
    fprintf(stderr, "impact %.1f: deviation %.4f\n", b, v3_length(v3_sub(exact, d)));
    CHECK(v3_length(v3_sub(exact, d)) > 0.02);
  }
  fprintf(stderr, "hollow sphere: largest angle from the analytic way out %.2e\n", worst);
  /* Two spheres of 9680 triangles, edges of about 0.06 rad: the interpolated normals and
   * the flat triangles are off the sphere's by up to about 5e-4 rad at each of the four
   * interfaces (measured: 6.3e-4 in all). */
  CHECK(worst < 2e-3);
  bbc_accel_free(accel);
  bbc_scene_free(s);
}

/* The glass of water: returns the number of failed checks of the media (the inner wall
 * below the water line has water in front and glass behind, eta 1.33 / 1.5 from the
 * water; above it air; the water's top air above; its side, inside the glass, glass in
 * front), and of a ray from the water out through the wall, refracted by the exact Snell
 * direction for eta 1.33 / 1.5 at the inner wall and by 1.5 at the outer. */
static long water_failures(const bbc_scene *s, const bbc_accel *accel, int print) {
  const uint32_t glass = mesh_named(s, "glass"), water = mesh_named(s, "water");
  if (glass == UINT32_MAX || water == UINT32_MAX) return 1000000;
  const double n_glass = (double)s->materials[s->meshes[glass].material].ior;
  const double n_water = (double)s->materials[s->meshes[water].material].ior;
  long failed = 0, wall_below = 0, wall_above = 0;
  const bbc_mesh *g = &s->meshes[glass];
  for (uint32_t t = g->first_triangle; t < g->first_triangle + g->triangle_count; t++) {
    bbc_vec3 p = centroid(s, t);
    double radius = sqrt(p.x * p.x + p.z * p.z);
    if (fabs(radius - 0.45) > 0.01 || p.y < 0.16) continue; /* not the inner wall */
    if (p.y < 0.802) {
      wall_below++;
      failed += medium_on(s, t, 1) != water + 1 || medium_on(s, t, -1) != glass + 1;
      failed += bbc__media_eta(s, t, 1) != n_water / n_glass;
      failed += bbc__media_eta(s, t, -1) != n_glass / n_water;
    } else {
      wall_above++;
      failed += medium_on(s, t, 1) != 0 || medium_on(s, t, -1) != glass + 1;
    }
  }
  failed += wall_below < 10 || wall_above < 10;
  const bbc_mesh *w = &s->meshes[water];
  for (uint32_t t = w->first_triangle; t < w->first_triangle + w->triangle_count; t++) {
    bbc_vec3 p = centroid(s, t);
    failed += medium_on(s, t, -1) != water + 1;
    if (fabs(p.y - 0.802) < 1e-6)
      failed += medium_on(s, t, 1) != 0; /* the top */
    else if (p.y > 0.16)
      failed += medium_on(s, t, 1) != glass + 1; /* the side */
  }
  failed += bbc__media_at(s, v3(0.05, 0.5, 0.02)) != water + 1;
  failed += bbc__media_at(s, v3(0.05, 1.0, 0.02)) != 0;
  failed += bbc__media_at(s, v3(0.475, 1.0, 0.0)) != glass + 1;
  /* A ray from the water, down and out through the wall. */
  crossing x[8];
  bbc_vec3 out;
  uint32_t medium;
  const bbc_vec3 d = v3_normalize(v3(1, -0.35, 0.2));
  int n = trace(s, accel, v3(0.05, 0.6, 0.02), d, x, 8, &out, &medium);
  int refracted = 0;
  double worst = 0;
  for (int i = 0; i < n; i++) {
    if (x[i].passed) continue;
    const double eta = x[i].before == water + 1 ? n_water / n_glass : n_glass / 1.0;
    worst = fmax(worst, snell_error(&x[i], eta));
    refracted++;
  }
  if (print)
    fprintf(stderr, "glass of water: %d crossings, %d refractions, Snell error %.2e\n", n,
            refracted, worst);
  failed += refracted != 2 || !(worst < 1e-12) || medium != 0;
  failed += n < 2 || x[0].before != water + 1 || x[0].after != glass + 1;
  return failed;
}

TEST(glass_of_water) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-of-water.gltf"), NULL) == BBC_OK);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  REQUIRE(s->media != NULL);
  CHECK_INT(water_failures(s, accel, 1), 0);
  /* Control: one medium per mesh gives the wall the glass's own ior against air. */
  old_rule(s);
  CHECK(water_failures(s, accel, 0) > 10);
  bbc_accel_free(accel);
  bbc_scene_free(s);
}

/* Scenes whose dielectrics' boxes do not meet keep one medium per mesh: no media array
 * (so their caches and images are those of the rule before). */
TEST(separate_dielectrics_keep_the_mesh_rule) {
  static const char *const scenes[] = {"glass-sphere.gltf", "pool.gltf", "slab10k.gltf"};
  for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", BBC_TEST_SCENES, scenes[i]);
    bbc_scene *s = NULL;
    REQUIRE(bbc_scene_load(&s, path, NULL) == BBC_OK);
    CHECK(s->media == NULL);
    bbc_scene_free(s);
  }
}

/* Each dielectric mesh cut in two open pieces (its first half of triangles and the rest),
 * as a file may hold a surface in several primitives; the media found again. */
static void cut_dielectrics(bbc_scene *s) {
  bbc_mesh *meshes = calloc(2 * (size_t)s->mesh_count, sizeof *meshes);
  REQUIRE(meshes);
  uint32_t k = 0;
  for (uint32_t i = 0; i < s->mesh_count; i++) {
    bbc_mesh m = s->meshes[i];
    const int cut = s->materials[m.material].type == BBC_MATERIAL_DIELECTRIC;
    const uint32_t half = cut ? m.triangle_count / 2 : m.triangle_count;
    meshes[k] = m;
    meshes[k].triangle_count = half;
    for (uint32_t t = m.first_triangle; t < m.first_triangle + half; t++) s->triangle_mesh[t] = k;
    k++;
    if (!cut) continue;
    meshes[k] = m;
    meshes[k].first_triangle = m.first_triangle + half;
    meshes[k].triangle_count = m.triangle_count - half;
    snprintf(meshes[k].name, sizeof meshes[k].name, "%.56s (cut)", m.name);
    for (uint32_t t = meshes[k].first_triangle; t < m.first_triangle + m.triangle_count; t++)
      s->triangle_mesh[t] = k;
    k++;
  }
  free(s->meshes);
  s->meshes = meshes;
  s->mesh_count = k;
  REQUIRE(bbc__scene_media(s) == BBC_OK);
}

/* A hollow ball whose outer and inner surfaces are each two open pieces: every piece has
 * the one glass behind it, air in front (the cavity is air: an open wall encloses
 * nothing by itself), and a ray off centre refracts four times by Snell's law, glass and
 * air alternating. */
TEST(hollow_sphere_open_pieces) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("hollow-sphere-small.gltf"), NULL) == BBC_OK);
  cut_dielectrics(s);
  REQUIRE(s->media != NULL);
  const uint32_t outer = mesh_named(s, "hollow_sphere_outer");
  REQUIRE(outer != UINT32_MAX);
  const uint32_t glass = outer + 1;
  long open = 0, wrong = 0;
  for (uint32_t i = 0; i < s->mesh_count; i++) {
    const bbc_mesh *m = &s->meshes[i];
    if (s->materials[m->material].type != BBC_MATERIAL_DIELECTRIC) continue;
    open += !m->closed;
    for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++)
      wrong += medium_on(s, t, 1) != 0 || medium_on(s, t, -1) != glass ||
               bbc__media_eta(s, t, 1) != 1.0 / 1.5 || bbc__media_eta(s, t, -1) != 1.5;
  }
  CHECK_INT(open, 4);
  CHECK_INT(wrong, 0);
  CHECK_INT(bbc__media_at(s, v3(0, 1, 0)), 0);
  CHECK_INT(bbc__media_at(s, v3(0.1, 1.92, 0)), glass);
  bbc_accel *accel = NULL;
  REQUIRE(bbc_accel_create(&accel, s, NULL, NULL) == BBC_OK);
  crossing x[8];
  bbc_vec3 out;
  uint32_t medium;
  int n = trace(s, accel, v3(-4, 1.5, 0.05), v3(1, 0, 0), x, 8, &out, &medium);
  CHECK_INT(n, 4);
  CHECK_INT(medium, 0);
  for (int i = 0; i < n && i < 4; i++) {
    CHECK_INT(x[i].passed, 0);
    CHECK_INT(x[i].before, i % 2 ? glass : 0);
    CHECK(snell_error(&x[i], i % 2 ? 1.5 : 1.0 / 1.5) < 1e-12);
  }
  /* Control: one medium per mesh refuses light in one piece's glass at another's. */
  old_rule(s);
  uint32_t after;
  const bbc_mesh *o2 = &s->meshes[outer + 1];
  CHECK(!bbc__media_refract(s, glass, o2->first_triangle, -1, &after));
  bbc_accel_free(accel);
  bbc_scene_free(s);
}

/* A closed glass with cut-outs encloses nothing: light refracted into it leaves through
 * its holes, so neither the search's medium rule nor a beam's landing box may keep it
 * inside the mesh's box. The glass ball on the bent floor encloses what enters it; the
 * same ball with a MASK material whose alpha is below the cutoff does not (the landing
 * box of a T tuple into it then stays the whole box given). */
TEST(cut_out_glass_encloses_nothing) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("bent-glass-sphere-512.gltf"), NULL) == BBC_OK);
  uint32_t ball = UINT32_MAX;
  for (uint32_t m = 0; m < s->mesh_count; m++)
    if (s->meshes[m].role == BBC_ROLE_CASTER) ball = m;
  REQUIRE(ball != UINT32_MAX);
  CHECK_INT(s->meshes[ball].closed, 1);
  /* A triangle the light meets from its front (outside). */
  uint32_t t1 = s->meshes[ball].first_triangle;
  while (bbc__media_side(s, t1, s->point_lights[0].position) <= 0) t1++;
  REQUIRE(t1 < s->meshes[ball].first_triangle + s->meshes[ball].triangle_count);
  const bbc_tuple t = {0, BBC_CHAIN_T, {t1, BBC_NO_TRIANGLE}, BBC_RECEIVER_BEAM};
  const int side = 1;
  double lo[3] = {-1e3, -1e3, -1e3}, hi[3] = {1e3, 1e3, 1e3};
  CHECK_INT(bbc__media_enclosure(s, t1, side), ball + 1);
  CHECK(bbc__tuple_landing_box(s, &t, lo, hi));
  CHECK(hi[1] - lo[1] <= 2.001); /* the ball's box: radius 1 */
  bbc_material *m = &s->materials[s->meshes[ball].material];
  CHECK_INT(bbc_material_partial(s, m), 0);
  m->alpha_mode = BBC_ALPHA_MASK;
  m->alpha = 0.25f;
  m->alpha_cutoff = 0.5f;
  CHECK_INT(bbc_material_partial(s, m), 1);
  CHECK_INT(bbc__media_enclosure(s, t1, side), 0);
  double lo2[3] = {-1e3, -1e3, -1e3}, hi2[3] = {1e3, 1e3, 1e3};
  CHECK(bbc__tuple_landing_box(s, &t, lo2, hi2));
  CHECK(lo2[1] == -1e3 && hi2[1] == 1e3);
  bbc_scene_free(s);
}

/* Without a media array the path tracer's and the light tracer's refraction step
 * (bbc__media_interface) follows the medium rule as the estimator and the tuple search
 * do (bbc__media_refract): light in air refracts into a glass ball only through its
 * front, light inside only out through its back, and light in air that meets the back
 * (through a cut-out) goes on unchanged. Before, every hit refracted, and TransmissionTest's
 * cut-out spheres got a third more single-refraction light by light tracing than the
 * estimator could count. */
TEST(refraction_step_follows_the_medium_rule) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-sphere.gltf"), NULL) == BBC_OK);
  REQUIRE(s->media == NULL);
  uint32_t ball = UINT32_MAX;
  for (uint32_t m = 0; m < s->mesh_count; m++)
    if (s->materials[s->meshes[m].material].type == BBC_MATERIAL_DIELECTRIC) ball = m;
  REQUIRE(ball != UINT32_MAX);
  long disagree = 0, cases = 0;
  for (uint32_t t = s->meshes[ball].first_triangle;
       t < s->meshes[ball].first_triangle + s->meshes[ball].triangle_count; t++)
    for (uint32_t medium = 0; medium <= ball + 1; medium += ball + 1)
      for (int front = 0; front <= 1; front++) {
        double eta = 0;
        uint32_t a = 99, b = 99;
        const int step = bbc__media_interface(s, medium, t, front, &eta, &a);
        const int rule = bbc__media_refract(s, medium, t, front ? 1 : -1, &b);
        const int want = medium == 0 ? front : !front;
        disagree += step != rule || step != want || (step && (a != b || !(eta > 0)));
        cases++;
      }
  CHECK_INT(cases, 4 * (long)s->meshes[ball].triangle_count);
  CHECK_INT(disagree, 0);
  bbc_scene_free(s);
}
