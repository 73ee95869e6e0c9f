//! Progress of a run, reported to an [`Observer`] that the caller attaches (a progress bar,
//! a log line, nothing): the library draws and prints nothing itself.

use std::ops::Range;
use std::path::Path;

/// What the trials being counted belong to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Phase {
    /// The trials of the campaign, or of the shard being run.
    Trials,
    /// The residual budget's reruns of the first trials ([`crate::residual_budget`]).
    ResidualBudget,
}

/// Receives the progress of a [`crate::CampaignRun`] or [`crate::SweepRun`]. Every method
/// has an empty default, so an observer implements only what it shows.
///
/// [`Observer::trials_done`] is called from the worker threads, concurrently and often
/// (once per trial): keep it cheap.
pub trait Observer: Sync {
    /// A phase of `total` trials starts.
    fn phase_started(&self, _phase: Phase, _total: u64) {}

    /// `k` more trials of the current phase are done. A run resumed from a checkpoint
    /// reports the checkpoint's trials at once.
    fn trials_done(&self, _k: u64) {}

    /// The current phase is over.
    fn phase_finished(&self, _phase: Phase) {}

    /// The run continues from the checkpoint at `checkpoint`, which holds trials `done` of
    /// the run's `trials`.
    fn resuming(&self, _checkpoint: &Path, _done: Range<u64>, _trials: Range<u64>) {}

    /// Point `point` (0-based) of a sweep of `points` points starts.
    fn sweep_point(&self, _point: usize, _points: usize) {}

    /// Something the user should know about the run that is not an error, e.g. where the
    /// outputs go when that is not the default place.
    fn note(&self, _message: &str) {}

    /// Whether the run should stop (an interrupted caller, e.g. Ctrl-C in Python). Asked
    /// before every trial, from the worker threads: keep it cheap. Once it is true the trials
    /// in progress finish, no other starts, and the run returns
    /// [`CampaignError::Stopped`](crate::CampaignError::Stopped) without writing its outputs
    /// (a checkpoint written before stays: the run resumes from it).
    fn stop_requested(&self) -> bool {
        false
    }
}

/// An observer that shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Observer for Silent {}
