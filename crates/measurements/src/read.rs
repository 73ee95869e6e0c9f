//! The reader (a small hand parser: fields never contain quotes or commas in this format,
//! and a hand parser keeps physical line numbers exact).

use std::path::Path;

use crate::error::short;
use crate::{
    Measurement, MeasurementError, MeasurementSet, QUATERNION_NORM_TOLERANCE, ReadOptions,
};

/// Longest offending field text quoted in an error message.
const MAX_QUOTED_CHARS: usize = 60;

/// Read a measurement file (`docs/model.md` §5). The file's path, as given, becomes
/// [`MeasurementSet::source`] and the file name in error messages.
pub fn read_file(path: &Path, opts: &ReadOptions) -> Result<MeasurementSet, MeasurementError> {
    read_str(&read_text(path)?, &path.display().to_string(), opts)
}

/// The text of a measurement file, read once, whole: a pipe or a FIFO (`--data <(cat f)`)
/// reads as a file does, and a caller that looks at the text before parsing it
/// ([`read_str`]) does not read the file twice (a pipe would be empty the second time).
///
/// # Errors
/// [`MeasurementError::Io`] and [`MeasurementError::NotUtf8`], naming the file by `path` as
/// given.
pub fn read_text(path: &Path) -> Result<String, MeasurementError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| MeasurementError::Io {
        file: source.clone(),
        source: e,
    })?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        MeasurementError::NotUtf8 {
            file: source,
            line: 1 + e.as_bytes()[..valid]
                .iter()
                .filter(|&&b| b == b'\n')
                .count(),
        }
    })
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
    let mut lines = lines.peekable();
    let header = parse_header(source, header_line, header_text, opts, &mut notices)
        .map_err(|e| with_decimal_comma(e, lines.peek().copied()))?;

    let mut rows = Vec::new();
    for (line, text) in lines {
        rows.push(parse_row(source, line, text, &header, opts)?);
    }
    if header.has_target {
        check_poses(&rows).map_err(|p| p.into_error(source, &rows))?;
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
    // No joint columns: a file of poses (Cartesian targets), whose points are required.
    if opts.n_joints == 0 && !opts.require_points {
        return Err(invalid(
            "n_joints is 0 and the points are not required (a file of nothing)".to_owned(),
        ));
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
    Target,
    /// Quaternion component 0 = qw, 1 = qx, 2 = qy, 3 = qz.
    Quat(usize),
    /// Euler angle 0 = rx, 1 = ry, 2 = rz.
    Euler(usize),
    /// Point standard deviation 0 = sx, 1 = sy, 2 = sz.
    SigmaMm(usize),
    /// Orientation standard deviation 0 = srx, 1 = sry, 2 = srz.
    SigmaDeg(usize),
    Ignored,
}

/// An optional group of columns: the role constructor and the names, in order.
type Group = (fn(usize) -> Role, &'static [&'static str]);

/// The optional groups of columns: the role constructor and the names, in order.
const GROUPS: [Group; 5] = [
    (Role::Point, &["x", "y", "z"]),
    (Role::Quat, &["qw", "qx", "qy", "qz"]),
    (Role::Euler, &["rx", "ry", "rz"]),
    (Role::SigmaMm, &["sx", "sy", "sz"]),
    (Role::SigmaDeg, &["srx", "sry", "srz"]),
];

/// Names of every column the reader knows besides the joints.
const KNOWN: [&str; 18] = [
    "id", "target", "x", "y", "z", "qw", "qx", "qy", "qz", "rx", "ry", "rz", "sx", "sy", "sz",
    "srx", "sry", "srz",
];

struct Header {
    /// Trimmed column names, in file order.
    names: Vec<String>,
    roles: Vec<Role>,
    has_points: bool,
    has_target: bool,
    has_quat: bool,
    has_euler: bool,
    has_sigma_mm: bool,
    has_sigma_deg: bool,
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
        let group_role = GROUPS
            .iter()
            .find_map(|(role, names)| names.iter().position(|n| *n == name).map(role));
        let role = match (name, group_role) {
            (_, Some(role)) => role,
            ("id", _) => Role::Id,
            ("target", _) => Role::Target,
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
                missing_column(source, line, text, q)
            },
        );
    }

    // Each optional group: all of its columns or none.
    let mut present = [false; 5];
    for (g, (role, group)) in GROUPS.iter().enumerate() {
        let have: Vec<bool> = (0..group.len()).map(|c| roles.contains(&role(c))).collect();
        present[g] = have.iter().any(|&p| p);
        // The points are required unless the caller reads the joints-only form.
        let required = g == 0 && opts.require_points;
        if (required || present[g])
            && let Some(c) = have.iter().position(|p| !p)
        {
            return Err(missing_column(source, line, text, group[c].to_owned()));
        }
    }
    let [has_points, has_quat, has_euler, has_sigma_mm, has_sigma_deg] = present;
    let has_target = roles.contains(&Role::Target);
    let conflict = |column: &str, reason: &str| MeasurementError::ColumnConflict {
        file: source.to_owned(),
        line,
        column: column.to_owned(),
        reason: reason.to_owned(),
    };
    if has_quat && has_euler {
        return Err(conflict(
            "rx",
            "the orientation is given both as a quaternion (qw,qx,qy,qz) and as Euler angles \
             (rx,ry,rz); give one of the two",
        ));
    }
    if has_euler && opts.euler.is_none() && !opts.rotation_vector {
        return Err(MeasurementError::EulerConventionMissing {
            file: source.to_owned(),
            line,
            column: "rx".to_owned(),
        });
    }
    if has_sigma_mm && !has_points {
        return Err(conflict(
            "sx",
            "standard deviations sx,sy,sz are given without the point columns x,y,z",
        ));
    }
    if has_sigma_deg && !(has_quat || has_euler) {
        return Err(conflict(
            "srx",
            "standard deviations srx,sry,srz are given without orientation columns \
             (qw,qx,qy,qz or rx,ry,rz)",
        ));
    }
    if has_target && !roles.contains(&Role::Id) {
        return Err(conflict(
            "target",
            "a target column needs an id column: the rows with the same id are the targets \
             measured at one pose",
        ));
    }

    Ok(Header {
        names,
        roles,
        has_points,
        has_target,
        has_quat,
        has_euler,
        has_sigma_mm,
        has_sigma_deg,
    })
}

/// The error of a header without the required `column`: the separator seen when the header
/// is not comma-separated ([`MeasurementError::Separator`]), the name in another letter case
/// ([`MeasurementError::HeaderCase`]), else [`MeasurementError::MissingColumn`].
fn missing_column(source: &str, line: usize, text: &str, column: String) -> MeasurementError {
    let names = |sep: char| -> Vec<String> {
        if sep == ' ' {
            text.split_whitespace().map(str::to_lowercase).collect()
        } else {
            text.split(sep).map(|f| f.trim().to_lowercase()).collect()
        }
    };
    let separator = [';', '\t', '|', ' ']
        .into_iter()
        .find(|&sep| text.trim().contains(sep) && names(sep).contains(&column));
    if let Some(separator) = separator {
        let start = text.len() - text.trim_start().len();
        let at = text[start..].find(separator).map_or(0, |i| start + i);
        return MeasurementError::Separator {
            file: source.to_owned(),
            line,
            position: text[..at].chars().count() + 1,
            separator,
            decimal_comma: None,
        };
    }
    let mut offset = 0;
    for field in text.split(',') {
        let name = field.trim();
        if name.to_lowercase() == column {
            let lead = field.len() - field.trim_start().len();
            return MeasurementError::HeaderCase {
                file: source.to_owned(),
                line,
                position: text[..offset + lead].chars().count() + 1,
                found: name.to_owned(),
                expected: column,
            };
        }
        offset += field.len() + 1;
    }
    MeasurementError::MissingColumn {
        file: source.to_owned(),
        line,
        column,
    }
}

/// A header separated by `;` (or another non-comma), with the first data row (`row`: its
/// line and text) writing a number with a decimal comma: the error says so as well.
fn with_decimal_comma(e: MeasurementError, row: Option<(usize, &str)>) -> MeasurementError {
    match (e, row) {
        (
            MeasurementError::Separator {
                file,
                line,
                position,
                separator,
                decimal_comma: None,
            },
            Some((row_line, row_text)),
        ) => {
            let comma_number = |f: &str| {
                let f = f.trim();
                let digits = f.strip_prefix(['-', '+']).unwrap_or(f);
                digits.split_once(',').is_some_and(|(a, b)| {
                    !a.is_empty()
                        && !b.is_empty()
                        && a.bytes().all(|c| c.is_ascii_digit())
                        && b.bytes().all(|c| c.is_ascii_digit())
                })
            };
            let fields: Vec<&str> = if separator == ' ' {
                row_text.split_whitespace().collect()
            } else {
                row_text.split(separator).collect()
            };
            MeasurementError::Separator {
                file,
                line,
                position,
                separator,
                decimal_comma: fields
                    .into_iter()
                    .find(|f| comma_number(f))
                    .map(|f| (row_line, shorten(f.trim()))),
            }
        }
        (e, _) => e,
    }
}

/// A row of `found` fields where the header has `expected` (fewer) that writes decimal
/// commas: no `.` in the row, a comma between two digits, and two fields or more too many or
/// a field with a leading zero (`000210`, a fraction's digits) — one field too many of plain
/// integers is a ragged row. The comma's 1-based character column and the number it belongs
/// to (the digits on either side).
fn decimal_comma(text: &str, expected: usize, found: usize) -> Option<(usize, String)> {
    let leading_zero = text.split(',').skip(1).any(|f| {
        let f = f.trim().as_bytes();
        f.len() > 1 && f[0] == b'0' && f[1].is_ascii_digit()
    });
    if text.contains('.') || !(found >= expected + 2 || leading_zero) {
        return None;
    }
    let b = text.as_bytes();
    let at = (1..b.len().saturating_sub(1))
        .find(|&i| b[i] == b',' && b[i - 1].is_ascii_digit() && b[i + 1].is_ascii_digit())?;
    let start = text[..at].rfind(',').map_or(0, |i| i + 1);
    let end = text[at + 1..].find(',').map_or(text.len(), |i| at + 1 + i);
    Some((
        text[..at].chars().count() + 1,
        shorten(text[start..end].trim()),
    ))
}

fn unknown_column_notice(source: &str, line: usize, field: usize, name: &str) -> String {
    if name.is_empty() {
        return format!("{source}:{line}: ignored unnamed column (header field {field})");
    }
    let lower = name.to_lowercase();
    let known = KNOWN.contains(&lower.as_str()) || joint_like(&lower).is_some();
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
    if fields.len() > header.names.len()
        && let Some((position, number)) = decimal_comma(text, header.names.len(), fields.len())
    {
        return Err(MeasurementError::DecimalComma {
            file: source.to_owned(),
            line,
            position,
            text: number,
            expected: header.names.len(),
            found: fields.len(),
        });
    }
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
    let mut quat = [0.0; 4];
    let mut euler = [0.0; 3];
    let mut sigma_mm = [0.0; 3];
    let mut sigma_deg = [0.0; 3];
    let mut id = None;
    let mut target = None;
    let invalid = |column: &str, reason: String| MeasurementError::InvalidField {
        file: source.to_owned(),
        line,
        column: column.to_owned(),
        reason,
    };
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
                            value: v,
                            min,
                            max,
                            unit: "deg",
                        });
                    }
                }
                q_deg[j] = v;
            }
            Role::Point(c) => point[c] = parse_number(source, line, name, field)?,
            Role::Quat(c) => quat[c] = parse_number(source, line, name, field)?,
            Role::Euler(c) => euler[c] = parse_number(source, line, name, field)?,
            Role::SigmaMm(c) | Role::SigmaDeg(c) => {
                let v = parse_number(source, line, name, field)?;
                if v <= 0.0 {
                    return Err(invalid(
                        name,
                        format!("standard deviation {} is not positive", short(v)),
                    ));
                }
                if matches!(role, Role::SigmaMm(_)) {
                    sigma_mm[c] = v;
                } else {
                    sigma_deg[c] = v;
                }
            }
            Role::Id => id = (!field.is_empty()).then(|| (*field).to_owned()),
            Role::Target => {
                if let Some(problem) = target_problem(field) {
                    return Err(invalid(
                        name,
                        format!("target {:?} {problem}", shorten(field)),
                    ));
                }
                target = Some((*field).to_owned());
            }
            Role::Ignored => {}
        }
    }
    if header.has_target && id.is_none() {
        return Err(invalid(
            "id",
            "the id is empty, but with a target column every row needs one (the rows with the \
             same id are one pose)"
                .to_owned(),
        ));
    }
    if header.has_quat {
        let norm = quat.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(MeasurementError::NotUnitQuaternion {
                file: source.to_owned(),
                line,
                column: "qw".to_owned(),
                norm,
                tolerance: QUATERNION_NORM_TOLERANCE,
            });
        }
    }
    let orientation = if header.has_quat {
        Some(quat)
    } else if header.has_euler && opts.rotation_vector {
        let angle = euler.iter().map(|v| v * v).sum::<f64>().sqrt();
        if angle > std::f64::consts::TAU {
            return Err(invalid(
                "rx",
                format!(
                    "the rotation vector (rx,ry,rz) has length {}, beyond one turn (2π = \
                     6.2832): rotation vectors are read in radians (degrees? multiply by π/180)",
                    short(angle)
                ),
            ));
        }
        Some(crate::rotvec_to_quaternion(euler))
    } else if header.has_euler {
        // The header check guarantees a convention.
        opts.euler.map(|c| c.to_quaternion(euler))
    } else {
        None
    };
    Ok(Measurement {
        line,
        id,
        q_deg,
        point_mm: header.has_points.then_some(point),
        target,
        orientation,
        sigma_mm: header.has_sigma_mm.then_some(sigma_mm),
        sigma_deg: header.has_sigma_deg.then_some(sigma_deg),
    })
}

/// Why `name` is not a valid target name, if it is not: a target is named by a simple
/// identifier, ASCII letters, digits, `_`, `-` and `.`, starting with a letter, digit or `_`.
pub(crate) fn target_problem(name: &str) -> Option<&'static str> {
    if name.is_empty() {
        Some("is empty (every row of a file with a target column names its target)")
    } else if !name
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
    {
        Some("is not a simple name (ASCII letters, digits, '_', '-' and '.' only)")
    } else if !name
        .bytes()
        .next()
        .is_some_and(|b| b.is_ascii_alphanumeric() || b == b'_')
    {
        Some("does not start with a letter, a digit or '_'")
    } else {
        None
    }
}

/// A violation of the pose rules of a set with targets, by 0-based row index.
pub(crate) enum PoseProblem {
    /// Row `row` disagrees with the pose's first row `first` in joint `joint`.
    Joints {
        row: usize,
        first: usize,
        joint: usize,
    },
    /// Row `row` names the same target as row `first` of its pose.
    DuplicateTarget { row: usize, first: usize },
    /// Row `row` names a target that differs from row `first`'s only in case.
    Inconsistent { row: usize, first: usize },
}

impl PoseProblem {
    /// The reader's error for this problem.
    fn into_error(self, source: &str, rows: &[Measurement]) -> MeasurementError {
        let file = source.to_owned();
        let id = |r: usize| rows[r].id.clone().unwrap_or_default();
        let target = |r: usize| rows[r].target.clone().unwrap_or_default();
        match self {
            Self::Joints { row, first, joint } => MeasurementError::PoseJointsDisagree {
                file,
                line: rows[row].line,
                first_line: rows[first].line,
                id: id(row).into(),
                column: format!("q{}", joint + 1).into(),
                value: rows[row].q_deg[joint],
                first_value: rows[first].q_deg[joint],
            },
            Self::DuplicateTarget { row, first } => MeasurementError::DuplicateTarget {
                file,
                line: rows[row].line,
                first_line: rows[first].line,
                id: id(row),
                target: target(row),
            },
            Self::Inconsistent { row, first } => MeasurementError::InconsistentTarget {
                file,
                line: rows[row].line,
                first_line: rows[first].line,
                target: target(row),
                earlier: target(first),
            },
        }
    }

    /// What is wrong, for the writer's [`MeasurementError::Unwritable`]: the row (1-based) and
    /// the reason.
    pub(crate) fn describe(&self, rows: &[Measurement]) -> (usize, String) {
        let id = |r: usize| rows[r].id.clone().unwrap_or_default();
        let target = |r: usize| rows[r].target.clone().unwrap_or_default();
        match *self {
            Self::Joints { row, first, joint } => (
                row + 1,
                format!(
                    "pose {:?}: q{} is {} here but {} in row {} (rows with the same id are one pose)",
                    id(row),
                    joint + 1,
                    short(rows[row].q_deg[joint]),
                    short(rows[first].q_deg[joint]),
                    first + 1
                ),
            ),
            Self::DuplicateTarget { row, first } => (
                row + 1,
                format!(
                    "target {:?} appears twice in pose {:?} (rows {} and {})",
                    target(row),
                    id(row),
                    first + 1,
                    row + 1
                ),
            ),
            Self::Inconsistent { row, first } => (
                row + 1,
                format!(
                    "target {:?} differs from target {:?} (row {}) only in letter case",
                    target(row),
                    target(first),
                    first + 1
                ),
            ),
        }
    }
}

impl MeasurementSet {
    /// The checks [`read_file`] makes across a file's rows, for a set built in memory: each
    /// orientation a unit quaternion within [`QUATERNION_NORM_TOLERANCE`]; each target name
    /// one a file accepts; with targets, a non-empty id on every row and the pose rules (rows with the same id are one pose: equal joints,
    /// each target at most once; a target spelled one way). Errors name the row's `line` as
    /// the reader names a file's line.
    ///
    /// # Errors
    /// [`MeasurementError::NotUnitQuaternion`], [`MeasurementError::InvalidField`] (a missing
    /// id), and the pose errors of a file.
    pub fn check_rows(&self) -> Result<(), MeasurementError> {
        let with_target = self.has_targets();
        for r in &self.rows {
            if let Some(q) = r.orientation {
                let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                    return Err(MeasurementError::NotUnitQuaternion {
                        file: self.source.clone(),
                        line: r.line,
                        column: "qw".to_owned(),
                        norm,
                        tolerance: QUATERNION_NORM_TOLERANCE,
                    });
                }
            }
            if let Some(t) = &r.target
                && let Some(problem) = target_problem(t)
            {
                return Err(MeasurementError::InvalidField {
                    file: self.source.clone(),
                    line: r.line,
                    column: "target".to_owned(),
                    reason: format!("target {:?} {problem}", shorten(t)),
                });
            }
            if with_target && r.id.as_deref().is_none_or(str::is_empty) {
                return Err(MeasurementError::InvalidField {
                    file: self.source.clone(),
                    line: r.line,
                    column: "id".to_owned(),
                    reason: "no id, but with targets every row needs one (the rows with the \
                             same id are one pose)"
                        .to_owned(),
                });
            }
        }
        if with_target {
            check_poses(&self.rows).map_err(|p| p.into_error(&self.source, &self.rows))?;
        }
        Ok(())
    }
}

/// The pose rules of a set with targets: a target name is spelled one way throughout (no
/// two names equal but for letter case); rows with the same id (one pose) have equal joint
/// values (`==`) and name each target at most once. Rows without an id are poses of their own.
pub(crate) fn check_poses(rows: &[Measurement]) -> Result<(), PoseProblem> {
    use std::collections::HashMap;
    // Lower-cased target name -> first row naming it.
    let mut spelled: HashMap<String, usize> = HashMap::new();
    // Pose id -> its rows.
    let mut poses: HashMap<&str, Vec<usize>> = HashMap::new();
    for (row, r) in rows.iter().enumerate() {
        if let Some(t) = &r.target {
            let first = *spelled.entry(t.to_ascii_lowercase()).or_insert(row);
            if rows[first].target.as_deref() != Some(t.as_str()) {
                return Err(PoseProblem::Inconsistent { row, first });
            }
        }
        let Some(id) = r.id.as_deref() else { continue };
        let members = poses.entry(id).or_default();
        if let Some(&first) = members.first() {
            if let Some(joint) = (0..r.q_deg.len().min(rows[first].q_deg.len()))
                .find(|&j| r.q_deg[j] != rows[first].q_deg[j])
            {
                return Err(PoseProblem::Joints { row, first, joint });
            }
            if let Some(&other) = members
                .iter()
                .find(|&&m| r.target.is_some() && rows[m].target == r.target)
            {
                return Err(PoseProblem::DuplicateTarget { row, first: other });
            }
        }
        members.push(row);
    }
    Ok(())
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

    /// A set built in memory gets the reader's checks across rows, naming the row's line.
    #[test]
    fn check_rows_applies_the_readers_rules_to_a_set_in_memory() {
        let row = |q: f64, id: &str, t: &str| {
            Measurement::new(vec![q], Some([0.0; 3]))
                .with_id(id)
                .with_target(t)
        };
        let lined = |mut rows: Vec<Measurement>| {
            for (k, r) in rows.iter_mut().enumerate() {
                r.line = k + 1;
            }
            MeasurementSet::new("mem", 1, rows)
        };
        let ok = lined(vec![
            row(1.0, "p1", "A"),
            row(1.0, "p1", "B"),
            row(2.0, "p2", "A"),
        ]);
        ok.check_rows().unwrap();
        let e = lined(vec![row(1.0, "p1", "A"), row(1.5, "p1", "B")])
            .check_rows()
            .unwrap_err();
        assert!(
            matches!(e, MeasurementError::PoseJointsDisagree { line: 2, .. }),
            "{e}"
        );
        let e = lined(vec![row(1.0, "p1", "A"), row(1.0, "p1", "A")])
            .check_rows()
            .unwrap_err();
        assert!(
            matches!(e, MeasurementError::DuplicateTarget { line: 2, .. }),
            "{e}"
        );
        let mut no_id = row(3.0, "p3", "A");
        no_id.id = None;
        let e = lined(vec![row(1.0, "p1", "A"), no_id])
            .check_rows()
            .unwrap_err();
        assert!(e.to_string().contains("\"id\""), "{e}");
        let e = lined(vec![row(1.0, "p1", "A"), row(3.0, "", "A")])
            .check_rows()
            .unwrap_err();
        assert!(e.to_string().contains("\"id\""), "{e}");
        for bad in ["", "r 1", "a,b"] {
            let e = lined(vec![row(1.0, "p1", "A"), row(3.0, "p3", bad)])
                .check_rows()
                .unwrap_err();
            assert!(
                matches!(&e, MeasurementError::InvalidField { line: 2, column, .. } if column == "target"),
                "{bad:?}: {e}"
            );
        }
        let turned =
            Measurement::new(vec![1.0], Some([0.0; 3])).with_orientation([1.0, 0.0, 0.0, 0.0]);
        lined(vec![turned.clone()]).check_rows().unwrap();
        let long = turned.with_orientation([1.0, 0.01, 0.0, 0.0]);
        let e = lined(vec![
            row(1.0, "p1", "A").with_orientation([1.0, 0.0, 0.0, 0.0]),
            long,
        ])
        .check_rows()
        .unwrap_err();
        assert!(
            matches!(e, MeasurementError::NotUnitQuaternion { line: 2, .. }),
            "{e}"
        );
    }

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

#[cfg(test)]
mod pose_file_tests {
    use super::*;

    /// A file of poses without joints (Cartesian targets, `n_joints` 0): points required, an
    /// orientation by quaternion or Euler angles, a joint column refused with the count.
    #[test]
    fn a_file_of_poses_without_joints_reads_with_n_joints_0() {
        let opts = ReadOptions::new(0);
        let set = read_str(
            "# targets\nid,x,y,z,qw,qx,qy,qz\nt1,1,2,3,1,0,0,0\n,4,5,6,0,0,0,1\n",
            "t.csv",
            &opts,
        )
        .unwrap();
        assert_eq!(set.rows.len(), 2);
        assert!(set.rows[0].q_deg.is_empty());
        assert_eq!(set.rows[1].point_mm, Some([4.0, 5.0, 6.0]));
        assert_eq!(set.rows[1].orientation, Some([0.0, 0.0, 0.0, 1.0]));
        assert_eq!(set.rows[1].line, 4);
        let euler = opts.clone().with_euler("ZYX".parse().unwrap());
        let set = read_str("x,y,z,rx,ry,rz\n1,2,3,90,0,0\n", "t.csv", &euler).unwrap();
        let q = set.rows[0].orientation.unwrap();
        assert!((q[0] - q[3]).abs() < 1e-15 && q[1] == 0.0, "{q:?}");
        let e = read_str("id,x,y\nt1,1,2\n", "t.csv", &opts).unwrap_err();
        assert!(
            e.to_string().contains("missing required column \"z\""),
            "{e}"
        );
        let e = read_str("q1,x,y,z\n1,1,2,3\n", "t.csv", &opts).unwrap_err();
        assert!(e.to_string().contains("0 joints are expected"), "{e}");
        let rotvec = opts.clone().with_rotation_vector();
        let set = read_str("x,y,z,rx,ry,rz\n1,2,3,0,0,1.5\n", "t.csv", &rotvec).unwrap();
        let q = set.rows[0].orientation.unwrap();
        assert!((q[0] - 0.75f64.cos()).abs() < 1e-15 && (q[3] - 0.75f64.sin()).abs() < 1e-15);
        let e = read_str("x,y,z,rx,ry,rz\n1,2,3,0,0,90\n", "t.csv", &rotvec).unwrap_err();
        assert!(e.to_string().contains("t.csv:2: column \"rx\""), "{e}");
        assert!(e.to_string().contains("radians"), "{e}");
        let e = read_str("x,y,z\n1,2,3\n", "t.csv", &opts.joints_only()).unwrap_err();
        assert!(e.to_string().contains("n_joints is 0"), "{e}");
    }
}
