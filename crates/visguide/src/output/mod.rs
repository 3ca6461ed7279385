//! Writing results: atomically ([`atomic`]), as region files ([`regions`]), and as pictures
//! ([`draw`]).

pub mod atomic;
pub mod draw;
pub mod regions;
