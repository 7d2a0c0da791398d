//! Frames: the mission's local frame against MAVLink's local NED frame, and
//! geodetic positions against local offsets.
//!
//! The mission frame has X north, Y east, Z up; MAVLink's `MAV_FRAME_LOCAL_NED`
//! has north, east, down. So N = X, E = Y, D = -Z. Getting the sign of Z
//! wrong sends a copter into the ground, which is why the conversion lives
//! in one place with its own tests.
//!
//! Geodetic offsets use the flat-earth approximation ArduPilot itself uses
//! (`Location::get_distance_NE`): metres per degree of latitude from the
//! WGS84 equatorial radius, longitude scaled by the cosine of latitude.
//! Within a few kilometres it agrees with the autopilot to the centimetre,
//! which is what matters: positions the adapter computes and positions the
//! autopilot reports must agree.

use crate::api::Vec3;

/// Metres per degree of latitude (ArduPilot's `LATLON_TO_M` times 1e7).
pub const METRES_PER_DEGREE: f64 = 111_318.845_021_450_34;

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

/// A point on the earth: degrees, and metres above mean sea level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodetic {
    pub lat: f64,
    pub lon: f64,
    pub alt: f64,
}

impl Geodetic {
    pub const fn new(lat: f64, lon: f64, alt: f64) -> Self {
        Self { lat, lon, alt }
    }

    /// Reads `LAT,LON,ALT` (degrees, degrees, metres), as `--home` takes it.
    pub fn parse(text: &str) -> Result<Self, String> {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        if parts.len() != 3 {
            return Err(format!(
                "`{text}` is not LAT,LON,ALT (three numbers separated by commas)"
            ));
        }
        let mut v = [0.0; 3];
        for (slot, part) in v.iter_mut().zip(&parts) {
            *slot = part
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`{part}` in `{text}` is not a number"))?;
        }
        let [lat, lon, alt] = v;
        if !(-90.0..=90.0).contains(&lat) {
            return Err(format!("latitude {lat} is not between -90 and 90 degrees"));
        }
        if !(-180.0..=180.0).contains(&lon) {
            return Err(format!(
                "longitude {lon} is not between -180 and 180 degrees"
            ));
        }
        Ok(Geodetic::new(lat, lon, alt))
    }

    /// From MAVLink's integer encoding: degrees times 1e7, millimetres.
    pub fn from_e7(lat: i32, lon: i32, alt_mm: i32) -> Self {
        Geodetic::new(
            f64::from(lat) * 1e-7,
            f64::from(lon) * 1e-7,
            f64::from(alt_mm) * 1e-3,
        )
    }

    /// To MAVLink's integer encoding: degrees times 1e7, millimetres.
    pub fn to_e7(self) -> (i32, i32, i32) {
        (
            (self.lat * 1e7).round() as i32,
            (self.lon * 1e7).round() as i32,
            (self.alt * 1e3).round() as i32,
        )
    }

    /// Where `other` lies from `self`, in metres north, east and down.
    pub fn ned_to(self, other: Geodetic) -> Ned {
        let north = (other.lat - self.lat) * METRES_PER_DEGREE;
        let east = wrap_degrees(other.lon - self.lon) * METRES_PER_DEGREE * lon_scale(self.lat);
        Ned::new(north, east, self.alt - other.alt)
    }

    /// The point `offset` away from `self`.
    pub fn offset(self, offset: Ned) -> Geodetic {
        let lat = self.lat + offset.north / METRES_PER_DEGREE;
        let lon = wrap_degrees(self.lon + offset.east / (METRES_PER_DEGREE * lon_scale(self.lat)));
        Geodetic::new(lat, lon, self.alt - offset.down)
    }
}

/// How much shorter a degree of longitude is than one of latitude, as
/// ArduPilot computes it (never below 0.01, so the poles do not divide by 0).
fn lon_scale(lat: f64) -> f64 {
    lat.to_radians().cos().max(0.01)
}

fn wrap_degrees(d: f64) -> f64 {
    let mut d = d % 360.0;
    if d > 180.0 {
        d -= 360.0;
    } else if d < -180.0 {
        d += 360.0;
    }
    d
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

    #[test]
    fn a_geodetic_offset_and_its_inverse_agree_to_the_millimetre() {
        let home = Geodetic::new(46.6139, 14.2650, 446.0);
        let off = Ned::new(123.4, -56.7, -8.9);
        let p = home.offset(off);
        let back = home.ned_to(p);
        assert!((back.north - off.north).abs() < 1e-3);
        assert!((back.east - off.east).abs() < 1e-3);
        assert!((back.down - off.down).abs() < 1e-9);
        assert!((p.alt - 454.9).abs() < 1e-9);
    }

    #[test]
    fn a_degree_of_latitude_is_about_111_km() {
        let a = Geodetic::new(0.0, 0.0, 0.0);
        let b = Geodetic::new(1.0, 0.0, 0.0);
        assert!((a.ned_to(b).north - 111_318.845).abs() < 0.01);
        // A degree of longitude at 60 degrees north is half as long.
        let c = Geodetic::new(60.0, 0.0, 0.0);
        let d = Geodetic::new(60.0, 1.0, 0.0);
        assert!((c.ned_to(d).east - 55_659.42).abs() < 0.1);
    }

    #[test]
    fn offsets_across_the_antimeridian_take_the_short_way() {
        let a = Geodetic::new(0.0, 179.9999, 0.0);
        let b = Geodetic::new(0.0, -179.9999, 0.0);
        let e = a.ned_to(b).east;
        assert!(e > 0.0 && e < 30.0, "{e}");
    }

    #[test]
    fn the_integer_encoding_round_trips() {
        let p = Geodetic::new(-35.363_261_6, 149.165_230_2, 584.09);
        let (lat, lon, alt) = p.to_e7();
        assert_eq!((lat, lon, alt), (-353_632_616, 1_491_652_302, 584_090));
        assert_eq!(Geodetic::from_e7(lat, lon, alt).to_e7(), (lat, lon, alt));
    }

    #[test]
    fn home_reads_from_lat_lon_alt_text() {
        assert_eq!(
            Geodetic::parse("-35.3632621, 149.1652374, 584"),
            Ok(Geodetic::new(-35.3632621, 149.1652374, 584.0))
        );
        assert!(Geodetic::parse("1,2").unwrap_err().contains("LAT,LON,ALT"));
        assert!(Geodetic::parse("91,0,0").unwrap_err().contains("latitude"));
        assert!(Geodetic::parse("0,x,0").unwrap_err().contains("`x`"));
    }
}
