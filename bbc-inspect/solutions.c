/* bbc-inspect solutions: the solutions per tuple (the paper's Fig. 8). */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "bbc/solver.h"
#include "bbc/specular_path.h"
#include "bbc/tuple.h"
#include "inspect.h"

static uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/* Sample i of triangle t: barycentrics uniform in the triangle, a pure function of (t, i). */
static void sample_point(uint32_t t, uint32_t i, double b[2]) {
  uint64_t h = mix64(((uint64_t)t << 32) | i);
  double r1 = (double)(h >> 11) * 0x1p-53;
  double r2 = (double)(mix64(h) >> 11) * 0x1p-53;
  if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
  b[0] = r1, b[1] = r2;
}

#define SOLUTION_BINS 5 /* 0, 1, 2, 3, 4+ */

int cmd_solutions(cli_args *a, const char *scene_path, const char *cache_path) {
  const char *samples_text = NULL, *threads_text = NULL;
  bbc_light_units light_units = BBC_LIGHT_UNITS_FILE;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "--samples", &v))
      samples_text = v;
    else if (cli_option(a, "--threads", &v))
      threads_text = v;
    else if (cli_option(a, "--light-units", &v))
      light_units = cli_parse_light_units(a, "--light-units", v);
    else
      cli_usage_error(a->usage, "unknown option '%s'", a->argv[a->i]);
  }
  uint32_t samples =
      samples_text ? (uint32_t)cli_parse_int(a, "--samples", samples_text, 1, UINT32_MAX) : 256;
  inspect_set_threads(a, threads_text);

  bbc_scene *scene = inspect_load_scene(scene_path, light_units);
  bbc_cache *c = inspect_open_cache_for(cache_path, scene);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  const bbc_grid *g = bbc_cache_grid(c);
  const bbc_tuple *tuples = bbc_cache_tuples(c);
  /* Receiver triangles in grid order; each is one unit of work. */
  uint64_t triangles = 0; /* every receiver's, planes' too (uv_triangle_count omits them) */
  for (uint32_t r = 0; r < g->receiver_count; r++) triangles += g->receivers[r].triangle_count;
  uint32_t *tri = malloc((triangles ? triangles : 1) * sizeof *tri);
  if (!tri) cli_fail("out of memory");
  uint64_t n_tri = 0;
  for (uint32_t r = 0; r < g->receiver_count; r++)
    for (uint32_t k = 0; k < g->receivers[r].triangle_count; k++)
      tri[n_tri++] = g->receivers[r].first_triangle + k;

  uint64_t hist[SOLUTION_BINS] = {0}, above_m = 0, points = 0, solutions = 0;
  uint64_t h0 = 0, h1 = 0, h2 = 0, h3 = 0, h4 = 0;
  bbc_result error = BBC_OK;
#pragma omp parallel reduction(+ : h0, h1, h2, h3, h4, above_m, points, solutions)
  {
    bbc_cache_cursor *cur = NULL;
    bbc_result r = bbc_cache_cursor_create(&cur, c);
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
#pragma omp for schedule(dynamic, 4)
    for (uint64_t j = 0; j < n_tri; j++) {
      uint32_t t = tri[j];
      for (uint32_t i = 0; i < samples && r == BBC_OK; i++) {
        double b[2];
        sample_point(t, i, b);
        const bbc_cache_entry *e;
        uint32_t n;
        bbc_vec3 p[3];
        bbc_receiver_triangle(scene, t, p);
        const double w0 = 1 - b[0] - b[1];
        const bbc_vec3 xk = {w0 * p[0].x + b[0] * p[1].x + b[1] * p[2].x,
                             w0 * p[0].y + b[0] * p[1].y + b[1] * p[2].y,
                             w0 * p[0].z + b[0] * p[1].z + b[1] * p[2].z};
        if ((r = bbc_cache_lookup(cur, t, b[0], b[1], &xk, &e, &n)) != BBC_OK) break;
        points++;
        for (uint32_t k = 0; k < n && r == BBC_OK; k++) {
          /* A beam tuple ends on the point's triangle (when it is not on a plane). */
          bbc_tuple ended = tuples[e[k].tuple];
          const uint32_t mesh = scene->triangle_mesh[t];
          if (bbc_receiver_is_beam(ended.receiver) && !scene->meshes[mesh].plane)
            ended.receiver = t;
          const bbc_tuple *u = &ended;
          if ((u->receiver != t && u->receiver != BBC_RECEIVER_PLANE(mesh)) ||
              (u->chain != BBC_CHAIN_R && u->chain != BBC_CHAIN_T))
            continue;
          bbc_path_geometry pg;
          if ((r = bbc_path_geometry_init(&pg, scene, u)) != BBC_OK) break;
          size_t m = 0;
          if ((r = bbc_solver_single(&pg, xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &m)) != BBC_OK)
            break;
          solutions += m;
          if (m == 0)
            h0++;
          else if (m == 1)
            h1++;
          else if (m == 2)
            h2++;
          else if (m == 3)
            h3++;
          else
            h4++;
          if ((double)m > in.params.m) above_m++;
        }
      }
    }
    if (r != BBC_OK) {
#pragma omp critical
      if (error == BBC_OK) error = r;
    }
    bbc_cache_cursor_free(cur);
  }
  /* A damaged chunk was reported by the cache, in one line. */
  if (error == BBC_ERR_CHECKSUM || error == BBC_ERR_CORRUPT) exit(1);
  if (error != BBC_OK) cli_fail("%s: %s", cache_path, bbc_result_string(error));
  hist[0] = h0, hist[1] = h1, hist[2] = h2, hist[3] = h3, hist[4] = h4;
  uint64_t pairs = h0 + h1 + h2 + h3 + h4;
  printf(
      "# %llu shading points on %llu receiver triangles (%u per triangle), %llu (point, "
      "tuple) pairs, %llu solutions\n",
      (unsigned long long)points, (unsigned long long)n_tri, samples, (unsigned long long)pairs,
      (unsigned long long)solutions);
  printf("# solutions  pairs  share\n");
  static const char *const names[SOLUTION_BINS] = {"0", "1", "2", "3", "4+"};
  for (int k = 0; k < SOLUTION_BINS; k++)
    printf("%-3s %12llu  %8.4f%%\n", names[k], (unsigned long long)hist[k],
           pairs ? 100.0 * (double)hist[k] / (double)pairs : 0.0);
  printf("more than m = %g: %llu of %llu pairs (%.4f%%)\n", in.params.m,
         (unsigned long long)above_m, (unsigned long long)pairs,
         pairs ? 100.0 * (double)above_m / (double)pairs : 0.0);
  free(tri);
  bbc_cache_close(c);
  bbc_scene_free(scene);
  return 0;
}
