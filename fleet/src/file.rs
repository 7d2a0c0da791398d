//! The fleet file: which adapter flies which drone of a mission, where each
//! drone's home is, where the fleet may fly, and how the peers (drones'
//! agents and the ground station) reach each other over zenoh.
//!
//! ```toml
//! origin = { lat = 46.6139, lon = 14.2650 }  # the fleet frame's 0 on the earth (optional)
//!
//! [airspace]                       # where the fleet may fly (optional)
//! fence = [[-5.0, -5.0], [50.0, -5.0], [50.0, 50.0], [-5.0, 50.0]]  # [x north, y east], metres
//! ceiling = 120.0                  # metres above home
//! separation = 2.0                 # least distance between two drones, metres
//!
//! [zenoh]
//! scouting = false                 # multicast scouting (off by default)
//! routers = ["tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"]  # join through routers (optional)
//!
//! [sim]                            # simulator settings (optional)
//! step = 0.02
//!
//! [gcs]
//! listen = ["tcp/127.0.0.1:7447"]  # zenoh endpoints of the ground station
//!
//! [keys]
//! gcs = "gcs.pub"                  # agents run only what this key signed
//!
//! [rollout]                        # where `eamos deploy` meets the agents
//! listen = ["tcp/127.0.0.1:7400"]  # the ground station listens there
//!
//! [failsafe]                       # liveness and abort (fleet-wide)
//! on_lost = "land"                 # hold | land | home | abort
//! grace = "5s"                     # mission time a lost peer has to come back
//! on_abort = "land"                # land | home | hold
//!
//! [drones.D1]
//! adapter = "sim"                  # the default
//! home = { x = 0.0, y = 0.0, z = 0.0 }
//! on_lost = "home"                 # this drone's own policy
//!
//! [drones.D2]
//! home = { lat = 46.61395, lon = 14.2650, alt = 0.0 }  # 5.6 m north of `origin`
//!
//! [drones.D3]
//! home = { x = 0.0, y = 4.0, z = 0.0 }
//! script = { legs = [{ leg = "go_to", x = -15.0, y = -10.0, z = 5.0, speed = 5.0 }] }
//!
//! [drones.D4]
//! adapter = "mavlink"
//! connect = "udpin:0.0.0.0:14550"     # MAVLink, as MAVLink tools spell it
//! zenoh = { listen = ["tcp/192.168.1.14:7447"] }
//!
//! [drones.D4.mavlink]                 # adapter settings, all optional
//! ready_timeout = 180
//! ```
//!
//! The origin and the airspace (a fence may also be a GeoJSON file) are
//! read into the fleet frame once, with every home, when the file is read:
//! see `file/airspace.rs`. Without an `[airspace]` table the fleet flies in
//! [`eamos_geo::Airspace::default`].
//!
//! A drone's `connect` is its MAVLink connection (the older spelling
//! `connection` is accepted too); its zenoh endpoints, like the ground
//! station's, are `listen` and `connect` lists, given in the drone's
//! `zenoh` table.
//!
//! A drone the file does not name is simulated, at a home of its own (see
//! [`default_home`]). A peer without `listen` endpoints listens on a
//! loopback port derived from the mission and the peer (see
//! [`loopback_port`]); every peer connects to every other peer's endpoints
//! unless it lists its own `connect` endpoints. With `routers`, no peer
//! listens: each joins as a client of the first router that answers, and
//! of the next one when it is lost (see `eamos router`).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use eamos_geo::{Airspace, Home, LocalFrame, Wgs84};
use eamos_mid::mavlink::{ConnectAddress, MavlinkSettings};
use eamos_mid::sim::kinematics::MultirotorConfig;
use eamos_mid::sim::script::Script;
use eamos_mid::sim::{SimConfig, SimDroneSpec};
use eamos_mid::{Failsafe, Vec3};

use crate::canonical::fleet_digest_with;
use crate::policy::{Grace, Liveness, OnLost};

mod airspace;
mod geojson;
mod tls;
use airspace::{AirspaceTable, Origin};
pub use tls::{FleetTls, PeerTls};

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fleet {
    #[serde(default)]
    pub zenoh: ZenohSettings,
    /// Simulator settings; `--speed` overrides the speed.
    #[serde(default)]
    pub sim: Option<SimConfig>,
    #[serde(default)]
    pub gcs: PeerNet,
    #[serde(default)]
    pub drones: BTreeMap<String, DroneEntry>,
    /// Who signs what agents run.
    #[serde(default)]
    pub keys: KeySettings,
    /// Where `eamos deploy` and the agents meet before a mission exists
    /// (see `eamos_rollout`).
    #[serde(default)]
    pub rollout: PeerNet,
    /// The digest of the file in canonical form, part of the mission
    /// identity (see [`crate::identity`]); empty when there is no file.
    #[serde(skip)]
    pub digest: String,
    /// What drones do when a peer they wait on is lost, and when the
    /// mission is aborted: the fleet's defaults (see [`crate::policy`]).
    #[serde(default)]
    pub failsafe: FailsafeSettings,
    /// The fleet frame's 0 on the earth, as written (see [`Fleet::origin`]).
    #[serde(default, rename = "origin")]
    origin_table: Option<toml::Spanned<Origin>>,
    /// `[airspace]` as written (see [`Fleet::airspace`]).
    #[serde(default, rename = "airspace")]
    airspace_table: Option<AirspaceTable>,
    #[serde(skip)]
    origin: Option<Wgs84>,
    #[serde(skip)]
    airspace: Airspace,
}

/// The fleet-wide liveness and abort policy; each drone may override it
/// with the same keys in its own table.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailsafeSettings {
    /// `hold`, `land`, `home` or `abort` (default `land`).
    #[serde(default)]
    pub on_lost: Option<OnLost>,
    /// How long a lost peer has to come back, in mission seconds or with a
    /// unit (`"5s"`, `"500ms"`; default 5 s).
    #[serde(default)]
    pub grace: Option<Grace>,
    /// Where a drone goes when the mission is aborted or stopped: `land`
    /// (the default), `home` or `hold`.
    #[serde(default)]
    pub on_abort: Option<Failsafe>,
}

/// The ground station's signing key, as agents know it.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeySettings {
    /// The ground station's public key (PEM, relative to the fleet file,
    /// resolved by [`Fleet::load`];
    /// `eamos keygen` writes one). When given, an agent runs only slices
    /// and obeys only commands that this key signed.
    #[serde(default)]
    pub gcs: Option<std::path::PathBuf>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZenohSettings {
    #[serde(default)]
    pub scouting: bool,
    /// The endpoints of the fleet's zenoh routers (`eamos router`): when
    /// given, every peer joins through them as a client instead of
    /// connecting to every other peer.
    #[serde(default)]
    pub routers: Vec<String>,
    /// TLS with mutual authentication for every peer (see [`FleetTls`]).
    #[serde(default)]
    pub tls: Option<FleetTls>,
}

/// How one peer joins the zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PeerNet {
    #[serde(default)]
    pub listen: Vec<String>,
    #[serde(default)]
    pub connect: Vec<String>,
    /// This peer's TLS certificate and key (see [`PeerTls`]).
    #[serde(default)]
    pub tls: Option<PeerTls>,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AdapterKind {
    #[default]
    Sim,
    Mavlink,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DroneEntry {
    #[serde(default)]
    pub adapter: AdapterKind,
    /// Home as written: in the fleet frame (metres north, east, up of the
    /// fleet's origin) or in WGS84 (placed through the fleet's `origin`);
    /// [`Fleet::home`] is the point of the frame.
    #[serde(default)]
    pub home: Option<Home>,
    /// The home in the fleet frame, placed when the file is read.
    #[serde(skip)]
    local_home: Option<Vec3>,
    /// The simulated airframe (sim only).
    #[serde(default)]
    pub vehicle: Option<MultirotorConfig>,
    /// A scripted pilot (sim only).
    #[serde(default)]
    pub script: Option<Script>,
    /// MAVLink connection (`udpin:0.0.0.0:14550`, `tcpout:...`, serial),
    /// checked when the file is read.
    #[serde(default, alias = "connection", deserialize_with = "mavlink_connection")]
    pub connect: Option<String>,
    /// The MAVLink adapter's settings (MAVLink only).
    #[serde(default, deserialize_with = "MavlinkSettings::deserialize_checked")]
    pub mavlink: Option<MavlinkSettings>,
    /// How the drone's agent joins zenoh.
    #[serde(default)]
    pub zenoh: PeerNet,
    /// Zenoh endpoints given where they used to be: refused with a pointer
    /// to the `zenoh` table.
    #[serde(default, rename = "listen", deserialize_with = "moved_to_zenoh")]
    moved_listen: Option<()>,
    /// This drone's policy when a peer it waits on is lost (overrides
    /// `[failsafe]`).
    #[serde(default)]
    pub on_lost: Option<OnLost>,
    #[serde(default)]
    pub grace: Option<Grace>,
    #[serde(default)]
    pub on_abort: Option<Failsafe>,
}

/// A drone's `connect` is a MAVLink connection string; a list is the old
/// place of its zenoh endpoints.
fn mavlink_connection<'de, D>(deserializer: D) -> Result<Option<String>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    use serde::de::Error;
    match toml::Value::deserialize(deserializer)? {
        toml::Value::String(s) => match ConnectAddress::parse(&s) {
            Ok(_) => Ok(Some(s)),
            Err(e) => Err(D::Error::custom(e)),
        },
        toml::Value::Array(_) => Err(D::Error::custom(
            "a drone's `connect` is its MAVLink connection (\"udpin:0.0.0.0:14550\"); zenoh endpoints go in its zenoh table: `zenoh = { connect = [...] }`",
        )),
        other => Err(D::Error::custom(format!(
            "`connect` must be a MAVLink connection string such as \"udpin:0.0.0.0:14550\", not a {}",
            other.type_str()
        ))),
    }
}

fn moved_to_zenoh<'de, D>(deserializer: D) -> Result<Option<()>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let _ = toml::Value::deserialize(deserializer)?;
    Err(serde::de::Error::custom(
        "a drone's zenoh endpoints go in its zenoh table: `zenoh = { listen = [...] }`",
    ))
}

#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    #[error("cannot read fleet file {path}: {error}")]
    Read { path: String, error: String },
    /// The TOML error names line and column.
    #[error("{path}: {error}")]
    Parse { path: String, error: String },
    #[error("{path}: drone `{drone}` is not a drone of mission {mission} (its drones: {known})")]
    UnknownDrone {
        path: String,
        drone: String,
        mission: String,
        known: String,
    },
    #[error("{path}: drone `{drone}`: {problem}")]
    Drone {
        path: String,
        drone: String,
        problem: String,
    },
    /// In the fleet's `origin` or `[airspace]`; `at` is `file:line:column`
    /// of the value at fault.
    #[error("{at}: {problem}")]
    Airspace { at: String, problem: String },
}

impl Fleet {
    /// Reads and checks a fleet file against the mission's drones. Every
    /// path it names (certificates, keys) is made relative to the file's
    /// directory here, once: nothing downstream resolves a path again.
    pub fn load(path: &Path, mission: &str, drones: &[String]) -> Result<Fleet, FleetError> {
        let text = read(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut fleet = Fleet::parse_in(&text, &path.display().to_string(), base, mission, drones)?;
        fleet.resolve_paths(base);
        Ok(fleet)
    }

    /// The fleet file a command was given, read as [`Fleet::load`] reads
    /// it, or the default fleet when it was given none (every drone
    /// simulated, loopback endpoints).
    pub fn load_or_default(
        path: Option<&Path>,
        mission: &str,
        drones: &[String],
    ) -> Result<Fleet, FleetError> {
        match path {
            Some(path) => Fleet::load(path, mission, drones),
            None => Ok(Fleet::default()),
        }
    }

    /// Reads an agent's fleet file before any mission is known: checked
    /// against the drones it names itself (against the mission's drones
    /// once a slice says which they are), its paths resolved as
    /// [`Fleet::load`] does.
    pub fn load_unbound(path: &Path) -> Result<Fleet, FleetError> {
        let text = read(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut fleet = Fleet::parse_unbound_in(&text, &path.display().to_string(), base)?;
        fleet.resolve_paths(base);
        Ok(fleet)
    }

    /// Parses fleet text against the drones it names itself (a GeoJSON
    /// fence relative to the working directory).
    pub fn parse_unbound(text: &str, name: &str) -> Result<Fleet, FleetError> {
        Fleet::parse_unbound_in(text, name, Path::new(""))
    }

    fn parse_unbound_in(text: &str, name: &str, base: &Path) -> Result<Fleet, FleetError> {
        let named: Vec<String> = toml::from_str::<toml::Table>(text)
            .ok()
            .and_then(|t| t.get("drones").and_then(|d| d.as_table()).cloned())
            .map(|d| d.keys().cloned().collect())
            .unwrap_or_default();
        Fleet::parse_in(text, name, base, "the fleet", &named)
    }

    /// Checks a fleet read before its mission was known
    /// ([`Fleet::parse_unbound`]) against the mission's drones, as
    /// [`Fleet::parse`] would have: every drone it names is one of them,
    /// and with TLS every one of them has a certificate. `name` is what
    /// errors call the file.
    pub fn check_mission(
        &self,
        name: &str,
        mission: &str,
        drones: &[String],
    ) -> Result<(), FleetError> {
        if let Some(d) = self.drones.keys().find(|d| !drones.contains(d)) {
            return Err(unknown_drone(name, mission, drones, d));
        }
        self.check_tls(name, drones)
    }

    /// Makes every relative path of the file relative to `base`, its
    /// directory, rather than to wherever the command runs.
    fn resolve_paths(&mut self, base: &Path) {
        self.resolve_tls_paths(base);
        if let Some(k) = &mut self.keys.gcs {
            if k.is_relative() {
                *k = base.join(&*k);
            }
        }
    }

    /// Parses fleet text; `name` is what errors call the file. A GeoJSON
    /// fence it names is read relative to the working directory.
    pub fn parse(
        text: &str,
        name: &str,
        mission: &str,
        drones: &[String],
    ) -> Result<Fleet, FleetError> {
        Fleet::parse_in(text, name, Path::new(""), mission, drones)
    }

    /// [`Fleet::parse`], a GeoJSON fence read relative to `base`.
    fn parse_in(
        text: &str,
        name: &str,
        base: &Path,
        mission: &str,
        drones: &[String],
    ) -> Result<Fleet, FleetError> {
        let mut fleet: Fleet = toml::from_str(text).map_err(|e| FleetError::Parse {
            path: name.to_string(),
            error: e.to_string().trim_end().to_string(),
        })?;
        let space = airspace::resolve(
            fleet.origin_table.as_ref(),
            fleet.airspace_table.as_ref(),
            base,
        )
        .map_err(|p| FleetError::Airspace {
            at: location(text, name, p.span.start),
            problem: p.what,
        })?;
        fleet.origin = space.origin;
        fleet.airspace = space.airspace;
        let frame = fleet.origin.map(LocalFrame::new);
        for (drone, entry) in &mut fleet.drones {
            if !drones.contains(drone) {
                return Err(unknown_drone(name, mission, drones, drone));
            }
            let problem = |p: &str| FleetError::Drone {
                path: drone_location(text, name, drone),
                drone: drone.clone(),
                problem: p.to_string(),
            };
            match entry.adapter {
                AdapterKind::Mavlink => {
                    if entry.connect.is_none() {
                        return Err(problem(
                            "a MAVLink drone needs `connect`, its MAVLink connection (for example \"udpin:0.0.0.0:14550\")",
                        ));
                    }
                    if entry.script.is_some() || entry.vehicle.is_some() {
                        return Err(problem(
                            "`script` and `vehicle` describe simulated drones, not MAVLink ones",
                        ));
                    }
                }
                AdapterKind::Sim => {
                    if entry.connect.is_some() || entry.mavlink.is_some() {
                        return Err(problem(
                            "`connect` and `mavlink` are for MAVLink drones; add `adapter = \"mavlink\"` (zenoh endpoints go in `zenoh = { connect = [...] }`)",
                        ));
                    }
                }
            }
            if let Some(h) = entry.home {
                let home = h
                    .resolve(frame.as_ref())
                    .map_err(|e| problem(&e.to_string()))?;
                entry.local_home = Some(home);
            }
            if let Some(s) = &entry.script {
                s.validate().map_err(|e| problem(&format!("script: {e}")))?;
            }
        }
        if let Some(sim) = &fleet.sim {
            sim.validate().map_err(|e| FleetError::Parse {
                path: name.to_string(),
                error: format!("[sim]: {e}"),
            })?;
        }
        fleet.check_tls(name, drones)?;
        fleet.digest = fleet_digest_with(text, space.geojson.as_ref());
        Ok(fleet)
    }

    /// The liveness policy of a peer: its own keys, else the fleet's
    /// `[failsafe]` table, else the defaults (land after 5 s).
    pub fn liveness(&self, peer: &str) -> Liveness {
        let e = self.drones.get(peer);
        let d = Liveness::default();
        let f = &self.failsafe;
        Liveness {
            on_lost: e.and_then(|e| e.on_lost).or(f.on_lost).unwrap_or(d.on_lost),
            grace: e.and_then(|e| e.grace).or(f.grace).map_or(d.grace, |g| g.0),
            on_abort: e
                .and_then(|e| e.on_abort)
                .or(f.on_abort)
                .unwrap_or(d.on_abort),
        }
    }

    pub fn entry(&self, drone: &str) -> DroneEntry {
        self.drones.get(drone).cloned().unwrap_or_default()
    }

    /// The home of a drone in the fleet frame: as the fleet file says, or
    /// the default for the `index`-th drone of the mission.
    pub fn home(&self, drone: &str, index: usize) -> Vec3 {
        self.drones
            .get(drone)
            .and_then(|e| e.local_home)
            .unwrap_or_else(|| default_home(index))
    }

    /// The homes of a mission's drones, in the mission's order (defaults
    /// included), as [`Fleet::home`] places each.
    pub fn homes(&self, drones: &[String]) -> Vec<Vec3> {
        drones
            .iter()
            .enumerate()
            .map(|(i, d)| self.home(d, i))
            .collect()
    }

    /// The fleet frame's 0 on the earth, if the file gives it (`origin`).
    pub fn origin(&self) -> Option<Wgs84> {
        self.origin
    }

    /// Where the fleet may fly, in the fleet frame: the `[airspace]` table
    /// as read, or no fence, no ceiling, the ground as the floor and the
    /// default separation ([`eamos_geo::DEFAULT_SEPARATION`]).
    pub fn airspace(&self) -> &Airspace {
        &self.airspace
    }

    /// The simulated drone as the fleet file describes it.
    pub fn sim_spec(&self, drone: &str, index: usize) -> SimDroneSpec {
        let e = self.entry(drone);
        SimDroneSpec {
            name: drone.to_string(),
            home: self.home(drone, index),
            vehicle: e.vehicle.unwrap_or_default(),
            script: e.script,
        }
    }
}

fn unknown_drone(name: &str, mission: &str, drones: &[String], drone: &str) -> FleetError {
    FleetError::UnknownDrone {
        path: name.to_string(),
        drone: drone.to_string(),
        mission: mission.to_string(),
        known: drones.join(", "),
    }
}

fn read(path: &Path) -> Result<String, FleetError> {
    std::fs::read_to_string(path).map_err(|e| FleetError::Read {
        path: path.display().to_string(),
        error: e.to_string(),
    })
}

/// `file:line:column` of a drone's table, for errors found after parsing
/// (just the file if the table cannot be found again).
fn drone_location(text: &str, name: &str, drone: &str) -> String {
    #[derive(Deserialize)]
    struct Spans {
        #[serde(default)]
        drones: BTreeMap<String, toml::Spanned<toml::Value>>,
    }
    match toml::from_str::<Spans>(text)
        .ok()
        .and_then(|s| s.drones.get(drone).map(|v| v.span().start))
    {
        Some(start) => location(text, name, start),
        None => name.to_string(),
    }
}

/// `file:line:column` of the byte `offset` of the file's text.
fn location(text: &str, name: &str, offset: usize) -> String {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("{name}:{line}:{column}")
}

pub use eamos_geo::default_home;

#[cfg(test)]
mod tests {
    use super::*;

    fn drones() -> Vec<String> {
        vec!["D1".into(), "D2".into(), "D3".into()]
    }

    #[test]
    fn a_drone_the_mission_does_not_have_is_named_with_the_known_ones() {
        let e = Fleet::parse("[drones.D9]\n", "f.toml", "M", &drones()).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("D9") && msg.contains("D1, D2, D3"), "{msg}");
    }

    #[test]
    fn a_typo_in_a_key_is_reported_with_its_line() {
        let e = Fleet::parse(
            "[drones.D1]\nhome = { x = 0.0, y = 0.0, z = 0.0 }\nadaptor = \"sim\"\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("f.toml") && msg.contains("line 3"), "{msg}");
    }

    #[test]
    fn a_mavlink_drone_without_a_connection_is_refused_at_its_table() {
        let e = Fleet::parse(
            "[drones.D2]\nhome = { x = 0.0, y = 0.0, z = 0.0 }\n\n[drones.D1]\nadapter = \"mavlink\"\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("f.toml:4:1: drone `D1`"), "{msg}");
        assert!(msg.contains("needs `connect`"), "{msg}");
    }

    #[test]
    fn a_simulated_drone_with_a_mavlink_connection_or_settings_is_refused() {
        for text in [
            "[drones.D1]\nconnect = \"udpin:0.0.0.0:1\"\n",
            "[drones.D1]\nmavlink = { ready_timeout = 10 }\n",
        ] {
            let e = Fleet::parse(text, "f.toml", "M", &drones()).unwrap_err();
            let msg = e.to_string();
            assert!(msg.starts_with("f.toml:1:1: drone `D1`"), "{msg}");
            assert!(msg.contains("add `adapter = \"mavlink\"`"), "{msg}");
        }
    }

    #[test]
    fn a_mavlink_drone_is_connected_as_mavlink_tools_spell_it_and_zenoh_has_its_own_table() {
        let f = Fleet::parse(
            r#"
[drones.D1]
adapter = "mavlink"
connect = "udpin:0.0.0.0:14550"
zenoh = { listen = ["tcp/127.0.0.1:9001"], connect = ["tcp/127.0.0.1:9000"] }

[drones.D1.mavlink]
ready_timeout = 30
ack_timeout = 0.5
command_attempts = 5

[drones.D2]
adapter = "mavlink"
connection = "/dev/ttyUSB0:57600"
"#,
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap();
        let d1 = f.entry("D1");
        assert_eq!(d1.connect.as_deref(), Some("udpin:0.0.0.0:14550"));
        let settings = d1.mavlink.expect("the mavlink table is read");
        assert_eq!(settings.ready_timeout, Some(30.0));
        assert_eq!(settings.command_attempts, Some(5));
        // `connection` is the older spelling of the same key.
        assert_eq!(f.entry("D2").connect.as_deref(), Some("/dev/ttyUSB0:57600"));
        let peers: Vec<String> = ["GCS", "D1", "D2"].map(String::from).to_vec();
        let z = f.zenoh_options("abc", &peers, "D1");
        assert_eq!(z.listen, vec!["tcp/127.0.0.1:9001"]);
        assert_eq!(z.connect, vec!["tcp/127.0.0.1:9000"]);
    }

    #[test]
    fn a_bad_mavlink_connection_or_setting_is_reported_at_its_line_and_column() {
        let e = Fleet::parse(
            "[drones.D1]\nadapter = \"mavlink\"\nconnect = \"udpin:0.0.0.0\"\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("f.toml") && msg.contains("line 3, column 11"),
            "{msg}"
        );
        assert!(msg.contains("is not a MAVLink connection"), "{msg}");

        let e = Fleet::parse(
            "[drones.D1]\nadapter = \"mavlink\"\nconnect = \"udpin:0.0.0.0:14550\"\n\n[drones.D1.mavlink]\nlink_timeout = -2\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("line 5"), "{msg}");
        assert!(
            msg.contains("`link_timeout` must be a positive number"),
            "{msg}"
        );

        let e = Fleet::parse(
            "[drones.D1]\nadapter = \"mavlink\"\nconnect = \"udpin:0.0.0.0:14550\"\nmavlink = { ready_timeot = 3 }\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("line 4") && msg.contains("ready_timeot"),
            "{msg}"
        );
    }

    #[test]
    fn zenoh_endpoints_where_they_used_to_be_point_to_the_zenoh_table() {
        let e = Fleet::parse(
            "[drones.D1]\nconnect = [\"tcp/127.0.0.1:9001\"]\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("line 2"), "{msg}");
        assert!(msg.contains("`zenoh = { connect = [...] }`"), "{msg}");
        let e = Fleet::parse(
            "[drones.D1]\nlisten = [\"tcp/127.0.0.1:9001\"]\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("line 2"), "{msg}");
        assert!(msg.contains("`zenoh = { listen = [...] }`"), "{msg}");
    }

    #[test]
    fn a_drone_follows_its_own_policy_else_the_fleets_else_lands_after_five_seconds() {
        let f = Fleet::parse(
            "[failsafe]\non_lost = \"hold\"\ngrace = \"2s\"\n\n[drones.D1]\non_lost = \"home\"\ngrace = 0.5\non_abort = \"home\"\n",
            "f.toml",
            "M",
            &drones(),
        )
        .unwrap();
        let d1 = f.liveness("D1");
        assert_eq!(
            (d1.on_lost, d1.grace, d1.on_abort),
            (OnLost::Home, 0.5, Failsafe::Home)
        );
        let d2 = f.liveness("D2");
        assert_eq!(
            (d2.on_lost, d2.grace, d2.on_abort),
            (OnLost::Hold, 2.0, Failsafe::Land)
        );
        assert_eq!(Fleet::default().liveness("D3"), Liveness::default());
        assert_eq!(Liveness::default().on_lost, OnLost::Land);
        assert_eq!(Liveness::default().grace, 5.0);
    }

    #[test]
    fn every_path_is_resolved_against_the_fleet_files_directory_once_when_it_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("fleet.toml");
        std::fs::write(
            &file,
            "[keys]\ngcs = \"keys/gcs.pub\"\n[zenoh.tls]\nca = \"ca.pem\"\ncertificate = \"all.pem\"\nkey = \"all.key\"\n[drones.D1]\n",
        )
        .unwrap();
        let bound = Fleet::load(&file, "M", &drones()).unwrap();
        let unbound = Fleet::load_unbound(&file).unwrap();
        for f in [&bound, &unbound] {
            assert_eq!(f.keys.gcs, Some(dir.path().join("keys/gcs.pub")));
            assert_eq!(
                f.tls_files("D1").unwrap().certificate,
                dir.path().join("all.pem")
            );
        }
        // A fleet read before its mission is checked against it later.
        unbound.check_mission("fleet.toml", "M", &drones()).unwrap();
        let e = unbound
            .check_mission("fleet.toml", "M", &["D2".to_string()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("D1") && e.contains("D2"), "{e}");
    }

    #[test]
    fn an_unknown_policy_or_a_bad_grace_period_is_reported_with_its_line() {
        for (text, what) in [
            ("[drones.D1]\non_lost = \"panic\"\n", "panic"),
            ("[drones.D1]\ngrace = \"5 parsecs\"\n", "parsecs"),
            ("[failsafe]\non_abort = \"abort\"\n", "abort"),
        ] {
            let e = Fleet::parse(text, "f.toml", "M", &drones()).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains("line 2") && msg.contains(what), "{msg}");
        }
    }
}
