//! Mission time: the one clock a fleet agrees on.
//!
//! Real drones fly in wall time; a simulated fleet flies in simulated time
//! that may run many times faster than the wall clock. Telemetry is stamped
//! with mission time and the executor sleeps on the same clock (`PauseFor`,
//! `Hover`), so a mission behaves the same at any simulation speed.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock, Weak};
use std::time::Duration;

use tokio::sync::{watch, Notify};
use tokio::time::Instant;

/// A handle on mission time, cheap to clone. Time is in seconds since the
/// mission (or the simulation) started.
#[derive(Debug, Clone)]
pub struct MissionClock {
    kind: ClockKind,
}

#[derive(Debug, Clone)]
enum ClockKind {
    /// Wall time since `origin` (tokio's clock, so paused-time tests work).
    Wall { origin: Instant },
    /// Simulated time published by the simulation's stepping task; with
    /// `alarms`, by a simulation that steps lazily while nothing moves
    /// (see [`Alarms`]).
    Simulated {
        time: watch::Receiver<f64>,
        alarms: Option<Arc<Alarms>>,
    },
    /// An autopilot's own clock (see [`MissionClock::following`]).
    Following { sample: watch::Receiver<Sample> },
}

/// A simulation that steps lazily: it may be behind the present while
/// nothing moves, and is brought up to it before its time is read.
pub trait Pace: Send + Sync {
    /// Steps the simulation up to the present, unless it is stepping now.
    fn catch_up(&self);
}

/// The deadlines of everyone sleeping on a lazily stepped simulated clock.
///
/// A simulation that stepped every few hundred microseconds of wall time
/// and woke every sleeper at each step costs an idle process a few percent
/// of a core; with this, the simulation knows the next instant anyone waits
/// for, steps up to it at once and wakes its sleepers only then, so the
/// same simulated instants are reached with a handful of wake-ups.
#[derive(Default)]
pub struct Alarms {
    /// Deadline (the bits of a positive `f64`, which order like it) to
    /// the number of sleepers waiting for it.
    deadlines: Mutex<BTreeMap<u64, usize>>,
    /// Rung when time has passed a deadline.
    rung: Notify,
    /// Notified when a deadline earlier than all others is set.
    earlier: Arc<Notify>,
    pace: OnceLock<Weak<dyn Pace>>,
}

impl Alarms {
    /// Alarms of the simulation `pace`.
    pub fn new(pace: Weak<dyn Pace>) -> Self {
        let alarms = Self::default();
        let _ = alarms.pace.set(pace);
        alarms
    }

    /// The earliest deadline anyone waits for.
    pub fn earliest(&self) -> Option<f64> {
        let deadlines = self.deadlines.lock().unwrap_or_else(|p| p.into_inner());
        deadlines.keys().next().map(|&bits| f64::from_bits(bits))
    }

    /// Wakes the sleepers whose deadline `now` has reached (the others go
    /// back to sleep).
    pub fn ring(&self, now: f64) {
        if self.earliest().is_some_and(|t| now >= t) {
            self.rung.notify_waiters();
        }
    }

    /// Notified when a deadline earlier than all others is set: the
    /// stepping task then plans its next wake-up again.
    pub fn earlier(&self) -> Arc<Notify> {
        self.earlier.clone()
    }

    fn catch_up(&self) {
        if let Some(pace) = self.pace.get().and_then(Weak::upgrade) {
            pace.catch_up();
        }
    }

    fn set(&self, t: f64) -> AlarmSet<'_> {
        let bits = t.to_bits();
        let first = {
            let mut deadlines = self.deadlines.lock().unwrap_or_else(|p| p.into_inner());
            let first = deadlines.keys().next().is_none_or(|&b| bits < b);
            *deadlines.entry(bits).or_default() += 1;
            first
        };
        if first {
            self.earlier.notify_one();
        }
        AlarmSet { alarms: self, bits }
    }
}

impl std::fmt::Debug for Alarms {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Alarms")
            .field("earliest", &self.earliest())
            .finish_non_exhaustive()
    }
}

/// A sleeper's deadline, unset when the sleeper stops waiting.
struct AlarmSet<'a> {
    alarms: &'a Alarms,
    bits: u64,
}

impl Drop for AlarmSet<'_> {
    fn drop(&mut self) {
        let mut deadlines = self
            .alarms
            .deadlines
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if let Some(n) = deadlines.get_mut(&self.bits) {
            *n -= 1;
            if *n == 0 {
                deadlines.remove(&self.bits);
            }
        }
    }
}

/// The latest reading of a followed clock: mission time `at` the wall
/// instant `seen`, advancing at `rate` mission seconds per wall second
/// until the next reading.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    at: f64,
    seen: Instant,
    rate: f64,
}

/// How long (wall) a followed clock holds still after a reading before it
/// runs on by itself: readings come ten times a second or more, so it
/// runs on only when the autopilot falls silent.
const HOLD: Duration = Duration::from_millis(500);

impl Sample {
    fn now(&self) -> f64 {
        let running = self.seen.elapsed().saturating_sub(HOLD);
        self.at + running.as_secs_f64() * self.rate
    }
}

/// Feeds a followed clock with an autopilot's time stamps (`time_boot_ms`
/// of its telemetry): mission time then runs at the autopilot's pace, so a
/// simulator run at a speed-up times every `Hover` and `PauseFor` in its
/// own seconds. Between readings, and while the link is silent, time goes
/// on at the last measured pace; it never runs backwards, and an
/// autopilot that reboots (its clock starts again at zero) does not set it
/// back.
#[derive(Debug)]
pub struct ClockFeed {
    tx: watch::Sender<Sample>,
    /// The autopilot's time and the wall instant of the reading that
    /// started the current pace measurement.
    window: Option<(f64, Instant)>,
    /// The autopilot's time of the last reading.
    last: Option<f64>,
}

impl ClockFeed {
    /// Takes one reading of the autopilot's clock, in its seconds since
    /// boot.
    pub fn reading(&mut self, vehicle: f64) {
        let now = Instant::now();
        let previous = *self.tx.borrow();
        let step = match self.last {
            Some(last) if vehicle >= last => vehicle - last,
            // The first reading, or a reboot: no step to take.
            _ => 0.0,
        };
        self.last = Some(vehicle);
        let mut rate = previous.rate;
        match self.window {
            Some((v0, w0)) if vehicle >= v0 => {
                let wall = now.duration_since(w0).as_secs_f64();
                // Measured over a second or more: readings come in bursts.
                if wall >= 1.0 {
                    rate = ((vehicle - v0) / wall).clamp(0.01, 1000.0);
                    self.window = Some((vehicle, now));
                }
            }
            _ => self.window = Some((vehicle, now)),
        }
        // What the autopilot says passed, unless the clock already ran
        // further on by itself during a silence: it never goes back.
        self.tx.send_replace(Sample {
            at: (previous.at + step).max(previous.now()),
            seen: now,
            rate,
        });
    }
}

impl MissionClock {
    /// Wall time, starting now.
    pub fn wall() -> Self {
        Self {
            kind: ClockKind::Wall {
                origin: Instant::now(),
            },
        }
    }

    /// Wall time counted from `origin`, so that several adapters of one
    /// process stamp telemetry alike.
    pub fn wall_from(origin: Instant) -> Self {
        Self {
            kind: ClockKind::Wall { origin },
        }
    }

    /// Simulated time, as published by whoever advances the simulation.
    pub fn simulated(time: watch::Receiver<f64>) -> Self {
        Self {
            kind: ClockKind::Simulated { time, alarms: None },
        }
    }

    /// Simulated time of a simulation that steps lazily: reading it brings
    /// the simulation up to the present first, and a sleeper sets an alarm
    /// instead of waking at every step.
    pub fn simulated_with_alarms(time: watch::Receiver<f64>, alarms: Arc<Alarms>) -> Self {
        Self {
            kind: ClockKind::Simulated {
                time,
                alarms: Some(alarms),
            },
        }
    }

    /// A clock that follows an autopilot's own time, fed by the returned
    /// [`ClockFeed`]; until the first reading it runs at the wall clock's
    /// pace.
    pub fn following() -> (Self, ClockFeed) {
        let (tx, sample) = watch::channel(Sample {
            at: 0.0,
            seen: Instant::now(),
            rate: 1.0,
        });
        (
            Self {
                kind: ClockKind::Following { sample },
            },
            ClockFeed {
                tx,
                window: None,
                last: None,
            },
        )
    }

    pub fn is_simulated(&self) -> bool {
        matches!(self.kind, ClockKind::Simulated { .. })
    }

    /// Seconds of mission time elapsed.
    pub fn now(&self) -> f64 {
        match &self.kind {
            ClockKind::Wall { origin } => origin.elapsed().as_secs_f64(),
            ClockKind::Simulated { time, alarms } => {
                if let Some(alarms) = alarms {
                    alarms.catch_up();
                }
                *time.borrow()
            }
            ClockKind::Following { sample } => sample.borrow().now(),
        }
    }

    /// Waits until mission time reaches `t`. A simulated clock whose
    /// simulation has stopped never reaches `t`, so this then waits forever
    /// (as time does not pass); wrap it in a cancellation if that matters.
    pub async fn sleep_until(&self, t: f64) {
        if t.is_nan() {
            return;
        }
        match &self.kind {
            ClockKind::Wall { origin } => {
                // About thirty years: beyond any mission, within `Duration`.
                let t = t.clamp(0.0, 1.0e9);
                tokio::time::sleep_until(*origin + Duration::from_secs_f64(t)).await;
            }
            ClockKind::Simulated {
                time,
                alarms: Some(alarms),
            } => {
                alarms.catch_up();
                if *time.borrow() >= t {
                    return;
                }
                let _set = alarms.set(t);
                loop {
                    let rung = alarms.rung.notified();
                    tokio::pin!(rung);
                    rung.as_mut().enable();
                    if *time.borrow() >= t {
                        return;
                    }
                    rung.await;
                }
            }
            ClockKind::Simulated { time, alarms: None } => {
                let mut time = time.clone();
                loop {
                    if *time.borrow_and_update() >= t {
                        return;
                    }
                    if time.changed().await.is_err() {
                        std::future::pending::<()>().await;
                    }
                }
            }
            ClockKind::Following { sample } => {
                let mut sample = sample.clone();
                loop {
                    let s = *sample.borrow_and_update();
                    let left = t.min(1.0e9) - s.now();
                    if left <= 0.0 {
                        return;
                    }
                    // Wake when the present pace says t is reached, or
                    // earlier when a new reading changes the pace.
                    let wall = Duration::from_secs_f64((left / s.rate).min(1.0e9));
                    tokio::select! {
                        _ = tokio::time::sleep(wall) => {}
                        changed = sample.changed() => {
                            if changed.is_err() {
                                // Nobody feeds it any more: time goes on at
                                // the last pace.
                                tokio::time::sleep(wall).await;
                            }
                        }
                    }
                }
            }
        }
    }

    /// Waits `seconds` of mission time.
    pub async fn sleep(&self, seconds: f64) {
        let until = self.now() + seconds.max(0.0);
        self.sleep_until(until).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_simulated_sleep_ends_when_simulated_time_reaches_it() {
        let (tx, rx) = watch::channel(0.0);
        let clock = MissionClock::simulated(rx);
        assert!(clock.is_simulated());
        let sleeper = tokio::spawn({
            let clock = clock.clone();
            async move { clock.sleep_until(2.0).await }
        });
        tx.send(1.0).unwrap();
        tokio::task::yield_now().await;
        assert!(!sleeper.is_finished());
        tx.send(2.0).unwrap();
        sleeper.await.unwrap();
        assert_eq!(clock.now(), 2.0);
    }

    #[tokio::test(start_paused = true)]
    async fn sleeping_until_a_time_that_is_not_a_number_or_is_past_returns_at_once() {
        let (_tx, rx) = watch::channel(5.0);
        let sim = MissionClock::simulated(rx);
        sim.sleep_until(f64::NAN).await;
        sim.sleep_until(4.0).await;
        sim.sleep(-3.0).await;
        let wall = MissionClock::wall();
        wall.sleep_until(f64::NAN).await;
        wall.sleep(-1.0).await;
        assert!(wall.now() < 0.01);
    }

    #[tokio::test(start_paused = true)]
    async fn a_wall_clock_sleep_far_beyond_any_mission_does_not_overflow() {
        let wall = MissionClock::wall();
        let far = tokio::time::timeout(Duration::from_secs(5), wall.sleep_until(1.0e300)).await;
        assert!(far.is_err(), "still sleeping after 5 s");
    }

    #[tokio::test(start_paused = true)]
    async fn a_followed_clock_runs_at_the_autopilots_pace_and_never_back() {
        let (clock, mut feed) = MissionClock::following();
        assert!(!clock.is_simulated());
        // An autopilot eight times as fast as the wall clock, read at 10 Hz.
        let mut boot = 100.0;
        feed.reading(boot);
        for _ in 0..30 {
            tokio::time::advance(Duration::from_millis(100)).await;
            boot += 0.8;
            feed.reading(boot);
        }
        // 24 s of its time in 3 s of the wall's.
        assert!((clock.now() - 24.0).abs() < 0.2, "{}", clock.now());
        // Silent, it holds for half a second, then goes on at that pace.
        let sleeper = tokio::spawn({
            let clock = clock.clone();
            async move { clock.sleep(8.0).await }
        });
        let wall = |ms: u64| async move {
            for _ in 0..ms / 10 {
                tokio::time::advance(Duration::from_millis(10)).await;
                tokio::task::yield_now().await;
            }
        };
        wall(900).await;
        assert!(
            !sleeper.is_finished(),
            "8 s of its time in 0.9 s of the wall's"
        );
        wall(700).await;
        assert!(
            sleeper.is_finished(),
            "8 s of its time took over 1.6 s of the wall's"
        );
        // A reboot starts its clock at zero again; mission time goes on.
        let before = clock.now();
        feed.reading(0.5);
        assert!(clock.now() >= before);
        tokio::time::advance(Duration::from_millis(100)).await;
        feed.reading(1.3);
        assert!(
            clock.now() >= before + 0.7,
            "{} after {before}",
            clock.now()
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_wall_clock_counts_tokio_time() {
        let clock = MissionClock::wall();
        clock.sleep(1.5).await;
        assert!((clock.now() - 1.5).abs() < 0.01);
    }
}
