//! Best and second-best matches of every query descriptor among target descriptors.
//!
//! **Pruning for FD Corr.** For unit-norm FDs, `|r₁₂(l)| ≤ Σ_n |C₁(n)||C₂(n)|` (triangle
//! inequality), so `e_lb = 2 − 2 Σ |C₁||C₂| = Σ (|C₁| − |C₂|)²` — the abs(FD) SSD — is a lower
//! bound of the correlation error (eq. 10). [`best_two`] computes the bound for every target
//! (one dot product of magnitudes), visits targets by increasing bound and stops as soon as a
//! bound exceeds the current second-best error by more than a rounding margin (`1e-9`, far
//! above the ~1e-14 rounding of either side). A visited pair whose correlation grid maximum
//! plus its Bernstein slack already rules it out stops before the Newton refinement
//! ([`crate::Correlator::correlate_below`]). Pairs it skips are strictly worse than the
//! second best, and ties are broken by the lower target index in both searches, so the result
//! is identical to [`best_two_brute_force`] (tested). SSD methods are cheap and are searched
//! exhaustively.
//!
//! Queries are processed in parallel with rayon; each query's result depends only on the data,
//! so output (in query order) is identical for any number of threads.
//!
//! **Why it is fast** (each step kept with the pruned search still identical to brute force):
//! the bound for all pairs in `f32` ([`crate::bound`]); candidates ordered by bound 64 at a time
//! (select, then sort) instead of sorting all of them, since a visit usually stops after a few
//! dozen; a pair whose refined peak and every other lobe are below what the current threshold needs
//! is dropped without refining the other lobes; the Newton evaluation pairs `n` with `−n` and ends
//! with a second-order Taylor step instead of a fresh evaluation; the curvature sums of the slack
//! come from the stored magnitudes in four independent lanes; the grids' slack bounds only the
//! downward curvature at a peak (`S₀S₂`, not `S₁² + S₀S₂`, see [`crate::correlation`]), which
//! roughly halves it, so the 64- and 128-point grids decide most visited pairs before any
//! refinement. Speed figures: `docs/performance.md`.
//!
//! **Tried and dropped:** screening grids of 16 and 32 points over the low band `|n| ≤ 7`, `≤ 15`
//! with the rest bounded by its magnitudes. On the bench's synthetic curves they dropped 0 and 88
//! of the 78,774 pairs that reached them: the threshold lies a median 8e-4 above the magnitude
//! bound, far inside such a grid's slack, so they only added work (+58 % instructions).
//!
//! **Why about 8 % of the pairs are still evaluated** (synthetic curves of `bench fd`): even
//! with the final second-best error known in advance, 80,056 pairs have a magnitude bound below
//! it, against 80,774 visited, so no visiting or query order can save more than 0.9 %; a
//! tighter bound would have to resolve about 1e-3 in the error (the true errors of those pairs
//! lie about 4e-3 above the bound, the threshold a median 8e-4).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::correlation::Alignment;
use crate::descriptor::DescriptorSet;
use crate::error::FdError;
use crate::method::{Method, PairError};

use crate::bound::{BoundTable, bound_slack};

/// Checks a pair error as every method produces it: finite and `≥ 0` (squared distances and
/// `2 − 2·peak` clamped at 0). The one home of that rule for deserialised results.
pub(crate) fn check_pair_error(value: f64) -> Result<(), FdError> {
    if !(value.is_finite() && value >= 0.0) {
        return Err(FdError::InvalidParameter {
            name: "error",
            value,
            reason: "a pair error is finite and >= 0",
        });
    }
    Ok(())
}

/// A target and its error against a query.
///
/// Deserialisation checks that the error is finite and `≥ 0` (and the alignment's ranges,
/// [`Alignment`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CandidateSpec")]
pub struct Candidate {
    /// Index of the target in the target set.
    pub index: usize,
    /// Error of the method (0 = perfect).
    pub error: f64,
    /// Rotation and start-point shift from query to target ([`Method::FdCorr`] only).
    pub alignment: Option<Alignment>,
}

/// The serialised form of a [`Candidate`], checked on deserialisation.
#[derive(Deserialize)]
struct CandidateSpec {
    index: usize,
    error: f64,
    alignment: Option<Alignment>,
}

impl TryFrom<CandidateSpec> for Candidate {
    type Error = FdError;
    fn try_from(s: CandidateSpec) -> Result<Self, FdError> {
        check_pair_error(s.error)?;
        Ok(Candidate {
            index: s.index,
            error: s.error,
            alignment: s.alignment,
        })
    }
}

impl Candidate {
    /// Ordering used everywhere: smaller error first, then smaller index.
    #[inline]
    fn beats(&self, other: &Candidate) -> bool {
        self.error < other.error || (self.error == other.error && self.index < other.index)
    }
}

/// The best and second-best targets of one query (`e_min`, `e_sec` of eq. 19).
///
/// Deserialisation checks what the search guarantees ([`FdError::InvalidParameter`]
/// `second` otherwise): a second only with a best, two different targets, the best strictly
/// first in the search's order (smaller error, ties by smaller index), and both from one
/// method (both with an alignment or both without); each candidate is checked as a
/// [`Candidate`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BestTwoSpec")]
pub struct BestTwo {
    /// Smallest error (None if there are no targets).
    pub best: Option<Candidate>,
    /// Second smallest error (None if there are fewer than two targets).
    pub second: Option<Candidate>,
}

/// The serialised form of a [`BestTwo`], checked on deserialisation.
#[derive(Deserialize)]
struct BestTwoSpec {
    best: Option<Candidate>,
    second: Option<Candidate>,
}

impl TryFrom<BestTwoSpec> for BestTwo {
    type Error = FdError;
    fn try_from(s: BestTwoSpec) -> Result<Self, FdError> {
        if let Some(second) = s.second {
            let refuse = |reason| FdError::InvalidParameter {
                name: "second",
                value: second.error,
                reason,
            };
            let Some(best) = s.best else {
                return Err(refuse("a second-best candidate needs a best one"));
            };
            if best.index == second.index {
                return Err(refuse(
                    "the best and second-best candidates are the same target",
                ));
            }
            if !best.beats(&second) {
                return Err(refuse(
                    "the second-best candidate beats the best (smaller error, ties by smaller index)",
                ));
            }
            if best.alignment.is_some() != second.alignment.is_some() {
                return Err(refuse(
                    "only one of the best and second-best candidates has an alignment",
                ));
            }
        }
        Ok(BestTwo {
            best: s.best,
            second: s.second,
        })
    }
}

impl BestTwo {
    /// Error ratio `e_r = e_min / e_sec` (eq. 19). `0` when there is no second target
    /// (`e_sec = ∞`), `1` when both errors are 0 (fully ambiguous), None without targets.
    pub fn ratio(&self) -> Option<f64> {
        let b = self.best?;
        Some(match self.second {
            None => 0.0,
            Some(s) if s.error == 0.0 => 1.0,
            Some(s) => b.error / s.error,
        })
    }

    #[inline]
    fn offer(&mut self, c: Candidate) {
        match self.best {
            None => self.best = Some(c),
            Some(b) if c.beats(&b) => {
                self.second = self.best;
                self.best = Some(c);
            }
            _ => match self.second {
                Some(s) if !c.beats(&s) => {}
                _ => self.second = Some(c),
            },
        }
    }

    /// Error a candidate must beat to change this result (∞ while incomplete).
    #[inline]
    fn threshold(&self, only_best: bool) -> f64 {
        let c = if only_best { self.best } else { self.second };
        c.map_or(f64::INFINITY, |c| c.error)
    }
}

/// Work counters of a search.
///
/// Deserialisation checks `evaluated ≤ pairs` ([`FdError::InvalidParameter`] otherwise).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "SearchStatsSpec")]
pub struct SearchStats {
    /// Query–target pairs considered (`queries × targets`, minus self pairs).
    pub pairs: u64,
    /// Pairs whose error was actually evaluated (the rest were pruned by the bound).
    pub evaluated: u64,
}

/// The serialised form of [`SearchStats`], checked on deserialisation.
#[derive(Deserialize)]
struct SearchStatsSpec {
    pairs: u64,
    evaluated: u64,
}

impl TryFrom<SearchStatsSpec> for SearchStats {
    type Error = FdError;
    fn try_from(s: SearchStatsSpec) -> Result<Self, FdError> {
        if s.evaluated > s.pairs {
            return Err(FdError::InvalidParameter {
                name: "evaluated",
                value: s.evaluated as f64,
                reason: "more pairs evaluated than considered",
            });
        }
        Ok(SearchStats {
            pairs: s.pairs,
            evaluated: s.evaluated,
        })
    }
}

/// Two sets are compared only when made with the same configuration (as
/// [`DescriptorSet::append`] requires): descriptors of another sampling, smoothing or dense
/// resampling have the same length but are not comparable, and their errors would be silently
/// wrong.
fn check(a: &DescriptorSet, b: &DescriptorSet) -> Result<(), FdError> {
    let (ca, cb) = (a.config(), b.config());
    if ca.coefficients != cb.coefficients || ca.samples != cb.samples {
        return Err(FdError::IncompatibleSets {
            reason: "different numbers of coefficients or samples",
        });
    }
    if ca != cb {
        return Err(FdError::IncompatibleSets {
            reason: "different sampling, smoothing or dense resampling",
        });
    }
    Ok(())
}

/// Candidates ordered per step of the visit by increasing bound (see [`search_one`]).
const VISIT_BATCH: usize = 64;

/// Per-thread scratch of a search.
#[derive(Clone)]
struct Work {
    pair: PairError,
    cand: Vec<(f64, usize)>,
}

/// The `f32` magnitude tables of the query and target sets, and the slack of their bound.
struct Bounds {
    queries: BoundTable,
    targets: BoundTable,
    slack: f64,
}

/// What a search looks for.
#[derive(Clone, Copy)]
struct Mode {
    /// Query and target sets are the same; skip `j == i`.
    skip_self: bool,
    /// Only the best target matters (eq. 18), so prune against it rather than the second.
    only_best: bool,
}

/// One query against all targets, pruned by the magnitude bound when `bounds` are given (FD
/// Corr only), exhaustive otherwise.
fn search_one(
    w: &mut Work,
    q: &DescriptorSet,
    i: usize,
    t: &DescriptorSet,
    mode: Mode,
    bounds: Option<&Bounds>,
) -> (BestTwo, u64) {
    let Mode {
        skip_self,
        only_best,
    } = mode;
    let mut out = BestTwo::default();
    let mut evaluated = 0u64;
    let Some(bounds) = bounds else {
        for j in 0..t.len() {
            if skip_self && j == i {
                continue;
            }
            let (error, alignment) = w.pair.eval(q, i, t, j);
            evaluated += 1;
            out.offer(Candidate {
                index: j,
                error,
                alignment,
            });
        }
        return (out, evaluated);
    };
    w.cand.clear();
    let skip = skip_self.then_some(i);
    bounds
        .targets
        .bounds_into(bounds.queries.row(i), skip, &mut w.cand);
    let margin = bounds.slack;
    // Seed the result with the smallest bounds (one linear pass), then keep only the targets
    // whose bound can still beat the threshold and visit those by increasing bound.
    let seeds = if only_best { 1 } else { 2 };
    for _ in 0..seeds.min(w.cand.len()) {
        let mut m = 0;
        for (idx, c) in w.cand.iter().enumerate() {
            let best = w.cand[m];
            if c.0 < best.0 || (c.0 == best.0 && c.1 < best.1) {
                m = idx;
            }
        }
        let (_, j) = w.cand.swap_remove(m);
        evaluated += 1;
        let (error, alignment) = w.pair.eval(q, i, t, j);
        out.offer(Candidate {
            index: j,
            error,
            alignment,
        });
    }
    let threshold = out.threshold(only_best);
    w.cand.retain(|c| c.0 - margin <= threshold);
    // Visit by increasing bound. The visit usually stops after a few dozen targets, so the
    // candidates are ordered a batch at a time (the smallest `VISIT_BATCH` selected, then
    // sorted) instead of sorting them all; the visiting order is the same.
    let order = |x: &(f64, usize), y: &(f64, usize)| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1));
    let mut rest = &mut w.cand[..];
    'visit: while !rest.is_empty() {
        let take = VISIT_BATCH.min(rest.len());
        if take < rest.len() {
            rest.select_nth_unstable_by(take - 1, order);
        }
        let (batch, tail) = std::mem::take(&mut rest).split_at_mut(take);
        batch.sort_unstable_by(order);
        for &(lb, j) in batch.iter() {
            let threshold = out.threshold(only_best);
            if lb - margin > threshold {
                break 'visit;
            }
            evaluated += 1;
            // The correlator may stop after its FFT when its own bound already exceeds the
            // threshold; such a pair cannot enter the result.
            if let Some((error, alignment)) = w.pair.eval_below(q, i, t, j, threshold) {
                out.offer(Candidate {
                    index: j,
                    error,
                    alignment,
                });
            }
        }
        rest = tail;
    }
    (out, evaluated)
}

fn run(
    q: &DescriptorSet,
    t: &DescriptorSet,
    method: Method,
    skip_self: bool,
    only_best: bool,
    prune: bool,
) -> Result<(Vec<BestTwo>, SearchStats), FdError> {
    let mode = Mode {
        skip_self,
        only_best,
    };
    check(q, t)?;
    let proto = Work {
        pair: PairError::new(method, q),
        cand: Vec::with_capacity(t.len()),
    };
    let bounds = (method == Method::FdCorr && prune).then(|| Bounds {
        queries: BoundTable::new(q),
        targets: BoundTable::new(t),
        slack: bound_slack(q.config().coefficients),
    });
    let res: Vec<(BestTwo, u64)> = (0..q.len())
        .into_par_iter()
        .map_init(
            || proto.clone(),
            |w, i| search_one(w, q, i, t, mode, bounds.as_ref()),
        )
        .collect();
    let per_query = t.len() as u64 - u64::from(skip_self && !t.is_empty());
    let stats = SearchStats {
        pairs: per_query * q.len() as u64,
        evaluated: res.iter().map(|r| r.1).sum(),
    };
    Ok((res.into_iter().map(|r| r.0).collect(), stats))
}

/// For every query descriptor, its best and second-best target under `method` (fast search;
/// see the module doc). The ratio test of any threshold then needs no recomputation:
/// [`BestTwo::ratio`], [`crate::mutual_matches`].
pub fn best_two(
    queries: &DescriptorSet,
    targets: &DescriptorSet,
    method: Method,
) -> Result<Vec<BestTwo>, FdError> {
    run(queries, targets, method, false, false, true).map(|r| r.0)
}

/// [`best_two`] and its work counters.
pub fn best_two_with_stats(
    queries: &DescriptorSet,
    targets: &DescriptorSet,
    method: Method,
) -> Result<(Vec<BestTwo>, SearchStats), FdError> {
    run(queries, targets, method, false, false, true)
}

/// Reference: evaluates every pair (no pruning); same result as [`best_two`].
pub fn best_two_brute_force(
    queries: &DescriptorSet,
    targets: &DescriptorSet,
    method: Method,
) -> Result<Vec<BestTwo>, FdError> {
    run(queries, targets, method, false, false, false).map(|r| r.0)
}

/// `e_min` of eq. 18 for every descriptor: its smallest error against every *other* descriptor
/// of the same set (∞ for a set of one). Feed to [`crate::preselect`] for any `T_err`.
///
/// ```
/// use fd_match::{describe_all, min_errors_within, preselect, DescriptorConfig, Method, Sampling};
/// let square = vec![(0, 0), (10, 0), (10, 10), (0, 10)];
/// let big_square = vec![(0, 0), (20, 0), (20, 20), (0, 20)]; // same shape: ambiguous
/// let triangle = vec![(0, 0), (12, 0), (3, 8)];
/// let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
/// let set = describe_all(cfg, &[square, big_square, triangle]).unwrap().set;
/// let method = Method::FdCorr;
/// let t_err = method.paper_preselection_threshold(Sampling::Canonical).unwrap(); // 1e-3
/// let keep = preselect(&min_errors_within(&set, method).unwrap(), t_err).unwrap();
/// assert_eq!(keep, vec![2]); // both squares are removed as non-discriminative
/// let reduced = set.select(&keep).unwrap();
/// assert_eq!(reduced.source(0), 2);
/// ```
pub fn min_errors_within(set: &DescriptorSet, method: Method) -> Result<Vec<f64>, FdError> {
    let (r, _) = run(set, set, method, true, true, true)?;
    Ok(r.iter()
        .map(|b| b.best.map_or(f64::INFINITY, |c| c.error))
        .collect())
}
