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
    buf.clear();
    buf.resize(rows, 0.0);
    kinematics::simd::vectorised(
        #[inline(always)]
        || comb_impl(js, rows, terms, buf),
    )
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
    kinematics::simd::vectorised(
        #[inline(always)]
        || chol_impl(a, n, ld),
    )
}

/// Columns factored together before the trailing matrix is updated (one pass over the trailing
/// matrix per panel instead of per column).
pub(crate) const PANEL_COLS: usize = 8;

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
            let col_k = &mut a[k * ld..(k + 1) * ld];
            let d = col_k[k];
            if !(d > 0.0 && d.is_finite()) {
                return false;
            }
            let lkk = d.sqrt();
            col_k[k] = lkk;
            for v in &mut col_k[k + 1..n] {
                *v /= lkk;
            }
            downdate_impl(a, ld, &[k], k + 1..k0 + kb);
        }
        // The trailing columns, by the whole panel in one pass.
        let panel: [usize; PANEL_COLS] = std::array::from_fn(|i| k0 + i);
        downdate_impl(a, ld, &panel[..kb], k0 + kb..n);
        k0 += kb;
    }
    true
}

/// Solves `L Lᵀ x = b` in place (`b` becomes x) with the factor from [`cholesky_padded`]
/// (leading dimension `ld`).
pub(crate) fn cholesky_solve_padded(l: &[f64], n: usize, ld: usize, b: &mut [f64]) {
    kinematics::simd::vectorised(
        #[inline(always)]
        || solve_impl(l, n, ld, b),
    )
}

/// The forward substitution as element-wise updates (vectorised), the back substitution as
/// sequential dot products: the same bits at every width.
#[inline(always)]
fn solve_impl(l: &[f64], n: usize, ld: usize, b: &mut [f64]) {
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

/// The trailing update of right-looking Cholesky steps at the pivots `pivots` (ascending, at
/// most [`PANEL_COLS`], each below `cols.start`) on the columns `cols` of the n × n
/// column-major matrix `m` with leading dimension `ld` = [`padded_ld`]`(n)` (lower
/// triangle): `m_aj −= l_ab·l_jb` for every pivot b in order, j ∈ `cols`, j ≤ a < n, where
/// column b already holds L's column. A rank-1 step at pivot b is `downdate(m, n, ld, &[b],
/// b + 1..n)`; a panel of pivots applied at once gives every entry the same operations in
/// the same order as one step after the other (one pass over the trailing columns instead of
/// one per pivot). Vectorised at the run-time SIMD level over whole blocks of 8 rows, from
/// the block that holds row j (as in [`cholesky_padded`]: the rows above the diagonal inside
/// it, and the padding rows, receive values that are never read); each lower entry gets one
/// multiplication and one subtraction per pivot, so the bits do not depend on the width.
pub(crate) fn downdate(
    m: &mut [f64],
    n: usize,
    ld: usize,
    pivots: &[usize],
    cols: std::ops::Range<usize>,
) {
    assert!(ld == padded_ld(n) && m.len() >= ld * n && cols.end <= n);
    assert!(pivots.len() <= PANEL_COLS && pivots.is_sorted());
    assert!(pivots.last().is_none_or(|&b| b < cols.start));
    kinematics::simd::vectorised(
        #[inline(always)]
        || downdate_impl(m, ld, pivots, cols),
    )
}

#[inline(always)]
fn downdate_impl(m: &mut [f64], ld: usize, pivots: &[usize], cols: std::ops::Range<usize>) {
    if pivots.is_empty() || cols.is_empty() {
        return;
    }
    let (head, tail) = m.split_at_mut(cols.start * ld);
    let mut panel: [&[f64]; PANEL_COLS] = [&[]; PANEL_COLS];
    for (c, &b) in panel.iter_mut().zip(pivots) {
        *c = &head[b * ld..(b + 1) * ld];
    }
    let kb = pivots.len();
    for (jj, col_j) in tail.chunks_exact_mut(ld).take(cols.len()).enumerate() {
        let j = cols.start + jj;
        let mut ljk = [0.0; PANEL_COLS];
        for (l, c) in ljk.iter_mut().zip(&panel).take(kb) {
            *l = c[j];
        }
        update_column(col_j, &panel[..kb], &ljk[..kb], j / BLOCK * BLOCK, ld);
    }
}

/// Columns of L⁻¹ computed together by [`lower_inverse_gram`] (two AVX-512 vectors: two
/// independent dependency chains).
const INV_LANES: usize = 16;

/// `L⁻¹` and `L⁻ᵀL⁻¹` of a lower-triangular `r × r` factor: `l` row-major with row stride
/// `p` (row i at `i·p`, entries 0..=i read), `inv_d` the reciprocals of its diagonal.
/// Writes `li` (column-major, column c at `c·r`: `L⁻¹_ic`, zero above the diagonal) and the
/// symmetric `ginv` (row i at `i·r`).
///
/// The documented sums, whatever the SIMD level:
/// - `L⁻¹_cc = 1/L_cc`, and for i > c `L⁻¹_ic = (−Σ_{j=c}^{i−1} L_ij·L⁻¹_jc)·(1/L_ii)`,
///   the sum started at +0 and taken in j order (forward substitution, column by column);
/// - `(L⁻ᵀL⁻¹)_ij` (j ≤ i) = `Σ_{t=i}^{r−1} L⁻¹_ti·L⁻¹_tj` in t order, started at the
///   empty sum of `Iterator::sum`.
///
/// The forward substitutions of [`INV_LANES`] columns run together, lane by lane (each
/// column's sum is a sequential chain; together they fill the vector): a column's lane sums
/// from the batch's first column on, and the extra terms `L_ij·0` (j < c) leave its sum at
/// exactly +0 until its own first term, so every entry has the bits of the one-column
/// substitution (L is finite: it is the factor of a finite matrix).
pub(crate) fn lower_inverse_gram(
    l: &[f64],
    p: usize,
    inv_d: &[f64],
    r: usize,
    li: &mut [f64],
    ginv: &mut [f64],
) {
    assert!(r <= p && l.len() >= r * p && inv_d.len() >= r);
    assert!(li.len() >= r * r && ginv.len() >= r * r);
    kinematics::simd::vectorised(
        #[inline(always)]
        || inv_impl(l, p, inv_d, r, li, ginv),
    )
}

thread_local! {
    /// The batch buffer of [`inv_impl`], kept by the thread between calls.
    static BATCH: kinematics::kept::Kept<Vec<[[f64; INV_LANES / 2]; 2]>> =
        const { kinematics::kept::Kept::new() };
}

#[inline(always)]
fn inv_impl(l: &[f64], p: usize, inv_d: &[f64], r: usize, li: &mut [f64], ginv: &mut [f64]) {
    const H: usize = INV_LANES / 2;
    // xb[i] = L⁻¹_{i, c0..c0+16} of the current batch, as two halves (one vector each)
    // (the thread's buffer, zeroed; given back at the end).
    let mut xb = kinematics::kept::take_kept(&BATCH).unwrap_or_default();
    xb.clear();
    xb.resize(r, [[0.0; H]; 2]);
    // L⁻¹ row-major with the row stride padded to whole vectors (row t at t·rr), zero
    // past column r (from the thread's pool).
    let rr = r.div_ceil(H) * H;
    let mut lt = crate::scratch::zeros(r * rr);
    for c0 in (0..r).step_by(INV_LANES) {
        for i in c0..r {
            let row = &l[i * p + c0..i * p + i];
            let (mut v0, mut v1) = ([0.0; H], [0.0; H]);
            for (lij, xj) in row.iter().zip(&xb[c0..i]) {
                for t in 0..H {
                    v0[t] -= lij * xj[0][t];
                    v1[t] -= lij * xj[1][t];
                }
            }
            let d = inv_d[i];
            let mut x = [[0.0; H]; 2];
            for t in 0..H {
                x[0][t] = if c0 + t == i { d } else { v0[t] * d };
                x[1][t] = if c0 + H + t == i { d } else { v1[t] * d };
            }
            xb[i] = x;
        }
        for (t, c) in (c0..r.min(c0 + INV_LANES)).enumerate() {
            li[c * r..c * r + c].fill(0.0);
            for (i, x) in xb.iter().enumerate().skip(c) {
                li[c * r + i] = x[t / H][t % H];
                lt[i * rr + c] = x[t / H][t % H];
            }
        }
    }
    // Row i of the Gram matrix, eight entries j at a time, each summed over t in order in
    // a register.
    let sum0: f64 = std::iter::empty::<f64>().sum();
    for i in 0..r {
        for j0 in (0..=i).step_by(H) {
            let mut acc = [sum0; H];
            for t in i..r {
                let u = li[i * r + t];
                let w: &[f64; H] = lt[t * rr + j0..t * rr + j0 + H].try_into().expect("H");
                for q in 0..H {
                    acc[q] += u * w[q];
                }
            }
            for (q, v) in acc.iter().enumerate().take(i + 1 - j0) {
                let j = j0 + q;
                ginv[i * r + j] = *v;
                ginv[j * r + i] = *v;
            }
        }
    }
    kinematics::kept::keep(&BATCH, xb);
    crate::scratch::give_back(lt);
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

    /// The padded, block-wise downdates give every lower entry the bits of the plain
    /// column-by-column update, one pivot after the other or a panel of pivots at once (with
    /// skipped pivots, as the greedy factorisation skips dropped columns), reading nothing
    /// above the diagonal or in the padding rows (NaN there would spread into the lower
    /// triangle).
    #[test]
    fn downdates_match_the_plain_update() {
        for n in 1..=35 {
            let ld = padded_ld(n);
            let value = |r: usize, c: usize| ((r * 31 + c * 17) as f64 * 0.7).sin() * 3.0;
            let mut plain = vec![0.0; n * n];
            for c in 0..n {
                for r in c..n {
                    plain[c * n + r] = value(r, c);
                }
            }
            let padded0 = {
                let mut m = vec![f64::NAN; ld * n];
                for c in 0..n {
                    m[c * ld..c * ld + n].copy_from_slice(&plain[c * n..(c + 1) * n]);
                    m[c * ld..c * ld + c].fill(f64::NAN);
                }
                m
            };
            let pivot = |b: usize| b % 5 != 3;
            for b in (0..n).filter(|&b| pivot(b)) {
                for j in b + 1..n {
                    let ljb = plain[b * n + j];
                    for a in j..n {
                        let lab = plain[b * n + a];
                        plain[j * n + a] -= lab * ljb;
                    }
                }
            }
            // One pivot after the other.
            let mut one = padded0.clone();
            for b in (0..n).filter(|&b| pivot(b)) {
                downdate(&mut one, n, ld, &[b], b + 1..n);
            }
            // Panels: each pivot on the rest of its panel, then the panel's pivots at once
            // on the trailing columns.
            let mut panels = padded0.clone();
            for b0 in (0..n).step_by(PANEL_COLS) {
                let end = (b0 + PANEL_COLS).min(n);
                let kept: Vec<usize> = (b0..end).filter(|&b| pivot(b)).collect();
                for &b in &kept {
                    downdate(&mut panels, n, ld, &[b], b + 1..end);
                }
                downdate(&mut panels, n, ld, &kept, end..n);
            }
            for c in 0..n {
                for r in c..n {
                    let want = plain[c * n + r].to_bits();
                    assert_eq!(one[c * ld + r].to_bits(), want, "n {n} ({r}, {c})");
                    assert_eq!(panels[c * ld + r].to_bits(), want, "n {n} ({r}, {c})");
                }
            }
        }
    }

    /// The batched forward substitutions and the Gram matrix have the bits of the
    /// one-column loops, at every SIMD level and size (across batch boundaries).
    #[test]
    fn lower_inverse_gram_is_the_documented_sums() {
        use kinematics::simd::SimdLevel;
        let p = 50;
        for r in [1, 2, 15, 16, 17, 33, 43, 50] {
            // A well-conditioned lower factor with mixed signs (row stride p; NaN where it
            // must not be read).
            let mut l = vec![f64::NAN; r * p];
            let mut inv_d = vec![0.0; r];
            for i in 0..r {
                for j in 0..i {
                    l[i * p + j] = ((i * 13 + j * 7) as f64 * 0.91).sin() * 0.4;
                }
                l[i * p + i] = 1.0 + 0.3 * ((i as f64) * 1.7).cos();
                inv_d[i] = 1.0 / l[i * p + i];
            }
            // The plain loops.
            let mut li0 = vec![0.0; r * r];
            for c in 0..r {
                li0[c * r + c] = inv_d[c];
                for i in c + 1..r {
                    let mut v = 0.0;
                    for j in c..i {
                        v -= l[i * p + j] * li0[c * r + j];
                    }
                    li0[c * r + i] = v * inv_d[i];
                }
            }
            let mut g0 = vec![0.0; r * r];
            for i in 0..r {
                for j in 0..=i {
                    let v: f64 = (i..r).map(|t| li0[i * r + t] * li0[j * r + t]).sum();
                    g0[i * r + j] = v;
                    g0[j * r + i] = v;
                }
            }
            for level in [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512] {
                if level > SimdLevel::detect() {
                    continue;
                }
                let (mut li, mut g) = (vec![7.0; r * r], vec![7.0; r * r]);
                kinematics::simd::at_level(level, || inv_impl(&l, p, &inv_d, r, &mut li, &mut g));
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&li), bits(&li0), "{level:?} r {r}: L⁻¹");
                assert_eq!(bits(&g), bits(&g0), "{level:?} r {r}: L⁻ᵀL⁻¹");
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
