//! Shared by the command-line tests: the workspace root and running the built `xtask`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root (commands run there, as `cargo xtask` does).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs the built `xtask` with `args` in the workspace root.
#[allow(dead_code)] // not every test binary runs commands this way
pub fn xtask(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(root())
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run xtask")
}
