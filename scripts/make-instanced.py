#!/usr/bin/env python3
"""Writes a field of instanced spheres as a .glb, for soupray's instancing
benchmark: one UV sphere mesh drawn N times, either by one node with
EXT_mesh_gpu_instancing (the default) or, with --flat, by N nodes of its
own (the same scene written out flat). Python's standard library only; the
output is deterministic.

    python3 scripts/make-instanced.py --instances 125 out/bench/field.glb
    python3 scripts/make-instanced.py --instances 125 --flat out/bench/flat.glb
"""
import argparse
import json
import math
import struct


def sphere(segments, rings):
    pos, nrm, idx = [], [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            pos += [0.5 * c for c in n]
            nrm += list(n)
    row = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b = r * row + s, r * row + s + 1
            c, d = a + row, b + row
            if r > 0:
                idx += [a, b, c]
            if r < rings - 1:
                idx += [b, d, c]
    return pos, nrm, idx


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--instances", type=int, default=125)
    ap.add_argument("--segments", type=int, default=32, help="sphere segments (triangles: about 2 x segments^2 / 2)")
    ap.add_argument("--flat", action="store_true", help="one node per instance instead of EXT_mesh_gpu_instancing")
    a = ap.parse_args()

    pos, nrm, idx = sphere(a.segments, a.segments // 2)
    side = math.ceil(math.sqrt(a.instances))
    seed = 12345
    def rand():
        nonlocal seed
        seed = (seed * 6364136223846793005 + 1442695040888963407) % (1 << 64)
        return (seed >> 11) / float(1 << 53)
    trs = []
    for i in range(a.instances):
        x, z = i % side, i // side
        s = 0.6 + 0.5 * rand()
        ang = 2 * math.pi * rand()
        trs.append(((x - side / 2) * 1.2, 0.5 * s, (z - side / 2) * 1.2, (0.0, math.sin(ang / 2), 0.0, math.cos(ang / 2)), s))

    bin_ = bytearray()
    views, accessors = [], []
    def add(data, fmt, count, type_, comp, extra=None):
        while len(bin_) % 4:
            bin_.append(0)
        off = len(bin_)
        bin_.extend(struct.pack("<%d%s" % (len(data), fmt), *data))
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(bin_) - off})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": type_}
        acc.update(extra or {})
        accessors.append(acc)
        return len(accessors) - 1
    n = len(pos) // 3
    p = add(pos, "f", n, "VEC3", 5126, {"min": [-0.5] * 3, "max": [0.5] * 3})
    q = add(nrm, "f", n, "VEC3", 5126)
    ix = add(idx, "I", len(idx), "SCALAR", 5125)
    nodes = []
    scene_nodes = []
    ext_used = ["KHR_lights_punctual"]
    if a.flat:
        for (x, y, z, r, s) in trs:
            nodes.append({"mesh": 0, "translation": [x, y, z], "rotation": list(r), "scale": [s, s, s]})
        scene_nodes = list(range(len(nodes)))
    else:
        t = add([c for (x, y, z, r, s) in trs for c in (x, y, z)], "f", len(trs), "VEC3", 5126)
        rr = add([c for tr in trs for c in tr[3]], "f", len(trs), "VEC4", 5126)
        ss = add([c for tr in trs for c in (tr[4],) * 3], "f", len(trs), "VEC3", 5126)
        nodes.append({"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t, "ROTATION": rr, "SCALE": ss}}}})
        scene_nodes = [0]
        ext_used.append("EXT_mesh_gpu_instancing")
    extent = side * 1.2
    nodes.append({"name": "sun", "rotation": [-0.4, 0.3, 0.0, 0.866], "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "camera", "camera": 0, "translation": [0.0, extent * 0.6, extent * 0.9],
                  "rotation": [-0.3, 0.0, 0.0, 0.954]})
    scene_nodes += [len(nodes) - 2, len(nodes) - 1]
    doc = {
        "asset": {"version": "2.0", "generator": "soupray scripts/make-instanced.py"},
        "extensionsUsed": ext_used,
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": scene_nodes, "extras": {"soupray": {"environment": [0.3, 0.35, 0.45]}}}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 1.5}}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "NORMAL": q}, "indices": ix, "material": 0}]}],
        "buffers": [{"byteLength": len(bin_)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    while len(bin_) % 4:
        bin_.append(0)
    with open(a.out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(bin_)))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bytes(bin_))
    tris = len(idx) // 3
    print(f"{a.out}: {a.instances} instances x {tris} triangles = {a.instances * tris} triangles"
          f" ({'flat nodes' if a.flat else 'EXT_mesh_gpu_instancing'})")


if __name__ == "__main__":
    main()
