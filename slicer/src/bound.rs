//! A lower bound on the bridges any behaviour-preserving slicing of a
//! mission needs.
//!
//! # The argument
//!
//! Take the mission's *events*: the ground station's start and the start and
//! the end of every action (each on its drone). SEQ/PAR nesting, and
//! `Signal`/`Await`, order them: a partial order `<`. Keep its covering pairs `a ⋖ b` whose
//! events happen on different owners `X = loc(a)`, `Y = loc(b)`: cross
//! edges.
//!
//! A slicing preserves the mission's traces, so `b` may only happen once `Y`
//! has heard, through a chain of messages, that `a` happened. Every cross
//! edge `e = (a, b)` therefore makes two *demands*: `S(e)` at `X` (some
//! message leaves `X` after `a`, the first hop of the chain) and `R(e)` at
//! `Y` (some message reaches `Y` before `b`, the last hop). A message from
//! `X` to `Y` may serve several demands at once, but
//!
//! - only `S` demands at its sender and `R` demands at its receiver;
//! - only demands of *compatible* edges: if it serves demands of `(a1, b1)`
//!   and `(a2, b2)` then it is sent after `a1` and `a2` and received before
//!   `b1` and `b2`, so it orders `a1` before `b2` and `a2` before `b1`. If
//!   the mission leaves either pair unordered, a slicing that did so would
//!   lose traces.
//!
//! So a set of demands no two of which one message could serve needs as many
//! messages. The bound is the largest such set (a maximum clique of the
//! "cannot share" graph, computed exactly). In a mission without loops or
//! conditions every bridge carries at most one message per run and every run
//! does everything, so it bounds the bridges too.
//!
//! The mission's end is not an event here. The slicer ends a mission where
//! its drones are (each owner holding part of the last join reaches an end
//! of its own, see the crate docs), and the news that every owner has ended
//! travels as a control notice, not as a bridge: it carries no token of the
//! net. So "every action ends before the mission does" costs no bridge, and
//! an order with the end in it would count demands no slicing pays. (Were
//! the end an event on one owner, as the paper's `final` node of the MDG,
//! the bound would be higher by up to one message per other drone that
//! ends the mission.)
//!
//! Relays are allowed by the argument (a chain may pass through a drone that
//! has nothing to do with the edge): that is why it counts demands per hop
//! end rather than per pair of drones.
//!
//! # Where it is defined
//!
//! For missions built from actions, SEQ/PAR blocks, `PauseFor`, and
//! `Signal`/`Await` with one `Signal` per event. Conditions and loops make
//! the order depend on the run, and a static bridge then serves different
//! messages in different runs; [`lower_bound`] returns `None` for them.

use std::collections::BTreeMap;

use eamos_lang::hir::{Block, BlockKind, Mission, Stmt};

/// Where an event happens: `0` is the ground station, `d + 1` drone `d`.
type Loc = usize;

struct Order {
    /// Location of each node; `None` for virtual nodes (points of the order
    /// that are not events, like "after the signal").
    loc: Vec<Option<Loc>>,
    edges: Vec<(usize, usize)>,
}

impl Order {
    fn node(&mut self, loc: Option<Loc>) -> usize {
        self.loc.push(loc);
        self.loc.len() - 1
    }

    fn after(&mut self, preds: &[usize], loc: Option<Loc>) -> usize {
        let v = self.node(loc);
        for &p in preds {
            self.edges.push((p, v));
        }
        v
    }
}

struct Builder {
    order: Order,
    signals: BTreeMap<String, Vec<usize>>,
    awaits: Vec<(String, usize)>,
}

impl Builder {
    fn block(&mut self, b: &Block, preds: Vec<usize>) -> Option<Vec<usize>> {
        match b.kind {
            BlockKind::Seq => {
                let mut cur = preds;
                for s in &b.stmts {
                    cur = self.stmt(s, cur)?;
                }
                Some(cur)
            }
            BlockKind::Par => {
                if b.stmts.is_empty() {
                    return Some(preds);
                }
                let mut out = Vec::new();
                for s in &b.stmts {
                    out.extend(self.stmt(s, preds.clone())?);
                }
                Some(out)
            }
        }
    }

    fn stmt(&mut self, s: &Stmt, preds: Vec<usize>) -> Option<Vec<usize>> {
        match s {
            Stmt::Action(a) => {
                let loc = Some(a.drone.0 as usize + 1);
                let start = self.order.after(&preds, loc);
                let end = self.order.after(&[start], loc);
                Some(vec![end])
            }
            Stmt::Block(b) => self.block(b, preds),
            Stmt::PauseFor { .. } => Some(preds),
            Stmt::Signal { event, .. } => {
                let v = self.order.after(&preds, None);
                self.signals.entry(event.clone()).or_default().push(v);
                Some(preds)
            }
            Stmt::Await { event, .. } => {
                let v = self.order.after(&preds, None);
                self.awaits.push((event.clone(), v));
                Some(vec![v])
            }
            Stmt::If { .. }
            | Stmt::Wait { .. }
            | Stmt::Repeat { .. }
            | Stmt::RepeatFor { .. }
            | Stmt::Pause { .. }
            | Stmt::Do { .. } => None,
        }
    }
}

/// The lower bound on bridges for a mission, or `None` where it is not
/// defined (see the module docs).
pub fn lower_bound(mission: &Mission) -> Option<usize> {
    let mut b = Builder {
        order: Order {
            loc: Vec::new(),
            edges: Vec::new(),
        },
        signals: BTreeMap::new(),
        awaits: Vec::new(),
    };
    let init = b.order.node(Some(0));
    b.block(&mission.root, vec![init])?;
    for (event, a) in std::mem::take(&mut b.awaits) {
        match b.signals.get(&event).map(Vec::as_slice) {
            Some(&[s]) => b.order.edges.push((s, a)),
            _ => return None,
        }
    }
    let order = b.order;
    let n = order.loc.len();
    // Transitive closure over the (acyclic) order; a cycle (awaits that
    // wait for each other) has no bound to speak of.
    let mut succ = vec![Vec::new(); n];
    for &(a, c) in &order.edges {
        succ[a].push(c);
    }
    let topo = topological(&succ)?;
    let mut below = vec![vec![false; n]; n];
    for &v in topo.iter().rev() {
        for &c in &succ[v] {
            below[v][c] = true;
            let reach = below[c].clone();
            for (x, y) in below[v].iter_mut().zip(reach) {
                *x |= y;
            }
        }
    }
    let events: Vec<usize> = (0..n).filter(|&v| order.loc[v].is_some()).collect();
    let lt = |a: usize, c: usize| below[a][c];
    // Covering pairs between events on different owners.
    let mut cross = Vec::new();
    for &a in &events {
        for &c in &events {
            if lt(a, c)
                && order.loc[a] != order.loc[c]
                && !events.iter().any(|&m| lt(a, m) && lt(m, c))
            {
                cross.push((a, c));
            }
        }
    }
    let compat =
        |e1: (usize, usize), e2: (usize, usize)| e1 == e2 || (lt(e1.0, e2.1) && lt(e2.0, e1.1));
    // Demands: (edge, is_receive, location).
    let demands: Vec<((usize, usize), bool, Loc)> = cross
        .iter()
        .flat_map(|&e| {
            [
                (e, false, order.loc[e.0].expect("event")),
                (e, true, order.loc[e.1].expect("event")),
            ]
        })
        .collect();
    let k = demands.len();
    let mut cannot_share = vec![vec![false; k]; k];
    for i in 0..k {
        for j in 0..k {
            if i == j {
                continue;
            }
            let (e1, r1, l1) = demands[i];
            let (e2, r2, l2) = demands[j];
            let share = if r1 == r2 { l1 == l2 } else { l1 != l2 } && compat(e1, e2);
            cannot_share[i][j] = !share;
        }
    }
    Some(max_clique(&cannot_share))
}

fn topological(succ: &[Vec<usize>]) -> Option<Vec<usize>> {
    let n = succ.len();
    let mut indeg = vec![0; n];
    for s in succ {
        for &c in s {
            indeg[c] += 1;
        }
    }
    let mut stack: Vec<usize> = (0..n).filter(|&v| indeg[v] == 0).collect();
    let mut out = Vec::with_capacity(n);
    while let Some(v) = stack.pop() {
        out.push(v);
        for &c in &succ[v] {
            indeg[c] -= 1;
            if indeg[c] == 0 {
                stack.push(c);
            }
        }
    }
    (out.len() == n).then_some(out)
}

/// Size of a maximum clique, by branch and bound with a greedy colouring
/// bound (Tomita and Seki's MCQ).
fn max_clique(adj: &[Vec<bool>]) -> usize {
    fn expand(adj: &[Vec<bool>], size: usize, cand: Vec<usize>, best: &mut usize) {
        // Colour the candidates greedily; a clique takes at most one vertex
        // of each colour class.
        let mut classes: Vec<Vec<usize>> = Vec::new();
        for &v in &cand {
            match classes.iter_mut().find(|c| c.iter().all(|&u| !adj[u][v])) {
                Some(c) => c.push(v),
                None => classes.push(vec![v]),
            }
        }
        let mut order: Vec<(usize, usize)> = Vec::new();
        for (k, c) in classes.iter().enumerate() {
            for &v in c {
                order.push((v, k + 1));
            }
        }
        let mut remaining: Vec<usize> = order.iter().map(|&(v, _)| v).collect();
        while let Some((v, colour)) = order.pop() {
            if size + colour <= *best {
                return;
            }
            remaining.pop();
            let next: Vec<usize> = remaining.iter().copied().filter(|&u| adj[v][u]).collect();
            if next.is_empty() {
                *best = (*best).max(size + 1);
            } else {
                expand(adj, size + 1, next, best);
            }
        }
    }
    let mut best = 0;
    expand(adj, 0, (0..adj.len()).collect(), &mut best);
    best
}

#[cfg(test)]
mod tests {
    use super::max_clique;

    #[test]
    fn the_maximum_clique_of_a_triangle_with_a_tail_is_three() {
        let mut adj = vec![vec![false; 4]; 4];
        for (a, b) in [(0, 1), (1, 2), (0, 2), (2, 3)] {
            adj[a][b] = true;
            adj[b][a] = true;
        }
        assert_eq!(max_clique(&adj), 3);
    }

    #[test]
    fn a_graph_without_edges_has_cliques_of_one() {
        assert_eq!(max_clique(&vec![vec![false; 3]; 3]), 1);
        assert_eq!(max_clique(&[]), 0);
    }
}
