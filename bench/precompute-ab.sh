#!/bin/sh
# The precompute's cost at two commits, side by side: each run (a scene and bbc-precompute
# options) is made with the base commit's binary and this checkout's, alternately, --rounds
# times (default 3), so that a noisy, shared machine slows both alike; prints the median
# CPU-seconds (user + sys) of each, their ratio, and whether the two caches are the same
# bytes (an optimisation that changes no bound must leave them so).
#
#   sh bench/precompute-ab.sh [--base COMMIT] [--rounds N] [--memory-gb G] \
#       SCENE "OPTIONS" [SCENE "OPTIONS" ...]
#
# COMMIT (default HEAD~1) is built in a worktree under bench/work/ab/ (Release, the
# bbc-precompute target only); this checkout's build/ is built as the benchmarks build
# it. Each run is under `ulimit -v` of --memory-gb (default 8). Example:
#
#   sh bench/precompute-ab.sh --base 9929358 \
#     bench/work/real-assets/TransmissionTest-lit.gltf "--chains R --threads 2"
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=precompute-ab
work="$root/bench/work/ab"
base=HEAD~1 rounds=3 memory_gb=8
while [ $# -gt 0 ]; do
  case "$1" in
    --base) base=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --memory-gb) memory_gb=$2; shift 2 ;;
    -h | --help) sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "$tool: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
[ $# -ge 2 ] && [ $(($# % 2)) -eq 0 ] || { echo "$tool: give SCENE \"OPTIONS\" pairs (--help)" >&2; exit 2; }
scale=1
. "$root/bench/lib.sh"
mkdir -p "$work"
commit=$(git -C "$root" rev-parse --short "$base")
tree="$work/tree-$commit"
if [ ! -d "$tree" ]; then
  git -C "$root" worktree add -q --detach "$tree" "$commit"
fi
cmake -S "$tree" -B "$tree/build" -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$tree/build" -j "$(nproc)" --target bbc-precompute > /dev/null
build_release "$root"
old="$tree/build/bbc-precompute/bbc-precompute"
new="$root/build/bbc-precompute/bbc-precompute"

echo "base $commit against $(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- libbbc bbc-precompute || echo ' (with uncommitted changes)'), $machine, $rounds rounds"
echo "| scene | options | base CPU-s | this CPU-s | ratio | caches |"
echo "|---|---|---:|---:|---:|---|"
median() { sort -g | awk '{ v[NR] = $1 } END { printf "%.2f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
while [ $# -gt 0 ]; do
  scene=$1 options=$2
  shift 2
  : > "$work/a" && : > "$work/b"
  r=0
  while [ "$r" -lt "$rounds" ]; do
    for side in a b; do
      bin=$old
      [ "$side" = b ] && bin=$new
      # shellcheck disable=SC2086
      (ulimit -v $((memory_gb * 1048576)); cpu "$work/log" "$bin" "$scene" -o "$work/$side.bbc" \
        --no-progress $options) >> "$work/$side"
      echo >> "$work/$side"
    done
    r=$((r + 1))
  done
  ta=$(median < "$work/a") tb=$(median < "$work/b")
  same="differ"
  cmp -s "$work/a.bbc" "$work/b.bbc" && same="identical"
  echo "| $(basename "$scene") | \`$options\` | $ta | $tb | $(awk -v a="$ta" -v b="$tb" 'BEGIN { printf "%.2f", (b > 0 ? a / b : 0) }') | $same |"
done
