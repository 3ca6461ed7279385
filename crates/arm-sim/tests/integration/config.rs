//! Configuration: JSON round trip, file round trip, unknown keys and impossible values named.

use arm_sim::{ArmSim, ArmSimError, SimConfig};

fn key_of(e: ArmSimError) -> String {
    match e {
        ArmSimError::InvalidConfig { key, .. } => key,
        other => panic!("expected InvalidConfig, got {other}"),
    }
}

#[test]
fn default_round_trips_through_json_and_files() {
    let c = SimConfig::default();
    let text = c.to_json();
    assert_eq!(SimConfig::from_json(&text).unwrap(), c);
    let path = std::env::temp_dir().join(format!("arm-sim-config-{}.json", std::process::id()));
    c.write_file(&path).unwrap();
    assert_eq!(SimConfig::read_file(&path).unwrap(), c);
    std::fs::remove_file(&path).unwrap();
    assert!(matches!(
        SimConfig::read_file(&path),
        Err(ArmSimError::ConfigIo { .. })
    ));
    let ideal = SimConfig::ideal();
    assert_eq!(SimConfig::from_json(&ideal.to_json()).unwrap(), ideal);
}

#[test]
fn default_configuration_snapshot() {
    insta::assert_snapshot!(SimConfig::default().to_json());
}

#[test]
fn unknown_keys_are_rejected_by_name() {
    let mut v: serde_json::Value = serde_json::from_str(&SimConfig::default().to_json()).unwrap();
    v["servos"][2]["stiffness"] = 1.0.into();
    let e = SimConfig::from_json(&v.to_string()).unwrap_err();
    assert!(
        matches!(&e, ArmSimError::ConfigParse(m) if m.contains("stiffness")),
        "{e}"
    );
    let mut v: serde_json::Value = serde_json::from_str(&SimConfig::default().to_json()).unwrap();
    v["cameras"][0]["fov"] = 60.into();
    let e = SimConfig::from_json(&v.to_string()).unwrap_err();
    assert!(e.to_string().contains("fov"), "{e}");
    let e = SimConfig::from_json("{\"seed\": 1}").unwrap_err();
    assert!(e.to_string().contains("arm"), "{e}");
}

#[test]
fn impossible_values_name_the_key() {
    let check = |f: &dyn Fn(&mut SimConfig), key: &str| {
        let mut c = SimConfig::default();
        f(&mut c);
        assert_eq!(key_of(c.validate().unwrap_err()), key);
        assert_eq!(key_of(SimConfig::from_json(&c.to_json()).unwrap_err()), key);
        assert!(ArmSim::new(c).is_err());
    };
    check(&|c| c.arm.upper_arm_mm = -120.0, "arm.upper_arm_mm");
    check(
        &|c| c.arm.joint_limits_deg[2] = [10.0, -10.0],
        "arm.joint_limits_deg[2]",
    );
    check(&|c| c.servos[1].gain = 0.0, "servos[1].gain");
    check(
        &|c| c.servos[4].backlash_deg = -0.1,
        "servos[4].backlash_deg",
    );
    check(&|c| c.servos[0].min_us = 3000.0, "servos[0].max_us");
    check(
        &|c| c.sag.compliance_deg_per_nm[1] = -1.0,
        "sag.compliance_deg_per_nm[1]",
    );
    check(&|c| c.cameras.push(c.cameras[0].clone()), "cameras");
    check(&|c| c.cameras.clear(), "cameras");
    check(&|c| c.cameras[1].k1 = -1.5, "cameras[1].k1");
    check(&|c| c.cameras[0].fx = 0.0, "cameras[0].fx");
    check(
        &|c| c.scene.sensor_noise_sigma = -2.0,
        "scene.sensor_noise_sigma",
    );
    check(
        &|c| c.scene.clutter[1].albedo = 1.5,
        "scene.clutter[1].albedo",
    );
    check(
        &|c| c.scene.light_direction = [0.0, 0.0, -1.0],
        "scene.light_direction",
    );
    // NaN cannot even be written as JSON, but the struct check still names it.
    let mut c = SimConfig::default();
    c.servos[3].offset_us = f64::NAN;
    assert_eq!(key_of(c.validate().unwrap_err()), "servos[3].offset_us");
}

#[test]
fn ideal_switches_every_non_ideality_off() {
    let c = SimConfig::ideal();
    for s in &c.servos {
        assert_eq!(
            (
                s.offset_us,
                s.gain,
                s.quantum_us,
                s.deadband_us,
                s.backlash_deg,
                s.end_noise_deg
            ),
            (0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
        );
    }
    assert_eq!(c.sag.compliance_deg_per_nm, [0.0; 3]);
    assert_eq!(c.scene.sensor_noise_sigma, 0.0);
    assert_eq!(c.scene.lighting_gain_sigma, 0.0);
    assert_eq!(c.scene.lighting_gradient_sigma, 0.0);
    let d = SimConfig::default();
    assert_eq!((c.arm, c.cameras), (d.arm, d.cameras));
}

/// `write_file` wrote in place (`fs::write` truncates, then writes), so a reader, or a crash,
/// between the two saw an empty or partial file. It now writes a temporary file beside it and
/// renames it into place: a concurrent reader always reads a whole configuration.
#[test]
fn write_file_replaces_the_file_whole() {
    let dir = std::env::temp_dir().join(format!("arm-sim-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("arm.json");
    let c = SimConfig::default();
    c.write_file(&path).unwrap();
    let done = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            for _ in 0..300 {
                c.write_file(&path).unwrap();
            }
            done.store(true, std::sync::atomic::Ordering::Relaxed);
        });
        let mut reads = 0;
        while !done.load(std::sync::atomic::Ordering::Relaxed) || reads == 0 {
            assert_eq!(SimConfig::read_file(&path).unwrap(), c, "read {reads}");
            reads += 1;
        }
    });
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1, "temporary files left behind");
    // A failed write (the folder does not exist) creates nothing.
    let missing = dir.join("no-such-folder").join("arm.json");
    assert!(matches!(
        c.write_file(&missing),
        Err(ArmSimError::ConfigIo { .. })
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A path that names no file (`dir/..`) is refused before anything is written: no temporary
/// file appears, in the folder it would have gone to or anywhere else in the tree.
#[test]
fn write_file_refuses_a_path_without_a_file_name_and_writes_nothing() {
    let dir = std::env::temp_dir().join(format!("arm-sim-no-name-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sub = dir.join("sub");
    std::fs::create_dir_all(&sub).unwrap();
    let listing = || {
        let mut v: Vec<_> = [&dir, &sub]
            .iter()
            .flat_map(|d| std::fs::read_dir(d).unwrap())
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        v
    };
    let before = listing();
    let e = SimConfig::default().write_file(sub.join("..")).unwrap_err();
    assert!(
        matches!(&e, ArmSimError::ConfigIo { message, .. } if message == "not a file path"),
        "{e}"
    );
    assert_eq!(listing(), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A configuration `read_file` would refuse (a NaN, which JSON writes as `null`; a size out of
/// range) used to be written, as a file that does not read back. It is refused with the error
/// reading would give, and no file is created or changed.
#[test]
fn write_file_refuses_what_read_file_would_refuse() {
    let dir = std::env::temp_dir().join(format!("arm-sim-invalid-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("arm.json");
    SimConfig::default().write_file(&path).unwrap();
    let old = std::fs::read(&path).unwrap();
    let mut nan = SimConfig::default();
    nan.arm.forearm_mm = f64::NAN;
    let mut huge = SimConfig::default();
    huge.arm.hand_mm = 1e300;
    for bad in [nan, huge] {
        let want = bad.validate().unwrap_err().to_string();
        let e = bad.write_file(&path).unwrap_err();
        assert_eq!(e.to_string(), want);
        assert!(matches!(e, ArmSimError::InvalidConfig { .. }), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), old);
        assert!(bad.write_file(dir.join("new.json")).is_err());
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "a file appeared"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Arm files with nonsense sizes used to load and then give NaN or absurd joint angles: masses
/// given in grams instead of kilograms sagged the shoulder by millions of degrees, and links of
/// 1e308 mm overflowed the kinematics to a NaN pose (a NaN tip, images of nothing).
#[test]
fn absurd_arm_sizes_and_sag_are_refused() {
    let check = |f: &dyn Fn(&mut SimConfig), key: &str| {
        let mut c = SimConfig::default();
        f(&mut c);
        let text = c.to_json();
        assert_eq!(key_of(c.validate().unwrap_err()), key);
        assert_eq!(key_of(SimConfig::from_json(&text).unwrap_err()), key);
        assert!(ArmSim::new(c).is_err());
    };
    // Grams for kilograms.
    check(
        &|c| c.sag.masses_kg = [35.0, 30.0, 55.0, 60.0, 50.0],
        "sag.masses_kg",
    );
    check(&|c| c.sag.masses_kg = [1e300; 5], "sag.masses_kg");
    check(&|c| c.sag.masses_kg[4] = 1e308, "sag.masses_kg");
    // At the compliance limit, ten times the default masses sag more than 45° at full reach.
    check(
        &|c| {
            c.sag.compliance_deg_per_nm = [100.0; 3];
            c.sag.masses_kg = c.sag.masses_kg.map(|m| 10.0 * m);
        },
        "sag.masses_kg",
    );
    check(&|c| c.arm.base_height_mm = 1e308, "arm.base_height_mm");
    check(
        &|c| {
            c.arm.upper_arm_mm = 1e308;
            c.arm.forearm_mm = 1e308;
        },
        "arm.upper_arm_mm",
    );
    check(&|c| c.arm.max_opening_mm = 1e308, "arm.max_opening_mm");
    check(&|c| c.arm.servo_radius_mm = 1e308, "arm.servo_radius_mm");
    // Heavy but rigid: the masses do not matter.
    let mut c = SimConfig::default();
    c.sag.compliance_deg_per_nm = [0.0; 3];
    c.sag.masses_kg = [1e6; 5];
    c.validate().unwrap();
    // The shipped arms (worn: twice the default compliance) stay valid.
    let mut c = SimConfig::default();
    c.sag.compliance_deg_per_nm = [8.0, 10.0, 12.0];
    c.validate().unwrap();
}

/// A fresh scratch folder for one test.
fn scratch_dir(what: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("arm-sim-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Set in the child process of [`in_child`]: the test runs its child part.
const CHILD: &str = "ARM_SIM_TEST_WRITE_CHILD";

/// Runs the test `test` of this binary alone in a child process whose working folder is `cwd`
/// (so the child can write to a bare file name), with [`CHILD`] set; with `limit`, under a file
/// size limit of one block (`ulimit -f 1`, 512 or 1024 bytes): a write past it fails with
/// `EFBIG`, like a full disk, even for root, with `SIGXFSZ` ignored so that it is an error
/// rather than the end of the process. Returns the child's standard output.
#[cfg(unix)]
fn in_child(test: &str, cwd: &std::path::Path, limit: bool) -> String {
    let run = r#"exec "$0" "$@""#;
    let script = if limit {
        format!("trap '' XFSZ; ulimit -f 1 && {run}")
    } else {
        run.to_string()
    };
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(std::env::current_exe().unwrap())
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .current_dir(cwd)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "the child failed ({}): {stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// A bare file name (`Path::parent()` is `Some("")`) is written into the working folder, with
/// its temporary file there too: nothing else is left behind.
#[cfg(unix)]
#[test]
fn write_file_to_a_bare_file_name_lands_in_the_working_folder() {
    if std::env::var_os(CHILD).is_some() {
        SimConfig::default().write_file("arm.json").unwrap();
        return;
    }
    let dir = scratch_dir("bare");
    in_child(
        "config::write_file_to_a_bare_file_name_lands_in_the_working_folder",
        &dir,
        false,
    );
    assert_eq!(names_in(&dir), ["arm.json"]);
    assert_eq!(
        SimConfig::read_file(dir.join("arm.json")).unwrap(),
        SimConfig::default()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A write that fails part-way (a file size limit, as a full disk would) is a `ConfigIo` error
/// naming the file; the file already there keeps every byte, and no temporary file is left.
#[cfg(unix)]
#[test]
fn write_file_failing_part_way_keeps_the_old_file_and_leaves_nothing_else() {
    if std::env::var_os(CHILD).is_some() {
        match SimConfig::default().write_file("arm.json") {
            Err(ArmSimError::ConfigIo { path, message }) => {
                println!("refused: path {path:?}, {message}")
            }
            other => panic!("expected ConfigIo, got {other:?}"),
        }
        return;
    }
    let dir = scratch_dir("full");
    let path = dir.join("arm.json");
    SimConfig::ideal().write_file(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    // Larger than the limit (at most 1024 bytes).
    assert!(SimConfig::default().to_json().len() > 2048);
    let out = in_child(
        "config::write_file_failing_part_way_keeps_the_old_file_and_leaves_nothing_else",
        &dir,
        true,
    );
    assert!(
        out.contains(r#"refused: path "arm.json", File too large"#),
        "{out}"
    );
    assert!(std::fs::read(&path).unwrap() == before, "arm.json changed");
    assert_eq!(names_in(&dir), ["arm.json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A write that fails after everything was written (the target is a folder, so the rename
/// fails) or before (the parent is a file, or missing) is a `ConfigIo` error naming the path,
/// and leaves nothing behind: no temporary file, the folder as it was.
#[test]
fn a_failed_write_file_names_the_path_and_leaves_no_temporary_file() {
    let dir = scratch_dir("failed");
    std::fs::create_dir_all(dir.join("arm.json").join("inside")).unwrap();
    std::fs::write(dir.join("file"), b"a file, not a folder").unwrap();
    for path in [
        dir.join("arm.json"),
        dir.join("file").join("arm.json"),
        dir.join("missing").join("arm.json"),
    ] {
        let e = SimConfig::default().write_file(&path).unwrap_err();
        assert!(
            matches!(&e, ArmSimError::ConfigIo { path: p, .. } if *p == path.display().to_string()),
            "{}: {e}",
            path.display()
        );
    }
    assert_eq!(names_in(&dir), ["arm.json", "file"]);
    assert_eq!(names_in(&dir.join("arm.json")), ["inside"]);
    assert_eq!(
        std::fs::read(dir.join("file")).unwrap(),
        b"a file, not a folder"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_table_too_large_for_its_texture_is_refused() {
    // The table's extent only had to be finite. Its texture hashes integer lattice coordinates
    // (`(x / 28 mm).floor() as i64` and the like): a camera looking along a table that reaches
    // 1e21 mm saturated them to i64::MAX, and the first capture overflowed `ix + 1` (a panic
    // in debug builds). An extent beyond ±1 km is refused now, naming the key.
    for (axis, key) in [(0, "scene.table.x_range_mm"), (1, "scene.table.y_range_mm")] {
        let far = |reach: f64| {
            let mut c = SimConfig::default().with_image_scale(0.05);
            c.cameras.truncate(1);
            c.cameras[0].position_mm = [0.0, 0.0, 1000.0];
            c.cameras[0].position_mm[axis] = reach;
            c.cameras[0].look_at_mm = [0.0; 3];
            let range = if axis == 0 {
                &mut c.scene.table.x_range_mm
            } else {
                &mut c.scene.table.y_range_mm
            };
            range[1] = 2.0 * reach;
            c
        };
        let c = far(1e21);
        if let Ok(mut sim) = ArmSim::new(c.clone()) {
            sim.capture();
            panic!("{key}: a table reaching 2e21 mm was accepted and rendered");
        }
        assert_eq!(key_of(c.validate().unwrap_err()), key);
        assert_eq!(key_of(SimConfig::from_json(&c.to_json()).unwrap_err()), key);
        let mut c = SimConfig::default();
        if axis == 0 {
            c.scene.table.x_range_mm[0] = -2e6;
        } else {
            c.scene.table.y_range_mm[0] = -2e6;
        }
        assert_eq!(key_of(c.validate().unwrap_err()), key);
        // At the limit: accepted, and the camera along it renders.
        let mut sim = ArmSim::new(far(5e5)).unwrap();
        assert_eq!(sim.capture().len(), 1);
    }
}
