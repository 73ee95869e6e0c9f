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
