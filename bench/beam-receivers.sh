#!/bin/sh
# Beam receivers against per-triangle tuples on a curved receiver: the wavy mirror (R,
# 2,000 triangles) over its floor bent into one wave (bbc-scenegen --floor-bend 0.2, so
# no plane) cut into 2,000 and 20,000 triangles, precomputed on one thread with
# --receivers per-triangle and --receivers beam at a grid of --resolution cells
# (default 128): time, memory, tuples, entries and cache size of each (docs/receivers.md,
# "Beam receivers"; bench/results/beam-scale.md has the same comparison at the default
# grid, for R, T and TT).
#
#   sh bench/beam-receivers.sh [--floors "2000 20000"] [--resolution N] [--memory-gb G]
#                              [--timeout S]
#
# Writes bench/results/beam-receivers.md; needs only the repository.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
floors="2000 20000"
resolution=128
memory_gb=8
timeout=300
while [ $# -gt 0 ]; do
  case $1 in
    --floors) floors=$2; shift 2 ;;
    --resolution) resolution=$2; shift 2 ;;
    --memory-gb) memory_gb=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    *) echo "usage: sh bench/beam-receivers.sh [--floors \"N...\"] [--resolution N]" \
      "[--memory-gb G] [--timeout S]" >&2
      exit 2 ;;
  esac
done
tool=beam-receivers.sh
scale=1
work=$root/bench/work/beam-receivers
out=$root/bench/results
. "$root/bench/lib.sh"
build_release "$root"
gen=$root/build/scenes/bbc-scenegen
pre=$root/build/bbc-precompute/bbc-precompute
mkdir -p "$work" "$out"
commit=$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)

field() { sed -n "s/^ *\"$2\": \([0-9.e+-]*\),\{0,1\}$/\1/p" "$1"; }

rows=$work/rows
: > "$rows"
for floor in $floors; do
  scene=$work/bent$floor.gltf
  "$gen" wavy-mirror --size 2000 --floor-size "$floor" --floor-bend 0.2 -o "$scene"
  for mode in per-triangle beam; do
    name=bent$floor-$mode
    echo "$tool: floor of $floor triangles, --receivers $mode" >&2
    rm -f "$work/$name.bbc" "$work/$name.json"
    status=ok
    (ulimit -v $((memory_gb * 1024 * 1024)) &&
      exec /usr/bin/time -f '%U %S %e %M' -o "$work/$name.time" \
        timeout "$timeout" "$pre" "$scene" -o "$work/$name.bbc" --chains R --threads 1 \
        --resolution "$resolution" --receivers "$mode" --no-progress \
        --json "$work/$name.json") > "$work/$name.log" 2>&1 || status=failed
    if [ $status = failed ]; then
      if grep -q "Command exited with non-zero status 124" "$work/$name.time"; then
        status="timeout ${timeout} s"
      else
        status="failed: $(grep -v '^Command' "$work/$name.log" | tail -1)"
      fi
    fi
    t=$(grep -v '^Command' "$work/$name.time" | tail -1)
    cpu=$(echo "$t" | awk '{ printf "%.2f", $1 + $2 }')
    rss=$(echo "$t" | awk '{ printf "%.0f", $4 / 1024 }')
    tuples=- entries=- mb=-
    if [ "$status" = ok ]; then
      tuples=$(field "$work/$name.json" tuples)
      entries=$(field "$work/$name.json" entries)
      mb=$(awk -v b="$(field "$work/$name.json" file_bytes)" 'BEGIN { printf "%.1f", b / 1048576 }')
    fi
    echo "$floor|$mode|$status|$cpu|$rss|$tuples|$entries|$mb" >> "$rows"
  done
done

{
  echo "# Beam receivers against per-triangle tuples on a bent floor"
  echo
  echo "\`sh bench/beam-receivers.sh --floors \"$floors\" --resolution $resolution\`"
  echo "at $commit; $machine (load average $(cut -d' ' -f1-3 /proc/loadavg)); one thread,"
  echo "\`--chains R\`, the wavy mirror of 2,000 triangles over a floor bent into a wave."
  echo "CPU-s are user + sys."
  echo
  echo "| floor triangles | receivers | status | CPU-s | peak RSS MB | tuples | entries | cache MB |"
  echo "|---:|---|---|---:|---:|---:|---:|---:|"
  awk -F'|' '{ printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8 }' "$rows"
} > "$out/beam-receivers.md"
cat "$out/beam-receivers.md"
