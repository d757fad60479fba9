# Run by blender/screenshot.sh inside a real Blender window (under Xvfb): opens a
# Properties editor with the add-on's panel expanded (see expand()), takes a
# screenshot of the window and quits.  blender FILE.blend --python screenshot.py -- OUT.png
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]


def setup():
    # Without an active object the Properties editor has no object tabs and opens on the
    # first tabs of the scene; the render tab is chosen below.
    bpy.context.view_layer.objects.active = None
    win = bpy.context.window_manager.windows[0]
    screen = win.screen
    # The largest area becomes the Properties editor, showing the render tab.
    area = max(screen.areas, key=lambda a: a.width * a.height)
    area.type = "PROPERTIES"
    for a in screen.areas:
        a.tag_redraw()
    return None


def expand():
    # The panel's own draw code, open and first, in the tab the editor shows. Setting the
    # editor's tab from a script failed here (its tab enum is empty outside a draw), so
    # without an active object it falls back to the Scene tab, and the panel is shown
    # there for the picture; the add-on itself puts it in the Render tab.
    from bbc_blender import RENDER_PT_bbc

    class SCENE_PT_bbc_picture(bpy.types.Panel):
        bl_label = RENDER_PT_bbc.bl_label
        bl_space_type = "PROPERTIES"
        bl_region_type = "WINDOW"
        bl_context = "scene"
        bl_order = -100
        draw = RENDER_PT_bbc.draw

    bpy.utils.register_class(SCENE_PT_bbc_picture)
    win = bpy.context.window_manager.windows[0]
    for a in win.screen.areas:
        a.tag_redraw()
    return None


def shoot():
    win = bpy.context.window_manager.windows[0]
    area = max(win.screen.areas, key=lambda a: a.width * a.height)
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot_area(filepath=out)
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(setup, first_interval=1.0)
bpy.app.timers.register(expand, first_interval=2.0)
bpy.app.timers.register(shoot, first_interval=4.0)
