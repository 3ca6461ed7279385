//! Scratch buffers for one update, allocated once per model so that an update of a model that
//! has stopped growing performs no heap allocation.

/// Scratch space sized for `n_in` inputs (a receptive field never has more than `n_in` PLS
/// directions).
#[derive(Debug, Clone, Default)]
pub(crate) struct Workspace {
    /// Normalised input.
    pub xn: Vec<f64>,
    /// Normalised output.
    pub yn: Vec<f64>,
    /// `x − c` (activation).
    pub xc: Vec<f64>,
    /// `x − x̄` after the mean update.
    pub xmz: Vec<f64>,
    /// Residual inputs of the PLS deflation, `n × R` column-major.
    pub xres: Vec<f64>,
    /// Residual input during the second projection.
    pub xu: Vec<f64>,
    /// Cumulative PLS predictions.
    pub yres: Vec<f64>,
    /// Regression targets per direction.
    pub ytarget: Vec<f64>,
    /// Cumulative CV residuals.
    pub e_cv: Vec<f64>,
    /// `∂w/∂M` (`n × n`).
    pub dwdm: Vec<f64>,
    /// `∂J₂/∂M`, reused as `∂J/∂M` (`n × n`).
    pub dj2dm: Vec<f64>,
    /// `∂²w/∂M²` (`n × n`, meta only).
    pub ddwdmdm: Vec<f64>,
    /// `∂²J₂/∂M²` (`n × n`, meta only).
    pub ddj2dmdm: Vec<f64>,
    /// Per-direction "derivative ok" flags.
    pub deriv_ok: Vec<bool>,
    /// `s_r / SSs2_r`.
    pub ps: Vec<f64>,
    /// `e · Ps_r`.
    pub pse: Vec<f64>,
    /// `x − c` for the metric update.
    pub dx: Vec<f64>,
    /// One row of `M` (metric derivatives).
    pub mrow: Vec<f64>,
    /// Per-column sums of the metric derivatives.
    pub sum_aux: Vec<f64>,
    /// Per-column sums of the second metric derivatives (meta learning).
    pub sum_aux1: Vec<f64>,
    /// Prefix sums of squared `M` row elements.
    pub prefix: Vec<f64>,
    /// `M` transposed (rows of `M` contiguous) for `D = MᵀM`.
    pub mt: Vec<f64>,
    /// Per row r of `M`: `Σ_i dx_i M_ri` (the reference's `dqdM` sum).
    pub dq: Vec<f64>,
}

impl Workspace {
    pub(crate) fn new(n_in: usize, n_out: usize) -> Self {
        let n = n_in;
        Workspace {
            xn: vec![0.0; n],
            yn: vec![0.0; n_out],
            xc: vec![0.0; n],
            xmz: vec![0.0; n],
            xres: vec![0.0; n * n],
            xu: vec![0.0; n],
            yres: vec![0.0; n],
            ytarget: vec![0.0; n],
            e_cv: vec![0.0; n],
            dwdm: vec![0.0; n * n],
            dj2dm: vec![0.0; n * n],
            ddwdmdm: vec![0.0; n * n],
            ddj2dmdm: vec![0.0; n * n],
            deriv_ok: vec![false; n],
            ps: vec![0.0; n],
            pse: vec![0.0; n],
            dx: vec![0.0; n],
            mrow: vec![0.0; n],
            sum_aux: vec![0.0; n],
            sum_aux1: vec![0.0; n],
            prefix: vec![0.0; n + 1],
            mt: vec![0.0; n * n],
            dq: vec![0.0; n],
        }
    }
}
