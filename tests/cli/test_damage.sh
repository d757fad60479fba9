#!/bin/sh
# Damaged caches through the tools users run: bbc-render refuses a damaged cache before
# the first pixel (or, with --no-verify, stops at the first damaged chunk a lookup
# meets) with one line and exit status 1, and writes nothing (format-spec R-REN-1).
# Each test_<name> function is one ctest entry.
set -u
RENDER="$BBC_BIN/bbc-render/bbc-render"
INSPECT="$BBC_BIN/bbc-inspect/bbc-inspect"
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
SCENE="$BBC_TEST_SCENES/flat-mirror.gltf"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

make_cache() {
  "$PRECOMPUTE" "$SCENE" -o "$TMP/c.bbc" --chains R --max-level 4 --resolution 64 \
    --no-progress 2>"$TMP/err" || fail "cannot precompute: $(cat "$TMP/err")"
}

# damage IN OUT WHERE: OUT is IN with one byte of chunk 0's data XORed with 0xFF, at
# WHERE = first, middle or last byte of the chunk.
damage() {
  python3 - "$1" "$2" "$3" <<'PY' || fail "cannot damage the file"
import struct, sys
src, dst, where = sys.argv[1:]
b = bytearray(open(src, "rb").read())
n = struct.unpack_from("<I", b, 12)[0]
secs = {}
for i in range(n):
    t, f, off, size = struct.unpack_from("<4sIQQ", b, 64 + 32 * i)
    secs[t] = (off, size)
cdat, chnk = secs[b"CDAT"][0], secs[b"CHNK"][0]
off, csize = struct.unpack_from("<QI", b, chnk)
k = {"first": 0, "middle": csize // 2, "last": csize - 1}[where]
b[cdat + off + k] ^= 0xFF
open(dst, "wb").write(b)
PY
}

render() {
  expect_status "$1" "$RENDER" "$SCENE" --cache "$2" -o "$TMP/out.exr" --only caustics \
    --spp 1 --width 16 --height 12 --no-progress $3
}

test_render_refuses_a_damaged_chunk() {
  make_cache
  render 0 "$TMP/c.bbc" ""
  [ -s "$TMP/out.exr" ] || fail "the undamaged cache gave no image"
  for where in first middle last; do
    rm -f "$TMP/out.exr"
    damage "$TMP/c.bbc" "$TMP/d.bbc" $where
    for threads in 1 2; do
      render 1 "$TMP/d.bbc" "--threads $threads --no-verify"
      [ -e "$TMP/out.exr" ] && fail "$where byte, $threads threads: an image was written"
      [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "$where byte: not one line: $(cat "$TMP/err")"
      grep -q "d.bbc: CDAT at byte [0-9]*: chunk 0 " "$TMP/err" ||
        fail "$where byte: message: $(cat "$TMP/err")"
    done
  done
  return 0
}

test_write_partial_never_writes_damaged_data() {
  make_cache
  damage "$TMP/c.bbc" "$TMP/d.bbc" middle
  render 1 "$TMP/d.bbc" "--write-partial --png $TMP/out.png --no-verify"
  [ -e "$TMP/out.exr" ] || [ -e "$TMP/out.png" ] && fail "an image was written"
  return 0
}

test_every_chunk_is_verified_first() {
  make_cache
  render 0 "$TMP/c.bbc" ""
  damage "$TMP/c.bbc" "$TMP/d.bbc" last
  rm -f "$TMP/out.exr"
  render 1 "$TMP/d.bbc" ""
  [ -e "$TMP/out.exr" ] && fail "an image was written"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "not one line: $(cat "$TMP/err")"
  grep -q "checksum mismatch (R-" "$TMP/err" || fail "message: $(cat "$TMP/err")"
}

# Every bbc-inspect command that reads the cell lists (validate lists every problem, one
# line each, and is tested in test_inspect.sh).
test_inspect_commands_refuse_a_damaged_chunk() {
  make_cache
  damage "$TMP/c.bbc" "$TMP/d.bbc" middle
  for cmd in "dump $TMP/d.bbc --cell 3,3" "heatmap $TMP/d.bbc -o $TMP/out.exr" \
             "check-bounds $SCENE $TMP/d.bbc --samples 5" "solutions $SCENE $TMP/d.bbc" \
             "diff $TMP/c.bbc $TMP/d.bbc"; do
    # shellcheck disable=SC2086
    expect_status 1 "$INSPECT" $cmd
    [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "$cmd: not one line: $(cat "$TMP/err")"
    grep -q "d.bbc: CDAT at byte [0-9]*: chunk 0 checksum mismatch" "$TMP/err" ||
      fail "$cmd: message: $(cat "$TMP/err")"
    [ -e "$TMP/out.exr" ] && fail "$cmd: wrote an image"
  done
  return 0
}

"test_$1"
