#!/bin/sh
# An area light over the wavy plane, the paper's Fig. 15 set-up: the caustic by bbc (the
# area-light cache) against path tracing, in relMSE against CPU-seconds, both against a
# light-traced reference.
#
#   sh bench/area-plane.sh [--size N] [--width W] [--seeds "1 2 3"] [--scale K] [--no-long]
#
# 1. The light tracer (bench/light_trace) from an area light, against the exact image:
#    bbc-scenegen flat-mirror --size 8 --area-light 0.25 (the scene of
#    test_area_lights.area_flat_mirror_caustic_is_the_mirrored_emitter), 160x120, the
#    caustic seen directly (bench/flat_mirror_exact --caustic --seen-directly: Gauss-Legendre
#    over each pixel and over the mirrored emitter). Its lit-mean ratio must be 1 within
#    0.5 % and its relMSE must fall as 1/photons (4x the photons: 3 to 5.3x smaller).
# 2. bbc-scenegen wavy-plane --size N --area-light 0.5 (about N triangles, 7,000 by
#    default: the paper's Plane), bbc-precompute --area-lights --chains R --threads 2 (its
#    CPU-s reported apart; reused while the cache is newer than the tools), then the
#    caustic, W pixels wide (80 by default):
#      bbc: bbc-render --cache C --method bbc --only caustics --max-depth 3 at 1-64 spp;
#      pt:  bbc-render --method pt --only indirect --max-depth 3, from 1 spp doubling until
#           its mean CPU-s reach bbc's at 64 spp (at most 65536 spp);
#    each budget over every seed of --seeds, reported by its mean CPU-s and mean relMSE.
#    Then (unless --no-long) one pt render (the first seed) given about the CPU-s of bbc's
#    precompute and its largest render together, so that equal CPU counting the
#    precompute is measured, not only extrapolated.
#    At depth 3 pt's indirect light is exactly the caustic: camera -> floor -> mirror ->
#    emitter (integrator.c: "indirect" is light found after the first diffuse vertex, and
#    an emitter hit counts only after a camera or specular vertex; the emitter's base
#    colour is black; the floor is flat, so nothing else fits in three segments). bbc's
#    caustic at depth 3 is the same paths (one specular vertex, seen directly: a caustic
#    seen in the mirror needs four segments). Checked here: with the cache, the
#    path tracer skips exactly the emitter hits the estimator counts, so
#    `--method bbc --only indirect --max-depth 3` must be black while pt's is not.
#    Reference: bench/light_trace --chains R, seeds 1001 and 1002 (cached in
#    bench/work/refs); the two must agree ten times better than the smallest relMSE
#    reported. Two measures: relMSE with eps 1e-2 (as compare.sh), which on this dim
#    caustic (lit mean about 0.01) is nearly an absolute error, and relMSE' with
#    eps = 1e-2 (lit mean)^2, the relMSE of the images scaled to a lit mean of 1; a black
#    image's score is given for both.
# Cost at 81a98e8, one of the 2 cores busy with another job: 351 s wall in all (the
# precompute 162 CPU-s, 156 s wall; the long pt render 173 CPU-s; the references, cached,
# 22 more); at 26e828a at load 8-12 the precompute alone took 1012 s wall.
# CPU-s: user + sys of each process (/usr/bin/time); the load average is recorded. Writes
# bench/results/area-plane.md and area-plane.png (gnuplot, if installed:
# scripts/install-deps.sh --bench). Builds bbc (Release) in build/ if needed.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
size=7000
width=80
seeds="1 2 3"
scale=1
long=1
while [ $# -gt 0 ]; do
  case $1 in
    --size) size=$2; shift 2 ;;
    --width) width=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --scale) scale=$2; shift 2 ;;
    --no-long) long=0; shift ;;
    *) echo "usage: sh bench/area-plane.sh [--size N] [--width W] [--seeds \"S...\"] [--scale K] [--no-long]" >&2
       exit 1 ;;
  esac
done
for k in $seeds; do
  case $k in *[!0-9]*) echo "area-plane.sh: --seeds takes non-negative integers" >&2; exit 1 ;; esac
done
nseeds=$(echo $seeds | wc -w)
[ "$nseeds" -gt 0 ] || { echo "area-plane.sh: --seeds is empty" >&2; exit 1; }
command -v /usr/bin/time > /dev/null || { echo "area-plane.sh: /usr/bin/time is missing" >&2; exit 1; }
. "$root/bench/lib.sh"
build_release "$root"
bin=$root/build
gen=$bin/scenes/bbc-scenegen
pre=$bin/bbc-precompute/bbc-precompute
ren=$bin/bbc-render/bbc-render
lt=$bin/bench/light_trace
work=$root/bench/work/area-plane
refs=$root/bench/work/refs
out=$root/bench/results
mkdir -p "$work" "$refs" "$out"
tool=area-plane.sh
commit=${BBC_COMMIT:-$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)}
dirty=$(git -C "$root" status --porcelain --untracked-files=no -- libbbc bbc-render bbc-precompute \
  scenes bench/light_trace.c 2> /dev/null | head -1)
[ -z "$dirty" ] || commit="$commit+changes"
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
started=$(date +%s)

# err IMG REF [--eps E]: "relMSE R lit_mean_ratio Q reference_lit_mean M"
err() { "$bin/bench/image_error" "$@"; }

# seeded PREFIX REF CMD...: runs CMD --seed K -o PREFIX-K.exr for every seed K, each
# against REF, keeping "seed CPU-s relMSE lit-mean relMSE-scaled" in PREFIX.seeds (relMSE
# with eps 1e-2, and with eps = $eps2, see below); prints the means.
seeded() {
  pfx=$1
  refimg=$2
  shift 2
  : > "$pfx.seeds"
  for k in $seeds; do
    c=$(cpu "$pfx-$k.log" "$@" --seed "$k" -o "$pfx-$k.exr")
    e=$(err "$pfx-$k.exr" "$refimg" | awk '{ print $2, $4 }')
    e2=$(err "$pfx-$k.exr" "$refimg" --eps "$eps2" | awk '{ print $2 }')
    echo "$k $c $e $e2" >> "$pfx.seeds"
  done
  awk '{ c += $2; e += $3; q += $4; f += $5 } END { printf "%.3f %.4g %.6f %.4g", c / NR, e / NR, q / NR, f / NR }' "$pfx.seeds"
}



# ------------------------------------------------------------------------------------
# 1. The light tracer from an area light against the exact flat-mirror image.
fm=$work/flat-mirror-area.gltf
"$gen" flat-mirror --size 8 --area-light 0.25 -o "$fm" > /dev/null
"$bin/bench/flat_mirror_exact" "$fm" --width 160 --height 120 --caustic --seen-directly \
  -o "$work/flat-exact.exr" 2> "$work/flat-exact.log"
: > "$work/flat-lt.dat"
for count in 8000000 32000000; do
  count=$(n $count)
  c=$(cpu "$work/flat-lt-$count.log" "$lt" "$fm" --chains R --width 160 --photons "$count" --seed 1 \
    --threads 2 -o "$work/flat-lt-$count.exr")
  set -- $(err "$work/flat-lt-$count.exr" "$work/flat-exact.exr")
  echo "$count $c $2 $4" >> "$work/flat-lt.dat"
done
if ! awk '{ q = $4 - 1; if (q < 0) q = -q; if (q >= 0.005) bad = 1 }
    NR == 1 { e1 = $3 } NR == 2 { e2 = $3 }
    END { r = e1 / e2; exit !(!bad && r > 3 && r < 5.3) }' "$work/flat-lt.dat"; then
  echo "area-plane.sh: light_trace is off on the area-lit flat mirror:" >&2
  cat "$work/flat-lt.dat" >&2
  exit 1
fi
flat_ratio=$(awk 'NR == 1 { e1 = $3 } NR == 2 { printf "%.2f", e1 / $3 }' "$work/flat-lt.dat")

# ------------------------------------------------------------------------------------
# 2. The wavy plane under a 0.5 area light.
scene=$work/plane$size-area.gltf
"$gen" wavy-plane --size "$size" --area-light 0.5 -o "$scene" > /dev/null
# The mirror is an n x n grid of quads, n = round(sqrt(N / 2)) (bbc-scenegen's
# square_grid_side).
triangles=$(awk -v s="$size" 'BEGIN { k = int(sqrt(s / 2) + 0.5); if (k < 1) k = 1; print 2 * k * k }')
cache=$work/plane$size-area.bbc
# The precompute, reused while the cache is newer than bbc-precompute and the scene
# generator; CACHE.cpu keeps "CPU-s wall-s load-average-at-start date" of the run that made it.
if [ -f "$cache.cpu" ] && [ "$cache" -nt "$pre" ] && [ "$cache" -nt "$gen" ]; then
  pre_how="reused: made earlier by the same command"
else
  pload=$(cut -d' ' -f1 /proc/loadavg)
  if ! /usr/bin/time -f '%U %S %e' -o "$work/pre.time" "$pre" "$scene" -o "$cache" --area-lights \
    --chains R --threads 2 --no-progress --json "$work/pre.json" > "$work/pre.log" 2>&1; then
    echo "area-plane.sh: the precompute failed" >&2
    tail -5 "$work/pre.log" >&2
    exit 1
  fi
  awk -v l="$pload" -v d="$(date -u +%Y-%m-%dT%H:%MZ)" '{ printf "%.3f %.0f %s %s\n", $1 + $2, $3, l, d }' \
    "$work/pre.time" > "$cache.cpu"
  pre_how="made by this run"
fi
set -- $(cat "$cache.cpu")
pc=$1
pre_how="$pre_how, $4: $2 s wall, load average $3 at its start"
tuples=$("$bin/bbc-inspect/bbc-inspect" info "$cache" | sed -n 's/^tuples *\([0-9]*\).*/\1/p')
common="$scene --max-depth 3 --width $width --threads 2 --no-progress"

# The split: with the cache, the path tracer leaves out exactly the emitter hits the
# estimator counts, so the light after the first diffuse vertex at depth 3 is black; pt's
# is not. (image_error IMG IMG prints a lit-mean ratio of 0 when IMG has no lit pixel.)
"$ren" $common --cache "$cache" --method bbc --only indirect --spp 16 --seed 1 -o "$work/split-bbc.exr" \
  > /dev/null 2>&1
"$ren" $common --method pt --only indirect --spp 16 --seed 1 -o "$work/split-pt.exr" > /dev/null 2>&1
split_bbc=$(err "$work/split-bbc.exr" "$work/split-bbc.exr" | awk '{ print ($4 == 0) ? "black" : "**not black**" }')
split_pt=$(err "$work/split-pt.exr" "$work/split-pt.exr" | awk '{ print ($4 == 0) ? "**black**" : "lit" }')
[ "$split_bbc" = black ] && [ "$split_pt" = lit ] || {
  echo "area-plane.sh: the depth-3 split check failed (bbc indirect $split_bbc, pt indirect $split_pt)" >&2
  exit 1
}

# References: light tracing, seeds 1001 and 1002, cached by the scene's content, the
# options and the light tracer's source.
photons=$(n 20000000)
sum=$(cat "$scene" "${scene%.gltf}.bin" | md5sum | cut -c1-8)
ltsum=$(md5sum < "$root/bench/light_trace.c" | cut -c1-8)
r=$refs/plane$size-area-$sum-w$width-lt$ltsum-R-$photons
for k in 1001 1002; do
  if [ ! -f "$r-$k.exr" ]; then
    c=$(cpu "$work/ref.log" "$lt" "$scene" --chains R --width "$width" --photons "$photons" --seed $k \
      --threads 2 -o "$r-$k.tmp.exr")
    mv "$r-$k.tmp.exr" "$r-$k.exr"
    echo "$c" > "$r-$k.exr.cpu"
  fi
done
ref=$r-1001.exr
set -- $(err "$ref" "$r-1002.exr")
agree=$2
agree_lit=$4
# The caustic's radiance is small here (lit mean M about 0.01), so relMSE's eps of 1e-2
# outweighs R^2 almost everywhere and makes it an absolute error (a black image scores
# about 0.014). The second measure takes eps = 1e-2 M^2: the relMSE of the images scaled
# to a lit mean of 1.
set -- $(err "$ref" "$ref")
lit_mean=$6
eps2=$(awk -v m="$lit_mean" 'BEGIN { printf "%.6g", 0.01 * m * m }')
set -- $(err "$r-1002.exr" "$ref" --eps "$eps2")
agree2=$2
# A black image against the reference, for scale.
set -- $(err "$work/split-bbc.exr" "$ref")
black=$2
set -- $(err "$work/split-bbc.exr" "$ref" --eps "$eps2")
black2=$2
refcpu=$(cat "$r-1001.exr.cpu" "$r-1002.exr.cpu" | awk '{ s += $1 } END { printf "%.0f", s }')

# bbc at 1-64 spp, then pt from 1 spp doubling until its mean CPU-s reach bbc's largest.
: > "$work/runs.dat"
: > "$work/bbc.xy"
: > "$work/pt.xy"
: > "$work/bbc2.xy"
: > "$work/pt2.xy"
spp=1
while :; do
  s=$(n $spp)
  set -- $(seeded "$work/bbc-$s" "$ref" "$ren" $common --cache "$cache" --method bbc --only caustics --spp "$s")
  echo "bbc $s $1 $2 $3 $4" >> "$work/runs.dat"
  echo "$1 $2" >> "$work/bbc.xy"
  echo "$1 $4" >> "$work/bbc2.xy"
  bc=$1
  [ "$s" -lt "$(n 64)" ] || break
  spp=$((spp * 2))
done
spp=1
while :; do
  set -- $(seeded "$work/pt-$spp" "$ref" "$ren" $common --method pt --only indirect --spp "$spp")
  echo "pt $spp $1 $2 $3 $4" >> "$work/runs.dat"
  echo "$1 $2" >> "$work/pt.xy"
  echo "$1 $4" >> "$work/pt2.xy"
  awk -v c="$1" -v b="$bc" 'BEGIN { exit !(c < b) }' && [ $spp -lt 65536 ] || break
  spp=$((spp * 2))
done
# The long pt render: its spp from the rate of pt's largest budget.
long_line=""
if [ $long = 1 ]; then
  k=$(echo $seeds | cut -d' ' -f1)
  target=$(awk -v a="$pc" -v b="$bc" 'BEGIN { printf "%.3f", a + b }')
  lspp=$(awk -v t="$target" '$1 == "pt" { s = $2; c = $3 } END { printf "%d", s * t / c + 0.5 }' "$work/runs.dat")
  c=$(cpu "$work/pt-long.log" "$ren" $common --method pt --only indirect --spp "$lspp" --seed "$k" \
    -o "$work/pt-long.exr")
  set -- $(err "$work/pt-long.exr" "$ref")
  l1=$2
  l4=$4
  set -- $(err "$work/pt-long.exr" "$ref" --eps "$eps2")
  long_line="$lspp $c $l1 $l4 $k $target $2"
fi
smallest=$(awk '{ print $4 }' "$work/runs.dat" | sort -g | head -1)
ok=$(awk -v a="$agree" -v s="$smallest" 'BEGIN { print (a * 10 <= s) ? "yes" : "**no**" }')
smallest2=$(awk '{ print $6 }' "$work/runs.dat" | sort -g | head -1)
ok2=$(awk -v a="$agree2" -v s="$smallest2" 'BEGIN { print (a * 10 <= s) ? "yes" : "**no**" }')
# Slopes over the budgets whose image is not black (pt's first ones can be).
slope_of() { awk -v m="$1" -v c="$2" '$1 == m && $5 > 0 { print $2, $c }' "$work/runs.dat" > "$work/slope.xy"; slope "$work/slope.xy"; }
bbc_slope="$(slope_of bbc 4), $(slope_of bbc 6)"
pt_slope="$(slope_of pt 4), $(slope_of pt 6)"
bbc_lit=$(awk '$1 == "bbc" { q = $5 } END { print q }' "$work/runs.dat")
pt_lit=$(awk '$1 == "pt" { q = $5 } END { print q }' "$work/runs.dat")
# Equal CPU: pt interpolated at each of bbc's budgets, render alone and with the
# precompute added to bbc's side (pt extrapolated along 1/CPU beyond its last budget).
: > "$work/equal.dat"
while read -r m s c e q f; do
  [ "$m" = bbc ] || continue
  total=$(awk -v a="$c" -v b="$pc" 'BEGIN { printf "%.3f", a + b }')
  pe=$(interpolate "$work/pt.xy" "$c")
  pt_total=$(interpolate "$work/pt.xy" "$total")
  pf=$(interpolate "$work/pt2.xy" "$c")
  pf_total=$(interpolate "$work/pt2.xy" "$total")
  echo "$s $c $e $pe $total $pt_total $f $pf $pf_total" >> "$work/equal.dat"
done < "$work/runs.dat"
elapsed=$(( $(date +%s) - started ))
load_end=$(cut -d' ' -f1-3 /proc/loadavg)

if command -v gnuplot > /dev/null; then
  gnuplot <<EOF
set terminal pngcairo size 1200,500 font ",10"
set output "$out/area-plane.png"
set multiplot layout 1,2 title "Wavy plane ($triangles triangles) under a 0.5 area light, caustic, $width px wide ($commit); bbc's precompute ($pc CPU-s) not included"
set logscale xy
set format y "%.0e"
set xlabel "render CPU-seconds (user + sys)"
set grid
set key top right
set title "relMSE, eps 1e-2"
plot "$work/bbc.xy" with linespoints lw 2 lc rgb "#c00000" title "bbc", \
     "$work/pt.xy" with linespoints lw 2 lc rgb "#0060c0" title "path tracing", \
     $black with lines dt 2 lc rgb "#808080" title "black image"
set title "relMSE, eps 1e-2 x (lit mean)^2 = $eps2"
plot "$work/bbc2.xy" with linespoints lw 2 lc rgb "#c00000" title "bbc", \
     "$work/pt2.xy" with linespoints lw 2 lc rgb "#0060c0" title "path tracing", \
     $black2 with lines dt 2 lc rgb "#808080" title "black image"
unset multiplot
EOF
fi

{
  echo "# Area light on the wavy plane (the paper's Fig. 15 set-up): bbc against path tracing"
  echo
  echo "Generated by \`sh bench/area-plane.sh --size $size --width $width --seeds \"$seeds\" --scale $scale\`"
  echo "at commit $commit; $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(nproc) cores, shared"
  echo "(load average $load_start at the start, $load_end at the end); $(date -u +%Y-%m-%d); $elapsed s wall in all."
  echo "CPU-s: user + sys of each process (/usr/bin/time). relMSE: mean over pixels of the mean over"
  echo "RGB of (I - R)^2 / (R^2 + 1e-2) (bbc_image_relmse). Lit-mean ratio: the image's mean over the"
  echo "pixels where the reference is lit, over the reference's mean there."
  echo
  echo "## The light tracer from an area light, against the exact image"
  echo
  echo "\`bbc-scenegen flat-mirror --size 8 --area-light 0.25\` (the scene of test_area_lights), 160x120,"
  echo "the caustic seen directly: \`bench/flat_mirror_exact --caustic --seen-directly\` (Gauss-Legendre"
  echo "over each pixel, cut along the floor's and the emitter's shadow's edges, and over the mirrored"
  echo "emitter; $(sed -n 's/.*nodes: //p' "$work/flat-exact.log")) against"
  echo "\`bench/light_trace --chains R --width 160 --photons N --seed 1\`:"
  echo
  echo "| photons | CPU-s | relMSE | lit-mean ratio |"
  echo "|---|---|---|---|"
  awk '{ printf "| %s | %s | %.3g | %.5f |\n", $1, $2, $3, $4 }' "$work/flat-lt.dat"
  echo
  echo "4x the photons: relMSE $flat_ratio times smaller (1/photons: 4; must be 3-5.3), lit-mean ratio"
  echo "within 0.5 % of 1 (required)."
  echo
  echo "## The wavy plane"
  echo
  echo "\`bbc-scenegen wavy-plane --size $size --area-light 0.5\` ($triangles mirror triangles; a"
  echo "0.5 x 0.5 emitter facing down at the shared planes' light position), $width px wide."
  echo
  echo "- Precompute \`bbc-precompute --area-lights --chains R --threads 2\`: **$pc CPU-s**, $tuples tuples"
  echo "  ($pre_how)."
  echo "- bbc: \`bbc-render --cache C --method bbc --only caustics --max-depth 3\`; pt:"
  echo "  \`bbc-render --method pt --only indirect --max-depth 3\` (no cache); both \`--width $width"
  echo "  --threads 2 --spp N --seed K\` for K in $seeds; CPU-s and relMSE are means over the seeds."
  echo "  A render's CPU-s are its whole process: bbc's include mapping and checking the cache (about"
  echo "  1 CPU-s: its 1-spp runs), pt's loading the scene."
  echo "- The same light: at depth 3 pt's indirect light is the camera -> floor -> mirror -> emitter"
  echo "  paths. With the cache, \`--method bbc --only indirect --max-depth 3\` (16 spp) is $split_bbc"
  echo "  (the path tracer skips exactly the emitter hits the estimator counts), pt's is $split_pt."
  echo "- Reference: \`bench/light_trace --chains R --width $width --photons $photons\`, seeds 1001 and"
  echo "  1002 ($refcpu CPU-s both): they agree to relMSE $agree (lit-mean $agree_lit); the smallest"
  echo "  relMSE reported is $smallest, ten times above it: $ok."
  echo "- Two measures. relMSE with eps 1e-2 (the project's, as in compare.md): the caustic is dim"
  echo "  (lit mean $lit_mean per channel), so eps outweighs R^2 almost everywhere and this is nearly"
  echo "  an absolute error; a black image scores **$black**. relMSE' with eps = 1e-2 x (lit mean)^2 ="
  echo "  $eps2: the relMSE of the images scaled to a lit mean of 1; a black image scores **$black2**;"
  echo "  the references agree to $agree2 (smallest reported $smallest2, ten times above it: $ok2)."
  echo
  echo "At equal CPU (pt interpolated log-log between its budgets, extrapolated along 1/CPU beyond"
  echo "them), render alone and with bbc's precompute added to bbc's side:"
  echo
  echo "| bbc spp | bbc render CPU-s | bbc relMSE | pt relMSE | pt / bbc | bbc relMSE' | pt relMSE' | pt / bbc | bbc precompute + render CPU-s | pt relMSE, relMSE' at that CPU (extrapolated) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  awk '{ printf "| %s | %s | %.3g | %.3g | %.1f | %.3g | %.3g | %.1f | %s | %.3g, %.3g |\n", $1, $2, $3, $4, $4 / $3, $7, $8, $8 / $7, $5, $6, $9 }' \
    "$work/equal.dat"
  echo
  if [ -n "$long_line" ]; then
    set -- $long_line
    bbc_top=$(awk '$1 == "bbc" { e = $4 } END { print e }' "$work/runs.dat")
    bbc_top_spp=$(awk '$1 == "bbc" { s = $2 } END { print s }' "$work/runs.dat")
    bbc_top2=$(awk '$1 == "bbc" { e = $6 } END { print e }' "$work/runs.dat")
    echo "Equal CPU counting the precompute, measured: pt at $1 spp (seed $5, aimed at bbc's precompute +"
    echo "largest render, $6 CPU-s) took **$2 CPU-s**: relMSE **$(printf '%.3g' "$3")**, relMSE' **$(printf '%.3g' "$7")**"
    echo "(lit-mean ratio $4), against bbc's $(printf '%.3g' "$bbc_top") and $(printf '%.3g' "$bbc_top2") at $bbc_top_spp spp (mean of"
    echo "the seeds): pt / bbc $(awk -v a="$3" -v b="$bbc_top" 'BEGIN { printf "%.1f", a / b }') and $(awk -v a="$7" -v b="$bbc_top2" 'BEGIN { printf "%.1f", a / b }')."
    echo
  fi
  echo "Slopes of log relMSE (and relMSE') against log spp, over the budgets whose image is not black:"
  echo "bbc $bbc_slope, pt $pt_slope (-1: unbiased Monte Carlo with independent samples)."
  echo "Lit-mean ratio at the largest budget: bbc $bbc_lit, pt $pt_lit."
  echo
  echo "All runs:"
  echo
  echo "| method | spp | render CPU-s | relMSE | relMSE per seed | relMSE' | relMSE' per seed | lit-mean ratio |"
  echo "|---|---|---|---|---|---|---|---|"
  while read -r m s c e q f; do
    per=$(awk '{ printf "%s%.2g", (NR > 1 ? " / " : ""), $3 }' "$work/$m-$s.seeds")
    per2=$(awk '{ printf "%s%.2g", (NR > 1 ? " / " : ""), $5 }' "$work/$m-$s.seeds")
    printf '| %s | %s | %s | %.3g | %s | %.3g | %s | %.4f |\n' "$m" "$s" "$c" "$e" "$per" "$f" "$per2" "$q"
  done < "$work/runs.dat"
  [ -f "$out/area-plane.png" ] && { echo; echo "Curves: bench/results/area-plane.png."; }
} > "$out/area-plane.md"
cat "$out/area-plane.md"
