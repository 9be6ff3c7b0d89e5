//! The binary's commands, kept apart from the pipeline's stages: each one
//! parses its options, calls the stages in order and reports what they did.
//!
//! - `render` (with `frames`, which names the frames and their files): the
//!   batch job;
//! - `bench`: the speed/accuracy sweep of one frame;
//! - `report`: tables and charts from a render's frame logs;
//! - `bvh` (`bvh`, `devices`): one tree build and the OpenCL devices;
//! - `scene` (`info`, `soup`): what a glTF file holds, and one frame's soup.

pub mod bench;
pub mod bvh;
pub mod frames;
pub mod render;
pub mod report;
pub mod scene;
