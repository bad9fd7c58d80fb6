//! The progressive render loop: iterations into a film until the budget is
//! spent or the user interrupts, with a progress bar on stderr.
//!
//! Each iteration is one sample per pixel; the film keeps their sum, so the
//! image after any number of completed iterations is a correctly normalised
//! mean. That is what makes an interrupted render worth writing, and a
//! checkpoint of the film worth resuming (`checkpoint`).

use std::fmt;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use integrators::Renderer;
use integrators::film::Film;

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::settings::Budget;

/// Exit code of an interrupted render (128 + SIGINT, the shell convention).
pub const INTERRUPTED_EXIT_CODE: u8 = 130;

/// Set by the first Ctrl-C (or SIGTERM/SIGHUP); the loop checks it between iterations.
static INTERRUPT_REQUESTED: AtomicBool = AtomicBool::new(false);
/// Set while the image files are written: a second Ctrl-C then waits for the
/// write instead of leaving a half-written `.partial` file behind.
static WRITING: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler: the first interrupt asks the loop to stop
/// after the current iteration, a second one quits at once (exit code 130).
/// Failing to install it is a warning, not an error: the render still works.
pub fn install_interrupt_handler() {
    let installed = ctrlc::set_handler(|| {
        if !INTERRUPT_REQUESTED.swap(true, Ordering::SeqCst) {
            // On a terminal, leave the progress bar's line first.
            let newline = if std::io::stderr().is_terminal() {
                "\n"
            } else {
                ""
            };
            eprintln!(
                "{newline}interrupt: dropping the iteration in progress, then writing the image of \
                 the completed ones (interrupt again to quit without writing)"
            );
        } else if !WRITING.load(Ordering::SeqCst) {
            std::process::exit(i32::from(INTERRUPTED_EXIT_CODE));
        }
    });
    if let Err(e) = installed {
        eprintln!("warning: cannot catch Ctrl-C ({e}): an interrupt will quit without writing");
    }
}

/// Marks the start of file writing (see [`WRITING`]).
pub fn begin_writing() {
    WRITING.store(true, Ordering::SeqCst);
}

/// How a render loop ended.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// Iterations completed by this run (all in the film).
    pub iterations: u64,
    /// Iterations the film held before (resumed from a checkpoint).
    pub resumed: u64,
    /// Wall-clock time of the loop.
    pub elapsed: Duration,
    /// Wall-clock time of the film's iterations in all: earlier runs' (as
    /// their checkpoint says) and this loop's.
    pub rendered: Duration,
    /// Whether an interrupt ended it early.
    pub interrupted: bool,
}

/// Renders iterations into `film` until `budget` is spent or an interrupt
/// is requested: the iteration in progress is then abandoned within about
/// a second (it checks between rows and blocks of subpaths) and the film
/// keeps the completed ones.
///
/// The film may hold iterations already (resumed from a checkpoint, which
/// took `rendered_before`): rendering goes on from global index `first` +
/// their number, and the budget counts them (a time budget counts
/// `rendered_before`). Between iterations, `checkpoint` is saved when due;
/// a failed save ends the render with its error.
pub fn progressive(
    renderer: &Renderer,
    film: &mut Film,
    budget: Budget,
    first: u64,
    rendered_before: Duration,
    mut checkpoint: Option<&mut Checkpoint>,
) -> Result<Outcome, CheckpointError> {
    let pixels = film.width() as usize * film.height() as usize;
    let mut estimates = vec![Vec3::ZERO; pixels];
    let resumed = film.iterations();
    let bar = progress_bar(budget);
    let start = Instant::now();
    let rendered = || rendered_before + start.elapsed();
    let show = |n: u64| match budget {
        Budget::Iterations(_) => bar.set_position(n),
        Budget::Time(limit) => {
            bar.set_position(rendered().min(limit).as_millis() as u64);
            let rate = (n - resumed) as f64 / start.elapsed().as_secs_f64().max(1e-9);
            bar.set_message(format!("{n} it, {rate:.1} it/s"));
        }
    };
    show(resumed);
    let mut n = resumed;
    let interrupted = loop {
        // The budget first: an interrupt during the last iteration changes nothing.
        let done = match budget {
            Budget::Iterations(total) => n >= total,
            Budget::Time(limit) => n >= 1 && rendered() >= limit,
        };
        if done {
            break false;
        }
        if INTERRUPT_REQUESTED.load(Ordering::SeqCst) {
            break true;
        }
        // An interrupt abandons the iteration in progress (within a block
        // of work); the completed ones are kept.
        if !renderer.render_iteration_until(first + n, &mut estimates, &INTERRUPT_REQUESTED) {
            break true;
        }
        n += 1;
        film.add_iteration(&estimates);
        if let Some(c) = checkpoint.as_deref_mut()
            && c.is_due()
            && let Err(e) = c.save(film, rendered())
        {
            bar.finish_and_clear();
            return Err(e);
        }
        show(n);
    };
    bar.finish_and_clear();
    Ok(Outcome {
        iterations: n - resumed,
        resumed,
        elapsed: start.elapsed(),
        rendered: rendered(),
        interrupted,
    })
}

/// A bar on stderr (hidden when stderr is not a terminal): iterations, rate
/// and ETA for a count; time, iterations and rate for a time budget.
fn progress_bar(budget: Budget) -> ProgressBar {
    let (length, template) = match budget {
        Budget::Iterations(n) => (
            n,
            "{elapsed_precise} [{wide_bar}] {pos}/{len} it, {rate} it/s, ETA {eta}",
        ),
        Budget::Time(t) => (
            t.as_millis() as u64,
            "{elapsed_precise} [{wide_bar}] {msg}, {eta} left",
        ),
    };
    let style = ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .with_key("rate", |state: &ProgressState, w: &mut dyn fmt::Write| {
            let _ = write!(w, "{:.1}", state.per_sec());
        })
        .progress_chars("=> ");
    ProgressBar::with_draw_target(Some(length), ProgressDrawTarget::stderr()).with_style(style)
}
