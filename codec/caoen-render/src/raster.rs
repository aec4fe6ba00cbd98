//! Z-buffer rasterisation of triangle meshes: the "mesh" render method.
//!
//! Triangles are projected, scanned at pixel centres with edge functions, and every
//! attribute (depth, normal, texture coordinates) is interpolated perspective-correctly
//! (linear in `1/z` on screen). The image is cut into bands of rows rendered in
//! parallel; within a band triangles are drawn in mesh order and ties keep the first,
//! so the result does not depend on the number of threads.

use rayon::prelude::*;

use super::camera::{Camera, Projection};
use super::framebuffer::{GBuffer, Hit};
use caoen_geometry::mesh::Mesh;
use caoen_geometry::vector::normalise_f32;

/// Rows per parallel band.
const BAND: u32 = 16;

/// Draws `mesh` (world coordinates) into `buf` as scene object `object`.
///
/// Triangles with a corner behind a perspective camera are skipped (the scenes this
/// renders keep the camera outside every object). Returns the number of triangles drawn.
pub fn rasterise(mesh: &Mesh, camera: &Camera, object: u32, buf: &mut GBuffer) -> usize {
    let (w, h) = (buf.width, buf.height);
    let perspective = matches!(camera.projection, Projection::Perspective { .. });
    let screen: Vec<Option<[f64; 3]>> = mesh
        .positions
        .par_iter()
        .map(|p| camera.project(*p))
        .collect();
    let has_uv = mesh.corner_uvs.len() == mesh.triangles.len();
    // Bin triangles into bands by their vertical extent.
    let bands = h.div_ceil(BAND) as usize;
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
    let mut drawn = 0;
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let Some(s) = t
            .iter()
            .map(|&v| screen[v as usize])
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let ymin = s.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let ymax = s.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        let xmin = s.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
        let xmax = s.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max);
        if !(ymax >= 0.0 && ymin < h as f64 && xmax >= 0.0 && xmin < w as f64) {
            continue;
        }
        drawn += 1;
        let b0 = (ymin.max(0.0) as u32 / BAND) as usize;
        let b1 = ((ymax.min(h as f64 - 1.0)) as u32 / BAND) as usize;
        for bin in &mut bins[b0..=b1.min(bands - 1)] {
            bin.push(ti as u32);
        }
    }
    buf.hits
        .par_chunks_mut((BAND * w) as usize)
        .zip(bins.par_iter())
        .enumerate()
        .for_each(|(band, (rows, tris))| {
            let y0 = band as u32 * BAND;
            let y1 = (y0 + BAND).min(h);
            for &ti in tris {
                let t = mesh.triangles[ti as usize];
                let s = t.map(|v| screen[v as usize].expect("binned triangles are in front"));
                // Signed doubled area; zero-area triangles cover no pixel centre.
                let area = (s[1][0] - s[0][0]) * (s[2][1] - s[0][1])
                    - (s[2][0] - s[0][0]) * (s[1][1] - s[0][1]);
                if area == 0.0 || !area.is_finite() {
                    continue;
                }
                let xmin = s.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
                let xmax = s.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max);
                let ymin = s.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
                let ymax = s.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
                let px0 = (xmin - 0.5).ceil().max(0.0) as u32;
                let px1 = ((xmax - 0.5).floor().min(w as f64 - 1.0)).max(-1.0);
                let py0 = ((ymin - 0.5).ceil().max(y0 as f64)) as u32;
                let py1 = (ymax - 0.5).floor().min(y1 as f64 - 1.0);
                if px1 < px0 as f64 || py1 < py0 as f64 {
                    continue;
                }
                let (px1, py1) = (px1 as u32, py1 as u32);
                let inv_z = s.map(|p| if perspective { 1.0 / p[2] } else { 1.0 });
                for py in py0..=py1 {
                    let y = py as f64 + 0.5;
                    for px in px0..=px1 {
                        let x = px as f64 + 0.5;
                        let edge = |a: [f64; 3], b: [f64; 3]| {
                            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
                        };
                        let mut l = [edge(s[1], s[2]), edge(s[2], s[0]), edge(s[0], s[1])];
                        if area < 0.0 {
                            l = l.map(|v| -v);
                        }
                        if l.iter().any(|v| *v < 0.0) {
                            continue;
                        }
                        let a = area.abs();
                        // Perspective-correct weights: screen barycentrics over z.
                        let wgt = [
                            l[0] / a * inv_z[0],
                            l[1] / a * inv_z[1],
                            l[2] / a * inv_z[2],
                        ];
                        let sum = wgt[0] + wgt[1] + wgt[2];
                        if !(sum > 0.0) {
                            continue;
                        }
                        let b = wgt.map(|v| v / sum);
                        let depth = b[0] * s[0][2] + b[1] * s[1][2] + b[2] * s[2][2];
                        let i = ((py - y0) * w + px) as usize;
                        if matches!(&rows[i], Some(hh) if hh.depth <= depth) {
                            continue;
                        }
                        let n =
                            t.map(|v| mesh.normals.get(v as usize).copied().unwrap_or([0.0; 3]));
                        let normal: [f32; 3] = std::array::from_fn(|k| {
                            (b[0] * n[0][k] + b[1] * n[1][k] + b[2] * n[2][k]) as f32
                        });
                        let uv = if has_uv {
                            let c = mesh.corner_uvs[ti as usize];
                            std::array::from_fn(|k| {
                                (b[0] * c[0][k] + b[1] * c[1][k] + b[2] * c[2][k]) as f32
                            })
                        } else {
                            [f32::NAN; 2]
                        };
                        rows[i] = Some(Hit {
                            depth,
                            normal: normalise_f32(normal),
                            uv,
                            object,
                        });
                    }
                }
            }
        });
    drawn
}
