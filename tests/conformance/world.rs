//! The guards' values, witnessed apart from the executor's decisions.
//!
//! The replay takes each condition decision as the drones took it; this
//! checks that the decision was right about the world. A guarded
//! transition that fired at mission time `t` on a drone must have a guard
//! that held on the drones' sampled telemetry (the run's `Telemetry`
//! events, every 5 cm a drone moves) at some moment of
//! `[t - before, t + after]`: the executor reads its own drone's state a
//! telemetry period late, and a sample is stamped when the sampling task
//! reads it, which may be just after the executor acted on the same
//! state. Only guards
//! over the evaluating drone's own state are judged (the generated
//! missions' conditions are all of that kind); one over another drone's
//! state travels over a faulty link, as late as the faults make it.

use eamos_exec::event::{Event, Kind};
use eamos_exec::guard::World;
use eamos_mid::{Telemetry, Vec3};
use eamos_petri::net::Net;

/// Each drone's sampled states, by time.
struct Samples {
    drones: Vec<String>,
    by_drone: Vec<Vec<(f64, Telemetry)>>,
    homes: Vec<Vec3>,
}

impl Samples {
    fn of(drones: &[String], homes: &[Vec3], events: &[Event]) -> Samples {
        let mut by_drone = vec![Vec::new(); drones.len()];
        for e in events {
            let Kind::Telemetry {
                position, battery, ..
            } = &e.kind
            else {
                continue;
            };
            let Some(d) = drones.iter().position(|n| *n == e.drone) else {
                continue;
            };
            let home = homes[d];
            by_drone[d].push((
                e.time,
                Telemetry {
                    time: e.time,
                    position: *position - home,
                    battery: *battery,
                    armed: true,
                    landed: false,
                    ..Telemetry::at_home(home)
                },
            ));
        }
        for s in &mut by_drone {
            s.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        Samples {
            drones: drones.to_vec(),
            by_drone,
            homes: homes.to_vec(),
        }
    }

    /// The world as sampled at mission time `s`.
    fn at(&self, s: f64) -> World {
        let mut w = World::new(self.drones.clone());
        for (d, samples) in self.by_drone.iter().enumerate() {
            let i = samples.partition_point(|(t, _)| *t <= s);
            let t = match i {
                0 => Telemetry::at_home(self.homes[d]),
                _ => samples[i - 1].1,
            };
            w.set(d as u16, t);
        }
        w
    }

    /// The moments of `[from, to]` at which the sampled world changed,
    /// and `from` itself.
    fn moments(&self, from: f64, to: f64) -> Vec<f64> {
        let mut out = vec![from];
        for s in &self.by_drone {
            out.extend(
                s.iter()
                    .map(|(t, _)| *t)
                    .filter(|t| (from..=to).contains(t)),
            );
        }
        out
    }
}

/// Every firing of a guarded transition whose guard the sampled world
/// never made true from `before` seconds of mission time before it to
/// `after` seconds after it.
pub fn misjudged(
    net: &Net,
    homes: &[Vec3],
    events: &[Event],
    (before, after): (f64, f64),
) -> Vec<String> {
    let samples = Samples::of(&net.drones, homes, events);
    let mut out = Vec::new();
    for e in events {
        let Kind::Fired { transition, .. } = &e.kind else {
            continue;
        };
        let Some(t) = net.find(transition).and_then(|n| net.transition(n)) else {
            continue;
        };
        let Some(guard) = &t.guard else { continue };
        let Some((cond, _)) = guard.condition() else {
            continue;
        };
        let own = guard
            .drones()
            .iter()
            .all(|d| net.drones.get(d.0 as usize) == Some(&e.drone));
        if !own {
            continue;
        }
        let held = samples
            .moments(e.time - before, e.time + after)
            .into_iter()
            .any(|s| samples.at(s).holds(cond).is_ok_and(|v| guard.holds_when(v)));
        if !held {
            out.push(format!(
                "{} fired `{}` ({}) at {:.2} s, its guard false on every state sampled from {before:.2} s before to {after:.2} s after",
                e.drone, t.label, t.id, e.time
            ));
        }
    }
    out
}
