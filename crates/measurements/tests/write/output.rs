//! Output targets and output sets written as a whole, with real processes: this test binary
//! runs itself as the writing child (`child_process`), which the tests kill at every step
//! (through the test-only fault injection, `measurements::FAULT_ENV`), make fail at every
//! step, and run twice at once.

use std::fs;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus};

use measurements::{
    FAULT_ENV, NO_EXCHANGE_ENV, OutputDir, OutputError, OutputKind, TargetProblem, check_output,
    write_all_atomically, write_atomically,
};

const CHILD_DIR: &str = "MEASUREMENTS_TEST_CHILD_DIR";
const CHILD_SET: &str = "MEASUREMENTS_TEST_CHILD_SET";
const CHILD_HOLD_MS: &str = "MEASUREMENTS_TEST_CHILD_HOLD_MS";
/// Exit codes of the child: written, refused by the lock, any other error.
const WRITTEN: i32 = 0;
const LOCKED: i32 = 3;
const FAILED: i32 = 4;

/// The set a child writes, labelled: three files, one in a subdirectory.
fn set(label: &str) -> Vec<(String, String)> {
    ["a.txt", "b.json", "plots/c.svg"]
        .iter()
        .map(|n| (n.to_string(), format!("{label} {n}\n")))
        .collect()
}

/// Not a test: the writing child. Does nothing unless started by a test with `CHILD_DIR` set.
#[test]
fn child_process() {
    let Some(dir) = std::env::var_os(CHILD_DIR) else {
        return;
    };
    let label = std::env::var(CHILD_SET).unwrap();
    let hold: u64 = std::env::var(CHILD_HOLD_MS).map_or(0, |s| s.parse().unwrap());
    let out = match OutputDir::lock(Path::new(&dir)) {
        Ok(out) => out,
        Err(e @ OutputError::Locked { .. }) => {
            eprintln!("{e}");
            std::process::exit(LOCKED);
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(FAILED);
        }
    };
    std::thread::sleep(std::time::Duration::from_millis(hold));
    match out.write_set(&set(&label)) {
        Ok(()) => {
            drop(out);
            std::process::exit(WRITTEN)
        }
        Err(e) => {
            eprintln!("{e}");
            drop(out);
            std::process::exit(FAILED);
        }
    }
}

fn child(dir: &Path, label: &str, env: &[(&str, &str)]) -> Command {
    // The test's own name in this binary: its module path without the crate's name.
    let module = module_path!().split_once("::").map_or("", |(_, m)| m);
    let mut c = Command::new(std::env::current_exe().unwrap());
    c.args([
        &format!("{module}::child_process"),
        "--exact",
        "--nocapture",
        "--quiet",
    ])
    .env(CHILD_DIR, dir)
    .env(CHILD_SET, label)
    .env_remove(FAULT_ENV)
    .env_remove(NO_EXCHANGE_ENV)
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::piped());
    for (k, v) in env {
        c.env(k, v);
    }
    c
}

fn run_child(dir: &Path, label: &str, env: &[(&str, &str)]) -> (ExitStatus, String) {
    let out = child(dir, label, env).output().unwrap();
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A fresh scratch root for one test.
fn scratch(name: &str) -> PathBuf {
    let dir =
        PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("measurements-output-{name}"));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// The entries of `dir`, leftovers included, less the set's manifest
/// ([`measurements::SET_MANIFEST`], which every set writes).
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != measurements::SET_MANIFEST)
        .collect();
    v.sort();
    v
}

/// The label of the complete set in `dir`; panics on a mixed or partial set.
fn set_label(dir: &Path) -> String {
    let labels: Vec<String> = set("x")
        .iter()
        .map(|(n, _)| {
            let text = fs::read_to_string(dir.join(n))
                .unwrap_or_else(|e| panic!("{}: {e}", dir.join(n).display()));
            text.split(' ').next().unwrap().to_owned()
        })
        .collect();
    assert!(
        labels.iter().all(|l| *l == labels[0]),
        "mixed set in {}: {labels:?}",
        dir.display()
    );
    labels[0].clone()
}

/// An output directory holding the set `old` and the user's own files.
fn prepared(root: &Path) -> PathBuf {
    let out = root.join("out");
    fs::create_dir_all(out.join("plots")).unwrap();
    fs::create_dir_all(out.join("notes")).unwrap();
    for (n, text) in set("old") {
        fs::write(out.join(n), text).unwrap();
    }
    fs::write(out.join("mine.txt"), "the user's\n").unwrap();
    fs::write(out.join("notes/x.txt"), "notes\n").unwrap();
    fs::write(out.join("plots/extra.svg"), "kept\n").unwrap();
    out
}

fn assert_foreign_intact(out: &Path) {
    assert_eq!(
        fs::read_to_string(out.join("mine.txt")).unwrap(),
        "the user's\n"
    );
    assert_eq!(
        fs::read_to_string(out.join("notes/x.txt")).unwrap(),
        "notes\n"
    );
    assert_eq!(
        fs::read_to_string(out.join("plots/extra.svg")).unwrap(),
        "kept\n"
    );
}

/// After a clean run: the parent holds only the directory, the directory no temporaries.
fn assert_no_leftovers(root: &Path, out: &Path) {
    assert_eq!(
        names(root),
        ["out"],
        "leftovers beside the output directory"
    );
    assert!(
        names(out)
            .iter()
            .all(|n| !n.ends_with(".tmp") && !n.contains("kincal")),
        "leftovers in the output directory: {:?}",
        names(out)
    );
}

/// A kill (abort) after every step of the set write, with the atomic exchange and with the
/// two-rename fallback: afterwards the directory holds the complete old or the complete new
/// set with the user's files, and the next run cleans up and writes its own set.
#[test]
fn a_kill_at_every_step_leaves_the_old_or_the_new_set() {
    for fallback in [false, true] {
        let root = scratch(if fallback { "kill-fallback" } else { "kill" });
        let mut seen = Vec::new();
        for n in 1.. {
            let _ = fs::remove_dir_all(root.join("out"));
            let out = prepared(&root);
            let fault = format!("abort@{n}");
            let mut env = vec![(FAULT_ENV, fault.as_str())];
            if fallback {
                env.push((NO_EXCHANGE_ENV, "1"));
            }
            let (status, stderr) = run_child(&out, "new", &env);
            if status.success() {
                assert!(n > 6, "only {n} steps");
                break;
            }
            assert_eq!(status.code(), None, "step {n}: {status} {stderr}");
            let label = if fallback && !out.exists() {
                // Killed between the fallback's two renames: no directory, and the complete
                // old set beside it, which the next run moves back.
                let retired: Vec<String> = names(&root)
                    .into_iter()
                    .filter(|n| n.starts_with(".out.kincal-old-"))
                    .collect();
                assert_eq!(retired.len(), 1, "step {n}: {:?}", names(&root));
                let old = root.join(&retired[0]);
                assert_eq!(set_label(&old), "old");
                assert_foreign_intact(&old);
                // The next lock moves it back.
                drop(OutputDir::lock(&out).unwrap());
                assert_eq!(set_label(&out), "old");
                "none (old beside)".to_owned()
            } else {
                set_label(&out)
            };
            assert_foreign_intact(&out);
            seen.push(label);
            // The next run removes the leftovers and writes its set.
            let (status, stderr) = run_child(&out, "next", &[]);
            assert!(status.success(), "step {n}: {stderr}");
            assert_eq!(set_label(&out), "next");
            assert_foreign_intact(&out);
            assert_no_leftovers(&root, &out);
        }
        assert!(
            seen.contains(&"old".to_owned()) && seen.contains(&"new".to_owned()),
            "{seen:?}"
        );
        eprintln!("fallback {fallback}: after each step {seen:?}");
    }
}

/// SIGKILL at moments spread over a set write (with the exchange): the directory always
/// holds a complete set, and the next run cleans up.
#[test]
fn a_sigkill_at_any_moment_leaves_a_complete_set() {
    let root = scratch("sigkill");
    let mut seen = Vec::new();
    for i in 0..12u64 {
        let _ = fs::remove_dir_all(root.join("out"));
        let out = prepared(&root);
        let mut c = child(&out, "new", &[]).spawn().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(i * 3));
        let _ = c.kill();
        c.wait().unwrap();
        seen.push(set_label(&out));
        assert_foreign_intact(&out);
        let (status, stderr) = run_child(&out, "next", &[]);
        assert!(status.success(), "{stderr}");
        assert_eq!(set_label(&out), "next");
        assert_no_leftovers(&root, &out);
    }
    eprintln!("SIGKILL after 0, 3, … 33 ms: {seen:?}");
}

/// A failure at every step: the write reports it and the directory holds the complete old
/// set (or, for a failure after the new set is in place, which is not an error, the new one).
#[test]
fn a_failure_at_every_step_leaves_the_old_set() {
    for fallback in [false, true] {
        let root = scratch(if fallback { "fail-fallback" } else { "fail" });
        for n in 1..=12 {
            let _ = fs::remove_dir_all(root.join("out"));
            let out = prepared(&root);
            let fault = format!("fail@{n}");
            let mut env = vec![(FAULT_ENV, fault.as_str())];
            if fallback {
                env.push((NO_EXCHANGE_ENV, "1"));
            }
            let (status, stderr) = run_child(&out, "new", &env);
            match status.code() {
                Some(FAILED) => {
                    assert!(stderr.contains("injected failure"), "{stderr}");
                    assert_eq!(set_label(&out), "old", "step {n}");
                }
                Some(WRITTEN) => assert_eq!(set_label(&out), "new", "step {n}"),
                _ => panic!("step {n}: {status} {stderr}"),
            }
            assert_foreign_intact(&out);
            assert_no_leftovers(&root, &out);
        }
    }
}

/// Two processes writing different sets into one directory at once: never a mixed set,
/// never two successes that overlapped; the second is refused naming the holder.
/// `MEASUREMENTS_CONCURRENT_RUNS=200` runs it 200 times and prints the counts.
#[test]
fn concurrent_writers_are_excluded() {
    let runs: usize =
        std::env::var("MEASUREMENTS_CONCURRENT_RUNS").map_or(4, |s| s.parse().unwrap());
    let root = scratch("concurrent");
    let out = prepared(&root);
    let (mut one_refused, mut both_wrote) = (0, 0);
    for i in 0..runs {
        let hold = if i % 2 == 0 { "0" } else { "20" };
        let env = [(CHILD_HOLD_MS, hold)];
        let a = child(&out, "A", &env).spawn().unwrap();
        // Staggered starts: B also arrives while A stages, exchanges, or releases the lock.
        std::thread::sleep(std::time::Duration::from_millis((i % 5) as u64 * 10));
        let b = child(&out, "B", &env).spawn().unwrap();
        let a = a.wait_with_output().unwrap();
        let b = b.wait_with_output().unwrap();
        let label = set_label(&out);
        assert_foreign_intact(&out);
        let code = |o: &std::process::Output| o.status.code().unwrap();
        match (code(&a), code(&b)) {
            (WRITTEN, WRITTEN) => {
                both_wrote += 1; // one after the other: the lock was free each time
                assert!(label == "A" || label == "B");
            }
            (WRITTEN, LOCKED) | (LOCKED, WRITTEN) => {
                one_refused += 1;
                let (winner, loser) = if code(&a) == WRITTEN {
                    ("A", &b)
                } else {
                    ("B", &a)
                };
                assert_eq!(label, winner, "run {i}: the refused run's set is in place");
                let msg = String::from_utf8_lossy(&loser.stderr);
                assert!(
                    msg.contains("another run is writing this output directory (pid ")
                        && msg.contains("command: "),
                    "{msg}"
                );
            }
            other => panic!(
                "run {i}: exit codes {other:?}: {} {}",
                String::from_utf8_lossy(&a.stderr),
                String::from_utf8_lossy(&b.stderr)
            ),
        }
        assert_no_leftovers(&root, &out);
    }
    eprintln!(
        "{runs} concurrent pairs: {one_refused} with the second refused, {both_wrote} one after the other, 0 mixed sets, 0 silent losses"
    );
}

/// The lock names its holder; it is released (and its file removed) on drop.
#[test]
fn the_lock_names_its_holder() {
    let root = scratch("lock");
    let out = root.join("new-out");
    let held = OutputDir::lock(&out).unwrap();
    assert_eq!(
        held.path(),
        fs::canonicalize(&root).unwrap().join("new-out")
    );
    let e = OutputDir::lock(&out).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, OutputError::Locked { .. }), "{msg}");
    assert!(
        msg.starts_with(&format!("{}: another run is writing", out.display()))
            && msg.contains(&format!("pid {}, started 20", std::process::id()))
            && msg.contains(" UTC, command: ")
            && msg.contains(".new-out.kincal-lock"),
        "{msg}"
    );
    drop(held);
    assert!(names(&root).is_empty(), "{:?}", names(&root));
    let again = OutputDir::lock(&out).unwrap();
    again.write_set(&set("first")).unwrap();
    assert_eq!(set_label(&out), "first");
    drop(again);
    assert_eq!(names(&root), ["new-out"]);
}

/// Foreign files are carried over (the same files, as hard links), obsolete ones dropped,
/// an interrupted run's leftovers removed, the directory's permissions kept.
/// The shards of a campaign write side by side: members of different names hold one
/// directory at once; a second run of one member is refused naming the first; a whole-set
/// writer and the members exclude each other, each naming the other.
#[test]
fn members_share_the_directory_and_exclude_whole_set_writers() {
    let root = scratch("members");
    let out = root.join("shards");
    let a = OutputDir::lock_member(&out, "shard-0-of-2").unwrap();
    let b = OutputDir::lock_member(&out, "shard-1-of-2").unwrap();
    assert_eq!(a.path(), b.path());
    let e = OutputDir::lock_member(&out, "shard-0-of-2").unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(e, OutputError::Locked { .. })
            && msg.contains(".shards.kincal-lock-shard-0-of-2")
            && msg.contains(&format!("pid {}, started 20", std::process::id())),
        "{msg}"
    );
    let e = OutputDir::lock(&out).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(e, OutputError::Locked { .. })
            && msg.contains("shard-0-of-2: pid ")
            && msg.contains("shard-1-of-2: pid "),
        "{msg}"
    );
    drop(a);
    assert!(OutputDir::lock(&out).is_err(), "member 1 still holds it");
    drop(b);
    let whole = OutputDir::lock(&out).unwrap();
    let e = OutputDir::lock_member(&out, "shard-0-of-2").unwrap_err();
    assert!(
        e.to_string()
            .contains(&format!("(pid {}, started 20", std::process::id())),
        "{e}"
    );
    drop(whole);
    let again = OutputDir::lock_member(&out, "shard-0-of-2").unwrap();
    drop(again);
    let left: Vec<String> = names(&root)
        .into_iter()
        .filter(|n| n != ".shards.kincal-lock")
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn foreign_files_survive_and_leftovers_go() {
    let root = scratch("foreign");
    let out = prepared(&root);
    fs::set_permissions(&out, fs::Permissions::from_mode(0o750)).unwrap();
    let ino = fs::metadata(out.join("mine.txt")).unwrap().ino();
    // Leftovers of a killed run: a staged set, a retired set, a dead process's temporary.
    fs::create_dir(root.join(".out.kincal-stage-999999999")).unwrap();
    fs::create_dir(root.join(".out.kincal-old-999999998")).unwrap();
    fs::write(out.join(".summary.json.999999999.3.tmp"), "partial").unwrap();
    // A live single-file writer's temporary (our own pid) is not touched.
    let live = format!(".ckpt.json.{}.0.tmp", std::process::id());
    fs::write(out.join(&live), "in flight").unwrap();
    let held = OutputDir::lock(&out).unwrap();
    assert!(!root.join(".out.kincal-stage-999999999").exists());
    assert!(!root.join(".out.kincal-old-999999998").exists());
    assert!(!out.join(".summary.json.999999999.3.tmp").exists());
    assert!(out.join(&live).exists());
    fs::remove_file(out.join(&live)).unwrap();
    // A checkpoint written while the lock is held survives the set write.
    write_atomically(&held.path().join("checkpoint.json"), b"{}\n").unwrap();
    held.write_set(&set("new")).unwrap();
    assert_eq!(set_label(&out), "new");
    assert_foreign_intact(&out);
    assert_eq!(fs::read(out.join("checkpoint.json")).unwrap(), b"{}\n");
    assert_eq!(fs::metadata(out.join("mine.txt")).unwrap().ino(), ino);
    assert_eq!(
        fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o750
    );
    // A set without the plots, dropping them.
    let smaller: Vec<(String, String)> = set("small").into_iter().take(2).collect();
    held.write_set_dropping(&smaller, &["plots"]).unwrap();
    assert!(!out.join("plots").exists());
    assert_eq!(
        fs::read_to_string(out.join("a.txt")).unwrap(),
        "small a.txt\n"
    );
    assert_eq!(
        fs::read_to_string(out.join("mine.txt")).unwrap(),
        "the user's\n"
    );
    drop(held);
    assert_no_leftovers(&root, &out);
}

#[test]
fn bad_set_names_are_refused_before_anything_is_written() {
    let root = scratch("names");
    let out = prepared(&root);
    let held = OutputDir::lock(&out).unwrap();
    for bad in ["", "../x", "/abs", "a/../b", "./a", "dir/"] {
        let e = held.write_set(&[(bad, "x")]).unwrap_err();
        assert!(matches!(e, OutputError::BadName { .. }), "{bad}: {e}");
    }
    let e = held
        .write_set(&[("a.txt", "1"), ("a.txt", "2")])
        .unwrap_err();
    assert!(e.to_string().contains("given twice"), "{e}");
    assert_eq!(set_label(&out), "old");
    drop(held);
    assert_no_leftovers(&root, &out);
}

/// The current directory (or one containing it) and the root cannot be replaced as a whole:
/// refused before anything is written.
#[test]
fn the_current_directory_and_the_root_are_refused() {
    let root = scratch("cwd");
    let out = prepared(&root);
    for (dir, cwd) in [
        (".", out.clone()),
        ("..", out.join("notes")),
        ("out", root.clone()),
    ] {
        let mut c = child(Path::new(dir), "new", &[]);
        c.current_dir(&cwd);
        let o = c.output().unwrap();
        let msg = String::from_utf8_lossy(&o.stderr);
        if dir == "out" {
            assert!(o.status.success(), "{msg}");
            continue;
        }
        assert_eq!(o.status.code(), Some(FAILED), "{msg}");
        assert!(
            msg.contains("is the current directory or contains it") && msg.starts_with(dir),
            "{msg}"
        );
    }
    assert_eq!(set_label(&out), "new");
    assert_foreign_intact(&out);
    assert_no_leftovers(&root, &out);
    let e = OutputDir::lock(Path::new("/")).unwrap_err();
    assert!(e.to_string().starts_with("/: is the root directory"), "{e}");
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

/// FIFOs, devices and sockets are refused as output targets, up front and at write time,
/// and left untouched.
#[test]
fn special_files_are_refused() {
    let root = scratch("special");
    let fifo = root.join("fifo");
    mkfifo(&fifo);
    let sock = root.join("sock");
    let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
    for (path, what) in [
        (fifo.as_path(), "a FIFO (named pipe)"),
        (sock.as_path(), "a socket"),
        (Path::new("/dev/null"), "a character device"),
    ] {
        for kind in [OutputKind::File, OutputKind::Directory] {
            let e = check_output(path, kind).unwrap_err();
            assert!(
                matches!(&e, OutputError::Target { problem: TargetProblem::Special { what: w }, .. } if *w == what),
                "{e:?}"
            );
            assert_eq!(
                e.to_string(),
                format!(
                    "{}: is {what}, not a regular file or a directory: kincal never writes into nor replaces one",
                    path.display()
                )
            );
        }
    }
    // The writers refuse too (never tried on /dev/null: a bug would replace it as root).
    for path in [&fifo, &sock] {
        let e = write_atomically(path, b"x").unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(
            e.to_string()
                .starts_with(&format!("writing {}: is a ", path.display())),
            "{e}"
        );
        let e = write_all_atomically(&root, &[(path.file_name().unwrap().to_str().unwrap(), "x")])
            .unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{e}");
    }
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert!(fs::symlink_metadata(&sock).unwrap().file_type().is_socket());
    let e = OutputDir::lock(&fifo).unwrap_err();
    assert!(matches!(e, OutputError::Target { .. }), "{e}");
    // A directory where a file is expected, and the reverse.
    let e = check_output(&root, OutputKind::File).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("is a directory, but a file is expected"),
        "{e}"
    );
    fs::write(root.join("file"), "f").unwrap();
    let e = OutputDir::lock(&root.join("file")).unwrap_err();
    assert!(
        e.to_string()
            .contains("is a regular file, but an output directory is expected"),
        "{e}"
    );
    assert_eq!(names(&root), ["fifo", "file", "sock"]);
}

/// A link to a regular file: its target is replaced atomically, the link stays. Dangling
/// links and links to special files or directories are refused and left alone.
#[test]
fn file_links_are_followed_or_refused() {
    use std::os::unix::fs::symlink;
    let root = scratch("file-links");
    fs::create_dir(root.join("real")).unwrap();
    fs::write(root.join("real/data.csv"), "old").unwrap();
    let link = root.join("link.csv");
    symlink("real/data.csv", &link).unwrap();
    assert_eq!(
        check_output(&link, OutputKind::File).unwrap(),
        fs::canonicalize(root.join("real/data.csv")).unwrap()
    );
    write_atomically(&link, b"new").unwrap();
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(fs::read_link(&link).unwrap(), Path::new("real/data.csv"));
    assert_eq!(fs::read(root.join("real/data.csv")).unwrap(), b"new");
    assert_eq!(names(&root.join("real")), ["data.csv"]);
    write_all_atomically(&root, &[("link.csv", "newer")]).unwrap();
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(fs::read(root.join("real/data.csv")).unwrap(), b"newer");

    let dangling = root.join("dangling.csv");
    symlink("nowhere.csv", &dangling).unwrap();
    let fifo = root.join("fifo");
    mkfifo(&fifo);
    let to_fifo = root.join("to-fifo");
    symlink("fifo", &to_fifo).unwrap();
    let to_dir = root.join("to-dir");
    symlink("real", &to_dir).unwrap();
    for (path, says) in [
        (
            &dangling,
            "is a symbolic link to nowhere.csv, which does not exist",
        ),
        (
            &to_fifo,
            "is a symbolic link to fifo, which is a FIFO (named pipe)",
        ),
        (&to_dir, "is a symbolic link to real, which is a directory"),
    ] {
        let e = check_output(path, OutputKind::File).unwrap_err();
        assert!(
            e.to_string()
                .starts_with(&format!("{}: {says}", path.display())),
            "{e}"
        );
        let e = write_atomically(path, b"x").unwrap_err();
        assert!(e.to_string().contains(says), "{e}");
        assert!(fs::symlink_metadata(path).unwrap().file_type().is_symlink());
    }
    assert!(!root.join("nowhere.csv").exists());
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
}

/// A link to a directory as the output directory: the set goes into the linked directory,
/// the link stays a link. A dangling directory link is refused.
#[test]
fn directory_links_are_followed() {
    use std::os::unix::fs::symlink;
    let root = scratch("dir-links");
    let real = prepared(&root);
    let link = root.join("out-link");
    symlink("out", &link).unwrap();
    let held = OutputDir::lock(&link).unwrap();
    assert_eq!(held.path(), fs::canonicalize(&real).unwrap());
    held.write_set(&set("new")).unwrap();
    drop(held);
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(set_label(&link), "new");
    assert_foreign_intact(&real);
    assert_eq!(names(&root), ["out", "out-link"]);
    symlink("gone", root.join("dangling")).unwrap();
    let e = OutputDir::lock(&root.join("dangling")).unwrap_err();
    assert!(e.to_string().contains("which does not exist"), "{e}");
}

/// Issue 39, item 3: an output set is replaced whole. The manifest lists the set; the next
/// set removes the previous set's files it does not write itself (stale plots, a point run's
/// `parameters.json` under a 6-DoF run's set) and keeps the user's own files; a directory
/// written before manifests keeps every file.
#[test]
fn a_new_set_removes_the_previous_sets_other_files_and_keeps_the_users() {
    let dir = scratch("manifest");
    let out = dir.join("out");
    let write = |files: &[(&str, &str)]| OutputDir::lock(&out).unwrap().write_set(files).unwrap();
    write(&[("a.txt", "1"), ("old.svg", "1"), ("plots/p.svg", "1")]);
    let manifest = fs::read_to_string(out.join(measurements::SET_MANIFEST)).unwrap();
    assert!(
        manifest.ends_with("a.txt\nold.svg\nplots/p.svg\n"),
        "{manifest}"
    );
    fs::write(out.join("mine.txt"), "the user's").unwrap();
    write(&[("a.txt", "2"), ("new.svg", "2")]);
    assert_eq!(names(&out), ["a.txt", "mine.txt", "new.svg"]);
    assert_eq!(fs::read_to_string(out.join("a.txt")).unwrap(), "2");
    // Before manifests: nothing is known to be a set's, so nothing is removed.
    fs::remove_file(out.join(measurements::SET_MANIFEST)).unwrap();
    write(&[("b.txt", "3")]);
    assert_eq!(names(&out), ["a.txt", "b.txt", "mine.txt", "new.svg"]);
    // A set may not name the manifest.
    let e = OutputDir::lock(&out)
        .unwrap()
        .write_set(&[(measurements::SET_MANIFEST, "x")])
        .unwrap_err();
    assert!(matches!(e, OutputError::BadName { .. }), "{e}");
}
