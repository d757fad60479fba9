/* The per-tuple solvers (bbc/solver.h) against independent oracles: analytic reflection
 * points for flat mirrors, Snell's law solved by bisection for flat interfaces and slabs,
 * and round trips on the research set-ups (sample u1, trace the exact path to x_k, solve for
 * x_k and recover u1). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/scene.h"
#include "bbc/solver.h"
#define CHAIN_FIXTURES_SEED 0x2545f4914f6cdd1dull
#include "chain_fixtures.h"
#include "harness.h"
#include "vec_internal.h"

/* The intersection of the line a -> b with the plane through p with normal n. */
static bbc_vec3 line_plane(bbc_vec3 a, bbc_vec3 b, bbc_vec3 p, bbc_vec3 n) {
  bbc_vec3 d = v3_sub(b, a);
  double t = v3_dot(v3_sub(p, a), n) / v3_dot(d, n);
  return v3_add(a, v3_scale(d, t));
}

static double edge_distance(const double u[2]) {
  return fmin(fmin(u[0], u[1]), 1 - u[0] - u[1]);
}

/* Every returned solution must trace back to x_k: admissible, and its exact path lands
 * on x_k. Returns the number of failures. */
static int check_solutions_trace_back(const bbc_path_geometry *g, bbc_vec3 xk,
                                      const bbc_solution *s, size_t n) {
  int bad = 0;
  for (size_t i = 0; i < n; i++) {
    bbc_specular_path p;
    if (bbc_specular_path_trace(g, s[i].u1[0], s[i].u1[1], &p) != BBC_OK || !p.complete) {
      bad++;
      continue;
    }
    double scale = 1.0 + v3_length(v3_sub(xk, p.x1));
    if (v3_length(v3_sub(p.xk, xk)) > 1e-8 * scale) bad++;
    if (p.flags & (BBC_PATH_BACK_SIDE | BBC_PATH_TIR | BBC_PATH_BACKWARD | BBC_PATH_DEGENERATE))
      bad++;
    if (edge_distance(s[i].u1) < -1e-9) bad++;
    if (!(fabs(p.irradiance - s[i].irradiance) <= 1e-12 * fabs(p.irradiance))) bad++;
  }
  return bad;
}

/* ------------------------------------------------------------------------------------ */
/* Flat mirror: the reflection point is where the line from the mirrored light to x_k
 * crosses the mirror's plane. */

TEST(flat_mirror_analytic) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 1.2, 0.3);
  g.intensity = 4.0;
  g.length = 1;
  flat_specular(&g.specular[0], v3(0, 0, -2), v3(0, 0, 2), v3(0, 2.5, 0), v3(1, 0, 0), 0, 1.5);
  set_tri(g.receiver, v3(-1, 0, -8), v3(8, 0, 0), v3(-1, 0, 8));
  bbc_vec3 image = mirror_point(g.light, v3(0, 0, 0), v3(1, 0, 0));
  int inside = 0, outside = 0;
  for (int i = 0; i < 3000; i++) {
    bbc_vec3 xk = v3(0.05 + 4 * rnd(), 0, -4 + 8 * rnd());
    bbc_vec3 x1 = line_plane(image, xk, v3(0, 0, 0), v3(1, 0, 0));
    double ub[2];
    REQUIRE(bbc_triangle_barycentrics(g.specular[0].p, x1, ub));
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n = 99;
    REQUIRE(bbc_solver_single(&g, xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    double margin = edge_distance(ub);
    if (margin > 1e-7) {
      inside++;
      CHECK_INT(n, 1);
      if (n >= 1) {
        CHECK_NEAR(sol[0].u1[0], ub[0], 1e-12);
        CHECK_NEAR(sol[0].u1[1], ub[1], 1e-12);
        bbc_vec3 d = v3_sub(image, xk);
        double r = v3_length(d);
        CHECK(fabs(sol[0].irradiance - g.intensity * d.y / (r * r * r)) <=
              1e-11 * sol[0].irradiance);
      }
    } else if (margin < -1e-7) {
      outside++;
      CHECK_INT(n, 0);
    }
    CHECK_INT(check_solutions_trace_back(&g, xk, sol, n), 0);
  }
  CHECK(inside > 300 && outside > 300);
}

/* ------------------------------------------------------------------------------------ */
/* Flat refraction: the oracle solves Snell's law along the azimuth by bisection. */

/* The horizontal distance from the light's foot to x1, for a light at height h above a
 * flat interface (index ior below) and a point at depth `depth` below it at horizontal
 * distance R: r1 + depth tan(theta1) = R, theta1 from sin(theta0) = ior sin(theta1),
 * tan(theta0) = r1 / h. The left side grows with r1, so bisection finds it. */
static double snell_radius(double h, double depth, double ior, double R) {
  double lo = 0, hi = R;
  for (int i = 0; i < 200; i++) {
    double r1 = 0.5 * (lo + hi);
    double s0 = r1 / sqrt(r1 * r1 + h * h), s1 = s0 / ior;
    /* Past the critical angle (leaving the denser side) the ray does not get through:
     * the root lies closer in. */
    double f = s1 >= 1 ? 1 : r1 + depth * s1 / sqrt(1 - s1 * s1) - R;
    if (f > 0)
      hi = r1;
    else
      lo = r1;
  }
  return 0.5 * (lo + hi);
}

static void refraction_oracle_case(double h, double depth, double ior_entering, int light_below) {
  /* The interface y = 0 with normals +y. Light above (entering, eta = 1/ior) or below it
   * (leaving, eta = ior): the oracle's "index below" is the index on x_k's side relative
   * to the light's side. */
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  double sign = light_below ? -1 : 1;
  g.light = v3(0.15, sign * h, -0.2);
  g.intensity = 1.0;
  g.length = 1;
  flat_specular(&g.specular[0], v3(-3, 0, -3), v3(3, 0, -3), v3(0.2, 0, 3.5), v3(0, 1, 0), 1,
                ior_entering);
  double yk = -sign * depth;
  set_tri(g.receiver, v3(-30, yk, -30), v3(30, yk, -30), v3(0, yk, 30));
  double rel_ior = light_below ? 1.0 / ior_entering : ior_entering;
  int found = 0, expected = 0;
  for (int i = 0; i < 2000; i++) {
    bbc_vec3 xk = v3(-3 + 6 * rnd(), yk, -3 + 6 * rnd());
    double dx = xk.x - g.light.x, dz = xk.z - g.light.z, R = hypot(dx, dz);
    double r1 = snell_radius(h, depth, rel_ior, R);
    /* Leaving the denser side, the angle of x1 is limited by the critical angle; beyond
     * the receiver's reach the oracle's bisection ends at R. */
    bbc_vec3 x1 = v3(g.light.x + dx * r1 / R, 0, g.light.z + dz * r1 / R);
    double ub[2];
    REQUIRE(bbc_triangle_barycentrics(g.specular[0].p, x1, ub));
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n;
    REQUIRE(bbc_solver_single(&g, xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    CHECK_INT(check_solutions_trace_back(&g, xk, sol, n), 0);
    double margin = edge_distance(ub);
    if (margin > 1e-7) {
      expected++;
      CHECK_INT(n, 1);
      if (n == 1) {
        found++;
        CHECK_NEAR(sol[0].u1[0], ub[0], 1e-9);
        CHECK_NEAR(sol[0].u1[1], ub[1], 1e-9);
      }
    } else if (margin < -1e-7) {
      CHECK_INT(n, 0);
    }
  }
  CHECK(expected > 500);
  CHECK_INT(found, expected);
}

TEST(flat_refraction_entering) {
  refraction_oracle_case(1.3, 0.9, 1.33, 0);
}

TEST(flat_refraction_leaving) {
  refraction_oracle_case(0.8, 1.1, 1.5, 1);
}

/* ------------------------------------------------------------------------------------ */
/* Round trips on scenes: sample u1 on a caster triangle, trace the exact path to the
 * receiver, then solve for that x_k and demand u1 back. */

typedef struct round_trip_stats {
  long samples, recovered, missed, extra, bad;
} round_trip_stats;

/* The receiver triangle the path through u1 lands in, with g's specular part fixed and
 * g->receiver set to it; -1 if the path is not admissible on any receiver triangle. */
static int land(bbc_path_geometry *g, const bbc_scene *s, const uint32_t *recv, uint32_t nr,
                double u, double v, bbc_specular_path *out) {
  for (uint32_t k = 0; k < nr; k++) {
    const uint32_t *idx = s->indices + 3 * (size_t)recv[k];
    for (int j = 0; j < 3; j++) g->receiver[j] = v3_load(s->positions + 3 * (size_t)idx[j]);
    if (bbc_specular_path_trace(g, u, v, out) == BBC_OK && out->complete &&
        !(out->flags & BBC_PATH_REJECT))
      return (int)k;
  }
  return -1;
}

static void round_trip(const char *path, bbc_chain chain, long samples, round_trip_stats *rt,
                       bbc_solver_stats *stats) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, path, NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  REQUIRE(nc > 0 && nr > 0);
  bbc_solver_options opts;
  memset(&opts, 0, sizeof opts);
  opts.stats = stats;
  int reported = 0;
  for (long attempt = 0; rt->samples < samples && attempt < 50 * samples; attempt++) {
    bbc_tuple t = {0, chain, {casters[(uint32_t)(rnd() * nc)], BBC_NO_TRIANGLE}, receivers[0]};
    bbc_path_geometry g;
    REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    if (land(&g, s, receivers, nr, u, v, &p) < 0) continue;
    rt->samples++;
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n;
    REQUIRE(bbc_solver_single(&g, p.xk, &opts, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    int hit = 0;
    for (size_t i = 0; i < n; i++)
      if (fabs(sol[i].u1[0] - u) <= 1e-6 && fabs(sol[i].u1[1] - v) <= 1e-6) hit = 1;
    if (hit) {
      rt->recovered++;
    } else {
      rt->missed++;
      if (reported++ < 10) {
        fprintf(stderr,
                "  miss: triangle %u u1 (%.17g, %.17g) edge %.3g, |det| %.3g, E %.6g, "
                "cos_i %.4f, %zu solutions\n",
                t.specular[0], u, v, edge_distance(p.u1), p.jacobian, p.irradiance,
                fabs(v3_dot(v3_normalize(v3_sub(p.x1, p.x0)), p.n1)), n);
      }
    }
    rt->extra += (long)n - hit;
    rt->bad += check_solutions_trace_back(&g, p.xk, sol, n);
  }
  fprintf(stderr,
          "%s %s: %ld round trips, %ld recovered (%.4f %%), %ld missed, %ld other solutions, "
          "%ld failed trace-back\n",
          path, bbc_chain_name(chain), rt->samples, rt->recovered,
          100.0 * (double)rt->recovered / (double)(rt->samples ? rt->samples : 1), rt->missed,
          rt->extra, rt->bad);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

static void print_stats(const bbc_solver_stats *s) {
  fprintf(
      stderr,
      "  solver: %llu solves, %.2f resultant roots, %.2f candidates, %.2f Newton iterations "
      "per solve; rejected: %llu not converged, %llu inadmissible; %llu duplicates, %llu "
      "fallbacks\n",
      (unsigned long long)s->solves, (double)s->resultant_roots / (double)s->solves,
      (double)s->candidates / (double)s->solves, (double)s->newton_iterations / (double)s->solves,
      (unsigned long long)s->rejected_not_converged, (unsigned long long)s->rejected_inadmissible,
      (unsigned long long)s->duplicates, (unsigned long long)s->fallbacks);
}

static void round_trip_test(const char *path, bbc_chain chain, long samples) {
  round_trip_stats rt = {0};
  bbc_solver_stats st = {0};
  round_trip(path, chain, samples, &rt, &st);
  print_stats(&st);
  CHECK(rt.samples == samples);
  CHECK_INT(rt.bad, 0);
  /* About 100 %: a miss is tolerated only at the rate of a near-degenerate sample
   * (grazing light or a focal point), one in ten thousand. */
  CHECK(rt.missed <= samples / 10000);
}

/* Suns (constant d0) and spots through the polynomial solver: curved reflection and
 * refraction. */
TEST(round_trip_sun_and_spot) {
  round_trip_test(TEST_SCENE("wavy-mirror-sun.gltf"), BBC_CHAIN_R, harness_scale(5000, 200000));
  round_trip_test(TEST_SCENE("pool-sun.gltf"), BBC_CHAIN_T, harness_scale(5000, 200000));
  round_trip_test(TEST_SCENE("pool-spot.gltf"), BBC_CHAIN_T, harness_scale(5000, 200000));
}

TEST(round_trip_plane1k) {
  round_trip_test(TEST_SCENE("plane1k.gltf"), BBC_CHAIN_R, harness_scale(20000, 500000));
}

TEST(round_trip_pool4k) {
  round_trip_test(TEST_SCENE("pool4k.gltf"), BBC_CHAIN_T, harness_scale(20000, 500000));
}

/* The generated scenes with strongly curved normals. */
TEST(round_trip_wavy_mirror) {
  round_trip_test(TEST_SCENE("wavy-mirror.gltf"), BBC_CHAIN_R, harness_scale(3000, 100000));
}

TEST(round_trip_pool) {
  round_trip_test(TEST_SCENE("pool.gltf"), BBC_CHAIN_T, harness_scale(3000, 100000));
}

TEST(round_trip_sphere_t) {
  round_trip_test(TEST_SCENE("glass-sphere.gltf"), BBC_CHAIN_T, harness_scale(2000, 50000));
}

/* Random configurations: triangles from 1e-3 to 1 across with normals tilted up to about
 * 30 degrees off the face (strongly curved), random lights and receiver planes, for both
 * reflection and refraction (ior 1.2 to 2). These reach grazing incidence, focal regions
 * and tuples with several solutions, which the scene-based round trips rarely do. */
static bbc_vec3 rnd_vec(double s) {
  return v3(s * (2 * rnd() - 1), s * (2 * rnd() - 1), s * (2 * rnd() - 1));
}

static void random_round_trips(int refract, long samples) {
  long done = 0, recovered = 0, bad = 0;
  int reported = 0;
  for (long attempt = 0; done < samples && attempt < 100 * samples; attempt++) {
    bbc_path_geometry g;
    memset(&g, 0, sizeof g);
    g.length = 1;
    g.intensity = 1;
    bbc_specular_triangle *t = &g.specular[0];
    double size = pow(10.0, -3 + 3 * rnd());
    for (int j = 0; j < 3; j++) t->p[j] = rnd_vec(size);
    bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(t->p[1], t->p[0]), v3_sub(t->p[2], t->p[0])));
    for (int j = 0; j < 3; j++) t->n[j] = v3_normalize(v3_add(ng, rnd_vec(0.3)));
    t->refract = refract;
    t->ior = 1.2 + 0.8 * rnd();
    g.light = rnd_vec(3);
    bbc_vec3 rn = v3_normalize(rnd_vec(1)), rp = rnd_vec(2), a, b;
    v3_basis(rn, &a, &b);
    g.receiver[0] = v3_add(rp, v3_scale(a, -50));
    g.receiver[1] = v3_add(rp, v3_add(v3_scale(a, 50), v3_scale(b, -50)));
    g.receiver[2] = v3_add(rp, v3_scale(b, 50));
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (!p.complete || (p.flags & BBC_PATH_REJECT)) continue;
    done++;
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n;
    REQUIRE(bbc_solver_single(&g, p.xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    int hit = 0;
    for (size_t i = 0; i < n; i++)
      hit |= fabs(sol[i].u1[0] - u) <= 1e-6 && fabs(sol[i].u1[1] - v) <= 1e-6;
    recovered += hit;
    if (!hit && reported++ < 10)
      fprintf(stderr, "  miss: size %.3g u1 (%.6f, %.6f) cos_i %.3g |det| %.3g, %zu solutions\n",
              size, u, v, fabs(v3_dot(v3_normalize(v3_sub(p.x1, p.x0)), p.n1)), p.jacobian, n);
    bad += check_solutions_trace_back(&g, p.xk, sol, n);
  }
  fprintf(stderr, "random %s: %ld round trips, %ld recovered (%.4f %%), %ld failed trace-back\n",
          refract ? "T" : "R", done, recovered, 100.0 * (double)recovered / (double)done, bad);
  CHECK(done == samples);
  CHECK_INT(bad, 0);
  CHECK(done - recovered <= samples / 10000);
}

TEST(round_trip_random_reflection) {
  random_round_trips(0, harness_scale(20000, 500000));
}

TEST(round_trip_random_refraction) {
  random_round_trips(1, harness_scale(20000, 500000));
}

/* Mirrors with three equal vertex normals are solved in closed form; the polynomial
 * solver (no_closed_form) must find the same paths on random configurations: triangles
 * of 1e-3 to 1 across, the one normal the face's or tilted up to about 30 degrees off it,
 * lights anywhere, and x_k both where a traced path lands (a solution exists) and at
 * random (mostly none). Solutions closer than 1e-7 to T1's edges may be found by one
 * solver and not the other (the polynomial one polishes by clamped Newton) and are not
 * compared. */
static int interior_count(const bbc_solution *s, size_t n) {
  int k = 0;
  for (size_t i = 0; i < n; i++) k += edge_distance(s[i].u1) > 1e-7;
  return k;
}

TEST(flat_mirror_closed_form_agrees_with_poly) {
  const long samples = harness_scale(20000, 500000);
  long compared = 0, with_paths = 0, two = 0, mismatched = 0;
  bbc_solver_options poly;
  memset(&poly, 0, sizeof poly);
  poly.no_closed_form = 1;
  for (long i = 0; i < samples; i++) {
    bbc_path_geometry g;
    memset(&g, 0, sizeof g);
    g.length = 1;
    g.intensity = 1;
    bbc_specular_triangle *t = &g.specular[0];
    double size = pow(10.0, -3 + 3 * rnd());
    for (int j = 0; j < 3; j++) t->p[j] = rnd_vec(size);
    bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(t->p[1], t->p[0]), v3_sub(t->p[2], t->p[0])));
    bbc_vec3 n = i % 2 ? ng : v3_normalize(v3_add(ng, rnd_vec(0.3)));
    for (int j = 0; j < 3; j++) t->n[j] = n;
    g.light = rnd_vec(3);
    bbc_vec3 rn = v3_normalize(rnd_vec(1)), rp = rnd_vec(2), a, b;
    v3_basis(rn, &a, &b);
    g.receiver[0] = v3_add(rp, v3_scale(a, -50));
    g.receiver[1] = v3_add(rp, v3_add(v3_scale(a, 50), v3_scale(b, -50)));
    g.receiver[2] = v3_add(rp, v3_scale(b, 50));
    bbc_vec3 xk = v3_add(rp, v3_add(v3_scale(a, 4 * rnd() - 2), v3_scale(b, 4 * rnd() - 2)));
    if (i % 4 < 2) {
      double u, v;
      rnd_bary(&u, &v);
      bbc_specular_path p;
      REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
      if (!p.complete || (p.flags & BBC_PATH_REJECT)) continue;
      xk = p.xk;
    }
    bbc_solution s1[BBC_SOLVER_MAX_SOLUTIONS], s2[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n1, n2;
    REQUIRE(bbc_solver_single(&g, xk, NULL, s1, BBC_SOLVER_MAX_SOLUTIONS, &n1) == BBC_OK);
    REQUIRE(bbc_solver_single(&g, xk, &poly, s2, BBC_SOLVER_MAX_SOLUTIONS, &n2) == BBC_OK);
    compared++;
    with_paths += n1 > 0;
    two += n1 > 1;
    int bad = interior_count(s1, n1) != interior_count(s2, n2);
    for (size_t k = 0; k < n1 && !bad; k++) {
      if (edge_distance(s1[k].u1) <= 1e-7) continue;
      int same = 0;
      /* The same reflection point up to 1e-6 of the path's length, the same irradiance
       * up to 1e-6 (both land on x_k: checked below). Grazing and near-fold cases are
       * ill-conditioned: there the polynomial solver's polish stops where x_k is missed
       * by ~1e-11 and u1 is off by up to 1e-4 of a small triangle, while the closed form
       * lands within 1e-14 (seen at BBC_TEST_FULL=1). */
      double scale = v3_length(v3_sub(s1[k].x1, g.light)) + v3_length(v3_sub(xk, s1[k].x1));
      for (size_t m = 0; m < n2; m++)
        same |= v3_length(v3_sub(s1[k].x1, s2[m].x1)) <= 1e-6 * scale &&
                fabs(s1[k].irradiance - s2[m].irradiance) <= 1e-6 * s2[m].irradiance;
      bad = !same;
    }
    if (bad && mismatched++ < 5) {
      fprintf(stderr, "  mismatch: size %.3g, %zu closed-form vs %zu polynomial solutions\n",
              size, n1, n2);
      for (size_t k = 0; k < n1 + n2; k++) {
        const bbc_solution *q = k < n1 ? &s1[k] : &s2[k - n1];
        fprintf(stderr, "    %s (%.12f, %.12f) E %.9g, misses x_k by %.3g\n",
                k < n1 ? "closed form" : "polynomial ", q->u1[0], q->u1[1], q->irradiance,
                v3_length(v3_sub(q->path.xk, xk)));
      }
    }
    CHECK_INT(check_solutions_trace_back(&g, xk, s1, n1), 0);
    CHECK_INT(check_solutions_trace_back(&g, xk, s2, n2), 0);
  }
  fprintf(stderr, "flat mirrors: %ld compared, %ld with paths, %ld with two, %ld mismatched\n",
          compared, with_paths, two, mismatched);
  CHECK(compared > samples / 2 && with_paths > samples / 10 && two > 0);
  CHECK_INT(mismatched, 0);
}

/* The pre-test (bbc_solver_single_possible: coplanarity, the reflection's direction, the
 * refraction's side and Snell's law) never rules out a point that a path reaches, and
 * rules out a good share of random points, all of which the solver
 * (with the pre-test bypassed by calling it on the same geometry) confirms hold no path
 * but at T1's edges. Curved random triangles, reflection and refraction, point lights
 * and suns. */
TEST(single_pretest_is_exact) {
  const long samples = harness_scale(20000, 400000);
  long traced = 0, suns = 0, wrongly_excluded = 0, random_points = 0, excluded = 0,
       solved_excluded = 0, refracted_points = 0, refracted_excluded = 0;
  for (long i = 0; i < samples; i++) {
    bbc_path_geometry g;
    memset(&g, 0, sizeof g);
    g.length = 1;
    g.intensity = 1;
    bbc_specular_triangle *t = &g.specular[0];
    double size = pow(10.0, -3 + 3 * rnd());
    for (int j = 0; j < 3; j++) t->p[j] = rnd_vec(size);
    bbc_vec3 ng = v3_normalize(v3_cross(v3_sub(t->p[1], t->p[0]), v3_sub(t->p[2], t->p[0])));
    for (int j = 0; j < 3; j++) t->n[j] = v3_normalize(v3_add(ng, rnd_vec(0.3)));
    t->refract = i % 2;
    t->ior = 1.2 + 0.8 * rnd();
    g.light = rnd_vec(3);
    if (i % 3 == 2) { /* a sun */
      g.light_model.kind = BBC_LIGHT_DIRECTIONAL;
      g.light_model.direction = v3_normalize(rnd_vec(1));
    }
    bbc_vec3 rn = v3_normalize(rnd_vec(1)), rp = rnd_vec(2), a, b;
    v3_basis(rn, &a, &b);
    g.receiver[0] = v3_add(rp, v3_scale(a, -50));
    g.receiver[1] = v3_add(rp, v3_add(v3_scale(a, 50), v3_scale(b, -50)));
    g.receiver[2] = v3_add(rp, v3_scale(b, 50));
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    REQUIRE(bbc_specular_path_trace(&g, u, v, &p) == BBC_OK);
    if (p.complete && !(p.flags & BBC_PATH_REJECT)) {
      traced++;
      suns += i % 3 == 2;
      if (!bbc_solver_single_possible(&g, p.xk, NULL)) wrongly_excluded++;
    }
    /* A random point near where the path lands (or near the receiver's centre). */
    bbc_vec3 xk = v3_add(p.complete ? p.xk : rp,
                         v3_add(v3_scale(a, 2 * rnd() - 1), v3_scale(b, 2 * rnd() - 1)));
    random_points++;
    refracted_points += t->refract;
    if (bbc_solver_single_possible(&g, xk, NULL)) continue;
    excluded++;
    refracted_excluded += t->refract;
    /* The polynomial solve itself, without the pre-test: a solution far from T1's
     * edges would mean the pre-test was wrong. */
    bbc_solver_options opts;
    memset(&opts, 0, sizeof opts);
    opts.no_pretest = 1;
    opts.no_closed_form = 1;
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
    size_t n;
    REQUIRE(bbc_solver_single(&g, xk, &opts, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    for (size_t k = 0; k < n; k++) solved_excluded += edge_distance(sol[k].u1) > 1e-7;
  }
  fprintf(stderr,
          "%ld traced paths (%ld from suns), %ld wrongly excluded; %ld random points, %ld "
          "excluded (%.1f %%; refraction %.1f %%), %ld of them with a solution\n",
          traced, suns, wrongly_excluded, random_points, excluded, 100.0 * excluded / random_points,
          100.0 * refracted_excluded / refracted_points, solved_excluded);
  CHECK(traced > samples / 10 && suns > samples / 50);
  CHECK_INT(wrongly_excluded, 0);
  CHECK_INT(solved_excluded, 0);
  CHECK(excluded > random_points / 10);
  /* Coplanarity alone rules out about 68 % of the refraction points; with the
   * transmission side and Snell's law on T1 and its quarters, 90 %. */
  CHECK(refracted_excluded * 10 > refracted_points * 8);
}

/* ------------------------------------------------------------------------------------ */

TEST(no_path_returns_zero) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 1.2, 0.3);
  g.intensity = 1.0;
  g.length = 1;
  flat_specular(&g.specular[0], v3(0, 0, -2), v3(0, 0, 2), v3(0, 2.5, 0), v3(1, 0, 0), 0, 1.5);
  set_tri(g.receiver, v3(-8, 0, -8), v3(8, 0, 0), v3(-8, 0, 8));
  bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
  size_t n = 99;
  /* Behind the mirror. */
  REQUIRE(bbc_solver_single(&g, v3(-1, 0, 0), NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
  CHECK_INT(n, 0);
  /* In front, but the reflection point would be far off the triangle. */
  REQUIRE(bbc_solver_single(&g, v3(2, 0, 7), NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
  CHECK_INT(n, 0);
  /* The light behind the mirror: no reflection at all. */
  bbc_path_geometry back = g;
  back.light = v3(-1, 1.2, 0.3);
  REQUIRE(bbc_solver_single(&back, v3(-2, 0, 0.2), NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) ==
          BBC_OK);
  CHECK_INT(n, 0);
  /* Refraction to a point on the light's own side. */
  bbc_path_geometry t = g;
  t.specular[0].refract = 1;
  REQUIRE(bbc_solver_single(&t, v3(2, 0, 0.3), NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
  CHECK_INT(n, 0);
  /* Refraction through the wall to the far side works, as a control. */
  REQUIRE(bbc_solver_single(&t, v3(-2, 0, 0.3), NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
  CHECK_INT(n, 1);
  /* A small capacity truncates, count says how many were written. */
  REQUIRE(bbc_solver_single(&t, v3(-2, 0, 0.3), NULL, NULL, 0, &n) == BBC_OK);
  CHECK_INT(n, 0);
}

/* Light and shading point on one normal line of a flat mirror: the coplanarity
 * polynomial vanishes identically and the solver must still find the foot point. */
TEST(degenerate_normal_line) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 1.0, 0.2);
  g.intensity = 1.0;
  g.length = 1;
  flat_specular(&g.specular[0], v3(0, 0, -2), v3(0, 0, 2), v3(0, 2.5, 0), v3(1, 0, 0), 0, 1.5);
  set_tri(g.receiver, v3(0.5, -5, -5), v3(0.5, 5, 0), v3(0.5, -5, 5));
  bbc_vec3 xk = v3(0.5, 1.0, 0.2);
  bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
  size_t n;
  bbc_solver_stats stats;
  memset(&stats, 0, sizeof stats);
  bbc_solver_options opts;
  memset(&opts, 0, sizeof opts);
  opts.stats = &stats;
  /* The polynomial solver falls back to Newton; the closed form needs no fallback. */
  for (int closed = 0; closed < 2; closed++) {
    opts.no_closed_form = !closed;
    memset(&stats, 0, sizeof stats);
    REQUIRE(bbc_solver_single(&g, xk, &opts, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    CHECK_INT(stats.fallbacks, !closed);
    CHECK_INT(n, 1);
    if (n == 1) {
      CHECK_NEAR(sol[0].x1.y, 1.0, 1e-9);
      CHECK_NEAR(sol[0].x1.z, 0.2, 1e-9);
    }
  }
}

/* ------------------------------------------------------------------------------------ */
/* Newton on the chain. */

/* Double reflection off two flat mirrors: x2 lies on the line from the doubly mirrored
 * light to x_k, x1 on the line from the singly mirrored light to x2. */
TEST(newton_rr_two_mirrors) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(1.0, 2.5, 3.0);
  g.intensity = 1.0;
  g.length = 2;
  flat_specular(&g.specular[0], v3(0, 0, 0.2), v3(0, 0, 3), v3(0, 3, 1.5), v3(1, 0, 0), 0, 1);
  flat_specular(&g.specular[1], v3(-1, 0, 0), v3(8, 0, 0), v3(3, 5, 0), v3(0, 0, 1), 0, 1);
  set_tri(g.receiver, v3(-10, 0, -10), v3(-10, 0, 10), v3(10, 0, 0));
  bbc_vec3 image1 = mirror_point(g.light, v3(0, 0, 0), v3(1, 0, 0));
  bbc_vec3 image2 = mirror_point(image1, v3(0, 0, 0), v3(0, 0, 1));
  int expected = 0, found_centres = 0;
  for (int i = 0; i < 2000; i++) {
    bbc_vec3 xk = v3(6 * rnd(), 0, 6 * rnd());
    bbc_vec3 x2 = line_plane(image2, xk, v3(0, 0, 0), v3(0, 0, 1));
    bbc_vec3 x1 = line_plane(image1, x2, v3(0, 0, 0), v3(1, 0, 0));
    double u1[2], u2[2];
    REQUIRE(bbc_triangle_barycentrics(g.specular[0].p, x1, u1));
    REQUIRE(bbc_triangle_barycentrics(g.specular[1].p, x2, u2));
    bbc_solution s;
    int found;
    REQUIRE(bbc_solver_newton_centre(&g, xk, NULL, &s, &found) == BBC_OK);
    if (found) {
      CHECK_INT(check_solutions_trace_back(&g, xk, &s, 1), 0);
      CHECK_NEAR(s.u1[0], u1[0], 1e-9);
      CHECK_NEAR(s.u1[1], u1[1], 1e-9);
      CHECK_NEAR(s.u2[0], u2[0], 1e-9);
      CHECK_NEAR(s.u2[1], u2[1], 1e-9);
      bbc_vec3 d = v3_sub(image2, xk);
      double r = v3_length(d);
      CHECK(fabs(s.irradiance - fabs(d.y) / (r * r * r)) <= 1e-11 * s.irradiance);
    }
    if (edge_distance(u1) > 1e-7 && edge_distance(u2) > 1e-7) {
      expected++;
      found_centres += found;
    } else if (edge_distance(u1) < -1e-7 || edge_distance(u2) < -1e-7) {
      CHECK(!found);
    }
  }
  fprintf(stderr, "RR two flat mirrors: %d of %d found from the centres\n", found_centres,
          expected);
  CHECK(expected > 200);
  /* Flat mirrors make the constraint nearly linear: Newton always converges. */
  CHECK_INT(found_centres, expected);
}

/* A glass slab with flat faces (TT): the oracle solves R = (h + D) tan(theta0) +
 * T tan(theta1) by bisection. */
TEST(newton_tt_flat_slab) {
  const double h = 1.1, thick = 0.4, depth = 0.7, ior = 1.5;
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.light = v3(-0.2, h, 0.3);
  g.intensity = 1.0;
  g.length = 2;
  flat_specular(&g.specular[0], v3(-4, 0, -4), v3(4, 0, -4), v3(0, 0, 4), v3(0, 1, 0), 1, ior);
  flat_specular(&g.specular[1], v3(-9, -thick, -9), v3(0, -thick, 9), v3(9, -thick, -9),
                v3(0, -1, 0), 1, ior);
  double yk = -thick - depth;
  set_tri(g.receiver, v3(-20, yk, -20), v3(20, yk, -20), v3(0, yk, 20));
  int expected = 0, found_centres = 0;
  for (int i = 0; i < 1000; i++) {
    bbc_vec3 xk = v3(-3 + 6 * rnd(), yk, -3 + 6 * rnd());
    double dx = xk.x - g.light.x, dz = xk.z - g.light.z, R = hypot(dx, dz);
    /* Bisection on theta0 in [0, pi/2). */
    double lo = 0, hi = 1.5707963267948966;
    for (int k = 0; k < 200; k++) {
      double t0 = 0.5 * (lo + hi), t1 = asin(sin(t0) / ior);
      if ((h + depth) * tan(t0) + thick * tan(t1) > R)
        hi = t0;
      else
        lo = t0;
    }
    double r1 = h * tan(0.5 * (lo + hi));
    bbc_vec3 x1 = v3(g.light.x + dx * r1 / R, 0, g.light.z + dz * r1 / R);
    double u1[2];
    REQUIRE(bbc_triangle_barycentrics(g.specular[0].p, x1, u1));
    bbc_solution s;
    int found;
    REQUIRE(bbc_solver_newton_centre(&g, xk, NULL, &s, &found) == BBC_OK);
    if (edge_distance(u1) > 1e-7) {
      expected++;
      found_centres += found;
      if (found) {
        CHECK_NEAR(s.u1[0], u1[0], 1e-9);
        CHECK_NEAR(s.u1[1], u1[1], 1e-9);
        CHECK_INT(check_solutions_trace_back(&g, xk, &s, 1), 0);
      }
    }
  }
  fprintf(stderr, "TT flat slab: %d of %d found from the centres\n", found_centres, expected);
  CHECK(expected > 500);
  CHECK_INT(found_centres, expected);
}

/* Newton on single scattering agrees with the polynomial solver wherever it converges. */
TEST(newton_single_agrees_with_poly) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("plane1k.gltf"), NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  long samples = harness_scale(2000, 50000), done = 0, newton_found = 0;
  for (long attempt = 0; done < samples && attempt < 50 * samples; attempt++) {
    bbc_tuple t = {
        0, BBC_CHAIN_R, {casters[(uint32_t)(rnd() * nc)], BBC_NO_TRIANGLE}, receivers[0]};
    bbc_path_geometry g;
    REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
    double u, v;
    rnd_bary(&u, &v);
    bbc_specular_path p;
    if (land(&g, s, receivers, nr, u, v, &p) < 0) continue;
    done++;
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS], ns;
    size_t n;
    int found;
    REQUIRE(bbc_solver_single(&g, p.xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &n) == BBC_OK);
    REQUIRE(bbc_solver_newton_centre(&g, p.xk, NULL, &ns, &found) == BBC_OK);
    if (!found) continue;
    newton_found++;
    int match = 0;
    for (size_t i = 0; i < n; i++)
      match |= fabs(sol[i].u1[0] - ns.u1[0]) <= 1e-8 && fabs(sol[i].u1[1] - ns.u1[1]) <= 1e-8;
    CHECK(match);
  }
  fprintf(stderr, "plane1k R: Newton from the centre found %ld of %ld\n", newton_found, done);
  CHECK(newton_found > done * 9 / 10);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

/* Double refraction through the generated glass slab (wavy top, flat bottom): sample a
 * path, then recover it with Newton from the centres and from random starts. */
TEST(newton_tt_glass_slab_round_trip) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("glass-slab.gltf"), NULL) == BBC_OK);
  uint32_t *casters, *receivers;
  uint32_t nc = role_triangles(s, BBC_ROLE_CASTER, &casters);
  uint32_t nr = role_triangles(s, BBC_ROLE_RECEIVER, &receivers);
  /* The top faces (normals up) and the two bottom triangles (normals down). */
  uint32_t *top = malloc(sizeof(uint32_t) * nc), bottom[2], ntop = 0, nbottom = 0;
  for (uint32_t i = 0; i < nc; i++) {
    const uint32_t *idx = s->indices + 3 * (size_t)casters[i];
    double ny = s->normals[3 * (size_t)idx[0] + 1];
    double py = s->positions[3 * (size_t)idx[0] + 1];
    if (ny > 0.5)
      top[ntop++] = casters[i];
    else if (ny < -0.99 && py < 0.51 && nbottom < 2)
      bottom[nbottom++] = casters[i];
  }
  REQUIRE(ntop > 100 && nbottom == 2);
  long samples = harness_scale(1000, 20000), done = 0, det_found = 0, det_same = 0, stoc_found = 0,
       stoc_same = 0;
  for (long attempt = 0; done < samples && attempt < 50 * samples; attempt++) {
    uint32_t t1 = top[(uint32_t)(rnd() * ntop)];
    double u, v;
    rnd_bary(&u, &v);
    bbc_path_geometry g;
    bbc_specular_path p;
    int ok = 0;
    for (int b = 0; b < 2 && !ok; b++) {
      bbc_tuple t = {0, BBC_CHAIN_TT, {t1, bottom[b]}, receivers[0]};
      REQUIRE(bbc_path_geometry_init(&g, s, &t) == BBC_OK);
      ok = land(&g, s, receivers, nr, u, v, &p) >= 0;
    }
    if (!ok) continue;
    done++;
    bbc_solution sol;
    int found;
    REQUIRE(bbc_solver_newton_centre(&g, p.xk, NULL, &sol, &found) == BBC_OK);
    if (found) {
      det_found++;
      det_same += fabs(sol.u1[0] - u) <= 1e-6 && fabs(sol.u1[1] - v) <= 1e-6;
      CHECK_INT(check_solutions_trace_back(&g, p.xk, &sol, 1), 0);
    }
    double r1[2];
    rnd_bary(&r1[0], &r1[1]);
    REQUIRE(bbc_solver_newton(&g, p.xk, r1, NULL, &sol, &found) == BBC_OK);
    if (found) {
      stoc_found++;
      stoc_same += fabs(sol.u1[0] - u) <= 1e-6 && fabs(sol.u1[1] - v) <= 1e-6;
      CHECK_INT(check_solutions_trace_back(&g, p.xk, &sol, 1), 0);
    }
  }
  fprintf(stderr,
          "glass-slab TT: %ld paths; from the centres %ld found (%ld the sampled one), from "
          "random starts %ld found (%ld the sampled one)\n",
          done, det_found, det_same, stoc_found, stoc_same);
  CHECK(done == samples);
  CHECK(det_found >= done * 95 / 100);
  free(top);
  free(casters);
  free(receivers);
  bbc_scene_free(s);
}

TEST(invalid_arguments) {
  bbc_path_geometry g;
  memset(&g, 0, sizeof g);
  g.length = 2;
  bbc_solution sol[2];
  size_t n = 5;
  CHECK_INT(bbc_solver_single(&g, v3(0, 0, 0), NULL, sol, 2, &n), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(n, 0);
  g.length = 1;
  CHECK_INT(bbc_solver_single(NULL, v3(0, 0, 0), NULL, sol, 2, &n), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_solver_single(&g, v3(NAN, 0, 0), NULL, sol, 2, &n), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_solver_single(&g, v3(0, 0, 0), NULL, NULL, 2, &n), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(bbc_solver_single(&g, v3(0, 0, 0), NULL, sol, 2, NULL), BBC_ERR_INVALID_ARGUMENT);
  int found = 7;
  double c[2] = {0.3, 0.3};
  g.length = 2;
  CHECK_INT(bbc_solver_newton(&g, v3(0, 0, 0), NULL, NULL, sol, &found), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(found, 0);
  CHECK_INT(bbc_solver_newton(&g, v3(0, 0, 0), c, NULL, NULL, &found), BBC_ERR_INVALID_ARGUMENT);
  CHECK_INT(found, 0);
  g.length = 3;
  CHECK_INT(bbc_solver_newton_centre(&g, v3(0, 0, 0), NULL, sol, &found), BBC_ERR_INVALID_ARGUMENT);
  /* A degenerate all-zero geometry solves to nothing rather than failing. */
  g.length = 1;
  g.receiver[1] = v3(1, 0, 0), g.receiver[2] = v3(0, 0, 1);
  CHECK_INT(bbc_solver_single(&g, v3(0, 0, 0), NULL, sol, 2, &n), BBC_OK);
  CHECK_INT(n, 0);
  CHECK_INT(bbc_solver_newton_centre(&g, v3(0, 0, 0), NULL, sol, &found), BBC_OK);
  CHECK_INT(found, 0);
}
