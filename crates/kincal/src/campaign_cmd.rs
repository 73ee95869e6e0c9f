//! `kincal campaign | merge | simulate | sweep`: parse the arguments into the campaign
//! crate's requests ([`campaign::CampaignRun`], [`campaign::MergeRun`],
//! [`campaign::SimulateRun`], [`campaign::SweepRun`]), run them with a progress bar, print.

mod args;
mod progress;

use anyhow::{Context as _, Result};
use campaign::{
    CampaignError, CampaignOutcome, CampaignRun, Checkpointing, MergeRun, Shard, SimulateRun,
    SweepOutcome, SweepRun,
};
use report::fmt;

pub use args::{CampaignArgs, CheckpointArgs, MergeArgs, SimulateArgs, SweepArgs};
pub use progress::Progress;

/// The library's error, with the command-line option it is about (if any) in front of it;
/// `out_given`: the output directory came from `--out`.
fn with_option(e: CampaignError, out_given: bool) -> anyhow::Error {
    let option = match &e {
        CampaignError::ZeroTrials => "--trials 0".to_string(),
        CampaignError::ZeroCheckpointInterval => "--checkpoint-every 0".to_string(),
        CampaignError::ZeroThreads => "--threads 0".to_string(),
        CampaignError::OutputIsAFile { path } | CampaignError::CreateDir { path, .. }
            if out_given =>
        {
            format!("--out {}", path.display())
        }
        CampaignError::Output(
            measurements::OutputError::Target { path, .. }
            | measurements::OutputError::Unswappable { path, .. }
            | measurements::OutputError::Locked { path, .. },
        ) if out_given => format!("--out {}", path.display()),
        CampaignError::UnfinishedCheckpoint { .. } => {
            "--resume not given (pass it to continue the unfinished run)".to_string()
        }
        _ => return e.into(),
    };
    anyhow::Error::new(e).context(option)
}

/// `--shard k/K`.
fn parse_shard(s: &str) -> Result<Shard> {
    let (k, n) = s
        .split_once('/')
        .with_context(|| format!("--shard {s:?}: expected k/K, e.g. 0/4"))?;
    let k: u64 = k
        .trim()
        .parse()
        .with_context(|| format!("--shard {s:?}: k"))?;
    let n: u64 = n
        .trim()
        .parse()
        .with_context(|| format!("--shard {s:?}: K"))?;
    Shard::new(k, n).with_context(|| format!("--shard {s:?}"))
}

fn checkpointing(args: &CheckpointArgs) -> Checkpointing {
    Checkpointing {
        resume: args.resume,
        every_trials: args.checkpoint_every,
    }
}

/// `--threads`, capped by [`campaign::cap_threads`], with a note when it was.
fn capped_threads(threads: Option<usize>) -> Option<usize> {
    threads.map(|t| {
        let (t, note) = campaign::cap_threads(t);
        if let Some(note) = note {
            crate::errln!("note: --threads {note}");
        }
        t
    })
}

/// `kincal campaign`.
pub fn campaign(args: CampaignArgs) -> Result<()> {
    let mut run = CampaignRun::new(&args.scenario);
    run.trials = args.trials;
    run.iso_off = args.no_iso;
    run.budget_off = args.no_budget;
    run.threads = capped_threads(args.threads);
    run.shard = args.shard.as_deref().map(parse_shard).transpose()?;
    run.checkpoint = Some(checkpointing(&args.checkpoint));
    let out_given = args.out.is_some();
    run.out = args.out;
    let outcome = run
        .run(&Progress::new(false))
        .map_err(|e| with_option(e, out_given))?;
    print_campaign(&outcome, args.quiet);
    Ok(())
}

/// Prints what a campaign did: the summary table (unless `quiet`) on stdout, the trial
/// count, wall clock and output on stderr.
pub fn print_campaign(outcome: &CampaignOutcome, quiet: bool) {
    match outcome {
        CampaignOutcome::Campaign {
            summary,
            out,
            threads,
            seconds,
        } => {
            if !quiet {
                crate::outln!("{}", summary.to_markdown());
            }
            crate::errln!(
                "{} trials in {} s on {threads} thread(s) → {}",
                summary.scenario.trials,
                fmt::secs(*seconds),
                out.display()
            );
        }
        CampaignOutcome::Shard {
            shard,
            trials,
            file,
            seconds,
        } => crate::errln!(
            "shard {shard}: trials {}..{} in {} s → {}",
            trials.start,
            trials.end,
            fmt::secs(*seconds),
            file.display()
        ),
        _ => {}
    }
}

/// `kincal merge`.
pub fn merge(args: MergeArgs) -> Result<()> {
    let mut run = MergeRun::new(args.shards);
    let out_given = args.out.is_some();
    run.out = args.out;
    let outcome = run.run().map_err(|e| with_option(e, out_given))?;
    crate::outln!("{}", outcome.summary.to_markdown());
    crate::errln!(
        "merged {} shards → {}",
        run.shards.len(),
        outcome.out.display()
    );
    Ok(())
}

/// `kincal simulate`.
pub fn simulate(args: SimulateArgs) -> Result<()> {
    let mut run = SimulateRun::new(&args.scenario, &args.out);
    run.trial = args.trial;
    let sim = run.run().map_err(|e| with_option(e, true))?;
    let t = sim.truth.sampling.total();
    // With several targets a pose has several rows.
    let count = |set: &measurements::MeasurementSet| {
        let poses = set.poses().len();
        if poses == set.rows.len() {
            format!("{poses}")
        } else {
            format!("{poses} poses ({} rows)", set.rows.len())
        }
    };
    crate::errln!(
        "{} identification and {} validation measurements, truth → {}\n\
         pose sampling: {} candidate draws, {} rejected ({} %: wrist {}, floor {}, \
         elevation {}, range {}, condition {})",
        count(&sim.identification),
        count(&sim.validation),
        args.out.display(),
        t.draws,
        t.rejected(),
        fmt::pct(100.0 * t.rejection_rate()),
        t.rejected_wrist,
        t.rejected_floor,
        t.rejected_elevation,
        t.rejected_range,
        t.rejected_condition,
    );
    Ok(())
}

/// `kincal sweep`.
pub fn sweep(args: SweepArgs) -> Result<()> {
    let mut run = SweepRun::new(&args.sweep);
    run.trials = args.trials;
    run.threads = capped_threads(args.threads);
    run.checkpoint = Some(checkpointing(&args.checkpoint));
    let out_given = args.out.is_some();
    run.out = args.out;
    let outcome = run
        .run(&Progress::new(true))
        .map_err(|e| with_option(e, out_given))?;
    print_sweep(&outcome, false);
    Ok(())
}

/// Prints what a sweep did: the table (unless `quiet`) on stdout, the points, trials, wall
/// clock and output on stderr.
pub fn print_sweep(outcome: &SweepOutcome, quiet: bool) {
    let r = &outcome.result;
    if !quiet {
        crate::outln!("{}", r.to_markdown());
    }
    crate::errln!(
        "{}: {} points × {} trials in {} s → {}",
        r.spec.name,
        r.points.len(),
        r.spec.trials,
        fmt::secs(outcome.seconds),
        outcome.out.display()
    );
}
