#!/bin/sh
# Sharded precomputes: bbc-precompute --shard I/N and bbc-inspect merge. The merged
# cache must be byte-identical to the unsharded one (the oracle is the unsharded
# precompute itself, an independent code path: no SHRD, no renumbering), and every
# refusal must exit non-zero with one line and leave no output behind. Each test_<name>
# function is one ctest entry.
set -u
PRECOMPUTE="$BBC_BIN/bbc-precompute/bbc-precompute"
INSPECT="$BBC_BIN/bbc-inspect/bbc-inspect"
RENDER="$BBC_BIN/bbc-render/bbc-render"
MIRROR="$BBC_TEST_SCENES/flat-mirror.gltf"
POOL="$BBC_TEST_SCENES/pool.glb"
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

# The explicit chains keep the tests independent of the default chain list.
mirror() { expect_status 0 "$PRECOMPUTE" "$MIRROR" --chains R --max-level 4 --resolution 64 \
  --no-progress "$@"; }
pool() { expect_status 0 "$PRECOMPUTE" "$POOL" --chains R,T --max-level 3 --resolution 128 \
  --no-progress "$@"; }

# expect_refusal CODE WORDS COMMAND...: exits CODE, the first line of stderr names the
# problem (grep pattern WORDS); for code 1 that line is all of stderr.
expect_refusal() {
  want=$1; words=$2; shift 2
  expect_status "$want" "$@"
  head -n 1 "$TMP/err" | grep -q -- "$words" || fail "$*: message: $(cat "$TMP/err")"
  if [ "$want" -eq 1 ]; then
    [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "$*: more than one line: $(cat "$TMP/err")"
  fi
  [ -s "$TMP/out" ] && fail "$*: wrote to stdout"
  return 0
}

# no_output FILE: neither FILE nor a temporary file next to it exists.
no_output() {
  [ -e "$1" ] && fail "$1 was written"
  ls "$TMP" | grep -q '\.tmp\.' && fail "a temporary file was left behind: $(ls "$TMP")"
  return 0
}

test_help_documents_shard_and_merge() {
  expect_status 0 "$PRECOMPUTE" --help
  grep -q -- "--shard I/N" "$TMP/out" || fail "bbc-precompute --help lacks --shard"
  expect_status 0 "$INSPECT" --help
  grep -q "merge OUT.bbc SHARD.bbc" "$TMP/out" || fail "bbc-inspect --help lacks merge"
  expect_status 0 "$RENDER" --help
  grep -q "shard" "$TMP/out" || fail "bbc-render --help does not say it refuses shards"
}

test_three_shards_merge_to_the_unsharded_cache() {
  pool -o "$TMP/full.bbc"
  pool -o "$TMP/s0.bbc" --shard 0/3
  pool -o "$TMP/s1.bbc" --shard 1/3 --threads 1
  pool -o "$TMP/s2.bbc" --shard=2/3
  for s in 0 1 2; do
    expect_status 0 "$INSPECT" validate "$TMP/s$s.bbc"
    grep -q "valid (format 1.6, shard $s/3," "$TMP/out" || fail "validate: $(cat "$TMP/out")"
    expect_status 0 "$INSPECT" info "$TMP/s$s.bbc"
    grep -q "^shard        $s/3 of a sharded precompute" "$TMP/out" || fail "info lacks the shard"
    grep -q "SHRD  optional" "$TMP/out" || fail "info lacks the SHRD section"
  done
  # Any order of the shards.
  expect_status 0 "$INSPECT" merge "$TMP/merged.bbc" "$TMP/s2.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  [ -s "$TMP/out" ] && fail "merge wrote to stdout"
  [ -s "$TMP/err" ] && fail "merge wrote to stderr: $(cat "$TMP/err")"
  cmp "$TMP/full.bbc" "$TMP/merged.bbc" >&2 || fail "merged cache differs from the unsharded one"
  expect_status 0 "$INSPECT" validate "$TMP/merged.bbc"
  grep -q "valid (format 1.6, [0-9]* tuples" "$TMP/out" || fail "validate: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" info "$TMP/merged.bbc"
  grep -q "SHRD" "$TMP/out" && fail "the merged cache has a SHRD section"
  # The shards hold every stored tuple once.
  total=0
  for s in 0 1 2; do
    n=$("$INSPECT" info "$TMP/s$s.bbc" | sed -n 's/^tuples  *\([0-9]*\).*/\1/p')
    total=$((total + n))
  done
  full=$("$INSPECT" info "$TMP/full.bbc" | sed -n 's/^tuples  *\([0-9]*\).*/\1/p')
  [ "$total" -eq "$full" ] || fail "shards hold $total tuples, the full cache $full"
  ls "$TMP" | grep -q '\.tmp\.' && fail "a temporary file was left behind"
  return 0
}

# Without GEOM the files are the versions that need nothing newer (1.6 here, for the
# floor is a receiver plane), and the merge is still the unsharded cache byte for byte.
test_shards_without_geometry() {
  pool -o "$TMP/full.bbc" --no-geometry
  pool -o "$TMP/s0.bbc" --shard 0/2 --no-geometry
  pool -o "$TMP/s1.bbc" --shard 1/2 --no-geometry
  expect_status 0 "$INSPECT" validate "$TMP/s1.bbc"
  grep -q "valid (format 1.6, shard 1/2," "$TMP/out" || fail "validate: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" merge "$TMP/merged.bbc" "$TMP/s1.bbc" "$TMP/s0.bbc"
  cmp "$TMP/full.bbc" "$TMP/merged.bbc" >&2 || fail "merged cache differs from the unsharded one"
  expect_status 0 "$INSPECT" info "$TMP/merged.bbc"
  grep -q "^format       1.6 " "$TMP/out" || fail "info: $(cat "$TMP/out")"
  grep -q "GEOM" "$TMP/out" && fail "a cache written with --no-geometry has GEOM"
  return 0
}

test_one_shard_merges_to_the_unsharded_cache() {
  mirror -o "$TMP/full.bbc"
  mirror -o "$TMP/s0.bbc" --shard 0/1
  cmp -s "$TMP/full.bbc" "$TMP/s0.bbc" && fail "a shard cache is the unsharded one"
  expect_status 0 "$INSPECT" validate "$TMP/s0.bbc"
  expect_status 0 "$INSPECT" merge "$TMP/merged.bbc" "$TMP/s0.bbc" --threads 1
  cmp "$TMP/full.bbc" "$TMP/merged.bbc" >&2 || fail "merged cache differs from the unsharded one"
}

test_more_shards_than_tuples() {
  mirror -o "$TMP/full.bbc"
  n=20
  candidates=$("$PRECOMPUTE" "$MIRROR" --chains R --max-level 4 --resolution 64 --no-progress \
    -o "$TMP/probe.bbc" --stats 2>&1 | sed -n 's/^tuples .* stored of \([0-9]*\) candidates.*/\1/p')
  [ -n "$candidates" ] && [ "$candidates" -lt "$n" ] ||
    fail "the scene has ${candidates:-?} candidates, not fewer than $n shards"
  shards=""
  i=0
  while [ $i -lt $n ]; do
    mirror -o "$TMP/s$i.bbc" --shard $i/$n
    shards="$shards $TMP/s$i.bbc"
    i=$((i + 1))
  done
  # The last shards bound no candidate at all, and are still valid caches.
  expect_status 0 "$INSPECT" validate "$TMP/s19.bbc"
  grep -q "shard 19/20, 0 tuples" "$TMP/out" || fail "shard 19 is not empty: $(cat "$TMP/out")"
  expect_status 0 "$INSPECT" merge "$TMP/merged.bbc" $shards
  cmp "$TMP/full.bbc" "$TMP/merged.bbc" >&2 || fail "merged cache differs from the unsharded one"
}

test_bad_shard_syntax_exits_2() {
  for bad in 3/3 0/0 a/b 1 1/ /2 -1/2 1/2x " 1/2" 1//2 4294967296/4294967297 ""; do
    expect_refusal 2 "^bbc-precompute: --shard" "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" \
      --shard "$bad"
    no_output "$TMP/x.bbc"
  done
  expect_refusal 2 "^bbc-precompute: --shard needs a value" "$PRECOMPUTE" "$MIRROR" \
    -o "$TMP/x.bbc" --shard
  no_output "$TMP/x.bbc"
}

# Shards 0/3 and 1/3 of the mirror, for the refusals below.
two_of_three() {
  mirror -o "$TMP/s0.bbc" --shard 0/3
  mirror -o "$TMP/s1.bbc" --shard 1/3
}

test_merge_refuses_a_missing_shard() {
  two_of_three
  expect_refusal 1 "shard 2/3 is missing" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    "$TMP/s1.bbc"
  no_output "$TMP/m.bbc"
  expect_refusal 1 "shard 0/3 is missing" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s1.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_a_duplicate_shard() {
  two_of_three
  mirror -o "$TMP/s2.bbc" --shard 2/3
  cp "$TMP/s1.bbc" "$TMP/again.bbc"
  expect_refusal 1 "are both shard 1/3" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    "$TMP/s1.bbc" "$TMP/s2.bbc" "$TMP/again.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_shards_of_another_scene() {
  two_of_three
  expect_status 0 "$PRECOMPUTE" "$POOL" --chains R --max-level 4 --resolution 64 --no-progress \
    -o "$TMP/p2.bbc" --shard 2/3
  expect_refusal 1 "computed for different scenes" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    "$TMP/s1.bbc" "$TMP/p2.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_shards_of_other_parameters() {
  two_of_three
  mirror -o "$TMP/s2.bbc" --shard 2/3 --sigma 0.001
  expect_refusal 1 "computed with other parameters" "$INSPECT" merge "$TMP/m.bbc" \
    "$TMP/s0.bbc" "$TMP/s1.bbc" "$TMP/s2.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_shards_of_different_splits() {
  two_of_three
  mirror -o "$TMP/h1.bbc" --shard 1/2
  expect_refusal 1 "shards of different splits" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    "$TMP/h1.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_a_cache_that_is_not_a_shard() {
  two_of_three
  mirror -o "$TMP/full.bbc"
  expect_refusal 1 "full.bbc: not a shard cache" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    "$TMP/s1.bbc" "$TMP/full.bbc"
  no_output "$TMP/m.bbc"
  printf 'not a cache' > "$TMP/junk.bbc"
  expect_refusal 1 "junk.bbc" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/junk.bbc"
  no_output "$TMP/m.bbc"
  expect_refusal 1 "none.bbc" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/none.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_refuses_a_damaged_shard() {
  two_of_three
  mirror -o "$TMP/s2.bbc" --shard 2/3
  # One byte of shard 1's chunk data: opening does not read it, merging decodes it.
  offset=$("$INSPECT" info "$TMP/s1.bbc" | sed -n 's/^  CDAT .* offset *\([0-9]*\) .*/\1/p')
  [ -n "$offset" ] || fail "no CDAT in shard 1"
  printf 'Z' | dd of="$TMP/s1.bbc" bs=1 seek=$((offset + 8)) conv=notrunc 2>/dev/null
  expect_refusal 1 "s1.bbc: CDAT at byte .*checksum" "$INSPECT" merge "$TMP/m.bbc" \
    "$TMP/s0.bbc" "$TMP/s1.bbc" "$TMP/s2.bbc"
  no_output "$TMP/m.bbc"
}

test_merge_keeps_an_existing_output_on_failure() {
  two_of_three
  printf 'precious' > "$TMP/m.bbc"
  expect_status 1 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  [ "$(cat "$TMP/m.bbc")" = precious ] || fail "the existing output was touched"
  ls "$TMP" | grep -q '\.tmp\.' && fail "a temporary file was left behind"
  return 0
}

# A disk too small for the merged cache: refused before merging, with the estimate
# (the shards' cell index alone is 12 bytes per cell: 49,152 bytes at 64 x 64), one line,
# no output. The shim (tests/tools/full_disk_shim.c) makes statvfs report 1000 free bytes.
test_merge_refuses_a_disk_too_small_up_front() {
  mirror -o "$TMP/s0.bbc" --shard 0/2
  mirror -o "$TMP/s1.bbc" --shard 1/2
  expect_refusal 1 "m.bbc: the merged cache will take about .* and its file system has 1000 bytes free" \
    env LD_PRELOAD="$BBC_BIN/tests/libfull_disk_shim.so" BBC_DISK_FREE=1000 \
    ASAN_OPTIONS=verify_asan_link_order=0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  no_output "$TMP/m.bbc"
  # The estimate is within a factor of two of the file a merge writes: refused with
  # room for half of it, merged with room for twice it.
  expect_status 0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  size=$(wc -c < "$TMP/m.bbc")
  rm -f "$TMP/m.bbc"
  expect_refusal 1 "m.bbc: the merged cache will take about" env \
    LD_PRELOAD="$BBC_BIN/tests/libfull_disk_shim.so" BBC_DISK_FREE=$((size / 2)) \
    ASAN_OPTIONS=verify_asan_link_order=0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  no_output "$TMP/m.bbc"
  expect_status 0 env LD_PRELOAD="$BBC_BIN/tests/libfull_disk_shim.so" BBC_DISK_FREE=$((2 * size)) \
    ASAN_OPTIONS=verify_asan_link_order=0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" "$TMP/s1.bbc"
  [ -s "$TMP/m.bbc" ] || fail "control: no merged cache"
}

test_merge_bad_usage_exits_2() {
  two_of_three
  expect_refusal 2 "^bbc-inspect: merge needs OUT.bbc" "$INSPECT" merge
  expect_refusal 2 "^bbc-inspect: merge needs OUT.bbc" "$INSPECT" merge "$TMP/m.bbc"
  expect_refusal 2 "^bbc-inspect: unknown option '--frobnicate'" "$INSPECT" merge "$TMP/m.bbc" \
    "$TMP/s0.bbc" --frobnicate
  expect_refusal 2 "is also given as a shard" "$INSPECT" merge "$TMP/s0.bbc" "$TMP/s0.bbc" \
    "$TMP/s1.bbc"
  expect_refusal 2 "^bbc-inspect: --threads" "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc" \
    --threads 0
  no_output "$TMP/m.bbc"
}

test_render_refuses_a_shard() {
  mirror -o "$TMP/s0.bbc" --shard 0/2
  expect_refusal 1 "s0.bbc: shard 0/2 of a sharded precompute" "$RENDER" "$MIRROR" \
    --cache "$TMP/s0.bbc" -o "$TMP/x.exr" --spp 1 --width 16
  no_output "$TMP/x.exr"
}

"test_$1"
