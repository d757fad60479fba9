#!/bin/sh
# The cost of a receiver's tessellation: the same caster over a floor of two triangles
# and over the same floor re-meshed as a flat grid in the same plane (bbc-scenegen
# --floor-size), precomputed on one thread. The floor is a receiver plane (format-spec
# Sec. 6.5): its tuples end on the plane, not on its triangles, so the tuples do not
# change with its tessellation and the cost and cache should not either (within 1.5x;
# before receiver planes, 2 -> 20,000 triangles cost 80x on R).
#
#   sh bench/receivers.sh [--floors "2 20000 200000"] [--memory-gb G] [--timeout S]
#
# Cases: R (bbc-scenegen wavy-mirror, 2,000 triangles), T (pool, 2,000) and TT
# (glass-sphere, 7,000, --max-level 1). Each precompute runs under `ulimit -v` of
# --memory-gb (default 8) and stops after --timeout seconds (default 300); a run that
# does not finish is reported as such, with what it had used. Writes
# bench/results/receivers.md; needs only the repository (builds build/ if missing).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
floors="2 20000 200000"
memory_gb=8
timeout=300
while [ $# -gt 0 ]; do
  case $1 in
    --floors) floors=$2; shift 2 ;;
    --memory-gb) memory_gb=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    *) echo "usage: sh bench/receivers.sh [--floors \"N...\"] [--memory-gb G] [--timeout S]" >&2
      exit 2 ;;
  esac
done
tool=receivers.sh
scale=1
work=$root/bench/work/receivers
out=$root/bench/results
. "$root/bench/lib.sh"
build_release "$root"
gen=$root/build/scenes/bbc-scenegen
pre=$root/build/bbc-precompute/bbc-precompute
mkdir -p "$work" "$out"
commit=$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)

# field JSON KEY: a number of the precompute's --json statistics.
field() { sed -n "s/^ *\"$2\": \([0-9.e+-]*\),\{0,1\}$/\1/p" "$1"; }

# One row per case and floor: status, CPU-s (user + sys), wall s, peak RSS MB, tuples,
# cache MB.
rows=$work/rows
: > "$rows"
for spec in "R:wavy-mirror:2000:" "T:pool:2000:" "TT:glass-sphere:7000:--max-level 1"; do
  chain=${spec%%:*}
  rest=${spec#*:}
  kind=${rest%%:*}
  rest=${rest#*:}
  size=${rest%%:*}
  extra=${rest#*:}
  for floor in $floors; do
    name=$kind-$size-floor$floor
    if [ "$floor" -le 2 ]; then
      "$gen" "$kind" --size "$size" -o "$work/$name.gltf"
    else
      "$gen" "$kind" --size "$size" --floor-size "$floor" -o "$work/$name.gltf"
    fi
    echo "$tool: $chain $kind --size $size, floor of $floor triangles $extra" >&2
    rm -f "$work/$name.bbc" "$work/$name.json"
    status=ok
    # shellcheck disable=SC2086
    (ulimit -v $((memory_gb * 1024 * 1024)) &&
      exec /usr/bin/time -f '%U %S %e %M' -o "$work/$name.time" \
        timeout "$timeout" "$pre" "$work/$name.gltf" -o "$work/$name.bbc" --chains "$chain" \
        --threads 1 --no-progress --json "$work/$name.json" $extra) > "$work/$name.log" 2>&1 ||
      status=failed
    if [ $status = failed ]; then
      if grep -q "Command exited with non-zero status 124" "$work/$name.time"; then
        status="timeout ${timeout} s"
      elif grep -qi "out of memory" "$work/$name.log"; then
        status="out of memory (${memory_gb} GB)"
      else
        status="failed: $(grep -v '^Command' "$work/$name.log" | tail -1)"
      fi
    fi
    t=$(grep -v '^Command' "$work/$name.time" | tail -1)
    cpu=$(echo "$t" | awk '{ printf "%.2f", $1 + $2 }')
    wall=$(echo "$t" | awk '{ printf "%.1f", $3 }')
    rss=$(echo "$t" | awk '{ printf "%.0f", $4 / 1024 }')
    tuples=-
    mb=-
    if [ "$status" = ok ]; then
      tuples=$(field "$work/$name.json" tuples)
      mb=$(awk -v b="$(field "$work/$name.json" file_bytes)" 'BEGIN { printf "%.1f", b / 1048576 }')
    fi
    echo "$chain|$kind --size $size $extra|$floor|$status|$cpu|$wall|$rss|$tuples|$mb" >> "$rows"
  done
done

{
  echo "# Precompute cost against the receiver's tessellation"
  echo
  echo "\`sh bench/receivers.sh --floors \"$floors\" --memory-gb $memory_gb --timeout $timeout\`"
  echo "at $commit; $machine (load average $(cut -d' ' -f1-3 /proc/loadavg)); one thread."
  echo "The same caster over a floor of 2 triangles and over that floor as a flat grid in"
  echo "the same plane (\`bbc-scenegen --floor-size N\`); CPU-s are user + sys."
  echo
  echo "| chain | caster | floor triangles | status | CPU-s | wall s | peak RSS MB | tuples | cache MB |"
  echo "|---|---|---:|---|---:|---:|---:|---:|---:|"
  awk -F'|' '{ printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }' "$rows"
  echo
  echo "Largest floor against the floor of 2 triangles (the first and last row of each chain):"
  echo
  awk -F'|' '{ if (!($1 in first)) { first[$1] = $5; mb[$1] = $9; order[n++] = $1 }
               last[$1] = $5; lmb[$1] = $9 }
             END { for (i = 0; i < n; i++) { c = order[i]
                     if (first[c] > 0 && mb[c] > 0 && lmb[c] != "-")
                       printf "- %s: CPU-s %.2fx, cache %.2fx\n", c, last[c] / first[c], lmb[c] / mb[c]
                     else printf "- %s: not comparable (a run did not finish)\n", c } }' "$rows"
} > "$out/receivers.md"
cat "$out/receivers.md"
