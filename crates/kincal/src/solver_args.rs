//! Argument parsing of the solver settings: the command line takes the library's own names
//! (`FromStr` of [`identify::Damping`], [`identify::Redundant`],
//! [`identify::RegistrationPolicy`], [`calibrate::JointUnits`], [`calibrate::LengthUnits`]),
//! listed to clap as possible values; the Python binding parses the same names.

use std::str::FromStr;

use clap::builder::{PossibleValuesParser, TypedValueParser};

/// A clap value parser of a library option type: `names` (the type's `NAMES`) as the
/// possible values (in the help and in clap's refusal), each parsed by the type's `FromStr`.
pub fn library_names<T>(names: &'static [&'static str]) -> impl TypedValueParser<Value = T>
where
    T: FromStr + Clone + Send + Sync + 'static,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    PossibleValuesParser::new(names.iter().copied()).try_map(|s| s.parse::<T>())
}
