//! The checker's benchmark corpus: nets that model checkers are compared
//! on, each written here from its generator command, checked by this
//! program as a whole process, and reported with its verdict, its states,
//! its time and its peak memory.
//!
//! - The dining philosophers (`eamos gen --philosophers N [--asymmetric]`),
//!   the classic family of the Model Checking Contest, asked only whether a
//!   deadlock is reachable, as model checkers are: the symmetric tables
//!   deadlock, the asymmetric ones do not.
//! - Generated missions of 20,000 nodes (`eamos gen --drones D --nodes
//!   20000 --seed S`), every property but the spatial ones.
//! - Fleets of 50 to 500 drones (`eamos gen --drones N --nodes 20N --seed
//!   12`), every property as `eamos check` decides them by default, the
//!   spatial ones included: how the check grows with the fleet.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use eamos_gen::{generate, philosophers, Constructs, Options, Size, Table};
use serde_json::Value;

/// One net of the corpus.
pub struct Entry {
    /// The command that writes it.
    pub generator: String,
    pub file: PathBuf,
    /// `--only deadlock`, or every property.
    pub deadlock_only: bool,
    /// Separation, airspace and flight state decided too.
    pub spatial: bool,
    /// The fleet's size, for a mission of the growth series.
    pub fleet: Option<usize>,
    /// The goal for it, in seconds.
    pub goal_s: Option<f64>,
    /// How many times it is checked: its time is the median of the runs.
    pub runs: usize,
}

/// What checking one net gave.
pub struct Checked {
    pub verdict: String,
    pub decided: bool,
    pub states: u64,
    pub wall: Duration,
    pub peak_kib: u64,
}

/// The fleets of the growth series.
pub const FLEETS: [usize; 4] = [50, 100, 250, 500];

/// Runs of each check of the growth series. Its exponent is fitted to
/// four times of half a second or less, which move by a sixth from one
/// run to the next on a busy machine: one run each moved the exponent by
/// 0.05 between reports of the same code; seven cost about three seconds
/// more than one. The runs are taken in turns ([`check_all`]).
pub const SERIES_RUNS: usize = 7;

/// Memory bound of the corpus checks, in MB: a net that needs more is
/// reported undecided rather than left to run for minutes.
pub const MAX_MEMORY_MB: u64 = 256;

/// Writes the corpus into `dir`.
pub fn prepare(dir: &Path) -> Result<Vec<Entry>, String> {
    let mut out = Vec::new();
    let write = |name: &str, text: &str| -> Result<PathBuf, String> {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok(path)
    };
    for (n, table, goal_s) in [
        (10, Table::Symmetric, None),
        (100, Table::Symmetric, None),
        (1000, Table::Symmetric, Some(0.1)),
        (10, Table::Asymmetric, None),
        (50, Table::Asymmetric, None),
        (100, Table::Asymmetric, Some(0.1)),
    ] {
        let asym = table == Table::Asymmetric;
        let suffix = if asym { " --asymmetric" } else { "" };
        let name = format!("philosophers-{n}{}.pnml", if asym { "-asym" } else { "" });
        out.push(Entry {
            generator: format!("eamos gen --philosophers {n}{suffix}"),
            file: write(&name, &philosophers(n, table))?,
            deadlock_only: true,
            spatial: false,
            fleet: None,
            goal_s,
            runs: 1,
        });
    }
    for (drones, seed, mix) in [
        (8, 9007, Constructs::WITHOUT_CHOICES),
        (16, 9005, Constructs::ALL),
        (32, 9010, Constructs::ALL),
    ] {
        let mut options = Options::new(drones, Size::Nodes(20_000), seed);
        options.constructs = mix;
        let flag = if mix == Constructs::ALL {
            ""
        } else {
            " --constructs without-choices"
        };
        let mission = generate(&options).map_err(|e| e.to_string())?;
        out.push(Entry {
            generator: format!("eamos gen --drones {drones} --nodes 20000 --seed {seed}{flag}"),
            file: write(&format!("mission-{drones}-{seed}.go"), &mission.text)?,
            deadlock_only: false,
            spatial: false,
            fleet: None,
            goal_s: Some(5.0),
            runs: 1,
        });
    }
    for drones in FLEETS {
        let mission = generate(&Options::new(drones, Size::Nodes(20 * drones), 12))
            .map_err(|e| e.to_string())?;
        out.push(Entry {
            generator: format!(
                "eamos gen --drones {drones} --nodes {} --seed 12",
                20 * drones
            ),
            file: write(&format!("fleet-{drones}.go"), &mission.text)?,
            deadlock_only: false,
            spatial: true,
            fleet: Some(drones),
            goal_s: None,
            runs: SERIES_RUNS,
        });
    }
    Ok(out)
}

/// `eamos check --json` of every entry, as a whole process, each
/// `entry.runs` times (see [`median`]), the runs taken in turns: a loud
/// stretch of the machine then slows every fleet of the series alike,
/// where five runs of one fleet after another let it slow one fleet's
/// five and bend the fitted exponent (a report once had the 50-drone
/// check at 47 ms against 38-39 in turns with the others). `said` hears
/// of each entry as its first run starts.
pub fn check_all(
    exe: &Path,
    entries: Vec<Entry>,
    said: impl Fn(&Entry),
) -> Result<Vec<(Entry, Checked)>, String> {
    let mut runs: Vec<Vec<Checked>> = entries.iter().map(|_| Vec::new()).collect();
    for i in in_turns(&entries.iter().map(|e| e.runs.max(1)).collect::<Vec<_>>()) {
        if runs[i].is_empty() {
            said(&entries[i]);
        }
        runs[i].push(check_once(exe, &entries[i])?);
    }
    Ok(entries
        .into_iter()
        .zip(runs)
        .map(|(e, r)| (e, median(r)))
        .collect())
}

/// The order of the runs of entries that want `runs[i]` each: a round
/// over every entry that wants another, round after round.
fn in_turns(runs: &[usize]) -> Vec<usize> {
    let rounds = runs.iter().copied().max().unwrap_or(0);
    (0..rounds)
        .flat_map(|round| (0..runs.len()).filter(move |&i| runs[i] > round))
        .collect()
}

/// The run of median time (of at least one), with the largest peak of
/// any run, decided only if every run was.
fn median(mut runs: Vec<Checked>) -> Checked {
    runs.sort_by_key(|c| c.wall);
    let peak_kib = runs.iter().map(|c| c.peak_kib).max().unwrap_or(0);
    let decided = runs.iter().all(|c| c.decided);
    let mut mid = runs.swap_remove(runs.len() / 2);
    mid.peak_kib = peak_kib;
    if !decided {
        mid.decided = false;
        mid.verdict = "**undecided**".into();
    }
    mid
}

/// `eamos check --json` of one entry, once.
fn check_once(exe: &Path, entry: &Entry) -> Result<Checked, String> {
    let mut args: Vec<String> = vec!["check".into(), "--json".into()];
    args.push(format!("--max-memory={MAX_MEMORY_MB}"));
    if entry.deadlock_only {
        args.extend(["--only".into(), "deadlock".into()]);
    } else if !entry.spatial {
        args.push("--no-spatial".into());
    }
    let peak_file = entry.file.with_extension("peak");
    let timed = Path::new("/usr/bin/time").exists();
    let mut cmd = if timed {
        // `/proc/self/exe` would name `time` itself once it runs; this
        // process's own entry still reaches the program when a rebuild has
        // replaced the file meanwhile, as reading the link would not.
        let own = PathBuf::from(format!("/proc/{}/exe", std::process::id()));
        let exe = if exe == Path::new("/proc/self/exe") && own.exists() {
            own
        } else {
            exe.to_path_buf()
        };
        let mut c = Command::new("/usr/bin/time");
        c.args(["-f", "%M", "-o"]).arg(&peak_file).arg(exe);
        c
    } else {
        Command::new(exe)
    };
    cmd.args(&args).arg(&entry.file).stderr(Stdio::null());
    let started = Instant::now();
    let out = cmd
        .output()
        .map_err(|e| format!("cannot check {}: {e}", entry.file.display()))?;
    let wall = started.elapsed();
    let report: Value = serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("the check of {} said no report ({e})", entry.file.display()))?;
    let verdicts: Vec<String> = report["properties"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|p| p["verdict"] != "not-applicable")
        .map(|p| {
            format!(
                "{} {}",
                p["property"].as_str().unwrap_or("?"),
                p["verdict"].as_str().unwrap_or("?")
            )
        })
        .collect();
    let decided = verdicts.iter().all(|v| !v.ends_with("unknown"));
    let peak_kib = std::fs::read_to_string(&peak_file)
        .ok()
        .and_then(|s| s.lines().last()?.trim().parse().ok())
        .unwrap_or(0);
    Ok(Checked {
        verdict: if entry.deadlock_only {
            verdicts.join(", ")
        } else if decided {
            "every property decided".into()
        } else {
            "**undecided**".into()
        },
        decided,
        states: report["stats"]["states"].as_u64().unwrap_or(0),
        wall,
        peak_kib,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(ms: u64, peak_kib: u64, decided: bool) -> Checked {
        Checked {
            verdict: if decided {
                "every property decided"
            } else {
                "**undecided**"
            }
            .into(),
            decided,
            states: 1,
            wall: Duration::from_millis(ms),
            peak_kib,
        }
    }

    #[test]
    fn a_series_check_takes_the_median_time_and_the_largest_peak() {
        let runs = vec![
            run(40, 900, true),
            run(10, 700, true),
            run(20, 800, true),
            run(90, 600, true),
            run(30, 950, true),
        ];
        let m = median(runs);
        assert_eq!(m.wall, Duration::from_millis(30));
        assert_eq!(m.peak_kib, 950);
        assert!(m.decided);
        assert_eq!(median(vec![run(5, 1, true)]).wall, Duration::from_millis(5));
    }

    #[test]
    fn the_runs_of_the_series_are_taken_in_turns_one_round_after_another() {
        assert_eq!(in_turns(&[1, 3, 1, 3]), vec![0, 1, 2, 3, 1, 3, 1, 3]);
        assert_eq!(in_turns(&[2]), vec![0, 0]);
        assert!(in_turns(&[]).is_empty());
    }

    #[test]
    fn a_series_check_is_decided_only_if_every_run_was() {
        let m = median(vec![run(10, 1, true), run(20, 1, false), run(30, 1, true)]);
        assert!(!m.decided);
        assert_eq!(m.verdict, "**undecided**");
    }
}
