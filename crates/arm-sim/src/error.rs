//! The crate's one error type.

use thiserror::Error;

/// Everything that can go wrong in `arm-sim`.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ArmSimError {
    /// A configuration value is impossible; `key` is its JSON path (e.g. `servos[2].gain`).
    #[error("invalid configuration value `{key}`: {reason}")]
    InvalidConfig {
        /// JSON path of the offending key.
        key: String,
        /// Why the value is rejected.
        reason: String,
    },
    /// The configuration text could not be parsed (syntax, unknown key, wrong type).
    #[error("cannot parse arm-sim configuration: {0}")]
    ConfigParse(String),
    /// Reading or writing a configuration file failed.
    #[error("configuration file {path}: {message}")]
    ConfigIo {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// A command did not hold one set-point per servo.
    #[error("expected {expected} servo set-points, got {got}")]
    WrongCommandLength {
        /// Number of servos.
        expected: usize,
        /// Number given.
        got: usize,
    },
    /// A set-point was NaN or infinite.
    #[error("set-point of servo {servo} is not finite ({value})")]
    NonFiniteCommand {
        /// Servo index (0 = base … 5 = gripper).
        servo: usize,
        /// The value given.
        value: f64,
    },
    /// A set-point lies outside the servo's pulse-width range.
    #[error("set-point of servo {servo} is {value} µs, outside [{min}, {max}] µs")]
    CommandOutOfRange {
        /// Servo index (0 = base … 5 = gripper).
        servo: usize,
        /// The value given.
        value: f64,
        /// Lowest accepted pulse width.
        min: f64,
        /// Highest accepted pulse width.
        max: f64,
    },
    /// A camera does not look at the scene (the arm base or its target point is behind it, or it
    /// sits below the table).
    #[error("camera {camera} does not see the scene: {reason}")]
    CameraBehindScene {
        /// Camera index.
        camera: usize,
        /// What is wrong.
        reason: String,
    },
    /// A point to project lies on or behind the camera's image plane.
    #[error("point ({x:.1}, {y:.1}, {z:.1}) mm is behind camera {camera}")]
    PointBehindCamera {
        /// Camera index.
        camera: usize,
        /// World x (mm).
        x: f64,
        /// World y (mm).
        y: f64,
        /// World z (mm).
        z: f64,
    },
    /// A camera index beyond the configured cameras.
    #[error("no camera {camera} (the simulator has {count})")]
    NoSuchCamera {
        /// Index asked for.
        camera: usize,
        /// Number of cameras.
        count: usize,
    },
    /// A non-finite number given to a geometry function (point or pixel).
    #[error("non-finite {what}")]
    NonFinite {
        /// What it was.
        what: &'static str,
    },
    /// Undistortion did not converge (pixel far outside the valid lens field).
    #[error("pixel ({u:.1}, {v:.1}) cannot be undistorted by camera {camera}")]
    Undistort {
        /// Camera index.
        camera: usize,
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, ArmSimError>;
