//! Progress on stderr, one helper for every long command: a bar with an ETA on a terminal (indicatif),
//! plain whole lines at most once a second when stderr is a log file or a pipe (no carriage-return
//! fragments), nothing at all with `--quiet`. Messages (`note`) go through it so they never break a
//! bar.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences progress for the rest of the run (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// True with `--quiet`.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// A line on stderr that is not an error (what a command is about to do, a warning), unless quiet.
pub fn note(message: impl std::fmt::Display) {
    if !quiet() {
        eprintln!("{message}");
    }
}

/// Progress through counted work, possibly in several named phases.
pub struct Progress {
    bar: Option<ProgressBar>,
    phase: String,
    last_line: Option<Instant>,
    plain: bool,
}

impl Progress {
    /// A progress display; a bar where stderr is a terminal.
    pub fn new() -> Progress {
        let plain = !std::io::stderr().is_terminal();
        Progress { bar: None, phase: String::new(), last_line: None, plain }
    }

    /// `done` of `total` in `phase` are finished.
    pub fn update(&mut self, phase: &str, done: usize, total: usize) {
        if quiet() {
            return;
        }
        if self.plain {
            // Whole lines, throttled, with the last of each phase always shown.
            let due = self.last_line.is_none_or(|t| t.elapsed() >= Duration::from_secs(1));
            if phase != self.phase || done == total || due {
                eprintln!("  {phase} {done}/{total}");
                self.last_line = Some(Instant::now());
                self.phase = phase.to_string();
            }
            return;
        }
        if phase != self.phase || self.bar.is_none() {
            self.finish();
            let bar = ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr());
            let style =
                ProgressStyle::with_template("  {msg:<14} [{bar:30}] {pos}/{len}, {elapsed} (about {eta} left)")
                    .expect("a fixed template")
                    .progress_chars("=> ");
            bar.set_style(style);
            bar.set_message(phase.to_string());
            self.bar = Some(bar);
            self.phase = phase.to_string();
        }
        if let Some(bar) = &self.bar {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            if done == total {
                self.finish();
            }
        }
    }

    /// Ends the current bar, leaving its last state on screen.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        // An error mid-phase: leave the bar where it stopped, then the error below it.
        if let Some(bar) = self.bar.take() {
            bar.abandon();
        }
    }
}
