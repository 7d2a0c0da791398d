//! Where a drone can be: a point, the straight leg it flies, or (after a
//! cancelled leg, which stops somewhere along it) a box that holds every
//! place it may have stopped at.
//!
//! Shapes are in the drone's own frame (metres from its home, Z up), as the
//! mission's arguments are; [`Shape::at`] moves them into the fleet frame.

use eamos_geo::{point_segment, segment_segment, Airspace, Breach, Vec3};
use eamos_profile::ActionSig;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shape {
    /// The segment from the first point to the second (a point when both
    /// are the same).
    Leg(Vec3, Vec3),
    /// Somewhere in the axis-aligned box from `min` to `max`.
    Box(Vec3, Vec3),
}

/// How close two shapes come, and the two points where they do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Closest {
    pub distance: f64,
    pub first: Vec3,
    pub second: Vec3,
}

impl Shape {
    pub(crate) fn point(p: Vec3) -> Shape {
        Shape::Leg(p, p)
    }

    /// The shape moved by `offset` (a home, into the fleet frame).
    pub(crate) fn at(self, offset: Vec3) -> Shape {
        match self {
            Shape::Leg(a, b) => Shape::Leg(a + offset, b + offset),
            Shape::Box(lo, hi) => Shape::Box(lo + offset, hi + offset),
        }
    }

    fn bounds(self) -> (Vec3, Vec3) {
        match self {
            Shape::Leg(a, b) => (min(a, b), max(a, b)),
            Shape::Box(lo, hi) => (lo, hi),
        }
    }

    /// A key that tells shapes apart to the millimetre, so that a loop
    /// that comes back to the same place adds nothing new.
    pub(crate) fn key(self) -> [i64; 7] {
        let mm = |v: f64| (v * 1000.0).round() as i64;
        let (kind, a, b) = match self {
            Shape::Leg(a, b) => (0, a, b),
            Shape::Box(a, b) => (1, a, b),
        };
        [kind, mm(a.x), mm(a.y), mm(a.z), mm(b.x), mm(b.y), mm(b.z)]
    }

    /// Where the drone rests once it has flown `action` from here, and the
    /// shape it sweeps on the way. `None` when the arguments do not fit
    /// the motion (the front end refuses such calls).
    pub(crate) fn fly(self, action: &ActionSig, args: &[f64]) -> Option<(Shape, Shape)> {
        action.motion.as_ref()?;
        let to = |p: Vec3| {
            action
                .target([p.x, p.y, p.z], args)
                .map(|[x, y, z]| Vec3::new(x, y, z))
        };
        match self {
            Shape::Leg(a, b) if a == b => {
                let end = to(a)?;
                Some((Shape::point(end), Shape::Leg(a, end)))
            }
            _ => {
                // Every motion moves or sets each coordinate on its own, so
                // the box's corners go where its corners go.
                let (lo, hi) = self.bounds();
                let (tlo, thi) = (to(lo)?, to(hi)?);
                let end = Shape::Box(min(tlo, thi), max(tlo, thi));
                Some((
                    end,
                    Shape::Box(min(lo, min(tlo, thi)), max(hi, max(tlo, thi))),
                ))
            }
        }
    }

    /// Where a drone may have stopped when this leg was cancelled.
    pub(crate) fn stopped_on(self) -> Shape {
        match self {
            Shape::Leg(a, b) if a == b => self,
            _ => {
                let (lo, hi) = self.bounds();
                Shape::Box(lo, hi)
            }
        }
    }

    /// The closest approach of two shapes, never farther than the truth.
    ///
    /// A leg is compared as the upright strip above and below its line seen
    /// from above, between its two ends' heights: a multirotor holds the
    /// line seen from above, but climbs and travels each at its own rate,
    /// so its height along the way is anywhere between the two (the
    /// simulator reaches the end of a diagonal climb up to 2.3 m off the
    /// straight segment). Two such strips are a line times an interval each,
    /// so their distance is the distance seen from above combined with the
    /// gap between the height intervals. Boxes are compared through their
    /// bounds.
    pub(crate) fn closest(self, other: Shape) -> Closest {
        match (self, other) {
            (Shape::Leg(a0, a1), Shape::Leg(b0, b1)) => {
                let flat = |v: Vec3| Vec3::new(v.x, v.y, 0.0);
                let (p, q) = if a0 == a1 {
                    let c = point_segment(flat(a0), flat(b0), flat(b1));
                    (c.first, c.second)
                } else {
                    let c = segment_segment(flat(a0), flat(a1), flat(b0), flat(b1));
                    (c.first, c.second)
                };
                let (za, zb) = closest_in(
                    (a0.z.min(a1.z), a0.z.max(a1.z)),
                    (b0.z.min(b1.z), b0.z.max(b1.z)),
                );
                let first = Vec3::new(p.x, p.y, za);
                let second = Vec3::new(q.x, q.y, zb);
                Closest {
                    distance: first.distance(second),
                    first,
                    second,
                }
            }
            _ => {
                let (alo, ahi) = self.bounds();
                let (blo, bhi) = other.bounds();
                // The closest points of two boxes, axis by axis.
                let (x0, x1) = closest_in((alo.x, ahi.x), (blo.x, bhi.x));
                let (y0, y1) = closest_in((alo.y, ahi.y), (blo.y, bhi.y));
                let (z0, z1) = closest_in((alo.z, ahi.z), (blo.z, bhi.z));
                let first = Vec3::new(x0, y0, z0);
                let second = Vec3::new(x1, y1, z1);
                Closest {
                    distance: first.distance(second),
                    first,
                    second,
                }
            }
        }
    }

    /// Where the shape, in the fleet frame with heights above home, leaves
    /// the airspace. A box is judged by its outline at its lowest and
    /// highest heights.
    pub(crate) fn breach(self, airspace: &Airspace) -> Option<Breach> {
        match self {
            Shape::Leg(a, b) => airspace.breach(a, b),
            Shape::Box(lo, hi) => {
                let corners = [
                    Vec3::new(lo.x, lo.y, lo.z),
                    Vec3::new(hi.x, lo.y, lo.z),
                    Vec3::new(hi.x, hi.y, lo.z),
                    Vec3::new(lo.x, hi.y, lo.z),
                ];
                let up = Vec3::new(0.0, 0.0, hi.z - lo.z);
                (0..4).find_map(|i| {
                    let (a, b) = (corners[i], corners[(i + 1) % 4]);
                    airspace
                        .breach(a, b)
                        .or_else(|| airspace.breach(a + up, b + up))
                })
            }
        }
    }

    /// The two ends of the shape (a box: its lowest and highest corners).
    pub(crate) fn ends(self) -> (Vec3, Vec3) {
        match self {
            Shape::Leg(a, b) => (a, b),
            Shape::Box(lo, hi) => (lo, hi),
        }
    }
}

/// The closest values of two intervals: equal where they overlap.
fn closest_in(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    if a.1 < b.0 {
        (a.1, b.0)
    } else if b.1 < a.0 {
        (a.0, b.1)
    } else {
        let m = a.0.max(b.0);
        (m, m)
    }
}

fn min(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(a.x.min(b.x), a.y.min(b.y), a.z.min(b.z))
}

fn max(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(a.x.max(b.x), a.y.max(b.y), a.z.max(b.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> eamos_profile::Profile {
        eamos_profile::builtin()
            .get("Quadcopter")
            .cloned()
            .expect("built-in quadcopter")
    }

    #[test]
    fn a_leg_flies_from_where_the_drone_is_to_where_the_motion_says() {
        let q = quad();
        let start = Shape::point(Vec3::new(1.0, 2.0, 5.0));
        let (end, leg) = start.fly(&q.actions["FlyByX"], &[3.0]).unwrap();
        assert_eq!(end, Shape::point(Vec3::new(4.0, 2.0, 5.0)));
        assert_eq!(
            leg,
            Shape::Leg(Vec3::new(1.0, 2.0, 5.0), Vec3::new(4.0, 2.0, 5.0))
        );
        let (down, _) = end.fly(&q.actions["Land"], &[]).unwrap();
        assert_eq!(down, Shape::point(Vec3::new(4.0, 2.0, 0.0)));
        assert!(start.fly(&q.actions["TakePhoto"], &[]).is_none());
    }

    #[test]
    fn a_drone_stopped_somewhere_on_a_leg_flies_on_as_a_box() {
        let q = quad();
        let stopped = Shape::Leg(Vec3::new(0.0, 0.0, 5.0), Vec3::new(10.0, 0.0, 5.0)).stopped_on();
        let (end, sweep) = stopped.fly(&q.actions["FlyByY"], &[4.0]).unwrap();
        assert_eq!(
            end,
            Shape::Box(Vec3::new(0.0, 4.0, 5.0), Vec3::new(10.0, 4.0, 5.0))
        );
        assert_eq!(
            sweep,
            Shape::Box(Vec3::new(0.0, 0.0, 5.0), Vec3::new(10.0, 4.0, 5.0))
        );
    }

    #[test]
    fn a_climbing_leg_may_be_at_any_of_its_heights_anywhere_along_it() {
        // Climbing from 2 to 20 m while flying 16 m north: above the
        // spot 6.6 m off its straight segment at 5 m, it may be at 5 m.
        let climb = Shape::Leg(Vec3::new(0.0, 0.0, 2.0), Vec3::new(16.0, 0.0, 20.0));
        let parked = Shape::point(Vec3::new(16.0, 0.0, 5.0));
        let c = climb.closest(parked);
        assert!(c.distance < 1e-9, "{c:?}");
        // Seen from above it stays on its line.
        let beside = Shape::point(Vec3::new(8.0, 3.0, 11.0));
        assert!((climb.closest(beside).distance - 3.0).abs() < 1e-9);
    }

    #[test]
    fn crossing_legs_meet_and_parallel_ones_keep_their_distance() {
        let a = Shape::Leg(Vec3::new(0.0, 0.0, 5.0), Vec3::new(10.0, 0.0, 5.0));
        let b = Shape::Leg(Vec3::new(5.0, -5.0, 5.0), Vec3::new(5.0, 5.0, 5.0));
        let c = a.closest(b);
        assert!(c.distance < 1e-9 && (c.first.x - 5.0).abs() < 1e-9, "{c:?}");
        let high = Shape::Leg(Vec3::new(0.0, 0.0, 8.0), Vec3::new(10.0, 0.0, 8.0));
        assert!((a.closest(high).distance - 3.0).abs() < 1e-9);
        let boxed = Shape::Box(Vec3::new(0.0, 2.0, 0.0), Vec3::new(1.0, 3.0, 5.0));
        assert!((a.closest(boxed).distance - 2.0).abs() < 1e-9);
    }
}
