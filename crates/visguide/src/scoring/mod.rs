//! Scoring matches against a known homography, as Paper A §5 and the Oxford benchmark do: the
//! ellipse overlap error ([`overlap`]), the ground truth of an image pair ([`ground_truth`]),
//! precision and recall of a set of matches ([`score`]) and curves over the ratio threshold
//! ([`pr`]).

pub mod ground_truth;
pub mod overlap;
pub mod pr;
pub mod score;

pub use ground_truth::{PairTruth, pair_truth};
pub use overlap::{DESCRIPTOR_THRESHOLD, Normalisation, Offset, map_linearised, overlap_error};
pub use pr::{PAPER_T_R, PrCurve, PrPoint, Scored, sweep};
pub use score::{MatchScore, PairScore, score_matches};
