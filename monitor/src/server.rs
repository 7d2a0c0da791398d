//! The HTTP side: the page at `/`, the events at `/events` as server-sent
//! events, and `POST /abort` only when the process holds the ground
//! station's key (`eamos monitor --key`): nothing else takes a command.

use std::convert::Infallible;
use std::future::Future;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse};
use axum::routing::{get, post};
use axum::Router;
use tokio::net::TcpListener;
use tokio::sync::{broadcast, mpsc};
use tokio_stream::wrappers::ReceiverStream;
use tokio_stream::StreamExt;
use tokio_util::sync::CancellationToken;

use crate::feed::{Feed, Frame};

/// How many frames wait for one page's connection before its writer waits
/// (it alone: the feed's broadcast goes on without it).
const PAGE_QUEUE: usize = 256;

/// The monitor's listening socket, bound before the mission starts so that
/// a taken port is an error before anything flies.
pub struct Monitor {
    listener: TcpListener,
}

/// Binds `addr`; the error says which address and why.
pub async fn bind(addr: SocketAddr) -> Result<Monitor, String> {
    TcpListener::bind(addr)
        .await
        .map(|listener| Monitor { listener })
        .map_err(|e| format!("the monitor cannot listen on {addr}: {e}"))
}

impl Monitor {
    /// Where it listens (the port the system chose, for port 0).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.listener.local_addr().ok()
    }
}

/// Aborts the mission, signed with the ground station's key (as `eamos
/// abort` does); says what came of it.
pub type Abort =
    Arc<dyn Fn() -> Pin<Box<dyn Future<Output = Result<String, String>> + Send>> + Send + Sync>;

/// The header a page's abort must carry: a browser sends no custom header
/// across origins without asking first (which this server never allows),
/// so another site open in the same browser cannot post an abort.
pub const CONFIRM_HEADER: &str = "x-eamos-confirm";

#[derive(Clone)]
struct Served {
    page: Arc<str>,
    feed: Feed,
    abort: Option<Abort>,
}

/// Serves `page` and `feed` until `stop`; with `abort`, an abort button
/// on the page and `POST /abort` behind it.
pub async fn serve(
    monitor: Monitor,
    page: String,
    feed: Feed,
    abort: Option<Abort>,
    stop: CancellationToken,
) {
    // The page draws the button only when the route exists.
    let page = match abort {
        Some(_) => page.replacen("<body>", "<body data-abort=\"abort\">", 1),
        None => page,
    };
    let mut app = Router::new()
        .route("/", get(page_of))
        .route("/events", get(events));
    if abort.is_some() {
        app = app.route("/abort", post(abort_mission));
    }
    let app = app.with_state(Served {
        page: page.into(),
        feed,
        abort,
    });
    let _ = axum::serve(monitor.listener, app)
        .with_graceful_shutdown(async move { stop.cancelled().await })
        .await;
}

async fn page_of(State(s): State<Served>) -> impl IntoResponse {
    (
        [(header::CACHE_CONTROL, "no-store")],
        Html(s.page.to_string()),
    )
}

async fn abort_mission(State(s): State<Served>, headers: HeaderMap) -> (StatusCode, String) {
    if headers.get(CONFIRM_HEADER).and_then(|v| v.to_str().ok()) != Some("abort") {
        return (
            StatusCode::FORBIDDEN,
            format!("an abort must carry `{CONFIRM_HEADER}: abort`"),
        );
    }
    let Some(abort) = s.abort else {
        return (StatusCode::NOT_FOUND, String::new());
    };
    match abort().await {
        Ok(said) => (StatusCode::OK, said),
        Err(e) => (StatusCode::BAD_GATEWAY, e),
    }
}

async fn events(
    State(s): State<Served>,
) -> Sse<impl tokio_stream::Stream<Item = Result<SseEvent, Infallible>>> {
    let (tx, rx) = mpsc::channel::<Arc<Frame>>(PAGE_QUEUE);
    // Subscribed before catching up, so that nothing falls between.
    let live = s.feed.subscribe();
    tokio::spawn(forward(s.feed, live, tx));
    let stream = ReceiverStream::new(rx)
        .map(|f| Ok(SseEvent::default().id(f.seq.to_string()).data(&f.json)));
    Sse::new(stream).keep_alive(KeepAlive::new().interval(Duration::from_secs(5)))
}

/// Hands one page the state so far, then every event, each once and in
/// order; a page that fell behind the broadcast is handed the latest
/// state again (its missed samples are lost, its markings are not).
async fn forward(
    feed: Feed,
    mut live: broadcast::Receiver<Arc<Frame>>,
    tx: mpsc::Sender<Arc<Frame>>,
) {
    let mut last = 0;
    let mut backlog = feed.catch_up();
    loop {
        for f in backlog.drain(..) {
            if f.seq > last {
                last = f.seq;
                if tx.send(f).await.is_err() {
                    return;
                }
            }
        }
        match live.recv().await {
            Ok(f) => backlog.push(f),
            Err(broadcast::error::RecvError::Lagged(_)) => backlog = feed.catch_up(),
            Err(broadcast::error::RecvError::Closed) => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_exec::event::{Event, Kind, Sink};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// One HTTP/1.1 request on the loopback; the response as it reads
    /// within `limit` (an event stream never ends by itself).
    async fn ask(addr: SocketAddr, method: &str, path: &str, until: &str) -> String {
        ask_with(addr, method, path, "", until).await
    }

    async fn ask_with(
        addr: SocketAddr,
        method: &str,
        path: &str,
        header: &str,
        until: &str,
    ) -> String {
        let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
        let req = format!(
            "{method} {path} HTTP/1.1\r\nHost: {addr}\r\n{header}Content-Length: 0\r\nConnection: close\r\n\r\n"
        );
        s.write_all(req.as_bytes()).await.unwrap();
        let mut got = Vec::new();
        let mut buf = [0u8; 4096];
        let read = async {
            loop {
                let n = s.read(&mut buf).await.unwrap_or(0);
                if n == 0 {
                    break;
                }
                got.extend_from_slice(&buf[..n]);
                if String::from_utf8_lossy(&got).contains(until) {
                    break;
                }
            }
        };
        let _ = tokio::time::timeout(Duration::from_secs(20), read).await;
        String::from_utf8_lossy(&got).into_owned()
    }

    #[tokio::test]
    async fn it_serves_the_page_and_the_events_and_takes_no_command() {
        let monitor = bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
        let addr = monitor.local_addr().unwrap();
        assert!(addr.ip().is_loopback());
        let feed = Feed::new();
        feed.event(&Event {
            time: 1.0,
            drone: "GCS".into(),
            kind: Kind::PeerLost {
                peer: "Drone2".into(),
            },
        });
        let stop = CancellationToken::new();
        let server = tokio::spawn(serve(
            monitor,
            "<p>page</p>".into(),
            feed,
            None,
            stop.clone(),
        ));

        let page = ask(addr, "GET", "/", "</p>").await;
        assert!(page.starts_with("HTTP/1.1 200"), "{page}");
        assert!(page.contains("<p>page</p>"));
        // A page that connects late is handed what happened before.
        let events = ask(addr, "GET", "/events", "peer_lost").await;
        assert!(events.contains("text/event-stream"), "{events}");
        assert!(
            events.contains(
                r#"data: {"time":1.0,"drone":"GCS","event":"peer_lost","peer":"Drone2","sent":"#
            ),
            "{events}"
        );
        // Nothing it serves takes a command.
        for (method, path) in [("POST", "/"), ("POST", "/events"), ("POST", "/abort")] {
            let answer = ask(addr, method, path, "\r\n\r\n").await;
            assert!(
                answer.starts_with("HTTP/1.1 405") || answer.starts_with("HTTP/1.1 404"),
                "{method} {path}: {answer}"
            );
        }
        stop.cancel();
        server.await.unwrap();
    }

    #[tokio::test]
    async fn with_the_key_an_abort_needs_its_confirmation_header() {
        let monitor = bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
        let addr = monitor.local_addr().unwrap();
        let calls = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let counted = calls.clone();
        let abort: Abort = Arc::new(move || {
            counted.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            Box::pin(async { Ok("abort sent".to_string()) })
        });
        let stop = CancellationToken::new();
        let server = tokio::spawn(serve(
            monitor,
            "<body><p>page</p>".into(),
            Feed::new(),
            Some(abort),
            stop.clone(),
        ));
        let page = ask(addr, "GET", "/", "</p>").await;
        assert!(page.contains(r#"<body data-abort="abort">"#), "{page}");
        // A plain post (a form on another site) is refused.
        let refused = ask(addr, "POST", "/abort", "\r\n\r\n").await;
        assert!(refused.starts_with("HTTP/1.1 403"), "{refused}");
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 0);
        let done = ask_with(
            addr,
            "POST",
            "/abort",
            "X-Eamos-Confirm: abort\r\n",
            "abort sent",
        )
        .await;
        assert!(done.starts_with("HTTP/1.1 200"), "{done}");
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 1);
        stop.cancel();
        server.await.unwrap();
    }
}
