//! The syntax tree: what the file says, before any name is looked up.
//!
//! Every node keeps its span. The tree is close to the text (a statement
//! knows whether it is a drone action, a block call, a control structure or a
//! `Signal`/`Await` only from its shape and its name), and the checker turns
//! it into [`crate::hir::Mission`]. Parts the parser could not read are kept
//! as `Error` nodes so the checker can go on around them.

use crate::span::Span;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct File {
    /// `package Name`; `None` when the clause is missing (already reported).
    pub package: Option<Ident>,
    pub decls: Vec<Decl>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Decl {
    Const(ConstDecl),
    Var(VarDecl),
    Func(FuncDecl),
    /// A declaration the parser could not read.
    Error(Span),
}

/// `const X = 1` or a grouped `const ( X = 1; Y = X * 2 )`.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstDecl {
    pub specs: Vec<ConstSpec>,
    pub grouped: bool,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ConstSpec {
    pub name: Ident,
    /// An optional Go type (`const N int = 3`).
    pub ty: Option<Ident>,
    pub value: Expr,
    pub span: Span,
}

/// `var D1 Quadcopter`, `var D1, D2 Quadcopter` or a grouped `var ( ... )`.
#[derive(Debug, Clone, PartialEq)]
pub struct VarDecl {
    pub specs: Vec<VarSpec>,
    pub grouped: bool,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct VarSpec {
    pub names: Vec<Ident>,
    /// The drone type: the name of a capability profile.
    pub ty: Ident,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct FuncDecl {
    pub name: Ident,
    pub params: Vec<Param>,
    /// The `( ... )` of the parameter list.
    pub params_span: Span,
    pub body: Body,
    pub span: Span,
}

/// One parameter: `d Quadcopter` or `side float64`.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: Ident,
    /// `None` when the list ends without a type (already reported).
    pub ty: Option<Ident>,
    pub span: Span,
}

/// `{ statements }`.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    pub stmts: Vec<Stmt>,
    pub span: Span,
}

/// A statement, classified by its shape.
#[derive(Debug, Clone, PartialEq)]
pub enum Stmt {
    /// `Drone1.FlyByX(1)`.
    Action(ActionCall),
    /// `SEQ_Fly()` or `SEQ_Square(Drone1, 2)`.
    BlockCall(BlockCall),
    /// One of the eleven control structures of the paper's Table 3.
    Control(ControlCall),
    /// `Signal("name")` / `Await("name")`.
    Sync(SyncCall),
    /// A statement the parser could not read.
    Error(Span),
}

impl Stmt {
    pub fn span(&self) -> Span {
        match self {
            Stmt::Action(c) => c.span,
            Stmt::BlockCall(c) => c.span,
            Stmt::Control(c) => c.span,
            Stmt::Sync(c) => c.span,
            Stmt::Error(s) => *s,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct ActionCall {
    pub drone: Ident,
    pub action: Ident,
    pub args: Args,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BlockCall {
    pub name: Ident,
    pub args: Args,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ControlCall {
    pub kind: ControlKind,
    /// The structure's name as written (`RepeatWhile`).
    pub name: Ident,
    pub args: Args,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct SyncCall {
    pub kind: SyncKind,
    pub name: Ident,
    pub args: Args,
    pub span: Span,
}

/// The arguments of a call and the span of its parentheses.
#[derive(Debug, Clone, PartialEq)]
pub struct Args {
    pub items: Vec<Expr>,
    /// From `(` to `)`.
    pub span: Span,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SyncKind {
    Signal,
    Await,
}

/// The control structures of the paper's Table 3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ControlKind {
    If,
    WaitWhile,
    WaitUntil,
    RepeatWhile,
    RepeatUntil,
    RepeatFor,
    PauseWhile,
    PauseUntil,
    PauseFor,
    DoWhile,
    DoUntil,
}

impl ControlKind {
    pub const ALL: [ControlKind; 11] = [
        ControlKind::If,
        ControlKind::WaitWhile,
        ControlKind::WaitUntil,
        ControlKind::RepeatWhile,
        ControlKind::RepeatUntil,
        ControlKind::RepeatFor,
        ControlKind::PauseWhile,
        ControlKind::PauseUntil,
        ControlKind::PauseFor,
        ControlKind::DoWhile,
        ControlKind::DoUntil,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ControlKind::If => "If",
            ControlKind::WaitWhile => "WaitWhile",
            ControlKind::WaitUntil => "WaitUntil",
            ControlKind::RepeatWhile => "RepeatWhile",
            ControlKind::RepeatUntil => "RepeatUntil",
            ControlKind::RepeatFor => "RepeatFor",
            ControlKind::PauseWhile => "PauseWhile",
            ControlKind::PauseUntil => "PauseUntil",
            ControlKind::PauseFor => "PauseFor",
            ControlKind::DoWhile => "DoWhile",
            ControlKind::DoUntil => "DoUntil",
        }
    }

    pub fn from_name(name: &str) -> Option<ControlKind> {
        ControlKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// How it is called, for messages.
    pub fn usage(self) -> &'static str {
        match self {
            ControlKind::If => "If(cond, Then) or If(cond, Then, Else)",
            ControlKind::WaitWhile => "WaitWhile(cond, Body)",
            ControlKind::WaitUntil => "WaitUntil(cond, Body)",
            ControlKind::RepeatWhile => "RepeatWhile(cond, Body) or RepeatWhile(cond, Body, Exit)",
            ControlKind::RepeatUntil => "RepeatUntil(cond, Body) or RepeatUntil(cond, Body, Exit)",
            ControlKind::RepeatFor => "RepeatFor(count, Body)",
            ControlKind::PauseWhile => "PauseWhile(cond)",
            ControlKind::PauseUntil => "PauseUntil(cond)",
            ControlKind::PauseFor => "PauseFor(seconds)",
            ControlKind::DoWhile => "DoWhile(cond, Body)",
            ControlKind::DoUntil => "DoUntil(cond, Body)",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A number literal; `bad` when it was malformed (already reported).
    Number {
        value: f64,
        bad: bool,
    },
    Str(String),
    /// A name: a constant, a parameter, `true`/`false`, a drone, a block.
    Name(String),
    /// `x.name`.
    Selector {
        base: Box<Expr>,
        field: Ident,
    },
    /// `f(args)`.
    Call {
        callee: Box<Expr>,
        args: Args,
    },
    Unary {
        op: UnaryOp,
        op_span: Span,
        operand: Box<Expr>,
    },
    Binary {
        op: BinaryOp,
        op_span: Span,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// `(e)`.
    Paren(Box<Expr>),
}

pub use crate::hir::{BinaryOp, UnaryOp};

impl BinaryOp {
    pub fn symbol(self) -> &'static str {
        match self {
            BinaryOp::Or => "||",
            BinaryOp::And => "&&",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
        }
    }
}

impl UnaryOp {
    pub fn symbol(self) -> &'static str {
        match self {
            UnaryOp::Not => "!",
            UnaryOp::Neg => "-",
        }
    }
}

impl Expr {
    pub fn new(kind: ExprKind, span: Span) -> Self {
        Expr { kind, span }
    }

    /// The name if the expression is a bare name.
    pub fn as_name(&self) -> Option<&str> {
        match &self.kind {
            ExprKind::Name(n) => Some(n),
            _ => None,
        }
    }

    /// The source-like form of a callee (`Drone1.FlyByX`), for messages.
    pub fn path(&self) -> Option<String> {
        match &self.kind {
            ExprKind::Name(n) => Some(n.clone()),
            ExprKind::Selector { base, field } => Some(format!("{}.{}", base.path()?, field.name)),
            _ => None,
        }
    }
}
