/* fuzz_lookup: cell lookups through the renderer's cursor on arbitrary bytes (libFuzzer
 * target).
 *
 * Opens the input as bbc-render --no-verify does (bbc_cache_open_memory, no full
 * validation), then looks up points of every receiver triangle with bbc_cache_lookup,
 * as the caustic estimator does at a shading point: the vertices, the centroid, edge
 * midpoints, points just outside the triangle, NaN and huge barycentrics. Lookups visit
 * the triangles forwards and then backwards, so chunks are decoded, kept and reused in
 * the cursor in different orders. The library must never crash, leak or trip a
 * sanitizer. The contract checked beyond that (abort() otherwise):
 *   - a failed lookup returns no entries (R-REN-1 relies on it: nothing of a damaged
 *     chunk reaches the estimator) and fails again when repeated (a damaged chunk is
 *     never taken for verified);
 *   - a lookup equals bbc_cache_cell of the cell bbc_grid_locate gives;
 *   - returned entries have tuple ids in the table, strictly increasing, and bounds that
 *     are not NaN or negative;
 *   - when bbc_cache_validate accepts the file, no lookup fails.
 *
 * Built as a libFuzzer binary (BBC_BUILD_FUZZERS=ON with clang) and, with replay.c,
 * as an ordinary test over tests/corpus/fuzz-cache and tests/corpus/invalid. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "bbc/cache.h"
#include "bbc/grid.h"
#include "bbc/tuple.h"

/* Lookups per input, so that one input stays fast. */
#define FUZZ_MAX_LOOKUPS 20000

#define FUZZ_ASSERT(cond) \
  do {                    \
    if (!(cond)) abort(); \
  } while (0)

static void ignore_message(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  (void)message;
}

/* Barycentrics (b1, b2) a shading point may have, including rounding spill and junk. */
static const double points[][2] = {
    {0, 0},         {1, 0},        {0, 1},     {1.0 / 3, 1.0 / 3}, {0.5, 0},
    {0, 0.5},       {0.5, 0.5},    {-1e-9, 0}, {1 + 1e-9, 0},      {0.7, 0.7},
    {-5, 3},        {1e300, -1e300}, {NAN, 0.2}, {0.2, NAN},       {INFINITY, -INFINITY},
};
#define POINTS (sizeof points / sizeof *points)

static int fails_validation;

/* One lookup, checked against the contract; returns the result. */
static bbc_result check_lookup(bbc_cache_cursor *cursor, bbc_cache_cursor *cell_cursor,
                               const bbc_grid *grid, uint32_t tuple_count, uint32_t triangle,
                               double b1, double b2) {
  const bbc_cache_entry *entries = NULL;
  uint32_t count = 0;
  /* A position to go with them (it locates a receiver plane's triangles), junk too. */
  const bbc_vec3 point = {b1, b2, b1 - b2};
  bbc_result r = bbc_cache_lookup(cursor, triangle, b1, b2, &point, &entries, &count);
  if (r != BBC_OK) {
    FUZZ_ASSERT(entries == NULL && count == 0);
    FUZZ_ASSERT(fails_validation);
    const bbc_cache_entry *again = NULL;
    uint32_t again_count = 0;
    FUZZ_ASSERT(bbc_cache_lookup(cursor, triangle, b1, b2, &point, &again, &again_count) !=
                BBC_OK);
    FUZZ_ASSERT(again == NULL && again_count == 0);
    return r;
  }
  FUZZ_ASSERT(count == 0 || entries != NULL);
  for (uint32_t k = 0; k < count; k++) {
    FUZZ_ASSERT(entries[k].tuple < tuple_count);
    FUZZ_ASSERT(k == 0 || entries[k - 1].tuple < entries[k].tuple);
    FUZZ_ASSERT(entries[k].bound >= 0.0f); /* false for NaN too */
  }
  bbc_cell cell;
  if (!bbc_grid_locate(grid, triangle, b1, b2, &point, &cell)) {
    FUZZ_ASSERT(count == 0);
    return r;
  }
  /* The same list through the cell API and a second cursor. */
  const bbc_cache_entry *same = NULL;
  uint32_t same_count = 0;
  FUZZ_ASSERT(bbc_cache_cell(cell_cursor, bbc_grid_cell_index(grid, cell), &same, &same_count) ==
              BBC_OK);
  FUZZ_ASSERT(same_count == count);
  for (uint32_t k = 0; k < count; k++)
    FUZZ_ASSERT(same[k].tuple == entries[k].tuple && same[k].bound == entries[k].bound);
  return r;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  bbc_cache_options options = {0};
  options.error_fn = ignore_message;
  bbc_cache *cache = NULL;
  if (bbc_cache_open_memory(&cache, data, size, &options) != BBC_OK) {
    FUZZ_ASSERT(cache == NULL);
    return 0;
  }
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  const bbc_grid *grid = bbc_cache_grid(cache);
  fails_validation = bbc_cache_validate(cache, ignore_message, NULL) != BBC_OK;
  bbc_cache_cursor *cursor = NULL, *cell_cursor = NULL;
  if (bbc_cache_cursor_create(&cursor, cache) == BBC_OK &&
      bbc_cache_cursor_create(&cell_cursor, cache) == BBC_OK) {
    long lookups = 0;
    for (int pass = 0; pass < 2; pass++) {
      for (uint32_t i = 0; i < grid->receiver_count; i++) {
        const bbc_receiver *rc = &grid->receivers[pass ? grid->receiver_count - 1 - i : i];
        for (uint32_t k = 0; k < rc->triangle_count && lookups < FUZZ_MAX_LOOKUPS; k++) {
          uint32_t t = rc->first_triangle + (pass ? rc->triangle_count - 1 - k : k);
          for (size_t p = 0; p < POINTS; p++, lookups++)
            check_lookup(cursor, cell_cursor, grid, info.tuple_count, t, points[p][0],
                         points[p][1]);
        }
        /* A plane, by its plane triangle's barycentrics. */
        for (size_t p = 0; rc->parameterisation == BBC_PARAM_PLANE && p < POINTS; p++, lookups++)
          check_lookup(cursor, cell_cursor, grid, info.tuple_count, BBC_RECEIVER_PLANE(rc->mesh),
                       points[p][0], points[p][1]);
      }
    }
    /* Triangles that are not receivers give nothing. */
    const bbc_cache_entry *entries = NULL;
    uint32_t count = 0;
    FUZZ_ASSERT(bbc_cache_lookup(cursor, info.scene_triangle_count, 0.2, 0.2, NULL, &entries,
                                 &count) == BBC_OK &&
                count == 0);
    FUZZ_ASSERT(bbc_cache_lookup(cursor, UINT32_MAX, 0.2, 0.2, NULL, &entries, &count) ==
                    BBC_OK &&
                count == 0);
  }
  bbc_cache_cursor_free(cursor);
  bbc_cache_cursor_free(cell_cursor);
  bbc_cache_close(cache);
  return 0;
}
