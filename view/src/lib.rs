//! The static mission report behind `eamos view`: one HTML file that opens
//! offline in any browser and shows a checked mission from above and from
//! the side (homes, fence, ceiling, every drone's legs through every
//! branch, the findings of `eamos check`), a timeline per drone and the
//! mission graph beside the source.
//!
//! The Rust side builds a [`Model`], plain data in mission terms, from what
//! the other crates computed: the checked mission's text, the net, the
//! checker's report and `eamos_verify::plan`'s legs. It draws nothing; the
//! page's script (`web/view.js`) draws the model (`render`), and the live
//! monitor (`eamos-monitor`) hands the same page the executor's own events
//! (`update(event)`, as the mission log writes them; `web/live.js` shows
//! what `view.js` does not draw) without a new model or a vocabulary of its
//! own. The page connects to the monitor's events only when it is served
//! over HTTP, never when opened from the disk.
//!
//! Architecture Invariant: data flows one way. This crate reads `lang`,
//! `petri`, `profile`, `verify` and `geo`, and nothing depends on it but the
//! command line and the monitor (`eamos-monitor`, which serves its page). It does no I/O and no analysis of its own: every leg comes
//! from `eamos_verify::plan`, every finding from the checker's report. The
//! page it writes fetches nothing (served by the monitor, it opens the
//! monitor's event stream and nothing else): scripts and styles are
//! inlined, and the model is a `<script type="application/json">`.

mod graph;
mod html;
mod input;
mod model;
mod timeline;

pub use html::page;
pub use input::Input;
pub use model::{model, Model};
