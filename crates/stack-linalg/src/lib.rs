//! nalgebra's decompositions of small dense matrices on the stack, for the sizes a trial
//! meets: the symmetric eigenvalues of a minimal parameter set's scaled normal matrix
//! (observability, O1–O5) and the singular values of a 6 × N geometric Jacobian (the pose
//! sampler's condition number).
//!
//! nalgebra's decompositions of a dynamic matrix (`DMatrix`) copy it and allocate their
//! work vectors. The same algorithm instantiated for a compile-time size
//! (`SMatrix<f64, R, C>`) keeps everything on the stack and performs the same floating-point
//! operations in the same order, so it gives the same bits (tested at every size and one
//! beyond, `tests/`); a different decomposition, or one with a workspace, would change the
//! last bits of committed results. Sizes outside the ranges take the dynamic matrix (and
//! allocate).
//!
//! Each size is a copy of the algorithm in the binary, so only [`EIGEN_SIZES`] and
//! [`SVD_COLUMNS`] are instantiated, here and only here: a crate of its own, with its tests
//! outside the library, so that the 39 copies (about 12 s of build on two cores) are
//! compiled once a profile, not again in each dependent crate's unit-test build.

use std::ops::RangeInclusive;

use nalgebra::{DMatrix, SMatrix};

/// The sizes whose eigenvalues are computed on the stack: a minimal set of 12 to 42
/// parameters, from a small free set to an eight-joint arm's full set measured by points
/// (4N + 6 = 38) and a few to spare; the committed scenarios' are 27 and 30. (The match
/// arms of [`symmetric_eigenvalues_into`] list them: keep the two in step; a size here
/// without its arm fails a debug assertion and the tests.)
pub const EIGEN_SIZES: RangeInclusive<usize> = 12..=42;

/// The column counts N of a 6 × N matrix whose singular values are computed on the stack:
/// chains of 1 to 8 joints (serial arms, an arm on a track or two). (The same note as
/// [`EIGEN_SIZES`] on the match arms of [`singular_value_range_6xn`].)
pub const SVD_COLUMNS: RangeInclusive<usize> = 1..=8;

/// Writes the eigenvalues of the symmetric matrix `a` (n × n; both triangles read, as
/// nalgebra does) into `out` (cleared first), in nalgebra's order and with its bits:
/// `a.symmetric_eigenvalues()`. Allocates nothing for n in [`EIGEN_SIZES`] once `out` has
/// room for n values.
pub fn symmetric_eigenvalues_into(a: &DMatrix<f64>, out: &mut Vec<f64>) {
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
                    debug_assert!(!EIGEN_SIZES.contains(&n), "size {n} of EIGEN_SIZES has no arm");
                    out.extend(a.symmetric_eigenvalues().iter().copied());
                }
            }
        };
    }
    on_the_stack!(12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36 37
        38 39 40 41 42);
}

/// The largest and smallest singular values of the 6 × n matrix whose columns are
/// `columns` (column-major, `6 n` values), with nalgebra's bits:
/// `DMatrix::from_column_slice(6, n, columns).singular_values()`'s `max()` and `min()`.
/// Allocates nothing for n in [`SVD_COLUMNS`].
///
/// # Panics
/// If `columns.len() != 6 n` or n = 0.
pub fn singular_value_range_6xn(columns: &[f64], n: usize) -> (f64, f64) {
    assert!(n > 0 && columns.len() == 6 * n, "6 × {n} values expected");
    macro_rules! on_the_stack {
        ($($n:literal)*) => {
            match n {
                $($n => {
                    let sv = SMatrix::<f64, 6, $n>::from_column_slice(columns).singular_values();
                    (sv.max(), sv.min())
                })*
                n => {
                    debug_assert!(!SVD_COLUMNS.contains(&n), "{n} columns of SVD_COLUMNS have no arm");
                    let sv = DMatrix::from_column_slice(6, n, columns).singular_values();
                    (sv.max(), sv.min())
                }
            }
        };
    }
    on_the_stack!(1 2 3 4 5 6 7 8)
}
