/* The census of the candidate tuples (candidates.c): one pass of the tuple search that
 * counts them before anything is bounded, so that a precompute knows what it will cost
 * before it spends it, and then the candidates again, a batch at a time, for the
 * bounding: from the list the census kept when it was small enough, else from a second
 * search, so that the whole list is never held. */
#ifndef BBC_CANDIDATES_INTERNAL_H
#define BBC_CANDIDATES_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/common.h"
#include "bbc/scene.h"
#include "bbc/tuple.h"
#include "tuple_search_internal.h"

/* What to search: the point lights' chain types, the emitters' (0: none), the threads
 * and a shard (count 0: none; the census counts every candidate, the sample and
 * `bounded` only the shard's). */
typedef struct bbc__census_request {
  uint32_t chains, area_chains;
  int beam; /* beam receivers (bbc_precompute_params.beam_receivers) */
  int threads;
  uint32_t shard_index, shard_count;
  size_t hold_bytes;  /* keep the list when its bytes are at most this */
  size_t block_bytes; /* the search's aim for a block (tuple_search_internal.h) */
  size_t sample_max;  /* candidates drawn for the timed sample */
  int sample_per_chain;     /* 1: sample_max of each chain type (bbc_precompute_choose_chains) */
  bbc_progress_fn progress; /* optional: prefixes searched / total; non-zero cancels */
  void *progress_user;
} bbc__census_request;

typedef struct bbc__census {
  uint64_t count; /* every candidate, in the order of bbc_tuples_find */
  uint64_t per_chain[BBC_CHAIN_COUNT];
  uint64_t bounded; /* the candidates the shard bounds (count without a shard) */
  uint64_t hash;    /* bbc__candidates_hash of the whole list */
  double second_per_first;
  bbc_tuple *held;        /* the whole list when it fit hold_bytes (malloc), else NULL */
  size_t block_peak;      /* the most bytes of tuples the search held at once */
  double seconds;         /* wall time of the census */
  bbc_tuple *sample;      /* sample_count of the bounded candidates drawn uniformly */
  size_t sample_count;
} bbc__census;

/* Runs the census; on failure nothing is left to free. BBC_ERR_CANCELLED when the
 * progress callback asked. */
bbc_result bbc__census_take(bbc__census *c, const bbc_scene *scene,
                            const bbc__census_request *q);
void bbc__census_free(bbc__census *c);

/* The candidates a census counted, again, in order: the shard's, in batches. */
typedef struct bbc__candidates {
  const bbc__census *census;
  bbc__tuple_search *search; /* NULL when the census held the list */
  const bbc_tuple *block;
  size_t block_count, block_pos;
  uint64_t next; /* candidate index of block[block_pos] */
  uint32_t shard_index, shard_count;
  double search_seconds; /* wall time spent searching again */
} bbc__candidates;

bbc_result bbc__candidates_begin(bbc__candidates *s, const bbc_scene *scene,
                                 const bbc__census *c, const bbc__census_request *q);
/* Up to `max` of the next candidates of the shard into tuples[] with their candidate
 * indices (k may be NULL); *n == 0 at the end. */
bbc_result bbc__candidates_next(bbc__candidates *s, bbc_tuple *tuples, uint64_t *k, size_t max,
                                size_t *n);
void bbc__candidates_end(bbc__candidates *s);

#endif
