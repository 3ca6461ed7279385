//! Synthetic sequences, used when no data folder exists: a planar scene of shapes (ellipses,
//! rotated rectangles, triangles, stars) with flat, striped and gradient fills on a smoothly
//! textured background, seen through known random homographies (seeded), with a brightness
//! change (gain and offset) and Gaussian noise per image. The scene is a continuous function of
//! plane coordinates; img1 samples it on the pixel grid and imgK at `H1toK⁻¹(x, y)`, each pixel
//! the mean of 3×3 sub-samples, so the ground truth is exact.
//!
//! The homographies are stored scaled by a random factor of either sign (as leuven's are), so
//! the pipeline's independence of h33 is exercised too.

use std::f64::consts::PI;

use image::GrayImage;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::sequence::{Protocol, Sequence, Source};
use visguide::Homography;

/// Generator settings.
#[derive(Debug, Clone)]
pub struct SyntheticSpec {
    /// Sequence name.
    pub name: String,
    /// Image width and height.
    pub size: (u32, u32),
    /// Number of shapes in the scene.
    pub shapes: usize,
    /// Number of images (img1 plus warped views).
    pub images: usize,
    /// Largest rotation of a view, radians.
    pub max_rotation: f64,
    /// Scale range of a view.
    pub scale: (f64, f64),
    /// Largest perspective coefficient (h31, h32) times the image width.
    pub perspective: f64,
    /// Gain range of the brightness change.
    pub gain: (f64, f64),
    /// Largest offset of the brightness change, grey levels.
    pub offset: f64,
    /// Noise standard deviation, grey levels.
    pub noise: f64,
    /// Seed of every random draw.
    pub seed: u64,
}

impl Default for SyntheticSpec {
    /// 480×360 images, 60 shapes, img1 + 3 views (rotation up to 20°, scale 0.8–1.25, mild
    /// perspective), gain 0.75–1.15, offset ±15, noise σ = 2.
    fn default() -> Self {
        SyntheticSpec {
            name: "synthetic".into(),
            size: (480, 360),
            shapes: 60,
            images: 4,
            max_rotation: 20f64.to_radians(),
            scale: (0.8, 1.25),
            perspective: 0.12,
            gain: (0.75, 1.15),
            offset: 15.0,
            noise: 2.0,
            seed: 2009,
        }
    }
}

#[derive(Debug, Clone)]
enum Outline {
    Ellipse { rx: f64, ry: f64 },
    Rectangle { hw: f64, hh: f64 },
    Polygon(Vec<(f64, f64)>),
}

#[derive(Debug, Clone)]
enum Fill {
    Flat(f64),
    Stripes {
        base: f64,
        amp: f64,
        freq: f64,
        dir: f64,
    },
    Gradient {
        base: f64,
        slope: f64,
        dir: f64,
    },
}

#[derive(Debug, Clone)]
struct Shape {
    cx: f64,
    cy: f64,
    angle: f64,
    outline: Outline,
    fill: Fill,
}

fn point_in_polygon(p: &[(f64, f64)], x: f64, y: f64) -> bool {
    let mut inside = false;
    let n = p.len();
    for i in 0..n {
        let (a, b) = (p[i], p[(i + 1) % n]);
        if (a.1 > y) != (b.1 > y) && x < a.0 + (y - a.1) * (b.0 - a.0) / (b.1 - a.1) {
            inside = !inside;
        }
    }
    inside
}

impl Shape {
    fn value(&self, x: f64, y: f64) -> Option<f64> {
        let (s, c) = self.angle.sin_cos();
        let (dx, dy) = (x - self.cx, y - self.cy);
        let (lx, ly) = (c * dx + s * dy, -s * dx + c * dy);
        let inside = match &self.outline {
            Outline::Ellipse { rx, ry } => (lx / rx).powi(2) + (ly / ry).powi(2) <= 1.0,
            Outline::Rectangle { hw, hh } => lx.abs() <= *hw && ly.abs() <= *hh,
            Outline::Polygon(p) => point_in_polygon(p, lx, ly),
        };
        inside.then(|| match self.fill {
            Fill::Flat(v) => v,
            Fill::Stripes {
                base,
                amp,
                freq,
                dir,
            } => base + amp * (freq * (lx * dir.cos() + ly * dir.sin())).sin().signum(),
            Fill::Gradient { base, slope, dir } => base + slope * (lx * dir.cos() + ly * dir.sin()),
        })
    }
}

/// The continuous scene.
#[derive(Debug, Clone)]
struct Scene {
    shapes: Vec<Shape>,
    waves: Vec<(f64, f64, f64, f64)>,
}

impl Scene {
    fn random(spec: &SyntheticSpec, rng: &mut Xoshiro256PlusPlus) -> Self {
        let (w, h) = (spec.size.0 as f64, spec.size.1 as f64);
        let waves = (0..4)
            .map(|_| {
                (
                    rng.random_range(6.0..14.0),
                    rng.random_range(0.005..0.02),
                    rng.random_range(0.0..2.0 * PI),
                    rng.random_range(0.0..2.0 * PI),
                )
            })
            .collect();
        let mut shapes = Vec::with_capacity(spec.shapes);
        for _ in 0..spec.shapes {
            let size = rng.random_range(6.0..28.0);
            let outline = match rng.random_range(0..4) {
                0 => Outline::Ellipse {
                    rx: size,
                    ry: size * rng.random_range(0.35..1.0),
                },
                1 => Outline::Rectangle {
                    hw: size,
                    hh: size * rng.random_range(0.3..1.0),
                },
                2 => Outline::Polygon(
                    (0..3)
                        .map(|k| {
                            let a = 2.0 * PI * k as f64 / 3.0 + rng.random_range(-0.4..0.4);
                            let r = size * rng.random_range(0.7..1.2);
                            (r * a.cos(), r * a.sin())
                        })
                        .collect(),
                ),
                _ => {
                    let arms = rng.random_range(4..8);
                    let inner = rng.random_range(0.4..0.7);
                    Outline::Polygon(
                        (0..2 * arms)
                            .map(|k| {
                                let a = PI * k as f64 / arms as f64;
                                let r = if k % 2 == 0 { size } else { size * inner };
                                (r * a.cos(), r * a.sin())
                            })
                            .collect(),
                    )
                }
            };
            let dark = rng.random_bool(0.5);
            let base = if dark {
                rng.random_range(15.0..75.0)
            } else {
                rng.random_range(180.0..240.0)
            };
            let fill = match rng.random_range(0..5) {
                0 => Fill::Stripes {
                    base,
                    amp: rng.random_range(10.0..25.0),
                    freq: rng.random_range(0.3..0.6),
                    dir: rng.random_range(0.0..PI),
                },
                1 => Fill::Gradient {
                    base,
                    slope: rng.random_range(-1.0..1.0),
                    dir: rng.random_range(0.0..PI),
                },
                _ => Fill::Flat(base),
            };
            let margin = 1.5 * size + 10.0;
            shapes.push(Shape {
                cx: rng.random_range(margin..w - margin),
                cy: rng.random_range(margin..h - margin),
                angle: rng.random_range(0.0..2.0 * PI),
                outline,
                fill,
            });
        }
        Scene { shapes, waves }
    }

    fn value(&self, x: f64, y: f64) -> f64 {
        // Later shapes are on top.
        for s in self.shapes.iter().rev() {
            if let Some(v) = s.value(x, y) {
                return v;
            }
        }
        let mut v = 128.0;
        for &(amp, freq, dir, phase) in &self.waves {
            v += amp * (freq * (x * dir.cos() + y * dir.sin()) + phase).sin();
        }
        v
    }
}

/// A random view homography about the image centre: rotation, anisotropic scale, shear,
/// perspective and a small translation.
fn random_view(spec: &SyntheticSpec, rng: &mut Xoshiro256PlusPlus) -> Homography {
    use nalgebra::Matrix3;
    let (w, h) = (spec.size.0 as f64, spec.size.1 as f64);
    let (cx, cy) = (w / 2.0, h / 2.0);
    let theta = rng.random_range(-spec.max_rotation..=spec.max_rotation);
    let s = rng.random_range(spec.scale.0..=spec.scale.1);
    let aniso = rng.random_range(0.9..1.1);
    let shear = rng.random_range(-0.1..0.1);
    let (sn, cs) = theta.sin_cos();
    let p = spec.perspective / w;
    let a = Matrix3::new(
        s * aniso * cs,
        -s * sn + shear,
        0.0,
        s * sn,
        s / aniso * cs,
        0.0,
        rng.random_range(-p..=p),
        rng.random_range(-p..=p),
        1.0,
    );
    let t = |x: f64, y: f64| Matrix3::new(1.0, 0.0, x, 0.0, 1.0, y, 0.0, 0.0, 1.0);
    let shift = (
        rng.random_range(-0.05..0.05) * w,
        rng.random_range(-0.05..0.05) * h,
    );
    let m = t(cx + shift.0, cy + shift.1) * a * t(-cx, -cy);
    // Store with a random scale of either sign, as the benchmark's files may be.
    let k = rng.random_range(0.5..2.0) * if rng.random_bool(0.5) { -1.0 } else { 1.0 };
    let v: Vec<f64> = m.transpose().iter().map(|x| x * k).collect();
    Homography::from_row_major(&v).expect("a view homography is regular")
}

fn render(
    scene: &Scene,
    spec: &SyntheticSpec,
    to_scene: Option<&Homography>,
    gain: f64,
    offset: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> GrayImage {
    const SUB: usize = 3;
    let noise = Normal::new(0.0, spec.noise).expect("finite σ");
    let (w, h) = spec.size;
    let mut img = GrayImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let px = x as f64 + (sx as f64 + 0.5) / SUB as f64 - 0.5;
                    let py = y as f64 + (sy as f64 + 0.5) / SUB as f64 - 0.5;
                    let (qx, qy) = match to_scene {
                        Some(hm) => hm.map(px, py).unwrap_or((-1e9, -1e9)),
                        None => (px, py),
                    };
                    acc += scene.value(qx, qy);
                }
            }
            let v = gain * acc / (SUB * SUB) as f64 + offset + noise.sample(rng);
            img.put_pixel(x, y, image::Luma([v.round().clamp(0.0, 255.0) as u8]));
        }
    }
    img
}

/// Generates a sequence from `spec`; equal specs give identical sequences.
pub fn generate(spec: &SyntheticSpec) -> Sequence {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(spec.seed);
    let scene = Scene::random(spec, &mut rng);
    let mut images = vec![render(&scene, spec, None, 1.0, 0.0, &mut rng)];
    let mut homographies = Vec::new();
    for _ in 1..spec.images {
        let h = random_view(spec, &mut rng);
        let gain = rng.random_range(spec.gain.0..=spec.gain.1);
        let offset = rng.random_range(-spec.offset..=spec.offset);
        images.push(render(
            &scene,
            spec,
            Some(&h.inverse()),
            gain,
            offset,
            &mut rng,
        ));
        homographies.push(h);
    }
    Sequence {
        name: spec.name.clone(),
        images,
        homographies,
        source: Source::Synthetic,
        protocol: Protocol::Accumulated,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SyntheticSpec {
        SyntheticSpec {
            size: (160, 120),
            shapes: 8,
            images: 3,
            ..SyntheticSpec::default()
        }
    }

    #[test]
    fn deterministic_for_a_seed_and_different_for_another() {
        let (a, b) = (generate(&small()), generate(&small()));
        assert_eq!(a.images, b.images);
        assert_eq!(a.homographies, b.homographies);
        let c = generate(&SyntheticSpec { seed: 7, ..small() });
        assert_ne!(a.images[0], c.images[0]);
        assert_eq!((a.images.len(), a.homographies.len()), (3, 2));
        assert_eq!(a.source, Source::Synthetic);
    }

    #[test]
    fn views_are_the_scene_warped_by_their_homography() {
        // Without noise and brightness change, img2 at H(p) equals img1 at p up to
        // interpolation at edges: compare on the bulk of pixels.
        let spec = SyntheticSpec {
            noise: 0.0,
            gain: (1.0, 1.0),
            offset: 0.0,
            ..small()
        };
        let s = generate(&spec);
        let h = &s.homographies[0];
        let (mut same, mut total) = (0, 0);
        for y in (10..110).step_by(3) {
            for x in (10..150).step_by(3) {
                let Some((u, v)) = h.map(x as f64, y as f64) else {
                    continue;
                };
                let (ui, vi) = (u.round(), v.round());
                if ui < 0.0 || vi < 0.0 || ui >= 160.0 || vi >= 120.0 {
                    continue;
                }
                total += 1;
                let a = s.images[0].get_pixel(x, y)[0] as i32;
                let b = s.images[1].get_pixel(ui as u32, vi as u32)[0] as i32;
                same += ((a - b).abs() <= 12) as usize;
            }
        }
        assert!(total > 300, "{total}");
        assert!(same as f64 > 0.85 * total as f64, "{same}/{total}");
    }
}
