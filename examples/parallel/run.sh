#!/bin/sh
# The three stages of a bbc run spread with GNU parallel, on this machine or over ssh:
#
#   1. the shards of the cache (bbc-precompute --shard I/N), N jobs;
#   2. their merge into the cache (bbc-inspect merge), here;
#   3. the images (bbc-render --shard I/M), M jobs.
#
#   sh run.sh [options] SCENE.gltf OUTDIR [-- bbc-render options]
#
#   --shards N          precompute shards (default 16)
#   --tasks M           render jobs, each rendering every M-th image (default 4)
#   --jobs J            jobs at once on each machine (default 1)
#   --threads T         --threads of each job (default: this machine's cores / J)
#   --precompute OPT    bbc-precompute options of every shard, one word list
#   --sshloginfile FILE run the jobs on the machines FILE lists, over ssh (GNU parallel's
#                       format: one [user@]host a line, ":" for this machine); SCENE and
#                       OUTDIR must be at the same path on every one of them (a shared
#                       folder), and bbc installed there
#   --resume            skip the shards already in OUTDIR/shards (a shard file is there
#                       only once it is whole and valid), after a failure
#
# OUTDIR receives shards/shard-I.bbc, cache.bbc, frames/image[.camC][.FFFF].exr and
# logs/ (GNU parallel's job logs). The render options say what to render, as in
# ../slurm/submit.sh: "-- --frames 0:99 --spp 64". Stops at the first stage that fails.
set -eu
shards=16 tasks=4 jobs=1 threads="" precompute_options="" login="" resume=0
usage() {
  echo "usage: sh run.sh [--shards N] [--tasks M] [--jobs J] [--threads T]" >&2
  echo "         [--precompute OPTIONS] [--sshloginfile FILE] [--resume]" >&2
  echo "         SCENE.gltf OUTDIR [-- bbc-render options]" >&2
  exit 2
}
number() {
  case $2 in
    '' | *[!0-9]* | 0*) echo "run.sh: $1 '$2' is not a whole number >= 1" >&2; usage ;;
  esac
}
while [ "$#" -gt 0 ]; do
  case $1 in
    --shards) [ "$#" -ge 2 ] || usage; number "$1" "$2"; shards=$2; shift 2 ;;
    --tasks) [ "$#" -ge 2 ] || usage; number "$1" "$2"; tasks=$2; shift 2 ;;
    --jobs) [ "$#" -ge 2 ] || usage; number "$1" "$2"; jobs=$2; shift 2 ;;
    --threads) [ "$#" -ge 2 ] || usage; number "$1" "$2"; threads=$2; shift 2 ;;
    --precompute) [ "$#" -ge 2 ] || usage; precompute_options=$2; shift 2 ;;
    --sshloginfile) [ "$#" -ge 2 ] || usage; login=$2; shift 2 ;;
    --resume) resume=1; shift ;;
    -h | --help) sed -n '2,/^set -eu/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "run.sh: unknown option '$1'" >&2; usage ;;
    *) break ;;
  esac
done
[ "$#" -ge 2 ] || usage
scene=$1
out=$2
shift 2
if [ "$#" -gt 0 ]; then
  [ "$1" = -- ] || { echo "run.sh: unexpected argument '$1'" >&2; usage; }
  shift
fi
[ -f "$scene" ] || { echo "run.sh: $scene: no such scene" >&2; exit 1; }
command -v parallel >/dev/null || { echo "run.sh: GNU parallel is missing" >&2; exit 1; }
[ -n "$threads" ] || threads=$(( $(nproc) / jobs > 0 ? $(nproc) / jobs : 1 ))
# Remote jobs see the same paths: absolute ones.
scene=$(cd "$(dirname "$scene")" && pwd)/$(basename "$scene")
mkdir -p "$out/shards" "$out/frames" "$out/logs"
out=$(cd "$out" && pwd)
where="--jobs $jobs"
[ -n "$login" ] && where="--sshloginfile $login --jobs $jobs"

# 1. The shards. A job's arguments are its index; the quoting of the paths survives ssh.
i=0 todo=""
while [ "$i" -lt "$shards" ]; do
  if [ "$resume" = 0 ] || [ ! -f "$out/shards/shard-$i.bbc" ]; then todo="$todo $i"; fi
  i=$((i + 1))
done
if [ -n "$todo" ]; then
  # shellcheck disable=SC2086
  parallel --will-cite -q $where --joblog "$out/logs/shards.joblog" \
    bbc-precompute "$scene" -o "$out/shards/shard-{}.bbc" --shard "{}/$shards" \
    --threads "$threads" --no-progress $precompute_options ::: $todo
fi

# 2. The merge, here (it reads every shard once: cheap next to the shards).
bbc-inspect merge "$out/cache.bbc" "$out"/shards/shard-*.bbc --threads "$(nproc)" --no-progress

# 3. The images, each job every M-th of the list the render options ask for.
# shellcheck disable=SC2086
parallel --will-cite -q $where --joblog "$out/logs/render.joblog" \
  bbc-render "$scene" --cache "$out/cache.bbc" -o "$out/frames/image.exr" \
  --shard "{}/$tasks" --threads "$threads" --no-progress "$@" ::: $(seq 0 $((tasks - 1)))
