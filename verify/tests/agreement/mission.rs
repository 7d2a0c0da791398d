//! Random small missions in the mission language, through the real front
//! end and net compiler: one to three drones, SEQ and PAR blocks (some
//! called twice, so their actions have several instances), every control
//! structure (`RepeatFor` with its colours, nested loops, `Do` regions),
//! `Signal`/`Await` in any order (so they may deadlock), two actions of one
//! drone in parallel (so they may conflict), and now and then a condition
//! that can never hold or always holds. Unlike `eamos gen`'s missions, they
//! are not meant to fly: they are meant to find the corners.

use eamos_petri::net::Net;
use eamos_profile::ProfileTable;
use rand::seq::IndexedRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Leaf statements at most, so that state spaces stay small.
const LEAVES: usize = 12;
const ACTIONS: [&str; 8] = [
    "Arm()",
    "Takeoff(2)",
    "FlyByX(1)",
    "FlyByY(-1)",
    "Hover(1)",
    "TakePhoto()",
    "TurnOnCamera()",
    "Land()",
];

struct Block {
    name: String,
    body: Vec<String>,
    /// A `Signal` in it or in what it calls: it may not go into a loop.
    signals: bool,
}

/// Blocks being written, innermost last: whether a `Signal` is in each.
type Open = Vec<bool>;

struct Gen {
    rng: ChaCha8Rng,
    drones: usize,
    blocks: Vec<Block>,
    leaves: usize,
    signalled: Vec<usize>,
    awaited: Vec<usize>,
    open: Open,
}

/// The mission text of `seed`.
pub fn random(seed: u64) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let drones = rng.random_range(1..=3);
    let mut g = Gen {
        rng,
        drones,
        blocks: Vec::new(),
        leaves: 0,
        signalled: Vec::new(),
        awaited: Vec::new(),
        open: Vec::new(),
    };
    let mut main = Vec::new();
    let n = g.rng.random_range(2..=4);
    for _ in 0..n {
        let s = g.statement(0, false);
        main.push(s);
    }
    // Every awaited event is signalled somewhere (else the front end
    // refuses the mission): at the start, or at the end of everything.
    for e in g.awaited.clone() {
        if !g.signalled.contains(&e) {
            let s = format!("Signal(\"e{e}\")");
            if g.rng.random_bool(0.5) {
                main.insert(0, s);
            } else {
                main.push(s);
            }
        }
    }
    let mut text = String::from("package Random\n\nvar (\n");
    for d in 1..=drones {
        text.push_str(&format!("\tD{d} Quadcopter\n"));
    }
    text.push_str(")\n\nfunc SEQ_Main() {\n");
    for s in &main {
        text.push_str(&format!("\t{s}\n"));
    }
    text.push_str("}\n");
    for b in &g.blocks {
        text.push_str(&format!("\nfunc {}() {{\n", b.name));
        for s in &b.body {
            text.push_str(&format!("\t{s}\n"));
        }
        text.push_str("}\n");
    }
    text
}

impl Gen {
    fn drone(&mut self) -> usize {
        self.rng.random_range(1..=self.drones)
    }

    /// A condition over one or two drones; one in twenty can never hold or
    /// always holds.
    fn condition(&mut self) -> String {
        let d = self.drone();
        let e = self.drone();
        match self.rng.random_range(0..20) {
            0 => format!("D{d}.Battery() > 120"),
            1 => format!("D{d}.Battery() >= 0"),
            2..=6 => format!("D{d}.X() > {}", self.rng.random_range(0..3)),
            7..=10 => format!("D{d}.Z() >= 2"),
            11..=13 => format!("D{d}.Battery() > 50"),
            14..=15 if d != e => format!("D{d}.DistanceTo(D{e}) < 3"),
            _ => format!("D{d}.X() > 1 && D{e}.Z() < 3"),
        }
    }

    /// A statement at nesting `depth`; `looped` inside a loop, where no
    /// `Signal` may go.
    fn statement(&mut self, depth: usize, looped: bool) -> String {
        if self.leaves >= LEAVES || depth >= 3 {
            return self.leaf(looped);
        }
        let c = self.condition();
        match self.rng.random_range(0..100) {
            0..=39 => self.leaf(looped),
            40..=54 => format!("{}()", self.block(depth, looped)),
            55..=62 => {
                let then = self.block(depth, looped);
                if self.rng.random_bool(0.5) {
                    let other = self.block(depth, looped);
                    format!("If({c}, {then}, {other})")
                } else {
                    format!("If({c}, {then})")
                }
            }
            63..=66 => {
                let body = self.block(depth, looped);
                let wait = ["WaitUntil", "WaitWhile"].choose(&mut self.rng).unwrap();
                format!("{wait}({c}, {body})")
            }
            67..=74 => {
                let n = self.rng.random_range(0..=3);
                let body = self.block(depth, true);
                format!("RepeatFor({n}, {body})")
            }
            75..=81 => {
                let body = self.block(depth, true);
                let repeat = ["RepeatWhile", "RepeatUntil"]
                    .choose(&mut self.rng)
                    .unwrap();
                if self.rng.random_bool(0.3) {
                    let exit = self.block(depth, true);
                    format!("{repeat}({c}, {body}, {exit})")
                } else {
                    format!("{repeat}({c}, {body})")
                }
            }
            82..=88 => {
                let body = self.block(depth, looped);
                let region = ["DoWhile", "DoUntil"].choose(&mut self.rng).unwrap();
                format!("{region}({c}, {body})")
            }
            89..=91 => {
                let pause = ["PauseUntil", "PauseWhile"].choose(&mut self.rng).unwrap();
                format!("{pause}({c})")
            }
            _ => self.leaf(looped),
        }
    }

    /// An action, a pause, a `Signal` or an `Await`.
    fn leaf(&mut self, looped: bool) -> String {
        self.leaves += 1;
        let e = self.rng.random_range(0..3);
        match self.rng.random_range(0..100) {
            0..=11 if !looped => {
                self.signalled.push(e);
                self.open.iter_mut().for_each(|s| *s = true);
                format!("Signal(\"e{e}\")")
            }
            12..=23 => {
                self.awaited.push(e);
                format!("Await(\"e{e}\")")
            }
            24..=29 => "PauseFor(1)".into(),
            _ => {
                let d = self.drone();
                let a = ACTIONS.choose(&mut self.rng).unwrap();
                format!("D{d}.{a}")
            }
        }
    }

    /// A call of a new block, or now and then of one already written (a
    /// second instance of it).
    fn block(&mut self, depth: usize, looped: bool) -> String {
        let reusable: Vec<usize> = (0..self.blocks.len())
            .filter(|&b| !(looped && self.blocks[b].signals))
            .collect();
        if !reusable.is_empty() && self.rng.random_bool(0.2) {
            let b = *reusable.choose(&mut self.rng).unwrap();
            if self.blocks[b].signals {
                self.open.iter_mut().for_each(|s| *s = true);
            }
            return self.blocks[b].name.clone();
        }
        let par = self.rng.random_bool(0.4);
        self.open.push(false);
        let n = self.rng.random_range(1..=3);
        let body: Vec<String> = (0..n).map(|_| self.statement(depth + 1, looped)).collect();
        let signals = self.open.pop().unwrap_or(false);
        let name = format!("{}_B{}", if par { "PAR" } else { "SEQ" }, self.blocks.len());
        self.blocks.push(Block {
            name: name.clone(),
            body,
            signals,
        });
        name
    }
}

/// Compiles a mission; the text is in the error when the front end
/// refuses it (the generators must not write such missions).
pub fn compile(text: &str, profiles: &ProfileTable) -> Result<Net, String> {
    let file = eamos_lang::SourceFile::new("random.go", text.to_string());
    let compiled = eamos_lang::compile(&file, profiles).map_err(|d| {
        let why = eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN);
        format!("does not compile:\n{why}\n{text}")
    })?;
    Ok(eamos_petri::compile(&compiled.mission, profiles))
}
