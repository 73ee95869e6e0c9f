//! Plausibility checks of a calibration: well-formed data or results that a careful engineer
//! would not accept. Each check looks at one piece of evidence, refuses with
//! [`Refusal::Implausible`] naming it and the [`Check`] that overrides it, and runs before
//! anything is written (`docs/calibrating-real-data.md`, "Checks").

use identify::proper_and_improper_rms;
use kinematics::Robot;
use measurements::Measurement;
use nalgebra::Vector3;

use crate::error::Refusal;
use crate::files::{points_mm, poses_rad};
use crate::request::{Check, IdentifyRequest, JointUnits, LengthUnits, Setting};
use measurements::number;

/// Smallest outlier factor k accepted [2: the cut k·σ̂₃ = 2·√3·σ already flags one clean
/// Gaussian point in 135 (P(χ²₃ > 12) = 0.0074); below 2 the screen rejects good data, not
/// gross errors (k = 0.5 flags 80 % of it)].
pub const MIN_OUTLIER_K: f64 = 2.0;

/// Largest share of the identification units (rows, or poses) outlier rejection may remove
/// [0.35: the robust screen separates gross errors up to its breakdown point (50 % for the
/// least-trimmed-squares start on half the units and the median scale; `identify::outliers`),
/// and finds every one of 30 % gross errors on the UR10 example; beyond a third of a
/// recording being wrong, the recording (units, frame, robot, a loose target) is suspect
/// rather than a few readings, and the rows left may be the wrong "majority"].
pub const MAX_REJECTED_FRACTION: f64 = 0.35;

/// Largest ratio of the classical per-row scale σ̂ of the final fit (on the units kept) to its
/// robust scale σ̃ (median of the scaled norms of the same units) [2: on clean Gaussian
/// residuals the two agree within a few per cent (σ̂ carries the degrees-of-freedom
/// correction, σ̃ not: ≈ 1.05 on the UR10 example); a ratio of 2 means that the units kept
/// still hold errors far outside their noise, which the screen could not separate].
pub const MAX_SCALE_RATIO: f64 = 2.0;

/// Measured spread over the nominal spread accepted, `[1/1.25, 1.25]` [geometric errors of a
/// real robot are millimetres on a workspace of hundreds: a spread off by 25 % is a unit
/// (metres ×0.001, centimetres ×0.1, inches ×0.039) or a different robot].
pub const SPREAD_RATIO_MAX: f64 = 1.25;

/// Spread below which the length check says nothing, mm, when both the nominal and the
/// measured points spread less [50: poses that barely move the point carry no scale
/// evidence].
pub const MIN_SPREAD_MM: f64 = 50.0;

/// The mirror check refuses when the best improper rigid fit's RMS is below the proper one's
/// divided by this [3: a right-handed frame fits a reflection at hundreds of mm, a rotation
/// at the robot's millimetres; a swapped or negated axis does the opposite].
pub const MIRROR_RATIO: f64 = 3.0;

/// Proper RMS below which the mirror check says nothing, mm [10: a rotation that fits to
/// 10 mm is no mirrored frame].
pub const MIRROR_MIN_RMS_MM: f64 = 10.0;

pub use crate::tolerance::{
    MAX_ANGLE_CHANGE_DEG, MAX_LINK_CHANGE_MM, MAX_SCALE_CHANGE, MAX_TOOL_CHANGE_MM, tolerance,
};

pub(crate) fn refuse(check: Check, evidence: String, remedy: &str) -> Refusal {
    refuse_with(check, evidence, remedy, None)
}

/// [`refuse`] with the setting the remedy suggests, which each front end spells in its own
/// words ([`Setting::spelled`]).
pub(crate) fn refuse_with(
    check: Check,
    evidence: String,
    remedy: &str,
    setting: Option<Setting>,
) -> Refusal {
    Refusal::Implausible {
        check,
        evidence,
        remedy: remedy.to_string(),
        setting,
    }
}

/// Joint values read as degrees that look like radians: at least 3 rows, every revolute
/// |q| ≤ 2π, and a robot whose limits reach beyond ±90° on some revolute joint
/// ([`crate::radians_evidence`]; `limits_deg` is `None` for a prismatic joint).
pub fn joint_units(
    source: &str,
    rows: &[Measurement],
    limits_deg: &[Option<[f64; 2]>],
) -> Result<(), Refusal> {
    if let Some(note) = crate::files::radians_evidence(source, rows, limits_deg) {
        return Err(refuse_with(
            Check::JointUnits,
            note,
            "if the joints are in radians, declare it",
            Some(Setting::JointUnits(JointUnits::Rad)),
        ));
    }
    Ok(())
}

/// Joint values declared radians (`joint_units="rad"`) that are degrees: the file, read in
/// degrees, is within the robot's limits, and some |q| exceeds 2π — no revolute joint
/// value in radians does (one turn), while degrees data of almost any pose do. `deg_rows`
/// are the file's rows read as degrees (unconverted). Called where the declared-radians read
/// failed, typically on a joint limit (the limits in radians are ±2.6 for ±150°), so that
/// the refusal names the evidence instead of the first row beyond a limit.
/// Only the revolute joints count: `limits_deg` is `None` for a prismatic joint, whose
/// column holds a length.
pub fn declared_radians(
    source: &str,
    deg_rows: &[Measurement],
    limits_deg: &[Option<[f64; 2]>],
) -> Result<(), Refusal> {
    let largest = crate::files::largest_revolute(deg_rows, limits_deg);
    if largest > std::f64::consts::TAU {
        return Err(refuse_with(
            Check::JointUnits,
            format!(
                "{source}: the joint values are declared radians but reach |q| = {}, beyond \
                 one turn (2π = 6.2832), and read as degrees every row is within the robot's \
                 joint limits: these look like degrees",
                number(largest, 4)
            ),
            "if the joints are in degrees, declare degrees (the default)",
            Some(Setting::JointUnits(JointUnits::Deg)),
        ));
    }
    Ok(())
}

fn spread(points: &[Vector3<f64>]) -> f64 {
    let n = points.len().max(1) as f64;
    let c = points.iter().sum::<Vector3<f64>>() / n;
    (points.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / n).sqrt()
}

/// A measured spread of `ratio` times the nominal's, within `[1/SPREAD_RATIO_MAX,
/// SPREAD_RATIO_MAX]`.
fn spread_matches(ratio: f64) -> bool {
    (1.0 / SPREAD_RATIO_MAX..=SPREAD_RATIO_MAX).contains(&ratio)
}

/// The units the length check recognises by the ratio of the measured spread to the
/// nominal's (within 25 %): what the lengths look like, what to do, and the setting that
/// declares them where there is one. Points in centimetres spread a tenth of the
/// millimetres' (ratio 0.1: declare `cm`, or multiply by 10); points ten times the robot's
/// are tenths of a millimetre or a robot file in centimetres (divide by 10).
const UNIT_GUESSES: [(f64, &str, &str, Option<LengthUnits>); 5] = [
    (0.001, "metres", "declare their unit", Some(LengthUnits::M)),
    (
        0.1,
        "centimetres",
        "multiply them by 10 or declare their unit",
        Some(LengthUnits::Cm),
    ),
    (
        1.0 / 25.4,
        "inches",
        "declare their unit",
        Some(LengthUnits::In),
    ),
    (
        10.0,
        "tenths of a millimetre — or the robot file's lengths are centimetres (its a, d and \
         tool must be millimetres)",
        "divide the points by 10, or write the robot file in millimetres",
        None,
    ),
    (
        1000.0,
        "micrometres — or the robot file's lengths are metres (its a, d and tool must be \
         millimetres)",
        "divide the points by 1000, or write the robot file in millimetres",
        None,
    ),
];

/// A row is far from the others when its point lies more than this many times the median
/// row's distance from the median point [10: the points of one robot spread over its
/// workspace, a reading ten times farther out than the typical one is a wrong reading or a
/// unit slip in that row (10⁶ mm, 1e300), not a different unit of the whole file].
pub const FAR_ROW_FACTOR: f64 = 10.0;

/// Rows named at most in a refusal of far rows.
const FAR_ROWS_NAMED: usize = 5;

/// The measured points' spread (RMS distance from their centroid, independent of the frame)
/// against the nominal robot's at the same joints. A few rows far from all the others
/// (beyond [`FAR_ROW_FACTOR`] times the typical distance, fewer than half) without which the
/// spreads match are named as such (line, point, distance), not as a unit of the file.
pub fn length_units(source: &str, nominal: &Robot, rows: &[Measurement]) -> Result<(), Refusal> {
    let predicted = nominal.points(&poses_rad(rows));
    let measured = points_mm(rows);
    let (sp, sm) = (spread(&predicted), spread(&measured));
    // Scale evidence needs motion: of the nominal points, or of the measured ones (a robot
    // file in metres spreads its points over millimetres while the tracker's spread metres).
    if (sp < MIN_SPREAD_MM && sm < MIN_SPREAD_MM) || rows.len() < 3 {
        return Ok(());
    }
    let ratio = sm / sp;
    if spread_matches(ratio) {
        return Ok(());
    }
    if let Some(refusal) = far_rows(source, rows, &predicted, &measured) {
        return Err(refusal);
    }
    let (looks, remedy, setting) = UNIT_GUESSES
        .iter()
        .find(|(f, ..)| (ratio / f - 1.0).abs() < 0.25)
        .map_or(
            (
                "a different robot or unit",
                "check the robot file and convert the points to millimetres",
                None,
            ),
            |(_, looks, remedy, setting)| (looks, remedy, *setting),
        );
    Err(refuse_with(
        Check::LengthUnits,
        format!(
            "{source}: the measured points spread {} (RMS about their centroid) where the \
             nominal robot's points at the same joints spread {} mm: ratio {}, outside \
             [{:.2}, {SPREAD_RATIO_MAX}] — the lengths look like {looks}",
            number(sm, 4),
            number(sp, 1),
            number(ratio, 4),
            1.0 / SPREAD_RATIO_MAX
        ),
        remedy,
        setting.map(Setting::LengthUnits),
    ))
}

/// The refusal of rows whose points lie far from all the others ([`FAR_ROW_FACTOR`]), when
/// without them the measured spread matches the nominal one; `None` otherwise.
fn far_rows(
    source: &str,
    rows: &[Measurement],
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
) -> Option<Refusal> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let centre = Vector3::from_fn(|k, _| median(measured.iter().map(|p| p[k]).collect()));
    // hypot: a point at 1e300 mm is 1e300 mm away, not an overflow to infinity.
    let distance: Vec<f64> = measured
        .iter()
        .map(|p| {
            let d = p - centre;
            d.x.hypot(d.y).hypot(d.z)
        })
        .collect();
    let typical = median(distance.clone()).max(MIN_SPREAD_MM);
    let far: Vec<usize> = (0..rows.len())
        .filter(|&i| distance[i].is_nan() || distance[i] > FAR_ROW_FACTOR * typical)
        .collect();
    if far.is_empty() || 2 * far.len() >= rows.len() {
        return None;
    }
    let rest = |v: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
        (0..v.len())
            .filter(|i| !far.contains(i))
            .map(|i| v[i])
            .collect()
    };
    let ratio = spread(&rest(measured)) / spread(&rest(predicted));
    if !spread_matches(ratio) {
        return None;
    }
    let within = (0..rows.len())
        .filter(|i| !far.contains(i))
        .map(|i| distance[i])
        .fold(0.0_f64, f64::max);
    let named: Vec<String> = far
        .iter()
        .take(FAR_ROWS_NAMED)
        .map(|&i| {
            let p = &measured[i];
            format!(
                "{} (x, y, z = {}, {}, {} mm: {} mm from the median point)",
                crate::files::row_label(&rows[i]),
                number(p.x, 3),
                number(p.y, 3),
                number(p.z, 3),
                number(distance[i], 1)
            )
        })
        .collect();
    let more = far.len().saturating_sub(FAR_ROWS_NAMED);
    Some(refuse(
        Check::LengthUnits,
        format!(
            "{source}: {} far from all the others: {}{}; the other rows lie within {} mm of \
             the median point, and without {} the measured points spread as the nominal \
             robot's (ratio {}): a wrong reading or a unit slip in {}, not the file's unit",
            if far.len() == 1 {
                "one row lies".to_string()
            } else {
                format!("{} rows lie", far.len())
            },
            named.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            },
            number(within, 1),
            if far.len() == 1 { "it" } else { "them" },
            number(ratio, 4),
            if far.len() == 1 {
                "that row"
            } else {
                "those rows"
            },
        ),
        "correct or remove the row",
    ))
}

/// A reflection fitting the nominal points onto the measured ones far better than any
/// rotation: a left-handed frame (two axes swapped, one negated).
pub fn mirror(source: &str, nominal: &Robot, rows: &[Measurement]) -> Result<(), Refusal> {
    let predicted = nominal.points(&poses_rad(rows));
    let Ok((proper, improper)) = proper_and_improper_rms(&predicted, &points_mm(rows)) else {
        return Ok(());
    };
    if proper > MIRROR_MIN_RMS_MM && improper * MIRROR_RATIO < proper {
        return Err(refuse(
            Check::Mirror,
            format!(
                "{source}: the best rotation fits the nominal robot's points to {} mm RMS, the \
                 best reflection to {} mm: the measurement frame is left-handed (axes swapped \
                 or one negated)",
                number(proper, 1),
                number(improper, 1)
            ),
            "write the x, y, z columns of a right-handed frame",
        ));
    }
    Ok(())
}

/// Identified parameters far from their start values, by name (the `identifiable` ones,
/// layout indices, that are geometric; the base is the frame, anywhere): for every kind of
/// measurement, `identified` the fitted robot.
pub fn parameters(
    start: &Robot,
    identified: &Robot,
    identifiable: &[usize],
) -> Result<(), Refusal> {
    let far: Vec<String> = far_parameters(start, identified, identifiable)
        .into_iter()
        .map(|(name, d, limit)| {
            let sign = if d >= 0.0 { "+" } else { "" };
            format!("{name} {sign}{} (limit ±{limit})", number(d, 3))
        })
        .collect();
    if far.is_empty() {
        return Ok(());
    }
    Err(refuse(
        Check::Parameters,
        format!(
            "identified parameters changed far beyond manufacturing errors (mm / °): {}",
            far.join(", ")
        ),
        "check the robot file, the data's units and frame",
    ))
}

/// The parameters [`parameters`] refuses: `(name, change, limit)` (display units), layout
/// order.
pub fn far_parameters(
    start: &Robot,
    identified: &Robot,
    identifiable: &[usize],
) -> Vec<(String, f64, f64)> {
    let (x0, x1) = (start.params(), identified.params());
    let layout = start.layout();
    let mut far = Vec::new();
    for &k in identifiable {
        let p = layout.get(k);
        let d = p.to_display(x1[k]) - p.to_display(x0[k]);
        let Some(limit) = tolerance(p.kind) else {
            continue;
        };
        let d = if p.unit == kinematics::Unit::Deg {
            (d + 180.0).rem_euclid(360.0) - 180.0
        } else {
            d
        };
        if d.abs() > limit {
            far.push((p.name.to_string(), d, limit));
        }
    }
    far
}

/// Validation: the calibrated model worse than the start model on the validation rows.
pub fn validation(source: &str, before_mean_mm: f64, after_mean_mm: f64) -> Result<(), Refusal> {
    if after_mean_mm > before_mean_mm {
        return Err(refuse(
            Check::Validation,
            format!(
                "{source}: the calibrated model predicts worse than the nominal one (mean {} mm \
                 → {} mm)",
                number(before_mean_mm, 3),
                number(after_mean_mm, 3)
            ),
            "check the data (units, frame, outliers) and the parameter set",
        ));
    }
    Ok(())
}

/// Outliers: a factor below [`MIN_OUTLIER_K`] (request check).
pub fn outlier_k(request: &IdentifyRequest) -> Result<(), Refusal> {
    let k = request.outlier_k;
    if k < MIN_OUTLIER_K && !request.allows(Check::Outliers) {
        return Err(refuse(
            Check::Outliers,
            format!(
                "outlier_k = {k} is below {MIN_OUTLIER_K}: the screen would flag good points \
                 as outliers"
            ),
            "use k ≥ 2 (3 is the default)",
        ));
    }
    Ok(())
}

/// Outliers: rejection removing more than [`MAX_REJECTED_FRACTION`] of the units.
pub fn rejected_fraction(
    source: &str,
    rejected: usize,
    (units, unit): (usize, &str),
    cut: f64,
) -> Result<(), Refusal> {
    if rejected as f64 > MAX_REJECTED_FRACTION * units as f64 {
        return Err(refuse_with(
            Check::Outliers,
            format!(
                "{source}: the robust outlier screen (cut {cut} σ̂) rejects {rejected} of {units} \
                 {unit}s, more than {:.0} % — beyond what it can separate from good data (its \
                 breakdown point is 50 %); this many wrong {unit}s mean wrong units, frame, \
                 robot or target, not a few bad readings",
                100.0 * MAX_REJECTED_FRACTION
            ),
            "check the data; keep every row to see the fit on all of them",
            Some(Setting::On("keep_outliers")),
        ));
    }
    Ok(())
}

/// Outliers: after screening, the classical scale `sigma_row` of the final fit more than
/// [`MAX_SCALE_RATIO`] times the robust scale `robust_row` of the same units (not checked
/// below 1 nm: an exact fit).
pub fn scale_agreement(
    source: &str,
    sigma_row: f64,
    robust_row: f64,
    unit: &str,
) -> Result<(), Refusal> {
    if sigma_row > identify::outliers::MIN_THRESHOLD_MM && sigma_row > MAX_SCALE_RATIO * robust_row
    {
        return Err(refuse_with(
            Check::Outliers,
            format!(
                "{source}: after the robust outlier screen the {unit}s kept still disagree: \
                 their classical scale σ̂ = {sigma_row:.4} is {:.1} × their robust scale σ̃ = \
                 {robust_row:.4} (more than {MAX_SCALE_RATIO}) — many errors the screen cannot \
                 separate from good data",
                sigma_row / robust_row.max(f64::MIN_POSITIVE)
            ),
            "check the data; keep every row to see the fit on all of them",
            Some(Setting::On("keep_outliers")),
        ));
    }
    Ok(())
}
