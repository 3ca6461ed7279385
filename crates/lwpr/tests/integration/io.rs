//! Save and load: exact round trips, and corrupt or truncated input is an error, not a panic.

use crate::harness;

use harness::*;
use lwpr::{Lwpr, LwprBuilder, LwprError};

fn trained() -> Lwpr {
    let mut m = LwprBuilder::new(2, 2)
        .init_d_spherical(40.0)
        .w_gen(0.2)
        .diag_only(false)
        .meta(true)
        .norm_out(&[1.0, 3.0])
        .build()
        .unwrap();
    let (x, y) = cross_samples(4, 1500, 0.05);
    for (a, b) in x.chunks(2).zip(&y) {
        m.update(a, &[*b, a[0] - a[1]]).unwrap();
    }
    m
}

fn same_future(mut a: Lwpr, mut b: Lwpr) {
    let (gx, _) = cross_grid();
    assert_eq!(
        a.predict_batch(&gx, 0.001).unwrap(),
        b.predict_batch(&gx, 0.001).unwrap()
    );
    let (x, y) = cross_samples(5, 300, 0.05);
    for (p, q) in x.chunks(2).zip(&y) {
        assert_eq!(
            a.update(p, &[*q, 0.0]).unwrap(),
            b.update(p, &[*q, 0.0]).unwrap()
        );
    }
    assert_eq!(a, b);
}

#[test]
fn json_round_trip_is_exact() {
    let m = trained();
    let back = Lwpr::from_json(&m.to_json()).unwrap();
    assert_eq!(m, back);
    same_future(m, back);
}

#[test]
fn binary_round_trip_is_exact_and_compact() {
    let m = trained();
    let bin = m.to_binary();
    let back = Lwpr::from_binary(&bin).unwrap();
    assert_eq!(m, back);
    assert!(bin.len() < m.to_json().len());
    same_future(m, back);
}

#[test]
fn files_round_trip_in_both_forms() {
    let m = trained();
    let dir = std::env::temp_dir().join(format!("lwpr-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["model.json", "model.bin"] {
        m.save(dir.join(name)).unwrap();
        assert_eq!(Lwpr::load(dir.join(name)).unwrap(), m);
    }
    // A file that cannot be read is an I/O error naming it, for both readers.
    let missing = dir.join("missing.bin");
    for e in [Lwpr::load(&missing), Lwpr::load_xml(&missing)] {
        match e {
            Err(LwprError::Io(m)) => assert!(m.contains(&*missing.to_string_lossy()), "{m}"),
            other => panic!("{other:?}"),
        }
    }
    std::fs::write(dir.join("junk"), [0xff, 0xfe, 0x00]).unwrap();
    assert!(matches!(
        Lwpr::load(dir.join("junk")),
        Err(LwprError::Format(_))
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn every_truncation_and_byte_flip_of_binary_is_rejected() {
    let m = trained();
    let bin = m.to_binary();
    let step = (bin.len() / 997).max(1);
    for len in (0..bin.len()).step_by(step) {
        assert!(
            matches!(Lwpr::from_binary(&bin[..len]), Err(LwprError::Format(_))),
            "length {len}"
        );
    }
    for pos in (0..bin.len()).step_by(step) {
        let mut c = bin.clone();
        c[pos] ^= 0x5a;
        assert!(Lwpr::from_binary(&c).is_err(), "flip at {pos}");
    }
    let mut longer = bin.clone();
    longer.push(0);
    assert!(Lwpr::from_binary(&longer).is_err());
}

#[test]
fn corrupt_json_is_rejected() {
    let m = trained();
    let json = m.to_json();
    for len in (0..json.len()).step_by(json.len() / 200) {
        assert!(Lwpr::from_json(&json[..len]).is_err(), "length {len}");
    }
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        f(&mut v);
        Lwpr::from_json(&v.to_string())
    };
    assert!(edit(&|v| v["version"] = 99.into()).is_err());
    assert!(edit(&|v| v["format"] = "other".into()).is_err());
    assert!(edit(&|v| v["model"]["sub"][0]["rfs"][0]["n_reg"] = 7.into()).is_err());
    assert!(edit(&|v| v["model"]["sub"][0]["rfs"][0]["c"] = serde_json::json!([0.0])).is_err());
    assert!(edit(&|v| v["model"]["sub"][0]["rfs"][0]["ss_s2"][0] = (-1.0).into()).is_err());
    assert!(edit(&|v| v["model"]["params"]["w_gen"] = 2.0.into()).is_err());
    assert!(edit(&|v| v["model"]["params"]["init_m"][0] = 1.0.into()).is_err());
    assert!(
        edit(&|v| v["model"]["sub"]
            .as_array_mut()
            .unwrap()
            .pop()
            .map(|_| ())
            .unwrap())
        .is_err()
    );
    assert!(edit(&|v| v["model"]["mean_x"] = serde_json::json!([0.0])).is_err());
    // Training relies on an exactly symmetric metric: one upper element changed is refused.
    assert!(edit(&|v| v["model"]["sub"][0]["rfs"][0]["d"][2] = 1.25.into()).is_err());
    // Unchanged it loads.
    assert!(edit(&|_| ()).is_ok());
}

#[test]
fn arithmetic_choice_survives_both_forms() {
    let mut m = LwprBuilder::new(6, 1)
        .diag_only(false)
        .arithmetic(lwpr::Arithmetic::Reference)
        .build()
        .unwrap();
    m.update(&[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], &[1.0]).unwrap();
    for back in [
        Lwpr::from_binary(&m.to_binary()).unwrap(),
        Lwpr::from_json(&m.to_json()).unwrap(),
    ] {
        assert_eq!(back.params().arithmetic, lwpr::Arithmetic::Reference);
        assert_eq!(back, m);
    }
}

#[test]
fn save_writes_binary_for_bin_and_json_otherwise() {
    // `files_round_trip_in_both_forms` cannot tell: `load` detects either format by content.
    let m = trained();
    let dir = std::env::temp_dir().join(format!("lwpr-io-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    m.save(dir.join("model.bin")).unwrap();
    // `assert!(a == b)`: a failure should name the file, not print the model.
    let bin = std::fs::read(dir.join("model.bin")).unwrap();
    assert!(bin == m.to_binary(), "model.bin is not the binary form");
    for name in ["model.json", "model.txt", "model", "model.bin.json"] {
        m.save(dir.join(name)).unwrap();
        let text = std::fs::read(dir.join(name)).unwrap();
        assert!(
            text == m.to_json().into_bytes(),
            "{name} is not the JSON form"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A fresh scratch folder for one test.
fn scratch_dir(what: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("lwpr-io-{what}-{}", std::process::id()));
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
const CHILD: &str = "LWPR_TEST_WRITE_CHILD";

/// Runs the test `test` of this binary alone in a child process whose working folder is `cwd`
/// (so the child can save to a bare file name), with [`CHILD`] set; with `limit`, under a file
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

/// The three files a model is saved to: JSON, binary and XML.
const FORMS: [&str; 3] = ["model.json", "model.bin", "model.xml"];

/// Saves `m` to `name` in the form its extension says.
fn save_as(m: &Lwpr, name: impl AsRef<std::path::Path>) -> Result<(), LwprError> {
    let name = name.as_ref();
    if name.extension().is_some_and(|e| e == "xml") {
        m.save_xml(name)
    } else {
        m.save(name)
    }
}

/// A bare file name (`Path::parent()` is `Some("")`) saves into the working folder, with its
/// temporary file there too: nothing else is left behind.
#[cfg(unix)]
#[test]
fn saves_to_a_bare_file_name_land_in_the_working_folder() {
    let m = trained();
    if std::env::var_os(CHILD).is_some() {
        for name in FORMS {
            save_as(&m, name).unwrap();
        }
        return;
    }
    let dir = scratch_dir("bare");
    in_child(
        "io::saves_to_a_bare_file_name_land_in_the_working_folder",
        &dir,
        false,
    );
    assert_eq!(names_in(&dir), ["model.bin", "model.json", "model.xml"]);
    for name in FORMS {
        assert!(Lwpr::load(dir.join(name)).unwrap() == m, "{name}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A save whose write fails part-way (a file size limit, as a full disk would) is an `Io`
/// error naming the file; the model file already there keeps every byte, and no temporary file
/// is left behind.
#[cfg(unix)]
#[test]
fn a_save_failing_part_way_keeps_the_old_file_and_leaves_nothing_else() {
    let m = trained();
    if std::env::var_os(CHILD).is_some() {
        for name in FORMS {
            match save_as(&m, name) {
                Err(LwprError::Io(msg)) => println!("refused {name}: {msg}"),
                other => panic!("{name}: expected an i/o error, got {other:?}"),
            }
        }
        return;
    }
    let dir = scratch_dir("full");
    let old = LwprBuilder::new(2, 2).build().unwrap();
    let mut before = Vec::new();
    for name in FORMS {
        save_as(&old, dir.join(name)).unwrap();
        before.push(std::fs::read(dir.join(name)).unwrap());
    }
    // Every form of the new model is larger than the limit (at most 1024 bytes).
    assert!(m.to_binary().len() > 4096 && m.to_json().len() > 4096 && m.to_xml().len() > 4096);
    let out = in_child(
        "io::a_save_failing_part_way_keeps_the_old_file_and_leaves_nothing_else",
        &dir,
        true,
    );
    for (name, old) in FORMS.iter().zip(&before) {
        let line = out
            .lines()
            .find(|l| l.contains(&format!("refused {name}: ")))
            .unwrap_or_else(|| panic!("{name} not refused: {out}"));
        assert!(
            line.contains(&format!("{name}: File too large")),
            "the error does not name the file: {line}"
        );
        assert!(
            std::fs::read(dir.join(name)).unwrap() == *old,
            "{name} changed"
        );
    }
    assert_eq!(names_in(&dir), ["model.bin", "model.json", "model.xml"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A save that fails after everything was written (the target is a folder, so the rename fails)
/// or before (the parent is a file) is an `Io` error naming the path, and leaves nothing behind:
/// no temporary file, the folder as it was.
#[test]
fn a_failed_save_names_the_path_and_leaves_no_temporary_file() {
    let m = trained();
    let dir = scratch_dir("failed");
    std::fs::create_dir_all(dir.join("model.json").join("inside")).unwrap();
    std::fs::write(dir.join("file"), b"a file, not a folder").unwrap();
    for path in [
        dir.join("model.json"),
        dir.join("file").join("model.bin"),
        dir.join("missing").join("model.bin"),
        // No file name: refused before any file is created.
        dir.join("model.json").join(".."),
        std::path::PathBuf::new(),
    ] {
        for e in [m.save(&path).unwrap_err(), m.save_xml(&path).unwrap_err()] {
            assert!(
                matches!(&e, LwprError::Io(msg) if msg.contains(&path.display().to_string())),
                "{}: {e}",
                path.display()
            );
        }
    }
    assert_eq!(names_in(&dir), ["file", "model.json"]);
    assert_eq!(names_in(&dir.join("model.json")), ["inside"]);
    assert_eq!(
        std::fs::read(dir.join("file")).unwrap(),
        b"a file, not a folder"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
