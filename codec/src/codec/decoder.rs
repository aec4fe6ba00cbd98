//! The decoder: parse, rebuild the key points, evaluate the network.
//!
//! Two evaluation paths: the identity fast path evaluates colours at output pixel
//! centres through [`KeySet::render`]; the forward-mapping path samples the domain
//! S x S times per pixel, maps every sample through the core [`Network`] to an output
//! position and colour, and splats the colour there (the paper's depth-buffer method in
//! 2-D), filling any pixel no sample reached from its neighbours.
//!
//! The position outputs interpolate key-point *displacements* (edited minus original
//! position; zero in a file that was not edited), added to the sample's own position.
//! Interpolating the key points' absolute positions instead would shift edges: the
//! normalised average of cell centres is biased wherever cell sizes change.

use rayon::prelude::*;

use super::bitstream::{self, tag, Header};
use super::colour::{self, CodingPlanes};
use super::entropy::RangeSource;
use super::geometry::Frame;
use super::keyset::KeySet;
use super::model::chroma_cells;
use super::quadtree::Cell;
use super::syntax::{self, MAX_BINS_PER_VALUE};
use super::{CodecError, DecodeOptions, MAX_SIDE};
use crate::raster::{Raster, SampleFormat};

/// The decoded key points and their values, before evaluation.
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The header.
    pub header: Header,
    /// Luma cells in coding order.
    pub luma_cells: Vec<Cell>,
    /// Chroma cells in coding order.
    pub chroma_cells: Vec<Cell>,
    /// Luma-set channel values (Y, then alpha).
    pub luma_values: Vec<Vec<f64>>,
    /// Chroma values (C1, C2).
    pub chroma_values: Vec<Vec<f64>>,
}

fn read_section_values(
    payload: &[u8],
    cells: &[Cell],
    width: u32,
    height: u32,
    steps: &[f64],
) -> Result<Vec<Vec<f64>>, CodecError> {
    let max_bins = MAX_BINS_PER_VALUE * cells.len() as u64 * steps.len() as u64;
    let mut src = RangeSource::new(payload, max_bins)?;
    let nbs = syntax::neighbours(cells, width, height);
    steps
        .iter()
        .map(|&step| {
            Ok(syntax::read_values(cells, &nbs, &mut src)?
                .into_iter()
                .map(|q| q as f64 * step)
                .collect())
        })
        .collect()
}

/// Parses and entropy-decodes a file (no pixel evaluation).
pub fn read(bytes: &[u8], max_pixels: u64) -> Result<Decoded, CodecError> {
    let parsed = bitstream::parse(bytes, max_pixels)?;
    let header = parsed.header.clone();
    let shape = header.shape();
    // The walk visits at most 4/3 of the leaves as nodes; each reads one flag.
    let max_nodes = shape.max_leaves() * 4 / 3 + 4;
    let mut src = RangeSource::new(parsed.payload(tag::TREE).unwrap_or(&[]), max_nodes)?;
    let luma_cells = syntax::read_tree(&shape, &mut src)?;
    if luma_cells.len() != header.luma_count as usize {
        return Err(CodecError::Format(format!(
            "tree has {} leaves, header says {}",
            luma_cells.len(),
            header.luma_count
        )));
    }
    let colour = header.layout.colour_channels() == 3;
    let chroma_cells = if colour {
        chroma_cells(&shape, &luma_cells, header.chroma_pruned)
    } else {
        Vec::new()
    };
    if chroma_cells.len() != header.chroma_count as usize {
        return Err(CodecError::Format(format!(
            "chroma tree has {} leaves, header says {}",
            chroma_cells.len(),
            header.chroma_count
        )));
    }
    let mut steps = vec![header.step_luma as f64];
    if header.layout.has_alpha() {
        steps.push(header.step_alpha as f64);
    }
    let (w, h) = (header.width, header.height);
    let luma_values = read_section_values(
        parsed.payload(tag::LUMA).unwrap_or(&[]),
        &luma_cells,
        w,
        h,
        &steps,
    )?;
    let chroma_values = if colour {
        let s = header.step_chroma as f64;
        read_section_values(
            parsed.payload(tag::CHROMA).unwrap_or(&[]),
            &chroma_cells,
            w,
            h,
            &[s, s],
        )?
    } else {
        Vec::new()
    };
    Ok(Decoded {
        header,
        luma_cells,
        chroma_cells,
        luma_values,
        chroma_values,
    })
}

fn output_size(header: &Header, opts: &DecodeOptions) -> Result<(u32, u32), CodecError> {
    let (ow, oh) = opts.size.unwrap_or((header.width, header.height));
    if ow == 0 || oh == 0 || ow > MAX_SIDE || oh > MAX_SIDE {
        return Err(CodecError::Parameter {
            name: "output size",
            value: format!("{ow}x{oh}"),
            reason: "1..=16384 per side",
        });
    }
    let px = ow as u64 * oh as u64;
    if px > opts.max_pixels {
        return Err(CodecError::Limit {
            what: "output pixels",
            value: px,
            limit: opts.max_pixels,
        });
    }
    Ok((ow, oh))
}

/// Decodes a file into a raster.
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    let d = read(bytes, opts.max_pixels)?;
    let (ow, oh) = output_size(&d.header, opts)?;
    let planes = match opts.supersample {
        None => render_identity(&d, ow, oh),
        Some(s) if (1..=4).contains(&s) => render_forward(&d, ow, oh, s)?,
        Some(s) => {
            return Err(CodecError::Parameter {
                name: "supersample",
                value: s.to_string(),
                reason: "1..=4",
            });
        }
    };
    Ok(to_raster(&d.header, planes, ow, oh))
}

/// Evaluates the key points at output pixel centres (the identity fast path).
pub fn render_identity(d: &Decoded, ow: u32, oh: u32) -> CodingPlanes {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let luma = KeySet::new(frame, &d.luma_cells, h.kernel).render(&d.luma_values, ow, oh);
    let mut colour = vec![luma[0].clone()];
    if !d.chroma_cells.is_empty() {
        colour.extend(KeySet::new(frame, &d.chroma_cells, h.kernel).render(
            &d.chroma_values,
            ow,
            oh,
        ));
    }
    CodingPlanes {
        colour,
        alpha: h.layout.has_alpha().then(|| luma[1].clone()),
    }
}

/// Forward mapping through the core network with `s x s` samples per output pixel.
///
/// Samples lie on the lattice refined by `1/s` that contains every output pixel centre;
/// each mapped sample is splatted with a tent one lattice step wide (linear splatting),
/// so a sample landing on a pixel centre decides that pixel alone and samples between
/// centres interpolate. An unedited file therefore reproduces the identity path, and a
/// warped one is reconstructed from `s x s` times denser samples. Along an axis where
/// the output is smaller than the coded image, the tent widens to one output pixel (a
/// triangle filter), so the extra samples anti-alias the downscale.
pub fn render_forward(d: &Decoded, ow: u32, oh: u32, s: u32) -> Result<CodingPlanes, CodecError> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    // Shape vectors: (dx, dy, values...) with zero displacement in an unedited file.
    let network = |cells: &[Cell], values: &[Vec<f64>]| {
        let ks = KeySet::new(frame, cells, h.kernel);
        let p = 2 + values.len();
        let mut shapes = Vec::with_capacity(cells.len() * p);
        for i in 0..cells.len() {
            shapes.extend([0.0, 0.0]);
            shapes.extend(values.iter().map(|v| v[i]));
        }
        ks.network(p, shapes)
    };
    let luma_net = network(&d.luma_cells, &d.luma_values)?;
    let chroma_net = if d.chroma_cells.is_empty() {
        None
    } else {
        Some(network(&d.chroma_cells, &d.chroma_values)?)
    };
    let (sx, sy) = (h.width as f64 / ow as f64, h.height as f64 / oh as f64);
    let (owu, ohu) = (ow as usize, oh as usize);
    let nl = d.luma_values.len();
    let nc = nl + chroma_net.as_ref().map_or(0, |_| 2);
    let ss = s as usize;
    let step = 1.0 / s as f64;
    let first = -((ss / 2) as f64) * step;
    let mut planes = vec![vec![0.0; owu * ohu]; nc];
    let mut weight = vec![0.0; owu * ohu];
    // Rows are sampled in parallel in bands, then splatted in a fixed order.
    const BAND: usize = 16;
    for band in (0..ohu).step_by(BAND) {
        let rows: Vec<Vec<f64>> = (band..(band + BAND).min(ohu))
            .into_par_iter()
            .map(|oy| -> Result<Vec<f64>, CodecError> {
                let mut domain = Vec::with_capacity(owu * ss * ss * 3);
                let mut pos = Vec::with_capacity(owu * ss * ss * 2);
                for b in 0..ss {
                    let y = oy as f64 + 0.5 + first + b as f64 * step;
                    for ox in 0..owu {
                        for a in 0..ss {
                            let x = ox as f64 + 0.5 + first + a as f64 * step;
                            domain.extend(frame.embed(x * sx, y * sy));
                            pos.extend([x, y]);
                        }
                    }
                }
                let ly = luma_net.eval_batch(&domain)?;
                let cy = chroma_net
                    .as_ref()
                    .map(|n| n.eval_batch(&domain))
                    .transpose()?;
                // Per sample: output position (x, y) then the nc channel values.
                let mut out = Vec::with_capacity(pos.len() / 2 * (2 + nc));
                let (pl, pc) = (2 + nl, 4);
                for k in 0..pos.len() / 2 {
                    out.push(pos[2 * k] + ly[k * pl] / sx);
                    out.push(pos[2 * k + 1] + ly[k * pl + 1] / sy);
                    out.extend_from_slice(&ly[k * pl + 2..(k + 1) * pl]);
                    if let Some(cy) = &cy {
                        out.extend_from_slice(&cy[k * pc + 2..(k + 1) * pc]);
                    }
                }
                Ok(out)
            })
            .collect::<Result<_, _>>()?;
        let (rx, ry) = (
            if sx > 1.0 { 1.0 } else { step },
            if sy > 1.0 { 1.0 } else { step },
        );
        for row in &rows {
            for sample in row.chunks_exact(2 + nc) {
                let (x, y) = (sample[0], sample[1]);
                if !(x.is_finite() && y.is_finite()) {
                    continue;
                }
                // Pixel centres within the tent's reach of the sample.
                let (i0, i1) = (
                    (x - 0.5 - rx).ceil().max(0.0),
                    (x - 0.5 + rx).floor().min(owu as f64 - 1.0),
                );
                let (j0, j1) = (
                    (y - 0.5 - ry).ceil().max(0.0),
                    (y - 0.5 + ry).floor().min(ohu as f64 - 1.0),
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
                                planes[c][idx] += w * sample[2 + c];
                            }
                        }
                        i += 1.0;
                    }
                    j += 1.0;
                }
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
    let alpha = h.layout.has_alpha().then(|| planes[1].clone());
    let mut colour = vec![planes[0].clone()];
    if nc > nl {
        colour.push(planes[nl].clone());
        colour.push(planes[nl + 1].clone());
    }
    Ok(CodingPlanes { colour, alpha })
}

/// Fills pixels no sample reached by repeatedly averaging their filled neighbours
/// (a push-pull fill at full resolution: terminates because each pass fills at least
/// the holes next to filled pixels).
pub(crate) fn fill_holes(planes: &mut [Vec<f64>], weight: &mut [f64], w: usize, h: usize) {
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

pub(crate) fn to_raster(header: &Header, planes: CodingPlanes, ow: u32, oh: u32) -> Raster {
    let mut samples = colour::inverse(&planes, ow, oh, header.format);
    // Output is where out-of-range values are clamped: integer formats to [0, 1],
    // alpha always.
    let n = ow as usize * oh as usize;
    let channels = header.layout.channels();
    for (c, chunk) in samples.chunks_mut(n).enumerate() {
        let is_alpha = header.layout.has_alpha() && c == channels - 1;
        if is_alpha || header.format != SampleFormat::F32 {
            chunk.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0));
        }
    }
    Raster::new(ow, oh, header.layout, header.format, samples)
        .expect("decoded samples are finite and sized")
}
