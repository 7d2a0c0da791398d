//! What the tests that start `eamos` processes share, included by path
//! (`#[path = "common/processes.rs"] mod processes;`) so that a test takes
//! only this, not the MAVLink helpers beside it.

#![allow(dead_code)]

use std::process::Child;

/// The processes a test started, each with a name for its messages,
/// killed when dropped: a failed assertion leaves no agent behind.
pub struct Processes(pub Vec<(String, Child)>);

impl Drop for Processes {
    fn drop(&mut self) {
        for (_, c) in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A loopback TCP port nobody holds now and no other test of this binary
/// was given (another program may take it before the test does: good
/// enough for a test's endpoints).
pub fn free_port() -> u16 {
    eamos_bench::workload::free_port().expect("a free loopback port")
}

/// Runs `eamos abort` on `mission`, waiting `timeout` seconds at most for
/// the acknowledgements; its report (standard output), once it succeeded.
pub fn abort(mission: &std::path::Path, timeout: u64) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_eamos"))
        .arg("abort")
        .arg(mission)
        .args(["--timeout", &timeout.to_string()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}
