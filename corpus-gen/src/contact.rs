//! Contact sheets: a grid of labelled thumbnails of a corpus.
//!
//! Layout: cells of [`CELL`]x[`CELL`] pixels plus a [`LABEL_H`]-pixel label strip,
//! [`PAD`] pixels between and around cells, at most [`MAX_COLS`] columns.

use image::{Rgb, RgbImage};

use crate::image::CorpusImage;

/// Thumbnail box size.
pub const CELL: u32 = 160;
/// Height of the label strip under each thumbnail.
pub const LABEL_H: u32 = 14;
/// Padding between and around cells.
pub const PAD: u32 = 6;
/// Maximum number of columns.
pub const MAX_COLS: u32 = 8;

const BG: Rgb<u8> = Rgb([38, 38, 42]);
const FG: Rgb<u8> = Rgb([225, 225, 225]);

/// `(columns, rows, width, height)` of a sheet with `n` images.
pub fn layout(n: usize) -> (u32, u32, u32, u32) {
    let n = n.max(1) as u32;
    let cols = n.min(MAX_COLS);
    let rows = n.div_ceil(cols);
    (
        cols,
        rows,
        PAD + cols * (CELL + PAD),
        PAD + rows * (CELL + LABEL_H + PAD),
    )
}

/// Thumbnail of an image fitting in `CELL x CELL` (area-averaged when shrinking,
/// nearest when enlarging tiny images), via [`CorpusImage::preview_rgb8`].
pub fn thumbnail(img: &CorpusImage) -> RgbImage {
    let src = img.preview_rgb8();
    let (w, h) = (src.width() as u64, src.height() as u64);
    let scale_num = CELL as u64;
    let big = w.max(h);
    let tw = ((w * scale_num).div_ceil(big)).clamp(1, CELL as u64) as u32;
    let th = ((h * scale_num).div_ceil(big)).clamp(1, CELL as u64) as u32;
    let mut out = RgbImage::new(tw, th);
    for ty in 0..th {
        let y0 = (ty as u64 * h / th as u64) as u32;
        let y1 = (((ty as u64 + 1) * h / th as u64) as u32).max(y0 + 1);
        for tx in 0..tw {
            let x0 = (tx as u64 * w / tw as u64) as u32;
            let x1 = (((tx as u64 + 1) * w / tw as u64) as u32).max(x0 + 1);
            let mut acc = [0u64; 3];
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = src.get_pixel(x, y);
                    for k in 0..3 {
                        acc[k] += p[k] as u64;
                    }
                }
            }
            let n = ((y1 - y0) * (x1 - x0)) as u64;
            out.put_pixel(tx, ty, Rgb(acc.map(|a| ((a + n / 2) / n) as u8)));
        }
    }
    out
}

/// Compose a sheet from `(label, thumbnail)` pairs, in order, row by row.
pub fn compose(items: &[(String, RgbImage)]) -> RgbImage {
    let (cols, _rows, w, h) = layout(items.len());
    let mut sheet = RgbImage::from_pixel(w, h, BG);
    for (k, (label, thumb)) in items.iter().enumerate() {
        let col = k as u32 % cols;
        let row = k as u32 / cols;
        let x0 = PAD + col * (CELL + PAD);
        let y0 = PAD + row * (CELL + LABEL_H + PAD);
        let ox = x0 + (CELL - thumb.width()) / 2;
        let oy = y0 + (CELL - thumb.height()) / 2;
        for (x, y, p) in thumb.enumerate_pixels() {
            sheet.put_pixel(ox + x, oy + y, *p);
        }
        draw_label(&mut sheet, x0, y0 + CELL + 2, label);
    }
    sheet
}

/// 3x5 pixel font, rows top to bottom, drawn at 2x.
fn glyph(ch: char) -> Option<[&'static str; 5]> {
    Some(match ch.to_ascii_lowercase() {
        '0' => ["111", "101", "101", "101", "111"],
        '1' => ["010", "110", "010", "010", "111"],
        '2' => ["111", "001", "111", "100", "111"],
        '3' => ["111", "001", "111", "001", "111"],
        '4' => ["101", "101", "111", "001", "001"],
        '5' => ["111", "100", "111", "001", "111"],
        '6' => ["111", "100", "111", "101", "111"],
        '7' => ["111", "001", "001", "001", "001"],
        '8' => ["111", "101", "111", "101", "111"],
        '9' => ["111", "101", "111", "001", "111"],
        'a' => ["010", "101", "111", "101", "101"],
        'b' => ["110", "101", "110", "101", "110"],
        'c' => ["011", "100", "100", "100", "011"],
        'd' => ["110", "101", "101", "101", "110"],
        'e' => ["111", "100", "110", "100", "111"],
        'f' => ["111", "100", "110", "100", "100"],
        'g' => ["011", "100", "101", "101", "011"],
        'h' => ["101", "101", "111", "101", "101"],
        'i' => ["111", "010", "010", "010", "111"],
        'j' => ["001", "001", "001", "101", "010"],
        'k' => ["101", "101", "110", "101", "101"],
        'l' => ["100", "100", "100", "100", "111"],
        'm' => ["101", "111", "111", "101", "101"],
        'n' => ["110", "101", "101", "101", "101"],
        'o' => ["010", "101", "101", "101", "010"],
        'p' => ["110", "101", "110", "100", "100"],
        'q' => ["010", "101", "101", "110", "011"],
        'r' => ["110", "101", "110", "101", "101"],
        's' => ["011", "100", "010", "001", "110"],
        't' => ["111", "010", "010", "010", "010"],
        'u' => ["101", "101", "101", "101", "111"],
        'v' => ["101", "101", "101", "101", "010"],
        'w' => ["101", "101", "111", "111", "101"],
        'x' => ["101", "101", "010", "101", "101"],
        'y' => ["101", "101", "010", "010", "010"],
        'z' => ["111", "001", "010", "100", "111"],
        '-' => ["000", "000", "111", "000", "000"],
        '.' => ["000", "000", "000", "000", "010"],
        ' ' => ["000", "000", "000", "000", "000"],
        _ => return None,
    })
}

fn draw_label(img: &mut RgbImage, x0: u32, y0: u32, text: &str) {
    let mut x = x0;
    for ch in text.chars() {
        if x + 6 > x0 + CELL {
            break;
        }
        if let Some(rows) = glyph(ch) {
            for (r, bits) in rows.iter().enumerate() {
                for (c, b) in bits.bytes().enumerate() {
                    if b == b'1' {
                        for dy in 0..2 {
                            for dx in 0..2 {
                                let (px, py) = (x + c as u32 * 2 + dx, y0 + r as u32 * 2 + dy);
                                if px < img.width() && py < img.height() {
                                    img.put_pixel(px, py, FG);
                                }
                            }
                        }
                    }
                }
            }
        }
        x += 8;
    }
}
