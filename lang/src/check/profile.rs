//! Actions against the capability profiles: the drone's profile must offer
//! the action, with as many arguments as its signature has, each a number
//! known before the flight.

use super::state::{count, kind_name, offers, Checker, Ctx, Env};
use crate::ast;
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir;

impl<'a> Checker<'a> {
    pub(super) fn lower_action(
        &mut self,
        a: &'a ast::ActionCall,
        env: &Env<'a>,
        ctx: &Ctx,
    ) -> Option<hir::Action> {
        let drone = self.resolve_drone(&a.drone, env)?;
        let profile = drone.profile?;
        let Some(sig) = profile.actions.get(&a.action.name) else {
            let d = if profile.properties.contains_key(&a.action.name) {
                Diagnostic::error(
                    "eamos::property-as-action",
                    a.action.span,
                    format!(
                        "`{}` is a property of `{}`, not an action",
                        a.action.name, drone.profile_name
                    ),
                )
                .with_label("a statement cannot only read a property")
                .with_help(format!(
                    "read it in a condition, for example `WaitUntil({}.{}() > 1, SEQ_Next)`",
                    a.drone.name, a.action.name
                ))
            } else {
                let mut d = Diagnostic::error(
                    "eamos::unknown-action",
                    a.action.span,
                    format!(
                        "drone type `{}` has no action `{}`",
                        drone.profile_name, a.action.name
                    ),
                )
                .with_label("unknown action");
                d.help = Some(did_you_mean(
                    &a.action.name,
                    profile.actions.keys().map(String::as_str),
                    || offers(drone.profile_name, profile.actions.keys()),
                ));
                d
            };
            self.emit(d);
            return None;
        };
        let what = || format!("`{}.{}`", a.drone.name, a.action.name);
        if !self.check_count(&what, &sig.params, &a.args) {
            return None;
        }
        let mut args = Vec::new();
        let mut ok = true;
        for (arg, param) in a.args.items.iter().zip(&sig.params) {
            if !param.kind.is_numeric() {
                self.emit(
                    Diagnostic::error(
                        "eamos::unsupported",
                        arg.span,
                        format!(
                            "action parameters that name a drone (`{}`) are not supported",
                            param.name
                        ),
                    )
                    .with_label("cannot be passed"),
                );
                ok = false;
                continue;
            }
            match self.const_number(arg, env, ctx, &|| {
                format!("argument `{}` of {}", param.name, what())
            }) {
                Some(v) => args.push(v),
                None => ok = false,
            }
        }
        if !ok {
            return None;
        }
        self.used_drones.insert(drone.id);
        Some(hir::Action {
            drone: drone.id,
            name: a.action.name.clone(),
            args,
            span: a.span,
        })
    }

    /// Checks the number of arguments against a parameter list.
    pub(super) fn check_count(
        &mut self,
        what: &dyn Fn() -> String,
        params: &[eamos_profile::Param],
        args: &ast::Args,
    ) -> bool {
        if params.len() == args.items.len() {
            return true;
        }
        let described: Vec<String> = params
            .iter()
            .map(|p| format!("{} ({})", p.name, kind_name(p.kind)))
            .collect();
        let expected = match params.len() {
            0 => "no arguments".to_string(),
            1 => format!("1 argument: {}", described[0]),
            n => format!("{n} arguments: {}", described.join(", ")),
        };
        let span = if args.items.len() > params.len() {
            args.items[params.len()]
                .span
                .to(args.items[args.items.len() - 1].span)
        } else {
            args.span
        };
        self.emit(
            Diagnostic::error(
                "eamos::arg-count",
                span,
                format!(
                    "{} takes {expected}; found {}",
                    what(),
                    count(args.items.len(), "argument")
                ),
            )
            .with_label(if args.items.len() > params.len() {
                "too many arguments"
            } else {
                "missing arguments"
            }),
        );
        false
    }
}
