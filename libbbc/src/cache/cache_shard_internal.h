/* Sharded precomputes (format-spec/bbc-format.md Sec. 5.10 and 7.4): the SHRD section
 * and the internal calls that the precompute driver (precompute.c), the writer
 * (cache_write.c), the reader (cache_read.c) and the merge (cache_merge.c) share.
 * Tests may include this header; tools may not. */
#ifndef BBC_CACHE_SHARD_INTERNAL_H
#define BBC_CACHE_SHARD_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"

/* Sec. 5.10: the SHRD section, a 32-byte head and one u64 per stored tuple. */
#define BBC__SEC_SHRD BBC__FOURCC('S', 'H', 'R', 'D')
#define BBC__SHRD_HEAD_SIZE 32u
#define BBC__SHRD_ENTRY_SIZE 8u

/* R-HDR-3: the minor version a writer writes, the smallest whose sections the file
 * uses: 0 without SHRD (so a complete cache is the same bytes as before shards
 * existed), 1 with it. */
#define BBC__MINOR_COMPLETE 0u
#define BBC__MINOR_SHARD 1u
#define BBC__MINOR_AREA 2u /* area lights (PARM flags bit 1) */
#define BBC__MINOR_GEOMETRY 3u /* the GEOM section */
#define BBC__MINOR_AREA_DOUBLE 4u /* area lights' double scattering (PARM flags bit 2) */
#define BBC__MINOR_AREA_ALPHA 5u  /* area lights' own ratio (PARM bytes 48-55) */
#define BBC__MINOR_PLANE 6u       /* receiver planes (RCVR parameterisation 3) */
#define BBC__MINOR_BEAM 7u        /* beam receivers (PARM flags bit 3) */
#define BBC__MINOR_LEVELS 8u      /* levels of cells (PARM bytes 56-59) */
#define BBC__MINOR_DOUBLE_LEVEL 9u /* the two-bounce tuples' own level (PARM bytes 60-63) */

/* XXH64 of a candidate list as TUPL records (the candidates_hash of SHRD). */
uint64_t bbc__candidates_hash(const bbc_tuple *tuples, size_t count);

/* Makes the builder write a shard cache, shard `index` of `count` (index < count, else
 * BBC_ERR_INVALID_ARGUMENT), of the complete candidate list tuples[0, *tuple_count).
 * The list is compacted in place to the shard's candidates (k % count == index, in
 * order) and *tuple_count updated; *candidate (malloc, the caller frees it) receives
 * the candidate index of each candidate left. Every tuple later added to the builder
 * must then be given its candidate index with bbc__cache_builder_set_candidate. */
bbc_result bbc__cache_builder_shard(bbc_cache_builder *b, uint32_t index, uint32_t count,
                                    bbc_tuple *tuples, size_t *tuple_count, uint64_t **candidate);

/* Makes the builder write a shard cache, shard `index` of `count` (index < count, else
 * BBC_ERR_INVALID_ARGUMENT), of a candidate list of candidate_count tuples whose
 * bbc__candidates_hash is candidates_hash, held by no one: the caller adds the shard's
 * tuples (k % count == index) and gives each its candidate index k. */
bbc_result bbc__cache_builder_set_shard(bbc_cache_builder *b, uint32_t index, uint32_t count,
                                        uint64_t candidate_count, uint64_t candidates_hash);

/* Records the candidate index of tuple `id` of a shard builder. The writer checks the
 * rules of R-SHR-3 and fails with BBC_ERR_INVALID_ARGUMENT if they do not hold. */
bbc_result bbc__cache_builder_set_candidate(bbc_cache_builder *b, uint32_t id, uint64_t candidate);

/* A builder for the scene and parameters of an open cache, given its information and
 * grid (bbc_cache_get_info, bbc_cache_grid): copies of its grid, parameters, fingerprint
 * and scene counts, and no tuple. */
bbc_result bbc__cache_builder_from_parts(bbc_cache_builder **out, const bbc_cache_info *info,
                                         const bbc_grid *g);

/* The INFO text the builder writes instead of "bbc <version>": `size` bytes of `text`
 * (at most 4096), or no INFO section when text is NULL. */
/* The GEOM section the builder writes (Sec. 5.11): `size` bytes of `section`, or none
 * when section is NULL (a builder made from parts has none until given one). */
bbc_result bbc__cache_builder_set_geometry(bbc_cache_builder *b, const void *section, size_t size);

/* Bytes the builder keeps per cell before any entry (for bbc_cache_check_resources). */
size_t bbc__cache_builder_cell_bytes(void);
bbc_result bbc__cache_builder_set_info(bbc_cache_builder *b, const void *text, size_t size);

/* Adds entries (tuple id, bound code) to cell `cell`, keeping the maximum code per
 * tuple. No lock is taken: concurrent callers must use distinct cells, and nothing
 * else may use the builder meanwhile. */
bbc_result bbc__cache_builder_add_codes(bbc_cache_builder *b, uint64_t cell, const uint32_t *tuples,
                                        const uint16_t *codes, uint32_t n);

/* Adds tuple `id`'s codes in rows y0 .. y0 + h - 1 of receiver `receiver`'s cells of level
 * `level` (< the grid's levels), keeping the maximum code per tuple: row y0 + k holds
 * spans[2k + 1] codes from column spans[2k], the rows' codes one after the other in
 * `codes`, 0 for no entry. Only the rows y with (y + receiver + level) % parts == part
 * are added. No lock is taken: concurrent
 * callers must pass the same `parts` and distinct `part`s (so they touch distinct rows),
 * and nothing else may use the builder meanwhile. A cell whose tuples come in
 * increasing order stays sorted, and is never sorted again. */
bbc_result bbc__cache_builder_add_rows(bbc_cache_builder *b, uint32_t id, uint32_t receiver,
                                       uint32_t level, uint32_t y0, uint32_t h,
                                       const uint32_t *spans, const uint16_t *codes, uint32_t part,
                                       uint32_t parts);

/* Bounded memory (spill_internal.h): past `bytes` of entry arrays in its cells (0: the
 * default), bbc__cache_builder_spill_if_full writes the builder's lists to its spill
 * store as a sorted run and frees them; writing merges the runs back. Call it only
 * where nothing else uses the builder (between batches of splats). BBC_ERR_IO when the
 * spill file cannot be written: bbc__cache_builder_error says why, and the builder then
 * refuses to write. */
#define BBC__DEFAULT_ENTRY_MEMORY ((size_t)8 << 20)
void bbc__cache_builder_set_entry_memory(bbc_cache_builder *b, size_t bytes);
bbc_result bbc__cache_builder_spill_if_full(bbc_cache_builder *b);
/* Whether the lists are over the budget (safe to call during splats). */
int bbc__cache_builder_full(const bbc_cache_builder *b);
void bbc__cache_builder_spill_stats(const bbc_cache_builder *b, uint32_t *runs, uint64_t *bytes);
const char *bbc__cache_builder_error(const bbc_cache_builder *b);

/* The path (or "(memory)") a cache was opened from. */
const char *bbc__cache_path(const bbc_cache *c);

/* The INFO section's bytes and size, or NULL when the file has none. Borrowed. */
const uint8_t *bbc__cache_info_bytes(const bbc_cache *c, uint64_t *size);
/* The GEOM section of an open cache (size 0 and NULL when it has none). */
const uint8_t *bbc__cache_geometry_bytes(const bbc_cache *c, uint64_t *size);

/* Writes the cache to file_path (created or truncated), naming `path` in messages. */
bbc_result bbc__cache_builder_write_file(bbc_cache_builder *b, const char *file_path,
                                         const char *path, const bbc_cache_write_options *o);

#endif
