//! Choosing N of K candidates: greedy forward selection with rank-3 updates, then an
//! exchange (modified Fedorov / DETMAX) until no swap improves the criterion, with optional
//! seeded restarts.
//!
//! # Regulariser and rank building
//!
//! The algorithms work on `M_ε = εI + Σ_{i∈S} B_iᵀB_i` with ε = 10⁻⁸ × the mean of
//! `tr(B_iᵀB_i)/p` over the pool (a hundred-millionth of one pose's information per
//! parameter), so that M_ε is invertible from the empty set on. Until M (without ε) has full
//! rank (at least ⌈p/3⌉ poses), every criterion greedily maximises `log det M_ε` (the
//! rank-building phase: A, E, I and the O indices are dominated by the ε directions until
//! then and cannot rank candidates). The reported value is always that of M itself.
//!
//! # Rank-3 updates (D, A, I, O1)
//!
//! With `M⁻¹` of the current M_ε, every candidate keeps the 3 × 3 matrices
//! `G_i = B_i M⁻¹ B_iᵀ` and (A, I) `H_i = B_i M⁻¹ W M⁻¹ B_iᵀ` (W = I for A). Adding candidate
//! i (matrix determinant lemma and Sherman–Morrison–Woodbury):
//! * `log det(M + B_iᵀB_i) = log det M + log det(I₃ + G_i)`,
//! * `tr((M + B_iᵀB_i)⁻¹ W) = tr(M⁻¹W) − tr((I₃ + G_i)⁻¹ H_i)`,
//! * O1's column norms: `M_kk + Σ_r B_i[r,k]²`.
//!
//! A swap (design point j out, candidate i in) is scored as the addition of i followed by
//! the removal of j — `M + B_iᵀB_i` is never closer to singular than M, whereas `M − B_jᵀB_j`
//! is singular when j is essential (N near p/3), where the other order loses every digit.
//! With `S = I₃ + G_i`, `X = B_i M⁻¹ B_jᵀ = B_i U` (U = M⁻¹B_jᵀ) and
//! `Y = B_i M⁻¹ W M⁻¹ B_jᵀ = B_i V` (V = M⁻¹WU):
//! * `G_j⁺ⁱ = G_j − Xᵀ S⁻¹ X` (j's G after adding i),
//!   `log det M' = log det M + log det S + log det(I₃ − G_j⁺ⁱ)`,
//! * `H_j⁺ⁱ = H_j − Xᵀ S⁻¹ Y − Yᵀ S⁻¹ X + Xᵀ S⁻¹ H_i S⁻¹ X`,
//!   `tr(M'⁻¹W) = tr(M⁻¹W) − tr(S⁻¹ H_i) + tr((I₃ − G_j⁺ⁱ)⁻¹ H_j⁺ⁱ)`:
//!
//! U and V once per design point, then O(p) per candidate (the two 3 × 3 products X, Y). After a move of candidate s with sign σ = ±1 (`U = M⁻¹Bₛᵀ`, `R = (σI₃ + BₛU)⁻¹`,
//! `V = M⁻¹WU`, `Q = UᵀWU`): `G_i ← G_i − C R Cᵀ`,
//! `H_i ← H_i − C R Eᵀ − E R Cᵀ + C R Q R Cᵀ` (C = B_i U, E = B_i V). `M⁻¹` itself is
//! refactored by Cholesky after every move (p³/3, negligible), and every G and H is
//! recomputed from scratch at the start of every exchange pass, so rounding cannot
//! accumulate.
//!
//! # E, O3, O5
//!
//! These need the spectrum of each trial matrix; they form it (O(p²)) and test it against
//! the best so far: E and O3 by a Cholesky factorisation of `M' − t·I` (resp. of the
//! unit-diagonal `D M' D − t²I`), which succeeds exactly when λ_min > t, and compute the
//! eigenvalues only of the winners; O5 always needs them. O(p³) per candidate: meant for
//! pools of hundreds to a few thousand. E first tries a Rayleigh-quotient certificate,
//! O(p) per candidate, that the candidate cannot beat the best so far (`EBound`); it skips
//! about half the factorisations of an exchange and halves a pose-selection sweep's time,
//! with the same design bit for bit.
//!
//! # Exchange
//!
//! For each design point in turn, the best replacement among the candidates not in the
//! design; the swap is made when it improves the utility by more than 10⁻⁹ relative. Passes
//! repeat until one makes no swap (or `max_passes`). Every accepted swap strictly improves
//! the criterion, so it never gets worse. Ties go to the lowest candidate index; no
//! randomness but the restarts' starting sets (ChaCha8, `seed`, stream = restart number), so
//! a seed gives the same design on any machine.

use nalgebra::{DMatrix, Matrix3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand::seq::index::sample;
use serde::{Deserialize, Serialize};

use crate::criterion::{Criterion, dense_value};
use crate::error::DesignError;
use crate::model::{InfoModel, add_outer};

/// Relative regulariser ε (see the module docs).
const RIDGE_REL: f64 = 1e-8;
/// Relative improvement a swap must bring.
const IMPROVE_RTOL: f64 = 1e-9;

/// How to choose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DesignOptions {
    /// The criterion.
    pub criterion: Criterion,
    /// Number of poses N to choose.
    pub poses: usize,
    /// Extra exchange runs from random starting sets (0: greedy start only).
    pub restarts: usize,
    /// Seed of the restarts' starting sets.
    pub seed: u64,
    /// Cap on exchange passes per run \[100\].
    pub max_passes: usize,
    /// Set from another thread to stop the design (Ctrl-C in Python): asked before every
    /// greedy step and every exchange slot; a stopped design is [`DesignError::Stopped`].
    /// Not part of the options' value (not serialised, equal whatever it holds).
    #[serde(skip)]
    pub stop: StopFlag,
}

/// A request to stop a long computation, shared with the thread that may make it (see
/// [`DesignOptions::stop`]): none by default.
#[derive(Clone, Debug, Default)]
pub struct StopFlag(Option<std::sync::Arc<std::sync::atomic::AtomicBool>>);

impl StopFlag {
    /// A flag that stops the computation once `flag` is true.
    pub fn new(flag: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Self {
        StopFlag(Some(flag))
    }

    /// Whether a stop was asked for.
    pub fn is_set(&self) -> bool {
        self.0
            .as_ref()
            .is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed))
    }

    fn check(&self) -> Result<(), DesignError> {
        if self.is_set() {
            Err(DesignError::Stopped)
        } else {
            Ok(())
        }
    }
}

/// Any two flags are equal: a stop request is not part of the options' value.
impl PartialEq for StopFlag {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl DesignOptions {
    /// `criterion`, `poses`, no restarts, seed 0, 100 passes.
    pub fn new(criterion: Criterion, poses: usize) -> Self {
        DesignOptions {
            criterion,
            poses,
            restarts: 0,
            seed: 0,
            max_passes: 100,
            stop: StopFlag::default(),
        }
    }
}

/// A design.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Design {
    /// The chosen candidates, ascending indices into the pool.
    pub selected: Vec<usize>,
    /// The criterion.
    pub criterion: Criterion,
    /// Its value on the design (on M, without the regulariser).
    pub value: f64,
    /// Its value on the greedy design, before the exchange.
    pub greedy_value: f64,
    /// Exchange passes of the run that won.
    pub passes: usize,
    /// Swaps made by that run.
    pub swaps: usize,
    /// Whether that run stopped because a pass made no swap (not on `max_passes`).
    pub converged: bool,
    /// The utility (value, negated when minimised; on M_ε) after the greedy phase and after
    /// every swap of the winning run: non-decreasing.
    pub trace: Vec<f64>,
}

type M3 = Matrix3<f64>;

/// `b (3×p row-major) · u (p×3 row-major)`: nine independent sums, each over k in order.
#[inline]
fn mul_bu(b: &[f64], u: &[f64], p: usize) -> M3 {
    let (r0, r1, r2) = (&b[..p], &b[p..2 * p], &b[2 * p..3 * p]);
    let u = &u[..3 * p];
    let mut c = [0.0; 9];
    for k in 0..p {
        let (b0, b1, b2) = (r0[k], r1[k], r2[k]);
        let (u0, u1, u2) = (u[3 * k], u[3 * k + 1], u[3 * k + 2]);
        c[0] += b0 * u0;
        c[1] += b0 * u1;
        c[2] += b0 * u2;
        c[3] += b1 * u0;
        c[4] += b1 * u1;
        c[5] += b1 * u2;
        c[6] += b2 * u0;
        c[7] += b2 * u1;
        c[8] += b2 * u2;
    }
    M3::new(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8])
}

/// `(b·u, b·v)` in one pass over the block: the same eighteen sums as two [`mul_bu`] calls,
/// each in the same order (same bits).
#[inline]
fn mul_bu2(b: &[f64], u: &[f64], v: &[f64], p: usize) -> (M3, M3) {
    let (r0, r1, r2) = (&b[..p], &b[p..2 * p], &b[2 * p..3 * p]);
    let (u, v) = (&u[..3 * p], &v[..3 * p]);
    let mut c = [0.0; 9];
    let mut e = [0.0; 9];
    for k in 0..p {
        let (b0, b1, b2) = (r0[k], r1[k], r2[k]);
        let (u0, u1, u2) = (u[3 * k], u[3 * k + 1], u[3 * k + 2]);
        let (v0, v1, v2) = (v[3 * k], v[3 * k + 1], v[3 * k + 2]);
        c[0] += b0 * u0;
        c[1] += b0 * u1;
        c[2] += b0 * u2;
        c[3] += b1 * u0;
        c[4] += b1 * u1;
        c[5] += b1 * u2;
        c[6] += b2 * u0;
        c[7] += b2 * u1;
        c[8] += b2 * u2;
        e[0] += b0 * v0;
        e[1] += b0 * v1;
        e[2] += b0 * v2;
        e[3] += b1 * v0;
        e[4] += b1 * v1;
        e[5] += b1 * v2;
        e[6] += b2 * v0;
        e[7] += b2 * v1;
        e[8] += b2 * v2;
    }
    (
        M3::new(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8]),
        M3::new(e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8]),
    )
}

/// `a · Bᵀ` for a p×p matrix given as its transpose `at` (column k of `at` is row k of
/// `a`, contiguous) and a 3×p block: p×3 row-major; each entry a sum over l in order.
fn mul_mbt(at: &DMatrix<f64>, b: &[f64], p: usize) -> Vec<f64> {
    let mut u = vec![0.0; 3 * p];
    mul_mbt_into(at, b, p, &mut u);
    u
}

/// [`mul_mbt`] into `u`.
fn mul_mbt_into(at: &DMatrix<f64>, b: &[f64], p: usize, u: &mut [f64]) {
    let (r0, r1, r2) = (&b[..p], &b[p..2 * p], &b[2 * p..3 * p]);
    let data = at.as_slice();
    for k in 0..p {
        let row = &data[k * p..(k + 1) * p];
        let (mut s0, mut s1, mut s2) = (0.0, 0.0, 0.0);
        for l in 0..p {
            s0 += row[l] * r0[l];
            s1 += row[l] * r1[l];
            s2 += row[l] * r2[l];
        }
        u[3 * k] = s0;
        u[3 * k + 1] = s1;
        u[3 * k + 2] = s2;
    }
}

/// `a · u` for p×p (given as its transpose, see [`mul_mbt`]) and p×3 row-major.
fn mul_mu(at: &DMatrix<f64>, u: &[f64], p: usize) -> Vec<f64> {
    let data = at.as_slice();
    let mut v = vec![0.0; 3 * p];
    for k in 0..p {
        let row = &data[k * p..(k + 1) * p];
        for c in 0..3 {
            let mut s = 0.0;
            for l in 0..p {
                s += row[l] * u[3 * l + c];
            }
            v[3 * k + c] = s;
        }
    }
    v
}

/// `uᵀ v` for two p×3 row-major matrices.
fn mul_utv(u: &[f64], v: &[f64], p: usize) -> M3 {
    let mut q = M3::zeros();
    for k in 0..p {
        for a in 0..3 {
            for b in 0..3 {
                q[(a, b)] += u[3 * k + a] * v[3 * k + b];
            }
        }
    }
    q
}

fn ln_det3(m: &M3) -> f64 {
    let d = m.determinant();
    if d > 0.0 { d.ln() } else { f64::NEG_INFINITY }
}

struct State<'a> {
    model: &'a InfoModel,
    crit: Criterion,
    p: usize,
    ridge: f64,
    /// Σ B_iᵀB_i over the set (no ridge).
    m: DMatrix<f64>,
    /// (M + εI)⁻¹.
    minv: DMatrix<f64>,
    logdet: f64,
    /// W (identity for A); only for A and I.
    w: Option<DMatrix<f64>>,
    trw: f64,
    g: Vec<M3>,
    /// Per candidate: `(I₃ + G_i)⁻¹` and `log det(I₃ + G_i)` (None when singular), kept
    /// with G.
    s_cache: Vec<Option<(M3, f64)>>,
    h: Vec<M3>,
    /// Σ_r B_i[r,k]² per candidate (O1).
    colsq: Vec<f64>,
    set: Vec<usize>,
    in_set: Vec<bool>,
    /// Rank-building phase: D on M_ε whatever the criterion.
    building: bool,
    /// The caller's stop request ([`DesignOptions::stop`]): the scans over the candidates
    /// end early once it is set (every [`STOP_EVERY`] candidates), and [`run`] returns
    /// [`DesignError::Stopped`].
    stop: StopFlag,
}

/// How many candidates a scan goes through between two looks at the stop request.
const STOP_EVERY: usize = 4096;

impl<'a> State<'a> {
    fn new(model: &'a InfoModel, crit: Criterion, ridge: f64, colsq: Vec<f64>) -> Self {
        let p = model.p;
        let w = match crit {
            Criterion::A => Some(DMatrix::identity(p, p)),
            Criterion::I => Some(model.workspace.clone()),
            _ => None,
        };
        let mut s = State {
            model,
            crit,
            p,
            ridge,
            m: DMatrix::zeros(p, p),
            minv: DMatrix::zeros(p, p),
            logdet: 0.0,
            w,
            trw: 0.0,
            g: Vec::new(),
            s_cache: Vec::new(),
            h: Vec::new(),
            colsq,
            set: Vec::new(),
            in_set: vec![false; model.n_candidates],
            building: true,
            stop: StopFlag::default(),
        };
        s.factor().expect("εI is positive definite");
        s
    }

    /// The criterion the scores use now.
    fn active(&self) -> Criterion {
        if self.building {
            Criterion::D
        } else {
            self.crit
        }
    }

    /// Whether the scores come from the rank-3 updates: a fast criterion on 3-row blocks
    /// (points). Blocks of 6 or 3k rows are scored densely, every criterion.
    fn fast(&self) -> bool {
        self.model.rows == 3 && self.active().is_fast()
    }

    fn uses_h(&self) -> bool {
        matches!(self.active(), Criterion::A | Criterion::I)
    }

    fn ridged(&self) -> DMatrix<f64> {
        let mut r = self.m.clone();
        for k in 0..self.p {
            r[(k, k)] += self.ridge;
        }
        r
    }

    /// M_ε⁻¹, log det M_ε and tr(M_ε⁻¹W) from a fresh Cholesky factorisation.
    fn factor(&mut self) -> Result<(), DesignError> {
        let chol = self
            .ridged()
            .cholesky()
            .ok_or_else(|| DesignError::Numerical("M + εI is not positive definite".into()))?;
        self.logdet = 2.0
            * chol
                .l_dirty()
                .diagonal()
                .iter()
                .map(|v| v.ln())
                .sum::<f64>();
        self.minv = chol.inverse();
        if let Some(w) = &self.w {
            self.trw = (&self.minv * w).trace();
        }
        Ok(())
    }

    /// G (and H) of every candidate from scratch.
    fn refresh(&mut self) {
        let (p, k) = (self.p, self.model.n_candidates);
        if !self.fast() {
            return;
        }
        let uses_h = self.uses_h();
        self.g.resize(k, M3::zeros());
        if uses_h {
            self.h.resize(k, M3::zeros());
        }
        let mw_t = self
            .w
            .as_ref()
            .map(|w| (&self.minv * w * &self.minv).transpose());
        let minv_t = self.minv.transpose();
        let mut u = vec![0.0; 3 * p];
        for i in 0..k {
            if i % STOP_EVERY == 0 && self.stop.is_set() {
                return;
            }
            let b = self.model.block(i);
            mul_mbt_into(&minv_t, b, p, &mut u);
            self.g[i] = mul_bu(b, &u, p);
            if uses_h && let Some(mw_t) = &mw_t {
                mul_mbt_into(mw_t, b, p, &mut u);
                self.h[i] = mul_bu(b, &u, p);
            }
        }
        self.update_s_cache();
    }

    fn update_s_cache(&mut self) {
        self.s_cache.clear();
        self.s_cache.extend(self.g.iter().map(|g| {
            let sm = M3::identity() + g;
            sm.try_inverse().map(|inv| (inv, ln_det3(&sm)))
        }));
    }

    fn diag_term(&self, i: Option<usize>, sign_i: f64, j: Option<usize>) -> f64 {
        let p = self.p;
        let mut s = 0.0;
        for k in 0..p {
            let mut d = self.m[(k, k)] + self.ridge;
            if let Some(i) = i {
                d += sign_i * self.colsq[i * p + k];
            }
            if let Some(j) = j {
                d -= self.colsq[j * p + k];
            }
            s += d.ln();
        }
        s
    }

    /// The utility of the current set (on M_ε).
    fn utility(&self) -> f64 {
        match self.active() {
            Criterion::D => self.logdet,
            Criterion::A | Criterion::I => -self.trw,
            Criterion::O1 => {
                (self.logdet - self.diag_term(None, 0.0, None)) / (2.0 * self.p as f64)
            }
            c => slow_utility(c, &self.ridged(), None, self.set.len(), f64::NEG_INFINITY)
                .unwrap_or(f64::NEG_INFINITY),
        }
    }

    /// Utility after adding candidate i (fast criteria).
    fn add_utility(&self, i: usize) -> f64 {
        let ip = M3::identity() + self.g[i];
        match self.active() {
            Criterion::D => self.logdet + ln_det3(&ip),
            Criterion::A | Criterion::I => match ip.try_inverse() {
                Some(inv) => -(self.trw - (inv * self.h[i]).trace()),
                None => f64::NEG_INFINITY,
            },
            Criterion::O1 => {
                (self.logdet + ln_det3(&ip) - self.diag_term(Some(i), 1.0, None))
                    / (2.0 * self.p as f64)
            }
            _ => unreachable!("slow criteria are scored densely"),
        }
    }

    /// Adds (sign 1) or removes (sign −1) candidate s, updating G and H by rank-3 formulas.
    fn apply(&mut self, s: usize, sign: f64) -> Result<(), DesignError> {
        let p = self.p;
        let b = self.model.block(s);
        if self.fast() && !self.g.is_empty() {
            let minv_t = self.minv.transpose();
            let u = mul_mbt(&minv_t, b, p);
            let sm = M3::identity() * sign + mul_bu(b, &u, p);
            let r = sm
                .try_inverse()
                .ok_or_else(|| DesignError::Numerical("singular rank-3 update".into()))?;
            let hv = if self.uses_h() {
                let w = self.w.as_ref().expect("W for A and I");
                let wu = mul_mu(&w.transpose(), &u, p);
                let v = mul_mu(&minv_t, &wu, p);
                let q = mul_utv(&u, &wu, p);
                Some((v, q))
            } else {
                None
            };
            for i in 0..self.model.n_candidates {
                let bi = self.model.block(i);
                let (c, e) = match &hv {
                    Some((v, _)) => {
                        let (c, e) = mul_bu2(bi, &u, v, p);
                        (c, Some(e))
                    }
                    None => (mul_bu(bi, &u, p), None),
                };
                let cr = c * r;
                if let (Some((_, q)), Some(e)) = (&hv, e) {
                    let er = e * r;
                    self.h[i] += -cr * e.transpose() - er * c.transpose() + cr * q * cr.transpose();
                }
                self.g[i] -= cr * c.transpose();
            }
            self.update_s_cache();
        }
        add_outer(&mut self.m, b, self.model.rows, p, sign);
        if sign > 0.0 {
            self.set.push(s);
            self.in_set[s] = true;
        } else {
            let pos = self.set.iter().position(|&x| x == s).expect("in the set");
            self.set.remove(pos);
            self.in_set[s] = false;
        }
        self.factor()
    }

    /// The best candidate to add: (index, utility); ties to the lowest index.
    fn best_addition(&self) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        let fast = self.fast();
        let base = if fast { None } else { Some(self.ridged()) };
        let bound = base.as_ref().and_then(|b| EBound::new(self.active(), b));
        for i in 0..self.model.n_candidates {
            if i % STOP_EVERY == 0 && self.stop.is_set() {
                break;
            }
            if self.in_set[i] {
                continue;
            }
            let t = best.map_or(f64::NEG_INFINITY, |b| b.1);
            if let Some(b) = &bound
                && b.cannot_exceed(self.model.block(i), t)
            {
                continue;
            }
            let u = if fast {
                Some(self.add_utility(i))
            } else {
                let mut m = base.clone().expect("dense base");
                add_outer(&mut m, self.model.block(i), self.model.rows, self.p, 1.0);
                slow_utility(self.active(), &m, self.w.as_ref(), self.set.len() + 1, t)
            };
            if let Some(u) = u
                && u.is_finite()
                && (best.is_none() || u > t)
            {
                best = Some((i, u));
            }
        }
        best
    }

    /// The best replacement of design point j: (candidate, utility of the swapped set).
    fn best_swap(&self, j: usize, floor: f64) -> Option<(usize, f64)> {
        let p = self.p;
        let mut best: Option<(usize, f64)> = None;
        let bj = self.model.block(j);
        if !self.fast() {
            let rows = self.model.rows;
            let mut base = self.ridged();
            add_outer(&mut base, bj, rows, p, -1.0);
            let bound = EBound::new(self.active(), &base);
            let mut m = base.clone();
            for i in 0..self.model.n_candidates {
                if i % STOP_EVERY == 0 && self.stop.is_set() {
                    break;
                }
                if self.in_set[i] {
                    continue;
                }
                let t = best.map_or(floor, |b| b.1);
                if let Some(b) = &bound
                    && b.cannot_exceed(self.model.block(i), t)
                {
                    continue;
                }
                m.copy_from(&base);
                add_outer(&mut m, self.model.block(i), rows, p, 1.0);
                if let Some(u) = slow_utility(self.active(), &m, self.w.as_ref(), self.set.len(), t)
                    && u > t
                {
                    best = Some((i, u));
                }
            }
            return best;
        }
        // Add i first, then remove j (see the module docs): M + B_iᵀB_i is never closer to
        // singular than M, so no inverse of (I − G_j) is formed.
        let minv_t = self.minv.transpose();
        let u = mul_mbt(&minv_t, bj, p);
        let crit = self.active();
        let lin = matches!(crit, Criterion::A | Criterion::I);
        let v = if lin {
            let w = self.w.as_ref().expect("W for A and I");
            let wu = mul_mu(&w.transpose(), &u, p);
            Some(mul_mu(&minv_t, &wu, p))
        } else {
            None
        };
        let diag_j: Vec<f64> = (0..p)
            .map(|k| self.m[(k, k)] + self.ridge - self.colsq[j * p + k])
            .collect();
        let (gj, hj) = (self.g[j], if lin { self.h[j] } else { M3::zeros() });
        for i in 0..self.model.n_candidates {
            if i % STOP_EVERY == 0 && self.stop.is_set() {
                break;
            }
            if self.in_set[i] {
                continue;
            }
            let bi = self.model.block(i);
            let Some((s_inv, ld_s)) = self.s_cache[i] else {
                continue;
            };
            let (x, y) = match &v {
                Some(v) => {
                    let (x, y) = mul_bu2(bi, &u, v, p);
                    (x, Some(y))
                }
                None => (mul_bu(bi, &u, p), None),
            };
            let xt_s = x.transpose() * s_inv;
            let rem = M3::identity() - gj + xt_s * x;
            let val = match crit {
                Criterion::D => self.logdet + ld_s + ln_det3(&rem),
                Criterion::O1 => {
                    let mut s = 0.0;
                    for (k, d) in diag_j.iter().enumerate() {
                        s += (d + self.colsq[i * p + k]).ln();
                    }
                    (self.logdet + ld_s + ln_det3(&rem) - s) / (2.0 * p as f64)
                }
                _ => {
                    let y = y.expect("linear criterion");
                    let hi = self.h[i];
                    let trw_i = self.trw - (s_inv * hi).trace();
                    let hj_i =
                        hj - xt_s * y - y.transpose() * s_inv * x + xt_s * hi * xt_s.transpose();
                    match rem.try_inverse() {
                        Some(r) if rem.determinant() > 0.0 => -(trw_i + (r * hj_i).trace()),
                        _ => f64::NEG_INFINITY,
                    }
                }
            };
            if val.is_finite() && val > best.map_or(floor, |b| b.1) {
                best = Some((i, val));
            }
        }
        best
    }

    fn full_rank(&self) -> bool {
        if self.model.rows * self.set.len() < self.p {
            return false;
        }
        match crate::criterion::unit_scaled_eigenvalues(&self.m) {
            Some(ev) => ev[ev.len() - 1] > 1e-12 * ev[0],
            None => false,
        }
    }
}

/// E's shortcut: a certificate, O(3p) per candidate, that adding candidate i to `base`
/// cannot lift the smallest eigenvalue above the best so far `t`, so that its O(p³) test (a
/// Cholesky factorisation of `M' − t·I`) is skipped.
///
/// For any vector u, `λ_min(M') ≤ uᵀM'u / uᵀu` (Rayleigh), and with `M' = base + B_iᵀB_i`:
/// `uᵀM'u = uᵀ·base·u + |B_i u|²`. With u the eigenvector of base's smallest eigenvalue the
/// bound is tight for every candidate that leaves that direction weak. A candidate is skipped
/// only when the bound is below `t` by 10⁻⁶ relative, far beyond the rounding of the
/// factorisation it replaces (p·ε·‖M'‖), so the design is the same bit for bit.
struct EBound {
    /// The eigenvector of base's smallest eigenvalue.
    u: Vec<f64>,
    /// `uᵀ·base·u`.
    r_base: f64,
    /// `uᵀu`.
    uu: f64,
}

impl EBound {
    /// The shortcut for E on `base` (`None` for other criteria).
    fn new(crit: Criterion, base: &DMatrix<f64>) -> Option<EBound> {
        if crit != Criterion::E {
            return None;
        }
        let eig = base.clone().symmetric_eigen();
        let k = eig.eigenvalues.imin();
        let u: Vec<f64> = eig.eigenvectors.column(k).iter().copied().collect();
        let bu = base * nalgebra::DVector::from_column_slice(&u);
        let r_base = u.iter().zip(bu.iter()).map(|(a, b)| a * b).sum();
        let uu = u.iter().map(|a| a * a).sum();
        Some(EBound { u, r_base, uu })
    }

    /// Whether candidate block `b` (rows × p, row-major) certainly cannot beat `t`.
    fn cannot_exceed(&self, b: &[f64], t: f64) -> bool {
        if !t.is_finite() {
            return false;
        }
        let p = self.u.len();
        let q: f64 = b
            .chunks_exact(p)
            .map(|row| {
                let d: f64 = row.iter().zip(&self.u).map(|(a, c)| a * c).sum();
                d * d
            })
            .sum();
        (self.r_base + q) / self.uu < t - 1e-6 * t.abs()
    }
}

/// The utility of a criterion scored densely on `m` if it exceeds `t` (`None` otherwise or
/// when singular); E and O3 decide by a shifted Cholesky factorisation first. `w`: the
/// workspace matrix of I.
fn slow_utility(
    crit: Criterion,
    m: &DMatrix<f64>,
    w: Option<&DMatrix<f64>>,
    n_poses: usize,
    t: f64,
) -> Option<f64> {
    let p = m.nrows();
    match crit {
        Criterion::E => {
            if t.is_finite() {
                let mut s = m.clone();
                for k in 0..p {
                    s[(k, k)] -= t;
                }
                s.cholesky()?;
            }
            dense_value(crit, m, None, n_poses)
        }
        Criterion::O3 => {
            if t.is_finite() && t > 0.0 {
                let d: Vec<f64> = (0..p).map(|k| m[(k, k)].sqrt()).collect();
                let s = DMatrix::from_fn(p, p, |i, j| {
                    m[(i, j)] / (d[i] * d[j]) - if i == j { t * t } else { 0.0 }
                });
                s.cholesky()?;
            }
            dense_value(crit, m, None, n_poses)
        }
        // The fast criteria on the utility scale of `State::utility` (blocks of more than
        // 3 rows score them densely).
        Criterion::A | Criterion::I => {
            let w = if crit == Criterion::I { w } else { None };
            let inv = m.clone().cholesky()?.inverse();
            let tr = match w {
                Some(w) => (inv * w).trace(),
                None => inv.trace(),
            };
            Some(-tr).filter(|&u| u > t || !t.is_finite())
        }
        Criterion::O1 => {
            let ld = dense_value(Criterion::D, m, None, n_poses)?;
            let diag: f64 = (0..p).map(|k| m[(k, k)].ln()).sum();
            Some((ld - diag) / (2.0 * p as f64)).filter(|&u| u > t || !t.is_finite())
        }
        _ => dense_value(crit, m, None, n_poses).filter(|&u| u > t || !t.is_finite()),
    }
}

/// One run: the set, the greedy value, passes, swaps, converged, the utility trace.
type RunOutcome = (Vec<usize>, f64, usize, usize, bool, Vec<f64>);

/// Runs greedy selection then the exchange, or (with `start`) the exchange from `start`.
fn run(
    model: &InfoModel,
    opts: &DesignOptions,
    ridge: f64,
    colsq: &[f64],
    start: Option<Vec<usize>>,
) -> Result<RunOutcome, DesignError> {
    let mut st = State::new(model, opts.criterion, ridge, colsq.to_vec());
    st.stop = opts.stop.clone();
    match start {
        None => {
            st.refresh();
            while st.set.len() < opts.poses {
                opts.stop.check()?;
                let best = st.best_addition();
                opts.stop.check()?;
                let (i, _) =
                    best.ok_or_else(|| DesignError::Numerical("no candidate can be added".into()))?;
                let was_building = st.building;
                st.apply(i, 1.0)?;
                if st.building && st.full_rank() {
                    st.building = false;
                }
                if was_building {
                    // Scores on a nearly singular M_ε lose digits in rank-3 updates
                    // (entries of order 1/ε cancel): recompute them while building.
                    st.refresh();
                }
            }
        }
        Some(set) => {
            for i in set {
                add_outer(&mut st.m, model.block(i), model.rows, model.p, 1.0);
                st.set.push(i);
                st.in_set[i] = true;
            }
            st.factor()?;
            st.building = !st.full_rank();
        }
    }
    if st.building {
        // The design itself does not reach full rank: nothing to exchange for.
        return Err(DesignError::Numerical(
            "the selected poses do not reach full rank".into(),
        ));
    }
    let greedy_value = dense_value(opts.criterion, &st.m, Some(&model.workspace), st.set.len())
        .unwrap_or(f64::NAN);
    let mut trace = vec![st.utility()];
    let (mut passes, mut swaps, mut converged) = (0, 0, false);
    while passes < opts.max_passes {
        passes += 1;
        st.refresh();
        let mut swapped = false;
        for slot in 0..st.set.len() {
            opts.stop.check()?;
            let j = st.set[slot];
            let cur = st.utility();
            let floor = cur + IMPROVE_RTOL * cur.abs();
            let swap = st.best_swap(j, floor);
            opts.stop.check()?;
            if let Some((i, _)) = swap {
                // Add first, then remove (the intermediate matrix is the better conditioned).
                st.apply(i, 1.0)?;
                st.apply(j, -1.0)?;
                // Keep the slot order: the new point takes j's slot.
                let last = st.set.pop().expect("just added");
                st.set.insert(slot, last);
                let now = st.utility();
                if now < cur {
                    // Rounding in the rank-3 scores: undo and stop trusting them.
                    st.apply(j, 1.0)?;
                    st.apply(i, -1.0)?;
                    let pos = st.set.iter().position(|&x| x == j).expect("restored");
                    st.set.remove(pos);
                    st.set.insert(slot, j);
                    st.refresh();
                    continue;
                }
                trace.push(now);
                swaps += 1;
                swapped = true;
            }
        }
        if !swapped {
            converged = true;
            break;
        }
    }
    Ok((
        st.set.clone(),
        greedy_value,
        passes,
        swaps,
        converged,
        trace,
    ))
}

/// Chooses `opts.poses` of the model's candidates (see the module docs).
pub fn select(model: &InfoModel, opts: &DesignOptions) -> Result<Design, DesignError> {
    let (p, k) = (model.p, model.n_candidates);
    let rows = model.rows;
    if opts.poses == 0 || rows * opts.poses < p {
        return Err(DesignError::TooFewPoses {
            poses: opts.poses,
            rank: p,
            rows_per_pose: rows,
        });
    }
    let (per_pose, shape) = model.rank_per_pose();
    if per_pose * opts.poses + shape < p {
        return Err(DesignError::TooFewTargetPoses {
            poses: opts.poses,
            targets: rows / 3,
            rank: p,
            per_pose,
            shape,
        });
    }
    if k < opts.poses {
        return Err(DesignError::TooFewCandidates {
            candidates: k,
            poses: opts.poses,
        });
    }
    if opts.max_passes == 0 {
        return Err(DesignError::InvalidOption {
            name: "max_passes",
            message: "must be at least 1".into(),
        });
    }
    let mut colsq = vec![0.0; k * p];
    let mut tr_sum = 0.0;
    for i in 0..k {
        let b = model.block(i);
        for c in 0..p {
            // Started at zero and summed in row order: for 3 rows the bits of
            // `b0² + b1² + b2²`.
            let mut s = 0.0;
            for r in 0..rows {
                s += b[r * p + c] * b[r * p + c];
            }
            colsq[i * p + c] = s;
            tr_sum += s;
        }
    }
    let ridge = RIDGE_REL * tr_sum / (k * p) as f64;
    let crit = opts.criterion;
    let mut best: Option<Design> = None;
    for restart in 0..=opts.restarts {
        let start = (restart > 0).then(|| {
            let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
            rng.set_stream(restart as u64);
            let mut s = sample(&mut rng, k, opts.poses).into_vec();
            s.sort_unstable();
            s
        });
        let outcome = run(model, opts, ridge, &colsq, start);
        let (set, greedy_value, passes, swaps, converged, trace) = match (outcome, restart) {
            (Ok(o), _) => o,
            (Err(e), 0) => return Err(e),
            (Err(DesignError::Stopped), _) => return Err(DesignError::Stopped),
            // A random start that does not reach full rank is skipped.
            (Err(_), _) => continue,
        };
        let mut selected = set;
        selected.sort_unstable();
        let value = model.value(crit, &selected).ok_or_else(|| {
            DesignError::Numerical("the design's information matrix is singular".into())
        })?;
        let better = best
            .as_ref()
            .is_none_or(|b| crit.utility(value) > crit.utility(b.value));
        if better {
            best = Some(Design {
                selected,
                criterion: crit,
                value,
                greedy_value: if restart == 0 {
                    greedy_value
                } else {
                    best.as_ref().map_or(greedy_value, |b| b.greedy_value)
                },
                passes,
                swaps,
                converged,
                trace,
            });
        }
    }
    best.ok_or_else(|| DesignError::Numerical("no run produced a design".into()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Scale;
    use kinematics::{PoseSampler, Robot};
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    fn model(k: usize, seed: u64) -> InfoModel {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenarios/robots/kr1000-titan.json");
        let robot = Robot::from_file(&path).unwrap();
        let pool = PoseSampler::default()
            .sample(&robot, k, &mut ChaCha8Rng::seed_from_u64(seed))
            .unwrap()
            .rad;
        InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap()
    }

    /// E's shortcut is sound and not vacuous: a candidate it skips fails the Cholesky test it
    /// replaces at every threshold tried, one that beats the threshold is never skipped, and
    /// it skips most candidates of a design with a point removed (the exchange's case).
    #[test]
    fn e_shortcut_skips_only_candidates_that_cannot_win() {
        let m = model(120, 3);
        let (ridge, _) = ridge_and_colsq(&m);
        let set: Vec<usize> = (0..14).collect();
        let mut base = m.information(&set[1..]);
        for k in 0..m.p {
            base[(k, k)] += ridge;
        }
        let bound = EBound::new(Criterion::E, &base).expect("E");
        assert!(EBound::new(Criterion::D, &base).is_none());
        let (mut skipped, mut tried) = (0, 0);
        for i in 14..m.n_candidates {
            let mut mi = base.clone();
            add_outer(&mut mi, m.block(i), 3, m.p, 1.0);
            let lmin = mi.clone().symmetric_eigenvalues().min();
            let current = m.information(&set).symmetric_eigenvalues().min();
            for t in [
                lmin * (1.0 - 1e-3),
                lmin * (1.0 - 1e-8),
                lmin,
                lmin * (1.0 + 1e-8),
                current,
            ] {
                tried += 1;
                let mut shifted = mi.clone();
                for k in 0..m.p {
                    shifted[(k, k)] -= t;
                }
                let passes = shifted.cholesky().is_some();
                if bound.cannot_exceed(m.block(i), t) {
                    skipped += 1;
                    assert!(!passes, "candidate {i} skipped at t = {t:e} but passes");
                }
                if t < lmin * (1.0 - 1e-5) {
                    assert!(!bound.cannot_exceed(m.block(i), t), "candidate {i} can win");
                }
            }
        }
        // Only the design's own value can be skipped at (the others are at or below λ_min(M')):
        // about half the candidates are.
        let candidates = m.n_candidates - 14;
        assert_eq!(tried, 5 * candidates);
        assert!(
            skipped * 3 > candidates,
            "{skipped} of {candidates} skipped"
        );
        assert!(!bound.cannot_exceed(m.block(20), f64::NEG_INFINITY));
    }

    fn ridge_and_colsq(model: &InfoModel) -> (f64, Vec<f64>) {
        let (p, k) = (model.p, model.n_candidates);
        let mut colsq = vec![0.0; k * p];
        let mut tr = 0.0;
        for i in 0..k {
            let b = model.block(i);
            for c in 0..p {
                colsq[i * p + c] = b[c] * b[c] + b[p + c] * b[p + c] + b[2 * p + c] * b[2 * p + c];
                tr += colsq[i * p + c];
            }
        }
        (RIDGE_REL * tr / (k * p) as f64, colsq)
    }

    /// The dense utility of M_ε for a set.
    fn dense_utility(st: &State, set: &[usize]) -> f64 {
        let mut m = st.model.information(set);
        for k in 0..st.p {
            m[(k, k)] += st.ridge;
        }
        let c = st.crit;
        let v = dense_value(c, &m, Some(&st.model.workspace), set.len()).unwrap();
        match c {
            // The fast O1 utility is ln O1 + ½ ln N.
            Criterion::O1 => v.ln() + 0.5 * (set.len() as f64).ln(),
            _ => c.utility(v),
        }
    }

    /// Every fast criterion's rank-3 scores of additions and of swaps (after a chain of
    /// rank-3 updates of G and H, without a refresh) equal the dense reference: nalgebra's
    /// Cholesky, inverse and eigenvalues of the full modified matrix.
    /// A stop request ends the selection with `Stopped`; without one the same options design.
    #[test]
    fn a_stop_request_ends_the_selection() {
        let model = model(80, 5);
        let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let mut opts = DesignOptions::new(Criterion::D, 12);
        opts.stop = StopFlag::new(flag.clone());
        assert!(select(&model, &opts).is_ok());
        flag.store(true, std::sync::atomic::Ordering::Relaxed);
        assert!(matches!(select(&model, &opts), Err(DesignError::Stopped)));
    }

    #[test]
    fn rank3_scores_match_the_dense_reference() {
        let model = model(80, 5);
        let (ridge, colsq) = ridge_and_colsq(&model);
        for crit in [Criterion::D, Criterion::A, Criterion::I, Criterion::O1] {
            let mut st = State::new(&model, crit, ridge, colsq.clone());
            st.building = false;
            // A full-rank start (as after the rank-building phase), then a chain of
            // rank-3 updates without a refresh.
            for i in (0..40).step_by(3) {
                add_outer(&mut st.m, model.block(i), 3, model.p, 1.0);
                st.set.push(i);
                st.in_set[i] = true;
            }
            st.factor().unwrap();
            st.refresh();
            for i in [50, 53, 57] {
                st.apply(i, 1.0).unwrap();
            }
            st.apply(9, -1.0).unwrap();
            st.apply(53, -1.0).unwrap();
            let set = st.set.clone();
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
            assert!(rel(st.utility(), dense_utility(&st, &set)) < 1e-9, "{crit}");
            for i in [1, 2, 9, 41, 79] {
                let mut s2 = set.clone();
                s2.push(i);
                let (fast, dense) = (st.add_utility(i), dense_utility(&st, &s2));
                assert!(rel(fast, dense) < 1e-8, "{crit} add {i}: {fast} vs {dense}");
            }
            for &j in &[set[0], set[5]] {
                let best = st.best_swap(j, f64::NEG_INFINITY).unwrap();
                // Brute force over every replacement with the dense reference.
                let mut brute: Option<(usize, f64)> = None;
                for i in 0..model.n_candidates {
                    if st.in_set[i] {
                        continue;
                    }
                    let s2: Vec<usize> = set.iter().map(|&x| if x == j { i } else { x }).collect();
                    let u = dense_utility(&st, &s2);
                    if brute.is_none_or(|b| u > b.1) {
                        brute = Some((i, u));
                    }
                }
                let brute = brute.unwrap();
                assert!(
                    rel(best.1, brute.1) < 1e-8,
                    "{crit} swap {j}: {best:?} vs {brute:?}"
                );
                assert_eq!(best.0, brute.0, "{crit} swap {j}");
            }
        }
    }

    /// E and O3's shifted-Cholesky test agrees with the eigenvalues.
    #[test]
    fn threshold_tests_agree_with_the_spectrum() {
        let model = model(40, 9);
        let set: Vec<usize> = (0..20).collect();
        let m = model.information(&set);
        for crit in [Criterion::E, Criterion::O3, Criterion::O5] {
            let v = dense_value(crit, &m, None, 20).unwrap();
            assert_eq!(slow_utility(crit, &m, None, 20, f64::NEG_INFINITY), Some(v));
            assert_eq!(slow_utility(crit, &m, None, 20, v * (1.0 - 1e-6)), Some(v));
            assert_eq!(slow_utility(crit, &m, None, 20, v * (1.0 + 1e-6)), None);
        }
    }
}
