//! Why a campaign, a sweep, a shard merge or one trial failed: [`CampaignError`], the one
//! error type of the crate.

/// Why a campaign or one of its trials failed.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    /// The scenario is unusable.
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// The virtual robot could not be built or simulated.
    #[error("trial {trial}: virtual robot: {source}")]
    Sim {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: virtual_robot::SimError,
    },
    /// Identification failed.
    #[error("trial {trial}: identification: {source}")]
    Identify {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: identify::IdentifyError,
    },
    /// The design of the identification poses failed.
    #[error("trial {trial}: design: {source}")]
    Design {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: design::DesignError,
    },
    /// Evaluation failed (e.g. no validation pose could be measured).
    #[error("trial {trial}: evaluation: {source}")]
    Evaluate {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: evaluate::EvalError,
    },
    /// The ISO 9283 test could not be set up.
    #[error("ISO 9283 setup: {0}")]
    Iso(String),
    /// Writing results failed.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Something else, described.
    #[error("{0}")]
    Other(String),
}
