//! `kincal predict | compensate`: parse, load the residual model the robot names, call
//! [`calibrate::predict_with`] / [`calibrate::compensate_file`], write or print.

use std::path::{Path, PathBuf};

use anyhow::Result;
use calibrate::{CalibrateError, LoadedRobot, Refusal};
use clap::Args;

/// Writes `text` to `out` atomically (checked again just before the rename), or to stdout
/// when `out` is `None` or `-`.
fn emit(out: Option<&Path>, text: &str) -> Result<()> {
    crate::write_file_out(out.unwrap_or(Path::new("-")), text.as_bytes())
}

/// Checks `--out` before any work: a FIFO, a device, a socket, a directory or a dangling
/// link is refused; `-` is stdout.
fn check_out(out: Option<&Path>) -> Result<()> {
    out.map_or(Ok(()), |p| crate::check_file_out("--out", p))
}

fn out_label(out: Option<&Path>) -> String {
    out.filter(|p| !crate::is_stdout(p))
        .map_or_else(|| "stdout".to_string(), |p| p.display().to_string())
}

/// Arguments of `predict`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
#[command(after_help = "Example:
  kincal predict --robot ur10-cal/identified.json \\
      --joints data/ur10-ipa/series-b-joint-configurations.csv --out predicted.csv")]
pub struct PredictArgs {
    /// Robot model file (JSON), e.g. an `identified.json` written by `identify`.
    #[arg(long)]
    robot: PathBuf,
    /// Joint file (docs/model.md §5 CSV; the joints-only form `id, q1…qN` is enough; other
    /// columns are ignored; `x, y, z` and `qw, qx, qy, qz`, if present, are compared with
    /// the prediction on stderr).
    #[arg(long)]
    joints: PathBuf,
    /// Output file [stdout; `-` is stdout too]: `id` (if the input has ids), `q1…qN` as read, and the
    /// predicted `x, y, z` in mm in the robot's measurement frame; when the robot has a tool
    /// orientation (`tool_rotation_deg`, a 6-DoF calibration), also the measured frame's
    /// orientation `qw, qx, qy, qz` (unit quaternion, scalar first, qw ≥ 0).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the learned residual model's predictive standard deviation of each point
    /// as `sx, sy, sz` (mm; docs/residual-model.md) [off]. Needs a robot whose provenance
    /// names a residual model (identify --residual-model gp kept one).
    #[arg(long, conflicts_with = "geometry_only")]
    with_sd: bool,
    /// Predict with the geometry alone, ignoring the residual model the robot file names
    /// [off: a residual model named in the robot file is applied].
    #[arg(long)]
    geometry_only: bool,
}

/// `kincal predict`.
pub fn predict(args: &PredictArgs) -> Result<()> {
    check_out(args.out.as_deref())?;
    if let Some(out) = args.out.as_deref() {
        crate::check_not_input(
            "--out",
            out,
            &[("--robot", &args.robot), ("--joints", &args.joints)],
        )?;
    }
    let robot = LoadedRobot::load(&args.robot, "robot")?;
    let model = if args.geometry_only {
        None
    } else {
        anyhow::Context::context(calibrate::residual::load_model(&robot), "--robot")?
    };
    if args.with_sd && model.is_none() {
        anyhow::bail!(
            "--with-sd: {} names no residual model (identify --residual-model gp writes one when \
             cross-validation says it helps)",
            args.robot.display()
        );
    }
    let p = calibrate::predict_with(
        &robot,
        model.as_ref().map(|m| (m, args.with_sd)),
        &args.joints,
        &out_label(args.out.as_deref()),
    )?;
    if p.residual_model {
        let what = if p.orientation && model.as_ref().is_some_and(|m| m.has_orientation()) {
            "the points and orientations include the learned residual model (with its \
             orientation part)"
        } else {
            "the points include the learned residual model"
        };
        crate::errln!(
            "note: {what} named in {} (--geometry-only to leave it out)",
            args.robot.display()
        );
    }
    for notice in &p.notices {
        crate::errln!("note: {notice}");
    }
    emit(args.out.as_deref(), &p.csv)?;
    match p.file_error_mm {
        Some((mean, max)) => crate::errln!(
            "{} rows; the file has points x, y, z: |file − predicted| mean {} mm, max {} mm",
            p.rows,
            report::fmt::mm(mean),
            report::fmt::mm(max)
        ),
        None => crate::errln!("{} rows", p.rows),
    }
    if let Some((mean, max)) = p.file_error_deg {
        crate::errln!(
            "the file has orientations qw, qx, qy, qz: angle file − predicted mean {}°, max {}°",
            report::fmt::deg(mean),
            report::fmt::deg(max)
        );
    }
    if let Some(out) = args.out.as_deref().filter(|p| !crate::is_stdout(p)) {
        crate::errln!("→ {}", out.display());
    }
    Ok(())
}

/// Arguments of `compensate`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
#[command(after_help = "Example (after `kincal identify … --out ur10-cal`):
  kincal compensate --robot ur10-cal/identified.json \\
      --nominal ur10-cal/registered-nominal.json --targets targets.csv --out commands.csv")]
pub struct CompensateArgs {
    /// The calibrated robot (e.g. `identified.json` from `identify`).
    #[arg(long)]
    robot: PathBuf,
    /// The nominal robot in the calibrated robot's measurement frame: its forward kinematics
    /// at the commanded joints are the targets. When `identify` registered the data (they
    /// were in a tracker frame), use the `registered-nominal.json` it wrote.
    #[arg(long)]
    nominal: PathBuf,
    /// Commanded joints (docs/model.md §5 joints-only CSV; other columns ignored), or
    /// Cartesian targets: a file without joint columns, `x, y, z` (mm, the TCP's position)
    /// and optionally `id` and an orientation (`qw, qx, qy, qz`, or `rx, ry, rz` read as
    /// `--euler` says).
    #[arg(long)]
    targets: PathBuf,
    /// Output file [stdout; `-` is stdout too]: `id, q1…qN, x, y, z`: the joints to command (degrees) and the
    /// target point they reach on the calibrated model (mm; compare a re-measurement with
    /// it, e.g. `predict --joints` on this file). Rows without an id get `L<line>` (their
    /// line in the targets file). For Cartesian targets `id, q1…qN, x, y, z, qw, qx, qy,
    /// qz`: the joints to command and the corrected target for a controller that runs the
    /// nominal model (its forward kinematics at those joints, in the robot's base frame).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Cartesian targets: how columns `rx, ry, rz` are read: Euler angles in degrees in a
    /// convention of three axis letters (`XYZ` intrinsic … `xyz` extrinsic, as SciPy's
    /// `from_euler`), `kuka` (KUKA's A, B, C = intrinsic ZYX), or `rotvec` (a UR rotation
    /// vector, radians).
    #[arg(long, value_name = "CONVENTION")]
    euler: Option<calibrate::OrientationColumns>,
    /// Cartesian targets: the frame they are given in, `base` (the robot's base frame: the
    /// nominal robot file's `base`, the controller's frame) or `measurement` (the
    /// calibration's measurement frame) [base].
    #[arg(long, value_name = "FRAME", default_value = "base")]
    frame: calibrate::TargetFrame,
    /// Cartesian targets: the TCP in the flange frame, `x,y,z` mm or `x,y,z,rx,ry,rz` with
    /// its rotation in degrees (R = Rz·Ry·Rx, the robot file's `tool_rotation_deg`)
    /// [the calibrated robot's `tool_mm` and `tool_rotation_deg`]; the nominal model gets the
    /// same TCP.
    #[arg(
        long,
        value_name = "X,Y,Z[,RX,RY,RZ]",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    tcp: Option<Vec<f64>>,
    /// Cartesian targets: the joints (degrees) the nominal controller starts from: the first
    /// target's nominal IK solution is the one nearest them, each next one the one nearest
    /// the previous target's [each joint's 0 clamped to its limits].
    #[arg(
        long,
        value_name = "Q1,…,QN",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    start_joints: Option<Vec<f64>>,
    /// Write the reachable rows and list the unreachable ones instead of failing.
    #[arg(long)]
    allow_unreachable: bool,
    /// Flag rows whose joints move by more than this, degrees [2]: each row gets the exact
    /// solution nearest the commanded joints; one moving a joint further (near a wrist,
    /// shoulder or elbow singularity, or on another branch) is still written, and listed on
    /// stderr and in the output's header with its reason.
    #[arg(long, default_value_t = identify::DEFAULT_FLAG_CHANGE_DEG, value_name = "DEG")]
    flag_change_deg: f64,
    /// Skip a check of the pair: `provenance` takes an `identified.json` and a
    /// `registered-nominal.json` that do not come from one identify run (or are swapped)
    /// as given.
    /// `length-units` takes Cartesian targets that all lie near the robot's base origin
    /// (within 1 % of its size: metres, by the look of them) as millimetres.
    #[arg(long, value_name = "CHECK", value_parser = ["provenance", "length-units"])]
    allow: Vec<String>,
    /// Output format [csv]: `kuka-krl` (a .dat of E6POS and E6AXIS), `abb-rapid` (a module of
    /// robtarget and jointtarget), `urscript` (poses p[…] and joints): per row the joints to
    /// command as the nominal robot file's controller axes, and the nominal forward
    /// kinematics of those joints as the Cartesian target (docs/controller.md).
    #[arg(long, default_value = "csv", value_name = "FORMAT")]
    format: controller::Format,
    /// Compensate with the geometry alone, ignoring the residual model the calibrated robot
    /// file names [off: a residual model named in it is applied: the joints bring the
    /// geometry plus the model's mean onto each target (docs/residual-model.md)].
    #[arg(long)]
    geometry_only: bool,
}

/// `kincal compensate`.
pub fn compensate(args: &CompensateArgs) -> Result<()> {
    check_out(args.out.as_deref())?;
    if let Some(out) = args.out.as_deref() {
        crate::check_not_input(
            "--out",
            out,
            &[
                ("--robot", &args.robot),
                ("--nominal", &args.nominal),
                ("--targets", &args.targets),
            ],
        )?;
    }
    let calibrated = LoadedRobot::load(&args.robot, "calibrated robot")?;
    let nominal = LoadedRobot::load(&args.nominal, "nominal robot")?;
    let model = if args.geometry_only {
        None
    } else {
        anyhow::Context::context(calibrate::residual::load_model(&calibrated), "--robot")?
    };
    if !args.allow.iter().any(|a| a == "provenance") {
        calibrate::provenance::check_pair(&calibrated, &nominal).map_err(|e| {
            anyhow::Error::new(e)
                .context("refused by the provenance check (override: --allow provenance)")
        })?;
    }
    if !(args.flag_change_deg.is_finite() && args.flag_change_deg > 0.0) {
        anyhow::bail!(
            "--flag-change-deg {} must be a positive number of degrees",
            args.flag_change_deg
        );
    }
    let options = identify::CompensationOptions {
        flag_change_deg: args.flag_change_deg,
        ..identify::CompensationOptions::default()
    };
    let tcp = match args.tcp.as_deref() {
        None => None,
        Some(&[x, y, z]) => Some(calibrate::Tcp {
            tool_mm: [x, y, z],
            tool_rotation_deg: None,
        }),
        Some(&[x, y, z, rx, ry, rz]) => Some(calibrate::Tcp {
            tool_mm: [x, y, z],
            tool_rotation_deg: Some([rx, ry, rz]),
        }),
        Some(v) => anyhow::bail!(
            "--tcp takes 3 or 6 numbers (x,y,z[,rx,ry,rz]), not {}",
            v.len()
        ),
    };
    if let Some(v) = args.tcp.iter().flatten().find(|v| !v.is_finite()) {
        anyhow::bail!("--tcp: {v} is not a finite number");
    }
    let cartesian = calibrate::CartesianOptions {
        frame: args.frame,
        orientation_columns: args.euler,
        tcp,
        start_deg: args.start_joints.clone(),
        allow_length_units: args.allow.iter().any(|a| a == "length-units"),
    };
    let c = calibrate::compensate_file(
        (&calibrated, model.as_ref()),
        &nominal,
        &args.targets,
        args.allow_unreachable,
        (&options, &cartesian),
        &out_label(args.out.as_deref()),
    )
    .map_err(|e| match e {
        CalibrateError::Refused(Refusal::Unreachable { .. }) => anyhow::Error::new(e)
            .context("some targets are unreachable; --allow-unreachable writes the others"),
        CalibrateError::Refused(r @ Refusal::Implausible { .. }) => {
            anyhow::anyhow!(r.in_words(calibrate::Front::Flags))
        }
        CalibrateError::Refused(Refusal::StartJoints { .. }) => {
            anyhow::Error::new(e).context("--start-joints")
        }
        e @ CalibrateError::Read {
            source: measurements::MeasurementError::EulerConventionMissing { .. },
            ..
        } => anyhow::Error::new(e).context(
            "the targets give rx,ry,rz: name what they are with --euler (a convention such as \
             XYZ or zyx, kuka for A,B,C, rotvec for a UR rotation vector in radians)",
        ),
        e => e.into(),
    })?;
    let cartesian_given = args.euler.is_some()
        || args.tcp.is_some()
        || args.start_joints.is_some()
        || args.frame != calibrate::TargetFrame::Base;
    if c.orientation == calibrate::OrientationSource::Held && cartesian_given {
        crate::errln!(
            "note: --euler, --frame, --tcp and --start-joints apply to Cartesian targets; {} \
             has joint columns",
            args.targets.display()
        );
    }
    if c.orientation == calibrate::OrientationSource::LeftToNominal {
        crate::errln!(
            "orientation: left to the nominal model ({} has no tool orientation: a calibration \
             of points; the calibrated solve holds the nominal solution's flange orientation)",
            args.robot.display()
        );
    }
    if let Some(m) = &c.residual_model {
        crate::errln!(
            "note: the joints include the learned residual model named in {} ({}; |r| mean {} \
             mm, max {} mm{}; at most {} fixed-point steps; --geometry-only to leave it out)",
            args.robot.display(),
            m.file,
            report::fmt::mm(m.mean_correction_mm),
            report::fmt::mm(m.max_correction_mm),
            m.max_orientation_correction_deg
                .map_or(String::new(), |d| format!(
                    "; orientation part |r_o| max {d:.4}°"
                )),
            m.max_steps
        );
    } else if args.geometry_only {
        crate::errln!("note: the geometry alone (--geometry-only): no residual model applied");
    }
    for notice in &c.notices {
        crate::errln!("note: {notice}");
    }
    for u in &c.unreachable {
        crate::errln!("{u}");
    }
    for f in &c.flagged {
        crate::errln!("flagged: {f}");
    }
    emit(
        args.out.as_deref(),
        &program_text(args.format, &nominal, &c, args.out.as_deref())?,
    )?;
    let reasons = c
        .flag_reasons
        .iter()
        .map(|(k, n)| format!("{k} {n}"))
        .collect::<Vec<_>>()
        .join(", ");
    crate::errln!(
        "compensated {} of {} targets ({} unreachable left out; {} flagged: a joint moves > \
         {}°{}); largest joint change {:.4}°, largest IK position error {:.1e} mm{}",
        c.compensated,
        c.targets,
        c.unreachable.len(),
        c.flagged.len(),
        c.flag_change_deg,
        if reasons.is_empty() {
            String::new()
        } else {
            format!(" — {reasons}")
        },
        c.max_joint_change_deg,
        c.max_ik_error_mm,
        args.out
            .as_deref()
            .filter(|p| !crate::is_stdout(p))
            .map_or(String::new(), |p| format!(" → {}", p.display()))
    );
    Ok(())
}

/// The compensation as `--format` writes it: the CSV as is, or a controller program of the
/// compensated rows (docs/controller.md): names the CSV's ids, axes the nominal robot file's
/// controller mapping of the joints to command, Cartesian targets the nominal model's TCP
/// pose at them in its base frame. The program is named after `--out`'s stem when that is
/// an identifier (KRL's DEFDAT must be), else `kincal_targets`.
fn program_text(
    format: controller::Format,
    nominal: &LoadedRobot,
    c: &calibrate::Compensation,
    out: Option<&Path>,
) -> Result<String> {
    if format == controller::Format::Csv {
        return Ok(c.csv.clone());
    }
    // The rows as `calibrate::CorrectedTarget`s: the joints to command and the corrected
    // target (the nominal model's TCP pose at them, in its base frame; for Cartesian targets
    // with the TCP the compensation used).
    let targets: Vec<controller::Target> = c
        .corrected
        .iter()
        .map(|t| controller::Target {
            name: t.id.clone(),
            joints_deg: t.joints_deg.clone(),
            position_mm: t.position_mm,
            orientation_wxyz: Some(t.orientation_wxyz),
        })
        .collect();
    let declarations = controller::declare(&nominal.robot, &targets)?;
    let mut header = vec![format!(
        "kincal compensate: {} targets; axes by the controller mapping of {}",
        c.compensated,
        nominal.path.display()
    )];
    if let Some(m) = &c.residual_model {
        header.push(format!(
            "residual model applied: the joints include the mean of {} (docs/residual-model.md)",
            m.file
        ));
    }
    header.extend(c.flagged.iter().map(|f| format!("flagged: {f}")));
    let stem = out
        .filter(|p| !crate::is_stdout(p))
        .and_then(|p| p.file_stem())
        .and_then(|s| s.to_str())
        .unwrap_or("kincal_targets");
    let program = controller::write(format, stem, &header, &declarations)
        .or_else(|_| controller::write(format, "kincal_targets", &header, &declarations))?;
    Ok(program)
}
