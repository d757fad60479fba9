#!/bin/sh
# Submits the three stages of a bbc run to Slurm at once, each starting when the one
# before it has succeeded:
#
#   1. precompute.sbatch, an array of N tasks: the shards of the cache;
#   2. merge.sbatch, once every shard is done (--dependency=afterok): the cache;
#   3. render.sbatch, an array of M tasks once the cache is there: the images.
#
#   sh submit.sh [options] SCENE.gltf OUTDIR [-- bbc-render options]
#
#   --shards N        precompute shards (default 16)
#   --tasks M         render tasks, each rendering every M-th image (default 4)
#   --cpus C          CPUs of each task, and so its --threads (default 4)
#   --precompute OPT  bbc-precompute options of every shard, one word list
#                     (e.g. "--chains R,T --max-level 8")
#   --sbatch OPT      sbatch options of every job (e.g. "--partition=cpu --time=2:00:00")
#   --resume          submit only the shards that are not in OUTDIR/shards yet: after a
#                     failed or cancelled shard, the same command with --resume does
#                     only what is left (a shard file is there only once it is whole
#                     and valid)
#
# The render options say what to render: "-- --frames 0:99 --spp 64" renders frames 0 to
# 99, "-- --all-cameras" one image per camera; without them, the first camera once.
# OUTDIR (on a file system the nodes share) receives shards/shard-I.bbc, cache.bbc,
# frames/image[.camC][.FFFF].exr and logs/ (each task's output). Prints the job IDs on
# stdout, a line each: "shards ID" ("shards none" when --resume finds them all), "merge
# ID", "render ID". A failed shard cancels the merge and the render
# (--kill-on-invalid-dep) instead of leaving them waiting forever.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
shards=16 tasks=4 cpus=4 precompute_options="" sbatch_options="" resume=0
usage() {
  echo "usage: sh submit.sh [--shards N] [--tasks M] [--cpus C] [--precompute OPTIONS]" >&2
  echo "         [--sbatch OPTIONS] [--resume] SCENE.gltf OUTDIR [-- bbc-render options]" >&2
  exit 2
}
number() {
  case $2 in
    '' | *[!0-9]* | 0*) echo "submit.sh: $1 '$2' is not a whole number >= 1" >&2; usage ;;
  esac
}
while [ "$#" -gt 0 ]; do
  case $1 in
    --shards) [ "$#" -ge 2 ] || usage; number "$1" "$2"; shards=$2; shift 2 ;;
    --tasks) [ "$#" -ge 2 ] || usage; number "$1" "$2"; tasks=$2; shift 2 ;;
    --cpus) [ "$#" -ge 2 ] || usage; number "$1" "$2"; cpus=$2; shift 2 ;;
    --precompute) [ "$#" -ge 2 ] || usage; precompute_options=$2; shift 2 ;;
    --sbatch) [ "$#" -ge 2 ] || usage; sbatch_options=$2; shift 2 ;;
    --resume) resume=1; shift ;;
    -h | --help) sed -n '2,/^set -eu/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "submit.sh: unknown option '$1'" >&2; usage ;;
    *) break ;;
  esac
done
[ "$#" -ge 2 ] || usage
scene=$1
out=$2
shift 2
if [ "$#" -gt 0 ]; then
  [ "$1" = -- ] || { echo "submit.sh: unexpected argument '$1'" >&2; usage; }
  shift
fi
[ -f "$scene" ] || { echo "submit.sh: $scene: no such scene" >&2; exit 1; }
# The jobs run elsewhere: absolute paths.
scene=$(cd "$(dirname "$scene")" && pwd)/$(basename "$scene")
mkdir -p "$out/shards" "$out/frames" "$out/logs"
out=$(cd "$out" && pwd)

# The shards to compute: all, or with --resume those not written yet.
array=""
i=0
while [ "$i" -lt "$shards" ]; do
  if [ "$resume" = 0 ] || [ ! -f "$out/shards/shard-$i.bbc" ]; then
    array="$array${array:+,}$i"
  fi
  i=$((i + 1))
done
[ "$resume" = 0 ] && array="0-$((shards - 1))"

# shellcheck disable=SC2086
submit() { sbatch --parsable --cpus-per-task="$cpus" $sbatch_options "$@" | cut -d';' -f1; }

merge_after=""
if [ -n "$array" ]; then
  # The count is given (BBC_SHARD_COUNT), so a partial array (--resume) numbers its
  # shards right too.
  # shellcheck disable=SC2086
  shards_job=$(submit --array="$array" --export=ALL,BBC_SHARD_COUNT="$shards" \
    --output="$out/logs/shard-%A_%a.out" "$here/precompute.sbatch" "$scene" "$out/shards" \
    $precompute_options)
  echo "shards $shards_job"
  merge_after="--dependency=afterok:$shards_job --kill-on-invalid-dep=yes"
else
  echo "shards none"
fi
# shellcheck disable=SC2086
merge_job=$(submit $merge_after --output="$out/logs/merge-%j.out" "$here/merge.sbatch" \
  "$out/shards" "$out/cache.bbc")
echo "merge $merge_job"
render_job=$(submit --array="0-$((tasks - 1))" --export=ALL,BBC_SHARD_COUNT="$tasks" \
  --dependency=afterok:"$merge_job" --kill-on-invalid-dep=yes \
  --output="$out/logs/render-%A_%a.out" "$here/render.sbatch" "$scene" "$out/cache.bbc" \
  "$out/frames/image.exr" "$@")
echo "render $render_job"
