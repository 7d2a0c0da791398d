//! The dining philosophers as a P/T net in PNML: the classic benchmark
//! family of model checkers, for measuring `eamos check` beside them.
//!
//! Philosopher `i` sits between fork `i` (left) and fork `i + 1` (right,
//! modulo `n`). It thinks, takes its first fork, takes its second, eats,
//! and puts both back:
//!
//! | transition | consumes | produces |
//! | --- | --- | --- |
//! | `take1_i` | `think_i`, first fork | `hasfirst_i` |
//! | `take2_i` | `hasfirst_i`, second fork | `eat_i` |
//! | `release_i` | `eat_i` | `think_i`, both forks |
//!
//! [`Table::Symmetric`]: everyone takes the left fork first, so all of them
//! holding their left fork is a deadlock. [`Table::Asymmetric`]: the last
//! philosopher takes the right fork first, which breaks the cycle of waits
//! (the textbook fix): the net is deadlock-free.

use std::fmt::Write;

/// Who takes which fork first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Table {
    /// Every philosopher takes the left fork first: a deadlock.
    Symmetric,
    /// The last philosopher takes the right fork first: deadlock-free.
    Asymmetric,
}

/// The net of `n` philosophers as a PNML document; a table has at least
/// two (fewer are taken as two).
pub fn philosophers(n: usize, table: Table) -> String {
    let n = n.max(2);
    let mut out = String::with_capacity(n * 1400);
    let id = match table {
        Table::Symmetric => format!("philosophers-{n}"),
        Table::Asymmetric => format!("philosophers-asym-{n}"),
    };
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str("<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n");
    let _ = writeln!(
        out,
        "  <net id=\"{id}\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\">"
    );
    let _ = writeln!(
        out,
        "    <name><text>{id}</text></name>\n    <page id=\"page0\">"
    );
    for i in 0..n {
        place(&mut out, &format!("think{i}"), 1);
        place(&mut out, &format!("fork{i}"), 1);
        place(&mut out, &format!("hasfirst{i}"), 0);
        place(&mut out, &format!("eat{i}"), 0);
    }
    for i in 0..n {
        for t in ["take1_", "take2_", "release"] {
            let _ = writeln!(out, "      <transition id=\"{t}{i}\"/>");
        }
    }
    for i in 0..n {
        let (left, right) = (format!("fork{i}"), format!("fork{}", (i + 1) % n));
        let reversed = table == Table::Asymmetric && i == n - 1;
        let (first, second) = if reversed {
            (&right, &left)
        } else {
            (&left, &right)
        };
        let (think, has, eat) = (
            format!("think{i}"),
            format!("hasfirst{i}"),
            format!("eat{i}"),
        );
        let (t1, t2, rel) = (
            format!("take1_{i}"),
            format!("take2_{i}"),
            format!("release{i}"),
        );
        for (s, t) in [
            (&think, &t1),
            (first, &t1),
            (&t1, &has),
            (&has, &t2),
            (second, &t2),
            (&t2, &eat),
            (&eat, &rel),
            (&rel, &think),
            (&rel, &left),
            (&rel, &right),
        ] {
            let _ = writeln!(
                out,
                "      <arc id=\"{s}-{t}\" source=\"{s}\" target=\"{t}\"/>"
            );
        }
    }
    out.push_str("    </page>\n  </net>\n</pnml>\n");
    out
}

fn place(out: &mut String, id: &str, tokens: u32) {
    if tokens == 0 {
        let _ = writeln!(out, "      <place id=\"{id}\"/>");
    } else {
        let _ = writeln!(
            out,
            "      <place id=\"{id}\"><initialMarking><text>{tokens}</text></initialMarking></place>"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_philosopher_has_four_places_three_transitions_and_ten_arcs() {
        let text = philosophers(5, Table::Symmetric);
        assert_eq!(text.matches("<place ").count(), 20);
        assert_eq!(text.matches("<transition ").count(), 15);
        assert_eq!(text.matches("<arc ").count(), 50);
    }

    #[test]
    fn only_the_last_philosopher_of_an_asymmetric_table_takes_the_right_fork_first() {
        let sym = philosophers(3, Table::Symmetric);
        let asym = philosophers(3, Table::Asymmetric);
        assert!(sym.contains("source=\"fork2\" target=\"take1_2\""));
        assert!(asym.contains("source=\"fork0\" target=\"take1_2\""));
        assert!(asym.contains("source=\"fork2\" target=\"take2_2\""));
        assert!(asym.contains("source=\"fork1\" target=\"take1_1\""));
    }
}
