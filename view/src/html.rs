//! The page: one HTML file with the model, the scripts and the styles
//! inlined, so that it opens from the disk with no server and no network.

use crate::model::Model;

/// Dagre (graph layout), as `npm ci` installs it from `web/package-lock.json`
/// (`web/vendor.sh` copies it here and checks the copy).
const DAGRE: &str = include_str!("../web/vendor/dagre.min.js");
/// The page's own script: `EamosView.render(root, model)` and `update(event)`.
const VIEW_JS: &str = include_str!("../web/view.js");
/// The live half, for the monitor: `EamosLive.attach(view)` and
/// `connect(view, url)`; a page opened from the disk never connects.
const LIVE_JS: &str = include_str!("../web/live.js");
const VIEW_CSS: &str = include_str!("../web/view.css");

/// The report page of `model`.
pub fn page(model: &Model) -> String {
    // `<` never appears raw inside the JSON, so no text of the mission can
    // close the script element that holds it.
    let json = serde_json::to_string(model)
        .unwrap_or_else(|_| "{}".into())
        .replace('<', "\\u003c");
    let title = escape(&format!("{}: mission report", model.name));
    format!(
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="eamos view">
<title>{title}</title>
<style>
{VIEW_CSS}
</style>
</head>
<body>
<div id="eamos-view"></div>
<script type="application/json" id="eamos-model">{json}</script>
<script>
{dagre}
</script>
<script>
{view}
</script>
<script>
{live}
</script>
<script>
window.eamosView = EamosLive.attach(EamosView.render(
  document.getElementById("eamos-view"),
  JSON.parse(document.getElementById("eamos-model").textContent)
));
// Served by the monitor: its events, live. From the disk: nothing.
if (location.protocol === "http:" || location.protocol === "https:") {{
  EamosLive.connect(window.eamosView, "events");
}}
</script>
</body>
</html>
"#,
        dagre = inline_script(DAGRE),
        view = inline_script(VIEW_JS),
        live = inline_script(LIVE_JS),
    )
}

/// A script's text, safe inside `<script>`: no closing tag, and no source
/// map comment that would make a browser's tools look for a file.
fn inline_script(js: &str) -> String {
    js.lines()
        .filter(|l| !l.starts_with("//# sourceMappingURL"))
        .collect::<Vec<_>>()
        .join("\n")
        .replace("</script", "<\\/script")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
