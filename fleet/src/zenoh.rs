//! The zenoh settings of one peer, as plain data: what the fleet file
//! resolves for each peer and the transport opens a session with.

use std::path::PathBuf;

/// The peer name of the ground station.
pub const GCS: &str = "GCS";

/// How one peer joins the zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ZenohOptions {
    /// Endpoints to listen on, as zenoh writes them (`tcp/127.0.0.1:7447`).
    pub listen: Vec<String>,
    /// Endpoints of the other peers.
    pub connect: Vec<String>,
    /// Find peers by multicast scouting as well (off by default).
    pub scouting: bool,
    /// TLS with mutual authentication; every endpoint must then be `tls/`.
    pub tls: Option<TlsFiles>,
    /// How it joins: as a peer of a mesh, or as a client of routers.
    pub mode: Mode,
}

/// How a process joins the zenoh network (zenoh's own modes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Mode {
    /// Every peer connects to every other: the default, for small fleets.
    #[default]
    Peer,
    /// Joins through a router (the first of `connect` that answers, the
    /// next one when it is lost): a fleet that outgrows a full mesh.
    Client,
    /// Routes the clients' traffic, and the other routers'.
    Router,
}

impl Mode {
    /// The mode as zenoh's configuration spells it.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
            Mode::Router => "router",
        }
    }
}

/// The files of one peer for TLS with mutual authentication (PEM).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    /// The fleet's certificate authority: only peers whose certificate it
    /// signed are let in, and only such peers are connected to.
    pub ca: PathBuf,
    /// This peer's certificate, presented when it listens and when it
    /// connects (zenoh peers do both).
    pub certificate: PathBuf,
    /// The private key of `certificate`.
    pub key: PathBuf,
    /// Check that the certificate of a peer we connect to names the address
    /// we connect to (its subject alternative names). Off only for fleets
    /// whose addresses change (DHCP); the CA check stays on either way.
    pub verify_name: bool,
}
