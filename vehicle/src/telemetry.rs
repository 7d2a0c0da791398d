//! What the vehicle sends: the heartbeat and every stream a ground station
//! asked for (or PX4 sends unasked), in the autopilot's own manner.

use eamos_geo::{LocalFrame, Ned, Vec3};
use eamos_mid::mavlink::dialect::{
    EkfStatusFlags, GpsFixType, MavAutopilot, MavDataStream, MavLandedState, MavMessage,
    MavModeFlag, MavState, MavSysStatusSensor, MavType, MavVtolState, EKF_STATUS_REPORT_DATA,
    EXTENDED_SYS_STATE_DATA, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA, HEARTBEAT_DATA,
    HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, SYS_STATUS_DATA,
};
use eamos_mid::FlightMode;

use crate::firmware::Firmware;
use crate::mode::Role;
use crate::state::Vehicle;

/// Message ids the vehicle can stream, with ArduPilot's data-stream group.
pub(crate) const STREAMABLE: &[(u32, MavDataStream)] = &[
    (1, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // SYS_STATUS
    (24, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // GPS_RAW_INT
    (33, MavDataStream::MAV_DATA_STREAM_POSITION),       // GLOBAL_POSITION_INT
    (32, MavDataStream::MAV_DATA_STREAM_POSITION),       // LOCAL_POSITION_NED
    (193, MavDataStream::MAV_DATA_STREAM_EXTRA3),        // EKF_STATUS_REPORT
    (245, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS), // EXTENDED_SYS_STATE
    (242, MavDataStream::MAV_DATA_STREAM_EXTRA3),        // HOME_POSITION
];

impl Vehicle {
    /// PX4 streams telemetry on a ground-station link from boot;
    /// ArduPilot waits to be asked.
    pub(crate) fn with_default_streams(mut self) -> Self {
        if self.o.autopilot == Firmware::Px4 {
            for (id, hz) in [(1, 1.0), (24, 1.0), (32, 10.0), (33, 5.0), (245, 1.0)] {
                self.streams.insert(id, (1.0 / hz, 0.0));
            }
        }
        self
    }

    /// Whether the firmware sends message `id` at all.
    pub(crate) fn streamable(&self, id: u32) -> bool {
        STREAMABLE.iter().any(|(s, _)| *s == id)
            && !(self.o.autopilot == Firmware::Px4 && id == 193)
    }

    /// Queues the heartbeat and every stream that is due.
    pub(crate) fn emit_due(&mut self) {
        if self.time >= self.next_heartbeat {
            self.next_heartbeat += 1.0;
            let hb = self.heartbeat();
            self.outbox.push(hb);
        }
        let mut due = Vec::new();
        for (id, (interval, next)) in self.streams.iter_mut() {
            if self.time >= *next {
                *next = (*next + *interval).max(self.time);
                due.push(*id);
            }
        }
        due.sort_unstable();
        for id in due {
            if let Some(m) = self.message(id) {
                self.outbox.push(m);
            }
        }
    }

    pub(crate) fn heartbeat(&self) -> MavMessage {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
        if self.kin.is_armed() {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        if self.mode.role() == Role::Guided {
            base |= MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
        }
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: self.mode.custom,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: match self.o.autopilot {
                Firmware::ArduPilot => MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                Firmware::Px4 => MavAutopilot::MAV_AUTOPILOT_PX4,
            },
            base_mode: base,
            system_status: if self.kin.is_armed() {
                MavState::MAV_STATE_ACTIVE
            } else {
                MavState::MAV_STATE_STANDBY
            },
            mavlink_version: 3,
        })
    }

    /// Position relative to the EKF origin.
    pub(crate) fn local_ned(&self) -> Ned {
        Ned::from_mission(self.kin.position()) - self.o.ekf_origin_offset
    }

    /// The wander of the position estimate of a flying copter (a real EKF
    /// drifts by centimetres around where the copter holds), and its rate
    /// of change, which the reported velocity carries too: a sum of slow
    /// sines per axis, their phases set by the system id, so that a run
    /// is repeatable and two vehicles wander apart. Zero on the ground.
    pub(crate) fn noise(&self) -> (Vec3, Vec3) {
        let a = self.o.position_noise;
        if a == 0.0 || !self.kin.is_airborne() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let t = self.time;
        let phase = f64::from(self.o.system_id) * 1.7;
        let axis = |k: f64| {
            let waves = [(0.5, 2.9), (0.3, 1.3), (0.2, 0.61)];
            let mut p = 0.0;
            let mut v = 0.0;
            for (weight, period) in waves {
                let w = std::f64::consts::TAU / (period * (1.0 + 0.13 * k));
                let x = w * t + phase * (k + 1.0);
                p += a * weight * x.sin();
                v += a * weight * w * x.cos();
            }
            (p, v)
        };
        let (x, y, z) = (axis(0.0), axis(1.0), axis(2.0));
        // Height wanders less than position.
        (
            Vec3::new(x.0, y.0, 0.5 * z.0),
            Vec3::new(x.1, y.1, 0.5 * z.1),
        )
    }

    pub(crate) fn boot_ms(&self) -> u32 {
        (self.time * 1000.0) as u32
    }

    /// One message of a stream, or `None` when the autopilot would not
    /// have it yet (no local position before the EKF origin).
    pub(crate) fn message(&self, id: u32) -> Option<MavMessage> {
        let (wander, wander_rate) = self.noise();
        let v = self.kin.velocity() + wander_rate;
        let vel = Ned::from_mission(v);
        Some(match id {
            1 => {
                let sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY;
                let prearm = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
                let mut health = sensors;
                if !self.has_fix() {
                    health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS);
                }
                if self.prearm_failure().is_none() || self.kin.is_armed() {
                    health |= prearm;
                }
                let battery = self.kin.battery();
                MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                    onboard_control_sensors_present: sensors | prearm,
                    onboard_control_sensors_enabled: sensors | prearm,
                    onboard_control_sensors_health: health,
                    load: 250,
                    // A 4S pack: 16.8 V full, 14.0 V empty.
                    voltage_battery: (14_000.0 + 28.0 * battery) as u16,
                    current_battery: if self.kin.is_airborne() { 1200 } else { 50 },
                    battery_remaining: battery.round().clamp(0.0, 100.0) as i8,
                    ..Default::default()
                })
            }
            24 => {
                let here = LocalFrame::new(self.o.home).to_wgs84(self.kin.position());
                let (lat, lon, alt) = here.to_e7();
                MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                    time_usec: (self.time * 1e6) as u64,
                    lat: if self.has_fix() { lat } else { 0 },
                    lon: if self.has_fix() { lon } else { 0 },
                    alt: if self.has_fix() { alt } else { 0 },
                    eph: if self.has_fix() { 121 } else { u16::MAX },
                    epv: if self.has_fix() { 200 } else { u16::MAX },
                    vel: (v.horizontal_norm() * 100.0) as u16,
                    cog: 0,
                    fix_type: if self.has_fix() {
                        GpsFixType::GPS_FIX_TYPE_3D_FIX
                    } else {
                        GpsFixType::GPS_FIX_TYPE_NO_FIX
                    },
                    satellites_visible: if self.has_fix() { 10 } else { 0 },
                })
            }
            33 => {
                if !self.has_fix() {
                    return None;
                }
                let p = self.kin.position() + wander;
                let here = LocalFrame::new(self.o.home).to_wgs84(p);
                let (lat, lon, alt) = here.to_e7();
                MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: self.boot_ms(),
                    lat,
                    lon,
                    alt,
                    relative_alt: (p.z * 1000.0).round() as i32,
                    vx: (vel.north * 100.0).round() as i16,
                    vy: (vel.east * 100.0).round() as i16,
                    vz: (vel.down * 100.0).round() as i16,
                    hdg: 0,
                })
            }
            32 => {
                if !self.has_origin() {
                    return None;
                }
                let p = self.local_ned() + Ned::from_mission(wander);
                MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                    time_boot_ms: self.boot_ms(),
                    x: p.north as f32,
                    y: p.east as f32,
                    z: p.down as f32,
                    vx: vel.north as f32,
                    vy: vel.east as f32,
                    vz: vel.down as f32,
                })
            }
            // Home is set at the first 3D fix, where the copter stands.
            242 => {
                if !self.has_fix() {
                    return None;
                }
                let (latitude, longitude, altitude) = self.o.home.to_e7();
                // Home stands at the kinematics' origin; its local position
                // is relative to the EKF origin, like LOCAL_POSITION_NED.
                let local = Ned::default() - self.o.ekf_origin_offset;
                MavMessage::HOME_POSITION(HOME_POSITION_DATA {
                    latitude,
                    longitude,
                    altitude,
                    x: local.north as f32,
                    y: local.east as f32,
                    z: local.down as f32,
                    q: [1.0, 0.0, 0.0, 0.0],
                    ..Default::default()
                })
            }
            193 if self.o.autopilot == Firmware::Px4 => return None,
            193 => {
                let mut flags = EkfStatusFlags::EKF_ATTITUDE | EkfStatusFlags::EKF_VELOCITY_VERT;
                if self.has_origin() {
                    flags |= EkfStatusFlags::EKF_VELOCITY_HORIZ
                        | EkfStatusFlags::EKF_POS_HORIZ_REL
                        | EkfStatusFlags::EKF_POS_VERT_AGL
                        | EkfStatusFlags::EKF_PRED_POS_HORIZ_REL;
                } else {
                    flags |= EkfStatusFlags::EKF_CONST_POS_MODE;
                }
                if self.ready() {
                    flags |= EkfStatusFlags::EKF_POS_HORIZ_ABS
                        | EkfStatusFlags::EKF_POS_VERT_ABS
                        | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS;
                }
                MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                    velocity_variance: 0.02,
                    pos_horiz_variance: if self.ready() { 0.01 } else { 0.5 },
                    pos_vert_variance: 0.01,
                    compass_variance: 0.01,
                    terrain_alt_variance: 0.0,
                    flags,
                })
            }
            245 => MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: if self.kin.on_ground() {
                    MavLandedState::MAV_LANDED_STATE_ON_GROUND
                } else if self.kin.mode() == FlightMode::Takeoff {
                    MavLandedState::MAV_LANDED_STATE_TAKEOFF
                } else if self.kin.mode() == FlightMode::Land {
                    MavLandedState::MAV_LANDED_STATE_LANDING
                } else {
                    MavLandedState::MAV_LANDED_STATE_IN_AIR
                },
            }),
            _ => return None,
        })
    }
}
