"""Diffuse roughness against Cycles: how much a rough diffuse surface darkens
relative to Lambert's, in Blender's Cycles (Principled BSDF "Diffuse
Roughness") and in soupray's lobe (KHR_materials_diffuse_roughness: EON).

A square of base colour (0.9, 0.6, 0.3), no specular layer, seen along its
normal by an orthographic camera under a sun from (0.7, 0.2, 0.35) and a
black sky: the geometry of tests/render_materials/diffuse_roughness.rs,
whose pixels match the EON formula below to 3e-7. Prints, per roughness,
each renderer's brightness over its own Lambertian render, R G B.

    PYTHONPATH=<bpy folder> python3 scripts/cycles-diffuse-roughness.py

Needs Blender 5 as a Python module (pip install bpy==5.0.1).
"""
import math
import tempfile

import bpy
import numpy as np
from mathutils import Vector

BASE = (0.9, 0.6, 0.3)
SUN = Vector((0.7, 0.2, 0.35)).normalized()
ROUGHNESS = (0.0, 0.2, 0.5, 0.8, 1.0)


def eon_over_lambert(rho, r, wi):
    """The EON BRDF (Portsmouth, Kutz and Hill 2024, Listing 1) for wo along
    the normal, over Lambert's rho / pi."""
    c1 = 0.5 - 2.0 / (3.0 * math.pi)
    c2 = 2.0 / 3.0 - 28.0 / (15.0 * math.pi)

    def fon_albedo(mu):
        m = 1.0 - mu
        g = m * (0.0571085289 + m * (0.491881867 + m * (-0.332181442 + m * 0.0714429953)))
        return (1.0 + r * g) / (1.0 + c1 * r)

    af = 1.0 / (1.0 + c1 * r)
    single = af  # s = 0 for wo along the normal
    e_avg = af * (1.0 + c2 * r)
    rho_ms = rho * rho * e_avg / (1.0 - rho * (1.0 - e_avg))
    k = max(1e-7, 1.0 - fon_albedo(1.0)) * max(1e-7, 1.0 - fon_albedo(wi.z)) / max(1e-7, 1.0 - e_avg)
    return single + rho_ms / rho * k


def cycles_means():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'
    sc.cycles.device = 'CPU'
    sc.cycles.samples = 256
    sc.cycles.use_denoising = False
    sc.render.resolution_x, sc.render.resolution_y = 32, 16
    sc.view_settings.view_transform = 'Standard'
    world = bpy.data.worlds.new('black')
    world.use_nodes = True
    world.node_tree.nodes['Background'].inputs['Strength'].default_value = 0.0
    sc.world = world
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.object
    mat = bpy.data.materials.new('rough')
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes['Principled BSDF']
    bsdf.inputs['Base Color'].default_value = (*BASE, 1.0)
    bsdf.inputs['Roughness'].default_value = 0.7
    bsdf.inputs['Specular IOR Level'].default_value = 0.0
    plane.data.materials.append(mat)
    cam_data = bpy.data.cameras.new('camera')
    cam_data.type = 'ORTHO'
    cam_data.ortho_scale = 1.0
    cam = bpy.data.objects.new('camera', cam_data)
    cam.location = (0.0, 0.0, 3.0)
    sc.collection.objects.link(cam)
    sc.camera = cam
    sun_data = bpy.data.lights.new('sun', 'SUN')
    sun_data.energy = 3.0
    sun_data.angle = 0.0
    sun = bpy.data.objects.new('sun', sun_data)
    sun.rotation_mode = 'QUATERNION'
    sun.rotation_quaternion = Vector((0.0, 0.0, 1.0)).rotation_difference(SUN)
    sc.collection.objects.link(sun)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    means = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in ROUGHNESS:
            bsdf.inputs['Diffuse Roughness'].default_value = r
            sc.render.filepath = f'{tmp}/r{r}.exr'
            bpy.ops.render.render(write_still=True)
            img = bpy.data.images.load(sc.render.filepath)
            means[r] = np.array(img.pixels[:]).reshape(-1, 4)[:, :3].mean(axis=0)
    return means


def main():
    means = cycles_means()
    print('roughness | Cycles 5 R G B over Lambert | soupray (EON) R G B over Lambert')
    for r in ROUGHNESS:
        cycles = ' '.join('%.3f' % (means[r][c] / means[0.0][c]) for c in range(3))
        eon = ' '.join('%.3f' % eon_over_lambert(rho, r, SUN) for rho in BASE)
        print(f'{r} | {cycles} | {eon}')


if __name__ == '__main__':
    main()
