/* Low-discrepancy samples for the path tracer: the first two dimensions of the Sobol
 * sequence, randomised per pixel and per "slot" (one 1D or 2D decision of a path, such
 * as the film position or the direction sampled at the second diffuse vertex), in the
 * manner of pbrt-v4's padded Sobol sampler.
 *
 * - Points. Dimension 0 is the van der Corput sequence (the index's bits reversed);
 *   dimension 1 has the upper-triangular Pascal matrix mod 2 as its generator (direction
 *   numbers v_0 = 2^31, v_j = v_{j-1} ^ (v_{j-1} >> 1)). Together they form a
 *   (0, 2)-sequence: every aligned block of 2^k consecutive points has exactly one point
 *   in each elementary interval of area 2^-k.
 * - Scrambling. Each coordinate is Owen-scrambled (a nested uniform scramble, hashed:
 *   each output bit is flipped by a hash of the bits above it, Laine and Karras 2011,
 *   Burley 2020), with a seed per (seed, pixel, slot, coordinate). Owen scrambling keeps
 *   the net property and makes every point uniform on [0, 1)^2, so estimates stay
 *   unbiased.
 * - Padding. Slots share the Sobol points but not their order: the sample index is
 *   permuted per (pixel, slot) by a bijection that maps each octave [2^b, 2^(b+1)) onto
 *   itself. The first 2^k samples of a pixel are then the same set in every slot (a net
 *   for any power-of-two spp), while the pairing of one slot's points with another's is
 *   shuffled, which decorrelates the dimensions.
 * Every value is a pure function of (seed, pixel, sample index, slot): images do not
 * depend on the thread count, and a render can stop after any number of samples (--time;
 * spp that are not powers of two get a net for the largest power of two below and
 * stratified but less even points above it). */
#ifndef BBC_SOBOL_INTERNAL_H
#define BBC_SOBOL_INTERNAL_H

#include <stdint.h>

#include "rng_internal.h"

static inline uint32_t bbc__reverse_bits32(uint32_t v) {
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
  v = ((v >> 8) & 0x00FF00FFu) | ((v & 0x00FF00FFu) << 8);
  return (v >> 16) | (v << 16);
}

/* Sobol dimension 0 or 1 of point i, as a 32-bit fixed-point fraction. */
static inline uint32_t bbc__sobol32(uint32_t i, int dimension) {
  if (dimension == 0) return bbc__reverse_bits32(i);
  uint32_t v = 0, direction = 0x80000000u;
  for (; i; i >>= 1, direction ^= direction >> 1)
    if (i & 1) v ^= direction;
  return v;
}

/* A nested uniform scramble of the fraction x by a hash: in bit-reversed order, every
 * operation below changes a bit only as a function of the bits below it (additions and
 * multiplications carry upwards only, x * even adds a function of lower bits), so after
 * reversing back each bit of x is flipped by a function of the more significant bits
 * and of the seed: the defining property of Owen scrambling. */
static inline uint32_t bbc__owen_scramble(uint32_t x, uint64_t seed) {
  x = bbc__reverse_bits32(x);
  x += (uint32_t)seed;
  x ^= x * 0x6C8E9CF6u;
  x *= (uint32_t)(seed >> 32) | 1u;
  x ^= x * 0xB2E4F0A2u;
  x += (uint32_t)(seed >> 16);
  x ^= x * 0x3A9B5C14u;
  return bbc__reverse_bits32(x);
}

/* A bijection of [0, 2^32) that maps each octave [2^b, 2^(b+1)) (and 0) onto itself:
 * the b bits below the leading one are permuted by invertible operations modulo 2^b
 * (xor and addition of constants, multiplication by an odd number, x ^= x * even in both
 * bit orders). */
static inline uint32_t bbc__permute_octave(uint32_t i, uint64_t seed) {
  if (i < 2) return i;
  int b = 31 - __builtin_clz(i);
  uint32_t mask = (1u << b) - 1u;
  uint32_t x = i & mask;
  x = (x ^ (uint32_t)seed) & mask;
  x = (x * ((uint32_t)(seed >> 32) | 1u)) & mask;
  x = (x ^ (x * 0x9E3779B8u)) & mask;
  /* The same in reversed order, so low bits depend on high ones too. */
  x = bbc__reverse_bits32(x) >> (32 - b);
  x = (x + (uint32_t)(seed >> 24)) & mask;
  x = (x ^ (x * 0x7F4A7C16u)) & mask;
  x = (x * ((uint32_t)(seed >> 8) | 1u)) & mask;
  x = bbc__reverse_bits32(x) >> (32 - b);
  return (1u << b) | x;
}

/* The samples of one path: its pixel's key and its index within the pixel. */
typedef struct bbc_sobol {
  uint64_t key;   /* from (seed, pixel) */
  uint32_t index; /* sample index within the pixel */
} bbc_sobol;

static inline bbc_sobol bbc_sobol_make(uint64_t seed, uint64_t pixel, uint32_t index) {
  uint64_t key = bbc__mix64(seed + 0x5851F42D4C957F2Dull);
  key = bbc__mix64(key ^ (pixel + 0x14057B7EF767814Full));
  return (bbc_sobol){key, index};
}

/* The first `n` (1 or 2) coordinates of slot `slot`, in [0, 1). */
static inline void bbc_sobol_get(const bbc_sobol *s, uint32_t slot, int n, double out[]) {
  uint64_t h = bbc__mix64(s->key ^ (slot * 0xD6E8FEB86659FD93ull));
  uint32_t i = bbc__permute_octave(s->index, h);
  for (int c = 0; c < n; c++) {
    uint64_t seed = bbc__mix64(h + (uint64_t)(c + 1) * 0x9E3779B97F4A7C15ull);
    out[c] = (double)bbc__owen_scramble(bbc__sobol32(i, c), seed) * 0x1.0p-32;
  }
}

#endif
