/* Images: linear RGB float pixels, written to OpenEXR (through OpenEXRCore) and to a
 * tone-mapped sRGB PNG preview, and read back from EXR for comparisons. */
#ifndef BBC_IMAGE_H
#define BBC_IMAGE_H

#include "bbc/common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A plain struct owning its pixels: rgb holds width*height*3 floats, row-major, the top
 * row first. Free with bbc_image_free. Not synchronised: threads may write disjoint
 * pixels concurrently. */
typedef struct bbc_image {
  uint32_t width, height;
  float *rgb;
} bbc_image;

/* Allocates a black image. *out is NULL on failure. */
BBC_API bbc_result bbc_image_create(bbc_image **out, uint32_t width, uint32_t height);
/* NULL is allowed. */
BBC_API void bbc_image_free(bbc_image *image);

/* Writes a 32-bit float RGB EXR (ZIP compressed). The file is written to a temporary
 * name in the same folder and renamed on success, so a failure never leaves a partial
 * file at path. Details of a failure go to error_fn (may be NULL). */
BBC_API bbc_result bbc_image_write_exr(const bbc_image *image, const char *path,
                                       bbc_message_fn error_fn, void *user);

/* Reads the R, G and B channels of a scanline or tiled EXR (any pixel type) into a new
 * image. A missing channel is an error (BBC_ERR_EXR). */
BBC_API bbc_result bbc_image_read_exr(bbc_image **out, const char *path, bbc_message_fn error_fn,
                                      void *user);

/* Writes an 8-bit sRGB PNG preview: pixels are scaled by 2^exposure, tone mapped with
 * x/(1+x) when tonemap is non-zero (clamped otherwise) and encoded with the sRGB curve.
 * Written through a temporary file like the EXR. */
BBC_API bbc_result bbc_image_write_png(const bbc_image *image, const char *path, double exposure,
                                       int tonemap, bbc_message_fn error_fn, void *user);

/* relMSE of image against reference: the mean over pixels of the mean over RGB of
 * (I - R)^2 / (R^2 + eps). With reject_fraction > 0 (e.g. 0.001) that fraction of the
 * largest per-pixel errors is left out, as in the papers. Sizes must match
 * (BBC_ERR_INVALID_ARGUMENT otherwise). */
BBC_API bbc_result bbc_image_relmse(const bbc_image *image, const bbc_image *reference, double eps,
                                    double reject_fraction, double *out);

#ifdef __cplusplus
}
#endif

#endif
