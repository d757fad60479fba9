/* XXH64 (format-spec Sec. 8), streaming: the hash of the scene fingerprint, of the
 * candidate tuples and of the cache's sections. */
#include <string.h>

#include "cache_format_internal.h"

#define P64_1 0x9E3779B185EBCA87ull
#define P64_2 0xC2B2AE3D27D4EB4Full
#define P64_3 0x165667B19E3779F9ull
#define P64_4 0x85EBCA77C2B2AE63ull
#define P64_5 0x27D4EB2F165667C5ull

static uint64_t rotl64(uint64_t x, int r) {
  return (x << r) | (x >> (64 - r));
}

static uint64_t xxh_round(uint64_t acc, uint64_t input) {
  acc += input * P64_2;
  acc = rotl64(acc, 31);
  return acc * P64_1;
}

static uint64_t xxh_merge(uint64_t acc, uint64_t val) {
  acc ^= xxh_round(0, val);
  return acc * P64_1 + P64_4;
}

void bbc__xxh64_init(bbc__xxh64_state *s) {
  memset(s, 0, sizeof *s);
  s->v[0] = P64_1 + P64_2;
  s->v[1] = P64_2;
  s->v[2] = 0;
  s->v[3] = (uint64_t)0 - P64_1;
}

static void xxh_stripe(bbc__xxh64_state *s, const uint8_t *p) {
  for (int k = 0; k < 4; k++) s->v[k] = xxh_round(s->v[k], bbc__ld64(p + 8 * k));
}

void bbc__xxh64_update(bbc__xxh64_state *s, const void *data, size_t size) {
  const uint8_t *p = data;
  s->total += size;
  if (s->buffered + size < 32) {
    if (size) memcpy(s->buf + s->buffered, p, size);
    s->buffered += (uint32_t)size;
    return;
  }
  if (s->buffered) {
    size_t fill = 32 - s->buffered;
    memcpy(s->buf + s->buffered, p, fill);
    xxh_stripe(s, s->buf);
    p += fill;
    size -= fill;
    s->buffered = 0;
  }
  while (size >= 32) {
    xxh_stripe(s, p);
    p += 32;
    size -= 32;
  }
  if (size) memcpy(s->buf, p, size);
  s->buffered = (uint32_t)size;
}

uint64_t bbc__xxh64_final(const bbc__xxh64_state *s) {
  uint64_t h;
  if (s->total >= 32) {
    h = rotl64(s->v[0], 1) + rotl64(s->v[1], 7) + rotl64(s->v[2], 12) + rotl64(s->v[3], 18);
    for (int k = 0; k < 4; k++) h = xxh_merge(h, s->v[k]);
  } else {
    h = P64_5;
  }
  h += s->total;
  const uint8_t *p = s->buf;
  uint32_t n = s->buffered;
  while (n >= 8) {
    h ^= xxh_round(0, bbc__ld64(p));
    h = rotl64(h, 27) * P64_1 + P64_4;
    p += 8;
    n -= 8;
  }
  if (n >= 4) {
    h ^= (uint64_t)bbc__ld32(p) * P64_1;
    h = rotl64(h, 23) * P64_2 + P64_3;
    p += 4;
    n -= 4;
  }
  while (n > 0) {
    h ^= (uint64_t)(*p) * P64_5;
    h = rotl64(h, 11) * P64_1;
    p++;
    n--;
  }
  h ^= h >> 33;
  h *= P64_2;
  h ^= h >> 29;
  h *= P64_3;
  h ^= h >> 32;
  return h;
}

uint64_t bbc__xxh64(const void *data, size_t size) {
  bbc__xxh64_state s;
  bbc__xxh64_init(&s);
  bbc__xxh64_update(&s, data, size);
  return bbc__xxh64_final(&s);
}
