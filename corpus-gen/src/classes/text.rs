//! Procedural "text": glyph-like stroke groups that look like lower-case Latin
//! script at a glance. No font files: every glyph is a few polylines in
//! x-height units (baseline y = 0, x-height y = 1, ascender 1.55, descender -0.55).

use crate::canvas::{Canvas, Stroke};
use crate::math::{cos, sin, Col, PI};
use crate::rng::Rng;

type Pl = Vec<(f64, f64)>;

fn arc(cx: f64, cy: f64, rx: f64, ry: f64, a0: f64, a1: f64, n: usize) -> Pl {
    (0..=n)
        .map(|k| {
            let a = (a0 + (a1 - a0) * k as f64 / n as f64) * PI / 180.0;
            (cx + rx * cos(a), cy + ry * sin(a))
        })
        .collect()
}

fn seg(a: (f64, f64), b: (f64, f64)) -> Pl {
    vec![a, b]
}

/// One glyph: strokes and advance width (both in x-height units).
fn glyph(k: u64) -> (Vec<Pl>, f64) {
    let bowl = || arc(0.3, 0.5, 0.28, 0.5, 0.0, 360.0, 16);
    let asc = 1.55;
    let desc = -0.55;
    match k % 22 {
        0 => (vec![bowl()], 0.62),                                    // o
        1 => (vec![arc(0.3, 0.5, 0.28, 0.5, 40.0, 320.0, 14)], 0.58), // c
        2 => (
            vec![
                seg((0.03, 0.5), (0.58, 0.5)),
                arc(0.3, 0.5, 0.28, 0.5, 0.0, 315.0, 16),
            ],
            0.62,
        ), // e
        3 => (
            vec![
                arc(0.28, 0.5, 0.26, 0.5, 0.0, 360.0, 16),
                seg((0.56, 0.0), (0.56, 1.0)),
            ],
            0.66,
        ), // a
        4 => (vec![bowl(), seg((0.58, 0.0), (0.58, asc))], 0.66),     // d
        5 => (vec![bowl(), seg((0.02, 0.0), (0.02, asc))], 0.66),     // b
        6 => (vec![bowl(), seg((0.02, 1.0), (0.02, desc))], 0.66),    // p
        7 => (
            vec![
                seg((0.05, 0.0), (0.05, 1.0)),
                arc(0.3, 0.55, 0.25, 0.45, 180.0, 0.0, 10),
                seg((0.55, 0.55), (0.55, 0.0)),
            ],
            0.66,
        ), // n
        8 => (
            vec![
                seg((0.05, 0.0), (0.05, 1.0)),
                arc(0.27, 0.55, 0.22, 0.45, 180.0, 0.0, 8),
                seg((0.49, 0.55), (0.49, 0.0)),
                arc(0.71, 0.55, 0.22, 0.45, 180.0, 0.0, 8),
                seg((0.93, 0.55), (0.93, 0.0)),
            ],
            1.02,
        ), // m
        9 => (
            vec![
                seg((0.05, 0.0), (0.05, asc)),
                arc(0.3, 0.55, 0.25, 0.45, 180.0, 0.0, 10),
                seg((0.55, 0.55), (0.55, 0.0)),
            ],
            0.66,
        ), // h
        10 => (
            vec![
                seg((0.05, 1.0), (0.05, 0.45)),
                arc(0.3, 0.45, 0.25, 0.45, 180.0, 360.0, 10),
                seg((0.55, 1.0), (0.55, 0.0)),
            ],
            0.66,
        ), // u
        11 => (vec![seg((0.08, 0.0), (0.08, asc))], 0.3),             // l
        12 => (
            vec![
                seg((0.08, 0.0), (0.08, 1.0)),
                seg((0.08, 1.32), (0.08, 1.36)),
            ],
            0.3,
        ), // i
        13 => (
            vec![seg((0.15, 0.0), (0.15, 1.35)), seg((0.0, 1.0), (0.38, 1.0))],
            0.42,
        ), // t
        14 => (
            vec![
                seg((0.05, 0.0), (0.05, 1.0)),
                arc(0.3, 0.55, 0.25, 0.42, 180.0, 60.0, 8),
            ],
            0.45,
        ), // r
        15 => (vec![vec![(0.0, 1.0), (0.28, 0.0), (0.56, 1.0)]], 0.6), // v
        16 => (
            vec![seg((0.0, 1.0), (0.56, 0.0)), seg((0.0, 0.0), (0.56, 1.0))],
            0.6,
        ), // x
        17 => (
            vec![
                seg((0.05, 0.0), (0.05, asc)),
                vec![(0.5, 1.0), (0.07, 0.45), (0.52, 0.0)],
            ],
            0.58,
        ), // k
        18 => (
            vec![vec![
                (0.52, 0.88),
                (0.3, 1.0),
                (0.07, 0.85),
                (0.12, 0.6),
                (0.45, 0.42),
                (0.55, 0.17),
                (0.3, 0.0),
                (0.03, 0.13),
            ]],
            0.6,
        ), // s
        19 => (
            vec![seg((0.0, 1.0), (0.3, 0.0)), seg((0.58, 1.0), (0.2, desc))],
            0.6,
        ), // y
        20 => (
            vec![
                bowl(),
                seg((0.58, 1.0), (0.58, -0.3)),
                arc(0.3, -0.3, 0.28, 0.25, 0.0, -150.0, 8),
            ],
            0.66,
        ), // g
        _ => (
            vec![
                arc(0.3, 0.5, 0.28, 0.5, 40.0, 320.0, 14),
                seg((0.02, 0.5), (0.02, asc)),
            ],
            0.62,
        ), // a ligature-ish
    }
}

/// Text layout parameters.
pub struct TextStyle {
    /// x-height in pixels.
    pub xh: f64,
    /// Stroke width in pixels.
    pub weight: f64,
    pub colour: Col,
    /// Horizontal shear (italic), in x per y.
    pub slant: f64,
}

impl TextStyle {
    /// Upright text (no slant).
    pub fn upright(xh: f64, weight: f64, colour: Col) -> TextStyle {
        TextStyle {
            xh,
            weight,
            colour,
            slant: 0.0,
        }
    }
}

/// Draw one line of random words from `x0` to at most `x1`, baseline `y`.
/// Returns the x where the text ended.
pub fn draw_line(
    c: &mut Canvas,
    rng: &mut Rng,
    style: &TextStyle,
    x0: f64,
    x1: f64,
    y: f64,
) -> f64 {
    let mut x = x0;
    let xh = style.xh;
    let gap = 0.12 * xh;
    loop {
        let len = 1 + rng.below(8);
        // Word width check before drawing.
        let glyphs: Vec<u64> = (0..len).map(|_| rng.below(22)).collect();
        let width: f64 = glyphs.iter().map(|&g| glyph(g).1 * xh + gap).sum();
        if x + width > x1 {
            break;
        }
        for g in glyphs {
            let (strokes, adv) = glyph(g);
            for pl in strokes {
                let pts: Pl = pl
                    .iter()
                    .map(|&(gx, gy)| {
                        (
                            x + (gx + style.slant * gy) * xh + style.weight * 0.5,
                            y - gy * xh,
                        )
                    })
                    .collect();
                c.fill(&Stroke::new(pts, style.weight), style.colour);
            }
            x += adv * xh + gap;
        }
        x += 0.55 * xh;
    }
    x
}

/// Draw a short label of `n` glyphs starting at `x`, baseline `y`.
pub fn draw_word(c: &mut Canvas, rng: &mut Rng, style: &TextStyle, x: f64, y: f64, n: u64) -> f64 {
    let mut x = x;
    for _ in 0..n {
        let (strokes, adv) = glyph(rng.below(22));
        for pl in strokes {
            let pts: Pl = pl
                .iter()
                .map(|&(gx, gy)| {
                    (
                        x + (gx + style.slant * gy) * style.xh + style.weight * 0.5,
                        y - gy * style.xh,
                    )
                })
                .collect();
            c.fill(&Stroke::new(pts, style.weight), style.colour);
        }
        x += adv * style.xh + 0.12 * style.xh;
    }
    x
}

/// Width a word of `n` average glyphs takes (for centring labels).
pub fn word_width(xh: f64, n: u64) -> f64 {
    n as f64 * 0.68 * xh
}
