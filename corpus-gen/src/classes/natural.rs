//! Natural class: fractal-noise materials with lighting, rendered in linear light
//! and sRGB-encoded. Terrain (hill-shaded relief), clouds (self-shadowed), marble
//! (turbulent veins, polished highlight) and wood planks (rings, grain, seams).

use super::{format, noise_seed, rng_for};
use crate::canvas::{field, Canvas, Encoding};
use crate::image::CorpusImage;
use crate::math::{clamp01, cos, exp, fract, sin, smoothstep, sqrt, Col, PI, TAU};
use crate::noise::Noise;
use crate::rng::{hash2, unit_f64};
use crate::Class;

/// Piecewise-linear colour ramp over sorted keys.
fn ramp(keys: &[(f64, Col)], t: f64) -> Col {
    if t <= keys[0].0 {
        return keys[0].1;
    }
    for k in 1..keys.len() {
        if t <= keys[k].0 {
            let (t0, c0) = keys[k - 1];
            let (t1, c1) = keys[k];
            return c0.mix(c1, (t - t0) / (t1 - t0));
        }
    }
    keys[keys.len() - 1].1
}

fn normalize3(x: f64, y: f64, z: f64) -> (f64, f64, f64) {
    let l = sqrt(x * x + y * y + z * z);
    (x / l, y / l, z / l)
}

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::Natural, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.max(hf);
    let n1 = Noise::new(noise_seed(Class::Natural, seed, 1));
    let n2 = Noise::new(noise_seed(Class::Natural, seed, 2));
    let mut c = Canvas::new(w, h, Col::gray(0.2));
    match seed % 4 {
        0 => {
            // Terrain seen from above, hill-shaded.
            let f0 = rng.range(2.0, 4.0) / s;
            let (ox, oy) = (rng.range(0.0, 100.0), rng.range(0.0, 100.0));
            let sea = rng.range(-0.15, 0.05);
            let ridge_amt = rng.range(0.3, 0.6);
            let height = |x: f64, y: f64| {
                let u = x * f0 + ox;
                let v = y * f0 + oy;
                (1.0 - ridge_amt) * n1.fbm(u, v, 8, 2.0, 0.5)
                    + ridge_amt * (n2.ridged(u * 0.7, v * 0.7, 7) * 1.4 - 0.6)
            };
            // Height field with a one-pixel border for the gradient.
            let (bw, bh) = (w + 2, h + 2);
            let hf_ = field(bw, bh, |x, y| height(x - 1.0, y - 1.0));
            let relief = s * rng.range(0.12, 0.22);
            let la = rng.range(0.6, 1.4) * PI; // light azimuth, from the upper left-ish
            let light = normalize3(cos(la), sin(la) * 0.8 - 0.6, 1.1);
            let keys = [
                (-1.0, Col::hex_linear(0x0a2a4a)),
                (sea - 0.08, Col::hex_linear(0x1d5578)),
                (sea, Col::hex_linear(0x2f7f8f)),
                (sea + 0.02, Col::hex_linear(0xd8c89a)),
                (sea + 0.07, Col::hex_linear(0x6f9a3c)),
                (sea + 0.25, Col::hex_linear(0x3c6a2a)),
                (sea + 0.42, Col::hex_linear(0x7a6a55)),
                (sea + 0.55, Col::hex_linear(0x9a9288)),
                (sea + 0.62, Col::hex_linear(0xf4f4f6)),
                (2.0, Col::hex_linear(0xffffff)),
            ];
            c.shade(|x, y| {
                let i = x as usize + 1;
                let j = y as usize + 1;
                let hv = hf_[j * bw + i];
                let base = ramp(&keys, hv);
                if hv < sea {
                    // Water: flat, lit from above, with faint ripples.
                    let rip = n2.perlin(x * 0.15, y * 0.6) * 0.04;
                    return base * (0.85 + rip);
                }
                let dx = (hf_[j * bw + i + 1] - hf_[j * bw + i - 1]) * 0.5 * relief;
                let dy = (hf_[(j + 1) * bw + i] - hf_[(j - 1) * bw + i]) * 0.5 * relief;
                let nrm = normalize3(-dx, -dy, 1.0);
                let slope = 1.0 - nrm.2;
                let rock = Col::hex_linear(0x6b6258);
                let base = base.mix(
                    rock,
                    smoothstep(0.25, 0.5, slope) * (1.0 - smoothstep(sea + 0.55, sea + 0.62, hv)),
                );
                let diff = (nrm.0 * light.0 + nrm.1 * light.1 + nrm.2 * light.2).max(0.0);
                let sky = 0.25 + 0.1 * nrm.2;
                base * (sky + 0.95 * diff)
            });
        }
        1 => {
            // Clouds in a blue sky, lit from the sun's side.
            let f0 = rng.range(2.0, 3.5) / s;
            let cover = rng.range(-0.15, 0.15);
            let (ox, oy) = (rng.range(0.0, 50.0), rng.range(0.0, 50.0));
            let zen = Col::hex_linear(0x1f5fb8).mix(Col::hex_linear(0x3a70c8), rng.f64());
            let hor = Col::hex_linear(0xa9c8e8);
            let sa = rng.range(-0.8, -0.2) * PI;
            let sun = (cos(sa) * s * 0.012, sin(sa) * s * 0.012);
            let density = |x: f64, y: f64| {
                let u = x * f0 + ox;
                let v = y * f0 * 1.8 + oy;
                let wx = n2.fbm(u * 0.5, v * 0.5, 4, 2.0, 0.5);
                let wy = n2.fbm(u * 0.5 + 7.7, v * 0.5 + 1.3, 4, 2.0, 0.5);
                let d = n1.fbm(u + 0.8 * wx, v + 0.8 * wy, 8, 2.0, 0.52);
                smoothstep(cover - 0.05, cover + 0.35, d)
            };
            c.shade(|x, y| {
                let t = y / hf;
                let sky = zen.mix(hor, smoothstep(0.0, 1.0, t));
                let d = density(x, y);
                if d <= 0.0 {
                    return sky;
                }
                let toward = density(x + sun.0, y + sun.1);
                let lit = clamp01(1.0 - 1.6 * (toward - d).max(0.0) - 0.35 * d);
                let shadow = Col::hex_linear(0x8a93a8);
                let cloud = shadow.mix(Col::gray(1.0), lit);
                sky.mix(cloud, d)
            });
        }
        2 => {
            // Polished marble slab: turbulent veins, soft reflection highlight.
            let warm = rng.chance(0.7);
            let (base, vein, vein2) = if warm {
                (
                    Col::hex_linear(0xefe9e0),
                    Col::hex_linear(0x4a4440),
                    Col::hex_linear(0xb59a7a),
                )
            } else {
                (
                    Col::hex_linear(0x1f4a3a),
                    Col::hex_linear(0xe8efe8),
                    Col::hex_linear(0x0c1a14),
                )
            };
            let f0 = rng.range(2.0, 4.0) / s;
            let ang = rng.range(0.0, PI);
            let (ka, kb) = (
                cos(ang) * rng.range(1.5, 3.0) * TAU / s,
                sin(ang) * rng.range(1.5, 3.0) * TAU / s,
            );
            let strength = rng.range(5.0, 9.0);
            let hx = rng.range(0.2, 0.8) * wf;
            let hy = rng.range(0.1, 0.5) * hf;
            let hr = s * rng.range(0.3, 0.6);
            c.shade(|x, y| {
                let t = n1.turbulence(x * f0, y * f0, 7);
                let v = sin(x * ka + y * kb + strength * t);
                let veins = exp(-v.abs() * 5.0);
                let fine = exp(-sin(x * kb * 3.1 - y * ka * 3.1
                    + 9.0 * n2.turbulence(x * f0 * 2.0, y * f0 * 2.0, 5))
                .abs()
                    * 14.0);
                let cloudy = 0.5 + 0.5 * n2.fbm(x * f0 * 0.7, y * f0 * 0.7, 5, 2.0, 0.5);
                let col = base
                    .mix(vein2, 0.35 * cloudy)
                    .mix(vein, 0.85 * veins)
                    .mix(vein, 0.35 * fine);
                // Lighting: a broad reflected window highlight plus falloff.
                let d2 = ((x - hx) * (x - hx) + (y - hy) * (y - hy)) / (hr * hr);
                let spec = 0.18 * exp(-d2);
                let fall = 0.8 + 0.2 * (1.0 - clamp01(y / hf));
                col * fall + Col::gray(spec)
            });
        }
        _ => {
            // Wood planks: growth rings, fine grain, dark seams, raking light.
            let ph = (s * rng.range(0.1, 0.2)).max(3.0);
            let light = Col::hex_linear(0xc89a62).mix(Col::hex_linear(0xe0b884), rng.f64());
            let dark = Col::hex_linear(0x6a3f1c).mix(Col::hex_linear(0x8a5a2e), rng.f64());
            let pseed = rng.next_u64();
            let ring_f = rng.range(0.08, 0.16) * 512.0 / s;
            let grain_f = 512.0 / s;
            c.shade(|x, y| {
                let row = (y / ph).floor();
                let ly = y - row * ph;
                // Planks have staggered end joints.
                let plen = ph * 6.0;
                let off = unit_f64(hash2(pseed, row as i64, 0)) * plen;
                let col_i = ((x + off) / plen).floor();
                let lx = x + off - col_i * plen;
                let pid = hash2(pseed, row as i64, col_i as i64);
                let r0 = unit_f64(pid) * 40.0 + 5.0;
                let shift = unit_f64(pid >> 7) * 1000.0;
                let tone = 0.85 + 0.3 * unit_f64(pid >> 13);
                // Rings: distance from the log's centre line, bent by noise.
                let d = (ly + r0) * ring_f * 0.35
                    + 2.2
                        * n1.fbm(
                            (lx + shift) * 0.004 * grain_f,
                            (ly + shift) * 0.02 * grain_f,
                            4,
                            2.0,
                            0.5,
                        );
                let r = fract(d);
                let ringv = smoothstep(0.0, 0.75, r) * (1.0 - smoothstep(0.85, 1.0, r));
                let grain = 0.5
                    + 0.5
                        * n2.perlin(
                            (lx + shift) * 0.015 * grain_f,
                            (ly + shift) * 0.25 * grain_f,
                        );
                let mut col = dark.mix(light, 0.25 + 0.6 * ringv) * (tone * (0.9 + 0.15 * grain));
                // Seams: dark grooves between planks and at the butt joints.
                let seam = (ly.min(ph - ly)).min(lx.min(plen - lx));
                let groove = clamp01(1.2 - seam);
                col = col * (1.0 - 0.75 * groove);
                // Raking light from the left with a varnish sheen.
                let sheen = 0.08
                    * exp(-((x / wf - 0.3) * (x / wf - 0.3) * 8.0
                        + (y / hf - 0.4) * (y / hf - 0.4) * 3.0));
                col * (0.85 + 0.25 * (1.0 - x / wf)) + Col::gray(sheen)
            });
        }
    }
    let (ch, fmt) = format(Class::Natural, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Srgb)
}
