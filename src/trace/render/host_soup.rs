//! Rendering a host `Soup` (tests, tools and analytic scenes, without a
//! glTF file): the tree is built here on the device, and the soup's
//! attributes are uploaded into buffers kept for the next call, then
//! rendered as any frame (`render_buffers`).

use super::{usage, MotionSteps, PathTracer, RenderOutput, RenderSettings, SoupBuffers};
use crate::bvh::device_builder::DeviceBuilder;
use crate::bvh::BuildParams;
use crate::device::{Device, GrowBuffer};
use crate::scene::{FrameCamera, FrameLight, MaterialTable};
use crate::soup::Soup;
use crate::trace::TraceError;

/// The host soup's uploads, kept from one `render_soup` call to the next.
pub(super) struct HostSoupBuffers {
    positions: GrowBuffer<[f32; 4]>,
    normals: GrowBuffer<[f32; 4]>,
    uvs: GrowBuffer<[f32; 2]>,
    uvs1: GrowBuffer<[f32; 2]>,
    colors: GrowBuffer<[f32; 4]>,
    material_ids: GrowBuffer<u32>,
}

impl<'d> PathTracer<'d> {
    /// Renders host soups at `steps.len()` >= 2 motion steps (same
    /// triangles, uvs and materials in each; `cameras` one per step, and
    /// `lights` the punctual lights at each step or none at all), their
    /// tree built here on the device over the triangles' bounds at every
    /// step (`motion::motion_bounds`). For tests and tools; the renderer
    /// keeps everything on the device with `render_motion`.
    pub fn render_motion_soup(
        &mut self,
        steps: &[Soup],
        cameras: &[FrameCamera],
        lights: &[Vec<FrameLight>],
        frame: i64,
    ) -> Result<RenderOutput, TraceError> {
        let count = steps.len();
        if count < 2 || cameras.len() != count || !(lights.is_empty() || lights.len() == count) {
            return Err(usage(format!(
                "render_motion_soup: {count} soups, {} cameras and {} light sets; give at least 2 steps, \
                 one camera per step and one light set per step (or none)",
                cameras.len(),
                lights.len()
            )));
        }
        let n = steps[0].triangle_count();
        if steps.iter().any(|s| s.triangle_count() != n) {
            return Err(usage(
                "render_motion_soup: every step must have the same triangles".into(),
            ));
        }
        let mut positions: Vec<[f32; 4]> = Vec::with_capacity(3 * n * count);
        for s in steps {
            positions.extend_from_slice(&s.positions);
        }
        let normals: Option<Vec<[f32; 4]>> =
            (n > 0 && steps.iter().all(|s| s.normals.len() == 3 * n)).then(|| {
                steps
                    .iter()
                    .flat_map(|s| s.normals.iter().copied())
                    .collect()
            });
        let bounds = Soup {
            positions: crate::trace::motion::motion_bounds(&positions, n, count as u32),
            ..Soup::default()
        };
        self.prepare_motion()?;
        self.render_host(
            &bounds,
            &positions,
            normals.as_deref(),
            &steps[0],
            &cameras[count / 2],
            lights.get(count / 2).map_or(&[], |l| l.as_slice()),
            frame,
            Some((count as u32, cameras, lights)),
        )
    }

    /// Renders a host soup (uploaded into buffers kept for the next call)
    /// whose tree is built here on the device. Missing material ids mean
    /// material 0 of the table (or the default material when it is empty).
    pub fn render_soup(
        &mut self,
        soup: &Soup,
        camera: &FrameCamera,
        lights: &[FrameLight],
        frame: i64,
    ) -> Result<RenderOutput, TraceError> {
        let n = soup.triangle_count();
        let normals = (soup.normals.len() == 3 * n && n > 0).then_some(soup.normals.as_slice());
        self.render_host(
            soup,
            &soup.positions,
            normals,
            soup,
            camera,
            lights,
            frame,
            None,
        )
    }

    /// The host-soup path of `render_soup` and `render_motion_soup`: builds
    /// the tree over `tree`'s triangles, uploads `positions` and `normals`
    /// (one soup's, or every motion step's side by side) with `first`'s
    /// texture coordinates and material ids into the buffers kept for the
    /// next call, and renders.
    #[allow(clippy::too_many_arguments)]
    fn render_host(
        &mut self,
        tree: &Soup,
        positions: &[[f32; 4]],
        normals: Option<&[[f32; 4]]>,
        first: &Soup,
        camera: &FrameCamera,
        lights: &[FrameLight],
        frame: i64,
        motion: Option<MotionSteps>,
    ) -> Result<RenderOutput, TraceError> {
        let n = first.triangle_count();
        let d = self.device;
        let mut builder = DeviceBuilder::new(d, BuildParams::default())
            .map_err(|e| usage(format!("BVH build: {e}")))?;
        let (bvh, _) = builder
            .build(tree)
            .map_err(|e| usage(format!("BVH build: {e}")))?;
        let mut hs = self.host_soup.take().unwrap_or(HostSoupBuffers {
            positions: GrowBuffer::new(),
            normals: GrowBuffer::new(),
            uvs: GrowBuffer::new(),
            uvs1: GrowBuffer::new(),
            colors: GrowBuffer::new(),
            material_ids: GrowBuffer::new(),
        });
        let result = (|| {
            d.write(hs.positions.ensure(d, positions.len().max(1))?, positions)?;
            if let Some(normals) = normals {
                d.write(hs.normals.ensure(d, normals.len())?, normals)?;
            }
            let has_uvs = first.uvs.len() == 3 * n && n > 0;
            if has_uvs {
                d.write(hs.uvs.ensure(d, 3 * n)?, &first.uvs)?;
            }
            let has_uvs1 = first.uvs1.len() == 3 * n && n > 0;
            if has_uvs1 {
                d.write(hs.uvs1.ensure(d, 3 * n)?, &first.uvs1)?;
            }
            let has_colors = first.colors.len() == 3 * n && n > 0;
            if has_colors {
                d.write(hs.colors.ensure(d, 3 * n)?, &first.colors)?;
            }
            let ids = if first.material_ids.len() == n {
                first.material_ids.clone()
            } else {
                vec![0; n]
            };
            d.write(hs.material_ids.ensure(d, n.max(1))?, &ids)?;
            let buffers = SoupBuffers {
                positions: hs.positions.get(),
                normals: normals.is_some().then(|| hs.normals.get()),
                uvs: has_uvs.then(|| hs.uvs.get()),
                uvs1: has_uvs1.then(|| hs.uvs1.get()),
                colors: has_colors.then(|| hs.colors.get()),
                material_ids: hs.material_ids.get(),
                triangles: n,
            };
            let prim_ids = builder
                .device_prim_ids()
                .ok_or_else(|| usage("BVH build left no primitive ids".into()))?;
            self.render_buffers(
                &buffers,
                &bvh,
                prim_ids,
                camera,
                lights,
                frame,
                motion,
                &mut |_| {},
            )
        })();
        self.host_soup = Some(hs);
        result
    }
}

/// Renders a host soup with `table`'s materials (soup material ids index
/// it), `camera` and `lights`: a tracer made for this one frame.
pub fn render_soup(
    device: &Device,
    soup: &Soup,
    table: &MaterialTable,
    camera: &FrameCamera,
    lights: &[FrameLight],
    settings: &RenderSettings,
    frame: i64,
) -> Result<RenderOutput, TraceError> {
    let mut pt = PathTracer::with_materials(device, table, settings)?;
    pt.render_soup(soup, camera, lights, frame)
}
