/* print_cell: opens a .bbc cache and prints one cell's list, using nothing but the
 * installed libbbc. It is the smallest program built against an installed bbc, with
 * CMake (CMakeLists.txt beside it) or with pkg-config (Makefile beside it).
 *
 *   print_cell CACHE.bbc [CELL]
 *
 * CELL is a global cell index (default: the first cell that holds any tuple). Each
 * line of the list is: tuple id, chain type, light, specular triangles, receiver
 * triangle and irradiance bound. */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>

#include <bbc/bbc.h>

static void print_error(void *user, bbc_result code, const char *message) {
  (void)user;
  fprintf(stderr, "print_cell: %s (%s)\n", message, bbc_result_string(code));
}

int main(int argc, char **argv) {
  if (argc < 2 || argc > 3) {
    fprintf(stderr, "usage: print_cell CACHE.bbc [CELL]\n");
    return 2;
  }
  bbc_cache_options options = {print_error, NULL, 0};
  bbc_cache *cache = NULL;
  bbc_result r = bbc_cache_open(&cache, argv[1], &options);
  if (r != BBC_OK) {
    fprintf(stderr, "print_cell: %s: %s\n", argv[1], bbc_result_string(r));
    return 1;
  }
  bbc_cache_info info;
  bbc_cache_get_info(cache, &info);
  printf("%s: libbbc %s, format %u.%u, %" PRIu32 " tuples, %" PRIu64 " cells\n", argv[1],
         bbc_version_string(), info.version_major, info.version_minor, info.tuple_count,
         info.cell_count);

  bbc_cache_cursor *cursor = NULL;
  r = bbc_cache_cursor_create(&cursor, cache);
  const bbc_cache_entry *entries = NULL;
  uint32_t count = 0;
  uint64_t cell = 0;
  if (r == BBC_OK && argc == 3) {
    char *end;
    errno = 0;
    unsigned long long v = strtoull(argv[2], &end, 10);
    if (errno || end == argv[2] || *end || v >= info.cell_count) {
      fprintf(stderr, "print_cell: '%s' is not a cell index below %" PRIu64 "\n", argv[2],
              info.cell_count);
      bbc_cache_cursor_free(cursor);
      bbc_cache_close(cache);
      return 2;
    }
    cell = v;
    r = bbc_cache_cell(cursor, cell, &entries, &count);
  } else if (r == BBC_OK) {
    /* The first cell with a list. */
    for (cell = 0; cell < info.cell_count; cell++) {
      r = bbc_cache_cell(cursor, cell, &entries, &count);
      if (r != BBC_OK || count > 0) break;
    }
  }
  if (r != BBC_OK) {
    fprintf(stderr, "print_cell: %s: %s\n", argv[1], bbc_result_string(r));
    bbc_cache_cursor_free(cursor);
    bbc_cache_close(cache);
    return 1;
  }

  const bbc_tuple *tuples = bbc_cache_tuples(cache);
  printf("cell %" PRIu64 ": %" PRIu32 " tuples\n", cell, count);
  for (uint32_t i = 0; i < count; i++) {
    const bbc_tuple *t = &tuples[entries[i].tuple];
    printf("  tuple %" PRIu32 " %s light %" PRIu32 " T1 %" PRIu32, entries[i].tuple,
           bbc_chain_name((bbc_chain)t->chain), t->light, t->specular[0]);
    if (t->specular[1] != BBC_NO_TRIANGLE) printf(" T2 %" PRIu32, t->specular[1]);
    printf(" receiver %" PRIu32 " bound %.9g\n", t->receiver, (double)entries[i].bound);
  }
  bbc_cache_cursor_free(cursor);
  bbc_cache_close(cache);
  return 0;
}
