//! A drone type's profile told as Markdown: what hover shows and what
//! completion items carry as documentation. Everything here is read from
//! the profile's data, never written twice.

use std::fmt::Write as _;

use eamos_profile::{ActionSig, Param, ParamKind, Profile, PropertySig, ValueType};

pub fn unit(kind: ParamKind) -> &'static str {
    match kind {
        ParamKind::Metres => "metres",
        ParamKind::Seconds => "seconds",
        ParamKind::Degrees => "degrees",
        ParamKind::Percent => "percent",
        ParamKind::Number => "number",
        ParamKind::Drone => "drone",
    }
}

/// `height: metres, > 0, at most the ceiling`.
pub fn param(p: &Param) -> String {
    let mut s = format!("`{}`: {}", p.name, unit(p.kind));
    if let Some(min) = p.min {
        let _ = write!(s, ", at least {min}");
    }
    if let Some(above) = p.above {
        let _ = write!(s, ", above {above}");
    }
    if let Some(max) = p.max {
        let _ = write!(s, ", at most {max}");
    }
    if p.ceiling {
        s.push_str(", at most the airspace's ceiling");
    }
    s
}

/// `Takeoff(height)`.
pub fn signature(name: &str, params: &[Param]) -> String {
    let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
    format!("{name}({})", names.join(", "))
}

/// `Takeoff(${1:height})`: the call with a tab stop per argument.
pub fn snippet(name: &str, params: &[Param]) -> String {
    let stops: Vec<String> = params
        .iter()
        .enumerate()
        .map(|(i, p)| format!("${{{}:{}}}", i + 1, p.name))
        .collect();
    format!("{name}({})", stops.join(", "))
}

pub fn action(profile: &Profile, name: &str, sig: &ActionSig) -> String {
    let mut s = format!(
        "```go\n{}.{}\n```\naction of `{}`\n\n{}\n",
        profile.name,
        signature(name, &sig.params),
        profile.name,
        sig.description
    );
    if !sig.params.is_empty() {
        s.push_str("\nparameters:\n");
        for p in &sig.params {
            let _ = writeln!(s, "- {}", param(p));
        }
    }
    if let Some(flight) = &sig.flight {
        let states: Vec<String> = flight
            .iter()
            .map(|(from, to)| format!("{from} → {to}"))
            .collect();
        let _ = writeln!(s, "\nflight states: {}", states.join(", "));
    }
    if !sig.resources.is_empty() {
        let _ = writeln!(s, "\nholds: {}", sig.resources.join(", "));
    }
    s
}

pub fn property(profile: &Profile, name: &str, sig: &PropertySig) -> String {
    let mut s = format!(
        "```go\n{}.{}\n```\nproperty of `{}`: {}",
        profile.name,
        signature(name, &sig.params),
        profile.name,
        match sig.ty {
            ValueType::Number => "number",
            ValueType::Bool => "bool",
        }
    );
    if let Some(unit) = sig.unit {
        let _ = write!(s, ", in {}", format!("{unit:?}").to_lowercase());
    }
    if let Some((lo, hi)) = sig.range {
        let _ = write!(s, ", from {lo} to {hi}");
    }
    let _ = write!(s, "\n\n{}\n", sig.description);
    if !sig.params.is_empty() {
        s.push_str("\nparameters:\n");
        for p in &sig.params {
            let _ = writeln!(s, "- {}", param(p));
        }
    }
    s
}
