#!/bin/sh
# The main job on the bundled demo scene: installs what is missing, builds, generates
# the demo scene (a wavy mirror casting a caustic onto a floor under a point light),
# precomputes its caustic bounds into demo/demo.bbc and renders demo/demo.exr with a
# PNG preview demo/demo.png.
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh
sh scripts/build.sh
mkdir -p demo
build/scenes/bbc-scenegen wavy-mirror --size 2000 --width 640 --height 480 -o demo/demo.gltf
build/bbc-precompute/bbc-precompute demo/demo.gltf -o demo/demo.bbc --chains R --max-level 8 --stats
build/bbc-render/bbc-render demo/demo.gltf --cache demo/demo.bbc -o demo/demo.exr \
  --png demo/demo.png --spp 16 --gamma 10 --stats
echo "wrote demo/demo.bbc, demo/demo.exr and demo/demo.png"
