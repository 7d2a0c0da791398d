//! Conditions: booleans read from drone properties at run time, checked
//! against the profiles (the property exists, its arguments are drones) and
//! against what no sensor can answer (a drone related to itself).

use eamos_profile::{ParamKind, ValueType};

use super::state::{
    kind_name, list, offers, Checker, Ctx, Env, Konst, Low, Mode, Ty, UNKNOWN_DRONE,
};
use crate::ast::{self, ControlKind, ExprKind};
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir;

impl<'a> Checker<'a> {
    pub(super) fn condition(
        &mut self,
        c: &'a ast::ControlCall,
        e: &'a ast::Expr,
        env: &Env<'a>,
        ctx: &Ctx,
    ) -> Option<hir::Expr> {
        let low = self.lower_expr(e, env, ctx)?;
        if low.ty != Ty::Bool {
            self.emit(
                Diagnostic::error(
                    "eamos::type-mismatch",
                    e.span,
                    format!(
                        "the condition of `{}` must be a boolean, found {}",
                        c.kind.name(),
                        low.ty.name()
                    ),
                )
                .with_label("a number")
                .with_help("compare it with something, for example `D1.Battery() > 20`"),
            );
            return None;
        }
        Some(low.expr)
    }

    pub(super) fn lower_property(
        &mut self,
        e: &'a ast::Expr,
        callee: &'a ast::Expr,
        args: &'a ast::Args,
        env: &Env<'a>,
        ctx: &Ctx,
    ) -> Option<Low> {
        let span = e.span;
        let (drone_expr, field) = match &callee.kind {
            ExprKind::Selector { base, field } => (base, field),
            ExprKind::Name(n) => {
                let what =
                    if self.funcs.contains_key(n.as_str()) || ControlKind::from_name(n).is_some() {
                        format!("`{n}(...)` runs a block; it has no value")
                    } else {
                        format!("`{n}(...)` is not a value")
                    };
                self.emit(
                    Diagnostic::error("eamos::type-mismatch", span, what)
                        .with_label("expected a number, a boolean or a property such as `D1.X()`"),
                );
                return None;
            }
            _ => {
                self.emit(
                    Diagnostic::error("eamos::type-mismatch", span, "this call is not a value")
                        .with_label("expected a property such as `D1.X()`"),
                );
                return None;
            }
        };
        let Some(drone_name) = drone_expr.as_name() else {
            self.emit(
                Diagnostic::error(
                    "eamos::type-mismatch",
                    drone_expr.span,
                    "a property is read from a drone's name",
                )
                .with_label("expected a drone name")
                .with_help("for example `D3.X()`"),
            );
            return None;
        };
        let ident = ast::Ident {
            name: drone_name.to_string(),
            span: drone_expr.span,
        };
        let drone = self.resolve_drone(&ident, env)?;
        let profile = drone.profile?;
        let Some(sig) = profile.properties.get(&field.name) else {
            let d = if profile.actions.contains_key(&field.name) {
                Diagnostic::error(
                    "eamos::action-in-condition",
                    field.span,
                    format!(
                        "`{}` is an action, not a property: a condition cannot run it",
                        field.name
                    ),
                )
                .with_label("an action")
                .with_help(format!(
                    "conditions read properties ({})",
                    list(
                        &profile
                            .properties
                            .keys()
                            .map(String::as_str)
                            .collect::<Vec<_>>()
                    )
                ))
            } else {
                let mut d = Diagnostic::error(
                    "eamos::unknown-property",
                    field.span,
                    format!(
                        "drone type `{}` has no property `{}`",
                        drone.profile_name, field.name
                    ),
                )
                .with_label("unknown property");
                d.help = Some(did_you_mean(
                    &field.name,
                    profile.properties.keys().map(String::as_str),
                    || offers(drone.profile_name, profile.properties.keys()),
                ));
                d
            };
            self.emit(d);
            return None;
        };
        let what = format!("`{drone_name}.{}`", field.name);
        if !self.check_count(&|| what.clone(), &sig.params, args) {
            return None;
        }
        let mut drone_args = Vec::new();
        for (arg, param) in args.items.iter().zip(&sig.params) {
            if param.kind != ParamKind::Drone {
                self.emit(
                    Diagnostic::error(
                        "eamos::unsupported",
                        arg.span,
                        format!(
                            "property parameters of kind {} are not supported in conditions",
                            kind_name(param.kind)
                        ),
                    )
                    .with_label("cannot be passed"),
                );
                return None;
            }
            let Some(name) = arg.as_name() else {
                self.emit(
                    Diagnostic::error(
                        "eamos::arg-kind",
                        arg.span,
                        format!(
                            "argument `{}` of {what} is a drone: pass a drone's name",
                            param.name
                        ),
                    )
                    .with_label("expected a drone name"),
                );
                return None;
            };
            let ident = ast::Ident {
                name: name.to_string(),
                span: arg.span,
            };
            let other = self.resolve_drone(&ident, env)?;
            // In the check pass a drone parameter is "some drone" (no id):
            // only the same name is surely the same drone there; the
            // expansion knows which drone each argument is.
            let same = other.id == drone.id
                && (self.mode == Mode::Expand || other.id != UNKNOWN_DRONE || name == drone_name);
            if same {
                let d = Diagnostic::error(
                    "eamos::same-drone",
                    arg.span,
                    match self.drones.get(drone.id.0 as usize) {
                        Some(decl) if name != drone_name => format!(
                            "{what} relates a drone to itself: `{drone_name}` and `{name}` are both `{}` here",
                            decl.name.name
                        ),
                        _ => format!("{what} relates `{drone_name}` to itself"),
                    },
                )
                .with_label("the same drone")
                .with_help(format!(
                    "name another drone: measured against itself, `{}` never changes \
                     (a drone's distance to itself is always 0)",
                    field.name
                ));
                self.emit_value(d, ctx);
                return None;
            }
            drone_args.push(other.id);
        }
        if self.mode == Mode::Expand {
            self.used_drones.insert(drone.id);
            self.used_drones.extend(drone_args.iter().copied());
        }
        let ty = match sig.ty {
            ValueType::Number => Ty::Number,
            ValueType::Bool => Ty::Bool,
        };
        Some(Low {
            expr: hir::Expr::Property {
                drone: drone.id,
                name: field.name.clone(),
                args: drone_args,
                span,
            },
            ty,
            konst: Konst::No,
        })
    }
}
