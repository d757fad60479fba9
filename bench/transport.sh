#!/bin/sh
# Light through more than two specular surfaces: the hollow glass sphere
# (`bbc-scenegen hollow-sphere`: outer and inner surfaces two closed meshes, every path
# through it to the floor refracts four times) and the glass of water (`bbc-scenegen
# glass-of-water`: a glass mesh, a water mesh reaching 0.005 into it), caustic only
# where the camera sees it directly (--only seen-caustics: what a light tracer sees),
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
#                         [--scenes "hollow water"] [--seeds "1 2"] [--povray-counts "..."]
#                         [--povray-depth 8] [--report]
#
# Each render's line is appended to bench/work/transport/SCENE.dat as it is measured;
# --report writes the results from those files as they stand without rendering (the
# results hold every scene with a .dat, whichever --scenes ran last). Besides the seeds,
# one long render with light tracing (16 x --spp, seed 1001) per scene: its relMSE,
# 16 x lower than the seeds' when it converges to the reference, not to something else,
# shows how much of the error is the render's noise. Scenes,
# caches and references are kept in bench/work/transport and reused while present
# (delete them after changing bbc-scenegen, bbc-precompute or bench/light_trace).
# Precompute: defaults, except for the --max-level given per scene in $levels below, and
# --allow-empty (the hollow sphere's cache holds no tuple: every path of one or two
# specular vertices through it is blocked by its inner sphere), under `ulimit -v 8000000`
# and a 900-second timeout.
# POV-Ray 3.7 photon mapping, the comparison users make (--povray-counts, default "250000
# 1000000 4000000"; "" for none): the scene translated by bench/povray_scene --any-chain
# --povray-depth (default 8: photons refract and reflect at the glass, Fresnel and total
# internal reflection, through up to 8 surfaces; POV-Ray splits a photon at every such
# surface instead of choosing a branch, so its stored photons double about every two
# surfaces: 0.10, 0.20, 0.41 and 2.0 million per 10^5 shot at depths 6, 8, 10 and 14 on the
# glass of water, 2, 4.3, 9.5 and 60 CPU-s), each count with gather radii of about 0.4 and
# 0.8 pixel footprints on the floor, 3x3 supersampling, --threads threads. Nested media
# follow POV-Ray's rule (the innermost interior entered), so the water's reach 0.005 into
# the glass is water there, where the reference makes it glass. Installs
# POV-Ray when missing (scripts/install-deps.sh --bench, as root).
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
povray_counts="250000 1000000 4000000"
povray_depth=8
radii="0.02 0.04"
depth=16 # bbc-render's default --max-depth: up to 14 specular vertices
while [ $# -gt 0 ]; do
  case $1 in
    --width) width=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --photons) photons=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --povray-counts) povray_counts=$2; shift 2 ;;
    --povray-depth) povray_depth=$2; shift 2 ;;
    --report) report=1; shift ;;
    *) echo "$tool: unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$work"
. "$root/bench/lib.sh"
if [ $report = 0 ]; then
  [ -z "$povray_counts" ] || sh "$root/scripts/install-deps.sh" --bench
  build_release "$root"
fi
bin=$root/build
height=$((width * 3 / 4)) # the scenes' cameras are 4:3
# scene name -> bbc-scenegen kind and precompute options
kind() { case $1 in hollow) echo hollow-sphere ;; water) echo glass-of-water ;; esac; }
levels=${BBC_TRANSPORT_LEVELS:-}

if [ $report = 0 ]; then
  for s in $scenes; do
    dat=$work/$s.dat
    : > "$dat"
    gltf=$work/$s.gltf
    [ -f "$gltf" ] || "$bin/scenes/bbc-scenegen" "$(kind $s)" -o "$gltf" > /dev/null
    cache=$work/$s.bbc
    if [ ! -f "$cache" ]; then
      lv=$(echo "$levels" | tr ' ' '\n' | sed -n "s/^$s://p")
      c=$( (ulimit -v 8000000; cpu "$work/$s-pre.log" timeout 900 "$bin/bbc-precompute/bbc-precompute" \
        "$gltf" -o "$cache.tmp" ${lv:+--max-level $lv} --threads "$threads" --no-progress \
        --allow-empty) )
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
    echo "$s ref2 - $(cut -d' ' -f1 "$work/$s-ref2-w$width.exr.cpu") $2 $4" | tee -a "$dat"
    for run in $seeds long; do
      for mode in on off alone; do
        seed=$run
        n=$spp
        if [ $run = long ]; then
          [ $mode = on ] || continue
          seed=1001
          n=$((16 * spp))
        fi
        # alone: light tracing without a cache, which needs no precompute.
        with="--cache $cache --light-trace $mode"
        [ $mode = alone ] && with="--light-trace on"
        # shellcheck disable=SC2086
        c=$(cpu "$work/render.log" "$bin/bbc-render/bbc-render" "$gltf" $with \
          --only seen-caustics --max-depth $depth --width "$width" --threads "$threads" \
          --spp "$n" --seed "$seed" --no-progress -o "$work/r.exr")
        cp "$work/r.exr" "$work/$s-$mode-$seed.exr"
        set -- $("$bin/bench/image_error" "$work/r.exr" "$ref")
        echo "$s $mode $seed $c $2 $4 $n" | tee -a "$dat"
      done
    done
    # POV-Ray.
    : > "$work/$s-pov.dat"
    mkdir -p "$work/pov"
    for count in $povray_counts; do
      for radius in $radii; do
        pov=$work/$s-pov.pov
        "$bin/bench/povray_scene" "$gltf" --width "$width" --height "$height" --photons "$count" \
          --radius "$radius" --any-chain "$povray_depth" -o "$pov"
        c=$(cd "$root" && povray_run "$pov")
        set -- $("$bin/bench/image_error" "$work/$s-pov.exr" "$ref")
        echo "$count $radius $c $2 $4" | tee -a "$work/$s-pov.dat"
      done
    done
  done
fi

out=$root/bench/results/transport.md
# Notes written by hand below the marker line of the results file are kept.
: > "$work/hand-notes"
[ -f "$out" ] && sed -n '/^<!-- by hand/,$p' "$out" > "$work/hand-notes"
{
  echo "# Light through more than two specular surfaces (bench/transport.sh)"
  echo
  echo "Caustic only (\`bbc-render SCENE --cache SCENE.bbc --only seen-caustics --max-depth $depth"
  echo "--width $width --threads $threads --spp $spp --seed S --light-trace on|off\`), ${width} px wide,"
  echo "against \`bench/light_trace SCENE --any-chain 14 --width $width --photons P --seed 1001\`."
  echo "POV-Ray 3.7: \`bench/povray_scene SCENE --width $width --height $height --photons N --radius R"
  echo "--any-chain $povray_depth\`, then \`povray +FE +W$width +H$height -D +WT$threads +A0.0 +AM1 +R3\`"
  echo "(photon mapping, 3x3 supersampling; see the script's header)."
  echo "Machine: $machine. CPU-s: user + sys."
  echo
  echo "The reference is independent of the renderer's media code: bench/light_trace"
  echo "--any-chain tracks the photon's medium by the parity of its crossings of each"
  echo "dielectric material's closed meshes (the highest index wins where two overlap: the"
  echo "water's reach into the glass is glass), so it never reads bbc_scene.media; a"
  echo "triangle's side only says whether it bounds the photon's medium there (glass met from"
  echo "behind by light in air passes, bbc's rule for cut-outs; here one landing photon in"
  echo "430,000 on the hollow sphere, by rounding, and none in the glass of water). It"
  echo "shares the scene loader, the ray intersector and the Fresnel formula. On bbc-scenegen glass-sphere with --no-fresnel it matches --chains TT"
  echo "(lit-mean ratio 0.9999, relMSE 1.8e-4 at 10^7 photons each, 160 px wide). Through the"
  echo "hollow sphere it crosses outer, inner, inner, outer surfaces (the cavity has even"
  echo "parity: air); through the glass of water, the water's wall inside the glass changes"
  echo "no medium and is crossed straight, and the glass's inner wall below the water line"
  echo "is a glass-water interface (1.5 / 1.33)."
  echo "\"1-2 specular vertices only\": the same tracer with --any-chain 2, a quarter of the"
  echo "photons; the most a cache of one- and two-vertex chains could hold. \"off\" renders the"
  echo "cache alone, without the Fresnel reflections off glass either; \"alone\" is light"
  echo "tracing without a cache (\`bbc-render SCENE --light-trace on\`, no precompute)."
  echo
  for s in hollow water; do
    [ -f "$work/$s.dat" ] || continue
    set -- $(cat "$work/$s-pre.cpu")
    echo "- $s (\`bbc-scenegen $(kind $s)\`): precompute $1 CPU-s (--max-level: $2);" \
      "reference $(cut -d' ' -f2 "$work/$s-ref14-w$width.exr.cpu") photons," \
      "$(cut -d' ' -f1 "$work/$s-ref14-w$width.exr.cpu") CPU-s"
  done
  echo
  echo "| scene | image | spp | seed | CPU-s | relMSE | lit-mean ratio |"
  echo "|---|---|---|---|---|---|---|"
  for s in hollow water; do
    [ -f "$work/$s.dat" ] || continue
    awk '{ if ($2 == "ref2") printf "| %s | reference, paths of 1-2 specular vertices only | - | - | %s (ref.) | %.3g | %.4f |\n", $1, $4, $5, $6;
           else if ($2 == "alone") printf "| %s | light tracing alone, no cache | %s | %s | %.1f | %.3g | %.4f |\n", $1, $7, $3, $4, $5, $6;
           else printf "| %s | --light-trace %s | %s | %s | %.1f | %.3g | %.4f |\n", $1, $2, $7, $3, $4, $5, $6 }' "$work/$s.dat"
    [ -s "$work/$s-pov.dat" ] &&
      awk -v s="$s" -v k="$povray_depth" '{ printf "| %s | POV-Ray, %.3g photons, radius %s, depth %s | - | - | %.1f | %.3g | %.4f |\n", s, $1, $2, k, $3, $4, $5 }' "$work/$s-pov.dat"
  done
  echo
  if [ -s "$work/hand-notes" ]; then
    echo
    cat "$work/hand-notes"
  else
    echo
    echo "<!-- by hand: the notes below this line are kept when bench/transport.sh rewrites this file -->"
  fi
} > "$out"
cat "$out"
