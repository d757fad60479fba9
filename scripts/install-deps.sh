#!/bin/sh
# Installs the Debian packages bbc needs to build and test (run as root). Skips apt
# entirely when everything is already there. pkg-config, file (for cpack's
# dpkg-shlibdeps step), groff-base and GNU parallel are for the tests of the installed
# package (tests/install/test_install.sh); slurm-wlm and munge are for the one-node Slurm
# cluster that runs examples/slurm/ in the suite (tests/cluster/test_slurm.sh). The
# packages only install the programs: nothing here starts a daemon. With --fuzz, also clang with libFuzzer
# and the sanitizer runtimes, for tests/fuzz/run.sh; with --bench, also POV-Ray 3.7
# (photon mapping, the competitor) and gnuplot (the PNG curves), for bench/compare.sh;
# with --lint, also lintian, to check the Debian packages (`lintian build/*.deb`);
# --screenshot is kept for older instructions and adds nothing now. Blender itself
# (Debian's 3.4) is always installed: the tests of the Blender add-on (tests/blender/) run
# it headless, and in a window on a virtual display (Xvfb, with xauth, which xvfb-run
# calls) for its operators' interactive path and for the panel's screenshot
# (blender/screenshot.sh); its glTF exporter needs NumPy, which Debian's package does
# not pull in.
set -eu
PACKAGES="build-essential cmake libembree-dev libopenexr-dev libzstd-dev libtinygltf-dev \
zlib1g-dev pkg-config file groff-base parallel blender python3-numpy xvfb xauth slurm-wlm \
munge"
case "${1:-}" in
  --fuzz) PACKAGES="$PACKAGES clang libclang-rt-dev llvm" ;;
  --bench) PACKAGES="$PACKAGES povray gnuplot-nox" ;;
  --lint) PACKAGES="$PACKAGES lintian" ;;
  --screenshot) ;;
esac
missing=""
for p in $PACKAGES; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "installing:$missing"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  # shellcheck disable=SC2086
  apt-get install -y -qq --no-install-recommends $missing
fi
