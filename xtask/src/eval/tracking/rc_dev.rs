//! Development runs on the synthetic RC-car levels (`cargo xtask eval tracking
//! --rc-car-development`): the training sequences of the study, test sequences of other seeds
//! than the study's (`DEV_SEED + level`), CBT's second order only, mean RMSE and lost frames
//! per level printed. For checking a change of CBT against the synthetic sets without scoring
//! their evaluation seeds; writes nothing.

use cbt_tracker::sim::{Level, Scenario, generate};

use super::study::{Trackers, run_one};
use super::{IMAGE_LOSS_RADIUS, TEST_PER_LEVEL, synthetic_sets};
use crate::Result;

/// Test seeds of the development runs: `DEV_SEED + level` (the study's are `2000 + level`).
pub const DEV_SEED: u64 = 7000;

/// Runs CBT (second order, the study's configuration) on development test sequences of the
/// five RC-car levels and prints its mean RMSE and lost-frame share per level.
pub fn run() -> Result<()> {
    let sc = Scenario::default();
    let levels = [0, 1, 2, 3, 4];
    let specs = synthetic_sets(TEST_PER_LEVEL, 150, &levels)?;
    for (spec, &i) in specs.iter().zip(&levels) {
        let (trackers, ..) = Trackers::for_set(spec)?;
        let test = generate(
            &sc,
            &Level::preset(i),
            2 * TEST_PER_LEVEL,
            150,
            DEV_SEED + i as u64,
        )?;
        let (mut rmse, mut loss) = (0.0, 0.0);
        for s in &test {
            let mut t = trackers.makers[0](0)?;
            let r = run_one(t.as_mut(), s, 2, IMAGE_LOSS_RADIUS)?;
            rmse += r.score.rmse;
            loss += r.score.loss_share;
        }
        let n = test.len() as f64;
        println!(
            "{}: CBT 2nd order mean RMSE {:.4} px, lost {:.2} % ({} development sequences)",
            spec.name,
            rmse / n,
            100.0 * loss / n,
            test.len()
        );
    }
    Ok(())
}
