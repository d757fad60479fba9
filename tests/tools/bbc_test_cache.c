/* bbc-test-cache: writes .bbc files for the tests, without the (separate) bounder.
 *
 *   bbc-test-cache minimal OUT.bbc          the minimal file of the spec's Appendix A
 *   bbc-test-cache corpus DIR               the invalid corpus, DIR/<error>--<what>.bbc
 *   bbc-test-cache synthetic SCENE OUT.bbc [RESOLUTION]
 *                                           synthetic tuples and splats on a real scene
 *
 * Test-only: not installed, not part of the product. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/cache.h"
#include "cache_fixtures.h"

static int write_bytes(const char *path, const void *bytes, size_t size) {
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(bytes, 1, size, f) != size || fclose(f) != 0) {
    fprintf(stderr, "bbc-test-cache: cannot write %s\n", path);
    return 1;
  }
  return 0;
}

static void print_error(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  fprintf(stderr, "bbc-test-cache: %s\n", message);
}

int main(int argc, char **argv) {
  if (argc == 3 && strcmp(argv[1], "minimal") == 0) {
    void *bytes;
    size_t size;
    if (fx_minimal_cache(&bytes, &size) != BBC_OK) return 1;
    int r = write_bytes(argv[2], bytes, size);
    free(bytes);
    return r;
  }
  if (argc == 3 && strcmp(argv[1], "corpus") == 0) {
    static fx_case cases[128];
    int n = fx_invalid_corpus(cases), bad = 0;
    for (int i = 0; i < n; i++) {
      char path[20000];
      snprintf(path, sizeof path, "%s/%.200s.bbc", argv[2], cases[i].name);
      bad |= write_bytes(path, cases[i].bytes, cases[i].size);
      free(cases[i].bytes);
    }
    return n == 0 || bad;
  }
  if ((argc == 4 || argc == 5) && strcmp(argv[1], "synthetic") == 0) {
    bbc_scene_options so = {print_error, NULL, NULL, BBC_LIGHT_UNITS_FILE};
    bbc_scene *scene = NULL;
    if (bbc_scene_load(&scene, argv[2], &so) != BBC_OK) return 1;
    uint32_t res = argc == 5 ? (uint32_t)atoi(argv[4]) : 64;
    bbc_cache_builder *b = NULL;
    bbc_result r = fx_synthetic_builder(&b, scene, res, 1, NULL);
    bbc_cache_write_options o;
    memset(&o, 0, sizeof o);
    o.error_fn = print_error;
    if (r == BBC_OK) r = bbc_cache_builder_write(b, argv[3], &o);
    bbc_cache_builder_free(b);
    bbc_scene_free(scene);
    if (r != BBC_OK) fprintf(stderr, "bbc-test-cache: %s\n", bbc_result_string(r));
    return r != BBC_OK;
  }
  fprintf(stderr,
          "usage: bbc-test-cache minimal OUT.bbc | corpus DIR | synthetic SCENE OUT.bbc "
          "[RESOLUTION]\n");
  return 2;
}
