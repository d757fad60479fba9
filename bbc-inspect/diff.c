/* bbc-inspect diff: what differs between two caches. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/tuple.h"
#include "inspect.h"

static int differences;
static const char *diff_paths[2];

static void differ(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void differ(const char *fmt, ...) {
  if (differences == 0) printf("--- %s\n+++ %s\n", diff_paths[0], diff_paths[1]);
  va_list ap;
  va_start(ap, fmt);
  vprintf(fmt, ap);
  va_end(ap);
  putchar('\n');
  differences++;
}

#define DIFF_U(name, a, b) \
  if ((a) != (b)) differ("%s: %llu | %llu", name, (unsigned long long)(a), (unsigned long long)(b))
#define DIFF_D(name, a, b) \
  if (memcmp(&(a), &(b), sizeof(double)) != 0) differ("%s: %.17g | %.17g", name, (a), (b))
#define DIFF_H(name, a, b) \
  if ((a) != (b))          \
  differ("%s: %016llx | %016llx", name, (unsigned long long)(a), (unsigned long long)(b))

static void print_tuple(char *buf, size_t size, const bbc_tuple *u) {
  char t2[16];
  if (u->specular[1] == BBC_NO_TRIANGLE)
    snprintf(t2, sizeof t2, "-");
  else
    snprintf(t2, sizeof t2, "%u", u->specular[1]);
  snprintf(buf, size, "%s light %u T1 %u T2 %s receiver %u",
           u->chain < BBC_CHAIN_COUNT ? bbc_chain_name((bbc_chain)u->chain) : "?", u->light,
           u->specular[0], t2, u->receiver);
}

static void print_list(const char *label, const bbc_cache_entry *e, uint32_t n) {
  printf("  %s: %u entries:", label, n);
  for (uint32_t i = 0; i < n; i++) printf(" %u:%.9g", e[i].tuple, (double)e[i].bound);
  putchar('\n');
}

int cmd_diff(const char *path_a, const char *path_b) {
  bbc_cache *ca = inspect_open_cache(path_a), *cb = inspect_open_cache(path_b);
  bbc_cache_info a, b;
  bbc_cache_get_info(ca, &a);
  bbc_cache_get_info(cb, &b);
  diff_paths[0] = path_a, diff_paths[1] = path_b; /* the header of the first difference */
  DIFF_U("format version major", a.version_major, b.version_major);
  DIFF_U("format version minor", a.version_minor, b.version_minor);
  char ta[64], tb[64];
  if (a.params.chains != b.params.chains)
    differ("params.chains: %s | %s", inspect_chains_text(a.params.chains, ta, sizeof ta),
           inspect_chains_text(b.params.chains, tb, sizeof tb));
  DIFF_U("params.max_level", a.params.max_level, b.params.max_level);
  DIFF_U("params.max_level_double", a.params.max_level_double, b.params.max_level_double);
  DIFF_D("params.sigma", a.params.sigma, b.params.sigma);
  DIFF_D("params.alpha_single", a.params.alpha_single, b.params.alpha_single);
  DIFF_D("params.alpha_double", a.params.alpha_double, b.params.alpha_double);
  DIFF_D("params.m", a.params.m, b.params.m);
  DIFF_U("params.grid_resolution", a.params.grid_resolution, b.params.grid_resolution);
  DIFF_U("params.cell_levels", a.params.cell_levels, b.params.cell_levels);
  DIFF_U("params.remainder", a.params.remainder, b.params.remainder);
  DIFF_U("params.area_lights", a.params.area_lights, b.params.area_lights);
  DIFF_U("params.area_double", a.params.area_double, b.params.area_double);
  DIFF_D("params.alpha_area", a.params.alpha_area, b.params.alpha_area);
  DIFF_H("fingerprint.total", a.fingerprint.total, b.fingerprint.total);
  DIFF_H("fingerprint.geometry", a.fingerprint.geometry, b.fingerprint.geometry);
  DIFF_H("fingerprint.materials", a.fingerprint.materials, b.fingerprint.materials);
  DIFF_H("fingerprint.meshes", a.fingerprint.meshes, b.fingerprint.meshes);
  DIFF_H("fingerprint.lights", a.fingerprint.lights, b.fingerprint.lights);
  DIFF_H("fingerprint.params", a.fingerprint.params, b.fingerprint.params);
  DIFF_U("scene vertices", a.scene_vertex_count, b.scene_vertex_count);
  DIFF_U("scene triangles", a.scene_triangle_count, b.scene_triangle_count);
  DIFF_U("scene meshes", a.scene_mesh_count, b.scene_mesh_count);
  DIFF_U("scene materials", a.scene_material_count, b.scene_material_count);
  DIFF_U("scene point lights", a.scene_light_count, b.scene_light_count);

  /* Tuples: the count and the first tuple that differs. */
  DIFF_U("tuples", a.tuple_count, b.tuple_count);
  const bbc_tuple *tua = bbc_cache_tuples(ca), *tub = bbc_cache_tuples(cb);
  uint32_t common = a.tuple_count < b.tuple_count ? a.tuple_count : b.tuple_count;
  for (uint32_t i = 0; i < common; i++)
    if (memcmp(&tua[i], &tub[i], sizeof *tua) != 0) {
      char sa[128], sb[128];
      print_tuple(sa, sizeof sa, &tua[i]);
      print_tuple(sb, sizeof sb, &tub[i]);
      differ("first differing tuple %u: %s | %s", i, sa, sb);
      break;
    }

  /* Receivers and their grids. */
  const bbc_grid *ga = bbc_cache_grid(ca), *gb = bbc_cache_grid(cb);
  DIFF_U("receivers", ga->receiver_count, gb->receiver_count);
  int grids_equal = ga->receiver_count == gb->receiver_count && ga->cell_count == gb->cell_count &&
                    ga->uv_triangle_count == gb->uv_triangle_count;
  uint32_t rc = ga->receiver_count < gb->receiver_count ? ga->receiver_count : gb->receiver_count;
  for (uint32_t r = 0; r < rc; r++) {
    const bbc_receiver *x = &ga->receivers[r], *y = &gb->receivers[r];
    char name[64];
    int before = differences;
#define RFIELD(f)                                    \
  snprintf(name, sizeof name, "receiver %u " #f, r); \
  DIFF_U(name, x->f, y->f)
    RFIELD(mesh);
    RFIELD(parameterisation);
    RFIELD(first_triangle);
    RFIELD(triangle_count);
    RFIELD(width);
    RFIELD(height);
    RFIELD(first_cell);
#undef RFIELD
    for (int k = 0; k < 4; k++) {
      snprintf(name, sizeof name, "receiver %u domain[%d]", r, k);
      DIFF_D(name, x->domain[k], y->domain[k]);
    }
    for (int k = 0; k < 3; k++) {
      snprintf(name, sizeof name, "receiver %u axis_u[%d]", r, k);
      DIFF_D(name, x->axis_u[k], y->axis_u[k]);
      snprintf(name, sizeof name, "receiver %u axis_v[%d]", r, k);
      DIFF_D(name, x->axis_v[k], y->axis_v[k]);
    }
    /* A plane's triangles have no grid coordinates (spec 6.5). */
    const uint32_t uvs = x->parameterisation == BBC_PARAM_PLANE ? 0 : x->triangle_count;
    if (differences == before && x->first_uv == y->first_uv &&
        memcmp(&ga->triangle_uv[6 * x->first_uv], &gb->triangle_uv[6 * y->first_uv],
               6 * sizeof(float) * uvs) != 0)
      differ("receiver %u: the grid coordinates of its triangles differ", r);
    if (differences != before) grids_equal = 0;
  }

  /* Cell lists, compared cell by cell when the grids agree. */
  if (!grids_equal) {
    differ("cells: %llu | %llu; the grids differ, so the cell lists are not compared",
           (unsigned long long)ga->cell_count, (unsigned long long)gb->cell_count);
  } else {
    bbc_cache_cursor *ka = NULL, *kb = NULL;
    if (bbc_cache_cursor_create(&ka, ca) != BBC_OK || bbc_cache_cursor_create(&kb, cb) != BBC_OK)
      cli_fail("out of memory");
    uint64_t differing = 0, first = 0;
    for (uint64_t cell = 0; cell < ga->cell_count; cell++) {
      const bbc_cache_entry *ea, *eb;
      uint32_t na, nb;
      if (bbc_cache_cell(ka, cell, &ea, &na) != BBC_OK) exit(1); /* the callback printed it */
      if (bbc_cache_cell(kb, cell, &eb, &nb) != BBC_OK) exit(1);
      int same = na == nb;
      for (uint32_t i = 0; same && i < na; i++)
        same = ea[i].tuple == eb[i].tuple && memcmp(&ea[i].bound, &eb[i].bound, sizeof(float)) == 0;
      if (!same && differing++ == 0) first = cell;
    }
    if (differing) {
      uint32_t r = 0;
      while (r + 1 < ga->receiver_count && ga->receivers[r + 1].first_cell <= first) r++;
      const bbc_receiver *rv = &ga->receivers[r];
      uint64_t local = first - rv->first_cell;
      differ("cell lists: %llu of %llu cells differ; first: receiver %u, cell %llu,%llu",
             (unsigned long long)differing, (unsigned long long)ga->cell_count, r,
             (unsigned long long)(local % rv->width), (unsigned long long)(local / rv->width));
      const bbc_cache_entry *ea, *eb;
      uint32_t na, nb;
      bbc_cache_cell(ka, first, &ea, &na);
      print_list("A", ea, na);
      bbc_cache_cell(kb, first, &eb, &nb);
      print_list("B", eb, nb);
    }
    bbc_cache_cursor_free(ka);
    bbc_cache_cursor_free(kb);
  }
  bbc_cache_close(ca);
  bbc_cache_close(cb);
  return differences ? 1 : 0;
}
