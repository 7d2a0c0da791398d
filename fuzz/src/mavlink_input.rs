//! Feeds arbitrary bytes through the MAVLink adapter's input path: the same
//! frame reader its links use (`AsyncMavlinkReader`, MAVLink 1 and 2
//! accepted, as the adapter's connections are set up), then every decoded
//! message folded into the vehicle state and its readiness, and read back
//! the way the adapter publishes telemetry and logs mode changes.
//!
//! Bytes that are not MAVLink (an autopilot's boot console, line noise)
//! must be skipped, frames that pass the CRC but do not decode must be
//! counted and skipped, and nothing may panic.

use std::future::Future;
use std::pin::pin;
use std::task::{Context, Poll, Waker};

use eamos_mid::mavlink::dialect::MavMessage;
use eamos_mid::mavlink::state::{Change, VehicleState};
use mavlink::error::MessageReadError;
use mavlink::AsyncMavlinkReader;

/// Runs a future whose reads come from memory: it never waits, so one poll
/// finishes it.
fn now<F: Future>(f: F) -> F::Output {
    let mut f = pin!(f);
    let mut cx = Context::from_waker(Waker::noop());
    match f.as_mut().poll(&mut cx) {
        Poll::Ready(v) => v,
        Poll::Pending => panic!("a read from memory waited"),
    }
}

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    let mut reader = AsyncMavlinkReader::new(data);
    let mut vehicle = VehicleState::new(None);
    let at = tokio::time::Instant::now();
    // Every round consumes input or ends it: at most one round per byte,
    // plus the one that meets the end.
    for _ in 0..=data.len() {
        match now(reader.read_any_message::<MavMessage>()) {
            Ok((header, message)) => {
                for change in vehicle.observe(&header, &message, at) {
                    if let (Change::Mode(_, m), Some(ap)) = (change, vehicle.autopilot) {
                        let _ = ap.mode_name(m);
                        let _ = ap.flight_mode(m);
                    }
                }
                let _ = vehicle.armed();
                let _ = vehicle.landed(0.0);
                let _ = vehicle.readiness.missing();
                let _ = vehicle.readiness.progress_line();
            }
            Err(MessageReadError::Parse(_)) => continue,
            Err(MessageReadError::Io(_)) => return,
        }
    }
    panic!("the reader did not reach the end of {} bytes", data.len());
}
