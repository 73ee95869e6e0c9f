//! Parameter-recovery scoring.
//!
//! For each parameter, in its display unit (mm for lengths, deg for angles):
//! `error = estimate − truth` and `z = error / std_error`, where `std_error` is the
//! standard error the identification reported. If the reported standard errors are
//! right, the z-scores of many parameters/trials have mean ≈ 0 and sd ≈ 1.

use std::borrow::Cow;

use serde::{Deserialize, Serialize};

use crate::{EvalError, Result};

/// Recovery of one parameter. All values are in the display unit `unit` (`"mm"` or
/// `"deg"`), except `z`, which is dimensionless.
///
/// `error = estimate − truth`, `z = error / std_error` (with `std_error > 0`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterRecovery {
    /// Stable parameter name (e.g. `"a_2"`): an interned name borrowed (no allocation per
    /// row in a campaign), or read text.
    pub name: Cow<'static, str>,
    /// Display unit of `truth`, `estimate`, `error` and `std_error` (`"mm"`, `"deg"`): a
    /// unit's static name, borrowed (no allocation per row in a campaign), or read text.
    pub unit: Cow<'static, str>,
    /// True value (unit `unit`).
    pub truth: f64,
    /// Estimated value (unit `unit`).
    pub estimate: f64,
    /// `estimate − truth` (unit `unit`).
    pub error: f64,
    /// Reported standard error of the estimate, `> 0` (unit `unit`).
    pub std_error: f64,
    /// `error / std_error` (dimensionless).
    pub z: f64,
}

impl ParameterRecovery {
    /// Scores one parameter: `error = estimate − truth`, `z = error / std_error`.
    ///
    /// # Errors
    /// [`EvalError::NonFinite`] if `truth` (index 0) or `estimate` (index 1) is not
    /// finite; [`EvalError::InvalidStdError`] unless `std_error` is finite and `> 0`.
    pub fn new(
        name: impl Into<Cow<'static, str>>,
        unit: impl Into<Cow<'static, str>>,
        truth: f64,
        estimate: f64,
        std_error: f64,
    ) -> Result<Self> {
        let name = name.into();
        crate::stats::check_finite("parameter truth/estimate", &[truth, estimate])?;
        if !(std_error.is_finite() && std_error > 0.0) {
            return Err(EvalError::InvalidStdError {
                name: name.into_owned(),
                value: std_error,
            });
        }
        let error = estimate - truth;
        Ok(Self {
            name,
            unit: unit.into(),
            truth,
            estimate,
            error,
            std_error,
            z: error / std_error,
        })
    }
}

/// Scores parameters given as parallel slices (index `i` is one parameter):
/// `error_i = estimates_i − truths_i`, `z_i = error_i / std_errors_i`.
///
/// # Errors
/// [`EvalError::Empty`] for no parameters; [`EvalError::LengthMismatch`] if any slice
/// differs in length from `names`; [`EvalError::NonFinite`] for a non-finite estimate
/// or truth (index = parameter index); [`EvalError::InvalidStdError`] for a standard
/// error that is not finite and positive.
pub fn score_recovery<N: AsRef<str>, U: AsRef<str>>(
    names: &[N],
    units: &[U],
    estimates: &[f64],
    truths: &[f64],
    std_errors: &[f64],
) -> Result<Vec<ParameterRecovery>> {
    if names.is_empty() {
        return Err(EvalError::Empty {
            what: "parameter names",
        });
    }
    let n = names.len();
    for (what, len) in [
        ("units", units.len()),
        ("estimates", estimates.len()),
        ("truths", truths.len()),
        ("std_errors", std_errors.len()),
    ] {
        if len != n {
            return Err(EvalError::LengthMismatch {
                what,
                expected: n,
                got: len,
            });
        }
    }
    crate::stats::check_finite("estimates", estimates)?;
    crate::stats::check_finite("truths", truths)?;
    (0..n)
        .map(|i| {
            ParameterRecovery::new(
                names[i].as_ref().to_string(),
                units[i].as_ref().to_string(),
                truths[i],
                estimates[i],
                std_errors[i],
            )
        })
        .collect()
}

/// Summary of a set of z-scores `z_1 … z_n`:
/// `mean = (1/n) Σ z_i`, `sd = √(Σ (z_i − mean)² / (n − 1))`, `max_abs = max |z_i|`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ZSummary {
    /// Number of z-scores `n`.
    pub count: usize,
    /// Mean `(1/n) Σ z_i`.
    pub mean: f64,
    /// Sample standard deviation `√(Σ (z_i − mean)² / (n − 1))`.
    pub sd: f64,
    /// Largest magnitude `max |z_i|`.
    pub max_abs: f64,
}

/// Summarises z-scores (see [`ZSummary`] for the formulas).
///
/// # Errors
/// [`EvalError::TooFew`] for fewer than 2 values (the sample sd needs `n − 1 > 0`);
/// [`EvalError::NonFinite`] for NaN/∞.
pub fn summarize_z(z: &[f64]) -> Result<ZSummary> {
    crate::stats::check_finite("z-scores", z)?;
    if z.len() < 2 {
        return Err(EvalError::TooFew {
            what: "z-scores",
            needed: 2,
            got: z.len(),
        });
    }
    let n = z.len() as f64;
    let mean = z.iter().sum::<f64>() / n;
    let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let max_abs = z.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    Ok(ZSummary {
        count: z.len(),
        mean,
        sd,
        max_abs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn z_scores_by_hand() {
        // a_2: 1400.30 − 1400.00 = 0.30 mm, / 0.10 → z = 3
        // theta_3: 0.010 − 0.020 = −0.010 deg, / 0.005 → z = −2
        // tx: 60.0 − 60.0 = 0, z = 0
        let r = score_recovery(
            &["a_2", "theta_3", "tx"],
            &["mm", "deg", "mm"],
            &[1400.30, 0.010, 60.0],
            &[1400.00, 0.020, 60.0],
            &[0.10, 0.005, 0.02],
        )
        .unwrap();
        assert_eq!(r.len(), 3);
        assert_eq!(r[0].name, "a_2");
        assert_eq!(r[1].unit, "deg");
        assert_relative_eq!(r[0].error, 0.30, epsilon = 1e-9);
        assert_relative_eq!(r[0].z, 3.0, epsilon = 1e-8);
        assert_relative_eq!(r[1].error, -0.010, epsilon = 1e-15);
        assert_relative_eq!(r[1].z, -2.0, epsilon = 1e-12);
        assert_eq!(r[2].error, 0.0);
        assert_eq!(r[2].z, 0.0);
        assert_eq!(r[0].truth, 1400.00);
        assert_eq!(r[0].estimate, 1400.30);
        assert_eq!(r[0].std_error, 0.10);
    }

    #[test]
    fn recovery_error_cases() {
        let bad_se = score_recovery(&["d_1"], &["mm"], &[1.0], &[1.0], &[0.0]);
        assert_eq!(
            bad_se,
            Err(EvalError::InvalidStdError {
                name: "d_1".into(),
                value: 0.0
            })
        );
        for se in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                ParameterRecovery::new("x", "mm", 0.0, 0.0, se),
                Err(EvalError::InvalidStdError { .. })
            ));
        }
        assert!(matches!(
            score_recovery(
                &["a", "b"],
                &["mm", "mm"],
                &[1.0, f64::NAN],
                &[1.0, 1.0],
                &[1.0, 1.0]
            ),
            Err(EvalError::NonFinite {
                what: "estimates",
                index: 1,
                ..
            })
        ));
        assert!(matches!(
            ParameterRecovery::new("x", "mm", f64::NAN, 0.0, 1.0),
            Err(EvalError::NonFinite { index: 0, .. })
        ));
        assert!(matches!(
            score_recovery(&["a", "b"], &["mm", "mm"], &[1.0, 2.0], &[1.0], &[1.0, 1.0]),
            Err(EvalError::LengthMismatch {
                what: "truths",
                expected: 2,
                got: 1
            })
        ));
        let none: [&str; 0] = [];
        assert!(matches!(
            score_recovery(&none, &none, &[], &[], &[]),
            Err(EvalError::Empty { .. })
        ));
    }

    #[test]
    fn z_summary_by_hand() {
        // z = 3, −2, 0, 1: mean = 0.5; deviations 2.5, −2.5, −0.5, 0.5;
        // Σ dev² = 6.25 + 6.25 + 0.25 + 0.25 = 13 → sd = √(13/3) = 2.081666…
        let s = summarize_z(&[3.0, -2.0, 0.0, 1.0]).unwrap();
        assert_eq!(s.count, 4);
        assert_relative_eq!(s.mean, 0.5, epsilon = 1e-12);
        assert_relative_eq!(s.sd, (13.0f64 / 3.0).sqrt(), epsilon = 1e-12);
        assert_eq!(s.max_abs, 3.0);
        assert!(matches!(
            summarize_z(&[1.0]),
            Err(EvalError::TooFew { got: 1, .. })
        ));
        assert!(matches!(
            summarize_z(&[1.0, f64::NAN]),
            Err(EvalError::NonFinite { index: 1, .. })
        ));
    }
}
