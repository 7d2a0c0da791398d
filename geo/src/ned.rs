//! MAVLink's local north-east-down frame against the mission frame.
//!
//! The mission frame has X north, Y east, Z up; MAVLink's `MAV_FRAME_LOCAL_NED`
//! has north, east, down. So N = X, E = Y, D = -Z. Getting the sign of Z
//! wrong sends a copter into the ground, which is why the conversion lives
//! in one place with its own tests.

use crate::Vec3;

/// A position or velocity in a local north-east-down frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ned {
    pub north: f64,
    pub east: f64,
    pub down: f64,
}

impl Ned {
    pub const fn new(north: f64, east: f64, down: f64) -> Self {
        Self { north, east, down }
    }

    /// The same point in the mission frame (X north, Y east, Z up).
    pub fn to_mission(self) -> Vec3 {
        Vec3::new(self.north, self.east, -self.down)
    }

    /// A point of the mission frame in NED.
    pub fn from_mission(v: Vec3) -> Self {
        Ned::new(v.x, v.y, -v.z)
    }
}

impl std::ops::Add for Ned {
    type Output = Ned;
    fn add(self, o: Ned) -> Ned {
        Ned::new(self.north + o.north, self.east + o.east, self.down + o.down)
    }
}

impl std::ops::Sub for Ned {
    type Output = Ned;
    fn sub(self, o: Ned) -> Ned {
        Ned::new(self.north - o.north, self.east - o.east, self.down - o.down)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn up_in_the_mission_is_negative_down_in_ned() {
        let ned = Ned::from_mission(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(ned, Ned::new(1.0, 2.0, -3.0));
        assert_eq!(ned.to_mission(), Vec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn north_is_x_and_east_is_y_in_both_frames() {
        assert_eq!(
            Ned::new(5.0, 0.0, 0.0).to_mission(),
            Vec3::new(5.0, 0.0, 0.0)
        );
        assert_eq!(
            Ned::new(0.0, 5.0, 0.0).to_mission(),
            Vec3::new(0.0, 5.0, 0.0)
        );
        assert_eq!(
            Ned::new(0.0, 0.0, 5.0).to_mission(),
            Vec3::new(0.0, 0.0, -5.0)
        );
    }
}
