//! The search window: where the FD + CBT percept looks for the gripper's regions when the
//! forward model predicts the tip ([`super::prior`]).
//!
//! The prior multiplies a vote's weight by `max(ε, exp(−d² / 2(kσ_c)²))`, `d` its distance to
//! the predicted tip `g(y)`; beyond `D_c = kσ_c √(2 ln(1/ε))` (7.4 σ_c) every vote has the floor
//! weight `ε`. A region that votes for a tip at `x` lies, when it is one of the stored views
//! seen again, within `s · R_c` of `x`: `R_c` the camera's reach
//! ([`super::ShapeModel::reach`], the farthest contour pixel of any stored view from its training
//! tip) and `s ≤ m` the region's scale against that view (size-aware matching,
//! [`super::ShapeConfig::max_scale`]). So every such region whose votes can weigh more than the
//! floor lies within `m R_c + D_c` of `g(y)`: the window is that square, clipped to the image, and
//! MSER runs on it alone. (A region that matches a view only loosely can reach a little
//! farther; the arm test finds no vote above the floor lost.)
//!
//! A region found in the window is kept only when its bounding box touches none of the
//! window's edges that lie inside the image: a component that reaches such an edge may go on
//! outside it, and its contour there would be the window's, not its own. A kept region's pixels
//! are the same as in the whole image (every neighbour of a pixel off the window's edges lies
//! in the window); its stability can still differ when a larger component of the same branch
//! reaches past the window, which is where a region found in the window and in the whole image
//! can disagree. The training walks keep their votes by the same rule, applied to the regions
//! of the whole image ([`SearchWindow::keeps`]), so the tracker learns from the votes it will
//! see.
//!
//! What it changes: the votes of the regions outside the window, which the prior weighed down to
//! its floor, are gone, so a frame whose every vote lies far from the prediction has no vote at
//! all (it used to be decided by those floor-weighted votes alone). What it saves: MSER, contours
//! and descriptors of the rest of the image, the percept's largest costs ([`super`],
//! *Cost*). Adopted as the default by a rule on development seeds 125–128
//! (docs/methods.md, *A window the training walks share*): on the default scene a third of the
//! cost, the same servo. Where one long stored view makes `R_c` large the window is the whole
//! image (the hard scene's camera 1, the held-out second rig).

use mser::BoundingBox;

use super::prior::PositionPrior;
use super::shapes::ShapeModel;

/// The half-width `m R_c + D_c` (px) of camera `cam`'s window (module docs); `None` (search
/// the whole image) where the prior does not apply to the camera, the shape model matches by
/// shape only (`m` infinite) or the camera is unknown.
pub fn half_width(shapes: &ShapeModel, prior: &PositionPrior, cam: usize) -> Option<f64> {
    Some(shapes.config().max_scale * shapes.reach(cam)? + prior.support_px(cam)?)
        .filter(|h| h.is_finite())
}

/// The window of camera `cam` when the forward model predicts its tip at `predicted`: the
/// square of [`half_width`] around it, on an image of `size`. `None` (search the whole image)
/// where there is no half-width or the prediction is not finite.
pub fn search_window(
    shapes: &ShapeModel,
    prior: &PositionPrior,
    cam: usize,
    predicted: [f64; 2],
    size: [u32; 2],
) -> Option<SearchWindow> {
    SearchWindow::around(predicted, half_width(shapes, prior, cam)?, size)
}

/// A window of an image of `size` pixels: columns `x0..x1`, rows `y0..y1` (half-open).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SearchWindow {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
    /// The image's width and height.
    pub size: [u32; 2],
}

impl SearchWindow {
    /// The square of half-width `half` (px) around `centre`, clipped to an image of `size`
    /// pixels; `None` when `centre` or `half` is not finite, `half` is negative, or nothing of
    /// the square lies in the image.
    pub fn around(centre: [f64; 2], half: f64, size: [u32; 2]) -> Option<Self> {
        if !(centre.iter().all(|c| c.is_finite()) && half.is_finite() && half >= 0.0) {
            return None;
        }
        let clip = |v: f64, n: u32| v.clamp(0.0, f64::from(n)) as u32;
        let (x0, x1) = (
            clip((centre[0] - half).floor(), size[0]),
            clip((centre[0] + half).ceil() + 1.0, size[0]),
        );
        let (y0, y1) = (
            clip((centre[1] - half).floor(), size[1]),
            clip((centre[1] + half).ceil() + 1.0, size[1]),
        );
        (x0 < x1 && y0 < y1).then_some(SearchWindow {
            x0,
            y0,
            x1,
            y1,
            size,
        })
    }

    /// Width and height of the window (0 along an inverted axis: the fields are public).
    pub fn extent(&self) -> [u32; 2] {
        [
            self.x1.saturating_sub(self.x0),
            self.y1.saturating_sub(self.y0),
        ]
    }

    /// Whether the window is the whole image.
    pub fn is_whole(&self) -> bool {
        self.x0 == 0 && self.y0 == 0 && self.x1 == self.size[0] && self.y1 == self.size[1]
    }

    /// Whether a region with bounding box `b` (image coordinates) is kept (module docs): it
    /// lies in the window and touches none of the window's edges inside the image. (A box
    /// reaching the last representable column or row is not kept: `x_max + 1` used to
    /// overflow there, a panic in a debug build and a kept box in a release one.)
    pub fn keeps(&self, b: &BoundingBox) -> bool {
        let left = b.x_min > self.x0 || (self.x0 == 0 && b.x_min == 0);
        let top = b.y_min > self.y0 || (self.y0 == 0 && b.y_min == 0);
        let right =
            b.x_max.saturating_add(1) < self.x1 || (self.x1 == self.size[0] && b.x_max < self.x1);
        let bottom =
            b.y_max.saturating_add(1) < self.y1 || (self.y1 == self.size[1] && b.y_max < self.y1);
        left && top && right && bottom
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bbox(x_min: u32, y_min: u32, x_max: u32, y_max: u32) -> BoundingBox {
        BoundingBox {
            x_min,
            y_min,
            x_max,
            y_max,
        }
    }

    #[test]
    fn the_square_is_clipped_to_the_image() {
        let w = SearchWindow::around([10.0, 100.0], 20.0, [640, 480]).unwrap();
        assert_eq!((w.x0, w.y0, w.x1, w.y1), (0, 80, 31, 121));
        assert_eq!(w.extent(), [31, 41]);
        assert!(!w.is_whole());
        let all = SearchWindow::around([320.0, 240.0], 1000.0, [640, 480]).unwrap();
        assert!(all.is_whole());
        assert_eq!(SearchWindow::around([-50.0, 10.0], 20.0, [640, 480]), None);
        assert_eq!(
            SearchWindow::around([f64::NAN, 10.0], 20.0, [640, 480]),
            None
        );
        assert_eq!(SearchWindow::around([10.0, 10.0], -1.0, [640, 480]), None);
        assert_eq!(
            SearchWindow::around([10.0, 10.0], f64::INFINITY, [640, 480]),
            None
        );
        // An inverted window (built by hand) is empty, not a panic.
        let inverted = SearchWindow {
            x0: 30,
            y0: 20,
            x1: 10,
            y1: 40,
            size: [640, 480],
        };
        assert_eq!(inverted.extent(), [0, 20]);
    }

    #[test]
    fn regions_touching_an_inner_edge_are_dropped_and_image_edges_are_fine() {
        let w = SearchWindow::around([10.0, 100.0], 20.0, [640, 480]).unwrap();
        // Columns 0..31, rows 80..121: the left edge is the image's, the others are inner.
        assert!(w.keeps(&bbox(0, 81, 29, 119)));
        assert!(!w.keeps(&bbox(0, 80, 29, 119)), "touches the top edge");
        assert!(!w.keeps(&bbox(0, 81, 30, 119)), "touches the right edge");
        assert!(!w.keeps(&bbox(0, 81, 29, 120)), "touches the bottom edge");
        assert!(!w.keeps(&bbox(5, 60, 29, 119)), "reaches outside");
        let corner = SearchWindow::around([630.0, 470.0], 20.0, [640, 480]).unwrap();
        assert_eq!((corner.x1, corner.y1), (640, 480));
        assert!(corner.keeps(&bbox(611, 451, 639, 479)));
        assert!(!corner.keeps(&bbox(610, 451, 639, 479)));
    }

    /// A bounding box (its fields are public) reaching `u32::MAX` is not kept, not a panic:
    /// `x_max + 1` overflowed (in a release build it wrapped to 0 and the box was kept).
    #[test]
    fn a_box_reaching_the_largest_coordinate_is_not_kept_and_no_panic() {
        let w = SearchWindow::around([10.0, 100.0], 20.0, [640, 480]).unwrap();
        assert!(!w.keeps(&bbox(5, 90, u32::MAX, 100)));
        assert!(!w.keeps(&bbox(5, 90, 20, u32::MAX)));
        let max = u32::MAX;
        let whole = SearchWindow {
            x0: 0,
            y0: 0,
            x1: max,
            y1: max,
            size: [max, max],
        };
        assert!(whole.keeps(&bbox(0, 0, max - 1, max - 1)));
        assert!(!whole.keeps(&bbox(0, 0, max, 3)));
        assert!(!whole.keeps(&bbox(0, 0, 3, max)));
    }
}
