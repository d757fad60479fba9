#!/bin/sh
# bbc against POV-Ray 3.7 photon mapping on glass (issue 38): the caustic alone of ball320
# (TT, --max-level 3 as bench/firefly.sh), pool4k (T) and `bbc-scenegen glass-sphere --size
# 5120` (TT, --max-level 3 too: the two-bounce default since format 1.9; level 10, the
# default before, cost 355 CPU-s of precompute there, bench/results/max-level2.md),
# 320x240, 2 threads, against a light-traced reference
# (bench/light_trace, 10^9 photons unless --photons; checked by a second one of another
# seed, --check-photons).
# POV-Ray renders the scene translated by bench/povray_scene (dielectrics: ior, Fresnel
# transmittance 1 - F per interface, refraction photons only; see its header) over a grid of
# photon counts x fixed gather radii; bbc precomputes (precompute CPU-s counted) and renders
# with `bbc-render --only caustics` (default light tracing) at several --spp. Every run is
# timed in CPU-seconds (user + sys, /usr/bin/time) and scored by relMSE and lit-mean ratio
# (bench/image_error). The acceptance figure per scene: POV-Ray's CPU-s for its best relMSE
# over bbc's total CPU-s (precompute + render) to reach that relMSE, bbc's curve
# interpolated log-log (aim: >= 10). First, a calibration of the translation: on
# `bbc-scenegen glass-sphere --size 320` (TT), a long POV-Ray run (3 * 10^7 photons, small
# radii) against a light-traced reference (10^8 photons) must agree in lit-mean ratio to 1-2 %.
# Writes bench/results/povray-glass.md.
#
#   sh bench/povray-glass.sh [--photons N] [--check-photons N] [--counts "1000000 ..."]
#                            [--spp "1 2 4 ..."] [--threads 2] [--report] [SHARED_SCENES_DIR]
#   (BBC_BENCH_SCENES="ball320 pool4k glass-sphere-5120" limits the scenes to those named)
#
# SHARED_SCENES_DIR as in bench/compare.sh (default $BBC_SHARED_DIR/scenes); without ball320
# and pool4k there the script says so in one line and exits 0. References, POV-Ray renders
# (keyed by the content of the .pov file and the options) and precomputes are cached in
# bench/work/povray-glass; a precompute is redone when bbc-precompute or the scene is newer.
# Each scene's measurements are kept in bench/work/povray-glass/SCENE-*.dat; --report writes
# the results from those files without rendering. Installs POV-Ray when missing
# (scripts/install-deps.sh --bench, as root) and builds bbc (Release) in build/.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=povray-glass.sh
work=$root/bench/work/povray-glass
scale=1
photons=1000000000
check_photons=100000000
counts="1000000 3000000 10000000 30000000"
spps="1 2 4 8 16 32 64 128"
threads=2
width=320
height=240
dir=
report=0
while [ $# -gt 0 ]; do
  case $1 in
    --photons) photons=$2; shift 2 ;;
    --check-photons) check_photons=$2; shift 2 ;;
    --counts) counts=$2; shift 2 ;;
    --spp) spps=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --report) report=1; shift ;;
    -*) echo "$tool: unknown option $1" >&2; exit 2 ;;
    *) dir=$1; shift ;;
  esac
done
mkdir -p "$work"
. "$root/bench/lib.sh"
scenes=$(shared_scenes "$dir" ball320.gltf pool4k.gltf) || exit 0
bin=$root/build
if [ $report = 0 ]; then
  sh "$root/scripts/install-deps.sh" --bench
  for t in povray /usr/bin/time; do
    command -v "$t" > /dev/null || { echo "$tool: $t is missing" >&2; exit 1; }
  done
  build_release "$root"
fi
cd "$root" # POV-Ray's I/O restrictions let it write below the current folder only

# The scenes: name:chain:max-level (empty: the default):gather radii (comma-separated, about
# 0.1 to 1.5 pixel footprints on the floor).
specs="ball320:TT:3:0.0025,0.005,0.01,0.02 pool4k:T::0.005,0.01,0.02,0.04
  glass-sphere-5120:TT:3:0.0025,0.005,0.01,0.02"

err() { "$bin/bench/image_error" "$1" "$2" | awk '{ print $2, $4 }'; } # relMSE lit-mean

# reach FILE E: the least x at which the curve "x y" (sorted by x) falls to E, by log-log
# interpolation between its points ("<=" and its first x when its first point is already
# there; "never" when it does not fall to E within its points).
reach() {
  sort -g "$1" | awk -v E="$2" '
    { x[NR] = log($1); y[NR] = log($2) }
    END {
      le = log(E)
      if (y[1] <= le) { printf "<=%.4g", exp(x[1]); exit }
      for (i = 1; i < NR; i++)
        if (y[i + 1] <= le) {
          t = (le - y[i]) / (y[i + 1] - y[i])
          printf "%.4g", exp(x[i] + t * (x[i + 1] - x[i])); exit
        }
      printf "never"
    }'
}

mkdir -p "$work/pov"

# The calibration: glass-sphere --size 320, TT.
if [ $report = 0 ]; then
  cal=$work/cal-glass-sphere-320
  "$bin/scenes/bbc-scenegen" glass-sphere --size 320 -o "$cal.gltf" > /dev/null
  if [ ! -f "$cal-ref.exr" ]; then
    cpu "$work/ref.log" "$bin/bench/light_trace" "$cal.gltf" --chains TT --width $width \
      --photons 100000000 --seed 1001 --threads "$threads" -o "$cal-ref.tmp.exr" > "$cal-ref.cpu"
    mv "$cal-ref.tmp.exr" "$cal-ref.exr"
  fi
  : > "$cal.dat"
  for radius in 0.005 0.01; do
    p=$cal-pov-$radius.pov
    "$bin/bench/povray_scene" "$cal.gltf" --width $width --height $height --photons 30000000 \
      --radius $radius -o "$p"
    c=$(povray_run "$p")
    echo "30000000 $radius $c $(err "${p%.pov}.exr" "$cal-ref.exr")" | tee -a "$cal.dat"
  done
fi

for spec in $specs; do
  IFS=: read -r s chain level radii << EOF
$spec
EOF
  picked "$s" || continue
  [ $report = 1 ] && continue
  case $s in
    glass-sphere-5120)
      gltf=$work/$s.gltf
      "$bin/scenes/bbc-scenegen" glass-sphere --size 5120 -o "$work/$s.new.gltf" > /dev/null
      sed 's/"[^"]*\.new\.bin"/"'"$s"'.bin"/' "$work/$s.new.gltf" > "$work/$s.new.txt"
      rm "$work/$s.new.gltf"
      # Rewritten only when it changed, so that what is cached stays valid.
      if cmp -s "$work/$s.new.txt" "$gltf" && cmp -s "$work/$s.new.bin" "$work/$s.bin"; then
        rm "$work/$s.new.txt" "$work/$s.new.bin"
      else
        mv "$work/$s.new.bin" "$work/$s.bin"
        mv "$work/$s.new.txt" "$gltf"
      fi ;;
    *) gltf=$scenes/$s.gltf ;;
  esac
  depth=$((2 + ${#chain})) # the camera's segment, the receiver's and the chain's

  # The references: seed 1001 (the errors are against it) and seed 1002 (the check).
  for job in "$photons:1001" "$check_photons:1002"; do
    ref=$work/$s-ref-w$width-${job%:*}-${job#*:}.exr
    if [ ! -f "$ref" ]; then
      cpu "$work/ref.log" "$bin/bench/light_trace" "$gltf" --chains "$chain" --width $width \
        --photons "${job%:*}" --seed "${job#*:}" --threads "$threads" -o "$ref.tmp.exr" > "$ref.cpu"
      mv "$ref.tmp.exr" "$ref"
    fi
  done
  ref=$work/$s-ref-w$width-$photons-1001.exr
  chk=$work/$s-ref-w$width-$check_photons-1002.exr
  echo "$photons $(cat "$ref.cpu") $check_photons $(cat "$chk.cpu") $(err "$chk" "$ref")" \
    > "$work/$s-ref.dat"

  # POV-Ray: photon counts x gather radii.
  : > "$work/$s-pov.dat"
  for count in $counts; do
    for radius in $(echo "$radii" | tr , ' '); do
      p=$work/$s-pov-$count-$radius.pov
      "$bin/bench/povray_scene" "$gltf" --width $width --height $height --photons "$count" \
        --radius "$radius" -o "$p"
      c=$(povray_run "$p")
      stored=$(sed -n 's/.*Surface photons stored: *\([0-9]*\).*/\1/p' "${p%.pov}.log")
      echo "$count $radius $c $(err "${p%.pov}.exr" "$ref") ${stored:-?}" |
        tee -a "$work/$s-pov.dat"
    done
  done

  # bbc: the precompute (its CPU-s counted in every total), then renders at each --spp.
  cache=$work/$s.bbc
  if [ ! -f "$work/$s-pre.cpu" ] || [ "$bin/bbc-precompute/bbc-precompute" -nt "$cache" ] ||
    [ "$gltf" -nt "$cache" ]; then
    cpu "$work/$s-pre.log" "$bin/bbc-precompute/bbc-precompute" "$gltf" -o "$cache" \
      --chains "$chain" ${level:+--max-level $level} --threads "$threads" --no-progress \
      > "$work/$s-pre.cpu"
  fi
  pc=$(cat "$work/$s-pre.cpu")
  : > "$work/$s-bbc.dat"
  for spp in $spps; do
    c=$(cpu "$work/render.log" "$bin/bbc-render/bbc-render" "$gltf" --cache "$cache" \
      --only caustics --chains "$chain" --max-depth $depth --width $width --threads "$threads" \
      --spp "$spp" --seed "$spp" --no-progress -o "$work/$s-bbc-$spp.exr")
    total=$(awk -v a="$c" -v b="$pc" 'BEGIN { printf "%.3f", a + b }')
    echo "$spp $c $total $(err "$work/$s-bbc-$spp.exr" "$ref")" | tee -a "$work/$s-bbc.dat"
  done
done

# The report.
out=$root/bench/results/povray-glass.md
commit=${BBC_COMMIT:-$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)}
{
  echo "# bbc against POV-Ray 3.7 photon mapping on glass (bench/povray-glass.sh)"
  echo
  echo "Commit $commit; $machine; $(date -u +%Y-%m-%d). Caustic only, ${width}x$height, $threads"
  echo "threads. CPU-s: user + sys of each process (/usr/bin/time). relMSE and lit-mean ratio"
  echo "(bench/image_error) against a light-traced reference (\`bench/light_trace SCENE --chains"
  echo "CHAIN --width $width --photons P --seed 1001\`); a second reference of seed 1002 (fewer"
  echo "photons) measures its noise."
  echo
  echo "POV-Ray: \`bench/povray_scene SCENE --photons N --radius R\` (ior, Fresnel transmittance"
  echo "1 - F per interface by conserve_energy, refraction photons only, no direct light on the"
  echo "receivers, the camera seeing the receivers directly only), \`povray +FE +W$width +H$height"
  echo "+WT$threads +A0.0 +AM1 +R3\` (3x3 samples per pixel), photons gathered within the fixed"
  echo "radius R. bbc: \`bbc-precompute SCENE -o C.bbc --chains CHAIN [--max-level L] --threads"
  echo "$threads\`, then \`bbc-render SCENE --cache C.bbc --only caustics --chains CHAIN"
  echo "--max-depth D --width $width --threads $threads --spp N --seed N\` (D = 2 + the chain's"
  echo "length; default light tracing); total = precompute + render. \"bbc's CPU-s to reach it\":"
  echo "bbc's total CPU-s against relMSE, interpolated log-log at POV-Ray's best relMSE (\"<=\":"
  echo "already below it at the smallest spp)."
  echo
  cal=$work/cal-glass-sphere-320
  if [ -s "$cal.dat" ]; then
    echo "Calibration: \`bbc-scenegen glass-sphere --size 320\` (TT), POV-Ray with 3 * 10^7 photons"
    echo "against a light-traced reference of 10^8 photons ($(cat "$cal-ref.cpu") CPU-s):"
    echo
    echo "| photons (count) | radius | CPU-s | relMSE | lit-mean ratio |"
    echo "|---|---|---|---|---|"
    awk '{ printf "| %s | %s | %s | %.3g | %.4f |\n", $1, $2, $3, $4, $5 }' "$cal.dat"
    echo
    echo "Here POV-Ray's lit-mean ratio stays about 1 % below 1 at many photons, as it does on the"
    echo "flat mirror against its exact image (bench/results/compare.md: 0.987-0.988), while on"
    echo "glass-sphere 5120 below it reaches 1 within the noise. One known part: POV-Ray stores"
    echo "photon fluxes as RGBE with truncated mantissas (about -0.3 %). With few photons in the"
    echo "gather disk its lit-mean falls further (the tables below)."
    echo
  fi
  printf '%s' "| scene | POV-Ray best: relMSE, CPU-s (photons, radius, lit-mean) "
  printf '%s' "| bbc's CPU-s to reach it | ratio | bbc precompute CPU-s | bbc lit-mean ratios "
  echo "| reference: photons, CPU-s; check vs it: relMSE, lit-mean |"
  echo "|---|---|---|---|---|---|---|"
  for spec in $specs; do
    s=${spec%%:*}
    [ -f "$work/$s-bbc.dat" ] && [ -s "$work/$s-pov.dat" ] || continue
    set -- $(sort -g -k4 "$work/$s-pov.dat" | head -1)
    pe=$4
    pcpu=$3
    pov="$(printf '%.3g' "$4"), $3 ($1, $2, $(printf '%.4f' "$5"))"
    awk '{ print $3, $4 }' "$work/$s-bbc.dat" > "$work/$s-bbc.xy"
    r=$(reach "$work/$s-bbc.xy" "$pe")
    ratio=$(echo "$r" | awk -v p="$pcpu" '{ v = $1; sub(/^<=/, "", v); if (v == "never") print "-";
      else printf "%s%.1f", (substr($1, 1, 2) == "<=" ? ">=" : ""), p / v }')
    lits=$(awk '{ printf "%s%.3f", (NR > 1 ? ", " : ""), $5 }' "$work/$s-bbc.dat")
    refinfo=$(awk '{ printf "%s, %s; %.2g, %.4f (%s photons)", $1, $2, $5, $6, $3 }' \
      "$work/$s-ref.dat")
    echo "| $s | $pov | $r | **$ratio** | $(cat "$work/$s-pre.cpu") | $lits | $refinfo |"
  done
  for spec in $specs; do
    s=${spec%%:*}
    [ -f "$work/$s-bbc.dat" ] && [ -s "$work/$s-pov.dat" ] || continue
    IFS=: read -r s chain level radii << EOF
$spec
EOF
    echo
    echo "## $s ($chain${level:+, --max-level $level})"
    echo
    echo "POV-Ray:"
    echo
    echo "| photons (count) | stored | radius | CPU-s | relMSE | lit-mean ratio |"
    echo "|---|---|---|---|---|---|"
    awk '{ printf "| %s | %s | %s | %s | %.3g | %.4f |\n", $1, $6, $2, $3, $4, $5 }' \
      "$work/$s-pov.dat"
    echo
    echo "bbc (precompute $(cat "$work/$s-pre.cpu") CPU-s):"
    echo
    echo "| spp | render CPU-s | total CPU-s | relMSE | lit-mean ratio |"
    echo "|---|---|---|---|---|"
    awk '{ printf "| %s | %s | %s | %.3g | %.4f |\n", $1, $2, $3, $4, $5 }' "$work/$s-bbc.dat"
  done
} > "$out"
cat "$out"
