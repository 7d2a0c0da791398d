//! The parameters a ground station may read before flight, as the imitated
//! firmware names them, with the firmware's defaults; `--param NAME=VALUE`
//! sets others. Only what the vehicle acts on is served: a parameter it
//! does not know gets no answer, as a real autopilot gives none.

use eamos_mid::mavlink::dialect::{
    MavMessage, MavParamType, PARAM_REQUEST_READ_DATA, PARAM_VALUE_DATA,
};

use crate::firmware::Firmware;
use crate::state::Vehicle;

impl Vehicle {
    /// The value of parameter `name`: set on the command line, else the
    /// firmware's default.
    pub(crate) fn param(&self, name: &str) -> Option<f64> {
        if name == "COM_OF_LOSS_T" && self.o.autopilot == Firmware::Px4 {
            return Some(self.o.offboard_loss_after);
        }
        self.o
            .params
            .iter()
            .rev()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
            .or_else(|| {
                self.o
                    .autopilot
                    .params()
                    .iter()
                    .find(|(n, ..)| *n == name)
                    .map(|(_, v, _)| *v)
            })
    }

    /// Answers a `PARAM_REQUEST_READ` by name, packing integers the way
    /// the firmware does (PX4 bytewise, ArduPilot as a cast).
    pub(crate) fn answer_param(&mut self, request: &PARAM_REQUEST_READ_DATA) {
        let Ok(name) = request.param_id.to_str() else {
            return;
        };
        let table = self.o.autopilot.params();
        let Some(index) = table.iter().position(|(n, ..)| *n == name) else {
            return;
        };
        let Some(value) = self.param(name) else {
            return;
        };
        let kind = table[index].2;
        let packed = match (self.o.autopilot, kind) {
            (Firmware::Px4, MavParamType::MAV_PARAM_TYPE_INT32) => {
                f32::from_bits(value as i32 as u32)
            }
            _ => value as f32,
        };
        self.outbox.push(MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: packed,
            param_count: table.len() as u16,
            param_index: index as u16,
            param_id: name.into(),
            param_type: kind,
        }));
    }
}
