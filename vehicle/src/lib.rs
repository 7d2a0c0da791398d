//! `eamos-vehicle`: [`SimVehicle`], the simulator's multirotor behind a
//! MAVLink 2 endpoint that behaves like an ArduPilot copter in the ways a
//! ground station notices, so that the adapter (and any other MAVLink
//! client) can be tested without ArduPilot's SITL.
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
//! - Parameters (`params`): it serves the ones it acts on by name
//!   (PARAM_REQUEST_READ): `FS_GCS_ENABLE` (0 by default, as ArduCopter
//!   ships) and `FS_GCS_TIMEOUT`: with the GCS failsafe on, no ground
//!   station heartbeat for that long while flying takes it to RTL (1, 3, 6)
//!   or LAND (4, 5, 7). `MAV_CMD_RUN_PREARM_CHECKS` repeats a failing
//!   pre-arm check at once.
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
//!   stops for that long, it leaves OFFBOARD (PX4's offboard-loss
//!   failsafe) for the mode `COM_OBL_RC_ACT` names (Return, Land; the
//!   pilot's modes, which need sticks it has not, and Hold become
//!   AUTO.LOITER; Terminate and Disarm stop the motors) and says so.
//! - Take-off: armed in OFFBOARD, a setpoint above the ground makes it
//!   climb; or `MAV_CMD_NAV_TAKEOFF` (param7 an altitude above sea level,
//!   NaN for the default 2.5 m) climbs in AUTO.TAKEOFF and then holds in
//!   AUTO.LOITER. There is no GUIDED take-off.
//!
//! On UDP it talks like SITL started with `--out`: from a port of its own
//! to the ground station's (`udpout:`), answering whoever it hears; it can
//! also listen (`udpin:`, `tcpin:` like SITL's `tcp:5760`).
//!
//! Behind `eamos sim-vehicle` and the MAVLink adapter's flight tests. Its
//! parts: [`options`] (how a vehicle is set up), [`handle`] (a running
//! vehicle as a test holds it), and inside, the vehicle's state and its
//! rules (`state`), the one task that runs it (`task`), its telemetry
//! (`telemetry`), the commands it answers (`commands`), its flight modes
//! (`mode`, `flight`) and PX4's ways (`px4`).
//!
//! Architecture invariant: a test instrument, never flown by a mission. It
//! speaks to the adapter only over MAVLink, as an autopilot would; nothing
//! of the middle layer depends on it, and it knows nothing of missions.

// SET_MODE and REQUEST_DATA_STREAM are deprecated in MAVLink, but
// MAVProxy and pymavlink still send them and ArduPilot still answers them.
#![allow(deprecated)]

mod commands;
mod firmware;
mod flight;
pub mod handle;
mod mode;
pub mod options;
mod params;
mod px4;
mod state;
mod task;
mod telemetry;

pub use firmware::Firmware;
pub use handle::SimVehicle;
pub use options::SimVehicleOptions;
pub use state::VehicleSnapshot;
