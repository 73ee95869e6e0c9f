//! The fixed-size decompositions give the dynamic matrices' bits at every size of their
//! ranges and one beyond (one on each side for the eigenvalues; 0 columns is refused),
//! where the dynamic path runs: a mistyped match arm (a
//! literal that is not the matrix's size panics in the fixed-size constructor), a size of a
//! range left without its arm (a debug assertion), or another algorithm fails these.

use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use stack_linalg::{
    EIGEN_SIZES, SVD_COLUMNS, singular_value_range_6xn, symmetric_eigenvalues_into,
};

/// Gram matrices of random Jacobians over seven decades of scale, column-scaled (unit
/// diagonal, as observability scales them) or not, rank-deficient or not.
#[test]
fn the_fixed_size_eigenvalues_are_the_dynamic_ones() {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(43);
    let mut out = Vec::new();
    for n in (EIGEN_SIZES.start() - 1)..=(EIGEN_SIZES.end() + 1) {
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

/// Random 6 × n matrices over seven decades, some with a zero row block (a prismatic
/// joint's orientation rows) or a repeated column (a singular configuration).
#[test]
fn the_fixed_size_singular_values_are_the_dynamic_ones() {
    let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(6);
    for n in *SVD_COLUMNS.start()..=(SVD_COLUMNS.end() + 1) {
        for case in 0..40 {
            let scale = 10f64.powi(case % 7 - 3);
            let mut cols: Vec<f64> = (0..6 * n)
                .map(|_| scale * rng.random_range(-1.0..1.0))
                .collect();
            if case % 5 == 1 {
                cols[3..6].fill(0.0);
            }
            if case % 5 == 2 && n > 1 {
                let (first, rest) = cols.split_at_mut(6);
                rest[..6].copy_from_slice(first);
            }
            let (max, min) = singular_value_range_6xn(&cols, n);
            let sv = DMatrix::from_column_slice(6, n, &cols).singular_values();
            assert_eq!(max.to_bits(), sv.max().to_bits(), "n = {n}, case {case}");
            assert_eq!(min.to_bits(), sv.min().to_bits(), "n = {n}, case {case}");
        }
    }
}
