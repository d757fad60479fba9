/* Counter-based random numbers: every value is a pure function of (seed, pixel,
 * sample, dimension), so an image never depends on which thread rendered what. */
#ifndef BBC_RNG_INTERNAL_H
#define BBC_RNG_INTERNAL_H

#include <stdint.h>

typedef struct bbc_rng {
  uint64_t key;
  uint64_t dimension;
} bbc_rng;

/* The splitmix64 finaliser: a bijective 64-bit mix with good avalanche. */
static inline uint64_t bbc__mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

static inline bbc_rng bbc_rng_make(uint64_t seed, uint64_t pixel, uint64_t sample) {
  uint64_t key = bbc__mix64(seed + 0x9E3779B97F4A7C15ull);
  key = bbc__mix64(key ^ (pixel + 0xD1B54A32D192ED03ull));
  key = bbc__mix64(key ^ (sample + 0x8CB92BA72F3D8DD7ull));
  return (bbc_rng){key, 0};
}

/* The next dimension's uniform number in [0, 1). */
static inline double bbc_rng_next(bbc_rng *rng) {
  uint64_t bits = bbc__mix64(rng->key + (++rng->dimension) * 0x9E3779B97F4A7C15ull);
  return (double)(bits >> 11) * 0x1.0p-53;
}

#endif
