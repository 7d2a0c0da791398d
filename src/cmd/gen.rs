//! `eamos gen --drones N --nodes K --seed S`: write a stress mission; or
//! `eamos gen --philosophers N [--asymmetric]`: the benchmark net.
//!
//! The mission is valid (it compiles, and its cross-drone dependencies
//! cannot deadlock unless `--risky` asks for ones that may), readable, and
//! the same for the same options. Its size is exact, in nodes of the
//! mission execution graph or in actions (see `eamos_gen` for how both are
//! counted). Exit status: 0 written, 2 bad options or an unwritable file.

use std::path::PathBuf;
use std::process::ExitCode;

use eamos_gen::{generate, philosophers, Constructs, Options, Size, Table};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Mix {
    /// Every statement of the language.
    All,
    /// What the paper's experiments use: WaitUntil and RepeatWhile.
    Paper,
    /// No If, condition loop or Do: every run takes the same path.
    WithoutChoices,
}

/// Write a valid, readable stress mission of an exact size.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("size").args(["nodes", "actions"])))]
pub struct Args {
    /// Drones of the mission (named D1, D2, ...).
    #[arg(
        long,
        value_name = "N",
        required_unless_present = "philosophers",
        requires = "size"
    )]
    pub drones: Option<usize>,
    /// Instead of a mission, the P/T net (PNML) of N dining philosophers,
    /// each taking the left fork first: the classic benchmark of model
    /// checkers, with a deadlock.
    #[arg(long, value_name = "N", conflicts_with_all = ["drones", "nodes", "actions", "risky"])]
    pub philosophers: Option<usize>,
    /// With `--philosophers`: the last one takes the right fork first,
    /// which makes the net deadlock-free.
    #[arg(long, requires = "philosophers")]
    pub asymmetric: bool,
    /// Size in nodes of the mission execution graph: actions, pauses,
    /// Signal and Await count one each, a PAR block of two statements or
    /// more two (fork, join), a control structure two (decision, merge),
    /// and the mission's start and end two.
    #[arg(long, value_name = "K")]
    pub nodes: Option<usize>,
    /// Size in actions as the paper counts them: drone actions and
    /// `PauseFor` pauses.
    #[arg(long, value_name = "M")]
    pub actions: Option<usize>,
    /// Same seed, same mission.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// The mission's `package` name.
    #[arg(long, default_value = "Stress")]
    pub name: String,
    /// Also generate Signal/Await pairs that may deadlock (for the checker).
    #[arg(long)]
    pub risky: bool,
    /// Which statements beyond actions, pauses and blocks may appear.
    #[arg(long, value_enum, default_value_t = Mix::All)]
    pub constructs: Mix,
    /// Write the mission here instead of standard output.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args) -> ExitCode {
    if let Some(n) = args.philosophers {
        if n < 2 {
            eprintln!("error: `--philosophers {n}`: a table needs at least two philosophers");
            return ExitCode::from(2);
        }
        let table = if args.asymmetric {
            Table::Asymmetric
        } else {
            Table::Symmetric
        };
        return write(&args.output, &philosophers(n, table), || {
            format!("{n} philosophers")
        });
    }
    let size = match (args.nodes, args.actions) {
        (Some(n), _) => Size::Nodes(n),
        (None, Some(m)) => Size::Actions(m),
        (None, None) => {
            eprintln!("error: say how big: --nodes K or --actions M");
            return ExitCode::from(2);
        }
    };
    let options = Options {
        drones: args.drones.unwrap_or(0),
        size,
        seed: args.seed,
        name: args.name,
        risky: args.risky,
        constructs: match args.constructs {
            Mix::All => Constructs::ALL,
            Mix::Paper => Constructs::PAPER,
            Mix::WithoutChoices => Constructs::WITHOUT_CHOICES,
        },
    };
    let mission = match generate(&options) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let s = &mission.stats;
    write(&args.output, &mission.text, || {
        format!(
            "{} drones, {} nodes, {} actions and {} pauses, {} SEQ and {} PAR blocks",
            s.drones, s.nodes, s.actions, s.pauses, s.seq_blocks, s.par_blocks
        )
    })
}

/// Prints `text`, or writes it to `output` and says what it wrote.
fn write(output: &Option<PathBuf>, text: &str, what: impl FnOnce() -> String) -> ExitCode {
    match output {
        None => print!("{text}"),
        Some(path) => {
            if let Err(e) = std::fs::write(path, text) {
                eprintln!("error: cannot write {}: {e}", path.display());
                return ExitCode::from(2);
            }
            eprintln!("wrote {}: {}", path.display(), what());
        }
    }
    ExitCode::SUCCESS
}
