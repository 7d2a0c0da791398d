//! Properties of the frames and of the geometry, over random inputs.

use eamos_geo::{point_segment, segment_segment, Fence, LocalFrame, Vec3, Wgs84};
use proptest::prelude::*;

fn origin() -> impl Strategy<Value = Wgs84> {
    // Up to 85 degrees of latitude: nobody flies a fleet at the pole.
    (-85.0..85.0f64, -180.0..180.0f64, -100.0..3000.0f64).prop_map(|(a, b, c)| Wgs84::new(a, b, c))
}

fn local(range: f64) -> impl Strategy<Value = Vec3> {
    (-range..range, -range..range, -range / 10.0..range / 10.0)
        .prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn point() -> impl Strategy<Value = Vec3> {
    local(100.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// A point of a fleet's frame (up to 10 km out) goes to WGS84 and back
    /// within a millimetre, anywhere on earth.
    #[test]
    fn local_to_wgs84_and_back_is_within_a_millimetre(o in origin(), p in local(10_000.0)) {
        let frame = LocalFrame::new(o);
        let back = frame.to_local(frame.to_wgs84(p));
        prop_assert!(back.distance(p) < 1e-3, "{p} came back as {back}");
    }

    /// And a point on earth near the origin comes back to the same place.
    #[test]
    fn wgs84_to_local_and_back_is_within_a_millimetre(o in origin(), d in (-0.05..0.05f64, -0.05..0.05f64, -50.0..50.0f64)) {
        let frame = LocalFrame::new(o);
        let p = Wgs84::new(o.lat + d.0, o.lon + d.1, o.alt + d.2);
        let there = frame.to_local(p);
        let q = frame.to_wgs84(there);
        prop_assert!(frame.to_local(q).distance(there) < 1e-3);
        prop_assert!((q.lat - p.lat).abs() < 1e-8 && (q.alt - p.alt).abs() < 1e-3, "{p:?} came back as {q:?}");
    }

    /// Lengths survive the frame: two points a few hundred metres apart
    /// are as far apart in the frame as along the straight line through the
    /// earth between them (no flat-earth scale error).
    #[test]
    fn the_frame_keeps_distances(o in origin(), a in local(500.0), b in local(500.0)) {
        let frame = LocalFrame::new(o);
        let (pa, pb) = (frame.to_wgs84(a), frame.to_wgs84(b));
        let other = LocalFrame::new(pa);
        let d = other.to_local(pb).norm();
        prop_assert!((d - a.distance(b)).abs() < 1e-3, "{d} against {}", a.distance(b));
    }

    #[test]
    fn segment_distance_is_symmetric(a0 in point(), a1 in point(), b0 in point(), b1 in point()) {
        let ab = segment_segment(a0, a1, b0, b1);
        let ba = segment_segment(b0, b1, a0, a1);
        prop_assert!((ab.distance - ba.distance).abs() < 1e-9, "{ab:?} {ba:?}");
        let reversed = segment_segment(a1, a0, b1, b0);
        prop_assert!((ab.distance - reversed.distance).abs() < 1e-9);
    }

    /// The closest approach is no farther than any pair of points of the two
    /// segments (their ends included), and it is a pair of such points.
    #[test]
    fn segment_distance_is_the_least_over_both_segments(
        a0 in point(), a1 in point(), b0 in point(), b1 in point(),
        s in 0.0..=1.0f64, t in 0.0..=1.0f64,
    ) {
        let ab = segment_segment(a0, a1, b0, b1);
        let eps = 1e-9;
        for (p, q) in [(a0, b0), (a0, b1), (a1, b0), (a1, b1)] {
            prop_assert!(ab.distance <= p.distance(q) + eps);
        }
        prop_assert!(ab.distance <= point_segment(a0, b0, b1).distance + eps);
        prop_assert!(ab.distance <= point_segment(b1, a0, a1).distance + eps);
        let (p, q) = (a0 + (a1 - a0) * s, b0 + (b1 - b0) * t);
        prop_assert!(ab.distance <= p.distance(q) + eps, "{ab:?} above {}", p.distance(q));
        prop_assert!((ab.first.distance(ab.second) - ab.distance).abs() < eps);
        prop_assert!(point_segment(ab.first, a0, a1).distance < 1e-6);
        prop_assert!(point_segment(ab.second, b0, b1).distance < 1e-6);
    }

    /// A point's distance to a segment is never above its distance to either
    /// end, and is the segment distance to a segment of length 0.
    #[test]
    fn point_distance_is_a_segment_distance(p in point(), a in point(), b in point()) {
        let d = point_segment(p, a, b);
        prop_assert!(d.distance <= p.distance(a) + 1e-9 && d.distance <= p.distance(b) + 1e-9);
        prop_assert!((segment_segment(p, p, a, b).distance - d.distance).abs() < 1e-9);
    }

    /// A leg between two points of a convex fence never leaves it; a leg to a
    /// point outside always does, at a point on the fence.
    #[test]
    fn a_leg_inside_a_convex_fence_stays_and_one_going_out_leaves(
        r in 5.0..100.0f64, n in 3usize..12, s in 0.0..=0.95f64, u in 0.0..=0.95f64,
        i in 0usize..12, j in 0usize..12, far in 1.1..3.0f64,
    ) {
        let corner = |k: usize| {
            let th = std::f64::consts::TAU * (k % n) as f64 / n as f64;
            [r * th.cos(), r * th.sin()]
        };
        let fence = Fence::new((0..n).map(corner).collect()).unwrap();
        let at = |k: usize, w: f64| { let c = corner(k); Vec3::new(c[0] * w, c[1] * w, 5.0) };
        let (a, b) = (at(i, s), at(j, u));
        prop_assert!(fence.contains(a) && fence.contains(b));
        prop_assert_eq!(fence.exit(a, b), None);
        let out = at(j, far);
        prop_assert!(!fence.contains(out));
        let exit = fence.exit(a, out).expect("leaves");
        prop_assert!(fence.contains(exit));
    }
}
