//! The encoder's side of the deringing: what each candidate filter gains over some
//! rows, from sums that take one pass over the pixels for every candidate.

use std::ops::Range;

#[cfg(doc)]
use caoen_decoder::deringing::Deringing;
use caoen_decoder::deringing::{
    constrain, gather_row, scaled_offsets, Strengths, BLOCK, CUTOFF_DIVISOR, PRIMARY_TAPS,
    SECONDARY_TAPS, STRENGTH_DIVISOR, TAPS,
};

/// Candidate primary strengths, in stored units (0: none).
pub const PRIMARIES: [u8; 10] = [0, 2, 4, 6, 8, 12, 16, 24, 32, 48];
/// Candidate secondary strengths, in stored units (0: none).
pub const SECONDARIES: [u8; 5] = [0, 3, 6, 12, 24];
/// Candidate cutoffs, in stored units.
pub const CUTOFFS: [u8; 5] = [6, 12, 24, 48, 96];
const NP: usize = PRIMARIES.len();
const NS: usize = SECONDARIES.len();
const NC: usize = CUTOFFS.len();

/// One plane kind's sums over the pixels seen, per cutoff: with `e` the source
/// minus the decoded value, `P` a primary strength's and `S` a secondary's
/// correction, `sum e P`, `sum P^2`, `sum e S`, `sum S^2` and `sum P S`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sums {
    ep: [[f64; NP]; NC],
    pp: [[f64; NP]; NC],
    es: [[f64; NS]; NC],
    ss: [[f64; NS]; NC],
    ps: [[[f64; NS]; NP]; NC],
    /// Pixels seen.
    pub samples: u64,
}

impl Default for Sums {
    fn default() -> Self {
        Sums {
            ep: [[0.0; NP]; NC],
            pp: [[0.0; NP]; NC],
            es: [[0.0; NS]; NC],
            ss: [[0.0; NS]; NC],
            ps: [[[0.0; NS]; NP]; NC],
            samples: 0,
        }
    }
}

impl Sums {
    /// Adds `other`'s sums.
    pub fn add(&mut self, other: &Sums) {
        fn add<const N: usize>(a: &mut [[f64; N]; NC], b: &[[f64; N]; NC]) {
            for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
                *x += y;
            }
        }
        add(&mut self.ep, &other.ep);
        add(&mut self.pp, &other.pp);
        add(&mut self.es, &other.es);
        add(&mut self.ss, &other.ss);
        for (x, y) in self
            .ps
            .iter_mut()
            .flatten()
            .flatten()
            .zip(other.ps.iter().flatten().flatten())
        {
            *x += y;
        }
        self.samples += other.samples;
    }

    /// How much the candidate `(cutoff, primary, secondary)` (indices into
    /// [`CUTOFFS`], [`PRIMARIES`], [`SECONDARIES`]) lowers the squared error.
    pub fn gain(&self, (c, p, s): (usize, usize, usize)) -> f64 {
        2.0 * self.ep[c][p] + 2.0 * self.es[c][s]
            - self.pp[c][p]
            - self.ss[c][s]
            - 2.0 * self.ps[c][p][s]
    }

    /// The candidate that gains most, its strengths and gain (`None` if none gains).
    pub fn best(&self) -> Option<(Strengths, f64)> {
        let mut best: Option<((usize, usize, usize), f64)> = None;
        for c in 0..NC {
            for p in 0..NP {
                for s in 0..NS {
                    if p == 0 && s == 0 {
                        continue;
                    }
                    let g = self.gain((c, p, s));
                    if g > 0.0 && best.is_none_or(|(_, b)| g > b) {
                        best = Some(((c, p, s), g));
                    }
                }
            }
        }
        best.map(|((c, p, s), g)| (Self::strengths((c, p, s)), g))
    }

    /// The gain of `strengths`, a candidate of these sums.
    pub fn gain_of(&self, strengths: Strengths) -> f64 {
        let find = |v: &[u8], x: u8| v.iter().position(|&y| y == x);
        match (
            find(&CUTOFFS, strengths.cutoff),
            find(&PRIMARIES, strengths.primary),
            find(&SECONDARIES, strengths.secondary),
        ) {
            (Some(c), Some(p), Some(s)) => self.gain((c, p, s)),
            _ => 0.0,
        }
    }

    fn strengths((c, p, s): (usize, usize, usize)) -> Strengths {
        Strengths {
            primary: PRIMARIES[p],
            secondary: SECONDARIES[s],
            cutoff: CUTOFFS[c],
        }
    }
}

/// Adds rows `rows` of colour plane `c` to `sums`: `window` holds the decoded
/// (restored) colour planes' rows from `y0` on, at least [`Deringing::reach`]'s, of
/// an image `w x h` at its coded size, and `source` the source's rows `rows` of
/// plane `c`. `dirs` are the luma's block directions for the rows' block rows,
/// `step` the plane kind's. Every `stride`-th row is summed, from the first.
#[allow(clippy::too_many_arguments)]
pub fn accumulate(
    sums: &mut Sums,
    window: &[f32],
    (w, h): (usize, usize),
    y0: usize,
    dirs: &[u8],
    rows: Range<usize>,
    source: &[f64],
    step: f32,
    stride: usize,
) {
    let cols = w.div_ceil(BLOCK);
    let first_block_row = rows.start / BLOCK;
    // Each tap's difference for the row: primary taps first (k, sign), then the
    // secondary ones (k, side, sign).
    let mut diffs = vec![0.0f32; TAPS * w];
    let mut e = vec![0.0f32; w];
    let mut prim = vec![0.0f32; NP * w];
    let mut sec = vec![0.0f32; NS * w];
    let arch = pulp::Arch::new();
    let offsets = scaled_offsets((1, 1));
    let all: [usize; TAPS] = std::array::from_fn(|t| t);
    for y in rows.clone().step_by(stride.max(1)) {
        let centre = &window[(y - y0) * w..][..w];
        let src = &source[(y - rows.start) * w..][..w];
        for ((e, &s), &c) in e.iter_mut().zip(src).zip(centre) {
            *e = (s - c as f64) as f32;
        }
        // The neighbours, then their differences (0 past the image: no correction).
        let row_dirs = &dirs[(y / BLOCK - first_block_row) * cols..][..cols];
        gather_row(
            window,
            (w, h),
            y0,
            y,
            (BLOCK, &offsets),
            row_dirs,
            &all,
            &mut diffs,
        );
        for tap in diffs.chunks_exact_mut(w) {
            for (d, &c) in tap.iter_mut().zip(centre) {
                *d -= c;
            }
        }
        arch.dispatch(RowFit {
            sums: &mut *sums,
            diffs: &diffs,
            e: &e,
            prim: &mut prim,
            sec: &mut sec,
            step,
        });
    }
    sums.samples += (rows.len().div_ceil(stride.max(1)) * w) as u64;
}

/// One row's sums for every candidate, as a `pulp` operation (inlined into the
/// target-feature function `pulp` picks, so the loops vectorise).
struct RowFit<'a> {
    sums: &'a mut Sums,
    diffs: &'a [f32],
    e: &'a [f32],
    prim: &'a mut [f32],
    sec: &'a mut [f32],
    step: f32,
}

impl pulp::WithSimd for RowFit<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let RowFit {
            sums,
            diffs,
            e,
            prim,
            sec,
            step,
        } = self;
        let w = e.len();
        for (ci, &cut) in CUTOFFS.iter().enumerate() {
            let cutoff = cut as f32 * step / CUTOFF_DIVISOR;
            let pw = [
                PRIMARY_TAPS[0],
                PRIMARY_TAPS[0],
                PRIMARY_TAPS[1],
                PRIMARY_TAPS[1],
            ];
            for (pi, &p) in PRIMARIES.iter().enumerate() {
                correction(
                    &diffs[..4 * w],
                    &pw,
                    p as f32 * step / STRENGTH_DIVISOR,
                    cutoff,
                    &mut prim[pi * w..][..w],
                );
            }
            let sw = [
                SECONDARY_TAPS[0],
                SECONDARY_TAPS[0],
                SECONDARY_TAPS[0],
                SECONDARY_TAPS[0],
                SECONDARY_TAPS[1],
                SECONDARY_TAPS[1],
                SECONDARY_TAPS[1],
                SECONDARY_TAPS[1],
            ];
            for (si, &s) in SECONDARIES.iter().enumerate() {
                correction(
                    &diffs[4 * w..],
                    &sw,
                    s as f32 * step / STRENGTH_DIVISOR,
                    cutoff,
                    &mut sec[si * w..][..w],
                );
            }
            for pi in 1..NP {
                let pv = &prim[pi * w..][..w];
                sums.ep[ci][pi] += dot(e, pv);
                sums.pp[ci][pi] += dot(pv, pv);
                for si in 1..NS {
                    sums.ps[ci][pi][si] += dot(pv, &sec[si * w..][..w]);
                }
            }
            for si in 1..NS {
                let sv = &sec[si * w..][..w];
                sums.es[ci][si] += dot(e, sv);
                sums.ss[ci][si] += dot(sv, sv);
            }
        }
    }
}

/// `sum_t wts[t] constrain(diffs[t], s, s / cutoff)` per pixel into `out`.
#[inline(always)]
fn correction(diffs: &[f32], wts: &[f32], s: f32, cutoff: f32, out: &mut [f32]) {
    let w = out.len();
    out.fill(0.0);
    if s == 0.0 {
        return;
    }
    let k = s / cutoff;
    for (t, &wt) in wts.iter().enumerate() {
        for (o, &d) in out.iter_mut().zip(&diffs[t * w..][..w]) {
            *o += wt * constrain(d, s, k);
        }
    }
}

#[inline(always)]
fn dot(a: &[f32], b: &[f32]) -> f64 {
    // Eight running sums, so the products vectorise; in f64 per chunk of 64, so
    // rows of several thousand pixels keep their precision.
    a.chunks(64)
        .zip(b.chunks(64))
        .map(|(a, b)| {
            let mut lanes = [0.0f32; 8];
            let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
            let tail: f32 = ca
                .remainder()
                .iter()
                .zip(cb.remainder())
                .map(|(x, y)| x * y)
                .sum();
            for (x, y) in ca.zip(cb) {
                for l in 0..8 {
                    lanes[l] += x[l] * y[l];
                }
            }
            (lanes.iter().sum::<f32>() + tail) as f64
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_decoder::deringing::{directions, Deringing};

    /// The tests' steps: strengths of 1/256 and cutoffs of 1/64 of a plane unit.
    const STEPS: [f32; 2] = [0.25, 0.125];

    fn noise(n: usize, seed: u64) -> Vec<f32> {
        caoen_base::rng::Lcg::new(seed).noise(n)
    }

    /// A plane that varies only across lines of direction 5 (stripes along it).
    fn stripes_5((w, h): (usize, usize)) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                ((x - y / 2.0) * 1.3).sin() * 0.4
            })
            .collect()
    }

    #[test]
    fn the_fits_sums_predict_the_filters_gain() {
        let (w, h) = (40, 33);
        let clean = stripes_5((w, h));
        let decoded: Vec<f32> = clean
            .iter()
            .zip(noise(w * h, 3))
            .map(|(c, n)| c + 0.06 * n)
            .collect();
        let source: Vec<f64> = clean.iter().map(|&v| v as f64).collect();
        let dirs = directions(&decoded, (w, h), 0, (1, 1), 0..h);
        let mut sums = Sums::default();
        accumulate(
            &mut sums,
            &decoded,
            (w, h),
            0,
            &dirs,
            0..h,
            &source,
            STEPS[0],
            1,
        );
        assert_eq!(sums.samples, (w * h) as u64);
        let err = |p: &[f32]| {
            p.iter()
                .zip(&source)
                .map(|(&a, &b)| (a as f64 - b).powi(2))
                .sum::<f64>()
        };
        let before = err(&decoded);
        for (primary, secondary, cutoff) in [
            (PRIMARIES[3], SECONDARIES[0], CUTOFFS[2]),
            (PRIMARIES[9], SECONDARIES[4], CUTOFFS[0]),
            (PRIMARIES[0], SECONDARIES[2], CUTOFFS[3]),
        ] {
            let s = Strengths {
                primary,
                secondary,
                cutoff,
            };
            let d = Deringing {
                luma: s,
                chroma: Strengths::OFF,
            };
            let mut planes = vec![decoded.clone()];
            d.apply(&mut planes, (w, h), (1.0, 1.0), STEPS);
            let gain = before - err(&planes[0]);
            let predicted = sums.gain_of(s);
            assert!(
                (gain - predicted).abs() <= 1e-4 * before,
                "{s:?}: measured {gain}, predicted {predicted}"
            );
        }
        let (best, gain) = sums.best().expect("noise along stripes is worth smoothing");
        assert!(
            best.is_on() && gain > 0.2 * before,
            "{best:?} gains {gain} of {before}"
        );
    }
}
