//! The forward-mapping path: the network sampled `s x s` times per output pixel, each
//! sample splatted where it maps, and the pixels no sample reached filled from their
//! neighbours.

use super::Decoded;
use crate::colour::CodingPlanes;
use crate::detail::DetailEval;
use crate::geometry::Frame;
use crate::keyset::{Grid, KeySet};
use crate::CodecError;

/// Forward mapping with `s x s` samples per output pixel.
///
/// Samples lie on the lattice refined by `1/s` that contains every output pixel centre;
/// each mapped sample is splatted with a tent one lattice step wide (linear splatting),
/// so a sample landing on a pixel centre decides that pixel alone and samples between
/// centres interpolate. An unedited file therefore reproduces the identity path, and a
/// warped one is reconstructed from `s x s` times denser samples. Along an axis where
/// the output is smaller than the coded image, the tent widens to one output pixel (a
/// triangle filter), so the extra samples anti-alias the downscale.
///
/// The network is evaluated on the whole lattice by [`KeySet::eval_grid`] (tested equal
/// to the core network). Its position outputs are the sample's own position plus the
/// interpolated key-point displacements; version 2 files carry no displacements, so
/// those outputs are the lattice positions themselves and are not evaluated.
pub fn render_forward(
    d: &Decoded,
    ow: u32,
    oh: u32,
    s: u32,
) -> Result<CodingPlanes<f32>, CodecError> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let (sx, sy) = (h.width as f64 / ow as f64, h.height as f64 / oh as f64);
    let (owu, ohu) = (ow as usize, oh as usize);
    let ss = s as usize;
    let step = 1.0 / s as f64;
    let first = -((ss / 2) as f64) * step;
    // Lattice point (i, j) sits at output position (0.5 + first + i step, ...), which is
    // coded position (that x sx, that y sy).
    let grid = Grid {
        x0: (0.5 + first) * sx,
        dx: step * sx,
        nx: owu * ss,
        y0: (0.5 + first) * sy,
        dy: step * sy,
        ny: ohu * ss,
    };
    let mut samples = KeySet::new(frame, &d.luma_cells, h.kernel).eval_grid(&d.luma_values, &grid);
    let nl = samples.len();
    if !d.chroma_cells.is_empty() {
        samples.extend(
            KeySet::new(frame, &d.chroma_cells, h.kernel).eval_grid(&d.chroma_values, &grid),
        );
    }
    if let Some(detail) = &d.detail {
        // The layer's cosine series at the lattice positions, added to the colour
        // outputs (Y, then C1 and C2 after the luma set's alpha).
        let layer = DetailEval::new(detail, &grid).eval();
        let colour = std::iter::once(0).chain(nl..nl + 2);
        for (c, plane) in colour.zip(layer) {
            for (s, v) in samples[c].iter_mut().zip(plane) {
                *s += v;
            }
        }
    }
    if h.restoration.is_some() || h.deringing.is_some() {
        // The lattice is the output this path samples the picture on.
        let mut colour: Vec<Vec<f32>> = std::iter::once(0)
            .chain(nl..samples.len())
            .map(|c| std::mem::take(&mut samples[c]))
            .collect();
        if let Some(r) = &h.restoration {
            r.apply(&mut colour, (grid.nx, grid.ny), (grid.dx, grid.dy));
        }
        if let Some(d) = &h.deringing {
            d.apply(
                &mut colour,
                (grid.nx, grid.ny),
                (grid.dx, grid.dy),
                h.deringing_steps(),
            );
        }
        if let Some(r) = &h.restoration {
            r.apply_last(&mut colour[0], (grid.nx, grid.ny), (grid.dx, grid.dy));
        }
        for (c, plane) in std::iter::once(0).chain(nl..samples.len()).zip(colour) {
            samples[c] = plane;
        }
    }
    let nc = samples.len();
    let mut planes = vec![vec![0.0f64; owu * ohu]; nc];
    let mut weight = vec![0.0; owu * ohu];
    let (rx, ry) = (
        if sx > 1.0 { 1.0 } else { step },
        if sy > 1.0 { 1.0 } else { step },
    );
    for lj in 0..grid.ny {
        let y = 0.5 + first + lj as f64 * step;
        // Pixel rows within the tent's reach of the sample row.
        let (j0, j1) = (
            (y - 0.5 - ry).ceil().max(0.0),
            (y - 0.5 + ry).floor().min(ohu as f64 - 1.0),
        );
        for li in 0..grid.nx {
            let x = 0.5 + first + li as f64 * step;
            let k = lj * grid.nx + li;
            let (i0, i1) = (
                (x - 0.5 - rx).ceil().max(0.0),
                (x - 0.5 + rx).floor().min(owu as f64 - 1.0),
            );
            let mut j = j0;
            while j <= j1 {
                let wy = 1.0 - (y - (j + 0.5)).abs() / ry;
                let mut i = i0;
                while i <= i1 {
                    let wx = 1.0 - (x - (i + 0.5)).abs() / rx;
                    let w = wx * wy;
                    if w > 0.0 {
                        let idx = j as usize * owu + i as usize;
                        weight[idx] += w;
                        for c in 0..nc {
                            planes[c][idx] += w * samples[c][k] as f64;
                        }
                    }
                    i += 1.0;
                }
                j += 1.0;
            }
        }
    }
    for idx in 0..owu * ohu {
        if weight[idx] > 0.0 {
            for p in planes.iter_mut() {
                p[idx] /= weight[idx];
            }
        }
    }
    fill_holes(&mut planes, &mut weight, owu, ohu);
    let mut planes = planes
        .into_iter()
        .map(|p| p.into_iter().map(|v| v as f32).collect::<Vec<f32>>());
    let mut colour: Vec<Vec<f32>> = planes.by_ref().take(1).collect();
    let alpha = if nl > 1 { planes.next() } else { None };
    colour.extend(planes);
    Ok(CodingPlanes { colour, alpha })
}

/// Fills pixels no sample reached by repeatedly averaging their filled neighbours
/// (a push-pull fill at full resolution: terminates because each pass fills at least
/// the holes next to filled pixels).
pub fn fill_holes(planes: &mut [Vec<f64>], weight: &mut [f64], w: usize, h: usize) {
    if weight.iter().all(|&v| v > 0.0) || weight.iter().all(|&v| v == 0.0) {
        return;
    }
    loop {
        let holes: Vec<usize> = (0..w * h).filter(|&i| weight[i] == 0.0).collect();
        if holes.is_empty() {
            return;
        }
        let mut filled = Vec::new();
        for &i in &holes {
            let (x, y) = (i % w, i / w);
            let mut n = 0.0;
            let mut sum = vec![0.0; planes.len()];
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                    let j = ny as usize * w + nx as usize;
                    if weight[j] > 0.0 {
                        n += 1.0;
                        for (c, p) in planes.iter().enumerate() {
                            sum[c] += p[j];
                        }
                    }
                }
            }
            if n > 0.0 {
                filled.push((i, sum.into_iter().map(|v| v / n).collect::<Vec<_>>()));
            }
        }
        for (i, vals) in filled {
            weight[i] = 1.0;
            for (c, v) in vals.into_iter().enumerate() {
                planes[c][i] = v;
            }
        }
    }
}
