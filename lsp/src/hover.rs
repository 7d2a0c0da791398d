//! Hover: what the name under the cursor is, from the profile (actions,
//! properties) or from the file itself (blocks, events, drones).

use std::fmt::Write as _;

use eamos_lang::ast::ControlKind;
use eamos_profile::ProfileTable;
use lsp_types::{Hover, HoverContents, MarkupContent, MarkupKind};

use crate::doc::Doc;
use crate::index::{Kind, Occurrence};
use crate::profile_doc;

pub fn hover(doc: &Doc, profiles: &ProfileTable, offset: usize) -> Option<Hover> {
    let occ = doc.index.at(offset)?;
    let text = markdown(doc, profiles, occ, offset)?;
    Some(Hover {
        contents: HoverContents::Markup(MarkupContent {
            kind: MarkupKind::Markdown,
            value: text,
        }),
        range: Some(doc.range(occ.span)),
    })
}

fn markdown(doc: &Doc, profiles: &ProfileTable, occ: &Occurrence, offset: usize) -> Option<String> {
    let ix = &doc.index;
    match occ.kind {
        Kind::Action | Kind::Property => {
            let owner = occ.owner.as_deref()?;
            let ty = ix.drone_type(owner, ix.func_at(offset))?;
            let profile = profiles.get(ty)?;
            if occ.kind == Kind::Action {
                let sig = profile.actions.get(&occ.name)?;
                Some(profile_doc::action(profile, &occ.name, sig))
            } else {
                let sig = profile.properties.get(&occ.name)?;
                Some(profile_doc::property(profile, &occ.name, sig))
            }
        }
        Kind::Block => {
            let f = &ix.funcs[ix.func_named(&occ.name)?];
            let kind = if f.name.starts_with("PAR_") {
                "PAR block: its statements run in parallel; it ends when all have ended"
            } else {
                "SEQ block: its statements run one after the other"
            };
            let params: Vec<String> = f.params.iter().map(|(n, t)| format!("{n} {t}")).collect();
            let mut s = format!(
                "```go\nfunc {}({})\n```\n{kind}\n",
                f.name,
                params.join(", ")
            );
            let drones = ix.drones_of(ix.func_named(&occ.name)?);
            if drones.is_empty() {
                s.push_str("\ndrones: none\n");
            } else {
                let _ = writeln!(s, "\ndrones: {}", drones.join(", "));
            }
            let calls = ix.all_of(Kind::Block, &occ.name).filter(|o| !o.def).count();
            let _ = writeln!(s, "\ncalled or passed {calls} time(s)");
            Some(s)
        }
        Kind::Event => {
            let line = |o: &Occurrence| doc.range(o.span).start.line + 1;
            let sites = |def: bool| -> String {
                let lines: Vec<String> = ix
                    .all_of(Kind::Event, &occ.name)
                    .filter(|o| o.def == def)
                    .map(|o| format!("line {}", line(o)))
                    .collect();
                if lines.is_empty() {
                    "nowhere".into()
                } else {
                    lines.join(", ")
                }
            };
            Some(format!(
                "event `{}`\n\n- `Signal` at {}\n- `Await` at {}\n",
                occ.name,
                sites(true),
                sites(false)
            ))
        }
        Kind::Drone => {
            let d = ix.drones.iter().find(|d| d.name == occ.name)?;
            let about = profiles.get(&d.ty).map_or("", |p| p.description.as_str());
            Some(format!("```go\nvar {} {}\n```\n{about}\n", d.name, d.ty))
        }
        Kind::Const => Some(format!("constant `{}`", occ.name)),
        Kind::Control => {
            let k = ControlKind::from_name(&occ.name)?;
            Some(format!("control structure\n\n```go\n{}\n```\n", k.usage()))
        }
    }
}
