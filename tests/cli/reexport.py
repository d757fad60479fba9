"""Writes a copy of a glTF scene (external .bin) as a re-export from an unchanged file
would come out of Blender: every position and normal float moved by a relative 2e-7
(the float noise of another run of the exporter), and each primitive's triangles in
another order with their corners rotated. With MOVE, one vertex of the first mesh is
also moved by that much (a real change of the scene).

    python3 reexport.py IN.gltf OUT.gltf [MOVE]

OUT.bin is written beside OUT.gltf. The noise and the order come from a fixed seed."""
import json, os, random, struct, sys

src, out = sys.argv[1], sys.argv[2]
move = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
g = json.load(open(src))
blob = bytearray(open(os.path.join(os.path.dirname(src), g["buffers"][0]["uri"]), "rb").read())
rng = random.Random(17)


def view(accessor):
    a = g["accessors"][accessor]
    v = g["bufferViews"][a["bufferView"]]
    return a, v.get("byteOffset", 0) + a.get("byteOffset", 0)


moved = False
for mesh in g["meshes"]:
    for prim in mesh["primitives"]:
        for attr in ("POSITION", "NORMAL"):
            a, off = view(prim["attributes"][attr])
            for i in range(3 * a["count"]):
                (x,) = struct.unpack_from("<f", blob, off + 4 * i)
                struct.pack_into("<f", blob, off + 4 * i, x * (1 + rng.uniform(-2e-7, 2e-7)))
            if attr == "POSITION" and move and not moved:
                (y,) = struct.unpack_from("<f", blob, off + 4)
                struct.pack_into("<f", blob, off + 4, y + move)
                moved = True
            if attr == "POSITION" and "min" in a:
                del a["min"], a["max"]  # recomputed by readers that need them
        a, off = view(prim["indices"])
        fmt = {5121: "B", 5123: "H", 5125: "I"}[a["componentType"]]
        size = struct.calcsize(fmt)
        idx = list(struct.unpack_from("<%d%s" % (a["count"], fmt), blob, off))
        tris = [idx[i:i + 3] for i in range(0, len(idx), 3)]
        rng.shuffle(tris)
        tris = [t[k:] + t[:k] for t, k in ((t, rng.randrange(3)) for t in tris)]
        struct.pack_into("<%d%s" % (a["count"], fmt), blob, off, *[i for t in tris for i in t])
bin_name = os.path.splitext(os.path.basename(out))[0] + ".bin"
g["buffers"][0]["uri"] = bin_name
open(os.path.join(os.path.dirname(out) or ".", bin_name), "wb").write(blob)
json.dump(g, open(out, "w"))
