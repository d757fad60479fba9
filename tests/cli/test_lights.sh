# CLI tests of spot and directional lights: per-light tuple lists (bbc-inspect info,
# bbc-render --stats) and check-bounds summaries per light kind. Each test_* function is
# one ctest entry (tests/CMakeLists.txt).
set -u
INSPECT="$BBC_BIN/bbc-inspect/bbc-inspect"
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
RENDER="$BBC_BIN/bbc-render/bbc-render"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

precompute() {
  expect_status 0 "$PRECOMPUTE" "$BBC_TEST_SCENES/$1" -o "$2" --max-level 5 --no-progress \
    --chains "$3"
}

test_info_and_stats_list_tuples_per_light() {
  precompute flat-mirror-sun.gltf "$TMP/sun.bbc" R
  expect_status 0 "$INSPECT" info "$TMP/sun.bbc"
  grep -q "^  light 0: [1-9][0-9]* tuples (R [1-9]" "$TMP/out" || fail "info: $(cat "$TMP/out")"
  expect_status 0 "$RENDER" "$BBC_TEST_SCENES/flat-mirror-sun.gltf" --cache "$TMP/sun.bbc" \
    --spp 1 --width 16 --height 12 --stats --no-progress -o "$TMP/sun.exr"
  grep -q "^  light 0 (directional): [1-9][0-9]* tuples (R " "$TMP/err" ||
    fail "--stats: $(cat "$TMP/err")"
}

test_check_bounds_per_light_kind() {
  precompute two-mirrors-spot.gltf "$TMP/spot.bbc" R,RR
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/two-mirrors-spot.gltf" "$TMP/spot.bbc" \
    --samples 200 --no-progress
  for c in R RR; do
    grep -q "^$c, spot lights: .* [1-9][0-9]* admissible paths.*(0 failing paths)" "$TMP/out" ||
      fail "no clean $c spot summary: $(cat "$TMP/out")"
  done
  precompute pool-sun.gltf "$TMP/sun.bbc" T
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/pool-sun.gltf" "$TMP/sun.bbc" \
    --samples 20 --no-progress
  grep -q "^T, directional lights: .* [1-9][0-9]* admissible paths.*(0 failing paths)" "$TMP/out" ||
    fail "no clean T sun summary: $(cat "$TMP/out")"
}

test_area_lights_through_the_cache() {
  expect_status 0 "$PRECOMPUTE" "$BBC_TEST_SCENES/flat-mirror-area.gltf" -o "$TMP/area.bbc" \
    --max-level 5 --resolution 64 --no-progress --chains R --area-lights
  expect_status 0 "$INSPECT" info "$TMP/area.bbc"
  grep -q "^format *1.6 " "$TMP/out" || fail "info: not format 1.6: $(cat "$TMP/out")"
  grep -q "^area lights *on, double scattering off, alpha 100$" "$TMP/out" ||
    fail "info: no area lights line: $(cat "$TMP/out")"
  grep -q "^  light 1: [1-9][0-9]* tuples (R [1-9]" "$TMP/out" || fail "info: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" validate "$TMP/area.bbc"
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/flat-mirror-area.gltf" "$TMP/area.bbc" \
    --samples 2000 --no-progress
  grep -q "^R, area lights: .* [1-9][0-9]* admissible paths.*(0 failing paths)" "$TMP/out" ||
    fail "no clean R area summary: $(cat "$TMP/out")"
  expect_status 0 "$RENDER" "$BBC_TEST_SCENES/flat-mirror-area.gltf" --cache "$TMP/area.bbc" \
    --spp 1 --width 16 --height 12 --stats --no-progress -o "$TMP/area.exr"
  grep -q "^  light 0 (area, triangle [0-9]*): [1-9][0-9]* tuples (R " "$TMP/err" ||
    fail "--stats: $(cat "$TMP/err")"
}

# Double scattering from area lights is opt-in: --area-lights alone caches the emitters'
# R only whatever --chains holds; --area-double adds their RR, whose bounds check-bounds
# finds clean (format 1.6 for both: a receiver plane); --area-double or --alpha-area
# without --area-lights, or --area-double without a double-scattering chain type, is a
# usage error.
test_area_double_is_opt_in() {
  scene="$BBC_TEST_SCENES/two-mirrors-area.gltf"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/single.bbc" --max-level 4 --resolution 64 \
    --no-progress --chains R,RR --area-lights
  expect_status 0 "$INSPECT" info "$TMP/single.bbc"
  grep -q "^area lights *on, double scattering off" "$TMP/out" || fail "info: $(cat "$TMP/out")"
  grep -q "^tuples .*RR" "$TMP/out" && fail "RR tuples without --area-double: $(cat "$TMP/out")"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/double.bbc" --max-level 4 --resolution 64 \
    --no-progress --chains R,RR --area-lights --area-double
  expect_status 0 "$INSPECT" info "$TMP/double.bbc"
  grep -q "^area lights *on, double scattering on" "$TMP/out" || fail "info: $(cat "$TMP/out")"
  grep -q "^  light 1: [1-9][0-9]* tuples (R [1-9][0-9]*, RR [1-9]" "$TMP/out" ||
    fail "info: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" check-bounds "$scene" "$TMP/double.bbc" --samples 500 --no-progress
  grep -q "^RR, area lights: .* [1-9][0-9]* admissible paths.*(0 failing paths)" "$TMP/out" ||
    fail "no clean RR area summary: $(cat "$TMP/out")"
  expect_status 2 "$PRECOMPUTE" "$scene" -o "$TMP/x.bbc" --area-double
  grep -q "needs --area-lights" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  expect_status 2 "$PRECOMPUTE" "$scene" -o "$TMP/x.bbc" --area-lights --area-double --chains R
  grep -q "needs a double-scattering chain type" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  expect_status 2 "$PRECOMPUTE" "$scene" -o "$TMP/x.bbc" --alpha-area 30
  grep -q "alpha-area needs --area-lights" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ -e "$TMP/x.bbc" ] && fail "a cache was written"
  return 0
}

"test_$1"
