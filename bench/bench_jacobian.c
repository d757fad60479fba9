/* The two forms of the irradiance Jacobian (DESIGN 3.5): the determinant D / q^3 and the
 * quotient rule's N / q^4. For each, on the tuples of the shared plane (R) and pool (T)
 * scenes: bounding time per core, and tightness as the mean and percentiles of
 * log10(bound / true) over sampled true paths (bbc_validate_tuple).
 *
 *   bench_jacobian [SHARED_SCENES_DIR] [--stride N] */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/bbc.h"

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void run(const char *dir, const char *file, long stride) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, file);
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, path, NULL) != BBC_OK) {
    fprintf(stderr, "bench_jacobian: cannot load %s\n", path);
    exit(1);
  }
  bbc_tuple *tuples = NULL;
  size_t count = 0;
  bbc_tuples_find(scene, BBC_CHAIN_MASK_ALL, &tuples, &count);
  bbc_bounder *b = NULL;
  bbc_bounder_create(&b);
  for (int form = 0; form < 2; form++) {
    bbc_bound_params p;
    memset(&p, 0, sizeof p);
    p.jacobian = form ? BBC_JACOBIAN_QUOTIENT : BBC_JACOBIAN_DETERMINANT;
    bbc_bound_stats stats;
    memset(&stats, 0, sizeof stats);
    double t0 = now();
    for (size_t i = 0; i < count; i += stride) {
      bbc_tuple_geometry g;
      bbc_tuple_geometry_init(&g, scene, &tuples[i]);
      bbc_bound_tuple(b, &g, &p, NULL, NULL, &stats);
    }
    double seconds = now() - t0;
    bbc_validation acc;
    bbc_validation_reset(&acc);
    for (size_t i = 0; i < count; i += stride)
      bbc_validate_tuple(b, scene, &tuples[i], &p, 200, 1, &acc);
    printf("| %-12s | %-11s | %6llu | %7.2f | %8.0f | %.4f | %.3f | %.3f | %llu | %llu |\n", file,
           form ? "quotient" : "determinant", (unsigned long long)stats.tuples, seconds,
           stats.irradiance_pieces / stats.irradiance_seconds,
           acc.sum_log_ratio / (double)acc.ratio_count,
           bbc_validation_log_ratio_quantile(&acc, 0.5),
           bbc_validation_log_ratio_quantile(&acc, 0.99), (unsigned long long)acc.unbounded,
           (unsigned long long)bbc_validation_failures(&acc));
  }
  free(tuples);
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
      "| scene | Jacobian | tuples | CPU s | irradiance pieces/s | mean log10(bound/true) | "
      "median | p99 | unbounded paths | failures |\n|---|---|---|---|---|---|---|---|---|---|\n");
  run(dir, "plane1k.gltf", stride);
  run(dir, "pool4k.gltf", stride);
  return 0;
}
