//! Constants and expressions: constants are folded in declaration order
//! (a cycle is reported once, where it closes), and every expression is
//! lowered with its type and, where known before the flight, its value, so
//! that what is constant reaches the net as a number.

use super::state::{Binding, Checker, ConstState, Ctx, Env, Global, Konst, Low, Ty, NUMERIC_TYPES};
use crate::ast::{self, ExprKind};
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir::{self, BinaryOp, UnaryOp};
use crate::span::Span;

impl<'a> Checker<'a> {
    /// The folded value of a constant (`None` if it has an error, already
    /// reported). `at` is where it is used, for the message about a cycle.
    pub(super) fn const_value(&mut self, name: &'a str, at: Option<Span>) -> Option<f64> {
        match self.consts.get(name) {
            None => None,
            Some(ConstState::Done(v)) => *v,
            Some(ConstState::Evaluating) => {
                let span = at.unwrap_or_default();
                self.emit(
                    Diagnostic::error(
                        "eamos::const-cycle",
                        span,
                        format!("constant `{name}` is defined in terms of itself"),
                    )
                    .with_label("refers back to the constant being defined")
                    .with_help("a constant must be computable from numbers and earlier constants"),
                );
                self.consts.insert(name, ConstState::Done(None));
                None
            }
            Some(ConstState::Pending(spec)) => {
                let spec = *spec;
                self.consts.insert(name, ConstState::Evaluating);
                let value = self.eval_const_spec(spec);
                if !matches!(self.consts.get(name), Some(ConstState::Done(None))) {
                    self.consts.insert(name, ConstState::Done(value));
                }
                value
            }
        }
    }

    pub(super) fn eval_const_spec(&mut self, spec: &'a ast::ConstSpec) -> Option<f64> {
        let ctx = Ctx::default();
        let low = self.lower_expr(&spec.value, &Env::default(), &ctx)?;
        let value = match (low.ty, low.konst) {
            (Ty::Bool, _) => {
                self.emit(
                    Diagnostic::error(
                        "eamos::type-mismatch",
                        spec.value.span,
                        format!(
                            "constant `{}` must be a number, found a boolean",
                            spec.name.name
                        ),
                    )
                    .with_label("a boolean")
                    .with_help("constants are numbers: distances, durations, counts"),
                );
                return None;
            }
            (_, Konst::Num(v)) => v,
            _ => {
                self.emit(not_constant(&spec.value, "a constant's value"));
                return None;
            }
        };
        if let Some(ty) = &spec.ty {
            if !NUMERIC_TYPES.contains(&ty.name.as_str()) {
                self.emit(
                    Diagnostic::error(
                        "eamos::unknown-type",
                        ty.span,
                        format!("unknown constant type `{}`", ty.name),
                    )
                    .with_label("expected a number type")
                    .with_help(did_you_mean(
                        &ty.name,
                        ["float64", "int"],
                        || "use `float64` or `int`, or leave the type out".into(),
                    )),
                );
                return None;
            }
            if !ty.name.starts_with("float") && value.fract() != 0.0 {
                self.emit(
                    Diagnostic::error(
                        "eamos::type-mismatch",
                        spec.value.span,
                        format!(
                            "constant `{}` is an `{}`, but its value is {value}",
                            spec.name.name, ty.name
                        ),
                    )
                    .with_label("not a whole number")
                    .with_help("declare it `float64`, or leave the type out"),
                );
                return None;
            }
        }
        Some(value)
    }

    /// A numeric constant expression, folded (`None` if it has an error,
    /// reported). In the check pass a number parameter folds to a stand-in.
    /// `what` names the expression in a diagnostic: formatted only for one,
    /// not for every argument of a mission that has none.
    pub(super) fn const_number(
        &mut self,
        e: &'a ast::Expr,
        env: &Env<'a>,
        ctx: &Ctx,
        what: &dyn Fn() -> String,
    ) -> Option<f64> {
        let low = self.lower_expr(e, env, ctx)?;
        if low.ty == Ty::Bool {
            self.emit(
                Diagnostic::error(
                    "eamos::type-mismatch",
                    e.span,
                    format!("{} must be a number, found a boolean", what()),
                )
                .with_label("a boolean"),
            );
            return None;
        }
        match low.konst {
            Konst::Num(v) => Some(v),
            Konst::Unknown => Some(f64::NAN),
            _ => {
                self.emit(not_constant(e, &what()));
                None
            }
        }
    }

    pub(super) fn lower_expr(&mut self, e: &'a ast::Expr, env: &Env<'a>, ctx: &Ctx) -> Option<Low> {
        let span = e.span;
        match &e.kind {
            ExprKind::Number { value, bad } => {
                if *bad {
                    return None;
                }
                Some(number(*value, span))
            }
            ExprKind::Str(_) => {
                self.emit(
                    Diagnostic::error("eamos::type-mismatch", span, "a string cannot be used here")
                        .with_label("a string")
                        .with_help(
                            "strings only name events: `Signal(\"ready\")`, `Await(\"ready\")`",
                        ),
                );
                None
            }
            ExprKind::Paren(inner) => {
                let mut low = self.lower_expr(inner, env, ctx)?;
                set_span(&mut low.expr, span);
                Some(low)
            }
            ExprKind::Name(name) => self.lower_name(name, span, env),
            ExprKind::Selector { base, field } => {
                let path = e.path().unwrap_or_else(|| format!("….{}", field.name));
                let d = match base.as_name().and_then(|d| self.drone_profile_of(d, env)) {
                    Some(p) if p.properties.contains_key(&field.name) => Diagnostic::error(
                        "eamos::property-without-call",
                        span,
                        format!("property `{}` is read with parentheses", field.name),
                    )
                    .with_label("missing `()`")
                    .with_help(format!("write `{path}()`")),
                    _ => Diagnostic::error(
                        "eamos::type-mismatch",
                        span,
                        format!("`{path}` is not a value"),
                    )
                    .with_label("expected a number, a boolean or a property such as `D1.X()`"),
                };
                self.emit(d);
                None
            }
            ExprKind::Call { callee, args } => self.lower_property(e, callee, args, env, ctx),
            ExprKind::Unary {
                op,
                op_span,
                operand,
            } => {
                let inner = self.lower_expr(operand, env, ctx)?;
                let want = match op {
                    UnaryOp::Not => Ty::Bool,
                    UnaryOp::Neg => Ty::Number,
                };
                if inner.ty != want {
                    self.emit(
                        Diagnostic::error(
                            "eamos::type-mismatch",
                            operand.span,
                            format!(
                                "`{}` needs {}, found {}",
                                op.symbol(),
                                want.name(),
                                inner.ty.name()
                            ),
                        )
                        .with_label(inner.ty.name())
                        .with_note_at(*op_span, "operator"),
                    );
                    return None;
                }
                let konst = match (op, inner.konst) {
                    (UnaryOp::Not, Konst::Bool(b)) => Konst::Bool(!b),
                    (UnaryOp::Neg, Konst::Num(v)) => Konst::Num(-v),
                    (_, k) => k,
                };
                Some(fold(
                    hir::Expr::Unary {
                        op: *op,
                        operand: Box::new(inner.expr),
                        span,
                    },
                    want,
                    konst,
                    span,
                ))
            }
            ExprKind::Binary {
                op,
                op_span,
                lhs,
                rhs,
            } => {
                let l = self.lower_expr(lhs, env, ctx);
                let r = self.lower_expr(rhs, env, ctx);
                let (l, r) = (l?, r?);
                self.lower_binary(*op, *op_span, (lhs, l), (rhs, r), span, ctx)
            }
        }
    }

    pub(super) fn lower_binary(
        &mut self,
        op: BinaryOp,
        op_span: Span,
        (le, l): (&ast::Expr, Low),
        (re, r): (&ast::Expr, Low),
        span: Span,
        ctx: &Ctx,
    ) -> Option<Low> {
        use BinaryOp as B;
        let sym = op.symbol();
        let mismatch = |this: &mut Self, bad: &ast::Expr, got: Ty, want: &str| {
            this.emit(
                Diagnostic::error(
                    "eamos::type-mismatch",
                    bad.span,
                    format!("`{sym}` needs {want}, found {}", got.name()),
                )
                .with_label(got.name())
                .with_note_at(op_span, "operator"),
            );
        };
        let result_ty = match op {
            B::Or | B::And => {
                for (e, x) in [(le, &l), (re, &r)] {
                    if x.ty != Ty::Bool {
                        mismatch(self, e, x.ty, "booleans on both sides");
                        return None;
                    }
                }
                Ty::Bool
            }
            B::Lt | B::Le | B::Gt | B::Ge => {
                for (e, x) in [(le, &l), (re, &r)] {
                    if x.ty != Ty::Number {
                        self.emit(
                            Diagnostic::error(
                                "eamos::type-mismatch",
                                e.span,
                                format!("cannot compare a boolean with `{sym}`: only numbers are ordered"),
                            )
                            .with_label("a boolean")
                            .with_note_at(op_span, "ordering comparison")
                            .with_help("test a boolean directly (`D1.IsArmed()`, `!D1.IsArmed()`) or with `==`/`!=`"),
                        );
                        return None;
                    }
                }
                Ty::Bool
            }
            B::Eq | B::Ne => {
                if l.ty != r.ty {
                    self.emit(
                        Diagnostic::error(
                            "eamos::type-mismatch",
                            span,
                            format!("cannot compare {} with {}", l.ty.name(), r.ty.name()),
                        )
                        .with_label("mismatched types")
                        .with_note_at(op_span, "comparison"),
                    );
                    return None;
                }
                Ty::Bool
            }
            B::Add | B::Sub | B::Mul | B::Div => {
                for (e, x) in [(le, &l), (re, &r)] {
                    if x.ty != Ty::Number {
                        mismatch(self, e, x.ty, "numbers on both sides");
                        return None;
                    }
                }
                Ty::Number
            }
        };
        if op == B::Div && r.konst == Konst::Num(0.0) {
            let d = Diagnostic::error("eamos::division-by-zero", re.span, "division by zero")
                .with_label("this is zero")
                .with_note_at(op_span, "division");
            self.emit_value(d, ctx);
            return None;
        }
        let konst = match (l.konst, r.konst) {
            (Konst::Num(a), Konst::Num(b)) => match op {
                B::Add => Konst::Num(a + b),
                B::Sub => Konst::Num(a - b),
                B::Mul => Konst::Num(a * b),
                B::Div => Konst::Num(a / b),
                B::Lt => Konst::Bool(a < b),
                B::Le => Konst::Bool(a <= b),
                B::Gt => Konst::Bool(a > b),
                B::Ge => Konst::Bool(a >= b),
                B::Eq => Konst::Bool(a == b),
                B::Ne => Konst::Bool(a != b),
                B::Or | B::And => Konst::No,
            },
            (Konst::Bool(a), Konst::Bool(b)) => match op {
                B::Or => Konst::Bool(a || b),
                B::And => Konst::Bool(a && b),
                B::Eq => Konst::Bool(a == b),
                B::Ne => Konst::Bool(a != b),
                _ => Konst::No,
            },
            (Konst::No, _) | (_, Konst::No) => Konst::No,
            _ => Konst::Unknown,
        };
        if let Konst::Num(v) = konst {
            if !v.is_finite() {
                let d = Diagnostic::error("eamos::overflow", span, "this constant is too large")
                    .with_label(format!("evaluates to {v}"));
                self.emit_value(d, ctx);
                return None;
            }
        }
        Some(fold(
            hir::Expr::Binary {
                op,
                lhs: Box::new(l.expr),
                rhs: Box::new(r.expr),
                span,
            },
            result_ty,
            konst,
            span,
        ))
    }

    pub(super) fn lower_name(&mut self, name: &'a str, span: Span, env: &Env<'a>) -> Option<Low> {
        match env.get(name) {
            Some(Binding::Number { value, .. }) => {
                return Some(match value {
                    Some(v) => number(*v, span),
                    None => Low {
                        expr: hir::Expr::Number { value: 0.0, span },
                        ty: Ty::Number,
                        konst: Konst::Unknown,
                    },
                });
            }
            Some(Binding::Drone { .. }) => {
                self.emit(drone_as_value(name, span));
                return None;
            }
            Some(Binding::Poisoned) => return None,
            None => {}
        }
        if self.consts.contains_key(name) {
            return self.const_value(name, Some(span)).map(|v| number(v, span));
        }
        match name {
            "true" | "false" => {
                let value = name == "true";
                return Some(Low {
                    expr: hir::Expr::Bool { value, span },
                    ty: Ty::Bool,
                    konst: Konst::Bool(value),
                });
            }
            _ => {}
        }
        let d = match self.globals.get(name) {
            Some((Global::Drone, _)) => drone_as_value(name, span),
            Some((Global::Func, _)) => Diagnostic::error(
                "eamos::type-mismatch",
                span,
                format!("`{name}` is a block, not a value"),
            )
            .with_label("a block"),
            _ => {
                let mut candidates: Vec<&str> = self.consts.keys().copied().collect();
                candidates.extend(env.params.iter().map(|(n, _)| n.as_str()));
                candidates.extend(["true", "false"]);
                let mut d = Diagnostic::error(
                    "eamos::unknown-name",
                    span,
                    format!("unknown name `{name}`"),
                )
                .with_label("not a constant, a parameter, `true` or `false`");
                d.help = Some(did_you_mean(name, candidates.iter().copied(), || {
                    format!("declare it: `const {name} = ...`")
                }));
                d
            }
        };
        self.emit(d);
        None
    }
}

fn number(value: f64, span: Span) -> Low {
    Low {
        expr: hir::Expr::Number { value, span },
        ty: Ty::Number,
        konst: Konst::Num(value),
    }
}

/// Replaces a subtree whose value is known by its value.
fn fold(expr: hir::Expr, ty: Ty, konst: Konst, span: Span) -> Low {
    let expr = match konst {
        Konst::Num(value) => hir::Expr::Number { value, span },
        Konst::Bool(value) => hir::Expr::Bool { value, span },
        _ => expr,
    };
    Low { expr, ty, konst }
}

fn set_span(e: &mut hir::Expr, to: Span) {
    match e {
        hir::Expr::Number { span, .. }
        | hir::Expr::Bool { span, .. }
        | hir::Expr::Property { span, .. }
        | hir::Expr::Unary { span, .. }
        | hir::Expr::Binary { span, .. } => *span = to,
    }
}

fn not_constant(e: &ast::Expr, what: &str) -> Diagnostic {
    Diagnostic::error(
        "eamos::not-constant",
        e.span,
        format!("{what} must be a constant, known before the flight"),
    )
    .with_label("read from a drone at run time")
    .with_help("use numbers, constants and parameters here; drone properties belong in conditions")
}

fn drone_as_value(name: &str, span: Span) -> Diagnostic {
    Diagnostic::error(
        "eamos::type-mismatch",
        span,
        format!("drone `{name}` is not a value"),
    )
    .with_label("a drone")
    .with_help(format!(
        "read one of its properties, for example `{name}.X()` or `{name}.Battery()`"
    ))
}
