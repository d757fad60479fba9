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

static void check_stream(const char *scene, uint32_t chains, uint32_t area_chains) {
  bbc_scene *s = NULL;
  REQUIRE(bbc_scene_load(&s, scene, NULL) == BBC_OK);
  size_t count = 0;
  bbc_tuple *want = reference_list(s, chains, area_chains, &count);
  REQUIRE(want != NULL);
  CHECK(count > 100); /* enough for many windows */
  /* Blocks of 4 kB (about 200 tuples) make the windows shrink and grow. */
  static const size_t budgets[2] = {4096, 0};
  for (int threads = 1; threads <= 2; threads++)
    for (int b = 0; b < 2; b++) {
      bbc__tuple_search *search = NULL;
      REQUIRE(bbc__tuple_search_create(&search, s, chains, area_chains, threads, budgets[b]) ==
              BBC_OK);
      size_t got = 0, blocks = 0, mismatches = 0;
      for (;;) {
        const bbc_tuple *block;
        size_t n;
        REQUIRE(bbc__tuple_search_next(search, &block, &n) == BBC_OK);
        if (n == 0) break;
        blocks++;
        for (size_t i = 0; i < n; i++, got++)
          mismatches += got >= count || memcmp(&block[i], &want[got], sizeof *block) != 0;
      }
      uint64_t done, total;
      bbc__tuple_search_progress(search, &done, &total);
      CHECK(done == total);
      CHECK(total > 0);
      bbc__tuple_search_free(search);
      CHECK_INT(got, count);
      CHECK_INT(mismatches, 0);
      CHECK(blocks > 1);
    }
  free(want);
  bbc_scene_free(s);
}

TEST(stream_is_the_list_mirrors) {
  check_stream(TEST_SCENE("wavy-mirror.gltf"), BBC_CHAIN_MASK_ALL, 0);
}

TEST(stream_is_the_list_glass) {
  check_stream(TEST_SCENE("ball80.gltf"), BBC_CHAIN_MASK_ALL, 0);
}

TEST(stream_is_the_list_area_lights) {
  check_stream(TEST_SCENE("wavy-corner-area.gltf"), BBC_CHAIN_MASK_ALL, BBC_CHAIN_MASK_ALL);
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
  size_t count = 0;
  bbc_tuple *want = reference_list(s, BBC_CHAIN_MASK_ALL, 0, &count);
  REQUIRE(want != NULL);
  uint64_t per_chain[BBC_CHAIN_COUNT] = {0};
  for (size_t i = 0; i < count; i++) per_chain[want[i].chain]++;
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
  free(want);
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
