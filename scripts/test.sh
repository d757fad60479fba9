#!/bin/sh
# The whole test suite: installs what is missing, builds (with tests) in ./build and runs
# ctest there; then builds the whole suite again with AddressSanitizer and
# UndefinedBehaviorSanitizer (BBC_SANITIZE=ON, RelWithDebInfo) in ./build-asan and runs
# ctest there too. Stops at the first failing part.
#
#   sh scripts/test.sh            both (what CI runs)
#   sh scripts/test.sh normal     only the normal build and suite
#   sh scripts/test.sh asan       only the sanitizer build and suite
#
# On this 2-core machine the sanitizer part takes about 3 minutes of building (from
# scratch) and 3.5 minutes of tests.
set -eu
cd "$(dirname "$0")/.."
what=${1:-all}
case $what in
  all | normal | asan) ;;
  *) echo "usage: sh scripts/test.sh [all|normal|asan]" >&2; exit 2 ;;
esac
sh scripts/install-deps.sh
jobs=$(nproc)

if [ "$what" != asan ]; then
  sh scripts/build.sh -DBBC_BUILD_TESTS=ON
  (cd build && ctest --output-on-failure -j "$jobs" --timeout 900)
fi

if [ "$what" != normal ]; then
  cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBBC_BUILD_TESTS=ON \
    -DBBC_SANITIZE=ON
  cmake --build build-asan -j "$jobs"
  # Any sanitizer report must fail its test. UBSan already stops at the first report
  # (-fno-sanitize-recover=undefined in CMakeLists.txt); ASan stops at its first error and
  # LeakSanitizer reports at exit. Their exit status is 86 rather than the default 1, so a
  # report can never pass for the runtime failure (exit 1) a CLI test expects.
  ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0:exitcode=86${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
  UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:exitcode=86${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
  export ASAN_OPTIONS UBSAN_OPTIONS
  (cd build-asan && ctest --output-on-failure -j "$jobs" --timeout 1800)
fi
