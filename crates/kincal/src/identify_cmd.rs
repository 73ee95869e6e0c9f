//! `kincal identify`: calibrate a robot from a measurement file. Parses the options into a
//! [`calibrate::IdentifyRequest`], runs it, renders the outputs
//! ([`report::calibration::render`]), writes them and prints the summary.

use std::path::Path;

use anyhow::{Context, Result};
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

/// `kincal identify`: the library reads the data and calibrates them as what they measure
/// (points, 6-DoF poses, several targets per pose: [`calibrate::MeasurementKind`]); every
/// kind writes the same set of files.
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
            calibrate::residual::MODEL_FILE,
        ],
        &inputs,
    )?;
    let out = lock_out(&args.out)?;
    let request = args.request();
    let mut cal = calibrate::run(&request).map_err(|e| args.flagged(e))?;
    if let Some(options) = args.residual_options() {
        cal.fit_residual_model(&options)
            .with_context(|| format!("--residual-model gp --residual-folds {}", options.folds))?;
    }
    for notice in cal.notices() {
        crate::errln!("note: {notice}");
    }
    let files = report::calibration::render(&cal)
        .with_context(|| format!("drawing the plots of {REPORT_HTML_FILE}"))?;
    write_outputs_into(&out, &files)?;
    drop(out);
    crate::out!("{}", report::calibration::summary(&cal));
    let (robot, plots) = if cal.kind().is_points() {
        ("the calibrated robot", "with its plots")
    } else {
        (
            "the calibrated robot with its tool frame",
            "with its plots: position and orientation errors",
        )
    };
    let residual = if cal.written_residual_model().is_some() {
        format!(
            ", {} (the learned residual model, named in {ROBOT_FILE})",
            calibrate::residual::MODEL_FILE
        )
    } else {
        String::new()
    };
    crate::outln!(
        "→ {}: {ROBOT_FILE} ({robot}), {REGISTERED_FILE} (the nominal robot in the same frame: \
         compensation targets), {PARAMETERS_FILE} (parameter table), {REPORT_FILE} and \
         {REPORT_HTML_FILE} (the report, {plots}){residual}",
        args.out.display(),
    );
    Ok(())
}
