//! `kincal`: kinematic calibration of industrial robots from the command line.

use clap::Parser;

/// The allocator of the binary: mimalloc, not the system's (`docs/profile.md`, "The
/// allocator"). A campaign trial allocates about 640 times; with glibc's malloc a trial on
/// one thread costs 1.26× and on two threads 1.28× what it costs with mimalloc (paired runs
/// of the paper scenario, same bytes out), and the 16-thread runs lost 30 % per
/// trial and thread to in-process sharing. It costs about 16 MB more peak memory.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[derive(Parser)]
#[command(
    name = "kincal",
    version,
    about = "kincal: kinematic calibration of industrial robots — calibrate real laser-tracker \
             data, and run Monte Carlo studies of a virtual KUKA KR1000",
    after_help = "Quick start (from the repository root):
  kincal identify --robot scenarios/robots/ur10.json \\
      --data data/ur10-ipa/series-b-joint-configurations.csv --every 15 --out ur10-cal
  kincal campaign scenarios/paper-kr1000.json --out my-run

`kincal <command> --help` shows each command's options and an example."
)]
struct Cli {
    #[command(subcommand)]
    cmd: kincal::Command,
}

/// Restores the default action of SIGPIPE, which the Rust runtime ignores: a write to a
/// closed standard output (`kincal predict … | head -1`) then ends the process quietly, as
/// it ends `cat` or `grep` (status 141 in a shell: 128 + SIGPIPE), instead of a panic
/// "failed printing to stdout: Broken pipe" in whatever `print!` met it first. Outputs
/// written to files are unaffected: they are written whole before anything is printed.
#[allow(unsafe_code)]
fn default_sigpipe() {
    // SAFETY: called first thing in `main`, before any other thread exists; `signal` with
    // `SIG_DFL` installs no handler, so no Rust code runs in signal context.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() {
    default_sigpipe();
    kincal::exit_on_error(kincal::run(Cli::parse().cmd));
}
