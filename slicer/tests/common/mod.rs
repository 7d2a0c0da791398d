//! Shared helpers of the slicer's tests: the paper missions, compiled, and
//! the runner of the property tests over generated missions.
#![allow(dead_code)]

use std::path::PathBuf;

use eamos_lang::SourceFile;
use eamos_petri::Net;

/// The built-in profiles.
pub fn profiles() -> eamos_profile::ProfileTable {
    eamos_profile::builtin()
}

/// The directory of the paper's missions, beside the repository.
pub fn paper_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/missions/paper")
}

/// The checked mission of one paper file (`experiment_b` and the like).
pub fn paper_mission(name: &str) -> eamos_lang::hir::Mission {
    let path = paper_dir().join(format!("{name}.go"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let file = SourceFile::new(format!("{name}.go"), text);
    match eamos_lang::compile(&file, &profiles()) {
        Ok(c) => c.mission,
        Err(d) => panic!("{name} does not compile: {d:?}"),
    }
}

/// The net of one paper mission.
pub fn paper_net(name: &str) -> Net {
    eamos_petri::compile(&paper_mission(name), &profiles())
}

pub const PAPER: &[&str] = &[
    "listing01_demo",
    "experiment_a",
    "experiment_b",
    "experiment_c",
    "experiment_d",
];

pub mod gen;
pub mod mutate;
pub mod write;

use eamos_slicer::equivalence::{Budget, Verdict};
use proptest::strategy::Strategy;
use proptest::test_runner::{Config, TestCaseError, TestError, TestRunner};

/// The budget of every comparison of a generated mission: sized (with the
/// generator's bounds) so that every case fits; one that does not fails.
pub const BUDGET: Budget = Budget {
    pairs: 60_000,
    markings: 200_000,
};

/// A generated test input that holds a mission.
pub trait HasMission: Clone + std::fmt::Debug {
    fn case(&self) -> &gen::Case;
}

impl HasMission for gen::Case {
    fn case(&self) -> &gen::Case {
        self
    }
}

impl<T: Clone + std::fmt::Debug> HasMission for (gen::Case, T) {
    fn case(&self) -> &gen::Case {
        &self.0
    }
}

/// Runs `test` on `default` cases (or `PROPTEST_CASES`), and on failure
/// panics with the reason and the smallest mission text that fails.
pub fn run<S>(default: u32, strategy: &S, test: impl Fn(S::Value) -> Result<(), String>)
where
    S: Strategy,
    S::Value: HasMission,
{
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        max_shrink_time: 120_000,
        // The generator leaves out missions beyond its size (about one in
        // six of the full size).
        max_global_rejects: 100_000,
        ..Config::default()
    });
    match runner.run(strategy, |case| test(case).map_err(TestCaseError::fail)) {
        Ok(()) => {}
        Err(TestError::Fail(reason, case)) => {
            panic!(
                "{reason}\nsmallest failing mission:\n{}",
                case.case().source
            )
        }
        Err(e) => panic!("{e}"),
    }
}

/// The checked mission and its net; a mission the front end refuses is a
/// generator bug.
pub fn compiled(case: &gen::Case) -> Result<(eamos_lang::hir::Mission, Net), String> {
    let mission = case
        .mission
        .clone()
        .map_err(|d| format!("the front end refused a generated mission: {d}"))?;
    let net = eamos_petri::compile(&mission, &profiles());
    Ok((mission, net))
}

/// Why a verdict is not equivalence, for a person.
pub fn explain(v: &Verdict) -> String {
    match v {
        Verdict::OutOfBudget {
            depth,
            pairs,
            markings,
        } => format!(
            "the comparison ran out of budget ({pairs} pairs, {markings} markings, traces \
             equal up to {depth} events): undecided. Grow the budget or shrink the generator"
        ),
        Verdict::Different {
            trace,
            only_left,
            only_right,
        } => {
            let list = |es: &[eamos_slicer::equivalence::Event]| {
                es.iter()
                    .map(|e| e.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            format!(
                "different: after [{}] only the mission can show [{}], only the slices [{}]",
                list(trace),
                list(only_left),
                list(only_right)
            )
        }
        other => format!("{other:?}"),
    }
}
