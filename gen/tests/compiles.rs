//! Every generated mission compiles: many seeds, sizes and fleets, both
//! size units, safe and risky dependencies.

use eamos_gen::{generate, Options, Size};
use eamos_lang::{compile, SourceFile};

fn compiles(options: &Options) {
    let m = generate(options).expect("generates");
    let file = SourceFile::new(format!("gen-{}.go", options.seed), m.text.clone());
    let profiles = eamos_profile::builtin();
    match compile(&file, &profiles) {
        Ok(c) => assert!(
            c.warnings.is_empty(),
            "{options:?} warns:\n{}",
            eamos_lang::render_all(&c.warnings, &file, eamos_lang::Style::PLAIN)
        ),
        Err(d) => panic!(
            "{options:?} does not compile:\n{}\n{}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN),
            m.text
        ),
    }
}

#[test]
fn generated_missions_compile_for_every_seed_size_and_fleet() {
    for seed in 0..40 {
        for (drones, size) in [
            (1, Size::Nodes(6)),
            (1, Size::Nodes(34)),
            (1, Size::Actions(16)),
            (2, Size::Nodes(60)),
            (3, Size::Actions(36)),
            (3, Size::Nodes(150)),
            (7, Size::Nodes(700)),
        ] {
            compiles(&Options::new(drones, size, seed));
        }
    }
}

#[test]
fn large_generated_missions_compile() {
    for seed in 0..3 {
        compiles(&Options::new(20, Size::Nodes(5000), seed));
        compiles(&Options::new(50, Size::Actions(8000), seed));
    }
}

#[test]
fn risky_missions_compile_too() {
    for seed in 0..40 {
        let mut o = Options::new(4, Size::Nodes(300), seed);
        o.risky = true;
        compiles(&o);
    }
}
