//! Cryptomatte (Psyop's specification 1.2, as Cycles, Arnold and RenderMan
//! write it): per pixel, the ids of the objects, materials and assets its
//! samples first hit, each with its coverage, so a compositor can cut any
//! of them out with antialiased, motion-blurred and defocused edges.
//!
//! The path tracer records, for each camera sample, the (object, material)
//! pair of its first hit (`scene::MatteTable`) in a small per-pixel table
//! of counts. Samples carry weight 1 (the filter is importance sampled), so
//! a name's coverage is the share of the pixel's kept samples that hit it,
//! and the mattes of a pixel add up to its alpha. `resolve_mattes` sums
//! the pairs into each layer's names and keeps each pixel's `depth` most
//! covering names, most first.
//!
//! In the EXR, layer `CryptoObject` (and `CryptoMaterial`, `CryptoAsset`)
//! is written as channels `CryptoObject00.R`, `.G`, `.B`, `.A`,
//! `CryptoObject01.R`, ...: each of those holds two ranks, id in R and B,
//! coverage in G and A. An id is the name's MurmurHash3_x86_32 (seed 0)
//! as the bits of a float (`name_id`). The header attributes
//! `cryptomatte/<key>/name`, `/hash`, `/conversion` and `/manifest` (the
//! JSON map from each name to its id in hex) let the compositor list the
//! names, `<key>` being the first 7 hex digits of the hash of the layer's
//! name.

use rayon::prelude::*;
use std::collections::BTreeMap;

use crate::scene::MatteTable;
use crate::UsageError;

/// The most ranks a layer can keep per pixel (`--cryptomatte-depth`).
pub const MAX_DEPTH: u32 = 16;

/// One Cryptomatte layer: what its names name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MatteKind {
    /// The node that places a mesh.
    Object,
    /// The material.
    Material,
    /// The object's root node.
    Asset,
}

impl MatteKind {
    /// The layer's name in the EXR (Cycles' names).
    pub fn layer_name(self) -> &'static str {
        match self {
            MatteKind::Object => "CryptoObject",
            MatteKind::Material => "CryptoMaterial",
            MatteKind::Asset => "CryptoAsset",
        }
    }

    /// Its name as `--cryptomatte` spells it.
    pub fn option_name(self) -> &'static str {
        match self {
            MatteKind::Object => "object",
            MatteKind::Material => "material",
            MatteKind::Asset => "asset",
        }
    }
}

/// `--cryptomatte` and `--cryptomatte-depth`: which layers a frame carries,
/// and how many ranks each keeps per pixel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cryptomatte {
    /// The layers, each once, in the order object, material, asset.
    pub kinds: Vec<MatteKind>,
    /// Ranks per pixel and layer: even, 2 to `MAX_DEPTH`.
    pub depth: u32,
}

impl Cryptomatte {
    /// Parses `--cryptomatte object,material,asset` (any subset) with
    /// `--cryptomatte-depth` ranks (rounded up to even: an EXR layer holds
    /// two).
    pub fn parse(list: &str, depth: u32) -> Result<Cryptomatte, UsageError> {
        let mut kinds = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let kind = match item.to_ascii_lowercase().as_str() {
                "object" => MatteKind::Object,
                "material" => MatteKind::Material,
                "asset" => MatteKind::Asset,
                _ => {
                    return Err(UsageError(format!(
                    "--cryptomatte: unknown layer {item:?}; choose from object, material, asset \
                         (e.g. --cryptomatte object,material)"
                )))
                }
            };
            if !kinds.contains(&kind) {
                kinds.push(kind);
            }
        }
        if kinds.is_empty() {
            return Err(UsageError(
                "--cryptomatte: name at least one layer: object, material or asset".into(),
            ));
        }
        if !(1..=MAX_DEPTH).contains(&depth) {
            return Err(UsageError(format!(
                "--cryptomatte-depth {depth}: choose 1 to {MAX_DEPTH} ranks per pixel (6, the \
                 default, is what Cycles writes)"
            )));
        }
        kinds.sort();
        Ok(Cryptomatte {
            kinds,
            depth: depth.next_multiple_of(2),
        })
    }

    /// The (object, material) pairs the tracer keeps per pixel: as many as
    /// a layer has ranks. A pixel whose samples hit more pairs loses the
    /// samples of those that came last (its mattes then add up to less
    /// than its alpha).
    pub fn slots(&self) -> u32 {
        self.depth
    }
}

/// A resolved Cryptomatte layer.
#[derive(Clone, Debug, PartialEq)]
pub struct MatteLayer {
    pub kind: MatteKind,
    /// Ranks per pixel (even).
    pub depth: usize,
    /// `depth` (id, coverage) pairs per pixel, most coverage first; unused
    /// ranks are (0, 0).
    pub ranks: Vec<[f32; 2]>,
    /// Every name the frame's scene has in this layer, with its id's bits.
    pub manifest: BTreeMap<String, u32>,
}

impl MatteLayer {
    /// The EXR channel names of rank pair `k` (`CryptoObject00.R` ...).
    pub fn channel_names(&self, k: usize) -> [String; 4] {
        let base = format!("{}{k:02}", self.kind.layer_name());
        ["R", "G", "B", "A"].map(|c| format!("{base}.{c}"))
    }

    /// The header attributes that describe the layer, as the specification
    /// names them.
    pub fn attributes(&self) -> Vec<(String, String)> {
        let name = self.kind.layer_name();
        let key = format!("{:08x}", murmur3_32(name.as_bytes(), 0));
        let key = &key[..7];
        let manifest: BTreeMap<&str, String> = self
            .manifest
            .iter()
            .map(|(n, bits)| (n.as_str(), format!("{bits:08x}")))
            .collect();
        let manifest = serde_json::to_string(&manifest).unwrap_or_else(|_| "{}".to_owned());
        vec![
            (format!("cryptomatte/{key}/name"), name.to_owned()),
            (
                format!("cryptomatte/{key}/hash"),
                "MurmurHash3_32".to_owned(),
            ),
            (
                format!("cryptomatte/{key}/conversion"),
                "uint32_to_float32".to_owned(),
            ),
            (format!("cryptomatte/{key}/manifest"), manifest),
        ]
    }

    /// Each pixel's coverage by `name` (0 where it is not among the ranks).
    pub fn coverage(&self, name: &str) -> Vec<f32> {
        let id = name_id(name);
        self.ranks
            .chunks(self.depth)
            .map(|ranks| {
                ranks
                    .iter()
                    .filter(|r| r[0].to_bits() == id.to_bits() && r[1] > 0.0)
                    .map(|r| r[1])
                    .sum()
            })
            .collect()
    }
}

/// MurmurHash3_x86_32 (Austin Appleby's public-domain reference), the hash
/// the specification names. Twenty lines, checked against the reference's
/// published values, rather than a dependency.
pub fn murmur3_32(data: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h = seed;
    let mut blocks = data.chunks_exact(4);
    for b in &mut blocks {
        let mut k = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        k = k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h ^= k;
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, &byte) in tail.iter().enumerate() {
            k |= (byte as u32) << (8 * i);
        }
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// A name's Cryptomatte id: its hash as the bits of a float, with the
/// exponent's lowest bit flipped where the bits would be a denormal, an
/// infinity or a NaN (the specification's `uint32_to_float32`), so every
/// id survives any float pipeline.
pub fn name_id(name: &str) -> f32 {
    let mut bits = murmur3_32(name.as_bytes(), 0);
    let exponent = (bits >> 23) & 0xff;
    if exponent == 0 || exponent == 0xff {
        bits ^= 1 << 23;
    }
    f32::from_bits(bits)
}

/// The frame's Cryptomatte layers from the tracer's per-pixel tables:
/// `slots` holds `cryptomatte.slots()` (pair + 1, count) entries per pixel
/// (0 marks an empty slot), `kept` each pixel's kept samples; in the
/// buffers of `spare` (a written frame's layers) where it has them.
pub fn resolve_mattes(
    slots: &[[u32; 2]],
    kept: &[u32],
    table: &MatteTable,
    cryptomatte: &Cryptomatte,
    mut spare: Vec<MatteLayer>,
) -> Vec<MatteLayer> {
    let per_pixel = cryptomatte.slots() as usize;
    let depth = cryptomatte.depth as usize;
    cryptomatte
        .kinds
        .iter()
        .map(|&kind| {
            let name_of = |pair: usize| {
                let p = &table.pairs[pair];
                match kind {
                    MatteKind::Object => p.object.as_str(),
                    MatteKind::Material => p.material.as_str(),
                    MatteKind::Asset => p.asset.as_str(),
                }
            };
            // Ids once per name, not once per pixel.
            let ids: Vec<f32> = (0..table.pairs.len())
                .map(|p| name_id(name_of(p)))
                .collect();
            let manifest = (0..table.pairs.len())
                .map(|p| (name_of(p).to_owned(), ids[p].to_bits()))
                .collect();
            // In a written frame's buffer where there is one (as
            // `film::resolve`'s other outputs).
            let mut ranks = spare.pop().map(|l| l.ranks).unwrap_or_default();
            ranks.clear();
            ranks.resize(kept.len() * depth, [0.0, 0.0]);
            // The pixels split among the threads (the device is idle
            // meanwhile), each with its own list of names.
            ranks
                .par_chunks_mut(depth.max(1))
                .zip(kept.par_iter())
                .enumerate()
                .for_each_init(
                    || Vec::with_capacity(per_pixel),
                    |named: &mut Vec<(u32, u32)>, (pixel, (out, &n))| {
                        named.clear();
                        for s in &slots[pixel * per_pixel..(pixel + 1) * per_pixel] {
                            if let Some(pair) = s[0].checked_sub(1) {
                                if let Some(id) = ids.get(pair as usize) {
                                    add_count(named, id.to_bits(), s[1]);
                                }
                            }
                        }
                        // Most coverage first; equal coverage by id.
                        named.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
                        let inv = if n > 0 { 1.0 / n as f32 } else { 0.0 };
                        for (rank, &(id, count)) in out.iter_mut().zip(named.iter()) {
                            *rank = [f32::from_bits(id), count as f32 * inv];
                        }
                    },
                );
            MatteLayer {
                kind,
                depth,
                ranks,
                manifest,
            }
        })
        .collect()
}

/// Adds `count` to `key`'s entry in `counts`, or appends one. A pixel has
/// a few slots (`Cryptomatte::slots`), so a linear search in one list
/// reused across pixels beats a hash map per pixel (a 640x360 frame has
/// 230,400 pixels).
fn add_count<K: PartialEq>(counts: &mut Vec<(K, u32)>, key: K, count: u32) {
    match counts.iter_mut().find(|(k, _)| *k == key) {
        Some((_, c)) => *c += count,
        None => counts.push((key, count)),
    }
}

/// Each pixel's object id (`--aov object_id`): the glTF node index + 1 of
/// the object most of its samples hit first (ties to the lower index), 0
/// where none hit. `slots` holds `per_pixel` entries per pixel.
pub fn resolve_object_ids(
    slots: &[[u32; 2]],
    per_pixel: usize,
    table: &MatteTable,
    ids: &mut [f32],
) {
    ids.par_iter_mut().enumerate().for_each_init(
        || Vec::with_capacity(per_pixel),
        |counts: &mut Vec<(usize, u32)>, (pixel, id)| {
            counts.clear();
            for s in &slots[pixel * per_pixel..(pixel + 1) * per_pixel] {
                if let Some(pair) = s[0]
                    .checked_sub(1)
                    .and_then(|p| table.pairs.get(p as usize))
                {
                    add_count(counts, pair.node, s[1]);
                }
            }
            *id = counts
                .iter()
                .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
                .map_or(0.0, |&(node, _)| (node + 1) as f32);
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mattes::MattePair;

    #[test]
    fn murmur3_matches_the_reference_values() {
        // Published values of MurmurHash3_x86_32 (SMHasher's reference).
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"", 0xffff_ffff), 0x81f1_6f39);
        assert_eq!(murmur3_32(&[0, 0, 0, 0], 0), 0x2362_f9de);
        assert_eq!(murmur3_32(b"aaaa", 0x9747_b28c), 0x5a97_808a);
        assert_eq!(murmur3_32(b"abc", 0), 0xb3dd_93fa);
        assert_eq!(murmur3_32(b"Hello, world!", 1234), 0xfaf6_cdb3);
        assert_eq!(
            murmur3_32(b"The quick brown fox jumps over the lazy dog", 0),
            0x2e4f_f723
        );
    }

    #[test]
    fn ids_are_finite_normal_floats() {
        for i in 0..10_000 {
            let id = name_id(&format!("node{i}"));
            assert!(id.is_finite() && (id == 0.0 || id.is_normal()), "{id}");
        }
    }

    #[test]
    fn ranks_sum_pairs_into_names_and_sort_by_coverage() {
        let pair = |o: &str, m: &str| MattePair {
            node: o.len(),
            object: o.into(),
            material: m.into(),
            asset: "root".into(),
        };
        let table = MatteTable {
            triangle_pairs: vec![],
            pairs: vec![pair("a", "red"), pair("b", "red"), pair("c", "blue")],
        };
        let c = Cryptomatte::parse("material,object,asset", 4).unwrap();
        assert_eq!(
            c.kinds,
            [MatteKind::Object, MatteKind::Material, MatteKind::Asset]
        );
        // One pixel of 10 kept samples: 3 on a, 2 on b, 4 on c, 1 missed.
        let slots = [[1, 3], [2, 2], [3, 4], [0, 0]];
        let layers = resolve_mattes(&slots, &[10], &table, &c, Vec::new());
        let object = &layers[0];
        assert_eq!(object.ranks[0], [name_id("c"), 0.4]);
        assert_eq!(object.ranks[1], [name_id("a"), 0.3]);
        assert_eq!(object.ranks[2], [name_id("b"), 0.2]);
        assert_eq!(object.ranks[3], [0.0, 0.0]);
        let material = &layers[1];
        assert_eq!(material.coverage("red"), [0.5]);
        assert_eq!(material.coverage("blue"), [0.4]);
        let asset = &layers[2];
        assert!((asset.coverage("root")[0] - 0.9).abs() < 1e-6);
        assert_eq!(object.manifest.len(), 3);
        let attrs = object.attributes();
        assert!(attrs[0].0.starts_with("cryptomatte/") && attrs[0].1 == "CryptoObject");
        assert!(attrs[3].1.contains("\"a\":\""));
    }

    #[test]
    fn options_are_checked() {
        assert_eq!(Cryptomatte::parse("object", 5).unwrap().depth, 6);
        assert!(Cryptomatte::parse("objects", 6)
            .unwrap_err()
            .0
            .contains("choose from object, material, asset"));
        assert!(Cryptomatte::parse("object", 0).is_err());
        assert!(Cryptomatte::parse("", 6).is_err());
    }
}
