/* A growing text, for the tests that write glTF in memory: JSON by printf and buffers
 * as base64 data URIs. Header-only, like the other test fixtures. */
#ifndef BBC_TEST_JSON_TEXT_H
#define BBC_TEST_JSON_TEXT_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct json_text {
  char *data; /* NUL-terminated once anything is written; malloc'd */
  size_t size, cap;
} json_text;

static inline void json_printf(json_text *t, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
static inline void json_printf(json_text *t, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(NULL, 0, fmt, ap);
  va_end(ap);
  if (t->size + (size_t)n + 1 > t->cap) {
    t->cap = 2 * (t->size + (size_t)n + 1);
    t->data = realloc(t->data, t->cap);
  }
  va_start(ap, fmt);
  vsnprintf(t->data + t->size, t->cap - t->size, fmt, ap);
  va_end(ap);
  t->size += (size_t)n;
}

static inline void json_base64(json_text *t, const unsigned char *p, size_t n) {
  static const char digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  for (size_t i = 0; i < n; i += 3) {
    uint32_t v = (uint32_t)p[i] << 16 | (i + 1 < n ? (uint32_t)p[i + 1] << 8 : 0) |
                 (i + 2 < n ? p[i + 2] : 0);
    json_printf(t, "%c%c%c%c", digits[v >> 18], digits[(v >> 12) & 63],
                i + 1 < n ? digits[(v >> 6) & 63] : '=', i + 2 < n ? digits[v & 63] : '=');
  }
}

#endif
