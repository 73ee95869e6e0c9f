//! Output targets and output sets: what an output path may name, and how a set of files
//! replaces the previous set of an output directory in one step.
//!
//! The policy is described in the crate documentation ("Output targets and output sets").

use std::collections::BTreeSet;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Read as _, Write as _};
use std::os::unix::fs::{FileTypeExt, MetadataExt};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// What the caller means to write at an output path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// One file, written with [`write_atomically`](crate::write_atomically).
    File,
    /// A directory of files, written as a whole with [`OutputDir::write_set`].
    Directory,
}

/// Why an existing path cannot be written as asked. The message does not name the path: the
/// error holding it does ([`OutputError::Target`], or the I/O error of
/// [`write_atomically`](crate::write_atomically), which starts with the path).
///
/// # When this error occurs
/// The path names something a writer must not replace: a FIFO, a device, a socket, a
/// directory where a file is expected (or the reverse), or a symbolic link that is dangling
/// or leads to one of those.
///
/// # How to handle
/// Name a regular file (or a new path) for a file output, a directory (or a new path) for an
/// output directory. A symbolic link to a regular file (or, for a directory output, to a
/// directory) is followed; its target is written and the link stays.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TargetProblem {
    /// A FIFO, a character or block device, or a socket.
    #[error(
        "is {what}, not a regular file or a directory: kincal never writes into nor replaces one"
    )]
    Special {
        /// What it is, e.g. "a FIFO (named pipe)".
        what: &'static str,
    },
    /// A directory where a file is expected.
    #[error("is a directory, but a file is expected")]
    IsDirectory,
    /// Not a directory where a directory is expected.
    #[error("is {what}, but an output directory is expected")]
    NotDirectory {
        /// What it is, e.g. "a regular file".
        what: &'static str,
    },
    /// A symbolic link whose target does not exist.
    #[error(
        "is a symbolic link to {target}, which does not exist: a dangling link is neither followed nor replaced"
    )]
    DanglingLink {
        /// The link's contents, as stored.
        target: PathBuf,
    },
    /// A symbolic link to something that is not of the expected kind.
    #[error(
        "is a symbolic link to {target}, which is {what}: only a link to a regular file (or, for an output directory, to a directory) is followed"
    )]
    LinkTo {
        /// The link's contents, as stored.
        target: PathBuf,
        /// What the target is.
        what: &'static str,
    },
}

/// Errors of [`check_output`] and [`OutputDir`]. Each names the path.
///
/// # When this error occurs
/// Before any work, when an output path cannot be written safely ([`Target`](Self::Target),
/// [`Unswappable`](Self::Unswappable)) or another run holds the output directory
/// ([`Locked`](Self::Locked)); at the end, when the set cannot be written
/// ([`Io`](Self::Io), [`BadName`](Self::BadName)): then the directory still holds its
/// complete previous set.
///
/// # How to handle
/// Report it and stop; the messages say what to change.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The path names something that must not be written (see [`TargetProblem`]).
    #[error("{path}: {problem}")]
    Target {
        /// The output path as given.
        path: PathBuf,
        /// What is wrong with it.
        problem: TargetProblem,
    },
    /// The directory cannot be replaced as a whole: the root, a mount point, or the current
    /// directory (or one containing it).
    #[error(
        "{path}: {why}: an output set replaces its directory as a whole, which cannot be done here; name a subdirectory (a new one is created)"
    )]
    Unswappable {
        /// The output directory.
        path: PathBuf,
        /// Why, e.g. "is a mount point".
        why: &'static str,
    },
    /// Another process holds the output directory's lock.
    #[error(
        "{path}: another run is writing this output directory ({holder}; lock file {lock}); wait for it to finish or choose another output directory"
    )]
    Locked {
        /// The output directory.
        path: PathBuf,
        /// The lock file.
        lock: PathBuf,
        /// What the holder wrote in the lock file: its pid, start time and command line.
        holder: String,
    },
    /// A file name of the set is not a plain relative path inside the directory.
    #[error(
        "{path}: output name {name:?} is not a relative path inside the directory (empty, absolute, with `.` or `..`, or given twice)"
    )]
    BadName {
        /// The output directory.
        path: PathBuf,
        /// The name.
        name: String,
    },
    /// An I/O operation failed.
    #[error("{path}: {action}: {source}")]
    Io {
        /// The file or directory concerned.
        path: PathBuf,
        /// What was being done, e.g. "writing".
        action: &'static str,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
}

fn io_err(path: &Path, action: &'static str) -> impl FnOnce(io::Error) -> OutputError {
    let path = path.to_path_buf();
    move |source| OutputError::Io {
        path,
        action,
        source,
    }
}

/// What a file type is, in words.
fn what(ft: fs::FileType) -> &'static str {
    if ft.is_file() {
        "a regular file"
    } else if ft.is_dir() {
        "a directory"
    } else if ft.is_symlink() {
        "a symbolic link"
    } else if ft.is_fifo() {
        "a FIFO (named pipe)"
    } else if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_socket() {
        "a socket"
    } else {
        "neither a regular file nor a directory"
    }
}

/// The problem with an existing non-link of type `ft` as a target of `kind`, if any.
fn kind_problem(ft: fs::FileType, kind: OutputKind) -> Option<TargetProblem> {
    match kind {
        OutputKind::File if ft.is_file() => None,
        OutputKind::Directory if ft.is_dir() => None,
        OutputKind::File if ft.is_dir() => Some(TargetProblem::IsDirectory),
        OutputKind::Directory if ft.is_file() => {
            Some(TargetProblem::NotDirectory { what: what(ft) })
        }
        _ => Some(TargetProblem::Special { what: what(ft) }),
    }
}

enum Resolve {
    Problem(TargetProblem),
    Io(io::Error),
}

/// Where writing `path` as `kind` lands: `path` itself if it does not exist or is of the
/// right kind, the link's resolved target if it is a symbolic link to the right kind.
fn resolve(path: &Path, kind: OutputKind) -> Result<PathBuf, Resolve> {
    let meta = match fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(Resolve::Io(e)),
    };
    let ft = meta.file_type();
    if !ft.is_symlink() {
        return match kind_problem(ft, kind) {
            None => Ok(path.to_path_buf()),
            Some(p) => Err(Resolve::Problem(p)),
        };
    }
    let target = fs::read_link(path).map_err(Resolve::Io)?;
    match fs::metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            Err(Resolve::Problem(TargetProblem::DanglingLink { target }))
        }
        Err(e) => Err(Resolve::Io(e)),
        Ok(m) => match kind_problem(m.file_type(), kind) {
            None => fs::canonicalize(path).map_err(Resolve::Io),
            Some(_) => Err(Resolve::Problem(TargetProblem::LinkTo {
                target,
                what: what(m.file_type()),
            })),
        },
    }
}

/// Checks an output path before any work, and says where the output will land.
///
/// * A path that does not exist is fine (it is returned as given; a file's directory must
///   exist when it is written, an output directory is created).
/// * A regular file (for [`OutputKind::File`]) or a directory (for
///   [`OutputKind::Directory`]) is fine and returned as given.
/// * A symbolic link to a regular file (file kind) or to a directory (directory kind) is
///   followed: the resolved target is returned, and it is the target that is replaced (a
///   file) or written into (a directory); the link itself stays a link.
/// * Everything else is refused with [`OutputError::Target`]: FIFOs, character and block
///   devices, sockets, a directory where a file is expected or the reverse, a dangling link,
///   a link to any of those.
///
/// The same checks are made again at write time by
/// [`write_atomically`](crate::write_atomically) and [`OutputDir::write_set`], so a path that
/// changed in between is not replaced either.
pub fn check_output(path: &Path, kind: OutputKind) -> Result<PathBuf, OutputError> {
    resolve(path, kind).map_err(|r| match r {
        Resolve::Problem(problem) => OutputError::Target {
            path: path.to_path_buf(),
            problem,
        },
        Resolve::Io(source) => OutputError::Io {
            path: path.to_path_buf(),
            action: "inspecting the output path",
            source,
        },
    })
}

fn problem_to_io(p: TargetProblem) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, p)
}

/// The file a single-file atomic write replaces (see [`check_output`]), as an I/O error
/// (whose message does not repeat the path) when it must not be written.
pub(crate) fn file_destination(path: &Path) -> io::Result<PathBuf> {
    resolve(path, OutputKind::File).map_err(|r| match r {
        Resolve::Problem(p) => problem_to_io(p),
        Resolve::Io(e) => e,
    })
}

/// Just before a rename over `dest`: it must not exist or be a regular file (a symbolic link
/// or special file that appeared since the first check is not replaced).
pub(crate) fn check_replaceable(dest: &Path) -> io::Result<()> {
    match fs::symlink_metadata(dest) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) if m.file_type().is_symlink() => Err(problem_to_io(TargetProblem::LinkTo {
            target: fs::read_link(dest).unwrap_or_default(),
            what: "a link that appeared while writing",
        })),
        Ok(m) => Err(problem_to_io(
            kind_problem(m.file_type(), OutputKind::File).unwrap_or(TargetProblem::Special {
                what: what(m.file_type()),
            }),
        )),
    }
}

// ---------------------------------------------------------------------------------------
// Test-only fault injection.

/// The environment variable of the test-only fault injection: `abort@N` aborts the process
/// (as a kill would) at the N-th step of [`OutputDir::write_set`] in this process, `fail@N`
/// makes that step fail with an I/O error. Steps count from 1 across the process's set
/// writes; each is one file staged, the carried files, the staged set synced, a rename or
/// exchange, the removal of the old set. Not for production use: the tests of this crate
/// use it to check that a kill or a failure at every step leaves the complete old or new
/// set.
pub const FAULT_ENV: &str = "KINCAL_OUTPUT_FAULT";

/// Test-only: when set (to anything), [`OutputDir::write_set`] does not use the atomic
/// exchange and takes the two-rename path of file systems without one.
pub const NO_EXCHANGE_ENV: &str = "KINCAL_OUTPUT_NO_EXCHANGE";

static STEP: AtomicUsize = AtomicUsize::new(0);

/// A step of a set write: the fault-injection point.
fn step(what: &str) -> io::Result<()> {
    let n = STEP.fetch_add(1, Ordering::Relaxed) + 1;
    let Ok(spec) = std::env::var(FAULT_ENV) else {
        return Ok(());
    };
    let parse = |prefix: &str| {
        spec.strip_prefix(prefix)
            .and_then(|s| s.parse::<usize>().ok())
    };
    if parse("abort@") == Some(n) {
        std::process::abort();
    }
    if parse("fail@") == Some(n) {
        return Err(io::Error::other(format!(
            "injected failure at step {n} ({what}, {FAULT_ENV})"
        )));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Output directories.

/// The name prefix of everything the set writer leaves beside an output directory `NAME`:
/// `.NAME.kincal-lock`, `.NAME.kincal-stage-PID`, `.NAME.kincal-old-PID`.
fn sibling(parent: &Path, name: &str, what: &str) -> PathBuf {
    parent.join(format!("{}{what}", sibling_prefix(name)))
}

/// The longest a name taken into a hidden helper file's name may be (bytes): 255, the
/// usual file-name limit, less room for the helper's own prefix and suffix.
pub(crate) const MAX_EMBEDDED_NAME: usize = 180;

/// `name` if it is at most [`MAX_EMBEDDED_NAME`] bytes, else its first bytes (at a
/// character boundary) and a 16-digit hash of the whole name, so that two long names
/// sharing a prefix still get different helper files.
pub(crate) fn short_name(name: &str) -> String {
    if name.len() <= MAX_EMBEDDED_NAME {
        return name.to_owned();
    }
    // FNV-1a, 64 bits: stable across runs and platforms.
    let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let mut cut = MAX_EMBEDDED_NAME - 17;
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    format!("{}~{hash:016x}", &name[..cut])
}

/// `.NAME.kincal-`, with `NAME` shortened ([`short_name`]) so that every sibling's name
/// stays within the file-name limit (255 bytes) whatever the directory's name.
fn sibling_prefix(name: &str) -> String {
    format!(".{}.kincal-", short_name(name))
}

/// An output directory held by this process: checked, locked against other writers, and
/// cleaned of an interrupted run's leftovers. Take it before any work
/// ([`OutputDir::lock`]), write the outputs at the end ([`OutputDir::write_set`]); the lock
/// is released when the value is dropped.
///
/// While it is held, single files may still be written into the directory with
/// [`write_atomically`](crate::write_atomically) (a checkpoint, say); [`OutputDir::write_set`]
/// carries them over.
///
/// ```
/// use measurements::{OutputDir, OutputError};
///
/// # let tmp = tempfile::tempdir().unwrap();
/// # let out_arg = tmp.path().join("results");
/// // At the start, before any work: refuses a bad --out, or a directory another run holds.
/// let out = OutputDir::lock(&out_arg)?;
/// // … the run; checkpoints may go to out.path() with write_atomically …
/// let files = vec![("summary.json", "{}\n"), ("plots/error.svg", "<svg/>\n")];
/// out.write_set(&files)?; // the complete previous set, then the complete new one
/// drop(out); // releases the lock
/// # assert_eq!(std::fs::read_to_string(out_arg.join("summary.json")).unwrap(), "{}\n");
/// # Ok::<(), OutputError>(())
/// ```
#[derive(Debug)]
pub struct OutputDir {
    /// The directory: absolute, with its parent's links resolved.
    dir: PathBuf,
    parent: PathBuf,
    name: String,
    lock_path: PathBuf,
    /// Holds the advisory lock while open.
    _lock: File,
}

pub(crate) fn is_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// The pid of a single-file writer's temporary `.<name>.<pid>.<n>.tmp`, if it is one.
pub(crate) fn temp_file_pid(file_name: &str) -> Option<u32> {
    let mid = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let mut parts = mid.rsplitn(3, '.');
    let n = parts.next()?;
    let pid = parts.next()?;
    let name = parts.next()?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(n) && digits(pid) && !name.is_empty())
        .then(|| pid.parse().ok())
        .flatten()
}

/// `YYYY-MM-DD hh:mm:ss UTC` of seconds since the Unix epoch.
fn utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The manifest of an output set: the names of the files the last set written into the
/// directory holds, one per line after a comment line ([`OutputDir::write_set`]).
pub const SET_MANIFEST: &str = ".kincal-set";

/// The manifest's text for the set `names`.
fn manifest_text(names: &BTreeSet<PathBuf>) -> String {
    let mut t = String::from(
        "# kincal output set: the files the last run wrote here, removed by the next run into \
         this directory unless it writes them again (other files are kept)\n",
    );
    for n in names {
        t.push_str(&n.to_string_lossy());
        t.push('\n');
    }
    t
}

/// The files the previous set of `dir` listed in its manifest (none when it has none).
fn previous_set(dir: &Path) -> Vec<String> {
    fs::read_to_string(dir.join(SET_MANIFEST))
        .map(|t| {
            t.lines()
                .filter(|l| !l.is_empty() && !l.starts_with('#'))
                .map(String::from)
                .collect()
        })
        .unwrap_or_default()
}

impl OutputDir {
    /// Checks `path` as an output directory ([`check_output`] with
    /// [`OutputKind::Directory`]; a link to a directory is followed), creates its parent
    /// directories if needed (not the directory itself: the first set creates it), takes
    /// the advisory lock `.NAME.kincal-lock` beside it, and removes what an interrupted run
    /// left (see the crate documentation). Call it before any work.
    ///
    /// Refused: a path that is not a directory ([`OutputError::Target`]); the root, a mount
    /// point, or the current directory or one containing it ([`OutputError::Unswappable`]);
    /// a directory another process holds ([`OutputError::Locked`], naming the holder's pid,
    /// start time and command line).
    pub fn lock(path: &Path) -> Result<Self, OutputError> {
        let (dir, parent, name) = resolve_dir(path)?;
        let lock_path = sibling(&parent, &name, "lock");
        let lock = take_lock(&lock_path, path, LockMode::Exclusive)?;
        let held = Self {
            dir,
            parent,
            name,
            lock_path,
            _lock: lock,
        };
        held.clean_up()?;
        Ok(held)
    }

    /// Takes `path` as one *member* of a group of runs that write single files side by side
    /// into one output directory (the shards of a campaign, each writing its own shard file
    /// and checkpoint): the directory's lock `.NAME.kincal-lock` is taken *shared*, so any
    /// number of members may hold it at once while a whole-set writer ([`OutputDir::lock`])
    /// is refused and refuses them; the member's own lock `.NAME.kincal-lock-MEMBER` is taken
    /// exclusively, so a second run of the same member is refused naming the first. The
    /// checks are those of [`OutputDir::lock`]; of an interrupted run's leftovers only the
    /// single-file temporaries of processes that are gone are removed (staged and retired
    /// copies are left to the next whole-set writer).
    ///
    /// A member writes single files only ([`write_atomically`](crate::write_atomically) into
    /// [`SharedOutputDir::path`]); it has no set to write.
    pub fn lock_member(path: &Path, member: &str) -> Result<SharedOutputDir, OutputError> {
        let (dir, parent, name) = resolve_dir(path)?;
        let dir_lock = take_lock(&sibling(&parent, &name, "lock"), path, LockMode::Shared)?;
        let member_lock_path = sibling(&parent, &name, &format!("lock-{member}"));
        let member_lock = take_lock(&member_lock_path, path, LockMode::Exclusive)?;
        let held = SharedOutputDir {
            dir,
            member_lock_path,
            _member_lock: member_lock,
            _dir_lock: dir_lock,
        };
        remove_dead_temporaries(&held.dir)?;
        Ok(held)
    }
}

/// An output directory held by this process as one member of a group of single-file
/// writers ([`OutputDir::lock_member`]); the locks are released when the value is dropped.
#[derive(Debug)]
pub struct SharedOutputDir {
    dir: PathBuf,
    member_lock_path: PathBuf,
    _member_lock: File,
    _dir_lock: File,
}

impl SharedOutputDir {
    /// The output directory: absolute, links resolved. Write this member's files here.
    pub fn path(&self) -> &Path {
        &self.dir
    }
}

impl Drop for SharedOutputDir {
    fn drop(&mut self) {
        // The member's own lock is removed while still held (as `OutputDir`'s); the shared
        // directory lock is left: other members may hold it.
        let _ = fs::remove_file(&self.member_lock_path);
    }
}

/// Removes the single-file temporaries in `dir` whose writing process is gone (one that
/// another cleaner removed first is not an error).
fn remove_dead_temporaries(dir: &Path) -> Result<(), OutputError> {
    if let Ok(entries) = fs::read_dir(dir) {
        for e in entries.flatten() {
            let f = e.file_name().to_string_lossy().into_owned();
            if temp_file_pid(&f).is_some_and(|pid| !is_alive(pid)) {
                let p = e.path();
                match fs::remove_file(&p) {
                    Err(err) if err.kind() != io::ErrorKind::NotFound => {
                        return Err(io_err(&p, "removing a leftover temporary")(err));
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(())
}

/// Checks `path` as an output directory and resolves it: the directory (absolute, its
/// parent's links resolved), its parent and its name; creates the parent if needed.
fn resolve_dir(path: &Path) -> Result<(PathBuf, PathBuf, String), OutputError> {
    let resolved = check_output(path, OutputKind::Directory)?;
    let unswappable = |why| OutputError::Unswappable {
        path: path.to_path_buf(),
        why,
    };
    let exists = resolved.exists();
    let dir = if exists {
        fs::canonicalize(&resolved).map_err(io_err(path, "resolving the output directory"))?
    } else {
        let name = match resolved.components().next_back() {
            Some(Component::Normal(n)) => n.to_owned(),
            _ => return Err(unswappable("does not name a directory")),
        };
        let parent = match resolved.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fs::create_dir_all(&parent).map_err(io_err(&parent, "creating the directory"))?;
        fs::canonicalize(&parent)
            .map_err(io_err(&parent, "resolving the directory"))?
            .join(name)
    };
    let (Some(parent), Some(name)) = (dir.parent(), dir.file_name()) else {
        return Err(unswappable("is the root directory"));
    };
    let parent = parent.to_path_buf();
    let name = name.to_string_lossy().into_owned();
    if exists {
        let dev = |p: &Path| fs::metadata(p).map(|m| m.dev());
        let d = dev(&dir).map_err(io_err(&dir, "inspecting"))?;
        let p = dev(&parent).map_err(io_err(&parent, "inspecting"))?;
        if d != p {
            return Err(unswappable("is a mount point"));
        }
        if let Ok(cwd) = std::env::current_dir().and_then(fs::canonicalize)
            && cwd.starts_with(&dir)
        {
            return Err(unswappable(
                "is the current directory or contains it (replacing it would leave the shell in a removed directory)",
            ));
        }
    }
    Ok((dir, parent, name))
}

impl OutputDir {
    /// The output directory: absolute, links resolved (for a link to a directory, the linked
    /// directory). Write single files (checkpoints, say) here.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// Removes an interrupted run's leftovers (we hold the lock, so no other set writer is
    /// using them): a staged or retired copy beside the directory (a retired copy is moved
    /// back first if the directory itself is missing, which only a kill between the two
    /// renames of the fallback leaves), and single-file temporaries of processes that are
    /// gone.
    fn clean_up(&self) -> Result<(), OutputError> {
        let prefix = sibling_prefix(&self.name);
        let mut staged = Vec::new();
        let mut retired = Vec::new();
        let entries = fs::read_dir(&self.parent).map_err(io_err(&self.parent, "listing"))?;
        for e in entries.flatten() {
            let f = e.file_name().to_string_lossy().into_owned();
            let Some(rest) = f.strip_prefix(&prefix) else {
                continue;
            };
            let pid = |s: &str| s.parse::<u32>().is_ok();
            if rest.strip_prefix("stage-").is_some_and(pid) {
                staged.push(e.path());
            } else if rest.strip_prefix("old-").is_some_and(pid) {
                retired.push(e.path());
            }
        }
        let exists = fs::symlink_metadata(&self.dir).is_ok();
        if !exists && let Some(old) = retired.pop() {
            fs::rename(&old, &self.dir).map_err(io_err(&old, "restoring the previous set"))?;
        }
        for p in staged.iter().chain(&retired) {
            fs::remove_dir_all(p).map_err(io_err(p, "removing an interrupted run's leftovers"))?;
        }
        remove_dead_temporaries(&self.dir)
    }

    /// Writes `files` (`(name, contents)`, names relative to the directory, `/`-separated
    /// subdirectories allowed) as the directory's new set, all or nothing: a reader of the
    /// directory sees the complete previous set or the complete new one, after a kill at any
    /// moment or a failure at any step.
    ///
    /// The new set is written into a staged sibling `.NAME.kincal-stage-PID` and flushed to
    /// disk; every entry of the directory that is not part of the new set (the user's own
    /// files, a checkpoint, `timing.json`, files of an earlier set this one does not
    /// rewrite) is carried into the staged directory as a hard link (the same file, not a
    /// copy; subdirectories are recreated with their entries linked); then the staged
    /// directory and the output directory are exchanged in one atomic rename, and the
    /// previous one is removed. The directory keeps its permission bits. Where the file
    /// system has no atomic exchange, two renames are used (see the crate documentation).
    ///
    /// The set is listed in the directory's manifest [`SET_MANIFEST`], written with it: the
    /// files of the previous set (the previous manifest's) that this set does not write are
    /// not carried over — a 6-DoF identify into a point run's directory leaves no stale
    /// `parameters.json` or plots beside its own — while files no manifest lists (the user's
    /// own, a checkpoint, a directory written before manifests) are kept.
    ///
    /// On error the directory holds its previous set and nothing staged is left. The bytes
    /// written are exactly `files`' contents, and the manifest.
    pub fn write_set<N: AsRef<str>, B: AsRef<[u8]>>(
        &self,
        files: &[(N, B)],
    ) -> Result<(), OutputError> {
        self.write_set_dropping(files, &[] as &[&str])
    }

    /// [`write_set`](Self::write_set), and entries named in `obsolete` (files or
    /// directories of an earlier set that the new set does not rewrite, e.g. plots no longer
    /// drawn) are not carried over: they disappear with the previous set.
    pub fn write_set_dropping<N: AsRef<str>, B: AsRef<[u8]>, O: AsRef<str>>(
        &self,
        files: &[(N, B)],
        obsolete: &[O],
    ) -> Result<(), OutputError> {
        let mut names = BTreeSet::new();
        for (n, _) in files {
            let rel = self.checked_name(n.as_ref())?;
            if !names.insert(rel) {
                return Err(self.bad_name(n.as_ref()));
            }
        }
        let mut skip = names.clone();
        for o in obsolete {
            skip.insert(self.checked_name(o.as_ref())?);
        }
        // The previous set's files that this one does not write go with it; the manifest is
        // rewritten.
        for old in previous_set(&self.dir) {
            if let Ok(rel) = self.checked_name(&old) {
                skip.insert(rel);
            }
        }
        let manifest_name = PathBuf::from(SET_MANIFEST);
        if names.contains(&manifest_name) {
            return Err(self.bad_name(SET_MANIFEST));
        }
        skip.insert(manifest_name);
        let manifest = manifest_text(&names);
        let mut files: Vec<(&str, &[u8])> = files
            .iter()
            .map(|(n, b)| (n.as_ref(), b.as_ref()))
            .collect();
        files.push((SET_MANIFEST, manifest.as_bytes()));
        let files = &files[..];
        let stage = sibling(
            &self.parent,
            &self.name,
            &format!("stage-{}", std::process::id()),
        );
        let staged = self.stage(&stage, files, &skip);
        let result = staged.and_then(|carried| self.swap(&stage, &carried));
        if result.is_err() {
            let _ = fs::remove_dir_all(&stage);
        }
        result
    }

    fn bad_name(&self, name: &str) -> OutputError {
        OutputError::BadName {
            path: self.dir.clone(),
            name: name.to_owned(),
        }
    }

    fn checked_name(&self, name: &str) -> Result<PathBuf, OutputError> {
        let p = Path::new(name);
        let plain = !name.is_empty()
            && p.components().all(|c| matches!(c, Component::Normal(_)))
            && !name.ends_with('/');
        if plain {
            Ok(p.components().collect())
        } else {
            Err(self.bad_name(name))
        }
    }

    /// Writes the staged directory; returns the top-level names of the output directory
    /// that were scanned (carried over or left out on purpose).
    fn stage<N: AsRef<str>, B: AsRef<[u8]>>(
        &self,
        stage: &Path,
        files: &[(N, B)],
        skip: &BTreeSet<PathBuf>,
    ) -> Result<BTreeSet<PathBuf>, OutputError> {
        if fs::symlink_metadata(stage).is_ok() {
            fs::remove_dir_all(stage).map_err(io_err(stage, "removing a stale staged set"))?;
        }
        fs::create_dir(stage).map_err(io_err(stage, "creating the staged set"))?;
        if let Ok(m) = fs::metadata(&self.dir) {
            fs::set_permissions(stage, m.permissions())
                .map_err(io_err(stage, "setting the permissions"))?;
        }
        let mut dirs = BTreeSet::new();
        for (name, bytes) in files {
            let target = stage.join(name.as_ref());
            let shown = self.dir.join(name.as_ref());
            if let Some(sub) = target.parent()
                && sub != stage
            {
                fs::create_dir_all(sub).map_err(io_err(&shown, "creating the directory of"))?;
                dirs.insert(sub.to_path_buf());
            }
            let mut f = OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&target)
                .map_err(io_err(&shown, "writing"))?;
            f.write_all(bytes.as_ref())
                .and_then(|()| f.sync_all())
                .and_then(|()| step("a file staged"))
                .map_err(io_err(&shown, "writing"))?;
        }
        let mut scanned = BTreeSet::new();
        if fs::symlink_metadata(&self.dir).is_ok() {
            carry(&self.dir, stage, Path::new(""), skip, &mut scanned)?;
        }
        step("carried").map_err(io_err(stage, "carrying files over"))?;
        for d in dirs.iter().rev().map(PathBuf::as_path).chain([stage]) {
            File::open(d)
                .and_then(|f| f.sync_all())
                .map_err(io_err(d, "flushing the staged set"))?;
        }
        step("staged set synced").map_err(io_err(stage, "flushing the staged set"))?;
        Ok(scanned)
    }

    /// Puts the staged directory in place of the output directory and removes the previous
    /// one.
    fn swap(&self, stage: &Path, scanned: &BTreeSet<PathBuf>) -> Result<(), OutputError> {
        let dir = &self.dir;
        // Steps after the new set is in place may abort (a kill) but not fail: the set is
        // written, and what is left is removed by the next run.
        let placed = |what| {
            let _ = step(what);
        };
        match fs::symlink_metadata(dir) {
            Err(_) => {
                fs::rename(stage, dir).map_err(io_err(dir, "moving the new set into place"))?;
                placed("renamed into place");
                sync_dir(&self.parent);
                return Ok(());
            }
            // Never swap away a link or a file that took the directory's place meanwhile.
            Ok(m) if !m.is_dir() => {
                return Err(OutputError::Target {
                    path: dir.clone(),
                    problem: TargetProblem::NotDirectory {
                        what: what(m.file_type()),
                    },
                });
            }
            Ok(_) => {}
        }
        let retired = match exchange(stage, dir) {
            Ok(()) => {
                placed("exchanged");
                stage.to_path_buf()
            }
            Err(e) if exchange_unsupported(&e) => {
                let old = sibling(
                    &self.parent,
                    &self.name,
                    &format!("old-{}", std::process::id()),
                );
                fs::rename(dir, &old).map_err(io_err(dir, "moving the previous set aside"))?;
                let moved = step("previous set moved aside").and_then(|()| fs::rename(stage, dir));
                if let Err(e) = moved {
                    if fs::symlink_metadata(dir).is_err() {
                        fs::rename(&old, dir).map_err(|source| OutputError::Io {
                            path: old.clone(),
                            action: "restoring the previous set after a failed rename (it is here)",
                            source,
                        })?;
                    }
                    return Err(io_err(dir, "moving the new set into place")(e));
                }
                placed("renamed into place");
                old
            }
            Err(e) => return Err(io_err(dir, "exchanging the new set")(e)),
        };
        sync_dir(&self.parent);
        // Entries that appeared in the previous directory after it was scanned (another
        // program's) are moved into the new one; then the previous set is removed. A failure
        // here leaves only leftovers, which the next run removes: the new set is in place.
        if let Ok(entries) = fs::read_dir(&retired) {
            for e in entries.flatten() {
                let name = PathBuf::from(e.file_name());
                let f = e.file_name().to_string_lossy().into_owned();
                let late = !scanned.contains(&name)
                    && temp_file_pid(&f).is_none()
                    && fs::symlink_metadata(dir.join(&name)).is_err();
                if late {
                    let _ = fs::rename(e.path(), dir.join(&name));
                }
            }
        }
        let _ = fs::remove_dir_all(&retired);
        placed("previous set removed");
        Ok(())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        // Removed while still locked; a process that opened it meanwhile sees that the path
        // no longer names the file it locked and opens it again (see `take_lock`).
        let _ = fs::remove_file(&self.lock_path);
    }
}

/// How a lock file is taken.
#[derive(Clone, Copy, PartialEq, Eq)]
enum LockMode {
    /// One holder, whose details are written into the file.
    Exclusive,
    /// Any number of holders (members); nothing is written.
    Shared,
}

/// Takes the advisory lock at `lock_path` (exclusive: and writes this process's details into
/// it).
fn take_lock(lock_path: &Path, shown: &Path, mode: LockMode) -> Result<File, OutputError> {
    for _ in 0..100 {
        let mut f = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(lock_path)
            .map_err(io_err(
                lock_path,
                "creating the lock file (an output directory is replaced as a whole, so the directory holding it must be writable)",
            ))?;
        let taken = match mode {
            LockMode::Exclusive => f.try_lock(),
            LockMode::Shared => f.try_lock_shared(),
        };
        match taken {
            Ok(()) => {}
            Err(fs::TryLockError::WouldBlock) => {
                return Err(OutputError::Locked {
                    path: shown.to_path_buf(),
                    lock: lock_path.to_path_buf(),
                    holder: read_holder(&mut f, lock_path),
                });
            }
            Err(fs::TryLockError::Error(e)) => {
                return Err(io_err(lock_path, "locking")(e));
            }
        }
        let ours = f.metadata().map_err(io_err(lock_path, "inspecting"))?;
        let named = fs::metadata(lock_path);
        if !named.is_ok_and(|m| m.ino() == ours.ino() && m.dev() == ours.dev()) {
            continue; // the previous holder removed it after we opened it
        }
        if mode == LockMode::Shared {
            return Ok(f);
        }
        let started = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let command: Vec<String> = std::env::args_os()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        let details = format!(
            "pid {}, started {}, command: {}\n",
            std::process::id(),
            utc(started),
            command.join(" ")
        );
        // Written over the start, then cut: the file never reads empty in between.
        f.write_all(details.as_bytes())
            .and_then(|()| f.set_len(details.len() as u64))
            .map_err(io_err(lock_path, "writing the lock file"))?;
        return Ok(f);
    }
    Err(io_err(lock_path, "locking")(io::Error::other(
        "the lock file kept being replaced",
    )))
}

/// The holder's details from a lock file held by another process. The holder writes them
/// just after taking the lock, so an empty file, or one naming a process that is gone (left
/// by a killed run), is read again for a moment.
///
/// An empty directory lock held shared is held by members ([`OutputDir::lock_member`]):
/// their details are in their own lock files `LOCK-MEMBER`, which are read instead.
fn read_holder(f: &mut File, lock_path: &Path) -> String {
    let mut text = String::new();
    for _ in 0..40 {
        text.clear();
        let read = io::Seek::rewind(f).and_then(|()| f.read_to_string(&mut text));
        let pid = text
            .strip_prefix("pid ")
            .and_then(|r| r.split(',').next())
            .and_then(|p| p.parse::<u32>().ok());
        if read.is_ok() && pid.is_some_and(is_alive) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    match text.trim() {
        "" => member_holders(lock_path)
            .unwrap_or_else(|| "a process that has not written its details yet".to_owned()),
        t => t.to_owned(),
    }
}

/// The details of the members holding the directory lock `lock_path`, read from their lock
/// files `LOCK-MEMBER` beside it; `None` when there are none.
fn member_holders(lock_path: &Path) -> Option<String> {
    let parent = lock_path.parent()?;
    let prefix = format!("{}-", lock_path.file_name()?.to_string_lossy());
    let mut members: Vec<(String, String)> = fs::read_dir(parent)
        .ok()?
        .flatten()
        .filter_map(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            let member = n.strip_prefix(&prefix)?.to_owned();
            let text = fs::read_to_string(e.path()).ok()?;
            (!text.trim().is_empty()).then(|| (member, text.trim().to_owned()))
        })
        .collect();
    members.sort();
    (!members.is_empty()).then(|| {
        members
            .iter()
            .map(|(m, t)| format!("{m}: {t}"))
            .collect::<Vec<_>>()
            .join("; ")
    })
}

/// Carries every entry of `from` (the output directory at `rel`) into `to` (the staged one
/// at `rel`), except the set's own paths (`skip`) and single-file temporaries: hard links
/// for files, links and special files, recreated directories for directories. Records the
/// top-level names seen.
fn carry(
    from: &Path,
    to: &Path,
    rel: &Path,
    skip: &BTreeSet<PathBuf>,
    scanned: &mut BTreeSet<PathBuf>,
) -> Result<(), OutputError> {
    let entries = fs::read_dir(from).map_err(io_err(from, "listing"))?;
    for e in entries {
        let e = e.map_err(io_err(from, "listing"))?;
        let name = e.file_name();
        let r = rel.join(&name);
        if rel.as_os_str().is_empty() {
            scanned.insert(r.clone());
        }
        if skip.contains(&r) || temp_file_pid(&name.to_string_lossy()).is_some() {
            continue;
        }
        let src = e.path();
        let dst = to.join(&name);
        let ft = e.file_type().map_err(io_err(&src, "inspecting"))?;
        // A directory that also holds files of the set is merged; others are carried whole.
        if ft.is_dir() {
            let dev = |p: &Path| fs::metadata(p).map(|m| m.dev());
            if dev(&src).map_err(io_err(&src, "inspecting"))?
                != dev(from).map_err(io_err(from, "inspecting"))?
            {
                return Err(OutputError::Unswappable {
                    path: src,
                    why: "is a mount point inside the output directory",
                });
            }
            let created = fs::symlink_metadata(&dst).is_err();
            if created {
                fs::create_dir(&dst).map_err(io_err(&dst, "creating"))?;
                let perm = fs::metadata(&src).map_err(io_err(&src, "inspecting"))?;
                fs::set_permissions(&dst, perm.permissions())
                    .map_err(io_err(&dst, "setting the permissions"))?;
            } else if !fs::symlink_metadata(&dst).is_ok_and(|m| m.is_dir()) {
                continue; // the set writes a file where a directory was
            }
            carry(&src, &dst, &r, skip, scanned)?;
            // A directory that held only files of the previous set goes with them.
            let empty = |d: &Path| fs::read_dir(d).is_ok_and(|mut i| i.next().is_none());
            if created && empty(&dst) && !empty(&src) {
                fs::remove_dir(&dst).map_err(io_err(&dst, "removing"))?;
            }
        } else if fs::symlink_metadata(&dst).is_ok() {
            continue; // the set writes a directory where this file was
        } else {
            fs::hard_link(&src, &dst)
                .or_else(|e| copy_instead(&src, &dst, ft, e))
                .map_err(io_err(&src, "carrying into the new set"))?;
        }
    }
    Ok(())
}

/// Where a hard link cannot be made (a file system without them, or a file of another user
/// under `protected_hardlinks`): a copy of a regular file, a new link with the same contents.
fn copy_instead(src: &Path, dst: &Path, ft: fs::FileType, e: io::Error) -> io::Result<()> {
    if ft.is_file() {
        fs::copy(src, dst).map(|_| ())
    } else if ft.is_symlink() {
        std::os::unix::fs::symlink(fs::read_link(src)?, dst)
    } else {
        Err(e)
    }
}

fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Exchanges two directories atomically (Linux `renameat2(RENAME_EXCHANGE)`).
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> io::Result<()> {
    if std::env::var_os(NO_EXCHANGE_ENV).is_some() {
        return Err(io::Error::from(io::ErrorKind::Unsupported));
    }
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).map_err(io::Error::from)
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> io::Result<()> {
    Err(io::Error::from(io::ErrorKind::Unsupported))
}

/// Whether an exchange failed because the file system (or kernel) has none.
fn exchange_unsupported(e: &io::Error) -> bool {
    e.kind() == io::ErrorKind::Unsupported
        || matches!(
            e.raw_os_error(),
            Some(code) if [22, 38, 95].contains(&code) // EINVAL, ENOSYS, EOPNOTSUPP
        )
}

/// Whether `a` and `b` name the same existing file: the same device and inode, whatever the
/// spelling (symbolic links, hard links, `..`, a relative or absolute path). A path that
/// does not exist (yet) is no file, so `false`; so is one that cannot be inspected.
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_795_000_000), "2026-11-18 11:06:40 UTC");
    }

    #[test]
    fn temporaries_are_recognised() {
        assert_eq!(temp_file_pid(".summary.json.123.4.tmp"), Some(123));
        assert_eq!(temp_file_pid(".a.1.0.tmp"), Some(1));
        assert_eq!(temp_file_pid("summary.json.123.4.tmp"), None);
        assert_eq!(temp_file_pid(".summary.json.tmp"), None);
        assert_eq!(temp_file_pid(".x.12a.4.tmp"), None);
        assert_eq!(temp_file_pid("..1.2.tmp"), None);
    }
}
