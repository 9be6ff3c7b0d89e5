//! Which `pathtrace.cl` a scene compiles: the defines that choose kernel
//! variants (traversal, sampler, textures, and each material lobe some
//! material uses), listed once here for the host, the frame log and the
//! portability test.

use opencl3::kernel::Kernel;
use opencl3::program::Program;

use crate::bvh::MAX_DEPTH;
use crate::device::Device;
use crate::scene::{Material, MaterialTable};
use crate::trace::sampling::Sampler;
use crate::trace::settings::{Layering, RenderSettings, Traversal};
use crate::trace::TraceError;

pub(super) struct Kernels {
    pub(super) render: Kernel,
    pub(super) clear: Kernel,
    pub(super) converge: Kernel,
    pub(super) dilate: Kernel,
    pub(super) emissive_power: Kernel,
    /// `pt_emissive_texture_factor`, compiled with textures only.
    pub(super) emissive_texture_factor: Option<Kernel>,
    pub(super) compare_and_keep: Kernel,
    /// The wide layouts' leaves (`leaf_gather`, kernels/trace/leaf_gather.h).
    pub(super) leaf_gather: Kernel,
    _program: Program,
}

impl Kernels {
    pub(super) fn build(
        device: &Device,
        defines: &[(&'static str, String)],
    ) -> Result<Kernels, TraceError> {
        let program = device.build_program("pathtrace.cl", defines)?;
        Ok(Kernels {
            render: device.kernel(&program, "pt_render")?,
            clear: device.kernel(&program, "pt_clear")?,
            converge: device.kernel(&program, "pt_converge")?,
            dilate: device.kernel(&program, "pt_dilate")?,
            emissive_power: device.kernel(&program, "pt_emissive_power")?,
            emissive_texture_factor: if defines.iter().any(|(name, _)| *name == "HAS_TEXTURES") {
                Some(device.kernel(&program, "pt_emissive_texture_factor")?)
            } else {
                None
            },
            compare_and_keep: device.kernel(&program, "pt_compare_and_keep")?,
            leaf_gather: device.kernel(&program, "leaf_gather")?,
            _program: program,
        })
    }
}

/// The defines `pathtrace.cl` is compiled with, assembled here and nowhere
/// else (`tests/kernels_portable.rs` compiles every combination with clang).
pub fn pathtrace_defines(
    traversal: Traversal,
    textures: bool,
    sampler: Sampler,
    transmission: bool,
    energy_compensation: bool,
    unlit: bool,
    lobes: Lobes,
) -> Vec<(&'static str, String)> {
    let mut defines = vec![("STACK_SIZE", (MAX_DEPTH + 1).to_string())];
    match traversal {
        Traversal::Stack => {}
        Traversal::Stackless => defines.push(("TRAVERSAL_STACKLESS", "1".to_owned())),
        Traversal::Wide => defines.push(("TRAVERSAL_WIDE", "1".to_owned())),
        Traversal::Wide8 => {
            defines.push(("TRAVERSAL_WIDE", "1".to_owned()));
            defines.push(("WIDE_WIDTH", "8".to_owned()));
        }
    }
    if textures {
        defines.push(("HAS_TEXTURES", "1".to_owned()));
    }
    if let Some(define) = sampler.define() {
        defines.push((define, "1".to_owned()));
    }
    if transmission {
        defines.push(("HAS_TRANSMISSION", "1".to_owned()));
    }
    if energy_compensation {
        defines.push(("GGX_ENERGY_COMPENSATION", "1".to_owned()));
    }
    if unlit {
        defines.push(("HAS_UNLIT", "1".to_owned()));
    }
    defines.extend(lobes.iter().map(|lobe| (lobe.define, "1".to_owned())));
    defines
}

/// `base` (from `pathtrace_defines`) with the layering's define:
/// `ENERGY_LAYERING` for `Layering::Energy`, none for the specification's.
pub fn layering_defines(
    mut base: Vec<(&'static str, String)>,
    layering: Layering,
) -> Vec<(&'static str, String)> {
    if layering == Layering::Energy {
        base.push(("ENERGY_LAYERING", "1".to_owned()));
    }
    base
}

/// A lobe of the BSDF compiled into the path tracer only where some
/// material has it: one row of [`LOBES`]. A new lobe is a new row; the
/// host's defines, the frame log's features
/// and the portability test's variants all read this table.
pub struct Lobe {
    /// The define `bsdf.h` tests.
    pub define: &'static str,
    /// Its name in the frame log's `features`.
    pub name: &'static str,
    /// Whether a material has it.
    pub used_by: fn(&Material) -> bool,
    /// Its code builds on the dielectric extensions: `bsdf.h` compiles
    /// `HAS_TRANSMISSION` with it, and a material that has it needs them.
    pub with_transmission: bool,
}

/// The optional lobes, in the order their defines are passed: the layers
/// over the BSDF (clear coat, sheen), the diffuse transmission under it, the
/// thin film on its Fresnel, the anisotropic specular lobes, the
/// per-channel indices of dispersive volumes and the rough diffuse lobe.
pub const LOBES: [Lobe; 7] = [
    Lobe {
        define: "HAS_CLEARCOAT",
        name: "clearcoat",
        used_by: Material::has_clearcoat,
        with_transmission: false,
    },
    Lobe {
        define: "HAS_SHEEN",
        name: "sheen",
        used_by: Material::has_sheen,
        with_transmission: false,
    },
    Lobe {
        define: "HAS_DIFFUSE_TRANSMISSION",
        name: "diffuse_transmission",
        used_by: Material::has_diffuse_transmission,
        with_transmission: true,
    },
    Lobe {
        define: "HAS_IRIDESCENCE",
        name: "iridescence",
        used_by: Material::has_iridescence,
        with_transmission: true,
    },
    Lobe {
        define: "HAS_ANISOTROPY",
        name: "anisotropy",
        used_by: Material::has_anisotropy,
        with_transmission: true,
    },
    Lobe {
        define: "HAS_DISPERSION",
        name: "dispersion",
        used_by: Material::has_dispersion,
        with_transmission: true,
    },
    Lobe {
        define: "HAS_DIFFUSE_ROUGHNESS",
        name: "diffuse_roughness",
        used_by: Material::has_diffuse_roughness,
        with_transmission: true,
    },
];

/// A set of [`LOBES`], by index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Lobes(u32);

impl Lobes {
    /// No optional lobe.
    pub const NONE: Lobes = Lobes(0);
    /// Every optional lobe.
    pub const ALL: Lobes = Lobes((1 << LOBES.len()) - 1);

    /// The lobe `LOBES[index]` alone.
    pub fn only(index: usize) -> Lobes {
        Lobes(1 << index)
    }

    /// The lobes some material of `table` has.
    pub fn of(table: &MaterialTable) -> Lobes {
        let mut set = 0;
        for (i, lobe) in LOBES.iter().enumerate() {
            if table.materials.iter().any(|m| (lobe.used_by)(m)) {
                set |= 1 << i;
            }
        }
        Lobes(set)
    }

    /// The lobes of the set, in `LOBES` order.
    pub fn iter(self) -> impl Iterator<Item = &'static Lobe> {
        LOBES
            .iter()
            .enumerate()
            .filter(move |(i, _)| self.0 & (1 << i) != 0)
            .map(|(_, lobe)| lobe)
    }

    /// Whether the set holds the lobe named `name`.
    pub fn has(self, name: &str) -> bool {
        self.iter().any(|lobe| lobe.name == name)
    }

    /// Whether any lobe of the set builds on the dielectric extensions.
    pub fn with_transmission(self) -> bool {
        self.iter().any(|lobe| lobe.with_transmission)
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// The lobes `LOBES[i]` for each index `i`.
impl FromIterator<usize> for Lobes {
    fn from_iter<I: IntoIterator<Item = usize>>(indices: I) -> Lobes {
        Lobes(indices.into_iter().fold(0, |set, i| set | 1 << i))
    }
}

/// The (object, material) pairs kept per pixel for `--aov object_id`
/// alone (without `--cryptomatte`).
pub const OBJECT_ID_SLOTS: u32 = 4;

/// The camera's and the film's options that change the program: each is
/// compiled in only when asked for, so without them the program, and so
/// the image, is that of a build without these features. Decided once per
/// tracer (`PathTracer::film`): which buffers a frame binds follows it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FilmFeatures {
    /// `HAS_DOF`: the camera has a lens (only then does a camera sample
    /// draw a lens point).
    pub lens: bool,
    /// `FILM_TRANSPARENT`: `--transparent`.
    pub transparent: bool,
    /// `FILM_MATTES` with `MATTE_SLOTS` slots per pixel: `--cryptomatte`.
    pub matte_slots: Option<u32>,
    /// `FILM_VECTORS`: `--aov motion`.
    pub vectors: bool,
    /// `FILM_CATCHER`: some node is a shadow catcher or a holdout.
    pub catcher: bool,
    /// `FILM_GEOMETRY`: `--aov position` or `uv`.
    pub geometry: bool,
    /// `FILM_LIGHT`: light-path passes (`--passes`).
    pub light: bool,
}

impl FilmFeatures {
    /// The options `settings` asks for.
    pub fn of(settings: &RenderSettings) -> FilmFeatures {
        FilmFeatures {
            lens: settings.lens.is_some(),
            transparent: settings.transparent,
            // The object id is the pair most of a pixel's samples hit.
            matte_slots: match (&settings.cryptomatte, settings.aovs.object_id) {
                (Some(c), _) => Some(c.slots()),
                (None, true) => Some(OBJECT_ID_SLOTS),
                (None, false) => None,
            },
            vectors: settings.aovs.motion,
            catcher: !settings.roles.is_empty(),
            geometry: settings.aovs.position || settings.aovs.uv,
            light: settings.aovs.light(),
        }
    }
}

/// `base` with the defines of `film`'s options.
pub fn film_defines(
    mut base: Vec<(&'static str, String)>,
    film: &FilmFeatures,
) -> Vec<(&'static str, String)> {
    if film.lens {
        base.push(("HAS_DOF", "1".to_owned()));
    }
    if film.transparent {
        base.push(("FILM_TRANSPARENT", "1".to_owned()));
    }
    if let Some(slots) = film.matte_slots {
        base.push(("FILM_MATTES", "1".to_owned()));
        base.push(("MATTE_SLOTS", slots.to_string()));
    }
    if film.vectors {
        base.push(("FILM_VECTORS", "1".to_owned()));
    }
    if film.catcher {
        base.push(("FILM_CATCHER", "1".to_owned()));
    }
    if film.geometry {
        base.push(("FILM_GEOMETRY", "1".to_owned()));
    }
    if film.light {
        base.push(("FILM_LIGHT", "1".to_owned()));
    }
    base
}

/// The defines of `pathtrace.cl`'s motion-blur variant: `base` (from
/// `pathtrace_defines`) and `MOTION_BLUR`.
pub fn motion_defines(mut base: Vec<(&'static str, String)>) -> Vec<(&'static str, String)> {
    base.push(("MOTION_BLUR", "1".to_owned()));
    base
}

/// The material features a table compiles into the path tracer, by define
/// name (for the frame log): only what some material uses.
pub fn material_features(
    table: &MaterialTable,
    textures: bool,
    energy_compensation: bool,
    layering: Layering,
) -> Vec<&'static str> {
    let mut v = vec!["metallic_roughness"];
    if energy_compensation {
        v.push("energy_compensation");
    }
    if layering == Layering::Energy {
        v.push("energy_layering");
    }
    if textures {
        v.push("textures");
    }
    if table.materials.iter().any(|m| m.needs_transmission()) {
        v.push("transmission");
    }
    if table.materials.iter().any(|m| m.unlit) {
        v.push("unlit");
    }
    v.extend(Lobes::of(table).iter().map(|lobe| lobe.name));
    v
}
