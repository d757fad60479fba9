#!/bin/sh
# The shared pool (pool4k, T) under a sun instead of its point light: bbc's cached caustic
# of the delta sun against the deterministic enumeration of all tuples and against an
# independent light-traced reference, and plain path tracing of the same pool with the sun
# given an angular size (0.53 degrees, the real sun's, and 2 degrees) against light-traced
# references of those disk suns, at equal render CPU. Writes bench/results/sun-pool.md.
#
#   sh bench/sun-pool.sh [--seeds "1 2 3"] [--photons N] [SHARED_SCENES_DIR]
#
# SHARED_SCENES_DIR is the folder of the shared scenes (pool4k.gltf and .bin); by default
# $BBC_SHARED_DIR/scenes (BBC_SHARED_DIR: the folder holding scenes/), else
# ../shared/scenes beside the repository, a folder that exists on some machines only.
# Without it (or without pool4k in it) part 1 is skipped with one line on stderr saying
# what is missing and how to provide it: part 0 still runs, its table is printed and the
# script exits 0, leaving bench/results/sun-pool.md as it is.
#
# 0. The light tracer's suns (bench/light_trace), checked on the flat mirror against the
#    exact image (bench/flat_mirror_exact --caustic --seen-directly, 160x120): a delta sun
#    and a 2-degree sun, 2M and 8M photons; the lit-mean ratio must be 1 within 0.5 % and
#    the relMSE must fall as 1/photons (4x the photons: 3 to 5.3x smaller).
# 1. The pool: the shared glTF with its light rewritten into a sun of 3 W/m^2 travelling
#    from the point light's position toward the origin, along (-0.120, -0.963, -0.241), and
#    two copies whose sun has extras.bbc.angular_diameter 0.53 and 2. One precompute
#    (--chains T) serves all three (the angular size is not in the cache's fingerprint).
#    Caustic only, 160 px wide, --max-depth 3, --threads 2:
#      bbc:  --cache C --method bbc --gamma 0.3 --only caustics, 4-256 spp, delta sun;
#      pt:   --method pt --only indirect, disk suns, from 4 spp doubling until its mean
#            CPU-s pass bbc's at 256 spp, and one render of 4096 spp per disk sun. At depth 3 pt's light after the first diffuse
#            vertex is exactly floor -> water -> sky within the disk (the floor is flat and
#            the water the only other mesh), the paths bbc's caustic counts; checked: with
#            the cache, --method bbc --only indirect is black (the split).
#    References: bench/light_trace --chains T, seeds 1001 and 1002 (cached in
#    bench/work/refs), one pair per sun; and bbc's --method enumerate at 256 spp for the
#    delta sun.
# CPU-s: user + sys of each process (/usr/bin/time). Needs a Release build in build/
# (sh scripts/build.sh; built here if missing).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
seeds="1 2 3"
photons=32000000
long_spp=4096
scenes=""
while [ $# -gt 0 ]; do
  case $1 in
    --seeds) seeds=$2; shift 2 ;;
    --photons) photons=$2; shift 2 ;;
    -*) echo "usage: sh bench/sun-pool.sh [--seeds \"S...\"] [--photons N] [SHARED_SCENES_DIR]" >&2; exit 1 ;;
    *) scenes=$1; shift ;;
  esac
done
tool=sun-pool.sh
. "$root/bench/lib.sh"
pool=1
scenes=$(shared_scenes "$scenes" pool4k.gltf pool4k.bin) || pool=0
command -v /usr/bin/time > /dev/null || { echo "sun-pool.sh: /usr/bin/time is missing" >&2; exit 1; }
build_release "$root"
bin=$root/build
gen=$bin/scenes/bbc-scenegen
ren=$bin/bbc-render/bbc-render
lt=$bin/bench/light_trace
work=$root/bench/work/sun-pool
refs=$root/bench/work/refs
out=$root/bench/results
mkdir -p "$work" "$refs" "$out"
scale=1
commit=$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)
dirty=$(git -C "$root" status --porcelain --untracked-files=no -- libbbc bbc-render bbc-precompute \
  scenes bench/light_trace.c bench/flat_mirror_exact.c 2> /dev/null | head -1)
[ -z "$dirty" ] || commit="$commit+changes"
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
started=$(date +%s)
err() { "$bin/bench/image_error" "$@"; }

# ------------------------------------------------------------------------------------
# 0. The light tracer's suns against the exact flat-mirror image.
: > "$work/flat.dat"
for angle in 0 2; do
  fm=$work/flat-mirror-sun$angle.gltf
  if [ "$angle" = 0 ]; then
    "$gen" flat-mirror --size 8 --sun 3 -o "$fm" > /dev/null
  else
    "$gen" flat-mirror --size 8 --sun 3 --sun-angle "$angle" -o "$fm" > /dev/null
  fi
  "$bin/bench/flat_mirror_exact" "$fm" --width 160 --height 120 --caustic --seen-directly \
    -o "$work/flat-exact-$angle.exr" 2> "$work/flat-exact-$angle.log"
  for count in 2000000 8000000; do
    c=$(cpu "$work/flat-lt.log" "$lt" "$fm" --chains R --width 160 --photons "$count" --seed 1 \
      --threads 2 -o "$work/flat-lt-$angle-$count.exr")
    set -- $(err "$work/flat-lt-$angle-$count.exr" "$work/flat-exact-$angle.exr")
    echo "$angle $count $c $2 $4" >> "$work/flat.dat"
  done
done
if ! awk '{ q = $5 - 1; if (q < 0) q = -q; if (q >= 0.005) bad = 1; e[NR] = $4 }
    END { for (i = 1; i < NR; i += 2) { r = e[i] / e[i + 1]; if (!(r > 3 && r < 5.3)) bad = 1 }
          exit bad }' "$work/flat.dat"; then
  echo "sun-pool.sh: light_trace is off on the sunlit flat mirror:" >&2
  cat "$work/flat.dat" >&2
  exit 1
fi
# flat_section: part 0's section of the report.
flat_section() {
  echo "## The light tracer's suns, against the exact image"
  echo
  echo "\`bbc-scenegen flat-mirror --size 8 --sun 3 [--sun-angle 2]\`, the caustic seen directly,"
  echo "160x120: \`bench/flat_mirror_exact --caustic --seen-directly\` against \`bench/light_trace"
  echo "--chains R --photons N --seed 1\`:"
  echo
  echo "| angular diameter | photons | CPU-s | relMSE | lit-mean ratio |"
  echo "|---|---|---|---|---|"
  awk '{ printf "| %s deg | %s | %s | %.3g | %.5f |\n", $1, $2, $3, $4, $5 }' "$work/flat.dat"
  echo
  echo "4x the photons: relMSE $(awk '{ e[NR] = $4 } END { printf "%.2f and %.2f", e[1] / e[2], e[3] / e[4] }' "$work/flat.dat") times"
  echo "smaller (1/photons: 4; must be 3-5.3), lit-mean ratios within 0.5 % of 1 (required)."
}
# Without the shared pool: part 0's table alone, on stdout (the skip was said above).
[ $pool = 1 ] || { flat_section; exit 0; }

# ------------------------------------------------------------------------------------
# 1. The pool under a delta sun and under disk suns.
cp "$scenes/pool4k.bin" "$work/"
# The node "light" gets the rotation taking -Z to the sun's direction; the light becomes
# directional.
sed -e 's/"type": "point",/"type": "directional",/' -e 's/"intensity": 50.0/"intensity": 3.0/' \
  -e 's/"name": "light",/"name": "light", "rotation": [-0.6113705335305231, 0.07642131669131538, 0.0, 0.7876457662463306],/' \
  "$scenes/pool4k.gltf" > "$work/pool4k-sun.gltf"
grep -q '"directional"' "$work/pool4k-sun.gltf"
angles="0.53 2"
for a in $angles; do
  sed "s/\"type\": \"directional\",/\"type\": \"directional\", \"extras\": {\"bbc\": {\"angular_diameter\": $a}},/" \
    "$work/pool4k-sun.gltf" > "$work/pool4k-sun-$a.gltf"
  grep -q "\"angular_diameter\": $a" "$work/pool4k-sun-$a.gltf"
done
delta=$work/pool4k-sun.gltf
cache=$work/sun.bbc
pc=$(cpu "$work/pre.log" "$bin/bbc-precompute/bbc-precompute" "$delta" -o "$cache" --chains T --threads 2 --no-progress)
tuples=$("$bin/bbc-inspect/bbc-inspect" info "$cache" | sed -n 's/^tuples *\([0-9]*\).*/\1/p')
common="--max-depth 3 --width 160 --threads 2 --no-progress"

# The split: with the cache, the path tracer skips the escapes the estimator counts.
# shellcheck disable=SC2086
"$ren" "$work/pool4k-sun-2.gltf" $common --cache "$cache" --method bbc --only indirect --spp 64 --seed 1 \
  -o "$work/split-bbc.exr" > /dev/null 2>&1
# shellcheck disable=SC2086
"$ren" "$work/pool4k-sun-2.gltf" $common --method pt --only indirect --spp 64 --seed 1 \
  -o "$work/split-pt.exr" > /dev/null 2>&1
split_bbc=$(err "$work/split-bbc.exr" "$work/split-bbc.exr" | awk '{ print ($4 == 0) ? "black" : "**not black**" }')
split_pt=$(err "$work/split-pt.exr" "$work/split-pt.exr" | awk '{ print ($4 == 0) ? "**black**" : "lit" }')
[ "$split_bbc" = black ] && [ "$split_pt" = lit ] || {
  echo "sun-pool.sh: the split check failed (bbc indirect $split_bbc, pt indirect $split_pt)" >&2
  exit 1
}

# References: light tracing, seeds 1001 and 1002, cached by the scene's content, the
# photons and the light tracer's source; and the enumeration for the delta sun.
ltsum=$(md5sum < "$root/bench/light_trace.c" | cut -c1-8)
refcpu=0
for a in 0 $angles; do
  scene=$delta
  [ "$a" = 0 ] || scene=$work/pool4k-sun-$a.gltf
  sum=$(cat "$scene" "$work/pool4k.bin" | md5sum | cut -c1-8)
  r=$refs/pool4k-sun-$sum-w160-lt$ltsum-T-$photons
  for k in 1001 1002; do
    if [ ! -f "$r-$k.exr" ]; then
      c=$(cpu "$work/ref.log" "$lt" "$scene" --chains T --width 160 --photons "$photons" --seed $k \
        --threads 2 -o "$r-$k.tmp.exr")
      mv "$r-$k.tmp.exr" "$r-$k.exr"
      echo "$c" > "$r-$k.exr.cpu"
    fi
  done
  refcpu=$(cat "$r-1001.exr.cpu" "$r-1002.exr.cpu" | awk -v s="$refcpu" '{ s += $1 } END { printf "%.0f", s }')
  cp "$r-1001.exr" "$work/ref-$a.exr"
  set -- $(err "$r-1002.exr" "$r-1001.exr")
  echo "$a $2 $4" > "$work/agree-$a"
done
# shellcheck disable=SC2086
enum_cpu=$(cpu "$work/enum.log" "$ren" "$delta" $common --cache "$cache" --method enumerate --only caustics --spp 256 --seed 1 \
  -o "$work/enum.exr")
set -- $(err "$work/enum.exr" "$work/ref-0.exr")
enum_vs_lt="$2 $4"
set -- $(err "$work/ref-0.53.exr" "$work/ref-0.exr")
disk053_vs_delta="$2 $4"
set -- $(err "$work/ref-2.exr" "$work/ref-0.exr")
disk2_vs_delta="$2 $4"
set -- $(err "$work/split-bbc.exr" "$work/ref-0.exr")
black=$2

# seeded PREFIX CMD...: runs CMD --seed K -o PREFIX-K.exr for every seed K; keeps "seed CPU-s"
# in PREFIX.seeds and prints the mean CPU-s.
seeded() {
  pfx=$1
  shift
  : > "$pfx.seeds"
  for k in $seeds; do
    c=$(cpu "$pfx-$k.log" "$@" --seed "$k" -o "$pfx-$k.exr")
    echo "$k $c" >> "$pfx.seeds"
  done
  awk '{ c += $2 } END { printf "%.3f", c / NR }' "$pfx.seeds"
}
# scored PREFIX REF: the means over the seeds of relMSE and lit-mean ratio against REF.
scored() {
  for k in $seeds; do err "$1-$k.exr" "$2"; done |
    awk '{ e += $2; q += $4 } END { printf "%.4g %.5f", e / NR, q / NR }'
}

: > "$work/runs.dat"
: > "$work/bbc.xy"
for s in 4 16 64 256; do
  # shellcheck disable=SC2086
  c=$(seeded "$work/bbc-$s" "$ren" "$delta" $common --cache "$cache" --method bbc --gamma 0.3 --only caustics --spp "$s")
  set -- $(scored "$work/bbc-$s" "$work/ref-0.exr")
  e_lt=$1
  q_lt=$2
  set -- $(scored "$work/bbc-$s" "$work/enum.exr")
  e_en=$1
  set -- $(scored "$work/bbc-$s" "$work/ref-0.53.exr")
  echo "bbc 0 $s $c $e_lt $q_lt $e_en $1" >> "$work/runs.dat"
  echo "$c $e_lt" >> "$work/bbc.xy"
  bc=$c
done
for a in $angles; do
  : > "$work/pt-$a.xy"
  spp=4
  while :; do
    # shellcheck disable=SC2086
    c=$(seeded "$work/pt-$a-$spp" "$ren" "$work/pool4k-sun-$a.gltf" $common --method pt --only indirect --spp "$spp")
    set -- $(scored "$work/pt-$a-$spp" "$work/ref-$a.exr")
    echo "pt $a $spp $c $1 $2 - -" >> "$work/runs.dat"
    echo "$c $1" >> "$work/pt-$a.xy"
    awk -v c="$c" -v b="$bc" 'BEGIN { exit !(c < b) }' && [ $spp -lt 65536 ] || break
    spp=$((spp * 2))
  done
done
# One long pt render per disk sun (the first seed), to see it converge.
: > "$work/long.dat"
k=$(echo $seeds | cut -d' ' -f1)
for a in $angles; do
  # shellcheck disable=SC2086
  c=$(cpu "$work/pt-long.log" "$ren" "$work/pool4k-sun-$a.gltf" $common --method pt --only indirect \
    --spp "$long_spp" --seed "$k" -o "$work/pt-long-$a.exr")
  set -- $(err "$work/pt-long-$a.exr" "$work/ref-$a.exr")
  echo "$a $long_spp $c $2 $4" >> "$work/long.dat"
done

# Equal CPU: for each bbc budget, the pt budget whose mean CPU-s is nearest (in ratio). Not
# interpolated: pt's relMSE is not monotone here (black at small budgets, then dominated
# by the rare paths that reach the disk).
nearest() {
  awk -v a="$1" -v c="$2" '$1 == "pt" && $2 == a { d = log($4 / c); if (d < 0) d = -d
      if (best == "" || d < best) { best = d; line = $3 " " $4 " " $5 " " $6 } }
    END { print line }' "$work/runs.dat"
}
: > "$work/equal.dat"
while read -r m a s c e q en e053; do
  [ "$m" = bbc ] || continue
  echo "$s $c $e $(nearest 0.53 "$c") $(nearest 2 "$c")" >> "$work/equal.dat"
done < "$work/runs.dat"
elapsed=$(( $(date +%s) - started ))
load_end=$(cut -d' ' -f1-3 /proc/loadavg)

{
  echo "# Sun over the shared pool (pool4k, T): bbc's delta sun and path tracing's disk suns"
  echo
  echo "Generated by \`sh bench/sun-pool.sh --seeds \"$seeds\" --photons $photons\` at commit $commit;"
  echo "$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(nproc) cores, shared (load average"
  echo "$load_start at the start, $load_end at the end); $(date -u +%Y-%m-%d); $elapsed s wall in all."
  echo "CPU-s: user + sys of each process (/usr/bin/time). relMSE: mean over pixels and RGB of"
  echo "(I - R)^2 / (R^2 + 1e-2). Lit-mean ratio: the image's mean over the pixels where the reference"
  echo "is lit, over the reference's mean there."
  echo
  flat_section
  echo
  echo "## The pool"
  echo
  echo "The shared pool4k with its light rewritten into a sun of 3 W/m^2 along (-0.120, -0.963, -0.241),"
  echo "and two copies whose sun has \`extras.bbc.angular_diameter\` 0.53 and 2 (degrees). Caustic only,"
  echo "160x120, \`--max-depth 3 --threads 2\`, seeds $seeds (means)."
  echo
  echo "- Precompute \`bbc-precompute --chains T --threads 2\` (delta sun; the same cache serves the"
  echo "  disk suns, whose angular size is not in the fingerprint): **$pc CPU-s**, $tuples tuples."
  echo "- bbc: \`--cache C --method bbc --gamma 0.3 --only caustics\`, the delta sun. pt: \`--method pt"
  echo "  --only indirect\` (no cache), the disk suns: at depth 3 its light after the first diffuse"
  echo "  vertex is floor -> water -> sky within the disk, the caustic. With the cache, \`--method bbc"
  echo "  --only indirect --spp 64\` on the 2-degree pool is $split_bbc (the path tracer skips the escapes the"
  echo "  estimator counts), pt's is $split_pt."
  echo "- References: \`bench/light_trace --chains T --width 160 --photons $photons\`, seeds 1001 and"
  echo "  1002 for each sun ($refcpu CPU-s in all); the two seeds agree to relMSE (lit-mean ratio):"
  echo "  $(awk '{ printf "%s deg %.2g (%.4f)", ($1 == 0 ? "delta" : $1), $2, $3 }' "$work/agree-0"),"
  echo "  $(awk '{ printf "%s deg %.2g (%.4f)", $1, $2, $3 }' "$work/agree-0.53"), $(awk '{ printf "%s deg %.2g (%.4f)", $1, $2, $3 }' "$work/agree-2")."
  echo "  bbc's enumeration (\`--method enumerate --spp 256\`, $enum_cpu CPU-s) against the delta sun's"
  echo "  light-traced reference: relMSE $(echo $enum_vs_lt | awk '{ printf "%.3g, lit-mean ratio %.4f", $1, $2 }')."
  echo "  The disk suns' references against the delta sun's: 0.53 deg $(echo $disk053_vs_delta | awk '{ printf "%.3g (lit-mean %.4f)", $1, $2 }'),"
  echo "  2 deg $(echo $disk2_vs_delta | awk '{ printf "%.3g (lit-mean %.4f)", $1, $2 }'): how far the delta sun is from them."
  echo "  A black image scores $black against the delta sun's reference."
  echo
  echo "### (a) bbc, delta sun: against enumeration and against the light-traced reference"
  echo
  echo "| spp | render CPU-s | relMSE vs light tracing | lit-mean ratio | relMSE vs enumeration | relMSE vs the 0.53-deg reference |"
  echo "|---|---|---|---|---|---|"
  awk '$1 == "bbc" { printf "| %s | %s | %.3g | %.4f | %.3g | %.3g |\n", $3, $4, $5, $6, $7, $8 }' "$work/runs.dat"
  echo
  echo "The last column is bbc's centre-direction caustic (what \`bbc-render\` draws for a disk sun:"
  echo "docs/lights.md) against the 0.53-degree sun's reference."
  echo
  echo "### (b) path tracing, disk suns, against their light-traced references"
  echo
  echo "| angular diameter | spp | render CPU-s | relMSE | relMSE per seed | lit-mean ratio |"
  echo "|---|---|---|---|---|---|"
  while read -r m a sp c e q rest; do
    [ "$m" = pt ] || continue
    per=$(for k in $seeds; do err "$work/pt-$a-$sp-$k.exr" "$work/ref-$a.exr"; done | awk '{ printf "%s%.2g", (NR > 1 ? " / " : ""), $2 }')
    printf '| %s deg | %s | %s | %.3g | %s | %.4f |\n' "$a" "$sp" "$c" "$e" "$per" "$q"
  done < "$work/runs.dat"
  echo
  echo "Long renders (seed $(echo $seeds | cut -d' ' -f1)):"
  echo
  echo "| angular diameter | spp | CPU-s | relMSE | lit-mean ratio |"
  echo "|---|---|---|---|---|"
  awk '{ printf "| %s deg | %s | %s | %.3g | %.4f |\n", $1, $2, $3, $4, $5 }' "$work/long.dat"
  echo
  echo "A black image scores $black; pt is black until some path reaches the disk, and then its"
  echo "relMSE is dominated by the few that do (each carries L = E / (pi sin^2(delta/2)))."
  echo
  echo "### At equal render CPU"
  echo
  echo "Each bbc budget against the pt budget of nearest mean CPU-s (pt's relMSE is not monotone in"
  echo "its budget, so it is not interpolated); every relMSE against its own sun's light-traced"
  echo "reference. bbc's precompute ($pc CPU-s) is not included."
  echo
  echo "| bbc spp | CPU-s | bbc relMSE (delta sun) | pt 0.53 deg: spp | CPU-s | relMSE | lit-mean | pt 2 deg: spp | CPU-s | relMSE | lit-mean |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  awk '{ printf "| %s | %s | %.3g | %s | %s | %.3g | %.3f | %s | %s | %.3g | %.3f |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11 }' "$work/equal.dat"
} > "$out/sun-pool.md"
cat "$out/sun-pool.md"
