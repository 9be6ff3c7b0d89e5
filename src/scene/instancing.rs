//! EXT_mesh_gpu_instancing: a node that draws its mesh many times, once per
//! element of its `TRANSLATION`, `ROTATION` and `SCALE` accessors. soupray
//! traces a flat soup, so each instance becomes a mesh instance of its own
//! (the mesh's vertex data is still stored once on the device, as for a mesh
//! that several nodes share), placed at `world_from_node * node_from_instance`
//! every frame: the instances follow the node's animation.

use glam::{Mat4, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;

use super::accessor::Reader;
use super::error::{Result, SceneError};

pub(crate) const EXT_MESH_GPU_INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// The `node_from_instance` transforms of `node`, or `None` when the node has
/// no EXT_mesh_gpu_instancing. `label` names the node in messages.
pub(super) fn node_instances(
    reader: &Reader,
    json: &Value,
    node: usize,
    label: &str,
) -> Result<Option<Vec<Mat4>>> {
    let Some(ext) = json
        .get("nodes")
        .and_then(|n| n.get(node))
        .and_then(|n| n.get("extensions"))
        .and_then(|e| e.get(EXT_MESH_GPU_INSTANCING))
    else {
        return Ok(None);
    };
    let file = &reader.src.file;
    let invalid = |detail: String| {
        SceneError::invalid(file, format!("{label}: {EXT_MESH_GPU_INSTANCING} {detail}"))
    };
    let Some(attributes) = ext.get("attributes").and_then(Value::as_object) else {
        return Err(invalid(
            "has no \"attributes\" object. Fix: re-export the scene.".into(),
        ));
    };
    let doc = &reader.src.document;
    let accessor = |name: &str| -> Result<Option<gltf::Accessor>> {
        let Some(v) = attributes.get(name) else {
            return Ok(None);
        };
        let index = v.as_u64().map(|i| i as usize);
        match index.and_then(|i| doc.accessors().nth(i)) {
            Some(a) => Ok(Some(a)),
            None => Err(invalid(format!(
                "attribute {name} names accessor {v}, which the file does not have ({} accessors). Fix: re-export the scene.",
                doc.accessors().count()
            ))),
        }
    };
    let translation = accessor("TRANSLATION")?;
    let rotation = accessor("ROTATION")?;
    let scale = accessor("SCALE")?;
    let present: Vec<&gltf::Accessor> = [&translation, &rotation, &scale]
        .into_iter()
        .flatten()
        .collect();
    let Some(first) = present.first() else {
        // The extension allows custom attributes only (`_ID` and such):
        // every instance then sits at the node, which is one instance.
        return Ok(Some(vec![Mat4::IDENTITY]));
    };
    let count = first.count();
    if let Some(other) = present.iter().find(|a| a.count() != count) {
        return Err(invalid(format!(
            "attributes have different counts ({count} and {}); every attribute has one element per instance. \
             Fix: re-export the scene.",
            other.count()
        )));
    }
    let usage = |name: &str| format!("{EXT_MESH_GPU_INSTANCING} {name} of {label}");
    let vec3s = |acc: &Option<gltf::Accessor>, name: &str| -> Result<Option<Vec<Vec3>>> {
        let Some(acc) = acc else { return Ok(None) };
        reader.expect(acc, &usage(name), &[Dimensions::Vec3], &[DataType::F32])?;
        Ok(Some(reader.vec3s(acc, &usage(name), true)?))
    };
    let translations = vec3s(&translation, "TRANSLATION")?;
    let scales = vec3s(&scale, "SCALE")?;
    let rotations = match &rotation {
        Some(acc) => {
            // The extension allows the normalized integer types that
            // KHR_mesh_quantization allows for rotations.
            reader.expect(
                acc,
                &usage("ROTATION"),
                &[Dimensions::Vec4],
                &[DataType::F32, DataType::I8, DataType::I16],
            )?;
            if acc.data_type() != DataType::F32 && !acc.normalized() {
                return Err(reader.error(
                    acc,
                    &usage("ROTATION"),
                    "holds integers that are not normalized; rotations must be float or normalized BYTE/SHORT. \
                     Fix: re-export the scene.",
                ));
            }
            let flat = reader.finite_floats(acc, &usage("ROTATION"))?;
            let quats: Vec<Quat> = flat
                .chunks_exact(4)
                .map(|q| Quat::from_xyzw(q[0], q[1], q[2], q[3]))
                .collect();
            if let Some(bad) = quats.iter().position(|q| q.length_squared() < 1e-12) {
                return Err(reader.error(
                    acc,
                    &usage("ROTATION"),
                    format!("element {bad} is a zero quaternion, which is no rotation. Fix: re-export the scene."),
                ));
            }
            // Unit quaternions by the spec; normalising forgives
            // quantization and exporters' rounding.
            Some(quats.into_iter().map(Quat::normalize).collect::<Vec<_>>())
        }
        None => None,
    };
    Ok(Some(
        (0..count)
            .map(|i| {
                Mat4::from_scale_rotation_translation(
                    scales.as_ref().map_or(Vec3::ONE, |s| s[i]),
                    rotations.as_ref().map_or(Quat::IDENTITY, |r| r[i]),
                    translations.as_ref().map_or(Vec3::ZERO, |t| t[i]),
                )
            })
            .collect(),
    ))
}
