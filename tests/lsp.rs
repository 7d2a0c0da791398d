//! `eamos lsp` driven by an independent language client: the pytest-lsp
//! suite in `tests/lsp/` (a mission author's session, and a client that
//! misbehaves) run against this build's binary.
//!
//! pytest-lsp is a test requirement (`scripts/test-requirements.txt`): if
//! python3 or pytest-lsp is missing the test fails, it does not skip.

use std::path::PathBuf;
use std::process::Command;

#[test]
fn an_independent_language_client_passes_the_lsp_suite() {
    let probe = Command::new("python3")
        .args(["-c", "import pytest_lsp"])
        .output()
        .unwrap_or_else(|e| panic!("python3 is needed to run the language server's tests: {e}"));
    assert!(
        probe.status.success(),
        "pytest-lsp is needed for this test: `pip install -r scripts/test-requirements.txt`\n{}",
        String::from_utf8_lossy(&probe.stderr)
    );
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new("python3")
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "."])
        .current_dir(root.join("tests/lsp"))
        .env("EAMOS_BIN", env!("CARGO_BIN_EXE_eamos"))
        .env("EAMOS_PAPER", root.join("../shared/missions/paper"))
        .output()
        .expect("pytest runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the language server's suite failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("passed"), "{stdout}");
}
