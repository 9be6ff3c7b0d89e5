//! What resolving a frame's sums into its image costs on the host with
//! every compositing pass: `film::resolve` (the beauty, the AOVs, the
//! light passes, the Cryptomatte ranks and the object ids), at the shipped
//! animation's 640x360 and 16 samples per pixel. The device is idle while
//! this runs, so it is time the frame waits.
//!
//! ```text
//! cargo bench --bench film_resolve
//! cargo bench --bench film_resolve -- --runs 31
//! ```
//!
//! The sums are made up (the device's are not written anywhere), with
//! what a real frame has: every pixel 16 samples, a few dropped, some
//! pixels that hit nothing, one to three matte pairs a pixel of the 204
//! the walker's soup has. Each run resolves the frame on every thread
//! (rayon's pool, as `soupray render` does) and on one, one after the
//! other, reusing the last frame's buffers as the renderer does; the table
//! gives their medians and ratio.

mod support;

use soupray::cli::report::median;
use soupray::film::light::LIGHT_PASSES;
use soupray::film::{self, Accumulated, Aovs, Cryptomatte, Image};
use soupray::scene::mattes::{MattePair, MatteTable};
use std::time::Instant;
use support::flag;

const WIDTH: u32 = 640;
const HEIGHT: u32 = 360;
const SPP: f32 = 16.0;
const PAIRS: usize = 204;

/// Marsaglia's xorshift32 from `state` (not 0).
fn xorshift(mut state: u32) -> impl FnMut() -> u32 {
    move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    }
}

/// A frame's sums as the device leaves them, from fixed seeds.
fn sums(cryptomatte: &Cryptomatte) -> Accumulated {
    let pixels = (WIDTH * HEIGHT) as usize;
    let mut next = xorshift(0x9e37_79b9);
    let mut unit = move || (next() >> 8) as f32 / (1u32 << 24) as f32;
    let mut quads = |n: usize, scale: f32| -> Vec<[f32; 4]> {
        (0..n)
            .map(|_| {
                [
                    unit() * scale,
                    unit() * scale,
                    unit() * scale,
                    unit() * scale,
                ]
            })
            .collect()
    };
    let color = quads(pixels, SPP);
    let (normal, albedo) = (quads(pixels, SPP), quads(pixels, SPP));
    let snapshots = quads(2 * pixels, SPP);
    let (motion, geometry) = (quads(pixels, SPP), quads(2 * pixels, SPP));
    let light = quads(3 * LIGHT_PASSES as usize * pixels / 4, SPP).concat();
    let mut next = xorshift(7);
    let aux = (0..pixels)
        .map(|_| {
            let r = next();
            let hits = if r.is_multiple_of(10) { 0.0 } else { SPP };
            let dropped = if r.is_multiple_of(97) { 1.0 } else { 0.0 };
            [hits * 3.0, hits, dropped, SPP]
        })
        .collect();
    let slots = cryptomatte.slots() as usize;
    let mut matte_slots = vec![[0u32; 2]; pixels * slots];
    for pixel in matte_slots.chunks_mut(slots) {
        let r = next();
        let hit = 1 + r as usize % 3;
        for (k, slot) in pixel.iter_mut().take(hit).enumerate() {
            *slot = [
                1 + (r as usize / 7 + k) as u32 % PAIRS as u32,
                16 / hit as u32,
            ];
        }
    }
    Accumulated {
        color,
        normal,
        albedo,
        snapshots,
        aux,
        rays: vec![40; pixels],
        motion,
        geometry,
        catcher: Vec::new(),
        matte_slots,
        light,
    }
}

fn table() -> MatteTable {
    MatteTable {
        triangle_pairs: Vec::new(),
        pairs: (0..PAIRS)
            .map(|k| MattePair {
                node: k / 4,
                object: format!("node{}", k / 4),
                material: format!("material{}", k % 5),
                asset: "walker".to_owned(),
            })
            .collect(),
    }
}

fn main() {
    let runs: usize = flag("--runs").and_then(|r| r.parse().ok()).unwrap_or(15);
    let aovs = Aovs::parse("depth,normal,albedo,motion,position,uv,object_id")
        .and_then(|a| a.with_light_passes("light"))
        .expect("every AOV");
    let cryptomatte = Cryptomatte::parse("object,material,asset", 6).expect("every layer");
    let table = table();
    let acc = sums(&cryptomatte);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    // The host's part of a frame, as the tracer does it after reading the
    // sums back.
    let resolve = |spare: Option<Image>| {
        let (c, t) = (Some(&cryptomatte), Some(&table));
        film::resolve(&acc, WIDTH, HEIGHT, aovs, c, t, spare).image
    };
    let threads = rayon::current_num_threads();
    let (mut all, mut single) = (Vec::new(), Vec::new());
    let (mut spare_all, mut spare_one) = (None, None);
    // One run of each first: the buffers' pages are touched once.
    for run in 0..=runs {
        let t = Instant::now();
        let image = resolve(spare_all.take());
        let ms_all = t.elapsed().as_secs_f64() * 1e3;
        spare_all = Some(image);
        let t = Instant::now();
        let image = one.install(|| resolve(spare_one.take()));
        let ms_one = t.elapsed().as_secs_f64() * 1e3;
        spare_one = Some(image);
        if run > 0 {
            all.push(ms_all);
            single.push(ms_one);
        }
    }
    assert_eq!(spare_all, spare_one, "the threads change no value");
    let (a, s) = (median(all), median(single));
    println!("host resolve of a {WIDTH}x{HEIGHT} frame with every pass, median of {runs} runs");
    println!("| threads | ms | ratio |");
    println!("|---|---:|---:|");
    println!("| 1 | {s:.1} | 1.00 |");
    println!("| {threads} | {a:.1} | {:.2} |", a / s);
}
