//! The 8-wide layout with its child boxes quantized to bytes (`Wide8QNode`,
//! 128 bytes, against `Wide8Node`'s 256): per node and axis an origin and a
//! power-of-two scale, per slot and axis a byte for each plane, as in
//! Ylitie, Karras and Laine's compressed wide BVH (2017). The traversal
//! decodes a plane as `origin + q * scale` in float (the product is exact,
//! the sum rounded once), and the host picks each byte so that the decoded
//! box contains the slot's box: the decoded boxes are the traversal's
//! boxes, tested as the uncompressed layout tests its own, so no hit is lost
//! and the closest hit is the same.

use super::wide::{Wide8Node, WideLayout};
use super::TraceError;
use crate::bvh::{Child, EMPTY_CHILD};
use crate::device_struct::device_struct;
use bytemuck::{Pod, Zeroable};

device_struct! {
/// One quantized 8-wide node (`Wide8QNode`): slot k's box on axis a is
/// [origin[a] + qlo[a][k] * scale[a], origin[a] + qhi[a][k] * scale[a]];
/// `child` and `count` as in `Wide8Node` (an absent slot has child
/// `EMPTY_CHILD`, which the traversal masks: its bytes decode to a box).
/// 128 bytes, two cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Wide8QNode as "Wide8QNode" {
    pub origin: [f32; 3],
    pub scale: [f32; 3],
    pub qlo: [[u8; 8]; 3],
    pub qhi: [[u8; 8]; 3],
    pub count: [u8; 8],
    pub child: [u32; 8],
    pub pad: [u32; 4],
}
}

const _: () = assert!(std::mem::size_of::<Wide8QNode>() == 128);

impl Wide8QNode {
    /// A node with every slot absent.
    pub fn empty() -> Self {
        Wide8QNode {
            child: [EMPTY_CHILD; 8],
            ..Wide8QNode::zeroed()
        }
    }
}

/// The plane byte `q` decodes to, in the traversal's float operations.
pub fn decode(origin: f32, scale: f32, q: u8) -> f32 {
    origin + f32::from(q) * scale
}

/// The smallest power of two `s` (a normal float) with `255 s >= extent`.
fn scale_for(extent: f64) -> f32 {
    let mut e = -126i32;
    if extent > 0.0 {
        e = (extent / 255.0).log2().ceil() as i32;
        // log2 of a float quotient may land one off: settle it exactly.
        while e > -126 && 255.0 * 2f64.powi(e - 1) >= extent {
            e -= 1;
        }
        while 255.0 * 2f64.powi(e) < extent {
            e += 1;
        }
    }
    2f32.powi(e.max(-126))
}

/// `nodes` (an 8-wide layout) quantized into `out` (cleared first).
pub fn quantize_into(nodes: &[Wide8Node], out: &mut Vec<Wide8QNode>) -> Result<(), TraceError> {
    out.clear();
    out.reserve(nodes.len());
    for n in nodes {
        // An absent slot is stored as (EMPTY_CHILD, 0) in both layouts.
        let mut q = Wide8QNode {
            child: n.child,
            ..Wide8QNode::zeroed()
        };
        for (k, &count) in n.count.iter().enumerate() {
            q.count[k] = u8::try_from(count).map_err(|_| {
                TraceError::Unsupported(format!("a leaf of {count} triangles (at most 255)"))
            })?;
        }
        let present = |k: &usize| n.slot(*k).0 != Child::Empty;
        if !(0..8).any(|k| present(&k)) {
            out.push(q); // an empty root: every slot masked
            continue;
        }
        for a in 0..3 {
            let lo = (0..8)
                .filter(present)
                .map(|k| n.lo[a][k])
                .fold(f32::INFINITY, f32::min);
            let hi = (0..8)
                .filter(present)
                .map(|k| n.hi[a][k])
                .fold(f32::NEG_INFINITY, f32::max);
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(TraceError::Unsupported(format!(
                    "a box of infinite or NaN extent on axis {a} ({lo}..{hi})"
                )));
            }
            let origin = lo;
            let mut scale = scale_for(f64::from(hi) - f64::from(origin));
            // Rounding of the decode can leave the top byte short of `hi`:
            // then a coarser scale.
            while decode(origin, scale, 255) < hi {
                scale *= 2.0;
            }
            if !decode(origin, scale, 255).is_finite() {
                return Err(TraceError::Unsupported(format!(
                    "a box too large to quantize on axis {a} ({lo}..{hi})"
                )));
            }
            q.origin[a] = origin;
            q.scale[a] = scale;
            for k in (0..8).filter(present) {
                let (l, h) = (n.lo[a][k], n.hi[a][k]);
                let mut ql = (((f64::from(l) - f64::from(origin)) / f64::from(scale)).floor())
                    .clamp(0.0, 255.0) as u8;
                while ql > 0 && decode(origin, scale, ql) > l {
                    ql -= 1;
                }
                let mut qh = (((f64::from(h) - f64::from(origin)) / f64::from(scale)).ceil())
                    .clamp(0.0, 255.0) as u8;
                while qh < 255 && decode(origin, scale, qh) < h {
                    qh += 1;
                }
                q.qlo[a][k] = ql;
                q.qhi[a][k] = qh;
            }
        }
        out.push(q);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::test_util::random_soup;
    use crate::bvh::{binned, BuildParams};
    use crate::trace::wide::wide_layout;

    #[test]
    fn decoded_boxes_contain_the_slots_boxes() {
        for (n, seed, extent) in [(1usize, 1u64, 0.05f32), (100, 3, 0.05), (5000, 4, 0.01)] {
            let mut soup = random_soup(n, extent, seed);
            // Far from the origin, where a float's spacing is coarse.
            for p in &mut soup.positions {
                p[0] += 1.0e5;
            }
            let bvh = binned::build(&soup, BuildParams::default()).unwrap();
            let (wide, _) = wide_layout::<Wide8Node>(&bvh).unwrap();
            let mut q = Vec::new();
            quantize_into(&wide, &mut q).unwrap();
            assert_eq!(q.len(), wide.len());
            for (w, q) in wide.iter().zip(&q) {
                for k in 0..8 {
                    assert_eq!(w.child_count(k).0, q.child[k]);
                    if w.slot(k).0 == Child::Empty {
                        continue;
                    }
                    assert_eq!(w.child_count(k).1, u32::from(q.count[k]));
                    for a in 0..3 {
                        let lo = decode(q.origin[a], q.scale[a], q.qlo[a][k]);
                        let hi = decode(q.origin[a], q.scale[a], q.qhi[a][k]);
                        assert!(
                            lo <= w.lo[a][k] && hi >= w.hi[a][k],
                            "{n}: slot {k} axis {a}"
                        );
                        // Within two steps of the exact box.
                        assert!(w.lo[a][k] - lo <= 2.0 * q.scale[a]);
                        assert!(hi - w.hi[a][k] <= 2.0 * q.scale[a]);
                    }
                }
            }
        }
    }
}
