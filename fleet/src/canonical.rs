//! One text per value: the canonical JSON that the fleet digest and the
//! slice digest hash, so that layout, comments and key order never change
//! a digest.

use serde_json::Value;
use sha3::{Digest, Sha3_256};

pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// JSON with object keys sorted at every level and no whitespace: one text
/// per value, whatever order its maps were built in.
pub fn canonical_json(v: &Value) -> String {
    let mut out = String::new();
    write_canonical(v, &mut out);
    out
}

fn write_canonical(v: &Value, out: &mut String) {
    match v {
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            out.push('{');
            for (i, k) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&Value::String(k.clone()).to_string());
                out.push(':');
                write_canonical(&map[k], out);
            }
            out.push('}');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_canonical(item, out);
            }
            out.push(']');
        }
        other => out.push_str(&other.to_string()),
    }
}

/// The digest of a fleet file's text in canonical form (the TOML read as
/// values, written back as canonical JSON): layout, comments, key order and
/// quoting style do not count; every value does. Text that is not TOML is
/// hashed as it is (such a file never gets as far as a mission).
pub fn fleet_digest(text: &str) -> String {
    fleet_digest_with(text, None)
}

/// [`fleet_digest`] of a fleet whose fence is a GeoJSON file: the
/// document (`geojson`, as read) stands in for its path, so that the
/// identity changes when the fence is redrawn and not when the file moves.
/// The document, not the fence computed from it, because the ground
/// station and every agent must agree on the digest to the bit, and the
/// conversion to the local frame goes through trigonometry that need not
/// round alike on every machine.
pub(crate) fn fleet_digest_with(text: &str, geojson: Option<&Value>) -> String {
    let canonical = match toml::from_str::<toml::Table>(text) {
        Ok(table) => match serde_json::to_value(&table) {
            Ok(mut v) => {
                if let Some(doc) = geojson {
                    if let Some(path) = v.pointer_mut("/airspace/fence_geojson") {
                        *path = doc.clone();
                    }
                }
                canonical_json(&v)
            }
            Err(_) => text.to_string(),
        },
        Err(_) => text.to_string(),
    };
    hex(&Sha3_256::digest(canonical.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_json_sorts_keys_at_every_level() {
        let v: Value =
            serde_json::from_str(r#"{"b":1,"a":{"d":[{"z":1,"y":2}],"c":"x"}}"#).unwrap();
        assert_eq!(
            canonical_json(&v),
            r#"{"a":{"c":"x","d":[{"y":2,"z":1}]},"b":1}"#
        );
    }
}
