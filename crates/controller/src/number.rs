//! The fixed number formatting of every format (crate docs, "Number formatting") and the
//! shared pieces of the readers.

use crate::ControllerError;

/// Decimals of millimetres.
pub const MM: usize = 3;
/// Decimals of degrees (axis values, A, B, C).
pub const DEG: usize = 4;
/// Decimals of quaternion components.
pub const QUAT: usize = 9;
/// Decimals of metres (URScript).
pub const M: usize = 6;
/// Decimals of radians (URScript).
pub const RAD: usize = 7;

/// `v` with `decimals` fixed decimals; a value that rounds to zero has no sign.
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_owned()
    } else {
        s
    }
}

/// `values` with `decimals` each, joined by `sep`.
pub fn join(values: &[f64], decimals: usize, sep: &str) -> String {
    values
        .iter()
        .map(|v| fixed(*v, decimals))
        .collect::<Vec<_>>()
        .join(sep)
}

/// Where a reader is: the text's label and the line, for errors.
#[derive(Clone, Copy)]
pub struct At<'a> {
    /// The text's label.
    pub source_name: &'a str,
    /// 1-based line.
    pub line: usize,
}

impl At<'_> {
    /// A parse error here.
    pub fn err(&self, message: impl Into<String>) -> ControllerError {
        ControllerError::Parse {
            source_name: self.source_name.to_owned(),
            line: self.line,
            message: message.into(),
        }
    }

    /// `text` (trimmed) as a finite number, or an error naming `field`.
    pub fn number(&self, field: &str, text: &str) -> Result<f64, ControllerError> {
        match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(format!("{field}: {:?} is not a finite number", text.trim()))),
        }
    }

    /// `text` as exactly `N` comma-separated numbers named `field[k]`.
    pub fn numbers<const N: usize>(
        &self,
        field: &str,
        text: &str,
    ) -> Result<[f64; N], ControllerError> {
        let parts: Vec<&str> = text.split(',').collect();
        if parts.len() != N {
            return Err(self.err(format!(
                "{field}: {} values where {N} are expected",
                parts.len()
            )));
        }
        let mut out = [0.0; N];
        for (k, p) in parts.iter().enumerate() {
            out[k] = self.number(&format!("{field}[{k}]"), p)?;
        }
        Ok(out)
    }
}

/// The name of a `target <name>` comment body (after the comment marker), if it is one.
pub fn target_comment(body: &str) -> Option<&str> {
    body.trim().strip_prefix("target ").map(str::trim)
}

/// A target being collected by a reader: a `target` comment opens one, and the first
/// declaration after a full one (or without a comment) opens the next.
#[derive(Default)]
pub struct Collect {
    /// Targets closed so far.
    pub done: Vec<crate::ReadTarget>,
    /// The open one, and whether its name came from a comment.
    pub open: Option<(crate::ReadTarget, bool)>,
}

impl Collect {
    /// A `target <name>` comment: closes the open target, opens a named one.
    pub fn named(&mut self, name: &str) {
        self.close();
        self.open = Some((
            crate::ReadTarget {
                name: name.to_owned(),
                ..Default::default()
            },
            true,
        ));
    }

    /// The open target for a declaration of variable `var` that fills the slot `taken`
    /// says is full or not: a new one (named `var`) when none is open or the slot is taken.
    pub fn target_for(
        &mut self,
        var: &str,
        taken: impl Fn(&crate::ReadTarget) -> bool,
    ) -> &mut crate::ReadTarget {
        if self.open.as_ref().is_none_or(|(t, _)| taken(t)) {
            self.close();
            self.open = Some((
                crate::ReadTarget {
                    name: var.to_owned(),
                    ..Default::default()
                },
                false,
            ));
        }
        &mut self.open.as_mut().expect("opened above").0
    }

    /// Closes the open target (one without declarations is dropped).
    pub fn close(&mut self) {
        if let Some((t, _)) = self.open.take()
            && (t.axes_deg.is_some() || t.position_mm.is_some())
        {
            self.done.push(t);
        }
    }

    /// Every target read.
    pub fn finish(mut self) -> Vec<crate::ReadTarget> {
        self.close();
        self.done
    }
}
