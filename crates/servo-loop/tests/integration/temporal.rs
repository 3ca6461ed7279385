//! The temporal check of percepts (`TemporalCheck`, `TemporalPlant`) on an analytic plant: a
//! planar two-link arm seen by an ideal camera, with a percept error injected on demand.

use servo_loop::{
    InverseModel, InverseModelConfig, LearnConfig, Observation, Plant, RandomCommands, ServoConfig,
    ServoError, TemporalCheck, TemporalConfig, TemporalPlant, Verdict, learn_control, servo_lwpr,
};

use crate::common::two_link;
use two_link::{RANGE, g};

/// The arm; `offset` is added to the next percept only (a recogniser's one-off mistake).
struct Arm {
    y: Vec<f64>,
    offset: Option<[f64; 2]>,
    samples: Samples,
}

impl Plant for Arm {
    fn percept_dim(&self) -> usize {
        2
    }
    fn command_dim(&self) -> usize {
        2
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        RANGE[j]
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.y = y.to_vec();
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        let mut x = g(&self.y);
        if let Some(o) = self.offset.take() {
            x[0] += o[0];
            x[1] += o[1];
        }
        self.samples.push((x.to_vec(), self.y.clone()));
        Ok(Observation {
            x: x.to_vec(),
            certainty: 1.0,
        })
    }
}

fn arm() -> Arm {
    Arm {
        y: vec![0.8, 1.0],
        offset: None,
        samples: Vec::new(),
    }
}

fn config() -> TemporalConfig {
    TemporalConfig {
        max_move: 0.2,
        quantile: 0.9,
        factor: 3.0,
        bins: 4,
    }
}

/// A model trained on 600 random moves, and those moves as samples.
/// Training samples `(percept, command)`.
type Samples = Vec<(Vec<f64>, Vec<f64>)>;

fn trained() -> (InverseModel, Samples) {
    let mut plant = arm();
    let mut model = InverseModel::new(
        2,
        2,
        &InverseModelConfig {
            percept_scale: 100.0,
            command_scale: 1.0,
            ..InverseModelConfig::default()
        },
    )
    .unwrap();
    let lc = LearnConfig {
        moves: 600,
        explore: vec![[0.3, 1.3], [0.5, 1.8]],
        seed: 7,
        approach: None,
    };
    learn_control(&mut plant, &mut model, &lc, |_, _| {}).unwrap();
    (model, plant.samples)
}

#[test]
fn the_residual_is_the_commanded_move_minus_the_models_change() {
    let (model, samples) = trained();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    let (a, b) = check.line();
    assert!(a >= 0.0 && b >= 0.0 && check.pairs() > 0);
    assert!((check.threshold(0.1) - 3.0 * (a + 0.1 * b)).abs() < 1e-12);
    let (y0, y1) = ([0.8, 1.0], [0.85, 0.97]);
    let (x0, x1) = (g(&y0), g(&y1));
    let (f0, f1) = (model.predict(&x0).unwrap(), model.predict(&x1).unwrap());
    let want = (((y1[0] - y0[0]) - (f1[0] - f0[0])).powi(2)
        + ((y1[1] - y0[1]) - (f1[1] - f0[1])).powi(2))
    .sqrt();
    match check.judge(&model, (&x0, &y0), (&x1, &y1)).unwrap() {
        Verdict::Consistent {
            residual,
            threshold,
        } => {
            assert!((residual - want).abs() < 1e-12);
            assert!((threshold - check.threshold(0.05f64.hypot(0.03))).abs() < 1e-12);
        }
        v => panic!("a true percept after a short move must pass: {v:?}"),
    }
    // A move longer than max_move is not judged.
    let y2 = [1.2, 1.4];
    assert_eq!(
        check.judge(&model, (&x0, &y0), (&g(&y2), &y2)).unwrap(),
        Verdict::NotJudged
    );
}

#[test]
fn true_percepts_pass_and_a_wrong_one_is_refused() {
    let (model, samples) = trained();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    let mut plant = TemporalPlant::new(arm(), model.clone(), check).unwrap();
    // A random walk of short moves inside the trained box: every true percept passes.
    let mut steps = RandomCommands::new(&[[-0.04, 0.04], [-0.04, 0.04]], 3).unwrap();
    let mut y = vec![0.8, 1.1];
    for _ in 0..200 {
        let d = steps.next_command();
        y = vec![(y[0] + d[0]).clamp(0.4, 1.2), (y[1] + d[1]).clamp(0.6, 1.7)];
        plant.act(&y).unwrap();
        plant.observe().unwrap();
    }
    assert!(plant.judged() >= 190, "judged {}", plant.judged());
    assert_eq!(plant.refused(), 0);
    // The recogniser slips by 8 px along some direction: refused, counted, and the next true
    // percept is judged against the last accepted one and passes.
    for (k, o) in [[8.0, 0.0], [0.0, -8.0], [5.7, 5.7]]
        .into_iter()
        .enumerate()
    {
        y[0] += 0.01;
        plant.act(&y).unwrap();
        plant.plant_mut().offset = Some(o);
        let e = plant.observe().unwrap_err();
        assert!(
            matches!(e, ServoError::PerceptInconsistent { residual, threshold } if residual > threshold),
            "{e}"
        );
        assert_eq!(plant.refused(), k + 1);
        y[1] -= 0.01;
        plant.act(&y).unwrap();
        plant.observe().unwrap();
    }
}

#[test]
fn the_servo_loop_stops_on_an_inconsistent_percept_and_converges_without_one() {
    let (model, samples) = trained();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    let cfg = ServoConfig {
        max_iterations: 10,
        tolerance: 0.05,
        refine_online: false,
        ..ServoConfig::default()
    };
    let x_w = g(&[0.9, 1.2]);
    let mut m = model.clone();
    let mut plant = TemporalPlant::new(arm(), model.clone(), check.clone()).unwrap();
    let run = servo_lwpr(&mut plant, &mut m, &x_w, &cfg).unwrap();
    assert!(run.converged && plant.refused() == 0);
    // Start near the target (so the first guess is a short move), then the first correction's
    // percept is 10 px off: the loop stops there instead of moving on it.
    let mut plant = TemporalPlant::new(arm(), model.clone(), check).unwrap();
    plant.act(&[0.88, 1.21]).unwrap();
    plant.observe().unwrap();
    plant.plant_mut().offset = Some([0.0, 10.0]);
    let abort = servo_lwpr(&mut plant, &mut m, &x_w, &cfg).unwrap_err();
    assert!(matches!(
        abort.error,
        ServoError::PerceptInconsistent { .. }
    ));
    assert!(abort.run.steps.is_empty());
    assert_eq!(plant.refused(), 1);
}

#[test]
fn unchecked_plants_pass_everything_and_bad_settings_are_errors() {
    let (model, samples) = trained();
    let mut plant = TemporalPlant::unchecked(arm());
    plant.act(&[0.8, 1.0]).unwrap();
    plant.observe().unwrap();
    plant.act(&[0.81, 1.0]).unwrap();
    plant.plant_mut().offset = Some([50.0, 0.0]);
    assert!(plant.observe().is_ok());
    assert_eq!((plant.judged(), plant.refused()), (0, 0));
    for bad in [
        TemporalConfig {
            max_move: 0.0,
            ..config()
        },
        TemporalConfig {
            quantile: 1.0,
            ..config()
        },
        TemporalConfig {
            factor: f64::NAN,
            ..config()
        },
        TemporalConfig {
            bins: 1,
            ..config()
        },
    ] {
        assert!(matches!(
            TemporalCheck::learn(&model, &samples, &bad),
            Err(ServoError::InvalidParameter { .. })
        ));
    }
    assert!(matches!(
        TemporalCheck::learn(&model, &samples[..3], &config()),
        Err(ServoError::NotEnoughData(_))
    ));
    let wrong = vec![(vec![1.0, 2.0], vec![1.0])];
    assert!(matches!(
        TemporalCheck::learn(&model, &wrong, &config()),
        Err(ServoError::DimensionMismatch { .. })
    ));
    let three = InverseModel::new(3, 2, &InverseModelConfig::default()).unwrap();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    assert!(TemporalPlant::new(arm(), three, check).is_err());
}

/// `TemporalPlant::act` refuses a command the plant cannot take (its length, a non-finite
/// value, a value outside the range) before the wrapped plant sees it, and the refusal changes
/// no state: the next percept is judged against the last accepted one, as on a twin plant that
/// never saw the bad command. (It used to forget the pending command first, so the next
/// percept went unjudged and did not become the reference.)
#[test]
fn a_refused_command_changes_nothing_in_the_temporal_plant() {
    let (model, samples) = trained();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    let mut p = TemporalPlant::new(arm(), model.clone(), check.clone()).unwrap();
    let mut twin = TemporalPlant::new(arm(), model, check).unwrap();
    for q in [&mut p, &mut twin] {
        q.act(&[0.8, 1.0]).unwrap();
        q.observe().unwrap();
        q.act(&[0.85, 0.97]).unwrap();
    }
    for bad in [
        vec![0.8],
        vec![0.8, 1.0, 0.1],
        vec![f64::NAN, 1.0],
        vec![0.8, 100.0],
    ] {
        assert!(p.act(&bad).is_err(), "{bad:?}: accepted");
        assert_eq!(p.plant().y, vec![0.85, 0.97], "{bad:?}: sent");
    }
    assert_eq!(p.observe().unwrap(), twin.observe().unwrap());
    assert_eq!((p.judged(), p.refused()), (twin.judged(), twin.refused()));
    assert_eq!(twin.judged(), 1, "the short move was judged");
    // The reference moved on alike: a wrong percept after the next move is refused by both.
    for q in [&mut p, &mut twin] {
        q.act(&[0.9, 0.95]).unwrap();
        q.plant_mut().offset = Some([25.0, -25.0]);
    }
    assert!(p.act(&[0.9]).is_err());
    let (a, b) = (p.observe().unwrap_err(), twin.observe().unwrap_err());
    assert!(matches!(a, ServoError::PerceptInconsistent { .. }), "{a}");
    assert_eq!(a, b);
}

/// A saved check reads back unchanged (same text, same verdicts); one whose settings
/// [`TemporalCheck::learn`] would refuse, or whose threshold line is negative, is an error when
/// it is read. (A factor of −3 used to load and refuse every percept, a true one included.)
#[test]
fn a_saved_check_round_trips_and_a_bad_file_is_an_error() {
    let (model, samples) = trained();
    let check = TemporalCheck::learn(&model, &samples, &config()).unwrap();
    let text = serde_json::to_string(&check).unwrap();
    let back: TemporalCheck = serde_json::from_str(&text).unwrap();
    assert_eq!(back, check);
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    let (x0, y0) = &samples[0];
    let (x1, y1) = &samples[1];
    assert_eq!(
        back.judge(&model, (x0, y0), (x1, y1)).unwrap(),
        check.judge(&model, (x0, y0), (x1, y1)).unwrap()
    );
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    for (pointer, bad) in [
        ("/config/factor", -3.0),
        ("/config/max_move", 0.0),
        ("/config/quantile", 1.5),
        ("/config/bins", 1.0),
        ("/offset", -1.0),
        ("/slope", -0.5),
    ] {
        let mut v = value.clone();
        *v.pointer_mut(pointer).unwrap() = if pointer.ends_with("bins") {
            serde_json::json!(bad as u64)
        } else {
            serde_json::json!(bad)
        };
        let err = serde_json::from_value::<TemporalCheck>(v)
            .map(|c| c.threshold(0.1))
            .expect_err(pointer);
        assert!(
            err.to_string().contains("invalid parameter"),
            "{pointer}: {err}"
        );
    }
}
