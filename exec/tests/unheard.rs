//! What nobody listens to does not cross the network: a drone that joins
//! through a router costs the network nothing for its telemetry until some
//! peer subscribes to it, however many drones publish. Two things see to
//! it: zenoh (a client's router declares which keys are subscribed, and a
//! client sends nothing else) and the link, which does not even publish
//! then (`Audience::IfHeard`: each put cost the publisher zenoh's routing
//! match, most of a 250-drone fleet's work once it flew). This test holds
//! the first; taking the link's gate out does not fail it (50 against 140
//! bytes here), since zenoh's filter alone keeps the bytes off the wire.
//!
//! The drone reaches the router through a relay of our own that counts the
//! bytes it carries, so what the test sees is what crossed the network.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use eamos_exec::transport::zenoh::open;
use eamos_exec::transport::{Link, TelemetryFrame};
use eamos_fleet::{Mode, ZenohOptions};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

const MISSION: &str = "Unheard-1";

fn tcp(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Forwards every connection to `127.0.0.1:to`, counting the bytes that go
/// from the connecting side to `to`. Returns the port it listens on.
async fn relay(to: u16, sent: Arc<AtomicU64>) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    tokio::spawn(async move {
        while let Ok((inbound, _)) = listener.accept().await {
            let outbound = TcpStream::connect(("127.0.0.1", to)).await.unwrap();
            let (mut ri, mut wi) = inbound.into_split();
            let (mut ro, mut wo) = outbound.into_split();
            let sent = sent.clone();
            tokio::spawn(async move {
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n) = ri.read(&mut buf).await {
                    if n == 0 || wo.write_all(&buf[..n]).await.is_err() {
                        break;
                    }
                    sent.fetch_add(n as u64, Ordering::Relaxed);
                }
            });
            tokio::spawn(async move { tokio::io::copy(&mut ro, &mut wi).await });
        }
    });
    port
}

/// D1's telemetry sample number `seq`, of 64 bytes.
fn sample(seq: u64) -> TelemetryFrame {
    TelemetryFrame {
        mission: MISSION.into(),
        drone: "D1".into(),
        seq,
        body: vec![7; 64],
    }
}

/// Bytes the drone sends while it publishes `n` samples of telemetry, a
/// few milliseconds apart, counted from the first to a settling time after
/// the last.
async fn bytes_for(link: &dyn Link, sent: &AtomicU64, n: u64, first_seq: u64) -> u64 {
    let before = sent.load(Ordering::Relaxed);
    for seq in first_seq..first_seq + n {
        link.publish_telemetry(&sample(seq)).await.unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    sent.load(Ordering::Relaxed) - before
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drones_telemetry_crosses_the_network_only_while_a_peer_subscribes_to_it() {
    let router_port = free_port();
    let options = |mode, listen: Vec<String>, connect: Vec<String>| ZenohOptions {
        mode,
        listen,
        connect,
        ..ZenohOptions::default()
    };
    let _router = open(
        MISSION,
        "GCS",
        &[],
        &options(Mode::Router, vec![tcp(router_port)], vec![]),
    )
    .await
    .unwrap();
    let sent = Arc::new(AtomicU64::new(0));
    let through = relay(router_port, sent.clone()).await;
    let drone = open(
        MISSION,
        "D1",
        &[],
        &options(Mode::Client, vec![], vec![tcp(through)]),
    )
    .await
    .unwrap();
    drone
        .link
        .wait_for_peers(&["GCS".into()], Duration::from_secs(20))
        .await
        .unwrap();
    // Let the session's own declarations cross first.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let link = drone.link.clone();

    let unheard = bytes_for(link.as_ref(), &sent, 100, 1).await;

    // A peer whose conditions read D1's telemetry joins the router.
    let mut reader = open(
        MISSION,
        "D2",
        &["D1".into()],
        &options(Mode::Client, vec![], vec![tcp(router_port)]),
    )
    .await
    .unwrap();
    let mut seq = 1000;
    loop {
        seq += 1;
        link.publish_telemetry(&sample(seq)).await.unwrap();
        let heard = tokio::time::timeout(Duration::from_millis(200), reader.telemetry.recv());
        if let Ok(Some(_)) = heard.await {
            break;
        }
        assert!(seq < 1100, "the reader never heard D1's telemetry");
    }
    let heard = bytes_for(link.as_ref(), &sent, 100, 2000).await;

    // 100 samples of 64 bytes each, and more, cross while someone listens;
    // next to nothing (keep-alives) while nobody does.
    assert!(heard >= 100 * 64, "{heard} bytes sent while heard");
    assert!(
        unheard * 10 < heard,
        "{unheard} bytes sent while nobody listened, {heard} while heard"
    );
}
