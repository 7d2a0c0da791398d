//! Reading an autopilot's parameters by name (`PARAM_REQUEST_READ`,
//! answered by `PARAM_VALUE`), for what the adapter must know before
//! flight, such as what the autopilot does when its ground link is lost.

use tokio::sync::broadcast::error::RecvError;
use tokio::time::{timeout_at, Instant};

use super::command::CommandPolicy;
use super::command::Target;
use super::dialect::{MavMessage, MavParamType, PARAM_REQUEST_READ_DATA};
use super::link::Link;
use super::modes::Autopilot;

/// A parameter that could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("the autopilot did not answer for parameter {name} after {attempts} requests")]
    NoAnswer { name: String, attempts: u32 },
    #[error("could not ask for parameter {name}: {reason}")]
    NotSent { name: String, reason: String },
}

/// Reads parameter `name` of `target`, asking again after each
/// acknowledgement timeout of `policy`. Integer parameters come back as
/// numbers: PX4 packs their bits into the float field ("bytewise"),
/// ArduPilot casts them, so `autopilot` says how to unpack.
pub async fn read_param(
    link: &Link,
    target: Target,
    autopilot: Autopilot,
    name: &str,
    policy: &CommandPolicy,
) -> Result<f64, ParamError> {
    let mut incoming = link.subscribe();
    let attempts = policy.attempts.max(1);
    for _ in 0..attempts {
        let request = MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: target.system,
            target_component: target.component,
            param_id: name.into(),
        });
        match link.send(&request).await {
            Ok(true) => {}
            Ok(false) => {
                return Err(ParamError::NotSent {
                    name: name.to_string(),
                    reason: "the vehicle has not been heard on this link".to_string(),
                })
            }
            Err(e) => {
                return Err(ParamError::NotSent {
                    name: name.to_string(),
                    reason: e.to_string(),
                })
            }
        }
        let deadline = Instant::now() + policy.ack_timeout;
        loop {
            let received = match timeout_at(deadline, incoming.recv()).await {
                Err(_) => break,
                Ok(Err(RecvError::Lagged(_))) => continue,
                Ok(Err(RecvError::Closed)) => {
                    return Err(ParamError::NotSent {
                        name: name.to_string(),
                        reason: "the link closed".to_string(),
                    })
                }
                Ok(Ok(r)) => r,
            };
            if received.header.system_id != u32::from(target.system) {
                continue;
            }
            if let MavMessage::PARAM_VALUE(v) = &received.message {
                if v.param_id.to_str().is_ok_and(|id| id == name) {
                    return Ok(value_of(v.param_value, v.param_type, autopilot));
                }
            }
        }
    }
    Err(ParamError::NoAnswer {
        name: name.to_string(),
        attempts,
    })
}

/// The number a `PARAM_VALUE` carries.
pub fn value_of(raw: f32, kind: MavParamType, autopilot: Autopilot) -> f64 {
    use MavParamType::*;
    let bytewise = matches!(autopilot, Autopilot::Px4);
    if !bytewise {
        return f64::from(raw);
    }
    let bits = raw.to_bits();
    match kind {
        MAV_PARAM_TYPE_UINT8 => f64::from(bits as u8),
        MAV_PARAM_TYPE_INT8 => f64::from(bits as u8 as i8),
        MAV_PARAM_TYPE_UINT16 => f64::from(bits as u16),
        MAV_PARAM_TYPE_INT16 => f64::from(bits as u16 as i16),
        MAV_PARAM_TYPE_UINT32 => f64::from(bits),
        MAV_PARAM_TYPE_INT32 => f64::from(bits as i32),
        _ => f64::from(raw),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn px4_integers_are_unpacked_from_the_float_bits_and_ardupilot_ones_are_cast() {
        let packed = f32::from_bits(4);
        assert_eq!(
            value_of(packed, MavParamType::MAV_PARAM_TYPE_INT32, Autopilot::Px4),
            4.0
        );
        assert_eq!(
            value_of(
                f32::from_bits((-1i32) as u32),
                MavParamType::MAV_PARAM_TYPE_INT32,
                Autopilot::Px4
            ),
            -1.0
        );
        assert_eq!(
            value_of(1.5, MavParamType::MAV_PARAM_TYPE_REAL32, Autopilot::Px4),
            1.5
        );
        assert_eq!(
            value_of(5.0, MavParamType::MAV_PARAM_TYPE_INT8, Autopilot::ArduPilot),
            5.0
        );
    }
}
