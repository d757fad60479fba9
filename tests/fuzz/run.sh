#!/bin/sh
# Builds the libFuzzer targets with clang and runs one of them for a given time on a
# corpus that is kept between runs.
#
#   sh tests/fuzz/run.sh TARGET SECONDS
#
# TARGET is cache, scene or lookup (fuzz_TARGET.c). The fuzzing build goes to
# $BBC_FUZZ_BUILD (default build-fuzz/ in the source tree); the corpus lives in
# $BBC_FUZZ_WORK/TARGET (default build-fuzz/corpus/TARGET), seeded on its first run from
# the corpora of tests/corpus, and grows with every run. Crashes are written as
# $BBC_FUZZ_WORK/TARGET-crash-* (see README.md for what to do with them). The last
# lines printed are libFuzzer's final statistics (executions, speed, coverage `cov`
# and features `ft` before and after the run) and the run's log is kept as
# $BBC_FUZZ_WORK/TARGET.log. BBC_FUZZ_JOBS=N runs N processes on the corpus at once (one
# per core). Installs clang through scripts/install-deps.sh --fuzz when it
# is missing (as root). Exits 1 when the fuzzer found a crash.
set -eu
usage() {
  echo "usage: sh tests/fuzz/run.sh cache|scene|lookup SECONDS" >&2
  exit 2
}
[ $# -ge 2 ] || usage
target=$1
seconds=$2
case "$target" in cache | scene | lookup) ;; *) usage ;; esac
case "$seconds" in '' | *[!0-9]*) usage ;; esac

src=$(cd "$(dirname "$0")/../.." && pwd)
build=${BBC_FUZZ_BUILD:-$src/build-fuzz}
work=${BBC_FUZZ_WORK:-$build/corpus}

if ! command -v clang >/dev/null 2>&1 || ! command -v clang++ >/dev/null 2>&1; then
  sh "$src/scripts/install-deps.sh" --fuzz
fi
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S "$src" -B "$build" -DBBC_BUILD_FUZZERS=ON -DBBC_BUILD_TESTS=ON \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
cmake --build "$build" -j2 --target "fuzz_$target" >/dev/null

corpus=$work/$target
if [ ! -d "$corpus" ]; then
  mkdir -p "$corpus"
  case "$target" in
  scene) seeds="fuzz-scene invalid-gltf valid" ;;
  *) seeds="fuzz-cache invalid" ;;
  esac
  for d in $seeds; do cp "$src/tests/corpus/$d"/* "$corpus/"; done
fi

# Allocation stacks are not recorded (ASan's malloc_context_size=0): recording them took
# a quarter of the scene target's time. Crashes are still found; replay one for the
# report with its stacks (README.md). An ASAN_OPTIONS of the caller's own is kept.
ASAN_OPTIONS=${ASAN_OPTIONS:-malloc_context_size=0}
export ASAN_OPTIONS
# BBC_FUZZ_JOBS processes (default 1) fuzz the same corpus at once, each picking up the
# others' new inputs (libFuzzer's -reload); logs TARGET.log, or TARGET-K.log for K > 1.
jobs=${BBC_FUZZ_JOBS:-1}
case "$jobs" in '' | *[!0-9]* | 0) echo "run.sh: BBC_FUZZ_JOBS takes a positive integer" >&2; exit 2 ;; esac
pids=
k=1
while [ "$k" -le "$jobs" ]; do
  log=$work/$target.log
  [ "$k" -eq 1 ] || log=$work/$target-$k.log
  "$build/tests/fuzz/fuzz_$target" "$corpus" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$work/$target-" >"$log" 2>&1 &
  pids="$pids $!"
  k=$((k + 1))
done
status=0
for p in $pids; do wait "$p" || status=$?; done
# Per process: the corpus coverage at the start (INITED) and the end (DONE), then the
# statistics; with several, the executions of all of them.
k=1
total=0
while [ "$k" -le "$jobs" ]; do
  log=$work/$target.log
  [ "$k" -eq 1 ] || log=$work/$target-$k.log
  [ "$jobs" -eq 1 ] || echo "process $k ($log):"
  grep -E '^#[0-9]+[[:space:]]+(INITED|DONE)' "$log" || true
  grep -E '^stat::' "$log" || true
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  total=$((total + ${runs:-0}))
  k=$((k + 1))
done
[ "$jobs" -eq 1 ] || echo "executions, all processes: $total"
echo "corpus: $(ls "$corpus" | wc -l) files in $corpus"
if [ "$status" -ne 0 ]; then
  ls "$work/$target"-crash-* 2>/dev/null || true
  exit 1
fi
