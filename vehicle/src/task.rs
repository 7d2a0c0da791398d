//! The one task that runs a vehicle: simulated time in fixed steps, the
//! link, the pilot's RC switch.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{broadcast, watch};
use tokio::time::{sleep_until, Instant};
use tokio_util::sync::CancellationToken;

use eamos_mid::mavlink::link::{Link, Received};

use crate::mode::Mode;
use crate::state::{Vehicle, VehicleSnapshot};

impl Vehicle {
    pub(crate) async fn run(
        mut self,
        mut link_rx: watch::Receiver<Option<Arc<Link>>>,
        mut silent: watch::Receiver<bool>,
        mut pilot: tokio::sync::mpsc::UnboundedReceiver<u32>,
        snapshot: watch::Sender<VehicleSnapshot>,
        stop: CancellationToken,
    ) {
        let started = Instant::now();
        let mut link: Option<Arc<Link>> = link_rx.borrow_and_update().clone();
        let mut incoming: Option<broadcast::Receiver<Arc<Received>>> =
            link.as_ref().map(|l| l.subscribe());
        // Wake often enough for the telemetry rates, rarely enough not to
        // spin: the kinematics catch up in fixed steps on every wake.
        let tick = Duration::from_secs_f64((self.o.step / self.o.speed).max(0.005));
        let mut next_wake = started;
        let mut link_pending = link.is_none();
        let mut silent_open = true;
        loop {
            next_wake += tick;
            tokio::select! {
                biased;
                _ = stop.cancelled() => return,
                _ = sleep_until(next_wake) => {
                    let target = started.elapsed().as_secs_f64() * self.o.speed;
                    while self.time + self.o.step <= target {
                        self.step();
                        self.emit_due();
                    }
                    let quiet = *silent.borrow();
                    if let (Some(l), false) = (&link, quiet) {
                        for m in self.outbox.drain(..) {
                            let _ = l.send(&m).await;
                        }
                    } else {
                        self.outbox.clear();
                    }
                    snapshot.send_replace(self.snapshot());
                    // A slow machine must not make the simulation race to
                    // catch up forever: drop ticks that are long past.
                    let now = Instant::now();
                    if next_wake + tick * 50 < now {
                        next_wake = now;
                    }
                }
                changed = link_rx.changed(), if link_pending => {
                    match changed {
                        Ok(()) => {
                            link = link_rx.borrow_and_update().clone();
                            incoming = link.as_ref().map(|l| l.subscribe());
                            link_pending = link.is_none();
                        }
                        // The listener could not be opened: boot on, mute.
                        Err(_) => link_pending = false,
                    }
                }
                r = recv(&mut incoming) => {
                    if let Some(r) = r {
                        if !*silent.borrow() {
                            self.handle(&r);
                        }
                    }
                }
                Some(custom) = pilot.recv() => {
                    if Mode::role_of(self.o.autopilot, custom).is_some() {
                        let mode = Mode { firmware: self.o.autopilot, custom };
                        tracing::info!(
                            "sim-vehicle {}: the RC mode switch selects {}",
                            self.o.system_id,
                            mode.name()
                        );
                        self.set_mode(mode);
                    }
                }
                changed = silent.changed(), if silent_open => {
                    silent_open = changed.is_ok();
                }
            }
        }
    }
}

async fn recv(incoming: &mut Option<broadcast::Receiver<Arc<Received>>>) -> Option<Arc<Received>> {
    match incoming {
        None => std::future::pending().await,
        Some(rx) => loop {
            match rx.recv().await {
                Ok(r) => return Some(r),
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => {
                    *incoming = None;
                    return None;
                }
            }
        },
    }
}
