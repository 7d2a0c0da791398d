//! Which condition guards some sensor value can make true, decided by
//! trying values, not by the checker's interval reasoning: the oracle must
//! leave out exactly the guards `check` leaves out, and must not learn which
//! from the checker.
//!
//! Every property read takes, in turn, each value of a small grid: the
//! constants of the condition, half a unit either side of each, zero and
//! two far values, all kept to the property's range in its drone's profile
//! (booleans 0 and 1). A condition that compares properties with constants,
//! as every generated one does, holds for some values of the properties if
//! and only if it holds on this grid.

use std::collections::BTreeMap;

use eamos_lang::hir::{BinaryOp, DroneId, Expr, UnaryOp};
use eamos_petri::net::{Guard, Net};
use eamos_profile::{ProfileTable, ValueType};

/// Whether some values of the properties it reads make `guard` hold (a
/// colour guard: always, the game decides it).
pub fn may_hold(net: &Net, profiles: &ProfileTable, guard: &Guard) -> bool {
    let Some((cond, negated)) = guard.condition() else {
        return true;
    };
    let mut constants = Vec::new();
    let mut reads = Vec::new();
    cond.visit(&mut |e| match e {
        Expr::Number { value, .. } => constants.push(*value),
        Expr::Property {
            drone, name, args, ..
        } => reads.push((*drone, name.clone(), args.clone())),
        _ => {}
    });
    reads.sort();
    reads.dedup();
    let grids: Vec<Vec<f64>> = reads
        .iter()
        .map(|(d, name, _)| grid(net, profiles, *d, name, &constants))
        .collect();
    let mut values = BTreeMap::new();
    some_valuation(cond, negated, &reads, &grids, &mut values)
}

type Read = (DroneId, String, Vec<DroneId>);

fn some_valuation(
    cond: &Expr,
    negated: bool,
    reads: &[Read],
    grids: &[Vec<f64>],
    values: &mut BTreeMap<Read, f64>,
) -> bool {
    let Some((read, rest)) = reads.split_first() else {
        return (eval(cond, values) != 0.0) != negated;
    };
    grids[0].iter().any(|&x| {
        values.insert(read.clone(), x);
        some_valuation(cond, negated, rest, &grids[1..], values)
    })
}

fn grid(net: &Net, profiles: &ProfileTable, d: DroneId, name: &str, constants: &[f64]) -> Vec<f64> {
    let sig = net
        .profiles
        .get(d.0 as usize)
        .and_then(|p| profiles.get(p))
        .and_then(|p| p.properties.get(name));
    let (lo, hi) = match sig {
        Some(s) if s.ty == ValueType::Bool => return vec![0.0, 1.0],
        Some(s) => s.range.unwrap_or((f64::MIN, f64::MAX)),
        None => (f64::MIN, f64::MAX),
    };
    let mut g: Vec<f64> = constants
        .iter()
        .flat_map(|&c| [c - 0.5, c, c + 0.5])
        .chain([0.0, -1e6, 1e6, lo, hi])
        .map(|x| x.clamp(lo, hi))
        .collect();
    g.sort_by(f64::total_cmp);
    g.dedup();
    g
}

fn eval(e: &Expr, values: &BTreeMap<Read, f64>) -> f64 {
    let truth = |b: bool| if b { 1.0 } else { 0.0 };
    match e {
        Expr::Number { value, .. } => *value,
        Expr::Bool { value, .. } => truth(*value),
        Expr::Property {
            drone, name, args, ..
        } => values
            .get(&(*drone, name.clone(), args.clone()))
            .copied()
            .unwrap_or(0.0),
        Expr::Unary { op, operand, .. } => {
            let x = eval(operand, values);
            match op {
                UnaryOp::Neg => -x,
                UnaryOp::Not => truth(x == 0.0),
            }
        }
        Expr::Binary { op, lhs, rhs, .. } => {
            let (a, b) = (eval(lhs, values), eval(rhs, values));
            match op {
                BinaryOp::Add => a + b,
                BinaryOp::Sub => a - b,
                BinaryOp::Mul => a * b,
                BinaryOp::Div => a / b,
                BinaryOp::Lt => truth(a < b),
                BinaryOp::Le => truth(a <= b),
                BinaryOp::Gt => truth(a > b),
                BinaryOp::Ge => truth(a >= b),
                BinaryOp::Eq => truth(a == b),
                BinaryOp::Ne => truth(a != b),
                BinaryOp::And => truth(a != 0.0 && b != 0.0),
                BinaryOp::Or => truth(a != 0.0 || b != 0.0),
            }
        }
    }
}
