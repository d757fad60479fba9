/* The cost of beam bounds (bbc_bound_beam) against the bounds of the same tuples on
 * their receiver planes (bbc_bound_tuple): CPU seconds and kept pieces per specular
 * prefix (light, T1[, T2]). Neither uses the precompute's cell test, so both subdivide
 * by their own stopping rules alone (docs/beams.md, "Measured").
 *
 *   bench_beam SCENE.gltf CHAIN [--max-level N] [--stride N] [--sigma S] [--grow D]
 *
 * The beam's receivers' box is the bounding box of every receiver mesh, grown by D on
 * every side (a thickness a curved receiver would have). One thread. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bbc/bbc.h"
#include "bbc/bounds.h"

static double cpu(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct counts {
  long kept, discarded, unbounded;
} counts;

static int count_plane(void *user, const bbc_piece *p) {
  counts *c = user;
  if (p->status == BBC_PIECE_KEPT) {
    c->kept++;
    c->unbounded += !(p->e_hi < INFINITY);
  } else {
    c->discarded++;
  }
  return 0;
}

static int dump = 0;
static int count_beam(void *user, const bbc_beam_piece *p) {
  counts *c = user;
  if (dump)
    printf(
        "  piece u [%.4g %.4g] v [%.4g %.4g] L%d %s axis %d lambda [%.4g %.4g] L%d box "
        "[%.3g %.3g %.3g]-[%.3g %.3g %.3g] E [%.3g %.3g]\n",
        p->u_lo, p->u_hi, p->v_lo, p->v_hi, p->level, p->status == BBC_PIECE_KEPT ? "kept" : "disc",
        p->axis, p->lambda_lo, p->lambda_hi, p->lambda_level, p->box_lo[0], p->box_lo[1],
        p->box_lo[2], p->box_hi[0], p->box_hi[1], p->box_hi[2], p->e_lo, p->e_hi);
  if (p->status == BBC_PIECE_KEPT) {
    c->kept++;
    c->unbounded += !(p->e_hi < INFINITY);
  } else {
    c->discarded++;
  }
  return 0;
}

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr,
            "usage: bench_beam SCENE.gltf CHAIN [--max-level N] [--stride N] [--sigma S]\n");
    return 2;
  }
  bbc_bound_params prm;
  memset(&prm, 0, sizeof prm);
  long stride = 1;
  double grow = 0;
  for (int i = 3; i + 1 < argc; i += 2) {
    if (strcmp(argv[i], "--max-level") == 0)
      prm.max_level = atoi(argv[i + 1]);
    else if (strcmp(argv[i], "--stride") == 0)
      stride = atol(argv[i + 1]);
    else if (strcmp(argv[i], "--sigma") == 0)
      prm.sigma = atof(argv[i + 1]);
    else if (strcmp(argv[i], "--dump") == 0)
      dump = atoi(argv[i + 1]);
    else if (strcmp(argv[i], "--grow") == 0)
      grow = atof(argv[i + 1]);
  }
  int chain = -1;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (strcmp(bbc_chain_name((bbc_chain)c), argv[2]) == 0) chain = c;
  bbc_scene *scene = NULL;
  if (chain < 0 || bbc_scene_load(&scene, argv[1], NULL) != BBC_OK) {
    fprintf(stderr, "bench_beam: cannot load %s or unknown chain %s\n", argv[1], argv[2]);
    return 1;
  }
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t t = 0; t < scene->triangle_count; t++) {
    if (scene->meshes[scene->triangle_mesh[t]].role != BBC_ROLE_RECEIVER) continue;
    for (int k = 0; k < 3; k++) {
      const float *p = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + k];
      for (int i = 0; i < 3; i++) lo[i] = fmin(lo[i], p[i]), hi[i] = fmax(hi[i], p[i]);
    }
  }
  /* --grow D: the box grown by D on every side, as a curved receiver's would be. */
  for (int i = 0; i < 3; i++) lo[i] -= grow, hi[i] += grow;
  bbc_tuple *tuples = NULL;
  size_t n = 0;
  bbc_tuples_find(scene, BBC_CHAIN_BIT(chain), &tuples, &n);
  bbc_bounder *b = NULL;
  bbc_bounder_create(&b);
  counts cp = {0}, cb = {0};
  double plane_s = 0, beam_s = 0;
  long prefixes = 0, plane_tuples = 0, index = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && tuples[j].light == tuples[i].light &&
           tuples[j].specular[0] == tuples[i].specular[0] &&
           tuples[j].specular[1] == tuples[i].specular[1])
      j++;
    if (index++ % stride == 0) {
      prefixes++;
      bbc_tuple_geometry g;
      double t0 = cpu();
      for (size_t k = i; k < j; k++) {
        bbc_tuple_geometry_init(&g, scene, &tuples[k]);
        bbc_bound_tuple(b, &g, &prm, count_plane, &cp, NULL);
        plane_tuples++;
      }
      double t1 = cpu();
      bbc_tuple_geometry_init(&g, scene, &tuples[i]);
      bbc_bound_beam(b, &g, lo, hi, &prm, count_beam, &cb, NULL);
      double t2 = cpu();
      plane_s += t1 - t0, beam_s += t2 - t1;
    }
    i = j;
  }
  printf("%s %s: %ld prefixes (%ld plane tuples); receivers' box [%g %g %g]-[%g %g %g]\n", argv[1],
         argv[2], prefixes, plane_tuples, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
  printf("  plane: %.4f CPU-ms/prefix, %.1f kept pieces/prefix (%.1f%% unbounded)\n",
         1e3 * plane_s / prefixes, (double)cp.kept / prefixes,
         100.0 * cp.unbounded / (cp.kept ? cp.kept : 1));
  printf("  beam:  %.4f CPU-ms/prefix, %.1f kept pieces/prefix (%.1f%% unbounded)\n",
         1e3 * beam_s / prefixes, (double)cb.kept / prefixes,
         100.0 * cb.unbounded / (cb.kept ? cb.kept : 1));
  free(tuples);
  bbc_bounder_free(b);
  bbc_scene_free(scene);
  return 0;
}
