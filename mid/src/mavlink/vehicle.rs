//! [`SimVehicle`]: the simulator's multirotor behind a MAVLink 2 endpoint
//! that behaves like an ArduPilot copter in the ways a ground station
//! notices, so that the adapter (and any other MAVLink client) can be
//! tested without ArduPilot's SITL.
//!
//! What it imitates, in simulated time (`speed` times real time):
//! - Boot: STABILIZE, disarmed. Readiness comes in stages over
//!   `ready_after` seconds, in the proportions SITL shows (of about 41 s):
//!   a 3D GPS fix at 22 %, the EKF origin at 46 % (only then does
//!   LOCAL_POSITION_NED exist), the EKF using GPS and the pre-arm checks
//!   passing at 100 %. Each stage is announced in a STATUSTEXT, and a
//!   failing pre-arm check is repeated every 30 s as ArduPilot does.
//! - Streams: only HEARTBEAT (1 Hz) and STATUSTEXT until a client asks
//!   with `MAV_CMD_SET_MESSAGE_INTERVAL`, `MAV_CMD_REQUEST_MESSAGE` or the
//!   older REQUEST_DATA_STREAM: SYS_STATUS (with battery), GPS_RAW_INT,
//!   GLOBAL_POSITION_INT, LOCAL_POSITION_NED, EKF_STATUS_REPORT,
//!   EXTENDED_SYS_STATE.
//! - Modes: STABILIZE, ALT_HOLD, LOITER, POSHOLD, BRAKE, GUIDED, LAND and
//!   RTL (home at the current height, then land) through
//!   `MAV_CMD_DO_SET_MODE` or SET_MODE; GUIDED only once the EKF has an
//!   origin. Optionally the RC mode switch selects STABILIZE once, some
//!   seconds after boot, overwriting a mode set before (`rc_mode_switch_at`).
//! - Commands answered with COMMAND_ACK; refusals (arming before the
//!   pre-arm checks pass, or against an arming check given in
//!   `refuse_arming`; take-off when not armed, not in GUIDED or already
//!   flying; disarming in flight) come with a STATUSTEXT saying why.
//! - GUIDED flies SET_POSITION_TARGET_LOCAL_NED position targets
//!   (MAV_FRAME_LOCAL_NED, relative to the EKF origin).
//! - Armed on the ground without taking off for `idle_disarm_after`
//!   seconds (ArduPilot's DISARM_DELAY): it disarms itself. LAND disarms on
//!   touchdown.
//!
//! With `autopilot = Firmware::Px4` it behaves like PX4 instead where PX4
//! differs in ways a ground station must handle:
//! - HEARTBEAT says `MAV_AUTOPILOT_PX4`, modes are PX4's (main and sub-mode
//!   packed in `custom_mode`): MANUAL at boot, POSCTL, ALTCTL, STABILIZED,
//!   AUTO.LOITER, AUTO.TAKEOFF, AUTO.LAND, AUTO.RTL, OFFBOARD; no GUIDED.
//! - Telemetry streams from boot without being asked (PX4's default
//!   streams on a ground-station link); no EKF_STATUS_REPORT.
//! - OFFBOARD is refused (`MAV_RESULT_TEMPORARILY_REJECTED`) unless
//!   SET_POSITION_TARGET_LOCAL_NED setpoints have been arriving, the last
//!   within `offboard_loss_after` seconds; in OFFBOARD, when the stream
//!   stops for that long, it leaves OFFBOARD for AUTO.LOITER (PX4's
//!   offboard-loss failsafe) and says so.
//! - Take-off: armed in OFFBOARD, a setpoint above the ground makes it
//!   climb; or `MAV_CMD_NAV_TAKEOFF` (param7 an altitude above sea level,
//!   NaN for the default 2.5 m) climbs in AUTO.TAKEOFF and then holds in
//!   AUTO.LOITER. There is no GUIDED take-off.
//!
//! On UDP it talks like SITL started with `--out`: from a port of its own
//! to the ground station's (`udpout:`), answering whoever it hears; it can
//! also listen (`udpin:`, `tcpin:` like SITL's `tcp:5760`).

// SET_MODE and REQUEST_DATA_STREAM are deprecated in MAVLink, but
// MAVProxy and pymavlink still send them and ArduPilot still answers them.
#![allow(deprecated)]

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use mavlink::MavHeader;
use tokio::sync::{broadcast, watch};
use tokio::time::{sleep_until, Instant};
use tokio_util::sync::CancellationToken;

use eamos_geo::{LocalFrame, Ned, Wgs84};

use crate::api::{FlightMode, Vec3};
use crate::sim::kinematics::{Multirotor, MultirotorConfig};

use super::address::ConnectAddress;
use super::dialect::{
    EkfStatusFlags, GpsFixType, MavAutopilot, MavCmd, MavDataStream, MavFrame, MavLandedState,
    MavMessage, MavModeFlag, MavResult, MavSeverity, MavState, MavSysStatusSensor, MavType,
    MavVtolState, PositionTargetTypemask, COMMAND_ACK_DATA, COMMAND_LONG_DATA,
    EKF_STATUS_REPORT_DATA, EXTENDED_SYS_STATE_DATA, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA,
    HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA, STATUSTEXT_DATA,
    SYS_STATUS_DATA,
};
use super::link::{Link, Received};
use super::modes::{CopterMode, Px4Mode};

/// PX4's default take-off height (`MIS_TAKEOFF_ALT`), metres.
const PX4_TAKEOFF_HEIGHT: f64 = 2.5;

/// ArduPilot's magic number that forces a disarm in flight.
const FORCE_DISARM: f32 = 21196.0;

/// How the test vehicle is set up.
#[derive(Debug, Clone)]
pub struct SimVehicleOptions {
    /// Where it talks: `udpout:GCS` (like SITL's `--out`), `udpin:`,
    /// `tcpin:`.
    pub connect: ConnectAddress,
    pub system_id: u8,
    pub component_id: u8,
    /// Simulated seconds from boot until it is ready to arm.
    pub ready_after: f64,
    /// Simulated seconds per real second.
    pub speed: f64,
    /// Simulated seconds per step of the kinematics.
    pub step: f64,
    /// Where it stands at boot (and its home).
    pub home: Wgs84,
    /// Where the EKF origin lies from home (real EKFs set it at the first
    /// fix, rarely exactly where the copter stands when it arms).
    pub ekf_origin_offset: Ned,
    /// Simulated seconds after boot at which the RC mode switch selects
    /// STABILIZE, overwriting whatever mode was set before.
    pub rc_mode_switch_at: Option<f64>,
    /// An arming check that fails: arming is refused with this STATUSTEXT
    /// although the pre-arm checks pass ("Arm: Hardware safety switch").
    pub refuse_arming: Option<String>,
    /// Simulated seconds armed on the ground without taking off before it
    /// disarms itself.
    pub idle_disarm_after: f64,
    pub kinematics: MultirotorConfig,
    /// Whose behaviour it imitates.
    pub autopilot: Firmware,
    /// PX4: simulated seconds without a setpoint after which OFFBOARD is
    /// unavailable, or left for AUTO.LOITER (PX4's `COM_OF_LOSS_T`).
    pub offboard_loss_after: f64,
}

/// The autopilot firmware a test vehicle imitates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Firmware {
    #[default]
    ArduPilot,
    Px4,
}

impl Default for SimVehicleOptions {
    fn default() -> Self {
        Self {
            connect: ConnectAddress::UdpOut("127.0.0.1:14550".to_string()),
            system_id: 1,
            component_id: 1,
            ready_after: 40.0,
            speed: 1.0,
            step: 0.02,
            // ArduPilot SITL's default location (CMAC, Canberra).
            home: Wgs84::new(-35.363_261, 149.165_230, 584.0),
            ekf_origin_offset: Ned::default(),
            rc_mode_switch_at: None,
            refuse_arming: None,
            idle_disarm_after: 10.0,
            kinematics: MultirotorConfig::default(),
            autopilot: Firmware::ArduPilot,
            offboard_loss_after: 1.0,
        }
    }
}

impl SimVehicleOptions {
    /// Checks the numbers a command line may have got wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.speed.is_finite() && self.speed > 0.0) {
            return Err(format!("the speed must be above zero, not {}", self.speed));
        }
        if !(self.ready_after.is_finite() && self.ready_after >= 0.0) {
            return Err(format!(
                "the time to readiness must be zero or more seconds, not {}",
                self.ready_after
            ));
        }
        if !(self.step.is_finite() && (0.001..=0.1).contains(&self.step)) {
            return Err(format!(
                "the step must be between 0.001 and 0.1 s, not {}",
                self.step
            ));
        }
        if !(self.idle_disarm_after.is_finite() && self.idle_disarm_after > 0.0) {
            return Err(format!(
                "the idle disarm delay must be above zero, not {}",
                self.idle_disarm_after
            ));
        }
        if let Some(t) = self.rc_mode_switch_at {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("the RC switch time must be zero or more, not {t}"));
            }
        }
        if !(self.offboard_loss_after.is_finite() && self.offboard_loss_after > 0.0) {
            return Err(format!(
                "the offboard loss time must be above zero, not {}",
                self.offboard_loss_after
            ));
        }
        if self.system_id == 0 {
            return Err("system id 0 is the broadcast address".to_string());
        }
        self.kinematics.validate()
    }
}

/// What a test may check of the vehicle from outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleSnapshot {
    /// Simulated seconds since boot.
    pub time: f64,
    /// Position from home (X north, Y east, Z up).
    pub position: Vec3,
    pub armed: bool,
    pub custom_mode: u32,
    pub on_ground: bool,
    pub photos: u32,
}

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

/// Message ids the vehicle can stream, with ArduPilot's data-stream group.
const STREAMABLE: &[(u32, MavDataStream)] = &[
    (1, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // SYS_STATUS
    (24, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // GPS_RAW_INT
    (33, MavDataStream::MAV_DATA_STREAM_POSITION),       // GLOBAL_POSITION_INT
    (32, MavDataStream::MAV_DATA_STREAM_POSITION),       // LOCAL_POSITION_NED
    (193, MavDataStream::MAV_DATA_STREAM_EXTRA3),        // EKF_STATUS_REPORT
    (245, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // EXTENDED_SYS_STATE
];

/// What a mode makes the copter do, whichever firmware numbers it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// A pilot flies it (sticks centred: it holds).
    Manual,
    /// It holds position by itself.
    Hold,
    /// It flies position targets from the ground station (GUIDED, OFFBOARD).
    Guided,
    Land,
    Rtl,
    /// PX4's AUTO.TAKEOFF: climbs, then holds.
    Takeoff,
}

/// A flight mode of the imitated firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Mode {
    firmware: Firmware,
    custom: u32,
}

impl Mode {
    fn copter(m: CopterMode) -> Mode {
        Mode {
            firmware: Firmware::ArduPilot,
            custom: m.custom_mode(),
        }
    }

    fn px4(m: Px4Mode) -> Mode {
        Mode {
            firmware: Firmware::Px4,
            custom: m.custom_mode(),
        }
    }

    /// The mode at boot, and the one the RC switch selects.
    fn boot(firmware: Firmware) -> Mode {
        match firmware {
            Firmware::ArduPilot => Mode::copter(CopterMode::Stabilize),
            Firmware::Px4 => Mode::px4(Px4Mode::Manual),
        }
    }

    fn for_role(firmware: Firmware, role: Role) -> Mode {
        match (firmware, role) {
            (Firmware::ArduPilot, Role::Land) => Mode::copter(CopterMode::Land),
            (Firmware::ArduPilot, Role::Rtl) => Mode::copter(CopterMode::Rtl),
            (Firmware::ArduPilot, Role::Guided) => Mode::copter(CopterMode::Guided),
            (Firmware::ArduPilot, _) => Mode::copter(CopterMode::Loiter),
            (Firmware::Px4, Role::Land) => Mode::px4(Px4Mode::AutoLand),
            (Firmware::Px4, Role::Rtl) => Mode::px4(Px4Mode::AutoRtl),
            (Firmware::Px4, Role::Guided) => Mode::px4(Px4Mode::Offboard),
            (Firmware::Px4, Role::Takeoff) => Mode::px4(Px4Mode::AutoTakeoff),
            (Firmware::Px4, _) => Mode::px4(Px4Mode::AutoLoiter),
        }
    }

    /// What the mode does, or `None` when the firmware has no such mode
    /// or the test vehicle does not simulate it.
    fn role_of(firmware: Firmware, custom: u32) -> Option<Role> {
        match firmware {
            Firmware::ArduPilot => {
                use CopterMode::*;
                Some(match CopterMode::from_custom_mode(custom)? {
                    Stabilize | AltHold => Role::Manual,
                    Loiter | PosHold | Brake => Role::Hold,
                    Guided => Role::Guided,
                    Land => Role::Land,
                    Rtl => Role::Rtl,
                    _ => return None,
                })
            }
            Firmware::Px4 => {
                use Px4Mode::*;
                Some(match Px4Mode::from_custom_mode(custom)? {
                    Manual | AltCtl | PosCtl | Stabilized => Role::Manual,
                    AutoLoiter => Role::Hold,
                    Offboard => Role::Guided,
                    AutoLand => Role::Land,
                    AutoRtl => Role::Rtl,
                    AutoTakeoff => Role::Takeoff,
                    _ => return None,
                })
            }
        }
    }

    fn role(self) -> Role {
        Mode::role_of(self.firmware, self.custom).unwrap_or(Role::Manual)
    }

    fn name(self) -> String {
        match self.firmware {
            Firmware::ArduPilot => super::modes::Autopilot::ArduPilot.mode_name(self.custom),
            Firmware::Px4 => super::modes::Autopilot::Px4.mode_name(self.custom),
        }
    }

    /// Whether the mode needs the EKF's position (an origin).
    fn needs_position(self) -> bool {
        match self.role() {
            Role::Manual => {
                self.custom == Px4Mode::PosCtl.custom_mode() && self.firmware == Firmware::Px4
            }
            Role::Land => false,
            _ => true,
        }
    }
}

/// The vehicle's state, owned by its one task.
struct Vehicle {
    o: SimVehicleOptions,
    kin: Multirotor,
    time: f64,
    mode: Mode,
    /// PX4: when the last position setpoint came, and where it was (EKF
    /// frame), whatever the mode.
    setpoint: Option<(f64, Ned)>,
    /// Requested message intervals (simulated seconds) and when each is
    /// next due.
    streams: HashMap<u32, (f64, f64)>,
    next_heartbeat: f64,
    /// When the copter was armed on the ground without taking off since.
    idle_since: Option<f64>,
    /// RTL: flying home before landing.
    returning: bool,
    /// Milestones already announced: GPS, origin, using GPS, RC switch.
    announced: [bool; 4],
    next_prearm_text: f64,
    photos: u32,
    /// Messages to send after this step.
    outbox: Vec<MavMessage>,
}

impl Vehicle {
    fn new(o: SimVehicleOptions) -> Self {
        let kin = Multirotor::new(o.kinematics.clone());
        let boot_mode = Mode::boot(o.autopilot);
        Self {
            o,
            kin,
            time: 0.0,
            mode: boot_mode,
            setpoint: None,
            streams: HashMap::new(),
            next_heartbeat: 0.0,
            idle_since: None,
            returning: false,
            announced: [false; 4],
            // After the first heartbeats, so a ground station knows whose
            // text it is.
            next_prearm_text: 2.0,
            photos: 0,
            outbox: Vec::new(),
        }
        .with_default_streams()
    }

    /// PX4 streams telemetry on a ground-station link from boot;
    /// ArduPilot waits to be asked.
    fn with_default_streams(mut self) -> Self {
        if self.o.autopilot == Firmware::Px4 {
            for (id, hz) in [(1, 1.0), (24, 1.0), (32, 10.0), (33, 5.0), (245, 1.0)] {
                self.streams.insert(id, (1.0 / hz, 0.0));
            }
        }
        self
    }

    /// Whether the firmware sends message `id` at all.
    fn streamable(&self, id: u32) -> bool {
        STREAMABLE.iter().any(|(s, _)| *s == id)
            && !(self.o.autopilot == Firmware::Px4 && id == 193)
    }

    fn gps_fix_at(&self) -> f64 {
        self.o.ready_after * 0.22
    }

    fn origin_at(&self) -> f64 {
        self.o.ready_after * 0.46
    }

    fn has_fix(&self) -> bool {
        self.time >= self.gps_fix_at()
    }

    fn has_origin(&self) -> bool {
        self.time >= self.origin_at()
    }

    fn ready(&self) -> bool {
        self.time >= self.o.ready_after
    }

    /// Why the pre-arm checks fail, in the firmware's manner.
    fn prearm_failure(&self) -> Option<&'static str> {
        let px4 = self.o.autopilot == Firmware::Px4;
        if !self.has_fix() {
            Some(if px4 {
                "Preflight Fail: GPS fix too low"
            } else {
                "PreArm: GPS 1: Bad fix"
            })
        } else if !self.ready() {
            Some(if px4 {
                "Preflight Fail: horizontal position unstable"
            } else {
                "PreArm: Need Position Estimate"
            })
        } else {
            None
        }
    }

    fn snapshot(&self) -> VehicleSnapshot {
        VehicleSnapshot {
            time: self.time,
            position: self.kin.position(),
            armed: self.kin.is_armed(),
            custom_mode: self.mode.custom,
            on_ground: self.kin.on_ground(),
            photos: self.photos,
        }
    }

    async fn run(
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

    fn say(&mut self, severity: MavSeverity, text: &str) {
        tracing::info!("sim-vehicle {}: {text}", self.o.system_id);
        self.outbox.push(MavMessage::STATUSTEXT(STATUSTEXT_DATA {
            severity,
            text: text.into(),
        }));
    }

    /// One step of simulated time: the copter moves, and the autopilot's
    /// own rules run (readiness milestones, RC switch, auto-disarm, LAND).
    fn step(&mut self) {
        let dt = self.o.step;
        let events = self.kin.step(dt);
        self.time += dt;

        if self.has_fix() && !self.announced[0] {
            self.announced[0] = true;
            self.say(
                MavSeverity::MAV_SEVERITY_INFO,
                "GPS 1: detected u-blox, 3D fix",
            );
        }
        if self.has_origin() && !self.announced[1] {
            self.announced[1] = true;
            self.say(MavSeverity::MAV_SEVERITY_INFO, "EKF3 IMU0 origin set");
        }
        if self.ready() && !self.announced[2] {
            self.announced[2] = true;
            self.say(MavSeverity::MAV_SEVERITY_INFO, "EKF3 IMU0 is using GPS");
        }
        if let Some(at) = self.o.rc_mode_switch_at {
            if self.time >= at && !self.announced[3] {
                self.announced[3] = true;
                let manual = Mode::boot(self.o.autopilot);
                if self.mode != manual {
                    tracing::info!(
                        "sim-vehicle {}: the RC mode switch selects {} over {}",
                        self.o.system_id,
                        manual.name(),
                        self.mode.name()
                    );
                }
                self.set_mode(manual);
            }
        }
        if let Some(text) = self.prearm_failure() {
            if self.time >= self.next_prearm_text {
                self.next_prearm_text = self.time + 30.0;
                self.say(MavSeverity::MAV_SEVERITY_CRITICAL, text);
            }
        }

        let landing_mode = matches!(self.mode.role(), Role::Land | Role::Rtl);
        if events.touched_down && self.kin.is_armed() && landing_mode {
            let _ = self.kin.disarm();
            self.say(MavSeverity::MAV_SEVERITY_INFO, "Land complete; disarming");
        }
        if events.lifted_off {
            self.idle_since = None;
        }
        if self.kin.is_armed() && self.kin.on_ground() {
            let since = *self.idle_since.get_or_insert(self.time);
            if self.time - since >= self.o.idle_disarm_after {
                let _ = self.kin.disarm();
                self.idle_since = None;
                self.say(
                    MavSeverity::MAV_SEVERITY_INFO,
                    "Disarming motors (auto disarm)",
                );
            }
        } else if !self.kin.is_armed() {
            self.idle_since = None;
        }
        if self.returning && self.kin.arrived() {
            self.returning = false;
            self.kin.land();
        }
        if self.mode.role() == Role::Takeoff && self.kin.is_airborne() && self.kin.arrived() {
            self.say(MavSeverity::MAV_SEVERITY_INFO, "Takeoff complete: holding");
            self.set_mode(Mode::for_role(self.o.autopilot, Role::Hold));
        }
        // PX4's offboard-loss failsafe: OFFBOARD without a fresh setpoint
        // is left for AUTO.LOITER.
        if self.mode.firmware == Firmware::Px4
            && self.mode.role() == Role::Guided
            && !self.setpoints_fresh()
        {
            self.say(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "Failsafe: offboard setpoints lost, switching to Hold",
            );
            self.set_mode(Mode::for_role(self.o.autopilot, Role::Hold));
        }
    }

    /// PX4: whether a setpoint came within the offboard loss time.
    fn setpoints_fresh(&self) -> bool {
        self.setpoint
            .is_some_and(|(at, _)| self.time - at <= self.o.offboard_loss_after)
    }

    /// Queues the heartbeat and every stream that is due.
    fn emit_due(&mut self) {
        if self.time >= self.next_heartbeat {
            self.next_heartbeat += 1.0;
            let hb = self.heartbeat();
            self.outbox.push(hb);
        }
        let mut due = Vec::new();
        for (id, (interval, next)) in self.streams.iter_mut() {
            if self.time >= *next {
                *next = (*next + *interval).max(self.time);
                due.push(*id);
            }
        }
        due.sort_unstable();
        for id in due {
            if let Some(m) = self.message(id) {
                self.outbox.push(m);
            }
        }
    }

    fn heartbeat(&self) -> MavMessage {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
        if self.kin.is_armed() {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        if self.mode.role() == Role::Guided {
            base |= MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
        }
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: self.mode.custom,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: match self.o.autopilot {
                Firmware::ArduPilot => MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                Firmware::Px4 => MavAutopilot::MAV_AUTOPILOT_PX4,
            },
            base_mode: base,
            system_status: if self.kin.is_armed() {
                MavState::MAV_STATE_ACTIVE
            } else {
                MavState::MAV_STATE_STANDBY
            },
            mavlink_version: 3,
        })
    }

    /// Position relative to the EKF origin.
    fn local_ned(&self) -> Ned {
        Ned::from_mission(self.kin.position()) - self.o.ekf_origin_offset
    }

    fn boot_ms(&self) -> u32 {
        (self.time * 1000.0) as u32
    }

    /// One message of a stream, or `None` when the autopilot would not
    /// have it yet (no local position before the EKF origin).
    fn message(&self, id: u32) -> Option<MavMessage> {
        let v = self.kin.velocity();
        let vel = Ned::from_mission(v);
        Some(match id {
            1 => {
                let sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY;
                let prearm = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
                let mut health = sensors;
                if !self.has_fix() {
                    health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS);
                }
                if self.prearm_failure().is_none() || self.kin.is_armed() {
                    health |= prearm;
                }
                let battery = self.kin.battery();
                MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                    onboard_control_sensors_present: sensors | prearm,
                    onboard_control_sensors_enabled: sensors | prearm,
                    onboard_control_sensors_health: health,
                    load: 250,
                    // A 4S pack: 16.8 V full, 14.0 V empty.
                    voltage_battery: (14_000.0 + 28.0 * battery) as u16,
                    current_battery: if self.kin.is_airborne() { 1200 } else { 50 },
                    battery_remaining: battery.round().clamp(0.0, 100.0) as i8,
                    ..Default::default()
                })
            }
            24 => {
                let here = LocalFrame::new(self.o.home).to_wgs84(self.kin.position());
                let (lat, lon, alt) = here.to_e7();
                MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                    time_usec: (self.time * 1e6) as u64,
                    lat: if self.has_fix() { lat } else { 0 },
                    lon: if self.has_fix() { lon } else { 0 },
                    alt: if self.has_fix() { alt } else { 0 },
                    eph: if self.has_fix() { 121 } else { u16::MAX },
                    epv: if self.has_fix() { 200 } else { u16::MAX },
                    vel: (v.horizontal_norm() * 100.0) as u16,
                    cog: 0,
                    fix_type: if self.has_fix() {
                        GpsFixType::GPS_FIX_TYPE_3D_FIX
                    } else {
                        GpsFixType::GPS_FIX_TYPE_NO_FIX
                    },
                    satellites_visible: if self.has_fix() { 10 } else { 0 },
                })
            }
            33 => {
                if !self.has_fix() {
                    return None;
                }
                let p = self.kin.position();
                let here = LocalFrame::new(self.o.home).to_wgs84(p);
                let (lat, lon, alt) = here.to_e7();
                MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: self.boot_ms(),
                    lat,
                    lon,
                    alt,
                    relative_alt: (p.z * 1000.0).round() as i32,
                    vx: (vel.north * 100.0).round() as i16,
                    vy: (vel.east * 100.0).round() as i16,
                    vz: (vel.down * 100.0).round() as i16,
                    hdg: 0,
                })
            }
            32 => {
                if !self.has_origin() {
                    return None;
                }
                let p = self.local_ned();
                MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                    time_boot_ms: self.boot_ms(),
                    x: p.north as f32,
                    y: p.east as f32,
                    z: p.down as f32,
                    vx: vel.north as f32,
                    vy: vel.east as f32,
                    vz: vel.down as f32,
                })
            }
            193 if self.o.autopilot == Firmware::Px4 => return None,
            193 => {
                let mut flags = EkfStatusFlags::EKF_ATTITUDE | EkfStatusFlags::EKF_VELOCITY_VERT;
                if self.has_origin() {
                    flags |= EkfStatusFlags::EKF_VELOCITY_HORIZ
                        | EkfStatusFlags::EKF_POS_HORIZ_REL
                        | EkfStatusFlags::EKF_POS_VERT_AGL
                        | EkfStatusFlags::EKF_PRED_POS_HORIZ_REL;
                } else {
                    flags |= EkfStatusFlags::EKF_CONST_POS_MODE;
                }
                if self.ready() {
                    flags |= EkfStatusFlags::EKF_POS_HORIZ_ABS
                        | EkfStatusFlags::EKF_POS_VERT_ABS
                        | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS;
                }
                MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                    velocity_variance: 0.02,
                    pos_horiz_variance: if self.ready() { 0.01 } else { 0.5 },
                    pos_vert_variance: 0.01,
                    compass_variance: 0.01,
                    terrain_alt_variance: 0.0,
                    flags,
                })
            }
            245 => MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: if self.kin.on_ground() {
                    MavLandedState::MAV_LANDED_STATE_ON_GROUND
                } else if self.kin.mode() == FlightMode::Takeoff {
                    MavLandedState::MAV_LANDED_STATE_TAKEOFF
                } else if self.kin.mode() == FlightMode::Land {
                    MavLandedState::MAV_LANDED_STATE_LANDING
                } else {
                    MavLandedState::MAV_LANDED_STATE_IN_AIR
                },
            }),
            _ => return None,
        })
    }

    fn for_me(&self, system: u8, component: u8) -> bool {
        (system == 0 || system == self.o.system_id)
            && (component == 0 || component == self.o.component_id)
    }

    fn handle(&mut self, r: &Received) {
        match &r.message {
            MavMessage::COMMAND_LONG(c) if self.for_me(c.target_system, c.target_component) => {
                let result = self.command(c);
                self.outbox.push(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                    command: c.command,
                    result,
                }));
            }
            MavMessage::SET_MODE(m) if self.for_me(m.target_system, 0) => {
                let result = self.set_mode_number(m.custom_mode);
                self.outbox.push(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                    command: MavCmd::MAV_CMD_DO_SET_MODE,
                    result,
                }));
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)
                if self.for_me(t.target_system, t.target_component) =>
            {
                self.position_target(t);
            }
            MavMessage::REQUEST_DATA_STREAM(r)
                if self.for_me(r.target_system, r.target_component) =>
            {
                let all = r.req_stream_id == MavDataStream::MAV_DATA_STREAM_ALL;
                for (id, group) in STREAMABLE {
                    if !self.streamable(*id) {
                        continue;
                    }
                    if all || *group == r.req_stream_id {
                        if r.start_stop == 0 || r.req_message_rate == 0 {
                            self.streams.remove(id);
                        } else {
                            let interval = 1.0 / f64::from(r.req_message_rate);
                            self.streams.insert(*id, (interval, self.time));
                        }
                    }
                }
            }
            _ => {}
        }
        // Answer messages queued while handling go out with the next step.
    }

    fn refuse(&mut self, result: MavResult, text: &str) -> MavResult {
        self.say(MavSeverity::MAV_SEVERITY_CRITICAL, text);
        result
    }

    fn command(&mut self, c: &COMMAND_LONG_DATA) -> MavResult {
        use MavResult::*;
        match c.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if c.param1 == 1.0 => self.arm(),
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if c.param1 == 0.0 => {
                if self.kin.is_airborne() && c.param2 != FORCE_DISARM {
                    return self.refuse(MAV_RESULT_FAILED, "Disarm: vehicle is flying");
                }
                if self.kin.is_airborne() {
                    // A forced disarm in the air: the copter falls.
                    self.kin
                        .place(Vec3::new(self.kin.position().x, self.kin.position().y, 0.0));
                }
                let _ = self.kin.disarm();
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_SET_MODE => {
                if c.param1 as u32 & 1 == 0 {
                    return MAV_RESULT_UNSUPPORTED;
                }
                let custom = match self.o.autopilot {
                    Firmware::ArduPilot => c.param2 as u32,
                    // PX4: main mode in param2, sub-mode in param3.
                    Firmware::Px4 => {
                        ((c.param2 as u32 & 0xff) << 16) | ((c.param3 as u32 & 0xff) << 24)
                    }
                };
                self.set_mode_number(custom)
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => match self.o.autopilot {
                Firmware::ArduPilot => self.takeoff(f64::from(c.param7)),
                Firmware::Px4 => self.px4_takeoff(f64::from(c.param7)),
            },
            MavCmd::MAV_CMD_NAV_LAND => {
                self.set_mode_number(Mode::for_role(self.o.autopilot, Role::Land).custom)
            }
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => {
                self.set_mode_number(Mode::for_role(self.o.autopilot, Role::Rtl).custom)
            }
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                let id = c.param1 as u32;
                if id == 0 {
                    // HEARTBEAT goes out at 1 Hz regardless.
                    return MAV_RESULT_ACCEPTED;
                }
                if !self.streamable(id) {
                    return MAV_RESULT_UNSUPPORTED;
                }
                let us = c.param2;
                if us < 0.0 {
                    self.streams.remove(&id);
                } else {
                    // 0 asks for the default rate: ArduPilot's is 4 Hz for
                    // these.
                    let interval = if us == 0.0 {
                        0.25
                    } else {
                        f64::from(us) * 1e-6
                    };
                    self.streams.insert(id, (interval.max(0.01), self.time));
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let id = c.param1 as u32;
                if id == 0 {
                    let hb = self.heartbeat();
                    self.outbox.push(hb);
                    return MAV_RESULT_ACCEPTED;
                }
                match self.message(id) {
                    Some(m) => {
                        self.outbox.push(m);
                        MAV_RESULT_ACCEPTED
                    }
                    None if self.streamable(id) => MAV_RESULT_FAILED,
                    None => MAV_RESULT_UNSUPPORTED,
                }
            }
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION => {
                if self.kin.is_armed() {
                    return self.refuse(MAV_RESULT_DENIED, "Calibration: vehicle is armed");
                }
                if c.param3 == 1.0 {
                    self.say(
                        MavSeverity::MAV_SEVERITY_INFO,
                        "Barometer calibration complete",
                    );
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_DIGICAM_CONTROL => {
                if c.param5 == 1.0 {
                    self.photos += 1;
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_DIGICAM_CONFIGURE => MAV_RESULT_ACCEPTED,
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    fn arm(&mut self) -> MavResult {
        if self.kin.is_armed() {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        if let Some(text) = self.prearm_failure() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, text);
        }
        if let Some(text) = self.o.refuse_arming.clone() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, &text);
        }
        if matches!(self.mode.role(), Role::Land | Role::Rtl) {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Arm: Mode not armable");
        }
        match self.kin.arm() {
            Ok(()) => {
                tracing::info!("sim-vehicle {}: armed", self.o.system_id);
                self.idle_since = Some(self.time);
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(e) => self.refuse(MavResult::MAV_RESULT_FAILED, &format!("Arm: {e}")),
        }
    }

    fn takeoff(&mut self, height: f64) -> MavResult {
        if !self.kin.is_armed() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Takeoff: motors not armed");
        }
        if self.mode != Mode::copter(CopterMode::Guided) {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Takeoff: not in GUIDED (in {})", self.mode.name()),
            );
        }
        if self.kin.is_airborne() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Takeoff: already flying");
        }
        match self.kin.takeoff(height) {
            Ok(()) => {
                self.idle_since = None;
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(e) => self.refuse(MavResult::MAV_RESULT_FAILED, &format!("Takeoff: {e}")),
        }
    }

    fn set_mode_number(&mut self, number: u32) -> MavResult {
        let firmware = self.o.autopilot;
        let mode = Mode {
            firmware,
            custom: number,
        };
        let known = match firmware {
            Firmware::ArduPilot => CopterMode::from_custom_mode(number).is_some(),
            Firmware::Px4 => Px4Mode::from_custom_mode(number).is_some(),
        };
        if !known {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Flight mode change failed: no mode {number:#x}"),
            );
        }
        if Mode::role_of(firmware, number).is_none() {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Flight mode change failed: {} not simulated", mode.name()),
            );
        }
        if mode.needs_position() && !self.has_origin() {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!(
                    "Flight mode change failed: {} requires position",
                    mode.name()
                ),
            );
        }
        if firmware == Firmware::Px4 && mode.role() == Role::Guided && !self.setpoints_fresh() {
            // PX4 enters OFFBOARD only with setpoints already streaming.
            return self.refuse(
                MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
                "Switching to OFFBOARD is not available: no offboard setpoints",
            );
        }
        if firmware == Firmware::Px4 && mode.role() == Role::Takeoff && !self.kin.is_armed() {
            return self.refuse(
                MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
                "Takeoff denied: disarmed",
            );
        }
        self.set_mode(mode);
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// Enters a mode: what the copter does on entering it.
    fn set_mode(&mut self, mode: Mode) {
        if mode != self.mode {
            tracing::info!("sim-vehicle {}: mode {}", self.o.system_id, mode.name());
        }
        self.mode = mode;
        self.returning = false;
        match mode.role() {
            Role::Land => self.kin.land(),
            Role::Rtl => {
                if self.kin.is_airborne() {
                    let z = self.kin.position().z;
                    if self
                        .kin
                        .go_to(Vec3::new(0.0, 0.0, z), FlightMode::ReturnHome)
                        .is_ok()
                    {
                        self.returning = true;
                    } else {
                        self.kin.land();
                    }
                }
            }
            Role::Takeoff => {
                if !self.kin.is_airborne() {
                    let _ = self.px4_climb(PX4_TAKEOFF_HEIGHT);
                }
            }
            Role::Guided if mode.firmware == Firmware::Px4 => {
                // OFFBOARD flies the setpoint that is streaming.
                self.kin.hold();
                if let Some((_, ned)) = self.setpoint {
                    self.offboard_target(ned);
                }
            }
            // Every other mode holds where it is: GUIDED until given a
            // target, the manual ones as a pilot would with sticks centred.
            _ => {
                if self.kin.is_airborne() {
                    self.kin.hold();
                }
            }
        }
    }

    /// PX4 `MAV_CMD_NAV_TAKEOFF`: param7 is an altitude above sea level
    /// (NaN: the default height); it climbs in AUTO.TAKEOFF.
    fn px4_takeoff(&mut self, altitude: f64) -> MavResult {
        if !self.kin.is_armed() {
            return self.refuse(MavResult::MAV_RESULT_DENIED, "Takeoff denied: disarmed");
        }
        if self.kin.is_airborne() {
            return self.refuse(
                MavResult::MAV_RESULT_DENIED,
                "Takeoff denied: already flying",
            );
        }
        let height = if altitude.is_finite() {
            altitude - self.o.home.alt
        } else {
            PX4_TAKEOFF_HEIGHT
        };
        match self.px4_climb(height) {
            Ok(()) => {
                self.mode = Mode::for_role(Firmware::Px4, Role::Takeoff);
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(text) => self.refuse(MavResult::MAV_RESULT_DENIED, &text),
        }
    }

    fn px4_climb(&mut self, height: f64) -> Result<(), String> {
        self.kin
            .takeoff(height)
            .map_err(|e| format!("Takeoff denied: {e}"))?;
        self.idle_since = None;
        Ok(())
    }

    /// PX4 in OFFBOARD flies to a setpoint (EKF frame); on the ground, a
    /// setpoint well above it is a take-off.
    fn offboard_target(&mut self, ned: Ned) {
        let target = (ned + self.o.ekf_origin_offset).to_mission();
        if !self.kin.is_armed() {
            return;
        }
        if self.kin.is_airborne() {
            if self.kin.mode() == FlightMode::Takeoff && !self.kin.arrived() {
                // Still climbing from the ground: let the climb finish
                // first, as PX4's take-off ramp does.
                return;
            }
            if let Err(e) = self.kin.go_to(target, FlightMode::Guided) {
                tracing::info!("sim-vehicle {}: ignored a setpoint: {e}", self.o.system_id);
            }
        } else if target.z > self.kin.position().z + 0.5 {
            if let Err(e) = self.px4_climb(target.z) {
                tracing::info!("sim-vehicle {}: {e}", self.o.system_id);
            }
        }
    }

    fn position_target(&mut self, t: &SET_POSITION_TARGET_LOCAL_NED_DATA) {
        if t.coordinate_frame != MavFrame::MAV_FRAME_LOCAL_NED {
            return;
        }
        let ignore_position = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Y_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Z_IGNORE;
        if t.type_mask.intersects(ignore_position) {
            // Velocity and acceleration targets are not simulated.
            return;
        }
        let setpoint = Ned::new(f64::from(t.x), f64::from(t.y), f64::from(t.z));
        if self.o.autopilot == Firmware::Px4 {
            // Every setpoint keeps the offboard stream alive, in any mode.
            self.setpoint = Some((self.time, setpoint));
            if self.mode.role() == Role::Guided {
                self.offboard_target(setpoint);
            }
            return;
        }
        if self.mode.role() != Role::Guided || !self.kin.is_airborne() {
            return;
        }
        let ned = setpoint + self.o.ekf_origin_offset;
        let target = ned.to_mission();
        if let Err(e) = self.kin.go_to(target, FlightMode::Guided) {
            tracing::info!(
                "sim-vehicle {}: ignored a position target: {e}",
                self.o.system_id
            );
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
