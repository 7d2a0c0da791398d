//! Reading P/T nets from PNML, so that the checker can be compared with
//! other Petri net tools on the same nets.
//!
//! Accepted: the PNML place/transition net grammar (`net`, nested `page`s,
//! `place` with `initialMarking`, `transition`, `arc` with `inscription`,
//! `referencePlace`/`referenceTransition`), arc types `normal` and
//! `test`/`read` (as written by TAPAAL and others), and eamos' own
//! `toolspecific tool="eamos"` data: a place carrying `<final/>` (or a place
//! with id `final`) marks the end of the run; an arc carrying `<read/>` is a
//! read arc, and its `<readReturn/>` partner (the self-loop plain P/T
//! readers see) is dropped, as is the `final-loop` transition. Inhibitor, reset and transport arcs are refused with their
//! position rather than silently misread. Only the first `net` of a file is
//! read.

use std::collections::HashMap;

use eamos_lang::span::SourceFile;
use eamos_lang::Span;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::check::Subject;
use crate::ptnet::{PlaceInfo, PtNet, RawTransition, StepInfo};
use crate::report::InputKind;

/// A PNML file that cannot be read, with where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{col}: {message}")]
pub struct PnmlError {
    pub file: String,
    pub line: u32,
    pub col: u32,
    pub message: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PnmlPlace {
    pub id: String,
    pub name: String,
    pub initial: u32,
    pub is_final: bool,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PnmlTransition {
    pub id: String,
    pub name: String,
    pub span: Span,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PnmlArcKind {
    Normal,
    Read,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PnmlArc {
    pub id: String,
    pub source: String,
    pub target: String,
    pub weight: u32,
    pub kind: PnmlArcKind,
    pub span: Span,
}

/// A P/T net read from PNML.
#[derive(Debug, Clone, PartialEq)]
pub struct PnmlNet {
    pub id: String,
    pub name: String,
    pub places: Vec<PnmlPlace>,
    pub transitions: Vec<PnmlTransition>,
    pub arcs: Vec<PnmlArc>,
    /// Ids of transitions left out (eamos' `final-loop`); their arcs go too.
    pub skipped: Vec<String>,
}

#[derive(Default)]
struct Open {
    kind: Elem,
    id: String,
    name: String,
    marking: String,
    inscription: String,
    arc_type: Option<String>,
    source: String,
    target: String,
    tool_eamos_final: bool,
    tool_eamos_read: bool,
    /// The return half of a read arc as eamos exports it (a self-loop for
    /// plain P/T readers): dropped, the read arc says it all.
    tool_eamos_read_return: bool,
    /// `<kind>` of a transition in eamos' data.
    tool_eamos_kind: String,
    start: usize,
    end: usize,
}

#[derive(Default, Clone, Copy, PartialEq, Eq, Debug)]
enum Elem {
    #[default]
    None,
    Place,
    Transition,
    Arc,
}

fn attr(e: &BytesStart, name: &[u8]) -> Result<Option<String>, String> {
    for a in e.attributes() {
        let a = a.map_err(|err| format!("malformed attribute: {err}"))?;
        if a.key.local_name().as_ref() == name {
            let v = a
                .unescape_value()
                .map_err(|err| format!("malformed attribute value: {err}"))?;
            return Ok(Some(v.into_owned()));
        }
    }
    Ok(None)
}

fn entity(name: &str) -> Option<char> {
    Some(match name {
        "amp" => '&',
        "lt" => '<',
        "gt" => '>',
        "quot" => '"',
        "apos" => '\'',
        _ => return None,
    })
}

/// Reads the first net of a PNML document.
pub fn parse(file: &str, text: &str) -> Result<PnmlNet, PnmlError> {
    let src = SourceFile::new(file, text);
    let err_at = |pos: usize, message: String| {
        let lc = src.line_col(pos as u32);
        PnmlError {
            file: file.to_string(),
            line: lc.line,
            col: lc.col,
            message,
        }
    };
    let mut reader = Reader::from_str(text);
    reader.config_mut().trim_text(true);
    let mut path: Vec<String> = Vec::new();
    let mut net: Option<PnmlNet> = None;
    let mut nets_seen = 0usize;
    let mut open = Open::default();
    // Aliases of reference nodes.
    let mut refs: HashMap<String, (String, usize)> = HashMap::new();
    let mut text_buf = String::new();
    loop {
        let before = reader.buffer_position() as usize;
        let ev = reader.read_event().map_err(|e| {
            err_at(
                reader.error_position() as usize,
                format!("malformed XML: {e}"),
            )
        })?;
        let tag_start = before + text[before.min(text.len())..].find('<').unwrap_or(0);
        let after = reader.buffer_position() as usize;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                let in_eamos_tool = path.iter().any(|p| p == "toolspecific#eamos");
                let mut pushed = name.clone();
                match name.as_str() {
                    "net" => {
                        nets_seen += 1;
                        if nets_seen == 1 {
                            net = Some(PnmlNet {
                                id: attr(e, b"id")
                                    .map_err(|m| err_at(tag_start, m))?
                                    .unwrap_or_default(),
                                name: String::new(),
                                places: Vec::new(),
                                transitions: Vec::new(),
                                arcs: Vec::new(),
                                skipped: Vec::new(),
                            });
                        }
                    }
                    "place" | "transition" | "arc" if nets_seen == 1 && open.kind == Elem::None => {
                        let id = attr(e, b"id")
                            .map_err(|m| err_at(tag_start, m))?
                            .ok_or_else(|| err_at(tag_start, format!("<{name}> without an id")))?;
                        open = Open {
                            kind: match name.as_str() {
                                "place" => Elem::Place,
                                "transition" => Elem::Transition,
                                _ => Elem::Arc,
                            },
                            id,
                            start: tag_start,
                            end: after,
                            ..Open::default()
                        };
                        if open.kind == Elem::Arc {
                            open.source = attr(e, b"source")
                                .map_err(|m| err_at(tag_start, m))?
                                .ok_or_else(|| {
                                    err_at(tag_start, "<arc> without a source".into())
                                })?;
                            open.target = attr(e, b"target")
                                .map_err(|m| err_at(tag_start, m))?
                                .ok_or_else(|| {
                                    err_at(tag_start, "<arc> without a target".into())
                                })?;
                        }
                    }
                    "referencePlace" | "referenceTransition" if nets_seen == 1 => {
                        let id = attr(e, b"id").map_err(|m| err_at(tag_start, m))?;
                        let r = attr(e, b"ref").map_err(|m| err_at(tag_start, m))?;
                        match (id, r) {
                            (Some(id), Some(r)) => {
                                refs.insert(id, (r, tag_start));
                            }
                            _ => {
                                return Err(err_at(
                                    tag_start,
                                    format!("<{name}> needs an id and a ref"),
                                ))
                            }
                        }
                    }
                    "type" if open.kind == Elem::Arc => {
                        open.arc_type = attr(e, b"value").map_err(|m| err_at(tag_start, m))?;
                    }
                    "toolspecific" => {
                        let tool = attr(e, b"tool").map_err(|m| err_at(tag_start, m))?;
                        if tool.as_deref() == Some("eamos") {
                            pushed = "toolspecific#eamos".into();
                        }
                    }
                    "final" if in_eamos_tool && open.kind == Elem::Place => {
                        open.tool_eamos_final = true;
                    }
                    "read" if in_eamos_tool && open.kind == Elem::Arc => {
                        open.tool_eamos_read = true;
                    }
                    "readReturn" if in_eamos_tool && open.kind == Elem::Arc => {
                        open.tool_eamos_read_return = true;
                    }
                    _ => {}
                }
                if !empty {
                    path.push(pushed);
                    text_buf.clear();
                }
            }
            Event::Text(ref t) => {
                let s = t
                    .xml_content()
                    .map_err(|e| err_at(before, format!("malformed text: {e}")))?;
                text_buf.push_str(&s);
            }
            Event::CData(ref t) => {
                let s = t
                    .decode()
                    .map_err(|e| err_at(before, format!("malformed text: {e}")))?;
                text_buf.push_str(&s);
            }
            Event::GeneralRef(ref r) => {
                if let Some(c) = r
                    .resolve_char_ref()
                    .map_err(|e| err_at(before, format!("malformed character reference: {e}")))?
                {
                    text_buf.push(c);
                } else {
                    let name = r
                        .decode()
                        .map_err(|e| err_at(before, format!("malformed reference: {e}")))?;
                    let c = entity(&name)
                        .ok_or_else(|| err_at(before, format!("unknown entity `&{name};`")))?;
                    text_buf.push(c);
                }
            }
            Event::End(ref e) => {
                let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                let ctx: Vec<&str> = path.iter().rev().take(3).map(String::as_str).collect();
                if name == "text" && open.kind != Elem::None {
                    match ctx.get(1).copied() {
                        Some("name")
                            if ctx.get(2).is_some_and(|p| {
                                *p == "place" || *p == "transition" || *p == "arc"
                            }) =>
                        {
                            open.name = text_buf.trim().to_string()
                        }
                        Some("initialMarking") => open.marking = text_buf.trim().to_string(),
                        Some("inscription") => open.inscription = text_buf.trim().to_string(),
                        _ => {}
                    }
                } else if name == "text"
                    && open.kind == Elem::None
                    && ctx.get(1) == Some(&"name")
                    && ctx.get(2) == Some(&"net")
                {
                    if let Some(n) = net.as_mut() {
                        n.name = text_buf.trim().to_string();
                    }
                }
                if name == "kind"
                    && open.kind == Elem::Transition
                    && path.iter().any(|p| p == "toolspecific#eamos")
                {
                    open.tool_eamos_kind = text_buf.trim().to_string();
                }
                let closes_open = matches!(
                    (name.as_str(), open.kind),
                    ("place", Elem::Place) | ("transition", Elem::Transition) | ("arc", Elem::Arc)
                ) && path.iter().filter(|p| *p == &name).count() == 1;
                if closes_open {
                    finish(&mut open, net.as_mut(), &err_at)?;
                }
                path.pop();
                text_buf.clear();
            }
            Event::Eof => break,
            _ => {}
        }
        // An empty place/transition/arc element closes at once.
        if let Event::Empty(ref e) = ev {
            let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
            if matches!(
                (name.as_str(), open.kind),
                ("place", Elem::Place) | ("transition", Elem::Transition) | ("arc", Elem::Arc)
            ) && open.start == tag_start
            {
                finish(&mut open, net.as_mut(), &err_at)?;
            }
        }
    }
    if !path.is_empty() {
        return Err(err_at(
            text.len(),
            format!(
                "malformed XML: <{}> is never closed",
                path.last().map_or("", |s| s.as_str())
            ),
        ));
    }
    let mut net =
        net.ok_or_else(|| err_at(0, "no <net> element: this is not a PNML net".into()))?;
    // Resolve references and check arcs.
    let resolve = |id: &str| -> String {
        let mut cur = id.to_string();
        for _ in 0..64 {
            match refs.get(&cur) {
                Some((r, _)) => cur = r.clone(),
                None => break,
            }
        }
        cur
    };
    let skipped = std::mem::take(&mut net.skipped);
    net.arcs
        .retain(|a| !skipped.contains(&a.source) && !skipped.contains(&a.target));
    net.skipped = skipped;
    let mut kinds: HashMap<&str, Elem> = HashMap::new();
    for p in &net.places {
        if kinds.insert(&p.id, Elem::Place).is_some() {
            return Err(err_at(
                p.span.start as usize,
                format!("id `{}` is used twice", p.id),
            ));
        }
    }
    for t in &net.transitions {
        if kinds.insert(&t.id, Elem::Transition).is_some() {
            return Err(err_at(
                t.span.start as usize,
                format!("id `{}` is used twice", t.id),
            ));
        }
    }
    let kinds: HashMap<String, Elem> = kinds.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
    for a in &mut net.arcs {
        a.source = resolve(&a.source);
        a.target = resolve(&a.target);
        let ks = kinds.get(&a.source).copied();
        let kt = kinds.get(&a.target).copied();
        let at = a.span.start as usize;
        match (ks, kt) {
            (None, _) => {
                return Err(err_at(
                    at,
                    format!("arc `{}`: no place or transition `{}`", a.id, a.source),
                ))
            }
            (_, None) => {
                return Err(err_at(
                    at,
                    format!("arc `{}`: no place or transition `{}`", a.id, a.target),
                ))
            }
            (Some(Elem::Place), Some(Elem::Transition)) => {}
            (Some(Elem::Transition), Some(Elem::Place)) => {
                if a.kind == PnmlArcKind::Read {
                    return Err(err_at(
                        at,
                        format!(
                            "arc `{}`: a read arc goes from a place to a transition",
                            a.id
                        ),
                    ));
                }
            }
            _ => {
                return Err(err_at(
                    at,
                    format!("arc `{}` must join a place and a transition", a.id),
                ))
            }
        }
    }
    Ok(net)
}

fn finish(
    open: &mut Open,
    net: Option<&mut PnmlNet>,
    err_at: &dyn Fn(usize, String) -> PnmlError,
) -> Result<(), PnmlError> {
    let o = std::mem::take(open);
    let Some(net) = net else { return Ok(()) };
    let span = Span::new(o.start, o.end);
    match o.kind {
        Elem::Place => {
            let initial = if o.marking.is_empty() {
                0
            } else {
                // Some tools write `Default,2`.
                let v = o.marking.rsplit(',').next().unwrap_or("").trim();
                v.parse::<u32>().map_err(|_| {
                    err_at(
                        o.start,
                        format!(
                            "place `{}`: initial marking `{}` is not a number of tokens",
                            o.id, o.marking
                        ),
                    )
                })?
            };
            net.places.push(PnmlPlace {
                is_final: o.tool_eamos_final || o.id == "final",
                name: if o.name.is_empty() {
                    o.id.clone()
                } else {
                    o.name
                },
                id: o.id,
                initial,
                span,
            });
        }
        // The self-loop eamos adds on `final` for tools without a notion
        // of a final marking: this reader has one.
        Elem::Transition if o.tool_eamos_kind == "final-loop" => {
            net.skipped.push(o.id);
        }
        Elem::Transition => net.transitions.push(PnmlTransition {
            name: if o.name.is_empty() {
                o.id.clone()
            } else {
                o.name
            },
            id: o.id,
            span,
        }),
        Elem::Arc if o.tool_eamos_read_return => {}
        Elem::Arc => {
            let weight = if o.inscription.is_empty() {
                1
            } else {
                let v = o.inscription.rsplit(',').next().unwrap_or("").trim();
                match v.parse::<u32>() {
                    Ok(w) if w > 0 => w,
                    _ => {
                        return Err(err_at(
                            o.start,
                            format!(
                                "arc `{}`: inscription `{}` is not a positive weight",
                                o.id, o.inscription
                            ),
                        ))
                    }
                }
            };
            let kind = match o.arc_type.as_deref() {
                None | Some("normal") => {
                    if o.tool_eamos_read {
                        PnmlArcKind::Read
                    } else {
                        PnmlArcKind::Normal
                    }
                }
                Some("test") | Some("read") => PnmlArcKind::Read,
                Some(other) => {
                    return Err(err_at(
                        o.start,
                        format!(
                            "arc `{}`: {other} arcs are not supported (only normal and read arcs)",
                            o.id
                        ),
                    ))
                }
            };
            net.arcs.push(PnmlArc {
                id: o.id,
                source: o.source,
                target: o.target,
                weight,
                kind,
                span,
            });
        }
        Elem::None => {}
    }
    Ok(())
}

/// What the checker needs from a PNML net.
pub(crate) fn subject(net: &PnmlNet) -> Subject {
    let mut place_ix: HashMap<&str, u32> = HashMap::new();
    let mut places = Vec::new();
    let mut initial = Vec::new();
    let mut final_place = None;
    for (i, p) in net.places.iter().enumerate() {
        place_ix.insert(&p.id, i as u32);
        places.push(PlaceInfo {
            id: p.id.as_str().into(),
            label: p.name.as_str().into(),
            span: Some(p.span),
            event: None,
            is_final: p.is_final,
            auxiliary: false,
            synthetic: false,
        });
        initial.push(p.initial);
        if p.is_final && final_place.is_none() {
            final_place = Some(i as u32);
        }
    }
    let mut trans_ix: HashMap<&str, usize> = HashMap::new();
    let mut steps = Vec::new();
    for (i, t) in net.transitions.iter().enumerate() {
        trans_ix.insert(&t.id, i);
        let text = if t.name == t.id {
            format!("transition `{}` fires", t.id)
        } else {
            format!("transition `{}` ({}) fires", t.name, t.id)
        };
        steps.push(StepInfo {
            id: t.id.as_str().into(),
            label: t.name.as_str().into(),
            kind: "Transition".into(),
            text: text.into(),
            internal: false,
            span: Some(t.span),
            guard: None,
        });
    }
    let mut raw = vec![RawTransition::default(); net.transitions.len()];
    for a in &net.arcs {
        if let (Some(&p), Some(&t)) = (
            place_ix.get(a.source.as_str()),
            trans_ix.get(a.target.as_str()),
        ) {
            match a.kind {
                PnmlArcKind::Normal => raw[t].pre.push((p, a.weight)),
                PnmlArcKind::Read => raw[t].read.push((p, a.weight)),
            }
        } else if let (Some(&t), Some(&p)) = (
            trans_ix.get(a.source.as_str()),
            place_ix.get(a.target.as_str()),
        ) {
            raw[t].post.push((p, a.weight));
        }
    }
    Subject {
        pt: PtNet::new(places, steps, raw, initial, final_place),
        input: InputKind::Pnml,
        name: if net.name.is_empty() {
            net.id.clone()
        } else {
            net.name.clone()
        },
        running: HashMap::new(),
        exclusive: Vec::new(),
        starts: Vec::new(),
        conditions: None,
        loops: Vec::new(),
        waits: Vec::new(),
        limits: Vec::new(),
        space: None,
        folded: 0,
        relation: None,
    }
}
