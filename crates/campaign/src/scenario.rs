//! Scenario files: everything a campaign needs, in one JSON document (documented field by
//! field in `scenarios/README.md`). Unknown fields are errors; errors name the field path.

use std::path::{Path, PathBuf};

use identify::{IdentifiabilityOptions, IdentifyOptions, LmOptions, ParamSet, RegistrationPolicy};
use kinematics::{IkOptions, Robot};
use serde::{Deserialize, Serialize};

use virtual_robot::{
    InjectedErrors, PoseSampling, TrackerConfig, UnmodelledConfig, VirtualRobotConfig,
};

/// Why a scenario cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file cannot be read.
    #[error("{file}: cannot read scenario: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Malformed JSON, an unknown or missing field, a wrong type.
    #[error("{file}: field `{field}`: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A value out of range.
    #[error("{file}: field `{field}`: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The robot model file named by `robot` is bad.
    #[error("{file}: field `robot` (a path relative to the scenario file's directory): {source}")]
    Robot {
        /// The scenario file.
        file: String,
        /// The model error.
        #[source]
        source: kinematics::ModelError,
    },
    /// The virtual-robot sections do not fit the robot.
    #[error("{file}: {source}")]
    VirtualRobot {
        /// The scenario file.
        file: String,
        /// The configuration error (names its field).
        #[source]
        source: virtual_robot::ConfigError,
    },
}

fn default_trials() -> u64 {
    200
}

/// The identification settings of a scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentificationConfig {
    /// `"paper"` (all parameters, the paper's 34) \[default\], `"minimal"`, or
    /// `{"names": [..]}`.
    pub params: ParamSet,
    /// Solver options: damping schedule and its settings, column scaling, stopping tests.
    pub lm: LmOptions,
    /// When to register the base first [never: simulated data are in the robot base frame].
    pub registration: RegistrationPolicy,
    /// Rank tolerance and thresholds of the identifiability analysis.
    pub identifiability: IdentifiabilityOptions,
    /// Non-geometric joint-error parameters identified beside the geometric ones
    /// (`docs/extended-model.md`) \[none\]: names (`compliance_2`, `gear_1_h1_sin`, …) or the
    /// families `"compliance"` (every joint's) and `"gears"` (the first harmonic, sine and
    /// cosine, of every joint). `params` then selects among all of them (`"paper"`: every
    /// geometric and every extended parameter).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub extended: Vec<String>,
}

impl Default for IdentificationConfig {
    fn default() -> Self {
        IdentificationConfig {
            params: ParamSet::Paper,
            lm: LmOptions::default(),
            registration: RegistrationPolicy::Never,
            identifiability: IdentifiabilityOptions::default(),
            extended: Vec::new(),
        }
    }
}

impl IdentificationConfig {
    /// `params` and `extended` as the one parameter spec of every front end
    /// ([`identify::ParamSpec`]: `paper+compliance` is `params = "paper"`, `extended =
    /// ["compliance"]`).
    pub fn param_spec(&self) -> identify::ParamSpec {
        identify::ParamSpec {
            base: self.params.clone(),
            extended: self.extended.clone(),
        }
    }

    /// The extended parameters' names for an `n_joints` robot, families expanded, in the
    /// order given ([`identify::ParamSpec::extended_names`]).
    pub fn extended_names(&self, n_joints: usize) -> Vec<String> {
        self.param_spec().extended_names(n_joints)
    }
}

impl IdentificationConfig {
    /// The options passed to [`identify::identify`].
    pub fn options(&self) -> IdentifyOptions {
        IdentifyOptions {
            lm: self.lm,
            registration: self.registration,
            identifiability: self.identifiability,
            ..IdentifyOptions::default()
        }
    }
}

/// Compensation of validation (and ISO) poses by IK of the identified model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CompensationConfig {
    /// Compensate and re-measure [true]. Off: the "after" figures are the identified model's
    /// prediction errors on the validation measurements instead.
    pub enabled: bool,
    /// IK iteration cap \[100\].
    pub max_iterations: usize,
    /// IK position tolerance, mm [1e-6].
    pub tol_pos_mm: f64,
}

impl Default for CompensationConfig {
    fn default() -> Self {
        CompensationConfig {
            enabled: true,
            max_iterations: 100,
            tol_pos_mm: 1e-6,
        }
    }
}

impl CompensationConfig {
    /// The IK options used for compensation.
    pub fn ik_options(&self) -> IkOptions {
        IkOptions {
            max_iterations: self.max_iterations,
            tol_pos_mm: self.tol_pos_mm,
            ..IkOptions::default()
        }
    }
}

/// The ISO 9283 position test (`docs/model.md` §9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IsoConfig {
    /// Run the test in every trial [false].
    pub enabled: bool,
    /// Cycles P1→P5→P4→P3→P2 [30, ISO 9283].
    pub cycles: usize,
    /// Joint configuration (deg) whose flange orientation every test pose holds, and from
    /// which the cube search solves IK [(0, 20, −20, 0, 60, 0): arm forward, wrist bent].
    pub reference_q_deg: Vec<f64>,
    /// Largest cube edge searched, mm \[1500\].
    pub max_edge_mm: f64,
    /// Smallest acceptable cube edge, mm \[100\].
    pub min_edge_mm: f64,
    /// Grid step of candidate cube centres around the reference point, mm \[250\].
    pub centre_step_mm: f64,
    /// Candidate centres per axis on each side of the reference point [2 → 5×5×5 grid].
    pub centre_half_count: usize,
}

impl Default for IsoConfig {
    fn default() -> Self {
        IsoConfig {
            enabled: false,
            cycles: 30,
            reference_q_deg: vec![0.0, 20.0, -20.0, 0.0, 60.0, 0.0],
            max_edge_mm: 1500.0,
            min_edge_mm: 100.0,
            centre_step_mm: 250.0,
            centre_half_count: 2,
        }
    }
}

/// Parameter recovery scoring against the injected truth (on the minimal set).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecoveryConfig {
    /// Score recovery in every trial [true].
    pub enabled: bool,
}

impl Default for RecoveryConfig {
    fn default() -> Self {
        RecoveryConfig { enabled: true }
    }
}

/// How the identification poses are chosen (`pose_selection`).
///
/// `random` \[default\]: `poses.identification` poses drawn by the sampler, as always.
/// A criterion (`d`, `a`, `e`, `i`, `o1`, `o3`, `o5`, see the `design` crate): the sampler
/// draws `candidates` poses instead (the same stream, so the first N of them are the random
/// set), and the design chooses `poses.identification` of them on the nominal model, before
/// anything is measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseSelection {
    /// `"random"` or a design criterion.
    pub method: SelectionMethod,
    /// Candidate pool size for a criterion \[1000\].
    pub candidates: usize,
}

/// `random` or a design criterion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SelectionMethod {
    /// The sampler's poses.
    Random,
    /// D-optimal.
    D,
    /// A-optimal.
    A,
    /// E-optimal.
    E,
    /// I-optimal (workspace: the candidate pool).
    I,
    /// O1.
    O1,
    /// O3.
    O3,
    /// O5.
    O5,
}

impl SelectionMethod {
    /// The design criterion (`None` for random).
    pub fn criterion(self) -> Option<design::Criterion> {
        use design::Criterion as C;
        match self {
            SelectionMethod::Random => None,
            SelectionMethod::D => Some(C::D),
            SelectionMethod::A => Some(C::A),
            SelectionMethod::E => Some(C::E),
            SelectionMethod::I => Some(C::I),
            SelectionMethod::O1 => Some(C::O1),
            SelectionMethod::O3 => Some(C::O3),
            SelectionMethod::O5 => Some(C::O5),
        }
    }
}

impl Default for PoseSelection {
    fn default() -> Self {
        PoseSelection {
            method: SelectionMethod::Random,
            candidates: 1000,
        }
    }
}

impl PoseSelection {
    /// The default (random) selection: not written into summaries, so that scenarios
    /// without the field give the same bytes as before it existed.
    pub fn is_default(&self) -> bool {
        *self == PoseSelection::default()
    }
}

/// Smallest plausible reach of a scenario's robot (the measured point from the base origin
/// at q = 0 and mid-limits), mm [20: the smallest arms calibrated with a tracker reach a few
/// hundred mm (a UR3 0.5 m); a robot file in metres reaches a few units]. The bounds of
/// `urdf` import.
pub const MIN_REACH_MM: f64 = 20.0;

/// Largest plausible reach of a scenario's robot, mm [50,000: the largest serial arms reach
/// 3–5 m (the KR1000 Titan 3.6 m)].
pub const MAX_REACH_MM: f64 = 50_000.0;

/// What the tracker measures at each identification pose (`measurement`).
///
/// `point` \[default\]: one reflector at the tool point, 3 equations per pose, the paper's
/// measurement (every committed result). `frame`: a 6-DoF probe at the tool point, its
/// position and orientation (`tracker.orientation_mpe_deg`), identified by
/// `identify::frames` with the tool orientation among the unknowns, orientation rows
/// weighted by `identify::frames::DEFAULT_MM_PER_DEG`. `targets`: the tool point and one
/// reflector per `reflector_offsets_mm` (flange frame, from the tool point), each a reading
/// of its own, identified by `identify::frames` with every target's point among the
/// unknowns. Validation always measures the tool point (Table 4 stays comparable).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeasurementConfig {
    /// `"point"`, `"frame"` or `"targets"` \[point\].
    #[serde(rename = "type")]
    pub kind: design::Measure,
    /// Offsets of the reflectors beside the tool point, flange frame, mm (`targets` only)
    /// \[(100, 0, 0) and (0, 100, 0): a right triangle of 100 mm legs with the tool point,
    /// the size of a three-reflector adapter on a large robot's flange\].
    pub reflector_offsets_mm: Vec<[f64; 3]>,
}

impl Default for MeasurementConfig {
    fn default() -> Self {
        MeasurementConfig {
            kind: design::Measure::Point,
            reflector_offsets_mm: vec![[100.0, 0.0, 0.0], [0.0, 100.0, 0.0]],
        }
    }
}

impl MeasurementConfig {
    /// The default (a point): not written into summaries, so that scenarios without the
    /// field give the same bytes as before it existed.
    pub fn is_default(&self) -> bool {
        *self == MeasurementConfig::default()
    }

    /// Offsets of every measured point from the tool point (flange frame): the tool point
    /// itself, then (for `targets`) the reflectors.
    pub fn offsets_mm(&self) -> Vec<nalgebra::Vector3<f64>> {
        let mut v = vec![nalgebra::Vector3::zeros()];
        if self.kind == design::Measure::Targets {
            v.extend(
                self.reflector_offsets_mm
                    .iter()
                    .map(|o| nalgebra::Vector3::from(*o)),
            );
        }
        v
    }

    /// What the virtual tracker reads per pose in a simulated measurement file
    /// (`kincal simulate`): the tool point, the 6-DoF probe, or the tool point and the
    /// reflectors named as [`MeasurementConfig::target_names`].
    pub fn probe(&self) -> virtual_robot::Probe {
        match self.kind {
            design::Measure::Point => virtual_robot::Probe::Point,
            design::Measure::Frame => virtual_robot::Probe::Frame,
            design::Measure::Targets => virtual_robot::Probe::Targets(
                self.target_names()
                    .into_iter()
                    .zip(self.offsets_mm())
                    .collect(),
            ),
        }
    }

    /// Target names of the identification (`""` for the tool point alone; `tool`, `r1`, …
    /// with reflectors).
    pub fn target_names(&self) -> Vec<String> {
        match self.kind {
            design::Measure::Targets => std::iter::once("tool".to_string())
                .chain((1..=self.reflector_offsets_mm.len()).map(|k| format!("r{k}")))
                .collect(),
            _ => vec![String::new()],
        }
    }
}

/// A scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name; results go to `results/<name>/`.
    pub name: String,
    /// One-paragraph rationale.
    #[serde(default)]
    pub description: String,
    /// Robot model file, relative to the scenario file.
    pub robot: PathBuf,
    /// Measured point (ball) in the flange frame, mm; overrides the model file's `tool_mm`.
    #[serde(default)]
    pub tool_mm: Option<[f64; 3]>,
    /// Checks of the scenario passed over \[none\]: `length-units` accepts a robot file whose
    /// reach is outside [`MIN_REACH_MM`] … [`MAX_REACH_MM`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub allow: Vec<String>,
    /// Seed of every random stream.
    pub seed: u64,
    /// Monte Carlo trials \[200\].
    #[serde(default = "default_trials")]
    pub trials: u64,
    /// Injected geometric errors.
    #[serde(default)]
    pub truth: InjectedErrors,
    /// The laser tracker.
    #[serde(default)]
    pub tracker: TrackerConfig,
    /// Errors outside the identification model.
    #[serde(default)]
    pub unmodelled: UnmodelledConfig,
    /// Identification and validation pose sets.
    #[serde(default)]
    pub poses: PoseSampling,
    /// Parameter set and solver.
    #[serde(default)]
    pub identification: IdentificationConfig,
    /// Compensation by IK.
    #[serde(default)]
    pub compensation: CompensationConfig,
    /// ISO 9283 position test.
    #[serde(default)]
    pub iso: IsoConfig,
    /// Recovery scoring.
    #[serde(default)]
    pub recovery: RecoveryConfig,
    /// How the identification poses are chosen (random or designed).
    #[serde(default, skip_serializing_if = "PoseSelection::is_default")]
    pub pose_selection: PoseSelection,
    /// The residual budget: rerun with each source outside the model switched off in turn
    /// and alone (see [`crate::residual_budget`]) \[off\].
    #[serde(default, skip_serializing_if = "BudgetConfig::is_default")]
    pub residual_budget: BudgetConfig,
    /// What each identification pose measures: a point \[default\], a 6-DoF frame, or
    /// several reflectors ([`MeasurementConfig`]).
    #[serde(default, skip_serializing_if = "MeasurementConfig::is_default")]
    pub measurement: MeasurementConfig,
    /// The learned residual model in each trial ([`ResidualModelConfig`]) \[off\].
    #[serde(default, skip_serializing_if = "ResidualModelConfig::is_default")]
    pub residual_model: ResidualModelConfig,
}

/// A parsed scenario with its robot loaded and everything validated.
#[derive(Clone, Debug)]
pub struct LoadedScenario {
    /// The scenario as written.
    pub scenario: Scenario,
    /// Where it came from (label for errors).
    pub source: String,
    /// The nominal robot (with the scenario's tool).
    pub nominal: Robot,
}

impl LoadedScenario {
    /// The virtual-robot part of the scenario.
    pub fn virtual_robot(&self) -> VirtualRobotConfig {
        let s = &self.scenario;
        VirtualRobotConfig {
            truth: s.truth.clone(),
            tracker: s.tracker.clone(),
            unmodelled: s.unmodelled.clone(),
            poses: s.poses.clone(),
        }
    }

    /// The virtual robot the trials run: with a designed selection, the sampler draws the
    /// candidate pool as the identification set (see [`PoseSelection`]).
    pub fn trial_virtual_robot(&self) -> VirtualRobotConfig {
        let mut vr = self.virtual_robot();
        if self.scenario.pose_selection.method.criterion().is_some() {
            vr.poses.identification =
                virtual_robot::PoseSet::Count(self.scenario.pose_selection.candidates);
        }
        vr
    }

    /// The physical scale of the design's columns: the scenario's per-class error budget
    /// (`truth.random` σ's), or the design crate's default when there is no random draw.
    pub fn design_scale(&self) -> design::Scale {
        match &self.scenario.truth.random {
            Some(r) => design::Scale::from_classes(
                &self.nominal,
                r.joint_angle_sigma_deg,
                r.length_sigma_mm,
                r.base_rotation_sigma_deg,
                r.base_translation_sigma_mm,
                r.tool_sigma_mm,
            ),
            None => design::Scale::default(),
        }
    }
}

impl Scenario {
    /// Parses a scenario from a JSON value (used by sweeps after editing axes).
    pub fn from_value(value: serde_json::Value, source: &str) -> Result<Scenario, ScenarioError> {
        serde_path_to_error::deserialize(value).map_err(|e| ScenarioError::Parse {
            file: source.to_string(),
            field: e.path().to_string(),
            message: e.into_inner().to_string(),
        })
    }

    /// Parses a scenario from JSON text.
    pub fn from_json_str(text: &str, source: &str) -> Result<Scenario, ScenarioError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let scenario =
            serde_path_to_error::deserialize(&mut *de).map_err(|e| ScenarioError::Parse {
                file: source.to_string(),
                field: e.path().to_string(),
                message: e.into_inner().to_string(),
            })?;
        // Nothing but white space after the document.
        de.end().map_err(|e| ScenarioError::Parse {
            file: source.to_string(),
            field: ".".to_string(),
            message: e.to_string(),
        })?;
        Ok(scenario)
    }

    /// Loads the robot (relative to `base_dir`) and validates every section.
    pub fn load(mut self, base_dir: &Path, source: &str) -> Result<LoadedScenario, ScenarioError> {
        let invalid = |field: &str, message: String| ScenarioError::Invalid {
            file: source.to_string(),
            field: field.to_string(),
            message,
        };
        if self.name.trim().is_empty()
            || self
                .name
                .chars()
                .any(|c| !(c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.'))
        {
            return Err(invalid(
                "name",
                format!(
                    "{:?} must be a non-empty file-name-safe word (letters, digits, - _ .)",
                    self.name
                ),
            ));
        }
        // Sizes before anything is allocated for them (docs/scale.md, "Sizes and memory").
        for (field, n) in [
            ("poses.identification", self.poses.identification.len()),
            ("poses.validation", self.poses.validation.len()),
            ("pose_selection.candidates", self.pose_selection.candidates),
        ] {
            check_poses(n).map_err(|e| ScenarioError::Invalid {
                file: source.to_string(),
                field: field.to_string(),
                message: e.to_string(),
            })?;
        }
        if self.trials == 0 {
            return Err(invalid("trials", "must be at least 1".into()));
        }
        let robot_path = base_dir.join(&self.robot);
        let mut nominal =
            Robot::from_file(&robot_path).map_err(|source_err| ScenarioError::Robot {
                file: source.to_string(),
                source: source_err,
            })?;
        if let Some(a) = self.allow.iter().find(|a| *a != "length-units") {
            return Err(invalid(
                "allow",
                format!("{a:?} is no check of a scenario (the one there is: \"length-units\")"),
            ));
        }
        // The reach (the measured point from the base origin at q = 0 and mid-limits), as
        // `urdf::reach_mm` measures it: a physical size, which a robot file in metres has
        // a thousand times too small.
        let base = nominal.to_spec().base;
        let origin = nalgebra::Vector3::new(base.dx_mm, base.dy_mm, base.dz_mm);
        let mid: Vec<f64> = (0..nominal.n_joints())
            .map(|i| {
                let l = nominal.limits_rad(i);
                0.5 * (l[0] + l[1])
            })
            .collect();
        let reach_mm = [vec![0.0; nominal.n_joints()], mid]
            .iter()
            .map(|q| (nominal.point(q) - origin).norm())
            .fold(0.0, f64::max);
        if !(MIN_REACH_MM..=MAX_REACH_MM).contains(&reach_mm)
            && !self.allow.iter().any(|a| a == "length-units")
        {
            return Err(invalid(
                "robot",
                format!(
                    "{}: the robot reaches {reach_mm:.1} mm from its base (the measured point at \
                     q = 0 or mid-limits), outside the {MIN_REACH_MM} … {MAX_REACH_MM} mm of robot \
                     arms: its lengths look like {} where a robot file has millimetres; convert \
                     the file, or pass the check with \"allow\": [\"length-units\"]",
                    robot_path.display(),
                    if reach_mm < MIN_REACH_MM {
                        "metres"
                    } else {
                        "micrometres (or a URDF's millimetres taken for metres)"
                    }
                ),
            ));
        }
        if let Some(t) = self.tool_mm {
            if t.iter().any(|v| !v.is_finite()) {
                return Err(invalid("tool_mm", format!("{t:?} is not finite")));
            }
            nominal.set_tool_mm(t.into());
        }
        if self.measurement.kind != design::Measure::Point {
            if !self.identification.extended.is_empty() {
                return Err(invalid(
                    "measurement.type",
                    "frame and target measurements identify the geometric model only; leave \
                     identification.extended out"
                        .into(),
                ));
            }
            if self.residual_budget.enabled {
                return Err(invalid(
                    "measurement.type",
                    "the residual budget runs point measurements only; switch \
                     residual_budget.enabled off"
                        .into(),
                ));
            }
        }
        self.residual_model
            .validate(&self)
            .map_err(|(field, message)| invalid(field, message))?;
        if self.measurement.kind == design::Measure::Targets {
            let offs = &self.measurement.reflector_offsets_mm;
            if offs.is_empty() {
                return Err(invalid(
                    "measurement.reflector_offsets_mm",
                    "targets need at least one reflector beside the tool point".into(),
                ));
            }
            for (k, o) in offs.iter().enumerate() {
                let n = nalgebra::Vector3::from(*o).norm();
                if !n.is_finite() || n < 1.0 {
                    return Err(invalid(
                        &format!("measurement.reflector_offsets_mm[{k}]"),
                        format!(
                            "{o:?}: a reflector must be finite and at least 1 mm from the tool point"
                        ),
                    ));
                }
            }
        }
        if self.iso.enabled {
            let iso = &self.iso;
            if iso.cycles < 2 {
                return Err(invalid("iso.cycles", "needs at least 2 cycles".into()));
            }
            if iso.reference_q_deg.len() != nominal.n_joints() {
                return Err(invalid(
                    "iso.reference_q_deg",
                    format!(
                        "has {} values, the robot has {} joints",
                        iso.reference_q_deg.len(),
                        nominal.n_joints()
                    ),
                ));
            }
            if !(iso.min_edge_mm > 0.0 && iso.max_edge_mm > iso.min_edge_mm) {
                return Err(invalid(
                    "iso.max_edge_mm",
                    "needs 0 < min_edge_mm < max_edge_mm".into(),
                ));
            }
            if iso.centre_step_mm.is_nan() || iso.centre_step_mm <= 0.0 {
                return Err(invalid("iso.centre_step_mm", "must be positive".into()));
            }
        }
        if self.residual_budget.enabled && self.residual_budget.trials == 0 {
            return Err(invalid(
                "residual_budget.trials",
                "must be at least 1 when the budget is enabled".into(),
            ));
        }
        if self.compensation.max_iterations == 0
            || self.compensation.tol_pos_mm.is_nan()
            || self.compensation.tol_pos_mm <= 0.0
        {
            return Err(invalid(
                "compensation",
                "max_iterations and tol_pos_mm must be positive".into(),
            ));
        }
        self.identification
            .lm
            .validate()
            .map_err(|e| invalid("identification.lm", e.to_string()))?;
        let id_nominal = nominal
            .with_extended(
                &self.identification.extended_names(nominal.n_joints()),
                source,
            )
            .map_err(|e| invalid("identification.extended", e.to_string()))?;
        if let ParamSet::Names(names) = &self.identification.params {
            id_nominal
                .layout()
                .select(names)
                .map_err(|e| invalid("identification.params", e.to_string()))?;
        }
        if self.pose_selection.method.criterion().is_some() {
            match &self.poses.identification {
                virtual_robot::PoseSet::Count(n) if *n <= self.pose_selection.candidates => {}
                virtual_robot::PoseSet::Count(n) => {
                    return Err(invalid(
                        "pose_selection.candidates",
                        format!(
                            "{} candidates cannot give {n} distinct identification poses",
                            self.pose_selection.candidates
                        ),
                    ));
                }
                virtual_robot::PoseSet::ListDeg(_) => {
                    return Err(invalid(
                        "pose_selection.method",
                        "a designed selection needs `poses.identification` as a count".into(),
                    ));
                }
            }
        }
        self.unmodelled
            .use_robot_mass_model(&nominal)
            .map_err(|e| ScenarioError::VirtualRobot {
                file: source.to_string(),
                source: e,
            })?;
        let loaded = LoadedScenario {
            source: source.to_string(),
            nominal,
            scenario: self,
        };
        loaded
            .virtual_robot()
            .validate(&loaded.nominal)
            .map_err(|e| ScenarioError::VirtualRobot {
                file: source.to_string(),
                source: e,
            })?;
        Ok(loaded)
    }

    /// Reads, parses and loads a scenario file.
    pub fn from_file(path: &Path) -> Result<LoadedScenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        let label = path.display().to_string();
        let base = path.parent().unwrap_or(Path::new("."));
        Scenario::from_json_str(&text, &label)?.load(base, &label)
    }
}

/// The most poses a set of a scenario may have (`poses.identification`,
/// `poses.validation`, `pose_selection.candidates`): 10⁶. A trial holds its poses'
/// Jacobian rows and points, about [`BYTES_PER_POSE`] per pose and worker thread; its time
/// and memory per pose, and a trial of 10⁶ poses extrapolated from them, are measured by
/// `cargo xtask timings` (`docs/timings.md`, "Poses per trial").
pub const MAX_POSES: u64 = 1_000_000;

/// Checks a count of poses (a scenario's sets, design candidates from a file, an option or
/// a Python array, random poses) before anything is allocated for them: at most
/// [`MAX_POSES`], and [`BYTES_PER_POSE`] each within the machine's available memory
/// (`measurements::check_size`; docs/scale.md, "Sizes and memory"). Every front end checks
/// poses through this.
pub fn check_poses(count: usize) -> Result<(), measurements::SizeError> {
    measurements::check_size("poses", count as u64, MAX_POSES, BYTES_PER_POSE)
}

/// Memory per pose of a trial, per worker thread, rounded up from the measurement of
/// `cargo xtask timings` (`docs/timings.md`, "Poses per trial": the slope of the peak
/// memory of one trial with 20,000 and 200,000 poses on one thread; 2.7 kB when this was
/// set).
pub const BYTES_PER_POSE: u64 = 3_072;

/// Trials per budget run when the scenario does not say \[200\].
pub const DEFAULT_BUDGET_TRIALS: u64 = 200;

/// The scenario's `residual_budget` section (what [`crate::residual_budget`] computes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BudgetConfig {
    /// Compute the budget \[false\]: it costs 2 runs per source plus 2, so it is opt-in.
    pub enabled: bool,
    /// Trials per run \[200\], capped at the campaign's trial count: the budget's figures are
    /// means over trials 0..trials, the same trials for every run.
    pub trials: u64,
}

impl Default for BudgetConfig {
    fn default() -> Self {
        BudgetConfig {
            enabled: false,
            trials: DEFAULT_BUDGET_TRIALS,
        }
    }
}

impl BudgetConfig {
    /// The default (off): not written into summaries, so that scenarios without the field
    /// give the same bytes as before it existed.
    pub fn is_default(&self) -> bool {
        *self == BudgetConfig::default()
    }
}

/// The scenario's `residual_model` section: each trial fits the learned residual model
/// (`docs/residual-model.md`, "In campaigns") on its identification poses as `kincal
/// identify --residual-model gp` does — a k-fold cross-validation whose gate decides
/// whether the hybrid is used — and compensates its validation poses (and the ISO test's)
/// with the hybrid when the gate keeps it. The trial reports both compensations, so a sweep
/// shows what the hybrid gives at every pose count, kept or not.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ResidualModelConfig {
    /// Fit the model in each trial \[false: it costs k + 1 Gaussian-process fits a trial,
    /// O(n³) each in the n identification poses — about a second a trial at 400 poses\].
    pub enabled: bool,
    /// Folds of the cross-validation \[5, `calibrate::residual::DEFAULT_FOLDS`, the CLI's
    /// default\]; at least 3.
    pub folds: usize,
    /// Most poses the Gaussian process trains on \[600, `GpOptions::max_train_poses`,
    /// the CLI's\].
    pub max_train_poses: usize,
}

impl Default for ResidualModelConfig {
    fn default() -> Self {
        let cv = calibrate::residual::CvOptions::default();
        ResidualModelConfig {
            enabled: false,
            folds: cv.folds,
            max_train_poses: cv.gp.max_train_poses,
        }
    }
}

impl ResidualModelConfig {
    /// The default (off): not written into summaries, so that scenarios without the field
    /// give the same bytes as before it existed.
    pub fn is_default(&self) -> bool {
        *self == ResidualModelConfig::default()
    }

    /// The cross-validation's options (the GP's as the CLI's, but for the pose cap).
    pub fn cv_options(&self) -> calibrate::residual::CvOptions {
        let mut cv = calibrate::residual::CvOptions {
            folds: self.folds,
            ..Default::default()
        };
        cv.gp.max_train_poses = self.max_train_poses;
        cv
    }

    /// Checks the section against the rest of `scenario`: the field at fault and why.
    fn validate(&self, scenario: &Scenario) -> Result<(), (&'static str, String)> {
        if !self.enabled {
            return Ok(());
        }
        let min = calibrate::residual::MIN_TRAIN_POSES;
        if self.folds < 3 {
            return Err((
                "residual_model.folds",
                format!(
                    "{}: at least 3 folds are needed (the gate compares each gain with its \
                     fold-to-fold scatter)",
                    self.folds
                ),
            ));
        }
        if self.max_train_poses < min {
            return Err((
                "residual_model.max_train_poses",
                format!("{}: at least {min}", self.max_train_poses),
            ));
        }
        if scenario.measurement.kind != design::Measure::Point {
            return Err((
                "residual_model.enabled",
                "a campaign's residual model is fitted on point measurements (its trials do not \
                 model orientation residuals; `kincal identify --residual-model gp` does, on a \
                 6-DoF recording); measurement.type must be \"point\""
                    .into(),
            ));
        }
        let n = scenario.poses.identification.len();
        if n < self.folds || n - n.div_ceil(self.folds) < min {
            return Err((
                "poses.identification",
                format!(
                    "{n} poses in {} folds: each fold of the residual model's cross-validation \
                     must train on at least {min} poses; measure more or switch \
                     residual_model.enabled off",
                    self.folds
                ),
            ));
        }
        Ok(())
    }
}
