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

/// Bounding sphere `[x, y, z, r]` of a solid (a cheap, allocation-free reject test).
fn bounding_sphere(solid: &Solid) -> [f64; 4] {
    match solid {
        Solid::Cuboid { centre, half, .. } => [centre.x, centre.y, centre.z, half.norm()],
        Solid::Cylinder {
            x,
            y,
            radius,
            z0,
            z1,
        } => {
            let h = 0.5 * (z1 - z0);
            [*x, *y, 0.5 * (z0 + z1), radius.hypot(h)]
        }
    }
}

/// Whether the ray `o + t d` (unit `d`) passes within the sphere `s`.
#[inline]
fn ray_meets_sphere(o: &[f64; 3], d: &[f64; 3], s: &[f64; 4]) -> bool {
    let w = [s[0] - o[0], s[1] - o[1], s[2] - o[2]];
    let tca = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
    let w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    w2 - tca * tca <= s[3] * s[3] && (tca > 0.0 || w2 <= s[3] * s[3])
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
    solids: &[(Solid, f64, [f64; 4])],
    o: &[f64; 3],
    d: &[f64; 3],
) -> (f64, f64) {
    let mut best = (scene.background_grey, f64::INFINITY);
    let t = &scene.table;
    if d[2] < 0.0 {
        let tt = -o[2] / d[2];
        let (x, y) = (o[0] + tt * d[0], o[1] + tt * d[1]);
        if x >= t.x_range_mm[0]
            && x <= t.x_range_mm[1]
            && y >= t.y_range_mm[0]
            && y <= t.y_range_mm[1]
        {
            let albedo =
                t.albedo * (1.0 + t.texture_contrast * table_pattern(x, y, t.texture_seed));
            let lit = scene.ambient + (1.0 - scene.ambient) * light.z.max(0.0);
            best = (scene.exposure * albedo * lit, tt);
        }
    }
    for (solid, albedo, sphere) in solids {
        if !ray_meets_sphere(o, d, sphere) {
            continue;
        }
        let (ov, dv) = (Vector3::from(*o), Vector3::from(*d));
        if let Some((tt, n)) = intersect(solid, &ov, &dv)
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
        let solids: Vec<(Solid, f64, [f64; 4])> = solids(scene, arm)
            .into_iter()
            .map(|(s, a)| {
                let b = bounding_sphere(&s);
                (s, a, b)
            })
            .collect();
        let o = [camera.centre.x, camera.centre.y, camera.centre.z];
        let rt = camera.rotation.transpose();
        let centre_rays: Vec<[f64; 3]> = (0..h)
            .flat_map(|v| (0..w).map(move |u| (u as f64, v as f64)))
            .map(|(u, v)| {
                // A validated camera undistorts every pixel; fall back to the distorted
                // direction rather than fail if a corner is marginal.
                let [x, y] = camera
                    .undistort(u, v)
                    .unwrap_or([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy]);
                let r = (rt * Vector3::new(x, y, 1.0)).normalize();
                [r.x, r.y, r.z]
            })
            .collect();
        let mut radiance = Vec::with_capacity(w * h);
        let mut depth = Vec::with_capacity(w * h);
        let mut rays = Vec::with_capacity(w * h);
        for v in 0..h {
            for u in 0..w {
                let c = centre_rays[v * w + u];
                rays.push([c[0] as f32, c[1] as f32, c[2] as f32]);
                let (ul, ur) = (u.saturating_sub(1), (u + 1).min(w - 1));
                let (vu, vd) = (v.saturating_sub(1), (v + 1).min(h - 1));
                let (cl, cr) = (centre_rays[v * w + ul], centre_rays[v * w + ur]);
                let (cu, cd) = (centre_rays[vu * w + u], centre_rays[vd * w + u]);
                let (nu, nv) = ((ur - ul) as f64, (vd - vu) as f64);
                let du: [f64; 3] = std::array::from_fn(|k| (cr[k] - cl[k]) / nu);
                let dv: [f64; 3] = std::array::from_fn(|k| (cd[k] - cu[k]) / nv);
                let mut sum = 0.0;
                let mut near = f64::INFINITY;
                for (su, sv) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                    let mut d: [f64; 3] = std::array::from_fn(|k| c[k] + du[k] * su + dv[k] * sv);
                    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    d.iter_mut().for_each(|x| *x /= n);
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
