//! Gross errors of known truth, for studies of the outlier screen (the outlier table of
//! `docs/calibrating-real-data.md`, "Robust screening", and the tests): rows of a recording
//! moved by a given distance in seeded random directions. Deterministic: the same seed gives
//! the same rows and directions on every machine and thread count.

use measurements::MeasurementSet;

/// splitmix64: the draws, reproducible without a dependency (the next value of `state`).
pub fn next(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform draw in [0, 1) (53 bits).
fn uniform(state: &mut u64) -> f64 {
    (next(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// Moves `count` of the rows `among` (indices into `set.rows`, chosen by a seeded partial
/// Fisher–Yates draw) by `magnitude_mm` each, in directions uniform on the sphere
/// (`z = 2u − 1`, `φ = 2πv`, `(√(1−z²) cos φ, √(1−z²) sin φ, z)`). Returns the rows moved,
/// ascending. Rows without a point are left alone (and still counted).
pub fn contaminate(
    set: &mut MeasurementSet,
    among: &[usize],
    count: usize,
    magnitude_mm: f64,
    seed: u64,
) -> Vec<usize> {
    let mut state = seed;
    let mut pool = among.to_vec();
    let count = count.min(pool.len());
    for i in 0..count {
        let j = i + (next(&mut state) % (pool.len() - i) as u64) as usize;
        pool.swap(i, j);
    }
    let mut moved = pool[..count].to_vec();
    moved.sort_unstable();
    for &r in &moved {
        let z = 2.0 * uniform(&mut state) - 1.0;
        let phi = 2.0 * std::f64::consts::PI * uniform(&mut state);
        let rho = (1.0 - z * z).max(0.0).sqrt();
        let dir = [rho * phi.cos(), rho * phi.sin(), z];
        if let Some(p) = set.rows[r].point_mm.as_mut() {
            for (c, d) in p.iter_mut().zip(dir) {
                *c += magnitude_mm * d;
            }
        }
    }
    moved
}

/// A unit or frame corruption of a whole file, for studies of the plausibility checks: what a
/// wrong unit or a mirrored frame makes of every row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corruption {
    /// Joints in radians (read as degrees).
    Radians,
    /// Points in metres.
    Metres,
    /// Points in centimetres.
    Centimetres,
    /// Points in inches.
    Inches,
    /// Two point axes swapped (a mirrored frame).
    Swap(usize, usize),
    /// One point axis negated (a mirrored frame).
    Negate(usize),
}

impl Corruption {
    /// Applies the corruption to every row of `rows` (which must have points).
    pub fn apply(self, rows: &mut [measurements::Measurement]) {
        for r in rows {
            let p = r.point_mm.as_mut().expect("rows with points");
            match self {
                Corruption::Radians => r.q_deg.iter_mut().for_each(|q| *q = q.to_radians()),
                Corruption::Metres => p.iter_mut().for_each(|v| *v /= 1000.0),
                Corruption::Centimetres => p.iter_mut().for_each(|v| *v /= 10.0),
                Corruption::Inches => p.iter_mut().for_each(|v| *v /= 25.4),
                Corruption::Swap(a, b) => p.swap(a, b),
                Corruption::Negate(a) => p[a] = -p[a],
            }
        }
    }
}
