//! Capability profiles: what a drone type offers to a mission, as data.
//!
//! A profile is data, not code, so that a team can describe a new airframe,
//! or a new action of one, without touching the compiler: the front end
//! checks missions against whatever [`ProfileTable`] it is handed, the
//! checker reads which actions exclude each other, and the middle layer
//! binds each action to an adapter. The built-in profiles live here as TOML
//! files ([`builtin`]).
//!
//! Owns: the schema of a profile, its TOML loader and the built-in
//! profiles. Must never: run an action, know a mission, a net or an
//! adapter, or depend on an async runtime (the front end, the net compiler
//! and the checker build on this crate alone).
//!
//! # An action in TOML
//! ```toml
//! [actions.Takeoff]
//! params = [{ name = "height", kind = "metres" }]   # arity and units
//! resources = ["motion"]             # held while it runs; shared = exclusive
//! flight = { armed = "airborne" }    # may start armed on the ground; ends in the air
//! motion = { climb_to = "height" }   # where it flies
//! duration = "flight"                # nominal time: its motion at [speeds]
//! description = "Climb to `height` metres above home."
//! ```
//! - `flight`: the flight states (`disarmed`, `armed`, `airborne`; the
//!   first two on the ground) the action may start in, each mapped to the
//!   state it leaves the drone in. Left out: any state, unchanged.
//! - `motion`: `{ by_x = "p" }`, `{ by_y = "p" }`, `{ by_z = "p" }`
//!   (relative, by the argument `p` in metres), `{ to = ["x", "y", "z"] }`
//!   (absolute), `{ climb_to = "h" }` (straight up), `"land"` (straight
//!   down), `"home"` (back above home at the same height). Left out: the
//!   drone does not move.
//! - `duration`: `{ seconds = 2.0 }` (fixed), `{ param = "p" }` (the
//!   argument `p`, in seconds), `"flight"` (the motion's length at the
//!   profile's `[speeds]`, `horizontal`, `climb`, `descent` in m/s). Left
//!   out: instant.
//!
//! A simulated drone runs an action of its profile that the simulator has
//! no code for as a wait of its nominal duration, after checking its flight
//! state; a real autopilot needs adapter code for it.

mod builtin;
mod flight;
mod schema;
mod table;

pub use builtin::{builtin, with_extra};
pub use flight::{DurationModel, FlightState, Motion, Point, Speeds};
pub use schema::{ActionSig, Param, ParamKind, Profile, PropertySig, Unit, ValueType};
pub use table::{ProfileError, ProfileTable};

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = r#"
        name = "Rover"
        [actions.Drive]
        params = [{ name = "d", kind = "metres" }]
        resources = ["motion"]
        [actions.Turn]
        params = [{ name = "a", kind = "degrees" }]
        resources = ["motion"]
        [actions.Beep]
        [properties.Speed]
        type = "number"
        unit = "metrespersecond"
        range = [0.0, 5.0]
    "#;

    #[test]
    fn a_profile_reads_from_toml_and_knows_its_exclusions() {
        let p = ProfileTable::parse_profile(SAMPLE).unwrap();
        assert_eq!(p.actions["Drive"].params[0].kind, ParamKind::Metres);
        assert!(p.excludes("Drive", "Turn"));
        assert!(!p.excludes("Drive", "Beep"));
        assert_eq!(p.properties["Speed"].range, Some((0.0, 5.0)));
    }

    #[test]
    fn a_table_refuses_a_second_profile_of_the_same_name() {
        let mut t = ProfileTable::new();
        t.insert(ProfileTable::parse_profile(SAMPLE).unwrap())
            .unwrap();
        let err = t.insert(ProfileTable::parse_profile(SAMPLE).unwrap());
        assert!(matches!(err, Err(ProfileError::Duplicate(n)) if n == "Rover"));
    }

    #[test]
    fn a_malformed_profile_is_an_error_not_a_panic() {
        assert!(ProfileTable::parse_profile("name = 3").is_err());
    }

    #[test]
    fn an_action_declares_its_flight_states_motion_and_duration() {
        let p = ProfileTable::parse_profile(
            r#"
            name = "Sprayer"
            speeds = { horizontal = 4.0, climb = 1.0, descent = 1.0 }
            [actions.Spray]
            params = [{ name = "seconds", kind = "seconds" }]
            flight = { airborne = "airborne" }
            duration = { param = "seconds" }
            [actions.Hop]
            params = [{ name = "d", kind = "metres" }]
            flight = { airborne = "airborne" }
            motion = { by_y = "d" }
            duration = "flight"
            [actions.Beep]
            duration = { seconds = 0.25 }
            "#,
        )
        .unwrap();
        let spray = &p.actions["Spray"];
        assert_eq!(spray.arity(), 1);
        assert_eq!(spray.starts_in(), [FlightState::Airborne]);
        assert_eq!(p.nominal_duration("Spray", &[7.0], [0.0; 3]), Some(7.0));
        assert_eq!(p.nominal_duration("Hop", &[8.0], [0.0; 3]), Some(2.0));
        assert_eq!(p.nominal_duration("Beep", &[], [0.0; 3]), Some(0.25));
        assert_eq!(
            p.actions["Beep"].state_after(FlightState::Armed),
            Some(FlightState::Armed)
        );
    }

    #[test]
    fn declarations_that_contradict_the_parameters_are_refused() {
        let bad = |action: &str| {
            let src = format!("name = \"P\"\n[actions.A]\n{action}\n");
            match ProfileTable::parse_profile(&src) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("accepted: {action}"),
            }
        };
        let e = bad("params = [{ name = \"d\", kind = \"metres\" }]\nduration = { param = \"d\" }");
        assert!(e.contains("not a parameter in seconds"), "{e}");
        let e = bad("motion = { by_x = \"d\" }");
        assert!(e.contains("not a parameter in metres"), "{e}");
        let e = bad("duration = \"flight\"");
        assert!(e.contains("declares no `motion`"), "{e}");
        let e = bad("params = [{ name = \"d\", kind = \"metres\" }]\nmotion = { by_x = \"d\" }\nduration = \"flight\"");
        assert!(e.contains("no `[speeds]`"), "{e}");
        let e = bad("duration = { seconds = -1.0 }");
        assert!(e.contains("not zero or more"), "{e}");
        let e = bad("flight = { flying = \"airborne\" }");
        assert!(e.contains("not valid"), "{e}");
        let e = bad("durration = { seconds = 1.0 }");
        assert!(e.contains("durration"), "a misspelt key is an error: {e}");
    }
}
