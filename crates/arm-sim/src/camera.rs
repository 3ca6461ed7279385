//! Pinhole camera with two-term radial distortion: projection, undistortion and pixel rays.
//!
//! `Xc = R (X − C)`; `x = Xc/Zc`, `y = Yc/Zc`; `d = 1 + k1 r² + k2 r⁴` with `r² = x² + y²`;
//! `u = fx d x + cx`, `v = fy d y + cy`. Undistortion inverts `ρ ↦ ρ (1 + k1 ρ² + k2 ρ⁴)` along
//! the radius by Newton's method (monotonic over the image, checked by the configuration).

use nalgebra::{Matrix3, Vector3};

use crate::config::CameraConfig;
use crate::error::{ArmSimError, Result};

/// Closest distance in front of the camera (mm) at which a point still projects.
pub const NEAR_MM: f64 = 1.0;

/// A calibrated camera in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    index: usize,
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length in pixels, horizontal.
    pub fx: f64,
    /// Focal length in pixels, vertical.
    pub fy: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
    /// First radial distortion coefficient.
    pub k1: f64,
    /// Second radial distortion coefficient.
    pub k2: f64,
    /// World-to-camera rotation (rows: image right, image down, optical axis).
    pub rotation: Matrix3<f64>,
    /// Camera centre in the world (mm).
    pub centre: Vector3<f64>,
}

impl Camera {
    /// Builds camera `index` from its configuration. Fails with
    /// [`ArmSimError::InvalidConfig`] for impossible values (as [`CameraConfig::validate`]:
    /// image size, focal lengths, principal point, a lens that does not fold over inside the
    /// image, roll and pose not finite), and with [`ArmSimError::CameraBehindScene`] if the
    /// camera is below the table top or the arm base is not in front of it.
    pub fn new(cfg: &CameraConfig, index: usize) -> Result<Self> {
        // Without this a zero, negative or NaN focal length, a NaN roll or distortion gave a
        // camera whose every projection was NaN, infinite or the principal point.
        cfg.validate_values(index)?;
        let centre = Vector3::from(cfg.position_mm);
        let target = Vector3::from(cfg.look_at_mm);
        let behind = |reason: &str| ArmSimError::CameraBehindScene {
            camera: index,
            reason: reason.to_string(),
        };
        if centre.z <= 0.0 {
            return Err(behind("the camera is not above the table top (z <= 0)"));
        }
        let axis = target - centre;
        if !axis.norm().is_finite() {
            // Finite coordinates whose difference overflows: the rotation would be NaN.
            return Err(ArmSimError::InvalidConfig {
                key: format!("cameras[{index}].position_mm"),
                reason: "too far from look_at_mm (the optical axis overflows)".into(),
            });
        }
        if axis.norm() < NEAR_MM {
            return Err(ArmSimError::InvalidConfig {
                key: format!("cameras[{index}].look_at_mm"),
                reason: "coincides with position_mm".into(),
            });
        }
        let forward = axis.normalize();
        let hint = if forward.z.abs() > 0.999 {
            Vector3::x()
        } else {
            Vector3::z()
        };
        let right0 = forward.cross(&hint).normalize();
        let down0 = forward.cross(&right0);
        let (s, c) = cfg.roll_deg.to_radians().sin_cos();
        let right = right0 * c + down0 * s;
        let down = down0 * c - right0 * s;
        let rotation =
            Matrix3::from_rows(&[right.transpose(), down.transpose(), forward.transpose()]);
        let cam = Camera {
            index,
            width: cfg.width,
            height: cfg.height,
            fx: cfg.fx,
            fy: cfg.fy,
            cx: cfg.cx,
            cy: cfg.cy,
            k1: cfg.k1,
            k2: cfg.k2,
            rotation,
            centre,
        };
        let base_depth = cam.to_camera(&Vector3::zeros()).z;
        if base_depth.is_nan() || base_depth < 10.0 * NEAR_MM {
            return Err(behind("the arm base (world origin) is behind the camera"));
        }
        Ok(cam)
    }

    /// This camera's index.
    pub fn index(&self) -> usize {
        self.index
    }

    /// World point → camera frame (mm).
    pub fn to_camera(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (p - self.centre)
    }

    /// Distortion factor `1 + k1 r² + k2 r⁴`.
    pub fn distortion(&self, r2: f64) -> f64 {
        1.0 + self.k1 * r2 + self.k2 * r2 * r2
    }

    /// Normalised undistorted image point → pixel.
    pub fn normalised_to_pixel(&self, x: f64, y: f64) -> [f64; 2] {
        let d = self.distortion(x * x + y * y);
        [self.fx * d * x + self.cx, self.fy * d * y + self.cy]
    }

    /// Projects a world point (mm) to pixel coordinates `[u, v]` (column, row; pixel centres at
    /// integers). The point may project outside the image; it must be in front of the camera.
    ///
    /// ```
    /// use arm_sim::{Camera, CameraConfig};
    /// let cam = Camera::new(&CameraConfig::looking_at([500.0, 0.0, 300.0], [0.0, 0.0, 0.0]), 0).unwrap();
    /// let [u, v] = cam.project(&nalgebra::Vector3::zeros()).unwrap();
    /// assert!((u - 319.5).abs() < 1e-9 && (v - 239.5).abs() < 1e-9);
    /// ```
    pub fn project(&self, p: &Vector3<f64>) -> Result<[f64; 2]> {
        if p.iter().any(|v| !v.is_finite()) {
            return Err(ArmSimError::NonFinite { what: "3-D point" });
        }
        let c = self.to_camera(p);
        if c.z < NEAR_MM {
            return Err(ArmSimError::PointBehindCamera {
                camera: self.index,
                x: p.x,
                y: p.y,
                z: p.z,
            });
        }
        Ok(self.normalised_to_pixel(c.x / c.z, c.y / c.z))
    }

    /// Pixel → normalised undistorted image point `(x, y)` (so that the pixel's ray in the
    /// camera frame is `(x, y, 1)`).
    pub fn undistort(&self, u: f64, v: f64) -> Result<[f64; 2]> {
        if !(u.is_finite() && v.is_finite()) {
            return Err(ArmSimError::NonFinite { what: "pixel" });
        }
        let xd = (u - self.cx) / self.fx;
        let yd = (v - self.cy) / self.fy;
        let rd = xd.hypot(yd);
        if rd == 0.0 {
            return Ok([0.0, 0.0]);
        }
        let fail = ArmSimError::Undistort {
            camera: self.index,
            u,
            v,
        };
        let mut r = rd;
        for _ in 0..50 {
            let r2 = r * r;
            let g = r * self.distortion(r2) - rd;
            let slope = 1.0 + 3.0 * self.k1 * r2 + 5.0 * self.k2 * r2 * r2;
            if slope <= 0.0 {
                return Err(fail);
            }
            let step = g / slope;
            r -= step;
            if step.abs() < 1e-15 * (1.0 + r) {
                break;
            }
        }
        let r2 = r * r;
        if !(r > 0.0 && (r * self.distortion(r2) - rd).abs() < 1e-9 * (1.0 + rd)) {
            return Err(fail);
        }
        let slope = 1.0 + 3.0 * self.k1 * r2 + 5.0 * self.k2 * r2 * r2;
        if slope <= 0.0 {
            return Err(fail);
        }
        Ok([xd * r / rd, yd * r / rd])
    }

    /// Unit direction (world frame) of the ray through pixel `(u, v)`.
    pub fn ray(&self, u: f64, v: f64) -> Result<Vector3<f64>> {
        let [x, y] = self.undistort(u, v)?;
        Ok((self.rotation.transpose() * Vector3::new(x, y, 1.0)).normalize())
    }

    /// Whether the pixel position lies inside the image (pixel centres `0..width−1`, with the
    /// half-pixel border).
    pub fn in_image(&self, uv: [f64; 2]) -> bool {
        uv[0] >= -0.5
            && uv[1] >= -0.5
            && uv[0] < self.width as f64 - 0.5
            && uv[1] < self.height as f64 - 0.5
    }
}
