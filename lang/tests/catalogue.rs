//! The catalogue of wrong missions: every file under `tests/catalogue/` is a
//! mission with something wrong in it (its first comment says what), and its
//! snapshot is the exact report a person gets: the machine form (code,
//! position, message) and the drawing with the source line and markers.
//! The snapshots are the specification of the diagnostics.

use eamos_lang::{compile, render, SourceFile, Style};

fn report(name: &str, text: &str) -> String {
    let file = SourceFile::new(name, text);
    let profiles = eamos_profile::builtin();
    let (verdict, diags) = match compile(&file, &profiles) {
        Ok(c) => ("compiles, with warnings", c.warnings),
        Err(d) => ("does not compile", d),
    };
    assert!(
        !diags.is_empty(),
        "{name}: a catalogue entry must produce diagnostics"
    );
    for d in &diags {
        assert!(
            d.span.start <= d.span.end && d.span.end as usize <= text.len(),
            "{name}: span out of the file: {d:?}"
        );
    }
    let mut out = format!("{name} {verdict}\n\n");
    for d in &diags {
        out.push_str(&format!("{}\n", d.record(&file)));
    }
    for d in &diags {
        out.push('\n');
        out.push_str(&render(d, &file, Style::PLAIN));
    }
    out
}

fn catalogue() -> Vec<std::path::PathBuf> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/catalogue");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .expect("catalogue directory")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "go"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_wrong_mission_of_the_catalogue_gets_the_diagnostics_of_its_snapshot() {
    // Every file is compared, and every mismatch named, before failing.
    let mut failed = Vec::new();
    for path in catalogue() {
        let text = std::fs::read_to_string(&path).expect("catalogue file is readable");
        let file_name = path.file_name().and_then(|n| n.to_str()).unwrap_or("?");
        let name = format!("catalogue/{file_name}");
        let outcome = std::panic::catch_unwind(|| {
            insta::with_settings!({
                prepend_module_to_snapshot => false,
                snapshot_suffix => file_name,
                input_file => &path,
            }, {
                insta::assert_snapshot!("catalogue", report(&name, &text));
            });
        });
        if outcome.is_err() {
            failed.push(name);
        }
    }
    assert!(
        failed.is_empty(),
        "diagnostics differ from the snapshots for: {failed:#?}"
    );
}

#[test]
fn the_catalogue_holds_at_least_forty_missions() {
    let count = catalogue().len();
    assert!(count >= 40, "only {count} catalogue missions");
}

#[test]
fn every_diagnostic_code_is_shown_by_some_catalogue_mission() {
    // Codes a catalogue file cannot show, and where they are tested instead.
    const ELSEWHERE: &[&str] = &[
        "eamos::mission-too-large", // front_end.rs: calls doubling, calls nested deep
        "eamos::too-complex",       // front_end.rs: thousands of nested brackets
        "eamos::too-many-drones",   // needs 65536 drone declarations
        "eamos::unsupported",       // no built-in profile has such a parameter
        "eamos::not-utf8",          // tests/build_cli.rs: the catalogue is UTF-8 text
    ];
    let snapshots: String =
        std::fs::read_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots"))
            .expect("snapshots")
            .filter_map(|e| e.ok())
            .map(|e| std::fs::read_to_string(e.path()).unwrap_or_default())
            .collect();
    let missing: Vec<&str> = eamos_lang::diag::CODES
        .iter()
        .map(|(code, _)| *code)
        .filter(|code| !ELSEWHERE.contains(code))
        .filter(|code| !snapshots.contains(&format!("[{code}]")))
        .collect();
    assert!(missing.is_empty(), "no catalogue mission shows {missing:?}");
}
