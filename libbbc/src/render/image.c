/* Images: allocation, OpenEXR output and input through OpenEXRCore, a PNG preview
 * (zlib for the deflate stream), and the relMSE metric. */
#include "bbc/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>
#include <zlib.h>

#include "report_internal.h"

bbc_result bbc_image_create(bbc_image **out, uint32_t width, uint32_t height) {
  *out = NULL;
  if (width == 0 || height == 0 || width > 65536 || height > 65536) return BBC_ERR_INVALID_ARGUMENT;
  bbc_image *image = calloc(1, sizeof *image);
  float *rgb = calloc((size_t)width * height * 3, sizeof *rgb);
  if (!image || !rgb) {
    free(image);
    free(rgb);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  image->width = width;
  image->height = height;
  image->rgb = rgb;
  *out = image;
  return BBC_OK;
}

void bbc_image_free(bbc_image *image) {
  if (!image) return;
  free(image->rgb);
  free(image);
}

/* --- EXR ------------------------------------------------------------------------ */

typedef struct exr_errors {
  bbc_message_fn fn;
  void *user;
  const char *path;
  char message[512];
} exr_errors;

/* OpenEXRCore reports details through the context's handler on the failing thread;
 * keep the first message so the caller gets one line naming the file. */
static void exr_error_handler(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
  void *data = NULL;
  exr_get_user_data(ctxt, &data);
  exr_errors *errors = data;
  (void)code;
  if (errors && errors->message[0] == '\0')
    snprintf(errors->message, sizeof errors->message, "%s", msg ? msg : "");
}

static bbc_result exr_fail(exr_errors *errors, exr_result_t rv, const char *what) {
  return bbc__report(errors->fn, errors->user, BBC_ERR_EXR, "%s: %s: %s", errors->path, what,
                     errors->message[0] ? errors->message : exr_get_default_error_message(rv));
}

typedef struct exr_write_job {
  const bbc_image *image;
  exr_errors *errors;
} exr_write_job;

static bbc_result exr_write_to(void *ctx, const char *tmp_path) {
  exr_write_job *job = ctx;
  const bbc_image *image = job->image;
  exr_errors *errors = job->errors;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = exr_error_handler;
  init.user_data = errors;
  exr_context_t exr = NULL;
  exr_result_t rv = exr_start_write(&exr, tmp_path, EXR_WRITE_FILE_DIRECTLY, &init);
  if (rv != EXR_ERR_SUCCESS) return exr_fail(errors, rv, "cannot create file");

  int part = 0;
  const char *step = "cannot write header";
  rv = exr_add_part(exr, "rgb", EXR_STORAGE_SCANLINE, &part);
  if (rv == EXR_ERR_SUCCESS)
    rv = exr_initialize_required_attr_simple(exr, part, (int32_t)image->width,
                                             (int32_t)image->height, EXR_COMPRESSION_ZIP);
  static const char *names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3 && rv == EXR_ERR_SUCCESS; c++)
    rv = exr_add_channel(exr, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
  if (rv == EXR_ERR_SUCCESS) rv = exr_write_header(exr);

  int32_t lines = 1;
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_scanlines_per_chunk(exr, part, &lines);
  exr_encode_pipeline_t encoder;
  memset(&encoder, 0, sizeof encoder);
  int have_encoder = 0;
  const size_t row_bytes = (size_t)image->width * 3 * sizeof(float);
  for (int32_t y = 0; rv == EXR_ERR_SUCCESS && y < (int32_t)image->height; y += lines) {
    step = "cannot write pixels";
    exr_chunk_info_t chunk;
    rv = exr_write_scanline_chunk_info(exr, part, y, &chunk);
    if (rv != EXR_ERR_SUCCESS) break;
    rv = have_encoder ? exr_encoding_update(exr, part, &chunk, &encoder)
                      : exr_encoding_initialize(exr, part, &chunk, &encoder);
    if (rv != EXR_ERR_SUCCESS) break;
    for (int16_t c = 0; c < encoder.channel_count; c++) {
      exr_coding_channel_info_t *channel = &encoder.channels[c];
      int index = channel->channel_name[0] == 'R' ? 0 : channel->channel_name[0] == 'G' ? 1 : 2;
      channel->user_pixel_stride = 3 * sizeof(float);
      channel->user_line_stride = (int32_t)row_bytes;
      channel->user_bytes_per_element = sizeof(float);
      channel->user_data_type = EXR_PIXEL_FLOAT;
      channel->encode_from_ptr =
          (const uint8_t *)(image->rgb + (size_t)y * image->width * 3 + index);
    }
    if (!have_encoder) {
      rv = exr_encoding_choose_default_routines(exr, part, &encoder);
      have_encoder = 1;
      if (rv != EXR_ERR_SUCCESS) break;
    }
    rv = exr_encoding_run(exr, part, &encoder);
  }
  if (have_encoder) exr_encoding_destroy(exr, &encoder);
  bbc_result result = BBC_OK;
  if (rv != EXR_ERR_SUCCESS) result = exr_fail(errors, rv, step);
  exr_result_t finish = exr_finish(&exr);
  if (result == BBC_OK && finish != EXR_ERR_SUCCESS)
    result = exr_fail(errors, finish, "cannot finish file");
  return result;
}

bbc_result bbc_image_write_exr(const bbc_image *image, const char *path, bbc_message_fn error_fn,
                               void *user) {
  if (!image || !path) return BBC_ERR_INVALID_ARGUMENT;
  exr_errors errors = {error_fn, user, path, ""};
  exr_write_job job = {image, &errors};
  return bbc__write_atomically(path, exr_write_to, &job, error_fn, user);
}

bbc_result bbc_image_read_exr(bbc_image **out, const char *path, bbc_message_fn error_fn,
                              void *user) {
  *out = NULL;
  exr_errors errors = {error_fn, user, path, ""};
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = exr_error_handler;
  init.user_data = &errors;
  exr_context_t exr = NULL;
  exr_result_t rv = exr_start_read(&exr, path, &init);
  if (rv != EXR_ERR_SUCCESS) {
    exr_finish(&exr);
    return exr_fail(&errors, rv, "cannot open");
  }
  bbc_result result = BBC_OK;
  bbc_image *image = NULL;
  exr_attr_box2i_t window;
  exr_storage_t storage;
  const exr_attr_chlist_t *channels = NULL;
  rv = exr_get_data_window(exr, 0, &window);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_storage(exr, 0, &storage);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_channels(exr, 0, &channels);
  if (rv != EXR_ERR_SUCCESS) {
    result = exr_fail(&errors, rv, "cannot read header");
    goto done;
  }
  if (storage != EXR_STORAGE_SCANLINE) {
    result = bbc__report(error_fn, user, BBC_ERR_EXR, "%s: only scanline EXR files are read", path);
    goto done;
  }
  int found = 0;
  for (int i = 0; i < channels->num_channels; i++) {
    const char *name = channels->entries[i].name.str;
    if (strcmp(name, "R") == 0 || strcmp(name, "G") == 0 || strcmp(name, "B") == 0) found++;
  }
  if (found != 3) {
    result = bbc__report(error_fn, user, BBC_ERR_EXR, "%s: no R, G and B channels", path);
    goto done;
  }
  int64_t width = (int64_t)window.max.x - window.min.x + 1;
  int64_t height = (int64_t)window.max.y - window.min.y + 1;
  if (width <= 0 || height <= 0 || width > 65536 || height > 65536) {
    result = bbc__report(error_fn, user, BBC_ERR_EXR, "%s: unsupported image size", path);
    goto done;
  }
  result = bbc_image_create(&image, (uint32_t)width, (uint32_t)height);
  if (result != BBC_OK) goto done;

  int32_t lines = 1;
  rv = exr_get_scanlines_per_chunk(exr, 0, &lines);
  exr_decode_pipeline_t decoder;
  memset(&decoder, 0, sizeof decoder);
  int have_decoder = 0;
  const size_t row_bytes = (size_t)width * 3 * sizeof(float);
  for (int64_t y = window.min.y; rv == EXR_ERR_SUCCESS && y <= window.max.y; y += lines) {
    exr_chunk_info_t chunk;
    rv = exr_read_scanline_chunk_info(exr, 0, (int)y, &chunk);
    if (rv != EXR_ERR_SUCCESS) break;
    rv = have_decoder ? exr_decoding_update(exr, 0, &chunk, &decoder)
                      : exr_decoding_initialize(exr, 0, &chunk, &decoder);
    if (rv != EXR_ERR_SUCCESS) break;
    int64_t row = chunk.start_y - window.min.y;
    for (int16_t c = 0; c < decoder.channel_count; c++) {
      exr_coding_channel_info_t *channel = &decoder.channels[c];
      const char *name = channel->channel_name;
      int index = strcmp(name, "R") == 0   ? 0
                  : strcmp(name, "G") == 0 ? 1
                  : strcmp(name, "B") == 0 ? 2
                                           : -1;
      if (index < 0) {
        channel->decode_to_ptr = NULL; /* skipped */
        continue;
      }
      channel->user_pixel_stride = 3 * sizeof(float);
      channel->user_line_stride = (int32_t)row_bytes;
      channel->user_bytes_per_element = sizeof(float);
      channel->user_data_type = EXR_PIXEL_FLOAT;
      channel->decode_to_ptr = (uint8_t *)(image->rgb + (size_t)row * (size_t)width * 3 + index);
    }
    if (!have_decoder) {
      rv = exr_decoding_choose_default_routines(exr, 0, &decoder);
      have_decoder = 1;
      if (rv != EXR_ERR_SUCCESS) break;
    }
    rv = exr_decoding_run(exr, 0, &decoder);
  }
  if (have_decoder) exr_decoding_destroy(exr, &decoder);
  if (rv != EXR_ERR_SUCCESS) result = exr_fail(&errors, rv, "cannot read pixels");

done:
  exr_finish(&exr);
  if (result != BBC_OK) {
    bbc_image_free(image);
    return result;
  }
  *out = image;
  return BBC_OK;
}

/* --- PNG ------------------------------------------------------------------------ */

static void put_be32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)(v >> 24);
  p[1] = (uint8_t)(v >> 16);
  p[2] = (uint8_t)(v >> 8);
  p[3] = (uint8_t)v;
}

static int png_chunk(FILE *f, const char *type, const uint8_t *data, uint32_t size) {
  uint8_t head[8];
  put_be32(head, size);
  memcpy(head + 4, type, 4);
  uLong crc = crc32(0L, (const Bytef *)type, 4);
  if (size) crc = crc32(crc, data, size);
  uint8_t tail[4];
  put_be32(tail, (uint32_t)crc);
  return fwrite(head, 1, 8, f) == 8 && (size == 0 || fwrite(data, 1, size, f) == size) &&
         fwrite(tail, 1, 4, f) == 4;
}

static uint8_t srgb_byte(double x) {
  if (!(x > 0)) return 0; /* also maps NaN to black */
  if (x >= 1) return 255;
  double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
  return (uint8_t)(s * 255.0 + 0.5);
}

typedef struct png_job {
  const bbc_image *image;
  double scale;
  int tonemap;
  bbc_message_fn error_fn;
  void *user;
} png_job;

static bbc_result png_write_to(void *ctx, const char *tmp_path) {
  png_job *job = ctx;
  const bbc_image *image = job->image;
  size_t stride = (size_t)image->width * 3 + 1;
  size_t raw_size = stride * image->height;
  uint8_t *raw = malloc(raw_size);
  uLongf packed_size = compressBound((uLong)raw_size);
  uint8_t *packed = malloc(packed_size);
  if (!raw || !packed) {
    free(raw);
    free(packed);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  for (uint32_t y = 0; y < image->height; y++) {
    uint8_t *row = raw + y * stride;
    row[0] = 0; /* filter: none */
    const float *src = image->rgb + (size_t)y * image->width * 3;
    for (size_t i = 0; i < (size_t)image->width * 3; i++) {
      double v = src[i] * job->scale;
      if (job->tonemap && v > 0) v = v / (1.0 + v);
      row[1 + i] = srgb_byte(v);
    }
  }
  bbc_result result = BBC_OK;
  if (compress2(packed, &packed_size, raw, (uLong)raw_size, 6) != Z_OK) {
    result = bbc__report(job->error_fn, job->user, BBC_ERR_OUT_OF_MEMORY, "%s: compression failed",
                         tmp_path);
  } else {
    FILE *f = fopen(tmp_path, "wb");
    if (!f) {
      result =
          bbc__report(job->error_fn, job->user, BBC_ERR_IO, "%s: cannot create file", tmp_path);
    } else {
      static const uint8_t signature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
      uint8_t ihdr[13];
      put_be32(ihdr, image->width);
      put_be32(ihdr + 4, image->height);
      ihdr[8] = 8;  /* bit depth */
      ihdr[9] = 2;  /* colour type: RGB */
      ihdr[10] = 0; /* deflate */
      ihdr[11] = 0; /* adaptive filtering */
      ihdr[12] = 0; /* no interlace */
      static const uint8_t srgb_intent[1] = {0};
      int ok = fwrite(signature, 1, 8, f) == 8 && png_chunk(f, "IHDR", ihdr, 13) &&
               png_chunk(f, "sRGB", srgb_intent, 1) &&
               png_chunk(f, "IDAT", packed, (uint32_t)packed_size) && png_chunk(f, "IEND", NULL, 0);
      if (fclose(f) != 0) ok = 0;
      if (!ok)
        result = bbc__report(job->error_fn, job->user, BBC_ERR_IO, "%s: write failed", tmp_path);
    }
  }
  free(raw);
  free(packed);
  return result;
}

bbc_result bbc_image_write_png(const bbc_image *image, const char *path, double exposure,
                               int tonemap, bbc_message_fn error_fn, void *user) {
  if (!image || !path) return BBC_ERR_INVALID_ARGUMENT;
  png_job job = {image, pow(2.0, exposure), tonemap, error_fn, user};
  return bbc__write_atomically(path, png_write_to, &job, error_fn, user);
}

/* --- metrics --------------------------------------------------------------------- */

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

bbc_result bbc_image_relmse(const bbc_image *image, const bbc_image *reference, double eps,
                            double reject_fraction, double *out) {
  if (!image || !reference || !out || image->width != reference->width ||
      image->height != reference->height || !(eps > 0) || !(reject_fraction >= 0) ||
      !(reject_fraction < 1))
    return BBC_ERR_INVALID_ARGUMENT;
  size_t n = (size_t)image->width * image->height;
  double *errors = malloc(n * sizeof *errors);
  if (!errors) return BBC_ERR_OUT_OF_MEMORY;
  for (size_t i = 0; i < n; i++) {
    double e = 0;
    for (int c = 0; c < 3; c++) {
      double a = image->rgb[3 * i + c], r = reference->rgb[3 * i + c];
      e += (a - r) * (a - r) / (r * r + eps);
    }
    errors[i] = e / 3.0;
  }
  size_t keep = n;
  if (reject_fraction > 0) {
    qsort(errors, n, sizeof *errors, compare_double);
    keep = n - (size_t)floor(reject_fraction * (double)n);
  }
  double sum = 0;
  for (size_t i = 0; i < keep; i++) sum += errors[i];
  free(errors);
  *out = sum / (double)keep;
  return BBC_OK;
}
