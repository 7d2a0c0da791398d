//! The call graph between the check and the expansion: which function the
//! mission starts from, which calls form a cycle (a mission is expanded
//! before it flies, so it cannot recurse), and afterwards what was never
//! reached (functions, drones, events).

use std::collections::{BTreeMap, BTreeSet, HashMap};

use super::state::{list, Checker};
use crate::ast::{self, ExprKind, SyncKind};
use crate::diag::Diagnostic;
use crate::hir::{self, DroneId};
use crate::span::Span;

impl<'a> Checker<'a> {
    pub(super) fn collect_signals(&mut self) {
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

    /// For each function, the functions it calls (as statements or as block
    /// arguments) and where.
    pub(super) fn call_graph(&self) -> BTreeMap<&'a str, Vec<(&'a str, Span)>> {
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
    pub(super) fn report_recursion(
        &mut self,
        graph: &BTreeMap<&'a str, Vec<(&'a str, Span)>>,
    ) -> bool {
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

    pub(super) fn entry_point(
        &mut self,
        graph: &BTreeMap<&'a str, Vec<(&'a str, Span)>>,
    ) -> Option<&'a str> {
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

    pub(super) fn warn_unused(
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

    pub(super) fn first_sync(&self, kind: SyncKind, event: &str) -> Span {
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
}
