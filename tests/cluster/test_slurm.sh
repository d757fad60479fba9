#!/bin/sh
# The Slurm job scripts of examples/slurm/, run as they are written on a one-node Slurm
# cluster started for each test (tests/cluster/cluster.sh): munged, slurmctld and slurmd
# of Debian's slurm-wlm, as root, stopped again whatever happens. The oracles are the
# same commands on one machine without a scheduler: the merged cache must be
# byte-identical to the one-shot precompute, and the frames bit-identical to the same
# --frames rendered in one process. Each test_<name> function is one ctest entry
# (cluster.<name>); they skip (exit 77) where no cluster can run (not root, slurm-wlm or
# munge missing), except in CI (CI=true), where that is a failure.
set -u
BIN=$BBC_BIN
SCENEGEN="$BIN/scenes/bbc-scenegen"
EXAMPLES="$BBC_SOURCE_DIR/examples/slurm"
TMP=$(mktemp -d)
# munged wants every folder above its socket world-traversable.
chmod 755 "$TMP"
CLUSTER_REMOVE=$TMP
. "$BBC_SOURCE_DIR/tests/cluster/cluster.sh"
# Whatever happens (failure, signal), the daemons are stopped and the scratch removed;
# the exit status is kept.
trap 'status=$?; cluster_stop; rm -rf "$TMP"; exit $status' EXIT
trap 'exit 129' HUP
trap 'exit 130' INT
trap 'exit 143' TERM

fail() { echo "FAILED: $*" >&2; cluster_logs; exit 1; }

# The tools the jobs run, found through PATH as on a real cluster (the jobs inherit the
# submitting environment).
PATH="$BIN/bbc-precompute:$BIN/bbc-render:$BIN/bbc-inspect:$PATH"
export PATH

# state_of JOB_OR_TASK: its state in the controller (PENDING, RUNNING, COMPLETED...).
state_of() { squeue -h -j "$1" -o %T 2>/dev/null | head -n 1; }

# task_runs TOOL JOB TASK: 0 once a process TOOL of array task JOB_TASK runs on the node
# (the controller says RUNNING a moment before slurmd has launched the task).
task_runs() {
  for comm in /proc/[0-9]*/comm; do
    name=""
    { read -r name <"$comm"; } 2>/dev/null
    # bbc-precompute executes itself once more at start (OMP_WAIT_POLICY), as "exe".
    [ "$name" = "$1" ] || [ "$name" = exe ] || continue
    n=$({ tr '\0' '\n' <"${comm%/comm}/environ"; } 2>/dev/null |
      grep -cx -e "SLURM_ARRAY_JOB_ID=$2" -e "SLURM_ARRAY_TASK_ID=$3")
    [ "$n" -eq 2 ] && return 0
  done
  return 1
}

# expect_states FILE ID=STATE...: FILE holds cluster_wait's "ID STATE" lines.
expect_states() {
  file=$1
  shift
  for want in "$@"; do
    id=${want%%=*}
    grep -qx "$id ${want#*=}" "$file" || fail "job $id is not ${want#*=}: $(tr '\n' ';' <"$file")"
  done
}

# no_partial_files DIR: no temporary file of an atomic write is left in DIR.
no_partial_files() {
  left=$(find "$1" -name '*.tmp.*')
  [ -z "$left" ] || fail "partial files were left behind: $left"
}

# job_of NAME FILE: the job ID submit.sh printed for NAME (shards, merge, render).
job_of() { awk -v n="$1" '$1 == n { print $2 }' "$2"; }

# The three stages at once with submit.sh: 4 precompute shards, their merge, and 6
# frames in 3 render tasks (frames 0 and 3, 1 and 4, 2 and 5).
test_submit_runs_shards_merge_and_frames() {
  cluster_start "$TMP/cluster"
  "$SCENEGEN" wavy-mirror --size 200 --orbit 6 --width 48 --height 36 -o "$TMP/scene.gltf" ||
    fail "bbc-scenegen failed"
  sh "$EXAMPLES/submit.sh" --shards 4 --tasks 3 --cpus 1 "$TMP/scene.gltf" "$TMP/run" \
    -- --frames 0:5 --spp 4 >"$TMP/jobs" 2>"$TMP/err" || fail "submit.sh: $(cat "$TMP/err")"
  shards=$(job_of shards "$TMP/jobs") merge=$(job_of merge "$TMP/jobs")
  render=$(job_of render "$TMP/jobs")
  [ -n "$shards" ] && [ -n "$merge" ] && [ -n "$render" ] || fail "submit.sh: $(cat "$TMP/jobs")"
  cluster_wait "$shards" "$merge" "$render" >"$TMP/states"
  expect_states "$TMP/states" "${shards}_0=COMPLETED" "${shards}_1=COMPLETED" \
    "${shards}_2=COMPLETED" "${shards}_3=COMPLETED" "$merge=COMPLETED" \
    "${render}_0=COMPLETED" "${render}_1=COMPLETED" "${render}_2=COMPLETED"

  # The oracle: the same precompute and frames on one machine.
  bbc-precompute "$TMP/scene.gltf" -o "$TMP/one.bbc" --no-progress 2>"$TMP/err" ||
    fail "one-shot precompute: $(cat "$TMP/err")"
  cmp "$TMP/one.bbc" "$TMP/run/cache.bbc" >&2 || fail "the merged cache differs from the one-shot"
  mkdir "$TMP/one"
  bbc-render "$TMP/scene.gltf" --cache "$TMP/one.bbc" -o "$TMP/one/image.exr" --frames 0:5 \
    --spp 4 --no-progress 2>"$TMP/err" || fail "one-machine render: $(cat "$TMP/err")"
  for f in 0000 0001 0002 0003 0004 0005; do
    cmp "$TMP/one/image.$f.exr" "$TMP/run/frames/image.$f.exr" >&2 ||
      fail "frame $f differs from the one rendered on one machine"
  done
  [ "$(ls "$TMP/run/frames" | wc -l)" -eq 6 ] || fail "frames: $(ls "$TMP/run/frames")"
  # Each render task rendered its own frames only (task 1: frames 1 and 4).
  grep -q "shard" "$TMP/run/logs/render-${render}_1.out" &&
    fail "render task 1 said: $(cat "$TMP/run/logs/render-${render}_1.out")"
  [ ! -s "$TMP/run/logs/merge-$merge.out" ] ||
    fail "the merge said: $(cat "$TMP/run/logs/merge-$merge.out")"
  no_partial_files "$TMP/run"
}

# A shard cancelled halfway (scancel of one array task) leaves no file, cancels the
# merge and the render that wait on it, and cannot be resubmitted alone without its
# count; submit.sh --resume then runs only that shard, and the final cache is still
# byte-identical to the one-shot precompute. A partial file that a writer killed outright
# would leave (SIGKILL, a lost node) is removed by the rerun.
test_cancelled_shard_resubmitted() {
  cluster_start "$TMP/cluster"
  # Large enough that a shard runs for seconds, so that it is cancelled halfway.
  "$SCENEGEN" wavy-mirror --size 12000 --width 32 --height 24 -o "$TMP/scene.gltf" ||
    fail "bbc-scenegen failed"
  sh "$EXAMPLES/submit.sh" --shards 3 --tasks 1 --cpus 1 "$TMP/scene.gltf" "$TMP/run" \
    -- --spp 1 >"$TMP/jobs" 2>"$TMP/err" || fail "submit.sh: $(cat "$TMP/err")"
  shards=$(job_of shards "$TMP/jobs") merge=$(job_of merge "$TMP/jobs")
  render=$(job_of render "$TMP/jobs")
  # Cancel task 1 a second after its bbc-precompute started.
  i=0
  while ! task_runs bbc-precompute "$shards" 1; do
    [ "$i" -lt 600 ] || fail "shard 1 did not start in 60 s: $(state_of "${shards}_1")"
    sleep 0.1
    i=$((i + 1))
  done
  sleep 1
  scancel "${shards}_1" || fail "scancel ${shards}_1 failed"
  cluster_wait "$shards" "$merge" "$render" >"$TMP/states"
  expect_states "$TMP/states" "${shards}_0=COMPLETED" "${shards}_1=CANCELLED" \
    "${shards}_2=COMPLETED" "$merge=CANCELLED" "${render}_0=CANCELLED"
  log="$TMP/run/logs/shard-${shards}_1.out"
  grep -q "bbc-precompute: interrupted; .*shard-1.bbc was not written" "$log" ||
    fail "shard 1 was not cancelled while it ran: $(cat "$log")"
  [ -e "$TMP/run/shards/shard-1.bbc" ] && fail "the cancelled shard left shard-1.bbc"
  [ -e "$TMP/run/cache.bbc" ] && fail "the merge ran without shard 1"
  no_partial_files "$TMP/run"

  # What a writer killed outright leaves: its temporary file, here of a process that is
  # gone.
  dead=$(sh -c 'echo $$')
  head -c 1000 "$TMP/run/shards/shard-0.bbc" >"$TMP/run/shards/shard-1.bbc.tmp.$dead"

  # The pitfall: submitted alone, the task sees an array of one and cannot tell the
  # shard count; bbc-precompute says so in one line and writes nothing.
  alone=$(sbatch --parsable --array=1 --output="$TMP/alone.out" "$EXAMPLES/precompute.sbatch" \
    "$TMP/scene.gltf" "$TMP/run/shards") || fail "sbatch --array=1 failed"
  cluster_wait "$alone" >"$TMP/states"
  expect_states "$TMP/states" "${alone}_1=FAILED"
  grep -q "^bbc-precompute: --shard auto: this array has one task (1), so it cannot tell" \
    "$TMP/alone.out" || fail "the lone task said: $(cat "$TMP/alone.out")"
  [ "$(wc -l <"$TMP/alone.out")" -eq 1 ] || fail "more than one line: $(cat "$TMP/alone.out")"
  [ -e "$TMP/run/shards/shard-1.bbc" ] && fail "the lone task wrote shard-1.bbc"

  # The same command with --resume: only shard 1, then the merge and the render.
  sh "$EXAMPLES/submit.sh" --shards 3 --tasks 1 --cpus 1 --resume "$TMP/scene.gltf" \
    "$TMP/run" -- --spp 1 >"$TMP/jobs" 2>"$TMP/err" || fail "submit.sh --resume: $(cat "$TMP/err")"
  shards=$(job_of shards "$TMP/jobs") merge=$(job_of merge "$TMP/jobs")
  render=$(job_of render "$TMP/jobs")
  cluster_wait "$shards" "$merge" "$render" >"$TMP/states"
  [ "$(grep -c "^${shards}_" "$TMP/states")" -eq 1 ] ||
    fail "--resume submitted more than shard 1: $(tr '\n' ';' <"$TMP/states")"
  expect_states "$TMP/states" "${shards}_1=COMPLETED" "$merge=COMPLETED" "${render}_0=COMPLETED"
  grep -q "note: removed .*shard-1.bbc.tmp.$dead, left by a run that was stopped" \
    "$TMP/run/logs/shard-${shards}_1.out" ||
    fail "the rerun did not remove the partial file: $(cat "$TMP/run/logs/shard-${shards}_1.out")"
  no_partial_files "$TMP/run"
  bbc-precompute "$TMP/scene.gltf" -o "$TMP/one.bbc" --no-progress 2>"$TMP/err" ||
    fail "one-shot precompute: $(cat "$TMP/err")"
  cmp "$TMP/one.bbc" "$TMP/run/cache.bbc" >&2 || fail "the merged cache differs from the one-shot"
  [ -f "$TMP/run/frames/image.exr" ] || fail "the render wrote no image: $(ls "$TMP/run/frames")"
}

# The daemons are gone once a test has stopped its cluster, on success and on failure.
test_stop_leaves_no_daemon() {
  cluster_start "$TMP/cluster"
  pids="$CLUSTER_PIDS"
  [ "$(echo $pids | wc -w)" -eq 3 ] || fail "expected 3 daemons, have: $pids"
  # A job still running when the cluster stops must end too.
  job=$(sbatch --parsable --output=/dev/null --wrap 'sleep 300') || fail "sbatch failed"
  i=0
  while [ "$(state_of "$job")" != RUNNING ]; do
    [ "$i" -lt 300 ] || fail "the job did not start"
    sleep 0.1
    i=$((i + 1))
  done
  cluster_stop
  for pid in $pids; do kill -0 "$pid" 2>/dev/null && fail "daemon $pid still runs"; done
  [ -z "$(cluster_processes)" ] || fail "processes left: $(cluster_processes)"
  return 0
}

"$1"
