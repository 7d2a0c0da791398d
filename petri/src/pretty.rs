//! Conditions and actions written back as mission text, for labels of nodes,
//! guards in exports and messages. What a person reads in a drawing should be
//! what they wrote in the mission, not a debug dump of the tree.

use eamos_lang::hir::{BinaryOp, DroneId, Expr, UnaryOp};

/// An expression in mission syntax, with the fewest parentheses that keep
/// its meaning. `drones` names the drones by [`DroneId`]; an id without a
/// name prints as `drone#N`, so a malformed net still prints.
pub fn expr(e: &Expr, drones: &[String]) -> String {
    let mut out = String::new();
    write_expr(e, drones, 0, &mut out);
    out
}

/// A number as a mission would write it: `1.5`, `-30`, `0.2`.
pub fn number(v: f64) -> String {
    format!("{v}")
}

pub(crate) fn drone_name(drones: &[String], d: DroneId) -> String {
    drones
        .get(d.0 as usize)
        .cloned()
        .unwrap_or_else(|| format!("drone#{}", d.0))
}

fn precedence(op: BinaryOp) -> u8 {
    match op {
        BinaryOp::Or => 1,
        BinaryOp::And => 2,
        BinaryOp::Eq | BinaryOp::Ne | BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge => {
            3
        }
        BinaryOp::Add | BinaryOp::Sub => 4,
        BinaryOp::Mul | BinaryOp::Div => 5,
    }
}

const UNARY_PRECEDENCE: u8 = 6;

fn symbol(op: BinaryOp) -> &'static str {
    match op {
        BinaryOp::Or => "||",
        BinaryOp::And => "&&",
        BinaryOp::Eq => "==",
        BinaryOp::Ne => "!=",
        BinaryOp::Lt => "<",
        BinaryOp::Le => "<=",
        BinaryOp::Gt => ">",
        BinaryOp::Ge => ">=",
        BinaryOp::Add => "+",
        BinaryOp::Sub => "-",
        BinaryOp::Mul => "*",
        BinaryOp::Div => "/",
    }
}

/// Writes `e`, in parentheses if it binds less tightly than `min`.
fn write_expr(e: &Expr, drones: &[String], min: u8, out: &mut String) {
    match e {
        Expr::Number { value, .. } => out.push_str(&number(*value)),
        Expr::Bool { value, .. } => out.push_str(if *value { "true" } else { "false" }),
        Expr::Property {
            drone, name, args, ..
        } => {
            out.push_str(&drone_name(drones, *drone));
            out.push('.');
            out.push_str(name);
            out.push('(');
            let args: Vec<String> = args.iter().map(|a| drone_name(drones, *a)).collect();
            out.push_str(&args.join(", "));
            out.push(')');
        }
        Expr::Unary { op, operand, .. } => {
            let paren = UNARY_PRECEDENCE < min;
            if paren {
                out.push('(');
            }
            out.push(match op {
                UnaryOp::Not => '!',
                UnaryOp::Neg => '-',
            });
            write_expr(operand, drones, UNARY_PRECEDENCE, out);
            if paren {
                out.push(')');
            }
        }
        Expr::Binary { op, lhs, rhs, .. } => {
            let p = precedence(*op);
            let paren = p < min;
            if paren {
                out.push('(');
            }
            // Left-associative: the right operand needs parentheses at equal
            // precedence (`a - (b - c)`), the left one does not.
            write_expr(lhs, drones, p, out);
            out.push(' ');
            out.push_str(symbol(*op));
            out.push(' ');
            write_expr(rhs, drones, p + 1, out);
            if paren {
                out.push(')');
            }
        }
    }
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

    #[test]
    fn conditions_print_as_the_mission_wrote_them() {
        let names = vec!["D1".to_string(), "D3".to_string()];
        let e = bin(
            BinaryOp::And,
            bin(BinaryOp::Gt, prop(1, "X"), num(-30.0)),
            bin(BinaryOp::Lt, prop(1, "X"), num(30.0)),
        );
        assert_eq!(expr(&e, &names), "D3.X() > -30 && D3.X() < 30");
    }

    #[test]
    fn parentheses_appear_only_where_precedence_needs_them() {
        let names = vec!["D1".to_string()];
        let or = bin(
            BinaryOp::Or,
            bin(BinaryOp::Lt, prop(0, "Z"), num(1.0)),
            bin(BinaryOp::Gt, prop(0, "Z"), num(2.5)),
        );
        let e = Expr::Unary {
            op: UnaryOp::Not,
            operand: Box::new(bin(BinaryOp::And, or, num(1.0))),
            span: Span::default(),
        };
        assert_eq!(expr(&e, &names), "!((D1.Z() < 1 || D1.Z() > 2.5) && 1)");
        let sub = bin(
            BinaryOp::Sub,
            num(1.0),
            bin(BinaryOp::Sub, num(2.0), num(3.0)),
        );
        assert_eq!(expr(&sub, &names), "1 - (2 - 3)");
    }

    #[test]
    fn a_property_with_a_drone_argument_names_both_drones() {
        let names = vec!["D1".to_string(), "D2".to_string()];
        let e = Expr::Property {
            drone: DroneId(0),
            name: "DistanceTo".into(),
            args: vec![DroneId(1)],
            span: Span::default(),
        };
        assert_eq!(expr(&e, &names), "D1.DistanceTo(D2)");
        assert_eq!(expr(&prop(7, "X"), &names), "drone#7.X()");
    }
}
