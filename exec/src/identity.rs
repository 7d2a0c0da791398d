//! The mission identity: which mission, in which version, with which fleet.
//!
//! Every message between peers (bridge tokens, acknowledgements, telemetry,
//! zenoh key expressions) carries the identity, and a peer drops what
//! carries another. It is `<mission name>-<version>`, where the version is
//! a hash of the mission's net and of the fleet file in canonical form: two
//! missions, or two versions of one mission, or one mission flown with two
//! different fleet files (another home, another adapter, another key) never
//! mix, while re-indenting the fleet file, reordering its keys or editing
//! its comments changes nothing.
//!
//! The slice digest ([`slice_digest`]) is the other half of a roll-out: what
//! a slice makes its drone do, without the identity (which changes with any
//! edit anywhere in the mission or the fleet), without source spans (which
//! move when a line is added above) and without labels (which describe a
//! wait in words: "after Drone2.FlyByY(1 m)" changes with Drone2's part).
//! Equal digests mean the drone's part did not change, so `eamos deploy`
//! need not send it again; the drone then keeps the labels of the version
//! it got, in its logs.

use serde_json::Value;
use sha3::{Digest, Sha3_256};

use eamos_slicer::{Slice, Slices};

use crate::fleet::Fleet;

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// JSON with object keys sorted at every level and no whitespace: one text
/// per value, whatever order its maps were built in.
pub fn canonical_json(v: &Value) -> String {
    let mut out = String::new();
    write_canonical(v, &mut out);
    out
}

fn write_canonical(v: &Value, out: &mut String) {
    match v {
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            out.push('{');
            for (i, k) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&Value::String(k.clone()).to_string());
                out.push(':');
                write_canonical(&map[k], out);
            }
            out.push('}');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_canonical(item, out);
            }
            out.push(']');
        }
        other => out.push_str(&other.to_string()),
    }
}

/// The digest of a fleet file's text in canonical form (the TOML read as
/// values, written back as canonical JSON): layout, comments, key order and
/// quoting style do not count; every value does. Text that is not TOML is
/// hashed as it is (such a file never gets as far as a mission).
pub fn fleet_digest(text: &str) -> String {
    let canonical = match toml::from_str::<toml::Table>(text) {
        Ok(table) => match serde_json::to_value(&table) {
            Ok(v) => canonical_json(&v),
            Err(_) => text.to_string(),
        },
        Err(_) => text.to_string(),
    };
    hex(&Sha3_256::digest(canonical.as_bytes()))
}

/// The digest of a fleet as read: that of its file, or of an empty file
/// when there is none (every drone simulated, loopback endpoints).
pub fn fleet_version(fleet: &Fleet) -> String {
    if fleet.digest.is_empty() {
        fleet_digest("")
    } else {
        fleet.digest.clone()
    }
}

/// `<mission>-<version>`: the version is the first 96 bits of the hash of
/// the net's identity (as the slicer computes it) and the fleet's digest.
pub fn mission_identity(mission: &str, net_id: &str, fleet_digest: &str) -> String {
    let mut h = Sha3_256::new();
    h.update(b"eamos-mission/1\0");
    h.update(net_id.as_bytes());
    h.update([0]);
    h.update(fleet_digest.as_bytes());
    let digest = h.finalize();
    format!("{mission}-{}", hex(&digest[..12]))
}

/// Scopes freshly cut slices by the mission identity of their net *and*
/// fleet. Call once, right after slicing: the slicer's `mission_id` (the
/// net's hash) is what it starts from.
pub fn bind(slices: &mut Slices, fleet: &Fleet) {
    let id = mission_identity(&slices.mission, &slices.mission_id, &fleet_version(fleet));
    slices.mission_id = id.clone();
    for s in &mut slices.slices {
        s.mission_id = id.clone();
    }
}

/// The mission name and the version of an identity (`None` for an identity
/// without a version, such as a hand-written one in a test).
pub fn split(identity: &str) -> Option<(&str, &str)> {
    identity
        .rsplit_once('-')
        .filter(|(name, version)| !name.is_empty() && !version.is_empty())
}

/// What a slice makes its drone do: the hash of the slice without its
/// mission identity, source spans and labels.
pub fn slice_digest(slice: &Slice) -> String {
    let mut v = serde_json::to_value(slice).expect("a slice always serialises");
    if let Value::Object(map) = &mut v {
        map.remove("mission_id");
    }
    strip_descriptions(&mut v);
    hex(&Sha3_256::digest(canonical_json(&v).as_bytes()))[..32].to_string()
}

/// Removes what describes the mission to people rather than what it does.
fn strip_descriptions(v: &mut Value) {
    match v {
        Value::Object(map) => {
            map.remove("span");
            if map.get("label").is_some_and(Value::is_string) {
                map.remove("label");
            }
            for (_, x) in map.iter_mut() {
                strip_descriptions(x);
            }
        }
        Value::Array(items) => items.iter_mut().for_each(strip_descriptions),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slices(text: &str) -> Slices {
        let source = eamos_lang::SourceFile::new("m.go".to_string(), text.to_string());
        let profiles = eamos_profile::builtin();
        let compiled = eamos_lang::compile(&source, &profiles).expect("the mission checks");
        let net = eamos_petri::compile(&compiled.mission, &profiles);
        eamos_slicer::slice(&net).expect("the mission slices")
    }

    const MISSION: &str = "package M\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc main() {\n\tD1.Takeoff(2)\n\tD2.Takeoff(2)\n}\n";

    fn fleet(text: &str) -> Fleet {
        Fleet::parse(text, "f.toml", "M", &["D1".into(), "D2".into()]).unwrap()
    }

    fn identity(mission: &str, fleet_text: &str) -> String {
        let mut s = slices(mission);
        bind(&mut s, &fleet(fleet_text));
        assert!(s.slices.iter().all(|x| x.mission_id == s.mission_id));
        s.mission_id
    }

    #[test]
    fn layout_comments_and_key_order_of_the_fleet_file_do_not_change_the_identity() {
        let a = "[sim]\nstep = 0.02\n\n[drones.D1]\nhome = { x = 1.0, y = 0.0, z = 0.0 }\n";
        let b = "# the same fleet\n[drones.D1]\nhome = {z=0.0,   x=1.0, y=0.0}\n[sim]\n  step = 0.02 # s\n";
        assert_eq!(identity(MISSION, a), identity(MISSION, b));
    }

    #[test]
    fn any_fleet_setting_changes_the_identity() {
        let base = identity(
            MISSION,
            "[drones.D1]\nhome = { x = 1.0, y = 0.0, z = 0.0 }\n",
        );
        let moved = identity(
            MISSION,
            "[drones.D1]\nhome = { x = 1.5, y = 0.0, z = 0.0 }\n",
        );
        let keyed = identity(
            MISSION,
            "[keys]\ngcs = \"gcs.pub\"\n[drones.D1]\nhome = { x = 1.0, y = 0.0, z = 0.0 }\n",
        );
        assert_ne!(base, moved);
        assert_ne!(base, keyed);
        assert_ne!(moved, keyed);
    }

    #[test]
    fn an_edit_of_the_mission_changes_the_identity_but_keeps_its_name() {
        let edited = MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)");
        let (a, b) = (identity(MISSION, ""), identity(&edited, ""));
        assert_ne!(a, b);
        assert_eq!(split(&a).unwrap().0, "M");
        assert_eq!(split(&b).unwrap().0, "M");
        assert_ne!(split(&a).unwrap().1, split(&b).unwrap().1);
    }

    #[test]
    fn no_fleet_file_and_an_empty_one_are_the_same_fleet() {
        let mut s = slices(MISSION);
        bind(&mut s, &Fleet::default());
        assert_eq!(s.mission_id, identity(MISSION, ""));
    }

    #[test]
    fn a_slice_digest_changes_only_with_what_its_drone_does() {
        let edited = MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)");
        // A line added above moves every span, and changes no behaviour.
        let shifted = MISSION.replace("func main", "// a comment\nfunc main");
        let (a, b, c) = (slices(MISSION), slices(&edited), slices(&shifted));
        let d = |s: &Slices, who: &str| slice_digest(s.get(who).unwrap());
        assert_eq!(d(&a, "D1"), d(&b, "D1"));
        assert_ne!(d(&a, "D2"), d(&b, "D2"));
        assert_eq!(d(&a, "D1"), d(&c, "D1"));
        assert_eq!(d(&a, "D2"), d(&c, "D2"));
        let mut bound = a.clone();
        bind(&mut bound, &fleet("[sim]\nstep = 0.01\n"));
        assert_eq!(d(&a, "D1"), d(&bound, "D1"));
    }

    #[test]
    fn a_drone_waiting_on_an_edited_drone_keeps_its_digest() {
        let seq = "package M\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc main() {\n\tD2.Takeoff(2)\n\tD1.Takeoff(2)\n}\n";
        let edited = seq.replace("D2.Takeoff(2)", "D2.Takeoff(3)");
        let (a, b) = (slices(seq), slices(&edited));
        let d = |s: &Slices, who: &str| slice_digest(s.get(who).unwrap());
        assert_eq!(d(&a, "D1"), d(&b, "D1"));
        assert_ne!(d(&a, "D2"), d(&b, "D2"));
    }

    #[test]
    fn canonical_json_sorts_keys_at_every_level() {
        let v: Value =
            serde_json::from_str(r#"{"b":1,"a":{"d":[{"z":1,"y":2}],"c":"x"}}"#).unwrap();
        assert_eq!(
            canonical_json(&v),
            r#"{"a":{"c":"x","d":[{"y":2,"z":1}]},"b":1}"#
        );
    }
}
