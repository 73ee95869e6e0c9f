//! Axes: a linear or log coordinate with explicit ticks ([`Coord`]), and where the ticks go
//! (1-2-5 steps; on a log axis 1-2-5 per decade or whole decades).

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;

use crate::fmt::number;

#[derive(Clone, Debug)]
pub(super) struct Coord {
    /// Base-10 logarithmic.
    pub log: bool,
    /// Lower end (log10 units on a log axis).
    pub lo: f64,
    /// Upper end (log10 units on a log axis).
    pub hi: f64,
    /// The labelled ticks, in values.
    pub ticks: Vec<f64>,
}

impl Coord {
    fn t(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }
}

impl Ranged for Coord {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        RangedCoordf64::from(self.lo..self.hi).map(&self.t(*value), limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        if self.log {
            10f64.powf(self.lo)..10f64.powf(self.hi)
        } else {
            self.lo..self.hi
        }
    }
}

impl ValueFormatter<f64> for Coord {
    fn format(value: &f64) -> String {
        number(*value)
    }
}

/// `m · 10^k` as the f64 nearest to its decimal value (so that it prints as e.g. `0.2`).
fn decimal(m: i64, k: i32) -> f64 {
    format!("{m}e{k}").parse().unwrap_or(f64::NAN)
}

/// 1-2-5 ticks inside `[lo, hi]`, at most about `max` of them.
pub(super) fn linear_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
    let span = hi - lo;
    if span <= 0.0 || !span.is_finite() {
        return vec![lo];
    }
    let raw = span / max as f64;
    let e = raw.log10().floor() as i32;
    let (m, e) = [1, 2, 5, 10]
        .iter()
        .map(|&m| (m, e))
        .find(|&(m, e)| decimal(m, e) >= raw)
        .unwrap_or((10, e));
    let step = decimal(m, e);
    let (k0, k1) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    (k0..=k1).map(|k| decimal(k * m, e)).collect()
}

/// Ticks for a log axis spanning `[10^lo, 10^hi]`: the densest of the mantissa sets 1–9,
/// {1, 2, 5}, {1} that gives at most 10 ticks, or every n-th power of ten over many decades;
/// the two ends if no such tick falls inside.
pub(super) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    const MAX_TICKS: usize = 10;
    let (k0, k1) = (lo.floor() as i32, hi.ceil() as i32);
    let inside = |v: &f64| (lo..=hi).contains(&v.log10());
    let all: [&[i64]; 3] = [&[1, 2, 3, 4, 5, 6, 7, 8, 9], &[1, 2, 5], &[1]];
    for mantissas in all {
        let ticks: Vec<f64> = (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |&m| decimal(m, k)))
            .filter(inside)
            .collect();
        if ticks.len() <= MAX_TICKS {
            return if ticks.len() < 2 {
                let r = |v: f64| format!("{v:.2e}").parse().unwrap_or(v);
                vec![r(10f64.powf(lo)), r(10f64.powf(hi))]
            } else {
                ticks
            };
        }
    }
    let step = ((k1 - k0) as usize).div_ceil(MAX_TICKS) as i32;
    (k0..=k1)
        .filter(|k| k.rem_euclid(step) == 0)
        .map(|k| decimal(1, k))
        .filter(inside)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks() {
        assert_eq!(
            log_ticks(-3.0, 3.0),
            vec![0.001, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]
        );
        assert_eq!(
            log_ticks(-1.0, 1.0),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0]
        );
        let wide = log_ticks(-9.5, 6.5);
        assert!(wide.len() <= 10 && wide.contains(&1.0), "{wide:?}");
        assert_eq!(
            linear_ticks(0.0, 1.0, 5),
            vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
        );
        assert_eq!(linear_ticks(0.31, 0.46, 5), vec![0.35, 0.4, 0.45]);
        assert_eq!(linear_ticks(-7.0, 13.0, 6), vec![-5.0, 0.0, 5.0, 10.0]);
    }
}
