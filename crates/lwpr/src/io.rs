//! Saving and loading models: JSON (serde) and a compact little-endian binary form. Both carry
//! a format version; loading checks structure, sizes and finiteness, so a corrupt or truncated
//! input is an error and never a panic or a half-loaded model.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{LwprError, Result};
use crate::model::{Lwpr, SubModel};
use crate::params::{Arithmetic, Kernel, MAX_ABS_VALUE, Params, PruneRule, check_sizes};
use crate::rf::ReceptiveField;
use crate::workspace::Workspace;

/// Version of both the JSON envelope and the binary layout written now. Version 2 added
/// [`crate::Arithmetic`] to the parameters. Files of version 1 still load: their models were
/// trained in the reference's arithmetic, so they come back with [`Arithmetic::Reference`] and
/// go on training exactly as before.
pub const BINARY_FORMAT_VERSION: u32 = 2;

/// The oldest format version that still loads.
const OLDEST_FORMAT_VERSION: u32 = 1;

/// Checks a file's format version: `Err` unless it is one this build reads.
fn check_version(version: u32) -> Result<()> {
    if (OLDEST_FORMAT_VERSION..=BINARY_FORMAT_VERSION).contains(&version) {
        Ok(())
    } else {
        Err(fmt_err(format!(
            "unsupported format version {version} (this build reads {OLDEST_FORMAT_VERSION} to {BINARY_FORMAT_VERSION})"
        )))
    }
}
const MAGIC: &[u8; 8] = b"LWPR-RS\0";
const JSON_FORMAT: &str = "lwpr-rs";

/// Largest sample count `n_data` a loaded model may carry: far beyond any trained model (and
/// the largest count an `f64` holds exactly), so that counting on from it cannot overflow.
const MAX_N_DATA: u64 = 1 << 53;

/// The fewest bytes one receptive field takes in the binary form (`n_reg`, `trustworthy`,
/// four scalars and the lengths of 22 vectors), to bound a count read from the data.
const MIN_RF_BYTES: usize = 8 + 1 + 4 * 8 + 22 * 8;

/// The serialised fields of an [`Lwpr`]: plain serde reads this, then `TryFrom` runs every
/// check of a loaded model (so a deserialised model is as valid as a trained one).
#[derive(Deserialize)]
pub(crate) struct LwprData {
    params: Params,
    n_data: u64,
    mean_x: Vec<f64>,
    var_x: Vec<f64>,
    sub: Vec<SubModel>,
}

impl TryFrom<LwprData> for Lwpr {
    type Error = LwprError;
    fn try_from(d: LwprData) -> Result<Self> {
        Lwpr::from_parts(d.params, d.n_data, d.mean_x, d.var_x, d.sub)
    }
}

/// Relative tolerance of the check `D = MᵀM` on loading: `|D_ij − (MᵀM)_ij| ≤ 1e-9·√(D_ii D_jj)`
/// (training computes `D` from `M` in several summation orders, all within a few ulp).
pub const METRIC_TOLERANCE: f64 = 1e-9;

#[derive(Serialize, Deserialize)]
struct Envelope<M> {
    format: String,
    version: u32,
    model: M,
}

fn fmt_err(s: impl Into<String>) -> LwprError {
    LwprError::Format(s.into())
}

/// FNV-1a, 64 bit: detects corruption of the binary payload.
fn fnv1a(data: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in data {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

struct Enc(Vec<u8>);

impl Enc {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn bool(&mut self, v: bool) {
        self.0.push(v as u8);
    }
    fn vec(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.f64(x);
        }
    }
}

struct Dec<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Dec<'a> {
    fn take(&mut self, k: usize) -> Result<&'a [u8]> {
        let end = self
            .pos
            .checked_add(k)
            .filter(|&e| e <= self.data.len())
            .ok_or_else(|| fmt_err("truncated data"))?;
        let s = &self.data[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn usize(&mut self) -> Result<usize> {
        usize::try_from(self.u64()?).map_err(|_| fmt_err("size out of range"))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn bool(&mut self) -> Result<bool> {
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(fmt_err(format!("invalid boolean byte {b}"))),
        }
    }
    fn vec(&mut self) -> Result<Vec<f64>> {
        let len = self.usize()?;
        if len > (self.data.len() - self.pos) / 8 {
            return Err(fmt_err("truncated data (vector longer than the input)"));
        }
        (0..len).map(|_| self.f64()).collect()
    }
}

fn kernel_code(k: Kernel) -> u64 {
    match k {
        Kernel::Gaussian => 0,
        Kernel::BiSquare => 1,
    }
}

fn prune_code(r: PruneRule) -> u64 {
    match r {
        PruneRule::Published => 0,
        PruneRule::ReferenceC => 1,
    }
}

fn enc_params(e: &mut Enc, p: &Params) {
    e.u64(p.n_in as u64);
    e.u64(p.n_out as u64);
    e.vec(&p.init_d);
    e.vec(&p.init_m);
    e.vec(&p.init_alpha);
    for v in [
        p.w_gen,
        p.w_prune,
        p.init_lambda,
        p.final_lambda,
        p.tau_lambda,
        p.init_s2,
        p.add_threshold,
        p.penalty,
        p.meta_rate,
    ] {
        e.f64(v);
    }
    e.bool(p.diag_only);
    e.bool(p.update_d);
    e.bool(p.meta);
    e.vec(&p.norm_in);
    e.vec(&p.norm_out);
    e.u64(kernel_code(p.kernel));
    e.u64(prune_code(p.prune_rule));
    e.u64(match p.arithmetic {
        Arithmetic::Fast => 0,
        Arithmetic::Reference => 1,
    });
}

/// Decodes the parameters of a file of format `version` (version 1 has no arithmetic code).
fn dec_params(d: &mut Dec, version: u32) -> Result<Params> {
    let n_in = d.usize()?;
    let n_out = d.usize()?;
    let init_d = d.vec()?;
    let init_m = d.vec()?;
    let init_alpha = d.vec()?;
    let mut f = [0.0; 9];
    for v in f.iter_mut() {
        *v = d.f64()?;
    }
    let diag_only = d.bool()?;
    let update_d = d.bool()?;
    let meta = d.bool()?;
    let norm_in = d.vec()?;
    let norm_out = d.vec()?;
    let kernel = match d.u64()? {
        0 => Kernel::Gaussian,
        1 => Kernel::BiSquare,
        k => return Err(fmt_err(format!("unknown kernel code {k}"))),
    };
    let prune_rule = match d.u64()? {
        0 => PruneRule::Published,
        1 => PruneRule::ReferenceC,
        k => return Err(fmt_err(format!("unknown prune rule code {k}"))),
    };
    let arithmetic = if version == 1 {
        Arithmetic::Reference
    } else {
        match d.u64()? {
            0 => Arithmetic::Fast,
            1 => Arithmetic::Reference,
            k => return Err(fmt_err(format!("unknown arithmetic code {k}"))),
        }
    };
    Ok(Params {
        n_in,
        n_out,
        init_d,
        init_m,
        init_alpha,
        w_gen: f[0],
        w_prune: f[1],
        init_lambda: f[2],
        final_lambda: f[3],
        tau_lambda: f[4],
        init_s2: f[5],
        add_threshold: f[6],
        penalty: f[7],
        meta_rate: f[8],
        diag_only,
        update_d,
        meta,
        norm_in,
        norm_out,
        kernel,
        prune_rule,
        arithmetic,
    })
}

fn enc_rf(e: &mut Enc, rf: &ReceptiveField) {
    e.u64(rf.n_reg as u64);
    e.bool(rf.trustworthy);
    for v in [rf.w, rf.sum_e2, rf.beta0, rf.ssp] {
        e.f64(v);
    }
    for v in rf_vecs(rf) {
        e.vec(v);
    }
}

/// The stored vectors of a field, in binary-format order (the slope is derived, not stored).
fn rf_vecs(rf: &ReceptiveField) -> [&Vec<f64>; 22] {
    [
        &rf.d,
        &rf.m,
        &rf.alpha,
        &rf.b,
        &rf.h,
        &rf.c,
        &rf.mean_x,
        &rf.var_x,
        &rf.sxy,
        &rf.ssx,
        &rf.u,
        &rf.p,
        &rf.beta,
        &rf.ss_s2,
        &rf.ss_y,
        &rf.tr_h,
        &rf.tr_r,
        &rf.sum_w,
        &rf.sum_e_cv2,
        &rf.n_data,
        &rf.lambda,
        &rf.s,
    ]
}

fn dec_rf(d: &mut Dec) -> Result<ReceptiveField> {
    let n_reg = d.usize()?;
    let trustworthy = d.bool()?;
    let (w, sum_e2, beta0, ssp) = (d.f64()?, d.f64()?, d.f64()?, d.f64()?);
    let mut v: Vec<Vec<f64>> = Vec::with_capacity(22);
    for _ in 0..22 {
        v.push(d.vec()?);
    }
    let mut it = v.into_iter();
    let mut next = || it.next().expect("22 vectors");
    Ok(ReceptiveField {
        n_reg,
        trustworthy,
        w,
        sum_e2,
        beta0,
        ssp,
        d: next(),
        m: next(),
        alpha: next(),
        b: next(),
        h: next(),
        c: next(),
        mean_x: next(),
        var_x: next(),
        sxy: next(),
        ssx: next(),
        u: next(),
        p: next(),
        beta: next(),
        ss_s2: next(),
        ss_y: next(),
        tr_h: next(),
        tr_r: next(),
        sum_w: next(),
        sum_e_cv2: next(),
        n_data: next(),
        lambda: next(),
        s: next(),
        slope: Vec::new(),
    })
}

/// Checks a receptive field's metric: `M` upper triangular (diagonal with `diag_only`) with a
/// positive diagonal, and `D = MᵀM` within [`METRIC_TOLERANCE`]: then `M` is the Cholesky
/// factor of `D` and `D` is positive definite.
pub(crate) fn check_metric(
    n: usize,
    diag_only: bool,
    d: &[f64],
    m: &[f64],
) -> std::result::Result<(), String> {
    for j in 0..n {
        if m[j + j * n] <= 0.0 {
            return Err(
                "metric factor M has a non-positive diagonal (D not positive definite)".into(),
            );
        }
        for i in 0..n {
            let below = i > j;
            if (below || (diag_only && i != j)) && m[i + j * n] != 0.0 {
                return Err(
                    "metric factor M is not upper triangular (diagonal with diag_only)".into(),
                );
            }
        }
    }
    for j in 0..n {
        for i in 0..=j {
            let mtm: f64 = (0..=i).map(|k| m[k + i * n] * m[k + j * n]).sum();
            // √D_ii·√D_jj, not √(D_ii·D_jj): the product overflows to +∞ (accepting any D_ij)
            // once the diagonal passes ~1e154.
            let scale = d[i + i * n].sqrt() * d[j + j * n].sqrt();
            let err = (d[i + j * n] - mtm).abs();
            if err.is_nan() || err > METRIC_TOLERANCE * scale || scale.is_nan() {
                return Err(format!(
                    "D is not MᵀM at ({i}, {j}): {} against {mtm} (relative tolerance {METRIC_TOLERANCE:e})",
                    d[i + j * n]
                ));
            }
        }
    }
    Ok(())
}

/// The bytes of the file `path`; an error is an [`LwprError::Io`] naming it (as
/// [`write_atomically`]'s do).
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| LwprError::Io(format!("{}: {e}", path.display())))
}

/// Writes `bytes` to `path` through a temporary file in the same folder, flushed to disk and
/// renamed into place, so a failed write leaves neither a partial file nor a damaged old one.
/// The temporary name is unique per process and call, so concurrent saves to one path do not
/// share (and rename away) each other's temporary file. The file is synced (`sync_all`) before
/// the rename: otherwise a crash soon after could leave the new name on an empty or partial
/// file on some file systems. An error is an [`LwprError::Io`] naming `path`.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    use std::sync::atomic::{AtomicU64, Ordering};
    static SAVES: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| LwprError::Io(format!("{} is not a file path", path.display())))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        SAVES.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp = path.with_file_name(tmp_name);
    let result = std::fs::File::create(&tmp)
        .and_then(|mut f| {
            f.write_all(bytes)?;
            f.sync_all()
        })
        .and_then(|()| std::fs::rename(&tmp, path));
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        LwprError::Io(format!("{}: {e}", path.display()))
    })
}

impl Lwpr {
    /// The model as JSON (with format name and version).
    pub fn to_json(&self) -> String {
        let env = Envelope {
            format: JSON_FORMAT.to_string(),
            version: BINARY_FORMAT_VERSION,
            model: self,
        };
        serde_json::to_string(&env).expect("a model always serialises")
    }

    /// Loads a model from [`to_json`](Self::to_json) output.
    pub fn from_json(s: &str) -> Result<Self> {
        let env: Envelope<serde_json::Value> =
            serde_json::from_str(s).map_err(|e| fmt_err(format!("invalid JSON model: {e}")))?;
        if env.format != JSON_FORMAT {
            return Err(fmt_err(format!("unknown format `{}`", env.format)));
        }
        check_version(env.version)?;
        let mut model = env.model;
        if env.version == 1 {
            // Version 1 had no arithmetic: its models were trained in the reference's.
            if let Some(p) = model.get_mut("params").and_then(|p| p.as_object_mut()) {
                p.insert("arithmetic".into(), serde_json::json!("Reference"));
            }
        }
        serde_json::from_value(model).map_err(|e| fmt_err(format!("invalid JSON model: {e}")))
    }

    /// The model in the compact binary form: magic, version, payload length, little-endian
    /// payload, FNV-1a checksum.
    pub fn to_binary(&self) -> Vec<u8> {
        let mut e = Enc(Vec::new());
        enc_params(&mut e, &self.params);
        e.u64(self.n_data);
        e.vec(&self.mean_x);
        e.vec(&self.var_x);
        e.u64(self.sub.len() as u64);
        for s in &self.sub {
            e.u64(s.n_pruned as u64);
            e.u64(s.rfs.len() as u64);
            for rf in &s.rfs {
                enc_rf(&mut e, rf);
            }
        }
        let payload = e.0;
        let mut out = Vec::with_capacity(payload.len() + 28);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&BINARY_FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&payload);
        out.extend_from_slice(&fnv1a(&payload).to_le_bytes());
        out
    }

    /// Loads a model from [`to_binary`](Self::to_binary) output.
    pub fn from_binary(data: &[u8]) -> Result<Self> {
        if data.len() < 20 || &data[..8] != MAGIC {
            return Err(fmt_err("not an lwpr-rs binary model (bad magic)"));
        }
        let version = u32::from_le_bytes(data[8..12].try_into().expect("4 bytes"));
        check_version(version)?;
        let len = u64::from_le_bytes(data[12..20].try_into().expect("8 bytes"));
        let rest = &data[20..];
        if (rest.len() as u64) < 8 || len != rest.len() as u64 - 8 {
            return Err(fmt_err("truncated or padded data (length mismatch)"));
        }
        let (payload, sum) = rest.split_at(len as usize);
        if fnv1a(payload) != u64::from_le_bytes(sum.try_into().expect("8 bytes")) {
            return Err(fmt_err("checksum mismatch (corrupt data)"));
        }
        let mut d = Dec {
            data: payload,
            pos: 0,
        };
        let params = dec_params(&mut d, version)?;
        // The sizes before anything is reserved per output (`n_out` = 2^60 overflowed the
        // capacity); the rest of the parameters are checked with the model.
        check_sizes(params.n_in, params.n_out)
            .map_err(|e| fmt_err(format!("invalid parameters: {e}")))?;
        let n_data = d.u64()?;
        let mean_x = d.vec()?;
        let var_x = d.vec()?;
        let n_sub = d.usize()?;
        if n_sub != params.n_out {
            return Err(fmt_err("number of sub-models differs from n_out"));
        }
        let mut sub = Vec::with_capacity(n_sub);
        for _ in 0..n_sub {
            let n_pruned = d.usize()?;
            let k = d.usize()?;
            // Bounded by what the rest of the data can hold, not by its length in bytes: each
            // field takes ~600 bytes in memory, so a 64 MB file asked for 38 GB.
            if k > (payload.len() - d.pos) / MIN_RF_BYTES {
                return Err(fmt_err("receptive-field count larger than the data"));
            }
            let mut rfs = Vec::with_capacity(k);
            for _ in 0..k {
                rfs.push(dec_rf(&mut d)?);
            }
            sub.push(SubModel { rfs, n_pruned });
        }
        if d.pos != payload.len() {
            return Err(fmt_err("trailing bytes in payload"));
        }
        Lwpr::from_parts(params, n_data, mean_x, var_x, sub)
    }

    /// Writes the model to `path`: binary if the extension is `bin`, JSON otherwise.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let bytes = if path.extension().is_some_and(|e| e == "bin") {
            self.to_binary()
        } else {
            self.to_json().into_bytes()
        };
        write_atomically(path, &bytes)
    }

    /// Reads a model written by [`save`](Self::save) or an XML model file (see
    /// [`from_xml`](Self::from_xml)); the format is detected from the content. A file that
    /// cannot be read is an [`LwprError::Io`] naming `path`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let data = read_file(path.as_ref())?;
        if data.starts_with(MAGIC) {
            Self::from_binary(&data)
        } else {
            let s = std::str::from_utf8(&data)
                .map_err(|_| fmt_err("neither binary nor UTF-8 JSON or XML"))?;
            if s.trim_start_matches('\u{feff}')
                .trim_start()
                .starts_with('<')
            {
                Self::from_xml(s)
            } else {
                Self::from_json(s)
            }
        }
    }

    /// A model from its stored parts (any format), checked like every loaded model.
    pub(crate) fn from_parts(
        params: Params,
        n_data: u64,
        mean_x: Vec<f64>,
        var_x: Vec<f64>,
        sub: Vec<SubModel>,
    ) -> Result<Self> {
        Lwpr {
            params,
            n_data,
            mean_x,
            var_x,
            sub,
            ws: Workspace::default(),
        }
        .finish_load()
    }

    /// Checks every invariant of a deserialised model and rebuilds derived data.
    fn finish_load(mut self) -> Result<Self> {
        let p = self
            .params
            .checked_copy()
            .map_err(|e| fmt_err(format!("invalid parameters: {e}")))?;
        let (n, m) = (p.n_in, p.n_out);
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let within = |v: &[f64]| v.iter().all(|x| x.abs() <= MAX_ABS_VALUE);
        let non_negative = |v: &[f64]| v.iter().all(|&x| x >= 0.0);
        if self.mean_x.len() != n
            || self.var_x.len() != n
            || !finite(&self.mean_x)
            || !finite(&self.var_x)
        {
            return Err(fmt_err(
                "input statistics have the wrong size or are not finite",
            ));
        }
        if !within(&self.mean_x) || !non_negative(&self.var_x) {
            return Err(fmt_err(format!(
                "input statistics out of range (|mean| ≤ {MAX_ABS_VALUE:e}, variance ≥ 0)"
            )));
        }
        if self.sub.len() != m {
            return Err(fmt_err("number of sub-models differs from n_out"));
        }
        // Counting on from a loaded count must not overflow (`update`): training adds one
        // sample per update and prunes at most one field per output and update.
        if self.n_data > MAX_N_DATA {
            return Err(fmt_err(format!(
                "sample count n_data = {} beyond 2^53",
                self.n_data
            )));
        }
        if let Some(dim) = self
            .sub
            .iter()
            .position(|s| s.n_pruned as u64 > self.n_data)
        {
            return Err(fmt_err(format!(
                "output {dim} pruned {} receptive fields in {} samples",
                self.sub[dim].n_pruned, self.n_data
            )));
        }
        for (dim, s) in self.sub.iter_mut().enumerate() {
            for (k, rf) in s.rfs.iter_mut().enumerate() {
                let bad =
                    |what: &str| fmt_err(format!("receptive field {k} of output {dim}: {what}"));
                let r = rf.n_reg;
                if r == 0 || r > n {
                    return Err(bad("PLS dimension out of range"));
                }
                let sizes: [(&Vec<f64>, usize); 22] = [
                    (&rf.d, n * n),
                    (&rf.m, n * n),
                    (&rf.alpha, n * n),
                    (&rf.b, n * n),
                    (&rf.h, n * n),
                    (&rf.c, n),
                    (&rf.mean_x, n),
                    (&rf.var_x, n),
                    (&rf.sxy, n * r),
                    (&rf.ssx, n * r),
                    (&rf.u, n * r),
                    (&rf.p, n * r),
                    (&rf.beta, r),
                    (&rf.ss_s2, r),
                    (&rf.ss_y, r),
                    (&rf.tr_h, r),
                    (&rf.tr_r, r),
                    (&rf.sum_w, r),
                    (&rf.sum_e_cv2, r),
                    (&rf.n_data, r),
                    (&rf.lambda, r),
                    (&rf.s, r),
                ];
                for (v, len) in sizes {
                    if v.len() != len {
                        return Err(bad("array of the wrong size"));
                    }
                    if !finite(v) {
                        return Err(bad("non-finite value"));
                    }
                }
                if ![rf.w, rf.sum_e2, rf.beta0, rf.ssp]
                    .iter()
                    .all(|x| x.is_finite())
                {
                    return Err(bad("non-finite value"));
                }
                // Training relies on D being exactly symmetric (it is, as MᵀM with the upper
                // triangle copied from the lower one).
                if (0..n).any(|j| (0..j).any(|i| rf.d[i + j * n] != rf.d[j + i * n])) {
                    return Err(bad("distance metric is not symmetric"));
                }
                if rf.ss_s2.iter().any(|&v| v <= 0.0) || rf.sum_w.iter().any(|&v| v <= 0.0) {
                    return Err(bad("non-positive PLS statistics"));
                }
                check_metric(n, p.diag_only, &rf.d, &rf.m).map_err(|e| bad(&e))?;
                if rf.alpha.iter().any(|&a| a <= 0.0) {
                    return Err(bad("learning rate not positive"));
                }
                if rf.lambda.iter().any(|&l| !(l > 0.0 && l <= 1.0)) {
                    return Err(bad("forgetting factor lambda outside (0, 1]"));
                }
                if !(0.0..=1.0).contains(&rf.w) {
                    return Err(bad("activation outside [0, 1]"));
                }
                if !within(&rf.c) || !within(&rf.mean_x) {
                    return Err(bad("centre or mean beyond MAX_ABS_VALUE"));
                }
                if !non_negative(&rf.var_x)
                    || !non_negative(&rf.n_data)
                    || !non_negative(&rf.sum_e_cv2)
                    || rf.sum_e2 < 0.0
                {
                    return Err(bad("negative variance, count or sum of squares"));
                }
                // Restore the growth capacity so later updates do not reallocate (`n·r ≤ n²`:
                // `r ≤ n` was checked above).
                for v in [&mut rf.sxy, &mut rf.ssx, &mut rf.u, &mut rf.p] {
                    v.reserve_exact(n * n - v.len());
                }
                rf.slope = vec![0.0; n];
                rf.refresh_slope(n);
            }
        }
        self.ws = Workspace::new(n, m);
        Ok(self)
    }
}

/// The 5-D model the save/load tests share with `tests/integration/xml.rs`.
#[cfg(test)]
#[path = "../tests/integration/common/five_d.rs"]
mod five_d;

#[cfg(test)]
mod tests {
    use super::*;

    fn trained() -> Lwpr {
        five_d::trained(five_d::builder(), 200)
    }

    /// Writes `payload` in the binary frame of format `version`.
    fn framed(version: u32, payload: &[u8]) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(payload);
        out.extend_from_slice(&fnv1a(payload).to_le_bytes());
        out
    }

    #[test]
    fn version_1_binary_loads_with_reference_arithmetic() {
        let m = trained();
        let mut params = Enc(Vec::new());
        enc_params(&mut params, &m.params);
        let bin = m.to_binary();
        let payload = &bin[20..bin.len() - 8];
        // Version 1 had no arithmetic code: the last u64 of the parameters.
        let cut = params.0.len() - 8;
        let v1: Vec<u8> = [&payload[..cut], &payload[cut + 8..]].concat();
        let loaded = Lwpr::from_binary(&framed(1, &v1)).unwrap();
        assert_eq!(loaded.params().arithmetic, Arithmetic::Reference);
        let mut expect = m.clone();
        expect.set_arithmetic(Arithmetic::Reference);
        assert_eq!(loaded, expect);
        // The same payload claiming version 2 is short by the arithmetic code.
        assert!(Lwpr::from_binary(&framed(2, &v1)).is_err());
        assert!(Lwpr::from_binary(&framed(3, payload)).is_err());
        assert!(Lwpr::from_binary(&framed(0, payload)).is_err());
    }

    #[test]
    fn version_1_json_loads_with_reference_arithmetic() {
        let m = trained();
        let mut v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
        v["version"] = 1.into();
        v["model"]["params"]
            .as_object_mut()
            .unwrap()
            .remove("arithmetic");
        let loaded = Lwpr::from_json(&v.to_string()).unwrap();
        let mut expect = m.clone();
        expect.set_arithmetic(Arithmetic::Reference);
        assert_eq!(loaded, expect);
        v["version"] = 3.into();
        assert!(Lwpr::from_json(&v.to_string()).is_err());
    }
}
