//! Fences: polygons of the local plane a drone must stay inside.
//!
//! A fence bounds the horizontal position only (ceiling and floor are plain
//! heights). It may be concave, so a leg between two inside waypoints can
//! still leave it: [`Fence::exit`] judges the whole leg, not its ends.

use std::fmt;

use crate::{LocalFrame, Vec3, Wgs84};

/// A simple polygon of the local plane, vertices `[x north, y east]` in
/// metres, in either winding. Its boundary counts as inside.
#[derive(Debug, Clone, PartialEq)]
pub struct Fence {
    vertices: Vec<[f64; 2]>,
}

/// Why a list of points is not a fence.
#[derive(Debug, Clone, PartialEq)]
pub enum FenceError {
    TooFewVertices(usize),
    NotFinite(usize),
    NoArea,
}

impl fmt::Display for FenceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FenceError::TooFewVertices(n) => {
                write!(f, "a fence needs at least 3 vertices, this one has {n}")
            }
            FenceError::NotFinite(i) => write!(f, "vertex {} of the fence is not finite", i + 1),
            FenceError::NoArea => write!(
                f,
                "the fence encloses no area (its vertices are on one line)"
            ),
        }
    }
}

impl std::error::Error for FenceError {}

/// How far from an edge a point still counts as on it, in metres: far below
/// any accuracy a drone has, far above rounding in a frame of kilometres.
const ON_EDGE: f64 = 1e-9;

impl Fence {
    /// The polygon through `vertices`, in order; the last joins the first.
    /// A repeated closing vertex (as GeoJSON writes rings) is dropped.
    pub fn new(mut vertices: Vec<[f64; 2]>) -> Result<Fence, FenceError> {
        if vertices.len() > 1 && vertices.first() == vertices.last() {
            vertices.pop();
        }
        if vertices.len() < 3 {
            return Err(FenceError::TooFewVertices(vertices.len()));
        }
        if let Some(i) = vertices
            .iter()
            .position(|v| !(v[0].is_finite() && v[1].is_finite()))
        {
            return Err(FenceError::NotFinite(i));
        }
        let fence = Fence { vertices };
        if fence.area() <= 0.0 {
            return Err(FenceError::NoArea);
        }
        Ok(fence)
    }

    /// The fence through points on the earth, in the fleet frame `frame`.
    pub fn from_wgs84(points: &[Wgs84], frame: &LocalFrame) -> Result<Fence, FenceError> {
        Fence::new(
            points
                .iter()
                .map(|p| {
                    let l = frame.to_local(*p);
                    [l.x, l.y]
                })
                .collect(),
        )
    }

    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.vertices
    }

    /// The enclosed area in square metres.
    pub fn area(&self) -> f64 {
        let twice: f64 = self.edges().map(|(a, b)| a[0] * b[1] - b[0] * a[1]).sum();
        twice.abs() / 2.0
    }

    /// The edges, each from one vertex to the next.
    pub fn edges(&self) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        let n = self.vertices.len();
        (0..n).map(move |i| (self.vertices[i], self.vertices[(i + 1) % n]))
    }

    /// Whether `p` is inside or on the fence (its height does not count).
    pub fn contains(&self, p: Vec3) -> bool {
        let q = [p.x, p.y];
        if self.edges().any(|(a, b)| on_segment(q, a, b)) {
            return true;
        }
        // Even-odd rule: a ray towards +y crosses the boundary an odd
        // number of times from inside.
        let mut inside = false;
        for (a, b) in self.edges() {
            if (a[0] > q[0]) != (b[0] > q[0]) {
                let y = a[1] + (q[0] - a[0]) / (b[0] - a[0]) * (b[1] - a[1]);
                if q[1] < y {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// Where the leg from `a` to `b` first leaves the fence: `a` if it
    /// starts outside, else the last point of the leg still on the fence
    /// before it goes out; `None` if every point of the leg is inside.
    pub fn exit(&self, a: Vec3, b: Vec3) -> Option<Vec3> {
        if !self.contains(a) {
            return Some(a);
        }
        let at = |t: f64| a + (b - a) * t;
        // Between two consecutive places where the leg meets the boundary,
        // it is wholly inside or wholly outside: its midpoint tells which.
        let mut ts = vec![0.0, 1.0];
        for (p, q) in self.edges() {
            crossings([a.x, a.y], [b.x, b.y], p, q, &mut ts);
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup();
        for w in ts.windows(2) {
            if !self.contains(at((w[0] + w[1]) / 2.0)) {
                return Some(at(w[0]));
            }
        }
        (!self.contains(b)).then_some(b)
    }
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// Whether `q` lies on the segment `a`-`b`, within [`ON_EDGE`].
fn on_segment(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    let d = sub(b, a);
    let len2 = dot(d, d);
    let t = if len2 > 0.0 {
        (dot(sub(q, a), d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let foot = [a[0] + d[0] * t, a[1] + d[1] * t];
    let off = sub(q, foot);
    dot(off, off).sqrt() <= ON_EDGE
}

/// Adds to `ts` the parameters along `a`-`b` (0 at `a`, 1 at `b`) where it
/// meets the edge `p`-`q`: one where they cross, both ends of the shared
/// part where they lie on one line.
fn crossings(a: [f64; 2], b: [f64; 2], p: [f64; 2], q: [f64; 2], ts: &mut Vec<f64>) {
    let r = sub(b, a);
    let s = sub(q, p);
    let rr = dot(r, r);
    if rr == 0.0 {
        return;
    }
    let denom = cross(r, s);
    let ap = sub(p, a);
    let keep = |t: f64, ts: &mut Vec<f64>| {
        if (0.0..=1.0).contains(&t) {
            ts.push(t);
        }
    };
    if denom.abs() <= 1e-12 * rr.sqrt() * dot(s, s).sqrt() {
        // Parallel: only a collinear edge touches, along a stretch.
        if cross(ap, r).abs() <= ON_EDGE * rr.sqrt() {
            keep(dot(ap, r) / rr, ts);
            keep(dot(sub(q, a), r) / rr, ts);
        }
        return;
    }
    let t = cross(ap, s) / denom;
    let u = cross(ap, r) / denom;
    if (-1e-12..=1.0 + 1e-12).contains(&u) {
        keep(t.clamp(0.0, 1.0), ts);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vec3 {
        Vec3::new(x, y, 10.0)
    }

    /// An L: the square 0..10 x 0..10 without its corner 5..10 x 5..10.
    fn ell() -> Fence {
        Fence::new(vec![
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 5.0],
            [5.0, 5.0],
            [5.0, 10.0],
            [0.0, 10.0],
        ])
        .unwrap()
    }

    #[test]
    fn points_inside_on_and_outside_the_boundary() {
        let f = ell();
        assert!(f.contains(v(2.0, 2.0)));
        assert!(f.contains(v(8.0, 2.0)));
        assert!(f.contains(v(0.0, 0.0)), "a corner is on the fence");
        assert!(f.contains(v(5.0, 7.0)), "an edge is on the fence");
        assert!(!f.contains(v(8.0, 8.0)), "the notch is outside");
        assert!(!f.contains(v(-1.0, 2.0)));
        assert!((f.area() - 75.0).abs() < 1e-12);
    }

    #[test]
    fn a_diagonal_between_two_inside_waypoints_can_cut_a_concave_fence() {
        let f = ell();
        let (a, b) = (v(9.0, 4.0), v(4.0, 9.0));
        assert!(f.contains(a) && f.contains(b));
        let out = f.exit(a, b).expect("the diagonal crosses the notch");
        assert!(out.distance(v(8.0, 5.0)) < 1e-9, "{out}");
        // Around the notch, through the inner corner, stays inside.
        assert_eq!(f.exit(a, v(5.0, 5.0)), None);
        assert_eq!(f.exit(v(5.0, 5.0), b), None);
        // Along an edge stays inside.
        assert_eq!(f.exit(v(0.0, 0.0), v(10.0, 0.0)), None);
    }

    #[test]
    fn a_leg_starting_outside_leaves_at_its_start_and_a_vertical_one_where_it_stands() {
        let f = ell();
        assert_eq!(f.exit(v(-1.0, 0.0), v(2.0, 2.0)), Some(v(-1.0, 0.0)));
        assert_eq!(f.exit(v(2.0, 2.0), Vec3::new(2.0, 2.0, 50.0)), None);
        let out = f.exit(v(2.0, 2.0), v(2.0, 20.0)).unwrap();
        assert!((out.y - 10.0).abs() < 1e-9, "{out}");
    }

    #[test]
    fn degenerate_fences_are_refused() {
        assert_eq!(
            Fence::new(vec![[0.0, 0.0], [1.0, 0.0]]),
            Err(FenceError::TooFewVertices(2))
        );
        assert_eq!(
            Fence::new(vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
            Err(FenceError::NoArea)
        );
        assert_eq!(
            Fence::new(vec![[0.0, 0.0], [1.0, f64::NAN], [2.0, 1.0]]),
            Err(FenceError::NotFinite(1))
        );
        // A closed ring as GeoJSON writes it is one vertex shorter.
        let ring = Fence::new(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]]).unwrap();
        assert_eq!(ring.vertices().len(), 3);
    }
}
