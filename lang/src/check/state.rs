//! What every pass of the checker shares: the [`Checker`] with the
//! declarations it has collected, the environments a body is lowered in,
//! the types of values, and the wording helpers every message uses. The
//! passes import this module and nothing of each other.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use eamos_profile::{ParamKind, Profile, ProfileTable};

use crate::ast::{self, ControlKind};
use crate::diag::Diagnostic;
use crate::hir::{self, DroneId};
use crate::span::{SourceFile, Span};

/// The id a drone parameter resolves to in the check pass, where it stands
/// for "some drone of its type".
pub(super) const UNKNOWN_DRONE: DroneId = DroneId(u16::MAX);

/// The number types a parameter or a constant may be declared with.
pub(super) const NUMERIC_TYPES: &[&str] = &[
    "float64", "float32", "int", "int8", "int16", "int32", "int64", "uint", "uint8", "uint16",
    "uint32", "uint64",
];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    Check,
    Expand,
}

/// The type of a value in a condition or a constant expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Ty {
    Number,
    Bool,
}

impl Ty {
    pub(super) fn name(self) -> &'static str {
        match self {
            Ty::Number => "a number",
            Ty::Bool => "a boolean",
        }
    }
}

/// What is known at compile time about a value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Konst {
    /// Read at run time (a drone property is involved).
    No,
    Num(f64),
    Bool(bool),
    /// A constant whose value only the expansion knows (a number parameter
    /// during the check pass).
    Unknown,
}

/// A lowered expression.
pub(super) struct Low {
    pub(super) expr: hir::Expr,
    pub(super) ty: Ty,
    pub(super) konst: Konst,
}

/// What a parameter stands for.
#[derive(Debug, Clone)]
pub(super) enum Binding<'a> {
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
pub(super) struct Env<'a> {
    pub(super) params: Vec<(String, Binding<'a>)>,
}

impl<'a> Env<'a> {
    pub(super) fn get(&self, name: &str) -> Option<&Binding<'a>> {
        self.params.iter().find(|(n, _)| n == name).map(|(_, b)| b)
    }
}

/// Where a statement is lowered: the calls that led there and the innermost
/// loop whose body it is in.
#[derive(Debug, Clone, Default)]
pub(super) struct Ctx {
    pub(super) calls: Vec<(String, Span)>,
    pub(super) in_loop: Option<(ControlKind, Span)>,
}

/// A resolved drone reference.
#[derive(Clone, Copy)]
pub(super) struct DroneRef<'a> {
    pub(super) id: DroneId,
    pub(super) profile: Option<&'a Profile>,
    pub(super) profile_name: &'a str,
}

pub(super) struct DroneDecl<'a> {
    pub(super) name: &'a ast::Ident,
    pub(super) ty: &'a ast::Ident,
    pub(super) profile: Option<&'a Profile>,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum ParamTy<'a> {
    Drone(Option<&'a Profile>),
    Number {
        integer: bool,
    },
    /// The type was wrong (already reported).
    Bad,
}

pub(super) struct FuncInfo<'a> {
    pub(super) decl: &'a ast::FuncDecl,
    pub(super) params: Vec<(&'a ast::Param, ParamTy<'a>)>,
}

pub(super) enum ConstState<'a> {
    Pending(&'a ast::ConstSpec),
    Evaluating,
    Done(Option<f64>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Global {
    Drone,
    Const,
    Func,
}

pub(super) struct Checker<'a> {
    pub(super) file: &'a ast::File,
    pub(super) source: &'a SourceFile,
    pub(super) profiles: &'a ProfileTable,
    pub(super) diags: Vec<Diagnostic>,
    pub(super) mode: Mode,
    pub(super) drones: Vec<DroneDecl<'a>>,
    /// Each drone's place in `drones`, by name: a fleet of hundreds is
    /// looked up once an action (a search of the list made the checks
    /// grow with the square of the fleet).
    drone_ids: HashMap<&'a str, usize>,
    pub(super) globals: HashMap<&'a str, (Global, Span)>,
    pub(super) consts: HashMap<&'a str, ConstState<'a>>,
    pub(super) funcs: BTreeMap<&'a str, FuncInfo<'a>>,
    pub(super) func_order: Vec<&'a str>,
    /// Every `Signal` event name in the file.
    pub(super) signalled: BTreeSet<String>,
    pub(super) awaited: BTreeSet<String>,
    pub(super) used_drones: BTreeSet<DroneId>,
    pub(super) expanded: usize,
    pub(super) too_large: bool,
}

impl<'a> Checker<'a> {
    /// Declares the next drone.
    pub(super) fn add_drone(&mut self, drone: DroneDecl<'a>) {
        self.drone_ids.insert(&drone.name.name, self.drones.len());
        self.drones.push(drone);
    }

    /// The declared drone named `name`, by its place in `drones`.
    pub(super) fn drone_named(&self, name: &str) -> Option<usize> {
        self.drone_ids
            .get(name)
            .copied()
            .filter(|&i| i < self.drones.len())
    }

    pub(super) fn new(
        file: &'a ast::File,
        source: &'a SourceFile,
        profiles: &'a ProfileTable,
    ) -> Self {
        Checker {
            file,
            source,
            profiles,
            diags: Vec::new(),
            mode: Mode::Check,
            drones: Vec::new(),
            drone_ids: HashMap::new(),
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
    pub(super) fn emit(&mut self, d: Diagnostic) {
        if self.mode == Mode::Check {
            self.diags.push(d);
        }
    }

    /// A finding that depends on values, reported in whichever pass knows
    /// them; in the expansion it points at the call that supplied them.
    pub(super) fn emit_value(&mut self, mut d: Diagnostic, ctx: &Ctx) {
        if self.mode == Mode::Expand {
            if let Some((name, span)) = ctx.calls.last() {
                d = d.with_note_at(*span, format!("in this call of `{name}`"));
            }
        }
        self.diags.push(d);
    }

    pub(super) fn loc(&self, span: Span) -> String {
        let lc = self.source.line_col(span.start);
        format!("{}:{}", lc.line, lc.col)
    }
}

pub(super) fn kind_name(kind: ParamKind) -> &'static str {
    match kind {
        ParamKind::Metres => "metres",
        ParamKind::Seconds => "seconds",
        ParamKind::Degrees => "degrees",
        ParamKind::Percent => "percent",
        ParamKind::Number => "number",
        ParamKind::Drone => "drone",
    }
}

pub(super) fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// What a profile offers instead of an unknown action or property.
pub(super) fn offers<'p>(profile: &str, names: impl Iterator<Item = &'p String>) -> String {
    let names: Vec<&str> = names.map(String::as_str).collect();
    format!("`{profile}` offers: {}", list(&names))
}

/// `` `a`, `b` and `c` ``.
pub(super) fn list(items: &[&str]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("`{s}`")).collect();
    match quoted.as_slice() {
        [] => "none".into(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}
