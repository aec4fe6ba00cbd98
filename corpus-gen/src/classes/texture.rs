//! Texture class: periodic and chirped patterns up to the Nyquist frequency.
//!
//! * zone plate: `0.5 + 0.5 cos(pi/2 (dx^2/cx + dy^2/cy) + phase)` centred in the
//!   image; its local frequency grows linearly from 0 at the centre to
//!   `0.5 - 1/(4 cx)` cycles/pixel (horizontal) at the left/right border pixels and
//!   likewise vertically, i.e. it sweeps right up to Nyquist without aliasing;
//! * stripes: box-filtered square waves and sine gratings, periods 2..24 px;
//! * checkerboards: pixel-aligned cells of 1..32 px, rotated and perspective
//!   boards with analytic box filtering;
//! * bricks, halftone dots, plaid and hexagon grids.

use super::{format, rng_for};
use crate::canvas::{Canvas, Encoding};
use crate::image::CorpusImage;
use crate::math::{clamp01, cos, fract, hsv, sin, sqrt, Col, PI, TAU};
use crate::rng::{hash2, unit_f64, Rng};
use crate::Class;

/// Integral of the unit square wave (1 on the first half of each period `p`).
#[inline]
fn sq_integral(u: f64, p: f64) -> f64 {
    let k = (u / p).floor();
    k * p * 0.5 + (u - k * p).min(p * 0.5)
}

/// Square wave of period `p` box-filtered over a footprint of width `fw`.
#[inline]
fn square_filtered(u: f64, p: f64, fw: f64) -> f64 {
    (sq_integral(u + 0.5 * fw, p) - sq_integral(u - 0.5 * fw, p)) / fw
}

/// Integral of a triangle helper for the box-filtered checkerboard.
#[inline]
fn tri(x: f64) -> f64 {
    (fract(x * 0.5) - 0.5).abs()
}

/// Box-filtered checkerboard (cells of size 1 in (u, v)), footprint (fu, fv); 1 on even cells.
#[inline]
fn checker_filtered(u: f64, v: f64, fu: f64, fv: f64) -> f64 {
    let fu = fu.max(1e-6);
    let fv = fv.max(1e-6);
    let ix = 2.0 * (tri(u - 0.5 * fu) - tri(u + 0.5 * fu)) / fu;
    let iy = 2.0 * (tri(v - 0.5 * fv) - tri(v + 0.5 * fv)) / fv;
    0.5 - 0.5 * ix * iy
}

fn colour_pair(rng: &mut Rng) -> (Col, Col) {
    let h = rng.f64();
    let a = hsv(h, rng.range(0.3, 0.9), rng.range(0.15, 0.45));
    let b = hsv(
        h + rng.range(0.1, 0.5),
        rng.range(0.1, 0.6),
        rng.range(0.75, 1.0),
    );
    (a, b)
}

#[derive(Clone, Copy)]
enum Tile {
    Square {
        ca: f64,
        sa: f64,
        p: f64,
        a: Col,
        b: Col,
    },
    Sine {
        ca: f64,
        sa: f64,
        p: f64,
        a: Col,
        b: Col,
    },
    Bricks {
        bw: f64,
        bh: f64,
        mortar: f64,
        seed: u64,
        base: Col,
        grout: Col,
    },
    Dots {
        g: f64,
        ink: Col,
        paper: Col,
        angle: (f64, f64),
    },
    Plaid {
        p: f64,
        cols: [Col; 3],
    },
    Hex {
        scale: f64,
        line: f64,
        a: Col,
        b: Col,
    },
}

fn eval_tile(t: &Tile, x: f64, y: f64, tw: f64, th: f64) -> Col {
    match *t {
        Tile::Square { ca, sa, p, a, b } => {
            let u = x * ca + y * sa;
            let fw = ca.abs() + sa.abs();
            a.mix(b, square_filtered(u, p, fw))
        }
        Tile::Sine { ca, sa, p, a, b } => {
            let u = x * ca + y * sa;
            a.mix(b, 0.5 + 0.5 * sin(TAU * u / p))
        }
        Tile::Bricks {
            bw,
            bh,
            mortar,
            seed,
            base,
            grout,
        } => {
            let row = (y / bh).floor();
            let off = if (row as i64) % 2 == 0 { 0.0 } else { bw * 0.5 };
            let col = ((x + off) / bw).floor();
            let lx = x + off - col * bw;
            let ly = y - row * bh;
            // Distance (px) to the mortar joint, positive inside the brick.
            let d = (lx.min(bw - lx)).min(ly.min(bh - ly)) - 0.5 * mortar;
            let shade = unit_f64(hash2(seed, col as i64, row as i64));
            let brick = base * (0.75 + 0.4 * shade);
            grout.mix(brick, clamp01(d + 0.5))
        }
        Tile::Dots {
            g,
            ink,
            paper,
            angle,
        } => {
            let u = x * angle.0 + y * angle.1;
            let v = -x * angle.1 + y * angle.0;
            let cu = (u / g).floor() * g + 0.5 * g;
            let cv = (v / g).floor() * g + 0.5 * g;
            let tone = clamp01(x / tw * 0.8 + y / th * 0.2);
            let r = 0.5 * g * sqrt(tone) * 1.2;
            let d = sqrt((u - cu) * (u - cu) + (v - cv) * (v - cv)) - r;
            paper.mix(ink, clamp01(0.5 - d))
        }
        Tile::Plaid { p, cols } => {
            let fw = 1.0;
            let s1 = square_filtered(x, p, fw);
            let s2 = square_filtered(y, p, fw);
            let s3 = square_filtered(x + p * 0.25, p / 4.0, fw) * square_filtered(x, p, fw);
            let s4 = square_filtered(y + p * 0.25, p / 4.0, fw) * square_filtered(y, p, fw);
            let base = cols[0].mix(cols[1], 0.5 * (s1 + s2));
            base.mix(cols[2], 0.35 * (s3 + s4))
        }
        Tile::Hex { scale, line, a, b } => {
            let px = x / scale;
            let py = y / scale;
            let sy = 1.732_050_807_568_877_2;
            let c1x = (px / 1.0).floor() + 0.5;
            let c1y = (py / sy).floor() + 0.5;
            let c2x = ((px - 0.5) / 1.0).floor() + 0.5;
            let c2y = ((py - 1.0) / sy).floor() + 0.5;
            let h1 = (px - c1x, py - c1y * sy);
            let h2 = (px - (c2x + 0.5), py - (c2y + 0.5) * sy);
            let h = if h1.0 * h1.0 + h1.1 * h1.1 < h2.0 * h2.0 + h2.1 * h2.1 {
                h1
            } else {
                h2
            };
            let hx = h.0.abs();
            let hy = h.1.abs();
            let hd = (hx * 0.5 + hy * 0.866_025_403_784_438_6).max(hx);
            let d = (0.5 - hd) * scale; // px to the cell edge
            let l = clamp01((d + 0.5).min(line * 0.5) - (d - 0.5).max(-line * 0.5));
            a.mix(b, l)
        }
    }
}

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::Texture, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.min(hf).max(wf.max(hf) * 0.25);
    let mut c = Canvas::new(w, h, Col::gray(0.5));
    match seed % 4 {
        0 => {
            let phase = if seed == 0 { 0.0 } else { rng.range(0.0, TAU) };
            let cx = wf * 0.5;
            let cy = hf * 0.5;
            c.shade(|x, y| {
                let dx = x - cx;
                let dy = y - cy;
                let v = 0.5 + 0.5 * cos(0.5 * PI * (dx * dx / cx + dy * dy / cy) + phase);
                Col::gray(v)
            });
        }
        1 | 3 => {
            let (nx, ny) = if seed % 4 == 1 {
                (3usize, 2usize)
            } else {
                (2, 2)
            };
            let mut tiles = Vec::new();
            for k in 0..nx * ny {
                let (a, b) = colour_pair(&mut rng);
                let t = if seed % 4 == 1 {
                    // Tile 0: pixel-aligned 2-px lines (Nyquist); others random.
                    let (ang, p): (f64, f64) = match k {
                        0 => (0.0, 2.0),
                        1 => (PI / 2.0, 3.0),
                        _ => (
                            rng.range(0.0, PI),
                            *rng.pick(&[2.5, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0]),
                        ),
                    };
                    if k >= 2 && rng.chance(0.35) {
                        Tile::Sine {
                            ca: cos(ang),
                            sa: sin(ang),
                            p: p.max(3.0),
                            a,
                            b,
                        }
                    } else {
                        Tile::Square {
                            ca: cos(ang),
                            sa: sin(ang),
                            p,
                            a,
                            b,
                        }
                    }
                } else {
                    match (k as u64 + seed / 4) % 4 {
                        0 => Tile::Bricks {
                            bw: (s * rng.range(0.06, 0.12)).max(4.0),
                            bh: (s * rng.range(0.025, 0.05)).max(2.0),
                            mortar: (s * 0.006).max(1.0),
                            seed: rng.next_u64(),
                            base: hsv(
                                rng.range(0.0, 0.08),
                                rng.range(0.5, 0.8),
                                rng.range(0.5, 0.8),
                            ),
                            grout: Col::gray(rng.range(0.6, 0.85)),
                        },
                        1 => {
                            let an = rng.range(0.0, PI / 2.0);
                            Tile::Dots {
                                g: (s * rng.range(0.015, 0.03)).max(3.0),
                                ink: a,
                                paper: b,
                                angle: (cos(an), sin(an)),
                            }
                        }
                        2 => Tile::Plaid {
                            p: (s * rng.range(0.04, 0.1)).max(8.0),
                            cols: [a, b, hsv(rng.f64(), 0.7, 0.8)],
                        },
                        _ => Tile::Hex {
                            scale: (s * rng.range(0.03, 0.07)).max(4.0),
                            line: rng.range(1.0, 2.5),
                            a: b,
                            b: a,
                        },
                    }
                };
                tiles.push(t);
            }
            let tw = wf / nx as f64;
            let th = hf / ny as f64;
            c.shade(|x, y| {
                let i = ((x / tw).floor() as usize).min(nx - 1);
                let j = ((y / th).floor() as usize).min(ny - 1);
                eval_tile(
                    &tiles[j * nx + i],
                    x - i as f64 * tw,
                    y - j as f64 * th,
                    tw,
                    th,
                )
            });
        }
        _ => {
            // Checkerboards (gray): top band of pixel-aligned boards, then a rotated
            // board and a perspective floor, all box-filtered.
            let mut cells: Vec<f64> = vec![1.0, 2.0, 3.0, 4.0, 5.0, 8.0, 16.0, 32.0];
            // Pick 4 cell sizes, always including 1 px (Nyquist in both axes).
            let mut pick = vec![1.0];
            cells.remove(0);
            for _ in 0..3 {
                let k = rng.below(cells.len() as u64) as usize;
                pick.push(cells.remove(k));
            }
            pick.sort_by(f64::total_cmp);
            let band = (hf * 0.3).floor();
            let tw = wf / 4.0;
            let ang = rng.range(0.1, PI / 2.0 - 0.1);
            let (ca, sa) = (cos(ang), sin(ang));
            let rcell = (s * rng.range(0.02, 0.05)).max(1.5);
            let horizon = band + (hf - band) * rng.range(0.1, 0.3);
            let fcell = rng.range(0.5, 1.5);
            let focal = s * 0.8;
            let cam_h = 2.0;
            let ink = rng.range(0.0, 0.15);
            let paper = rng.range(0.85, 1.0);
            let split = (wf * 0.35).floor();
            let floor_uv = |x: f64, y: f64| {
                let z = cam_h * focal / (y - horizon);
                ((x - wf * 0.5) * z / focal / fcell, z / fcell)
            };
            c.shade(|x, y| {
                let v = if y < band {
                    let i = ((x / tw).floor() as usize).min(3);
                    let cell = pick[i];
                    let u = (x / cell).floor() as i64 + (y / cell).floor() as i64;
                    if u % 2 == 0 {
                        1.0
                    } else {
                        0.0
                    }
                } else if x < split {
                    let u = (x * ca + y * sa) / rcell;
                    let v = (-x * sa + y * ca) / rcell;
                    let f = (ca.abs() + sa.abs()) / rcell;
                    checker_filtered(u, v, f, f)
                } else if y <= horizon + 0.5 {
                    0.5 + 0.4 * (horizon - y) / hf
                } else {
                    let (u, v) = floor_uv(x, y);
                    let (ux, vx) = floor_uv(x + 1.0, y);
                    let (uy, vy) = floor_uv(x, y + 1.0);
                    let fu = (ux - u).abs() + (uy - u).abs();
                    let fv = (vx - v).abs() + (vy - v).abs();
                    checker_filtered(u, v, fu, fv)
                };
                Col::gray(ink + (paper - ink) * v)
            });
        }
    }
    let (ch, fmt) = format(Class::Texture, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Display)
}
