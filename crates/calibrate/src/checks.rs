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
use crate::request::{Check, IdentifyRequest};

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
    Refusal::Implausible {
        check,
        evidence,
        remedy: remedy.to_string(),
    }
}

/// Joint values read as degrees that look like radians: at least 3 rows, every |q| ≤ 2π,
/// and a robot whose limits reach beyond ±90° on some joint.
pub fn joint_units(
    source: &str,
    rows: &[Measurement],
    limits_deg: &[[f64; 2]],
) -> Result<(), Refusal> {
    if let Some(note) = crate::files::radians_evidence(source, rows, limits_deg) {
        return Err(refuse(
            Check::JointUnits,
            note,
            "if the joints are in radians, declare it (joint_units = rad)",
        ));
    }
    Ok(())
}

/// Joint values declared radians (`joint_units = rad`) that are degrees: the file, read in
/// degrees, is within the robot's limits, and some |q| exceeds 2π — no revolute joint
/// value in radians does (one turn), while degrees data of almost any pose do. `deg_rows`
/// are the file's rows read as degrees (unconverted). Called where the declared-radians read
/// failed, typically on a joint limit (the limits in radians are ±2.6 for ±150°), so that
/// the refusal names the evidence instead of the first row beyond a limit.
pub fn declared_radians(source: &str, deg_rows: &[Measurement]) -> Result<(), Refusal> {
    let largest = deg_rows
        .iter()
        .flat_map(|r| r.q_deg.iter())
        .fold(0.0_f64, |m, q| m.max(q.abs()));
    if largest > std::f64::consts::TAU {
        return Err(refuse(
            Check::JointUnits,
            format!(
                "{source}: the joint values are declared radians (joint_units = rad) but reach \
                 |q| = {largest:.4}, beyond one turn (2π = 6.2832), and read as degrees every \
                 row is within the robot's joint limits: these look like degrees"
            ),
            "if the joints are in degrees, leave joint_units at deg (the default)",
        ));
    }
    Ok(())
}

fn spread(points: &[Vector3<f64>]) -> f64 {
    let n = points.len().max(1) as f64;
    let c = points.iter().sum::<Vector3<f64>>() / n;
    (points.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / n).sqrt()
}

/// The measured points' spread (RMS distance from their centroid, independent of the frame)
/// against the nominal robot's at the same joints.
pub fn length_units(source: &str, nominal: &Robot, rows: &[Measurement]) -> Result<(), Refusal> {
    let predicted = nominal.points(&poses_rad(rows));
    let (sp, sm) = (spread(&predicted), spread(&points_mm(rows)));
    // Scale evidence needs motion: of the nominal points, or of the measured ones (a robot
    // file in metres spreads its points over millimetres while the tracker's spread metres).
    if (sp < MIN_SPREAD_MM && sm < MIN_SPREAD_MM) || rows.len() < 3 {
        return Ok(());
    }
    let ratio = sm / sp;
    if (1.0 / SPREAD_RATIO_MAX..=SPREAD_RATIO_MAX).contains(&ratio) {
        return Ok(());
    }
    let guess = [
        (0.001, "metres: length_units = m"),
        (0.01, "centimetres: multiply by 10"),
        (1.0 / 25.4, "inches: length_units = in"),
        (
            1000.0,
            "micrometres (divide by 1000) — or the robot file's lengths are metres \
             (its a, d and tool must be millimetres)",
        ),
    ]
    .iter()
    .find(|(f, _)| (ratio / f - 1.0).abs() < 0.25)
    .map_or("a different robot or unit", |(_, g)| g);
    Err(refuse(
        Check::LengthUnits,
        format!(
            "{source}: the measured points spread {sm:.4} (RMS about their centroid) where the \
             nominal robot's points at the same joints spread {sp:.1} mm: ratio {ratio:.4}, \
             outside [{:.2}, {SPREAD_RATIO_MAX}] — the lengths look like {guess}",
            1.0 / SPREAD_RATIO_MAX
        ),
        "convert the points to millimetres (length_units)",
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
                "{source}: the best rotation fits the nominal robot's points to {proper:.1} mm \
                 RMS, the best reflection to {improper:.1} mm: the measurement frame is \
                 left-handed (axes swapped or one negated)"
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
        .map(|(name, d, limit)| format!("{name} {d:+.3} (limit ±{limit})"))
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
            far.push((p.name.clone(), d, limit));
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
                "{source}: the calibrated model predicts worse than the nominal one (mean \
                 {before_mean_mm:.3} mm → {after_mean_mm:.3} mm)"
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
        return Err(refuse(
            Check::Outliers,
            format!(
                "{source}: the robust outlier screen (cut {cut} σ̂) rejects {rejected} of {units} \
                 {unit}s, more than {:.0} % — beyond what it can separate from good data (its \
                 breakdown point is 50 %); this many wrong {unit}s mean wrong units, frame, \
                 robot or target, not a few bad readings",
                100.0 * MAX_REJECTED_FRACTION
            ),
            "check the data; keep every row (keep_outliers) to see the fit on all of them",
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
        return Err(refuse(
            Check::Outliers,
            format!(
                "{source}: after the robust outlier screen the {unit}s kept still disagree: \
                 their classical scale σ̂ = {sigma_row:.4} is {:.1} × their robust scale σ̃ = \
                 {robust_row:.4} (more than {MAX_SCALE_RATIO}) — many errors the screen cannot \
                 separate from good data",
                sigma_row / robust_row.max(f64::MIN_POSITIVE)
            ),
            "check the data; keep every row (keep_outliers) to see the fit on all of them",
        ));
    }
    Ok(())
}
