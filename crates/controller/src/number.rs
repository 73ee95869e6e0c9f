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

/// The first line of a program and the header lines as comments (`comment` then a space).
pub fn opening(first: &str, comment: &str, header: &[String]) -> String {
    let mut out = format!("{first}\n");
    for h in header {
        out += &format!("{comment} {h}\n");
    }
    out
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
        self.values(field, &text.split(',').collect::<Vec<_>>())
    }

    /// `parts` as exactly `N` numbers named `field[k]`.
    pub fn values<const N: usize>(
        &self,
        field: &str,
        parts: &[&str],
    ) -> Result<[f64; N], ControllerError> {
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

/// The targets of `text`, read line by line: a comment (a line starting with `marker`)
/// `target <name>` opens a named target, any other line goes to `declaration` with where
/// it is and the target collection.
pub fn read_lines(
    text: &str,
    source_name: &str,
    marker: char,
    mut declaration: impl FnMut(At<'_>, &str, &mut Collect) -> Result<(), ControllerError>,
) -> Result<Vec<crate::ReadTarget>, ControllerError> {
    let mut c = Collect::default();
    for (i, raw) in text.lines().enumerate() {
        let at = At {
            source_name,
            line: i + 1,
        };
        let line = raw.trim();
        match line.strip_prefix(marker) {
            Some(comment) => {
                if let Some(name) = target_comment(comment) {
                    c.named(name);
                }
            }
            None => declaration(at, line, &mut c)?,
        }
    }
    Ok(c.finish())
}

/// The name of a `target <name>` comment body (after the comment marker), if it is one.
fn target_comment(body: &str) -> Option<&str> {
    body.trim().strip_prefix("target ").map(str::trim)
}

/// A target being collected by a reader: a `target` comment opens one, and the first
/// declaration after a full one (or without a comment) opens the next.
#[derive(Default)]
pub struct Collect {
    /// Targets closed so far.
    done: Vec<crate::ReadTarget>,
    /// The open one.
    open: Option<crate::ReadTarget>,
}

impl Collect {
    /// A `target <name>` comment: closes the open target, opens a named one.
    pub fn named(&mut self, name: &str) {
        self.open_new(name);
    }

    /// Closes the open target and opens one named `name`.
    fn open_new(&mut self, name: &str) {
        self.close();
        self.open = Some(crate::ReadTarget {
            name: name.to_owned(),
            ..Default::default()
        });
    }

    /// The open target for a declaration of variable `var` that fills the slot `taken`
    /// says is full or not: a new one (named `var`) when none is open or the slot is taken.
    pub fn target_for(
        &mut self,
        var: &str,
        taken: impl Fn(&crate::ReadTarget) -> bool,
    ) -> &mut crate::ReadTarget {
        if self.open.as_ref().is_none_or(&taken) {
            self.open_new(var);
        }
        self.open.as_mut().expect("opened above")
    }

    /// Closes the open target (one without declarations is dropped).
    fn close(&mut self) {
        if let Some(t) = self.open.take()
            && (t.axes_deg.is_some() || t.position_mm.is_some())
        {
            self.done.push(t);
        }
    }

    /// Every target read.
    fn finish(mut self) -> Vec<crate::ReadTarget> {
        self.close();
        self.done
    }
}
