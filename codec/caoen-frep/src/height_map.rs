//! Perturbation by a height map (the perturbation-function paper): `F = G + h(u, v)`,
//! a base solid `G >= 0` (a plane's lower side, an ellipsoid, a cylinder) raised by
//! heights read from an image over a rectangle of the base's parameters `(u, v)`, zero
//! outside it. Heights between the image's samples are interpolated bilinearly or
//! bicubically (Catmull-Rom, which passes through the samples); a threshold `T` keeps
//! only `h >= T` (the rest is 0), which gives a non-rectangular outline.
//!
//! | base | `G` | `(u, v)` |
//! |---|---|---|
//! | plane | `-z` (below `z = 0`) | `(x, y)` |
//! | ellipsoid (semi-axes `a, b, c`) | `1 - (x/a)^2 - (y/b)^2 - (z/c)^2` | longitude `atan2(y/b, x/a)`, latitude `atan2(z/c, sqrt((x/a)^2 + (y/b)^2))` |
//! | cylinder (radius `r`, axis z) | `1 - (x^2 + y^2) / r^2` | angle `atan2(y, x)`, height `z` |
//!
//! Image column 0 is `u0`, the last `u1`; row 0 (the top) is `v1`, the last row `v0`.
//! The gradient is exact: `grad G + h_u grad u + h_v grad v`. The bound over a box uses
//! the range of `(u, v)` over the box and a min/max pyramid of the samples.

use std::f64::consts::PI;
use std::sync::Arc;

use super::interval::{Aabb, Interval};

/// The base solid a height map perturbs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Base {
    /// The half-space below `z = 0`.
    Plane,
    /// An ellipsoid at the origin with these semi-axes.
    Ellipsoid([f64; 3]),
    /// An infinite cylinder around the z axis with this radius.
    Cylinder(f64),
}

/// How heights between samples are interpolated (`"bilinear"`, the default, or
/// `"bicubic"` in a model file).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interp {
    /// Bilinear: continuous, exact at the samples, bounded by them.
    #[default]
    Bilinear,
    /// Catmull-Rom bicubic: C1, exact at the samples, may overshoot them a little.
    Bicubic,
}

/// One pyramid level: width, height, and (min, max) per block.
type Level = (usize, usize, Vec<(f64, f64)>);

/// Bytes a sample keeps: its value (8) and its min/max pair in the pyramid's first
/// level (16) and the levels above (16/3).
pub const SAMPLE_BYTES: u64 = 30;

/// Samples with a min/max pyramid for range queries.
#[derive(Debug, PartialEq)]
struct Samples {
    width: usize,
    height: usize,
    values: Vec<f64>,
    /// Level `k` holds the min and max of blocks of `2^k x 2^k` samples.
    pyramid: Vec<Level>,
    /// The memory budget's count of the above, while they live.
    held: caoen_base::budget::Reservation,
}

/// A handle on a map's samples that does not keep them alive: maps of the same image
/// share one copy while any of them lives.
#[derive(Debug, Clone, Default)]
pub struct SamplesHandle(std::sync::Weak<Samples>);

impl SamplesHandle {
    /// Whether the samples are still alive.
    pub fn is_alive(&self) -> bool {
        self.0.strong_count() > 0
    }
}

impl Samples {
    fn new(
        width: usize,
        height: usize,
        values: Vec<f64>,
        held: caoen_base::budget::Reservation,
    ) -> Self {
        let mut pyramid = vec![(
            width,
            height,
            values.iter().map(|v| (*v, *v)).collect::<Vec<_>>(),
        )];
        while {
            let (w, h, _) = pyramid.last().expect("level 0");
            *w > 1 || *h > 1
        } {
            let (w, h, prev) = pyramid.last().expect("level 0");
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let mut next = Vec::with_capacity(nw * nh);
            for j in 0..nh {
                for i in 0..nw {
                    let mut m = (f64::INFINITY, f64::NEG_INFINITY);
                    for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (x, y) = ((2 * i + di).min(w - 1), (2 * j + dj).min(h - 1));
                        let p = prev[y * w + x];
                        m = (m.0.min(p.0), m.1.max(p.1));
                    }
                    next.push(m);
                }
            }
            pyramid.push((nw, nh, next));
        }
        Samples {
            width,
            height,
            values,
            pyramid,
            held,
        }
    }

    fn at(&self, i: i64, j: i64) -> f64 {
        let i = i.clamp(0, self.width as i64 - 1) as usize;
        let j = j.clamp(0, self.height as i64 - 1) as usize;
        self.values[j * self.width + i]
    }

    /// Min and max of the samples in columns `i0..=i1`, rows `j0..=j1` (clamped), by
    /// the pyramid level where the block spans at most two entries per side.
    fn range(&self, i0: i64, i1: i64, j0: i64, j1: i64) -> (f64, f64) {
        let c = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let (i0, i1) = (c(i0, self.width), c(i1, self.width));
        let (j0, j1) = (c(j0, self.height), c(j1, self.height));
        let span = (i1 - i0).max(j1 - j0) + 1;
        let level = (usize::BITS - span.leading_zeros()).saturating_sub(1) as usize;
        let level = level.min(self.pyramid.len() - 1);
        let (w, _, m) = &self.pyramid[level];
        let mut out = (f64::INFINITY, f64::NEG_INFINITY);
        for j in (j0 >> level)..=(j1 >> level) {
            for i in (i0 >> level)..=(i1 >> level) {
                let p = m[j * w + i];
                out = (out.0.min(p.0), out.1.max(p.1));
            }
        }
        out
    }
}

/// A height map on a base solid.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    base: Base,
    /// `[u0, v0, u1, v1]`.
    rect: [f64; 4],
    threshold: f64,
    interp: Interp,
    samples: Arc<Samples>,
    /// The image file the samples came from and the height of white, for exports.
    source: Option<(std::path::PathBuf, f64)>,
}

/// Bilinear interpolation of a cell's corner heights (as [`HeightMap::corners`] gives
/// them) at `(tx, ty)` within it.
fn bilinear((a, b, c, d): (f64, f64, f64, f64), tx: f64, ty: f64) -> f64 {
    a * (1.0 - tx) * (1.0 - ty) + b * tx * (1.0 - ty) + c * (1.0 - tx) * ty + d * tx * ty
}

/// Catmull-Rom weights and their derivatives at `t` in [0, 1].
fn catmull_rom(t: f64) -> ([f64; 4], [f64; 4]) {
    let (t2, t3) = (t * t, t * t * t);
    (
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ],
        [
            0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
            0.5 * (9.0 * t2 - 10.0 * t),
            0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
            0.5 * (3.0 * t2 - 2.0 * t),
        ],
    )
}

/// Why samples cannot make a height map.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeightMapError {
    /// Fewer than 2x2 samples, or not `width * height` of them.
    #[error("{width}x{height} samples ({values} values): need at least 2x2")]
    Samples {
        /// Samples per row.
        width: usize,
        /// Rows.
        height: usize,
        /// Values given.
        values: usize,
    },
    /// The parameter rectangle is empty, inverted or not finite.
    #[error("rectangle {rect:?}: need u0 < u1 and v0 < v1")]
    Rect {
        /// `[u0, v0, u1, v1]`.
        rect: [f64; 4],
    },
    /// The samples do not fit the memory budget.
    #[error("{source}")]
    OverBudget {
        /// The budget check.
        source: caoen_base::budget::OverBudget,
    },
    /// A height is not finite, or the threshold is NaN or +infinity.
    #[error("heights must be finite and the threshold below infinity")]
    NotFinite,
}

impl HeightMap {
    /// A height map of `width x height` samples (row 0 at `v1`) over `rect`
    /// (`[u0, v0, u1, v1]`, `u0 < u1`, `v0 < v1`) of `base`'s parameters.
    pub fn new(
        base: Base,
        rect: [f64; 4],
        (width, height): (usize, usize),
        values: Vec<f64>,
        threshold: f64,
        interp: Interp,
        limits: &caoen_base::budget::Limits,
    ) -> Result<Self, HeightMapError> {
        if width < 2 || height < 2 || values.len() != width * height {
            return Err(HeightMapError::Samples {
                width,
                height,
                values: values.len(),
            });
        }
        if !(rect[0] < rect[2] && rect[1] < rect[3]) || rect.iter().any(|v| !v.is_finite()) {
            return Err(HeightMapError::Rect { rect });
        }
        if values.iter().any(|v| !v.is_finite()) || threshold.is_nan() || threshold == f64::INFINITY
        {
            return Err(HeightMapError::NotFinite);
        }
        let held = limits
            .reserve(
                || format!("a {width}x{height} height map"),
                caoen_base::budget::bytes(width as u64, height as u64, SAMPLE_BYTES),
            )
            .map_err(|source| HeightMapError::OverBudget { source })?;
        Ok(HeightMap {
            base,
            rect,
            threshold,
            interp,
            samples: Arc::new(Samples::new(width, height, values, held)),
            source: None,
        })
    }

    /// A handle on this map's samples, for [`HeightMap::from_shared`].
    pub fn samples_handle(&self) -> SamplesHandle {
        SamplesHandle(Arc::downgrade(&self.samples))
    }

    /// A map on the samples behind `handle` (no copy), if they are still alive.
    pub fn from_shared(
        base: Base,
        rect: [f64; 4],
        handle: &SamplesHandle,
        threshold: f64,
        interp: Interp,
    ) -> Option<Result<Self, HeightMapError>> {
        let samples = handle.0.upgrade()?;
        if !(rect[0] < rect[2] && rect[1] < rect[3]) || rect.iter().any(|v| !v.is_finite()) {
            return Some(Err(HeightMapError::Rect { rect }));
        }
        if threshold.is_nan() || threshold == f64::INFINITY {
            return Some(Err(HeightMapError::NotFinite));
        }
        Some(Ok(HeightMap {
            base,
            rect,
            threshold,
            interp,
            samples,
            source: None,
        }))
    }

    /// The same map, remembering the image file it was read from and the height of
    /// white (grey level 1), so an exporter can name the file instead of the samples.
    pub fn with_source(self, path: std::path::PathBuf, scale: f64) -> Self {
        HeightMap {
            source: Some((path, scale)),
            ..self
        }
    }

    /// The image file and the height of white, if the map was read from a file.
    pub fn source(&self) -> Option<(&std::path::Path, f64)> {
        self.source.as_ref().map(|(p, s)| (p.as_path(), *s))
    }

    /// The sample grid's size.
    pub fn size(&self) -> (usize, usize) {
        (self.samples.width, self.samples.height)
    }

    /// The sample at column `i`, row `j`.
    pub fn sample(&self, i: usize, j: usize) -> f64 {
        self.samples.values[j * self.samples.width + i]
    }

    /// The parameter point of sample `(i, j)`.
    pub fn sample_uv(&self, i: usize, j: usize) -> [f64; 2] {
        let [u0, v0, u1, v1] = self.rect;
        let (w, h) = self.size();
        [
            u0 + (u1 - u0) * i as f64 / (w - 1) as f64,
            v1 - (v1 - v0) * j as f64 / (h - 1) as f64,
        ]
    }

    /// The base, rectangle, threshold and interpolation.
    pub fn parts(&self) -> (Base, [f64; 4], f64, Interp) {
        (self.base, self.rect, self.threshold, self.interp)
    }

    /// Grid coordinates of a parameter point (column, row), or None outside the rectangle.
    fn grid(&self, uv: [f64; 2]) -> Option<(f64, f64)> {
        let [u0, v0, u1, v1] = self.rect;
        if !(uv[0] >= u0 && uv[0] <= u1 && uv[1] >= v0 && uv[1] <= v1) {
            return None;
        }
        let (w, h) = self.size();
        Some((
            (uv[0] - u0) / (u1 - u0) * (w - 1) as f64,
            (v1 - uv[1]) / (v1 - v0) * (h - 1) as f64,
        ))
    }

    /// The grid cell holding grid position `(gx, gy)`: its corner `(i, j)` (the last
    /// cell for positions on the far edges) and the position within it.
    fn cell(&self, gx: f64, gy: f64) -> (i64, i64, f64, f64) {
        let (w, h) = self.size();
        let (i, j) = (
            (gx.floor() as i64).min(w as i64 - 2),
            (gy.floor() as i64).min(h as i64 - 2),
        );
        (i, j, gx - i as f64, gy - j as f64)
    }

    /// The heights at the corners of cell `(i, j)`: `(i, j)`, `(i + 1, j)`, `(i, j + 1)`,
    /// `(i + 1, j + 1)`.
    fn corners(&self, i: i64, j: i64) -> (f64, f64, f64, f64) {
        let s = &self.samples;
        (
            s.at(i, j),
            s.at(i + 1, j),
            s.at(i, j + 1),
            s.at(i + 1, j + 1),
        )
    }

    /// The interpolated height (before the threshold) and its derivatives in u and v.
    pub fn height(&self, uv: [f64; 2]) -> (f64, f64, f64) {
        let Some((gx, gy)) = self.grid(uv) else {
            return (0.0, 0.0, 0.0);
        };
        let [u0, v0, u1, v1] = self.rect;
        let (w, h) = self.size();
        // d(grid)/d(u) and d(grid)/d(v).
        let (sx, sy) = ((w - 1) as f64 / (u1 - u0), -((h - 1) as f64) / (v1 - v0));
        let (i, j, tx, ty) = self.cell(gx, gy);
        let s = &self.samples;
        let (v, dx, dy) = match self.interp {
            Interp::Bilinear => {
                let (a, b, c, d) = self.corners(i, j);
                (
                    bilinear((a, b, c, d), tx, ty),
                    (b - a) * (1.0 - ty) + (d - c) * ty,
                    (c - a) * (1.0 - tx) + (d - b) * tx,
                )
            }
            Interp::Bicubic => {
                let (wx, dwx) = catmull_rom(tx);
                let (wy, dwy) = catmull_rom(ty);
                let (mut v, mut dx, mut dy) = (0.0, 0.0, 0.0);
                for (b, (yw, ydw)) in wy.iter().zip(dwy).enumerate() {
                    for (a, (xw, xdw)) in wx.iter().zip(dwx).enumerate() {
                        let p = s.at(i - 1 + a as i64, j - 1 + b as i64);
                        v += p * xw * yw;
                        dx += p * xdw * yw;
                        dy += p * xw * ydw;
                    }
                }
                (v, dx, dy)
            }
        };
        (v, dx * sx, dy * sy)
    }

    /// The interpolated height alone: the first value of [`Self::height`], computed
    /// the same way, for the ray caster's many point values.
    fn height_value(&self, uv: [f64; 2]) -> f64 {
        let Some((gx, gy)) = self.grid(uv) else {
            return 0.0;
        };
        let (i, j, tx, ty) = self.cell(gx, gy);
        let s = &self.samples;
        match self.interp {
            Interp::Bilinear => bilinear(self.corners(i, j), tx, ty),
            Interp::Bicubic => {
                let (wx, _) = catmull_rom(tx);
                let (wy, _) = catmull_rom(ty);
                let mut v = 0.0;
                for (b, yw) in wy.iter().enumerate() {
                    for (a, xw) in wx.iter().enumerate() {
                        v += s.at(i - 1 + a as i64, j - 1 + b as i64) * xw * yw;
                    }
                }
                v
            }
        }
    }

    /// The base's parameters at `p`: the first value of [`Self::params`], computed the
    /// same way.
    fn uv(&self, p: [f64; 3]) -> [f64; 2] {
        match self.base {
            Base::Plane => [p[0], p[1]],
            Base::Cylinder(_) => [p[1].atan2(p[0]), p[2]],
            Base::Ellipsoid([a, b, c]) => {
                let (x, y, z) = (p[0] / a, p[1] / b, p[2] / c);
                let rho = (x * x + y * y).sqrt();
                [y.atan2(x), z.atan2(rho)]
            }
        }
    }

    /// The base's parameters at `p` with their gradients.
    fn params(&self, p: [f64; 3]) -> ([f64; 2], [f64; 3], [f64; 3]) {
        match self.base {
            Base::Plane => ([p[0], p[1]], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            Base::Cylinder(_) => {
                let r2 = p[0] * p[0] + p[1] * p[1];
                let gu = if r2 > 0.0 {
                    [-p[1] / r2, p[0] / r2, 0.0]
                } else {
                    [0.0; 3]
                };
                ([p[1].atan2(p[0]), p[2]], gu, [0.0, 0.0, 1.0])
            }
            Base::Ellipsoid([a, b, c]) => {
                let (x, y, z) = (p[0] / a, p[1] / b, p[2] / c);
                let rho2 = x * x + y * y;
                let rho = rho2.sqrt();
                let gu = if rho2 > 0.0 {
                    [-y / rho2 / a, x / rho2 / b, 0.0]
                } else {
                    [0.0; 3]
                };
                let d = rho2 + z * z;
                let gv = if rho > 0.0 && d > 0.0 {
                    [-z * x / (rho * d) / a, -z * y / (rho * d) / b, rho / d / c]
                } else {
                    [0.0; 3]
                };
                ([y.atan2(x), z.atan2(rho)], gu, gv)
            }
        }
    }

    fn base_value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self.base {
            Base::Plane => (-p[2], [0.0, 0.0, -1.0]),
            Base::Cylinder(r) => (
                1.0 - (p[0] * p[0] + p[1] * p[1]) / (r * r),
                [-2.0 * p[0] / (r * r), -2.0 * p[1] / (r * r), 0.0],
            ),
            Base::Ellipsoid(s) => (
                1.0 - (0..3).map(|k| (p[k] / s[k]).powi(2)).sum::<f64>(),
                [0, 1, 2].map(|k| -2.0 * p[k] / (s[k] * s[k])),
            ),
        }
    }

    /// The thresholded height `h(u(p), v(p))` alone (without the base) and its exact
    /// gradient in space: a picture mapped onto 3-D space through the base's
    /// parameters, constant along the parameters' level lines.
    pub fn perturbation(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (uv, gu, gv) = self.params(p);
        let (h, hu, hv) = self.height(uv);
        if h >= self.threshold {
            (h, [0, 1, 2].map(|k| hu * gu[k] + hv * gv[k]))
        } else {
            (0.0, [0.0; 3])
        }
    }

    /// The value of [`Self::perturbation`] alone.
    pub fn perturbation_value(&self, p: [f64; 3]) -> f64 {
        let h = self.height_value(self.uv(p));
        if h >= self.threshold {
            h
        } else {
            0.0
        }
    }

    /// The value of [`Self::value_gradient`] alone.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        let g = self.base_value_gradient(p).0;
        let h = self.height_value(self.uv(p));
        if h >= self.threshold && h != 0.0 {
            g + h
        } else {
            g
        }
    }

    /// Bounds of [`Self::perturbation`] over a box.
    pub fn perturbation_range(&self, b: &Aabb) -> Interval {
        self.height_range(b)
    }

    /// `F = G + h` and its exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (g, mut grad) = self.base_value_gradient(p);
        let (uv, gu, gv) = self.params(p);
        let (h, hu, hv) = self.height(uv);
        if h >= self.threshold && h != 0.0 {
            for k in 0..3 {
                grad[k] += hu * gu[k] + hv * gv[k];
            }
            (g + h, grad)
        } else {
            (g, grad)
        }
    }

    /// A box holding the solid, or None for the unbounded bases (plane, cylinder).
    pub fn bounds(&self) -> Option<Aabb> {
        match self.base {
            Base::Ellipsoid(s) => {
                // G + h >= 0 needs (x/a)^2 + ... <= 1 + h.
                let top = self.global_range().hi.max(0.0);
                let k = (1.0 + top).sqrt();
                Some(Aabb::new(s.map(|v| -k * v), s.map(|v| k * v)))
            }
            Base::Plane | Base::Cylinder(_) => None,
        }
    }

    /// Bounds of `F` over a box.
    pub fn interval(&self, b: &Aabb) -> Interval {
        let [x, y, z] = b.axes();
        let base = match self.base {
            Base::Plane => -z,
            Base::Cylinder(r) => Interval::point(1.0) - (x.sqr() + y.sqr()).scale(1.0 / (r * r)),
            Base::Ellipsoid([a, bb, c]) => {
                Interval::point(1.0)
                    - (x.scale(1.0 / a).sqr() + y.scale(1.0 / bb).sqr() + z.scale(1.0 / c).sqr())
            }
        };
        base + self.height_range(b)
    }

    /// Bounds of the thresholded height over a box.
    fn height_range(&self, b: &Aabb) -> Interval {
        let [u0, v0, u1, v1] = self.rect;
        let Some((ur, vr)) = self.param_range(b) else {
            return self.global_range();
        };
        if ur.hi < u0 || ur.lo > u1 || vr.hi < v0 || vr.lo > v1 {
            return Interval::point(0.0);
        }
        let (w, h) = self.size();
        let gx = |u: f64| (u - u0) / (u1 - u0) * (w - 1) as f64;
        let gy = |v: f64| (v1 - v) / (v1 - v0) * (h - 1) as f64;
        // Bicubic reads one more sample on each side.
        let reach = if self.interp == Interp::Bicubic { 1 } else { 0 };
        let (i0, i1) = (
            gx(ur.lo).floor() as i64 - reach,
            gx(ur.hi).ceil() as i64 + reach,
        );
        let (j0, j1) = (
            gy(vr.hi).floor() as i64 - reach,
            gy(vr.lo).ceil() as i64 + reach,
        );
        let (lo, hi) = self.samples.range(i0, i1, j0, j1);
        self.thresholded(lo, hi, ur.lo < u0 || ur.hi > u1 || vr.lo < v0 || vr.hi > v1)
    }

    /// The range of heights from a sample range: Catmull-Rom can overshoot by a quarter
    /// of the local spread; the threshold maps what is below it to 0; a box reaching
    /// outside the rectangle also sees 0.
    fn thresholded(&self, lo: f64, hi: f64, outside: bool) -> Interval {
        let (lo, hi) = match self.interp {
            Interp::Bilinear => (lo, hi),
            Interp::Bicubic => (lo - 0.25 * (hi - lo), hi + 0.25 * (hi - lo)),
        };
        self.clipped(lo, hi, outside)
    }

    /// Bounds of the thresholded height over a box, as tight as the interpolation
    /// allows: the samples for bilinear; for bicubic the extremes of each covered
    /// cell's Bezier control net, which holds the patch (convex hull) and passes its
    /// true extremes by far less than the worst case [`Self::perturbation_range`] adds.
    pub fn interpolated_range(&self, b: &Aabb) -> Interval {
        let [u0, v0, u1, v1] = self.rect;
        let (w, h) = self.size();
        // Past 16 M cells the cell-by-cell bound costs more than it is worth.
        if self.interp == Interp::Bilinear || (w as u64) * (h as u64) > 1 << 24 {
            return self.height_range(b);
        }
        let (ur, vr) = self
            .param_range(b)
            .unwrap_or((Interval::new(u0, u1), Interval::new(v0, v1)));
        if ur.hi < u0 || ur.lo > u1 || vr.hi < v0 || vr.lo > v1 {
            return Interval::point(0.0);
        }
        let outside = ur.lo < u0 || ur.hi > u1 || vr.lo < v0 || vr.hi > v1;
        let cells = |a: f64, b: f64, n: usize| {
            let last = (n as i64 - 2).max(0);
            (a.floor() as i64).clamp(0, last)..=((b.ceil() as i64) - 1).clamp(0, last)
        };
        let gx = |u: f64| (u - u0) / (u1 - u0) * (w - 1) as f64;
        let gy = |v: f64| (v1 - v) / (v1 - v0) * (h - 1) as f64;
        // A Catmull-Rom segment's Bezier points from its four samples.
        let bezier = |p: [f64; 4]| {
            [
                p[1],
                p[1] + (p[2] - p[0]) / 6.0,
                p[2] - (p[3] - p[1]) / 6.0,
                p[2],
            ]
        };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in cells(gy(vr.hi), gy(vr.lo), h) {
            for i in cells(gx(ur.lo), gx(ur.hi), w) {
                let rows: [[f64; 4]; 4] = std::array::from_fn(|y| {
                    bezier(std::array::from_fn(|x| {
                        self.samples.at(i - 1 + x as i64, j - 1 + y as i64)
                    }))
                });
                for c in (0..4).flat_map(|x| bezier(rows.map(|r| r[x]))) {
                    (lo, hi) = (lo.min(c), hi.max(c));
                }
            }
        }
        self.clipped(lo, hi, outside)
    }

    /// The threshold maps heights below it to 0; a box reaching outside the rectangle
    /// also sees 0.
    fn clipped(&self, lo: f64, hi: f64, outside: bool) -> Interval {
        if lo < self.threshold || outside {
            Interval::new(lo.min(0.0), hi.max(0.0))
        } else {
            Interval::new(lo, hi)
        }
    }

    fn global_range(&self) -> Interval {
        let (w, h) = self.size();
        let (lo, hi) = self.samples.range(0, w as i64 - 1, 0, h as i64 - 1);
        self.thresholded(lo, hi, true)
    }

    /// The range of the base's parameters over a box, or None where it is not
    /// cheaply bounded (the box holds the angle's axis).
    fn param_range(&self, b: &Aabb) -> Option<(Interval, Interval)> {
        let [x, y, z] = b.axes();
        match self.base {
            Base::Plane => Some((x, y)),
            Base::Cylinder(_) => Some((angle_range(x, y)?, z)),
            Base::Ellipsoid([a, bb, c]) => {
                let (x, y, z) = (x.scale(1.0 / a), y.scale(1.0 / bb), z.scale(1.0 / c));
                let u = angle_range(x, y)?;
                // Distance from the axis: at least to the nearest point of the xy box.
                let near = |i: Interval| {
                    if i.contains(0.0) {
                        0.0
                    } else {
                        i.lo.abs().min(i.hi.abs())
                    }
                };
                let far = |i: Interval| i.lo.abs().max(i.hi.abs());
                let radius = |a: f64, b: f64| (a * a + b * b).sqrt();
                let (rlo, rhi) = (radius(near(x), near(y)), radius(far(x), far(y)));
                // Latitude increases with z and moves towards 0 as rho grows.
                let lat = |zz: f64, r: f64| rough_atan2(zz, r);
                let lo = lat(z.lo, if z.lo >= 0.0 { rhi } else { rlo }) - ROUGH_ATAN2_ERROR;
                let hi = lat(z.hi, if z.hi >= 0.0 { rlo } else { rhi }) + ROUGH_ATAN2_ERROR;
                Some((u, Interval::new(lo, hi)))
            }
        }
    }
}

/// The range of `atan2(y, x)` over a box that does not hold the origin's axis; None if
/// it does. The angle is in (-pi, pi]; a box across the negative x axis gets a range
/// reaching past pi, which the height lookup treats as outside (it is conservative:
/// the caller then uses the global range).
fn angle_range(x: Interval, y: Interval) -> Option<Interval> {
    if x.contains(0.0) && y.contains(0.0) {
        return None;
    }
    if y.contains(0.0) && x.hi < 0.0 {
        // Across the branch cut.
        return None;
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for xx in [x.lo, x.hi] {
        for yy in [y.lo, y.hi] {
            let a = rough_atan2(yy, xx);
            lo = lo.min(a);
            hi = hi.max(a);
        }
    }
    Some(Interval::new(
        lo - ROUGH_ATAN2_ERROR,
        (hi + ROUGH_ATAN2_ERROR).min(PI),
    ))
}

/// A bound on `|rough_atan2(y, x) - y.atan2(x)|` (the approximation's largest error is
/// 0.00151 on [-1, 1]; the rest is room for rounding).
const ROUGH_ATAN2_ERROR: f64 = 0.002;

/// `y.atan2(x)` to within [`ROUGH_ATAN2_ERROR`], a few times cheaper than the library's:
/// the bounds of a box's angles (padded by the error) are what the ray caster asks
/// for most, and the image's pixels are far wider. Uses
/// `atan t ~ pi/4 t - t (|t| - 1) (0.2447 + 0.0663 |t|)` on `|t| <= 1` (Rajan et al.,
/// "Efficient approximations for the arctangent function", 2006) and the octant
/// symmetries; the same branch as `atan2` (the result in [-pi, pi], `x < 0, y = 0` at
/// pi or -pi by the sign of `y`), NaN for a NaN argument.
fn rough_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::FRAC_PI_2;
    let atan = |t: f64| PI / 4.0 * t - t * (t.abs() - 1.0) * (0.2447 + 0.0663 * t.abs());
    if x.is_nan() || y.is_nan() {
        return f64::NAN;
    }
    if x == 0.0 && y == 0.0 {
        return y.atan2(x);
    }
    if x.abs() >= y.abs() {
        let a = atan(y / x);
        if x > 0.0 {
            a
        } else if y.is_sign_negative() {
            a - PI
        } else {
            a + PI
        }
    } else {
        let a = -atan(x / y);
        if y > 0.0 {
            FRAC_PI_2 + a
        } else {
            -FRAC_PI_2 + a
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rough_atan2_is_within_its_error_on_every_side() {
        let mut worst: f64 = 0.0;
        for i in 0..=400 {
            for j in 0..=400 {
                let (x, y) = (-2.0 + 0.01 * f64::from(i), -2.0 + 0.01 * f64::from(j));
                for (y, x) in [(y, x), (-0.0, x), (0.0, x), (y, -0.0), (y, 0.0)] {
                    worst = worst.max((rough_atan2(y, x) - y.atan2(x)).abs());
                }
            }
        }
        assert!(worst <= ROUGH_ATAN2_ERROR, "largest error {worst}");
        assert!(
            worst > 0.001,
            "the approximation's error is 0.0015: {worst}"
        );
    }
}
