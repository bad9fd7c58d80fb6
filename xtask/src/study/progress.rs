//! Progress of a study: indicatif bars on a terminal, plain lines otherwise.

use std::fmt;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Progress: on a terminal, a bar per render and an overall bar with the
/// ETA of the whole study (indicatif, on stderr); otherwise plain lines on
/// stdout, at most one every 15 s per render, with the same ETA.
pub(super) struct Progress {
    multi: MultiProgress,
    overall: ProgressBar,
    terminal: bool,
    total: u64,
    done: u64,
    started: Instant,
    last_line: Instant,
}

const PLAIN_LINE_INTERVAL: Duration = Duration::from_secs(15);

impl Progress {
    pub(super) fn new(total: u64) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let multi = MultiProgress::with_draw_target(if terminal {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        let overall = multi.add(ProgressBar::new(total));
        overall.set_style(style(
            "{prefix:>12} [{wide_bar}] {pos}/{len} it, {elapsed_precise}, ETA {eta_precise}",
        ));
        overall.set_prefix("overall");
        Self {
            multi,
            overall,
            terminal,
            total,
            done: 0,
            started: Instant::now(),
            last_line: Instant::now(),
        }
    }

    /// A bar for a render of `iterations`, `done` of them done already (a
    /// resumed render), which the study's total then leaves out.
    pub(super) fn start(&mut self, label: &str, iterations: u64, done: u64) -> ProgressBar {
        let bar = self
            .multi
            .insert_before(&self.overall, ProgressBar::new(iterations));
        bar.set_style(style(
            "{prefix:>12} [{wide_bar}] {pos}/{len} it, {rate} it/s, ETA {eta}",
        ));
        bar.set_prefix(label.to_string());
        bar.set_position(done);
        self.total = self.total.saturating_sub(done);
        self.overall.set_length(self.total);
        if !self.terminal {
            if done > 0 {
                println!("{label}: {iterations} iterations, from {}", done + 1);
            } else {
                println!("{label}: {iterations} iterations");
            }
        }
        self.last_line = Instant::now();
        bar
    }

    pub(super) fn advance(
        &mut self,
        bar: &ProgressBar,
        label: &str,
        n: u64,
        iterations: u64,
        seconds: f64,
    ) {
        self.done += 1;
        bar.set_position(n);
        self.overall.set_position(self.done);
        if !self.terminal && n < iterations && self.last_line.elapsed() >= PLAIN_LINE_INTERVAL {
            self.last_line = Instant::now();
            println!(
                "  {label}: {n}/{iterations} iterations, {seconds:.1} s; study ETA {}",
                self.eta()
            );
        }
    }

    /// Remaining time of the study at its average rate so far.
    fn eta(&self) -> String {
        let elapsed = self.started.elapsed().as_secs_f64();
        if self.done == 0 {
            return "?".into();
        }
        let left = elapsed / self.done as f64 * self.total.saturating_sub(self.done) as f64;
        format!("{:.0} s", left)
    }

    pub(super) fn println(&self, line: &str) {
        if self.terminal {
            let _ = self.multi.println(line);
        } else {
            println!("{line}");
        }
    }

    pub(super) fn finish(&self) {
        self.overall.finish_and_clear();
    }
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .with_key(
            "rate",
            |state: &indicatif::ProgressState, w: &mut dyn fmt::Write| {
                let _ = write!(w, "{:.1}", state.per_sec());
            },
        )
        .progress_chars("=> ")
}
