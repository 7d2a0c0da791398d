//! Closest approach between points and straight segments in 3D.
//!
//! A drone at rest occupies a point and a drone under way the segment from
//! where it started to its target, so the separation of two drones is the
//! distance between two segments (a point being a segment of length 0).

use crate::Vec3;

/// How close two shapes come, and where: `first` on the first shape,
/// `second` on the second, `distance` between the two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    pub distance: f64,
    pub first: Vec3,
    pub second: Vec3,
}

impl Approach {
    fn between(first: Vec3, second: Vec3) -> Self {
        Approach {
            distance: first.distance(second),
            first,
            second,
        }
    }
}

/// The closest approach of point `p` to the segment from `a` to `b`.
pub fn point_segment(p: Vec3, a: Vec3, b: Vec3) -> Approach {
    let d = b - a;
    let len2 = d.dot(d);
    let t = if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Approach::between(p, a + d * t)
}

/// The closest approach of the segment `a0`-`a1` to the segment `b0`-`b1`.
///
/// Minimises over both segments' parameters at once, clamping to the
/// segments' ends (Ericson, *Real-Time Collision Detection*, 5.1.9); parallel
/// and degenerate segments are answered too.
pub fn segment_segment(a0: Vec3, a1: Vec3, b0: Vec3, b1: Vec3) -> Approach {
    let d1 = a1 - a0;
    let d2 = b1 - b0;
    let r = a0 - b0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let (s, t) = if a == 0.0 && e == 0.0 {
        (0.0, 0.0)
    } else if a == 0.0 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e == 0.0 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            // Parallel (or nearly): any start on the first segment will do,
            // the clamping below finds the closest pair from there.
            let s = if denom > 1e-12 * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t = (b * s + f) / e;
            if t < 0.0 {
                ((-c / a).clamp(0.0, 1.0), 0.0)
            } else if t > 1.0 {
                (((b - c) / a).clamp(0.0, 1.0), 1.0)
            } else {
                (s, t)
            }
        }
    };
    Approach::between(a0 + d1 * s, b0 + d2 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn a_point_is_closest_to_its_foot_on_the_segment_or_to_an_end() {
        let a = v(0.0, 0.0, 0.0);
        let b = v(10.0, 0.0, 0.0);
        let mid = point_segment(v(4.0, 3.0, 0.0), a, b);
        assert_eq!(mid.second, v(4.0, 0.0, 0.0));
        assert!((mid.distance - 3.0).abs() < 1e-12);
        let past = point_segment(v(13.0, 4.0, 0.0), a, b);
        assert_eq!(past.second, b);
        assert!((past.distance - 5.0).abs() < 1e-12);
        assert!((point_segment(v(0.0, 0.0, 2.0), a, a).distance - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_head_on_swap_at_one_height_meets_and_at_two_heights_keeps_apart() {
        let swap = segment_segment(
            v(0.0, 0.0, 3.0),
            v(10.0, 0.0, 3.0),
            v(10.0, 0.0, 3.0),
            v(0.0, 0.0, 3.0),
        );
        assert!(swap.distance < 1e-12);
        let stacked = segment_segment(
            v(0.0, 0.0, 3.0),
            v(10.0, 0.0, 3.0),
            v(10.0, 0.0, 6.0),
            v(0.0, 0.0, 6.0),
        );
        assert!((stacked.distance - 3.0).abs() < 1e-12);
    }

    #[test]
    fn crossing_legs_meet_where_they_cross_and_skew_ones_at_their_gap() {
        let cross = segment_segment(
            v(-1.0, 0.0, 2.0),
            v(1.0, 0.0, 2.0),
            v(0.0, -1.0, 2.0),
            v(0.0, 1.0, 2.0),
        );
        assert!(cross.distance < 1e-12);
        assert!(cross.first.distance(v(0.0, 0.0, 2.0)) < 1e-12);
        let skew = segment_segment(
            v(-1.0, 0.0, 2.0),
            v(1.0, 0.0, 2.0),
            v(0.0, -1.0, 5.0),
            v(0.0, 1.0, 5.0),
        );
        assert!((skew.distance - 3.0).abs() < 1e-12);
        assert!(skew.second.distance(v(0.0, 0.0, 5.0)) < 1e-12);
    }

    #[test]
    fn parallel_legs_apart_end_to_end_are_as_far_as_their_nearest_ends() {
        let d = segment_segment(
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(4.0, 4.0, 0.0),
            v(5.0, 4.0, 0.0),
        );
        assert!((d.distance - 5.0).abs() < 1e-12, "{d:?}");
    }
}
