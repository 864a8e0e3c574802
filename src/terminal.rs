//! The command line's progress and messages: a bar per phase on a terminal, a line every
//! [`log_every`] elsewhere, warnings always (the library's [`Ui`]).

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use lightlearn::commands::Ui;

use super::one_line;

/// Progress on a terminal (a bar per phase, 0..BAR_STEPS = fraction done) and messages on
/// stderr; `quiet` keeps only warnings. Where stderr is not a terminal (a farm's log, a
/// pipe) progress is a line every [`log_every`] instead: a long render there printed
/// nothing after its first line and looked hung (an audit, 2026-12-06).
pub struct Terminal {
    bar: Option<ProgressBar>,
    quiet: bool,
    /// The label, when it began (its first progress) and when its last progress line was
    /// logged (no terminal): `compare` reports sampler after sampler in one phase.
    logged: Option<(String, Instant, Instant)>,
}

/// The bar's steps: with 1000 a render of hours stayed at step 0 for minutes and its ETA
/// read "0s" (1e9 spp of one pixel; an audit, 2026-12-06).
const BAR_STEPS: u64 = 1_000_000;
/// How often progress is logged where stderr is not a terminal: every 30 s, or every
/// `LIGHTLEARN_PROGRESS_EVERY` seconds.
fn log_every() -> Duration {
    std::env::var("LIGHTLEARN_PROGRESS_EVERY")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0 && *s < 1e9)
        .map_or(Duration::from_secs(30), Duration::from_secs_f64)
}

impl Terminal {
    pub fn new(quiet: bool) -> Terminal {
        Terminal {
            bar: None,
            quiet,
            logged: None,
        }
    }

    fn log_progress(&mut self, label: &str, spp: u32, fraction: f64) {
        let now = Instant::now();
        if self.logged.as_ref().is_none_or(|(l, _, _)| l != label) {
            self.logged = Some((label.to_string(), now, now));
        }
        let Some((_, start, last)) = self.logged.as_mut() else {
            return;
        };
        if now.duration_since(*last) < log_every() {
            return;
        }
        *last = now;
        let elapsed = now.duration_since(*start).as_secs_f64();
        let left = if fraction > 0.0 {
            format!(
                ", about {:.0} s left",
                elapsed * (1.0 - fraction) / fraction
            )
        } else {
            String::new()
        };
        say!(
            "{label}: {spp} spp, {:.1} % after {elapsed:.0} s{left}",
            100.0 * fraction
        );
    }
}

impl Ui for Terminal {
    fn progress(&mut self, label: &str, spp: u32, fraction: f64) {
        if self.quiet {
            return;
        }
        if !std::io::stderr().is_terminal() {
            self.log_progress(label, spp, fraction);
            return;
        }
        let bar = self.bar.get_or_insert_with(|| {
            let b = ProgressBar::new(BAR_STEPS);
            b.set_style(
                ProgressStyle::with_template(
                    "{bar:40.cyan/blue} {percent:>3}% {msg} [{elapsed_precise} / ETA {eta}]",
                )
                .expect("valid template"),
            );
            b
        });
        bar.set_position((fraction * BAR_STEPS as f64) as u64);
        bar.set_message(format!("{label}: {spp} spp"));
    }

    fn phase_done(&mut self) {
        self.logged = None;
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }

    fn message(&mut self, line: &str) {
        let line = one_line(line);
        if !self.quiet || line.starts_with("warning:") {
            match &self.bar {
                Some(b) => b.suspend(|| say!("{line}")),
                None => say!("{line}"),
            }
        }
    }
}
