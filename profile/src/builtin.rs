//! The built-in capability profiles, kept as data files beside this crate so
//! that adding an airframe or an action is an edit of a TOML file, not of
//! the compiler.

use crate::schema::Profile;
use crate::table::{ProfileError, ProfileTable};

const BUILTIN: &[&str] = &[include_str!("../profiles/quadcopter.toml")];

/// The profiles every mission may use without a profile file of its own.
pub fn builtin() -> ProfileTable {
    let mut table = ProfileTable::new();
    for src in BUILTIN {
        let profile = ProfileTable::parse_profile(src).expect("built-in profiles are valid");
        table
            .insert(profile)
            .expect("built-in profiles have distinct names");
    }
    table
}

/// Reads extra profiles from TOML text and adds them to the built-in ones.
pub fn with_extra(sources: &[&str]) -> Result<ProfileTable, ProfileError> {
    let mut table = builtin();
    for src in sources {
        let profile: Profile = ProfileTable::parse_profile(src)?;
        table.insert(profile)?;
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flight::{DurationModel, FlightState, Motion};

    #[test]
    fn the_quadcopter_offers_what_the_language_page_promises() {
        let t = builtin();
        let q = t.get("Quadcopter").unwrap();
        for a in [
            "Arm",
            "Disarm",
            "Takeoff",
            "Land",
            "FlyByX",
            "FlyByY",
            "FlyByZ",
            "FlyTo",
            "Hover",
            "ReturnHome",
            "TurnOn",
            "PreFlightCheck",
            "Calibrate",
            "TurnOnCamera",
            "AdjustCamera",
            "TakePhoto",
        ] {
            assert!(q.actions.contains_key(a), "missing action {a}");
        }
        for p in ["X", "Y", "Z", "Battery", "IsArmed", "DistanceTo"] {
            assert!(q.properties.contains_key(p), "missing property {p}");
        }
        assert_eq!(q.actions["FlyTo"].params.len(), 3);
        assert!(q.excludes("FlyByX", "Land"));
        assert!(!q.excludes("FlyByX", "TakePhoto"));
    }

    #[test]
    fn the_quadcopter_flies_only_after_take_off_and_disarms_only_on_the_ground() {
        use FlightState::*;
        let t = builtin();
        let q = t.get("Quadcopter").unwrap();
        let after = |a: &str, s| q.actions[a].state_after(s);
        assert_eq!(after("Arm", Disarmed), Some(Armed));
        assert_eq!(after("Arm", Airborne), None);
        assert_eq!(after("Takeoff", Armed), Some(Airborne));
        assert_eq!(after("Takeoff", Disarmed), None);
        assert_eq!(after("Takeoff", Airborne), None);
        for motion in ["FlyByX", "FlyByY", "FlyByZ", "FlyTo", "Hover", "ReturnHome"] {
            assert_eq!(q.actions[motion].starts_in(), [Airborne], "{motion}");
            assert_eq!(after(motion, Airborne), Some(Airborne), "{motion}");
        }
        assert_eq!(after("Land", Airborne), Some(Armed));
        assert_eq!(after("Disarm", Armed), Some(Disarmed));
        assert_eq!(after("Disarm", Airborne), None);
        assert_eq!(after("Calibrate", Armed), None);
        assert_eq!(after("TakePhoto", Airborne), Some(Airborne));
        assert_eq!(after("TurnOn", Disarmed), Some(Disarmed));
    }

    #[test]
    fn the_quadcopter_times_its_actions_as_the_simulator_did() {
        let t = builtin();
        let q = t.get("Quadcopter").unwrap();
        let at = [0.0, 0.0, 2.0];
        let d = |a: &str, args: &[f64]| q.nominal_duration(a, args, at).unwrap();
        // The system and camera actions' simulated times, now data.
        assert_eq!(d("TurnOn", &[]), 2.0);
        assert_eq!(d("PreFlightCheck", &[]), 3.0);
        assert_eq!(d("Calibrate", &[]), 5.0);
        assert_eq!(d("TurnOnCamera", &[]), 1.0);
        assert_eq!(d("AdjustCamera", &[]), 1.0);
        assert_eq!(d("TakePhoto", &[]), 0.5);
        assert_eq!(d("Arm", &[]), 0.0);
        assert_eq!(d("Hover", &[3.0]), 3.0);
        assert_eq!(
            q.actions["Hover"].duration,
            DurationModel::Param("duration".into())
        );
        // Flights at the default airframe's limits: 5 m/s across, 2 m/s up,
        // 1.5 m/s down.
        assert_eq!(d("FlyByX", &[10.0]), 2.0);
        assert_eq!(d("FlyByZ", &[4.0]), 2.0);
        assert_eq!(d("Land", &[]), 2.0 / 1.5);
        assert_eq!(d("Takeoff", &[6.0]), 2.0);
        assert_eq!(d("FlyTo", &[3.0, 4.0, 2.0]), 1.0);
        assert_eq!(
            q.actions["FlyTo"].target(at, &[3.0, 4.0, 2.0]),
            Some([3.0, 4.0, 2.0])
        );
        assert_eq!(q.actions["ReturnHome"].motion, Some(Motion::Home));
        assert_eq!(q.nominal_duration("FlyTo", &[1.0], at), None, "bad arity");
        assert_eq!(q.nominal_duration("Spray", &[], at), None, "no such action");
    }
}
