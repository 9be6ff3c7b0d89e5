#!/usr/bin/env python3
"""Blender 5's glTF exporter against soupray: builds scenes in Blender (as a
Python module: `pip install bpy==5.0.1`), exports each with the options
artists use (Draco, GPU instancing, vertex colours, two UV sets, WebP
textures), renders nothing, and compares soupray's
soup of every exported file (`soupray soup`) with Blender's own evaluation
of the scene at several frames: every triangle soupray makes must match one
of Blender's within 1e-4 of the scene's diagonal (Draco within its
quantization), and the counts must agree.

(KHR_animation_pointer is not here: Blender 5.0.1's exporter, asked with
export_pointer_animation, wrote no pointer channel for an animated camera
lens, light power or material roughness in our attempts.)

    python3 scripts/blender-roundtrip.py --soupray target/release/soupray OUT_DIR

Exits 0 when every scene matches, 1 otherwise, 2 without bpy.
tests/blender_roundtrip.rs runs it where bpy is installed.
"""

import argparse
import math
import struct
import subprocess
import sys
from pathlib import Path

try:
    import bpy
    import bmesh  # noqa: F401  (part of bpy)
except ImportError:
    print("skipped: the bpy module (Blender 5 as a Python module) is not installed: pip install bpy==5.0.1")
    sys.exit(2)

FRAMES = [0, 7, 15, 24]


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene
    s.render.fps = 24
    s.frame_start = 0
    s.frame_end = 24
    return s


def key(obj, frame, **values):
    for k, v in values.items():
        setattr(obj, k, v)
        obj.keyframe_insert(data_path=k, frame=frame)


def morph_sphere_with_colours_and_uvs():
    """A sphere with an animated shape key, moved and turned, with a vertex
    colour attribute and two UV maps."""
    s = reset()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=1.0)
    obj = bpy.context.active_object
    obj.name = "ball"
    mesh = obj.data
    mesh.uv_layers.new(name="second")
    for i, d in enumerate(mesh.uv_layers["second"].data):
        d.uv = (0.5 * d.uv[0] + 0.25, 0.5 * d.uv[1])
    col = mesh.color_attributes.new(name="Col", type="BYTE_COLOR", domain="CORNER")
    for i, d in enumerate(col.data):
        d.color = ((i % 7) / 6.0, (i % 5) / 4.0, (i % 3) / 2.0, 1.0)
    obj.shape_key_add(name="Basis")
    sk = obj.shape_key_add(name="squash")
    for v in sk.data:
        v.co = (v.co[0] * 1.3, v.co[1] * 1.3, v.co[2] * 0.6)
    sk.value = 0.0
    sk.keyframe_insert("value", frame=0)
    sk.value = 1.0
    sk.keyframe_insert("value", frame=24)
    key(obj, 0, location=(0.0, 0.0, 0.0), rotation_euler=(0.0, 0.0, 0.0))
    key(obj, 24, location=(2.0, 1.0, 0.5), rotation_euler=(0.3, 0.0, 1.2))
    mat = bpy.data.materials.new("painted")
    obj.data.materials.append(mat)
    return s


def instanced_cubes():
    """Twenty cubes sharing one mesh under an empty: the exporter
    writes them as one node with EXT_mesh_gpu_instancing (its rule: children
    of an empty that share a mesh)."""
    s = reset()
    bpy.ops.mesh.primitive_cube_add(size=0.3)
    first = bpy.context.active_object
    mesh = first.data
    bpy.data.objects.remove(first)
    field = bpy.data.objects.new("field", None)
    s.collection.objects.link(field)
    for i in range(20):
        obj = bpy.data.objects.new(f"cube{i}", mesh)
        s.collection.objects.link(obj)
        obj.parent = field
        obj.location = ((i % 5) * 0.6 - 1.2, (i // 5) * 0.6 - 0.9, 0.1 * (i % 3))
        obj.rotation_euler = (0.0, 0.0, 0.3 * i)
        obj.scale = (1.0 + 0.05 * i, 1.0, 1.0 + 0.02 * i)
    # The empty is placed but not animated: Blender 5.0.1's exporter then
    # writes the empty's channels for a node index that the instancing
    # removed (node 20 in a file of 1 node), a file soupray refuses as
    # invalid, naming the channel.
    field.location = (0.0, 1.0, 1.0)
    field.rotation_euler = (0.0, 0.0, 0.8)
    return s


def webp_textured_plane():
    """A textured, turning plane whose image the exporter writes as WebP."""
    s = reset()
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    obj = bpy.context.active_object
    img = bpy.data.images.new("checker", 16, 16)
    img.pixels = [c for y in range(16) for x in range(16)
                  for c in ((0.9, 0.2, 0.1, 1.0) if (x // 4 + y // 4) % 2 else (0.1, 0.2, 0.9, 1.0))]
    mat = bpy.data.materials.new("checker")
    mat.use_nodes = True
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    mat.node_tree.links.new(tex.outputs["Color"], mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    obj.data.materials.append(mat)
    key(obj, 0, rotation_euler=(0.0, 0.0, 0.0))
    key(obj, 24, rotation_euler=(0.0, 0.0, 1.5))
    return s


SCENES = [
    ("morph_colours_uvs_draco", morph_sphere_with_colours_and_uvs,
     dict(export_draco_mesh_compression_enable=True, export_attributes=True), 2e-3),
    ("morph_colours_uvs", morph_sphere_with_colours_and_uvs, dict(export_attributes=True), 1e-4),
    ("instanced", instanced_cubes, dict(export_gpu_instances=True), 1e-4),
    ("webp", webp_textured_plane, dict(export_image_format="WEBP"), 1e-4),
]


def blender_triangles(scene, frame):
    """World-space triangles of every rendered object at `frame`, in glTF's
    axes (Y up: Blender's (x, y, z) is glTF's (x, z, -y))."""
    scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    tris = []
    for inst in dg.object_instances:
        obj = inst.object
        if obj.type != "MESH" or (not inst.is_instance and obj.original.hide_render):
            continue
        mesh = obj.to_mesh()
        mesh.calc_loop_triangles()
        m = inst.matrix_world
        for t in mesh.loop_triangles:
            corners = []
            for v in t.vertices:
                p = m @ mesh.vertices[v].co
                corners.append((p.x, p.z, -p.y))
            tris.append(corners)
        obj.to_mesh_clear()
    return tris


def soupray_triangles(soupray, path, frame, out):
    ply = out / f"{path.stem}.{frame}.ply"
    r = subprocess.run([soupray, "soup", str(path), "--frame", str(frame), "--output", str(ply)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"soupray soup {path} --frame {frame}: exit {r.returncode}: {r.stderr}")
    data = ply.read_bytes()
    head_end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:head_end].decode()
    verts = next(int(l.split()[2]) for l in header.splitlines() if l.startswith("element vertex"))
    xyz = struct.unpack_from("<%df" % (3 * verts), data, head_end)
    return [[tuple(xyz[9 * t + 3 * k: 9 * t + 3 * k + 3]) for k in range(3)] for t in range(verts // 3)]


def match(ours, theirs, tol):
    """The worst distance from each of our triangles to its best match in
    theirs (corners compared as sets), or None when the counts differ."""
    if len(ours) != len(theirs):
        return None
    cell = max(tol * 4, 1e-6)
    grid = {}
    def centre(t):
        return tuple(sum(c[i] for c in t) / 3 for i in range(3))
    for j, t in enumerate(theirs):
        k = tuple(int(math.floor(x / cell)) for x in centre(t))
        grid.setdefault(k, []).append(j)
    worst = 0.0
    for t in ours:
        c = centre(t)
        k0 = tuple(int(math.floor(x / cell)) for x in c)
        best = math.inf
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in grid.get((k0[0] + dx, k0[1] + dy, k0[2] + dz), []):
                        u = theirs[j]
                        d = max(min(math.dist(a, b) for b in u) for a in t)
                        best = min(best, d)
        worst = max(worst, best)
    return worst


def diagonal(tris):
    lo = [min(c[i] for t in tris for c in t) for i in range(3)]
    hi = [max(c[i] for t in tris for c in t) for i in range(3)]
    return math.dist(lo, hi)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--soupray", required=True)
    ap.add_argument("out")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    failed = False
    print(f"Blender {bpy.app.version_string} against soupray; worst corner distance / scene diagonal")
    for name, build, options, rel_tol in SCENES:
        scene = build()
        path = out / f"{name}.glb"
        bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", export_animations=True,
                                  export_yup=True, **options)
        row = []
        for f in FRAMES:
            theirs = blender_triangles(scene, f)
            ours = soupray_triangles(a.soupray, path, f, out)
            tol = rel_tol * diagonal(theirs)
            worst = match(ours, theirs, tol * 10)
            if worst is None:
                row.append(f"frame {f}: {len(ours)} triangles, Blender {len(theirs)}")
                failed = True
            else:
                row.append(f"frame {f}: {worst / diagonal(theirs):.1e}")
                failed |= worst > tol
        print(f"{name:26s} " + "; ".join(row))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
