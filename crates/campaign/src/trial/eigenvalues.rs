//! The eigenvalues of a trial's symmetric matrix without allocating: nalgebra's
//! `symmetric_eigenvalues` on a fixed-size copy for the sizes a minimal parameter set has.
//!
//! nalgebra's eigenvalues of a dynamic matrix copy it and allocate the tridiagonal form's
//! vectors (five allocations a call, the most of a trial's steady state; issue 43). The same
//! algorithm instantiated for a compile-time size (`SMatrix<f64, N, N>`) keeps everything on
//! the stack and performs the same floating-point operations in the same order, so it gives
//! the same bits (the test `the_fixed_sizes_give_the_dynamic_bits`); a different
//! decomposition (or one with a workspace) would change the last bits of O1–O5 in the
//! committed results.
//!
//! Each size is a copy of the algorithm in the binary (about 0.2 s of release build a size,
//! 6 s for the 31), so only [`FIXED_SIZES`] are instantiated: from a small free set up to
//! the full minimal set of an eight-joint arm (4N + 6 = 38 for N revolute joints measured
//! by points) and a few to spare; the committed scenarios' are 27 and 30. Other sizes take
//! the dynamic matrix and allocate.

use nalgebra::{DMatrix, SMatrix};

/// The sizes computed on the stack: a minimal set of 12 to 42 parameters (the match arms of
/// [`symmetric_eigenvalues_into`] list them: keep the two in step; a size here without its
/// arm fails a debug assertion and the test).
pub(super) const FIXED_SIZES: std::ops::RangeInclusive<usize> = 12..=42;

/// Writes the eigenvalues of the symmetric matrix `a` (n × n; both triangles read, as
/// nalgebra does) into `out` (cleared first), in nalgebra's order and with its bits.
/// Allocates nothing for n in [`FIXED_SIZES`] once `out` has room for n values.
pub(super) fn symmetric_eigenvalues_into(a: &DMatrix<f64>, out: &mut Vec<f64>) {
    debug_assert!(a.is_square());
    out.clear();
    macro_rules! on_the_stack {
        ($($n:literal)*) => {
            match a.nrows() {
                $($n => {
                    let m = SMatrix::<f64, $n, $n>::from_iterator(a.iter().copied());
                    out.extend(m.symmetric_eigenvalues().iter().copied());
                })*
                n => {
                    debug_assert!(!FIXED_SIZES.contains(&n), "size {n} of FIXED_SIZES has no arm");
                    out.extend(a.symmetric_eigenvalues().iter().copied());
                }
            }
        };
    }
    on_the_stack!(12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36 37
        38 39 40 41 42);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Every fixed size (and a dynamic one on each side) gives nalgebra's dynamic bits on
    /// Gram matrices of random Jacobians over seven decades of scale, column-scaled (unit
    /// diagonal, as observability scales them) or not, rank-deficient or not. A size in the
    /// match arm whose literal differs from the matrix (a mistyped arm) or a different
    /// algorithm fails it, and so does a size of [`FIXED_SIZES`] left without an arm (a debug
    /// assertion).
    #[test]
    fn the_fixed_sizes_give_the_dynamic_bits() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(43);
        let mut out = Vec::new();
        for n in (FIXED_SIZES.start() - 1)..=(FIXED_SIZES.end() + 1) {
            for case in 0..12 {
                let rows = if case % 4 == 3 { n - 2 } else { 2 * n + 3 };
                let scale = 10f64.powi(case % 7 - 3);
                let j = DMatrix::from_fn(rows, n, |_, _| scale * rng.random_range(-1.0..1.0));
                let mut a = j.transpose() * &j;
                if case % 2 == 0 {
                    let d: Vec<f64> = (0..n).map(|k| a[(k, k)].sqrt()).collect();
                    for c in 0..n {
                        for r in 0..n {
                            a[(r, c)] /= d[r] * d[c];
                        }
                    }
                }
                symmetric_eigenvalues_into(&a, &mut out);
                let dynamic = a.symmetric_eigenvalues();
                assert_eq!(out.len(), n);
                for (k, (x, y)) in out.iter().zip(dynamic.iter()).enumerate() {
                    assert_eq!(x.to_bits(), y.to_bits(), "n = {n}, case {case}, λ_{k}");
                }
            }
        }
    }
}
