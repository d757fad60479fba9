#!/bin/sh
# Installs what the comparison benchmark (bench/compare.sh) needs beyond the build
# dependencies (run as root): POV-Ray 3.7 (photon mapping, the competitor) and gnuplot
# (the PNG curves). Skips apt entirely when everything is already there.
set -eu
PACKAGES="povray gnuplot-nox"
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
