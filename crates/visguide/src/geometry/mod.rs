//! The geometry a user needs after matching: the homography type (read from the benchmark's
//! `H1toNp` files or estimated), a least-squares fit ([`fit`]), a robust fit from all matches
//! ([`ransac`]) and a local affine / similarity estimate per match ([`local`]).

pub mod fit;
pub mod homography;
pub mod local;
pub mod ransac;

pub use homography::Homography;
pub use local::{LocalAffine, local_affine};
pub use ransac::{HomographyFit, RansacConfig, fit_homography};
