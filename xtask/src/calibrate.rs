//! `cargo xtask predict | compensate`, and the file helpers shared with `identify`
//! (`identify_cmd.rs`): robot files, spec §8 measurement files with the robot's joint limits,
//! row labels.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use identify::{compensate, kabsch};
use kinematics::{IkOptions, Robot, RobotSpec};
use measurements::{
    Measurement, MeasurementError, MeasurementSet, ReadOptions, read_file, to_csv_string,
};
use nalgebra::Vector3;

/// A robot file, parsed, with the exact degree limits of the file.
pub(crate) struct LoadedRobot {
    pub spec: RobotSpec,
    pub robot: Robot,
}

impl LoadedRobot {
    /// Loads and validates a robot model file (JSON, [`RobotSpec`]).
    pub fn load(path: &Path, what: &str) -> Result<Self> {
        let spec = RobotSpec::from_file(path)
            .with_context(|| format!("loading the {what} {}", path.display()))?;
        let robot = Robot::from_spec(&spec)
            .with_context(|| format!("loading the {what} {}", path.display()))?;
        Ok(LoadedRobot { spec, robot })
    }

    /// Joint limits in degrees, exactly as in the file.
    pub fn limits_deg(&self) -> Vec<[f64; 2]> {
        self.spec.joints.iter().map(|j| j.limits_deg).collect()
    }
}

/// Reads a spec §8 file for `robot`: its joint count, its joint limits, points required or
/// not, at least `min_rows` rows (`why`, if given, explains that minimum when it is not
/// met). Notices (ignored columns) go to stderr.
pub(crate) fn read_set(
    robot: &LoadedRobot,
    path: &Path,
    require_points: bool,
    (min_rows, why): (usize, Option<&str>),
    what: &str,
) -> Result<MeasurementSet> {
    let mut opts = ReadOptions::new(robot.robot.n_joints())
        .with_limits_deg(robot.limits_deg())
        .with_min_rows(min_rows);
    if !require_points {
        opts = opts.joints_only();
    }
    let set = read_file(path, &opts).map_err(|e| {
        let too_few = matches!(e, MeasurementError::TooFewRows { .. });
        let err = anyhow::Error::new(e).context(format!(
            "reading the {what} {} for {} ({} joints)",
            path.display(),
            robot.robot.name(),
            robot.robot.n_joints()
        ));
        match why {
            Some(why) if too_few => err.context(why.to_string()),
            _ => err,
        }
    })?;
    for notice in &set.notices {
        eprintln!("note: {notice}");
    }
    Ok(set)
}

/// The joint values of `rows`, radians, flat.
pub(crate) fn poses_rad(rows: &[Measurement]) -> Vec<f64> {
    rows.iter()
        .flat_map(|r| r.q_deg.iter().map(|q| q.to_radians()))
        .collect()
}

/// The measured points of `rows` (which must have them), mm.
pub(crate) fn points_mm(rows: &[Measurement]) -> Vec<Vector3<f64>> {
    rows.iter()
        .map(|r| Vector3::from(r.point_mm.expect("read with require_points")))
        .collect()
}

/// `V003 (line 5)` or `line 5`.
pub(crate) fn row_label(row: &Measurement) -> String {
    match &row.id {
        Some(id) => format!("{id} (line {})", row.line),
        None => format!("line {}", row.line),
    }
}

/// The file name of a path, for headers and names.
pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

/// Writes `text` to `out` atomically, or prints it to stdout.
fn emit(out: Option<&Path>, text: &str) -> Result<()> {
    match out {
        Some(path) => measurements::write_atomically(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display())),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

/// Arguments of `predict`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Robot model file (JSON), e.g. an `identified.json` written by `identify`.
    #[arg(long)]
    robot: PathBuf,
    /// Joint file (spec §8; the joints-only form `id, q1…qN` is enough; other columns are
    /// ignored; `x, y, z`, if present, are compared with the prediction on stderr).
    #[arg(long)]
    joints: PathBuf,
    /// Output file [stdout]: `id` (if the input has ids), `q1…qN` as read, and the
    /// predicted `x, y, z` in mm in the robot's measurement frame.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `cargo xtask predict`.
pub fn predict(args: &PredictArgs) -> Result<()> {
    let robot = LoadedRobot::load(&args.robot, "robot")?;
    let set = read_set(&robot, &args.joints, false, (1, None), "joint file")?;
    let mut rows = Vec::with_capacity(set.rows.len());
    let mut errors = Vec::new();
    let mut q = vec![0.0; robot.robot.n_joints()];
    for r in &set.rows {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        let p = robot.robot.point(&q);
        if let Some(m) = r.point_mm {
            errors.push((Vector3::from(m) - p).norm());
        }
        rows.push(Measurement {
            line: 0,
            id: r.id.clone(),
            q_deg: r.q_deg.clone(),
            point_mm: Some([p.x, p.y, p.z]),
        });
    }
    let label = args
        .out
        .as_ref()
        .map_or_else(|| "stdout".to_string(), |p| p.display().to_string());
    let out_set = MeasurementSet::new(label, robot.robot.n_joints(), rows);
    let header = format!(
        "kincal predict: points of {} ({}) at the joints of {}\nq in degrees as read; x y z \
         predicted, mm, in the robot's measurement frame",
        robot.robot.name(),
        file_name(&args.robot),
        file_name(&args.joints)
    );
    let text = to_csv_string(&out_set, Some(&header)).context("formatting the predictions")?;
    emit(args.out.as_deref(), &text)?;
    let n = set.rows.len();
    if errors.len() == n {
        let mean = errors.iter().sum::<f64>() / n as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "{n} rows; the file has points x, y, z: |file − predicted| mean {mean:.4} mm, max \
             {max:.4} mm"
        );
    } else {
        eprintln!("{n} rows");
    }
    if let Some(out) = &args.out {
        eprintln!("→ {}", out.display());
    }
    Ok(())
}

/// Largest mean shift (mm) of the rigid transform between the nominal and the calibrated
/// robot's points that `compensate` accepts [10 mm, the threshold above which `identify`
/// registers: geometric errors are millimetres, another frame is metres].
const SAME_FRAME_MM: f64 = 10.0;

/// Arguments of `compensate`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
pub struct CompensateArgs {
    /// The calibrated robot (e.g. `identified.json` from `identify`).
    #[arg(long)]
    robot: PathBuf,
    /// The nominal robot in the calibrated robot's measurement frame: its forward kinematics
    /// at the commanded joints are the targets. When `identify` registered the data (they
    /// were in a tracker frame), use the `registered-nominal.json` it wrote.
    #[arg(long)]
    nominal: PathBuf,
    /// Commanded joints (spec §8 joints-only form; other columns ignored).
    #[arg(long)]
    targets: PathBuf,
    /// Output file [stdout]: `id, q1…qN, x, y, z`: the joints to command (degrees) and the
    /// target point they reach on the calibrated model (mm; compare a re-measurement with
    /// it, e.g. `predict --joints` on this file). Rows without an id get `L<line>` (their
    /// line in the targets file).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the reachable rows and list the unreachable ones instead of failing.
    #[arg(long)]
    allow_unreachable: bool,
}

/// Refuses a nominal model that is not in the calibrated robot's measurement frame: the
/// rigid transform best mapping the nominal model's points onto the calibrated robot's at the
/// target poses must move them by at most [`SAME_FRAME_MM`] on average. (Base parameters alone
/// cannot tell: with redundant parameters the identified base trades against θ1 and d1.)
/// Skipped when the targets do not determine a rotation (fewer than three, or collinear).
fn check_same_frame(
    args: &CompensateArgs,
    nominal: &Robot,
    identified: &Robot,
    poses: &[f64],
) -> Result<()> {
    let (pn, pi) = (nominal.points(poses), identified.points(poses));
    let Ok(t) = kabsch(&pn, &pi) else {
        return Ok(());
    };
    let shift = pn.iter().map(|p| (t.apply(p) - p).norm()).sum::<f64>() / pn.len() as f64;
    if shift > SAME_FRAME_MM {
        bail!(
            "{} and {} are not in the same measurement frame: at the target poses a rigid \
             transform of {:.3}° and {:.1} mm separates their points (mean shift {shift:.1} mm \
             > {SAME_FRAME_MM} mm), so the nominal targets would be meaningless for the \
             calibrated robot; pass the nominal model registered in its frame \
             (`registered-nominal.json`, written by `identify` next to `identified.json`)",
            args.robot.display(),
            args.nominal.display(),
            t.angle_deg(),
            t.translation_mm.norm()
        );
    }
    Ok(())
}

/// `cargo xtask compensate`.
pub fn compensate_cmd(args: &CompensateArgs) -> Result<()> {
    let identified = LoadedRobot::load(&args.robot, "calibrated robot")?;
    let nominal = LoadedRobot::load(&args.nominal, "nominal robot")?;
    let (id_r, nom_r) = (&identified.robot, &nominal.robot);
    if id_r.layout() != nom_r.layout() {
        bail!(
            "{} ({} joints, {} parameters) and {} ({} joints, {} parameters) are not the same \
             kind of robot",
            args.robot.display(),
            id_r.n_joints(),
            id_r.n_params(),
            args.nominal.display(),
            nom_r.n_joints(),
            nom_r.n_params()
        );
    }
    let set = read_set(
        &nominal,
        &args.targets,
        false,
        (1, None),
        "target joint file",
    )?;
    let n = nom_r.n_joints();
    check_same_frame(args, nom_r, id_r, &poses_rad(&set.rows))?;
    let ik = IkOptions::default();
    let mut rows = Vec::with_capacity(set.rows.len());
    let mut unreachable = Vec::new();
    let mut q = vec![0.0; n];
    let mut cmd = vec![0.0; n];
    let (mut max_dq_deg, mut max_err_mm) = (0.0_f64, 0.0_f64);
    for r in &set.rows {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        cmd.copy_from_slice(&q);
        match compensate(nom_r, id_r, &mut q, &ik) {
            Ok(rep) => {
                let target = nom_r.point(&cmd);
                let q_deg: Vec<f64> = q.iter().map(|v| v.to_degrees()).collect();
                for (a, b) in q_deg.iter().zip(&r.q_deg) {
                    max_dq_deg = max_dq_deg.max((a - b).abs());
                }
                max_err_mm = max_err_mm.max(rep.pos_err_mm);
                rows.push(Measurement {
                    line: 0,
                    id: Some(r.id.clone().unwrap_or_else(|| format!("L{}", r.line))),
                    q_deg,
                    point_mm: Some([target.x, target.y, target.z]),
                });
            }
            Err(e) => unreachable.push(format!(
                "{}:{}: {}unreachable: {e}",
                set.source,
                r.line,
                r.id.as_ref().map_or(String::new(), |id| format!("{id}: "))
            )),
        }
    }
    for u in &unreachable {
        eprintln!("{u}");
    }
    if !unreachable.is_empty() && !args.allow_unreachable {
        bail!(
            "{} of {} targets in {} are unreachable for {} (listed above); nothing written — \
             --allow-unreachable writes the others",
            unreachable.len(),
            set.rows.len(),
            set.source,
            id_r.name()
        );
    }
    if rows.is_empty() {
        bail!("no target in {} is reachable; nothing written", set.source);
    }
    let label = args
        .out
        .as_ref()
        .map_or_else(|| "stdout".to_string(), |p| p.display().to_string());
    let out_set = MeasurementSet::new(label, n, rows);
    let header = format!(
        "kincal compensate: joints (degrees) to command so that {} ({}) reaches the points of \
         {} ({}) at the commanded joints of {}\nx y z: that target point, mm",
        id_r.name(),
        file_name(&args.robot),
        nom_r.name(),
        file_name(&args.nominal),
        file_name(&args.targets)
    );
    let text = to_csv_string(&out_set, Some(&header)).context("formatting the joints")?;
    emit(args.out.as_deref(), &text)?;
    eprintln!(
        "compensated {} of {} targets ({} unreachable left out); largest joint change \
         {max_dq_deg:.4}°, largest IK position error {max_err_mm:.1e} mm{}",
        out_set.rows.len(),
        set.rows.len(),
        unreachable.len(),
        args.out
            .as_ref()
            .map_or(String::new(), |p| format!(" → {}", p.display()))
    );
    Ok(())
}
