//! Streaming, exactly mergeable statistics over trials.
//!
//! A campaign's summary must be byte-identical whatever the thread count or the number of
//! shards it was split into, and its memory must not grow with the trial count. Floating-point
//! sums depend on the order of addition, so [`Stat`] keeps:
//! - the count and the sums `Σq`, `Σq²` of the values quantised to fixed point,
//!   `q = round(x · 2^FRAC_BITS)`, in `i128` — integer addition is associative, so any split
//!   and order give the same sums (resolution 2^-32 ≈ 2.3·10⁻¹⁰ in the value's unit);
//! - exact minimum and maximum;
//! - a histogram whose bucket is the value's sign, exponent and top [`MANTISSA_BITS`]
//!   mantissa bits (relative bucket width 2⁻⁷ ≈ 0.8 %), for percentiles; magnitudes below
//!   [`TINY`] share one bucket per sign. The number of buckets is bounded by the range of
//!   values (at most 2·2⁷ per binade between [`TINY`] and [`MAX_ABS`]), not by the number of
//!   trials; in practice it saturates within the first 10⁴ trials (about 10⁵ buckets over
//!   all of `paper-kr1000`'s statistics, a few MB), so a campaign's memory is flat in its
//!   trial count.
//!
//! Mean and sample standard deviation come from the exact sums; percentiles (p5, p50, p95)
//! interpolate linearly between order statistics (numpy's default) using the midpoint of
//! each bucket's actual values, so they are accurate to ±0.4 % relative (±[`TINY`] absolute
//! near zero; exact for repeated values) — well inside the sampling error of a percentile
//! over 10⁴ trials (≈1–2 % at p5/p95). Non-finite values are counted
//! separately and excluded.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Fixed-point fraction bits of the exact sums.
pub const FRAC_BITS: u32 = 32;
/// Mantissa bits kept in a histogram bucket key.
pub const MANTISSA_BITS: u32 = 7;
/// Magnitudes below this (2⁻²⁴ ≈ 6·10⁻⁸ in the value's unit) share one bucket per sign:
/// without the floor, the sparse binades near zero of signed quantities (errors, z-scores)
/// keep adding buckets as the trial count grows.
pub const TINY: f64 = 1.0 / (1u64 << 24) as f64;
/// Largest magnitude accepted into the exact sums (beyond it the value counts as out of
/// range): keeps `Σq²` within i128 for 10⁸ trials.
pub const MAX_ABS: f64 = 1.0e6;

/// Accumulator of one scalar metric over trials.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    /// Finite values pushed.
    pub n: u64,
    /// Values that were NaN, infinite or beyond ±[`MAX_ABS`] (excluded from the statistics).
    pub rejected: u64,
    /// Σ round(x·2^FRAC_BITS).
    pub sum_q: i128,
    /// Σ round(x·2^FRAC_BITS)².
    pub sum_q2: i128,
    /// Smallest value (None before the first).
    pub min: Option<f64>,
    /// Largest value.
    pub max: Option<f64>,
    /// Bucket key → count and the exact extremes of the values in it (see the module docs).
    pub hist: BTreeMap<i64, Bucket>,
}

/// One histogram bucket: how many values fell in it and their exact range. Merging takes
/// sums and extremes, so it is exact; the bucket's representative value is the midpoint of
/// its actual range (exact when all its values are equal, e.g. iteration counts).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bucket {
    /// Values in the bucket.
    pub count: u64,
    /// Smallest of them.
    pub min: f64,
    /// Largest of them.
    pub max: f64,
}

impl Bucket {
    fn merge(&mut self, other: &Bucket) {
        self.count += other.count;
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// The value standing for the bucket: the midpoint of its values' range.
    pub fn value(&self) -> f64 {
        0.5 * (self.min + self.max)
    }
}

/// Summary of a [`Stat`]: what `summary.json` reports per metric.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Number of finite values.
    pub n: u64,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1); 0 for a single value.
    pub sd: f64,
    /// 5th percentile.
    pub p5: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

fn bucket_key(x: f64) -> i64 {
    if x == 0.0 {
        return 0;
    }
    // The bits of |x| are monotone in |x|; dropping low mantissa bits groups neighbours.
    // Everything below TINY is key ±1; the others count up from ±2.
    let shift = 52 - MANTISSA_BITS;
    let floor = (TINY.to_bits() >> shift) as i64;
    let k = ((x.abs().to_bits() >> shift) as i64 - floor).max(-1) + 2;
    if x < 0.0 { -k } else { k }
}

impl Stat {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one value.
    pub fn push(&mut self, x: f64) {
        if !x.is_finite() || x.abs() > MAX_ABS {
            self.rejected += 1;
            return;
        }
        let q = (x * (1u64 << FRAC_BITS) as f64).round() as i128;
        self.n += 1;
        self.sum_q += q;
        self.sum_q2 += q * q;
        self.min = Some(self.min.map_or(x, |m| m.min(x)));
        self.max = Some(self.max.map_or(x, |m| m.max(x)));
        self.hist
            .entry(bucket_key(x))
            .and_modify(|b| {
                b.merge(&Bucket {
                    count: 1,
                    min: x,
                    max: x,
                })
            })
            .or_insert(Bucket {
                count: 1,
                min: x,
                max: x,
            });
    }

    /// Adds everything `other` has seen (exact: the result does not depend on the split).
    pub fn merge(&mut self, other: &Stat) {
        self.n += other.n;
        self.rejected += other.rejected;
        self.sum_q += other.sum_q;
        self.sum_q2 += other.sum_q2;
        self.min = match (self.min, other.min) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.max = match (self.max, other.max) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        for (k, b) in &other.hist {
            self.hist
                .entry(*k)
                .and_modify(|mine| mine.merge(b))
                .or_insert(*b);
        }
    }

    /// The value of the `rank`-th smallest (0-based), as its bucket's representative.
    fn order_stat(&self, rank: u64) -> f64 {
        let mut seen = 0;
        for b in self.hist.values() {
            seen += b.count;
            if rank < seen {
                return b.value();
            }
        }
        self.max.unwrap_or(f64::NAN)
    }

    /// Percentile `p` ∈ [0, 100] with linear interpolation between order statistics.
    pub fn percentile(&self, p: f64) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        let pos = (p / 100.0).clamp(0.0, 1.0) * (self.n - 1) as f64;
        let lo = pos.floor() as u64;
        let frac = pos - lo as f64;
        let a = self.order_stat(lo);
        if frac == 0.0 || lo + 1 >= self.n {
            return a;
        }
        a + (self.order_stat(lo + 1) - a) * frac
    }

    /// Mean, sd and percentiles; `None` when no finite value was pushed.
    pub fn summary(&self) -> Option<Summary> {
        if self.n == 0 {
            return None;
        }
        let scale = (1u64 << FRAC_BITS) as f64;
        let n = self.n as f64;
        let mean = self.sum_q as f64 / n / scale;
        let sd = if self.n > 1 {
            // n·Σq² − (Σq)² is exact in i128; divide last.
            let num = self.n as i128 * self.sum_q2 - self.sum_q * self.sum_q;
            ((num as f64) / (n * (n - 1.0))).max(0.0).sqrt() / scale
        } else {
            0.0
        };
        Some(Summary {
            n: self.n,
            mean,
            sd,
            p5: self.percentile(5.0),
            p50: self.percentile(50.0),
            p95: self.percentile(95.0),
            min: self.min.unwrap_or(f64::NAN),
            max: self.max.unwrap_or(f64::NAN),
        })
    }
}

/// Counts of categorical outcomes (stop reasons, ranks), in a stable order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Counts(pub BTreeMap<String, u64>);

impl Counts {
    /// Counts one occurrence of `key`.
    pub fn add(&mut self, key: impl Into<String>) {
        *self.0.entry(key.into()).or_insert(0) += 1;
    }

    /// [`Counts::add`] without allocating when `key` has been seen before.
    pub fn add_str(&mut self, key: &str) {
        match self.0.get_mut(key) {
            Some(n) => *n += 1,
            None => self.add(key),
        }
    }

    /// Adds another set of counts.
    pub fn merge(&mut self, other: &Counts) {
        for (k, v) in &other.0 {
            *self.0.entry(k.clone()).or_insert(0) += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn values(n: usize) -> Vec<f64> {
        // A fixed, irregular sequence with a long tail.
        (0..n)
            .map(|i| {
                let t = (i as f64 * 0.618_033_988_749_895).fract();
                0.3 + 0.2 * t + 2.0 * t.powi(8)
            })
            .collect()
    }

    #[test]
    fn matches_direct_formulas() {
        let v = values(1001);
        let mut s = Stat::new();
        v.iter().for_each(|x| s.push(*x));
        let sum = s.summary().unwrap();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
        assert!((sum.mean - mean).abs() < 1e-9, "{} vs {mean}", sum.mean);
        assert!((sum.sd - var.sqrt()).abs() < 1e-9);
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        for (p, got) in [(5.0, sum.p5), (50.0, sum.p50), (95.0, sum.p95)] {
            let pos = p / 100.0 * 1000.0;
            let exact = sorted[pos as usize];
            // Half a bucket's relative width.
            let tol = 0.5f64.powi(MANTISSA_BITS as i32 + 1);
            assert!(
                (got - exact).abs() <= tol * exact.abs(),
                "p{p}: {got} vs {exact}"
            );
        }
        assert_eq!(sum.min, sorted[0]);
        assert_eq!(sum.max, sorted[1000]);
    }

    #[test]
    fn non_finite_values_are_counted_not_summed() {
        let mut s = Stat::new();
        s.push(f64::NAN);
        s.push(f64::INFINITY);
        s.push(1.0);
        assert_eq!((s.n, s.rejected), (1, 2));
        assert_eq!(s.summary().unwrap().mean, 1.0);
        assert!(Stat::new().summary().is_none());
    }

    #[test]
    fn negative_and_zero_values_order_correctly() {
        let mut s = Stat::new();
        for x in [-3.0, -1.0, 0.0, 1.0, 3.0] {
            s.push(x);
        }
        let sum = s.summary().unwrap();
        assert!((sum.p50 - 0.0).abs() < 1e-12);
        assert!((s.percentile(25.0) + 1.0).abs() < 1e-3);
        assert!((s.percentile(100.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn bucket_count_is_bounded_whatever_the_trial_count() {
        // A symmetric, heavy-near-zero sample spread over many binades (like z-scores and
        // recovery errors): without the floor every new trial could open a new bucket.
        let mut s = Stat::new();
        let mut count_at = Vec::new();
        for i in 0..1_000_000u64 {
            let t = (i as f64 * 0.618_033_988_749_895).fract();
            let x = (t - 0.5) * 10f64.powf(-12.0 * (i as f64 * 0.754_877_666).fract());
            s.push(x);
            if [99_999, 999_999].contains(&i) {
                count_at.push(s.hist.len());
            }
        }
        // Per sign: one bucket below TINY, 2^MANTISSA_BITS per binade from TINY to 1.
        let bound = 2 * (1 + (1 << MANTISSA_BITS) * 24) + 1;
        assert!(count_at[1] <= bound, "{count_at:?} > {bound}");
        assert!(count_at[1] < count_at[0] + count_at[0] / 10, "{count_at:?}");
        // Magnitudes below TINY share one bucket per sign, ordered around zero.
        assert_eq!(bucket_key(TINY * 0.5), bucket_key(TINY * 1e-9));
        assert_eq!(bucket_key(-TINY * 0.5), -bucket_key(TINY * 0.25));
        assert!(bucket_key(TINY) > bucket_key(TINY * 0.999));
        assert!(bucket_key(-TINY) < bucket_key(-TINY * 0.999));
        assert!(bucket_key(TINY * 0.999) > bucket_key(0.0));
    }

    proptest! {
        /// Any split into shards and any order give identical accumulators and summaries.
        #[test]
        fn merge_is_exact_and_order_free(
            v in prop::collection::vec(-50.0..50.0f64, 1..200),
            cut in 0usize..200,
        ) {
            let cut = cut.min(v.len());
            let mut whole = Stat::new();
            v.iter().for_each(|x| whole.push(*x));
            let (mut a, mut b) = (Stat::new(), Stat::new());
            v[..cut].iter().rev().for_each(|x| a.push(*x));
            v[cut..].iter().for_each(|x| b.push(*x));
            b.merge(&a);
            prop_assert_eq!(&whole, &b);
            let (s1, s2) = (whole.summary().unwrap(), b.summary().unwrap());
            prop_assert_eq!(s1.mean.to_bits(), s2.mean.to_bits());
            prop_assert_eq!(s1.sd.to_bits(), s2.sd.to_bits());
            prop_assert_eq!(s1.p95.to_bits(), s2.p95.to_bits());
        }
    }
}
