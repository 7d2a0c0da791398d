//! The protocol's framing over a byte stream (`Content-Length` headers, a
//! JSON body), tolerant of a bad client.
//!
//! `lsp-server`'s own stdio transport ends the connection on the first body
//! that is not a message. Here a malformed body is answered with JSON-RPC's
//! parse error (or "invalid request") and the next message is read; only
//! the end of the input or an unreadable header block ends the reader.

use std::io::{self, BufRead, Write};
use std::thread;

use crossbeam_channel::{select, unbounded, Receiver, Sender};
use lsp_server::{Connection, Message};
use serde_json::{json, Value};

/// The largest body accepted: a mission is a few hundred kilobytes at most.
const MAX_BODY: usize = 64 << 20;

/// The reader and writer threads of a connection.
pub struct Io {
    reader: thread::JoinHandle<()>,
    writer: thread::JoinHandle<()>,
}

impl Io {
    /// Waits for both threads (the writer ends when every sender is gone).
    /// The reader may be blocked on input nobody sends any more: it is left
    /// to end with the process.
    pub fn join(self) {
        let _ = self.writer.join();
        drop(self.reader);
    }
}

/// A connection over any input and output (standard input and output for
/// `eamos lsp`, pipes in tests).
pub fn connect(
    input: impl BufRead + Send + 'static,
    output: impl Write + Send + 'static,
) -> (Connection, Io) {
    let (in_tx, in_rx) = unbounded::<Message>();
    let (out_tx, out_rx) = unbounded::<Message>();
    let (raw_tx, raw_rx) = unbounded::<Value>();
    let reader = thread::spawn(move || read_loop(input, &in_tx, &raw_tx));
    let writer = thread::spawn(move || write_loop(output, &out_rx, &raw_rx));
    let conn = Connection {
        sender: out_tx,
        receiver: in_rx,
    };
    (conn, Io { reader, writer })
}

fn read_loop(mut input: impl BufRead, messages: &Sender<Message>, raw: &Sender<Value>) {
    loop {
        let body = match read_body(&mut input) {
            Ok(Some(body)) => body,
            Ok(None) => return,
            Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                let _ = raw.send(error(Value::Null, -32700, &e.to_string()));
                continue;
            }
            Err(_) => return,
        };
        let value: Value = match serde_json::from_slice(&body) {
            Ok(v) => v,
            Err(e) => {
                let _ = raw.send(error(Value::Null, -32700, &format!("parse error: {e}")));
                continue;
            }
        };
        let id = value.get("id").cloned().unwrap_or(Value::Null);
        let has_method = value.get("method").is_some();
        match serde_json::from_value::<Message>(value) {
            // A bad request can read as a response (`id` and nothing
            // else the response needs): it is still a bad request.
            Ok(Message::Response(_)) if has_method => {
                let _ = raw.send(error(
                    id,
                    -32600,
                    "invalid request: `method` is not a string",
                ));
            }
            Ok(msg) => {
                let exit = matches!(&msg, Message::Notification(n) if n.method == "exit");
                if messages.send(msg).is_err() || exit {
                    return;
                }
            }
            Err(e) => {
                let _ = raw.send(error(id, -32600, &format!("invalid request: {e}")));
            }
        }
    }
}

/// One message body; `None` at the end of the input (also in the middle of
/// a body: the client is gone). A header block without a usable
/// `Content-Length`, or one announcing a body too large, is `InvalidData`,
/// which the caller answers and skips.
fn read_body(input: &mut impl BufRead) -> io::Result<Option<Vec<u8>>> {
    let mut length: Option<usize> = None;
    let mut saw_header = false;
    loop {
        let mut line = String::new();
        if input.read_line(&mut line)? == 0 {
            return Ok(None);
        }
        let line = line.trim_end_matches(['\r', '\n']);
        if line.is_empty() {
            if saw_header {
                break;
            }
            continue;
        }
        saw_header = true;
        if let Some((name, value)) = line.split_once(':') {
            if name.trim().eq_ignore_ascii_case("content-length") {
                length = value.trim().parse().ok();
            }
        }
    }
    let length = match length {
        Some(n) if n <= MAX_BODY => n,
        _ => {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "a message without a valid Content-Length header",
            ))
        }
    };
    let mut body = vec![0; length];
    match input.read_exact(&mut body) {
        Ok(()) => Ok(Some(body)),
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Ok(None),
        Err(e) => Err(e),
    }
}

fn error(id: Value, code: i64, message: &str) -> Value {
    json!({"jsonrpc": "2.0", "id": id, "error": {"code": code, "message": message}})
}

fn write_loop(mut output: impl Write, messages: &Receiver<Message>, raw: &Receiver<Value>) {
    loop {
        let written = select! {
            recv(messages) -> m => match m {
                Ok(m) => m.write(&mut output),
                Err(_) => return,
            },
            recv(raw) -> v => match v {
                Ok(v) => write_raw(&mut output, &v),
                Err(_) => continue,
            },
        };
        if written.is_err() {
            // The client is gone; what is left to say has nowhere to go.
            return;
        }
    }
}

fn write_raw(output: &mut impl Write, value: &Value) -> io::Result<()> {
    let text = value.to_string();
    write!(output, "Content-Length: {}\r\n\r\n{text}", text.len())?;
    output.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(body: &str) -> String {
        format!("Content-Length: {}\r\n\r\n{body}", body.len())
    }

    #[test]
    fn a_malformed_body_is_answered_and_the_next_message_read() {
        let input =
            frame("{not json") + &frame(r#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#);
        let (tx, rx) = unbounded();
        let (raw_tx, raw_rx) = unbounded();
        read_loop(io::Cursor::new(input.into_bytes()), &tx, &raw_tx);
        assert_eq!(raw_rx.try_recv().unwrap()["error"]["code"], -32700);
        assert!(matches!(rx.try_recv(), Ok(Message::Notification(n)) if n.method == "initialized"));
    }

    #[test]
    fn a_header_without_length_is_skipped() {
        let input =
            "X-Nothing: 1\r\n\r\n".to_string() + &frame(r#"{"jsonrpc":"2.0","method":"exit"}"#);
        let (tx, rx) = unbounded();
        let (raw_tx, raw_rx) = unbounded();
        read_loop(io::Cursor::new(input.into_bytes()), &tx, &raw_tx);
        assert!(raw_rx.try_recv().is_ok());
        assert!(matches!(rx.try_recv(), Ok(Message::Notification(n)) if n.method == "exit"));
    }
}
