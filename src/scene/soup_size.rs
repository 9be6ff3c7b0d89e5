//! How big a scene's soup gets, checked before anything is allocated for
//! it. Instancing (several nodes sharing a mesh, or EXT_mesh_gpu_instancing)
//! lets a small file ask for a soup of any size, so the count of triangles
//! it expands to is bounded at load, against what the soup's indices can
//! address and against this machine's memory.

use super::error::{Result, SceneError};
use super::mesh::Mesh;
use super::{triangle_count, MeshInstance};

/// The most triangles a soup may have: the device kernels address soup
/// corners (three per triangle) with 32-bit indices.
pub const MAX_SOUP_TRIANGLES: usize = (u32::MAX / 3) as usize;

/// Bytes per triangle of the host soup with every attribute: three corners
/// of position, normal and colour (16 bytes each), two uv sets (8 bytes
/// each), and the material id.
pub const SOUP_BYTES_PER_TRIANGLE: u64 = 3 * (16 + 16 + 16 + 8 + 8) + 4;

/// Bytes per triangle a frame holds at its peak, soup included: the
/// device's deformed soup, the builder's references and bins, the BVH and
/// its wide layout, and the tracer's copies of the corner attributes.
/// Measured as the peak resident memory of a 20M-triangle instanced scene
/// with positions and normals on PoCL: 373 bytes per triangle
/// (BENCHMARKS.md, "Memory"); the bound adds the uv sets and colours
/// (96 bytes a triangle, held twice) and rounds up.
pub const FRAME_BYTES_PER_TRIANGLE: u64 = 640;

/// Physical memory of this machine, when the system says.
pub fn physical_memory_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// "1.5 GiB" for messages and logs.
pub fn human_bytes(bytes: u64) -> String {
    const GIB: f64 = (1u64 << 30) as f64;
    const MIB: f64 = (1u64 << 20) as f64;
    let b = bytes as f64;
    if b >= GIB {
        format!("{:.1} GiB", b / GIB)
    } else {
        format!("{:.1} MiB", b / MIB)
    }
}

/// Refuses a scene whose soup cannot exist: more triangles than the soup
/// can index, or a soup larger than this machine's memory.
pub(super) fn check_scene_fits(
    file: &str,
    instances: &[MeshInstance],
    meshes: &[Mesh],
) -> Result<()> {
    let triangles = triangle_count(instances, meshes);
    let need = triangles as u64 * SOUP_BYTES_PER_TRIANGLE;
    let refuse = |limit: String| {
        Err(SceneError::invalid(
            file,
            format!(
                "its {} mesh instance(s) expand to a soup of {triangles} triangles, which would need about {} \
                 of memory for the soup alone; {limit}. Fix: render fewer instances (a lower \
                 EXT_mesh_gpu_instancing count or fewer nodes sharing a mesh), or a simplified mesh.",
                instances.len(),
                human_bytes(need)
            ),
        ))
    };
    if triangles > MAX_SOUP_TRIANGLES {
        return refuse(format!(
            "soupray's soup holds at most {MAX_SOUP_TRIANGLES} triangles"
        ));
    }
    if let Some(physical) = physical_memory_bytes() {
        if need > physical {
            return refuse(format!("this machine has {}", human_bytes(physical)));
        }
    }
    Ok(())
}

/// Refuses, before a frame is rendered, a scene whose frames need more
/// memory than this machine or the device has, at
/// [`FRAME_BYTES_PER_TRIANGLE`]. The message names the triangle count and
/// the memory a frame would need.
pub fn check_frame_fits(
    triangles: usize,
    device_memory: Option<u64>,
) -> std::result::Result<(), String> {
    let need = triangles as u64 * FRAME_BYTES_PER_TRIANGLE;
    let limits = [
        physical_memory_bytes().map(|b| (b, "this machine has")),
        device_memory
            .filter(|&b| b > 0)
            .map(|b| (b, "the OpenCL device has")),
    ];
    match limits.into_iter().flatten().min_by_key(|l| l.0) {
        Some((limit, whose)) if need > limit => Err(format!(
            "the scene's soup has {triangles} triangles; a frame of it needs about {} of memory \
             (soup, BVH and tracer buffers), but {whose} {}. Fix: render fewer instances or a \
             simplified mesh, or use a machine or device with more memory.",
            human_bytes(need),
            human_bytes(limit)
        )),
        _ => Ok(()),
    }
}
