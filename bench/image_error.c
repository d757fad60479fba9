/* The error of an image against a reference, for the comparison benchmark:
 *
 *   image_error IMAGE.exr REFERENCE.exr [--eps E]
 *
 * prints "relMSE R lit_mean_ratio Q reference_lit_mean M": R is bbc's relMSE
 * (bbc_image_relmse: the mean over pixels of the mean over RGB of (I - R)^2 / (R^2 + eps),
 * eps 1e-2 by default), Q the mean of the image over the lit pixels (those where the
 * reference is positive in some channel) divided by the reference's mean over the same
 * pixels: 1 for an unbiased image, below 1 for a dark one; M the reference's mean over its
 * lit pixels and channels (the scale eps is compared with); and "mean_ratio A", A the
 * image's mean over every pixel over the reference's. Against a reference that is still
 * speckled (a light-traced one of few photons per lit pixel) Q is low, since it leaves out
 * what the image has where no photon of the reference landed; A is not. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"

int main(int argc, char **argv) {
  double eps = 1e-2;
  if (argc == 5 && !strcmp(argv[3], "--eps")) eps = atof(argv[4]);
  else if (argc != 3) {
    fprintf(stderr, "usage: image_error IMAGE.exr REFERENCE.exr [--eps E]\n");
    return 1;
  }
  bbc_image *image = NULL, *ref = NULL;
  if (bbc_image_read_exr(&image, argv[1], NULL, NULL) != BBC_OK ||
      bbc_image_read_exr(&ref, argv[2], NULL, NULL) != BBC_OK) {
    fprintf(stderr, "image_error: cannot read %s or %s\n", argv[1], argv[2]);
    return 1;
  }
  double relmse;
  if (!(eps > 0) || bbc_image_relmse(image, ref, eps, 0, &relmse) != BBC_OK) {
    fprintf(stderr, "image_error: the images differ in size (or eps is not positive)\n");
    return 1;
  }
  double sum_i = 0, sum_r = 0;
  for (size_t p = 0; p < (size_t)ref->width * ref->height; p++) {
    const float *r = ref->rgb + 3 * p, *i = image->rgb + 3 * p;
    if (!(r[0] > 0 || r[1] > 0 || r[2] > 0)) continue;
    sum_i += (double)i[0] + i[1] + i[2];
    sum_r += (double)r[0] + r[1] + r[2];
  }
  size_t lit = 0;
  double all_i = 0, all_r = 0;
  for (size_t p = 0; p < (size_t)ref->width * ref->height; p++) {
    const float *r = ref->rgb + 3 * p, *i = image->rgb + 3 * p;
    lit += r[0] > 0 || r[1] > 0 || r[2] > 0;
    all_i += (double)i[0] + i[1] + i[2];
    all_r += (double)r[0] + r[1] + r[2];
  }
  printf("relMSE %.6g lit_mean_ratio %.7f reference_lit_mean %.6g mean_ratio %.7f\n", relmse,
         sum_r > 0 ? sum_i / sum_r : 0.0, lit ? sum_r / (3.0 * lit) : 0.0,
         all_r > 0 ? all_i / all_r : 0.0);
  bbc_image_free(image);
  bbc_image_free(ref);
  return 0;
}
