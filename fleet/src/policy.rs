//! What a drone does when a peer it waits on is lost, and when the mission
//! is aborted: the fleet's `[failsafe]` table and each drone's own keys.
//! The executor's liveness watch applies these; this module only reads
//! them.

use std::fmt;

use serde::{Deserialize, Serialize};

use eamos_mid::Failsafe;

/// What a drone does once a peer it waits on has been lost for the grace
/// period.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OnLost {
    /// Hover where it is and keep waiting: if the peer comes back, the
    /// mission goes on.
    Hold,
    /// Land where it is; its part of the mission ends.
    #[default]
    Land,
    /// Return home and land there; its part of the mission ends.
    Home,
    /// Abort the whole mission: every drone goes to its abort failsafe.
    Abort,
}

impl OnLost {
    pub fn name(self) -> &'static str {
        match self {
            OnLost::Hold => "hold",
            OnLost::Land => "land",
            OnLost::Home => "home",
            OnLost::Abort => "abort",
        }
    }

    /// The policy a name in a fleet file or a stuck notice stands for.
    pub fn parse(s: &str) -> Option<OnLost> {
        Some(match s {
            "hold" => OnLost::Hold,
            "land" => OnLost::Land,
            "home" => OnLost::Home,
            "abort" => OnLost::Abort,
            _ => return None,
        })
    }
}

impl fmt::Display for OnLost {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The liveness settings of one peer, as its fleet file declares them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Liveness {
    pub on_lost: OnLost,
    /// Mission seconds a lost peer has to come back before the policy
    /// applies (simulated seconds in a simulated fleet, like every other
    /// duration of a mission).
    pub grace: f64,
    /// Where the drone goes when the mission is aborted or stopped (the
    /// `abort` command, Ctrl-C, a peer's abort, the time limit).
    pub on_abort: Failsafe,
}

impl Default for Liveness {
    fn default() -> Self {
        Liveness {
            on_lost: OnLost::Land,
            grace: DEFAULT_GRACE,
            on_abort: Failsafe::Land,
        }
    }
}

/// The grace period when the fleet file gives none, in mission seconds.
pub const DEFAULT_GRACE: f64 = 5.0;

/// Reads a duration as fleet files write it: a number of seconds (`5`,
/// `2.5`) or a string with a unit (`"5s"`, `"500ms"`, `"2min"`).
pub fn parse_duration(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number.parse().map_err(|_| {
        format!("`{text}` is not a duration (write seconds, or \"5s\", \"500ms\", \"2min\")")
    })?;
    let factor = match unit.trim() {
        "" | "s" => 1.0,
        "ms" => 0.001,
        "min" => 60.0,
        other => {
            return Err(format!(
                "`{other}` is not a unit of time here (use s, ms or min)"
            ))
        }
    };
    let seconds = value * factor;
    if !seconds.is_finite() || seconds < 0.0 {
        return Err(format!("`{text}` is not a duration of zero or more"));
    }
    Ok(seconds)
}

/// A grace period in a fleet file: seconds, or a string with a unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grace(pub f64);

impl<'de> Deserialize<'de> for Grace {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Grace, D::Error> {
        use serde::de::Error;
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Integer(i64),
            Text(String),
        }
        let seconds = match Raw::deserialize(d)? {
            Raw::Number(n) => n,
            Raw::Integer(n) => n as f64,
            Raw::Text(t) => parse_duration(&t).map_err(D::Error::custom)?,
        };
        if !seconds.is_finite() || seconds < 0.0 {
            return Err(D::Error::custom(format!(
                "a grace period is zero or more seconds, not {seconds}"
            )));
        }
        Ok(Grace(seconds))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grace_periods_are_seconds_or_text_with_a_unit() {
        assert_eq!(parse_duration("5s"), Ok(5.0));
        assert_eq!(parse_duration("250ms"), Ok(0.25));
        assert_eq!(parse_duration("2min"), Ok(120.0));
        assert_eq!(parse_duration("1.5"), Ok(1.5));
        assert!(parse_duration("5 parsecs").unwrap_err().contains("parsecs"));
        assert!(parse_duration("soon").is_err());
        #[derive(Deserialize)]
        struct G {
            grace: Grace,
        }
        assert_eq!(toml::from_str::<G>("grace = 3").unwrap().grace, Grace(3.0));
        assert_eq!(
            toml::from_str::<G>("grace = 0.5").unwrap().grace,
            Grace(0.5)
        );
        assert_eq!(
            toml::from_str::<G>("grace = \"10s\"").unwrap().grace,
            Grace(10.0)
        );
        assert!(toml::from_str::<G>("grace = -1").is_err());
    }
}
