#!/bin/sh
# SIGINT/SIGTERM handling of bbc-render and bbc-precompute: exit status 130, no output
# (or, for bbc-render --write-partial, a valid image of the completed passes) and no
# temporary file left behind. Each test_<name> function is one ctest entry.
#
# The tools run in the background; the tests wait for a sign that the work has started
# (bbc-render's progress line naming the samples done) rather than for a fixed time, and
# a watchdog kills a tool that does not stop within a minute.
set -u
RENDER="$BBC_BIN/bbc-render/bbc-render"
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
TMP=$(mktemp -d)
OUT="$TMP/out" # outputs only: must hold exactly the expected files afterwards
mkdir "$OUT"
trap 'rm -rf "$TMP"' EXIT

fail() { echo "FAILED: $*" >&2; [ -s "$TMP/err" ] && sed 's/^/  stderr: /' "$TMP/err" >&2; exit 1; }

# wait_for_text PID TEXT: waits (up to 60 s) until $TMP/err contains TEXT while PID runs.
wait_for_text() {
  n=0
  until grep -q -- "$2" "$TMP/err" 2>/dev/null; do
    kill -0 "$1" 2>/dev/null || fail "the tool exited before printing '$2'"
    n=$((n + 1))
    [ "$n" -le 600 ] || { kill -KILL "$1"; fail "no '$2' within 60 s"; }
    sleep 0.1
  done
}

# interrupt PID SIGNAL: sends the signal and waits for the tool; its status goes to
# $status. A tool still running after 60 s is killed (and the test fails).
interrupt() {
  kill -"$2" "$1" || fail "cannot send SIG$2 (the tool has already exited?)"
  (sleep 60 && kill -KILL "$1") >/dev/null 2>&1 &
  dog=$!
  wait "$1"
  status=$?
  kill "$dog" 2>/dev/null
  [ "$status" -eq 137 ] && fail "the tool did not stop within 60 s of SIG$2"
  return 0
}

# expect_files NAME...: $OUT holds exactly these files (no output, no temporary file).
expect_files() {
  got=$(cd "$OUT" && ls -A | tr '\n' ' ')
  want=""
  for f in "$@"; do want="$want$f "; done
  [ "$got" = "$want" ] || fail "output folder holds '$got', expected '$want'"
}

# is_exr FILE: starts with the OpenEXR magic number 76 2f 31 01.
is_exr() {
  [ "$(od -An -tx1 -N4 "$1" | tr -d ' \n')" = "762f3101" ]
}

# A render of at most 60 s, small enough that a pass takes a fraction of a second even
# under the sanitizers; --progress prints "N spp" once the first pass is done.
start_render() {
  "$RENDER" "$BBC_TEST_SCENES/glass-sphere.gltf" -o "$OUT/image.exr" --time 60 --width 64 \
    --progress "$@" >"$TMP/stdout" 2>"$TMP/err" &
  pid=$!
}

test_render_sigint_writes_nothing() {
  start_render
  wait_for_text "$pid" " spp"
  interrupt "$pid" INT
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  tail -n 1 "$TMP/err" | grep -qx "bbc-render: interrupted; $OUT/image.exr was not written" ||
    fail "message: $(tail -n 1 "$TMP/err")"
  [ -s "$TMP/stdout" ] && fail "wrote to stdout: $(cat "$TMP/stdout")"
  expect_files
}

test_render_sigterm_writes_nothing() {
  start_render --png "$OUT/image.png"
  wait_for_text "$pid" " spp"
  interrupt "$pid" TERM
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  grep -q "interrupted; .*image.exr was not written" "$TMP/err" || fail "no message"
  expect_files
}

test_render_write_partial() {
  start_render --png "$OUT/image.png" --write-partial
  wait_for_text "$pid" " spp"
  interrupt "$pid" INT
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  tail -n 1 "$TMP/err" |
    grep -qx "bbc-render: interrupted after [1-9][0-9]* spp; wrote partial image $OUT/image.exr" ||
    fail "message: $(tail -n 1 "$TMP/err")"
  expect_files image.exr image.png
  is_exr "$OUT/image.exr" || fail "image.exr is not an OpenEXR file"
  [ -s "$OUT/image.png" ] || fail "image.png is empty"
}

test_render_write_partial_is_documented() {
  "$RENDER" --help >"$TMP/stdout" 2>"$TMP/err" || fail "--help failed"
  grep -q -- "--write-partial" "$TMP/stdout" || fail "--help does not mention --write-partial"
  grep -q "130" "$TMP/stdout" || fail "--help does not mention exit status 130"
}

# bbc-precompute checks for a signal between batches and within each tuple's bounding;
# the demo at --max-level 8 runs long enough (several seconds) to be interrupted.
test_precompute_sigint_writes_nothing() {
  "$PRECOMPUTE" "$BBC_TEST_SCENES/demo.gltf" -o "$OUT/demo.bbc" --max-level 8 --no-progress \
    >"$TMP/stdout" 2>"$TMP/err" &
  pid=$!
  sleep 1
  interrupt "$pid" INT
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  tail -n 1 "$TMP/err" | grep -qx "bbc-precompute: interrupted; $OUT/demo.bbc was not written" ||
    fail "message: $(tail -n 1 "$TMP/err")"
  expect_files
}

# The same while the builder spills its grid entries to a temporary file: the file is
# unlinked as soon as it is made, so the spill folder stays empty whatever happens.
test_precompute_sigint_while_spilling_leaves_no_file() {
  mkdir "$TMP/spill"
  TMPDIR="$TMP/spill" "$PRECOMPUTE" "$BBC_TEST_SCENES/demo.gltf" -o "$OUT/demo.bbc" \
    --max-level 8 --entry-memory 0.01 --no-progress >"$TMP/stdout" 2>"$TMP/err" &
  pid=$!
  sleep 1
  interrupt "$pid" INT
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  expect_files
  [ -z "$(ls -A "$TMP/spill")" ] || fail "spill files left behind: $(ls -A "$TMP/spill")"
}

# A signal reaches bbc-precompute within the bounding of a tuple, not only between
# batches: a two-bounce precompute at a deep level takes minutes for its first batch
# (before the cancel check within a tuple, it ran on past 90 s after SIGTERM), and must
# stop within 20 s (it stops in about 0.1 s; seconds under the sanitizers).
test_precompute_sigterm_stops_within_a_batch() {
  "$PRECOMPUTE" "$BBC_TEST_SCENES/ball320.gltf" -o "$OUT/ball.bbc" --chains TT --max-level 14 \
    --threads 1 --no-progress >"$TMP/stdout" 2>"$TMP/err" &
  pid=$!
  sleep 2
  kill -TERM "$pid" || fail "cannot send SIGTERM (the precompute has already exited?)"
  (sleep 20 && kill -KILL "$pid") >/dev/null 2>&1 &
  dog=$!
  wait "$pid"
  status=$?
  kill "$dog" 2>/dev/null
  [ "$status" -eq 137 ] && fail "bbc-precompute did not stop within 20 s of SIGTERM"
  [ "$status" -eq 130 ] || fail "exit status $status, expected 130"
  expect_files
}

"test_$1"
