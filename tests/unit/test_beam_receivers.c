/* Beam receivers (tuple.h BBC_RECEIVER_BEAM, docs/receivers.md): one tuple per specular
 * prefix stands for every receiver triangle not on a plane. Oracles: the tuple search on
 * the same caster over a bent floor cut into 128 and 512 triangles (the count must not
 * change; per-triangle tuples, the control, do), true paths traced to every triangle
 * they land on and looked up there (a cache whose beam tuples hold no cells, the
 * control, fails), the render against per-triangle tuples enumerated (the same caustic),
 * and the bytes of caches precomputed on 1 and 2 threads. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "harness.h"
#include "render_fixture.h"

#define BENT(n) TEST_SCENE("bent-wavy-mirror-" #n ".gltf")

/* The receiver mesh of the bent floor: not a plane. */
static uint32_t floor_triangles(const bbc_scene *s) {
  for (uint32_t m = 0; m < s->mesh_count; m++)
    if (s->meshes[m].role == BBC_ROLE_RECEIVER) {
      CHECK_INT(s->meshes[m].plane, 0);
      return s->meshes[m].triangle_count;
    }
  return 0;
}

TEST(beam_tuples_do_not_multiply_with_the_floor) {
  size_t beams[2], triangles[2];
  uint32_t floors[2];
  const char *paths[2] = {BENT(128), BENT(512)};
  for (int k = 0; k < 2; k++) {
    bbc_scene *s = NULL;
    REQUIRE(bbc_scene_load(&s, paths[k], NULL) == BBC_OK);
    floors[k] = floor_triangles(s);
    bbc_tuple *t = NULL;
    REQUIRE(bbc_tuples_find_beam(s, BBC_CHAIN_BIT(BBC_CHAIN_R), 0, &t, &beams[k]) == BBC_OK);
    for (size_t i = 0; i < beams[k]; i++) CHECK(bbc_receiver_is_beam(t[i].receiver));
    /* One per prefix: the T1 are distinct. */
    for (size_t i = 1; i < beams[k]; i++) CHECK(t[i].specular[0] > t[i - 1].specular[0]);
    free(t);
    REQUIRE(bbc_tuples_find(s, BBC_CHAIN_BIT(BBC_CHAIN_R), &t, &triangles[k]) == BBC_OK);
    free(t);
    bbc_scene_free(s);
  }
  fprintf(stderr,
          "floors of %u and %u triangles: beam tuples %zu and %zu, per-triangle %zu and %zu\n",
          floors[0], floors[1], beams[0], beams[1], triangles[0], triangles[1]);
  CHECK(floors[1] >= 3 * floors[0]);
  CHECK(beams[0] > 20);
  CHECK_INT(beams[1], beams[0]);
  /* The control: per-triangle tuples grow with the floor. */
  CHECK(triangles[0] > beams[0]);
  CHECK(triangles[1] > 2 * triangles[0]);
}

/* A cache of the scene at `path` (R, level 6, a 64 x 64 grid) with beam or per-triangle
 * receivers on `threads` threads: its bytes (malloc'd) and their size. */
static int precompute_chains(const char *path, uint32_t chains, int beam, int threads,
                             uint32_t levels, void **bytes, size_t *size) {
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, NULL) != BBC_OK) return 0;
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.chains = chains;
  o.params.max_level = 6;
  o.params.grid_resolution = 64;
  o.params.beam_receivers = (uint32_t)beam;
  o.params.cell_levels = levels;
  o.threads = threads;
  bbc_cache_builder *b = NULL;
  int ok = bbc_precompute(&b, s, &o, NULL) == BBC_OK &&
           bbc_cache_builder_write_memory(b, bytes, size, NULL) == BBC_OK;
  bbc_cache_builder_free(b);
  bbc_scene_free(s);
  return ok;
}

static int precompute_levels(const char *path, int beam, int threads, uint32_t levels, void **bytes,
                             size_t *size) {
  return precompute_chains(path, BBC_CHAIN_BIT(BBC_CHAIN_R), beam, threads, levels, bytes, size);
}

static int precompute_bytes(const char *path, int beam, int threads, void **bytes, size_t *size) {
  return precompute_levels(path, beam, threads, 0, bytes, size);
}

static int fixture_chains(fixture *f, const char *path, uint32_t chains, int beam) {
  memset(f, 0, sizeof *f);
  size_t size = 0;
  return bbc_scene_load(&f->scene, path, NULL) == BBC_OK &&
         bbc_accel_create(&f->accel, f->scene, NULL, NULL) == BBC_OK &&
         precompute_chains(path, chains, beam, 0, 0, &f->bytes, &size) &&
         bbc_cache_open_memory(&f->cache, f->bytes, size, NULL) == BBC_OK &&
         bbc_cache_check_scene(f->cache, f->scene) == BBC_OK;
}

static int fixture_of(fixture *f, const char *path, int beam) {
  return fixture_chains(f, path, BBC_CHAIN_BIT(BBC_CHAIN_R), beam);
}

/* Every true path of every beam tuple, on every triangle it lands on, is listed in that
 * point's cell with a bound of at least its irradiance. */
static void validate_all(const fixture *f, uint32_t samples, bbc_validation *v) {
  bbc_cache_info info;
  bbc_cache_get_info(f->cache, &info);
  bbc_cache_cursor *cursor = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, f->cache) == BBC_OK);
  bbc_validation_reset(v);
  const bbc_tuple *tuples = bbc_cache_tuples(f->cache);
  for (uint32_t i = 0; i < info.tuple_count; i++)
    REQUIRE(bbc_validate_cached_tuple(f->cache, cursor, f->scene, &tuples[i], i, samples, 7, v) ==
            BBC_OK);
  bbc_cache_cursor_free(cursor);
}

TEST(beam_true_paths_are_covered) {
  fixture f;
  REQUIRE(fixture_of(&f, BENT(512), 1));
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  CHECK_INT(info.version_minor, 8);
  CHECK_INT(info.params.beam_receivers, 1);
  CHECK_INT(info.params.cell_levels, 4); /* 64 cells a side: the coarsest cells 8 x 8 */
  const bbc_tuple *tuples = bbc_cache_tuples(f.cache);
  for (uint32_t i = 0; i < info.tuple_count; i++) CHECK(bbc_receiver_is_beam(tuples[i].receiver));
  bbc_validation v;
  validate_all(&f, 100, &v);
  fprintf(stderr, "%llu tuples, %llu samples, %llu landings on floor triangles, %llu failing\n",
          (unsigned long long)v.tuples, (unsigned long long)v.samples,
          (unsigned long long)v.admissible, (unsigned long long)v.failing);
  CHECK(v.admissible > 2000);
  CHECK_INT(v.failing, 0);

  /* The control: the same tuples in a cache with no cells are caught. */
  bbc_cache_builder *b = NULL;
  REQUIRE(bbc_cache_builder_create(&b, f.scene, &info.params) == BBC_OK);
  for (uint32_t i = 0; i < info.tuple_count; i++) {
    uint32_t id;
    REQUIRE(bbc_cache_builder_add_tuple(b, &tuples[i], &id) == BBC_OK);
  }
  fixture g = f;
  size_t size = 0;
  REQUIRE(bbc_cache_builder_write_memory(b, &g.bytes, &size, NULL) == BBC_OK);
  bbc_cache_builder_free(b);
  REQUIRE(bbc_cache_open_memory(&g.cache, g.bytes, size, NULL) == BBC_OK);
  bbc_validation empty;
  validate_all(&g, 50, &empty);
  CHECK(empty.position_violations > 100);
  bbc_cache_close(g.cache);
  free(g.bytes);
  teardown(&f);
}

/* Light refracted into a closed glass lands only inside it (bbc__tuple_landing_box): a
 * glass ball rests on the bent floor, whose wave rises into the ball beside the point it
 * rests on. Every true T path is covered, and no point of a floor triangle whose box
 * misses the ball's sees a tuple (a beam bounded over the whole floor's box, the control
 * run by removing the narrowing, reaches 50 of the 464 floor triangles outside it). */
TEST(refraction_into_glass_lands_inside_it) {
  fixture f;
  REQUIRE(
      fixture_chains(&f, TEST_SCENE("bent-glass-sphere-512.gltf"), BBC_CHAIN_BIT(BBC_CHAIN_T), 1));
  const bbc_scene *s = f.scene;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  uint32_t floor = UINT32_MAX;
  for (uint32_t m = 0; m < s->mesh_count; m++) {
    const bbc_mesh *mesh = &s->meshes[m];
    if (mesh->role == BBC_ROLE_RECEIVER) floor = m;
    if (mesh->role != BBC_ROLE_CASTER) continue;
    CHECK_INT(mesh->closed, 1);
    for (uint32_t v = 0; v < mesh->vertex_count; v++)
      for (int a = 0; a < 3; a++) {
        lo[a] = fmin(lo[a], s->positions[3 * (size_t)(mesh->first_vertex + v) + a]);
        hi[a] = fmax(hi[a], s->positions[3 * (size_t)(mesh->first_vertex + v) + a]);
      }
  }
  REQUIRE(floor != UINT32_MAX);
  bbc_validation v;
  validate_all(&f, 200, &v);
  bbc_cache_cursor *cursor = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, f.cache) == BBC_OK);
  const bbc_mesh *fm = &s->meshes[floor];
  uint32_t outside = 0, seen_outside = 0, seen_inside = 0;
  for (uint32_t t = fm->first_triangle; t < fm->first_triangle + fm->triangle_count; t++) {
    double tlo[3] = {INFINITY, INFINITY, INFINITY}, thi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3; k++)
      for (int a = 0; a < 3; a++) {
        const double x = s->positions[3 * (size_t)s->indices[3 * (size_t)t + k] + a];
        tlo[a] = fmin(tlo[a], x), thi[a] = fmax(thi[a], x);
      }
    int misses = 0;
    for (int a = 0; a < 3; a++) misses |= thi[a] < lo[a] || tlo[a] > hi[a];
    outside += misses;
    int seen = 0;
    static const double points[4][2] = {{1 / 3.0, 1 / 3.0}, {0.05, 0.05}, {0.9, 0.05}, {0.05, 0.9}};
    for (int k = 0; k < 4; k++) {
      const bbc_cache_entry *e;
      uint32_t n;
      REQUIRE(bbc_cache_lookup(cursor, t, points[k][0], points[k][1], NULL, &e, &n) == BBC_OK);
      seen |= n > 0;
    }
    if (misses)
      seen_outside += seen;
    else
      seen_inside += seen;
  }
  fprintf(stderr,
          "%llu admissible T paths, %llu failing; floor triangles outside the ball's box %u of "
          "%u, seeing a tuple: %u outside, %u inside\n",
          (unsigned long long)v.admissible, (unsigned long long)v.failing, outside,
          fm->triangle_count, seen_outside, seen_inside);
  CHECK(v.admissible > 50);
  CHECK_INT(v.failing, 0);
  CHECK(outside > fm->triangle_count / 2);
  CHECK(seen_inside > 0);
  CHECK_INT(seen_outside, 0);
  bbc_cache_cursor_free(cursor);
  teardown(&f);
}

/* A point sees its cell's list and those of the coarser cells holding it, merged: the
 * oracle takes each level's list (bbc_cache_cell) and keeps per tuple its largest bound. */
TEST(levels_merge_in_lookups) {
  fixture f;
  REQUIRE(fixture_of(&f, BENT(512), 1));
  const bbc_grid *g = bbc_cache_grid(f.cache);
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  REQUIRE(g->levels == 4);
  bbc_cache_cursor *cursor = NULL, *raw = NULL;
  REQUIRE(bbc_cache_cursor_create(&cursor, f.cache) == BBC_OK);
  REQUIRE(bbc_cache_cursor_create(&raw, f.cache) == BBC_OK);
  float *best = malloc(sizeof *best * info.tuple_count);
  REQUIRE(best);
  uint64_t coarse_entries = 0, widened = 0, checked = 0;
  for (uint64_t c = g->receivers[0].first_coarse_cell; c < g->cell_count; c++) {
    const bbc_cache_entry *e;
    uint32_t n;
    REQUIRE(bbc_cache_cell(raw, c, &e, &n) == BBC_OK);
    coarse_entries += n;
  }
  const bbc_receiver *r = &g->receivers[0];
  for (uint32_t y = 0; y < r->height; y++)
    for (uint32_t x = 0; x < r->width; x++) {
      const bbc_cell cell = {0, x, y};
      for (uint32_t i = 0; i < info.tuple_count; i++) best[i] = -1;
      uint32_t expected = 0, own = 0;
      for (uint32_t k = 0; k < g->levels; k++) {
        const bbc_cache_entry *e;
        uint32_t n;
        REQUIRE(bbc_cache_cell(raw, bbc_grid_level_cell(g, cell, k), &e, &n) == BBC_OK);
        if (k == 0) own = n;
        for (uint32_t i = 0; i < n; i++) {
          if (best[e[i].tuple] < 0) expected++;
          if (e[i].bound > best[e[i].tuple]) best[e[i].tuple] = e[i].bound;
        }
      }
      const bbc_cache_entry *m;
      uint32_t n;
      REQUIRE(bbc_cache_leaf(cursor, cell, &m, &n) == BBC_OK);
      CHECK_INT(n, expected);
      for (uint32_t i = 0; i < n; i++) {
        CHECK(i == 0 || m[i].tuple > m[i - 1].tuple);
        CHECK(m[i].bound == best[m[i].tuple]);
      }
      widened += n > own;
      checked++;
    }
  fprintf(stderr, "%llu coarse entries; %llu of %llu cells see more tuples than their own list\n",
          (unsigned long long)coarse_entries, (unsigned long long)widened,
          (unsigned long long)checked);
  CHECK(coarse_entries > 0); /* spread tuples were recorded at a coarser level */
  CHECK(widened > 0);
  const bbc_cache_entry *e;
  uint32_t n;
  CHECK_INT(bbc_cache_leaf(cursor, (bbc_cell){0, r->width, 0}, &e, &n), BBC_ERR_INVALID_ARGUMENT);
  free(best);
  bbc_cache_cursor_free(raw);
  bbc_cache_cursor_free(cursor);
  teardown(&f);
}

/* Levels change where a bound is recorded, never below what the grid's cells held: the
 * same precompute on one level (the oracle) and on the writer's levels store the same
 * tuples, and at every cell each tuple's merged bound is at least its one-level bound,
 * and unbounded exactly where that was (an unbounded cell sends its chain type to light
 * tracing, which levels must not spread). */
TEST(levels_keep_every_bound_and_the_unbounded_cells) {
  void *one = NULL, *many = NULL;
  size_t n1 = 0, n2 = 0;
  REQUIRE(precompute_levels(BENT(512), 1, 0, 1, &one, &n1));
  REQUIRE(precompute_levels(BENT(512), 1, 0, 0, &many, &n2));
  bbc_cache *c1 = NULL, *c2 = NULL;
  REQUIRE(bbc_cache_open_memory(&c1, one, n1, NULL) == BBC_OK);
  REQUIRE(bbc_cache_open_memory(&c2, many, n2, NULL) == BBC_OK);
  bbc_cache_info i1, i2;
  bbc_cache_get_info(c1, &i1);
  bbc_cache_get_info(c2, &i2);
  CHECK_INT(i1.params.cell_levels, 0);
  CHECK_INT(i1.version_minor, 7);
  CHECK_INT(i2.params.cell_levels, 4);
  REQUIRE(i1.tuple_count == i2.tuple_count);
  CHECK(memcmp(bbc_cache_tuples(c1), bbc_cache_tuples(c2), sizeof(bbc_tuple) * i1.tuple_count) ==
        0);
  CHECK(i2.entry_count < i1.entry_count);
  bbc_cache_cursor *k1 = NULL, *k2 = NULL;
  REQUIRE(bbc_cache_cursor_create(&k1, c1) == BBC_OK);
  REQUIRE(bbc_cache_cursor_create(&k2, c2) == BBC_OK);
  float *seen = malloc(sizeof *seen * i1.tuple_count);
  REQUIRE(seen);
  const bbc_grid *g = bbc_cache_grid(c1);
  uint64_t entries = 0, unbounded = 0, raised = 0, bad = 0;
  for (uint32_t r = 0; r < g->receiver_count; r++)
    for (uint32_t y = 0; y < g->receivers[r].height; y++)
      for (uint32_t x = 0; x < g->receivers[r].width; x++) {
        const bbc_cache_entry *a, *b;
        uint32_t na, nb;
        REQUIRE(bbc_cache_leaf(k1, (bbc_cell){r, x, y}, &a, &na) == BBC_OK);
        for (uint32_t i = 0; i < i1.tuple_count; i++) seen[i] = 0;
        for (uint32_t i = 0; i < na; i++) seen[a[i].tuple] = a[i].bound;
        REQUIRE(bbc_cache_leaf(k2, (bbc_cell){r, x, y}, &b, &nb) == BBC_OK);
        uint32_t matched = 0;
        for (uint32_t i = 0; i < nb; i++) {
          const float was = seen[b[i].tuple];
          if (was > 0) matched++;
          if (b[i].bound < was || (isinf(b[i].bound) != isinf(was) && was > 0) ||
              (isinf(b[i].bound) && was == 0))
            bad++;
          raised += b[i].bound > was;
        }
        if (matched != na) bad += na - matched; /* a one-level entry lost */
        entries += na;
        for (uint32_t i = 0; i < na; i++) unbounded += isinf(a[i].bound);
      }
  fprintf(stderr,
          "%llu entries on one level, %llu with levels; %llu cell entries unbounded; %llu "
          "raised or added; %llu wrong\n",
          (unsigned long long)i1.entry_count, (unsigned long long)i2.entry_count,
          (unsigned long long)unbounded, (unsigned long long)raised, (unsigned long long)bad);
  CHECK(unbounded > 0); /* the floor has unbounded cells, so the rule is exercised */
  CHECK(raised > 0);
  CHECK_INT(bad, 0);
  free(seen);
  bbc_cache_cursor_free(k1);
  bbc_cache_cursor_free(k2);
  bbc_cache_close(c1);
  bbc_cache_close(c2);
  free(one);
  free(many);
}

/* The caustic rendered through beam tuples, every tuple of a cell solved (enumerated),
 * is the one of per-triangle tuples enumerated: the cells of the beam tuples, which the
 * cell test now prunes, still hold every tuple with a path to the shading point. (The
 * tuple sampler draws a tuple with a probability below 1 once its bound is finite, so
 * its render differs from this by noise.) */
TEST(beam_render_matches_per_triangle) {
  fixture a, b;
  REQUIRE(fixture_of(&a, BENT(128), 0));
  REQUIRE(fixture_of(&b, BENT(128), 1));
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.spp = 2;
  o.components = BBC_COMPONENT_CAUSTICS;
  o.method = BBC_METHOD_ENUMERATE;
  bbc_image *x = fixture_render(&a, o, 48, 36, NULL);
  bbc_image *y = fixture_render(&b, o, 48, 36, NULL);
  REQUIRE(x && y);
  const size_t n = 3 * (size_t)48 * 36;
  double sx = 0, sy = 0, diff = 0, norm = 0;
  for (size_t i = 0; i < n; i++) {
    sx += x->rgb[i], sy += y->rgb[i];
    diff += ((double)x->rgb[i] - y->rgb[i]) * ((double)x->rgb[i] - y->rgb[i]);
    norm += (double)x->rgb[i] * x->rgb[i];
  }
  fprintf(stderr, "means %.9g (per-triangle) and %.9g (beam); relative squared difference %.3g\n",
          sx / n, sy / n, norm > 0 ? diff / norm : 0.0);
  CHECK(sx > 0);
  CHECK(fabs(sy - sx) <= 1e-6 * sx);
  CHECK(diff <= 1e-9 * norm);
  bbc_image_free(x);
  bbc_image_free(y);
  teardown(&a);
  teardown(&b);
}

TEST(beam_cache_is_the_same_for_any_thread_count) {
  void *one = NULL, *two = NULL;
  size_t n1 = 0, n2 = 0;
  REQUIRE(precompute_bytes(BENT(128), 1, 1, &one, &n1));
  REQUIRE(precompute_bytes(BENT(128), 1, 2, &two, &n2));
  CHECK(n1 > 0);
  CHECK(n1 == n2 && memcmp(one, two, n1) == 0);
  free(one);
  free(two);
}

/* Per-triangle caches stay as they were (format 1.6 with a plane, here without one: the
 * minor version of their features), and a beam cache is refused for per-triangle
 * parameters. */
TEST(per_triangle_caches_keep_their_version) {
  fixture f;
  REQUIRE(fixture_of(&f, BENT(128), 0));
  bbc_cache_info info;
  bbc_cache_get_info(f.cache, &info);
  CHECK(info.version_minor < 7);
  CHECK_INT(info.params.beam_receivers, 0);
  teardown(&f);
}

/* The bound itself (bbc_bound_beam) against true paths: every landing on a floor
 * triangle lies in the box of a kept piece holding its u1, with an irradiance at most
 * that piece's E_hi (docs/beams.md, "Validation"). */
TEST(beam_bound_holds_on_true_paths) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, BENT(512), NULL) == BBC_OK);
  bbc_tuple *t = NULL;
  size_t n = 0;
  REQUIRE(bbc_tuples_find_beam(s, BBC_CHAIN_BIT(BBC_CHAIN_R), 0, &t, &n) == BBC_OK);
  bbc_bounder *bounder = NULL;
  REQUIRE(bbc_bounder_create(&bounder) == BBC_OK);
  bbc_validation v;
  bbc_validation_reset(&v);
  for (size_t i = 0; i < n; i++)
    REQUIRE(bbc_validate_tuple(bounder, s, &t[i], NULL, 100, 3, &v) == BBC_OK);
  fprintf(stderr, "%llu tuples, %llu landings, %llu failing, %llu unbounded\n",
          (unsigned long long)v.tuples, (unsigned long long)v.admissible,
          (unsigned long long)v.failing, (unsigned long long)v.unbounded);
  CHECK(v.admissible > 2000);
  CHECK_INT(v.failing, 0);
  bbc_bounder_free(bounder);
  free(t);
  bbc_scene_free(s);
}

/* ---- the cells a piece's box reaches (beam_cells_internal.h) ------------------------- */

#include "beam_cells_internal.h"

/* Marks the cells of a piece's rows (bbc__beam_piece_rows) in a per-cell array. */
typedef struct cell_sink {
  const bbc_grid *grid;
  const bbc__beam_receivers *b;
  double *cells; /* per global cell index */
} cell_sink;

static int mark_row(void *user, uint32_t k, uint32_t y, uint32_t x0, uint32_t x1,
                    const uint8_t *mask) {
  cell_sink *s = user;
  const bbc_receiver *r = &s->grid->receivers[s->b->items[k].receiver];
  for (uint32_t x = x0; x <= x1; x++)
    if (!mask || mask[x]) s->cells[r->first_cell + (uint64_t)y * r->width + x] = 1;
  return 0;
}

static double unit(uint64_t *state) {
  *state = *state * 6364136223846793005ull + 1442695040888963407ull;
  return (double)(*state >> 11) * 0x1.0p-53;
}

/* Points of the floor's triangles inside `box` whose cells hold no entry after the
 * cells of a piece with box `given` were taken (0: every point is covered); *inside
 * counts the points tested. */
static uint64_t uncovered(const bbc_scene *s, const bbc_grid *grid, const double *cells,
                          const double lo[3], const double hi[3], uint64_t *inside) {
  uint64_t missed = 0, state = 99;
  for (uint32_t t = 0; t < s->triangle_count; t++) {
    if (s->meshes[s->triangle_mesh[t]].role != BBC_ROLE_RECEIVER) continue;
    bbc_vec3 p[3];
    if (!bbc_receiver_triangle(s, t, p)) return UINT64_MAX;
    for (int k = 0; k < 64; k++) {
      double b1 = unit(&state), b2 = unit(&state);
      if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
      const double w = 1 - b1 - b2;
      const double x[3] = {w * p[0].x + b1 * p[1].x + b2 * p[2].x,
                           w * p[0].y + b1 * p[1].y + b2 * p[2].y,
                           w * p[0].z + b1 * p[1].z + b2 * p[2].z};
      int in = 1;
      for (int a = 0; a < 3; a++) in &= x[a] >= lo[a] && x[a] <= hi[a];
      if (!in) continue;
      ++*inside;
      bbc_cell c;
      if (!bbc_grid_locate(grid, t, b1, b2, NULL, &c) || !(cells[bbc_grid_cell_index(grid, c)] > 0))
        missed++;
    }
  }
  return missed;
}

/* Random boxes over the bent floor: every point of a floor triangle inside a piece's box
 * is in a cell the piece reaches (bbc__beam_piece_rows), the triangles clipped to the
 * box; the cells are fewer than the triangles' whole footprints (printed: the
 * difference), and a piece with a smaller box than the points' (the control) leaves
 * points uncovered. */
TEST(beam_cells_cover_the_box) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, BENT(512), NULL) == BBC_OK);
  bbc_grid *grid = NULL;
  REQUIRE(bbc_grid_create(&grid, s, 128, NULL, NULL) == BBC_OK);
  bbc__beam_receivers b;
  REQUIRE(bbc__beam_receivers_init(&b, s, grid) == BBC_OK);
  REQUIRE(b.count == 1);
  bbc__beam_scratch scratch;
  memset(&scratch, 0, sizeof scratch);
  double *cells = calloc(grid->cell_count, sizeof *cells);
  REQUIRE(cells);
  REQUIRE(bbc__beam_scratch_reserve(&scratch, &b) == BBC_OK);
  cell_sink sink = {grid, &b, cells};
  uint64_t state = 7, inside = 0, missed = 0, clipped_cells = 0, whole_cells = 0, control = 0;
  for (int k = 0; k < 40; k++) {
    bbc_beam_piece piece;
    memset(&piece, 0, sizeof piece);
    piece.status = BBC_PIECE_KEPT;
    piece.e_hi = 1;
    /* A box of 2 % to 40 % of the floor's extent on x and z, any height range. */
    const double f = 0.02 + 0.38 * unit(&state);
    for (int a = 0; a < 3; a++) {
      const double ext = b.hi[a] - b.lo[a], size = a == 1 ? ext * unit(&state) : ext * f;
      piece.box_lo[a] = b.lo[a] + (ext - size) * unit(&state);
      piece.box_hi[a] = piece.box_lo[a] + size;
    }
    for (int whole = 1; whole >= 0; whole--) {
      memset(cells, 0, grid->cell_count * sizeof *cells);
      b.whole_triangles = whole;
      bbc__beam_piece_rows(&b, s, grid, &piece, &scratch, mark_row, &sink);
      uint64_t n = 0;
      for (uint64_t c = 0; c < grid->cell_count; c++) n += cells[c] > 0;
      *(whole ? &whole_cells : &clipped_cells) += n;
    }
    missed += uncovered(s, grid, cells, piece.box_lo, piece.box_hi, &inside);
    /* The control: cells of a box shrunk to its lower half on x. */
    bbc_beam_piece half = piece;
    half.box_hi[0] = 0.5 * (piece.box_lo[0] + piece.box_hi[0]);
    memset(cells, 0, grid->cell_count * sizeof *cells);
    bbc__beam_piece_rows(&b, s, grid, &half, &scratch, mark_row, &sink);
    uint64_t ignored = 0;
    control += uncovered(s, grid, cells, piece.box_lo, piece.box_hi, &ignored);
  }
  fprintf(stderr,
          "%llu points inside the boxes, %llu uncovered; cells: %llu clipped, %llu whole "
          "triangles; control (half boxes) misses %llu\n",
          (unsigned long long)inside, (unsigned long long)missed, (unsigned long long)clipped_cells,
          (unsigned long long)whole_cells, (unsigned long long)control);
  CHECK(inside > 10000);
  CHECK_INT(missed, 0);
  CHECK(clipped_cells < whole_cells);
  CHECK(control > 100);
  free(cells);
  bbc__beam_scratch_free(&scratch);
  bbc__beam_receivers_free(&b);
  bbc_grid_free(grid);
  bbc_scene_free(s);
}
