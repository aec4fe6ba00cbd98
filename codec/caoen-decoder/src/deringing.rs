//! Deringing: a directional filter after AV1's CDEF (constrained directional
//! enhancement), applied by the decoder after the restoration filters, on the coding
//! planes before their conversion to output colours.
//!
//! Each block of 8x8 coded pixels takes the direction along which its luma varies
//! least ([`block_direction`]). Every pixel then moves towards its neighbours one and
//! two pixels along that direction (the primary taps) and along the directions 45
//! degrees either side (the secondary taps), each difference passed through
//! [`constrain`]: small differences (ringing and quantisation noise along an edge) are
//! smoothed, large ones (the edge itself) pass unchanged. The encoder chooses one set
//! of [`Strengths`] for luma and one for both chroma planes and stores them in the
//! header (`docs/format.md`, "Deringing").
//!
//! At an output size `k` times the coded size along an axis (`k` rounded to a whole
//! number, at least 1) the blocks are `8k` output pixels and the offsets `k` times
//! longer, so the filter follows the picture: the half-size files that decode at twice
//! their coded size read their taps directly.

use std::ops::Range;

#[cfg(doc)]
use super::bitstream::Header;

/// Stored strengths are in units of the plane kind's step over this.
pub const STRENGTH_DIVISOR: f32 = 64.0;
/// Stored cutoffs are in units of the plane kind's step over this.
pub const CUTOFF_DIVISOR: f32 = 16.0;
/// The primary taps' weights at one and two pixels.
pub const PRIMARY_TAPS: [f32; 2] = [4.0 / 16.0, 2.0 / 16.0];
/// The secondary taps' weights at one and two pixels.
pub const SECONDARY_TAPS: [f32; 2] = [2.0 / 16.0, 1.0 / 16.0];
/// A direction block's side in coded pixels.
pub const BLOCK: usize = 8;

/// The taps' offsets `(dx, dy)` at one and two pixels along each of the eight
/// directions: 0 up-right at 45 degrees, 2 across, 4 down-right, 6 down, the odd
/// ones between (AV1's `cdef_directions`).
pub const OFFSETS: [[(i32, i32); 2]; 8] = [
    [(1, -1), (2, -2)],
    [(1, 0), (2, -1)],
    [(1, 0), (2, 0)],
    [(1, 0), (2, 1)],
    [(1, 1), (2, 2)],
    [(0, 1), (1, 2)],
    [(0, 1), (0, 2)],
    [(0, 1), (-1, 2)],
];

/// One plane kind's filter: strengths in units of its step over [`STRENGTH_DIVISOR`],
/// the cutoff in units of its step over [`CUTOFF_DIVISOR`] (the step: the header's
/// detail step of the kind, else its key points' step; [`Header::deringing_steps`]).
/// A difference of `d` moves a pixel by
/// `min(|d|, max(0, s (1 - |d| / cutoff)))`: fully up to `s / (1 + s / cutoff)`, and
/// not at all from the cutoff on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Strengths {
    /// The primary taps' strength.
    pub primary: u8,
    /// The secondary taps' strength.
    pub secondary: u8,
    /// The difference from which a neighbour is ignored.
    pub cutoff: u8,
}

impl Strengths {
    /// No filter.
    pub const OFF: Strengths = Strengths {
        primary: 0,
        secondary: 0,
        cutoff: 0,
    };

    /// Whether the plane kind is filtered.
    pub fn is_on(&self) -> bool {
        self.primary > 0 || self.secondary > 0
    }

    /// Whether the header may hold these values: off is all zero, on has a cutoff.
    pub fn is_valid(&self) -> bool {
        if self.is_on() {
            self.cutoff > 0
        } else {
            self.cutoff == 0
        }
    }

    /// The strengths in plane units for a kind whose step is `step`: primary,
    /// secondary and cutoff.
    pub fn in_plane_units(&self, step: f32) -> (f32, f32, f32) {
        (
            self.primary as f32 * step / STRENGTH_DIVISOR,
            self.secondary as f32 * step / STRENGTH_DIVISOR,
            self.cutoff as f32 * step / CUTOFF_DIVISOR,
        )
    }

    fn params(&self, step: f32) -> Params {
        let (p, s, cutoff) = self.in_plane_units(step);
        Params {
            primary: (p, p / cutoff),
            secondary: (s, s / cutoff),
        }
    }
}

/// A strength and its slope `strength / cutoff`, in plane units.
#[derive(Debug, Clone, Copy)]
struct Params {
    primary: (f32, f32),
    secondary: (f32, f32),
}

/// How far a neighbour `d` away moves a pixel with strength `s` and slope
/// `k = s / cutoff`: `sign(d) min(|d|, max(0, s - k |d|))`.
#[inline(always)]
pub fn constrain(d: f32, s: f32, k: f32) -> f32 {
    let a = d.abs();
    a.min((s - k * a).max(0.0)).copysign(d)
}

/// The deringing of a file: luma's strengths and both chroma planes'.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Deringing {
    /// The luma (or grey) plane's.
    pub luma: Strengths,
    /// The chroma planes' (off for grey images).
    pub chroma: Strengths,
}

impl Deringing {
    /// The strengths of colour plane `c` (0 luma or grey, else chroma).
    pub fn of(&self, c: usize) -> Strengths {
        if c == 0 {
            self.luma
        } else {
            self.chroma
        }
    }

    /// Whether any plane is filtered.
    pub fn any(&self) -> bool {
        self.luma.is_on() || self.chroma.is_on()
    }

    /// Filters whole planes (Y, or Y, C1, C2) of `w x h` samples `spacing` coded pixels
    /// apart, in place: one plane's output at a time. `steps` are luma's and chroma's
    /// ([`Header::deringing_steps`]).
    pub fn apply(
        &self,
        planes: &mut [Vec<f32>],
        (w, h): (usize, usize),
        spacing: (f64, f64),
        steps: [f32; 2],
    ) {
        let scale = scale(spacing);
        let Some(luma) = planes.first() else {
            return;
        };
        let dirs = directions(luma, (w, h), 0, scale, 0..h);
        for (c, plane) in planes.iter_mut().enumerate() {
            if self.of(c).is_on() {
                let mut out = vec![0.0f32; plane.len()];
                self.filter_plane(c, plane, (w, h), 0, (scale, steps), &dirs, 0..h, &mut out);
                *plane = out;
            }
        }
    }

    /// The rows of the planes [`Deringing::filter_rows`] reads to filter rows `rows` of
    /// an image `h` rows high at `scale`: their direction blocks and the taps' reach.
    pub fn reach(rows: Range<usize>, h: usize, scale: (usize, usize)) -> Range<usize> {
        let side = BLOCK * scale.1;
        let first = (rows.start / side * side).min(rows.start.saturating_sub(2 * scale.1));
        let last = rows.end.div_ceil(side) * side;
        first..last.max(rows.end + 2 * scale.1).min(h)
    }

    /// Filters rows `rows` of the colour planes of an image of `w x h` samples, at
    /// `scale` output pixels per coded pixel, into `out` (one slice per plane,
    /// `rows.len() * w` samples). `window` holds each plane's rows from `y0` on, at
    /// least [`Deringing::reach`]'s; `steps` are luma's and chroma's.
    #[allow(clippy::too_many_arguments)]
    pub fn filter_rows(
        &self,
        window: &[&[f32]],
        (w, h): (usize, usize),
        y0: usize,
        scale: (usize, usize),
        steps: [f32; 2],
        rows: Range<usize>,
        out: &mut [&mut [f32]],
    ) {
        if rows.is_empty() || w == 0 {
            return;
        }
        let dirs = directions(window[0], (w, h), y0, scale, rows.clone());
        self.filter_rows_directed(window, &dirs, (w, h), y0, (scale, steps), rows, out);
    }

    /// [`Deringing::filter_rows`] with the directions `dirs` of the blocks of rows
    /// `rows` known (as [`directions`] gives them): `window` then needs only the rows
    /// the taps read, `rows` and [`Deringing::tap_rows`] either side.
    #[allow(clippy::too_many_arguments)]
    pub fn filter_rows_directed(
        &self,
        window: &[&[f32]],
        dirs: &[u8],
        (w, h): (usize, usize),
        y0: usize,
        (scale, steps): ((usize, usize), [f32; 2]),
        rows: Range<usize>,
        out: &mut [&mut [f32]],
    ) {
        if rows.is_empty() || w == 0 {
            return;
        }
        for (c, (plane, out)) in window.iter().zip(out.iter_mut()).enumerate() {
            self.filter_plane(
                c,
                plane,
                (w, h),
                y0,
                (scale, steps),
                dirs,
                rows.clone(),
                out,
            );
        }
    }

    /// Output rows the taps read either side of a row at `scale`: two coded pixels.
    pub fn tap_rows(scale: (usize, usize)) -> usize {
        2 * scale.1
    }

    /// Rows `rows` of colour plane `c` (its rows from `y0` on in `plane`) into `out`,
    /// with the block directions `dirs` of [`directions`] for the same rows.
    #[allow(clippy::too_many_arguments)]
    fn filter_plane(
        &self,
        c: usize,
        plane: &[f32],
        (w, h): (usize, usize),
        y0: usize,
        (scale, steps): ((usize, usize), [f32; 2]),
        dirs: &[u8],
        rows: Range<usize>,
        out: &mut [f32],
    ) {
        let strengths = self.of(c);
        let (sx, sy) = (BLOCK * scale.0, BLOCK * scale.1);
        let cols = w.div_ceil(sx);
        let first_block_row = rows.start / sy;
        let p = strengths.params(steps[usize::from(c > 0)]);
        // Each tap's strength, slope and weight, in [`taps`]' order; a tap of no
        // strength is left out.
        let params: [(f32, f32, f32); TAPS] = std::array::from_fn(|t| {
            let (strength, k, weights) = if t < 4 {
                (p.primary.0, p.primary.1, PRIMARY_TAPS)
            } else {
                (p.secondary.0, p.secondary.1, SECONDARY_TAPS)
            };
            (strength, k, weights[tap_distance(t)])
        });
        let active: Vec<usize> = (0..TAPS).filter(|&t| params[t].0 > 0.0).collect();
        let taps: Vec<(f32, f32, f32)> = active.iter().map(|&t| params[t]).collect();
        let arch = pulp::Arch::new();
        let offsets = scaled_offsets(scale);
        // Each active tap's neighbours along the row, then the row's sums tap by tap.
        let mut neighbours = vec![0.0f32; active.len() * w];
        let mut acc = vec![0.0f32; w];
        for (j, y) in rows.enumerate() {
            let centre = &plane[(y - y0) * w..][..w];
            let o = &mut out[j * w..(j + 1) * w];
            if active.is_empty() {
                o.copy_from_slice(centre);
                continue;
            }
            let row_dirs = &dirs[(y / sy - first_block_row) * cols..][..cols];
            gather_row(
                plane,
                (w, h),
                y0,
                y,
                (sx, &offsets),
                row_dirs,
                &active,
                &mut neighbours,
            );
            arch.dispatch(RowSums {
                neighbours: &neighbours,
                centre,
                taps: &taps,
                acc: &mut acc,
                out: o,
            });
        }
    }
}

/// Each direction's taps ([`taps`]) in output pixels at `scale`.
pub fn scaled_offsets(scale: (usize, usize)) -> [[(isize, isize); TAPS]; 8] {
    std::array::from_fn(|d| {
        taps(d as u8).map(|(dx, dy)| (dx * scale.0 as isize, dy * scale.1 as isize))
    })
}

/// Row `y`'s neighbours at the taps `active` (indices into [`taps`]) into
/// `neighbours`, a row of `w` per tap: each block of `side` columns at the offsets of
/// its direction in `row_dirs`, a neighbour past the image the pixel itself (a
/// difference of 0). `plane` holds the rows from `y0` on. Runs of blocks with one
/// direction share their offsets: one copy per tap.
#[allow(clippy::too_many_arguments)]
pub fn gather_row(
    plane: &[f32],
    (w, h): (usize, usize),
    y0: usize,
    y: usize,
    (side, offsets): (usize, &[[(isize, isize); TAPS]; 8]),
    row_dirs: &[u8],
    active: &[usize],
    neighbours: &mut [f32],
) {
    let centre = &plane[(y - y0) * w..][..w];
    let mut bx = 0;
    while bx < row_dirs.len() {
        let d = row_dirs[bx];
        let run = row_dirs[bx..].iter().take_while(|&&e| e == d).count();
        let xs = bx * side..((bx + run) * side).min(w);
        bx += run;
        for (a, &t) in active.iter().enumerate() {
            let (dx, dy) = offsets[d as usize][t];
            let nb = &mut neighbours[a * w..(a + 1) * w];
            let yy = y as isize + dy;
            if yy < 0 || yy >= h as isize {
                nb[xs.clone()].copy_from_slice(&centre[xs.clone()]);
                continue;
            }
            let row = &plane[(yy as usize - y0) * w..][..w];
            let lo = (xs.start as isize)
                .max(-dx)
                .clamp(xs.start as isize, xs.end as isize) as usize;
            let hi = (xs.end as isize)
                .min(w as isize - dx)
                .clamp(lo as isize, xs.end as isize) as usize;
            nb[xs.start..lo].copy_from_slice(&centre[xs.start..lo]);
            if lo < hi {
                nb[lo..hi].copy_from_slice(
                    &row[(lo as isize + dx) as usize..(hi as isize + dx) as usize],
                );
            }
            nb[hi..xs.end].copy_from_slice(&centre[hi..xs.end]);
        }
    }
}

/// One row's filtered values from its taps' gathered neighbours, as a `pulp`
/// operation: inlined into the target-feature function `pulp` picks, so the sums
/// vectorise for the widest unit (the same bits on every unit: no fused operations).
struct RowSums<'a> {
    /// Each active tap's neighbours along the row.
    neighbours: &'a [f32],
    centre: &'a [f32],
    /// Each active tap's strength, slope and weight.
    taps: &'a [(f32, f32, f32)],
    acc: &'a mut [f32],
    out: &'a mut [f32],
}

impl pulp::WithSimd for RowSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let w = self.centre.len();
        self.acc.fill(0.0);
        for (a, &(s, k, wt)) in self.taps.iter().enumerate() {
            for ((acc, &n), &c) in self
                .acc
                .iter_mut()
                .zip(&self.neighbours[a * w..(a + 1) * w])
                .zip(self.centre)
            {
                *acc += wt * constrain(n - c, s, k);
            }
        }
        for ((o, &c), &a) in self.out.iter_mut().zip(self.centre).zip(self.acc.iter()) {
            *o = c + a;
        }
    }
}

/// Taps per pixel: the primary ones at one and two pixels either way, and the
/// secondary ones on both sides.
pub const TAPS: usize = 12;

/// The offsets `(dx, dy)` of a pixel's taps in a block of direction `d`, at the coded
/// size: the primary taps at one pixel (both signs) and two, then the secondary ones
/// at one pixel (direction `d + 2`, both signs, then `d - 2`) and two.
pub fn taps(d: u8) -> [(isize, isize); TAPS] {
    let d = d as usize;
    let mut t = [(0, 0); TAPS];
    let mut i = 0;
    for &(dx, dy) in &OFFSETS[d] {
        for sign in [1, -1] {
            t[i] = ((sign * dx) as isize, (sign * dy) as isize);
            i += 1;
        }
    }
    let (left, right) = (OFFSETS[(d + 2) & 7], OFFSETS[(d + 6) & 7]);
    for (a, b) in left.into_iter().zip(right) {
        for (dx, dy) in [a, b] {
            for sign in [1, -1] {
                t[i] = ((sign * dx) as isize, (sign * dy) as isize);
                i += 1;
            }
        }
    }
    t
}

/// Whether tap `t` of [`taps`] lies two pixels out (else one).
fn tap_distance(t: usize) -> usize {
    if t < 4 {
        t / 2
    } else {
        (t - 4) / 4
    }
}

/// The block directions of rows `rows` of a luma plane of `w x h` samples at `scale`
/// ([`block_direction`] of every block those rows cross, row by row of blocks), its
/// rows from `y0` on in `luma`.
pub fn directions(
    luma: &[f32],
    (w, h): (usize, usize),
    y0: usize,
    scale: (usize, usize),
    rows: Range<usize>,
) -> Vec<u8> {
    if rows.is_empty() {
        return Vec::new();
    }
    let (sx, sy) = (BLOCK * scale.0, BLOCK * scale.1);
    let cols = w.div_ceil(sx);
    (rows.start / sy..(rows.end - 1) / sy + 1)
        .flat_map(|by| (0..cols).map(move |bx| (bx, by)))
        .map(|(bx, by)| block_direction(luma, (w, h), y0, (bx * sx, by * sy), scale))
        .collect()
}

/// Output pixels per coded pixel along each axis for samples `spacing` coded pixels
/// apart: the ratio rounded, at least 1.
pub fn scale((sx, sy): (f64, f64)) -> (usize, usize) {
    let k = |s: f64| (1.0 / s).round().clamp(1.0, 65536.0) as usize;
    (k(sx), k(sy))
}

/// The direction (0..8, [`OFFSETS`]' numbering) along which the block of `8 x 8`
/// samples `scale` output pixels apart from `(x0, y0)` varies least: the one whose
/// lines' sums carry the most of the block's energy, `sum_L S_L^2 / N_L` over the
/// lines `L` of that direction (AV1's `cdef_find_dir`). Samples past the image are
/// left out; the first of equal directions wins. `plane` holds the rows from `top` on.
pub fn block_direction(
    plane: &[f32],
    (w, h): (usize, usize),
    top: usize,
    (x0, y0): (usize, usize),
    (mx, my): (usize, usize),
) -> u8 {
    let mut sums = [[0.0f32; 15]; 8];
    let base = plane[(y0 - top) * w + x0];
    let (rows, cols) = (
        (h - y0).div_ceil(my).min(BLOCK),
        (w - x0).div_ceil(mx).min(BLOCK),
    );
    for i in 0..rows {
        let row = &plane[(y0 + i * my - top) * w..][..w];
        for j in 0..cols {
            let v = row[x0 + j * mx] - base;
            for (d, &l) in line_of(i, j).iter().enumerate() {
                sums[d][l] += v;
            }
        }
    }
    // The lines' pixel counts: a whole block's from the table, a block cut by the
    // image's edge counted.
    let counted;
    let counts = if (rows, cols) == (BLOCK, BLOCK) {
        &WHOLE_BLOCK_COUNTS
    } else {
        let mut c = [[0u8; 15]; 8];
        for i in 0..rows {
            for j in 0..cols {
                for (d, &l) in line_of(i, j).iter().enumerate() {
                    c[d][l] += 1;
                }
            }
        }
        counted = c;
        &counted
    };
    let mut best = (0u8, f32::NEG_INFINITY);
    for d in 0..8 {
        let cost: f32 = sums[d]
            .iter()
            .zip(&counts[d])
            .filter(|(_, &n)| n > 0)
            .map(|(&s, &n)| s * s / n as f32)
            .sum();
        if cost > best.1 {
            best = (d as u8, cost);
        }
    }
    best.0
}

/// The line of each direction that sample `(j, i)` of a block lies on.
#[inline(always)]
const fn line_of(i: usize, j: usize) -> [usize; 8] {
    [
        i + j,
        i + j / 2,
        i,
        3 + i - j / 2,
        7 + i - j,
        3 + j - i / 2,
        j,
        i / 2 + j,
    ]
}

/// Each direction's lines' pixel counts in a whole block.
const WHOLE_BLOCK_COUNTS: [[u8; 15]; 8] = {
    let mut c = [[0u8; 15]; 8];
    let mut i = 0;
    while i < BLOCK {
        let mut j = 0;
        while j < BLOCK {
            let l = line_of(i, j);
            let mut d = 0;
            while d < 8 {
                c[d][l[d]] += 1;
                d += 1;
            }
            j += 1;
        }
        i += 1;
    }
    c
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The tests' steps: strengths of 1/256 and cutoffs of 1/64 of a plane unit.
    const STEPS: [f32; 2] = [0.25, 0.125];

    fn noise(n: usize, seed: u64) -> Vec<f32> {
        caoen_base::rng::Lcg::new(seed).noise(n)
    }

    /// A plane that varies only across lines of direction `d` (stripes along it).
    fn stripes(d: u8, (w, h): (usize, usize)) -> Vec<f32> {
        stripes_at(d, (w, h), 1.3)
    }

    /// [`stripes`] of angular frequency `f` across their lines.
    fn stripes_at(d: u8, (w, h): (usize, usize), f: f32) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                // The line index of AV1's direction search, continuous.
                let t = match d {
                    0 => x + y,
                    1 => y + x / 2.0,
                    2 => y,
                    3 => y - x / 2.0,
                    4 => y - x,
                    5 => x - y / 2.0,
                    6 => x,
                    _ => x + y / 2.0,
                };
                (t * f).sin() * 0.4
            })
            .collect()
    }

    #[test]
    fn constrain_passes_small_differences_and_drops_those_past_the_cutoff() {
        let (s, cutoff) = (0.1f32, 0.4f32);
        let k = s / cutoff;
        for (d, want) in [
            (0.05, 0.05),
            (0.2, 0.05),
            (-0.3, -0.025),
            (0.4, 0.0),
            (0.5, 0.0),
            (-9.0, 0.0),
            (0.0, 0.0),
        ] {
            assert!(
                (constrain(d, s, k) - want).abs() < 1e-7,
                "{d}: {} vs {want}",
                constrain(d, s, k)
            );
        }
        assert_eq!(constrain(f32::INFINITY, s, k), 0.0);
    }

    #[test]
    fn blocks_take_the_direction_their_stripes_run_along() {
        let (w, h) = (8, 8);
        for d in 0..8u8 {
            let p = stripes(d, (w, h));
            assert_eq!(
                block_direction(&p, (w, h), 0, (0, 0), (1, 1)),
                d,
                "direction {d}"
            );
            // The same block twice as large, sampled every other pixel.
            let big: Vec<f32> = (0..4 * w * h)
                .map(|i| {
                    let (x, y) = (i % (2 * w), i / (2 * w));
                    p[(y / 2) * w + x / 2]
                })
                .collect();
            assert_eq!(
                block_direction(&big, (2 * w, 2 * h), 0, (0, 0), (2, 2)),
                d,
                "direction {d} at twice the size"
            );
        }
    }

    #[test]
    fn flat_planes_and_edges_along_the_direction_pass_unchanged() {
        let (w, h) = (24, 16);
        let d = Deringing {
            luma: Strengths {
                primary: 50,
                secondary: 15,
                cutoff: 30,
            },
            chroma: Strengths::OFF,
        };
        let flat = vec![0.3f32; w * h];
        let mut planes = vec![flat.clone()];
        d.apply(&mut planes, (w, h), (1.0, 1.0), STEPS);
        assert_eq!(planes[0], flat);
        // A vertical edge far above the cutoff (30/64 of a plane unit).
        let edge: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 11 { 0.0 } else { 1.0 })
            .collect();
        let mut planes = vec![edge.clone()];
        d.apply(&mut planes, (w, h), (1.0, 1.0), STEPS);
        assert_eq!(planes[0], edge);
    }

    #[test]
    fn ringing_along_a_direction_is_smoothed() {
        let (w, h) = (64, 48);
        for dir in 0..8u8 {
            // Slow enough that the odd directions' first taps, a pixel off the line,
            // stay close to it.
            let clean = stripes_at(dir, (w, h), 0.5);
            let noisy: Vec<f32> = clean
                .iter()
                .zip(noise(w * h, dir as u64 + 1))
                .map(|(c, n)| c + 0.04 * n)
                .collect();
            let d = Deringing {
                luma: Strengths {
                    primary: 16,
                    secondary: 0,
                    cutoff: 32,
                },
                chroma: Strengths::OFF,
            };
            let mut planes = vec![noisy.clone()];
            d.apply(&mut planes, (w, h), (1.0, 1.0), STEPS);
            let err = |p: &[f32]| {
                p.iter()
                    .zip(&clean)
                    .map(|(a, b)| ((a - b) as f64).powi(2))
                    .sum::<f64>()
            };
            assert!(
                err(&planes[0]) < 0.7 * err(&noisy),
                "direction {dir}: {} vs {}",
                err(&planes[0]),
                err(&noisy)
            );
        }
    }

    #[test]
    fn rows_filtered_from_their_reach_equal_the_whole_plane_filtered() {
        let (w, h) = (37, 45);
        let planes: Vec<Vec<f32>> = (0..3)
            .map(|c| {
                noise(w * h, 7 + c)
                    .iter()
                    .zip(stripes(c as u8 * 3, (w, h)))
                    .map(|(n, s)| s + 0.1 * n)
                    .collect()
            })
            .collect();
        let d = Deringing {
            luma: Strengths {
                primary: 150,
                secondary: 40,
                cutoff: 70,
            },
            chroma: Strengths {
                primary: 0,
                secondary: 30,
                cutoff: 20,
            },
        };
        for spacing in [(1.0, 1.0), (0.5, 0.5), (1.0, 1.0 / 3.0), (2.5, 0.9)] {
            let mut whole = planes.clone();
            d.apply(&mut whole, (w, h), spacing, STEPS);
            let scale = scale(spacing);
            for (start, len) in [(0, 16), (16, 16), (5, 7), (40, 5), (0, 45)] {
                let rows = start..start + len;
                let reach = Deringing::reach(rows.clone(), h, scale);
                let window: Vec<&[f32]> = planes
                    .iter()
                    .map(|p| &p[reach.start * w..reach.end * w])
                    .collect();
                let mut out: Vec<Vec<f32>> = (0..3).map(|_| vec![0.0; len * w]).collect();
                let mut dst: Vec<&mut [f32]> = out.iter_mut().map(Vec::as_mut_slice).collect();
                d.filter_rows(
                    &window,
                    (w, h),
                    reach.start,
                    scale,
                    STEPS,
                    rows.clone(),
                    &mut dst,
                );
                for c in 0..3 {
                    assert_eq!(
                        out[c],
                        whole[c][rows.start * w..rows.end * w],
                        "plane {c}, rows {rows:?}, spacing {spacing:?}"
                    );
                }
            }
        }
    }
}
