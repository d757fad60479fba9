#!/bin/sh
# The shared pool (pool4k, T) under a sun instead of its point light: the bbc estimator
# converges to the deterministic enumeration of all tuples. Writes bench/results/sun-pool.md.
#   Usage: sh bench/sun-pool.sh [SHARED_SCENES_DIR]
# The sun (irradiance 3 W/m^2) travels from the point light's position toward the origin,
# along (-0.120, -0.963, -0.241); the glTF is the shared one with its light rewritten.
# Needs a Release build in build/ (sh scripts/build.sh).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
scenes=${1:-$root/../shared/scenes}
bin=$root/build
out=$root/bench/results
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
cp "$scenes/pool4k.bin" "$work/"
# The node "light" gets the rotation taking -Z to the sun's direction; the light becomes
# directional.
sed -e 's/"type": "point",/"type": "directional",/' -e 's/"intensity": 50.0/"intensity": 3.0/' \
  -e 's/"name": "light",/"name": "light", "rotation": [-0.6113705335305231, 0.07642131669131538, 0.0, 0.7876457662463306],/' \
  "$scenes/pool4k.gltf" > "$work/pool4k-sun.gltf"
grep -q '"directional"' "$work/pool4k-sun.gltf"

time_of() { /usr/bin/time -f '%U %S %e' "$@" 2> "$work/time" > /dev/null; tail -1 "$work/time"; }
pre=$(time_of "$bin/bbc-precompute/bbc-precompute" "$work/pool4k-sun.gltf" -o "$work/sun.bbc" --chains T --no-progress)
common="$work/pool4k-sun.gltf --cache $work/sun.bbc --only caustics --max-depth 3 --width 160 --no-progress"
# shellcheck disable=SC2086
"$bin/bbc-render/bbc-render" $common --method enumerate --spp 256 --seed 1 -o "$work/ref.exr"
{
  echo "# Sun over the shared pool (pool4k, T)"
  echo
  echo "Machine: $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(nproc) cores; $(date -u +%Y-%m-%d)."
  echo "Precompute \`--chains T\`: user/sys/wall $pre s."
  "$bin/bbc-inspect/bbc-inspect" info "$work/sun.bbc" | sed -n 's/^tuples */Tuples: /p; s/^  light/  light/p'
  echo
  echo "Caustic only (\`--only caustics --max-depth 3\`, 160 px wide). Reference:"
  echo "\`--method enumerate --spp 256\`. relMSE = mean over pixels and RGB of (I-R)^2/(R^2+0.01)."
  echo "bbc samples tuples with \`--gamma 0.3\` (P < 1 for most: mean |S| 2.5 of |U| 8.0);"
  echo "enumerate takes every tuple, so its relMSE is the pixel-sampling noise alone."
  echo
  echo "| method | spp | relMSE vs enumeration | user+sys s |"
  echo "|---|---|---|---|"
  for spp in 4 16 64; do
    for m in bbc enumerate; do
      gamma=""
      [ $m = bbc ] && gamma="--gamma 0.3"
      # shellcheck disable=SC2086
      /usr/bin/time -f '%U %S' "$bin/bbc-render/bbc-render" $common --method $m $gamma --spp $spp --seed 2 \
        -o "$work/$m.exr" --reference "$work/ref.exr" > "$work/out" 2> "$work/err"
      cpu=$(tail -1 "$work/err" | awk '{print $1 + $2}')
      printf '| %s | %s | %s | %s |\n' "$m" "$spp" "$(sed -n 's/relMSE //p' "$work/out")" "$cpu"
    done
  done
} > "$out/sun-pool.md"
cat "$out/sun-pool.md"
