//! `eamos lsp`: the language server, for editors (glue: `eamos-lsp`).
//! Exit status: 0 when the client has gone (after `exit` or the end of its
//! input).

use std::process::ExitCode;

/// Serve mission files to an editor over the Language Server Protocol
/// (standard input and output): diagnostics as you type, `eamos check` on
/// save, hover, completion, go to definition, rename.
#[derive(clap::Args)]
pub struct Args {
    /// Standard input and output (the only transport; accepted because
    /// editors' clients pass it).
    #[arg(long)]
    pub stdio: bool,
}

pub fn run(_args: Args) -> ExitCode {
    eamos_lsp::stdio();
    ExitCode::SUCCESS
}
