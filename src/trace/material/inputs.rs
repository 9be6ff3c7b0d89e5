//! `PtMaterialInputs`: the extension factors as the BSDF reads them at one
//! surface point, each scaled by its texture, generated from the material
//! tables (`scene::material::FACTORS` and `texture_slots!`) so that a new
//! factor with a texture reaches `BsdfParams.in` without a kernel edit.
//!
//! The struct and the macros that fill it go into
//! `kernels/generated/pt_types.h`; `scene_view.h`'s `pt_material_inputs`
//! expands the macros after the texture lookup they call.

use std::fmt::Write;

use crate::scene::material::{device_factors, Slot};

/// One field of `PtMaterialInputs`: its name (the factor's define in
/// lower case, `sheen_roughness`), its `F_<KEY>` define, its width, and
/// the extension and key that set it.
struct InputField {
    name: String,
    define: String,
    width: usize,
    source: Option<(&'static str, &'static str)>,
}

fn input_fields() -> Vec<InputField> {
    device_factors()
        .map(|(_, define, f)| InputField {
            name: define.trim_start_matches("F_").to_ascii_lowercase(),
            define,
            width: f.width(),
            source: f.extension_key(),
        })
        .collect()
}

/// The field a scaling slot's texture scales: its extension's factor of
/// that key.
fn scaled_field<'f>(fields: &'f [InputField], slot: Slot, factor: &str) -> Option<&'f InputField> {
    let (ext, _) = slot.extension_key()?;
    fields.iter().find(|f| f.source == Some((ext, factor)))
}

fn c_type(width: usize) -> &'static str {
    match width {
        1 => "float",
        3 => "float3",
        _ => "float4",
    }
}

/// The typedef of `PtMaterialInputs`, one field per factor of
/// `PtMaterialExt.factor`, in its order.
pub fn inputs_struct_code() -> String {
    let mut s = String::from(
        "// The extension factors at one surface point (`BsdfParams.in`): each\n\
         // of `PtMaterialExt.factor`, times its texture's channel where the\n\
         // material table gives it one (src/trace/material/inputs.rs).\n\
         typedef struct {\n",
    );
    for f in input_fields() {
        let _ = writeln!(s, "    {} {};", c_type(f.width), f.name);
    }
    s.push_str("} PtMaterialInputs;\n\n");
    s
}

/// `PT_MATERIAL_FACTORS(v, mx)` and `PT_MATERIAL_TEXTURES(v, mx, at)`:
/// `PtMaterialExt.factor` of `mx` into `v`, then each texture row that
/// scales a factor applied, in the table's order. Macros, so that they sit
/// in `pt_types.h` beside the struct although the texture lookup they call
/// comes later (`scene_view.h`'s `pt_material_inputs` expands them).
pub fn inputs_fill_code() -> String {
    let fields = input_fields();
    let mut s = String::from(
        "// PT_MATERIAL_FACTORS(v, mx): PtMaterialInputs `v` from material `mx`'s\n\
         // factors; PT_MATERIAL_TEXTURES(v, mx, at): then each texture that\n\
         // scales a factor applied at attributes `at` (src/scene/material.rs,\n\
         // texture_slots!: the `scales` column). scene_view.h's\n\
         // pt_material_inputs expands them. A texture of a lobe not compiled\n\
         // in scales a factor no code reads, which the compiler drops.\n\
         #define PT_MATERIAL_FACTORS(v, mx)",
    );
    for f in &fields {
        let value = match f.width {
            1 => format!("(mx).factor[{}]", f.define),
            w => {
                let parts: Vec<String> = (0..w)
                    .map(|i| match i {
                        0 => format!("(mx).factor[{}]", f.define),
                        i => format!("(mx).factor[{} + {i}]", f.define),
                    })
                    .collect();
                format!("({})({})", c_type(w), parts.join(", "))
            }
        };
        let _ = write!(s, " \\\n    (v).{} = {value};", f.name);
    }
    s.push_str("\n#ifdef HAS_TEXTURES\n#define PT_MATERIAL_TEXTURES(v, mx, at)");
    for (slot, (factor, channel)) in scaling_slots() {
        let field = scaled_field(&fields, slot, factor)
            .unwrap_or_else(|| panic!("{slot:?} scales {factor}, which is not on the device"));
        let tex = crate::scene::material::define_name("TEX", &format!("{slot:?}"));
        let _ = write!(
            s,
            " \\\n    if ((mx).tex[{tex}] >= 0) \\\n        (v).{} *= pt_texture((mx).tex[{tex}], (at) TEX_PASS).{channel};",
            field.name
        );
    }
    s.push_str("\n#else\n#define PT_MATERIAL_TEXTURES(v, mx, at)\n#endif\n\n");
    s
}

/// The slots whose texture scales a factor, with the factor's key and the
/// channel.
fn scaling_slots() -> impl Iterator<Item = (Slot, (&'static str, &'static str))> {
    Slot::ALL
        .into_iter()
        .filter_map(|slot| Some((slot, slot.scales()?)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scaling_slot_names_a_device_factor_of_its_extension() {
        let fields = input_fields();
        for (slot, (factor, channel)) in scaling_slots() {
            let field = scaled_field(&fields, slot, factor);
            assert!(field.is_some(), "{slot:?}: {factor}");
            assert!(["x", "y", "z", "w", "xyz"].contains(&channel), "{slot:?}");
            let (ext, _) = slot.extension_key().unwrap();
            let field = field.unwrap();
            assert_eq!(field.source.unwrap().0, ext, "{slot:?}");
            assert_eq!(field.width, channel.len(), "{slot:?}");
        }
    }

    #[test]
    fn the_fill_applies_the_sheen_roughness_texture_by_alpha() {
        let code = inputs_fill_code();
        assert!(code.contains(
            "    if ((mx).tex[TEX_SHEEN_ROUGHNESS] >= 0) \\\n        (v).sheen_roughness *= \
             pt_texture((mx).tex[TEX_SHEEN_ROUGHNESS], (at) TEX_PASS).w;"
        ));
        assert!(code.contains("    (v).sheen_roughness = (mx).factor[F_SHEEN_ROUGHNESS];"));
        // Every line of a macro but its last continues.
        let body = code
            .split("#define PT_MATERIAL_TEXTURES(v, mx, at) \\\n")
            .nth(1)
            .unwrap();
        let lines: Vec<&str> = body.lines().take_while(|l| !l.starts_with('#')).collect();
        assert!(lines[..lines.len() - 1].iter().all(|l| l.ends_with('\\')));
        assert!(inputs_struct_code().contains("    float3 sheen_color;\n"));
    }
}
