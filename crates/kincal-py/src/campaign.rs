//! `kincal.campaign` and `kincal.simulate`: Monte Carlo campaigns and simulated measurement
//! sets of a scenario (a file or a dict).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{rows_array, vec_rows_array};
use crate::errors::{kincal_error, kincal_error_in, refuse};
use crate::interrupt::run_interruptible;

/// Registers `campaign` and `simulate`.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(py_simulate, m)?)?;
    Ok(())
}

/// A scenario given as a path or a dict (JSON-serialisable, the file's fields; a relative
/// `robot` path is taken from the current directory), loaded and checked by the campaign
/// crate as `kincal campaign` loads a file.
fn scenario_arg(py: Python<'_>, scenario: &Bound<'_, PyAny>) -> PyResult<campaign::LoadedScenario> {
    if let Ok(path) = scenario.extract::<PathBuf>() {
        return py
            .detach(|| campaign::Scenario::from_file(&path))
            .map_err(|e| kincal_error(&e));
    }
    let text: String = py
        .import("json")?
        .call_method1("dumps", (scenario,))
        .map_err(|e| {
            refuse(format!(
                "scenario: expected a path or a JSON-serialisable dict ({e})"
            ))
        })?
        .extract()?;
    let label = "scenario dict";
    py.detach(|| {
        campaign::Scenario::from_json_str(&text, label)
            .and_then(|s| s.load(std::path::Path::new("."), label))
    })
    .map_err(|e| kincal_error(&e))
}

/// Counts the progress of a campaign from the worker threads (atomics only; the Python
/// callback is called on the calling thread), and carries the calling thread's request to
/// stop (a signal such as Ctrl-C, or an exception in the callback) to them.
#[derive(Default)]
pub(crate) struct Progress {
    done: std::sync::atomic::AtomicU64,
    total: std::sync::atomic::AtomicU64,
    stop: std::sync::atomic::AtomicBool,
}

impl campaign::Observer for Progress {
    fn phase_started(&self, _phase: campaign::Phase, total: u64) {
        self.total
            .fetch_add(total, std::sync::atomic::Ordering::Relaxed);
    }
    fn trials_done(&self, k: u64) {
        self.done.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
    }
    fn stop_requested(&self) -> bool {
        self.stop.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// `threads=`, capped by [`campaign::cap_threads`] as the CLI caps `--threads`, with a
/// `UserWarning` when it was.
fn capped_threads(py: Python<'_>, threads: Option<usize>) -> PyResult<Option<usize>> {
    let Some(asked) = threads else {
        return Ok(None);
    };
    let (t, note) = campaign::cap_threads(asked);
    if let Some(note) = note {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        py.import("warnings")?
            .call_method1("warn", (format!("threads={note}"), category, 2))?;
    }
    Ok(Some(t))
}

/// Runs a Monte Carlo campaign of a scenario (a file or a dict) and returns its summary, the
/// contents of the `summary.json` that `kincal campaign` writes for the same scenario and
/// options, as a dict.
#[pyfunction(name = "campaign")]
#[pyo3(signature = (
    scenario, *, trials = None, threads = None, seed = None, progress = None, iso = true,
    budget = true
))]
#[allow(clippy::too_many_arguments)]
fn py_campaign<'py>(
    py: Python<'py>,
    scenario: Bound<'py, PyAny>,
    trials: Option<u64>,
    threads: Option<usize>,
    seed: Option<u64>,
    progress: Option<Bound<'py, PyAny>>,
    iso: bool,
    budget: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if trials == Some(0) {
        return Err(refuse("trials must be at least 1"));
    }
    if threads == Some(0) {
        return Err(refuse("threads must be at least 1"));
    }
    let mut loaded = scenario_arg(py, &scenario)?;
    let s = &mut loaded.scenario;
    s.iso.enabled &= iso;
    s.residual_budget.enabled &= budget;
    if let Some(t) = trials {
        s.trials = t;
    }
    if let Some(seed) = seed {
        s.seed = seed;
    }
    let threads = capped_threads(py, threads)?;
    let counter = Progress::default();
    let mut reported = (u64::MAX, u64::MAX);
    // Ctrl-C or an exception in `progress` stops the workers before their next trial
    // (`Observer::stop_requested`) and is raised as it was.
    let outcome = run_interruptible(
        py,
        &counter.stop,
        || campaign::summarize(loaded, threads, &counter),
        || {
            if let Some(cb) = &progress {
                let now = (
                    counter.done.load(std::sync::atomic::Ordering::Relaxed),
                    counter.total.load(std::sync::atomic::Ordering::Relaxed),
                );
                if now != reported {
                    reported = now;
                    cb.call1(now)?;
                }
            }
            Ok(())
        },
    )?;
    let outcome = outcome.map_err(|e| kincal_error(&e))?;
    py.import("json")?
        .call_method1("loads", (outcome.summary.to_json(),))
}

/// A simulated measurement set of trial `trial` of a scenario (a file or a dict): what
/// `kincal simulate` writes as `identification.csv` and `validation.csv`, as arrays
/// `{"identification_q_deg", "identification_points_mm", "validation_q_deg",
/// "validation_points_mm"}`.
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scenario, *, seed = None, trial = 0))]
fn py_simulate<'py>(
    py: Python<'py>,
    scenario: Bound<'py, PyAny>,
    seed: Option<u64>,
    trial: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let loaded = scenario_arg(py, &scenario)?;
    let seed = seed.unwrap_or(loaded.scenario.seed);
    let sim = py
        .detach(|| {
            virtual_robot::simulate_with(
                &loaded.nominal,
                &loaded.virtual_robot(),
                seed,
                trial,
                &loaded.scenario.measurement.probe(),
            )
        })
        .map_err(|e| {
            kincal_error_in(
                &format!("simulating trial {trial} of {}", loaded.source),
                &e,
            )
        })?;
    let n = loaded.nominal.n_joints();
    let d = PyDict::new(py);
    for (name, set) in [
        ("identification", &sim.identification),
        ("validation", &sim.validation),
    ] {
        let q: Vec<Vec<f64>> = set.rows.iter().map(|r| r.q_deg.clone()).collect();
        let p: Vec<[f64; 3]> = set
            .rows
            .iter()
            .map(|r| r.point_mm.unwrap_or([f64::NAN; 3]))
            .collect();
        d.set_item(format!("{name}_q_deg"), vec_rows_array(py, &q, n))?;
        d.set_item(format!("{name}_points_mm"), rows_array(py, &p))?;
        if set.has_orientation() {
            let o: Vec<[f64; 4]> = set
                .rows
                .iter()
                .map(|r| r.orientation.unwrap_or([f64::NAN; 4]))
                .collect();
            d.set_item(format!("{name}_orientations_wxyz"), rows_array(py, &o))?;
        }
        if set.has_targets() {
            let column = |f: fn(&measurements::Measurement) -> Option<&String>| -> Vec<String> {
                set.rows
                    .iter()
                    .map(|r| f(r).cloned().unwrap_or_default())
                    .collect()
            };
            d.set_item(format!("{name}_targets"), column(|r| r.target.as_ref()))?;
            d.set_item(format!("{name}_pose_ids"), column(|r| r.id.as_ref()))?;
        }
    }
    Ok(d)
}
