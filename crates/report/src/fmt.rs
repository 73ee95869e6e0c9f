//! Number formatting rules for every table, report and console line.
//!
//! | quantity | rule | example |
//! |---|---|---|
//! | length (mm) | 3 decimals; 4 below 0.1 mm in magnitude | `0.363`, `0.0312` |
//! | angle (degrees) | 4 decimals, unit stated | `0.0040` |
//! | angle (arcsec) | 1 decimal, unit stated | `14.4` |
//! | percentage | 1 decimal | `68.3` |
//! | rate (per second) | whole number, thousands separated by `,` | `1,834` |
//! | count | whole number, thousands separated by `,` | `1,495` |
//! | z-score | 2 decimals | `-13.80` |
//! | dimensionless index (O1–O5) | 3 significant digits | `0.0861` |
//!
//! A cell that shows several statistics of one quantity (`mean ± sd [p5, p95]`) uses the
//! precision its mean calls for, for all of them, so the column stays aligned.
//!
//! Negative zero prints as `0`, never `-0.000`, except in the signed rules below.
//!
//! Fixed-column and signed rules, for the files whose layout predates the rules above (the
//! trial report `trial-*.md`, the calibration report and its console summary): committed
//! files and documented outputs keep their bytes, and every cell still goes through a named
//! rule here.
//!
//! | quantity | rule | function | example |
//! |---|---|---|---|
//! | length in a before/after column (mm) | 3 decimals always | [`mm_col`] | `0.030` |
//! | distance of a frame change (mm) | 1 decimal | [`mm_coarse`] | `2954.1` |
//! | rotation of a frame change (°) | 3 decimals | [`deg_coarse`] | `20.076` |
//! | parameter value or standard error in a table | `d` decimals as the table states | [`param`] | `0.0040` |
//! | signed component (error vector, translation, base, Δ, improvement) | sign kept on zero | [`signed`] | `-0.000` |
//! | weight or correlation | explicit sign | [`plus`] | `+0.982` |
//! | ratio, condition number | 2 decimals | [`ratio`] | `3.41` |
//! | duration (ms) | 1 decimal | [`ms`] | `12.5` |
//! | wall-clock duration (s) | 2 decimals | [`secs`] | `3.07` |
//! | singular value, observability O1–O5, rank threshold | scientific, `d` decimals | [`sci`] | `1.2345e-3` |
//! | a setting echoed as given (outlier k, a tool offset) | shortest round-trip form | [`setting`], [`setting_sci`] | `3`, `2.5`, `1e-10` |

/// Arcseconds per degree.
pub const ARCSEC_PER_DEG: f64 = 3600.0;

/// Decimals for a length of magnitude `v` in mm: 3, or 4 below 0.1 mm.
pub fn mm_decimals(v: f64) -> usize {
    if v.abs() < 0.1 { 4 } else { 3 }
}

/// `v` with `d` decimals, without a minus sign on a value that rounds to zero.
pub fn fixed(v: f64, d: usize) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "n/a".into()
        } else {
            format!("{v}")
        };
    }
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// A length in a before/after column, mm: 3 decimals always, so a column of errors stays
/// aligned whatever its magnitude (the trial and calibration reports).
pub fn mm_col(v: f64) -> String {
    fixed(v, 3)
}

/// The distance of a frame change (a registration's translation), mm: 1 decimal (a tracker
/// frame is metres away; its tenth of a millimetre is below the fit's own uncertainty).
pub fn mm_coarse(v: f64) -> String {
    fixed(v, 1)
}

/// The rotation angle of a frame change, degrees: 3 decimals.
pub fn deg_coarse(v: f64) -> String {
    fixed(v, 3)
}

/// A parameter value or standard error in a table with `d` decimals (the trial report's 4,
/// the calibration report's 5), without a minus sign on a value that rounds to zero.
pub fn param(v: f64, d: usize) -> String {
    fixed(v, d)
}

/// A signed component with `d` decimals (an error vector's component, a translation, a base
/// value, a Δ, an improvement): Rust's fixed notation, the sign kept even when the value
/// rounds to zero (`-0.000`), so the direction of a small error still shows.
pub fn signed(v: f64, d: usize) -> String {
    format!("{v:.d$}")
}

/// A weight or a correlation with `d` decimals and an explicit sign (`+0.982`, `-0.500`).
pub fn plus(v: f64, d: usize) -> String {
    format!("{v:+.d$}")
}

/// A ratio or a condition number: 2 decimals.
pub fn ratio(v: f64) -> String {
    fixed(v, 2)
}

/// A wall-clock duration in seconds: 2 decimals.
pub fn secs(v: f64) -> String {
    fixed(v, 2)
}

/// A duration in milliseconds: 1 decimal.
pub fn ms(v: f64) -> String {
    fixed(v, 1)
}

/// A singular value, an observability index O1–O5 of a calibration or a rank threshold:
/// scientific notation with `d` decimals in the mantissa (`1.2345e-3` for 4); they span
/// decades.
pub fn sci(v: f64, d: usize) -> String {
    format!("{v:.d$e}")
}

/// A setting echoed as the user gave it: Rust's shortest round-trip form (`3`, `2.5`).
pub fn setting(v: f64) -> String {
    format!("{v}")
}

/// A setting that is a tolerance, echoed in scientific notation in its shortest round-trip
/// form (`1e-10`).
pub fn setting_sci(v: f64) -> String {
    format!("{v:e}")
}

/// A length in mm: 3 decimals, 4 below 0.1 mm.
pub fn mm(v: f64) -> String {
    fixed(v, mm_decimals(v))
}

/// An angle in degrees: 4 decimals.
pub fn deg(v: f64) -> String {
    fixed(v, 4)
}

/// An angle given in degrees, printed in arcseconds with 1 decimal.
pub fn arcsec_from_deg(v_deg: f64) -> String {
    fixed(v_deg * ARCSEC_PER_DEG, 1)
}

/// A percentage: 1 decimal.
pub fn pct(v: f64) -> String {
    fixed(v, 1)
}

/// A z-score: 2 decimals.
pub fn z(v: f64) -> String {
    fixed(v, 2)
}

/// A whole number with `,` between thousands (`1834.42` → `1,834`).
pub fn whole(v: f64) -> String {
    if !v.is_finite() {
        return fixed(v, 0);
    }
    let r = v.round();
    let digits = format!("{:.0}", r.abs());
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    if r < 0.0 { format!("-{out}") } else { out }
}

/// A rate per second: a whole number with thousands separators.
pub fn rate(per_second: f64) -> String {
    whole(per_second)
}

/// A dimensionless value to 3 significant digits (`0.08607` → `0.0861`), plain notation
/// between 1e-4 and 1e6, scientific outside.
pub fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return fixed(v, 0);
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{v:.2e}");
    }
    let d = (2 - mag).max(0) as usize;
    fixed(v, d)
}

/// What a value measures, which decides how it is printed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// A length in mm.
    LengthMm,
    /// An angle in degrees.
    AngleDeg,
    /// An angle given in degrees, printed in arcseconds.
    AngleArcsecFromDeg,
    /// A percentage.
    Percent,
    /// A z-score.
    ZScore,
    /// A count or a mean of counts (2 decimals).
    MeanCount,
    /// A dimensionless index (3 significant digits).
    Index,
}

impl Quantity {
    /// Decimals this quantity gets for a cell whose leading value is `lead`.
    pub fn decimals(self, lead: f64) -> usize {
        match self {
            Quantity::LengthMm => mm_decimals(lead),
            Quantity::AngleDeg => 4,
            Quantity::AngleArcsecFromDeg => 1,
            Quantity::Percent => 1,
            Quantity::ZScore | Quantity::MeanCount => 2,
            Quantity::Index => {
                if lead == 0.0 || !lead.is_finite() {
                    3
                } else {
                    (2 - lead.abs().log10().floor() as i32).max(0) as usize
                }
            }
        }
    }

    /// The value as printed (angles in arcsec are converted).
    pub fn format(self, v: f64) -> String {
        self.format_with(v, self.decimals(v))
    }

    fn scale(self) -> f64 {
        if self == Quantity::AngleArcsecFromDeg {
            ARCSEC_PER_DEG
        } else {
            1.0
        }
    }

    fn format_with(self, v: f64, d: usize) -> String {
        fixed(v * self.scale(), d)
    }

    /// `mean ± sd [p5, p95]`, all with the decimals the mean calls for.
    pub fn mean_sd_range(self, mean: f64, sd: f64, p5: f64, p95: f64) -> String {
        let d = self.decimals(mean * self.scale());
        format!(
            "{} ± {} [{}, {}]",
            self.format_with(mean, d),
            self.format_with(sd, d),
            self.format_with(p5, d),
            self.format_with(p95, d)
        )
    }
}

/// A number for tick labels, legends and swept values: rounded to 10 significant digits
/// (hiding float noise such as `0.30000000000000004`), plain between 1e-4 and 1e6,
/// scientific (`1e-9`, `2.5e6`) outside.
pub fn number(v: f64) -> String {
    let r: f64 = format!("{v:.9e}").parse().unwrap_or(v);
    if r == 0.0 {
        "0".into()
    } else if (1e-4..1e6).contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_take_three_decimals_or_four_below_a_tenth() {
        assert_eq!(mm(0.3634), "0.363");
        assert_eq!(mm(1.1684), "1.168");
        assert_eq!(mm(0.03123), "0.0312");
        assert_eq!(mm(-0.0999), "-0.0999");
        assert_eq!(mm(-0.00001), "0.0000");
        assert_eq!(mm(12.0), "12.000");
    }

    #[test]
    fn percentages_rates_and_counts() {
        assert_eq!(pct(74.619), "74.6");
        assert_eq!(rate(1834.4204), "1,834");
        assert_eq!(rate(999.5), "1,000");
        assert_eq!(whole(1_234_567.0), "1,234,567");
        assert_eq!(whole(12.0), "12");
        assert_eq!(whole(-4321.0), "-4,321");
        assert_eq!(whole(0.2), "0");
    }

    #[test]
    fn angles_and_z_scores() {
        assert_eq!(deg(0.00403), "0.0040");
        assert_eq!(arcsec_from_deg(0.004), "14.4");
        assert_eq!(z(-13.7966), "-13.80");
        assert_eq!(z(-0.001), "0.00");
    }

    #[test]
    fn fixed_column_and_signed_rules() {
        assert_eq!(mm_col(0.0312), "0.031");
        assert_eq!(mm_col(-0.0001), "0.000");
        assert_eq!(signed(-0.0001, 3), "-0.000");
        assert_eq!(signed(1.23456, 3), "1.235");
        assert_eq!(plus(0.5, 3), "+0.500");
        assert_eq!(plus(-0.9821, 4), "-0.9821");
        assert_eq!(sci(0.018591, 4), "1.8591e-2");
        assert_eq!(setting_sci(1e-10), "1e-10");
        assert_eq!(setting(3.0), "3");
        assert_eq!(setting(2.5), "2.5");
        assert_eq!(mm_coarse(3820.64), "3820.6");
        assert_eq!(deg_coarse(20.0764), "20.076");
        assert_eq!(param(-0.00001, 4), "0.0000");
        assert_eq!(ratio(3.414), "3.41");
        assert_eq!(ms(7.46), "7.5");
    }

    #[test]
    fn significant_digits() {
        assert_eq!(significant(0.08607), "0.0861");
        assert_eq!(significant(0.00137), "0.00137");
        assert_eq!(significant(123.4), "123");
        assert_eq!(significant(2.0e-7), "2.00e-7");
    }

    #[test]
    fn a_cell_of_statistics_uses_the_precision_of_its_mean() {
        let q = Quantity::LengthMm;
        assert_eq!(
            q.mean_sd_range(0.363, 0.0521, 0.29, 0.45),
            "0.363 ± 0.052 [0.290, 0.450]"
        );
        assert_eq!(
            q.mean_sd_range(0.031, 0.002, 0.028, 0.034),
            "0.0310 ± 0.0020 [0.0280, 0.0340]"
        );
        assert_eq!(
            Quantity::Percent.mean_sd_range(74.619, 13.597, 44.837, 87.738),
            "74.6 ± 13.6 [44.8, 87.7]"
        );
        assert_eq!(Quantity::AngleArcsecFromDeg.format(0.0040), "14.4");
    }

    #[test]
    fn tick_numbers() {
        assert_eq!(number(0.1 + 0.2), "0.3");
        assert_eq!(number(10.0), "10");
        assert_eq!(number(-0.0), "0");
        assert_eq!(number(1e-9), "1e-9");
        assert_eq!(number(2.5e6), "2.5e6");
        assert_eq!(number(1000.0), "1000");
    }
}
