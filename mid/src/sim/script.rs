//! A scripted pilot: a simulated drone flown "by hand" along a script, for
//! missions that only watch a drone (the hand-flown Drone3 of the paper's
//! experiment D, whose position steers the others).
//!
//! The pilot takes over once the drone is in the air and holding (after
//! the mission's `Takeoff` completed) and not before `start_after` seconds
//! of mission time. It then flies the legs in order. When the last leg is
//! done it lets go: the drone holds where it is and the mission has control
//! again.
//!
//! While the pilot flies, the mission's `Land` and `ReturnHome` take
//! control back (a pilot obeys a call to land), and the mission's other
//! motions are refused with a reason that says the drone is piloted: a
//! mission that tries to steer a watched drone is told so, rather than
//! fighting the pilot silently.

use serde::{Deserialize, Serialize};

use super::kinematics::Multirotor;
use crate::api::{FlightMode, Vec3};

/// What the pilot will fly (from a fleet file, or built in a test).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    /// Mission time before which the pilot does not take over, s.
    #[serde(default)]
    pub start_after: f64,
    pub legs: Vec<Leg>,
}

/// One leg of a script, in the drone's local frame (metres from home).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "leg", rename_all = "snake_case", deny_unknown_fields)]
pub enum Leg {
    /// Be at (x, y, z) at `t` seconds after the pilot took over: fly there
    /// at the speed that arrives in time (as fast as the drone can if it is
    /// late), then wait there until `t`.
    At { t: f64, x: f64, y: f64, z: f64 },
    /// Fly to (x, y, z), horizontally at `speed` m/s at most.
    GoTo { x: f64, y: f64, z: f64, speed: f64 },
    /// Stay where the last leg ended for `seconds`.
    Hold { seconds: f64 },
}

impl Leg {
    fn target(&self) -> Option<Vec3> {
        match *self {
            Leg::At { x, y, z, .. } | Leg::GoTo { x, y, z, .. } => Some(Vec3::new(x, y, z)),
            Leg::Hold { .. } => None,
        }
    }
}

impl Script {
    /// Checks what serde cannot: finite numbers, positive speeds, times in
    /// order.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.start_after.is_finite() && self.start_after >= 0.0) {
            return Err(format!(
                "start_after must be a time of zero or more seconds, not {}",
                self.start_after
            ));
        }
        let mut last_t = 0.0;
        for (i, leg) in self.legs.iter().enumerate() {
            let n = i + 1;
            if let Some(p) = leg.target() {
                if !p.is_finite() {
                    return Err(format!("leg {n}: the position {p} is not finite"));
                }
            }
            match *leg {
                Leg::At { t, .. } => {
                    if !(t.is_finite() && t >= last_t) {
                        return Err(format!(
                            "leg {n}: time {t} s comes before the previous leg's {last_t} s"
                        ));
                    }
                    last_t = t;
                }
                Leg::GoTo { speed, .. } => {
                    if !(speed.is_finite() && speed > 0.0) {
                        return Err(format!("leg {n}: speed must be above zero, not {speed}"));
                    }
                }
                Leg::Hold { seconds } => {
                    if !(seconds.is_finite() && seconds >= 0.0) {
                        return Err(format!(
                            "leg {n}: a hold lasts zero or more seconds, not {seconds}"
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// What the pilot did in one update, for the adapter log.
#[derive(Debug, Clone, PartialEq)]
pub enum PilotEvent {
    TookOver,
    /// Leg `index` (from 0) began.
    LegStarted {
        index: usize,
    },
    /// Leg `index` ended with the drone at `position`.
    LegDone {
        index: usize,
        position: Vec3,
    },
    /// The script ended; the drone holds and the mission has control.
    LetGo,
    /// The mission took control back (`Land`, `ReturnHome`).
    Released,
    /// The drone could not fly the leg (refused by the model).
    Stuck {
        index: usize,
        reason: String,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Waiting,
    Flying {
        /// Mission time the pilot took over.
        start: f64,
        leg: usize,
        /// Mission time the current leg began.
        leg_start: f64,
    },
    Done,
}

/// The pilot flying a [`Script`], stepped with the drone.
#[derive(Debug, Clone)]
pub struct ScriptPilot {
    script: Script,
    state: State,
}

impl ScriptPilot {
    pub fn new(script: Script) -> Self {
        Self {
            script,
            state: State::Waiting,
        }
    }

    pub fn script(&self) -> &Script {
        &self.script
    }

    /// Whether the pilot has the controls right now.
    pub fn is_flying(&self) -> bool {
        matches!(self.state, State::Flying { .. })
    }

    pub fn is_done(&self) -> bool {
        self.state == State::Done
    }

    /// The mission takes control back; the pilot will not fly again.
    pub fn release(&mut self) -> Option<PilotEvent> {
        let was_flying = self.is_flying();
        self.state = State::Done;
        was_flying.then_some(PilotEvent::Released)
    }

    /// Moves the sticks for mission time `now`. `mission_busy` says the
    /// mission still runs a motion (the take-off), which the pilot waits
    /// for before taking over.
    pub fn update(
        &mut self,
        now: f64,
        drone: &mut Multirotor,
        mission_busy: bool,
    ) -> Vec<PilotEvent> {
        let mut events = Vec::new();
        if self.state == State::Waiting {
            let ready = drone.is_airborne()
                && drone.is_armed()
                && !mission_busy
                && now >= self.script.start_after;
            if !ready {
                return events;
            }
            events.push(PilotEvent::TookOver);
            self.state = State::Flying {
                start: now,
                leg: 0,
                leg_start: now,
            };
            self.begin_leg(now, drone, &mut events);
        }
        // A leg may end and the next begin in the same update (a zero hold).
        for _ in 0..=self.script.legs.len() {
            let State::Flying {
                start,
                leg,
                leg_start,
            } = self.state
            else {
                break;
            };
            if !drone.is_airborne() {
                // Landed under the pilot (battery): nothing more to fly.
                self.state = State::Done;
                events.push(PilotEvent::LetGo);
                break;
            }
            let done = match self.script.legs[leg] {
                Leg::At { t, x, y, z } => {
                    drone.is_at(Vec3::new(x, y, z)) && now - start >= t - 1e-9
                }
                Leg::GoTo { x, y, z, .. } => drone.is_at(Vec3::new(x, y, z)),
                Leg::Hold { seconds } => now - leg_start >= seconds - 1e-9,
            };
            if !done {
                if let (Leg::At { x, y, z, .. }, true) = (&self.script.legs[leg], drone.arrived()) {
                    // Early: wait on the waypoint.
                    drone.hold_at(Vec3::new(*x, *y, *z));
                    drone.set_mode(FlightMode::Piloted);
                }
                break;
            }
            events.push(PilotEvent::LegDone {
                index: leg,
                position: drone.position(),
            });
            if leg + 1 == self.script.legs.len() {
                self.state = State::Done;
                let at = self.script.legs[leg].target().unwrap_or(drone.position());
                drone.hold_at(at);
                events.push(PilotEvent::LetGo);
                break;
            }
            self.state = State::Flying {
                start,
                leg: leg + 1,
                leg_start: now,
            };
            self.begin_leg(now, drone, &mut events);
        }
        events
    }

    fn begin_leg(&mut self, now: f64, drone: &mut Multirotor, events: &mut Vec<PilotEvent>) {
        let State::Flying { start, leg, .. } = self.state else {
            return;
        };
        let Some(current) = self.script.legs.get(leg).cloned() else {
            self.state = State::Done;
            drone.hold();
            events.push(PilotEvent::LetGo);
            return;
        };
        events.push(PilotEvent::LegStarted { index: leg });
        let result = match current {
            Leg::At { t, x, y, z } => {
                let target = Vec3::new(x, y, z);
                let speed = on_time_speed(drone, target, t - (now - start));
                drone.go_to_at(target, speed, FlightMode::Piloted)
            }
            Leg::GoTo { x, y, z, speed } => {
                drone.go_to_at(Vec3::new(x, y, z), speed, FlightMode::Piloted)
            }
            Leg::Hold { .. } => {
                drone.hold_at(drone.reference());
                Ok(())
            }
        };
        drone.set_mode(FlightMode::Piloted);
        if let Err(refusal) = result {
            events.push(PilotEvent::Stuck {
                index: leg,
                reason: refusal.to_string(),
            });
            self.state = State::Done;
            drone.hold();
            events.push(PilotEvent::LetGo);
        }
    }
}

/// The cruise speed that covers the horizontal distance to `target` in
/// `time` seconds, counting the time to speed up and slow down at the
/// drone's acceleration, with a tenth of the time kept in reserve for the
/// final approach. As fast as the drone can when it cannot make it.
fn on_time_speed(drone: &Multirotor, target: Vec3, time: f64) -> f64 {
    let c = drone.config();
    let d = (target - drone.position()).horizontal_norm();
    let a = c.max_horizontal_accel;
    let t = 0.85 * time - 0.5;
    if d < 1e-6 {
        return c.max_horizontal_speed;
    }
    if t <= 0.0 {
        return c.max_horizontal_speed;
    }
    // A trapezoid at cruise v takes d/v + v/a: solve v² - a t v + a d = 0.
    let disc = a * a * t * t - 4.0 * a * d;
    if disc < 0.0 {
        return c.max_horizontal_speed;
    }
    let v = (a * t - disc.sqrt()) / 2.0;
    v.clamp(0.05, c.max_horizontal_speed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::kinematics::MultirotorConfig;

    const DT: f64 = 0.02;

    fn in_the_air() -> Multirotor {
        let mut m = Multirotor::new(MultirotorConfig::default());
        m.place(Vec3::new(0.0, 0.0, 1.0));
        m.arm().unwrap();
        m
    }

    #[test]
    fn a_script_reads_from_toml_and_validates() {
        let s: Script = toml::from_str(
            r#"
            start_after = 2.0
            [[legs]]
            leg = "at"
            t = 10.0
            x = -15.0
            y = -10.0
            z = 1.0
            [[legs]]
            leg = "hold"
            seconds = 5.0
            [[legs]]
            leg = "go_to"
            x = 0.0
            y = 0.0
            z = 1.0
            speed = 2.0
            "#,
        )
        .unwrap();
        assert_eq!(s.legs.len(), 3);
        assert!(s.validate().is_ok());
        let bad = Script {
            start_after: 0.0,
            legs: vec![
                Leg::At {
                    t: 5.0,
                    x: 0.0,
                    y: 0.0,
                    z: 1.0,
                },
                Leg::At {
                    t: 4.0,
                    x: 1.0,
                    y: 0.0,
                    z: 1.0,
                },
            ],
        };
        assert!(bad.validate().unwrap_err().contains("leg 2"));
        let slow = Script {
            start_after: 0.0,
            legs: vec![Leg::GoTo {
                x: 0.0,
                y: 0.0,
                z: 1.0,
                speed: 0.0,
            }],
        };
        assert!(slow.validate().unwrap_err().contains("speed"));
    }

    #[test]
    fn the_pilot_waits_for_the_takeoff_and_for_its_start_time() {
        let mut m = Multirotor::new(MultirotorConfig::default());
        let mut p = ScriptPilot::new(Script {
            start_after: 1.0,
            legs: vec![Leg::Hold { seconds: 1.0 }],
        });
        assert!(p.update(0.0, &mut m, false).is_empty(), "on the ground");
        let mut m = in_the_air();
        assert!(p.update(0.5, &mut m, false).is_empty(), "too early");
        assert!(p.update(1.0, &mut m, true).is_empty(), "take-off running");
        let e = p.update(1.0, &mut m, false);
        assert_eq!(e[0], PilotEvent::TookOver);
        assert!(p.is_flying());
        assert_eq!(m.mode(), FlightMode::Piloted);
    }

    #[test]
    fn the_pilot_is_on_each_timed_waypoint_at_its_time_in_order() {
        let mut m = in_the_air();
        let waypoints = [
            (8.0, Vec3::new(-15.0, -10.0, 1.0)),
            (16.0, Vec3::new(-15.0, 7.0, 1.5)),
            (30.0, Vec3::new(15.0, 7.0, 1.0)),
        ];
        let mut p = ScriptPilot::new(Script {
            start_after: 0.0,
            legs: waypoints
                .iter()
                .map(|(t, w)| Leg::At {
                    t: *t,
                    x: w.x,
                    y: w.y,
                    z: w.z,
                })
                .collect(),
        });
        let mut done = Vec::new();
        let mut now = 0.0;
        for step in 0..(40.0 / DT) as usize {
            now = step as f64 * DT;
            for e in p.update(now, &mut m, false) {
                if let PilotEvent::LegDone { index, position } = e {
                    done.push((index, now, position));
                }
            }
            m.step(DT);
        }
        assert!(p.is_done(), "script not finished at {now}");
        assert_eq!(done.iter().map(|d| d.0).collect::<Vec<_>>(), vec![0, 1, 2]);
        for ((_, t_done, at), (t, w)) in done.iter().zip(waypoints) {
            assert!(at.distance(w) <= 0.1, "leg ended at {at}, not {w}");
            // Done at the scripted time, to the step.
            assert!(
                (t_done - t).abs() <= DT + 1e-9,
                "done at {t_done}, scripted {t}"
            );
        }
        assert_eq!(m.mode(), FlightMode::Hold, "let go after the script");
    }

    #[test]
    fn a_released_pilot_never_flies_again() {
        let mut m = in_the_air();
        let mut p = ScriptPilot::new(Script {
            start_after: 0.0,
            legs: vec![Leg::GoTo {
                x: 10.0,
                y: 0.0,
                z: 1.0,
                speed: 1.0,
            }],
        });
        p.update(0.0, &mut m, false);
        assert!(p.is_flying());
        assert_eq!(p.release(), Some(PilotEvent::Released));
        m.land();
        for i in 0..100 {
            assert!(p.update(i as f64 * DT, &mut m, false).is_empty());
            m.step(DT);
        }
        assert_eq!(m.mode(), FlightMode::Land);
    }

    #[test]
    fn a_leg_the_drone_refuses_ends_the_script_with_the_reason() {
        let mut m = in_the_air();
        let mut p = ScriptPilot::new(Script {
            start_after: 0.0,
            legs: vec![Leg::GoTo {
                x: 1.0,
                y: 0.0,
                z: 900.0,
                speed: 1.0,
            }],
        });
        let e = p.update(0.0, &mut m, false);
        assert!(
            matches!(&e[2], PilotEvent::Stuck { reason, .. } if reason.contains("ceiling")),
            "{e:?}"
        );
        assert!(p.is_done());
    }
}
