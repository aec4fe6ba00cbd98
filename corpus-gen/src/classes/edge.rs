//! Edge cases: any size (including 1x1, 1xN, Nx1), fully flat images, pure noise,
//! grayscale / gray+alpha / RGBA variants in 8 and 16 bits.

use super::{format, noise_seed, rng_for};
use crate::canvas::{Canvas, Disc, Encoding, Polygon};
use crate::image::{CorpusImage, PixelData};
use crate::math::{clamp01, hsv, sqrt, Col};
use crate::rng::hash3;
use crate::Class;

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let mut rng = rng_for(Class::EdgeCases, seed);
    let (ch, _) = format(Class::EdgeCases, seed);
    let (wf, hf) = (w as f64, h as f64);
    let s = wf.max(hf);
    let nseed = noise_seed(Class::EdgeCases, seed, 0);
    match seed % 8 {
        0 => {
            let col = hsv(rng.f64(), rng.range(0.2, 0.9), rng.range(0.2, 0.95));
            Canvas::new(w, h, col).to_image(ch, 8, Encoding::Display)
        }
        1 => {
            // Independent uniform bytes: incompressible.
            let mut v = vec![0u8; w * h * 3];
            for (k, b) in v.iter_mut().enumerate() {
                let p = k / 3;
                *b = (hash3(nseed, (p % w) as i64, (p / w) as i64, (k % 3) as i64) >> 56) as u8;
            }
            CorpusImage::from_parts(w as u32, h as u32, 3, PixelData::U8(v))
        }
        4 => {
            let v: Vec<u16> = (0..w * h)
                .map(|p| (hash3(nseed, (p % w) as i64, (p / w) as i64, 0) >> 48) as u16)
                .collect();
            CorpusImage::from_parts(w as u32, h as u32, 1, PixelData::U16(v))
        }
        6 => {
            let level = 0x1234 + rng.below(0xC000) as u16;
            CorpusImage::from_parts(w as u32, h as u32, 1, PixelData::U16(vec![level; w * h]))
        }
        2 => {
            let mut c = Canvas::new(w, h, Col::gray(0.5));
            let (a, b) = (rng.range(0.0, 0.4), rng.range(0.6, 1.0));
            c.shade(|x, y| Col::gray(a + (b - a) * clamp01((x + y) / (wf + hf))));
            c.fill(
                &Disc::new(wf * rng.range(0.2, 0.8), hf * rng.range(0.2, 0.8), s * 0.2),
                Col::gray(0.05),
            );
            c.fill(
                &Polygon::rect(wf * 0.55, hf * 0.1, wf * 0.9, hf * 0.6),
                Col::gray(0.95),
            );
            c.to_image(ch, 8, Encoding::Display)
        }
        3 => {
            let mut c = Canvas::transparent(w, h);
            for _ in 0..3 + rng.below(4) {
                let col = hsv(rng.f64(), 0.8, 0.9);
                let d = Disc {
                    cx: wf * rng.range(0.0, 1.0),
                    cy: hf * rng.range(0.0, 1.0),
                    r: s * rng.range(0.1, 0.4),
                };
                let a = rng.range(0.4, 1.0);
                c.draw(&d, a, move |_, _| col);
            }
            c.to_image(ch, 8, Encoding::Display)
        }
        5 => {
            let mut c = Canvas::transparent(w, h);
            let (cx, cy) = (wf * rng.range(0.3, 0.7), hf * rng.range(0.3, 0.7));
            c.shade_rgba(|x, y| {
                let g = clamp01(x / wf);
                let d = sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (0.5 * s);
                [g, g, g, clamp01(1.0 - d)]
            });
            c.to_image(ch, 8, Encoding::Display)
        }
        _ => {
            let mut c = Canvas::transparent(w, h);
            let hue = rng.f64();
            c.shade_rgba(|x, y| {
                let col = hsv(hue + 0.3 * x / wf, 0.7, 0.3 + 0.7 * y / hf);
                [col.0, col.1, col.2, clamp01(0.1 + 0.9 * x / wf)]
            });
            c.to_image(ch, 16, Encoding::Display)
        }
    }
}
