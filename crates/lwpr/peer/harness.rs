//! Shared by `tests/integration/reference.rs` and `cargo xtask bench lwpr` (included with
//! `#[path]`, not part of the library): the cross-function data of the reference's benchmark, and
//! building and running the reference C library (LGPL, from `../shared/peers/lwpr`, built under
//! `target/peers/lwpr`, never copied into this repository) through `peer/lwpr_peer.c`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The cross function of docs/methods.md § LWPR.
pub fn cross(x1: f64, x2: f64) -> f64 {
    let a = (-10.0 * x1 * x1).exp();
    let b = (-50.0 * x2 * x2).exp();
    let c = 1.25 * (-5.0 * (x1 * x1 + x2 * x2)).exp();
    let m = if a > b { a } else { b };
    if m > c { m } else { c }
}

/// splitmix64 + Box–Muller, the generator of the reference's `bench_cross.c`, so that a seed
/// gives exactly the benchmark's samples.
pub struct Rng {
    state: u64,
    spare: Option<f64>,
}

impl Rng {
    /// Seeded generator.
    pub fn new(seed: u64) -> Self {
        Rng {
            state: seed,
            spare: None,
        }
    }
    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) with 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / 9007199254740992.0)
    }
    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let t = std::f64::consts::TAU * u2; // the C literal rounds to the same double
        self.spare = Some(r * t.sin());
        r * t.cos()
    }
}

/// `n` training samples of `bench_cross.c` (x ~ U[-1,1]², y = cross + N(0, σ²)).
pub fn cross_samples(seed: u64, n: usize, noise_sd: f64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Rng::new(seed);
    let (mut x, mut y) = (Vec::with_capacity(2 * n), Vec::with_capacity(n));
    for _ in 0..n {
        let a = 2.0 * rng.uniform() - 1.0;
        let b = 2.0 * rng.uniform() - 1.0;
        x.push(a);
        x.push(b);
        y.push(cross(a, b) + noise_sd * rng.normal());
    }
    (x, y)
}

/// The 41 × 41 test grid over [-1, 1]² (x₁ fastest) and its noise-free targets.
pub fn cross_grid() -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for i in 0..41 * 41 {
        let a = -1.0 + 0.05 * (i % 41) as f64;
        let b = -1.0 + 0.05 * (i / 41) as f64;
        x.push(a);
        x.push(b);
        y.push(cross(a, b));
    }
    (x, y)
}

/// A random rotation of R^dim (QR of a Gaussian matrix by Gram–Schmidt), column-major.
pub fn random_rotation(dim: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let mut q: Vec<f64> = (0..dim * dim).map(|_| rng.normal()).collect();
    for j in 0..dim {
        for k in 0..j {
            let d: f64 = (0..dim).map(|i| q[i + j * dim] * q[i + k * dim]).sum();
            for i in 0..dim {
                q[i + j * dim] -= d * q[i + k * dim];
            }
        }
        let nrm: f64 = (0..dim)
            .map(|i| q[i + j * dim] * q[i + j * dim])
            .sum::<f64>()
            .sqrt();
        for i in 0..dim {
            q[i + j * dim] /= nrm;
        }
    }
    q
}

/// Embeds 2-D points into `dim` dimensions: `Q (x₁, x₂, 0, …, 0)ᵀ`.
pub fn embed(x2: &[f64], q: &[f64], dim: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(x2.len() / 2 * dim);
    for p in x2.chunks(2) {
        for i in 0..dim {
            out.push(q[i] * p[0] + q[i + dim] * p[1]);
        }
    }
    out
}

/// Setting A of docs/methods.md § LWPR (the reference's cross example, `bench_cross.c`) for `dim`
/// inputs and one output: `init_D = 50 I`, `init_alpha = 250`, `w_gen = 0.2`, the rest default.
pub fn setting_a_builder(dim: usize) -> lwpr::LwprBuilder {
    lwpr::LwprBuilder::new(dim, 1)
        .init_d_spherical(50.0)
        .init_alpha(250.0)
        .w_gen(0.2)
}

/// Setting B of docs/methods.md § LWPR (500 samples, 20 epochs) for 2 inputs and one output:
/// `init_D = 25 I`, `init_alpha = 250`, `w_gen = 0.2`, full metric, meta learning.
pub fn setting_b_builder() -> lwpr::LwprBuilder {
    lwpr::LwprBuilder::new(2, 1)
        .init_d_spherical(25.0)
        .init_alpha(250.0)
        .w_gen(0.2)
        .diag_only(false)
        .meta(true)
}

/// One pass of single-output samples (`x` row-major, `y.len()` rows) through `model.update`.
pub fn train(model: &mut lwpr::Lwpr, x: &[f64], y: &[f64]) -> Result<(), lwpr::LwprError> {
    let dim = x.len() / y.len().max(1);
    for (a, b) in x.chunks(dim).zip(y) {
        model.update(a, &[*b])?;
    }
    Ok(())
}

/// The reference library's 25-D test settings (docs/methods.md § LWPR) for `dim` inputs and one
/// output: `init_D = 0.25 I`, `init_alpha = 250`, `w_gen = 0.2`, `w_prune = 0.7`, full metric, meta
/// learning. The pruning rule and the arithmetic are left to the caller.
pub fn setting_25d(dim: usize) -> lwpr::LwprBuilder {
    lwpr::LwprBuilder::new(dim, 1)
        .init_d_spherical(0.25)
        .init_alpha(250.0)
        .w_gen(0.2)
        .w_prune(0.7)
        .diag_only(false)
        .meta(true)
}

/// nMSE: mean squared error over the population variance of the targets.
pub fn nmse(pred: &[f64], target: &[f64]) -> f64 {
    let n = target.len() as f64;
    let mean = target.iter().sum::<f64>() / n;
    let var = target.iter().map(|t| (t - mean) * (t - mean)).sum::<f64>() / n;
    let mse = pred
        .iter()
        .zip(target)
        .map(|(p, t)| (p - t) * (p - t))
        .sum::<f64>()
        / n;
    mse / var
}

/// Largest absolute element-wise difference of two prediction vectors (over the common length).
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// C compiler flags of the reference library and its driver: the optimisation level of our
/// release build (cargo's `opt-level = 3`), for the same baseline x86-64 target (no
/// `-march=native`; our AVX2 paths are picked at run time) and without `-ffast-math`, like
/// ours. The reference's own `build.sh` uses `-O2`; its objects are recompiled with these.
pub const PEER_CFLAGS: &[&str] = &["-O3"];

/// Finds the reference library (env `LWPR_PEER_DIR`, else `<workspace>/../shared/peers/lwpr`),
/// builds it and the driver into `<workspace>/target/peers/lwpr` and returns the driver's path,
/// or the reason why that is impossible.
pub fn build_peer(workspace: &Path) -> Result<PathBuf, String> {
    build_driver(workspace, "lwpr_peer", false)
}

/// Like [`build_peer`] for `peer/lwpr_xml_peer.c`, which reads XML model files: the reference's
/// XML reader needs libexpat (Debian: `libexpat1-dev`), so the library is compiled with
/// `HAVE_LIBEXPAT 1` (a copy of `build.sh`'s generated `lwpr_config.h` with that one line
/// changed) and linked with `-lexpat`.
pub fn build_xml_peer(workspace: &Path) -> Result<PathBuf, String> {
    build_driver(workspace, "lwpr_xml_peer", true)
}

fn build_driver(workspace: &Path, name: &str, expat: bool) -> Result<PathBuf, String> {
    let src = std::env::var_os("LWPR_PEER_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join("../shared/peers/lwpr"));
    if !src.join("build.sh").exists() {
        return Err(format!(
            "reference LWPR not found at {} (set LWPR_PEER_DIR)",
            src.display()
        ));
    }
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    if Command::new(&cc).arg("--version").output().is_err() {
        return Err(format!(
            "no C compiler (`{cc}`) to build the reference LWPR"
        ));
    }
    // Tests in several threads and processes may get here at once: build in a private
    // staging folder and move the finished driver into place with an atomic rename, so that
    // nobody ever executes a half-written binary.
    static BUILDING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = BUILDING.lock().unwrap_or_else(|e| e.into_inner());
    let peers = workspace.join("target/peers");
    let driver = peers
        .join(format!("lwpr{}", PEER_CFLAGS.concat()))
        .join(name);
    let driver_src = workspace.join(format!("crates/lwpr/peer/{name}.c"));
    let fresh = |p: &Path| p.metadata().and_then(|m| m.modified()).ok();
    if driver.exists() && fresh(&driver) >= fresh(&driver_src) {
        return Ok(driver);
    }
    let out = peers.join(format!("{name}.staging-{}", std::process::id()));
    // Removed however this ends (a failed build script or compile included), so no half-built
    // staging folder is left in `target/peers`.
    let _staging = RemoveOnDrop(out.clone());
    let st = Command::new("bash")
        .arg(src.join("build.sh"))
        .arg(&out)
        .output()
        .map_err(|e| format!("cannot run build.sh: {e}"))?;
    if !st.status.success() {
        return Err(format!(
            "building the reference failed: {}",
            String::from_utf8_lossy(&st.stderr)
        ));
    }
    if expat {
        let config = out.join("lwpr_config.h");
        let text = std::fs::read_to_string(&config).map_err(|e| e.to_string())?;
        if !text.contains("#define HAVE_LIBEXPAT 0") {
            return Err("build.sh's lwpr_config.h no longer defines HAVE_LIBEXPAT 0".into());
        }
        std::fs::write(
            &config,
            text.replace("#define HAVE_LIBEXPAT 0", "#define HAVE_LIBEXPAT 1"),
        )
        .map_err(|e| e.to_string())?;
    }
    // Recompile the library with PEER_CFLAGS (build.sh wrote lwpr_config.h into `out`).
    let mut objects = Vec::new();
    for f in [
        "lwpr",
        "lwpr_aux",
        "lwpr_binio",
        "lwpr_math",
        "lwpr_mem",
        "lwpr_xml",
    ] {
        let obj = out.join(format!("{f}.peer.o"));
        let st = Command::new(&cc)
            .args(PEER_CFLAGS)
            .arg(format!("-I{}", out.display()))
            .arg(format!("-I{}", src.join("include").display()))
            .arg("-c")
            .arg(src.join("src").join(format!("{f}.c")))
            .arg("-o")
            .arg(&obj)
            .output()
            .map_err(|e| format!("cannot run {cc}: {e}"))?;
        if !st.status.success() {
            return Err(format!(
                "compiling the reference's {f}.c failed{}: {}",
                if expat {
                    " (its XML reader needs libexpat: install libexpat1-dev)"
                } else {
                    ""
                },
                String::from_utf8_lossy(&st.stderr)
            ));
        }
        objects.push(obj);
    }
    let staged = out.join(name);
    let st = Command::new(&cc)
        .args(PEER_CFLAGS)
        .arg("-o")
        .arg(&staged)
        .arg(format!("-I{}", out.display()))
        .arg(format!("-I{}", src.join("include").display()))
        .arg(&driver_src)
        .args(&objects)
        .args(if expat {
            &["-lexpat", "-lm"][..]
        } else {
            &["-lm"][..]
        })
        .output()
        .map_err(|e| format!("cannot run {cc}: {e}"))?;
    if !st.status.success() {
        return Err(format!(
            "building the driver failed: {}",
            String::from_utf8_lossy(&st.stderr)
        ));
    }
    let place = |e: std::io::Error| format!("cannot move the driver into place: {e}");
    std::fs::create_dir_all(driver.parent().expect("driver has a folder")).map_err(place)?;
    std::fs::rename(&staged, &driver).map_err(place)?;
    Ok(driver)
}

/// A scratch folder removed with everything in it when this goes out of scope, on every path
/// out of the function that made it.
struct RemoveOnDrop(PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `Ok(value)`, or `None` with a printed note when the reference cannot be used; with
/// `CI=true` a failure instead (strict CI: a cross-check that cannot run must not pass).
pub fn or_skip<T>(built: Result<T, String>, what: &str) -> Option<T> {
    let reason = match built {
        Ok(v) => return Some(v),
        Err(reason) => reason,
    };
    let ci = std::env::var("CI").is_ok_and(|v| v == "true");
    assert!(
        !ci,
        "{what}: the reference LWPR is required with CI=true: {reason}"
    );
    eprintln!("SKIPPED {what}: {reason}");
    None
}

/// The reference driver, or `None` with a printed note when it cannot be built; with
/// `CI=true` a failure instead (strict CI: a cross-check that cannot run must not pass).
pub fn peer_or_skip(workspace: &Path, what: &str) -> Option<PathBuf> {
    or_skip(build_peer(workspace), what)
}

/// Settings handed to the reference (a subset of `lwpr::Params`, same names).
pub struct PeerSettings<'a> {
    pub n_in: usize,
    pub n_out: usize,
    pub diag_only: bool,
    pub meta: bool,
    pub update_d: bool,
    pub bisquare: bool,
    pub meta_rate: f64,
    pub penalty: f64,
    pub init_alpha: f64,
    pub w_gen: f64,
    pub w_prune: f64,
    pub init_lambda: f64,
    pub final_lambda: f64,
    pub tau_lambda: f64,
    pub init_s2: f64,
    pub add_threshold: f64,
    pub init_d: &'a [f64],
    pub norm_in: &'a [f64],
    pub norm_out: &'a [f64],
}

impl<'a> PeerSettings<'a> {
    /// The settings of `model`'s parameters, for the reference to start from the same state.
    pub fn of(model: &'a lwpr::Lwpr) -> Self {
        let p = model.params();
        PeerSettings {
            n_in: p.n_in,
            n_out: p.n_out,
            diag_only: p.diag_only,
            meta: p.meta,
            update_d: p.update_d,
            bisquare: p.kernel == lwpr::Kernel::BiSquare,
            meta_rate: p.meta_rate,
            penalty: p.penalty,
            init_alpha: p.init_alpha[0],
            w_gen: p.w_gen,
            w_prune: p.w_prune,
            init_lambda: p.init_lambda,
            final_lambda: p.final_lambda,
            tau_lambda: p.tau_lambda,
            init_s2: p.init_s2,
            add_threshold: p.add_threshold,
            init_d: &p.init_d,
            norm_in: &p.norm_in,
            norm_out: &p.norm_out,
        }
    }
}

/// What the reference produced.
pub struct PeerRun {
    /// Per checkpoint: receptive fields per output and test predictions.
    pub checkpoints: Vec<(Vec<usize>, Vec<f64>)>,
    /// Predictions returned by every `lwpr_update`.
    pub update_predictions: Vec<f64>,
    /// Seconds spent in `lwpr_update` only.
    pub update_seconds: f64,
    /// `lwpr_predict` calls per second over repeated passes of the test set.
    pub predictions_per_second: f64,
}

/// Runs the reference on the given samples.
pub fn run_peer(
    driver: &Path,
    s: &PeerSettings,
    x: &[f64],
    y: &[f64],
    x_test: &[f64],
    checkpoints: &[usize],
) -> Result<PeerRun, String> {
    run_peer_with_xml(driver, s, x, y, x_test, checkpoints, None)
}

/// [`run_peer`], and with `xml` the trained model is written there by `lwpr_write_xml`.
pub fn run_peer_with_xml(
    driver: &Path,
    s: &PeerSettings,
    x: &[f64],
    y: &[f64],
    x_test: &[f64],
    checkpoints: &[usize],
    xml: Option<&Path>,
) -> Result<PeerRun, String> {
    let mut b: Vec<u8> = Vec::new();
    let i32le = |b: &mut Vec<u8>, v: i64| b.extend_from_slice(&(v as i32).to_le_bytes());
    let f64le = |b: &mut Vec<u8>, v: f64| b.extend_from_slice(&v.to_le_bytes());
    for v in [
        s.n_in as i64,
        s.n_out as i64,
        s.diag_only as i64,
        s.meta as i64,
        s.update_d as i64,
        s.bisquare as i64,
    ] {
        i32le(&mut b, v);
    }
    for v in [
        s.meta_rate,
        s.penalty,
        s.init_alpha,
        s.w_gen,
        s.w_prune,
        s.init_lambda,
        s.final_lambda,
        s.tau_lambda,
        s.init_s2,
        s.add_threshold,
    ] {
        f64le(&mut b, v);
    }
    for &v in s.init_d.iter().chain(s.norm_in).chain(s.norm_out) {
        f64le(&mut b, v);
    }
    let n_train = x.len() / s.n_in;
    i32le(&mut b, n_train as i64);
    for &v in x.iter().chain(y) {
        f64le(&mut b, v);
    }
    let n_test = x_test.len() / s.n_in;
    i32le(&mut b, n_test as i64);
    for &v in x_test {
        f64le(&mut b, v);
    }
    i32le(&mut b, checkpoints.len() as i64);
    for &c in checkpoints {
        i32le(&mut b, c as i64);
    }
    let o = run_driver(driver, None, &b, xml)?;
    let mut pos = 0;
    let mut rd = |k: usize| -> Result<&[u8], String> {
        let s = o.get(pos..pos + k).ok_or("short driver output")?;
        pos += k;
        Ok(s)
    };
    let mut cks = Vec::new();
    for _ in checkpoints {
        let mut nrf = Vec::new();
        for _ in 0..s.n_out {
            nrf.push(i32::from_le_bytes(rd(4)?.try_into().unwrap()) as usize);
        }
        let mut p = Vec::new();
        for _ in 0..n_test * s.n_out {
            p.push(f64::from_le_bytes(rd(8)?.try_into().unwrap()));
        }
        cks.push((nrf, p));
    }
    let mut yp = Vec::new();
    for _ in 0..n_train * s.n_out {
        yp.push(f64::from_le_bytes(rd(8)?.try_into().unwrap()));
    }
    let update_seconds = f64::from_le_bytes(rd(8)?.try_into().unwrap());
    let predictions_per_second = f64::from_le_bytes(rd(8)?.try_into().unwrap());
    Ok(PeerRun {
        checkpoints: cks,
        update_predictions: yp,
        update_seconds,
        predictions_per_second,
    })
}

/// What the reference made of an XML model file (`peer/lwpr_xml_peer.c`).
pub struct XmlPeerRun {
    /// Receptive fields per output as read.
    pub num_rfs: Vec<usize>,
    /// Per test point: predictions (`n_out`).
    pub y: Vec<f64>,
    /// Per test point: confidence bounds (`n_out`).
    pub conf: Vec<f64>,
    /// Per test point: the Jacobian, `n_out × n_in` row-major (output after output).
    pub jacobian: Vec<f64>,
    /// Predictions returned by `lwpr_update` while training on from the file.
    pub update_predictions: Vec<f64>,
    /// Receptive fields per output after that training.
    pub num_rfs_after: Vec<usize>,
    /// Test predictions after that training.
    pub y_after: Vec<f64>,
}

/// Has the reference read `xml` (`lwpr_read_xml`), predict at `x_test`, then train on `(x, y)`.
pub fn run_xml_peer(
    driver: &Path,
    xml: &Path,
    x_test: &[f64],
    x: &[f64],
    y: &[f64],
    n_in: usize,
    n_out: usize,
) -> Result<XmlPeerRun, String> {
    let mut b: Vec<u8> = Vec::new();
    let n_test = x_test.len() / n_in;
    let n_train = x.len() / n_in;
    b.extend_from_slice(&(n_test as i32).to_le_bytes());
    x_test
        .iter()
        .for_each(|v| b.extend_from_slice(&v.to_le_bytes()));
    b.extend_from_slice(&(n_train as i32).to_le_bytes());
    x.iter()
        .chain(y)
        .for_each(|v| b.extend_from_slice(&v.to_le_bytes()));
    let o = run_driver(driver, Some(xml), &b, None)?;
    let mut r = Bytes { data: &o, pos: 0 };
    let dims = r.ints(2)?;
    if dims != [n_in, n_out] {
        return Err(format!("the reference read dimensions {dims:?}"));
    }
    let num_rfs = r.ints(n_out)?;
    let (mut yv, mut conf, mut jacobian) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..n_test {
        yv.extend(r.floats(n_out)?);
        conf.extend(r.floats(n_out)?);
        let j = r.floats(n_out * n_in)?;
        // column-major → row-major
        for i in 0..n_out {
            for k in 0..n_in {
                jacobian.push(j[i + k * n_out]);
            }
        }
    }
    Ok(XmlPeerRun {
        num_rfs,
        y: yv,
        conf,
        jacobian,
        update_predictions: r.floats(n_train * n_out)?,
        num_rfs_after: r.ints(n_out)?,
        y_after: r.floats(n_test * n_out)?,
    })
}

/// Runs `driver [lead] IN OUT [tail]` with `input` written to IN in a scratch folder, and
/// returns what it wrote to OUT.
fn run_driver(
    driver: &Path,
    lead: Option<&Path>,
    input: &[u8],
    tail: Option<&Path>,
) -> Result<Vec<u8>, String> {
    static RUN: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let run = RUN.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("lwpr-peer-{}-{run}", std::process::id()));
    let _scratch = RemoveOnDrop(dir.clone());
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let (inp, outp) = (dir.join("in.bin"), dir.join("out.bin"));
    std::fs::write(&inp, input).map_err(|e| e.to_string())?;
    let st = Command::new(driver)
        .args(lead)
        .arg(&inp)
        .arg(&outp)
        .args(tail)
        .output()
        .map_err(|e| format!("cannot run the driver: {e}"))?;
    if !st.status.success() {
        return Err(format!(
            "the driver {} failed ({}): {}",
            driver.display(),
            st.status,
            String::from_utf8_lossy(&st.stderr)
        ));
    }
    std::fs::read(&outp).map_err(|e| e.to_string())
}

/// Little-endian values of a driver's output, in order.
struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl Bytes<'_> {
    fn take<const K: usize>(&mut self) -> Result<[u8; K], String> {
        let s = self
            .data
            .get(self.pos..self.pos + K)
            .ok_or("short driver output")?;
        self.pos += K;
        Ok(s.try_into().expect("K bytes"))
    }
    fn ints(&mut self, k: usize) -> Result<Vec<usize>, String> {
        (0..k)
            .map(|_| self.take::<4>().map(|a| i32::from_le_bytes(a) as usize))
            .collect()
    }
    fn floats(&mut self, k: usize) -> Result<Vec<f64>, String> {
        (0..k)
            .map(|_| self.take::<8>().map(f64::from_le_bytes))
            .collect()
    }
}
