//! Reading and writing the kincal measurement file (`docs/model.md` §5).
//!
//! This is the only crate that parses or produces measurement CSV files. It knows nothing
//! about kinematics and uses no randomness. It also provides [`write_atomically`], which every
//! other crate uses to write its output files.
//!
//! # The format
//!
//! A measurement file is UTF-8 text (a leading UTF-8 byte-order mark is accepted), with `\n`
//! or `\r\n` line endings:
//!
//! ```text
//! # UR10, series B (comment lines may appear anywhere)
//! id,q1,q2,q3,q4,q5,q6,x,y,z
//! p001,-52.068972,-2.989293,-110.435323,-66.585144,-117.984042,-0.047965,-0.507208,-3343.1516,-426.95048
//!
//! # blank lines are skipped too
//! p002,-52.068972,-107.895401,110.435323,-182.536905,-117.984042,-0.042501,1.845197,-3343.6855,-425.73515
//! ```
//!
//! * Lines whose first non-blank character is `#` are comments, anywhere in the file. Blank
//!   (or whitespace-only) lines are skipped. Both still count for line numbers.
//! * The first line that is neither a comment nor blank is the header: comma-separated column
//!   names, surrounding whitespace ignored, names case-sensitive.
//! * Columns, in any order:
//!   * `q1` … `qN` — joint values as the controller reports them, **degrees**; all N required.
//!   * `x`, `y`, `z` — the measured point in the measurement (tracker) frame, **millimetres**;
//!     required unless the caller reads the joints-only form ([`ReadOptions::require_points`]
//!     `= false`), in which case they are read when present (all three or none).
//!   * `id` — optional free-text pose label; an empty field means "no id".
//!   * Any other column is ignored and named in [`MeasurementSet::notices`]. A column that looks
//!     like a joint (`q` followed by digits) but is not one of `q1`…`qN` is not "unknown": it
//!     means the file is for a different robot and is a [`MeasurementError::JointCountMismatch`].
//! * Every following non-comment, non-blank line is one measurement with exactly as many
//!   comma-separated fields as the header. Fields are trimmed; they never contain quotes or
//!   commas. Numbers must be finite: `NaN`, `inf`, `-inf`, `infinity` and values that overflow
//!   `f64` are rejected even though Rust's parser accepts them.
//!
//! Every failure is a [`MeasurementError`] whose message names the file and, where it applies,
//! the physical 1-based line and the column, e.g.
//! `data.csv:17: column "q3": "abc" is not a number`. Reading is all-or-nothing: the first
//! failure aborts and no partial set is returned.
//!
//! Writing ([`to_csv_string`], [`write_file`]) produces the header `id,q1,…,qN,x,y,z` (`id`
//! only if some row has one, `x,y,z` only if the rows have points) and formats numbers with
//! Rust's shortest round-trip `{}` formatting, so files are byte-deterministic and reading
//! them back gives bit-identical values (including `-0`).
//!
//! # Example
//!
//! ```
//! use measurements::{read_str, to_csv_string, ReadOptions};
//!
//! let text = "# two poses\nq2,q1,x,y,z,temp\n10,20,1.5,2.5,3.5,21.9\n11,21,1,2,3,22.0\n";
//! let opts = ReadOptions::new(2).with_limits_deg(vec![[-180.0, 180.0]; 2]).with_min_rows(2);
//! let set = read_str(text, "poses.csv", &opts)?;
//! assert_eq!(set.rows[0].q_deg, vec![20.0, 10.0]);
//! assert_eq!(set.rows[0].point_mm, Some([1.5, 2.5, 3.5]));
//! assert_eq!(set.rows[0].line, 3);
//! assert_eq!(set.notices, vec!["poses.csv:2: ignored unknown column \"temp\""]);
//! assert_eq!(to_csv_string(&set, None)?, "q1,q2,x,y,z\n20,10,1.5,2.5,3.5\n21,11,1,2,3\n");
//!
//! let bad = "q1,q2,x,y,z\n1,abc,3,4,5\n";
//! let err = read_str(bad, "poses.csv", &opts).unwrap_err();
//! assert_eq!(err.to_string(), r#"poses.csv:2: column "q2": "abc" is not a number"#);
//! # Ok::<(), measurements::MeasurementError>(())
//! ```

#![warn(missing_docs)]

mod error;
#[cfg(unix)]
mod output;
mod read;
mod write;

pub use error::MeasurementError;
#[cfg(unix)]
pub use output::{
    FAULT_ENV, NO_EXCHANGE_ENV, OutputDir, OutputError, OutputKind, TargetProblem, check_output,
};
pub use read::{read_file, read_str};
pub use write::{to_csv_string, write_all_atomically, write_atomically, write_file};

/// One measured pose: the commanded joint values and (usually) the measured point.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Physical 1-based line of this row in the file it was read from; 0 if it was not read
    /// from a file (e.g. produced by a simulation).
    pub line: usize,
    /// Optional pose label from the `id` column (`None` if the column is absent or the field
    /// is empty).
    pub id: Option<String>,
    /// Joint values `q1…qN` in degrees, as the controller reports them.
    pub q_deg: Vec<f64>,
    /// Measured point `(x, y, z)` in millimetres in the measurement frame; `None` in the
    /// joints-only form.
    pub point_mm: Option<[f64; 3]>,
}

impl Measurement {
    /// A measurement not read from a file (`line = 0`, no id).
    pub fn new(q_deg: Vec<f64>, point_mm: Option<[f64; 3]>) -> Self {
        Self {
            line: 0,
            id: None,
            q_deg,
            point_mm,
        }
    }

    /// The same measurement with the given id.
    pub fn with_id(mut self, id: impl Into<String>) -> Self {
        self.id = Some(id.into());
        self
    }
}

/// All measurements of one file (or one in-memory data set), in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementSet {
    /// Where the data came from: the file path as given, or a label. Error messages use it.
    pub source: String,
    /// Number of joints N; every row has exactly N joint values.
    pub n_joints: usize,
    /// The measurements in file order.
    pub rows: Vec<Measurement>,
    /// Non-fatal remarks made while reading, e.g. `data.csv:1: ignored unknown column "temp"`.
    pub notices: Vec<String>,
}

impl MeasurementSet {
    /// A set with no notices.
    pub fn new(source: impl Into<String>, n_joints: usize, rows: Vec<Measurement>) -> Self {
        Self {
            source: source.into(),
            n_joints,
            rows,
            notices: Vec::new(),
        }
    }

    /// True if the set has at least one row and every row has a measured point.
    pub fn has_points(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.point_mm.is_some())
    }
}

/// What the caller expects of a measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Number of joints N: the header must have exactly the joint columns `q1…qN`.
    pub n_joints: usize,
    /// Optional joint limits in degrees, one `[min, max]` per joint (inclusive). A value
    /// outside its limits is an error ([`MeasurementError::JointOutOfLimits`]).
    pub limits_deg: Option<Vec<[f64; 2]>>,
    /// `true`: the columns `x, y, z` are required. `false`: the joints-only form
    /// (`q1…qN` and optionally `id`) is accepted; `x, y, z` are still read if all present.
    pub require_points: bool,
    /// Minimum number of data rows, typically the number of free parameters to identify
    /// divided by 3; fewer is an error ([`MeasurementError::TooFewRows`]).
    pub min_rows: usize,
}

impl ReadOptions {
    /// Options for an N-joint robot: points required, no joint limits, no minimum row count.
    pub fn new(n_joints: usize) -> Self {
        Self {
            n_joints,
            limits_deg: None,
            require_points: true,
            min_rows: 0,
        }
    }

    /// Check every joint value against these limits (degrees, `[min, max]` per joint).
    pub fn with_limits_deg(mut self, limits_deg: Vec<[f64; 2]>) -> Self {
        self.limits_deg = Some(limits_deg);
        self
    }

    /// Accept the joints-only form (`x, y, z` optional).
    pub fn joints_only(mut self) -> Self {
        self.require_points = false;
        self
    }

    /// Require at least `min_rows` data rows.
    pub fn with_min_rows(mut self, min_rows: usize) -> Self {
        self.min_rows = min_rows;
        self
    }
}
