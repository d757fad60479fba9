/* Saving a cache file: written to a temporary file beside the target, checked by the
 * reader's full validation, then renamed. A cache that its own validator would reject
 * is never left behind (it would be a bug of the writer; the message says so). */
#include <stdio.h>
#include <string.h>

#include "bbc/cache.h"
#include "cache_shard_internal.h"
#include "report_internal.h"

typedef struct save_job {
  bbc_cache_builder *b;
  const bbc_cache_write_options *o;
  const char *path;
} save_job;

typedef struct relay {
  const save_job *job;
  int said;
} relay;

/* The validator's first line, as a writer bug about the target path (running out of
 * memory to check the file is not one). */
static void relay_message(void *user, bbc_result code, const char *message) {
  relay *r = user;
  const bbc_cache_write_options *o = r->job->o;
  if (r->said++ || !o || !o->error_fn) return;
  if (code == BBC_ERR_OUT_OF_MEMORY)
    bbc__report(o->error_fn, o->user, code, "%s: not written: out of memory to check it: %s",
                r->job->path, message);
  else
    bbc__report(o->error_fn, o->user, code,
                "%s: not written: the cache fails its own validation (a bug in bbc): %s",
                r->job->path, message);
}

static bbc_result save_file(void *ctx, const char *tmp_path) {
  const save_job *job = ctx;
  bbc_result r = bbc__cache_builder_write_file(job->b, tmp_path, job->path, job->o);
  if (r != BBC_OK) return r;
  relay rl = {job, 0};
  bbc_cache_options co = {relay_message, &rl, 0};
  bbc_cache *c = NULL;
  r = bbc_cache_open(&c, tmp_path, &co);
  if (r == BBC_OK) r = bbc_cache_validate(c, relay_message, &rl);
  bbc_cache_close(c);
  /* The reader's own failures (memory, I/O) are not the file's fault, but still leave
   * nothing: the file could not be checked. */
  return r;
}

bbc_result bbc_cache_builder_write(bbc_cache_builder *b, const char *path,
                                   const bbc_cache_write_options *options) {
  if (!b || !path) return BBC_ERR_INVALID_ARGUMENT;
  save_job job = {b, options, path};
  return bbc__write_atomically(path, save_file, &job, options ? options->error_fn : NULL,
                               options ? options->user : NULL);
}
