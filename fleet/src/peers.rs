//! How the peers of a mission (the ground station and every drone's agent)
//! find each other over zenoh: each peer's listen and connect endpoints
//! and TLS files, resolved from the fleet file once, handed to the
//! transport as plain settings. Opening a session is the executor's
//! business, not this crate's.

use crate::file::Fleet;
use crate::zenoh::{ZenohOptions, GCS};

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
            loopback_port(mission_id, k)
        )]
    }

    /// How `peer` joins zenoh: its listen endpoints, and the others' as
    /// connect endpoints unless the file gives its own.
    pub fn zenoh_options(&self, mission_id: &str, peers: &[String], peer: &str) -> ZenohOptions {
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
        }
    }
}

/// The loopback port of peer number `k` of a mission (`k` = 0 for the
/// ground station, 1 + the drone's index for a drone):
/// `20000 + 64 * (FNV-1a(mission id) mod 199) + k`.
///
/// Every process of one mission derives the same ports with no file to
/// share; two different missions are unlikely to meet in the same block
/// of 64; the ports stay below 32768, where Linux starts handing out
/// ephemeral ports; a fleet of more than 63 drones needs explicit
/// endpoints.
pub fn loopback_port(mission_id: &str, k: usize) -> u16 {
    let mut h: u32 = 0x811c_9dc5;
    for b in mission_id.bytes() {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    (20000 + 64 * (h % 199) + (k as u32 % 64)) as u16
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
        let ports: Vec<u16> = (0..4).map(|k| loopback_port("mission-x", k)).collect();
        let mut d = ports.clone();
        d.sort();
        d.dedup();
        assert_eq!(d.len(), 4);
        assert_eq!(
            ports,
            (0..4)
                .map(|k| loopback_port("mission-x", k))
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
}
