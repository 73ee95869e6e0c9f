//! The scale of the measurements: a tracker whose scale (or temperature compensation) is off
//! by a factor s measures the robot s times too large, and a calibration absorbs it.
//!
//! A uniform scale of every length of the model (a, d, the tool, the base's translation)
//! reproduces the scaled points exactly, so s is not identifiable from the points alone: a
//! fit of points ×1.02 moves every identified length by 2 % and validates as well as a right
//! one — and against correctly scaled points that robot is millimetres off. What separates a
//! scale error from manufacturing errors is the pattern: manufacturing moves each length by
//! its own tenths of a millimetre, a scale error moves every length in proportion to itself.
//!
//! [`common_scale`] fits that pattern to the identified change of the links' lengths (the a
//! and d of the robot file at least [`MIN_LENGTH_MM`] long, identifiable in the fit):
//!
//! `ε̂ = Σ_k L_k δ_k / Σ_k L_k²`, `δ_k = L_k^identified − L_k^start`,
//!
//! the least-squares factor of `δ ≈ ε L`, with the scatter of the lengths about it as its
//! standard deviation, `sd(ε̂) = √(Σ_k r_k² / (n − 1)) / √(Σ_k L_k²)`, `r_k = δ_k − ε̂ L_k`.
//! The data say the measurements are scaled by `s = 1 + ε̂` when `|ε̂|` exceeds
//! [`MAX_SCALE_ERROR`] and [`SCALE_SIGNIFICANCE`] standard deviations ([`check`]
//! refuses then; `--fit-scale` divides the points by s and identifies again).

use kinematics::{ParamKind, Robot};

use crate::checks::refuse_with;
use crate::error::Refusal;
use crate::request::{Check, Setting};

/// Shortest length of the robot file that carries scale evidence, mm \[100: a link offset of
/// a few tens of millimetres moves by manufacturing errors as much as by a percent of
/// scale\].
pub const MIN_LENGTH_MM: f64 = 100.0;

/// Largest scale error of the measurements accepted without a word \[5·10⁻⁴ (0.05 %): a laser
/// tracker's scale is a few ppm, and an uncompensated air temperature error of 10 K gives
/// 10 ppm; 0.05 % is a wrong unit conversion, a wrong scale setting or a
/// temperature-compensation error far beyond what a tracker and a hall explain\].
pub const MAX_SCALE_ERROR: f64 = 5e-4;

/// Standard deviations of ε̂ beyond which a scale is significant \[3\].
pub const SCALE_SIGNIFICANCE: f64 = 3.0;

/// Largest scale error that is said to be one \[0.1 (10 %): no tracker's scale or temperature
/// compensation is that far off; lengths moving by more, even in proportion, are a unit
/// (the `length-units` check), a mirrored frame or another robot (the `parameters` check),
/// whose refusals say so\].
pub const MAX_SCALE_EVIDENCE: f64 = 0.1;

/// The common scale of the identified lengths (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ScaleEvidence {
    /// `s = 1 + ε̂`: the factor the measurements are too large by.
    pub factor: f64,
    /// `sd(ε̂)`: the scatter of the lengths' own changes about the common factor.
    pub sd: f64,
    /// The lengths that carried evidence: `(name, start mm, identified − start mm)`.
    pub lengths: Vec<(String, f64, f64)>,
}

impl ScaleEvidence {
    /// `ε̂ = s − 1`.
    pub fn error(&self) -> f64 {
        self.factor - 1.0
    }

    /// Whether the data say the measurements are scaled: `MAX_SCALE_ERROR < |ε̂| ≤
    /// MAX_SCALE_EVIDENCE` and `|ε̂| > SCALE_SIGNIFICANCE · sd`.
    pub fn significant(&self) -> bool {
        let e = self.error().abs();
        e > MAX_SCALE_ERROR && e <= MAX_SCALE_EVIDENCE && e > SCALE_SIGNIFICANCE * self.sd
    }

    /// The factor in words, as the console and the report give it after `--fit-scale`.
    pub fn describe(&self) -> String {
        format!(
            "the points were {:.5} times too large ({:+.3} % ± {:.3} %: {}) and were divided \
             by it before identifying (--fit-scale)",
            self.factor,
            100.0 * self.error(),
            100.0 * self.sd,
            self.lengths_text()
        )
    }

    /// The lengths as `a2 −612.0 → −624.2 mm (+2.00 %)`, the largest first, at most four.
    pub fn lengths_text(&self) -> String {
        let mut l: Vec<&(String, f64, f64)> = self.lengths.iter().collect();
        l.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        l.iter()
            .take(4)
            .map(|(name, start, d)| {
                format!(
                    "{name} {start:.1} → {:.1} mm ({:+.2} %)",
                    start + d,
                    100.0 * d / start
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The common scale of the change from `start` to `identified` of the identifiable
/// (`identifiable`, layout indices) a and d at least [`MIN_LENGTH_MM`] long; `None` with
/// fewer than three such lengths (no pattern to see).
pub fn common_scale(
    start: &Robot,
    identified: &Robot,
    identifiable: &[usize],
) -> Option<ScaleEvidence> {
    let layout = start.layout();
    let (x0, x1) = (start.params(), identified.params());
    let lengths: Vec<(String, f64, f64)> = identifiable
        .iter()
        .filter_map(|&k| {
            let p = layout.get(k);
            let (l0, l1) = (p.to_display(x0[k]), p.to_display(x1[k]));
            (matches!(p.kind, ParamKind::A(_) | ParamKind::D(_)) && l0.abs() >= MIN_LENGTH_MM)
                .then(|| (p.name.to_string(), l0, l1 - l0))
        })
        .collect();
    let n = lengths.len();
    if n < 3 {
        return None;
    }
    let sll: f64 = lengths.iter().map(|(_, l, _)| l * l).sum();
    let sld: f64 = lengths.iter().map(|(_, l, d)| l * d).sum();
    let eps = sld / sll;
    let rss: f64 = lengths
        .iter()
        .map(|(_, l, d)| {
            let r = d - eps * l;
            r * r
        })
        .sum();
    let sd = (rss / (n - 1) as f64).sqrt() / sll.sqrt();
    Some(ScaleEvidence {
        factor: 1.0 + eps,
        sd,
        lengths,
    })
}

/// The scale check: refuses when the identified lengths say the measurements of `source` are
/// scaled ([`ScaleEvidence::significant`]), naming the factor, the lengths and the likely
/// causes.
///
/// # Errors
/// [`Refusal::Implausible`] of [`Check::Scale`].
pub fn check(
    source: &str,
    start: &Robot,
    identified: &Robot,
    identifiable: &[usize],
) -> Result<(), Refusal> {
    match common_scale(start, identified, identifiable) {
        Some(e) if e.significant() => Err(refuse_with(
            Check::Scale,
            format!(
                "{source}: every identified length moved in proportion to itself — {} — as \
                 if the points were scaled by {:.5} ({:+.3} %, ± {:.3} % from the lengths' own \
                 scatter); manufacturing errors move each length by its own tenths of a \
                 millimetre, a tracker's scale is known to a few ppm",
                e.lengths_text(),
                e.factor,
                100.0 * e.error(),
                100.0 * e.sd
            ),
            "check the points' unit and the tracker's scale and temperature compensation \
             (air temperature, pressure, material expansion), or identify the factor as a \
             parameter of the measurement",
            Some(Setting::On("fit_scale")),
        )),
        _ => Ok(()),
    }
}
