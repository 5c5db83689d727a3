#!/usr/bin/env python3
"""Writes the small meshes the example scenes use: a unit icosphere (2 subdivisions, 320 triangles)
as OBJ (with vertex normals) and as glTF 2.0 (one embedded base64 buffer, under a node transform).
Run from this folder: python3 generate.py"""
import base64, json, math, struct

def icosphere(n):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(n):
        cache, nf = {}, []
        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                l = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / l for x in p))
                cache[k] = len(v) - 1
            return cache[k]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return v, f

v, f = icosphere(2)
with open("icosphere.obj", "w") as o:
    o.write("# unit icosphere, 2 subdivisions, %d triangles (written by generate.py)\n" % len(f))
    for p in v:
        o.write("v %.7f %.7f %.7f\n" % p)
    for p in v:
        o.write("vn %.7f %.7f %.7f\n" % p)
    for a, b, c in f:
        o.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))

pos = b"".join(struct.pack("<3f", *p) for p in v)
nrm = pos
idx = b"".join(struct.pack("<3I", *t) for t in f)
buf = pos + nrm + idx
lo = [min(p[i] for p in v) for i in range(3)]
hi = [max(p[i] for p in v) for i in range(3)]
gltf = {
    "asset": {"version": "2.0", "generator": "reflect scenes/meshes/generate.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    # A parent node that scales by 2 and a child that scales by 0.5: the net transform is the identity,
    # which exercises the loader's transform chain.
    "nodes": [{"children": [1], "scale": [2, 2, 2]}, {"mesh": 0, "scale": [0.5, 0.5, 0.5]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "mode": 4}]}],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(nrm), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos) + len(nrm), "byteLength": len(idx), "target": 34963},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": len(v), "type": "VEC3"},
        {"bufferView": 2, "componentType": 5125, "count": 3 * len(f), "type": "SCALAR"},
    ],
}
with open("icosphere.gltf", "w") as o:
    json.dump(gltf, o)
