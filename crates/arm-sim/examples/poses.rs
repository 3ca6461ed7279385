//! Prints the ideal arm's tip and table contact for a few set-points (a development aid):
//! `cargo run -p arm-sim --example poses -- 1500,1500,1500,1500,1500,500 …`.

use arm_sim::{ArmSim, SimConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sim = ArmSim::new(SimConfig::ideal())?;
    for arg in std::env::args().skip(1) {
        let set: Vec<f64> = arg.split(',').map(str::parse).collect::<Result<_, _>>()?;
        sim.command(&set)?;
        let i = sim.inspect();
        println!(
            "{arg}: tip {:.1?} contact {} px {:.1?}",
            i.tip().as_slice(),
            i.last_move().table_contact,
            i.tip_pixels()?
        );
    }
    Ok(())
}
