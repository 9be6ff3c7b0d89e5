//! Cameras: the file's perspective and orthographic cameras placed by their
//! (possibly animated) nodes, and the default camera used when the file has
//! none, which frames the bounds of the whole clip so the subject never
//! leaves the picture.

use glam::{Mat4, Vec3};

/// Lens model, with glTF's parameters and conventions (radians, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    Perspective {
        /// Vertical field of view in radians.
        yfov: f32,
        /// Width / height; `None` means "use the image's aspect ratio".
        aspect: Option<f32>,
        znear: f32,
        /// `None` is an infinite projection.
        zfar: Option<f32>,
    },
    Orthographic {
        /// Half the view width and height, in world units.
        xmag: f32,
        ymag: f32,
        znear: f32,
        zfar: f32,
    },
}

/// A camera of the file, before placement.
#[derive(Debug, Clone)]
pub struct CameraDef {
    pub name: Option<String>,
    pub projection: Projection,
    /// The physical focal length in millimetres, from the draft
    /// `EXT_camera_physical` extension (its `focalLength`) when the file
    /// has it: the lens `--aperture` opens (`trace::lens`).
    pub focal_mm: Option<f32>,
}

/// The camera of one frame. Like every glTF camera it looks down its local
/// -Z axis with +Y up and +X to the right.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameCamera {
    pub name: Option<String>,
    /// Camera-to-world rigid transform (the node's scale is removed, since a
    /// scaled camera frame would skew rays).
    pub world_from_camera: Mat4,
    pub projection: Projection,
    /// False for the default camera soupray made up.
    pub from_file: bool,
}

impl FrameCamera {
    pub fn position(&self) -> Vec3 {
        self.world_from_camera.w_axis.truncate()
    }

    /// Unit viewing direction in world space.
    pub fn forward(&self) -> Vec3 {
        (-self.world_from_camera.z_axis.truncate()).normalize_or_zero()
    }
}

pub(crate) fn load_camera(camera: &gltf::Camera) -> CameraDef {
    let projection = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => Projection::Perspective {
            yfov: p.yfov(),
            aspect: p.aspect_ratio(),
            znear: p.znear(),
            zfar: p.zfar(),
        },
        gltf::camera::Projection::Orthographic(o) => Projection::Orthographic {
            xmag: o.xmag(),
            ymag: o.ymag(),
            znear: o.znear(),
            zfar: o.zfar(),
        },
    };
    CameraDef {
        name: camera.name().map(str::to_owned),
        projection,
        focal_mm: None,
    }
}

/// Removes scale (and shear) from a node's world matrix, keeping its
/// rotation and position. A mirrored frame keeps its handedness flipped
/// back to right-handed, as a camera cannot be mirrored meaningfully.
pub(crate) fn rigid(world_from_node: &Mat4) -> Mat4 {
    let z = world_from_node.z_axis.truncate().normalize_or(Vec3::Z);
    let y0 = world_from_node.y_axis.truncate();
    let x = y0.cross(z).normalize_or(Vec3::X);
    let y = z.cross(x);
    Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        world_from_node.w_axis.truncate().extend(1.0),
    )
}

/// Vertical field of view of the default camera.
pub const DEFAULT_YFOV: f32 = 0.698_131_7; // 40 degrees

/// A perspective camera that sees the whole box `lo..hi` for any image
/// aspect ratio of at least one (wider than tall): the bounding sphere is
/// fitted inside the vertical field of view. It looks at the box centre
/// from the front (+Z, glTF's forward for assets) and slightly above.
pub fn framing(lo: Vec3, hi: Vec3) -> FrameCamera {
    let (center, mut radius) = if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
        ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
    } else {
        (Vec3::ZERO, 1.0)
    };
    if radius <= 1e-6 {
        radius = 1.0;
    }
    let distance = radius / (DEFAULT_YFOV * 0.5).sin() * 1.05;
    let direction = Vec3::new(0.0, 0.35, 1.0).normalize();
    let eye = center + direction * distance;
    let world_from_camera = Mat4::look_at_rh(eye, center, Vec3::Y).inverse();
    FrameCamera {
        name: None,
        world_from_camera,
        projection: Projection::Perspective {
            yfov: DEFAULT_YFOV,
            aspect: None,
            znear: (distance - radius) * 0.5,
            zfar: Some(distance + radius * 2.0),
        },
        from_file: false,
    }
}
