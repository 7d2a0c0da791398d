//! The child side of a probe: this program, started again as
//! `eamos bench-report --probe WHAT [FILE]`, does one thing, says "ready"
//! (with its own peak memory and what it found) and exits.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use eamos_lang::SourceFile;

use crate::workload;

/// The peak resident set of this process so far, in KiB, from
/// `/proc/self/status` (Linux). `wait4`'s `ru_maxrss` cannot be trusted
/// for it: Linux counts into a child's maximum the pages it shared with its
/// parent between `fork` and `exec`, so every probe would weigh at least as
/// much as the report that started it.
fn own_peak_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    crate::process::status_kib(&status, "VmHWM:")
}

/// The child side: do one thing, say "ready" (with its peak memory where the
/// system tells it, and what it found), exit.
pub fn run_probe(probe: &[String]) -> ExitCode {
    let result = match probe {
        [what] if what == "idle" => Ok(String::new()),
        [what, file] if what == "compile" => probe_compile(Path::new(file)),
        [what, file] if what == "start" => probe_start(Path::new(file)),
        [what, file] if what == "check" => probe_check(Path::new(file)),
        _ => Err(format!(
            "unknown probe `{}`: idle, compile MISSION, start SLICE or check MISSION",
            probe.join(" ")
        )),
    };
    match result {
        Ok(said) => {
            let mut out = std::io::stdout().lock();
            let peak = own_peak_kib().map_or(String::new(), |kib| format!(" {kib}"));
            // A reader that went away is the report's business, not a panic.
            let written = (|| {
                writeln!(out, "ready{peak}")?;
                if !said.is_empty() {
                    writeln!(out, "{said}")?;
                }
                out.flush()
            })();
            // What happens after "ready" is not part of the measurement.
            std::process::exit(if written.is_ok() { 0 } else { 2 })
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn probe_compile(file: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let source = SourceFile::new(file.display().to_string(), text);
    let profiles = eamos_profile::builtin();
    let compiled = workload::compile_in_phases(&source, &profiles, eamos_trim::after_phase)?;
    std::hint::black_box(&compiled);
    // Compiled is when the slices exist; the process exits right after
    // saying so. Freeing the mission, its net and its slices first (a
    // hundred thousand allocations on the stress mission, a tenth of the
    // probe's instructions) would time the clean-up, not the compile.
    std::mem::forget(compiled);
    Ok(String::new())
}

/// Checks a mission as `eamos check` does; says how far the proof went
/// (JSON).
fn probe_check(file: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let source = SourceFile::new(file.display().to_string(), text);
    let profiles = eamos_profile::builtin();
    let mission = workload::front_end(&source, &profiles)?;
    let net = eamos_petri::compile(&mission, &profiles);
    // As `eamos check` does: the checked mission, the front end's and the
    // net compiler's code are let go before the check.
    drop(mission);
    eamos_trim::after_phase();
    let options = eamos_verify::Options {
        max_memory_mb: workload::CHECK_MEMORY_MB,
        ..eamos_verify::Options::default()
    };
    let report = eamos_verify::check_net(&net, &profiles, Some(&source.text), &options);
    Ok(serde_json::json!({
        "states": report.stats.states,
        "full_expansions": report.stats.full_expansions,
        "complete": report.stats.complete,
        "seconds": report.stats.seconds,
        "found_something": report.found_something(),
    })
    .to_string())
}

fn probe_start(file: &Path) -> Result<String, String> {
    let bytes = std::fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let slice = eamos_slicer::Slice::from_bytes(&bytes).map_err(|e| e.to_string())?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the async runtime: {e}"))?;
    let profiles = eamos_profile::builtin();
    let ready = runtime.block_on(workload::ready_agent(
        slice,
        &profiles,
        workload::LinkKind::Zenoh,
    ))?;
    std::hint::black_box(&ready);
    Ok(String::new())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg(target_os = "linux")]
    fn a_probe_reads_its_own_peak_memory() {
        let kib = own_peak_kib().expect("Linux gives every process its VmHWM");
        assert!(kib > 0);
    }
}
