//! The render flags that turn on every compositing pass: the AOVs,
//! Cryptomatte's three layers and the light-path passes (tests and
//! benches alike).

/// `soupray render` flags for every pass.
pub const EVERY_PASS: [&str; 6] = [
    "--aov",
    "depth,normal,albedo,motion,position,uv,object_id",
    "--cryptomatte",
    "object,material,asset",
    "--passes",
    "light",
];
