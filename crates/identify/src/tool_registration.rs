//! Registration of the base together with the measured point's offset from the flange (the
//! tool, `docs/model.md` §3).
//!
//! [`crate::register_base_robust`] fits the rigid transform `T = (R, b)` taking the start
//! model's predicted points onto the measured ones. When the start model's tool is wrong
//! (a probe 125 mm from the flange, the robot file saying 0), the predictions are off by
//! `R_i·Δt`, a vector that turns with the flange, and the rigid fit bends to absorb it: the
//! base yaw comes out degrees off and the fit then moves θ1 by as much (it is redundant with
//! the base yaw), which the parameters check refuses.
//!
//! Here the tool `t` is estimated with the frame: `p_i^meas ≈ R·(R_i·t + p_i) + b`, with
//! `(R_i, p_i)` the start model's flange at pose `i`.
//! 1. A linear start: written with `M = R` as a free 3×3 matrix and `W_{jk} = R_{·j}·t_k`,
//!    each coordinate of the measured point is linear in 13 unknowns
//!    (`p_i^meas = M·p_i + Σ_{jk} R_i[j,k]·W_{·jk} + b`); least squares per coordinate, `R`
//!    the rotation nearest `M`, `t_k = ⅓·Σ_j R_{·j}ᵀ·W_{·jk}`.
//! 2. Alternating closed forms to the least-squares optimum: `(R, b)` by [`kabsch`] on the
//!    inliers for the current `t`, then `(t, b)` by linear least squares for that `R` (with
//!    `y_i = Rᵀ·p_i^meas − p_i`: `S·t = Σ_i (R_i − R̄)ᵀ(y_i − ȳ)`, `S = Σ_i (R_i − R̄)ᵀ(R_i − R̄)`),
//!    each step lowering the same sum of squares, until `t` moves less than
//!    [`TOOL_TOLERANCE_MM`]; the inliers are those of [`kabsch_robust`] at the optimum, and the
//!    alternation is redone on them until they do not change.
//!
//! The tool is only determined in the directions about which the flange turns: with one
//! orientation `R_i·t` is one vector, absorbed by `b`, and a direction turned by a few degrees
//! only is fixed by the start model's geometric errors (millimetres) divided by that angle.
//! So `t` is estimated along the eigenvectors of `S/n` whose RMS rotation is at least
//! [`MIN_TOOL_ROTATION_DEG`], and keeps the robot file's value along the others; with no such
//! direction the estimate is refused ([`IdentifyError::Registration`]).

use kinematics::{Frame, Robot};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::error::IdentifyError;
use crate::problem::check_poses_and_points;
use crate::registration::{
    RegistrationReport, RigidTransform, RobustRegistration, kabsch, kabsch_robust,
};
use kinematics::rotation::project_so3;

/// Convergence of the alternation: the tool moves less than this in one step, mm [1e-9: far
/// below any measurement; the alternation converges linearly, from the linear start within
/// tens of steps].
pub const TOOL_TOLERANCE_MM: f64 = 1e-9;

/// Alternation steps at most per set of inliers [500].
const MAX_STEPS: usize = 500;

/// Re-selections of the inliers at most [5].
const MAX_INLIER_ROUNDS: usize = 5;

/// Least RMS rotation of the flange about a direction for the tool to be estimated along it,
/// degrees [2: the estimate along a direction turned by φ moves by the start model's
/// geometric error over φ (2.6 mm at 10° gives 15 mm: enough to unbend a registration that a
/// tool 100 mm off tilts by degrees); below 2° it would move by a decimetre for nothing. The
/// UR10 of `data/ur10-ipa` turns its flange 10° RMS at most: its data keep the tool's axis
/// nearly vertical].
pub const MIN_TOOL_ROTATION_DEG: f64 = 2.0;

/// A registration of the base with the tool estimated.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolRegistration {
    /// The robot with its base registered and its tool the estimate; the medians and the
    /// inliers as [`crate::register_base_robust`]'s.
    pub registration: RobustRegistration,
    /// The start model's tool, mm.
    pub tool_before_mm: Vector3<f64>,
    /// The estimated tool (in the flange frame), mm.
    pub tool_after_mm: Vector3<f64>,
    /// The RMS rotations of the flange about the principal directions of its motion,
    /// ascending, degrees: the tool is estimated along those of at least
    /// [`MIN_TOOL_ROTATION_DEG`] and kept along the others.
    pub flange_rotation_deg: Vec<f64>,
}

/// The tool's leverage: the mean flange orientation `R̄`, and the eigen-decomposition of
/// `S/n = Σ_i (R_i − R̄)ᵀ(R_i − R̄) / n` (its eigenvalues the squared RMS rotations, rad²,
/// about its eigenvectors).
struct Leverage {
    mean: Matrix3<f64>,
    values: Vector3<f64>,
    vectors: Matrix3<f64>,
}

impl Leverage {
    fn new(flanges: &[Frame], idx: &[usize]) -> Leverage {
        let n = idx.len().max(1) as f64;
        let mean = idx.iter().map(|&i| flanges[i].rot).sum::<Matrix3<f64>>() / n;
        let s: Matrix3<f64> = idx
            .iter()
            .map(|&i| (flanges[i].rot - mean).transpose() * (flanges[i].rot - mean))
            .sum::<Matrix3<f64>>()
            / n;
        let eig = s.symmetric_eigen();
        Leverage {
            mean,
            values: eig.eigenvalues,
            vectors: eig.eigenvectors,
        }
    }

    /// Whether direction `j` turns enough ([`MIN_TOOL_ROTATION_DEG`]).
    fn strong(&self, j: usize) -> bool {
        self.values[j].max(0.0).sqrt().to_degrees() >= MIN_TOOL_ROTATION_DEG
    }

    /// The RMS rotations, degrees, ascending.
    fn rotations_deg(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .values
            .iter()
            .map(|l| l.max(0.0).sqrt().to_degrees())
            .collect();
        v.sort_by(f64::total_cmp);
        v
    }

    /// `t` along the strong directions, `keep` along the others.
    fn project(&self, t: &Vector3<f64>, keep: &Vector3<f64>) -> Vector3<f64> {
        (0..3)
            .map(|j| {
                let v = self.vectors.column(j).into_owned();
                v * if self.strong(j) {
                    v.dot(t)
                } else {
                    v.dot(keep)
                }
            })
            .sum()
    }
}

/// The linear start: `(R, b, t)` from the 13-unknown least squares per coordinate.
fn linear_start(
    flanges: &[Frame],
    measured: &[Vector3<f64>],
) -> Option<(RigidTransform, Vector3<f64>)> {
    let n = flanges.len();
    let mut a = DMatrix::<f64>::zeros(n, 13);
    for (i, f) in flanges.iter().enumerate() {
        for c in 0..3 {
            a[(i, c)] = f.pos_mm[c];
        }
        for j in 0..3 {
            for k in 0..3 {
                a[(i, 3 + 3 * j + k)] = f.rot[(j, k)];
            }
        }
        a[(i, 12)] = 1.0;
    }
    let svd = a.svd(true, true);
    let mut m = Matrix3::zeros();
    let mut w = [[Vector3::zeros(); 3]; 3];
    let mut b = Vector3::zeros();
    for c in 0..3 {
        let y = DVector::from_iterator(n, measured.iter().map(|p| p[c]));
        let x = svd.solve(&y, 1e-12).ok()?;
        for col in 0..3 {
            m[(c, col)] = x[col];
        }
        for j in 0..3 {
            for k in 0..3 {
                w[j][k][c] = x[3 + 3 * j + k];
            }
        }
        b[c] = x[12];
    }
    if !m.iter().chain(b.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let r = project_so3(&m);
    let t = Vector3::from_fn(|k, _| (0..3).map(|j| r.column(j).dot(&w[j][k])).sum::<f64>() / 3.0);
    Some((
        RigidTransform {
            rotation: r,
            translation_mm: b,
        },
        t,
    ))
}

/// The tool minimising `Σ_i ‖R·(R_i·t + p_i) + b − p_i^meas‖²` over `idx` and `b` for the
/// rotation of `t` (module docs), along the strong directions of `lev`; `keep` along the
/// others.
fn tool_step(
    t: &RigidTransform,
    flanges: &[Frame],
    measured: &[Vector3<f64>],
    idx: &[usize],
    lev: &Leverage,
    keep: &Vector3<f64>,
) -> Vector3<f64> {
    let rt = t.rotation.transpose();
    let n = idx.len().max(1) as f64;
    let y: Vec<Vector3<f64>> = idx
        .iter()
        .map(|&i| rt * measured[i] - flanges[i].pos_mm)
        .collect();
    let y_mean = y.iter().sum::<Vector3<f64>>() / n;
    let h: Vector3<f64> = idx
        .iter()
        .zip(&y)
        .map(|(&i, yi)| (flanges[i].rot - lev.mean).transpose() * (yi - y_mean))
        .sum::<Vector3<f64>>()
        / n;
    (0..3)
        .map(|j| {
            let v = lev.vectors.column(j).into_owned();
            v * if lev.strong(j) {
                v.dot(&h) / lev.values[j]
            } else {
                v.dot(keep)
            }
        })
        .sum()
}

fn predicted(flanges: &[Frame], tool: &Vector3<f64>) -> Vec<Vector3<f64>> {
    flanges.iter().map(|f| f.rot * tool + f.pos_mm).collect()
}

/// Alternation to the optimum on the points `idx`, from the tool `tool`.
fn alternate(
    flanges: &[Frame],
    measured: &[Vector3<f64>],
    idx: &[usize],
    mut tool: Vector3<f64>,
    keep: &Vector3<f64>,
) -> Result<(RigidTransform, Vector3<f64>), IdentifyError> {
    let lev = Leverage::new(flanges, idx);
    let to: Vec<Vector3<f64>> = idx.iter().map(|&i| measured[i]).collect();
    let mut t = kabsch(
        &idx.iter()
            .map(|&i| flanges[i].rot * tool + flanges[i].pos_mm)
            .collect::<Vec<_>>(),
        &to,
    )?;
    for _ in 0..MAX_STEPS {
        let next = tool_step(&t, flanges, measured, idx, &lev, keep);
        let moved = (next - tool).norm();
        tool = next;
        let from: Vec<Vector3<f64>> = idx
            .iter()
            .map(|&i| flanges[i].rot * tool + flanges[i].pos_mm)
            .collect();
        t = kabsch(&from, &to)?;
        if moved < TOOL_TOLERANCE_MM {
            break;
        }
    }
    Ok((t, tool))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Registers `robot`'s base to the measurements with its tool estimated (module docs).
///
/// # Errors
/// The data's errors (lengths, finiteness); [`IdentifyError::Registration`] when the points
/// are collinear or the flange orientations do not determine the tool.
pub fn register_base_and_tool(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
) -> Result<ToolRegistration, IdentifyError> {
    check_poses_and_points(robot, poses_rad, points_mm)?;
    let flanges: Vec<Frame> = poses_rad
        .chunks_exact(robot.n_joints())
        .map(|q| robot.flange(q))
        .collect();
    let all: Vec<usize> = (0..flanges.len()).collect();
    let lev = Leverage::new(&flanges, &all);
    if !(0..3).any(|j| lev.strong(j)) || flanges.len() < 5 {
        return Err(IdentifyError::Registration {
            reason: format!(
                "the flange turns {:.2}° RMS about its most turned direction (at least \
                 {MIN_TOOL_ROTATION_DEG}° needed): the tool offset is not determined",
                lev.rotations_deg()[2]
            ),
        });
    }
    let tool0 = robot.tool_mm();
    let start = linear_start(&flanges, points_mm).map_or(tool0, |(_, t)| lev.project(&t, &tool0));
    let (mut t, mut tool) = alternate(&flanges, points_mm, &all, start, &tool0)?;
    let mut inliers = all;
    for _ in 0..MAX_INLIER_ROUNDS {
        let (_, next) = kabsch_robust(&predicted(&flanges, &tool), points_mm)?;
        if next == inliers {
            break;
        }
        inliers = next;
        (t, tool) = alternate(&flanges, points_mm, &inliers, tool, &tool0)?;
    }
    // The base re-expressed as `T · T_base`, the tool replaced.
    let (mut registered, base_before, base_after) = crate::registration::base_moved_by(robot, &t)?;
    registered.set_tool_mm(tool);
    let mut before: Vec<f64> = robot
        .points(poses_rad)
        .iter()
        .zip(points_mm)
        .map(|(a, b)| (a - b).norm())
        .collect();
    let mut after: Vec<f64> = registered
        .points(poses_rad)
        .iter()
        .zip(points_mm)
        .map(|(a, b)| (a - b).norm())
        .collect();
    let m = before.len().max(1) as f64;
    let report = RegistrationReport {
        applied: true,
        mean_error_before_mm: before.iter().sum::<f64>() / m,
        mean_error_after_mm: after.iter().sum::<f64>() / m,
        rotation_deg: t.angle_deg(),
        translation_mm: t.translation_mm.into(),
        base_before,
        base_after,
    };
    Ok(ToolRegistration {
        registration: RobustRegistration {
            robot: registered,
            report,
            inliers,
            median_before_mm: median(&mut before),
            median_after_mm: median(&mut after),
        },
        tool_before_mm: tool0,
        tool_after_mm: tool,
        flange_rotation_deg: lev.rotations_deg(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinematics::{PoseSampler, RobotSpec};
    use nalgebra::Rotation3;
    use rand::{SeedableRng, rngs::ChaCha8Rng};

    /// A KR1000 whose probe is 180 mm from where the file says, measured noise-free in a frame
    /// turned 150° about z and 29° about x: the joint estimate recovers the tool and the frame
    /// exactly, where the rigid fit alone leaves tens of millimetres.
    #[test]
    fn the_tool_and_the_frame_are_recovered_together() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenarios/robots/kr1000-titan.json"
        ))
        .unwrap();
        let nominal =
            Robot::from_spec(&RobotSpec::from_json_str(&text, "kr1000").unwrap()).unwrap();
        let poses = PoseSampler::default()
            .sample(&nominal, 60, &mut ChaCha8Rng::seed_from_u64(3))
            .unwrap()
            .rad;
        let mut truth = nominal.clone();
        let true_tool = nominal.tool_mm() + Vector3::new(60.0, -40.0, 165.0);
        truth.set_tool_mm(true_tool);
        let frame = Rotation3::from_euler_angles(0.5, 0.0, 150f64.to_radians());
        let shift = Vector3::new(2500.0, -800.0, 300.0);
        let measured: Vec<Vector3<f64>> = truth
            .points(&poses)
            .iter()
            .map(|p| frame * p + shift)
            .collect();
        let r = register_base_and_tool(&nominal, &poses, &measured).unwrap();
        assert!(
            (r.tool_after_mm - true_tool).norm() < 1e-6,
            "{}",
            r.tool_after_mm
        );
        assert!(r.registration.report.mean_error_after_mm < 1e-6);
        assert_eq!(r.registration.inliers.len(), 60);
        let bent = crate::register_base_robust(&nominal, &poses, &measured).unwrap();
        assert!(bent.report.mean_error_after_mm > 10.0);
        // One orientation only: the tool is not determined, and said so.
        let still: Vec<f64> = poses[..6].repeat(10);
        let p: Vec<Vector3<f64>> = truth.points(&still);
        let e = register_base_and_tool(&nominal, &still, &p).unwrap_err();
        assert!(e.to_string().contains("not determined"), "{e}");
    }
}
