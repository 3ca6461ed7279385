//! The arm files shipped beside the default (`crates/arm-sim/arms/`) load and differ from the
//! default where their README says.

use arm_sim::SimConfig;

fn arm(name: &str) -> SimConfig {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("arms")
        .join(name);
    SimConfig::read_file(path).expect("a shipped arm file loads")
}

#[test]
fn the_worn_arm_has_more_backlash_noise_and_sag() {
    let (d, w) = (SimConfig::default(), arm("worn-arm.json"));
    for (a, b) in d.servos.iter().zip(&w.servos) {
        assert!(b.backlash_deg >= 2.0 * a.backlash_deg);
        assert!(b.end_noise_deg >= 2.0 * a.end_noise_deg);
    }
    for (a, b) in d
        .sag
        .compliance_deg_per_nm
        .iter()
        .zip(&w.sag.compliance_deg_per_nm)
    {
        assert!(*b >= 2.0 * *a);
    }
    assert_eq!(d.cameras, w.cameras);
}

#[test]
fn the_second_rig_moves_the_cameras_and_changes_the_scene() {
    let (d, r) = (SimConfig::default(), arm("second-rig.json"));
    assert_eq!(d.arm, r.arm);
    for (a, b) in d.cameras.iter().zip(&r.cameras) {
        assert_ne!(a.position_mm, b.position_mm);
    }
    assert!(r.scene.clutter.len() > d.scene.clutter.len());
    assert!(r.scene.sensor_noise_sigma > d.scene.sensor_noise_sigma);
}
