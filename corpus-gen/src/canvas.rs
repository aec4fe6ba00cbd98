//! A float RGBA canvas with anti-aliased shape rasterisation.
//!
//! Every pixel is computed as a pure function of its coordinates and of the
//! drawing commands issued so far, in order. Rows are processed in parallel
//! with rayon, which cannot change the result: no pixel depends on another
//! pixel of the same pass.
//!
//! Coordinates are in pixels; pixel `(i, j)` is sampled at its centre
//! `(i + 0.5, j + 0.5)`. Coverage of a shape edge is the box-filtered
//! coverage `clamp(0.5 - d, 0, 1)` of the signed distance `d`, so interiors
//! are exactly covered (coverage 1.0): flat fills stay exactly flat.

#![allow(dead_code)]

use rayon::prelude::*;

use crate::image::{CorpusImage, PixelData};
use crate::math::{clamp01, quantize, sqrt, srgb_encode, Col};

/// How canvas values map to output samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Values are display-referred already: clamp to `[0, 1]` and quantise.
    Display,
    /// Values are linear light: apply the sRGB transfer function, then quantise.
    Srgb,
}

#[derive(Clone, Debug)]
pub struct Canvas {
    pub w: usize,
    pub h: usize,
    /// Row-major RGBA, alpha in `[0, 1]` (straight, not premultiplied).
    pub px: Vec<[f32; 4]>,
}

/// Something with an anti-aliased footprint.
pub trait Shape: Sync {
    /// `[x0, y0, x1, y1]` in pixel coordinates; coverage is zero outside.
    fn bbox(&self) -> [f64; 4];
    /// Coverage in `[0, 1]` of the pixel whose centre is `(x, y)`.
    fn coverage(&self, x: f64, y: f64) -> f64;
}

impl Canvas {
    pub fn new(w: usize, h: usize, fill: Col) -> Canvas {
        Canvas {
            w,
            h,
            px: vec![[fill.0 as f32, fill.1 as f32, fill.2 as f32, 1.0]; w * h],
        }
    }

    pub fn transparent(w: usize, h: usize) -> Canvas {
        Canvas {
            w,
            h,
            px: vec![[0.0; 4]; w * h],
        }
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Col {
        let p = self.px[y * self.w + x];
        Col(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// Set every pixel's colour from `f(x, y)` at the pixel centre (alpha becomes 1).
    pub fn shade<F: Fn(f64, f64) -> Col + Sync>(&mut self, f: F) {
        let w = self.w.max(1);
        self.px.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
            let y = j as f64 + 0.5;
            for (i, p) in row.iter_mut().enumerate() {
                let c = f(i as f64 + 0.5, y);
                *p = [c.0 as f32, c.1 as f32, c.2 as f32, 1.0];
            }
        });
    }

    /// Set every pixel's RGBA from `f(x, y)`.
    pub fn shade_rgba<F: Fn(f64, f64) -> [f64; 4] + Sync>(&mut self, f: F) {
        let w = self.w.max(1);
        self.px.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
            let y = j as f64 + 0.5;
            for (i, p) in row.iter_mut().enumerate() {
                let c = f(i as f64 + 0.5, y);
                *p = [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32];
            }
        });
    }

    /// Replace each colour by `f(x, y, old)`.
    pub fn modify<F: Fn(f64, f64, Col) -> Col + Sync>(&mut self, f: F) {
        let w = self.w.max(1);
        self.px.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
            let y = j as f64 + 0.5;
            for (i, p) in row.iter_mut().enumerate() {
                let c = f(
                    i as f64 + 0.5,
                    y,
                    Col(p[0] as f64, p[1] as f64, p[2] as f64),
                );
                p[0] = c.0 as f32;
                p[1] = c.1 as f32;
                p[2] = c.2 as f32;
            }
        });
    }

    fn rows_of(&self, bb: [f64; 4]) -> Option<(usize, usize, usize, usize)> {
        let x0 = bb[0].floor().max(0.0);
        let y0 = bb[1].floor().max(0.0);
        let x1 = (bb[2].ceil() + 1.0).min(self.w as f64);
        let y1 = (bb[3].ceil() + 1.0).min(self.h as f64);
        if !(x0 < x1 && y0 < y1) {
            return None;
        }
        Some((x0 as usize, y0 as usize, x1 as usize, y1 as usize))
    }

    /// Composite `shape` painted with `paint(x, y)` at opacity `alpha`.
    pub fn draw<S: Shape + ?Sized, P: Fn(f64, f64) -> Col + Sync>(
        &mut self,
        shape: &S,
        alpha: f64,
        paint: P,
    ) {
        let Some((x0, y0, x1, y1)) = self.rows_of(shape.bbox()) else {
            return;
        };
        let w = self.w;
        self.px[y0 * w..y1 * w]
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(jj, row)| {
                let y = (y0 + jj) as f64 + 0.5;
                for (i, p) in row.iter_mut().enumerate().take(x1).skip(x0) {
                    let x = i as f64 + 0.5;
                    let cov = shape.coverage(x, y);
                    if cov <= 0.0 {
                        continue;
                    }
                    let a = (cov * alpha) as f32;
                    let c = paint(x, y);
                    let c = [c.0 as f32, c.1 as f32, c.2 as f32];
                    if a >= 1.0 {
                        p[0] = c[0];
                        p[1] = c[1];
                        p[2] = c[2];
                        p[3] = 1.0;
                    } else {
                        // Straight-alpha "over".
                        let ab = p[3];
                        let ao = a + ab * (1.0 - a);
                        if ao > 0.0 {
                            for k in 0..3 {
                                p[k] = (c[k] * a + p[k] * ab * (1.0 - a)) / ao;
                            }
                        }
                        p[3] = ao;
                    }
                }
            });
    }

    /// Fill `shape` with a solid colour.
    pub fn fill<S: Shape + ?Sized>(&mut self, shape: &S, col: Col) {
        self.draw(shape, 1.0, move |_, _| col);
    }

    /// Convert to an integer image. `channels`: 1 (luma of RGB), 2 (luma + alpha),
    /// 3 (RGB) or 4 (RGBA). `bits`: 8 or 16.
    pub fn to_image(&self, channels: u8, bits: u8, enc: Encoding) -> CorpusImage {
        let max = if bits == 16 { 65535 } else { 255 };
        let ch = channels as usize;
        let mut out = vec![0u32; self.w * self.h * ch];
        let w = self.w.max(1);
        out.par_chunks_mut(w * ch).enumerate().for_each(|(j, row)| {
            for i in 0..self.w {
                let p = self.px[j * self.w + i];
                let e = |v: f32| match enc {
                    Encoding::Display => clamp01(v as f64),
                    Encoding::Srgb => srgb_encode(v as f64),
                };
                let (r, g, b) = (e(p[0]), e(p[1]), e(p[2]));
                let luma = 0.2126 * r + 0.7152 * g + 0.0722 * b;
                let a = clamp01(p[3] as f64);
                let o = &mut row[i * ch..(i + 1) * ch];
                match ch {
                    1 => o[0] = quantize(luma, max),
                    2 => {
                        o[0] = quantize(luma, max);
                        o[1] = quantize(a, max);
                    }
                    3 => {
                        o[0] = quantize(r, max);
                        o[1] = quantize(g, max);
                        o[2] = quantize(b, max);
                    }
                    _ => {
                        o[0] = quantize(r, max);
                        o[1] = quantize(g, max);
                        o[2] = quantize(b, max);
                        o[3] = quantize(a, max);
                    }
                }
            }
        });
        let data = if bits == 16 {
            PixelData::U16(out.into_iter().map(|v| v as u16).collect())
        } else {
            PixelData::U8(out.into_iter().map(|v| v as u8).collect())
        };
        CorpusImage::from_parts(self.w as u32, self.h as u32, channels, data)
    }

    /// Convert to a float RGB image (linear values kept as they are).
    pub fn to_float_rgb(&self) -> CorpusImage {
        let mut out = Vec::with_capacity(self.w * self.h * 3);
        for p in &self.px {
            out.extend_from_slice(&p[..3]);
        }
        CorpusImage::from_parts(self.w as u32, self.h as u32, 3, PixelData::F32(out))
    }
}

// ---------------------------------------------------------------------------
// Shapes

#[inline]
fn edge_cov(d: f64) -> f64 {
    clamp01(0.5 - d)
}

/// A disc.
#[derive(Clone, Copy, Debug)]
pub struct Disc {
    pub cx: f64,
    pub cy: f64,
    pub r: f64,
}

impl Disc {
    /// The disc of radius `r` centred at `(cx, cy)`.
    pub fn new(cx: f64, cy: f64, r: f64) -> Disc {
        Disc { cx, cy, r }
    }
}

impl Shape for Disc {
    fn bbox(&self) -> [f64; 4] {
        [
            self.cx - self.r - 1.0,
            self.cy - self.r - 1.0,
            self.cx + self.r + 1.0,
            self.cy + self.r + 1.0,
        ]
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        let dx = x - self.cx;
        let dy = y - self.cy;
        edge_cov(sqrt(dx * dx + dy * dy) - self.r)
    }
}

/// A rotated ellipse (first-order distance approximation: exact enough for AA).
#[derive(Clone, Copy, Debug)]
pub struct Ellipse {
    pub cx: f64,
    pub cy: f64,
    pub rx: f64,
    pub ry: f64,
    /// Rotation as (cos, sin).
    pub rot: (f64, f64),
}

impl Ellipse {
    pub fn sdf(&self, x: f64, y: f64) -> f64 {
        let dx = x - self.cx;
        let dy = y - self.cy;
        let u = dx * self.rot.0 + dy * self.rot.1;
        let v = -dx * self.rot.1 + dy * self.rot.0;
        let px = u / self.rx;
        let py = v / self.ry;
        let k0 = sqrt(px * px + py * py);
        if k0 == 0.0 {
            return -self.rx.min(self.ry);
        }
        let qx = u / (self.rx * self.rx);
        let qy = v / (self.ry * self.ry);
        let k1 = sqrt(qx * qx + qy * qy);
        k0 * (k0 - 1.0) / k1
    }
}

impl Shape for Ellipse {
    fn bbox(&self) -> [f64; 4] {
        let r = self.rx.max(self.ry) + 1.0;
        [self.cx - r, self.cy - r, self.cx + r, self.cy + r]
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        edge_cov(self.sdf(x, y))
    }
}

/// The bounding box `[x0, y0, x1, y1]` of `pts`, grown by `margin` on every side.
fn points_bbox(pts: &[(f64, f64)], margin: f64) -> [f64; 4] {
    let mut bb = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    for &(x, y) in pts {
        bb[0] = bb[0].min(x);
        bb[1] = bb[1].min(y);
        bb[2] = bb[2].max(x);
        bb[3] = bb[3].max(y);
    }
    [
        bb[0] - margin,
        bb[1] - margin,
        bb[2] + margin,
        bb[3] + margin,
    ]
}

/// `coverage()` where `(x, y)` lies in the box `bb` (`[x0, y0, x1, y1]`), 0 outside it.
fn inside_box(bb: &[f64; 4], x: f64, y: f64, coverage: impl FnOnce() -> f64) -> f64 {
    if x < bb[0] || x > bb[2] || y < bb[1] || y > bb[3] {
        0.0
    } else {
        coverage()
    }
}

/// `w` less its projection onto the segment from 0 to `e`: the offset of the point `w`
/// from the segment's nearest point.
fn off_segment(wx: f64, wy: f64, ex: f64, ey: f64) -> (f64, f64) {
    let ee = ex * ex + ey * ey;
    let t = if ee > 0.0 {
        ((wx * ex + wy * ey) / ee).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (wx - ex * t, wy - ey * t)
}

/// A simple or self-intersecting polygon (even-odd rule), any vertex count >= 3.
#[derive(Clone, Debug)]
pub struct Polygon {
    pub pts: Vec<(f64, f64)>,
    bb: [f64; 4],
}

impl Polygon {
    pub fn new(pts: Vec<(f64, f64)>) -> Polygon {
        let bb = points_bbox(&pts, 1.0);
        Polygon { pts, bb }
    }

    /// Axis-aligned rectangle.
    pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon {
        Polygon::new(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    }

    /// Rectangle centred at (cx, cy) with half sizes, rotated by (cos, sin).
    pub fn rotated_rect(cx: f64, cy: f64, hw: f64, hh: f64, rot: (f64, f64)) -> Polygon {
        let (c, s) = rot;
        let corner = |u: f64, v: f64| (cx + u * c - v * s, cy + u * s + v * c);
        Polygon::new(vec![
            corner(-hw, -hh),
            corner(hw, -hh),
            corner(hw, hh),
            corner(-hw, hh),
        ])
    }

    /// Signed distance, negative inside.
    pub fn sdf(&self, x: f64, y: f64) -> f64 {
        let v = &self.pts;
        let n = v.len();
        let mut d = (x - v[0].0) * (x - v[0].0) + (y - v[0].1) * (y - v[0].1);
        let mut s = 1.0;
        let mut j = n - 1;
        for i in 0..n {
            let ex = v[j].0 - v[i].0;
            let ey = v[j].1 - v[i].1;
            let wx = x - v[i].0;
            let wy = y - v[i].1;
            let (bx, by) = off_segment(wx, wy, ex, ey);
            d = d.min(bx * bx + by * by);
            let c1 = y >= v[i].1;
            let c2 = y < v[j].1;
            let c3 = ex * wy > ey * wx;
            if (c1 && c2 && c3) || (!c1 && !c2 && !c3) {
                s = -s;
            }
            j = i;
        }
        s * sqrt(d)
    }
}

impl Shape for Polygon {
    fn bbox(&self) -> [f64; 4] {
        self.bb
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        inside_box(&self.bb, x, y, || edge_cov(self.sdf(x, y)))
    }
}

/// An open polyline stroked with round caps and joins. Thin strokes (width < 1 px)
/// get their exact 1-D box-filtered coverage, so hairlines keep their weight.
#[derive(Clone, Debug)]
pub struct Stroke {
    pub pts: Vec<(f64, f64)>,
    pub half_width: f64,
    bb: [f64; 4],
}

impl Stroke {
    pub fn new(pts: Vec<(f64, f64)>, width: f64) -> Stroke {
        let hw = width * 0.5;
        let bb = points_bbox(&pts, hw + 1.0);
        Stroke {
            pts,
            half_width: hw,
            bb,
        }
    }

    pub fn line(a: (f64, f64), b: (f64, f64), width: f64) -> Stroke {
        Stroke::new(vec![a, b], width)
    }

    /// Distance from (x, y) to the centre line.
    pub fn dist(&self, x: f64, y: f64) -> f64 {
        let mut best = f64::MAX;
        let p = &self.pts;
        if p.len() == 1 {
            let dx = x - p[0].0;
            let dy = y - p[0].1;
            return sqrt(dx * dx + dy * dy);
        }
        for k in 1..p.len() {
            let (ax, ay) = p[k - 1];
            let (bx, by) = p[k];
            let ex = bx - ax;
            let ey = by - ay;
            let (dx, dy) = off_segment(x - ax, y - ay, ex, ey);
            best = best.min(dx * dx + dy * dy);
        }
        sqrt(best)
    }
}

impl Shape for Stroke {
    fn bbox(&self) -> [f64; 4] {
        self.bb
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        inside_box(&self.bb, x, y, || {
            let t = self.dist(x, y);
            let hw = self.half_width;
            clamp01((t + 0.5).min(hw) - (t - 0.5).max(-hw))
        })
    }
}

/// A shape given by a signed-distance closure.
pub struct SdfShape<F: Fn(f64, f64) -> f64 + Sync> {
    pub bb: [f64; 4],
    pub f: F,
}

impl<F: Fn(f64, f64) -> f64 + Sync> Shape for SdfShape<F> {
    fn bbox(&self) -> [f64; 4] {
        self.bb
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        edge_cov((self.f)(x, y))
    }
}

/// Flatten a cubic Bézier into `n + 1` points.
pub fn cubic(
    p0: (f64, f64),
    p1: (f64, f64),
    p2: (f64, f64),
    p3: (f64, f64),
    n: usize,
) -> Vec<(f64, f64)> {
    (0..=n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let u = 1.0 - t;
            let a = u * u * u;
            let b = 3.0 * u * u * t;
            let c = 3.0 * u * t * t;
            let d = t * t * t;
            (
                a * p0.0 + b * p1.0 + c * p2.0 + d * p3.0,
                a * p0.1 + b * p1.1 + c * p2.1 + d * p3.1,
            )
        })
        .collect()
}

/// Closed Catmull-Rom spline through `ctrl`, `per_seg` points per segment.
pub fn closed_spline(ctrl: &[(f64, f64)], per_seg: usize) -> Vec<(f64, f64)> {
    let n = ctrl.len();
    let mut out = Vec::with_capacity(n * per_seg);
    for i in 0..n {
        let p0 = ctrl[(i + n - 1) % n];
        let p1 = ctrl[i];
        let p2 = ctrl[(i + 1) % n];
        let p3 = ctrl[(i + 2) % n];
        for k in 0..per_seg {
            let t = k as f64 / per_seg as f64;
            let t2 = t * t;
            let t3 = t2 * t;
            let f = |a: f64, b: f64, c: f64, d: f64| {
                0.5 * (2.0 * b
                    + (-a + c) * t
                    + (2.0 * a - 5.0 * b + 4.0 * c - d) * t2
                    + (-a + 3.0 * b - 3.0 * c + d) * t3)
            };
            out.push((f(p0.0, p1.0, p2.0, p3.0), f(p0.1, p1.1, p2.1, p3.1)));
        }
    }
    out
}

/// Axis-aligned rectangle with rounded corners of radius `r`.
pub fn rounded_rect(
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    r: f64,
) -> SdfShape<impl Fn(f64, f64) -> f64 + Sync> {
    let cx = 0.5 * (x0 + x1);
    let cy = 0.5 * (y0 + y1);
    let hx = 0.5 * (x1 - x0);
    let hy = 0.5 * (y1 - y0);
    let r = r.min(hx).min(hy).max(0.0);
    SdfShape {
        bb: [x0 - 1.0, y0 - 1.0, x1 + 1.0, y1 + 1.0],
        f: move |x: f64, y: f64| {
            let qx = (x - cx).abs() - hx + r;
            let qy = (y - cy).abs() - hy + r;
            let ox = qx.max(0.0);
            let oy = qy.max(0.0);
            sqrt(ox * ox + oy * oy) + qx.max(qy).min(0.0) - r
        },
    }
}

/// Annulus centred at (cx, cy) with mid radius `r` and total thickness `t`.
pub fn ring(cx: f64, cy: f64, r: f64, t: f64) -> SdfShape<impl Fn(f64, f64) -> f64 + Sync> {
    let m = r + t + 1.0;
    SdfShape {
        bb: [cx - m, cy - m, cx + m, cy + m],
        f: move |x: f64, y: f64| {
            let d = sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy));
            (d - r).abs() - 0.5 * t
        },
    }
}

/// Evaluate a scalar field at pixel centres, `w x h`, row-major (parallel over rows).
pub fn field<F: Fn(f64, f64) -> f64 + Sync>(w: usize, h: usize, f: F) -> Vec<f64> {
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(j, row)| {
            for (i, v) in row.iter_mut().enumerate() {
                *v = f(i as f64 + 0.5, j as f64 + 0.5);
            }
        });
    out
}

/// Bilinear lookup into a field with clamped borders (pixel-centre coordinates).
pub fn sample_field(f: &[f64], w: usize, h: usize, x: f64, y: f64) -> f64 {
    let fx = (x - 0.5).clamp(0.0, (w - 1) as f64);
    let fy = (y - 0.5).clamp(0.0, (h - 1) as f64);
    let x0 = fx.floor() as usize;
    let y0 = fy.floor() as usize;
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let tx = fx - x0 as f64;
    let ty = fy - y0 as f64;
    let a = f[y0 * w + x0] + (f[y0 * w + x1] - f[y0 * w + x0]) * tx;
    let b = f[y1 * w + x0] + (f[y1 * w + x1] - f[y1 * w + x0]) * tx;
    a + (b - a) * ty
}

impl Canvas {
    /// Like [`Canvas::shade`], but only for rows `y0..`.
    pub fn shade_rows_from<F: Fn(f64, f64) -> Col + Sync>(&mut self, y0: usize, f: F) {
        let w = self.w.max(1);
        let y0 = y0.min(self.h);
        self.px[y0 * self.w..]
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(j, row)| {
                let y = (y0 + j) as f64 + 0.5;
                for (i, p) in row.iter_mut().enumerate() {
                    let c = f(i as f64 + 0.5, y);
                    *p = [c.0 as f32, c.1 as f32, c.2 as f32, 1.0];
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interiors_are_exact_and_edges_antialiased() {
        let mut c = Canvas::new(40, 40, Col::gray(0.0));
        c.fill(&Polygon::rect(10.0, 10.0, 30.5, 30.0), Col::gray(1.0));
        assert_eq!(c.get(20, 20).0, 1.0);
        assert_eq!(c.get(5, 5).0, 0.0);
        // Column 30 is half covered.
        assert!((c.get(30, 20).0 - 0.5).abs() < 1e-6);
    }

    #[test]
    fn hairline_keeps_weight() {
        let s = Stroke::line((0.0, 10.5), (100.0, 10.5), 0.5);
        assert!((s.coverage(50.5, 10.5) - 0.5).abs() < 1e-12);
        assert_eq!(s.coverage(50.5, 12.5), 0.0);
    }
}
