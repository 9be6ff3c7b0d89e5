#!/usr/bin/env python3
"""Writes soupray's shipped animation, animations/walker/walker.glb.

It is a skinned, textured figure walking across a checkered ground between
three crates, lit by a sun and a sky, with a tracking camera: 2 seconds at
24 fps, frames 0 to 48. The project owns every byte of it (MIT OR
Apache-2.0, like the code).

It uses Python's standard library only. The output is deterministic: every
float is rounded to 6 decimals before it is packed, so libm's last-bit
differences between machines cannot change a byte.
tests/shipped_animation.rs regenerates the file and compares it.

Usage: scripts/make-walker.py [OUT.glb]
"""

import json
import math
import struct
import sys
import zlib
from pathlib import Path

FPS = 24
FRAMES = 49  # 0..48: two gait cycles of one second each
GAIT = 1.0  # seconds per cycle (two steps)
SPEED = 1.4  # metres per second along +Z
START_Z = -1.4


def r6(x):
    return round(float(x), 6) + 0.0  # + 0.0 turns -0.0 into 0.0


# --- quaternions and matrices ----------------------------------------------

def quat_axis(axis, angle):
    s = math.sin(angle / 2)
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]


def quat_from_to(a, b):
    """The rotation taking unit vector a to unit vector b."""
    d = sum(x * y for x, y in zip(a, b))
    c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    q = [c[0], c[1], c[2], 1.0 + d]
    n = math.sqrt(sum(x * x for x in q))
    return [x / n for x in q]


def normalize(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def look_rotation(eye, target):
    """The camera rotation looking from eye at target with +Y up (glTF
    cameras look along -Z)."""
    f = normalize([t - e for t, e in zip(target, eye)])
    # Yaw about Y, then pitch about the camera's X.
    yaw = math.atan2(-f[0], -f[2])
    pitch = math.asin(max(-1.0, min(1.0, f[1])))
    return quat_mul(quat_axis([0, 1, 0], yaw), quat_axis([1, 0, 0], pitch))


# --- the binary buffer -------------------------------------------------------

class Buffer:
    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def view(self, raw, target=None):
        while len(self.data) % 4:
            self.data.append(0)
        v = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        if target:
            v["target"] = target
        self.data += raw
        self.views.append(v)
        return len(self.views) - 1

    def floats(self, rows, kind, target=None, bounds=False):
        flat = [r6(x) for row in rows for x in (row if isinstance(row, (list, tuple)) else [row])]
        view = self.view(struct.pack("<%df" % len(flat), *flat), target)
        acc = {"bufferView": view, "componentType": 5126, "count": len(rows), "type": kind}
        if bounds:
            width = len(rows[0])
            acc["min"] = [min(r6(r[i]) for r in rows) for i in range(width)]
            acc["max"] = [max(r6(r[i]) for r in rows) for i in range(width)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def ubytes(self, rows, kind):
        flat = [x for row in rows for x in row]
        view = self.view(bytes(flat), 34962)
        self.accessors.append(
            {"bufferView": view, "componentType": 5121, "count": len(rows), "type": kind}
        )
        return len(self.accessors) - 1

    def indices(self, idx):
        view = self.view(struct.pack("<%dH" % len(idx), *idx), 34963)
        self.accessors.append(
            {"bufferView": view, "componentType": 5123, "count": len(idx), "type": "SCALAR"}
        )
        return len(self.accessors) - 1


# --- textures ----------------------------------------------------------------

def png(width, height, pixel):
    """An RGB PNG of pixel(x, y) -> (r, g, b), bytes 0..255."""
    rows = b"".join(
        b"\x00" + bytes(c for x in range(width) for c in pixel(x, y)) for y in range(height)
    )

    def chunk(tag, body):
        return (
            struct.pack(">I", len(body)) + tag + body
            + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF)
        )

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    )


# The figure's atlas: four 32x32 quadrants (shirt, trousers, skin, shoes).
def atlas_pixel(x, y):
    if y < 32 and x < 32:  # shirt: teal with cream stripes
        return (232, 220, 190) if y % 8 < 2 else (30, 128, 132)
    if y < 32:  # trousers: indigo with a twill line
        return (52, 60, 110) if (x + y) % 6 else (70, 80, 140)
    if x < 32:  # skin
        return (214, 160, 122)
    return (70, 46, 34)  # shoes


QUADRANT = {"shirt": (0, 0), "trousers": (0.5, 0), "skin": (0, 0.5), "shoes": (0.5, 0.5)}


def checker_pixel(x, y):
    light = ((x // 8) + (y // 8)) % 2 == 0
    return (196, 192, 182) if light else (150, 146, 138)


# --- the figure ----------------------------------------------------------------

# (name, parent, local translation in the bind pose)
JOINTS = [
    ("hips", None, (0.0, 0.95, 0.0)),
    ("spine", "hips", (0.0, 0.10, 0.0)),
    ("head", "spine", (0.0, 0.50, 0.0)),
    ("thigh_L", "hips", (0.10, -0.02, 0.0)),
    ("shin_L", "thigh_L", (0.0, -0.45, 0.0)),
    ("thigh_R", "hips", (-0.10, -0.02, 0.0)),
    ("shin_R", "thigh_R", (0.0, -0.45, 0.0)),
    ("upper_arm_L", "spine", (0.23, 0.38, 0.0)),
    ("forearm_L", "upper_arm_L", (0.0, -0.30, 0.0)),
    ("upper_arm_R", "spine", (-0.23, 0.38, 0.0)),
    ("forearm_R", "upper_arm_R", (0.0, -0.30, 0.0)),
]
JOINT_INDEX = {name: i for i, (name, _, _) in enumerate(JOINTS)}


def bind_world(name):
    x = y = z = 0.0
    while name is not None:
        _, parent, t = JOINTS[JOINT_INDEX[name]]
        x, y, z = x + t[0], y + t[1], z + t[2]
        name = parent
    return (x, y, z)


# (centre, half size, joint, atlas quadrant, blend the top face with the parent)
BOXES = [
    ((0.0, 0.98, 0.0), (0.15, 0.08, 0.09), "hips", "trousers", False),
    ((0.0, 1.27, 0.0), (0.17, 0.22, 0.10), "spine", "shirt", True),
    ((0.0, 1.62, 0.0), (0.10, 0.12, 0.11), "head", "skin", False),
]
for side, sx in (("L", 1.0), ("R", -1.0)):
    BOXES += [
        ((0.10 * sx, 0.70, 0.0), (0.065, 0.22, 0.07), "thigh_" + side, "trousers", True),
        ((0.10 * sx, 0.28, 0.0), (0.055, 0.20, 0.06), "shin_" + side, "trousers", True),
        ((0.10 * sx, 0.04, 0.05), (0.055, 0.04, 0.11), "shin_" + side, "shoes", False),
        ((0.23 * sx, 1.28, 0.0), (0.045, 0.15, 0.05), "upper_arm_" + side, "shirt", True),
        ((0.23 * sx, 0.99, 0.0), (0.04, 0.14, 0.045), "forearm_" + side, "skin", True),
    ]

# A box's faces: (normal axis, sign), corners counter-clockwise seen from outside.
FACES = [(0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)]


def box_faces(centre, half):
    """Yields (normal, four corners) per face, wound counter-clockwise."""
    for axis, sign in FACES:
        u = (axis + 1) % 3
        v = (axis + 2) % 3
        corners = []
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = [0.0, 0.0, 0.0]
            p[axis] = centre[axis] + sign * half[axis]
            p[u] = centre[u] + a * half[u]
            p[v] = centre[v] + b * half[v] * sign
            corners.append(p)
        n = [0.0, 0.0, 0.0]
        n[axis] = float(sign)
        yield n, corners


def figure_mesh():
    pos, nrm, uv, joints, weights, idx = [], [], [], [], [], []
    for centre, half, joint, quadrant, blend in BOXES:
        j = JOINT_INDEX[joint]
        parent = JOINTS[j][1]
        u0, v0 = QUADRANT[quadrant]
        for n, corners in box_faces(centre, half):
            base = len(pos)
            for k, p in enumerate(corners):
                pos.append(p)
                nrm.append(n)
                du, dv = ((0, 0), (1, 0), (1, 1), (0, 1))[k]
                uv.append([u0 + 0.03 + 0.44 * du, v0 + 0.03 + 0.44 * dv])
                top = p[1] > centre[1]
                if blend and top and parent is not None:
                    # The joint's top face bends with its parent: a smooth
                    # elbow, knee or waist instead of a gap.
                    joints.append([j, JOINT_INDEX[parent], 0, 0])
                    weights.append([0.5, 0.5, 0.0, 0.0])
                else:
                    joints.append([j, 0, 0, 0])
                    weights.append([1.0, 0.0, 0.0, 0.0])
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, uv, joints, weights, idx


def box_mesh(boxes, uv_scale):
    pos, nrm, uv, idx = [], [], [], []
    for centre, half in boxes:
        for n, corners in box_faces(centre, half):
            base = len(pos)
            for k, p in enumerate(corners):
                pos.append(p)
                nrm.append(n)
                du, dv = ((0, 0), (1, 0), (1, 1), (0, 1))[k]
                uv.append([du * uv_scale, dv * uv_scale])
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, uv, idx


# --- the animation ---------------------------------------------------------------

def pose(t):
    """Local rotations (and the hips' translation) of every joint at t."""
    phase = 2 * math.pi * t / GAIT
    s = math.sin(phase)
    x_axis, y_axis = [1, 0, 0], [0, 1, 0]
    rot = {name: [0.0, 0.0, 0.0, 1.0] for name, _, _ in JOINTS}
    rot["hips"] = quat_axis(y_axis, 0.08 * s)
    rot["spine"] = quat_axis(y_axis, -0.12 * s)
    # A positive turn about X swings a hanging limb backwards (-Z).
    for side, sign in (("L", 1.0), ("R", -1.0)):
        swing = sign * s
        rot["thigh_" + side] = quat_axis(x_axis, 0.42 * swing)
        # The knee bends while the leg swings forward, and straightens to
        # take the weight.
        knee = 0.5 * max(0.0, math.sin(phase + (0.0 if sign > 0 else math.pi) + 2.2))
        rot["shin_" + side] = quat_axis(x_axis, 0.15 + knee)
        rot["upper_arm_" + side] = quat_axis(x_axis, -0.35 * swing)
        rot["forearm_" + side] = quat_axis(x_axis, -0.35 - 0.2 * max(0.0, -swing))
    hips = [0.0, 0.95 + 0.025 * math.cos(2 * phase), START_Z + SPEED * t]
    return rot, hips


def camera_at(t):
    walker = START_Z + SPEED * t
    eye = [4.4 - 0.4 * t, 1.55 + 0.1 * t, walker - 2.8 + 1.0 * t]
    target = [0.0, 0.85, walker + 0.3]
    return eye, look_rotation(eye, target)


# --- the file ----------------------------------------------------------------------

def build():
    buf = Buffer()
    accessor = {}

    pos, nrm, uv, joints, weights, idx = figure_mesh()
    figure = {
        "attributes": {
            "POSITION": buf.floats(pos, "VEC3", 34962, bounds=True),
            "NORMAL": buf.floats(nrm, "VEC3", 34962),
            "TEXCOORD_0": buf.floats(uv, "VEC2", 34962),
            "JOINTS_0": buf.ubytes(joints, "VEC4"),
            "WEIGHTS_0": buf.floats(weights, "VEC4", 34962),
        },
        "indices": buf.indices(idx),
        "material": 0,
    }
    accessor["ibm"] = buf.floats(
        [
            [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -w[0], -w[1], -w[2], 1]
            for w in (bind_world(name) for name, _, _ in JOINTS)
        ],
        "MAT4",
    )

    g_pos, g_nrm, g_uv, g_idx = box_mesh([((0.0, -0.05, 0.0), (8.0, 0.05, 8.0))], 8.0)
    ground = {
        "attributes": {
            "POSITION": buf.floats(g_pos, "VEC3", 34962, bounds=True),
            "NORMAL": buf.floats(g_nrm, "VEC3", 34962),
            "TEXCOORD_0": buf.floats(g_uv, "VEC2", 34962),
        },
        "indices": buf.indices(g_idx),
        "material": 1,
    }
    crates = [
        ((-0.9, 0.25, 0.6), (0.25, 0.25, 0.25)),
        ((-1.3, 0.2, -0.5), (0.2, 0.2, 0.2)),
        ((-1.0, 0.3, 1.9), (0.3, 0.3, 0.3)),
    ]
    c_pos, c_nrm, c_uv, c_idx = box_mesh(crates, 1.0)
    crate = {
        "attributes": {
            "POSITION": buf.floats(c_pos, "VEC3", 34962, bounds=True),
            "NORMAL": buf.floats(c_nrm, "VEC3", 34962),
        },
        "indices": buf.indices(c_idx),
        "material": 2,
    }

    # Animation: one key per frame, linear, for every joint's rotation and
    # the hips' translation; the camera's path as CUBICSPLINE keys every
    # quarter second (tangents from central differences), its aim linear.
    times = [i / FPS for i in range(FRAMES)]
    time_acc = buf.floats(times, "SCALAR")
    buf.accessors[time_acc]["min"] = [r6(times[0])]
    buf.accessors[time_acc]["max"] = [r6(times[-1])]
    poses = [pose(t) for t in times]
    samplers, channels = [], []
    joint_node = 3  # nodes: 0 scene root, 1 figure mesh, 2 camera, 3.. joints

    def channel(node, path, output, interpolation="LINEAR", input_acc=time_acc):
        samplers.append({"input": input_acc, "output": output, "interpolation": interpolation})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    for i, (name, _, _) in enumerate(JOINTS):
        channel(joint_node + i, "rotation", buf.floats([p[0][name] for p in poses], "VEC4"))
    channel(joint_node, "translation", buf.floats([p[1] for p in poses], "VEC3"))

    cam_times = [i * 0.25 for i in range(9)]
    cam_acc = buf.floats(cam_times, "SCALAR")
    buf.accessors[cam_acc]["min"] = [0.0]
    buf.accessors[cam_acc]["max"] = [2.0]
    spline = []
    for t in cam_times:
        eye = camera_at(t)[0]
        h = 1e-3
        before, after = camera_at(t - h)[0], camera_at(t + h)[0]
        # glTF's cubic-spline tangents are per second, scaled by the key
        # interval when evaluated.
        tangent = [(a - b) / (2 * h) for a, b in zip(after, before)]
        spline += [tangent, eye, tangent]
    channel(2, "translation", buf.floats(spline, "VEC3"), "CUBICSPLINE", cam_acc)
    channel(2, "rotation", buf.floats([camera_at(t)[1] for t in cam_times], "VEC4"), "LINEAR", cam_acc)

    sun_dir = normalize([0.45, -0.8, -0.4])
    sun_rotation = quat_from_to([0.0, 0.0, -1.0], sun_dir)

    nodes = [
        {"name": "walker_scene", "children": [1, 2, joint_node, 3 + len(JOINTS), 4 + len(JOINTS), 5 + len(JOINTS)]},
        {"name": "walker", "mesh": 0, "skin": 0},
        {"name": "camera", "camera": 0, "translation": [r6(x) for x in camera_at(0)[0]],
         "rotation": [r6(x) for x in camera_at(0)[1]]},
    ]
    for name, parent, t in JOINTS:
        node = {"name": name, "translation": [r6(x) for x in t]}
        children = [joint_node + k for k, (_, p, _) in enumerate(JOINTS) if p == name]
        if children:
            node["children"] = children
        nodes.append(node)
    nodes += [
        {"name": "ground", "mesh": 1},
        {"name": "crates", "mesh": 2},
        {"name": "sun", "rotation": [r6(x) for x in sun_rotation],
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]

    images = [png(64, 64, atlas_pixel), png(64, 64, checker_pixel)]
    image_views = [buf.view(data) for data in images]

    root = {
        "asset": {"version": "2.0", "generator": "soupray scripts/make-walker.py",
                  "copyright": "soupray authors, MIT OR Apache-2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{
            "name": "walk",
            "nodes": [0],
            # glTF has no sky: soupray reads its constant environment here.
            "extras": {"soupray": {"environment": [0.28, 0.36, 0.5]}},
        }],
        "nodes": nodes,
        "meshes": [
            {"name": "walker", "primitives": [figure]},
            {"name": "ground", "primitives": [ground]},
            {"name": "crates", "primitives": [crate]},
        ],
        "skins": [{
            "name": "walker_rig",
            "inverseBindMatrices": accessor["ibm"],
            "skeleton": joint_node,
            "joints": [joint_node + i for i in range(len(JOINTS))],
        }],
        "animations": [{"name": "walk", "samplers": samplers, "channels": channels}],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.62, "aspectRatio": r6(16 / 9), "znear": 0.05, "zfar": 100.0}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{
            "type": "directional", "name": "sun", "color": [1.0, 0.95, 0.86], "intensity": 3.2}]}},
        "materials": [
            {"name": "walker", "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.65}},
            {"name": "ground", "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 1}, "metallicFactor": 0.0, "roughnessFactor": 0.9}},
            {"name": "crates", "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.42, 0.16, 1.0], "metallicFactor": 0.0,
                "roughnessFactor": 0.5}},
        ],
        "samplers": [
            {"magFilter": 9728, "minFilter": 9728},  # the atlas: crisp stripes
            {"magFilter": 9729, "minFilter": 9729, "wrapS": 10497, "wrapT": 10497},
        ],
        "textures": [{"sampler": 0, "source": 0}, {"sampler": 1, "source": 1}],
        "images": [{"bufferView": v, "mimeType": "image/png"} for v in image_views],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }
    while len(buf.data) % 4:
        buf.data.append(0)
    root["buffers"] = [{"byteLength": len(buf.data)}]

    text = json.dumps(root, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = (
        struct.pack("<II", len(text), 0x4E4F534A) + text
        + struct.pack("<II", len(buf.data), 0x004E4942) + bytes(buf.data)
    )
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else (
        Path(__file__).resolve().parent.parent / "animations" / "walker" / "walker.glb")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(build())


if __name__ == "__main__":
    main()
