//! The front end of the `kincal` command line, as a library so that the repository's
//! automation (`cargo xtask`) runs the same commands: argument types (clap), and functions
//! that call the library crates and print. No calibration logic lives here: campaigns are
//! `campaign`'s, the real-data workflow is `calibrate`'s and its outputs are rendered by
//! `report`.
// The argument docs of the clap types are `--help` text, printed verbatim: defaults are
// written `[stdout]` and placeholders `<scenario>` there, not rustdoc links or HTML, so those
// types allow the two rustdoc lints.

pub mod campaign_cmd;
pub mod console;
pub mod design_cmd;
pub mod identifiability;
pub mod identify_cmd;
pub mod joints_cmd;
pub mod solver_args;
pub mod urdf_cmd;

use std::io::Write as _;
use std::path::Path;

use anyhow::{Context as _, Result};
use clap::Subcommand;

/// The user commands of `kincal` (also reachable as `cargo xtask <command>` in the
/// repository).
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Subcommand)]
pub enum Command {
    /// Run a Monte Carlo campaign of a scenario: trials in parallel, summary against the
    /// paper, plots, in results/<scenario name>/ (or --out).
    Campaign(campaign_cmd::CampaignArgs),
    /// Merge shard files written by `campaign --shard k/K` into one summary.
    Merge(campaign_cmd::MergeArgs),
    /// Run a sweep: the cross product of a scenario's axes, one campaign per point, one
    /// table and curves in results/<sweep name>/ (or --out).
    Sweep(campaign_cmd::SweepArgs),
    /// Simulate one trial of a scenario: identification.csv, validation.csv (measurement
    /// files) and truth.json.
    Simulate(campaign_cmd::SimulateArgs),
    /// Calibrate a robot from measurements: register, identify, screen outliers, validate;
    /// writes identified.json, registered-nominal.json, parameters.json, report.md and
    /// report.html with its plots.
    Identify(identify_cmd::IdentifyArgs),
    /// Predicted x, y, z of a robot model for each row of a joint file.
    Predict(joints_cmd::PredictArgs),
    /// Joints to command so that the calibrated robot reaches the nominal targets.
    Compensate(joints_cmd::CompensateArgs),
    /// Identifiability of a robot's parameters on a pose set: rank, redundant parameters and
    /// what they are confounded with, condition number, observability indices O1–O5.
    Identifiability(identifiability::IdentifiabilityArgs),
    /// Choose which poses to measure: N of a candidate pool by a design criterion (D, A, E,
    /// I, O1, O3, O5) → plan.csv, and a report against random sets of the same size.
    Design(design_cmd::DesignArgs),
    /// URDF in and out: `urdf import` a chain of a URDF as a robot file, `urdf export` a
    /// robot file (e.g. identified.json) as a URDF.
    Urdf(urdf_cmd::UrdfArgs),
}

/// Runs a user command.
pub fn run(cmd: Command) -> Result<()> {
    match cmd {
        Command::Campaign(args) => campaign_cmd::campaign(args),
        Command::Merge(args) => campaign_cmd::merge(args),
        Command::Sweep(args) => campaign_cmd::sweep(args),
        Command::Simulate(args) => campaign_cmd::simulate(args),
        Command::Identify(args) => identify_cmd::run(&args),
        Command::Predict(args) => joints_cmd::predict(&args),
        Command::Compensate(args) => joints_cmd::compensate(&args),
        Command::Identifiability(args) => identifiability::run(&args),
        Command::Design(args) => design_cmd::run(&args),
        Command::Urdf(args) => urdf_cmd::run(&args),
    }
}

/// Ends a front end's `main`: on an error, prints it and what caused it, one line each
/// (`error: …` then `  caused by: …`, outermost first) to stderr and exits with status 1.
/// A cause that the message before it already quotes is left out. No backtrace, whatever
/// `RUST_BACKTRACE` says: every error names its file, line or option. A run whose notes
/// could not be written to standard error ([`console`]) also ends with status 1.
pub fn exit_on_error(result: Result<()>) {
    if let Err(e) = result {
        crate::errln!("error: {e}");
        let mut shown = e.to_string();
        for cause in e.chain().skip(1).map(|c| c.to_string()) {
            // A message that already quotes its cause (`file: No such file…`) is not repeated.
            if !shown.contains(&cause) {
                crate::errln!("  caused by: {cause}");
            }
            shown = cause;
        }
        std::process::exit(1);
    }
    if console::stderr_failed() {
        std::process::exit(1);
    }
}

/// `--out -`: a single-file output written to standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Checks a single-file output before any work ([`measurements::check_output`]): `-` is
/// standard output; a FIFO, a device, a socket, a directory or a dangling link is refused
/// naming the path; a link to a regular file is followed (its target is replaced, the link
/// stays). `flag` names the option in the error, e.g. `--out`.
pub fn check_file_out(flag: &str, path: &Path) -> Result<()> {
    if !is_stdout(path) {
        measurements::check_output(path, measurements::OutputKind::File)
            .with_context(|| format!("{flag} {}", path.display()))?;
    }
    Ok(())
}

/// Refuses, before any work, a single-file output that is the same file as one of the
/// command's inputs (same device and inode through any spelling: links, `..`, another
/// relative path; [`measurements::same_file`]): `predict --joints m.csv --out m.csv` would
/// replace the measurements with the prediction. `inputs` pairs each input's option (or
/// argument name) with its path; `-` (standard output) is never an input.
pub fn check_not_input(out_flag: &str, out: &Path, inputs: &[(&str, &Path)]) -> Result<()> {
    if is_stdout(out) {
        return Ok(());
    }
    for (flag, input) in inputs {
        if measurements::same_file(out, input) {
            anyhow::bail!(
                "{out_flag} {} is the same file as {flag} {}: the output would replace its own \
                 input; write the output to another file",
                out.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Refuses, before any work, an output directory whose set would replace one of the
/// command's inputs: `dir/NAME` for a `NAME` of `set_names` is the same file as an input
/// ([`check_not_input`]); e.g. `identify --robot cal/identified.json --out cal`.
pub fn check_dir_not_input(dir: &Path, set_names: &[&str], inputs: &[(&str, &Path)]) -> Result<()> {
    for name in set_names {
        let target = dir.join(name);
        for (flag, input) in inputs {
            if measurements::same_file(&target, input) {
                anyhow::bail!(
                    "{flag} {} is {name} in --out {}, which this run replaces: the output set \
                     would overwrite its own input; copy the input elsewhere or write the \
                     outputs to another directory",
                    input.display(),
                    dir.display()
                );
            }
        }
    }
    Ok(())
}

/// Writes a single-file output: to standard output for `-`, else atomically
/// ([`measurements::write_atomically`], which checks the target again just before its
/// rename).
pub fn write_file_out(path: &Path, bytes: &[u8]) -> Result<()> {
    if is_stdout(path) {
        let mut out = std::io::stdout().lock();
        return out
            .write_all(bytes)
            .and_then(|()| out.flush())
            .context("writing to standard output");
    }
    measurements::write_atomically(path, bytes).map_err(anyhow::Error::new)
}

/// How a single-file output is named in messages: `standard output` for `-`.
pub fn out_name(path: &Path) -> String {
    if is_stdout(path) {
        "standard output".to_string()
    } else {
        path.display().to_string()
    }
}
