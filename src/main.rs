//! The `soupray` binary: parses the command line and hands each command to
//! the library. Exit codes are documented in `--help` and the README.

use clap::{Parser, Subcommand};
use soupray::cli::{bvh as cli_bvh, scene as cli_scene};
use std::process::ExitCode;

/// soupray: an offline path tracer for glTF animations.
///
/// Each frame is evaluated into a world-space triangle soup, a full
/// binned-SAH BVH is rebuilt from it on an OpenCL device (PoCL on the CPU,
/// or a GPU's driver), and the frame is traced.
#[derive(Parser, Debug)]
#[command(name = "soupray", version, after_help = soupray::EXIT_CODES, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    Devices(cli_bvh::DevicesArgs),
    Bvh(cli_bvh::BvhArgs),
    Info(cli_scene::InfoArgs),
    Soup(cli_scene::SoupArgs),
    Render(Box<soupray::cli::render::RenderArgs>),
    Bench(soupray::cli::bench::BenchArgs),
    Report(soupray::cli::report::ReportArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let result = match &cli.command {
        Command::Devices(a) => cli_bvh::run_devices(a),
        Command::Bvh(a) => cli_bvh::run_bvh(a),
        Command::Info(a) => cli_scene::run_info(a),
        Command::Soup(a) => cli_scene::run_soup(a),
        Command::Render(a) => soupray::cli::render::run_render(a),
        Command::Bench(a) => soupray::cli::bench::run_bench(a),
        Command::Report(a) => soupray::cli::report::run_report(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("soupray: error: {e:#}");
            ExitCode::from(exit_code(&e))
        }
    }
}

/// The exit code for an error, from the kind of failure in its chain.
fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if let Some(j) = cause.downcast_ref::<soupray::cli::render::JobError>() {
            return match j {
                soupray::cli::render::JobError::Interrupted { signal, .. } => (128 + signal) as u8,
                soupray::cli::render::JobError::FramesFailed { .. } => 5,
            };
        }
        if cause.is::<soupray::pipeline::FrameError>() {
            return 5;
        }
        if cause.is::<soupray::cli::frames::OutputDirError>() {
            return 6;
        }
        if cause.is::<soupray::UsageError>() {
            return 2;
        }
        if cause.is::<soupray::device::DeviceError>() {
            return 3;
        }
        if let Some(d) = cause.downcast_ref::<soupray::denoise::DenoiseError>() {
            return if d.is_setup() { 3 } else { 5 };
        }
        if let Some(b) = cause.downcast_ref::<soupray::bvh::binned::BuildError>() {
            return match b {
                soupray::bvh::binned::BuildError::Device(_) => 3,
                soupray::bvh::binned::BuildError::Params(_) => 2,
                _ => 5,
            };
        }
        if let Some(s) = cause.downcast_ref::<soupray::soup::device::SoupError>() {
            return match s {
                soupray::soup::device::SoupError::Device(_) => 3,
                soupray::soup::device::SoupError::Scene(_) => 4,
                _ => 5,
            };
        }
        if cause.is::<soupray::scene::SceneError>()
            || cause.is::<soupray::ply::PlyError>()
            || cause.is::<soupray::trace::lights::EnvError>()
            || cause.is::<soupray::input::InputError>()
        {
            return 4;
        }
        if let Some(soupray::trace::TraceError::Env(_)) = cause.downcast_ref() {
            return 4;
        }
        if let Some(o) = cause.downcast_ref::<soupray::output::OutputError>() {
            return match o {
                // Reading a render's logs (`report`): the input.
                soupray::output::OutputError::BadLog { .. }
                | soupray::output::OutputError::Read { .. } => 4,
                _ => 6,
            };
        }
    }
    1
}
