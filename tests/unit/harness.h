/* A small test harness: TEST(name) registers a test; the runner runs one test by
 * name (as ctest does) or all of them. CHECK macros print both values on failure and
 * let the test continue, so one run reports every broken assertion. */
#ifndef BBC_TEST_HARNESS_H
#define BBC_TEST_HARNESS_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>

typedef void (*harness_fn)(void);
void harness_register(const char *name, harness_fn fn);
void harness_fail(const char *file, int line, const char *fmt, ...);

/* Sample counts scale with BBC_TEST_FULL=1 (the full-size random tests) and are kept
 * small otherwise so the CI suite stays quick. */
long harness_scale(long ci_count, long full_count);

/* Marks the current test skipped, with one line saying why: its runner exits with
 * HARNESS_SKIPPED, which ctest counts as "not run", never as passed. For opt-in tests
 * whose input is missing; a test that also failed a check still fails. */
#define HARNESS_SKIPPED 77
void harness_skip(const char *fmt, ...);
#define SKIP(...)              \
  do {                         \
    harness_skip(__VA_ARGS__); \
    return;                    \
  } while (0)

/* Paths of data the tests use: the scenes the build generates (tests/make_test_scenes.sh)
 * and the repository's files. */
#define TEST_SCENE(file) BBC_TEST_SCENES "/" file
#define SOURCE_PATH(file) BBC_SOURCE_DIR "/" file

/* The folder of the shared research scenes and real assets for opt-in tests: the
 * environment's BBC_SHARED_DIR (the folder holding scenes/), or NULL when it is unset or
 * has no scenes/ folder. The suite itself never needs it. */
const char *harness_shared_dir(void);

#define TEST(name)                                                 \
  static void test_##name(void);                                   \
  __attribute__((constructor)) static void register_##name(void) { \
    harness_register(#name, test_##name);                          \
  }                                                                \
  static void test_##name(void)

#define CHECK(cond)                                                    \
  do {                                                                 \
    if (!(cond)) harness_fail(__FILE__, __LINE__, "CHECK(%s)", #cond); \
  } while (0)

#define CHECK_INT(a, b)                                                                           \
  do {                                                                                            \
    long long va_ = (long long)(a), vb_ = (long long)(b);                                         \
    if (va_ != vb_) harness_fail(__FILE__, __LINE__, "%s == %s: %lld != %lld", #a, #b, va_, vb_); \
  } while (0)

#define CHECK_NEAR(a, b, tol)                                                                      \
  do {                                                                                             \
    double va_ = (double)(a), vb_ = (double)(b), vt_ = (double)(tol);                              \
    if (!(fabs(va_ - vb_) <= vt_))                                                                 \
      harness_fail(__FILE__, __LINE__, "%s ~ %s: %.17g vs %.17g (tol %g)", #a, #b, va_, vb_, vt_); \
  } while (0)

#define CHECK_STR_CONTAINS(s, sub)                                                             \
  do {                                                                                         \
    const char *vs_ = (s), *vsub_ = (sub);                                                     \
    if (!vs_ || !strstr(vs_, vsub_))                                                           \
      harness_fail(__FILE__, __LINE__, "\"%s\" does not contain \"%s\"", vs_ ? vs_ : "(null)", \
                   vsub_);                                                                     \
  } while (0)

/* Stops the current test early when a precondition for the rest fails. */
#define REQUIRE(cond)                                         \
  do {                                                        \
    if (!(cond)) {                                            \
      harness_fail(__FILE__, __LINE__, "REQUIRE(%s)", #cond); \
      return;                                                 \
    }                                                         \
  } while (0)

#endif
