/* The census of the candidate tuples and their second reading (candidates_internal.h).
 * The search is deterministic, so a second search gives the same candidates in the same
 * order as the first: the census may forget them and the bounding find them again, and
 * the cache does not depend on whether the list was held. */
#include "candidates_internal.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "cache_format_internal.h"
#include "rng_internal.h"

/* Whether candidate k is the shard's. */
static int in_shard(uint64_t k, uint32_t index, uint32_t count) {
  return count == 0 || k % count == index;
}

bbc_result bbc__census_take(bbc__census *c, const bbc_scene *scene,
                            const bbc__census_request *q) {
  memset(c, 0, sizeof *c);
  const double t0 = omp_get_wtime();
  bbc__tuple_search *s = NULL;
  bbc_result r = bbc__tuple_search_create(&s, scene, q->chains, q->area_chains, q->beam, q->threads,
                                          q->block_bytes);
  /* The reservoir: sample_max slots, or sample_max per chain type. */
  const size_t strata = q->sample_per_chain ? BBC_CHAIN_COUNT : 1;
  uint64_t seen[BBC_CHAIN_COUNT] = {0}; /* the shard's candidates so far, per stratum */
  size_t drawn[BBC_CHAIN_COUNT] = {0};
  c->sample = q->sample_max ? malloc(strata * q->sample_max * sizeof *c->sample) : NULL;
  if (r == BBC_OK && q->sample_max && !c->sample) r = BBC_ERR_OUT_OF_MEMORY;
  bbc__xxh64_state hash;
  bbc__xxh64_init(&hash);
  size_t held_cap = 0;
  int holding = 1;
  /* Tuples come ordered by light, T1, T2: count the distinct prefixes and pairs. */
  uint64_t firsts = 0, pairs = 0;
  bbc_tuple last;
  int have_last = 0;
  while (r == BBC_OK) {
    const bbc_tuple *block;
    size_t n;
    if ((r = bbc__tuple_search_next(s, &block, &n)) != BBC_OK || n == 0) break;
    bbc__xxh64_update(&hash, block, n * sizeof *block);
    for (size_t i = 0; i < n; i++) {
      const bbc_tuple *t = &block[i];
      const uint64_t k = c->count + i;
      c->per_chain[t->chain < BBC_CHAIN_COUNT ? t->chain : 0]++;
      if (in_shard(k, q->shard_index, q->shard_count)) {
        /* Reservoir sampling with a hash for the dice: the j-th of the shard's
         * candidates (of its chain type, per stratum) replaces a drawn one with
         * probability sample_max / (j + 1). */
        c->bounded++;
        const size_t h = strata > 1 && t->chain < BBC_CHAIN_COUNT ? t->chain : 0;
        bbc_tuple *slots = c->sample + h * q->sample_max;
        const uint64_t j = seen[h]++;
        if (j < q->sample_max) {
          slots[drawn[h]++] = *t;
        } else if (q->sample_max) {
          const uint64_t slot = bbc__mix64(j ^ 0x5DEECE66Dull) % (j + 1);
          if (slot < q->sample_max) slots[slot] = *t;
        }
      }
      if (bbc_chain_length((bbc_chain)t->chain) != 2) continue;
      const int new_first =
          !have_last || last.light != t->light || last.specular[0] != t->specular[0];
      firsts += new_first;
      pairs += new_first || last.specular[1] != t->specular[1];
      last = *t;
      have_last = 1;
    }
    c->count += n;
    /* The list is kept while it fits hold_bytes, then forgotten for good. */
    if (holding && c->count * sizeof *block > q->hold_bytes) {
      free(c->held);
      c->held = NULL;
      holding = 0;
    }
    if (holding && c->count > held_cap) {
      size_t cap = held_cap ? held_cap : 1024;
      while (cap < c->count) cap *= 2;
      if (cap * sizeof *block > q->hold_bytes) cap = (size_t)c->count;
      bbc_tuple *grown = realloc(c->held, cap * sizeof *grown);
      if (!grown) {
        r = BBC_ERR_OUT_OF_MEMORY;
        break;
      }
      c->held = grown;
      held_cap = cap;
    }
    if (holding) memcpy(c->held + (c->count - n), block, n * sizeof *block);
    if (q->progress) {
      uint64_t done, total;
      bbc__tuple_search_progress(s, &done, &total);
      if (q->progress(q->progress_user, done, total)) r = BBC_ERR_CANCELLED;
    }
  }
  if (r == BBC_OK) {
    c->block_peak = bbc__tuple_search_peak_bytes(s);
    if (holding && !c->held) c->held = malloc(sizeof *c->held); /* an empty list, held */
    if (holding && !c->held) r = BBC_ERR_OUT_OF_MEMORY;
  }
  bbc__tuple_search_free(s);
  if (r != BBC_OK) {
    bbc__census_free(c);
    return r;
  }
  /* The strata's draws, one after the other. */
  for (size_t h = 0; h < strata; h++) {
    if (drawn[h])
      memmove(c->sample + c->sample_count, c->sample + h * q->sample_max,
              drawn[h] * sizeof *c->sample);
    c->sample_count += drawn[h];
  }
  c->hash = bbc__xxh64_final(&hash);
  c->second_per_first = firsts ? (double)pairs / (double)firsts : 0.0;
  c->seconds = omp_get_wtime() - t0;
  return BBC_OK;
}

void bbc__census_free(bbc__census *c) {
  free(c->held);
  free(c->sample);
  memset(c, 0, sizeof *c);
}

bbc_result bbc__candidates_begin(bbc__candidates *s, const bbc_scene *scene,
                                 const bbc__census *c, const bbc__census_request *q) {
  memset(s, 0, sizeof *s);
  s->census = c;
  s->shard_index = q->shard_index;
  s->shard_count = q->shard_count;
  if (c->held) {
    s->block = c->held;
    s->block_count = (size_t)c->count;
    return BBC_OK;
  }
  return bbc__tuple_search_create(&s->search, scene, q->chains, q->area_chains, q->beam, q->threads,
                                  q->block_bytes);
}

bbc_result bbc__candidates_next(bbc__candidates *s, bbc_tuple *tuples, uint64_t *k, size_t max,
                                size_t *n) {
  *n = 0;
  while (*n < max) {
    if (s->block_pos == s->block_count) {
      if (!s->search) break;
      const double t0 = omp_get_wtime();
      bbc_result r = bbc__tuple_search_next(s->search, &s->block, &s->block_count);
      s->search_seconds += omp_get_wtime() - t0;
      s->block_pos = 0;
      if (r != BBC_OK) return r;
      if (s->block_count == 0) {
        bbc__tuple_search_free(s->search);
        s->search = NULL;
        break;
      }
    }
    /* The shard's candidates of the block, in order. */
    for (; s->block_pos < s->block_count && *n < max; s->block_pos++, s->next++) {
      if (!in_shard(s->next, s->shard_index, s->shard_count)) continue;
      tuples[*n] = s->block[s->block_pos];
      if (k) k[*n] = s->next;
      ++*n;
    }
  }
  /* The search found what the census counted (it is deterministic). */
  assert(*n > 0 || s->next == s->census->count);
  return BBC_OK;
}

void bbc__candidates_end(bbc__candidates *s) {
  bbc__tuple_search_free(s->search);
  s->search = NULL;
}
