#!/bin/sh
# The comparison benchmark: quality against CPU time of the caustic alone.
#
#   sh bench/compare.sh [--scale K] [--part all|flat|scenes] [--scenes DIR] [--width W]
#                       [--seeds "7 8 9 10 11 12 13 14"]
#   (BBC_BENCH_SCENES="plane1k pool4k" limits the shared scenes to those named)
#
# The shared scenes (part 2) are read from --scenes DIR, else from $BBC_SHARED_DIR/scenes
# (BBC_SHARED_DIR: the folder holding scenes/), else from ../shared/scenes beside the
# repository; that folder exists on some machines only. When it, or one of the scenes
# part 2 needs, is missing, part 2 is skipped with one line on stderr saying what is
# missing and how to provide it: --part all runs part 1 alone, --part scenes exits 0 at
# once (before installing or building anything).
#
# Every budget (method, spp) is rendered once per seed of --seeds (eight by default: one
# seed can be an outlier for every method), and reported by its mean relMSE and mean
# CPU-seconds over the seeds; every method uses the same seeds (the same camera samples).
#
# 1. flat mirror (bbc-scenegen flat-mirror, 100 triangles, 160x120, 2 threads): the exact
#    image (bench/flat_mirror_exact), POV-Ray 3.7 photon mapping of the scene translated
#    by bench/povray_scene (after a calibration of the translation on the direct light,
#    which must match the exact image to relMSE < 1e-6), and bbc (default precompute,
#    then bbc-render --only caustics at several --spp);
# 2. the shared scenes plane1k, plane7k, pool4k (one bounce) and ball320 (two, at
#    --max-level 3, --max-depth 4), W pixels wide (80 by default): bbc at 1-32 spp, uniform
#    and enumerate from 1 spp doubling until their mean CPU-seconds reach bbc's largest
#    (so that equal CPU is interpolated, not extrapolated), against a reference made by
#    light tracing (bench/light_trace: it shares nothing with bbc's cache and solvers, and
#    its pixels have a finite variance even at a caustic's focus); a second one from
#    another seed must agree with it ten times better than the smallest relMSE reported.
#    A long bbc render and a long enumeration are compared with it too: both must converge
#    to it. The light tracer is itself checked on the flat mirror against the exact image
#    (part 1). References are cached in bench/work/refs.
# Every run is timed in CPU-seconds (user + sys of the process, /usr/bin/time), not wall
# time: the machine may be shared. --scale K multiplies every budget (spp, photons,
# reference spp). Writes bench/results/compare.md, flat-mirror.png, scenes.png and the
# rows between the compare.sh markers in README.md and docs/numbers.md. Installs POV-Ray
# and gnuplot when missing (scripts/install-deps.sh --bench, as root) and builds bbc
# (Release) in build/.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
scale=1
part=all
scenes=
scene_width=80
seeds="7 8 9 10 11 12 13 14"
while [ $# -gt 0 ]; do
  case $1 in
    --scale) scale=$2; shift 2 ;;
    --part) part=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --width) scene_width=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    *) echo "usage: sh bench/compare.sh [--scale K] [--part all|flat|scenes] [--scenes DIR] [--width W] [--seeds \"S...\"]" >&2
       exit 1 ;;
  esac
done
case $part in all | flat | scenes) ;; *) echo "compare.sh: --part all, flat or scenes" >&2; exit 1 ;; esac
for k in $seeds; do
  case $k in *[!0-9]*) echo "compare.sh: --seeds takes non-negative integers" >&2; exit 1 ;; esac
done
nseeds=$(echo $seeds | wc -w)
[ "$nseeds" -gt 0 ] || { echo "compare.sh: --seeds is empty" >&2; exit 1; }
tool=compare.sh
. "$root/bench/lib.sh"

# The shared scenes of part 2: scene:chain:level:photons of a reference (light
# tracing):spp of the long bbc render and of the long enumeration.
shared_specs="plane1k:R::20000000:2048:128 plane7k:R::20000000:2048:128 pool4k:T::100000000:2048:512
  ball320:TT:3:100000000:2048:2048"
case $part in
  all | scenes)
    needed=
    for spec in $shared_specs; do
      if picked "${spec%%:*}"; then needed="$needed ${spec%%:*}.gltf"; fi
    done
    # shellcheck disable=SC2086
    if ! scenes=$(shared_scenes "$scenes" $needed); then
      [ $part = scenes ] && exit 0
      part=flat
    fi ;;
esac

cd "$root" # POV-Ray's I/O restrictions let it write below the current folder only
sh "$root/scripts/install-deps.sh" --bench
for t in gnuplot povray /usr/bin/time; do
  command -v "$t" > /dev/null || { echo "compare.sh: $t is missing" >&2; exit 1; }
done
build_release "$root"
bin=$root/build
gen=$bin/scenes/bbc-scenegen
pre=$bin/bbc-precompute/bbc-precompute
ren=$bin/bbc-render/bbc-render
work=$root/bench/work
out=$root/bench/results
mkdir -p "$work/flat" "$work/scenes" "$work/refs" "$out"
# BBC_COMMIT names the commit measured when root is not a git checkout.
commit=${BBC_COMMIT:-$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)}
dirty=$(git -C "$root" status --porcelain --untracked-files=no -- libbbc bbc-render bbc-precompute \
  scenes 2> /dev/null | head -1)
[ -z "$dirty" ] || commit="$commit+changes"



err() { "$bin/bench/image_error" "$1" "$2"; }   # "relMSE R lit_mean_ratio Q"

# seeded PREFIX REF CMD...: runs CMD --seed K --stats -o PREFIX-K.exr (log PREFIX-K.log)
# for every K of the seeds, each against REF, keeping "seed CPU-s relMSE lit-mean
# solutions-per-solved-tuple" in PREFIX.seeds; prints the means over the seeds of the
# CPU-s, relMSE and lit-mean ratio, and the first seed's solutions per solved tuple.
seeded() {
  pfx=$1
  refimg=$2
  shift 2
  : > "$pfx.seeds"
  for k in $seeds; do
    c=$(cpu "$pfx-$k.log" "$@" --seed "$k" --stats -o "$pfx-$k.exr")
    e=$(err "$pfx-$k.exr" "$refimg" | awk '{ print $2, $4 }')
    sols=$(sed -n 's/.*, \([0-9.]*\) per solved tuple.*/\1/p' "$pfx-$k.log")
    echo "$k $c $e ${sols:-?}" >> "$pfx.seeds"
  done
  awk '{ c += $2; e += $3; q += $4; if (NR == 1) s = $5 }
    END { printf "%.3f %.4g %.6f %s", c / NR, e / NR, q / NR, s }' "$pfx.seeds"
}




# reach FILE E: the least x at which the curve "x y" (sorted by x) falls to E, by log-log
# interpolation between its points ("never" if it does not within them).
reach() {
  sort -g "$1" | awk -v E="$2" '
    { x[NR] = log($1); y[NR] = log($2) }
    END {
      le = log(E)
      if (y[1] <= le) { printf "%.3g", exp(x[1]); exit }
      for (i = 1; i < NR; i++)
        if (y[i + 1] <= le) {
          t = (le - y[i]) / (y[i + 1] - y[i])
          printf "%.3g", exp(x[i] + t * (x[i + 1] - x[i])); exit
        }
      printf "never"
    }'
}

flat_md=$work/flat/section.md
scenes_md=$work/scenes/section.md
readme_rows=$work/readme-rows.md

# ------------------------------------------------------------------------------------
# 1. The flat mirror.
flat() {
  d=$work/flat
  w=160
  h=120
  scene=$d/flat-mirror.gltf
  "$gen" flat-mirror -o "$scene" --size 100 > /dev/null
  "$bin/bench/flat_mirror_exact" "$scene" --width $w --height $h --caustic -o "$d/exact.exr" 2> "$d/exact.log"
  "$bin/bench/flat_mirror_exact" "$scene" --width $w --height $h --direct -o "$d/direct-exact.exr" 2> "$d/direct-exact.log"
  # povray_run POV ARGS...: renders POV to OUT.exr beside it and prints the CPU-seconds.
  # POV-Ray does not depend on bbc's code, so its renders are cached by the content of
  # the scene file and the arguments (bench/work/povray).
  mkdir -p "$work/povray"
  povray_run() {
    p=$1
    shift
    key=$work/povray/$( (cat "$p"; echo "$*") | md5sum | cut -c1-16)
    if [ ! -f "$key.cpu" ]; then
      cpu "$key.log" povray "+I$p" "+O$key.exr" +FE +W$w +H$h -D +WT2 -V "$@" > "$key.tmp"
      mv "$key.tmp" "$key.cpu"
    fi
    cp "$key.exr" "${p%.pov}.exr"
    cp "$key.log" "${p%.pov}.log"
    cat "$key.cpu"
  }

  # Calibration: the translated scene, lit directly (no mirror), one ray per pixel centre.
  "$bin/bench/povray_scene" "$scene" --width $w --height $h --direct -o "$d/direct.pov"
  povray_run "$d/direct.pov" -A > /dev/null
  set -- $(err "$d/direct.exr" "$d/direct-exact.exr")
  calibration=$2
  calibration_ratio=$4
  if ! awk -v e="$calibration" 'BEGIN { exit !(e < 1e-6) }'; then
    echo "compare.sh: the POV-Ray translation is off: relMSE $calibration >= 1e-6 on the direct light" >&2
    exit 1
  fi

  # The light tracer of part 2's references, against the exact caustic as a camera sees
  # it directly: its lit mean must be right to 0.5 %, its error fall as 1/photons.
  "$bin/bench/flat_mirror_exact" "$scene" --width $w --height $h --caustic --seen-directly \
    -o "$d/exact-seen.exr" 2> /dev/null
  : > "$d/light_trace.dat"
  for count in 10000000 40000000; do
    count=$(n $count)
    c=$(cpu "$d/lt-$count.log" "$bin/bench/light_trace" "$scene" --chains R --width $w --photons "$count" \
      --seed 1 --threads 2 -o "$d/lt-$count.exr")
    set -- $(err "$d/lt-$count.exr" "$d/exact-seen.exr")
    echo "$count $c $2 $4" >> "$d/light_trace.dat"
  done
  if ! awk '{ q = $4 - 1; if (q < 0) q = -q } END { exit !(q < 0.005) }' "$d/light_trace.dat"; then
    echo "compare.sh: light_trace is off on the flat mirror: lit-mean ratio $(tail -1 "$d/light_trace.dat" | cut -d' ' -f4)" >&2
    exit 1
  fi

  # POV-Ray photon mapping: photon counts x fixed gather radii, 3x3 antialiasing.
  : > "$d/povray.dat"
  for count in 300000 1000000 3000000 10000000 30000000; do
    count=$(n $count)
    for radius in 0.0025 0.005 0.01 0.02; do
      p=$d/pov-$count-$radius.pov
      "$bin/bench/povray_scene" "$scene" --width $w --height $h --photons "$count" --radius $radius -o "$p"
      c=$(povray_run "$p" +A0.0 +AM1 +R3)
      set -- $(err "${p%.pov}.exr" "$d/exact.exr")
      stored=$(sed -n 's/.*Surface photons stored: *\([0-9]*\).*/\1/p' "${p%.pov}.log")
      echo "$count $radius $c $2 $4 ${stored:-?}" >> "$d/povray.dat"
    done
  done

  # bbc: the default precompute, then renders of the caustic.
  pre_cpu=$(cpu "$d/pre.log" "$pre" "$scene" -o "$d/flat.bbc" --threads 2 --no-progress --json "$d/pre.json")
  tuples=$(sed -n 's/.*"tuples": \([0-9]*\).*/\1/p' "$d/pre.json" | head -1)
  : > "$d/bbc.dat"
  for spp in 1 2 4 8 16 32 64 128 256; do
    spp=$(n $spp)
    set -- $(seeded "$d/bbc-$spp" "$d/exact.exr" "$ren" "$scene" --cache "$d/flat.bbc" --only caustics \
      --width $w --height $h --threads 2 --spp "$spp" --no-progress)
    total=$(awk -v a="$1" -v b="$pre_cpu" 'BEGIN { printf "%.3f", a + b }')
    echo "$spp $1 $total $2 $3 $4" >> "$d/bbc.dat"
  done

  # Curves and acceptance figures.
  awk '{ print $3, $4 }' "$d/povray.dat" > "$d/povray.xy"
  awk '{ print $2, $4 }' "$d/bbc.dat" > "$d/bbc-render.xy"
  awk '{ print $3, $4 }' "$d/bbc.dat" > "$d/bbc-total.xy"
  best=$(sort -g -k4 "$d/povray.dat" | head -1)
  set -- $best
  pov_best_err=$4
  pov_best_cpu=$3
  pov_best="$1 photons, radius $2: relMSE $4 in $3 CPU-s (lit-mean ratio $5)"
  bbc_reach=$(reach "$d/bbc-total.xy" "$pov_best_err")
  solutions=$(awk '$1 == 16 || NR == 5 { print $6; exit }' "$d/bbc.dat")
  aim=$(awk '$3 <= 10 { e = $4; s = $1; c = $3 } END { if (s) printf "%s (%s spp, %s CPU-s)", e, s, c; else printf "none" }' "$d/bbc.dat")
  lit_worst=$(awk '{ q = $5 - 1; if (q < 0) q = -q; if (q > m) { m = q; v = $5 } } END { print v }' "$d/bbc.dat")

  gnuplot <<EOF
set terminal pngcairo size 900,600 font ",11"
set output "$out/flat-mirror.png"
set logscale xy
set format y "%.0e"
set xlabel "CPU-seconds (user + sys)"
set ylabel "relMSE against the exact image"
set title "Flat mirror caustic, 160x120 ($commit)"
set grid
set key outside right
plot for [r in "0.0025 0.005 0.01 0.02"] "< awk '\$2 == ".r." { print \$3, \$4 }' $d/povray.dat" \
       with linespoints title "POV-Ray, radius ".r, \
     "$d/bbc-render.xy" with linespoints lw 2 lc rgb "#c00000" title "bbc, render only", \
     "$d/bbc-total.xy" with linespoints lw 2 lc rgb "#000000" title "bbc, precompute + render"
EOF

  {
    echo "## Flat mirror against POV-Ray photon mapping"
    echo
    echo "bbc-scenegen flat-mirror --size 100 (a mirror of 100 triangles, reflectance 1, on a"
    echo "floor of albedo 0.8 under a 10 W/sr point light), ${w}x${h}, caustic only, 2 threads."
    echo "Exact image: bench/flat_mirror_exact (the floor lit by the mirrored light, seen directly"
    echo "and in the mirror, box-filtered over each pixel by Gauss-Legendre quadrature; 8 against"
    echo "16 nodes: $(sed -n 's/.*nodes: //p' "$d/exact.log"))."
    echo
    echo "Calibration (bench/povray_scene --direct: the floor lit by the light alone, one ray per"
    echo "pixel centre, POV-Ray's EXR output): relMSE **$calibration** against the exact direct image"
    echo "(must be < 1e-6), lit-mean ratio $calibration_ratio."
    echo
    echo "The light tracer that makes the references of the shared scenes (bench/light_trace,"
    echo "below) against the exact caustic where the camera sees the floor directly (the floor in"
    echo "the mirror left out, bench/flat_mirror_exact --seen-directly); its lit-mean ratio must be"
    echo "within 0.5 % of 1:"
    echo
    echo "| photons | CPU-s | relMSE | lit-mean ratio |"
    echo "|---|---|---|---|"
    awk '{ printf "| %s | %s | %.3g | %.5f |\n", $1, $2, $3, $4 }' "$d/light_trace.dat"
    echo
    echo "POV-Ray: \`povray +FE +W$w +H$h +WT2 +A0.0 +AM1 +R3\` (3x3 supersampling of every pixel),"
    echo "photons shot at the mirror, gathered within a fixed radius (\`gather 0, 1000000\`,"
    echo "\`expand_thresholds 0, 0\`), no direct light on the floor (a light group without lights)."
    echo
    echo "| photons (count) | stored | radius | CPU-s | relMSE | lit-mean ratio |"
    echo "|---|---|---|---|---|---|"
    awk '{ printf "| %s | %s | %s | %s | %.3g | %.4f |\n", $1, $6, $2, $3, $4, $5 }' "$d/povray.dat"
    echo
    echo "bbc: \`bbc-precompute SCENE -o C.bbc --threads 2\` (defaults):"
    echo "**$pre_cpu CPU-s**, $tuples tuples; then"
    echo "\`bbc-render SCENE --cache C.bbc --only caustics --width $w --height $h --threads 2 --spp N --seed K\`"
    echo "for each seed K of $seeds: CPU-s, relMSE and lit-mean ratio are means over the seeds."
    echo
    echo "| spp | render CPU-s | total CPU-s | relMSE | lit-mean ratio | solutions per solved tuple |"
    echo "|---|---|---|---|---|---|"
    awk '{ printf "| %s | %s | %s | %.3g | %.6f | %s |\n", $1, $2, $3, $4, $5, $6 }' "$d/bbc.dat"
    echo
    echo "- POV-Ray's best: $pov_best."
    echo "- bbc reaches that relMSE at **$bbc_reach CPU-s** in total (precompute + render)."
    echo "- bbc's best relMSE within 10 CPU-s in total: $aim (aim: <= 2e-6)."
    echo "- bbc's lit-mean ratio furthest from 1: $lit_worst (limit: within 0.1 %)."
    echo "- Solutions per solved tuple (16 spp): $solutions (aim: >= 0.5)."
    echo
    echo "Curves: bench/results/flat-mirror.png."
  } > "$flat_md"
  {
    awk -v e="$pov_best_err" -v c="$pov_best_cpu" -v p="$pre_cpu" -v r="$bbc_reach" '
      $3 <= 10 { best = sprintf("%.2g at %s CPU-s in total (%s spp)", $4, $3, $1) }
      END { printf "| flat mirror (vs exact) | POV-Ray photon mapping, best: %.2g in %s CPU-s | precompute %s CPU-s; POV-Ray'"'"'s best reached at %s CPU-s in total; %s (means of '"$nseeds"' seeds) |\n", e, c, p, r, best }' "$d/bbc.dat"
  } > "$work/flat/readme-row.md"
}

# ------------------------------------------------------------------------------------
# 2. The shared scenes: bbc, uniform and enumerate against two enumeration references.
scenes_part() {
  d=$work/scenes
  w=$scene_width
  : > "$d/summary.dat"
  for spec in $shared_specs; do
    s=${spec%%:*}
    picked "$s" || continue
    set -- $(echo "$spec" | awk -F: '{ for (i = 1; i <= NF; i++) printf "%s ", ($i == "" ? "-" : $i) }')
    chain=$2
    level=$3
    [ "$level" = - ] && level=
    photons=$(n "$4")
    refspp=$(n "$5")
    chkspp=$(n "$6")
    gltf=$scenes/$s.gltf
    # The precompute, reused while the cache is newer than bbc-precompute and the scene.
    if [ -f "$d/$s-pre.cpu" ] && [ "$d/$s.bbc" -nt "$pre" ] && [ "$d/$s.bbc" -nt "$gltf" ]; then
      pc=$(cat "$d/$s-pre.cpu")
    else
      pc=$(cpu "$d/$s-pre.log" "$pre" "$gltf" -o "$d/$s.bbc" --chains "$chain" ${level:+--max-level $level} \
        --threads 2 --no-progress --json "$d/$s-pre.json")
      echo "$pc" > "$d/$s-pre.cpu"
    fi
    # The camera path, the diffuse vertex and the chain's segments: 2 + its length.
    depth=$((2 + ${#chain}))
    # --chains: the renders count the reference's chain alone (light tracing would add the
    # Fresnel reflections off glass, which the reference leaves out).
    common="$gltf --cache $d/$s.bbc --only caustics --chains $chain --max-depth $depth --width $w"
    common="$common --threads 2 --no-progress"
    # The references: light tracing, seeds 1001 and 1002, and the long bbc and enumerate
    # renders (seed 1001), cached in bench/work/refs by the scene's content, the options
    # and the source of the light tracer (delete the renders' when the renderer's expected
    # image changes).
    sum=$(cat "$gltf" "${gltf%.gltf}.bin" 2> /dev/null | md5sum | cut -c1-8)
    ltsum=$(md5sum < "$root/bench/light_trace.c" | cut -c1-8)
    r=$work/refs/$s-$sum-w$w-d$depth
    for k in 1001 1002; do
      ref=$r-lt$ltsum-$chain-$photons-$k.exr
      if [ ! -f "$ref" ]; then
        c=$(cpu "$d/$s-ref.log" "$bin/bench/light_trace" "$gltf" --chains "$chain" --width $w \
          --photons "$photons" --seed $k --threads 2 -o "$ref.tmp.exr")
        mv "$ref.tmp.exr" "$ref"
        echo "$c" > "$ref.cpu"
      fi
    done
    for job in bbc:$refspp enumerate:$chkspp; do
      ref=$r-${job%%:*}-${job#*:}-1001.exr
      if [ ! -f "$ref" ]; then
        c=$(cpu "$d/$s-ref.log" "$ren" $common --method ${job%%:*} --spp "${job#*:}" --seed 1001 -o "$ref.tmp.exr")
        mv "$ref.tmp.exr" "$ref"
        echo "$c" > "$ref.cpu"
      fi
    done
    refa=$r-lt$ltsum-$chain-$photons-1001.exr
    set -- $(err "$refa" "$r-lt$ltsum-$chain-$photons-1002.exr")
    agree=$2
    agree_lit=$4
    # The long renders against the light tracing: both converge to it.
    set -- $(err "$r-bbc-$refspp-1001.exr" "$refa")
    check_err=$2
    check_lit=$4
    set -- $(err "$r-enumerate-$chkspp-1001.exr" "$refa")
    enum_err=$2
    enum_lit=$4
    refcpu=$(cat "$r-lt$ltsum-$chain-$photons-1001.exr.cpu" "$r-lt$ltsum-$chain-$photons-1002.exr.cpu" | awk '{ s += $1 } END { printf "%.0f", s }')
    chkcpu=$(cat "$r-bbc-$refspp-1001.exr.cpu" "$r-enumerate-$chkspp-1001.exr.cpu" | awk '{ s += $1 } END { printf "%.0f", s }')
    : > "$d/$s.dat"
    # bbc at 1-32 spp; the others from 1 spp, doubling until their mean CPU reaches bbc's
    # largest (at most 256 spp), so that equal CPU lies within every curve.
    top=$(n 32)
    bc=0
    for m in bbc uniform enumerate; do
      : > "$d/$s-$m.xy"
      spp=1
      while :; do
        set -- $(seeded "$d/$s-$m-$(n $spp)" "$refa" "$ren" $common --method $m --spp "$(n $spp)")
        echo "$m $(n $spp) $1 $2 $3 $4" >> "$d/$s.dat"
        echo "$1 $2" >> "$d/$s-$m.xy"
        if [ $m = bbc ]; then
          [ "$(n $spp)" -lt "$top" ] || break
        else
          awk -v c="$1" -v b="$bc" 'BEGIN { exit !(c < b) }' && [ $spp -lt 256 ] || break
        fi
        spp=$((spp * 2))
      done
      [ $m = bbc ] && bc=$1
    done
    # At equal CPU: the others interpolated at bbc's largest budget.
    be=$(tail -1 "$d/$s-bbc.xy" | cut -d' ' -f2)
    ue=$(interpolate "$d/$s-uniform.xy" "$bc")
    ee=$(interpolate "$d/$s-enumerate.xy" "$bc")
    smallest=$(awk '{ print $4 }' "$d/$s.dat" | sort -g | head -1)
    lit=$(awk '$1 == "bbc" { q = $5 } END { print q }' "$d/$s.dat")
    spp_slope() { awk -v m="$1" '$1 == m { print $2, $4 }' "$d/$s.dat" > "$d/slope.xy"; slope "$d/slope.xy"; }
    # Paired, seed by seed: bbc and uniform at bbc's largest spp (the same camera samples;
    # "wins of seeds, uniform's mean CPU-s there"), a check that the mean is not one seed's.
    paired="- - -"
    if [ -f "$d/$s-uniform-$top.seeds" ]; then
      paired=$(paste "$d/$s-bbc-$top.seeds" "$d/$s-uniform-$top.seeds" |
        awk '{ n++; w += ($3 < $8); c += $7 } END { printf "%d %d %.3f", w, n, c / n }')
    fi
    echo "$s $chain ${level:--} $pc $photons $refcpu $agree $smallest $bc $be $ue $ee $lit" \
      "$(spp_slope bbc) $(spp_slope uniform) $(spp_slope enumerate)" \
      "$refspp,$chkspp $chkcpu $check_err $enum_err $check_lit $enum_lit $agree_lit $paired" >> "$d/summary.dat"
  done

  gnuplot <<EOF
set terminal pngcairo size 1100,800 font ",10"
set output "$out/scenes.png"
set multiplot layout 2,2 title "Caustic only, $w px wide, relMSE against the reference ($commit)"
set logscale xy
set format y "%.0e"
set xlabel "render CPU-seconds (user + sys)"
set ylabel "relMSE"
set grid
set key top right
do for [s in "$(awk '{ printf "%s ", $1 }' "$d/summary.dat")"] {
  set title s
  plot "$d/".s."-bbc.xy" with linespoints lw 2 lc rgb "#c00000" title "bbc", \
       "$d/".s."-uniform.xy" with linespoints lc rgb "#0060c0" title "uniform", \
       "$d/".s."-enumerate.xy" with linespoints lc rgb "#008000" title "enumerate"
}
unset multiplot
EOF

  {
    echo "## bbc, uniform and enumerate on the shared scenes"
    echo
    echo "\`bbc-precompute SCENE -o C.bbc --chains CHAIN [--max-level L] --threads 2\`, then"
    echo "\`bbc-render SCENE --cache C.bbc --only caustics --chains CHAIN --max-depth D --width $w --threads 2"
    echo "--method M --spp N --seed K\` (D = 2 + the chain's length: the caustic path's segments), for"
    echo "each seed K of $seeds (every method the same seeds); CPU-s, relMSE and lit-mean"
    echo "ratio below are means over the seeds. bbc runs at 1-32 spp, uniform and enumerate from 1"
    echo "spp doubling until their mean CPU-s reach bbc's at 32 spp. References: light tracing"
    echo "(\`bench/light_trace SCENE --chains CHAIN --width $w --photons P --seed K\`, checked on the"
    echo "flat mirror above), seeds 1001 and 1002 (cached in bench/work/refs). Errors are against"
    echo "reference 1; the two agree to the \"refs agree\" relMSE, which must be ten times below the"
    echo "smallest relMSE reported. Convergence: a long bbc render and a long enumeration (seed 1001)"
    echo "against reference 1, beside the two references against each other: if both converge to"
    echo "the light tracing, their lit-mean ratios are 1 within the noise of the three."
    echo
    echo "| scene | chain | level | precompute CPU-s | reference photons | reference CPU-s (both) | refs agree: relMSE, lit-mean | smallest reported | ok | long spp bbc, enumerate (CPU-s) | long bbc vs reference: relMSE, lit-mean | long enumerate vs reference: relMSE, lit-mean |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
    awk '{ ok = ($7 * 10 <= $8) ? "yes" : "**no**"
           printf "| %s | %s | %s | %s | %s | %s | %.2g, %.4f | %.2g | %s | %s (%s) | %.2g, %.4f | %.2g, %.4f |\n", $1, $2, $3, $4, $5, $6, $7, $23, $8, ok, $17, $18, $19, $21, $20, $22 }' \
      "$d/summary.dat"
    echo
    echo "At equal render CPU (uniform and enumerate interpolated log-log at bbc's largest budget,"
    echo "extrapolated along 1/CPU beyond their ends):"
    echo
    echo "| scene | CPU-s | bbc | uniform | enumerate | uniform / bbc | enumerate / bbc | bbc below uniform, seed by seed | bbc lit-mean ratio | slopes bbc, uniform, enumerate |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    awk '{ paired = $24 == "-" ? "-" : sprintf("%s of %s (uniform %s CPU-s)", $24, $25, $26)
           printf "| %s | %s | %.3g | %.3g | %.3g | %.2f | %.2f | %s | %.4f | %s, %s, %s |\n", $1, $9, $10, $11, $12, $11 / $10, $12 / $10, paired, $13, $14, $15, $16 }' \
      "$d/summary.dat"
    echo
    echo "Seed by seed: in how many seeds bbc's relMSE at its largest budget is below uniform's at"
    echo "the same spp (the same camera samples; uniform's mean CPU-s there beside it), so that a"
    echo "ratio of means is not one seed's outlier. Slopes: of log relMSE against log spp over the"
    echo "budgets (-1: unbiased Monte Carlo with independent samples; a bias or a floor flattens"
    echo "it); bbc's lit-mean ratio at its largest budget."
    echo
    echo "All runs:"
    echo
    echo "| scene | method | spp | render CPU-s | relMSE | relMSE per seed | lit-mean ratio | solutions per solved tuple |"
    echo "|---|---|---|---|---|---|---|---|"
    while read -r s rest; do
      while read -r m spp rest; do
        per=$(awk '{ printf "%s%.2g", (NR > 1 ? " / " : ""), $3 }' "$d/$s-$m-$spp.seeds")
        echo "$m $spp $rest" | awk -v s="$s" -v per="$per" '{ printf "| %s | %s | %s | %s | %.3g | %s | %.4f | %s |\n", s, $1, $2, $3, $4, per, $5, $6 }'
      done < "$d/$s.dat"
    done < "$d/summary.dat"
    echo
    echo "Curves: bench/results/scenes.png."
  } > "$scenes_md"
  awk '{ paired = $24 == "-" ? "" : sprintf("; below uniform in %s of %s seeds", $24, $25)
         printf "| %s (vs light tracing) | at %s render CPU-s (mean of '"$nseeds"' seeds): uniform %.3g, enumerate %.3g | bbc %.3g (%.2fx below uniform, %.2fx below enumerate%s) |\n",
         $1, $9, $11, $12, $10, $11 / $10, $12 / $10, paired }' "$d/summary.dat" > "$work/scenes/readme-rows.md"
}

case $part in all | flat) flat ;; esac
case $part in all | scenes) scenes_part ;; esac

# ------------------------------------------------------------------------------------
# The report and the rows of README.md and docs/numbers.md (from whichever parts have been run).
# The flat mirror not run here and without its work files keeps what the results hold.
if [ ! -f "$flat_md" ] && [ -f "$out/compare.md" ]; then
  mkdir -p "$work/flat"
  sed -n '/^## Flat mirror/,/^## /p' "$out/compare.md" | sed '$d' > "$flat_md"
  [ -s "$flat_md" ] || rm -f "$flat_md"
  grep '^| flat mirror (vs exact)' "$root/README.md" > "$work/flat/readme-row.md" ||
    rm -f "$work/flat/readme-row.md"
fi
{
  echo "# Caustic quality against CPU time"
  echo
  echo "Generated by \`sh bench/compare.sh --scale $scale --seeds \"$seeds\"\` at commit $commit; $machine; $(date -u +%Y-%m-%d)."
  echo "CPU-s: user + sys of each process (/usr/bin/time), precompute counted separately."
  echo "relMSE: mean over pixels of the mean over RGB of (I - R)^2 / (R^2 + eps), eps = 1e-2"
  echo "(bbc_image_relmse, as \`bbc-render --reference\`). Lit-mean ratio: the image's mean over"
  echo "the pixels where the reference is lit, divided by the reference's mean there."
  echo
  [ -f "$flat_md" ] && cat "$flat_md" && echo
  [ -f "$scenes_md" ] && cat "$scenes_md"
} > "$out/compare.md"
{
  echo "<!-- compare.sh begin: regenerated by sh bench/compare.sh -->"
  echo "Caustic quality against CPU-seconds (\`bench/results/compare.md\`, commit $commit, 2 threads,"
  echo "relMSE with eps 1e-2; curves in bench/results/flat-mirror.png and scenes.png):"
  echo
  echo "| scene | others | bbc |"
  echo "|---|---|---|"
  [ -f "$work/flat/readme-row.md" ] && cat "$work/flat/readme-row.md"
  [ -f "$work/scenes/readme-rows.md" ] && cat "$work/scenes/readme-rows.md"
  echo "<!-- compare.sh end -->"
} > "$readme_rows"
# Both files carry the same rows: the README quotes them, docs/numbers.md discusses them.
for doc in README.md docs/numbers.md; do
  if grep -q '<!-- compare.sh begin' "$root/$doc"; then
    awk -v rows="$readme_rows" '
      /<!-- compare.sh begin/ { while ((getline l < rows) > 0) print l; close(rows); skip = 1; next }
      /<!-- compare.sh end/ { skip = 0; next }
      !skip { print }' "$root/$doc" > "$work/rows-doc.md"
    cp "$work/rows-doc.md" "$root/$doc"
  else
    echo "compare.sh: $doc has no compare.sh markers; rows left in $readme_rows" >&2
  fi
done
cat "$out/compare.md"
