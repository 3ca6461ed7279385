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
