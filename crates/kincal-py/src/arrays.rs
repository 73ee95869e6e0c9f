//! Conversion of arrays: numpy arguments checked for shape into rows and measurement sets,
//! and rows back into numpy arrays. Errors name the argument and the shape expected.

use numpy::ndarray::{Array1, Array2};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayLikeDyn,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{refuse, size_error};

/// A numpy-convertible float64 array of any shape (lists are converted).
pub(crate) type ArrayArg<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [k] => format!("({k},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The joint angles of `q_deg` (degrees), checked to be `(n, N)` or `(N,)` for an N-joint
/// robot: the flat values and whether it was one pose. Rows that cannot fit in memory
/// (forward kinematics' cost: the joints in degrees and radians and the points, twice) are
/// refused before anything is copied (`MemoryError`): a broadcast array costs numpy nothing
/// but would cost its full size here.
pub(crate) fn joints_arg(q_deg: &ArrayArg<'_>, n: usize, name: &str) -> PyResult<(Vec<f64>, bool)> {
    let shape = q_deg.shape().to_vec();
    let single = match shape[..] {
        [k] if k == n => true,
        [_, k] if k == n => false,
        _ => {
            return Err(refuse(format!(
                "{name}: expected shape (n, {n}) or ({n},) (joint angles in degrees of this \
                 {n}-joint robot), got {}",
                shape_text(&shape)
            )));
        }
    };
    let rows = if single { 1 } else { shape[0] };
    let fk_bytes = 8 * (2 * n as u64 + 2 * 3);
    measurements::check_rows("rows", rows, fk_bytes).map_err(|e| size_error(name, &e))?;
    Ok((q_deg.as_array().iter().copied().collect(), single))
}

/// `(n, N)` joints (`(N,)` is one row) as rows of N values, for a measurement set: refused
/// before anything is copied where the rows, at `measurements::BYTES_PER_ROW` each (a
/// row's cost from reading to identifying, docs/scale.md), cannot fit in memory.
pub(crate) fn joint_rows(q_deg: &ArrayArg<'_>, n: usize, name: &str) -> PyResult<Vec<Vec<f64>>> {
    let rows = match q_deg.shape() {
        [_] => 1,
        [k, ..] => *k,
        [] => 0,
    };
    measurements::check_rows("rows", rows, measurements::BYTES_PER_ROW)
        .map_err(|e| size_error(name, &e))?;
    let (flat, _) = joints_arg(q_deg, n, name)?;
    Ok(flat.chunks_exact(n).map(<[f64]>::to_vec).collect())
}

/// `(n, 3)` points as rows, `n` rows expected (`what` names the joints they go with).
pub(crate) fn point_rows(
    points: &ArrayArg<'_>,
    rows: usize,
    name: &str,
    what: &str,
) -> PyResult<Vec<[f64; 3]>> {
    fixed_rows(points, rows, name, "point in mm", what)
}

/// `(n, K)` values as rows of K, `n` rows expected; the error says what each row is (`each`)
/// and names the joints they go with (`what`).
pub(crate) fn fixed_rows<const K: usize>(
    a: &ArrayArg<'_>,
    rows: usize,
    name: &str,
    each: &str,
    what: &str,
) -> PyResult<Vec<[f64; K]>> {
    let shape = a.shape().to_vec();
    if shape[..] != [rows, K] {
        return Err(refuse(format!(
            "{name}: expected shape ({rows}, {K}) (one {each} per row of {what}), got {}",
            shape_text(&shape)
        )));
    }
    let flat: Vec<f64> = a.as_array().iter().copied().collect();
    Ok(flat
        .chunks_exact(K)
        .map(|r| std::array::from_fn(|k| r[k]))
        .collect())
}

/// `n` strings (target names or pose ids), or an error naming `name`.
pub(crate) fn string_rows(v: &Bound<'_, PyAny>, rows: usize, name: &str) -> PyResult<Vec<String>> {
    let v: Vec<String> = v
        .extract()
        .map_err(|_| refuse(format!("{name}: expected a sequence of {rows} strings")))?;
    if v.len() != rows {
        return Err(refuse(format!(
            "{name}: expected {rows} strings (one per row), got {}",
            v.len()
        )));
    }
    Ok(v)
}

/// A measurement set of joint rows (and points) built in memory, named `source`.
pub(crate) fn memory_set(
    source: &str,
    n: usize,
    q: Vec<Vec<f64>>,
    points: Option<Vec<[f64; 3]>>,
) -> measurements::MeasurementSet {
    let rows = match points {
        Some(p) => q
            .into_iter()
            .zip(p)
            .map(|(q, p)| measurements::Measurement::new(q, Some(p)))
            .collect(),
        None => q
            .into_iter()
            .map(|q| measurements::Measurement::new(q, None))
            .collect(),
    };
    measurements::MeasurementSet::new(source, n, rows)
}

/// Forward kinematics of `robot` on `q_deg` as a numpy array (see `Robot.fk`).
pub(crate) fn fk_array<'py>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    q_deg: &ArrayArg<'py>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    pose_array::<3>(py, robot, q_deg, |q_rad| {
        robot
            .points(q_rad)
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .collect()
    })
}

/// The learned residual model of a calibration on `q_deg` (`(n, N)` or `(N,)`, degrees, as
/// given: the model reads degrees, so they are not converted): with `points`, the calibrated
/// robot's points plus the model's mean (mm), as `kincal predict` computes them; otherwise
/// the model's predictive standard deviation per axis (mm), as `--with-sd` writes it.
pub(crate) fn residual_array<'py>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    model: &calibrate::residual::ResidualModel,
    q_deg: &ArrayArg<'py>,
    points: bool,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let n = robot.n_joints();
    let (flat_deg, single) = joints_arg(q_deg, n, "q_deg")?;
    if flat_deg.iter().any(|v| !v.is_finite()) {
        return Err(refuse("q_deg: joint angles must be finite"));
    }
    let joints: Vec<Vec<f64>> = flat_deg.chunks_exact(n).map(<[f64]>::to_vec).collect();
    let predictions = py
        .detach(|| model.predict(&joints))
        .map_err(|e| refuse(format!("q_deg: {e}")))?;
    let mut flat = Vec::with_capacity(3 * joints.len());
    let mut q_rad = vec![0.0; n];
    for (q, c) in joints.iter().zip(&predictions) {
        if points {
            for (r, d) in q_rad.iter_mut().zip(q) {
                *r = d.to_radians();
            }
            let p = robot.point(&q_rad);
            let m = c.mean_mm;
            flat.extend([p.x + m[0], p.y + m[1], p.z + m[2]]);
        } else {
            flat.extend(c.sd_mm);
        }
    }
    let out = if single {
        Array1::from(flat).into_dyn()
    } else {
        Array2::from_shape_vec((flat.len() / 3, 3), flat)
            .expect("3 values per pose")
            .into_dyn()
    };
    Ok(out.into_pyarray(py))
}

/// [`orientation_array`] with a residual model's orientation part applied
/// ([`calibrate::orientation_wxyz_with`]: `exp(r_o)·R`, as `kincal predict`); the plain
/// orientations when the model has no orientation part; `None` without a tool orientation.
pub(crate) fn residual_orientation_array<'py>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    model: &calibrate::residual::ResidualModel,
    q_deg: &ArrayArg<'py>,
) -> PyResult<Option<Bound<'py, PyArrayDyn<f64>>>> {
    if robot.tool_rotation_rad().is_none() {
        return Ok(None);
    }
    let n = robot.n_joints();
    let (flat_deg, _) = joints_arg(q_deg, n, "q_deg")?;
    if flat_deg.iter().any(|v| !v.is_finite()) {
        return Err(refuse("q_deg: joint angles must be finite"));
    }
    let joints: Vec<Vec<f64>> = flat_deg.chunks_exact(n).map(<[f64]>::to_vec).collect();
    let rotations = py
        .detach(|| model.predict_orientation(&joints))
        .map_err(|e| refuse(format!("q_deg: {e}")))?;
    pose_array::<4>(py, robot, q_deg, |q_rad| {
        q_rad
            .chunks_exact(n)
            .enumerate()
            .flat_map(|(k, q)| {
                let r = rotations.as_ref().map(|r| r[k].mean_deg);
                calibrate::orientation_wxyz_with(robot, q, r).expect("a tool orientation")
            })
            .collect()
    })
    .map(Some)
}

/// The measured frame's orientation of `robot` on `q_deg` as a numpy array of unit
/// quaternions `w, x, y, z` (see `Robot.fk_orientation`); `None` for a robot without a tool
/// orientation.
pub(crate) fn orientation_array<'py>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    q_deg: &ArrayArg<'py>,
) -> PyResult<Option<Bound<'py, PyArrayDyn<f64>>>> {
    if robot.tool_rotation_rad().is_none() {
        return Ok(None);
    }
    let n = robot.n_joints();
    pose_array::<4>(py, robot, q_deg, |q_rad| {
        q_rad
            .chunks_exact(n)
            .flat_map(|q| calibrate::orientation_wxyz(robot, q).expect("a tool orientation"))
            .collect()
    })
    .map(Some)
}

/// `value` of the flat joint vectors (radians) of `q_deg`, `(n, N)` → `(n, K)` or `(N,)` →
/// `(K,)`, computed without the GIL; non-finite angles refused, naming the first.
fn pose_array<'py, const K: usize>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    q_deg: &ArrayArg<'py>,
    value: impl Fn(&[f64]) -> Vec<f64> + Sync,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let n = robot.n_joints();
    let (flat_deg, single) = joints_arg(q_deg, n, "q_deg")?;
    if let Some(k) = flat_deg.iter().position(|v| !v.is_finite()) {
        let at = if single {
            format!("{k}")
        } else {
            format!("{}, {}", k / n, k % n)
        };
        return Err(refuse(format!(
            "q_deg[{at}] is {}: joint angles must be finite",
            flat_deg[k]
        )));
    }
    let q_rad: Vec<f64> = flat_deg.iter().map(|d| d.to_radians()).collect();
    let flat: Vec<f64> = py.detach(|| value(&q_rad));
    let out = if single {
        Array1::from(flat).into_dyn()
    } else {
        Array2::from_shape_vec((flat.len() / K, K), flat)
            .expect("K values per pose")
            .into_dyn()
    };
    Ok(out.into_pyarray(py))
}

/// `(n, k)` rows as a 2-D array.
pub(crate) fn rows_array<'py, const K: usize>(
    py: Python<'py>,
    rows: &[[f64; K]],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), K), flat)
        .expect("K values per row")
        .into_pyarray(py)
}

/// Variable-length rows of equal length `k` as a 2-D array.
pub(crate) fn vec_rows_array<'py>(
    py: Python<'py>,
    rows: &[Vec<f64>],
    k: usize,
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), k), flat)
        .expect("k values per row")
        .into_pyarray(py)
}

/// A matrix of `shape` (rows, columns) with entries `at(i, j)` as a 2-D array.
pub(crate) fn matrix_array(
    py: Python<'_>,
    shape: (usize, usize),
    at: impl Fn(usize, usize) -> f64,
) -> Bound<'_, PyArray2<f64>> {
    Array2::from_shape_fn(shape, |(i, j)| at(i, j)).into_pyarray(py)
}

/// Indices as a 1-D int64 array.
pub(crate) fn index_array(py: Python<'_>, indices: Vec<usize>) -> Bound<'_, PyArray1<i64>> {
    Array1::from(indices.into_iter().map(|i| i as i64).collect::<Vec<_>>()).into_pyarray(py)
}
