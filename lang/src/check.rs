//! Name resolution and checks: from the syntax tree to [`hir::Mission`].
//!
//! Two passes over the same lowering code:
//!
//! 1. *Check*: every function body is lowered once, with its parameters
//!    standing for "some drone of this type" or "some number". Every error a
//!    person can fix in that function is reported there, once, however often
//!    the function is called.
//! 2. *Expand*: from the entry point, every call is expanded into its own
//!    block instance with its arguments substituted. Only what depends on the
//!    expansion is reported here: values that come from arguments (a negative
//!    `RepeatFor` count), and a `Signal` that ends up inside a loop body.
//!
//! Between the two, the call graph gives the entry point and finds recursion.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use eamos_profile::{ParamKind, Profile, ProfileTable, ValueType};

use crate::ast::{self, ControlKind, ExprKind, SyncKind};
use crate::diag::{did_you_mean, Diagnostic};
use crate::hir::{self, BinaryOp, BlockKind, CondMode, DroneId, UnaryOp};
use crate::span::{SourceFile, Span};

/// More statements than this after expansion is almost certainly a mistake
/// (calls doubling at every level), and would exhaust memory before it flies.
pub const MAX_EXPANDED_STATEMENTS: usize = 100_000;

/// How deep block calls may nest when expanded: far beyond a real mission,
/// far below what would exhaust a thread's stack.
pub const MAX_CALL_DEPTH: usize = 128;

/// Codes whose findings need the whole file: after a syntax error a
/// declaration may be missing, so these would only be echoes of it.
const NEED_COMPLETE_FILE: &[&str] = &[
    "eamos::unknown-drone",
    "eamos::unknown-function",
    "eamos::unknown-name",
    "eamos::unknown-event",
    "eamos::no-entry",
    "eamos::several-entries",
];

/// Warnings about the mission as a whole (a drone never used, a function
/// never called): while there are errors they are only echoes of them.
pub const WHOLE_MISSION_WARNINGS: &[&str] = &[
    "eamos::never-called",
    "eamos::unused-drone",
    "eamos::empty-mission",
    "eamos::event-never-awaited",
];

const NUMERIC_TYPES: &[&str] = &[
    "float64", "float32", "int", "int8", "int16", "int32", "int64", "uint", "uint8", "uint16",
    "uint32", "uint64",
];

/// Checks a parsed file. `complete` is false when the parser had to skip
/// parts of the file: findings that may only echo a skipped declaration are
/// then left out, and so are warnings.
pub fn check(
    file: &ast::File,
    source: &SourceFile,
    profiles: &ProfileTable,
    complete: bool,
) -> (Option<hir::Mission>, Vec<Diagnostic>) {
    let mut c = Checker::new(file, source, profiles);
    let mission = c.run();
    let mut diags = c.diags;
    if !complete {
        diags.retain(|d| d.is_error() && !NEED_COMPLETE_FILE.contains(&d.code));
    }
    let mut seen = BTreeSet::new();
    diags.retain(|d| seen.insert((d.code, d.span.start, d.span.end)));
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    let ok = complete && !diags.iter().any(Diagnostic::is_error);
    (if ok { mission } else { None }, diags)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Check,
    Expand,
}

/// The type of a value in a condition or a constant expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ty {
    Number,
    Bool,
}

impl Ty {
    fn name(self) -> &'static str {
        match self {
            Ty::Number => "a number",
            Ty::Bool => "a boolean",
        }
    }
}

/// What is known at compile time about a value.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Konst {
    /// Read at run time (a drone property is involved).
    No,
    Num(f64),
    Bool(bool),
    /// A constant whose value only the expansion knows (a number parameter
    /// during the check pass).
    Unknown,
}

/// A lowered expression.
struct Low {
    expr: hir::Expr,
    ty: Ty,
    konst: Konst,
}

/// What a parameter stands for.
#[derive(Debug, Clone)]
enum Binding<'a> {
    Drone {
        /// `None` in the check pass: some drone of this profile.
        id: Option<DroneId>,
        profile: Option<&'a Profile>,
    },
    Number {
        /// `None` in the check pass.
        value: Option<f64>,
    },
    /// A parameter whose type is wrong (already reported): uses of it are
    /// not reported again.
    Poisoned,
}

#[derive(Debug, Clone, Default)]
struct Env<'a> {
    params: Vec<(String, Binding<'a>)>,
}

impl<'a> Env<'a> {
    fn get(&self, name: &str) -> Option<&Binding<'a>> {
        self.params.iter().find(|(n, _)| n == name).map(|(_, b)| b)
    }
}

/// Where a statement is lowered: the calls that led there and the innermost
/// loop whose body it is in.
#[derive(Debug, Clone, Default)]
struct Ctx {
    calls: Vec<(String, Span)>,
    in_loop: Option<(ControlKind, Span)>,
}

/// A resolved drone reference.
#[derive(Clone, Copy)]
struct DroneRef<'a> {
    id: DroneId,
    profile: Option<&'a Profile>,
    profile_name: &'a str,
}

struct DroneDecl<'a> {
    name: &'a ast::Ident,
    ty: &'a ast::Ident,
    profile: Option<&'a Profile>,
}

#[derive(Debug, Clone, Copy)]
enum ParamTy<'a> {
    Drone(Option<&'a Profile>),
    Number {
        integer: bool,
    },
    /// The type was wrong (already reported).
    Bad,
}

struct FuncInfo<'a> {
    decl: &'a ast::FuncDecl,
    params: Vec<(&'a ast::Param, ParamTy<'a>)>,
}

enum ConstState<'a> {
    Pending(&'a ast::ConstSpec),
    Evaluating,
    Done(Option<f64>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Global {
    Drone,
    Const,
    Func,
}

struct Checker<'a> {
    file: &'a ast::File,
    source: &'a SourceFile,
    profiles: &'a ProfileTable,
    diags: Vec<Diagnostic>,
    mode: Mode,
    drones: Vec<DroneDecl<'a>>,
    globals: HashMap<&'a str, (Global, Span)>,
    consts: HashMap<&'a str, ConstState<'a>>,
    funcs: BTreeMap<&'a str, FuncInfo<'a>>,
    func_order: Vec<&'a str>,
    /// Every `Signal` event name in the file.
    signalled: BTreeSet<String>,
    awaited: BTreeSet<String>,
    used_drones: BTreeSet<DroneId>,
    expanded: usize,
    too_large: bool,
}

impl<'a> Checker<'a> {
    fn new(file: &'a ast::File, source: &'a SourceFile, profiles: &'a ProfileTable) -> Self {
        Checker {
            file,
            source,
            profiles,
            diags: Vec::new(),
            mode: Mode::Check,
            drones: Vec::new(),
            globals: HashMap::new(),
            consts: HashMap::new(),
            funcs: BTreeMap::new(),
            func_order: Vec::new(),
            signalled: BTreeSet::new(),
            awaited: BTreeSet::new(),
            used_drones: BTreeSet::new(),
            expanded: 0,
            too_large: false,
        }
    }

    /// A finding of the check pass (reported once per source location).
    fn emit(&mut self, d: Diagnostic) {
        if self.mode == Mode::Check {
            self.diags.push(d);
        }
    }

    /// A finding that depends on values, reported in whichever pass knows
    /// them; in the expansion it points at the call that supplied them.
    fn emit_value(&mut self, mut d: Diagnostic, ctx: &Ctx) {
        if self.mode == Mode::Expand {
            if let Some((name, span)) = ctx.calls.last() {
                d = d.with_note_at(*span, format!("in this call of `{name}`"));
            }
        }
        self.diags.push(d);
    }

    fn loc(&self, span: Span) -> String {
        let lc = self.source.line_col(span.start);
        format!("{}:{}", lc.line, lc.col)
    }

    fn run(&mut self) -> Option<hir::Mission> {
        self.declare();
        // In declaration order, so that a cycle is always reported at the
        // same place.
        let const_names: Vec<&'a str> = self
            .file
            .decls
            .iter()
            .filter_map(|d| match d {
                ast::Decl::Const(c) => Some(c.specs.iter().map(|s| s.name.name.as_str())),
                _ => None,
            })
            .flatten()
            .collect();
        for name in const_names {
            self.const_value(name, None);
        }
        self.collect_signals();
        let order = self.func_order.clone();
        for name in &order {
            self.check_func(name);
        }
        let graph = self.call_graph();
        let recursive = self.report_recursion(&graph);
        let entry = self.entry_point(&graph)?;
        if recursive {
            return None;
        }
        self.mode = Mode::Expand;
        let info = &self.funcs[entry];
        let decl = info.decl;
        let mut ctx = Ctx::default();
        let root = self.expand(decl, &Env::default(), decl.name.span, &mut ctx);
        self.mode = Mode::Check;
        self.warn_unused(entry, &graph, &root);
        let name = self
            .file
            .package
            .as_ref()
            .map_or_else(String::new, |p| p.name.clone());
        let drones = self
            .drones
            .iter()
            .map(|d| hir::Drone {
                name: d.name.name.clone(),
                profile: d.ty.name.clone(),
                span: d.name.span,
            })
            .collect();
        Some(hir::Mission {
            name,
            drones,
            entry: entry.to_string(),
            root,
        })
    }

    // ---- declarations -------------------------------------------------

    fn declare_global(&mut self, ident: &'a ast::Ident, kind: Global) -> bool {
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

    fn declare(&mut self) {
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
                            self.drones.push(DroneDecl {
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

    fn drone_type(&mut self, ty: &'a ast::Ident) -> Option<&'a Profile> {
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
            d.help = Some(match did_you_mean(&ty.name, known.iter().copied()) {
                Some(s) => s,
                None => format!("known drone types: {}", list(&known)),
            });
        }
        self.emit(d);
        None
    }

    fn params(&mut self, f: &'a ast::FuncDecl) -> Vec<(&'a ast::Param, ParamTy<'a>)> {
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

    fn param_type(&mut self, t: &'a ast::Ident) -> ParamTy<'a> {
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
        d.help = Some(match did_you_mean(&t.name, candidates.iter().copied()) {
            Some(s) => s,
            None => format!(
                "a parameter is a drone ({}) or a number (`float64`, `int`)",
                list(&self.profiles.names().collect::<Vec<_>>())
            ),
        });
        self.emit(d);
        ParamTy::Bad
    }

    // ---- constants ----------------------------------------------------

    /// The folded value of a constant (`None` if it has an error, already
    /// reported). `at` is where it is used, for the message about a cycle.
    fn const_value(&mut self, name: &'a str, at: Option<Span>) -> Option<f64> {
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

    fn eval_const_spec(&mut self, spec: &'a ast::ConstSpec) -> Option<f64> {
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
                    .with_help(
                        did_you_mean(&ty.name, ["float64", "int"]).unwrap_or_else(|| {
                            "use `float64` or `int`, or leave the type out".into()
                        }),
                    ),
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

    // ---- functions and the call graph ---------------------------------

    fn collect_signals(&mut self) {
        for info in self.funcs.values() {
            for stmt in &info.decl.body.stmts {
                if let ast::Stmt::Sync(s) = stmt {
                    if let Some(ast::Expr {
                        kind: ExprKind::Str(name),
                        ..
                    }) = s.args.items.first()
                    {
                        match s.kind {
                            SyncKind::Signal => self.signalled.insert(name.clone()),
                            SyncKind::Await => self.awaited.insert(name.clone()),
                        };
                    }
                }
            }
        }
    }

    fn env_for_check(&self, name: &str) -> Env<'a> {
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

    fn check_func(&mut self, name: &'a str) {
        let env = self.env_for_check(name);
        let decl = self.funcs[name].decl;
        let mut ctx = Ctx::default();
        for stmt in &decl.body.stmts {
            self.lower_stmt(stmt, &env, &mut ctx);
        }
    }

    /// For each function, the functions it calls (as statements or as block
    /// arguments) and where.
    fn call_graph(&self) -> BTreeMap<&'a str, Vec<(&'a str, Span)>> {
        let mut graph = BTreeMap::new();
        for (&name, info) in &self.funcs {
            let mut calls = Vec::new();
            for stmt in &info.decl.body.stmts {
                // A call of INIT is an error of its own (`call-entry`), not
                // a cycle to report again.
                let mut add = |callee: &str, span: Span| {
                    if callee == "INIT" {
                        return;
                    }
                    if let Some((&k, _)) = self.funcs.get_key_value(callee) {
                        calls.push((k, span));
                    }
                };
                match stmt {
                    ast::Stmt::BlockCall(b) => add(&b.name.name, b.name.span),
                    ast::Stmt::Control(c) => {
                        for arg in &c.args.items {
                            match &arg.kind {
                                ExprKind::Name(n) => add(n, arg.span),
                                ExprKind::Call { callee, .. } => {
                                    if let ExprKind::Name(n) = &callee.kind {
                                        add(n, callee.span);
                                    }
                                }
                                _ => {}
                            }
                        }
                    }
                    _ => {}
                }
            }
            graph.insert(name, calls);
        }
        graph
    }

    /// Reports every call cycle once; true if there is one.
    fn report_recursion(&mut self, graph: &BTreeMap<&'a str, Vec<(&'a str, Span)>>) -> bool {
        // Functions on no cycle are peeled off first (repeatedly drop those
        // that call nothing left), so the search below only starts from
        // functions that can reach themselves: linear in a long call chain.
        let mut left: BTreeMap<&str, usize> = graph
            .iter()
            .map(|(&f, calls)| {
                (
                    f,
                    calls
                        .iter()
                        .map(|(to, _)| *to)
                        .collect::<BTreeSet<_>>()
                        .len(),
                )
            })
            .collect();
        let mut callers: HashMap<&str, Vec<&str>> = HashMap::new();
        for (&from, calls) in graph {
            for to in calls.iter().map(|(to, _)| *to).collect::<BTreeSet<_>>() {
                callers.entry(to).or_default().push(from);
            }
        }
        let mut leaves: Vec<&str> = left
            .iter()
            .filter(|(_, n)| **n == 0)
            .map(|(f, _)| *f)
            .collect();
        while let Some(f) = leaves.pop() {
            left.remove(f);
            for caller in callers.get(f).into_iter().flatten() {
                if let Some(n) = left.get_mut(caller) {
                    *n -= 1;
                    if *n == 0 {
                        leaves.push(caller);
                    }
                }
            }
        }
        let mut reported: BTreeSet<&str> = BTreeSet::new();
        let mut any = false;
        for &start in graph.keys() {
            if reported.contains(start) || !left.contains_key(start) {
                continue;
            }
            // Shortest path from `start` back to itself (breadth first).
            let mut prev: HashMap<&str, (&str, Span)> = HashMap::new();
            let mut queue = std::collections::VecDeque::from([start]);
            let mut closing = None;
            'search: while let Some(n) = queue.pop_front() {
                for &(m, span) in &graph[n] {
                    if m == start {
                        closing = Some((n, span));
                        break 'search;
                    }
                    if let std::collections::hash_map::Entry::Vacant(e) = prev.entry(m) {
                        e.insert((n, span));
                        queue.push_back(m);
                    }
                }
            }
            let Some((last, last_span)) = closing else {
                continue;
            };
            let mut path = vec![(last, start, last_span)];
            let mut cur = last;
            while cur != start {
                let (p, span) = prev[cur];
                path.push((p, cur, span));
                cur = p;
            }
            path.reverse();
            any = true;
            for (from, _, _) in &path {
                reported.insert(from);
            }
            let chain: Vec<String> = path
                .iter()
                .map(|(from, _, _)| format!("`{from}`"))
                .chain(std::iter::once(format!("`{start}`")))
                .collect();
            let (first_from, first_to, first_span) = path[0];
            let message = if path.len() == 1 {
                format!("`{start}` calls itself")
            } else {
                format!("recursion: {}", chain.join(" calls "))
            };
            let mut d = Diagnostic::error("eamos::recursion", first_span, message)
                .with_label(format!("`{first_from}` calls `{first_to}` here"))
                .with_help(
                    "a mission is expanded before it flies, so it cannot call itself; \
                     to repeat, use `RepeatWhile`, `RepeatUntil` or `RepeatFor`",
                );
            for &(from, to, span) in &path[1..] {
                d = d.with_note_at(span, format!("`{from}` calls `{to}` here"));
            }
            self.emit(d);
        }
        any
    }

    fn entry_point(&mut self, graph: &BTreeMap<&'a str, Vec<(&'a str, Span)>>) -> Option<&'a str> {
        let entry = if self.funcs.contains_key("INIT") {
            "INIT"
        } else {
            let called: BTreeSet<&str> = graph
                .iter()
                .flat_map(|(&from, calls)| calls.iter().filter(move |(to, _)| *to != from))
                .map(|(to, _)| *to)
                .collect();
            let roots: Vec<&'a str> = self
                .func_order
                .iter()
                .copied()
                .filter(|f| !called.contains(f))
                .collect();
            match roots.as_slice() {
                [one] => *one,
                [] => {
                    let span = self
                        .file
                        .package
                        .as_ref()
                        .map_or(Span::new(0, 0), |p| p.span);
                    let message = if self.funcs.is_empty() {
                        "the mission has no function to start from".to_string()
                    } else {
                        format!(
                            "no entry point: every function is called by another one ({})",
                            list(&self.func_order)
                        )
                    };
                    let d = Diagnostic::error("eamos::no-entry", span, message)
                        .with_label("this mission")
                        .with_help("add `func INIT() { ... }`: the mission starts there");
                    self.emit(d);
                    return None;
                }
                several => {
                    let names: Vec<&str> = several.to_vec();
                    let first = self.funcs[names[0]].decl.name.span;
                    let mut d = Diagnostic::error(
                        "eamos::several-entries",
                        first,
                        format!(
                            "which function does the mission start from? {} are called by no other function",
                            list(&names)
                        ),
                    )
                    .with_label("not called by any function")
                    .with_help(
                        "name the entry point `INIT`, or call the other functions from the one the mission starts with",
                    );
                    for f in &names[1..] {
                        d = d.with_note_at(
                            self.funcs[f].decl.name.span,
                            "not called by any function",
                        );
                    }
                    self.emit(d);
                    return None;
                }
            }
        };
        let decl = self.funcs[entry].decl;
        if !decl.params.is_empty() {
            self.emit(
                Diagnostic::error(
                    "eamos::entry-params",
                    decl.params_span,
                    format!("the entry point `{entry}` cannot take parameters"),
                )
                .with_label("nothing calls the entry point with arguments")
                .with_help(format!(
                    "call it from `func INIT() {{ {entry}(...) }}` with the arguments it needs"
                )),
            );
            return None;
        }
        Some(entry)
    }

    fn warn_unused(
        &mut self,
        entry: &str,
        graph: &BTreeMap<&'a str, Vec<(&'a str, Span)>>,
        root: &hir::Block,
    ) {
        let mut reachable: BTreeSet<&str> = BTreeSet::from([entry]);
        let mut stack = vec![entry];
        while let Some(f) = stack.pop() {
            for (to, _) in graph.get(f).into_iter().flatten() {
                if reachable.insert(to) {
                    stack.push(to);
                }
            }
        }
        for f in self.func_order.clone() {
            if !reachable.contains(f) {
                let span = self.funcs[f].decl.name.span;
                self.diags.push(
                    Diagnostic::warning(
                        "eamos::never-called",
                        span,
                        format!("function `{f}` is never called"),
                    )
                    .with_label(format!("not reached from `{entry}`"))
                    .with_help(format!(
                        "call it from `{entry}` or a block it runs, or remove it"
                    )),
                );
            }
        }
        for (i, d) in self.drones.iter().enumerate() {
            if !self.used_drones.contains(&DroneId(i as u16)) {
                self.diags.push(
                    Diagnostic::warning(
                        "eamos::unused-drone",
                        d.name.span,
                        format!("drone `{}` is declared but never used", d.name.name),
                    )
                    .with_label("no action or condition uses it")
                    .with_help("give it something to do, or remove it"),
                );
            }
        }
        let mut actions = 0;
        root.walk(&mut |s| {
            if matches!(s, hir::Stmt::Action(_)) {
                actions += 1;
            }
        });
        if actions == 0 {
            let span = self.funcs[entry].decl.name.span;
            self.diags.push(
                Diagnostic::warning(
                    "eamos::empty-mission",
                    span,
                    "the mission runs no drone action",
                )
                .with_label("starts here")
                .with_help("add actions such as `Drone1.Takeoff(1.5)`"),
            );
        }
        for event in self
            .signalled
            .difference(&self.awaited)
            .cloned()
            .collect::<Vec<_>>()
        {
            let span = self.first_sync(SyncKind::Signal, &event);
            self.diags.push(
                Diagnostic::warning(
                    "eamos::event-never-awaited",
                    span,
                    format!("event `{event}` is signalled but never awaited"),
                )
                .with_label("nothing waits for this")
                .with_help(format!("add `Await(\"{event}\")` where a branch must wait for it, or remove the Signal")),
            );
        }
    }

    fn first_sync(&self, kind: SyncKind, event: &str) -> Span {
        for name in &self.func_order {
            for stmt in &self.funcs[name].decl.body.stmts {
                if let ast::Stmt::Sync(s) = stmt {
                    if s.kind == kind
                        && matches!(s.args.items.first(), Some(ast::Expr { kind: ExprKind::Str(n), .. }) if n == event)
                    {
                        return s.span;
                    }
                }
            }
        }
        Span::default()
    }

    // ---- statements ---------------------------------------------------

    /// One instance of a function body: the entry, a block call, or a block
    /// passed to a control structure. `at` is where it was called.
    fn expand(
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

    fn count_expanded(&mut self, span: Span) -> bool {
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

    fn lower_stmt(
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

    fn lower_sync(&mut self, s: &'a ast::SyncCall, ctx: &Ctx) -> Option<hir::Stmt> {
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
                    d.help = did_you_mean(&event, self.signalled.iter().map(String::as_str))
                        .or_else(|| {
                            Some(format!(
                                "add `Signal(\"{event}\")` in the branch this one waits for"
                            ))
                        });
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

    fn lower_action(
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
                d.help = Some(
                    did_you_mean(&a.action.name, profile.actions.keys().map(String::as_str))
                        .unwrap_or_else(|| {
                            format!(
                                "`{}` offers: {}",
                                drone.profile_name,
                                list(
                                    &profile
                                        .actions
                                        .keys()
                                        .map(String::as_str)
                                        .collect::<Vec<_>>()
                                )
                            )
                        }),
                );
                d
            };
            self.emit(d);
            return None;
        };
        let what = format!("`{}.{}`", a.drone.name, a.action.name);
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
            match self.const_number(
                arg,
                env,
                ctx,
                &format!("argument `{}` of {what}", param.name),
            ) {
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
    fn check_count(
        &mut self,
        what: &str,
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
                    "{what} takes {expected}; found {}",
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

    /// A numeric constant expression, folded (`None` if it has an error,
    /// reported). In the check pass a number parameter folds to a stand-in.
    fn const_number(
        &mut self,
        e: &'a ast::Expr,
        env: &Env<'a>,
        ctx: &Ctx,
        what: &str,
    ) -> Option<f64> {
        let low = self.lower_expr(e, env, ctx)?;
        if low.ty == Ty::Bool {
            self.emit(
                Diagnostic::error(
                    "eamos::type-mismatch",
                    e.span,
                    format!("{what} must be a number, found a boolean"),
                )
                .with_label("a boolean"),
            );
            return None;
        }
        match low.konst {
            Konst::Num(v) => Some(v),
            Konst::Unknown => Some(f64::NAN),
            _ => {
                self.emit(not_constant(e, what));
                None
            }
        }
    }

    /// A drone named in an action, a property or an argument: a drone
    /// parameter or a declared drone.
    fn resolve_drone(&mut self, name: &ast::Ident, env: &Env<'a>) -> Option<DroneRef<'a>> {
        match env.get(&name.name) {
            Some(Binding::Drone { id, profile }) => {
                return Some(DroneRef {
                    id: id.unwrap_or(DroneId(u16::MAX)),
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
        if let Some(i) = self.drones.iter().position(|d| d.name.name == name.name) {
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
                d.help = Some(
                    did_you_mean(&name.name, candidates.iter().copied())
                        .unwrap_or_else(|| format!("declare it: `var {} {example}`", name.name)),
                );
                d
            }
        };
        self.emit(d);
        None
    }

    fn lower_block_call(
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
                    let what = format!("argument `{}` of `{}`", param.name.name, b.name.name);
                    if let Some(n) = arg.as_name() {
                        let is_drone = matches!(env.get(n), Some(Binding::Drone { .. }))
                            || (env.get(n).is_none()
                                && self.drones.iter().any(|d| d.name.name == n));
                        if is_drone {
                            self.emit(
                                Diagnostic::error(
                                    "eamos::arg-kind",
                                    arg.span,
                                    format!("{what} is a number, but `{n}` is a drone"),
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
                            format!("{what} must be a whole number, found {v}"),
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

    fn unknown_block(&mut self, name: &ast::Ident, env: &Env<'a>) {
        if matches!(env.get(&name.name), Some(Binding::Poisoned)) {
            return;
        }
        let is_drone = self.drones.iter().any(|d| d.name.name == name.name)
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
            d.help = Some(
                did_you_mean(&name.name, candidates.iter().copied())
                    .unwrap_or_else(|| format!("declare it: `func {}() {{ ... }}`", name.name)),
            );
            d
        };
        self.emit(d);
    }

    /// A block passed by name to a control structure.
    fn block_arg(
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

    fn condition(
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

    fn lower_control(
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
                let n = self.const_number(&args[0], env, ctx, "the count of `RepeatFor`");
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
                let s = self.const_number(&args[0], env, ctx, "the duration of `PauseFor`")?;
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

    // ---- expressions --------------------------------------------------

    fn lower_expr(&mut self, e: &'a ast::Expr, env: &Env<'a>, ctx: &Ctx) -> Option<Low> {
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
            ExprKind::Call { callee, args } => self.lower_property(e, callee, args, env),
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

    fn lower_binary(
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

    fn drone_profile_of(&self, name: &str, env: &Env<'a>) -> Option<&'a Profile> {
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

    fn lower_name(&mut self, name: &'a str, span: Span, env: &Env<'a>) -> Option<Low> {
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
                d.help = did_you_mean(name, candidates.iter().copied())
                    .or_else(|| Some(format!("declare it: `const {name} = ...`")));
                d
            }
        };
        self.emit(d);
        None
    }

    fn lower_property(
        &mut self,
        e: &'a ast::Expr,
        callee: &'a ast::Expr,
        args: &'a ast::Args,
        env: &Env<'a>,
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
                d.help = Some(
                    did_you_mean(&field.name, profile.properties.keys().map(String::as_str))
                        .unwrap_or_else(|| {
                            format!(
                                "`{}` offers: {}",
                                drone.profile_name,
                                list(
                                    &profile
                                        .properties
                                        .keys()
                                        .map(String::as_str)
                                        .collect::<Vec<_>>()
                                )
                            )
                        }),
                );
                d
            };
            self.emit(d);
            return None;
        };
        let what = format!("`{drone_name}.{}`", field.name);
        if !self.check_count(&what, &sig.params, args) {
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

fn block_kind(name: &str) -> BlockKind {
    if name.starts_with("PAR_") {
        BlockKind::Par
    } else {
        BlockKind::Seq
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

fn not_constant(e: &ast::Expr, what: &str) -> Diagnostic {
    Diagnostic::error(
        "eamos::not-constant",
        e.span,
        format!("{what} must be a constant, known before the flight"),
    )
    .with_label("read from a drone at run time")
    .with_help("use numbers, constants and parameters here; drone properties belong in conditions")
}

fn not_a_block(arg: &ast::Expr, structure: &str) -> Diagnostic {
    Diagnostic::error(
        "eamos::not-a-block",
        arg.span,
        format!("`{structure}` expects a block here: the name of a function"),
    )
    .with_label("not a block name")
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

fn kind_name(kind: ParamKind) -> &'static str {
    match kind {
        ParamKind::Metres => "metres",
        ParamKind::Seconds => "seconds",
        ParamKind::Degrees => "degrees",
        ParamKind::Percent => "percent",
        ParamKind::Number => "number",
        ParamKind::Drone => "drone",
    }
}

fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// `` `a`, `b` and `c` ``.
fn list(items: &[&str]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("`{s}`")).collect();
    match quoted.as_slice() {
        [] => "none".into(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}
