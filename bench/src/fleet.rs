//! A fleet of drones, one process each, on this computer: `eamos gen`'s
//! mission of N drones (ten nodes per drone, seed 12), cut once by `eamos
//! build --fleet --out`, flown by N processes `eamos run --slices DIR
//! --drone Dk` and one `eamos run MISSION --gcs`, all joined
//! through one zenoh router (`eamos router`, named by the fleet file's
//! `[zenoh] routers`), as a crew would start them. Measured: from the
//! launch to the mission's start (the ground station's first token, sent
//! once every drone is ready), from the launch to the last process's exit,
//! the peak resident set of each process and, sampled, the peak of its
//! private (anonymous) memory: most of a resident set is the program's
//! code, mapped from one file and shared by every process of the fleet.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::process::status_kib;
use crate::workload::free_port;

/// Simulated seconds per real second.
const SPEED: &str = "50";
/// How long the ground station waits for every drone to be ready.
const STARTUP: Duration = Duration::from_secs(120);
/// When the measurement gives up on a fleet that has not ended.
const LIMIT: Duration = Duration::from_secs(300);

/// What one fleet did.
#[derive(Debug, Clone)]
pub struct FleetRun {
    pub drones: usize,
    /// From the launch to the ground station's first token; `None` if the
    /// mission never started.
    pub to_start: Option<Duration>,
    /// From the launch to the last process's exit (or to the limit).
    pub to_end: Duration,
    /// The ground station said the mission completed, and every process
    /// exited with success.
    pub completed: bool,
    /// Peak resident set in KiB of the largest drone process, of the
    /// median one and of the ground station's (0: not measured, without
    /// GNU `time`).
    pub drone_max_kib: u64,
    pub drone_median_kib: u64,
    pub gcs_kib: u64,
    /// Peak private (anonymous) memory in KiB, sampled every
    /// [`SAMPLE`]: of the largest drone process, of the median one and of
    /// the ground station (0: not measured).
    pub drone_private_max_kib: u64,
    pub drone_private_median_kib: u64,
    pub gcs_private_kib: u64,
    /// The ground station's largest resident set once the mission has
    /// started, sampled likewise: what it holds while the fleet flies,
    /// after the compile and the check are done with (0: not measured).
    pub gcs_flying_kib: u64,
    /// Peak proportional set (the resident set with each shared page
    /// divided among the processes that map it: what each process adds
    /// to the machine), sampled likewise: largest drone, median drone.
    pub drone_pss_max_kib: u64,
    pub drone_pss_median_kib: u64,
    /// Peak resident set in KiB of the zenoh router (`eamos router`),
    /// read from the kernel before it is stopped (0: not measured). It
    /// runs on the ground and carries every frame of the fleet.
    pub router_kib: u64,
    /// Compiling and cutting the slices once, before the launch.
    pub cut: Duration,
    /// The loopback interface's traffic over the flight (from the launch
    /// to the end): every frame of the fleet goes through the router on
    /// it, once in and once out. `None` where the kernel does not say.
    pub loopback: Option<Traffic>,
}

/// Packets and bytes a network interface received, as the kernel counts
/// them (`/proc/net/dev`): on loopback every packet sent is received once,
/// TCP's acknowledgements included.
#[derive(Debug, Clone, Copy, Default)]
pub struct Traffic {
    pub packets: u64,
    pub bytes: u64,
}

#[cfg(target_os = "linux")]
fn loopback() -> Option<Traffic> {
    let text = std::fs::read_to_string("/proc/net/dev").ok()?;
    let line = text
        .lines()
        .find_map(|l| l.trim_start().strip_prefix("lo:"))?;
    let mut fields = line.split_whitespace().map(|f| f.parse::<u64>().ok());
    let bytes = fields.next()??;
    let packets = fields.next()??;
    Some(Traffic { packets, bytes })
}

#[cfg(not(target_os = "linux"))]
fn loopback() -> Option<Traffic> {
    None
}

/// Proportional set size of a running process, in KiB.
#[cfg(target_os = "linux")]
fn pss_kib(pid: u32) -> Option<u64> {
    std::fs::read_to_string(format!("/proc/{pid}/smaps_rollup"))
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("Pss:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(not(target_os = "linux"))]
fn pss_kib(_pid: u32) -> Option<u64> {
    None
}

/// How often the private memory of every process is read (a few
/// microseconds a process: `/proc/PID/status` keeps counters).
const SAMPLE: Duration = Duration::from_millis(500);

/// The process that does the work: the child of GNU `time` when it
/// measures, else the process itself.
#[cfg(target_os = "linux")]
fn worker(pid: u32, timed: bool) -> Option<u32> {
    if !timed {
        return Some(pid);
    }
    std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children"))
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A running process's `/proc/PID/status`.
#[cfg(target_os = "linux")]
fn status(pid: u32) -> Option<String> {
    std::fs::read_to_string(format!("/proc/{pid}/status")).ok()
}

/// Private memory of a process, in KiB, from its status.
fn private_kib(status: &str) -> Option<u64> {
    Some(status_kib(status, "RssAnon:")? + status_kib(status, "RssShmem:").unwrap_or(0))
}

#[cfg(not(target_os = "linux"))]
fn worker(_pid: u32, _timed: bool) -> Option<u32> {
    None
}

#[cfg(not(target_os = "linux"))]
fn status(_pid: u32) -> Option<String> {
    None
}

/// Processes (each the leader of its own process group, with GNU `time`
/// around it) killed with their group when dropped.
struct Group(Vec<Child>);

impl Drop for Group {
    fn drop(&mut self) {
        for c in &mut self.0 {
            kill_group(c);
            let _ = c.wait();
        }
    }
}

#[cfg(unix)]
fn kill_group(c: &mut Child) {
    // SAFETY: a plain system call on a process group this program made.
    unsafe {
        libc::kill(-(c.id() as libc::pid_t), libc::SIGKILL);
    }
}

#[cfg(not(unix))]
fn kill_group(c: &mut Child) {
    let _ = c.kill();
}

/// `exe ARGS` under GNU `time`, writing its peak memory to `peak` (when
/// that is installed), in a process group of its own.
fn command(exe: &Path, peak: &Path, timed: bool) -> Command {
    let mut cmd = if timed {
        let mut c = Command::new("/usr/bin/time");
        c.args(["-f", "%M", "-o"]).arg(peak).arg(exe);
        c
    } else {
        Command::new(exe)
    };
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
    }
    cmd
}

fn peak_kib(path: &Path) -> u64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.lines().last()?.trim().parse().ok())
        .unwrap_or(0)
}

/// Flies `drones` drones, one process each, in `dir`.
pub fn measure(exe: &Path, dir: &Path, drones: usize) -> Result<FleetRun, String> {
    // GNU `time` starts the processes: `/proc/self/exe` would be `time`
    // itself there.
    let exe = &std::fs::canonicalize(exe)
        .map_err(|e| format!("cannot resolve {}: {e}", exe.display()))?;
    let dir = dir.join(format!("fleet-{drones}"));
    if dir.exists() {
        std::fs::remove_dir_all(&dir)
            .map_err(|e| format!("cannot clear {}: {e}", dir.display()))?;
    }
    std::fs::create_dir_all(dir.join("peak"))
        .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let write = |name: &str, text: &[u8]| -> Result<PathBuf, String> {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        Ok(p)
    };
    let gen = Command::new(exe)
        .args(["gen", "--drones", &drones.to_string()])
        .args(["--nodes", &(drones * 10).to_string(), "--seed", "12"])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", exe.display()))?;
    if !gen.status.success() {
        return Err(format!("eamos gen failed: {gen:?}"));
    }
    let mission = write("fleet.go", &gen.stdout)?;
    let fleet = write(
        "fleet.toml",
        format!("[zenoh]\nrouters = [\"tcp/127.0.0.1:{}\"]\n", free_port()?).as_bytes(),
    )?;
    // Cut once for the fleet: each drone's agent reads its own slice
    // instead of compiling the whole mission (`eamos run --slices`).
    let slices = dir.join("slices");
    let cutting = Instant::now();
    let built = Command::new(exe)
        .arg("build")
        .arg(&mission)
        .arg("--fleet")
        .arg(&fleet)
        .arg("--out")
        .arg(&slices)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", exe.display()))?;
    if !built.status.success() {
        return Err(format!(
            "eamos build failed: {}",
            String::from_utf8_lossy(&built.stderr)
        ));
    }
    let cut = cutting.elapsed();
    let timed = Path::new("/usr/bin/time").exists();
    let logs = dir.join("logs");
    let gcs_log = logs.join("GCS.mission.jsonl");
    let peak = |tag: &str| dir.join("peak").join(tag);
    let spawn = |mut cmd: Command| {
        cmd.stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start a process of the fleet: {e}"))
    };

    let launched = Instant::now();
    let traffic_before = loopback();
    let mut router = Group(Vec::new());
    let mut cmd = command(exe, &peak("router"), false);
    cmd.args(["router", "--fleet"])
        .arg(&fleet)
        .args(["--router", "1"]);
    router.0.push(spawn(cmd)?);
    let mut peers = Group(Vec::new());
    let slices_dir = slices.to_string_lossy().into_owned();
    let mission_file = mission.to_string_lossy().into_owned();
    let roles = (1..=drones)
        .map(|k| {
            (
                format!("D{k}"),
                vec![
                    "--slices".to_string(),
                    slices_dir.clone(),
                    "--drone".to_string(),
                    format!("D{k}"),
                ],
            )
        })
        .chain(std::iter::once((
            "GCS".to_string(),
            vec![mission_file.clone(), "--gcs".to_string()],
        )));
    for (tag, role) in roles {
        let mut cmd = command(exe, &peak(&tag), timed);
        cmd.arg("run")
            .arg("--fleet")
            .arg(&fleet)
            .args(&role)
            .args(["--speed", SPEED, "--max-duration", "100000"])
            .args(["--startup-timeout", &STARTUP.as_secs().to_string()])
            .arg("--out")
            .arg(&logs);
        peers.0.push(spawn(cmd)?);
    }

    let mut to_start = None;
    let mut statuses = vec![None; peers.0.len()];
    let mut private = vec![0u64; peers.0.len()];
    let mut pss = vec![0u64; peers.0.len()];
    let mut workers: Vec<Option<u32>> = vec![None; peers.0.len()];
    let mut gcs_flying = 0u64;
    let mut sampled = Instant::now() - SAMPLE;
    while launched.elapsed() < LIMIT {
        if sampled.elapsed() >= SAMPLE {
            sampled = Instant::now();
            // The ground station is the last process.
            let gcs = peers.0.len() - 1;
            for (i, (((c, w), p), shared)) in peers
                .0
                .iter()
                .zip(workers.iter_mut())
                .zip(private.iter_mut())
                .zip(pss.iter_mut())
                .enumerate()
            {
                if w.is_none() {
                    *w = worker(c.id(), timed);
                }
                if let Some(status) = w.and_then(status) {
                    *p = (*p).max(private_kib(&status).unwrap_or(0));
                    if i == gcs && to_start.is_some() {
                        let kib = status_kib(&status, "VmRSS:").unwrap_or(0);
                        gcs_flying = gcs_flying.max(kib);
                    }
                }
                if let Some(kib) = w.and_then(pss_kib) {
                    *shared = (*shared).max(kib);
                }
            }
        }
        if to_start.is_none()
            && std::fs::read_to_string(&gcs_log)
                .is_ok_and(|t| t.contains("\"event\":\"bridge_sent\""))
        {
            to_start = Some(launched.elapsed());
        }
        for (c, s) in peers.0.iter_mut().zip(statuses.iter_mut()) {
            if s.is_none() {
                *s = c
                    .try_wait()
                    .map_err(|e| format!("cannot wait for a process of the fleet: {e}"))?;
            }
        }
        if statuses.iter().all(Option::is_some) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let to_end = launched.elapsed();
    let traffic = match (traffic_before, loopback()) {
        (Some(a), Some(b)) => Some(Traffic {
            packets: b.packets.saturating_sub(a.packets),
            bytes: b.bytes.saturating_sub(a.bytes),
        }),
        _ => None,
    };
    drop(peers);
    // Started without GNU `time`: its peak is read before it is stopped.
    let router_kib = router
        .0
        .first()
        .and_then(|r| status(r.id()))
        .and_then(|s| status_kib(&s, "VmHWM:"))
        .unwrap_or(0);
    drop(router);
    let said = std::fs::read_to_string(&gcs_log).unwrap_or_default();
    let completed = statuses.iter().all(|s| s.is_some_and(|s| s.success()))
        && said.contains("\"event\":\"stopped\",\"reason\":\"completed\"");
    let mut peaks: Vec<u64> = (1..=drones)
        .map(|k| peak_kib(&peak(&format!("D{k}"))))
        .collect();
    peaks.sort_unstable();
    // The ground station is the last process.
    let gcs_private_kib = private.pop().unwrap_or(0);
    private.sort_unstable();
    pss.pop();
    pss.sort_unstable();
    Ok(FleetRun {
        drone_private_max_kib: private.last().copied().unwrap_or(0),
        drone_private_median_kib: private.get(private.len() / 2).copied().unwrap_or(0),
        gcs_private_kib,
        gcs_flying_kib: gcs_flying,
        drones,
        to_start,
        to_end,
        completed,
        drone_max_kib: peaks.last().copied().unwrap_or(0),
        drone_median_kib: peaks.get(peaks.len() / 2).copied().unwrap_or(0),
        gcs_kib: peak_kib(&peak("GCS")),
        drone_pss_max_kib: pss.last().copied().unwrap_or(0),
        drone_pss_median_kib: pss.get(pss.len() / 2).copied().unwrap_or(0),
        router_kib,
        cut,
        loopback: traffic,
    })
}
