//! What to calibrate and how: [`IdentifyRequest`], its fields in the identification crate's
//! own types (no mirror types, no command-line vocabulary).

use std::path::PathBuf;

use identify::{Damping, LmOptions, ParamSpec, Redundant, RegistrationPolicy};

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

impl Split {
    /// `every` or `select`: the name of a split that holds rows out, `None` for [`Split::All`].
    pub fn name(&self) -> Option<&'static str> {
        match self {
            Split::All => None,
            Split::Every { .. } => Some("every"),
            Split::Select { .. } => Some("select"),
        }
    }
}

/// What to calibrate and how. Defaults in brackets, with the reason.
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
    /// Parameters to identify, extended ones after `+` \[`paper`: the paper's method\].
    pub params: ParamSpec,
    /// Damping schedule and its constants \[Levenberg, μ0 = 1e-3, ÷10 / ×10: the paper's\].
    pub damping: Damping,
    /// Free parameters exactly redundant at the start \[held: the solve is well posed and
    /// converges in a few iterations\].
    pub redundant: Redundant,
    /// Registration of the measurement frame onto the robot base before identifying \[auto,
    /// above 10 mm of mean point error: geometric errors are millimetres, a tracker frame is
    /// metres away\].
    pub registration: RegistrationPolicy,
    /// Drop every flagged unit (beyond k·σ̂₃), not only the gross errors, and refit \[no:
    /// the default drops the gross errors alone, beyond [`identify::outliers::GROSS_K`]·σ̂₃
    /// of a robust screen, and lists the others; `docs/calibrating-real-data.md`, "Robust
    /// screening"\].
    pub reject_outliers: bool,
    /// Keep every unit, gross errors included: the screen only lists them (the behaviour
    /// before robust screening) \[no\]. Not with [`IdentifyRequest::reject_outliers`].
    pub keep_outliers: bool,
    /// Outlier threshold k: ‖residual‖ > k·σ̂₃ \[3: fewer than one Gaussian point in 10⁵\].
    pub outlier_k: f64,
    /// Worst points listed in the report, per data set \[10\].
    pub worst: usize,
    /// Units of the joint columns of the data files \[degrees: `docs/model.md` §5\].
    pub joint_units: JointUnits,
    /// Units of the x, y, z columns of the data files \[millimetres: `docs/model.md` §5\].
    pub length_units: LengthUnits,
    /// Plausibility checks to pass over (`crate::checks`) \[none: a wrong robot must not
    /// leave the calibration unremarked\].
    pub allow: Vec<Check>,
    /// Euler convention of orientation columns `rx,ry,rz` (degrees), converted on reading
    /// \[none: quaternions `qw,qx,qy,qz` need none; a file of Euler angles without it is
    /// refused\].
    pub euler: Option<measurements::EulerConvention>,
    /// How the rows of 6-DoF and multi-target data weigh against each other.
    pub weighting: Weighting,
    /// Calibrate from the points alone, ignoring the data's orientations (the
    /// [`crate::MeasurementKind::Points`] fit of 6-DoF data, for comparison) \[no\].
    pub points_only: bool,
    /// Identify the measurements' scale factor (`crate::scale`): fit, take the common scale
    /// of the identified lengths, divide the points (identification and validation) by it
    /// when it is significant and identify again; the calibration reports the factor \[no: a
    /// significant scale is refused by the `scale` check, since a tracker's scale is known to
    /// a few ppm and the robot file's lengths are the better reference\].
    pub fit_scale: bool,
    /// Gaussian prior on the parameters (`crate::prior`) \[`auto`: the manufacturing
    /// tolerances when the data leave a parameter undetermined, so that weakly excited data
    /// give a fit held near the robot file where the poses say nothing; none otherwise. The
    /// prior changes well-excited data by well under 0.005 mm (the UR10 of `data/ur10-ipa`,
    /// every 15th row: its 1,495 points predicted within 0.00036 mm of the fit without it),
    /// but not by nothing — the rounding of its held-out max moves, 1.766 → 1.767 mm — so
    /// where the data determine every parameter the least-squares fit stays, to the bit\].
    pub prior: crate::prior::PriorSpec,
}

/// How the rows of 6-DoF and multi-target data are weighted (`docs/model.md` §6.4); the
/// report states which.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Weighting {
    /// Weigh orientation against position by this ratio: 1° of orientation residual weighs
    /// as `mm_per_deg` mm of position residual, position rows 1/mm [`None`:
    /// [`identify::frames::DEFAULT_MM_PER_DEG`]].
    pub mm_per_deg: Option<f64>,
    /// Weigh every row by the file's σ instead (where every row gives them) [false: on real
    /// data the model's unmodelled errors (≈0.3 mm, 0.05°) dwarf the tracker's σ (≈0.01 mm,
    /// 0.002°), so per-row σ weights mostly reshuffle rows: on the UR10 of `data/ur10-ipa`
    /// they raise the held-out position error (0.505 mm against 0.422 mm with the ratio,
    /// `--every 15`)].
    pub sigma: bool,
}

/// Units of joint columns; values are converted to degrees on loading.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum JointUnits {
    /// Degrees (the format's).
    #[default]
    Deg,
    /// Radians.
    Rad,
}

impl JointUnits {
    /// Degrees per unit.
    pub fn deg_per_unit(self) -> f64 {
        match self {
            JointUnits::Deg => 1.0,
            JointUnits::Rad => 180.0 / std::f64::consts::PI,
        }
    }

    /// `deg` or `rad`.
    pub fn name(self) -> &'static str {
        match self {
            JointUnits::Deg => "deg",
            JointUnits::Rad => "rad",
        }
    }
}

/// Units of point columns; values are converted to millimetres on loading.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LengthUnits {
    /// Millimetres (the format's).
    #[default]
    Mm,
    /// Metres.
    M,
    /// Inches (25.4 mm).
    In,
    /// Centimetres (10 mm).
    Cm,
}

impl LengthUnits {
    /// Millimetres per unit.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            LengthUnits::Mm => 1.0,
            LengthUnits::M => 1000.0,
            LengthUnits::In => 25.4,
            LengthUnits::Cm => 10.0,
        }
    }

    /// `mm`, `m`, `in` or `cm`.
    pub fn name(self) -> &'static str {
        match self {
            LengthUnits::Mm => "mm",
            LengthUnits::M => "m",
            LengthUnits::In => "in",
            LengthUnits::Cm => "cm",
        }
    }
}

/// A setting of the request that a refusal suggests (`crate::checks`), spelled by the front
/// end that shows it: [`Front::Keywords`] as the request's field, Python's keyword argument
/// (`joint_units="rad"`), [`Front::Flags`] as the command line's option (`--joint-units rad`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// [`IdentifyRequest::joint_units`].
    JointUnits(JointUnits),
    /// [`IdentifyRequest::length_units`].
    LengthUnits(LengthUnits),
    /// A check in [`IdentifyRequest::allow`].
    Allow(Check),
    /// [`IdentifyRequest::prior`], as written (`auto`).
    Prior(&'static str),
    /// A switch of the request turned on, by its field name: `fit_scale`
    /// ([`IdentifyRequest::fit_scale`]), `keep_outliers`.
    On(&'static str),
}

/// Whose words a message uses for the request's settings ([`Setting::spelled`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Front {
    /// The library's and Python's: the keyword argument, `length_units="cm"`.
    #[default]
    Keywords,
    /// The command line's: the option, `--length-units cm`.
    Flags,
}

impl Setting {
    /// The setting as `front` writes it: `joint_units="rad"` or `--joint-units rad`.
    pub fn spelled(self, front: Front) -> String {
        if let Setting::On(field) = self {
            return match front {
                Front::Keywords => format!("{field}=True"),
                Front::Flags => format!("--{}", field.replace('_', "-")),
            };
        }
        let (field, value) = match self {
            Setting::JointUnits(u) => ("joint_units", u.name()),
            Setting::LengthUnits(u) => ("length_units", u.name()),
            Setting::Allow(c) => ("allow", c.name()),
            Setting::Prior(p) => ("prior", p),
            Setting::On(_) => unreachable!("spelled above"),
        };
        match front {
            Front::Keywords => format!("{field}=\"{value}\""),
            Front::Flags => format!("--{} {value}", field.replace('_', "-")),
        }
    }
}

/// A plausibility check of the calibration (`crate::checks`), named to override it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Check {
    /// Joint values that look like radians although read as degrees.
    JointUnits,
    /// A measured extent that does not match the robot's (metres, centimetres, inches).
    LengthUnits,
    /// A measurement frame that a reflection fits far better than any rotation.
    Mirror,
    /// Identified parameters far from the nominal ones.
    Parameters,
    /// Validation worse after calibration than before.
    Validation,
    /// A k below the minimum, a rejection of more than 35 % of the units, or units kept whose
    /// classical scale exceeds twice their robust one (`docs/calibrating-real-data.md`,
    /// "Robust screening").
    Outliers,
    /// Every identified length moved in proportion to itself: measurements scaled
    /// (`crate::scale`).
    Scale,
}

impl Check {
    /// Every check, in the order they run.
    pub const ALL: [Check; 7] = [
        Check::JointUnits,
        Check::LengthUnits,
        Check::Mirror,
        Check::Outliers,
        Check::Scale,
        Check::Parameters,
        Check::Validation,
    ];

    /// The check's name (`joint-units`, `length-units`, `mirror`, `outliers`, `scale`,
    /// `parameters`, `validation`).
    pub fn name(self) -> &'static str {
        match self {
            Check::JointUnits => "joint-units",
            Check::LengthUnits => "length-units",
            Check::Mirror => "mirror",
            Check::Parameters => "parameters",
            Check::Validation => "validation",
            Check::Outliers => "outliers",
            Check::Scale => "scale",
        }
    }
}

impl std::str::FromStr for Check {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Check::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Check::ALL.iter().map(|c| c.name()).collect();
                format!("unknown check `{s}` (one of {})", names.join(", "))
            })
    }
}

/// What the outlier screen drops ([`IdentifyRequest::outlier_mode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutlierMode {
    /// Nothing: flagged units are listed ([`IdentifyRequest::keep_outliers`]).
    Keep,
    /// The gross errors, beyond `max(G, k)`·σ̂ of the robust screen (the default).
    Gross,
    /// Every flagged unit, beyond k·σ̂ ([`IdentifyRequest::reject_outliers`]).
    Flagged,
}

impl OutlierMode {
    /// The factor of the rejection cut for outlier factor `k`: `None` (keep), `max(G, k)`
    /// (gross) or `k` (flagged).
    pub fn cut(self, k: f64) -> Option<f64> {
        match self {
            OutlierMode::Keep => None,
            OutlierMode::Gross => Some(identify::outliers::GROSS_K.max(k)),
            OutlierMode::Flagged => Some(k),
        }
    }
}

impl IdentifyRequest {
    /// What the outlier screen drops: [`OutlierMode::Keep`] with `keep_outliers`,
    /// [`OutlierMode::Flagged`] with `reject_outliers`, else [`OutlierMode::Gross`] (both set
    /// is refused by the request check).
    pub fn outlier_mode(&self) -> OutlierMode {
        if self.keep_outliers {
            OutlierMode::Keep
        } else if self.reject_outliers {
            OutlierMode::Flagged
        } else {
            OutlierMode::Gross
        }
    }

    /// A request with every option at its default.
    pub fn new(robot: impl Into<PathBuf>, data: impl Into<PathBuf>) -> Self {
        IdentifyRequest {
            robot: robot.into(),
            data: data.into(),
            validate: None,
            split: Split::All,
            params: ParamSpec::default(),
            damping: Damping::default(),
            redundant: Redundant::default(),
            registration: RegistrationPolicy::default(),
            reject_outliers: false,
            keep_outliers: false,
            outlier_k: 3.0,
            worst: 10,
            joint_units: JointUnits::Deg,
            length_units: LengthUnits::Mm,
            allow: Vec::new(),
            euler: None,
            weighting: Weighting::default(),
            points_only: false,
            fit_scale: false,
            prior: crate::prior::PriorSpec::default(),
        }
    }

    /// Whether the plausibility check `check` is overridden.
    pub fn allows(&self, check: Check) -> bool {
        self.allow.contains(&check)
    }

    /// The solver options of the request: its damping and its treatment of redundant
    /// parameters, the rest at their defaults.
    pub fn lm_options(&self) -> LmOptions {
        LmOptions {
            redundant: self.redundant,
            ..LmOptions::with_damping(self.damping)
        }
    }
}

impl JointUnits {
    /// `deg` and `rad`, the names [`JointUnits::name`] gives and `FromStr` accepts.
    pub const NAMES: &'static [&'static str] = &["deg", "rad"];
}

impl std::str::FromStr for JointUnits {
    type Err = identify::UnknownName;

    /// `deg` or `rad`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        identify::parse_name(s, JointUnits::NAMES, &[JointUnits::Deg, JointUnits::Rad])
    }
}

impl LengthUnits {
    /// `mm`, `m`, `in` and `cm`, the names [`LengthUnits::name`] gives and `FromStr`
    /// accepts.
    pub const NAMES: &'static [&'static str] = &["mm", "m", "in", "cm"];
}

impl std::str::FromStr for LengthUnits {
    type Err = identify::UnknownName;

    /// `mm`, `m`, `in` or `cm`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        identify::parse_name(
            s,
            LengthUnits::NAMES,
            &[
                LengthUnits::Mm,
                LengthUnits::M,
                LengthUnits::In,
                LengthUnits::Cm,
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_parse_by_their_names_and_refuse_others() {
        for u in [JointUnits::Deg, JointUnits::Rad] {
            assert_eq!(u.name().parse::<JointUnits>(), Ok(u));
        }
        for u in [
            LengthUnits::Mm,
            LengthUnits::M,
            LengthUnits::In,
            LengthUnits::Cm,
        ] {
            assert_eq!(u.name().parse::<LengthUnits>(), Ok(u));
        }
        assert_eq!(LengthUnits::Cm.mm_per_unit(), 10.0);
        assert_eq!(
            "degrees".parse::<JointUnits>().unwrap_err().to_string(),
            "unknown value \"degrees\" (deg, rad)"
        );
        assert_eq!(
            "MM".parse::<LengthUnits>().unwrap_err().to_string(),
            "unknown value \"MM\" (mm, m, in, cm)"
        );
    }

    #[test]
    fn settings_are_spelled_as_keywords_or_flags() {
        let s = Setting::JointUnits(JointUnits::Rad);
        assert_eq!(s.spelled(Front::Keywords), "joint_units=\"rad\"");
        assert_eq!(s.spelled(Front::Flags), "--joint-units rad");
        let s = Setting::LengthUnits(LengthUnits::Cm);
        assert_eq!(s.spelled(Front::Flags), "--length-units cm");
        let s = Setting::Allow(Check::LengthUnits);
        assert_eq!(s.spelled(Front::Keywords), "allow=\"length-units\"");
        assert_eq!(s.spelled(Front::Flags), "--allow length-units");
    }
}
