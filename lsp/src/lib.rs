//! The language server behind `eamos lsp`: mission files with live help.
//!
//! On every edit the front end (`eamos-lang`) runs again and its
//! diagnostics, the very ones `eamos build` prints (codes, hints, "did you
//! mean"), are published; on every save `eamos check` runs on a worker
//! thread with the fleet file beside the mission, and its findings join
//! them, each with its counterexample as related information. Hover,
//! completion, go to definition, references, rename, the outline and the
//! quick fixes all read one index of the syntax tree (`index`).
//!
//! Architecture invariant: this crate is a leaf. It reads the front end,
//! the profiles, the fleet file and the checker; nothing but the command
//! line depends on it, and `lang` stays free of it (and of any runtime).
//! The protocol's types appear here only; the findings of the front end
//! and of the checker become diagnostics in one place, `proto`.

mod capabilities;
mod check;
mod complete;
mod doc;
mod fix;
mod fleet;
mod hover;
mod index;
mod navigate;
mod position;
mod profile_doc;
mod proto;
mod server;
mod transport;

use std::io::{BufReader, Read, Write};

pub use server::serve;

/// Serves one client over the given streams until it says `exit` or its
/// input ends.
pub fn run(input: impl Read + Send + 'static, output: impl Write + Send + 'static) {
    let (conn, io) = transport::connect(BufReader::new(input), output);
    serve(conn);
    io.join();
}

/// `eamos lsp`: serves the editor over standard input and output.
pub fn stdio() {
    run(std::io::stdin(), std::io::stdout());
}
