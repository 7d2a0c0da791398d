//! The live monitor under load: a fleet of simulated drones flown by one
//! `eamos run --monitor` in real time (each drone's telemetry at the
//! simulator's 10 Hz), its page open in a real headless Chromium. The page
//! measures, from the wall-clock stamp the monitor puts on each event
//! (`sent`), how long events take to be handled and to reach a drawn
//! frame (`EamosLive.latency`); after a warm-up the figures start again,
//! and the page's live JavaScript heap (after a collection) and its
//! elements are counted at the start and at the end, to show whether the
//! page grows over a long flight.
//!
//! Where Chromium or its driver is missing the report says so; nothing is
//! made up.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use eamos_browser::Browser;

/// Simulated metres of each leg: a minute at the profile's 5 m/s.
const LEG_M: f64 = 300.0;
/// Metres between two drones' homes, across the legs' direction.
const SPACING_M: f64 = 8.0;
/// From the page's first sample to the start of the measurement: the
/// graph laid out, every marker drawn, every trail started.
const WARM_UP: Duration = Duration::from_secs(10);
/// How long the run and the page may take to show every drone.
const PATIENCE: Duration = Duration::from_secs(180);

/// Latencies from the monitor's stamp to the page, in milliseconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Latency {
    pub count: u64,
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
}

/// The page's live heap and its elements at one moment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PageSize {
    pub heap_bytes: u64,
    pub elements: u64,
}

/// What one monitored flight showed.
#[derive(Debug, Clone)]
pub struct MonitorRun {
    pub drones: usize,
    /// The span measured, after the warm-up.
    pub measured: Duration,
    /// From the monitor to the page's handler, and to the frame drawn.
    pub handled: Latency,
    pub painted: Latency,
    pub start: PageSize,
    pub end: PageSize,
    /// The largest live heap seen, sampled every minute and at the end.
    pub largest_heap_bytes: u64,
}

/// How often the page's size is sampled during the measurement.
const SAMPLE: Duration = Duration::from_secs(60);

/// The mission: every drone takes off and flies legs back and forth along
/// x, long enough for the warm-up and `span`; no two drones' legs meet.
fn mission(drones: usize, span: Duration) -> String {
    let legs = ((WARM_UP + span).as_secs_f64() / 60.0).ceil() as usize * 2 + 2;
    let mut text = String::from("package MonitorLoad\n\n");
    for k in 1..=drones {
        text.push_str(&format!("var D{k} Quadcopter\n"));
    }
    text.push_str("\nfunc SEQ_Main() {\n\tPAR_Fleet()\n}\n\nfunc PAR_Fleet() {\n");
    for k in 1..=drones {
        text.push_str(&format!("\tSEQ_D{k}()\n"));
    }
    text.push_str("}\n");
    for k in 1..=drones {
        text.push_str(&format!(
            "\nfunc SEQ_D{k}() {{\n\tD{k}.Arm()\n\tD{k}.Takeoff(5)\n"
        ));
        for leg in 0..legs {
            let x = if leg % 2 == 0 { LEG_M } else { -LEG_M };
            text.push_str(&format!("\tD{k}.FlyByX({x})\n"));
        }
        text.push_str(&format!("\tD{k}.Land()\n\tD{k}.Disarm()\n}}\n"));
    }
    text
}

/// Homes side by side across the legs.
fn fleet(drones: usize) -> String {
    (1..=drones)
        .map(|k| {
            format!(
                "[drones.D{k}]\nhome = {{ x = 0.0, y = {:.1}, z = 0.0 }}\n",
                (k - 1) as f64 * SPACING_M
            )
        })
        .collect()
}

/// The run, killed when the measurement ends however it ends.
struct Run(Child);

impl Drop for Run {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Flies `drones` drones for the warm-up and `span` under the monitor, its
/// page in Chromium. `None` where no browser is installed.
pub fn measure(
    exe: &Path,
    dir: &Path,
    drones: usize,
    span: Duration,
) -> Result<Option<MonitorRun>, String> {
    if !eamos_browser::available() {
        return Ok(None);
    }
    let dir = dir.join("monitor");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .map(|_| path.clone())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    let mission = write("mission.go", mission(drones, span))?;
    let fleet = write("fleet.toml", fleet(drones))?;
    let mut child = Command::new(exe)
        .arg("run")
        .arg(&mission)
        .arg("--fleet")
        .arg(&fleet)
        .args(["--monitor", "127.0.0.1:0", "--speed", "1", "--out"])
        .arg(dir.join("out"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    let stderr = child.stderr.take().ok_or("no standard error")?;
    let mut run = Run(child);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(url) = line.strip_prefix("monitor: ") {
                let _ = tx.send(Ok(url.to_string()));
            } else if line.starts_with("error") {
                let _ = tx.send(Err(line));
            }
        }
    });
    let url = match rx.recv_timeout(PATIENCE) {
        Ok(Ok(url)) => url,
        Ok(Err(e)) => return Err(format!("the monitored run failed: {e}")),
        Err(_) => return Err("the monitored run never said where its monitor is".into()),
    };
    let browser = Browser::start_with(
        1300,
        1000,
        &["--js-flags=--expose-gc", "--enable-precise-memory-info"],
    )?;
    browser.navigate(&url)?;
    let markers =
        format!("return document.querySelectorAll('#plan .live-drone').length === {drones};");
    browser
        .wait_until(&markers, PATIENCE)
        .map_err(|e| format!("the page never showed every drone: {e}"))?;
    std::thread::sleep(WARM_UP);
    latency(&browser, true)?;
    let start = page_size(&browser)?;
    let began = Instant::now();
    let mut largest = start.heap_bytes;
    let mut sampled = began;
    while began.elapsed() < span {
        std::thread::sleep(
            span.saturating_sub(began.elapsed())
                .min(Duration::from_secs(1)),
        );
        if matches!(run.0.try_wait(), Ok(Some(_))) {
            return Err("the monitored run ended before the measurement did".into());
        }
        if sampled.elapsed() >= SAMPLE {
            sampled = Instant::now();
            largest = largest.max(page_size(&browser)?.heap_bytes);
        }
    }
    let (handled, painted) = latency(&browser, false)?;
    let end = page_size(&browser)?;
    drop(browser);
    drop(run);
    Ok(Some(MonitorRun {
        drones,
        measured: began.elapsed(),
        handled,
        painted,
        start,
        end,
        largest_heap_bytes: largest.max(end.heap_bytes),
    }))
}

/// The page's latencies so far (`reset` starts them again).
fn latency(b: &Browser, reset: bool) -> Result<(Latency, Latency), String> {
    let v = b.eval(&format!(
        "return EamosLive.latency(window.eamosView, {reset});"
    ))?;
    let read = |what: &str| -> Result<Latency, String> {
        let l = &v[what];
        let f = |k: &str| l[k].as_f64().unwrap_or(f64::NAN);
        Ok(Latency {
            count: l["count"]
                .as_u64()
                .ok_or_else(|| format!("the page measured no {what} latency: {v}"))?,
            p50: f("p50"),
            p99: f("p99"),
            max: f("max"),
        })
    };
    Ok((read("handled")?, read("painted")?))
}

/// The page's live heap after a garbage collection, and its elements.
fn page_size(b: &Browser) -> Result<PageSize, String> {
    let v = b.eval(
        "if (window.gc) window.gc(); \
         return [performance.memory ? performance.memory.usedJSHeapSize : null, \
                 document.getElementsByTagName('*').length];",
    )?;
    let number = |i: usize| {
        v[i].as_u64()
            .ok_or_else(|| format!("the page did not say its size: {v}"))
    };
    Ok(PageSize {
        heap_bytes: number(0)?,
        elements: number(1)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_load_mission_flies_every_drone_long_enough_on_legs_that_never_meet() {
        let text = mission(3, Duration::from_secs(600));
        assert_eq!(text.matches("Quadcopter").count(), 3);
        // Ten minutes and the warm-up at a minute a leg, and spare legs.
        assert_eq!(text.matches("D2.FlyByX(").count(), 24);
        let homes = fleet(3);
        assert!(homes.contains("[drones.D3]\nhome = { x = 0.0, y = 16.0, z = 0.0 }"));
    }
}
