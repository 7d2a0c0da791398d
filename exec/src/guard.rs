//! Conditions of guards, evaluated over the latest telemetry of the drones
//! they read: this drone's own, and other drones' as received over the
//! transport. A condition over a drone whose telemetry has not arrived yet
//! is undecided, never false: a branch must not be taken on a guess. Nor is
//! the last telemetry of a drone that has since been lost: it is frozen, not
//! an answer, so a condition over it is undecided until the drone is back.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use eamos_lang::hir::{BinaryOp, Expr, UnaryOp};
use eamos_mid::{evaluate_property, PropertyArg, Telemetry, Value};

/// Why a condition has no value now.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EvalError {
    #[error("no telemetry from {0} yet")]
    NoTelemetry(String),
    #[error("{0} is lost: its last telemetry is no answer")]
    Lost(String),
    #[error("{0}")]
    Property(String),
    #[error("type mismatch in a condition: {0}")]
    Type(String),
}

/// The latest state of every drone a slice may read, by drone index.
#[derive(Debug, Clone, Default)]
pub struct World {
    /// The slice's list, shared.
    names: Arc<[String]>,
    latest: HashMap<u16, Telemetry>,
    /// Drones lost (by liveness) whose telemetry no condition may use.
    lost: HashSet<u16>,
}

impl World {
    /// A world over the mission's drones (by `DroneId` index).
    pub fn new(names: impl Into<Arc<[String]>>) -> Self {
        World {
            names: names.into(),
            latest: HashMap::new(),
            lost: HashSet::new(),
        }
    }

    pub fn index(&self, name: &str) -> Option<u16> {
        self.names.iter().position(|n| n == name).map(|i| i as u16)
    }

    pub fn set(&mut self, drone: u16, t: Telemetry) {
        self.latest.insert(drone, t);
    }

    pub fn get(&self, drone: u16) -> Option<&Telemetry> {
        self.latest.get(&drone)
    }

    /// Marks `drone` lost or back: while it is lost, conditions over it are
    /// undecided ([`EvalError::Lost`]) whatever it last sent.
    pub fn set_lost(&mut self, drone: u16, lost: bool) {
        if lost {
            self.lost.insert(drone);
        } else {
            self.lost.remove(&drone);
        }
    }

    fn name(&self, drone: u16) -> String {
        self.names
            .get(drone as usize)
            .cloned()
            .unwrap_or_else(|| format!("drone#{drone}"))
    }

    fn telemetry(&self, drone: u16) -> Result<&Telemetry, EvalError> {
        if self.lost.contains(&drone) {
            return Err(EvalError::Lost(self.name(drone)));
        }
        self.latest
            .get(&drone)
            .ok_or_else(|| EvalError::NoTelemetry(self.name(drone)))
    }

    /// The value of `e` now.
    pub fn eval(&self, e: &Expr) -> Result<Value, EvalError> {
        match e {
            Expr::Number { value, .. } => Ok(Value::Number(*value)),
            Expr::Bool { value, .. } => Ok(Value::Bool(*value)),
            Expr::Property {
                drone, name, args, ..
            } => {
                let own = self.telemetry(drone.0)?;
                let others = args
                    .iter()
                    .map(|a| self.telemetry(a.0))
                    .collect::<Result<Vec<_>, _>>()?;
                let args: Vec<PropertyArg<'_>> =
                    others.into_iter().map(PropertyArg::Drone).collect();
                evaluate_property(name, own, &args).map_err(|e| EvalError::Property(e.to_string()))
            }
            Expr::Unary { op, operand, .. } => {
                let v = self.eval(operand)?;
                match (op, v) {
                    (UnaryOp::Not, Value::Bool(b)) => Ok(Value::Bool(!b)),
                    (UnaryOp::Neg, Value::Number(n)) => Ok(Value::Number(-n)),
                    (op, v) => Err(EvalError::Type(format!("{op:?} of {v}"))),
                }
            }
            Expr::Binary { op, lhs, rhs, .. } => {
                // `&&` and `||` decide on the left operand where they can,
                // so `D3.X() > 0 || D4.X() > 0` holds once D3's telemetry
                // says so, before D4's has arrived.
                if matches!(op, BinaryOp::And | BinaryOp::Or) {
                    let short = matches!(op, BinaryOp::Or);
                    let l = self.eval(lhs).and_then(bool_of);
                    if l == Ok(short) {
                        return Ok(Value::Bool(short));
                    }
                    let r = self.eval(rhs).and_then(bool_of);
                    if r == Ok(short) {
                        return Ok(Value::Bool(short));
                    }
                    return match (l, r) {
                        (Ok(_), Ok(_)) => Ok(Value::Bool(!short)),
                        (Err(e), _) | (_, Err(e)) => Err(e),
                    };
                }
                let l = self.eval(lhs)?;
                let r = self.eval(rhs)?;
                binary(*op, l, r)
            }
        }
    }

    /// The value of a boolean condition now.
    pub fn holds(&self, e: &Expr) -> Result<bool, EvalError> {
        self.eval(e).and_then(bool_of)
    }
}

fn bool_of(v: Value) -> Result<bool, EvalError> {
    v.as_bool()
        .ok_or_else(|| EvalError::Type(format!("{v} is not a truth value")))
}

fn binary(op: BinaryOp, l: Value, r: Value) -> Result<Value, EvalError> {
    use Value::{Bool, Number};
    Ok(match (op, l, r) {
        (BinaryOp::Add, Number(a), Number(b)) => Number(a + b),
        (BinaryOp::Sub, Number(a), Number(b)) => Number(a - b),
        (BinaryOp::Mul, Number(a), Number(b)) => Number(a * b),
        (BinaryOp::Div, Number(a), Number(b)) => Number(a / b),
        (BinaryOp::Lt, Number(a), Number(b)) => Bool(a < b),
        (BinaryOp::Le, Number(a), Number(b)) => Bool(a <= b),
        (BinaryOp::Gt, Number(a), Number(b)) => Bool(a > b),
        (BinaryOp::Ge, Number(a), Number(b)) => Bool(a >= b),
        (BinaryOp::Eq, Number(a), Number(b)) => Bool(a == b),
        (BinaryOp::Ne, Number(a), Number(b)) => Bool(a != b),
        (BinaryOp::Eq, Bool(a), Bool(b)) => Bool(a == b),
        (BinaryOp::Ne, Bool(a), Bool(b)) => Bool(a != b),
        (op, l, r) => return Err(EvalError::Type(format!("{l} {op:?} {r}"))),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_lang::hir::DroneId;
    use eamos_lang::Span;
    use eamos_mid::Vec3;

    fn num(v: f64) -> Expr {
        Expr::Number {
            value: v,
            span: Span::default(),
        }
    }

    fn prop(d: u16, name: &str) -> Expr {
        Expr::Property {
            drone: DroneId(d),
            name: name.into(),
            args: vec![],
            span: Span::default(),
        }
    }

    fn bin(op: BinaryOp, l: Expr, r: Expr) -> Expr {
        Expr::Binary {
            op,
            lhs: Box::new(l),
            rhs: Box::new(r),
            span: Span::default(),
        }
    }

    fn at(x: f64, y: f64) -> Telemetry {
        Telemetry {
            position: Vec3::new(x, y, 1.0),
            ..Telemetry::at_home(Vec3::ZERO)
        }
    }

    #[test]
    fn a_condition_over_positions_follows_the_latest_telemetry() {
        let mut w = World::new(vec!["D1".into(), "D3".into()]);
        let inside = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(1, "X"), num(-30.0)),
            bin(BinaryOp::Lt, prop(1, "X"), num(30.0)),
        );
        w.set(1, at(0.0, 0.0));
        assert_eq!(w.holds(&inside), Ok(true));
        w.set(1, at(45.0, 0.0));
        assert_eq!(w.holds(&inside), Ok(false));
    }

    #[test]
    fn a_condition_over_a_drone_not_heard_from_is_undecided_and_names_it() {
        let w = World::new(vec!["D1".into(), "D3".into()]);
        let e = bin(BinaryOp::Gt, prop(1, "X"), num(0.0));
        assert_eq!(w.holds(&e), Err(EvalError::NoTelemetry("D3".into())));
    }

    #[test]
    fn or_holds_as_soon_as_one_known_side_holds() {
        let mut w = World::new(vec!["D1".into(), "D2".into()]);
        w.set(0, at(5.0, 0.0));
        let e = bin(
            BinaryOp::Or,
            bin(BinaryOp::Gt, prop(1, "X"), num(0.0)),
            bin(BinaryOp::Gt, prop(0, "X"), num(0.0)),
        );
        assert_eq!(w.holds(&e), Ok(true));
        let and = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(1, "X"), num(0.0)),
            bin(BinaryOp::Lt, prop(0, "X"), num(0.0)),
        );
        assert_eq!(w.holds(&and), Ok(false));
    }

    #[test]
    fn distance_between_two_drones_uses_both_telemetries() {
        let mut w = World::new(vec!["D1".into(), "D2".into()]);
        w.set(0, at(0.0, 0.0));
        w.set(1, at(3.0, 4.0));
        let e = Expr::Property {
            drone: DroneId(0),
            name: "DistanceTo".into(),
            args: vec![DroneId(1)],
            span: Span::default(),
        };
        assert_eq!(w.eval(&e), Ok(Value::Number(5.0)));
    }

    #[test]
    fn the_frozen_telemetry_of_a_lost_drone_decides_nothing_until_it_is_back() {
        let mut w = World::new(vec!["D1".into(), "D2".into()]);
        w.set(0, at(5.0, 0.0));
        w.set(1, at(5.0, 0.0));
        let theirs = bin(BinaryOp::Gt, prop(1, "X"), num(0.0));
        assert_eq!(w.holds(&theirs), Ok(true));
        w.set_lost(1, true);
        assert_eq!(w.holds(&theirs), Err(EvalError::Lost("D2".into())));
        let not_theirs = Expr::Unary {
            op: UnaryOp::Not,
            operand: Box::new(theirs.clone()),
            span: Span::default(),
        };
        assert_eq!(w.holds(&not_theirs), Err(EvalError::Lost("D2".into())));
        // An answer that does not need the lost drone still stands.
        let either = bin(
            BinaryOp::Or,
            theirs.clone(),
            bin(BinaryOp::Gt, prop(0, "X"), num(0.0)),
        );
        assert_eq!(w.holds(&either), Ok(true));
        w.set_lost(1, false);
        assert_eq!(w.holds(&theirs), Ok(true));
    }

    #[test]
    fn comparing_a_truth_value_with_a_number_is_a_type_error() {
        let mut w = World::new(vec!["D1".into()]);
        w.set(0, at(0.0, 0.0));
        let e = bin(BinaryOp::Lt, prop(0, "IsArmed"), num(1.0));
        assert!(matches!(w.holds(&e), Err(EvalError::Type(_))));
    }
}
