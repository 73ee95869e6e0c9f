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

#[cfg(test)]
mod tests {
    use clap::{Arg, Command};
    use identify::{Damping, RegistrationPolicy};

    use super::library_names;

    fn parse(args: &[&str]) -> Result<(Damping, RegistrationPolicy), clap::Error> {
        let m = Command::new("t")
            .arg(
                Arg::new("schedule")
                    .long("schedule")
                    .default_value("levenberg")
                    .value_parser(library_names::<Damping>(Damping::NAMES)),
            )
            .arg(
                Arg::new("registration")
                    .long("registration")
                    .default_value("auto")
                    .value_parser(library_names::<RegistrationPolicy>(
                        RegistrationPolicy::NAMES,
                    )),
            )
            .try_get_matches_from(std::iter::once("t").chain(args.iter().copied()))?;
        Ok((
            *m.get_one::<Damping>("schedule").unwrap(),
            *m.get_one::<RegistrationPolicy>("registration").unwrap(),
        ))
    }

    #[test]
    fn the_library_names_parse_and_others_are_refused_listing_them() {
        assert_eq!(
            parse(&[]).unwrap(),
            (Damping::levenberg(), RegistrationPolicy::default())
        );
        assert_eq!(
            parse(&["--schedule", "nielsen", "--registration", "never"]).unwrap(),
            (Damping::nielsen(), RegistrationPolicy::Never)
        );
        let e = parse(&["--schedule", "fast"]).unwrap_err().to_string();
        assert!(e.contains("invalid value 'fast'"), "{e}");
        assert!(
            e.contains("[possible values: levenberg, marquardt, nielsen]"),
            "{e}"
        );
    }
}
