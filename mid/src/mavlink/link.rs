//! One MAVLink connection, shared: a receive task reads frames and hands
//! every decoded message to whoever subscribed; anyone may send.
//!
//! What the link does about the transport's quirks:
//! - Bytes that are not MAVLink (an autopilot's boot console on its first
//!   serial port, line noise) are skipped by the frame decoder, which
//!   resynchronises on the next start marker and checks every frame's CRC;
//!   a frame that passes the CRC but does not decode (a message or enum
//!   value this dialect does not know) is counted and skipped too. Neither
//!   is fatal.
//! - A `udpin` link cannot send until it has heard a peer (it does not know
//!   where to send); [`Link::send`] then reports `Ok(false)` instead of
//!   pretending the message left.
//! - A stream (TCP, serial) that ends is reopened every second until the
//!   link is dropped; the owner sees silence in the meantime, which is
//!   what it watches for anyway.
//!
//! Receives are cancellation-safe (the decoder keeps partial frames), so
//! the receive task can be stopped at any point.

use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Duration;

use mavlink::error::MessageReadError;
use mavlink::{AsyncConnection, AsyncMavConnection, MavHeader};
use tokio::sync::broadcast;
use tokio_util::sync::CancellationToken;

use super::address::ConnectAddress;
use super::dialect::MavMessage;

/// How many received messages a slow subscriber may fall behind before it
/// misses some (it is told how many it missed).
const BACKLOG: usize = 4096;

/// A message and who sent it.
#[derive(Debug, Clone)]
pub struct Received {
    pub header: MavHeader,
    pub message: MavMessage,
}

/// A MAVLink connection and its receive task. Dropping the link stops the
/// task and closes the connection.
pub struct Link {
    inner: Arc<Inner>,
}

struct Inner {
    address: ConnectAddress,
    local: Option<SocketAddr>,
    own: MavHeader,
    connection: RwLock<Option<Arc<AsyncConnection<MavMessage>>>>,
    incoming: broadcast::Sender<Arc<Received>>,
    stop: CancellationToken,
    skipped: AtomicU64,
    received: AtomicU64,
}

impl Link {
    /// Opens the connection and starts receiving. `own` is the identity
    /// this end sends with (system and component id).
    pub async fn open(address: &ConnectAddress, own: MavHeader) -> io::Result<Link> {
        let (connection, local) = address.open().await?;
        let (incoming, _) = broadcast::channel(BACKLOG);
        let inner = Arc::new(Inner {
            address: address.clone(),
            local,
            own,
            connection: RwLock::new(Some(Arc::new(connection))),
            incoming,
            stop: CancellationToken::new(),
            skipped: AtomicU64::new(0),
            received: AtomicU64::new(0),
        });
        tokio::spawn(receive(inner.clone()));
        Ok(Link { inner })
    }

    /// The address the link was opened with.
    pub fn address(&self) -> &ConnectAddress {
        &self.inner.address
    }

    /// The local address a listening link (`udpin`, `tcpin`) bound.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.inner.local
    }

    /// Every message received from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<Received>> {
        self.inner.incoming.subscribe()
    }

    /// Sends one message with this end's identity. `Ok(false)` when it
    /// could not leave: a `udpin` link that has not heard a peer yet, or a
    /// stream being reopened.
    pub async fn send(&self, message: &MavMessage) -> io::Result<bool> {
        let connection = self
            .inner
            .connection
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .clone();
        let Some(connection) = connection else {
            return Ok(false);
        };
        match connection.send(&self.inner.own, message).await {
            Ok(0) => Ok(false),
            Ok(_) => Ok(true),
            Err(mavlink::error::MessageWriteError::Io(e)) => Err(e),
            Err(e) => Err(io::Error::other(e.to_string())),
        }
    }

    /// Frames that passed the CRC but did not decode, skipped so far.
    pub fn skipped(&self) -> u64 {
        self.inner.skipped.load(Ordering::Relaxed)
    }

    /// Messages decoded so far.
    pub fn received(&self) -> u64 {
        self.inner.received.load(Ordering::Relaxed)
    }

    /// The identity this end sends with.
    pub fn own(&self) -> MavHeader {
        self.inner.own
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        self.inner.stop.cancel();
    }
}

async fn receive(inner: Arc<Inner>) {
    loop {
        let current = inner
            .connection
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .clone();
        let Some(connection) = current else {
            if !reopen(&inner).await {
                return;
            }
            continue;
        };
        let result = tokio::select! {
            _ = inner.stop.cancelled() => return,
            r = connection.recv() => r,
        };
        match result {
            Ok((header, message)) => {
                inner.received.fetch_add(1, Ordering::Relaxed);
                // No subscriber is not an error: nobody listens yet.
                let _ = inner.incoming.send(Arc::new(Received { header, message }));
            }
            Err(MessageReadError::Parse(e)) => {
                inner.skipped.fetch_add(1, Ordering::Relaxed);
                tracing::debug!(link = %inner.address, "skipped an undecodable MAVLink frame: {e}");
            }
            Err(MessageReadError::Io(e)) => {
                if inner.address.is_stream() {
                    tracing::warn!(link = %inner.address, "MAVLink connection lost: {e}; reopening");
                    *inner.connection.write().unwrap_or_else(|p| p.into_inner()) = None;
                } else {
                    // UDP receive errors (an ICMP unreachable bounced back
                    // from a peer not yet listening) are transient.
                    tracing::debug!(link = %inner.address, "UDP receive error: {e}");
                    tokio::select! {
                        _ = inner.stop.cancelled() => return,
                        _ = tokio::time::sleep(Duration::from_millis(50)) => {}
                    }
                }
            }
        }
    }
}

/// Tries to reopen a stream once a second until it works (true) or the
/// link is dropped (false).
async fn reopen(inner: &Inner) -> bool {
    // A listener that bound port 0 must come back on the port it got.
    let address = match (&inner.address, inner.local) {
        (ConnectAddress::TcpIn(_), Some(local)) => ConnectAddress::TcpIn(local.to_string()),
        (a, _) => a.clone(),
    };
    loop {
        tokio::select! {
            _ = inner.stop.cancelled() => return false,
            _ = tokio::time::sleep(Duration::from_secs(1)) => {}
        }
        let opened = tokio::select! {
            _ = inner.stop.cancelled() => return false,
            r = address.open() => r,
        };
        match opened {
            Ok((connection, _)) => {
                tracing::info!(link = %inner.address, "MAVLink connection reopened");
                *inner.connection.write().unwrap_or_else(|p| p.into_inner()) =
                    Some(Arc::new(connection));
                return true;
            }
            Err(e) => tracing::debug!(link = %inner.address, "reopening failed: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::dialect::{MavAutopilot, MavModeFlag, MavState, MavType, HEARTBEAT_DATA};
    use tokio::io::AsyncWriteExt;
    use tokio::time::timeout;

    const WAIT: Duration = Duration::from_secs(10);

    fn heartbeat(custom_mode: u32) -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    fn frame(seq: u8, message: &MavMessage) -> Vec<u8> {
        let mut out = Vec::new();
        mavlink::write_v2_msg(
            &mut out,
            MavHeader {
                system_id: 1,
                component_id: 1,
                sequence: seq,
            },
            message,
        )
        .unwrap();
        out
    }

    async fn next_custom_mode(rx: &mut broadcast::Receiver<Arc<Received>>) -> u32 {
        loop {
            let r = timeout(WAIT, rx.recv())
                .await
                .expect("a message in time")
                .unwrap();
            if let MavMessage::HEARTBEAT(hb) = &r.message {
                return hb.custom_mode;
            }
        }
    }

    #[tokio::test]
    async fn console_text_between_frames_on_a_tcp_stream_is_skipped() {
        // An autopilot's first serial port, as a TCP stream: boot text,
        // then frames with text and garbage between them.
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let port = listener.local_addr().unwrap().port();
        let writer = tokio::spawn(async move {
            let (mut stream, _) = listener.accept().await.unwrap();
            let mut bytes = b"ArduCopter V4.5.7 (2a3dc4b7)\r\nInit ArduCopter\r\n".to_vec();
            bytes.extend(frame(0, &heartbeat(1)));
            bytes.extend(b"\r\nEKF3 IMU0 initialised\r\n\xfd\x03garbage\xfe");
            bytes.extend(frame(1, &heartbeat(2)));
            // A frame cut in two by a console line: its CRC fails and it is
            // dropped, the next one still reads.
            let broken = frame(2, &heartbeat(99));
            bytes.extend(&broken[..6]);
            bytes.extend(b"Barometer calibration complete\r\n");
            bytes.extend(frame(3, &heartbeat(3)));
            stream.write_all(&bytes).await.unwrap();
            // The autopilot goes on talking; a decoder that took the stray
            // MAVLink 1 marker above for a long frame needs more bytes
            // before it can give up on it.
            for seq in 4..=255u8 {
                stream.write_all(&frame(seq, &heartbeat(10))).await.unwrap();
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        });
        let address = ConnectAddress::parse(&format!("tcpout:127.0.0.1:{port}")).unwrap();
        let link = Link::open(&address, MavHeader::default()).await.unwrap();
        let mut rx = link.subscribe();
        assert_eq!(next_custom_mode(&mut rx).await, 1);
        assert_eq!(next_custom_mode(&mut rx).await, 2);
        assert_eq!(next_custom_mode(&mut rx).await, 3);
        writer.abort();
    }

    #[tokio::test]
    async fn a_udpin_link_cannot_send_before_it_hears_a_peer_and_then_answers_it() {
        let listen = ConnectAddress::parse("udpin:127.0.0.1:0").unwrap();
        let gcs = Link::open(&listen, MavHeader::default()).await.unwrap();
        assert!(
            !gcs.send(&heartbeat(0)).await.unwrap(),
            "nowhere to send yet"
        );

        let port = gcs.local_addr().unwrap().port();
        let vehicle_addr = ConnectAddress::parse(&format!("udpout:127.0.0.1:{port}")).unwrap();
        let vehicle = Link::open(
            &vehicle_addr,
            MavHeader {
                system_id: 1,
                component_id: 1,
                sequence: 0,
            },
        )
        .await
        .unwrap();
        let mut at_gcs = gcs.subscribe();
        let mut at_vehicle = vehicle.subscribe();
        assert!(vehicle.send(&heartbeat(4)).await.unwrap());
        assert_eq!(next_custom_mode(&mut at_gcs).await, 4);
        // Now the ground station knows the vehicle's port and answers it.
        assert!(gcs.send(&heartbeat(7)).await.unwrap());
        assert_eq!(next_custom_mode(&mut at_vehicle).await, 7);
    }

    #[tokio::test]
    async fn a_frame_this_dialect_cannot_decode_is_counted_and_skipped() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let port = listener.local_addr().unwrap().port();
        let writer = tokio::spawn(async move {
            let (mut stream, _) = listener.accept().await.unwrap();
            // A HEARTBEAT whose autopilot field (byte 5 of the payload) is
            // out of the enum's range: the CRC is right, decoding fails.
            let mut bad = frame(0, &heartbeat(5));
            let payload_start = 10;
            bad[payload_start + 5] = 250;
            let crc_at = bad.len() - 2;
            let crc = mavlink::calculate_crc(&bad[1..crc_at], 50);
            bad[crc_at..].copy_from_slice(&crc.to_le_bytes());
            let mut bytes = bad;
            bytes.extend(frame(1, &heartbeat(6)));
            stream.write_all(&bytes).await.unwrap();
            tokio::time::sleep(WAIT).await;
        });
        let address = ConnectAddress::parse(&format!("tcp:127.0.0.1:{port}")).unwrap();
        let link = Link::open(&address, MavHeader::default()).await.unwrap();
        let mut rx = link.subscribe();
        assert_eq!(next_custom_mode(&mut rx).await, 6);
        assert_eq!(link.skipped(), 1);
        writer.abort();
    }
}
