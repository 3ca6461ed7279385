//! n-dimensional channel grids: separable (outer-product) encoding of vectors and n-D local
//! decoding. Channel `(k_0, …, k_{D−1})` of a grid is stored at the row-major flat index
//! `Σ_d k_d · stride_d` (last dimension fastest).

use serde::{Deserialize, Serialize};

use crate::basis::{MAX_CHANNELS, check_weight};
use crate::decode::{VALID_SLACK, check_channels, check_mode, sort_modes};
use crate::{ChanError, ChannelBasis};

/// The most channels one n-D decoding window may hold (the product of the bases' windows:
/// e.g. 7 dimensions of cos² with `m = 3`, or 5 with `m = 5`; a single [`ChannelBasis`] is
/// held to it too, so that every basis makes a 1-D grid). Decoding costs this many reads
/// per window, and a sparse histogram's decoding up to its square per stored channel, so grids
/// of more dimensions are refused by [`ChannelGrid::new`] rather than left to run for hours.
pub const MAX_WINDOW_CHANNELS: usize = 1 << 12;

/// A product of 1-D channel bases: the channel vector of `x = (x_0, …, x_{D−1})` is the outer
/// product of the per-dimension channel vectors.
///
/// ```
/// use chan_repr::{ChannelBasis, ChannelGrid, Kernel};
/// let b = ChannelBasis::integer(8, Kernel::Cos2 { m: 3 }).unwrap();
/// let grid = ChannelGrid::new(vec![b.clone(), b]).unwrap();
/// let c = grid.encode(&[2.25, 6.5]).unwrap();
/// let modes = grid.decode(&c).unwrap();
/// assert_eq!(modes.len(), 1);
/// assert!((modes[0].value[0] - 2.25).abs() < 1e-9 && (modes[0].value[1] - 6.5).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<ChannelBasis>", into = "Vec<ChannelBasis>")]
pub struct ChannelGrid {
    bases: Vec<ChannelBasis>,
    strides: Vec<usize>,
    len: usize,
}

/// One decoded mode of an n-D channel grid.
///
/// Deserialisation checks what the decoders produce: at least one coordinate
/// ([`ChanError::LengthMismatch`]), every coordinate finite, a finite certainty `> 0` and a
/// finite weight `≥ 0` ([`ChanError::InvalidParameter`] naming the field).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ModeNdSpec")]
pub struct ModeNd {
    /// The decoded vector (value space), one entry per dimension.
    pub value: Vec<f64>,
    /// Sum of the channel coefficients in the decoding window (eq. 2.5 in n-D).
    pub certainty: f64,
    /// The encoded weight this certainty corresponds to (1 for a plain encoded value).
    pub weight: f64,
}

/// The serialised form of a [`ModeNd`] (the same fields), checked by `check_mode`.
#[derive(Deserialize)]
struct ModeNdSpec {
    value: Vec<f64>,
    certainty: f64,
    weight: f64,
}

impl TryFrom<ModeNdSpec> for ModeNd {
    type Error = ChanError;
    fn try_from(s: ModeNdSpec) -> Result<Self, ChanError> {
        check_mode(&s.value, s.certainty, s.weight)?;
        Ok(ModeNd {
            value: s.value,
            certainty: s.certainty,
            weight: s.weight,
        })
    }
}

impl TryFrom<Vec<ChannelBasis>> for ChannelGrid {
    type Error = ChanError;
    fn try_from(bases: Vec<ChannelBasis>) -> Result<Self, ChanError> {
        ChannelGrid::new(bases)
    }
}

impl From<ChannelGrid> for Vec<ChannelBasis> {
    fn from(g: ChannelGrid) -> Self {
        g.bases
    }
}

impl ChannelGrid {
    /// A grid with one basis per dimension (at least one). Refused
    /// ([`ChanError::GridTooLarge`]) when a decoding window would hold more than
    /// [`MAX_WINDOW_CHANNELS`] channels or one encoded value would touch more than
    /// [`crate::MAX_CHANNELS`]: the product over dimensions that decoding and adding cost.
    ///
    /// ```
    /// use chan_repr::{ChanError, ChannelBasis, ChannelGrid, Kernel};
    /// let b = ChannelBasis::integer(4, Kernel::BSpline2).unwrap();
    /// assert!(ChannelGrid::new(vec![b.clone(); 7]).is_ok()); // 3⁷ = 2,187 channels a window
    /// assert!(matches!(
    ///     ChannelGrid::new(vec![b; 8]), // 3⁸ = 6,561
    ///     Err(ChanError::GridTooLarge { got: 6561, .. })
    /// ));
    /// ```
    pub fn new(bases: Vec<ChannelBasis>) -> Result<Self, ChanError> {
        if bases.is_empty() {
            return Err(ChanError::LengthMismatch {
                what: "dimensions (at least)",
                expected: 1,
                got: 0,
            });
        }
        let mut strides = vec![0; bases.len()];
        let mut len: usize = 1;
        for (d, b) in bases.iter().enumerate().rev() {
            strides[d] = len;
            len = len
                .checked_mul(b.len())
                .ok_or(ChanError::InvalidParameter {
                    name: "channels",
                    value: f64::INFINITY,
                    reason: "the grid has more channels than memory can address",
                })?;
        }
        let window = saturating_product(bases.iter().map(|b| b.kernel().window()));
        if window > MAX_WINDOW_CHANNELS {
            return Err(ChanError::GridTooLarge {
                what: "channels in one decoding window",
                got: window,
                max: MAX_WINDOW_CHANNELS,
            });
        }
        let active = saturating_product(bases.iter().map(|b| b.kernel().max_active().min(b.len())));
        if active > MAX_CHANNELS {
            return Err(ChanError::GridTooLarge {
                what: "channels one encoded value touches",
                got: active,
                max: MAX_CHANNELS,
            });
        }
        Ok(ChannelGrid {
            bases,
            strides,
            len,
        })
    }

    /// Bounds on the sum of all channel values of one value of weight 1 encoded anywhere in
    /// the grid's representable range: the product of the bases'
    /// [`Kernel::unit_mass_bounds`](crate::Kernel::unit_mass_bounds) (the encoding is their outer product).
    pub fn unit_mass_bounds(&self) -> (f64, f64) {
        self.bases.iter().fold((1.0, 1.0), |(lo, hi), b| {
            let (l, h) = b.kernel().unit_mass_bounds();
            (lo * l, hi * h)
        })
    }

    /// Number of dimensions `D`.
    pub fn dims(&self) -> usize {
        self.bases.len()
    }

    /// Total number of channels `Π N_d`.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: every dimension has channels.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The basis of dimension `d` (`None` when `d ≥ dims()`).
    pub fn basis(&self, d: usize) -> Option<&ChannelBasis> {
        self.bases.get(d)
    }

    /// All bases, one per dimension.
    pub fn bases(&self) -> &[ChannelBasis] {
        &self.bases
    }

    /// Row-major strides (last dimension 1).
    pub fn strides(&self) -> &[usize] {
        &self.strides
    }

    /// Flat index of the channel with per-dimension indices `k` (one per dimension, each
    /// below its basis's channel count).
    ///
    /// ```
    /// use chan_repr::{ChannelBasis, ChannelGrid, Kernel};
    /// let b = ChannelBasis::integer(5, Kernel::BSpline2).unwrap();
    /// let g = ChannelGrid::new(vec![b.clone(), b]).unwrap();
    /// assert_eq!(g.flat_index(&[2, 3]).unwrap(), 13);
    /// assert!(g.flat_index(&[0, 5]).is_err() && g.flat_index(&[1]).is_err());
    /// ```
    pub fn flat_index(&self, k: &[usize]) -> Result<usize, ChanError> {
        if k.len() != self.dims() {
            return Err(ChanError::LengthMismatch {
                what: "channel indices",
                expected: self.dims(),
                got: k.len(),
            });
        }
        for (dim, (&index, b)) in k.iter().zip(&self.bases).enumerate() {
            if index >= b.len() {
                return Err(ChanError::IndexOutOfBounds {
                    dim,
                    index,
                    len: b.len(),
                });
            }
        }
        Ok(self.flat_index_unchecked(k))
    }

    /// [`flat_index`](Self::flat_index) for indices known to be in bounds.
    #[inline]
    fn flat_index_unchecked(&self, k: &[usize]) -> usize {
        k.iter().zip(&self.strides).map(|(k, s)| k * s).sum()
    }

    /// Checks the grid is small enough for a dense channel vector ([`crate::MAX_CHANNELS`]).
    pub(crate) fn check_dense(&self) -> Result<(), ChanError> {
        if self.len > MAX_CHANNELS {
            return Err(ChanError::TooManyChannels {
                got: self.len,
                max: MAX_CHANNELS,
            });
        }
        Ok(())
    }

    /// Checks `x` has `D` finite, representable coordinates; writes their index coordinates.
    pub(crate) fn checked_indices(&self, x: &[f64], t: &mut Vec<f64>) -> Result<(), ChanError> {
        if x.len() != self.dims() {
            return Err(ChanError::LengthMismatch {
                what: "coordinates",
                expected: self.dims(),
                got: x.len(),
            });
        }
        t.clear();
        for (b, &xi) in self.bases.iter().zip(x) {
            t.push(b.checked_index(xi)?);
        }
        Ok(())
    }

    /// Calls `f(flat, value)` for every active channel of the index coordinates `t`, using
    /// `scratch` (made by [`ActiveScratch::new`] for this grid's dimensions), so that no call
    /// allocates once the scratch's lists have grown. `t` is not validated.
    pub(crate) fn for_each_active(
        &self,
        t: &[f64],
        scratch: &mut ActiveScratch,
        mut f: impl FnMut(usize, f64),
    ) {
        let ActiveScratch { lists, pos } = scratch;
        for ((b, &td), list) in self.bases.iter().zip(t).zip(lists.iter_mut()) {
            list.clear();
            b.for_each_active(td, |k, v| list.push((k, v)));
            if list.is_empty() {
                return;
            }
        }
        let dims = self.dims();
        pos.clear();
        pos.resize(dims, 0);
        loop {
            let (mut flat, mut v) = (0, 1.0);
            for d in 0..dims {
                let (k, vd) = lists[d][pos[d]];
                flat += k * self.strides[d];
                v *= vd;
            }
            f(flat, v);
            if !advance(pos, |d| lists[d].len()) {
                return;
            }
        }
    }

    /// Encodes the vector `x` into a dense grid channel vector (outer product of eq. 2.1).
    pub fn encode(&self, x: &[f64]) -> Result<Vec<f64>, ChanError> {
        self.encode_weighted(x, 1.0)
    }

    /// Encodes `x` with certainty `weight ≥ 0`.
    /// Grids of more than [`crate::MAX_CHANNELS`] channels are refused before allocating.
    pub fn encode_weighted(&self, x: &[f64], weight: f64) -> Result<Vec<f64>, ChanError> {
        self.check_dense()?;
        let mut c = vec![0.0; self.len];
        self.accumulate(x, weight, &mut c)?;
        Ok(c)
    }

    /// Adds `weight ·` the channel vector of `x` into `out` (length [`len`](Self::len)).
    pub fn accumulate(&self, x: &[f64], weight: f64, out: &mut [f64]) -> Result<(), ChanError> {
        check_weight(weight)?;
        if out.len() != self.len {
            return Err(ChanError::LengthMismatch {
                what: "channels",
                expected: self.len,
                got: out.len(),
            });
        }
        let mut t = Vec::with_capacity(self.dims());
        self.checked_indices(x, &mut t)?;
        let mut scratch = ActiveScratch::new(self.dims());
        self.for_each_active(&t, &mut scratch, |k, v| out[k] += weight * v);
        Ok(())
    }

    /// All modes of the dense grid channel vector `c`, by decreasing certainty.
    pub fn decode(&self, c: &[f64]) -> Result<Vec<ModeNd>, ChanError> {
        check_channels(c, self.len)?;
        let counts: Vec<usize> = self
            .bases
            .iter()
            // Every basis has at least one window of channels (`ChannelBasis::new`).
            .map(|b| b.len() - b.kernel().window() + 1)
            .collect();
        let mut modes = Vec::new();
        let mut scratch = WindowScratch::new(self);
        let mut start = vec![0usize; self.dims()];
        loop {
            if let Some(m) = self.decode_window(&start, |i| c[i], &mut scratch) {
                modes.push(m);
            }
            if !advance(&mut start, |d| counts[d]) {
                break;
            }
        }
        Ok(finish_modes(self, modes))
    }

    /// Decodes the window whose first channel has per-dimension indices `start`, reading
    /// coefficients through `get(flat)`; `None` when the window has no valid estimate.
    pub(crate) fn decode_window(
        &self,
        start: &[usize],
        get: impl Fn(usize) -> f64,
        s: &mut WindowScratch,
    ) -> Option<ModeNd> {
        let dims = self.dims();
        for (m, b) in s.marginals.iter_mut().zip(&self.bases) {
            m.clear();
            m.resize(b.kernel().window(), 0.0);
        }
        let base = self.flat_index_unchecked(start);
        let mut total = 0.0;
        s.pos.iter_mut().for_each(|p| *p = 0);
        loop {
            let flat = base
                + s.pos
                    .iter()
                    .zip(&self.strides)
                    .map(|(p, st)| p * st)
                    .sum::<usize>();
            let v = get(flat);
            if v != 0.0 {
                total += v;
                for d in 0..dims {
                    s.marginals[d][s.pos[d]] += v;
                }
            }
            if !advance(&mut s.pos, |d| s.marginals[d].len()) {
                break;
            }
        }
        if total <= 0.0 {
            return None;
        }
        let mut value = Vec::with_capacity(dims);
        let mut unit = 1.0;
        for (d, b) in self.bases.iter().enumerate() {
            let k = b.kernel();
            let offset = k.decode_window_unchecked(&s.marginals[d])?;
            let (lo, hi) = k.valid_offsets();
            if offset < lo - VALID_SLACK || offset > hi + VALID_SLACK {
                return None;
            }
            unit *= k.unit_window_sum(offset);
            value.push(b.from_index(start[d] as f64 + offset));
        }
        Some(ModeNd {
            value,
            certainty: total,
            weight: total / unit,
        })
    }
}

/// The product of `counts`, saturated at `usize::MAX`.
fn saturating_product(counts: impl Iterator<Item = usize>) -> usize {
    counts.fold(1usize, |p, c| p.saturating_mul(c))
}

/// Reusable buffers for n-D window decoding.
pub(crate) struct WindowScratch {
    marginals: Vec<Vec<f64>>,
    pos: Vec<usize>,
}

impl WindowScratch {
    pub(crate) fn new(grid: &ChannelGrid) -> Self {
        WindowScratch {
            marginals: vec![Vec::new(); grid.dims()],
            pos: vec![0; grid.dims()],
        }
    }
}

/// The reusable buffers of [`ChannelGrid::for_each_active`]: each dimension's active channels
/// and the position in their product.
#[derive(Debug, Clone)]
pub(crate) struct ActiveScratch {
    lists: Vec<Vec<(usize, f64)>>,
    pos: Vec<usize>,
}

impl ActiveScratch {
    /// Buffers for a grid of `dims` dimensions.
    pub(crate) fn new(dims: usize) -> Self {
        ActiveScratch {
            lists: vec![Vec::new(); dims],
            pos: Vec::with_capacity(dims),
        }
    }
}

/// Odometer step over `0..count(d)` per dimension (last dimension fastest); false after the
/// last index, which leaves `idx` all zero.
pub(crate) fn advance(idx: &mut [usize], count: impl Fn(usize) -> usize) -> bool {
    for d in (0..idx.len()).rev() {
        idx[d] += 1;
        if idx[d] < count(d) {
            return true;
        }
        idx[d] = 0;
    }
    false
}

/// Merges twins (the same mode found by windows that meet at their valid ranges' borders) and
/// sorts by decreasing certainty.
pub(crate) fn finish_modes(grid: &ChannelGrid, mut modes: Vec<ModeNd>) -> Vec<ModeNd> {
    sort_modes(&mut modes, |m| m.certainty, |m| m.value.clone());
    let mut kept: Vec<ModeNd> = Vec::with_capacity(modes.len());
    for m in modes {
        let twin = kept.iter().any(|k| {
            k.value
                .iter()
                .zip(&m.value)
                .zip(grid.bases())
                .all(|((a, b), basis)| {
                    (basis.to_index(*a) - basis.to_index(*b)).abs() <= 2.0 * VALID_SLACK
                })
        });
        if !twin {
            kept.push(m);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Kernel;

    fn grid2(kernel: Kernel) -> ChannelGrid {
        let b = ChannelBasis::covering(0.0, 10.0, 12, kernel).unwrap();
        ChannelGrid::new(vec![b.clone(), b]).unwrap()
    }

    #[test]
    fn encoding_is_the_outer_product() {
        let g = grid2(Kernel::Cos2 { m: 3 });
        let x = [3.1, 7.7];
        let c = g.encode(&x).unwrap();
        let (c0, c1) = (
            g.bases()[0].encode(x[0]).unwrap(),
            g.bases()[1].encode(x[1]).unwrap(),
        );
        for i in 0..12 {
            for j in 0..12 {
                assert_eq!(c[g.flat_index(&[i, j]).unwrap()], c0[i] * c1[j]);
            }
        }
    }

    #[test]
    fn two_dimensional_round_trip_for_every_kernel() {
        for kernel in [
            Kernel::Cos2 { m: 3 },
            Kernel::Cos2 { m: 5 },
            Kernel::BSpline2,
            Kernel::Gaussian { sigma: 0.9 },
        ] {
            let g = grid2(kernel);
            for x in [[0.0, 10.0], [4.5, 5.25], [9.99, 0.01]] {
                let modes = g.decode(&g.encode_weighted(&x, 2.0).unwrap()).unwrap();
                assert_eq!(modes.len(), 1, "{kernel:?} {x:?}: {modes:?}");
                assert!(
                    (modes[0].value[0] - x[0]).abs() < 1e-9
                        && (modes[0].value[1] - x[1]).abs() < 1e-9
                );
                assert!((modes[0].weight - 2.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn flat_index_checks_bounds() {
        // Issue 24 #11: out-of-range indices used to give another channel's flat index.
        let g = grid2(Kernel::BSpline2);
        assert_eq!(g.flat_index(&[1, 2]), Ok(14));
        assert_eq!(
            g.flat_index(&[0, 12]),
            Err(ChanError::IndexOutOfBounds {
                dim: 1,
                index: 12,
                len: 12
            })
        );
        assert!(g.flat_index(&[12, 0]).is_err());
        assert!(g.flat_index(&[1, 2, 3]).is_err());
    }

    #[test]
    fn dense_vectors_of_huge_grids_are_refused() {
        let b = ChannelBasis::integer(1000, Kernel::Cos2 { m: 3 }).unwrap();
        let g = ChannelGrid::new(vec![b.clone(), b.clone(), b]).unwrap(); // 10⁹ channels
        assert!(matches!(
            g.encode(&[10.0, 10.0, 10.0]),
            Err(ChanError::TooManyChannels { .. })
        ));
        assert!(matches!(
            crate::SoftHistogram::new(g),
            Err(ChanError::TooManyChannels { .. })
        ));
    }

    #[test]
    fn bad_vectors_are_errors() {
        let g = grid2(Kernel::BSpline2);
        assert!(matches!(
            g.encode(&[1.0]),
            Err(ChanError::LengthMismatch { .. })
        ));
        assert!(matches!(
            g.encode(&[1.0, f64::NAN]),
            Err(ChanError::NonFinite { .. })
        ));
        assert!(matches!(
            g.encode(&[1.0, 11.0]),
            Err(ChanError::OutOfRange { .. })
        ));
        assert!(ChannelGrid::new(vec![]).is_err());
        assert!(matches!(
            g.decode(&[0.0; 5]),
            Err(ChanError::LengthMismatch { .. })
        ));
    }
}
