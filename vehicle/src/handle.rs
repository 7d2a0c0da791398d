//! A running test vehicle, as a test or `eamos sim-vehicle` holds it.

use std::net::SocketAddr;
use std::sync::Arc;

use mavlink::MavHeader;
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;

use eamos_mid::mavlink::link::Link;
use eamos_mid::mavlink::modes::CopterMode;
use eamos_mid::mavlink::ConnectAddress;

use crate::options::SimVehicleOptions;
use crate::state::{Vehicle, VehicleSnapshot};

/// A running test vehicle; dropping it stops it.
pub struct SimVehicle {
    stop: CancellationToken,
    silent: watch::Sender<bool>,
    pilot: tokio::sync::mpsc::UnboundedSender<u32>,
    snapshot: watch::Receiver<VehicleSnapshot>,
    local: Option<SocketAddr>,
    done: tokio::task::JoinHandle<()>,
}

impl SimVehicle {
    /// Boots the vehicle and opens its connection. A `tcpin:` vehicle waits
    /// for its ground station in the background while it boots.
    pub async fn start(options: SimVehicleOptions) -> Result<SimVehicle, String> {
        options.validate()?;
        let own = MavHeader {
            system_id: u32::from(options.system_id),
            component_id: options.component_id,
            sequence: 0,
        };
        let (link_tx, link_rx) = watch::channel::<Option<Arc<Link>>>(None);
        let mut local = None;
        if matches!(options.connect, ConnectAddress::TcpIn(_)) {
            let address = options.connect.clone();
            tokio::spawn(async move {
                match Link::open(&address, own).await {
                    Ok(link) => {
                        let _ = link_tx.send(Some(Arc::new(link)));
                    }
                    Err(e) => tracing::error!("sim-vehicle: cannot listen on {address}: {e}"),
                }
            });
        } else {
            let link = Link::open(&options.connect, own)
                .await
                .map_err(|e| format!("cannot open {}: {e}", options.connect))?;
            local = link.local_addr();
            let _ = link_tx.send(Some(Arc::new(link)));
        }
        let stop = CancellationToken::new();
        let (silent, silent_rx) = watch::channel(false);
        let (pilot, pilot_rx) = tokio::sync::mpsc::unbounded_channel();
        let vehicle = Vehicle::new(options);
        let (snap_tx, snapshot) = watch::channel(vehicle.snapshot());
        let done = tokio::spawn(vehicle.run(link_rx, silent_rx, pilot_rx, snap_tx, stop.clone()));
        Ok(SimVehicle {
            stop,
            silent,
            pilot,
            snapshot,
            local,
            done,
        })
    }

    /// The local address of a `udpin` vehicle.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local
    }

    /// Stops talking and listening (a radio out of range) or resumes.
    pub fn set_silent(&self, silent: bool) {
        let _ = self.silent.send(silent);
    }

    /// The pilot flips the RC mode switch to `mode` (a pilot taking over,
    /// or the switch read at boot).
    pub fn rc_select(&self, mode: CopterMode) {
        let _ = self.pilot.send(mode.custom_mode());
    }

    /// The pilot selects a mode by its `custom_mode` number (a PX4 mode).
    pub fn rc_select_custom(&self, custom_mode: u32) {
        let _ = self.pilot.send(custom_mode);
    }

    /// The vehicle's state now.
    pub fn snapshot(&self) -> VehicleSnapshot {
        *self.snapshot.borrow()
    }

    /// A receiver of the vehicle's state, to wait for a condition.
    pub fn watch(&self) -> watch::Receiver<VehicleSnapshot> {
        self.snapshot.clone()
    }

    /// Stops the vehicle and waits until it has.
    pub async fn shutdown(mut self) {
        self.stop.cancel();
        let done = std::mem::replace(&mut self.done, tokio::spawn(async {}));
        let _ = done.await;
    }
}

impl Drop for SimVehicle {
    fn drop(&mut self) {
        self.stop.cancel();
    }
}
