//! Where the fleet is on the earth and where it may fly: the fleet file's
//! `origin` and its `[airspace]` table.
//!
//! ```toml
//! origin = { lat = 46.6139, lon = 14.2650 }  # the fleet frame's 0 (alt defaults to 0)
//!
//! [airspace]
//! fence = [[-5.0, -5.0], [50.0, -5.0], [50.0, 50.0], [-5.0, 50.0]]  # [x north, y east], metres
//! # fence_geojson = "site.geojson"   # or a polygon drawn on a map (needs `origin`)
//! ceiling = 120.0                    # metres above home (none by default)
//! floor = 0.0                        # metres above home (0 by default)
//! separation = 2.0                   # least distance between two drones, metres
//! ```
//!
//! Both are read into the fleet frame once, here, when the file is read:
//! the checker and the adapters see local metres only. A GeoJSON path is
//! relative to the fleet file. A home given in WGS84 lands at the height of
//! its `alt` above the origin's: give both altitudes in one datum, or
//! neither (both 0).

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde_json::Value;
use toml::Spanned;

use eamos_geo::{Airspace, Fence, LocalFrame, Wgs84};

use super::geojson::fence_ring;

/// `origin = { lat = .., lon = .. }`, with an optional `alt` (metres,
/// default 0): the point on the earth that is the fleet frame's 0.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Origin {
    lat: f64,
    lon: f64,
    #[serde(default)]
    alt: f64,
}

/// `[airspace]` as written; each value keeps its place in the file for
/// the errors found after parsing.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AirspaceTable {
    #[serde(default)]
    fence: Option<Spanned<Vec<[f64; 2]>>>,
    #[serde(default)]
    fence_geojson: Option<Spanned<PathBuf>>,
    #[serde(default)]
    ceiling: Option<Spanned<f64>>,
    #[serde(default)]
    floor: Option<Spanned<f64>>,
    #[serde(default)]
    separation: Option<Spanned<f64>>,
}

/// The origin and the airspace in the fleet frame.
pub(super) struct Resolved {
    pub origin: Option<Wgs84>,
    pub airspace: Airspace,
    /// The GeoJSON document the fence was read from, for the fleet digest.
    pub geojson: Option<Value>,
}

/// What is wrong, and where in the fleet file (a byte range of its text).
pub(super) struct Problem {
    pub span: Range<usize>,
    pub what: String,
}

fn problem(span: Range<usize>, what: impl Into<String>) -> Problem {
    Problem {
        span,
        what: what.into(),
    }
}

/// Checks the origin and the airspace table and brings the fence into the
/// fleet frame; `base` is the fleet file's directory.
pub(super) fn resolve(
    origin: Option<&Spanned<Origin>>,
    table: Option<&AirspaceTable>,
    base: &Path,
) -> Result<Resolved, Problem> {
    let origin = match origin {
        Some(o) => {
            let Origin { lat, lon, alt } = *o.get_ref();
            let p = Wgs84::new(lat, lon, alt)
                .validated()
                .map_err(|e| problem(o.span(), format!("`origin`: {e}")))?;
            Some(p)
        }
        None => None,
    };
    let mut resolved = Resolved {
        origin,
        airspace: Airspace::default(),
        geojson: None,
    };
    let Some(t) = table else {
        return Ok(resolved);
    };
    let space = &mut resolved.airspace;
    match (&t.fence, &t.fence_geojson) {
        (Some(_), Some(g)) => {
            return Err(problem(
                g.span(),
                "the fence is either `fence` or `fence_geojson`, not both",
            ))
        }
        (Some(f), None) => {
            let fence = Fence::new(f.get_ref().clone())
                .map_err(|e| problem(f.span(), format!("`fence`: {e}")))?;
            space.fence = Some(fence);
        }
        (None, Some(g)) => {
            let frame = origin.map(LocalFrame::new).ok_or_else(|| {
                problem(
                    g.span(),
                    "`fence_geojson` is drawn in latitude and longitude: it needs the fleet's `origin = { lat = .., lon = .. }` to place it",
                )
            })?;
            let path = base.join(g.get_ref());
            let (doc, fence) = read_geojson(&path, &frame).map_err(|e| {
                problem(g.span(), format!("`fence_geojson` {}: {e}", path.display()))
            })?;
            space.fence = Some(fence);
            resolved.geojson = Some(doc);
        }
        (None, None) => {}
    }
    if let Some(f) = &t.floor {
        space.floor = finite(f, "floor")?;
    }
    if let Some(c) = &t.ceiling {
        let ceiling = finite(c, "ceiling")?;
        if ceiling <= space.floor {
            return Err(problem(
                c.span(),
                format!(
                    "the `ceiling` ({ceiling} m) must be above the floor ({} m)",
                    space.floor
                ),
            ));
        }
        space.ceiling = Some(ceiling);
    }
    if let Some(s) = &t.separation {
        let separation = finite(s, "separation")?;
        if separation < 0.0 {
            return Err(problem(
                s.span(),
                format!("`separation` is a distance, 0 m or more, not {separation} m"),
            ));
        }
        space.separation = separation;
    }
    Ok(resolved)
}

fn finite(v: &Spanned<f64>, key: &str) -> Result<f64, Problem> {
    let x = *v.get_ref();
    if x.is_finite() {
        Ok(x)
    } else {
        Err(problem(
            v.span(),
            format!("`{key}` must be a finite number of metres, not {x}"),
        ))
    }
}

/// The GeoJSON document at `path` and its fence in `frame`.
fn read_geojson(path: &Path, frame: &LocalFrame) -> Result<(Value, Fence), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot be read: {e}"))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| format!("not JSON: {e}"))?;
    let ring = fence_ring(&doc, frame.origin().alt)?;
    let fence = Fence::from_wgs84(&ring, frame).map_err(|e| e.to_string())?;
    Ok((doc, fence))
}

#[cfg(test)]
mod tests;
