//! The net while the rules rewrite it: transitions that can be taken out
//! and added, and for every place who consumes, reads and produces it.
//!
//! [`PtNet`] is built once and read millions of times; the rules need the
//! opposite, so they work here and the result is packed into a new
//! [`PtNet`] at the end.

use crate::ptnet::{PtNet, RawTransition};

/// Where a transition of the reduced net comes from: a transition of the
/// original net, or two firings one after the other. A tree, so that a
/// chain of a thousand fused steps costs a thousand nodes, not a thousand
/// copies of ever longer sequences.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Origin {
    Step(u32),
    Seq(u32, u32),
}

/// A transition of the working net with the origin node it stands for.
#[derive(Debug, Clone)]
pub(super) struct Tr {
    pub arcs: RawTransition,
    pub origin: u32,
}

pub(super) struct Work<'a> {
    pub net: &'a PtNet,
    pub trs: Vec<Option<Tr>>,
    pub place_alive: Vec<bool>,
    /// Per place: live transitions consuming, reading and producing it
    /// (producing: the place is in the transition's post at all).
    pub consumers: Vec<Vec<u32>>,
    pub readers: Vec<Vec<u32>>,
    pub producers: Vec<Vec<u32>>,
    pub origins: Vec<Origin>,
}

impl<'a> Work<'a> {
    pub(super) fn new(net: &'a PtNet) -> Self {
        let np = net.n_places();
        let mut w = Work {
            net,
            trs: Vec::new(),
            place_alive: vec![true; np],
            consumers: vec![Vec::new(); np],
            readers: vec![Vec::new(); np],
            producers: vec![Vec::new(); np],
            origins: Vec::new(),
        };
        for (t, arcs) in net.raw().into_iter().enumerate() {
            let origin = w.origin(Origin::Step(t as u32));
            w.add(Tr { arcs, origin });
        }
        w
    }

    pub(super) fn origin(&mut self, o: Origin) -> u32 {
        self.origins.push(o);
        self.origins.len() as u32 - 1
    }

    pub(super) fn is_final(&self, p: u32) -> bool {
        self.net.final_place == Some(p)
    }

    pub(super) fn tr(&self, t: u32) -> Option<&Tr> {
        self.trs.get(t as usize).and_then(Option::as_ref)
    }

    pub(super) fn add(&mut self, tr: Tr) -> u32 {
        let t = self.trs.len() as u32;
        for &(p, _) in &tr.arcs.pre {
            self.consumers[p as usize].push(t);
        }
        for &(p, _) in &tr.arcs.read {
            self.readers[p as usize].push(t);
        }
        for &(p, _) in &tr.arcs.post {
            self.producers[p as usize].push(t);
        }
        self.trs.push(Some(tr));
        t
    }

    /// Takes transition `t` out; returns it and leaves every place it
    /// touched in `touched`.
    pub(super) fn remove(&mut self, t: u32, touched: &mut Vec<u32>) -> Option<Tr> {
        let tr = self.trs.get_mut(t as usize)?.take()?;
        for &(p, _) in &tr.arcs.pre {
            self.consumers[p as usize].retain(|&u| u != t);
            touched.push(p);
        }
        for &(p, _) in &tr.arcs.read {
            self.readers[p as usize].retain(|&u| u != t);
            touched.push(p);
        }
        for &(p, _) in &tr.arcs.post {
            self.producers[p as usize].retain(|&u| u != t);
            touched.push(p);
        }
        Some(tr)
    }

    /// Every place any arc of `tr` touches.
    pub(super) fn places_of(tr: &Tr) -> impl Iterator<Item = u32> + '_ {
        tr.arcs
            .pre
            .iter()
            .chain(&tr.arcs.read)
            .chain(&tr.arcs.post)
            .map(|&(p, _)| p)
    }
}
