//! Timing child processes: wall time from spawn to exit and peak memory (`wait4`'s
//! `ru_maxrss`), and the machine's load and memory.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};

/// The one-minute load average (`/proc/loadavg`).
pub(super) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(String::from))
        .unwrap_or_else(|| "unknown".into())
}

/// What one child process took.
#[derive(Clone, Copy)]
pub(super) struct Measured {
    /// Wall seconds from spawn to exit.
    pub(super) seconds: f64,
    /// Peak resident memory in MB (10⁶ bytes).
    pub(super) peak_mb: f64,
}

/// Runs `kincal args…` and measures it; it must succeed. With `stop_after`, it is killed
/// (SIGKILL) after that long if still running (and then counts as measured).
pub(super) fn measure(
    kincal: &Path,
    args: &[&str],
    tmp: &Path,
    stop_after: Option<Duration>,
) -> Result<Measured> {
    let stderr_path = tmp.join("stderr.txt");
    let stderr = std::fs::File::create(&stderr_path)
        .with_context(|| format!("creating {}", stderr_path.display()))?;
    let started = Instant::now();
    let child = Command::new(kincal)
        .args(args)
        .env("CI", "1")
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .with_context(|| format!("running {}", kincal.display()))?;
    let pid = libc::pid_t::try_from(child.id()).context("child pid")?;
    let mut killed = false;
    let (status, max_rss_kib) = loop {
        let poll = stop_after.is_some() && !killed;
        if let Some(done) = wait4(pid, poll).context("waiting for kincal")? {
            break done;
        }
        // Still running (polled).
        if stop_after.is_some_and(|d| started.elapsed() >= d) {
            kill(pid);
            killed = true;
        } else {
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let seconds = started.elapsed().as_secs_f64();
    let exited_ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    if !killed && !exited_ok {
        bail!(
            "{} {}: {}",
            kincal.display(),
            args.join(" "),
            std::fs::read_to_string(&stderr_path).unwrap_or_default()
        );
    }
    // Reaped above: dropping the handle does not wait again.
    drop(child);
    Ok(Measured {
        seconds,
        // ru_maxrss is in KiB on Linux.
        peak_mb: max_rss_kib as f64 * 1024.0 / 1e6,
    })
}

/// Waits for the child `pid` (`poll`: returns `None` at once if it is still running) and
/// returns its wait status and peak resident set size in KiB (`ru_maxrss`, Linux units).
#[allow(unsafe_code)]
fn wait4(pid: libc::pid_t, poll: bool) -> std::io::Result<Option<(libc::c_int, i64)>> {
    let flags = if poll { libc::WNOHANG } else { 0 };
    loop {
        let mut status: libc::c_int = 0;
        // SAFETY: `rusage` is a plain C struct for which all-zero bytes are a valid value.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `pid` is a child of this process that nothing else waits for (its
        // `std::process::Child` is never waited on); both pointers are to live locals.
        let r = unsafe { libc::wait4(pid, &mut status, flags, &mut usage) };
        if r == pid {
            return Ok(Some((status, usage.ru_maxrss)));
        }
        if r == 0 {
            return Ok(None);
        }
        let e = std::io::Error::last_os_error();
        if e.kind() != std::io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
}

/// Sends SIGKILL to the child `pid` (not yet reaped, so the pid is still ours).
#[allow(unsafe_code)]
fn kill(pid: libc::pid_t) {
    // SAFETY: `kill` has no memory-safety preconditions; the pid is our unreaped child.
    unsafe {
        libc::kill(pid, libc::SIGKILL);
    }
}

pub(super) fn median(mut v: Vec<Measured>) -> Measured {
    v.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    v[v.len() / 2]
}

/// This process's own peak resident memory in MB (`VmHWM` of `/proc/self/status`).
pub(super) fn own_peak_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0 / 1e6)
}

/// The machine's memory (`MemTotal` of `/proc/meminfo`), e.g. "24.7 GB".
pub(super) fn machine_memory_gb() -> String {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(format!("{:.1} GB", kib * 1024.0 / 1e9))
        })
        .unwrap_or_else(|| "unknown".into())
}
