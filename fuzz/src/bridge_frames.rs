//! Feeds arbitrary bytes to everything an agent decodes from the network:
//! a bridge frame (token or acknowledgement), a telemetry frame, and the
//! drone state inside a telemetry frame's body. Any peer on the network can
//! send these, so none may panic, and whatever decodes must encode back to
//! the same value.

use eamos_exec::transport::{Frame, TelemetryFrame};
use eamos_mid::Telemetry;

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    if let Ok(frame) = Frame::decode(data) {
        assert_eq!(Frame::decode(&frame.encode()).expect("re-decodes"), frame);
    }
    if let Ok(t) = TelemetryFrame::decode(data) {
        assert_eq!(TelemetryFrame::decode(&t.encode()).expect("re-decodes"), t);
        // The executor reads the body the same way.
        let _ = postcard::from_bytes::<Telemetry>(&t.body);
    }
    let _ = postcard::from_bytes::<Telemetry>(data);
}
