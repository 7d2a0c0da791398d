//! The uniform space of the paper's middle layer: the one entry point the
//! executor calls for every drone, whatever adapter drives it.
//!
//! It checks each call against the drone's capability profile before the
//! adapter sees it (so every adapter refuses unknown actions and wrong
//! arities in the same words), writes the uniform log, and forwards.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use async_trait::async_trait;
use eamos_profile::Profile;
use tokio::sync::watch;

use crate::api::{
    evaluate_property, ActionCall, ActionError, Adapter, AdapterInfo, CancellationToken, Control,
    PropertyArg, PropertyError, Telemetry, Value, Vec3,
};
use crate::clock::MissionClock;
use crate::log::{CallPhase, LogRecord, SharedSink, UniformRecord};

/// An adapter seen through the drone's profile, with the uniform log.
pub struct Uniform {
    adapter: Arc<dyn Adapter>,
    profile: Profile,
    log: SharedSink,
    next_call: AtomicU64,
}

impl Uniform {
    pub fn new(adapter: Arc<dyn Adapter>, profile: Profile, log: SharedSink) -> Self {
        Self {
            adapter,
            profile,
            log,
            next_call: AtomicU64::new(1),
        }
    }

    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    pub fn adapter(&self) -> &Arc<dyn Adapter> {
        &self.adapter
    }

    /// Whether the profile offers the action with this many numeric
    /// arguments, each a finite number.
    pub fn check(&self, call: &ActionCall) -> Result<(), ActionError> {
        let Some(sig) = self.profile.actions.get(&call.name) else {
            return Err(ActionError::Unsupported {
                action: call.name.clone(),
            });
        };
        if sig.params.len() != call.args.len() {
            let names: Vec<&str> = sig.params.iter().map(|p| p.name.as_str()).collect();
            return Err(ActionError::bad_arguments(
                &call.name,
                format!(
                    "{} takes {} argument{} ({}), got {}",
                    self.profile.name,
                    sig.params.len(),
                    if sig.params.len() == 1 { "" } else { "s" },
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    },
                    call.args.len()
                ),
            ));
        }
        if let Some(p) = sig.params.iter().find(|p| !p.kind.is_numeric()) {
            return Err(ActionError::bad_arguments(
                &call.name,
                format!(
                    "parameter `{}` names a drone, which an action call cannot pass",
                    p.name
                ),
            ));
        }
        if let Some((p, a)) = sig
            .params
            .iter()
            .zip(&call.args)
            .find(|(_, a)| !a.is_finite())
        {
            return Err(ActionError::bad_arguments(
                &call.name,
                format!("`{}` is {a}, not a finite number", p.name),
            ));
        }
        Ok(())
    }

    /// Evaluates a property the profile offers, from this drone's latest
    /// telemetry and the arguments (other drones' telemetry).
    pub fn property(&self, name: &str, args: &[PropertyArg<'_>]) -> Result<Value, PropertyError> {
        if !self.profile.properties.contains_key(name) {
            return Err(PropertyError::Unknown {
                property: name.to_string(),
            });
        }
        let own = *self.adapter.telemetry().borrow();
        evaluate_property(name, &own, args)
    }

    fn log_call(
        &self,
        call_id: u64,
        call: &ActionCall,
        phase: CallPhase,
        end: Option<(&Result<(), ActionError>, f64)>,
    ) {
        let drone = self.adapter.info().drone;
        let time = self.adapter.clock().now();
        let (outcome, error, duration) = match end {
            None => (None, None, None),
            Some((Ok(()), d)) => (Some("ok".to_string()), None, Some(d)),
            Some((Err(e), d)) => (Some(e.kind().to_string()), Some(e.to_string()), Some(d)),
        };
        self.log.record(LogRecord::Uniform(UniformRecord {
            time,
            drone,
            call: call_id,
            action: call.name.clone(),
            args: call.args.clone(),
            phase,
            outcome,
            error,
            duration,
        }));
    }
}

#[async_trait]
impl Adapter for Uniform {
    fn info(&self) -> AdapterInfo {
        self.adapter.info()
    }

    fn telemetry(&self) -> watch::Receiver<Telemetry> {
        self.adapter.telemetry()
    }

    fn clock(&self) -> MissionClock {
        self.adapter.clock()
    }

    /// Checks, logs the start, forwards, logs the outcome. A call the
    /// profile rejects is logged too (it never reaches the adapter).
    async fn run(&self, call: &ActionCall, cancel: CancellationToken) -> Result<(), ActionError> {
        let call_id = self.next_call.fetch_add(1, Ordering::Relaxed);
        let clock = self.adapter.clock();
        let start = clock.now();
        self.log_call(call_id, call, CallPhase::Started, None);
        let result = match self.check(call) {
            Ok(()) => self.adapter.run(call, cancel).await,
            Err(e) => Err(e),
        };
        let duration = (clock.now() - start).max(0.0);
        self.log_call(
            call_id,
            call,
            CallPhase::Finished,
            Some((&result, duration)),
        );
        result
    }

    async fn regain_control(&self) -> Result<Control, ActionError> {
        self.adapter.regain_control().await
    }

    fn motion_reference(&self) -> Result<Vec3, ActionError> {
        self.adapter.motion_reference()
    }

    fn motion_target(&self, call: &ActionCall) -> Option<Vec3> {
        self.adapter.motion_target(call)
    }

    /// Checked and logged like [`Adapter::run`]: a resumed motion is one
    /// more call of its action in the uniform log.
    async fn fly_to_target(
        &self,
        call: &ActionCall,
        target: Vec3,
        cancel: CancellationToken,
    ) -> Result<(), ActionError> {
        let call_id = self.next_call.fetch_add(1, Ordering::Relaxed);
        let clock = self.adapter.clock();
        let start = clock.now();
        self.log_call(call_id, call, CallPhase::Started, None);
        let result = match self.check(call) {
            Ok(()) => self.adapter.fly_to_target(call, target, cancel).await,
            Err(e) => Err(e),
        };
        let duration = (clock.now() - start).max(0.0);
        self.log_call(
            call_id,
            call,
            CallPhase::Finished,
            Some((&result, duration)),
        );
        result
    }
}
