//! The live monitor, as the commands that start it share it (`eamos run
//! --monitor ADDR`, `eamos deploy --monitor ADDR`, `eamos monitor`): the
//! mission's report page served on ADDR (the loopback unless the address
//! says otherwise) and fed with the run's events. The drones never wait
//! for it: it is one more sink of their events, and it serves nothing
//! that commands a drone.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};

use eamos_monitor::Feed;
use tokio_util::sync::CancellationToken;

use super::mission::Mission;

/// `--monitor`'s value: `HOST:PORT`, or a port alone for the loopback.
pub fn parse_addr(s: &str) -> Result<SocketAddr, String> {
    if let Ok(port) = s.parse::<u16>() {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    s.parse::<SocketAddr>().map_err(|_| {
        format!("`{s}` is not an address to listen on: give HOST:PORT (127.0.0.1:8080) or a port")
    })
}

/// A monitor started: feed it the run's events; it serves until `stop`.
pub struct Running {
    pub feed: Feed,
    pub stop: CancellationToken,
    pub task: tokio::task::JoinHandle<()>,
}

/// Binds `addr`, then serves `mission`'s report page and the events fed
/// to it (and, with `abort`, the page's abort button). A taken or bad
/// address is an error before anything flies.
pub async fn start(
    addr: SocketAddr,
    mission: &Mission,
    abort: Option<eamos_monitor::Abort>,
) -> Result<Running, String> {
    let monitor = eamos_monitor::bind(addr).await?;
    let (model, _) = super::view::model_of(
        &mission.source,
        &mission.net,
        &mission.profiles,
        &mission.fleet,
        false,
    );
    let page = eamos_view::page(&model);
    let shown = monitor.local_addr().unwrap_or(addr);
    eprintln!("monitor: http://{shown}/");
    let feed = Feed::new();
    let stop = CancellationToken::new();
    let task = tokio::spawn(eamos_monitor::serve(
        monitor,
        page,
        feed.clone(),
        abort,
        stop.clone(),
    ));
    Ok(Running { feed, stop, task })
}

/// Joins `mission`'s zenoh network as a read-only observer feeding
/// `feed`: each drone's telemetry, each peer's events and which peers are
/// up (see
/// `eamos_exec::transport::observe`).
pub async fn observe(
    mission: &Mission,
    feed: &Feed,
) -> Result<eamos_exec::transport::observe::Observer, String> {
    let id = &mission.slices.mission_id;
    let peers = eamos_exec::runner::peers(&mission.slices);
    // No peer of the mission: it connects to every peer's endpoints (the
    // ground station's too), or to whoever routes for the fleet.
    let mut options = mission.fleet.outsider_options(id, &peers);
    // Over TLS it shows the ground station's certificate: the monitor runs
    // where the ground station does, and its abort is the ground
    // station's too.
    options.tls = mission.fleet.tls_files(eamos_exec::transport::GCS);
    let sink: std::sync::Arc<dyn eamos_exec::event::Sink> = std::sync::Arc::new(feed.clone());
    eamos_exec::transport::observe::observe(id, &options, sink)
        .await
        .map_err(|e| e.to_string())
}

/// The page's abort: `mission` aborted as `eamos abort` aborts it, from
/// this process, the command sealed with `key` (the ground station's).
pub fn abort_with(mission: &Mission, key: eamos_seal::GroundKey) -> eamos_monitor::Abort {
    let sealer = eamos_exec::abort::sealer(std::sync::Arc::new(key));
    let id = mission.slices.mission_id.clone();
    let name = mission.slices.mission.clone();
    let peers = eamos_exec::runner::peers(&mission.slices);
    // Joined as `eamos abort` joins.
    let mut options = mission.fleet.outsider_options(&id, &peers);
    options.tls = mission.fleet.tls_files(eamos_exec::transport::GCS);
    std::sync::Arc::new(move || {
        let (sealer, id, name, peers, options) = (
            sealer.clone(),
            id.clone(),
            name.clone(),
            peers.clone(),
            options.clone(),
        );
        Box::pin(async move {
            let me = format!("monitor-abort-{}", std::process::id());
            let command = eamos_exec::abort::AbortCommand::new(&id, &format!("the monitor ({me})"));
            let sent = eamos_exec::abort::broadcast(
                &command,
                &me,
                &peers,
                &options,
                Some(&sealer),
                std::time::Duration::from_secs(10),
            )
            .await
            .map_err(|e| format!("cannot join the mission's network: {e}"))?;
            Ok(format!(
                "{name}: abort sent to {} peers ({} up), {} not acknowledged",
                sent.sent_to.len(),
                sent.reached.len(),
                sent.unacknowledged
            ))
        })
    })
}
