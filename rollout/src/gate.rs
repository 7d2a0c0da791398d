//! The part of an agent that judges what it is sent: pure, so that every
//! refusal can be tested without a network.

use eamos_fleet::identity::{fleet_version, slice_digest};
use eamos_fleet::Fleet;
use eamos_seal::{PublicKey, Sealed, CONTEXT_SLICE, CONTEXT_START};
use eamos_slicer::Slice;

use crate::sessions::{check_session, Sessions};
use crate::wire::{Held, SliceBundle, StartCommand};

/// What a slice offer asks of an agent.
#[derive(Debug)]
pub enum Offer {
    /// Hold this slice, for this session.
    New {
        slice: Box<Slice>,
        digest: String,
        fleet: Box<Fleet>,
        session: String,
    },
    /// Keep the slice held (it did not change), for this session.
    Keep { digest: String, session: String },
}

/// The part of an agent that judges what it is sent: pure, so that every
/// refusal can be tested without a network.
pub struct Gate {
    pub drone: String,
    /// The agent's fleet, read before any mission was known.
    pub fleet: Fleet,
    pub fleet_name: String,
    pub trusted: Option<PublicKey>,
}

impl Gate {
    /// The digest of the agent's fleet, as its status reports it.
    pub fn fleet_digest(&self) -> String {
        fleet_version(&self.fleet)
    }

    fn wrong_fleet(&self, theirs: &str) -> String {
        format!(
            "wrong mission version: it was built with another fleet file (digest {}) than this agent's {} (digest {}); give the ground station and every agent the same fleet file",
            short(theirs),
            self.fleet_name,
            short(&self.fleet_digest())
        )
    }

    /// Checks a sealed slice offer against the slice held and the sessions
    /// already started.
    pub fn check_slice(
        &self,
        bytes: &[u8],
        held: Option<&Held>,
        started: &Sessions,
    ) -> Result<Offer, String> {
        let sealed = Sealed::from_bytes(bytes).map_err(|e| e.to_string())?;
        let payload = sealed
            .open_with(self.trusted.as_ref(), CONTEXT_SLICE)
            .map_err(|e| e.to_string())?;
        let bundle = SliceBundle::from_bytes(payload)?;
        if bundle.fleet != self.fleet_digest() {
            return Err(self.wrong_fleet(&bundle.fleet));
        }
        check_session(&bundle.session)?;
        if started.contains(&bundle.session) {
            return Err(format!(
                "replayed slice: deploy session {} was started before by this agent, and a session flies once; every `eamos deploy` offers slices in a fresh session",
                bundle.session
            ));
        }
        let Some(bytes) = bundle.slice else {
            return match held {
                Some(h) if h.digest == bundle.digest => Ok(Offer::Keep {
                    digest: bundle.digest,
                    session: bundle.session,
                }),
                Some(h) => Err(format!(
                    "no such slice: told to keep slice {}, but this agent holds {} (of {})",
                    bundle.digest, h.digest, h.identity
                )),
                None => Err(format!(
                    "no slice: told to keep slice {}, but this agent holds none",
                    bundle.digest
                )),
            };
        };
        let slice = Slice::from_bytes(&bytes).map_err(|e| format!("damaged slice: {e}"))?;
        if slice.drone != self.drone {
            return Err(format!(
                "this is {}'s slice, and this agent flies {}",
                slice.drone, self.drone
            ));
        }
        if slice.mission_id != bundle.identity {
            return Err(format!(
                "wrong mission version: the slice belongs to {} but was sent for {}",
                slice.mission_id, bundle.identity
            ));
        }
        let digest = slice_digest(&slice);
        if digest != bundle.digest {
            return Err(format!(
                "damaged slice: its digest is {digest}, and the offer says {}",
                bundle.digest
            ));
        }
        self.fleet
            .check_mission(&self.fleet_name, &slice.mission, &slice.drones)
            .map_err(|e| e.to_string())?;
        let fleet = self.fleet.clone();
        Ok(Offer::New {
            slice: Box::new(slice),
            digest,
            fleet: Box::new(fleet),
            session: bundle.session,
        })
    }

    /// Checks a sealed start command against the slice held and the
    /// sessions already started.
    pub fn check_start(
        &self,
        bytes: &[u8],
        held: Option<&Held>,
        started: &Sessions,
    ) -> Result<StartCommand, String> {
        let sealed = Sealed::from_bytes(bytes).map_err(|e| e.to_string())?;
        let payload = sealed
            .open_with(self.trusted.as_ref(), CONTEXT_START)
            .map_err(|e| e.to_string())?;
        let start = StartCommand::from_bytes(payload)?;
        if start.fleet != self.fleet_digest() {
            return Err(self.wrong_fleet(&start.fleet));
        }
        check_session(&start.session)?;
        if started.contains(&start.session) {
            return Err(format!(
                "replayed start command: deploy session {} of {} was started before by this agent, and a session flies once",
                start.session, start.identity
            ));
        }
        let Some(held) = held else {
            return Err(format!(
                "no slice: this agent holds no slice of {} yet",
                start.identity
            ));
        };
        match start.digests.get(&self.drone) {
            None => {
                return Err(format!(
                    "wrong mission version: {} has no part for {}",
                    start.identity, self.drone
                ))
            }
            Some(d) if *d != held.digest => {
                return Err(format!(
                "wrong mission version: {} gives {} the slice {}, and this agent holds {} (of {})",
                start.identity, self.drone, d, held.digest, held.identity
            ))
            }
            Some(_) => {}
        }
        if start.session != held.session {
            return Err(format!(
                "start command of another deploy: it starts session {}, and this agent's slice was offered in session {}; an agent starts only the session that offered its slice (a recorded start played back is refused so)",
                start.session, held.session
            ));
        }
        if !(start.speed.is_finite() && start.speed > 0.0) {
            return Err(format!("the speed {} is not above zero", start.speed));
        }
        Ok(start)
    }
}

fn short(digest: &str) -> &str {
    &digest[..digest.len().min(16)]
}
