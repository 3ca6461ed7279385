//! Per-frame rendering: the arm as shaded capsules and boxes over the pre-rendered background,
//! then the frame's lighting change and sensor noise.
//!
//! Each arm part is rasterised only inside the bounding box of its projection. Per pixel the
//! pixel's precomputed ray (lens distortion included) is intersected with the part: for a
//! capsule, the closest approach of the ray to the axis segment gives both the hit and, for rays
//! that miss, the distance from the silhouette, which becomes the anti-aliasing coverage
//! `clamp(0.5 + (r − dist)·px_per_mm)`; for a box the slab test gives the hit and, for near
//! misses, a convex 1-D minimisation of the box's distance function along the ray gives the
//! coverage. A depth buffer (seeded by the background's depths) resolves occlusion; parts are
//! drawn far to near so anti-aliased fringes blend over what lies behind them. No allocation
//! happens per pixel.
//!
//! **The frame budget** (< 5 ms per 640 × 480 camera image; `docs/performance.md`): the static
//! scene (table, clutter, arm base) is ray-traced once per camera with 2 × 2 supersampling into a
//! radiance and a depth buffer, with a per-pixel ray table; each frame restores only the rectangle
//! the arm dirtied the frame before, draws the arm's parts inside their projected outlines, and
//! applies lighting and sensor noise in one branch-free pass (32 random bits per pixel).

use image::GrayImage;
use nalgebra::Vector3;
use rand::Rng;

use crate::camera::Camera;
use crate::config::{ArmGeometry, Distractor, SceneConfig};
use crate::kinematics::{ArmPose, FINGER_THICKNESS_MM, FINGER_WIDTH_MM};
use crate::scene::Background;

type V3 = Vector3<f32>;

/// Label of pixels showing the arm's links and servos in [`crate::Inspection::labels`].
pub const LABEL_ARM: u8 = 1;
/// Label of pixels showing the gripper's palm.
pub const LABEL_PALM: u8 = 2;
/// Label of pixels showing the first finger.
pub const LABEL_FINGER_A: u8 = 3;
/// Label of pixels showing the second finger.
pub const LABEL_FINGER_B: u8 = 4;

/// Label of pixels showing the moving distractor ([`crate::Distractor`]).
pub const LABEL_DISTRACTOR: u8 = 5;

/// Length of the gripper palm along the hand (mm).
const PALM_LENGTH_MM: f64 = 18.0;
/// Palm thickness across the opening direction and the approach (mm).
const PALM_THICKNESS_MM: f64 = 20.0;

#[derive(Clone, Debug)]
enum Shape {
    Capsule { a: V3, b: V3, r: f32 },
    Cuboid { c: V3, axes: [V3; 3], half: V3 },
}

#[derive(Clone, Debug)]
struct Part {
    shape: Shape,
    label: u8,
    albedo: f32,
    /// Specular strength (share of the exposure).
    specular: f32,
}

fn v3(v: &Vector3<f64>) -> V3 {
    V3::new(v.x as f32, v.y as f32, v.z as f32)
}

/// The arm's drawable parts for `pose`.
fn arm_parts(g: &ArmGeometry, scene: &SceneConfig, pose: &ArmPose) -> Vec<Part> {
    let arm = scene.arm_albedo as f32;
    let grip = scene.gripper_albedo as f32;
    let p = pose.pitch_axis;
    let a = pose.approach;
    let o = pose.opening_axis;
    let b = a.cross(&o);
    let sr = g.servo_radius_mm;
    let capsule = |from: Vector3<f64>, to: Vector3<f64>, r: f64, albedo: f32| Part {
        shape: Shape::Capsule {
            a: v3(&from),
            b: v3(&to),
            r: r as f32,
        },
        label: LABEL_ARM,
        albedo,
        specular: 0.15,
    };
    let cuboid = |c: Vector3<f64>, half: [f64; 3], label: u8| Part {
        shape: Shape::Cuboid {
            c: v3(&c),
            axes: [v3(&a), v3(&o), v3(&b)],
            half: V3::new(half[0] as f32, half[1] as f32, half[2] as f32),
        },
        label,
        albedo: grip,
        specular: 0.25,
    };
    let finger_start = g.hand_mm + g.finger_pad_mm - g.finger_length_mm;
    let palm_centre = pose.wrist + a * (finger_start - 0.5 * PALM_LENGTH_MM);
    let roll_end = (finger_start - PALM_LENGTH_MM - 0.6 * sr).max(0.0);
    let finger_centre = pose.tip + a * (g.finger_pad_mm - 0.5 * g.finger_length_mm);
    let finger_off = o * (0.5 * pose.opening_mm + 0.5 * FINGER_THICKNESS_MM);
    let finger_half = [
        0.5 * g.finger_length_mm,
        0.5 * FINGER_THICKNESS_MM,
        0.5 * FINGER_WIDTH_MM,
    ];
    vec![
        capsule(pose.shoulder - p * 26.0, pose.shoulder + p * 26.0, sr, arm),
        capsule(pose.shoulder, pose.elbow, g.link_radius_mm[0], arm * 1.2),
        capsule(pose.elbow - p * 22.0, pose.elbow + p * 22.0, 0.9 * sr, arm),
        capsule(pose.elbow, pose.wrist, g.link_radius_mm[1], arm * 1.2),
        capsule(pose.wrist - p * 18.0, pose.wrist + p * 18.0, 0.8 * sr, arm),
        capsule(pose.wrist, pose.wrist + a * roll_end, 0.75 * sr, arm),
        cuboid(
            palm_centre,
            [
                0.5 * PALM_LENGTH_MM,
                0.5 * g.max_opening_mm + FINGER_THICKNESS_MM + 3.0,
                0.5 * PALM_THICKNESS_MM,
            ],
            LABEL_PALM,
        ),
        cuboid(finger_centre + finger_off, finger_half, LABEL_FINGER_A),
        cuboid(finger_centre - finger_off, finger_half, LABEL_FINGER_B),
    ]
}

/// The distractor box standing on the table at `placement` (footprint centre, yaw).
fn distractor_part(d: &Distractor, (centre, yaw): ([f64; 2], f64)) -> Part {
    let (s, c) = yaw.sin_cos();
    Part {
        shape: Shape::Cuboid {
            c: V3::new(
                centre[0] as f32,
                centre[1] as f32,
                (0.5 * d.size_mm[2]) as f32,
            ),
            axes: [
                V3::new(c as f32, s as f32, 0.0),
                V3::new(-s as f32, c as f32, 0.0),
                V3::new(0.0, 0.0, 1.0),
            ],
            half: V3::new(
                (0.5 * d.size_mm[0]) as f32,
                (0.5 * d.size_mm[1]) as f32,
                (0.5 * d.size_mm[2]) as f32,
            ),
        },
        label: LABEL_DISTRACTOR,
        albedo: d.albedo as f32,
        specular: 0.25,
    }
}

/// The frame's lighting: global gain and brightness gradients across the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lighting {
    pub gain: f32,
    pub grad_x: f32,
    pub grad_y: f32,
}

/// One camera's renderer with its buffers.
pub(crate) struct CameraView {
    pub camera: Camera,
    background: Option<Background>,
    work: Vec<f32>,
    depth: Vec<f32>,
    pub labels: Vec<u8>,
    column_gain: Vec<f32>,
    /// Pixel rectangle `[u0, v0, u1, v1)` the arm was drawn into last frame (work, depth and
    /// labels differ from the background only there).
    dirty: Option<[usize; 4]>,
    /// Random bits of one row's sensor noise (reused).
    noise_bits: Vec<u32>,
    light: V3,
    origin: V3,
    forward: V3,
    px_per_mm_at_unit: f32,
}

impl CameraView {
    /// A renderer for `camera`; the static background is ray-traced on the first frame.
    pub fn new(camera: Camera, scene: &SceneConfig) -> Self {
        let light = Vector3::from(scene.light_direction).normalize();
        let forward = camera.rotation.row(2).transpose();
        CameraView {
            background: None,
            work: Vec::new(),
            depth: Vec::new(),
            labels: Vec::new(),
            column_gain: vec![0.0; camera.width as usize],
            dirty: None,
            noise_bits: vec![0; camera.width as usize],
            light: v3(&light),
            origin: v3(&camera.centre),
            forward: v3(&forward),
            px_per_mm_at_unit: (0.5 * (camera.fx + camera.fy)) as f32,
            camera,
        }
    }

    fn ensure_background(&mut self, scene: &SceneConfig, g: &ArmGeometry) {
        if self.background.is_none() {
            let bg = Background::render(&self.camera, scene, g);
            let n = bg.radiance.len();
            self.work = bg.radiance.clone();
            self.depth = bg.depth.clone();
            self.labels = vec![0; n];
            self.dirty = None;
            self.background = Some(bg);
        }
    }

    /// Renders the arm in `pose` into a new 8-bit image.
    pub fn render<R: Rng + ?Sized>(
        &mut self,
        g: &ArmGeometry,
        scene: &SceneConfig,
        pose: &ArmPose,
        distractor: Option<(&Distractor, ([f64; 2], f64))>,
        lighting: Lighting,
        rng: &mut R,
    ) -> GrayImage {
        self.ensure_background(scene, g);
        // Restore only what the last frame's arm touched.
        let bg = self.background.as_ref().expect("just ensured");
        if let Some([u0, v0, u1, v1]) = self.dirty.take() {
            let w = self.camera.width as usize;
            for v in v0..v1 {
                let r = v * w + u0..v * w + u1;
                self.work[r.clone()].copy_from_slice(&bg.radiance[r.clone()]);
                self.depth[r.clone()].copy_from_slice(&bg.depth[r.clone()]);
                self.labels[r].fill(0);
            }
        }
        let mut parts = arm_parts(g, scene, pose);
        if let Some((d, placement)) = distractor {
            parts.push(distractor_part(d, placement));
        }
        let centre_distance = |p: &Part| -> f32 {
            let c = match &p.shape {
                Shape::Capsule { a, b, .. } => (a + b) * 0.5,
                Shape::Cuboid { c, .. } => *c,
            };
            (c - self.origin).norm()
        };
        parts.sort_by(|x, y| centre_distance(y).total_cmp(&centre_distance(x)));
        for part in &parts {
            self.draw(scene, part);
        }
        self.composite(scene, lighting, rng)
    }

    /// Pixel bounding box `[u0, u1) × [v0, v1)` of world points (plus `margin` pixels).
    fn bbox(&self, points: &[V3], margin: f64) -> Option<[usize; 4]> {
        let (w, h) = (self.camera.width as f64, self.camera.height as f64);
        let (mut u0, mut v0, mut u1, mut v1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in points {
            let q = Vector3::new(p.x as f64, p.y as f64, p.z as f64);
            match self.camera.project(&q) {
                Ok([u, v]) => {
                    u0 = u0.min(u);
                    u1 = u1.max(u);
                    v0 = v0.min(v);
                    v1 = v1.max(v);
                }
                // A corner behind the camera: fall back to the whole image.
                Err(_) => return Some([0, 0, w as usize, h as usize]),
            }
        }
        let u0 = (u0 - margin).floor().max(0.0);
        let v0 = (v0 - margin).floor().max(0.0);
        let u1 = (u1 + margin).ceil().min(w - 1.0) + 1.0;
        let v1 = (v1 + margin).ceil().min(h - 1.0) + 1.0;
        if u0 >= u1 || v0 >= v1 {
            return None;
        }
        Some([u0 as usize, v0 as usize, u1 as usize, v1 as usize])
    }

    fn shade(&self, scene: &SceneConfig, part: &Part, n: &V3, d: &V3) -> f32 {
        let ambient = scene.ambient as f32;
        let exposure = scene.exposure as f32;
        let diffuse = n.dot(&self.light).max(0.0);
        let half = self.light - d;
        let hn = half.norm();
        let mut spec = if hn > 1e-6 {
            (n.dot(&half) / hn).max(0.0)
        } else {
            0.0
        };
        spec *= spec; // ^2
        spec *= spec; // ^4
        spec *= spec; // ^8
        spec *= spec; // ^16
        exposure * (part.albedo * (ambient + (1.0 - ambient) * diffuse) + part.specular * spec)
    }

    fn draw(&mut self, scene: &SceneConfig, part: &Part) {
        // The background (with the ray table) is moved out while the buffers are written.
        let bg = self.background.take().expect("background rendered");
        match part.shape {
            Shape::Capsule { a, b, r } => self.draw_capsule(scene, part, &bg.rays, a, b, r),
            Shape::Cuboid { c, axes, half } => {
                self.draw_cuboid(scene, part, &bg.rays, c, axes, half)
            }
        }
        self.background = Some(bg);
    }

    fn draw_capsule(
        &mut self,
        scene: &SceneConfig,
        part: &Part,
        rays: &[[f32; 3]],
        a: V3,
        b: V3,
        r: f32,
    ) {
        let rv = V3::new(r, r, r);
        let (lo, hi) = (a.inf(&b) - rv, a.sup(&b) + rv);
        let corners = box_corners(lo, hi);
        let Some([u0, v0, u1, v1]) = self.bbox(&corners, 2.0) else {
            return;
        };
        self.mark_dirty([u0, v0, u1, v1]);
        let mid = (a + b) * 0.5;
        let z_mid = (mid - self.origin).dot(&self.forward).max(1.0);
        let ppm = self.px_per_mm_at_unit / z_mid;
        let o = self.origin;
        let u = b - a;
        let c = u.dot(&u);
        let w0 = o - a;
        let e = u.dot(&w0);
        let width = self.camera.width as usize;
        let r2 = r * r;
        let stadium = self.projected_stadium(a, b, r);
        for v in v0..v1 {
            let (x0, x1) = match &stadium {
                Some(st) => match st.row_span(v as f64) {
                    Some((lo, hi)) => (
                        (lo.floor().max(u0 as f64) as usize).min(u1),
                        // u0 < u1 (`bbox` returns `None` otherwise), so `clamp` cannot panic.
                        ((hi.ceil() + 1.0).max(0.0) as usize).clamp(u0, u1),
                    ),
                    None => continue,
                },
                None => (u0, u1),
            };
            for x in x0..x1 {
                let i = v * width + x;
                let d = V3::from(rays[i]);
                let bb = d.dot(&u);
                let dd = d.dot(&w0);
                let denom = c - bb * bb;
                let s = if denom > 1e-6 * c {
                    ((e - bb * dd) / denom).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let t = s * bb - dd;
                if t <= 0.0 {
                    continue;
                }
                let closest = w0 + d * t - u * s;
                let dist2 = closest.norm_squared();
                let dist = dist2.sqrt();
                let coverage = (0.5 + (r - dist) * ppm).clamp(0.0, 1.0);
                if coverage <= 0.0 {
                    continue;
                }
                let (t_hit, normal) = if dist2 < r2 {
                    let t_hit = t - (r2 - dist2).sqrt();
                    let rel = w0 + d * t_hit;
                    let s2 = (rel.dot(&u) / c).clamp(0.0, 1.0);
                    let n = rel - u * s2;
                    let nn = n.norm();
                    (t_hit, if nn > 0.0 { n / nn } else { -d })
                } else {
                    (t, if dist > 0.0 { closest / dist } else { -d })
                };
                if t_hit >= self.depth[i] {
                    continue;
                }
                let g = self.shade(scene, part, &normal, &d);
                self.blend(i, coverage, g, t_hit, part.label);
            }
        }
    }

    /// The capsule's outline in the image as a 2-D stadium (projected axis, radius enlarged by
    /// the lens's bowing of the axis and a 2-pixel margin), or `None` if an end is behind.
    fn projected_stadium(&self, a: V3, b: V3, r: f32) -> Option<Stadium> {
        let f64v = |p: V3| Vector3::new(p.x as f64, p.y as f64, p.z as f64);
        let (a, b) = (f64v(a), f64v(b));
        let pa = self.camera.project(&a).ok()?;
        let pb = self.camera.project(&b).ok()?;
        let pm = self.camera.project(&((a + b) * 0.5)).ok()?;
        let f = 0.5 * (self.camera.fx + self.camera.fy);
        let radius_at = |p: &Vector3<f64>| {
            let z = self.camera.to_camera(p).z;
            // Radial distortion stretches by at most a few per cent at the border.
            1.1 * r as f64 * f / z
        };
        let bow = {
            let (dx, dy) = (pb[0] - pa[0], pb[1] - pa[1]);
            let l = dx.hypot(dy);
            if l > 1e-9 {
                ((pm[0] - pa[0]) * dy - (pm[1] - pa[1]) * dx).abs() / l
            } else {
                0.0
            }
        };
        Some(Stadium {
            p0: pa,
            p1: pb,
            radius: radius_at(&a).max(radius_at(&b)) + bow + 2.0,
        })
    }

    fn draw_cuboid(
        &mut self,
        scene: &SceneConfig,
        part: &Part,
        rays: &[[f32; 3]],
        c: V3,
        axes: [V3; 3],
        half: V3,
    ) {
        let z_c = (c - self.origin).dot(&self.forward).max(1.0);
        let ppm = self.px_per_mm_at_unit / z_c;
        let margin = 1.0 / ppm;
        let mut corners = [V3::zeros(); 8];
        for (k, corner) in corners.iter_mut().enumerate() {
            let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
            *corner = c
                + axes[0] * (s(1) * half.x)
                + axes[1] * (s(2) * half.y)
                + axes[2] * (s(4) * half.z);
        }
        let Some([u0, v0, u1, v1]) = self.bbox(&corners, 2.0) else {
            return;
        };
        self.mark_dirty([u0, v0, u1, v1]);
        let rel = self.origin - c;
        let ol = V3::new(axes[0].dot(&rel), axes[1].dot(&rel), axes[2].dot(&rel));
        let grown = half.add_scalar(margin);
        let width = self.camera.width as usize;
        for v in v0..v1 {
            for x in u0..u1 {
                let i = v * width + x;
                let d = V3::from(rays[i]);
                let dl = V3::new(axes[0].dot(&d), axes[1].dot(&d), axes[2].dot(&d));
                let Some((tn, tf, _)) = slab(&ol, &dl, &grown) else {
                    continue;
                };
                if tf <= 0.0 {
                    continue;
                }
                let (coverage, t_hit, nl) = match slab(&ol, &dl, &half) {
                    Some((t0, t1, axis)) if t0 > 0.0 && t0 <= t1 => {
                        let mut nl = V3::zeros();
                        nl[axis] = -dl[axis].signum();
                        (1.0, t0, nl)
                    }
                    _ => {
                        // Near miss: minimise the (convex) exterior distance along the ray.
                        let (mut lo, mut hi) = (tn.max(0.0), tf);
                        for _ in 0..12 {
                            let m1 = lo + (hi - lo) / 3.0;
                            let m2 = hi - (hi - lo) / 3.0;
                            if box_distance(&(ol + dl * m1), &half)
                                < box_distance(&(ol + dl * m2), &half)
                            {
                                hi = m2;
                            } else {
                                lo = m1;
                            }
                        }
                        let t = 0.5 * (lo + hi);
                        let p = ol + dl * t;
                        let dist = box_distance(&p, &half);
                        let q = V3::new(
                            (p.x.abs() - half.x).max(0.0) * p.x.signum(),
                            (p.y.abs() - half.y).max(0.0) * p.y.signum(),
                            (p.z.abs() - half.z).max(0.0) * p.z.signum(),
                        );
                        let qn = q.norm();
                        let nl = if qn > 0.0 { q / qn } else { -dl };
                        ((0.5 - dist * ppm).clamp(0.0, 1.0), t, nl)
                    }
                };
                if coverage <= 0.0 || t_hit >= self.depth[i] {
                    continue;
                }
                let normal = axes[0] * nl.x + axes[1] * nl.y + axes[2] * nl.z;
                let g = self.shade(scene, part, &normal, &d);
                self.blend(i, coverage, g, t_hit, part.label);
            }
        }
    }

    fn mark_dirty(&mut self, r: [usize; 4]) {
        self.dirty = Some(match self.dirty {
            None => r,
            Some(d) => [
                d[0].min(r[0]),
                d[1].min(r[1]),
                d[2].max(r[2]),
                d[3].max(r[3]),
            ],
        });
    }

    #[inline]
    fn blend(&mut self, i: usize, coverage: f32, grey: f32, t: f32, label: u8) {
        self.work[i] = coverage * grey + (1.0 - coverage) * self.work[i];
        if coverage >= 0.5 {
            self.depth[i] = t;
            self.labels[i] = label;
        }
    }

    /// Lighting change and sensor noise, quantised to 8 bits.
    fn composite<R: Rng + ?Sized>(
        &mut self,
        scene: &SceneConfig,
        light: Lighting,
        rng: &mut R,
    ) -> GrayImage {
        let (w, h) = (self.camera.width as usize, self.camera.height as usize);
        let (hw, hh) = (0.5 * w as f32, 0.5 * h as f32);
        for (x, g) in self.column_gain.iter_mut().enumerate() {
            *g = light.grad_x * (x as f32 + 0.5 - hw) / hw;
        }
        let sigma = scene.sensor_noise_sigma as f32;
        // Irwin–Hall: the sum of four uniform bytes has mean 510 and std. dev. 147.80.
        let noise_scale = sigma / 147.80;
        let mut out = vec![0u8; w * h];
        let cols = &self.column_gain;
        for y in 0..h {
            let row_gain = light.gain + light.grad_y * (y as f32 + 0.5 - hh) / hh;
            let src = &self.work[y * w..(y + 1) * w];
            let dst = &mut out[y * w..(y + 1) * w];
            if sigma > 0.0 {
                // 32 random bits per pixel, then a branch-free (vectorisable) pass.
                for pair in self.noise_bits.chunks_mut(2) {
                    let bits = rng.next_u64();
                    pair[0] = bits as u32;
                    if let Some(second) = pair.get_mut(1) {
                        *second = (bits >> 32) as u32;
                    }
                }
                for (((d, s), c), &n) in dst.iter_mut().zip(src).zip(cols).zip(&self.noise_bits) {
                    // Sum of the four bytes (SWAR): Irwin–Hall of 4 uniform bytes.
                    let pairs = (n & 0x00FF_00FF) + ((n >> 8) & 0x00FF_00FF);
                    let sum = (pairs & 0xFFFF) + (pairs >> 16);
                    let noise = (sum as f32 - 510.0) * noise_scale;
                    *d = (s * (row_gain + c) + noise + 0.5) as u8;
                }
            } else {
                for ((d, s), c) in dst.iter_mut().zip(src).zip(cols) {
                    *d = (s * (row_gain + c) + 0.5) as u8;
                }
            }
        }
        GrayImage::from_raw(w as u32, h as u32, out).expect("buffer matches size")
    }
}

/// A 2-D capsule (all points within `radius` of the segment `p0 p1`), pixel units.
struct Stadium {
    p0: [f64; 2],
    p1: [f64; 2],
    radius: f64,
}

impl Stadium {
    /// The x-interval of row `y` inside the stadium (the shape is convex, so the hull of the two
    /// end discs' and the band's intervals).
    fn row_span(&self, y: f64) -> Option<(f64, f64)> {
        let r = self.radius;
        let mut span: Option<(f64, f64)> = None;
        let mut join = |lo: f64, hi: f64| {
            if lo <= hi {
                span = Some(span.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
        };
        for p in [self.p0, self.p1] {
            let dy = y - p[1];
            if dy.abs() <= r {
                let h = (r * r - dy * dy).sqrt();
                join(p[0] - h, p[0] + h);
            }
        }
        let (dx, dy) = (self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]);
        let l2 = dx * dx + dy * dy;
        if l2 > 1e-12 {
            let l = l2.sqrt();
            // Perpendicular offset n·(p − p0) in [−r, r] and axis parameter in [0, 1], both
            // linear in x along the row.
            let (nx, ny) = (-dy / l, dx / l);
            let ry = y - self.p0[1];
            let band = linear_range(nx, ny * ry - nx * self.p0[0], -r, r);
            let along = linear_range(dx / l2, (ry * dy - self.p0[0] * dx) / l2, 0.0, 1.0);
            if let (Some((a0, a1)), Some((b0, b1))) = (band, along) {
                join(a0.max(b0), a1.min(b1));
            }
        }
        span
    }
}

/// The x-interval where `lo <= alpha·x + beta <= hi` (unbounded as ±∞).
fn linear_range(alpha: f64, beta: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if alpha.abs() < 1e-12 {
        return (beta >= lo && beta <= hi).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (x0, x1) = ((lo - beta) / alpha, (hi - beta) / alpha);
    Some(if x0 < x1 { (x0, x1) } else { (x1, x0) })
}

fn box_corners(lo: V3, hi: V3) -> [V3; 8] {
    std::array::from_fn(|k| {
        V3::new(
            if k & 1 != 0 { hi.x } else { lo.x },
            if k & 2 != 0 { hi.y } else { lo.y },
            if k & 4 != 0 { hi.z } else { lo.z },
        )
    })
}

/// Slab test of a local-frame ray against the box `|p| ≤ half`: entry, exit and entry axis.
#[inline]
fn slab(o: &V3, d: &V3, half: &V3) -> Option<(f32, f32, usize)> {
    let (mut tn, mut tf) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut axis = 0;
    for k in 0..3 {
        if d[k].abs() < 1e-9 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[k];
        let t1 = (-half[k] - o[k]) * inv;
        let t2 = (half[k] - o[k]) * inv;
        let (a, b) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if a > tn {
            tn = a;
            axis = k;
        }
        tf = tf.min(b);
    }
    (tn <= tf).then_some((tn, tf, axis))
}

/// Distance from a local point to the box `|p| ≤ half` (0 inside).
#[inline]
fn box_distance(p: &V3, half: &V3) -> f32 {
    let q = V3::new(
        (p.x.abs() - half.x).max(0.0),
        (p.y.abs() - half.y).max(0.0),
        (p.z.abs() - half.z).max(0.0),
    );
    q.norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute-force distance from a 2-D point to the segment `p0 p1`.
    fn segment_distance(p: [f64; 2], p0: [f64; 2], p1: [f64; 2]) -> f64 {
        let (dx, dy) = (p1[0] - p0[0], p1[1] - p0[1]);
        let l2 = dx * dx + dy * dy;
        let s = if l2 > 0.0 {
            (((p[0] - p0[0]) * dx + (p[1] - p0[1]) * dy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p[0] - p0[0] - s * dx).hypot(p[1] - p0[1] - s * dy)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, rng_seed: proptest::test_runner::RngSeed::Fixed(2009), ..ProptestConfig::default() })]
        /// The row span is exactly the set of row points within the radius of the segment.
        #[test]
        fn stadium_row_span_matches_brute_force(
            x0 in 0.0f64..100.0, y0 in 0.0f64..100.0,
            x1 in 0.0f64..100.0, y1 in 0.0f64..100.0,
            radius in 0.5f64..20.0, y in -10.0f64..110.0,
        ) {
            let st = Stadium { p0: [x0, y0], p1: [x1, y1], radius };
            let span = st.row_span(y);
            for i in 0..=400 {
                let x = -30.0 + i as f64 * 0.4;
                let d = segment_distance([x, y], st.p0, st.p1);
                let inside = span.is_some_and(|(lo, hi)| x >= lo - 1e-9 && x <= hi + 1e-9);
                if d < radius - 1e-6 {
                    prop_assert!(inside, "x {x}: distance {d} < {radius} but span {span:?}");
                }
                if d > radius + 1e-6 {
                    prop_assert!(!inside, "x {x}: distance {d} > {radius} but span {span:?}");
                }
            }
        }
    }
}
