//! A texture's mean over a triangle (`texture_triangle_mean` of
//! `kernels/trace/texture.h`), which weighs textured emitters by what they
//! emit when next-event estimation chooses a triangle: its plain Rust
//! reference, and the device probe the tests hold the two to.

use super::texture::{
    sample_texture_ref, texture_uv_ref, HostTextures, Result, TextureBinding, TextureError,
    TextureSet, TEXTURE_MEAN_GRID,
};
use crate::device::Arg;

/// One triangle's corners: their TEXCOORD_0 and their second uv set.
pub type TriangleUvs = ([[f32; 2]; 3], [[f32; 2]; 3]);

/// `texture_interpolate_uv`: the uv at barycentrics (u, v), with the same
/// float operations in the same order.
fn interpolate(t: &[[f32; 2]; 3], u: f32, v: f32) -> [f32; 2] {
    let w = 1.0 - u - v;
    std::array::from_fn(|a| (w * t[0][a] + u * t[1][a]) + v * t[2][a])
}

/// `texture_triangle_mean`: the average of the binding's samples at the
/// centroids of the grid² congruent triangles the triangle divides into.
pub fn texture_triangle_mean_ref(
    host: &HostTextures,
    b: &TextureBinding,
    corners: &TriangleUvs,
) -> [f32; 4] {
    let g = TEXTURE_MEAN_GRID as f32;
    let mut sum = [0.0f32; 4];
    for i in 0..TEXTURE_MEAN_GRID {
        for j in 0..TEXTURE_MEAN_GRID - i {
            let cells = if i + j + 1 < TEXTURE_MEAN_GRID { 2 } else { 1 };
            for k in 0..cells {
                let s = if k == 0 { 1.0f32 / 3.0 } else { 2.0f32 / 3.0 };
                let (u, v) = ((i as f32 + s) / g, (j as f32 + s) / g);
                let uv = texture_uv_ref(
                    b,
                    interpolate(&corners.0, u, v),
                    interpolate(&corners.1, u, v),
                );
                let c = sample_texture_ref(host, b, uv);
                for a in 0..4 {
                    sum[a] += c[a];
                }
            }
        }
    }
    sum.map(|s| s / (g * g))
}

impl TextureSet<'_> {
    /// Runs `texture_triangle_mean` on the device for each
    /// `(bindings[i], triangles[i])`: the device side of the tests.
    pub fn triangle_mean_batch(
        &self,
        bindings: &[TextureBinding],
        triangles: &[TriangleUvs],
    ) -> Result<Vec<[f32; 4]>> {
        let n = bindings.len();
        if triangles.len() != n {
            return Err(TextureError::Usage(format!(
                "triangle_mean_batch needs as many triangles as bindings ({n}), got {}",
                triangles.len()
            )));
        }
        let (Some(info), Some(texels)) = (self.info_buffer(), self.texel_buffer()) else {
            // Nothing can be bound in an empty set: every binding is NONE.
            return Ok(vec![[1.0; 4]; n]);
        };
        let d = self.device();
        let program = d.build_program("texture_probe.cl", &[])?;
        let kernel = d.kernel(&program, "texture_mean_probe")?;
        let corners: Vec<[f32; 2]> = triangles
            .iter()
            .flat_map(|(t0, t1)| t0.iter().chain(t1).copied())
            .collect();
        let mut b_buf = d.buffer::<TextureBinding>(n.max(1))?;
        d.write(&mut b_buf, bindings)?;
        let mut c_buf = d.buffer::<[f32; 2]>(corners.len().max(1))?;
        d.write(&mut c_buf, &corners)?;
        let out = d.buffer::<[f32; 4]>(n.max(1))?;
        const LOCAL: usize = 64;
        d.launch(
            "texture/mean_probe",
            &kernel,
            n.div_ceil(LOCAL),
            LOCAL,
            &[
                Arg::Buf(info),
                Arg::Buf(texels),
                Arg::Buf(&b_buf),
                Arg::Buf(&c_buf),
                Arg::Buf(&out),
                Arg::U32(n as u32),
            ],
        )?;
        let mut means = vec![[0.0f32; 4]; n];
        d.read(&out, &mut means)?;
        d.finish()?;
        Ok(means)
    }
}
