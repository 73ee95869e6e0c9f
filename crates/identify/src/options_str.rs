//! The solver options by name, for every front end: `FromStr` of [`Damping`] (the schedule
//! with its default constants), [`Redundant`] and [`RegistrationPolicy`] (`auto` = the
//! default threshold), each accepting exactly the names of its `NAMES`. The command line
//! (`kincal identify --schedule`, `--redundant`, `--registration`) and the Python binding
//! (`schedule=`, `redundant=`, `registration=`) both parse with these.

use std::str::FromStr;

use crate::lm::{Damping, Redundant};
use crate::registration::RegistrationPolicy;

/// A name that is not one of an option's values: `unknown value "x" (a, b, c)`. A front end
/// puts the option's own name (its flag or argument) before it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown value {value:?} ({})", accepted.join(", "))]
pub struct UnknownName {
    /// The name given.
    pub value: String,
    /// The names accepted, in their documented order.
    pub accepted: &'static [&'static str],
}

/// The entry of `names` equal to `s` (exactly: case and spaces count), with the value
/// `values` gives at the same index.
pub fn parse_name<T: Copy>(
    s: &str,
    names: &'static [&'static str],
    values: &[T],
) -> Result<T, UnknownName> {
    names
        .iter()
        .position(|n| *n == s)
        .map(|k| values[k])
        .ok_or_else(|| UnknownName {
            value: s.to_string(),
            accepted: names,
        })
}

impl Damping {
    /// The schedules by name, in the order of [`Damping::name`]'s documentation.
    pub const NAMES: &'static [&'static str] = &["levenberg", "marquardt", "nielsen"];
}

impl FromStr for Damping {
    type Err = UnknownName;

    /// `levenberg`, `marquardt` or `nielsen`, with the schedule's default constants.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_name(
            s,
            Damping::NAMES,
            &[
                Damping::levenberg(),
                Damping::marquardt(),
                Damping::nielsen(),
            ],
        )
    }
}

impl Redundant {
    /// `hold` and `damp`.
    pub const NAMES: &'static [&'static str] = &["hold", "damp"];
}

impl FromStr for Redundant {
    type Err = UnknownName;

    /// `hold` or `damp`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_name(s, Redundant::NAMES, &[Redundant::Hold, Redundant::Damp])
    }
}

impl RegistrationPolicy {
    /// `auto` (the default threshold), `always` and `never`.
    pub const NAMES: &'static [&'static str] = &["auto", "always", "never"];
}

impl FromStr for RegistrationPolicy {
    type Err = UnknownName;

    /// `auto` ([`RegistrationPolicy::default`]), `always` or `never`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_name(
            s,
            RegistrationPolicy::NAMES,
            &[
                RegistrationPolicy::default(),
                RegistrationPolicy::Always,
                RegistrationPolicy::Never,
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_parses_to_its_value() {
        assert_eq!("levenberg".parse(), Ok(Damping::levenberg()));
        assert_eq!("marquardt".parse(), Ok(Damping::marquardt()));
        assert_eq!("nielsen".parse(), Ok(Damping::nielsen()));
        for name in Damping::NAMES {
            assert_eq!(name.parse::<Damping>().map(|d| d.name()), Ok(*name));
        }
        assert_eq!("hold".parse(), Ok(Redundant::Hold));
        assert_eq!("damp".parse(), Ok(Redundant::Damp));
        assert_eq!("auto".parse(), Ok(RegistrationPolicy::default()));
        assert_eq!("always".parse(), Ok(RegistrationPolicy::Always));
        assert_eq!("never".parse(), Ok(RegistrationPolicy::Never));
    }

    #[test]
    fn an_unknown_name_is_refused_with_the_accepted_ones() {
        let e = "Levenberg".parse::<Damping>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown value \"Levenberg\" (levenberg, marquardt, nielsen)"
        );
        assert_eq!(
            " hold".parse::<Redundant>().unwrap_err().to_string(),
            "unknown value \" hold\" (hold, damp)"
        );
        assert_eq!(
            "sometimes"
                .parse::<RegistrationPolicy>()
                .unwrap_err()
                .to_string(),
            "unknown value \"sometimes\" (auto, always, never)"
        );
    }
}
