//! The gripper tip from the arm's silhouette against a learned static scene.
//!
//! **Learning (action precedes perception).** The robot makes random moves and, at each pose,
//! closes and opens its gripper ([`TrainingView`](super::TrainingView)). From these frames every camera learns:
//! 1. *the static scene* `B`: the per-pixel median of the frames after normalising each
//!    frame's lighting (below); the arm is elsewhere in most frames, so the median is the
//!    table, the clutter and the arm's fixed base;
//! 2. *which end is the gripper*: the image change of closing the gripper is the fingers
//!    ([`changed_region`](crate::recognition::change::changed_region)); the *root* is the point (searched on a 24-pixel grid, refined on a
//!    6-pixel grid) from which the silhouette's farthest pixel lies nearest to that change in
//!    the training views (sum of distances capped at 60 px), so "farthest from the root" means
//!    "the gripper end" in new images;
//! 3. *the gripper end's size*: twice the median distance of that change from the
//!    silhouette's far end is the length `L` of the end window.
//!
//! **Lighting.** A frame is modelled as `I(u, v) = B(u, v) · (a + b u' + c v') + noise`
//! (`u', v'` in `[-1, 1]` across the image): a global gain and brightness gradients
//! (`arm-sim`'s lighting change has exactly this form; a real camera's is close to it). The three
//! coefficients come from a robust least-squares fit on an 8-pixel grid (three rounds, dropping
//! residuals beyond `3·1.4826·MAD`).
//!
//! **Localisation in one image.** The residual `r = I − (a + b u' + c v') B` is the arm (static
//! clutter and lighting cancel). At half resolution, its 3×3-smoothed magnitude above
//! `max(k σ/2, d_min)` (`σ` the learned per-pixel noise) is the silhouette; the largest 8-connected component is the arm.
//! Its pixel farthest from the root is the end of the chain (the gripper). There, the soft
//! coverage `c = clamp((|r| − 3σ)/(C − 3σ), 0, 1)` (`C` the median contrast of the end) is
//! analysed in the gripper's frame: the direction `d` is the principal axis of the covered
//! pixels within `L` of the end (pointing away from the root), `n ⊥ d`. With `s`, `t` the
//! coordinates along `d` and `n`:
//! - the **end** along `d`, at sub-pixel precision from areas: `s_end = s_a + A(s > s_a) /
//!   w(s_a)`, the covered area beyond a cut `s_a` divided by the mean covered width just
//!   before it (exact for a straight end, the mean end position for an oblique one);
//! - the **centre** across `d`: the coverage-weighted mean `t` of the end window;
//! - the **tip** is `end·d + centre·n`: the middle of the gripper's far end, i.e. between the
//!   finger ends. Two passes, the second centred on the first estimate, make the result
//!   independent of the integer position of the farthest pixel.
//!
//! This is [`TipRule::FarEnd`](crate::TipRule::FarEnd). It measures the far *outline*, which lies ahead of the end
//! face's centre by up to the face's projected depth, and its coverage-weighted centre leans
//! to the side of an oblique cap. [`TipRule::EndFace`](crate::TipRule::EndFace) instead takes the middle of the end face
//! from the far cap's two outer corners on the outline (the 0.5 level of the same coverage;
//! `end_face` module), within `0.6 L` behind the far end, and falls back to the far end when
//! the outline shows no two sides. [`TipRule::Learned`](crate::TipRule::Learned) (the default and the servo percept)
//! corrects the far end by an offset learned from the end-face tips of further training poses
//! and moves it towards the end-face tip by at most half a pixel (opt-in: by more where the
//! learned offset is unsure, its local spread; `tip_correction` module, *the correction's own
//! certainty*);
//! it locates all cameras together ([`TipModel::locate_all`](crate::TipModel::locate_all)).
//!
//! The certainty compares the end window's covered area with the median learned one.
//!
//! **What "tip" means here.** The system can only define the tip by what it sees: the middle
//! of the gripper's far end. A simulator may define its tool point elsewhere (`arm-sim`'s lies
//! `finger_pad_mm` = 8 mm behind the finger ends); the evaluation reports the error against
//! both.

//!
//! This module holds the silhouette itself and the end analysis; the scene is `scene`, the
//! rules `tip_rule`, the model type [`TipModel`](crate::TipModel) `tip_model`.

use crate::recognition::end_face::{
    CoverageGrid, cap_corners, convex_hull, iso_crossings, side_direction,
};
use crate::recognition::scene::CameraScene;

/// The arm's silhouette in one image.
pub(super) struct Silhouette {
    /// The full-resolution frame.
    pub(super) image: Vec<f32>,
    /// Its lighting `[a, b, c]`.
    pub(super) coef: [f64; 3],
    /// Pixels of the largest component (found at half resolution), full-resolution
    /// coordinates of their centres.
    pub(super) component: Vec<[f64; 2]>,
    pub(super) threshold: f32,
}

impl Silhouette {
    /// Residual of full-resolution pixel `(x, y)` against the lit scene.
    #[inline]
    pub(super) fn residual(&self, scene: &CameraScene, x: usize, y: usize) -> f32 {
        let (hw, hh) = (0.5 * scene.width as f64, 0.5 * scene.height as f64);
        let g = self.coef[0]
            + self.coef[1] * (x as f64 + 0.5 - hw) / hw
            + self.coef[2] * (y as f64 + 0.5 - hh) / hh;
        let i = y * scene.width + x;
        self.image[i] - g as f32 * scene.background[i]
    }
}

/// The end analysis of one silhouette: tip, direction, covered area of the end window.
#[derive(Debug, Clone, Copy)]
pub(super) struct EndFit {
    /// The far end (the `FarEnd` tip).
    pub(super) tip: [f64; 2],
    /// The end-face centre, when asked for and the outline shows two sides.
    pub(super) face: Option<[f64; 2]>,
    pub(super) area: f64,
}

/// Length of the end window for the cap corners, as a share of the learned end length `L`.
pub(super) const FACE_WINDOW: f64 = 0.6;
/// Largest angle between the principal axis and the side edges it is refined from (degrees).
const AXIS_ANGLE: f64 = 30.0;
/// Largest angle between a side edge of the outline and the axis (degrees).
const SIDE_ANGLE: f64 = 12.0;
/// Shortest side run, as a share of the window length.
const MIN_SIDE_SHARE: f64 = 0.2;

/// The middle of the end face from the outline of the far end (`end_face` module): the 0.5
/// level crossings of the coverage `grid` within `FACE_WINDOW · l` behind `end` (along `d`)
/// and `l` across, their convex hull, its sides (refined from the principal axis `d`) and the
/// mean of the far cap's outer corners.
pub(super) fn end_face_centre(
    grid: &CoverageGrid,
    end: [f64; 2],
    d: [f64; 2],
    l: f64,
) -> Option<[f64; 2]> {
    let back = FACE_WINDOW * l;
    let crossings: Vec<[f64; 2]> = iso_crossings(grid, 0.5)
        .into_iter()
        .filter(|p| {
            let (dx, dy) = (p[0] - end[0], p[1] - end[1]);
            let sa = dx * d[0] + dy * d[1];
            let ta = -dx * d[1] + dy * d[0];
            sa >= -back && sa <= 6.0 && ta.abs() <= l
        })
        .collect();
    let hull = convex_hull(&crossings);
    let mut side = d;
    for _ in 0..2 {
        side = side_direction(&hull, side, AXIS_ANGLE.to_radians());
    }
    let [a, b] = cap_corners(
        &hull,
        &crossings,
        side,
        SIDE_ANGLE.to_radians(),
        MIN_SIDE_SHARE * back,
    )?;
    Some([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])])
}

/// The root (24-pixel grid, refined on a 6-pixel grid) that makes the farthest silhouette pixel closest to the
/// gripper change in most views: minimises the sum over views of `min(distance, cap)`
/// between the farthest pixel and the change centroid (`cap` = 60 px; ties: first in
/// row-major order).
pub(super) fn learn_root(
    silhouettes: &[Silhouette],
    changes: &[Option<[f64; 2]>],
    w: usize,
    h: usize,
) -> Option<[f64; 2]> {
    // The open-gripper frame of each view, subsampled (every 2nd half-resolution pixel).
    let samples: Vec<(Vec<[f32; 2]>, [f64; 2])> = changes
        .iter()
        .enumerate()
        .filter_map(|(k, g)| {
            let g = (*g)?;
            let s = silhouettes.get(2 * k)?;
            let pts: Vec<[f32; 2]> = s
                .component
                .iter()
                .step_by(2)
                .map(|p| [p[0] as f32, p[1] as f32])
                .collect();
            (!pts.is_empty()).then_some((pts, g))
        })
        .collect();
    if samples.is_empty() {
        return None;
    }
    let cap = 60.0f64;
    let cost_at = |rx: f32, ry: f32| -> f64 {
        let mut cost = 0.0;
        for (pts, g) in &samples {
            let far = pts
                .iter()
                .max_by(|a, b| {
                    let da = (a[0] - rx).powi(2) + (a[1] - ry).powi(2);
                    let db = (b[0] - rx).powi(2) + (b[1] - ry).powi(2);
                    da.total_cmp(&db)
                })
                .expect("`samples` keeps only views with a non-empty `pts`");
            let d = (f64::from(far[0]) - g[0]).hypot(f64::from(far[1]) - g[1]);
            cost += d.min(cap);
        }
        cost
    };
    let mut best: Option<(f64, [f64; 2])> = None;
    let consider = |x: i64, y: i64, best: &mut Option<(f64, [f64; 2])>| {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            return;
        }
        let c = cost_at(x as f32, y as f32);
        if best.is_none_or(|b| c < b.0) {
            *best = Some((c, [x as f64, y as f64]));
        }
    };
    // Coarse 24-pixel grid, then a 6-pixel grid around the best coarse point.
    for gy in (0..h as i64).step_by(24) {
        for gx in (0..w as i64).step_by(24) {
            consider(gx, gy, &mut best);
        }
    }
    let [bx, by] = best?.1;
    for dy in -4..=4 {
        for dx in -4..=4 {
            consider(bx as i64 + 6 * dx, by as i64 + 6 * dy, &mut best);
        }
    }
    best.map(|b| b.1)
}

/// The distribution function of a unit pixel's area projected on the unit direction `d`
/// (offset from the pixel centre): the sum of uniform variables of widths `|d_x|`, `|d_y|`.
pub(super) fn pixel_cdf(d: [f64; 2]) -> impl Fn(f64) -> f64 {
    let (a, b) = {
        let (p, q) = (d[0].abs(), d[1].abs());
        if p >= q { (p, q) } else { (q, p) }
    };
    move |x: f64| {
        let (lo, hi) = (-(a + b) / 2.0, (a + b) / 2.0);
        if x <= lo {
            0.0
        } else if x >= hi {
            1.0
        } else if b < 1e-9 {
            (x + a / 2.0) / a
        } else if x < -(a - b) / 2.0 {
            (x - lo).powi(2) / (2.0 * a * b)
        } else if x <= (a - b) / 2.0 {
            (x + a / 2.0) / a
        } else {
            1.0 - (hi - x).powi(2) / (2.0 * a * b)
        }
    }
}

/// The component pixel farthest from `root`.
pub(super) fn farthest(component: &[[f64; 2]], root: [f64; 2]) -> Option<[f64; 2]> {
    component.iter().copied().max_by(|a, b| {
        let da = (a[0] - root[0]).powi(2) + (a[1] - root[1]).powi(2);
        let db = (b[0] - root[0]).powi(2) + (b[1] - root[1]).powi(2);
        da.total_cmp(&db)
    })
}
