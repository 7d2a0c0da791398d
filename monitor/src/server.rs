//! The HTTP side: the page at `/`, the events at `/events` as server-sent
//! events, nothing else (no route takes a command).

use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::State;
use axum::http::header;
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse};
use axum::routing::get;
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

#[derive(Clone)]
struct Served {
    page: Arc<str>,
    feed: Feed,
}

/// Serves `page` and `feed` until `stop`.
pub async fn serve(monitor: Monitor, page: String, feed: Feed, stop: CancellationToken) {
    let app = Router::new()
        .route("/", get(page_of))
        .route("/events", get(events))
        .with_state(Served {
            page: page.into(),
            feed,
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
