//! Nodes of the mission execution graph of any compiled mission, counted as
//! the generator counts them (see the crate documentation), so that a
//! generated mission's size can be checked against what the front end made
//! of it and the paper's missions can be measured alike.

use eamos_lang::hir::{Block, BlockKind, Mission, Stmt};

/// Nodes of the mission execution graph of `mission`.
pub fn nodes(mission: &Mission) -> usize {
    2 + block(&mission.root)
}

fn block(b: &Block) -> usize {
    let fork_join = if b.kind == BlockKind::Par && b.stmts.len() >= 2 {
        2
    } else {
        0
    };
    fork_join + b.stmts.iter().map(stmt).sum::<usize>()
}

fn stmt(s: &Stmt) -> usize {
    match s {
        Stmt::Action(_)
        | Stmt::Pause { .. }
        | Stmt::PauseFor { .. }
        | Stmt::Signal { .. }
        | Stmt::Await { .. } => 1,
        Stmt::Block(b) => block(b),
        Stmt::If { .. }
        | Stmt::Wait { .. }
        | Stmt::Repeat { .. }
        | Stmt::RepeatFor { .. }
        | Stmt::Do { .. } => 2 + s.blocks().into_iter().map(block).sum::<usize>(),
    }
}
