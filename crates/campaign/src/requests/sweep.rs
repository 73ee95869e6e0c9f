//! A sweep to run end to end, as `kincal sweep` and `cargo xtask regenerate` ask for it:
//! [`SweepRun`] loads the sweep file, applies the caller's overrides, runs every point on
//! its own thread pool (with checkpoints if asked), and writes the sweep's outputs all or
//! nothing.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::CampaignError;
use crate::observer::Observer;
use crate::requests::campaign::{
    Checkpointing, default_out, lock_out_dir, scratch_out, thread_pool, visible_files,
};
use crate::run::checkpoint::finish;
use crate::sweep::plots::render_sweep_outputs;
use crate::sweep::spec::{SweepResult, SweepSpec, run_sweep_checkpointed};

/// The name of a sweep's checkpoint file in its output directory.
pub const SWEEP_CHECKPOINT: &str = "sweep-checkpoint.json";

/// A sweep to run: a sweep file and the caller's overrides.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct SweepRun {
    /// The sweep file (JSON); its base scenario is relative to it.
    pub sweep: PathBuf,
    /// Override the trials per point (at least 1).
    pub trials: Option<u64>,
    /// Worker threads (`None`: all cores). The results do not depend on it.
    pub threads: Option<usize>,
    /// Output directory (`None`: `results/<sweep name>`).
    pub out: Option<PathBuf>,
    /// Checkpoint the run into [`SWEEP_CHECKPOINT`] (`None`: no checkpoint).
    pub checkpoint: Option<Checkpointing>,
}

/// What a [`SweepRun`] did.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct SweepOutcome {
    /// Every point's figures (what `sweep.json` holds).
    pub result: SweepResult,
    /// The output directory.
    pub out: PathBuf,
    /// Wall clock, s.
    pub seconds: f64,
}

impl SweepRun {
    /// The sweep of the sweep file `sweep` as the file says: all cores, output in
    /// `results/<sweep name>`, no checkpoint.
    pub fn new(sweep: impl Into<PathBuf>) -> SweepRun {
        SweepRun {
            sweep: sweep.into(),
            trials: None,
            threads: None,
            out: None,
            checkpoint: None,
        }
    }

    /// Runs every point of the sweep and writes `sweep.json`, `sweep.csv`, `sweep.md`, the
    /// plots and `report.html` (all or nothing); a finished sweep removes its checkpoint.
    pub fn run(&self, observer: &dyn Observer) -> Result<SweepOutcome, CampaignError> {
        // Every setting is checked before any work starts.
        if self.trials == Some(0) {
            return Err(CampaignError::ZeroTrials);
        }
        if self.threads == Some(0) {
            return Err(CampaignError::ZeroThreads);
        }
        self.checkpoint.map(Checkpointing::check).transpose()?;
        let mut spec = SweepSpec::from_file(&self.sweep)?;
        let committed_trials = spec.trials;
        if let Some(t) = self.trials {
            spec.trials = t;
        }
        let dir = self.sweep.parent().unwrap_or(Path::new("."));
        // Every point's scenario and the plots' settings, before any point runs.
        spec.validate(&self.sweep)?;
        let (pool, _) = thread_pool(self.threads)?;
        let started = Instant::now();
        let out = match &self.out {
            Some(out) => out.clone(),
            None => match self.trials.filter(|t| *t != committed_trials) {
                None => default_out(&spec.name),
                Some(t) => {
                    let out = scratch_out(&spec.name, &[format!("trials-{t}")]);
                    observer.note(&format!(
                        "the settings differ from {} (trials-{t}): writing to {}, not {} \
                         (which holds the committed sweep's results; name an output directory \
                         to choose)",
                        self.sweep.display(),
                        out.display(),
                        default_out(&spec.name).display()
                    ));
                    out
                }
            },
        };
        let held = lock_out_dir(&out)?;
        let checkpoint_path = out.join(SWEEP_CHECKPOINT);
        let result = pool.install(|| {
            // The chunk size is taken on the sweep's pool.
            let checkpoint = self.checkpoint.map(|c| c.config(checkpoint_path.clone()));
            run_sweep_checkpointed(&spec, dir, checkpoint.as_ref(), &|i, n| {
                observer.sweep_point(i, n)
            })
        })?;
        let files = render_sweep_outputs(&result)?;
        // The new set replaces the old one as a whole; the checkpoint goes with the old one.
        let dropped: &[&str] = if self.checkpoint.is_some() {
            &[SWEEP_CHECKPOINT]
        } else {
            &[]
        };
        held.write_set_dropping(&files, dropped)?;
        if self.checkpoint.is_some() {
            finish(&checkpoint_path, &visible_files(&out))?;
        }
        drop(held);
        Ok(SweepOutcome {
            result,
            out,
            seconds: started.elapsed().as_secs_f64(),
        })
    }
}
