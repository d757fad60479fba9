#!/bin/sh
# The Blender add-on (blender/bbc_blender) in the real Blender, headless: each
# test_<name> function is one ctest entry "blender.<name>", and runs
# tests/blender/check.py's test_<name> in a fresh Blender with its own user folder (the
# add-on installed from build/blender/bbc_blender.zip) and the bbc tools of this build on
# PATH. Without Blender the tests are skipped (exit 77, ctest's "Not Run");
# scripts/install-deps.sh installs it, so CI runs them.
set -u
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"

command -v blender >/dev/null 2>&1 || { echo "blender is not installed: skipped"; exit 77; }
[ -f "$BBC_BIN/blender/bbc_blender.zip" ] || fail "$BBC_BIN/blender/bbc_blender.zip missing"

# check NAME: runs check.py's test_NAME; its output is kept in $TMP/log and shown on failure.
check() {
  mkdir -p "$TMP/work" "$TMP/user"
  BLENDER_USER_SCRIPTS="$TMP/user/scripts" BLENDER_USER_CONFIG="$TMP/user/config" \
  PATH="$BBC_BIN/bbc-precompute:$BBC_BIN/bbc-render:$PATH" \
    blender -b --factory-startup --python-exit-code 1 \
      --python "$BBC_SOURCE_DIR/tests/blender/check.py" -- "$1" "$TMP/work" \
      >"$TMP/log" 2>&1
  status=$?
  grep -E "^(composite|caustic|floor|lit floor|frame)" "$TMP/log"
  [ "$status" -eq 0 ] || { cat "$TMP/log" >&2; fail "check.py $1 exited $status"; }
}

test_install() { check install; }
test_composite() { check composite; }
test_floor() { check floor; }
test_camera_reuses() { check camera_reuses; }
test_glass_recomputes() { check glass_recomputes; }
test_frames() { check frames; }

# The operators as the panel's buttons run them (their modal path), in a Blender window
# on a virtual display: tests/blender/window.py, after check.py's prepare_window has
# installed the add-on in the test's user folder and saved the scene.
test_interactive() {
  command -v xvfb-run >/dev/null 2>&1 || { echo "xvfb-run is not installed: skipped"; exit 77; }
  check prepare_window
  BLENDER_USER_SCRIPTS="$TMP/user/scripts" BLENDER_USER_CONFIG="$TMP/user/config" \
  PATH="$BBC_BIN/bbc-precompute:$BBC_BIN/bbc-render:$PATH" \
    timeout 600 xvfb-run -a -s "-screen 0 1280x900x24" blender --enable-event-simulate \
      "$TMP/work/scene.blend" --python "$BBC_SOURCE_DIR/tests/blender/window.py" -- \
      "$TMP/work" >"$TMP/log" 2>&1
  status=$?
  grep "^window.py" "$TMP/log"
  grep -q "^ok" "$TMP/work/window.txt" 2>/dev/null ||
    { cat "$TMP/log" >&2; fail "the window test failed (exit status $status)"; }
}

"test_$1"
