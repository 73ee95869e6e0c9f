//! The error type of this crate.

/// Everything that can go wrong reading or writing a measurement file.
///
/// The message (`Display`) always starts with the file (path or label), followed where it
/// applies by the physical 1-based line and the column, e.g.
/// `data.csv:17: column "q3": "abc" is not a number`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeasurementError {
    /// The file could not be read or written.
    #[error("{file}: {source}")]
    Io {
        /// File path.
        file: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The file is not valid UTF-8.
    #[error("{file}:{line}: not valid UTF-8")]
    NotUtf8 {
        /// File path or label.
        file: String,
        /// Line holding the first invalid byte.
        line: usize,
    },

    /// The file has no header: it is empty or holds only comments and blank lines.
    #[error("{file}: no header line (the file is empty or holds only comments and blank lines)")]
    NoHeader {
        /// File path or label.
        file: String,
    },

    /// A required column is absent from the header.
    #[error("{file}:{line}: missing required column \"{column}\"")]
    MissingColumn {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// Name of the missing column.
        column: String,
    },

    /// The header's fields are separated by something other than commas (`;`, a tab,
    /// spaces), so none of its columns is found; the first data row may also write decimal
    /// commas (the usual companion of `;`).
    #[error(
        "{file}:{line}:{position}: the header is separated by {}, not commas: measurement files \
         are comma-separated (q1,q2,…,x,y,z){}",
        describe_separator(*.separator),
        decimal_comma_hint(.decimal_comma)
    )]
    Separator {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// 1-based character column of the first separator on that line.
        position: usize,
        /// The separator seen.
        separator: char,
        /// The first data row's line and a number written with a decimal comma there.
        decimal_comma: Option<(usize, String)>,
    },

    /// A required column is in the header in another letter case (`Q1`, `X`): names are
    /// lower-case and case-sensitive.
    #[error(
        "{file}:{line}:{position}: column \"{found}\": column names are lower-case and \
         case-sensitive; write \"{expected}\""
    )]
    HeaderCase {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// 1-based character column where the name starts.
        position: usize,
        /// The name as written.
        found: String,
        /// The name the reader expects.
        expected: String,
    },

    /// A row with more fields than the header whose numbers are written with a decimal comma
    /// (`-179,999848`): each comma splits a number in two.
    #[error(
        "{file}:{line}:{position}: \"{text}\" is a number with a decimal comma (the row has \
         {found} fields where the header has {expected}): numbers take a decimal point \
         (-179.999848)"
    )]
    DecimalComma {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// 1-based character column of the decimal comma.
        position: usize,
        /// The number as written, with its comma.
        text: String,
        /// Number of header fields.
        expected: usize,
        /// Number of fields in this row.
        found: usize,
    },

    /// A known column appears twice in the header.
    #[error(
        "{file}:{line}: duplicate column \"{column}\" (header fields {first_field} and {second_field})"
    )]
    DuplicateColumn {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// The duplicated column name.
        column: String,
        /// 1-based position of its first occurrence in the header.
        first_field: usize,
        /// 1-based position of its second occurrence in the header.
        second_field: usize,
    },

    /// The header's joint columns are not exactly `q1…qN` for the expected N (e.g. a 7-joint
    /// file read as a 6-joint robot, or only `q1…q5`).
    #[error(
        "{file}:{line}: column \"{column}\": the header has {} joint column(s) ({}) but {expected} joints are expected (q1..q{expected})",
        .found.len(), describe_joint_columns(.found)
    )]
    JointCountMismatch {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// The first offending column: an unexpected joint column (e.g. `q7`) or the first
        /// missing one (e.g. `q6`).
        column: String,
        /// Expected number of joints.
        expected: usize,
        /// Joint-like columns found in the header, sorted by joint index.
        found: Vec<String>,
    },

    /// A field that must be a number is not one (including an empty field).
    #[error("{file}:{line}: column \"{column}\": \"{text}\" is not a number")]
    NotANumber {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Column name.
        column: String,
        /// The offending text (trimmed, possibly shortened).
        text: String,
    },

    /// A field is `NaN`, an infinity, or overflows `f64`.
    #[error(
        "{file}:{line}: column \"{column}\": \"{text}\" is not a finite number (NaN and infinity are not allowed)"
    )]
    NonFinite {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Column name.
        column: String,
        /// The offending text (trimmed, possibly shortened).
        text: String,
    },

    /// A row does not have as many fields as the header.
    #[error(
        "{file}:{line}: row has {found} field(s) but the header has {expected}{}",
        ragged_hint(.first_missing_column)
    )]
    RaggedRow {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Number of header fields.
        expected: usize,
        /// Number of fields in this row.
        found: usize,
        /// If the row is short: the header name of its first missing field.
        first_missing_column: Option<String>,
    },

    /// A joint value lies outside its limits: degrees for a revolute joint, millimetres for a
    /// prismatic one (`unit`).
    #[error(
        "{file}:{line}: column \"{column}\": joint value {} {unit} is outside its limits [{}, {}] {unit}",
        short(*.value), short(*.min), short(*.max)
    )]
    JointOutOfLimits {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Joint column name (`q1`…).
        column: String,
        /// The value read, in `unit`.
        value: f64,
        /// Lower limit, in `unit`.
        min: f64,
        /// Upper limit, in `unit`.
        max: f64,
        /// The unit of `value`, `min` and `max`: `"deg"` (a revolute joint, and the reader's
        /// own limits, [`crate::ReadOptions::limits_deg`]) or `"mm"` (a prismatic joint).
        unit: &'static str,
    },

    /// The file has fewer data rows than required.
    #[error(
        "{file}: {found} data row(s), but at least {needed} are needed (fewer rows than the free parameters need)"
    )]
    TooFewRows {
        /// File path or label.
        file: String,
        /// Data rows found.
        found: usize,
        /// Data rows required ([`ReadOptions::min_rows`](crate::ReadOptions::min_rows)).
        needed: usize,
    },

    /// The [`ReadOptions`](crate::ReadOptions) themselves are unusable (a caller bug).
    #[error("{file}: invalid read options: {reason}")]
    InvalidOptions {
        /// File path or label being read.
        file: String,
        /// What is wrong.
        reason: String,
    },

    /// The header's columns contradict each other or the options: both quaternion and Euler
    /// orientation columns, standard deviations without the values they belong to, a `target`
    /// column without an `id` column.
    #[error("{file}:{line}: column \"{column}\": {reason}")]
    ColumnConflict {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// The column the conflict is reported at.
        column: String,
        /// What is wrong and how to fix it.
        reason: String,
    },

    /// The file has Euler-angle columns `rx,ry,rz` but the caller gave no convention
    /// ([`ReadOptions::euler`](crate::ReadOptions::euler)).
    #[error(
        "{file}:{line}: column \"{column}\": Euler angles rx,ry,rz need a convention, and none was given: set ReadOptions::euler (ReadOptions::with_euler, e.g. \"XYZ\" for intrinsic X-Y-Z, \"xyz\" for extrinsic), or give the orientation as a quaternion qw,qx,qy,qz"
    )]
    EulerConventionMissing {
        /// File path or label.
        file: String,
        /// Line of the header.
        line: usize,
        /// The first Euler column in the header.
        column: String,
    },

    /// The quaternion `qw,qx,qy,qz` of a row is not of unit norm within
    /// [`QUATERNION_NORM_TOLERANCE`](crate::QUATERNION_NORM_TOLERANCE).
    #[error(
        "{file}:{line}: column \"{column}\": the quaternion (qw,qx,qy,qz) has norm {}, not 1 (|norm - 1| must be at most {tolerance})",
        short(*.norm)
    )]
    NotUnitQuaternion {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Column name (`qw`).
        column: String,
        /// The norm found.
        norm: f64,
        /// The tolerance applied.
        tolerance: f64,
    },

    /// A field holds a value this column does not accept: a standard deviation that is not
    /// positive, an invalid target name, an empty id where a `target` column needs one.
    #[error("{file}:{line}: column \"{column}\": {reason}")]
    InvalidField {
        /// File path or label.
        file: String,
        /// Line of the row.
        line: usize,
        /// Column name.
        column: String,
        /// What is wrong.
        reason: String,
    },

    /// Two rows of one pose (same `id` in a file with a `target` column) disagree in a joint
    /// value.
    #[error(
        "{file}:{line}: column \"{column}\": pose \"{id}\" has {} here but {} on line {first_line}; rows with the same id are one pose and must have the same joint values",
        short(*.value), short(*.first_value)
    )]
    PoseJointsDisagree {
        /// File path or label.
        file: String,
        /// Line of the disagreeing row.
        line: usize,
        /// The pose's first row.
        first_line: usize,
        /// The pose id (`Box<str>`, not `String`: this variant sets the size of every error
        /// that carries a `MeasurementError`).
        id: Box<str>,
        /// The first joint column that disagrees.
        column: Box<str>,
        /// Its value on `line`, degrees.
        value: f64,
        /// Its value on `first_line`, degrees.
        first_value: f64,
    },

    /// A target is named twice in one pose.
    #[error(
        "{file}:{line}: column \"target\": target \"{target}\" appears twice in pose \"{id}\" (lines {first_line} and {line})"
    )]
    DuplicateTarget {
        /// File path or label.
        file: String,
        /// Line of the second occurrence.
        line: usize,
        /// Line of the first occurrence.
        first_line: usize,
        /// The pose id.
        id: String,
        /// The target name.
        target: String,
    },

    /// A target name differs from an earlier one only in letter case (`T1` and `t1`): one
    /// reflector named two ways, or two reflectors named too alike.
    #[error(
        "{file}:{line}: column \"target\": target \"{target}\" differs from target \"{earlier}\" (line {first_line}) only in letter case; name each reflector one way"
    )]
    InconsistentTarget {
        /// File path or label.
        file: String,
        /// Line of this name.
        line: usize,
        /// Line where the earlier spelling appears first.
        first_line: usize,
        /// The name on `line`.
        target: String,
        /// The earlier spelling.
        earlier: String,
    },

    /// A set cannot be written as a valid measurement file (the result would not read back
    /// identically).
    #[error("{file}: cannot write row {row}: {reason}")]
    Unwritable {
        /// Target file path (or the set's source label for [`to_csv_string`](crate::to_csv_string)).
        file: String,
        /// 1-based index of the offending row in [`MeasurementSet::rows`](crate::MeasurementSet::rows)
        /// (0 if the problem is not in a row).
        row: usize,
        /// What is wrong.
        reason: String,
    },
}

impl MeasurementError {
    /// The file path or label the error is about.
    pub fn file(&self) -> &str {
        match self {
            Self::Io { file, .. }
            | Self::NotUtf8 { file, .. }
            | Self::NoHeader { file }
            | Self::MissingColumn { file, .. }
            | Self::Separator { file, .. }
            | Self::HeaderCase { file, .. }
            | Self::DecimalComma { file, .. }
            | Self::DuplicateColumn { file, .. }
            | Self::JointCountMismatch { file, .. }
            | Self::NotANumber { file, .. }
            | Self::NonFinite { file, .. }
            | Self::RaggedRow { file, .. }
            | Self::JointOutOfLimits { file, .. }
            | Self::TooFewRows { file, .. }
            | Self::InvalidOptions { file, .. }
            | Self::Unwritable { file, .. }
            | Self::ColumnConflict { file, .. }
            | Self::EulerConventionMissing { file, .. }
            | Self::NotUnitQuaternion { file, .. }
            | Self::InvalidField { file, .. }
            | Self::PoseJointsDisagree { file, .. }
            | Self::DuplicateTarget { file, .. }
            | Self::InconsistentTarget { file, .. } => file,
        }
    }

    /// The physical 1-based line the error is about, if any.
    pub fn line(&self) -> Option<usize> {
        match self {
            Self::NotUtf8 { line, .. }
            | Self::MissingColumn { line, .. }
            | Self::Separator { line, .. }
            | Self::HeaderCase { line, .. }
            | Self::DecimalComma { line, .. }
            | Self::DuplicateColumn { line, .. }
            | Self::JointCountMismatch { line, .. }
            | Self::NotANumber { line, .. }
            | Self::NonFinite { line, .. }
            | Self::RaggedRow { line, .. }
            | Self::JointOutOfLimits { line, .. }
            | Self::ColumnConflict { line, .. }
            | Self::EulerConventionMissing { line, .. }
            | Self::NotUnitQuaternion { line, .. }
            | Self::InvalidField { line, .. }
            | Self::PoseJointsDisagree { line, .. }
            | Self::DuplicateTarget { line, .. }
            | Self::InconsistentTarget { line, .. } => Some(*line),
            _ => None,
        }
    }

    /// The column the error is about, if any.
    pub fn column(&self) -> Option<&str> {
        match self {
            Self::MissingColumn { column, .. }
            | Self::DuplicateColumn { column, .. }
            | Self::JointCountMismatch { column, .. }
            | Self::NotANumber { column, .. }
            | Self::NonFinite { column, .. }
            | Self::JointOutOfLimits { column, .. }
            | Self::ColumnConflict { column, .. }
            | Self::EulerConventionMissing { column, .. }
            | Self::NotUnitQuaternion { column, .. }
            | Self::InvalidField { column, .. } => Some(column),
            Self::PoseJointsDisagree { column, .. } => Some(column),
            Self::HeaderCase { found, .. } => Some(found),
            Self::DuplicateTarget { .. } | Self::InconsistentTarget { .. } => Some("target"),
            Self::RaggedRow {
                first_missing_column,
                ..
            } => first_missing_column.as_deref(),
            _ => None,
        }
    }
}

/// An unusable Euler-angle convention name ([`EulerConvention::parse`](crate::EulerConvention::parse)).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "invalid Euler convention \"{text}\": {reason}; expected three axis letters, upper case for intrinsic (rotating) axes as in XYZ, ZYX, ZYZ, lower case for extrinsic (fixed) axes as in xyz, zyx, zyz, no axis twice in a row"
)]
pub struct EulerConventionError {
    /// The text given.
    pub text: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

/// `q1..q5` if the columns are exactly `q1…qk`, else a comma-separated list.
fn describe_joint_columns(found: &[String]) -> String {
    let contiguous = !found.is_empty()
        && found
            .iter()
            .enumerate()
            .all(|(i, name)| *name == format!("q{}", i + 1));
    if contiguous && found.len() > 1 {
        format!("q1..q{}", found.len())
    } else if found.is_empty() {
        "none".to_owned()
    } else {
        found.join(", ")
    }
}

/// Magnitude from which [`short`] and [`number`] print exponent notation [10⁶: no length in
/// mm, angle in degrees or count of a calibration is that large, so a value beyond it is
/// wrong data, and its digits say nothing].
pub const EXPONENT_FROM: f64 = 1e6;

/// A number for a message: Rust's shortest form, in exponent notation from
/// [`EXPONENT_FROM`] up and below 10⁻⁶ (`1e300`, not 301 digits; `1.8446744073709552e19`).
pub fn short(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-6..EXPONENT_FROM).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A number for a message with `decimals` decimals, as `{:.decimals$}` does, but from
/// [`EXPONENT_FROM`] up in exponent notation with 4 significant digits, trailing zeros
/// dropped (`99469.0459`, `1.2e6`, `1e300`, `inf`).
pub fn number(v: f64, decimals: usize) -> String {
    if !(v.is_finite() && v.abs() >= EXPONENT_FROM) {
        return format!("{v:.decimals$}");
    }
    let e = format!("{v:.3e}");
    match e.split_once('e') {
        Some((mantissa, exp)) if mantissa.contains('.') => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exp}")
        }
        _ => e,
    }
}

/// `';' (semicolon)`, `a tab`, `spaces`.
fn describe_separator(c: char) -> String {
    match c {
        ';' => "';' (semicolons)".to_owned(),
        '\t' => "tabs".to_owned(),
        ' ' => "spaces".to_owned(),
        '|' => "'|' (vertical bars)".to_owned(),
        c => format!("{c:?}"),
    }
}

fn decimal_comma_hint(d: &Option<(usize, String)>) -> String {
    match d {
        Some((line, text)) => format!(
            "; line {line} also writes numbers with a decimal comma (\"{text}\"): numbers take a \
             decimal point"
        ),
        None => String::new(),
    }
}

fn ragged_hint(first_missing_column: &Option<String>) -> String {
    match first_missing_column {
        Some(c) => format!(" (first missing column \"{c}\")"),
        None => String::new(),
    }
}
