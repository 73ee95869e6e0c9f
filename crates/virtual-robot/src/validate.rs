//! Small checks shared by the sections' `validate` methods.

use crate::error::ConfigError;

pub(crate) fn finite(field: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::invalid(
            field,
            format!("{v:?} is not a finite number"),
        ))
    }
}

pub(crate) fn non_negative(field: &str, v: f64) -> Result<(), ConfigError> {
    finite(field, v)?;
    if v < 0.0 {
        Err(ConfigError::invalid(
            field,
            format!("must not be negative, got {v:?}"),
        ))
    } else {
        Ok(())
    }
}

pub(crate) fn positive(field: &str, v: f64) -> Result<(), ConfigError> {
    finite(field, v)?;
    if v <= 0.0 {
        Err(ConfigError::invalid(
            field,
            format!("must be positive, got {v:?}"),
        ))
    } else {
        Ok(())
    }
}

pub(crate) fn all_finite(field: &str, v: &[f64]) -> Result<(), ConfigError> {
    for (k, x) in v.iter().enumerate() {
        finite(&format!("{field}[{k}]"), *x)?;
    }
    Ok(())
}
