//! Flat-and-edges class: flat colour regions bounded by hard anti-aliased edges.
//! Interiors are exactly flat (coverage 1.0 writes the fill colour bit-exactly),
//! only edge pixels carry intermediate values.

use super::text::{draw_line, draw_word, word_width, TextStyle};
use super::{format, rng_for};
use crate::canvas::{
    closed_spline, cubic, ring, rounded_rect, Canvas, Disc, Ellipse, Encoding, Polygon, Stroke,
};
use crate::image::CorpusImage;
use crate::math::{cos, hsv, sin, Col, PI, TAU};
use crate::rng::Rng;
use crate::Class;

fn palette(rng: &mut Rng, n: usize) -> Vec<Col> {
    let base = rng.f64();
    (0..n)
        .map(|k| {
            let h = base + k as f64 * 0.618_033_988_749_895 + rng.range(-0.05, 0.05);
            let light = rng.chance(0.3);
            if light {
                hsv(h, rng.range(0.05, 0.3), rng.range(0.85, 1.0))
            } else {
                hsv(h, rng.range(0.45, 0.95), rng.range(0.3, 0.95))
            }
        })
        .collect()
}

fn regular_polygon(cx: f64, cy: f64, r: f64, n: usize, rot: f64, inner: Option<f64>) -> Polygon {
    let mut pts = Vec::new();
    let m = if inner.is_some() { 2 * n } else { n };
    for k in 0..m {
        let a = rot + TAU * k as f64 / m as f64;
        let rr = match inner {
            Some(f) if k % 2 == 1 => r * f,
            _ => r,
        };
        pts.push((cx + rr * cos(a), cy + rr * sin(a)));
    }
    Polygon::new(pts)
}

fn random_shape(c: &mut Canvas, rng: &mut Rng, s: f64, wf: f64, hf: f64, col: Col) {
    let cx = rng.range(-0.05, 1.05) * wf;
    let cy = rng.range(-0.05, 1.05) * hf;
    let r = s * rng.range(0.04, 0.2);
    match rng.below(7) {
        0 => c.fill(&Disc { cx, cy, r }, col),
        1 => {
            let a = rng.range(0.0, PI);
            c.fill(
                &Ellipse {
                    cx,
                    cy,
                    rx: r,
                    ry: r * rng.range(0.3, 0.9),
                    rot: (cos(a), sin(a)),
                },
                col,
            )
        }
        2 => {
            let n = 3 + rng.below(6) as usize;
            c.fill(
                &regular_polygon(cx, cy, r, n, rng.range(0.0, TAU), None),
                col,
            )
        }
        3 => {
            let n = 5 + rng.below(3) as usize;
            c.fill(
                &regular_polygon(
                    cx,
                    cy,
                    r,
                    n,
                    rng.range(0.0, TAU),
                    Some(rng.range(0.35, 0.6)),
                ),
                col,
            )
        }
        4 => {
            let a = rng.range(0.0, PI);
            c.fill(
                &Polygon::rotated_rect(cx, cy, r, r * rng.range(0.2, 1.0), (cos(a), sin(a))),
                col,
            )
        }
        5 => c.fill(&ring(cx, cy, r, r * rng.range(0.15, 0.5)), col),
        _ => {
            // Axis-aligned rectangle (pixel-aligned on one side, fractional on the other).
            let x0 = cx.floor();
            let y0 = cy + 0.3;
            c.fill(
                &Polygon::rect(x0, y0, x0 + 2.0 * r, y0 + r * rng.range(0.5, 1.5)),
                col,
            )
        }
    }
}

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::FlatEdges, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.min(hf).max(wf.max(hf) * 0.25);
    let pal = palette(&mut rng, 7);
    let mut c = Canvas::new(w, h, pal[0]);
    match seed % 4 {
        0 => {
            let n = 14 + rng.below(12);
            for _ in 0..n {
                let col = pal[1 + rng.below(6) as usize];
                random_shape(&mut c, &mut rng, s, wf, hf, col);
            }
        }
        1 => {
            // Curved blobs.
            for _ in 0..4 + rng.below(4) {
                let cx = rng.range(0.1, 0.9) * wf;
                let cy = rng.range(0.1, 0.9) * hf;
                let r = s * rng.range(0.08, 0.25);
                let n = 5 + rng.below(5) as usize;
                let ctrl: Vec<(f64, f64)> = (0..n)
                    .map(|k| {
                        let a = TAU * k as f64 / n as f64;
                        let rr = r * rng.range(0.5, 1.2);
                        (cx + rr * cos(a), cy + rr * sin(a))
                    })
                    .collect();
                let col = pal[1 + rng.below(6) as usize];
                c.fill(&Polygon::new(closed_spline(&ctrl, 12)), col);
            }
            // Bezier curves of several widths.
            for _ in 0..3 + rng.below(4) {
                let mut p = || (rng.range(0.0, wf), rng.range(0.0, hf));
                let pts = cubic(p(), p(), p(), p(), 64);
                let width = *rng.pick(&[1.0, 1.5, 2.5, 4.0, 6.0]);
                let col = pal[1 + rng.below(6) as usize];
                c.fill(&Stroke::new(pts, width), col);
            }
            // Straight thin lines, down to sub-pixel hairlines.
            let dark = Col::gray(0.08);
            for _ in 0..10 + rng.below(10) {
                let a = (rng.range(0.0, wf), rng.range(0.0, hf));
                let b = (rng.range(0.0, wf), rng.range(0.0, hf));
                let width = *rng.pick(&[0.35, 0.5, 0.75, 1.0, 1.0, 1.5, 2.0]);
                let col = if rng.chance(0.5) {
                    dark
                } else {
                    pal[1 + rng.below(6) as usize]
                };
                c.fill(&Stroke::line(a, b, width), col);
            }
            // A hairline grid in one corner.
            let gx0 = (rng.range(0.05, 0.5) * wf).floor();
            let gy0 = (rng.range(0.05, 0.5) * hf).floor();
            let step = (s / 40.0).max(3.0).floor();
            let gw = (s * 0.3).floor();
            let mut k = 0.0;
            while k <= gw {
                c.fill(
                    &Stroke::line((gx0 + k + 0.5, gy0), (gx0 + k + 0.5, gy0 + gw), 1.0),
                    dark,
                );
                c.fill(
                    &Stroke::line((gx0, gy0 + k + 0.5), (gx0 + gw, gy0 + k + 0.5), 1.0),
                    dark,
                );
                k += step;
            }
        }
        2 => {
            // A printed page: title, paragraphs, a figure with a bar chart.
            c = Canvas::new(w, h, Col::gray(0.97));
            let ink = Col::gray(0.1);
            let margin = (s * 0.07).floor();
            let xh = (s / 75.0).max(2.5);
            let body = TextStyle::upright(xh, (xh * 0.16).max(0.7), ink);
            let title = TextStyle::upright(xh * 2.2, xh * 0.5, ink);
            let mut y = margin + title.xh * 1.6;
            draw_line(&mut c, &mut rng, &title, margin, wf * 0.75, y);
            y += title.xh * 1.5;
            c.fill(
                &Stroke::line((margin, y), (wf - margin, y), 1.0),
                Col::gray(0.4),
            );
            y += xh * 3.0;
            let fig_at = rng.below(3);
            let mut para = 0;
            while y < hf - margin {
                let lines = 3 + rng.below(5);
                for l in 0..lines {
                    if y > hf - margin {
                        break;
                    }
                    let end = if l + 1 == lines {
                        wf * rng.range(0.3, 0.8)
                    } else {
                        wf - margin
                    };
                    draw_line(&mut c, &mut rng, &body, margin, end, y);
                    y += xh * 2.6;
                }
                y += xh * 1.5;
                if para == fig_at {
                    // Figure: a framed bar chart with hairline axes.
                    let fh = (s * 0.25).floor();
                    let fx0 = margin + 0.5;
                    let fx1 = wf - margin - 0.5;
                    let fy0 = y.floor() + 0.5;
                    c.fill(
                        &Stroke::new(
                            vec![
                                (fx0, fy0),
                                (fx1, fy0),
                                (fx1, fy0 + fh),
                                (fx0, fy0 + fh),
                                (fx0, fy0),
                            ],
                            1.0,
                        ),
                        ink,
                    );
                    let nb = 5 + rng.below(6);
                    let bw = (fx1 - fx0) / (nb as f64 * 1.6 + 0.6);
                    for b in 0..nb {
                        let bx = fx0 + bw * (0.6 + 1.6 * b as f64);
                        let bh = fh * rng.range(0.15, 0.85);
                        let g = Col::gray(*rng.pick(&[0.25, 0.5, 0.7]));
                        c.fill(
                            &Polygon::rect(bx, fy0 + fh - bh, bx + bw, fy0 + fh - 1.0),
                            g,
                        );
                    }
                    for t in 1..4 {
                        let ty = fy0 + fh * t as f64 / 4.0;
                        c.fill(&Stroke::line((fx0, ty), (fx1, ty), 0.5), Col::gray(0.6));
                    }
                    y += fh + xh * 4.0;
                }
                para += 1;
            }
        }
        _ => {
            // A flat user interface: window, title bar, sidebar, buttons, text, icons.
            let bg = Col::gray(0.92);
            c = Canvas::new(w, h, bg);
            let accent = pal[1];
            let accent2 = pal[2];
            let text_col = Col::gray(0.13);
            let xh = (s / 90.0).max(2.0);
            let style = TextStyle::upright(xh, (xh * 0.18).max(0.7), text_col);
            let white = TextStyle {
                colour: Col::gray(1.0),
                ..style
            };
            let bar = (s * 0.07).floor();
            c.fill(&Polygon::rect(0.0, 0.0, wf, bar), accent);
            draw_word(&mut c, &mut rng, &white, bar * 0.4, bar * 0.65, 7);
            for k in 0..3 {
                let cx = wf - bar * (0.5 + 0.8 * k as f64);
                c.fill(
                    &Disc {
                        cx,
                        cy: bar * 0.5,
                        r: bar * 0.2,
                    },
                    Col::gray(1.0).mix(accent, 0.3 * k as f64),
                );
            }
            // Sidebar with items.
            let sw = (wf * 0.22).floor();
            c.fill(&Polygon::rect(0.0, bar, sw, hf), Col::gray(0.85));
            c.fill(
                &Stroke::line((sw + 0.5, bar), (sw + 0.5, hf), 1.0),
                Col::gray(0.7),
            );
            let item_h = (xh * 4.0).floor();
            let mut y = bar + item_h;
            let selected = rng.below(6);
            let mut k = 0;
            while y < hf - item_h * 0.5 {
                if k == selected {
                    c.fill(
                        &Polygon::rect(0.0, y - item_h * 0.7, sw, y + item_h * 0.3),
                        accent2,
                    );
                }
                c.fill(
                    &rounded_rect(xh, y - xh * 1.6, xh * 2.6, y, xh * 0.3),
                    accent.mix(Col::gray(0.5), 0.3),
                );
                draw_line(&mut c, &mut rng, &style, xh * 4.0, sw - xh, y);
                y += item_h;
                k += 1;
            }
            // Content: cards with text and buttons.
            let cx0 = sw + xh * 3.0;
            let cx1 = wf - xh * 3.0;
            let mut y = bar + xh * 3.0;
            while y < hf - xh * 16.0 {
                let card_h = (xh * rng.range(12.0, 22.0)).floor();
                let y1 = (y + card_h).min(hf - xh * 2.0);
                c.fill(
                    &rounded_rect(cx0 + 2.0, y + 2.0, cx1 + 2.0, y1 + 2.0, xh),
                    Col::gray(0.8),
                );
                c.fill(&rounded_rect(cx0, y, cx1, y1, xh), Col::gray(1.0));
                let mut ty = y + xh * 3.0;
                while ty < y1 - xh * 7.0 {
                    draw_line(&mut c, &mut rng, &style, cx0 + xh * 2.0, cx1 - xh * 2.0, ty);
                    ty += xh * 2.4;
                }
                // Button, checkbox and slider along the bottom of the card.
                let by = y1 - xh * 4.5;
                let bw = word_width(xh, 6) + xh * 3.0;
                c.fill(
                    &rounded_rect(
                        cx0 + xh * 2.0,
                        by,
                        cx0 + xh * 2.0 + bw,
                        by + xh * 3.0,
                        xh * 0.8,
                    ),
                    accent,
                );
                draw_word(&mut c, &mut rng, &white, cx0 + xh * 3.5, by + xh * 2.0, 6);
                let kx = cx0 + xh * 4.0 + bw;
                c.fill(
                    &rounded_rect(kx, by + xh * 0.5, kx + xh * 2.0, by + xh * 2.5, xh * 0.3),
                    Col::gray(0.55),
                );
                c.fill(
                    &rounded_rect(
                        kx + 1.0,
                        by + xh * 0.5 + 1.0,
                        kx + xh * 2.0 - 1.0,
                        by + xh * 2.5 - 1.0,
                        xh * 0.2,
                    ),
                    Col::gray(1.0),
                );
                if rng.chance(0.6) {
                    c.fill(
                        &Stroke::new(
                            vec![
                                (kx + xh * 0.5, by + xh * 1.5),
                                (kx + xh * 0.9, by + xh * 2.0),
                                (kx + xh * 1.6, by + xh),
                            ],
                            xh * 0.35,
                        ),
                        accent2,
                    );
                }
                let sx0 = kx + xh * 4.0;
                let sx1 = cx1 - xh * 2.0;
                if sx1 > sx0 + xh * 4.0 {
                    let sy = by + xh * 1.5;
                    c.fill(
                        &Stroke::line((sx0, sy), (sx1, sy), xh * 0.4),
                        Col::gray(0.75),
                    );
                    let t = rng.range(0.1, 0.9);
                    let kxx = sx0 + (sx1 - sx0) * t;
                    c.fill(&Stroke::line((sx0, sy), (kxx, sy), xh * 0.4), accent);
                    c.fill(&Disc::new(kxx, sy, xh * 0.9), accent);
                }
                y = y1 + xh * 3.0;
            }
        }
    }
    let (ch, fmt) = format(Class::FlatEdges, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Display)
}
