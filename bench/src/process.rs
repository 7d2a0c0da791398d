//! The parent side of a probe: start a whole process, time it to its
//! "ready" line (or to its exit, for a baseline that says nothing) and read
//! its peak memory.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One process measured: from spawn to its "ready" line, and its peak
/// resident set size (medians over the runs), and what it said after
/// "ready" (the last run's).
#[derive(Debug, Clone)]
pub struct Process {
    pub to_ready: Duration,
    pub peak_kib: u64,
    pub said: Vec<String>,
}

pub fn probe(exe: &Path, what: &[&str], runs: usize) -> Result<Process, String> {
    let mut times = Vec::with_capacity(runs);
    let mut peaks = Vec::with_capacity(runs);
    let mut said = Vec::new();
    for _ in 0..runs {
        let p = probe_once(exe, what)?;
        times.push(p.to_ready);
        peaks.push(p.peak_kib);
        said = p.said;
    }
    times.sort();
    peaks.sort();
    Ok(Process {
        to_ready: times[runs / 2],
        peak_kib: peaks[runs / 2],
        said,
    })
}

fn probe_once(exe: &Path, what: &[&str]) -> Result<Process, String> {
    let started = Instant::now();
    let mut child = Command::new(exe)
        .arg("bench-report")
        .arg("--probe")
        .args(what)
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    let mut line = String::new();
    let mut said = Vec::new();
    let mut to_ready = Duration::ZERO;
    if let Some(out) = child.stdout.take() {
        let mut out = BufReader::new(out);
        let _ = out.read_line(&mut line);
        to_ready = started.elapsed();
        said = out.lines().map_while(Result::ok).collect();
    }
    let (ok, rusage_kib) = wait_with_peak(&mut child)?;
    let mut words = line.split_whitespace();
    if !ok || words.next() != Some("ready") {
        return Err(format!("the probe `{}` failed (see above)", what.join(" ")));
    }
    // The child's own figure where it has one: see `own_peak_kib`.
    let peak_kib = words
        .next()
        .and_then(|w| w.parse().ok())
        .unwrap_or(rusage_kib);
    Ok(Process {
        to_ready,
        peak_kib,
        said,
    })
}

/// Waits for the child and returns whether it succeeded and its peak
/// resident set size in KiB.
#[cfg(unix)]
fn wait_with_peak(child: &mut std::process::Child) -> Result<(bool, u64), String> {
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain data that `wait4` fills in; all zeroes is a
    // valid value of it.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet waited for (std never waits
    // on its own), and both pointers are to live locals.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        return Err(format!(
            "cannot wait for the probe: {}",
            std::io::Error::last_os_error()
        ));
    }
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    // Linux reports KiB, macOS bytes.
    let maxrss = usage.ru_maxrss as u64;
    let kib = if cfg!(target_os = "macos") {
        maxrss / 1024
    } else {
        maxrss
    };
    Ok((ok, kib))
}

#[cfg(not(unix))]
fn wait_with_peak(child: &mut std::process::Child) -> Result<(bool, u64), String> {
    let status = child
        .wait()
        .map_err(|e| format!("cannot wait for the probe: {e}"))?;
    Ok((status.success(), 0))
}

/// `gofmt` formatting `file`, as the baseline of a compile: a well-known
/// tool reading and rewriting the same Go text, timed as a whole process
/// from spawn to exit (medians over `runs`). `None` where `gofmt` is not
/// installed: the table then says the baseline was not measured.
///
/// Its peak memory cannot come from `wait4`: a child spawned from this
/// process is charged the report's own resident pages (see
/// `own_peak_kib`), some 37 MB against gofmt's 6-7. It is read instead
/// from GNU `time`, whose own child gofmt is; without it the memory is
/// not measured (0).
pub fn gofmt(file: &Path, runs: usize) -> Option<Process> {
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let started = Instant::now();
        let status = Command::new("gofmt")
            .arg(file)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .ok()?;
        if !status.success() {
            eprintln!("gofmt failed on {}: no baseline", file.display());
            return None;
        }
        times.push(started.elapsed());
    }
    times.sort();
    Some(Process {
        to_ready: times[times.len() / 2],
        peak_kib: gofmt_peak_kib(file).unwrap_or(0),
        said: Vec::new(),
    })
}

/// gofmt's peak resident set in KiB, as GNU `time -f %M` reports it.
fn gofmt_peak_kib(file: &Path) -> Option<u64> {
    let out = Command::new("/usr/bin/time")
        .args(["-f", "%M", "gofmt"])
        .arg(file)
        .stdout(Stdio::null())
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    stderr.lines().last()?.trim().parse().ok()
}

/// A field of a process's `/proc/PID/status` (`VmHWM:`, `RssAnon:`...),
/// in KiB.
pub fn status_kib(status: &str, name: &str) -> Option<u64> {
    status
        .lines()
        .find_map(|l| l.strip_prefix(name))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}
