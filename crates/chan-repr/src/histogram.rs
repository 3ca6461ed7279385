//! Soft histograms: sums of (weighted) channel vectors, the channel representation of a
//! distribution (thesis ch. 2, eq. 2.9). Each added value touches only its active channels.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::basis::{MAX_MASS, check_weight};
use crate::decode::check_coefficient;
use crate::grid::{ActiveScratch, WindowScratch, advance, finish_modes};
use crate::{ChanError, ChannelBasis, ChannelGrid, Kernel, ModeNd};

/// A dense soft histogram over an n-D channel grid.
///
/// ```
/// use chan_repr::{ChannelBasis, ChannelGrid, Kernel, SoftHistogram};
/// let b = ChannelBasis::covering(0.0, 1.0, 16, Kernel::BSpline2).unwrap();
/// let mut h = SoftHistogram::new(ChannelGrid::new(vec![b]).unwrap()).unwrap();
/// for x in [0.20, 0.21, 0.19, 0.80] {
///     h.add(&[x], 1.0).unwrap();
/// }
/// let modes = h.decode().unwrap();
/// assert!((modes[0].value[0] - 0.20).abs() < 0.01); // three samples near 0.2 win
/// assert!((modes[1].value[0] - 0.80).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "DenseSpec", into = "DenseSpec")]
pub struct SoftHistogram {
    grid: ChannelGrid,
    counts: Vec<f64>,
    total_weight: f64,
    /// Upper bound on every coefficient and on the total weight (each added value raises no
    /// coefficient by more than its weight, as kernel values are at most 1): adding is refused
    /// when it would pass [`MAX_MASS`], in O(1).
    #[serde(skip)]
    ceiling: f64,
    #[serde(skip)]
    t: Vec<f64>,
    #[serde(skip)]
    scratch: ActiveScratch,
}

/// Equality of the represented distribution (grid, coefficients, total weight), not of scratch.
impl PartialEq for SoftHistogram {
    fn eq(&self, o: &Self) -> bool {
        self.grid == o.grid && self.counts == o.counts && self.total_weight == o.total_weight
    }
}

/// Equality of the represented distribution (grid, coefficients, total weight), not of scratch.
impl PartialEq for SparseHistogram {
    fn eq(&self, o: &Self) -> bool {
        self.grid == o.grid && self.counts == o.counts && self.total_weight == o.total_weight
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DenseSpec {
    grid: ChannelGrid,
    counts: Vec<f64>,
    total_weight: f64,
}

impl TryFrom<DenseSpec> for SoftHistogram {
    type Error = ChanError;
    fn try_from(s: DenseSpec) -> Result<Self, ChanError> {
        SoftHistogram::from_counts(s.grid, s.counts, s.total_weight)
    }
}

impl From<SoftHistogram> for DenseSpec {
    fn from(h: SoftHistogram) -> Self {
        DenseSpec {
            grid: h.grid,
            counts: h.counts,
            total_weight: h.total_weight,
        }
    }
}

/// Checks that adding `weight` to a histogram whose coefficients and total are at most
/// `ceiling` keeps them within [`MAX_MASS`]; returns the new ceiling.
fn raise_ceiling(ceiling: f64, weight: f64) -> Result<f64, ChanError> {
    let raised = ceiling + weight;
    if raised > MAX_MASS {
        return Err(ChanError::TooLarge {
            what: "histogram total weight",
            value: raised,
            max: MAX_MASS,
        });
    }
    Ok(raised)
}

impl SoftHistogram {
    /// An empty histogram over `grid` (at most [`crate::MAX_CHANNELS`] channels, checked before
    /// allocating).
    pub fn new(grid: ChannelGrid) -> Result<Self, ChanError> {
        grid.check_dense()?;
        let counts = vec![0.0; grid.len()];
        Ok(SoftHistogram::with(grid, counts, 0.0))
    }

    /// An empty 1-D histogram over `basis` (never too large: a basis has at most
    /// [`crate::MAX_CHANNELS`] channels and a decoding window of at most
    /// [`crate::MAX_WINDOW_CHANNELS`], both checked by [`ChannelBasis::new`]).
    pub fn one_d(basis: ChannelBasis) -> Self {
        let grid = ChannelGrid::new(vec![basis])
            .expect("a basis is a valid 1-D grid (ChannelBasis::new bounds its window)");
        SoftHistogram::new(grid).expect("a basis fits in a dense vector")
    }

    /// A histogram with given channel coefficients and the total weight of the values they
    /// encode (checked: length, finite, non-negative, at most [`MAX_MASS`], and consistent:
    /// the coefficients must sum to what `total_weight` of encoded values can give, between
    /// the bounds of [`ChannelGrid::unit_mass_bounds`] times `total_weight`, to a relative
    /// 1e-6 for rounding; [`ChanError::InconsistentTotal`] otherwise).
    ///
    /// ```
    /// use chan_repr::{ChanError, ChannelBasis, ChannelGrid, Kernel, SoftHistogram};
    /// let grid = ChannelGrid::new(vec![ChannelBasis::integer(6, Kernel::BSpline2).unwrap()]).unwrap();
    /// let counts = vec![0.0, 0.125, 0.75, 0.125, 0.0, 0.0]; // one value at 2
    /// assert!(SoftHistogram::from_counts(grid.clone(), counts.clone(), 1.0).is_ok());
    /// assert!(matches!(
    ///     SoftHistogram::from_counts(grid, counts, 7.0),
    ///     Err(ChanError::InconsistentTotal { .. })
    /// ));
    /// ```
    pub fn from_counts(
        grid: ChannelGrid,
        counts: Vec<f64>,
        total_weight: f64,
    ) -> Result<Self, ChanError> {
        crate::decode::check_channels(&counts, grid.len())?;
        check_weight(total_weight)?;
        check_total(&grid, &counts, total_weight)?;
        Ok(SoftHistogram::with(grid, counts, total_weight))
    }

    fn with(grid: ChannelGrid, counts: Vec<f64>, total_weight: f64) -> Self {
        let dims = grid.dims();
        let ceiling = counts.iter().copied().fold(total_weight, f64::max);
        SoftHistogram {
            grid,
            counts,
            total_weight,
            ceiling,
            t: Vec::with_capacity(dims),
            scratch: ActiveScratch::new(dims),
        }
    }

    /// Adds the value `x` (one coordinate per dimension) with certainty `weight`. Costs
    /// O(active channels) and allocates nothing after the first call. Refused, leaving the
    /// histogram unchanged, when the total would pass [`MAX_MASS`].
    pub fn add(&mut self, x: &[f64], weight: f64) -> Result<(), ChanError> {
        check_weight(weight)?;
        let ceiling = raise_ceiling(self.ceiling, weight)?;
        self.grid.checked_indices(x, &mut self.t)?;
        let counts = &mut self.counts;
        self.grid
            .for_each_active(&self.t, &mut self.scratch, |k, v| counts[k] += weight * v);
        self.total_weight += weight;
        self.ceiling = ceiling;
        Ok(())
    }

    /// Adds many 1-D values of weight 1 (the histogram must be 1-D). All or nothing: every
    /// value is checked before any is added, so a rejected batch changes no state.
    pub fn extend_1d(&mut self, xs: &[f64]) -> Result<(), ChanError> {
        if self.grid.dims() != 1 {
            return Err(ChanError::LengthMismatch {
                what: "dimensions",
                expected: self.grid.dims(),
                got: 1,
            });
        }
        let ceiling = raise_ceiling(self.ceiling, xs.len() as f64)?;
        let basis = &self.grid.bases()[0];
        basis.check_all(xs)?;
        // Every value passed `checked_index`, so its index is finite and inside the
        // representable range up to the slack that `checked_index` clamps away.
        let (tlo, thi) = basis.representable_index_range();
        let counts = &mut self.counts;
        if basis.kernel() == Kernel::BSpline2 {
            add_bspline2(basis, (tlo, thi), xs, counts);
        } else if let Kernel::Cos2 { m } = basis.kernel() {
            for &x in xs {
                let t = basis.to_index(x).clamp(tlo, thi);
                basis.for_each_active_cos2_reduced(m, t, |k, v| counts[k] += v);
            }
        } else {
            for &x in xs {
                let t = basis.to_index(x).clamp(tlo, thi);
                basis.for_each_active(t, |k, v| counts[k] += v);
            }
        }
        self.total_weight += xs.len() as f64;
        self.ceiling = ceiling;
        Ok(())
    }

    /// The grid.
    pub fn grid(&self) -> &ChannelGrid {
        &self.grid
    }

    /// The channel coefficients (row-major).
    pub fn counts(&self) -> &[f64] {
        &self.counts
    }

    /// Sum of the weights added so far.
    pub fn total_weight(&self) -> f64 {
        self.total_weight
    }

    /// Resets every channel to zero.
    pub fn clear(&mut self) {
        self.counts.iter_mut().for_each(|c| *c = 0.0);
        self.total_weight = 0.0;
        self.ceiling = 0.0;
    }

    /// All modes, by decreasing certainty.
    pub fn decode(&self) -> Result<Vec<ModeNd>, ChanError> {
        self.grid.decode(&self.counts)
    }
}

/// Adds validated 1-D values to a dense quadratic B-spline histogram without the general
/// per-channel kernel evaluation: with `c` the channel nearest to the index coordinate `t` and
/// `d = t − c ∈ [−½, ½]`, the three active channels `c − 1, c, c + 1` receive
/// `½(½ − d)²`, `¾ − d²` and `½(½ + d)²` (the kernel's pieces, eq. 2.1 with the B-spline of
/// Felsberg et al.), which sum to 1. Equal to [`ChannelBasis::for_each_active`]'s values up to
/// rounding. `t` is clamped to the representable range `[½, n − 3/2]`, so `c ≥ 1`; at its upper
/// end `c + 1 = n` gets weight 0 and is skipped.
fn add_bspline2(basis: &ChannelBasis, (tlo, thi): (f64, f64), xs: &[f64], counts: &mut [f64]) {
    let n = counts.len();
    for &x in xs {
        let t = basis.to_index(x).clamp(tlo, thi);
        let c = t.round();
        let d = t - c;
        let k = c as usize;
        let (below, above) = (0.5 - d, 0.5 + d);
        counts[k - 1] += 0.5 * below * below;
        counts[k] += 0.75 - d * d;
        if k + 1 < n {
            counts[k + 1] += 0.5 * above * above;
        }
    }
}

/// A sparse soft histogram: only channels that received mass are stored (ordered map, so
/// iteration and decoding are deterministic). For large n-D grids with few samples.
///
/// ```
/// use chan_repr::{ChannelBasis, ChannelGrid, Kernel, SparseHistogram};
/// let b = ChannelBasis::integer(1000, Kernel::Cos2 { m: 3 }).unwrap(); // centres 1..=1000
/// let mut h = SparseHistogram::new(ChannelGrid::new(vec![b.clone(), b.clone(), b]).unwrap());
/// h.add(&[10.0, 500.0, 990.0], 1.0).unwrap(); // on centres: 3 active channels per axis
/// assert_eq!(h.nonzero(), 27); // 3 × 3 × 3 stored of 10⁹
/// assert!((h.decode().unwrap()[0].value[1] - 500.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct SparseHistogram {
    grid: ChannelGrid,
    counts: BTreeMap<usize, f64>,
    total_weight: f64,
    /// Upper bound on every coefficient and the total (as in [`SoftHistogram`]).
    ceiling: f64,
    t: Vec<f64>,
    scratch: ActiveScratch,
}

impl SparseHistogram {
    /// An empty sparse histogram over `grid`.
    pub fn new(grid: ChannelGrid) -> Self {
        let dims = grid.dims();
        SparseHistogram {
            grid,
            counts: BTreeMap::new(),
            total_weight: 0.0,
            ceiling: 0.0,
            t: Vec::with_capacity(dims),
            scratch: ActiveScratch::new(dims),
        }
    }

    /// Adds the value `x` with certainty `weight` (O(active channels · log stored)). Refused,
    /// leaving the histogram unchanged, when the total would pass [`MAX_MASS`].
    pub fn add(&mut self, x: &[f64], weight: f64) -> Result<(), ChanError> {
        check_weight(weight)?;
        let ceiling = raise_ceiling(self.ceiling, weight)?;
        self.grid.checked_indices(x, &mut self.t)?;
        let counts = &mut self.counts;
        self.grid
            .for_each_active(&self.t, &mut self.scratch, |k, v| {
                *counts.entry(k).or_insert(0.0) += weight * v
            });
        self.total_weight += weight;
        self.ceiling = ceiling;
        Ok(())
    }

    /// Number of stored (non-zero) channels.
    pub fn nonzero(&self) -> usize {
        self.counts.len()
    }

    /// The coefficient of the channel at flat index `k` (0 when not stored).
    pub fn get(&self, k: usize) -> f64 {
        self.counts.get(&k).copied().unwrap_or(0.0)
    }

    /// Stored channels as `(flat index, coefficient)` in increasing index order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.counts.iter().map(|(&k, &v)| (k, v))
    }

    /// Sum of the weights added so far.
    pub fn total_weight(&self) -> f64 {
        self.total_weight
    }

    /// The grid.
    pub fn grid(&self) -> &ChannelGrid {
        &self.grid
    }

    /// The dense equivalent (refused for grids of more than [`crate::MAX_CHANNELS`]).
    pub fn to_dense(&self) -> Result<SoftHistogram, ChanError> {
        self.grid.check_dense()?;
        let mut counts = vec![0.0; self.grid.len()];
        for (k, v) in self.iter() {
            counts[k] = v;
        }
        Ok(SoftHistogram::with(
            self.grid.clone(),
            counts,
            self.total_weight,
        ))
    }

    /// All modes, by decreasing certainty: only windows containing a stored channel are
    /// visited, so the cost follows the number of stored channels, not the grid size.
    /// Gives the same modes as decoding [`to_dense`](Self::to_dense).
    pub fn decode(&self) -> Result<Vec<ModeNd>, ChanError> {
        for (_, v) in self.iter() {
            check_coefficient(v)?;
        }
        let g = &self.grid;
        let dims = g.dims();
        let mut starts: BTreeSet<Vec<usize>> = BTreeSet::new();
        let mut k = vec![0usize; dims];
        for (flat, _) in self.iter() {
            let mut rest = flat;
            for (kd, &stride) in k.iter_mut().zip(g.strides()) {
                *kd = rest / stride;
                rest %= stride;
            }
            // Every window start within W−1 below k in each dimension, clipped to the grid.
            let lo: Vec<usize> = (0..dims)
                .map(|d| k[d].saturating_sub(g.bases()[d].kernel().window() - 1))
                .collect();
            let hi: Vec<usize> = (0..dims)
                .map(|d| k[d].min(g.bases()[d].len() - g.bases()[d].kernel().window()))
                .collect();
            if (0..dims).any(|d| lo[d] > hi[d]) {
                continue;
            }
            let mut off = vec![0usize; dims];
            loop {
                starts.insert(lo.iter().zip(&off).map(|(l, o)| l + o).collect());
                if !advance(&mut off, |d| hi[d] - lo[d] + 1) {
                    break;
                }
            }
        }
        let mut scratch = WindowScratch::new(g);
        let modes = starts
            .iter()
            .filter_map(|s| g.decode_window(s, |i| self.get(i), &mut scratch))
            .collect();
        Ok(finish_modes(g, modes))
    }
}

/// Relative slack for rounding in [`check_total`]: sums of many encodings drift by far less.
const TOTAL_SLACK: f64 = 1e-6;

/// Checks the coefficients sum to what `total_weight` of encoded values can give.
fn check_total(grid: &ChannelGrid, counts: &[f64], total_weight: f64) -> Result<(), ChanError> {
    let counts_sum: f64 = counts.iter().sum();
    let (unit_lo, unit_hi) = grid.unit_mass_bounds();
    let (lo, hi) = (unit_lo * total_weight, unit_hi * total_weight);
    if counts_sum < lo * (1.0 - TOTAL_SLACK) || counts_sum > hi * (1.0 + TOTAL_SLACK) {
        return Err(ChanError::InconsistentTotal {
            total_weight,
            counts_sum,
            lo,
            hi,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Kernel;

    #[test]
    fn histogram_equals_sum_of_encodings() {
        let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
        let mut h = SoftHistogram::one_d(b.clone());
        h.add(&[3.3], 1.0).unwrap();
        h.add(&[6.8], 0.5).unwrap();
        let (c1, c2) = (b.encode(3.3).unwrap(), b.encode_weighted(6.8, 0.5).unwrap());
        for k in 0..10 {
            assert!((h.counts()[k] - (c1[k] + c2[k])).abs() < 1e-15);
        }
        assert_eq!(h.total_weight(), 1.5);
        let mut g = SoftHistogram::one_d(b);
        g.extend_1d(&[3.3, 6.8]).unwrap();
        assert_eq!(g.decode().unwrap().len(), 2);
    }

    #[test]
    fn bad_values_leave_the_histogram_unchanged() {
        let b = ChannelBasis::integer(10, Kernel::BSpline2).unwrap();
        let mut h = SoftHistogram::one_d(b);
        h.add(&[4.0], 1.0).unwrap();
        let before = h.clone();
        assert!(h.add(&[f64::NAN], 1.0).is_err());
        assert!(h.add(&[4.0], -1.0).is_err());
        assert!(h.add(&[40.0], 1.0).is_err());
        assert!(h.add(&[4.0, 4.0], 1.0).is_err());
        assert_eq!(h, before);
    }

    #[test]
    fn weights_that_would_overflow_are_refused() {
        // Issue 24 #11: 1e308 added twice made the histogram infinite and every later decode
        // fail. Now such weights are refused and the histogram stays decodable.
        let b = ChannelBasis::integer(10, Kernel::BSpline2).unwrap();
        let grid = ChannelGrid::new(vec![b.clone()]).unwrap();
        let mut h = SoftHistogram::one_d(b);
        let mut s = SparseHistogram::new(grid);
        assert!(matches!(
            h.add(&[4.0], 1e308),
            Err(ChanError::TooLarge { .. })
        ));
        h.add(&[4.0], 0.6 * MAX_MASS).unwrap();
        s.add(&[4.0], 0.6 * MAX_MASS).unwrap();
        let (before, sparse_before) = (h.clone(), s.clone());
        assert!(matches!(
            h.add(&[6.0], 0.6 * MAX_MASS),
            Err(ChanError::TooLarge { .. })
        ));
        assert!(matches!(
            s.add(&[6.0], 0.6 * MAX_MASS),
            Err(ChanError::TooLarge { .. })
        ));
        assert_eq!(h, before);
        assert_eq!(s, sparse_before);
        let modes = h.decode().unwrap();
        assert!((modes[0].weight / (0.6 * MAX_MASS) - 1.0).abs() < 1e-12);
        assert_eq!(s.decode().unwrap(), modes);
        // The bound survives a round trip through serde and from_counts.
        let mut back: SoftHistogram =
            serde_json::from_str(&serde_json::to_string(&h).unwrap()).unwrap();
        assert!(back.add(&[6.0], 0.6 * MAX_MASS).is_err());
        let mut full = SoftHistogram::one_d(ChannelBasis::integer(10, Kernel::BSpline2).unwrap());
        assert!(full.extend_1d(&[4.0; 3]).is_ok());
        assert_eq!(full.total_weight(), 3.0);
    }

    #[test]
    fn a_rejected_batch_changes_nothing() {
        let mut h = SoftHistogram::one_d(ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap());
        h.extend_1d(&[3.3, 6.8]).unwrap();
        let before = h.clone();
        for bad in [f64::NAN, f64::INFINITY, 42.0, -7.0] {
            assert!(h.extend_1d(&[4.0, 5.5, bad, 2.0]).is_err());
            assert_eq!(h.counts(), before.counts(), "{bad}");
            assert_eq!(h.total_weight(), before.total_weight(), "{bad}");
        }
        let mut one = before.clone();
        one.extend_1d(&[4.0, 5.5]).unwrap();
        let mut each = before.clone();
        each.add(&[4.0], 1.0).unwrap();
        each.add(&[5.5], 1.0).unwrap();
        assert_eq!(one.counts(), each.counts());
        assert_eq!(one.total_weight(), each.total_weight());
    }

    #[test]
    fn sparse_matches_dense() {
        let b = ChannelBasis::covering(0.0, 20.0, 24, Kernel::Gaussian { sigma: 0.8 }).unwrap();
        let grid = ChannelGrid::new(vec![b.clone(), b]).unwrap();
        let mut dense = SoftHistogram::new(grid.clone()).unwrap();
        let mut sparse = SparseHistogram::new(grid);
        for (x, w) in [([2.0, 3.0], 1.0), ([15.5, 9.25], 0.7), ([2.2, 3.1], 0.4)] {
            dense.add(&x, w).unwrap();
            sparse.add(&x, w).unwrap();
        }
        assert_eq!(sparse.to_dense().unwrap().counts(), dense.counts());
        assert_eq!(sparse.decode().unwrap(), dense.decode().unwrap());
    }

    #[test]
    fn serde_round_trip_checks_counts() {
        let b = ChannelBasis::integer(5, Kernel::BSpline2).unwrap();
        let mut h = SoftHistogram::one_d(b);
        h.add(&[2.5], 1.0).unwrap();
        let json = serde_json::to_string(&h).unwrap();
        let back: SoftHistogram = serde_json::from_str(&json).unwrap();
        assert_eq!(back.counts(), h.counts());
        let broken = json.replace("\"counts\":[", "\"counts\":[1.0,");
        assert!(serde_json::from_str::<SoftHistogram>(&broken).is_err());
    }
}
