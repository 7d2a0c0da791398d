//! The built-in capability profiles, kept as data files beside this crate so
//! that adding an airframe is an edit of a TOML file, not of the compiler.

use eamos_profile::{Profile, ProfileError, ProfileTable};

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
}
