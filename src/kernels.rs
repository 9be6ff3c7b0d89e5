//! The kernels' sources, embedded in the binary, and the headers generated
//! from the Rust definitions of the structs and constants the host shares
//! with them (src/device_struct.rs).

use crate::device_struct::{DeviceStruct, GeneratedHeader};
use crate::{bvh, soup, trace};

/// The OpenCL C sources, embedded so the binary runs from anywhere. Headers
/// are inlined by `assemble_source` where a program `#include`s them.
pub const KERNEL_SOURCES: &[(&str, &str)] = &[
    (
        "bvh_types.h",
        include_str!("../kernels/generated/bvh_types.h"),
    ),
    ("bvh_common.h", include_str!("../kernels/bvh_common.h")),
    ("bvh_build.cl", include_str!("../kernels/bvh_build.cl")),
    (
        "soup_types.h",
        include_str!("../kernels/generated/soup_types.h"),
    ),
    ("soup_eval.cl", include_str!("../kernels/soup_eval.cl")),
    (
        "trace_types.h",
        include_str!("../kernels/generated/trace_types.h"),
    ),
    ("trace_common.h", include_str!("../kernels/trace_common.h")),
    ("trace.cl", include_str!("../kernels/trace.cl")),
    (
        "texture_types.h",
        include_str!("../kernels/generated/texture_types.h"),
    ),
    ("texture.h", include_str!("../kernels/texture.h")),
    (
        "texture_probe.cl",
        include_str!("../kernels/texture_probe.cl"),
    ),
    (
        "pt_types.h",
        include_str!("../kernels/generated/pt_types.h"),
    ),
    ("sampling.h", include_str!("../kernels/sampling.h")),
    ("ggx_energy.h", include_str!("../kernels/ggx_energy.h")),
    (
        "ggx_aniso_energy.h",
        include_str!("../kernels/ggx_aniso_energy.h"),
    ),
    ("sheen_energy.h", include_str!("../kernels/sheen_energy.h")),
    ("bsdf.h", include_str!("../kernels/bsdf.h")),
    ("lights.h", include_str!("../kernels/lights.h")),
    ("media.h", include_str!("../kernels/media.h")),
    ("pathtrace.cl", include_str!("../kernels/pathtrace.cl")),
    ("pt_probe.cl", include_str!("../kernels/pt_probe.cl")),
    ("motion.h", include_str!("../kernels/motion.h")),
    ("motion.cl", include_str!("../kernels/motion.cl")),
];

/// Every generated header of `kernels/generated/`, from the definitions in
/// the stages that own the structs. `tests/device_structs.rs` regenerates
/// them and probes every field's layout on the device.
pub fn generated_headers() -> Vec<GeneratedHeader> {
    use bvh::layout as b;
    use trace::{escape, lights, material, render, texture, wide};
    vec![
        GeneratedHeader {
            file: "bvh_types.h",
            about: "The BVH builder's structs (src/bvh/layout.rs).",
            consts: b::bvh_consts(),
            structs: vec![
                b::BvhNode::layout(),
                b::PrimRef::layout(),
                b::Bin::layout(),
                b::BuildTask::layout(),
                b::SplitResult::layout(),
                b::SmallSubtree::layout(),
            ],
        },
        GeneratedHeader {
            file: "trace_types.h",
            about: "Rays, hits and the traversal layouts (src/trace/).",
            consts: [trace::trace_consts(), escape::stackless_consts()].concat(),
            structs: vec![
                trace::Ray::layout(),
                trace::Hit::layout(),
                escape::StacklessNode::layout(),
                wide::WideNode::layout(),
            ],
        },
        GeneratedHeader {
            file: "soup_types.h",
            about: "The soup evaluator's structs (src/soup/device.rs).",
            consts: soup::device::soup_consts(),
            structs: vec![
                soup::device::SoupSegment::layout(),
                soup::device::SoupInstancePose::layout(),
            ],
        },
        GeneratedHeader {
            file: "texture_types.h",
            about: "Textures and their bindings (src/trace/texture.rs).",
            consts: texture::texture_consts(),
            structs: vec![
                texture::TextureInfo::layout(),
                texture::TextureBinding::layout(),
            ],
        },
        GeneratedHeader {
            file: "pt_types.h",
            about: "The path tracer's per-frame tables: camera, frame, materials, lights, environment (src/trace/).",
            consts: [
                render::frame_consts(),
                material::material_consts(),
                lights::light_consts(),
            ]
            .concat(),
            structs: vec![
                render::DeviceCamera::layout(),
                render::DeviceFrame::layout(),
                material::DeviceMaterial::layout(),
                material::DeviceMaterialExt::layout(),
                lights::DeviceLight::layout(),
                lights::DeviceEnv::layout(),
            ],
        },
    ]
}
