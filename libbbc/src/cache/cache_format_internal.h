/* On-disk constants of the .bbc format (format-spec/bbc-format.md) and the helpers shared
 * by the writer (cache_write.c) and the reader (cache_read.c): little-endian loads and
 * stores, bound quantisation (R-BND-1), XXH64 and the fingerprint (Sec. 8). Tests may
 * include this header; tools may not. */
#ifndef BBC_CACHE_FORMAT_INTERNAL_H
#define BBC_CACHE_FORMAT_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "bbc/cache.h"

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
/* Mapped sections are used in place as arrays of native integers and floats, which is
 * only correct on little-endian hosts (R-FILE-1). */
#error "bbc's cache reader and writer need a little-endian host"
#endif

/* Sec. 3: the header. */
#define BBC__MAGIC \
  "\x89"           \
  "BBC\r\n\x1a\n"
#define BBC__HEADER_SIZE 64u
#define BBC__DIR_ENTRY_SIZE 32u
#define BBC__MAX_SECTIONS 64u
#define BBC__ALIGN 64u
#define BBC__MIN_PADDING 16u

/* Sec. 4: directory flags. */
#define BBC__SECTION_REQUIRED 1u

/* Sec. 5: section types, four characters with the first one in the lowest byte. */
#define BBC__FOURCC(a, b, c, d) \
  ((uint32_t)(a) | ((uint32_t)(b) << 8) | ((uint32_t)(c) << 16) | ((uint32_t)(d) << 24))
#define BBC__SEC_PARM BBC__FOURCC('P', 'A', 'R', 'M')
#define BBC__SEC_FPRT BBC__FOURCC('F', 'P', 'R', 'T')
#define BBC__SEC_RCVR BBC__FOURCC('R', 'C', 'V', 'R')
#define BBC__SEC_TRUV BBC__FOURCC('T', 'R', 'U', 'V')
#define BBC__SEC_TUPL BBC__FOURCC('T', 'U', 'P', 'L')
#define BBC__SEC_CIDX BBC__FOURCC('C', 'I', 'D', 'X')
#define BBC__SEC_CDAT BBC__FOURCC('C', 'D', 'A', 'T')
#define BBC__SEC_CHNK BBC__FOURCC('C', 'H', 'N', 'K')
#define BBC__SEC_INFO BBC__FOURCC('I', 'N', 'F', 'O')

/* Record sizes. */
#define BBC__PARM_SIZE 64u
#define BBC__FPRT_SIZE 96u
#define BBC__RCVR_SIZE 128u
#define BBC__TRUV_SIZE 24u
#define BBC__TUPL_SIZE 20u
#define BBC__CIDX_SIZE 12u
#define BBC__CHNK_SIZE 24u
#define BBC__ENTRY_BYTES 6u /* decoded bytes per cell-list entry (Sec. 7.2) */

/* Sec. 10: limits. */
#define BBC__MAX_RESOLUTION 65536u
#define BBC__MAX_CHUNK_ENTRIES (1u << 24)
#define BBC__MAX_INFO 4096u
#define BBC__MAX_TUPLES 0xFFFFFFFEu
#define BBC__MAX_LEVEL 64u
#define BBC__MAX_CELL_LEVELS 17u /* levels of cells: k <= 16, so 65536 cells halve to 1 */

/* Writer defaults (Sec. 7.3). */
#define BBC__DEFAULT_CHUNK_BYTES (256u * 1024u)
#define BBC__DEFAULT_LEVEL 6

/* Sec. 7.1: bound codes. 0xFF00 is +infinity. */
#define BBC__CODE_INF 0xFF00u

/* Little-endian loads and stores through memcpy, so they work at any alignment. */
static inline uint16_t bbc__ld16(const uint8_t *p) {
  uint16_t v;
  memcpy(&v, p, 2);
  return v;
}
static inline uint32_t bbc__ld32(const uint8_t *p) {
  uint32_t v;
  memcpy(&v, p, 4);
  return v;
}
static inline uint64_t bbc__ld64(const uint8_t *p) {
  uint64_t v;
  memcpy(&v, p, 8);
  return v;
}
static inline double bbc__ldf64(const uint8_t *p) {
  double v;
  memcpy(&v, p, 8);
  return v;
}
static inline void bbc__st16(uint8_t *p, uint16_t v) {
  memcpy(p, &v, 2);
}
static inline void bbc__st32(uint8_t *p, uint32_t v) {
  memcpy(p, &v, 4);
}
static inline void bbc__st64(uint8_t *p, uint64_t v) {
  memcpy(p, &v, 8);
}
static inline void bbc__stf64(uint8_t *p, double v) {
  memcpy(p, &v, 8);
}

static inline uint64_t bbc__align64(uint64_t x) {
  return (x + 63u) & ~(uint64_t)63u;
}

/* R-BND-1: the code of a bound, rounding up. b must not be NaN; negative values are the
 * caller's error and are encoded as 0 here. */
static inline uint16_t bbc__bound_encode(double b) {
  if (!(b > 0)) return 0;
  float f = (float)b;
  if ((double)f < b) f = nextafterf(f, INFINITY);
  uint32_t bits;
  memcpy(&bits, &f, 4);
  return (uint16_t)((bits + 0x7FFFu) >> 15);
}

/* The binary32 value of a code (exact). Codes above 0xFF00 must be rejected before. */
static inline float bbc__bound_decode(uint16_t code) {
  uint32_t bits = (uint32_t)code << 15;
  float f;
  memcpy(&f, &bits, 4);
  return f;
}

/* XXH64 (Sec. 8), streaming. */
typedef struct bbc__xxh64_state {
  uint64_t v[4];
  uint64_t total;
  uint8_t buf[32];
  uint32_t buffered;
} bbc__xxh64_state;
void bbc__xxh64_init(bbc__xxh64_state *s);
void bbc__xxh64_update(bbc__xxh64_state *s, const void *data, size_t size);
uint64_t bbc__xxh64_final(const bbc__xxh64_state *s);
uint64_t bbc__xxh64(const void *data, size_t size);

/* R-INF-1: INFO is well-formed UTF-8 (RFC 3629: shortest form, no surrogates, at most
 * U+10FFFF) without control characters (U+0000-U+001F, U+007F-U+009F). */
static inline int bbc__info_text_valid(const uint8_t *p, size_t n) {
  for (size_t i = 0; i < n;) {
    uint32_t c = p[i], len = c < 0x80 ? 1 : c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3
                                       : c >= 0xF0 && c <= 0xF4                   ? 4
                                                                                  : 0;
    if (len == 0 || len > n - i) return 0;
    if (len > 1) c &= 0x3Fu >> (len - 1);
    for (uint32_t k = 1; k < len; k++) {
      if ((p[i + k] & 0xC0) != 0x80) return 0;
      c = (c << 6) | (p[i + k] & 0x3Fu);
    }
    static const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (c < least[len] || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF) || c < 0x20 ||
        (c >= 0x7F && c <= 0x9F))
      return 0;
    i += len;
  }
  return 1;
}

/* The 64-byte PARM encoding of parameters (Sec. 5.1). */
void bbc__params_encode(const bbc_precompute_params *p, uint8_t out[BBC__PARM_SIZE]);
/* 1 if the parameters satisfy R-PAR-1. */
int bbc__params_valid(const bbc_precompute_params *p);
/* The ratio the tuples of area lights are bounded to: alpha_area, or alpha_double where
 * it is 0 (caches before 1.5). */
double bbc__params_alpha_area(const bbc_precompute_params *p);
/* The deepest level of the two-bounce tuples of point, spot and sun lights:
 * max_level_double, or max_level where it is 0 (caches before 1.9). */
uint32_t bbc__params_max_level_double(const bbc_precompute_params *p);
/* The max_level_double a file stores (PARM bytes 60-63): 0 without a two-bounce chain
 * type, so that the parameters' hash does not depend on a value nothing used. */
uint32_t bbc__params_stored_level_double(const bbc_precompute_params *p);

/* The compressor used for chunks, exposed for the layout measurements in the tests:
 * returns the compressed size, or 0 on failure. */
size_t bbc__cache_compress(void *dst, size_t capacity, const void *src, size_t size, int level);
size_t bbc__cache_compress_bound(size_t size);

/* Sec. 7.2: writes n entries (deltas and codes) as 6-byte records to out (6n bytes). */
void bbc__cache_encode_records(const uint32_t *deltas, const uint16_t *codes, size_t n,
                               uint8_t *out);

#endif
