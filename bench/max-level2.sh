#!/bin/sh
# How deep to subdivide two-bounce tuples (bbc-precompute --max-level2): for each level,
# the precompute's CPU-seconds and the render's relMSE at a fixed spp, against the
# references that bench/equal-cpu.sh, bench/povray-glass.sh and bench/transport.sh made
# (run those first; a case whose scene or reference is missing is skipped with one line
# on stderr). CPU-s: user + sys (/usr/bin/time).
#
#   sh bench/max-level2.sh [LEVEL...]        (default levels 1 2 3 4 5 10)
#
# Cases (caustic only, default light tracing):
#   mirror-pool  RT,TR seen in a mirror and under water, 80 px, 64 spp, seeds 1-4, one
#                thread, against a 4096-spp enumeration (bench/equal-cpu.sh);
#   ball320      TT, 320 px, 16 spp, seeds 1-2, 2 threads, against 10^9 photons
#                (bench/povray-glass.sh);
#   glass-sphere-5120  the same (bench/povray-glass.sh);
#   water        the glass of water, every chain (its cache TT), 160 px, 64 spp, seeds
#                1-2, 2 threads, --only seen-caustics, against 2x10^8 photons of up to
#                14 specular vertices (bench/transport.sh).
# Writes bench/results/max-level2.md; caches and images go to bench/work/max-level2.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=max-level2.sh
work=$root/bench/work/max-level2
scale=1
. "$root/bench/lib.sh"
levels=${*:-1 2 3 4 5 10}
mkdir -p "$work"
build_release "$root"
bin=$root/build
out=$root/bench/results/max-level2.md
shared=${BBC_SHARED_DIR:-$(cd "$root/.." && pwd)/shared}/scenes
ec=$root/bench/work/equal-cpu
pg=$root/bench/work/povray-glass
tr=$root/bench/work/transport

{
  echo "# How deep to subdivide two-bounce tuples (bench/max-level2.sh)"
  echo
  echo "Commit $(git -C "$root" rev-parse --short HEAD); $machine; $(date -u +%Y-%m-%d)."
  echo "\`bbc-precompute SCENE --chains C --max-level2 L --threads 2\`, then \`bbc-render"
  echo "--cache\` at a fixed spp (caustic only, default light tracing); means over the seeds."
  echo "CPU-s: user + sys. Level 3 is the default (before: 10, the one-bounce level)."
  echo
} > "$out"

# case NAME SCENE PRECOMPUTE-CHAINS RENDER-ARGS WIDTH SPP THREADS "SEEDS" REFERENCE
case_run() {
  name=$1 scene=$2 chains=$3 rargs=$4 width=$5 spp=$6 threads=$7 seeds=$8 ref=$9
  if [ ! -f "$scene" ] || [ ! -f "$ref" ]; then
    echo "$tool: skipped $name: no $scene or $ref (run the bench that makes them)" >&2
    return 0
  fi
  {
    echo "## $name"
    echo
    echo "\`--chains $chains\`; render \`$rargs --width $width --spp $spp --threads $threads\`,"
    echo "seeds $seeds; reference $(basename "$ref")."
    echo
    echo "| level | precompute CPU-s | render CPU-s | relMSE | relMSE per seed | lit-mean ratios |"
    echo "|---|---|---|---|---|---|"
  } >> "$out"
  for level in $levels; do
    cache=$work/$name-$level.bbc
    pre=$(cpu "$work/pre.log" "$bin/bbc-precompute/bbc-precompute" "$scene" -o "$cache" \
      --chains "$chains" --max-level2 "$level" --threads 2 --no-progress)
    cpus= errs= lits=
    for seed in $seeds; do
      # shellcheck disable=SC2086
      c=$(cpu "$work/render.log" "$bin/bbc-render/bbc-render" "$scene" --cache "$cache" \
        $rargs --width "$width" --spp "$spp" --threads "$threads" --seed "$seed" \
        -o "$work/r.exr")
      set -- $("$bin/bench/image_error" "$work/r.exr" "$ref")
      cpus="$cpus $c" errs="$errs $2" lits="$lits $4"
    done
    mean() { echo "$1" | awk '{ s = 0; for (i = 1; i <= NF; i++) s += $i; printf "%.3g", s / NF }'; }
    echo "| $level | $pre | $(mean "$cpus") | $(mean "$errs") |$(echo "$errs" | awk '{ for (i = 1; i <= NF; i++) printf " %.3g", $i }') |$lits |" |
      tee -a "$out"
  done
  echo >> "$out"
}

case_run mirror-pool "$ec/mirror-pool.gltf" RT,TR \
  "--only caustics --chains RT,TR --max-depth 5" 80 64 1 "1 2 3 4" \
  "$ec/mirror-pool-ref-enum-w80-4096-1001.exr"
case_run ball320 "$shared/ball320.gltf" TT "--only caustics --chains TT --max-depth 4" 320 16 2 \
  "1 2" "$pg/ball320-ref-w320-1000000000-1001.exr"
case_run glass-sphere-5120 "$pg/glass-sphere-5120.gltf" TT \
  "--only caustics --chains TT --max-depth 4" 320 16 2 "1 2" \
  "$pg/glass-sphere-5120-ref-w320-1000000000-1001.exr"
case_run water "$tr/water.gltf" TT "--only seen-caustics --max-depth 16" 160 64 2 "1 2" \
  "$tr/water-ref14-w160.exr"
echo "$tool: wrote $out" >&2
