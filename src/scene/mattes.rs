//! What a Cryptomatte names: every object (the node that places a mesh),
//! material and asset (the object's root node) of a scene, and for each
//! triangle of its soup the pair of object and material it belongs to.
//! The path tracer records the pair at each camera ray's first hit; the
//! film turns pairs into the names of each Cryptomatte layer.

use std::collections::HashMap;

use super::Scene;

/// The matte names of a scene, and the (object, material) pair of each
/// soup triangle.
#[derive(Clone, Debug, PartialEq)]
pub struct MatteTable {
    /// Per soup triangle, in soup order: its index into `pairs`.
    pub triangle_pairs: Vec<u32>,
    /// The distinct (object, material) pairs the soup's triangles have.
    pub pairs: Vec<MattePair>,
}

/// The names one first hit counts under, one per Cryptomatte layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct MattePair {
    /// The glTF index of the node that places the mesh.
    pub node: usize,
    /// The node that places the mesh: its glTF name, or its path of names
    /// from the scene root where names repeat.
    pub object: String,
    /// The material's name (`default` for the glTF default material).
    pub material: String,
    /// The object's root node, named as objects are.
    pub asset: String,
}

impl MatteTable {
    /// The table of `scene`, its triangles in the order the soup lays them
    /// out (instances, then their mesh's primitives, then triangles).
    pub fn of(scene: &Scene) -> MatteTable {
        let node_names = unique_node_names(scene);
        let material_names = unique_material_names(scene);
        let default_material = scene.materials().default_material.unwrap_or(0) as usize;
        let mut index: HashMap<MattePair, u32> = HashMap::new();
        let mut table = MatteTable {
            triangle_pairs: Vec::with_capacity(scene.triangle_count()),
            pairs: Vec::new(),
        };
        for (instance, prim) in scene.instance_primitives() {
            let root = root_of(scene, instance.node);
            let material = prim.material.unwrap_or(default_material);
            let pair = MattePair {
                node: instance.node,
                object: node_names[instance.node].clone(),
                material: material_names
                    .get(material)
                    .cloned()
                    .unwrap_or_else(|| "default".to_owned()),
                asset: node_names[root].clone(),
            };
            let next = table.pairs.len() as u32;
            let id = *index.entry(pair.clone()).or_insert_with(|| {
                table.pairs.push(pair);
                next
            });
            table
                .triangle_pairs
                .extend(std::iter::repeat_n(id, prim.triangles.len()));
        }
        table
    }
}

/// The scene root above `node`.
fn root_of(scene: &Scene, mut node: usize) -> usize {
    // The loader rejects cycles, so the walk ends; the bound is a guard.
    for _ in 0..scene.nodes().len() {
        match scene.nodes()[node].parent {
            Some(p) => node = p,
            None => break,
        }
    }
    node
}

/// Each node's matte name: its glTF name (`node<i>` when it has none); its
/// path of names from the root, `/`-separated, where another node has the
/// same name; and the path with `#<i>` where even paths repeat. Names are
/// what a compositor picks by, so they must tell every object apart.
fn unique_node_names(scene: &Scene) -> Vec<String> {
    let nodes = scene.nodes();
    let own: Vec<String> = (0..nodes.len())
        .map(|i| nodes[i].name.clone().unwrap_or_else(|| format!("node{i}")))
        .collect();
    let paths: Vec<String> = (0..nodes.len())
        .map(|i| {
            let mut parts = vec![own[i].as_str()];
            let mut at = i;
            for _ in 0..nodes.len() {
                match nodes[at].parent {
                    Some(p) => {
                        parts.push(own[p].as_str());
                        at = p;
                    }
                    None => break,
                }
            }
            parts.reverse();
            parts.join("/")
        })
        .collect();
    let own_repeats = counts(&own);
    let path_repeats = counts(&paths);
    (0..nodes.len())
        .map(|i| {
            if own_repeats[&own[i]] == 1 {
                own[i].clone()
            } else if path_repeats[&paths[i]] == 1 {
                paths[i].clone()
            } else {
                format!("{}#{i}", paths[i])
            }
        })
        .collect()
}

/// Each material's matte name: its glTF name (`material<i>` when it has
/// none), with `#<i>` where another material has the same name.
fn unique_material_names(scene: &Scene) -> Vec<String> {
    let table = scene.materials();
    let own: Vec<String> = table
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| match (&m.name, table.default_material) {
            (Some(n), _) => n.clone(),
            (None, Some(d)) if d as usize == i => "default".to_owned(),
            (None, _) => format!("material{i}"),
        })
        .collect();
    let repeats = counts(&own);
    own.iter()
        .enumerate()
        .map(|(i, n)| {
            if repeats[n] == 1 {
                n.clone()
            } else {
                format!("{n}#{i}")
            }
        })
        .collect()
}

fn counts(names: &[String]) -> HashMap<&String, usize> {
    let mut c = HashMap::new();
    for n in names {
        *c.entry(n).or_insert(0) += 1;
    }
    c
}
