#include "harness.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define HARNESS_MAX_TESTS 512

static struct {
  const char *name;
  harness_fn fn;
} tests[HARNESS_MAX_TESTS];
static int test_count;
static int failures;
static int skipped;

void harness_register(const char *name, harness_fn fn) {
  if (test_count < HARNESS_MAX_TESTS) {
    tests[test_count].name = name;
    tests[test_count].fn = fn;
    test_count++;
  }
}

void harness_fail(const char *file, int line, const char *fmt, ...) {
  va_list ap;
  if (failures < 50) {
    fprintf(stderr, "%s:%d: FAILED: ", file, line);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
  }
  failures++;
}

void harness_skip(const char *fmt, ...) {
  va_list ap;
  fprintf(stderr, "skipped: ");
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  skipped++;
}

const char *harness_shared_dir(void) {
  const char *dir = getenv("BBC_SHARED_DIR");
  char scenes[4096];
  struct stat st;
  if (!dir || !dir[0] || snprintf(scenes, sizeof scenes, "%s/scenes", dir) >= (int)sizeof scenes)
    return NULL;
  return stat(scenes, &st) == 0 && S_ISDIR(st.st_mode) ? dir : NULL;
}

long harness_scale(long ci_count, long full_count) {
  const char *full = getenv("BBC_TEST_FULL");
  return (full && strcmp(full, "1") == 0) ? full_count : ci_count;
}

int main(int argc, char **argv) {
  int ran = 0, failed_tests = 0, skipped_tests = 0;
  if (argc > 1 && strcmp(argv[1], "--list") == 0) {
    for (int i = 0; i < test_count; i++) printf("%s\n", tests[i].name);
    return 0;
  }
  for (int i = 0; i < test_count; i++) {
    if (argc > 1 && strcmp(argv[1], tests[i].name) != 0) continue;
    int before = failures, skipped_before = skipped;
    tests[i].fn();
    ran++;
    if (failures != before) {
      failed_tests++;
      fprintf(stderr, "test %s: FAILED (%d checks)\n", tests[i].name, failures - before);
    } else if (skipped != skipped_before) {
      skipped_tests++;
      fprintf(stderr, "test %s: skipped\n", tests[i].name);
    } else {
      fprintf(stderr, "test %s: ok\n", tests[i].name);
    }
  }
  if (ran == 0) {
    fprintf(stderr, "no test named %s\n", argc > 1 ? argv[1] : "(any)");
    return 1;
  }
  /* One test run alone (as ctest runs them) that skipped reports it; a run of several
   * passes when none failed. */
  if (failed_tests) return 1;
  return ran == 1 && skipped_tests ? HARNESS_SKIPPED : 0;
}
