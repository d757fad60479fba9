#define _POSIX_C_SOURCE 200809L
#include "report_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

bbc_result bbc__report(bbc_message_fn fn, void *user, bbc_result code, const char *fmt, ...) {
  if (fn) {
    char message[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    fn(user, code, message);
  }
  return code;
}

bbc_result bbc__write_atomically(const char *path, bbc__write_fn write, void *ctx,
                                 bbc_message_fn error_fn, void *user) {
  char tmp[4096];
  int n = snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
  if (n < 0 || (size_t)n >= sizeof tmp)
    return bbc__report(error_fn, user, BBC_ERR_INVALID_ARGUMENT, "%s: path too long", path);
  bbc_result r = write(ctx, tmp);
  if (r != BBC_OK) {
    remove(tmp);
    return r;
  }
  if (rename(tmp, path) != 0) {
    int e = errno;
    remove(tmp);
    return bbc__report(error_fn, user, BBC_ERR_IO, "%s: cannot rename %s: %s", path, tmp,
                       strerror(e));
  }
  return BBC_OK;
}
