//! The origin, the airspace table and homes in WGS84, as a fleet file's
//! author meets them: what is read, and every error with its place.

use std::path::Path;

use eamos_geo::{Airspace, Fence, LocalFrame, Vec3, Wgs84, DEFAULT_SEPARATION};

use crate::file::{default_home, Fleet};

const ORIGIN: Wgs84 = Wgs84::new(46.6139, 14.2650, 0.0);

fn drones() -> Vec<String> {
    vec!["D1".into(), "D2".into(), "D3".into()]
}

fn parse(text: &str) -> Result<Fleet, String> {
    Fleet::parse(text, "f.toml", "M", &drones()).map_err(|e| e.to_string())
}

fn error(text: &str) -> String {
    parse(text).expect_err("the fleet file is refused")
}

#[test]
fn without_an_airspace_table_the_fleet_flies_the_default_airspace_from_the_default_homes() {
    let f = parse("[drones.D2]\nhome = { x = 5.0, y = 0.0, z = 0.0 }\n").unwrap();
    assert_eq!(f.airspace(), &Airspace::default());
    assert_eq!(f.airspace().separation, DEFAULT_SEPARATION);
    assert_eq!(f.origin(), None);
    assert_eq!(
        f.homes(&drones()),
        vec![default_home(0), Vec3::new(5.0, 0.0, 0.0), default_home(2)]
    );
    assert_eq!(Fleet::default().airspace(), &Airspace::default());
}

#[test]
fn a_fence_in_local_metres_a_ceiling_a_floor_and_a_separation_are_read() {
    let f = parse(
        "[airspace]\nfence = [[-5.0, -5.0], [50.0, -5.0], [50.0, 50.0], [-5.0, 50.0]]\nceiling = 120.0\nfloor = 2.0\nseparation = 2.0\n",
    )
    .unwrap();
    let fence = Fence::new(vec![[-5.0, -5.0], [50.0, -5.0], [50.0, 50.0], [-5.0, 50.0]]).unwrap();
    assert_eq!(
        f.airspace(),
        &Airspace {
            fence: Some(fence),
            ceiling: Some(120.0),
            floor: 2.0,
            separation: 2.0,
        }
    );
    // Every key is optional.
    let f = parse("[airspace]\nceiling = 30\n").unwrap();
    assert_eq!(f.airspace().fence, None);
    assert_eq!(f.airspace().ceiling, Some(30.0));
    assert_eq!(f.airspace().separation, DEFAULT_SEPARATION);
}

#[test]
fn a_home_in_wgs84_is_placed_in_the_fleet_frame_through_the_origin() {
    let there = LocalFrame::new(ORIGIN).to_wgs84(Vec3::new(12.0, -7.0, 0.0));
    let text = format!(
        "origin = {{ lat = {}, lon = {} }}\n[drones.D3]\nhome = {{ lat = {}, lon = {}, alt = {} }}\n[drones.D1]\nhome = {{ x = 1.0, y = 1.0, z = 0.0 }}\n",
        ORIGIN.lat, ORIGIN.lon, there.lat, there.lon, there.alt
    );
    let f = parse(&text).unwrap();
    assert_eq!(f.origin(), Some(ORIGIN));
    let homes = f.homes(&drones());
    assert_eq!(homes[0], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(homes[1], default_home(1));
    assert!(
        homes[2].distance(Vec3::new(12.0, -7.0, 0.0)) < 0.01,
        "{}",
        homes[2]
    );
    assert_eq!(f.home("D3", 2), homes[2]);
    assert_eq!(f.sim_spec("D3", 2).home, homes[2]);
}

#[test]
fn a_home_in_wgs84_without_an_origin_is_refused_at_its_drones_table() {
    let e = error("[drones.D1]\nadapter = \"sim\"\n\n[drones.D2]\nhome = { lat = 46.6, lon = 14.2, alt = 0.0 }\n");
    assert!(e.starts_with("f.toml:4:1: drone `D2`"), "{e}");
    assert!(e.contains("needs the fleet's `origin`"), "{e}");
    let e = error("origin = { lat = 46.6, lon = 14.2 }\n[drones.D1]\nhome = { lat = 95.0, lon = 14.2, alt = 0.0 }\n");
    assert!(
        e.starts_with("f.toml:2:1: drone `D1`") && e.contains("latitude 95"),
        "{e}"
    );
    let e = error("[drones.D1]\nhome = { x = nan, y = 0.0, z = 0.0 }\n");
    assert!(
        e.starts_with("f.toml:1:1: drone `D1`") && e.contains("not finite"),
        "{e}"
    );
}

#[test]
fn a_bad_origin_or_airspace_value_is_refused_at_its_line_and_column() {
    for (text, at, what) in [
        (
            "origin = { lat = 46.6, lon = 194.2 }\n",
            "f.toml:1:10:",
            "longitude 194.2",
        ),
        (
            "[airspace]\nfence = [[0.0, 0.0], [1.0, 1.0]]\n",
            "f.toml:2:9:",
            "at least 3 vertices",
        ),
        (
            "[airspace]\nfence = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]\n",
            "f.toml:2:9:",
            "encloses no area",
        ),
        (
            "[airspace]\nfence = [[0.0, 0.0], [1.0, 0.0], [1.0, inf]]\n",
            "f.toml:2:9:",
            "vertex 3 of the fence is not finite",
        ),
        (
            "[airspace]\nceiling = 10.0\nseparation = -1.0\n",
            "f.toml:3:14:",
            "0 m or more, not -1 m",
        ),
        (
            "[airspace]\nseparation = nan\n",
            "f.toml:2:14:",
            "`separation` must be a finite number",
        ),
        (
            "[airspace]\nfloor = 10.0\nceiling = 10.0\n",
            "f.toml:3:11:",
            "`ceiling` (10 m) must be above the floor (10 m)",
        ),
        (
            "[airspace]\nceiling = -3.0\n",
            "f.toml:2:11:",
            "must be above the floor (0 m)",
        ),
        (
            "[airspace]\nfloor = -inf\n",
            "f.toml:2:9:",
            "`floor` must be a finite number",
        ),
        (
            "[airspace]\nfence = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]\nfence_geojson = \"site.geojson\"\n",
            "f.toml:3:17:",
            "either `fence` or `fence_geojson`, not both",
        ),
        (
            "[airspace]\nfence_geojson = \"site.geojson\"\n",
            "f.toml:2:17:",
            "needs the fleet's `origin = { lat = .., lon = .. }`",
        ),
    ] {
        let e = error(text);
        assert!(e.starts_with(at) && e.contains(what), "{text}\n-> {e}");
    }
}

#[test]
fn a_misspelt_airspace_key_is_reported_with_its_line() {
    let e = error("[airspace]\nceiling = 10.0\nseperation = 2.0\n");
    assert!(e.contains("line 3") && e.contains("seperation"), "{e}");
    let e = error("origin = { lat = 46.6, lng = 14.2 }\n");
    assert!(e.contains("line 1") && e.contains("lng"), "{e}");
}

/// A fleet file with an origin and a GeoJSON fence `doc`, in a directory
/// of its own.
fn with_geojson(doc: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("maps")).unwrap();
    std::fs::write(dir.path().join("maps/site.geojson"), doc).unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "origin = {{ lat = {}, lon = {} }}\n\n[airspace]\nfence_geojson = \"maps/site.geojson\"\n",
            ORIGIN.lat, ORIGIN.lon
        ),
    )
    .unwrap();
    (dir, fleet)
}

fn load(fleet: &Path) -> Result<Fleet, String> {
    Fleet::load(fleet, "M", &drones()).map_err(|e| e.to_string())
}

/// The corners of a 40 m x 30 m field north-east of the origin, as a map
/// tool would write them: `[lon, lat]`, the ring closed.
const FIELD: [[f64; 2]; 4] = [[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]];

fn ring() -> String {
    let frame = LocalFrame::new(ORIGIN);
    let points: Vec<String> = FIELD
        .iter()
        .chain(&FIELD[..1])
        .map(|[x, y]| {
            let p = frame.to_wgs84(Vec3::new(*x, *y, 0.0));
            format!("[{}, {}]", p.lon, p.lat)
        })
        .collect();
    format!("[[{}]]", points.join(", "))
}

#[test]
fn a_geojson_fence_lands_in_the_fleet_frame_where_its_local_frame_says() {
    let polygon = format!(r#"{{"type": "Polygon", "coordinates": {}}}"#, ring());
    let feature = format!(
        r#"{{"type": "Feature", "properties": {{"name": "field"}}, "geometry": {polygon}}}"#
    );
    let marker = r#"{"type": "Feature", "properties": null, "geometry": {"type": "Point", "coordinates": [14.265, 46.6139]}}"#;
    let collection =
        format!(r#"{{"type": "FeatureCollection", "features": [{marker}, {feature}]}}"#);
    for doc in [&polygon, &feature, &collection] {
        let (_dir, fleet) = with_geojson(doc);
        let f = load(&fleet).unwrap();
        let fence = f.airspace().fence.as_ref().expect("the fence is read");
        assert_eq!(fence.vertices().len(), FIELD.len(), "{doc}");
        for (v, want) in fence.vertices().iter().zip(FIELD) {
            let off = ((v[0] - want[0]).powi(2) + (v[1] - want[1]).powi(2)).sqrt();
            assert!(off < 0.01, "{v:?} is {off} m from {want:?}");
        }
        assert!(fence.contains(Vec3::new(20.0, 15.0, 0.0)));
        assert!(!fence.contains(Vec3::new(41.0, 15.0, 0.0)));
    }
}

#[test]
fn a_geojson_that_is_not_one_polygon_is_refused_naming_both_files() {
    let r = ring();
    let two = format!(
        r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "properties": {{}}, "geometry": {{"type": "Polygon", "coordinates": {r}}}}}, {{"type": "Feature", "properties": {{}}, "geometry": {{"type": "Polygon", "coordinates": {r}}}}}]}}"#
    );
    let holed = format!(
        r#"{{"type": "Polygon", "coordinates": [{}, {}]}}"#,
        &r[1..r.len() - 1],
        &r[1..r.len() - 1]
    );
    for (doc, what) in [
        ("{ not json", "not JSON"),
        (r#"{"type": "Circle"}"#, "not GeoJSON"),
        (
            r#"{"type": "LineString", "coordinates": [[14.0, 46.0], [14.1, 46.1]]}"#,
            "it is a LineString, not a Polygon",
        ),
        (
            r#"{"type": "Feature", "properties": {}, "geometry": null}"#,
            "no geometry",
        ),
        (
            r#"{"type": "FeatureCollection", "features": []}"#,
            "holds no Polygon",
        ),
        (&two, "holds 2 areas"),
        (&holed, "has a hole"),
        (
            r#"{"type": "Polygon", "coordinates": [[[14.0, 46.0], [14.1, 46.0], [14.0, 46.0]]]}"#,
            "at least 3 vertices",
        ),
        (
            r#"{"type": "Polygon", "coordinates": [[[14.0, 46.0], [14.1, 96.0], [14.2, 46.1], [14.0, 46.0]]]}"#,
            "vertex 2 ([lon, lat]): latitude 96",
        ),
    ] {
        let (_dir, fleet) = with_geojson(doc);
        let e = load(&fleet).unwrap_err();
        let at = format!("{}:4:17: `fence_geojson` ", fleet.display());
        assert!(e.starts_with(&at), "{doc}\n-> {e}");
        assert!(
            e.contains("site.geojson") && e.contains(what),
            "{doc}\n-> {e}"
        );
    }
    let (dir, fleet) = with_geojson("");
    std::fs::remove_file(dir.path().join("maps/site.geojson")).unwrap();
    let e = load(&fleet).unwrap_err();
    assert!(e.contains("site.geojson: cannot be read"), "{e}");
}

#[test]
fn the_fleet_digest_holds_the_airspace_and_the_geojson_fence_not_its_path() {
    let digest = |text: &str| parse(text).unwrap().digest;
    let base = digest("[airspace]\nceiling = 120.0\n");
    assert_ne!(base, digest("[airspace]\nceiling = 100.0\n"));
    assert_ne!(
        base,
        digest("[airspace]\nceiling = 120.0\nseparation = 1.0\n")
    );
    assert_ne!(
        digest("origin = { lat = 46.0, lon = 14.0 }\n"),
        digest("origin = { lat = 46.0, lon = 14.1 }\n")
    );

    let polygon = format!(r#"{{"type": "Polygon", "coordinates": {}}}"#, ring());
    let (_a, fleet) = with_geojson(&polygon);
    let first = load(&fleet).unwrap().digest;
    // The same document under another name: the same fleet.
    let (b, fleet) = with_geojson(&polygon);
    std::fs::rename(b.path().join("maps"), b.path().join("plans")).unwrap();
    let text = std::fs::read_to_string(&fleet)
        .unwrap()
        .replace("maps/", "plans/");
    std::fs::write(&fleet, text).unwrap();
    assert_eq!(load(&fleet).unwrap().digest, first);
    // A vertex moved: another fleet.
    let moved = polygon.replacen("14.265", "14.2651", 1);
    assert_ne!(moved, polygon);
    let (_c, fleet) = with_geojson(&moved);
    assert_ne!(load(&fleet).unwrap().digest, first);
}

#[test]
fn the_survey_examples_airspace_is_read_and_holds_the_survey() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mission = std::fs::read_to_string(root.join("examples/survey.go")).unwrap();
    let source = eamos_lang::SourceFile::new("survey.go".to_string(), mission);
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&source, &profiles).expect("the survey checks");
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    let fleet = Fleet::load(&root.join("examples/airspace.toml"), &net.name, &net.drones)
        .expect("the example fleet file is read");
    let homes = fleet.homes(&net.drones);
    let at = |who: &str| homes[net.drones.iter().position(|d| d == who).unwrap()];
    let (scout, camera) = (at("Scout"), at("Camera"));
    assert_eq!(scout, Vec3::ZERO);
    assert!(camera.distance(Vec3::new(0.0, 3.0, 0.0)) < 0.01, "{camera}");
    // The survey's legs, as examples/survey.go flies them: up, 10 m north,
    // down.
    let space = fleet.airspace();
    for (home, height) in [(scout, 5.0), (camera, 3.0)] {
        let up = home + Vec3::new(0.0, 0.0, height);
        let there = up + Vec3::new(10.0, 0.0, 0.0);
        let down = there - Vec3::new(0.0, 0.0, height);
        for (a, b) in [(home, up), (up, there), (there, down)] {
            assert_eq!(space.breach(a, b), None, "{a} -> {b}");
        }
    }
    assert!(space.fence.is_some() && space.ceiling == Some(30.0));
    assert_eq!(space.separation, 2.0);
}
