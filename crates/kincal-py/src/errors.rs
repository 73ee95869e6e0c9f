//! The exceptions of the package and the one conversion of library errors into them.
//!
//! Every library error becomes a `KincalError` (a `ValueError`) whose message is the
//! error's text followed by the causes it does not already include; a refusal by a
//! plausibility check (`calibrate::Check`) becomes its subclass `Refused`, whose `check`
//! attribute is the check's name, the value of `allow=` that overrides it.

use std::error::Error;
use std::path::Path;

use pyo3::create_exception;
use pyo3::prelude::*;

create_exception!(
    kincal,
    KincalError,
    pyo3::exceptions::PyValueError,
    "An error of kincal: a malformed or unreadable file, an invalid value or an array of the \
     wrong shape. A subclass of ValueError; its message is the library's (file, line, field)."
);

create_exception!(
    kincal,
    Refused,
    KincalError,
    "A refusal by a plausibility check (the data or the result look wrong: radians read as \
     degrees, metres as millimetres, a mirrored frame, outliers, far parameters, worse \
     validation, a URDF of the wrong size). Its attribute `check` names the check, which is \
     also the value of `allow=` that overrides it: `except kincal.Refused as e:` then retry \
     with `allow=e.check`."
);

/// Registers the exceptions.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("KincalError", m.py().get_type::<KincalError>())?;
    m.add("Refused", m.py().get_type::<Refused>())?;
    Ok(())
}

/// A library error as a `KincalError` (a `Refused` when a plausibility check refused),
/// whose message is the error's own text followed by the causes that the text does not
/// already include.
pub(crate) fn kincal_error(e: &(dyn Error + 'static)) -> PyErr {
    in_context(None, e)
}

/// [`kincal_error`] with `context` (what was being done) before the message.
pub(crate) fn kincal_error_in(context: &str, e: &(dyn Error + 'static)) -> PyErr {
    in_context(Some(context), e)
}

fn in_context(context: Option<&str>, e: &(dyn Error + 'static)) -> PyErr {
    let mut msg = e.to_string();
    let mut check = refused_check(e);
    let mut source = e.source();
    while let Some(s) = source {
        let text = s.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        check = check.or_else(|| refused_check(s));
        source = s.source();
    }
    if let Some(c) = context {
        msg = format!("{c}: {msg}");
    }
    match check {
        None => KincalError::new_err(msg),
        Some(check) => refused(msg, check),
    }
}

/// The check that refused, if `e` is a plausibility refusal: calibrate's checks, and the
/// URDF import's reach check (`allow="length-units"`, as `kincal urdf import --allow`).
fn refused_check(e: &(dyn Error + 'static)) -> Option<calibrate::Check> {
    if let Some(c) = e.downcast_ref::<calibrate::CalibrateError>() {
        return c.refused_check();
    }
    match e.downcast_ref::<urdf::UrdfError>() {
        Some(urdf::UrdfError::ImplausibleSize { .. }) => Some(calibrate::Check::LengthUnits),
        _ => None,
    }
}

/// A `Refused` with the message `msg` and `check` as its attribute (set on the instance, so
/// the interpreter is attached for that; it may be called from a detached closure).
fn refused(msg: String, check: calibrate::Check) -> PyErr {
    Python::attach(|py| {
        let err = Refused::new_err(msg);
        match err.value(py).setattr("check", check.name()) {
            Ok(()) => err,
            Err(e) => e,
        }
    })
}

/// A `KincalError` with the message `msg` (a front-end refusal: a shape, an option).
pub(crate) fn refuse(msg: impl Into<String>) -> PyErr {
    KincalError::new_err(msg.into())
}

/// A size of argument `name` refused before allocation (`measurements::SizeError`):
/// `MemoryError` when it does not fit in this machine's available memory, `KincalError`
/// above a stated limit; the message is `{name}: {the library's text}`.
pub(crate) fn size_error(name: &str, e: &measurements::SizeError) -> PyErr {
    let msg = format!("{name}: {e}");
    match e {
        measurements::SizeError::OutOfMemory { .. } => {
            pyo3::exceptions::PyMemoryError::new_err(msg)
        }
        _ => KincalError::new_err(msg),
    }
}

/// Writes a calibration's rendered files into `directory` as `kincal identify --out` does
/// (`measurements::OutputDir`): under the directory's advisory lock (another run writing
/// there is refused, named), the set replacing the previous one as a whole, the user's own
/// files kept; a path that is not a directory is refused.
pub(crate) fn save_outputs(
    directory: &Path,
    files: Result<Vec<(String, String)>, report::PlotError>,
) -> PyResult<()> {
    let files = files.map_err(|e| kincal_error(&e))?;
    let dir = directory.display().to_string();
    let context = |e: measurements::OutputError| naming(&dir, "writing the outputs into", e);
    measurements::OutputDir::lock(directory)
        .map_err(context)?
        .write_set(&files)
        .map_err(context)
}

/// Writes a file the way every kincal front end does (atomically: temporary file, rename).
pub(crate) fn write_file(path: &Path, text: &str) -> PyResult<()> {
    measurements::write_atomically(path, text.as_bytes())
        .map_err(|e| naming(&path.display().to_string(), "writing", e))
}

/// An I/O error as a `KincalError` that names `file`: its message if it does, else
/// `{doing} {file}: {message}`.
fn naming(file: &str, doing: &str, e: impl std::fmt::Display) -> PyErr {
    let msg = e.to_string();
    refuse(if msg.contains(file) {
        msg
    } else {
        format!("{doing} {file}: {msg}")
    })
}
