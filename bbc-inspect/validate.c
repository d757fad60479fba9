/* bbc-inspect validate: every structural rule and checksum of a cache. */
#include <stdio.h>

#include "inspect.h"

typedef struct problems {
  int count;
} problems;

static void on_problem(void *user, bbc_result code, const char *message) {
  ((problems *)user)->count++;
  cli_print_message(NULL, code, message);
}

int cmd_validate(const char *path) {
  bbc_cache *c = inspect_open_cache(path);
  problems pr = {0};
  bbc_result r = bbc_cache_validate(c, on_problem, &pr);
  if (r != BBC_OK) {
    bbc_cache_close(c);
    return 1;
  }
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  bbc_cache_shard shard;
  char shard_text[64] = "";
  if (bbc_cache_get_shard(c, &shard))
    snprintf(shard_text, sizeof shard_text, "shard %u/%u, ", shard.index, shard.count);
  printf("%s: valid (format %u.%u, %s%u tuples, %u receivers, %u chunks, %llu entries)\n", path,
         in.version_major, in.version_minor, shard_text, in.tuple_count, in.receiver_count,
         in.chunk_count, (unsigned long long)in.entry_count);
  bbc_cache_close(c);
  return 0;
}
