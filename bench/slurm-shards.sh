#!/bin/sh
# A sharded precompute on a one-node Slurm cluster (the test suite's,
# tests/cluster/cluster.sh): examples/slurm/precompute.sbatch as an array of N tasks and
# merge.sbatch after it, against the one-shot precompute of the same scene. Checks that
# the merged cache is byte-identical to the one-shot one, and reports the CPU-s (user +
# sys) of the shards together against the one-shot's (the cost of sharding: each shard
# builds the candidate list and writes a file of its own), and the merge's wall time and
# CPU-s. Writes bench/results/slurm-shards.md.
#
#   sh bench/slurm-shards.sh [--shards N] [--scene NAME] [--precompute OPTIONS]
#                            [SHARED_SCENES_DIR]
#
# Defaults: 16 shards of plane28k with --chains R (the single scattering of the README's
# precompute table; the default chains add RR, far costlier on this plane), from the
# shared scenes ($BBC_SHARED_DIR/scenes, else ../shared/scenes beside the repository;
# without them, one line and exit 0). Each task
# and the one-shot use one thread (--cpus-per-task=1), so that the CPU-s compare like
# with like. Needs root, slurm-wlm and munge (sh scripts/install-deps.sh) and a Release
# build in build/ (built here if missing). The job scripts run as they are; the CPU-s of
# each task are taken by a wrapper put first in PATH that runs the real tool under
# /usr/bin/time.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
shards=16 name=plane28k scenes="" options="--chains R"
while [ $# -gt 0 ]; do
  case $1 in
    --shards) shards=$2; shift 2 ;;
    --scene) name=$2; shift 2 ;;
    --precompute) options=$2; shift 2 ;;
    -*)
      echo "usage: sh bench/slurm-shards.sh [--shards N] [--scene NAME] [--precompute OPT]" \
        "[DIR]" >&2
      exit 2
      ;;
    *) scenes=$1; shift ;;
  esac
done
tool=slurm-shards.sh
. "$root/bench/lib.sh"
scenes=$(shared_scenes "$scenes" "$name.gltf") || exit 0
command -v /usr/bin/time >/dev/null || { echo "$tool: /usr/bin/time is missing" >&2; exit 1; }
build_release "$root"
bin=$root/build
work=$(mktemp -d)
chmod 755 "$work"
BBC_SOURCE_DIR=$root
CLUSTER_REMOVE=$work
. "$root/tests/cluster/cluster.sh"
trap 'status=$?; cluster_stop; rm -rf "$work"; exit $status' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
cluster_start "$work/cluster"

# The wrappers: each run's "wall user sys" to $work/times/<tool>-<task>.
mkdir -p "$work/wrap" "$work/times"
for t in bbc-precompute bbc-inspect; do
  case $t in bbc-precompute) real=$bin/bbc-precompute/$t ;; *) real=$bin/bbc-inspect/$t ;; esac
  cat >"$work/wrap/$t" <<WRAP
#!/bin/sh
exec /usr/bin/time -f '%e %U %S' -o "$work/times/$t-\${SLURM_ARRAY_TASK_ID:-\$SLURM_JOB_ID}" \
  "$real" "\$@"
WRAP
  chmod +x "$work/wrap/$t"
done
PATH="$work/wrap:$PATH"
export PATH

scene=$scenes/$name.gltf
echo "$tool: one-shot precompute of $name ($options), 1 thread" >&2
/usr/bin/time -f '%e %U %S' -o "$work/one-time" "$bin/bbc-precompute/bbc-precompute" "$scene" \
  -o "$work/one.bbc" --threads 1 --no-progress $options 2>"$work/one.log" ||
  { echo "$tool: the one-shot precompute failed: $(tail -3 "$work/one.log")" >&2; exit 1; }
one=$(awk '{ printf "%.2f", $2 + $3 }' "$work/one-time")
one_wall=$(awk '{ printf "%.2f", $1 }' "$work/one-time")
echo "$tool: $shards shards on the one-node cluster" >&2
start=$(date +%s.%N)
shards_job=$(sbatch --parsable --array="0-$((shards - 1))" --output="$work/shard-%a.out" \
  "$root/examples/slurm/precompute.sbatch" "$scene" "$work/shards" $options)
merge_job=$(sbatch --parsable --dependency=afterok:"$shards_job" --kill-on-invalid-dep=yes \
  --output="$work/merge.out" "$root/examples/slurm/merge.sbatch" "$work/shards" "$work/merged.bbc")
BBC_CLUSTER_TIMEOUT=3600 cluster_wait "$shards_job" "$merge_job" >"$work/states"
end=$(date +%s.%N)
bad=$(grep -v ' COMPLETED$' "$work/states" || true)
if [ -n "$bad" ]; then
  echo "$tool: jobs failed: $bad" >&2
  cat "$work"/shard-*.out "$work/merge.out" >&2
  exit 1
fi
if cmp -s "$work/one.bbc" "$work/merged.bbc"; then same=yes; else same=NO; fi
sum=$(cat "$work"/times/bbc-precompute-* | awk '{ s += $2 + $3 } END { printf "%.2f", s }')
max=$(cat "$work"/times/bbc-precompute-* | awk '$1 > m { m = $1 } END { printf "%.2f", m }')
merge=$(awk '{ printf "%.2f s wall, %.2f CPU-s", $1, $2 + $3 }' "$work"/times/bbc-inspect-*)
elapsed=$(echo "$end $start" | awk '{ printf "%.1f", $1 - $2 }')
size=$(wc -c <"$work/one.bbc")
out=$root/bench/results/slurm-shards.md
{
  echo "# A sharded precompute on a one-node Slurm cluster"
  echo
  echo "\`sh bench/slurm-shards.sh --shards $shards --scene $name\` at" \
    "$(git -C "$root" rev-parse --short HEAD) on $(date -u +%Y-%m-%d) ($machine, load" \
    "average $(cut -d' ' -f1 /proc/loadavg) at the end)."
  echo "examples/slurm/precompute.sbatch as --array=0-$((shards - 1)), one CPU a task," \
    "then merge.sbatch (--dependency=afterok); the one-shot precompute with --threads 1;" \
    "bbc-precompute options: \`$options\`."
  echo
  echo "| | CPU-s (user + sys) | wall |"
  echo "|---|---|---|"
  echo "| one-shot precompute | $one | ${one_wall} s |"
  ratio=$(echo "$sum $one" | awk '{ printf "%.2fx", $1 / $2 }')
  echo "| $shards shards, together | $sum ($ratio the one-shot's) | longest task $max s |"
  echo "| merge | ${merge#* wall, } | ${merge%% wall*} |"
  echo "| submission to merged cache | | $elapsed s |"
  echo
  echo "Merged cache byte-identical to the one-shot one ($size bytes): **$same**."
} >"$out"
cat "$out"
[ "$same" = yes ]
