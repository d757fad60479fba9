#!/bin/sh
# The main job on the bundled demo scene: installs what is missing, builds, generates
# the demo scene (bbc-scenegen glass-pool: wavy water over a tiled pool and a glass ball
# on the deck beside it, under a warm point light), precomputes its caustic bounds into
# demo/demo.bbc (refraction through the water, T, and double refraction through the
# ball, TT) and renders demo/demo.exr with a PNG preview demo/demo.png.
#
# --max-depth 4 keeps the paths of at most four segments: the light reaching the camera
# straight from a lit surface, through the water or the ball, and every caustic of the
# cache on a surface the camera sees directly or through the water (camera, water, pool
# floor, water, light is four; camera, deck, ball, ball, light too). It leaves out light that has bounced off a diffuse surface on its
# way, so the pool wall facing away from the light stays black: path tracing finds such
# light only by chance (a diffuse bounce that happens to land on a caustic), which at
# the full depth scattered bright speckles over the walls, the deck and the ball's
# shadow. Double refraction is solved by newton-stoch, the default, which is unbiased.
set -eu
cd "$(dirname "$0")/.."
sh scripts/install-deps.sh
sh scripts/build.sh
mkdir -p demo
build/scenes/bbc-scenegen glass-pool --checker 10 --width 640 --height 360 -o demo/demo.gltf
build/bbc-precompute/bbc-precompute demo/demo.gltf -o demo/demo.bbc --chains T,TT --max-level 7 \
  --stats
build/bbc-render/bbc-render demo/demo.gltf --cache demo/demo.bbc -o demo/demo.exr \
  --png demo/demo.png --spp 128 --max-depth 4 --stats
echo "wrote demo/demo.bbc, demo/demo.exr and demo/demo.png"
