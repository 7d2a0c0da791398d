//! Feeds arbitrary text to the JSON slice reader (`eamos build -o` writes
//! it; a person may edit it). It must never panic, and a slice it accepts
//! must survive its own encodings (JSON and binary) unchanged.

use eamos_slicer::Slice;

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(slice) = Slice::from_json(text) {
        let again = Slice::from_json(&slice.to_json()).expect("a read slice reads again");
        assert_eq!(again, slice);
        let binary = Slice::from_bytes(&slice.to_bytes()).expect("a read slice decodes");
        assert_eq!(binary, slice);
    }
}
