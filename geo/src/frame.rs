//! The mission's local frame, anchored at a WGS84 origin.
//!
//! A fleet flies in one local frame: X north, Y east, Z up, metres from an
//! origin on the earth. Homes given in WGS84, fences drawn on a map and the
//! positions an autopilot's GPS reports all come into that frame here, and
//! only here. The conversion is the exact one on the WGS84 ellipsoid (through
//! earth-centred coordinates onto the plane tangent at the origin, by the
//! `map_3d` crate), not a flat-earth approximation: Z is the height above
//! that tangent plane, so a point on the ground 1 km away lies about 8 cm
//! below it, as the earth curves away.

use crate::{Vec3, Wgs84};

/// A local frame (X north, Y east, Z up) whose origin is a point on earth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    origin: Wgs84,
}

impl LocalFrame {
    /// The frame whose origin is `origin`.
    pub const fn new(origin: Wgs84) -> Self {
        Self { origin }
    }

    pub fn origin(&self) -> Wgs84 {
        self.origin
    }

    /// Where `point` lies in this frame, in metres.
    pub fn to_local(&self, point: Wgs84) -> Vec3 {
        let o = self.origin;
        let (n, e, d) = map_3d::geodetic2ned(
            point.lat.to_radians(),
            point.lon.to_radians(),
            point.alt,
            o.lat.to_radians(),
            o.lon.to_radians(),
            o.alt,
            map_3d::Ellipsoid::WGS84,
        );
        Vec3::new(n, e, -d)
    }

    /// The point on earth at `local` in this frame.
    pub fn to_wgs84(&self, local: Vec3) -> Wgs84 {
        let o = self.origin;
        let (lat, lon, alt) = map_3d::ned2geodetic(
            local.x,
            local.y,
            -local.z,
            o.lat.to_radians(),
            o.lon.to_radians(),
            o.alt,
            map_3d::Ellipsoid::WGS84,
        );
        Wgs84::new(lat.to_degrees(), lon.to_degrees(), alt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KLAGENFURT: Wgs84 = Wgs84::new(46.6139, 14.2650, 446.0);

    #[test]
    fn the_origin_is_the_frame_s_zero() {
        let f = LocalFrame::new(KLAGENFURT);
        assert!(f.to_local(KLAGENFURT).norm() < 1e-6);
        let o = f.to_wgs84(Vec3::ZERO);
        assert!((o.lat - KLAGENFURT.lat).abs() < 1e-10);
        assert!((o.lon - KLAGENFURT.lon).abs() < 1e-10);
        assert!((o.alt - KLAGENFURT.alt).abs() < 1e-6);
    }

    #[test]
    fn degrees_have_the_lengths_of_the_survey_tables() {
        // A degree of latitude at the equator is 110 574 m of meridian; one
        // of longitude at 60 degrees north is 55 800 m. A thousandth of each:
        let equator = LocalFrame::new(Wgs84::new(0.0, 0.0, 0.0));
        let n = equator.to_local(Wgs84::new(0.001, 0.0, 0.0));
        assert!((n.x - 110.574).abs() < 0.01, "{n}");
        assert!(n.y.abs() < 1e-6, "{n}");
        let sixty = LocalFrame::new(Wgs84::new(60.0, 0.0, 0.0));
        let e = sixty.to_local(Wgs84::new(60.0, 0.001, 0.0));
        assert!((e.y - 55.800).abs() < 0.01, "{e}");
    }

    #[test]
    fn north_is_x_east_is_y_and_up_is_z() {
        let f = LocalFrame::new(KLAGENFURT);
        let p = f.to_local(Wgs84::new(46.6140, 14.2651, 456.0));
        assert!(p.x > 10.0 && p.y > 7.0 && (p.z - 10.0).abs() < 0.01, "{p}");
    }

    #[test]
    fn offsets_across_the_antimeridian_take_the_short_way() {
        let f = LocalFrame::new(Wgs84::new(0.0, 179.9999, 0.0));
        let e = f.to_local(Wgs84::new(0.0, -179.9999, 0.0)).y;
        assert!(e > 0.0 && e < 30.0, "{e}");
        let back = f.to_wgs84(Vec3::new(0.0, e, 0.0));
        assert!((back.lon + 179.9999).abs() < 1e-9, "{back:?}");
    }
}
