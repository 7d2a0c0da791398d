//! Every leg every drone can fly, in the fleet frame: the model the spatial
//! properties stand on, handed to whoever draws a mission (`eamos view`),
//! so that a drawing shows exactly the legs the checker judged and never a
//! second analysis of its own.

use eamos_geo::Vec3;
use eamos_lang::Span;
use eamos_petri::Net;
use eamos_profile::ProfileTable;

use crate::names::Names;
use crate::space::shape::Shape;
use crate::space::walk::Walker;
use crate::space::{model, Space};

/// Where every drone of a mission flies, on every branch and in every
/// round the checker tells apart.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The mission's drones, in its order.
    pub drones: Vec<String>,
    /// Each drone's home in the fleet frame, in the order of `drones`.
    pub homes: Vec<Vec3>,
    /// Every way every motion can be flown, once each.
    pub legs: Vec<PlannedLeg>,
}

/// One way one motion of one drone can be flown.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedLeg {
    /// Index into [`Plan::drones`].
    pub drone: usize,
    /// The action as the mission writes it: `Drone1.FlyByX(1)`.
    pub action: String,
    /// The action instance in the net (`ActionRef::instance`): ties the
    /// leg to the action's transitions.
    pub instance: u32,
    /// In the fleet frame (metres north, east of the origin; up from home).
    pub from: Vec3,
    pub to: Vec3,
    /// Somewhere in the box between `from` and `to`: a leg flown on from
    /// wherever a cancelled leg stopped.
    pub boxed: bool,
    /// The call in the mission.
    pub span: Span,
    /// The loop rounds around it, outermost first, counted from 0.
    pub rounds: Vec<u32>,
}

/// Follows every drone's motions from its home, as `eamos check` does.
/// An error when the mission is too large to follow (the check reports
/// the same as a limit).
pub fn plan(net: &Net, profiles: &ProfileTable, space: &Space) -> Result<Plan, String> {
    let names = Names::new(net, None);
    let walker = Walker::new(net);
    let positions = model::positions(net, profiles, &walker)
        .map_err(|_| "the mission is too large to follow every drone's legs".to_string())?;
    let mut legs = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for (m, ways) in positions.legs.iter().enumerate() {
        let t = &positions.motions[m];
        let home = space.home(t.drone);
        for leg in ways {
            let sweep = leg.sweep.at(Vec3::new(home.x, home.y, 0.0));
            // The same leg in two rounds is drawn once (the first round).
            if !seen.insert((m, sweep.key())) {
                continue;
            }
            let (from, to) = sweep.ends();
            legs.push(PlannedLeg {
                drone: t.drone as usize,
                action: names.action(&t.action),
                instance: t.action.instance,
                from,
                to,
                boxed: matches!(sweep, Shape::Box(..)),
                span: t.span,
                rounds: leg.colour.clone(),
            });
        }
    }
    Ok(Plan {
        drones: net.drones.clone(),
        homes: (0..net.drones.len())
            .map(|d| space.home(d as u16))
            .collect(),
        legs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn net(text: &str) -> (Net, ProfileTable) {
        let profiles = eamos_profile::builtin();
        let source = eamos_lang::SourceFile::new("m.go", text);
        let compiled = eamos_lang::compile(&source, &profiles).expect("compiles");
        (eamos_petri::compile(&compiled.mission, &profiles), profiles)
    }

    #[test]
    fn every_branch_of_every_drone_is_a_leg_from_its_home() {
        let (net, profiles) = net(r#"package P
var A Quadcopter
var B Quadcopter
func SEQ_M() {
	PAR_Up()
	If(A.Battery() > 50, SEQ_Far, SEQ_Near)
	B.FlyByY(2)
}
func PAR_Up() {
	A.Arm()
	B.Arm()
	A.Takeoff(5)
	B.Takeoff(3)
}
func SEQ_Far() {
	A.FlyByX(10)
}
func SEQ_Near() {
	A.FlyByX(1)
}
"#);
        let space = Space::default_for(2);
        let plan = plan(&net, &profiles, &space).unwrap();
        assert_eq!(plan.drones, ["A", "B"]);
        let of =
            |d: usize| -> Vec<&PlannedLeg> { plan.legs.iter().filter(|l| l.drone == d).collect() };
        // A: take-off, then one leg per branch, both from 5 m up.
        let a = of(0);
        assert_eq!(a.len(), 3, "{a:?}");
        let ends: Vec<f64> = a.iter().map(|l| l.to.x).collect();
        assert!(ends.contains(&10.0) && ends.contains(&1.0), "{ends:?}");
        // B flies from its own home, 3 m east of A's (the default row).
        let b = of(1);
        assert_eq!(b.len(), 2, "{b:?}");
        let fly = b.iter().find(|l| l.action == "B.FlyByY(2)").unwrap();
        assert_eq!(fly.from, Vec3::new(0.0, space.homes[1].y, 3.0));
        assert_eq!(fly.to, Vec3::new(0.0, space.homes[1].y + 2.0, 3.0));
        assert!(fly.span.start > 0);
    }
}
