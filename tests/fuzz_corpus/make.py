#!/usr/bin/env python3
"""Writes the regression corpus of hostile glTF files (tests/fuzz_corpus/)
and its expectations (expect.json), read by tests/fuzz_scene/corpus.rs.

Every case is a small valid base file (a triangle, a rotation animation, a
camera, a point light, an unused image) with one mutation of the kind a
broken exporter or a hostile file produces. `outcome` is "error" (the load
must fail with a message naming the file and each of `mentions`) or "ok"
(the load and frame 0 succeed, and the warnings mention each of
`mentions`). Re-run after changing a case: python3 tests/fuzz_corpus/make.py
"""
import base64, copy, json, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))
PNG_1x1 = ("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAE"
           "hQGAhKmMIQAAAABJRU5ErkJggg==")


def buffer_bytes(times=(0.0, 1.0)):
    b = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)  # 0..36 positions
    b += struct.pack("<3H", 0, 1, 2) + b"\0\0"  # 36..44 indices
    b += struct.pack("<2f", *times)  # 44..52 key times
    b += struct.pack("<8f", 0, 0, 0, 1, 0, 0.7071, 0, 0.7071)  # 52..84 rotations
    b += bytes([0, 0, 0, 255, 0, 180, 0, 180])  # 84..92 u8 rotations
    return b


def base(times=(0.0, 1.0)):
    data = buffer_bytes(times)
    return {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 5}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0, "name": "tri"},
            {"camera": 0, "translation": [0.3, 0.3, 3]},
            {"translation": [0, 0, 2], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
            {"buffer": 0, "byteOffset": 44, "byteLength": 8},
            {"buffer": 0, "byteOffset": 52, "byteLength": 32},
            {"buffer": 0, "byteOffset": 84, "byteLength": 8},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
            {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC4"},
            {"bufferView": 4, "componentType": 5121, "count": 2, "type": "VEC4"},
        ],
        "animations": [{"samplers": [{"input": 2, "output": 3}],
                        "channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}]}],
        "images": [{"uri": "data:image/png;base64," + PNG_1x1}],
    }


CASES = {}


def case(name, outcome, mentions, times=(0.0, 1.0)):
    def deco(mutate):
        doc = base(times)
        mutate(doc)
        CASES[name] = (doc, outcome, mentions)
        return mutate
    return deco


@case("valid", "ok", [])
def _(d): pass

# The gltf crate's panics.
@case("anim_target_node_out_of_range", "error", ["target.node", "node 7"])
def _(d): d["animations"][0]["channels"][0]["target"]["node"] = 7

# KHR_animation_pointer: a pointer to node TRS loads as a node channel.
@case("anim_path_pointer", "ok", [])
def _(d):
    d["animations"][0]["channels"].append(
        {"sampler": 0, "target": {"path": "pointer",
                                  "extensions": {"KHR_animation_pointer": {"pointer": "/nodes/0/rotation"}}}})
    d["extensionsUsed"].append("KHR_animation_pointer")

# A "pointer" channel without its pointer is skipped, like a channel
# without a node.
@case("anim_path_pointer_required", "ok", ["\"pointer\" but no KHR_animation_pointer pointer", "skipped 1 channel"])
def _(d):
    d["animations"][0]["channels"][0]["target"] = {"path": "pointer"}
    d["extensionsUsed"].append("KHR_animation_pointer")
    d["extensionsRequired"] = ["KHR_animation_pointer"]

# Pointers soupray does not animate: skipped, named in one warning.
@case("anim_pointer_unsupported", "ok", ["\"/asset/version\"", "\"/nodes/9/rotation\"", "no node 9", "2 channels"])
def _(d):
    for pointer in ["/asset/version", "/nodes/9/rotation", "/nodes/9/rotation"]:
        d["animations"][0]["channels"].append(
            {"sampler": 0, "target": {"path": "pointer",
                                      "extensions": {"KHR_animation_pointer": {"pointer": pointer}}}})
    d["extensionsUsed"].append("KHR_animation_pointer")

# A pointer channel's output must have the property's type.
@case("anim_pointer_wrong_type", "error", ["keyframe values of animation 0 channel 1", "SCALAR"])
def _(d):
    d["animations"][0]["channels"].append(
        {"sampler": 0, "target": {"path": "pointer",
                                  "extensions": {"KHR_animation_pointer": {"pointer": "/extensions/KHR_lights_punctual/lights/0/intensity"}}}})
    d["extensionsUsed"].append("KHR_animation_pointer")

@case("anim_path_unknown", "ok", ["\"colour\"", "skipped 1 channel"])
def _(d): d["animations"][0]["channels"].append({"sampler": 0, "target": {"node": 0, "path": "colour"}})

@case("image_view_without_mime", "error", ["image 0", "mimeType"])
def _(d): d["images"][0] = {"bufferView": 0}

@case("image_without_source", "error", ["image 0", "neither a uri nor a bufferView"])
def _(d): d["images"][0] = {"name": "empty"}

@case("image_uri_and_view", "error", ["image 0", "both"])
def _(d): d["images"][0]["bufferView"] = 0

@case("meshes_without_accessors", "error", ["attribute POSITION", "no accessors"])
def _(d):
    del d["accessors"]
    del d["animations"]

# Indices of 2^32 and more must not wrap.
for name, path, value in [
    ("mesh_index_2_32_plus_1", ("nodes", 0, "mesh"), 4294967297),
    ("mesh_index_2_32", ("nodes", 0, "mesh"), 4294967296),
    ("scene_node_2_32", ("scenes", 0, "nodes", 0), 4294967296),
    ("child_2_32", ("nodes", 1, "children"), [4294967296]),
    ("accessor_index_2_32", ("meshes", 0, "primitives", 0, "indices"), 4294967297),
    ("position_index_2_32", ("meshes", 0, "primitives", 0, "attributes", "POSITION"), 4294967296),
    ("bufferview_index_2_32", ("accessors", 0, "bufferView"), 4294967296),
    ("buffer_index_2_32", ("bufferViews", 0, "buffer"), 4294967296),
    ("camera_index_2_32", ("nodes", 1, "camera"), 4294967296),
    ("light_index_2_32", ("nodes", 2, "extensions", "KHR_lights_punctual", "light"), 4294967296),
    ("anim_sampler_2_32", ("animations", 0, "channels", 0, "sampler"), 4294967296),
    ("anim_input_2_32", ("animations", 0, "samplers", 0, "input"), 4294967298),
    ("scene_2_32", ("scene",), 4294967296),
    ("mesh_index_negative", ("nodes", 0, "mesh"), -1),
    ("mesh_index_fraction", ("nodes", 0, "mesh"), 0.5),
    ("mesh_index_string", ("nodes", 0, "mesh"), "0"),
]:
    def mut(d, path=path, value=value):
        obj = d
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value
    mentions = [] if value in ("0", 0.5, -1) else [str(value[0] if isinstance(value, list) else value)]
    case(name, "error", mentions)(mut)

# Out-of-range indices of every kind.
@case("mesh_out_of_range", "error", ["node 0.mesh", "mesh 3"])
def _(d): d["nodes"][0]["mesh"] = 3

@case("material_out_of_range", "error", ["material 2", "no materials"])
def _(d): d["meshes"][0]["primitives"][0]["material"] = 2

@case("texture_source_out_of_range", "error", ["texture 0.source", "image 5"])
def _(d): d["textures"] = [{"source": 5}]

@case("anim_sampler_out_of_range", "error", ["channel 0.sampler", "1 sampler"])
def _(d): d["animations"][0]["channels"][0]["sampler"] = 1

@case("skin_joint_out_of_range", "error", ["skin 0.joints", "node 9"])
def _(d): d["skins"] = [{"joints": [9]}]

# Accessors, views and buffers.
@case("float_accessor_misaligned", "error", ["accessor 0", "multiple of its 4-byte component size"])
def _(d):
    d["bufferViews"][0]["byteOffset"] = 2

@case("float_accessor_offset_misaligned", "error", ["accessor 3", "multiple of its 4-byte"])
def _(d):
    d["bufferViews"][3]["byteLength"] = 32
    d["accessors"][3]["byteOffset"] = 2
    d["accessors"][3]["count"] = 1

@case("accessor_past_view", "error", ["accessor 0", "needs bytes 0..48", "36 bytes long"])
def _(d): d["accessors"][0]["count"] = 4

@case("accessor_count_huge", "error", ["accessor 0", "bufferView 0"])
def _(d): d["accessors"][0]["count"] = 2**62

@case("accessor_without_view_huge", "error", ["accessor 0", "no bufferView", "zeros"])
def _(d):
    d["accessors"][0] = {"componentType": 5126, "count": 200000000, "type": "VEC3",
                         "min": [0, 0, 0], "max": [1, 1, 0],
                         "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123},
                                    "values": {"bufferView": 0}}}

@case("ibm_without_view_huge", "error", ["accessor 5", "no bufferView", "zeros"])
def _(d):
    d["bufferViews"].append({"buffer": 0, "byteOffset": 0, "byteLength": 84})
    d["accessors"].append({"componentType": 5126, "count": 100000000, "type": "MAT4",
                           "sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123},
                                      "values": {"bufferView": 5}}})
    d["skins"] = [{"joints": [0], "inverseBindMatrices": 5}]

@case("accessor_count_zero", "error", ["accessor 0", "count"])
def _(d): d["accessors"][0]["count"] = 0

@case("accessor_bad_component_type", "error", ["accessor 0", "componentType 1234"])
def _(d): d["accessors"][0]["componentType"] = 1234

@case("accessor_bad_type", "error", ["accessor 0", "VEC5"])
def _(d): d["accessors"][0]["type"] = "VEC5"

@case("view_past_buffer", "error", ["bufferView 3", "byteLength is 92"])
def _(d): d["bufferViews"][3]["byteLength"] = 100

@case("view_stride_odd", "error", ["bufferView 0", "byteStride 3"])
def _(d): d["bufferViews"][0]["byteStride"] = 3

@case("sparse_view_out_of_range", "error", ["sparse", "bufferView 8"])
def _(d):
    d["accessors"][0]["sparse"] = {"count": 1, "indices": {"bufferView": 8, "componentType": 5123},
                                   "values": {"bufferView": 0}}

@case("buffer_without_length", "error", ["buffer 0", "byteLength"])
def _(d): del d["buffers"][0]["byteLength"]

@case("buffer_length_short", "ok", ["buffer 0 holds 92 bytes", "byteLength is 200"])
def _(d): d["buffers"][0]["byteLength"] = 200

@case("buffer_length_long", "ok", ["buffer 0 holds 92 bytes", "byteLength is 88", "ignored"])
def _(d):
    d["buffers"][0]["byteLength"] = 88
    d["bufferViews"][4]["byteLength"] = 4
    d["accessors"][4]["count"] = 1

# Versions.
@case("version_3", "error", ["\"3.0\"", "glTF 2.x"])
def _(d): d["asset"]["version"] = "3.0"

@case("version_banana", "error", ["banana", "glTF 2.x"])
def _(d): d["asset"]["version"] = "banana"

@case("min_version_2_1", "error", ["2.1", "minVersion"])
def _(d): d["asset"]["minVersion"] = "2.1"

@case("version_2_1", "ok", [])
def _(d): d["asset"]["version"] = "2.1"

@case("no_asset", "error", ["asset"])
def _(d): del d["asset"]

# Animations.
@case("key_times_equal", "error", ["keyframe times", "strictly increasing"], times=(0.5, 0.5))
def _(d): pass

@case("key_times_decreasing", "error", ["keyframe times", "strictly increasing"], times=(1.0, 0.0))
def _(d): pass

@case("rotation_u8_not_normalized", "error", ["channel 0", "normalized"])
def _(d): d["animations"][0]["samplers"][0]["output"] = 4

@case("rotation_u8_normalized", "ok", [])
def _(d):
    d["animations"][0]["samplers"][0]["output"] = 4
    d["accessors"][4]["normalized"] = True

@case("translation_u8", "error", ["channel 0", "translation", "FLOAT"])
def _(d):
    d["animations"][0]["samplers"][0]["output"] = 4
    d["animations"][0]["channels"][0]["target"]["path"] = "translation"

@case("texcoord_u8_not_normalized", "error", ["attribute TEXCOORD_0", "normalized"])
def _(d):
    d["accessors"].append({"bufferView": 4, "componentType": 5121, "count": 3, "type": "VEC2"})
    d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 5

@case("texcoord_u8_normalized", "ok", [])
def _(d):
    d["accessors"].append({"bufferView": 4, "componentType": 5121, "count": 3, "type": "VEC2", "normalized": True})
    d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 5

@case("attribute_unknown_semantic", "ok", ["\"BANANA\"", "ignored"])
def _(d): d["meshes"][0]["primitives"][0]["attributes"]["BANANA"] = 0

@case("texture_without_source", "error", ["source"])
def _(d):
    d["textures"] = [{"sampler": 0}]
    d["samplers"] = [{}]

@case("sampler_wrap_unknown", "error", ["wrapS"])
def _(d):
    d["textures"] = [{"source": 0, "sampler": 0}]
    d["samplers"] = [{"wrapS": 1}]

# Scenes, cameras, lights, materials.
@case("scene_root_twice", "error", ["scene 0.nodes", "node 0 more than once"])
def _(d): d["scenes"][0]["nodes"] = [0, 1, 2, 0]

@case("child_twice", "error", ["node 1.children", "node 0 more than once"])
def _(d):
    d["nodes"][1]["children"] = [0, 0]
    d["scenes"][0]["nodes"] = [1, 2]

@case("camera_type_without_object", "error", ["camera 0", "perspective"])
def _(d): d["cameras"][0] = {"type": "perspective"}

@case("camera_type_unknown", "error", ["camera 0", "fisheye"])
def _(d): d["cameras"][0] = {"type": "fisheye", "fisheye": {}}

@case("spot_without_cone", "error", ["light 0", "spot"])
def _(d): d["extensions"]["KHR_lights_punctual"]["lights"][0] = {"type": "spot"}

@case("texcoord_2_32", "error", ["texCoord", "4294967296"])
def _(d):
    d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 4294967296}}}]

@case("root_not_object", "error", ["not an object"])
def _(d):
    d.clear()

# Out-of-range values: clamped with a warning naming the object.
@case("camera_yfov_negative", "ok", ["camera 0", "yfov -0.5", "40 degrees"])
def _(d): d["cameras"][0]["perspective"]["yfov"] = -0.5

@case("camera_yfov_zero", "ok", ["camera 0", "yfov 0"])
def _(d): d["cameras"][0]["perspective"]["yfov"] = 0

@case("camera_znear_zero", "ok", ["camera 0", "znear 0", "0.001"])
def _(d): d["cameras"][0]["perspective"]["znear"] = 0

@case("camera_zfar_before_znear", "ok", ["camera 0", "zfar 0.05", "infinite"])
def _(d): d["cameras"][0]["perspective"]["zfar"] = 0.05

@case("camera_aspect_negative", "ok", ["camera 0", "aspectRatio -1.5"])
def _(d): d["cameras"][0]["perspective"]["aspectRatio"] = -1.5

@case("camera_ortho_zero_mag", "ok", ["camera 0", "xmag 0", "ymag -2"])
def _(d): d["cameras"][0] = {"type": "orthographic", "orthographic": {"xmag": 0, "ymag": -2, "znear": 0, "zfar": 10}}

@case("light_negative_intensity", "ok", ["light 0", "intensity -5"])
def _(d): d["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = -5

@case("light_negative_color", "ok", ["light 0", "color.g -1"])
def _(d): d["extensions"]["KHR_lights_punctual"]["lights"][0]["color"] = [1, -1, 0.5]

@case("spot_cones_reversed", "ok", ["light 0", "innerConeAngle 0.7", "swapped"])
def _(d):
    d["extensions"]["KHR_lights_punctual"]["lights"][0] = {
        "type": "spot", "intensity": 5, "spot": {"innerConeAngle": 0.7, "outerConeAngle": 0.2}}

@case("spot_outer_too_wide", "ok", ["light 0", "outerConeAngle 3"])
def _(d):
    d["extensions"]["KHR_lights_punctual"]["lights"][0] = {
        "type": "spot", "intensity": 5, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 3}}

@case("material_factors_out_of_range", "ok",
      ["material 0 \"hot\"", "baseColorFactor.r 2", "metallicFactor -1", "roughnessFactor 7", "emissiveFactor.g 3"])
def _(d):
    d["materials"] = [{"name": "hot", "pbrMetallicRoughness": {
        "baseColorFactor": [2, 0.5, 0.5, 1], "metallicFactor": -1, "roughnessFactor": 7},
        "emissiveFactor": [0, 3, 0]}]
    d["meshes"][0]["primitives"][0]["material"] = 0

# Inputs that are not regular files (read-only paths; never written).
@case("buffer_uri_dev_zero", "error", ["/dev/zero", "character device"])
def _(d): d["buffers"][0]["uri"] = "/dev/zero"

@case("buffer_uri_dev_urandom", "error", ["/dev/urandom", "character device"])
def _(d): d["buffers"][0]["uri"] = "/dev/urandom"

@case("buffer_uri_directory", "error", ["buffer 0", "directory"])
def _(d): d["buffers"][0]["uri"] = "."

@case("image_uri_dev_zero", "error", ["image 0", "character device"])
def _(d):
    d["images"][0] = {"uri": "/dev/zero"}
    d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    d["meshes"][0]["primitives"][0]["material"] = 0


# KHR_texture_basisu payloads: an 8x8 UASTC KTX2 of four solid-colour
# blocks (UASTC mode 8, which needs no encoder), raw or under a Zstandard
# frame of stored blocks; the same layout as tests/common/scene/ktx2.rs.
def uastc_solid(r, g, b, a):
    return (0x17 | r << 5 | g << 13 | b << 21 | a << 29).to_bytes(16, "little")


def zstd_stored(data):
    return (b"\x28\xb5\x2f\xfd\xa0" + struct.pack("<I", len(data))
            + (len(data) << 3 | 1).to_bytes(3, "little") + data)


def ktx2(zstd=False, width=8, height=8):
    raw = b"".join(uastc_solid(*c) for c in
                   [(255, 0, 0, 255), (0, 200, 0, 128), (10, 20, 250, 255), (90, 90, 90, 0)])
    level = zstd_stored(raw) if zstd else raw
    dfd = struct.pack("<7I", 44, 0, 2 | 40 << 16, 166 | 1 << 8 | 2 << 16, 3 | 3 << 8, 16, 0)
    dfd += struct.pack("<4I", 127 << 16 | 3 << 24, 0, 0, 0xFFFFFFFF)
    dfd_at = 80 + 24
    level_at = (dfd_at + len(dfd) + 15) // 16 * 16
    out = b"\xabKTX 20\xbb\r\n\x1a\n"
    out += struct.pack("<9I", 0, 1, width, height, 0, 0, 1, 1, 2 if zstd else 0)
    out += struct.pack("<4I", dfd_at, len(dfd), 0, 0)
    out += struct.pack("<5Q", 0, 0, level_at, len(level), len(raw))
    out += dfd
    out += b"\0" * (level_at - len(out)) + level
    return bytearray(out)


# An 8x8 lossless WebP, made by the `image` crate's encoder (as in
# tests/fuzz_scene/textures.rs damaged_webp_is_refused).
WEBP_8x8 = bytes.fromhex(
    "524946469a000000574542505650384c8d0000002f07c00110cd552022021ec8260000000000"
    "000000000000000000000000000000000000000000000000000000000000808041c001c00391"
    "0000000000387f63000000000200000000000000000000000000000000000000000000000000"
    "007820010000000000e72f100000000000000000000000000000000000000000000000000000"
    "0000000010a9f6330300")


def textured(d, uri, basisu):
    """The triangle's material samples `uri` as its base colour."""
    d["images"][0] = {"uri": uri}
    if basisu:
        d["extensionsUsed"].append("KHR_texture_basisu")
        d["textures"] = [{"extensions": {"KHR_texture_basisu": {"source": 0}}}]
    else:
        d["textures"] = [{"source": 0}]
    d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    d["meshes"][0]["primitives"][0]["material"] = 0


def ktx2_case(name, outcome, mentions, bytes_):
    @case(name, outcome, (["image 0"] if outcome == "error" else []) + mentions)
    def _(d):
        textured(d, "data:image/ktx2;base64," + base64.b64encode(bytes(bytes_)).decode(), True)


def webp_case(name, outcome, mentions, bytes_):
    @case(name, outcome, (["image 0"] if outcome == "error" else []) + mentions)
    def _(d):
        textured(d, "data:image/webp;base64," + base64.b64encode(bytes(bytes_)).decode(), False)


def patched(b, at, fmt, value):
    b = bytearray(b)
    struct.pack_into(fmt, b, at, value)
    return b


LEVEL_AT = 160  # level 0's data in ktx2(): after the 44-byte DFD at 104, 16-aligned
ktx2_case("ktx2_valid", "ok", [], ktx2())
ktx2_case("ktx2_valid_zstd", "ok", [], ktx2(zstd=True))
ktx2_case("ktx2_truncated", "error", ["damaged KTX2"], ktx2()[:LEVEL_AT + 20])
ktx2_case("ktx2_truncated_header", "error", ["damaged KTX2"], ktx2()[:50])
ktx2_case("ktx2_level_length_past_file", "error", ["damaged KTX2"], patched(ktx2(), 88, "<Q", 1 << 40))
ktx2_case("ktx2_level_offset_wraps", "error", ["damaged KTX2"], patched(ktx2(), 80, "<Q", 2**64 - 8))
ktx2_case("ktx2_level_length_short", "error", ["mip level 0", "needs 64"], patched(ktx2(), 88, "<Q", 48))
ktx2_case("ktx2_uncompressed_length_lies", "error", ["uncompressed length", "needs 64"],
          patched(ktx2(zstd=True), 96, "<Q", 1 << 62))
ktx2_case("ktx2_pixel_width_absurd", "error", ["4294967295x8", "MiB"], patched(ktx2(), 20, "<I", 2**32 - 1))
ktx2_case("ktx2_level_count_lies", "error", ["damaged KTX2"], patched(ktx2(), 40, "<I", 100000))
ktx2_case("ktx2_bitflipped_format", "error", ["vkFormat 37"], patched(ktx2(), 12, "<I", 37))
ktx2_case("ktx2_bitflipped_scheme", "error", ["scheme 1"], patched(ktx2(), 44, "<I", 1))
webp_case("webp_valid", "ok", [], WEBP_8x8)
webp_case("webp_truncated", "error", ["cannot be decoded"], WEBP_8x8[:len(WEBP_8x8) // 2])
webp_case("webp_header_only", "error", ["cannot be decoded"], WEBP_8x8[:12])
webp_case("webp_bitflipped_signature", "error", ["cannot be decoded"], patched(WEBP_8x8, 20, "<B", 0x3f))
webp_case("webp_bitflipped_size", "error", ["cannot be decoded"], patched(WEBP_8x8, 21, "<B", WEBP_8x8[21] ^ 0x10))
ktx2_case("ktx2_bitflipped_block_mode", "error", ["cannot be transcoded"], patched(ktx2(), LEVEL_AT, "<B", 69))  # mode code 69: no UASTC mode


def main():
    for f in os.listdir(HERE):
        if f.endswith(".gltf"):
            os.remove(os.path.join(HERE, f))
    expect = {}
    for name, (doc, outcome, mentions) in sorted(CASES.items()):
        text = "[]" if name == "root_not_object" else json.dumps(doc, indent=1)
        with open(os.path.join(HERE, name + ".gltf"), "w") as f:
            f.write(text + "\n")
        expect[name + ".gltf"] = {"outcome": outcome, "mentions": mentions}
    with open(os.path.join(HERE, "expect.json"), "w") as f:
        json.dump(expect, f, indent=1, sort_keys=True)
        f.write("\n")
    print(f"{len(CASES)} cases")


main()
