//! The roll-out's refusals and bookkeeping, without a network.

use eamos_fleet::identity::{fleet_version, slice_digest};
use eamos_fleet::{Fleet, GCS};
use eamos_seal::{GroundKey, PublicKey, Sealed, CONTEXT_SLICE, CONTEXT_START};
use eamos_slicer::Slices;

use crate::gate::{Gate, Offer};
use crate::link::{rollout_endpoints, rollout_options};
use crate::sessions::Sessions;
use crate::wire::{encode, AgentStatus, Answer, Held, SliceBundle, StartCommand};

mod flight;

const MISSION: &str = "package M\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc main() {\n\tD1.Takeoff(2)\n\tD2.Takeoff(2)\n}\n";
const FLEET: &str = "[drones.D1]\nhome = { x = 0.0, y = 0.0, z = 0.0 }\n";

fn slices(mission: &str, fleet: &Fleet) -> Slices {
    let source = eamos_lang::SourceFile::new("m.go".to_string(), mission.to_string());
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&source, &profiles).unwrap();
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    eamos_fleet::identity::slice(&net, fleet).unwrap()
}

fn fleet(text: &str) -> Fleet {
    Fleet::parse(text, "fleet.toml", "M", &["D1".into(), "D2".into()]).unwrap()
}

fn gate(drone: &str, text: &str, trusted: Option<PublicKey>) -> Gate {
    Gate {
        drone: drone.into(),
        fleet: Fleet::parse_unbound(text, "fleet.toml").unwrap(),
        fleet_name: "fleet.toml".into(),
        trusted,
    }
}

const SESSION: &str = "0123456789abcdef0123456789abcdef";

fn offer(s: &Slices, drone: &str, session: &str, with_slice: bool) -> SliceBundle {
    let slice = s.get(drone).unwrap();
    SliceBundle {
        identity: s.mission_id.clone(),
        fleet: fleet_version(&fleet(FLEET)),
        session: session.into(),
        digest: slice_digest(slice),
        slice: with_slice.then(|| slice.to_bytes()),
    }
}

fn seal_offer(bundle: &SliceBundle, key: Option<&GroundKey>) -> Vec<u8> {
    match key {
        Some(k) => k.seal(CONTEXT_SLICE, encode(bundle)),
        None => Sealed::unsigned(CONTEXT_SLICE, encode(bundle)),
    }
    .to_bytes()
}

fn sealed_slice(s: &Slices, drone: &str, key: Option<&GroundKey>) -> Vec<u8> {
    let bundle = offer(s, drone, SESSION, true);
    let sealed = match key {
        Some(k) => k.seal(CONTEXT_SLICE, encode(&bundle)),
        None => Sealed::unsigned(CONTEXT_SLICE, encode(&bundle)),
    };
    sealed.to_bytes()
}

#[test]
fn a_signed_slice_for_this_drone_is_accepted_with_its_digest() {
    let key = GroundKey::generate().unwrap();
    let s = slices(MISSION, &fleet(FLEET));
    let g = gate("D2", FLEET, Some(key.public()));
    let offer = g.check_slice(&sealed_slice(&s, "D2", Some(&key)), None, &none());
    let Ok(Offer::New {
        slice,
        digest,
        session,
        ..
    }) = offer
    else {
        panic!("{offer:?}");
    };
    assert_eq!(slice.drone, "D2");
    assert_eq!(digest, slice_digest(s.get("D2").unwrap()));
    assert_eq!(session, SESSION);
}

#[test]
fn unsigned_altered_and_foreign_slices_are_refused_by_an_agent_with_a_key() {
    let (key, other) = (
        GroundKey::generate().unwrap(),
        GroundKey::generate().unwrap(),
    );
    let s = slices(MISSION, &fleet(FLEET));
    let g = gate("D2", FLEET, Some(key.public()));
    let e = g
        .check_slice(&sealed_slice(&s, "D2", None), None, &none())
        .unwrap_err();
    assert!(e.starts_with("not signed"), "{e}");
    let e = g
        .check_slice(&sealed_slice(&s, "D2", Some(&other)), None, &none())
        .unwrap_err();
    assert!(e.starts_with("unknown key"), "{e}");
    let mut altered = sealed_slice(&s, "D2", Some(&key));
    let n = altered.len();
    altered[n / 2] ^= 0x01;
    let e = g.check_slice(&altered, None, &none()).unwrap_err();
    assert!(
        e.starts_with("bad signature") || e.starts_with("not a sealed"),
        "{e}"
    );
    // Without a key, an unsigned slice passes.
    assert!(gate("D2", FLEET, None)
        .check_slice(&sealed_slice(&s, "D2", None), None, &none())
        .is_ok());
}

#[test]
fn a_slice_built_with_another_fleet_file_is_a_wrong_mission_version() {
    let s = slices(MISSION, &fleet(FLEET));
    let other = "[drones.D1]\nhome = { x = 5.0, y = 0.0, z = 0.0 }\n";
    let e = gate("D2", other, None)
        .check_slice(&sealed_slice(&s, "D2", None), None, &none())
        .unwrap_err();
    assert!(e.starts_with("wrong mission version"), "{e}");
}

#[test]
fn another_drones_slice_is_refused() {
    let s = slices(MISSION, &fleet(FLEET));
    let e = gate("D1", FLEET, None)
        .check_slice(&sealed_slice(&s, "D2", None), None, &none())
        .unwrap_err();
    assert!(e.contains("D2's slice") && e.contains("flies D1"), "{e}");
}

#[test]
fn a_start_for_another_version_than_the_slice_held_is_refused() {
    let key = GroundKey::generate().unwrap();
    let f = fleet(FLEET);
    let v1 = slices(MISSION, &f);
    let v2 = slices(&MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)"), &f);
    let g = gate("D2", FLEET, Some(key.public()));
    let held = Held {
        identity: v1.mission_id.clone(),
        digest: slice_digest(v1.get("D2").unwrap()),
        session: SESSION.into(),
    };
    let start = |s: &Slices| StartCommand {
        identity: s.mission_id.clone(),
        fleet: fleet_version(&f),
        session: SESSION.into(),
        issued_at_ms: 1,
        digests: ["D1", "D2"]
            .iter()
            .map(|d| (d.to_string(), slice_digest(s.get(d).unwrap())))
            .collect(),
        speed: 20.0,
        max_duration: None,
        seed: 0,
    };
    let ok = key.seal(CONTEXT_START, encode(&start(&v1))).to_bytes();
    assert!(g.check_start(&ok, Some(&held), &none()).is_ok());
    let newer = key.seal(CONTEXT_START, encode(&start(&v2))).to_bytes();
    let e = g.check_start(&newer, Some(&held), &none()).unwrap_err();
    assert!(e.starts_with("wrong mission version"), "{e}");
    let e = g.check_start(&ok, None, &none()).unwrap_err();
    assert!(e.starts_with("no slice"), "{e}");
    let unsigned = Sealed::unsigned(CONTEXT_START, encode(&start(&v1))).to_bytes();
    let e = g.check_start(&unsigned, Some(&held), &none()).unwrap_err();
    assert!(e.starts_with("not signed"), "{e}");
    // A signed slice is no start command.
    let e = g
        .check_start(&sealed_slice(&v1, "D2", Some(&key)), Some(&held), &none())
        .unwrap_err();
    assert!(e.contains("expected a signed start command"), "{e}");
}

fn none() -> Sessions {
    Sessions::default()
}

/// D2 holding v1's slice, offered in `session`; the start of v1 in
/// `session`, signed by `key`.
fn held_and_start(key: &GroundKey, session: &str) -> (Slices, Held, Vec<u8>) {
    let f = fleet(FLEET);
    let v1 = slices(MISSION, &f);
    let held = Held {
        identity: v1.mission_id.clone(),
        digest: slice_digest(v1.get("D2").unwrap()),
        session: session.into(),
    };
    let start = StartCommand {
        identity: v1.mission_id.clone(),
        fleet: fleet_version(&f),
        session: session.into(),
        issued_at_ms: 1,
        digests: ["D1", "D2"]
            .iter()
            .map(|d| (d.to_string(), slice_digest(v1.get(d).unwrap())))
            .collect(),
        speed: 20.0,
        max_duration: None,
        seed: 0,
    };
    let wire = key.seal(CONTEXT_START, encode(&start)).to_bytes();
    (v1, held, wire)
}

#[test]
fn a_start_replayed_after_its_session_was_started_is_refused_even_by_a_restarted_agent() {
    let key = GroundKey::generate().unwrap();
    let g = gate("D2", FLEET, Some(key.public()));
    let (_, held, start) = held_and_start(&key, SESSION);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("D2.sessions");
    let mut sessions = Sessions::load(&path).unwrap();
    let ok = g.check_start(&start, Some(&held), &sessions).unwrap();
    sessions.record(&ok.session, &ok.identity).unwrap();
    let e = g.check_start(&start, Some(&held), &sessions).unwrap_err();
    assert!(e.starts_with("replayed start command"), "{e}");
    assert!(e.contains(SESSION), "{e}");
    // The agent restarts: it remembers the session from its disk.
    let restarted = Sessions::load(&path).unwrap();
    let e = g.check_start(&start, Some(&held), &restarted).unwrap_err();
    assert!(e.starts_with("replayed start command"), "{e}");
}

#[test]
fn a_session_record_that_cannot_be_read_or_written_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let e = Sessions::load(dir.path()).unwrap_err();
    assert!(
        e.starts_with("cannot read") && e.contains(&dir.path().display().to_string()),
        "{e}"
    );
    let mut gone = Sessions::load(&dir.path().join("no-such-dir").join("D2.sessions")).unwrap();
    let e = gone.record(SESSION, "M-1").unwrap_err();
    assert!(e.starts_with("cannot record the session"), "{e}");
    assert!(
        !gone.contains(SESSION),
        "a start not recorded is not obeyed"
    );
}

#[test]
fn a_slice_offer_of_a_session_already_started_is_refused_as_a_replay() {
    let key = GroundKey::generate().unwrap();
    let s = slices(MISSION, &fleet(FLEET));
    let g = gate("D2", FLEET, Some(key.public()));
    let mut sessions = Sessions::default();
    sessions.record(SESSION, &s.mission_id).unwrap();
    let e = g
        .check_slice(&sealed_slice(&s, "D2", Some(&key)), None, &sessions)
        .unwrap_err();
    assert!(e.starts_with("replayed slice"), "{e}");
}

#[test]
fn a_start_of_another_deploy_session_than_the_one_that_offered_the_slice_is_refused() {
    let key = GroundKey::generate().unwrap();
    let g = gate("D2", FLEET, Some(key.public()));
    let (_, held, start) = held_and_start(&key, SESSION);
    let offered_later = Held {
        session: "fedcba9876543210fedcba9876543210".into(),
        ..held
    };
    let e = g
        .check_start(&start, Some(&offered_later), &none())
        .unwrap_err();
    assert!(e.starts_with("start command of another deploy"), "{e}");
    assert!(e.contains("fedcba98"), "{e}");
}

#[test]
fn a_keep_offer_rebinds_the_slice_held_to_the_new_session_and_no_other_slice() {
    let key = GroundKey::generate().unwrap();
    let s = slices(MISSION, &fleet(FLEET));
    let g = gate("D2", FLEET, Some(key.public()));
    let later = "fedcba9876543210fedcba9876543210";
    let keep = seal_offer(&offer(&s, "D2", later, false), Some(&key));
    let held = Held {
        identity: s.mission_id.clone(),
        digest: slice_digest(s.get("D2").unwrap()),
        session: SESSION.into(),
    };
    match g.check_slice(&keep, Some(&held), &none()) {
        Ok(Offer::Keep { digest, session }) => {
            assert_eq!(digest, held.digest);
            assert_eq!(session, later);
        }
        other => panic!("{other:?}"),
    }
    let e = g.check_slice(&keep, None, &none()).unwrap_err();
    assert!(e.starts_with("no slice"), "{e}");
    let other = Held {
        digest: "0".repeat(32),
        ..held
    };
    let e = g.check_slice(&keep, Some(&other), &none()).unwrap_err();
    assert!(e.starts_with("no such slice"), "{e}");
}

#[test]
fn an_offer_whose_slice_does_not_match_its_digest_or_whose_session_is_malformed_is_refused() {
    let s = slices(MISSION, &fleet(FLEET));
    let g = gate("D2", FLEET, None);
    let mut wrong = offer(&s, "D2", SESSION, true);
    wrong.digest = "0".repeat(32);
    let e = g
        .check_slice(&seal_offer(&wrong, None), None, &none())
        .unwrap_err();
    assert!(e.starts_with("damaged slice"), "{e}");
    let odd = offer(&s, "D2", "x\nD9 forged", true);
    let e = g
        .check_slice(&seal_offer(&odd, None), None, &none())
        .unwrap_err();
    assert!(e.starts_with("malformed deploy session"), "{e}");
}

#[test]
fn roll_out_messages_with_trailing_bytes_or_garbage_are_errors_not_panics() {
    let s = slices(MISSION, &fleet(FLEET));
    let mut b = offer(&s, "D2", SESSION, true).to_bytes();
    assert!(SliceBundle::from_bytes(&b).is_ok());
    b.push(0);
    assert!(SliceBundle::from_bytes(&b).is_err());
    for junk in [&[][..], &[0xff; 7], b"start"] {
        assert!(StartCommand::from_bytes(junk).is_err());
        assert!(AgentStatus::from_bytes(junk).is_err());
        assert!(Answer::from_bytes(junk).is_err());
    }
}

#[test]
fn an_unchanged_drone_keeps_its_slice_under_the_new_identity() {
    let f = fleet(FLEET);
    let v1 = slices(MISSION, &f);
    let v2 = slices(&MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)"), &f);
    assert_ne!(v1.mission_id, v2.mission_id);
    assert_eq!(
        slice_digest(v1.get("D1").unwrap()),
        slice_digest(v2.get("D1").unwrap())
    );
    let mut kept = v1.get("D1").unwrap().clone();
    kept.mission_id = v2.mission_id.clone();
    assert_eq!(&kept, v2.get("D1").unwrap());
}

#[test]
fn roll_out_endpoints_default_to_a_loopback_port_of_the_fleet_and_agents_connect_to_them() {
    let f = fleet(FLEET);
    let (listen, connect) = rollout_endpoints(&f);
    assert_eq!(listen, connect);
    assert!(listen[0].starts_with("tcp/127.0.0.1:"));
    let g =
        fleet("[rollout]\nlisten = [\"tcp/0.0.0.0:7400\"]\nconnect = [\"tcp/10.0.0.1:7400\"]\n");
    assert_eq!(
        rollout_endpoints(&g),
        (
            vec!["tcp/0.0.0.0:7400".to_string()],
            vec!["tcp/10.0.0.1:7400".to_string()]
        )
    );
    assert!(rollout_options(&g, "D1").listen.is_empty());
    assert!(rollout_options(&g, GCS).connect.is_empty());
}

#[test]
fn an_agent_prints_its_rollout_events_and_leaves_a_flight_to_its_logs() {
    use eamos_exec::event::Kind;
    let refused = Kind::RolloutRefused {
        what: "start command".into(),
        reason: "replayed".into(),
    };
    assert_eq!(
        crate::describe(&refused).as_deref(),
        Some("refused a start command: replayed")
    );
    let ended = Kind::RolloutEnded {
        identity: "M-1".into(),
        outcome: "completed".into(),
    };
    assert_eq!(
        crate::describe(&ended).as_deref(),
        Some("mission M-1 ended: completed")
    );
    let flight = Kind::PeerLost { peer: "D2".into() };
    assert!(crate::describe(&flight).is_none() && !flight.is_rollout());
}
