//! The server's loop: one thread owns every document, answers requests
//! from the latest analysis, and runs the front end once per batch of
//! edits; `eamos check` runs on the worker of `check`.
//!
//! Nothing a client sends ends the loop but `exit` or the end of its
//! input: a request that fails (bad parameters, an unknown method, a panic
//! in a handler) is answered with an error and the loop goes on.

use std::collections::{BTreeSet, HashMap};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use crossbeam_channel::{select, Receiver, Sender};
use eamos_profile::ProfileTable;
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, RequestId, Response};
use lsp_types::notification::{self as note, Notification as _};
use lsp_types::request::{self as req, Request as _};
use lsp_types::{
    Diagnostic, InitializeParams, Position, PublishDiagnosticsParams,
    TextDocumentContentChangeEvent, Uri,
};
use serde_json::Value;

use crate::check::{self, Job, Outcome};
use crate::doc::{hash, Doc};
use crate::{capabilities, complete, fix, fleet, hover, navigate, proto};

/// What the editor configured (`initializationOptions`, or the `eamos`
/// section of `workspace/didChangeConfiguration`).
#[derive(Debug, Default, Clone)]
struct Settings {
    /// The fleet file, relative to the workspace root.
    fleet: Option<String>,
}

impl Settings {
    fn read(&mut self, v: &Value) {
        let v = v.get("eamos").unwrap_or(v);
        if let Some(f) = v.get("fleet") {
            self.fleet = f.as_str().map(str::to_string);
        }
    }
}

/// Why a request failed: the error code and message the client gets.
type Failure = (ErrorCode, String);

/// An answer as the protocol's JSON.
fn json(v: impl serde::Serialize) -> Result<Value, Failure> {
    serde_json::to_value(v).map_err(|e| (ErrorCode::InternalError, e.to_string()))
}

/// A check's findings for the text of `hash`.
struct Checked {
    hash: u64,
    diagnostics: Vec<Diagnostic>,
}

struct Server {
    sender: Sender<Message>,
    profiles: ProfileTable,
    docs: HashMap<String, (Uri, Doc)>,
    checked: HashMap<String, Checked>,
    /// Documents edited since their last analysis.
    dirty: BTreeSet<String>,
    settings: Settings,
    root: Option<PathBuf>,
    jobs: Sender<Job>,
    shut_down: bool,
}

/// Serves one client until `exit` or the end of its input.
pub fn serve(conn: Connection) {
    let Some((id, params)) = initialize(&conn) else {
        return;
    };
    let (jobs, outcomes) = check::spawn();
    let mut server = Server {
        sender: conn.sender.clone(),
        profiles: eamos_profile::builtin(),
        docs: HashMap::new(),
        checked: HashMap::new(),
        dirty: BTreeSet::new(),
        settings: Settings::default(),
        root: None,
        jobs,
        shut_down: false,
    };
    let init: Option<InitializeParams> = serde_json::from_value(params.clone()).ok();
    if let Some(opts) = params.get("initializationOptions") {
        server.settings.read(opts);
    }
    #[allow(deprecated)] // `root_uri` is what older clients send.
    let root = init.as_ref().and_then(|p| {
        p.workspace_folders
            .as_ref()
            .and_then(|f| f.first().map(|f| f.uri.clone()))
            .or_else(|| p.root_uri.clone())
    });
    server.root = root.and_then(|u| fleet::path_of(u.as_str()));
    let result = serde_json::json!({
        "capabilities": capabilities::server(),
        "serverInfo": {"name": "eamos", "version": env!("CARGO_PKG_VERSION")},
    });
    server.send(Response::new_ok(id, result).into());
    server.run(&conn.receiver, &outcomes);
}

/// The handshake: answers requests before `initialize` with an error, as
/// the protocol says; `None` if the client leaves first.
fn initialize(conn: &Connection) -> Option<(RequestId, Value)> {
    loop {
        match conn.receiver.recv().ok()? {
            Message::Request(r) if r.method == req::Initialize::METHOD => {
                return Some((r.id, r.params))
            }
            Message::Request(r) => {
                let resp = Response::new_err(
                    r.id,
                    ErrorCode::ServerNotInitialized as i32,
                    "not initialized".into(),
                );
                let _ = conn.sender.send(resp.into());
            }
            Message::Notification(n) if n.method == note::Exit::METHOD => return None,
            _ => {}
        }
    }
}

impl Server {
    fn send(&self, m: Message) {
        // A client gone mid-request: nobody is left to tell.
        let _ = self.sender.send(m);
    }

    fn run(&mut self, messages: &Receiver<Message>, outcomes: &Receiver<Outcome>) {
        loop {
            select! {
                recv(messages) -> m => match m {
                    Ok(m) => if !self.handle(m) { return },
                    Err(_) => return,
                },
                recv(outcomes) -> o => if let Ok(o) = o { self.checked(o) },
            }
            // Everything the client sent meanwhile first: a burst of
            // keystrokes is analysed once, at its last version.
            while let Ok(m) = messages.try_recv() {
                if !self.handle(m) {
                    return;
                }
            }
            self.flush();
        }
    }

    /// Handles one message; `false` to stop.
    fn handle(&mut self, m: Message) -> bool {
        match m {
            Message::Request(r) => {
                let id = r.id.clone();
                let response = match catch_unwind(AssertUnwindSafe(|| self.request(r))) {
                    Ok(r) => r,
                    Err(_) => Response::new_err(
                        id,
                        ErrorCode::InternalError as i32,
                        "the server failed on this request (a bug of eamos)".into(),
                    ),
                };
                self.send(response.into());
                true
            }
            Message::Notification(n) if n.method == note::Exit::METHOD => false,
            Message::Notification(n) => {
                let _ = catch_unwind(AssertUnwindSafe(|| self.notification(n)));
                true
            }
            Message::Response(_) => true,
        }
    }

    fn request(&mut self, r: Request) -> Response {
        let id = r.id.clone();
        if self.shut_down {
            return Response::new_err(
                id,
                ErrorCode::InvalidRequest as i32,
                "the server is shut down".into(),
            );
        }
        let result: Result<Value, Failure> = match r.method.as_str() {
            req::Shutdown::METHOD => {
                self.shut_down = true;
                Ok(Value::Null)
            }
            req::HoverRequest::METHOD => self.at::<req::HoverRequest>(r, |s, doc, _, off| {
                json(hover::hover(doc, &s.profiles, off))
            }),
            req::Completion::METHOD => self.at::<req::Completion>(r, |s, doc, _, off| {
                json(complete::complete(doc, &s.profiles, off))
            }),
            req::GotoDefinition::METHOD => self.at::<req::GotoDefinition>(r, |_, doc, uri, off| {
                json(navigate::definition(doc, uri, off))
            }),
            req::References::METHOD => {
                let declaration = r
                    .params
                    .pointer("/context/includeDeclaration")
                    .and_then(Value::as_bool)
                    .unwrap_or(true);
                self.at::<req::References>(r, move |_, doc, uri, off| {
                    json(navigate::references(doc, uri, off, declaration))
                })
            }
            req::PrepareRenameRequest::METHOD => self
                .at::<req::PrepareRenameRequest>(r, |_, doc, _, off| {
                    json(navigate::prepare_rename(doc, off))
                }),
            req::Rename::METHOD => {
                let new_name = r
                    .params
                    .get("newName")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .to_string();
                self.at::<req::Rename>(r, |_, doc, uri, off| {
                    navigate::rename(doc, uri, off, &new_name)
                        .map_err(|e| (ErrorCode::InvalidParams, e))
                        .and_then(json)
                })
            }
            req::DocumentSymbolRequest::METHOD => self
                .doc_request::<req::DocumentSymbolRequest>(r, |_, doc, _| {
                    json(navigate::symbols(doc))
                }),
            req::CodeActionRequest::METHOD => {
                let diags: Vec<Diagnostic> = r
                    .params
                    .pointer("/context/diagnostics")
                    .and_then(|d| serde_json::from_value(d.clone()).ok())
                    .unwrap_or_default();
                self.doc_request::<req::CodeActionRequest>(r, move |_, doc, uri| {
                    json(fix::quick_fixes(doc, uri, &diags))
                })
            }
            other => Err((
                ErrorCode::MethodNotFound,
                format!("unknown method `{other}`"),
            )),
        };
        match result {
            Ok(v) => Response::new_ok(id, v),
            Err((code, message)) => Response::new_err(id, code as i32, message),
        }
    }

    /// A request about a document: its parameters read, the document
    /// analysed at its latest text, then `f`.
    fn doc_request<R: lsp_types::request::Request>(
        &mut self,
        r: Request,
        f: impl FnOnce(&Server, &Doc, &Uri) -> Result<Value, Failure>,
    ) -> Result<Value, Failure> {
        let params: Value = r.params;
        let uri = params
            .pointer("/textDocument/uri")
            .and_then(Value::as_str)
            .ok_or((ErrorCode::InvalidParams, "no textDocument.uri".to_string()))?
            .to_string();
        serde_json::from_value::<R::Params>(params)
            .map_err(|e| (ErrorCode::InvalidParams, e.to_string()))?;
        self.analyse(&uri);
        let Some((u, doc)) = self.docs.get(&uri) else {
            return Ok(Value::Null);
        };
        f(self, doc, u)
    }

    /// A request at a position in a document.
    fn at<R: lsp_types::request::Request>(
        &mut self,
        r: Request,
        f: impl FnOnce(&Server, &Doc, &Uri, usize) -> Result<Value, Failure>,
    ) -> Result<Value, Failure> {
        let pos: Position = r
            .params
            .get("position")
            .and_then(|p| serde_json::from_value(p.clone()).ok())
            .ok_or((ErrorCode::InvalidParams, "no position".to_string()))?;
        self.doc_request::<R>(r, move |s, doc, uri| f(s, doc, uri, doc.offset(pos)))
    }

    fn notification(&mut self, n: Notification) {
        match n.method.as_str() {
            note::DidOpenTextDocument::METHOD => {
                let Ok(p) = n.extract::<lsp_types::DidOpenTextDocumentParams>(
                    note::DidOpenTextDocument::METHOD,
                ) else {
                    return;
                };
                let key = p.text_document.uri.as_str().to_string();
                let name = fleet::path_of(&key).map_or(key.clone(), |p| p.display().to_string());
                let doc = Doc::new(&name, p.text_document.text, p.text_document.version);
                self.docs.insert(key.clone(), (p.text_document.uri, doc));
                self.dirty.insert(key);
            }
            note::DidChangeTextDocument::METHOD => {
                let Ok(p) = n.extract::<lsp_types::DidChangeTextDocumentParams>(
                    note::DidChangeTextDocument::METHOD,
                ) else {
                    return;
                };
                let key = p.text_document.uri.as_str().to_string();
                let Some((_, doc)) = self.docs.get_mut(&key) else {
                    return;
                };
                let text = apply(doc, p.content_changes);
                doc.set_text(text, p.text_document.version);
                self.dirty.insert(key);
            }
            note::DidSaveTextDocument::METHOD => {
                let Ok(p) = n.extract::<lsp_types::DidSaveTextDocumentParams>(
                    note::DidSaveTextDocument::METHOD,
                ) else {
                    return;
                };
                let key = p.text_document.uri.as_str().to_string();
                if let Some((_, doc)) = self.docs.get_mut(&key) {
                    if let Some(text) = p.text {
                        let version = doc.version;
                        doc.set_text(text, version);
                        self.dirty.insert(key.clone());
                    }
                }
                self.check(&key);
            }
            note::DidCloseTextDocument::METHOD => {
                let Ok(p) = n.extract::<lsp_types::DidCloseTextDocumentParams>(
                    note::DidCloseTextDocument::METHOD,
                ) else {
                    return;
                };
                let key = p.text_document.uri.as_str().to_string();
                self.docs.remove(&key);
                self.checked.remove(&key);
                self.dirty.remove(&key);
                self.publish(p.text_document.uri, Vec::new(), None);
            }
            note::DidChangeConfiguration::METHOD => {
                if let Some(s) = n.params.get("settings") {
                    self.settings.read(s);
                }
            }
            _ => {}
        }
    }

    /// Queues `eamos check` of a document's current text.
    fn check(&mut self, key: &str) {
        let Some((_, doc)) = self.docs.get(key) else {
            return;
        };
        let path = fleet::path_of(key);
        let job = Job {
            uri: key.to_string(),
            hash: hash(doc.text()),
            source: doc.source.clone(),
            fleet: fleet::fleet_for(
                path.as_deref(),
                self.settings.fleet.as_deref(),
                self.root.as_deref(),
            ),
        };
        let _ = self.jobs.send(job);
    }

    fn checked(&mut self, o: Outcome) {
        let Some((uri, doc)) = self.docs.get(&o.uri) else {
            return;
        };
        let diagnostics = match &o.report {
            Ok(None) => Vec::new(),
            Ok(Some(report)) => report
                .findings
                .iter()
                .map(|f| proto::finding(f, doc, uri))
                .chain(report.limits.iter().map(|l| proto::limit(l, doc)))
                .collect(),
            Err(message) => vec![Diagnostic {
                severity: Some(lsp_types::DiagnosticSeverity::ERROR),
                source: Some("eamos check".into()),
                code: Some(lsp_types::NumberOrString::String("check::fleet".into())),
                message: message.clone(),
                ..Diagnostic::default()
            }],
        };
        self.checked.insert(
            o.uri.clone(),
            Checked {
                hash: o.hash,
                diagnostics,
            },
        );
        self.dirty.insert(o.uri);
    }

    /// Analyses a document if its text changed, and publishes.
    fn analyse(&mut self, key: &str) {
        if !self.dirty.remove(key) {
            return;
        }
        let Some((uri, doc)) = self.docs.get_mut(key) else {
            return;
        };
        doc.analyse(&self.profiles);
        let (uri, doc) = (uri.clone(), &self.docs[key].1);
        let mut diagnostics: Vec<Diagnostic> = doc
            .diagnostics()
            .iter()
            .map(|d| proto::diagnostic(d, doc, &uri))
            .collect();
        if let Some(c) = self.checked.get(key).filter(|c| c.hash == hash(doc.text())) {
            diagnostics.extend(c.diagnostics.iter().cloned());
        }
        let version = doc.version;
        self.publish(uri, diagnostics, Some(version));
    }

    fn flush(&mut self) {
        let dirty: Vec<String> = self.dirty.iter().cloned().collect();
        for key in dirty {
            self.analyse(&key);
        }
    }

    fn publish(&self, uri: Uri, diagnostics: Vec<Diagnostic>, version: Option<i32>) {
        let params = PublishDiagnosticsParams {
            uri,
            diagnostics,
            version,
        };
        self.send(Notification::new(note::PublishDiagnostics::METHOD.into(), params).into());
    }
}

/// The text after a batch of changes: whole texts replace it, ranged
/// edits splice it (positions in UTF-16, as the client counts).
fn apply(doc: &Doc, changes: Vec<TextDocumentContentChangeEvent>) -> String {
    let mut text = doc.text().to_string();
    for c in changes {
        match c.range {
            None => text = c.text,
            Some(range) => {
                let lines = crate::position::LineIndex::new(&text);
                let start = lines.offset(&text, range.start);
                let end = lines.offset(&text, range.end).max(start);
                text.replace_range(start..end, &c.text);
            }
        }
    }
    text
}
