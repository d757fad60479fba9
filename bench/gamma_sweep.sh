#!/bin/sh
# Sweep of the tuple sampler's parameter (--gamma and --expected-tuples) by relMSE at
# equal CPU: each setting renders the caustic at a fixed spp, and the figure of merit is
# relMSE x CPU-seconds (user + sys), which does not depend on the budget for an
# estimator whose error falls as 1/CPU (smaller is better).
#
#   sh bench/gamma_sweep.sh BUILD_DIR WORK_DIR [SCENE...]
#
# SCENE is a name in ../shared/scenes (default plane1k pool4k). WORK_DIR receives the
# caches (made with default options and the scene's chain, R or T, when missing), the
# references (bbc at REF_SPP samples, default 1024, Sobol; made when missing) and
# sweep.md. SPP (default 32) and THREADS (default 1) set the sweep's renders.
set -eu
bin=$1
work=$2
shift 2
scenes=${*:-plane1k pool4k}
shared=$(cd "$(dirname "$0")/../../shared/scenes" && pwd)
spp=${SPP:-32}
ref_spp=${REF_SPP:-1024}
threads=${THREADS:-1}
mkdir -p "$work"
out="$work/sweep.md"
{
  echo "| scene | setting | CPU s | relMSE | relMSE x CPU s | mean |S| |"
  echo "|---|---|---|---|---|---|"
} > "$out"
for s in $scenes; do
  chain=R
  case $s in pool*) chain=T ;; esac
  cache="$work/$s.bbc"
  [ -f "$cache" ] || "$bin/bbc-precompute/bbc-precompute" "$shared/$s.gltf" -o "$cache" \
    --chains $chain --no-progress
  common="$shared/$s.gltf --cache $cache --only caustics --max-depth 3 --width 160 --no-progress"
  ref="$work/$s-ref.exr"
  # shellcheck disable=SC2086
  [ -f "$ref" ] || "$bin/bbc-render/bbc-render" $common --spp "$ref_spp" --seed 1000 -o "$ref"
  for setting in "--gamma 10" "--gamma 30" "--gamma 100" "--gamma 300" "--gamma 1000" \
    "--expected-tuples 1" "--expected-tuples 2" "--expected-tuples 4" "--expected-tuples 8"; do
    # shellcheck disable=SC2086
    /usr/bin/time -f '%U %S' -o "$work/time" "$bin/bbc-render/bbc-render" $common $setting \
      --spp "$spp" --threads "$threads" --seed 7 -o "$work/sweep.exr" --reference "$ref" \
      --stats > "$work/out" 2> "$work/err"
    cpu=$(awk '{printf "%.2f", $1 + $2}' "$work/time")
    rel=$(sed -n 's/relMSE //p' "$work/out")
    s_mean=$(sed -n 's/.*|S| \([0-9.]*\);.*/\1/p' "$work/err")
    merit=$(awk -v a="$rel" -v b="$cpu" 'BEGIN {printf "%.3g", a * b}')
    printf '| %s | %s | %s | %s | %s | %s |\n' "$s" "$setting" "$cpu" "$rel" "$merit" "$s_mean" \
      >> "$out"
  done
done
cat "$out"
