//! The one dense encoding path of the 1-D bases, bounded ([`crate::ChannelBasis`]) and periodic
//! ([`crate::PeriodicBasis`]): validate the weight, the output length and the value, then add
//! `weight · B(t − k)` into every active channel `k`. Each basis supplies its own index
//! coordinate and active channels; the arithmetic is the same for both.

use crate::ChanError;
use crate::basis::check_weight;

/// A 1-D basis as the encoder sees it.
pub(crate) trait Line {
    /// Number of channels `N`.
    fn channels(&self) -> usize;
    /// The checked index coordinate of `x` (the basis's `checked_index`).
    fn index(&self, x: f64) -> Result<f64, ChanError>;
    /// `f(k, B(t − k))` for every active channel (the basis's `for_each_active`).
    fn each_active(&self, t: f64, f: impl FnMut(usize, f64));
}

/// Adds `weight ·` the channel vector of `x` into `out` (length `N`); a rejected value leaves
/// `out` unchanged.
#[inline]
pub(crate) fn accumulate<L: Line>(
    line: &L,
    x: f64,
    weight: f64,
    out: &mut [f64],
) -> Result<(), ChanError> {
    check_weight(weight)?;
    let n = line.channels();
    if out.len() != n {
        return Err(ChanError::LengthMismatch {
            what: "channels",
            expected: n,
            got: out.len(),
        });
    }
    let t = line.index(x)?;
    line.each_active(t, |k, v| out[k] += weight * v);
    Ok(())
}

/// The dense channel vector of `x` scaled by `weight`.
pub(crate) fn encode_weighted<L: Line>(
    line: &L,
    x: f64,
    weight: f64,
) -> Result<Vec<f64>, ChanError> {
    let mut c = vec![0.0; line.channels()];
    accumulate(line, x, weight, &mut c)?;
    Ok(c)
}
