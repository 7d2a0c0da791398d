//! `eamos gen --drones N --nodes K --seed S`: write a stress mission.
//!
//! The mission is valid (it compiles, and its cross-drone dependencies
//! cannot deadlock unless `--risky` asks for ones that may), readable, and
//! the same for the same options. Its size is exact, in nodes of the
//! mission execution graph or in actions (see `eamos_gen` for how both are
//! counted). Exit status: 0 written, 2 bad options or an unwritable file.

use std::path::PathBuf;
use std::process::ExitCode;

use eamos_gen::{generate, Constructs, Options, Size};

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
#[command(group(clap::ArgGroup::new("size").required(true).args(["nodes", "actions"])))]
pub struct Args {
    /// Drones of the mission (named D1, D2, ...).
    #[arg(long, value_name = "N")]
    pub drones: usize,
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
    let size = match (args.nodes, args.actions) {
        (Some(n), _) => Size::Nodes(n),
        (None, Some(m)) => Size::Actions(m),
        (None, None) => {
            eprintln!("error: say how big: --nodes K or --actions M");
            return ExitCode::from(2);
        }
    };
    let options = Options {
        drones: args.drones,
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
    match &args.output {
        None => print!("{}", mission.text),
        Some(path) => {
            if let Err(e) = std::fs::write(path, &mission.text) {
                eprintln!("error: cannot write {}: {e}", path.display());
                return ExitCode::from(2);
            }
            let s = &mission.stats;
            eprintln!(
                "wrote {}: {} drones, {} nodes, {} actions and {} pauses, {} SEQ and {} PAR blocks",
                path.display(),
                s.drones,
                s.nodes,
                s.actions,
                s.pauses,
                s.seq_blocks,
                s.par_blocks
            );
        }
    }
    ExitCode::SUCCESS
}
