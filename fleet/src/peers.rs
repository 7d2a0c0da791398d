//! How the peers of a mission (the ground station and every drone's agent)
//! find each other over zenoh: each peer's listen and connect endpoints
//! and TLS files, resolved from the fleet file once, handed to the
//! transport as plain settings. Opening a session is the executor's
//! business, not this crate's.

use crate::file::Fleet;
use crate::zenoh::{Mode, ZenohOptions, GCS};

impl Fleet {
    /// The listen endpoints of a peer (`GCS` or a drone).
    pub fn listen(&self, mission_id: &str, peers: &[String], peer: &str) -> Vec<String> {
        let given = if peer == GCS {
            self.gcs.listen.clone()
        } else {
            self.entry(peer).zenoh.listen
        };
        if !given.is_empty() {
            return given;
        }
        let k = peers.iter().position(|p| p == peer).unwrap_or(0);
        let scheme = if self.zenoh.tls.is_some() {
            "tls"
        } else {
            "tcp"
        };
        vec![format!(
            "{scheme}/127.0.0.1:{}",
            loopback_port(mission_id, peers.len(), k)
        )]
    }

    /// How `peer` joins zenoh: its listen endpoints, and the others' as
    /// connect endpoints unless the file gives its own.
    pub fn zenoh_options(&self, mission_id: &str, peers: &[String], peer: &str) -> ZenohOptions {
        if !self.zenoh.routers.is_empty() {
            return ZenohOptions {
                listen: Vec::new(),
                connect: self.zenoh.routers.clone(),
                scouting: false,
                tls: self.tls_files(peer),
                mode: Mode::Client,
            };
        }
        if self.hub(peers) {
            let gcs = self.listen(mission_id, peers, GCS);
            return if peer == GCS {
                ZenohOptions {
                    listen: gcs,
                    connect: Vec::new(),
                    scouting: false,
                    tls: self.tls_files(peer),
                    mode: Mode::Router,
                }
            } else {
                ZenohOptions {
                    listen: Vec::new(),
                    connect: gcs,
                    scouting: false,
                    tls: self.tls_files(peer),
                    mode: Mode::Client,
                }
            };
        }
        let connect_given = if peer == GCS {
            self.gcs.connect.clone()
        } else {
            self.entry(peer).zenoh.connect
        };
        let connect = if connect_given.is_empty() {
            peers
                .iter()
                .filter(|p| p.as_str() != peer)
                .flat_map(|p| self.listen(mission_id, peers, p))
                .collect()
        } else {
            connect_given
        };
        ZenohOptions {
            listen: self.listen(mission_id, peers, peer),
            connect,
            scouting: self.zenoh.scouting,
            tls: self.tls_files(peer),
            mode: Mode::Peer,
        }
    }

    /// How a process that is no peer of the mission joins its network (a
    /// monitor, `eamos abort`): as a client of the routers, or of the
    /// ground station when it routes (see [`Fleet::hub`]); in a mesh, by
    /// connecting to every peer's endpoints while listening on none, so
    /// that it never takes a peer's port.
    pub fn outsider_options(&self, mission_id: &str, peers: &[String]) -> ZenohOptions {
        let mut options = self.zenoh_options(mission_id, peers, OUTSIDER);
        if options.mode == Mode::Peer {
            options.listen = Vec::new();
            options.connect = peers
                .iter()
                .flat_map(|p| self.listen(mission_id, peers, p))
                .collect();
        }
        options
    }

    /// Whether the peers join through the ground station, which routes
    /// for them, rather than as a full mesh: for a fleet of more than
    /// [`MESH_DRONES`] drones whose file names neither routers nor any
    /// endpoint nor TLS (routers over TLS are not supported yet): the
    /// fleet a user gets without writing one.
    ///
    /// A mesh of `n` peers is `n (n - 1) / 2` zenoh sessions, each
    /// declaring every peer's subscriptions and liveliness to every other:
    /// 101 peers on one computer were about 5,000 sessions that did not
    /// form within a minute. Through one router, `n` sessions. The price is
    /// that losing the ground station then cuts the drones from each
    /// other, where in a mesh they keep their bridges: a fleet flown for
    /// real names its own routers, two of them (`[zenoh] routers`).
    pub fn hub(&self, peers: &[String]) -> bool {
        let drones = peers.iter().filter(|p| p.as_str() != GCS).count();
        drones > MESH_DRONES
            && self.zenoh.routers.is_empty()
            && !self.zenoh.scouting
            && self.zenoh.tls.is_none()
            && self.gcs.listen.is_empty()
            && self.gcs.connect.is_empty()
            && self
                .drones
                .values()
                .all(|d| d.zenoh.listen.is_empty() && d.zenoh.connect.is_empty())
    }

    /// How router number `n` (from 1, in the order of `[zenoh] routers`)
    /// runs: it listens on its own endpoint and connects to the other
    /// routers, so that clients of different routers reach each other.
    pub fn router_options(&self, n: usize) -> Result<ZenohOptions, String> {
        let routers = &self.zenoh.routers;
        if n == 0 || n > routers.len() {
            return Err(match routers.len() {
                0 => "the fleet file names no routers: add `routers = [...]` to its `[zenoh]` table".to_string(),
                k => format!("router {n} does not exist: the fleet file's `[zenoh] routers` names {k} (number them from 1)"),
            });
        }
        Ok(ZenohOptions {
            listen: vec![routers[n - 1].clone()],
            connect: routers
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != n - 1)
                .map(|(_, r)| r.clone())
                .collect(),
            scouting: false,
            tls: None,
            mode: Mode::Router,
        })
    }
}

/// The name [`Fleet::outsider_options`] asks for: no peer's.
const OUTSIDER: &str = "\u{0}outsider";

/// The largest fleet whose peers join as a full mesh by default: above
/// it, through the ground station (see [`Fleet::hub`]). A mesh of 30
/// drones formed in a few seconds; one of 100 did not within a minute.
pub const MESH_DRONES: usize = 32;

/// The loopback port of peer number `k` of a mission of `peers` peers
/// (`k` = 0 for the ground station, 1 + the drone's index for a drone):
/// `20000 + block * (FNV-1a(mission id) mod (12768 / block)) + k`, where
/// the block is the fleet's size rounded up to a power of two, at least 64.
///
/// Every process of one mission derives the same ports with no file to
/// share (each knows the mission's peers); a mission's peers never share a
/// port, whatever the fleet's size; two different missions are unlikely to
/// meet in the same block; the ports stay below 32768, where Linux starts
/// handing out ephemeral ports. A fleet up to 63 drones keeps the ports it
/// always had.
pub fn loopback_port(mission_id: &str, peers: usize, k: usize) -> u16 {
    const FIRST: u32 = 20000;
    const SPAN: u32 = 32768 - FIRST;
    let mut h: u32 = 0x811c_9dc5;
    for b in mission_id.bytes() {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    let block = (peers.max(64) as u32).next_power_of_two().min(SPAN);
    let blocks = (SPAN / block).max(1);
    (FIRST + block * (h % blocks) + (k as u32 % block)) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::default_home;
    use crate::file::AdapterKind;
    use eamos_mid::Vec3;

    fn drones() -> Vec<String> {
        vec!["D1".into(), "D2".into(), "D3".into()]
    }

    #[test]
    fn a_fleet_file_binds_drones_to_adapters_homes_and_endpoints() {
        let f = Fleet::parse(
            r#"
[gcs]
listen = ["tcp/127.0.0.1:9000"]

[drones.D1]
home = { x = 1.0, y = 2.0, z = 0.0 }

[drones.D3]
script = { start_after = 1.0, legs = [{ leg = "hold", seconds = 2.0 }] }
zenoh = { listen = ["tcp/127.0.0.1:9003"] }

[drones.D2]
adapter = "mavlink"
connect = "udpin:0.0.0.0:14550"
"#,
            "fleet.toml",
            "M",
            &drones(),
        )
        .unwrap();
        assert_eq!(f.home("D1", 0), Vec3::new(1.0, 2.0, 0.0));
        assert_eq!(f.home("D3", 2), default_home(2));
        assert_eq!(f.entry("D2").adapter, AdapterKind::Mavlink);
        assert!(f.sim_spec("D3", 2).script.is_some());
        let peers: Vec<String> = ["GCS", "D1", "D2", "D3"].map(String::from).to_vec();
        let z = f.zenoh_options("abc", &peers, "D3");
        assert_eq!(z.listen, vec!["tcp/127.0.0.1:9003"]);
        assert!(z.connect.contains(&"tcp/127.0.0.1:9000".to_string()));
        assert_eq!(z.connect.len(), 3);
        assert!(!z.scouting);
    }

    #[test]
    fn loopback_ports_are_distinct_per_peer_and_the_same_in_every_process() {
        let ports: Vec<u16> = (0..4).map(|k| loopback_port("mission-x", 4, k)).collect();
        let mut d = ports.clone();
        d.sort();
        d.dedup();
        assert_eq!(d.len(), 4);
        assert_eq!(
            ports,
            (0..4)
                .map(|k| loopback_port("mission-x", 4, k))
                .collect::<Vec<_>>()
        );
        assert!(ports.iter().all(|p| (20000..32768).contains(p)));
        let f = Fleet::default();
        let peers: Vec<String> = ["GCS", "D1"].map(String::from).to_vec();
        assert_eq!(
            f.listen("mission-x", &peers, "D1"),
            vec![format!("tcp/127.0.0.1:{}", ports[1])]
        );
    }

    #[test]
    fn no_two_peers_of_a_fleet_of_any_size_share_a_loopback_port() {
        for n in [2, 63, 64, 65, 100, 101, 250, 1000, 5000] {
            let mut ports: Vec<u16> = (0..n).map(|k| loopback_port("mission-y", n, k)).collect();
            assert!(
                ports.iter().all(|p| (20000..32768).contains(p)),
                "{n} peers"
            );
            ports.sort_unstable();
            ports.dedup();
            assert_eq!(ports.len(), n, "{n} peers share ports");
        }
        // The ports of a small fleet did not move.
        let h = "mission-y".bytes().fold(0x811c_9dc5_u32, |h, b| {
            (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
        });
        assert_eq!(
            loopback_port("mission-y", 10, 3),
            (20000 + 64 * (h % 199) + 3) as u16
        );
    }

    #[test]
    fn with_routers_every_peer_joins_as_their_client_and_listens_nowhere() {
        let f = Fleet::parse_unbound(
            "[zenoh]\nrouters = [\"tcp/10.0.0.1:7447\", \"tcp/10.0.0.2:7447\"]\n\n[gcs]\nlisten = [\"tcp/127.0.0.1:9000\"]\n",
            "fleet.toml",
        )
        .unwrap();
        let peers: Vec<String> = ["GCS", "D1", "D2"].map(String::from).to_vec();
        for peer in &peers {
            let o = f.zenoh_options("m", &peers, peer);
            assert_eq!(o.mode, Mode::Client, "{peer}");
            assert!(o.listen.is_empty(), "{peer}: {o:?}");
            assert_eq!(o.connect, ["tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"]);
        }
        // Each router listens on its own endpoint and joins the others.
        let r2 = f.router_options(2).unwrap();
        assert_eq!(r2.mode, Mode::Router);
        assert_eq!(r2.listen, ["tcp/10.0.0.2:7447"]);
        assert_eq!(r2.connect, ["tcp/10.0.0.1:7447"]);
        let e = f.router_options(3).unwrap_err();
        assert!(
            e.contains("router 3 does not exist") && e.contains("names 2"),
            "{e}"
        );
        assert!(f.router_options(0).is_err());
        let e = Fleet::default().router_options(1).unwrap_err();
        assert!(e.contains("names no routers"), "{e}");
        // Without routers: the mesh, as before.
        let mesh = Fleet::default().zenoh_options("m", &peers, "D1");
        assert_eq!(mesh.mode, Mode::Peer);
        assert_eq!(mesh.connect.len(), 2);
    }

    fn fleet_of(drones: usize) -> Vec<String> {
        std::iter::once("GCS".to_string())
            .chain((1..=drones).map(|k| format!("D{k}")))
            .collect()
    }

    #[test]
    fn a_large_fleet_without_endpoints_joins_through_the_ground_station() {
        let f = Fleet::default();
        let small = fleet_of(MESH_DRONES);
        assert!(!f.hub(&small));
        assert_eq!(f.zenoh_options("m", &small, "D1").mode, Mode::Peer);

        let large = fleet_of(MESH_DRONES + 1);
        assert!(f.hub(&large));
        let gcs = f.zenoh_options("m", &large, "GCS");
        assert_eq!(gcs.mode, Mode::Router);
        assert!(gcs.connect.is_empty());
        let port = loopback_port("m", large.len(), 0);
        assert_eq!(gcs.listen, [format!("tcp/127.0.0.1:{port}")]);
        for drone in ["D1", "D33"] {
            let d = f.zenoh_options("m", &large, drone);
            assert_eq!(d.mode, Mode::Client, "{drone}");
            assert!(d.listen.is_empty(), "{drone}");
            assert_eq!(d.connect, gcs.listen, "{drone}");
        }
        // A monitor or `eamos abort` joins as the drones do.
        let o = f.outsider_options("m", &large);
        assert_eq!((o.mode, o.connect), (Mode::Client, gcs.listen.clone()));
        assert!(o.listen.is_empty());
        // In a mesh, it connects to every peer and takes no peer's port.
        let o = f.outsider_options("m", &small);
        assert_eq!(o.mode, Mode::Peer);
        assert!(o.listen.is_empty());
        assert_eq!(o.connect.len(), small.len());
        // Through routers, as their client.
        let routed =
            Fleet::parse_unbound("[zenoh]\nrouters = [\"tcp/10.0.0.1:7447\"]\n", "fleet.toml")
                .unwrap();
        let o = routed.outsider_options("m", &large);
        assert_eq!(
            (o.mode, o.connect),
            (Mode::Client, vec!["tcp/10.0.0.1:7447".to_string()])
        );
    }

    #[test]
    fn a_fleet_file_that_names_endpoints_or_scouting_keeps_its_topology() {
        let large = fleet_of(MESH_DRONES + 10);
        for text in [
            "[gcs]\nlisten = [\"tcp/127.0.0.1:9000\"]\n",
            "[drones.D2]\nzenoh = { connect = [\"tcp/127.0.0.1:9001\"] }\n",
            "[zenoh]\nscouting = true\n",
        ] {
            let f = Fleet::parse_unbound(text, "fleet.toml").unwrap();
            assert!(!f.hub(&large), "{text}");
            assert_eq!(
                f.zenoh_options("m", &large, "D1").mode,
                Mode::Peer,
                "{text}"
            );
        }
    }
}
