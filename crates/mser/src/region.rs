//! A detected region: polarity, grey level, size, moments, bounding box and the equivalent ellipse.

use crate::contour::{check_seed, trace_outer_contour};
use crate::error::{MserError, Result};
use crate::image::GrayView;
use crate::pixels::flood_pixels;

/// Whether a region is darker or brighter than its surround.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Polarity {
    /// A connected component of `{p : I(p) ≤ level}` (darker than its surround).
    Dark,
    /// A connected component of `{p : I(p) ≥ level}` (brighter than its surround).
    Bright,
}

impl Polarity {
    /// Whether grey value `g` passes this polarity's threshold at `level`.
    #[inline]
    pub fn contains(self, g: u8, level: u8) -> bool {
        match self {
            Polarity::Dark => g <= level,
            Polarity::Bright => g >= level,
        }
    }
}

/// An axis-aligned bounding box with inclusive pixel bounds: columns `x_min..=x_max`, rows
/// `y_min..=y_max`. The detector's boxes have `x_min ≤ x_max` and `y_min ≤ y_max`; a
/// hand-built box with `x_max < x_min` (or `y_max < y_min`) is inverted and holds no pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BoundingBox {
    /// Leftmost column.
    pub x_min: u32,
    /// Topmost row.
    pub y_min: u32,
    /// Rightmost column (inclusive).
    pub x_max: u32,
    /// Bottom row (inclusive).
    pub y_max: u32,
}

impl BoundingBox {
    /// Width in pixels: the number of columns in `x_min..=x_max`, `x_max − x_min + 1`. In `u64`
    /// because the full `u32` range has 2³² columns; 0 for an inverted box (`x_max < x_min`).
    ///
    /// ```
    /// use mser::BoundingBox;
    /// let b = BoundingBox { x_min: 2, y_min: 1, x_max: 7, y_max: 3 };
    /// assert_eq!((b.width(), b.height()), (6, 3));
    /// let all = BoundingBox { x_min: 0, y_min: 0, x_max: u32::MAX, y_max: u32::MAX };
    /// assert_eq!(all.width(), 1 << 32);
    /// let inverted = BoundingBox { x_min: 8, ..b }; // x_max = 7 < x_min
    /// assert_eq!(inverted.width(), 0);
    /// ```
    pub fn width(&self) -> u64 {
        inclusive_len(self.x_min, self.x_max)
    }

    /// Height in pixels: the number of rows in `y_min..=y_max`, `y_max − y_min + 1`. In `u64`
    /// because the full `u32` range has 2³² rows; 0 for an inverted box (`y_max < y_min`).
    pub fn height(&self) -> u64 {
        inclusive_len(self.y_min, self.y_max)
    }
}

/// The number of integers in `lo..=hi` (0 when `hi < lo`); at most 2³², so no overflow.
fn inclusive_len(lo: u32, hi: u32) -> u64 {
    (u64::from(hi) + 1).saturating_sub(u64::from(lo))
}

/// Raw moments of a pixel set, summed exactly in integers over the pixel centres `(x, y)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Moments {
    /// Number of pixels (the zeroth moment).
    pub n: u64,
    /// Σ x.
    pub sx: u64,
    /// Σ y.
    pub sy: u64,
    /// Σ x².
    pub sxx: u64,
    /// Σ x y.
    pub sxy: u64,
    /// Σ y².
    pub syy: u64,
}

impl Moments {
    /// The moments of a list of pixels. A list whose sums do not fit the `u64` fields (far
    /// beyond any image's regions: e.g. two pixels at `u32::MAX`) is an
    /// [`MserError::InvalidParameter`].
    pub fn of_pixels(pixels: &[(u32, u32)]) -> Result<Self> {
        let mut m = Moments {
            n: 0,
            sx: 0,
            sy: 0,
            sxx: 0,
            sxy: 0,
            syy: 0,
        };
        for &(x, y) in pixels {
            let (x, y) = (x as u64, y as u64);
            let add = |s: u64, v: u64| s.checked_add(v);
            let next = (|| {
                Some(Moments {
                    n: add(m.n, 1)?,
                    sx: add(m.sx, x)?,
                    sy: add(m.sy, y)?,
                    sxx: add(m.sxx, x * x)?,
                    sxy: add(m.sxy, x * y)?,
                    syy: add(m.syy, y * y)?,
                })
            })();
            m = next.ok_or_else(|| MserError::InvalidParameter {
                name: "pixels",
                reason: format!("the moments of {} pixels overflow u64", pixels.len()),
            })?;
        }
        Ok(m)
    }

    /// The moments of the same pixels moved by `(dx, dy)`: `Σ(x+dx) = Σx + n·dx`,
    /// `Σ(x+dx)² = Σx² + 2dx·Σx + n·dx²`, `Σ(x+dx)(y+dy) = Σxy + dy·Σx + dx·Σy + n·dx·dy`.
    /// Errors ([`MserError::InvalidParameter`] `offset`): sums that overflow `u64`.
    pub fn translated(&self, dx: u32, dy: u32) -> Result<Self> {
        let (dx, dy) = (u64::from(dx), u64::from(dy));
        let m = self;
        let next = (|| {
            let mul = u64::checked_mul;
            Some(Moments {
                n: m.n,
                sx: m.sx.checked_add(mul(m.n, dx)?)?,
                sy: m.sy.checked_add(mul(m.n, dy)?)?,
                sxx: m
                    .sxx
                    .checked_add(mul(mul(2, dx)?, m.sx)?)?
                    .checked_add(mul(m.n, mul(dx, dx)?)?)?,
                sxy: m
                    .sxy
                    .checked_add(mul(dy, m.sx)?)?
                    .checked_add(mul(dx, m.sy)?)?
                    .checked_add(mul(m.n, mul(dx, dy)?)?)?,
                syy: m
                    .syy
                    .checked_add(mul(mul(2, dy)?, m.sy)?)?
                    .checked_add(mul(m.n, mul(dy, dy)?)?)?,
            })
        })();
        next.ok_or_else(|| MserError::InvalidParameter {
            name: "offset",
            reason: format!("moments moved by ({dx}, {dy}) overflow u64"),
        })
    }

    /// Centroid `(x̄, ȳ)` (first moments over the area).
    pub fn centroid(&self) -> (f64, f64) {
        let n = self.n as f64;
        (self.sx as f64 / n, self.sy as f64 / n)
    }

    /// Second central moments of the pixel centres `[σxx, σxy, σyy]` (divided by the area), as
    /// VLFeat and OpenCV compute them. Singular for collinear pixels.
    ///
    /// Near the origin the exact integer sums are centred in `f64`, `Σx²/n − x̄²`: the
    /// cancellation costs a few ulps of `x̄²`, under 2⁻¹⁸ pixel² while the centroid lies within
    /// [`EXACT_CENTRING_FROM`] pixels of the origin (every image of the benchmarks). Farther
    /// out, that error grows with `x̄²` (a two-pixel region at x = 2²⁶ came out with σxx = 0
    /// instead of 0.25), so the sums are centred exactly in integers, `(nΣx² − (Σx)²)/n²`, and
    /// rounded once.
    pub fn covariance(&self) -> [f64; 3] {
        let n = self.n as f64;
        let (mx, my) = self.centroid();
        let in_f64 = |sab: u64, ma: f64, mb: f64| sab as f64 / n - ma * mb;
        if mx.max(my) < EXACT_CENTRING_FROM {
            return [
                in_f64(self.sxx, mx, mx),
                in_f64(self.sxy, mx, my),
                in_f64(self.syy, my, my),
            ];
        }
        // Within i128 for any region of an image (n ≤ 2^28: |nΣab| ≤ 2^92, |ΣaΣb| ≤ 2^120);
        // moments built by hand beyond that are centred in f64.
        let n2 = n * n;
        let centred = |sab: u64, sa: u64, sb: u64, ma: f64, mb: f64| {
            let wide = |a: u64, b: u64| i128::from(a).checked_mul(i128::from(b));
            match (wide(self.n, sab), wide(sa, sb)) {
                (Some(p), Some(q)) => (p - q) as f64 / n2,
                _ => in_f64(sab, ma, mb),
            }
        };
        [
            centred(self.sxx, self.sx, self.sx, mx, mx),
            centred(self.sxy, self.sx, self.sy, mx, my),
            centred(self.syy, self.sy, self.sy, my, my),
        ]
    }

    /// Second central moments of the region as a plane figure, the union of its unit pixel
    /// squares: [`covariance`](Self::covariance) plus 1/12 on the diagonal (the variance of a
    /// unit square). Always positive definite.
    pub fn area_covariance(&self) -> [f64; 3] {
        let [xx, xy, yy] = self.covariance();
        [xx + 1.0 / 12.0, xy, yy + 1.0 / 12.0]
    }
}

/// How far from the origin (in pixels, the larger centroid coordinate) [`Moments::covariance`]
/// centres its sums exactly in integers rather than in `f64`.
pub const EXACT_CENTRING_FROM: f64 = 65536.0;

/// An ellipse `a (x − u)² + 2 b (x − u)(y − v) + c (y − v)² = 1`, the convention of the Oxford
/// affine benchmark's region files (docs/methods.md § MSER); `(u, v)` in 0-based pixel coordinates,
/// x right, y down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    /// Centre x.
    pub u: f64,
    /// Centre y.
    pub v: f64,
    /// Coefficient of (x − u)².
    pub a: f64,
    /// Half the coefficient of (x − u)(y − v).
    pub b: f64,
    /// Coefficient of (y − v)².
    pub c: f64,
}

impl Ellipse {
    /// The ellipse `dᵀ (k² Σ)⁻¹ d = 1` of a covariance `Σ = [σxx, σxy, σyy]`: semi-axes `k` times
    /// the standard deviations along the principal axes. `None` if `Σ` is not positive definite,
    /// `k` is not positive, or the centre `(u, v)` or a coefficient is not finite.
    pub fn from_covariance(u: f64, v: f64, cov: [f64; 3], k: f64) -> Option<Self> {
        let [xx, xy, yy] = cov.map(|s| s * k * k);
        let det = xx * yy - xy * xy;
        let finite = [u, v, xx, xy, yy, det].iter().all(|c| c.is_finite());
        if !(finite && det > 0.0 && xx > 0.0 && k > 0.0) {
            return None;
        }
        Some(Ellipse {
            u,
            v,
            a: yy / det,
            b: -xy / det,
            c: xx / det,
        })
    }

    /// Area `π / √(ac − b²)`.
    pub fn area(&self) -> f64 {
        std::f64::consts::PI / (self.a * self.c - self.b * self.b).sqrt()
    }

    /// Semi-axes `(l_max, l_min)`.
    pub fn semi_axes(&self) -> (f64, f64) {
        let tr = self.a + self.c;
        let det = self.a * self.c - self.b * self.b;
        let disc = (0.25 * (self.a - self.c).powi(2) + self.b * self.b).sqrt();
        let l1 = 0.5 * tr + disc; // larger eigenvalue
        let l2 = det / l1;
        (1.0 / l2.sqrt(), 1.0 / l1.sqrt())
    }

    /// Whether `(x, y)` lies strictly inside (`dᵀ M d < 1`, as the benchmark code tests).
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (dx, dy) = (x - self.u, y - self.v);
        self.a * dx * dx + 2.0 * self.b * dx * dy + self.c * dy * dy < 1.0
    }
}

/// One maximally stable extremal region.
///
/// The region is the connected component (4-neighbourhood) of `{p : I(p) ≤ level}` (dark) or
/// `{p : I(p) ≥ level}` (bright) that contains `seed`. Its pixels and contour are not stored; they
/// are recomputed from the image on demand in time proportional to the area and the perimeter.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Darker or brighter than the surround.
    pub polarity: Polarity,
    /// The threshold at which the region is the component: the largest (dark) or smallest
    /// (bright) grey value inside it.
    pub level: u8,
    /// The region's first pixel in raster order (topmost row, then leftmost column).
    pub seed: (u32, u32),
    /// Number of pixels.
    pub area: u32,
    /// The stability measure `v` of the region (see [`Variation`](crate::Variation)).
    pub variation: f64,
    /// Inclusive bounding box.
    pub bbox: BoundingBox,
    /// Exact raw moments.
    pub moments: Moments,
}

impl Region {
    /// The region as found in a window of a larger image whose top-left pixel is `(dx, dy)`
    /// there, in the larger image's coordinates: seed, bounding box and moments moved (level,
    /// area and stability unchanged). Its pixels and contour are then those of the larger image
    /// ([`pixels`](Self::pixels) and [`contour`](Self::contour) on it).
    /// Errors ([`MserError::InvalidParameter`] `offset`): coordinates or moments that overflow.
    pub fn translated(&self, dx: u32, dy: u32) -> Result<Region> {
        let overflow = || MserError::InvalidParameter {
            name: "offset",
            reason: format!("a region moved by ({dx}, {dy}) leaves the u32 coordinates"),
        };
        let x = |v: u32| v.checked_add(dx).ok_or_else(overflow);
        let y = |v: u32| v.checked_add(dy).ok_or_else(overflow);
        Ok(Region {
            seed: (x(self.seed.0)?, y(self.seed.1)?),
            bbox: BoundingBox {
                x_min: x(self.bbox.x_min)?,
                y_min: y(self.bbox.y_min)?,
                x_max: x(self.bbox.x_max)?,
                y_max: y(self.bbox.y_max)?,
            },
            moments: self.moments.translated(dx, dy)?,
            ..self.clone()
        })
    }

    /// Centroid `(x̄, ȳ)`.
    pub fn centroid(&self) -> (f64, f64) {
        self.moments.centroid()
    }

    /// The equivalent ellipse in the Oxford `(u, v, a, b, c)` convention: centred on the centroid,
    /// with the second moments of the region as a union of unit pixel squares
    /// ([`Moments::area_covariance`], Σ), scaled as the uniformly filled ellipse with those moments:
    /// `M = (4Σ)⁻¹`, semi-axes twice the standard deviations, so its area is close to the region's
    /// (equal for elliptical regions). Use [`ellipse_scaled`](Self::ellipse_scaled)`(1.0)` for
    /// VLFeat/VLBenchmarks frames (`M = Σ⁻¹`, half the size).
    ///
    /// Errors ([`MserError::InvalidParameter`] `region`): moments no pixel set has — a hand-built
    /// region with no pixels (`n = 0`), or sums whose covariance is not positive definite. A
    /// region from the detector always has an ellipse.
    pub fn ellipse(&self) -> Result<Ellipse> {
        self.ellipse_scaled(2.0)
    }

    /// The ellipse `M = (k² Σ)⁻¹` with Σ the region's [`Moments::area_covariance`]. `k = 2` is
    /// [`ellipse`](Self::ellipse); `k = 1` the moment ellipse of VLFeat.
    ///
    /// Errors ([`MserError::InvalidParameter`]): `k` not finite and positive, or so small or
    /// large that `k² Σ` underflows to a singular matrix or overflows (`k`); moments no pixel set
    /// has (`region`, as [`ellipse`](Self::ellipse)).
    ///
    /// ```
    /// # use mser::{GrayView, Mser, MserParams};
    /// let mut px = vec![0u8; 20 * 20];
    /// for y in 5..12 { for x in 4..15 { px[y * 20 + x] = 200; } }
    /// let img = GrayView::new(&px, 20, 20, 20).unwrap();
    /// let r = &Mser::new(MserParams::default()).unwrap().detect(&img).unwrap()[0];
    /// assert_eq!(r.ellipse_scaled(2.0).unwrap(), r.ellipse().unwrap());
    /// assert!(r.ellipse_scaled(0.0).is_err() && r.ellipse_scaled(1e-200).is_err());
    /// ```
    pub fn ellipse_scaled(&self, k: f64) -> Result<Ellipse> {
        if !(k.is_finite() && k > 0.0) {
            return Err(MserError::InvalidParameter {
                name: "k",
                reason: format!("the ellipse scale {k} must be a finite positive number"),
            });
        }
        let (u, v) = self.centroid();
        let cov = self.moments.area_covariance();
        if Ellipse::from_covariance(u, v, cov, 1.0).is_none() {
            return Err(MserError::InvalidParameter {
                name: "region",
                reason: format!(
                    "moments {:?} are not those of a pixel set (no pixels, or a covariance that \
                     is not positive definite)",
                    self.moments
                ),
            });
        }
        Ellipse::from_covariance(u, v, cov, k).ok_or_else(|| MserError::InvalidParameter {
            name: "k",
            reason: format!(
                "the ellipse scale {k} makes k²Σ singular or infinite in floating point"
            ),
        })
    }

    /// The region's pixels `(x, y)` in raster order, recomputed by a flood fill from the seed.
    /// `img` must be the image the region was detected in.
    pub fn pixels(&self, img: &GrayView) -> Result<Vec<(u32, u32)>> {
        check_seed(img, self.seed, self.level, self.polarity)?;
        let px = flood_pixels(img, self.seed, self.level, self.polarity, self.bbox)?;
        if px.len() != self.area as usize {
            return Err(MserError::RegionImageMismatch {
                reason: "flood fill from the seed does not give the region's area",
            });
        }
        Ok(px)
    }

    /// The outer contour: a closed, ordered list of region pixels `(x, y)`, each with a
    /// non-region 4-neighbour, consecutive points (and last to first) 8-adjacent, running once
    /// along the whole boundary between the region and the outside, counter-clockwise as seen on
    /// screen (x right, y down; the shoelace sum `Σ x_i y_{i+1} − x_{i+1} y_i` is ≤ 0: negative
    /// for a region with an interior, 0 for a one-pixel-wide one, which the chain retraces),
    /// starting at [`seed`](Self::seed). Holes are not part of it. A pixel is listed again when
    /// the boundary passes it twice (one-pixel-wide parts); the first point is not repeated at the
    /// end, and a one-pixel region gives one point.
    /// `img` must be the image the region was detected in.
    pub fn contour(&self, img: &GrayView) -> Result<Vec<(u32, u32)>> {
        trace_outer_contour(img, self.seed, self.level, self.polarity)
    }

    /// [`contour`](Self::contour) as `f64` points, the form `fd-match` consumes.
    pub fn contour_f64(&self, img: &GrayView) -> Result<Vec<(f64, f64)>> {
        Ok(self
            .contour(img)?
            .into_iter()
            .map(|(x, y)| (x as f64, y as f64))
            .collect())
    }
}
