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

/// A loopback TCP port nobody holds now (another program may take it
/// before the test does: good enough for a test's endpoints).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}
