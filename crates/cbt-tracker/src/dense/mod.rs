//! The dense layouts ([`Layout::Separable`](crate::Layout) and
//! [`Layout::SparseJoint`](crate::Layout)): models over every cell of the grid (per axis, or
//! sparse over the joint grid) and the decoder of a posterior held on the whole grid.
//!
//! - `observation`: the observation model `O` (per axis or joint, clutter floor);
//! - `system`: the first- and second-order system models `S` and `T`;
//! - `decode`: the local decoder restricted to the heaviest windows;
//! - `posterior`: the posterior over every cell and one step of the filter on it.

mod decode;
mod observation;
mod posterior;
mod system;

pub(crate) use decode::{MIN_SHARE, decode_posterior};
pub(crate) use observation::{AxisObservation, JointObservation};
pub(crate) use posterior::{DensePosterior, check_marginals, uniform_marginals};
pub(crate) use system::{AxisSystem1, AxisSystem2, JointSystem};
