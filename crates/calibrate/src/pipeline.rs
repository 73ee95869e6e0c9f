//! The one calibration pipeline, for every kind of measurement ([`MeasurementKind`]):
//!
//! ```text
//! check the request → split (rows, or poses) → plausibility of the data (joint units,
//! length units, handedness) → register, choose the free set, fit → screen outliers (refit
//! without them on request, to a fixed point) → check the result (parameters) → validate
//! (and check it) → a crate::Calibration
//! ```
//!
//! Each stage is written here once. What depends on the kind of measurement — how the data
//! of a pass are held, the points registration uses, the free set, the fit and the outlier
//! screen's blocks — is a [`Kind`]: points in `crate::workflow`, 6-DoF and multi-target
//! data in `crate::tool_frame`.

use identify::{RegistrationPolicy, RegistrationReport, mean_point_error, register_base_robust};
use kinematics::Robot;
use measurements::{Measurement, MeasurementError, MeasurementSet};
use nalgebra::Vector3;

use crate::checks;
use crate::error::{CalibrateError, Refusal, Result, id_err};
use crate::files::LoadedRobot;
use crate::request::{Check, IdentifyRequest, Split};

/// What the data measure at each pose: the kind of measurement a calibration fits. The
/// library chooses it from the data ([`MeasurementKind::of`]); every kind goes through the
/// same pipeline and gives the same outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeasurementKind {
    /// One point per pose (`x,y,z`): the tool point's position.
    Points,
    /// The tool frame per pose: its orientation (`qw,qx,qy,qz`, or `rx,ry,rz` with an Euler
    /// convention) with the point of each of `targets` targets (1: the tool point).
    SixDof {
        /// Targets per pose (1 without a `target` column).
        targets: usize,
    },
    /// The points of several targets per pose (`id,target` columns), without orientation.
    Targets {
        /// Targets per pose.
        targets: usize,
    },
}

impl MeasurementKind {
    /// The kind of the data `set`: [`MeasurementKind::SixDof`] when every row has an
    /// orientation, [`MeasurementKind::Targets`] when rows name targets, else (and with
    /// `points_only`, which ignores orientations and targets) [`MeasurementKind::Points`].
    pub fn of(set: &MeasurementSet, points_only: bool) -> MeasurementKind {
        let targets = set.targets().len().max(1);
        if points_only {
            MeasurementKind::Points
        } else if set.has_orientation() {
            MeasurementKind::SixDof { targets }
        } else if set.has_targets() {
            MeasurementKind::Targets { targets }
        } else {
            MeasurementKind::Points
        }
    }

    /// Whether it is [`MeasurementKind::Points`].
    pub fn is_points(self) -> bool {
        self == MeasurementKind::Points
    }

    /// The unit the split and the outlier screen take or drop whole: `row` for points,
    /// `pose` otherwise (a pose's block of rows).
    pub fn unit(self) -> &'static str {
        if self.is_points() { "row" } else { "pose" }
    }
}

impl std::fmt::Display for MeasurementKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            MeasurementKind::Points => f.write_str("points (one per pose)"),
            MeasurementKind::SixDof { targets: 1 } => {
                f.write_str("6-DoF (point and orientation per pose)")
            }
            MeasurementKind::SixDof { targets } => {
                write!(f, "6-DoF with {targets} targets per pose")
            }
            MeasurementKind::Targets { targets } => write!(f, "{targets} targets per pose"),
        }
    }
}

/// The validation part of a split: the units the split holds out, or another file.
pub(crate) enum Held {
    /// Units of the identification file (indices into the units).
    Rest(Vec<usize>),
    /// A validation file.
    File(MeasurementSet),
}

/// A split of the data's units (rows for points, poses otherwise).
pub(crate) struct Units {
    /// The identifying units (indices into the units, ascending).
    pub id: Vec<usize>,
    /// Validation, with where it comes from.
    pub val: Option<(String, Held)>,
    /// Which units identify, in words.
    pub text: String,
}

/// Splits `units` (each the indices into `data.rows` of its rows) as `request.split` says:
/// the same split for every kind, in the kind's words; `free` and `min_rows` for the
/// refusals of point data (each row three equations).
pub(crate) fn split(
    request: &IdentifyRequest,
    robot: &Robot,
    data: &MeasurementSet,
    validate: Option<MeasurementSet>,
    (kind, units): (MeasurementKind, &[Vec<usize>]),
    (free, min_rows): (usize, usize),
) -> Result<Units> {
    let m = units.len();
    let points = kind.is_points();
    let rows_of = |sel: &[usize]| sel.iter().map(|&u| units[u].len()).sum::<usize>();
    let other = |rest: &[usize]| {
        format!(
            "{} (the {} other {}s)",
            data.source,
            rest.len(),
            kind.unit()
        )
    };
    Ok(match request.split {
        Split::Every { every: k, offset } => {
            let (sel, rest): (Vec<usize>, Vec<usize>) = (0..m).partition(|i| i % k == offset);
            if points && sel.len() < min_rows {
                return Err(CalibrateError::TooFewRows {
                    free,
                    spec: request.params.to_string(),
                    needed: min_rows,
                    source: Box::new(
                        Refusal::EveryTooFew {
                            every: k,
                            offset,
                            selected: sel.len(),
                            rows: m,
                            source: Box::new(MeasurementError::TooFewRows {
                                file: data.source.clone(),
                                found: sel.len(),
                                needed: min_rows,
                            }),
                        }
                        .into(),
                    ),
                });
            }
            let text = if points {
                format!(
                    "{} of {m} rows (data rows {offset}, {}, {}, … — every {k}th from \
                     {offset})",
                    sel.len(),
                    offset + k,
                    offset + 2 * k,
                )
            } else {
                format!(
                    "{} of {m} poses (every {k}th from {offset}; {} rows)",
                    sel.len(),
                    rows_of(&sel)
                )
            };
            let val = (!rest.is_empty()).then(|| (other(&rest), Held::Rest(rest)));
            Units { id: sel, val, text }
        }
        Split::Select { poses, criterion } => {
            if points && poses < min_rows {
                return Err(Refusal::SelectTooFew {
                    poses,
                    free,
                    spec: request.params.to_string(),
                    needed: min_rows,
                }
                .into());
            }
            if poses >= m {
                return Err(Refusal::SelectTooMany {
                    poses,
                    file: data.source.clone(),
                    rows: m,
                }
                .into());
            }
            // The design scores each pose by what it measures: a 6-DoF frame's rows when the
            // data carry orientations, the robot file's targets when the data name several
            // targets and the robot file gives their points, else the tool point's rows (the
            // targets' points are then unknown before the fit).
            let measure = match kind {
                MeasurementKind::SixDof { .. } => design::Measure::Frame,
                MeasurementKind::Targets { targets }
                    if targets > 1 && robot.targets().is_some_and(|t| !t.is_empty()) =>
                {
                    design::Measure::Targets
                }
                _ => design::Measure::Point,
            };
            let q_deg: Vec<f64> = units
                .iter()
                .flat_map(|u| data.rows[u[0]].q_deg.iter().copied())
                .collect();
            let chosen =
                design::select_rows_measuring(robot, &q_deg, poses, criterion, None, measure)
                    .map_err(|source| CalibrateError::Design {
                        context: format!(
                            "choosing {poses} {}s of {} by the {} criterion",
                            kind.unit(),
                            data.source,
                            criterion.as_str()
                        ),
                        source: Box::new(source),
                    })?;
            let rest: Vec<usize> = (0..m)
                .filter(|i| chosen.binary_search(i).is_err())
                .collect();
            let lines: Vec<String> = chosen
                .iter()
                .take(3)
                .map(|&u| data.rows[units[u][0]].line.to_string())
                .collect();
            let text = if points {
                format!(
                    "{} of {m} rows chosen by the {} criterion on their joints (lines {}, …)",
                    chosen.len(),
                    criterion.as_str().to_uppercase(),
                    lines.join(", "),
                )
            } else {
                format!(
                    "{} of {m} poses chosen by the {} criterion on their {} information \
                     (lines {}, …; {} rows)",
                    chosen.len(),
                    criterion.as_str().to_uppercase(),
                    measure,
                    lines.join(", "),
                    rows_of(&chosen)
                )
            };
            let val = Some((other(&rest), Held::Rest(rest)));
            Units {
                id: chosen,
                val,
                text,
            }
        }
        Split::All => Units {
            id: (0..m).collect(),
            val: validate.map(|v| (v.source.clone(), Held::File(v))),
            text: format!("all {m} {}s", kind.unit()),
        },
    })
}

/// The rows of `units` `sel` of `data`, in unit order.
pub(crate) fn rows_of(
    data: &MeasurementSet,
    units: &[Vec<usize>],
    sel: &[usize],
) -> Vec<Measurement> {
    sel.iter()
        .flat_map(|&u| units[u].iter().map(|&i| data.rows[i].clone()))
        .collect()
}

/// The plausibility checks of the identification rows, before any fit, for every kind:
/// joint units, length units and handedness (each unless the request allows it).
pub(crate) fn check_data(
    request: &IdentifyRequest,
    source: &str,
    nominal: &Robot,
    limits_deg: &[Option<[f64; 2]>],
    rows: &[Measurement],
) -> Result<()> {
    if !request.allows(Check::JointUnits) {
        checks::joint_units(source, rows, limits_deg)?;
    }
    if !request.allows(Check::LengthUnits) {
        checks::length_units(source, nominal, rows)?;
    }
    if !request.allows(Check::Mirror) {
        checks::mirror(source, nominal, rows)?;
    }
    Ok(())
}

/// Rows of `val` equal to a row of `id` (joints and point bit for bit).
pub(crate) fn overlapping(id: &[Measurement], val: &[Measurement]) -> usize {
    let key = |r: &Measurement| {
        let mut k: Vec<u64> = r.q_deg.iter().map(|v| v.to_bits()).collect();
        if let Some(p) = r.point_mm {
            k.extend(p.iter().map(|v| v.to_bits()));
        }
        k
    };
    let ids: std::collections::BTreeSet<Vec<u64>> = id.iter().map(key).collect();
    val.iter().filter(|r| ids.contains(&key(r))).count()
}

/// The stages of the pipeline that depend on the kind of measurement.
pub(crate) trait Kind {
    /// The unit the split and the screen take or drop whole ([`MeasurementKind::unit`]).
    const UNIT: &'static str;
    /// The identification data of a pass.
    type Data;
    /// One registration and fit.
    type Pass: Clone;
    /// An outlier screen of the identification units.
    type Screen;
    /// The analysis of the final fit (what the parameters check and the report need).
    type Analysis;
    /// Validation data.
    type Held;
    /// A validation.
    type Validation;

    /// The units `keep` of `data`.
    fn subset(&self, data: &Self::Data, keep: &[usize]) -> Self::Data;
    /// Units of `data`.
    fn units(&self, data: &Self::Data) -> usize;
    /// One pass on `data`: register, choose the free set at the registered start, fit.
    fn pass(&self, data: &Self::Data) -> Result<Self::Pass>;
    /// The outlier screen at factor `k` of every unit of `data` after the fit of `pass`
    /// (`None` without residual degrees of freedom).
    fn screen(&self, pass: &Self::Pass, data: &Self::Data, k: f64) -> Result<Option<Self::Screen>>;
    /// Every unit's block `(norm of its residual rows, rows)` at the fit of `pass` (the units
    /// of [`identify::outliers::screen_blocks`]).
    fn norms(&self, pass: &Self::Pass, data: &Self::Data) -> Vec<(f64, usize)>;
    /// The same at the start model of `pass` (the registered nominal, before the fit).
    fn start_norms(&self, pass: &Self::Pass, data: &Self::Data) -> Vec<(f64, usize)>;
    /// The fit's classical per-row scale σ̂ (`None` without degrees of freedom).
    fn sigma_row(pass: &Self::Pass) -> Option<f64>;
    /// The units the screen flags, ascending.
    fn flagged(screen: &Self::Screen) -> Vec<usize>;
    /// The free unknowns of a pass.
    fn n_free(pass: &Self::Pass) -> usize;
    /// Whether `data` give at least `n_free` equations.
    fn determines(&self, data: &Self::Data, n_free: usize) -> bool;
    /// The registration decision of a pass, in words.
    fn decision(pass: &mut Self::Pass) -> &mut String;
    /// The analysis of the final pass on the units used.
    fn analyse(&self, pass: &Self::Pass, used: &Self::Data) -> Result<Self::Analysis>;
    /// The parameters check's evidence: the start model, the identified one, and the
    /// identifiable parameters (layout indices).
    fn moved<'a>(
        pass: &'a Self::Pass,
        analysis: &'a Self::Analysis,
    ) -> (&'a Robot, &'a Robot, &'a [usize]);
    /// The parameters check ([`checks::parameters`] on [`Kind::moved`]); a kind with more
    /// evidence (what its poses determine) refines the refusal's wording.
    fn check_parameters(&self, pass: &Self::Pass, analysis: &Self::Analysis) -> Result<()> {
        let (start, identified, identifiable) = Self::moved(pass, analysis);
        checks::parameters(start, identified, identifiable)?;
        Ok(())
    }
    /// Validation of the final pass on `held`.
    fn validate(
        &self,
        pass: &Self::Pass,
        source: String,
        held: Self::Held,
    ) -> Result<Self::Validation>;
    /// The validation check's evidence: the source and the mean position error (mm) of the
    /// start model and of the identified one.
    fn validated(v: &Self::Validation) -> (&str, f64, f64);
}

/// Passes of outlier rejection at most [10: each pass drops what the fit on the others
/// flags; a clean recording needs one or two].
pub const MAX_REJECTION_PASSES: usize = 10;

/// Concentration steps of the robust start at most, per start [10: each step refits on the
/// units the last fit fits best and cannot raise the trimmed objective; a few suffice].
pub const MAX_CONCENTRATION_STEPS: usize = 10;

/// The robust start of the outlier screen (`docs/calibrating-real-data.md`, "Robust
/// screening"): least trimmed squares on `h` of the units, then the robust scale.
#[derive(Clone, Debug, PartialEq)]
pub struct RobustScreen {
    /// Units screened.
    pub units: usize,
    /// Units of the trimmed fit, `⌊m/2⌋ + 1` (`m` when half does not determine the fit).
    pub h: usize,
    /// The start the trimmed fit came from: `registered nominal` or `fit on every <unit>`.
    pub start: String,
    /// Concentration steps taken from it.
    pub steps: usize,
    /// The robust per-row scale σ̃ at the trimmed fit over every unit (mm per axis for
    /// points; weighted units for 6-DoF and multi-target data).
    pub sigma_robust_row: f64,
    /// The classical σ̂ of the first fit (on every unit), same units.
    pub sigma_first_row: f64,
    /// The factor of the rejection cut (`max(G, k)` by default, k with `reject_outliers`).
    pub cut_k: f64,
    /// The units excluded from the final fit (indices into the screened units, ascending).
    pub excluded: Vec<usize>,
}

/// What the pipeline gives a kind to assemble its calibration from.
pub(crate) struct Outcome<K: Kind> {
    /// The first pass (on every unit, before outlier rejection).
    pub first: K::Pass,
    /// The final pass.
    pub last: K::Pass,
    /// The outlier screen (at k) of every identification unit after the final fit.
    pub screen: Option<K::Screen>,
    /// The identification data of the final fit.
    pub used: K::Data,
    /// Whether units were dropped and the model refitted.
    pub rejected: bool,
    /// The robust screen (`None` with `keep_outliers`).
    pub robust: Option<RobustScreen>,
    /// The analysis of the final fit.
    pub analysis: K::Analysis,
    /// The validation, if any.
    pub validation: Option<K::Validation>,
}

/// Every unit's block `(norm, rows)` at one fit.
type Blocks = Vec<(f64, usize)>;

/// The units of `0..n` not in `drop` (ascending).
fn complement(n: usize, drop: &[usize]) -> Vec<usize> {
    (0..n).filter(|i| drop.binary_search(i).is_err()).collect()
}

/// The robust start: least trimmed squares by concentration steps from two deterministic
/// starts — the `h` units the registered nominal fits best (the registration itself is a
/// least-trimmed-squares fit, so this start does not see the outliers), and the `h` units the
/// least-squares fit on every unit fits best — each refitted on its `h` units until they no
/// longer change; the one with the smaller trimmed objective `Σ_h (‖e_b‖/m_d)²` is kept
/// (ties: the first). Returns `None` when `h` units do not determine the fit.
fn trimmed_start<K: Kind>(
    kind: &K,
    id: &K::Data,
    first: &K::Pass,
) -> Result<Option<(Blocks, RobustScreen)>> {
    use identify::outliers::{smallest, trimmed_cost};
    let n = kind.units(id);
    let h = n / 2 + 1;
    let starts = [
        (
            "registered nominal".to_string(),
            kind.start_norms(first, id),
        ),
        (format!("fit on every {}", K::UNIT), kind.norms(first, id)),
    ];
    let mut best: Option<(f64, Blocks, String, usize)> = None;
    let mut tried: Vec<Vec<usize>> = Vec::new();
    for (name, norms0) in starts {
        let mut sel = smallest(&norms0, h);
        if tried.contains(&sel) {
            continue;
        }
        tried.push(sel.clone());
        let rows = kind.subset(id, &sel);
        if !kind.determines(&rows, K::n_free(first)) {
            return Ok(None);
        }
        let context = || {
            format!(
                "the robust outlier screen's trimmed fit on {h} of {n} {}s",
                K::UNIT
            )
        };
        let mut pass = kind.pass(&rows).map_err(|e| e.context(context()))?;
        let mut norms = kind.norms(&pass, id);
        let mut steps = 1;
        while steps < MAX_CONCENTRATION_STEPS {
            let next = smallest(&norms, h);
            if next == sel {
                break;
            }
            sel = next;
            pass = kind
                .pass(&kind.subset(id, &sel))
                .map_err(|e| e.context(context()))?;
            norms = kind.norms(&pass, id);
            steps += 1;
        }
        let cost = trimmed_cost(&norms, &smallest(&norms, h));
        if best.as_ref().is_none_or(|b| cost < b.0) {
            best = Some((cost, norms, name, steps));
        }
    }
    Ok(best.map(|(_, norms, start, steps)| {
        let robust = RobustScreen {
            units: n,
            h,
            start,
            steps,
            sigma_robust_row: identify::outliers::robust_sigma_row(&norms),
            sigma_first_row: K::sigma_row(first).unwrap_or(f64::NAN),
            cut_k: f64::NAN,
            excluded: Vec::new(),
        };
        (norms, robust)
    }))
}

/// Fits `id` (the identification data of `source`), screens outliers robustly and rejects
/// them to a fixed point (the gross ones by default, every flagged one with
/// `reject_outliers`, none with `keep_outliers`), checks the result and validates on `val`:
/// the stages after the split, for every kind.
///
/// The screen (`docs/calibrating-real-data.md`, "Robust screening"): a least-trimmed-squares
/// fit on `h = ⌊m/2⌋ + 1` of the `m` units ([`trimmed_start`]); the robust scale σ̃ of its
/// residuals over every unit ([`identify::outliers::robust_sigma_row`]); the units within
/// `c·√d·σ̃` (c the cut: `max(G, k)` or k) kept and refitted; then, with the classical σ̂ of
/// the fit on the units kept, every unit screened again at `c·√d·σ̂` and the fit redone on
/// those it passes, to a fixed point. When nothing is beyond the cut the final fit is the
/// first one, bit for bit.
pub(crate) fn fit_and_check<K: Kind>(
    kind: &K,
    request: &IdentifyRequest,
    source: &str,
    id: &K::Data,
    val: Option<(String, K::Held)>,
) -> Result<Outcome<K>> {
    let n = kind.units(id);
    let all: Vec<usize> = (0..n).collect();
    let first = kind.pass(id)?;
    let cut = request.outlier_mode().cut(request.outlier_k);
    let mut current = first.clone();
    let mut kept = all.clone();
    let mut robust = None;
    if let Some(cut) = cut
        && K::sigma_row(&first).is_some()
    {
        if let Some((norms, mut r)) = trimmed_start(kind, id, &first)? {
            r.cut_k = cut;
            let start: Vec<usize> = norms
                .iter()
                .enumerate()
                .filter(|&(_, &(norm, rows))| {
                    norm <= identify::outliers::block_threshold(cut, r.sigma_robust_row, rows).1
                })
                .map(|(i, _)| i)
                .collect();
            if start != all {
                let rows = kind.subset(id, &start);
                if kind.determines(&rows, K::n_free(&first)) {
                    kept = start;
                    current = kind
                        .pass(&rows)
                        .map_err(|e| e.context("refitting without the outliers"))?;
                }
            }
            robust = Some(r);
        }
        // Rejection to a fixed point, with the classical σ̂ of the fit on the units kept:
        // every unit is screened against that fit until the units kept are those the
        // screen passes (so that the result with a rejected unit is the result without it);
        // registration is redone each time.
        let mut passes = 0;
        loop {
            let screen = kind.screen(&current, id, cut)?;
            let flagged = screen.as_ref().map_or_else(Vec::new, K::flagged);
            let next = complement(n, &flagged);
            if next == kept || passes == MAX_REJECTION_PASSES {
                break;
            }
            let rows = kind.subset(id, &next);
            let free = K::n_free(&current);
            if !kind.determines(&rows, free) {
                return Err(Refusal::TooManyOutliers {
                    file: source.to_string(),
                    outliers: flagged.len(),
                    rows: n,
                    kept: next.len(),
                    free,
                }
                .into());
            }
            passes += 1;
            current = if next == all {
                first.clone()
            } else {
                kind.pass(&rows)
                    .map_err(|e| e.context("refitting without the outliers"))?
            };
            kept = next;
        }
    }
    let excluded: Vec<usize> = (0..n).filter(|i| kept.binary_search(i).is_err()).collect();
    let rejected = !excluded.is_empty();
    if let (Some(cut), Some(r)) = (cut, robust.as_mut()) {
        r.excluded = excluded.clone();
        if !request.allows(Check::Outliers) {
            checks::rejected_fraction(source, excluded.len(), (n, K::UNIT), cut)?;
            let kept_norms: Vec<(f64, usize)> = {
                let norms = kind.norms(&current, id);
                kept.iter().map(|&i| norms[i]).collect()
            };
            if let Some(sigma) = K::sigma_row(&current) {
                checks::scale_agreement(
                    source,
                    sigma,
                    identify::outliers::robust_sigma_row(&kept_norms),
                    K::UNIT,
                )?;
            }
        }
    }
    let screen = kind.screen(&current, id, request.outlier_k)?;
    let used = kind.subset(id, &kept);
    if rejected {
        let first_decision = K::decision(&mut first.clone()).clone();
        let decision = K::decision(&mut current);
        *decision = format!(
            "{decision} — decided on the {} {}s kept after rejecting the outliers (on all {n} \
             {}s: {first_decision})",
            kept.len(),
            K::UNIT,
            K::UNIT,
        );
    }
    let analysis = kind.analyse(&current, &used)?;
    // A scale of the measurements moves every length in proportion: named as such before the
    // parameters check blames the robot file (`crate::scale`).
    if !request.allows(Check::Scale) {
        let (start, identified, identifiable) = K::moved(&current, &analysis);
        crate::scale::check(source, start, identified, identifiable)?;
    }
    if !request.allows(Check::Parameters) {
        kind.check_parameters(&current, &analysis)?;
    }
    let validation = val
        .map(|(source, held)| kind.validate(&current, source, held))
        .transpose()?;
    if let Some(v) = &validation
        && !request.allows(Check::Validation)
    {
        let (source, before, after) = K::validated(v);
        checks::validation(source, before, after)?;
    }
    Ok(Outcome {
        first,
        last: current,
        screen,
        used,
        rejected,
        robust,
        analysis,
        validation,
    })
}

/// The mean and the largest of `v` (0 and 0 for an empty slice).
pub fn mean_max(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v.iter().copied().fold(0.0, f64::max))
}

/// The registration decision with its evidence: the start model, the report (`None` when
/// never considered) and a sentence saying what was decided and why. For every kind: the
/// points are those of the rows (the mean of a pose's targets for multi-target data).
pub(crate) fn register(
    nominal: &Robot,
    poses: &[f64],
    points: &[Vector3<f64>],
    policy: RegistrationPolicy,
) -> Result<(Robot, Option<RegistrationReport>, String)> {
    let before = mean_point_error(nominal, poses, points);
    let threshold = match policy {
        RegistrationPolicy::Never => {
            return Ok((
                nominal.clone(),
                None,
                format!(
                    "not registered (registration never): nominal mean error {before:.3} mm \
                     in the robot's base frame"
                ),
            ));
        }
        RegistrationPolicy::Always => None,
        RegistrationPolicy::Auto { threshold_mm } => Some(threshold_mm),
    };
    if let Some(t) = threshold
        && before.partial_cmp(&t) != Some(std::cmp::Ordering::Greater)
    {
        return Ok((
            nominal.clone(),
            Some(not_registered(nominal, before)),
            format!(
                "not registered: nominal mean error {before:.3} mm ≤ {t} mm, the data are taken \
                 to be in the robot's base frame (the fit refines the base)"
            ),
        ));
    }
    let robust =
        register_base_robust(nominal, poses, points).map_err(id_err("registering the base"))?;
    let (robust, tool_note) = crate::tool_offset::prefer(nominal, poses, points, robust);
    let n = points.len();
    let mut evidence = format!(
        "rigid fit on {} of {n} points (the others beyond {} × the median residual), median \
         error {:.3} mm → {:.3} mm, mean {before:.3} mm → {:.3} mm",
        robust.inliers.len(),
        identify::ROBUST_INLIER_FACTOR,
        robust.median_before_mm,
        robust.median_after_mm,
        robust.report.mean_error_after_mm
    );
    if let Some(note) = tool_note {
        evidence = format!("{evidence}; {note}");
    }
    let better = robust.median_after_mm < robust.median_before_mm;
    match threshold {
        Some(t) if !better => Ok((
            nominal.clone(),
            Some(not_registered(nominal, before)),
            format!(
                "not registered: nominal mean error {before:.3} mm > {t} mm, but the \
                 registration would make it worse ({evidence})"
            ),
        )),
        Some(t) => Ok((
            robust.robot,
            Some(robust.report),
            format!(
                "registered (nominal mean error {before:.3} mm > {t} mm: the data are in \
                 another frame): {evidence}; the base is refitted with the other parameters"
            ),
        )),
        None => Ok((
            robust.robot,
            Some(robust.report),
            format!("registered (registration always): {evidence}"),
        )),
    }
}

/// A report for "not registered" at a start error of `before` mm.
fn not_registered(nominal: &Robot, before: f64) -> RegistrationReport {
    let layout = nominal.layout();
    let x = nominal.params();
    let b = identify::base_parameter_indices(nominal).map(|k| layout.get(k).to_display(x[k]));
    RegistrationReport {
        applied: false,
        mean_error_before_mm: before,
        mean_error_after_mm: before,
        rotation_deg: 0.0,
        translation_mm: [0.0; 3],
        base_before: b,
        base_after: b,
    }
}

/// What every kind's calibration starts from after the split and the data's checks.
pub(crate) struct Common<'a> {
    pub request: &'a IdentifyRequest,
    /// The nominal, extended by the request's parameters.
    pub nominal: LoadedRobot,
    pub data: MeasurementSet,
    /// The units (rows or poses) of `data`, each as the indices of its rows.
    pub units: Vec<Vec<usize>>,
    pub split: Units,
    pub kind: MeasurementKind,
    pub notices: Vec<String>,
    /// The warning that validation rows are identification rows, if they are.
    pub overlap_warning: Option<String>,
}
