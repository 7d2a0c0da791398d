//! A fence drawn on a map: the one polygon of a GeoJSON document.
//!
//! Map tools save an area as a bare Polygon, as a Feature holding one, or
//! as a FeatureCollection (often with a marker or two beside the area).
//! All three are read; whatever else would have to be guessed at (two
//! areas, a MultiPolygon, a polygon with holes, which are no-fly zones this
//! fleet file cannot express) is refused rather than half read.

use geojson::{GeoJson, Geometry, GeometryValue, PolygonType};
use serde::Deserialize;
use serde_json::Value;

use eamos_geo::Wgs84;

/// The outer ring of the one polygon of `doc`, its points at altitude
/// `alt` (the fence bounds positions on the ground plane, and GeoJSON's
/// optional third coordinate is a height nobody draws a fence by); or why
/// `doc` is not one polygon.
pub(super) fn fence_ring(doc: &Value, alt: f64) -> Result<Vec<Wgs84>, String> {
    let doc = GeoJson::deserialize(doc).map_err(|e| format!("not GeoJSON: {e}"))?;
    let polygon = match &doc {
        GeoJson::Geometry(g) => polygon(g)?,
        GeoJson::Feature(f) => match &f.geometry {
            Some(g) => polygon(g)?,
            None => return Err("its Feature has no geometry".to_string()),
        },
        GeoJson::FeatureCollection(c) => {
            let areas: Vec<&Geometry> = c
                .features
                .iter()
                .filter_map(|f| f.geometry.as_ref())
                .filter(|g| {
                    matches!(
                        g.value,
                        GeometryValue::Polygon { .. } | GeometryValue::MultiPolygon { .. }
                    )
                })
                .collect();
            match areas[..] {
                [one] => polygon(one)?,
                [] => return Err("its FeatureCollection holds no Polygon".to_string()),
                _ => {
                    return Err(format!(
                        "its FeatureCollection holds {} areas; a fence is one Polygon",
                        areas.len()
                    ))
                }
            }
        }
    };
    let [outer] = &polygon[..] else {
        return Err(match polygon.len() {
            0 => "its Polygon has no ring".to_string(),
            2 => "its Polygon has a hole; a fence is one ring (holes, no-fly zones inside it, are not supported)".to_string(),
            n => format!(
                "its Polygon has {} holes; a fence is one ring (holes, no-fly zones inside it, are not supported)",
                n - 1
            ),
        });
    };
    outer
        .iter()
        .enumerate()
        .map(|(i, p)| match p.as_slice() {
            [lon, lat, ..] => Wgs84::new(*lat, *lon, alt)
                .validated()
                .map_err(|e| format!("vertex {} ([lon, lat]): {e}", i + 1)),
            _ => Err(format!("vertex {} has fewer than two coordinates", i + 1)),
        })
        .collect()
}

fn polygon(g: &Geometry) -> Result<&PolygonType, String> {
    match &g.value {
        GeometryValue::Polygon { coordinates } => Ok(coordinates),
        other => Err(format!(
            "it is a {}, not a Polygon (a fence is one Polygon)",
            other.type_name()
        )),
    }
}
