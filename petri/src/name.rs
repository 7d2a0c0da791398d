//! Shared, immutable text of the net: node ids and labels, action names.
//!
//! A net is copied whole twice on its way to the drones (the distributed
//! net, then the slices cut from it), and every node carries an id and a
//! label. As owned `String`s each copy allocated and copied every one of
//! them again: on the stress mission a quarter of the slicer's work and a
//! fifth of the compile's peak memory. A [`Name`] of more than 15 bytes is
//! one reference-counted allocation that copies share; a shorter one (every
//! node id, `p17`, `t4242`, and short labels) lives inside the `Name`
//! itself, with no allocation at all (`ecow`'s small-string layout, the
//! same 16 bytes as a shared `str`). As shared `str`s only, the ids alone
//! were 17,000 allocations of the stress mission, and a 250-drone ground
//! station held 0.85 MB more.
//!
//! It reads, compares, hashes and serialises as the `str` it holds, so
//! files, hashes and drawings are the same as with a `String`.

use std::borrow::Borrow;
use std::fmt;
use std::ops::Deref;

use ecow::EcoString;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A shared string (see the module docs). Clones share the text, or copy
/// it when it fits in the `Name` itself.
#[derive(Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Name(EcoString);

impl Name {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl Deref for Name {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

impl AsRef<str> for Name {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

impl Borrow<str> for Name {
    fn borrow(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Name {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&*self.0, f)
    }
}

/// As the `str`: a net printed for debugging reads as it did with strings.
impl fmt::Debug for Name {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&*self.0, f)
    }
}

impl From<&str> for Name {
    fn from(s: &str) -> Self {
        Name(EcoString::from(s))
    }
}

impl From<String> for Name {
    fn from(s: String) -> Self {
        Name(EcoString::from(s))
    }
}

impl From<&String> for Name {
    fn from(s: &String) -> Self {
        Name(EcoString::from(s.as_str()))
    }
}

impl From<Name> for String {
    fn from(n: Name) -> Self {
        n.0.into()
    }
}

impl PartialEq<str> for Name {
    fn eq(&self, other: &str) -> bool {
        &*self.0 == other
    }
}

impl PartialEq<&str> for Name {
    fn eq(&self, other: &&str) -> bool {
        &*self.0 == *other
    }
}

impl PartialEq<String> for Name {
    fn eq(&self, other: &String) -> bool {
        *self.0 == **other
    }
}

impl PartialEq<Name> for str {
    fn eq(&self, other: &Name) -> bool {
        self == &*other.0
    }
}

impl PartialEq<Name> for &str {
    fn eq(&self, other: &Name) -> bool {
        *self == &*other.0
    }
}

impl PartialEq<Name> for String {
    fn eq(&self, other: &Name) -> bool {
        **self == *other.0
    }
}

impl Serialize for Name {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.0)
    }
}

impl<'de> Deserialize<'de> for Name {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d).map(Name::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_serialises_as_the_string_it_holds() {
        let name = Name::from("take off");
        assert_eq!(
            serde_json::to_string(&name).unwrap(),
            serde_json::to_string("take off").unwrap()
        );
        let back: Name = serde_json::from_str("\"take off\"").unwrap();
        assert_eq!(back, name);
        assert_eq!(format!("{name:?}"), format!("{:?}", "take off"));
    }

    #[test]
    fn clones_of_a_long_name_share_its_text() {
        let a = Name::from(String::from("D1.Takeoff(2.5 m) running"));
        let b = a.clone();
        assert!(std::ptr::eq(a.as_str(), b.as_str()));
        assert_eq!(a, "D1.Takeoff(2.5 m) running");
        assert_eq!("D1.Takeoff(2.5 m) running", b);
    }

    #[test]
    fn a_short_name_holds_its_text_itself() {
        let a = Name::from("p17");
        let inside = (&a as *const Name).cast::<u8>();
        let text = a.as_str().as_ptr();
        assert!(
            (inside..inside.wrapping_add(std::mem::size_of::<Name>())).contains(&text),
            "a node id is not an allocation of its own"
        );
        assert_eq!(a.clone(), "p17");
        assert_eq!(std::mem::size_of::<Name>(), 16);
    }
}
