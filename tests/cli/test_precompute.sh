#!/bin/sh
# Command-line behaviour of bbc-precompute and of bbc-render with a cache. Each
# test_<name> function is one ctest entry.
set -u
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
RENDER="$BBC_BIN/bbc-render/bbc-render"
MIRROR="$BBC_TEST_SCENES/flat-mirror.gltf"
POOL="$BBC_TEST_SCENES/pool.glb"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

test_help_documents_every_flag() {
  expect_status 0 "$PRECOMPUTE" --help
  for flag in --output --stats --json --chains --max-level --sigma --alpha --alpha2 --m --resolution \
              --no-remainder --jacobian --threads --progress --no-progress --version --help; do
    grep -q -- "$flag" "$TMP/out" || fail "--help does not mention $flag"
  done
}

test_bad_usage_exits_2() {
  expect_status 2 "$PRECOMPUTE" "$MIRROR"
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --chains X
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --alpha2 0.5
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --sigma abc
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --max-level 99
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --resolution 0
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --frobnicate
  [ -e "$TMP/x.bbc" ] && fail "an output was written"
  return 0
}

test_bad_scene_exits_1() {
  expect_status 1 "$PRECOMPUTE" "$TMP/missing.gltf" -o "$TMP/x.bbc"
  grep -q "missing.gltf" "$TMP/err" || fail "message does not name the file"
  [ -e "$TMP/x.bbc" ] && fail "an output was written"
  return 0
}

test_writes_cache_with_stats_and_json() {
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --stats --json "$TMP/m.json" \
    --no-progress --max-level 6
  [ -s "$TMP/m.bbc" ] || fail "no cache"
  head -c 4 "$TMP/m.bbc" | grep -q "BBC" || fail "no magic"
  for word in tuples pieces file memory; do
    grep -q "$word" "$TMP/err" || fail "--stats lacks $word"
  done
  grep -q '"tuples"' "$TMP/m.json" || fail "JSON lacks tuples"
  [ -s "$TMP/out" ] && fail "stdout is not empty"
  ls "$TMP" | grep -q tmp && fail "a temporary file was left behind"
  return 0
}

test_byte_identical_for_any_thread_count() {
  expect_status 0 "$PRECOMPUTE" "$POOL" -o "$TMP/a.bbc" --threads 1 --max-level 3 --chains R,T
  expect_status 0 "$PRECOMPUTE" "$POOL" -o "$TMP/b.bbc" --threads 2 --max-level 3 --chains R,T
  cmp -s "$TMP/a.bbc" "$TMP/b.bbc" || fail "caches differ between 1 and 2 threads"
}

test_render_refuses_cache_of_another_scene() {
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --max-level 4
  expect_status 1 "$RENDER" "$POOL" --cache "$TMP/m.bbc" -o "$TMP/x.exr" --spp 1 --width 16
  grep -q "another scene" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ -e "$TMP/x.exr" ] && fail "an image was written"
  return 0
}

test_render_methods_need_a_cache() {
  expect_status 2 "$RENDER" "$MIRROR" -o "$TMP/x.exr" --method enumerate
  grep -q "needs a cache" "$TMP/err" || fail "message: $(cat "$TMP/err")"
}

test_render_rejects_garbage_cache() {
  printf 'not a cache' > "$TMP/bad.bbc"
  expect_status 1 "$RENDER" "$MIRROR" --cache "$TMP/bad.bbc" -o "$TMP/x.exr" --spp 1
  grep -q "bad.bbc" "$TMP/err" || fail "message does not name the file"
}

test_render_caustics_with_cache_and_reference() {
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --max-level 6
  expect_status 0 "$RENDER" "$MIRROR" --cache "$TMP/m.bbc" -o "$TMP/e.exr" --only caustics \
    --method enumerate --spp 2 --width 48
  expect_status 0 "$RENDER" "$MIRROR" --cache "$TMP/m.bbc" -o "$TMP/b.exr" --only caustics \
    --spp 2 --width 48 --stats --reference "$TMP/e.exr"
  grep -q "^relMSE " "$TMP/out" || fail "no relMSE printed"
  grep -q "|S|" "$TMP/err" || fail "--stats lacks the sampling figures"
  expect_status 1 "$RENDER" "$MIRROR" --cache "$TMP/m.bbc" -o "$TMP/x.exr" --spp 1 \
    --width 20 --reference "$TMP/e.exr"
  grep -q "not the size" "$TMP/err" || fail "size mismatch not reported"
}

"test_$1"
