#!/bin/sh
# CLI tests of bbc-scenegen. Every function test_<name> below is one ctest entry
# (cli_scenegen.<name>); ctest runs `sh test_scenegen.sh <name>` with BBC_BIN set to the
# build folder. A test fails by exiting non-zero after printing what it expected and what
# it got.

gen="${BBC_BIN:?BBC_BIN must name the build folder}/scenes/bbc-scenegen"
kinds="floor flat-mirror wavy-mirror glass-sphere glass-slab pool"

tmp=$(mktemp -d) || exit 1
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM

fail() {
  echo "FAIL: $*" >&2
  if [ -s "$tmp/stderr" ]; then
    echo "--- stderr of the last run:" >&2
    cat "$tmp/stderr" >&2
  fi
  exit 1
}

# Runs the generator with the given arguments, keeping its exit status in $status and its
# output in $tmp/stdout and $tmp/stderr.
run() {
  status=0
  "$gen" "$@" >"$tmp/stdout" 2>"$tmp/stderr" || status=$?
}

expect_status() {
  [ "$status" -eq "$1" ] || fail "expected exit status $1, got $status (args: $2)"
}

# Succeeds only if every named file exists and is not empty. (Shell variables are global,
# hence the loop variable's name, which no caller uses.)
expect_files() {
  for expected_file in "$@"; do
    [ -s "$expected_file" ] || fail "expected a non-empty file $expected_file"
  done
}

# Bad usage: exit 2, one "bbc-scenegen: <reason>" line plus the short usage on stderr,
# nothing on stdout and no file written.
expect_usage_error() {
  run "$@"
  expect_status 2 "$*"
  head -n 1 "$tmp/stderr" | grep -q '^bbc-scenegen: ' ||
    fail "stderr does not start with 'bbc-scenegen: ' (args: $*)"
  grep -q '^usage: bbc-scenegen KIND -o OUT.gltf' "$tmp/stderr" ||
    fail "stderr lacks the short usage (args: $*)"
  [ ! -s "$tmp/stdout" ] || fail "stdout is not empty (args: $*)"
  for unwanted in "$tmp/out.gltf" "$tmp/out.bin" "$tmp/out.glb"; do
    [ ! -e "$unwanted" ] || fail "$unwanted was written (args: $*)"
  done
}

# The byteLength of the buffer, which is the last byteLength in the JSON.
buffer_length() {
  sed 's/.*"byteLength":\([0-9]*\)}\]}$/\1/' "$1"
}

test_help() {
  run --help
  expect_status 0 --help
  [ ! -s "$tmp/stderr" ] || fail "--help wrote to stderr"
  for word in $kinds --size --width --height --area-light --glb --output --help --version; do
    grep -q -- "$word" "$tmp/stdout" || fail "--help does not mention '$word'"
  done
  run -h
  expect_status 0 -h
}

# The version line, as the other tools print it; the project's version from CMakeLists.txt.
test_version() {
  run --version
  expect_status 0 --version
  version=$(sed -n 's/^project(bbc VERSION \([0-9.]*\).*/\1/p' "$BBC_SOURCE_DIR/CMakeLists.txt")
  [ -n "$version" ] || fail "no version in CMakeLists.txt"
  [ "$(cat "$tmp/stdout")" = "bbc-scenegen $version" ] || fail "--version: $(cat "$tmp/stdout")"
}

test_unknown_kind() {
  expect_usage_error teapot -o "$tmp/out.gltf"
  grep -q "unknown kind 'teapot'" "$tmp/stderr" || fail "the reason does not name the kind"
}

test_bad_size() {
  expect_usage_error flat-mirror --size 12x -o "$tmp/out.gltf"
  grep -q "'12x'" "$tmp/stderr" || fail "the reason does not quote the bad value"
}

# Numbers are parsed strictly: no sign, space, exponent, junk or out-of-range value.
test_bad_numbers() {
  for bad in "--size=" "--size=0" "--size=-5" "--size=+5" "--size= 5" "--size=1e3" \
    "--size=99999999999999999999" "--width=0" "--width=640.5" "--height=abc" \
    "--height=100000" "--area-light=0" "--area-light=-0.1" "--area-light=nan" \
    "--area-light=inf" "--area-light=0.05m" "--area-light=" "--checker=0" "--checker=4097" \
    "--checker=2.5" "--roughness=1.5" "--roughness=-0.1" "--roughness=nan" "--metallic=x" \
    "--metallic="; do
    expect_usage_error floor "$bad" -o "$tmp/out.gltf"
  done
}

test_bad_usage() {
  expect_usage_error
  expect_usage_error floor
  expect_usage_error -o "$tmp/out.gltf"
  expect_usage_error floor -o
  expect_usage_error floor pool -o "$tmp/out.gltf"
  expect_usage_error floor --frobnicate -o "$tmp/out.gltf"
  expect_usage_error floor --glb=yes -o "$tmp/out.glb"
  # The extension must agree with the format, or loaders would pick the wrong parser.
  expect_usage_error floor --glb -o "$tmp/out.gltf"
  expect_usage_error floor -o "$tmp/out.glb"
}

test_unwritable_output() {
  run floor -o "$tmp/no/such/folder/out.gltf"
  expect_status 1 "output in a missing folder"
  [ "$(wc -l <"$tmp/stderr")" -eq 1 ] || fail "expected a one-line message"
  grep -q "^bbc-scenegen: .*no/such/folder/out" "$tmp/stderr" ||
    fail "the message does not name the file"
}

test_no_temporary_left() {
  run pool --size 50 -o "$tmp/out.gltf"
  expect_status 0 "pool"
  run pool --size 50 --glb -o "$tmp/out.glb"
  expect_status 0 "pool --glb"
  expect_files "$tmp/out.gltf" "$tmp/out.bin" "$tmp/out.glb"
  # A folder in the way of the .gltf: the temporaries are written, the rename fails, and
  # the temporary of the .gltf must not be left behind.
  mkdir "$tmp/dir.gltf"
  run pool --size 50 -o "$tmp/dir.gltf"
  expect_status 1 "pool onto a folder"
  left=
  for file in "$tmp"/*; do
    case ${file##*/} in
      out.gltf | out.bin | out.glb | dir.gltf | dir.bin | stdout | stderr) ;;
      *) left="$left ${file##*/}" ;;
    esac
  done
  [ -z "$left" ] || fail "unexpected files left behind: $left"
}

test_deterministic() {
  mkdir "$tmp/a" "$tmp/b"
  for dir in a b; do
    run glass-sphere --size 320 --area-light 0.1 -o "$tmp/$dir/s.gltf"
    expect_status 0 "run into $dir"
    run wavy-mirror --size 300 --glb -o "$tmp/$dir/w.glb"
    expect_status 0 "--glb run into $dir"
    run pool --size 50 --checker 8 --roughness 0.3 --glb -o "$tmp/$dir/c.glb"
    expect_status 0 "--checker run into $dir"
  done
  for file in s.gltf s.bin w.glb c.glb; do
    expect_files "$tmp/a/$file" "$tmp/b/$file"
    cmp -s "$tmp/a/$file" "$tmp/b/$file" || fail "two runs gave different $file"
  done
}

# Writes one kind as .gltf + .bin and as .glb and checks the outputs' basic shape.
check_kind() {
  run "$1" --size 50 -o "$tmp/$1.gltf"
  expect_status 0 "$1"
  expect_files "$tmp/$1.gltf" "$tmp/$1.bin"
  grep -q "\"kind\":\"$1\"" "$tmp/$1.gltf" || fail "$1: the scene extras lack the kind"
  grep -q '"asset":{[^}]*"extras":{"bbc":{"light_units":"radiometric"}}' "$tmp/$1.gltf" ||
    fail "$1: the asset does not say its lights are radiometric"
  grep -q "\"uri\":\"$1.bin\"" "$tmp/$1.gltf" || fail "$1: the buffer uri is not $1.bin"
  want=$(wc -c <"$tmp/$1.bin" | tr -d ' ')
  got=$(buffer_length "$tmp/$1.gltf")
  [ "$got" = "$want" ] || fail "$1: buffer byteLength $got, .bin holds $want bytes"
  run "$1" --size 50 --glb -o "$tmp/$1.glb"
  expect_status 0 "$1 --glb"
  expect_files "$tmp/$1.glb"
  [ "$(head -c 4 "$tmp/$1.glb")" = "glTF" ] || fail "$1: the .glb lacks the glTF magic"
}

test_kind_floor() { check_kind floor; }
test_kind_flat_mirror() { check_kind flat-mirror; }
test_kind_wavy_mirror() { check_kind wavy-mirror; }
test_kind_glass_sphere() { check_kind glass-sphere; }
test_kind_glass_slab() { check_kind glass-slab; }
test_kind_pool() { check_kind pool; }
test_kind_glass_pool() { check_kind glass-pool; }
test_kind_ball() { check_kind ball; }
test_kind_slab_sheets() { check_kind slab-sheets; }
test_kind_diamond() { check_kind diamond; }
test_kind_wide_pool() { check_kind wide-pool; }
test_kind_hollow_sphere() { check_kind hollow-sphere; }
test_kind_glass_of_water() { check_kind glass-of-water; }

# The triangles of the mesh named $2 in the glTF file $1 and its positions' bounds.
mesh_shape() {
  python3 - "$1" "$2" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
m = next(m for m in d["meshes"] if m["name"] == sys.argv[2])
p = m["primitives"][0]
pos = d["accessors"][p["attributes"]["POSITION"]]
print(d["accessors"][p["indices"]]["count"] // 3, pos["min"], pos["max"])
PY
}

# --floor-size re-meshes the floor as a flat grid of about N triangles over the same
# rectangle, and changes nothing else.
test_floor_size() {
  run wavy-mirror --size 50 -o "$tmp/two.gltf"
  expect_status 0 "wavy-mirror"
  run wavy-mirror --size 50 --floor-size 20000 -o "$tmp/grid.gltf"
  expect_status 0 "--floor-size 20000"
  two=$(mesh_shape "$tmp/two.gltf" floor) || fail "cannot read two.gltf"
  grid=$(mesh_shape "$tmp/grid.gltf" floor) || fail "cannot read grid.gltf"
  [ "${two%% *}" = 2 ] || fail "default floor: ${two%% *} triangles, expected 2"
  [ "${grid%% *}" = 20000 ] || fail "--floor-size 20000: ${grid%% *} triangles"
  [ "${two#* }" = "${grid#* }" ] || fail "the floor moved: ${two#* } against ${grid#* }"
  [ "$(mesh_shape "$tmp/two.gltf" wavy_mirror)" = "$(mesh_shape "$tmp/grid.gltf" wavy_mirror)" ] ||
    fail "the mirror changed"
  expect_usage_error wavy-mirror --floor-size 1 -o "$tmp/out.gltf"
  expect_usage_error floor --floor-size 100 -o "$tmp/out.gltf"
}

# The point light gives way to an emissive square when --area-light is given.
test_area_light() {
  run flat-mirror --size 8 --area-light 0.05 -o "$tmp/out.gltf"
  expect_status 0 "--area-light"
  expect_files "$tmp/out.gltf"
  grep -q 'KHR_materials_emissive_strength' "$tmp/out.gltf" || fail "no emissive strength"
  ! grep -q 'KHR_lights_punctual' "$tmp/out.gltf" || fail "the point light is still there"
  grep -q '"role":"none"' "$tmp/out.gltf" || fail "the emitter lacks role none"
}

# 16-bit indices up to 65535 vertices, 32-bit above, so loaders meet both.
test_index_width() {
  run flat-mirror --size 800 -o "$tmp/small.gltf"
  expect_status 0 "small mirror"
  expect_files "$tmp/small.gltf"
  grep -q '"componentType":5123' "$tmp/small.gltf" || fail "small mesh: no 16-bit indices"
  ! grep -q '"componentType":5125' "$tmp/small.gltf" || fail "small mesh: 32-bit indices"
  run flat-mirror --size 140000 -o "$tmp/large.gltf"
  expect_status 0 "large mirror"
  expect_files "$tmp/large.gltf"
  grep -q '"componentType":5125' "$tmp/large.gltf" || fail "large mesh: no 32-bit indices"
}

test_camera_size() {
  run floor --width 640 --height=480 -o "$tmp/out.gltf"
  expect_status 0 "--width/--height"
  expect_files "$tmp/out.gltf"
  grep -q '"width":640,"height":480' "$tmp/out.gltf" || fail "camera extras lack 640x480"
  grep -q '"aspectRatio":1.3333333333333333' "$tmp/out.gltf" || fail "aspect ratio not 4/3"
}

# --orbit adds a second camera and a LINEAR animation of the first camera's node.
test_orbit() {
  run flat-mirror --size 8 --orbit 3 -o "$tmp/orbit.gltf"
  expect_status 0 "--orbit"
  grep -q '"animations":\[{"name":"orbit"' "$tmp/orbit.gltf" || fail "no orbit animation"
  grep -q '"name":"side","camera":1' "$tmp/orbit.gltf" || fail "no side camera"
  expect_usage_error flat-mirror --orbit 1 -o "$tmp/out.gltf"
  expect_usage_error flat-mirror --orbit x -o "$tmp/out.gltf"
}

command -v "test_$1" >/dev/null 2>&1 || { echo "no such test: '$1'" >&2; exit 2; }
"test_$1"
