/* Reporting details of a failure through the optional message callback. */
#ifndef BBC_REPORT_INTERNAL_H
#define BBC_REPORT_INTERNAL_H

#include "bbc/common.h"

/* Formats a one-line message and passes it to fn (if not NULL); returns code, so a
 * failing function can `return bbc__report(fn, user, code, "...", ...)`. */
bbc_result bbc__report(bbc_message_fn fn, void *user, bbc_result code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Writes a file atomically: the data goes to "<path>.tmp.<pid>" in the same folder,
 * which is renamed to path once completely written and closed. */
typedef bbc_result (*bbc__write_fn)(void *ctx, const char *tmp_path);
bbc_result bbc__write_atomically(const char *path, bbc__write_fn write, void *ctx,
                                 bbc_message_fn error_fn, void *user);

#endif
