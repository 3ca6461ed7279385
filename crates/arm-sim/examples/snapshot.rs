//! Writes one frame per camera of the default simulator to the folder given (default `.`), with
//! the ground-truth gripper tip printed: `cargo run -p arm-sim --example snapshot -- /tmp`.

use arm_sim::{ArmSim, SimConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let mut sim = ArmSim::new(SimConfig::default())?;
    sim.command(&[1650.0, 1850.0, 1750.0, 1900.0, 1500.0, 1300.0])?;
    let t = std::time::Instant::now();
    for _ in 0..50 {
        std::hint::black_box(sim.capture());
    }
    eprintln!("capture (all cameras): {:?}", t.elapsed() / 50);
    let images = sim.capture();
    for (i, img) in images.iter().enumerate() {
        let path = format!("{dir}/arm-sim-camera{i}.png");
        img.save(&path)?;
        println!(
            "{path}: tip at {:?}",
            sim.inspect().project(i, &sim.inspect().tip())?
        );
    }
    Ok(())
}
