#!/usr/bin/env python3
"""Lit versions of the public sample assets in the shared scenes' real/ folder.

    python3 bench/real-assets-scenes.py REAL_DIR OUT_DIR

REAL_DIR holds TransmissionTest/ and GlassVaseFlowers/ (Khronos glTF sample assets,
unchanged; read real/README.md). Neither has a light, and GlassVaseFlowers has no
floor and no camera; this writes, for each, a new .gltf into OUT_DIR that adds what
real/README.md says a user added when they were first tried, and references the
original .bin files and images by relative URIs (the loader resolves URIs relative to
the .gltf it reads, and a relative URI is the only kind it accepts). The originals are
only read: nothing is copied or changed.

The light is a point light as Blender's glTF exporter writes a lamp of P watts in its
default (Standard) lighting mode: KHR_lights_punctual intensity = P / (4 pi) * 683 cd,
white, no light_units extras (so photometric, which bbc reads back as P / (4 pi) W/sr).

- TransmissionTest-lit.gltf: a 100 W lamp at (0.4, 0.9, 1.0); the asset's own camera.
- GlassVaseFlowers-lit.gltf: a 20 W lamp at (-0.13, 0.45, 0.15) over a 1.2 m square
  floor of albedo 0.8 at y = 0 centred under it (a new mesh in a new buffer, a base64
  data URI), and a camera in front of and above the vase with KHR_materials_volume
  (at x = 0.12), looking down at it and at the floor behind it, where its caustic lands.

Prints the paths written, one a line. Standard library only.
"""
import base64
import json
import math
import os
import struct
import sys
import urllib.parse

LUMENS_PER_WATT = 683.0


def blender_point_light(watts, name):
    return {"color": [1.0, 1.0, 1.0], "intensity": watts / (4.0 * math.pi) * LUMENS_PER_WATT,
            "type": "point", "name": name}


def relative_uri(target, out_dir):
    """The URI of file `target` relative to the folder `out_dir` (percent-encoded)."""
    rel = os.path.relpath(os.path.realpath(target), os.path.realpath(out_dir))
    return urllib.parse.quote(rel.replace(os.sep, "/"), safe="/._-~")


def rebase(gltf, src_dir, out_dir):
    """Points every external buffer and image URI of `gltf` (read from src_dir) at the
    original file, relative to out_dir; data URIs stay as they are."""
    for item in gltf.get("buffers", []) + gltf.get("images", []):
        uri = item.get("uri")
        if uri is None or uri.startswith("data:"):
            continue
        target = os.path.join(src_dir, urllib.parse.unquote(uri))
        if not os.path.isfile(target):
            sys.exit("real-assets-scenes.py: %s: no such file (named by %s)" % (target, src_dir))
        item["uri"] = relative_uri(target, out_dir)


def add_light(gltf, light, translation):
    """Adds `light` as KHR_lights_punctual on a new root node at `translation`."""
    ext = gltf.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {})
    lights = ext.setdefault("lights", [])
    lights.append(light)
    used = gltf.setdefault("extensionsUsed", [])
    if "KHR_lights_punctual" not in used:
        used.append("KHR_lights_punctual")
    add_root(gltf, {"name": light["name"], "translation": list(translation),
                    "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}})


def add_root(gltf, node):
    gltf.setdefault("nodes", []).append(node)
    gltf["scenes"][gltf.get("scene", 0)]["nodes"].append(len(gltf["nodes"]) - 1)


def add_floor(gltf, centre_x, centre_z, side, albedo):
    """A square floor at y = 0, facing +Y (counter-clockwise seen from above), diffuse:
    metallic 0, roughness 1, baseColor albedo. Its own buffer, a base64 data URI."""
    h = side / 2.0
    x0, x1, z0, z1 = centre_x - h, centre_x + h, centre_z - h, centre_z + h
    positions = [(x0, 0.0, z0), (x0, 0.0, z1), (x1, 0.0, z1), (x1, 0.0, z0)]
    normals = [(0.0, 1.0, 0.0)] * 4
    indices = [0, 1, 2, 0, 2, 3]
    data = b"".join(struct.pack("<3f", *p) for p in positions)
    data += b"".join(struct.pack("<3f", *n) for n in normals)
    data += struct.pack("<6H", *indices) + b"\0\0"  # padded to 4 bytes
    gltf.setdefault("buffers", []).append({
        "byteLength": len(data),
        "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")})
    buf = len(gltf["buffers"]) - 1
    views = gltf.setdefault("bufferViews", [])
    views += [{"buffer": buf, "byteOffset": 0, "byteLength": 48, "target": 34962},
              {"buffer": buf, "byteOffset": 48, "byteLength": 48, "target": 34962},
              {"buffer": buf, "byteOffset": 96, "byteLength": 12, "target": 34963}]
    v = len(views) - 3
    acc = gltf.setdefault("accessors", [])
    acc += [{"bufferView": v, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [x0, 0.0, z0], "max": [x1, 0.0, z1]},
            {"bufferView": v + 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": v + 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    a = len(acc) - 3
    mats = gltf.setdefault("materials", [])
    mats.append({"name": "Floor", "pbrMetallicRoughness": {
        "baseColorFactor": [albedo, albedo, albedo, 1.0], "metallicFactor": 0.0,
        "roughnessFactor": 1.0}})
    meshes = gltf.setdefault("meshes", [])
    meshes.append({"name": "Floor", "primitives": [{
        "attributes": {"POSITION": a, "NORMAL": a + 1}, "indices": a + 2,
        "material": len(mats) - 1}]})
    add_root(gltf, {"name": "Floor", "mesh": len(meshes) - 1})


def look_at(eye, target):
    """The rotation quaternion (x, y, z, w) of a glTF camera node at eye looking at
    target (the camera looks along its -Z, +Y up, world +Y up)."""
    def norm(v):
        n = math.sqrt(sum(c * c for c in v))
        return [c / n for c in v]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

    z = norm([e - t for e, t in zip(eye, target)])  # the camera's +Z points backwards
    x = norm(cross([0.0, 1.0, 0.0], z))
    y = cross(z, x)
    m = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, s / 4]
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2])
        q = [s / 4, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
    elif m[1][1] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2])
        q = [(m[0][1] + m[1][0]) / s, s / 4, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1])
        q = [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, s / 4, (m[1][0] - m[0][1]) / s]
    return q


def write(gltf, path):
    with open(path + ".tmp", "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    os.replace(path + ".tmp", path)
    print(path)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: python3 bench/real-assets-scenes.py REAL_DIR OUT_DIR")
    real, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)

    src = os.path.join(real, "TransmissionTest")
    with open(os.path.join(src, "TransmissionTest.gltf")) as f:
        g = json.load(f)
    rebase(g, src, out)
    add_light(g, blender_point_light(100.0, "Light"), (0.4, 0.9, 1.0))
    write(g, os.path.join(out, "TransmissionTest-lit.gltf"))

    src = os.path.join(real, "GlassVaseFlowers")
    with open(os.path.join(src, "GlassVaseFlowers.gltf")) as f:
        g = json.load(f)
    rebase(g, src, out)
    light = (-0.13, 0.45, 0.15)
    add_light(g, blender_point_light(20.0, "Light"), light)
    add_floor(g, light[0], light[2], 1.2, 0.8)
    # The vase with KHR_materials_volume stands at x = 0.12, 0.14 m tall; the lamp is
    # to its front left, so its caustic falls behind it to the right, around
    # (0.15..0.25, 0, -0.1..0): seen from the front and well above.
    eye, target = (0.12, 0.5, 0.45), (0.15, 0.04, -0.02)
    g.setdefault("cameras", []).append({"name": "Camera", "type": "perspective", "perspective": {
        "yfov": 0.6, "aspectRatio": 4.0 / 3.0, "znear": 0.01, "zfar": 10.0}})
    add_root(g, {"name": "Camera", "camera": len(g["cameras"]) - 1, "translation": list(eye),
                 "rotation": look_at(eye, target)})
    write(g, os.path.join(out, "GlassVaseFlowers-lit.gltf"))

    # The same with the floor as the only receiver: the flowers and the alpha-blended
    # vase (curved meshes, whose tuples end on each of their triangles) get role none.
    for node in g["nodes"]:
        if node.get("name") in ("Flowers1", "Flowers2", "GlassAlpha"):
            node.setdefault("extras", {})["bbc"] = {"role": "none"}
    write(g, os.path.join(out, "GlassVaseFlowers-floor-lit.gltf"))


if __name__ == "__main__":
    main()
