"""Writes a small glTF scene (buffers inline) for the writer edge-case tests of
test_precompute.sh: a mirror triangle above a floor lit by a point light, and one more
receiver mesh whose shape is the edge case.

    python3 edge_scene.py OUT.gltf KIND

KIND: point (the extra receiver's three vertices are one point), one-triangle (the
floor is a single triangle, no extra receiver), zero-area (the extra receiver's
triangles are segments), mixed-zero-area (the floor has a degenerate triangle besides
its two), huge (everything scaled by 1e30), tiny (scaled by 1e-30), dark (no light),
empty-receiver (the extra receiver has no triangle)."""
import base64, json, struct, sys

out, kind = sys.argv[1], sys.argv[2]
scale = {"huge": 1e30, "tiny": 1e-30}.get(kind, 1.0)
mirror = [(0, 0, -1), (0, 2, -1), (0, 0, 1)]
floor = [(-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2)]
floor_idx = [0, 2, 1, 0, 3, 2]
extra, extra_idx = [(1, 0.5, 0.5)] * 3, [0, 1, 2]
if kind == "one-triangle":
    floor, floor_idx, extra, extra_idx = floor[:3], [0, 2, 1], [], []
elif kind == "zero-area":
    extra, extra_idx = [(1, 0.2, 0.0), (1.5, 0.2, 0.5), (2, 0.2, 1.0)], [0, 1, 2, 2, 1, 0]
elif kind == "mixed-zero-area":
    floor = floor + [(0, 0, 0)]
    floor_idx = floor_idx + [0, 4, 2]
    extra, extra_idx = [], []
elif kind == "empty-receiver":
    extra_idx = []
meshes_pos = [mirror, floor] + ([extra] if extra else [])
meshes_idx = [[0, 1, 2, 0, 2, 1], floor_idx] + ([extra_idx] if extra else [])
blob, views, accessors = b"", [], []
for pos in meshes_pos:
    p = [tuple(scale * c for c in v) for v in pos]
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 12 * len(p)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(p),
                      "type": "VEC3", "min": [min(v[k] for v in p) for k in range(3)],
                      "max": [max(v[k] for v in p) for k in range(3)]})
    blob += b"".join(struct.pack("<3f", *v) for v in p)
for idx in meshes_idx:
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 4 * len(idx)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5125, "count": len(idx),
                      "type": "SCALAR"})
    blob += struct.pack("<%dI" % len(idx), *idx)
n = len(meshes_pos)
meshes = [{"primitives": [{"attributes": {"POSITION": i}, "indices": n + i,
                           "material": 0 if i == 0 else 1}]} for i in range(n)]
nodes = [{"mesh": 0}] + [{"mesh": i, "extras": {"bbc": {"role": "receiver"}}}
                         for i in range(1, n)]
nodes.append({"camera": 0, "translation": [2 * scale, 6 * scale, 0],
              "rotation": [-0.7071067811865475, 0, 0, 0.7071067811865476]})
g = {"asset": {"version": "2.0", "extras": {"bbc": {"light_units": "radiometric"}}},
     "scene": 0, "nodes": nodes, "meshes": meshes,
     "cameras": [{"type": "perspective",
                  "perspective": {"aspectRatio": 1.333, "yfov": 0.7, "znear": 0.01 * scale}}],
     "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                                             "metallicFactor": 1, "roughnessFactor": 0}},
                   {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                             "metallicFactor": 0}}],
     "buffers": [{"byteLength": len(blob),
                  "uri": "data:application/octet-stream;base64," +
                         base64.b64encode(blob).decode()}],
     "bufferViews": views, "accessors": accessors}
if kind != "dark":
    g["extensionsUsed"] = ["KHR_lights_punctual"]
    g["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 1, 1], "intensity": 10}]}}
    nodes.append({"translation": [1 * scale, 1 * scale, 0],
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
g["scenes"] = [{"nodes": list(range(len(nodes)))}]
json.dump(g, open(out, "w"))
