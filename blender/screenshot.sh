#!/bin/sh
# The pictures of docs/blender.md, made with the real Blender: the test scene
# (tests/blender/scene.py) at 400x300, its Cycles render without caustics beside the
# composite with bbc's caustics (docs/blender/cycles.png, composite.png, caustics.png),
# and a screenshot of the add-on's panel in a Blender window under Xvfb
# (docs/blender/panel.png: the whole window, its Properties editor maximised on the
# Render tab with the add-on's panel open; blender/screenshot.py). Needs a build with
# the tools and the add-on zip, and Xvfb
# (sh scripts/install-deps.sh installs it).
#   sh blender/screenshot.sh [BUILD]      (default ./build)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
out="$root/docs/blender"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM
mkdir -p "$out"
export BLENDER_USER_SCRIPTS="$work/scripts" BLENDER_USER_CONFIG="$work/config"
export PATH="$build/bbc-precompute:$build/bbc-render:$PATH"

blender -b --factory-startup --python "$root/tests/blender/scene.py" -- "$work/scene.blend" >/dev/null
blender -b "$work/scene.blend" --python-exit-code 1 --python-expr "
import bpy, addon_utils, os
bpy.ops.preferences.addon_install(filepath='$build/blender/bbc_blender.zip')
addon_utils.enable('bbc_blender', default_set=True)
bpy.ops.wm.save_userpref()
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y = 400, 300
scene.cycles.samples = 64
scene.bbc.samples = 64
scene.bbc.precompute_options = '--max-level 6'
bpy.ops.bbc.render_caustics()
tree = scene.node_tree
layers = next(n for n in tree.nodes if n.bl_idname == 'CompositorNodeRLayers')
fo = tree.nodes.new('CompositorNodeOutputFile')
fo.base_path = '$work'
fo.format.file_format = 'PNG'
fo.file_slots[0].path = 'cycles'
tree.links.new(layers.outputs['Image'], fo.inputs[0])
scene.view_settings.view_transform = 'Standard'
scene.render.filepath = '$out/composite.png'
scene.render.image_settings.file_format = 'PNG'
bpy.ops.render.render(write_still=True)
tree.nodes.remove(fo)
os.replace('$work/cycles0001.png', '$out/cycles.png')
bpy.ops.wm.save_mainfile()
" >"$work/log" 2>&1 || { cat "$work/log" >&2; exit 1; }
# A window 900 px wide and tall enough for the Render tab's panels with the add-on's open.
rm -f "$out/panel.png"
timeout 300 xvfb-run -a -s "-screen 0 900x1250x24" blender "$work/scene.blend" \
  --python "$root/blender/screenshot.py" -- "$out/panel.png" >"$work/log" 2>&1 &&
  [ -f "$out/panel.png" ] || { cat "$work/log" >&2; echo "no screenshot" >&2; exit 1; }
ls -l "$out"
