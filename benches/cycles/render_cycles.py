"""Renders a glTF scene with Blender Cycles the way soupray renders it.

Run by `cargo bench --bench cycles` (benches/cycles/), one Blender process
per scene and seed, either in a Blender binary:

    blender -b -noaudio --factory-startup -P benches/cycles/render_cycles.py -- \
        --scene S.gltf --width 384 --height 256 --spp 16,64,256 --seed 1 \
        --max-bounces 7 --threads 2 --env 1,1,1 --out-dir DIR [--warmup]

or in Python with Blender as a module (`pip install bpy==5.0.1`):

    python3 benches/cycles/render_cycles.py -- --scene S.gltf ...

The translation, so that both renderers solve the same light transport:

* the scene comes from Blender's own glTF importer, camera included;
* every material becomes a pure Diffuse BSDF (Lambertian, roughness 0) of
  colour 0.8, like soupray's `--clay` (a Principled BSDF at roughness 1 is
  not Lambertian);
* the world is a constant background of radiance `--env`, like soupray's
  `--env-color`;
* KHR_lights_punctual directional lights become suns whose strength (W/m^2,
  i.e. irradiance) is the file's intensity in lux, the way soupray reads it
  (Blender's importer divides lux by 683 by default; the strength is set
  from the file here, whatever the importer did) and whose angle is 0: a
  delta light, like soupray's; point lights become point lights of radius
  0 whose power (W) is 4 pi times the file's intensity in candela (the
  importer's 683 lm/W undone the same way);
* no clamping, no adaptive sampling, no denoising, no light threshold;
  `--max-bounces` is soupray's `--max-depth` minus one (Cycles counts
  bounces after the first hit: 0 bounces is direct light only, which is
  soupray's depth 1);
* Blackman-Harris pixel filter of width 1.5 px (both renderers' default);
* otherwise Cycles' defaults: its sampling pattern (3.4: progressive
  multi-jitter; 5.0: tabulated Sobol) and, from 3.5, its light tree;
  `--guiding` turns on path guiding on surfaces and in volumes (Cycles'
  CPU path guiding, deterministic, its default training samples);
* output: linear OpenEXR, float, RGBA, film not transparent.

For the feature comparisons (`cargo bench --bench cycles_features`):

* `--frame N` renders frame N of the imported animation (glTF time N/24 s:
  the importer keys at 24 fps; checked by that bench's unblurred row);
* `--motion-blur SHUTTER` turns Cycles' motion blur on with that shutter in
  frames, centred on the frame (`--shutter-position` start|center|end),
  with `--motion-steps N` for objects and deformation (Cycles' per-object
  `motion_steps`, which Blender's manual gives as 2^(N-1) steps), the
  shutter curve left at Blender's default (flat: open the whole time);
* `--keep-materials` keeps the importer's Principled BSDFs (glass,
  clearcoat, sheen...) instead of the clay diffuse, with every 8-bit sRGB
  texture replaced by a float copy of its linear values, so that Cycles
  filters light, not sRGB codes, as glTF and soupray do.

For each sample count it prints one line

    CYCLES_RENDER spp=16 seconds=1.234 sampling=1.200 out=DIR/cycles-spp16.exr

where seconds is the wall time of bpy.ops.render.render alone (Cycles'
scene sync, its BVH build and the path tracing; not Blender's start-up, the
import or writing the file) and sampling the path tracing alone, from the
first sample to the end. `--warmup` first renders one untimed sample
so that one-time initialisation does not land in the first timed render.
"""

import argparse
import json
import math
import os
import sys
import time

import bpy
import mathutils


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="render_cycles.py")
    p.add_argument("--scene", required=True)
    p.add_argument("--width", type=int, required=True)
    p.add_argument("--height", type=int, required=True)
    p.add_argument("--spp", required=True, help="comma-separated sample counts")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-bounces", type=int, default=7)
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    p.add_argument("--env", default="1,1,1", help="background radiance R,G,B")
    p.add_argument("--albedo", type=float, default=0.8)
    p.add_argument("--out-dir", required=True)
    p.add_argument("--warmup", action="store_true")
    p.add_argument("--frame", type=int, default=None)
    p.add_argument("--motion-blur", type=float, default=0.0, help="shutter in frames; 0: off")
    p.add_argument("--shutter-position", default="CENTER", choices=["START", "CENTER", "END"])
    p.add_argument("--motion-steps", type=int, default=1)
    p.add_argument("--keep-materials", action="store_true")
    p.add_argument("--guiding", action="store_true", help="path guiding on (CPU only)")
    return p.parse_args(argv)


def linearize_srgb_textures():
    """Replaces every 8-bit sRGB image the materials sample with a float copy
    of its decoded, linear texels.

    Cycles keeps 8-bit sRGB textures as bytes and decodes them after its
    bilinear filter, so it averages sRGB codes, not light: on DamagedHelmet's
    emissive texture (thin bright lines on black) that renders 6.3% darker
    than the texels' linear mean. glTF samples sRGB textures the way GPUs do,
    decoding each texel before filtering, and so does soupray; a float image
    is filtered in linear values by Cycles too.
    """
    import numpy

    converted = {}
    for m in bpy.data.materials:
        if not m.node_tree:
            continue
        for n in m.node_tree.nodes:
            img = getattr(n, "image", None) if n.type == "TEX_IMAGE" else None
            if img is None or img.is_float or img.colorspace_settings.name != "sRGB":
                continue
            if img.name not in converted:
                w, h = img.size
                px = numpy.empty(w * h * 4, dtype=numpy.float32)
                img.pixels.foreach_get(px)
                px = px.reshape(-1, 4)
                # The sRGB transfer function's exact inverse (IEC 61966-2-1).
                c = px[:, :3].astype(numpy.float64)
                px[:, :3] = numpy.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
                lin = bpy.data.images.new(img.name + " (linear)", w, h, alpha=True, float_buffer=True)
                # A float image is scene-linear by default; named for
                # clarity ("Linear" before Blender 4.0).
                spaces = lin.colorspace_settings.bl_rna.properties["name"].enum_items.keys()
                lin.colorspace_settings.name = "Linear Rec.709" if "Linear Rec.709" in spaces else "Linear"
                lin.alpha_mode = img.alpha_mode
                lin.pixels.foreach_set(px.ravel())
                converted[img.name] = lin
                print(f"CYCLES_INFO linearized texture {img.name!r} {w}x{h}")
            n.image = converted[img.name]


def file_lights(scene_path):
    """The KHR_lights_punctual lights of the glTF file, by name."""
    if not scene_path.endswith(".gltf"):
        return {}
    with open(scene_path) as f:
        doc = json.load(f)
    lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    return {l.get("name"): l for l in lights}


def main():
    args = parse_args()
    env = [float(v) for v in args.env.split(",")]
    if len(env) != 3:
        raise SystemExit("--env wants R,G,B")

    try:
        import numpy
    except ImportError:
        raise SystemExit(
            "Blender's glTF importer needs numpy for Blender's Python "
            "(Debian/Ubuntu: apt-get install python3-numpy)"
        )
    # Debian's Blender 3.4 importer still uses np.bool, which numpy 1.24
    # removed; FLAT shading (what glTF asks for when a primitive has no
    # normals, as here) avoids that code path, the alias covers the rest.
    if "bool" not in numpy.__dict__:
        numpy.bool = bool

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.scene), import_shading="FLAT")
    if args.keep_materials:
        linearize_srgb_textures()
    scene = bpy.context.scene

    cameras = [o for o in scene.objects if o.type == "CAMERA"]
    if not cameras:
        raise SystemExit(f"{args.scene}: no camera")
    scene.camera = cameras[0]

    if args.frame is not None:
        scene.render.fps = 24
        scene.render.fps_base = 1.0
        scene.frame_set(args.frame)

    # Materials: one pure Lambertian for everything.
    mat = bpy.data.materials.new("bench_diffuse")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (args.albedo, args.albedo, args.albedo, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    out = nodes.new("ShaderNodeOutputMaterial")
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    triangles = 0
    for o in scene.objects:
        if o.type != "MESH":
            continue
        if args.motion_blur > 0:
            o.cycles.use_motion_blur = True
            o.cycles.use_deform_motion = True
            o.cycles.motion_steps = args.motion_steps
        if not args.keep_materials:
            o.data.materials.clear()
            o.data.materials.append(mat)
            for poly in o.data.polygons:
                poly.material_index = 0
        triangles += sum(len(p.vertices) - 2 for p in o.data.polygons)

    # World: a constant background.
    world = bpy.data.worlds.new("bench_world")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (env[0], env[1], env[2], 1.0)
    bg.inputs["Strength"].default_value = 1.0
    scene.world = world

    # Lights: suns of the file's irradiance and point lights of its
    # intensity, delta.
    lights = file_lights(args.scene)
    for o in scene.objects:
        if o.type != "LIGHT":
            continue
        light = o.data
        if light.type not in ("SUN", "POINT"):
            raise SystemExit(f"{o.name}: only directional and point lights are translated")
        src = lights.get(light.name) or (next(iter(lights.values())) if len(lights) == 1 else None)
        if src is None:
            raise SystemExit(f"{o.name}: not found among the file's lights {list(lights)}")
        imported = light.energy
        intensity = float(src.get("intensity", 1.0))
        light.color = src.get("color", [1.0, 1.0, 1.0])
        if light.type == "POINT":
            light.energy = 4.0 * math.pi * intensity
            light.shadow_soft_size = 0.0
            continue
        light.energy = intensity
        light.angle = 0.0
        print(
            f"CYCLES_INFO sun={o.name!r} strength={light.energy} "
            f"(importer gave {imported}, x{light.energy / imported if imported else float('nan'):.1f}) "
            f"direction={tuple(round(v, 4) for v in (o.matrix_world.to_3x3() @ mathutils.Vector((0, 0, -1))))}"
        )

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = args.width
    r.resolution_y = args.height
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.use_compositing = False
    r.use_sequencer = False
    r.use_motion_blur = args.motion_blur > 0
    if args.motion_blur > 0:
        r.motion_blur_shutter = args.motion_blur
        scene.cycles.motion_blur_position = args.shutter_position
        for o in scene.objects:
            o.cycles.use_motion_blur = True
    r.use_persistent_data = False
    if args.threads > 0:
        r.threads_mode = "FIXED"
        r.threads = args.threads
    else:
        r.threads_mode = "AUTO"
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_mode = "RGBA"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"

    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0

    c = scene.cycles
    c.device = "CPU"
    if hasattr(c, "feature_set"):  # gone in Blender 5: no experimental set
        c.feature_set = "SUPPORTED"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.max_bounces = args.max_bounces
    c.diffuse_bounces = args.max_bounces
    c.glossy_bounces = args.max_bounces
    c.transmission_bounces = args.max_bounces
    c.transparent_max_bounces = args.max_bounces
    c.volume_bounces = 0
    c.min_light_bounces = 0
    c.min_transparent_bounces = 0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.use_fast_gi = False
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 1.5
    c.use_animated_seed = False
    c.seed = args.seed
    if args.guiding:
        if not hasattr(c, "use_guiding"):
            raise SystemExit(f"--guiding: Blender {bpy.app.version_string} has no path guiding")
        c.use_guiding = True
        c.use_surface_guiding = True
        c.use_volume_guiding = True

    cam = scene.camera.data
    print(
        f"CYCLES_INFO blender={bpy.app.version_string} triangles={triangles} "
        f"camera={scene.camera.name!r} angle_y_deg={cam.angle_y * 57.29577951308232:.4f} "
        f"sensor_fit={cam.sensor_fit} clip={cam.clip_start},{cam.clip_end} "
        f"pattern={getattr(c, 'sampling_pattern', '?')} "
        f"light_tree={getattr(c, 'use_light_tree', '-')} guiding={getattr(c, 'use_guiding', '-')} "
        f"threads={r.threads}"
    )

    # Path tracing alone: from Cycles' first sample to `Finished`, as its
    # status messages (the render_stats handler, called by the render
    # thread) report them; both Blender 3.4 and 5.0 end them with
    # `Sample 0/N` and `Finished`.
    marks = {}

    def on_stats(*stats):
        text = stats[0] if stats and isinstance(stats[0], str) else ""
        if "Sample 0/" in text and "first" not in marks:
            marks["first"] = time.perf_counter()
        elif text.endswith("Finished"):
            marks["finished"] = time.perf_counter()

    bpy.app.handlers.render_stats.append(on_stats)

    os.makedirs(args.out_dir, exist_ok=True)
    if args.warmup:
        c.samples = 1
        bpy.ops.render.render(write_still=False)
    for spp in [int(v) for v in args.spp.split(",") if v]:
        c.samples = spp
        marks.clear()
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        seconds = time.perf_counter() - t0
        sampling = marks.get("finished", float("nan")) - marks.get("first", float("nan"))
        path = os.path.join(os.path.abspath(args.out_dir), f"cycles-spp{spp}.exr")
        tmp = path + ".tmp.exr"
        bpy.data.images["Render Result"].save_render(filepath=tmp, scene=scene)
        os.replace(tmp, path)
        print(
            f"CYCLES_RENDER spp={spp} seconds={seconds:.6f} sampling={sampling:.6f} out={path}",
            flush=True,
        )


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        if e.code not in (None, 0):
            print(f"render_cycles.py: error: {e.code}", file=sys.stderr)
            sys.stderr.flush()
            os._exit(1)
        raise
    except Exception:
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        os._exit(1)
