//! Compositing roles: meshes that show to the camera only as the shadows
//! cast on them (shadow catchers) or as a hole in the frame (holdouts), so
//! a CG element can be composited onto a filmed plate. A node takes its
//! role from `--shadow-catcher` / `--holdout`, else from its
//! `extras.soupray` (`{"soupray": {"shadow_catcher": true}}` or
//! `{"soupray": {"holdout": true}}`), else from its parent: a role covers
//! the node's whole subtree.

use super::Scene;
use crate::device_struct::device_consts;

/// How a node's meshes appear to camera rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Invisible to the camera but for the shadows the rest of the scene
    /// casts on it; it still lights, shadows and reflects the rest.
    ShadowCatcher,
    /// Cut out of the frame (RGB and alpha 0 where the camera sees it); it
    /// still hides what is behind it, and lights and shadows the rest.
    Holdout,
}

device_consts! {
    fn compositing_consts;
    /// A triangle's flags (`triangle_flags`): a shadow catcher's.
    pub const TRIANGLE_SHADOW_CATCHER: u32 = 1;
    /// A holdout's.
    pub const TRIANGLE_HOLDOUT: u32 = 2;
}

impl Role {
    /// The role a node's `extras` give it: `{"soupray": {"shadow_catcher":
    /// true}}` or `{"soupray": {"holdout": true}}`.
    pub fn of_extras(extras: Option<&serde_json::value::RawValue>) -> Option<Role> {
        let value: serde_json::Value = serde_json::from_str(extras?.get()).ok()?;
        let soupray = value.get("soupray")?;
        let flag = |k: &str| soupray.get(k).and_then(serde_json::Value::as_bool) == Some(true);
        if flag("shadow_catcher") {
            Some(Role::ShadowCatcher)
        } else if flag("holdout") {
            Some(Role::Holdout)
        } else {
            None
        }
    }

    fn flag(self) -> u32 {
        match self {
            Role::ShadowCatcher => TRIANGLE_SHADOW_CATCHER,
            Role::Holdout => TRIANGLE_HOLDOUT,
        }
    }
}

/// The nodes given a role on the command line (`--shadow-catcher`,
/// `--holdout`), by node index.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RoleOverrides {
    pub shadow_catchers: Vec<usize>,
    pub holdouts: Vec<usize>,
}

impl RoleOverrides {
    /// No node has a role.
    pub fn is_empty(&self) -> bool {
        self.shadow_catchers.is_empty() && self.holdouts.is_empty()
    }

    /// These overrides with the roles `scene`'s nodes give themselves in
    /// their extras.
    pub fn with_extras_of(&self, scene: &Scene) -> RoleOverrides {
        let mut all = self.clone();
        for (i, node) in scene.nodes().iter().enumerate() {
            let list = match node.role {
                Some(Role::ShadowCatcher) => &mut all.shadow_catchers,
                Some(Role::Holdout) => &mut all.holdouts,
                None => continue,
            };
            if !self.shadow_catchers.contains(&i) && !self.holdouts.contains(&i) {
                list.push(i);
            }
        }
        all
    }
}

/// Each node's role: its override, else its own extras, else its parent's.
pub fn node_roles(scene: &Scene, overrides: &RoleOverrides) -> Vec<Option<Role>> {
    let nodes = scene.nodes();
    let mut roles: Vec<Option<Role>> = vec![None; nodes.len()];
    for &n in scene.node_order() {
        let own = if overrides.holdouts.contains(&n) {
            Some(Role::Holdout)
        } else if overrides.shadow_catchers.contains(&n) {
            Some(Role::ShadowCatcher)
        } else {
            nodes[n].role
        };
        roles[n] = own.or_else(|| nodes[n].parent.and_then(|p| roles[p]));
    }
    roles
}

/// Per soup triangle, in soup order, its `TRIANGLE_*` flags; `None` when
/// no triangle has a role (the path tracer then compiles none of it).
pub fn triangle_flags(scene: &Scene, overrides: &RoleOverrides) -> Option<Vec<u32>> {
    let roles = node_roles(scene, overrides);
    if scene.instances().iter().all(|i| roles[i.node].is_none()) {
        return None;
    }
    let mut flags = Vec::with_capacity(scene.triangle_count());
    for (instance, prim) in scene.instance_primitives() {
        let flag = roles[instance.node].map_or(0, Role::flag);
        flags.extend(std::iter::repeat_n(flag, prim.triangles.len()));
    }
    Some(flags)
}
