//! `learn_by_action`'s checks of the heuristic percept it learns from, on the simulated arm:
//! refused before the robot moves.

use arm_sim::{ArmSim, SimConfig};
use servo_loop::SilhouetteConfig;
use visguide::SimRobot;
use visguide::pipeline::{ActionProtocol, PipelineError, learn_by_action};

use crate::common::arm;
use arm::{EXPLORE, heuristic, space};

/// A heuristic percept whose cameras see images of different sizes (the second camera at half
/// the resolution) is refused before the robot moves: the FD + CBT percept takes one image size
/// for every camera, so learning from it used to give a percept that refused every capture of
/// the second camera.
#[test]
fn a_heuristic_with_cameras_of_different_sizes_is_refused_before_the_robot_moves() {
    let mut config = SimConfig::default();
    let cam = &mut config.cameras[1];
    cam.width /= 2;
    cam.height /= 2;
    cam.fx /= 2.0;
    cam.fy /= 2.0;
    cam.cx /= 2.0;
    cam.cy /= 2.0;
    let mut robot = SimRobot::new(ArmSim::new(config).unwrap());
    let heuristic = heuristic(&mut robot, &SilhouetteConfig::default());
    let sent = robot.commands();
    let protocol = ActionProtocol {
        views: 4,
        walks: 1,
        steps: 3,
        ..ActionProtocol::default()
    };
    match learn_by_action(&mut robot, &space(), &EXPLORE, &heuristic, &protocol) {
        Err(PipelineError::InvalidParameter { name, reason }) => {
            assert_eq!(name, "heuristic");
            assert!(reason.contains("camera 1"), "{reason}");
        }
        other => panic!("{:?}", other.map(|(_, r)| r)),
    }
    assert_eq!(robot.commands(), sent, "the robot did not move");
}
