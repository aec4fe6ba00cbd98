//! HDR class: float linear-radiance scenes with a dynamic range far above 1000:1
//! (bright sources of 10^3..10^4 next to shadows of 10^-3..10^-2), OpenEXR output.

use super::{noise_seed, rng_for};
use crate::canvas::{rounded_rect, Canvas, Disc, Polygon, SdfShape, Stroke};
use crate::image::CorpusImage;
use crate::math::{clamp01, exp, smoothstep, sqrt, Col};
use crate::noise::Noise;
use crate::rng::{hash2, unit_f64};
use crate::Class;

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::Hdr, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.min(hf).max(wf.max(hf) * 0.25);
    let n1 = Noise::new(noise_seed(Class::Hdr, seed, 1));
    let mut c = Canvas::new(w, h, Col::gray(0.1));
    match seed % 3 {
        0 => {
            // Sunlit landscape: sun disc ~ 2e4, sky ~ 1..5, sunlit ground ~ 3, deep
            // shadow in a cave mouth ~ 0.003.
            let horizon = hf * rng.range(0.55, 0.7);
            let sx = wf * rng.range(0.2, 0.8);
            let sy = horizon * rng.range(0.25, 0.6);
            let sr = (s * 0.03).max(2.5);
            let f0 = 3.0 / s;
            c.shade(|x, y| {
                let t = clamp01(y / horizon);
                let mut sky = Col(0.35, 0.6, 1.4).mix(Col(2.0, 2.3, 2.8), t * t);
                let d = sqrt((x - sx) * (x - sx) + (y - sy) * (y - sy)) / s;
                sky = sky
                    + Col(60.0, 50.0, 35.0) * exp(-d * 40.0)
                    + Col(3.0, 2.6, 2.0) * exp(-d * 5.0);
                let ridge = horizon - s * (0.05 + 0.12 * (0.5 + 0.5 * n1.fbm1(x * f0, 6)));
                if y < ridge {
                    return sky;
                }
                let g = 0.5 + 0.5 * n1.fbm(x * f0 * 4.0, y * f0 * 4.0, 6, 2.0, 0.5);
                let lit = Col(2.2, 2.6, 1.2) * (0.6 + 0.6 * g);
                let haze = clamp01(1.0 - (y - ridge) / (hf - ridge + 1.0));
                let cov = clamp01(y - ridge + 0.5);
                sky.mix(lit.mix(Col(1.6, 1.9, 2.4), 0.5 * haze), cov)
            });
            c.fill(&Disc::new(sx, sy, sr), Col(22000.0, 20000.0, 17000.0));
            // A cliff face in shade with a dark cave mouth.
            let cx = wf * rng.range(0.05, 0.3);
            let cliff = Polygon::new(vec![
                (cx - s * 0.3, hf + 1.0),
                (cx - s * 0.2, horizon - s * 0.25),
                (cx + s * 0.1, horizon - s * 0.3),
                (cx + s * 0.25, hf + 1.0),
            ]);
            c.draw(&cliff, 1.0, |x, y| {
                Col(0.25, 0.22, 0.2)
                    * (0.6 + 0.5 * (0.5 + 0.5 * n1.fbm(x * 0.05, y * 0.05, 5, 2.0, 0.5)))
            });
            let cave = SdfShape {
                bb: [cx - s * 0.1, horizon - s * 0.1, cx + s * 0.12, hf],
                f: move |x: f64, y: f64| {
                    let dx = (x - cx) / (s * 0.08);
                    let dy = (y - (horizon + s * 0.05)) / (s * 0.12);
                    (sqrt(dx * dx + dy * dy) - 1.0) * s * 0.08
                },
            };
            c.draw(&cave, 1.0, |x, y| {
                Col(0.004, 0.0035, 0.003) * (1.0 + 0.2 * unit_f64(hash2(7, x as i64, y as i64)))
            });
        }
        1 => {
            // Interior: dim walls ~ 0.02..0.3, a window onto a bright exterior ~ 30,
            // a bare lamp bulb ~ 3000.
            let lx = wf * rng.range(0.6, 0.85);
            let ly = hf * rng.range(0.2, 0.35);
            let floor_y = hf * 0.72;
            c.shade(|x, y| {
                let d = sqrt((x - lx) * (x - lx) + (y - ly) * (y - ly)) / s;
                let wall = Col(0.09, 0.07, 0.05) + Col(0.5, 0.4, 0.25) * exp(-d * 4.0);
                if y < floor_y {
                    wall
                } else {
                    let fd = sqrt(
                        (x - lx) * (x - lx)
                            + (y - floor_y - s * 0.2) * (y - floor_y - s * 0.2) * 4.0,
                    ) / s;
                    let plank = 0.8 + 0.2 * unit_f64(hash2(3, (x / (s * 0.12)).floor() as i64, 0));
                    (Col(0.03, 0.02, 0.012) + Col(0.45, 0.3, 0.15) * exp(-fd * 3.0)) * plank
                }
            });
            // Window.
            let (wx0, wy0) = (wf * 0.1, hf * 0.15);
            let (wx1, wy1) = (wf * 0.42, hf * 0.6);
            let win = Polygon::rect(wx0, wy0, wx1, wy1);
            let hz = wy0 + (wy1 - wy0) * 0.7;
            c.draw(&win, 1.0, move |x, y| {
                if y < hz {
                    Col(8.0, 12.0, 25.0).mix(Col(30.0, 32.0, 35.0), (y - wy0) / (hz - wy0))
                } else {
                    Col(6.0, 9.0, 3.0)
                        * (0.7 + 0.6 * unit_f64(hash2(11, (x / 3.0) as i64, (y / 3.0) as i64)))
                }
            });
            let frame = Col(0.05, 0.04, 0.03);
            let mw = (s * 0.012).max(1.0);
            c.fill(
                &Polygon::rect((wx0 + wx1) * 0.5 - mw, wy0, (wx0 + wx1) * 0.5 + mw, wy1),
                frame,
            );
            c.fill(
                &Polygon::rect(wx0, (wy0 + wy1) * 0.5 - mw, wx1, (wy0 + wy1) * 0.5 + mw),
                frame,
            );
            // Light patch from the window on the floor.
            let patch = Polygon::new(vec![
                (wx0, floor_y + s * 0.05),
                (wx1, floor_y + s * 0.05),
                (wx1 + s * 0.25, hf),
                (wx0 + s * 0.05, hf),
            ]);
            c.draw(&patch, 1.0, |x, y| {
                Col(3.0, 2.6, 2.0)
                    * (0.8 + 0.2 * unit_f64(hash2(3, (x / (s * 0.12)).floor() as i64, 0)))
                    * (1.0 - 0.3 * (y - floor_y) / hf)
            });
            // Lamp: cord, shade, bulb.
            c.fill(
                &Stroke::line((lx, 0.0), (lx, ly - s * 0.04), (s * 0.004).max(0.7)),
                Col(0.01, 0.01, 0.01),
            );
            c.fill(
                &Polygon::new(vec![
                    (lx - s * 0.03, ly - s * 0.05),
                    (lx + s * 0.03, ly - s * 0.05),
                    (lx + s * 0.07, ly),
                    (lx - s * 0.07, ly),
                ]),
                Col(0.02, 0.015, 0.01),
            );
            c.fill(
                &Disc::new(lx, ly + s * 0.01, (s * 0.025).max(2.5)),
                Col(3500.0, 3000.0, 2000.0),
            );
            // A dark cabinet in the corner (deep shadow).
            c.draw(
                &rounded_rect(wf * 0.02, floor_y - s * 0.3, wf * 0.25, hf * 0.98, 2.0),
                1.0,
                |_, y| Col(0.003, 0.0025, 0.002) * (1.0 + 0.5 * smoothstep(0.0, hf, y)),
            );
        }
        _ => {
            // Night street: sky ~ 0.002, stars, moon ~ 80, street lamps ~ 2000 with
            // halos, lit windows ~ 2, wet-road reflections.
            let horizon = hf * rng.range(0.55, 0.65);
            let star_seed = rng.next_u64();
            let nlamps = 2 + rng.below(3) as usize;
            let lamps: Vec<(f64, f64)> = (0..nlamps)
                .map(|k| {
                    (
                        wf * (k as f64 + rng.range(0.3, 0.7)) / nlamps as f64,
                        horizon - s * rng.range(0.15, 0.25),
                    )
                })
                .collect();
            let lamps2 = lamps.clone();
            let star_cell = (s * 0.035).max(3.0);
            c.shade(|x, y| {
                let mut col = if y < horizon {
                    let g = Col(0.001, 0.0015, 0.004)
                        .mix(Col(0.008, 0.007, 0.01), clamp01(y / horizon));
                    let (ci, cj) = (
                        (x / star_cell).floor() as i64,
                        (y / star_cell).floor() as i64,
                    );
                    let hsh = hash2(star_seed, ci, cj);
                    let (px, py) = (
                        (ci as f64 + 0.2 + 0.6 * unit_f64(hsh)) * star_cell,
                        (cj as f64 + 0.2 + 0.6 * unit_f64(hsh >> 20)) * star_cell,
                    );
                    let st = if unit_f64(hsh >> 40) < 0.12 {
                        exp(-((x - px) * (x - px) + (y - py) * (y - py)) * 3.0)
                            * 0.2
                            * (1.0 + 4.0 * unit_f64(hsh >> 50))
                    } else {
                        0.0
                    };
                    g + Col(st, st, st * 1.1)
                } else {
                    // Wet asphalt.
                    let n = 0.5 + 0.5 * n1.fbm(x * 0.05, y * 0.2, 5, 2.0, 0.5);
                    Col(0.004, 0.004, 0.005) * (0.6 + 0.8 * n)
                };
                for &(lx, ly) in &lamps2 {
                    let d = sqrt((x - lx) * (x - lx) + (y - ly) * (y - ly)) / s;
                    col = col
                        + Col(30.0, 20.0, 8.0) * exp(-d * 60.0)
                        + Col(0.3, 0.2, 0.08) * exp(-d * 8.0);
                    if y > horizon {
                        // Streaky reflection below the lamp.
                        let rx = (x - lx) / s;
                        let ry = (y - horizon) / s;
                        col = col + Col(4.0, 2.6, 1.0) * exp(-rx * rx * 1500.0) * exp(-ry * 4.0);
                    }
                }
                col
            });
            // Moon.
            let (mx, my) = (wf * rng.range(0.6, 0.9), horizon * rng.range(0.15, 0.35));
            c.fill(
                &Disc::new(mx, my, (s * 0.035).max(2.5)),
                Col(80.0, 80.0, 75.0),
            );
            // Buildings with lit windows.
            let mut bx = 0.0;
            let mut k = 0;
            while bx < wf {
                let bw = s * rng.range(0.12, 0.25);
                let bh = s * rng.range(0.1, 0.35);
                let top = horizon - bh;
                let wseed = rng.next_u64();
                let x0 = bx;
                c.draw(
                    &Polygon::rect(bx, top, bx + bw, horizon + 0.5),
                    1.0,
                    move |x, y| {
                        let cw = (s * 0.03).max(2.0);
                        let (i, j) = (
                            ((x - x0) / cw).floor() as i64,
                            ((y - top) / cw).floor() as i64,
                        );
                        let lx = (x - x0) - i as f64 * cw;
                        let ly = (y - top) - j as f64 * cw;
                        let inside = lx > cw * 0.25
                            && lx < cw * 0.75
                            && ly > cw * 0.3
                            && ly < cw * 0.8
                            && j > 0;
                        let hsh = hash2(wseed, i, j);
                        if inside && unit_f64(hsh) < 0.35 {
                            Col(2.5, 1.8, 0.9) * (0.5 + unit_f64(hsh >> 16))
                        } else {
                            Col(0.0012, 0.0012, 0.0016)
                        }
                    },
                );
                bx += bw + s * rng.range(0.0, 0.05);
                k += 1;
                if k > 64 {
                    break;
                }
            }
            // Lamp posts and bulbs.
            for &(lx, ly) in &lamps {
                c.fill(
                    &Stroke::line((lx, ly), (lx, horizon + s * 0.03), (s * 0.008).max(1.0)),
                    Col(0.002, 0.002, 0.002),
                );
                c.fill(
                    &Disc::new(lx, ly, (s * 0.012).max(2.0)),
                    Col(2500.0, 1900.0, 900.0),
                );
            }
        }
    }
    // Radiance is strictly positive everywhere.
    c.modify(|_, _, col| Col(col.0.max(1e-4), col.1.max(1e-4), col.2.max(1e-4)));
    c.to_float_rgb()
}
