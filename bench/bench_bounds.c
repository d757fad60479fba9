/* Throughput of the single-scattering bounder: pieces per second per core for R and T
 * with interpolated and flat normals, on the tuples of the shared plane and pool scenes.
 *
 *   bench_bounds [SHARED_SCENES_DIR] [--stride N]
 *
 * Every stride-th (caster, receiver) tuple is bounded with the default parameters; the
 * flat variants replace the vertex normals by the geometric normal. One thread. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/bbc.h"
#include "bbc/bounds.h"
#include "vec_internal.h"

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void run(const char *dir, const char *file, bbc_chain chain, int flat, long stride) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, file);
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, path, NULL) != BBC_OK) {
    fprintf(stderr, "bench_bounds: cannot load %s\n", path);
    exit(1);
  }
  bbc_bounder *b = NULL;
  bbc_bounder_create(&b);
  bbc_bound_stats stats;
  memset(&stats, 0, sizeof stats);
  long index = 0;
  double start = now();
  for (uint32_t i = 0; i < scene->triangle_count; i++) {
    if (scene->meshes[scene->triangle_mesh[i]].role != BBC_ROLE_CASTER) continue;
    for (uint32_t k = 0; k < scene->triangle_count; k++) {
      if (scene->meshes[scene->triangle_mesh[k]].role != BBC_ROLE_RECEIVER) continue;
      if (index++ % stride) continue;
      bbc_tuple tuple = {0, chain, {i, BBC_NO_TRIANGLE}, k};
      bbc_tuple_geometry g;
      bbc_tuple_geometry_init(&g, scene, &tuple);
      if (flat) {
        bbc_vec3 n = v3_normalize(v3_cross(v3_sub(g.p[1], g.p[0]), v3_sub(g.p[2], g.p[0])));
        if (v3_dot(n, g.n[0]) < 0) n = v3_neg(n);
        g.n[0] = g.n[1] = g.n[2] = n;
      }
      bbc_bound_tuple(b, &g, NULL, NULL, NULL, &stats);
    }
  }
  double seconds = now() - start;
  printf("| %-11s | %s | %-6s | %7llu | %6.1f | %6.1f | %7.3f | %9.0f | %9.0f |\n", file,
         bbc_chain_name(chain), flat ? "flat" : "interp", (unsigned long long)stats.tuples,
         (double)stats.position_pieces / stats.tuples,
         (double)stats.irradiance_pieces / stats.tuples, seconds, stats.position_pieces / seconds,
         stats.tuples / seconds);
  bbc_bounder_free(b);
  bbc_scene_free(scene);
}

int main(int argc, char **argv) {
  const char *dir = "../shared/scenes";
  long stride = 1;
  for (int i = 1; i < argc; i++) {
    if (strcmp(argv[i], "--stride") == 0 && i + 1 < argc)
      stride = atol(argv[++i]);
    else
      dir = argv[i];
  }
  if (stride < 1) stride = 1;
  printf(
      "| scene       | chain | normals | tuples | pos. pieces/tuple | irr. pieces/tuple | "
      "seconds | pieces/s | tuples/s |\n|---|---|---|---|---|---|---|---|---|\n");
  run(dir, "plane1k.gltf", BBC_CHAIN_R, 0, stride);
  run(dir, "plane1k.gltf", BBC_CHAIN_R, 1, stride);
  run(dir, "pool4k.gltf", BBC_CHAIN_T, 0, stride);
  run(dir, "pool4k.gltf", BBC_CHAIN_T, 1, stride);
  return 0;
}
