# The checks of tests/blender/test_blender.sh, run inside Blender (headless):
#   blender -b --factory-startup --python-exit-code 1 --python check.py -- TEST WORKDIR
# Each TEST below is one function; a failed check raises, and --python-exit-code turns
# that into exit status 1. The add-on is installed from the zip the build makes, into the
# user scripts folder the test gives Blender (BLENDER_USER_SCRIPTS), exactly as a user
# installs it; the bbc tools are found on PATH. Images are read by Blender itself (its
# float EXR reader, bottom row first), as lists of floats, since Debian's Blender has
# NumPy only for its exporter's sake and the tests need nothing more.
import math
import os
import struct
import subprocess
import sys

import addon_utils
import bpy

TEST, WORK = sys.argv[sys.argv.index("--") + 1:][:2]
SOURCE = os.environ["BBC_SOURCE_DIR"]
ZIP = os.path.join(os.environ["BBC_BIN"], "blender", "bbc_blender.zip")
BLEND = os.path.join(WORK, "scene.blend")
# Small and quick: the cache is bounded coarsely (it stays conservative at any level),
# and both renders take 16 samples per pixel at 160x120.
PRECOMPUTE_OPTIONS = "--max-level 4 --resolution 128"


def fail(msg):
    raise AssertionError(msg)


def install_addon():
    bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
    addon_utils.enable("bbc_blender", default_set=True)
    if not hasattr(bpy.types.Scene, "bbc"):
        fail("the add-on did not register its settings")


def open_scene():
    """The test scene (tests/blender/scene.py), built once per test in its own folder."""
    subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python",
                    os.path.join(SOURCE, "tests", "blender", "scene.py"), "--", BLEND],
                   check=True, stdout=subprocess.DEVNULL)
    bpy.ops.wm.open_mainfile(filepath=BLEND)
    s = bpy.context.scene.bbc
    s.precompute_options = PRECOMPUTE_OPTIONS
    s.samples = 16
    s.threads = 2


def run(op, **kw):
    r = op(**kw)
    if r != {"FINISHED"}:
        fail("%s returned %s" % (op.idname_py(), r))


def read_exr(path):
    img = bpy.data.images.load(path, check_existing=False)
    w, h = img.size
    px = list(img.pixels[:])
    bpy.data.images.remove(img)
    return w, h, px


def write_png(path, w, h, px):
    """A PNG through the scene's view transform (Standard), for the figures."""
    img = bpy.data.images.new("png", w, h, float_buffer=True)
    img.pixels[:] = px
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Standard"
    img.save_render(path, scene=scene)
    bpy.data.images.remove(img)


def render_with_layers(out_dir, frame=None):
    """Renders with Cycles and the add-on's compositing; returns the composite and, from a
    File Output node on Render Layers, Cycles' own image (both 32-bit float EXR)."""
    scene = bpy.context.scene
    tree = scene.node_tree
    layers = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers")
    fo = tree.nodes.new("CompositorNodeOutputFile")
    fo.base_path = out_dir
    fo.format.file_format = "OPEN_EXR"
    fo.format.color_depth = "32"
    fo.file_slots[0].path = "cycles"
    tree.links.new(layers.outputs["Image"], fo.inputs[0])
    if frame is not None:
        scene.frame_set(frame)
    f = scene.frame_current
    scene.render.filepath = os.path.join(out_dir, "composite.exr")
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    bpy.ops.render.render(write_still=True)
    tree.nodes.remove(fo)
    return (read_exr(os.path.join(out_dir, "composite.exr")),
            read_exr(os.path.join(out_dir, "cycles%04d.exr" % f)))


def cache_state():
    p = bpy.context.scene.bbc
    from bbc_blender import pipeline
    path = pipeline.paths(p)["cache"]
    st = os.stat(path)
    with open(path, "rb") as f:
        return (st.st_ino, st.st_mtime_ns, f.read())


def floor_pixels(w, h):
    """The pixels (indices into Blender's bottom-up rows) whose centre and 8 neighbours'
    centres see the floor directly (no glass, water or edge in between), each with the
    floor point its centre sees."""
    scene = bpy.context.scene
    cam = scene.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = cam.data.view_frame(scene=scene)  # top-right, bottom-right, bottom-left, top-left
    tr, br, bl, tl = (cam.matrix_world @ v for v in frame)
    origin = cam.matrix_world.translation
    hit = [[None] * w for _ in range(h)]
    for j in range(h):            # j from the top
        for i in range(w):
            u, v = (i + 0.5) / w, (j + 0.5) / h
            target = tl.lerp(tr, u).lerp(bl.lerp(br, u), v)
            ok, loc, nrm, idx, obj, mat = scene.ray_cast(depsgraph, origin,
                                                          (target - origin).normalized())
            if ok and obj.name == "Floor":
                hit[j][i] = loc
    out = []
    for j in range(1, h - 1):
        for i in range(1, w - 1):
            if all(hit[j + dj][i + di] is not None for dj in (-1, 0, 1) for di in (-1, 0, 1)):
                out.append(((h - 1 - j) * w + i, hit[j][i]))
    return out


def f32(x):
    """x rounded to single precision: the compositor adds in float, Python in double."""
    return struct.unpack("f", struct.pack("f", x))[0]


def max_sum_error(comp, a, b):
    """The largest |comp - (a + b)| over the colour channels, the sum taken in float."""
    return max(abs(comp[k] - f32(a[k] + b[k])) for k in range(len(comp)) if k % 4 != 3)


def luminance(px, k):
    return 0.2126 * px[4 * k] + 0.7152 * px[4 * k + 1] + 0.0722 * px[4 * k + 2]


# ---------------------------------------------------------------------------- tests

# The extension manifest's rules, from the Blender manual (4.2 and later: "How to Create
# Extensions", its Manifest section, and "Extensions Tags").
MANIFEST_REQUIRED = ("schema_version", "id", "version", "name", "tagline", "maintainer",
                     "type", "blender_version_min", "license")
MANIFEST_PERMISSIONS = ("files", "network", "clipboard", "camera", "microphone")
ADDON_TAGS = ("3D View", "Add Curve", "Add Mesh", "Animation", "Bake", "Camera",
              "Compositing", "Development", "Game Engine", "Geometry Nodes",
              "Grease Pencil", "Import-Export", "Lighting", "Material", "Modeling", "Mesh",
              "Node", "Object", "Paint", "Pipeline", "Physics", "Render", "Rigging",
              "Scene", "Sculpt", "Sequencer", "System", "Text Editor", "Tracking",
              "User Interface", "UV")


def check_manifest():
    """blender_manifest.toml in the zip, against the manual's rules (Blender 3.4 cannot
    validate an extension itself): the required values present and not empty; the
    tagline and each permission's reason one line of at most 64 characters without final
    punctuation; known permissions and tags; semantic versions, the same as bl_info's;
    the id the name of the zip's folder, which is the add-on's module."""
    import re
    import tomllib
    import zipfile
    with zipfile.ZipFile(ZIP) as z:
        folders = {n.split("/")[0] for n in z.namelist()}
        m = tomllib.loads(z.read("bbc_blender/blender_manifest.toml").decode("utf-8"))
    for key in MANIFEST_REQUIRED:
        if not m.get(key):
            fail("manifest: %s missing or empty" % key)
    for key, value in m.items():
        if value in ("", [], {}):
            fail("manifest: %s is empty (leave it out instead)" % key)
    short = [("tagline", m["tagline"])] + [("permission " + k, v) for k, v in
                                           m.get("permissions", {}).items()]
    for what, text in short:
        if len(text) > 64 or "\n" in text or text[-1] in ".,;:!?":
            fail("manifest: %s %r: at most 64 characters, one line, no final punctuation"
                 % (what, text))
    for k in m.get("permissions", {}):
        if k not in MANIFEST_PERMISSIONS:
            fail("manifest: unknown permission %s" % k)
    for t in m.get("tags", []):
        if t not in ADDON_TAGS:
            fail("manifest: %r is not an add-on tag" % t)
    semver = re.compile(r"^(\d+)\.(\d+)\.(\d+)$")
    for key in ("schema_version", "version", "blender_version_min"):
        if not semver.match(m[key]):
            fail("manifest: %s %r is not MAJOR.MINOR.PATCH" % (key, m[key]))
    if tuple(int(x) for x in m["blender_version_min"].split(".")) < (4, 2, 0):
        fail("manifest: blender_version_min below 4.2.0")
    if m["type"] != "add-on" or not all(l.startswith("SPDX:") for l in m["license"]):
        fail("manifest: type %r, license %r" % (m["type"], m["license"]))
    if folders != {m["id"]} or m["id"] != "bbc_blender":
        fail("manifest: id %r, zip folders %s" % (m["id"], sorted(folders)))
    import bbc_blender
    if ".".join(str(v) for v in bbc_blender.bl_info["version"]) != m["version"]:
        fail("manifest version %s, bl_info %s" % (m["version"], bbc_blender.bl_info["version"]))


def test_install():
    """The zip installs and enables; the operators and the panel exist; without the tools
    the operators refuse in one line instead of failing later. The extension manifest
    follows the manual's rules."""
    install_addon()
    check_manifest()
    for name in ("precompute", "render_caustics"):
        if not hasattr(bpy.ops.bbc, name):
            fail("bpy.ops.bbc.%s missing" % name)
    if not hasattr(bpy.types, "RENDER_PT_bbc"):
        fail("the render properties panel is not registered")
    open_scene()
    bpy.context.scene.bbc.tools_dir = os.path.join(WORK, "nowhere")
    try:
        bpy.ops.bbc.precompute()
    except RuntimeError as e:
        if "bbc-precompute not found in" not in str(e):
            fail("message: %s" % e)
    else:
        fail("precompute without the tools did not fail")


def test_composite():
    """The composite is Cycles' render plus bbc's caustic pass, exactly: the compositor
    adds the two float images and nothing else happens to either (colour management
    comes after, on the sum). Cycles' own caustics are off; the pass holds caustics."""
    install_addon()
    open_scene()
    run(bpy.ops.bbc.render_caustics)
    scene = bpy.context.scene
    if scene.cycles.caustics_reflective or scene.cycles.caustics_refractive:
        fail("Cycles' caustics are still on")
    if scene.cycles.pixel_filter_type != "BOX" or scene.cycles.filter_width != 1.0:
        fail("pixel filter %s %g" % (scene.cycles.pixel_filter_type, scene.cycles.filter_width))
    (w, h, comp), (_, _, cyc) = render_with_layers(WORK)
    from bbc_blender import pipeline
    cw, ch, caus = read_exr(pipeline.paths(scene.bbc)["caustics"])
    if (cw, ch) != (w, h) or (w, h) != (160, 120):
        fail("sizes: composite %dx%d, caustics %dx%d" % (w, h, cw, ch))
    worst = max_sum_error(comp, cyc, caus)
    print("composite - (cycles + caustics): max |difference| %g" % worst)
    if worst != 0.0:
        fail("the composite differs from Cycles + caustics by up to %g" % worst)
    lit = sum(1 for k in range(w * h) if luminance(caus, k) > 0.05)
    print("caustic pass: %d of %d pixels above 0.05" % (lit, w * h))
    if lit < 50:
        fail("the caustic pass is nearly black (%d pixels above 0.05)" % lit)
    figures = os.environ.get("BBC_BLENDER_FIGURES")
    if figures:
        write_png(os.path.join(figures, "blender-cycles.png"), w, h, cyc)
        write_png(os.path.join(figures, "blender-composite.png"), w, h, comp)
        write_png(os.path.join(figures, "blender-caustics.png"), w, h, caus)
    # Film exposure 2: Cycles doubles its render and the add-on's Multiply node ("bbc
    # exposure", added when the operator runs again) doubles the pass; the composite is
    # still their sum, exactly.
    scene.cycles.film_exposure = 2.0
    run(bpy.ops.bbc.render_caustics)
    if scene.node_tree.nodes.get("bbc exposure") is None:
        fail("no exposure node with film exposure 2")
    (_, _, comp2), (_, _, cyc2) = render_with_layers(WORK)
    scaled = [f32(2.0 * v) for v in caus]
    worst = max_sum_error(comp2, cyc2, scaled)
    doubled = max(abs(cyc2[k] - 2.0 * cyc[k]) for k in range(len(cyc)) if k % 4 != 3)
    print("composite with exposure 2 - (cycles + 2 caustics): max |difference| %g; "
          "cycles at exposure 2 - 2 cycles: %g" % (worst, doubled))
    if worst != 0.0:
        fail("with film exposure 2 the composite differs from Cycles + 2 x caustics by %g"
             % worst)
    if doubled > 1e-5 * max(cyc):
        fail("Cycles' film exposure 2 is not twice its render (%g)" % doubled)


def compare_means(pixels, comp, ref):
    """The mean of the composite over the pixels against the mean of bbc's render there:
    comp / ref - 1 of the sums, with its standard error from the per-pixel differences
    (sd(comp - ref) sqrt(n) / sum ref; the pixels' noise is independent). Returns
    (difference, standard error)."""
    n = len(pixels)
    diff = [luminance(comp, k) - luminance(ref, k) for k in pixels]
    total = sum(luminance(ref, k) for k in pixels)
    mean = sum(diff) / n
    sd = math.sqrt(sum((e - mean) ** 2 for e in diff) / (n - 1))
    return sum(diff) / total, sd * math.sqrt(n) / total


def compare_medians(pixels, comp, ref):
    """The median of the per-pixel relative differences comp / ref - 1 and its standard
    error (1.2533 sd / sqrt(n) for a median)."""
    rel = sorted((luminance(comp, k) - luminance(ref, k)) / luminance(ref, k)
                 for k in pixels if luminance(ref, k) > 0.0)
    n = len(rel)
    median = 0.5 * (rel[(n - 1) // 2] + rel[n // 2])
    mean = sum(rel) / n
    sd = math.sqrt(sum((e - mean) ** 2 for e in rel) / (n - 1))
    return median, 1.2533 * sd / math.sqrt(n)


# What Cycles' and bbc's direct light on the Lambert floor may differ by apart from noise:
# single-precision rounding (the exporter's light intensity, 32-bit images, Cycles' float
# shading), a few 1e-7 each. Measured, Cycles' Lambert floor against bbc-render --only
# direct on the 4,981 floor pixels without caustic: -0.001 % with a standard error of
# 0.0007 %; 0.01 % is ten times that.
MODEL_MARGIN = 1e-4


def test_floor():
    """Where caustics fall on the floor seen directly, and where the light falls on it
    directly, the composite (Cycles without caustics + bbc's caustic pass) matches bbc's
    own render of the same export and cache, direct light and caustics (bbc-render --only
    direct,caustics): the two agree on the point light's units, the camera and the
    diffuse floor, and nothing is counted twice or lost. Both the means over each set of
    pixels and the medians of the per-pixel differences must agree within 4 standard
    errors plus MODEL_MARGIN. bbc's full render also holds caustics lit by the floor's
    own glow (light, floor, glass, floor, eye), which Cycles without caustics drops and
    the caustic pass does not hold: 0.5 % of this lit floor on average, measured, left out
    of the comparison and said in docs/blender.md."""
    install_addon()
    open_scene()
    run(bpy.ops.bbc.render_caustics)
    scene = bpy.context.scene
    # Cycles renders the floor with a Diffuse BSDF, Lambert's model as bbc's, after the
    # export: Blender 3.4's Principled diffuse is Burley's, whose retro-reflection makes
    # this floor 2.1 % brighter on average than Lambert's (docs/blender.md); 4.0 made it
    # Lambert's.
    floor_mat = bpy.data.materials["Floor"]
    nodes, links = floor_mat.node_tree.nodes, floor_mat.node_tree.links
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    links.new(diffuse.outputs[0], nodes["Material Output"].inputs["Surface"])
    (w, h, comp), (_, _, cyc) = render_with_layers(WORK)
    from bbc_blender import pipeline
    p = pipeline.paths(scene.bbc)
    bbc_render = [pipeline.find_tool(scene.bbc, "bbc-render"), p["scene"], "--cache",
                  p["cache"], "--camera", "View", "--width", str(w), "--height", str(h),
                  "--threads", "2", "--no-progress"]
    full = os.path.join(WORK, "bbc-full.exr")
    subprocess.run(bbc_render + ["-o", full, "--spp", "64", "--only", "direct,caustics"],
                   check=True, stderr=subprocess.DEVNULL)
    # The pixels are chosen on a third image, bbc's caustics alone with another seed (every
    # tuple evaluated at each sample): its noise is independent of both images compared.
    # Choosing them on the caustic pass itself biases both sets: where its 16 samples
    # missed a faint caustic, that pixel joins the lit floor while the reference's 64
    # samples see the caustic (-0.52 % over that set), and where one sample met a thin
    # bright caustic line, the pixel joins the caustic set with its pass above the
    # reference's (+1.6 %). docs/blender.md, "Tests", gives the figures.
    chooser = os.path.join(WORK, "bbc-chooser.exr")
    subprocess.run(bbc_render + ["-o", chooser, "--spp", "64", "--only", "caustics",
                                 "--method", "enumerate", "--seed", "1"],
                   check=True, stderr=subprocess.DEVNULL)
    _, _, ref = read_exr(full)
    _, _, chosen = read_exr(chooser)
    floor = floor_pixels(w, h)
    direct = [k for k, _ in floor if luminance(chosen, k) == 0.0]
    caustic = [k for k, _ in floor if luminance(chosen, k) > 0.1]
    print("floor pixels seen directly: %d; without caustic %d, with caustic > 0.1: %d"
          % (len(floor), len(direct), len(caustic)))
    if len(caustic) < 30 or len(direct) < 300:
        fail("too few pixels to compare")
    for name, pixels in (("lit floor", direct), ("caustic", caustic)):
        mean, mean_se = compare_means(pixels, comp, ref)
        median, median_se = compare_medians(pixels, comp, ref)
        mean_tol = 4.0 * mean_se + MODEL_MARGIN
        median_tol = 4.0 * median_se + MODEL_MARGIN
        print("%s: %d pixels, composite / bbc - 1: mean %+.4f%% (standard error %.4f%%, "
              "tolerance %.4f%%), median %+.4f%% (standard error %.4f%%, tolerance %.4f%%)"
              % (name, len(pixels), 100 * mean, 100 * mean_se, 100 * mean_tol,
                 100 * median, 100 * median_se, 100 * median_tol))
        if abs(mean) > mean_tol:
            fail("%s: the composite's mean differs from bbc's render's by %+.4f%%, beyond "
                 "%.4f%%" % (name, 100 * mean, 100 * mean_tol))
        if abs(median) > median_tol:
            fail("%s: the composite differs from bbc's render by %+.4f%% (median), beyond "
                 "%.4f%%" % (name, 100 * median, 100 * median_tol))
    # The control: Cycles' render alone, without the caustic pass, is far outside.
    mean, mean_se = compare_means(caustic, cyc, ref)
    print("caustic set, Cycles alone / bbc - 1: mean %+.2f%%" % (100 * mean))
    if abs(mean) <= 4.0 * mean_se + MODEL_MARGIN:
        fail("the comparison cannot tell Cycles alone from the composite")


def test_prepare_window():
    """Not a test by itself: the first step of test_blender.sh's interactive test. The
    add-on installed and enabled in the saved preferences of the test's user folder (a
    window session starts from them), and the test scene saved with its settings."""
    install_addon()
    bpy.context.preferences.use_preferences_save = True
    bpy.ops.wm.save_userpref()
    open_scene()
    bpy.ops.wm.save_mainfile()


def test_camera_reuses():
    """Moving the camera keeps the cache: bbc accepts it for the new export (the camera
    is not part of the scene's fingerprint) and the add-on leaves the file alone."""
    install_addon()
    open_scene()
    run(bpy.ops.bbc.precompute)
    before = cache_state()
    scene = bpy.context.scene
    scene.camera.location.x += 0.4
    scene.camera.rotation_euler.z += math.radians(6.0)
    run(bpy.ops.bbc.precompute)
    run(bpy.ops.bbc.render_caustics)
    if cache_state() != before:
        fail("the cache was rewritten after moving the camera")


def test_glass_recomputes():
    """Moving the glass ball makes bbc refuse the cache for the new export (its geometry
    differs), and the add-on recomputes it; the render then succeeds with the new one."""
    install_addon()
    open_scene()
    run(bpy.ops.bbc.precompute)
    before = cache_state()
    bpy.data.objects["Ball"].location.x += 0.3
    run(bpy.ops.bbc.render_caustics)
    after = cache_state()
    if after[2] == before[2]:
        fail("the cache was kept after moving the glass")


def test_frames():
    """A camera animation over three frames: one bbc-render --frames run writes a caustic
    pass per frame, the compositor reads them as an image sequence, and frame 2's
    composite is Cycles' frame 2 plus caustics frame 2, exactly."""
    install_addon()
    open_scene()
    scene = bpy.context.scene
    scene.render.resolution_percentage = 50
    scene.frame_start, scene.frame_end = 1, 3
    cam = scene.camera
    for f, dx in ((1, -0.3), (3, 0.3)):
        cam.location.x = dx
        cam.keyframe_insert("location", frame=f)
    scene.frame_set(1)
    run(bpy.ops.bbc.render_caustics, animation=True)
    from bbc_blender import pipeline
    p = pipeline.paths(scene.bbc)
    images = [pipeline.frame_path(p, f) for f in (1, 2, 3)]
    for path in images:
        if not os.path.isfile(path):
            fail("%s missing" % path)
    (w, h, comp), (_, _, cyc) = render_with_layers(WORK, frame=2)
    _, _, c1 = read_exr(images[0])
    _, _, c2 = read_exr(images[1])
    worst = max_sum_error(comp, cyc, c2)
    print("frame 2: composite - (cycles + caustics.0002): max |difference| %g" % worst)
    if worst != 0.0:
        fail("frame 2's composite is not Cycles + its caustic pass (%g)" % worst)
    if c1 == c2:
        fail("frames 1 and 2 have the same caustic pass although the camera moved")


globals()["test_" + TEST]()
