//! Sparse channel encodings of the sets of states and detections of one frame.

use crate::data::Point;
use crate::{Detection, Space, TrackError};

/// Sparse channel vectors of one frame's set: per axis the sum `Σ_j w_j·b_d(x_j)` and, when
/// asked for, the joint sum `Σ_j w_j·b(x_j)` over the state (or measurement) grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Encoded {
    /// Per-axis `(channel, value)` lists (entries may repeat a channel; sums are linear).
    pub axes: [Vec<(usize, f64)>; 2],
    /// Joint `(cell, value)` list (empty unless requested).
    pub joint: Vec<(usize, f64)>,
    /// Number of elements (states) or total weight (detections).
    pub count: f64,
    /// End offsets into `axes[0]` and `axes[1]` after each encoded element (its channels
    /// are the run since the previous element's end).
    pub ends: Vec<[usize; 2]>,
}

impl Encoded {
    /// Whether the set was empty (or had zero weight).
    pub fn is_empty(&self) -> bool {
        self.count <= 0.0
    }
}

/// Which basis to encode in.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Basis {
    State,
    Measurement,
}

/// Encodes a set of points, each with a weight; validates every point first.
pub(crate) fn encode_set(
    space: &Space,
    points: impl Iterator<Item = (Point, f64)> + Clone,
    basis: Basis,
    joint: bool,
) -> Result<Encoded, TrackError> {
    let dims = space.dims();
    let mut idx = Vec::new();
    for (p, w) in points.clone() {
        let t = match basis {
            Basis::State => space.state_index(&p)?,
            Basis::Measurement => space.detection_index(&Detection { pos: p, weight: w })?,
        };
        idx.push((t, w));
    }
    let mut e = Encoded::default();
    let mut per_axis: [Vec<(usize, f64)>; 2] = [Vec::new(), Vec::new()];
    for (t, w) in idx {
        e.count += w;
        if w == 0.0 {
            continue;
        }
        for d in 0..dims {
            let b = match basis {
                Basis::State => space.state_basis(d),
                Basis::Measurement => space.meas_basis(d),
            };
            per_axis[d].clear();
            b.for_each_active(t[d], |k, v| per_axis[d].push((k, v)));
            e.axes[d].extend(per_axis[d].iter().map(|&(k, v)| (k, w * v)));
        }
        e.ends.push([e.axes[0].len(), e.axes[1].len()]);
        if joint {
            if dims == 1 {
                e.joint.extend(per_axis[0].iter().map(|&(k, v)| (k, w * v)));
            } else {
                let ny = match basis {
                    Basis::State => space.axis_len(1),
                    Basis::Measurement => space.meas_len(1),
                };
                for &(i, vi) in &per_axis[0] {
                    for &(j, vj) in &per_axis[1] {
                        e.joint.push((i * ny + j, w * vi * vj));
                    }
                }
            }
        }
    }
    Ok(e)
}

/// Encodes states (weight 1 each, times `weight`).
pub(crate) fn encode_states(
    space: &Space,
    states: &[Point],
    weight: f64,
    joint: bool,
) -> Result<Encoded, TrackError> {
    encode_set(
        space,
        states.iter().map(|p| (*p, weight)),
        Basis::State,
        joint,
    )
}

/// Encodes detections (each with its weight, times `weight`).
pub(crate) fn encode_detections(
    space: &Space,
    dets: &[Detection],
    weight: f64,
    joint: bool,
) -> Result<Encoded, TrackError> {
    for d in dets {
        d.validate(space.dims())?;
    }
    encode_set(
        space,
        dets.iter().map(|d| (d.pos, d.weight * weight)),
        Basis::Measurement,
        joint,
    )
}
