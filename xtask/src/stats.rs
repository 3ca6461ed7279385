//! Order statistics of samples: the medians and quantiles that the benches and the evaluation
//! targets report. Their one home is `servo_loop::stats` (the lowest crate whose library code
//! needs them); each is named for what it computes, because the fixtures depend on which one a
//! table uses.

pub use servo_loop::stats::{median, quantile_linear, quantile_rank};
