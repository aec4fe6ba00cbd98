//! Forward-mapping resampling of images through a warp: the sample lattice, the warp
//! interpolated on a node field, linear splats with the decoder's hole fill, and the
//! warped grid overlay.

use rayon::prelude::*;

use super::Warp;
use crate::TextureError;
use caoen_base::raster::Raster;
use caoen_decoder::decoder;

/// Spacing of the `--grid` overlay lines in pixels for an image.
pub fn grid_spacing(width: u32, height: u32) -> f64 {
    (width.max(height) as f64 / 16.0).max(4.0)
}

/// Splat accumulators: `nc` planes plus tent weights.
pub(super) struct Splat {
    w: usize,
    h: usize,
    planes: Vec<Vec<f64>>,
    weight: Vec<f64>,
}

impl Splat {
    pub(super) fn new(w: usize, h: usize, nc: usize) -> Self {
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
    pub(super) fn add(&mut self, x: f64, y: f64, rx: f64, ry: f64, vals: &[f64]) {
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

    pub(super) fn finish(mut self) -> Vec<Vec<f64>> {
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

pub(super) fn check_supersample(s: u32) -> Result<usize, TextureError> {
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
pub(super) struct Lattice {
    s: usize,
    pub(super) step: f64,
    first: f64,
}

impl Lattice {
    pub(super) fn new(s: usize) -> Self {
        let step = 1.0 / s as f64;
        Lattice {
            s,
            step,
            first: -((s / 2) as f64) * step,
        }
    }

    /// Sample positions of pixel row `y`, `[x0, y0, x1, y1, ...]`, sub-row by sub-row.
    /// Samples per pixel along each axis.
    pub(super) fn s(&self) -> usize {
        self.s
    }

    pub(super) fn row(&self, width: usize, y: usize) -> Vec<f64> {
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
pub(super) struct Field {
    spacing: f64,
    /// Node `(i, j)` is at `((i - 0.5) spacing, (j0 + j - 0.5) spacing)`.
    j0: usize,
    nx: usize,
    ny: usize,
    d: Vec<[f64; 2]>,
}

impl Field {
    /// Node spacing for a warp sampled with lattice step `step`.
    pub(super) fn spacing(warp: &Warp, step: f64) -> f64 {
        (warp.min_sigma / 8.0).clamp(step, 1.0)
    }

    /// The nodes covering rows `y_lo..=y_hi` (pixel coordinates) of the whole width.
    pub(super) fn band(warp: &Warp, spacing: f64, y_lo: f64, y_hi: f64) -> Self {
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
    pub(super) fn at(&self, x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
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
pub(super) fn tent(step: f64, jac: &[[f64; 2]; 2]) -> (f64, f64) {
    let r = |row: [f64; 2]| (step * row[0].abs().max(row[1].abs()).max(1.0)).min(MAX_TENT);
    (r(jac[0]), r(jac[1]))
}

/// Bilinear sample of plane `p` (`w x h`, pixel centres at `i + 0.5`, edges clamped).
#[inline]
pub(super) fn bilinear(p: &[f32], w: usize, h: usize, x: f64, y: f64) -> f64 {
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
pub(super) const BAND: usize = 16;

/// Warps an image by forward mapping with `s x s` samples per input pixel; the output
/// has the input's size, layout and format.
///
/// Each sample takes the input bilinearly at its lattice position, moves by the warp
/// (interpolated from the node `Field`) and is splatted linearly; pixels no tent
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

#[cfg(test)]
mod tests {
    use super::super::Move;
    use super::*;

    fn warp() -> Warp {
        let moves = [
            ([40.5, 30.5], [48.25, 36.0]),
            ([120.5, 30.5], [113.0, 26.5]),
            ([80.5, 60.5], [80.5, 70.0]),
        ]
        .map(|(from, to)| Move { from, to });
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
