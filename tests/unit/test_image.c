/* EXR and PNG output, EXR input and the relMSE metric. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bbc/bbc.h"
#include "harness.h"

static char last_error[1024];
static void keep_error(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  snprintf(last_error, sizeof last_error, "%s", message);
}

static bbc_image *random_image(uint32_t w, uint32_t h, unsigned seed) {
  bbc_image *image = NULL;
  if (bbc_image_create(&image, w, h) != BBC_OK) return NULL;
  srand(seed);
  for (size_t i = 0; i < (size_t)w * h * 3; i++)
    image->rgb[i] = (float)((rand() / (double)RAND_MAX - 0.2) * 1e3 * (i % 7));
  return image;
}

TEST(exr_round_trip_is_exact) {
  /* Sizes around the 16-line ZIP chunk, including a single row and column. */
  const uint32_t sizes[][2] = {{1, 1}, {37, 17}, {16, 33}, {200, 3}};
  for (int s = 0; s < 4; s++) {
    bbc_image *a = random_image(sizes[s][0], sizes[s][1], 1u + s);
    REQUIRE(a);
    char path[] = "/tmp/bbc-test-exr-XXXXXX";
    int fd = mkstemp(path);
    REQUIRE(fd >= 0);
    close(fd);
    CHECK(bbc_image_write_exr(a, path, NULL, NULL) == BBC_OK);
    bbc_image *b = NULL;
    CHECK(bbc_image_read_exr(&b, path, keep_error, NULL) == BBC_OK);
    REQUIRE(b);
    CHECK_INT(b->width, a->width);
    CHECK_INT(b->height, a->height);
    CHECK(memcmp(a->rgb, b->rgb, (size_t)a->width * a->height * 3 * sizeof(float)) == 0);
    bbc_image_free(a);
    bbc_image_free(b);
    remove(path);
  }
}

TEST(exr_write_failure_leaves_no_file) {
  bbc_image *a = random_image(8, 8, 3);
  REQUIRE(a);
  last_error[0] = '\0';
  const char *path = "/nonexistent-folder-bbc/out.exr";
  CHECK(bbc_image_write_exr(a, path, keep_error, NULL) != BBC_OK);
  CHECK(access(path, F_OK) != 0);
  CHECK_STR_CONTAINS(last_error, "/nonexistent-folder-bbc/");
  bbc_image_free(a);
}

TEST(exr_read_rejects_garbage) {
  char path[] = "/tmp/bbc-test-garbage-XXXXXX";
  int fd = mkstemp(path);
  REQUIRE(fd >= 0);
  REQUIRE(write(fd, "not an exr file at all", 22) == 22);
  close(fd);
  bbc_image *b = NULL;
  last_error[0] = '\0';
  CHECK(bbc_image_read_exr(&b, path, keep_error, NULL) == BBC_ERR_EXR);
  CHECK(b == NULL);
  CHECK_STR_CONTAINS(last_error, path);
  remove(path);
}

TEST(png_has_signature_and_size) {
  bbc_image *a = random_image(13, 5, 4);
  REQUIRE(a);
  char path[] = "/tmp/bbc-test-png-XXXXXX";
  int fd = mkstemp(path);
  REQUIRE(fd >= 0);
  close(fd);
  CHECK(bbc_image_write_png(a, path, 0, 1, NULL, NULL) == BBC_OK);
  FILE *f = fopen(path, "rb");
  REQUIRE(f);
  unsigned char head[24];
  CHECK(fread(head, 1, 24, f) == 24);
  fclose(f);
  CHECK(memcmp(head, "\x89PNG\r\n\x1a\n", 8) == 0);
  CHECK(memcmp(head + 12, "IHDR", 4) == 0);
  CHECK_INT(head[19], 13); /* width, big-endian */
  CHECK_INT(head[23], 5);  /* height */
  bbc_image_free(a);
  remove(path);
}

TEST(relmse_matches_definition) {
  bbc_image *a = NULL, *r = NULL;
  REQUIRE(bbc_image_create(&a, 2, 1) == BBC_OK);
  REQUIRE(bbc_image_create(&r, 2, 1) == BBC_OK);
  /* Pixel 0: I = 2, R = 1 in every channel -> 1 / (1 + 0.01); pixel 1 equal. */
  for (int c = 0; c < 3; c++) {
    a->rgb[c] = 2;
    r->rgb[c] = 1;
    a->rgb[3 + c] = r->rgb[3 + c] = 5;
  }
  double v = 0;
  CHECK(bbc_image_relmse(a, r, 1e-2, 0, &v) == BBC_OK);
  CHECK_NEAR(v, 0.5 / 1.01, 1e-15);
  /* Rejecting the worst half leaves only the exact pixel. */
  CHECK(bbc_image_relmse(a, r, 1e-2, 0.5, &v) == BBC_OK);
  CHECK_NEAR(v, 0, 0);
  bbc_image_free(a);
  bbc_image_free(r);
}
