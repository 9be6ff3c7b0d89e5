#!/usr/bin/env python3
"""Writes soupray's feature scenes: small glTF files, one per feature the
tests exercise, that the project owns outright (MIT OR Apache-2.0).

    scripts/make-features.py OUT_DIR

writes into OUT_DIR:

- skin_chain.gltf: a three-joint chain under a transformed skeleton root,
  with inverse bind matrices, bending over 1 s (LINEAR rotations).
- morph_sparse.gltf: a quad with two morph targets, the first a sparse
  accessor moving two of the four vertices, weights animated (LINEAR).
- interpolation.gltf: three boxes animated on translation, rotation and
  scale, one per interpolation (STEP, LINEAR, CUBICSPLINE), and three morph
  quads whose weights use the same three.
- cameras_lights.gltf: a ground and a box under a directional, a point and
  a spot light (KHR_lights_punctual), seen by a perspective camera
  ("perspective") and an orthographic one ("orthographic").
- texture_transform.gltf: a quad with two uv sets and a checker texture
  whose KHR_texture_transform offsets, rotates and scales it and reads
  TEXCOORD_1 through its texCoord override.
- materials.gltf: a row of spheres, one per material extension soupray
  renders (clearcoat, sheen, transmission with volume and ior, specular,
  iridescence, anisotropy, dispersion, emissive_strength, unlit,
  diffuse_transmission), under a sun.

Python's standard library only; deterministic (floats rounded to 6
decimals). tests/generated_features.rs runs it and checks each file.
"""

import base64
import json
import math
import struct
import sys
import zlib
from pathlib import Path


def r6(x):
    return round(float(x), 6) + 0.0


def quat_axis(axis, angle):
    s = math.sin(angle / 2)
    return [r6(axis[0] * s), r6(axis[1] * s), r6(axis[2] * s), r6(math.cos(angle / 2))]


class Doc:
    """One glTF document with one embedded buffer."""

    def __init__(self):
        self.data = bytearray()
        self.root = {
            "asset": {"version": "2.0", "generator": "soupray scripts/make-features.py"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [],
            "meshes": [],
            "accessors": [],
            "bufferViews": [],
        }

    def view(self, raw):
        while len(self.data) % 4:
            self.data.append(0)
        self.root["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        )
        self.data += raw
        return len(self.root["bufferViews"]) - 1

    def floats(self, rows, kind, bounds=False):
        rows = [row if isinstance(row, (list, tuple)) else [row] for row in rows]
        flat = [r6(x) for row in rows for x in row]
        acc = {
            "bufferView": self.view(struct.pack("<%df" % len(flat), *flat)),
            "componentType": 5126,
            "count": len(rows),
            "type": kind,
        }
        if bounds:
            acc["min"] = [min(r6(r[i]) for r in rows) for i in range(len(rows[0]))]
            acc["max"] = [max(r6(r[i]) for r in rows) for i in range(len(rows[0]))]
        self.root["accessors"].append(acc)
        return len(self.root["accessors"]) - 1

    def sparse_vec3(self, count, changed):
        """A VEC3 accessor of `count` zeros with `changed` {index: xyz}."""
        idx = sorted(changed)
        values = [r6(c) for i in idx for c in changed[i]]
        acc = {
            "componentType": 5126,
            "count": count,
            "type": "VEC3",
            "sparse": {
                "count": len(idx),
                "indices": {"bufferView": self.view(struct.pack("<%dH" % len(idx), *idx)), "componentType": 5123},
                "values": {"bufferView": self.view(struct.pack("<%df" % len(values), *values))},
            },
        }
        self.root["accessors"].append(acc)
        return len(self.root["accessors"]) - 1

    def indices(self, idx):
        acc = {
            "bufferView": self.view(struct.pack("<%dH" % len(idx), *idx)),
            "componentType": 5123,
            "count": len(idx),
            "type": "SCALAR",
        }
        self.root["accessors"].append(acc)
        return len(self.root["accessors"]) - 1

    def ubytes(self, rows, kind):
        flat = [x for row in rows for x in row]
        self.root["accessors"].append(
            {"bufferView": self.view(bytes(flat)), "componentType": 5121, "count": len(rows), "type": kind}
        )
        return len(self.root["accessors"]) - 1

    def mesh(self, attributes, indices, material=None, targets=None, weights=None):
        prim = {"attributes": attributes, "indices": indices}
        if material is not None:
            prim["material"] = material
        if targets:
            prim["targets"] = targets
        mesh = {"primitives": [prim]}
        if weights is not None:
            mesh["weights"] = weights
        self.root["meshes"].append(mesh)
        return len(self.root["meshes"]) - 1

    def node(self, node, root=True):
        self.root["nodes"].append(node)
        n = len(self.root["nodes"]) - 1
        if root:
            self.root["scenes"][0]["nodes"].append(n)
        return n

    def add(self, key, value):
        self.root.setdefault(key, []).append(value)
        return len(self.root[key]) - 1

    def channel(self, anim, node, path, times, values, interpolation, kind):
        a = self.root.setdefault("animations", [{"channels": [], "samplers": []}])[anim]
        a["samplers"].append(
            {"input": self.floats(times, "SCALAR", bounds=True), "output": self.floats(values, kind),
             "interpolation": interpolation}
        )
        a["channels"].append({"sampler": len(a["samplers"]) - 1, "target": {"node": node, "path": path}})

    def write(self, path):
        while len(self.data) % 4:
            self.data.append(0)
        self.root["buffers"] = [
            {"byteLength": len(self.data),
             "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.data)).decode()}
        ]
        for key in ("meshes", "accessors", "bufferViews"):
            if not self.root[key]:
                del self.root[key]
        Path(path).write_text(json.dumps(self.root, indent=1, sort_keys=True) + "\n")


def box(doc, half, material=None):
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (1, -1):
            n = [0, 0, 0]
            n[axis] = sign
            u = [0, 0, 0]
            u[(axis + 1) % 3] = 1
            v = [0, 0, 0]
            v[(axis + 2) % 3] = 1
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append([half * (n[k] + a * u[k] + b * v[k]) for k in range(3)])
                nrm.append(n)
            quad = [base, base + 1, base + 2, base, base + 2, base + 3]
            if sign < 0:
                quad = [base, base + 2, base + 1, base, base + 3, base + 2]
            idx += quad
    return doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3")},
                    doc.indices(idx), material)


def quad_geometry(size=1.0):
    pos = [[-size, -size, 0], [size, -size, 0], [size, size, 0], [-size, size, 0]]
    return pos, [[0, 0, 1]] * 4, [0, 1, 2, 0, 2, 3]


def sphere(doc, radius, material, segments=24):
    pos, nrm, uvs, idx = [], [], [], []
    rings = segments // 2
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            n = [math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph)]
            pos.append([radius * c for c in n])
            nrm.append(n)
            uvs.append([s / segments, r / rings])
    row = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b = r * row + s, r * row + s + 1
            idx += [a, row + a, b, b, row + a, row + b]
    return doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3"),
                     "TEXCOORD_0": doc.floats(uvs, "VEC2")},
                    doc.indices(idx), material)


def matte(doc, rgb):
    return doc.add("materials", {"pbrMetallicRoughness": {
        "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}})


def sun(doc, intensity=3.0):
    doc.root.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
    light = {"type": "directional", "intensity": intensity}
    doc.root["extensions"] = {"KHR_lights_punctual": {"lights": [light]}}
    doc.node({"name": "sun", "rotation": quat_axis([1, 0, 0], -0.9),
              "extensions": {"KHR_lights_punctual": {"light": 0}}})


def skin_chain(path):
    doc = Doc()
    # A column of three segments along +Y, skinned rigidly to joints 0-2.
    pos, nrm, joints, weights, idx = [], [], [], [], []
    for seg in range(3):
        for k, (x, z) in enumerate(((-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1))):
            for y in (seg * 0.5, seg * 0.5 + 0.5):
                pos.append([x, y, z])
                nrm.append([x * 10, 0, z * 10])
                joints.append([seg, 0, 0, 0])
                weights.append([1.0, 0, 0, 0])
        b = seg * 8
        for k in range(4):
            a0, a1 = b + 2 * k, b + 2 * k + 1
            c0, c1 = b + 2 * ((k + 1) % 4), b + 2 * ((k + 1) % 4) + 1
            idx += [a0, c0, c1, a0, c1, a1]
    mesh = doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3"),
                     "JOINTS_0": doc.ubytes(joints, "VEC4"), "WEIGHTS_0": doc.floats(weights, "VEC4")},
                    doc.indices(idx), matte(doc, [0.8, 0.5, 0.3]))
    # Skeleton: root (translated and turned) -> j0 -> j1 -> j2.
    j2 = doc.node({"name": "j2", "translation": [0, 0.5, 0]}, root=False)
    j1 = doc.node({"name": "j1", "translation": [0, 0.5, 0], "children": [j2]}, root=False)
    j0 = doc.node({"name": "j0", "children": [j1]}, root=False)
    doc.node({"name": "skeleton", "translation": [0.5, 0, 0], "rotation": quat_axis([0, 1, 0], 0.4),
              "children": [j0]})
    # Inverse bind matrices: the joints' bind worlds are translations by
    # (0.5, 0.5 k, 0) turned by the root; their inverses in column order.
    c, s = math.cos(0.4), math.sin(0.4)
    ibms = []
    for k in range(3):
        # world = T(0.5,0,0) R_y(0.4) T(0, 0.5k, 0); inverse = T(0,-0.5k,0) R_y(-0.4) T(-0.5,0,0)
        m = [c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0, -0.5 * c, -0.5 * k, -0.5 * s, 1]
        ibms.append(m)
    skin = doc.add("skins", {"joints": [j0, j1, j2], "inverseBindMatrices": doc.floats(ibms, "MAT4"), "skeleton": 3})
    doc.node({"name": "column", "mesh": mesh, "skin": skin})
    times = [0.0, 0.5, 1.0]
    for j in (j1, j2):
        doc.channel(0, j, "rotation", times,
                    [quat_axis([0, 0, 1], a) for a in (0.0, 0.5, 1.0)], "LINEAR", "VEC4")
    sun(doc)
    doc.write(path)


def morph_sparse(path):
    doc = Doc()
    pos, nrm, idx = quad_geometry()
    t0 = doc.sparse_vec3(4, {1: [0.0, 0.0, 0.5], 2: [0.25, 0.0, 0.5]})
    t1 = doc.floats([[0.0, 0.0, -0.2]] * 4, "VEC3", True)
    mesh = doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3")},
                    doc.indices(idx), matte(doc, [0.3, 0.6, 0.8]),
                    targets=[{"POSITION": t0}, {"POSITION": t1}], weights=[0.0, 0.0])
    n = doc.node({"name": "quad", "mesh": mesh})
    doc.channel(0, n, "weights", [0.0, 1.0], [0.0, 0.0, 1.0, 0.5], "LINEAR", "SCALAR")
    sun(doc)
    doc.write(path)


INTERPOLATIONS = ("STEP", "LINEAR", "CUBICSPLINE")


def interpolation(path):
    doc = Doc()
    cube = box(doc, 0.2, matte(doc, [0.7, 0.7, 0.7]))
    pos, nrm, idx = quad_geometry(0.2)
    morph = doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3")},
                     doc.indices(idx), matte(doc, [0.7, 0.3, 0.3]),
                     targets=[{"POSITION": doc.floats([[0.0, 0.5, 0.0]] * 4, "VEC3", True)}], weights=[0.0])
    times = [0.0, 1.0]
    for i, interp in enumerate(INTERPOLATIONS):
        n = doc.node({"name": "box " + interp, "mesh": cube, "translation": [i - 1.0, 0, 0]})
        m = doc.node({"name": "morph " + interp, "mesh": morph, "translation": [i - 1.0, -1.0, 0]})
        t = [[i - 1.0, 0, 0], [i - 1.0, 1.0, 0]]
        r = [quat_axis([0, 1, 0], 0.0), quat_axis([0, 1, 0], 1.0)]
        s = [[1, 1, 1], [2, 1, 0.5]]
        w = [0.0, 1.0]
        if interp == "CUBICSPLINE":
            # (in-tangent, value, out-tangent) per key; tangents per second.
            def spline(values, out_tangent):
                zero = [0.0] * len(values[0]) if isinstance(values[0], list) else 0.0
                return [zero, values[0], out_tangent, zero, values[1], zero]
            t = spline(t, [0.0, 3.0, 0.0])
            r = spline(r, [0.0, 0.0, 0.0, 0.0])
            s = spline(s, [0.0, 0.0, 0.0])
            w = spline(w, 2.0)
        doc.channel(0, n, "translation", times, t, interp, "VEC3")
        doc.channel(0, n, "rotation", times, r, interp, "VEC4")
        doc.channel(0, n, "scale", times, s, interp, "VEC3")
        doc.channel(0, m, "weights", times, w, interp, "SCALAR")
    sun(doc)
    doc.write(path)


def cameras_lights(path):
    doc = Doc()
    ground = box(doc, 1.0, matte(doc, [0.8, 0.8, 0.8]))
    doc.node({"name": "ground", "mesh": ground, "translation": [0, -1.0, 0], "scale": [3, 1, 3]})
    doc.node({"name": "box", "mesh": box(doc, 0.3, matte(doc, [0.2, 0.5, 0.9])), "translation": [0, 0.3, 0]})
    doc.root["extensionsUsed"] = ["KHR_lights_punctual"]
    doc.root["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "sun", "type": "directional", "intensity": 2.0, "color": [1.0, 0.95, 0.9]},
        {"name": "bulb", "type": "point", "intensity": 20.0, "range": 10.0},
        {"name": "spot", "type": "spot", "intensity": 40.0, "color": [0.6, 0.8, 1.0],
         "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
    ]}}
    doc.node({"name": "sun", "rotation": quat_axis([1, 0, 0], -0.8), "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc.node({"name": "bulb", "translation": [1.0, 1.5, 1.0], "extensions": {"KHR_lights_punctual": {"light": 1}}})
    doc.node({"name": "spot", "translation": [-1.0, 2.0, 0.0], "rotation": quat_axis([1, 0, 0], -math.pi / 2),
              "extensions": {"KHR_lights_punctual": {"light": 2}}})
    doc.add("cameras", {"name": "perspective", "type": "perspective",
                        "perspective": {"yfov": 0.7, "znear": 0.05, "zfar": 100.0, "aspectRatio": 1.5}})
    doc.add("cameras", {"name": "orthographic", "type": "orthographic",
                        "orthographic": {"xmag": 1.5, "ymag": 1.0, "znear": 0.05, "zfar": 100.0}})
    look = quat_axis([1, 0, 0], -0.35)
    doc.node({"name": "perspective camera", "camera": 0, "translation": [0, 1.3, 3.5], "rotation": look})
    doc.node({"name": "orthographic camera", "camera": 1, "translation": [0, 1.3, 3.5], "rotation": look})
    doc.write(path)


def checker_png(size=8):
    rows = b"".join(
        b"\x00" + bytes(c for x in range(size) for c in ((230, 60, 40) if (x + y) % 2 else (30, 30, 160)))
        for y in range(size)
    )

    def chunk(tag, body):
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def texture_transform(path):
    doc = Doc()
    pos, nrm, idx = quad_geometry()
    uv0 = [[0, 1], [1, 1], [1, 0], [0, 0]]
    uv1 = [[0, 0], [2, 0], [2, 2], [0, 2]]
    image = doc.add("images", {"bufferView": doc.view(checker_png()), "mimeType": "image/png"})
    doc.add("samplers", {"magFilter": 9728, "minFilter": 9728})
    doc.add("textures", {"source": image, "sampler": 0})
    mat = doc.add("materials", {"pbrMetallicRoughness": {
        "baseColorTexture": {"index": 0, "texCoord": 0, "extensions": {"KHR_texture_transform": {
            "offset": [0.25, 0.5], "rotation": 0.3, "scale": [2.0, 3.0], "texCoord": 1}}},
        "metallicFactor": 0.0, "roughnessFactor": 0.9}})
    doc.root["extensionsUsed"] = ["KHR_texture_transform"]
    mesh = doc.mesh({"POSITION": doc.floats(pos, "VEC3", True), "NORMAL": doc.floats(nrm, "VEC3"),
                     "TEXCOORD_0": doc.floats(uv0, "VEC2"), "TEXCOORD_1": doc.floats(uv1, "VEC2")},
                    doc.indices(idx), mat)
    doc.node({"name": "quad", "mesh": mesh})
    doc.write(path)


# Each sphere's material: the extension it shows, on a mid-grey base.
MATERIAL_EXTENSIONS = [
    ("KHR_materials_clearcoat", {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.1}),
    ("KHR_materials_sheen", {"sheenColorFactor": [0.9, 0.3, 0.6], "sheenRoughnessFactor": 0.4}),
    ("KHR_materials_transmission", {"transmissionFactor": 1.0}),
    ("KHR_materials_specular", {"specularFactor": 0.5, "specularColorFactor": [1.0, 0.6, 0.3]}),
    ("KHR_materials_iridescence", {"iridescenceFactor": 1.0, "iridescenceIor": 1.3,
                                   "iridescenceThicknessMinimum": 300, "iridescenceThicknessMaximum": 300}),
    ("KHR_materials_anisotropy", {"anisotropyStrength": 0.8, "anisotropyRotation": 0.5}),
    ("KHR_materials_dispersion", {"dispersion": 2.0}),
    ("KHR_materials_emissive_strength", {"emissiveStrength": 4.0}),
    ("KHR_materials_unlit", {}),
    ("KHR_materials_diffuse_transmission", {"diffuseTransmissionFactor": 0.7,
                                            "diffuseTransmissionColorFactor": [0.9, 0.5, 0.2]}),
    ("KHR_materials_diffuse_roughness", {"diffuseRoughnessFactor": 0.9}),
]


def materials(path):
    doc = Doc()
    used = ["KHR_lights_punctual"]
    for i, (ext, params) in enumerate(MATERIAL_EXTENSIONS):
        exts = {ext: params}
        mat = {"name": ext, "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
                                                     "metallicFactor": 0.0, "roughnessFactor": 0.5}}
        if ext in ("KHR_materials_transmission", "KHR_materials_dispersion"):
            exts.setdefault("KHR_materials_transmission", {"transmissionFactor": 1.0})
            exts["KHR_materials_volume"] = {"thicknessFactor": 0.5, "attenuationColor": [0.9, 0.8, 0.6],
                                            "attenuationDistance": 1.0}
            exts["KHR_materials_ior"] = {"ior": 1.6}
        if ext == "KHR_materials_anisotropy":
            mat["pbrMetallicRoughness"]["metallicFactor"] = 1.0
        if ext == "KHR_materials_emissive_strength":
            mat["emissiveFactor"] = [1.0, 0.6, 0.2]
        mat["extensions"] = exts
        used += [e for e in exts if e not in used]
        m = doc.add("materials", mat)
        doc.node({"name": ext, "mesh": sphere(doc, 0.4, m), "translation": [(i % 5) * 1.0 - 2.0, 0.0, (i // 5) * -1.0]})
    sun(doc)
    doc.root["scenes"][0]["extras"] = {"soupray": {"environment": [0.4, 0.45, 0.5]}}
    doc.root["extensionsUsed"] = sorted(set(used))
    doc.write(path)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for name, make in (("skin_chain", skin_chain), ("morph_sparse", morph_sparse),
                       ("interpolation", interpolation), ("cameras_lights", cameras_lights),
                       ("texture_transform", texture_transform), ("materials", materials)):
        make(out / (name + ".gltf"))
        print(out / (name + ".gltf"))


if __name__ == "__main__":
    main()
