//! Mission time: the one clock a fleet agrees on.
//!
//! Real drones fly in wall time; a simulated fleet flies in simulated time
//! that may run many times faster than the wall clock. Telemetry is stamped
//! with mission time and the executor sleeps on the same clock (`PauseFor`,
//! `Hover`), so a mission behaves the same at any simulation speed.

use std::time::Duration;

use tokio::sync::watch;
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
    /// Simulated time published by the simulation's stepping task.
    Simulated { time: watch::Receiver<f64> },
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
            kind: ClockKind::Simulated { time },
        }
    }

    pub fn is_simulated(&self) -> bool {
        matches!(self.kind, ClockKind::Simulated { .. })
    }

    /// Seconds of mission time elapsed.
    pub fn now(&self) -> f64 {
        match &self.kind {
            ClockKind::Wall { origin } => origin.elapsed().as_secs_f64(),
            ClockKind::Simulated { time } => *time.borrow(),
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
            ClockKind::Simulated { time } => {
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
    async fn a_wall_clock_counts_tokio_time() {
        let clock = MissionClock::wall();
        clock.sleep(1.5).await;
        assert!((clock.now() - 1.5).abs() < 0.01);
    }
}
