//! Conditions that can never hold, or always hold, whatever the sensors say.
//!
//! Exploration treats every guard as "may hold, may not", which is sound but
//! blind to `D1.Battery() > 120`. This module reasons over the values the
//! properties can take (the profile's `range`, unbounded otherwise; booleans
//! are 0 or 1) with intervals, keeping a disjunction of *boxes* (one interval
//! per property read) so that `D1.X() > 3 && D1.X() < 2` is seen to be empty
//! although each side alone can hold. Comparisons of one property with a
//! constant narrow its interval; any other comparison is decided by interval
//! arithmetic over the box, or kept as "may hold". Everything is an
//! over-approximation of what can hold, so "never holds" is a proof; past a
//! fixed number of boxes the analysis gives up and says nothing.

use std::collections::BTreeMap;

use eamos_lang::hir::{BinaryOp, DroneId, Expr, UnaryOp};

/// Most boxes kept for one condition before giving up.
const MAX_BOXES: usize = 256;

/// What a condition can do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Possibility {
    /// No values of the properties make it true.
    NeverHolds,
    /// No values of the properties make it false.
    AlwaysHolds,
    /// It can hold and can fail (or the analysis could not tell).
    Either,
}

/// The values a property can take: its range and whether it is boolean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    pub lo: f64,
    pub hi: f64,
}

impl Domain {
    pub const UNBOUNDED: Domain = Domain {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };
}

/// A property read: drone, name, drone arguments.
type Key = (DroneId, String, Vec<DroneId>);

#[derive(Debug, Clone, Copy, PartialEq)]
struct Iv {
    lo: f64,
    lo_open: bool,
    hi: f64,
    hi_open: bool,
}

impl Iv {
    fn closed(lo: f64, hi: f64) -> Iv {
        let (lo, hi) = (
            if lo.is_nan() { f64::NEG_INFINITY } else { lo },
            if hi.is_nan() { f64::INFINITY } else { hi },
        );
        Iv {
            lo,
            lo_open: false,
            hi,
            hi_open: false,
        }
    }

    fn point(v: f64) -> Iv {
        Iv::closed(v, v)
    }

    fn unbounded() -> Iv {
        Iv::closed(f64::NEG_INFINITY, f64::INFINITY)
    }

    fn is_empty(&self) -> bool {
        self.lo > self.hi || (self.lo == self.hi && (self.lo_open || self.hi_open))
    }

    fn is_point(&self) -> Option<f64> {
        (self.lo == self.hi && !self.is_empty()).then_some(self.lo)
    }

    /// Narrows the upper end to `v` (open or closed), keeping the tighter.
    fn cap_hi(&mut self, v: f64, open: bool) {
        if v < self.hi || (v == self.hi && open) {
            self.hi = v;
            self.hi_open = open;
        }
    }

    fn cap_lo(&mut self, v: f64, open: bool) {
        if v > self.lo || (v == self.lo && open) {
            self.lo = v;
            self.lo_open = open;
        }
    }
}

fn arith(op: BinaryOp, a: Iv, b: Iv) -> Iv {
    match op {
        BinaryOp::Add => Iv::closed(a.lo + b.lo, a.hi + b.hi),
        BinaryOp::Sub => Iv::closed(a.lo - b.hi, a.hi - b.lo),
        BinaryOp::Mul => {
            let c = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
            if c.iter().any(|x| x.is_nan()) {
                return Iv::unbounded();
            }
            Iv::closed(
                c.iter().copied().fold(f64::INFINITY, f64::min),
                c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
        BinaryOp::Div => {
            if b.lo <= 0.0 && b.hi >= 0.0 {
                return Iv::unbounded();
            }
            let c = [a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi];
            if c.iter().any(|x| x.is_nan()) {
                return Iv::unbounded();
            }
            Iv::closed(
                c.iter().copied().fold(f64::INFINITY, f64::min),
                c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
        _ => Iv::unbounded(),
    }
}

/// Whether `a op b` can hold for some values in the intervals.
fn can_compare(op: BinaryOp, a: Iv, b: Iv) -> bool {
    match op {
        BinaryOp::Lt => a.lo < b.hi,
        BinaryOp::Le => a.lo < b.hi || (a.lo == b.hi && !a.lo_open && !b.hi_open),
        BinaryOp::Gt => can_compare(BinaryOp::Lt, b, a),
        BinaryOp::Ge => can_compare(BinaryOp::Le, b, a),
        BinaryOp::Eq => {
            let mut i = a;
            i.cap_lo(b.lo, b.lo_open);
            i.cap_hi(b.hi, b.hi_open);
            !i.is_empty()
        }
        BinaryOp::Ne => !matches!((a.is_point(), b.is_point()), (Some(x), Some(y)) if x == y),
        _ => true,
    }
}

fn negate(op: BinaryOp) -> BinaryOp {
    match op {
        BinaryOp::Lt => BinaryOp::Ge,
        BinaryOp::Le => BinaryOp::Gt,
        BinaryOp::Gt => BinaryOp::Le,
        BinaryOp::Ge => BinaryOp::Lt,
        BinaryOp::Eq => BinaryOp::Ne,
        BinaryOp::Ne => BinaryOp::Eq,
        other => other,
    }
}

/// `a op b` as `b op' a`.
fn flip(op: BinaryOp) -> BinaryOp {
    match op {
        BinaryOp::Lt => BinaryOp::Gt,
        BinaryOp::Le => BinaryOp::Ge,
        BinaryOp::Gt => BinaryOp::Lt,
        BinaryOp::Ge => BinaryOp::Le,
        other => other,
    }
}

type Boxes = Vec<BTreeMap<Key, Iv>>;

struct Analysis<'a> {
    domain: &'a dyn Fn(DroneId, &str) -> Option<Domain>,
}

struct GiveUp;

fn key(drone: DroneId, name: &str, args: &[DroneId]) -> Key {
    (drone, name.to_string(), args.to_vec())
}

impl Analysis<'_> {
    fn lookup(&self, b: &BTreeMap<Key, Iv>, k: &Key) -> Iv {
        b.get(k).copied().unwrap_or_else(|| {
            let d = (self.domain)(k.0, &k.1).unwrap_or(Domain::UNBOUNDED);
            Iv::closed(d.lo, d.hi)
        })
    }

    /// The values a numeric expression can take in a box.
    fn eval(&self, e: &Expr, b: &BTreeMap<Key, Iv>) -> Iv {
        match e {
            Expr::Number { value, .. } => Iv::point(*value),
            Expr::Bool { value, .. } => Iv::point(if *value { 1.0 } else { 0.0 }),
            Expr::Property {
                drone, name, args, ..
            } => self.lookup(b, &key(*drone, name, args)),
            Expr::Unary {
                op: UnaryOp::Neg,
                operand,
                ..
            } => {
                let v = self.eval(operand, b);
                Iv {
                    lo: -v.hi,
                    lo_open: v.hi_open,
                    hi: -v.lo,
                    hi_open: v.lo_open,
                }
            }
            Expr::Unary {
                op: UnaryOp::Not,
                operand,
                ..
            } => {
                let v = self.eval(operand, b);
                match v.is_point() {
                    Some(x) => Iv::point(if x == 0.0 { 1.0 } else { 0.0 }),
                    None => Iv::closed(0.0, 1.0),
                }
            }
            Expr::Binary { op, lhs, rhs, .. } => match op {
                BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div => {
                    arith(*op, self.eval(lhs, b), self.eval(rhs, b))
                }
                _ => Iv::closed(0.0, 1.0),
            },
        }
    }

    fn constant(e: &Expr) -> bool {
        let mut c = true;
        e.visit(&mut |x| c &= !matches!(x, Expr::Property { .. }));
        c
    }

    /// The boxes of `input` in which `e` can evaluate to `want`.
    fn sat(&self, e: &Expr, want: bool, input: Boxes) -> Result<Boxes, GiveUp> {
        if input.is_empty() {
            return Ok(input);
        }
        let out = match e {
            Expr::Bool { value, .. } => {
                if *value == want {
                    input
                } else {
                    Vec::new()
                }
            }
            Expr::Unary {
                op: UnaryOp::Not,
                operand,
                ..
            } => self.sat(operand, !want, input)?,
            Expr::Binary {
                op: op @ (BinaryOp::And | BinaryOp::Or),
                lhs,
                rhs,
                ..
            } => {
                let conj = (*op == BinaryOp::And) == want;
                if conj {
                    let l = self.sat(lhs, want, input)?;
                    self.sat(rhs, want, l)?
                } else {
                    let mut l = self.sat(lhs, want, input.clone())?;
                    l.extend(self.sat(rhs, want, input)?);
                    l
                }
            }
            Expr::Property {
                drone, name, args, ..
            } => {
                // A boolean property read as a condition: 1 is true.
                let k = key(*drone, name, args);
                let v = if want { 1.0 } else { 0.0 };
                self.narrow(input, &k, BinaryOp::Eq, Iv::point(v))
            }
            Expr::Binary { op, lhs, rhs, .. } => {
                let op = if want { *op } else { negate(*op) };
                match (&**lhs, &**rhs) {
                    (
                        Expr::Property {
                            drone, name, args, ..
                        },
                        c,
                    ) if Self::constant(c) => {
                        let c = self.eval(c, &BTreeMap::new());
                        self.narrow(input, &key(*drone, name, args), op, c)
                    }
                    (
                        c,
                        Expr::Property {
                            drone, name, args, ..
                        },
                    ) if Self::constant(c) => {
                        let c = self.eval(c, &BTreeMap::new());
                        self.narrow(input, &key(*drone, name, args), flip(op), c)
                    }
                    _ => input
                        .into_iter()
                        .filter(|b| can_compare(op, self.eval(lhs, b), self.eval(rhs, b)))
                        .collect(),
                }
            }
            // A number in a boolean position does not type-check; say nothing.
            _ => return Err(GiveUp),
        };
        if out.len() > MAX_BOXES {
            return Err(GiveUp);
        }
        Ok(out)
    }

    /// Keeps the part of each box where `property op c` can hold.
    fn narrow(&self, input: Boxes, k: &Key, op: BinaryOp, c: Iv) -> Boxes {
        input
            .into_iter()
            .filter_map(|mut b| {
                let mut v = self.lookup(&b, k);
                match op {
                    BinaryOp::Lt => v.cap_hi(c.hi, true),
                    BinaryOp::Le => v.cap_hi(c.hi, c.hi_open),
                    BinaryOp::Gt => v.cap_lo(c.lo, true),
                    BinaryOp::Ge => v.cap_lo(c.lo, c.lo_open),
                    BinaryOp::Eq => {
                        v.cap_lo(c.lo, c.lo_open);
                        v.cap_hi(c.hi, c.hi_open);
                    }
                    BinaryOp::Ne => {
                        if matches!((v.is_point(), c.is_point()), (Some(x), Some(y)) if x == y) {
                            return None;
                        }
                    }
                    _ => {}
                }
                if v.is_empty() {
                    return None;
                }
                b.insert(k.clone(), v);
                Some(b)
            })
            .collect()
    }
}

/// Decides whether `cond` can never hold or always holds, given the domain of
/// each property (`None`: unbounded).
pub fn possibility(cond: &Expr, domain: &dyn Fn(DroneId, &str) -> Option<Domain>) -> Possibility {
    let a = Analysis { domain };
    let start = || vec![BTreeMap::new()];
    match a.sat(cond, true, start()) {
        Ok(b) if b.is_empty() => return Possibility::NeverHolds,
        Err(GiveUp) => return Possibility::Either,
        Ok(_) => {}
    }
    match a.sat(cond, false, start()) {
        Ok(b) if b.is_empty() => Possibility::AlwaysHolds,
        _ => Possibility::Either,
    }
}

/// The properties a condition reads, for explaining a verdict.
pub(crate) fn properties_read(cond: &Expr) -> Vec<(DroneId, String)> {
    let mut out = Vec::new();
    cond.visit(&mut |e| {
        if let Expr::Property { drone, name, .. } = e {
            out.push((*drone, name.clone()));
        }
    });
    out.sort();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_lang::Span;

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
    fn not(e: Expr) -> Expr {
        Expr::Unary {
            op: UnaryOp::Not,
            operand: Box::new(e),
            span: Span::default(),
        }
    }
    fn domains(_: DroneId, name: &str) -> Option<Domain> {
        match name {
            "Battery" => Some(Domain { lo: 0.0, hi: 100.0 }),
            "IsArmed" => Some(Domain { lo: 0.0, hi: 1.0 }),
            _ => None,
        }
    }

    #[test]
    fn a_battery_above_its_range_never_holds() {
        let c = bin(BinaryOp::Gt, prop(0, "Battery"), num(120.0));
        assert_eq!(possibility(&c, &domains), Possibility::NeverHolds);
    }

    #[test]
    fn a_disjunction_covering_the_range_always_holds() {
        let c = bin(
            BinaryOp::Or,
            bin(BinaryOp::Ge, prop(0, "Battery"), num(0.0)),
            bin(BinaryOp::Lt, prop(0, "X"), num(3.0)),
        );
        assert_eq!(possibility(&c, &domains), Possibility::AlwaysHolds);
    }

    #[test]
    fn an_empty_window_on_one_property_never_holds_though_each_side_can() {
        let c = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(0, "X"), num(3.0)),
            bin(BinaryOp::Lt, prop(0, "X"), num(2.0)),
        );
        assert_eq!(possibility(&c, &domains), Possibility::NeverHolds);
        let touching = bin(
            BinaryOp::And,
            bin(BinaryOp::Ge, prop(0, "X"), num(3.0)),
            bin(BinaryOp::Le, prop(0, "X"), num(3.0)),
        );
        assert_eq!(possibility(&touching, &domains), Possibility::Either);
        let open = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(0, "X"), num(3.0)),
            bin(BinaryOp::Le, prop(0, "X"), num(3.0)),
        );
        assert_eq!(possibility(&open, &domains), Possibility::NeverHolds);
    }

    #[test]
    fn arithmetic_over_ranges_decides_comparisons_between_expressions() {
        // Battery * 2 + 1 is at most 201.
        let c = bin(
            BinaryOp::Gt,
            bin(
                BinaryOp::Add,
                bin(BinaryOp::Mul, prop(0, "Battery"), num(2.0)),
                num(1.0),
            ),
            num(250.0),
        );
        assert_eq!(possibility(&c, &domains), Possibility::NeverHolds);
        let d = bin(BinaryOp::Lt, prop(0, "Battery"), prop(1, "Battery"));
        assert_eq!(possibility(&d, &domains), Possibility::Either);
        let e = bin(
            BinaryOp::Le,
            bin(BinaryOp::Sub, prop(0, "Battery"), prop(1, "Battery")),
            num(100.0),
        );
        assert_eq!(possibility(&e, &domains), Possibility::AlwaysHolds);
    }

    #[test]
    fn a_boolean_property_and_its_negation_cannot_both_hold() {
        let c = bin(BinaryOp::And, prop(0, "IsArmed"), not(prop(0, "IsArmed")));
        assert_eq!(possibility(&c, &domains), Possibility::NeverHolds);
        let d = bin(BinaryOp::Or, prop(0, "IsArmed"), not(prop(0, "IsArmed")));
        assert_eq!(possibility(&d, &domains), Possibility::AlwaysHolds);
    }

    #[test]
    fn a_division_by_a_range_holding_zero_is_unbounded() {
        let c = bin(
            BinaryOp::Gt,
            bin(BinaryOp::Div, num(1.0), prop(0, "Battery")),
            num(1e12),
        );
        assert_eq!(possibility(&c, &domains), Possibility::Either);
    }

    #[test]
    fn the_area_test_of_experiment_d_can_hold_and_fail() {
        let c = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(2, "X"), num(-30.0)),
            bin(BinaryOp::Lt, prop(2, "X"), num(30.0)),
        );
        assert_eq!(possibility(&c, &domains), Possibility::Either);
    }
}
