#!/bin/sh
# Fireflies at the glass ball's focus: ball320's caustic (TT, --max-level 3, --max-depth 4,
# caustic only) rendered by today's caustic estimator alone (--light-trace off) and by the
# estimator combined with light tracing (the default: cells with an unbounded tuple
# light-traced, docs/light-tracing.md), per seed: relMSE and lit-mean ratio against an
# independent light-traced reference (bench/light_trace, 10^9 photons unless --photons),
# and each render's CPU-seconds (user + sys). Writes bench/results/firefly.md.
#
#   sh bench/firefly.sh [--seeds "1 2 ... 32"] [--spp 256] [--width 320] [--photons N]
#                       [--threads 2] [--report] [SHARED_SCENES_DIR]
#
# Each seed's line is appended to bench/work/firefly/firefly.dat as it is measured;
# --report writes the results from that file as it stands (after a run cut short)
# without rendering.
# SHARED_SCENES_DIR as in bench/compare.sh (default $BBC_SHARED_DIR/scenes); without
# ball320 there the script says so in one line and exits 0. The precompute and the
# reference are kept in bench/work/firefly and reused while their inputs are unchanged.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=firefly.sh
work=$root/bench/work/firefly
scale=1
seeds=$(seq 1 32)
spp=256
width=320
photons=1000000000
threads=2
dir=
report=0
while [ $# -gt 0 ]; do
  case $1 in
    --seeds) seeds=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --width) width=$2; shift 2 ;;
    --photons) photons=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --report) report=1; shift ;;
    -*) echo "$tool: unknown option $1" >&2; exit 2 ;;
    *) dir=$1; shift ;;
  esac
done
mkdir -p "$work"
. "$root/bench/lib.sh"
scenes=$(shared_scenes "$dir" ball320.gltf) || exit 0
build_release "$root"
bin=$root/build
gltf=$scenes/ball320.gltf

cache=$work/ball320.bbc
if [ ! -f "$cache" ] || [ "$gltf" -nt "$cache" ]; then
  cpu "$work/pre.log" "$bin/bbc-precompute/bbc-precompute" "$gltf" -o "$cache" --chains TT \
    --max-level 3 --threads "$threads" --no-progress > "$work/pre.cpu"
fi
ref=$work/ref-w$width-$photons.exr
if [ ! -f "$ref" ]; then
  cpu "$work/ref.log" "$bin/bench/light_trace" "$gltf" --chains TT --width "$width" \
    --photons "$photons" --seed 1001 --threads "$threads" -o "$ref.tmp.exr" > "$ref.cpu"
  mv "$ref.tmp.exr" "$ref"
fi

dat=$work/firefly.dat
[ $report = 1 ] && seeds=
[ $report = 1 ] || : > "$dat"
for seed in $seeds; do
  for mode in off on; do
    c=$(cpu "$work/render.log" "$bin/bbc-render/bbc-render" "$gltf" --cache "$cache" \
      --only caustics --max-depth 4 --chains TT --width "$width" --threads "$threads" \
      --spp "$spp" --seed "$seed" --light-trace "$mode" --no-progress -o "$work/r.exr")
    set -- $("$bin/bench/image_error" "$work/r.exr" "$ref")
    echo "$seed $mode $c $2 $4" | tee -a "$dat"
  done
done

out=$root/bench/results/firefly.md
{
  echo "# Fireflies at the glass ball's focus (bench/firefly.sh)"
  echo
  echo "ball320, TT, level 3 (precompute $(cat "$work/pre.cpu") CPU-s), ${width} px wide, caustic"
  echo "only, $spp spp, $threads threads; reference: bench/light_trace, $photons photons"
  echo "($(cat "$ref.cpu") CPU-s). Machine: $machine. CPU-s: user + sys of each render."
  echo "\"off\": \`bbc-render --light-trace off\` (the caustic estimator alone); \"on\": the"
  echo "default (light tracing with the cells of unbounded tuples; per sample one photon per"
  echo "pixel from the cones and, after the first sample's pilot, up to as many aimed ones)."
  echo
  echo "| seed | off relMSE | off lit-mean | off CPU-s | on relMSE | on lit-mean | on CPU-s |"
  echo "|---|---|---|---|---|---|---|"
  awk '{ k = $1; if ($2 == "off") { o[k] = sprintf("%.3g | %.4f | %.1f", $4, $5, $3); keys[++n] = k }
         else on[k] = sprintf("%.3g | %.4f | %.1f", $4, $5, $3) }
       END { for (i = 1; i <= n; i++) printf "| %s | %s | %s |\n", keys[i], o[keys[i]], on[keys[i]] }' "$dat"
  echo
  awk '{ e[$2, ++n[$2]] = $4; s[$2] += $4; c[$2] += $3; l = $5 - 1; if (l < 0) l = -l;
         if (l > w[$2]) w[$2] = l }
       END { for (m = 0; m < 2; m++) { k = m ? "on" : "off"; if (!n[k]) continue;
               # the median by selection
               for (i = 1; i <= n[k]; i++) v[i] = e[k, i];
               for (i = 1; i <= n[k]; i++) for (j = i + 1; j <= n[k]; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
               med = n[k] % 2 ? v[(n[k] + 1) / 2] : (v[n[k] / 2] + v[n[k] / 2 + 1]) / 2;
               printf "- %s: %d seeds, mean relMSE %.3g, median %.3g, worst %.3g (%.1fx the median), worst lit-mean deviation %.2f %%, mean CPU-s %.1f\n",
                 k, n[k], s[k] / n[k], med, v[n[k]], v[n[k]] / med, 100 * w[k], c[k] / n[k] } }' "$dat"
} > "$out"
cat "$out"
