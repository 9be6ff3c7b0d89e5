//! The kernels' sources, embedded in the binary, and the headers generated
//! from the Rust definitions of the structs and constants the host shares
//! with them (src/device_struct.rs).

use crate::device_struct::{DeviceStruct, GeneratedHeader};
use crate::{bvh, soup, trace};

/// One kernel source embedded by its path under `kernels/`, listed by its
/// file name, which is how `#include` names it (the folders are for people:
/// one per stage, as in `src/`, with `common/` shared and `generated/` made
/// from the Rust definitions).
macro_rules! kernel {
    ($dir:literal / $file:literal) => {
        (
            $file,
            include_str!(concat!("../kernels/", $dir, "/", $file)),
        )
    };
}

/// The OpenCL C sources, embedded so the binary runs from anywhere. Headers
/// are inlined by `assemble_source` where a program `#include`s them.
pub const KERNEL_SOURCES: &[(&str, &str)] = &[
    kernel!("generated" / "bvh_types.h"),
    kernel!("generated" / "soup_types.h"),
    kernel!("generated" / "trace_types.h"),
    kernel!("generated" / "texture_types.h"),
    kernel!("generated" / "pt_types.h"),
    kernel!("generated" / "ggx_energy.h"),
    kernel!("generated" / "ggx_aniso_energy.h"),
    kernel!("generated" / "sheen_energy.h"),
    kernel!("generated" / "ggx_schlick_energy.h"),
    kernel!("generated" / "ggx_average_energy.h"),
    kernel!("generated" / "ggx_refraction_energy.h"),
    kernel!("common" / "sampling.h"),
    kernel!("soup" / "soup_eval.cl"),
    kernel!("bvh" / "bvh_common.h"),
    kernel!("bvh" / "bvh_build.cl"),
    kernel!("trace" / "trace_common.h"),
    kernel!("trace" / "leaf_gather.h"),
    kernel!("trace" / "trace.cl"),
    kernel!("trace" / "texture.h"),
    kernel!("trace" / "texture_probe.cl"),
    kernel!("trace" / "eon.h"),
    kernel!("trace" / "bsdf.h"),
    kernel!("trace" / "layering.h"),
    kernel!("trace" / "bsdf_layers.h"),
    kernel!("trace" / "lights.h"),
    kernel!("trace" / "media.h"),
    kernel!("trace" / "lens.h"),
    kernel!("trace" / "scene_view.h"),
    kernel!("trace" / "direct_light.h"),
    kernel!("trace" / "path_sample.h"),
    kernel!("trace" / "pathtrace.cl"),
    kernel!("trace" / "pt_probe.cl"),
    kernel!("trace" / "light_tree.cl"),
    kernel!("trace" / "motion.h"),
    kernel!("trace" / "motion.cl"),
];

/// Every generated header of `kernels/generated/`, from the definitions in
/// the stages that own the structs. `tests/device_structs.rs` regenerates
/// them and probes every field's layout on the device.
pub fn generated_headers() -> Vec<GeneratedHeader> {
    use bvh::layout as b;
    use trace::{camera, escape, light_tree, lights, material, render, texture, vectors, wide};
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
            code: String::new(),
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
                wide::Wide8Node::layout(),
                trace::quantized::Wide8QNode::layout(),
                wide::LeafBlock::layout(),
            ],
            code: String::new(),
        },
        GeneratedHeader {
            file: "soup_types.h",
            about: "The soup evaluator's structs (src/soup/device.rs).",
            consts: soup::device::soup_consts(),
            structs: vec![
                soup::device::SoupSegment::layout(),
                soup::device::SoupInstancePose::layout(),
            ],
            code: String::new(),
        },
        GeneratedHeader {
            file: "texture_types.h",
            about: "Textures and their bindings (src/trace/texture.rs).",
            consts: texture::texture_consts(),
            structs: vec![
                texture::TextureInfo::layout(),
                texture::TextureBinding::layout(),
            ],
            code: String::new(),
        },
        GeneratedHeader {
            file: "pt_types.h",
            about: "The path tracer's per-frame tables: camera, frame, materials, lights, environment (src/trace/).",
            consts: [
                render::frame_consts(),
                material::material_consts(),
                material::material_ext_consts(),
                lights::light_consts(),
                light_tree::light_tree_consts(),
                crate::scene::compositing::compositing_consts(),
                crate::film::light::light_pass_consts(),
            ]
            .concat(),
            structs: vec![
                camera::DeviceCamera::layout(),
                vectors::VectorCamera::layout(),
                render::DeviceFrame::layout(),
                material::DeviceMaterial::layout(),
                material::DeviceMaterialExt::layout(),
                lights::DeviceLight::layout(),
                lights::DeviceEnv::layout(),
                light_tree::DeviceLightNode::layout(),
            ],
            code: material::inputs_struct_code() + &material::inputs_fill_code(),
        },
    ]
}
