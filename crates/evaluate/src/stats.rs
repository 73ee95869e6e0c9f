//! Error statistics in the form of the paper's Table 4.
//!
//! Input: one error vector per pose, `e_i = p_measured,i − p_target,i` (mm). For each
//! of the absolute axis components `|e_x|`, `|e_y|`, `|e_z|` and the 3-D norm
//! `‖e‖ = √(e_x² + e_y² + e_z²)` the statistics of [`AxisStats`] are computed.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::{EvalError, Result};

/// Statistics of one non-negative error series `v_1 … v_n` (mm).
///
/// * `mean_mm = (1/n) Σ v_i`
/// * `max_mm = max_i v_i`
/// * `rms_mm = √((1/n) Σ v_i²)`
/// * `p95_mm` = 95th percentile by [`percentile_linear`] (numpy's default, linear
///   interpolation between order statistics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisStats {
    /// Arithmetic mean `(1/n) Σ v_i` (mm).
    pub mean_mm: f64,
    /// Maximum `max_i v_i` (mm).
    pub max_mm: f64,
    /// Root mean square `√((1/n) Σ v_i²)` (mm).
    pub rms_mm: f64,
    /// 95th percentile, linear interpolation between order statistics (mm).
    pub p95_mm: f64,
}

impl AxisStats {
    /// Statistics of a series of finite values (see the type's doc for the formulas).
    ///
    /// # Errors
    /// [`EvalError::Empty`] for an empty series, [`EvalError::NonFinite`] if a value is
    /// NaN or infinite.
    pub fn from_values(values_mm: &[f64]) -> Result<Self> {
        Self::from_scratch(&mut values_mm.to_vec())
    }

    /// [`AxisStats::from_values`] of `values_mm`, which it sorts in place (the sums run
    /// in the given order first: the same bits, without a copy to sort).
    fn from_scratch(values_mm: &mut [f64]) -> Result<Self> {
        const WHAT: &str = "error series";
        check_finite(WHAT, values_mm)?;
        if values_mm.is_empty() {
            return Err(EvalError::Empty { what: WHAT });
        }
        let n = values_mm.len() as f64;
        let mean_mm = values_mm.iter().sum::<f64>() / n;
        let max_mm = values_mm.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let rms_mm = (values_mm.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
        values_mm.sort_by(f64::total_cmp);
        let p95_mm = percentile_sorted(values_mm, 95.0);
        Ok(Self {
            mean_mm,
            max_mm,
            rms_mm,
            p95_mm,
        })
    }
}

/// Table 4 statistics of a set of error vectors `e_i` (mm), `i = 1 … count`.
///
/// `x`, `y`, `z` are the [`AxisStats`] of `|e_{x,i}|`, `|e_{y,i}|`, `|e_{z,i}|`;
/// `norm` those of `‖e_i‖₂`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Number of error vectors `n`.
    pub count: usize,
    /// Statistics of `|e_x|` (mm).
    pub x: AxisStats,
    /// Statistics of `|e_y|` (mm).
    pub y: AxisStats,
    /// Statistics of `|e_z|` (mm).
    pub z: AxisStats,
    /// Statistics of the 3-D error `‖e‖ = √(e_x² + e_y² + e_z²)` (mm).
    pub norm: AxisStats,
}

/// Computes [`ErrorStats`] from per-pose error vectors `e_i = measured − target` (mm).
///
/// # Errors
/// [`EvalError::Empty`] if `errors_mm` is empty; [`EvalError::NonFinite`] (with the row
/// index) if any component is NaN or infinite.
pub fn error_stats(errors_mm: &[[f64; 3]]) -> Result<ErrorStats> {
    error_stats_in(errors_mm, &mut Vec::with_capacity(errors_mm.len()))
}

/// [`error_stats`] with the caller's buffer for the series (cleared first; no allocation
/// once it has the room: a campaign's trials keep one).
pub fn error_stats_in(errors_mm: &[[f64; 3]], scratch: &mut Vec<f64>) -> Result<ErrorStats> {
    const WHAT: &str = "error vectors";
    if errors_mm.is_empty() {
        return Err(EvalError::Empty { what: WHAT });
    }
    for (index, e) in errors_mm.iter().enumerate() {
        if let Some(&value) = e.iter().find(|v| !v.is_finite()) {
            return Err(EvalError::NonFinite {
                what: WHAT,
                index,
                value,
            });
        }
    }
    // One buffer for the four series, each sorted in place once its sums are taken.
    let mut axis = |k: usize| {
        scratch.clear();
        scratch.extend(errors_mm.iter().map(|e| match k {
            3 => norm3(e),
            _ => e[k].abs(),
        }));
        AxisStats::from_scratch(scratch)
    };
    Ok(ErrorStats {
        count: errors_mm.len(),
        x: axis(0)?,
        y: axis(1)?,
        z: axis(2)?,
        norm: axis(3)?,
    })
}

/// The 3-D norms ‖e‖ = √(x² + y² + z²) of error vectors, in their order (the `norm` row of
/// [`error_stats`], and what the error plots draw).
pub fn norms(errors_mm: &[[f64; 3]]) -> Vec<f64> {
    errors_mm.iter().map(norm3).collect()
}

/// ‖e‖ = √(x² + y² + z²), summed in that order.
fn norm3(e: &[f64; 3]) -> f64 {
    (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
}

/// The mean of `v`, summed in order (0 for an empty slice): e.g. the reference lines of the
/// plots.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// [`error_stats`] for nalgebra vectors `e_i = measured − target` (mm).
///
/// # Errors
/// As [`error_stats`].
pub fn error_stats_vectors(errors_mm: &[Vector3<f64>]) -> Result<ErrorStats> {
    let rows: Vec<[f64; 3]> = errors_mm.iter().map(|e| [e.x, e.y, e.z]).collect();
    error_stats(&rows)
}

/// Error vectors `e_i = measured_i − target_i` (mm), row by row.
///
/// # Errors
/// [`EvalError::LengthMismatch`] if the two slices differ in length,
/// [`EvalError::Empty`] if they are empty, [`EvalError::NonFinite`] for NaN/∞.
pub fn error_vectors_mm(measured_mm: &[[f64; 3]], target_mm: &[[f64; 3]]) -> Result<Vec<[f64; 3]>> {
    if measured_mm.len() != target_mm.len() {
        return Err(EvalError::LengthMismatch {
            what: "target points",
            expected: measured_mm.len(),
            got: target_mm.len(),
        });
    }
    if measured_mm.is_empty() {
        return Err(EvalError::Empty {
            what: "measured points",
        });
    }
    for (what, rows) in [
        ("measured points", measured_mm),
        ("target points", target_mm),
    ] {
        for (index, r) in rows.iter().enumerate() {
            if let Some(&value) = r.iter().find(|v| !v.is_finite()) {
                return Err(EvalError::NonFinite { what, index, value });
            }
        }
    }
    Ok(measured_mm
        .iter()
        .zip(target_mm)
        .map(|(m, t)| [m[0] - t[0], m[1] - t[1], m[2] - t[2]])
        .collect())
}

/// The `p`-th percentile (`0 ≤ p ≤ 100`) by linear interpolation between order
/// statistics — numpy's default (`method="linear"`, Hyndman & Fan type 7).
///
/// With the values sorted ascending, `v_(0) ≤ … ≤ v_(n−1)`:
/// `h = (n − 1)·p/100`, `k = ⌊h⌋`,
/// `Q(p) = v_(k) + (h − k)·(v_(k+1) − v_(k))` (and `Q = v_(n−1)` when `k = n − 1`).
///
/// # Errors
/// [`EvalError::Empty`] for no values, [`EvalError::NonFinite`] for NaN/∞ values,
/// [`EvalError::InvalidArgument`] if `p` is outside `[0, 100]` or not finite.
pub fn percentile_linear(values: &[f64], p: f64) -> Result<f64> {
    const WHAT: &str = "percentile input";
    if !(0.0..=100.0).contains(&p) {
        return Err(EvalError::InvalidArgument {
            name: "p",
            value: p,
            reason: "percentile must lie in [0, 100]",
        });
    }
    check_finite(WHAT, values)?;
    if values.is_empty() {
        return Err(EvalError::Empty { what: WHAT });
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    Ok(percentile_sorted(&sorted, p))
}

/// [`percentile_linear`] of values already sorted ascending (non-empty, finite, `p` in
/// `[0, 100]`).
fn percentile_sorted(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p / 100.0;
    let k = h.floor() as usize;
    if k + 1 >= sorted.len() {
        return sorted[sorted.len() - 1];
    }
    sorted[k] + (h - k as f64) * (sorted[k + 1] - sorted[k])
}

/// Relative improvement in percent, `100·(before − after)/before`.
///
/// Positive when `after < before`; negative when the error grew. Returns `None` when
/// the ratio is undefined: `before ≤ 0` or either value not finite (never NaN).
pub fn improvement_pct(before: f64, after: f64) -> Option<f64> {
    (before.is_finite() && after.is_finite() && before > 0.0)
        .then(|| 100.0 * (before - after) / before)
}

/// Improvement `100·(before − after)/before` (%) of each statistic of one series;
/// `None` where undefined (see [`improvement_pct`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisImprovement {
    /// Improvement of the mean (%).
    pub mean_pct: Option<f64>,
    /// Improvement of the maximum (%).
    pub max_pct: Option<f64>,
    /// Improvement of the RMS (%).
    pub rms_pct: Option<f64>,
    /// Improvement of the 95th percentile (%).
    pub p95_pct: Option<f64>,
}

impl AxisImprovement {
    /// Element-wise [`improvement_pct`] of two [`AxisStats`].
    pub fn between(before: &AxisStats, after: &AxisStats) -> Self {
        Self {
            mean_pct: improvement_pct(before.mean_mm, after.mean_mm),
            max_pct: improvement_pct(before.max_mm, after.max_mm),
            rms_pct: improvement_pct(before.rms_mm, after.rms_mm),
            p95_pct: improvement_pct(before.p95_mm, after.p95_mm),
        }
    }
}

/// [`AxisImprovement`] for `|x|`, `|y|`, `|z|` and the 3-D norm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StatsImprovement {
    /// Improvement of the `|e_x|` statistics (%).
    pub x: AxisImprovement,
    /// Improvement of the `|e_y|` statistics (%).
    pub y: AxisImprovement,
    /// Improvement of the `|e_z|` statistics (%).
    pub z: AxisImprovement,
    /// Improvement of the `‖e‖` statistics (%).
    pub norm: AxisImprovement,
}

/// The paper's Table 4: error statistics before and after compensation, on the same
/// validation poses. Improvement per statistic `s`: `100·(s_before − s_after)/s_before`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Table4 {
    /// Statistics before compensation.
    pub before: ErrorStats,
    /// Statistics after compensation.
    pub after: ErrorStats,
}

impl Table4 {
    /// Builds the table from the two sets of error vectors (mm).
    ///
    /// # Errors
    /// As [`error_stats`] for either set.
    pub fn from_errors(before_mm: &[[f64; 3]], after_mm: &[[f64; 3]]) -> Result<Self> {
        Self::from_errors_in(before_mm, after_mm, &mut Vec::new())
    }

    /// [`Table4::from_errors`] with the caller's buffer for the series ([`error_stats_in`]).
    pub fn from_errors_in(
        before_mm: &[[f64; 3]],
        after_mm: &[[f64; 3]],
        scratch: &mut Vec<f64>,
    ) -> Result<Self> {
        Ok(Self {
            before: error_stats_in(before_mm, scratch)?,
            after: error_stats_in(after_mm, scratch)?,
        })
    }

    /// Improvement `100·(before − after)/before` (%) for every statistic.
    pub fn improvement(&self) -> StatsImprovement {
        StatsImprovement {
            x: AxisImprovement::between(&self.before.x, &self.after.x),
            y: AxisImprovement::between(&self.before.y, &self.after.y),
            z: AxisImprovement::between(&self.before.z, &self.after.z),
            norm: AxisImprovement::between(&self.before.norm, &self.after.norm),
        }
    }
}

/// Fails with [`EvalError::NonFinite`] on the first NaN/∞ entry.
pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(EvalError::NonFinite {
            what,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    /// Norms of a 3-4-12 and a zero vector; the mean in order, and 0 for nothing.
    #[test]
    fn norms_and_mean() {
        assert_eq!(norms(&[[3.0, 4.0, 12.0], [0.0, 0.0, 0.0]]), [13.0, 0.0]);
        assert!(norms(&[]).is_empty());
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
        assert_eq!(mean(&[]), 0.0);
    }

    #[test]
    fn percentile_matches_numpy_linear() {
        // numpy.percentile([1, 2, 3, 4], 95) = 3.85: h = 3·0.95 = 2.85 → 3 + 0.85·1.
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_relative_eq!(percentile_linear(&v, 95.0).unwrap(), 3.85, epsilon = 1e-12);
        assert_relative_eq!(percentile_linear(&v, 50.0).unwrap(), 2.5, epsilon = 1e-12);
        assert_eq!(percentile_linear(&v, 0.0).unwrap(), 1.0);
        assert_eq!(percentile_linear(&v, 100.0).unwrap(), 4.0);
        assert_eq!(percentile_linear(&[7.0], 95.0).unwrap(), 7.0);
        // numpy.percentile(range(21), 95) = 19.0 exactly.
        let r: Vec<f64> = (0..21).map(f64::from).collect();
        assert_relative_eq!(percentile_linear(&r, 95.0).unwrap(), 19.0, epsilon = 1e-12);
    }

    #[test]
    fn percentile_errors() {
        assert!(matches!(
            percentile_linear(&[], 50.0),
            Err(EvalError::Empty { .. })
        ));
        assert!(matches!(
            percentile_linear(&[1.0], 101.0),
            Err(EvalError::InvalidArgument { .. })
        ));
        assert!(matches!(
            percentile_linear(&[1.0], f64::NAN),
            Err(EvalError::InvalidArgument { .. })
        ));
        assert!(matches!(
            percentile_linear(&[1.0, f64::INFINITY], 50.0),
            Err(EvalError::NonFinite { index: 1, .. })
        ));
    }

    #[test]
    fn hand_example() {
        // Errors (mm):            |x| |y| |z|  norm
        //   ( 3,  4,  0)           3   4   0    5
        //   ( 0,  0, -2)           0   0   2    2
        //   (-1,  2,  2)           1   2   2    3
        //   ( 6,  0,  8)           6   0   8   10
        let e = [
            [3.0, 4.0, 0.0],
            [0.0, 0.0, -2.0],
            [-1.0, 2.0, 2.0],
            [6.0, 0.0, 8.0],
        ];
        let s = error_stats(&e).unwrap();
        assert_eq!(s.count, 4);
        // norm: mean = 20/4 = 5, max = 10, RMS = √((25+4+9+100)/4) = √34.5,
        // sorted 2,3,5,10: h = 2.85 → 5 + 0.85·5 = 9.25.
        assert_relative_eq!(s.norm.mean_mm, 5.0, epsilon = 1e-12);
        assert_relative_eq!(s.norm.max_mm, 10.0, epsilon = 1e-12);
        assert_relative_eq!(s.norm.rms_mm, 34.5_f64.sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.norm.p95_mm, 9.25, epsilon = 1e-12);
        // |x|: 3,0,1,6 → mean 2.5, max 6, RMS √(46/4), sorted 0,1,3,6 → 3 + 0.85·3 = 5.55.
        assert_relative_eq!(s.x.mean_mm, 2.5, epsilon = 1e-12);
        assert_relative_eq!(s.x.max_mm, 6.0, epsilon = 1e-12);
        assert_relative_eq!(s.x.rms_mm, 11.5_f64.sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.x.p95_mm, 5.55, epsilon = 1e-12);
        // |y|: 4,0,2,0 → mean 1.5, max 4, RMS √5, sorted 0,0,2,4 → 2 + 0.85·2 = 3.7.
        assert_relative_eq!(s.y.mean_mm, 1.5, epsilon = 1e-12);
        assert_relative_eq!(s.y.rms_mm, 5.0_f64.sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.y.p95_mm, 3.7, epsilon = 1e-12);
        // |z|: 0,2,2,8 → mean 3, max 8, RMS √18, sorted 0,2,2,8 → 2 + 0.85·6 = 7.1.
        assert_relative_eq!(s.z.mean_mm, 3.0, epsilon = 1e-12);
        assert_relative_eq!(s.z.max_mm, 8.0, epsilon = 1e-12);
        assert_relative_eq!(s.z.rms_mm, 18.0_f64.sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.z.p95_mm, 7.1, epsilon = 1e-12);

        let v: Vec<Vector3<f64>> = e.iter().map(|r| Vector3::new(r[0], r[1], r[2])).collect();
        assert_eq!(error_stats_vectors(&v).unwrap(), s);
    }

    #[test]
    fn error_vectors_subtract_target() {
        let m = [[1.0, 2.0, 3.0], [0.5, 0.5, 0.5]];
        let t = [[1.5, 2.0, 1.0], [0.0, 1.0, 0.5]];
        assert_eq!(
            error_vectors_mm(&m, &t).unwrap(),
            vec![[-0.5, 0.0, 2.0], [0.5, -0.5, 0.0]]
        );
        assert!(matches!(
            error_vectors_mm(&m, &t[..1]),
            Err(EvalError::LengthMismatch {
                expected: 2,
                got: 1,
                ..
            })
        ));
        assert!(matches!(
            error_vectors_mm(&[], &[]),
            Err(EvalError::Empty { .. })
        ));
        assert!(matches!(
            error_vectors_mm(&m, &[[0.0; 3], [0.0, f64::NAN, 0.0]]),
            Err(EvalError::NonFinite {
                what: "target points",
                index: 1,
                ..
            })
        ));
    }

    #[test]
    fn improvement_percent() {
        // The paper's Table 4: 1.122 → 0.340 mm is 69.7 %, 2.557 → 0.973 mm is 61.9 %.
        assert_relative_eq!(
            improvement_pct(1.122, 0.340).unwrap(),
            69.696_969_696_969_7,
            epsilon = 1e-9
        );
        assert_relative_eq!(
            improvement_pct(2.557, 0.973).unwrap(),
            61.947_594_837_700_4,
            epsilon = 1e-9
        );
        assert_relative_eq!(improvement_pct(1.0, 1.5).unwrap(), -50.0, epsilon = 1e-12);
        assert_eq!(improvement_pct(0.0, 0.0), None);
        assert_eq!(improvement_pct(1.0, f64::NAN), None);
        assert_eq!(improvement_pct(f64::INFINITY, 1.0), None);
    }

    #[test]
    fn table4_improvement_per_statistic() {
        let before = [[2.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        let after = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let t = Table4::from_errors(&before, &after).unwrap();
        let imp = t.improvement();
        // norm: before 2, 4 (mean 3, max 4); after 1, 1 (mean 1, max 1).
        assert_relative_eq!(
            imp.norm.mean_pct.unwrap(),
            100.0 * 2.0 / 3.0,
            epsilon = 1e-12
        );
        assert_relative_eq!(imp.norm.max_pct.unwrap(), 75.0, epsilon = 1e-12);
        // rms: before √10, after 1.
        assert_relative_eq!(
            imp.norm.rms_pct.unwrap(),
            100.0 * (10.0_f64.sqrt() - 1.0) / 10.0_f64.sqrt(),
            epsilon = 1e-12
        );
        // |z| is zero before: improvement undefined.
        assert_eq!(imp.z.mean_pct, None);
        // |x|: mean 1 → 0.5.
        assert_relative_eq!(imp.x.mean_pct.unwrap(), 50.0, epsilon = 1e-12);
    }

    #[test]
    fn error_cases() {
        assert_eq!(
            error_stats(&[]),
            Err(EvalError::Empty {
                what: "error vectors"
            })
        );
        assert!(matches!(
            error_stats(&[[0.0; 3], [1.0, f64::NAN, 0.0]]),
            Err(EvalError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            error_stats(&[[f64::NEG_INFINITY, 0.0, 0.0]]),
            Err(EvalError::NonFinite { index: 0, .. })
        ));
        assert!(matches!(
            AxisStats::from_values(&[]),
            Err(EvalError::Empty { .. })
        ));
        assert!(Table4::from_errors(&[[1.0; 3]], &[]).is_err());
    }

    #[test]
    fn serde_round_trip() {
        let s = error_stats(&[[0.1, -0.2, 0.3], [0.4, 0.5, -0.6]]).unwrap();
        let json = serde_json::to_string(&s).unwrap();
        let back: ErrorStats = serde_json::from_str(&json).unwrap();
        assert_eq!(back, s);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn ordering_invariants(rows in proptest::collection::vec(
            proptest::array::uniform3(-10.0f64..10.0), 1..40)) {
            let s = error_stats(&rows).unwrap();
            for a in [s.x, s.y, s.z, s.norm] {
                prop_assert!(a.mean_mm <= a.rms_mm + 1e-12);
                prop_assert!(a.rms_mm <= a.max_mm + 1e-12);
                prop_assert!(a.p95_mm <= a.max_mm + 1e-12);
                prop_assert!(a.mean_mm >= 0.0);
            }
            // The norm dominates every axis component.
            prop_assert!(s.norm.max_mm + 1e-12 >= s.x.max_mm.max(s.y.max_mm).max(s.z.max_mm));
        }
    }
}
