/* The candidate tuples as a stream (tuple_search_internal.h) and the census that counts
 * them before a precompute bounds any (candidates_internal.h): the stream must hand out
 * exactly the list bbc_tuples_find returns, in its order, whatever the threads and the
 * block budget; the estimate must count exactly those candidates; and a cache must be
 * the same bytes whether its candidate list was held or searched again while bounding. */
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "bbc/precompute.h"
#include "harness.h"
#include "tuple_search_internal.h"

/* The list of bbc_tuples_find, then bbc_tuples_find_area's for area_chains (0: none). */
static bbc_tuple *reference_list(const bbc_scene *s, uint32_t chains, uint32_t area_chains,
                                 size_t *count) {
  bbc_tuple *a = NULL, *b = NULL;
  size_t na = 0, nb = 0;
  if (bbc_tuples_find(s, chains, &a, &na) != BBC_OK) return NULL;
  if (area_chains && bbc_tuples_find_area(s, area_chains, &b, &nb) != BBC_OK) return NULL;
  bbc_tuple *all = realloc(a, (na + nb + 1) * sizeof *all);
  if (!all) return NULL;
  if (nb) memcpy(all + na, b, nb * sizeof *b);
  free(b);
  *count = na + nb;
  return all;
}

/* The candidates of reference_list per chain type into per_chain, and their count. */
static void reference_per_chain(const bbc_scene *s, uint32_t chains,
                                uint64_t per_chain[BBC_CHAIN_COUNT], size_t *count) {
  memset(per_chain, 0, BBC_CHAIN_COUNT * sizeof *per_chain);
  *count = 0;
  bbc_tuple *want = reference_list(s, chains, 0, count);
  REQUIRE(want != NULL);
  for (size_t i = 0; i < *count; i++) per_chain[want[i].chain]++;
  free(want);
}

/* Whether two tuples share their prefix (light, T1), and (light, T1, T2). */
static int same_first(const bbc_tuple *a, const bbc_tuple *b) {
  return a->light == b->light && a->specular[0] == b->specular[0];
}

static int same_pair(const bbc_tuple *a, const bbc_tuple *b) {
  return same_first(a, b) && a->specular[1] == b->specular[1] && a->specular[1] != BBC_NO_TRIANGLE;
}

/* The stream against the list for block budgets of 4 kB (about 200 tuples: the windows
 * shrink and grow), the default, and `tiny` bytes: then the candidates of one (light, T1)
 * prefix are handed out over several blocks, and the search must carry on where it
 * stopped inside them. `triangles`: the receiver planes count as their triangles (one
 * prefix (light, T1, T2) then reaches many receivers, which `tiny` must split too). */
static void check_stream(const char *scene, uint32_t chains, uint32_t area_chains, size_t tiny,
                         int triangles) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, scene, NULL) == BBC_OK);
  for (uint32_t m = 0; triangles && m < s->mesh_count; m++) s->meshes[m].plane = 0;
  size_t count = 0;
  bbc_tuple *want = reference_list(s, chains, area_chains, &count);
  REQUIRE(want != NULL);
  CHECK(count > 100); /* enough for many windows */
  const size_t budgets[3] = {4096, 0, tiny};
  for (int threads = 1; threads <= 2; threads++)
    for (int b = 0; b < 3; b++) {
      bbc__tuple_search *search = NULL;
      REQUIRE(bbc__tuple_search_create(&search, s, chains, area_chains, 0, threads, budgets[b]) ==
              BBC_OK);
      size_t got = 0, blocks = 0, mismatches = 0, largest = 0;
      size_t first_splits = 0, pair_splits = 0;
      bbc_tuple last;
      for (;;) {
        const bbc_tuple *block;
        size_t n;
        REQUIRE(bbc__tuple_search_next(search, &block, &n) == BBC_OK);
        if (n == 0) break;
        if (blocks) {
          first_splits += same_first(&last, &block[0]);
          pair_splits += same_pair(&last, &block[0]);
        }
        blocks++;
        largest = n > largest ? n : largest;
        for (size_t i = 0; i < n; i++, got++)
          mismatches += got >= count || memcmp(&block[i], &want[got], sizeof *block) != 0;
        last = block[n - 1];
      }
      uint64_t done, total;
      bbc__tuple_search_progress(search, &done, &total);
      CHECK(done == total);
      CHECK(total > 0);
      const size_t peak = bbc__tuple_search_peak_bytes(search);
      bbc__tuple_search_free(search);
      CHECK_INT(got, count);
      CHECK_INT(mismatches, 0);
      CHECK(blocks > 1);
      if (budgets[b]) {
        /* Never more than the budget held (it is at least one tuple per thread). */
        CHECK(largest * sizeof(bbc_tuple) <= budgets[b]);
        CHECK(peak <= budgets[b]);
      }
      if (b == 2) {
        CHECK(first_splits > 0);
        if (triangles) CHECK(pair_splits > 0);
      }
    }
  free(want);
  bbc_scene_free(s);
}

#define TINY (3 * sizeof(bbc_tuple))

TEST(stream_is_the_list_mirrors) {
  check_stream(TEST_SCENE("wavy-mirror.gltf"), BBC_CHAIN_MASK_ALL, 0, TINY, 0);
}

/* A glass ball resting on its floor at a pole: TT alone (no light inside the ball lands
 * on the floor with an area, so no T), of 320 triangles for enough of them. */
TEST(stream_is_the_list_glass) {
  check_stream(TEST_SCENE("glass-sphere.gltf"), BBC_CHAIN_MASK_ALL, 0, TINY, 0);
}

TEST(stream_is_the_list_area_lights) {
  check_stream(TEST_SCENE("wavy-corner-area.gltf"), BBC_CHAIN_MASK_ALL, BBC_CHAIN_MASK_ALL, TINY,
               0);
}

/* The glass ball over its floor's two triangles: a pair (T1, T2) reaches both. */
TEST(stream_splits_inside_a_pair) {
  check_stream(TEST_SCENE("ball80.gltf"), BBC_CHAIN_MASK_ALL, 0, TINY, 1);
}

/* The glass sphere over a floor of 3,000 triangles: a pair reaches up to all of them, a
 * prefix (light, T1) some 18,000, and blocks of 1,000 tuples split both many times. */
TEST(stream_splits_long_receiver_lists) {
  check_stream(TEST_SCENE("plane-glass-sphere-3k.gltf"), BBC_CHAIN_MASK_ALL, 0,
               1000 * sizeof(bbc_tuple), 1);
}

/* The estimate stops the precompute before any bounding. */
static int keep_estimate(void *user, const bbc_precompute_estimate *e) {
  *(bbc_precompute_estimate *)user = *e;
  return 1;
}

/* The estimate counts the candidates exactly: all of them, per chain type, and the ones
 * a shard bounds, against the list of bbc_tuples_find. */
TEST(estimate_counts_the_candidates) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("wavy-mirror.gltf"), NULL) == BBC_OK);
  uint64_t per_chain[BBC_CHAIN_COUNT];
  size_t count = 0;
  reference_per_chain(s, BBC_CHAIN_MASK_ALL, per_chain, &count);
  for (uint32_t shards = 0; shards <= 3; shards += 3) {
    bbc_precompute_options o;
    memset(&o, 0, sizeof o);
    bbc_precompute_params_default(&o.params);
    o.threads = 2;
    o.shard_count = shards;
    o.shard_index = shards ? 1 : 0;
    bbc_precompute_estimate e;
    memset(&e, 0, sizeof e);
    o.estimate_fn = keep_estimate;
    o.user = &e;
    bbc_cache_builder *b = NULL;
    CHECK_INT(bbc_precompute(&b, s, &o, NULL), BBC_ERR_CANCELLED);
    CHECK(b == NULL);
    CHECK_INT(e.candidate_tuples, count);
    for (int c = 0; c < BBC_CHAIN_COUNT; c++) CHECK_INT(e.candidates_per_chain[c], per_chain[c]);
    CHECK_INT(e.bounded_tuples, shards ? (count - 2) / 3 + 1 : count);
    CHECK_INT(e.list_bytes, count * sizeof(bbc_tuple));
    CHECK(e.list_held);
    CHECK(e.sample_tuples > 0 && e.sample_tuples <= 256);
    CHECK(e.bounding_cpu_seconds > 0 && e.seconds > 0);
    CHECK(e.stored_tuples <= e.bounded_tuples);
    CHECK(e.memory_bytes > 0 && e.file_bytes > 0);
  }
  bbc_scene_free(s);
}

/* The cache of a precompute, in memory. */
static void *cache_bytes(const bbc_scene *s, int threads, size_t candidate_memory,
                         uint32_t shard_index, uint32_t shard_count, size_t *size,
                         int *held) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.max_level = 3;
  o.threads = threads;
  o.candidate_memory = candidate_memory;
  o.shard_index = shard_index;
  o.shard_count = shard_count;
  bbc_cache_builder *b = NULL;
  bbc_precompute_stats st;
  if (bbc_precompute(&b, s, &o, &st) != BBC_OK) return NULL;
  *held = st.estimate.list_held;
  void *bytes = NULL;
  bbc_result r = bbc_cache_builder_write_memory(b, &bytes, size, NULL);
  bbc_cache_builder_free(b);
  return r == BBC_OK ? bytes : NULL;
}

/* A list too long to hold (candidate_memory of one byte) is searched again while it is
 * bounded: the cache is the same bytes as with the list held, for any thread count, and
 * for a shard. */
TEST(cache_same_held_or_searched_again) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("wavy-mirror.gltf"), NULL) == BBC_OK);
  for (uint32_t shards = 0; shards <= 2; shards += 2) {
    size_t na = 0, nb = 0, nc = 0;
    int held_a = 0, held_b = 1, held_c = 1;
    void *a = cache_bytes(s, 1, 0, shards ? 1 : 0, shards, &na, &held_a);
    void *b = cache_bytes(s, 2, 1, shards ? 1 : 0, shards, &nb, &held_b);
    void *c = cache_bytes(s, 1, 1, shards ? 1 : 0, shards, &nc, &held_c);
    REQUIRE(a && b && c);
    CHECK(held_a);
    CHECK(!held_b && !held_c);
    CHECK_INT(na, nb);
    CHECK_INT(na, nc);
    CHECK(na == nb && memcmp(a, b, na) == 0);
    CHECK(na == nc && memcmp(a, c, na) == 0);
    free(a);
    free(b);
    free(c);
  }
  bbc_scene_free(s);
}

/* The choice of the default chain types (bbc_precompute_choose_chains) on a scene with
 * every chain type: its work is counted, not clocked, so the choice is the same for any
 * thread count and shard; the costliest two-bounce type goes first, and only as many as
 * the budget asks; candidates are the census's exactly. */
static bbc_chain_choice choose(const bbc_scene *s, int threads, uint32_t shard_count,
                               double max_pieces) {
  bbc_precompute_options o;
  memset(&o, 0, sizeof o);
  bbc_precompute_params_default(&o.params);
  o.params.max_level = 4;
  o.threads = threads;
  o.shard_count = shard_count;
  o.shard_index = shard_count ? shard_count - 1 : 0;
  bbc_chain_choice c;
  memset(&c, 0xAB, sizeof c);
  CHECK_INT(bbc_precompute_choose_chains(s, &o, max_pieces, &c), BBC_OK);
  return c;
}

TEST(default_chains_by_counted_work) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, TEST_SCENE("mirror-pool.gltf"), NULL) == BBC_OK);
  uint64_t per_chain[BBC_CHAIN_COUNT];
  size_t count = 0;
  reference_per_chain(s, BBC_CHAIN_MASK_DOUBLE, per_chain, &count);

  const bbc_chain_choice all = choose(s, 1, 0, 1e30);
  CHECK_INT(all.chains, BBC_CHAIN_MASK_ALL);
  CHECK_INT(all.left_out, 0);
  double total = 0;
  int worst = -1, types = 0;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    const int dbl = (BBC_CHAIN_MASK_DOUBLE & BBC_CHAIN_BIT(c)) != 0;
    CHECK_INT(all.candidates[c], dbl ? per_chain[c] : 0);
    CHECK(dbl ? all.pieces[c] >= (double)per_chain[c] : all.pieces[c] == 0);
    total += all.pieces[c];
    types += dbl && per_chain[c] > 0;
    if (dbl && (worst < 0 || all.pieces[c] > all.pieces[worst])) worst = c;
  }
  CHECK(types == 4); /* RR, RT, TR and TT all have candidates */

  /* Counted work: the same for two threads and for a shard (every shard chooses the
   * same chains, from every candidate). */
  const bbc_chain_choice two = choose(s, 2, 0, 1e30), shard = choose(s, 2, 3, 1e30);
  CHECK(memcmp(&all, &two, sizeof all) == 0);
  CHECK(memcmp(&all, &shard, sizeof all) == 0);

  /* A budget just short of the total leaves out the costliest type alone; one just
   * above it, none. */
  const bbc_chain_choice less = choose(s, 2, 0, total - 0.5 * all.pieces[worst]);
  CHECK_INT(less.left_out, BBC_CHAIN_BIT(worst));
  CHECK_INT(less.chains, BBC_CHAIN_MASK_ALL & ~BBC_CHAIN_BIT(worst));
  CHECK_INT(choose(s, 2, 0, total * 1.001).left_out, 0);
  /* A budget below every type's work leaves out all four; 0 does so without weighing. */
  double least = 1e300;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (per_chain[c] && all.pieces[c] < least) least = all.pieces[c];
  CHECK_INT(choose(s, 1, 0, 0.5 * least).left_out, BBC_CHAIN_MASK_DOUBLE);
  const bbc_chain_choice none = choose(s, 1, 0, 0);
  CHECK_INT(none.left_out, BBC_CHAIN_MASK_DOUBLE);
  CHECK_INT(none.chains, BBC_CHAIN_MASK_ALL & ~BBC_CHAIN_MASK_DOUBLE);
  CHECK(none.candidates[BBC_CHAIN_TT] == 0 && none.pieces[BBC_CHAIN_TT] == 0);
  bbc_scene_free(s);
}
