//! `eamos`: compile, check, slice and fly multidrone missions.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod phases;

/// Compile multidrone missions into coloured Petri nets, prove them, slice
/// them per drone and fly them.
#[derive(Parser)]
#[command(name = "eamos", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Build(cmd::build::Args),
    Check(cmd::check::Args),
    View(cmd::view::Args),
    Monitor(cmd::monitor::Args),
    Run(cmd::run::Args),
    Abort(cmd::abort::Args),
    Agent(cmd::agent::Args),
    Deploy(cmd::deploy::Args),
    Router(cmd::router::Args),
    Keygen(cmd::keygen::Args),
    SimVehicle(cmd::sim_vehicle::Args),
    Gen(cmd::gen::Args),
    BenchReport(cmd::bench_report::Args),
    Lsp(cmd::lsp::Args),
}

fn main() -> ExitCode {
    quiet_library_backtraces();
    let cli = Cli::parse();
    match cli.command {
        Command::Build(args) => cmd::build::run(args),
        Command::Check(args) => cmd::check::run(args),
        Command::View(args) => cmd::view::run(args),
        Command::Monitor(args) => cmd::monitor::run(args),
        Command::Run(args) => cmd::run::run(args),
        Command::Abort(args) => cmd::abort::run(args),
        Command::Agent(args) => cmd::agent::run(args),
        Command::Deploy(args) => cmd::deploy::run(args),
        Command::Router(args) => cmd::router::run(args),
        Command::Keygen(args) => cmd::keygen::run(args),
        Command::SimVehicle(args) => cmd::sim_vehicle::run(args),
        Command::Gen(args) => cmd::gen::run(args),
        Command::BenchReport(args) => cmd::bench_report::run(args),
        Command::Lsp(args) => cmd::lsp::run(args),
    }
}

/// Keeps `RUST_BACKTRACE` for panics only, unless the user set
/// `RUST_LIB_BACKTRACE` too. zenoh builds an error, and with
/// `RUST_BACKTRACE=1` a backtrace, for each link it closes and handles it
/// itself: walking the stack read in a megabyte of unwinding tables, the
/// largest part of a drone's peak memory at the end of a flight. Nothing
/// of eamos ever prints a library's backtrace.
fn quiet_library_backtraces() {
    if let Some(value) = library_backtraces(std::env::var_os("RUST_LIB_BACKTRACE")) {
        // Sound here: no other thread exists yet to read the environment.
        std::env::set_var("RUST_LIB_BACKTRACE", value);
    }
}

/// What `RUST_LIB_BACKTRACE` is set to, given the user's own: none where
/// the user chose.
fn library_backtraces(user: Option<std::ffi::OsString>) -> Option<&'static str> {
    user.is_none().then_some("0")
}

#[cfg(test)]
mod tests {
    use super::library_backtraces;

    #[test]
    fn library_backtraces_are_off_unless_the_user_chose() {
        assert_eq!(library_backtraces(None), Some("0"));
        assert_eq!(library_backtraces(Some("1".into())), None);
        assert_eq!(library_backtraces(Some("0".into())), None);
    }
}
