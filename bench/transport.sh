#!/bin/sh
# Light through more than two specular surfaces: the hollow glass sphere
# (`bbc-scenegen hollow-sphere`: outer and inner surfaces two closed meshes, every path
# through it to the floor refracts four times) and the glass of water (`bbc-scenegen
# glass-of-water`: a glass mesh, a water mesh reaching 0.005 into it), caustic only,
# rendered by bbc-render with light tracing (the default, docs/light-tracing.md) and
# without it (--light-trace off: the cached one- and two-vertex chains alone), each
# against an independent light-traced reference: bench/light_trace --any-chain K (every
# path of 1..K specular vertices, Fresnel reflections included, the media tracked by the
# photon's own crossings, not read from the scene's media: see bench/light_trace.c). Per
# image: relMSE, lit-mean ratio, CPU-s (user + sys). Also the part of the reference made
# of at most two specular vertices (--any-chain 2), which is what the cache can hold.
# Writes bench/results/transport.md.
#
#   sh bench/transport.sh [--width 160] [--spp 64] [--photons 2e8] [--threads 2]
#                         [--scenes "hollow water"] [--seeds "1 2"] [--report]
#
# Each render's line is appended to bench/work/transport/transport.dat as it is measured;
# --report writes the results from that file as it stands without rendering. Scenes,
# caches and references are kept in bench/work/transport and reused while present
# (delete them after changing bbc-scenegen, bbc-precompute or bench/light_trace).
# Precompute: defaults, except for the --max-level given per scene in $levels below,
# under `ulimit -v 8000000` and a 900-second timeout.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=transport.sh
work=$root/bench/work/transport
scale=1
width=160
spp=64
photons=2e8
threads=2
scenes="hollow water"
seeds="1 2"
report=0
depth=16 # bbc-render's default --max-depth: up to 14 specular vertices
while [ $# -gt 0 ]; do
  case $1 in
    --width) width=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --photons) photons=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --report) report=1; shift ;;
    *) echo "$tool: unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$work"
. "$root/bench/lib.sh"
build_release "$root"
bin=$root/build
dat=$work/transport.dat
# scene name -> bbc-scenegen kind and precompute options
kind() { case $1 in hollow) echo hollow-sphere ;; water) echo glass-of-water ;; esac; }
levels=${BBC_TRANSPORT_LEVELS:-}

if [ $report = 0 ]; then
  : > "$dat"
  for s in $scenes; do
    gltf=$work/$s.gltf
    [ -f "$gltf" ] || "$bin/scenes/bbc-scenegen" "$(kind $s)" -o "$gltf" > /dev/null
    cache=$work/$s.bbc
    if [ ! -f "$cache" ]; then
      lv=$(echo "$levels" | tr ' ' '\n' | sed -n "s/^$s://p")
      c=$( (ulimit -v 8000000; cpu "$work/$s-pre.log" timeout 900 "$bin/bbc-precompute/bbc-precompute" \
        "$gltf" -o "$cache.tmp" ${lv:+--max-level $lv} --threads "$threads" --no-progress) )
      mv "$cache.tmp" "$cache"
      echo "$c ${lv:-default}" > "$work/$s-pre.cpu"
    fi
    for k in 14 2; do
      p=$photons
      [ $k = 2 ] && p=$(awk -v p="$photons" 'BEGIN { printf "%.0f", p / 4 }')
      ref=$work/$s-ref$k-w$width.exr
      if [ ! -f "$ref" ]; then
        c=$(cpu "$work/$s-ref.log" "$bin/bench/light_trace" "$gltf" --any-chain $k --width "$width" \
          --photons "$p" --seed 1001 --threads "$threads" -o "$ref.tmp.exr")
        mv "$ref.tmp.exr" "$ref"
        echo "$c $p" > "$ref.cpu"
      fi
    done
    ref=$work/$s-ref14-w$width.exr
    set -- $("$bin/bench/image_error" "$work/$s-ref2-w$width.exr" "$ref")
    echo "$s ref2 - $(cut -d' ' -f1 "$ref.cpu") $2 $4" | tee -a "$dat"
    for seed in $seeds; do
      for mode in on off; do
        c=$(cpu "$work/render.log" "$bin/bbc-render/bbc-render" "$gltf" --cache "$cache" \
          --only caustics --max-depth $depth --width "$width" --threads "$threads" \
          --spp "$spp" --seed "$seed" --light-trace "$mode" --no-progress -o "$work/r.exr")
        cp "$work/r.exr" "$work/$s-$mode-$seed.exr"
        set -- $("$bin/bench/image_error" "$work/r.exr" "$ref")
        echo "$s $mode $seed $c $2 $4" | tee -a "$dat"
      done
    done
  done
fi

out=$root/bench/results/transport.md
{
  echo "# Light through more than two specular surfaces (bench/transport.sh)"
  echo
  echo "Caustic only (\`bbc-render SCENE --cache SCENE.bbc --only caustics --max-depth $depth"
  echo "--width $width --threads $threads --spp $spp --seed S --light-trace on|off\`), ${width} px wide,"
  echo "against \`bench/light_trace SCENE --any-chain 14 --width $width --photons P --seed 1001\`."
  echo "Machine: $machine. CPU-s: user + sys."
  echo
  for s in $scenes; do
    [ -f "$work/$s-pre.cpu" ] || continue
    set -- $(cat "$work/$s-pre.cpu")
    echo "- $s (\`bbc-scenegen $(kind $s)\`): precompute $1 CPU-s (--max-level $2);" \
      "reference $(cut -d' ' -f2 "$work/$s-ref14-w$width.exr.cpu") photons," \
      "$(cut -d' ' -f1 "$work/$s-ref14-w$width.exr.cpu") CPU-s"
  done
  echo
  echo "| scene | image | seed | CPU-s | relMSE | lit-mean ratio |"
  echo "|---|---|---|---|---|---|"
  awk '{ if ($2 == "ref2") printf "| %s | reference, at most 2 specular vertices | - | %s (ref.) | %.3g | %.4f |\n", $1, $4, $5, $6;
         else printf "| %s | light trace %s | %s | %.1f | %.3g | %.4f |\n", $1, $2, $3, $4, $5, $6 }' "$dat"
} > "$out"
cat "$out"
