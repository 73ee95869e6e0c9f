//! The calibration workflow on a measurement file (`docs/model.md` §5):
//!
//! read → (split) → register the base if the data are in another frame → identify → screen
//! outliers (refit without them on request) → analyse identifiability at the solution →
//! validate → render `identified.json`, `registered-nominal.json`, `parameters.json` and
//! `report.md` in memory ([`Calibration::render`]) → write them atomically into the output
//! directory, which is created only then ([`Rendered::write_to`]).

use report::fmt::mm;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use evaluate::{AxisStats, ErrorStats, Table4, improvement_pct};
use identify::{
    Damping, Fit, IdentifiabilityOptions, IdentifiabilityReport, IdentifyOptions, LmOptions,
    OutlierScreen, ParamSet, Problem, Redundant, RegistrationPolicy, RegistrationReport, analyze,
    generic_poses, identify, mean_point_error, outliers, register_base,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementError};
use nalgebra::Vector3;
use serde::Serialize;

use crate::error::{CalibrateError, Result, id_err};
use crate::files::{LoadedRobot, file_name, points_mm, poses_rad, row_label};

/// The damping schedule (`docs/model.md` §7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Schedule {
    /// The paper's: (JᵀJ + μI), μ0 = 1e-3, ÷10 / ×10.
    #[default]
    Levenberg,
    /// (JᵀJ + μ diag JᵀJ), same updates.
    Marquardt,
    /// Nielsen's gain-ratio schedule.
    Nielsen,
}

impl Schedule {
    /// The solver's damping for this schedule.
    pub fn damping(self) -> Damping {
        match self {
            Schedule::Levenberg => Damping::levenberg(),
            Schedule::Marquardt => Damping::marquardt(),
            Schedule::Nielsen => Damping::nielsen(),
        }
    }
}

/// What the solver does with free parameters exactly redundant at the start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum RedundantArg {
    /// Hold them at their start values and solve on the identifiable rest [default: the
    /// solve is well posed and converges in a few iterations].
    #[default]
    Hold,
    /// Keep them in the damped system (the paper's verbatim method).
    Damp,
}

/// When to register the measurement frame onto the robot base before identifying.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Registration {
    /// When the nominal model misses the points by more than 10 mm on average [default:
    /// geometric errors are millimetres, a tracker frame is metres away].
    #[default]
    Auto,
    /// Always.
    Always,
    /// Never (the paper's procedure: LM from the nominal model).
    Never,
}

/// Which data rows identify and which validate.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Split {
    /// All rows identify; validation, if any, comes from another file.
    #[default]
    All,
    /// Identify on data rows `offset`, `offset + every`, … (0-based, comments and blank lines
    /// not counted) and validate on all the others.
    Every {
        /// K ≥ 1.
        every: usize,
        /// First identification row, below `every`.
        offset: usize,
    },
    /// Identify on `poses` rows chosen by design (`design::select_rows`: greedy selection then
    /// exchange by `criterion`, on the nominal model's minimal identifiable set, using only the
    /// rows' joints) and validate on all the others: what `poses` well-chosen poses of the
    /// recording would have given.
    Select {
        /// Rows to choose; 3·poses must cover the free parameters.
        poses: usize,
        /// Design criterion.
        criterion: design::Criterion,
    },
}

/// What to calibrate and how. Every field is an option of `kincal identify`.
#[derive(Clone, Debug)]
pub struct IdentifyRequest {
    /// Nominal robot model file (JSON); its joint limits check the data.
    pub robot: PathBuf,
    /// Identification measurements.
    pub data: PathBuf,
    /// Validation measurements (with [`Split::All`] only).
    pub validate: Option<PathBuf>,
    /// Hold-out split of `data`.
    pub split: Split,
    /// Parameters to identify: `paper` (all), `minimal` (the identifiable set at the
    /// registered nominal model), or comma-separated names [`paper`: the paper's method].
    pub params: String,
    /// Damping schedule [Levenberg: the paper's].
    pub schedule: Schedule,
    /// Exactly redundant free parameters (default: held).
    pub redundant: RedundantArg,
    /// Registration of the measurement frame (default: auto).
    pub registration: Registration,
    /// Drop the outliers found after the first fit and refit [no: only reported].
    pub reject_outliers: bool,
    /// Outlier threshold k: ‖residual‖ > k·σ̂₃ [3: fewer than one Gaussian point in 10⁵].
    pub outlier_k: f64,
    /// Worst points listed in the report, per data set (default: 10).
    pub worst: usize,
}

impl IdentifyRequest {
    /// A request with every option at its default.
    pub fn new(robot: impl Into<PathBuf>, data: impl Into<PathBuf>) -> Self {
        IdentifyRequest {
            robot: robot.into(),
            data: data.into(),
            validate: None,
            split: Split::All,
            params: "paper".into(),
            schedule: Schedule::default(),
            redundant: RedundantArg::default(),
            registration: Registration::default(),
            reject_outliers: false,
            outlier_k: 3.0,
            worst: 10,
        }
    }
}

/// File names in the output directory: the calibrated robot.
pub const ROBOT_FILE: &str = "identified.json";
/// The nominal robot in the measurement frame (its base registered on the data).
pub const REGISTERED_FILE: &str = "registered-nominal.json";
/// The parameter table.
pub const PARAMETERS_FILE: &str = "parameters.json";
/// The report.
pub const REPORT_FILE: &str = "report.md";
/// The report as a self-contained HTML page with the plots inline.
pub const REPORT_HTML_FILE: &str = "report.html";

/// Validation of the nominal and identified models on one measurement set.
#[derive(Clone, Debug)]
pub struct Validation {
    /// Where the rows come from.
    pub source: String,
    /// The validation rows.
    pub rows: Vec<Measurement>,
    /// measured − start model (the nominal after registration).
    pub before: Vec<[f64; 3]>,
    /// measured − identified.
    pub after: Vec<[f64; 3]>,
    /// Table 4 of before and after.
    pub table: Table4,
    /// Mean and max of the nominal model rigidly registered on these points themselves.
    pub self_registered: Option<(f64, f64)>,
}

/// A finished calibration: everything the outputs are rendered from.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// What was asked.
    pub request: IdentifyRequest,
    /// The nominal robot file.
    pub nominal: LoadedRobot,
    /// The model the fit started from (the nominal after registration).
    pub start: Robot,
    /// The registration, if considered.
    pub registration: Option<RegistrationReport>,
    /// Which rows identified, in words.
    pub selection: String,
    /// The identification rows used by the final fit.
    pub used: Vec<Measurement>,
    /// Free parameter indices.
    pub free: Vec<usize>,
    /// The first fit (before outlier rejection).
    pub first: Fit,
    /// The outlier screen after the first fit.
    pub screen: Option<OutlierScreen>,
    /// Rows screened (the rows of the first fit), for labels.
    pub screened_rows: Vec<Measurement>,
    /// Whether outliers were excluded and the model refitted.
    pub rejected: bool,
    /// The final fit.
    pub fit: Fit,
    /// Identifiability at the solution.
    pub analysis: IdentifiabilityReport,
    /// Validation, if validation rows were given.
    pub validation: Option<Validation>,
    /// Reader notices (ignored columns), in reading order.
    pub notices: Vec<String>,
    /// Wall-clock time of registration, identification and validation (ms).
    pub elapsed_ms: f64,
}

/// The output files, rendered: the four files, [`REPORT_HTML_FILE`] and the plots of
/// [`report::identify::IDENTIFY_PLOT_FILES`].
#[derive(Clone, Debug)]
pub struct Rendered {
    /// `(file name, contents)`, in writing order.
    pub files: Vec<(String, String)>,
}

impl Rendered {
    /// Creates `dir` and writes every file atomically into it.
    pub fn write_to(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|source| CalibrateError::Write {
            path: dir.to_path_buf(),
            source,
        })?;
        // All or nothing: on a full disk no output of an earlier run is replaced.
        measurements::write_all_atomically(dir, &self.files).map_err(|source| {
            CalibrateError::Write {
                path: dir.to_path_buf(),
                source,
            }
        })
    }
}

/// Rows needed so that 3·rows ≥ the free parameters of `set`, and that count. For `minimal`
/// the count is the structural rank of the nominal model (on generic random poses).
/// Splits `--params` into its base set (`paper`, `minimal` or names) and the non-geometric
/// parameters after `+`: the families `compliance` (every joint's) and `gears` (the first
/// harmonic, sine and cosine, of every joint), or names (`compliance_2`, `gear_1_h2_sin`).
/// `paper+compliance+gears` → (`paper`, [compliance_1 … gear_6_h1_cos]).
pub fn split_params(params: &str, n_joints: usize) -> (String, Vec<String>) {
    let mut parts = params.split('+').map(str::trim);
    let base = parts.next().unwrap_or("paper").to_string();
    let mut ext = Vec::new();
    for p in parts {
        if p.contains(',') {
            ext.extend(p.split(',').map(|n| n.trim().to_string()));
        } else {
            ext.extend(kinematics::expand_family(p, n_joints));
        }
    }
    (base, ext)
}

fn free_count(robot: &Robot, set: &ParamSet, opts: &IdentifiabilityOptions) -> Result<usize> {
    Ok(match set {
        ParamSet::Paper => robot.n_params(),
        ParamSet::Names(_) => set
            .resolve(robot, &[], None, opts)
            .map_err(id_err("resolving the parameter names"))?
            .len(),
        ParamSet::Minimal => {
            let all: Vec<usize> = (0..robot.n_params()).collect();
            generic_poses(robot)
                .ok()
                .and_then(|poses| analyze(robot, &poses, None, &all, opts).ok())
                .map_or(robot.n_params(), |a| a.identifiable.len())
        }
    })
}

fn to_arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The 3-D norms of error vectors.
pub fn norms(errors: &[[f64; 3]]) -> Vec<f64> {
    errors.iter().map(|e| Vector3::from(*e).norm()).collect()
}

fn mean_max(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v.iter().copied().fold(0.0, f64::max))
}

/// Residuals `measured − robot` of `rows` (which have points), mm.
pub fn residuals(robot: &Robot, rows: &[Measurement]) -> Vec<[f64; 3]> {
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
        let (r, rep) =
            register_base(nominal, poses, points).map_err(id_err("registering the base"))?;
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

/// Runs the whole calibration of `request`: nothing is written (see [`Calibration::render`]
/// and [`Rendered::write_to`]).
pub fn run(request: &IdentifyRequest) -> Result<Calibration> {
    let args = request;
    if !(args.outlier_k.is_finite() && args.outlier_k > 0.0) {
        return Err(CalibrateError::Refused(format!(
            "--outlier-k {}: must be a finite number > 0",
            args.outlier_k
        )));
    }
    if let Split::Every { every, offset } = args.split {
        if every == 0 {
            return Err(CalibrateError::Refused("--every must be at least 1".into()));
        }
        if offset >= every {
            return Err(CalibrateError::Refused(format!(
                "--offset {offset} must be below --every {every}"
            )));
        }
        if args.validate.is_some() {
            return Err(CalibrateError::Refused(
                "--validate and --every exclude each other: --every validates on the rows it \
                 does not identify on"
                    .into(),
            ));
        }
    }
    if let Split::Select { .. } = args.split
        && args.validate.is_some()
    {
        return Err(CalibrateError::Refused(
            "--validate and --select exclude each other: --select validates on the rows it \
             does not identify on"
                .into(),
        ));
    }
    let mut nominal = LoadedRobot::load(&args.robot, "robot")?;
    // `--params BASE+FAMILY+…`: the extended families join the geometric parameters.
    let (base_set, extended) = split_params(&args.params, nominal.robot.n_joints());
    if !extended.is_empty() {
        nominal.robot = nominal
            .robot
            .with_extended(&extended, &args.robot.display().to_string())
            .map_err(|source| CalibrateError::Robot {
                what: "robot (--params)",
                path: args.robot.clone(),
                source,
            })?;
    }
    let nom = &nominal.robot;
    let id_opts = IdentifiabilityOptions::default();
    let set: ParamSet = base_set.parse().expect("infallible");
    let n_free = free_count(nom, &set, &id_opts)
        .map_err(|e| e.context(format!("--params {}", args.params)))?;
    let min_rows = n_free.div_ceil(3);
    let why = format!(
        "{n_free} free parameters (--params {}) need at least {min_rows} rows: 3 equations per \
         row, at least as many equations as free parameters",
        args.params
    );
    let data = nominal.read_set(
        &args.data,
        true,
        (min_rows, Some(&why)),
        "identification data",
    )?;
    let mut notices = data.notices.clone();
    let n_file_rows = data.rows.len();

    // Split.
    let (id_rows, val_rows, selection) = match args.split {
        Split::Every { every: k, offset } => {
            let (mut sel, mut rest) = (Vec::new(), Vec::new());
            for (i, r) in data.rows.iter().enumerate() {
                if i % k == offset {
                    sel.push(r.clone());
                } else {
                    rest.push(r.clone());
                }
            }
            if sel.len() < min_rows {
                return Err(CalibrateError::Read {
                    context: format!(
                        "--every {k} --offset {offset} selects {} of the {n_file_rows} data \
                         rows; {why}",
                        sel.len()
                    ),
                    source: MeasurementError::TooFewRows {
                        file: data.source.clone(),
                        found: sel.len(),
                        needed: min_rows,
                    },
                });
            }
            let text = format!(
                "{} of {n_file_rows} rows (data rows {offset}, {}, {}, … — every {k}th from \
                 {offset})",
                sel.len(),
                offset + k,
                offset + 2 * k,
            );
            let val = (!rest.is_empty()).then(|| {
                (
                    format!("{} (the {} other rows)", data.source, rest.len()),
                    rest,
                )
            });
            (sel, val, text)
        }
        Split::Select {
            poses: n,
            criterion,
        } => {
            let n_rows = data.rows.len();
            if n < min_rows {
                return Err(CalibrateError::Refused(format!("--select {n}: {why}")));
            }
            if n >= n_rows {
                return Err(CalibrateError::Refused(format!(
                    "--select {n}: {} has {n_rows} rows; choose fewer so that the others \
                     validate",
                    data.source
                )));
            }
            let q_deg: Vec<f64> = data.rows.iter().flat_map(|r| r.q_deg.clone()).collect();
            let chosen =
                design::select_rows(nom, &q_deg, n, criterion, None).map_err(|source| {
                    CalibrateError::Design {
                        context: format!(
                            "--select {n} --criterion {}: choosing rows of {}",
                            criterion.as_str(),
                            data.source
                        ),
                        source,
                    }
                })?;
            let (mut sel, mut rest) = (Vec::new(), Vec::new());
            for (i, r) in data.rows.iter().enumerate() {
                if chosen.binary_search(&i).is_ok() {
                    sel.push(r.clone());
                } else {
                    rest.push(r.clone());
                }
            }
            let lines: Vec<String> = sel.iter().take(3).map(|r| r.line.to_string()).collect();
            let text = format!(
                "{} of {n_rows} rows chosen by the {} criterion on their joints (lines {}, …)",
                sel.len(),
                criterion.as_str().to_uppercase(),
                lines.join(", "),
            );
            let val = Some((
                format!("{} (the {} other rows)", data.source, rest.len()),
                rest,
            ));
            (sel, val, text)
        }
        Split::All => {
            let val = match &args.validate {
                Some(path) => {
                    let v = nominal.read_set(path, true, (1, None), "validation data")?;
                    notices.extend(v.notices);
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
        .map_err(|e| e.context(format!("identification data {}", data.source)))?;
    let free = set
        .resolve(&start, &poses, None, &id_opts)
        .map_err(id_err(format!("--params {}", args.params)))?;
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
        let problem = Problem::new(&start, &p, &x, free.clone()).map_err(id_err(format!(
            "setting up the identification on {}",
            data.source
        )))?;
        let mut fit = identify(&problem, &options).map_err(id_err(format!(
            "identifying {} on {}",
            nom.name(),
            data.source
        )))?;
        // An extended model evaluates its gravity torques on the geometry it was extended
        // from (the nominal, during the fit). `identified.json` re-extends its own geometry
        // when it is read, so the model validated and reported is that one: what every
        // command loading the file will compute.
        if fit.robot.is_extended() {
            fit.robot =
                Robot::from_spec(&fit.robot.to_spec()).map_err(|source| CalibrateError::Robot {
                    what: "identified robot",
                    path: args.robot.clone(),
                    source,
                })?;
        }
        Ok(fit)
    };
    let first = fit_rows(&id_rows)?;
    let screen = match first.sigma_hat {
        Some(s) => Some(
            outliers::screen(&first.robot, &poses, &points, s, args.outlier_k)
                .map_err(id_err("screening outliers"))?,
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
            return Err(CalibrateError::Refused(format!(
                "{}: {} of {} rows are outliers; the {} left are too few for {} free parameters \
                 (3 equations per row) — run without --reject-outliers",
                data.source,
                flagged.len(),
                id_rows.len(),
                kept.len(),
                free.len()
            )));
        }
        let refit = fit_rows(&kept).map_err(|e| e.context("refitting without the outliers"))?;
        (refit, kept)
    } else {
        (first.clone(), id_rows.clone())
    };
    let analysis = analyze(&fit.robot, &poses_rad(&used), None, &free, &id_opts)
        .map_err(id_err("identifiability at the solution"))?;
    let validation = match val_rows {
        Some((source, rows)) => {
            let before = residuals(&start, &rows);
            let after = residuals(&fit.robot, &rows);
            let table = Table4::from_errors(&before, &after).map_err(|source| {
                CalibrateError::Evaluate {
                    context: "validation statistics".into(),
                    source,
                }
            })?;
            let (vp, vx) = (poses_rad(&rows), points_mm(&rows));
            let self_registered = register_base(nom, &vp, &vx)
                .ok()
                .map(|(r, _)| mean_max(&norms(&residuals(&r, &rows))));
            Some(Validation {
                source,
                rows,
                before,
                after,
                table,
                self_registered,
            })
        }
        None => None,
    };
    let elapsed_ms = started.elapsed().as_secs_f64() * 1e3;
    Ok(Calibration {
        request: request.clone(),
        nominal: nominal.clone(),
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
        notices,
        elapsed_ms,
    })
}

impl Calibration {
    /// Renders the output files in memory: `identified.json`, `registered-nominal.json`,
    /// `parameters.json`, `report.md`, then `report.html` with the plots of
    /// [`report::identify::identify_plots`] (errors of the start model and of the identified
    /// one on the screened identification rows and on the validation rows; the outlier screen)
    /// inline and beside it as SVG files.
    ///
    /// # Errors
    /// [`CalibrateError::Plot`] when an error is not finite (nothing can be drawn).
    pub fn render(&self) -> Result<Rendered> {
        let nom = &self.nominal.robot;
        let data = file_name(&self.request.data);
        let mut robot = self.fit.robot.clone();
        robot.set_name(format!("{}, identified from {data}", nom.name()));
        let mut registered = self.start.clone();
        if self.registration.as_ref().is_some_and(|r| r.applied) {
            registered.set_name(format!("{}, base registered on {data}", nom.name()));
        }
        let report_md = render_report(self);
        let id_before = residuals(&self.start, &self.screened_rows);
        let id_after = residuals(&self.fit.robot, &self.screened_rows);
        let flagged = self.screen.as_ref().map_or_else(Vec::new, |s| s.indices());
        let labels: Vec<String> = flagged
            .iter()
            .map(|&i| row_label(&self.screened_rows[i]))
            .collect();
        let plots = report::identify::identify_plots(&report::identify::IdentifyPlotData {
            robot: nom.name(),
            identification_before_mm: &id_before,
            identification_after_mm: &id_after,
            validation_before_mm: self.validation.as_ref().map(|v| v.before.as_slice()),
            validation_after_mm: self.validation.as_ref().map(|v| v.after.as_slice()),
            outlier_threshold: self.screen.as_ref().map(|s| (s.threshold_mm, s.k)),
            outliers: &flagged,
            outlier_labels: &labels,
        })
        .map_err(|source| CalibrateError::Plot {
            what: format!("the plots of {REPORT_HTML_FILE}"),
            source,
        })?;
        let html = report::identify::identify_page(
            &format!("Calibration of {} on {data}", nom.name()),
            &report_md,
            &plots,
        );
        let mut files = vec![
            (ROBOT_FILE.to_string(), robot.to_spec().to_json_string()),
            (
                REGISTERED_FILE.to_string(),
                registered.to_spec().to_json_string(),
            ),
            (PARAMETERS_FILE.to_string(), parameters_json(self)),
            (REPORT_FILE.to_string(), report_md),
            (REPORT_HTML_FILE.to_string(), html),
        ];
        files.extend(plots);
        Ok(Rendered { files })
    }

    /// The console summary: what was fitted, registration, fit, held parameters, outliers,
    /// validation (one line each).
    pub fn summary(&self) -> String {
        summary_text(self)
    }
}

/// `nominal, registered` or `nominal`: the model the fit started from.
fn start_label(o: &Calibration) -> &'static str {
    if o.registration.as_ref().is_some_and(|r| r.applied) {
        "nominal, registered"
    } else {
        "nominal"
    }
}

fn schedule_name(request: &IdentifyRequest) -> &'static str {
    request.schedule.damping().name()
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

fn parameters_json(o: &Calibration) -> String {
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
        nominal_robot: o.request.robot.display().to_string(),
        data: o.request.data.display().to_string(),
        rows: o.used.len(),
        params: &o.request.params,
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

fn render_report(o: &Calibration) -> String {
    let a = &o.request;
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
    match o.fit.robot.extended() {
        None => s.push_str(
            "- model: geometry only (docs/model.md §2–§3). Compliance, gear errors and other \
             non-geometric effects are not identified; they stay in the residuals.\n",
        ),
        Some(model) => {
            let names: Vec<String> = model.kinds().iter().map(|k| k.name()).collect();
            let _ = writeln!(
                s,
                "- model: geometry (docs/model.md §2–§3) plus the non-geometric joint errors {} \
                 (docs/extended-model.md: gravity torques from the robot file's mass model on \
                 the start geometry). Other non-geometric effects stay in the residuals.",
                names.join(", ")
            );
        }
    }

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
            "| {name} | {} | {} | {} | {} |",
            v.len(),
            mm(rms),
            mm(mean),
            mm(max)
        );
    }
    match o.fit.sigma_hat {
        Some(sh) => {
            let _ = writeln!(
                s,
                "\nσ̂ = √(RSS / dof) = {} mm per axis (dof = {}).",
                mm(sh),
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
                "Screened after the first fit: ‖e‖ > k·σ̂₃ = {} × {} = {} mm (σ̂₃ = √3·σ̂, \
                 first-fit RMS {} mm).",
                sc.k,
                mm(sc.sigma_3d_mm),
                mm(sc.threshold_mm),
                mm(o.first.rms_mm)
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
                            "excluded and refitted (RMS {} → {} mm)",
                            mm(o.first.rms_mm),
                            mm(o.fit.rms_mm)
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
                        "| {} | {} | {} | {:.2} |",
                        r.id.as_deref().unwrap_or("–"),
                        r.line,
                        mm(ol.norm_mm),
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

fn summary_text(o: &Calibration) -> String {
    let mut out = String::new();
    let a = &o.request;
    let nom = &o.nominal.robot;
    let _ = writeln!(
        out,
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
        let _ = writeln!(
            out,
            "registration: nominal mean error {:.3} mm → {:.3} mm (rotation {:.3}°, translation \
             {:.1} mm)",
            r.mean_error_before_mm,
            r.mean_error_after_mm,
            r.rotation_deg,
            Vector3::from(r.translation_mm).norm()
        );
    }
    let (_, fit_max) = mean_max(&norms(&residuals(&o.fit.robot, &o.used)));
    let _ = writeln!(
        out,
        "fit: RMS {} mm, max {} mm on {} poses; σ̂ {} mm/axis; rank {} of {}; {} after {} \
         iterations; {:.1} ms",
        mm(o.fit.rms_mm),
        mm(fit_max),
        o.used.len(),
        o.fit.sigma_hat.map_or_else(|| "n/a".into(), mm),
        o.analysis.rank,
        o.free.len(),
        o.fit.stop,
        o.fit.iterations,
        o.elapsed_ms
    );
    if !o.fit.held.is_empty() {
        let _ = writeln!(
            out,
            "held at their start values (exactly redundant there; --redundant damp keeps them \
             in the damped system): {}",
            o.fit.held.join(", ")
        );
    }
    if !o.fit.stop.converged() {
        let _ = writeln!(
            out,
            "warning: the solver stopped without converging ({}): some free parameters are \
             (nearly) redundant and drift along a flat valley; predictions are unaffected, \
             but only the identifiable values mean anything — try --params minimal",
            o.fit.stop
        );
    }
    if let Some(sc) = &o.screen {
        if sc.outliers.is_empty() {
            let _ = writeln!(
                out,
                "outliers (‖e‖ > {} σ̂₃ = {} mm): none",
                sc.k,
                mm(sc.threshold_mm)
            );
        } else {
            let list: Vec<String> = sc
                .outliers
                .iter()
                .take(10)
                .map(|ol| {
                    format!(
                        "{} {} mm",
                        row_label(&o.screened_rows[ol.index]),
                        mm(ol.norm_mm)
                    )
                })
                .collect();
            let _ = writeln!(
                out,
                "outliers (‖e‖ > {} σ̂₃ = {} mm): {} — {}{}; {}",
                sc.k,
                mm(sc.threshold_mm),
                sc.outliers.len(),
                list.join(", "),
                if sc.outliers.len() > 10 { ", …" } else { "" },
                if o.rejected {
                    format!(
                        "excluded, refitted: RMS {} → {} mm",
                        mm(o.first.rms_mm),
                        mm(o.fit.rms_mm)
                    )
                } else {
                    "kept (--reject-outliers to exclude)".to_string()
                }
            );
        }
    }
    if let Some(v) = &o.validation {
        let (b, af) = (&v.table.before.norm, &v.table.after.norm);
        let _ = writeln!(
            out,
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
    out
}
