//! The thesis's future work (§6.2): Fourier-descriptor recognition (Paper A) and channel based
//! tracking (Paper B) as the percept of the learned visual servo (Paper C).
//!
//! 1. **Learned by action** ([`learn_by_action`]): the arm moves its gripper at random poses;
//!    the MSER regions that change with the gripper, near the tip the heuristic percept gives
//!    on the same capture, are stored as Fourier descriptors with their offset to the tip, per
//!    camera ([`ShapeModel`]).
//! 2. **Recognise** ([`ShapeModel::votes`]): MSER → contours → FDs → correlation matching
//!    against the gripper views with a ratio test against the background's regions, both
//!    limited to regions of about the same size and of the same MSER polarity; each accepted
//!    region votes for the tip once
//!    per stored view near its best match, with that view's recovered rotation and scale
//!    ([`Vote`]; a generalised Hough transform). The frame's mode is the FD-only percept
//!    ([`FdRecogniser`]).
//! 3. **Track** ([`FdCbtRecogniser`]): CBT learns its observation and system models from the
//!    votes and percepts of small random walks (unordered sets, in coordinates compensated by
//!    the commanded moves' predicted shifts) and tracks each camera's tip through the frames;
//!    its estimate and certainty are the percept, through servo-loop's
//!    [`servo_loop::Recogniser`] seam (the servo loop is unchanged).
//!
//! The commanded move is a known input ([`motion`]): a forward model learned by action (LWPR
//! from the controlled servos to the tip in each image) predicts each move's image shift, the
//! tracks are shifted by it ([`Notifying`] tells them the commands) and the tracker's learned
//! motion is the prediction's residual; without a prediction, a move larger than the training
//! walks' restarts the tracks from the votes. Its absolute prediction at the last command is also
//! a prior on where the tip can be ([`prior`]): on a camera where the forward model is sharp
//! enough, each vote's weight falls with its distance to the prediction, so that the clusters a
//! gripper part voting with another part's offset makes, a part's length from the tip, lose to
//! the cluster at the tip (in tracking and in the training walks alike). There MSER and the FD
//! stage also run only in the window around the prediction outside which every vote would weigh
//! the prior's floor ([`window`]; on by default, [`PerceptConfig::search_window`]): less work,
//! and the answers change only in frames that votes of that floor weight decided.
//!
//! ## Cost
//!
//! The goal is 25 ms per capture of both cameras on one core; the measured times per scene are
//! in docs/performance.md, *visguide pipeline*. What decides them:
//! - **MSER's flood.** A `perf` profile with call graphs (development seed 133, default and hard
//!   scenes) puts `mser`'s component-tree flood at 80 % of [`ShapeModel::votes`], the
//!   descriptors at 9 %, the FD matching at 8 % and the contours under 1 %. So the flood is the
//!   lever here, as it is for `mser`'s speed against OpenCV.
//! - **The window** ([`window`]). [`FdRecogniser`] searches the whole image. [`FdCbtRecogniser`]
//!   searches only the square of half-width `m R_c + D_c` around the predicted tip, where the
//!   prior applies (`fixtures/pipeline/summary.md` lists the half-width per camera).
//!   - On the default scene the square is about 210–230 px, and it cut the cost by a third:
//!     20.9 → 13.6 ms side by side on development seeds 125–128.
//!   - On the hard scene's camera 1 (334 px; camera 0 has no prior) and on both cameras of the
//!     held-out second rig (403 / 356 px) it is about the whole image. There one stored view
//!     about 250–275 px long sets the reach `R_c`. So the cost there is the whole image's.
//!   - Where the window cuts little, FD + CBT costs about 1–1.5 ms more than FD only: the
//!     tracking.
//! - **The second rig's FD stage.** Its textured table and extra clutter give the FD stage more
//!   contours to describe and match. Its shape model also holds more stored views: 356 / 267
//!   against 204 / 224 per camera on the default arm.
//!   - A `perf` profile of one whole study run per arm (before size-aware matching, one thread):
//!     `fd-match` (contour sampling, descriptor FFTs, matching) took 9.8 s against 2.1 s on the
//!     default arm. The sampling and the FFTs took about five times as much. MSER took 19.2 s
//!     against 17.7 s.
//!   - Within [`ShapeModel::votes`] on the second rig, with size-aware matching (development
//!     seed 123): MSER with the contours is about three quarters of the samples, the FD
//!     correlations about a seventh.
//!   - Tried and not kept: a size pre-filter before the contours removed nothing (the views'
//!     areas span 40–5,544 px); a magnitude bound before each view's correlation (no FFT)
//!     pruned next to nothing.
//! - **Training poses.** The 80 training poses store about twice the views of 40, and make the
//!   FD matching 3–6 ms dearer per capture.

pub mod error;
pub mod learn;
pub mod motion;
pub mod prior;
pub mod shapes;
pub mod track;
pub mod vote;
pub mod window;

pub use error::PipelineError;
pub use learn::{ActionProtocol, LearnReport, MIN_PRIOR_FRAMES, learn_by_action};
pub use motion::{MotionConfig, MotionModel};
pub use prior::PositionPrior;
pub use shapes::{ActionPair, GripperView, ShapeConfig, ShapeModel, ShapeReport};
pub use track::{
    FdCbtRecogniser, FdRecogniser, MoveNotifier, Notifying, NotifyingError, PerceptConfig, Walk,
    detections, learn_tracker,
};
pub use vote::{Mode, Vote, mode};
pub use window::{SearchWindow, search_window};
