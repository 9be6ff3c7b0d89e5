//! Every number and texture a glTF material sets, one row each: where it
//! stands in the file, which `Material` field holds it, and the range the
//! specification allows. The loader, the range checks, the animation
//! pointers, the texture bindings and `soupray info` all read these two
//! tables, so a new material parameter is a field in `Material` and a row
//! here, not an edit in each of them.

use super::material::{Material, TextureRef};

/// Declares [`Slot`] from one row per texture use: the variant, the
/// `Material` field, the path below `/materials/N/` in the file, the name
/// messages give it, whether its RGB is sRGB-encoded, and for an
/// extension's texture the kernel define under which it is read.
macro_rules! texture_slots {
    (@feature) => { None };
    (@feature $feature:literal) => { Some($feature) };
    ($($(#[$doc:meta])* $variant:ident: $field:ident at $path:literal as $name:literal, $srgb:literal $(, $feature:literal)?;)*) => {
        /// A texture use of a material.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Slot {
            $($(#[$doc])* $variant,)*
        }

        impl Slot {
            pub const COUNT: usize = [$($name),*].len();
            /// Every slot, core first, in the order of this table.
            pub const ALL: [Slot; Slot::COUNT] = [$(Slot::$variant),*];

            /// The texture info's path below `/materials/N/` (what an
            /// animation pointer names).
            pub fn path(self) -> &'static str {
                match self {
                    $(Slot::$variant => $path,)*
                }
            }

            /// The glTF property name, for messages.
            pub fn name(self) -> &'static str {
                match self {
                    $(Slot::$variant => $name,)*
                }
            }

            /// Whether the glTF specification says the slot's RGB is
            /// sRGB-encoded.
            pub fn is_srgb(self) -> bool {
                match self {
                    $(Slot::$variant => $srgb,)*
                }
            }

            /// The kernel define that compiles the code reading an
            /// extension's texture (`PtMaterialExt.tex`); `None` for the
            /// core textures (`PtMaterial`).
            pub const fn feature(self) -> Option<&'static str> {
                match self {
                    $(Slot::$variant => texture_slots!(@feature $($feature)?),)*
                }
            }

            pub fn of(self, m: &Material) -> Option<&TextureRef> {
                match self {
                    $(Slot::$variant => m.$field.as_ref(),)*
                }
            }

            pub fn of_mut(self, m: &mut Material) -> &mut Option<TextureRef> {
                match self {
                    $(Slot::$variant => &mut m.$field,)*
                }
            }
        }

        impl Material {
            /// Every texture use of the material, core and extensions alike.
            pub fn texture_refs_mut(&mut self) -> [&mut Option<TextureRef>; Slot::COUNT] {
                [$(&mut self.$field),*]
            }
        }
    };
}

texture_slots! {
    BaseColor: base_color_texture
        at "pbrMetallicRoughness/baseColorTexture" as "baseColorTexture", true;
    MetallicRoughness: metallic_roughness_texture
        at "pbrMetallicRoughness/metallicRoughnessTexture" as "metallicRoughnessTexture", false;
    Normal: normal_texture at "normalTexture" as "normalTexture", false;
    Occlusion: occlusion_texture at "occlusionTexture" as "occlusionTexture", false;
    Emissive: emissive_texture at "emissiveTexture" as "emissiveTexture", true;
    /// R scales the transmission factor.
    Transmission: transmission_texture
        at "extensions/KHR_materials_transmission/transmissionTexture"
        as "KHR_materials_transmission transmissionTexture", false, "HAS_TRANSMISSION";
    /// A scales the specular factor.
    Specular: specular_texture
        at "extensions/KHR_materials_specular/specularTexture"
        as "KHR_materials_specular specularTexture", false, "HAS_TRANSMISSION";
    /// RGB scales the specular colour.
    SpecularColor: specular_color_texture
        at "extensions/KHR_materials_specular/specularColorTexture"
        as "KHR_materials_specular specularColorTexture", true, "HAS_TRANSMISSION";
    /// R scales the clear coat factor.
    Clearcoat: clearcoat_texture
        at "extensions/KHR_materials_clearcoat/clearcoatTexture"
        as "KHR_materials_clearcoat clearcoatTexture", false, "HAS_CLEARCOAT";
    /// G scales the clear coat's roughness.
    ClearcoatRoughness: clearcoat_roughness_texture
        at "extensions/KHR_materials_clearcoat/clearcoatRoughnessTexture"
        as "KHR_materials_clearcoat clearcoatRoughnessTexture", false, "HAS_CLEARCOAT";
    /// The coat's own normal map.
    ClearcoatNormal: clearcoat_normal_texture
        at "extensions/KHR_materials_clearcoat/clearcoatNormalTexture"
        as "KHR_materials_clearcoat clearcoatNormalTexture", false, "HAS_CLEARCOAT";
    /// RGB scales the sheen colour.
    SheenColor: sheen_color_texture
        at "extensions/KHR_materials_sheen/sheenColorTexture"
        as "KHR_materials_sheen sheenColorTexture", true, "HAS_SHEEN";
    /// A scales the sheen roughness.
    SheenRoughness: sheen_roughness_texture
        at "extensions/KHR_materials_sheen/sheenRoughnessTexture"
        as "KHR_materials_sheen sheenRoughnessTexture", false, "HAS_SHEEN";
    /// A scales the diffuse transmission factor.
    DiffuseTransmission: diffuse_transmission_texture
        at "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionTexture"
        as "KHR_materials_diffuse_transmission diffuseTransmissionTexture", false, "HAS_DIFFUSE_TRANSMISSION";
    /// RGB scales the diffuse transmission colour.
    DiffuseTransmissionColor: diffuse_transmission_color_texture
        at "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionColorTexture"
        as "KHR_materials_diffuse_transmission diffuseTransmissionColorTexture", true, "HAS_DIFFUSE_TRANSMISSION";
    /// R scales the iridescence factor.
    Iridescence: iridescence_texture
        at "extensions/KHR_materials_iridescence/iridescenceTexture"
        as "KHR_materials_iridescence iridescenceTexture", false, "HAS_IRIDESCENCE";
    /// G picks the film's thickness between its minimum and maximum.
    IridescenceThickness: iridescence_thickness_texture
        at "extensions/KHR_materials_iridescence/iridescenceThicknessTexture"
        as "KHR_materials_iridescence iridescenceThicknessTexture", false, "HAS_IRIDESCENCE";
    /// RG: the direction in tangent space; B scales the strength.
    Anisotropy: anisotropy_texture
        at "extensions/KHR_materials_anisotropy/anisotropyTexture"
        as "KHR_materials_anisotropy anisotropyTexture", false, "HAS_ANISOTROPY";
}

impl Slot {
    /// The extension whose object holds the texture info, and the info's
    /// key in it; `None` for the core textures.
    pub fn extension_key(self) -> Option<(&'static str, &'static str)> {
        self.path().strip_prefix("extensions/")?.split_once('/')
    }
}

/// Where a factor's value lives in `Material`.
#[derive(Clone, Copy)]
pub enum FactorField {
    Scalar(fn(&mut Material) -> &mut f32),
    Rgb(fn(&mut Material) -> &mut [f32; 3]),
    Rgba(fn(&mut Material) -> &mut [f32; 4]),
}

/// A number (or colour) a material sets.
#[derive(Clone, Copy)]
pub struct Factor {
    /// The property's path below `/materials/N/`.
    pub path: &'static str,
    pub field: FactorField,
    /// The range the specification allows, each component clamped into it
    /// with a warning (NaN: the default). `None`: checked by hand in
    /// `ranges`, or unbounded.
    pub range: Option<(f32, f32)>,
    /// Whether the kernels read it as it is, from `PtMaterialExt.factor`
    /// (the core factors are in `PtMaterial`; the rest reach the device
    /// derived, as the volume's attenuation coefficient).
    pub on_device: bool,
}

impl Factor {
    /// Floats in the value.
    pub const fn width(&self) -> usize {
        match self.field {
            FactorField::Scalar(_) => 1,
            FactorField::Rgb(_) => 3,
            FactorField::Rgba(_) => 4,
        }
    }

    /// The value's components in `m`.
    pub fn components<'m>(&self, m: &'m mut Material) -> &'m mut [f32] {
        match self.field {
            FactorField::Scalar(f) => std::slice::from_mut(f(m)),
            FactorField::Rgb(f) => f(m),
            FactorField::Rgba(f) => f(m),
        }
    }

    /// The extension that sets it, and the key path inside the
    /// extension's object; `None` for core factors.
    pub fn extension_key(&self) -> Option<(&'static str, &'static str)> {
        self.path.strip_prefix("extensions/")?.split_once('/')
    }

    /// The property as messages name it: `KHR_materials_sheen
    /// sheenRoughnessFactor`, `occlusionTexture.strength`.
    pub fn name(&self) -> String {
        match self.extension_key() {
            Some((ext, key)) => format!("{ext} {}", key.replace('/', ".")),
            None => self
                .path
                .trim_start_matches("pbrMetallicRoughness/")
                .replace('/', "."),
        }
    }
}

const UNIT: Option<(f32, f32)> = Some((0.0, 1.0));
const NON_NEGATIVE: Option<(f32, f32)> = Some((0.0, f32::MAX));

/// Every factor a material sets, core and extensions. The specification's
/// defaults are `Material::default()`'s.
pub const FACTORS: &[Factor] = &[
    Factor {
        path: "pbrMetallicRoughness/baseColorFactor",
        field: FactorField::Rgba(|m| &mut m.base_color_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "pbrMetallicRoughness/metallicFactor",
        field: FactorField::Scalar(|m| &mut m.metallic_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "pbrMetallicRoughness/roughnessFactor",
        field: FactorField::Scalar(|m| &mut m.roughness_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "emissiveFactor",
        field: FactorField::Rgb(|m| &mut m.emissive_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "alphaCutoff",
        field: FactorField::Scalar(|m| &mut m.alpha_cutoff),
        range: NON_NEGATIVE,
        on_device: false,
    },
    // Any finite scale is allowed; `ranges` replaces an infinite one.
    Factor {
        path: "normalTexture/scale",
        field: FactorField::Scalar(|m| &mut m.normal_scale),
        range: None,
        on_device: false,
    },
    Factor {
        path: "occlusionTexture/strength",
        field: FactorField::Scalar(|m| &mut m.occlusion_strength),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_emissive_strength/emissiveStrength",
        field: FactorField::Scalar(|m| &mut m.emissive_strength),
        range: NON_NEGATIVE,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_transmission/transmissionFactor",
        field: FactorField::Scalar(|m| &mut m.transmission_factor),
        range: UNIT,
        on_device: true,
    },
    // 1 or more, or 0 for an infinite index, which `ranges` maps first.
    Factor {
        path: "extensions/KHR_materials_ior/ior",
        field: FactorField::Scalar(|m| &mut m.ior),
        range: Some((1.0, f32::MAX)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_volume/thicknessFactor",
        field: FactorField::Scalar(|m| &mut m.thickness_factor),
        range: NON_NEGATIVE,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_volume/attenuationColor",
        field: FactorField::Rgb(|m| &mut m.attenuation_color),
        range: UNIT,
        on_device: false,
    },
    // Above 0, or infinite: checked last in `ranges`.
    Factor {
        path: "extensions/KHR_materials_volume/attenuationDistance",
        field: FactorField::Scalar(|m| &mut m.attenuation_distance),
        range: None,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_specular/specularFactor",
        field: FactorField::Scalar(|m| &mut m.specular_factor),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_specular/specularColorFactor",
        field: FactorField::Rgb(|m| &mut m.specular_color),
        range: NON_NEGATIVE,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatFactor",
        field: FactorField::Scalar(|m| &mut m.clearcoat_factor),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatRoughnessFactor",
        field: FactorField::Scalar(|m| &mut m.clearcoat_roughness),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatNormalTexture/scale",
        field: FactorField::Scalar(|m| &mut m.clearcoat_normal_scale),
        range: None,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_sheen/sheenColorFactor",
        field: FactorField::Rgb(|m| &mut m.sheen_color),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_sheen/sheenRoughnessFactor",
        field: FactorField::Scalar(|m| &mut m.sheen_roughness),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionFactor",
        field: FactorField::Scalar(|m| &mut m.diffuse_transmission),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionColorFactor",
        field: FactorField::Rgb(|m| &mut m.diffuse_transmission_color),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceFactor",
        field: FactorField::Scalar(|m| &mut m.iridescence),
        range: UNIT,
        on_device: true,
    },
    // Real films have indices of 1 to about 4; the bound keeps the film's
    // optical path (index times thickness) finite.
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceIor",
        field: FactorField::Scalar(|m| &mut m.iridescence_ior),
        range: Some((1.0, 100.0)),
        on_device: true,
    },
    // Films are nanometres thick: anything above 100 µm is a mistake, and
    // the interference terms vanish long before.
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceThicknessMinimum",
        field: FactorField::Scalar(|m| &mut m.iridescence_thickness_min),
        range: Some((0.0, 1.0e5)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceThicknessMaximum",
        field: FactorField::Scalar(|m| &mut m.iridescence_thickness_max),
        range: Some((0.0, 1.0e5)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_anisotropy/anisotropyStrength",
        field: FactorField::Scalar(|m| &mut m.anisotropy_strength),
        range: UNIT,
        on_device: true,
    },
    // A turn is 2 pi; beyond 1e4 radians an f32 angle is coarser than a
    // thousandth of a radian, and an infinite one has no cosine.
    Factor {
        path: "extensions/KHR_materials_anisotropy/anisotropyRotation",
        field: FactorField::Scalar(|m| &mut m.anisotropy_rotation),
        range: Some((-1.0e4, 1.0e4)),
        on_device: false,
    },
    // 1 is an Abbe number of 20, about the lowest of real materials; the
    // extension allows more to exaggerate, and 20 (Abbe number 1) is far
    // beyond any material.
    Factor {
        path: "extensions/KHR_materials_dispersion/dispersion",
        field: FactorField::Scalar(|m| &mut m.dispersion),
        range: Some((0.0, 20.0)),
        on_device: true,
    },
];

/// Floats in `PtMaterialExt.factor`: the factors the kernels read as
/// they are, in the table's order.
pub const DEVICE_FACTOR_FLOATS: usize = {
    let (mut i, mut n) = (0, 0);
    while i < FACTORS.len() {
        if FACTORS[i].on_device {
            n += FACTORS[i].width();
        }
        i += 1;
    }
    n
};

/// The factors the kernels read, each with its first float's index in
/// `PtMaterialExt.factor` and its define's name (`F_SHEEN_ROUGHNESS` for
/// `sheenRoughnessFactor`).
pub fn device_factors() -> impl Iterator<Item = (usize, String, &'static Factor)> {
    FACTORS.iter().filter(|f| f.on_device).scan(0, |at, f| {
        let first = *at;
        *at += f.width();
        let key = f.extension_key().map_or(f.path, |(_, key)| key);
        let key = key.strip_suffix("Factor").unwrap_or(key);
        let mut name = String::from("F_");
        for c in key.chars() {
            match c {
                '/' => name.push('_'),
                c if c.is_ascii_uppercase() => {
                    name.push('_');
                    name.push(c);
                }
                c => name.push(c.to_ascii_uppercase()),
            }
        }
        Some((first, name, f))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_slot_names_its_extension_and_key() {
        for slot in Slot::ALL {
            match slot.extension_key() {
                Some((ext, key)) => assert_eq!(slot.name(), format!("{ext} {key}")),
                None => assert!(slot.path().ends_with(slot.name()), "{slot:?}"),
            }
        }
    }

    #[test]
    fn factor_paths_are_unique() {
        for (i, a) in FACTORS.iter().enumerate() {
            assert!(
                FACTORS[i + 1..].iter().all(|b| b.path != a.path),
                "{}",
                a.path
            );
        }
    }

    #[test]
    fn factor_names_match_the_messages() {
        let name = |p: &str| FACTORS.iter().find(|f| f.path == p).unwrap().name();
        assert_eq!(
            name("pbrMetallicRoughness/baseColorFactor"),
            "baseColorFactor"
        );
        assert_eq!(
            name("occlusionTexture/strength"),
            "occlusionTexture.strength"
        );
        assert_eq!(
            name("extensions/KHR_materials_sheen/sheenRoughnessFactor"),
            "KHR_materials_sheen sheenRoughnessFactor"
        );
    }
}
