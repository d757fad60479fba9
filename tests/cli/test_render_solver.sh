#!/bin/sh
# bbc-render's --solver option (Newton's method on double-scattering tuples): parsing,
# help, the --stats line and thread independence with a cache holding two-bounce
# tuples. Each test_<name> function is one ctest entry.
set -u
RENDER="$BBC_BIN/bbc-render/bbc-render"
TEST_CACHE="$BBC_BIN/tests/bbc-test-cache"
SCENE="$BBC_TEST_SCENES/glass-sphere.gltf"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

# A cache of the glass ball whose tuples are one third TT (bbc-test-cache synthetic).
make_cache() {
  "$TEST_CACHE" synthetic "$SCENE" "$TMP/c.bbc" 32 || fail "bbc-test-cache synthetic failed"
}

test_help_documents_solver() {
  expect_status 0 "$RENDER" --help
  for word in --solver newton-stoch newton-det; do
    grep -q -- "$word" "$TMP/out" || fail "--help does not mention $word"
  done
}

test_bad_solver_exits_2() {
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --solver magic
  [ "$(head -n 1 "$TMP/err")" = "bbc-render: --solver: unknown solver 'magic' (newton-stoch, newton-det)" ] ||
    fail "message: $(cat "$TMP/err")"
  grep -q "^usage:" "$TMP/err" || fail "no usage line"
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --solver
  head -n 1 "$TMP/err" | grep -q "^bbc-render: --solver needs a value$" || fail "message: $(cat "$TMP/err")"
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --solver=Newton-Det
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --solver=
  [ -e "$TMP/x.exr" ] && fail "an output was written"
  return 0
}

test_solver_values_accepted() {
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/a.exr" --solver newton-det --spp 1 --width 8
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/b.exr" --solver=newton-stoch --spp 1 --width 8
  [ -s "$TMP/a.exr" ] && [ -s "$TMP/b.exr" ] || fail "no image"
}

test_stats_report_newton() {
  make_cache
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/a.exr" --cache "$TMP/c.bbc" --method enumerate \
    --solver newton-det --spp 1 --width 24 --stats --no-progress
  grep -q "^newton       newton-det: [0-9]* solves, [0-9]* converged" "$TMP/err" ||
    fail "no newton line: $(cat "$TMP/err")"
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/b.exr" --cache "$TMP/c.bbc" --method enumerate \
    --spp 1 --width 24 --stats --no-progress
  grep -q "^newton       newton-stoch: .* mean K [0-9.]*, [0-9]* capped at K = 65536$" "$TMP/err" ||
    fail "no newton line: $(cat "$TMP/err")"
}

test_two_bounce_thread_independence() {
  make_cache
  for n in 1 2 3; do
    expect_status 0 "$RENDER" "$SCENE" -o "$TMP/t$n.exr" --cache "$TMP/c.bbc" --gamma 20 \
      --solver newton-stoch --spp 2 --width 24 --threads $n
  done
  cmp -s "$TMP/t1.exr" "$TMP/t2.exr" || fail "images differ between 1 and 2 threads"
  cmp -s "$TMP/t1.exr" "$TMP/t3.exr" || fail "images differ between 1 and 3 threads"
}

"test_$1"
