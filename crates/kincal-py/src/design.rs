//! `kincal.design`: which poses to measure, chosen by the design crate's `design_selection`
//! (the selection of `design_plan`, which `kincal design` writes as a plan file).

use numpy::{PyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::arrays::{ArrayArg, index_array, joint_rows, memory_set};
use crate::errors::{kincal_error, kincal_error_in};
use crate::interrupt::run_interruptible;
use crate::options::{params_arg, parse_arg};
use crate::robot::PyRobot;

/// Registers `design`.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_design, m)?)
}

/// Indices (into the candidates) of the `n` poses the design criterion chooses, each pose
/// measuring `measure` (`point`, `frame` or `targets`), as `kincal design --candidates` does
/// with the same rows.
#[pyfunction(name = "design")]
#[pyo3(signature = (
    robot, candidates_q_deg, n, *, criterion = "d", workspace_q_deg = None,
    params = None, seed = 1, restarts = 0, measure = "point"
))]
#[allow(clippy::too_many_arguments)]
fn py_design<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    candidates_q_deg: ArrayArg<'py>,
    n: usize,
    criterion: &str,
    workspace_q_deg: Option<ArrayArg<'py>>,
    params: Option<Bound<'py, PyAny>>,
    seed: u64,
    restarts: usize,
    measure: &str,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let loaded = &robot.loaded;
    let nj = loaded.robot.n_joints();
    let criterion: design::Criterion = criterion.parse().map_err(crate::errors::refuse)?;
    let measure: design::Measure = parse_arg("measure", measure)?;
    let spec = match &params {
        Some(p) => params_arg(p)?,
        None => "minimal".parse().expect("a parameter spec always parses"),
    };
    // The candidates' count as the CLI checks it (each is designed on: a pose's memory).
    campaign::check_poses(candidates_q_deg.shape().first().copied().unwrap_or(0))
        .map_err(|e| crate::errors::size_error("candidates_q_deg", &e))?;
    let cand = memory_set(
        "candidates",
        nj,
        joint_rows(&candidates_q_deg, nj, "candidates_q_deg")?,
        None,
    );
    let work = workspace_q_deg
        .map(|w| -> PyResult<_> {
            Ok(memory_set(
                "workspace",
                nj,
                joint_rows(&w, nj, "workspace_q_deg")?,
                None,
            ))
        })
        .transpose()?;
    // Ctrl-C stops the selection at its next step (`DesignOptions::stop`).
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop_flag = design::StopFlag::new(stop.clone());
    let work = || -> PyResult<Vec<usize>> {
        let candidates = loaded
            .check_set(cand, false, "candidates")
            .map_err(|e| kincal_error(&e))?;
        let workspace = work
            .map(|w| {
                loaded
                    .check_set(w, false, "workspace")
                    .map_err(|e| kincal_error(&e))
            })
            .transpose()?;
        // The extended parameters after `+` join the geometric ones, as in `kincal design`.
        let spec_err =
            |e: identify::IdentifyError| kincal_error_in(&format!("params `{spec}`"), &e);
        let model_robot = spec
            .apply(&loaded.robot, &loaded.path.display().to_string())
            .map_err(spec_err)?;
        let names = spec.listed(&model_robot).map_err(spec_err)?;
        let pool = design::Candidates::from_set(&candidates);
        let ws = workspace.map(|w| design::Candidates::from_set(&w));
        let mut opts = design::DesignOptions::new(criterion, n);
        opts.seed = seed;
        opts.restarts = restarts;
        opts.stop = stop_flag;
        // No random sets: the indices are the answer, the comparison is not returned.
        let (selected, _) = design::design_selection(
            &model_robot,
            &pool,
            ws.as_ref(),
            names.as_deref(),
            measure,
            &opts,
            0,
        )
        .map_err(|e| match measure {
            design::Measure::Point => kincal_error(&e),
            _ => kincal_error_in(&format!("measure {measure}"), &e),
        })?;
        Ok(selected)
    };
    let chosen = run_interruptible(py, &stop, work, || Ok(()))??;
    Ok(index_array(py, chosen))
}
