//! Capability profiles: what a drone type offers to a mission.
//!
//! A profile is data, not code, so that a team can describe a new airframe
//! without touching the compiler: the front end checks missions against
//! whatever [`ProfileTable`] it is handed, the checker reads which actions
//! exclude each other, and the middle layer binds each action to an adapter.
//! The built-in profiles themselves live with the middle layer (`eamos-mid`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// All drone types known to one compilation, by name.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileTable {
    profiles: BTreeMap<String, Profile>,
}

/// One drone type: the actions it can run and the properties it can report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub actions: BTreeMap<String, ActionSig>,
    #[serde(default)]
    pub properties: BTreeMap<String, PropertySig>,
}

/// The signature of an action and the resources it holds while it runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionSig {
    #[serde(default)]
    pub params: Vec<Param>,
    /// Exclusive resources of the drone held from start to end (for example
    /// `motion`): two running actions of one drone that share a resource are
    /// a conflict.
    #[serde(default)]
    pub resources: Vec<String>,
    #[serde(default)]
    pub description: String,
}

/// The signature of a property that conditions may read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PropertySig {
    #[serde(default)]
    pub params: Vec<Param>,
    #[serde(rename = "type")]
    pub ty: ValueType,
    #[serde(default)]
    pub unit: Option<Unit>,
    /// Bounds the property can take, used by interval reasoning over
    /// conditions (a battery is between 0 and 100 percent).
    #[serde(default)]
    pub range: Option<(f64, f64)>,
    #[serde(default)]
    pub description: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    pub name: String,
    pub kind: ParamKind,
}

/// What an argument must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ParamKind {
    /// A numeric constant expression in the given unit.
    Metres,
    Seconds,
    Degrees,
    Percent,
    Number,
    /// The name of a drone of the mission.
    Drone,
}

impl ParamKind {
    pub fn is_numeric(self) -> bool {
        !matches!(self, ParamKind::Drone)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ValueType {
    Number,
    Bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    Metres,
    Seconds,
    Degrees,
    Percent,
    Metrespersecond,
}

#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error("profile file is not valid: {0}")]
    Parse(#[from] toml::de::Error),
    #[error("profile `{0}` is defined twice")]
    Duplicate(String),
}

impl ProfileTable {
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads one profile from its TOML form (see `mid/profiles/*.toml`).
    pub fn parse_profile(src: &str) -> Result<Profile, ProfileError> {
        Ok(toml::from_str(src)?)
    }

    pub fn insert(&mut self, profile: Profile) -> Result<(), ProfileError> {
        if self.profiles.contains_key(&profile.name) {
            return Err(ProfileError::Duplicate(profile.name));
        }
        self.profiles.insert(profile.name.clone(), profile);
        Ok(())
    }

    pub fn get(&self, name: &str) -> Option<&Profile> {
        self.profiles.get(name)
    }

    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.profiles.keys().map(String::as_str)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Profile> {
        self.profiles.values()
    }
}

impl Profile {
    /// Whether two actions of this profile may not run at once on one drone.
    pub fn excludes(&self, a: &str, b: &str) -> bool {
        match (self.actions.get(a), self.actions.get(b)) {
            (Some(x), Some(y)) => x.resources.iter().any(|r| y.resources.contains(r)),
            _ => false,
        }
    }
}

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
}
