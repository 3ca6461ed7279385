//! The percept seam: a user's own recogniser plugs into [`VisualPlant`] through
//! [`Recogniser`]; a doubted percept is re-captured, then refused with a typed error; learning
//! skips and counts it; the servo loop never moves on it.

use image::{GrayImage, Luma};
use servo_loop::{
    ControlSpace, InverseModel, InverseModelConfig, LearnConfig, Localisation, PerceptPolicy,
    PerceptUse, Plant, Recogniser, Robot, ServoConfig, ServoError, VisualPlant, learn_control,
    servo_lwpr,
};

/// Two servos; each capture shows the set-points as grey levels and a "doubt" flag for the
/// next `doubt` captures.
struct Toy {
    y: [f64; 2],
    doubt: usize,
    captures: usize,
    commands: usize,
}

impl Robot for Toy {
    type Error = String;
    fn num_servos(&self) -> usize {
        2
    }
    fn servo_range(&self, _: usize) -> [f64; 2] {
        [0.0, 250.0]
    }
    fn command(&mut self, set_points: &[f64]) -> Result<(), String> {
        self.commands += 1;
        self.y = [set_points[0], set_points[1]];
        Ok(())
    }
    fn capture(&mut self) -> Result<Vec<GrayImage>, String> {
        self.captures += 1;
        let flag = if self.doubt > 0 {
            self.doubt -= 1;
            255
        } else {
            0
        };
        Ok((0..2)
            .map(|cam| {
                let mut img = GrayImage::new(8, 8);
                img.put_pixel(0, 0, Luma([self.y[0].round() as u8]));
                img.put_pixel(1, 0, Luma([self.y[1].round() as u8]));
                img.put_pixel(2, 0, Luma([flag]));
                img.put_pixel(3, 0, Luma([cam]));
                img
            })
            .collect())
    }
}

/// A user's recogniser: reads the grey levels back as a point; doubts flagged images.
struct Reader;

impl Recogniser for Reader {
    fn num_cameras(&self) -> usize {
        2
    }
    fn image_size(&self, _: usize) -> [u32; 2] {
        [300, 300]
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        Ok(images
            .iter()
            .map(|img| {
                let p = |x| f64::from(img.get_pixel(x, 0).0[0]);
                let cam = p(3);
                Localisation {
                    position: [10.0 + p(0) + 5.0 * cam, 20.0 + p(1) - 3.0 * cam],
                    certainty: if p(2) > 0.0 { 0.01 } else { 0.9 },
                }
            })
            .collect())
    }
}

/// A recogniser that doubts flagged images only when the servo acts on them (as the learned
/// tip's spread cap with `cap_training` off).
struct ServoDoubter;

impl Recogniser for ServoDoubter {
    fn num_cameras(&self) -> usize {
        Reader.num_cameras()
    }
    fn image_size(&self, cam: usize) -> [u32; 2] {
        Reader.image_size(cam)
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        Reader.locate_all(images)
    }
    fn locate_all_for(
        &self,
        images: &[GrayImage],
        used: PerceptUse,
    ) -> servo_loop::Result<Vec<Localisation>> {
        let mut locs = Reader.locate_all(images)?;
        if used == PerceptUse::Training {
            for l in &mut locs {
                l.certainty = l.certainty.max(0.9);
            }
        }
        Ok(locs)
    }
}

fn toy_space() -> ControlSpace {
    ControlSpace {
        controlled: vec![0, 1],
        rest: vec![100.0, 100.0],
        gripper: None,
    }
}

/// An untrained inverse model of the toy's scales and `moves` random training moves.
fn toy_learning(moves: usize) -> (InverseModel, LearnConfig) {
    let config = InverseModelConfig {
        percept_scale: 100.0,
        command_scale: 100.0,
        ..InverseModelConfig::default()
    };
    let learn = LearnConfig {
        moves,
        explore: vec![[20.0, 200.0]; 2],
        seed: 5,
        approach: None,
    };
    (InverseModel::new(4, 2, &config).unwrap(), learn)
}

fn plant(doubt: usize) -> VisualPlant<Toy, Reader> {
    let toy = Toy {
        y: [100.0, 100.0],
        doubt,
        captures: 0,
        commands: 0,
    };
    VisualPlant::new(toy, toy_space(), Reader).unwrap()
}

/// The plant passes its policy's use to the recogniser: training moves under
/// `PerceptUse::Training` keep percepts the servo's policy refuses.
#[test]
fn the_policy_says_what_a_percept_is_for() {
    let toy = Toy {
        y: [100.0, 100.0],
        doubt: usize::MAX,
        captures: 0,
        commands: 0,
    };
    let mut p = VisualPlant::new(toy, toy_space(), ServoDoubter).unwrap();
    assert_eq!(p.policy().used, PerceptUse::Servo, "the default use");
    p.set_policy(PerceptPolicy {
        used: PerceptUse::Training,
        ..PerceptPolicy::default()
    })
    .unwrap();
    let (mut model, learn) = toy_learning(50);
    let report = learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    assert_eq!((report.refused, p.refused(), p.recaptured()), (0, 0, 0));
    // The same images as servo percepts: re-captured, then refused.
    p.set_policy(PerceptPolicy::default()).unwrap();
    assert!(matches!(
        p.observe(),
        Err(ServoError::PerceptRefused { .. })
    ));
    assert_eq!((p.refused(), p.recaptured()), (1, 1));
}

#[test]
fn a_users_recogniser_is_the_percept() {
    let mut p = plant(0);
    p.act(&[50.0, 60.0]).unwrap();
    let o = p.observe().unwrap();
    assert_eq!(o.x, vec![60.0, 80.0, 65.0, 77.0]);
    assert_eq!(o.certainty, 0.9);
    assert_eq!(p.percept_bounds().unwrap(), vec![[0.0, 299.0]; 4]);
}

#[test]
fn a_doubted_percept_is_recaptured_then_refused() {
    // One doubted capture: the re-capture is accepted.
    let mut p = plant(1);
    let o = p.observe().unwrap();
    assert_eq!(o.certainty, 0.9);
    assert_eq!((p.recaptured(), p.refused()), (1, 0));
    assert_eq!(p.robot().captures, 2);
    // Doubted on every attempt (2 captures per attempt, 1 re-capture): refused, typed.
    let mut p = plant(100);
    p.set_policy(PerceptPolicy {
        captures: 2,
        min_certainty: 0.05,
        recaptures: 1,
        used: PerceptUse::Servo,
    })
    .unwrap();
    let e = p.observe().unwrap_err();
    assert_eq!(
        e,
        ServoError::PerceptRefused {
            camera: 0,
            certainty: 0.01,
            min: 0.05,
            captures: 4
        }
    );
    assert_eq!((p.recaptured(), p.refused()), (1, 1));
    // An invalid policy is refused and changes nothing.
    let before = *p.policy();
    for bad in [
        PerceptPolicy {
            captures: 0,
            ..before
        },
        PerceptPolicy {
            min_certainty: 1.5,
            ..before
        },
    ] {
        assert!(p.set_policy(bad).is_err());
        assert_eq!(*p.policy(), before);
    }
}

#[test]
fn learning_skips_refused_percepts_and_the_servo_loop_never_moves_on_one() {
    let mut p = plant(0);
    let (mut model, learn) = toy_learning(200);
    learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    // Ten doubted moves (two captures each with the re-capture) are skipped and counted.
    p.robot_mut().doubt = 20;
    let before = model.clone();
    let ten = LearnConfig {
        moves: 10,
        ..learn.clone()
    };
    assert!(matches!(
        learn_control(&mut p, &mut model, &ten, |_, _| {}),
        Err(ServoError::NotEnoughData(_))
    ));
    assert_eq!(model, before, "nothing learned from refused percepts");
    assert_eq!(p.refused(), 10);
    // A servo run whose second percept is refused stops there: one move, no second.
    let x_w = [10.0 + 120.0, 20.0 + 90.0, 15.0 + 120.0, 17.0 + 90.0];
    let commands = p.robot().commands;
    p.robot_mut().doubt = 0;
    let mut servo_model = model.clone();
    // The first guess is seen clearly; the next percept is doubted twice (refused).
    let cfg = ServoConfig {
        tolerance: 0.0,
        ..ServoConfig::default()
    };
    let run = servo_lwpr(
        &mut DoubtAfterFirst {
            plant: &mut p,
            moves: 0,
        },
        &mut servo_model,
        &x_w,
        &cfg,
    )
    .unwrap_err();
    assert!(
        matches!(run.error, ServoError::PerceptRefused { .. }),
        "{}",
        run.error
    );
    assert_eq!(run.run.steps.len(), 1, "only the first guess was recorded");
    assert_eq!(
        p.robot().commands,
        commands + 2,
        "no move after the refusal"
    );
}

/// The toy plant, with every percept after the first move doubted.
struct DoubtAfterFirst<'a> {
    plant: &'a mut VisualPlant<Toy, Reader>,
    moves: usize,
}

impl Plant for DoubtAfterFirst<'_> {
    fn percept_dim(&self) -> usize {
        self.plant.percept_dim()
    }
    fn command_dim(&self) -> usize {
        self.plant.command_dim()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        self.plant.command_range(j)
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.moves += 1;
        if self.moves >= 2 {
            self.plant.robot_mut().doubt = 100;
        }
        self.plant.act(y)
    }
    fn observe(&mut self) -> servo_loop::Result<servo_loop::Observation> {
        self.plant.observe()
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.plant.percept_bounds()
    }
}
