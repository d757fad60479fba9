#!/bin/sh
# The whole test suite: installs what is missing, builds (with tests) and runs ctest.
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh
sh scripts/build.sh -DBBC_BUILD_TESTS=ON
cd build
ctest --output-on-failure -j "$(nproc)" --timeout 900
