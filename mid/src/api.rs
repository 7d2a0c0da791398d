//! The one drone API every platform offers to the executor.
//!
//! The executor of a slice knows nothing about autopilots: it starts actions
//! by name (as the mission spells them, with numeric arguments in the
//! mission's units and frame), cancels them when a `Do` block is interrupted,
//! and re-evaluates guards when a drone's telemetry changes. Everything
//! platform-specific lives behind [`Adapter`]; [`crate::uniform::Uniform`]
//! wraps any adapter with the profile checks and the uniform log.
//!
//! # Frame and units
//! Local frame of each drone: X north, Y east, Z up, metres from the drone's
//! home. Durations in seconds, angles in degrees, battery in percent. Each
//! drone's home is itself a point of the fleet frame (same axes, shared
//! origin), so that distances between drones can be computed from their
//! telemetry ([`Telemetry::fleet_position`]).
//!
//! # Cancellation
//! Every action takes a [`CancellationToken`]. Cancelling a motion leaves the
//! drone holding where it is and the action returns
//! [`ActionError::Cancelled`] promptly, without waiting for the drone to
//! come to rest.

use std::fmt;
use std::sync::OnceLock;

use async_trait::async_trait;
use eamos_profile::Profile;
use serde::{Deserialize, Serialize};
use tokio::sync::watch;

pub use eamos_geo::Vec3;
pub use tokio_util::sync::CancellationToken;

use crate::clock::MissionClock;
use crate::failsafe::Failsafe;

/// One action invocation as the mission states it: `Drone1.FlyTo(1, 2, 3)`
/// is `ActionCall { name: "FlyTo", args: [1.0, 2.0, 3.0] }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionCall {
    pub name: String,
    #[serde(default)]
    pub args: Vec<f64>,
}

impl ActionCall {
    pub fn new(name: impl Into<String>, args: impl Into<Vec<f64>>) -> Self {
        Self {
            name: name.into(),
            args: args.into(),
        }
    }
}

impl fmt::Display for ActionCall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}(", self.name)?;
        for (i, a) in self.args.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{a}")?;
        }
        write!(f, ")")
    }
}

/// Why an action did not succeed. The messages are written for the pilot
/// watching the mission, not for the programmer: they say what the drone
/// did and, where it helps, what to do about it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "error", rename_all = "snake_case")]
pub enum ActionError {
    /// The drone's profile (or its adapter) does not offer this action.
    #[error("`{action}` is not an action this drone offers")]
    Unsupported { action: String },
    /// The arguments do not fit the action's signature (count, or a value
    /// that is not a finite number, or out of the action's domain).
    #[error("`{action}` was called with bad arguments: {reason}")]
    BadArguments { action: String, reason: String },
    /// The drone declined to start the action in its present state (taking
    /// off while disarmed, disarming in the air). Nothing moved.
    #[error("the drone refused `{action}`: {reason}")]
    Refused { action: String, reason: String },
    /// The action started but could not be completed.
    #[error("`{action}` failed: {reason}")]
    Failed { action: String, reason: String },
    /// The link to the drone was lost while the action ran or before it
    /// could be sent; the drone's own failsafe decides what it does now.
    #[error("lost the link to the drone during `{action}`")]
    LinkLost { action: String },
    /// The adapter gave up waiting (for an acknowledgement, for arrival).
    #[error("`{action}` timed out waiting for {what}")]
    Timeout { action: String, what: String },
    /// The mission cancelled the action; a motion holds where it was.
    #[error("`{action}` was cancelled; the drone holds its position")]
    Cancelled { action: String },
}

impl ActionError {
    /// A stable one-word name of the failure kind, for logs and reports.
    pub fn kind(&self) -> &'static str {
        match self {
            ActionError::Unsupported { .. } => "unsupported",
            ActionError::BadArguments { .. } => "bad_arguments",
            ActionError::Refused { .. } => "refused",
            ActionError::Failed { .. } => "failed",
            ActionError::LinkLost { .. } => "link_lost",
            ActionError::Timeout { .. } => "timeout",
            ActionError::Cancelled { .. } => "cancelled",
        }
    }

    /// The action the failure belongs to.
    pub fn action(&self) -> &str {
        match self {
            ActionError::Unsupported { action }
            | ActionError::BadArguments { action, .. }
            | ActionError::Refused { action, .. }
            | ActionError::Failed { action, .. }
            | ActionError::LinkLost { action }
            | ActionError::Timeout { action, .. }
            | ActionError::Cancelled { action } => action,
        }
    }

    pub fn refused(action: impl Into<String>, reason: impl fmt::Display) -> Self {
        ActionError::Refused {
            action: action.into(),
            reason: reason.to_string(),
        }
    }

    pub fn failed(action: impl Into<String>, reason: impl fmt::Display) -> Self {
        ActionError::Failed {
            action: action.into(),
            reason: reason.to_string(),
        }
    }

    pub fn bad_arguments(action: impl Into<String>, reason: impl fmt::Display) -> Self {
        ActionError::BadArguments {
            action: action.into(),
            reason: reason.to_string(),
        }
    }
}

/// What the autopilot is doing, in words common to every platform. A
/// MAVLink adapter maps the autopilot's own modes onto these (GUIDED is
/// `Guided`, LOITER/POSHOLD `Hold`, RTL `ReturnHome`, manual modes
/// `Piloted`) and keeps anything else as `Other(custom_mode)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FlightMode {
    /// On the ground, waiting for commands.
    #[default]
    Standby,
    /// Climbing to the take-off height.
    Takeoff,
    /// Flying to a target the mission gave.
    Guided,
    /// Holding position in the air.
    Hold,
    /// Descending to land.
    Land,
    /// Flying back above home.
    ReturnHome,
    /// Flown by a pilot (or the simulator's scripted pilot); the mission
    /// only watches.
    Piloted,
    /// A platform mode with no common name.
    Other(u32),
}

impl fmt::Display for FlightMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlightMode::Standby => write!(f, "standby"),
            FlightMode::Takeoff => write!(f, "takeoff"),
            FlightMode::Guided => write!(f, "guided"),
            FlightMode::Hold => write!(f, "hold"),
            FlightMode::Land => write!(f, "land"),
            FlightMode::ReturnHome => write!(f, "return-home"),
            FlightMode::Piloted => write!(f, "piloted"),
            FlightMode::Other(m) => write!(f, "mode {m}"),
        }
    }
}

/// One snapshot of a drone's state, stamped with mission time. Adapters
/// publish it through a `watch` channel: the latest value plus a change
/// notification, so guards are re-evaluated when something changed instead
/// of being polled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Mission time in seconds (simulated time for simulated drones).
    pub time: f64,
    /// Position in the drone's local frame, metres from its home.
    pub position: Vec3,
    /// Velocity in the local frame, metres per second.
    pub velocity: Vec3,
    /// Battery charge in percent, 0 to 100.
    pub battery: f64,
    pub armed: bool,
    /// On the ground and not moving.
    pub landed: bool,
    pub mode: FlightMode,
    /// The drone's home in the fleet frame (shared by all drones of a
    /// mission), so positions of different drones can be compared.
    pub home: Vec3,
}

impl Telemetry {
    /// A drone at rest on the ground at its home, disarmed, battery full.
    pub fn at_home(home: Vec3) -> Self {
        Self {
            time: 0.0,
            position: Vec3::ZERO,
            velocity: Vec3::ZERO,
            battery: 100.0,
            armed: false,
            landed: true,
            mode: FlightMode::Standby,
            home,
        }
    }

    /// Position in the fleet frame: home plus local position.
    pub fn fleet_position(&self) -> Vec3 {
        self.home + self.position
    }
}

/// The value of a property.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Value {
    Number(f64),
    Bool(bool),
}

impl Value {
    pub fn as_number(self) -> Option<f64> {
        match self {
            Value::Number(n) => Some(n),
            Value::Bool(_) => None,
        }
    }

    pub fn as_bool(self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(b),
            Value::Number(_) => None,
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Number(n) => write!(f, "{n}"),
            Value::Bool(b) => write!(f, "{b}"),
        }
    }
}

/// An argument of a property: another drone (its latest telemetry) or a
/// number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PropertyArg<'a> {
    Drone(&'a Telemetry),
    Number(f64),
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PropertyError {
    #[error("`{property}` is not a property the middle layer can compute")]
    Unknown { property: String },
    #[error("`{property}` was given bad arguments: {reason}")]
    BadArguments { property: String, reason: String },
}

/// Evaluates a property of the built-in profiles from telemetry alone.
///
/// It is a pure function so that the executor can evaluate a condition over
/// remote drones' telemetry (received as messages) exactly as over its own
/// drone's: `D1.DistanceTo(D2)` is
/// `evaluate_property("DistanceTo", &t1, &[PropertyArg::Drone(&t2)])`.
/// Distances are measured in the fleet frame (homes included).
pub fn evaluate_property(
    property: &str,
    own: &Telemetry,
    args: &[PropertyArg<'_>],
) -> Result<Value, PropertyError> {
    let no_args = |v: Value| {
        if args.is_empty() {
            Ok(v)
        } else {
            Err(PropertyError::BadArguments {
                property: property.to_string(),
                reason: format!("expected no arguments, got {}", args.len()),
            })
        }
    };
    match property {
        "X" => no_args(Value::Number(own.position.x)),
        "Y" => no_args(Value::Number(own.position.y)),
        "Z" => no_args(Value::Number(own.position.z)),
        "Battery" => no_args(Value::Number(own.battery)),
        "IsArmed" => no_args(Value::Bool(own.armed)),
        "DistanceTo" => match args {
            [PropertyArg::Drone(other)] => Ok(Value::Number(
                own.fleet_position().distance(other.fleet_position()),
            )),
            _ => Err(PropertyError::BadArguments {
                property: property.to_string(),
                reason: "expected one drone".to_string(),
            }),
        },
        _ => Err(PropertyError::Unknown {
            property: property.to_string(),
        }),
    }
}

/// What an adapter is, for logs and reports: `sim` or `mavlink`, the drone
/// it drives, and a detail such as the connection string.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdapterInfo {
    /// The adapter kind: `sim`, `mavlink`, ...
    pub kind: String,
    /// The drone's name in the mission.
    pub drone: String,
    /// Free text: connection, vehicle, script.
    #[serde(default)]
    pub detail: String,
}

impl fmt::Display for AdapterInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({} adapter", self.drone, self.kind)?;
        if !self.detail.is_empty() {
            write!(f, ", {}", self.detail)?;
        }
        write!(f, ")")
    }
}

/// A platform adapter: drives one drone.
///
/// Object-safe (adapters are chosen at run time from a fleet file), so the
/// executor holds `Arc<dyn Adapter>`. `run` takes `&self` because actions
/// that hold different resources (a flight and a photo) run at the same
/// time on one drone.
#[async_trait]
pub trait Adapter: Send + Sync {
    /// Which adapter drives which drone.
    fn info(&self) -> AdapterInfo;

    /// The drone's telemetry: latest snapshot and change notification.
    fn telemetry(&self) -> watch::Receiver<Telemetry>;

    /// The clock mission time is read from (simulated time for a simulated
    /// fleet, wall time since start otherwise). `PauseFor` and timeouts of
    /// the executor should sleep on it, so that a sped-up simulation pauses
    /// in simulated seconds.
    fn clock(&self) -> MissionClock;

    /// Runs one action to its end: `Ok(())` when the drone did it, a typed
    /// error otherwise. When `cancel` fires, a motion holds where it is and
    /// the call returns [`ActionError::Cancelled`] promptly. Dropping the
    /// returned future should stop a motion the same way (the simulator
    /// does), so that a caller that stops waiting never leaves a drone
    /// flying on for nobody; callers should still prefer the token, which
    /// also reports the outcome.
    async fn run(&self, call: &ActionCall, cancel: CancellationToken) -> Result<(), ActionError>;

    /// Puts the drone into a failsafe (the mission was aborted, or a peer
    /// it waits on was lost). The default flies the adapter's own `Land`
    /// and `ReturnHome` actions (see [`fly_failsafe`]); an adapter
    /// whose platform has a better native failsafe may override it.
    async fn failsafe(&self, kind: Failsafe) -> Result<(), ActionError> {
        fly_failsafe(self, kind).await
    }

    /// Waits until the mission may command the drone again, before its
    /// failsafe flies: a drone that a pilot (or the autopilot's own
    /// failsafe) took over stays theirs until they give it back, and a
    /// drone whose link is lost can be commanded only once the link
    /// returns. [`Control::Down`] when whoever had it brought it down, so
    /// that there is nothing left to fly. Adapters that never share their
    /// drone answer at once.
    async fn regain_control(&self) -> Result<Control, ActionError> {
        Ok(Control::Mission)
    }

    /// The point relative moves (`FlyByX`, `ReturnHome`'s height) start
    /// from now, in the local frame. An agent that journals a motion records
    /// the absolute target computed from it, so that a motion interrupted by
    /// a crash of the agent is resumed towards that target instead of being
    /// applied again as a new relative move. Adapters whose vehicle holds a
    /// point other than where it is (the simulator, an autopilot in
    /// position hold) say so here.
    fn motion_reference(&self) -> Result<Vec3, ActionError> {
        Ok(self.telemetry().borrow().position)
    }

    /// The absolute target `call` flies to if it starts now (see
    /// [`MultirotorAction::target_from`]); `None` for actions that are not
    /// a flight to a point.
    fn motion_target(&self, call: &ActionCall) -> Option<Vec3> {
        let action = MultirotorAction::parse(call).ok()?;
        action.target_from(self.motion_reference().ok()?)
    }

    /// Flies to an absolute target on behalf of `call` (which names the
    /// action in logs and errors), ending like `call` would: within the
    /// arrival tolerance of `target`, holding there. This is how a motion
    /// interrupted by a crash of the agent is resumed. Adapters that cannot
    /// fly to a point refuse it as unsupported.
    async fn fly_to_target(
        &self,
        call: &ActionCall,
        target: Vec3,
        cancel: CancellationToken,
    ) -> Result<(), ActionError> {
        let _ = (target, cancel);
        Err(ActionError::Unsupported {
            action: call.name.clone(),
        })
    }
}

/// An axis of the local frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn unit(self) -> Vec3 {
        match self {
            Axis::X => Vec3::new(1.0, 0.0, 0.0),
            Axis::Y => Vec3::new(0.0, 1.0, 0.0),
            Axis::Z => Vec3::new(0.0, 0.0, 1.0),
        }
    }
}

/// The built-in `Quadcopter` profile, read once: the arity of each typed
/// action below is its data, not a second list kept here.
pub(crate) fn quadcopter() -> &'static Profile {
    static QUADCOPTER: OnceLock<Profile> = OnceLock::new();
    QUADCOPTER.get_or_init(|| {
        eamos_profile::builtin()
            .get("Quadcopter")
            .expect("the built-in profiles have a Quadcopter")
            .clone()
    })
}

/// The actions of the built-in `Quadcopter` profile, typed, so that every
/// multirotor adapter (simulator, MAVLink) parses and validates calls the
/// same way. Their arities are the profile's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum MultirotorAction {
    TurnOn,
    PreFlightCheck,
    Calibrate,
    Arm,
    Disarm,
    Takeoff { height: f64 },
    Land,
    FlyBy { axis: Axis, distance: f64 },
    FlyTo { target: Vec3 },
    Hover { seconds: f64 },
    ReturnHome,
    TurnOnCamera,
    AdjustCamera,
    TakePhoto,
}

impl MultirotorAction {
    /// Reads a call: an unknown name is [`ActionError::Unsupported`], a
    /// wrong argument count or a value outside the action's domain (a
    /// non-finite number, a negative duration, a take-off height that is
    /// not above the ground) is [`ActionError::BadArguments`].
    pub fn parse(call: &ActionCall) -> Result<Self, ActionError> {
        let name = call.name.as_str();
        let Some(sig) = quadcopter().actions.get(name) else {
            return Err(ActionError::Unsupported {
                action: call.name.clone(),
            });
        };
        let arity = sig.arity();
        if call.args.len() != arity {
            return Err(ActionError::bad_arguments(
                name,
                format!(
                    "expected {arity} argument{}, got {}",
                    if arity == 1 { "" } else { "s" },
                    call.args.len()
                ),
            ));
        }
        if let Some(bad) = call.args.iter().find(|a| !a.is_finite()) {
            return Err(ActionError::bad_arguments(
                name,
                format!("{bad} is not a finite number"),
            ));
        }
        let a = &call.args;
        Ok(match name {
            "TurnOn" => MultirotorAction::TurnOn,
            "PreFlightCheck" => MultirotorAction::PreFlightCheck,
            "Calibrate" => MultirotorAction::Calibrate,
            "Arm" => MultirotorAction::Arm,
            "Disarm" => MultirotorAction::Disarm,
            "Takeoff" => {
                if a[0] <= 0.0 {
                    return Err(ActionError::bad_arguments(
                        name,
                        format!(
                            "the take-off height must be above the ground, not {} m",
                            a[0]
                        ),
                    ));
                }
                MultirotorAction::Takeoff { height: a[0] }
            }
            "Land" => MultirotorAction::Land,
            "FlyByX" => MultirotorAction::FlyBy {
                axis: Axis::X,
                distance: a[0],
            },
            "FlyByY" => MultirotorAction::FlyBy {
                axis: Axis::Y,
                distance: a[0],
            },
            "FlyByZ" => MultirotorAction::FlyBy {
                axis: Axis::Z,
                distance: a[0],
            },
            "FlyTo" => MultirotorAction::FlyTo {
                target: Vec3::new(a[0], a[1], a[2]),
            },
            "Hover" => {
                if a[0] < 0.0 {
                    return Err(ActionError::bad_arguments(
                        name,
                        format!("a duration cannot be negative ({} s)", a[0]),
                    ));
                }
                MultirotorAction::Hover { seconds: a[0] }
            }
            "ReturnHome" => MultirotorAction::ReturnHome,
            "TurnOnCamera" => MultirotorAction::TurnOnCamera,
            "AdjustCamera" => MultirotorAction::AdjustCamera,
            "TakePhoto" => MultirotorAction::TakePhoto,
            // An action of the profile with no typed form: adapters that
            // run it do so from its declaration, the others refuse it.
            _ => {
                return Err(ActionError::Unsupported {
                    action: call.name.clone(),
                })
            }
        })
    }

    /// Whether the action moves the drone (holds the `motion` resource and
    /// is refused or cancelled as a flight).
    pub fn is_motion(self) -> bool {
        matches!(
            self,
            MultirotorAction::Arm
                | MultirotorAction::Disarm
                | MultirotorAction::Takeoff { .. }
                | MultirotorAction::Land
                | MultirotorAction::FlyBy { .. }
                | MultirotorAction::FlyTo { .. }
                | MultirotorAction::Hover { .. }
                | MultirotorAction::ReturnHome
        )
    }

    /// The absolute target of this action when it starts from `start` (the
    /// adapter's [`Adapter::motion_reference`]): where `FlyByX(d)` from
    /// there ends, the point `Takeoff(h)` climbs to, `ReturnHome`'s point
    /// above home. `None` for actions that do not fly to a point (`Land`
    /// ends wherever the ground is, `Hover` holds for a time).
    pub fn target_from(self, start: Vec3) -> Option<Vec3> {
        match self {
            MultirotorAction::Takeoff { height } => Some(Vec3::new(start.x, start.y, height)),
            MultirotorAction::FlyBy { axis, distance } => Some(start + axis.unit() * distance),
            MultirotorAction::FlyTo { target } => Some(target),
            MultirotorAction::ReturnHome => Some(Vec3::new(0.0, 0.0, start.z)),
            _ => None,
        }
    }

    /// The mission's name of the action.
    pub fn name(self) -> &'static str {
        match self {
            MultirotorAction::TurnOn => "TurnOn",
            MultirotorAction::PreFlightCheck => "PreFlightCheck",
            MultirotorAction::Calibrate => "Calibrate",
            MultirotorAction::Arm => "Arm",
            MultirotorAction::Disarm => "Disarm",
            MultirotorAction::Takeoff { .. } => "Takeoff",
            MultirotorAction::Land => "Land",
            MultirotorAction::FlyBy { axis: Axis::X, .. } => "FlyByX",
            MultirotorAction::FlyBy { axis: Axis::Y, .. } => "FlyByY",
            MultirotorAction::FlyBy { axis: Axis::Z, .. } => "FlyByZ",
            MultirotorAction::FlyTo { .. } => "FlyTo",
            MultirotorAction::Hover { .. } => "Hover",
            MultirotorAction::ReturnHome => "ReturnHome",
            MultirotorAction::TurnOnCamera => "TurnOnCamera",
            MultirotorAction::AdjustCamera => "AdjustCamera",
            MultirotorAction::TakePhoto => "TakePhoto",
        }
    }
}

/// Whether the mission has its drone back (see [`Adapter::regain_control`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// The mission may command the drone.
    Mission,
    /// Whoever had the drone brought it down: it is on the ground, or
    /// disarmed, and nothing is left to fly.
    Down,
}

/// Flies `kind` with `adapter`'s own `Land` and `ReturnHome` actions (the
/// default of [`Adapter::failsafe`]). A drone on the ground has nothing to
/// do. The caller cancels whatever the drone was doing first.
pub async fn fly_failsafe<A: Adapter + ?Sized>(
    adapter: &A,
    kind: Failsafe,
) -> Result<(), ActionError> {
    // Holding flies nothing, so it takes nothing back from anyone.
    if kind == Failsafe::Hold {
        return Ok(());
    }
    if adapter.regain_control().await? == Control::Down {
        return Ok(());
    }
    if adapter.telemetry().borrow().landed {
        return Ok(());
    }
    let run = |name: &str| {
        let call = ActionCall::new(name, Vec::<f64>::new());
        async move { adapter.run(&call, CancellationToken::new()).await }
    };
    match kind {
        Failsafe::Hold => Ok(()),
        Failsafe::Land => run("Land").await,
        Failsafe::Home => {
            run("ReturnHome").await?;
            run("Land").await
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flying_at(home: Vec3, position: Vec3) -> Telemetry {
        Telemetry {
            position,
            armed: true,
            landed: false,
            mode: FlightMode::Hold,
            ..Telemetry::at_home(home)
        }
    }

    #[test]
    fn coordinates_battery_and_armed_state_read_from_one_snapshot() {
        let mut t = flying_at(Vec3::ZERO, Vec3::new(1.0, -2.0, 3.0));
        t.battery = 87.5;
        assert_eq!(evaluate_property("X", &t, &[]), Ok(Value::Number(1.0)));
        assert_eq!(evaluate_property("Y", &t, &[]), Ok(Value::Number(-2.0)));
        assert_eq!(evaluate_property("Z", &t, &[]), Ok(Value::Number(3.0)));
        assert_eq!(
            evaluate_property("Battery", &t, &[]),
            Ok(Value::Number(87.5))
        );
        assert_eq!(evaluate_property("IsArmed", &t, &[]), Ok(Value::Bool(true)));
    }

    #[test]
    fn distance_between_two_drones_counts_their_homes() {
        // Homes 10 m apart along Y; both 3 m north of their home.
        let a = flying_at(Vec3::ZERO, Vec3::new(3.0, 0.0, 2.0));
        let b = flying_at(Vec3::new(0.0, 10.0, 0.0), Vec3::new(3.0, 0.0, 2.0));
        let d = evaluate_property("DistanceTo", &a, &[PropertyArg::Drone(&b)])
            .unwrap()
            .as_number()
            .unwrap();
        assert!((d - 10.0).abs() < 1e-12);
    }

    #[test]
    fn a_property_with_the_wrong_arguments_is_an_error() {
        let t = Telemetry::at_home(Vec3::ZERO);
        assert!(matches!(
            evaluate_property("DistanceTo", &t, &[]),
            Err(PropertyError::BadArguments { .. })
        ));
        assert!(matches!(
            evaluate_property("X", &t, &[PropertyArg::Number(1.0)]),
            Err(PropertyError::BadArguments { .. })
        ));
        assert!(matches!(
            evaluate_property("Speed", &t, &[]),
            Err(PropertyError::Unknown { .. })
        ));
    }

    #[test]
    fn a_call_parses_into_a_typed_multirotor_action() {
        assert_eq!(
            MultirotorAction::parse(&ActionCall::new("FlyTo", [1.0, 2.0, 3.0])),
            Ok(MultirotorAction::FlyTo {
                target: Vec3::new(1.0, 2.0, 3.0)
            })
        );
        assert_eq!(
            MultirotorAction::parse(&ActionCall::new("FlyByY", [-0.2])),
            Ok(MultirotorAction::FlyBy {
                axis: Axis::Y,
                distance: -0.2
            })
        );
        assert_eq!(
            MultirotorAction::parse(&ActionCall::new("FlyByY", [-0.2]))
                .unwrap()
                .name(),
            "FlyByY"
        );
    }

    #[test]
    fn the_target_of_a_relative_move_is_its_start_plus_the_move() {
        let start = Vec3::new(1.0, 2.0, 5.0);
        let target = |name: &str, args: &[f64]| {
            MultirotorAction::parse(&ActionCall::new(name, args.to_vec()))
                .unwrap()
                .target_from(start)
        };
        assert_eq!(target("FlyByX", &[5.0]), Some(Vec3::new(6.0, 2.0, 5.0)));
        assert_eq!(target("FlyByY", &[-1.0]), Some(Vec3::new(1.0, 1.0, 5.0)));
        assert_eq!(target("FlyByZ", &[0.5]), Some(Vec3::new(1.0, 2.0, 5.5)));
        assert_eq!(
            target("FlyTo", &[0.0, 0.0, 3.0]),
            Some(Vec3::new(0.0, 0.0, 3.0))
        );
        assert_eq!(target("Takeoff", &[1.5]), Some(Vec3::new(1.0, 2.0, 1.5)));
        assert_eq!(target("ReturnHome", &[]), Some(Vec3::new(0.0, 0.0, 5.0)));
        assert_eq!(target("Land", &[]), None);
        assert_eq!(target("Hover", &[3.0]), None);
        assert_eq!(target("Arm", &[]), None);
    }

    #[test]
    fn a_call_with_an_unknown_name_is_unsupported() {
        let err = MultirotorAction::parse(&ActionCall::new("DoABarrelRoll", [])).unwrap_err();
        assert_eq!(err.kind(), "unsupported");
        assert_eq!(
            err.to_string(),
            "`DoABarrelRoll` is not an action this drone offers"
        );
    }

    #[test]
    fn a_call_with_the_wrong_arity_or_a_non_finite_argument_is_bad_arguments() {
        let err = MultirotorAction::parse(&ActionCall::new("FlyTo", [1.0])).unwrap_err();
        assert_eq!(
            err.to_string(),
            "`FlyTo` was called with bad arguments: expected 3 arguments, got 1"
        );
        let err = MultirotorAction::parse(&ActionCall::new("Hover", [f64::NAN])).unwrap_err();
        assert_eq!(err.kind(), "bad_arguments");
        let err = MultirotorAction::parse(&ActionCall::new("Takeoff", [0.0])).unwrap_err();
        assert_eq!(err.kind(), "bad_arguments");
        let err = MultirotorAction::parse(&ActionCall::new("Hover", [-1.0])).unwrap_err();
        assert_eq!(err.kind(), "bad_arguments");
    }

    #[test]
    fn errors_serialise_with_their_kind_for_the_logs() {
        let e = ActionError::refused("Takeoff", "the motors are not armed");
        let v = serde_json::to_value(&e).unwrap();
        assert_eq!(v["error"], "refused");
        assert_eq!(v["reason"], "the motors are not armed");
        assert_eq!(
            e.to_string(),
            "the drone refused `Takeoff`: the motors are not armed"
        );
        let back: ActionError = serde_json::from_value(v).unwrap();
        assert_eq!(back, e);
    }
}
