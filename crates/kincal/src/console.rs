//! Every line the front end prints goes through here, so that a failing standard stream
//! ends the command cleanly instead of panicking ("failed printing to stdout: No space left
//! on device" from `print!`, exit status 101 and a backtrace hint).
//!
//! - **Standard output** carries results (a summary, a table, a plan): a write that fails
//!   ends the command at once with status 1 and `error: writing to standard output: …` on
//!   standard error (where that still works). Output files are written whole before any
//!   summary is printed, so they are complete.
//! - **Standard error** carries notes and progress: a write that fails is remembered and the
//!   work goes on (a full disk under a log must not stop a campaign half-way); the command
//!   then ends with status 1 ([`exit_on_error`](crate::exit_on_error)), since what it had to
//!   say was lost.
//!
//! A closed pipe is not an error: `main` restores SIGPIPE's default action, so `kincal … |
//! head -1` ends quietly (status 141), as `cat` does.

use std::fmt;
use std::io::Write as _;
use std::sync::atomic::{AtomicBool, Ordering};

static STDERR_FAILED: AtomicBool = AtomicBool::new(false);

/// Writes to standard output and flushes; on failure ends the process (status 1).
pub fn out(args: fmt::Arguments<'_>) {
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        let _ = writeln!(std::io::stderr(), "error: writing to standard output: {e}");
        std::process::exit(1);
    }
}

/// Writes to standard error; a failure is remembered ([`stderr_failed`]), not raised.
pub fn err(args: fmt::Arguments<'_>) {
    let mut stderr = std::io::stderr().lock();
    if stderr
        .write_fmt(args)
        .and_then(|()| stderr.flush())
        .is_err()
    {
        STDERR_FAILED.store(true, Ordering::Relaxed);
    }
}

/// Whether a write to standard error failed during this process.
pub fn stderr_failed() -> bool {
    STDERR_FAILED.load(Ordering::Relaxed)
}

/// `print!` through [`out`].
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::console::out(format_args!($($arg)*)) };
}

/// `println!` through [`out`].
#[macro_export]
macro_rules! outln {
    () => { $crate::console::out(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::console::out(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `eprint!` through [`err`].
#[macro_export]
macro_rules! errout {
    ($($arg:tt)*) => { $crate::console::err(format_args!($($arg)*)) };
}

/// `eprintln!` through [`err`].
#[macro_export]
macro_rules! errln {
    () => { $crate::console::err(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::console::err(format_args!("{}\n", format_args!($($arg)*))) };
}
