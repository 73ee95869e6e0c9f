//! Small dense kernels on column-major `n × n` buffers (leading dimension n), without
//! allocation: the Cholesky factorisation and solve of the damped normal equations, a
//! symmetric matrix–vector product.
//!
//! The inner loops are element-wise updates (`y[i] -= a·x[i]`), never floating-point
//! reductions split across lanes, so a vectorised build gives the same bits as a scalar
//! one; sums that are reductions (the back substitution) run sequentially.

/// In-place Cholesky factorisation `A = L Lᵀ` of the symmetric matrix in `a` (column-major,
/// n × n; only the lower triangle is read). On success the lower triangle holds L (the
/// strict upper triangle is left as it was). Returns `false` when a pivot is not positive
/// and finite (A is not numerically positive definite).
///
/// Right-looking: after column k is scaled, the trailing lower triangle is updated column by
/// column with contiguous `axpy`s. (The unpadded reference of [`cholesky_padded`].)
#[cfg(test)]
pub(crate) fn cholesky_in_place(a: &mut [f64], n: usize) -> bool {
    debug_assert!(a.len() >= n * n);
    for k in 0..n {
        let (head, tail) = a.split_at_mut((k + 1) * n);
        let col_k = &mut head[k * n..];
        let d = col_k[k];
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let lkk = d.sqrt();
        col_k[k] = lkk;
        for v in &mut col_k[k + 1..n] {
            *v /= lkk;
        }
        let col_k = &col_k[..n];
        for (jj, col_j) in tail.chunks_exact_mut(n).enumerate() {
            let j = k + 1 + jj;
            let ljk = col_k[j];
            for (aij, lik) in col_j[j..n].iter_mut().zip(&col_k[j..n]) {
                *aij -= ljk * lik;
            }
        }
    }
    true
}

/// `‖Σ_i c_i · col(k_i)‖²` for columns of the column-major matrix `js` (`rows` rows): the
/// terms are added row by row in the given order, then the squares summed in row order, so
/// the result has the same bits at every vector width (the run-time SIMD level).
pub(crate) fn combination_norm_sq(
    js: &[f64],
    rows: usize,
    terms: &[(usize, f64)],
    buf: &mut Vec<f64>,
) -> f64 {
    use kinematics::simd::{SimdLevel, simd_level};
    buf.clear();
    buf.resize(rows, 0.0);
    match simd_level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: simd_level() never returns a level the CPU does not support.
        SimdLevel::Avx512 => unsafe { comb_avx512(js, rows, terms, buf) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { comb_avx2(js, rows, terms, buf) },
        _ => comb_impl(js, rows, terms, buf),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn comb_avx512(js: &[f64], rows: usize, terms: &[(usize, f64)], buf: &mut [f64]) -> f64 {
    comb_impl(js, rows, terms, buf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn comb_avx2(js: &[f64], rows: usize, terms: &[(usize, f64)], buf: &mut [f64]) -> f64 {
    comb_impl(js, rows, terms, buf)
}

#[inline(always)]
fn comb_impl(js: &[f64], rows: usize, terms: &[(usize, f64)], buf: &mut [f64]) -> f64 {
    if let Some((&(k0, c0), rest)) = terms.split_first() {
        for (o, v) in buf.iter_mut().zip(&js[k0 * rows..(k0 + 1) * rows]) {
            *o = c0 * v;
        }
        for &(k, c) in rest {
            for (o, v) in buf.iter_mut().zip(&js[k * rows..(k + 1) * rows]) {
                *o -= c * v;
            }
        }
    }
    buf.iter().map(|v| v * v).sum()
}

/// Rows per block of the padded factorisation.
const BLOCK: usize = 8;

/// Leading dimension of an n × n matrix for [`cholesky_padded`]: n rounded up to 8.
pub(crate) fn padded_ld(n: usize) -> usize {
    n.div_ceil(BLOCK) * BLOCK
}

/// The Cholesky factorisation `A = L Lᵀ` in place (see `cholesky_in_place`, its unpadded
/// reference) on a matrix stored with leading dimension `ld` =
/// [`padded_ld`]`(n)` (rows n..ld of every column zero on entry), vectorised at the run-time
/// SIMD level: the trailing updates run over whole blocks of 8 rows, starting at the block
/// that holds the diagonal. Rows above the diagonal inside that block (the strict upper
/// triangle) receive meaningless values that are never read; every lower entry gets the
/// same operations in the same order as in [`cholesky_in_place`], so the factor L is
/// bit for bit the same at any width.
pub(crate) fn cholesky_padded(a: &mut [f64], n: usize, ld: usize) -> bool {
    use kinematics::simd::{SimdLevel, simd_level};
    match simd_level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: simd_level() never returns a level the CPU does not support.
        SimdLevel::Avx512 => unsafe { chol_avx512(a, n, ld) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { chol_avx2(a, n, ld) },
        _ => chol_impl(a, n, ld),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn chol_avx512(a: &mut [f64], n: usize, ld: usize) -> bool {
    chol_impl(a, n, ld)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn chol_avx2(a: &mut [f64], n: usize, ld: usize) -> bool {
    chol_impl(a, n, ld)
}

/// Columns factored together before the trailing matrix is updated (one pass over the trailing
/// matrix per panel instead of per column).
const PANEL_COLS: usize = 4;

/// Updates `col_j` (rows `start..ld`) by the columns `cols` (each `ld` long) in order:
/// `v -= l_j,k · col_k` for every k — the per-entry sequence of the column-by-column method.
#[inline(always)]
fn update_column(col_j: &mut [f64], cols: &[&[f64]], ljk: &[f64], start: usize, ld: usize) {
    for blk in (start..ld).step_by(BLOCK) {
        let mut v: [f64; BLOCK] = col_j[blk..blk + BLOCK].try_into().expect("block");
        for (col_k, l) in cols.iter().zip(ljk) {
            let lk: [f64; BLOCK] = col_k[blk..blk + BLOCK].try_into().expect("block");
            for t in 0..BLOCK {
                v[t] -= l * lk[t];
            }
        }
        col_j[blk..blk + BLOCK].copy_from_slice(&v);
    }
}

#[inline(always)]
fn chol_impl(a: &mut [f64], n: usize, ld: usize) -> bool {
    debug_assert!(ld.is_multiple_of(BLOCK) && ld >= n && a.len() >= ld * n);
    let mut k0 = 0;
    while k0 < n {
        let kb = PANEL_COLS.min(n - k0);
        // The panel's columns, one after the other (each updates the later ones).
        for k in k0..k0 + kb {
            let (head, tail) = a.split_at_mut((k + 1) * ld);
            let col_k = &mut head[k * ld..];
            let d = col_k[k];
            if !(d > 0.0 && d.is_finite()) {
                return false;
            }
            let lkk = d.sqrt();
            col_k[k] = lkk;
            for v in &mut col_k[k + 1..n] {
                *v /= lkk;
            }
            let col_k = &col_k[..ld];
            for (jj, col_j) in tail.chunks_exact_mut(ld).take(k0 + kb - k - 1).enumerate() {
                let j = k + 1 + jj;
                update_column(col_j, &[col_k], &[col_k[j]], j / BLOCK * BLOCK, ld);
            }
        }
        // The trailing columns, by the whole panel in one pass.
        let (head, tail) = a.split_at_mut((k0 + kb) * ld);
        let mut cols: [&[f64]; PANEL_COLS] = [&[]; PANEL_COLS];
        for (i, c) in cols.iter_mut().enumerate().take(kb) {
            *c = &head[(k0 + i) * ld..(k0 + i + 1) * ld];
        }
        for (jj, col_j) in tail.chunks_exact_mut(ld).take(n - k0 - kb).enumerate() {
            let j = k0 + kb + jj;
            let mut ljk = [0.0; PANEL_COLS];
            for (l, c) in ljk.iter_mut().zip(&cols).take(kb) {
                *l = c[j];
            }
            update_column(col_j, &cols[..kb], &ljk[..kb], j / BLOCK * BLOCK, ld);
        }
        k0 += kb;
    }
    true
}

/// Solves `L Lᵀ x = b` in place (`b` becomes x) with the factor from [`cholesky_padded`]
/// (leading dimension `ld`).
pub(crate) fn cholesky_solve_padded(l: &[f64], n: usize, ld: usize, b: &mut [f64]) {
    for k in 0..n {
        let col = &l[k * ld..k * ld + n];
        b[k] /= col[k];
        let bk = b[k];
        let (_, rest) = b.split_at_mut(k + 1);
        for (bi, lik) in rest[..n - k - 1].iter_mut().zip(&col[k + 1..]) {
            *bi -= lik * bk;
        }
    }
    for k in (0..n).rev() {
        let col = &l[k * ld..k * ld + n];
        let mut s = b[k];
        for i in k + 1..n {
            s -= col[i] * b[i];
        }
        b[k] = s / col[k];
    }
}

/// Solves `L Lᵀ x = b` in place (`b` becomes x) with the factor from
/// [`cholesky_in_place`].
#[cfg(test)]
pub(crate) fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    // L y = b, column by column.
    for k in 0..n {
        let col = &l[k * n..(k + 1) * n];
        b[k] /= col[k];
        let bk = b[k];
        let (_, rest) = b.split_at_mut(k + 1);
        for (bi, lik) in rest[..n - k - 1].iter_mut().zip(&col[k + 1..]) {
            *bi -= lik * bk;
        }
    }
    // Lᵀ x = y, sequential dot products.
    for k in (0..n).rev() {
        let col = &l[k * n..(k + 1) * n];
        let mut s = b[k];
        for i in k + 1..n {
            s -= col[i] * b[i];
        }
        b[k] = s / col[k];
    }
}

/// The trailing update of a right-looking Cholesky step at pivot `b` of the n × n
/// column-major matrix `m` with leading dimension `ld` = [`padded_ld`]`(n)` (lower
/// triangle): `m_aj −= l_ab·l_jb` for b < j ≤ a < n, where column b already holds L's
/// column. Vectorised at the run-time SIMD level over whole blocks of 8 rows, from the block
/// that holds row j (as in [`cholesky_padded`]: the rows above the diagonal inside it, and
/// the padding rows, receive values that are never read); each lower entry gets one
/// multiplication and one subtraction, so the bits do not depend on the width.
pub(crate) fn rank1_downdate(m: &mut [f64], n: usize, ld: usize, b: usize) {
    use kinematics::simd::{SimdLevel, simd_level};
    debug_assert!(ld == padded_ld(n) && m.len() >= ld * n);
    match simd_level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: simd_level() never returns a level the CPU does not support.
        SimdLevel::Avx512 => unsafe { rank1_avx512(m, n, ld, b) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { rank1_avx2(m, n, ld, b) },
        _ => rank1_impl(m, n, ld, b),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn rank1_avx512(m: &mut [f64], n: usize, ld: usize, b: usize) {
    rank1_impl(m, n, ld, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rank1_avx2(m: &mut [f64], n: usize, ld: usize, b: usize) {
    rank1_impl(m, n, ld, b)
}

#[inline(always)]
fn rank1_impl(m: &mut [f64], n: usize, ld: usize, b: usize) {
    let (head, tail) = m.split_at_mut((b + 1) * ld);
    let col_b = &head[b * ld..];
    for (jj, col_j) in tail.chunks_exact_mut(ld).take(n - b - 1).enumerate() {
        let j = b + 1 + jj;
        update_column(col_j, &[col_b], &[col_b[j]], j / BLOCK * BLOCK, ld);
    }
}

/// `y = A x` for a full (both triangles stored) n × n matrix, column by column.
pub(crate) fn mat_vec(a: &[f64], n: usize, x: &[f64], y: &mut [f64]) {
    y[..n].fill(0.0);
    for (l, col) in a.chunks_exact(n).take(n).enumerate() {
        let xl = x[l];
        for (yk, akl) in y[..n].iter_mut().zip(col) {
            *yk += akl * xl;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn cholesky_and_solve_match_nalgebra() {
        for n in [9, 34] {
            check(n);
        }
    }

    /// The padded, block-wise rank-1 downdate gives every lower entry the bits of the plain
    /// column-by-column one, reading nothing above the diagonal or in the padding rows (NaN
    /// there would spread into the lower triangle).
    #[test]
    fn rank1_downdate_matches_the_plain_update() {
        for n in 1..=35 {
            let ld = padded_ld(n);
            let value = |r: usize, c: usize| ((r * 31 + c * 17) as f64 * 0.7).sin() * 3.0;
            let mut plain = vec![0.0; n * n];
            let mut padded = vec![f64::NAN; ld * n];
            for c in 0..n {
                for r in c..n {
                    plain[c * n + r] = value(r, c);
                    padded[c * ld + r] = value(r, c);
                }
            }
            for b in 0..n {
                for j in b + 1..n {
                    let ljb = plain[b * n + j];
                    for a in j..n {
                        let lab = plain[b * n + a];
                        plain[j * n + a] -= lab * ljb;
                    }
                }
                rank1_downdate(&mut padded, n, ld, b);
            }
            for c in 0..n {
                for r in c..n {
                    assert_eq!(
                        padded[c * ld + r].to_bits(),
                        plain[c * n + r].to_bits(),
                        "n {n} ({r}, {c})"
                    );
                }
            }
        }
    }

    fn check(n: usize) {
        let b = DMatrix::from_fn(3 * n, n, |i, j| {
            ((i * 7 + j * 3) as f64 * 0.37).sin() + (i == j) as u8 as f64
        });
        let a = b.transpose() * &b;
        let mut buf = a.as_slice().to_vec();
        assert!(cholesky_in_place(&mut buf, n));
        let mut x: Vec<f64> = (0..n).map(|k| k as f64 - 3.0).collect();
        let rhs = nalgebra::DVector::from_vec(x.clone());
        cholesky_solve(&buf, n, &mut x);
        let expected = a.clone().cholesky().unwrap().solve(&rhs);
        for k in 0..n {
            assert!((x[k] - expected[k]).abs() <= 1e-12 * expected.amax(), "{k}");
        }
        let mut y = vec![0.0; n];
        mat_vec(a.as_slice(), n, &x, &mut y);
        for k in 0..n {
            assert!((y[k] - rhs[k]).abs() <= 1e-10 * rhs.amax());
        }
        // The padded, vectorised factorisation gives the same factor and solution bits.
        let ld = padded_ld(n);
        let mut pad = vec![0.0; ld * n];
        for c in 0..n {
            pad[c * ld..c * ld + n].copy_from_slice(&a.as_slice()[c * n..(c + 1) * n]);
        }
        assert!(cholesky_padded(&mut pad, n, ld));
        for c in 0..n {
            for r in c..n {
                assert_eq!(pad[c * ld + r], buf[c * n + r]);
            }
        }
        let mut y: Vec<f64> = (0..n).map(|k| k as f64 - 3.0).collect();
        cholesky_solve_padded(&pad, n, ld, &mut y);
        assert_eq!(y, x);
        // Not positive definite.
        let mut bad = a.as_slice().to_vec();
        bad[0] = -1.0;
        assert!(!cholesky_in_place(&mut bad, n));
    }
}
