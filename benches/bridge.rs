//! Bridge latency: one token from drone A to drone B and back through the
//! executor's exactly-once bridges over zenoh on loopback, against a bare
//! zenoh ping-pong of a message of the same size between two sessions
//! configured alike, measured in the same run.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use tokio::sync::mpsc;
use zenoh::Wait;

use eamos_exec::transport::reliable::{Bridges, Delivered, RetransmitPolicy};
use eamos_exec::transport::zenoh::{self as zenoh_link, ZenohOptions};
use eamos_exec::transport::{BridgeMessage, Frame};

use eamos_bench::workload;

const MISSION: &str = "benchbridge";

/// Options of two peers: A listens, B listens and connects to A.
fn options() -> (ZenohOptions, ZenohOptions) {
    let a = workload::free_port().expect("a free port");
    let b = workload::free_port().expect("a free port");
    let a_end = format!("tcp/127.0.0.1:{a}");
    (
        ZenohOptions {
            listen: vec![a_end.clone()],
            connect: Vec::new(),
            scouting: false,
            ..ZenohOptions::default()
        },
        ZenohOptions {
            listen: vec![format!("tcp/127.0.0.1:{b}")],
            connect: vec![a_end],
            scouting: false,
            ..ZenohOptions::default()
        },
    )
}

/// Two bare sessions: B echoes on `pong` what arrives on `ping`.
struct Bare {
    ping: zenoh::pubsub::Publisher<'static>,
    pongs: mpsc::UnboundedReceiver<()>,
    _sessions: Vec<zenoh::Session>,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    payload: Vec<u8>,
}

impl Bare {
    async fn open(payload: Vec<u8>) -> Bare {
        let (oa, ob) = options();
        let a = zenoh::open(zenoh_link::config(&oa).expect("valid"))
            .await
            .expect("zenoh opens");
        let b = zenoh::open(zenoh_link::config(&ob).expect("valid"))
            .await
            .expect("zenoh opens");
        let pong = b.declare_publisher("bench/pong").await.expect("publisher");
        let echo = b
            .declare_subscriber("bench/ping")
            .callback(move |s| {
                let _ = pong.put(s.payload().to_bytes().into_owned()).wait();
            })
            .await
            .expect("subscriber");
        let (tx, pongs) = mpsc::unbounded_channel();
        let back = a
            .declare_subscriber("bench/pong")
            .callback(move |_| {
                let _ = tx.send(());
            })
            .await
            .expect("subscriber");
        let ping = a.declare_publisher("bench/ping").await.expect("publisher");
        let mut bare = Bare {
            ping,
            pongs,
            _sessions: vec![a, b],
            _subscribers: vec![echo, back],
            payload,
        };
        // Until the peers have met, pings go nowhere.
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            bare.ping.put(bare.payload.clone()).await.expect("put");
            if tokio::time::timeout(Duration::from_millis(100), bare.pongs.recv())
                .await
                .is_ok()
            {
                break;
            }
            assert!(Instant::now() < deadline, "the zenoh peers never met");
        }
        while bare.pongs.try_recv().is_ok() {}
        bare
    }

    async fn round(&mut self) {
        self.ping.put(self.payload.clone()).await.expect("put");
        self.pongs.recv().await.expect("a pong");
    }
}

/// Drones A and B with their bridges; B sends back every token it gets.
struct Pair {
    a: Bridges,
    a_delivered: mpsc::UnboundedReceiver<Delivered>,
    _b: tokio::task::JoinHandle<()>,
    next: u32,
}

impl Pair {
    async fn open() -> Pair {
        let (oa, ob) = options();
        let ea = zenoh_link::open(MISSION, "A", &[], &oa)
            .await
            .expect("zenoh opens");
        let eb = zenoh_link::open(MISSION, "B", &[], &ob)
            .await
            .expect("zenoh opens");
        ea.link
            .wait_for_peers(&["B".to_string()], Duration::from_secs(20))
            .await
            .expect("B shows up");
        eb.link
            .wait_for_peers(&["A".to_string()], Duration::from_secs(20))
            .await
            .expect("A shows up");
        let (a, a_delivered) = Bridges::start(
            MISSION,
            ea.link.clone(),
            ea.frames,
            RetransmitPolicy::default(),
        );
        let (b, mut b_delivered) = Bridges::start(
            MISSION,
            eb.link.clone(),
            eb.frames,
            RetransmitPolicy::default(),
        );
        let echo = tokio::spawn(async move {
            let _link = eb.link;
            while let Some(d) = b_delivered.recv().await {
                b.send("A", "b2", d.colour);
            }
        });
        let mut pair = Pair {
            a,
            a_delivered,
            _b: echo,
            next: 0,
        };
        // The first round also declares the publishers.
        pair.round().await;
        pair
    }

    async fn round(&mut self) {
        // A bridge carries a colour once: every round is another colour.
        self.next += 1;
        self.a.send("B", "b1", vec![self.next]);
        self.a_delivered.recv().await.expect("the token comes back");
    }
}

fn round_trip(c: &mut Criterion) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime");
    // The bare ping carries what a bridge token weighs on the wire.
    let payload = Frame::Token(BridgeMessage {
        mission: format!("{:064x}", 0),
        from: "A".into(),
        bridge: "b1".into(),
        colour: vec![1],
        seq: 1,
    })
    .encode();
    let mut bare = runtime.block_on(Bare::open(payload));
    let mut pair = runtime.block_on(Pair::open());
    let mut g = c.benchmark_group("bridge");
    g.measurement_time(Duration::from_secs(3));
    g.bench_function("zenoh_bare", |b| {
        b.iter_custom(|iters| {
            runtime.block_on(async {
                let t = Instant::now();
                for _ in 0..iters {
                    bare.round().await;
                }
                t.elapsed()
            })
        })
    });
    g.bench_function("round_trip", |b| {
        b.iter_custom(|iters| {
            runtime.block_on(async {
                let t = Instant::now();
                for _ in 0..iters {
                    pair.round().await;
                }
                t.elapsed()
            })
        })
    });
    g.finish();
}

criterion_group!(benches, round_trip);
criterion_main!(benches);
