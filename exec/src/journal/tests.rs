//! The journal as a file (torn tails, damage, another mission's journal)
//! and its replay over a slice (the marking, the messages to send again,
//! the actions to resume).

use super::*;

use std::path::Path;

fn sent(to: &str, bridge: &str, colour: &[u32], seq: u64) -> Record {
    Record::Sent(Sent {
        to: to.into(),
        bridge: bridge.into(),
        colour: colour.to_vec(),
        seq,
    })
}

fn some_records() -> Vec<Record> {
    vec![
        Record::Consumed {
            from: "GCS".into(),
            bridge: "0".into(),
            colour: vec![],
            seq: 1,
        },
        Record::Fired {
            transition: "t3".into(),
            colour: vec![2],
        },
        sent("D2", "4", &[2], 7),
        Record::Started(Started {
            instance: 3,
            colour: vec![],
            call: ActionCall::new("FlyByX", vec![5.0]),
            target: Some(Vec3::new(5.0, 0.0, 1.5)),
            time: 12.5,
        }),
        Record::Acked {
            to: "D2".into(),
            bridge: "4".into(),
            colour: vec![2],
        },
        Record::Finished {
            instance: 3,
            colour: vec![],
            error: None,
        },
    ]
}

/// A journal file holding the header and `records`.
fn journal_with(dir: &Path, records: &[Record]) -> PathBuf {
    let path = Journal::path(dir, "D1");
    let opened = Journal::open(&path, "M-1", "D1").unwrap();
    assert!(opened.records.is_empty());
    for r in records {
        opened.journal.append(r, false).unwrap();
    }
    path
}

#[test]
fn records_read_back_as_they_were_written_after_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let opened = Journal::open(&path, "M-1", "D1").unwrap();
    assert_eq!(opened.records, some_records());
    assert_eq!(opened.torn, 0);
}

#[test]
fn a_journal_cut_anywhere_reads_as_the_records_before_the_cut_and_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let bytes = std::fs::read(&path).unwrap();
    let header = encode(&Record::Header {
        format: FORMAT,
        mission_id: "M-1".into(),
        peer: "D1".into(),
    })
    .len();
    // Where each record ends, from the header on.
    let mut ends = vec![header];
    for r in some_records() {
        ends.push(ends.last().unwrap() + encode(&r).len());
    }
    assert_eq!(*ends.last().unwrap(), bytes.len());
    for cut in 0..=bytes.len() {
        let read = decode("D1.journal", &bytes[..cut]).unwrap();
        let whole = ends.iter().filter(|e| **e <= cut).count();
        assert_eq!(read.records.len(), whole, "cut at {cut}");
        assert_eq!(read.intact + read.torn, cut as u64);
    }
}

#[test]
fn a_torn_last_record_is_cut_off_and_the_journal_goes_on_after_the_intact_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let full = std::fs::read(&path).unwrap();
    std::fs::write(&path, &full[..full.len() - 3]).unwrap();

    let opened = Journal::open(&path, "M-1", "D1").unwrap();
    assert_eq!(opened.records, some_records()[..5].to_vec());
    assert!(opened.torn > 0);
    let again = Record::Resumed { time: 20.0 };
    opened.journal.append(&again, true).unwrap();
    drop(opened);

    let reopened = Journal::open(&path, "M-1", "D1").unwrap();
    assert_eq!(reopened.torn, 0);
    assert_eq!(reopened.records.last(), Some(&again));
    assert_eq!(reopened.records.len(), 6);
}

#[test]
fn a_last_record_whose_checksum_does_not_match_is_taken_for_a_torn_write() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    let read = decode("D1.journal", &bytes).unwrap();
    assert_eq!(read.records.len(), 1 + some_records().len() - 1);
    assert!(read.torn > 0);
}

#[test]
fn a_zero_filled_end_left_by_a_power_cut_is_a_torn_write() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.extend_from_slice(&[0; 37]);
    let read = decode("D1.journal", &bytes).unwrap();
    assert_eq!(read.records.len(), 1 + some_records().len());
    assert_eq!(read.torn, 37);
}

#[test]
fn a_damaged_record_followed_by_intact_ones_is_refused_with_its_offset() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let mut bytes = std::fs::read(&path).unwrap();
    let header = encode(&Record::Header {
        format: FORMAT,
        mission_id: "M-1".into(),
        peer: "D1".into(),
    })
    .len();
    // A bit flipped in the payload of the first record after the header.
    bytes[header + HEADER + 1] ^= 0x01;
    std::fs::write(&path, &bytes).unwrap();
    let err = Journal::open(&path, "M-1", "D1").err().unwrap();
    match &err {
        JournalError::Damaged { offset, reason, .. } => {
            assert_eq!(*offset, header as u64);
            assert!(reason.contains("checksum"), "{reason}");
        }
        other => panic!("expected damage, got {other}"),
    }
    assert!(err.to_string().contains(&format!("byte {header}")));
    // The damaged journal is left as it was for whoever looks at it.
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
}

#[test]
fn a_damaged_length_followed_by_intact_records_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let mut bytes = std::fs::read(&path).unwrap();
    let header = encode(&Record::Header {
        format: FORMAT,
        mission_id: "M-1".into(),
        peer: "D1".into(),
    })
    .len();
    bytes[header + 3] = 0x7f;
    assert!(matches!(
        decode("D1.journal", &bytes),
        Err(JournalError::Damaged { .. })
    ));
}

#[test]
fn a_journal_of_another_mission_or_peer_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &some_records());
    let err = Journal::open(&path, "M-2", "D1").err().unwrap();
    assert!(matches!(err, JournalError::Foreign { .. }), "{err}");
    assert!(err.to_string().contains("mission M-1, peer D1"), "{err}");
    let err = Journal::open(&path, "M-1", "D2").err().unwrap();
    assert!(matches!(err, JournalError::Foreign { .. }), "{err}");
}

#[test]
fn a_journal_that_does_not_start_with_its_header_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("D1.journal");
    std::fs::write(&path, encode(&Record::Resumed { time: 1.0 })).unwrap();
    assert!(matches!(
        Journal::open(&path, "M-1", "D1"),
        Err(JournalError::Damaged { .. })
    ));
}

#[test]
fn a_journal_in_a_directory_that_cannot_be_made_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let err = Journal::open(&file.join("sub").join("D1.journal"), "M-1", "D1")
        .err()
        .unwrap();
    assert!(err.to_string().contains("plain-file"), "{err}");
}

// Replay over a real slice.

pub(crate) fn slices(mission: &str) -> eamos_slicer::Slices {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/missions/paper")
        .join(mission);
    let file = eamos_lang::SourceFile::new(mission, std::fs::read_to_string(path).unwrap());
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    eamos_slicer::slice(eamos_petri::compile(&m, &profiles)).unwrap()
}

fn transition(slice: &Slice, kind: &str, name: &str) -> (String, u32) {
    slice
        .transitions
        .iter()
        .find_map(|t| match &t.transition.kind {
            TransitionKind::ActionStart(a) if kind == "start" && a.name == name => {
                Some((t.transition.id.to_string(), a.instance))
            }
            TransitionKind::ActionEnd(a) if kind == "end" && a.name == name => {
                Some((t.transition.id.to_string(), a.instance))
            }
            _ => None,
        })
        .unwrap()
}

#[test]
fn an_empty_journal_replays_to_the_initial_marking() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let r = replay(slice, "j", &[]).unwrap();
    assert!(!r.is_resume());
    let marked: Vec<u32> = (0..slice.places.len() as u32)
        .filter(|p| !r.marking[*p as usize].is_empty())
        .collect();
    let mut initial = slice.initial_marking.clone();
    initial.sort();
    initial.dedup();
    assert_eq!(marked, initial);
}

#[test]
fn a_firing_whose_message_was_not_journaled_as_sent_is_sent_on_resume() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let b = &slice.bridges_out[0];
    let t = &slice.transitions[b.transition as usize].transition.id;
    let fired = Record::Fired {
        transition: t.to_string(),
        colour: vec![],
    };
    let r = replay(slice, "j", std::slice::from_ref(&fired)).unwrap();
    assert_eq!(r.unsent, vec![(b.to.clone(), b.id.to_string(), vec![])]);
    let r = replay(slice, "j", &[fired, sent(&b.to, &b.id.to_string(), &[], 4)]).unwrap();
    assert!(r.unsent.is_empty());
    assert_eq!(r.unacked.len(), 1);
    assert_eq!(r.unacked[0].seq, 4, "sent again with its own number");
    assert_eq!(r.last_seq, 4);
}

#[test]
fn messages_acknowledged_before_the_crash_are_not_sent_again() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let r = replay(
        slice,
        "j",
        &[
            sent("D2", "end", &[], 1),
            sent("GCS", "end", &[], 2),
            Record::Acked {
                to: "GCS".into(),
                bridge: "end".into(),
                colour: vec![],
            },
        ],
    )
    .unwrap();
    assert_eq!(r.unacked.len(), 1);
    assert_eq!(r.unacked[0].to, "D2");
    assert_eq!(r.sent, 0, "notices are not bridge tokens");
}

#[test]
fn an_action_started_and_not_finished_is_resumed_towards_its_journaled_target() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let (start, instance) = transition(slice, "start", "FlyByX");
    let target = Some(Vec3::new(1.0, 0.0, 1.5));
    let records = vec![
        Record::Fired {
            transition: start,
            colour: vec![],
        },
        Record::Started(Started {
            instance,
            colour: vec![],
            call: ActionCall::new("FlyByX", vec![1.0]),
            target,
            time: 9.0,
        }),
    ];
    let r = replay(slice, "j", &records).unwrap();
    assert_eq!(r.interrupted.len(), 1);
    assert_eq!(r.interrupted[0].target, target);
    assert_eq!(r.started, vec![(instance, vec![])]);
    assert!(r.not_started.is_empty());

    let mut finished = records.clone();
    finished.push(Record::Finished {
        instance,
        colour: vec![],
        error: None,
    });
    let r = replay(slice, "j", &finished).unwrap();
    assert!(r.interrupted.is_empty());
    assert!(r.succeeded.contains(&(instance, vec![])));

    // Fired but never handed to the drone: started afresh.
    let r = replay(slice, "j", &records[..1]).unwrap();
    assert_eq!(r.not_started, vec![(instance, vec![])]);
    assert!(r.interrupted.is_empty());
}

#[test]
fn an_action_that_failed_before_the_crash_leaves_the_mission_failed() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let (start, instance) = transition(slice, "start", "Arm");
    let r = replay(
        slice,
        "j",
        &[
            Record::Fired {
                transition: start,
                colour: vec![],
            },
            Record::Started(Started {
                instance,
                colour: vec![],
                call: ActionCall::new("Arm", vec![]),
                target: None,
                time: 0.0,
            }),
            Record::Finished {
                instance,
                colour: vec![],
                error: Some("refused".into()),
            },
        ],
    )
    .unwrap();
    assert!(r.failed.as_deref().unwrap().contains("refused"));
}

#[test]
fn a_journal_naming_a_transition_or_bridge_the_slice_lacks_is_refused() {
    let s = slices("experiment_b.go");
    let slice = s.get("Drone1").unwrap();
    let err = replay(
        slice,
        "D1.journal",
        &[Record::Fired {
            transition: "no-such-transition".into(),
            colour: vec![],
        }],
    )
    .unwrap_err();
    assert!(err.to_string().contains("no-such-transition"), "{err}");
    let err = replay(
        slice,
        "D1.journal",
        &[Record::Consumed {
            from: "D2".into(),
            bridge: "9999".into(),
            colour: vec![],
            seq: 1,
        }],
    )
    .unwrap_err();
    assert!(err.to_string().contains("9999"), "{err}");
}

#[test]
fn an_airframe_record_reads_back_and_a_missing_one_is_none() {
    let dir = tempfile::tempdir().unwrap();
    let path = airframe_path(dir.path(), "D1");
    assert_eq!(read_airframe(&path).unwrap(), None);
    let a = Airframe {
        time: 4.25,
        position: Vec3::new(1.0, 2.0, 3.0),
        armed: true,
        battery: 97.5,
    };
    write_airframe(&path, &a).unwrap();
    assert_eq!(read_airframe(&path).unwrap(), Some(a));
    std::fs::write(&path, "{ not json").unwrap();
    assert!(read_airframe(&path).is_err());
}

// Pauses, and the journal's format.

const PAUSING: &str = "package Pausing

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(2)
	PauseFor(60)
	D1.Land()
}
";

pub(crate) fn pausing() -> eamos_slicer::Slices {
    let file = eamos_lang::SourceFile::new("pausing.go", PAUSING);
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    eamos_slicer::slice(eamos_petri::compile(&m, &profiles)).unwrap()
}

fn pause_transition(slice: &Slice) -> String {
    slice
        .transitions
        .iter()
        .find(|t| t.transition.delay.is_some())
        .map(|t| t.transition.id.to_string())
        .unwrap()
}

fn paused(transition: &str, time: f64) -> Record {
    Record::Paused(Paused {
        transition: transition.into(),
        colour: vec![],
        time,
        wall_ms: 1_000_000,
    })
}

#[test]
fn a_pause_begun_before_the_crash_is_recovered_until_its_transition_fires() {
    let s = pausing();
    let slice = s.get("D1").unwrap();
    let pause = pause_transition(slice);
    let r = replay(slice, "j", &[paused(&pause, 12.5)]).unwrap();
    assert_eq!(
        r.paused,
        vec![Paused {
            transition: pause.clone(),
            colour: vec![],
            time: 12.5,
            wall_ms: 1_000_000,
        }]
    );
    let fired = Record::Fired {
        transition: pause.clone(),
        colour: vec![],
    };
    let r = replay(slice, "j", &[paused(&pause, 12.5), fired]).unwrap();
    assert!(r.paused.is_empty(), "{:?}", r.paused);
    let err = replay(slice, "j", &[paused("t999", 1.0)]).err().unwrap();
    assert!(err.to_string().contains("t999"), "{err}");
}

#[test]
fn a_resumed_pause_keeps_its_mission_time_on_a_simulated_clock_and_counts_the_wall_clock_otherwise()
{
    let p = Paused {
        transition: "t1".into(),
        colour: vec![],
        time: 40.0,
        wall_ms: 1_000_000,
    };
    // The simulation went on from the recorded airframes' time.
    assert_eq!(pause_began(&p, true, 55.0, 9_999_999), 40.0);
    // A wall clock restarted at 0 with the agent; 25 s passed in the world.
    assert_eq!(pause_began(&p, false, 2.0, 1_025_000), -23.0);
    // Neither clock makes a pause begin after the restart.
    assert_eq!(pause_began(&p, true, 30.0, 0), 30.0);
    assert_eq!(pause_began(&p, false, 2.0, 999_000), 2.0);
}

#[test]
fn a_new_journal_names_its_format_and_a_later_format_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = journal_with(dir.path(), &[]);
    let bytes = std::fs::read(&path).unwrap();
    let first = decode("j", &bytes).unwrap().records;
    assert_eq!(
        first,
        vec![Record::Header {
            format: FORMAT,
            mission_id: "M-1".into(),
            peer: "D1".into(),
        }]
    );
    let later = dir.path().join("later.journal");
    std::fs::write(
        &later,
        encode(&Record::Header {
            format: FORMAT + 1,
            mission_id: "M-1".into(),
            peer: "D1".into(),
        }),
    )
    .unwrap();
    let err = Journal::open(&later, "M-1", "D1").err().unwrap();
    assert!(matches!(err, JournalError::Format { found, .. } if found == FORMAT + 1));
    assert!(err.to_string().contains("later.journal"), "{err}");
    assert!(
        err.to_string().contains(&format!("format {}", FORMAT + 1)),
        "{err}"
    );
}

#[test]
fn a_journal_of_format_1_without_a_format_number_is_read_as_it_was_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("D1.journal");
    let mut bytes = encode(&Record::Opened {
        mission_id: "M-1".into(),
        peer: "D1".into(),
    });
    for r in some_records() {
        bytes.extend(encode(&r));
    }
    std::fs::write(&path, bytes).unwrap();
    let opened = Journal::open(&path, "M-1", "D1").unwrap();
    assert_eq!(opened.records, some_records());
    assert!(matches!(
        Journal::open(&path, "M-2", "D1"),
        Err(JournalError::Foreign { .. })
    ));
}
