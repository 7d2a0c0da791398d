//! The checked mission: what the front end hands to every later stage.
//!
//! Names are resolved (drones are [`DroneId`]s), constants are folded to
//! numbers, parameters are substituted and every block call is expanded into
//! its own instance, so a consumer never looks back at the source text except
//! through spans. The tree is series-parallel by construction; `Signal` and
//! `Await` are the only edges across it.

use serde::{Deserialize, Serialize};

use crate::span::Span;

/// Index of a drone in [`Mission::drones`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct DroneId(pub u16);

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mission {
    /// The `package` name.
    pub name: String,
    pub drones: Vec<Drone>,
    /// The entry function (`INIT`, or the single root).
    pub entry: String,
    /// The entry function's body, with every call below it expanded.
    pub root: Block,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Drone {
    pub name: String,
    /// The capability profile it was declared with (`Quadcopter`).
    pub profile: String,
    pub span: Span,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BlockKind {
    /// Statements run one after the other.
    Seq,
    /// Statements run in parallel; the block ends when all have ended.
    Par,
}

/// One instance of a function body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Block {
    pub kind: BlockKind,
    /// The function this instance was expanded from.
    pub name: String,
    /// Where this instance was called (for the entry, the function name).
    pub span: Span,
    pub stmts: Vec<Stmt>,
}

/// Whether a condition lets a structure go on while it holds or until it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CondMode {
    While,
    Until,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Stmt {
    /// `Drone1.FlyByX(1)`.
    Action(Action),
    /// A block call, `SEQ_Fly()`.
    Block(Block),
    /// `If(c, Then)` / `If(c, Then, Else)`.
    If {
        cond: Expr,
        then: Block,
        otherwise: Option<Block>,
        span: Span,
    },
    /// `WaitWhile(c, Body)` / `WaitUntil(c, Body)`.
    Wait {
        mode: CondMode,
        cond: Expr,
        body: Block,
        span: Span,
    },
    /// `RepeatWhile(c, Body[, Exit])` / `RepeatUntil(c, Body[, Exit])`.
    Repeat {
        mode: CondMode,
        cond: Expr,
        body: Block,
        exit: Option<Block>,
        span: Span,
    },
    /// `RepeatFor(n, Body)`.
    RepeatFor { count: u32, body: Block, span: Span },
    /// `PauseWhile(c)` / `PauseUntil(c)`.
    Pause {
        mode: CondMode,
        cond: Expr,
        span: Span,
    },
    /// `PauseFor(s)`.
    PauseFor { seconds: f64, span: Span },
    /// `DoWhile(c, Body)` / `DoUntil(c, Body)`: the body is interrupted the
    /// moment the condition stops letting it go on.
    Do {
        mode: CondMode,
        cond: Expr,
        body: Block,
        span: Span,
    },
    /// `Signal("name")`.
    Signal { event: String, span: Span },
    /// `Await("name")`.
    Await { event: String, span: Span },
}

/// A drone action, with its arguments folded to numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Action {
    pub drone: DroneId,
    pub name: String,
    pub args: Vec<f64>,
    pub span: Span,
}

/// A condition or numeric expression, type-checked: the root of a condition
/// is boolean.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Expr {
    Number {
        value: f64,
        span: Span,
    },
    Bool {
        value: bool,
        span: Span,
    },
    /// `D3.X()`, `D1.DistanceTo(D2)`.
    Property {
        drone: DroneId,
        name: String,
        args: Vec<DroneId>,
        span: Span,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
        span: Span,
    },
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
        span: Span,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum UnaryOp {
    Not,
    Neg,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BinaryOp {
    Or,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
}

impl Expr {
    pub fn span(&self) -> Span {
        match self {
            Expr::Number { span, .. }
            | Expr::Bool { span, .. }
            | Expr::Property { span, .. }
            | Expr::Unary { span, .. }
            | Expr::Binary { span, .. } => *span,
        }
    }

    /// Every drone whose state the expression reads.
    pub fn drones(&self) -> Vec<DroneId> {
        let mut out = Vec::new();
        self.visit(&mut |e| {
            if let Expr::Property { drone, args, .. } = e {
                out.push(*drone);
                out.extend(args.iter().copied());
            }
        });
        out.sort();
        out.dedup();
        out
    }

    /// Calls `f` on this node and every node below it, parents first.
    pub fn visit(&self, f: &mut impl FnMut(&Expr)) {
        f(self);
        match self {
            Expr::Unary { operand, .. } => operand.visit(f),
            Expr::Binary { lhs, rhs, .. } => {
                lhs.visit(f);
                rhs.visit(f);
            }
            _ => {}
        }
    }
}

impl Stmt {
    pub fn span(&self) -> Span {
        match self {
            Stmt::Action(a) => a.span,
            Stmt::Block(b) => b.span,
            Stmt::If { span, .. }
            | Stmt::Wait { span, .. }
            | Stmt::Repeat { span, .. }
            | Stmt::RepeatFor { span, .. }
            | Stmt::Pause { span, .. }
            | Stmt::PauseFor { span, .. }
            | Stmt::Do { span, .. }
            | Stmt::Signal { span, .. }
            | Stmt::Await { span, .. } => *span,
        }
    }
}

impl Mission {
    pub fn drone(&self, id: DroneId) -> &Drone {
        &self.drones[id.0 as usize]
    }

    pub fn drone_id(&self, name: &str) -> Option<DroneId> {
        self.drones
            .iter()
            .position(|d| d.name == name)
            .map(|i| DroneId(i as u16))
    }
}

impl Block {
    /// Calls `f` on every statement of this block and of every block below
    /// it (block calls, bodies and exits of control structures), parents
    /// first, in source order.
    pub fn walk(&self, f: &mut impl FnMut(&Stmt)) {
        for stmt in &self.stmts {
            f(stmt);
            for block in stmt.blocks() {
                block.walk(f);
            }
        }
    }

    /// Calls `f` on this block and every block instance below it.
    pub fn walk_blocks(&self, f: &mut impl FnMut(&Block)) {
        f(self);
        for stmt in &self.stmts {
            for block in stmt.blocks() {
                block.walk_blocks(f);
            }
        }
    }
}

impl Stmt {
    /// The block instances a statement holds directly.
    pub fn blocks(&self) -> Vec<&Block> {
        match self {
            Stmt::Block(b) => vec![b],
            Stmt::If {
                then, otherwise, ..
            } => std::iter::once(then).chain(otherwise).collect(),
            Stmt::Wait { body, .. } | Stmt::RepeatFor { body, .. } | Stmt::Do { body, .. } => {
                vec![body]
            }
            Stmt::Repeat { body, exit, .. } => std::iter::once(body).chain(exit).collect(),
            Stmt::Action(_)
            | Stmt::Pause { .. }
            | Stmt::PauseFor { .. }
            | Stmt::Signal { .. }
            | Stmt::Await { .. } => Vec::new(),
        }
    }

    /// The control structure's name as written in a mission (`RepeatWhile`),
    /// or `None` for actions, block calls, `Signal` and `Await`.
    pub fn control_name(&self) -> Option<&'static str> {
        use CondMode::{Until, While};
        Some(match self {
            Stmt::If { .. } => "If",
            Stmt::Wait { mode: While, .. } => "WaitWhile",
            Stmt::Wait { mode: Until, .. } => "WaitUntil",
            Stmt::Repeat { mode: While, .. } => "RepeatWhile",
            Stmt::Repeat { mode: Until, .. } => "RepeatUntil",
            Stmt::RepeatFor { .. } => "RepeatFor",
            Stmt::Pause { mode: While, .. } => "PauseWhile",
            Stmt::Pause { mode: Until, .. } => "PauseUntil",
            Stmt::PauseFor { .. } => "PauseFor",
            Stmt::Do { mode: While, .. } => "DoWhile",
            Stmt::Do { mode: Until, .. } => "DoUntil",
            Stmt::Action(_) | Stmt::Block(_) | Stmt::Signal { .. } | Stmt::Await { .. } => {
                return None
            }
        })
    }
}

/// What a mission amounts to, counted over the expanded instances: the
/// numbers a person checks against the mission they meant to write.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Summary {
    pub name: String,
    pub entry: String,
    pub drones: Vec<DroneSummary>,
    /// Action instances over all drones.
    pub actions: usize,
    /// Block instances, the entry's body included.
    pub seq_blocks: usize,
    pub par_blocks: usize,
    /// Control structure instances by name (`RepeatWhile`: 4).
    pub controls: std::collections::BTreeMap<String, usize>,
    /// Every event named by a `Signal` or an `Await`, sorted.
    pub events: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DroneSummary {
    pub name: String,
    pub profile: String,
    pub actions: usize,
}

impl Mission {
    /// Counts the expanded mission; see [`Summary`].
    pub fn summary(&self) -> Summary {
        let mut drones: Vec<DroneSummary> = self
            .drones
            .iter()
            .map(|d| DroneSummary {
                name: d.name.clone(),
                profile: d.profile.clone(),
                actions: 0,
            })
            .collect();
        let mut actions = 0;
        let mut controls = std::collections::BTreeMap::new();
        let mut events = std::collections::BTreeSet::new();
        self.root.walk(&mut |s| match s {
            Stmt::Action(a) => {
                actions += 1;
                if let Some(d) = drones.get_mut(a.drone.0 as usize) {
                    d.actions += 1;
                }
            }
            Stmt::Signal { event, .. } | Stmt::Await { event, .. } => {
                events.insert(event.clone());
            }
            other => {
                if let Some(name) = other.control_name() {
                    *controls.entry(name.to_string()).or_insert(0) += 1;
                }
            }
        });
        let (mut seq_blocks, mut par_blocks) = (0, 0);
        self.root.walk_blocks(&mut |b| match b.kind {
            BlockKind::Seq => seq_blocks += 1,
            BlockKind::Par => par_blocks += 1,
        });
        Summary {
            name: self.name.clone(),
            entry: self.entry.clone(),
            drones,
            actions,
            seq_blocks,
            par_blocks,
            controls,
            events: events.into_iter().collect(),
        }
    }
}

impl std::fmt::Display for Summary {
    /// The few lines `eamos build` prints.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "mission {} (entry {})", self.name, self.entry)?;
        writeln!(f, "drones: {}", self.drones.len())?;
        for d in &self.drones {
            writeln!(
                f,
                "  {}: {}, {} action{}",
                d.name,
                d.profile,
                d.actions,
                if d.actions == 1 { "" } else { "s" }
            )?;
        }
        writeln!(f, "actions: {}", self.actions)?;
        writeln!(
            f,
            "blocks: {} ({} SEQ, {} PAR)",
            self.seq_blocks + self.par_blocks,
            self.seq_blocks,
            self.par_blocks
        )?;
        if self.controls.is_empty() {
            writeln!(f, "control structures: none")?;
        } else {
            let parts: Vec<String> = self
                .controls
                .iter()
                .map(|(k, n)| format!("{k} {n}"))
                .collect();
            writeln!(
                f,
                "control structures: {} ({})",
                self.controls.values().sum::<usize>(),
                parts.join(", ")
            )?;
        }
        if self.events.is_empty() {
            writeln!(f, "events: none")
        } else {
            writeln!(f, "events: {}", self.events.join(", "))
        }
    }
}
