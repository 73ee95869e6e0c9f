//! What to identify, as a user writes it: a parameter spec `BASE[+ITEM]…`.
//!
//! * BASE is a [`ParamSet`]: `paper` (every parameter, redundant ones included), `minimal`
//!   (the identifiable set at the start model and the poses) or comma-separated names.
//! * Each ITEM after a `+` adds non-geometric joint parameters (`docs/extended-model.md`) to
//!   the model and to the free set: the family `compliance` (every joint's `compliance_j`),
//!   the family `gears` (the first harmonic, sine and cosine, of every joint), a parameter name
//!   (`compliance_2`) or comma-separated names (`gear_1_h2_sin,gear_1_h2_cos`).
//!
//! `paper+compliance+gears` frees every geometric parameter of a 6-joint robot and its 18
//! extended ones; `a2,d3+compliance_2` frees a2, d3 and compliance_2. This module is the one
//! reading of a spec: `kincal identify`, `identifiability` and `design` (`--params`) and the
//! calibration workflow all go through [`ParamSpec`].

use std::convert::Infallible;
use std::fmt;
use std::str::FromStr;

use kinematics::Robot;

use crate::error::IdentifyError;
use crate::identifiability::{IdentifiabilityOptions, ParamSet};

/// Which parameters to identify, extended parameters included (see the module docs).
///
/// ```
/// use identify::{ParamSet, ParamSpec};
///
/// let spec: ParamSpec = "minimal+compliance+gear_1_h2_sin,gear_1_h2_cos".parse().unwrap();
/// assert_eq!(spec.base, ParamSet::Minimal);
/// assert_eq!(spec.extended, ["compliance", "gear_1_h2_sin,gear_1_h2_cos"]);
/// assert_eq!(spec.extended_names(2), ["compliance_1", "compliance_2", "gear_1_h2_sin", "gear_1_h2_cos"]);
/// assert_eq!(spec.to_string(), "minimal+compliance+gear_1_h2_sin,gear_1_h2_cos");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSpec {
    /// The part before the first `+`: `paper`, `minimal` or names.
    pub base: ParamSet,
    /// The items after each `+`, in order, as written (names trimmed): a family
    /// (`compliance`, `gears`), a parameter name, or comma-separated parameter names. Empty:
    /// the robot's model as it is.
    pub extended: Vec<String>,
}

impl Default for ParamSpec {
    /// `paper`: every parameter of the robot as it is (the paper's method).
    fn default() -> Self {
        ParamSpec {
            base: ParamSet::Paper,
            extended: Vec::new(),
        }
    }
}

impl FromStr for ParamSpec {
    type Err = Infallible;

    /// Reads `BASE[+ITEM]…` (whitespace around names ignored). Nothing is checked against a
    /// robot here: unknown names are refused by [`ParamSpec::apply`] and
    /// [`ParamSpec::resolve`], which name them.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut parts = s.split('+');
        let base = parts.next().unwrap_or_default().parse()?;
        let extended = parts
            .map(|item| item.split(',').map(str::trim).collect::<Vec<_>>().join(","))
            .collect();
        Ok(ParamSpec { base, extended })
    }
}

impl fmt::Display for ParamSpec {
    /// The spec as written (`paper+compliance+gears`): [`ParamSpec::from_str`] reads it back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.base)?;
        for item in &self.extended {
            write!(f, "+{item}")?;
        }
        Ok(())
    }
}

impl ParamSpec {
    /// The extended parameters' names for an `n_joints` robot, in the order given: families
    /// expanded ([`kinematics::expand_family`]), comma-separated names split.
    pub fn extended_names(&self, n_joints: usize) -> Vec<String> {
        let mut names = Vec::new();
        for item in &self.extended {
            if item.contains(',') {
                names.extend(item.split(',').map(|n| n.trim().to_string()));
            } else {
                names.extend(kinematics::expand_family(item.trim(), n_joints));
            }
        }
        names
    }

    /// `robot` with the extended parameters appended to its parameter vector, all zero
    /// ([`Robot::with_extended`]; `source_name` names the robot in its errors), or `robot`
    /// unchanged when the spec has none (an extended robot file stays extended).
    ///
    /// # Errors
    /// [`IdentifyError::Model`] naming an unknown family member (`compliance_9` of a 6-joint
    /// robot) or a robot file without the mass model that compliance needs.
    pub fn apply(&self, robot: &Robot, source_name: &str) -> Result<Robot, IdentifyError> {
        if self.extended.is_empty() {
            return Ok(robot.clone());
        }
        Ok(robot.with_extended(&self.extended_names(robot.n_joints()), source_name)?)
    }

    /// The free parameter indices of `robot` (layout order; `robot` as [`ParamSpec::apply`]
    /// returns it). `paper`: every parameter, the extended ones included; `minimal`: the
    /// identifiable set of every parameter at `robot` on `poses_rad` (with the optional
    /// weights); names: those names and the extended parameters.
    ///
    /// # Errors
    /// An unknown name (the error lists the robot's parameters), no free parameter at all, or
    /// the analysis of `minimal` failing on the poses.
    pub fn resolve(
        &self,
        robot: &Robot,
        poses_rad: &[f64],
        weights: Option<&[f64]>,
        opts: &IdentifiabilityOptions,
    ) -> Result<Vec<usize>, IdentifyError> {
        match &self.base {
            ParamSet::Names(names) if !self.extended.is_empty() => {
                let all = names
                    .iter()
                    .cloned()
                    .chain(self.extended_names(robot.n_joints()))
                    .collect();
                ParamSet::Names(all).resolve(robot, poses_rad, weights, opts)
            }
            base => base.resolve(robot, poses_rad, weights, opts),
        }
    }

    /// The free parameters' names when they do not depend on poses (`paper` and names, as
    /// [`ParamSpec::resolve`] gives them, in layout order); `None` for `minimal`, which the
    /// caller decides on its own poses (a design on its candidates, a workflow on its data).
    ///
    /// # Errors
    /// As [`ParamSpec::resolve`].
    pub fn listed(&self, robot: &Robot) -> Result<Option<Vec<String>>, IdentifyError> {
        if self.base == ParamSet::Minimal {
            return Ok(None);
        }
        let free = self.resolve(robot, &[], None, &IdentifiabilityOptions::default())?;
        let layout = robot.layout();
        Ok(Some(
            free.iter()
                .map(|&k| layout.get(k).name.to_string())
                .collect(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinematics::RobotSpec;

    fn kr1000() -> Robot {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap()
    }

    fn spec(s: &str) -> ParamSpec {
        s.parse().unwrap()
    }

    #[test]
    fn specs_read_back_as_written() {
        for s in [
            "paper",
            "minimal",
            "a2,theta3",
            "paper+compliance",
            "paper+compliance+gears",
            "minimal+compliance_2,compliance_3",
            "a2+compliance_2+gears",
        ] {
            assert_eq!(spec(s).to_string(), s);
            assert_eq!(spec(&spec(s).to_string()), spec(s));
        }
        assert_eq!(
            spec(" paper + compliance_2 , compliance_3").to_string(),
            "paper+compliance_2,compliance_3"
        );
        assert_eq!(
            spec("a2, d3").base,
            ParamSet::Names(vec!["a2".into(), "d3".into()])
        );
        assert_eq!(ParamSpec::default(), spec("paper"));
    }

    #[test]
    fn families_expand_for_the_robot_and_lists_are_names() {
        let s = spec("paper+compliance+gears+gear_2_h2_sin,gear_2_h2_cos");
        let names = s.extended_names(6);
        assert_eq!(names.len(), 6 + 12 + 2);
        assert_eq!(names[0], "compliance_1");
        assert_eq!(names[6..8], ["gear_1_h1_sin", "gear_1_h1_cos"]);
        assert_eq!(names[18..], ["gear_2_h2_sin", "gear_2_h2_cos"]);
        // In a list, a family's name is a name, as `--params` has always read it.
        assert_eq!(
            spec("paper+compliance,gears").extended_names(6),
            ["compliance", "gears"]
        );
    }

    #[test]
    fn apply_extends_and_resolve_frees_the_extended_parameters() {
        let robot = kr1000();
        let opts = IdentifiabilityOptions::default();
        assert_eq!(spec("minimal").apply(&robot, "kr1000").unwrap(), robot);
        let s = spec("paper+compliance");
        let extended = s.apply(&robot, "kr1000").unwrap();
        assert_eq!(extended.n_params(), 34 + 6);
        assert_eq!(s.resolve(&extended, &[], None, &opts).unwrap().len(), 40);
        let s = spec("a2, theta3+compliance_2");
        let extended = s.apply(&robot, "kr1000").unwrap();
        let free = s.resolve(&extended, &[], None, &opts).unwrap();
        assert_eq!(free, vec![6, 8, 34]);
        assert_eq!(
            s.listed(&extended).unwrap().unwrap(),
            ["a2", "theta3", "compliance_2"]
        );
        assert_eq!(spec("minimal").listed(&robot).unwrap(), None);
        let e = spec("paper+compliance_7")
            .apply(&robot, "kr1000")
            .unwrap_err();
        assert!(e.to_string().contains("compliance_7"), "{e}");
        let e = spec("a2,a7").resolve(&robot, &[], None, &opts).unwrap_err();
        assert!(e.to_string().contains("unknown parameter `a7`"), "{e}");
    }
}
