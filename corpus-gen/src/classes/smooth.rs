//! Smooth class: low-frequency content only (gradients, Gaussian blobs, long waves).
//! Every variant is an infinitely differentiable function of position whose
//! spectrum is concentrated below ~2 cycles per image.

use super::{format, rng_for};
use crate::canvas::{Canvas, Encoding};
use crate::image::CorpusImage;
use crate::math::{cos, exp, hsv, sin, smoothstep, sq, Col, PI, TAU};
use crate::rng::Rng;
use crate::Class;

fn random_colour(rng: &mut Rng) -> Col {
    hsv(rng.f64(), rng.range(0.2, 0.85), rng.range(0.25, 0.95))
}

/// Smooth interpolation through colour stops at equal spacing; `t` in [0, 1].
fn stops(cols: &[Col], t: f64) -> Col {
    let n = cols.len() - 1;
    let u = t.clamp(0.0, 1.0) * n as f64;
    let i = (u.floor() as usize).min(n - 1);
    let f = u - i as f64;
    // Smootherstep: C2 at the stops.
    let s = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    cols[i].mix(cols[i + 1], s)
}

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::Smooth, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.max(hf);
    let mut c = Canvas::new(w, h, Col::gray(0.5));
    match seed % 4 {
        0 => {
            // Linear gradient through 2-4 stops along a random direction, with a
            // weak perpendicular tint.
            let a = rng.range(0.0, TAU);
            let (ca, sa) = (cos(a), sin(a));
            let n = 2 + rng.below(3) as usize;
            let cols: Vec<Col> = (0..n).map(|_| random_colour(&mut rng)).collect();
            let tint = random_colour(&mut rng);
            let tint_amt = rng.range(0.0, 0.25);
            let ext = wf * ca.abs() + hf * sa.abs();
            c.shade(|x, y| {
                let dx = x - wf * 0.5;
                let dy = y - hf * 0.5;
                let t = (dx * ca + dy * sa) / ext + 0.5;
                let u = (-dx * sa + dy * ca) / ext + 0.5;
                stops(&cols, t).mix(tint, tint_amt * smoothstep(0.0, 1.0, u))
            });
        }
        1 => {
            // Gaussian-profile radial gradients (smooth everywhere, no cusp at the centre).
            let bg = hsv(rng.f64(), rng.range(0.3, 0.8), rng.range(0.15, 0.4));
            let k = 2 + rng.below(2) as usize;
            let spots: Vec<(f64, f64, f64, Col, f64)> = (0..k)
                .map(|_| {
                    let cx = rng.range(0.05, 0.95) * wf;
                    let cy = rng.range(0.05, 0.95) * hf;
                    let r = rng.range(0.3, 0.6) * s;
                    (
                        cx,
                        cy,
                        r,
                        hsv(rng.f64(), rng.range(0.4, 0.9), rng.range(0.7, 1.0)),
                        rng.range(0.85, 1.0),
                    )
                })
                .collect();
            c.shade(|x, y| {
                let mut col = bg;
                for &(cx, cy, r, sc, amt) in &spots {
                    let d2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (r * r);
                    col = col.mix(sc, amt * exp(-d2));
                }
                col
            });
        }
        2 => {
            // Sum of large Gaussian blobs over a soft two-colour background.
            let top = random_colour(&mut rng);
            let bottom = random_colour(&mut rng);
            let k = 5 + rng.below(6) as usize;
            let blobs: Vec<(f64, f64, f64, f64, Col)> = (0..k)
                .map(|_| {
                    let cx = rng.range(0.0, wf);
                    let cy = rng.range(0.0, hf);
                    let sx = rng.range(0.12, 0.3) * s;
                    let sy = rng.range(0.12, 0.3) * s;
                    (cx, cy, sx, sy, random_colour(&mut rng))
                })
                .collect();
            c.shade(|x, y| {
                let mut col = top.mix(bottom, smoothstep(0.0, 1.0, y / hf));
                for &(cx, cy, sx, sy, bc) in &blobs {
                    let g = exp(-0.5 * (sq((x - cx) / sx) + sq((y - cy) / sy)));
                    col = col.mix(bc, 0.8 * g);
                }
                col
            });
        }
        _ => {
            // A few long plane waves through a gentle cosine palette.
            let k = 3 + rng.below(3) as usize;
            let waves: Vec<(f64, f64, f64, f64)> = (0..k)
                .map(|_| {
                    let a = rng.range(0.0, PI);
                    let cycles = rng.range(0.3, 1.5);
                    (
                        cos(a) * cycles / s,
                        sin(a) * cycles / s,
                        rng.range(0.0, TAU),
                        rng.range(0.5, 1.0),
                    )
                })
                .collect();
            let norm: f64 = waves.iter().map(|w| w.3).sum();
            let base = Col(
                rng.range(0.35, 0.65),
                rng.range(0.35, 0.65),
                rng.range(0.35, 0.65),
            );
            let amp = Col(
                rng.range(0.15, 0.35),
                rng.range(0.15, 0.35),
                rng.range(0.15, 0.35),
            );
            let phase = Col(
                rng.range(0.0, TAU),
                rng.range(0.0, TAU),
                rng.range(0.0, TAU),
            );
            c.shade(|x, y| {
                let mut v = 0.0;
                for &(fx, fy, ph, a) in &waves {
                    v += a * sin(TAU * (fx * x + fy * y) + ph);
                }
                let t = v / norm; // in [-1, 1]
                Col(
                    base.0 + amp.0 * sin(1.3 * t + phase.0),
                    base.1 + amp.1 * sin(1.3 * t + phase.1),
                    base.2 + amp.2 * sin(1.3 * t + phase.2),
                )
            });
        }
    }
    let (ch, fmt) = format(Class::Smooth, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Display)
}
