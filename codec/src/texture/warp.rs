//! Image distortion by moving control points: a Cao En warp network over the image
//! domain (paper section 9, "Distortion").
//!
//! The image is embedded on the unit sphere exactly as the codec embeds it
//! ([`Frame::embed`], inverse stereographic projection), so the warp is a network
//! `S^2 -> R^2` whose output is the pixel *displacement* `(dx, dy)` added to the input
//! position. Its key points are the control points (source = the original position)
//! and identity anchors on a coarse grid including the border (source = the grid node,
//! target displacement zero) so far-away regions stay put. Blend: exponential
//! (a Gaussian of the pixel distance with a footprint `sigma`, through
//! [`Frame::sharpness`]), normalised.
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

use rayon::prelude::*;

use super::TextureError;
use crate::codec::decoder::{self, Decoded};
use crate::codec::geometry::Frame;
use crate::codec::keyset::KeySet;
use crate::codec::quadtree::Cell;
use crate::raster::Raster;
use crate::surface::{Blend, Network};

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

/// Spacing of the `--grid` overlay lines in pixels for an image.
pub fn grid_spacing(width: u32, height: u32) -> f64 {
    (width.max(height) as f64 / 16.0).max(4.0)
}

/// Splat accumulators: `nc` planes plus tent weights.
struct Splat {
    w: usize,
    h: usize,
    planes: Vec<Vec<f64>>,
    weight: Vec<f64>,
}

impl Splat {
    fn new(w: usize, h: usize, nc: usize) -> Self {
        Splat {
            w,
            h,
            planes: vec![vec![0.0; w * h]; nc],
            weight: vec![0.0; w * h],
        }
    }

    /// Adds a sample at `(x, y)` with a tent of half-widths `(rx, ry)` (linear
    /// splatting, as the decoder's forward path): the pixel centres within reach get
    /// weights `(1 - |dx| / rx)(1 - |dy| / ry)`.
    #[inline]
    fn add(&mut self, x: f64, y: f64, rx: f64, ry: f64, vals: &[f64]) {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        let (i0, i1) = (
            (x - 0.5 - rx).ceil().max(0.0),
            (x - 0.5 + rx).floor().min(self.w as f64 - 1.0),
        );
        let (j0, j1) = (
            (y - 0.5 - ry).ceil().max(0.0),
            (y - 0.5 + ry).floor().min(self.h as f64 - 1.0),
        );
        let mut j = j0;
        while j <= j1 {
            let wy = 1.0 - (y - (j + 0.5)).abs() / ry;
            let mut i = i0;
            while i <= i1 {
                let wt = wy * (1.0 - (x - (i + 0.5)).abs() / rx);
                if wt > 0.0 {
                    let idx = j as usize * self.w + i as usize;
                    self.weight[idx] += wt;
                    for (p, v) in self.planes.iter_mut().zip(vals) {
                        p[idx] += wt * v;
                    }
                }
                i += 1.0;
            }
            j += 1.0;
        }
    }

    fn finish(mut self) -> Vec<Vec<f64>> {
        for (i, &wt) in self.weight.iter().enumerate() {
            if wt > 0.0 {
                for p in &mut self.planes {
                    p[i] /= wt;
                }
            }
        }
        decoder::fill_holes(&mut self.planes, &mut self.weight, self.w, self.h);
        self.planes
    }
}

fn check_supersample(s: u32) -> Result<usize, TextureError> {
    if (1..=8).contains(&s) {
        Ok(s as usize)
    } else {
        Err(TextureError::Count {
            what: "supersample",
            value: s.into(),
            min: 1,
            max: 8,
        })
    }
}

/// Largest tent half-width (px): beyond this stretch the hole fill takes over, which
/// bounds the splat cost per sample.
const MAX_TENT: f64 = 2.0;

/// The sampling lattice of the forward mapping: `s x s` samples per pixel on the
/// lattice refined by `1/s` that contains every pixel centre (as the decoder's forward
/// path), so a sample on a pixel centre decides that pixel alone under identity.
#[derive(Clone, Copy)]
struct Lattice {
    s: usize,
    step: f64,
    first: f64,
}

impl Lattice {
    fn new(s: usize) -> Self {
        let step = 1.0 / s as f64;
        Lattice {
            s,
            step,
            first: -((s / 2) as f64) * step,
        }
    }

    /// Sample positions of pixel row `y`, `[x0, y0, x1, y1, ...]`, sub-row by sub-row.
    fn row(&self, width: usize, y: usize) -> Vec<f64> {
        let s = self.s;
        let mut pts = Vec::with_capacity(width * s * s * 2);
        for b in 0..s {
            let py = y as f64 + 0.5 + self.first + b as f64 * self.step;
            for x in 0..width {
                for a in 0..s {
                    pts.push(x as f64 + 0.5 + self.first + a as f64 * self.step);
                    pts.push(py);
                }
            }
        }
        pts
    }
}

/// The warp's displacement on a node grid over a band of rows, interpolated
/// bilinearly in between: the resampling evaluates the network at the nodes only
/// (`1 / spacing^2` per pixel instead of `S^2`). The field is smooth on the scale of
/// the smallest key point footprint `sigma`, and bilinear interpolation errs by at most
/// `spacing^2 / 8` times its curvature (about `|d| / sigma^2`, somewhat more where the
/// solved shapes exceed the displacements), so the spacing is `sigma / 8` capped at one
/// pixel: 0.0033 px at most for 10 px moves with 48 px footprints (unit test).
struct Field {
    spacing: f64,
    /// Node `(i, j)` is at `((i - 0.5) spacing, (j0 + j - 0.5) spacing)`.
    j0: usize,
    nx: usize,
    ny: usize,
    d: Vec<[f64; 2]>,
}

impl Field {
    /// Node spacing for a warp sampled with lattice step `step`.
    fn spacing(warp: &Warp, step: f64) -> f64 {
        (warp.min_sigma / 8.0).clamp(step, 1.0)
    }

    /// The nodes covering rows `y_lo..=y_hi` (pixel coordinates) of the whole width.
    fn band(warp: &Warp, spacing: f64, y_lo: f64, y_hi: f64) -> Self {
        let w = warp.frame.width as f64;
        let nx = (w / spacing).ceil() as usize + 2;
        let j0 = (y_lo / spacing + 0.5).floor().max(0.0) as usize;
        let j1 = ((y_hi / spacing + 0.5).ceil() as usize).max(j0 + 1);
        let ny = j1 - j0 + 1;
        let mut pts = Vec::with_capacity(nx * ny * 2);
        for j in 0..ny {
            for i in 0..nx {
                pts.push((i as f64 - 0.5) * spacing);
                pts.push(((j0 + j) as f64 - 0.5) * spacing);
            }
        }
        let d = warp
            .map_batch(&pts)
            .chunks_exact(2)
            .zip(pts.chunks_exact(2))
            .map(|(m, p)| [m[0] - p[0], m[1] - p[1]])
            .collect();
        Field {
            spacing,
            j0,
            nx,
            ny,
            d,
        }
    }

    /// The displacement at `(x, y)` and the Jacobian `I + grad d` of the map there.
    #[inline]
    fn at(&self, x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
        let tx = x / self.spacing + 0.5;
        let ty = y / self.spacing + 0.5 - self.j0 as f64;
        let i = (tx.floor().max(0.0) as usize).min(self.nx - 2);
        let j = (ty.floor().max(0.0) as usize).min(self.ny - 2);
        let (fx, fy) = (tx - i as f64, ty - j as f64);
        let k = j * self.nx + i;
        let (d00, d10, d01, d11) = (
            self.d[k],
            self.d[k + 1],
            self.d[k + self.nx],
            self.d[k + self.nx + 1],
        );
        let mut d = [0.0; 2];
        let mut jac = [[1.0, 0.0], [0.0, 1.0]];
        for c in 0..2 {
            let top = d00[c] + fx * (d10[c] - d00[c]);
            let bottom = d01[c] + fx * (d11[c] - d01[c]);
            d[c] = top + fy * (bottom - top);
            jac[c][0] += ((1.0 - fy) * (d10[c] - d00[c]) + fy * (d11[c] - d01[c])) / self.spacing;
            jac[c][1] += (bottom - top) / self.spacing;
        }
        (d, jac)
    }
}

/// Tent half-widths for a sample whose neighbourhood is mapped with Jacobian `jac`:
/// one lattice step, widened where the map stretches so neighbouring samples' tents
/// still meet (no holes under magnification); exactly one step under identity.
#[inline]
fn tent(step: f64, jac: &[[f64; 2]; 2]) -> (f64, f64) {
    let r = |row: [f64; 2]| (step * row[0].abs().max(row[1].abs()).max(1.0)).min(MAX_TENT);
    (r(jac[0]), r(jac[1]))
}

/// Bilinear sample of plane `p` (`w x h`, pixel centres at `i + 0.5`, edges clamped).
#[inline]
fn bilinear(p: &[f32], w: usize, h: usize, x: f64, y: f64) -> f64 {
    let tx = (x - 0.5).clamp(0.0, (w - 1) as f64);
    let ty = (y - 0.5).clamp(0.0, (h - 1) as f64);
    let (i, j) = (
        (tx as usize).min(w.saturating_sub(2)),
        (ty as usize).min(h.saturating_sub(2)),
    );
    let (fx, fy) = (tx - i as f64, ty - j as f64);
    let (i1, j1) = ((i + 1).min(w - 1), (j + 1).min(h - 1));
    let v = |i: usize, j: usize| p[j * w + i] as f64;
    let top = v(i, j) + fx * (v(i1, j) - v(i, j));
    let bottom = v(i, j1) + fx * (v(i1, j1) - v(i, j1));
    top + fy * (bottom - top)
}

/// Rows are mapped in parallel in bands of this many, then splatted in a fixed order
/// (deterministic, and memory bounded by one band's samples).
const BAND: usize = 16;

/// Warps an image by forward mapping with `s x s` samples per input pixel; the output
/// has the input's size, layout and format.
///
/// Each sample takes the input bilinearly at its lattice position, moves by the warp
/// (interpolated from the node [`Field`]) and is splatted linearly; pixels no tent
/// reached are filled from their neighbours. Identity moves reproduce the input exactly.
pub fn warp_raster(img: &Raster, warp: &Warp, s: u32) -> Result<Raster, TextureError> {
    let s = check_supersample(s)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if (warp.frame.width as usize, warp.frame.height as usize) != (w, h) {
        return Err(TextureError::SizeMismatch {
            warp: (warp.frame.width, warp.frame.height),
            image: (img.width(), img.height()),
        });
    }
    let nc = img.layout().channels();
    let lat = Lattice::new(s);
    let spacing = Field::spacing(warp, lat.step);
    let planes: Vec<&[f32]> = (0..nc).map(|c| img.plane(c)).collect();
    let mut acc = Splat::new(w, h, nc);
    // Per sample: x, y, rx, ry, then the nc channel values.
    let stride = 4 + nc;
    for band in (0..h).step_by(BAND) {
        let rows: Vec<Vec<f64>> = (band..(band + BAND).min(h))
            .into_par_iter()
            .map(|y| {
                let pts = lat.row(w, y);
                let y_lo = pts[1];
                let y_hi = pts[pts.len() - 1];
                let field = Field::band(warp, spacing, y_lo, y_hi);
                let mut out = Vec::with_capacity(pts.len() / 2 * stride);
                for p in pts.chunks_exact(2) {
                    let (d, jac) = field.at(p[0], p[1]);
                    let (rx, ry) = tent(lat.step, &jac);
                    out.extend([p[0] + d[0], p[1] + d[1], rx, ry]);
                    out.extend(planes.iter().map(|pl| bilinear(pl, w, h, p[0], p[1])));
                }
                out
            })
            .collect();
        for row in &rows {
            for v in row.chunks_exact(stride) {
                acc.add(v[0], v[1], v[2], v[3], &v[4..]);
            }
        }
    }
    let planes = acc.finish();
    let samples: Vec<f32> = planes.into_iter().flatten().map(|v| v as f32).collect();
    Ok(Raster::new(
        img.width(),
        img.height(),
        img.layout(),
        img.format(),
        samples,
    )?)
}

/// Draws the warped grid (source lines every [`grid_spacing`] pixels) over `img`:
/// colour channels set to 1 then 0 (red on RGB, white on grey), alpha to 1.
pub fn draw_grid(img: Raster, warp: &Warp) -> Result<Raster, TextureError> {
    let (w, h) = (img.width(), img.height());
    let g = grid_spacing(w, h);
    let (wf, hf) = (w as f64, h as f64);
    let mut pts = Vec::new();
    let mut t = g;
    while t < wf.max(hf) {
        for k in 0..(hf.max(wf) * 4.0) as usize {
            let u = k as f64 * 0.25;
            if t < wf && u < hf {
                pts.extend([t, u]);
            }
            if t < hf && u < wf {
                pts.extend([u, t]);
            }
        }
        t += g;
    }
    let mapped = warp.map_batch(&pts);
    let layout = img.layout();
    let (format, n) = (img.format(), (w * h) as usize);
    let mut samples = img.into_samples();
    for p in mapped.chunks_exact(2) {
        if p[0] < 0.0 || p[1] < 0.0 || p[0] >= wf || p[1] >= hf {
            continue;
        }
        let i = p[1] as usize * w as usize + p[0] as usize;
        let cc = layout.colour_channels();
        for c in 0..cc {
            samples[c * n + i] = if c == 0 { 1.0 } else { 0.0 };
        }
        if layout.has_alpha() {
            samples[cc * n + i] = 1.0;
        }
    }
    Ok(Raster::new(w, h, layout, format, samples)?)
}

/// Distorts a decoded caoen file: every key point's displacement `(dx, dy)` is set to
/// the warp's displacement at its centre, and the file is evaluated by forward mapping
/// (`docs/format.md`, "Reconstruction") with `s x s` samples per pixel on the same
/// lattice and linear splat as [`warp_raster`] (so identity moves give the decoder's
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
        Ok(ks.network(p, shapes)?)
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
    for band in (0..h).step_by(BAND) {
        let rows: Vec<Vec<f64>> = (band..(band + BAND).min(h))
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
        for row in &rows {
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
        crate::codec::colour::CodingPlanes { colour, alpha },
        hd.width,
        hd.height,
    ))
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
    }

    fn warp() -> Warp {
        let moves = [
            Move {
                from: [40.5, 30.5],
                to: [48.25, 36.0],
            },
            Move {
                from: [120.5, 30.5],
                to: [113.0, 26.5],
            },
            Move {
                from: [80.5, 60.5],
                to: [80.5, 70.0],
            },
        ];
        Warp::new(160, 120, &moves).unwrap()
    }

    #[test]
    fn texture_field_interpolates_the_network_closely() {
        // The node field stands in for the network in the resampling: its error must
        // stay far below the 0.5 px placement budget.
        let w = warp();
        let spacing = Field::spacing(&w, 0.25);
        assert_eq!(spacing, 1.0);
        let mut worst: f64 = 0.0;
        for y0 in [0usize, 29, 60, 119] {
            let field = Field::band(&w, spacing, y0 as f64, y0 as f64 + 1.0);
            for k in 0..400 {
                let (x, y) = (k as f64 * 0.3997, y0 as f64 + (k % 7) as f64 / 7.0);
                let (d, _) = field.at(x, y);
                let e = w.displacement(x, y);
                worst = worst.max((d[0] - e[0]).hypot(d[1] - e[1]));
            }
        }
        // Measured 0.0033 px: bilinear error of a field bending over ~50 px.
        assert!(worst < 5e-3, "{worst}");
    }

    #[test]
    fn texture_field_jacobian_matches_the_exact_one() {
        let w = warp();
        let field = Field::band(&w, 1.0, 44.0, 45.0);
        let (_, j) = field.at(70.3, 44.1);
        let e = w.jacobian(70.3, 44.1);
        for r in 0..2 {
            for c in 0..2 {
                assert!((j[r][c] - e[r][c]).abs() < 5e-3, "{j:?} vs {e:?}");
            }
        }
    }

    #[test]
    fn texture_tent_is_one_step_under_identity_and_widens_with_stretch() {
        let id = [[1.0, 0.0], [0.0, 1.0]];
        assert_eq!(tent(0.25, &id), (0.25, 0.25));
        assert_eq!(tent(0.25, &[[3.0, 0.0], [0.5, 0.8]]), (0.75, 0.25));
        assert_eq!(tent(0.5, &[[9.0, 0.0], [0.0, 1.0]]), (MAX_TENT, 0.5));
    }

    #[test]
    fn texture_bilinear_hits_pixel_centres_and_clamps() {
        let p = [0.0f32, 1.0, 2.0, 3.0];
        assert_eq!(bilinear(&p, 2, 2, 0.5, 0.5), 0.0);
        assert_eq!(bilinear(&p, 2, 2, 1.5, 1.5), 3.0);
        assert_eq!(bilinear(&p, 2, 2, 1.0, 1.0), 1.5);
        assert_eq!(bilinear(&p, 2, 2, -4.0, 9.0), 2.0);
        assert_eq!(bilinear(&[7.0], 1, 1, 0.3, 0.9), 7.0);
    }
}
