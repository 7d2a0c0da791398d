//! How closely the simulator keeps its pace on this machine: flies a short
//! mission at several speeds on a real (multi-threaded) runtime and prints
//! simulated seconds against wall seconds.
//!
//! `cargo run -p eamos-mid --example sim_pace`

use std::sync::Arc;
use std::time::Instant;

use eamos_mid::{
    ActionCall, Adapter, CancellationToken, NullSink, SimConfig, SimDroneSpec, SimFleet, Vec3,
};

#[tokio::main]
async fn main() {
    println!("speed  simulated_s  wall_s  achieved_speed");
    for speed in [1.0, 5.0, 20.0, 100.0, 500.0] {
        let fleet = SimFleet::start(SimConfig {
            speed,
            ..SimConfig::default()
        })
        .expect("valid settings");
        let drones: Vec<_> = (0..4)
            .map(|i| {
                fleet
                    .add_drone(
                        SimDroneSpec::new(format!("D{i}"), Vec3::new(0.0, 5.0 * i as f64, 0.0)),
                        Arc::new(NullSink),
                    )
                    .expect("distinct names")
            })
            .collect();
        let clock = fleet.clock();
        let (sim0, wall0) = (clock.now(), Instant::now());
        let flights = drones.into_iter().map(|d| {
            tokio::spawn(async move {
                for (name, args) in [
                    ("Arm", vec![]),
                    ("Takeoff", vec![1.5]),
                    ("FlyByX", vec![5.0]),
                    ("Hover", vec![2.0]),
                    ("Land", vec![]),
                ] {
                    d.run(&ActionCall::new(name, args), CancellationToken::new())
                        .await
                        .expect("the flight succeeds");
                }
            })
        });
        for f in flights.collect::<Vec<_>>() {
            f.await.expect("no panic");
        }
        let sim = clock.now() - sim0;
        let wall = wall0.elapsed().as_secs_f64();
        println!("{speed:5}  {sim:11.2}  {wall:6.3}  {:14.1}", sim / wall);
    }
}
