//! Connection strings, spelled as MAVLink tools spell them, so that a pilot
//! can paste what already works in their ground station into a fleet file.
//!
//! | spelling | meaning |
//! | --- | --- |
//! | `udpin:HOST:PORT` (also `udp:`) | listen; answer whoever sent last (a SITL started with `--out`, a telemetry router) |
//! | `udpout:HOST:PORT` | send to a vehicle that listens |
//! | `tcpout:HOST:PORT` (also `tcp:`) | connect to a vehicle that listens (SITL's `tcp:5760`) |
//! | `tcpin:HOST:PORT` | accept one connection (used by the test vehicle) |
//! | `serial:DEVICE:BAUD`, `DEVICE:BAUD`, `DEVICE,BAUD`, `DEVICE` | a serial port (`/dev/ttyACM0`, `COM3`); 57600 baud unless told |

use std::fmt;
use std::io;
use std::net::{SocketAddr, TcpListener, ToSocketAddrs, UdpSocket};

use mavlink::{
    AsyncConnectable, AsyncMavConnection, ConnectionAddress, SerialConfig, TcpConfig, TcpMode,
    UdpConfig, UdpMode,
};

use super::dialect::MavMessage;

/// The baud rate of a serial port named without one: the rate of most
/// telemetry radios (a USB autopilot ignores it).
pub const DEFAULT_BAUD: u32 = 57_600;

/// Where a MAVLink peer is and which side opens the connection.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ConnectAddress {
    /// Listen on `HOST:PORT` and answer the last sender.
    UdpIn(String),
    /// Send to `HOST:PORT` from a port of our own.
    UdpOut(String),
    /// Connect to a TCP listener.
    TcpOut(String),
    /// Accept one TCP connection.
    TcpIn(String),
    /// A serial device.
    Serial { device: String, baud: u32 },
}

/// A connection string that does not name a MAVLink connection.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{address}` is not a MAVLink connection: {reason} (expected udpin:HOST:PORT, udpout:HOST:PORT, tcpout:HOST:PORT, tcpin:HOST:PORT or serial:DEVICE:BAUD)")]
pub struct AddressError {
    pub address: String,
    pub reason: String,
}

impl ConnectAddress {
    /// Reads a connection string (see the module documentation).
    pub fn parse(text: &str) -> Result<Self, AddressError> {
        let err = |reason: &str| AddressError {
            address: text.to_string(),
            reason: reason.to_string(),
        };
        let text_trimmed = text.trim();
        if text_trimmed.is_empty() {
            return Err(err("it is empty"));
        }
        if let Some((scheme, rest)) = text_trimmed.split_once(':') {
            let net = |rest: &str| -> Result<String, AddressError> {
                let (host, port) = rest
                    .rsplit_once(':')
                    .ok_or_else(|| err("the host and port must be separated by `:`"))?;
                if host.is_empty() {
                    return Err(err(
                        "the host is missing (use 0.0.0.0 to listen everywhere)",
                    ));
                }
                port.parse::<u16>()
                    .map_err(|_| err(&format!("`{port}` is not a port number")))?;
                Ok(rest.to_string())
            };
            match scheme {
                "udpin" | "udp" => return Ok(ConnectAddress::UdpIn(net(rest)?)),
                "udpout" => return Ok(ConnectAddress::UdpOut(net(rest)?)),
                "tcpout" | "tcp" => return Ok(ConnectAddress::TcpOut(net(rest)?)),
                "tcpin" => return Ok(ConnectAddress::TcpIn(net(rest)?)),
                "serial" => return Self::serial(rest, text),
                _ => {}
            }
        }
        if looks_like_device(text_trimmed) {
            return Self::serial(text_trimmed, text);
        }
        Err(err("unknown kind of connection"))
    }

    fn serial(spec: &str, whole: &str) -> Result<Self, AddressError> {
        let err = |reason: String| AddressError {
            address: whole.to_string(),
            reason,
        };
        // `DEVICE:BAUD` or `DEVICE,BAUD`; a Windows `COM3` has no colon of
        // its own, a Unix path never ends in `:digits`.
        let split = spec
            .rsplit_once(',')
            .or_else(|| spec.rsplit_once(':'))
            .filter(|(_, baud)| !baud.is_empty() && baud.chars().all(|c| c.is_ascii_digit()));
        let (device, baud) = match split {
            Some((device, baud)) => (
                device,
                baud.parse::<u32>()
                    .map_err(|_| err(format!("`{baud}` is not a baud rate")))?,
            ),
            None => (spec, DEFAULT_BAUD),
        };
        if device.is_empty() {
            return Err(err("the serial device is missing".to_string()));
        }
        if baud == 0 {
            return Err(err("a baud rate of 0 cannot carry anything".to_string()));
        }
        Ok(ConnectAddress::Serial {
            device: device.to_string(),
            baud,
        })
    }

    /// Whether the connection can fail and be opened again (a TCP peer
    /// that restarted, a serial cable pulled out). UDP has no connection
    /// to lose.
    pub fn is_stream(&self) -> bool {
        !matches!(self, ConnectAddress::UdpIn(_) | ConnectAddress::UdpOut(_))
    }

    /// Opens the connection. A `udpin` or `tcpin` address with port 0 binds
    /// a free port; the second value is the local address actually bound
    /// (for listeners), so a test can tell its peer where to send.
    pub async fn open(
        &self,
    ) -> io::Result<(mavlink::AsyncConnection<MavMessage>, Option<SocketAddr>)> {
        let (address, local): (ConnectionAddress, Option<SocketAddr>) = match self {
            ConnectAddress::UdpIn(hostport) => {
                let socket = UdpSocket::bind(resolve(hostport)?)?;
                let local = socket.local_addr()?;
                (
                    UdpConfig::from_socket(socket, UdpMode::Udpin)?.into(),
                    Some(local),
                )
            }
            ConnectAddress::UdpOut(hostport) => {
                // Resolve here, so that a name that does not resolve fails
                // now with a clear error rather than at the first send.
                let target = resolve(hostport)?;
                (
                    UdpConfig::new(target.to_string(), UdpMode::Udpout).into(),
                    None,
                )
            }
            ConnectAddress::TcpOut(hostport) => (
                TcpConfig::new(resolve(hostport)?.to_string(), TcpMode::TcpOut).into(),
                None,
            ),
            ConnectAddress::TcpIn(hostport) => {
                let listener = TcpListener::bind(resolve(hostport)?)?;
                let local = listener.local_addr()?;
                (TcpConfig::from_listener(listener)?.into(), Some(local))
            }
            ConnectAddress::Serial { device, baud } => {
                (SerialConfig::new(device.clone(), *baud).into(), None)
            }
        };
        let mut connection = address.connect_async::<MavMessage>().await?;
        // Telemetry radios are often left on MAVLink 1; read both, send 2.
        connection.set_allow_recv_any_version(true);
        Ok((connection, local))
    }
}

fn resolve(hostport: &str) -> io::Result<SocketAddr> {
    hostport.to_socket_addrs()?.next().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::AddrNotAvailable,
            format!("`{hostport}` resolves to no address"),
        )
    })
}

fn looks_like_device(text: &str) -> bool {
    text.starts_with('/')
        || text.starts_with("\\\\.\\")
        || text.get(..3).is_some_and(|p| p.eq_ignore_ascii_case("com"))
            && text[3..].chars().next().is_some_and(|c| c.is_ascii_digit())
}

impl fmt::Display for ConnectAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConnectAddress::UdpIn(a) => write!(f, "udpin:{a}"),
            ConnectAddress::UdpOut(a) => write!(f, "udpout:{a}"),
            ConnectAddress::TcpOut(a) => write!(f, "tcpout:{a}"),
            ConnectAddress::TcpIn(a) => write!(f, "tcpin:{a}"),
            ConnectAddress::Serial { device, baud } => write!(f, "serial:{device}:{baud}"),
        }
    }
}

impl std::str::FromStr for ConnectAddress {
    type Err = AddressError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn network_connections_read_as_mavproxy_and_pymavlink_spell_them() {
        assert_eq!(
            ConnectAddress::parse("udpin:0.0.0.0:14550"),
            Ok(ConnectAddress::UdpIn("0.0.0.0:14550".into()))
        );
        assert_eq!(
            ConnectAddress::parse("udp:127.0.0.1:14550"),
            Ok(ConnectAddress::UdpIn("127.0.0.1:14550".into()))
        );
        assert_eq!(
            ConnectAddress::parse("udpout:10.0.0.2:14555"),
            Ok(ConnectAddress::UdpOut("10.0.0.2:14555".into()))
        );
        assert_eq!(
            ConnectAddress::parse("tcp:127.0.0.1:5760"),
            Ok(ConnectAddress::TcpOut("127.0.0.1:5760".into()))
        );
        assert_eq!(
            ConnectAddress::parse("tcpout:localhost:5760"),
            Ok(ConnectAddress::TcpOut("localhost:5760".into()))
        );
        assert_eq!(
            ConnectAddress::parse("tcpin:127.0.0.1:0"),
            Ok(ConnectAddress::TcpIn("127.0.0.1:0".into()))
        );
    }

    #[test]
    fn serial_ports_read_with_or_without_a_baud_rate() {
        assert_eq!(
            ConnectAddress::parse("serial:/dev/ttyACM0:115200"),
            Ok(ConnectAddress::Serial {
                device: "/dev/ttyACM0".into(),
                baud: 115_200
            })
        );
        assert_eq!(
            ConnectAddress::parse("/dev/ttyUSB0,921600"),
            Ok(ConnectAddress::Serial {
                device: "/dev/ttyUSB0".into(),
                baud: 921_600
            })
        );
        assert_eq!(
            ConnectAddress::parse("/dev/serial/by-id/usb-ArduPilot_fmuv3-if00"),
            Ok(ConnectAddress::Serial {
                device: "/dev/serial/by-id/usb-ArduPilot_fmuv3-if00".into(),
                baud: DEFAULT_BAUD
            })
        );
        assert_eq!(
            ConnectAddress::parse("COM3:57600"),
            Ok(ConnectAddress::Serial {
                device: "COM3".into(),
                baud: 57_600
            })
        );
    }

    #[test]
    fn a_malformed_connection_names_what_is_wrong() {
        let e = ConnectAddress::parse("udpin:14550").unwrap_err();
        assert!(
            e.reason.contains("host is missing") || e.reason.contains("separated"),
            "{e}"
        );
        let e = ConnectAddress::parse("udpin:0.0.0.0:port").unwrap_err();
        assert!(e.reason.contains("`port` is not a port number"), "{e}");
        let e = ConnectAddress::parse("http://drone").unwrap_err();
        assert!(e
            .to_string()
            .contains("`http://drone` is not a MAVLink connection"));
        assert!(ConnectAddress::parse("").is_err());
        assert!(ConnectAddress::parse("serial:/dev/ttyS0:0").is_err());
    }

    #[test]
    fn an_address_prints_back_in_the_canonical_spelling() {
        for s in [
            "udpin:0.0.0.0:14550",
            "udpout:127.0.0.1:14555",
            "tcpout:127.0.0.1:5760",
            "serial:/dev/ttyACM0:57600",
        ] {
            assert_eq!(ConnectAddress::parse(s).unwrap().to_string(), s);
        }
        assert_eq!(
            ConnectAddress::parse("tcp:127.0.0.1:5760")
                .unwrap()
                .to_string(),
            "tcpout:127.0.0.1:5760"
        );
    }

    #[tokio::test]
    async fn a_listener_on_port_zero_reports_the_port_it_bound() {
        let (_conn, local) = ConnectAddress::parse("udpin:127.0.0.1:0")
            .unwrap()
            .open()
            .await
            .unwrap();
        let local = local.unwrap();
        assert_ne!(local.port(), 0);
        assert!(local.ip().is_loopback());
    }
}
