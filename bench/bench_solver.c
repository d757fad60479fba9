/* Throughput of the per-tuple solvers (bbc/solver.h) and of exact path tracing
 * (bbc/specular_path.h) on one core, on the shared single-scattering scenes.
 *
 *   bench_solver [plane1k.gltf [pool4k.gltf]] [--seconds S]
 *
 * Queries are built like the renderer's: a tuple (light, caster triangle, receiver
 * triangle) and a shading point x_k on the receiver. "hit" queries take x_k where the
 * exact path through a random u1 of the tuple lands, so a solution exists; "miss" queries
 * pair the tuple with the x_k of another random tuple, which nearly never has one (the
 * renderer meets both: tuples are selected by conservative bounds). Times are thread CPU
 * seconds, so the figures are per core. */
/* clock_gettime and CLOCK_THREAD_CPUTIME_ID under strict C11. */
#define _POSIX_C_SOURCE 199309L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/scene.h"
#include "bbc/solver.h"

/* The shared scenes sit next to the project: ../shared/scenes from the source tree. */
#define DEFAULT_SCENE_DIR_FROM_SOURCE "/../../shared/scenes/"

typedef struct query {
  bbc_path_geometry g;
  bbc_vec3 xk;
} query;

static uint64_t rng_state = 0x853c49e6748fea9bull;
static double rnd(void) {
  uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static double cpu_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Builds `count` hit queries of the scene's first light on its caster triangles, with
 * the chain type given. Returns the number built. */
static size_t build_queries(const bbc_scene *s, bbc_chain chain, query *out, size_t count) {
  uint32_t *casters = malloc(sizeof(uint32_t) * s->triangle_count);
  uint32_t *receivers = malloc(sizeof(uint32_t) * s->triangle_count);
  uint32_t nc = 0, nr = 0;
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    bbc_role r = s->meshes[s->triangle_mesh[t]].role;
    if (r == BBC_ROLE_CASTER) casters[nc++] = t;
    if (r == BBC_ROLE_RECEIVER) receivers[nr++] = t;
  }
  size_t n = 0;
  for (size_t attempt = 0; n < count && nc && nr && attempt < 100 * count; attempt++) {
    bbc_tuple tuple = {0, chain, {casters[(uint32_t)(rnd() * nc)], BBC_NO_TRIANGLE}, 0};
    double u = rnd(), v = rnd();
    if (u + v > 1) u = 1 - u, v = 1 - v;
    for (uint32_t k = 0; k < nr; k++) {
      tuple.receiver = receivers[k];
      query q;
      if (bbc_path_geometry_init(&q.g, s, &tuple) != BBC_OK) continue;
      bbc_specular_path p;
      if (bbc_specular_path_trace(&q.g, u, v, &p) != BBC_OK || !p.complete ||
          (p.flags & BBC_PATH_REJECT))
        continue;
      q.xk = p.xk;
      out[n++] = q;
      break;
    }
  }
  free(casters);
  free(receivers);
  return n;
}

typedef enum method { METHOD_POLY, METHOD_NEWTON, METHOD_TRACE } method;

/* Runs every query repeatedly for about `seconds` of CPU time; returns calls per second
 * and the mean number of solutions found per call. */
static double run(const query *q, size_t n, method m, double seconds, double *solutions) {
  size_t calls = 0, found_total = 0;
  double start = cpu_seconds(), elapsed = 0;
  do {
    for (size_t i = 0; i < n; i++) {
      if (m == METHOD_POLY) {
        bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
        size_t count = 0;
        bbc_solver_single(&q[i].g, q[i].xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &count);
        found_total += count;
      } else if (m == METHOD_NEWTON) {
        bbc_solution sol;
        int found = 0;
        bbc_solver_newton_centre(&q[i].g, q[i].xk, NULL, &sol, &found);
        found_total += (size_t)found;
      } else {
        bbc_specular_path p;
        bbc_specular_path_trace(&q[i].g, 0.25, 0.25, &p);
        found_total += (size_t)p.complete;
      }
    }
    calls += n;
    elapsed = cpu_seconds() - start;
  } while (elapsed < seconds);
  *solutions = (double)found_total / (double)calls;
  return (double)calls / elapsed;
}

static int bench_scene(const char *path, bbc_chain chain, double seconds) {
  bbc_scene *s = NULL;
  bbc_result r = bbc_scene_load(&s, path, NULL);
  if (r != BBC_OK) {
    fprintf(stderr, "bench_solver: %s: %s\n", path, bbc_result_string(r));
    return 1;
  }
  enum { COUNT = 20000 };
  query *hit = malloc(sizeof(query) * COUNT), *miss = malloc(sizeof(query) * COUNT);
  size_t n = build_queries(s, chain, hit, COUNT);
  /* Misses: each tuple with another query's shading point. */
  for (size_t i = 0; i < n; i++) {
    miss[i] = hit[i];
    miss[i].xk = hit[(i * 7919 + 13) % n].xk;
  }
  printf("%s (%s, %u triangles, %zu queries)\n", path, bbc_chain_name(chain), s->triangle_count, n);
  double sol;
  double rate = run(hit, n, METHOD_POLY, seconds, &sol);
  printf("  specular polynomials, hit : %10.0f solves/s per core (%.1f us), %.3f solutions\n", rate,
         1e6 / rate, sol);
  rate = run(miss, n, METHOD_POLY, seconds, &sol);
  printf("  specular polynomials, miss: %10.0f solves/s per core (%.1f us), %.3f solutions\n", rate,
         1e6 / rate, sol);
  rate = run(hit, n, METHOD_NEWTON, seconds, &sol);
  printf("  Newton from the centre, hit : %8.0f solves/s per core (%.1f us), %.3f solutions\n",
         rate, 1e6 / rate, sol);
  rate = run(miss, n, METHOD_NEWTON, seconds, &sol);
  printf("  Newton from the centre, miss: %8.0f solves/s per core (%.1f us), %.3f solutions\n",
         rate, 1e6 / rate, sol);
  rate = run(hit, n, METHOD_TRACE, seconds, &sol);
  printf("  exact path trace with derivatives: %8.0f paths/s per core (%.2f us)\n", rate,
         1e6 / rate);
  free(hit);
  free(miss);
  bbc_scene_free(s);
  return 0;
}

int main(int argc, char **argv) {
  const char *paths[2] = {NULL, NULL};
  int np = 0;
  double seconds = 1.0;
  for (int i = 1; i < argc; i++) {
    if (strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
      char *end;
      seconds = strtod(argv[++i], &end);
      if (*end || !(seconds > 0)) {
        fprintf(stderr, "bench_solver: --seconds needs a positive number\n");
        return 2;
      }
    } else if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
      printf("usage: bench_solver [plane1k.gltf [pool4k.gltf]] [--seconds S]\n");
      return 0;
    } else if (np < 2) {
      paths[np++] = argv[i];
    } else {
      fprintf(stderr, "bench_solver: too many arguments\n");
      return 2;
    }
  }
  /* Defaults: the shared scenes beside the source tree this file was compiled from. */
  static char def[2][4096];
  const char *src = __FILE__;
  const char *slash = strrchr(src, '/');
  int dirlen = slash ? (int)(slash - src) : 1;
  snprintf(def[0], sizeof def[0], "%.*s%splane1k.gltf", dirlen, slash ? src : ".",
           DEFAULT_SCENE_DIR_FROM_SOURCE);
  snprintf(def[1], sizeof def[1], "%.*s%spool4k.gltf", dirlen, slash ? src : ".",
           DEFAULT_SCENE_DIR_FROM_SOURCE);
  if (!paths[0]) paths[0] = def[0];
  if (!paths[1] && np < 2) paths[1] = np == 0 ? def[1] : NULL;
  int rc = bench_scene(paths[0], BBC_CHAIN_R, seconds);
  if (paths[1]) rc |= bench_scene(paths[1], BBC_CHAIN_T, seconds);
  return rc;
}
