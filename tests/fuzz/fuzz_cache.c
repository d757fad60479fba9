/* fuzz_cache: the .bbc reader over arbitrary bytes (libFuzzer target).
 *
 * Opens the input with bbc_cache_open_memory; when that succeeds, reads the info and
 * every section entry, runs the full validation and walks every cell's list through
 * one cursor. The library must never crash, leak or trip a sanitizer, whatever the
 * bytes. Beyond that the target checks the reader's contract: when bbc_cache_validate
 * accepts the file, every cell decodes, its tuple ids are inside the tuple table and
 * sorted, and its bounds are not NaN or negative. A broken contract aborts, so the
 * fuzzer reports it like a crash.
 *
 * Built as a libFuzzer binary (BBC_BUILD_FUZZERS=ON with clang) and, with replay.c,
 * as an ordinary test that replays tests/corpus/fuzz-cache and tests/corpus/invalid. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "bbc/cache.h"

/* A cap on the cells walked per input so that one input stays fast; the cell table
 * lives in the file, so inputs small enough to fuzz stay far below it. */
#define FUZZ_MAX_CELLS ((uint64_t)1 << 22)

#define FUZZ_ASSERT(cond) \
  do {                    \
    if (!(cond)) abort(); \
  } while (0)

/* Formats nothing, but makes the library build every message it would report. */
static void ignore_message(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  (void)message;
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
  FUZZ_ASSERT(cache != NULL);

  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  for (uint32_t i = 0; i < info.section_count; i++) {
    bbc_cache_section section;
    bbc_cache_get_section(cache, i, &section);
    FUZZ_ASSERT(section.offset <= info.file_size && section.size <= info.file_size - section.offset);
  }
  (void)bbc_cache_tuples(cache);
  (void)bbc_cache_grid(cache);

  int valid = bbc_cache_validate(cache, ignore_message, NULL) == BBC_OK;

  bbc_cache_cursor *cursor = NULL;
  if (bbc_cache_cursor_create(&cursor, cache) == BBC_OK) {
    uint64_t cells = info.cell_count < FUZZ_MAX_CELLS ? info.cell_count : FUZZ_MAX_CELLS;
    uint64_t entries_seen = 0;
    for (uint64_t cell = 0; cell < cells; cell++) {
      const bbc_cache_entry *entries = NULL;
      uint32_t count = 0;
      bbc_result r = bbc_cache_cell(cursor, cell, &entries, &count);
      if (r != BBC_OK) {
        FUZZ_ASSERT(!valid);
        FUZZ_ASSERT(count == 0);
        continue;
      }
      entries_seen += count;
      for (uint32_t k = 0; k < count; k++) {
        FUZZ_ASSERT(entries[k].tuple < info.tuple_count);
        FUZZ_ASSERT(k == 0 || entries[k - 1].tuple < entries[k].tuple);
        FUZZ_ASSERT(entries[k].bound >= 0.0f); /* false for NaN too */
      }
    }
    /* An out-of-range cell is refused, not read. */
    const bbc_cache_entry *entries = NULL;
    uint32_t count = 0;
    FUZZ_ASSERT(bbc_cache_cell(cursor, info.cell_count, &entries, &count) ==
                BBC_ERR_INVALID_ARGUMENT);
    if (valid && cells == info.cell_count) FUZZ_ASSERT(entries_seen == info.entry_count);
    bbc_cache_cursor_free(cursor);
  } else {
    FUZZ_ASSERT(cursor == NULL);
  }
  bbc_cache_close(cache);
  return 0;
}
