# The add-on's operators as a user runs them, in a Blender window (under Xvfb), for
# tests/blender/test_blender.sh's "interactive" test:
#   blender --enable-event-simulate WORK/scene.blend --python window.py -- WORK
# Everything happens from timers once the window is up, as the button of the panel
# calls them (INVOKE_DEFAULT: the modal path, its command run in the background while
# Blender keeps drawing):
# 1. Precompute Caustics with a long precompute, then Esc (a simulated key press): the
#    operator is cancelled, bbc-precompute is stopped and leaves no cache behind.
# 2. Render Caustics: it runs to the end in the background; the cache and the caustic
#    pass are written and the compositor adds the pass.
# The outcome is written to WORK/window.txt ("ok" or the failure), which the shell test
# reads: an exception inside a timer does not change Blender's exit status.
import os
import sys
import time

import bpy

WORK = sys.argv[sys.argv.index("--") + 1]
RESULT = os.path.join(WORK, "window.txt")
state = {}


def finish(message):
    with open(RESULT, "w") as f:
        f.write(message + "\n")
    print("window.py: " + message, flush=True)
    bpy.ops.wm.quit_blender()


def window_override():
    win = bpy.context.window_manager.windows[0]
    area = max(win.screen.areas, key=lambda a: a.width * a.height)
    return win, area


def bbc_processes():
    """Running bbc tools whose command line names the work folder (Linux /proc)."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                argv = f.read().split(b"\0")
        except OSError:
            continue
        if argv and os.path.basename(argv[0]).startswith(b"bbc-") and \
                any(WORK.encode() in a for a in argv):
            found.append(pid)
    return found


def paths():
    from bbc_blender import pipeline
    return pipeline.paths(bpy.context.scene.bbc)


def start_precompute():
    s = bpy.context.scene.bbc
    s.precompute_options = "--max-level 9 --resolution 512"   # long enough to cancel
    s.threads = 2
    win, area = window_override()
    with bpy.context.temp_override(window=win, area=area):
        r = bpy.ops.bbc.precompute("INVOKE_DEFAULT")
    if r != {"RUNNING_MODAL"}:
        finish("Precompute Caustics returned %s, not RUNNING_MODAL" % r)
        return None
    state["t"] = time.time()
    bpy.app.timers.register(press_escape, first_interval=1.0)
    return None


def press_escape():
    if not bbc_processes():
        finish("bbc-precompute is not running 1 s after Precompute Caustics")
        return None
    win, _ = window_override()
    win.event_simulate(type="ESC", value="PRESS")
    win.event_simulate(type="ESC", value="RELEASE")
    bpy.app.timers.register(check_cancelled, first_interval=1.0)
    return None


def check_cancelled():
    left = bbc_processes()
    p = paths()
    if left:
        finish("bbc-precompute still running after Esc (pids %s)" % ", ".join(left))
    elif os.path.exists(p["cache"]) or os.path.exists(p["params"]):
        finish("a cache was left after Esc")
    else:
        bpy.app.timers.register(start_render, first_interval=0.1)
    return None


def start_render():
    s = bpy.context.scene.bbc
    s.precompute_options = "--max-level 4 --resolution 128"
    s.samples = 16
    win, area = window_override()
    with bpy.context.temp_override(window=win, area=area):
        r = bpy.ops.bbc.render_caustics("INVOKE_DEFAULT")
    if r != {"RUNNING_MODAL"}:
        finish("Render Caustics returned %s, not RUNNING_MODAL" % r)
        return None
    state["t"] = time.time()
    bpy.app.timers.register(wait_render, first_interval=0.5)
    return None


def wait_render():
    tree = bpy.context.scene.node_tree
    add = tree.nodes.get("bbc add caustics") if tree is not None else None
    if add is None:
        if time.time() - state["t"] > 240:
            finish("Render Caustics did not finish within 240 s")
            return None
        return 0.5
    p = paths()
    image = tree.nodes["bbc caustics"].image
    if not (os.path.isfile(p["cache"]) and os.path.isfile(p["caustics"])):
        finish("Render Caustics finished without its cache or caustic pass")
    elif image is None or bpy.path.abspath(image.filepath) != p["caustics"]:
        finish("the compositor does not read %s" % p["caustics"])
    elif bbc_processes():
        finish("bbc tools still running after Render Caustics finished")
    else:
        finish("ok: cancelled precompute left nothing; Render Caustics took %.1f s"
               % (time.time() - state["t"]))
    return None


bpy.app.timers.register(start_precompute, first_interval=1.0)
