//! Shared by the command-line tests: the workspace root and running the built `kincal`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root (commands run there).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the workspace root")
}

/// Runs the built `kincal` with `args` in the workspace root.
#[allow(dead_code)] // not every test binary runs commands this way
pub fn kincal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kincal"))
        .args(args)
        .current_dir(root())
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run kincal")
}

/// A path as the `&str` a command line takes.
#[allow(dead_code)] // not every test binary uses it
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A command's stderr as text.
#[allow(dead_code)] // not every test binary uses it
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The files of an output directory (name → bytes), hidden ones left out.
#[allow(dead_code)] // not every test binary uses it
pub fn dir_set(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .map(|n| {
            let b = std::fs::read(dir.join(&n)).unwrap();
            (n, b)
        })
        .collect()
}

/// The stdout of a command that must have succeeded (else stdout and stderr in the panic).
#[allow(dead_code)] // not every test binary uses it
pub fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "command failed\nstdout:\n{stdout}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The KR1000 Titan's robot file.
#[allow(dead_code)] // not every test binary uses it
pub fn kr1000() -> &'static Path {
    static P: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    P.get_or_init(|| root().join("scenarios/robots/kr1000-titan.json"))
}

/// One simulation of the noise-floor scenario (KR1000, 50 + 50 poses in the base frame),
/// made once and shared, read only, by the tests of this binary.
#[allow(dead_code)] // not every test binary uses it
pub fn sim() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("kincal-cli-sim");
        let _ = std::fs::remove_dir_all(&dir);
        ok(&kincal(&[
            "simulate",
            "scenarios/noise-floor.json",
            "--out",
            s(&dir),
        ]));
        dir
    })
}
