//! Feeds arbitrary bytes to everything the roll-out and the abort path
//! decode from the network: the sealed envelope, the slice offer and the
//! start command inside it (through the agent's own checks, with and
//! without a trusted key), the status and answers the ground station
//! reads, and an abort command in a bridge token's colour. Anyone on the
//! roll-out network can send these, so none may panic, and whatever
//! decodes must encode back to bytes that decode the same.

use std::sync::OnceLock;

use eamos_exec::abort::{self, AbortCommand, CommandOpener};
use eamos_fleet::Fleet;
use eamos_rollout::{AgentStatus, Answer, Gate, Held, Sessions, SliceBundle, StartCommand};
use eamos_seal::{PublicKey, Sealed, CONTEXT_ABORT, CONTEXT_SLICE, CONTEXT_START};

/// The ground station key that signed the seeds under
/// `corpus/deploy_messages/`, so that the signed paths are reached.
const TRUSTED: &str = "-----BEGIN PUBLIC KEY-----\nMCowBQYDK2VwAyEAT+5GHfdAM0EtqhqbD6z+Q2ZQQSJTwDpxn3I0jN5hxno=\n-----END PUBLIC KEY-----\n";

struct Fixture {
    trusting: Gate,
    open: Gate,
    opener: CommandOpener,
    peers: Vec<String>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let key = PublicKey::from_pem(TRUSTED, "trusted.pub").expect("a valid key");
        let gate = |trusted: Option<PublicKey>| Gate {
            drone: "Drone1".into(),
            fleet: Fleet::default(),
            fleet_name: "fleet.toml".into(),
            trusted,
        };
        Fixture {
            trusting: gate(Some(key.clone())),
            open: gate(None),
            opener: abort::opener_since(key, 0),
            peers: ["GCS", "Drone1", "Drone2"].map(String::from).to_vec(),
        }
    })
}

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    let f = fixture();
    if let Ok(sealed) = Sealed::from_bytes(data) {
        let bytes = sealed.to_bytes();
        assert_eq!(Sealed::from_bytes(&bytes).expect("re-decodes"), sealed);
        for context in [CONTEXT_SLICE, CONTEXT_START, CONTEXT_ABORT] {
            let _ = sealed.open_untrusted(context);
        }
    }
    if let Ok(b) = SliceBundle::from_bytes(data) {
        let bytes = b.to_bytes();
        assert_eq!(SliceBundle::from_bytes(&bytes).expect("re-decodes"), b);
    }
    if let Ok(s) = StartCommand::from_bytes(data) {
        // Compared as bytes: a NaN speed is not equal to itself.
        let bytes = s.to_bytes();
        let again = StartCommand::from_bytes(&bytes).expect("re-decodes");
        assert_eq!(again.to_bytes(), bytes);
    }
    let _ = AgentStatus::from_bytes(data);
    let _ = Answer::from_bytes(data);
    // The agent's checks, as its queryables run them on what arrives.
    let held = Held {
        identity: "M-1".into(),
        digest: "0".repeat(32),
        session: "0".repeat(32),
    };
    let started = Sessions::default();
    for gate in [&f.trusting, &f.open] {
        let _ = gate.check_slice(data, None, &started);
        let _ = gate.check_slice(data, Some(&held), &started);
        let _ = gate.check_start(data, Some(&held), &started);
    }
    // An abort command: its bytes in a colour, and the colour as words.
    let _ = AbortCommand::from_payload(data);
    for opener in [None, Some(&f.opener)] {
        let _ = abort::accept("abort-1", &abort::pack(data), "M-1", &f.peers, opener);
        let words: Vec<u32> = data
            .chunks(4)
            .map(|w| {
                let mut b = [0u8; 4];
                b[..w.len()].copy_from_slice(w);
                u32::from_le_bytes(b)
            })
            .collect();
        let _ = abort::accept("Drone2", &words, "M-1", &f.peers, opener);
    }
}
