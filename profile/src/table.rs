//! All profiles of one compilation, read from TOML and checked for
//! declarations that contradict each other.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::flight::DurationModel;
use crate::schema::{ActionSig, ParamKind, Profile};

/// All drone types known to one compilation, by name.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileTable {
    profiles: BTreeMap<String, Profile>,
}

#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error("profile file is not valid: {0}")]
    Parse(#[from] toml::de::Error),
    #[error("profile `{0}` is defined twice")]
    Duplicate(String),
    #[error("profile `{profile}`, action `{action}`: {reason}")]
    Invalid {
        profile: String,
        action: String,
        reason: String,
    },
}

impl ProfileTable {
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads one profile from its TOML form (see `profile/profiles/*.toml`)
    /// and checks that each action's motion and duration name parameters
    /// it has, of the right kind.
    pub fn parse_profile(src: &str) -> Result<Profile, ProfileError> {
        let profile: Profile = toml::from_str(src)?;
        validate(&profile)?;
        Ok(profile)
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

fn validate(profile: &Profile) -> Result<(), ProfileError> {
    if let Some(speeds) = &profile.speeds {
        speeds.validate().map_err(|reason| ProfileError::Invalid {
            profile: profile.name.clone(),
            action: "-".to_string(),
            reason,
        })?;
    }
    for (name, sig) in &profile.actions {
        validate_action(profile, sig).map_err(|reason| ProfileError::Invalid {
            profile: profile.name.clone(),
            action: name.clone(),
            reason,
        })?;
    }
    Ok(())
}

fn validate_action(profile: &Profile, sig: &ActionSig) -> Result<(), String> {
    let kind_of = |p: &str| sig.params.iter().find(|q| q.name == p).map(|q| q.kind);
    for p in &sig.params {
        let bounds = [p.min, p.above, p.max];
        if bounds.iter().flatten().any(|b| !b.is_finite()) {
            return Err(format!("the range of `{}` is not finite", p.name));
        }
        if (bounds.iter().any(Option::is_some) || p.ceiling) && !p.kind.is_numeric() {
            return Err(format!("`{}` is not a number: it has no range", p.name));
        }
    }
    if let Some(motion) = &sig.motion {
        for p in motion.params() {
            if kind_of(p) != Some(ParamKind::Metres) {
                return Err(format!(
                    "the motion reads `{p}`, which is not a parameter in metres"
                ));
            }
        }
    }
    match &sig.duration {
        DurationModel::Seconds(s) if !(s.is_finite() && *s >= 0.0) => {
            Err(format!("a duration of {s} seconds is not zero or more"))
        }
        DurationModel::Param(p) if kind_of(p) != Some(ParamKind::Seconds) => Err(format!(
            "the duration is `{p}`, which is not a parameter in seconds"
        )),
        DurationModel::Flight if sig.motion.is_none() => {
            Err("the duration is its flight, but it declares no `motion`".to_string())
        }
        DurationModel::Flight if profile.speeds.is_none() => Err(
            "the duration is its flight, but the profile declares no `[speeds]` to time it at"
                .to_string(),
        ),
        _ => Ok(()),
    }
}
