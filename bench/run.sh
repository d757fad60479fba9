#!/bin/sh
# Regenerates the benchmark tables in bench/results/ (Markdown) on this machine:
#   precompute.md  precompute of the shared scenes: time by phase, tuples, pieces,
#                  peak memory, file size and compression of the cell lists; double
#                  refraction through the balls at the paper's levels (Table 3 bottom);
#   render.md      equal-time renders of the caustic alone: relMSE of bbc, uniform and
#                  enumerate against a converged enumeration.
# Usage: sh bench/run.sh [--single|--double] [SHARED_SCENES_DIR] [SECONDS_PER_RENDER]
#   --single  regenerates only the single-bounce table of precompute.md (planes and pools)
#             and keeps the rest of that file as it is; render.md is left alone.
#   --double  regenerates only the double-refraction table of precompute.md (the balls
#             and the slab) and keeps the rest of that file as it is; render.md is left
#             alone.
#   SHARED_SCENES_DIR  the folder of the shared scenes (plane1k.gltf...; a scene missing
#             from it is left out of the tables); when not given (or empty),
#             $BBC_SHARED_DIR/scenes (BBC_SHARED_DIR: the folder holding scenes/), else
#             ../shared/scenes beside the repository. Every table needs that folder:
#             without it the script says so in one line on stderr and exits 0, running
#             nothing and leaving bench/results/ as it is.
#   SECONDS_PER_RENDER  the time of each equal-time render of render.md (10 by default).
# Needs a Release build in build/ (sh scripts/build.sh).
set -eu
single=0
double=0
[ "${1:-}" = --single ] && { single=1; shift; }
[ "${1:-}" = --double ] && { double=1; shift; }
root=$(cd "$(dirname "$0")/.." && pwd)
tool=run.sh
. "$root/bench/lib.sh"
scenes=$(shared_scenes "${1:-}") || exit 0
seconds=${2:-10}
bin=$root/build
out=$root/bench/results
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"

machine() {
  cpu=$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //')
  echo "Machine: $cpu, $(nproc) cores, $(free -g | awk '/Mem:/ {print $2}') GiB; $(date -u +%Y-%m-%d)."
}

# json FIELD FILE: a number from bbc-precompute's --json output.
json() { sed -n "s/.*\"$1\": \([-0-9.e+]*\).*/\1/p" "$2"; }

# double_table: the double-refraction section's heading and table.
double_table() {
  echo "Double refraction (TT) through the balls at the paper's levels (Table 3 bottom) and the slab at"
  echo "its level (Table 2: tuples, memory); CPU s"
  echo "is the bounding threads' CPU time, the per-core figure, and process CPU s the whole run's"
  echo "user + system time. Paper: i9-13900KF, 32 threads."
  if [ $double = 1 ]; then
    echo "Measured by \`sh bench/run.sh --double\` at $(git -C "$root" rev-parse --short HEAD) on $(date -u +%Y-%m-%d),"
    echo "$(nproc) threads, load average $(cut -d' ' -f1-3 /proc/loadavg) at the start."
  fi
  echo
  echo "| scene | level | candidates | tuples | T2 per T1 | pos. pieces/tuple | irr. pieces/tuple | time s | CPU s | process CPU s | peak MB | file MB | paper |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
  for spec in ball80:4:15K,4.1s ball320:3:52K,7.1s ball1280:2:198K,17.5s ball5120:1:771K,47.1s \
    slab10k:1:127K,28.6MB; do
    s=${spec%%:*}; rest=${spec#*:}; level=${rest%%:*}; paper=${rest#*:}
    [ -f "$scenes/$s.gltf" ] || continue
    "$bin/bbc-precompute/bbc-precompute" "$scenes/$s.gltf" \
      -o "$work/$s.bbc" --json "$work/$s.json" --chains TT --max-level "$level" --no-progress
    cpu=$(awk -v a="$(json position_cpu_seconds "$work/$s.json")" \
      -v b="$(json irradiance_cpu_seconds "$work/$s.json")" 'BEGIN {printf "%.1f", a + b}')
    printf '| %s | %s | %s | %s | %.1f | %.1f | %.1f | %.2f | %s | %.1f | %.0f | %.1f | %s |\n' "$s" "$level" \
      "$(json candidate_tuples "$work/$s.json")" "$(json tuples "$work/$s.json")" \
      "$(json second_per_first "$work/$s.json")" "$(json position_pieces_per_tuple "$work/$s.json")" \
      "$(json irradiance_pieces_per_tuple "$work/$s.json")" "$(json seconds "$work/$s.json")" \
      "$cpu" "$(json process_cpu_seconds "$work/$s.json")" "$(json peak_memory_mb "$work/$s.json")" \
      "$(echo "$(json file_bytes "$work/$s.json")" | awk '{printf "%.1f", $1 / 1e6}')" \
      "$(echo "$paper" | tr ',' ' ')"
  done
}

if [ $double = 1 ]; then
  # Everything before the double-refraction section, the new section, and what follows
  # its table (earlier comparisons), as it was.
  {
    sed -n '/^Double refraction (TT)/q;p' "$out/precompute.md"
    double_table
    awk '/^Double refraction \(TT\)/ {s = 1} s == 1 && /^\|/ {s = 2} s == 2 && !/^\|/ {s = 3} s == 3' \
      "$out/precompute.md"
  } > "$work/precompute.md"
  mv "$work/precompute.md" "$out/precompute.md"
  cat "$out/precompute.md"
  exit 0
fi

{
  echo "# Precompute"
  echo
  machine
  echo "Command: \`bbc-precompute SCENE -o OUT.bbc --json S.json --chains CHAIN\` (defaults: level 10,"
  echo "sigma 1e-4, alpha 2, 512x512 grids, remainder variables on), $(nproc) threads."
  echo
  echo "CPU s is user + system time of the whole run (process_cpu_seconds), the per-core figure;"
  echo "plane458k is \`bbc-scenegen wavy-plane --size 458000\` (the paper's largest plane, Table 3)."
  echo
  echo "| scene | chain | tuples | pos. pieces/tuple | irr. pieces/tuple | time s | CPU s | bounding s | recording s | peak MB | file MB | list compression |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
  "$bin/scenes/bbc-scenegen" wavy-plane --size 458000 -o "$work/plane458k.gltf" > /dev/null
  for s in plane1k plane7k plane28k plane458k pool4k pool20k; do
    dir=$scenes; [ $s = plane458k ] && dir=$work
    [ -f "$dir/$s.gltf" ] || continue
    chain=R; case $s in pool*) chain=T ;; esac
    "$bin/bbc-precompute/bbc-precompute" "$dir/$s.gltf" -o "$work/$s.bbc" --json "$work/$s.json" \
      --chains $chain --no-progress
    ratio=$("$bin/bbc-inspect/bbc-inspect" info "$work/$s.bbc" | sed -n 's/.*ratio[^0-9]*\([0-9.]*\).*/\1/p' | head -1)
    printf '| %s | %s | %s | %.1f | %.1f | %.2f | %.1f | %.2f | %.2f | %.0f | %.1f | %s |\n' "$s" "$chain" \
      "$(json tuples "$work/$s.json")" "$(json position_pieces_per_tuple "$work/$s.json")" \
      "$(json irradiance_pieces_per_tuple "$work/$s.json")" "$(json seconds "$work/$s.json")" \
      "$(json process_cpu_seconds "$work/$s.json")" \
      "$(json bounding_seconds "$work/$s.json")" "$(json recording_seconds "$work/$s.json")" \
      "$(json peak_memory_mb "$work/$s.json")" \
      "$(echo "$(json file_bytes "$work/$s.json")" | awk '{printf "%.1f", $1 / 1e6}')" "${ratio:-?}"
  done
  echo
  if [ $single = 1 ]; then
    # The rest of the file (double refraction and what follows) as it was.
    sed -n '/^Double refraction (TT)/,$p' "$out/precompute.md"
  else
    double_table
  fi
} > "$work/precompute.md"
mv "$work/precompute.md" "$out/precompute.md"
[ $single = 1 ] && { cat "$out/precompute.md"; exit 0; }

{
  echo "# Equal-time renders of the caustic"
  echo
  machine
  echo "Each method renders only the caustic estimator (\`--only caustics --max-depth 3\`)"
  echo "for ${seconds} s at 160 pixels wide; the reference is \`--method enumerate\` at 64 spp."
  echo "relMSE: mean over pixels of the mean over RGB of (I-R)^2/(R^2+0.01)."
  echo
  echo "| scene | method | seconds | spp | relMSE |"
  echo "|---|---|---|---|---|"
  for s in plane1k plane7k pool4k; do
    [ -f "$work/$s.bbc" ] || continue
    common="$scenes/$s.gltf --cache $work/$s.bbc --only caustics --max-depth 3 --width 160 --no-progress"
    # shellcheck disable=SC2086
    "$bin/bbc-render/bbc-render" $common --method enumerate --spp 64 --seed 1 -o "$work/$s-ref.exr"
    for m in bbc uniform enumerate; do
      # shellcheck disable=SC2086
      "$bin/bbc-render/bbc-render" $common --method $m --time "$seconds" --seed 2 \
        -o "$work/$s-$m.exr" --reference "$work/$s-ref.exr" --stats > "$work/out" 2> "$work/err"
      spp=$(sed -n 's/.*, \([0-9]*\) spp.*/\1/p' "$work/err" | head -1)
      t=$(sed -n 's/^time *\([0-9.]*\) s.*/\1/p' "$work/err" | head -1)
      printf '| %s | %s | %s | %s | %s |\n' "$s" "$m" "$t" "$spp" "$(sed -n 's/relMSE //p' "$work/out")"
    done
  done
} > "$out/render.md"
cat "$out/precompute.md" "$out/render.md"
