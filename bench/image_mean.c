/* The pixel-wise mean of two images of the same size, for the comparison benchmark's
 * references (bench/compare.sh): the mean of two independent unbiased images is unbiased
 * and has half their variance.
 *
 *   image_mean A.exr B.exr -o OUT.exr */
#include <stdio.h>
#include <string.h>

#include "bbc/bbc.h"

int main(int argc, char **argv) {
  if (argc != 5 || strcmp(argv[3], "-o")) {
    fprintf(stderr, "usage: image_mean A.exr B.exr -o OUT.exr\n");
    return 1;
  }
  bbc_image *a = NULL, *b = NULL;
  if (bbc_image_read_exr(&a, argv[1], NULL, NULL) != BBC_OK ||
      bbc_image_read_exr(&b, argv[2], NULL, NULL) != BBC_OK) {
    fprintf(stderr, "image_mean: cannot read %s or %s\n", argv[1], argv[2]);
    return 1;
  }
  if (a->width != b->width || a->height != b->height) {
    fprintf(stderr, "image_mean: the images differ in size\n");
    return 1;
  }
  for (size_t i = 0; i < (size_t)a->width * a->height * 3; i++)
    a->rgb[i] = (float)(0.5 * ((double)a->rgb[i] + b->rgb[i]));
  if (bbc_image_write_exr(a, argv[4], NULL, NULL) != BBC_OK) {
    fprintf(stderr, "image_mean: cannot write %s\n", argv[4]);
    return 1;
  }
  bbc_image_free(a);
  bbc_image_free(b);
  return 0;
}
