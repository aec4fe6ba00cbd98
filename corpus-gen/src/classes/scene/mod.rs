//! Scene class: photograph-like composites rendered in linear light, then
//! sRGB-encoded, with a mild vignette and film grain (grain is a stateless hash of
//! the pixel position, so it is as reproducible as everything else).
//!
//! Variants: countryside (sky, clouds, sun, mountains, farmland, trees, house,
//! fence, power line), mountain lake at sunset (with reflections), still life
//! (wall, framed picture, table, fruit, vase, books) and a coast with a lighthouse.

mod coast;
mod indoors;
mod land;

use super::text::{draw_line, TextStyle};
use super::{format, noise_seed, rng_for};
use crate::canvas::{
    closed_spline, rounded_rect, Canvas, Disc, Ellipse, Encoding, Polygon, SdfShape, Shape, Stroke,
};
use crate::image::CorpusImage;
use crate::math::{clamp01, cos, exp, fract, pow, sin, smoothstep, sq, sqrt, Col, PI, TAU};
use crate::noise::Noise;
use crate::rng::{hash2, hash3, unit_f64, Rng};
use crate::Class;

/// Region below a curve `y = f(x)`, with the distance corrected for the slope.
fn below<F: Fn(f64) -> f64 + Sync>(
    f: F,
    bb: [f64; 4],
) -> SdfShape<impl Fn(f64, f64) -> f64 + Sync> {
    SdfShape {
        bb,
        f: move |x: f64, y: f64| {
            let c = f(x);
            let d = f(x + 0.5) - f(x - 0.5);
            (c - y) / sqrt(1.0 + d * d)
        },
    }
}

/// A soft-edged version of a polygon (blur radius in pixels), for shadows.
fn soft_poly(p: Polygon, blur: f64) -> SdfShape<impl Fn(f64, f64) -> f64 + Sync> {
    let bb = p.bbox();
    SdfShape {
        bb: [bb[0] - blur, bb[1] - blur, bb[2] + blur, bb[3] + blur],
        f: move |x: f64, y: f64| p.sdf(x, y) / blur,
    }
}

/// A soft ellipse with level axes, of one colour: a shadow on the ground.
fn flat_shadow(
    c: &mut Canvas,
    centre: (f64, f64),
    radii: (f64, f64),
    blur: f64,
    alpha: f64,
    col: Col,
) {
    let e = Ellipse {
        cx: centre.0,
        cy: centre.1,
        rx: radii.0,
        ry: radii.1,
        rot: (1.0, 0.0),
    };
    c.draw(&soft_ellipse(e, blur), alpha, move |_, _| col);
}

fn soft_ellipse(e: Ellipse, blur: f64) -> SdfShape<impl Fn(f64, f64) -> f64 + Sync> {
    let bb = e.bbox();
    SdfShape {
        bb: [bb[0] - blur, bb[1] - blur, bb[2] + blur, bb[3] + blur],
        f: move |x: f64, y: f64| e.sdf(x, y) / blur,
    }
}

/// A union of discs with a noisy boundary: tree crowns, bushes, rocks.
struct Blob {
    discs: Vec<(f64, f64, f64)>,
    noise: Noise,
    amp: f64,
    freq: f64,
    bb: [f64; 4],
}

impl Blob {
    fn new(discs: Vec<(f64, f64, f64)>, noise: Noise, amp: f64, freq: f64) -> Blob {
        let mut bb = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
        for &(x, y, r) in &discs {
            bb[0] = bb[0].min(x - r);
            bb[1] = bb[1].min(y - r);
            bb[2] = bb[2].max(x + r);
            bb[3] = bb[3].max(y + r);
        }
        let m = amp + 1.0;
        Blob {
            discs,
            noise,
            amp,
            freq,
            bb: [bb[0] - m, bb[1] - m, bb[2] + m, bb[3] + m],
        }
    }
    fn sdf(&self, x: f64, y: f64) -> f64 {
        let mut d = f64::MAX;
        for &(cx, cy, r) in &self.discs {
            d = d.min(sqrt(sq(x - cx) + sq(y - cy)) - r);
        }
        if d > self.amp + 1.0 {
            return d;
        }
        d + self.amp * self.noise.fbm(x * self.freq, y * self.freq, 4, 2.0, 0.55)
    }
    /// Centre and radius of the bounding circle (for sphere-like shading).
    fn centre(&self) -> (f64, f64, f64) {
        let cx = 0.5 * (self.bb[0] + self.bb[2]);
        let cy = 0.5 * (self.bb[1] + self.bb[3]);
        (
            cx,
            cy,
            0.5 * (self.bb[2] - self.bb[0]).max(self.bb[3] - self.bb[1]),
        )
    }
}

impl Shape for Blob {
    fn bbox(&self) -> [f64; 4] {
        self.bb
    }
    fn coverage(&self, x: f64, y: f64) -> f64 {
        clamp01(0.5 - self.sdf(x, y))
    }
}

fn normalize3(v: (f64, f64, f64)) -> (f64, f64, f64) {
    let l = sqrt(v.0 * v.0 + v.1 * v.1 + v.2 * v.2);
    (v.0 / l, v.1 / l, v.2 / l)
}

/// Sphere-like shading of a point inside a blob-ish shape of centre (cx, cy), radius r.
fn sphere_light(
    x: f64,
    y: f64,
    cx: f64,
    cy: f64,
    r: f64,
    l: (f64, f64, f64),
) -> (f64, (f64, f64, f64)) {
    let nx = ((x - cx) / r).clamp(-1.0, 1.0);
    let ny = ((y - cy) / r).clamp(-1.0, 1.0);
    let nz = sqrt((1.0 - nx * nx - ny * ny).max(0.0));
    let n = normalize3((nx, ny, nz + 1e-3));
    ((n.0 * l.0 + n.1 * l.1 + n.2 * l.2).max(0.0), n)
}

/// Cloud density in [0, 1] (domain-warped fBm, stretched horizontally).
fn cloud_density(n1: &Noise, n2: &Noise, x: f64, y: f64, f0: f64, cover: f64, stretch: f64) -> f64 {
    let u = x * f0;
    let v = y * f0 * stretch;
    let wx = n2.fbm(u * 0.5, v * 0.5, 3, 2.0, 0.5);
    let wy = n2.fbm(u * 0.5 + 5.2, v * 0.5 + 1.3, 3, 2.0, 0.5);
    let d = n1.fbm(u + 0.7 * wx, v + 0.7 * wy, 6, 2.0, 0.5);
    smoothstep(cover, cover + 0.3, d)
}

/// Vignette, film grain; values stay linear.
fn finish(c: &mut Canvas, seed: u64, grain: f64, vignette: f64) {
    let (wf, hf) = (c.w as f64, c.h as f64);
    let gs = noise_seed(Class::Scene, seed, 99);
    c.modify(|x, y, col| {
        let dx = (x / wf - 0.5) * 2.0;
        let dy = (y / hf - 0.5) * 2.0;
        let v = 1.0 - vignette * sq(sqrt(dx * dx * 0.6 + dy * dy * 0.6));
        let (i, j) = (x as i64, y as i64);
        // Triangular-distributed grain, independent per channel, scaled for sRGB.
        let g = |k: i64| {
            let h = hash3(gs, i, j, k);
            (unit_f64(h) + unit_f64(h.rotate_left(32)) - 1.0) * grain
        };
        let f = |v: f64, k: i64| {
            let v = v.max(0.0);
            v + g(k) * sqrt(v) * 0.25
        };
        let c2 = col * v;
        Col(f(c2.0, 0), f(c2.1, 1), f(c2.2, 2))
    });
}

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::Scene, seed);
    let mut c = Canvas::new(w, h, Col::gray(0.2));
    let grain = rng.range(0.02, 0.06);
    match seed % 4 {
        0 => land::countryside(&mut c, &mut rng, seed),
        1 => land::lake(&mut c, &mut rng, seed),
        2 => indoors::still_life(&mut c, &mut rng, seed),
        _ => coast::coast(&mut c, &mut rng, seed),
    }
    finish(&mut c, seed, grain, 0.22);
    let (ch, fmt) = format(Class::Scene, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Srgb)
}

/// The canvas's width and height, and the scene's scale: its height, or a quarter of
/// its width when that is more (panoramas).
fn frame(c: &Canvas) -> (f64, f64, f64) {
    let (wf, hf) = (c.w as f64, c.h as f64);
    (wf, hf, hf.max(wf * 0.25))
}

fn noises(seed: u64) -> [Noise; 6] {
    core::array::from_fn(|k| Noise::new(noise_seed(Class::Scene, seed, k as u64)))
}

fn birds(c: &mut Canvas, rng: &mut Rng, xs: (f64, f64), ys: (f64, f64), size: f64, col: Col) {
    let ((x0, x1), (y0, y1)) = (xs, ys);
    for _ in 0..rng.int(0, 5) {
        let (x, y) = (rng.range(x0, x1), rng.range(y0, y1));
        let s = size * rng.range(0.6, 1.2);
        let flap = rng.range(-0.3, 0.3);
        let pts = vec![
            (x - s, y - s * (0.3 + flap)),
            (x - s * 0.4, y - s * 0.35),
            (x, y),
            (x + s * 0.4, y - s * 0.35),
            (x + s, y - s * (0.3 - flap)),
        ];
        c.fill(&Stroke::new(pts, (s * 0.18).max(0.7)), col);
    }
}
