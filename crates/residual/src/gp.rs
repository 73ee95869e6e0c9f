//! The Gaussian process: kernel, Cholesky factor, log marginal likelihood and its gradient,
//! the deterministic optimiser of the hyperparameters, prediction and the model file.
//!
//! Inputs are the joint angles in radians, `x ∈ ℝ^d`; outputs the three components of the
//! position residual `r = p_measured − p_geometry` (mm), each normalised by the training
//! set's mean `μ_c` and standard deviation `σ_c` (population, `1/n`): `y_c = (r_c − μ_c)/σ_c`.
//! The three outputs share one kernel (one Cholesky factor):
//!
//! ```text
//! k(x, x') = s² · exp(−½ Σ_i (x_i − x'_i)² / ℓ_i²) + σ_n² · [x = x']
//! ```
//!
//! (anisotropic squared exponential, one length scale `ℓ_i` a joint, signal variance `s²`,
//! white noise `σ_n²`, both in normalised units). The hyperparameters
//! `θ = (ln ℓ_1 … ln ℓ_d, ln s², ln σ_n²)` maximise the log marginal likelihood of the three
//! outputs,
//!
//! ```text
//! ln p(Y | θ) = Σ_c [ −½ y_cᵀ K⁻¹ y_c ] − 3 Σ_a ln L_aa − (3n/2) ln 2π,   K = L Lᵀ,
//! ∂ ln p / ∂θ_j = ½ tr( (Σ_c α_c α_cᵀ − 3 K⁻¹) ∂K/∂θ_j ),                α_c = K⁻¹ y_c,
//! ```
//!
//! with `∂K/∂ln ℓ_i = K_f ∘ D_i` (`D_i,ab = (x_ai − x_bi)²/ℓ_i²`, `K_f` the signal part),
//! `∂K/∂ln s² = K_f`, `∂K/∂ln σ_n² = σ_n² I` (Rasmussen & Williams 2006, eq. 2.30, 5.9). The
//! same model as scikit-learn's `ConstantKernel · RBF(ℓ) + WhiteKernel` with
//! `normalize_y=True`, the one of `crates/kincal-py/examples/hybrid_gp.py`.
//!
//! The prediction at `x*` (per output, back in mm):
//!
//! ```text
//! mean_c(x*) = μ_c + σ_c · k*ᵀ α_c,
//! sd_c(x*)   = σ_c · √( s² − ‖L⁻¹ k*‖² + σ_n² )
//! ```
//!
//! `sd` is the standard deviation of a *measured* residual at `x*` (the latent function's
//! variance plus the noise the model learnt): what the held-out coverage checks
//! (`crate::cv`). The noise is one variance in normalised units, so in mm it is
//! `σ_c·σ_n`, proportional to each axis's scatter: exact when the axes scatter alike (the
//! UR10's do, within 20 %), an approximation otherwise — scikit-learn's too.
//!
//! Every sum has one fixed order (dot products in eight fixed lanes, then the lanes in one
//! tree; no FMA, no threads), so a fit gives the same bits on every run and machine with
//! the same floating-point semantics.

use serde::{Deserialize, Serialize};

use crate::error::{ResidualError, Result};

/// The model file's format tag (a model of the position residuals alone: point data, or
/// 6-DoF data whose orientation part the gate declined).
pub const FORMAT: &str = "kincal-residual-model/1";

/// The format tag of a model file that also carries the orientation part (6-DoF data:
/// the `orientation` object, `docs/residual-model.md`). A reader of `/1` refuses it rather
/// than ignore the orientation correction.
pub const FORMAT_ORIENTATION: &str = "kincal-residual-model/2";

/// The kernel, in words (the model file's `kernel` field).
pub const KERNEL: &str = "s² · exp(−½ Σ_i (q_i − q'_i)² / ℓ_i²) + σ_n² · [q = q'], q in radians, \
                          outputs normalised by the training mean and standard deviation";

/// Fewest training poses a fit accepts: with fewer, the marginal likelihood of the 8
/// hyperparameters of a six-joint arm is flat and a fit means nothing.
pub const MIN_TRAIN_POSES: usize = 20;

/// Options of [`ResidualModel::fit`]. The defaults are those of the scikit-learn example
/// (`hybrid_gp.py`: start values and bounds of `ConstantKernel(1.0, (1e-3, 1e2)) ·
/// RBF(1.0, (1e-2, 1e2)) + WhiteKernel(0.05, (1e-4, 1.0))`), so that the two can be compared.
#[derive(Clone, Debug, PartialEq)]
pub struct GpOptions {
    /// Most poses the GP trains on \[600\]: the fit costs O(n³) per likelihood evaluation
    /// (about 0.1 s at 600 poses in a release build, 1 s at 1,200); with more poses given,
    /// every ⌈n/600⌉-th is not dropped but an evenly spaced subset of indices
    /// `⌊i·n/600⌋` is kept (deterministic, the same for the same data).
    pub max_train_poses: usize,
    /// Most optimiser iterations \[100\]: the UR10 fits converge in 15–40.
    pub max_iterations: usize,
    /// Start of every length scale, radians \[1.0: about a joint's typical travel\].
    pub length_scale_start_rad: f64,
    /// Bounds of the length scales, radians \[0.01, 100\]: 100 rad means “this joint does
    /// not matter” (the kernel is then flat along it).
    pub length_scale_bounds_rad: [f64; 2],
    /// Start of the signal variance `s²`, normalised units \[1.0\].
    pub signal_variance_start: f64,
    /// Bounds of `s²` \[0.001, 100\].
    pub signal_variance_bounds: [f64; 2],
    /// Start of the noise variance `σ_n²`, normalised units \[0.05\].
    pub noise_variance_start: f64,
    /// Bounds of `σ_n²` \[0.0001, 1\]: the lower bound keeps the kernel matrix well
    /// conditioned (a residual is never known better than 1 % of its scatter).
    pub noise_variance_bounds: [f64; 2],
}

impl Default for GpOptions {
    fn default() -> Self {
        Self {
            max_train_poses: 600,
            max_iterations: 100,
            length_scale_start_rad: 1.0,
            length_scale_bounds_rad: [1e-2, 1e2],
            signal_variance_start: 1.0,
            signal_variance_bounds: [1e-3, 1e2],
            noise_variance_start: 0.05,
            noise_variance_bounds: [1e-4, 1.0],
        }
    }
}

/// The kernel's hyperparameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hyperparameters {
    /// `ℓ_i`, one a joint, radians.
    pub length_scales_rad: Vec<f64>,
    /// `s²`, in units of the normalised residual (dimensionless).
    pub signal_variance: f64,
    /// `σ_n²`, in units of the normalised residual (dimensionless).
    pub noise_variance: f64,
}

/// How the optimiser ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptimiserReport {
    /// Iterations (accepted steps).
    pub iterations: usize,
    /// Likelihood evaluations (each one Cholesky factor and inverse).
    pub evaluations: usize,
    /// Whether it stopped on a small projected gradient or a small change of the
    /// likelihood (false: [`GpOptions::max_iterations`] or no decrease along the step).
    pub converged: bool,
}

/// One prediction of the residual model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// The predicted residual (measured − geometry), mm: add it to the geometric model's
    /// point.
    pub mean_mm: [f64; 3],
    /// The standard deviation of a measured residual at this pose (the latent function's
    /// variance and the learnt noise), mm, per axis.
    pub sd_mm: [f64; 3],
}

/// One prediction of the orientation part of a residual model (6-DoF data).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientationPrediction {
    /// The predicted orientation residual, the rotation vector of `R_measured ·
    /// R_geometryᵀ` (measurement axes), degrees: the measured orientation is
    /// `exp(mean) · R_geometry`.
    pub mean_deg: [f64; 3],
    /// The standard deviation of a measured orientation residual at this pose, degrees, per
    /// axis.
    pub sd_deg: [f64; 3],
}

/// The orientation part of a model file (`kincal-residual-model/2`): the same GP as the
/// position part, on the rotation vectors in degrees, trained on the same poses (the
/// file's `training_joints_deg`).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct OrientationFile {
    hyperparameters: Hyperparameters,
    residual_mean_deg: [f64; 3],
    residual_scale_deg: [f64; 3],
    log_marginal_likelihood: f64,
    optimiser: OptimiserReport,
    training_residuals_deg: Vec<[f64; 3]>,
}

/// The model file (`kincal-residual-model/1`, or `/2` with the orientation part), as
/// written.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    format: String,
    kernel: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fitted_for: Option<String>,
    hyperparameters: Hyperparameters,
    residual_mean_mm: [f64; 3],
    residual_scale_mm: [f64; 3],
    log_marginal_likelihood: f64,
    optimiser: OptimiserReport,
    training_poses_given: usize,
    training_joints_deg: Vec<Vec<f64>>,
    training_residuals_mm: Vec<[f64; 3]>,
    /// The orientation part (`/2` only); in memory always `None`: the part is held
    /// factored in [`ResidualModel::orientation`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    orientation: Option<OrientationFile>,
}

/// A fitted residual model: the hyperparameters, the training data and their factor; with
/// 6-DoF data optionally a second GP of the same code on the orientation residuals
/// (degrees), trained on the same poses.
#[derive(Clone, Debug)]
pub struct ResidualModel {
    file: ModelFile,
    train: Train,
    /// Lower Cholesky factor of `K` (row-major, upper triangle unused).
    chol: Vec<f64>,
    /// `α = K⁻¹ Y`, row-major `n × 3`.
    alpha: Vec<f64>,
    /// The orientation part: a GP whose outputs (named `_mm` inside) are degrees.
    orientation: Option<Box<ResidualModel>>,
}

/// Training inputs (radians) and normalised outputs.
#[derive(Clone, Debug)]
struct Train {
    n: usize,
    d: usize,
    /// `n × d`, radians.
    x: Vec<f64>,
    /// `n × 3`, normalised.
    y: Vec<f64>,
}

/// Lanes of [`dot`]: eight independent sums (four SSE2 registers), enough to hide the
/// latency of the additions, which one or two chains do not.
const LANES: usize = 8;

/// Dot product in [`LANES`] fixed lanes, then the lanes in one tree, then the tail: one
/// order on every machine (the compiler never reorders floating-point sums).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = [0.0; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..LANES {
            s[l] += x[l] * y[l];
        }
    }
    let mut t = ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
    for (x, y) in ra.iter().zip(rb) {
        t += x * y;
    }
    t
}

/// Rows per block of the factor and the inverse: a block's rows stay in cache while each
/// streamed row is dotted with all of them. The blocking changes the order of the loops,
/// not of any sum: every entry is the same dot product, with the same bits, as unblocked.
const BLOCK: usize = 8;

/// In-place lower Cholesky factor of the symmetric `n × n` row-major `a` (its lower
/// triangle is read and overwritten by `L`): `L_ij = (a_ij − Σ_{k<j} L_ik L_jk) / L_jj`,
/// `L_jj = √(a_jj − Σ_{k<j} L_jk²)`, each sum one [`dot`], by blocks of [`BLOCK`] columns.
/// `false` if a pivot is not positive.
fn cholesky(a: &mut [f64], n: usize) -> bool {
    let mut j0 = 0;
    while j0 < n {
        let j1 = (j0 + BLOCK).min(n);
        // The block's own rows, in order: columns j0..j, then the diagonal.
        for j in j0..j1 {
            let (upto, rest) = a.split_at_mut(j * n);
            let row_j = &mut rest[..n];
            for k in j0..j {
                row_j[k] = (row_j[k] - dot(&row_j[..k], &upto[k * n..k * n + k])) / upto[k * n + k];
            }
            let s = row_j[j] - dot(&row_j[..j], &row_j[..j]);
            if !(s > 0.0 && s.is_finite()) {
                return false;
            }
            row_j[j] = s.sqrt();
        }
        // The rows below: the block's columns.
        let (upto, rest) = a.split_at_mut(j1 * n);
        for row_i in rest.chunks_exact_mut(n) {
            for k in j0..j1 {
                row_i[k] = (row_i[k] - dot(&row_i[..k], &upto[k * n..k * n + k])) / upto[k * n + k];
            }
        }
        j0 = j1;
    }
    true
}

/// Solves `L x = b` in place (`L` lower, row-major).
fn forward(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let row = &l[i * n..i * n + i];
        b[i] = (b[i] - dot(row, &b[..i])) / l[i * n + i];
    }
}

/// Solves `Lᵀ x = b` in place (`L` lower, row-major), row by row from the last.
fn backward(l: &[f64], n: usize, b: &mut [f64]) {
    for i in (0..n).rev() {
        b[i] /= l[i * n + i];
        let xi = b[i];
        let row = &l[i * n..i * n + i];
        for (bk, lik) in b[..i].iter_mut().zip(row) {
            *bk -= lik * xi;
        }
    }
}

/// `K⁻¹` (full symmetric, row-major) from its lower Cholesky factor: `U = L⁻ᵀ` row by row
/// (row `j` of `U` is `L⁻¹ e_j`: `U_jj = 1/L_jj`, `U_ji = −Σ_{j≤k<i} L_ik U_jk / L_ii`),
/// then `(K⁻¹)_ab = Σ_{k ≥ max(a,b)} U_ak U_bk`; both by blocks of [`BLOCK`] rows.
fn inverse_from_cholesky(l: &[f64], n: usize) -> Vec<f64> {
    let mut u = vec![0.0; n * n];
    for (block, rows) in u.chunks_mut(BLOCK * n).enumerate() {
        let j0 = block * BLOCK;
        let count = rows.len() / n;
        for i in j0..n {
            let li = &l[i * n..(i + 1) * n];
            for (r, row) in rows
                .chunks_exact_mut(n)
                .enumerate()
                .take((i + 1 - j0).min(count))
            {
                let j = j0 + r;
                row[i] = if i == j {
                    1.0 / li[i]
                } else {
                    -dot(&li[j..i], &row[j..i]) / li[i]
                };
            }
        }
    }
    let mut inv = vec![0.0; n * n];
    let mut b0 = 0;
    while b0 < n {
        let b1 = (b0 + BLOCK).min(n);
        for a in 0..b1 {
            for b in a.max(b0)..b1 {
                let v = dot(&u[a * n + b..(a + 1) * n], &u[b * n + b..(b + 1) * n]);
                inv[a * n + b] = v;
                inv[b * n + a] = v;
            }
        }
        b0 = b1;
    }
    inv
}

impl Train {
    /// The signal part `K_f` of the kernel matrix at `ls` (length scales) and `s2`.
    fn kernel_f(&self, ls: &[f64], s2: f64) -> Vec<f64> {
        let (n, d) = (self.n, self.d);
        let z: Vec<f64> = (0..n * d).map(|k| self.x[k] / ls[k % d]).collect();
        let mut k = vec![0.0; n * n];
        for a in 0..n {
            k[a * n + a] = s2;
            for b in 0..a {
                let r2 = sq_dist(&z[a * d..(a + 1) * d], &z[b * d..(b + 1) * d]);
                let v = s2 * (-0.5 * r2).exp();
                k[a * n + b] = v;
                k[b * n + a] = v;
            }
        }
        k
    }

    /// `K = K_f + σ_n² I` factored, and `α = K⁻¹ Y`; `None` if not positive definite.
    fn factor(&self, kf: &[f64], noise: f64) -> Option<(Vec<f64>, Vec<f64>)> {
        let n = self.n;
        let mut l = kf.to_vec();
        for a in 0..n {
            l[a * n + a] += noise;
        }
        if !cholesky(&mut l, n) {
            return None;
        }
        let mut alpha = vec![0.0; n * 3];
        let mut col = vec![0.0; n];
        for c in 0..3 {
            for (a, v) in col.iter_mut().enumerate() {
                *v = self.y[a * 3 + c];
            }
            forward(&l, n, &mut col);
            backward(&l, n, &mut col);
            for (a, v) in col.iter().enumerate() {
                alpha[a * 3 + c] = *v;
            }
        }
        Some((l, alpha))
    }

    /// `−ln p(Y | θ)` and its gradient in `θ = (ln ℓ, ln s², ln σ_n²)`; `None` where `K` is
    /// not positive definite.
    fn objective(&self, theta: &[f64]) -> Option<(f64, Vec<f64>)> {
        let (n, d) = (self.n, self.d);
        let ls: Vec<f64> = theta[..d].iter().map(|t| t.exp()).collect();
        let (s2, noise) = (theta[d].exp(), theta[d + 1].exp());
        let kf = self.kernel_f(&ls, s2);
        let (l, alpha) = self.factor(&kf, noise)?;
        let fit: f64 = dot(&self.y, &alpha);
        let log_det: f64 = (0..n).map(|a| l[a * n + a].ln()).sum();
        let lml = -0.5 * fit - 3.0 * log_det - 1.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
        if !lml.is_finite() {
            return None;
        }
        let inv = inverse_from_cholesky(&l, n);
        let z: Vec<f64> = (0..n * d).map(|k| self.x[k] / ls[k % d]).collect();
        // W = Σ_c α_c α_cᵀ − 3 K⁻¹; the traces over the upper triangle, doubled, plus the
        // diagonal.
        let w = |a: usize, b: usize| {
            dot(&alpha[a * 3..a * 3 + 3], &alpha[b * 3..b * 3 + 3]) - 3.0 * inv[a * n + b]
        };
        let mut g_ls = vec![0.0; d];
        let mut g_s2 = 0.0;
        let mut g_noise = 0.0;
        for a in 0..n {
            let waa = w(a, a);
            g_s2 += 0.5 * waa * kf[a * n + a];
            g_noise += 0.5 * waa * noise;
            for b in (a + 1)..n {
                let t = w(a, b) * kf[a * n + b];
                g_s2 += t;
                for (i, g) in g_ls.iter_mut().enumerate() {
                    let dz = z[a * d + i] - z[b * d + i];
                    *g += t * dz * dz;
                }
            }
        }
        let mut grad: Vec<f64> = g_ls.iter().map(|g| -g).collect();
        grad.push(-g_s2);
        grad.push(-g_noise);
        Some((-lml, grad))
    }
}

fn sq_dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Relative change of `−ln p` below which the optimiser stops (scikit-learn's L-BFGS-B
/// `ftol` is 2.2e-9; 1e-9 here).
const F_TOL: f64 = 1e-9;
/// Projected gradient (∞-norm, per unit of ln θ) below which the optimiser stops.
const G_TOL: f64 = 1e-5;
/// Largest step in any ln θ component (a factor e² ≈ 7.4 on a hyperparameter).
const MAX_STEP: f64 = 2.0;

/// A value and its gradient; `None` where the objective is undefined (the kernel matrix is
/// not positive definite there).
type Objective<'a> = &'a dyn Fn(&[f64]) -> Option<(f64, Vec<f64>)>;

/// Minimises `f` over the box `[lo, hi]` by projected BFGS with a backtracking (Armijo)
/// line search, from `x0`: deterministic (no random restarts). Returns the minimiser, its
/// value and the report.
fn minimise(
    f: Objective<'_>,
    x0: Vec<f64>,
    lo: &[f64],
    hi: &[f64],
    max_iterations: usize,
) -> Option<(Vec<f64>, f64, OptimiserReport)> {
    let m = x0.len();
    let clamp = |x: &mut [f64]| {
        for k in 0..m {
            x[k] = x[k].clamp(lo[k], hi[k]);
        }
    };
    let mut x = x0;
    clamp(&mut x);
    let mut evaluations = 1;
    let (mut fx, mut g) = f(&x)?;
    let mut h = identity(m);
    let mut report = OptimiserReport {
        iterations: 0,
        evaluations: 0,
        converged: false,
    };
    // Components at a bound whose gradient pushes outwards are held.
    let held = |x: &[f64], g: &[f64], k: usize| {
        (x[k] <= lo[k] && g[k] > 0.0) || (x[k] >= hi[k] && g[k] < 0.0)
    };
    for _ in 0..max_iterations {
        let pg = (0..m)
            .filter(|&k| !held(&x, &g, k))
            .map(|k| g[k].abs())
            .fold(0.0, f64::max);
        if pg < G_TOL {
            report.converged = true;
            break;
        }
        let mut dir = vec![0.0; m];
        for (k, dk) in dir.iter_mut().enumerate() {
            if !held(&x, &g, k) {
                *dk = -(0..m)
                    .filter(|&j| !held(&x, &g, j))
                    .map(|j| h[k * m + j] * g[j])
                    .sum::<f64>();
            }
        }
        let mut slope: f64 = dir.iter().zip(&g).map(|(a, b)| a * b).sum();
        if slope >= 0.0 {
            // Not a descent direction: restart from steepest descent.
            h = identity(m);
            for k in 0..m {
                dir[k] = if held(&x, &g, k) { 0.0 } else { -g[k] };
            }
            slope = dir.iter().zip(&g).map(|(a, b)| a * b).sum();
        }
        let big = dir.iter().fold(0.0f64, |a, d| a.max(d.abs()));
        let mut t = if big > MAX_STEP { MAX_STEP / big } else { 1.0 };
        let mut accepted = None;
        for _ in 0..40 {
            let mut xn: Vec<f64> = x.iter().zip(&dir).map(|(a, d)| a + t * d).collect();
            clamp(&mut xn);
            evaluations += 1;
            if let Some((fnew, gnew)) = f(&xn) {
                let moved: f64 = xn
                    .iter()
                    .zip(&x)
                    .zip(&g)
                    .map(|((a, b), gk)| (a - b) * gk)
                    .sum();
                if fnew <= fx + 1e-4 * moved.min(t * slope).min(0.0) && fnew < fx {
                    accepted = Some((xn, fnew, gnew));
                    break;
                }
            }
            t *= 0.5;
        }
        let Some((xn, fnew, gnew)) = accepted else {
            break;
        };
        report.iterations += 1;
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gnew.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy: f64 = s.iter().zip(&y).map(|(a, b)| a * b).sum();
        if sy > 1e-12 {
            bfgs_update(&mut h, &s, &y, sy);
        }
        let df = fx - fnew;
        x = xn;
        fx = fnew;
        g = gnew;
        if df <= F_TOL * fx.abs().max(1.0) {
            report.converged = true;
            break;
        }
    }
    report.evaluations = evaluations;
    Some((x, fx, report))
}

fn identity(m: usize) -> Vec<f64> {
    (0..m * m)
        .map(|k| if k / m == k % m { 1.0 } else { 0.0 })
        .collect()
}

/// BFGS update of the inverse Hessian `H`: `H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ`,
/// `ρ = 1/(sᵀy)`.
fn bfgs_update(h: &mut [f64], s: &[f64], y: &[f64], sy: f64) {
    let m = s.len();
    let rho = 1.0 / sy;
    let hy: Vec<f64> = (0..m)
        .map(|k| (0..m).map(|j| h[k * m + j] * y[j]).sum())
        .collect();
    let yhy: f64 = y.iter().zip(&hy).map(|(a, b)| a * b).sum();
    for k in 0..m {
        for j in 0..m {
            h[k * m + j] +=
                -rho * (hy[k] * s[j] + s[k] * hy[j]) + (rho * rho * yhy + rho) * s[k] * s[j];
        }
    }
}

/// Evenly spaced indices `⌊i·n/m⌋`, `i < m`, of `0..n` (all of them when `n ≤ m`).
pub fn evenly_spaced(n: usize, m: usize) -> Vec<usize> {
    if n <= m {
        (0..n).collect()
    } else {
        (0..m).map(|i| i * n / m).collect()
    }
}

fn check_rows(joints_deg: &[Vec<f64>], what: &'static str, d: usize) -> Result<()> {
    for (row, q) in joints_deg.iter().enumerate() {
        if q.len() != d {
            return Err(ResidualError::Joints {
                row,
                got: q.len(),
                expected: d,
            });
        }
        if q.iter().any(|v| !v.is_finite()) {
            return Err(ResidualError::NonFinite { what, row });
        }
    }
    Ok(())
}

impl ResidualModel {
    /// Fits the model to the residuals `residuals_mm` (measured − geometry, mm) at the poses
    /// `joints_deg` (one row a pose, degrees): normalises the outputs, maximises the log
    /// marginal likelihood over the hyperparameters from the start values of `opts`
    /// (projected BFGS in ln θ, box bounds of `opts`), then factors the kernel matrix.
    /// Deterministic: the same inputs give the same bits.
    ///
    /// # Errors
    /// [`ResidualError::Data`] for fewer than [`MIN_TRAIN_POSES`] poses, lengths that differ
    /// or no joints; [`ResidualError::Joints`] and [`ResidualError::NonFinite`] naming the
    /// row; [`ResidualError::NotPositiveDefinite`] if the kernel matrix cannot be factored
    /// even at the start values.
    pub fn fit(
        joints_deg: &[Vec<f64>],
        residuals_mm: &[[f64; 3]],
        opts: &GpOptions,
    ) -> Result<Self> {
        if joints_deg.len() != residuals_mm.len() {
            return Err(ResidualError::Data(format!(
                "{} poses but {} residuals",
                joints_deg.len(),
                residuals_mm.len()
            )));
        }
        if joints_deg.len() < MIN_TRAIN_POSES {
            return Err(ResidualError::Data(format!(
                "{} poses; a residual model needs at least {MIN_TRAIN_POSES}",
                joints_deg.len()
            )));
        }
        let d = joints_deg[0].len();
        if d == 0 {
            return Err(ResidualError::Data("poses without joints".into()));
        }
        check_rows(joints_deg, "joints_deg", d)?;
        if let Some(row) = residuals_mm
            .iter()
            .position(|r| r.iter().any(|v| !v.is_finite()))
        {
            return Err(ResidualError::NonFinite {
                what: "residuals_mm",
                row,
            });
        }
        check_options(opts)?;
        let keep = evenly_spaced(joints_deg.len(), opts.max_train_poses);
        let q: Vec<Vec<f64>> = keep.iter().map(|&i| joints_deg[i].clone()).collect();
        let r: Vec<[f64; 3]> = keep.iter().map(|&i| residuals_mm[i]).collect();
        let (mean, scale) = normalisation(&r);
        let train = train_set(&q, &r, mean, scale);
        let ln = |v: f64| v.ln();
        let mut x0 = vec![ln(opts.length_scale_start_rad); d];
        x0.push(ln(opts.signal_variance_start));
        x0.push(ln(opts.noise_variance_start));
        let mut lo = vec![ln(opts.length_scale_bounds_rad[0]); d];
        lo.extend([
            ln(opts.signal_variance_bounds[0]),
            ln(opts.noise_variance_bounds[0]),
        ]);
        let mut hi = vec![ln(opts.length_scale_bounds_rad[1]); d];
        hi.extend([
            ln(opts.signal_variance_bounds[1]),
            ln(opts.noise_variance_bounds[1]),
        ]);
        let (theta, f, optimiser) =
            minimise(&|t| train.objective(t), x0, &lo, &hi, opts.max_iterations).ok_or_else(
                || ResidualError::NotPositiveDefinite {
                    context: "at the optimiser's start values".into(),
                },
            )?;
        let hyper = Hyperparameters {
            length_scales_rad: theta[..d].iter().map(|t| t.exp()).collect(),
            signal_variance: theta[d].exp(),
            noise_variance: theta[d + 1].exp(),
        };
        let file = ModelFile {
            format: FORMAT.to_string(),
            kernel: KERNEL.to_string(),
            fitted_for: None,
            hyperparameters: hyper,
            residual_mean_mm: mean,
            residual_scale_mm: scale,
            log_marginal_likelihood: -f,
            optimiser,
            training_poses_given: joints_deg.len(),
            training_joints_deg: q,
            training_residuals_mm: r,
            orientation: None,
        };
        Self::from_file(file, "the fit")
    }

    /// Builds the model from its file contents: checks them, factors the kernel matrix.
    fn from_file(file: ModelFile, context: &str) -> Result<Self> {
        let q = &file.training_joints_deg;
        let r = &file.training_residuals_mm;
        let h = &file.hyperparameters;
        let train = train_set(q, r, file.residual_mean_mm, file.residual_scale_mm);
        let kf = train.kernel_f(&h.length_scales_rad, h.signal_variance);
        let (chol, alpha) = train.factor(&kf, h.noise_variance).ok_or_else(|| {
            ResidualError::NotPositiveDefinite {
                context: context.to_string(),
            }
        })?;
        Ok(Self {
            file,
            train,
            chol,
            alpha,
            orientation: None,
        })
    }

    /// Adds the orientation part (6-DoF data): the same GP fitted to the orientation
    /// residuals `residuals_deg` (rotation vectors of `R_measured · R_geometryᵀ`, degrees)
    /// at the poses `joints_deg`, which must be those the position part was fitted on.
    /// The file is then written as [`FORMAT_ORIENTATION`].
    ///
    /// # Errors
    /// [`ResidualModel::fit`]'s; [`ResidualError::Data`] for other poses than the position
    /// part's.
    pub fn fit_orientation(
        &mut self,
        joints_deg: &[Vec<f64>],
        residuals_deg: &[[f64; 3]],
        opts: &GpOptions,
    ) -> Result<()> {
        // Checked before the fit: the poses it would train on must be the position part's.
        let keep = evenly_spaced(joints_deg.len(), opts.max_train_poses);
        let given = &self.file.training_joints_deg;
        if joints_deg.len() != self.file.training_poses_given
            || keep.len() != given.len()
            || keep.iter().zip(given).any(|(&i, q)| joints_deg[i] != *q)
        {
            return Err(ResidualError::Data(
                "the orientation residuals must be given at the poses of the position part".into(),
            ));
        }
        let part = ResidualModel::fit(joints_deg, residuals_deg, opts)?;
        self.orientation = Some(Box::new(part));
        Ok(())
    }

    /// Whether the model has the orientation part (6-DoF data, [`FORMAT_ORIENTATION`]).
    pub fn has_orientation(&self) -> bool {
        self.orientation.is_some()
    }

    /// The orientation part's hyperparameters (its signal and noise variances normalised
    /// by the degrees' scatter), if it has one.
    pub fn orientation_hyperparameters(&self) -> Option<&Hyperparameters> {
        self.orientation.as_ref().map(|o| o.hyperparameters())
    }

    /// The noise standard deviation the orientation part learnt, degrees, per axis.
    pub fn orientation_noise_sd_deg(&self) -> Option<[f64; 3]> {
        self.orientation.as_ref().map(|o| o.noise_sd_mm())
    }

    /// The orientation part's log marginal likelihood and optimiser report.
    pub fn orientation_fit(&self) -> Option<(f64, &OptimiserReport)> {
        self.orientation
            .as_ref()
            .map(|o| (o.log_marginal_likelihood(), o.optimiser()))
    }

    /// Predicts the orientation residual and its standard deviation (degrees) at each pose
    /// of `joints_deg`; `None` without the orientation part.
    ///
    /// # Errors
    /// As [`ResidualModel::predict`].
    pub fn predict_orientation(
        &self,
        joints_deg: &[Vec<f64>],
    ) -> Result<Option<Vec<OrientationPrediction>>> {
        let Some(o) = &self.orientation else {
            return Ok(None);
        };
        Ok(Some(
            o.predict(joints_deg)?
                .into_iter()
                .map(|p| OrientationPrediction {
                    mean_deg: p.mean_mm,
                    sd_deg: p.sd_mm,
                })
                .collect(),
        ))
    }

    /// The hyperparameters.
    pub fn hyperparameters(&self) -> &Hyperparameters {
        &self.file.hyperparameters
    }

    /// How the optimiser ended.
    pub fn optimiser(&self) -> &OptimiserReport {
        &self.file.optimiser
    }

    /// The log marginal likelihood at the hyperparameters (normalised outputs).
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.file.log_marginal_likelihood
    }

    /// Training poses the model holds (after [`GpOptions::max_train_poses`]).
    pub fn training_poses(&self) -> usize {
        self.train.n
    }

    /// Poses given to the fit (before [`GpOptions::max_train_poses`]).
    pub fn training_poses_given(&self) -> usize {
        self.file.training_poses_given
    }

    /// Joints of the training poses.
    pub fn n_joints(&self) -> usize {
        self.train.d
    }

    /// The standard deviation of the training residuals, mm, per axis (the normalisation).
    pub fn residual_scale_mm(&self) -> [f64; 3] {
        self.file.residual_scale_mm
    }

    /// The noise standard deviation the model learnt, mm, per axis (`σ_c·σ_n`).
    pub fn noise_sd_mm(&self) -> [f64; 3] {
        let s = self.file.hyperparameters.noise_variance.sqrt();
        self.file.residual_scale_mm.map(|c| c * s)
    }

    /// What the model corrects (the calibration run of the robot file it was fitted on),
    /// if set.
    pub fn fitted_for(&self) -> Option<&str> {
        self.file.fitted_for.as_deref()
    }

    /// Names what the model corrects (e.g. the `run` of `identified.json`'s provenance).
    pub fn set_fitted_for(&mut self, run: impl Into<String>) {
        self.file.fitted_for = Some(run.into());
    }

    /// Predicts the residual and its standard deviation at each pose of `joints_deg`
    /// (degrees). The formulas are in the module doc.
    ///
    /// # Errors
    /// [`ResidualError::Joints`] or [`ResidualError::NonFinite`] naming the query row.
    pub fn predict(&self, joints_deg: &[Vec<f64>]) -> Result<Vec<Prediction>> {
        check_rows(joints_deg, "query joints_deg", self.train.d)?;
        let (n, d) = (self.train.n, self.train.d);
        let h = &self.file.hyperparameters;
        let ls = &h.length_scales_rad;
        let z: Vec<f64> = (0..n * d).map(|k| self.train.x[k] / ls[k % d]).collect();
        let mut ks = vec![0.0; n];
        let mut zq = vec![0.0; d];
        let mut out = Vec::with_capacity(joints_deg.len());
        for q in joints_deg {
            for i in 0..d {
                zq[i] = q[i].to_radians() / ls[i];
            }
            for (a, k) in ks.iter_mut().enumerate() {
                *k = h.signal_variance * (-0.5 * sq_dist(&zq, &z[a * d..(a + 1) * d])).exp();
            }
            let mut m = [0.0; 3];
            for (c, mc) in m.iter_mut().enumerate() {
                let col: Vec<f64> = (0..n).map(|a| self.alpha[a * 3 + c]).collect();
                *mc = dot(&ks, &col);
            }
            forward(&self.chol, n, &mut ks);
            let var_f = (h.signal_variance - dot(&ks, &ks)).max(0.0);
            let sd = (var_f + h.noise_variance).sqrt();
            let (mu, sc) = (self.file.residual_mean_mm, self.file.residual_scale_mm);
            out.push(Prediction {
                mean_mm: [0, 1, 2].map(|c| mu[c] + sc[c] * m[c]),
                sd_mm: [0, 1, 2].map(|c| sc[c] * sd),
            });
        }
        Ok(out)
    }

    /// The model file (`kincal-residual-model/1`, `docs/residual-model.md`), pretty JSON
    /// ending in a newline: the hyperparameters, the normalisation, the optimiser's report
    /// and the training data (the factor is recomputed when read).
    pub fn to_json_string(&self) -> String {
        let mut s = match &self.orientation {
            None => serde_json::to_string_pretty(&self.file),
            Some(o) => {
                let mut file = self.file.clone();
                file.format = FORMAT_ORIENTATION.to_string();
                file.orientation = Some(OrientationFile {
                    hyperparameters: o.file.hyperparameters.clone(),
                    residual_mean_deg: o.file.residual_mean_mm,
                    residual_scale_deg: o.file.residual_scale_mm,
                    log_marginal_likelihood: o.file.log_marginal_likelihood,
                    optimiser: o.file.optimiser.clone(),
                    training_residuals_deg: o.file.training_residuals_mm.clone(),
                });
                serde_json::to_string_pretty(&file)
            }
        }
        .expect("a model serialises");
        s.push('\n');
        s
    }

    /// Reads a model file written by [`ResidualModel::to_json_string`]; `source` names it in
    /// errors.
    ///
    /// # Errors
    /// [`ResidualError::File`] naming the field (an unknown or missing field, another
    /// format, lengths that differ, a value not finite or not positive);
    /// [`ResidualError::NotPositiveDefinite`] if the kernel matrix cannot be factored.
    pub fn from_json_str(text: &str, source: &str) -> Result<Self> {
        let bad = |message: String| ResidualError::File {
            source_name: source.to_string(),
            message,
        };
        let mut file: ModelFile = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        let expected = if file.orientation.is_some() {
            FORMAT_ORIENTATION
        } else {
            FORMAT
        };
        if file.format != expected {
            return Err(bad(format!(
                "format is {:?}, expected {expected:?} (a model {} the orientation part)",
                file.format,
                if file.orientation.is_some() {
                    "with"
                } else {
                    "without"
                }
            )));
        }
        let orientation = file.orientation.take().map(|o| ModelFile {
            format: FORMAT.to_string(),
            kernel: file.kernel.clone(),
            fitted_for: None,
            hyperparameters: o.hyperparameters,
            residual_mean_mm: o.residual_mean_deg,
            residual_scale_mm: o.residual_scale_deg,
            log_marginal_likelihood: o.log_marginal_likelihood,
            optimiser: o.optimiser,
            training_poses_given: file.training_poses_given,
            training_joints_deg: file.training_joints_deg.clone(),
            training_residuals_mm: o.training_residuals_deg,
            orientation: None,
        });
        let mut model = Self::checked(file, source)?;
        if let Some(o) = orientation {
            // The part's own field names in messages: `_deg` where the position part says `_mm`.
            let part = Self::checked(o, source).map_err(|e| match e {
                ResidualError::File {
                    source_name,
                    message,
                } => ResidualError::File {
                    source_name,
                    message: format!("orientation: {}", message.replace("_mm", "_deg")),
                },
                other => other,
            })?;
            model.orientation = Some(Box::new(part));
        }
        Ok(model)
    }

    /// [`ResidualModel::from_json_str`]'s checks of one part and its factor.
    fn checked(file: ModelFile, source: &str) -> Result<Self> {
        let bad = |message: String| ResidualError::File {
            source_name: source.to_string(),
            message,
        };
        let n = file.training_joints_deg.len();
        if n == 0 || file.training_residuals_mm.len() != n {
            return Err(bad(format!(
                "training_joints_deg has {n} rows and training_residuals_mm {}: they must be \
                 the same, at least one",
                file.training_residuals_mm.len()
            )));
        }
        let d = file.training_joints_deg[0].len();
        let h = &file.hyperparameters;
        if h.length_scales_rad.len() != d || d == 0 {
            return Err(bad(format!(
                "hyperparameters.length_scales_rad has {} values for {d} joints",
                h.length_scales_rad.len()
            )));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !h.length_scales_rad.iter().all(|&v| positive(v)) {
            return Err(bad(
                "hyperparameters.length_scales_rad: every value must be finite and > 0".into(),
            ));
        }
        if !positive(h.signal_variance) || !positive(h.noise_variance) {
            return Err(bad(
                "hyperparameters.signal_variance and noise_variance must be finite and > 0".into(),
            ));
        }
        if !file.residual_scale_mm.iter().all(|&v| positive(v))
            || !file.residual_mean_mm.iter().all(|v| v.is_finite())
        {
            return Err(bad(
                "residual_scale_mm must be finite and > 0, residual_mean_mm finite".into(),
            ));
        }
        check_rows(&file.training_joints_deg, "training_joints_deg", d)
            .map_err(|e| bad(e.to_string()))?;
        if let Some(row) = file
            .training_residuals_mm
            .iter()
            .position(|r| r.iter().any(|v| !v.is_finite()))
        {
            return Err(bad(format!(
                "training_residuals_mm row {row} is not finite"
            )));
        }
        Self::from_file(file, &format!("reading {source}"))
    }
}

fn check_options(o: &GpOptions) -> Result<()> {
    let ok = |start: f64, [lo, hi]: [f64; 2]| {
        lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= start && start <= hi
    };
    if o.max_train_poses < MIN_TRAIN_POSES
        || !ok(o.length_scale_start_rad, o.length_scale_bounds_rad)
        || !ok(o.signal_variance_start, o.signal_variance_bounds)
        || !ok(o.noise_variance_start, o.noise_variance_bounds)
    {
        return Err(ResidualError::Data(format!(
            "options: every start value must lie within its bounds, the bounds be positive and \
             finite, max_train_poses at least {MIN_TRAIN_POSES} ({o:?})"
        )));
    }
    Ok(())
}

/// Mean and population standard deviation of each axis (a standard deviation of 0 is
/// taken as 1, as scikit-learn does).
fn normalisation(r: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let n = r.len() as f64;
    let mean = [0, 1, 2].map(|c| r.iter().map(|v| v[c]).sum::<f64>() / n);
    let scale = [0, 1, 2].map(|c| {
        let s = (r.iter().map(|v| (v[c] - mean[c]).powi(2)).sum::<f64>() / n).sqrt();
        if s > 0.0 { s } else { 1.0 }
    });
    (mean, scale)
}

fn train_set(q: &[Vec<f64>], r: &[[f64; 3]], mean: [f64; 3], scale: [f64; 3]) -> Train {
    let d = q[0].len();
    Train {
        n: q.len(),
        d,
        x: q.iter()
            .flat_map(|row| row.iter().map(|v| v.to_radians()))
            .collect(),
        y: r.iter()
            .flat_map(|v| [0, 1, 2].map(|c| (v[c] - mean[c]) / scale[c]))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In-place lower Cholesky factor of the symmetric `n × n` row-major `a` (its lower
    /// triangle is read and overwritten by `L`). `false` if a pivot is not positive.
    fn cholesky_unblocked(a: &mut [f64], n: usize) -> bool {
        for j in 0..n {
            let (upto, rest) = a.split_at_mut((j + 1) * n);
            let row_j = &mut upto[j * n..];
            let s = row_j[j] - dot(&row_j[..j], &row_j[..j]);
            if !(s > 0.0 && s.is_finite()) {
                return false;
            }
            row_j[j] = s.sqrt();
            let (row_j, ljj) = (&upto[j * n..j * n + j], upto[j * n + j]);
            for i in (j + 1)..n {
                let row_i = &mut rest[(i - j - 1) * n..(i - j) * n];
                row_i[j] = (row_i[j] - dot(&row_i[..j], row_j)) / ljj;
            }
        }
        true
    }

    /// `K⁻¹` (full symmetric, row-major) from its lower Cholesky factor: `U = L⁻ᵀ` row by row
    /// (row `j` of `U` is `L⁻¹ e_j`), then `(K⁻¹)_ab = Σ_{k ≥ max(a,b)} U_ak U_bk`.
    fn inverse_unblocked(l: &[f64], n: usize) -> Vec<f64> {
        let mut u = vec![0.0; n * n];
        for j in 0..n {
            let row = &mut u[j * n..(j + 1) * n];
            row[j] = 1.0 / l[j * n + j];
            for i in (j + 1)..n {
                let li = &l[i * n + j..i * n + i];
                row[i] = -dot(li, &row[j..i]) / l[i * n + i];
            }
        }
        let mut inv = vec![0.0; n * n];
        for a in 0..n {
            for b in a..n {
                let v = dot(&u[a * n + b..(a + 1) * n], &u[b * n + b..(b + 1) * n]);
                inv[a * n + b] = v;
                inv[b * n + a] = v;
            }
        }
        inv
    }

    /// The blocked factor and inverse give the bits of the plain loops (sizes around the
    /// block size and not multiples of it).
    #[test]
    fn blocking_changes_no_bit() {
        for n in [1, 7, 8, 9, 37] {
            let q: Vec<Vec<f64>> = (0..n)
                .map(|i| {
                    (0..3)
                        .map(|k| ((i * 31 + k * 17) % 97) as f64 - 48.0)
                        .collect()
                })
                .collect();
            let r = vec![[0.0; 3]; n];
            let train = train_set(&q, &r, [0.0; 3], [1.0; 3]);
            let mut a = train.kernel_f(&[0.7, 1.1, 0.4], 1.3);
            for i in 0..n {
                a[i * n + i] += 0.01;
            }
            let (mut l, mut l_ref) = (a.clone(), a);
            assert!(cholesky(&mut l, n) && cholesky_unblocked(&mut l_ref, n));
            for i in 0..n {
                for j in 0..=i {
                    assert_eq!(
                        l[i * n + j].to_bits(),
                        l_ref[i * n + j].to_bits(),
                        "L {i} {j}"
                    );
                }
            }
            let (inv, inv_ref) = (inverse_from_cholesky(&l, n), inverse_unblocked(&l, n));
            assert!(
                inv.iter()
                    .zip(&inv_ref)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
        }
    }

    /// The Cholesky factor, the solves and the inverse on a small SPD matrix.
    #[test]
    fn factor_solve_inverse() {
        let n = 5;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] =
                    1.0 / (1.0 + (i as f64 - j as f64).abs()) + if i == j { 2.0 } else { 0.0 };
            }
        }
        let mut l = a.clone();
        assert!(cholesky(&mut l, n));
        let inv = inverse_from_cholesky(&l, n);
        for i in 0..n {
            for j in 0..n {
                let p: f64 = (0..n).map(|k| a[i * n + k] * inv[k * n + j]).sum();
                assert!(
                    (p - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12,
                    "{i} {j} {p}"
                );
            }
        }
        let b: Vec<f64> = (0..n).map(|i| i as f64 - 1.5).collect();
        let mut x = b.clone();
        forward(&l, n, &mut x);
        backward(&l, n, &mut x);
        for i in 0..n {
            let p: f64 = (0..n).map(|k| a[i * n + k] * x[k]).sum();
            assert!((p - b[i]).abs() < 1e-12);
        }
        let mut not_pd = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky(&mut not_pd, 2));
    }

    /// The analytic gradient of the marginal likelihood against central differences.
    #[test]
    fn gradient_matches_finite_differences() {
        let q: Vec<Vec<f64>> = (0..25)
            .map(|i| {
                let t = i as f64;
                vec![(t * 37.0) % 170.0 - 85.0, (t * 53.0) % 120.0 - 60.0]
            })
            .collect();
        let r: Vec<[f64; 3]> = q
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let (a, b) = (v[0].to_radians(), v[1].to_radians());
                [
                    a.sin() + 0.1 * (i % 3) as f64,
                    (a * b).cos(),
                    b * 0.3 - 0.05 * (i % 2) as f64,
                ]
            })
            .collect();
        let (m, s) = normalisation(&r);
        let train = train_set(&q, &r, m, s);
        let theta = [0.2f64, -0.3, 0.1, -2.0];
        let (_, g) = train.objective(&theta).unwrap();
        for k in 0..theta.len() {
            let h = 1e-5;
            let (mut tp, mut tm) = (theta, theta);
            tp[k] += h;
            tm[k] -= h;
            let fd =
                (train.objective(&tp).unwrap().0 - train.objective(&tm).unwrap().0) / (2.0 * h);
            assert!(
                (fd - g[k]).abs() < 1e-5 * (1.0 + fd.abs()),
                "θ{k}: analytic {} fd {fd}",
                g[k]
            );
        }
    }
}
