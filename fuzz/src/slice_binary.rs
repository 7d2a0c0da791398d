//! Feeds arbitrary bytes to the binary slice decoder, the form an agent
//! reads from disk or receives when a slice is deployed. Two ways in: input
//! that starts with the magic is decoded as it is (header, length and
//! checksum parsing); any other input becomes the postcard payload (the
//! file's own types, `eamos_slicer::wire`) of a well-framed file with a
//! correct checksum, so that the fuzzer reaches the payload decoder, the
//! conversion to the compiler's types and `Slice::validate` instead of
//! stopping at the checksum. Neither may panic, and a slice that decodes must survive its
//! own encodings (binary and JSON) unchanged.

use eamos_slicer::{Slice, FORMAT_VERSION, MAGIC};
use sha3::{Digest, Sha3_256};

/// A slice file around `payload`, as `Slice::to_bytes` lays it out.
fn framed(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 46);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    out.extend_from_slice(&Sha3_256::digest(payload));
    out
}

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    let decoded = if data.starts_with(MAGIC) {
        Slice::from_bytes(data)
    } else {
        Slice::from_bytes(&framed(data))
    };
    if let Ok(slice) = decoded {
        let again = Slice::from_bytes(&slice.to_bytes()).expect("a decoded slice re-decodes");
        assert_eq!(again, slice);
        let json = Slice::from_json(&slice.to_json()).expect("a decoded slice reads as JSON");
        assert_eq!(json, slice);
    }
}
