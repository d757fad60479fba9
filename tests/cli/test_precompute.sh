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
  python3 "$BBC_SOURCE_DIR/tests/cli/edge_scene.py" "$TMP/d.gltf" point ||
    fail "cannot write the scene"
  expect_status 0 "$PRECOMPUTE" "$TMP/d.gltf" -o "$TMP/d.bbc" --chains R --max-level 4 \
    --resolution 64 --no-progress
  expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$TMP/d.bbc"
  grep -q "1: mesh 2, box, 1 x 1 cells" "$TMP/out" || fail "no 1 x 1 receiver: $(cat "$TMP/out")"
  expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" validate "$TMP/d.bbc"
}

# --receivers auto (the default) takes beam receivers when the receivers that are not
# planes hold 1000 triangles or more: a bent floor of about 1,200 triangles gets beams,
# one of 512 and the same large floor with --receivers per-triangle do not.
test_receivers_auto_follows_the_curved_triangles() {
  expect_status 0 "$BBC_BIN/scenes/bbc-scenegen" wavy-mirror --size 200 --floor-size 1200 \
    --floor-bend 0.2 -o "$TMP/big.gltf"
  small="$BBC_TEST_SCENES/bent-wavy-mirror-512.gltf"
  run() { expect_status 0 "$PRECOMPUTE" "$@" --chains R --max-level 3 --resolution 32 \
    --no-progress; }
  receivers() { expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$1"
    grep -c "^receivers    beam" "$TMP/out"; }
  run "$TMP/big.gltf" -o "$TMP/big.bbc"
  grep -q "receivers: beam (1[0-9][0-9][0-9] receiver triangles not on a plane" "$TMP/err" ||
    fail "auto did not say it took beams: $(cat "$TMP/err")"
  [ "$(receivers "$TMP/big.bbc")" = 1 ] || fail "the large bent floor has no beam tuples"
  run "$small" -o "$TMP/small.bbc"
  grep -q "receivers: beam" "$TMP/err" && fail "auto took beams for 512 triangles"
  [ "$(receivers "$TMP/small.bbc")" = 0 ] || fail "the 512-triangle floor has beam tuples"
  run "$TMP/big.gltf" -o "$TMP/pt.bbc" --receivers per-triangle
  [ "$(receivers "$TMP/pt.bbc")" = 0 ] || fail "--receivers per-triangle gave beams"
}

# Two-bounce tuples stop at level 3 unless told: --max-level2 sets their level alone,
# --max-level N every tuple's. The bounder's piece counts show which level it used, and
# bbc-inspect info the level stored.
test_two_bounce_tuples_have_their_own_level() {
  ball="$BBC_TEST_SCENES/ball80.gltf"
  pieces() { name=$1; shift
    expect_status 0 "$PRECOMPUTE" "$ball" -o "$TMP/$name.bbc" --chains TT --resolution 32 \
      --stats --no-progress "$@"
    grep "^pieces per tuple" "$TMP/err" > "$TMP/$name.pieces" ||
      fail "no piece counts: $(cat "$TMP/err")"; }
  two_bounce_line() { expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$TMP/$1.bbc"
    grep "^two bounces" "$TMP/out"; }
  pieces default
  pieces l3 --max-level 3
  pieces d1 --max-level2 1
  pieces l1 --max-level 1
  cmp -s "$TMP/default.pieces" "$TMP/l3.pieces" || fail "default: not level 3"
  cmp -s "$TMP/d1.pieces" "$TMP/l1.pieces" || fail "--max-level2 1: not level 1"
  cmp -s "$TMP/d1.pieces" "$TMP/default.pieces" && fail "level 1 bounded as level 3"
  [ "$(two_bounce_line default)" = "two bounces  max_level 3 (point, spot and sun lights)" ] ||
    fail "info: $(cat "$TMP/out")"
  [ "$(two_bounce_line d1)" = "two bounces  max_level 1 (point, spot and sun lights)" ] ||
    fail "info: $(cat "$TMP/out")"
  [ -z "$(two_bounce_line l3)" ] || fail "--max-level 3 stored a level of its own"
}

test_help_documents_every_flag() {
  expect_status 0 "$PRECOMPUTE" --help
  for flag in --output --stats --json --chains --max-level --max-level2 --sigma --alpha --alpha2 --alpha-area --m --resolution \
              --no-remainder --jacobian --threads --memory --entry-memory --progress --no-progress \
              --version --help --allow-empty --light-units --dry-run --ignore-estimate \
              --receivers --double-budget; do
    grep -q -- "$flag" "$TMP/out" || fail "--help does not mention $flag"
  done
}

test_bad_usage_exits_2() {
  expect_status 2 "$PRECOMPUTE" "$MIRROR"
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --chains X
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --alpha2 0.5
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --alpha-area nan
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --alpha-area 50
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --sigma abc
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --max-level 99
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --max-level2 0
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --resolution 0
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --frobnicate
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --receivers beams
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

# Without --chains, the two-bounce chain types over --double-budget are left out, said in
# one line, and the cache is then the one --chains names; an explicit --chains is never
# trimmed. A cache left with no tuple is written (light tracing renders the caustic).
test_default_leaves_costly_double_chains_out() {
  scene="$BBC_TEST_SCENES/mirror-pool.gltf"
  opts="--max-level 3 --resolution 64 --no-progress"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/auto.bbc" $opts --double-budget 0 \
    --json "$TMP/a.json"
  grep -q "^bbc-precompute: chains: RR, RT, TR, TT left to bbc-render's light tracing" "$TMP/err" ||
    fail "no line says what was left out: $(cat "$TMP/err")"
  grep -q '"chains_left_out": {"RR"' "$TMP/a.json" || fail "JSON: $(grep left_out "$TMP/a.json")"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/rt.bbc" $opts --chains R,T --double-budget 0
  grep -q "chains:" "$TMP/err" && fail "--chains was trimmed: $(cat "$TMP/err")"
  cmp -s "$TMP/auto.bbc" "$TMP/rt.bbc" || fail "the default's cache is not that of --chains R,T"
  # The default budget keeps every chain type of this small scene.
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/all.bbc" $opts
  grep -q "chains:" "$TMP/err" && fail "a chain type was left out: $(cat "$TMP/err")"
  expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$TMP/all.bbc"
  grep -q "chains R,T,RR,RT,TR,TT" "$TMP/out" || fail "$(grep chains "$TMP/out")"
  expect_status 0 "$PRECOMPUTE" "$BBC_TEST_SCENES/ball80.gltf" -o "$TMP/b.bbc" $opts \
    --double-budget 0
  grep -q "warning: .*holds no tuples: every chain type with candidates is left" "$TMP/err" ||
    fail "ball80: $(cat "$TMP/err")"
  [ -s "$TMP/b.bbc" ] || fail "ball80: no cache"
  # Beam receivers (a bent floor of 1,200 triangles): every two-bounce type is left out
  # whatever the budget; --receivers per-triangle keeps them.
  expect_status 0 "$BBC_BIN/scenes/bbc-scenegen" glass-sphere --size 80 --floor-size 1200 \
    --floor-bend 0.2 -o "$TMP/bent.gltf"
  expect_status 0 "$PRECOMPUTE" "$TMP/bent.gltf" --dry-run $opts --double-budget 1e6
  grep -q "chains: RR, RT, TR, TT left to .* with beam receivers" "$TMP/err" ||
    fail "beams: $(cat "$TMP/err")"
  expect_status 0 "$PRECOMPUTE" "$TMP/bent.gltf" --dry-run $opts --receivers per-triangle
  grep -q "chains:" "$TMP/err" && fail "per-triangle: $(cat "$TMP/err")"
  for bad in -1 abc nan; do
    expect_status 2 "$PRECOMPUTE" "$scene" -o "$TMP/x.bbc" --double-budget "$bad"
  done
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
  for word in tuples pieces file "memory budget" "peak memory"; do
    grep -q "$word" "$TMP/err" || fail "--stats lacks $word"
  done
  grep -q '"tuples"' "$TMP/m.json" || fail "JSON lacks tuples"
  grep -q '"memory_budget_mb"' "$TMP/m.json" || fail "JSON lacks the memory budget"
  [ -s "$TMP/out" ] && fail "stdout is not empty"
  ls "$TMP" | grep -q tmp && fail "a temporary file was left behind"
  return 0
}

test_byte_identical_for_any_thread_count() {
  expect_status 0 "$PRECOMPUTE" "$POOL" -o "$TMP/a.bbc" --threads 1 --max-level 3 --chains R,T
  expect_status 0 "$PRECOMPUTE" "$POOL" -o "$TMP/b.bbc" --threads 2 --max-level 3 --chains R,T
  cmp -s "$TMP/a.bbc" "$TMP/b.bbc" || fail "caches differ between 1 and 2 threads"
}

# Grid entries beyond --entry-memory go to sorted runs in a temporary file, merged when
# the cache is written. The oracle is the in-memory path (no run written), with which
# the spilled caches must agree byte for byte for any budget and thread count; the
# spill files are deleted at once, so the spill folder stays empty.
PLANE="$BBC_TEST_SCENES/wavy-plane.gltf"
plane() { expect_status 0 "$PRECOMPUTE" "$PLANE" --chains R --max-level 4 --resolution 64 \
  --no-progress --stats "$@"; }
runs() { sed -n 's/^grid entries .*(\([0-9]*\) runs.*/\1/p' "$TMP/err"; }

test_spilled_cache_is_byte_identical() {
  mkdir "$TMP/spill"
  export TMPDIR="$TMP/spill"
  plane -o "$TMP/a.bbc" --entry-memory 1000
  [ "$(runs)" = 0 ] || fail "the in-memory precompute spilled: $(grep entries "$TMP/err")"
  plane -o "$TMP/b.bbc" --entry-memory 0.001 --threads 1
  [ "$(runs)" -ge 8 ] || fail "too few runs: $(grep entries "$TMP/err")"
  cmp "$TMP/a.bbc" "$TMP/b.bbc" >&2 || fail "spilled cache (1 thread) differs"
  plane -o "$TMP/c.bbc" --entry-memory 0.05 --threads 2
  [ "$(runs)" -gt 1 ] || fail "too few runs: $(grep entries "$TMP/err")"
  cmp "$TMP/a.bbc" "$TMP/c.bbc" >&2 || fail "spilled cache (2 threads) differs"
  [ -z "$(ls -A "$TMP/spill")" ] || fail "spill files left behind: $(ls -A "$TMP/spill")"
}

# A spill file that cannot be written (the file size limit stands in for a full disk:
# EFBIG instead of ENOSPC) fails the precompute with one line and leaves no output.
test_spill_write_failure_exits_1() {
  mkdir "$TMP/spill"
  export TMPDIR="$TMP/spill"
  (trap '' XFSZ; ulimit -f 64; "$PRECOMPUTE" "$PLANE" --chains R --max-level 4 --no-progress \
    --entry-memory 0.01 -o "$TMP/x.bbc" >"$TMP/out" 2>"$TMP/err")
  status=$?
  [ "$status" -eq 1 ] || fail "exit status $status, expected 1: $(cat "$TMP/err")"
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "not one line: $(cat "$TMP/err")"
  grep -q "cannot write the spill file in $TMP/spill: File too large" "$TMP/err" ||
    fail "message: $(cat "$TMP/err")"
  [ -e "$TMP/x.bbc" ] && fail "an output was written"
  ls "$TMP" | grep -q '\.tmp' && fail "a temporary file was left behind"
  [ -z "$(ls -A "$TMP/spill")" ] || fail "spill files left behind: $(ls -A "$TMP/spill")"
  export TMPDIR="$TMP/none"
  expect_status 1 "$PRECOMPUTE" "$PLANE" --chains R --max-level 4 --no-progress \
    --entry-memory 0.01 -o "$TMP/x.bbc"
  grep -q "cannot create the spill file in $TMP/none: No such file" "$TMP/err" ||
    fail "message: $(cat "$TMP/err")"
  [ -e "$TMP/x.bbc" ] && fail "an output was written"
  return 0
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

# Writer edge cases (tests/cli/edge_scene.py): one-triangle receivers, receivers of
# zero-area triangles (alone, or beside proper ones in one mesh), a receiver mesh without
# triangles, coordinates scaled by 1e30 and 1e-30. Every cache is written (the save
# path validates it before the rename) and validates again; a scene without light is
# refused with one line.
test_writer_edge_cases_give_valid_caches() {
  for kind in one-triangle zero-area mixed-zero-area empty-receiver huge tiny; do
    python3 "$BBC_SOURCE_DIR/tests/cli/edge_scene.py" "$TMP/$kind.gltf" $kind ||
      fail "cannot write $kind"
    expect_status 0 "$PRECOMPUTE" "$TMP/$kind.gltf" -o "$TMP/$kind.bbc" --max-level 4 \
      --resolution 32 --no-progress
    expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" validate "$TMP/$kind.bbc"
    expect_status 0 "$BBC_BIN/bbc-inspect/bbc-inspect" info "$TMP/$kind.bbc"
    grep -Eq "^tuples +[1-9]" "$TMP/out" || fail "$kind: no tuple: $(cat "$TMP/out")"
  done
  python3 "$BBC_SOURCE_DIR/tests/cli/edge_scene.py" "$TMP/dark.gltf" dark || fail "cannot write dark"
  expect_status 1 "$PRECOMPUTE" "$TMP/dark.gltf" -o "$TMP/dark.bbc" --no-progress
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "dark: not one line: $(cat "$TMP/err")"
  [ ! -e "$TMP/dark.bbc" ] || fail "dark: an output was written"
}

# Resource limits: a grid that cannot fit in memory is refused before anything large is
# allocated, with the estimate (65536^2 cells of at least 28 bytes: 112 GiB).
test_refuses_a_grid_that_does_not_fit_in_memory() {
  expect_status 1 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --resolution 65536 --no-progress
  grep -q "GiB of memory" "$TMP/err" || fail "no memory estimate: $(cat "$TMP/err")"
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ ! -e "$TMP/m.bbc" ] || fail "an output was written"
}

# The same for the disk: 4096 cells need a file of at least 50,624 bytes; the shim reports
# 1000 bytes free.
test_refuses_a_cache_that_does_not_fit_on_disk() {
  expect_status 1 env LD_PRELOAD="$BBC_BIN/tests/libfull_disk_shim.so" BBC_DISK_FREE=1000 \
    ASAN_OPTIONS=verify_asan_link_order=0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/d.bbc" --resolution 64 --no-progress
  grep -q "at least 50624 bytes .* has 1000 bytes free" "$TMP/err" ||
    fail "no disk estimate: $(cat "$TMP/err")"
  [ ! -e "$TMP/d.bbc" ] || fail "an output was written"
}

# A disk that fills up during the write: one line naming the error, no file left (not
# even the temporary one). The control without the shim writes the cache.
test_full_disk_during_write_leaves_no_file() {
  expect_status 1 env LD_PRELOAD="$BBC_BIN/tests/libfull_disk_shim.so" BBC_DISK_FULL_AFTER=2000 \
    ASAN_OPTIONS=verify_asan_link_order=0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/f.bbc" --max-level 2 --resolution 16 \
    --no-progress
  grep -q "No space left on device" "$TMP/err" || fail "does not say why: $(cat "$TMP/err")"
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ "$(ls "$TMP" | tr '\n' ' ')" = "err out " ] || fail "files left behind: $(ls "$TMP")"
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/f.bbc" --max-level 2 --resolution 16 \
    --no-progress
  [ -s "$TMP/f.bbc" ] || fail "control: no cache written"
}

# The memory budget (--memory): a grid whose least memory (28 bytes per cell: 512 x 512
# cells of the mirror's floor, 7.0 MiB) exceeds it is refused before any work, in one
# line with the estimate; a budget above it (the control) lets the precompute run.
test_memory_budget_below_the_estimate_is_refused() {
  expect_status 1 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --memory 4 --no-progress
  grep -q "262144 cells at grid resolution 512 need at least 7.0 MiB of memory .*more than the memory budget of 4.0 MiB.*(--memory)$" \
    "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ "$(ls "$TMP" | tr '\n' ' ')" = "err out " ] || fail "files left behind: $(ls "$TMP")"
  # The control: a budget the grid fits. The estimate counts what the process holds, which
  # a sanitizer build's shadow memory multiplies.
  mb=32
  sanitized && mb=512
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/m.bbc" --memory $mb --max-level 4 --no-progress
  [ -s "$TMP/m.bbc" ] || fail "control: no cache written"
}

# AddressSanitizer reserves its shadow and its heap's address space when it starts, so
# RLIMIT_AS does not limit its allocations and a ulimit -v stops it from starting: the
# budget is not enforced in a sanitizer build, whose runs skip the checks that need it.
sanitized() { ASAN_OPTIONS=help=1 "$PRECOMPUTE" --version 2>&1 | grep -q AddressSanitizer; }

# An allocation beyond the budget fails inside the process (RLIMIT_AS) instead of the
# kernel's OOM killer ending it: one line naming the budget and --memory, exit 1, no
# file. plane1k at resolution 768 passes the up-front check (590k cells, 16 MiB) but
# keeps its 25 million entries in memory (--entry-memory 1000), about 270 MB. One
# OpenMP thread, so that the allowance for the program's own mappings (a stack and a
# malloc heap per core) leaves the same room whatever the machine's cores.
test_memory_budget_exceeded_fails_in_one_line() {
  sanitized && return 0
  expect_status 1 env OMP_NUM_THREADS=1 "$PRECOMPUTE" "$BBC_TEST_SCENES/plane1k.gltf" \
    -o "$TMP/p.bbc" --chains R --max-level 3 --resolution 768 --threads 1 \
    --entry-memory 1000 --memory 64 --no-progress --ignore-estimate
  grep -q "^bbc-precompute: .*plane1k.gltf: out of memory within the budget of 64 MB (--memory) while bounding the candidate tuples; $TMP/p.bbc was not written$" \
    "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ "$(ls "$TMP" | tr '\n' ' ')" = "err out " ] || fail "files left behind: $(ls "$TMP")"
}

# The estimate, before any bounding: the candidate tuples counted exactly (the same
# number as the run that bounds them reports, per chain type too), and a budget the
# estimate does not fit refused in one line naming the count, exit 1, no file; the same
# budget with --dry-run, or a larger one, runs. wavy-mirror: R and RR candidates, whose
# stored tuples and grid entries (two lists of 8 MB at most) need about 18 MB more than
# the scene and grids.
test_estimate_counts_and_refuses_a_budget_too_small() {
  SCENE="$BBC_TEST_SCENES/wavy-mirror.gltf"
  expect_status 0 "$PRECOMPUTE" "$SCENE" -o "$TMP/w.bbc" --max-level 2 --no-progress \
    --json "$TMP/w.json" --stats
  n=$(sed -n 's/^  "candidate_tuples": \([0-9]*\),$/\1/p' "$TMP/w.json")
  [ -n "$n" ] && [ "$n" -gt 1000 ] || fail "no candidate count: $(cat "$TMP/w.json")"
  grep -q "^    \"candidate_tuples\": $n,$" "$TMP/w.json" || fail "estimate: $(cat "$TMP/w.json")"
  r=$(sed -n 's/^    "candidates_R": \([0-9]*\),$/\1/p' "$TMP/w.json")
  rr=$(sed -n 's/^    "candidates_RR": \([0-9]*\),$/\1/p' "$TMP/w.json")
  [ $((r + rr)) -eq "$n" ] || fail "per chain $r + $rr, not $n"
  grep -q "^bbc-precompute: estimate: $n candidate tuples (RR $rr, R $r), found in" "$TMP/err" ||
    fail "--stats shows no estimate: $(cat "$TMP/err")"
  rm -f "$TMP/w.bbc" "$TMP/w.json"
  expect_status 1 "$PRECOMPUTE" "$SCENE" -o "$TMP/w.bbc" --memory 12 --no-progress
  grep -q "^bbc-precompute: .*wavy-mirror.gltf: $n candidate tuples (RR $rr, R $r; .* as a list), up to [0-9]* of them stored: the precompute needs about .* over the budget of 12 MB (--memory); try .*; $TMP/w.bbc was not written$" \
    "$TMP/err" || fail "message: $(cat "$TMP/err")"
  [ "$(wc -l <"$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ "$(ls "$TMP" | tr '\n' ' ')" = "err out " ] || fail "files left behind: $(ls "$TMP")"
  expect_status 0 "$PRECOMPUTE" "$SCENE" --memory 64 --dry-run
  grep -q "^bbc-precompute: estimate: $n candidate tuples (RR $rr, R $r), .* of the budget of 64 MB (--memory), cache about" \
    "$TMP/err" || fail "--dry-run: $(cat "$TMP/err")"
  [ "$(ls "$TMP" | tr '\n' ' ')" = "err out " ] || fail "--dry-run wrote: $(ls "$TMP")"
}

test_memory_budget_bad_values_exit_2() {
  for bad in 0 -5 0.5 abc 12MB "" nan inf 1e30 2000000000; do
    expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --memory "$bad"
    grep -q "^bbc-precompute: --memory: " "$TMP/err" || fail "'$bad': $(cat "$TMP/err")"
  done
  expect_status 2 "$PRECOMPUTE" "$MIRROR" -o "$TMP/x.bbc" --memory
  [ -e "$TMP/x.bbc" ] && fail "an output was written"
  return 0
}

# A lower address-space limit (ulimit -v) is kept, and --stats and --json say so: the
# budget is what it leaves beside the program's own mappings (memory_allowance_mb of a
# first run), 200 MB here; a limit below those mappings is refused in one line.
test_memory_budget_keeps_a_lower_ulimit() {
  expect_status 0 "$PRECOMPUTE" "$MIRROR" -o "$TMP/a.bbc" --max-level 4 --no-progress \
    --memory 64 --stats --json "$TMP/a.json"
  grep -q "^memory budget  *64 MB (--memory); address space limited to" "$TMP/err" ||
    fail "--stats: $(grep budget "$TMP/err")"
  grep -q '"memory_budget_mb": 64.0,' "$TMP/a.json" || fail "JSON: $(cat "$TMP/a.json")"
  grep -q '"memory_budget_source": "--memory",' "$TMP/a.json" || fail "JSON: $(cat "$TMP/a.json")"
  allowance=$(sed -n 's/.*"memory_allowance_mb": \([0-9]*\).*/\1/p' "$TMP/a.json")
  [ -n "$allowance" ] || fail "no allowance in the JSON: $(cat "$TMP/a.json")"
  sanitized && return 0
  (ulimit -v $(((allowance + 200) * 1024)) && "$PRECOMPUTE" "$MIRROR" -o "$TMP/b.bbc" \
    --max-level 4 --no-progress --memory 100000 --stats --json "$TMP/b.json" \
    >"$TMP/out" 2>"$TMP/err") || fail "under ulimit -v: $(cat "$TMP/err")"
  grep -Eq "^memory budget +(19[0-9]|20[0-9]) MB: the address-space limit of $((allowance + 200)) MB \(ulimit -v\) was kept" \
    "$TMP/err" || fail "--stats: $(grep budget "$TMP/err")"
  grep -q '"memory_budget_source": "ulimit -v",' "$TMP/b.json" || fail "JSON: $(cat "$TMP/b.json")"
  (ulimit -v $((allowance / 2 * 1024)) && "$PRECOMPUTE" "$MIRROR" -o "$TMP/c.bbc" \
    --no-progress >"$TMP/out" 2>"$TMP/err")
  status=$?
  [ "$status" -eq 1 ] || fail "exit status $status under a tiny ulimit: $(cat "$TMP/err")"
  grep -q "^bbc-precompute: the address-space limit of .* MB (ulimit -v) leaves no room" "$TMP/err" ||
    fail "message: $(cat "$TMP/err")"
  [ -e "$TMP/c.bbc" ] && fail "an output was written"
  return 0
}

# A scene re-exported with float noise and another triangle order still renders from
# its cache, with a note, and exactly as the original scene does (the cache's geometry is
# adopted); a vertex moved by 1e-3 is refused in one line, with no image.
test_noisy_reexport_renders_from_the_cache() {
  scene="$BBC_TEST_SCENES/wavy-mirror.gltf"
  python3 "$BBC_SOURCE_DIR/tests/cli/reexport.py" "$scene" "$TMP/noisy.gltf" ||
    fail "cannot write the re-export"
  python3 "$BBC_SOURCE_DIR/tests/cli/reexport.py" "$scene" "$TMP/moved.gltf" 1e-3 ||
    fail "cannot write the changed scene"
  expect_status 0 "$PRECOMPUTE" "$scene" -o "$TMP/c.bbc" --chains R --max-level 3 \
    --resolution 32 --no-progress
  expect_status 0 "$RENDER" "$scene" -o "$TMP/a.exr" --cache "$TMP/c.bbc" --spp 2 --width 32
  expect_status 0 "$RENDER" "$TMP/noisy.gltf" -o "$TMP/b.exr" --cache "$TMP/c.bbc" --spp 2 \
    --width 32
  grep -q "geometry" "$TMP/err" || fail "no note about the adopted geometry: $(cat "$TMP/err")"
  cmp -s "$TMP/a.exr" "$TMP/b.exr" || fail "the re-export renders differently"
  expect_status 1 "$RENDER" "$TMP/moved.gltf" -o "$TMP/m.exr" --cache "$TMP/c.bbc" --spp 2 \
    --width 32
  [ "$(wc -l < "$TMP/err")" -eq 1 ] || fail "more than one line: $(cat "$TMP/err")"
  [ -e "$TMP/m.exr" ] && fail "an image was written for a changed scene"
  return 0
}

"test_$1"
