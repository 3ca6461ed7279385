//! Model parameters (the reference library's names and defaults) and the validating builder.

use serde::{Deserialize, Serialize};

use crate::error::{LwprError, Result};
use crate::linalg::cholesky_upper;
use crate::model::Lwpr;

/// Locality kernel turning the squared Mahalanobis distance `q = (x−c)ᵀD(x−c)` into an
/// activation `w` (docs/methods.md § LWPR).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Kernel {
    /// `w = exp(−q/2)` (the reference's default).
    #[default]
    Gaussian,
    /// `w = (1 − q/4)²` for `q < 4`, else 0 (compact support).
    BiSquare,
}

/// Which of the two most active receptive fields is removed when the second-largest activation
/// exceeds `w_prune` (docs/methods.md § LWPR). The default is the reference C library's rule:
/// the published one was less accurate on every sample stream measured (crate docs, "Pruning").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum PruneRule {
    /// The published algorithm (Vijayakumar et al. 2005, the library's own documentation and its
    /// Matlab code): remove the field with the larger `tr D`, i.e. the *narrower* one. Kept as
    /// an option; it removes fields that metric learning has shrunk and keeps wide untrained ones.
    Published,
    /// The reference C library's behaviour: remove the field with the *smaller* `tr D` (the wider
    /// one); its source carries a "TODO: ORIGINAL LOGIC WAS REVERSED -- CHECK" comment there.
    /// Default: more accurate than [`PruneRule::Published`] wherever pruning fired in our
    /// measurements, and training stays bit-identical to the C library when pruning fires.
    #[default]
    ReferenceC,
}

/// How the update of a full distance metric with `n ≥ 5` inputs does its arithmetic. For
/// `n ≤ 4` or a diagonal metric both choices run the reference's operations in the reference's
/// order, so training is bit-identical to the C library either way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Arithmetic {
    /// Sums reordered into vector lanes, the activation from the triangular factor
    /// (`q = |M(x−c)|²`) and a polynomial exponential for the meta-learned rates (see the crate
    /// docs, "Faithfulness"). The same formulas as the reference; the values differ from it by
    /// rounding, which over thousands of updates makes the models differ slightly (the same
    /// accuracy). Deterministic (independent of vector width and thread count). Default.
    #[default]
    Fast,
    /// Every operation in the reference's order, also for `n ≥ 5`: training is bit-identical to
    /// the C library in every dimension (slower for large `n`).
    Reference,
}

/// Largest input dimension `n_in` (each receptive field stores five `n × n` matrices: 2.6 MB
/// at this limit). Larger models are refused with [`LwprError::TooBig`] before allocating.
pub const MAX_INPUTS: usize = 256;

/// Largest output dimension `n_out` (one independent sub-model per output).
pub const MAX_OUTPUTS: usize = 4096;

/// Largest magnitude of an input or output, raw and normalised (1e30), accepted by training.
/// The model's statistics and its metric gradient hold squares and products of up to four
/// differences of such values (`e²·(x−c)²` and the like), so larger finite values could
/// overflow to infinity and poison the model; they are refused with [`LwprError::TooLarge`].
pub const MAX_ABS_VALUE: f64 = 1e30;

/// All parameters of a model. Names follow the reference library (`init_D` → `init_d` etc.).
/// Matrices are `n_in × n_in`, stored column-major. Deserialisation runs
/// [`Params::validate`] and requires the stored `init_m` to be the factor it computes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ParamsData")]
pub struct Params {
    /// Input dimension n.
    pub n_in: usize,
    /// Output dimension m (one independent sub-model per output).
    pub n_out: usize,
    /// Initial distance metric of new receptive fields (default `25·I`).
    pub init_d: Vec<f64>,
    /// Upper-triangular Cholesky factor of `init_d` (`init_d = init_mᵀ init_m`).
    pub init_m: Vec<f64>,
    /// Initial learning rates of `M` (default 50 in every element).
    pub init_alpha: Vec<f64>,
    /// Create a receptive field when no activation exceeds this (default 0.1).
    pub w_gen: f64,
    /// Prune one of the two most active fields when the second activation exceeds this
    /// (default 1.0, which with a Gaussian kernel practically never fires).
    pub w_prune: f64,
    /// Initial forgetting factor (default 0.999).
    pub init_lambda: f64,
    /// Final forgetting factor (default 0.99999).
    pub final_lambda: f64,
    /// Annealing constant of the forgetting factor (default 0.9999).
    pub tau_lambda: f64,
    /// Initial value of the PLS statistics `SSs2` (default 1e-10).
    pub init_s2: f64,
    /// Add a PLS direction when the CV-error ratio falls below this (default 0.5).
    pub add_threshold: f64,
    /// Ridge penalty γ on the distance metric (default 1e-6; divided by n internally).
    pub penalty: f64,
    /// Learn only the diagonal of `D` (default true).
    pub diag_only: bool,
    /// Learn the distance metric at all (default true).
    pub update_d: bool,
    /// Meta-learn the learning rates with IDBD (default false).
    pub meta: bool,
    /// Meta learning rate (default 250).
    pub meta_rate: f64,
    /// Input normalisation: inputs are divided by this before anything else (default 1).
    pub norm_in: Vec<f64>,
    /// Output normalisation (default 1).
    pub norm_out: Vec<f64>,
    /// Locality kernel (default Gaussian).
    pub kernel: Kernel,
    /// Pruning rule (default: the reference C library's, [`PruneRule::ReferenceC`]).
    pub prune_rule: PruneRule,
    /// Arithmetic of the metric update for `n ≥ 5` (default [`Arithmetic::Fast`]).
    #[serde(default)]
    pub arithmetic: Arithmetic,
}

/// The serialised form of [`Params`] (the same fields), checked on the way in.
#[derive(Deserialize)]
struct ParamsData {
    n_in: usize,
    n_out: usize,
    init_d: Vec<f64>,
    init_m: Vec<f64>,
    init_alpha: Vec<f64>,
    w_gen: f64,
    w_prune: f64,
    init_lambda: f64,
    final_lambda: f64,
    tau_lambda: f64,
    init_s2: f64,
    add_threshold: f64,
    penalty: f64,
    diag_only: bool,
    update_d: bool,
    meta: bool,
    meta_rate: f64,
    norm_in: Vec<f64>,
    norm_out: Vec<f64>,
    kernel: Kernel,
    prune_rule: PruneRule,
    #[serde(default)]
    arithmetic: Arithmetic,
}

impl TryFrom<ParamsData> for Params {
    type Error = LwprError;
    fn try_from(d: ParamsData) -> Result<Self> {
        let p = Params {
            n_in: d.n_in,
            n_out: d.n_out,
            init_d: d.init_d,
            init_m: d.init_m,
            init_alpha: d.init_alpha,
            w_gen: d.w_gen,
            w_prune: d.w_prune,
            init_lambda: d.init_lambda,
            final_lambda: d.final_lambda,
            tau_lambda: d.tau_lambda,
            init_s2: d.init_s2,
            add_threshold: d.add_threshold,
            penalty: d.penalty,
            diag_only: d.diag_only,
            update_d: d.update_d,
            meta: d.meta,
            meta_rate: d.meta_rate,
            norm_in: d.norm_in,
            norm_out: d.norm_out,
            kernel: d.kernel,
            prune_rule: d.prune_rule,
            arithmetic: d.arithmetic,
        };
        p.checked_copy()?;
        Ok(p)
    }
}

impl Params {
    /// The reference library's defaults (`lwpr_init_model`) for `n_in` inputs and `n_out` outputs.
    /// Sizes beyond [`MAX_INPUTS`] or [`MAX_OUTPUTS`] allocate nothing: the vectors are left
    /// empty and [`validate`](Self::validate) (or [`LwprBuilder::build`]) reports
    /// [`LwprError::TooBig`].
    pub fn defaults(n_in: usize, n_out: usize) -> Self {
        if check_sizes(n_in, n_out).is_err() {
            let mut p = Params::defaults(0, 0);
            (p.n_in, p.n_out) = (n_in, n_out);
            return p;
        }
        let mut init_d = vec![0.0; n_in * n_in];
        let mut init_m = vec![0.0; n_in * n_in];
        for i in 0..n_in {
            init_d[i + i * n_in] = 25.0;
            init_m[i + i * n_in] = 5.0;
        }
        Params {
            n_in,
            n_out,
            init_d,
            init_m,
            init_alpha: vec![50.0; n_in * n_in],
            w_gen: 0.1,
            w_prune: 1.0,
            init_lambda: 0.999,
            final_lambda: 0.99999,
            tau_lambda: 0.9999,
            init_s2: 1e-10,
            add_threshold: 0.5,
            penalty: 1e-6,
            diag_only: true,
            update_d: true,
            meta: false,
            meta_rate: 250.0,
            norm_in: vec![1.0; n_in],
            norm_out: vec![1.0; n_out],
            kernel: Kernel::Gaussian,
            prune_rule: PruneRule::ReferenceC,
            arithmetic: Arithmetic::Fast,
        }
    }

    /// Validates a copy and checks that the stored `init_m` is the factor [`validate`]
    /// computes from `init_d` (as it is in every model we write): the checks of a loaded
    /// parameter set.
    ///
    /// [`validate`]: Self::validate
    pub(crate) fn checked_copy(&self) -> Result<Params> {
        let mut p = self.clone();
        p.validate()?;
        if p.init_m != self.init_m {
            return Err(LwprError::InvalidParameter {
                name: "init_M",
                reason: "is not the Cholesky factor of init_D".into(),
            });
        }
        Ok(p)
    }

    /// Checks every parameter; on success `init_m` is recomputed from `init_d`.
    pub fn validate(&mut self) -> Result<()> {
        let n = self.n_in;
        let bad =
            |name: &'static str, reason: String| Err(LwprError::InvalidParameter { name, reason });
        check_sizes(n, self.n_out)?;
        if n == 0 {
            return bad("n_in", "must be at least 1".into());
        }
        if self.n_out == 0 {
            return bad("n_out", "must be at least 1".into());
        }
        for (name, v, len) in [
            ("init_D", &self.init_d, n * n),
            ("init_alpha", &self.init_alpha, n * n),
            ("norm_in", &self.norm_in, n),
            ("norm_out", &self.norm_out, self.n_out),
        ] {
            if v.len() != len {
                return bad(name, format!("expected {len} elements, got {}", v.len()));
            }
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return bad(name, format!("element {i} is not finite"));
            }
        }
        if let Some(i) = self.init_alpha.iter().position(|&a| a <= 0.0) {
            return bad("init_alpha", format!("element {i} must be > 0"));
        }
        if let Some(i) = self.norm_in.iter().position(|&a| a <= 0.0) {
            return bad("norm_in", format!("element {i} must be > 0"));
        }
        if let Some(i) = self.norm_out.iter().position(|&a| a <= 0.0) {
            return bad("norm_out", format!("element {i} must be > 0"));
        }
        for j in 0..n {
            for i in 0..n {
                if self.init_d[i + j * n] != self.init_d[j + i * n] {
                    return bad("init_D", "must be symmetric".into());
                }
                if self.diag_only && i != j && self.init_d[i + j * n] != 0.0 {
                    return bad("init_D", "must be diagonal when diag_only is set".into());
                }
            }
        }
        // Stored only once every check has passed: a rejected call changes nothing.
        let Some(init_m) = cholesky_upper(n, &self.init_d) else {
            return bad("init_D", "must be positive definite".into());
        };
        let unit_open = |v: f64| v > 0.0 && v < 1.0;
        if !unit_open(self.w_gen) {
            return bad("w_gen", format!("{} is not in (0, 1)", self.w_gen));
        }
        if !(self.w_prune > 0.0 && self.w_prune.is_finite()) {
            return bad(
                "w_prune",
                format!("{} must be a positive number", self.w_prune),
            );
        }
        for (name, v) in [
            ("init_lambda", self.init_lambda),
            ("final_lambda", self.final_lambda),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                return bad(name, format!("{v} is not in (0, 1]"));
            }
        }
        if !(0.0..=1.0).contains(&self.tau_lambda) {
            return bad(
                "tau_lambda",
                format!("{} is not in [0, 1]", self.tau_lambda),
            );
        }
        for (name, v) in [
            ("init_S2", self.init_s2),
            ("add_threshold", self.add_threshold),
            ("meta_rate", self.meta_rate),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return bad(name, format!("{v} must be a positive number"));
            }
        }
        if !(self.penalty >= 0.0 && self.penalty.is_finite()) {
            return bad("penalty", format!("{} must be ≥ 0", self.penalty));
        }
        self.init_m = init_m;
        Ok(())
    }
}

/// Checks `n_in ≤ MAX_INPUTS` and `n_out ≤ MAX_OUTPUTS` ([`LwprError::TooBig`] otherwise), the
/// check [`LwprBuilder::new`] makes; for callers that allocate per-dimension vectors (norms)
/// before building.
pub fn check_sizes(n_in: usize, n_out: usize) -> Result<()> {
    for (what, got, max) in [("n_in", n_in, MAX_INPUTS), ("n_out", n_out, MAX_OUTPUTS)] {
        if got > max {
            return Err(LwprError::TooBig { what, got, max });
        }
    }
    Ok(())
}

/// Builder of an [`Lwpr`] model with the reference library's parameter names and defaults.
///
/// Values are checked in [`build`](Self::build). A size refused on the spot (model sizes in
/// [`new`](Self::new), a diagonal of the wrong length in
/// [`init_d_diagonal`](Self::init_d_diagonal)) is kept: `build` returns the first such error,
/// whatever is set after it.
///
/// ```
/// use lwpr::{LwprBuilder, Kernel};
/// let model = LwprBuilder::new(2, 1)
///     .init_d_spherical(50.0)
///     .init_alpha(250.0)
///     .w_gen(0.2)
///     .kernel(Kernel::Gaussian)
///     .build()
///     .unwrap();
/// assert_eq!(model.n_in(), 2);
/// assert!(LwprBuilder::new(2, 1).w_gen(1.5).build().is_err());
/// ```
#[derive(Debug, Clone)]
pub struct LwprBuilder {
    params: Params,
    error: Option<LwprError>,
}

impl LwprBuilder {
    /// Starts from the reference defaults (see [`Params::defaults`]). Sizes beyond
    /// [`MAX_INPUTS`] or [`MAX_OUTPUTS`] allocate nothing and make [`build`](Self::build)
    /// return [`LwprError::TooBig`].
    ///
    /// ```
    /// use lwpr::{LwprBuilder, LwprError};
    /// assert!(matches!(
    ///     LwprBuilder::new(10_000, 1).init_alpha(10.0).build(),
    ///     Err(LwprError::TooBig { what: "n_in", got: 10_000, .. })
    /// ));
    /// ```
    pub fn new(n_in: usize, n_out: usize) -> Self {
        if let Err(e) = check_sizes(n_in, n_out) {
            return LwprBuilder {
                params: Params::defaults(n_in, n_out),
                error: Some(e),
            };
        }
        LwprBuilder {
            params: Params::defaults(n_in, n_out),
            error: None,
        }
    }

    /// Starts from a complete parameter set (validated in [`build`](Self::build)). Sizes
    /// beyond [`MAX_INPUTS`] or [`MAX_OUTPUTS`] are refused on the spot, as in
    /// [`new`](Self::new): the setters then allocate nothing and `build` returns
    /// [`LwprError::TooBig`].
    pub fn from_params(params: Params) -> Self {
        // Kept like `new`'s: the setters build `n × n` matrices, which for an unchecked `n_in`
        // overflowed the capacity (panic) or asked for gigabytes.
        let error = check_sizes(params.n_in, params.n_out).err();
        LwprBuilder { params, error }
    }

    /// `init_D = d·I` (`lwpr_set_init_D_spherical`).
    pub fn init_d_spherical(mut self, d: f64) -> Self {
        if self.error.is_some() {
            return self;
        }
        let n = self.params.n_in;
        self.params.init_d = vec![0.0; n * n];
        for i in 0..n {
            self.params.init_d[i + i * n] = d;
        }
        self
    }

    /// `init_D = diag(d)` (`lwpr_set_init_D_diagonal`).
    pub fn init_d_diagonal(mut self, d: &[f64]) -> Self {
        if self.error.is_some() {
            return self;
        }
        let n = self.params.n_in;
        if d.len() != n {
            self.error.get_or_insert(LwprError::InvalidParameter {
                name: "init_D",
                reason: format!("expected {n} diagonal elements, got {}", d.len()),
            });
            return self;
        }
        self.params.init_d = vec![0.0; n * n];
        for i in 0..n {
            self.params.init_d[i + i * n] = d[i];
        }
        self
    }

    /// Full symmetric positive definite `init_D` (`n × n`, column-major = row-major as it is
    /// symmetric).
    pub fn init_d(mut self, d: &[f64]) -> Self {
        self.params.init_d = d.to_vec();
        self
    }

    /// The same initial learning rate for every element of `M`.
    pub fn init_alpha(mut self, alpha: f64) -> Self {
        if self.error.is_some() {
            return self;
        }
        let n = self.params.n_in;
        self.params.init_alpha = vec![alpha; n * n];
        self
    }

    /// Activation threshold below which a new receptive field is created.
    pub fn w_gen(mut self, v: f64) -> Self {
        self.params.w_gen = v;
        self
    }

    /// Second-activation threshold above which a receptive field is pruned.
    pub fn w_prune(mut self, v: f64) -> Self {
        self.params.w_prune = v;
        self
    }

    /// Initial forgetting factor.
    pub fn init_lambda(mut self, v: f64) -> Self {
        self.params.init_lambda = v;
        self
    }

    /// Final forgetting factor.
    pub fn final_lambda(mut self, v: f64) -> Self {
        self.params.final_lambda = v;
        self
    }

    /// Annealing constant of the forgetting factor.
    pub fn tau_lambda(mut self, v: f64) -> Self {
        self.params.tau_lambda = v;
        self
    }

    /// Initial `SSs2`.
    pub fn init_s2(mut self, v: f64) -> Self {
        self.params.init_s2 = v;
        self
    }

    /// PLS growth threshold.
    pub fn add_threshold(mut self, v: f64) -> Self {
        self.params.add_threshold = v;
        self
    }

    /// Ridge penalty on the distance metric.
    pub fn penalty(mut self, v: f64) -> Self {
        self.params.penalty = v;
        self
    }

    /// Learn only the diagonal of the distance metric.
    pub fn diag_only(mut self, v: bool) -> Self {
        self.params.diag_only = v;
        self
    }

    /// Learn the distance metric.
    pub fn update_d(mut self, v: bool) -> Self {
        self.params.update_d = v;
        self
    }

    /// Meta-learn the learning rates (IDBD).
    pub fn meta(mut self, v: bool) -> Self {
        self.params.meta = v;
        self
    }

    /// Meta learning rate.
    pub fn meta_rate(mut self, v: f64) -> Self {
        self.params.meta_rate = v;
        self
    }

    /// Input normalisation (one positive factor per input).
    pub fn norm_in(mut self, v: &[f64]) -> Self {
        self.params.norm_in = v.to_vec();
        self
    }

    /// Output normalisation (one positive factor per output).
    pub fn norm_out(mut self, v: &[f64]) -> Self {
        self.params.norm_out = v.to_vec();
        self
    }

    /// Locality kernel.
    pub fn kernel(mut self, k: Kernel) -> Self {
        self.params.kernel = k;
        self
    }

    /// Pruning rule.
    pub fn prune_rule(mut self, r: PruneRule) -> Self {
        self.params.prune_rule = r;
        self
    }

    /// Arithmetic of the metric update for `n ≥ 5` ([`Arithmetic::Reference`] for training
    /// that is bit-identical to the C library in every dimension).
    pub fn arithmetic(mut self, a: Arithmetic) -> Self {
        self.params.arithmetic = a;
        self
    }

    /// Validates the parameters and creates an empty model.
    pub fn build(self) -> Result<Lwpr> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let mut p = self.params;
        p.validate()?;
        Ok(Lwpr::from_valid_params(p))
    }
}
