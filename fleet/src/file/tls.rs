//! Certificates in the fleet file: zenoh over TLS with mutual
//! authentication.
//!
//! ```toml
//! [zenoh.tls]
//! ca = "certs/fleet-ca.pem"          # the fleet's certificate authority
//! # certificate = "certs/any.pem"    # one certificate for every peer
//! # key = "certs/any.key"            # (a test bench; a fleet gives one per peer)
//! # verify_name = true               # a certificate must name its peer's address
//!
//! [gcs]
//! tls = { certificate = "certs/gcs.pem", key = "certs/gcs.key" }
//!
//! [drones.D1.zenoh.tls]
//! certificate = "certs/D1.pem"
//! key = "certs/D1.key"
//! ```
//!
//! `[zenoh.tls]` switches TLS on for the whole mission: every peer (the
//! ground station and every drone, named in the file or not) then needs a
//! certificate and key, its own or the fleet-wide one, and every endpoint
//! is `tls/`; the default loopback endpoints become `tls/127.0.0.1:PORT`.
//! Relative paths are relative to the fleet file. Only the files of the
//! peers a process runs are read, when it opens its link: a drone's
//! companion computer holds the CA, its own certificate and its own key,
//! and nobody else's.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::{Fleet, FleetError};
use crate::zenoh::{TlsFiles, GCS};

/// `[zenoh.tls]`: the fleet's CA, and a certificate for every peer that
/// does not name its own.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FleetTls {
    pub ca: PathBuf,
    #[serde(default)]
    pub certificate: Option<PathBuf>,
    #[serde(default)]
    pub key: Option<PathBuf>,
    /// Check that a peer's certificate names the address it is reached at;
    /// turn off only where addresses change (DHCP). The CA check stays.
    #[serde(default = "yes")]
    pub verify_name: bool,
}

fn yes() -> bool {
    true
}

/// A peer's own certificate and key (`tls` in `[gcs]` or in a drone's
/// `zenoh` table).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PeerTls {
    pub certificate: PathBuf,
    pub key: PathBuf,
}

impl Fleet {
    fn own_tls(&self, peer: &str) -> Option<PeerTls> {
        if peer == GCS {
            self.gcs.tls.clone()
        } else {
            self.drones.get(peer).and_then(|e| e.zenoh.tls.clone())
        }
    }

    fn table(peer: &str) -> String {
        if peer == GCS {
            "[gcs]".to_string()
        } else {
            format!("[drones.{peer}.zenoh]")
        }
    }

    /// The TLS files of `peer`, when the fleet uses TLS.
    pub fn tls_files(&self, peer: &str) -> Option<TlsFiles> {
        let fleet = self.zenoh.tls.as_ref()?;
        let (certificate, key) = match self.own_tls(peer) {
            Some(own) => (own.certificate, own.key),
            None => (fleet.certificate.clone()?, fleet.key.clone()?),
        };
        Some(TlsFiles {
            ca: fleet.ca.clone(),
            certificate,
            key,
            verify_name: fleet.verify_name,
        })
    }

    /// Every peer has a certificate and key, and no endpoint is plain, or
    /// no peer names a certificate at all.
    pub(super) fn check_tls(&self, name: &str, drones: &[String]) -> Result<(), FleetError> {
        let error = |e: String| FleetError::Parse {
            path: name.to_string(),
            error: e,
        };
        let peers: Vec<&str> = std::iter::once(GCS)
            .chain(drones.iter().map(String::as_str))
            .collect();
        let Some(fleet) = &self.zenoh.tls else {
            return match peers.iter().find(|p| self.own_tls(p).is_some()) {
                Some(p) => Err(error(format!(
                    "{} names a TLS certificate, but the fleet has no CA: add `[zenoh.tls]` with `ca = \"ca.pem\"`",
                    Self::table(p)
                ))),
                None => Ok(()),
            };
        };
        if !self.zenoh.routers.is_empty() {
            return Err(error(
                "[zenoh] routers with [zenoh.tls] are not supported yet: a fleet joins through routers in clear text, or through a mesh with TLS".to_string(),
            ));
        }
        if fleet.certificate.is_some() != fleet.key.is_some() {
            return Err(error(
                "[zenoh.tls] needs both `certificate` and `key`, or neither".to_string(),
            ));
        }
        for peer in peers {
            if self.tls_files(peer).is_none() {
                return Err(error(format!(
                    "`{peer}` has no TLS certificate: give it `tls = {{ certificate = \"...\", key = \"...\" }}` in {}, or one for every peer in [zenoh.tls]",
                    Self::table(peer)
                )));
            }
            let net = if peer == GCS {
                self.gcs.clone()
            } else {
                self.entry(peer).zenoh
            };
            if let Some(plain) = net
                .listen
                .iter()
                .chain(&net.connect)
                .find(|e| !e.starts_with("tls/"))
            {
                return Err(error(format!(
                    "{}: endpoint `{plain}` is not TLS; with [zenoh.tls] every endpoint is `tls/HOST:PORT`",
                    Self::table(peer)
                )));
            }
        }
        Ok(())
    }

    /// Makes relative certificate paths relative to the fleet file's
    /// directory rather than to wherever the command runs.
    pub(super) fn resolve_tls_paths(&mut self, base: &Path) {
        let at = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        if let Some(f) = &mut self.zenoh.tls {
            at(&mut f.ca);
            f.certificate.iter_mut().for_each(at);
            f.key.iter_mut().for_each(at);
        }
        let own = std::iter::once(&mut self.gcs.tls)
            .chain(self.drones.values_mut().map(|e| &mut e.zenoh.tls))
            .flatten();
        for t in own {
            at(&mut t.certificate);
            at(&mut t.key);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drones() -> Vec<String> {
        vec!["D1".into(), "D2".into()]
    }

    fn parse(text: &str) -> Result<Fleet, FleetError> {
        Fleet::parse(text, "fleet.toml", "M", &drones())
    }

    const PER_PEER: &str = r#"
[zenoh.tls]
ca = "ca.pem"

[gcs]
tls = { certificate = "gcs.pem", key = "gcs.key" }

[drones.D1.zenoh.tls]
certificate = "d1.pem"
key = "d1.key"

[drones.D2.zenoh]
listen = ["tls/192.168.1.12:7447"]
tls = { certificate = "d2.pem", key = "d2.key" }
"#;

    #[test]
    fn each_peer_presents_its_own_certificate_signed_by_the_fleet_ca() {
        let f = parse(PER_PEER).unwrap();
        let d1 = f.tls_files("D1").unwrap();
        assert_eq!(
            (d1.ca.as_path(), d1.certificate.as_path(), d1.key.as_path()),
            (
                Path::new("ca.pem"),
                Path::new("d1.pem"),
                Path::new("d1.key")
            )
        );
        assert!(d1.verify_name);
        assert_eq!(f.tls_files(GCS).unwrap().key, Path::new("gcs.key"));
        assert_eq!(f.tls_files("D2").unwrap().certificate, Path::new("d2.pem"));
    }

    #[test]
    fn with_tls_every_endpoint_of_a_peer_is_tls_the_default_ones_included() {
        let f = parse(PER_PEER).unwrap();
        let peers: Vec<String> = ["GCS", "D1", "D2"].map(String::from).to_vec();
        let z = f.zenoh_options("abc", &peers, "D1");
        assert!(z.tls.is_some());
        assert!(z.listen[0].starts_with("tls/127.0.0.1:"), "{:?}", z.listen);
        assert!(
            z.connect.contains(&"tls/192.168.1.12:7447".to_string()),
            "{:?}",
            z.connect
        );
        assert!(z.connect.iter().all(|e| e.starts_with("tls/")), "{z:?}");
    }

    #[test]
    fn a_fleet_wide_certificate_serves_every_peer_without_its_own() {
        let f = parse(
            "[zenoh.tls]\nca = \"ca.pem\"\ncertificate = \"all.pem\"\nkey = \"all.key\"\nverify_name = false\n\n[drones.D2.zenoh.tls]\ncertificate = \"d2.pem\"\nkey = \"d2.key\"\n",
        )
        .unwrap();
        assert_eq!(f.tls_files(GCS).unwrap().certificate, Path::new("all.pem"));
        assert_eq!(f.tls_files("D1").unwrap().key, Path::new("all.key"));
        assert_eq!(f.tls_files("D2").unwrap().certificate, Path::new("d2.pem"));
        assert!(!f.tls_files("D1").unwrap().verify_name);
    }

    #[test]
    fn without_tls_no_peer_has_tls_files_and_endpoints_stay_tcp() {
        let f = parse("[drones.D1]\n").unwrap();
        assert_eq!(f.tls_files("D1"), None);
        let peers: Vec<String> = ["GCS", "D1"].map(String::from).to_vec();
        let z = f.zenoh_options("abc", &peers, "GCS");
        assert_eq!(z.tls, None);
        assert!(z.listen[0].starts_with("tcp/"));
    }

    #[test]
    fn routers_with_tls_are_refused_rather_than_left_unreachable() {
        let e = parse(
            "[zenoh]\nrouters = [\"tls/10.0.0.1:7447\"]\n\n[zenoh.tls]\nca = \"ca.pem\"\ncertificate = \"all.pem\"\nkey = \"all.key\"\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("routers with [zenoh.tls] are not supported yet"),
            "{e}"
        );
    }

    #[test]
    fn a_peer_certificate_without_a_fleet_ca_is_refused() {
        let e = parse("[gcs]\ntls = { certificate = \"g.pem\", key = \"g.key\" }\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("fleet.toml") && e.contains("[gcs]") && e.contains("[zenoh.tls]"),
            "{e}"
        );
    }

    #[test]
    fn a_drone_without_a_certificate_is_named() {
        let e = parse(
            "[zenoh.tls]\nca = \"ca.pem\"\n[gcs]\ntls = { certificate = \"g.pem\", key = \"g.key\" }\n[drones.D1.zenoh.tls]\ncertificate = \"d1.pem\"\nkey = \"d1.key\"\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("`D2`") && e.contains("[drones.D2.zenoh]"), "{e}");
    }

    #[test]
    fn a_plain_endpoint_beside_certificates_is_refused_with_its_table() {
        let e = parse(
            "[zenoh.tls]\nca = \"ca.pem\"\ncertificate = \"a.pem\"\nkey = \"a.key\"\n[drones.D1.zenoh]\nlisten = [\"tcp/10.0.0.1:7447\"]\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("tcp/10.0.0.1:7447") && e.contains("[drones.D1.zenoh]"),
            "{e}"
        );
    }

    #[test]
    fn a_fleet_wide_certificate_without_its_key_is_refused() {
        let e = parse("[zenoh.tls]\nca = \"ca.pem\"\ncertificate = \"a.pem\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("key"), "{e}");
    }

    #[test]
    fn relative_certificate_paths_are_relative_to_the_fleet_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("fleet.toml");
        std::fs::write(&file, PER_PEER).unwrap();
        let f = Fleet::load(&file, "M", &drones()).unwrap();
        let d1 = f.tls_files("D1").unwrap();
        assert_eq!(d1.ca, dir.path().join("ca.pem"));
        assert_eq!(d1.key, dir.path().join("d1.key"));
        assert_eq!(
            f.tls_files(GCS).unwrap().certificate,
            dir.path().join("gcs.pem")
        );
    }
}
