#!/bin/sh
# The main job on the bundled demo scene: installs what is missing, builds, generates
# the demo scene (bbc-scenegen glass-pool: wavy water over a tiled pool and a glass ball
# on the deck beside it, under a warm point light), precomputes its caustic bounds into
# demo/demo.bbc (refraction through the water, T, and double refraction through the
# ball, TT) and renders demo/demo.exr with a PNG preview demo/demo.png.
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh
sh scripts/build.sh
mkdir -p demo
build/scenes/bbc-scenegen glass-pool --checker 10 --width 640 --height 360 -o demo/demo.gltf
build/bbc-precompute/bbc-precompute demo/demo.gltf -o demo/demo.bbc --max-level 7 --stats
build/bbc-render/bbc-render demo/demo.gltf --cache demo/demo.bbc -o demo/demo.exr \
  --png demo/demo.png --spp 32 --solver newton-det --stats
echo "wrote demo/demo.bbc, demo/demo.exr and demo/demo.png"
