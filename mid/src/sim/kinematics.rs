//! Multirotor kinematics as a plain synchronous model.
//!
//! No tokio here: the simulator adapter steps it from its fleet task, and a
//! MAVLink test vehicle can step it from its own loop. The model is what an
//! autopilot's position controller makes of a copter seen from outside:
//! horizontal speed and acceleration limits, separate climb and descent
//! rates, a braking curve that stops on the target, ground contact, a
//! battery that drains with use, and optional seeded wind. It is not an
//! attitude or motor model: missions care where the drone is and when it
//! gets there.
//!
//! Frame: X north, Y east, Z up, metres from home (the mission's frame).

use std::fmt;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::api::{FlightMode, Telemetry, Vec3};

/// The performance envelope and battery of one airframe. Defaults are a
/// small camera quadcopter flown conservatively.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MultirotorConfig {
    /// Horizontal speed limit, m/s.
    pub max_horizontal_speed: f64,
    /// Horizontal acceleration limit, m/s².
    pub max_horizontal_accel: f64,
    /// Climb rate limit, m/s.
    pub climb_rate: f64,
    /// Descent rate limit, m/s.
    pub descent_rate: f64,
    /// Descent rate of a landing for its last `land_slow_height` metres,
    /// m/s.
    pub land_speed: f64,
    /// Height under which a landing slows to `land_speed`, m.
    pub land_slow_height: f64,
    /// Vertical acceleration limit, m/s².
    pub max_vertical_accel: f64,
    /// Gain of the position loop near the target, 1/s: how briskly the
    /// last decimetres are closed.
    pub position_gain: f64,
    /// Arrival: within this distance of the target, m ...
    pub arrival_tolerance: f64,
    /// ... and slower than this, m/s.
    pub arrival_speed: f64,
    /// Lowest height a flight target may have, m: below it use `Land`.
    pub min_flight_height: f64,
    /// Highest height a target may have, m (a geofence ceiling).
    pub max_flight_height: f64,
    pub battery: BatteryConfig,
    pub wind: WindConfig,
}

impl Default for MultirotorConfig {
    fn default() -> Self {
        Self {
            max_horizontal_speed: 5.0,
            max_horizontal_accel: 2.5,
            climb_rate: 2.0,
            descent_rate: 1.5,
            land_speed: 0.5,
            land_slow_height: 2.0,
            max_vertical_accel: 2.0,
            position_gain: 2.0,
            arrival_tolerance: 0.1,
            arrival_speed: 0.2,
            min_flight_height: 0.3,
            max_flight_height: 120.0,
            battery: BatteryConfig::default(),
            wind: WindConfig::default(),
        }
    }
}

impl MultirotorConfig {
    /// Checks that every limit is a positive finite number (a fleet file
    /// may say otherwise).
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("max_horizontal_speed", self.max_horizontal_speed),
            ("max_horizontal_accel", self.max_horizontal_accel),
            ("climb_rate", self.climb_rate),
            ("descent_rate", self.descent_rate),
            ("land_speed", self.land_speed),
            ("max_vertical_accel", self.max_vertical_accel),
            ("position_gain", self.position_gain),
            ("arrival_tolerance", self.arrival_tolerance),
            ("arrival_speed", self.arrival_speed),
            ("max_flight_height", self.max_flight_height),
            ("wind.gust_time", self.wind.gust_time),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`{name}` must be above zero, not {v}"));
            }
        }
        let non_negative = [
            ("land_slow_height", self.land_slow_height),
            ("min_flight_height", self.min_flight_height),
            ("battery.idle_per_second", self.battery.idle_per_second),
            (
                "battery.airborne_per_second",
                self.battery.airborne_per_second,
            ),
            ("battery.per_metre", self.battery.per_metre),
            ("battery.arm_minimum", self.battery.arm_minimum),
            ("wind.gust", self.wind.gust),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("`{name}` must be zero or more, not {v}"));
            }
        }
        if !(self.battery.initial.is_finite() && (0.0..=100.0).contains(&self.battery.initial)) {
            return Err(format!(
                "`battery.initial` is a percentage, not {}",
                self.battery.initial
            ));
        }
        if self.min_flight_height >= self.max_flight_height {
            return Err(format!(
                "`min_flight_height` ({}) must be below `max_flight_height` ({})",
                self.min_flight_height, self.max_flight_height
            ));
        }
        Ok(())
    }
}

/// Battery drain in percent of a full charge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BatteryConfig {
    /// Charge at start, percent.
    pub initial: f64,
    /// Armed on the ground (motors idling), percent per second.
    pub idle_per_second: f64,
    /// In the air, percent per second (hovering costs most).
    pub airborne_per_second: f64,
    /// Extra per metre travelled (3D, through the air), percent.
    pub per_metre: f64,
    /// Arming is refused at or below this charge, percent.
    pub arm_minimum: f64,
}

impl Default for BatteryConfig {
    fn default() -> Self {
        Self {
            initial: 100.0,
            idle_per_second: 0.01,
            // About 20 minutes of hover on a full battery.
            airborne_per_second: 100.0 / 1200.0,
            per_metre: 0.01,
            arm_minimum: 0.0,
        }
    }
}

/// Gusts as a first-order (Ornstein-Uhlenbeck) random process on the
/// horizontal ground velocity, seeded so that runs repeat. Off when `gust`
/// is zero.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindConfig {
    pub seed: u64,
    /// Standard deviation of the gust speed, m/s.
    pub gust: f64,
    /// How long a gust lasts (correlation time), s.
    pub gust_time: f64,
}

impl Default for WindConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            gust: 0.0,
            gust_time: 2.0,
        }
    }
}

/// What the position controller is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Guidance {
    /// On the ground, motors idle or off.
    Idle,
    /// Hold this point in the air.
    Hold { at: Vec3 },
    /// Fly to `target`, horizontally no faster than `speed`.
    GoTo { target: Vec3, speed: f64 },
    /// Descend at (x, y) until on the ground.
    Land { x: f64, y: f64 },
}

/// Why the model will not do what it was asked. The adapter turns these
/// into [`crate::ActionError::Refused`] with this text as the reason.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refusal {
    #[error("the motors are not armed; call Arm first")]
    NotArmed,
    #[error("the drone is in the air ({z:.2} m up); land first")]
    Airborne { z: f64 },
    #[error("the drone is on the ground; take off first")]
    OnGround,
    #[error("the drone is already flying ({z:.2} m up); use FlyTo or FlyByZ to change height")]
    AlreadyFlying { z: f64 },
    #[error("the battery is at {percent:.1}%, not above the {minimum:.1}% needed to fly")]
    BatteryEmpty { percent: f64, minimum: f64 },
    #[error("the target is {z:.2} m up, below the lowest flight height of {min:.2} m; use Land to come down")]
    TooLow { z: f64, min: f64 },
    #[error("the target is {z:.2} m up, above the ceiling of {max:.2} m")]
    TooHigh { z: f64, max: f64 },
}

/// What happened during one step, for the adapter's log.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepEvents {
    pub lifted_off: bool,
    pub touched_down: bool,
    /// The battery ran out during this step; the model started landing.
    pub battery_emptied: bool,
}

/// A share of the braking acceleration kept in reserve, so that the
/// discretised braking curve stops on the target rather than past it.
const BRAKING_MARGIN: f64 = 0.9;

/// Height under which the drone counts as touching the ground, m.
const GROUND: f64 = 1e-6;

/// One multirotor.
#[derive(Debug, Clone)]
pub struct Multirotor {
    config: MultirotorConfig,
    position: Vec3,
    /// Velocity through the air (what the controller commands).
    velocity: Vec3,
    /// Horizontal wind, added to the ground velocity.
    wind: Vec3,
    armed: bool,
    on_ground: bool,
    battery: f64,
    guidance: Guidance,
    mode: FlightMode,
    time: f64,
    travelled: f64,
    rng: ChaCha8Rng,
}

impl Multirotor {
    /// A drone at rest on the ground at its home, disarmed.
    pub fn new(config: MultirotorConfig) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(config.wind.seed);
        Self {
            battery: config.battery.initial.clamp(0.0, 100.0),
            config,
            position: Vec3::ZERO,
            velocity: Vec3::ZERO,
            wind: Vec3::ZERO,
            armed: false,
            on_ground: true,
            guidance: Guidance::Idle,
            mode: FlightMode::Standby,
            time: 0.0,
            travelled: 0.0,
            rng,
        }
    }

    pub fn config(&self) -> &MultirotorConfig {
        &self.config
    }

    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Velocity over the ground (air velocity plus wind).
    pub fn velocity(&self) -> Vec3 {
        self.velocity + self.wind
    }

    /// Velocity through the air: what the limits apply to.
    pub fn air_velocity(&self) -> Vec3 {
        self.velocity
    }

    pub fn battery(&self) -> f64 {
        self.battery
    }

    pub fn is_armed(&self) -> bool {
        self.armed
    }

    pub fn on_ground(&self) -> bool {
        self.on_ground
    }

    pub fn is_airborne(&self) -> bool {
        !self.on_ground
    }

    /// On the ground and still.
    pub fn landed(&self) -> bool {
        self.on_ground && self.velocity().norm() <= self.config.arrival_speed
    }

    pub fn guidance(&self) -> Guidance {
        self.guidance
    }

    pub fn mode(&self) -> FlightMode {
        self.mode
    }

    /// Seconds simulated since the model was made.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Metres travelled since the model was made.
    pub fn travelled(&self) -> f64 {
        self.travelled
    }

    /// Sets the charge (a fleet file's starting charge, a test's empty
    /// battery).
    pub fn set_battery(&mut self, percent: f64) {
        self.battery = percent.clamp(0.0, 100.0);
    }

    /// Places the drone somewhere, at rest (a test's or a vehicle's
    /// starting point). Above the ground it is airborne and holds there.
    pub fn place(&mut self, position: Vec3) {
        self.position = Vec3::new(position.x, position.y, position.z.max(0.0));
        self.velocity = Vec3::ZERO;
        self.on_ground = self.position.z <= GROUND;
        if self.on_ground {
            self.guidance = Guidance::Idle;
            self.mode = FlightMode::Standby;
        } else {
            self.guidance = Guidance::Hold { at: self.position };
            self.mode = FlightMode::Hold;
        }
    }

    /// Puts the drone back in a recorded state, at rest: the airframe of an
    /// agent that crashed and restarted is still where it was, armed if it
    /// was, holding there if it is in the air (an airborne drone is always
    /// armed).
    pub fn restore(&mut self, position: Vec3, armed: bool, battery: f64) {
        self.set_battery(battery);
        self.place(position);
        self.armed = armed || !self.on_ground;
    }

    /// Overrides the reported mode (a pilot takes over, a vehicle switches
    /// to a mode the model has no guidance for).
    pub fn set_mode(&mut self, mode: FlightMode) {
        self.mode = mode;
    }

    pub fn arm(&mut self) -> Result<(), Refusal> {
        if self.armed {
            return Ok(());
        }
        self.check_battery()?;
        self.armed = true;
        Ok(())
    }

    pub fn disarm(&mut self) -> Result<(), Refusal> {
        if !self.on_ground {
            return Err(Refusal::Airborne { z: self.position.z });
        }
        self.armed = false;
        self.guidance = Guidance::Idle;
        self.mode = FlightMode::Standby;
        Ok(())
    }

    /// Climbs straight up to `height`.
    pub fn takeoff(&mut self, height: f64) -> Result<(), Refusal> {
        if !self.armed {
            return Err(Refusal::NotArmed);
        }
        if !self.on_ground {
            return Err(Refusal::AlreadyFlying { z: self.position.z });
        }
        self.check_battery()?;
        self.check_height(height)?;
        self.guidance = Guidance::GoTo {
            target: Vec3::new(self.position.x, self.position.y, height),
            speed: self.config.max_horizontal_speed,
        };
        self.mode = FlightMode::Takeoff;
        Ok(())
    }

    /// Flies to `target` at the airframe's speed.
    pub fn go_to(&mut self, target: Vec3, mode: FlightMode) -> Result<(), Refusal> {
        self.go_to_at(target, self.config.max_horizontal_speed, mode)
    }

    /// Flies to `target`, horizontally no faster than `speed` (capped by
    /// the airframe's limit).
    pub fn go_to_at(&mut self, target: Vec3, speed: f64, mode: FlightMode) -> Result<(), Refusal> {
        if !self.armed {
            return Err(Refusal::NotArmed);
        }
        if self.on_ground {
            return Err(Refusal::OnGround);
        }
        self.check_height(target.z)?;
        let speed = if speed.is_finite() && speed > 0.0 {
            speed.min(self.config.max_horizontal_speed)
        } else {
            self.config.max_horizontal_speed
        };
        self.guidance = Guidance::GoTo { target, speed };
        self.mode = mode;
        Ok(())
    }

    /// The point relative moves (`FlyByX`) start from: the held point when
    /// the drone holds near it, so that a run of small moves adds up
    /// exactly, otherwise where the drone is.
    pub fn reference(&self) -> Vec3 {
        match self.guidance {
            Guidance::Hold { at }
                if at.distance(self.position) <= self.config.arrival_tolerance =>
            {
                at
            }
            _ => self.position,
        }
    }

    /// Stops and holds: brakes to the point where the drone can come to
    /// rest without exceeding its limits, and holds there. On the ground
    /// it simply stays.
    pub fn hold(&mut self) {
        if self.on_ground {
            self.guidance = Guidance::Idle;
            self.mode = FlightMode::Standby;
            return;
        }
        let at = self.stopping_point();
        self.hold_at(at);
    }

    /// Holds a given point in the air.
    pub fn hold_at(&mut self, at: Vec3) {
        if self.on_ground {
            self.guidance = Guidance::Idle;
            self.mode = FlightMode::Standby;
            return;
        }
        self.guidance = Guidance::Hold { at };
        self.mode = FlightMode::Hold;
    }

    /// Descends where it is until on the ground. Already on the ground,
    /// there is nothing to do.
    pub fn land(&mut self) {
        if self.on_ground {
            self.guidance = Guidance::Idle;
            self.mode = FlightMode::Standby;
            return;
        }
        let at = self.stopping_point();
        self.guidance = Guidance::Land { x: at.x, y: at.y };
        self.mode = FlightMode::Land;
    }

    /// Whether the drone is at its `GoTo` target, within the arrival
    /// tolerance in position and speed.
    pub fn arrived(&self) -> bool {
        match self.guidance {
            Guidance::GoTo { target, .. } => self.is_at(target),
            Guidance::Hold { at } => self.is_at(at),
            _ => false,
        }
    }

    /// Within the arrival tolerance of `point`, and slow.
    pub fn is_at(&self, point: Vec3) -> bool {
        self.position.distance(point) <= self.config.arrival_tolerance
            && self.velocity().norm() <= self.config.arrival_speed
    }

    /// A telemetry snapshot of the model.
    pub fn telemetry(&self, time: f64, home: Vec3) -> Telemetry {
        Telemetry {
            time,
            position: self.position,
            velocity: self.velocity(),
            battery: self.battery,
            armed: self.armed,
            landed: self.landed(),
            mode: self.mode,
            home,
        }
    }

    /// Advances the model by `dt` seconds.
    pub fn step(&mut self, dt: f64) -> StepEvents {
        let mut events = StepEvents::default();
        if !(dt.is_finite() && dt > 0.0) {
            return events;
        }
        let c = &self.config;
        let was_on_ground = self.on_ground;

        // Desired air velocity from the guidance.
        let (desired_h, desired_vz) = match self.guidance {
            Guidance::Idle => (Vec3::ZERO, 0.0),
            Guidance::Hold { at } => (
                self.horizontal_command(at, c.max_horizontal_speed),
                self.vertical_command(at.z),
            ),
            Guidance::GoTo { target, speed } => (
                self.horizontal_command(target, speed),
                self.vertical_command(target.z),
            ),
            Guidance::Land { x, y } => {
                let rate = if self.position.z > c.land_slow_height {
                    c.descent_rate
                } else {
                    c.land_speed.min(c.descent_rate)
                };
                (
                    self.horizontal_command(Vec3::new(x, y, 0.0), c.max_horizontal_speed),
                    -rate,
                )
            }
        };
        let (desired_h, desired_vz) = if self.armed {
            (desired_h, desired_vz)
        } else {
            (Vec3::ZERO, 0.0)
        };

        // Acceleration limits: the horizontal change as one vector, the
        // vertical on its own.
        let current_h = Vec3::new(self.velocity.x, self.velocity.y, 0.0);
        let mut dv = desired_h - current_h;
        let max_dv = c.max_horizontal_accel * dt;
        let n = dv.horizontal_norm();
        if n > max_dv {
            dv = dv * (max_dv / n);
        }
        let mut new_h = current_h + dv;
        let limit = c.max_horizontal_speed;
        let speed = new_h.horizontal_norm();
        if speed > limit {
            new_h = new_h * (limit / speed);
        }
        let max_dvz = c.max_vertical_accel * dt;
        let mut vz = self.velocity.z + (desired_vz - self.velocity.z).clamp(-max_dvz, max_dvz);
        vz = vz.clamp(-c.descent_rate, c.climb_rate);
        if self.on_ground && vz <= 0.0 {
            // Resting on the ground: no sliding, no sinking.
            new_h = Vec3::ZERO;
            vz = 0.0;
        }
        self.velocity = Vec3::new(new_h.x, new_h.y, vz);

        // Wind acts only on a drone in the air.
        if c.wind.gust > 0.0 && !self.on_ground {
            let tau = c.wind.gust_time.max(dt);
            let k = (2.0 * dt / tau).sqrt() * c.wind.gust;
            let (gx, gy) = (gaussian(&mut self.rng), gaussian(&mut self.rng));
            self.wind = Vec3::new(
                self.wind.x - self.wind.x / tau * dt + k * gx,
                self.wind.y - self.wind.y / tau * dt + k * gy,
                0.0,
            );
        } else {
            self.wind = Vec3::ZERO;
        }

        let before = self.position;
        self.position = self.position + (self.velocity + self.wind) * dt;
        if self.position.z <= GROUND {
            self.position.z = 0.0;
            if self.velocity.z <= 0.0 {
                self.velocity = Vec3::ZERO;
                self.wind = Vec3::ZERO;
                self.on_ground = true;
            }
        } else {
            self.on_ground = false;
        }
        let moved = self.position.distance(before);
        self.travelled += moved;
        self.time += dt;

        events.lifted_off = was_on_ground && !self.on_ground;
        events.touched_down = !was_on_ground && self.on_ground;
        if events.touched_down {
            self.guidance = Guidance::Idle;
            self.mode = FlightMode::Standby;
        }

        if self.armed && self.battery > 0.0 {
            let b = &self.config.battery;
            let per_second = if self.on_ground {
                b.idle_per_second
            } else {
                b.airborne_per_second
            };
            self.battery = (self.battery - per_second * dt - b.per_metre * moved).max(0.0);
            if self.battery <= 0.0 {
                events.battery_emptied = true;
                if !self.on_ground {
                    self.land();
                }
            }
        }
        events
    }

    fn check_battery(&self) -> Result<(), Refusal> {
        let minimum = self.config.battery.arm_minimum.max(0.0);
        if self.battery <= minimum {
            return Err(Refusal::BatteryEmpty {
                percent: self.battery,
                minimum,
            });
        }
        Ok(())
    }

    fn check_height(&self, z: f64) -> Result<(), Refusal> {
        if z < self.config.min_flight_height {
            return Err(Refusal::TooLow {
                z,
                min: self.config.min_flight_height,
            });
        }
        if z > self.config.max_flight_height {
            return Err(Refusal::TooHigh {
                z,
                max: self.config.max_flight_height,
            });
        }
        Ok(())
    }

    /// Where the drone comes to rest if it brakes now at its limits.
    fn stopping_point(&self) -> Vec3 {
        let c = &self.config;
        let h = Vec3::new(self.velocity.x, self.velocity.y, 0.0);
        let speed = h.horizontal_norm();
        let h_stop = if speed > 0.0 {
            h * (speed / (2.0 * c.max_horizontal_accel * BRAKING_MARGIN))
        } else {
            Vec3::ZERO
        };
        let vz = self.velocity.z;
        let z_stop = vz * vz.abs() / (2.0 * c.max_vertical_accel * BRAKING_MARGIN);
        let mut at = self.position + h_stop + Vec3::new(0.0, 0.0, z_stop);
        at.z = at.z.max(c.min_flight_height.min(self.position.z));
        at
    }

    /// Horizontal velocity toward `target`: as fast as allowed, slowing on
    /// a braking curve that stops on the target, and proportional to the
    /// error in the last decimetres.
    fn horizontal_command(&self, target: Vec3, speed: f64) -> Vec3 {
        let c = &self.config;
        let error = Vec3::new(target.x - self.position.x, target.y - self.position.y, 0.0);
        let d = error.horizontal_norm();
        if d < 1e-9 {
            return Vec3::ZERO;
        }
        let braking = (2.0 * c.max_horizontal_accel * BRAKING_MARGIN * d).sqrt();
        let s = speed
            .min(c.max_horizontal_speed)
            .min(braking)
            .min(c.position_gain * d);
        error * (s / d)
    }

    fn vertical_command(&self, target_z: f64) -> f64 {
        let c = &self.config;
        let e = target_z - self.position.z;
        let d = e.abs();
        let rate = if e > 0.0 {
            c.climb_rate
        } else {
            c.descent_rate
        };
        let braking = (2.0 * c.max_vertical_accel * BRAKING_MARGIN * d).sqrt();
        rate.min(braking).min(c.position_gain * d) * e.signum()
    }
}

/// A standard normal sample (Box-Muller), so the only dependency for noise
/// is the seeded generator itself.
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

impl fmt::Display for Guidance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Guidance::Idle => write!(f, "idle"),
            Guidance::Hold { at } => write!(f, "hold at {at}"),
            Guidance::GoTo { target, speed } => write!(f, "go to {target} at {speed:.2} m/s"),
            Guidance::Land { x, y } => write!(f, "land at ({x:.2}, {y:.2})"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.02;

    fn airborne_at(h: f64) -> Multirotor {
        let mut m = Multirotor::new(MultirotorConfig::default());
        m.arm().unwrap();
        m.takeoff(h).unwrap();
        run_until(&mut m, 60.0, |m| m.arrived());
        m.hold_at(m.position());
        m
    }

    /// Steps until `done` or `limit` seconds, returning the seconds taken.
    fn run_until(m: &mut Multirotor, limit: f64, mut done: impl FnMut(&Multirotor) -> bool) -> f64 {
        let mut t = 0.0;
        while t < limit {
            if done(m) {
                return t;
            }
            m.step(DT);
            t += DT;
        }
        panic!("not done after {limit} s: {:?}", m);
    }

    /// Steps until arrival, checking the envelope at every step; returns
    /// the seconds taken and the top horizontal speed.
    fn fly_within_limits(m: &mut Multirotor, limit: f64) -> (f64, f64) {
        let c = m.config().clone();
        let mut prev = m.air_velocity();
        let mut top: f64 = 0.0;
        let mut t = 0.0;
        while !m.arrived() {
            assert!(t < limit, "not there after {limit} s: {m:?}");
            m.step(DT);
            t += DT;
            let v = m.air_velocity();
            let h = v.horizontal_norm();
            top = top.max(h);
            assert!(h <= c.max_horizontal_speed + 1e-9, "horizontal speed {h}");
            assert!(v.z <= c.climb_rate + 1e-9, "climb {}", v.z);
            assert!(-v.z <= c.descent_rate + 1e-9, "descent {}", v.z);
            let dv = v - prev;
            let ah = dv.horizontal_norm() / DT;
            assert!(ah <= c.max_horizontal_accel + 1e-6, "horizontal accel {ah}");
            assert!(
                dv.z.abs() / DT <= c.max_vertical_accel + 1e-6,
                "vertical accel"
            );
            assert!(m.position().z >= 0.0);
            prev = v;
        }
        (t, top)
    }

    #[test]
    fn a_fly_by_x_of_one_metre_arrives_within_tolerance_inside_the_envelope() {
        let mut m = airborne_at(1.5);
        let start = m.reference();
        let target = start + Vec3::new(1.0, 0.0, 0.0);
        m.go_to(target, FlightMode::Guided).unwrap();
        let (t, _) = fly_within_limits(&mut m, 30.0);
        assert!(m.position().distance(target) <= m.config().arrival_tolerance);
        assert!(m.velocity().norm() <= m.config().arrival_speed);
        // A metre at 2.5 m/s² takes well over a second and well under ten.
        assert!(t > 0.8 && t < 10.0, "took {t} s");
    }

    #[test]
    fn a_long_flight_never_exceeds_the_speed_and_acceleration_limits() {
        let mut m = airborne_at(2.0);
        let c = m.config().clone();
        m.go_to(Vec3::new(40.0, -30.0, 12.0), FlightMode::Guided)
            .unwrap();
        let (_, top_speed) = fly_within_limits(&mut m, 60.0);
        // It did reach cruise speed on a 50 m leg.
        assert!(top_speed > c.max_horizontal_speed - 0.01);
        // And comes down again within the descent rate.
        m.go_to(Vec3::new(40.0, -30.0, 1.0), FlightMode::Guided)
            .unwrap();
        fly_within_limits(&mut m, 60.0);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        #[test]
        fn any_target_in_the_flight_volume_is_reached_inside_the_envelope(
            start_h in 0.5f64..20.0,
            x in -60.0f64..60.0,
            y in -60.0f64..60.0,
            z in 0.3f64..40.0,
            stop_after in 0usize..400,
        ) {
            let mut m = airborne_at(start_h);
            // Sometimes redirect mid-flight, to start from any velocity.
            m.go_to(Vec3::new(-x, y / 2.0, start_h), FlightMode::Guided).unwrap();
            for _ in 0..stop_after {
                m.step(DT);
            }
            let target = Vec3::new(x, y, z);
            m.go_to(target, FlightMode::Guided).unwrap();
            fly_within_limits(&mut m, 120.0);
            proptest::prop_assert!(m.position().distance(target) <= m.config().arrival_tolerance);
        }
    }

    #[test]
    fn a_takeoff_climbs_at_the_climb_rate() {
        let mut m = Multirotor::new(MultirotorConfig::default());
        m.arm().unwrap();
        m.takeoff(20.0).unwrap();
        let mut top_climb: f64 = 0.0;
        let mut steps_at_rate = 0;
        for _ in 0..(20.0 / DT) as usize {
            let events = m.step(DT);
            let vz = m.velocity().z;
            top_climb = top_climb.max(vz);
            if (vz - m.config().climb_rate).abs() < 1e-9 {
                steps_at_rate += 1;
            }
            assert!(!events.touched_down);
        }
        assert_eq!(top_climb, m.config().climb_rate);
        // Most of a 20 m climb at 2 m/s is spent at the rate.
        assert!(
            steps_at_rate as f64 * DT > 6.0,
            "{steps_at_rate} steps at rate"
        );
        assert!(m.arrived());
        assert_eq!(m.mode(), FlightMode::Takeoff);
    }

    #[test]
    fn a_landing_stops_on_the_ground_and_never_below_it() {
        let mut m = airborne_at(5.0);
        m.land();
        assert_eq!(m.mode(), FlightMode::Land);
        let mut touched = false;
        for _ in 0..(30.0 / DT) as usize {
            let e = m.step(DT);
            touched |= e.touched_down;
            assert!(m.position().z >= 0.0);
        }
        assert!(touched);
        assert!(m.landed());
        assert_eq!(m.mode(), FlightMode::Standby);
        assert!(m.is_armed(), "landing does not disarm by itself");
        m.disarm().unwrap();
    }

    #[test]
    fn the_same_seed_gives_the_same_trajectory_and_another_seed_another() {
        let fly = |seed: u64| {
            let config = MultirotorConfig {
                wind: WindConfig {
                    seed,
                    gust: 0.5,
                    gust_time: 1.0,
                },
                ..MultirotorConfig::default()
            };
            let mut m = Multirotor::new(config);
            m.arm().unwrap();
            m.takeoff(3.0).unwrap();
            let mut track = Vec::new();
            for i in 0..1500 {
                if i == 300 {
                    m.go_to(Vec3::new(10.0, 5.0, 3.0), FlightMode::Guided)
                        .unwrap();
                }
                m.step(DT);
                track.push(m.position());
            }
            track
        };
        let a = fly(7);
        assert_eq!(a, fly(7));
        assert_ne!(a, fly(8));
        // The wind pushes, but the controller still brings it home.
        assert!(a.last().unwrap().distance(Vec3::new(10.0, 5.0, 3.0)) < 1.0);
    }

    #[test]
    fn the_battery_drains_faster_in_flight_than_idling_and_not_when_disarmed() {
        let mut m = Multirotor::new(MultirotorConfig::default());
        for _ in 0..100 {
            m.step(DT);
        }
        assert_eq!(m.battery(), 100.0);
        m.arm().unwrap();
        for _ in 0..100 {
            m.step(DT);
        }
        let idle = 100.0 - m.battery();
        assert!(idle > 0.0);
        m.takeoff(2.0).unwrap();
        run_until(&mut m, 30.0, |m| m.arrived());
        m.go_to(Vec3::new(20.0, 0.0, 2.0), FlightMode::Guided)
            .unwrap();
        let before = m.battery();
        for _ in 0..100 {
            m.step(DT);
        }
        let flying = before - m.battery();
        assert!(flying > idle, "flying {flying} vs idle {idle}");
    }

    #[test]
    fn an_empty_battery_in_the_air_lands_the_drone() {
        let mut m = airborne_at(3.0);
        m.set_battery(0.01);
        let mut emptied = false;
        for _ in 0..(20.0 / DT) as usize {
            emptied |= m.step(DT).battery_emptied;
        }
        assert!(emptied);
        assert!(m.landed());
        assert_eq!(m.battery(), 0.0);
        m.disarm().unwrap();
        assert_eq!(
            m.arm(),
            Err(Refusal::BatteryEmpty {
                percent: 0.0,
                minimum: 0.0
            })
        );
    }

    #[test]
    fn refusals_say_what_state_the_drone_is_in() {
        let mut m = Multirotor::new(MultirotorConfig::default());
        assert_eq!(m.takeoff(2.0), Err(Refusal::NotArmed));
        m.arm().unwrap();
        assert_eq!(
            m.go_to(Vec3::new(1.0, 0.0, 2.0), FlightMode::Guided),
            Err(Refusal::OnGround)
        );
        assert!(matches!(m.takeoff(0.1), Err(Refusal::TooLow { .. })));
        assert!(matches!(m.takeoff(500.0), Err(Refusal::TooHigh { .. })));
        m.takeoff(2.0).unwrap();
        run_until(&mut m, 30.0, |m| m.arrived());
        assert!(matches!(m.disarm(), Err(Refusal::Airborne { .. })));
        assert!(matches!(m.takeoff(3.0), Err(Refusal::AlreadyFlying { .. })));
        assert!(matches!(
            m.go_to(Vec3::new(0.0, 0.0, 0.0), FlightMode::Guided),
            Err(Refusal::TooLow { .. })
        ));
        assert_eq!(
            Refusal::NotArmed.to_string(),
            "the motors are not armed; call Arm first"
        );
    }

    #[test]
    fn holding_brakes_to_a_stop_without_turning_back() {
        let mut m = airborne_at(3.0);
        m.go_to(Vec3::new(30.0, 0.0, 3.0), FlightMode::Guided)
            .unwrap();
        for _ in 0..200 {
            m.step(DT);
        }
        let x_at_hold = m.position().x;
        m.hold();
        let mut prev_x = x_at_hold;
        for _ in 0..(10.0 / DT) as usize {
            m.step(DT);
            assert!(m.position().x >= prev_x - 1e-3, "turned back");
            prev_x = m.position().x;
        }
        assert!(m.velocity().norm() < 0.01);
        assert_eq!(m.mode(), FlightMode::Hold);
        // Braking from at most 5 m/s at 2.5 m/s² takes at most about 5.6 m.
        assert!(m.position().x - x_at_hold < 6.0);
    }

    #[test]
    fn repeated_small_moves_add_up_from_the_held_point() {
        let mut m = airborne_at(1.0);
        let start = m.reference();
        for _ in 0..3 {
            let target = m.reference() + Vec3::new(0.2, 0.0, 0.0);
            m.go_to(target, FlightMode::Guided).unwrap();
            run_until(&mut m, 10.0, |m| m.arrived());
            m.hold_at(target);
        }
        assert!((m.reference().x - start.x - 0.6).abs() < 1e-9);
    }
}
