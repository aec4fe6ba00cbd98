//! Scene class: photograph-like composites rendered in linear light, then
//! sRGB-encoded, with a mild vignette and film grain (grain is a stateless hash of
//! the pixel position, so it is as reproducible as everything else).
//!
//! Variants: countryside (sky, clouds, sun, mountains, farmland, trees, house,
//! fence, power line), mountain lake at sunset (with reflections), still life
//! (wall, framed picture, table, fruit, vase, books) and a coast with a lighthouse.

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
        0 => countryside(&mut c, &mut rng, seed),
        1 => lake(&mut c, &mut rng, seed),
        2 => still_life(&mut c, &mut rng, seed),
        _ => coast(&mut c, &mut rng, seed),
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

fn countryside(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let horizon = hf * rng.range(0.48, 0.6);
    let sun = (wf * rng.range(0.15, 0.85), horizon * rng.range(0.2, 0.55));
    let sun_r = s * 0.028;
    let zen = Col::hex_linear(0x2a62b0).mix(Col::hex_linear(0x4a80c8), rng.f64());
    let hor = Col::hex_linear(0xc4d8ea);
    let sun_col = Col(1.0, 0.92, 0.78);
    let cover = rng.range(0.0, 0.25);
    let f0 = rng.range(2.0, 3.5) / s;
    let light = normalize3(((sun.0 - wf * 0.5) / wf, (sun.1 - hf * 0.5) / hf - 0.3, 0.7));
    let sky_at = move |x: f64, y: f64| {
        let t = clamp01(y / horizon);
        let mut col = zen.mix(hor, pow(t, 1.6));
        let d = sqrt(sq(x - sun.0) + sq(y - sun.1)) / s;
        col = col + sun_col * (0.9 * exp(-d * 18.0) + 0.2 * exp(-d * 4.0));
        col
    };
    // Sky, sun, clouds.
    c.shade(|x, y| {
        let mut col = sky_at(x, y);
        let ds = sqrt(sq(x - sun.0) + sq(y - sun.1));
        col = col.mix(Col(4.0, 3.8, 3.4), clamp01(sun_r + 0.5 - ds));
        if y < horizon {
            let fade = 1.0 - smoothstep(0.55, 1.0, y / horizon);
            let d = cloud_density(&n0, &n1, x, y, f0, cover, 2.2) * fade;
            if d > 0.0 {
                let toward = cloud_density(
                    &n0,
                    &n1,
                    x + (sun.0 - x) * 0.02,
                    y + (sun.1 - y) * 0.02 - s * 0.004,
                    f0,
                    cover,
                    2.2,
                );
                let lit = clamp01(1.0 - 1.8 * (toward - d).max(0.0) - 0.3 * d);
                let cloud = Col(0.45, 0.5, 0.6).mix(Col(1.05, 1.02, 0.98), lit);
                col = col.mix(cloud, d);
            }
        }
        col
    });
    // Far mountains, hazy.
    let mtop = horizon - s * rng.range(0.08, 0.16);
    let mh = s * rng.range(0.06, 0.12);
    let mf = rng.range(3.0, 6.0) / s;
    let haze = hor.mix(zen, 0.15);
    c.draw(
        &below(
            |x| mtop + mh * (1.0 - n2.ridged(x * mf, 0.5, 6)),
            [0.0, mtop - 2.0, wf, hf],
        ),
        1.0,
        |x, y| {
            let shade = 0.5 + 0.5 * n2.fbm(x * mf * 4.0, y * mf * 4.0, 5, 2.0, 0.5);
            let rock = Col(0.12, 0.14, 0.18) * (0.7 + 0.6 * shade);
            rock.mix(haze, 0.62)
        },
    );
    // Rolling hills with a farmland patchwork.
    let h1 = horizon - s * 0.02;
    let hf1 = 2.0 / s;
    let hill1 = move |x: f64| h1 + s * 0.03 * n3.fbm1(x * hf1, 3);
    let field_seed = rng.next_u64();
    let cw = s * rng.range(0.08, 0.14);
    let skew = rng.range(-0.8, 0.8);
    let greens = [
        Col::hex_linear(0x5f8a2c),
        Col::hex_linear(0x7a9a38),
        Col::hex_linear(0xa8a050),
        Col::hex_linear(0x4d7a2a),
        Col::hex_linear(0x8aa040),
        Col::hex_linear(0xc0b060),
    ];
    c.draw(&below(hill1, [0.0, h1 - s * 0.06, wf, hf]), 1.0, |x, y| {
        let depth = clamp01((y - h1) / (hf - h1)); // 0 far .. 1 near
        let z = 0.08 + depth;
        let u = (x - wf * 0.5) / z / cw * 0.12 + skew * (y - h1) / cw;
        let v = 1.0 / z * 1.6;
        let (ci, cj) = (u.floor(), v.floor());
        let base = greens[(hash2(field_seed, ci as i64, cj as i64) % 6) as usize];
        // Hedgerows along field borders: width ~1.5 px in screen space.
        let du = (fract(u) - 0.5).abs();
        let dv = (fract(v) - 0.5).abs();
        let px_u = 0.12 / z / cw;
        let px_v = 1.6 / sq(z) / (hf - h1);
        let hedge = clamp01((du - 0.5) / px_u + 1.6).max(clamp01((dv - 0.5) / px_v + 1.6));
        let tex = 0.85 + 0.3 * (0.5 + 0.5 * n4.fbm(x * 0.08, y * 0.25, 4, 2.0, 0.5));
        let col = base.mix(Col::hex_linear(0x2a4418), hedge) * tex;
        col.mix(haze, 0.35 * (1.0 - depth))
    });
    // A row of distant trees on the hill crest.
    let ntrees_far = rng.int(4, 12);
    for _ in 0..ntrees_far {
        let tx = rng.range(0.0, wf);
        let ty = hill1(tx) + s * 0.003;
        let r = s * rng.range(0.008, 0.016);
        let blob = Blob::new(
            vec![
                (tx, ty - r, r),
                (tx - r * 0.7, ty - r * 0.6, r * 0.7),
                (tx + r * 0.7, ty - r * 0.6, r * 0.7),
            ],
            n5,
            r * 0.25,
            0.5 / r.max(1.0),
        );
        let base = Col::hex_linear(0x2c4a22).mix(haze, 0.3);
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, tx, ty - r, r * 1.4, light);
            base * (0.5 + 0.7 * lit)
        });
    }
    // Near meadow.
    let h2 = hf * rng.range(0.72, 0.82);
    let meadow = move |x: f64| h2 - s * 0.06 * (0.5 + 0.5 * n3.fbm1(x * 1.2 / s + 3.3, 4));
    let grass_a = Col::hex_linear(0x4e7d22);
    let grass_b = Col::hex_linear(0x8fae3c);
    c.draw(&below(meadow, [0.0, h2 - s * 0.07, wf, hf]), 1.0, |x, y| {
        let depth = clamp01((y - h2 + s * 0.06) / (hf - h2 + s * 0.06));
        let blades = 0.5 + 0.5 * n4.fbm(x * 0.35, y * 0.06, 4, 2.0, 0.6);
        let clumps = 0.5 + 0.5 * n5.fbm(x * 6.0 / s, y * 12.0 / s, 4, 2.0, 0.5);
        let col = grass_a.mix(grass_b, clumps * 0.8) * (0.55 + 0.6 * blades);
        col * (1.1 - 0.45 * depth)
    });
    // House on the meadow ridge: hard edges over soft background.
    let hx = wf * rng.range(0.15, 0.55);
    let hs = s * rng.range(0.09, 0.14);
    let gy = meadow(hx) + hs * 0.15;
    let wall = Col::hex_linear(0xe8e0d0);
    let roof = Col::hex_linear(0x8a3a28).mix(Col::hex_linear(0x4a4a50), rng.f64());
    let side_w = hs * 1.6;
    let depth_dy = hs * 0.18;
    let front = Polygon::new(vec![
        (hx, gy),
        (hx + hs, gy),
        (hx + hs, gy - hs * 0.7),
        (hx + hs * 0.5, gy - hs * 1.15),
        (hx, gy - hs * 0.7),
    ]);
    let side = Polygon::new(vec![
        (hx + hs, gy),
        (hx + hs + side_w, gy - depth_dy),
        (hx + hs + side_w, gy - hs * 0.7 - depth_dy),
        (hx + hs, gy - hs * 0.7),
    ]);
    let roof_side = Polygon::new(vec![
        (hx + hs * 0.5, gy - hs * 1.15),
        (hx + hs * 0.5 + side_w, gy - hs * 1.15 - depth_dy),
        (hx + hs + side_w + hs * 0.08, gy - hs * 0.66 - depth_dy),
        (hx + hs + hs * 0.08, gy - hs * 0.66),
    ]);
    let lit_front = 0.4 + 0.8 * (-light.0).max(0.0) + 0.3 * light.2;
    let lit_side = 0.4 + 0.8 * light.0.max(0.0) + 0.3 * light.2;
    c.fill(
        &soft_poly(
            Polygon::new(vec![
                (hx - hs * 0.1, gy + 1.0),
                (hx + hs + side_w + hs * 0.3, gy - depth_dy + 1.0),
                (hx + hs + side_w + hs * 0.6, gy + hs * 0.1),
                (hx, gy + hs * 0.12),
            ]),
            hs * 0.08,
        ),
        Col(0.05, 0.07, 0.03),
    );
    c.fill(&front, wall * lit_front);
    c.fill(&side, wall * lit_side * 0.85);
    c.draw(&roof_side, 1.0, |x, y| {
        // Tile rows parallel to the ridge.
        let t = (y - (gy - hs * 1.15) + (x - hx - hs * 0.5) * depth_dy / side_w) / (hs * 0.09);
        let line = clamp01(1.0 - (fract(t) - 0.05).abs() * hs * 0.09 / 0.8);
        roof * (0.75 + 0.3 * light.2) * (1.0 - 0.35 * line)
    });
    // Windows with frames on the side wall, door on the gable end.
    let nw = 3;
    for k in 0..nw {
        let wx = hx + hs + side_w * (0.15 + 0.3 * k as f64);
        let wy = gy - hs * 0.5 - depth_dy * (0.15 + 0.3 * k as f64);
        let ww = hs * 0.18;
        let wh = hs * 0.22;
        c.fill(
            &Polygon::new(vec![
                (wx, wy),
                (wx + ww, wy - ww * depth_dy / side_w),
                (wx + ww, wy + wh - ww * depth_dy / side_w),
                (wx, wy + wh),
            ]),
            Col(0.9, 0.9, 0.88),
        );
        let fr = (hs * 0.02).max(0.8);
        c.fill(
            &Polygon::new(vec![
                (wx + fr, wy + fr),
                (wx + ww - fr, wy + fr - ww * depth_dy / side_w),
                (wx + ww - fr, wy + wh - fr - ww * depth_dy / side_w),
                (wx + fr, wy + wh - fr),
            ]),
            Col(0.03, 0.04, 0.06),
        );
        c.fill(
            &Stroke::line(
                (wx + ww * 0.5, wy),
                (wx + ww * 0.5, wy + wh - ww * 0.5 * depth_dy / side_w),
                fr,
            ),
            Col(0.9, 0.9, 0.88),
        );
    }
    c.fill(
        &Polygon::rect(hx + hs * 0.38, gy - hs * 0.4, hx + hs * 0.62, gy),
        Col::hex_linear(0x3a2418),
    );
    c.fill(
        &Disc::new(hx + hs * 0.5, gy - hs * 0.85, hs * 0.07),
        Col(0.03, 0.03, 0.04),
    );
    // Trees in front of the meadow ridge.
    let ntrees = rng.int(2, 5);
    for _ in 0..ntrees {
        let mut tx = rng.range(0.0, wf);
        if (tx - hx - hs).abs() < hs * 1.5 {
            tx = (tx + wf * 0.5) % wf;
        }
        let ty = meadow(tx) + s * rng.range(0.0, 0.02);
        let th = s * rng.range(0.12, 0.25);
        let tw = th * 0.05;
        let cr = th * rng.range(0.3, 0.42);
        // Ground shadow away from the sun.
        let sd = if light.0 > 0.0 { -1.0 } else { 1.0 };
        flat_shadow(
            c,
            (tx + sd * cr * 0.8, ty + cr * 0.08),
            (cr * 1.3, cr * 0.18),
            cr * 0.15,
            0.55,
            Col(0.02, 0.04, 0.01),
        );
        c.fill(
            &Polygon::new(vec![
                (tx - tw, ty),
                (tx + tw, ty),
                (tx + tw * 0.5, ty - th * 0.7),
                (tx - tw * 0.5, ty - th * 0.7),
            ]),
            Col::hex_linear(0x3a2a1c),
        );
        let ccy = ty - th + cr;
        let mut discs = vec![(tx, ccy, cr)];
        for _ in 0..rng.int(4, 8) {
            let a = rng.range(0.0, TAU);
            let rr = cr * rng.range(0.35, 0.8);
            discs.push((tx + cos(a) * cr * 0.75, ccy + sin(a) * cr * 0.6, rr));
        }
        let blob = Blob::new(discs, n5, cr * 0.18, 2.5 / cr);
        let base = Col::hex_linear(0x2f5a1c).mix(Col::hex_linear(0x47702a), rng.f64());
        let leaf_f = 1.0 / (s * 0.006).max(1.0);
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, tx, ccy, cr * 1.2, light);
            let leaves = 0.5 + 0.5 * n4.fbm(x * leaf_f, y * leaf_f, 3, 2.0, 0.6);
            base * (0.2 + 1.1 * lit * (0.45 + 0.7 * leaves)) + Col(0.01, 0.015, 0.02)
        });
    }
    // Fence along the foreground.
    let fy = hf * rng.range(0.86, 0.93);
    let post_gap = s * rng.range(0.06, 0.1);
    let post_h = s * 0.06;
    let wood = Col::hex_linear(0x6a5a48);
    let mut px = rng.range(0.0, post_gap);
    let rail = |x: f64| fy - post_h * 0.8 + x * 0.02;
    while px < wf {
        let pw = (s * 0.006).max(1.2);
        c.fill(
            &Polygon::rect(px - pw, rail(px) - post_h * 0.3, px + pw, fy + px * 0.02),
            wood * 0.8,
        );
        px += post_gap;
    }
    for k in 0..2 {
        let off = post_h * 0.45 * k as f64;
        c.fill(
            &Stroke::line(
                (0.0, rail(0.0) + off),
                (wf, rail(wf) + off),
                (s * 0.005).max(1.0),
            ),
            wood,
        );
    }
    // Power line sagging across the sky, and birds.
    let py0 = horizon * rng.range(0.15, 0.5);
    let py1 = horizon * rng.range(0.15, 0.5);
    let sag = s * rng.range(0.03, 0.08);
    let pts: Vec<(f64, f64)> = (0..=64)
        .map(|k| {
            let t = k as f64 / 64.0;
            (t * wf, py0 + (py1 - py0) * t + sag * 4.0 * t * (1.0 - t))
        })
        .collect();
    c.fill(&Stroke::new(pts, 0.8), Col(0.03, 0.03, 0.035));
    birds(
        c,
        rng,
        (0.0, wf),
        (horizon * 0.1, horizon * 0.6),
        s * 0.01,
        Col(0.02, 0.02, 0.025),
    );
}

fn lake(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let water = hf * rng.range(0.55, 0.65);
    let sun = (
        wf * rng.range(0.25, 0.75),
        water - s * rng.range(0.12, 0.25),
    );
    let sun_r = s * 0.035;
    let top = Col::hex_linear(0x121a3a);
    let mid = Col::hex_linear(0x8a4a5a).mix(Col::hex_linear(0x6a4a7a), rng.f64());
    let low = Col::hex_linear(0xffb060).mix(Col::hex_linear(0xff9050), rng.f64());
    let f0 = rng.range(1.5, 2.5) / s;
    let cover = rng.range(0.0, 0.2);
    c.shade(|x, y| {
        let t = clamp01(y / water);
        let mut col = if t < 0.55 {
            top.mix(mid, smoothstep(0.0, 0.55, t))
        } else {
            mid.mix(low, smoothstep(0.55, 1.0, t))
        };
        let d = sqrt(sq(x - sun.0) + sq((y - sun.1) * 1.3)) / s;
        col = col + Col(1.0, 0.6, 0.25) * (1.2 * exp(-d * 10.0) + 0.3 * exp(-d * 3.0));
        let ds = sqrt(sq(x - sun.0) + sq(y - sun.1));
        col = col.mix(Col(5.0, 3.8, 2.2), clamp01(sun_r + 0.5 - ds));
        // Long streaky clouds lit from below.
        let dn = cloud_density(&n0, &n1, x, y, f0, cover, 5.0) * (1.0 - smoothstep(0.6, 1.0, t));
        if dn > 0.0 {
            let below = cloud_density(&n0, &n1, x, y + s * 0.01, f0, cover, 5.0);
            let lit = clamp01(0.3 + 1.5 * (dn - below) + 0.8 * t) * (0.6 + 0.8 * exp(-d * 2.5));
            let cl = Col(0.12, 0.07, 0.14).mix(Col(1.1, 0.55, 0.35), clamp01(lit));
            col = col.mix(cl, dn * 0.9);
        }
        col
    });
    // Two mountain ranges, with rim light and snow on the sunny side.
    for (k, (hgt, dark, haze)) in [(0.3, 0.1, 0.55), (0.18, 0.04, 0.25)]
        .into_iter()
        .enumerate()
    {
        let nn = if k == 0 { n2 } else { n3 };
        let base_y = water - s * 0.01;
        let mf = rng.range(2.5, 4.5) / s;
        let amp = s * hgt * rng.range(0.7, 1.1);
        let ridge = move |x: f64| base_y - amp * nn.ridged(x * mf + k as f64 * 10.0, 0.3, 5);
        let col_m = Col(0.09, 0.07, 0.12) * (dark * 10.0);
        let to_sun = if k == 0 { 1.0 } else { 0.7 };
        c.draw(
            &below(ridge, [0.0, base_y - amp - 2.0, wf, hf]),
            1.0,
            |x, y| {
                let r = ridge(x);
                let below_crest = (y - r) / amp;
                // Facets: lighting from the gradient of a 2-D height field.
                let hf2 = |x: f64, y: f64| nn.fbm(x * mf * 3.0, y * mf * 3.0, 6, 2.0, 0.5);
                let e = 2.0;
                let gx = (hf2(x + e, y) - hf2(x - e, y)) / (2.0 * e) * s * 0.05;
                let dir = if x < sun.0 { 1.0 } else { -1.0 };
                let lit = clamp01(0.45 + 2.0 * gx * dir * to_sun - 0.6 * below_crest);
                let tex = 0.5 + 0.5 * hf2(x * 3.0, y * 3.0);
                let snow =
                    smoothstep(0.6, 0.75, tex + 0.5 - below_crest * 3.0) * (k == 0) as u8 as f64;
                let rock = col_m * (0.7 + 0.5 * tex) * (0.5 + 0.9 * lit);
                let snowc = Col(0.85, 0.5, 0.42) * (0.3 + 0.8 * lit);
                let rim = Col(0.8, 0.4, 0.2) * exp(-below_crest * 40.0) * lit * 0.6;
                let col = rock.mix(snowc, snow) + rim;
                col.mix(low * 0.5, haze * (1.0 - below_crest).max(0.0) * 0.5)
            },
        );
    }
    // Pine forest along the shore.
    let pine_seed = rng.next_u64();
    let pine_w = s * 0.025;
    let pines = move |x: f64| {
        let i = (x / pine_w).floor() as i64;
        let mut best = water + 1.0;
        for k in i - 1..=i + 1 {
            let hsh = hash2(pine_seed, k, 0);
            let cx = (k as f64 + 0.3 + 0.4 * unit_f64(hsh)) * pine_w;
            let th = s * (0.03 + 0.06 * unit_f64(hsh >> 16));
            let slope = 3.2;
            let jag = 0.15 * th * (0.5 + 0.5 * sin((x - cx) * 2.4 / pine_w * TAU));
            let y = water - th + (x - cx).abs() * slope + jag;
            best = best.min(y);
        }
        best.min(water - s * 0.006 + s * 0.004 * n4.perlin(x * 0.02, 0.5))
    };
    c.draw(
        &below(pines, [0.0, water - s * 0.1, wf, water + 1.0]),
        1.0,
        |x, y| Col(0.012, 0.016, 0.018) * (0.8 + 0.4 * n5.perlin(x * 0.3, y * 0.3)),
    );
    // Water: rippled reflection of everything above the waterline, sun glitter.
    let snap = c.clone();
    let (w, h) = (c.w, c.h);
    let wi = water.floor() as usize;
    c.shade_rows_from(wi.min(h), |x, y| {
        let depth = (y - water) / (hf - water + 1.0);
        let rip = n4.fbm(x * 0.01, y * 0.3 / (0.05 + depth), 4, 2.0, 0.5);
        let dx = rip * s * 0.02 * (0.2 + depth);
        let ry = (2.0 * water - y + rip * s * 0.01 * depth).max(0.5);
        let sx = (x + dx).clamp(0.5, wf - 0.5);
        let ix = (sx as usize).min(w - 1);
        let iy = (ry as usize).min(h - 1);
        let refl = snap.get(ix, iy);
        let fresnel = 0.55 + 0.35 * (1.0 - depth);
        let mut col = refl * fresnel + Col(0.005, 0.01, 0.015);
        let band = exp(-sq((x - sun.0) / (s * (0.02 + 0.12 * depth))));
        let spark = smoothstep(
            0.25,
            0.6,
            n5.fbm(x * 0.08, y * 0.8 / (0.05 + depth), 3, 2.0, 0.5),
        );
        col = col + Col(3.0, 1.8, 0.8) * band * spark * 0.8;
        col
    });
    // A small boat.
    let bx = wf * rng.range(0.1, 0.8);
    let by = water + (hf - water) * rng.range(0.3, 0.6);
    let bl = s * rng.range(0.05, 0.08);
    c.fill(
        &Polygon::new(vec![
            (bx - bl, by - bl * 0.12),
            (bx + bl, by - bl * 0.12),
            (bx + bl * 0.75, by + bl * 0.05),
            (bx - bl * 0.8, by + bl * 0.05),
        ]),
        Col(0.01, 0.008, 0.008),
    );
    c.fill(
        &Stroke::line(
            (bx, by - bl * 0.12),
            (bx, by - bl * 1.2),
            (s * 0.003).max(0.8),
        ),
        Col(0.01, 0.008, 0.008),
    );
    c.fill(
        &Polygon::new(vec![
            (bx + bl * 0.05, by - bl * 1.15),
            (bx + bl * 0.7, by - bl * 0.2),
            (bx + bl * 0.05, by - bl * 0.2),
        ]),
        Col(0.5, 0.32, 0.22),
    );
    flat_shadow(
        c,
        (bx, by + bl * 0.3),
        (bl * 0.9, bl * 0.15),
        bl * 0.1,
        0.6,
        Col(0.005, 0.005, 0.008),
    );
    birds(
        c,
        rng,
        (0.0, wf),
        (water * 0.2, water * 0.6),
        s * 0.009,
        Col(0.01, 0.008, 0.01),
    );
}

fn still_life(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, _n4, _n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let table_y = hf * rng.range(0.55, 0.65);
    let front_y = hf * rng.range(0.86, 0.93);
    let lx = wf * rng.range(-0.2, 0.3);
    let ly = hf * rng.range(-0.3, 0.2);
    let light = normalize3((-0.6, -0.5, 0.65));
    let wall = Col::hex_linear(0xb8a890).mix(Col::hex_linear(0x8aa0a8), rng.f64());
    c.shade(|x, y| {
        let d2 = (sq(x - lx) + sq(y - ly)) / sq(s * 1.1);
        let lit = 0.18 + 0.9 * exp(-d2);
        let plaster = 1.0 + 0.04 * n0.fbm(x * 0.05, y * 0.05, 5, 2.0, 0.5);
        wall * lit * plaster
    });
    // Framed picture on the wall, with a soft shadow.
    let fw = s * rng.range(0.25, 0.35);
    let fh = fw * rng.range(0.7, 0.9);
    let fx = wf * rng.range(0.4, 0.6);
    let fy = table_y * 0.45;
    let border = fw * 0.07;
    c.draw(
        &soft_poly(
            Polygon::rect(
                fx - fw * 0.5 + border * 0.6,
                fy - fh * 0.5 + border * 0.9,
                fx + fw * 0.5 + border * 0.6,
                fy + fh * 0.5 + border * 0.9,
            ),
            border * 0.6,
        ),
        0.5,
        |_, _| Col(0.02, 0.015, 0.01),
    );
    c.draw(
        &Polygon::rect(fx - fw * 0.5, fy - fh * 0.5, fx + fw * 0.5, fy + fh * 0.5),
        1.0,
        |x, y| {
            Col::hex_linear(0x5a3a20)
                * (0.7
                    + 0.3 * n1.perlin(x * 0.2, y * 0.01)
                    + 0.2 * (1.0 - (y - fy + fh * 0.5) / fh))
        },
    );
    let (px0, py0, px1, py1) = (
        fx - fw * 0.5 + border,
        fy - fh * 0.5 + border,
        fx + fw * 0.5 - border,
        fy + fh * 0.5 - border,
    );
    c.fill(&Polygon::rect(px0, py0, px1, py1), Col(0.85, 0.83, 0.78));
    let m = border * 0.8;
    let (qx0, qy0, qx1, qy1) = (px0 + m, py0 + m, px1 - m, py1 - m);
    let ph = qy1 - qy0;
    let art_sun = (qx0 + (qx1 - qx0) * rng.range(0.2, 0.8), qy0 + ph * 0.3);
    c.draw(&Polygon::rect(qx0, qy0, qx1, qy1), 1.0, move |x, y| {
        let t = (y - qy0) / ph;
        let hill = qy0 + ph * (0.6 + 0.1 * sin((x - qx0) / (qx1 - qx0) * 5.0));
        if y > hill {
            Col(0.1, 0.25, 0.08) * (1.2 - 0.5 * (y - hill) / ph)
        } else if sq(x - art_sun.0) + sq(y - art_sun.1) < sq(ph * 0.1) {
            Col(0.9, 0.6, 0.2)
        } else {
            Col(0.6, 0.3, 0.2).mix(Col(0.2, 0.35, 0.6), 1.0 - t)
        }
    });
    // Table top (wood in perspective) and front edge.
    let grain_seed = n2;
    c.draw(
        &Polygon::rect(-1.0, table_y, wf + 1.0, hf + 1.0),
        1.0,
        |x, y| {
            let z = (y - table_y) / (front_y - table_y);
            let persp = 0.35 + 0.65 * z;
            let u = (x - wf * 0.5) / persp;
            let v = z * s * 0.6;
            let rings = fract(v * 0.06 + 1.5 * grain_seed.fbm(u * 0.004, v * 0.03, 4, 2.0, 0.5));
            let wood = Col::hex_linear(0x7a4a24)
                .mix(Col::hex_linear(0x4a2812), smoothstep(0.3, 0.9, rings));
            let spec = 0.25 * exp(-sq((x - wf * 0.35) / (s * 0.3)) - sq(z - 0.3) * 6.0);
            if y < front_y {
                wood * (0.45 + 0.55 * z) + Col::gray(spec * 0.5)
            } else {
                wood * 0.22
            }
        },
    );
    c.fill(
        &Stroke::line((0.0, front_y), (wf, front_y), (s * 0.004).max(1.0)),
        Col::hex_linear(0xa0764a),
    );
    // Objects, back to front: books, vase, fruit.
    let shadow = Col(0.015, 0.01, 0.005);
    let bx = wf * rng.range(0.05, 0.2);
    let by = table_y + (front_y - table_y) * 0.35;
    let mut yb = by;
    let nbooks = rng.int(2, 4);
    for k in 0..nbooks {
        let bw = s * rng.range(0.28, 0.36);
        let bh = s * rng.range(0.03, 0.05);
        let x0 = bx + rng.range(-0.02, 0.02) * s;
        let cover = Col::hex_linear(*rng.pick(&[0x7a1e1e, 0x1e3a6a, 0x2a5a3a, 0x6a5a2a, 0x3a2a4a]));
        if k == 0 {
            c.draw(
                &soft_poly(
                    Polygon::rect(
                        x0 + s * 0.02,
                        by - s * 0.01,
                        x0 + bw + s * 0.06,
                        by + s * 0.02,
                    ),
                    s * 0.015,
                ),
                0.7,
                move |_, _| shadow,
            );
        }
        // Top face (pages visible on the top book only as a thin band), spine face.
        c.fill(
            &Polygon::new(vec![
                (x0, yb - bh),
                (x0 + bw, yb - bh),
                (x0 + bw + s * 0.02, yb - bh - s * 0.012),
                (x0 + s * 0.02, yb - bh - s * 0.012),
            ]),
            cover * 0.9,
        );
        c.fill(&Polygon::rect(x0, yb - bh, x0 + bw, yb), cover * 0.55);
        c.draw(
            &Polygon::rect(x0 + bw, yb - bh, x0 + bw + s * 0.02, yb - s * 0.012 * 0.0),
            1.0,
            |_, y| Col(0.75, 0.7, 0.6) * (0.6 + 0.4 * fract(y * 1.3)),
        );
        let style = TextStyle::upright(
            (bh * 0.22).max(1.5),
            (bh * 0.05).max(0.6),
            Col(0.85, 0.75, 0.45),
        );
        draw_line(c, rng, &style, x0 + bw * 0.1, x0 + bw * 0.7, yb - bh * 0.35);
        yb -= bh;
    }
    // Vase: cylinder with a glaze highlight.
    let vx = wf * rng.range(0.45, 0.6);
    let vr = s * rng.range(0.05, 0.08);
    let vh = s * rng.range(0.22, 0.32);
    let vb = table_y + (front_y - table_y) * 0.25;
    let glaze = Col::hex_linear(*rng.pick(&[0x2a4a8a, 0xd8d4cc, 0x3a6a5a, 0x9a3a2a]));
    flat_shadow(
        c,
        (vx + vr * 1.3, vb),
        (vr * 2.2, vr * 0.35),
        vr * 0.3,
        0.8,
        shadow,
    );
    let body = Polygon::new(
        (0..=24)
            .map(|k| {
                let t = k as f64 / 24.0;
                let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
                (vx - r, vb - vh * t)
            })
            .chain((0..=24).rev().map(|k| {
                let t = k as f64 / 24.0;
                let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
                (vx + r, vb - vh * t)
            }))
            .collect(),
    );
    c.draw(&body, 1.0, |x, y| {
        let t = (vb - y) / vh;
        let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
        let nx = ((x - vx) / r).clamp(-1.0, 1.0);
        let nz = sqrt(1.0 - nx * nx);
        let diff = (nx * light.0 + nz * light.2).max(0.0) + 0.1;
        let hl = exp(-sq((nx + 0.45) * 9.0)) * 0.8;
        glaze * (0.15 + 0.85 * diff) + Col::gray(hl)
    });
    c.fill(
        &Ellipse {
            cx: vx,
            cy: vb - vh,
            rx: vr * 0.75 * 1.0 + vr * 0.35 * sin(1.2 * PI),
            ry: vr * 0.18,
            rot: (1.0, 0.0),
        },
        glaze * 0.6,
    );
    c.fill(
        &Ellipse {
            cx: vx,
            cy: vb - vh,
            rx: vr * 0.55,
            ry: vr * 0.12,
            rot: (1.0, 0.0),
        },
        Col(0.01, 0.01, 0.01),
    );
    // Fruit: shaded spheres with specular highlights and contact shadows.
    let nf = rng.int(2, 4);
    for k in 0..nf {
        let fr = s * rng.range(0.045, 0.07);
        let fx = wf * (0.6 + 0.12 * k as f64) + rng.range(-0.03, 0.03) * s;
        let fy = table_y + (front_y - table_y) * rng.range(0.45, 0.8) - fr;
        let base = Col::hex_linear(*rng.pick(&[0xe07010, 0xb01818, 0x6a9a20, 0xd0b020]));
        flat_shadow(
            c,
            (fx + fr * 0.5, fy + fr * 0.9),
            (fr * 1.4, fr * 0.3),
            fr * 0.3,
            0.85,
            shadow,
        );
        let spot = n3;
        c.draw(&Disc::new(fx, fy, fr), 1.0, |x, y| {
            let (lit, n) = sphere_light(x, y, fx, fy, fr, light);
            let hv = normalize3((light.0, light.1, light.2 + 1.0));
            let spec = pow((n.0 * hv.0 + n.1 * hv.1 + n.2 * hv.2).max(0.0), 60.0);
            let bounce = clamp01(n.1) * 0.15;
            let pores = 1.0 + 0.06 * spot.perlin(x * 0.6, y * 0.6);
            base * (0.06 + 0.94 * lit) * pores
                + Col(0.25, 0.15, 0.08) * bounce
                + Col::gray(spec * 0.9)
        });
        c.fill(
            &Stroke::new(
                vec![
                    (fx, fy - fr * 0.85),
                    (fx + fr * 0.1, fy - fr * 1.15),
                    (fx + fr * 0.25, fy - fr * 1.25),
                ],
                (fr * 0.08).max(0.8),
            ),
            Col(0.06, 0.04, 0.02),
        );
    }
}

fn coast(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let horizon = hf * rng.range(0.4, 0.5);
    let zen = Col::hex_linear(0x3068b8);
    let hor = Col::hex_linear(0xd0e0ee);
    let sun = (wf * rng.range(0.6, 1.1), -s * rng.range(0.0, 0.2));
    let f0 = rng.range(2.5, 4.0) / s;
    let cover = rng.range(0.05, 0.3);
    let sea_far = Col::hex_linear(0x3a7090);
    let sea_near = Col::hex_linear(0x0e3a48);
    c.shade(|x, y| {
        if y < horizon {
            let t = clamp01(y / horizon);
            let mut col = zen.mix(hor, pow(t, 2.0));
            let d = sqrt(sq(x - sun.0) + sq(y - sun.1)) / s;
            col = col + Col(0.8, 0.7, 0.5) * 0.6 * exp(-d * 3.0);
            let dn =
                cloud_density(&n0, &n1, x, y, f0, cover, 2.5) * (1.0 - smoothstep(0.6, 1.0, t));
            if dn > 0.0 {
                let tw = cloud_density(&n0, &n1, x + s * 0.006, y - s * 0.006, f0, cover, 2.5);
                let lit = clamp01(1.0 - 1.8 * (tw - dn).max(0.0) - 0.25 * dn);
                col = col.mix(Col(0.5, 0.55, 0.65).mix(Col(1.05, 1.03, 1.0), lit), dn);
            }
            col
        } else {
            let z = (y - horizon) / (hf - horizon); // 0 at horizon, 1 at bottom
            let zz = 0.02 + z;
            let waves = n2.fbm(x * 0.02 / zz, 3.0 / zz, 5, 2.0, 0.55);
            let fine = n3.fbm(x * 0.1 / zz, 12.0 / zz, 3, 2.0, 0.5);
            let fres = 0.5 * (1.0 - smoothstep(0.0, 0.5, z));
            let base = sea_far.mix(sea_near, smoothstep(0.0, 0.8, z));
            let skyref = hor * 0.8;
            let mut col = base.mix(skyref, fres) * (0.8 + 0.3 * waves + 0.1 * fine);
            let glint =
                smoothstep(0.55, 0.8, fine * 0.5 + waves * 0.7) * exp(-sq((x - sun.0) / (s * 0.5)));
            col = col + Col::gray(glint * 0.8);
            col
        }
    });
    // Headland with a cliff face and a grassy top.
    let hl_end = wf * rng.range(0.3, 0.45);
    let hl_top = horizon - s * rng.range(0.08, 0.14);
    let cliff_top = move |x: f64| {
        let t = clamp01(x / hl_end);
        hl_top
            + (horizon + s * 0.01 - hl_top) * smoothstep(0.55, 1.0, t)
            + s * 0.012 * n4.fbm1(x * 0.02, 4)
    };
    let grass = Col::hex_linear(0x5a7a2a);
    let rock = Col::hex_linear(0x7a6e62);
    let waterline = horizon + s * 0.018;
    let headland = SdfShape {
        bb: [0.0, hl_top - s * 0.05, hl_end + s * 0.05, waterline + 1.0],
        f: move |x: f64, y: f64| {
            let c = cliff_top(x);
            let d = cliff_top(x + 0.5) - cliff_top(x - 0.5);
            ((c - y) / sqrt(1.0 + d * d)).max(y - waterline)
        },
    };
    c.draw(&headland, 1.0, |x, y| {
        let top = cliff_top(x);
        let band = s * (0.02 + 0.01 * n5.perlin(x * 0.05, 0.3));
        let strata = n4.ridged(x * 0.03, y * 0.006, 5);
        let face = rock * (0.45 + 0.7 * strata) * (0.6 + 0.5 * (1.0 - x / hl_end));
        let g = grass * (0.7 + 0.5 * (0.5 + 0.5 * n5.fbm(x * 0.2, y * 0.2, 3, 2.0, 0.5)));
        if y - top < band {
            g
        } else {
            face
        }
    });
    // Foam where the cliff meets the sea.
    let foam_band = SdfShape {
        bb: [
            0.0,
            waterline - s * 0.01,
            hl_end + s * 0.1,
            waterline + s * 0.03,
        ],
        f: move |x: f64, y: f64| {
            let end = cliff_top(x) > waterline - s * 0.002;
            let t =
                (y - waterline - s * 0.006 * (1.0 + n3.perlin(x * 0.05, 1.0))).abs() - s * 0.006;
            if end {
                t.max(x - hl_end - s * 0.02)
            } else {
                t
            }
        },
    };
    c.draw(&foam_band, 0.9, |x, y| {
        let f = smoothstep(0.0, 0.7, 0.5 + 0.5 * n2.fbm(x * 0.08, y * 0.3, 4, 2.0, 0.5));
        sea_far.mix(Col(0.85, 0.88, 0.9), 0.3 + 0.7 * f)
    });
    // Lighthouse with red and white bands, gallery railing, lantern.
    let lx = hl_end * rng.range(0.3, 0.55);
    let base_y = cliff_top(lx) + s * 0.01;
    let th = s * rng.range(0.16, 0.22);
    let rb = th * 0.11;
    let rt = th * 0.075;
    let red = Col::hex_linear(0xb8202a);
    let white = Col::hex_linear(0xf0eee8);
    let bands = 4.0;
    let tower = Polygon::new(vec![
        (lx - rb, base_y),
        (lx + rb, base_y),
        (lx + rt, base_y - th),
        (lx - rt, base_y - th),
    ]);
    c.draw(&tower, 1.0, |x, y| {
        let t = (base_y - y) / th;
        let r = rb + (rt - rb) * t;
        let nx = ((x - lx) / r).clamp(-1.0, 1.0);
        let lit = 0.25 + 0.85 * (0.5 + 0.5 * nx).max(0.0);
        let band = (t * bands * 2.0).floor() as i64 % 2 == 0;
        (if band { white } else { red }) * lit
    });
    let gy = base_y - th;
    c.fill(
        &Polygon::rect(
            lx - rt * 1.5,
            gy - th * 0.02,
            lx + rt * 1.5,
            gy + th * 0.015,
        ),
        Col(0.05, 0.05, 0.05),
    );
    let lh = th * 0.14;
    c.draw(
        &Polygon::rect(
            lx - rt * 0.8,
            gy - th * 0.02 - lh,
            lx + rt * 0.8,
            gy - th * 0.02,
        ),
        1.0,
        |x, _| Col(0.9, 0.85, 0.55) * (0.6 + 0.4 * (x - lx + rt) / (2.0 * rt)),
    );
    let post_w = (s * 0.0025).max(0.6);
    let nposts = 7;
    for k in 0..=nposts {
        let px = lx - rt * 1.4 + rt * 2.8 * k as f64 / nposts as f64;
        c.fill(
            &Stroke::line(
                (px, gy - th * 0.02),
                (px, gy - th * 0.02 - th * 0.05),
                post_w,
            ),
            Col(0.04, 0.04, 0.04),
        );
    }
    c.fill(
        &Stroke::line(
            (lx - rt * 1.45, gy - th * 0.07),
            (lx + rt * 1.45, gy - th * 0.07),
            post_w,
        ),
        Col(0.04, 0.04, 0.04),
    );
    for k in 0..3 {
        let px = lx - rt * 0.8 + rt * 1.6 * (k as f64 + 0.5) / 3.0;
        c.fill(
            &Stroke::line((px, gy - th * 0.02), (px, gy - th * 0.02 - lh), post_w),
            Col(0.05, 0.05, 0.05),
        );
    }
    let cap = Polygon::new(closed_spline(
        &[
            (lx - rt * 0.95, gy - th * 0.02 - lh),
            (lx, gy - th * 0.02 - lh - rt * 0.9),
            (lx + rt * 0.95, gy - th * 0.02 - lh),
        ],
        8,
    ));
    c.fill(&cap, Col::hex_linear(0x301010));
    // Keeper's cottage.
    let kx = lx + rb * 1.6;
    let kw = th * 0.4;
    let kh = th * 0.2;
    let ky = cliff_top(kx + kw * 0.5) + s * 0.012;
    c.fill(&Polygon::rect(kx, ky - kh, kx + kw, ky), white * 0.8);
    c.fill(
        &Polygon::new(vec![
            (kx - kw * 0.05, ky - kh),
            (kx + kw * 1.05, ky - kh),
            (kx + kw * 0.85, ky - kh * 1.6),
            (kx + kw * 0.15, ky - kh * 1.6),
        ]),
        Col::hex_linear(0x3a3a40),
    );
    for k in 0..2 {
        let wx = kx + kw * (0.2 + 0.45 * k as f64);
        c.fill(
            &rounded_rect(wx, ky - kh * 0.75, wx + kw * 0.18, ky - kh * 0.35, 0.5),
            Col(0.05, 0.07, 0.1),
        );
    }
    // Beach in the lower right with wet sand and a foam line.
    let shore = {
        let a = hf * rng.range(0.7, 0.8);
        move |x: f64| a + (hf - a) * 0.8 * (1.0 - x / wf) + s * 0.015 * n4.fbm1(x * 0.01, 4)
    };
    let sand = Col::hex_linear(0xd8c098);
    c.draw(&below(shore, [0.0, hf * 0.6, wf, hf]), 1.0, |x, y| {
        let d = (y - shore(x)) / s;
        let fine = unit_f64(hash2(77, x as i64, y as i64));
        let ripples = 0.5
            + 0.5 * sin((x * 0.3 + y * 0.9) / (s * 0.004) + 3.0 * n5.perlin(x * 0.02, y * 0.02));
        let wet = 1.0 - smoothstep(0.0, 0.05, d);
        let col = sand * (0.82 + 0.1 * fine + 0.08 * ripples) * (1.0 - 0.45 * wet);
        let foam = smoothstep(
            0.45,
            0.8,
            0.5 + 0.5 * n2.fbm(x * 0.05, y * 0.2, 4, 2.0, 0.5),
        ) * (1.0 - smoothstep(0.0, 0.012, d));
        col.mix(Col(0.9, 0.92, 0.95), foam)
    });
    // Rocks in the surf.
    let nrocks = rng.int(2, 4);
    for _ in 0..nrocks {
        let rx = wf * rng.range(0.4, 0.95);
        let ry = shore(rx) - s * rng.range(0.0, 0.08);
        let rr = s * rng.range(0.025, 0.05);
        let blob = Blob::new(
            vec![(rx, ry, rr), (rx + rr * 0.6, ry + rr * 0.2, rr * 0.7)],
            n1,
            rr * 0.25,
            1.5 / rr,
        );
        let (bcx, bcy, brad) = blob.centre();
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, bcx, bcy, brad, normalize3((0.5, -0.6, 0.6)));
            let tex = 0.6 + 0.6 * n3.ridged(x * 0.08, y * 0.08, 4);
            Col(0.09, 0.08, 0.075) * tex * (0.35 + 1.1 * lit)
        });
        let foam = Blob::new(
            (0..6)
                .map(|k| {
                    (
                        rx - rr * 0.9 + rr * 0.45 * k as f64,
                        ry + rr * 0.85,
                        rr * 0.18,
                    )
                })
                .collect(),
            n2,
            rr * 0.12,
            4.0 / rr,
        );
        c.draw(&foam, 0.6, |x, y| {
            Col(0.8, 0.84, 0.88) * (0.8 + 0.2 * n4.perlin(x * 0.3, y * 0.3))
        });
    }
    birds(
        c,
        rng,
        (wf * 0.3, wf),
        (horizon * 0.15, horizon * 0.7),
        s * 0.008,
        Col(0.03, 0.03, 0.035),
    );
    let _ = n0;
}
