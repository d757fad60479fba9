#!/bin/sh
# Command-line behaviour of bbc-precompute and of bbc-render with a cache. Each
# test_<name> function is one ctest entry.
set -u
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
RENDER="$BBC_BIN/bbc-render/bbc-render"
MIRROR="$BBC_TEST_SCENES/flat-mirror.gltf"
POOL="$BBC_TEST_SCENES/pool.glb"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

# Writer edge cases: every cache bbc-precompute writes passes its own validation (it is
# checked before the rename). A receiver whose three vertices are one point gets the
# 1 x 1 grid of a single-point domain (format-spec 6.3, R-RCV-2).
test_degenerate_receiver_cache_is_valid() {
  python3 - "$TMP/d.gltf" <<'PY' || fail "cannot write the scene"
import json, struct, base64, sys
# mirror triangle (x=0 wall), floor quad, and a receiver whose vertices are one point
mirror = [(0,0,-1),(0,2,-1),(0,0,1)]
floor = [(-2,0,-2),(2,0,-2),(2,0,2),(-2,0,2)]
dot = [(1,0.5,0.5)]*3
pos = mirror+floor+dot
idx = [0,1,2, 0,2,1, 0,3,2, 0,1,2]
blob = b''.join(struct.pack('<3f',*p) for p in pos) + struct.pack('<12I',*idx)
nb = len(pos)*12
uri = 'data:application/octet-stream;base64,' + base64.b64encode(blob).decode()
def acc(bv, count, typ, comp, mn=None, mx=None):
    a={"bufferView":bv,"componentType":comp,"count":count,"type":typ}
    if mn: a["min"]=mn; a["max"]=mx
    return a
g = {"asset":{"version":"2.0","extras":{"bbc":{"light_units":"radiometric"}}},
 "extensionsUsed":["KHR_lights_punctual"],
 "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","color":[1,1,1],"intensity":10}]}},
 "scene":0,"scenes":[{"nodes":[0,1,2,3,4]}],
 "nodes":[{"mesh":0},{"mesh":1},{"mesh":2,"extras":{"bbc":{"role":"receiver"}}},
          {"translation":[1,1,0],"extensions":{"KHR_lights_punctual":{"light":0}}},
          {"camera":0,"translation":[2,6,0],"rotation":[-0.7071067811865475,0,0,0.7071067811865476]}],
 "cameras":[{"type":"perspective","perspective":{"aspectRatio":1.333,"yfov":0.7,"znear":0.01}}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":3,"material":0}]},
           {"primitives":[{"attributes":{"POSITION":1},"indices":4,"material":1}]},
           {"primitives":[{"attributes":{"POSITION":2},"indices":5,"material":1}]}],
 "materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"metallicFactor":1,"roughnessFactor":0}},
              {"pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0}}],
 "buffers":[{"byteLength":len(blob),"uri":uri}],
 "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":48},
                {"buffer":0,"byteOffset":84,"byteLength":36},{"buffer":0,"byteOffset":nb,"byteLength":12},
                {"buffer":0,"byteOffset":nb+12,"byteLength":24},{"buffer":0,"byteOffset":nb+36,"byteLength":12}],
 "accessors":[acc(0,3,"VEC3",5126,[0,0,-1],[0,2,1]),acc(1,4,"VEC3",5126,[-2,0,-2],[2,0,2]),
              acc(2,3,"VEC3",5126,[1,0.5,0.5],[1,0.5,0.5]),acc(3,3,"SCALAR",5125),acc(4,6,"SCALAR",5125),acc(5,3,"SCALAR",5125)]}
json.dump(g, open(sys.argv[1],'w'))
PY
  expect_status 0 "$PRECOMPUTE" "$TMP/d.gltf" -o "$TMP/d.bbc" --chains R --max-level 4 \
    --resolution 64 --no-progress
  expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$TMP/d.bbc"
  grep -q "1: mesh 2, box, 1 x 1 cells" "$TMP/out" || fail "no 1 x 1 receiver: $(cat "$TMP/out")"
  expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" validate "$TMP/d.bbc"
}

test_help_documents_every_flag() {
  expect_status 0 "$PRECOMPUTE" --help
  for flag in --output --stats --json --chains --max-level --sigma --alpha --alpha2 --m --resolution \
              --no-remainder --jacobian --threads --progress --no-progress --version --help \
              --allow-empty --light-units; do
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

# A cache with no tuple for a scene with casters is an error that says why, unless
# --allow-empty; a scene without casters only gets a warning.
test_empty_cache_says_why() {
  area="$BBC_TEST_SCENES/flat-mirror-area.gltf"
  expect_status 1 "$PRECOMPUTE" "$area" -o "$TMP/a.bbc" --no-progress
  grep -q "^bbc-precompute: .*flat-mirror-area.gltf: the cache would hold no tuple: the scene has no point light" \
    "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ -e "$TMP/a.bbc" ] && fail "an output was written"
  expect_status 0 "$PRECOMPUTE" "$area" -o "$TMP/a.bbc" --no-progress --allow-empty
  grep -q "warning: .*no point light" "$TMP/err" || fail "no warning: $(cat "$TMP/err")"
  [ -s "$TMP/a.bbc" ] || fail "--allow-empty wrote no cache"
  expect_status 1 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --chains T,TT --no-progress
  grep -q "the casters are all mirrors" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  expect_status 0 "$PRECOMPUTE" "$BBC_TEST_SCENES/floor.gltf" -o "$TMP/f.bbc" --no-progress
  grep -q "warning: .*no mesh is a caster" "$TMP/err" || fail "floor: $(cat "$TMP/err")"
  [ -s "$TMP/f.bbc" ] || fail "floor: no cache"
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
