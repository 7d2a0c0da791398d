//! Points on the earth as GPS and autopilots give them.

use serde::{Deserialize, Serialize};

/// A point on the earth: degrees of latitude and longitude (WGS84), and
/// metres of altitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wgs84 {
    pub lat: f64,
    pub lon: f64,
    pub alt: f64,
}

impl Wgs84 {
    pub const fn new(lat: f64, lon: f64, alt: f64) -> Self {
        Self { lat, lon, alt }
    }

    /// The same point if its numbers are finite and its latitude and
    /// longitude in range; otherwise why not, in a pilot's words.
    pub fn validated(self) -> Result<Self, String> {
        let Wgs84 { lat, lon, alt } = self;
        if !(lat.is_finite() && lon.is_finite() && alt.is_finite()) {
            return Err(format!("{lat}, {lon}, {alt} is not three finite numbers"));
        }
        if !(-90.0..=90.0).contains(&lat) {
            return Err(format!("latitude {lat} is not between -90 and 90 degrees"));
        }
        if !(-180.0..=180.0).contains(&lon) {
            return Err(format!(
                "longitude {lon} is not between -180 and 180 degrees"
            ));
        }
        Ok(self)
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
        Wgs84::new(lat, lon, alt).validated()
    }

    /// From MAVLink's integer encoding: degrees times 1e7, millimetres.
    pub fn from_e7(lat: i32, lon: i32, alt_mm: i32) -> Self {
        Wgs84::new(
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_integer_encoding_round_trips() {
        let p = Wgs84::new(-35.363_261_6, 149.165_230_2, 584.09);
        let (lat, lon, alt) = p.to_e7();
        assert_eq!((lat, lon, alt), (-353_632_616, 1_491_652_302, 584_090));
        assert_eq!(Wgs84::from_e7(lat, lon, alt).to_e7(), (lat, lon, alt));
    }

    #[test]
    fn home_reads_from_lat_lon_alt_text() {
        assert_eq!(
            Wgs84::parse("-35.3632621, 149.1652374, 584"),
            Ok(Wgs84::new(-35.3632621, 149.1652374, 584.0))
        );
        assert!(Wgs84::parse("1,2").unwrap_err().contains("LAT,LON,ALT"));
        assert!(Wgs84::parse("91,0,0").unwrap_err().contains("latitude"));
        assert!(Wgs84::parse("0,181,0").unwrap_err().contains("longitude"));
        assert!(Wgs84::parse("0,x,0").unwrap_err().contains("`x`"));
        assert!(Wgs84::new(f64::NAN, 0.0, 0.0).validated().is_err());
    }
}
