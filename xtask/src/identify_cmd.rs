//! `cargo xtask identify`: calibrate a robot from a measurement file (spec §8).
//!
//! Reads → (splits) → registers the base if the data are in another frame → identifies →
//! screens outliers (refits without them on request) → analyses identifiability at the
//! solution → validates → renders `identified.json`, `parameters.json` and `report.md` in
//! memory → writes them atomically into the output directory, which is created only then.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use evaluate::{AxisStats, ErrorStats, Table4, improvement_pct};
use identify::{
    Damping, Fit, IdentifiabilityOptions, IdentifiabilityReport, IdentifyOptions, LmOptions,
    OutlierScreen, ParamSet, Problem, Redundant, RegistrationPolicy, RegistrationReport, analyze,
    identify, mean_point_error, outliers, random_poses, register_base,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementError};
use nalgebra::Vector3;
use serde::Serialize;

use crate::calibrate::{LoadedRobot, file_name, points_mm, poses_rad, read_set, row_label};

/// The damping schedule (spec §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Schedule {
    /// The paper's: (JᵀJ + μI), μ0 = 1e-3, ÷10 / ×10.
    Levenberg,
    /// (JᵀJ + μ diag JᵀJ), same updates.
    Marquardt,
    /// Nielsen's gain-ratio schedule.
    Nielsen,
}

impl Schedule {
    fn damping(self) -> Damping {
        match self {
            Schedule::Levenberg => Damping::levenberg(),
            Schedule::Marquardt => Damping::marquardt(),
            Schedule::Nielsen => Damping::nielsen(),
        }
    }
}

/// What the solver does with free parameters exactly redundant at the start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RedundantArg {
    /// Hold them at their start values and solve on the identifiable rest.
    Hold,
    /// Keep them in the damped system (the paper's verbatim method).
    Damp,
}

/// When to register the measurement frame onto the robot base before identifying.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Registration {
    /// When the nominal model misses the points by more than 10 mm on average.
    Auto,
    /// Always.
    Always,
    /// Never (the paper's procedure: LM from the nominal model).
    Never,
}

/// Arguments of `identify`.
#[derive(Args, Debug)]
pub struct IdentifyArgs {
    /// Nominal robot model file (JSON); its joint limits check the data.
    #[arg(long)]
    robot: PathBuf,
    /// Identification measurements (spec §8 CSV: q1…qN in degrees, x, y, z in mm).
    #[arg(long)]
    data: PathBuf,
    /// Validation measurements (spec §8 CSV): Table 4 of the nominal (after registration)
    /// and the identified model's predictions.
    #[arg(long, conflicts_with = "every")]
    validate: Option<PathBuf>,
    /// Hold-out split of --data: identify on data rows OFFSET, OFFSET+K, OFFSET+2K, …
    /// (0-based, comments and blank lines not counted) and validate on all the others.
    #[arg(long, value_name = "K")]
    every: Option<usize>,
    /// First identification row of --every.
    #[arg(long, default_value_t = 0, requires = "every")]
    offset: usize,
    /// Parameters to identify: `paper` (all, redundant ones included), `minimal` (the
    /// identifiable set at the registered nominal model), or comma-separated names.
    #[arg(long, default_value = "paper")]
    params: String,
    /// Damping schedule.
    #[arg(long, value_enum, default_value_t = Schedule::Levenberg)]
    schedule: Schedule,
    /// Free parameters exactly redundant at the start (e.g. 10 of the UR10's 35): held at
    /// their start values, or kept in the damped system as the paper does.
    #[arg(long, value_enum, default_value_t = RedundantArg::Hold)]
    redundant: RedundantArg,
    /// Registration of the measurement frame.
    #[arg(long, value_enum, default_value_t = Registration::Auto)]
    registration: Registration,
    /// Drop the outliers found after the first fit and refit (without it they are only
    /// reported).
    #[arg(long)]
    reject_outliers: bool,
    /// Outlier threshold: ‖residual‖ > k·σ̂₃, σ̂₃ = √3·σ̂ the fit's 3-D residual scale.
    #[arg(long, default_value_t = 3.0, value_name = "K")]
    outlier_k: f64,
    /// Worst points listed in the report, per data set.
    #[arg(long, default_value_t = 10, value_name = "N")]
    worst: usize,
    /// Output directory, created if missing (only once everything succeeded).
    #[arg(long, default_value = "identified")]
    out: PathBuf,
}

/// File names in the output directory.
pub const ROBOT_FILE: &str = "identified.json";
/// The nominal robot in the measurement frame (its base registered on the data).
pub const REGISTERED_FILE: &str = "registered-nominal.json";
/// The parameter table.
pub const PARAMETERS_FILE: &str = "parameters.json";
/// The report.
pub const REPORT_FILE: &str = "report.md";

/// Validation of the nominal and identified models on one measurement set.
struct Validation {
    source: String,
    rows: Vec<Measurement>,
    /// measured − identified.
    after: Vec<[f64; 3]>,
    table: Table4,
    /// Mean and max of the nominal model rigidly registered on these points themselves.
    self_registered: Option<(f64, f64)>,
}

/// Everything the outputs are rendered from.
struct Outcome<'a> {
    args: &'a IdentifyArgs,
    nominal: &'a LoadedRobot,
    start: Robot,
    registration: Option<RegistrationReport>,
    selection: String,
    used: Vec<Measurement>,
    free: Vec<usize>,
    first: Fit,
    screen: Option<OutlierScreen>,
    /// Rows screened (the rows of the first fit), for labels.
    screened_rows: Vec<Measurement>,
    rejected: bool,
    fit: Fit,
    analysis: IdentifiabilityReport,
    validation: Option<Validation>,
}

/// Rows needed so that 3·rows ≥ the free parameters of `set`, and that count. For `minimal`
/// the count is the structural rank of the nominal model (on generic random poses).
fn free_count(robot: &Robot, set: &ParamSet, opts: &IdentifiabilityOptions) -> Result<usize> {
    Ok(match set {
        ParamSet::Paper => robot.n_params(),
        ParamSet::Names(_) => set.resolve(robot, &[], None, opts)?.len(),
        ParamSet::Minimal => {
            let all: Vec<usize> = (0..robot.n_params()).collect();
            random_poses(robot, robot.n_params(), 1)
                .ok()
                .and_then(|poses| analyze(robot, &poses, None, &all, opts).ok())
                .map_or(robot.n_params(), |a| a.identifiable.len())
        }
    })
}

fn to_arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn norms(errors: &[[f64; 3]]) -> Vec<f64> {
    errors
        .iter()
        .map(|e| Vector3::from(*e).norm())
        .collect::<Vec<_>>()
}

fn mean_max(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v.iter().copied().fold(0.0, f64::max))
}

/// Residuals `measured − robot` of `rows`.
fn residuals(robot: &Robot, rows: &[Measurement]) -> Vec<[f64; 3]> {
    let n = robot.n_joints();
    let poses = poses_rad(rows);
    poses
        .chunks_exact(n)
        .zip(points_mm(rows))
        .map(|(q, p)| to_arr(p - robot.point(q)))
        .collect()
}

fn register(
    nominal: &Robot,
    poses: &[f64],
    points: &[Vector3<f64>],
    policy: Registration,
) -> Result<(Robot, Option<RegistrationReport>)> {
    let before = mean_point_error(nominal, poses, points);
    let apply = match policy {
        Registration::Never => return Ok((nominal.clone(), None)),
        Registration::Always => true,
        Registration::Auto => match RegistrationPolicy::default() {
            RegistrationPolicy::Auto { threshold_mm } => before > threshold_mm,
            _ => true,
        },
    };
    if apply {
        let (r, rep) = register_base(nominal, poses, points).context("registering the base")?;
        return Ok((r, Some(rep)));
    }
    let layout = nominal.layout();
    let x = nominal.params();
    let base: Vec<f64> = [
        "base_rx", "base_ry", "base_rz", "base_dx", "base_dy", "base_dz",
    ]
    .iter()
    .map(|n| {
        let k = layout.index_of(n).expect("every layout has a base");
        layout.get(k).to_display(x[k])
    })
    .collect();
    let b: [f64; 6] = base.try_into().expect("six base parameters");
    Ok((
        nominal.clone(),
        Some(RegistrationReport {
            applied: false,
            mean_error_before_mm: before,
            mean_error_after_mm: before,
            rotation_deg: 0.0,
            translation_mm: [0.0; 3],
            base_before: b,
            base_after: b,
        }),
    ))
}

/// `cargo xtask identify`.
pub fn run(args: &IdentifyArgs) -> Result<()> {
    if !(args.outlier_k.is_finite() && args.outlier_k > 0.0) {
        bail!(
            "--outlier-k {}: must be a finite number > 0",
            args.outlier_k
        );
    }
    if let Some(k) = args.every {
        if k == 0 {
            bail!("--every must be at least 1");
        }
        if args.offset >= k {
            bail!("--offset {} must be below --every {k}", args.offset);
        }
    }
    let nominal = LoadedRobot::load(&args.robot, "robot")?;
    let nom = &nominal.robot;
    let id_opts = IdentifiabilityOptions::default();
    let set: ParamSet = args.params.parse().expect("infallible");
    let n_free =
        free_count(nom, &set, &id_opts).with_context(|| format!("--params {}", args.params))?;
    let min_rows = n_free.div_ceil(3);
    let why = format!(
        "{n_free} free parameters (--params {}) need at least {min_rows} rows: 3 equations per \
         row, at least as many equations as free parameters",
        args.params
    );
    let data = read_set(
        &nominal,
        &args.data,
        true,
        (min_rows, Some(&why)),
        "identification data",
    )?;
    let n_file_rows = data.rows.len();

    // Split.
    let (id_rows, val_rows, selection) = match args.every {
        Some(k) => {
            let (mut sel, mut rest) = (Vec::new(), Vec::new());
            for (i, r) in data.rows.iter().enumerate() {
                if i % k == args.offset {
                    sel.push(r.clone());
                } else {
                    rest.push(r.clone());
                }
            }
            if sel.len() < min_rows {
                return Err(MeasurementError::TooFewRows {
                    file: data.source.clone(),
                    found: sel.len(),
                    needed: min_rows,
                })
                .with_context(|| {
                    format!(
                        "--every {k} --offset {} selects {} of the {n_file_rows} data rows; {why}",
                        args.offset,
                        sel.len()
                    )
                });
            }
            let text = format!(
                "{} of {n_file_rows} rows (data rows {}, {}, {}, … — every {k}th from {})",
                sel.len(),
                args.offset,
                args.offset + k,
                args.offset + 2 * k,
                args.offset
            );
            let val = (!rest.is_empty()).then(|| {
                (
                    format!("{} (the {} other rows)", data.source, rest.len()),
                    rest,
                )
            });
            (sel, val, text)
        }
        None => {
            let val = match &args.validate {
                Some(path) => {
                    let v = read_set(&nominal, path, true, (1, None), "validation data")?;
                    Some((v.source, v.rows))
                }
                None => None,
            };
            (data.rows.clone(), val, format!("all {n_file_rows} rows"))
        }
    };

    let started = Instant::now();
    let poses = poses_rad(&id_rows);
    let points = points_mm(&id_rows);
    let (start, registration) = register(nom, &poses, &points, args.registration)
        .with_context(|| format!("identification data {}", data.source))?;
    let free = set
        .resolve(&start, &poses, None, &id_opts)
        .with_context(|| format!("--params {}", args.params))?;
    let options = IdentifyOptions {
        lm: LmOptions {
            redundant: match args.redundant {
                RedundantArg::Hold => Redundant::Hold,
                RedundantArg::Damp => Redundant::Damp,
            },
            ..LmOptions::with_damping(args.schedule.damping())
        },
        registration: RegistrationPolicy::Never,
        ..IdentifyOptions::default()
    };
    let fit_rows = |rows: &[Measurement]| -> Result<Fit> {
        let (p, x) = (poses_rad(rows), points_mm(rows));
        let problem = Problem::new(&start, &p, &x, free.clone())
            .with_context(|| format!("setting up the identification on {}", data.source))?;
        identify(&problem, &options)
            .with_context(|| format!("identifying {} on {}", nom.name(), data.source))
    };
    let first = fit_rows(&id_rows)?;
    let screen = match first.sigma_hat {
        Some(s) => Some(
            outliers::screen(&first.robot, &poses, &points, s, args.outlier_k)
                .context("screening outliers")?,
        ),
        None => None,
    };
    let flagged = screen.as_ref().map_or_else(Vec::new, |s| s.indices());
    let rejected = args.reject_outliers && !flagged.is_empty();
    let (fit, used) = if rejected {
        let kept: Vec<Measurement> = id_rows
            .iter()
            .enumerate()
            .filter(|(i, _)| flagged.binary_search(i).is_err())
            .map(|(_, r)| r.clone())
            .collect();
        if 3 * kept.len() < free.len() {
            bail!(
                "{}: {} of {} rows are outliers; the {} left are too few for {} free parameters \
                 (3 equations per row) — run without --reject-outliers",
                data.source,
                flagged.len(),
                id_rows.len(),
                kept.len(),
                free.len()
            );
        }
        let refit = fit_rows(&kept).context("refitting without the outliers")?;
        (refit, kept)
    } else {
        (first.clone(), id_rows.clone())
    };
    let analysis = analyze(&fit.robot, &poses_rad(&used), None, &free, &id_opts)
        .context("identifiability at the solution")?;
    let validation = match val_rows {
        Some((source, rows)) => {
            let before = residuals(&start, &rows);
            let after = residuals(&fit.robot, &rows);
            let table = Table4::from_errors(&before, &after).context("validation statistics")?;
            let (vp, vx) = (poses_rad(&rows), points_mm(&rows));
            let self_registered = register_base(nom, &vp, &vx)
                .ok()
                .map(|(r, _)| mean_max(&norms(&residuals(&r, &rows))));
            Some(Validation {
                source,
                rows,
                after,
                table,
                self_registered,
            })
        }
        None => None,
    };
    let elapsed_ms = started.elapsed().as_secs_f64() * 1e3;

    let outcome = Outcome {
        args,
        nominal: &nominal,
        start,
        registration,
        selection,
        used,
        free,
        first,
        screen,
        screened_rows: id_rows,
        rejected,
        fit,
        analysis,
        validation,
    };

    // Render everything, then write.
    let mut robot = outcome.fit.robot.clone();
    robot.set_name(format!(
        "{}, identified from {}",
        nom.name(),
        file_name(&args.data)
    ));
    let robot_json = robot.to_spec().to_json_string();
    let mut registered = outcome.start.clone();
    if outcome.registration.as_ref().is_some_and(|r| r.applied) {
        registered.set_name(format!(
            "{}, base registered on {}",
            nom.name(),
            file_name(&args.data)
        ));
    }
    let registered_json = registered.to_spec().to_json_string();
    let params_json = parameters_json(&outcome);
    let report = render_report(&outcome);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    for (name, text) in [
        (ROBOT_FILE, &robot_json),
        (REGISTERED_FILE, &registered_json),
        (PARAMETERS_FILE, &params_json),
        (REPORT_FILE, &report),
    ] {
        let path = args.out.join(name);
        measurements::write_atomically(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    print_summary(&outcome, elapsed_ms);
    Ok(())
}

/// `nominal, registered` or `nominal`: the model the fit started from.
fn start_label(o: &Outcome) -> &'static str {
    if o.registration.as_ref().is_some_and(|r| r.applied) {
        "nominal, registered"
    } else {
        "nominal"
    }
}

fn schedule_name(args: &IdentifyArgs) -> &'static str {
    args.schedule.damping().name()
}

/// One row of `parameters.json`.
#[derive(Serialize)]
struct ParamRow<'a> {
    name: &'a str,
    unit: &'static str,
    free: bool,
    nominal: f64,
    start: f64,
    identified: f64,
    delta: f64,
    std_error: Option<f64>,
    identifiable: bool,
}

/// `parameters.json`.
#[derive(Serialize)]
struct ParamTable<'a> {
    format: &'static str,
    robot_file: &'static str,
    nominal_robot: String,
    data: String,
    rows: usize,
    params: &'a str,
    free: usize,
    rank: usize,
    sigma_hat_mm: Option<f64>,
    rms_mm: f64,
    columns: BTreeMap<&'static str, &'static str>,
    parameters: Vec<ParamRow<'a>>,
}

fn parameters_json(o: &Outcome) -> String {
    let layout = o.start.layout();
    let (xn, xs) = (o.nominal.robot.params(), o.start.params());
    let cov = o.fit.covariance.as_ref();
    let parameters = layout
        .params()
        .iter()
        .enumerate()
        .map(|(k, info)| {
            let nominal = info.to_display(xn[k]);
            let identified = info.to_display(o.fit.params[k]);
            ParamRow {
                name: &info.name,
                unit: info.unit.as_str(),
                free: o.free.contains(&k),
                nominal,
                start: info.to_display(xs[k]),
                identified,
                delta: identified - nominal,
                std_error: cov.and_then(|c| c.std_error(&info.name)),
                identifiable: match cov {
                    Some(c) => c.parameters.contains(&info.name),
                    None => o.analysis.identifiable.contains(&info.name),
                },
            }
        })
        .collect();
    let columns = BTreeMap::from([
        ("nominal", "value in the nominal robot file"),
        (
            "start",
            "value the fit started from (the nominal model after base registration)",
        ),
        (
            "identified",
            "value of the calibrated robot (identified.json)",
        ),
        ("delta", "identified − nominal"),
        (
            "std_error",
            "standard error, for identifiable parameters (null otherwise)",
        ),
        (
            "identifiable",
            "in the identifiable (minimal) subset at the solution; the values of the others \
             are arbitrary along their null-space directions",
        ),
    ]);
    let table = ParamTable {
        format: "kincal-parameters/1",
        robot_file: ROBOT_FILE,
        nominal_robot: o.args.robot.display().to_string(),
        data: o.args.data.display().to_string(),
        rows: o.used.len(),
        params: &o.args.params,
        free: o.free.len(),
        rank: o.analysis.rank,
        sigma_hat_mm: o.fit.sigma_hat,
        rms_mm: o.fit.rms_mm,
        columns,
        parameters,
    };
    let mut s = serde_json::to_string_pretty(&table).expect("the table serialises");
    s.push('\n');
    s
}

fn stats_row(out: &mut String, name: &str, before: f64, after: f64) {
    let pct = improvement_pct(before, after).map_or_else(|| "n/a".into(), |p| format!("{p:.1}"));
    let _ = writeln!(out, "| {name} | {before:.3} | {after:.3} | {pct} |");
}

fn table4_md(out: &mut String, t: &Table4, before: &str) {
    let _ = writeln!(
        out,
        "| statistic | {before} (mm) | calibrated (mm) | improvement (%) |"
    );
    out.push_str("|---|---:|---:|---:|\n");
    type Pick = fn(&AxisStats) -> f64;
    type Axis = fn(&ErrorStats) -> &AxisStats;
    let stats: [(&str, Pick); 4] = [
        ("mean", |a| a.mean_mm),
        ("max", |a| a.max_mm),
        ("RMS", |a| a.rms_mm),
        ("p95", |a| a.p95_mm),
    ];
    let axes: [(&str, Axis); 4] = [
        ("\\|x\\|", |s| &s.x),
        ("\\|y\\|", |s| &s.y),
        ("\\|z\\|", |s| &s.z),
        ("3-D", |s| &s.norm),
    ];
    for (sn, pick) in stats {
        for (an, axis) in axes {
            stats_row(
                out,
                &format!("{sn} {an}"),
                pick(axis(&t.before)),
                pick(axis(&t.after)),
            );
        }
    }
}

fn worst_md(out: &mut String, rows: &[Measurement], errors: &[[f64; 3]], n: usize) {
    let mut idx: Vec<usize> = (0..rows.len()).collect();
    let nrm = norms(errors);
    idx.sort_by(|&a, &b| nrm[b].total_cmp(&nrm[a]).then(a.cmp(&b)));
    out.push_str("| point | line | ‖e‖ (mm) | e_x | e_y | e_z |\n|---|---:|---:|---:|---:|---:|\n");
    for &i in idx.iter().take(n) {
        let e = errors[i];
        let _ = writeln!(
            out,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} |",
            rows[i].id.as_deref().unwrap_or("–"),
            rows[i].line,
            nrm[i],
            e[0],
            e[1],
            e[2]
        );
    }
}

fn render_report(o: &Outcome) -> String {
    let a = o.args;
    let nom = &o.nominal.robot;
    let mut s = String::new();
    let _ = writeln!(s, "# Calibration of {}\n", nom.name());
    let _ = writeln!(
        s,
        "- nominal robot: `{}` ({} joints, {} parameters)",
        a.robot.display(),
        nom.n_joints(),
        nom.n_params()
    );
    let _ = writeln!(
        s,
        "- identification data: `{}`, {}{}",
        a.data.display(),
        o.selection,
        if o.rejected {
            format!(
                "; {} outliers excluded, {} rows used",
                o.screened_rows.len() - o.used.len(),
                o.used.len()
            )
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        s,
        "- free parameters: {} (`--params {}`): {}",
        o.free.len(),
        a.params,
        o.fit.free.join(", ")
    );
    if !o.fit.held.is_empty() {
        let _ = writeln!(
            s,
            "- held at their start values (exactly redundant there, `--redundant hold`): {}",
            o.fit.held.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "- solver: {} damping, column scaling {}; stopped after {} iterations ({} accepted): {}",
        schedule_name(a),
        if o.fit.column_scaling { "on" } else { "off" },
        o.fit.iterations,
        o.fit.accepted_steps,
        o.fit.stop
    );
    if !o.fit.stop.converged() {
        s.push_str(
            "- **not converged**: the solver hit a cap. With (nearly) redundant free parameters \
             the cost is flat along their null-space directions, so their values drift while \
             the predictions stay put; trust the identifiable values only, or use \
             `--params minimal`.\n",
        );
    }
    match &o.registration {
        Some(r) if r.applied => {
            let _ = writeln!(
                s,
                "- registration: applied — mean point error of the nominal model {:.3} mm → {:.3} mm \
                 after a rigid fit (rotation {:.3}°, translation ({:.3}, {:.3}, {:.3}) mm); base \
                 (rx, ry, rz °; dx, dy, dz mm) = ({:.4}, {:.4}, {:.4}; {:.3}, {:.3}, {:.3})",
                r.mean_error_before_mm,
                r.mean_error_after_mm,
                r.rotation_deg,
                r.translation_mm[0],
                r.translation_mm[1],
                r.translation_mm[2],
                r.base_after[0],
                r.base_after[1],
                r.base_after[2],
                r.base_after[3],
                r.base_after[4],
                r.base_after[5]
            );
        }
        Some(r) => {
            let _ = writeln!(
                s,
                "- registration: not needed (nominal mean point error {:.3} mm ≤ 10 mm)",
                r.mean_error_before_mm
            );
        }
        None => s.push_str("- registration: off (`--registration never`)\n"),
    }
    s.push_str(
        "- model: geometry only (spec §2). Compliance, gear errors and other non-geometric \
         effects are not identified; they stay in the residuals.\n",
    );

    s.push_str("\n## Fit residuals\n\n");
    s.push_str("| model | poses | RMS 3-D (mm) | mean 3-D (mm) | max 3-D (mm) |\n|---|---:|---:|---:|---:|\n");
    let start_n = norms(&residuals(&o.start, &o.used));
    let fit_res = residuals(&o.fit.robot, &o.used);
    let fit_n = norms(&fit_res);
    for (name, v) in [(start_label(o), &start_n), ("identified", &fit_n)] {
        let (mean, max) = mean_max(v);
        let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let _ = writeln!(
            s,
            "| {name} | {} | {rms:.4} | {mean:.4} | {max:.4} |",
            v.len()
        );
    }
    match o.fit.sigma_hat {
        Some(sh) => {
            let _ = writeln!(
                s,
                "\nσ̂ = √(RSS / dof) = {sh:.4} mm per axis (dof = {}).",
                o.fit.dof
            );
        }
        None => s.push_str("\nNo degrees of freedom left: σ̂ undefined.\n"),
    }

    let an = &o.analysis;
    s.push_str("\n## Identifiability at the solution\n\n");
    let _ = writeln!(
        s,
        "Rank {} of {} free parameters ({}; σ_i > {:e}·σ_max).",
        an.rank, an.parameter_count, an.scaling, an.rank_rtol
    );
    if let Some(c) = an.condition_number {
        let _ = writeln!(s, "Condition number of the identifiable part: {c:.2}.");
    }
    if let Some(ob) = &an.observability {
        let _ = writeln!(
            s,
            "\nObservability (singular values of the column-scaled Jacobian, m = {}): \
             O1 {:.4e}, O2 {:.4e}, O3 {:.4e}, O4 {:.4e}, O5 {:.4e}.",
            an.n_poses, ob.o1, ob.o2, ob.o3, ob.o4, ob.o5
        );
    }
    if an.redundancies.is_empty() {
        s.push_str("\nRedundant set: none.\n");
    } else {
        let _ = writeln!(
            s,
            "\nRedundant set ({}; values arbitrary, no standard error):\n",
            an.redundant.len()
        );
        for r in &an.redundancies {
            let with: Vec<String> = r
                .confounded_with
                .iter()
                .map(|t| format!("{} ({:+.3})", t.name, t.weight))
                .collect();
            let with = if with.is_empty() {
                "nothing: it does not move the point".to_string()
            } else {
                with.join(", ")
            };
            let _ = writeln!(s, "- `{}` confounded with {with}", r.name);
        }
    }

    s.push_str("\n## Parameters\n\n");
    s.push_str(
        "Nominal = robot file; identified = `identified.json`; Δ = identified − nominal (for \
         the base this includes the registration).\n\n",
    );
    s.push_str("| parameter | unit | nominal | identified | Δ | std error | identifiable |\n|---|---|---:|---:|---:|---:|---|\n");
    let layout = o.start.layout();
    let xn = nom.params();
    let cov = o.fit.covariance.as_ref();
    for (k, info) in layout.params().iter().enumerate() {
        let (n, v) = (info.to_display(xn[k]), info.to_display(o.fit.params[k]));
        let se = cov.and_then(|c| c.std_error(&info.name));
        let ident = if !o.free.contains(&k) {
            "fixed"
        } else if se.is_some() || an.identifiable.contains(&info.name) {
            "yes"
        } else {
            "no"
        };
        let _ = writeln!(
            s,
            "| {} | {} | {n:.5} | {v:.5} | {:.5} | {} | {ident} |",
            info.name,
            info.unit.as_str(),
            v - n,
            se.map_or_else(|| "–".into(), |e| format!("{e:.5}"))
        );
    }

    s.push_str("\n## Correlations above 0.9\n\n");
    match cov {
        Some(c) if !c.high_correlations.is_empty() => {
            s.push_str("| a | b | ρ |\n|---|---|---:|\n");
            for p in &c.high_correlations {
                let _ = writeln!(s, "| {} | {} | {:+.4} |", p.a, p.b, p.rho);
            }
        }
        Some(_) => s.push_str("None.\n"),
        None => s.push_str("No covariance (no degrees of freedom).\n"),
    }

    s.push_str("\n## Outliers\n\n");
    match &o.screen {
        Some(sc) => {
            let _ = writeln!(
                s,
                "Screened after the first fit: ‖e‖ > k·σ̂₃ = {} × {:.4} = {:.4} mm (σ̂₃ = √3·σ̂, \
                 first-fit RMS {:.4} mm).",
                sc.k, sc.sigma_3d_mm, sc.threshold_mm, o.first.rms_mm
            );
            if sc.outliers.is_empty() {
                s.push_str("\nNone.\n");
            } else {
                let _ = writeln!(
                    s,
                    "\n{} point(s) — {}:\n",
                    sc.outliers.len(),
                    if o.rejected {
                        format!(
                            "excluded and refitted (RMS {:.4} → {:.4} mm)",
                            o.first.rms_mm, o.fit.rms_mm
                        )
                    } else {
                        "kept (use `--reject-outliers` to exclude them and refit)".to_string()
                    }
                );
                s.push_str("| point | line | ‖e‖ (mm) | ‖e‖/σ̂₃ |\n|---|---:|---:|---:|\n");
                for ol in &sc.outliers {
                    let r = &o.screened_rows[ol.index];
                    let _ = writeln!(
                        s,
                        "| {} | {} | {:.4} | {:.2} |",
                        r.id.as_deref().unwrap_or("–"),
                        r.line,
                        ol.norm_mm,
                        ol.ratio
                    );
                }
            }
        }
        None => s.push_str("Not screened (no degrees of freedom).\n"),
    }

    let _ = writeln!(s, "\n## Worst identification points (identified model)\n");
    worst_md(&mut s, &o.used, &fit_res, a.worst);

    if let Some(v) = &o.validation {
        let _ = writeln!(s, "\n## Validation on {}\n", v.source);
        let _ = writeln!(
            s,
            "{} poses never used to identify. Before: the nominal model (after registration, \
             if any: the model the fit started from) vs measured; after: the identified \
             model's prediction vs measured. e = measured − predicted.\n",
            v.rows.len()
        );
        table4_md(&mut s, &v.table, start_label(o));
        if let Some((mean, max)) = v.self_registered {
            let _ = writeln!(
                s,
                "\nFor reference, the nominal model rigidly registered on these validation \
                 points themselves (the best any frame alone can do): mean {mean:.3} mm, max \
                 {max:.3} mm."
            );
        }
        s.push_str("\n### Worst validation points (identified model)\n\n");
        worst_md(&mut s, &v.rows, &v.after, a.worst);
    } else {
        s.push_str("\n## Validation\n\nNo validation data (`--validate FILE` or `--every K`).\n");
    }
    s
}

fn print_summary(o: &Outcome, elapsed_ms: f64) {
    let a = o.args;
    let nom = &o.nominal.robot;
    println!(
        "{} — {} of {} ({} free parameters, --params {}, {} damping)",
        nom.name(),
        o.selection,
        a.data.display(),
        o.free.len(),
        a.params,
        schedule_name(a)
    );
    if let Some(r) = &o.registration
        && r.applied
    {
        println!(
            "registration: nominal mean error {:.3} mm → {:.3} mm (rotation {:.3}°, translation \
             {:.1} mm)",
            r.mean_error_before_mm,
            r.mean_error_after_mm,
            r.rotation_deg,
            Vector3::from(r.translation_mm).norm()
        );
    }
    let (_, fit_max) = mean_max(&norms(&residuals(&o.fit.robot, &o.used)));
    println!(
        "fit: RMS {:.4} mm, max {:.4} mm on {} poses; σ̂ {} mm/axis; rank {} of {}; {} after {} \
         iterations; {:.1} ms",
        o.fit.rms_mm,
        fit_max,
        o.used.len(),
        o.fit
            .sigma_hat
            .map_or_else(|| "n/a".into(), |v| format!("{v:.4}")),
        o.analysis.rank,
        o.free.len(),
        o.fit.stop,
        o.fit.iterations,
        elapsed_ms
    );
    if !o.fit.held.is_empty() {
        println!(
            "held at their start values (exactly redundant there; --redundant damp keeps them \
             in the damped system): {}",
            o.fit.held.join(", ")
        );
    }
    if !o.fit.stop.converged() {
        println!(
            "warning: the solver stopped without converging ({}): some free parameters are \
             (nearly) redundant and drift along a flat valley; predictions are unaffected, \
             but only the identifiable values mean anything — try --params minimal",
            o.fit.stop
        );
    }
    if let Some(sc) = &o.screen {
        if sc.outliers.is_empty() {
            println!(
                "outliers (‖e‖ > {} σ̂₃ = {:.4} mm): none",
                sc.k, sc.threshold_mm
            );
        } else {
            let list: Vec<String> = sc
                .outliers
                .iter()
                .take(10)
                .map(|ol| {
                    format!(
                        "{} {:.3} mm",
                        row_label(&o.screened_rows[ol.index]),
                        ol.norm_mm
                    )
                })
                .collect();
            println!(
                "outliers (‖e‖ > {} σ̂₃ = {:.4} mm): {} — {}{}; {}",
                sc.k,
                sc.threshold_mm,
                sc.outliers.len(),
                list.join(", "),
                if sc.outliers.len() > 10 { ", …" } else { "" },
                if o.rejected {
                    format!(
                        "excluded, refitted: RMS {:.4} → {:.4} mm",
                        o.first.rms_mm, o.fit.rms_mm
                    )
                } else {
                    "kept (--reject-outliers to exclude)".to_string()
                }
            );
        }
    }
    if let Some(v) = &o.validation {
        let (b, af) = (&v.table.before.norm, &v.table.after.norm);
        println!(
            "validation: {} poses of {}: {} mean {:.3} mm, max {:.3} mm → calibrated mean \
             {:.3} mm, max {:.3} mm",
            v.rows.len(),
            v.source,
            if start_label(o) == "nominal" {
                "nominal"
            } else {
                "nominal (registered)"
            },
            b.mean_mm,
            b.max_mm,
            af.mean_mm,
            af.max_mm
        );
    }
    println!(
        "→ {}: {ROBOT_FILE} (the calibrated robot), {REGISTERED_FILE} (the nominal robot in \
         the same frame: compensation targets), {PARAMETERS_FILE} (parameter table), \
         {REPORT_FILE}",
        a.out.display(),
    );
}
