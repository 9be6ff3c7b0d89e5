//! How a render job talks to the person or the farm watching it (progress
//! bars and lines), and how it hears SIGINT/SIGTERM.

use super::{JobError, RenderArgs};
use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// How the job talks to the person or the farm watching it.
pub(super) struct Progress {
    bars: Option<(
        indicatif::MultiProgress,
        indicatif::ProgressBar,
        indicatif::ProgressBar,
    )>,
    quiet: bool,
    pub verbose: bool,
}

impl Progress {
    pub(super) fn new(frames: usize, spp: u32, args: &RenderArgs) -> Progress {
        let bars = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
            let multi = indicatif::MultiProgress::new();
            let style = indicatif::ProgressStyle::with_template(
                "{prefix:>8} [{bar:40}] {pos}/{len} {msg} ETA {eta}",
            )
            .expect("a valid template")
            .progress_chars("=> ");
            let frames_bar = multi.add(indicatif::ProgressBar::new(frames as u64));
            frames_bar.set_style(style.clone());
            frames_bar.set_prefix("frames");
            let samples = multi.add(indicatif::ProgressBar::new(spp as u64));
            samples.set_style(style);
            samples.set_prefix("samples");
            (multi, frames_bar, samples)
        });
        Progress {
            bars,
            quiet: args.quiet,
            verbose: args.verbose,
        }
    }

    /// A line for the person or the farm log, above the bars on a terminal.
    pub(super) fn line(&self, text: &str) {
        if self.quiet {
            return;
        }
        match &self.bars {
            Some((multi, _, _)) => {
                let _ = multi.println(text);
            }
            None => eprintln!("{text}"),
        }
    }

    pub(super) fn warn(&self, text: &str) {
        match &self.bars {
            Some((multi, _, _)) => {
                let _ = multi.println(format!("warning: {text}"));
            }
            None => eprintln!("warning: {text}"),
        }
    }

    pub(super) fn frame_started(&self, frame: i64) {
        if let Some((_, frames, samples)) = &self.bars {
            frames.set_message(format!("frame {frame}"));
            samples.set_position(0);
        }
    }

    pub(super) fn samples(&self, done: u32) {
        if let Some((_, _, samples)) = &self.bars {
            samples.set_position(done as u64);
        }
    }

    pub(super) fn frame_finished(&self) {
        if let Some((_, frames, _)) = &self.bars {
            frames.inc(1);
        }
    }

    pub(super) fn finish(&self) {
        if let Some((_, frames, samples)) = &self.bars {
            samples.finish_and_clear();
            frames.finish();
        }
    }
}

/// SIGINT/SIGTERM. While the scene loads and the device is set up (nothing
/// of ours is being written), a signal ends the process at once with
/// 128 + signal.
/// Once frames render, the handler records it and the job stops cleanly
/// between stages; a second signal of either kind ends the process at once.
pub(super) struct Signals {
    received: Arc<AtomicUsize>,
    /// When set, the next signal exits at once. Set during set-up and by
    /// the first signal while rendering.
    immediate: Arc<std::sync::atomic::AtomicBool>,
}

impl Signals {
    pub(super) fn install() -> Signals {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let received = Arc::new(AtomicUsize::new(0));
        let immediate = Arc::new(std::sync::atomic::AtomicBool::new(true));
        for sig in [SIGINT, SIGTERM] {
            // Runs first: exits (with 128 + signal, as a shell would) when
            // `immediate` is set.
            let _ = signal_hook::flag::register_conditional_shutdown(
                sig,
                128 + sig,
                Arc::clone(&immediate),
            );
            let flag = Arc::clone(&received);
            // SAFETY: the handler only stores to an atomic.
            let _ = unsafe {
                signal_hook::low_level::register(sig, move || {
                    flag.store(sig as usize, Ordering::SeqCst);
                })
            };
            // A second signal exits at once.
            let _ = signal_hook::flag::register(sig, Arc::clone(&immediate));
        }
        Signals {
            received,
            immediate,
        }
    }

    /// From now on a first signal stops the job cleanly instead of at once
    /// (a signal that came in the meantime is reported by `check`).
    pub(super) fn deferred(&self) {
        self.immediate.store(false, Ordering::SeqCst);
    }

    /// From now on a signal ends the process at once again.
    pub(super) fn immediate(&self) {
        self.immediate.store(true, Ordering::SeqCst);
    }

    pub(super) fn check(&self) -> Result<(), JobError> {
        match self.received.load(Ordering::SeqCst) as i32 {
            0 => Ok(()),
            signal => Err(JobError::Interrupted {
                signal,
                name: if signal == signal_hook::consts::SIGTERM {
                    "SIGTERM"
                } else {
                    "SIGINT"
                },
            }),
        }
    }
}
