//! Nested dielectrics: the refracting volumes a path is inside, innermost
//! last (`PtMedia` of `kernels/trace/media.h`, which this mirrors operation for
//! operation; `media_probe` in `kernels/trace/pt_probe.cl` holds the two to each
//! other).
//!
//! The rule (Schmidt & Budge 2002 without priorities, the most recently
//! entered volume winning): transmitting through a front face of a volume
//! material enters it, through a back face leaves it. At a front face the
//! sides are the innermost volume (air when none) and the material; at a
//! back face of the innermost volume, that volume and the one it was
//! entered from. A back face of a volume that is in the list but not
//! innermost is a false interface, crossed unchanged. Liquid in a glass is
//! modelled with the liquid's surface slightly overlapping the glass's wall
//! (docs/materials.md, "Nested dielectrics").

/// Volumes a path can be inside at once (`MEDIUM_STACK`).
pub const MEDIUM_STACK: usize = 4;
/// No volume: the space outside every volume (`NO_MEDIUM`).
pub const NO_MEDIUM: u32 = u32::MAX;

/// The list of volumes (material indices) a path is inside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MediumStack {
    pub id: [u32; MEDIUM_STACK],
    pub count: usize,
}

impl Default for MediumStack {
    fn default() -> Self {
        MediumStack {
            id: [NO_MEDIUM; MEDIUM_STACK],
            count: 0,
        }
    }
}

impl MediumStack {
    /// The innermost volume, `NO_MEDIUM` outside all.
    pub fn innermost(&self) -> u32 {
        if self.count > 0 {
            self.id[self.count - 1]
        } else {
            NO_MEDIUM
        }
    }

    /// The position of the most recent entry of `mat`.
    pub fn find(&self, mat: u32) -> Option<usize> {
        self.id[..self.count].iter().rposition(|&m| m == mat)
    }

    /// Whether a back face of `mat` is a false interface.
    pub fn false_interface(&self, mat: u32) -> bool {
        matches!(self.find(mat), Some(k) if k + 1 < self.count)
    }

    /// The volume on the other side of `mat`'s surface from `mat`'s own,
    /// at a front face (`front`) or a back face.
    pub fn other(&self, mat: u32, front: bool) -> u32 {
        let inner = self.innermost();
        if front || inner != mat {
            inner
        } else if self.count > 1 {
            self.id[self.count - 2]
        } else {
            NO_MEDIUM
        }
    }

    /// Enters `mat`; a full list drops its outermost entry.
    pub fn enter(&mut self, mat: u32) {
        if self.count == MEDIUM_STACK {
            self.id.copy_within(1.., 0);
            self.count = MEDIUM_STACK - 1;
        }
        self.id[self.count] = mat;
        self.count += 1;
    }

    /// Leaves the most recent entry of `mat` (none: no change).
    pub fn leave(&mut self, mat: u32) {
        let Some(k) = self.find(mat) else { return };
        self.id.copy_within(k + 1..self.count, k);
        self.count -= 1;
        self.id[self.count] = NO_MEDIUM;
    }
}

/// The relative index (far side over the incoming side) at a surface of a
/// material of index `ior` with index `n_other` on its other side: `ior /
/// n_other` at a front face, `n_other / ior` at a back face.
pub fn relative_eta(ior: f32, n_other: f32, front: bool) -> f32 {
    if front {
        ior / n_other
    } else {
        n_other / ior
    }
}

/// KHR_materials_dispersion's index of a volume of index `ior` and
/// `dispersion` (20 / Abbe number) for colour channel `channel` (0 red, 1
/// green, 2 blue; `None`: a path that carries all three): the extension's
/// `ior -/+ (ior - 1) 0.025 dispersion` for red and blue, red at least 1.
/// Twin of `media_channel_ior` in kernels/trace/media.h.
pub fn channel_ior(ior: f32, dispersion: f32, channel: Option<usize>) -> f32 {
    if dispersion.is_nan() || dispersion <= 0.0 {
        return ior;
    }
    let half_spread = ((ior - 1.0) * 0.025) * dispersion;
    match channel {
        Some(0) => (ior - half_spread).max(1.0),
        Some(2) => ior + half_spread,
        _ => ior,
    }
}

/// The interface's normal-incidence reflectance from the ratio of the two
/// indices (`media_f0`; symmetric in them, against air the material's own).
pub fn relative_f0(ior: f32, n_other: f32) -> f32 {
    super::material::f0_of_ior(ior / n_other)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glass_in_water_and_back_out() {
        let (water, glass) = (0, 1);
        let mut m = MediumStack::default();
        assert_eq!(m.other(water, true), NO_MEDIUM);
        m.enter(water);
        assert_eq!(m.other(glass, true), water);
        m.enter(glass);
        // Leaving the glass: back into water.
        assert!(!m.false_interface(glass));
        assert_eq!(m.other(glass, false), water);
        m.leave(glass);
        assert_eq!(m.innermost(), water);
        assert_eq!(m.other(water, false), NO_MEDIUM);
        m.leave(water);
        assert_eq!(m, MediumStack::default());
    }

    #[test]
    fn overlapping_liquid_makes_the_glass_inner_wall_false() {
        let (glass, liquid) = (0, 1);
        let mut m = MediumStack::default();
        m.enter(glass);
        m.enter(liquid);
        assert!(m.false_interface(glass));
        m.leave(glass);
        assert_eq!(m.innermost(), liquid);
        // The liquid's free surface: liquid against air.
        assert_eq!(m.other(liquid, false), NO_MEDIUM);
    }

    #[test]
    fn a_full_list_drops_the_outermost() {
        let mut m = MediumStack::default();
        for k in 0..6 {
            m.enter(k);
        }
        assert_eq!(m.id, [2, 3, 4, 5]);
        // Leaving a volume that fell off: no change, a real interface.
        m.leave(0);
        assert_eq!(m.count, 4);
        assert!(!m.false_interface(0));
        assert_eq!(m.other(0, false), 5);
    }

    #[test]
    fn eta_against_air_is_the_lone_volume_s() {
        assert_eq!(relative_eta(1.5, 1.0, true), 1.5);
        assert_eq!(relative_eta(1.5, 1.0, false), 1.0 / 1.5);
        assert_eq!(relative_eta(1.5, 1.33, true), 1.5 / 1.33);
    }
}
