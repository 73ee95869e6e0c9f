//! `kincal identify`: calibrate a robot from a measurement file. Parses the options into a
//! [`calibrate::IdentifyRequest`], runs it, renders the outputs
//! ([`report::calibration::render`]), writes them and prints the summary.

use std::path::Path;

use anyhow::{Context, Result};
use calibrate::IdentifyRequest;
use report::calibration::{
    PARAMETERS_FILE, REGISTERED_FILE, REPORT_FILE, REPORT_HTML_FILE, ROBOT_FILE,
};

mod args;

pub use args::IdentifyArgs;

/// Takes the output directory `dir` for this run ([`measurements::OutputDir::lock`]): refuses
/// a path that is not a directory (a FIFO, a device, a file…) and a directory another run is
/// writing, naming the holder. Called before any work.
pub fn lock_out(dir: &Path) -> Result<measurements::OutputDir> {
    measurements::OutputDir::lock(dir).with_context(|| format!("--out {}", dir.display()))
}

/// Writes `files` as the new set of the held output directory, as a whole: a reader (and a
/// kill at any moment) sees the complete previous set or the complete new one; the user's
/// own files in the directory stay.
pub fn write_outputs_into(out: &measurements::OutputDir, files: &[(String, String)]) -> Result<()> {
    out.write_set(files)
        .with_context(|| format!("writing the outputs into {}", out.path().display()))
}

/// Takes `dir` ([`lock_out`]) and writes `files` into it as a whole ([`write_outputs_into`]);
/// no output of an earlier run is replaced unless every file could be written.
pub fn write_outputs(dir: &Path, files: &[(String, String)]) -> Result<()> {
    write_outputs_into(&lock_out(dir)?, files)
}

/// `kincal identify`.
pub fn run(args: &IdentifyArgs) -> Result<()> {
    let mut inputs = vec![("--robot", args.robot.as_path()), ("--data", &args.data)];
    inputs.extend(args.validate.as_deref().map(|p| ("--validate", p)));
    crate::check_dir_not_input(
        &args.out,
        &[
            ROBOT_FILE,
            REGISTERED_FILE,
            PARAMETERS_FILE,
            REPORT_FILE,
            REPORT_HTML_FILE,
        ],
        &inputs,
    )?;
    let out = lock_out(&args.out)?;
    let request = args.request();
    let cal = if args.euler.is_some() || calibrate::frames::header_has_frames(&args.data) {
        let inputs =
            calibrate::frames::load_inputs(&request, args.euler).map_err(|e| args.flagged(e))?;
        if !args.points_only && calibrate::frames::applies(&inputs.data) {
            return run_frames(args, &request, inputs, &out);
        }
        calibrate::calibrate(&request, inputs)
    } else {
        calibrate::run(&request)
    }
    .map_err(|e| args.flagged(e))?;
    for notice in &cal.notices {
        crate::errln!("note: {notice}");
    }
    let files = report::calibration::render(&cal)
        .with_context(|| format!("drawing the plots of {REPORT_HTML_FILE}"))?;
    write_outputs_into(&out, &files)?;
    drop(out);
    crate::out!("{}", report::calibration::summary(&cal));
    crate::outln!(
        "→ {}: {ROBOT_FILE} (the calibrated robot), {REGISTERED_FILE} (the nominal robot in \
         the same frame: compensation targets), {PARAMETERS_FILE} (parameter table), \
         {REPORT_FILE} and {REPORT_HTML_FILE} (the report, with its plots)",
        args.out.display(),
    );
    Ok(())
}

/// `kincal identify` on 6-DoF or multi-target data.
fn run_frames(
    args: &IdentifyArgs,
    request: &IdentifyRequest,
    inputs: calibrate::Inputs,
    out: &measurements::OutputDir,
) -> Result<()> {
    let options = args::OrientationWeight::options(args.orientation_weight);
    let cal = calibrate::frames::calibrate_frames(request, inputs, &options)
        .map_err(|e| args.flagged(e))?;
    for notice in &cal.notices {
        crate::errln!("note: {notice}");
    }
    let files = report::calibration::frames::render(&cal)
        .with_context(|| format!("drawing the plots of {REPORT_HTML_FILE}"))?;
    write_outputs_into(out, &files)?;
    crate::out!("{}", report::calibration::frames::summary(&cal));
    crate::outln!(
        "→ {}: {ROBOT_FILE} (the calibrated robot with its tool frame), {REPORT_FILE} and \
         {REPORT_HTML_FILE} (the report, with its plots: position and orientation errors)",
        args.out.display(),
    );
    Ok(())
}
