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
    /// Drop the outliers found after the first fit and refit \[no: only reported\].
    pub reject_outliers: bool,
    /// Outlier threshold k: ‖residual‖ > k·σ̂₃ \[3: fewer than one Gaussian point in 10⁵\].
    pub outlier_k: f64,
    /// Worst points listed in the report, per data set \[10\].
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
            params: ParamSpec::default(),
            damping: Damping::default(),
            redundant: Redundant::default(),
            registration: RegistrationPolicy::default(),
            reject_outliers: false,
            outlier_k: 3.0,
            worst: 10,
        }
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
