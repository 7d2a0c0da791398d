//! The phases of a command that flies, and what it hands back to the
//! system between them ([`eamos_trim`]): after the compile, after the
//! check, before the flight, and once the flight is under way.

use std::sync::{Arc, Mutex};

use eamos_exec::event::{Event, Kind, Sink, Tee};

/// The sink a flight's events go to: `sinks`, and the release of the
/// program's code pages once each of the flight's `executors` has started
/// (see [`FlightStarted`]).
pub fn releasing_once_started(executors: usize, mut sinks: Vec<Arc<dyn Sink>>) -> Arc<dyn Sink> {
    sinks.push(Arc::new(FlightStarted::new(
        executors,
        eamos_trim::release_code_pages,
    )));
    Arc::new(Tee::new(sinks))
}

/// Does something once a flight is under way: when each of its
/// `executors` has said it started, and again for the next flight (an
/// agent flies one after another, one executor each). `eamos run`,
/// `eamos deploy` and `eamos agent` release the code pages then
/// ([`eamos_trim::release_code_pages`]): starting up (the links, the
/// peers' liveliness, a router's sessions) runs code the flight does not
/// run again; a ground station of 250 drones flew at 16.5-18.4 MiB instead
/// of 19.5-20.1.
pub struct FlightStarted<F> {
    executors: usize,
    waiting: Mutex<usize>,
    then: F,
}

impl<F: Fn() + Send + Sync> FlightStarted<F> {
    pub fn new(executors: usize, then: F) -> Self {
        Self {
            executors: executors.max(1),
            waiting: Mutex::new(executors.max(1)),
            then,
        }
    }
}

impl<F: Fn() + Send + Sync> Sink for FlightStarted<F> {
    fn event(&self, e: &Event) {
        if !matches!(e.kind, Kind::Started { .. }) {
            return;
        }
        let mut waiting = self.waiting.lock().unwrap_or_else(|p| p.into_inner());
        *waiting -= 1;
        if *waiting == 0 {
            *waiting = self.executors;
            drop(waiting);
            (self.then)();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;

    fn at(kind: Kind) -> Event {
        Event {
            time: 0.0,
            drone: "D1".into(),
            kind,
        }
    }

    fn started() -> Event {
        at(Kind::Started {
            mission: "M".into(),
            mission_id: "M-1".into(),
            places: 1,
            transitions: 1,
            bridges_in: 0,
            bridges_out: 0,
        })
    }

    #[test]
    fn it_acts_when_every_executor_of_a_flight_has_started() {
        let acted = AtomicUsize::new(0);
        let sink = FlightStarted::new(3, || {
            acted.fetch_add(1, Ordering::Relaxed);
        });
        let acts = || acted.load(Ordering::Relaxed);
        sink.event(&started());
        sink.event(&at(Kind::MissionEnded { by: "D1".into() }));
        sink.event(&started());
        assert_eq!(acts(), 0, "one executor still starting");
        sink.event(&started());
        assert_eq!(acts(), 1);
        // The next flight of three.
        sink.event(&started());
        sink.event(&started());
        assert_eq!(acts(), 1, "the next flight is still starting");
        sink.event(&started());
        assert_eq!(acts(), 2);
    }

    /// Resident kilobytes of this program's executable mappings.
    #[cfg(target_os = "linux")]
    fn resident_code_kib() -> u64 {
        let exe = std::fs::read_link("/proc/self/exe").expect("Linux names the program");
        let smaps = std::fs::read_to_string("/proc/self/smaps").expect("Linux has smaps");
        let mut total = 0;
        let mut counting = false;
        for line in smaps.lines() {
            let fields: Vec<&str> = line.split_whitespace().collect();
            if fields
                .first()
                .is_some_and(|f| f.contains('-') && !f.ends_with(':'))
            {
                counting = fields.get(1) == Some(&"r-xp")
                    && fields.get(5).map(std::path::Path::new) == Some(exe.as_path());
            } else if counting && fields.first() == Some(&"Rss:") {
                total += fields[1].parse::<u64>().expect("a number of kB");
            }
        }
        total
    }

    /// The survey example compiled and checked: the compiler's and the
    /// checker's code, run once.
    fn survey_checked() -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/survey.go");
        let text = std::fs::read_to_string(&path).expect("the example is in the repository");
        let source = eamos_lang::SourceFile::new(path.display().to_string(), text);
        let profiles = eamos_profile::builtin();
        let compiled = eamos_lang::compile(&source, &profiles).expect("the example compiles");
        let net = eamos_petri::compile(&compiled.mission, &profiles);
        let options = eamos_verify::Options::default();
        let report = eamos_verify::check_net(&net, &profiles, Some(&source.text), &options);
        format!("{} {:?}", net.graph.node_count(), report.findings)
    }

    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn released_code_leaves_the_resident_set_and_the_program_runs_on() {
        let first = survey_checked();
        let before = resident_code_kib();
        eamos_trim::release_code_pages();
        let after = resident_code_kib();
        assert!(
            after + 1024 < before,
            "{before} kB of code resident before, {after} kB after"
        );
        // The compiler and the checker come back from the file, and their
        // calls through vtables and function tables (relocated read-only
        // data, which is kept) land where they did.
        assert_eq!(survey_checked(), first);
    }
}
