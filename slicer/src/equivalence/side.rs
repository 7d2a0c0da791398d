//! One net's markings and determinised states, explored lazily.

use std::collections::{BTreeMap, HashMap, HashSet};

use eamos_petri::net::Net;

use super::event::Event;
use super::game::{unpack, Game, Marking, Stop};
use super::Reductions;

pub(super) struct Succ {
    /// Silent firings: (transition, next marking).
    pub silent: Vec<(u32, u32)>,
    /// Visible firings: (event, transition, next marking).
    pub visible: Vec<(Event, u32, u32)>,
    pub dead: bool,
}

pub(super) struct Side {
    pub game: Game,
    ids: HashMap<Marking, u32>,
    pub markings: Vec<Marking>,
    pub succ: Vec<Option<Succ>>,
    macros: HashMap<Vec<u32>, u32>,
    macro_sets: Vec<Vec<u32>>,
    macro_succ: Vec<Option<BTreeMap<Event, u32>>>,
}

impl Side {
    pub fn new(net: &Net, reductions: Reductions) -> Side {
        Side {
            game: Game::of(net, reductions),
            ids: HashMap::new(),
            markings: Vec::new(),
            succ: Vec::new(),
            macros: HashMap::new(),
            macro_sets: Vec::new(),
            macro_succ: Vec::new(),
        }
    }

    pub fn intern(&mut self, m: Marking) -> u32 {
        if let Some(&i) = self.ids.get(&m) {
            return i;
        }
        let i = self.markings.len() as u32;
        self.ids.insert(m.clone(), i);
        self.markings.push(m);
        self.succ.push(None);
        i
    }

    pub fn successors(&mut self, i: u32) -> Result<(), Stop> {
        if self.succ[i as usize].is_some() {
            return Ok(());
        }
        let m = self.markings[i as usize].clone();
        let game = &self.game;
        let mut candidates: Vec<usize> = m
            .iter()
            .flat_map(|(p, _)| game.users[*p as usize].iter().map(|&k| k as usize))
            .chain(game.sources.iter().map(|&k| k as usize))
            .collect();
        candidates.sort_unstable();
        candidates.dedup();
        let enabled = |k: usize| game.enabled(&m, &game.transitions[k]).is_some();
        let eager = candidates
            .iter()
            .copied()
            .find(|&k| game.transitions[k].eager && enabled(k));
        // A free choice: every transition that could take the token of one
        // place, and nothing else; the others wait until it is made.
        let choice = || {
            let k = candidates
                .iter()
                .copied()
                .find(|&k| game.transitions[k].chooser && enabled(k))?;
            let p = game.transitions[k].consume[0];
            Some(game.users[p as usize].iter().map(|&k| k as usize).collect())
        };
        let chosen: Vec<usize> = match eager {
            Some(k) => vec![k],
            None => choice().unwrap_or_else(|| candidates.clone()),
        };
        let mut fired = Vec::new();
        for k in chosen {
            let t = &self.game.transitions[k];
            let Some(colour) = self.game.enabled(&m, t) else {
                continue;
            };
            let next = self.game.fire(&m, t, colour)?;
            let event = match &t.label {
                Some(l) => Some(l.event(unpack(colour))),
                None if t.marks_final => Some(Event::Final),
                None => None,
            };
            fired.push((k as u32, event, next));
        }
        let dead = fired.is_empty() && Game::token(&m, self.game.final_place).is_none();
        let mut succ = Succ {
            silent: Vec::new(),
            visible: Vec::new(),
            dead,
        };
        for (k, event, next) in fired {
            let j = self.intern(next);
            match event {
                Some(e) => succ.visible.push((e, k, j)),
                None => succ.silent.push((k, j)),
            }
        }
        self.succ[i as usize] = Some(succ);
        Ok(())
    }

    /// The determinised state of a set of markings: their silent closure.
    pub fn closure(&mut self, seeds: Vec<u32>, budget: usize) -> Result<u32, Stop> {
        let mut seen: Vec<u32> = Vec::new();
        let mut stack = seeds;
        let mut mark = HashSet::new();
        while let Some(i) = stack.pop() {
            if !mark.insert(i) {
                continue;
            }
            seen.push(i);
            self.successors(i)?;
            if self.markings.len() > budget {
                return Err(Stop::Budget);
            }
            let succ = self.succ[i as usize].as_ref().expect("computed");
            stack.extend(succ.silent.iter().map(|&(_, j)| j));
        }
        seen.sort_unstable();
        if let Some(&k) = self.macros.get(&seen) {
            return Ok(k);
        }
        let k = self.macro_sets.len() as u32;
        self.macros.insert(seen.clone(), k);
        self.macro_sets.push(seen);
        self.macro_succ.push(None);
        Ok(k)
    }

    pub fn macro_successors(
        &mut self,
        k: u32,
        budget: usize,
    ) -> Result<BTreeMap<Event, u32>, Stop> {
        if let Some(s) = &self.macro_succ[k as usize] {
            return Ok(s.clone());
        }
        let mut seeds: BTreeMap<Event, Vec<u32>> = BTreeMap::new();
        let mut dead = false;
        for &i in &self.macro_sets[k as usize].clone() {
            let s = self.succ[i as usize]
                .as_ref()
                .expect("closed states are expanded");
            dead |= s.dead;
            for (e, _, j) in &s.visible {
                seeds.entry(e.clone()).or_default().push(*j);
            }
        }
        let mut out = BTreeMap::new();
        for (e, s) in seeds {
            let m = self.closure(s, budget)?;
            out.insert(e, m);
        }
        if dead {
            let m = self.closure(Vec::new(), budget)?;
            out.insert(Event::Deadlock, m);
        }
        self.macro_succ[k as usize] = Some(out.clone());
        Ok(out)
    }
}
