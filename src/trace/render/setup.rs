//! What a path tracer is made with, checked and uploaded once per scene
//! (`PathTracer::with_animated_materials`): the settings it refuses, the
//! device materials and their texture slots, the textures and the
//! environment map.

use opencl3::memory::Buffer;

use super::upload::{bind_textures, upload_env_map, EnvBuffers};
use super::{usage, Environment, Lobes, RenderSettings};
use crate::device::Device;
use crate::scene::MaterialTable;
use crate::trace::lights::EnvMap;
use crate::trace::material::{
    device_materials, DeviceMaterial, DeviceMaterialExt, MAT_CULL_BACK, MAT_DOUBLE_SIDED,
};
use crate::trace::texture::{Slot, TextureBinding, TextureSet};
use crate::trace::TraceError;

/// The render settings the tracer cannot work with are refused up front.
pub(super) fn check_settings(settings: &RenderSettings) -> Result<(), TraceError> {
    if settings.width == 0
        || settings.height == 0
        || settings.width > 65536
        || settings.height > 65536
    {
        return Err(usage(format!(
            "render size {}x{}: both sides must be 1 to 65536 pixels (--width, --height)",
            settings.width, settings.height
        )));
    }
    if settings.spp == 0 {
        return Err(usage(
            "--spp 0: at least one sample per pixel is needed".into(),
        ));
    }
    Ok(())
}

/// The textures the compiled `slots` sample, and their bindings: only
/// when some material samples one (and not in clay mode, where only alpha
/// cut-outs would need them: those are kept). A texture set that cannot
/// be made leaves the materials to their factors, with a warning.
pub(super) fn upload_textures<'d>(
    device: &'d Device,
    table: &MaterialTable,
    slots: &[Slot],
    host_materials: &mut [DeviceMaterial],
    host_exts: Option<&mut [DeviceMaterialExt]>,
    warnings: &mut Vec<String>,
) -> Result<Option<(TextureSet<'d>, Buffer<TextureBinding>)>, TraceError> {
    let mut textures = None;
    let textured = table
        .materials
        .iter()
        .any(|m| slots.iter().any(|s| s.of(m).is_some()));
    if textured {
        match TextureSet::with_slots(device, table, slots) {
            Ok(set) if !set.is_empty() => {
                // Four bindings per material (`PtMaterial`), then
                // `Slot::EXT.len()` per material for `PtMaterialExt` when compiled in
                // (those of slots outside `slots` stay -1).
                let bindings = bind_textures(&set, &table.materials, host_materials, host_exts);
                let mut buf = device.buffer::<TextureBinding>(bindings.len())?;
                device.write(&mut buf, &bindings)?;
                textures = Some((set, buf));
            }
            Ok(_) => {}
            Err(e) => warnings.push(format!(
                "textures are not used ({e}); materials are rendered with their factors only"
            )),
        }
    }
    Ok(textures)
}

/// The environment map `settings` asks for, uploaded; a constant colour
/// must be a radiance.
pub(super) fn environment_map(
    device: &Device,
    settings: &RenderSettings,
) -> Result<Option<EnvBuffers>, TraceError> {
    Ok(match &settings.environment {
        Environment::Map(path) => Some(upload_env_map(device, &EnvMap::load(path)?)?),
        Environment::Color(c) => {
            if !c.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(usage(format!(
                    "--env-color {c:?}: the radiance must be three finite, non-negative numbers"
                )));
            }
            None
        }
        Environment::Default => None,
    })
}

/// The table's materials as the kernels read them; with
/// `--backface-culling`, single-sided ones are culled from behind.
pub(super) fn host_materials(
    table: &MaterialTable,
    settings: &RenderSettings,
) -> Vec<DeviceMaterial> {
    let mut host_materials = device_materials(table);
    if settings.backface_culling {
        for m in &mut host_materials {
            if m.flags & MAT_DOUBLE_SIDED == 0 {
                m.flags |= MAT_CULL_BACK;
            }
        }
    }
    host_materials
}

/// The texture slots the kernels read: the extensions' only where their
/// code is compiled in.
pub(super) fn texture_slots(transmission: bool, lobes: &Lobes) -> Vec<Slot> {
    let mut slots: Vec<Slot> = Slot::BASE.to_vec();
    if transmission {
        slots.extend(Slot::read_under("HAS_TRANSMISSION"));
    }
    for lobe in lobes.iter() {
        slots.extend(Slot::read_under(lobe.define));
    }
    slots
}

/// The material table and, when compiled in, the extensions' table, on
/// the device.
pub(super) fn upload_materials(
    device: &Device,
    host_materials: &[DeviceMaterial],
    host_exts: Option<Vec<DeviceMaterialExt>>,
) -> Result<(Buffer<DeviceMaterial>, Option<Buffer<DeviceMaterialExt>>), TraceError> {
    let mut materials = device.buffer::<DeviceMaterial>(host_materials.len())?;
    device.write(&mut materials, host_materials)?;
    let material_exts = match host_exts {
        Some(exts) => {
            let mut buf = device.buffer::<DeviceMaterialExt>(exts.len())?;
            device.write(&mut buf, &exts)?;
            Some(buf)
        }
        None => None,
    };
    Ok((materials, material_exts))
}
