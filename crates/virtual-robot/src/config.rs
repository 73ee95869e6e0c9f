//! [`VirtualRobotConfig`]: the four scenario sections together.

use kinematics::Robot;
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;
use crate::poses::PoseSampling;
use crate::tracker::TrackerConfig;
use crate::truth::InjectedErrors;
use crate::unmodelled::UnmodelledConfig;

/// The virtual robot's configuration: the `truth`, `tracker`, `unmodelled` and `poses`
/// sections of a scenario file. Every section and field has a default; unknown fields are
/// errors.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VirtualRobotConfig {
    /// Injected geometric errors.
    pub truth: InjectedErrors,
    /// The laser tracker.
    pub tracker: TrackerConfig,
    /// Errors outside the identification model.
    pub unmodelled: UnmodelledConfig,
    /// Pose sampling.
    pub poses: PoseSampling,
}

impl VirtualRobotConfig {
    /// A perfect world: no injected error, no unmodelled error, no tracker noise, zero
    /// residual (default tracker placement and pose sampling).
    pub fn ideal() -> Self {
        let mut c = VirtualRobotConfig {
            unmodelled: UnmodelledConfig::off(),
            ..VirtualRobotConfig::default()
        };
        c.tracker.noise = false;
        c
    }

    /// Checks every section against the nominal robot. Errors name the field by its path,
    /// e.g. `tracker.sigma_fraction`, `truth.explicit.thetaX`, `poses.validation`.
    pub fn validate(&self, nominal: &Robot) -> Result<(), ConfigError> {
        // The virtual robot's physics beyond geometry is the `unmodelled` section; a nominal
        // model with non-geometric parameters (an `extended` section) has no place here.
        if let Some(model) = nominal.extended() {
            return Err(ConfigError::invalid(
                "robot",
                format!(
                    "the virtual robot's nominal model must be geometric, but `{}` carries the \
                     non-geometric parameters {} (its `extended` section): inject joint \
                     compliance and gear errors with `unmodelled.compliance` and \
                     `unmodelled.gears` instead",
                    nominal.name(),
                    model
                        .kinds()
                        .iter()
                        .map(|k| k.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        self.truth.validate(nominal.layout())?;
        self.tracker.validate(nominal)?;
        self.unmodelled.validate(nominal)?;
        self.poses.validate(nominal)
    }

    /// Parses the four sections from a JSON object (not validated against a robot: call
    /// [`VirtualRobotConfig::validate`]). Errors name the offending field's path.
    pub fn from_json_str(text: &str) -> Result<Self, ConfigError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let config =
            serde_path_to_error::deserialize(&mut *de).map_err(|e| ConfigError::Parse {
                field: e.path().to_string(),
                message: e.into_inner().to_string(),
            })?;
        de.end().map_err(|e| ConfigError::Parse {
            field: ".".to_string(),
            message: e.to_string(),
        })?;
        Ok(config)
    }
}
