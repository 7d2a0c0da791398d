//! `eamos view MISSION`: the static mission report, one HTML file that
//! opens offline in any browser (plan and side views with the findings of
//! `eamos check`, a timeline per drone, the mission graph beside the
//! source). Exit status: 0 written (findings or not: the report shows
//! them), 2 bad input.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use eamos_lang::Style;

use super::mission::bad_input;

/// Write the mission report: one self-contained HTML file.
#[derive(clap::Args)]
pub struct Args {
    /// The mission (`.go`).
    pub mission: PathBuf,
    /// The fleet file: homes, the airspace (fence, ceiling, floor,
    /// separation) and the origin. Without one: the homes `eamos run`
    /// uses, no fence, no ceiling.
    #[arg(long, value_name = "FLEET")]
    pub fleet: Option<PathBuf>,
    /// Where to write the report [default: the mission's name with
    /// `.html`, in the current directory].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

pub fn run(args: Args) -> ExitCode {
    let name = args.mission.display().to_string();
    let bytes = match std::fs::read(&args.mission) {
        Ok(b) => b,
        Err(e) => return bad_input(&format!("cannot read {name}: {e}")),
    };
    let style = Style {
        width: 100,
        colour: std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none(),
    };
    let diagnostics = |source: &eamos_lang::SourceFile, diags: &[eamos_lang::Diagnostic]| {
        eprint!("{}", eamos_lang::render_all(diags, source, style));
        ExitCode::from(2)
    };
    let source = match eamos_lang::decode(name.clone(), bytes) {
        Ok(s) => s,
        Err((source, diags)) => return diagnostics(&source, &diags),
    };
    let profiles = eamos_profile::builtin();
    let compiled = match eamos_lang::compile(&source, &profiles) {
        Ok(c) => c,
        Err(diags) => return diagnostics(&source, &diags),
    };
    if !compiled.warnings.is_empty() {
        eprint!(
            "{}",
            eamos_lang::render_all(&compiled.warnings, &source, style)
        );
    }
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    let fleet =
        match eamos_fleet::Fleet::load_or_default(args.fleet.as_deref(), &net.name, &net.drones) {
            Ok(f) => f,
            Err(e) => return bad_input(&e.to_string()),
        };
    let (model, findings) = model_of(&source, &net, &profiles, &fleet, true);
    let output = args.output.unwrap_or_else(|| {
        let stem = args
            .mission
            .file_stem()
            .map_or("mission".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}.html"))
    });
    if let Err(e) = std::fs::write(&output, eamos_view::page(&model)) {
        return bad_input(&format!("cannot write {}: {e}", output.display()));
    }
    eprintln!(
        "{}: {} finding(s) of `eamos check`; report written to {}",
        name,
        findings,
        output.display()
    );
    ExitCode::SUCCESS
}

/// The report's model of a compiled mission with its fleet, and how many
/// findings `eamos check` made (the checker runs here, with a progress
/// line on the terminal when `progress`). The monitor serves the same.
pub fn model_of(
    source: &eamos_lang::SourceFile,
    net: &eamos_petri::net::Net,
    profiles: &eamos_profile::ProfileTable,
    fleet: &eamos_fleet::Fleet,
    progress: bool,
) -> (eamos_view::Model, usize) {
    let space = super::mission::space(fleet, &net.drones);
    let mut options = eamos_verify::Options {
        space: Some(space.clone()),
        ..eamos_verify::Options::default()
    };
    if progress {
        options.progress = eamos_verify::terminal_progress();
    }
    let report = eamos_verify::check_net(net, profiles, Some(&source.text), &options);
    let plan = eamos_verify::plan(net, profiles, &space);
    let model = eamos_view::model(&eamos_view::Input {
        source,
        net,
        profiles,
        report: &report,
        plan: &plan,
        space: &space,
        origin: fleet.origin(),
    });
    (model, report.findings.len())
}
