//! The per-vertex pass, written as small pure functions over plain numbers
//! so the OpenCL kernel can mirror it line for line: morph blend, then the
//! skin matrix blend, then the transform to world space. Everything that
//! depends only on the frame (joint matrices, node matrices, morph weights)
//! is computed once beforehand in `pose`; nothing here looks at the scene
//! graph.

use glam::{Mat3, Mat4, Vec3};

/// `base + sum_t weights[t] * delta(t)`: glTF §3.7.2.2 morph targets.
/// Deltas of targets that lack the attribute are zero and may be skipped.
#[inline]
pub fn morph_blend(base: Vec3, weights: &[f32], delta: impl Fn(usize) -> Option<Vec3>) -> Vec3 {
    let mut v = base;
    for (t, &w) in weights.iter().enumerate() {
        if w != 0.0 {
            if let Some(d) = delta(t) {
                v += w * d;
            }
        }
    }
    v
}

/// `sum_i weights[i] * joint_matrices[joints[i]]` (§3.7.3.3). Each joint
/// matrix is `world_from_joint * joint_from_bind`, so the blend maps bind
/// space straight to world space and the mesh node's own transform plays
/// no part, as the specification requires.
#[inline]
pub fn skin_matrix(joints: &[u32], weights: &[f32], joint_matrices: &[Mat4]) -> Mat4 {
    let mut m = Mat4::ZERO;
    for (&j, &w) in joints.iter().zip(weights) {
        if w != 0.0 {
            m += joint_matrices[j as usize] * w;
        }
    }
    m
}

/// The matrix that carries normals through `world_from_mesh`: the inverse
/// transpose of its 3x3 part, up to a positive factor. It is computed as
/// the cofactor matrix times the sign of the determinant, which is the same
/// direction, needs no division, and stays defined for singular matrices
/// (zero scale) where the inverse does not exist.
#[inline]
pub fn normal_matrix(world_from_mesh: &Mat4) -> (Mat3, f32) {
    let c0 = world_from_mesh.x_axis.truncate();
    let c1 = world_from_mesh.y_axis.truncate();
    let c2 = world_from_mesh.z_axis.truncate();
    let cofactor = Mat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
    let det = c0.dot(c1.cross(c2));
    let sign = if det < 0.0 { -1.0 } else { 1.0 };
    (cofactor * sign, det)
}

/// A vertex after the per-vertex pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeformedVertex {
    pub position: Vec3,
    /// Unit length, or zero when the source had no normal.
    pub normal: Vec3,
    /// Determinant of the vertex's linear transform: negative means the
    /// transform mirrors, which flips the winding of triangles.
    pub det: f32,
}

/// The last step: bind/mesh-space position and normal to world space.
#[inline]
pub fn transform_vertex(world_from_mesh: &Mat4, position: Vec3, normal: Vec3) -> DeformedVertex {
    let (n_matrix, det) = normal_matrix(world_from_mesh);
    DeformedVertex {
        position: world_from_mesh.transform_point3(position),
        normal: (n_matrix * normal).normalize_or_zero(),
        det,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn normal_matrix_is_inverse_transpose_direction() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, -0.5, 3.0),
            Quat::from_rotation_y(0.7),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let (n, det) = normal_matrix(&m);
        assert!(det < 0.0);
        let reference = Mat3::from_mat4(m).inverse().transpose();
        for v in [Vec3::X, Vec3::Y, Vec3::new(0.3, -0.2, 0.9)] {
            let a = (n * v).normalize();
            let b = (reference * v).normalize();
            assert!((a - b).length() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn skin_blend_of_identical_matrices_is_that_matrix() {
        let j = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
        let m = skin_matrix(&[0, 1], &[0.25, 0.75], &[j, j]);
        assert!(m.abs_diff_eq(j, 1e-6));
    }
}
