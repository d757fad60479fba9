# What the operators do, apart from Blender's user interface: finding the bbc tools,
# exporting the scene, the command lines of bbc-precompute and bbc-render, and the
# compositor nodes that add bbc's caustics to the Cycles render.
#
# A job is a generator: it yields the Command objects it wants run and receives each
# one's Result. The operators drive it either synchronously (headless, for farms) or from
# a modal timer (interactive, with the progress in the status bar), so both share one
# sequence of steps. Every file lives in the cache folder beside the .blend:
#   <blend>.glb             the scene as Blender's glTF exporter writes it
#   <blend>.bbc             the cache of bbc-precompute
#   <blend>.bbc.json        the precompute command line that wrote the cache
#   <blend>.caustics.exr    bbc-render's caustic pass (<blend>.caustics.FFFF.exr for frames)

import json
import os
import re
import shlex
import shutil

import bpy

PRECOMPUTE = "bbc-precompute"
RENDER = "bbc-render"
NODE_PREFIX = "bbc "
# How bbc-render and bbc-inspect refuse a cache computed for another scene (libbbc's
# BBC_ERR_SCENE_MISMATCH message, "<cache>: computed for another scene than <scene>: ...").
STALE_MESSAGE = "computed for another scene"
# cli_progress_update: "\r<label> [####....]  42%  3 s elapsed, ETA 4 s  <detail>".
PROGRESS = re.compile(r"([^\[\r\n]*?)\s*\[[#.]+\]\s+(\d+)%")


class BBCError(Exception):
    """A failure to report to the user in one line."""


class Command:
    def __init__(self, argv, label):
        self.argv = argv
        self.label = label


class Result:
    def __init__(self, returncode, stderr):
        self.returncode = returncode
        self.stderr = stderr

    def last_line(self):
        lines = [l for l in re.split(r"[\r\n]", self.stderr) if l.strip()]
        return lines[-1].strip() if lines else "exit status %d" % self.returncode


def parse_progress(text):
    """The label and percentage of the last progress bar drawn in text, or None."""
    found = PROGRESS.findall(text)
    if not found:
        return None
    label, percent = found[-1]
    return label.strip(), int(percent)


# ---------------------------------------------------------------------------- tools

def find_tool(settings, name):
    """The path of a bbc tool: in the folder the panel names, else on PATH; None if absent."""
    folder = bpy.path.abspath(settings.tools_dir) if settings.tools_dir else ""
    if folder:
        for candidate in (os.path.join(folder, name), os.path.join(folder, name, name)):
            if os.path.isfile(candidate) and os.access(candidate, os.X_OK):
                return candidate
        return None
    return shutil.which(name)


def require_tool(settings, name):
    path = find_tool(settings, name)
    if not path:
        where = "in " + settings.tools_dir if settings.tools_dir else "on PATH"
        raise BBCError("%s not found %s (set the bbc tools folder in Render Properties > "
                       "bbc caustics)" % (name, where))
    return path


# ---------------------------------------------------------------------------- files

def cache_folder(settings):
    """The absolute cache folder; relative paths (//) are relative to the .blend."""
    folder = settings.cache_dir or "//bbc/"
    if folder.startswith("//") and not bpy.data.filepath:
        raise BBCError("save the .blend file first: the cache is kept beside it (%s)" % folder)
    return os.path.normpath(bpy.path.abspath(folder))


def paths(settings):
    folder = cache_folder(settings)
    stem = bpy.path.display_name_from_filepath(bpy.data.filepath) or "untitled"
    stem = bpy.path.clean_name(stem)
    base = os.path.join(folder, stem)
    return {
        "folder": folder,
        "scene": base + ".glb",
        "cache": base + ".bbc",
        "params": base + ".bbc.json",
        "caustics": base + ".caustics.exr",
        "probe": base + ".probe.exr",
    }


def frame_path(p, frame):
    """bbc-render --frames writes OUT.FFFF.exr for -o OUT.exr."""
    return p["caustics"][:-len(".exr")] + ".%04d.exr" % frame


# ---------------------------------------------------------------------------- scene

# The exporter's options the export cannot do without (checked in the exporter's source,
# io_scene_gltf2/__init__.py of Blender 3.4, 3.6, 4.2, 4.5, 5.0, 5.1 and 5.2: all have
# them), and the lighting mode's two names: convert_lighting_mode in 3.4 and 3.5,
# export_import_convert_lighting_mode from 3.6 on.
EXPORT_REQUIRED = ("filepath", "export_format", "export_cameras", "export_lights",
                   "export_apply", "export_yup", "export_animations")
LIGHTING_MODE = ("export_import_convert_lighting_mode", "convert_lighting_mode")


def export_scene(path, animations):
    """Exports the scene with Blender's glTF exporter: lights, cameras and materials as
    they are, modifiers applied, custom properties as extras (bbc reads its extras.bbc
    there), only what renders. An exporter without one of EXPORT_REQUIRED or a lighting
    mode is refused in one line rather than writing a scene bbc would misread; the other
    options are passed when this exporter has them."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    known = set(bpy.ops.export_scene.gltf.get_rna_type().properties.keys())
    lighting = next((k for k in LIGHTING_MODE if k in known), None)
    missing = [k for k in EXPORT_REQUIRED if k not in known]
    if missing or lighting is None:
        raise BBCError("this Blender's glTF exporter has no option %s"
                       % (missing[0] if missing else " or ".join(LIGHTING_MODE)))
    wanted = {
        "filepath": path,
        "export_format": "GLB",
        "use_selection": False,
        "use_renderable": True,
        "export_cameras": True,
        "export_lights": True,
        "export_apply": True,
        "export_extras": True,
        "export_yup": True,
        "export_animations": animations,
        # Standard: W -> candela at 683 lm/W, which bbc reads back as W/sr (docs/scenes.md).
        lighting: "SPEC",
    }
    options = {k: v for k, v in wanted.items() if k in known}
    result = bpy.ops.export_scene.gltf(**options)
    if "FINISHED" not in result or not os.path.isfile(path):
        raise BBCError("the glTF exporter did not write %s" % path)


def camera_argument(scene):
    """bbc-render's --camera: the glTF name of the scene's active camera. The exporter
    names a glTF camera after the camera data and its node after the object; bbc-render
    matches the camera's name first, so the data's name is used unless other cameras
    share the data."""
    cam = scene.camera
    if cam is None or cam.type != "CAMERA":
        raise BBCError("the scene has no active camera")
    sharing = [o for o in scene.objects if o.type == "CAMERA" and o.data == cam.data]
    return cam.data.name if len(sharing) == 1 else cam.name


def check_view(scene):
    """What bbc's pinhole camera cannot reproduce: refused in one line each."""
    cam = scene.camera
    data = cam.data
    if data.type != "PERSP":
        raise BBCError("camera %s is %s; bbc renders perspective cameras only"
                       % (cam.name, data.type.lower()))
    if data.shift_x != 0 or data.shift_y != 0:
        raise BBCError("camera %s has a lens shift, which glTF cannot carry" % cam.name)
    r = scene.render
    if r.pixel_aspect_x != r.pixel_aspect_y:
        raise BBCError("pixel aspect %g:%g; bbc renders square pixels"
                       % (r.pixel_aspect_x, r.pixel_aspect_y))
    w, h = resolution(scene)
    if data.sensor_fit == "AUTO" and h > w:
        raise BBCError("a portrait image with sensor fit Auto is exported with the wrong "
                       "field of view; set the camera's sensor fit to Vertical")


def resolution(scene):
    r = scene.render
    return (r.resolution_x * r.resolution_percentage // 100,
            r.resolution_y * r.resolution_percentage // 100)


def moving_objects(scene):
    """Objects other than the active camera (and its parents) that are animated."""
    keep = set()
    o = scene.camera
    while o is not None:
        keep.add(o.name)
        o = o.parent
    out = []
    for o in scene.objects:
        if o.name in keep:
            continue
        ad = o.animation_data
        if ad and (ad.action or ad.drivers or len(ad.nla_tracks)):
            out.append(o.name)
    return out


# ---------------------------------------------------------------------------- commands

def progress_flag():
    """The tools' progress bar is for the status bar; headless, the log stays clean."""
    return "--no-progress" if bpy.app.background else "--progress"


def precompute_argv(settings, p):
    argv = [require_tool(settings, PRECOMPUTE), p["scene"], "-o", p["cache"], progress_flag()]
    if settings.chains.strip():
        argv += ["--chains", settings.chains.strip()]
    if settings.threads > 0:
        argv += ["--threads", str(settings.threads)]
    argv += shlex.split(settings.precompute_options)
    return argv


def params_record(argv):
    """What decides the cache's content besides the scene: the precompute's options
    (without the paths, the progress switch and the thread count, which change nothing
    in the file: the cache is byte-identical for any thread count)."""
    opts = argv[5:]
    cleaned = []
    skip = False
    for a in opts:
        if skip:
            skip = False
            continue
        if a == "--threads":
            skip = True
            continue
        if a.startswith("--threads="):
            continue
        cleaned.append(a)
    return {"options": cleaned}


def render_argv(settings, scene, p, output, frames=None, region=None):
    w, h = resolution(scene)
    argv = [require_tool(settings, RENDER), p["scene"], "--cache", p["cache"], "-o", output,
            "--only", "caustics", "--camera", camera_argument(scene),
            "--width", str(w), "--height", str(h), progress_flag()]
    if settings.quality == "TIME":
        argv += ["--time", repr(float(settings.time_limit))]
    else:
        argv += ["--spp", str(settings.samples)]
    if settings.threads > 0:
        argv += ["--threads", str(settings.threads)]
    if frames:
        a, b, step = frames
        argv += ["--frames", "%d:%d:%d" % (a, b, step), "--fps", repr(float(scene.render.fps))]
    if region:
        argv += ["--region", ",".join(str(v) for v in region)]
    argv += shlex.split(settings.render_options)
    return argv


def probe_argv(settings, scene, p):
    """A one-pixel render that asks bbc-render whether it accepts the cache for the
    exported scene (it refuses one of another scene before rendering anything)."""
    return [require_tool(settings, RENDER), p["scene"], "--cache", p["cache"], "-o", p["probe"],
            "--only", "caustics", "--camera", camera_argument(scene), "--width", "1",
            "--height", "1", "--spp", "1", "--no-verify", "--no-progress"]


def read_params(p):
    try:
        with open(p["params"]) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def write_params(p, record):
    tmp = p["params"] + ".tmp"
    with open(tmp, "w") as f:
        json.dump(record, f, indent=1)
    os.replace(tmp, p["params"])


# ---------------------------------------------------------------------------- jobs

def ensure_cache(settings, scene, p, log):
    """Job step: makes sure p["cache"] is a cache bbc accepts for p["scene"] (already
    exported), running bbc-precompute when there is none, when its options changed, or
    when bbc-render refuses it. Returns True if it was computed, False if reused."""
    argv = precompute_argv(settings, p)
    record = params_record(argv)
    if os.path.isfile(p["cache"]) and read_params(p) == record:
        result = yield Command(probe_argv(settings, scene, p), "checking the cache")
        _remove(p["probe"])
        if result.returncode == 0:
            log("INFO", "bbc: cache %s reused (bbc accepts it for this scene)" % p["cache"])
            return False
        if STALE_MESSAGE not in result.stderr:
            raise BBCError(result.last_line())
        log("INFO", "bbc: the scene changed, recomputing: %s" % result.last_line())
    elif os.path.isfile(p["cache"]):
        log("INFO", "bbc: precompute options changed, recomputing %s" % p["cache"])
    _remove(p["params"])
    result = yield Command(argv, "precomputing")
    if result.returncode != 0:
        raise BBCError(result.last_line())
    write_params(p, record)
    log("INFO", "bbc: cache written to %s" % p["cache"])
    return True


def precompute_job(context, log):
    scene = context.scene
    settings = scene.bbc
    p = paths(settings)
    export_scene(p["scene"], animations=False)
    computed = yield from ensure_cache(settings, scene, p, log)
    return {"computed": computed, "paths": p}


def render_job(context, log, animation):
    """Renders the caustic pass of the current frame, or of the frame range, and sets up
    Cycles and the compositor so that F12 (or -f/-a on the command line) gives Cycles'
    render plus the caustics."""
    scene = context.scene
    settings = scene.bbc
    p = paths(settings)
    check_view(scene)
    computed = False
    if not animation:
        export_scene(p["scene"], animations=False)
        computed = yield from ensure_cache(settings, scene, p, log)
        result = yield Command(render_argv(settings, scene, p, p["caustics"]), "rendering caustics")
        if result.returncode != 0:
            raise BBCError(result.last_line())
        image = p["caustics"]
        frames = None
    else:
        a, b, step = scene.frame_start, scene.frame_end, scene.frame_step
        frames = (a, b, step)
        moving = moving_objects(scene)
        if not moving:
            # Only the camera moves: one export with its animation, one cache, and one
            # bbc-render run for every frame (bbc-render --frames).
            export_scene(p["scene"], animations=True)
            computed = yield from ensure_cache(settings, scene, p, log)
            result = yield Command(render_argv(settings, scene, p, p["caustics"], frames=frames),
                                   "rendering caustics, frames %d-%d" % (a, b))
            if result.returncode != 0:
                raise BBCError(result.last_line())
        else:
            # Other objects move: the scene (and the cache bbc accepts) differ per frame,
            # so each frame is exported and rendered on its own; bbc recomputes the cache
            # whenever it refuses the previous one.
            log("INFO", "bbc: %s animated: exporting every frame" % ", ".join(moving[:3]))
            current = scene.frame_current
            try:
                for f in range(a, b + 1, step):
                    scene.frame_set(f)
                    export_scene(p["scene"], animations=False)
                    computed = (yield from ensure_cache(settings, scene, p, log)) or computed
                    result = yield Command(render_argv(settings, scene, p, frame_path(p, f)),
                                           "rendering caustics, frame %d" % f)
                    if result.returncode != 0:
                        raise BBCError(result.last_line())
            finally:
                scene.frame_set(current)
        image = frame_path(p, a)
    changes = setup_cycles(scene)
    setup_compositor(scene, image, frames)
    for c in changes:
        log("INFO", "bbc: " + c)
    return {"computed": computed, "paths": p, "image": image}


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


# ---------------------------------------------------------------------------- Cycles

def setup_cycles(scene):
    """Switches off what would count caustics twice or blur differently from bbc, and
    says what it changed. Cycles' own reflective and refractive caustics (the paths bbc's
    pass holds) go, and so do MNEE shadow caustics (a light's "Shadow Caustics"). bbc's
    EXR is the mean radiance over each pixel, a 1-pixel box filter, which Cycles' Box
    filter of width 1 matches."""
    changes = []
    cy = getattr(scene, "cycles", None)
    if scene.render.engine != "CYCLES":
        changes.append("the render engine is %s, not Cycles: set it to Cycles"
                       % scene.render.engine)
    if cy is not None:
        for attr in ("caustics_reflective", "caustics_refractive"):
            if getattr(cy, attr, False):
                setattr(cy, attr, False)
                changes.append("Cycles %s switched off" % attr.replace("_", " "))
        if getattr(cy, "pixel_filter_type", "BOX") != "BOX" or cy.filter_width != 1.0:
            cy.pixel_filter_type = "BOX"
            cy.filter_width = 1.0
            changes.append("Cycles pixel filter set to Box, 1 px (bbc's pixel filter)")
    for o in scene.objects:
        if o.type == "LIGHT":
            lc = getattr(o.data, "cycles", None)
            if lc is not None and getattr(lc, "is_caustics_light", False):
                lc.is_caustics_light = False
                changes.append("shadow caustics of light %s switched off" % o.name)
    return changes


# ---------------------------------------------------------------------------- compositor

def compositor_tree(scene):
    """The scene's compositing node tree, created if needed, and whether it is a node
    group (5.0 and later: scene.compositing_node_group, its result on a Group Output
    node) rather than the scene's own tree (up to 4.5: scene.node_tree and a Composite
    node)."""
    if hasattr(scene, "compositing_node_group"):
        tree = scene.compositing_node_group
        if tree is None:
            tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
            scene.compositing_node_group = tree
        return tree, True
    scene.use_nodes = True
    return scene.node_tree, False


def _node(tree, idname, name, location):
    node = tree.nodes.get(name)
    if node is None or node.bl_idname != idname:
        if node is not None:
            tree.nodes.remove(node)
        node = tree.nodes.new(idname)
        node.name = name
    node.label = name
    node.location = location
    return node


def _mix_sockets(node):
    """(factor, A, B, result) of a colour mix node. MixRGB: Fac, Image, Image_001 and
    Image. The shared Mix node has a float, a vector and a colour variant of each, told
    apart by identifier (Factor_Float, A_Color, B_Color, Result_Color, the names 5.0's
    versioning gives a converted MixRGB), whatever sockets are shown."""
    if node.bl_idname == "ShaderNodeMix":
        ins = {s.identifier: s for s in node.inputs}
        outs = {s.identifier: s for s in node.outputs}
        return ins["Factor_Float"], ins["A_Color"], ins["B_Color"], outs["Result_Color"]
    return node.inputs[0], node.inputs[1], node.inputs[2], node.outputs[0]


def _mix_node(tree, name, blend, location, shared):
    """A colour mix node: the compositor's MixRGB up to 4.5; from 5.0 (shared: the tree
    is a node group) the shared Mix node (ShaderNodeMix, data type RGBA), which 5.0's
    Add menu offers as "Mix Color" and into which it converts old MixRGB nodes when it
    reads a file. The other is tried when the tree refuses the first."""
    kinds = ("ShaderNodeMix", "CompositorNodeMixRGB")
    node = tree.nodes.get(name)
    if node is not None and node.bl_idname not in kinds:
        tree.nodes.remove(node)
        node = None
    if node is None:
        first, second = kinds if shared else reversed(kinds)
        try:
            node = tree.nodes.new(first)
        except RuntimeError:  # an undefined type, or one this tree does not accept
            node = tree.nodes.new(second)
        node.name = name
    if node.bl_idname == "ShaderNodeMix":
        node.data_type = "RGBA"
        node.clamp_factor = False
        node.clamp_result = False
    else:
        node.use_clamp = False
    node.label = name
    node.location = location
    node.blend_type = blend
    _mix_sockets(node)[0].default_value = 1.0
    return node


def _set_linear(image):
    """Marks the image as scene-linear Rec.709, the space bbc writes: "Linear" in 3.x's
    OCIO configuration, "Linear Rec.709" from 4.0. The names are read from the image's own
    colour space enum (its items come from the configuration Blender runs with)."""
    settings = image.colorspace_settings
    names = {i.identifier for i in settings.bl_rna.properties["name"].enum_items}
    for n in ("Linear Rec.709", "Linear"):
        if n in names:
            settings.name = n
            return n
    return None


def setup_compositor(scene, image_path, frames=None):
    """Render Layers' image plus bbc's caustic pass (times Cycles' film exposure, which
    scales Cycles' render the same way) goes wherever the render layer's image went
    before, so the user's own compositing applies to the sum. The addition happens in
    scene-linear light, before the view transform; bbc's EXR is linear Rec.709, Blender's
    scene-linear space. Running it again updates the nodes (names start with "bbc ")."""
    tree, is_group = compositor_tree(scene)
    layers = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if layers is None:
        layers = tree.nodes.new("CompositorNodeRLayers")
        layers.location = (-300, 300)
    out_type = "NodeGroupOutput" if is_group else "CompositorNodeComposite"
    output = next((n for n in tree.nodes if n.bl_idname == out_type), None)
    if output is None:
        if is_group and not any(
                i.in_out == "OUTPUT" for i in tree.interface.items_tree
                if getattr(i, "item_type", "") == "SOCKET"):
            tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        output = tree.nodes.new(out_type)
        output.location = (500, 300)

    x, y = layers.location
    img_node = _node(tree, "CompositorNodeImage", NODE_PREFIX + "caustics", (x, y - 400))
    add = _mix_node(tree, NODE_PREFIX + "add caustics", "ADD", (x + 450, y), is_group)

    path = bpy.path.relpath(image_path) if bpy.data.filepath else image_path
    image = img_node.image
    if image is None or bpy.path.abspath(image.filepath) != image_path:
        image = bpy.data.images.load(image_path, check_existing=True)
    image.filepath = path
    if frames:
        image.source = "SEQUENCE"
        a, b, step = frames
        img_node.frame_start = a
        img_node.frame_duration = b - a + 1
        img_node.frame_offset = a - 1
    else:
        image.source = "FILE"
    _set_linear(image)
    image.reload()
    img_node.image = image

    source = img_node.outputs["Image"]
    exposure = getattr(getattr(scene, "cycles", None), "film_exposure", 1.0)
    old = tree.nodes.get(NODE_PREFIX + "exposure")
    if exposure != 1.0:
        mul = _mix_node(tree, NODE_PREFIX + "exposure", "MULTIPLY", (x + 200, y - 400),
                        is_group)
        _, a_in, b_in, mul_out = _mix_sockets(mul)
        b_in.default_value = (exposure, exposure, exposure, 1.0)
        tree.links.new(source, a_in)
        source = mul_out
    elif old is not None:
        tree.nodes.remove(old)

    _, first, second, result = _mix_sockets(add)
    # Whatever read the render layer's image now reads the sum (done once: later runs
    # find the links already going through the add node).
    image_out = layers.outputs["Image"]
    targets = [l.to_socket for l in tree.links if l.from_socket == image_out
               and l.to_node != add]
    for sock in targets:
        tree.links.new(result, sock)
    if not targets and not any(l.from_socket == result for l in tree.links):
        tree.links.new(result, output.inputs[0])
    tree.links.new(image_out, first)
    tree.links.new(source, second)
    return tree
