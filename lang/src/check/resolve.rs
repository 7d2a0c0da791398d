//! Declarations and names: drones, constants and functions enter one
//! namespace (a reserved or doubly declared name is refused where it is
//! declared), parameter and drone types are looked up in the profiles, and
//! a name used as a drone or a block is resolved against the declarations
//! and the parameters in scope.

use std::collections::HashMap;

use eamos_profile::Profile;

use super::state::{
    list, Binding, Checker, ConstState, DroneDecl, DroneRef, Env, FuncInfo, Global, ParamTy,
    NUMERIC_TYPES, UNKNOWN_DRONE,
};
use crate::ast::{self, ControlKind};
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir::DroneId;
use crate::span::Span;

impl<'a> Checker<'a> {
    pub(super) fn declare_global(&mut self, ident: &'a ast::Ident, kind: Global) -> bool {
        if let Some(reason) = reserved(&ident.name) {
            self.emit(
                Diagnostic::error(
                    "eamos::reserved-name",
                    ident.span,
                    format!("`{}` cannot be declared: {reason}", ident.name),
                )
                .with_label("reserved name")
                .with_help("choose another name"),
            );
            return false;
        }
        if let Some((_, first)) = self.globals.get(ident.name.as_str()) {
            let first = *first;
            self.emit(
                Diagnostic::error(
                    "eamos::duplicate",
                    ident.span,
                    format!(
                        "`{}` is declared twice (first at {})",
                        ident.name,
                        self.loc(first)
                    ),
                )
                .with_label("declared again here")
                .with_note_at(first, "first declared here")
                .with_help("drones, constants and functions share one namespace; rename one"),
            );
            return false;
        }
        self.globals.insert(&ident.name, (kind, ident.span));
        true
    }

    pub(super) fn declare(&mut self) {
        let file = self.file;
        for decl in &file.decls {
            match decl {
                ast::Decl::Var(v) => {
                    for spec in &v.specs {
                        for name in &spec.names {
                            if !self.declare_global(name, Global::Drone) {
                                continue;
                            }
                            let profile = self.drone_type(&spec.ty);
                            self.add_drone(DroneDecl {
                                name,
                                ty: &spec.ty,
                                profile,
                            });
                        }
                    }
                }
                ast::Decl::Const(c) => {
                    for spec in &c.specs {
                        if self.declare_global(&spec.name, Global::Const) {
                            self.consts
                                .insert(&spec.name.name, ConstState::Pending(spec));
                        }
                    }
                }
                ast::Decl::Func(f) => {
                    if !self.declare_global(&f.name, Global::Func) {
                        continue;
                    }
                    let params = self.params(f);
                    self.funcs
                        .insert(&f.name.name, FuncInfo { decl: f, params });
                    self.func_order.push(&f.name.name);
                }
                ast::Decl::Error(_) => {}
            }
        }
        if self.drones.len() > u16::MAX as usize {
            let span = self.drones[u16::MAX as usize].name.span;
            self.emit(Diagnostic::error(
                "eamos::too-many-drones",
                span,
                format!("a mission has at most {} drones", u16::MAX),
            ));
            self.drones.truncate(u16::MAX as usize);
        }
    }

    pub(super) fn drone_type(&mut self, ty: &'a ast::Ident) -> Option<&'a Profile> {
        if let Some(p) = self.profiles.get(&ty.name) {
            return Some(p);
        }
        let known: Vec<&str> = self.profiles.names().collect();
        let mut d = if NUMERIC_TYPES.contains(&ty.name.as_str()) || ty.name == "bool" {
            Diagnostic::error(
                "eamos::unknown-profile",
                ty.span,
                format!(
                    "`var` declares a drone, and `{}` is not a drone type",
                    ty.name
                ),
            )
            .with_label("expected a capability profile")
            .with_help("for a number, declare a constant: `const Side = 2.5`")
        } else {
            Diagnostic::error(
                "eamos::unknown-profile",
                ty.span,
                format!("unknown drone type `{}`", ty.name),
            )
            .with_label("no capability profile of this name")
        };
        if d.help.is_none() {
            d.help = Some(did_you_mean(&ty.name, known.iter().copied(), || {
                format!("known drone types: {}", list(&known))
            }));
        }
        self.emit(d);
        None
    }

    pub(super) fn params(&mut self, f: &'a ast::FuncDecl) -> Vec<(&'a ast::Param, ParamTy<'a>)> {
        let mut out = Vec::new();
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for p in &f.params {
            if let Some(first) = seen.get(p.name.name.as_str()) {
                let first = *first;
                self.emit(
                    Diagnostic::error(
                        "eamos::duplicate",
                        p.name.span,
                        format!(
                            "parameter `{}` of `{}` is declared twice",
                            p.name.name, f.name.name
                        ),
                    )
                    .with_label("declared again here")
                    .with_note_at(first, "first declared here"),
                );
            } else {
                seen.insert(&p.name.name, p.name.span);
            }
            let ty = match &p.ty {
                None => ParamTy::Bad,
                Some(t) => self.param_type(t),
            };
            out.push((p, ty));
        }
        out
    }

    pub(super) fn param_type(&mut self, t: &'a ast::Ident) -> ParamTy<'a> {
        if let Some(p) = self.profiles.get(&t.name) {
            return ParamTy::Drone(Some(p));
        }
        if NUMERIC_TYPES.contains(&t.name.as_str()) {
            return ParamTy::Number {
                integer: !t.name.starts_with("float"),
            };
        }
        let mut candidates: Vec<&str> = self.profiles.names().collect();
        candidates.extend(["float64", "int"]);
        let mut d = Diagnostic::error(
            "eamos::unknown-type",
            t.span,
            format!("unknown parameter type `{}`", t.name),
        )
        .with_label("expected a drone type or a number type");
        d.help = Some(did_you_mean(&t.name, candidates.iter().copied(), || {
            format!(
                "a parameter is a drone ({}) or a number (`float64`, `int`)",
                list(&self.profiles.names().collect::<Vec<_>>())
            )
        }));
        self.emit(d);
        ParamTy::Bad
    }

    /// A drone named in an action, a property or an argument: a drone
    /// parameter or a declared drone.
    pub(super) fn resolve_drone(
        &mut self,
        name: &ast::Ident,
        env: &Env<'a>,
    ) -> Option<DroneRef<'a>> {
        match env.get(&name.name) {
            Some(Binding::Drone { id, profile }) => {
                return Some(DroneRef {
                    id: id.unwrap_or(UNKNOWN_DRONE),
                    profile: *profile,
                    profile_name: profile.map_or("", |p| p.name.as_str()),
                })
            }
            Some(Binding::Number { .. }) => {
                self.emit(
                    Diagnostic::error(
                        "eamos::not-a-drone",
                        name.span,
                        format!("`{}` is a number parameter, not a drone", name.name),
                    )
                    .with_label("expected a drone"),
                );
                return None;
            }
            Some(Binding::Poisoned) => return None,
            None => {}
        }
        if let Some(i) = self.drone_named(&name.name) {
            let d = &self.drones[i];
            return Some(DroneRef {
                id: DroneId(i as u16),
                profile: d.profile,
                profile_name: &d.ty.name,
            });
        }
        let kind = match self.globals.get(name.name.as_str()) {
            Some((Global::Const, _)) => Some("a constant"),
            Some((Global::Func, _)) => Some("a block"),
            _ => None,
        };
        let d = match kind {
            Some(kind) => Diagnostic::error(
                "eamos::not-a-drone",
                name.span,
                format!("`{}` is {kind}, not a drone", name.name),
            )
            .with_label("expected a drone"),
            None => {
                let mut candidates: Vec<&str> =
                    self.drones.iter().map(|d| d.name.name.as_str()).collect();
                candidates.extend(
                    env.params
                        .iter()
                        .filter(|(_, b)| matches!(b, Binding::Drone { .. }))
                        .map(|(n, _)| n.as_str()),
                );
                let mut d = Diagnostic::error(
                    "eamos::unknown-drone",
                    name.span,
                    format!("unknown drone `{}`", name.name),
                )
                .with_label("not declared");
                let example = self.profiles.names().next().unwrap_or("DroneType");
                d.help = Some(did_you_mean(&name.name, candidates.iter().copied(), || {
                    format!("declare it: `var {} {example}`", name.name)
                }));
                d
            }
        };
        self.emit(d);
        None
    }

    pub(super) fn unknown_block(&mut self, name: &ast::Ident, env: &Env<'a>) {
        if matches!(env.get(&name.name), Some(Binding::Poisoned)) {
            return;
        }
        let is_drone = self.drone_named(&name.name).is_some()
            || matches!(env.get(&name.name), Some(Binding::Drone { .. }));
        let d = if is_drone {
            Diagnostic::error(
                "eamos::not-a-block",
                name.span,
                format!("`{}` is a drone, not a block", name.name),
            )
            .with_label("cannot be run")
            .with_help(format!(
                "call one of its actions, such as `{}.Land()`",
                name.name
            ))
        } else if self.consts.contains_key(name.name.as_str()) || env.get(&name.name).is_some() {
            Diagnostic::error(
                "eamos::not-a-block",
                name.span,
                format!("`{}` is a number, not a block", name.name),
            )
            .with_label("cannot be run")
        } else {
            let mut candidates: Vec<&str> = self.funcs.keys().copied().collect();
            candidates.extend(ControlKind::ALL.iter().map(|k| k.name()));
            candidates.extend(["Signal", "Await"]);
            let mut d = Diagnostic::error(
                "eamos::unknown-function",
                name.span,
                format!("unknown block `{}`", name.name),
            )
            .with_label("no function of this name");
            d.help = Some(did_you_mean(&name.name, candidates.iter().copied(), || {
                format!("declare it: `func {}() {{ ... }}`", name.name)
            }));
            d
        };
        self.emit(d);
    }

    pub(super) fn drone_profile_of(&self, name: &str, env: &Env<'a>) -> Option<&'a Profile> {
        match env.get(name) {
            Some(Binding::Drone { profile, .. }) => *profile,
            Some(_) => None,
            None => self
                .drones
                .iter()
                .find(|d| d.name.name == name)
                .and_then(|d| d.profile),
        }
    }
}

fn reserved(name: &str) -> Option<String> {
    if let Some(k) = ControlKind::from_name(name) {
        return Some(format!("`{}` is a control structure", k.name()));
    }
    match name {
        "Signal" | "Await" => Some(format!("`{name}` synchronises branches")),
        "true" | "false" => Some(format!("`{name}` is a boolean value")),
        "_" => Some("`_` is not a name".into()),
        // The slicer and the executor name the ground station's part so.
        "GCS" => Some("`GCS` is the ground station's name".into()),
        _ => None,
    }
}
