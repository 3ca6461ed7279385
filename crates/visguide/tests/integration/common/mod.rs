//! Scenes and models that several test modules share.

pub mod arm;
pub mod cases;
