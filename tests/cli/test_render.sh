#!/bin/sh
# Command-line behaviour of bbc-render, bbc-precompute and bbc-inspect: help, exit
# codes, messages and outputs. Each test_<name> function is one ctest entry.
set -u
RENDER="$BBC_BIN/bbc-render/bbc-render"
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
INSPECT="$BBC_BIN/bbc-inspect/bbc-inspect"
SCENE="$BBC_TEST_SCENES/glass-sphere.gltf"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

test_help_documents_every_flag() {
  expect_status 0 "$RENDER" --help
  for flag in --output --png --exposure --width --height --method --max-depth --no-fresnel \
              --spp --time --threads --seed --progress --no-progress --stats --version --help \
              --no-verify --region; do
    grep -q -- "$flag" "$TMP/out" || fail "--help does not mention $flag"
  done
  [ -s "$TMP/err" ] && fail "--help wrote to stderr"
  return 0
}

test_version() {
  expect_status 0 "$RENDER" --version
  grep -q "bbc-render" "$TMP/out" || fail "no version line"
}

test_unknown_flag_exits_2() {
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --bogus
  grep -q "^bbc-render: unknown option '--bogus'" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  grep -q "usage:" "$TMP/err" || fail "no usage"
}

test_bad_numbers_exit_2() {
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --spp 12x
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --spp 0
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --time nan
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --threads=-1
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --spp
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --method magic
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --region 1,2,3
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --region 5,0,5,4
  expect_status 2 "$RENDER" "$SCENE" -o "$TMP/x.exr" --width 8 --region 0,0,9,2
  grep -q "does not lie within the 8x" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  expect_status 2 "$RENDER" "$SCENE"
  expect_status 2 "$RENDER" -o "$TMP/x.exr"
  [ -e "$TMP/x.exr" ] && fail "an output was written"
  return 0
}

test_missing_scene_exits_1() {
  expect_status 1 "$RENDER" "$TMP/none.gltf" -o "$TMP/x.exr"
  grep -q "none.gltf" "$TMP/err" || fail "message does not name the file"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ -e "$TMP/x.exr" ] && fail "an output was written"
  return 0
}

test_malformed_scene_exits_1() {
  printf '{"asset": {"version": "2.0"}, "nodes": [' > "$TMP/bad.gltf"
  expect_status 1 "$RENDER" "$TMP/bad.gltf" -o "$TMP/x.exr"
  grep -q "bad.gltf" "$TMP/err" || fail "message does not name the file"
  [ -e "$TMP/x.exr" ] && fail "an output was written"
  return 0
}

test_unwritable_output_exits_1() {
  expect_status 1 "$RENDER" "$SCENE" -o "$TMP/no/such/dir/x.exr" --spp 1 --width 8
  grep -q "x.exr" "$TMP/err" || fail "message does not name the file"
}

test_renders_exr_and_png() {
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/a.exr" --png "$TMP/a.png" --spp 2 --width 40 \
    --stats --no-progress
  [ -s "$TMP/a.exr" ] || fail "no EXR"
  head -c 4 "$TMP/a.exr" | od -An -tx1 | grep -q "76 2f 31 01" || fail "not an EXR"
  head -c 8 "$TMP/a.png" | od -An -c | grep -q "P   N   G" || fail "not a PNG"
  grep -q "rays" "$TMP/err" || fail "--stats printed no rays"
  [ -s "$TMP/out" ] && fail "stdout is not empty"
  ls "$TMP" | grep -q tmp && fail "a temporary file was left behind"
  return 0
}

test_equals_form_and_thread_independence() {
  expect_status 0 "$RENDER" "$SCENE" --output="$TMP/a.exr" --spp=3 --width=24 --threads=1
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/b.exr" --spp 3 --width 24 --threads 2
  cmp -s "$TMP/a.exr" "$TMP/b.exr" || fail "images differ between 1 and 2 threads"
}

# --region renders part of the image: its pixels are those of the whole image (relMSE 0
# over the region, from another thread count), the rest differs (black).
test_region() {
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/a.exr" --spp 3 --width 24 --threads 2
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/b.exr" --spp 3 --width 24 --threads 1 \
    --region 4,3,20,15 --reference "$TMP/a.exr"
  grep -qx "relMSE 0" "$TMP/out" || fail "the region differs: $(cat "$TMP/out")"
  expect_status 0 "$RENDER" "$SCENE" -o "$TMP/c.exr" --spp 3 --width 24 --reference "$TMP/b.exr"
  grep -qx "relMSE 0" "$TMP/out" && fail "pixels outside the region were rendered"
  return 0
}

# --light-units reaches the scene: the generated scenes are radiometric, so reading them
# as photometric changes the light and the cache of the file's units is refused.
test_light_units_override() {
  scene="$BBC_TEST_SCENES/flat-mirror.gltf"
  expect_status 2 "$RENDER" "$scene" -o "$TMP/x.exr" --light-units watts
  grep -q "^bbc-render: --light-units: unknown units 'watts'" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$PRECOMPUTE" "$scene" -o "$TMP/x.bbc" --light-units=lux
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/m.bbc" --max-level 2 --resolution 8 --no-progress
  expect_status 0 "$RENDER" "$scene" -o "$TMP/a.exr" --cache "$TMP/m.bbc" --spp 1 --width 8 \
    --light-units radiometric
  expect_status 1 "$RENDER" "$scene" -o "$TMP/b.exr" --cache "$TMP/m.bbc" --spp 1 --width 8 \
    --light-units photometric
  grep -q "light" "$TMP/err" || fail "the refusal does not name the lights: $(cat "$TMP/err")"
  [ -e "$TMP/b.exr" ] && fail "an output was written"
  expect_status 0 "$INSPECT" check-bounds "$scene" "$TMP/m.bbc" --samples 1 --light-units radiometric
  expect_status 1 "$INSPECT" check-bounds "$scene" "$TMP/m.bbc" --samples 1 --light-units photometric
  return 0
}

# Photons per sample: a sixteenth of the pixels for a scene of mirrors whose cache holds
# R and RR (photons can then only add chains of three mirrors), a photon per pixel when
# the cache lacks RR (as --chains R or the precompute's --double-budget leave it).
test_photons_cover_mirror_chains_the_cache_lacks() {
  scene="$BBC_TEST_SCENES/two-mirrors.gltf"
  opts="--max-level 3 --resolution 32 --no-progress"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/all.bbc" $opts
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/r.bbc" $opts --chains R
  traced() { expect_status 0 "$RENDER" "$scene" --cache "$1" -o "$TMP/x.exr" --width 32 --spp 2 \
      --stats --no-progress
    sed -n 's/^photons *\([0-9]*\) traced.*/\1/p' "$TMP/err"; }
  pixels=$((32 * 24)) # the camera's 4:3
  all=$(traced "$TMP/all.bbc")
  [ "$all" = $((pixels / 16 * 2)) ] || fail "R and RR cached: $all photons in 2 samples"
  r=$(traced "$TMP/r.bbc")
  [ "$r" = $((pixels * 2)) ] || fail "RR not cached: $r photons in 2 samples"
}

# --only seen-caustics counts the caustic only where the camera sees it directly: with the
# TT chains alone that is every caustic path of 4 segments, so the image is the one that
# --max-depth 4 makes bit for bit; without the limit the caustic seen through the ball
# adds light.
test_seen_caustics() {
  scene="$BBC_TEST_SCENES/glass-sphere.gltf"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/tt.bbc" --chains TT --max-level 1 --no-progress
  opts="--cache $TMP/tt.bbc --chains TT --width 32 --spp 2 --no-progress"
  expect_status 0 "$RENDER" "$scene" $opts -o "$TMP/seen.exr" --only seen-caustics
  expect_status 0 "$RENDER" "$scene" $opts -o "$TMP/four.exr" --only caustics --max-depth 4
  expect_status 0 "$RENDER" "$scene" $opts -o "$TMP/all.exr" --only caustics
  cmp -s "$TMP/seen.exr" "$TMP/four.exr" || fail "seen-caustics differs from depth 4"
  cmp -s "$TMP/seen.exr" "$TMP/all.exr" && fail "no caustic is seen through the ball"
  return 0
}

# A hollow glass ball: every light path of one or two specular vertices through it is
# blocked by its inner sphere, so the precompute finds no tuple and says what to do; the
# renderer light-traces its caustic without a cache when asked (off by default there).
test_hollow_glass_without_a_cache() {
  scene="$BBC_TEST_SCENES/hollow-sphere.gltf"
  expect_status 1 "$PRECOMPUTE" "$scene" -o "$TMP/h.bbc" --no-progress
  grep -q "would hold no tuple.*light-traced by bbc-render" "$TMP/err" || fail "$(cat "$TMP/err")"
  [ -e "$TMP/h.bbc" ] && fail "a cache was written"
  expect_status 0 "$RENDER" "$scene" -o "$TMP/off.exr" --only caustics --width 32 --spp 2 --stats
  grep -q "^photons" "$TMP/err" && fail "light-traced without being asked: $(cat "$TMP/err")"
  expect_status 0 "$RENDER" "$scene" -o "$TMP/on.exr" --only caustics --width 32 --spp 2 --stats \
    --light-trace on
  added=$(sed -n 's/^photons.* traced, \([0-9]*\) added.*/\1/p' "$TMP/err")
  [ "${added:-0}" -gt 0 ] || fail "no photon reached a pixel: $(cat "$TMP/err")"
  return 0
}

# Many images from one cache: --camera, --all-cameras and --frames name their outputs,
# and every image is reproducible bit for bit.
test_cameras_and_frames() {
  scene="$BBC_TEST_SCENES/orbit.gltf"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/o.bbc" --max-level 3 --resolution 16 --no-progress
  common="--cache $TMP/o.bbc --spp 2 --width 24 --no-progress"
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/plain.exr"
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/all.exr" --all-cameras --stats
  [ -s "$TMP/all.cam0.exr" ] && [ -s "$TMP/all.cam1.exr" ] || fail "--all-cameras: $(ls "$TMP")"
  grep -q "loading .* once" "$TMP/err" || fail "--stats does not time the loading: $(cat "$TMP/err")"
  [ "$(grep -c '^time  *[0-9]' "$TMP/err")" -eq 2 ] || fail "--stats: not one time per camera"
  cmp -s "$TMP/plain.exr" "$TMP/all.cam0.exr" || fail "camera 0 differs from the default render"
  cmp -s "$TMP/all.cam0.exr" "$TMP/all.cam1.exr" && fail "the two cameras gave the same image"
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/side.exr" --camera side
  cmp -s "$TMP/side.exr" "$TMP/all.cam1.exr" || fail "--camera side is not camera 1"
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/one.exr" --camera=1
  cmp -s "$TMP/one.exr" "$TMP/all.cam1.exr" || fail "--camera 1 is not camera 1"
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/f.exr" --png "$TMP/f.png" --frames 0:4:2
  for f in 0000 0002 0004; do
    [ -s "$TMP/f.$f.exr" ] && [ -s "$TMP/f.$f.png" ] || fail "frame $f missing: $(ls "$TMP")"
  done
  [ -e "$TMP/f.0001.exr" ] && fail "frame 1 was written with step 2"
  cmp -s "$TMP/f.0000.exr" "$TMP/f.0004.exr" && fail "frames 0 and 4 are the same image"
  # A frame rendered alone, again, is bit-identical to the same frame of the range.
  expect_status 0 "$RENDER" "$scene" $common -o "$TMP/g.exr" --frames 2:2 --threads 1
  cmp -s "$TMP/g.0002.exr" "$TMP/f.0002.exr" || fail "frame 2 re-rendered differs"
  # Bad input: one line, no image.
  expect_status 1 "$RENDER" "$scene" $common -o "$TMP/x.exr" --camera nope
  grep -q "^bbc-render: .*orbit.gltf: --camera: no camera 'nope' (2 cameras: 0 \"camera\", 1 \"side\")$" \
    "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 1 "$RENDER" "$scene" $common -o "$TMP/x.exr" --camera side --frames 0:3
  grep -q "^bbc-render: .*--frames: the camera is not animated" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 1 "$RENDER" "$BBC_TEST_SCENES/flat-mirror.gltf" -o "$TMP/x.exr" --frames 0:3 --width 8
  grep -q "not animated" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$RENDER" "$scene" -o "$TMP/x.exr" --frames 3:1
  expect_status 2 "$RENDER" "$scene" -o "$TMP/x.exr" --frames 1:x
  expect_status 2 "$RENDER" "$scene" -o "$TMP/x.exr" --frames 0:3:0
  expect_status 2 "$RENDER" "$scene" -o "$TMP/x.exr" --camera 0 --all-cameras
  ls "$TMP" | grep -q '^x\.' && fail "an output was written"
  return 0
}

test_placeholder_tools_document_themselves() {
  expect_status 0 "$PRECOMPUTE" --help
  grep -q "usage" "$TMP/out" || fail "bbc-precompute --help"
  expect_status 0 "$INSPECT" --help
  grep -q "usage" "$TMP/out" || fail "bbc-inspect --help"
  expect_status 2 "$PRECOMPUTE" "$SCENE"
}

"test_$1"
