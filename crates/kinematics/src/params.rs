//! The identification parameter vector: names, units, order, and subsets.
//!
//! Order (`docs/model.md` §3), for an N-joint chain: for i = 1..N `theta_i, d_i, a_i, alpha_i`;
//! then `beta_i` for every joint i < N whose nominal α_i is zero (|α_i| <
//! [`BETA_ALPHA_TOL_DEG`]: the axis is parallel to the next one, Hayati's case); then `scale_i`
//! for every prismatic joint i (its axis scale, mm/mm); then `base_rx,
//! base_ry, base_rz, base_dx, base_dy, base_dz`; then `tool_x, tool_y, tool_z`. The KR1000 gets
//! 34 parameters (β2 only), a UR10 35 (β2, β3).
//!
//! Values in a parameter vector are in internal units: radians and millimetres. Use
//! [`ParamInfo::to_display`] / [`ParamInfo::from_display`] at interfaces (degrees, mm).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::error::ModelError;

/// |α_i| below this (degrees) makes β_i a parameter: consecutive axes are parallel.
pub const BETA_ALPHA_TOL_DEG: f64 = 1.0;

/// What a parameter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ParamKind {
    /// Joint-angle offset θ of joint `i` (0-based).
    Theta(usize),
    /// Link offset d of joint `i`.
    D(usize),
    /// Link length a of joint `i`.
    A(usize),
    /// Link twist α of joint `i`.
    Alpha(usize),
    /// Hayati β of joint `i`.
    Beta(usize),
    /// Axis scale of prismatic joint `i` (the encoder's mm per mm; the joint moves
    /// `scale · q` along z).
    Scale(usize),
    /// Base rotation about x.
    BaseRx,
    /// Base rotation about y.
    BaseRy,
    /// Base rotation about z.
    BaseRz,
    /// Base translation x.
    BaseDx,
    /// Base translation y.
    BaseDy,
    /// Base translation z.
    BaseDz,
    /// Measured point in the flange frame, x.
    ToolX,
    /// Measured point in the flange frame, y.
    ToolY,
    /// Measured point in the flange frame, z.
    ToolZ,
    /// A non-geometric joint-error parameter (`compliance_j`, `gear_j_hk_sin|cos`), after the
    /// tool in the layout of an extended robot ([`crate::Robot::with_extended`]).
    Extended(ExtendedKind),
}

/// Radians per arcsecond.
const RAD_PER_ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// What a non-geometric parameter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ExtendedKind {
    /// Compliance of joint `i` (0-based): Δθ = c · τ_i(q).
    Compliance(usize),
    /// Sine term of harmonic `harmonic` on joint `joint` (0-based): Δθ = s · sin(k q).
    GearSin {
        /// Joint, 0-based.
        joint: usize,
        /// Harmonic k ≥ 1.
        harmonic: u32,
    },
    /// Cosine term: Δθ = c · cos(k q).
    GearCos {
        /// Joint, 0-based.
        joint: usize,
        /// Harmonic k ≥ 1.
        harmonic: u32,
    },
}

impl ExtendedKind {
    /// The joint (0-based) the parameter acts on.
    pub fn joint(self) -> usize {
        match self {
            ExtendedKind::Compliance(j)
            | ExtendedKind::GearSin { joint: j, .. }
            | ExtendedKind::GearCos { joint: j, .. } => j,
        }
    }

    /// The stable name: `compliance_2`, `gear_1_h1_sin`, `gear_1_h1_cos` (joints 1-based).
    pub fn name(self) -> String {
        match self {
            ExtendedKind::Compliance(j) => format!("compliance_{}", j + 1),
            ExtendedKind::GearSin { joint, harmonic } => {
                format!("gear_{}_h{harmonic}_sin", joint + 1)
            }
            ExtendedKind::GearCos { joint, harmonic } => {
                format!("gear_{}_h{harmonic}_cos", joint + 1)
            }
        }
    }

    /// Parses a stable name (the inverse of [`ExtendedKind::name`]); `None` if `name` is not
    /// of either family's form.
    pub fn parse(name: &str) -> Option<ExtendedKind> {
        let joint = |s: &str| s.parse::<usize>().ok().filter(|j| *j >= 1).map(|j| j - 1);
        if let Some(j) = name.strip_prefix("compliance_") {
            return joint(j).map(ExtendedKind::Compliance);
        }
        let rest = name.strip_prefix("gear_")?;
        let (j, rest) = rest.split_once("_h")?;
        let (k, kind) = rest.split_once('_')?;
        let joint = joint(j)?;
        let harmonic = k.parse::<u32>().ok().filter(|k| *k >= 1)?;
        match kind {
            "sin" => Some(ExtendedKind::GearSin { joint, harmonic }),
            "cos" => Some(ExtendedKind::GearCos { joint, harmonic }),
            _ => None,
        }
    }

    /// The interface unit: µrad/(N·m) ([`Unit::MicroradPerNm`]) or arcseconds
    /// ([`Unit::Arcsec`]).
    pub fn unit(self) -> Unit {
        match self {
            ExtendedKind::Compliance(_) => Unit::MicroradPerNm,
            _ => Unit::Arcsec,
        }
    }

    /// Internal value (rad/(N·m) or rad) → display value (µrad/(N·m) or arcsec).
    pub fn to_display(self, internal: f64) -> f64 {
        match self {
            ExtendedKind::Compliance(_) => internal * 1e6,
            _ => internal / RAD_PER_ARCSEC,
        }
    }

    /// Display value → internal value.
    pub fn from_display(self, display: f64) -> f64 {
        match self {
            ExtendedKind::Compliance(_) => display * 1e-6,
            _ => display * RAD_PER_ARCSEC,
        }
    }
}

/// The interface unit of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Unit {
    /// An angle: degrees outside, radians inside.
    Deg,
    /// A length: millimetres everywhere.
    Mm,
    /// A joint compliance: µrad/(N·m) outside, rad/(N·m) inside.
    MicroradPerNm,
    /// A small joint angle (gear harmonics): arcseconds outside, radians inside.
    Arcsec,
    /// A ratio of lengths (a prismatic joint's axis scale): mm per mm everywhere.
    MmPerMm,
}

impl Unit {
    /// `"deg"` or `"mm"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Unit::Deg => "deg",
            Unit::Mm => "mm",
            Unit::MicroradPerNm => "urad/Nm",
            Unit::Arcsec => "arcsec",
            Unit::MmPerMm => "mm/mm",
        }
    }
}

/// A parameter's stable name (`theta1`, `beta2`, `base_dz`, `gear_1_h1_sin`, …), interned:
/// each distinct name is stored once for the life of the process, so a copy is a pointer
/// and the identification's outputs (free set, estimates, covariance, recovery), which a
/// campaign builds every trial, name their parameters without allocating. It reads as the
/// `str` it holds (`Deref`, `Display`, comparisons with `str` and `String`) and is written
/// and read as a JSON string.
///
/// The names interned are those of the layouts built and the names read from files (each
/// distinct one is kept for the life of the process): a few hundred in any command; a
/// long-lived process reading many files with ever new names would keep them all.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParamName(&'static str);

impl ParamName {
    /// The interned name equal to `name`. Each thread looks in its own copy of the names
    /// it has seen first, so threads that build layouts every trial (an extended
    /// identification's truth) do not contend for the process-wide set's lock.
    pub fn new(name: &str) -> ParamName {
        use std::cell::RefCell;
        use std::collections::HashSet;
        use std::sync::{Mutex, OnceLock};
        static NAMES: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
        thread_local! {
            static SEEN: RefCell<HashSet<&'static str>> = RefCell::new(HashSet::new());
        }
        // (`try_with`: a thread whose thread-locals are being torn down uses the global set.)
        if let Ok(Some(seen)) = SEEN.try_with(|s| s.borrow().get(name).copied()) {
            return ParamName(seen);
        }
        let interned = {
            let mut names = NAMES
                .get_or_init(Default::default)
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            match names.get(name) {
                Some(&interned) => interned,
                None => {
                    let interned: &'static str = Box::leak(name.to_owned().into_boxed_str());
                    names.insert(interned);
                    interned
                }
            }
        };
        let _ = SEEN.try_with(|s| s.borrow_mut().insert(interned));
        ParamName(interned)
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        self.0
    }
}

impl std::ops::Deref for ParamName {
    type Target = str;
    fn deref(&self) -> &str {
        self.0
    }
}

impl AsRef<str> for ParamName {
    fn as_ref(&self) -> &str {
        self.0
    }
}

impl std::borrow::Borrow<str> for ParamName {
    fn borrow(&self) -> &str {
        self.0
    }
}

impl std::fmt::Display for ParamName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl std::fmt::Debug for ParamName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self.0, f)
    }
}

impl From<&str> for ParamName {
    fn from(name: &str) -> ParamName {
        ParamName::new(name)
    }
}

impl From<ParamName> for String {
    fn from(name: ParamName) -> String {
        name.0.to_string()
    }
}

impl PartialEq<str> for ParamName {
    fn eq(&self, other: &str) -> bool {
        self.0 == other
    }
}

impl PartialEq<&str> for ParamName {
    fn eq(&self, other: &&str) -> bool {
        self.0 == *other
    }
}

impl PartialEq<String> for ParamName {
    fn eq(&self, other: &String) -> bool {
        self.0 == other
    }
}

impl PartialEq<ParamName> for str {
    fn eq(&self, other: &ParamName) -> bool {
        self == other.0
    }
}

impl PartialEq<ParamName> for &str {
    fn eq(&self, other: &ParamName) -> bool {
        *self == other.0
    }
}

impl PartialEq<ParamName> for String {
    fn eq(&self, other: &ParamName) -> bool {
        self == other.0
    }
}

impl Serialize for ParamName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

impl<'de> Deserialize<'de> for ParamName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<ParamName, D::Error> {
        let name = std::borrow::Cow::<'de, str>::deserialize(d)?;
        Ok(ParamName::new(&name))
    }
}

/// One entry of the parameter vector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamInfo {
    /// Stable name used in every output (`theta1`, `beta2`, `base_dz`, `tool_x`, …).
    pub name: ParamName,
    /// What it is.
    pub kind: ParamKind,
    /// Its interface unit.
    pub unit: Unit,
}

impl ParamInfo {
    fn new(kind: ParamKind) -> Self {
        let (name, unit) = match kind {
            ParamKind::Theta(i) => (format!("theta{}", i + 1), Unit::Deg),
            ParamKind::D(i) => (format!("d{}", i + 1), Unit::Mm),
            ParamKind::A(i) => (format!("a{}", i + 1), Unit::Mm),
            ParamKind::Alpha(i) => (format!("alpha{}", i + 1), Unit::Deg),
            ParamKind::Beta(i) => (format!("beta{}", i + 1), Unit::Deg),
            ParamKind::Scale(i) => (format!("scale{}", i + 1), Unit::MmPerMm),
            ParamKind::BaseRx => ("base_rx".into(), Unit::Deg),
            ParamKind::BaseRy => ("base_ry".into(), Unit::Deg),
            ParamKind::BaseRz => ("base_rz".into(), Unit::Deg),
            ParamKind::BaseDx => ("base_dx".into(), Unit::Mm),
            ParamKind::BaseDy => ("base_dy".into(), Unit::Mm),
            ParamKind::BaseDz => ("base_dz".into(), Unit::Mm),
            ParamKind::ToolX => ("tool_x".into(), Unit::Mm),
            ParamKind::ToolY => ("tool_y".into(), Unit::Mm),
            ParamKind::ToolZ => ("tool_z".into(), Unit::Mm),
            ParamKind::Extended(e) => (e.name(), e.unit()),
        };
        ParamInfo {
            name: ParamName::new(&name),
            kind,
            unit,
        }
    }

    /// Internal value (rad or mm) → interface value (deg or mm).
    pub fn to_display(&self, internal: f64) -> f64 {
        match (self.unit, self.kind) {
            (Unit::Deg, _) => internal.to_degrees(),
            (_, ParamKind::Extended(e)) => e.to_display(internal),
            _ => internal,
        }
    }

    /// Interface value (deg or mm) → internal value (rad or mm).
    pub fn from_display(&self, display: f64) -> f64 {
        match (self.unit, self.kind) {
            (Unit::Deg, _) => display.to_radians(),
            (_, ParamKind::Extended(e)) => e.from_display(display),
            _ => display,
        }
    }
}

/// The ordered parameter vector of one robot. Cloning it is cheap (the entries are shared),
/// which matters because every [`crate::Robot`] carries one and solvers clone robots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "LayoutRepr", into = "LayoutRepr")]
pub struct ParamLayout {
    params: Arc<[ParamInfo]>,
    n_joints: usize,
}

/// The serialised form of [`ParamLayout`] (the fields as they are).
#[derive(Serialize, Deserialize)]
struct LayoutRepr {
    params: Vec<ParamInfo>,
    n_joints: usize,
}

impl From<LayoutRepr> for ParamLayout {
    fn from(r: LayoutRepr) -> Self {
        ParamLayout {
            params: r.params.into(),
            n_joints: r.n_joints,
        }
    }
}

impl From<ParamLayout> for LayoutRepr {
    fn from(l: ParamLayout) -> Self {
        LayoutRepr {
            params: l.params.to_vec(),
            n_joints: l.n_joints,
        }
    }
}

impl ParamLayout {
    /// The layout for a revolute chain with the given nominal twists α_i (degrees).
    pub fn new(alpha_deg: &[f64]) -> Self {
        Self::for_chain(alpha_deg, &vec![false; alpha_deg.len()])
    }

    /// The layout for a chain with the given nominal twists α_i (degrees) and joint types
    /// (`prismatic[i]`): a prismatic joint adds `scale<i>` after the β parameters
    /// (`docs/model.md` §3); a revolute chain's layout is [`ParamLayout::new`]'s.
    pub fn for_chain(alpha_deg: &[f64], prismatic: &[bool]) -> Self {
        assert_eq!(alpha_deg.len(), prismatic.len(), "one joint type per joint");
        let n = alpha_deg.len();
        let mut params = Vec::with_capacity(4 * n + n + 9);
        for i in 0..n {
            for kind in [
                ParamKind::Theta(i),
                ParamKind::D(i),
                ParamKind::A(i),
                ParamKind::Alpha(i),
            ] {
                params.push(ParamInfo::new(kind));
            }
        }
        for (i, a) in alpha_deg.iter().enumerate().take(n.saturating_sub(1)) {
            if a.abs() < BETA_ALPHA_TOL_DEG {
                params.push(ParamInfo::new(ParamKind::Beta(i)));
            }
        }
        for (i, p) in prismatic.iter().enumerate() {
            if *p {
                params.push(ParamInfo::new(ParamKind::Scale(i)));
            }
        }
        for kind in [
            ParamKind::BaseRx,
            ParamKind::BaseRy,
            ParamKind::BaseRz,
            ParamKind::BaseDx,
            ParamKind::BaseDy,
            ParamKind::BaseDz,
            ParamKind::ToolX,
            ParamKind::ToolY,
            ParamKind::ToolZ,
        ] {
            params.push(ParamInfo::new(kind));
        }
        ParamLayout {
            params: params.into(),
            n_joints: n,
        }
    }

    /// This layout with the non-geometric parameters `kinds` appended (after the tool).
    pub fn with_extended(&self, kinds: &[ExtendedKind]) -> ParamLayout {
        let mut params: Vec<ParamInfo> = self
            .params
            .iter()
            .filter(|p| !matches!(p.kind, ParamKind::Extended(_)))
            .cloned()
            .collect();
        params.extend(
            kinds
                .iter()
                .map(|k| ParamInfo::new(ParamKind::Extended(*k))),
        );
        ParamLayout {
            params: params.into(),
            n_joints: self.n_joints,
        }
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Always false: every layout has at least the 9 base and tool parameters.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Number of joints of the chain this layout belongs to.
    pub fn n_joints(&self) -> usize {
        self.n_joints
    }

    /// All parameters in order.
    pub fn params(&self) -> &[ParamInfo] {
        &self.params
    }

    /// Parameter `k`.
    pub fn get(&self, k: usize) -> &ParamInfo {
        &self.params[k]
    }

    /// Names in order.
    pub fn names(&self) -> Vec<&str> {
        self.params.iter().map(|p| p.name.as_str()).collect()
    }

    /// Index of the parameter called `name`.
    pub fn index_of(&self, name: &str) -> Result<usize, ModelError> {
        self.params
            .iter()
            .position(|p| p.name == name)
            .ok_or_else(|| ModelError::UnknownParameter {
                name: name.to_string(),
                known: self.names().join(", "),
            })
    }

    /// Indices of the named parameters, sorted in layout order, duplicates removed.
    pub fn select<S: AsRef<str>>(&self, names: &[S]) -> Result<Vec<usize>, ModelError> {
        let mut idx = names
            .iter()
            .map(|n| self.index_of(n.as_ref().trim()))
            .collect::<Result<Vec<_>, _>>()?;
        idx.sort_unstable();
        idx.dedup();
        Ok(idx)
    }

    /// Indices of the β parameters' joints (0-based).
    pub fn beta_joints(&self) -> Vec<usize> {
        self.params
            .iter()
            .filter_map(|p| match p.kind {
                ParamKind::Beta(i) => Some(i),
                _ => None,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal names are one interned string (the same pointer, however they were made);
    /// a name compares with `str` and `String` both ways, prints as its text, is written
    /// as a JSON string and read back interned.
    #[test]
    fn parameter_names_are_interned_strings() {
        let layout_name = ParamInfo::new(ParamKind::Theta(1)).name;
        let made = ParamName::new(&String::from("theta2"));
        assert_eq!(layout_name, made);
        assert!(std::ptr::eq(layout_name.as_str(), made.as_str()));
        assert!(!std::ptr::eq(
            ParamName::new("theta3").as_str(),
            made.as_str()
        ));
        let (text, owned) = ("theta2", String::from("theta2"));
        assert_eq!(made, text);
        assert_eq!(text, made);
        assert_eq!(made, owned);
        assert_eq!(owned, made);
        assert_ne!(made, "theta3");
        assert_eq!(format!("{made} {made:?}"), "theta2 \"theta2\"");
        let json = serde_json::to_string(&vec![made, ParamName::new("base_dz")]).unwrap();
        assert_eq!(json, r#"["theta2","base_dz"]"#);
        let back: Vec<ParamName> = serde_json::from_str(&json).unwrap();
        assert!(std::ptr::eq(back[0].as_str(), made.as_str()));
        assert_eq!(back.join(","), "theta2,base_dz");
        // Another thread finds the same string.
        let there = std::thread::spawn(|| ParamName::new("theta2").as_str().as_ptr() as usize)
            .join()
            .unwrap();
        assert_eq!(there, made.as_str().as_ptr() as usize);
    }
}
