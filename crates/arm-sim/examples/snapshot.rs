//! Writes one frame per camera of the default simulator to the folder given (default `.`), with
//! the ground-truth gripper tip printed: `cargo run -p arm-sim --example snapshot -- /tmp`.

use std::path::Path;

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
        let path = Path::new(&dir).join(format!("arm-sim-camera{i}.png"));
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
        write_whole(&path, &png).map_err(|e| format!("{}: {e}", path.display()))?;
        println!(
            "{}: tip at {:?}",
            path.display(),
            sim.inspect().project(i, &sim.inspect().tip())?
        );
    }
    Ok(())
}

/// Writes `bytes` to a temporary file beside `path` and renames it over `path`, so a failed
/// write leaves no half-written PNG (and an older image at `path` as it was).
fn write_whole(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".partial-{}", std::process::id()));
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
