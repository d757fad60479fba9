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

# Runs a command with none of the variables --shard auto reads, but those given first
# (NAME=VALUE...), so that a suite run inside a Slurm job is not misled.
sched() {
  env -u SLURM_ARRAY_TASK_ID -u SLURM_ARRAY_TASK_MIN -u SLURM_ARRAY_TASK_MAX \
    -u SLURM_ARRAY_TASK_COUNT -u SLURM_JOB_ID -u JOB_COMPLETION_INDEX -u BBC_SHARD_COUNT "$@"
}

# --shard auto writes the same shard as the explicit I/N, from a Slurm array (whole, or
# a task resubmitted alone with its count), and from a Kubernetes Indexed Job.
test_shard_auto_takes_the_index_from_the_scheduler() {
  for s in 0 1 2; do mirror -o "$TMP/s$s.bbc" --shard "$s/3"; done
  for s in 0 1 2; do
    expect_status 0 sched SLURM_JOB_ID=7 SLURM_ARRAY_TASK_ID=$s SLURM_ARRAY_TASK_MIN=0 \
      SLURM_ARRAY_TASK_MAX=2 SLURM_ARRAY_TASK_COUNT=3 "$PRECOMPUTE" "$MIRROR" --chains R \
      --max-level 4 --resolution 64 --no-progress -o "$TMP/a$s.bbc" --shard auto
    cmp "$TMP/s$s.bbc" "$TMP/a$s.bbc" >&2 || fail "--shard auto as task $s differs from $s/3"
  done
  # Resubmitted alone (sbatch --array=1): the count from BBC_SHARD_COUNT or auto/N.
  for how in "BBC_SHARD_COUNT=3 auto" "BBC_SHARD_COUNT=3 auto/3" "X=1 auto/3"; do
    expect_status 0 sched ${how% *} SLURM_JOB_ID=8 SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MIN=1 \
      SLURM_ARRAY_TASK_MAX=1 SLURM_ARRAY_TASK_COUNT=1 "$PRECOMPUTE" "$MIRROR" --chains R \
      --max-level 4 --resolution 64 --no-progress -o "$TMP/r.bbc" --shard "${how#* }"
    cmp "$TMP/s1.bbc" "$TMP/r.bbc" >&2 || fail "resubmitted task 1 ($how) differs from 1/3"
  done
  expect_status 0 sched JOB_COMPLETION_INDEX=2 "$PRECOMPUTE" "$MIRROR" --chains R --max-level 4 \
    --resolution 64 --no-progress -o "$TMP/k.bbc" --shard auto/3
  cmp "$TMP/s2.bbc" "$TMP/k.bbc" >&2 || fail "JOB_COMPLETION_INDEX=2 differs from 2/3"
  expect_status 0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/a0.bbc" "$TMP/r.bbc" "$TMP/k.bbc"
  mirror -o "$TMP/full.bbc"
  cmp "$TMP/full.bbc" "$TMP/m.bbc" >&2 || fail "the merged cache differs from the unsharded one"
}

# A missing or inconsistent variable is one line naming it, exit 1, and nothing written;
# bad syntax is a usage error.
test_shard_auto_refuses_a_bad_environment() {
  # "@I:MIN:MAX:COUNT" stands for the four SLURM_ARRAY_TASK_ variables.
  while IFS='|' read -r vars option words; do
    case $vars in
      @*)
        # shellcheck disable=SC2046
        set -- $(echo "${vars#@}" | tr ':' ' ')
        vars="SLURM_ARRAY_TASK_ID=$1 SLURM_ARRAY_TASK_MIN=$2 SLURM_ARRAY_TASK_MAX=$3"
        vars="$vars SLURM_ARRAY_TASK_COUNT=$4"
        ;;
    esac
    # shellcheck disable=SC2086
    expect_refusal 1 "^bbc-precompute: --shard auto.*$words" sched $vars "$PRECOMPUTE" \
      "$MIRROR" -o "$TMP/x.bbc" --no-progress --shard "$option"
    no_output "$TMP/x.bbc"
  done <<'CASES'
X=1|auto|neither SLURM_ARRAY_TASK_ID (a Slurm array job) nor JOB_COMPLETION_INDEX
SLURM_JOB_ID=3|auto|SLURM_ARRAY_TASK_ID is not set: this Slurm job is not an array
@5:5:5:1|auto|this array has one task (5), so it cannot tell the shard count
@2:1:3:3|auto|the array's tasks are 1..3, 3 of them
@4:0:4:3|auto|the array's tasks are 0..4, 3 of them
SLURM_ARRAY_TASK_ID=1|auto|SLURM_ARRAY_TASK_COUNT, _MIN or _MAX is not set
SLURM_ARRAY_TASK_ID=4|auto/4|SLURM_ARRAY_TASK_ID is 4, not below the shard count 4
SLURM_ARRAY_TASK_ID=1x|auto/4|SLURM_ARRAY_TASK_ID is '1x', not a whole number
SLURM_ARRAY_TASK_ID=1 BBC_SHARD_COUNT=3|auto/4|BBC_SHARD_COUNT is 3, not 4
SLURM_ARRAY_TASK_ID=1 BBC_SHARD_COUNT=0|auto|BBC_SHARD_COUNT is 0
SLURM_ARRAY_TASK_ID=1 BBC_SHARD_COUNT=|auto|BBC_SHARD_COUNT is '', not a whole number
JOB_COMPLETION_INDEX=2|auto|JOB_COMPLETION_INDEX is 2 but the count is not known
JOB_COMPLETION_INDEX=2|auto/2|JOB_COMPLETION_INDEX is 2, not below the shard count 2
JOB_COMPLETION_INDEX=0 SLURM_ARRAY_TASK_ID=0|auto/2|both SLURM_ARRAY_TASK_ID (0) and JOB_COMPLET
CASES
  for bad in auto/0 auto/ auto/x autox auto/-1 "auto 2"; do
    expect_refusal 2 "^bbc-precompute: --shard: '$bad'" sched SLURM_ARRAY_TASK_ID=0 \
      "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --shard "$bad"
    no_output "$TMP/x.bbc"
  done
  # bbc-render reads the environment the same way.
  expect_refusal 1 "^bbc-render: --shard auto: this array has one task (5)" sched \
    SLURM_ARRAY_TASK_ID=5 SLURM_ARRAY_TASK_MIN=5 SLURM_ARRAY_TASK_MAX=5 \
    SLURM_ARRAY_TASK_COUNT=1 "$RENDER" "$MIRROR" -o "$TMP/x.exr" --shard auto
  no_output "$TMP/x.exr"
}

# The temporary file of a run killed while writing (SIGKILL, a lost node: no chance to
# remove it) is removed by the next run writing the same output; one of a process that
# still runs here, and files of other outputs, are kept.
test_rerun_removes_what_a_killed_writer_left() {
  dead=$(sh -c 'echo $$')
  for f in "x.bbc.tmp.$dead" "x.bbc.tmp.$dead.tmp.$dead" "x.bbc.tmp.$$" "x.bbc.tmp.12a" \
    "y.bbc.tmp.$dead" "x.bbc.tmp."; do
    echo partial >"$TMP/$f"
  done
  mirror -o "$TMP/x.bbc"
  for f in "x.bbc.tmp.$dead" "x.bbc.tmp.$dead.tmp.$dead"; do
    [ -e "$TMP/$f" ] && fail "$f was not removed"
    grep -q "^bbc-precompute: note: removed $TMP/$f, left by a run that was stopped while" \
      "$TMP/err" || fail "no note for $f: $(cat "$TMP/err")"
  done
  for f in "x.bbc.tmp.$$" "x.bbc.tmp.12a" "y.bbc.tmp.$dead" "x.bbc.tmp."; do
    [ -e "$TMP/$f" ] || fail "$f was removed"
  done
  [ "$(wc -l <"$TMP/err")" -eq 2 ] || fail "stderr: $(cat "$TMP/err")"
  # The merge and the render do the same for their outputs.
  mirror -o "$TMP/s0.bbc" --shard 0/1
  echo partial >"$TMP/m.bbc.tmp.$dead"
  expect_status 0 "$INSPECT" merge "$TMP/m.bbc" "$TMP/s0.bbc"
  [ -e "$TMP/m.bbc.tmp.$dead" ] && fail "merge: m.bbc.tmp.$dead was not removed"
  echo partial >"$TMP/i.exr.tmp.$dead.tmp.$dead"
  expect_status 0 "$RENDER" "$MIRROR" -o "$TMP/i.exr" --spp 1 --width 16 --no-progress
  [ -e "$TMP/i.exr.tmp.$dead.tmp.$dead" ] && fail "render: i.exr.tmp.$dead.tmp.$dead is still there"
  return 0
}

# render_shards DIR SHARD ARGS...: renders the orbit scene's images of ARGS into DIR
# (path tracing only, 16 x 12 pixels: quick) as shard SHARD ("" for all).
render_shards() {
  dir=$1 shard=$2
  shift 2
  mkdir -p "$dir"
  expect_status 0 sched "$RENDER" "$BBC_TEST_SCENES/orbit.gltf" -o "$dir/i.exr" --spp 2 \
    --width 16 --height 12 --no-progress ${shard:+--shard "$shard"} "$@"
}

# bbc-render --shard I/N renders the images whose position in the list is I mod N, each
# bit-identical to the same image of the whole list; a task with no image exits 0.
test_render_shard_splits_frames_and_cameras() {
  render_shards "$TMP/all" "" --frames 0:4
  for s in 0 1 2; do
    render_shards "$TMP/s$s" "$s/3" --frames 0:4
    want=$(for f in 0 1 2 3 4; do [ $((f % 3)) -eq "$s" ] && echo "i.000$f.exr"; done)
    [ "$(ls "$TMP/s$s")" = "$want" ] || fail "shard $s/3 wrote $(ls "$TMP/s$s"), not $want"
    for f in $want; do
      cmp "$TMP/all/$f" "$TMP/s$s/$f" >&2 || fail "shard $s/3: $f differs from the whole list's"
    done
  done
  # From the scheduler, with a step in the frames: 0, 2, 4 as positions 0, 1, 2.
  mkdir "$TMP/k"
  expect_status 0 sched JOB_COMPLETION_INDEX=1 "$RENDER" "$BBC_TEST_SCENES/orbit.gltf" \
    -o "$TMP/k/i.exr" --spp 2 --width 16 --height 12 --no-progress --shard auto/2 --frames 0:4:2
  [ "$(ls "$TMP/k")" = i.0002.exr ] || fail "auto/2 as index 1 wrote $(ls "$TMP/k")"
  cmp "$TMP/all/i.0002.exr" "$TMP/k/i.0002.exr" >&2 || fail "frame 2 differs"
  # Cameras: camera 0 then camera 1 ("side").
  render_shards "$TMP/c" 1/2 --all-cameras
  [ "$(ls "$TMP/c")" = i.cam1.exr ] || fail "1/2 of the cameras wrote $(ls "$TMP/c")"
  render_shards "$TMP/call" "" --all-cameras
  cmp "$TMP/call/i.cam1.exr" "$TMP/c/i.cam1.exr" >&2 || fail "camera 1 differs"
  # More tasks than images: nothing to do is no failure.
  render_shards "$TMP/none" 2/3 --all-cameras
  [ -z "$(ls "$TMP/none")" ] || fail "shard 2/3 of 2 images wrote $(ls "$TMP/none")"
  grep -q "^bbc-render: note: shard 2/3: none of the 2 images asked for is this shard's" \
    "$TMP/err" || fail "no note: $(cat "$TMP/err")"
  # The single image of a plain render is shard 0's.
  render_shards "$TMP/one" 0/2
  [ "$(ls "$TMP/one")" = i.exr ] || fail "shard 0/2 of one image wrote $(ls "$TMP/one")"
  ls "$TMP"/*/ | grep -q '\.tmp\.' && fail "a temporary file was left behind"
  return 0
}

# examples/parallel/run.sh on this machine, and through --sshloginfile with ":" (GNU
# parallel's name for this machine, reached the way remote ones are): the cache equals
# the unsharded one and the frames the ones rendered in one process.
test_parallel_example() {
  command -v parallel >/dev/null || fail "GNU parallel is missing (sh scripts/install-deps.sh)"
  "$BBC_BIN/scenes/bbc-scenegen" wavy-mirror --size 100 --orbit 3 --width 24 --height 18 \
    -o "$TMP/scene.gltf" || fail "bbc-scenegen failed"
  echo : >"$TMP/logins"
  PATH="$BBC_BIN/bbc-precompute:$BBC_BIN/bbc-render:$BBC_BIN/bbc-inspect:$PATH"
  export PATH
  expect_status 0 env HOME="$TMP" sh "$BBC_SOURCE_DIR/examples/parallel/run.sh" --shards 3 \
    --tasks 2 --jobs 2 --threads 1 "$TMP/scene.gltf" "$TMP/local" -- --frames 0:2 --spp 2
  expect_status 0 env HOME="$TMP" sh "$BBC_SOURCE_DIR/examples/parallel/run.sh" --shards 3 \
    --tasks 2 --sshloginfile "$TMP/logins" "$TMP/scene.gltf" "$TMP/ssh" -- --frames 0:2 --spp 2
  expect_status 0 "$PRECOMPUTE" "$TMP/scene.gltf" -o "$TMP/one.bbc" --no-progress
  mkdir "$TMP/one"
  expect_status 0 "$RENDER" "$TMP/scene.gltf" --cache "$TMP/one.bbc" -o "$TMP/one/image.exr" \
    --frames 0:2 --spp 2 --no-progress
  for run in local ssh; do
    cmp "$TMP/one.bbc" "$TMP/$run/cache.bbc" >&2 || fail "$run: the cache differs"
    [ "$(ls "$TMP/$run/frames")" = "$(ls "$TMP/one")" ] || fail "$run: $(ls "$TMP/$run/frames")"
    for f in "$TMP"/one/*; do
      cmp "$f" "$TMP/$run/frames/${f##*/}" >&2 || fail "$run: ${f##*/} differs"
    done
  done
  # --resume with every shard there computes none.
  rm "$TMP/local/cache.bbc"
  expect_status 0 env HOME="$TMP" sh "$BBC_SOURCE_DIR/examples/parallel/run.sh" --shards 3 \
    --tasks 2 --resume "$TMP/scene.gltf" "$TMP/local" -- --frames 0:2 --spp 2
  [ "$(wc -l <"$TMP/local/logs/shards.joblog")" -eq 4 ] || fail "--resume ran shards again"
  cmp "$TMP/one.bbc" "$TMP/local/cache.bbc" >&2 || fail "--resume: the cache differs"
}

# Beam receivers (a bent floor, not a plane): two shards merge to the unsharded cache,
# which is format 1.8 (info says beam: the control that the option took) and the same
# on one thread and on two with its entries spilled.
test_beam_receivers_shard_and_thread_alike() {
  bent="$BBC_TEST_SCENES/bent-wavy-mirror-128.gltf"
  beam() { expect_status 0 "$PRECOMPUTE" "$bent" --chains R,RR --max-level 3 --resolution 32 \
    --receivers beam --no-progress "$@"; }
  beam -o "$TMP/full.bbc" --threads 1
  beam -o "$TMP/spilled.bbc" --threads 2 --entry-memory 1
  cmp "$TMP/full.bbc" "$TMP/spilled.bbc" >&2 || fail "threads or spill changed the beam cache"
  beam -o "$TMP/s0.bbc" --shard 0/2
  beam -o "$TMP/s1.bbc" --shard 1/2
  expect_status 0 "$INSPECT" merge "$TMP/merged.bbc" "$TMP/s1.bbc" "$TMP/s0.bbc" --no-progress
  cmp "$TMP/full.bbc" "$TMP/merged.bbc" >&2 || fail "merged beam cache differs from the whole one"
  expect_status 0 "$INSPECT" info "$TMP/merged.bbc"
  grep -q "^format       1.8" "$TMP/out" || fail "not format 1.8: $(cat "$TMP/out")"
  grep -q "^receivers    beam" "$TMP/out" || fail "info does not say beam: $(cat "$TMP/out")"
}

"test_$1"
