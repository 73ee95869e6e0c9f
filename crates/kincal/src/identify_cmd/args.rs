//! The arguments of `kincal identify` and their mapping onto a [`calibrate::IdentifyRequest`]
//! (and of library refusals onto the flags that cause them).

use std::path::PathBuf;

use calibrate::{CalibrateError, IdentifyRequest, JointUnits, LengthUnits, Refusal, Split};
use clap::Args;
use identify::ParamSpec;

use identify::{Damping, Redundant, RegistrationPolicy};

use crate::solver_args::library_names;

/// Arguments of `identify`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
#[command(
    after_help = "Example (the real UR10 of data/ur10-ipa, from the repository root):
  kincal identify --robot scenarios/robots/ur10.json \\
      --data data/ur10-ipa/series-b-joint-configurations.csv --every 15 --out ur10-cal
  → ur10-cal/identified.json, registered-nominal.json, parameters.json, report.md, report.html
  kincal identify --robot scenarios/robots/ur10.json \\
      --data data/ur10-ipa/series-b-joint-configurations.csv --select 30 --criterion i --out ur10-i30
  → 30 rows chosen by the I criterion identify, the other 1465 validate"
)]
pub struct IdentifyArgs {
    /// Nominal robot model file (JSON); its joint limits check the data.
    #[arg(long)]
    pub(crate) robot: PathBuf,
    /// Identification measurements (docs/model.md §5 CSV: q1…qN in degrees, x, y, z in mm).
    #[arg(long)]
    pub(crate) data: PathBuf,
    /// Validation measurements (same CSV format): Table 4 of the nominal (after
    /// registration) and the identified model's predictions.
    #[arg(long, conflicts_with = "every")]
    pub(crate) validate: Option<PathBuf>,
    /// Hold-out split of --data: identify on data rows OFFSET, OFFSET+K, OFFSET+2K, …
    /// (0-based, comments and blank lines not counted) and validate on all the others.
    #[arg(long, value_name = "K")]
    pub(crate) every: Option<usize>,
    /// First identification row of --every.
    #[arg(long, default_value_t = 0, requires = "every")]
    pub(crate) offset: usize,
    /// Identify on N rows of --data chosen by design (their joints only; the nominal
    /// model's minimal identifiable set) and validate on all the others: what N well-chosen
    /// poses of the recording would have given.
    #[arg(long, value_name = "N", conflicts_with_all = ["every", "validate"])]
    pub(crate) select: Option<usize>,
    /// Design criterion of --select: d (log det M), a (trace M⁻¹), e (λ_min), i (mean
    /// predicted variance on the data's poses), o1, o3, o5 (docs/design.md).
    #[arg(long, default_value = "d", requires = "select")]
    pub(crate) criterion: design::Criterion,
    /// Parameters to identify: `paper` (all, redundant ones included), `minimal` (the
    /// identifiable set at the registered nominal model), or comma-separated names; then,
    /// after `+`, non-geometric joint parameters (docs/extended-model.md): `compliance`
    /// (every joint's; needs the robot file's mass_model), `gears` (first harmonic of every
    /// joint) or names, e.g. `paper+compliance`, `paper+compliance+gears`,
    /// `minimal+compliance_2,compliance_3`. identified.json then has an `extended` section.
    #[arg(long, default_value = "paper")]
    pub(crate) params: ParamSpec,
    /// Damping schedule (docs/model.md §7): levenberg, the paper's (JᵀJ + μI), μ0 = 1e-3,
    /// ÷10 / ×10; marquardt, (JᵀJ + μ diag JᵀJ) with the same updates; nielsen, Nielsen's
    /// gain-ratio schedule.
    #[arg(long, default_value = "levenberg", value_parser = library_names::<Damping>(Damping::NAMES))]
    pub(crate) schedule: Damping,
    /// Free parameters exactly redundant at the start (e.g. 10 of the UR10's 35): hold, held
    /// at their start values while the identifiable rest is solved [the solve is well posed
    /// and converges in a few iterations]; damp, kept in the damped system as the paper does.
    #[arg(long, default_value = "hold", value_parser = library_names::<Redundant>(Redundant::NAMES))]
    pub(crate) redundant: Redundant,
    /// Registration of the measurement frame onto the robot base before identifying: auto,
    /// when the nominal model misses the points by more than 10 mm on average [geometric
    /// errors are millimetres, a tracker frame is metres away]; always; never (the paper's
    /// procedure: LM from the nominal model).
    #[arg(
        long,
        default_value = "auto",
        value_parser = library_names::<RegistrationPolicy>(RegistrationPolicy::NAMES)
    )]
    pub(crate) registration: RegistrationPolicy,
    /// Drop every flagged row (beyond k·σ̂₃), not only the gross errors, and refit. Without
    /// it the robust screen drops the gross errors alone (beyond max(5, k)·σ̂₃; a least-
    /// trimmed-squares start, so that many outliers cannot hide themselves) and lists the
    /// others; the flag is accepted as before.
    #[arg(long, conflicts_with = "keep_outliers")]
    pub(crate) reject_outliers: bool,
    /// Keep every row, gross errors included (the outlier screen only lists them).
    #[arg(long)]
    pub(crate) keep_outliers: bool,
    /// Outlier threshold: ‖residual‖ > k·σ̂₃, σ̂₃ = √3·σ̂ the fit's 3-D residual scale.
    #[arg(long, default_value_t = 3.0, value_name = "K")]
    pub(crate) outlier_k: f64,
    /// Worst points listed in the report, per data set.
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub(crate) worst: usize,
    /// Units of the joint columns of --data and --validate: deg (the format's) or rad
    /// (converted to degrees on reading).
    #[arg(
        long,
        default_value = "deg",
        value_name = "UNITS",
        value_parser = library_names::<JointUnits>(JointUnits::NAMES)
    )]
    pub(crate) joint_units: JointUnits,
    /// Units of the x, y, z columns: mm (the format's), m, cm or in (converted to
    /// millimetres on reading).
    #[arg(
        long,
        default_value = "mm",
        value_name = "UNITS",
        value_parser = library_names::<LengthUnits>(LengthUnits::NAMES)
    )]
    pub(crate) length_units: LengthUnits,
    /// Pass over a plausibility check (docs/calibrating-real-data.md, "Checks"), repeatable:
    /// joint-units, length-units, mirror, outliers, scale, parameters, validation.
    #[arg(long, value_name = "CHECK")]
    pub(crate) allow: Vec<calibrate::Check>,
    /// Gaussian prior on the parameters (maximum a posteriori; point data): `tolerance`
    /// (each geometric parameter about the robot file's value with its manufacturing
    /// tolerance as standard deviation, the parameters check's: 20 mm for a and d, 5° for θ,
    /// α, β, 250 mm for the tool; the base has none), `tolerance,NAME=SD,…` (some standard
    /// deviations replaced, mm or °), `none` (plain least squares), or `auto` (that prior
    /// when the data leave a parameter's standard error above half its tolerance, else
    /// none). The report marks the parameters the prior rather than the data determine.
    #[arg(
        long,
        default_value = "auto",
        value_name = "auto|none|tolerance[,NAME=SD…]"
    )]
    pub(crate) prior: calibrate::PriorSpec,
    /// Output directory, created if missing (only once everything succeeded).
    #[arg(long, default_value = "identified")]
    pub(crate) out: PathBuf,
    /// Euler convention of orientation columns rx,ry,rz (degrees) in the data: three axis
    /// letters, upper case intrinsic (XYZ), lower case extrinsic (xyz); docs/model.md §5.
    #[arg(long, value_name = "SEQ")]
    pub(crate) euler: Option<measurements::EulerConvention>,
    /// With orientation data: weigh 1° of orientation residual as this many mm of position
    /// residual [default 5, the ratio of a tracker probe's σ], or `sigma`: weigh every row
    /// by the file's σ (sx,sy,sz, srx,sry,srz).
    #[arg(long, value_name = "MM_PER_DEG|sigma", allow_hyphen_values = true)]
    pub(crate) orientation_weight: Option<OrientationWeight>,
    /// Identify from the points only, ignoring the file's orientation columns (the
    /// point-only fit of the same poses, for comparison).
    #[arg(long)]
    pub(crate) points_only: bool,
    /// Identify the measurements' scale factor (a tracker's scale or temperature
    /// compensation): fit, take the common scale of the identified lengths, divide the points
    /// by it when significant and identify again [off: a significant scale is refused by the
    /// `scale` check].
    #[arg(long)]
    pub(crate) fit_scale: bool,
    /// Learned residual model over the geometry (docs/residual-model.md): `gp` fits a
    /// Gaussian process on the position residuals as a function of the joints, decides by
    /// k-fold cross-validation on the identification rows whether the hybrid predicts
    /// held-out poses better (mean and p95 gains beyond their fold-to-fold scatter) and only
    /// then writes it (residual-model.json, named in identified.json), else says so and
    /// writes the geometric robot alone [none: the geometry alone]. Point data only.
    #[arg(long, value_name = "none|gp", default_value = "none")]
    pub(crate) residual_model: ResidualModelArg,
    /// Folds of --residual-model's cross-validation [5: each fold trains on 80 % of the
    /// rows, nearly the model written].
    #[arg(long, value_name = "K", default_value_t = calibrate::residual::DEFAULT_FOLDS, requires = "residual_model")]
    pub(crate) residual_folds: usize,
}

/// `--residual-model`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ResidualModelArg {
    /// The geometry alone.
    None,
    /// A Gaussian process on the position residuals, used when cross-validation says it helps.
    Gp,
}

impl IdentifyArgs {
    /// The residual model's options, if `--residual-model gp`.
    pub(crate) fn residual_options(&self) -> Option<calibrate::residual::CvOptions> {
        (self.residual_model == ResidualModelArg::Gp).then(|| calibrate::residual::CvOptions {
            folds: self.residual_folds,
            ..Default::default()
        })
    }

    pub(crate) fn request(&self) -> IdentifyRequest {
        IdentifyRequest {
            validate: self.validate.clone(),
            split: match (self.every, self.select) {
                (Some(every), _) => Split::Every {
                    every,
                    offset: self.offset,
                },
                (None, Some(poses)) => Split::Select {
                    poses,
                    criterion: self.criterion,
                },
                (None, None) => Split::All,
            },
            params: self.params.clone(),
            damping: self.schedule,
            redundant: self.redundant,
            registration: self.registration,
            reject_outliers: self.reject_outliers,
            keep_outliers: self.keep_outliers,
            outlier_k: self.outlier_k,
            worst: self.worst,
            joint_units: self.joint_units,
            length_units: self.length_units,
            allow: self.allow.clone(),
            euler: self.euler,
            weighting: OrientationWeight::options(self.orientation_weight),
            points_only: self.points_only,
            fit_scale: self.fit_scale,
            prior: self.prior.clone(),
            ..IdentifyRequest::new(&self.robot, &self.data)
        }
    }

    /// The error of the workflow in the command line's words: the flag that sets the request
    /// field at fault, before the library's message (which names the field).
    pub(crate) fn flagged(&self, e: CalibrateError) -> anyhow::Error {
        let flag = match &e {
            CalibrateError::Refused(refusal) => match refusal {
                Refusal::OutlierK(k) => Some(format!("--outlier-k {k}")),
                Refusal::EveryZero => Some("--every 0".to_string()),
                Refusal::OffsetNotBelowEvery { every, offset } => {
                    Some(format!("--every {every} --offset {offset}"))
                }
                Refusal::ValidateWithSplit { split } => Some(format!("--validate with --{split}")),
                Refusal::SelectTooFew { poses, .. } | Refusal::SelectTooMany { poses, .. } => {
                    Some(format!("--select {poses}"))
                }
                Refusal::TooManyOutliers { .. } => Some(if self.reject_outliers {
                    "--reject-outliers".to_string()
                } else {
                    "the outlier screen (--keep-outliers keeps every row)".to_string()
                }),
                Refusal::KeepAndRejectOutliers => {
                    Some("--keep-outliers with --reject-outliers".to_string())
                }
                Refusal::Implausible { check, .. } => Some(format!(
                    "refused by the {} check (override: --allow {})",
                    check.name(),
                    check.name()
                )),
                Refusal::NoDataRows { .. } => self
                    .validate
                    .as_ref()
                    .map(|v| format!("--validate {}", v.display())),
                _ => None,
            },
            CalibrateError::TooFewRows { source, .. } => match source.as_ref() {
                CalibrateError::Refused(Refusal::EveryTooFew { every, offset, .. }) => {
                    Some(format!("--every {every} --offset {offset}"))
                }
                _ => None,
            },
            CalibrateError::Read {
                source: measurements::MeasurementError::EulerConventionMissing { .. },
                ..
            } => Some(
                "the data give Euler angles rx,ry,rz: name their convention with --euler SEQ \
                 (e.g. --euler XYZ intrinsic, --euler xyz extrinsic)"
                    .to_string(),
            ),
            CalibrateError::Design { .. } => self
                .select
                .map(|n| format!("--select {n} --criterion {}", self.criterion.as_str())),
            _ => None,
        };
        let e = match e {
            // The refusal's settings in the command line's words (`--length-units cm`,
            // `--allow length-units`), not the library's keywords.
            CalibrateError::Refused(refusal @ Refusal::Implausible { .. }) => {
                anyhow::anyhow!(refusal.in_words(calibrate::Front::Flags))
            }
            CalibrateError::Params { spec, source } => {
                anyhow::Error::new(source).context(format!("--params {spec}"))
            }
            CalibrateError::TooFewRows {
                free,
                spec,
                needed,
                source,
            } => anyhow::Error::new(*source).context(format!(
                "{free} free parameters (--params {spec}) need at least {needed} rows: 3 \
                 equations per row, at least as many equations as free parameters"
            )),
            e => anyhow::Error::new(e),
        };
        match flag {
            Some(flag) => e.context(flag),
            None => e,
        }
    }
}

/// `--orientation-weight`: a ratio in mm per degree, or `sigma` (each row by its σ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum OrientationWeight {
    /// 1° of orientation residual weighs as this many mm of position residual.
    MmPerDeg(f64),
    /// Each row by its own σ.
    Sigma,
}

impl std::str::FromStr for OrientationWeight {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.trim() == "sigma" {
            return Ok(OrientationWeight::Sigma);
        }
        match s.trim().parse::<f64>() {
            Ok(w) if w.is_finite() && w > 0.0 => Ok(OrientationWeight::MmPerDeg(w)),
            _ => Err(format!(
                "`{s}` is neither `sigma` nor a finite number > 0 (mm of position residual \
                 per degree of orientation residual)"
            )),
        }
    }
}

impl OrientationWeight {
    /// The calibration's options for this weighting.
    pub(crate) fn options(this: Option<Self>) -> calibrate::Weighting {
        match this {
            None => calibrate::Weighting::default(),
            Some(OrientationWeight::Sigma) => calibrate::Weighting {
                sigma: true,
                ..Default::default()
            },
            Some(OrientationWeight::MmPerDeg(w)) => calibrate::Weighting {
                mm_per_deg: Some(w),
                sigma: false,
            },
        }
    }
}
