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
//! The identity is computed once, from the net and the fleet, before the
//! net is cut ([`slice`]): every slice is born carrying it, and nothing
//! rewrites it afterwards. The slicer's own hash of the net
//! ([`eamos_slicer::net_id`]) is one of its inputs, under its own name.
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

use std::fmt;

use eamos_petri::net::Net;
use eamos_slicer::{Slice, SliceError, Slices};

use crate::canonical::{canonical_json, fleet_digest, hex};
use crate::file::Fleet;

/// The digest of a fleet as read: that of its file, or of an empty file
/// when there is none (every drone simulated, loopback endpoints).
pub fn fleet_version(fleet: &Fleet) -> String {
    if fleet.digest.is_empty() {
        fleet_digest("")
    } else {
        fleet.digest.clone()
    }
}

/// The mission identity, `<mission>-<version>`: the version is the first
/// 96 bits of the hash of the net's hash (as the slicer computes it) and
/// the fleet's digest.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct MissionId(String);

impl MissionId {
    /// The identity of `mission` whose net hashes to `net_id`, flown with
    /// the fleet whose digest is `fleet_digest`.
    pub fn new(mission: &str, net_id: &str, fleet_digest: &str) -> MissionId {
        let mut h = Sha3_256::new();
        h.update(b"eamos-mission/1\0");
        h.update(net_id.as_bytes());
        h.update([0]);
        h.update(fleet_digest.as_bytes());
        let digest = h.finalize();
        MissionId(format!("{mission}-{}", hex(&digest[..12])))
    }

    /// The identity of `net` flown with `fleet`.
    pub fn of(net: &Net, fleet: &Fleet) -> MissionId {
        MissionId::new(&net.name, &eamos_slicer::net_id(net), &fleet_version(fleet))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for MissionId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// Cuts `net` into slices scoped by the mission identity of the net *and*
/// the fleet: a peer built from another mission or fleet file refuses
/// them.
pub fn slice(net: &Net, fleet: &Fleet) -> Result<Slices, SliceError> {
    eamos_slicer::slice_as(net, MissionId::of(net, fleet).as_str())
}

/// The mission name and the version of an identity (`None` for an identity
/// without a version, such as a hand-written one in a test).
pub fn split(identity: &str) -> Option<(&str, &str)> {
    identity
        .rsplit_once('-')
        .filter(|(name, version)| !name.is_empty() && !version.is_empty())
}

/// What a slice makes its drone do: the hash of the slice without its
/// mission identity, source spans and labels. It hashes the slice file's
/// own form ([`eamos_slicer::wire`]), not the compiler's types, so that it
/// changes when the file format does and never because the compiler
/// renamed a field.
pub fn slice_digest(slice: &Slice) -> String {
    let wire = eamos_slicer::wire::v3::Slice::from(slice);
    let mut v = serde_json::to_value(&wire).expect("a slice always serialises");
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

    fn net(text: &str) -> eamos_petri::net::Net {
        let source = eamos_lang::SourceFile::new("m.go".to_string(), text.to_string());
        let profiles = eamos_profile::builtin();
        let compiled = eamos_lang::compile(&source, &profiles).expect("the mission checks");
        eamos_petri::compile(&compiled.mission, &profiles)
    }

    /// Slices named by their net alone, as the slicer cuts them without a
    /// fleet.
    fn slices(text: &str) -> Slices {
        eamos_slicer::slice(net(text)).expect("the mission slices")
    }

    const MISSION: &str = "package M\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc main() {\n\tD1.Takeoff(2)\n\tD2.Takeoff(2)\n}\n";

    fn fleet(text: &str) -> Fleet {
        Fleet::parse(text, "f.toml", "M", &["D1".into(), "D2".into()]).unwrap()
    }

    fn identity(mission: &str, fleet_text: &str) -> String {
        let n = net(mission);
        let s = slice(&n, &fleet(fleet_text)).expect("the mission slices");
        assert!(s.slices.iter().all(|x| x.mission_id == s.mission_id));
        assert_eq!(s.mission_id, MissionId::of(&n, &fleet(fleet_text)).as_str());
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
        let fenced = identity(
            MISSION,
            "[airspace]\nceiling = 120.0\n[drones.D1]\nhome = { x = 1.0, y = 0.0, z = 0.0 }\n",
        );
        let lowered = identity(
            MISSION,
            "[airspace]\nceiling = 100.0\n[drones.D1]\nhome = { x = 1.0, y = 0.0, z = 0.0 }\n",
        );
        assert_ne!(base, moved);
        assert_ne!(base, keyed);
        assert_ne!(moved, keyed);
        assert_ne!(base, fenced);
        assert_ne!(fenced, lowered);
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
        let s = slice(&net(MISSION), &Fleet::default()).unwrap();
        assert_eq!(s.mission_id, identity(MISSION, ""));
    }

    #[test]
    fn the_identity_is_not_the_nets_hash_and_names_the_mission() {
        let n = net(MISSION);
        let id = MissionId::of(&n, &Fleet::default());
        assert_ne!(id.as_str(), eamos_slicer::net_id(&n));
        assert_eq!(split(id.as_str()).unwrap().0, "M");
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
        let bound = slice(&net(MISSION), &fleet("[sim]\nstep = 0.01\n")).unwrap();
        assert_ne!(bound.mission_id, a.mission_id);
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
}
