//! Which fleet file a mission is checked with: the one the workspace
//! settings name, else `fleet.toml` beside the mission, else none (the
//! default fleet `eamos check` uses without `--fleet`).

use std::path::{Path, PathBuf};

/// The local path of a `file:` URI (percent-escapes decoded).
pub fn path_of(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file://")?;
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let Ok(b) = u8::from_str_radix(std::str::from_utf8(&bytes[i + 1..i + 3]).ok()?, 16) {
                out.push(b);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    Some(PathBuf::from(String::from_utf8(out).ok()?))
}

/// The fleet file for the mission at `mission`: `setting` (relative to
/// `root`, the workspace, or to the mission's folder without one) when
/// given, else `fleet.toml` beside the mission if there is one.
pub fn fleet_for(
    mission: Option<&Path>,
    setting: Option<&str>,
    root: Option<&Path>,
) -> Option<PathBuf> {
    let dir = mission.and_then(Path::parent);
    if let Some(s) = setting.filter(|s| !s.is_empty()) {
        let p = Path::new(s);
        return Some(if p.is_absolute() {
            p.to_path_buf()
        } else {
            root.or(dir).map_or_else(|| p.to_path_buf(), |r| r.join(p))
        });
    }
    let beside = dir?.join("fleet.toml");
    beside.is_file().then_some(beside)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_uri_is_decoded_to_its_path() {
        assert_eq!(
            path_of("file:///home/a%20b/m.go"),
            Some(PathBuf::from("/home/a b/m.go"))
        );
        assert_eq!(path_of("untitled:1"), None);
    }

    #[test]
    fn the_setting_wins_over_the_file_beside_the_mission() {
        let got = fleet_for(
            Some(Path::new("/m/x.go")),
            Some("f/fleet.toml"),
            Some(Path::new("/ws")),
        );
        assert_eq!(got, Some(PathBuf::from("/ws/f/fleet.toml")));
        assert_eq!(
            fleet_for(Some(Path::new("/nowhere/x.go")), None, None),
            None
        );
    }
}
