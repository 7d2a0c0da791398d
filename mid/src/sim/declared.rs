//! What the simulator reads from the drone's profile: the nominal time of
//! each action that does not move the drone, the flight states it may
//! start in, and how to run an action the profile declares but the
//! simulator has no code of its own for.
//!
//! Such an action is run from its declaration, so that a new action is a
//! TOML edit for the simulator (its real adapter still needs code):
//! - with a `motion`, it flies that motion as the typed action that moves
//!   the same way does (`by_x` as `FlyByX`, `climb_to` as `Takeoff`, ...);
//! - without, it is a wait of its nominal duration after its flight state
//!   is checked: nothing in the simulated world changes, which is all a
//!   simulator can honestly say about spraying or dropping a parcel.

use std::collections::BTreeMap;

use eamos_profile::{FlightState, Motion, Profile};

use crate::api::{ActionCall, ActionError, Axis, MultirotorAction, Vec3};

use super::kinematics::Multirotor;

/// How the simulator runs one call.
pub(super) enum Plan {
    /// As one of its typed actions (a motion only the profile declares is
    /// flown as the typed action that moves the same way).
    Typed(MultirotorAction),
    /// As a wait of the action's nominal duration.
    Timed,
}

/// Reads `call` as a typed action or, failing that, from the profile's
/// declaration of it.
pub(super) fn plan(profile: &Profile, call: &ActionCall) -> Result<Plan, ActionError> {
    let unsupported = match MultirotorAction::parse(call) {
        Ok(action) => return Ok(Plan::Typed(action)),
        Err(e @ ActionError::Unsupported { .. }) => e,
        Err(e) => return Err(e),
    };
    let Some(sig) = profile.actions.get(&call.name) else {
        return Err(unsupported);
    };
    if call.args.len() != sig.arity() {
        return Err(ActionError::bad_arguments(
            &call.name,
            format!(
                "expected {} argument(s), got {}",
                sig.arity(),
                call.args.len()
            ),
        ));
    }
    if let Some(bad) = call.args.iter().find(|a| !a.is_finite()) {
        return Err(ActionError::bad_arguments(
            &call.name,
            format!("{bad} is not a finite number"),
        ));
    }
    let arg = |p: &str| sig.arg(p, &call.args).unwrap_or(0.0);
    Ok(match &sig.motion {
        None => Plan::Timed,
        Some(motion) => Plan::Typed(match motion {
            Motion::ByX(p) => MultirotorAction::FlyBy {
                axis: Axis::X,
                distance: arg(p),
            },
            Motion::ByY(p) => MultirotorAction::FlyBy {
                axis: Axis::Y,
                distance: arg(p),
            },
            Motion::ByZ(p) => MultirotorAction::FlyBy {
                axis: Axis::Z,
                distance: arg(p),
            },
            Motion::To([x, y, z]) => MultirotorAction::FlyTo {
                target: Vec3::new(arg(x), arg(y), arg(z)),
            },
            Motion::ClimbTo(p) => MultirotorAction::Takeoff { height: arg(p) },
            Motion::Land => MultirotorAction::Land,
            Motion::Home => MultirotorAction::ReturnHome,
        }),
    })
}

/// The simulated drone's flight state.
pub(super) fn flight_state(model: &Multirotor) -> FlightState {
    if model.is_airborne() {
        FlightState::Airborne
    } else if model.is_armed() {
        FlightState::Armed
    } else {
        FlightState::Disarmed
    }
}

/// Simulated seconds a call that does not move the drone takes: the
/// simulation's own setting for the action if it has one, else the
/// profile's nominal duration. Refused when the profile says the action
/// may not start in the drone's flight state.
pub(super) fn timed_seconds(
    profile: &Profile,
    overrides: &BTreeMap<String, f64>,
    call: &ActionCall,
    model: &Multirotor,
) -> Result<f64, ActionError> {
    let name = call.name.as_str();
    let unsupported = || ActionError::Unsupported {
        action: call.name.clone(),
    };
    let sig = profile.actions.get(name).ok_or_else(unsupported)?;
    let state = flight_state(model);
    if !sig.may_start_in(state) {
        let allowed: Vec<String> = sig.starts_in().iter().map(|s| s.to_string()).collect();
        return Err(ActionError::refused(
            name,
            format!(
                "{name} starts only {}, and the drone is {state}",
                allowed.join(" or ")
            ),
        ));
    }
    if let Some(seconds) = overrides.get(name) {
        return Ok(*seconds);
    }
    let p = model.position();
    sig.nominal_duration([p.x, p.y, p.z], &call.args, profile.speeds.as_ref())
        .ok_or_else(|| {
            ActionError::bad_arguments(name, "its nominal duration cannot be read from them")
        })
}
