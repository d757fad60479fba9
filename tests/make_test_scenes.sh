#!/bin/sh
# Writes the generated scenes the test suite reads: make_test_scenes.sh GENERATOR OUTDIR,
# where GENERATOR is the built bbc-scenegen. The build runs it once (tests/CMakeLists.txt)
# and the unit and CLI tests find the scenes in BBC_TEST_SCENES.
#
# Sizes are kept small so that precomputing caches for them stays quick in the suite;
# scenes/kinds.c documents each set-up (positions, lights, cameras).
set -e

if [ "$#" -ne 2 ]; then
  echo "usage: make_test_scenes.sh GENERATOR OUTDIR" >&2
  exit 2
fi
gen=$1
out=$2

if [ ! -x "$gen" ]; then
  echo "make_test_scenes.sh: generator '$gen' is missing or not executable" >&2
  exit 1
fi
mkdir -p "$out"

# Runs one generation and names it on failure, so a broken build step says which scene
# could not be written instead of failing silently.
scene() {
  if ! "$gen" "$@"; then
    echo "make_test_scenes.sh: failed: $gen $*" >&2
    exit 1
  fi
}

# Analytic irradiance: a point light over a bare floor.
scene floor -o "$out/floor.gltf"
# Analytic mirror: the floor receives the light plus exactly its mirror image; the tiny
# mirror keeps enumeration cheap, and the area-light variant tests emissive triangles.
scene flat-mirror --size 8 -o "$out/flat-mirror.gltf"
scene flat-mirror --size 8 --area-light 0.25 -o "$out/flat-mirror-area.gltf"
# The analytic mirror on a floor with an 8 x 8 checker texture (mirrored light x texture).
scene flat-mirror --size 8 --checker 8 -o "$out/flat-mirror-checker.gltf"
# ... and on a glossy floor (glTF metallic-roughness BRDF), with a point and an area light.
scene flat-mirror --size 8 --roughness 0.3 --metallic 0.5 -o "$out/flat-mirror-glossy.gltf"
scene flat-mirror --size 8 --roughness 0.3 --metallic 0.5 --area-light 1 \
  -o "$out/flat-mirror-glossy-area.gltf"
# The same mirror under a sun travelling along (-1, -1, 0) / sqrt 2, and under a spot
# aimed at the mirror's foot whose cone edge crosses the caustic.
scene flat-mirror --size 8 --sun 3 -o "$out/flat-mirror-sun.gltf"
scene flat-mirror --size 8 --spot 0.5 -o "$out/flat-mirror-spot.gltf"
# The same sun with an angular diameter of 16 degrees (a disk the path tracer can hit),
# and with an angular diameter of 0 written out (which must change nothing).
scene flat-mirror --size 8 --sun 3 --sun-angle 16 -o "$out/flat-mirror-disk-sun.gltf"
sed 's/"type":"directional",/"type":"directional","extras":{"bbc":{"angular_diameter":0}},/' \
  "$out/flat-mirror-sun.gltf" > "$out/flat-mirror-sun-zero.gltf"
grep -q '"angular_diameter":0' "$out/flat-mirror-sun-zero.gltf" || {
  echo "make_test_scenes.sh: cannot write flat-mirror-sun-zero.gltf" >&2
  exit 1
}
scene wavy-mirror --size 200 --sun 2 -o "$out/wavy-mirror-sun.gltf"
scene wavy-mirror --size 200 --spot 0.6 -o "$out/wavy-mirror-spot.gltf"
# Two cameras, the first animated over five frames (--camera, --all-cameras, --frames).
scene flat-mirror --size 8 --orbit 5 -o "$out/orbit.gltf"
# Curved casters for single reflection, double refraction and single refraction.
scene wavy-mirror --size 800 -o "$out/wavy-mirror.gltf"
scene glass-sphere --size 320 -o "$out/glass-sphere.gltf"
# Media from the geometry (test_media): a hollow glass ball of two separate closed meshes,
# fine enough for its rays to follow the analytic ones, and a glass of water.
scene hollow-sphere --size 20000 -o "$out/hollow-sphere.gltf"
scene hollow-sphere --size 640 -o "$out/hollow-sphere-small.gltf"
scene glass-of-water --size 600 -o "$out/glass-of-water.gltf"
scene glass-slab --size 500 -o "$out/glass-slab.gltf"
scene pool --size 800 -o "$out/pool.gltf"
# The binary container, so the loader's .glb path is exercised too.
scene pool --size 200 --glb -o "$out/pool.glb"
# The demo scene of the README, larger and at a presentable size.
scene wavy-mirror --size 5000 --width 640 --height 480 -o "$out/demo.gltf"
# Analytic double reflection: two flat mirrors in a corner, the light's double image.
scene two-mirrors --size 8 -o "$out/two-mirrors.gltf"
# Mixed chains (RT, TR): the pool with a mirror above and one under the water.
scene mirror-pool --size 800 -o "$out/mirror-pool.gltf"
# Curved double reflection (RR, interpolated normals): the corner with bumpy mirrors.
scene wavy-corner --size 200 -o "$out/wavy-corner.gltf"
# Suns and spots through every chain type: T (pool), RR (two mirrors), TT (glass slab).
for kind in pool two-mirrors glass-slab; do
  size=60
  [ "$kind" = two-mirrors ] && size=8
  scene $kind --size $size --sun 2 -o "$out/$kind-sun.gltf"
  scene $kind --size $size --spot 0.6 -o "$out/$kind-spot.gltf"
done
# Area lights through every chain type (emissive squares of side 0.25 instead of the
# point light): RR (flat and curved), RT and TR, TT.
scene two-mirrors --size 8 --area-light 0.25 -o "$out/two-mirrors-area.gltf"
scene wavy-corner --size 200 --area-light 0.25 -o "$out/wavy-corner-area.gltf"
scene mirror-pool --size 200 --area-light 0.25 -o "$out/mirror-pool-area.gltf"
scene glass-sphere --size 80 --area-light 0.25 -o "$out/glass-sphere-area.gltf"
# Finite double refraction: the closed glass box with flat parallel faces (12 triangles).
scene glass-box -o "$out/glass-box.gltf"
# The shared planes' set-up (the paper's Plane), small: its footprints cover many cells.
scene wavy-plane --size 200 -o "$out/wavy-plane.gltf"
# The research set-ups of the paper (Sec. 6), made here so the suite needs nothing from
# outside the repository: the wavy plane (R), the pool (T), the balls (TT, at the four
# tessellations of the paper's Table 3), the two-sheet slab (TT, open) and the diamond
# (TT, flat facets, ior 2.42), at the sizes of the research meshes they stand in for.
scene wavy-plane --size 1200 -o "$out/plane1k.gltf"
scene wide-pool --size 4000 -o "$out/pool4k.gltf"
for n in 80 320 1280 5120; do
  scene ball --size $n -o "$out/ball$n.gltf"
done
scene slab-sheets --size 10000 -o "$out/slab10k.gltf"
scene diamond -o "$out/diamond.gltf"
# Receiver planes: the same casters over their two-triangle floor and over that floor cut
# into about 3,000 triangles in the same plane (R, T, TT).
for spec in "wavy-mirror 200" "pool 200" "glass-sphere 80"; do
  set -- $spec
  scene "$1" --size "$2" -o "$out/plane-$1.gltf"
  scene "$1" --size "$2" --floor-size 3000 -o "$out/plane-$1-3k.gltf"
done
# Curved receivers: the wavy mirror over its floor bent into a wave (no plane), cut into
# 128 and 512 triangles whose vertices both take the wave's crest and trough, so that
# the two floors have the same bounding box (beam receivers).
for n in 128 512; do
  scene wavy-mirror --size 200 --floor-size $n --floor-bend 0.2 -o "$out/bent-wavy-mirror-$n.gltf"
done
# A glass ball resting on that floor, whose wave rises into the ball beside the point it
# rests on (light refracted into the ball lands on the floor inside it).
scene glass-sphere --size 80 --floor-size 512 --floor-bend 0.2 -o "$out/bent-glass-sphere-512.gltf"
