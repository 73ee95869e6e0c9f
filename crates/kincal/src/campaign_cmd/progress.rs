//! Progress of a campaign or a sweep on stderr: a bar on a terminal, plain lines otherwise
//! (the campaign crate's [`Observer`]).

use std::io::IsTerminal as _;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use campaign::{Observer, Phase};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Progress on stderr. On a terminal: a bar per phase of trials (hidden when `CI` is set).
/// Otherwise (stderr redirected to a file or a pipe, a batch job's log): a plain line every
/// 10 s (`KINCAL_PROGRESS_SECONDS` sets the interval), e.g. `trials: 12,288 of 1,000,000
/// (1.2 %), 169/s, about 1 h 37 min left`, and one when a phase ends. Also a line per sweep
/// point if asked, the line `resuming from …` when a run continues a checkpoint, and the
/// library's notes (`note: …`).
pub struct Progress {
    bar: Mutex<Option<ProgressBar>>,
    done: AtomicU64,
    points: bool,
    /// Plain lines instead of a bar (stderr is not a terminal).
    plain: Option<Mutex<PlainProgress>>,
}

/// The state of the plain progress lines.
struct PlainProgress {
    phase: &'static str,
    total: u64,
    started: Instant,
    last: Instant,
    every: Duration,
}

impl Progress {
    /// Progress bars (plain lines when stderr is not a terminal), and a line per sweep point
    /// when `points`.
    pub fn new(points: bool) -> Progress {
        let plain = (!std::io::stderr().is_terminal()).then(|| {
            let every = std::env::var("KINCAL_PROGRESS_SECONDS")
                .ok()
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|s| s.is_finite() && *s >= 0.0)
                .map_or(Duration::from_secs(10), Duration::from_secs_f64);
            Mutex::new(PlainProgress {
                phase: "trials",
                total: 0,
                started: Instant::now(),
                last: Instant::now(),
                every,
            })
        });
        Progress {
            bar: Mutex::new(None),
            done: AtomicU64::new(0),
            points,
            plain,
        }
    }

    fn bar(&self) -> std::sync::MutexGuard<'_, Option<ProgressBar>> {
        self.bar.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// `1 h 37 min`, `4 min 10 s`, `12 s`.
fn duration_in_words(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s / 60 % 60),
    }
}

impl PlainProgress {
    /// The line for `done` trials of the phase.
    fn line(&self, done: u64) -> String {
        let elapsed = self.started.elapsed().as_secs_f64();
        let rate = done as f64 / elapsed.max(1e-9);
        let pct = 100.0 * done as f64 / self.total.max(1) as f64;
        let left = if rate > 0.0 && done < self.total {
            format!(
                ", about {} left",
                duration_in_words((self.total - done) as f64 / rate)
            )
        } else {
            String::new()
        };
        format!(
            "{}: {} of {} ({pct:.1} %), {}/s, {} elapsed{left}",
            self.phase,
            report::fmt::whole(done as f64),
            report::fmt::whole(self.total as f64),
            report::fmt::rate(rate),
            duration_in_words(elapsed),
        )
    }
}

fn progress_bar(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    if std::env::var_os("CI").is_some() {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} trials  {trials_per_sec}/s  ETA {eta}  {elapsed_precise}",
        )
        .expect("valid template")
        // A whole number of trials per second, thousands separated (not indicatif's
        // `1,834.4204/s`).
        .with_key(
            "trials_per_sec",
            |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(&report::fmt::rate(state.per_sec()));
            },
        ),
    );
    pb
}

impl Observer for Progress {
    fn phase_started(&self, phase: Phase, total: u64) {
        self.done.store(0, Ordering::Relaxed);
        if let Some(plain) = &self.plain {
            let mut p = plain.lock().unwrap_or_else(|e| e.into_inner());
            p.phase = match phase {
                Phase::ResidualBudget => "residual budget trials",
                _ => "trials",
            };
            p.total = total;
            p.started = Instant::now();
            p.last = Instant::now();
            return;
        }
        *self.bar() = Some(progress_bar(total));
    }

    /// Moves the bar every 16 trials; a plain line when the interval has passed.
    fn trials_done(&self, k: u64) {
        let d = self.done.fetch_add(k, Ordering::Relaxed) + k;
        if let Some(plain) = &self.plain {
            // Never waits: a worker that finds the lock taken goes on.
            if let Ok(mut p) = plain.try_lock()
                && p.last.elapsed() >= p.every
                && d < p.total
            {
                p.last = Instant::now();
                crate::errln!("{}", p.line(d));
            }
            return;
        }
        if d.is_multiple_of(16)
            && let Some(pb) = self.bar().as_ref()
        {
            pb.set_position(d);
        }
    }

    fn phase_finished(&self, _phase: Phase) {
        if let Some(plain) = &self.plain {
            let p = plain.lock().unwrap_or_else(|e| e.into_inner());
            if p.total > 0 {
                crate::errln!("{}", p.line(self.done.load(Ordering::Relaxed)));
            }
            return;
        }
        if let Some(pb) = self.bar().take() {
            pb.finish_and_clear();
        }
    }

    fn note(&self, message: &str) {
        crate::errln!("note: {message}");
    }

    fn resuming(
        &self,
        checkpoint: &std::path::Path,
        done: std::ops::Range<u64>,
        trials: std::ops::Range<u64>,
    ) {
        crate::errln!(
            "resuming from {}: trials {}..{} of {}..{} done",
            checkpoint.display(),
            done.start,
            done.end,
            trials.start,
            trials.end
        );
    }

    fn sweep_point(&self, point: usize, points: usize) {
        if self.points {
            crate::errln!("point {}/{points}", point + 1);
        }
    }
}
