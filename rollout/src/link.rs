//! Where the ground station and the agents meet before a mission exists:
//! the fleet's roll-out endpoints, and the zenoh session on them.

use zenoh::Session;

use eamos_exec::transport::zenoh::{config, ZenohOptions};
use eamos_fleet::identity::fleet_version;
use eamos_fleet::{loopback_port, Fleet, GCS};

#[derive(Debug, thiserror::Error)]
pub enum DeployError {
    #[error("cannot open the roll-out link: {0}")]
    Open(String),
    #[error("{0}")]
    Setup(String),
}

/// Where the ground station listens for agents, and where agents connect.
pub fn rollout_endpoints(fleet: &Fleet) -> (Vec<String>, Vec<String>) {
    let listen = if fleet.rollout.listen.is_empty() {
        // Slot 63 of the fleet's block: a mission's peers use the first
        // slots of their own block, so the two do not meet.
        let scope = format!("rollout-{}", fleet_version(fleet));
        vec![format!("tcp/127.0.0.1:{}", loopback_port(&scope, 64, 63))]
    } else {
        fleet.rollout.listen.clone()
    };
    let connect = if fleet.rollout.connect.is_empty() {
        listen.clone()
    } else {
        fleet.rollout.connect.clone()
    };
    (listen, connect)
}

/// The zenoh options of the roll-out link: the fleet's settings for `peer`
/// (scouting, and whatever else the fleet says about links) with the
/// roll-out endpoints.
pub(crate) fn rollout_options(fleet: &Fleet, peer: &str) -> ZenohOptions {
    let (listen, connect) = rollout_endpoints(fleet);
    let peers = vec![GCS.to_string(), peer.to_string()];
    let base = fleet.zenoh_options("rollout", &peers, peer);
    if peer == GCS {
        ZenohOptions {
            listen,
            connect: Vec::new(),
            ..base
        }
    } else {
        ZenohOptions {
            listen: Vec::new(),
            connect,
            ..base
        }
    }
}

pub(crate) async fn open_session(options: &ZenohOptions) -> Result<Session, DeployError> {
    zenoh::open(config(options).map_err(|e| DeployError::Open(e.to_string()))?)
        .await
        .map_err(|e| DeployError::Open(e.to_string()))
}
