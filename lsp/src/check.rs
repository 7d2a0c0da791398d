//! `eamos check` behind the editor: run on save, on a thread of its own, so
//! that a long exploration never holds up typing.
//!
//! Saves queue up while a check runs; the worker then checks only the
//! latest text of each file (older saves are stale work, dropped). A
//! result is shown only while the file's text is still the one checked:
//! the server compares the hash it carries.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::thread;

use crossbeam_channel::{unbounded, Receiver, Sender};
use eamos_lang::SourceFile;
use eamos_verify::Report;

/// What to check: a file's saved text, and the fleet file beside it.
pub struct Job {
    pub uri: String,
    pub hash: u64,
    pub source: SourceFile,
    pub fleet: Option<PathBuf>,
}

/// What the check found, for the text of `hash`.
pub struct Outcome {
    pub uri: String,
    pub hash: u64,
    /// `None` when the mission does not compile (the front end's
    /// diagnostics say why); `Err` when the fleet file cannot be read.
    pub report: Result<Option<Report>, String>,
}

/// Starts the worker; it ends when the job sender is dropped.
pub fn spawn() -> (Sender<Job>, Receiver<Outcome>) {
    let (job_tx, job_rx) = unbounded::<Job>();
    let (out_tx, out_rx) = unbounded();
    thread::spawn(move || {
        let profiles = eamos_profile::builtin();
        while let Ok(first) = job_rx.recv() {
            let mut latest = BTreeMap::new();
            latest.insert(first.uri.clone(), first);
            for job in job_rx.try_iter() {
                latest.insert(job.uri.clone(), job);
            }
            for (_, job) in latest {
                let report =
                    std::panic::catch_unwind(|| run(&job, &profiles)).unwrap_or_else(|_| {
                        Err("the checker failed on this mission (a bug of eamos)".into())
                    });
                let outcome = Outcome {
                    uri: job.uri,
                    hash: job.hash,
                    report,
                };
                if out_tx.send(outcome).is_err() {
                    return;
                }
            }
        }
    });
    (job_tx, out_rx)
}

/// The same steps as `eamos check --fleet`: compile, build the net, load
/// the fleet (or the default one), check.
pub fn run(job: &Job, profiles: &eamos_profile::ProfileTable) -> Result<Option<Report>, String> {
    let Ok(compiled) = eamos_lang::compile(&job.source, profiles) else {
        return Ok(None);
    };
    let net = eamos_petri::compile(&compiled.mission, profiles);
    let fleet = match &job.fleet {
        Some(path) => {
            eamos_fleet::Fleet::load(path, &net.name, &net.drones).map_err(|e| e.to_string())?
        }
        None => eamos_fleet::Fleet::default(),
    };
    let options = eamos_verify::Options {
        space: Some(eamos_verify::Space {
            homes: fleet.homes(&net.drones),
            airspace: fleet.airspace().clone(),
        }),
        // An editor's check must leave memory for the editor.
        max_memory_mb: 1024,
        ..eamos_verify::Options::default()
    };
    Ok(Some(eamos_verify::check_net(
        &net,
        profiles,
        Some(&job.source.text),
        &options,
    )))
}
