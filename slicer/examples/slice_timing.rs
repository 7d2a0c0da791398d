//! How long the whole compile of a generated stress mission takes, stage by
//! stage: parse and check, net, slices. Speed goals live here and in the
//! benchmarks, never in tests (machines are noisy).
//!
//! ```text
//! cargo run --release -p eamos-slicer --example slice_timing -- 20 1000 5000 20000 100000
//! ```
//!
//! The first argument is the number of drones, the others are sizes in
//! nodes of the mission execution graph (see `eamos_gen`). Prints, per
//! size, the best of a few runs of each stage and the bridges per owner.

use std::time::{Duration, Instant};

use eamos_gen::{generate, Options, Size};
use eamos_lang::SourceFile;

fn profiles() -> eamos_profile::ProfileTable {
    eamos_profile::builtin()
}

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut out = None;
    for _ in 0..runs {
        let start = Instant::now();
        let r = f();
        best = best.min(start.elapsed());
        out = Some(r);
    }
    (best, out.expect("at least one run"))
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("numbers: drones, then sizes in nodes"))
        .collect();
    let (drones, sizes) = match args.split_first() {
        Some((&d, s)) if !s.is_empty() => (d, s.to_vec()),
        _ => (20, vec![1000, 5000, 20_000, 100_000]),
    };
    let profiles = profiles();
    println!("drones  nodes  net nodes   check ms    net ms  slice ms  total ms  bridges");
    for n in sizes {
        let generated = generate(&Options::new(drones, Size::Nodes(n), 1)).expect("generates");
        let file = SourceFile::new("stress.go", generated.text);
        let runs = if n >= 50_000 { 3 } else { 7 };
        let (t_check, mission) = best(runs, || {
            eamos_lang::compile(&file, &profiles)
                .expect("generated missions compile")
                .mission
        });
        let (t_net, net) = best(runs, || eamos_petri::compile(&mission, &profiles));
        let (t_slice, slices) = best(runs, || eamos_slicer::slice(&net).expect("slices"));
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        println!(
            "{drones:>6} {n:>6} {:>10} {:>10.2} {:>9.2} {:>9.2} {:>9.2}  {}",
            net.graph.node_count(),
            ms(t_check),
            ms(t_net),
            ms(t_slice),
            ms(t_check + t_net + t_slice),
            slices.bridge_count()
        );
    }
}
