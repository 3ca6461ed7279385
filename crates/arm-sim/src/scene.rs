//! The static part of each image: the textured table, the clutter objects and the arm's fixed
//! base, ray-traced once per camera with 2×2 supersampling (anti-aliased edges) into a radiance
//! buffer and a depth buffer that every frame starts from.

use nalgebra::Vector3;

use crate::camera::Camera;
use crate::config::{ArmGeometry, ClutterKind, SceneConfig};
use crate::texture::table_pattern;

/// A static solid standing on the table.
#[derive(Clone, Debug)]
enum Solid {
    /// Oriented box: centre, half sizes, yaw (radians).
    Cuboid {
        centre: Vector3<f64>,
        half: Vector3<f64>,
        yaw: f64,
    },
    /// Vertical cylinder: axis position, radius, bottom and top heights.
    Cylinder {
        x: f64,
        y: f64,
        radius: f64,
        z0: f64,
        z1: f64,
    },
}

/// The ray's first hit on a solid: distance and outward unit normal.
fn intersect(solid: &Solid, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    match solid {
        Solid::Cuboid { centre, half, yaw } => {
            let (s, c) = yaw.sin_cos();
            let to_local =
                |v: &Vector3<f64>| Vector3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z);
            let ol = to_local(&(o - centre));
            let dl = to_local(d);
            let (mut tn, mut tf) = (f64::NEG_INFINITY, f64::INFINITY);
            let mut axis = 0;
            for k in 0..3 {
                if dl[k].abs() < 1e-12 {
                    if ol[k].abs() > half[k] {
                        return None;
                    }
                    continue;
                }
                let t1 = (-half[k] - ol[k]) / dl[k];
                let t2 = (half[k] - ol[k]) / dl[k];
                let (a, b) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
                if a > tn {
                    tn = a;
                    axis = k;
                }
                tf = tf.min(b);
            }
            if tn > tf || tn <= 0.0 {
                return None;
            }
            let mut nl = Vector3::zeros();
            nl[axis] = -dl[axis].signum();
            let n = Vector3::new(c * nl.x - s * nl.y, s * nl.x + c * nl.y, nl.z);
            Some((tn, n))
        }
        Solid::Cylinder {
            x,
            y,
            radius,
            z0,
            z1,
        } => {
            let mut best: Option<(f64, Vector3<f64>)> = None;
            let (px, py) = (o.x - x, o.y - y);
            let a = d.x * d.x + d.y * d.y;
            if a > 1e-12 {
                let b = px * d.x + py * d.y;
                let c = px * px + py * py - radius * radius;
                let disc = b * b - a * c;
                if disc >= 0.0 {
                    let t = (-b - disc.sqrt()) / a;
                    let z = o.z + t * d.z;
                    if t > 0.0 && z >= *z0 && z <= *z1 {
                        let n = Vector3::new(px + t * d.x, py + t * d.y, 0.0) / *radius;
                        best = Some((t, n));
                    }
                }
            }
            if d.z.abs() > 1e-12 {
                let t = (z1 - o.z) / d.z;
                let (qx, qy) = (px + t * d.x, py + t * d.y);
                if t > 0.0 && qx * qx + qy * qy <= radius * radius && best.is_none_or(|b| t < b.0) {
                    best = Some((t, Vector3::z()));
                }
            }
            best
        }
    }
}

/// Lambertian shading: grey level of a surface with `albedo` and unit normal `n`.
pub(crate) fn lambert(
    scene: &SceneConfig,
    light: &Vector3<f64>,
    albedo: f64,
    n: &Vector3<f64>,
) -> f64 {
    scene.exposure * albedo * (scene.ambient + (1.0 - scene.ambient) * n.dot(light).max(0.0))
}

/// The pre-rendered static background of one camera.
pub(crate) struct Background {
    /// Grey level per pixel (before the frame's lighting change and noise).
    pub radiance: Vec<f32>,
    /// Distance along the pixel's unit ray to the nearest static surface (mm; +∞ if none).
    pub depth: Vec<f32>,
    /// Unit ray direction per pixel centre (world frame).
    pub rays: Vec<[f32; 3]>,
}

/// The static solids: clutter objects and the arm's base (housing and turntable).
fn solids(scene: &SceneConfig, arm: &ArmGeometry) -> Vec<(Solid, f64)> {
    let mut out = Vec::new();
    let housing = 0.5 * arm.base_height_mm;
    out.push((
        Solid::Cuboid {
            centre: Vector3::new(0.0, 0.0, 0.5 * housing),
            half: Vector3::new(48.0, 48.0, 0.5 * housing),
            yaw: 0.0,
        },
        scene.arm_albedo,
    ));
    out.push((
        Solid::Cylinder {
            x: 0.0,
            y: 0.0,
            radius: 34.0,
            z0: housing,
            z1: (arm.base_height_mm - arm.servo_radius_mm).max(housing + 1.0),
        },
        scene.arm_albedo * 1.3,
    ));
    for o in &scene.clutter {
        let solid = match o.kind {
            ClutterKind::Box => Solid::Cuboid {
                centre: Vector3::new(o.centre_mm[0], o.centre_mm[1], 0.5 * o.size_mm[2]),
                half: Vector3::new(0.5 * o.size_mm[0], 0.5 * o.size_mm[1], 0.5 * o.size_mm[2]),
                yaw: o.yaw_deg.to_radians(),
            },
            ClutterKind::Cylinder => Solid::Cylinder {
                x: o.centre_mm[0],
                y: o.centre_mm[1],
                radius: 0.5 * o.size_mm[0],
                z0: 0.0,
                z1: o.size_mm[2],
            },
        };
        out.push((solid, o.albedo));
    }
    out
}

/// Traces one ray: grey level and distance.
fn trace(
    scene: &SceneConfig,
    light: &Vector3<f64>,
    solids: &[(Solid, f64)],
    o: &Vector3<f64>,
    d: &Vector3<f64>,
) -> (f64, f64) {
    let mut best = (scene.background_grey, f64::INFINITY);
    let t = &scene.table;
    if d.z < 0.0 {
        let tt = -o.z / d.z;
        let (x, y) = (o.x + tt * d.x, o.y + tt * d.y);
        if x >= t.x_range_mm[0]
            && x <= t.x_range_mm[1]
            && y >= t.y_range_mm[0]
            && y <= t.y_range_mm[1]
        {
            let albedo =
                t.albedo * (1.0 + t.texture_contrast * table_pattern(x, y, t.texture_seed));
            best = (lambert(scene, light, albedo, &Vector3::z()), tt);
        }
    }
    for (solid, albedo) in solids {
        if let Some((tt, n)) = intersect(solid, o, d)
            && tt < best.1
        {
            best = (lambert(scene, light, *albedo, &n), tt);
        }
    }
    best
}

impl Background {
    /// Ray-traces the static scene for `camera` (2×2 samples per pixel). The pixel-centre rays
    /// are exact (undistorted by Newton's method); the sub-sample rays at ±¼ pixel are
    /// interpolated from the neighbouring centre rays (error far below a pixel's footprint).
    pub fn render(camera: &Camera, scene: &SceneConfig, arm: &ArmGeometry) -> Self {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let light = Vector3::from(scene.light_direction).normalize();
        let solids = solids(scene, arm);
        let o = camera.centre;
        let rt = camera.rotation.transpose();
        let centre_rays: Vec<Vector3<f64>> = (0..h)
            .flat_map(|v| (0..w).map(move |u| (u as f64, v as f64)))
            .map(|(u, v)| {
                // A validated camera undistorts every pixel; fall back to the distorted
                // direction rather than fail if a corner is marginal.
                let [x, y] = camera
                    .undistort(u, v)
                    .unwrap_or([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy]);
                (rt * Vector3::new(x, y, 1.0)).normalize()
            })
            .collect();
        let mut radiance = Vec::with_capacity(w * h);
        let mut depth = Vec::with_capacity(w * h);
        let mut rays = Vec::with_capacity(w * h);
        for v in 0..h {
            for u in 0..w {
                let c = centre_rays[v * w + u];
                rays.push([c.x as f32, c.y as f32, c.z as f32]);
                let (ul, ur) = (u.saturating_sub(1), (u + 1).min(w - 1));
                let (vu, vd) = (v.saturating_sub(1), (v + 1).min(h - 1));
                let du = (centre_rays[v * w + ur] - centre_rays[v * w + ul]) / (ur - ul) as f64;
                let dv = (centre_rays[vd * w + u] - centre_rays[vu * w + u]) / (vd - vu) as f64;
                let mut sum = 0.0;
                let mut near = f64::INFINITY;
                for (su, sv) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let d = (c + du * su + dv * sv).normalize();
                    let (g, t) = trace(scene, &light, &solids, &o, &d);
                    sum += g;
                    near = near.min(t);
                }
                radiance.push((0.25 * sum) as f32);
                depth.push(near as f32);
            }
        }
        Background {
            radiance,
            depth,
            rays,
        }
    }
}
