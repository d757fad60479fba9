#!/bin/sh
# Caustics light tracing cannot see (under water, in a mirror) at equal CPU: relMSE against
# CPU-seconds of `bbc-render --light-trace on` (the default) and `--light-trace off`, caustic
# only, on
#   pool4k-direct  the shared pool4k (T), --max-depth 3: the caustic where the camera sees
#                  the floor directly (as bench/compare.sh renders it); reference:
#                  bench/light_trace (independent of bbc's cache and solvers);
#   pool4k-water   pool4k (T), --max-depth 4: also the floor seen through the water
#                  surface, which light tracing cannot reach (its photons add only to
#                  points the camera sees directly); reference: a long
#                  `--method enumerate --light-trace off` render;
#   mirror-pool    `bbc-scenegen mirror-pool` (RT, TR: a mirror above the water, one under
#                  it; the camera looks down through the water, so nothing is seen
#                  directly), --max-depth 5 (the camera's refraction and a mirror under the
#                  water before the diffuse point); reference: a long enumerate render as
#                  above, bench/light_trace seeing almost nothing of this caustic.
# Both modes render with --chains of the scene, so the photons count only those chain
# types (the same quantity as the estimator's). Each reference is made twice (seeds 1001
# and 1002); their relMSE against each other is reported (each one's own noise adds about
# half of it to every relMSE below). Every spp of --spp is rendered once per seed of
# --seeds; the figures are means over the seeds. "At equal CPU": the off curve
# interpolated log-log at the on curve's mean CPU-s (bench/lib.sh interpolate, along
# 1/CPU beyond its ends); a ratio off / on above 1 means light tracing costs nothing in
# quality there. Writes bench/results/equal-cpu.md.
#
#   sh bench/equal-cpu.sh [--spp "4 16 64 256"] [--seeds "1 2 3 4"] [--width 80]
#                         [--threads 1] [--ref-spp 4096] [--photons 1e8]
#                         [--cases "pool4k-direct pool4k-water mirror-pool"] [--report]
#                         [SHARED_SCENES_DIR]
#
# Each render's line is appended to bench/work/equal-cpu/CASE.dat as it is measured;
# --report writes the results from those files as they stand without rendering.
# SHARED_SCENES_DIR as in bench/compare.sh (default $BBC_SHARED_DIR/scenes); without
# pool4k there the pool4k cases are skipped (one line on stderr). Scenes, caches and
# references are kept in bench/work/equal-cpu and reused while present (delete them after
# changing bbc-scenegen, bbc-precompute, the renderer's estimator or bench/light_trace).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
tool=equal-cpu.sh
work=$root/bench/work/equal-cpu
scale=1
spps="4 16 64 256"
seeds="1 2 3 4"
width=80
threads=1
refspp=4096
photons=100000000
cases="pool4k-direct pool4k-water mirror-pool"
report=0
dir=
while [ $# -gt 0 ]; do
  case $1 in
    --spp) spps=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --width) width=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --ref-spp) refspp=$2; shift 2 ;;
    --photons) photons=$(awk -v p="$2" 'BEGIN { printf "%.0f", p }'); shift 2 ;;
    --cases) cases=$2; shift 2 ;;
    --report) report=1; shift ;;
    -*) echo "$tool: unknown option $1" >&2; exit 2 ;;
    *) dir=$1; shift ;;
  esac
done
mkdir -p "$work"
. "$root/bench/lib.sh"
build_release "$root"
bin=$root/build
ren=$bin/bbc-render/bbc-render
if ! scenes=$(shared_scenes "$dir" pool4k.gltf); then
  cases=$(echo $cases | tr ' ' '\n' | grep -v '^pool4k' | tr '\n' ' ')
fi

# spec CASE: "scene-file chains depth reference-kind"
spec() {
  case $1 in
    pool4k-direct) echo "$scenes/pool4k.gltf T 3 lt" ;;
    pool4k-water) echo "$scenes/pool4k.gltf T 4 enum" ;;
    mirror-pool) echo "$work/mirror-pool.gltf RT,TR 5 enum" ;;
    *) echo "$tool: unknown case $1" >&2; exit 2 ;;
  esac
}

for c in $cases; do
  spec "$c" > /dev/null || exit 2
done
for c in $cases; do
  set -- $(spec "$c")
  gltf=$1 chains=$2 depth=$3 refkind=$4
  [ $report = 1 ] && continue
  name=$(basename "$gltf" .gltf)
  if [ "$name" = mirror-pool ] && [ ! -f "$gltf" ]; then
    "$bin/scenes/bbc-scenegen" mirror-pool -o "$gltf" > /dev/null
  fi
  cache=$work/$name.bbc
  if [ ! -f "$cache" ] || [ "$gltf" -nt "$cache" ]; then
    cpu "$work/pre.log" "$bin/bbc-precompute/bbc-precompute" "$gltf" -o "$cache" --chains "$chains" \
      --threads "$threads" --no-progress > "$work/$name-pre.cpu"
  fi
  common="$gltf --cache $cache --only caustics --chains $chains --max-depth $depth --width $width --threads $threads --no-progress"
  for k in 1001 1002; do
    if [ $refkind = lt ]; then
      ref=$work/$c-ref-lt-w$width-$photons-$k.exr
      [ -f "$ref" ] || cpu "$work/ref.log" "$bin/bench/light_trace" "$gltf" --chains "$chains" \
        --width "$width" --photons "$photons" --seed $k --threads "$threads" -o "$ref.tmp.exr" > "$ref.cpu"
    else
      ref=$work/$c-ref-enum-w$width-$refspp-$k.exr
      [ -f "$ref" ] || cpu "$work/ref.log" "$ren" $common --method enumerate --light-trace off \
        --spp "$refspp" --seed $k -o "$ref.tmp.exr" > "$ref.cpu"
    fi
    [ -f "$ref" ] || mv "$ref.tmp.exr" "$ref"
  done
  dat=$work/$c.dat
  : > "$dat"
  for spp in $spps; do
    for seed in $seeds; do
      for mode in off on; do
        t=$(cpu "$work/render.log" "$ren" $common --spp "$spp" --seed "$seed" --light-trace "$mode" \
          --stats -o "$work/r.exr")
        added=$(sed -n 's/^photons *\([0-9]*\) traced, \([0-9]*\) added.*/\1 \2/p' "$work/render.log")
        set -- $("$bin/bench/image_error" "$work/r.exr" "${ref%-*}-1001.exr")
        echo "$spp $seed $mode $t $2 $4 ${added:-0 0}" | tee -a "$dat"
      done
    done
  done
done

# The report, from the .dat files.
out=$root/bench/results/equal-cpu.md
{
  echo "# Caustics under water and in a mirror at equal CPU (bench/equal-cpu.sh)"
  echo
  echo "Caustic only, $width px wide, $threads thread(s), seeds $seeds (figures are means over"
  echo "them); machine: $machine. CPU-s: user + sys of each render. \"on\": \`bbc-render\`'s"
  echo "default (light tracing, docs/light-tracing.md); \"off\": \`--light-trace off\`. Both with"
  echo "the case's --chains and --max-depth. Precompute \`bbc-precompute --chains C\` (defaults"
  echo "otherwise), not counted. \"off at on's CPU\": the off curve interpolated log-log at on's"
  echo "mean CPU-s; \"ratio\": that over on's relMSE (> 1: light tracing is better at equal CPU)."
  echo
  for c in $cases; do
    dat=$work/$c.dat
    [ -s "$dat" ] || continue
    set -- $(spec "$c")
    gltf=$1 chains=$2 depth=$3 refkind=$4
    name=$(basename "$gltf" .gltf)
    if [ $refkind = lt ]; then
      r=$work/$c-ref-lt-w$width-$photons
      what="bench/light_trace --chains $chains --photons $photons"
      note=""
    else
      r=$work/$c-ref-enum-w$width-$refspp
      what="bbc-render --method enumerate --light-trace off --spp $refspp"
      note=" It uses the renders' cache, so it is independent of the estimator's sampling but not of the precompute (bench/compare.sh checks a long enumeration against light tracing where the camera sees the caustic directly)."
    fi
    set -- $("$bin/bench/image_error" "$r-1002.exr" "$r-1001.exr")
    agree="relMSE $(printf %.2g "$2"), lit-mean ratio $(printf %.4f "$4")"
    refcpu=$(cat "$r-1001.exr.cpu")
    echo "## $c: $name, --chains $chains, --max-depth $depth"
    echo
    echo "Reference: \`$what --seed 1001\` ($refcpu CPU-s); the same with seed 1002 against it:"
    echo "$agree.$note Precompute $(cat "$work/$name-pre.cpu") CPU-s."
    echo
    echo "| spp | off CPU-s | off relMSE | off lit-mean | on CPU-s | on relMSE | on lit-mean | photons added / traced per render (on) | off at on's CPU | ratio |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    awk '{ k = $1 " " $3; n[k]++; t[k] += $4; e[k] += $5; l[k] += $6; a[k] += $8; p[k] += $7 }
      END { for (k in n) print k, t[k] / n[k], e[k] / n[k], l[k] / n[k], p[k] / n[k], a[k] / n[k] }' "$dat" | sort -k1,1n > "$work/means"
    awk '$2 == "off" { print $3, $4 }' "$work/means" > "$work/off.xy"
    awk '$2 == "on" { print $1, $3, $4, $5, $6, $7 }' "$work/means" | while read -r spp t e l p a; do
      set -- $(awk -v s="$spp" '$1 == s && $2 == "off" { print $3, $4, $5 }' "$work/means")
      oe=$(interpolate "$work/off.xy" "$t")
      awk -v s="$spp" -v ot="$1" -v oe0="$2" -v ol="$3" -v t="$t" -v e="$e" -v l="$l" -v p="$p" -v a="$a" -v oe="$oe" \
        'BEGIN { printf "| %s | %.3f | %.3g | %.4f | %.3f | %.3g | %.4f | %.0f / %.0f | %.3g | %.2f |\n", s, ot, oe0, ol, t, e, l, a, p, oe, oe / e }'
    done
    echo
    echo "Per seed (relMSE off / on):"
    echo
    awk '{ k = $1; v = sprintf("%.2g", $5); if ($3 == "off") o[k] = o[k] (o[k] == "" ? "" : ", ") v; else q[k] = q[k] (q[k] == "" ? "" : ", ") v; if (!(k in seen)) { seen[k] = 1; ks[++m] = k } }
      END { for (i = 1; i <= m; i++) printf "- %s spp: off %s; on %s\n", ks[i], o[ks[i]], q[ks[i]] }' "$dat"
    echo
  done
} > "$out"
cat "$out"
