//! Control structures (`If`, the `Wait`, `Repeat`, `Do` and `Pause`
//! families, `RepeatFor`, `PauseFor`): their arity, the blocks they are
//! passed by name, and the counts and durations that must be constants.

use super::state::{count, Checker, Ctx, Env};
use crate::ast::{self, ControlKind, ExprKind};
use crate::diag::Diagnostic;
use crate::hir::{self, CondMode};

impl<'a> Checker<'a> {
    /// A block passed by name to a control structure.
    pub(super) fn block_arg(
        &mut self,
        c: &'a ast::ControlCall,
        arg: &'a ast::Expr,
        env: &Env<'a>,
        ctx: &mut Ctx,
        loop_body: bool,
    ) -> Option<hir::Block> {
        let structure = c.kind.name();
        let name = match &arg.kind {
            ExprKind::Name(n) => n,
            ExprKind::Call { callee, args } => {
                if let ExprKind::Name(n) = &callee.kind {
                    if let Some(info) = self.funcs.get(n.as_str()) {
                        let mut d = Diagnostic::error(
                            "eamos::block-call-as-argument",
                            arg.span,
                            format!("a block passed to `{structure}` is written by name, without parentheses"),
                        )
                        .with_label(format!("this runs `{n}` instead of passing it"))
                        .with_note_at(args.span, "remove these parentheses");
                        d.help = Some(if info.params.is_empty() {
                            format!("write `{n}`: `{structure}` decides when the block runs")
                        } else {
                            format!(
                                "`{n}` takes parameters, so it cannot be passed by name either; wrap the call in a block \
                                 without parameters: `func SEQ_Wrapper() {{ {}(...) }}` and pass `SEQ_Wrapper`",
                                n
                            )
                        });
                        self.emit(d);
                        return None;
                    }
                }
                self.emit(not_a_block(arg, structure));
                return None;
            }
            _ => {
                self.emit(not_a_block(arg, structure));
                return None;
            }
        };
        let ident = ast::Ident {
            name: name.clone(),
            span: arg.span,
        };
        let Some(info) = self.funcs.get(name.as_str()) else {
            self.unknown_block(&ident, env);
            return None;
        };
        let decl = info.decl;
        if !decl.params.is_empty() {
            self.emit(
                Diagnostic::error(
                    "eamos::block-with-params",
                    arg.span,
                    format!("`{name}` takes parameters, so it cannot be passed by name to `{structure}`"),
                )
                .with_label("a block passed by name runs without arguments")
                .with_note_at(decl.params_span, "its parameters")
                .with_help(format!(
                    "wrap the call in a block without parameters: `func SEQ_Wrapper() {{ {name}(...) }}` and pass `SEQ_Wrapper`"
                )),
            );
            return None;
        }
        if name == "INIT" {
            self.emit(
                Diagnostic::error(
                    "eamos::call-entry",
                    arg.span,
                    "`INIT` is the entry point and cannot be run as a block",
                )
                .with_label("passed here"),
            );
            return None;
        }
        let saved = ctx.in_loop;
        if loop_body {
            ctx.in_loop = Some((c.kind, c.span));
        }
        let block = self.expand(decl, &Env::default(), arg.span, ctx);
        ctx.in_loop = saved;
        Some(block)
    }

    pub(super) fn lower_control(
        &mut self,
        c: &'a ast::ControlCall,
        env: &Env<'a>,
        ctx: &mut Ctx,
    ) -> Option<hir::Stmt> {
        use ControlKind as K;
        let (min, max) = match c.kind {
            K::If | K::RepeatWhile | K::RepeatUntil => (2, 3),
            K::WaitWhile | K::WaitUntil | K::RepeatFor | K::DoWhile | K::DoUntil => (2, 2),
            K::PauseWhile | K::PauseUntil | K::PauseFor => (1, 1),
        };
        let n = c.args.items.len();
        if n < min || n > max {
            let expected = if min == max {
                count(min, "argument")
            } else {
                format!("{min} or {max} arguments")
            };
            let span = if n > max {
                c.args.items[max].span.to(c.args.items[n - 1].span)
            } else {
                c.args.span
            };
            self.emit(
                Diagnostic::error(
                    "eamos::arg-count",
                    span,
                    format!("`{}` takes {expected}, found {n}", c.kind.name()),
                )
                .with_label(if n > max {
                    "too many arguments"
                } else {
                    "missing arguments"
                })
                .with_help(format!("usage: {}", c.kind.usage())),
            );
            return None;
        }
        let args = &c.args.items;
        let mode = match c.kind {
            K::WaitWhile | K::RepeatWhile | K::PauseWhile | K::DoWhile => CondMode::While,
            _ => CondMode::Until,
        };
        let span = c.span;
        match c.kind {
            K::If => {
                let cond = self.condition(c, &args[0], env, ctx);
                let then = self.block_arg(c, &args[1], env, ctx, false);
                let otherwise = match args.get(2) {
                    Some(a) => Some(self.block_arg(c, a, env, ctx, false)?),
                    None => None,
                };
                Some(hir::Stmt::If {
                    cond: cond?,
                    then: then?,
                    otherwise,
                    span,
                })
            }
            K::WaitWhile | K::WaitUntil => {
                let cond = self.condition(c, &args[0], env, ctx);
                let body = self.block_arg(c, &args[1], env, ctx, false);
                Some(hir::Stmt::Wait {
                    mode,
                    cond: cond?,
                    body: body?,
                    span,
                })
            }
            K::RepeatWhile | K::RepeatUntil => {
                let cond = self.condition(c, &args[0], env, ctx);
                let body = self.block_arg(c, &args[1], env, ctx, true);
                let exit = match args.get(2) {
                    Some(a) => Some(self.block_arg(c, a, env, ctx, false)?),
                    None => None,
                };
                Some(hir::Stmt::Repeat {
                    mode,
                    cond: cond?,
                    body: body?,
                    exit,
                    span,
                })
            }
            K::DoWhile | K::DoUntil => {
                let cond = self.condition(c, &args[0], env, ctx);
                let body = self.block_arg(c, &args[1], env, ctx, false);
                Some(hir::Stmt::Do {
                    mode,
                    cond: cond?,
                    body: body?,
                    span,
                })
            }
            K::PauseWhile | K::PauseUntil => {
                let cond = self.condition(c, &args[0], env, ctx)?;
                Some(hir::Stmt::Pause { mode, cond, span })
            }
            K::RepeatFor => {
                let n =
                    self.const_number(&args[0], env, ctx, &|| "the count of `RepeatFor`".into());
                let body = self.block_arg(c, &args[1], env, ctx, true);
                let n = n?;
                let count = if n.is_nan() {
                    1
                } else if n < 0.0 || n.fract() != 0.0 || n > u32::MAX as f64 {
                    let d = Diagnostic::error(
                        "eamos::bad-repeat-count",
                        args[0].span,
                        format!(
                            "`RepeatFor` repeats a whole number of times (0 or more), found {n}"
                        ),
                    )
                    .with_label("not a whole number of repetitions");
                    self.emit_value(d, ctx);
                    return None;
                } else {
                    n as u32
                };
                if count == 0 && !n.is_nan() {
                    self.diags.push(
                        Diagnostic::warning(
                            "eamos::zero-repeat",
                            args[0].span,
                            "`RepeatFor(0, ...)` never runs its body",
                        )
                        .with_label("zero repetitions"),
                    );
                }
                Some(hir::Stmt::RepeatFor {
                    count,
                    body: body?,
                    span,
                })
            }
            K::PauseFor => {
                let s =
                    self.const_number(&args[0], env, ctx, &|| "the duration of `PauseFor`".into())?;
                if s < 0.0 {
                    let d = Diagnostic::error(
                        "eamos::negative-pause",
                        args[0].span,
                        format!("`PauseFor` waits a duration in seconds, 0 or more; found {s}"),
                    )
                    .with_label("negative duration");
                    self.emit_value(d, ctx);
                    return None;
                }
                Some(hir::Stmt::PauseFor {
                    seconds: if s.is_nan() { 0.0 } else { s },
                    span,
                })
            }
        }
    }
}

fn not_a_block(arg: &ast::Expr, structure: &str) -> Diagnostic {
    Diagnostic::error(
        "eamos::not-a-block",
        arg.span,
        format!("`{structure}` expects a block here: the name of a function"),
    )
    .with_label("not a block name")
}
