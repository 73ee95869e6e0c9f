//! Design criteria on the information matrix, and their straightforward dense evaluation
//! (the reference the fast rank-3 scoring of [`mod@crate::select`] is tested against).
//!
//! With `B_i` the 3 × p block of pose i (the identification Jacobian of the minimal set,
//! column k multiplied by the physical scale `s_k`, see [`crate::Scale`]) and the design's
//! poses `S` (|S| = N):
//!
//! * `M = Σ_{i∈S} B_iᵀ B_i` (p × p);
//! * **D**: `log det M` (maximised);
//! * **A**: `trace M⁻¹` (minimised): the sum of the parameters' variances in units of their
//!   scale, per unit point noise;
//! * **E**: `λ_min(M)` (maximised): the worst-determined scaled direction;
//! * **I**: `trace(M⁻¹ W)` (minimised), `W = (1/n_w) Σ_w C_wᵀ C_w` over the workspace poses w
//!   (their blocks `C_w`, scaled alike): the mean over the workspace of the variance of the
//!   predicted point, `E_w[tr(C_w M⁻¹ C_wᵀ)]`, per unit noise variance (mm² per mm²). It does
//!   not depend on the scale `s` (it cancels between M and W);
//! * **O1, O3, O5** (maximised): the observability indices of `identify` on the singular
//!   values σ of the unit-norm-column Jacobian, `σ² = eig(D M D)`, `D = diag(M_kk^{-1/2})`:
//!   O1 = (∏σ)^{1/p}/√N, O3 = σ_min, O5 = (Σ 1/σ)⁻¹ ([`identify::Observability`]). They do
//!   not depend on `s` either.
//!
//! D is also independent of `s` for the *choice* (`log det(SMS) = log det M + 2 Σ log s_k`);
//! the scale matters for A and E only.

use std::fmt;
use std::str::FromStr;

use identify::Observability;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// A design criterion (see the module docs for the formulas).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// log det M, maximised.
    D,
    /// trace M⁻¹, minimised.
    A,
    /// λ_min(M), maximised.
    E,
    /// trace(M⁻¹ W), minimised.
    I,
    /// Observability index O1, maximised.
    O1,
    /// O3 = σ_min of the unit-norm-column Jacobian, maximised.
    O3,
    /// O5, maximised.
    O5,
}

impl Criterion {
    /// Every criterion.
    pub const ALL: [Criterion; 7] = [
        Criterion::D,
        Criterion::A,
        Criterion::E,
        Criterion::I,
        Criterion::O1,
        Criterion::O3,
        Criterion::O5,
    ];

    /// Lower-case name (`d`, `a`, `e`, `i`, `o1`, `o3`, `o5`).
    pub fn as_str(self) -> &'static str {
        match self {
            Criterion::D => "d",
            Criterion::A => "a",
            Criterion::E => "e",
            Criterion::I => "i",
            Criterion::O1 => "o1",
            Criterion::O3 => "o3",
            Criterion::O5 => "o5",
        }
    }

    /// Whether smaller values are better (A and I).
    pub fn minimised(self) -> bool {
        matches!(self, Criterion::A | Criterion::I)
    }

    /// Scored by rank-3 updates (D, A, I, O1); the others (E, O3, O5) need the spectrum of
    /// each trial matrix, O(p³) per evaluation.
    pub(crate) fn is_fast(self) -> bool {
        matches!(
            self,
            Criterion::D | Criterion::A | Criterion::I | Criterion::O1
        )
    }

    /// The utility the algorithms maximise: the value, negated when minimised.
    pub fn utility(self, value: f64) -> f64 {
        if self.minimised() { -value } else { value }
    }

    /// A short description with the formula.
    pub fn describe(self) -> &'static str {
        match self {
            Criterion::D => "D: log det M (larger is better)",
            Criterion::A => "A: trace M⁻¹ (smaller is better)",
            Criterion::E => "E: λ_min(M) (larger is better)",
            Criterion::I => {
                "I: trace(M⁻¹ W), mean predicted point variance on the workspace (smaller is better)"
            }
            Criterion::O1 => "O1: (∏σ)^(1/p)/√N (larger is better)",
            Criterion::O3 => "O3: σ_min (larger is better)",
            Criterion::O5 => "O5: (Σ 1/σ)⁻¹ (larger is better)",
        }
    }
}

impl fmt::Display for Criterion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Criterion {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Criterion::ALL
            .into_iter()
            .find(|c| c.as_str().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("unknown criterion {s:?} (d, a, e, i, o1, o3, o5)"))
    }
}

/// Eigenvalues of the unit-diagonal matrix `D M D` (D = diag(M_kk^{-1/2})), descending;
/// `None` if a diagonal entry is not positive.
pub(crate) fn unit_scaled_eigenvalues(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    let p = m.nrows();
    let d: Vec<f64> = (0..p).map(|k| m[(k, k)]).collect();
    if d.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return None;
    }
    let dm = DMatrix::from_fn(p, p, |i, j| m[(i, j)] / (d[i].sqrt() * d[j].sqrt()));
    let mut ev: Vec<f64> = dm.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    Some(ev)
}

/// O1–O5 of an information matrix over `n_poses` poses (σ = √eig(D M D), see the module
/// docs); `None` when M is singular.
pub fn observability(m: &DMatrix<f64>, n_poses: usize) -> Option<Observability> {
    let ev = unit_scaled_eigenvalues(m)?;
    let sv: Vec<f64> = ev.iter().map(|&l| l.max(0.0).sqrt()).collect();
    Observability::from_singular_values(&sv, n_poses)
}

/// Condition number σ_max/σ_min of the unit-norm-column Jacobian (as `identify` reports it);
/// `None` when M is singular.
pub fn condition_number(m: &DMatrix<f64>) -> Option<f64> {
    let ev = unit_scaled_eigenvalues(m)?;
    let (hi, lo) = (ev[0], *ev.last()?);
    (lo > 0.0).then(|| (hi / lo).sqrt())
}

/// The criterion's value on the information matrix `m` (p × p, scaled) of `n_poses` poses,
/// computed the straightforward way (nalgebra's Cholesky, inverse and symmetric eigenvalues
/// of the full matrix); `w` is the workspace matrix of I. `None` when M is singular (not
/// positive definite) or `w` is missing for I.
pub fn dense_value(
    criterion: Criterion,
    m: &DMatrix<f64>,
    w: Option<&DMatrix<f64>>,
    n_poses: usize,
) -> Option<f64> {
    let chol = m.clone().cholesky()?;
    match criterion {
        Criterion::D => Some(
            2.0 * chol
                .l_dirty()
                .diagonal()
                .iter()
                .map(|v| v.ln())
                .sum::<f64>(),
        ),
        Criterion::A => Some(chol.inverse().trace()),
        Criterion::I => Some((chol.inverse() * w?).trace()),
        Criterion::E => m.symmetric_eigenvalues().iter().copied().reduce(f64::min),
        Criterion::O1 => observability(m, n_poses).map(|o| o.o1),
        Criterion::O3 => observability(m, n_poses).map(|o| o.o3),
        Criterion::O5 => observability(m, n_poses).map(|o| o.o5),
    }
}
