//! Scenes and models that several test modules share.

pub mod rectified;
pub mod tip_model;
pub mod two_bar_scene;
pub mod two_link;
