//! From tokens to the syntax tree, with syntax errors worded for people.
//!
//! The lalrpop grammar (`grammar.lalrpop`) and its generated types stay
//! behind this module: the rest of the crate sees [`parse`] and the
//! [`crate::ast`] types only. lalrpop reports an error as a token and the
//! list of terminals it expected; this module turns that into a Go-like
//! message ("expected `,` or `)` to close the call of `RepeatWhile` opened at
//! 12:5, found newline"), using the token stream to find which bracket is
//! still open, and drops the cascade of errors that follows a declaration
//! the parser could not read.

use std::convert::Infallible;

use lalrpop_util::{lalrpop_mod, ErrorRecovery, ParseError};

use crate::ast::{
    ActionCall, BinaryOp, BlockCall, ControlCall, ControlKind, Expr, ExprKind, File, Ident, Param,
    Stmt, SyncCall, SyncKind, UnaryOp,
};
use crate::diag::Diagnostic;
use crate::lexer::{lex, Spanned, Tok};
use crate::span::{SourceFile, Span};

lalrpop_mod!(
    #[allow(
        clippy::all,
        clippy::pedantic,
        unused_qualifications,
        unused_parens,
        dead_code
    )]
    grammar,
    "/grammar.rs"
);

/// Where the parser recovered from an error: inside a function body (the
/// statement is dropped) or at the top level (the declaration is dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Level {
    Stmt,
    Decl,
}

/// A parameter as written, before Go's `a, b float64` grouping is applied.
pub(crate) struct ParamItem {
    pub name: Ident,
    pub ty: Option<Ident>,
}

type Recovered = (Level, ErrorRecovery<usize, Tok, Infallible>);

/// Parses a mission file. The tree is always returned (parts that could not
/// be read are `Error` nodes) together with every lexical and syntax error,
/// in source order.
pub fn parse(file: &SourceFile) -> (File, Vec<Diagnostic>) {
    let lexed = lex(&file.text);
    let mut diags = lexed.diagnostics;
    let tokens = lexed.tokens;
    if let Some(d) = too_deep(&tokens) {
        // The tree of such a statement would be deep enough to exhaust the
        // stack of every later pass; it is refused before it is built.
        diags.push(d);
        let empty = File {
            package: None,
            decls: Vec::new(),
            span: Span::new(0, file.text.len()),
        };
        return (empty, diags);
    }
    let mut recovered: Vec<Recovered> = Vec::new();
    let mut shape_diags = Vec::new();
    let result = grammar::FileParser::new().parse(
        &mut recovered,
        &mut shape_diags,
        tokens.iter().cloned().map(Ok::<Spanned, Infallible>),
    );
    let ctx = Context {
        file,
        tokens: &tokens,
    };
    let mut errors: Vec<(Level, ParseError<usize, Tok, Infallible>)> = recovered
        .into_iter()
        .map(|(lvl, r)| (lvl, r.error))
        .collect();
    let ast = match result {
        Ok(ast) => ast,
        Err(e) => {
            errors.push((Level::Decl, e));
            File {
                package: None,
                decls: Vec::new(),
                span: Span::new(0, file.text.len()),
            }
        }
    };
    let mut syntax = ctx.filter_cascades(errors);
    // A comment or raw string left open runs to the end of the file: what
    // the parser says about the end of the file is only an echo of it.
    if let Some(open) = diags
        .iter()
        .filter(|d| {
            d.code == "eamos::unterminated-comment" || d.span.end as usize == file.text.len()
        })
        .filter(|d| d.code.starts_with("eamos::unterminated"))
        .map(|d| d.span.start)
        .min()
    {
        syntax.retain(|d| d.span.start < open);
    }
    diags.extend(syntax);
    diags.extend(shape_diags);
    if ast.package.is_none() && !matches!(tokens.first(), Some((_, Tok::Package, _))) {
        let at = tokens
            .first()
            .map_or(Span::new(0, 0), |(l, _, r)| Span::new(*l, *r));
        diags.push(
            Diagnostic::error(
                "eamos::missing-package",
                at,
                "a mission file starts with `package Name`",
            )
            .with_label("expected `package` before this")
            .with_help("the package name is the mission's name: `package SquareFlight`"),
        );
    }
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    (ast, diags)
}

/// How many operators and open brackets one statement may hold. Far beyond
/// any real condition, far below what would exhaust a thread's stack.
pub const MAX_STATEMENT_OPERATORS: usize = 256;

/// A statement or declaration with more operators or brackets than
/// [`MAX_STATEMENT_OPERATORS`], if any.
fn too_deep(tokens: &[Spanned]) -> Option<Diagnostic> {
    let mut count = 0usize;
    let mut start = 0usize;
    for (l, t, r) in tokens {
        match t {
            Tok::Semi { .. } | Tok::LBrace | Tok::RBrace => count = 0,
            Tok::LParen
            | Tok::OrOr
            | Tok::AndAnd
            | Tok::Not
            | Tok::EqEq
            | Tok::NotEq
            | Tok::Lt
            | Tok::Le
            | Tok::Gt
            | Tok::Ge
            | Tok::Plus
            | Tok::Minus
            | Tok::Star
            | Tok::Slash
            | Tok::Dot => {
                if count == 0 {
                    start = *l;
                }
                count += 1;
                if count > MAX_STATEMENT_OPERATORS {
                    return Some(
                        Diagnostic::error(
                            "eamos::too-complex",
                            Span::new(start, *r),
                            format!(
                                "this statement holds more than {MAX_STATEMENT_OPERATORS} operators and brackets"
                            ),
                        )
                        .with_label("too long to check")
                        .with_help("split the expression with constants or into several statements"),
                    );
                }
            }
            _ => {}
        }
    }
    None
}

struct Context<'a> {
    file: &'a SourceFile,
    tokens: &'a [Spanned],
}

impl Context<'_> {
    /// Turns parse errors into diagnostics, dropping those that only follow
    /// from an earlier one: after a declaration that could not be read, the
    /// rest of it (its body, its closing brace) would be reported line by
    /// line, so everything up to the next declaration keyword at the start of
    /// a line is skipped.
    fn filter_cascades(
        &self,
        mut errors: Vec<(Level, ParseError<usize, Tok, Infallible>)>,
    ) -> Vec<Diagnostic> {
        errors.sort_by_key(|(_, e)| error_span(e, self.file.text.len()).start);
        let decl_starts: Vec<usize> = self
            .tokens
            .iter()
            .enumerate()
            .filter(|(i, (_, t, _))| {
                matches!(t, Tok::Func | Tok::Var | Tok::Const | Tok::Package)
                    && (*i == 0 || matches!(self.tokens[i - 1].1, Tok::Semi { .. }))
            })
            .map(|(_, (l, _, _))| *l)
            .collect();
        let mut out: Vec<Diagnostic> = Vec::new();
        let mut skip_until = 0usize;
        let mut last_at = None;
        for (level, e) in errors {
            let at = error_span(&e, self.file.text.len()).start as usize;
            if at < skip_until || last_at == Some(at) {
                continue;
            }
            last_at = Some(at);
            if level == Level::Decl {
                skip_until = decl_starts
                    .iter()
                    .copied()
                    .find(|&s| s > at)
                    .unwrap_or(usize::MAX);
            } else if let Some(end) = self.unclosed_call_end(self.token_index(error_span(&e, 0))) {
                skip_until = skip_until.max(end);
            }
            out.push(self.describe(e));
        }
        out
    }

    fn describe(&self, e: ParseError<usize, Tok, Infallible>) -> Diagnostic {
        match e {
            ParseError::UnrecognizedToken {
                token: (l, tok, r),
                expected,
            } => self.unexpected(Span::new(l, r), Some(&tok), &expected),
            ParseError::UnrecognizedEof { location, expected } => {
                self.unexpected(Span::new(location, location), None, &expected)
            }
            ParseError::ExtraToken { token: (l, tok, r) } => Diagnostic::error(
                "eamos::syntax",
                Span::new(l, r),
                format!("unexpected {tok} after the last declaration"),
            )
            .with_label("unexpected"),
            ParseError::InvalidToken { location } => Diagnostic::error(
                "eamos::syntax",
                Span::new(location, location),
                "invalid token",
            )
            .with_label("here"),
            ParseError::User { error } => match error {},
        }
    }

    fn unexpected(&self, span: Span, found: Option<&Tok>, expected: &[String]) -> Diagnostic {
        let found_text = found.map_or("end of file".to_string(), |t| t.to_string());
        let expected: Vec<String> = expected
            .iter()
            .map(|e| e.trim_matches('"').to_string())
            .collect();
        let has = |t: &str| expected.iter().any(|e| e == t);
        // After a complete operand, every binary operator, `.` and `(` could
        // follow: listing them says nothing, so they are left out whenever a
        // closing token is possible too. Likewise the tokens that can start
        // an operand are said as "an expression".
        const CONTINUATIONS: &[&str] = &[
            "||", "&&", "==", "!=", "<", "<=", ">", ">=", "+", "-", "*", "/", ".", "(",
        ];
        const OPERAND_STARTS: &[&str] = &["name", "number", "string", "(", "!", "+", "-"];
        let closing = has(")") || has(",") || has("}") || has(";");
        let expr_start = has("name") && has("number");
        let mut names: Vec<String> = Vec::new();
        let stmt_start = expr_start && has("}") && has(";");
        if stmt_start {
            names.push("a statement".into());
        } else if expr_start {
            names.push("an expression".into());
        }
        for e in &expected {
            let noise = (closing && !expr_start && CONTINUATIONS.contains(&e.as_str()))
                || (expr_start && OPERAND_STARTS.contains(&e.as_str()))
                || (stmt_start && e == ";");
            if !noise {
                names.push(friendly(e));
            }
        }
        let list = join_or(&names);
        let token_index = self.token_index(span);
        let open = self.open_bracket(token_index);
        let after_operand = token_index
            .checked_sub(1)
            .and_then(|i| self.tokens.get(i))
            .is_some_and(|(_, t, _)| {
                matches!(
                    t,
                    Tok::Ident(_) | Tok::Number(_) | Tok::Str(_) | Tok::RParen | Tok::RBrace
                )
            });
        let starts_decl = matches!(
            found,
            None | Some(Tok::Func | Tok::Var | Tok::Const | Tok::Package)
        );
        let opened = |k: usize| {
            let (l, _, r) = &self.tokens[k];
            let at = self.file.line_col(*l as u32);
            (Span::new(*l, *r), format!("{}:{}", at.line, at.col))
        };
        let mut d = match open {
            Some((k, Tok::LBrace)) if starts_decl && has("}") => {
                let (open_span, at) = opened(k);
                Diagnostic::error(
                    "eamos::syntax",
                    span,
                    format!(
                        "expected `}}` to close {} opened at {at}, found {found_text}",
                        self.brace_owner(k)
                    ),
                )
                .with_label(format!("found {found_text}"))
                .with_note_at(open_span, "opened here")
            }
            Some((k, Tok::LParen)) if has(")") && (found.is_none() || !expr_start) => {
                let (open_span, at) = opened(k);
                let wanted = if found.is_none() {
                    "`)`".to_string()
                } else {
                    list.clone()
                };
                let mut d = Diagnostic::error(
                    "eamos::syntax",
                    span,
                    format!(
                        "expected {wanted} to close {} opened at {at}, found {found_text}",
                        self.paren_owner(k)
                    ),
                )
                .with_label(format!("found {found_text}"))
                .with_note_at(open_span, "opened here");
                if matches!(found, Some(Tok::Semi { auto: true })) {
                    d = d.with_help(
                        "a line inside a call must end with `,` or an operator such as `&&`; \
                         otherwise Go ends the statement there",
                    );
                }
                d
            }
            _ if has(";") && after_operand && found.is_some() => Diagnostic::error(
                "eamos::syntax",
                span,
                format!("unexpected {found_text} at the end of a statement"),
            )
            .with_label(format!(
                "expected a newline before this; found {found_text}"
            ))
            .with_help("put each statement or declaration on its own line"),
            _ => {
                let message = if list.is_empty() {
                    format!("unexpected {found_text}")
                } else {
                    format!("unexpected {found_text}, expected {list}")
                };
                let label = if list.is_empty() {
                    "unexpected here".to_string()
                } else {
                    format!("expected {list}")
                };
                let mut d = Diagnostic::error("eamos::syntax", span, message).with_label(label);
                if has("{") && matches!(found, Some(Tok::Semi { auto: true })) {
                    d = d.with_help(
                        "put the opening brace `{` on the same line as `func`: Go ends the line \
                         before it with a `;`",
                    );
                }
                if let Some((k, Tok::LParen)) = open {
                    let (open_span, _) = opened(k);
                    d = d.with_note_at(open_span, format!("in {}", self.paren_owner(k)));
                }
                d
            }
        };
        if let Some(help) = found.and_then(unsupported_help) {
            d = d.with_help(help);
        }
        d
    }

    /// When an error is a newline inside a call whose `)` comes on a later
    /// line (a condition broken before `&&`), the end of that `)`: the lines
    /// up to it belong to the same broken call.
    fn unclosed_call_end(&self, error_index: usize) -> Option<usize> {
        if !matches!(
            self.tokens.get(error_index),
            Some((_, Tok::Semi { auto: true }, _))
        ) {
            return None;
        }
        if !matches!(self.open_bracket(error_index), Some((_, Tok::LParen))) {
            return None;
        }
        let mut depth = 0usize;
        for (_, t, r) in &self.tokens[error_index..] {
            match t {
                Tok::LParen | Tok::LBrace | Tok::LBracket => depth += 1,
                Tok::RParen if depth == 0 => return Some(*r),
                Tok::RBrace | Tok::RBracket if depth == 0 => return None,
                Tok::RParen | Tok::RBrace | Tok::RBracket => depth -= 1,
                Tok::Func | Tok::Var | Tok::Const | Tok::Package if depth == 0 => return None,
                _ => {}
            }
        }
        None
    }

    /// The index of the token an error points at.
    fn token_index(&self, span: Span) -> usize {
        self.tokens
            .iter()
            .position(|(l, _, r)| *l == span.start as usize && *r == span.end as usize)
            .unwrap_or(self.tokens.len())
    }

    /// The innermost bracket still open before token `upto`.
    fn open_bracket(&self, upto: usize) -> Option<(usize, Tok)> {
        let mut stack: Vec<usize> = Vec::new();
        for (i, (_, t, _)) in self.tokens[..upto.min(self.tokens.len())]
            .iter()
            .enumerate()
        {
            match t {
                Tok::LParen | Tok::LBrace | Tok::LBracket => stack.push(i),
                Tok::RParen | Tok::RBrace | Tok::RBracket => {
                    stack.pop();
                }
                _ => {}
            }
        }
        stack.last().map(|&i| (i, self.tokens[i].1.clone()))
    }

    /// "the call of `Drone1.FlyByX`", "the parameter list of `SEQ_A`"...
    fn paren_owner(&self, k: usize) -> String {
        let tok = |i: usize| self.tokens.get(i).map(|t| &t.1);
        match k.checked_sub(1).and_then(tok) {
            Some(Tok::Ident(name)) => {
                let before = k.checked_sub(2).and_then(tok);
                match before {
                    Some(Tok::Func) => format!("the parameter list of `{name}`"),
                    Some(Tok::Dot) => match k.checked_sub(3).and_then(tok) {
                        Some(Tok::Ident(recv)) => format!("the call of `{recv}.{name}`"),
                        _ => format!("the call of `{name}`"),
                    },
                    _ => format!("the call of `{name}`"),
                }
            }
            Some(Tok::Const) => "the `const` group".into(),
            Some(Tok::Var) => "the `var` group".into(),
            _ => "the parenthesis".into(),
        }
    }

    /// "the body of `SEQ_A`".
    fn brace_owner(&self, k: usize) -> String {
        let func = self.tokens[..k]
            .iter()
            .rposition(|t| t.1 == Tok::Func)
            .and_then(|i| match self.tokens.get(i + 1) {
                Some((_, Tok::Ident(name), _)) => Some(name.clone()),
                _ => None,
            });
        match func {
            Some(name) => format!("the body of `{name}`"),
            None => "the block".into(),
        }
    }
}

fn error_span(e: &ParseError<usize, Tok, Infallible>, len: usize) -> Span {
    match e {
        ParseError::UnrecognizedToken {
            token: (l, _, r), ..
        }
        | ParseError::ExtraToken { token: (l, _, r) } => Span::new(*l, *r),
        ParseError::UnrecognizedEof { location, .. } | ParseError::InvalidToken { location } => {
            Span::new(*location, *location)
        }
        ParseError::User { .. } => Span::new(len, len),
    }
}

/// How a terminal of the grammar is named in a message.
fn friendly(terminal: &str) -> String {
    match terminal {
        "name" => "a name".into(),
        "number" => "a number".into(),
        "string" => "a string".into(),
        ";" => "a newline".into(),
        t => format!("`{t}`"),
    }
}

/// `a`, `a or b`, `a, b or c`.
fn join_or(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// What to write instead of Go syntax the mission language leaves out.
fn unsupported_help(tok: &Tok) -> Option<String> {
    let text = match tok {
        Tok::Keyword("if" | "else" | "switch" | "case" | "default") => {
            "the mission language has no `if` statement: use `If(cond, Then)` or `If(cond, Then, Else)` with blocks passed by name"
        }
        Tok::Keyword("for" | "range" | "break" | "continue") => {
            "the mission language has no `for` loop: use `RepeatFor(n, Body)`, `RepeatWhile(cond, Body)` or `RepeatUntil(cond, Body)`"
        }
        Tok::Keyword("go") => "to run statements in parallel, put them in a block whose name starts with `PAR_`",
        Tok::Keyword("return") => "a block ends at its closing brace; there is nothing to return",
        Tok::Keyword("import") => "missions import nothing: drone types come from capability profiles",
        Tok::Keyword("type" | "struct" | "interface") => {
            "drone types are capability profiles, not Go types"
        }
        Tok::Keyword(k) => return Some(format!("`{k}` is Go, but not part of the mission language")),
        Tok::Op(":=") => "missions have no variables: declare a number with `const Name = value`",
        Tok::Op("%") => "only `+`, `-`, `*` and `/` are available",
        Tok::Op(op) => return Some(format!("`{op}` is Go, but not part of the mission language")),
        _ => return None,
    };
    Some(text.into())
}

/// Builds a binary node; its span covers both operands.
pub(crate) fn binary(op: BinaryOp, op_span: Span, lhs: Expr, rhs: Expr) -> Expr {
    let span = lhs.span.to(rhs.span);
    Expr::new(
        ExprKind::Binary {
            op,
            op_span,
            lhs: Box::new(lhs),
            rhs: Box::new(rhs),
        },
        span,
    )
}

pub(crate) fn unary(op: UnaryOp, op_span: Span, operand: Expr) -> Expr {
    let span = op_span.to(operand.span);
    Expr::new(
        ExprKind::Unary {
            op,
            op_span,
            operand: Box::new(operand),
        },
        span,
    )
}

/// Applies Go's grouping of parameters: in `a, b float64`, `a` takes the
/// type of the next typed parameter.
pub(crate) fn fix_params(items: Vec<ParamItem>, diags: &mut Vec<Diagnostic>) -> Vec<Param> {
    let mut out = Vec::with_capacity(items.len());
    let mut ty: Option<Ident> = None;
    for item in items.into_iter().rev() {
        if item.ty.is_some() {
            ty = item.ty;
        }
        if ty.is_none() {
            diags.push(
                Diagnostic::error(
                    "eamos::syntax",
                    item.name.span,
                    format!("parameter `{}` has no type", item.name.name),
                )
                .with_label("a parameter needs a type")
                .with_help(format!(
                    "write `{0} float64` for a number or `{0} Quadcopter` for a drone",
                    item.name.name
                )),
            );
        }
        let span = match &ty {
            Some(t) if t.span.start >= item.name.span.start => item.name.span.to(t.span),
            _ => item.name.span,
        };
        out.push(Param {
            name: item.name,
            ty: ty.clone(),
            span,
        });
    }
    out.reverse();
    out
}

/// Sorts a statement by its shape: `D.Act(...)` is a drone action, `If(...)`
/// and the other names of Table 3 are control structures, `Signal`/`Await`
/// synchronise, any other `Name(...)` runs a block. Anything else is not a
/// statement.
pub(crate) fn classify(expr: Expr, diags: &mut Vec<Diagnostic>) -> Stmt {
    let span = expr.span;
    match expr.kind {
        ExprKind::Call { callee, args } => {
            let callee = *callee;
            match callee.kind {
                ExprKind::Name(name) => {
                    let name = Ident {
                        name,
                        span: callee.span,
                    };
                    if let Some(kind) = ControlKind::from_name(&name.name) {
                        Stmt::Control(ControlCall {
                            kind,
                            name,
                            args,
                            span,
                        })
                    } else if name.name == "Signal" || name.name == "Await" {
                        let kind = if name.name == "Signal" {
                            SyncKind::Signal
                        } else {
                            SyncKind::Await
                        };
                        Stmt::Sync(SyncCall {
                            kind,
                            name,
                            args,
                            span,
                        })
                    } else {
                        Stmt::BlockCall(BlockCall { name, args, span })
                    }
                }
                ExprKind::Selector { base, field } => match base.kind {
                    ExprKind::Name(drone) => Stmt::Action(ActionCall {
                        drone: Ident {
                            name: drone,
                            span: base.span,
                        },
                        action: field,
                        args,
                        span,
                    }),
                    _ => {
                        diags.push(
                            Diagnostic::error(
                                "eamos::not-a-statement",
                                span,
                                "a drone action is called on a drone's name",
                            )
                            .with_label("expected `Drone.Action(...)`")
                            .with_help("for example `Drone1.FlyByX(1)`"),
                        );
                        Stmt::Error(span)
                    }
                },
                _ => {
                    diags.push(
                        Diagnostic::error(
                            "eamos::not-a-statement",
                            callee.span,
                            "only a name can be called",
                        )
                        .with_label("not a block, action or control structure name"),
                    );
                    Stmt::Error(span)
                }
            }
        }
        ExprKind::Paren(inner) => classify(*inner, diags),
        ExprKind::Name(name) => {
            diags.push(
                Diagnostic::error(
                    "eamos::not-a-statement",
                    span,
                    format!("`{name}` alone is not a statement"),
                )
                .with_label("nothing to run")
                .with_help(format!("to run the block, call it: `{name}()`")),
            );
            Stmt::Error(span)
        }
        ExprKind::Selector {
            ref base,
            ref field,
        } => {
            let path = base.path().map(|b| format!("{b}.{}", field.name));
            let mut d = Diagnostic::error(
                "eamos::not-a-statement",
                span,
                format!(
                    "`{}` alone is not a statement",
                    path.as_deref().unwrap_or("this")
                ),
            )
            .with_label("nothing to run");
            if let Some(p) = path {
                d = d.with_help(format!("an action is called with parentheses: `{p}()`"));
            }
            diags.push(d);
            Stmt::Error(span)
        }
        _ => {
            diags.push(
                Diagnostic::error(
                    "eamos::not-a-statement",
                    span,
                    "this expression is not a statement",
                )
                .with_label("nothing to run")
                .with_help(
                    "a statement is a drone action (`Drone1.Land()`), a block call \
                     (`SEQ_Fly()`), a control structure (`RepeatFor(3, SEQ_Body)`) or \
                     `Signal(\"name\")`/`Await(\"name\")`",
                ),
            );
            Stmt::Error(span)
        }
    }
}

/// Parses one expression on its own (for tests and tools).
pub fn parse_expr(text: &str) -> Result<Expr, Vec<Diagnostic>> {
    let file = SourceFile::new("<expr>", text);
    let lexed = lex(text);
    let mut tokens = lexed.tokens;
    if matches!(tokens.last(), Some((_, Tok::Semi { auto: true }, _))) {
        tokens.pop();
    }
    let mut recovered = Vec::new();
    let mut shape = Vec::new();
    let result = grammar::ExprParser::new().parse(
        &mut recovered,
        &mut shape,
        tokens.iter().cloned().map(Ok::<Spanned, Infallible>),
    );
    let ctx = Context {
        file: &file,
        tokens: &tokens,
    };
    let mut diags = lexed.diagnostics;
    match result {
        Ok(e) if diags.is_empty() => Ok(e),
        Ok(_) => Err(diags),
        Err(e) => {
            diags.push(ctx.describe(e));
            Err(diags)
        }
    }
}
