//! Warping a decoded `.cae` file: its key points' displacements set from the warp, the
//! file evaluated by forward mapping on the same lattice and splat as images.

use rayon::prelude::*;

use super::resample::{check_supersample, tent, Field, Lattice, Splat, BAND};
use super::Warp;
use crate::TextureError;
use caoen_base::raster::Raster;
use caoen_base::Blend;
use caoen_decoder::decoder::{self, Decoded};
use caoen_decoder::geometry::Frame;
use caoen_decoder::keyset::KeySet;
use caoen_decoder::quadtree::Cell;
use caoen_surface::{Network, SurfaceError};

/// The core Cao En network a codec key-point set stands for, with the given shape
/// vectors (`n x p`, row per key point): its sources, sharpness and weights, the compact
/// blend, normalised.
pub fn keyset_network(ks: &KeySet, p: usize, shapes: Vec<f64>) -> Result<Network, SurfaceError> {
    Network::from_parts(
        3,
        p,
        ks.sources().iter().flatten().copied().collect(),
        shapes,
        ks.sharpness().to_vec(),
        ks.weights().to_vec(),
        vec![Blend::Compact; ks.len()],
        true,
    )
}

/// Distorts a decoded caoen file: every key point's displacement `(dx, dy)` is set to
/// the warp's displacement at its centre, and the file is evaluated by forward mapping
/// (`docs/format.md`, "Reconstruction") with `s x s` samples per pixel on the same
/// lattice and linear splat as [`warp_raster`](super::warp_raster) (so identity moves give the decoder's
/// identity path). Unlike the decoder's forward path, samples may land in any row.
pub fn warp_decoded(d: &Decoded, warp: &Warp, s: u32) -> Result<Raster, TextureError> {
    let s = check_supersample(s)?;
    let hd = &d.header;
    let frame = Frame::new(hd.width, hd.height);
    if frame != warp.frame {
        return Err(TextureError::SizeMismatch {
            warp: (warp.frame.width, warp.frame.height),
            image: (hd.width, hd.height),
        });
    }
    let network = |cells: &[Cell], values: &[Vec<f64>]| -> Result<Network, TextureError> {
        let ks = KeySet::new(frame, cells, hd.kernel);
        let p = 2 + values.len();
        let mut shapes = Vec::with_capacity(cells.len() * p);
        for (i, c) in cells.iter().enumerate() {
            let (cx, cy) = c.centre(hd.width, hd.height);
            shapes.extend(warp.displacement(cx, cy));
            shapes.extend(values.iter().map(|v| v[i]));
        }
        Ok(keyset_network(&ks, p, shapes)?)
    };
    let luma = network(&d.luma_cells, &d.luma_values)?;
    let chroma = if d.chroma_cells.is_empty() {
        None
    } else {
        Some(network(&d.chroma_cells, &d.chroma_values)?)
    };
    let (w, h) = (hd.width as usize, hd.height as usize);
    let nl = d.luma_values.len();
    let nc = nl + chroma.as_ref().map_or(0, |_| 2);
    let lat = Lattice::new(s);
    let spacing = Field::spacing(warp, lat.step);
    let stride = 4 + nc;
    let pl = 2 + nl;
    let mut acc = Splat::new(w, h, nc);
    // The restoration filters reach this many pixel rows past a band: each band's
    // lattice is evaluated with them, filtered, and splatted without them.
    let restoration = hd.restoration.as_ref().filter(|r| r.any());
    let deringing = hd.deringing.filter(|d| d.any());
    // The deringing reads a direction block and two pixels past the rows it filters.
    let halo = restoration.map_or(0, |_| caoen_decoder::restoration::RADIUS)
        + deringing.map_or(0, |_| caoen_decoder::deringing::BLOCK + 2)
        + restoration.filter(|r| r.last.is_some()).map_or(0, |_| {
            caoen_decoder::restoration::Restoration::last_reach((lat.step, lat.step))
        });
    for band in (0..h).step_by(BAND) {
        let (y0, y1) = (band.saturating_sub(halo), (band + BAND + halo).min(h));
        let mut rows: Vec<Vec<f64>> = (y0..y1)
            .into_par_iter()
            .map(|y| -> Result<_, TextureError> {
                let pts = lat.row(w, y);
                let dom: Vec<f64> = pts
                    .chunks_exact(2)
                    .flat_map(|p| frame.embed(p[0], p[1]))
                    .collect();
                let ly = luma.eval_batch(&dom)?;
                let cy = chroma.as_ref().map(|n| n.eval_batch(&dom)).transpose()?;
                // The tents follow the warp's stretch (the file's own displacements
                // interpolate the same field between its key points).
                let field = Field::band(warp, spacing, pts[1], pts[pts.len() - 1]);
                let mut out = Vec::with_capacity(pts.len() / 2 * stride);
                for (k, p) in pts.chunks_exact(2).enumerate() {
                    let l = &ly[k * pl..(k + 1) * pl];
                    let (rx, ry) = tent(lat.step, &field.at(p[0], p[1]).1);
                    out.extend([p[0] + l[0], p[1] + l[1], rx, ry]);
                    // The detail layer rides with its sample: evaluated at the
                    // sample's own position, moved with it.
                    let detail = d.detail.as_ref().map(|det| det.at(p[0], p[1]));
                    let dl = |c: usize| detail.as_ref().map_or(0.0, |v| v[c]);
                    out.push(l[2] + dl(0));
                    out.extend_from_slice(&l[3..]);
                    if let Some(c) = &cy {
                        out.extend([c[k * 4 + 2] + dl(1), c[k * 4 + 3] + dl(2)]);
                    }
                }
                Ok(out)
            })
            .collect::<Result<_, _>>()?;
        if restoration.is_some() || deringing.is_some() {
            // The lattice's colour planes, filtered with the lattice's spacing (the
            // decoder's forward path does the same on its whole lattice).
            let colour: Vec<usize> = std::iter::once(4).chain(4 + nl..4 + nc).collect();
            let size = (w * lat.s(), (y1 - y0) * lat.s());
            let mut planes: Vec<Vec<f32>> = colour
                .iter()
                .map(|&c| {
                    rows.iter()
                        .flat_map(|row| row.chunks_exact(stride).map(move |v| v[c] as f32))
                        .collect()
                })
                .collect();
            if let Some(r) = restoration {
                r.apply(&mut planes, size, (lat.step, lat.step));
            }
            if let Some(d) = deringing {
                d.apply(
                    &mut planes,
                    size,
                    (lat.step, lat.step),
                    hd.deringing_steps(),
                );
            }
            if let Some(r) = restoration {
                r.apply_last(&mut planes[0], size, (lat.step, lat.step));
            }
            for (plane, &c) in planes.iter().zip(&colour) {
                let mut values = plane.iter();
                for row in rows.iter_mut() {
                    for v in row.chunks_exact_mut(stride) {
                        v[c] = *values.next().expect("one value per lattice point") as f64;
                    }
                }
            }
        }
        for row in &rows[band - y0..(band + BAND).min(h) - y0] {
            for v in row.chunks_exact(stride) {
                acc.add(v[0], v[1], v[2], v[3], &v[4..]);
            }
        }
    }
    let planes = acc.finish();
    let alpha = hd.layout.has_alpha().then(|| planes[1].clone());
    let mut colour = vec![planes[0].clone()];
    if nc > nl {
        colour.push(planes[nl].clone());
        colour.push(planes[nl + 1].clone());
    }
    Ok(decoder::to_raster(
        hd,
        caoen_decoder::colour::CodingPlanes { colour, alpha },
        hd.width,
        hd.height,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    // The codec's fast per-pixel path evaluates exactly the network its key points
    // stand for.
    #[test]
    fn per_pixel_path_equals_the_core_network() {
        let (_, cells) = caoen_decoder::quadtree::random_tree(53, 37, 7, |d| d.is_multiple_of(2));
        let params = caoen_decoder::keyset::KernelParams {
            sigma_factor: 0.4,
            weight_exponent: 1.0,
        };
        let ks = KeySet::new(Frame::new(53, 37), &cells, params);
        let frame = *ks.frame();
        let colours: Vec<f64> = (0..ks.len()).map(|i| (i as f64 * 0.37).sin()).collect();
        let net = keyset_network(&ks, 1, colours.clone()).unwrap();
        let fast = ks.render_per_pixel(&[colours], 53, 37);
        let mut worst: f64 = 0.0;
        for y in 0..37 {
            for x in 0..53 {
                let p = frame.embed(x as f64 + 0.5, y as f64 + 0.5);
                let (v, cover) = net.eval_with_coverage(&p).unwrap();
                assert!(cover > 0.0, "pixel {x},{y} uncovered");
                worst = worst.max((v[0] - fast[0][y * 53 + x]).abs());
            }
        }
        assert!(
            worst < 1e-12,
            "per-pixel path differs from the core network by {worst}"
        );
    }
}
