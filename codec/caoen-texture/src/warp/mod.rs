//! Image distortion by moving control points: a Cao En warp network over the image
//! domain (paper section 9, "Distortion").
//!
//! The image is embedded on the unit sphere exactly as the codec embeds it
//! (`Frame::embed`, inverse stereographic projection), so the warp is a network
//! `S^2 -> R^2` whose output is the pixel *displacement* `(dx, dy)` added to the input
//! position. Its key points are the control points (source = the original position)
//! and identity anchors on a coarse grid including the border (source = the grid node,
//! target displacement zero) so far-away regions stay put. Blend: exponential
//! (a Gaussian of the pixel distance with a footprint `sigma`, through
//! `Frame::sharpness`), normalised.
//!
//! The shape vectors are not the raw displacements: with a normalised blend the
//! network at a key point is a weighted mean of all shapes, so the shapes are solved
//! from the `n x n` interpolation system `A c = t`, `A_ji = k_i(x_j) / sum_l k_l(x_j)`,
//! which makes the network pass exactly through every target (control points land
//! on their targets to rounding).
//!
//! The image is then resampled by forward mapping: `S x S` samples per input pixel on
//! the lattice through the pixel centres, each taking the input bilinearly and splatted
//! linearly at its warped position (the decoder's forward path), with the decoder's
//! hole fill for pixels no sample reached. Fold-over (crossing
//! moves) is detected as a non-positive Jacobian determinant on a sampled grid; the
//! result is still defined (overlapping samples average).
//!
//! Here the network and its solve; `jacobian` the exact Jacobian and the fold check,
//! `resample` the forward mapping of images, `keypoints` that of `.cae` key points.

mod jacobian;
mod keypoints;
mod resample;

pub use keypoints::warp_decoded;
pub use resample::{draw_grid, grid_spacing, warp_raster};

use super::TextureError;
use caoen_decoder::geometry::Frame;
use caoen_surface::{Blend, Network};

/// One control point move: from `from` to `to`, in pixel coordinates (continuous,
/// pixel centres at `i + 0.5`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Move {
    /// Original position `[x, y]`.
    pub from: [f64; 2],
    /// Target position `[x, y]`.
    pub to: [f64; 2],
}

/// One entry of a moves file: `{"from": [x, y], "to": [x2, y2]}` or `[[x, y], [x2, y2]]`.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum MoveJson {
    Object(Move),
    Pair([[f64; 2]; 2]),
}

/// Parses a moves file (`docs/texture.md`): a JSON array of moves, each an object
/// `{"from": [x, y], "to": [x2, y2]}` or a pair `[[x, y], [x2, y2]]`, every coordinate
/// finite.
pub fn parse_moves(text: &str) -> Result<Vec<Move>, TextureError> {
    let v: Vec<MoveJson> =
        serde_json::from_str(text).map_err(|source| TextureError::MovesJson { source })?;
    let moves: Vec<Move> = v
        .into_iter()
        .map(|m| match m {
            MoveJson::Object(m) => m,
            MoveJson::Pair([from, to]) => Move { from, to },
        })
        .collect();
    check_moves(&moves)?;
    Ok(moves)
}

/// Refuses a move with a NaN or infinite coordinate, naming it.
fn check_moves(moves: &[Move]) -> Result<(), TextureError> {
    match moves
        .iter()
        .position(|m| !m.from.iter().chain(&m.to).all(|v| v.is_finite()))
    {
        Some(index) => Err(TextureError::NonFiniteMove {
            index,
            from: moves[index].from,
            to: moves[index].to,
        }),
        None => Ok(()),
    }
}

/// Options of the warp network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarpOptions {
    /// Anchor grid cells per longer image side (default 3: anchors hold the far field,
    /// but each one near a control point also bends the field there, so a coarse grid
    /// is smoother and places points more exactly).
    pub anchor_cells: u32,
    /// Footprint of a key point in units of the anchor spacing (default 0.9). A
    /// normalised Gaussian blend much narrower than the key point spacing tends to
    /// nearest-key-point plateaus with steep steps between them; much wider makes the
    /// interpolation system ill-conditioned (shapes of alternating sign, ripples, even
    /// folds). `docs/texture.md` has the sweep.
    pub sigma_factor: f64,
    /// Radius of the rigid neighbourhood of a control point, in units of its local
    /// spacing (default 0, off): four extra key points on a ring around each control
    /// point carry the same displacement (the paper's texture control: several sources,
    /// one shape), so the warp is locally a translation there. Off by default: the
    /// plateau must be paid for by sharper bending around it (mean |Laplacian| 3.6x
    /// larger at 0.2) and the near-coincident sources condition the solve badly enough
    /// to fold consistent moves.
    pub rigid_factor: f64,
    /// Blending function of the key points.
    pub blend: Blend,
}

impl Default for WarpOptions {
    fn default() -> Self {
        WarpOptions {
            anchor_cells: 3,
            sigma_factor: 0.9,
            rigid_factor: 0.0,
            blend: Blend::Exponential,
        }
    }
}

/// The result of the fold-over check on a sampled grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoldReport {
    /// Grid samples checked.
    pub samples: usize,
    /// Samples whose Jacobian determinant is `<= 0`.
    pub folded: usize,
    /// The smallest determinant seen.
    pub min_det: f64,
}

impl FoldReport {
    /// Whether the warp is locally invertible at every sample.
    pub fn is_consistent(&self) -> bool {
        self.folded == 0
    }
}

/// A warp of a `width x height` image.
#[derive(Debug, Clone)]
pub struct Warp {
    frame: Frame,
    net: Network,
    moves: Vec<Move>,
    anchors: usize,
    /// The smallest key point footprint (px): bounds the field's curvature, so it sets
    /// the node spacing of the interpolated field used for resampling.
    min_sigma: f64,
}

/// Largest number of key points (controls plus anchors) the dense solve accepts.
pub const MAX_KEY_POINTS: usize = 2048;

impl Warp {
    /// A warp with default options.
    pub fn new(width: u32, height: u32, moves: &[Move]) -> Result<Self, TextureError> {
        Self::with_options(width, height, moves, &WarpOptions::default())
    }

    /// Builds the warp network and solves its shapes so every control point lands on
    /// its target. Control points closer than 0.5 px to each other are merged (their
    /// targets averaged).
    pub fn with_options(
        width: u32,
        height: u32,
        moves: &[Move],
        opts: &WarpOptions,
    ) -> Result<Self, TextureError> {
        if width == 0 || height == 0 {
            return Err(TextureError::EmptyImage { width, height });
        }
        check_moves(moves)?;
        let option = |name, value, allowed| TextureError::WarpOption {
            name,
            value,
            allowed,
        };
        if !(opts.sigma_factor > 0.0 && opts.sigma_factor.is_finite()) {
            return Err(option("sigma_factor", opts.sigma_factor, "finite and > 0"));
        }
        if !(0.0..0.5).contains(&opts.rigid_factor) {
            return Err(option("rigid_factor", opts.rigid_factor, "0 <= r < 0.5"));
        }
        if opts.anchor_cells == 0 {
            return Err(option("anchor_cells", 0.0, ">= 1"));
        }
        if moves.len() > MAX_KEY_POINTS / 8 {
            return Err(TextureError::TooManyMoves {
                moves: moves.len(),
                max: MAX_KEY_POINTS / 8,
            });
        }
        // Merge near-duplicate control points.
        let mut merged: Vec<(Move, usize)> = Vec::new();
        for m in moves {
            match merged.iter_mut().find(|(a, _)| dist(a.from, m.from) < 0.5) {
                Some((a, n)) => {
                    let k = *n as f64;
                    a.to = [
                        (a.to[0] * k + m.to[0]) / (k + 1.0),
                        (a.to[1] * k + m.to[1]) / (k + 1.0),
                    ];
                    *n += 1;
                }
                None => merged.push((*m, 1)),
            }
        }
        let moves: Vec<Move> = merged.into_iter().map(|(m, _)| m).collect();
        let frame = Frame::new(width, height);
        let (w, h) = (width as f64, height as f64);
        let g = w.max(h) / opts.anchor_cells as f64;
        let sigma_a = opts.sigma_factor * g;
        // Key points: (position, target displacement, sigma).
        let mut kp: Vec<([f64; 2], [f64; 2], f64)> = Vec::new();
        let froms: Vec<[f64; 2]> = moves.iter().map(|m| m.from).collect();
        for (m, nearest) in moves.iter().zip(nearest_other(&froms)) {
            let local = nearest.min(g);
            let sigma = (opts.sigma_factor * local).max(1.0);
            let d = [m.to[0] - m.from[0], m.to[1] - m.from[1]];
            kp.push((m.from, d, sigma));
            let r = opts.rigid_factor * local;
            if r >= 1.0 {
                for (ox, oy) in [(r, 0.0), (0.0, r), (-r, 0.0), (0.0, -r)] {
                    kp.push(([m.from[0] + ox, m.from[1] + oy], d, sigma));
                }
            }
        }
        let (nx, ny) = ((w / g).ceil() as u32, (h / g).ceil() as u32);
        let mut anchors = 0;
        for j in 0..=ny {
            for i in 0..=nx {
                let p = [w * i as f64 / nx as f64, h * j as f64 / ny as f64];
                if moves.iter().any(|m| dist(m.from, p) < 0.75 * g) {
                    continue;
                }
                kp.push((p, [0.0, 0.0], sigma_a));
                anchors += 1;
            }
        }
        if kp.len() > MAX_KEY_POINTS {
            return Err(TextureError::TooManyKeyPoints {
                key_points: kp.len(),
                max: MAX_KEY_POINTS,
            });
        }
        let n = kp.len();
        let sources: Vec<[f64; 3]> = kp.iter().map(|k| frame.embed(k.0[0], k.0[1])).collect();
        let q: Vec<f64> = kp
            .iter()
            .map(|k| frame.sharpness(k.0[0], k.0[1], k.2))
            .collect();
        let mut targets = Vec::with_capacity(n * 2);
        for k in &kp {
            targets.extend([k.1[0], k.1[1]]);
        }
        let net = Network::interpolating(
            3,
            2,
            sources.iter().flatten().copied().collect(),
            q,
            opts.blend,
            &targets,
        )
        .map_err(|source| TextureError::Unsolvable { source })?;
        let min_sigma = kp.iter().map(|k| k.2).fold(f64::INFINITY, f64::min);
        Ok(Warp {
            frame,
            net,
            moves,
            anchors,
            min_sigma,
        })
    }

    /// The image frame.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    /// The (merged) control point moves.
    pub fn moves(&self) -> &[Move] {
        &self.moves
    }

    /// Number of identity anchors.
    pub fn anchors(&self) -> usize {
        self.anchors
    }

    /// The warp network (`S^2 -> (dx, dy)`).
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// The displacement at pixel position `(x, y)`.
    pub fn displacement(&self, x: f64, y: f64) -> [f64; 2] {
        let d = self
            .net
            .eval(&self.frame.embed(x, y))
            .expect("3-D input to a 3-D network");
        [d[0], d[1]]
    }

    /// Where pixel position `(x, y)` goes.
    pub fn map(&self, x: f64, y: f64) -> [f64; 2] {
        let d = self.displacement(x, y);
        [x + d[0], y + d[1]]
    }

    /// Mapped positions of many points (`[x0, y0, x1, y1, ...]`), in parallel.
    pub fn map_batch(&self, pts: &[f64]) -> Vec<f64> {
        let dom: Vec<f64> = pts
            .chunks_exact(2)
            .flat_map(|p| self.frame.embed(p[0], p[1]))
            .collect();
        let mut d = self.net.eval_batch(&dom).expect("3-D inputs");
        for (o, p) in d.iter_mut().zip(pts) {
            *o += p;
        }
        d
    }
}

/// Per point, the distance to the nearest other point (infinite for a lone point): the
/// local spacing that sizes a move's key point, in 2-D and 3-D warps alike.
pub(super) fn nearest_other<const N: usize>(points: &[[f64; N]]) -> Vec<f64> {
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            points
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, o)| dist(*o, *p))
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

/// Euclidean distance.
pub(super) fn dist<const N: usize>(a: [f64; N], b: [f64; N]) -> f64 {
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_files_take_objects_and_pairs_and_nothing_else() {
        let m = Move {
            from: [1.0, 2.5],
            to: [3.0, -4.0],
        };
        let objects = r#"[{"from": [1, 2.5], "to": [3, -4]}, {"from": [1, 2.5], "to": [3, -4]}]"#;
        assert_eq!(parse_moves(objects).unwrap(), [m, m]);
        assert_eq!(parse_moves("[[[1, 2.5], [3, -4]]]").unwrap(), [m]);
        assert_eq!(parse_moves("[]").unwrap(), []);
        for bad in [
            "",
            "{}",
            "[[1, 2]]",
            r#"[{"from": [1, 2]}]"#,
            "[[[1, 2], [3, 1e999]]]",
            "[] x",
        ] {
            assert!(parse_moves(bad).is_err(), "{bad:?} accepted");
        }
        assert!(matches!(
            parse_moves("[[[1, 2], [3, 4]], [[1, 2], [3, NaN]]]"),
            Err(TextureError::MovesJson { .. })
        ));
        assert!(matches!(
            Warp::new(
                8,
                8,
                &[
                    m,
                    Move {
                        from: [1.0, f64::NAN],
                        to: m.to
                    }
                ]
            ),
            Err(TextureError::NonFiniteMove { index: 1, .. })
        ));
        assert!(matches!(
            Warp::new(0, 8, &[m]),
            Err(TextureError::EmptyImage {
                width: 0,
                height: 8
            })
        ));
    }
}
