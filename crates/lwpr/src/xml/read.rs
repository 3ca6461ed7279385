//! Reading the reference library's XML layout into a checked [`Lwpr`].
//!
//! Stricter than the reference's reader (which warns about unknown fields and leaves missing
//! ones at their defaults): every field must be present exactly once with its declared size,
//! every number finite; then the model passes every check of a loaded model.

use std::collections::BTreeMap;

use super::parse::Element;
use crate::error::{LwprError, Result};
use crate::io::check_metric;
use crate::linalg::cholesky_upper;
use crate::model::{Lwpr, SubModel};
use crate::params::{Arithmetic, Kernel, MAX_INPUTS, MAX_OUTPUTS, Params, PruneRule};
use crate::rf::ReceptiveField;

fn err(s: impl Into<String>) -> LwprError {
    LwprError::Format(s.into())
}

/// The numbers of one `<integer>`, `<scalar>`, `<vector>` or `<matrix>` element.
enum Value {
    /// Wide enough for every `u64` count our writer emits and every negative the reference's
    /// `int` can hold.
    Int(i128),
    Scalar(f64),
    /// Values and declared length.
    Vector(Vec<f64>),
    /// Column-major values, rows, columns.
    Matrix(Vec<f64>, usize, usize),
}

fn size_attr(e: &Element, key: &str, field: &str) -> Result<usize> {
    let v = e
        .attr(key)
        .ok_or_else(|| err(format!("<{}> `{field}` has no `{key}`", e.name)))?;
    v.trim()
        .parse::<usize>()
        .ok()
        .filter(|&k| k > 0 && k <= MAX_INPUTS * MAX_INPUTS)
        .ok_or_else(|| err(format!("`{field}`: invalid {key} `{v}`")))
}

/// Whitespace-separated finite numbers, exactly `count` of them.
fn numbers(text: &str, count: usize, field: &str) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(count.min(text.len() / 2 + 1));
    for tok in text.split_ascii_whitespace() {
        if out.len() == count {
            return Err(err(format!("`{field}`: more than {count} numbers")));
        }
        let v: f64 = tok
            .parse()
            .map_err(|_| err(format!("`{field}`: `{tok}` is not a number")))?;
        if !v.is_finite() {
            return Err(err(format!(
                "`{field}`: non-finite value at element {}",
                out.len()
            )));
        }
        out.push(v);
    }
    if out.len() != count {
        return Err(err(format!(
            "`{field}`: {} numbers where {count} were declared",
            out.len()
        )));
    }
    Ok(out)
}

/// The named numeric fields among `e`'s children; structural children (`SubModel`,
/// `ReceptiveField`) are returned separately.
fn fields<'a>(e: &'a Element, structural: &str) -> Result<(Fields<'a>, Vec<&'a Element>)> {
    let mut map = BTreeMap::new();
    let mut nested = Vec::new();
    for c in &e.children {
        if c.name == structural {
            nested.push(c);
            continue;
        }
        let name = c
            .attr("name")
            .ok_or_else(|| err(format!("<{}> inside <{}> without a name", c.name, e.name)))?;
        if !c.children.is_empty() {
            return Err(err(format!("`{name}` has child elements")));
        }
        let v = match c.name.as_str() {
            "integer" => {
                let t = c.text.trim();
                Value::Int(
                    t.parse()
                        .map_err(|_| err(format!("`{name}`: `{t}` is not an integer")))?,
                )
            }
            "scalar" => Value::Scalar(numbers(&c.text, 1, name)?[0]),
            "vector" => {
                let len = size_attr(c, "length", name)?;
                Value::Vector(numbers(&c.text, len, name)?)
            }
            "matrix" => {
                let rows = size_attr(c, "rows", name)?;
                let cols = size_attr(c, "columns", name)?;
                let count = rows
                    .checked_mul(cols)
                    .filter(|&k| k <= MAX_INPUTS * MAX_INPUTS)
                    .ok_or_else(|| err(format!("`{name}`: matrix too large")))?;
                let row_major = numbers(&c.text, count, name)?;
                let mut v = vec![0.0; count];
                for i in 0..rows {
                    for j in 0..cols {
                        v[i + j * rows] = row_major[i * cols + j];
                    }
                }
                Value::Matrix(v, rows, cols)
            }
            other => {
                return Err(err(format!(
                    "unknown element <{other}> inside <{}>",
                    e.name
                )));
            }
        };
        if map.insert(name.to_string(), v).is_some() {
            return Err(err(format!("`{name}` given twice inside <{}>", e.name)));
        }
    }
    Ok((
        Fields {
            map,
            owner: &e.name,
        },
        nested,
    ))
}

/// Named fields of one element, taken one by one with their expected kind and size.
struct Fields<'a> {
    map: BTreeMap<String, Value>,
    owner: &'a str,
}

impl Fields<'_> {
    fn take(&mut self, name: &str) -> Result<Value> {
        self.map
            .remove(name)
            .ok_or_else(|| err(format!("`{name}` missing inside <{}>", self.owner)))
    }
    fn int(&mut self, name: &str) -> Result<i128> {
        match self.take(name)? {
            Value::Int(v) => Ok(v),
            _ => Err(err(format!("`{name}` must be an <integer>"))),
        }
    }
    fn flag(&mut self, name: &str) -> Result<bool> {
        match self.int(name)? {
            0 => Ok(false),
            1 => Ok(true),
            v => Err(err(format!("`{name}` must be 0 or 1, got {v}"))),
        }
    }
    fn count(&mut self, name: &str) -> Result<u64> {
        let v = self.int(name)?;
        u64::try_from(v).map_err(|_| err(format!("`{name}` is negative or too large ({v})")))
    }
    fn scalar(&mut self, name: &str) -> Result<f64> {
        match self.take(name)? {
            Value::Scalar(v) => Ok(v),
            _ => Err(err(format!("`{name}` must be a <scalar>"))),
        }
    }
    fn vector(&mut self, name: &str, len: usize) -> Result<Vec<f64>> {
        match self.take(name)? {
            Value::Vector(v) if v.len() == len => Ok(v),
            Value::Vector(v) => Err(err(format!(
                "vector `{name}` has {} elements, expected {len}",
                v.len()
            ))),
            _ => Err(err(format!("`{name}` must be a <vector>"))),
        }
    }
    fn matrix(&mut self, name: &str, rows: usize, cols: usize) -> Result<Vec<f64>> {
        match self.take(name)? {
            Value::Matrix(v, r, c) if (r, c) == (rows, cols) => Ok(v),
            Value::Matrix(_, r, c) => Err(err(format!(
                "matrix `{name}` is {r}x{c}, expected {rows}x{cols}"
            ))),
            _ => Err(err(format!("`{name}` must be a <matrix>"))),
        }
    }
    /// Fails if a field was not taken.
    fn done(self) -> Result<()> {
        match self.map.keys().next() {
            Some(k) => Err(err(format!("unknown field `{k}` inside <{}>", self.owner))),
            None => Ok(()),
        }
    }
}

fn dim_attr(e: &Element, key: &str, max: usize) -> Result<usize> {
    let v = e
        .attr(key)
        .ok_or_else(|| err(format!("<{}> has no `{key}`", e.name)))?;
    let k: usize = v
        .trim()
        .parse()
        .map_err(|_| err(format!("invalid {key} `{v}`")))?;
    if k == 0 {
        return Err(err(format!("{key} must be at least 1")));
    }
    if k > max {
        return Err(LwprError::TooBig {
            what: if key == "nIn" { "n_in" } else { "n_out" },
            got: k,
            max,
        });
    }
    Ok(k)
}

/// `D` and `M` of a field as stored. Files of the reference hold them to six decimals, so
/// `D = MᵀM` holds only to that precision there: then `D` (which the reference's predictions
/// use) is kept and `M` recomputed as its Cholesky factor.
fn metric(n: usize, diag_only: bool, d: Vec<f64>, m: Vec<f64>) -> Result<(Vec<f64>, Vec<f64>)> {
    if check_metric(n, diag_only, &d, &m).is_ok() {
        return Ok((d, m));
    }
    if (0..n).any(|j| (0..j).any(|i| d[i + j * n] != d[j + i * n])) {
        return Err(err("distance metric D is not symmetric"));
    }
    let m =
        cholesky_upper(n, &d).ok_or_else(|| err("distance metric D is not positive definite"))?;
    Ok((d, m))
}

fn receptive_field(e: &Element, n: usize, diag_only: bool) -> Result<ReceptiveField> {
    let r = e
        .attr("nReg")
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&r| (1..=n).contains(&r))
        .ok_or_else(|| err(format!("<ReceptiveField> needs nReg in 1..={n}")))?;
    let (mut f, nested) = fields(e, "")?;
    debug_assert!(nested.is_empty());
    let (d, m) = metric(n, diag_only, f.matrix("D", n, n)?, f.matrix("M", n, n)?)?;
    let rf = ReceptiveField {
        n_reg: r,
        d,
        m,
        alpha: f.matrix("alpha", n, n)?,
        beta0: f.scalar("beta0")?,
        beta: f.vector("beta", r)?,
        c: f.vector("c", n)?,
        sxy: f.matrix("SXresYres", n, r)?,
        ss_s2: f.vector("SSs2", r)?,
        ss_y: f.vector("SSYres", r)?,
        ssx: f.matrix("SSXres", n, r)?,
        u: f.matrix("U", n, r)?,
        p: f.matrix("P", n, r)?,
        tr_h: f.vector("H", r)?,
        tr_r: f.vector("r", r)?,
        h: f.matrix("h", n, n)?,
        b: f.matrix("b", n, n)?,
        sum_w: f.vector("sum_w", r)?,
        sum_e_cv2: f.vector("sum_e_cv2", r)?,
        sum_e2: f.scalar("sum_e2")?,
        ssp: f.scalar("SSp")?,
        n_data: f.vector("n_data", r)?,
        trustworthy: f.flag("trustworthy")?,
        lambda: f.vector("lambda", r)?,
        mean_x: f.vector("mean_x", n)?,
        var_x: f.vector("var_x", n)?,
        w: f.scalar("w")?,
        s: f.vector("s", r)?,
        slope: Vec::new(),
    };
    f.done()?;
    Ok(rf)
}

/// The model of a parsed document (checked like every loaded model).
pub(super) fn model(root: &Element) -> Result<Lwpr> {
    if root.name != "LWPR" {
        return Err(err(format!("root element is <{}>, not <LWPR>", root.name)));
    }
    let n = dim_attr(root, "nIn", MAX_INPUTS)?;
    let n_out = dim_attr(root, "nOut", MAX_OUTPUTS)?;
    let kernel = match root.attr("kernel").unwrap_or("Gaussian") {
        "Gaussian" => Kernel::Gaussian,
        "BiSquare" | "Bisquare" => Kernel::BiSquare,
        k => return Err(err(format!("unknown kernel `{k}`"))),
    };
    // Our own attributes; files of the reference have neither: its models prune by its rule
    // and were trained in its arithmetic.
    let prune_rule = match root.attr("prune_rule").unwrap_or("ReferenceC") {
        "ReferenceC" => PruneRule::ReferenceC,
        "Published" => PruneRule::Published,
        k => return Err(err(format!("unknown prune_rule `{k}`"))),
    };
    let arithmetic = match root.attr("arithmetic").unwrap_or("Reference") {
        "Reference" => Arithmetic::Reference,
        "Fast" => Arithmetic::Fast,
        k => return Err(err(format!("unknown arithmetic `{k}`"))),
    };
    let (mut f, subs) = fields(root, "SubModel")?;
    let n_data = f.count("n_data")?;
    let mean_x = f.vector("mean_x", n)?;
    let var_x = f.vector("var_x", n)?;
    let diag_only = f.flag("diag_only")?;
    let mut params = Params {
        n_in: n,
        n_out,
        diag_only,
        update_d: f.flag("update_D")?,
        meta: f.flag("meta")?,
        meta_rate: f.scalar("meta_rate")?,
        penalty: f.scalar("penalty")?,
        init_alpha: f.matrix("init_alpha", n, n)?,
        norm_in: f.vector("norm_in", n)?,
        norm_out: f.vector("norm_out", n_out)?,
        init_d: f.matrix("init_D", n, n)?,
        // Derived: recomputed from init_D by `validate` below (exactly what we wrote).
        init_m: f.matrix("init_M", n, n)?,
        w_gen: f.scalar("w_gen")?,
        w_prune: f.scalar("w_prune")?,
        init_lambda: f.scalar("init_lambda")?,
        final_lambda: f.scalar("final_lambda")?,
        tau_lambda: f.scalar("tau_lambda")?,
        init_s2: f.scalar("init_S2")?,
        add_threshold: f.scalar("add_threshold")?,
        kernel,
        prune_rule,
        arithmetic,
    };
    f.done()?;
    params
        .validate()
        .map_err(|e| err(format!("invalid parameters: {e}")))?;
    let mut sub: Vec<Option<SubModel>> = (0..n_out).map(|_| None).collect();
    for s in subs {
        let dim = s
            .attr("out_dim")
            .and_then(|v| v.trim().parse::<usize>().ok())
            .filter(|&d| d < n_out)
            .ok_or_else(|| err(format!("<SubModel> needs out_dim in 0..{n_out}")))?;
        let declared = s
            .attr("numRFS")
            .and_then(|v| v.trim().parse::<usize>().ok())
            .ok_or_else(|| err(format!("<SubModel> {dim} needs numRFS")))?;
        let (mut f, rfs) = fields(s, "ReceptiveField")?;
        let n_pruned =
            usize::try_from(f.count("n_pruned")?).map_err(|_| err("n_pruned out of range"))?;
        f.done()?;
        if rfs.len() != declared {
            return Err(err(format!(
                "<SubModel> {dim} declares {declared} receptive fields and holds {}",
                rfs.len()
            )));
        }
        let rfs = rfs
            .into_iter()
            .enumerate()
            .map(|(k, e)| {
                receptive_field(e, n, diag_only).map_err(|e| match e {
                    LwprError::Format(s) => {
                        err(format!("receptive field {k} of output {dim}: {s}"))
                    }
                    other => other,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        if sub[dim].replace(SubModel { rfs, n_pruned }).is_some() {
            return Err(err(format!("<SubModel> {dim} given twice")));
        }
    }
    let sub = sub
        .into_iter()
        .enumerate()
        .map(|(d, s)| s.ok_or_else(|| err(format!("<SubModel> {d} missing"))))
        .collect::<Result<Vec<_>>>()?;
    Lwpr::from_parts(params, n_data, mean_x, var_x, sub)
}
