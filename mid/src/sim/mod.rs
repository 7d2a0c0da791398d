//! The built-in simulator: every drone of a mission that no fleet file
//! binds to a real autopilot flies here.
//!
//! One [`SimFleet`] holds all simulated drones of a process and advances
//! them together in fixed simulated steps, so that they agree on mission
//! time. Steps are paced by tokio's clock at `step / speed` of real time:
//! `speed = 20` flies twenty times faster than real time, and tests with
//! tokio's paused time run as fast as the machine allows while staying
//! deterministic. Each drone is a [`SimDrone`], an [`Adapter`] over the
//! synchronous [`kinematics::Multirotor`] model.
//!
//! How the simulated copter answers the mission, like a real one would:
//! - `Arm` is refused on an empty battery; `Disarm` in the air.
//! - `Takeoff` is refused unless armed and on the ground.
//! - Motions (`FlyBy*`, `FlyTo`, `Hover`, `ReturnHome`) are refused on the
//!   ground; they end when the drone is within the arrival tolerance of the
//!   target (position and speed), and it then holds the target.
//! - `FlyBy*` moves from the point the drone holds, so that a run of small
//!   moves adds up exactly.
//! - `Land` ends on the ground; the motors stay armed until `Disarm`.
//! - Cancelling a motion brakes to a stop and holds there.
//! - A second motion while one runs is refused (the profile's `motion`
//!   resource says they exclude each other), except the very same call,
//!   which waits for the running one: four branches that each call
//!   `D3.Land()` land D3 once.
//! - The system and camera actions take the nominal time of the drone's
//!   profile (or [`SimConfig::durations`]), and are refused in a flight
//!   state the profile does not allow (`Calibrate` while armed).
//! - An action only the profile declares runs from its declaration (see
//!   [`declared`]).
//! - A drone with a [`script::Script`] is flown by a scripted pilot once it
//!   is in the air (see [`script`]).

pub mod declared;
pub mod kinematics;
pub mod script;

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard, Weak};
use std::time::Duration;

use async_trait::async_trait;
use eamos_profile::Profile;
use serde::{Deserialize, Serialize};
use tokio::sync::{watch, Notify};
use tokio::time::Instant;

use crate::api::{
    ActionCall, ActionError, Adapter, AdapterInfo, CancellationToken, FlightMode, MultirotorAction,
    Telemetry, Vec3,
};
use crate::clock::{Alarms, MissionClock, Pace};
use crate::log::{AdapterEvent, AdapterRecord, LogRecord, SharedSink};

use declared::Plan;
use kinematics::{Multirotor, MultirotorConfig, Refusal};
use script::{PilotEvent, Script, ScriptPilot};

/// How the whole simulated fleet runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Simulated seconds per step.
    pub step: f64,
    /// Simulated seconds per real second (20 runs twenty times faster).
    pub speed: f64,
    /// Simulated seconds between telemetry updates (state changes such as
    /// arming or an action's end are published at once as well).
    pub telemetry_period: f64,
    /// Simulated seconds between position records in the adapter log,
    /// while armed.
    pub position_log_period: f64,
    /// Simulated seconds of actions that do not move the drone, by action
    /// name (`TakePhoto = 0.2`), instead of their profile's nominal time.
    pub durations: BTreeMap<String, f64>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            step: 0.02,
            speed: 1.0,
            telemetry_period: 0.1,
            position_log_period: 1.0,
            durations: BTreeMap::new(),
        }
    }
}

impl SimConfig {
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.speed.is_finite() && self.speed > 0.0) {
            return Err(SimError::BadSpeed(self.speed));
        }
        if !(self.step.is_finite() && (0.001..=1.0).contains(&self.step)) {
            return Err(SimError::BadStep(self.step));
        }
        for (name, v) in [
            ("telemetry_period", self.telemetry_period),
            ("position_log_period", self.position_log_period),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::BadConfig(format!(
                    "`{name}` must be above zero, not {v}"
                )));
            }
        }
        for (name, v) in &self.durations {
            if !(v.is_finite() && *v >= 0.0) {
                return Err(SimError::BadConfig(format!(
                    "`durations.{name}` must be zero or more seconds, not {v}"
                )));
            }
        }
        Ok(())
    }
}

/// One simulated drone (from a fleet file, or made in code).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimDroneSpec {
    /// The drone's name in the mission.
    pub name: String,
    /// Where the drone starts, in the fleet frame (metres north, east, up
    /// of the fleet's origin); its local frame is centred here.
    #[serde(default)]
    pub home: Vec3,
    #[serde(default)]
    pub vehicle: MultirotorConfig,
    /// A scripted pilot that flies the drone once it is airborne.
    #[serde(default)]
    pub script: Option<Script>,
}

impl SimDroneSpec {
    /// A drone with the default airframe and no script.
    pub fn new(name: impl Into<String>, home: Vec3) -> Self {
        Self {
            name: name.into(),
            home,
            vehicle: MultirotorConfig::default(),
            script: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("the simulation speed must be above zero, not {0}")]
    BadSpeed(f64),
    #[error("the simulation step must be between 0.001 s and 1 s, not {0} s")]
    BadStep(f64),
    #[error("the simulation settings are not valid: {0}")]
    BadConfig(String),
    #[error("drone `{0}` is already in the simulated fleet")]
    Duplicate(String),
    #[error("the airframe of simulated drone `{drone}` is not valid: {reason}")]
    BadVehicle { drone: String, reason: String },
    #[error("the script of simulated drone `{drone}` is not valid: {reason}")]
    BadScript { drone: String, reason: String },
    #[error("the simulator must be started inside a tokio runtime")]
    NoRuntime,
}

/// Steps done at most per wake-up before letting other tasks run.
const MAX_BATCH: u64 = 2_000;
/// Steps behind schedule after which the simulation gives up catching up
/// and runs slower than asked, rather than in bursts.
const MAX_LAG: u64 = 20_000;
/// How long (wall) the simulation sleeps at most while nothing moves: its
/// telemetry, a holding drone's battery, then show at this pace.
const IDLE_WAKE: Duration = Duration::from_millis(50);

/// All simulated drones of a process, on one clock.
///
/// The simulation runs while the fleet or any of its drones is held, and
/// stops by itself when the last is dropped.
pub struct SimFleet {
    world: Arc<World>,
}

impl SimFleet {
    /// Starts the stepping task. Must be called inside a tokio runtime.
    pub fn start(config: SimConfig) -> Result<Self, SimError> {
        Self::start_at(config, 0.0)
    }

    /// Starts the stepping task with the clock at mission time `time`: a
    /// restarted agent's simulation goes on from the time its airframe was
    /// recorded, so that mission times in its logs keep increasing.
    pub fn start_at(config: SimConfig, time: f64) -> Result<Self, SimError> {
        config.validate()?;
        let steps = if time.is_finite() && time > 0.0 {
            (time / config.step).round() as u64
        } else {
            0
        };
        let handle = tokio::runtime::Handle::try_current().map_err(|_| SimError::NoRuntime)?;
        let (time_tx, time_rx) = watch::channel(steps as f64 * config.step);
        let world = Arc::new_cyclic(|me: &Weak<World>| {
            let pace: Weak<dyn Pace> = me.clone();
            let alarms = Arc::new(Alarms::new(pace));
            World {
                clock: MissionClock::simulated_with_alarms(time_rx, alarms.clone()),
                alarms,
                wake: Arc::new(Notify::new()),
                time_tx,
                state: Mutex::new(WorldState {
                    steps,
                    drones: Vec::new(),
                    origin: Instant::now(),
                    base: 0,
                    done: 0,
                }),
                config,
            }
        });
        handle.spawn(drive(Arc::downgrade(&world)));
        Ok(Self { world })
    }

    /// Adds a drone of the built-in `Quadcopter` profile, at rest and
    /// disarmed on its home. Its records go to `log`.
    pub fn add_drone(&self, spec: SimDroneSpec, log: SharedSink) -> Result<SimDrone, SimError> {
        self.add_drone_with_profile(spec, crate::api::quadcopter().clone(), log)
    }

    /// Adds a drone of the drone type `profile`: the simulator times its
    /// actions and runs the ones it has no code for from that profile.
    pub fn add_drone_with_profile(
        &self,
        spec: SimDroneSpec,
        profile: Profile,
        log: SharedSink,
    ) -> Result<SimDrone, SimError> {
        spec.vehicle
            .validate()
            .map_err(|reason| SimError::BadVehicle {
                drone: spec.name.clone(),
                reason,
            })?;
        if !spec.home.is_finite() {
            return Err(SimError::BadVehicle {
                drone: spec.name.clone(),
                reason: format!("the home {} is not finite", spec.home),
            });
        }
        if let Some(script) = &spec.script {
            script.validate().map_err(|reason| SimError::BadScript {
                drone: spec.name.clone(),
                reason,
            })?;
        }
        let mut state = self.world.lock();
        if state.drones.iter().any(|d| d.name == spec.name) {
            return Err(SimError::Duplicate(spec.name));
        }
        self.world.catch_up_locked(&mut state);
        let now = state.now(self.world.config.step);
        let model = Multirotor::new(spec.vehicle);
        let telemetry = watch::Sender::new(model.telemetry(now, spec.home));
        let index = state.drones.len();
        let slot = Slot {
            name: spec.name.clone(),
            home: spec.home,
            pilot: spec.script.map(ScriptPilot::new),
            profile,
            model,
            telemetry,
            log,
            motion: None,
            next_motion: 1,
            next_telemetry: now,
            next_position_log: now,
            dirty: true,
        };
        slot.note(
            now,
            AdapterEvent::State {
                detail: format!(
                    "simulated drone at home {} (fleet frame){}",
                    spec.home,
                    if slot.pilot.is_some() {
                        ", flown by a scripted pilot once airborne"
                    } else {
                        ""
                    }
                ),
            },
        );
        state.drones.push(slot);
        Ok(SimDrone {
            world: self.world.clone(),
            index,
            name: spec.name,
        })
    }

    /// A drone of the fleet by name.
    pub fn drone(&self, name: &str) -> Option<SimDrone> {
        let state = self.world.lock();
        state
            .drones
            .iter()
            .position(|d| d.name == name)
            .map(|index| SimDrone {
                world: self.world.clone(),
                index,
                name: name.to_string(),
            })
    }

    /// The fleet's mission clock (simulated time).
    pub fn clock(&self) -> MissionClock {
        self.world.clock.clone()
    }

    pub fn config(&self) -> &SimConfig {
        &self.world.config
    }

    /// Steps simulated so far.
    pub fn steps(&self) -> u64 {
        let mut state = self.world.lock();
        self.world.catch_up_locked(&mut state);
        state.steps
    }
}

/// Advances the world on schedule until nobody holds it any more.
///
/// While a drone moves (a motion runs, or a scripted pilot flies it) it
/// wakes at every step, so that whoever waits on the motion sees its end at
/// the step it happens. While nothing moves it sleeps until the next alarm
/// on the clock (a `PauseFor`, a timed action, a deadline), or for
/// [`IDLE_WAKE`] of wall time, and then takes every step due at once: the
/// same steps, the same physics (a holding drone still drains its battery
/// and may land on an empty one), at a few dozen wake-ups a second instead
/// of one per step. A command given meanwhile first brings the world up to
/// the present (see [`World::catch_up_locked`]), so it starts at the same
/// step as with a wake-up at every step.
async fn drive(world: Weak<World>) {
    let Some(w) = world.upgrade() else {
        return;
    };
    let (wake, earlier) = (w.wake.clone(), w.alarms.earlier());
    let (step, speed) = (w.config.step, w.config.speed);
    // Steps of one idle wake-up: at least one.
    let idle_steps = ((IDLE_WAKE.as_secs_f64() * speed / step).floor() as u64).max(1);
    drop(w);
    loop {
        let Some(w) = world.upgrade() else {
            return;
        };
        let next = {
            let mut state = w.lock();
            let due = w.due(&mut state);
            let until = due.min(state.done + MAX_BATCH);
            w.run_until(&mut state, until);
            if state.done < due {
                None
            } else {
                Some(plan(&w, &state, idle_steps))
            }
        };
        drop(w);
        let Some(next) = next else {
            // Behind schedule: let other tasks run between batches.
            tokio::task::yield_now().await;
            continue;
        };
        tokio::select! {
            _ = tokio::time::sleep_until(next) => {}
            _ = wake.notified() => {}
            _ = earlier.notified() => {}
        }
    }
}

/// When the stepping task wakes next: at the next step while a drone
/// moves, else at the next alarm or after `idle_steps`.
fn plan(w: &World, state: &WorldState, idle_steps: u64) -> Instant {
    let (step, speed) = (w.config.step, w.config.speed);
    let moving = state
        .drones
        .iter()
        .any(|d| d.motion.is_some() || d.pilot.is_some());
    let ahead = if moving {
        1
    } else {
        let now = state.now(step);
        let alarm = w.alarms.earliest().map_or(u64::MAX, |t| {
            // Steps until time reaches `t`, at least one (a step short
            // by rounding is taken at the next wake-up).
            ((t - now) / step - 1e-9).ceil().clamp(1.0, 1.0e15) as u64
        });
        idle_steps.min(alarm)
    };
    state.origin + Duration::from_secs_f64((state.done - state.base + ahead) as f64 * step / speed)
}

struct World {
    config: SimConfig,
    clock: MissionClock,
    alarms: Arc<Alarms>,
    /// Wakes the stepping task when a command may have set a drone moving.
    wake: Arc<Notify>,
    time_tx: watch::Sender<f64>,
    state: Mutex<WorldState>,
}

struct WorldState {
    steps: u64,
    drones: Vec<Slot>,
    /// The pace: `done` steps taken since the start, of which those after
    /// `base` are due `step / speed` apart from `origin`.
    origin: Instant,
    base: u64,
    done: u64,
}

impl WorldState {
    fn now(&self, step: f64) -> f64 {
        self.steps as f64 * step
    }
}

impl World {
    fn lock(&self) -> MutexGuard<'_, WorldState> {
        // A panic elsewhere must not ground the whole fleet.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Steps due by now on the wall clock. Far behind (a machine too
    /// busy), the world gives up catching up and runs slower than asked,
    /// rather than in bursts.
    fn due(&self, state: &mut WorldState) -> u64 {
        let (step, speed) = (self.config.step, self.config.speed);
        let due = state.base
            + (state.origin.elapsed().as_secs_f64() * speed / step + 1e-6).floor() as u64;
        if due > state.done + MAX_LAG {
            state.origin = Instant::now();
            state.base = state.done;
            return state.done;
        }
        due
    }

    /// Takes every step up to `done == until`, then publishes the time and
    /// wakes the sleepers whose alarm it reached.
    fn run_until(&self, state: &mut WorldState, until: u64) {
        if state.done >= until {
            return;
        }
        while state.done < until {
            state.steps += 1;
            state.done += 1;
            let now = state.now(self.config.step);
            for slot in &mut state.drones {
                slot.step(now, &self.config);
            }
        }
        let now = state.now(self.config.step);
        self.time_tx.send_replace(now);
        self.alarms.ring(now);
    }

    /// Brings a world that slept while nothing moved up to the present,
    /// before a command changes it or its time is read.
    fn catch_up_locked(&self, state: &mut WorldState) {
        let due = self.due(state);
        self.run_until(state, due.min(state.done + MAX_LAG));
    }
}

impl Pace for World {
    fn catch_up(&self) {
        // The stepping task holds the world: it is stepping now, and a
        // reader inside a step must not wait for itself.
        if let Ok(mut state) = self.state.try_lock() {
            self.catch_up_locked(&mut state);
        }
    }
}

/// When a running motion is over.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Until {
    Arrive(Vec3),
    Landed,
    Time(f64),
}

type Outcome = Option<Result<(), ActionError>>;

struct Motion {
    id: u64,
    call: ActionCall,
    until: Until,
    done: watch::Sender<Outcome>,
    /// Calls waiting on this motion (the same call made twice joins).
    waiters: usize,
}

struct Slot {
    name: String,
    home: Vec3,
    profile: Profile,
    model: Multirotor,
    pilot: Option<ScriptPilot>,
    telemetry: watch::Sender<Telemetry>,
    log: SharedSink,
    motion: Option<Motion>,
    next_motion: u64,
    next_telemetry: f64,
    next_position_log: f64,
    /// Something changed that telemetry readers should see now.
    dirty: bool,
}

impl Slot {
    fn note(&self, time: f64, event: AdapterEvent) {
        self.log.record(LogRecord::Adapter(AdapterRecord {
            time,
            drone: self.name.clone(),
            adapter: "sim".to_string(),
            event,
        }));
    }

    fn state(&self, time: f64, detail: impl Into<String>) {
        self.note(
            time,
            AdapterEvent::State {
                detail: detail.into(),
            },
        );
    }

    fn publish(&mut self, now: f64) {
        self.telemetry
            .send_replace(self.model.telemetry(now, self.home));
        self.dirty = false;
    }

    fn step(&mut self, now: f64, config: &SimConfig) {
        if let Some(pilot) = &mut self.pilot {
            let busy = self.motion.is_some();
            let events = pilot.update(now, &mut self.model, busy);
            for e in events {
                self.dirty = true;
                let detail = match e {
                    PilotEvent::TookOver => "the scripted pilot took over".to_string(),
                    PilotEvent::LegStarted { index } => format!(
                        "scripted pilot: leg {} begins, {}",
                        index + 1,
                        self.model.guidance()
                    ),
                    PilotEvent::LegDone { index, position } => {
                        format!("scripted pilot: leg {} done at {position}", index + 1)
                    }
                    PilotEvent::LetGo => {
                        "the scripted pilot let go; the drone holds and the mission has control"
                            .to_string()
                    }
                    PilotEvent::Released => "the mission took control from the pilot".to_string(),
                    PilotEvent::Stuck { index, reason } => {
                        format!("scripted pilot cannot fly leg {}: {reason}", index + 1)
                    }
                };
                self.state(now, detail);
            }
        }

        let events = self.model.step(config.step);
        if events.lifted_off {
            self.dirty = true;
            self.state(now, "lifted off");
        }
        if events.touched_down {
            self.dirty = true;
            let p = self.model.position();
            self.state(now, format!("touched down at ({:.2}, {:.2})", p.x, p.y));
        }
        let mut completion: Option<Result<(), ActionError>> = None;
        if events.battery_emptied {
            self.dirty = true;
            self.state(now, "the battery is empty; landing where it is");
            if let Some(pilot) = &mut self.pilot {
                pilot.release();
            }
            if let Some(m) = &self.motion {
                if m.until != Until::Landed {
                    completion = Some(Err(ActionError::failed(
                        &m.call.name,
                        "the battery ran out; the drone is landing where it is",
                    )));
                }
            }
        }
        if completion.is_none() {
            if let Some(m) = &self.motion {
                let finished = match m.until {
                    Until::Arrive(p) => self.model.is_at(p),
                    Until::Landed => self.model.landed(),
                    Until::Time(t) => now >= t - 1e-9,
                };
                if finished {
                    if let Until::Arrive(p) = m.until {
                        self.model.hold_at(p);
                    }
                    completion = Some(Ok(()));
                }
            }
        }
        if completion.is_some() {
            self.dirty = true;
        }

        if self.dirty || now >= self.next_telemetry - 1e-9 {
            self.publish(now);
            if now >= self.next_telemetry - 1e-9 {
                self.next_telemetry = now + config.telemetry_period;
            }
        }
        if self.model.is_armed() && now >= self.next_position_log - 1e-9 {
            self.next_position_log = now + config.position_log_period;
            self.note(
                now,
                AdapterEvent::Position {
                    position: self.model.position(),
                    velocity: self.model.velocity(),
                    battery: self.model.battery(),
                    armed: true,
                    mode: self.model.mode(),
                },
            );
        }

        if let Some(result) = completion {
            if let Some(m) = self.motion.take() {
                self.note(
                    now,
                    AdapterEvent::Completed {
                        action: m.call.name.clone(),
                        outcome: match &result {
                            Ok(()) => "ok".to_string(),
                            Err(e) => e.kind().to_string(),
                        },
                        detail: format!("at {}", self.model.position()),
                    },
                );
                m.done.send_replace(Some(result));
            }
        }
    }
}

/// What survives of a simulated drone when the agent flying it crashes:
/// the airframe. A real autopilot keeps its state through a crash of the
/// companion computer; a simulated one lives in the agent's process, so the
/// agent records it now and then, and a restarted agent puts its simulated
/// drone back where it was recorded instead of on its home.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Airframe {
    /// Mission time of the record.
    pub time: f64,
    /// Local frame, metres from home.
    pub position: Vec3,
    pub armed: bool,
    pub battery: f64,
}

/// One simulated drone: the [`Adapter`] the executor drives.
#[derive(Clone)]
pub struct SimDrone {
    world: Arc<World>,
    index: usize,
    name: String,
}

/// What starting an action led to.
enum Start {
    /// Done already (arming, a refusal).
    Finished(Result<(), ActionError>),
    /// A motion is running: wait on it.
    Wait {
        id: u64,
        done: watch::Receiver<Outcome>,
    },
    /// A timed action that does not move the drone.
    Timed(f64),
}

impl SimDrone {
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The drone's home in the fleet frame.
    pub fn home(&self) -> Vec3 {
        self.with_slot(|slot, _| slot.home)
    }

    /// A copy of the kinematic model as it is now (for tests and tools).
    pub fn model(&self) -> Multirotor {
        self.with_slot(|slot, _| slot.model.clone())
    }

    /// The airframe's state now, to record.
    pub fn airframe(&self) -> Airframe {
        self.with_slot(|slot, now| Airframe {
            time: now,
            position: slot.model.position(),
            armed: slot.model.is_armed(),
            battery: slot.model.battery(),
        })
    }

    /// Puts the drone back where a recorded airframe was, at rest: holding
    /// in the air there, or on the ground. A recorded state that is not
    /// finite is refused and the drone stays where it is.
    pub fn restore(&self, airframe: &Airframe) -> Result<(), SimError> {
        if !(airframe.position.is_finite() && airframe.battery.is_finite()) {
            return Err(SimError::BadVehicle {
                drone: self.name.clone(),
                reason: format!("the recorded position {} is not finite", airframe.position),
            });
        }
        self.with_slot(|slot, now| {
            slot.motion = None;
            slot.model
                .restore(airframe.position, airframe.armed, airframe.battery);
            slot.state(
                now,
                format!(
                    "restored from the airframe recorded at {:.2} s: {}{}",
                    airframe.time,
                    airframe.position,
                    if airframe.armed { ", armed" } else { "" }
                ),
            );
            slot.dirty = true;
            slot.publish(now);
        });
        Ok(())
    }

    /// Runs `f` on the drone at the present step, then lets the stepping
    /// task know that the drone may move now.
    fn with_slot<R>(&self, f: impl FnOnce(&mut Slot, f64) -> R) -> R {
        let mut state = self.world.lock();
        self.world.catch_up_locked(&mut state);
        let now = state.now(self.world.config.step);
        let r = f(&mut state.drones[self.index], now);
        drop(state);
        self.world.wake.notify_one();
        r
    }

    fn start(&self, call: &ActionCall, plan: Plan, target: Option<Vec3>) -> Start {
        let durations = &self.world.config.durations;
        self.with_slot(|slot, now| {
            let name = call.name.as_str();
            let refused = |r: Refusal| Start::Finished(Err(ActionError::refused(name, r)));

            let action = match plan {
                Plan::Typed(action) if action.is_motion() => action,
                _ => {
                    let seconds = match declared::timed_seconds(
                        &slot.profile,
                        durations,
                        call,
                        &slot.model,
                    ) {
                        Ok(seconds) => seconds,
                        Err(e) => return Start::Finished(Err(e)),
                    };
                    slot.note(
                        now,
                        AdapterEvent::Command {
                            action: name.to_string(),
                            args: call.args.clone(),
                            detail: format!("simulated, {seconds} s"),
                        },
                    );
                    return Start::Timed(seconds);
                }
            };

            if let Some(m) = &mut slot.motion {
                if m.call == *call {
                    m.waiters += 1;
                    let wait = Start::Wait {
                        id: m.id,
                        done: m.done.subscribe(),
                    };
                    slot.state(now, format!("{call} joins the same running call"));
                    return wait;
                }
                return Start::Finished(Err(ActionError::refused(
                    name,
                    format!("the drone is busy with {}", m.call),
                )));
            }

            let piloted = slot.pilot.as_ref().is_some_and(|p| p.is_flying());
            if piloted {
                match action {
                    MultirotorAction::Land | MultirotorAction::ReturnHome => {
                        if let Some(p) = &mut slot.pilot {
                            p.release();
                        }
                        slot.state(
                            now,
                            format!("the scripted pilot hands control back for {name}"),
                        );
                    }
                    MultirotorAction::Arm => return Start::Finished(Ok(())),
                    _ => {
                        return Start::Finished(Err(ActionError::refused(
                            name,
                            "the drone is flown by its pilot and the mission only watches it \
                             (Land and ReturnHome take control back)",
                        )))
                    }
                }
            }

            // A resumed motion flies to the target recorded when it first
            // started, whatever the action.
            let resumed = match target {
                Some(target) => match slot.model.go_to(target, FlightMode::Guided) {
                    Ok(()) => Some(Until::Arrive(target)),
                    Err(r) => return refused(r),
                },
                None => None,
            };
            let model = &mut slot.model;
            let until = match resumed {
                Some(until) => until,
                None => match action {
                    MultirotorAction::Arm => {
                        let was = model.is_armed();
                        return match model.arm() {
                            Ok(()) => {
                                if !was {
                                    slot.dirty = true;
                                    slot.publish(now);
                                    slot.state(now, "armed");
                                }
                                Start::Finished(Ok(()))
                            }
                            Err(r) => refused(r),
                        };
                    }
                    MultirotorAction::Disarm => {
                        let was = model.is_armed();
                        return match model.disarm() {
                            Ok(()) => {
                                if was {
                                    slot.publish(now);
                                    slot.state(now, "disarmed");
                                }
                                Start::Finished(Ok(()))
                            }
                            Err(r) => refused(r),
                        };
                    }
                    MultirotorAction::Takeoff { height } => match model.takeoff(height) {
                        Ok(()) => {
                            let p = model.position();
                            Until::Arrive(Vec3::new(p.x, p.y, height))
                        }
                        Err(r) => return refused(r),
                    },
                    MultirotorAction::Land => {
                        if model.on_ground() {
                            slot.state(now, "Land: already on the ground");
                            return Start::Finished(Ok(()));
                        }
                        model.land();
                        Until::Landed
                    }
                    MultirotorAction::FlyBy { axis, distance } => {
                        let target = model.reference() + axis.unit() * distance;
                        match model.go_to(target, FlightMode::Guided) {
                            Ok(()) => Until::Arrive(target),
                            Err(r) => return refused(r),
                        }
                    }
                    MultirotorAction::FlyTo { target } => {
                        match model.go_to(target, FlightMode::Guided) {
                            Ok(()) => Until::Arrive(target),
                            Err(r) => return refused(r),
                        }
                    }
                    MultirotorAction::ReturnHome => {
                        let target = Vec3::new(0.0, 0.0, model.reference().z);
                        match model.go_to(target, FlightMode::ReturnHome) {
                            Ok(()) => Until::Arrive(target),
                            Err(r) => return refused(r),
                        }
                    }
                    MultirotorAction::Hover { seconds } => {
                        if !model.is_airborne() {
                            return refused(Refusal::OnGround);
                        }
                        // The profile says how long a hover lasts (its
                        // argument, for the built-in one).
                        let p = model.position();
                        let seconds = slot
                            .profile
                            .nominal_duration(name, &call.args, [p.x, p.y, p.z])
                            .unwrap_or(seconds);
                        let at = model.reference();
                        model.hold_at(at);
                        Until::Time(now + seconds)
                    }
                    _ => unreachable!("every motion is matched above"),
                },
            };
            let id = slot.next_motion;
            slot.next_motion += 1;
            let (done, rx) = watch::channel(None);
            slot.note(
                now,
                AdapterEvent::Command {
                    action: name.to_string(),
                    args: call.args.clone(),
                    detail: slot.model.guidance().to_string(),
                },
            );
            slot.motion = Some(Motion {
                id,
                call: call.clone(),
                until,
                done,
                waiters: 1,
            });
            slot.publish(now);
            Start::Wait { id, done: rx }
        })
    }

    /// A caller stops waiting on motion `id` (cancelled, or dropped its
    /// call): the last caller waiting on it stops it, and the drone brakes
    /// and holds. Nothing happens if the motion already ended.
    fn cancel_motion(&self, id: u64) {
        self.with_slot(|slot, now| {
            let Some(m) = &mut slot.motion else {
                return;
            };
            if m.id != id {
                return;
            }
            m.waiters -= 1;
            if m.waiters > 0 {
                return;
            }
            let name = m.call.name.clone();
            slot.motion = None;
            slot.model.hold();
            slot.note(
                now,
                AdapterEvent::Completed {
                    action: name,
                    outcome: "cancelled".to_string(),
                    detail: format!("braking to hold at {}", slot.model.guidance()),
                },
            );
            slot.publish(now);
        });
    }
}

/// Lets go of motion `id` when dropped (see [`SimDrone::cancel_motion`]).
struct LeaveOnDrop<'a> {
    drone: &'a SimDrone,
    id: u64,
}

impl Drop for LeaveOnDrop<'_> {
    fn drop(&mut self) {
        self.drone.cancel_motion(self.id);
    }
}

async fn wait_for(mut done: watch::Receiver<Outcome>, action: &str) -> Result<(), ActionError> {
    loop {
        if let Some(result) = done.borrow_and_update().clone() {
            return result;
        }
        if done.changed().await.is_err() {
            return done.borrow().clone().unwrap_or_else(|| {
                Err(ActionError::failed(
                    action,
                    "the simulation stopped before the action ended",
                ))
            });
        }
    }
}

#[async_trait]
impl Adapter for SimDrone {
    fn info(&self) -> AdapterInfo {
        let scripted = self.with_slot(|slot, _| slot.pilot.is_some());
        AdapterInfo {
            kind: "sim".to_string(),
            drone: self.name.clone(),
            detail: format!(
                "home {}, speed x{}{}",
                self.home(),
                self.world.config.speed,
                if scripted { ", scripted pilot" } else { "" }
            ),
        }
    }

    fn telemetry(&self) -> watch::Receiver<Telemetry> {
        self.with_slot(|slot, _| slot.telemetry.subscribe())
    }

    fn clock(&self) -> MissionClock {
        self.world.clock.clone()
    }

    async fn run(&self, call: &ActionCall, cancel: CancellationToken) -> Result<(), ActionError> {
        self.perform(call, None, cancel).await
    }

    fn motion_reference(&self) -> Result<Vec3, ActionError> {
        Ok(self.with_slot(|slot, _| slot.model.reference()))
    }

    async fn fly_to_target(
        &self,
        call: &ActionCall,
        target: Vec3,
        cancel: CancellationToken,
    ) -> Result<(), ActionError> {
        if !target.is_finite() {
            return Err(ActionError::bad_arguments(
                &call.name,
                format!("the target {target} is not finite"),
            ));
        }
        self.perform(call, Some(target), cancel).await
    }
}

impl SimDrone {
    /// Runs `call`, towards `target` instead of its own target when given.
    async fn perform(
        &self,
        call: &ActionCall,
        target: Option<Vec3>,
        cancel: CancellationToken,
    ) -> Result<(), ActionError> {
        let plan = self.with_slot(|slot, _| declared::plan(&slot.profile, call))?;
        let name = call.name.as_str();
        if cancel.is_cancelled() {
            return Err(ActionError::Cancelled {
                action: name.to_string(),
            });
        }
        match self.start(call, plan, target) {
            Start::Finished(result) => result,
            Start::Timed(seconds) => {
                let clock = self.world.clock.clone();
                let result = tokio::select! {
                    biased;
                    _ = clock.sleep(seconds) => Ok(()),
                    _ = cancel.cancelled() => Err(ActionError::Cancelled { action: name.to_string() }),
                };
                self.with_slot(|slot, now| {
                    slot.note(
                        now,
                        AdapterEvent::Completed {
                            action: name.to_string(),
                            outcome: match &result {
                                Ok(()) => "ok".to_string(),
                                Err(e) => e.kind().to_string(),
                            },
                            detail: String::new(),
                        },
                    )
                });
                result
            }
            Start::Wait { id, done } => {
                // Leaving this call, by cancellation or because the caller
                // dropped the future, lets go of the motion: the last caller
                // to let go stops it, so the drone never flies on for
                // nobody. A motion that already ended is not touched.
                let _leave = LeaveOnDrop { drone: self, id };
                tokio::select! {
                    biased;
                    result = wait_for(done, name) => result,
                    _ = cancel.cancelled() => {
                        Err(ActionError::Cancelled { action: name.to_string() })
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
