//! The warp's exact Jacobian (the network's chained with the embedding's) and the
//! fold-over check on a sampled grid.

use rayon::prelude::*;

use super::{FoldReport, Warp};
use caoen_decoder::geometry::Frame;

impl Warp {
    /// The Jacobian `[[dX/dx, dX/dy], [dY/dx, dY/dy]]` of the map at `(x, y)`: the
    /// network's exact Jacobian chained with the embedding's.
    pub fn jacobian(&self, x: f64, y: f64) -> [[f64; 2]; 2] {
        let (_, jn) = self
            .net
            .eval_with_jacobian(&self.frame.embed(x, y))
            .expect("3-D input");
        let e = embed_jacobian(&self.frame, x, y);
        let mut j = [[1.0, 0.0], [0.0, 1.0]];
        for (r, row) in j.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v += (0..3).map(|k| jn[r * 3 + k] * e[k][c]).sum::<f64>();
            }
        }
        j
    }

    /// Checks the Jacobian determinant on a grid with `step` pixels between samples.
    pub fn check_folds(&self, step: f64) -> FoldReport {
        let (w, h) = (self.frame.width as f64, self.frame.height as f64);
        let step = step.max(0.5);
        let (nx, ny) = ((w / step).ceil() as usize, (h / step).ceil() as usize);
        let dets: Vec<f64> = (0..=ny)
            .into_par_iter()
            .flat_map_iter(|j| {
                (0..=nx).map(move |i| {
                    let (x, y) = ((i as f64 * step).min(w), (j as f64 * step).min(h));
                    let m = self.jacobian(x, y);
                    m[0][0] * m[1][1] - m[0][1] * m[1][0]
                })
            })
            .collect();
        FoldReport {
            samples: dets.len(),
            folded: dets.iter().filter(|&&d| d <= 0.0).count(),
            min_det: dets.iter().copied().fold(f64::INFINITY, f64::min),
        }
    }
}

/// `dP/d(x, y)` of the stereographic embedding (3 x 2).
fn embed_jacobian(f: &Frame, x: f64, y: f64) -> [[f64; 2]; 3] {
    let (u, v) = f.plane(x, y);
    let inv_s = 1.0 / f.width.max(f.height).max(1) as f64;
    let d = 1.0 + u * u + v * v;
    let d2 = d * d;
    [
        [
            2.0 * (d - 2.0 * u * u) / d2 * inv_s,
            -4.0 * u * v / d2 * inv_s,
        ],
        [
            -4.0 * u * v / d2 * inv_s,
            2.0 * (d - 2.0 * v * v) / d2 * inv_s,
        ],
        [-4.0 * u / d2 * inv_s, -4.0 * v / d2 * inv_s],
    ]
}
