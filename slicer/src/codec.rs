//! Slice files: readable JSON and a compact binary form.
//!
//! Binary layout (all integers little-endian):
//!
//! | bytes | content |
//! | --- | --- |
//! | 8 | magic `EAMOSSLC` |
//! | 2 | format version ([`FORMAT_VERSION`]) |
//! | 4 | length `n` of the payload |
//! | n | the slice as [`v3::Slice`], postcard-encoded |
//! | 32 | SHA3-256 of the payload |
//!
//! The checksum makes a damaged file an error rather than a different
//! mission: postcard alone would decode many altered payloads into another,
//! well-formed slice. The JSON form wraps the slice in
//! `{"format": "eamos-slice", "version": 3, "slice": {...}}` and is checked
//! for consistency ([`Slice::validate`]) when read; it carries no checksum so
//! that a person can read and diff it.
//!
//! Both forms go through the file's own types ([`crate::wire`]), never the
//! compiler's: a reader of another version is refused by number before its
//! content is looked at.

use serde::{Deserialize, Serialize};
use sha3::{Digest, Sha3_256};

use crate::error::DecodeError;
use crate::slice::Slice;
use crate::wire::{v3, FORMAT_VERSION};

pub const MAGIC: &[u8; 8] = b"EAMOSSLC";
const FORMAT_NAME: &str = "eamos-slice";
const HEADER: usize = 8 + 2 + 4;
const DIGEST: usize = 32;

#[derive(Serialize)]
struct JsonOut<'a> {
    format: &'a str,
    version: u16,
    slice: &'a v3::Slice,
}

#[derive(Deserialize)]
struct JsonIn {
    format: String,
    version: u16,
    slice: serde_json::Value,
}

impl Slice {
    /// The readable form, pretty-printed.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(&JsonOut {
            format: FORMAT_NAME,
            version: FORMAT_VERSION,
            slice: &v3::Slice::from(self),
        })
        .expect("a slice always serialises")
    }

    /// Reads the readable form; a wrong format, another version, a JSON error
    /// (with its line and column) or an inconsistent slice is an error.
    pub fn from_json(text: &str) -> Result<Slice, DecodeError> {
        let file: JsonIn = serde_json::from_str(text)?;
        if file.format != FORMAT_NAME {
            return Err(DecodeError::Format(file.format));
        }
        if file.version != FORMAT_VERSION {
            return Err(DecodeError::Version {
                found: file.version,
                expected: FORMAT_VERSION,
            });
        }
        let wire: v3::Slice = serde_json::from_value(file.slice)?;
        let slice = Slice::try_from(wire)?;
        slice.validate()?;
        Ok(slice)
    }

    /// The compact form: header, postcard payload, checksum.
    pub fn to_bytes(&self) -> Vec<u8> {
        let payload =
            postcard::to_allocvec(&v3::Slice::from(self)).expect("a slice always serialises");
        let mut out = Vec::with_capacity(HEADER + payload.len() + DIGEST);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        out.extend_from_slice(&payload);
        out.extend_from_slice(&Sha3_256::digest(&payload));
        out
    }

    /// Reads the compact form. Never panics: a file that is not a slice, of
    /// another version, truncated, altered or inconsistent is an error.
    pub fn from_bytes(bytes: &[u8]) -> Result<Slice, DecodeError> {
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            return Err(DecodeError::NotASlice);
        }
        if bytes.len() < HEADER {
            return Err(DecodeError::Truncated {
                expected: HEADER as u64,
                found: bytes.len() as u64,
            });
        }
        let version = u16::from_le_bytes([bytes[8], bytes[9]]);
        if version != FORMAT_VERSION {
            return Err(DecodeError::Version {
                found: version,
                expected: FORMAT_VERSION,
            });
        }
        let n = u32::from_le_bytes([bytes[10], bytes[11], bytes[12], bytes[13]]) as u64;
        let rest = (bytes.len() - HEADER) as u64;
        if rest < n + DIGEST as u64 {
            return Err(DecodeError::Truncated {
                expected: n + DIGEST as u64,
                found: rest,
            });
        }
        if rest > n + DIGEST as u64 {
            return Err(DecodeError::TrailingBytes {
                extra: rest - n - DIGEST as u64,
            });
        }
        let payload = &bytes[HEADER..HEADER + n as usize];
        let digest = &bytes[HEADER + n as usize..];
        if Sha3_256::digest(payload).as_slice() != digest {
            return Err(DecodeError::Checksum);
        }
        let wire: v3::Slice =
            postcard::from_bytes(payload).map_err(|e| DecodeError::Binary(e.to_string()))?;
        let slice = Slice::try_from(wire)?;
        slice.validate()?;
        Ok(slice)
    }
}
