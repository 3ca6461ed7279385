//! The learned inverse kinematics `ŷ = f̂(x)` (percept → command) and its Jacobian, the
//! inverse image Jacobian `J = ∂ŷ/∂x` of thesis eq. 5.2–5.3, both from one LWPR model
//! (docs/methods.md § LWPR).

use lwpr::{Lwpr, LwprBuilder};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError, check_finite, check_len};

/// LWPR settings of the inverse model. Defaults follow the LWPR documentation's rule of thumb
/// (docs/methods.md § LWPR): normalise inputs and outputs by their expected range, start with wide
/// spherical receptive fields and let distance-metric learning narrow them; `init_alpha` and
/// `w_gen` are the reference library's cross-function settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InverseModelConfig {
    /// Percept normalisation (`norm_in`, same for every input; pixels for a visual plant).
    pub percept_scale: f64,
    /// Command normalisation (`norm_out`, same for every output; µs for RC servos).
    pub command_scale: f64,
    /// Initial spherical distance metric `init_D` (in normalised units).
    pub init_d: f64,
    /// Learning rate of the distance metric.
    pub init_alpha: f64,
    /// Activation below which a new receptive field is created.
    pub w_gen: f64,
    /// Whether receptive fields adapt their size (distance-metric learning).
    pub update_d: bool,
    /// Activation cutoff of predictions.
    pub cutoff: f64,
}

impl Default for InverseModelConfig {
    fn default() -> Self {
        InverseModelConfig {
            percept_scale: 320.0,
            command_scale: 500.0,
            init_d: 25.0,
            init_alpha: 250.0,
            w_gen: 0.2,
            update_d: true,
            cutoff: 0.001,
        }
    }
}

impl InverseModelConfig {
    /// Checks every value (positive, finite scales; `w_gen`, `cutoff` in `(0, 1)`).
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("percept_scale", self.percept_scale),
            ("command_scale", self.command_scale),
            ("init_d", self.init_d),
            ("init_alpha", self.init_alpha),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(ServoError::InvalidParameter {
                    name,
                    reason: format!("must be finite and positive, got {v}"),
                });
            }
        }
        for (name, v) in [("w_gen", self.w_gen), ("cutoff", self.cutoff)] {
            if !(v > 0.0 && v < 1.0) {
                return Err(ServoError::InvalidParameter {
                    name,
                    reason: format!("must lie in (0, 1), got {v}"),
                });
            }
        }
        Ok(())
    }
}

/// The learned mapping from percept `x` (`n` values) to controlled command `y` (`m` values).
///
/// Deserialising goes through [`InverseModel::from_lwpr`]'s checks, and the LWPR part through
/// [`Lwpr::from_json`]'s loading (its checks and its scratch space): a model read with serde is
/// either usable or an error, never a model that panics later.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "InverseModelFile")]
pub struct InverseModel {
    lwpr: Lwpr,
    cutoff: f64,
}

/// The serialised form of [`InverseModel`], before its checks.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct InverseModelFile {
    lwpr: Lwpr,
    cutoff: f64,
}

impl TryFrom<InverseModelFile> for InverseModel {
    type Error = ServoError;

    fn try_from(file: InverseModelFile) -> Result<Self> {
        // Plain serde fills the LWPR fields only; its loader validates them and allocates
        // the model's scratch space.
        let lwpr = Lwpr::from_json(&file.lwpr.to_json())?;
        InverseModel::from_lwpr(lwpr, file.cutoff)
    }
}

/// A prediction with the inverse image Jacobian.
#[derive(Debug, Clone, PartialEq)]
pub struct InversePrediction {
    /// `ŷ = f̂(x)`.
    pub y: Vec<f64>,
    /// `J = ∂ŷ/∂x`, `m × n`.
    pub jacobian: DMatrix<f64>,
}

impl InverseModel {
    /// An empty model from `percept_dim` inputs to `command_dim` outputs.
    pub fn new(
        percept_dim: usize,
        command_dim: usize,
        config: &InverseModelConfig,
    ) -> Result<Self> {
        config.validate()?;
        if percept_dim == 0 || command_dim == 0 {
            return Err(ServoError::InvalidParameter {
                name: "dimensions",
                reason: "percept and command need at least one dimension".into(),
            });
        }
        // LWPR's limits, before the norm vectors are allocated (a huge dimension used to panic
        // with a capacity overflow there, before the builder could refuse it).
        lwpr::check_sizes(percept_dim, command_dim)?;
        let lwpr = LwprBuilder::new(percept_dim, command_dim)
            .norm_in(&vec![config.percept_scale; percept_dim])
            .norm_out(&vec![config.command_scale; command_dim])
            .init_d_spherical(config.init_d)
            .init_alpha(config.init_alpha)
            .w_gen(config.w_gen)
            .update_d(config.update_d)
            .build()?;
        Ok(InverseModel {
            lwpr,
            cutoff: config.cutoff,
        })
    }

    /// Wraps an existing LWPR model (e.g. loaded from disk).
    pub fn from_lwpr(lwpr: Lwpr, cutoff: f64) -> Result<Self> {
        if !(cutoff > 0.0 && cutoff < 1.0) {
            return Err(ServoError::InvalidParameter {
                name: "cutoff",
                reason: format!("must lie in (0, 1), got {cutoff}"),
            });
        }
        Ok(InverseModel { lwpr, cutoff })
    }

    /// The underlying LWPR model.
    pub fn lwpr(&self) -> &Lwpr {
        &self.lwpr
    }

    /// Percept dimension `n`.
    pub fn percept_dim(&self) -> usize {
        self.lwpr.n_in()
    }

    /// Command dimension `m`.
    pub fn command_dim(&self) -> usize {
        self.lwpr.n_out()
    }

    /// Number of training pairs seen.
    pub fn n_data(&self) -> u64 {
        self.lwpr.n_data()
    }

    /// One incremental update with the pair (percept `x`, command `y` that produced it).
    /// Invalid input leaves the model untouched.
    pub fn update(&mut self, x: &[f64], y: &[f64]) -> Result<()> {
        self.lwpr.update(x, y)?;
        Ok(())
    }

    /// `ŷ = f̂(x)`; [`ServoError::OutsideModel`] where no trustworthy receptive field is
    /// active for some output.
    pub fn predict(&self, x: &[f64]) -> Result<Vec<f64>> {
        check_len("percept", x, self.percept_dim())?;
        check_finite("percept", x)?;
        let (y, w) = self.lwpr.predict_with_max_activation(x, self.cutoff)?;
        if w.iter().any(|&w| w <= self.cutoff) {
            return Err(ServoError::OutsideModel);
        }
        Ok(y)
    }

    /// `ŷ = f̂(x)` and `J = ∂ŷ/∂x` (LWPR's analytic Jacobian).
    pub fn predict_with_jacobian(&self, x: &[f64]) -> Result<InversePrediction> {
        self.predict(x)?;
        let p = self.lwpr.predict_with_jacobian(x, self.cutoff)?;
        Ok(InversePrediction {
            y: p.y,
            jacobian: p.jacobian,
        })
    }
}
