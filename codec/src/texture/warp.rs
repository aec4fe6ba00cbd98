//! Image distortion by moving control points: a Cao En warp network over the image
//! domain (design section 9, "Distortion").
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
//! The image is then resampled by forward mapping: `S x S` samples per input pixel,
//! each carrying its pixel's colour to its warped position, averaged per output pixel,
//! with the codec decoder's hole fill for pixels no sample reached. Fold-over (crossing
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

/// Options of the warp network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarpOptions {
    /// Anchor grid cells per longer image side (default 6).
    pub anchor_cells: u32,
    /// Footprint of a key point in units of the anchor spacing (default 0.6).
    pub sigma_factor: f64,
    /// Radius of the rigid neighbourhood of a control point, in units of its local
    /// spacing (default 0.2; 0 disables): four extra key points on a ring around each
    /// control point carry the same displacement (the paper's texture control: several
    /// sources, one shape), so the warp is locally a translation there and small
    /// features at a control point move without stretching.
    pub rigid_factor: f64,
}

impl Default for WarpOptions {
    fn default() -> Self {
        WarpOptions {
            anchor_cells: 6,
            sigma_factor: 0.6,
            rigid_factor: 0.2,
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
            return Err(TextureError::Invalid(format!(
                "empty image {width}x{height}"
            )));
        }
        for m in moves {
            if !m.from.iter().chain(&m.to).all(|v| v.is_finite()) {
                return Err(TextureError::Invalid(format!("move {m:?} is not finite")));
            }
        }
        let valid = opts.sigma_factor > 0.0
            && opts.sigma_factor.is_finite()
            && (0.0..0.5).contains(&opts.rigid_factor)
            && opts.anchor_cells > 0;
        if !valid {
            return Err(TextureError::Invalid("bad warp options".into()));
        }
        if moves.len() > MAX_KEY_POINTS / 8 {
            return Err(TextureError::Invalid(format!(
                "{} moves: at most {}",
                moves.len(),
                MAX_KEY_POINTS / 8
            )));
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
        for (i, m) in moves.iter().enumerate() {
            let nearest = moves
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, o)| dist(o.from, m.from))
                .fold(f64::INFINITY, f64::min);
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
            return Err(TextureError::Invalid(format!(
                "{} key points: at most {MAX_KEY_POINTS}",
                kp.len()
            )));
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
            Blend::Exponential,
            &targets,
        )
        .map_err(|e| TextureError::Invalid(format!("control points too close to solve: {e}")))?;
        Ok(Warp {
            frame,
            net,
            moves,
            anchors,
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

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
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

/// Splat accumulators: `nc` planes plus sample counts.
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

    #[inline]
    fn add(&mut self, x: f64, y: f64, vals: impl Iterator<Item = f64>) {
        let (px, py) = (x.floor(), y.floor());
        if px < 0.0 || py < 0.0 || px >= self.w as f64 || py >= self.h as f64 {
            return;
        }
        let i = py as usize * self.w + px as usize;
        self.weight[i] += 1.0;
        for (p, v) in self.planes.iter_mut().zip(vals) {
            p[i] += v;
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

/// Sub-pixel sample positions of input row `y` with `s x s` samples per pixel.
fn row_samples(width: usize, y: usize, s: usize) -> Vec<f64> {
    let mut pts = Vec::with_capacity(width * s * s * 2);
    for b in 0..s {
        for x in 0..width {
            for a in 0..s {
                pts.push(x as f64 + (a as f64 + 0.5) / s as f64);
                pts.push(y as f64 + (b as f64 + 0.5) / s as f64);
            }
        }
    }
    pts
}

fn check_supersample(s: u32) -> Result<usize, TextureError> {
    if (1..=8).contains(&s) {
        Ok(s as usize)
    } else {
        Err(TextureError::Invalid(format!("supersample {s}: 1..=8")))
    }
}

/// Warps an image by forward mapping with `s x s` samples per input pixel; the output
/// has the input's size, layout and format.
pub fn warp_raster(img: &Raster, warp: &Warp, s: u32) -> Result<Raster, TextureError> {
    let s = check_supersample(s)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if (warp.frame.width as usize, warp.frame.height as usize) != (w, h) {
        return Err(TextureError::Invalid("warp and image sizes differ".into()));
    }
    let nc = img.layout().channels();
    let rows: Vec<Vec<f64>> = (0..h)
        .into_par_iter()
        .map(|y| warp.map_batch(&row_samples(w, y, s)))
        .collect();
    let mut acc = Splat::new(w, h, nc);
    for (y, mapped) in rows.iter().enumerate() {
        for (k, p) in mapped.chunks_exact(2).enumerate() {
            let x = (k % (w * s)) / s;
            let i = y * w + x;
            acc.add(p[0], p[1], (0..nc).map(|c| img.plane(c)[i] as f64));
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
/// (`docs/format.md`, "Reconstruction") with `s x s` samples per pixel. Unlike the
/// decoder's row-local splat, samples may land in any row.
pub fn warp_decoded(d: &Decoded, warp: &Warp, s: u32) -> Result<Raster, TextureError> {
    let s = check_supersample(s)?;
    let hd = &d.header;
    let frame = Frame::new(hd.width, hd.height);
    if frame != warp.frame {
        return Err(TextureError::Invalid("warp and image sizes differ".into()));
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
    type Row = (Vec<f64>, Vec<f64>, Option<Vec<f64>>);
    let rows: Vec<Row> = (0..h)
        .into_par_iter()
        .map(|y| -> Result<_, TextureError> {
            let pts = row_samples(w, y, s);
            let dom: Vec<f64> = pts
                .chunks_exact(2)
                .flat_map(|p| frame.embed(p[0], p[1]))
                .collect();
            let ly = luma.eval_batch(&dom)?;
            let cy = chroma.as_ref().map(|n| n.eval_batch(&dom)).transpose()?;
            Ok((pts, ly, cy))
        })
        .collect::<Result<_, _>>()?;
    let mut acc = Splat::new(w, h, nc);
    let pl = 2 + nl;
    for (pts, ly, cy) in &rows {
        for (k, p) in pts.chunks_exact(2).enumerate() {
            let l = &ly[k * pl..(k + 1) * pl];
            let vals = l[2..]
                .iter()
                .copied()
                .chain(cy.iter().flat_map(|c| [c[k * 4 + 2], c[k * 4 + 3]]));
            acc.add(p[0] + l[0], p[1] + l[1], vals);
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
