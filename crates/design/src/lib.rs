//! Experiment design: which poses to measure.
//!
//! ```text
//! candidates ─► design (criterion, N) ─► plan.csv ─► measure / simulate ─► identify ─► evaluate
//! ```
//!
//! * [`Candidates`]: a pool of joint configurations — poses drawn by the caller (the front
//!   end and the campaign sample them with the virtual robot: joint limits, floor, tracker
//!   window, singularity distance; this crate does not link the simulator), a joint CSV (ids
//!   kept) or the joints of a measurement file; files are read by `measurements`, so a bad
//!   value is reported with its file, line and column.
//! * [`InfoModel`]: each candidate's 3 × p identification-Jacobian block on the minimal
//!   identifiable set (`identify`'s rank decision, `kinematics::Robot`'s analytic Jacobian),
//!   columns multiplied by a physical [`Scale`] (the expected size of each parameter's error),
//!   and the workspace matrix W of the I criterion.
//! * [`Criterion`]: D, A, E, I, O1, O3, O5 on `M = Σ B_iᵀB_i` (formulas in
//!   [`criterion`]); [`dense_value`] is the straightforward reference.
//! * [`select()`]: greedy forward selection with rank-3 updates, then exchange until no swap
//!   improves the criterion, optional seeded restarts (see the [`mod@select`] module for the
//!   algebra). Deterministic.
//! * [`compare()`]: the design's criterion, condition number and O1–O5 beside the medians of
//!   random sets of the same size.
//! * [`select_rows`]: the real-data entry point (rows of a recording chosen by their joints).
//!
//! ```
//! use design::{Candidates, Criterion, DesignOptions, InfoModel, Scale, select};
//! use kinematics::{PoseSampler, Robot};
//! use rand::{SeedableRng, rngs::ChaCha8Rng};
//!
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
//!     .join("../../scenarios/robots/kr1000-titan.json");
//! let robot = Robot::from_file(&path)?;
//! let pool = PoseSampler::default()
//!     .sample(&robot, 200, &mut ChaCha8Rng::seed_from_u64(1))?
//!     .rad;
//! let model = InfoModel::new(&robot, &pool, None, None, &Scale::default())?;
//! assert_eq!(model.p, 27); // the KR1000's minimal set
//! let design = select(&model, &DesignOptions::new(Criterion::D, 15))?;
//! assert_eq!(design.selected.len(), 15);
//! assert!(design.value >= design.greedy_value);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub mod candidates;
pub mod comparison;
pub mod criterion;
mod error;
pub mod frames;
pub mod measure;
pub mod model;
pub mod select;

pub use candidates::Candidates;
pub use comparison::{DesignComparison, SetFigures, compare};
pub use criterion::{Criterion, condition_number, dense_value, observability};
pub use error::DesignError;
pub use measure::Measure;
pub use model::{InfoModel, Scale};
pub use select::{Design, DesignOptions, StopFlag, select};

use kinematics::Robot;

/// Real data: chooses `n` of the rows whose joints (degrees, flat, stride N) are `q_deg`,
/// by `criterion` on the minimal identifiable set (or `params`), with the default
/// [`Scale`]. Returns the chosen row indices, ascending. The robot should be the model the
/// data will be identified with (e.g. the nominal model registered in the tracker frame);
/// only the joints are used.
pub fn select_rows(
    robot: &Robot,
    q_deg: &[f64],
    n: usize,
    criterion: Criterion,
    params: Option<&[usize]>,
) -> Result<Vec<usize>, DesignError> {
    select_rows_measuring(robot, q_deg, n, criterion, params, Measure::Point)
}

/// [`select_rows`] for poses that each measure `measure` (a 6-DoF frame, or the robot file's
/// targets): the information matrix of those rows ([`InfoModel::with_measure`]).
pub fn select_rows_measuring(
    robot: &Robot,
    q_deg: &[f64],
    n: usize,
    criterion: Criterion,
    params: Option<&[usize]>,
    measure: Measure,
) -> Result<Vec<usize>, DesignError> {
    let q_rad: Vec<f64> = q_deg.iter().map(|d| d.to_radians()).collect();
    let model = InfoModel::with_measure(robot, &q_rad, None, params, &Scale::default(), measure)?;
    Ok(select(&model, &DesignOptions::new(criterion, n))?.selected)
}

/// The design of a plan file: chooses `opts.poses` of `candidates` for the parameters
/// `params` (names; `None`: the minimal identifiable set), measuring `measure` at each pose
/// ([`Measure`]: a point, a 6-DoF frame, or the robot file's targets), with the I
/// criterion's workspace `workspace` (`None`: the candidates), and compares with
/// `random_sets` random sets of the same size. For a frame or targets the comparison also
/// states what a single reflector would need (its unknowns and equations per pose). Returns
/// the plan (joints-only measurement set, candidate ids kept, in pool order) and its
/// comparison with random sets. Nothing is written.
pub fn design_plan(
    robot: &Robot,
    candidates: &Candidates,
    workspace: Option<&Candidates>,
    params: Option<&[String]>,
    measure: Measure,
    opts: &DesignOptions,
    random_sets: usize,
) -> Result<(measurements::MeasurementSet, DesignComparison), DesignError> {
    let (selected, rep) = design_selection(
        robot,
        candidates,
        workspace,
        params,
        measure,
        opts,
        random_sets,
    )?;
    Ok((candidates.plan(&selected, &candidates.source), rep))
}

/// [`design_plan`]'s choice as indices into `candidates` (in the order [`select()`] gives
/// them), with the same comparison: for a front end that wants the rows rather than a plan
/// file (the Python binding's `design`).
pub fn design_selection(
    robot: &Robot,
    candidates: &Candidates,
    workspace: Option<&Candidates>,
    params: Option<&[String]>,
    measure: Measure,
    opts: &DesignOptions,
    random_sets: usize,
) -> Result<(Vec<usize>, DesignComparison), DesignError> {
    let params = params.map(|p| robot.layout().select(p)).transpose()?;
    let model = InfoModel::with_measure(
        robot,
        &candidates.q_rad,
        workspace.map(|w| w.q_rad.as_slice()),
        params.as_deref(),
        &Scale::default(),
        measure,
    )
    .map_err(|e| with_ids(e, candidates))?;
    let d = select(&model, opts)?;
    let mut rep = compare(&model, &d, random_sets, opts.seed);
    if measure != Measure::Point {
        // What one reflector would need: the identification's unknowns for points.
        let point = match params.as_deref() {
            Some(p) => p.len(),
            None => {
                let generic = identify::generic_poses(robot)?;
                identify::ParamSet::Minimal
                    .resolve(
                        robot,
                        &generic,
                        None,
                        &identify::IdentifiabilityOptions::default(),
                    )?
                    .len()
            }
        };
        rep.point_unknowns = Some(point);
    }
    Ok((d.selected, rep))
}

/// Adds the candidate's id and source line to a bad-pose error.
fn with_ids(e: DesignError, c: &Candidates) -> DesignError {
    match e {
        DesignError::BadPose {
            what: "candidate",
            index,
            id: None,
            message,
        } if index < c.len() => DesignError::BadPose {
            what: "candidate",
            index,
            id: c.ids[index].clone(),
            message: if c.lines[index] > 0 {
                format!("{}:{}: {message}", c.source, c.lines[index])
            } else {
                message
            },
        },
        other => other,
    }
}
