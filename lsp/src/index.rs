//! What each name of a mission file is, and where: the one walk over the
//! syntax tree that hover, completion, navigation and rename all read.
//!
//! It works on the syntax tree alone, so it serves a file that does not
//! compile as far as the parser could read it.

use std::collections::BTreeSet;

use eamos_lang::ast::{self, Expr, ExprKind, Stmt, SyncKind};
use eamos_lang::Span;

/// What a name stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A function: a SEQ or PAR block.
    Block,
    /// An event of `Signal` / `Await`; its span is the string's content.
    Event,
    Drone,
    Const,
    /// A drone's action; `owner` is the drone (or drone parameter).
    Action,
    /// A drone's property, read in a condition.
    Property,
    /// A control structure (`If`, `RepeatFor`, ...).
    Control,
}

/// One place a name is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Occurrence {
    pub kind: Kind,
    pub name: String,
    pub span: Span,
    /// The declaration (a function's name, a `Signal`, a `var`), not a use.
    pub def: bool,
    /// For an action or property: the drone name before the dot.
    pub owner: Option<String>,
    /// The function the occurrence is in.
    pub func: Option<usize>,
}

/// A function as declared.
#[derive(Debug, Clone)]
pub struct Func {
    pub name: String,
    pub name_span: Span,
    pub span: Span,
    /// Parameters: name and type as written.
    pub params: Vec<(String, String)>,
}

/// A declared drone: its name and type (profile) as written.
#[derive(Debug, Clone)]
pub struct Drone {
    pub name: String,
    pub ty: String,
    pub span: Span,
}

#[derive(Debug, Clone, Default)]
pub struct Index {
    pub occurrences: Vec<Occurrence>,
    pub funcs: Vec<Func>,
    pub drones: Vec<Drone>,
    pub consts: Vec<(String, Span)>,
}

impl Index {
    pub fn new(file: &ast::File, text: &str) -> Index {
        let mut ix = Index::default();
        for decl in &file.decls {
            match decl {
                ast::Decl::Var(v) => {
                    for spec in &v.specs {
                        for n in &spec.names {
                            ix.drones.push(Drone {
                                name: n.name.clone(),
                                ty: spec.ty.name.clone(),
                                span: n.span,
                            });
                            ix.push(Kind::Drone, n, true, None, None);
                        }
                    }
                }
                ast::Decl::Const(c) => {
                    for spec in &c.specs {
                        ix.consts.push((spec.name.name.clone(), spec.name.span));
                        ix.push(Kind::Const, &spec.name, true, None, None);
                    }
                }
                ast::Decl::Func(f) => {
                    ix.funcs.push(Func {
                        name: f.name.name.clone(),
                        name_span: f.name.span,
                        span: f.span,
                        params: f
                            .params
                            .iter()
                            .map(|p| {
                                let ty = p.ty.as_ref().map_or(String::new(), |t| t.name.clone());
                                (p.name.name.clone(), ty)
                            })
                            .collect(),
                    });
                    let at = Some(ix.funcs.len() - 1);
                    ix.push(Kind::Block, &f.name, true, None, at);
                }
                ast::Decl::Error(_) => {}
            }
        }
        // Bodies after every declaration: a bare name is classified by what
        // the file declares, wherever it declares it.
        let mut walker = Walker { ix: &mut ix, text };
        for decl in &file.decls {
            if let ast::Decl::Func(f) = decl {
                let at = walker.ix.func_named(&f.name.name);
                let params: BTreeSet<&str> =
                    f.params.iter().map(|p| p.name.name.as_str()).collect();
                for s in &f.body.stmts {
                    walker.stmt(s, at, &params);
                }
            }
        }
        ix.occurrences.sort_by_key(|o| (o.span.start, o.span.end));
        ix
    }

    fn push(
        &mut self,
        kind: Kind,
        id: &ast::Ident,
        def: bool,
        owner: Option<String>,
        func: Option<usize>,
    ) {
        self.occurrences.push(Occurrence {
            kind,
            name: id.name.clone(),
            span: id.span,
            def,
            owner,
            func,
        });
    }

    pub fn func_named(&self, name: &str) -> Option<usize> {
        self.funcs.iter().position(|f| f.name == name)
    }

    /// The occurrence under the cursor (its end counts: a cursor just
    /// after a name is on it).
    pub fn at(&self, offset: usize) -> Option<&Occurrence> {
        let offset = offset as u32;
        self.occurrences
            .iter()
            .find(|o| o.span.start <= offset && offset <= o.span.end)
    }

    /// Every occurrence of the same symbol (same kind and name).
    pub fn all_of<'a>(
        &'a self,
        kind: Kind,
        name: &'a str,
    ) -> impl Iterator<Item = &'a Occurrence> + 'a {
        self.occurrences
            .iter()
            .filter(move |o| o.kind == kind && o.name == name)
    }

    /// The function whose text holds `offset`.
    pub fn func_at(&self, offset: usize) -> Option<&Func> {
        let offset = offset as u32;
        self.funcs
            .iter()
            .find(|f| f.span.start <= offset && offset <= f.span.end)
    }

    /// The drone type of a name as seen from `func`: a declared drone, or
    /// a parameter of the function.
    pub fn drone_type<'a>(&'a self, name: &str, func: Option<&'a Func>) -> Option<&'a str> {
        if let Some(f) = func {
            if let Some((_, ty)) = f.params.iter().find(|(n, _)| n == name) {
                return Some(ty);
            }
        }
        self.drones
            .iter()
            .find(|d| d.name == name)
            .map(|d| d.ty.as_str())
    }

    /// Events in order of first appearance (an empty one, being typed,
    /// left out).
    pub fn events(&self) -> Vec<&str> {
        let mut seen = Vec::new();
        for o in &self.occurrences {
            if o.kind == Kind::Event && !o.name.is_empty() && !seen.contains(&o.name.as_str()) {
                seen.push(o.name.as_str());
            }
        }
        seen
    }

    /// The drones a block's actions run on: its own, and those of the
    /// blocks it calls, each once (parameters named as such).
    pub fn drones_of(&self, func: usize) -> Vec<String> {
        let mut seen = BTreeSet::new();
        let mut out = Vec::new();
        let mut todo = vec![func];
        let mut visited = BTreeSet::new();
        while let Some(f) = todo.pop() {
            if !visited.insert(f) {
                continue;
            }
            for o in self.occurrences.iter().filter(|o| o.func == Some(f)) {
                match o.kind {
                    Kind::Action => {
                        let owner = o.owner.clone().unwrap_or_default();
                        if seen.insert(owner.clone()) {
                            out.push(owner);
                        }
                    }
                    Kind::Block if !o.def => {
                        if let Some(g) = self.func_named(&o.name) {
                            todo.push(g);
                        }
                    }
                    _ => {}
                }
            }
        }
        out
    }
}

struct Walker<'a> {
    ix: &'a mut Index,
    text: &'a str,
}

impl Walker<'_> {
    fn stmt(&mut self, s: &Stmt, func: Option<usize>, params: &BTreeSet<&str>) {
        match s {
            Stmt::Action(a) => {
                self.name(&a.drone.name, a.drone.span, func, params);
                let owner = Some(a.drone.name.clone());
                self.ix.push(Kind::Action, &a.action, false, owner, func);
                self.exprs(&a.args.items, func, params);
            }
            Stmt::BlockCall(b) => {
                self.ix.push(Kind::Block, &b.name, false, None, func);
                self.exprs(&b.args.items, func, params);
            }
            Stmt::Control(c) => {
                self.ix.push(Kind::Control, &c.name, false, None, func);
                self.exprs(&c.args.items, func, params);
            }
            Stmt::Sync(s) => {
                if let Some(Expr {
                    kind: ExprKind::Str(event),
                    span,
                }) = s.args.items.first()
                {
                    self.ix.occurrences.push(Occurrence {
                        kind: Kind::Event,
                        name: event.clone(),
                        span: inside_quotes(self.text, *span),
                        def: s.kind == SyncKind::Signal,
                        owner: None,
                        func,
                    });
                }
            }
            Stmt::Error(_) => {}
        }
    }

    fn exprs(&mut self, items: &[Expr], func: Option<usize>, params: &BTreeSet<&str>) {
        for e in items {
            self.expr(e, func, params);
        }
    }

    fn expr(&mut self, e: &Expr, func: Option<usize>, params: &BTreeSet<&str>) {
        match &e.kind {
            ExprKind::Name(n) => self.name(n, e.span, func, params),
            ExprKind::Call { callee, args } => {
                if let ExprKind::Selector { base, field } = &callee.kind {
                    if let Some(drone) = base.as_name() {
                        self.name(drone, base.span, func, params);
                        let owner = Some(drone.to_string());
                        self.ix.push(Kind::Property, field, false, owner, func);
                    }
                } else {
                    self.expr(callee, func, params);
                }
                self.exprs(&args.items, func, params);
            }
            ExprKind::Selector { base, .. } => self.expr(base, func, params),
            ExprKind::Unary { operand, .. } => self.expr(operand, func, params),
            ExprKind::Binary { lhs, rhs, .. } => {
                self.expr(lhs, func, params);
                self.expr(rhs, func, params);
            }
            ExprKind::Paren(inner) => self.expr(inner, func, params),
            ExprKind::Number { .. } | ExprKind::Str(_) => {}
        }
    }

    /// A bare name: a drone, constant or block, by what the file declares
    /// (a parameter shadows them and is left out).
    fn name(&mut self, name: &str, span: Span, func: Option<usize>, params: &BTreeSet<&str>) {
        if params.contains(name) {
            return;
        }
        let kind = if self.ix.drones.iter().any(|d| d.name == name) {
            Kind::Drone
        } else if self.ix.consts.iter().any(|(c, _)| c == name) {
            Kind::Const
        } else if self.ix.func_named(name).is_some() {
            Kind::Block
        } else {
            return;
        };
        self.ix.occurrences.push(Occurrence {
            kind,
            name: name.to_string(),
            span,
            def: false,
            owner: None,
            func,
        });
    }
}

/// The content of a string literal's span, without its quotes.
fn inside_quotes(text: &str, span: Span) -> Span {
    let quoted = text
        .get(span.start as usize..span.end as usize)
        .is_some_and(|s| s.len() >= 2 && (s.starts_with('"') || s.starts_with('`')));
    if quoted {
        Span::new(span.start as usize + 1, span.end as usize - 1)
    } else {
        span
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_lang::SourceFile;

    pub(crate) fn index(text: &str) -> Index {
        let file = SourceFile::new("m.go", text);
        let (ast, _) = eamos_lang::parser::parse(&file);
        Index::new(&ast, text)
    }

    const MISSION: &str = "package M\nvar D1 Quadcopter\nfunc INIT() { PAR_Go() }\nfunc PAR_Go() {\n\tSEQ_A(D1)\n\tAwait(\"up\")\n}\nfunc SEQ_A(d Quadcopter) {\n\td.Arm()\n\tSignal(\"up\")\n}\n";

    #[test]
    fn events_are_indexed_without_their_quotes() {
        let ix = index(MISSION);
        let sites: Vec<_> = ix.all_of(Kind::Event, "up").collect();
        assert_eq!(sites.len(), 2);
        for s in sites {
            assert_eq!(&MISSION[s.span.start as usize..s.span.end as usize], "up");
        }
        assert!(ix.all_of(Kind::Event, "up").any(|o| o.def));
    }

    #[test]
    fn a_block_runs_the_drones_of_the_blocks_it_calls() {
        let ix = index(MISSION);
        let go = ix.func_named("PAR_Go").unwrap();
        assert_eq!(ix.drones_of(go), vec!["d".to_string()]);
        assert_eq!(ix.all_of(Kind::Block, "SEQ_A").count(), 2);
    }

    #[test]
    fn a_parameter_has_its_declared_drone_type() {
        let ix = index(MISSION);
        let at = MISSION.find("d.Arm").unwrap();
        assert_eq!(ix.drone_type("d", ix.func_at(at)), Some("Quadcopter"));
    }
}
