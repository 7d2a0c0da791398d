//! The text of a generated mission, as a user would write it: one function
//! per block, control structures naming their bodies, shared bodies and
//! library blocks after the entry point.

use std::fmt::Write as _;

use super::gen::{Spec, C, G, L};

/// Quadcopter actions with the argument lists the generator passes.
pub const ACTIONS: &[(&str, &[&str])] = &[
    ("Takeoff", &["1", "2.5", "4"]),
    ("Land", &[""]),
    ("FlyByX", &["-2", "1", "3.5"]),
    ("FlyByY", &["2", "-0.5"]),
    ("FlyByZ", &["0.5", "-1"]),
    ("FlyTo", &["1, 2, 3", "0, -2, 1.5"]),
    ("Hover", &["0", "1", "2.5"]),
    ("TakePhoto", &[""]),
    ("Arm", &[""]),
    ("ReturnHome", &[""]),
];
pub const SECONDS: &[&str] = &["0.5", "1", "2"];
pub const NUMBERS: &[&str] = &["0", "1", "2.5", "-3", "40"];
pub const COMPARE: &[&str] = &["<", "<=", ">", ">=", "==", "!="];
pub const NUMERIC: &[&str] = &["X", "Y", "Z", "Battery"];

fn write_cond(c: &C, out: &mut String) {
    let num = |d: u16, p: usize| format!("D{}.{}()", d + 1, NUMERIC[p]);
    match c {
        C::Const(b) => write!(out, "{b}"),
        C::Compare(d, p, o, n) => write!(out, "{} {} {}", num(*d, *p), COMPARE[*o], NUMBERS[*n]),
        C::Armed(d) => write!(out, "D{}.IsArmed()", d + 1),
        // The front end refuses a drone's distance to itself.
        C::Distance(a, b, _, n) if a == b => write!(out, "{} < {}", num(*a, 2), NUMBERS[*n]),
        C::Distance(a, b, o, n) => write!(
            out,
            "D{}.DistanceTo(D{}) {} {}",
            a + 1,
            b + 1,
            COMPARE[*o],
            NUMBERS[*n]
        ),
        C::Sum(a, p, b, q, o, n) => write!(
            out,
            "{} + {} {} {}",
            num(*a, *p),
            num(*b, *q),
            COMPARE[*o],
            NUMBERS[*n]
        ),
        C::Not(c) => {
            out.push_str("!(");
            write_cond(c, out);
            write!(out, ")")
        }
        C::And(a, b) | C::Or(a, b) => {
            out.push('(');
            write_cond(a, out);
            out.push_str(if matches!(c, C::And(..)) {
                ") && ("
            } else {
                ") || ("
            });
            write_cond(b, out);
            write!(out, ")")
        }
    }
    .expect("writing to a string");
}

/// Writes the mission text.
struct Writer<'a> {
    spec: &'a Spec,
    functions: Vec<String>,
    signalled: Vec<u8>,
    /// Writing a shared body: it calls no shared body (no recursion).
    in_shared: bool,
}

/// The events some reachable `Signal` (outside loops) names.
fn signals(g: &G, in_loop: bool, out: &mut Vec<u8>) {
    let mut go = |g: &G, l| signals(g, l, out);
    match g {
        G::Signal(k) if !in_loop => out.push(*k),
        G::Seq(v) | G::Par(v) => v.iter().for_each(|g| go(g, in_loop)),
        G::If(_, t, e) => {
            go(t, in_loop);
            if let Some(e) = e {
                go(e, in_loop)
            }
        }
        G::Wait(_, _, t) | G::Do(_, _, t) => go(t, in_loop),
        G::Repeat(_, _, t, x) => {
            go(t, true);
            if let Some(x) = x {
                go(x, in_loop)
            }
        }
        G::RepeatFor(_, t) => go(t, true),
        _ => {}
    }
}

impl Writer<'_> {
    /// A function for `g`, returning its name.
    fn function(&mut self, g: &G, in_loop: bool) -> String {
        if let G::Shared(i) = g {
            if *i < self.spec.shared.len() && !self.in_shared {
                return format!("SEQ_S{i}");
            }
        }
        let (par, items): (bool, Vec<&G>) = match g {
            G::Seq(v) => (false, v.iter().collect()),
            G::Par(v) => (true, v.iter().collect()),
            other => (false, vec![other]),
        };
        let name = format!(
            "{}_B{}",
            if par { "PAR" } else { "SEQ" },
            self.functions.len()
        );
        self.functions.push(String::new());
        let at = self.functions.len() - 1;
        let mut body = String::new();
        for g in items {
            let line = self.stmt(g, in_loop);
            writeln!(body, "\t{line}").expect("writing to a string");
        }
        self.functions[at] = format!("func {name}() {{\n{body}}}\n");
        name
    }

    fn stmt(&mut self, g: &G, in_loop: bool) -> String {
        let c = |c: &C| {
            let mut s = String::new();
            write_cond(c, &mut s);
            s
        };
        let mode = |m: bool| if m { "While" } else { "Until" };
        match g {
            G::Action(d, a, v) => format!("D{}.{}({})", d + 1, ACTIONS[*a].0, ACTIONS[*a].1[*v]),
            G::PauseFor(s) => format!("PauseFor({})", SECONDS[*s]),
            G::Pause(m, cond) => format!("Pause{}({})", mode(*m), c(cond)),
            G::Signal(_) if in_loop => "PauseFor(1)".into(),
            G::Signal(k) => format!("Signal(\"e{k}\")"),
            G::Await(k) if self.signalled.contains(k) => format!("Await(\"e{k}\")"),
            G::Await(_) => "PauseFor(2)".into(),
            G::Shared(i) if *i < self.spec.shared.len() && !self.in_shared => {
                format!("SEQ_S{i}()")
            }
            G::Shared(_) => "PauseFor(0.5)".into(),
            G::Library(l, d, k) if *l < self.spec.library.len() => {
                let kind = if self.spec.library[*l].0 {
                    "PAR"
                } else {
                    "SEQ"
                };
                format!("{kind}_L{l}(D{}, {})", d + 1, SECONDS[*k])
            }
            G::Library(_, d, _) => format!("D{}.TakePhoto()", d + 1),
            G::Seq(_) | G::Par(_) => format!("{}()", self.function(g, in_loop)),
            G::If(cond, t, e) => {
                let t = self.function(t, in_loop);
                match e {
                    Some(e) => format!("If({}, {t}, {})", c(cond), self.function(e, in_loop)),
                    None => format!("If({}, {t})", c(cond)),
                }
            }
            G::Wait(m, cond, t) => {
                format!(
                    "Wait{}({}, {})",
                    mode(*m),
                    c(cond),
                    self.function(t, in_loop)
                )
            }
            G::Repeat(m, cond, t, x) => {
                let t = self.function(t, true);
                match x {
                    Some(x) => {
                        let x = self.function(x, in_loop);
                        format!("Repeat{}({}, {t}, {x})", mode(*m), c(cond))
                    }
                    None => format!("Repeat{}({}, {t})", mode(*m), c(cond)),
                }
            }
            G::RepeatFor(n, t) => format!("RepeatFor({n}, {})", self.function(t, true)),
            G::Do(m, cond, t) => {
                format!("Do{}({}, {})", mode(*m), c(cond), self.function(t, in_loop))
            }
        }
    }
}

/// The mission text of a spec.
pub fn write(spec: &Spec) -> String {
    let mut signalled = Vec::new();
    for g in &spec.root {
        signals(g, false, &mut signalled);
    }
    let mut w = Writer {
        spec,
        functions: Vec::new(),
        signalled,
        in_shared: false,
    };
    let mut out = String::from("package Random\n\nvar (\n");
    for d in 1..=spec.drones {
        writeln!(out, "\tD{d} Quadcopter").expect("writing to a string");
    }
    out.push_str(")\n\nfunc INIT() {\n");
    for g in &spec.root {
        let line = w.stmt(g, false);
        writeln!(out, "\t{line}").expect("writing to a string");
    }
    out.push_str("}\n");
    // Shared bodies may run inside loops, so they signal nothing.
    w.in_shared = true;
    for (i, g) in spec.shared.iter().enumerate() {
        let items: Vec<&G> = match g {
            G::Seq(v) => v.iter().collect(),
            other => vec![other],
        };
        let mut body = String::new();
        for g in items {
            let line = w.stmt(g, true);
            writeln!(body, "\t{line}").expect("writing to a string");
        }
        w.functions.push(format!("func SEQ_S{i}() {{\n{body}}}\n"));
    }
    for (l, (par, stmts)) in spec.library.iter().enumerate() {
        let kind = if *par { "PAR" } else { "SEQ" };
        let mut body = String::new();
        for s in stmts {
            let line = match s {
                L::Fly => "d.FlyByX(k)",
                L::Hover => "d.Hover(k)",
                L::Photo => "d.TakePhoto()",
                L::Pause => "PauseFor(k)",
                L::PauseUntilHigh => "PauseUntil(d.Z() >= k)",
                L::PauseWhileLow => "PauseWhile(d.Battery() < k * 10)",
            };
            writeln!(body, "\t{line}").expect("writing to a string");
        }
        w.functions.push(format!(
            "func {kind}_L{l}(d Quadcopter, k float64) {{\n{body}}}\n"
        ));
    }
    for f in &w.functions {
        out.push('\n');
        out.push_str(f);
    }
    out
}
