//! The writer and the atomic file write used by every kincal output.

use std::fmt::Write as _;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::short;
use crate::read::{check_poses, target_problem};
use crate::{MeasurementError, MeasurementSet, QUATERNION_NORM_TOLERANCE};

/// Format `set` as a measurement file (`docs/model.md` §5).
///
/// Layout: the optional `header_comment`, each of its lines prefixed with `# `; then the header
/// `id,target,q1,…,qN,x,y,z,qw,qx,qy,qz,sx,sy,sz,srx,sry,srz`, where `id` appears only if some
/// row has an id (rows without one get an empty field) and each other optional group only if
/// the rows have it (`target`, the point, the orientation as a quaternion, `sigma_mm`,
/// `sigma_deg`); then one line per row, all lines ending in `\n`. Numbers use Rust's shortest
/// round-trip `{}` formatting, so the output is byte-deterministic and
/// [`read_str`](crate::read_str) gives back bit-identical values. A file without the new
/// optional fields is written exactly as before they existed.
///
/// Errors ([`MeasurementError::Unwritable`], naming `set.source`) if the set could not be read
/// back identically: a row with the wrong number of joints, a NaN or infinite value, some rows
/// with an optional group (point, target, orientation, `sigma_mm`, `sigma_deg`) and some
/// without, standard deviations without their values or not positive, a quaternion whose norm
/// is off 1 by more than [`QUATERNION_NORM_TOLERANCE`], an id that is empty, has surrounding
/// whitespace, starts with `#`, or contains a comma, quote or control character, a target that
/// is not a simple name, targets without ids, or poses that break the rules of
/// [`MeasurementSet::poses`](crate::MeasurementSet::poses).
pub fn to_csv_string(
    set: &MeasurementSet,
    header_comment: Option<&str>,
) -> Result<String, MeasurementError> {
    format_set(set, header_comment, &set.source)
}

/// Write `set` to `path` as a measurement file ([`to_csv_string`]), atomically
/// ([`write_atomically`]): on any error nothing is written and any previous file at `path` is
/// left untouched. Errors name `path`.
pub fn write_file(
    path: &Path,
    set: &MeasurementSet,
    header_comment: Option<&str>,
) -> Result<(), MeasurementError> {
    let file = path.display().to_string();
    let text = format_set(set, header_comment, &file)?;
    write_atomically_inner(path, text.as_bytes())
        .map_err(|source| MeasurementError::Io { file, source })
}

/// Write `bytes` to `path` atomically: write a temporary file in the same directory, flush it
/// to disk, then rename it over `path`. Readers see either the old file or the complete new
/// one; on failure the temporary file is removed and nothing half-written is left behind.
///
/// An existing regular file at `path` is replaced. A symbolic link to a regular file is
/// followed: its target is replaced atomically and the link stays a link. Anything else is
/// refused and left untouched ([`check_output`](crate::check_output)): a FIFO, a device, a
/// socket, a directory, a dangling link or a link to one of those; the check is made before
/// writing and again just before the rename. The new file gets default permissions, not
/// those of the file it replaces. The error message names `path`; the [`io::ErrorKind`] is
/// kept (`InvalidInput` for a refused target, whose inner error is a
/// [`TargetProblem`](crate::TargetProblem)).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), io::Error> {
    write_atomically_inner(path, bytes)
        .map_err(|e| io::Error::new(e.kind(), format!("writing {}: {e}", path.display())))
}

/// Write a set of files into `dir` (which must exist) all or nothing: every file is first
/// written in full to a temporary file beside its target and flushed to disk; only when all
/// of them succeeded are they renamed into place. If any write fails (a full disk, say),
/// every temporary file is removed and no target is touched. The error names the file.
/// Targets are checked as by [`write_atomically`] (no link or special file is replaced).
///
/// The renames are one per file, so a kill between two of them, or a concurrent writer,
/// can leave a mixed set: an output directory written by a command is better written with
/// [`OutputDir::write_set`](crate::OutputDir::write_set), which replaces the set as a whole.
pub fn write_all_atomically<N: AsRef<str>, B: AsRef<[u8]>>(
    dir: &Path,
    files: &[(N, B)],
) -> Result<(), io::Error> {
    let mut staged: Vec<(PathBuf, PathBuf)> = Vec::with_capacity(files.len());
    let abandon = |staged: &[(PathBuf, PathBuf)]| {
        for (tmp, _) in staged {
            let _ = fs::remove_file(tmp);
        }
    };
    for (name, bytes) in files {
        let path = dir.join(name.as_ref());
        let written = destination(&path).and_then(|path| {
            let (parent, name) = split(&path)?;
            let (tmp, mut file) = create_temp_file(parent, &name.to_string_lossy())?;
            let filled = file
                .write_all(bytes.as_ref())
                .and_then(|()| file.sync_all());
            match filled {
                Ok(()) => Ok((tmp, path)),
                Err(e) => {
                    let _ = fs::remove_file(&tmp);
                    Err(e)
                }
            }
        });
        match written {
            Ok(pair) => staged.push(pair),
            Err(e) => {
                abandon(&staged);
                return Err(io::Error::new(
                    e.kind(),
                    format!("writing {}: {e}", path.display()),
                ));
            }
        }
    }
    for (i, (tmp, path)) in staged.iter().enumerate() {
        if let Err(e) = replaceable(path).and_then(|()| fs::rename(tmp, path)) {
            abandon(&staged[i..]);
            return Err(io::Error::new(
                e.kind(),
                format!("writing {}: {e}", path.display()),
            ));
        }
    }
    sync_dir(dir);
    Ok(())
}

/// Where a write of `path` lands (a link to a regular file: its target), or why not.
fn destination(path: &Path) -> io::Result<PathBuf> {
    #[cfg(unix)]
    return crate::output::file_destination(path);
    #[cfg(not(unix))]
    Ok(path.to_path_buf())
}

/// Just before the rename: `path` is absent or a regular file.
fn replaceable(path: &Path) -> io::Result<()> {
    #[cfg(unix)]
    return crate::output::check_replaceable(path);
    #[cfg(not(unix))]
    {
        let _ = path;
        Ok(())
    }
}

/// The directory and the file name of a file path (`.` for a bare name).
fn split(path: &Path) -> io::Result<(&Path, &std::ffi::OsStr)> {
    let file_name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "path does not name a file"))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Ok((dir, file_name))
}

fn write_atomically_inner(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dest = destination(path)?;
    let path = dest.as_path();
    let (dir, file_name) = split(path)?;
    let (tmp_path, file) = create_temp_file(dir, &file_name.to_string_lossy())?;
    if let Err(e) = fill_and_rename(file, bytes, &tmp_path, path) {
        let _ = fs::remove_file(&tmp_path);
        return Err(e);
    }
    sync_dir(dir);
    Ok(())
}

fn fill_and_rename(mut file: File, bytes: &[u8], tmp_path: &Path, path: &Path) -> io::Result<()> {
    file.write_all(bytes)?;
    file.sync_all()?;
    drop(file);
    replaceable(path)?;
    fs::rename(tmp_path, path)
}

/// Create a new, uniquely named hidden file `.<name>.<pid>.<n>.tmp` in `dir` (`<name>`
/// shortened when long, so the temporary's name stays within the file-name limit). The
/// temporaries of this name left by writers that are gone (a killed run) are removed first.
fn create_temp_file(dir: &Path, name: &str) -> io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let pid = std::process::id();
    #[cfg(unix)]
    let name = crate::output::short_name(name);
    #[cfg(unix)]
    remove_dead_temporaries_of(dir, &name);
    let mut attempt = 0;
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp_path = dir.join(format!(".{name}.{pid}.{n}.tmp"));
        match OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp_path)
        {
            Ok(f) => return Ok((tmp_path, f)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempt < 100 => attempt += 1,
            Err(e) => return Err(e),
        }
    }
}

/// Removes `dir`'s temporaries `.<name>.<pid>.<n>.tmp` whose process is gone (best effort:
/// a file another process removed first, or one that cannot be removed, is left).
#[cfg(unix)]
fn remove_dead_temporaries_of(dir: &Path, name: &str) {
    let prefix = format!(".{name}.");
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let f = e.file_name().to_string_lossy().into_owned();
        let ours = f
            .strip_prefix(&prefix)
            .is_some_and(|rest| rest.matches('.').count() == 2);
        if ours && crate::output::temp_file_pid(&f).is_some_and(|pid| !crate::output::is_alive(pid))
        {
            let _ = fs::remove_file(e.path());
        }
    }
}

/// Make the rename durable (best effort; only meaningful on Unix).
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

fn format_set(
    set: &MeasurementSet,
    header_comment: Option<&str>,
    file: &str,
) -> Result<String, MeasurementError> {
    let unwritable = |row: usize, reason: String| MeasurementError::Unwritable {
        file: file.to_owned(),
        row,
        reason,
    };
    let n = set.n_joints;
    if n == 0 {
        return Err(unwritable(0, "the set has n_joints = 0".to_owned()));
    }
    let first = set.rows.first();
    let with_points = first.is_some_and(|r| r.point_mm.is_some());
    let with_target = first.is_some_and(|r| r.target.is_some());
    let with_orientation = first.is_some_and(|r| r.orientation.is_some());
    let with_sigma_mm = first.is_some_and(|r| r.sigma_mm.is_some());
    let with_sigma_deg = first.is_some_and(|r| r.sigma_deg.is_some());
    let with_id = set.rows.iter().any(|r| r.id.is_some());
    if with_sigma_mm && !with_points {
        return Err(unwritable(
            1,
            "sigma_mm is given without a point".to_owned(),
        ));
    }
    if with_sigma_deg && !with_orientation {
        return Err(unwritable(
            1,
            "sigma_deg is given without an orientation".to_owned(),
        ));
    }

    for (i, r) in set.rows.iter().enumerate() {
        let row = i + 1;
        if r.q_deg.len() != n {
            return Err(unwritable(
                row,
                format!("{} joint values for a {n}-joint set", r.q_deg.len()),
            ));
        }
        for (has, with, what) in [
            (r.point_mm.is_some(), with_points, "a measured point"),
            (r.target.is_some(), with_target, "a target"),
            (r.orientation.is_some(), with_orientation, "an orientation"),
            (r.sigma_mm.is_some(), with_sigma_mm, "sigma_mm"),
            (r.sigma_deg.is_some(), with_sigma_deg, "sigma_deg"),
        ] {
            if has != with {
                return Err(unwritable(
                    row,
                    format!("some rows have {what} and some do not"),
                ));
            }
        }
        let values = r
            .q_deg
            .iter()
            .zip((1..=n).map(|j| format!("q{j}")))
            .chain(r.point_mm.iter().flatten().zip(names(&["x", "y", "z"])))
            .chain(
                r.orientation
                    .iter()
                    .flatten()
                    .zip(names(&["qw", "qx", "qy", "qz"])),
            )
            .chain(r.sigma_mm.iter().flatten().zip(names(&["sx", "sy", "sz"])))
            .chain(
                r.sigma_deg
                    .iter()
                    .flatten()
                    .zip(names(&["srx", "sry", "srz"])),
            );
        for (v, name) in values {
            if !v.is_finite() {
                return Err(unwritable(row, format!("column \"{name}\" is {v}")));
            }
            if name.starts_with('s') && *v <= 0.0 {
                return Err(unwritable(
                    row,
                    format!(
                        "column \"{name}\": standard deviation {} is not positive",
                        short(*v)
                    ),
                ));
            }
        }
        if let Some(q) = r.orientation {
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
                return Err(unwritable(
                    row,
                    format!("the orientation quaternion has norm {}, not 1", short(norm)),
                ));
            }
        }
        if let Some(id) = &r.id
            && let Some(problem) = id_problem(id)
        {
            return Err(unwritable(row, format!("id {id:?} {problem}")));
        }
        if let Some(t) = &r.target {
            if let Some(problem) = target_problem(t) {
                return Err(unwritable(row, format!("target {t:?} {problem}")));
            }
            if r.id.is_none() {
                return Err(unwritable(
                    row,
                    "a row with a target needs an id (rows with the same id are one pose)"
                        .to_owned(),
                ));
            }
        }
    }
    if with_target && let Err(problem) = check_poses(&set.rows) {
        let (row, reason) = problem.describe(&set.rows);
        return Err(unwritable(row, reason));
    }

    let mut out = String::new();
    if let Some(comment) = header_comment {
        for l in comment.lines() {
            if l.is_empty() {
                out.push_str("#\n");
            } else {
                let _ = writeln!(out, "# {l}");
            }
        }
    }
    let mut header: Vec<String> = Vec::with_capacity(n + 18);
    if with_id {
        header.push("id".to_owned());
    }
    if with_target {
        header.push("target".to_owned());
    }
    header.extend((1..=n).map(|j| format!("q{j}")));
    for (with, group) in [
        (with_points, &["x", "y", "z"][..]),
        (with_orientation, &["qw", "qx", "qy", "qz"][..]),
        (with_sigma_mm, &["sx", "sy", "sz"][..]),
        (with_sigma_deg, &["srx", "sry", "srz"][..]),
    ] {
        if with {
            header.extend(names(group));
        }
    }
    out.push_str(&header.join(","));
    out.push('\n');

    for r in &set.rows {
        let mut first = true;
        let mut sep = |out: &mut String| {
            if !first {
                out.push(',');
            }
            first = false;
        };
        if with_id {
            sep(&mut out);
            out.push_str(r.id.as_deref().unwrap_or(""));
        }
        if let Some(t) = &r.target {
            sep(&mut out);
            out.push_str(t);
        }
        let numbers = r
            .q_deg
            .iter()
            .chain(r.point_mm.iter().flatten())
            .chain(r.orientation.iter().flatten())
            .chain(r.sigma_mm.iter().flatten())
            .chain(r.sigma_deg.iter().flatten());
        for v in numbers {
            sep(&mut out);
            let _ = write!(out, "{v}");
        }
        out.push('\n');
    }
    Ok(out)
}

/// Owned column names.
fn names(group: &[&str]) -> Vec<String> {
    group.iter().map(|s| (*s).to_owned()).collect()
}

/// Why an id would not read back identically, if it would not.
fn id_problem(id: &str) -> Option<&'static str> {
    if id.is_empty() {
        Some("is empty (use None)")
    } else if id.trim() != id {
        Some("has surrounding whitespace")
    } else if id.starts_with('#') {
        Some("starts with '#' (the line would read as a comment)")
    } else if id.contains([',', '"']) {
        Some("contains a comma or a quote")
    } else if id.chars().any(char::is_control) {
        Some("contains a control character")
    } else {
        None
    }
}
