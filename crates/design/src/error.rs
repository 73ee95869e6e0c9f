//! Why a design cannot be made.

/// Every way a design request can fail; each names what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// Fewer equations than identifiable parameters: rN < rank (r rows per pose).
    #[error(
        "{poses} poses give {} equations, fewer than the {rank} identifiable parameters \
         (need at least {} poses)",
        rows_per_pose * poses,
        rank.div_ceil(*rows_per_pose)
    )]
    TooFewPoses {
        /// Poses asked for.
        poses: usize,
        /// Size of the minimal identifiable set.
        rank: usize,
        /// Equations per pose (3 for a point, 6 for a frame, 3k for k targets).
        rows_per_pose: usize,
    },
    /// Several rigidly attached targets: enough equations, but their rank is bounded by the
    /// motion of one rigid body per pose and the targets' fixed shape.
    #[error(
        "{poses} poses of {targets} rigidly attached targets determine at most {} of the {rank} \
         unknowns ({per_pose} per pose for the tool's motion, {shape} for the targets' fixed \
         shape): need at least {} poses",
        per_pose * poses + shape,
        (rank.saturating_sub(*shape)).div_ceil(*per_pose)
    )]
    TooFewTargetPoses {
        /// Poses asked for.
        poses: usize,
        /// Targets per pose.
        targets: usize,
        /// Unknowns.
        rank: usize,
        /// Rank a pose adds: 6 (3 for one target, 5 for two).
        per_pose: usize,
        /// Rank of the shape, counted once: 3k − 6 (0 for one target, 1 for two).
        shape: usize,
    },
    /// The pool is smaller than the design.
    #[error("{candidates} candidates cannot give a design of {poses} distinct poses")]
    TooFewCandidates {
        /// Candidates available.
        candidates: usize,
        /// Poses asked for.
        poses: usize,
    },
    /// A candidate (or workspace) pose is unusable.
    #[error("{what} {index}{id}: {message}", id = id.as_deref().map(|s| format!(" (id {s})")).unwrap_or_default())]
    BadPose {
        /// `candidate` or `workspace pose`.
        what: &'static str,
        /// 0-based index in its set.
        index: usize,
        /// Its id, when it has one.
        id: Option<String>,
        /// What is wrong (NaN, outside the limits of joint k, wrong joint count).
        message: String,
    },
    /// No candidate (no combination of candidates) can observe these parameters: the pool's
    /// information matrix is singular on them.
    #[error(
        "the candidate pool cannot observe {}: on these {candidates} candidates they are \
         redundant ({}); add candidates that move these parameters or leave them out with --params",
        names.join(", "),
        detail
    )]
    RankDeficientPool {
        /// The parameters of the minimal set the pool leaves unobservable.
        names: Vec<String>,
        /// What they are confounded with on the pool (words).
        detail: String,
        /// Number of candidates.
        candidates: usize,
    },
    /// The caller asked the design to stop ([`crate::DesignOptions::stop`]).
    #[error("stopped on request")]
    Stopped,
    /// An option is out of range.
    #[error("option `{name}`: {message}")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The identifiability analysis failed.
    #[error("identifiability: {0}")]
    Identify(#[from] identify::IdentifyError),
    /// A parameter name is unknown.
    #[error("parameters: {0}")]
    Model(#[from] kinematics::ModelError),
    /// A candidate or workspace file is bad (names file, line and column).
    #[error(transparent)]
    Measurements(#[from] measurements::MeasurementError),
    /// A numerical failure (a matrix that should be positive definite is not).
    #[error("numerical failure: {0}")]
    Numerical(String),
}
