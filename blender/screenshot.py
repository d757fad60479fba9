# Run by blender/screenshot.sh inside a real Blender window (under Xvfb): the largest
# area becomes a Properties editor, maximised (Ctrl Space), on its Render tab, where the
# add-on registers its panel; a screenshot of the whole window is saved and Blender quits.
#   blender FILE.blend --python screenshot.py -- OUT.png
#
# Each step runs from a timer, once the window is up, and each waits for what the one
# before needs:
# - The panel is closed by default (bl_options DEFAULT_CLOSED). It is registered again,
#   open, before the editor first draws the Render tab, which is when the editor takes a
#   panel's default state. Its class, label, place and draw code are the add-on's own.
# - The editor's tab (SpaceProperties.context) is an enum whose items are the tabs the
#   editor found at its last redraw. Right after the area becomes a Properties editor it
#   has not drawn yet, the list is empty and "RENDER" is refused; the step tags a redraw
#   and tries again until the tab is accepted.
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]


def properties_area():
    win = bpy.context.window_manager.windows[0]
    return win, next(a for a in win.screen.areas if a.type == "PROPERTIES")


def setup():
    from bbc_blender import RENDER_PT_bbc
    bpy.utils.unregister_class(RENDER_PT_bbc)
    RENDER_PT_bbc.bl_options = set()
    bpy.utils.register_class(RENDER_PT_bbc)
    # Without an active object the editor shows the scene's tabs only.
    bpy.context.view_layer.objects.active = None
    win = bpy.context.window_manager.windows[0]
    area = max(win.screen.areas, key=lambda a: a.width * a.height)
    area.type = "PROPERTIES"
    area.tag_redraw()
    bpy.app.timers.register(maximise, first_interval=0.5)
    return None


def maximise():
    win, area = properties_area()
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screen_full_area()
    bpy.app.timers.register(render_tab, first_interval=0.5)
    return None


def render_tab():
    win, area = properties_area()
    try:
        area.spaces.active.context = "RENDER"
    except TypeError:          # no tabs listed yet: not drawn since it became Properties
        area.tag_redraw()
        return 0.2
    area.tag_redraw()
    bpy.app.timers.register(shoot, first_interval=1.0)
    return None


def shoot():
    win, area = properties_area()
    if area.spaces.active.context == "RENDER":
        with bpy.context.temp_override(window=win):
            bpy.ops.screen.screenshot(filepath=out)
    else:                      # no picture: screenshot.sh says so
        print("screenshot.py: the editor shows the %s tab" % area.spaces.active.context)
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(setup, first_interval=1.0)
