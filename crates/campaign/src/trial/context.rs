//! What every trial of a campaign shares ([`Context`]): the loaded scenario, the virtual
//! robot's setup, the identification options, the minimal sets recovery is scored on, the
//! ISO 9283 plan and a designed pose selection.

use identify::{IdentifyOptions, ParamSet};
use kinematics::Robot;
use virtual_robot::Setup;

use super::iso::{IsoPlan, iso_plan};
use crate::error::CampaignError;
use crate::scenario::LoadedScenario;

/// What is shared by all trials of a campaign.
pub struct Context {
    /// The scenario.
    pub loaded: LoadedScenario,
    /// The virtual robot's per-seed setup.
    pub setup: Setup,
    /// Identification options.
    pub id_options: IdentifyOptions,
    /// The minimal identifiable set (computed at the nominal model on trial 0's
    /// identification poses): recovery is scored on it.
    pub minimal_free: Vec<usize>,
    /// The ISO plan when the test is on.
    pub iso: Option<IsoPlan>,
    /// A designed pose selection: criterion, poses to choose and column scale.
    pub design: Option<(design::Criterion, usize, design::Scale)>,
    /// The start model of the identification: the nominal robot, extended by the
    /// scenario's non-geometric parameters (`identification.extended`) when it has any.
    pub id_nominal: Robot,
    /// The minimal identifiable set of `id_nominal` (on the same poses as `minimal_free`,
    /// which it equals for a geometric identification): recovery is scored on it.
    pub recovery_free: Vec<usize>,
}

impl Context {
    /// Builds the shared state: validates the virtual robot, resolves the minimal set,
    /// finds the ISO cube.
    pub fn new(loaded: LoadedScenario) -> Result<Context, CampaignError> {
        let vr = loaded.trial_virtual_robot();
        let seed = loaded.scenario.seed;
        let setup = Setup::new(&loaded.nominal, &vr, seed)
            .map_err(|source| CampaignError::Sim { trial: 0, source })?;
        let id = &loaded.scenario.identification;
        let reference = setup
            .world(0)
            .map_err(|source| CampaignError::Sim { trial: 0, source })?;
        let minimal_free = ParamSet::Minimal
            .resolve(
                &loaded.nominal,
                reference.identification_poses_rad(),
                None,
                &id.identifiability,
            )
            .map_err(|source| CampaignError::Identify { trial: 0, source })?;
        let iso = if loaded.scenario.iso.enabled {
            Some(iso_plan(&loaded, &vr.tracker)?)
        } else {
            None
        };
        let design = match (
            loaded.scenario.pose_selection.method.criterion(),
            &loaded.scenario.poses.identification,
        ) {
            (Some(c), virtual_robot::PoseSet::Count(n)) => Some((c, *n, loaded.design_scale())),
            _ => None,
        };
        let id_nominal = loaded
            .nominal
            .with_extended(
                &id.extended_names(loaded.nominal.n_joints()),
                &loaded.source,
            )
            .map_err(|source| CampaignError::ExtendedModel { source })?;
        let recovery_free = if id_nominal.is_extended() {
            ParamSet::Minimal
                .resolve(
                    &id_nominal,
                    reference.identification_poses_rad(),
                    None,
                    &id.identifiability,
                )
                .map_err(|source| CampaignError::Identify { trial: 0, source })?
        } else {
            minimal_free.clone()
        };
        Ok(Context {
            design,
            id_nominal,
            recovery_free,
            id_options: id.options(),
            loaded,
            setup,
            minimal_free,
            iso,
        })
    }

    /// The nominal robot.
    pub fn nominal(&self) -> &Robot {
        &self.loaded.nominal
    }
}
