//! The 3-D distortion of the paper (section 9): a network from S^3 (R^3 embedded by
//! inverse stereographic projection) to 3-D displacements, with control points moved
//! exactly and identity anchors on a coarse grid around the object, applied to a
//! surface model (its key points' position shapes are moved) or to a mesh (its
//! vertices are moved). As in 2-D, fold-over is detected by sampling the Jacobian
//! determinant of the map over the box ([`Warp3::check_folds`]).

use rayon::prelude::*;

use super::warp::{dist, nearest_other, FoldReport};
use super::TextureError;
use caoen_surface::model_file::MAX_SHAPE;
use caoen_surface::{Blend, Network, SurfaceModel};

/// One 3-D control point move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move3 {
    /// Original position.
    pub from: [f64; 3],
    /// Target position.
    pub to: [f64; 3],
}

/// Most moves a surface warp takes (each one adds a key point to a dense solve).
pub const MAX_MOVES: usize = 256;

/// A warp of 3-D space around a box.
#[derive(Debug, Clone)]
pub struct Warp3 {
    lo: [f64; 3],
    hi: [f64; 3],
    embedding: Stereographic,
    net: Network,
    anchors: usize,
}

impl Warp3 {
    /// Builds the warp for the box `lo..hi` (anchors on a 4-cell grid over the box
    /// grown by a quarter on each side) so every control point lands on its target.
    pub fn new(lo: [f64; 3], hi: [f64; 3], moves: &[Move3]) -> Result<Self, TextureError> {
        if !lo.iter().chain(&hi).all(|v| v.is_finite()) {
            return Err(TextureError::BadBox {
                what: "warp box",
                lo,
                hi,
            });
        }
        if let Some(index) = moves
            .iter()
            .position(|m| !m.from.iter().chain(&m.to).all(|v| v.is_finite()))
        {
            return Err(TextureError::NonFiniteMove3 {
                index,
                from: moves[index].from,
                to: moves[index].to,
            });
        }
        // A surface model holds coordinates up to MAX_SHAPE: a move past them could only
        // write a model its own reader refuses.
        if let Some(index) = moves
            .iter()
            .position(|m| m.from.iter().chain(&m.to).any(|v| v.abs() > MAX_SHAPE))
        {
            return Err(TextureError::MoveOutOfRange {
                index,
                from: moves[index].from,
                to: moves[index].to,
                max: MAX_SHAPE,
            });
        }
        if moves.is_empty() {
            return Err(TextureError::NoMoves { max: MAX_MOVES });
        }
        if moves.len() > MAX_MOVES {
            return Err(TextureError::TooManyMoves {
                moves: moves.len(),
                max: MAX_MOVES,
            });
        }
        let size = (0..3)
            .map(|k| hi[k] - lo[k])
            .fold(0.0f64, f64::max)
            .max(1e-9);
        let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let embedding = Stereographic {
            centre,
            inv_scale: 1.0 / size,
        };
        let cells = 4usize;
        let g = 1.5 * size / cells as f64;
        let mut kp: Vec<([f64; 3], [f64; 3], f64)> = Vec::new();
        let froms: Vec<[f64; 3]> = moves.iter().map(|m| m.from).collect();
        for (index, (m, nearest)) in moves.iter().zip(nearest_other(&froms)).enumerate() {
            if nearest < 1e-9 * size {
                return Err(TextureError::CoincidentMoves {
                    index,
                    from: m.from,
                });
            }
            let d = [0, 1, 2].map(|k| m.to[k] - m.from[k]);
            kp.push((m.from, d, 0.6 * nearest.min(g)));
        }
        let mut anchors = 0;
        for i in 0..=cells {
            for j in 0..=cells {
                for k in 0..=cells {
                    let p = [
                        centre[0] - 0.75 * size + (i as f64) * g,
                        centre[1] - 0.75 * size + (j as f64) * g,
                        centre[2] - 0.75 * size + (k as f64) * g,
                    ];
                    if moves.iter().any(|m| dist(m.from, p) < 0.75 * g) {
                        continue;
                    }
                    kp.push((p, [0.0; 3], 0.6 * g));
                    anchors += 1;
                }
            }
        }
        let sources: Vec<[f64; 4]> = kp.iter().map(|k| embedding.point(k.0)).collect();
        let q: Vec<f64> = kp
            .iter()
            .map(|k| {
                let r2: f64 = embedding.local(k.0).iter().map(|v| v.powi(2)).sum();
                ((1.0 + r2) / (2.0 * k.2 * embedding.inv_scale)).powi(2)
            })
            .collect();
        let targets: Vec<f64> = kp.iter().flat_map(|k| k.1).collect();
        let net = Network::interpolating(
            4,
            3,
            sources.iter().flatten().copied().collect(),
            q,
            Blend::Exponential,
            &targets,
        )
        .map_err(|source| TextureError::Unsolvable { source })?;
        Ok(Warp3 {
            lo,
            hi,
            embedding,
            net,
            anchors,
        })
    }

    /// Number of identity anchors.
    pub fn anchors(&self) -> usize {
        self.anchors
    }

    /// Where `p` goes.
    pub fn map(&self, p: [f64; 3]) -> [f64; 3] {
        let d = self.net.eval(&self.embedding.point(p)).expect("4-D input");
        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
    }

    /// The Jacobian `d map / d p` (row `r` = output component `r`) at `p`: the
    /// network's exact Jacobian chained with the embedding's.
    pub fn jacobian(&self, p: [f64; 3]) -> [[f64; 3]; 3] {
        let (_, jn) = self
            .net
            .eval_with_jacobian(&self.embedding.point(p))
            .expect("4-D input");
        let e = self.embedding.jacobian(p);
        let mut j = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for (r, row) in j.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v += (0..4).map(|k| jn[r * 4 + k] * e[k][c]).sum::<f64>();
            }
        }
        j
    }

    /// Checks the Jacobian determinant on an `n x n x n` grid over the box the warp was
    /// built for (corners included, `n >= 2`): a consistent set of moves keeps it
    /// positive everywhere; crossing moves fold space over (determinant `<= 0`).
    pub fn check_folds(&self, n: usize) -> FoldReport {
        let n = n.max(2);
        let at =
            |k: usize, i: usize| self.lo[k] + (self.hi[k] - self.lo[k]) * i as f64 / (n - 1) as f64;
        let dets: Vec<f64> = (0..n * n * n)
            .into_par_iter()
            .map(|idx| {
                let p = [at(0, idx % n), at(1, (idx / n) % n), at(2, idx / (n * n))];
                det3(&self.jacobian(p))
            })
            .collect();
        FoldReport {
            samples: dets.len(),
            folded: dets.iter().filter(|&&d| d <= 0.0).count(),
            min_det: dets.iter().copied().fold(f64::INFINITY, f64::min),
        }
    }

    /// The model with its key points' position shapes (first three components) moved
    /// by the warp: the "edited output positions of the stored key points" form of the
    /// distortion (exact at the key points' shapes, approximate between them).
    pub fn apply_to_model(&self, model: &SurfaceModel) -> Result<SurfaceModel, TextureError> {
        let p = model.network.output_dim();
        if p < 3 {
            return Err(TextureError::NotPositions { components: p });
        }
        let mut shapes = model.network.shapes().to_vec();
        for (index, s) in shapes.chunks_exact_mut(p).enumerate() {
            let m = self.map([s[0], s[1], s[2]]);
            // The warp extrapolates past its box: keep the result readable.
            if let Some(&value) = m.iter().find(|v| v.is_nan() || v.abs() > MAX_SHAPE) {
                return Err(TextureError::WarpedOutOfRange {
                    index,
                    value,
                    max: MAX_SHAPE,
                });
            }
            s[..3].copy_from_slice(&m);
        }
        let mut out = model.clone();
        out.network = model.network.with_shapes(p, shapes)?;
        Ok(out)
    }
}

/// The inverse stereographic embedding of 3-D space, centred and scaled to the warp's
/// box, into the unit 3-sphere the network's key points live on.
#[derive(Debug, Clone, Copy)]
struct Stereographic {
    centre: [f64; 3],
    inv_scale: f64,
}

impl Stereographic {
    /// `p` relative to the centre, in units of the box size.
    fn local(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| (p[k] - self.centre[k]) * self.inv_scale)
    }

    /// The point of the sphere `p` maps to.
    fn point(&self, p: [f64; 3]) -> [f64; 4] {
        let u = self.local(p);
        let r2: f64 = u.iter().map(|v| v * v).sum();
        let d = 1.0 / (1.0 + r2);
        [
            2.0 * u[0] * d,
            2.0 * u[1] * d,
            2.0 * u[2] * d,
            (1.0 - r2) * d,
        ]
    }

    /// `d point / d p` (4 x 3).
    fn jacobian(&self, p: [f64; 3]) -> [[f64; 3]; 4] {
        let u = self.local(p);
        let r2: f64 = u.iter().map(|v| v * v).sum();
        let d = 1.0 + r2;
        let d2 = d * d;
        let mut e = [[0.0; 3]; 4];
        for (k, row) in e.iter_mut().take(3).enumerate() {
            for (l, v) in row.iter_mut().enumerate() {
                let delta = if k == l { d } else { 0.0 };
                *v = 2.0 * (delta - 2.0 * u[k] * u[l]) / d2 * self.inv_scale;
            }
        }
        for (l, v) in e[3].iter_mut().enumerate() {
            *v = -4.0 * u[l] / d2 * self.inv_scale;
        }
        e
    }
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}
