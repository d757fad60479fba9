/* The path tracer's low-discrepancy samples (sobol_internal.h): over a pixel's first 2^k
 * samples every slot is a (0, k, 2)-net (exactly one point in each elementary interval),
 * whatever the pixel, slot and seed; values are uniform and different slots are
 * uncorrelated. */
#include <math.h>
#include <string.h>

#include "harness.h"
#include "sobol_internal.h"

/* 1 if points 0 .. 2^k - 1 of slot `slot` of the pixel have exactly one point in each
 * elementary interval [a 2^-i, (a+1) 2^-i) x [b 2^-(k-i), (b+1) 2^-(k-i)), i = 0..k. */
static int is_net(uint64_t seed, uint64_t pixel, uint32_t slot, int k) {
  static unsigned char seen[1 << 12];
  const uint32_t n = 1u << k;
  uint32_t x[1 << 12], y[1 << 12];
  for (uint32_t i = 0; i < n; i++) {
    bbc_sobol s = bbc_sobol_make(seed, pixel, i);
    double u[2];
    bbc_sobol_get(&s, slot, 2, u);
    if (!(u[0] >= 0 && u[0] < 1 && u[1] >= 0 && u[1] < 1)) return 0;
    x[i] = (uint32_t)(u[0] * n), y[i] = (uint32_t)(u[1] * n);
  }
  for (int i = 0; i <= k; i++) {
    memset(seen, 0, n);
    for (uint32_t j = 0; j < n; j++) {
      uint32_t cell = ((x[j] >> (k - i)) << (k - i)) | (y[j] >> i);
      if (seen[cell]++) return 0;
    }
  }
  return 1;
}

TEST(prefixes_are_nets) {
  int bad = 0, checked = 0;
  for (uint64_t seed = 0; seed < 3; seed++)
    for (uint64_t pixel = 0; pixel < 20; pixel++)
      for (uint32_t slot = 0; slot < 12; slot++)
        for (int k = 0; k <= 10; k++) {
          checked++;
          if (!is_net(seed, pixel * 7919 + 3, slot, k) && bad++ < 5)
            fprintf(stderr, "seed %llu pixel %llu slot %u: the first 2^%d points are no net\n",
                    (unsigned long long)seed, (unsigned long long)pixel, slot, k);
        }
  fprintf(stderr, "%d prefixes checked, %d not nets\n", checked, bad);
  CHECK_INT(bad, 0);
}

/* The octave permutation is a bijection of [0, 2^32) that keeps every octave. */
TEST(octave_permutation_is_a_bijection) {
  static unsigned char seen[1 << 16];
  for (uint64_t seed = 1; seed < 50; seed++) {
    uint64_t h = bbc__mix64(seed);
    memset(seen, 0, sizeof seen);
    int bad = 0;
    for (uint32_t i = 0; i < (1u << 16); i++) {
      uint32_t j = bbc__permute_octave(i, h);
      int same_octave = i < 2 ? j == i : (31 - __builtin_clz(i)) == (31 - __builtin_clz(j | 1));
      if (j >= (1u << 16) || !same_octave || seen[j]++) bad++;
    }
    CHECK_INT(bad, 0);
  }
}

/* Over many pixels, each coordinate is uniform (chi-square over 32 bins) and two slots
 * (or the two coordinates of one) are uncorrelated at every sample index. */
TEST(uniform_and_uncorrelated) {
  enum { BINS = 32, PIXELS = 20000, SAMPLES = 16 };
  long count[BINS] = {0};
  double sa = 0, sb = 0, sab = 0, saa = 0, sbb = 0, s01 = 0;
  long n = 0;
  for (uint64_t p = 0; p < PIXELS; p++)
    for (uint32_t i = 0; i < SAMPLES; i++) {
      bbc_sobol s = bbc_sobol_make(9, p, i);
      double a[2], b[2];
      bbc_sobol_get(&s, 3, 2, a);
      bbc_sobol_get(&s, 4, 2, b);
      count[(int)(a[0] * BINS)]++;
      sa += a[0], sb += b[0], sab += a[0] * b[0], saa += a[0] * a[0], sbb += b[0] * b[0];
      s01 += (a[0] - 0.5) * (a[1] - 0.5);
      n++;
    }
  double chi2 = 0, expected = (double)n / BINS;
  for (int k = 0; k < BINS; k++) chi2 += (count[k] - expected) * (count[k] - expected) / expected;
  double cov = sab / n - (sa / n) * (sb / n);
  double corr = cov / sqrt((saa / n - (sa / n) * (sa / n)) * (sbb / n - (sb / n) * (sb / n)));
  double corr01 = (s01 / n) * 12.0;
  fprintf(stderr, "chi2 %.1f (31 dof), corr(slot 3, slot 4) %.4f, corr(x, y) %.4f\n", chi2, corr,
          corr01);
  CHECK(chi2 < 70); /* p < 1e-4 for 31 degrees of freedom */
  CHECK(fabs(corr) < 0.01);
  CHECK(fabs(corr01) < 0.01);
}
