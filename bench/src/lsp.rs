//! The language server's latency: from a `didChange` to the diagnostics
//! published for that version, on the stress mission, through `eamos lsp`
//! started as its own process and spoken to over pipes as an editor does.
//! Only the protocol's JSON is shared with the server, none of its code.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// How many edits are timed (the median is reported).
pub const EDITS: usize = 21;

/// The median time from an edit to its diagnostics, and the time from
/// opening the file to its first diagnostics.
#[derive(Debug, Clone, Copy)]
pub struct Latency {
    pub open: Duration,
    pub edit: Duration,
}

pub fn measure(exe: &Path, mission: &Path) -> Result<Latency, String> {
    let text = std::fs::read_to_string(mission)
        .map_err(|e| format!("cannot read {}: {e}", mission.display()))?;
    let mut child = Command::new(exe)
        .arg("lsp")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {} lsp: {e}", exe.display()))?;
    let mut input = child.stdin.take().ok_or("no stdin")?;
    let mut output = BufReader::new(child.stdout.take().ok_or("no stdout")?);
    let uri = "file:///bench/stress.go";
    send(
        &mut input,
        &json!({"id": 1, "method": "initialize", "params": {"capabilities": {}}}),
    )?;
    wait(&mut output, |m| m["id"] == 1)?;
    send(&mut input, &json!({"method": "initialized", "params": {}}))?;
    let started = Instant::now();
    send(
        &mut input,
        &json!({"method": "textDocument/didOpen", "params": {"textDocument":
        {"uri": uri, "languageId": "go", "version": 1, "text": text}}}),
    )?;
    wait(&mut output, |m| published(m, 1))?;
    let open = started.elapsed();
    let mut edits = Vec::with_capacity(EDITS);
    for i in 0..EDITS {
        let version = i as i64 + 2;
        // A keystroke: one character typed into a comment on the first line.
        let change = json!({"range": {"start": {"line": 0, "character": 0},
            "end": {"line": 0, "character": 0}}, "text": if i == 0 { "//x\n" } else { "x" }});
        let started = Instant::now();
        send(
            &mut input,
            &json!({"method": "textDocument/didChange", "params": {
            "textDocument": {"uri": uri, "version": version}, "contentChanges": [change]}}),
        )?;
        wait(&mut output, |m| published(m, version))?;
        edits.push(started.elapsed());
    }
    send(&mut input, &json!({"id": 2, "method": "shutdown"}))?;
    wait(&mut output, |m| m["id"] == 2)?;
    send(&mut input, &json!({"method": "exit"}))?;
    let _ = child.wait();
    edits.sort();
    Ok(Latency {
        open,
        edit: edits[edits.len() / 2],
    })
}

fn published(m: &Value, version: i64) -> bool {
    m["method"] == "textDocument/publishDiagnostics" && m["params"]["version"] == version
}

fn send(input: &mut ChildStdin, msg: &Value) -> Result<(), String> {
    let mut msg = msg.clone();
    msg["jsonrpc"] = json!("2.0");
    let body = msg.to_string();
    write!(input, "Content-Length: {}\r\n\r\n{body}", body.len())
        .and_then(|()| input.flush())
        .map_err(|e| format!("the language server stopped reading: {e}"))
}

fn wait(
    output: &mut BufReader<ChildStdout>,
    done: impl Fn(&Value) -> bool,
) -> Result<Value, String> {
    loop {
        let mut length = None;
        loop {
            let mut line = String::new();
            if output.read_line(&mut line).map_err(|e| e.to_string())? == 0 {
                return Err("the language server ended early".into());
            }
            let line = line.trim();
            if line.is_empty() {
                break;
            }
            if let Some(v) = line.strip_prefix("Content-Length:") {
                length = v.trim().parse().ok();
            }
        }
        let mut body = vec![0; length.ok_or("a message without Content-Length")?];
        output.read_exact(&mut body).map_err(|e| e.to_string())?;
        let msg: Value = serde_json::from_slice(&body).map_err(|e| e.to_string())?;
        if done(&msg) {
            return Ok(msg);
        }
    }
}
