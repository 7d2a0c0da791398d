//! The shape of one profile: its actions, with their parameters, resources,
//! flight states, motion and nominal duration, and its properties.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::flight::{DurationModel, FlightState, Motion, Point, Speeds};

/// One drone type: the actions it can run and the properties it can report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// The speeds flights are timed at (needed by `duration = "flight"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speeds: Option<Speeds>,
    #[serde(default)]
    pub actions: BTreeMap<String, ActionSig>,
    #[serde(default)]
    pub properties: BTreeMap<String, PropertySig>,
}

/// The signature of an action and what it does to the drone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
    /// The flight states the action may start in, each with the state it
    /// leaves the drone in (`flight = { armed = "airborne" }` for a
    /// take-off). `None`: any state, left as it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flight: Option<BTreeMap<FlightState, FlightState>>,
    /// Where the action flies the drone; `None` for an action that does
    /// not move it (it may still hold the `motion` resource, as a hover
    /// does).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Motion>,
    /// How long the action takes nominally.
    #[serde(default)]
    pub duration: DurationModel,
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
    /// The least value the argument may take (`min = 0.0`: a duration is
    /// never negative).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// The argument must be strictly above this (`above = 0.0`: a take-off
    /// climbs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub above: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// A height that must stay at or below the airspace's ceiling (the
    /// checker knows the ceiling from the fleet file; the profile does not).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub ceiling: bool,
}

impl Param {
    /// Why `value` is out of the parameter's declared range, if it is
    /// (`ceiling` is the airspace's, when there is one).
    pub fn out_of_range(&self, value: f64, ceiling: Option<f64>) -> Option<String> {
        if let Some(m) = self.min {
            if value < m {
                return Some(format!("`{}` must be at least {m}", self.name));
            }
        }
        if let Some(a) = self.above {
            if value <= a {
                return Some(format!("`{}` must be above {a}", self.name));
            }
        }
        if let Some(m) = self.max {
            if value > m {
                return Some(format!("`{}` must be at most {m}", self.name));
            }
        }
        match ceiling {
            Some(c) if self.ceiling && value > c => Some(format!(
                "`{}` must be at most the airspace's ceiling, {c} m",
                self.name
            )),
            _ => None,
        }
    }
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

impl ActionSig {
    /// How many arguments a call passes.
    pub fn arity(&self) -> usize {
        self.params.len()
    }

    /// The argument of the parameter `name` in a call's arguments (given in
    /// the order of the parameters).
    pub fn arg(&self, name: &str, args: &[f64]) -> Option<f64> {
        let i = self.params.iter().position(|p| p.name == name)?;
        args.get(i).copied()
    }

    /// Whether the action may start in `state`.
    pub fn may_start_in(&self, state: FlightState) -> bool {
        self.state_after(state).is_some()
    }

    /// The state the action leaves the drone in when it starts in `state`;
    /// `None` when it may not start there.
    pub fn state_after(&self, state: FlightState) -> Option<FlightState> {
        match &self.flight {
            None => Some(state),
            Some(map) => map.get(&state).copied(),
        }
    }

    /// The states the action may start in, in order.
    pub fn starts_in(&self) -> Vec<FlightState> {
        FlightState::ALL
            .into_iter()
            .filter(|s| self.may_start_in(*s))
            .collect()
    }

    /// Where the action ends when it starts at `start` with `args`; `None`
    /// for an action that does not move the drone, or arguments that do
    /// not fit.
    pub fn target(&self, start: Point, args: &[f64]) -> Option<Point> {
        self.motion.as_ref()?.target(start, |p| self.arg(p, args))
    }

    /// Nominal seconds the action takes when it starts at `start` with
    /// `args`, flights at `speeds`. `None` when the arguments do not fit
    /// or a flight has no speeds to be timed at.
    pub fn nominal_duration(
        &self,
        start: Point,
        args: &[f64],
        speeds: Option<&Speeds>,
    ) -> Option<f64> {
        match &self.duration {
            DurationModel::Seconds(s) => Some(*s),
            DurationModel::Param(p) => self.arg(p, args),
            DurationModel::Flight => Some(speeds?.flight_time(start, self.target(start, args)?)),
        }
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

    /// Nominal seconds `action(args)` takes from `start` (see
    /// [`ActionSig::nominal_duration`]); `None` for an action the profile
    /// does not offer.
    pub fn nominal_duration(&self, action: &str, args: &[f64], start: Point) -> Option<f64> {
        self.actions
            .get(action)?
            .nominal_duration(start, args, self.speeds.as_ref())
    }
}
