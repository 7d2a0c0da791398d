//! Statements and block instances: the check pass lowers each function
//! body once with stand-in parameters; the expansion lowers it again for
//! every call with the arguments substituted, and stops at a size no
//! mission needs (calls nested in calls multiply).

use super::state::{count, Binding, Checker, Ctx, Env, Mode, ParamTy};
use crate::ast::{self, ExprKind, SyncKind};
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir::{self, BlockKind};
use crate::span::Span;

/// More statements than this after expansion is almost certainly a mistake
/// (calls doubling at every level), and would exhaust memory before it flies.
pub const MAX_EXPANDED_STATEMENTS: usize = 100_000;

/// How deep block calls may nest when expanded: far beyond a real mission,
/// far below what would exhaust a thread's stack.
pub const MAX_CALL_DEPTH: usize = 128;

impl<'a> Checker<'a> {
    pub(super) fn env_for_check(&self, name: &str) -> Env<'a> {
        let info = &self.funcs[name];
        let params = info
            .params
            .iter()
            .map(|(p, ty)| {
                let b = match *ty {
                    ParamTy::Drone(profile) => Binding::Drone { id: None, profile },
                    ParamTy::Number { .. } => Binding::Number { value: None },
                    ParamTy::Bad => Binding::Poisoned,
                };
                (p.name.name.clone(), b)
            })
            .collect();
        Env { params }
    }

    pub(super) fn check_func(&mut self, name: &'a str) {
        let env = self.env_for_check(name);
        let decl = self.funcs[name].decl;
        let mut ctx = Ctx::default();
        for stmt in &decl.body.stmts {
            self.lower_stmt(stmt, &env, &mut ctx);
        }
    }

    /// One instance of a function body: the entry, a block call, or a block
    /// passed to a control structure. `at` is where it was called.
    pub(super) fn expand(
        &mut self,
        decl: &'a ast::FuncDecl,
        env: &Env<'a>,
        at: Span,
        ctx: &mut Ctx,
    ) -> hir::Block {
        let kind = block_kind(&decl.name.name);
        let mut stmts = Vec::new();
        let recursive = ctx.calls.iter().any(|(n, _)| *n == decl.name.name);
        if self.mode == Mode::Expand && ctx.calls.len() >= MAX_CALL_DEPTH && !self.too_large {
            self.too_large = true;
            self.diags.push(
                Diagnostic::error(
                    "eamos::mission-too-large",
                    at,
                    format!("block calls nest more than {MAX_CALL_DEPTH} deep here"),
                )
                .with_label("reached while expanding this call")
                .with_help("flatten the chain of blocks calling blocks"),
            );
        }
        if self.mode == Mode::Expand && !recursive && !self.too_large {
            ctx.calls.push((decl.name.name.clone(), at));
            for stmt in &decl.body.stmts {
                if let Some(s) = self.lower_stmt(stmt, env, ctx) {
                    stmts.push(s);
                }
            }
            ctx.calls.pop();
        }
        hir::Block {
            kind,
            name: decl.name.name.clone(),
            span: at,
            stmts,
        }
    }

    pub(super) fn count_expanded(&mut self, span: Span) -> bool {
        if self.mode != Mode::Expand {
            return true;
        }
        self.expanded += 1;
        if self.expanded > MAX_EXPANDED_STATEMENTS && !self.too_large {
            self.too_large = true;
            self.diags.push(
                Diagnostic::error(
                    "eamos::mission-too-large",
                    span,
                    format!(
                        "the mission expands to more than {MAX_EXPANDED_STATEMENTS} statements"
                    ),
                )
                .with_label("reached while expanding this statement")
                .with_help(
                    "every call is its own copy of the block: calls nested in calls multiply",
                ),
            );
        }
        !self.too_large
    }

    pub(super) fn lower_stmt(
        &mut self,
        stmt: &'a ast::Stmt,
        env: &Env<'a>,
        ctx: &mut Ctx,
    ) -> Option<hir::Stmt> {
        if !self.count_expanded(stmt.span()) {
            return None;
        }
        match stmt {
            ast::Stmt::Error(_) => None,
            ast::Stmt::Action(a) => self.lower_action(a, env, ctx).map(hir::Stmt::Action),
            ast::Stmt::BlockCall(b) => self.lower_block_call(b, env, ctx),
            ast::Stmt::Control(c) => self.lower_control(c, env, ctx),
            ast::Stmt::Sync(s) => self.lower_sync(s, ctx),
        }
    }

    pub(super) fn lower_sync(&mut self, s: &'a ast::SyncCall, ctx: &Ctx) -> Option<hir::Stmt> {
        let what = match s.kind {
            SyncKind::Signal => "Signal",
            SyncKind::Await => "Await",
        };
        let event = match s.args.items.as_slice() {
            [ast::Expr {
                kind: ExprKind::Str(name),
                span,
            }] => {
                if name.trim().is_empty() {
                    self.emit(
                        Diagnostic::error(
                            "eamos::arg-kind",
                            *span,
                            "an event name cannot be empty",
                        )
                        .with_label("empty name")
                        .with_help(format!("name the event: `{what}(\"ready\")`")),
                    );
                    return None;
                }
                name.clone()
            }
            [other] => {
                self.emit(
                    Diagnostic::error(
                        "eamos::arg-kind",
                        other.span,
                        format!("`{what}` takes the event's name as a string"),
                    )
                    .with_label("expected a string such as \"ready\"")
                    .with_help(format!("write `{what}(\"ready\")`")),
                );
                return None;
            }
            items => {
                self.emit(
                    Diagnostic::error(
                        "eamos::arg-count",
                        s.args.span,
                        format!("`{what}` takes 1 argument, found {}", items.len()),
                    )
                    .with_label("expected one event name")
                    .with_help(format!("write `{what}(\"ready\")`")),
                );
                return None;
            }
        };
        match s.kind {
            SyncKind::Signal => {
                if let Some((kind, loop_span)) = ctx.in_loop {
                    let d = Diagnostic::error(
                        "eamos::signal-in-loop",
                        s.span,
                        format!(
                            "`Signal(\"{event}\")` runs inside the body of `{}`",
                            kind.name()
                        ),
                    )
                    .with_label("would signal once per repetition")
                    .with_note_at(loop_span, "the loop")
                    .with_help(
                        "an event happens once for the mission; move the Signal out of the loop",
                    );
                    self.emit_value(d, ctx);
                    return None;
                }
                Some(hir::Stmt::Signal {
                    event,
                    span: s.span,
                })
            }
            SyncKind::Await => {
                if !self.signalled.contains(&event) {
                    let mut d = Diagnostic::error(
                        "eamos::unknown-event",
                        s.args.items[0].span,
                        format!("no `Signal(\"{event}\")` in the mission: this `Await` would wait forever"),
                    )
                    .with_label("never signalled");
                    d.help = Some(did_you_mean(
                        &event,
                        self.signalled.iter().map(String::as_str),
                        || format!("add `Signal(\"{event}\")` in the branch this one waits for"),
                    ));
                    self.emit(d);
                    return None;
                }
                Some(hir::Stmt::Await {
                    event,
                    span: s.span,
                })
            }
        }
    }

    pub(super) fn lower_block_call(
        &mut self,
        b: &'a ast::BlockCall,
        env: &Env<'a>,
        ctx: &mut Ctx,
    ) -> Option<hir::Stmt> {
        if b.name.name == "INIT" && self.funcs.contains_key("INIT") {
            self.emit(
                Diagnostic::error(
                    "eamos::call-entry",
                    b.name.span,
                    "`INIT` is the entry point and cannot be called",
                )
                .with_label("called here")
                .with_help("move what both need into a block of its own and call that"),
            );
            return None;
        }
        let Some(info) = self.funcs.get(b.name.name.as_str()) else {
            self.unknown_block(&b.name, env);
            return None;
        };
        let decl = info.decl;
        let params = info.params.clone();
        if params.len() != b.args.items.len() {
            let described: Vec<String> = params
                .iter()
                .map(|(p, _)| match &p.ty {
                    Some(t) => format!("{} {}", p.name.name, t.name),
                    None => p.name.name.clone(),
                })
                .collect();
            let span = if b.args.items.len() > params.len() {
                b.args.items[params.len()]
                    .span
                    .to(b.args.items[b.args.items.len() - 1].span)
            } else {
                b.args.span
            };
            self.emit(
                Diagnostic::error(
                    "eamos::arg-count",
                    span,
                    format!(
                        "`{}` takes {}; found {}",
                        b.name.name,
                        if params.is_empty() {
                            "no arguments".to_string()
                        } else {
                            format!(
                                "{} ({})",
                                count(params.len(), "argument"),
                                described.join(", ")
                            )
                        },
                        count(b.args.items.len(), "argument")
                    ),
                )
                .with_label(if b.args.items.len() > params.len() {
                    "too many arguments"
                } else {
                    "missing arguments"
                })
                .with_note_at(decl.params_span, "parameters declared here"),
            );
            return None;
        }
        let mut inner = Env::default();
        let mut ok = true;
        for (arg, (param, ty)) in b.args.items.iter().zip(&params) {
            match *ty {
                ParamTy::Bad => ok = false,
                ParamTy::Drone(profile) => {
                    let Some(name) = arg.as_name() else {
                        self.emit(
                            Diagnostic::error(
                                "eamos::arg-kind",
                                arg.span,
                                format!(
                                    "parameter `{}` of `{}` is a drone: pass a drone's name",
                                    param.name.name, b.name.name
                                ),
                            )
                            .with_label("expected a drone name")
                            .with_note_at(param.span, "declared here"),
                        );
                        ok = false;
                        continue;
                    };
                    let ident = ast::Ident {
                        name: name.to_string(),
                        span: arg.span,
                    };
                    let Some(d) = self.resolve_drone(&ident, env) else {
                        ok = false;
                        continue;
                    };
                    if let (Some(want), Some(got)) = (profile, d.profile) {
                        if want.name != got.name {
                            self.emit(
                                Diagnostic::error(
                                    "eamos::arg-kind",
                                    arg.span,
                                    format!(
                                        "parameter `{}` is a `{}`, but `{name}` is a `{}`",
                                        param.name.name, want.name, got.name
                                    ),
                                )
                                .with_label("wrong drone type")
                                .with_note_at(param.span, "declared here"),
                            );
                            ok = false;
                            continue;
                        }
                    }
                    let id = (self.mode == Mode::Expand).then_some(d.id);
                    inner.params.push((
                        param.name.name.clone(),
                        Binding::Drone {
                            id,
                            profile: d.profile,
                        },
                    ));
                }
                ParamTy::Number { integer } => {
                    let what = || format!("argument `{}` of `{}`", param.name.name, b.name.name);
                    if let Some(n) = arg.as_name() {
                        let is_drone = matches!(env.get(n), Some(Binding::Drone { .. }))
                            || (env.get(n).is_none() && self.drone_named(n).is_some());
                        if is_drone {
                            self.emit(
                                Diagnostic::error(
                                    "eamos::arg-kind",
                                    arg.span,
                                    format!("{} is a number, but `{n}` is a drone", what()),
                                )
                                .with_label("expected a number")
                                .with_note_at(param.span, "declared here"),
                            );
                            ok = false;
                            continue;
                        }
                    }
                    let Some(v) = self.const_number(arg, env, ctx, &what) else {
                        ok = false;
                        continue;
                    };
                    if integer && v.is_finite() && v.fract() != 0.0 {
                        let d = Diagnostic::error(
                            "eamos::arg-kind",
                            arg.span,
                            format!("{} must be a whole number, found {v}", what()),
                        )
                        .with_label("not a whole number")
                        .with_note_at(param.span, "declared here");
                        self.emit_value(d, ctx);
                        ok = false;
                        continue;
                    }
                    let value = (self.mode == Mode::Expand && v.is_finite()).then_some(v);
                    inner
                        .params
                        .push((param.name.name.clone(), Binding::Number { value }));
                }
            }
        }
        if !ok {
            return None;
        }
        Some(hir::Stmt::Block(self.expand(decl, &inner, b.span, ctx)))
    }
}

fn block_kind(name: &str) -> BlockKind {
    if name.starts_with("PAR_") {
        BlockKind::Par
    } else {
        BlockKind::Seq
    }
}
