//! The transitions enabled in a marking: worked out from its marked
//! places, or from its parent's along the one transition fired between
//! them.
//!
//! A mission's marking holds about one token per drone in flight, and so
//! does its list of enabled transitions: working it out afresh from every
//! marked place made each state's expansion grow with the fleet, and the
//! exploration of a fleet as many states again, its square (a state cost
//! 12,600 instructions at 50 drones and 59,600 at 500). Firing `t` changes
//! only the places `t` consumes and produces, so only the transitions that
//! consume or read those can change from enabled to not or back; every
//! other one is as it was in the parent.

use rustc_hash::FxHashMap;

use super::{Encoding, Scratch, Store};
use crate::ptnet::PtNet;

/// What a marking's expansion takes from its parent's: the transitions
/// enabled there, sorted, and the one fired from there to it.
#[derive(Clone, Copy)]
pub(crate) struct Parent<'a> {
    pub enabled: &'a [u32],
    pub fired: u32,
}

#[inline]
pub(super) fn enabled<E: Encoding>(net: &PtNet, m: &[u64], t: usize) -> bool {
    net.pre.get(t).iter().all(|&(p, w)| E::get(m, p) >= w)
        && net.read.get(t).iter().all(|&(p, w)| E::get(m, p) >= w)
}

/// Every transition enabled in `m`, sorted into `s.enabled` and stamped
/// `gen` in `s.enabled_at`: the consumers and readers of its marked
/// places, and the sources.
pub(super) fn from_scratch<E: Encoding>(net: &PtNet, m: &[u64], s: &mut Scratch, gen: u32) {
    let Scratch {
        enabled_at,
        seen_at,
        enabled: en,
        ..
    } = s;
    en.clear();
    let mut consider = |t: u32| {
        if seen_at[t as usize] != gen {
            seen_at[t as usize] = gen;
            if enabled::<E>(net, m, t as usize) {
                enabled_at[t as usize] = gen;
                en.push(t);
            }
        }
    };
    E::for_each_marked(m, |p| {
        for &t in net.consumers.get(p as usize) {
            consider(t);
        }
        for &t in net.readers.get(p as usize) {
            consider(t);
        }
    });
    for &t in &net.sources {
        consider(t);
    }
    en.sort_unstable();
}

/// [`from_scratch`]'s result, from the parent's: the consumers and
/// readers of the places the fired transition changed are judged again,
/// the rest of the parent's list carried over. Leaves in `s.touched` the
/// transitions whose overflow ([`super::overflow`]) may differ from the
/// parent's: those judged again and those that raise a place the fired
/// transition raised (an enabled transition of the parent that does
/// neither overflows here as little as it did there).
pub(super) fn after<E: Encoding>(
    net: &PtNet,
    m: &[u64],
    s: &mut Scratch,
    gen: u32,
    parent: Parent,
) {
    let t = parent.fired as usize;
    let Scratch {
        enabled_at,
        seen_at,
        enabled: en,
        touched,
        cur: now,
        ..
    } = s;
    touched.clear();
    now.clear();
    for &(p, _) in net.pre.get(t).iter().chain(net.post.get(t)) {
        let p = p as usize;
        for &u in net.consumers.get(p).iter().chain(net.readers.get(p)) {
            if seen_at[u as usize] != gen {
                seen_at[u as usize] = gen;
                touched.push(u);
                if enabled::<E>(net, m, u as usize) {
                    enabled_at[u as usize] = gen;
                    now.push(u);
                }
            }
        }
    }
    now.sort_unstable();
    en.clear();
    let mut now = now.iter().copied().peekable();
    for &u in parent.enabled {
        if seen_at[u as usize] == gen {
            continue;
        }
        while let Some(v) = now.next_if(|&v| v < u) {
            en.push(v);
        }
        enabled_at[u as usize] = gen;
        en.push(u);
    }
    en.extend(now);
    for &(p, _) in net.post.get(t) {
        touched.extend_from_slice(net.producers.get(p as usize));
    }
    touched.sort_unstable();
    touched.dedup();
}

/// The enabled lists of expanded markings whose children are still to be
/// expanded in a breadth-first search, each let go with its last child.
/// Up to `room` bytes of them (a fraction of the memory bound): a child
/// whose parent's list was not kept works its own out from scratch.
pub(super) struct Kept {
    by_parent: FxHashMap<u32, (Vec<u32>, u32)>,
    bytes: usize,
    room: usize,
}

impl Kept {
    pub(super) fn new(room: usize) -> Self {
        Kept {
            by_parent: FxHashMap::default(),
            bytes: 0,
            room,
        }
    }

    /// What marking `id` of `store` takes from its parent, if kept.
    pub(super) fn parent_of<'a>(&'a self, store: &Store, id: u32) -> Option<Parent<'a>> {
        let parent = store.parent[id as usize];
        let (enabled, _) = self.by_parent.get(&parent)?;
        Some(Parent {
            enabled,
            fired: store.via[id as usize],
        })
    }

    /// Keeps marking `id`'s list for its `children` new markings.
    pub(super) fn keep(&mut self, id: u32, enabled: Vec<u32>, children: u32) {
        let cost = Self::cost(&enabled);
        if children == 0 || self.bytes + cost > self.room {
            return;
        }
        self.bytes += cost;
        if let Some((old, _)) = self.by_parent.insert(id, (enabled, children)) {
            self.bytes -= Self::cost(&old);
        }
    }

    /// Marking `id` of `store` is expanded: its parent has one child
    /// fewer to wait for.
    pub(super) fn expanded(&mut self, store: &Store, id: u32) {
        let parent = store.parent[id as usize];
        let Some((enabled, waiting)) = self.by_parent.get_mut(&parent) else {
            return;
        };
        *waiting -= 1;
        if *waiting == 0 {
            self.bytes -= Self::cost(enabled);
            self.by_parent.remove(&parent);
        }
    }

    pub(super) fn bytes(&self) -> usize {
        self.bytes
    }

    fn cost(enabled: &[u32]) -> usize {
        enabled.len() * 4 + 48
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::{fire, overflow, Bits, Bytes, Store};
    use super::*;

    /// From every marking `counts` makes of `net`, through every
    /// transition that fires without overflow: the child's list worked out
    /// from the parent's is the one worked out from scratch, and a
    /// transition that overflows in the child but did not in the parent is
    /// one `after` leaves to judge.
    fn as_from_scratch<E: Encoding>(net: &PtNet, counts: &[u32]) -> Result<(), TestCaseError> {
        let words = E::words(net.n_places());
        let m = super::super::tests::marking_of::<E>(net, counts);
        let mut s = Scratch::new(net.n_all(), words);
        let gen = s.next_gen();
        from_scratch::<E>(net, &m, &mut s, gen);
        let parent_list = s.enabled.clone();
        let mut child = vec![0u64; words];
        for &t in parent_list.iter().filter(|&&t| !net.is_monitor(t)) {
            if fire::<E>(net, &m, t as usize, &mut child).is_err() {
                continue;
            }
            let gen = s.next_gen();
            from_scratch::<E>(net, &child, &mut s, gen);
            let expected = s.enabled.clone();
            let parent = Parent {
                enabled: &parent_list,
                fired: t,
            };
            let gen = s.next_gen();
            after::<E>(net, &child, &mut s, gen, parent);
            prop_assert_eq!(&s.enabled, &expected, "after t{}", t);
            for &u in &expected {
                prop_assert_eq!(s.enabled_at[u as usize], gen, "t{} stamped", u);
            }
            for &u in expected.iter().filter(|&&u| !net.is_monitor(u)) {
                let new_overflow = overflow::<E>(net, &child, u as usize).is_some()
                    && !(parent_list.contains(&u) && overflow::<E>(net, &m, u as usize).is_some());
                prop_assert!(
                    !new_overflow || s.touched.contains(&u),
                    "t{} overflows after t{} unjudged",
                    u,
                    t
                );
            }
        }
        Ok(())
    }

    /// A parent's list is there for each of its children until the last
    /// is expanded, and is not kept beyond the room given (its children
    /// then work theirs out from scratch).
    #[test]
    fn a_parents_list_lives_as_long_as_its_children_wait_within_its_room() {
        let mut store = Store::new::<Bits>(1);
        let root = store.insert(&[0], 1, u32::MAX, u32::MAX).0;
        let a = store.insert(&[1], 2, root, 7).0;
        let b = store.insert(&[2], 3, root, 8).0;
        let mut kept = Kept::new(1_000);
        kept.keep(root, vec![7, 8], 2);
        assert!(kept.bytes() > 0);
        let parent = kept.parent_of(&store, b).expect("kept for b");
        assert_eq!((parent.enabled, parent.fired), (&[7, 8][..], 8));
        kept.expanded(&store, a);
        assert!(kept.parent_of(&store, b).is_some(), "b still waits");
        kept.expanded(&store, b);
        assert!(kept.parent_of(&store, b).is_none());
        assert_eq!(kept.bytes(), 0);

        let mut cramped = Kept::new(8);
        cramped.keep(root, vec![7, 8], 2);
        assert!(cramped.parent_of(&store, a).is_none());
        assert_eq!(cramped.bytes(), 0);
    }

    proptest! {
        #[test]
        fn a_childs_enabled_transitions_follow_from_its_parents(
            (n, initial, ts) in crate::testnet::random(),
            counts in proptest::collection::vec(0u32..3, 8),
        ) {
            let net = crate::testnet::net(n, &initial, &ts);
            as_from_scratch::<Bits>(&net, &counts)?;
            as_from_scratch::<Bytes>(&net, &counts)?;
            let near_full: Vec<u32> = counts.iter().map(|c| 253 + c).collect();
            as_from_scratch::<Bytes>(&net, &near_full)?;
        }
    }
}
