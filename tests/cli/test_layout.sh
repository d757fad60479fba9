#!/bin/sh
# The source layout (docs/architecture.md): libbbc/src is grouped by the pipeline's stages, and a
# file includes only headers of its own stage or of earlier ones.
. "${BBC_SOURCE_DIR:?BBC_SOURCE_DIR must name the source folder}/tests/cli/lib.sh"

# The stages in pipeline order, and the stage of each public header.
STAGES="common math scene bound cache precompute render"
public_stage() {
  case $1 in
    common.h) echo common ;;
    bernstein.h | interval.h) echo math ;;
    scene.h | accel.h | tuple.h | bsdf.h | texture.h) echo scene ;;
    bounds.h | specular_path.h) echo bound ;;
    grid.h | cache.h) echo cache ;;
    precompute.h | validate.h) echo precompute ;;
    solver.h | render.h | image.h) echo render ;;
    bbc.h) echo all ;;
    *) echo unknown ;;
  esac
}
rank() {
  n=0
  for s in $STAGES; do
    [ "$s" = "$1" ] && { echo $n; return; }
    n=$((n + 1))
  done
  echo 99
}

test_stages() {
  src="$BBC_SOURCE_DIR/libbbc/src"
  inc="$BBC_SOURCE_DIR/libbbc/include/bbc"
  bad=0
  # Every source file lies in a stage folder.
  for f in "$src"/*; do
    [ -d "$f" ] || { echo "not in a stage folder: $f"; bad=1; }
  done
  for dir in "$src"/*/; do
    stage=$(basename "$dir")
    [ "$(rank "$stage")" -lt 99 ] || { echo "unknown stage folder: $stage"; bad=1; continue; }
    for f in "$dir"*; do
      for h in $(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$f"); do
        case $h in
          bbc/*) hs=$(public_stage "${h#bbc/}") ;;
          *) hs=$(ls "$src"/*/"$h" 2>/dev/null | head -n 1); hs=$(basename "$(dirname "$hs")") ;;
        esac
        if [ "$(rank "$hs")" -gt "$(rank "$stage")" ]; then
          echo "$stage/$(basename "$f") includes $h (stage $hs)"
          bad=1
        fi
      done
    done
  done
  # Public headers, too, include only their own or earlier stages (bbc.h includes all).
  for f in "$inc"/*.h; do
    stage=$(public_stage "$(basename "$f")")
    [ "$stage" = unknown ] && { echo "public header of no stage: $f"; bad=1; continue; }
    [ "$stage" = all ] && continue
    for h in $(sed -n 's/^#include "bbc\/\([^"]*\)".*/\1/p' "$f"); do
      if [ "$(rank "$(public_stage "$h")")" -gt "$(rank "$stage")" ]; then
        echo "bbc/$(basename "$f") includes bbc/$h (stage $(public_stage "$h"))"
        bad=1
      fi
    done
  done
  [ $bad = 0 ] || fail "the layout breaks the stage order"
}

command -v "test_$1" >/dev/null 2>&1 || { echo "no such test: '$1'" >&2; exit 2; }
"test_$1"
