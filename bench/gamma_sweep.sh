#!/bin/sh
# Sweep of the tuple sampler's parameter (--gamma and --expected-tuples) by relMSE at
# equal CPU: each setting renders the caustic at a fixed spp, once per seed, and the
# figure of merit is mean relMSE x mean CPU-seconds (user + sys) over the seeds, which
# does not depend on the budget for an estimator whose error falls as 1/CPU (smaller is
# better). Every setting uses the same seeds, hence the same camera samples.
#
#   sh bench/gamma_sweep.sh BUILD_DIR WORK_DIR [SCENE...]
#
# SCENE is a name in the shared scenes (default plane1k pool4k); its chain is T for
# pool*, TT at --max-level LEVEL (default 3) for ball* (named SCENE-LLEVEL below), R
# otherwise, and the caustic's depth 2 + the chain's length. The shared scenes are read
# from $BBC_SHARED_DIR/scenes (BBC_SHARED_DIR: the folder holding scenes/), else from
# ../shared/scenes beside the repository; that folder exists on some machines only: when
# it, or a SCENE.gltf in it, is missing, the script says so in one line on stderr and
# exits 0 without running anything. WORK_DIR receives the caches
# (made with default options and that chain when missing), the references (bbc at
# REF_SPP samples, default 1024, Sobol, seed 1000; made when missing, or put there as
# WORK_DIR/SCENE-ref.exr) and sweep.md. SPP (default 32), SEEDS (default "7 8 9 10"),
# WIDTH (default 160), THREADS (default 1) and SETTINGS (default the gammas 10-1000 and
# expected counts 1-8, separated by commas) set the sweep's renders; a setting may name
# another method (--method uniform --gamma 30: the expected count of --gamma 30, taken
# with uniform probabilities).
set -eu
[ $# -ge 2 ] || { echo "usage: sh bench/gamma_sweep.sh BUILD_DIR WORK_DIR [SCENE...]" >&2; exit 1; }
bin=$1
work=$2
shift 2
scenes=${*:-plane1k pool4k}
root=$(cd "$(dirname "$0")/.." && pwd)
tool=gamma_sweep.sh
. "$root/bench/lib.sh"
needed=
for s in $scenes; do needed="$needed $s.gltf"; done
# shellcheck disable=SC2086
shared=$(shared_scenes "" $needed) || exit 0
spp=${SPP:-32}
ref_spp=${REF_SPP:-1024}
threads=${THREADS:-1}
seeds=${SEEDS:-7 8 9 10}
width=${WIDTH:-160}
settings=${SETTINGS:---gamma 10,--gamma 30,--gamma 100,--gamma 300,--gamma 1000,--expected-tuples 1,--expected-tuples 2,--expected-tuples 4,--expected-tuples 8}
mkdir -p "$work"
out="$work/sweep.md"
{
  echo "$spp spp, ${width} px wide, $threads thread(s), seeds $seeds; means over the seeds."
  echo
  echo "| scene | setting | CPU s | relMSE | relMSE per seed | relMSE x CPU s | mean \|S\| |"
  echo "|---|---|---|---|---|---|---|"
} > "$out"
for s in $scenes; do
  chain=R
  level=
  case $s in pool*) chain=T ;; ball*) chain=TT level=${LEVEL:-3} ;; esac
  depth=$((2 + ${#chain}))
  name=$s${level:+-L$level}
  cache="$work/$name.bbc"
  [ -f "$cache" ] || "$bin/bbc-precompute/bbc-precompute" "$shared/$s.gltf" -o "$cache" \
    --chains $chain ${level:+--max-level $level} --no-progress
  common="$shared/$s.gltf --cache $cache --only caustics --max-depth $depth --width $width --no-progress"
  ref="$work/$name-ref.exr"
  # shellcheck disable=SC2086
  [ -f "$ref" ] || "$bin/bbc-render/bbc-render" $common --spp "$ref_spp" --seed 1000 -o "$ref"
  old_ifs=$IFS
  IFS=,
  for setting in $settings; do
    IFS=$old_ifs
    : > "$work/seeds"
    for k in $seeds; do
      # shellcheck disable=SC2086
      /usr/bin/time -f '%U %S' -o "$work/time" "$bin/bbc-render/bbc-render" $common $setting \
        --spp "$spp" --threads "$threads" --seed "$k" -o "$work/sweep.exr" --reference "$ref" \
        --stats > "$work/out" 2> "$work/err"
      cpu=$(awk '{printf "%.2f", $1 + $2}' "$work/time")
      rel=$(sed -n 's/relMSE //p' "$work/out")
      s_mean=$(sed -n 's/.*|S| \([0-9.]*\);.*/\1/p' "$work/err")
      echo "$cpu $rel $s_mean" >> "$work/seeds"
    done
    awk -v s="$name" -v setting="$setting" '
      { c += $1; e += $2; m += $3; per = per (NR > 1 ? " / " : "") sprintf("%.2g", $2) }
      END { c /= NR; e /= NR; m /= NR
            printf "| %s | %s | %.3f | %.4g | %s | %.3g | %.2f |\n", s, setting, c, e, per, c * e, m }' \
      "$work/seeds" >> "$out"
    IFS=,
  done
  IFS=$old_ifs
done
cat "$out"
