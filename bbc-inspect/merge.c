/* bbc-inspect merge: the shard caches of one sharded precompute into one cache. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "inspect.h"

static int on_merge_progress(void *user, uint64_t done, uint64_t total) {
  cli_progress_update(user, total ? (double)done / (double)total : 1.0, "cells");
  return cli_interrupted;
}

int cmd_merge(cli_args *a) {
  const char *out = NULL, *threads_text = NULL;
  const char **paths = calloc((size_t)a->argc, sizeof *paths);
  if (!paths) cli_fail("out of memory");
  size_t n = 0;
  int progress = -1;
  while (a->i < a->argc) {
    const char *v, *arg = a->argv[a->i];
    if (cli_option(a, "--threads", &v)) {
      threads_text = v;
    } else if (cli_flag(a, "--progress")) {
      progress = 1;
    } else if (cli_flag(a, "--no-progress")) {
      progress = 0;
    } else if (arg[0] == '-' && arg[1] != '\0') {
      cli_usage_error(a->usage, "unknown option '%s'", arg);
    } else {
      if (!out)
        out = arg;
      else
        paths[n++] = arg;
      a->i++;
    }
  }
  if (!out || n == 0) cli_usage_error(a->usage, "merge needs OUT.bbc and at least one SHARD.bbc");
  for (size_t i = 0; i < n; i++)
    if (strcmp(paths[i], out) == 0)
      cli_usage_error(a->usage, "merge: the output %s is also given as a shard", out);
  bbc_cache_merge_options options;
  memset(&options, 0, sizeof options);
  if (threads_text) options.threads = (int)cli_parse_int(a, "--threads", threads_text, 1, 4096);
  cli_catch_interrupts();
  /* What a merge killed while writing left beside OUT, a rerun removes. */
  cli_remove_leftovers(out);

  bbc_cache **shards = calloc(n, sizeof *shards);
  if (!shards) cli_fail("out of memory");
  for (size_t i = 0; i < n; i++) shards[i] = inspect_open_cache(paths[i]); /* exits 1 on failure */
  if (bbc_cache_merge_check_resources((const bbc_cache *const *)shards, n, out,
                                      cli_print_message, NULL) != BBC_OK) {
    for (size_t i = 0; i < n; i++) bbc_cache_close(shards[i]);
    free(shards);
    free(paths);
    return 1; /* the one line is printed; nothing was written */
  }
  cli_progress bar;
  cli_progress_begin(&bar, "merging", progress);
  options.error_fn = cli_print_message;
  options.progress_fn = on_merge_progress;
  options.progress_user = &bar;
  bbc_cache_builder *b = NULL;
  bbc_result r = bbc_cache_merge(&b, (const bbc_cache *const *)shards, n, &options);
  cli_progress_end(&bar);
  for (size_t i = 0; i < n; i++) bbc_cache_close(shards[i]);
  free(shards);
  free(paths);
  if (r == BBC_OK && !cli_interrupted) {
    bbc_cache_write_options wo;
    memset(&wo, 0, sizeof wo);
    wo.error_fn = cli_print_message;
    wo.progress_fn = cli_poll_interrupt;
    r = bbc_cache_builder_write(b, out, &wo);
  }
  bbc_cache_builder_free(b);
  if (r == BBC_ERR_CANCELLED || cli_interrupted) {
    fprintf(stderr, "bbc-inspect: interrupted; %s was not written\n", out);
    return 130;
  }
  return r == BBC_OK ? 0 : 1; /* the library printed the one line */
}
