# bbc caustics for Blender: a panel in the render properties and two operators,
# bpy.ops.bbc.precompute() and bpy.ops.bbc.render_caustics(), that export the scene,
# run bbc-precompute and bbc-render, and add bbc's caustic pass to the Cycles render in
# the compositor (docs/blender.md). Written for Blender 3.4 (Debian's) and the 4.x API;
# pipeline.py holds what does not depend on the user interface.

bl_info = {
    "name": "bbc caustics",
    "author": "bbc authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > bbc caustics",
    "description": "Point-light caustics through glass, water and mirrors, rendered by bbc "
                   "and added to the Cycles render",
    "category": "Render",
}

import os
import subprocess
import sys
import threading

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import pipeline


class BBCSettings(bpy.types.PropertyGroup):
    tools_dir: StringProperty(
        name="bbc tools",
        description="Folder holding bbc-precompute and bbc-render (or a build folder with "
                    "bbc-precompute/ and bbc-render/); empty: find them on PATH",
        subtype="DIR_PATH", default="")
    cache_dir: StringProperty(
        name="Cache folder",
        description="Where the exported scene, the cache and the caustic images live; "
                    "// is the folder of the .blend",
        subtype="DIR_PATH", default="//bbc/")
    quality: EnumProperty(
        name="Quality", description="How long bbc-render works on each image",
        items=[("SAMPLES", "Samples", "A number of samples per pixel (--spp)"),
               ("TIME", "Time", "A time in seconds per image (--time)")],
        default="SAMPLES")
    samples: IntProperty(name="Samples", description="Samples per pixel of the caustic pass",
                         min=1, soft_max=4096, default=64)
    time_limit: FloatProperty(name="Time", description="Seconds of rendering per image",
                              min=0.01, soft_max=3600.0, default=10.0, unit="TIME_ABSOLUTE")
    chains: StringProperty(
        name="Chains",
        description="Chain types to precompute, e.g. T,TT for water and glass without "
                    "mirrors (empty: bbc-precompute's default, every type the materials "
                    "form less the two-bounce types over its --double-budget)", default="")
    threads: IntProperty(name="Threads", description="Threads of the bbc tools (0: all cores)",
                         min=0, default=0)
    precompute_options: StringProperty(
        name="Precompute options", description="More bbc-precompute options, as typed in a "
        "shell (e.g. --max-level 8 --resolution 256)", default="")
    render_options: StringProperty(
        name="Render options", description="More bbc-render options, as typed in a shell "
        "(e.g. --seed 3)", default="")


# ---------------------------------------------------------------------------- running jobs

def _run_blocking(job, report):
    """Drives a job to its end, running each command in turn: headless Blender (farms,
    scripts) and the tests. The tools' progress goes to Blender's stderr as it comes."""
    result = None
    try:
        while True:
            cmd = job.send(result)
            report({"INFO"}, "bbc: %s: %s" % (cmd.label, " ".join(cmd.argv)))
            proc = subprocess.Popen(cmd.argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            chunks = []
            while True:
                data = proc.stderr.read1(4096) if hasattr(proc.stderr, "read1") else \
                    proc.stderr.read(4096)
                if not data:
                    break
                chunks.append(data)
                sys.stderr.write(data.decode("utf-8", "replace"))
                sys.stderr.flush()
            proc.wait()
            result = pipeline.Result(proc.returncode, b"".join(chunks).decode("utf-8", "replace"))
    except StopIteration as stop:
        return stop.value


class _Runner:
    """One command run in the background while the modal operator keeps Blender
    responsive; a thread collects its stderr for the progress and the error line."""

    def __init__(self, cmd):
        self.cmd = cmd
        self.text = ""
        self.lock = threading.Lock()
        self.proc = subprocess.Popen(cmd.argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        while True:
            data = self.proc.stderr.read1(4096) if hasattr(self.proc.stderr, "read1") else \
                self.proc.stderr.read(4096)
            if not data:
                break
            with self.lock:
                self.text += data.decode("utf-8", "replace")

    def poll(self):
        with self.lock:
            text = self.text
        return self.proc.poll(), text

    def cancel(self):
        if self.proc.poll() is None:
            self.proc.terminate()  # the bbc tools stop cleanly and write nothing (exit 130)
            self.proc.wait()


class _JobOperator:
    """execute(): runs the whole job (headless or from scripts). invoke(): runs it from a
    timer, the current tool's progress bar in the status bar; Esc cancels."""

    _timer = None
    _runner = None
    _job = None

    def make_job(self, context):
        raise NotImplementedError

    def finished(self, context, value):
        pass

    def _log(self, level, text):
        self.report({level}, text)
        print(text)

    def execute(self, context):
        try:
            value = _run_blocking(self.make_job(context), self.report)
        except pipeline.BBCError as e:
            self.report({"ERROR"}, "bbc: %s" % e)
            return {"CANCELLED"}
        self.finished(context, value)
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._job = self.make_job(context)
            if not self._advance(context, None):
                return {"FINISHED"}
        except pipeline.BBCError as e:
            self.report({"ERROR"}, "bbc: %s" % e)
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        return {"RUNNING_MODAL"}

    def _advance(self, context, result):
        """Sends a result to the job and starts its next command; False once it is done."""
        try:
            cmd = self._job.send(result)
        except StopIteration as stop:
            self.finished(context, stop.value)
            return False
        self._runner = _Runner(cmd)
        self._status(context, cmd.label, None)
        return True

    def _status(self, context, label, percent):
        text = "bbc: %s" % label if percent is None else "bbc: %s %d%%" % (label, percent)
        if context.workspace is not None:
            context.workspace.status_text_set(text + "  (Esc to cancel)")
        if percent is not None:
            context.window_manager.progress_update(percent)

    def _end(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        for area in context.screen.areas if context.screen else []:
            area.tag_redraw()

    def modal(self, context, event):
        if event.type == "ESC":
            self._runner.cancel()
            self._end(context)
            self.report({"WARNING"}, "bbc: cancelled")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        code, text = self._runner.poll()
        if code is None:
            progress = pipeline.parse_progress(text)
            if progress:
                self._status(context, "%s: %s" % (self._runner.cmd.label, progress[0]),
                             progress[1])
            return {"RUNNING_MODAL"}
        self._runner.thread.join()
        _, text = self._runner.poll()
        try:
            if self._advance(context, pipeline.Result(code, text)):
                return {"RUNNING_MODAL"}
        except pipeline.BBCError as e:
            self._end(context)
            self.report({"ERROR"}, "bbc: %s" % e)
            return {"CANCELLED"}
        self._end(context)
        return {"FINISHED"}


class BBC_OT_precompute(_JobOperator, bpy.types.Operator):
    """Export the scene and precompute bbc's caustic cache beside the .blend (kept while
    bbc accepts it for the scene)"""
    bl_idname = "bbc.precompute"
    bl_label = "Precompute Caustics"
    bl_options = {"REGISTER"}

    def make_job(self, context):
        return pipeline.precompute_job(context, self._log)

    def finished(self, context, value):
        what = "computed" if value["computed"] else "reused"
        self.report({"INFO"}, "bbc: cache %s: %s" % (what, value["paths"]["cache"]))


class BBC_OT_render_caustics(_JobOperator, bpy.types.Operator):
    """Render bbc's caustic pass of the active camera (or of the frame range) and add it
    to the Cycles render in the compositor"""
    bl_idname = "bbc.render_caustics"
    bl_label = "Render Caustics"
    bl_options = {"REGISTER"}

    animation: bpy.props.BoolProperty(
        name="Animation", description="Render every frame of the scene's frame range",
        default=False)

    def make_job(self, context):
        return pipeline.render_job(context, self._log, self.animation)

    def finished(self, context, value):
        self.report({"INFO"}, "bbc: caustics in %s, added to the render in the compositor"
                    % value["image"])


class RENDER_PT_bbc(bpy.types.Panel):
    bl_label = "bbc caustics"
    bl_idname = "RENDER_PT_bbc"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.bbc

        col = layout.column()
        col.prop(s, "tools_dir")
        for name in (pipeline.PRECOMPUTE, pipeline.RENDER):
            path = pipeline.find_tool(s, name)
            row = col.row()
            row.alignment = "RIGHT"
            if path:
                row.label(text=path, icon="CHECKMARK")
            else:
                row.label(text="%s not found" % name, icon="ERROR")

        col = layout.column()
        col.prop(s, "quality")
        if s.quality == "TIME":
            col.prop(s, "time_limit")
        else:
            col.prop(s, "samples")
        col.prop(s, "chains")
        col.prop(s, "threads")

        col = layout.column()
        col.prop(s, "cache_dir")
        try:
            p = pipeline.paths(s)
            if os.path.isfile(p["cache"]):
                size = os.path.getsize(p["cache"]) / 1e6
                col.label(text="%s, %.1f MB" % (os.path.basename(p["cache"]), size), icon="FILE")
            else:
                col.label(text="no cache yet", icon="INFO")
        except pipeline.BBCError as e:
            col.label(text=str(e), icon="ERROR")

        col = layout.column(align=True)
        col.use_property_split = False
        col.operator(BBC_OT_precompute.bl_idname, icon="PHYSICS")
        col.operator(BBC_OT_render_caustics.bl_idname, icon="RENDER_STILL")
        op = col.operator(BBC_OT_render_caustics.bl_idname, text="Render Caustics (Animation)",
                          icon="RENDER_ANIMATION")
        op.animation = True

        box = layout.box()
        box.use_property_split = False
        box.label(text="Advanced")
        box.prop(s, "precompute_options", text="Precompute")
        box.prop(s, "render_options", text="Render")


classes = (BBCSettings, BBC_OT_precompute, BBC_OT_render_caustics, RENDER_PT_bbc)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.bbc = PointerProperty(type=BBCSettings)


def unregister():
    del bpy.types.Scene.bbc
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
