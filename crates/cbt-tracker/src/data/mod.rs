//! Data and formats: the plain data types, the synthetic generators and the sequence files.
//!
//! - `sequence`: points, detections, training frames and sequences;
//! - [`sim`](crate::sim): synthetic RC-car and UNGM sequences, simulated detections;
//! - [`csv`](crate::csv): the plain `frame,kind,x,y` sequence format;
//! - [`mot`](crate::mot): MOTChallenge ground truth, one sequence per id.

pub mod csv;
pub mod mot;
mod sequence;
pub mod sim;

pub use sequence::{Detection, Frame, Point, Sequence, TrainingFrame};
pub(crate) use sequence::{check_finite, check_point, check_sequences};
