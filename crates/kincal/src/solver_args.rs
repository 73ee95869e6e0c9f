//! Argument definitions: the command line's value enums of the solver settings, each mapped
//! onto the identification crate's own type (the libraries know nothing of clap).

use clap::ValueEnum;
use identify::{Damping, Redundant, RegistrationPolicy};

/// The damping schedule (`docs/model.md` §7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Schedule {
    /// The paper's: (JᵀJ + μI), μ0 = 1e-3, ÷10 / ×10.
    #[default]
    Levenberg,
    /// (JᵀJ + μ diag JᵀJ), same updates.
    Marquardt,
    /// Nielsen's gain-ratio schedule.
    Nielsen,
}

impl From<Schedule> for Damping {
    /// The schedule with its default constants.
    fn from(schedule: Schedule) -> Damping {
        match schedule {
            Schedule::Levenberg => Damping::levenberg(),
            Schedule::Marquardt => Damping::marquardt(),
            Schedule::Nielsen => Damping::nielsen(),
        }
    }
}

/// What the solver does with free parameters exactly redundant at the start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum RedundantArg {
    /// Hold them at their start values and solve on the identifiable rest [default: the
    /// solve is well posed and converges in a few iterations].
    #[default]
    Hold,
    /// Keep them in the damped system (the paper's verbatim method).
    Damp,
}

impl From<RedundantArg> for Redundant {
    fn from(arg: RedundantArg) -> Redundant {
        match arg {
            RedundantArg::Hold => Redundant::Hold,
            RedundantArg::Damp => Redundant::Damp,
        }
    }
}

/// When to register the measurement frame onto the robot base before identifying.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum RegistrationArg {
    /// When the nominal model misses the points by more than 10 mm on average [default:
    /// geometric errors are millimetres, a tracker frame is metres away].
    #[default]
    Auto,
    /// Always.
    Always,
    /// Never (the paper's procedure: LM from the nominal model).
    Never,
}

impl From<RegistrationArg> for RegistrationPolicy {
    /// `auto` is the library's default policy (10 mm).
    fn from(arg: RegistrationArg) -> RegistrationPolicy {
        match arg {
            RegistrationArg::Auto => RegistrationPolicy::default(),
            RegistrationArg::Always => RegistrationPolicy::Always,
            RegistrationArg::Never => RegistrationPolicy::Never,
        }
    }
}
