//! The airspace a fleet may fly in: a fence, a ceiling and a floor, and the
//! least distance two drones must keep.
//!
//! Heights are metres above each drone's own home, as the mission's `Z` is:
//! a ceiling of 120 m is 120 m above the ground the drone took off from.

use crate::{Fence, Vec3};

/// The separation two drones keep when the fleet file does not say: the
/// span of a small multirotor (0.5 m, rotor tip to rotor tip) plus a metre
/// of margin for position error (GNSS with a good fix, and the autopilot's
/// own tracking error in a gentle wind).
pub const DEFAULT_SEPARATION: f64 = 1.5;

/// Where a fleet may fly. Without a fence, any horizontal position is
/// allowed; without a ceiling, any height above the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Airspace {
    /// In the fleet frame (metres north and east of its origin).
    pub fence: Option<Fence>,
    /// Metres above home.
    pub ceiling: Option<f64>,
    /// Metres above home; 0 (the ground) unless the fleet file says.
    pub floor: f64,
    /// Least distance between two drones, metres.
    pub separation: f64,
}

impl Default for Airspace {
    fn default() -> Self {
        Airspace {
            fence: None,
            ceiling: None,
            floor: 0.0,
            separation: DEFAULT_SEPARATION,
        }
    }
}

/// Why a leg leaves the airspace: the first point out and which bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Breach {
    /// Leaves the fence at this point (fleet frame).
    Fence(Vec3),
    /// Climbs above the ceiling; the point is the highest one of the leg.
    Ceiling(Vec3),
    /// Goes below the floor; the point is the lowest one of the leg.
    Floor(Vec3),
}

impl Breach {
    pub fn point(self) -> Vec3 {
        match self {
            Breach::Fence(p) | Breach::Ceiling(p) | Breach::Floor(p) => p,
        }
    }
}

impl Airspace {
    /// Whether the straight leg from `a` to `b` (fleet frame, with heights
    /// above home in `z`) stays inside: the fence judges every point of the
    /// leg, not only its ends; heights are linear along a leg, so its ends
    /// decide the ceiling and the floor.
    pub fn breach(&self, a: Vec3, b: Vec3) -> Option<Breach> {
        if let Some(fence) = &self.fence {
            if let Some(p) = fence.exit(a, b) {
                return Some(Breach::Fence(p));
            }
        }
        let (high, low) = if a.z >= b.z { (a, b) } else { (b, a) };
        if let Some(c) = self.ceiling {
            if high.z > c + HEIGHT_TOLERANCE {
                return Some(Breach::Ceiling(high));
            }
        }
        if low.z < self.floor - HEIGHT_TOLERANCE {
            return Some(Breach::Floor(low));
        }
        None
    }
}

/// Rounding of heights computed from the mission's arguments (a millimetre).
const HEIGHT_TOLERANCE: f64 = 1e-3;

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Airspace {
        Airspace {
            fence: Some(
                Fence::new(vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]).unwrap(),
            ),
            ceiling: Some(20.0),
            ..Airspace::default()
        }
    }

    #[test]
    fn a_leg_inside_the_fence_and_below_the_ceiling_stays_inside() {
        let a = square();
        assert_eq!(
            a.breach(Vec3::new(1.0, 1.0, 0.0), Vec3::new(9.0, 9.0, 20.0)),
            None
        );
    }

    #[test]
    fn a_leg_is_out_through_the_fence_the_ceiling_or_the_floor() {
        let a = square();
        let out = a.breach(Vec3::new(5.0, 5.0, 5.0), Vec3::new(15.0, 5.0, 5.0));
        assert!(
            matches!(out, Some(Breach::Fence(p)) if (p.x - 10.0).abs() < 1e-6),
            "{out:?}"
        );
        let up = a.breach(Vec3::new(5.0, 5.0, 5.0), Vec3::new(5.0, 5.0, 25.0));
        assert_eq!(up, Some(Breach::Ceiling(Vec3::new(5.0, 5.0, 25.0))));
        let down = a.breach(Vec3::new(5.0, 5.0, 5.0), Vec3::new(5.0, 5.0, -1.0));
        assert_eq!(down, Some(Breach::Floor(Vec3::new(5.0, 5.0, -1.0))));
    }

    #[test]
    fn without_a_fence_or_a_ceiling_only_the_floor_bounds() {
        let a = Airspace::default();
        assert_eq!(
            a.breach(Vec3::new(-1e6, 0.0, 0.0), Vec3::new(1e6, 0.0, 1e4)),
            None
        );
        assert!(a.separation > 0.0 && a.separation <= 2.0);
    }
}
