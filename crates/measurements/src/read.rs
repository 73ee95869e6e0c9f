//! The reader (a small hand parser: fields never contain quotes or commas in this format,
//! and a hand parser keeps physical line numbers exact).

use std::path::Path;

use crate::{Measurement, MeasurementError, MeasurementSet, ReadOptions};

/// Longest offending field text quoted in an error message.
const MAX_QUOTED_CHARS: usize = 60;

/// Read a measurement file (`docs/model.md` §5). The file's path, as given, becomes
/// [`MeasurementSet::source`] and the file name in error messages.
pub fn read_file(path: &Path, opts: &ReadOptions) -> Result<MeasurementSet, MeasurementError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| MeasurementError::Io {
        file: source.clone(),
        source: e,
    })?;
    let text = std::str::from_utf8(&bytes).map_err(|e| MeasurementError::NotUtf8 {
        file: source.clone(),
        line: 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count(),
    })?;
    read_str(text, &source, opts)
}

/// Read measurement-file text (`docs/model.md` §5). `source` names the text in errors and becomes
/// [`MeasurementSet::source`].
pub fn read_str(
    text: &str,
    source: &str,
    opts: &ReadOptions,
) -> Result<MeasurementSet, MeasurementError> {
    check_options(source, opts)?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);

    // Physical lines, 1-based, without the line terminator; comments and blank lines dropped.
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .filter(|(_, l)| {
            let t = l.trim_start();
            !t.is_empty() && !t.starts_with('#')
        });

    let Some((header_line, header_text)) = lines.next() else {
        return Err(MeasurementError::NoHeader {
            file: source.to_owned(),
        });
    };
    let mut notices = Vec::new();
    let header = parse_header(source, header_line, header_text, opts, &mut notices)?;

    let mut rows = Vec::new();
    for (line, text) in lines {
        rows.push(parse_row(source, line, text, &header, opts)?);
    }

    if rows.len() < opts.min_rows {
        return Err(MeasurementError::TooFewRows {
            file: source.to_owned(),
            found: rows.len(),
            needed: opts.min_rows,
        });
    }

    Ok(MeasurementSet {
        source: source.to_owned(),
        n_joints: opts.n_joints,
        rows,
        notices,
    })
}

fn check_options(source: &str, opts: &ReadOptions) -> Result<(), MeasurementError> {
    let invalid = |reason: String| MeasurementError::InvalidOptions {
        file: source.to_owned(),
        reason,
    };
    if opts.n_joints == 0 {
        return Err(invalid("n_joints is 0".to_owned()));
    }
    if let Some(limits) = &opts.limits_deg {
        if limits.len() != opts.n_joints {
            return Err(invalid(format!(
                "{} joint limits given for {} joints",
                limits.len(),
                opts.n_joints
            )));
        }
        for (i, &[min, max]) in limits.iter().enumerate() {
            if min.is_nan() || max.is_nan() || min > max {
                return Err(invalid(format!(
                    "limits of q{} are [{min}, {max}] deg",
                    i + 1
                )));
            }
        }
    }
    Ok(())
}

/// What a header field means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Joint q_{i+1} (0-based index).
    Joint(usize),
    /// Point coordinate 0 = x, 1 = y, 2 = z.
    Point(usize),
    Id,
    Ignored,
}

struct Header {
    /// Trimmed column names, in file order.
    names: Vec<String>,
    roles: Vec<Role>,
    has_points: bool,
}

/// `Some(Ok(index))` for `q<digits>` (index parsed, may be 0 or out of range, `Err` if it
/// overflows); `None` if the name does not look like a joint column.
fn joint_like(name: &str) -> Option<Result<usize, ()>> {
    let digits = name.strip_prefix('q')?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(digits.parse::<usize>().map_err(|_| ()))
}

fn parse_header(
    source: &str,
    line: usize,
    text: &str,
    opts: &ReadOptions,
    notices: &mut Vec<String>,
) -> Result<Header, MeasurementError> {
    let n = opts.n_joints;
    let names: Vec<String> = text.split(',').map(|f| f.trim().to_owned()).collect();
    let mut roles = Vec::with_capacity(names.len());
    // 1-based header field where each known column was first seen.
    let mut seen: Vec<(&str, usize)> = Vec::new();
    // Joint-like columns: (index or usize::MAX on overflow, name).
    let mut joint_like_cols: Vec<(usize, &str)> = Vec::new();
    let mut offending_joint: Option<&str> = None;

    for (k, name) in names.iter().enumerate() {
        let name = name.as_str();
        let role = match name {
            "id" => Role::Id,
            "x" => Role::Point(0),
            "y" => Role::Point(1),
            "z" => Role::Point(2),
            _ => match joint_like(name) {
                Some(parsed) => {
                    let idx = parsed.unwrap_or(usize::MAX);
                    joint_like_cols.push((idx, name));
                    let canonical = parsed.is_ok() && name == format!("q{idx}");
                    if canonical && (1..=n).contains(&idx) {
                        Role::Joint(idx - 1)
                    } else {
                        offending_joint.get_or_insert(name);
                        Role::Ignored
                    }
                }
                None => {
                    notices.push(unknown_column_notice(source, line, k + 1, name));
                    Role::Ignored
                }
            },
        };
        if role != Role::Ignored || joint_like(name).is_some() {
            if let Some(&(_, first)) = seen.iter().find(|(s, _)| *s == name) {
                return Err(MeasurementError::DuplicateColumn {
                    file: source.to_owned(),
                    line,
                    column: name.to_owned(),
                    first_field: first,
                    second_field: k + 1,
                });
            }
            seen.push((name, k + 1));
        }
        roles.push(role);
    }

    joint_like_cols.sort();
    let found: Vec<String> = joint_like_cols.iter().map(|(_, s)| s.to_string()).collect();
    let mismatch = |column: String| MeasurementError::JointCountMismatch {
        file: source.to_owned(),
        line,
        column,
        expected: n,
        found: found.clone(),
    };
    if let Some(col) = offending_joint {
        return Err(mismatch(col.to_owned()));
    }
    let present: Vec<bool> = (0..n).map(|j| roles.contains(&Role::Joint(j))).collect();
    if let Some(first_missing) = present.iter().position(|p| !p) {
        let q = format!("q{}", first_missing + 1);
        // Exactly q1..qk with k < n present: the file is for a k-joint robot.
        return Err(
            if first_missing > 0 && present[first_missing..].iter().all(|p| !p) {
                mismatch(q)
            } else {
                MeasurementError::MissingColumn {
                    file: source.to_owned(),
                    line,
                    column: q,
                }
            },
        );
    }

    let point_present: Vec<bool> = (0..3).map(|c| roles.contains(&Role::Point(c))).collect();
    let any_point = point_present.iter().any(|&p| p);
    if (opts.require_points || any_point)
        && let Some(c) = point_present.iter().position(|p| !p)
    {
        return Err(MeasurementError::MissingColumn {
            file: source.to_owned(),
            line,
            column: ["x", "y", "z"][c].to_owned(),
        });
    }

    Ok(Header {
        names,
        roles,
        has_points: any_point,
    })
}

fn unknown_column_notice(source: &str, line: usize, field: usize, name: &str) -> String {
    if name.is_empty() {
        return format!("{source}:{line}: ignored unnamed column (header field {field})");
    }
    let lower = name.to_lowercase();
    let known = lower == "id"
        || lower == "x"
        || lower == "y"
        || lower == "z"
        || joint_like(&lower).is_some();
    let hint = if known {
        " (column names are case-sensitive, lower-case)"
    } else {
        ""
    };
    format!("{source}:{line}: ignored unknown column \"{name}\"{hint}")
}

fn parse_row(
    source: &str,
    line: usize,
    text: &str,
    header: &Header,
    opts: &ReadOptions,
) -> Result<Measurement, MeasurementError> {
    let fields: Vec<&str> = text.split(',').map(str::trim).collect();
    if fields.len() != header.names.len() {
        return Err(MeasurementError::RaggedRow {
            file: source.to_owned(),
            line,
            expected: header.names.len(),
            found: fields.len(),
            first_missing_column: header.names.get(fields.len()).cloned(),
        });
    }

    let mut q_deg = vec![0.0; opts.n_joints];
    let mut point = [0.0; 3];
    let mut id = None;
    for ((field, role), name) in fields.iter().zip(&header.roles).zip(&header.names) {
        match *role {
            Role::Joint(j) => {
                let v = parse_number(source, line, name, field)?;
                if let Some(limits) = &opts.limits_deg {
                    let [min, max] = limits[j];
                    if !(min..=max).contains(&v) {
                        return Err(MeasurementError::JointOutOfLimits {
                            file: source.to_owned(),
                            line,
                            column: name.clone(),
                            value_deg: v,
                            min_deg: min,
                            max_deg: max,
                        });
                    }
                }
                q_deg[j] = v;
            }
            Role::Point(c) => point[c] = parse_number(source, line, name, field)?,
            Role::Id => id = (!field.is_empty()).then(|| (*field).to_owned()),
            Role::Ignored => {}
        }
    }
    Ok(Measurement {
        line,
        id,
        q_deg,
        point_mm: header.has_points.then_some(point),
    })
}

fn parse_number(
    source: &str,
    line: usize,
    column: &str,
    text: &str,
) -> Result<f64, MeasurementError> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(MeasurementError::NonFinite {
            file: source.to_owned(),
            line,
            column: column.to_owned(),
            text: shorten(text),
        }),
        Err(_) => Err(MeasurementError::NotANumber {
            file: source.to_owned(),
            line,
            column: column.to_owned(),
            text: shorten(text),
        }),
    }
}

fn shorten(text: &str) -> String {
    if text.chars().count() <= MAX_QUOTED_CHARS {
        text.to_owned()
    } else {
        let head: String = text.chars().take(MAX_QUOTED_CHARS).collect();
        format!("{head}...")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_like_names() {
        assert_eq!(joint_like("q1"), Some(Ok(1)));
        assert_eq!(joint_like("q07"), Some(Ok(7)));
        assert_eq!(joint_like("q0"), Some(Ok(0)));
        assert_eq!(joint_like("q99999999999999999999999"), Some(Err(())));
        assert_eq!(joint_like("q"), None);
        assert_eq!(joint_like("q1a"), None);
        assert_eq!(joint_like("Q1"), None);
        assert_eq!(joint_like("qx"), None);
    }

    #[test]
    fn shorten_long_text() {
        let long = "a".repeat(100);
        let s = shorten(&long);
        assert_eq!(s.len(), MAX_QUOTED_CHARS + 3);
        assert!(s.ends_with("..."));
        assert_eq!(shorten("abc"), "abc");
    }
}
