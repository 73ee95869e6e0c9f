//! Reading and writing the kincal measurement file (`docs/model.md` §5): joint values and
//! measured points, optionally the measured orientation, per-row standard deviations and
//! several targets per pose.
//!
//! This is the only crate that parses or produces measurement CSV files. It knows nothing
//! about kinematics and uses no randomness. It also provides the output writers every other
//! crate uses: [`write_atomically`] for one file, [`OutputDir`] for an output directory
//! written as a whole, and [`check_output`] to check an output path before any work (see
//! "Output targets and output sets" below).
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
//!   * `id` — optional free-text pose label; an empty field means "no id". Required, and
//!     non-empty on every row, with a `target` column.
//!   * `qw`, `qx`, `qy`, `qz` — optional (all four or none): the orientation of the measured
//!     frame in the measurement frame as a unit quaternion, scalar first (the columns of its
//!     rotation matrix are the measured frame's axes in measurement coordinates). The norm
//!     must be 1 within [`QUATERNION_NORM_TOLERANCE`] (10⁻⁶); values are kept as given.
//!   * `rx`, `ry`, `rz` — optional (all three or none), instead of `qw…qz`: the orientation as
//!     Euler angles in degrees, the first, second and third angle of the caller's convention
//!     ([`ReadOptions::euler`], [`EulerConvention`]: `XYZ` intrinsic … `xyz` extrinsic, as
//!     SciPy's `Rotation.from_euler`), converted to a quaternion on reading. Without a
//!     convention such a file is an error; both forms in one file are an error.
//!   * `sx`, `sy`, `sz` — optional standard deviations of `x, y, z` in millimetres;
//!     `srx`, `sry`, `srz` — of the orientation in degrees, about the measurement axes (see
//!     [`Measurement::sigma_deg`]). All three or none, positive, only with the values they
//!     belong to.
//!   * `target` — optional name of the target (reflector) measured: a simple name (ASCII
//!     letters, digits, `_`, `-`, `.`). With it, the rows with the same `id` form one pose
//!     ([`MeasurementSet::poses`]): their joint values must be equal, each target appears at
//!     most once per pose, and no two target names differ only in letter case. Without it,
//!     every row is a pose.
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
//! only if some row has one, `x,y,z` only if the rows have points; `target` after `id`, and
//! `qw,qx,qy,qz`, `sx,sy,sz`, `srx,sry,srz` after `z`, when the rows have them — orientations
//! always as quaternions) and formats numbers with
//! Rust's shortest round-trip `{}` formatting, so files are byte-deterministic and reading
//! them back gives bit-identical values (including `-0`).
//!
//! # Output targets and output sets
//!
//! **What an output path may name** ([`check_output`], checked again at write time by every
//! writer): nothing yet, a regular file (for a file output), or a directory (for an output
//! directory). A symbolic link is followed when it leads to the right kind: for a file, the
//! link's target is replaced atomically and the link stays a link; for a directory, the
//! files go into the linked directory and the link is never replaced. Everything else is
//! refused with an error naming the path and what it is, and left untouched: FIFOs,
//! character and block devices, sockets, a directory where a file is expected or the
//! reverse, a dangling link, a link to any of those. (Standard output is the front ends'
//! business, `--out -`; the library never writes to a device.)
//!
//! **Single files** ([`write_atomically`], [`write_file`]): a temporary
//! `.NAME.PID.N.tmp` beside the target, flushed, then renamed over it; a reader sees the old
//! file or the complete new one.
//!
//! **Output directories** ([`OutputDir`]): the front end takes [`OutputDir::lock`] before any
//! work and holds it for the whole run; at the end [`OutputDir::write_set`] replaces the
//! directory's set as a whole. A reader of the directory sees the complete previous set or
//! the complete new one, after a kill at any moment or a failure at any step:
//!
//! * *Lock.* An advisory lock (`flock`) on `.NAME.kincal-lock` beside the directory `NAME`
//!   (beside it, not inside, because the directory itself is replaced). It holds the
//!   holder's pid, start time (UTC) and command line; a second writer is refused at once
//!   with [`OutputError::Locked`] naming them (it does not wait). The lock dies with its
//!   process, so a killed run never blocks the next one; the file is removed when the
//!   [`OutputDir`] is dropped. Runs that only write single files side by side into one
//!   directory (the shards of a campaign) take it as *members* ([`OutputDir::lock_member`]):
//!   the directory lock shared, so members run at once while a whole-set writer is refused,
//!   and a lock of their own, `.NAME.kincal-lock-MEMBER`, so a second run of one member is
//!   refused.
//! * *Staging and exchange.* The new set is written into `.NAME.kincal-stage-PID` beside the
//!   directory and flushed to disk, then exchanged with the directory in one atomic rename
//!   (Linux `renameat2(RENAME_EXCHANGE)`), and the previous set (now under the staged name)
//!   is removed. The directory keeps its permission bits; its owner becomes the writer.
//! * *A set is replaced whole.* A set lists its files in the manifest [`SET_MANIFEST`]; the
//!   files the previous manifest lists that the new set does not write are not carried over.
//! * *Foreign files survive.* Every entry of the directory that is not a file of the new set
//!   or of the previous manifest — the user's own files, a checkpoint written during the run,
//!   files of a set written before manifests — is carried into the staged directory as
//!   a hard link (the same file, no copy; subdirectories are recreated with their entries
//!   linked; a copy where the file system has no hard links). Entries that appear in the
//!   directory between that scan and the exchange are moved over afterwards. Files of an
//!   earlier set that should disappear are named to [`OutputDir::write_set_dropping`].
//! * *Leftovers.* [`OutputDir::lock`] removes what an interrupted run left: staged and
//!   retired copies beside the directory (no other writer can be using them: the lock is
//!   held) and single-file temporaries inside it whose process is gone.
//! * *Without an exchange* (a file system or kernel that lacks it): the directory is renamed
//!   to `.NAME.kincal-old-PID`, the staged set renamed into place, the old one removed. A
//!   failure of the second rename moves the old set back. Between the two renames a reader
//!   finds no directory (never a mixed one); a kill there leaves the complete old set under
//!   `.NAME.kincal-old-PID`, which the next [`OutputDir::lock`] moves back.
//! * *Refused as output directories* ([`OutputError::Unswappable`]): the root, a mount point,
//!   and the current directory or one containing it (replacing it would leave the user's
//!   shell in a removed directory). Another process whose working directory is inside the
//!   output directory is left in the removed previous copy.
//!
//! The test-only environment variables [`FAULT_ENV`] and [`NO_EXCHANGE_ENV`] make a set
//! write abort or fail at a chosen step, or take the path without exchange; the tests use
//! them to kill a writer at every step.
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
//!
//! Several targets per pose, and Euler angles:
//!
//! ```
//! use measurements::{read_str, EulerConvention, ReadOptions};
//!
//! let text = "id,target,q1,x,y,z\np1,A,10,1,2,3\np1,B,10,4,5,6\np2,A,20,7,8,9\n";
//! let set = read_str(text, "t.csv", &ReadOptions::new(1))?;
//! assert_eq!(set.poses(), vec![vec![0, 1], vec![2]]);
//!
//! let text = "q1,x,y,z,rx,ry,rz\n10,1,2,3,0,0,90\n";
//! let err = read_str(text, "e.csv", &ReadOptions::new(1)).unwrap_err();
//! assert!(err.to_string().contains("ReadOptions::euler"));
//! let xyz: EulerConvention = "XYZ".parse().unwrap();
//! let set = read_str(text, "e.csv", &ReadOptions::new(1).with_euler(xyz))?;
//! let h = 0.5f64.sqrt();
//! let q = set.rows[0].orientation.unwrap(); // 90° about z
//! assert!((q[0] - h).abs() < 1e-15 && (q[3] - h).abs() < 1e-15);
//! # Ok::<(), measurements::MeasurementError>(())
//! ```

#![warn(missing_docs)]

mod error;
mod limits;
#[cfg(unix)]
mod output;
mod read;
mod rotation;
mod write;

pub use error::{EXPONENT_FROM, EulerConventionError, MeasurementError, number, short};
pub use limits::{
    BYTES_PER_ROW, SizeError, available_memory, bytes_in_words, check_rows, check_size,
};
#[cfg(unix)]
pub use output::{
    FAULT_ENV, NO_EXCHANGE_ENV, OutputDir, OutputError, OutputKind, SET_MANIFEST, SharedOutputDir,
    TargetProblem, check_output, same_file,
};
pub use read::{read_file, read_str, read_text};
pub use rotation::{
    EulerConvention, QUATERNION_NORM_TOLERANCE, quaternion_product, quaternion_to_matrix,
    quaternion_to_rotvec, rotvec_to_quaternion,
};
pub use write::{to_csv_string, write_all_atomically, write_atomically, write_file};

/// One measured row: the commanded joint values and (usually) the measured point, optionally
/// the measured orientation, standard deviations and the name of the target measured.
///
/// Rows are usually one pose each; with targets, rows with the same id are one pose
/// ([`MeasurementSet::poses`]). Build rows not read from a file with [`Measurement::new`] and
/// the `with_…` methods, or with `Measurement { q_deg, point_mm, ..Default::default() }`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurement {
    /// Physical 1-based line of this row in the file it was read from; 0 if it was not read
    /// from a file (e.g. produced by a simulation).
    pub line: usize,
    /// Optional pose label from the `id` column (`None` if the column is absent or the field
    /// is empty). With targets, the rows of one pose share it.
    pub id: Option<String>,
    /// Joint values `q1…qN` in degrees, as the controller reports them.
    pub q_deg: Vec<f64>,
    /// Measured point `(x, y, z)` in millimetres in the measurement frame; `None` in the
    /// joints-only form.
    pub point_mm: Option<[f64; 3]>,
    /// Name of the target (reflector) measured, from the `target` column; `None` if the file
    /// has none (one target per pose).
    pub target: Option<String>,
    /// Measured orientation as a unit quaternion `[w, x, y, z]`, scalar first: the
    /// orientation of the measured frame in the measurement frame (the columns of its
    /// rotation matrix are the measured frame's axes in measurement coordinates). As given in
    /// the file (`qw,qx,qy,qz`), not renormalised: its norm is within
    /// [`QUATERNION_NORM_TOLERANCE`] of 1. Euler angles (`rx,ry,rz`) are converted on reading
    /// ([`EulerConvention::to_quaternion`], `w ≥ 0`). `None` if the file has no orientation.
    pub orientation: Option<[f64; 4]>,
    /// Standard deviations of the point's `x, y, z` in millimetres (`sx,sy,sz`), positive;
    /// `None` if not given.
    pub sigma_mm: Option<[f64; 3]>,
    /// Standard deviations of the orientation in degrees (`srx,sry,srz`), positive: those of
    /// the components of the small rotation vector of the orientation error about the
    /// measurement frame's x, y and z axes (`R_measured = exp([δ]×)·R_true`, σ of δx, δy, δz),
    /// whatever form the orientation was given in. `None` if not given.
    pub sigma_deg: Option<[f64; 3]>,
}

impl Measurement {
    /// A measurement not read from a file (`line = 0`, no id, no target, orientation or
    /// standard deviations).
    pub fn new(q_deg: Vec<f64>, point_mm: Option<[f64; 3]>) -> Self {
        Self {
            q_deg,
            point_mm,
            ..Default::default()
        }
    }

    /// The same measurement with the given id.
    pub fn with_id(mut self, id: impl Into<String>) -> Self {
        self.id = Some(id.into());
        self
    }

    /// The same measurement with the given target name.
    pub fn with_target(mut self, target: impl Into<String>) -> Self {
        self.target = Some(target.into());
        self
    }

    /// The same measurement with the given orientation (unit quaternion `[w, x, y, z]`).
    pub fn with_orientation(mut self, quaternion: [f64; 4]) -> Self {
        self.orientation = Some(quaternion);
        self
    }

    /// The same measurement with the given standard deviations of the point (mm).
    pub fn with_sigma_mm(mut self, sigma_mm: [f64; 3]) -> Self {
        self.sigma_mm = Some(sigma_mm);
        self
    }

    /// The same measurement with the given standard deviations of the orientation (degrees,
    /// about the measurement axes, see [`Measurement::sigma_deg`]).
    pub fn with_sigma_deg(mut self, sigma_deg: [f64; 3]) -> Self {
        self.sigma_deg = Some(sigma_deg);
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

    /// True if the set has at least one row and every row has a measured orientation.
    pub fn has_orientation(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.orientation.is_some())
    }

    /// True if some row names a target (the set has a `target` column).
    pub fn has_targets(&self) -> bool {
        self.rows.iter().any(|r| r.target.is_some())
    }

    /// The distinct target names, in order of first appearance (empty without targets).
    pub fn targets(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for t in self.rows.iter().filter_map(|r| r.target.as_deref()) {
            if !names.contains(&t) {
                names.push(t);
            }
        }
        names
    }

    /// The poses, each as the indices into [`rows`](Self::rows) of its rows, in file order.
    ///
    /// Without targets ([`has_targets`](Self::has_targets) false) every row is a pose of its
    /// own. With targets, rows with the same [`id`](Measurement::id) form one pose (a row
    /// without an id is a pose of its own); poses are ordered by their first row. The reader
    /// guarantees that the rows of a pose share their joint values and name each target at
    /// most once.
    ///
    /// ```
    /// use measurements::{Measurement, MeasurementSet};
    /// let row = |id: &str, t: &str| Measurement::new(vec![1.0], Some([0.0; 3])).with_id(id).with_target(t);
    /// let set = MeasurementSet::new("mem", 1, vec![row("p1", "A"), row("p1", "B"), row("p2", "A")]);
    /// assert_eq!(set.poses(), vec![vec![0, 1], vec![2]]);
    /// ```
    pub fn poses(&self) -> Vec<Vec<usize>> {
        if !self.has_targets() {
            return (0..self.rows.len()).map(|i| vec![i]).collect();
        }
        let mut first: std::collections::HashMap<&str, usize> = Default::default();
        let mut poses: Vec<Vec<usize>> = Vec::new();
        for (i, r) in self.rows.iter().enumerate() {
            match r.id.as_deref() {
                Some(id) => match first.get(id) {
                    Some(&p) => poses[p].push(i),
                    None => {
                        first.insert(id, poses.len());
                        poses.push(vec![i]);
                    }
                },
                None => poses.push(vec![i]),
            }
        }
        poses
    }
}

/// What the caller expects of a measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Number of joints N: the header must have exactly the joint columns `q1…qN`. 0 reads a
    /// file of poses without joints (Cartesian targets: `x, y, z` required, an orientation
    /// optional, any `q<k>` column refused); it needs [`ReadOptions::require_points`].
    pub n_joints: usize,
    /// Optional joint limits in degrees, one `[min, max]` per joint (inclusive). A value
    /// outside its limits is an error ([`MeasurementError::JointOutOfLimits`]).
    pub limits_deg: Option<Vec<[f64; 2]>>,
    /// `true`: the columns `x, y, z` are required. `false`: the joints-only form
    /// (`q1…qN` and optionally `id`) is accepted; `x, y, z` are still read if all present.
    pub require_points: bool,
    /// Minimum number of data rows, typically the number of free parameters to identify
    /// divided by the equations per row (3 for a point; a row with an orientation gives 6);
    /// fewer is an error ([`MeasurementError::TooFewRows`]). Rows, not poses: with targets
    /// each row counts.
    pub min_rows: usize,
    /// The convention of Euler-angle columns `rx,ry,rz`, if the file may have them; a file
    /// with them and no convention is an error ([`MeasurementError::EulerConventionMissing`]).
    /// Unused for files without Euler columns. The columns hold the sequence's first, second
    /// and third angle, in degrees: a row's orientation is
    /// [`EulerConvention::to_quaternion`]`([rx, ry, rz])`, as SciPy's
    /// `Rotation.from_euler(convention, [rx, ry, rz], degrees=True)`. For `XYZ` and `xyz` these
    /// are the angles about x, y and z; for other sequences they are not (with `ZYX`, `rx` is
    /// the angle about z).
    pub euler: Option<EulerConvention>,
    /// `true`: the columns `rx, ry, rz` hold a rotation vector (axis times angle, **radians**,
    /// as a UR controller writes a pose's orientation), not Euler angles; a row's orientation
    /// is [`rotvec_to_quaternion`]`([rx, ry, rz])`. A vector longer than one turn (2π) is
    /// refused as degrees ([`MeasurementError::InvalidField`]). Takes the place of
    /// [`ReadOptions::euler`].
    pub rotation_vector: bool,
}

impl ReadOptions {
    /// Options for an N-joint robot: points required, no joint limits, no minimum row count.
    pub fn new(n_joints: usize) -> Self {
        Self {
            n_joints,
            limits_deg: None,
            require_points: true,
            min_rows: 0,
            euler: None,
            rotation_vector: false,
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

    /// Read Euler-angle columns `rx,ry,rz` (degrees) in this convention, e.g.
    /// `"XYZ".parse()?` (intrinsic) or `"xyz".parse()?` (extrinsic).
    pub fn with_euler(mut self, convention: EulerConvention) -> Self {
        self.euler = Some(convention);
        self
    }

    /// Read the columns `rx,ry,rz` as a rotation vector in radians
    /// ([`ReadOptions::rotation_vector`]).
    pub fn with_rotation_vector(mut self) -> Self {
        self.rotation_vector = true;
        self.euler = None;
        self
    }
}
