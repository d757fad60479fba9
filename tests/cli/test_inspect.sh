#!/bin/sh
# Command-line behaviour of bbc-inspect: help, usage errors (exit 2), bad files (exit 1,
# one line naming the file) and the four commands on a cache written by the test tool
# bbc-test-cache. Each test_<name> function is one ctest entry.
set -u
INSPECT="$BBC_BIN/bbc-inspect/bbc-inspect"
MAKE_CACHE="$BBC_BIN/tests/bbc-test-cache"
SCENE="$BBC_TEST_SCENES/pool.gltf"
INVALID="$BBC_SOURCE_DIR/tests/corpus/invalid"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

make_cache() {
  "$MAKE_CACHE" synthetic "$SCENE" "$TMP/c.bbc" 32 || fail "cannot write a test cache"
}

test_help_documents_every_command_and_flag() {
  expect_status 0 "$INSPECT" --help
  for word in usage info validate dump heatmap --cell --receiver -o --output --log10 \
              --help --version; do
    grep -q -- "$word" "$TMP/out" || fail "--help does not mention $word"
  done
  [ -s "$TMP/err" ] && fail "--help wrote to stderr"
  expect_status 0 "$INSPECT" -h
  expect_status 0 "$INSPECT" info -h
  return 0
}

test_version() {
  expect_status 0 "$INSPECT" --version
  grep -q "^bbc-inspect " "$TMP/out" || fail "no version line"
  grep -q "format 1" "$TMP/out" || fail "no format version"
}

test_bad_usage_exits_2() {
  make_cache
  expect_status 2 "$INSPECT"
  grep -q "^bbc-inspect: missing command" "$TMP/err" || fail "message: $(cat "$TMP/err")"
  grep -q "usage:" "$TMP/err" || fail "no usage"
  expect_status 2 "$INSPECT" frobnicate "$TMP/c.bbc"
  grep -q "^bbc-inspect: unknown command 'frobnicate'" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$INSPECT" info
  expect_status 2 "$INSPECT" info "$TMP/c.bbc" extra
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc"
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc" --cell 3
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc" --cell 3,4x
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc" --cell 32,0
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc" --cell 1,1 --receiver 1
  expect_status 2 "$INSPECT" dump "$TMP/c.bbc" --cell 1,1 --bogus
  grep -q "^bbc-inspect: unknown option '--bogus'" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$INSPECT" heatmap "$TMP/c.bbc"
  expect_status 2 "$INSPECT" heatmap "$TMP/c.bbc" -o
  [ -e "$TMP/x.exr" ] && fail "an output was written"
  return 0
}

test_bad_files_exit_1_with_one_line() {
  expect_status 1 "$INSPECT" info "$TMP/none.bbc"
  grep -q "none.bbc" "$TMP/err" || fail "message does not name the file"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  for f in "$INVALID"/not_bbc--wrong-magic.bbc "$INVALID"/truncated--cut-at-100.bbc \
           "$INVALID"/version_unsupported--major-version-2.bbc \
           "$INVALID"/corrupt--overlapping-sections.bbc \
           "$INVALID"/checksum--flipped-byte-in-TUPL.bbc; do
    for cmd in info validate; do
      expect_status 1 "$INSPECT" $cmd "$f"
      grep -q "$(basename "$f")" "$TMP/err" || fail "$cmd $f: message does not name the file"
      [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "$cmd $f: more than one line"
      [ -s "$TMP/out" ] && fail "$cmd $f: wrote to stdout"
    done
  done
  return 0
}

test_validate_every_invalid_corpus_file() {
  n=0
  for f in "$INVALID"/*.bbc; do
    expect_status 1 "$INSPECT" validate "$f"
    grep -q "R-[A-Z]*-[0-9]" "$TMP/err" || fail "$f: no requirement ID: $(cat "$TMP/err")"
    n=$((n + 1))
  done
  [ "$n" -gt 60 ] || fail "only $n corpus files"
}

test_validate_reports_one_line_per_problem() {
  make_cache
  # Damage two chunks: the CDAT checksum and both chunks are reported, one line each.
  python3 - "$TMP/c.bbc" <<'PY' || fail "cannot damage the file"
import struct, sys
path = sys.argv[1]
b = bytearray(open(path, "rb").read())
n = struct.unpack_from("<I", b, 12)[0]
secs = {}
for i in range(n):
    t, f, off, size = struct.unpack_from("<4sIQQ", b, 64 + 32 * i)
    secs[t] = (off, size)
cdat, chnk = secs[b"CDAT"][0], secs[b"CHNK"][0]
for k in (0, 1):
    b[cdat + struct.unpack_from("<Q", b, chnk + 24 * k)[0] + 5] ^= 0xFF
open(path, "wb").write(b)
PY
  expect_status 1 "$INSPECT" validate "$TMP/c.bbc"
  [ "$(wc -l < "$TMP/err")" -eq 3 ] || fail "expected 3 lines: $(cat "$TMP/err")"
  grep -q "chunk 0 checksum" "$TMP/err" || fail "chunk 0 not reported"
  grep -q "chunk 1 checksum" "$TMP/err" || fail "chunk 1 not reported"
}

test_info_and_validate() {
  make_cache
  expect_status 0 "$INSPECT" info "$TMP/c.bbc"
  for word in "format       1.9" "CDAT" "CHNK" "GEOM  optional" "crc32 0x" "chains R,T,RR,RT,TR,TT" \
              "two bounces  max_level 3" "fingerprint" "tuples       " "plane, 32 x 32 cells" "ratio"; do
    grep -q -- "$word" "$TMP/out" || fail "info does not show '$word': $(cat "$TMP/out")"
  done
  [ -s "$TMP/err" ] && fail "info wrote to stderr"
  expect_status 0 "$INSPECT" validate "$TMP/c.bbc"
  grep -q "c.bbc: valid" "$TMP/out" || fail "no summary"
  [ -s "$TMP/err" ] && fail "validate wrote to stderr"
  return 0
}

test_dump_lists_a_cell() {
  make_cache
  expect_status 0 "$INSPECT" dump "$TMP/c.bbc" --cell 5,7
  grep -q "^# receiver 0, cell 5,7: [0-9]* entries" "$TMP/out" || fail "$(head -2 "$TMP/out")"
  # Data lines: id, chain, light, T1, T2 or -, receiver, bound; ids increase.
  awk '!/^#/ { if (NF != 7) exit 1; if (NR > 3 && $1 <= prev) exit 1; prev = $1 }' \
    "$TMP/out" || fail "malformed or unsorted lines"
  grep -q " R 0 [0-9]* - " "$TMP/out" || fail "no one-bounce tuple"
  expect_status 0 "$INSPECT" dump "$TMP/c.bbc" --cell=0,0 --receiver=0
}

test_heatmap_writes_exr() {
  make_cache
  expect_status 0 "$INSPECT" heatmap "$TMP/c.bbc" -o "$TMP/h.exr"
  head -c 4 "$TMP/h.exr" | od -An -tx1 | grep -q "76 2f 31 01" || fail "not an EXR"
  expect_status 0 "$INSPECT" heatmap "$TMP/c.bbc" --output="$TMP/l.exr" --log10 --receiver 0
  [ -s "$TMP/l.exr" ] || fail "no log10 EXR"
  ls "$TMP" | grep -q tmp && fail "a temporary file was left behind"
  expect_status 1 "$INSPECT" heatmap "$TMP/c.bbc" -o "$TMP/no/such/dir/h.exr"
  grep -q "h.exr" "$TMP/err" || fail "message does not name the output"
  return 0
}

# precompute SCENE OUT [OPTIONS...]: a small cache of a test scene by bbc-precompute.
precompute() {
  scene=$1; out=$2; shift 2
  "$BBC_BIN/bbc-precompute/bbc-precompute" "$BBC_TEST_SCENES/$scene" -o "$out" --max-level 4 --chains R,T \
    "$@" >/dev/null 2>"$TMP/precompute.err" || { cat "$TMP/precompute.err" >&2; fail "cannot precompute $scene"; }
}

test_check_bounds_two_mirrors_rr_has_no_violations() {
  precompute two-mirrors.gltf "$TMP/rr.bbc" --chains RR
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/two-mirrors.gltf" "$TMP/rr.bbc" \
    --samples 400
  grep -q "^RR: .*(0 failing paths)" "$TMP/out" || fail "no clean RR summary: $(cat "$TMP/out")"
  grep -q "^RR: .* [1-9][0-9]* admissible paths" "$TMP/out" || fail "no admissible RR path"
}

test_check_bounds_flat_mirror_has_no_violations() {
  precompute flat-mirror.gltf "$TMP/fm.bbc"
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/flat-mirror.gltf" "$TMP/fm.bbc" \
    --samples 50 --json "$TMP/fm.json"
  grep -q "^R: .*(0 failing paths)" "$TMP/out" || fail "no clean R summary: $(cat "$TMP/out")"
  grep -q "^R: .* [1-9][0-9]* admissible paths" "$TMP/out" || fail "no admissible R path"
  grep -q "^T: " "$TMP/out" || fail "no T summary"
  grep -q "log10(E_hi / E)" "$TMP/out" || fail "no histogram"
  grep -q "first failure" "$TMP/out" && fail "a failure was printed"
  python3 - "$TMP/fm.json" <<'PY' || fail "bad JSON: $(cat "$TMP/fm.json")"
import json, sys
d = json.load(open(sys.argv[1]))
assert set(d) == {"R", "T", "RR", "RT", "TR", "TT"}, d.keys()
assert d["R"]["admissible"] > 0 and d["R"]["failing"] == 0, d["R"]
PY
  ls "$TMP" | grep -q "\.tmp" && fail "a temporary file was left behind"
  return 0
}

test_check_bounds_pool_has_no_violations_and_ignores_threads() {
  precompute pool.glb "$TMP/pool.bbc"
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/pool.glb" "$TMP/pool.bbc" \
    --samples 60 --threads 1
  cp "$TMP/out" "$TMP/one.txt"
  grep -q "^T: .* [1-9][0-9]* admissible paths.*(0 failing paths)" "$TMP/out" \
    || fail "no clean T summary: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" check-bounds "$BBC_TEST_SCENES/pool.glb" "$TMP/pool.bbc" \
    --samples=60 --threads=3
  cmp -s "$TMP/one.txt" "$TMP/out" || fail "the output depends on the thread count"
  # Without remainder variables the bounds may break; the check runs either way.
  precompute pool.glb "$TMP/nr.bbc" --no-remainder
  "$INSPECT" check-bounds "$BBC_TEST_SCENES/pool.glb" "$TMP/nr.bbc" --samples 20 \
    >"$TMP/out" 2>"$TMP/err"
  got=$?
  [ "$got" -eq 0 ] || [ "$got" -eq 1 ] || fail "--no-remainder cache: exit $got"
  grep -q "^T: " "$TMP/out" || fail "--no-remainder cache: no T summary"
  return 0
}

test_check_bounds_refuses_another_scene() {
  precompute flat-mirror.gltf "$TMP/fm.bbc"
  expect_status 1 "$INSPECT" check-bounds "$BBC_TEST_SCENES/pool.glb" "$TMP/fm.bbc"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "not one line: $(cat "$TMP/err")"
  grep -q "fm.bbc" "$TMP/err" || fail "message does not name the cache"
  [ -s "$TMP/out" ] && fail "wrote to stdout"
  return 0
}

test_solutions_prints_a_histogram() {
  precompute pool.glb "$TMP/pool.bbc"
  expect_status 0 "$INSPECT" solutions "$BBC_TEST_SCENES/pool.glb" "$TMP/pool.bbc" --samples 32
  for row in 0 1 2 3 4+; do
    grep -q "^$row  *[0-9][0-9]*  *[0-9.]*%" "$TMP/out" || fail "no row $row: $(cat "$TMP/out")"
  done
  grep -q "^more than m = 1: [0-9]* of [1-9][0-9]* pairs" "$TMP/out" || fail "no share above m"
  cp "$TMP/out" "$TMP/one.txt"
  expect_status 0 "$INSPECT" solutions "$BBC_TEST_SCENES/pool.glb" "$TMP/pool.bbc" --samples 32 \
    --threads 2
  cmp -s "$TMP/one.txt" "$TMP/out" || fail "the output depends on the thread count"
  return 0
}

test_diff_of_caches() {
  precompute flat-mirror.gltf "$TMP/a.bbc"
  precompute flat-mirror.gltf "$TMP/b.bbc"
  expect_status 0 "$INSPECT" diff "$TMP/a.bbc" "$TMP/b.bbc"
  [ -s "$TMP/out" ] && fail "identical caches: output $(cat "$TMP/out")"
  "$BBC_BIN/bbc-precompute/bbc-precompute" "$BBC_TEST_SCENES/flat-mirror.gltf" -o "$TMP/c.bbc" \
    --max-level 3 >/dev/null 2>&1 || fail "cannot precompute"
  expect_status 1 "$INSPECT" diff "$TMP/a.bbc" "$TMP/c.bbc"
  grep -q "max_level: 4 | 3" "$TMP/out" || fail "max_level not named: $(cat "$TMP/out")"
  grep -q "fingerprint.params" "$TMP/out" || fail "fingerprint not named"
  precompute pool.glb "$TMP/p.bbc"
  expect_status 1 "$INSPECT" diff "$TMP/a.bbc" "$TMP/p.bbc"
  grep -q "^tuples: " "$TMP/out" || fail "tuple counts not compared: $(cat "$TMP/out")"
  expect_status 1 "$INSPECT" diff "$TMP/a.bbc" "$TMP/none.bbc"
  grep -q "none.bbc" "$TMP/err" || fail "message does not name the file"
  return 0
}

test_new_commands_bad_usage_exits_2() {
  precompute flat-mirror.gltf "$TMP/a.bbc"
  S="$BBC_TEST_SCENES/flat-mirror.gltf"
  expect_status 2 "$INSPECT" check-bounds "$S"
  grep -q "^bbc-inspect: check-bounds needs SCENE.gltf CACHE.bbc" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$INSPECT" check-bounds "$S" "$TMP/a.bbc" --samples 0
  expect_status 2 "$INSPECT" check-bounds "$S" "$TMP/a.bbc" --samples 10x
  expect_status 2 "$INSPECT" check-bounds "$S" "$TMP/a.bbc" --threads 0
  expect_status 2 "$INSPECT" check-bounds "$S" "$TMP/a.bbc" --json
  expect_status 2 "$INSPECT" check-bounds "$S" "$TMP/a.bbc" --bogus
  grep -q "^bbc-inspect: unknown option '--bogus'" "$TMP/err" || fail "$(cat "$TMP/err")"
  expect_status 2 "$INSPECT" solutions "$S"
  expect_status 2 "$INSPECT" solutions "$S" "$TMP/a.bbc" --samples -1
  # The cache before the scene: said so, not a glTF parse error.
  for cmd in check-bounds solutions; do
    expect_status 2 "$INSPECT" $cmd "$TMP/a.bbc" "$S"
    grep -q "^bbc-inspect: $cmd needs SCENE.gltf CACHE.bbc: $TMP/a.bbc is a cache (swapped?)" \
      "$TMP/err" || fail "$(cat "$TMP/err")"
  done
  expect_status 2 "$INSPECT" diff "$TMP/a.bbc"
  expect_status 2 "$INSPECT" diff "$TMP/a.bbc" "$TMP/a.bbc" extra
  grep -q "usage:" "$TMP/err" || fail "no usage"
  expect_status 0 "$INSPECT" --help
  for word in check-bounds solutions diff --samples --json --threads; do
    grep -q -- "$word" "$TMP/out" || fail "--help does not mention $word"
  done
  expect_status 0 "$INSPECT" diff --help
  return 0
}

"test_$1"
