//! The key point map: the analysis and the chosen key points drawn over the image, so
//! a user can see where the encoder spent its key points and why.

use super::analysis::Analysis;
use super::colour;
use super::decoder::Decoded;
use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};

/// An RGB picture: the luma dimmed to grey, edge strength in red, local detail (the
/// cell size the analysis asks for; finer is bluer) in blue, and one dot per luma key
/// point at its cell centre, white for coarse cells shading to yellow for fine ones.
pub fn render(image: &Raster, decoded: &Decoded) -> Raster {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let planes = colour::forward(image, decoded.header.basis);
    let luma: Vec<f64> = if planes.colour.len() == 3 {
        planes.colour[0].iter().map(|v| v / 3f64.sqrt()).collect()
    } else {
        planes.colour[0].clone()
    };
    let block = decoded.header.block_log2;
    let analysis = Analysis::new(&planes.colour, w, h, block);
    let target = analysis.target_log2(1e-4);
    let max_edge = analysis.edges.iter().copied().fold(1e-9, f64::max);
    let mut rgb = vec![0f32; 3 * w * h];
    for i in 0..w * h {
        let base = 0.45 * luma[i].clamp(0.0, 1.0);
        let edge = (analysis.edges[i] / max_edge).sqrt();
        let detail = 1.0 - target[i] as f64 / block.max(1) as f64;
        rgb[i] = (base + 0.55 * edge) as f32;
        rgb[w * h + i] = base as f32;
        rgb[2 * w * h + i] = (base + 0.4 * detail) as f32;
    }
    for c in &decoded.luma_cells {
        let (x0, y0, x1, y1) = c.clip(decoded.header.width, decoded.header.height);
        let (cx, cy) = (((x0 + x1) / 2) as usize, ((y0 + y1) / 2) as usize);
        let fine = 1.0 - c.log2 as f32 / block.max(1) as f32;
        let r = if c.log2 >= 3 { 1 } else { 0 };
        for dy in -r..=r {
            for dx in -r..=r {
                let (x, y) = (cx as isize + dx, cy as isize + dy);
                if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                    let i = y as usize * w + x as usize;
                    rgb[i] = 1.0;
                    rgb[w * h + i] = 1.0;
                    rgb[2 * w * h + i] = 1.0 - fine;
                }
            }
        }
    }
    Raster::new(
        w as u32,
        h as u32,
        ChannelLayout::Rgb,
        SampleFormat::U8,
        rgb,
    )
    .expect("finite and sized")
}
