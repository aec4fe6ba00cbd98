//! Restoration: small linear filters per colour plane, fitted by the encoder to bring
//! the decoded colours closest to the source's and applied by the decoder last, on the
//! coding planes before their conversion to output colours.
//!
//! A plane's filter is point-symmetric over a diamond of offsets `d` in coded pixels
//! (radius 3 for luma, 2 for chroma: the shapes of VVC's adaptive loop filter). With
//! taps `w`, the restored colour at `p` is
//!
//! `g(p) = f(p) + sum_d w_d (f(p + d) + f(p - d) - 2 f(p))`
//!
//! where `f` is the decoded plane, so a flat region passes unchanged whatever the taps.
//! At the coded size `f(p + d)` is a pixel's own colour (positions past the image
//! clamped to its edge). At any other size the offsets stay in coded pixels, and `f`
//! between output pixel centres is the bilinear interpolation of the output's samples,
//! so the filter follows the picture as the decode's scale changes. What the filter
//! corrects is what the network and the 8x8 blocks leave behind: quantisation noise
//! and ringing around edges, and edges softened by the network's blend.
//!
//! A plane has one filter, or one per class of pixels ([`classify_rows`]: the local
//! activity and direction of the luma's second differences), so that flat regions can
//! be smoothed and edges sharpened, each along its direction. After the filters, a
//! [`ColourMap`](colour_map::ColourMap) may map the colour planes together.

mod classes;
pub mod colour_map;
mod scaled;

use scaled::{interpolated_bytes, scaled_rows, KEPT_OFFSETS};

pub mod syntax;
#[cfg(test)]
mod tests;

pub use classes::classify_rows;

/// Tap precision: taps are integers in units of `2^-TAP_LOG2`.
pub const TAP_LOG2: u32 = 8;
/// Largest tap magnitude (just under 4).
pub const MAX_TAP: i32 = 1023;

/// One offset of each symmetric pair of the luma filter: the 7x7 diamond.
pub const LUMA_SHAPE: [(i32, i32); 12] = [
    (1, 0),
    (2, 0),
    (3, 0),
    (-2, 1),
    (-1, 1),
    (0, 1),
    (1, 1),
    (2, 1),
    (-1, 2),
    (0, 2),
    (1, 2),
    (0, 3),
];
/// One offset of each symmetric pair of the chroma filters: the 5x5 diamond.
pub const CHROMA_SHAPE: [(i32, i32); 6] = [(1, 0), (2, 0), (-1, 1), (0, 1), (1, 1), (0, 2)];
/// Largest offset along either axis.
pub const RADIUS: usize = 3;

/// The offsets of colour plane `c` (0 luma or grey, else chroma).
pub fn shape(c: usize) -> &'static [(i32, i32)] {
    if c == 0 {
        &LUMA_SHAPE
    } else {
        &CHROMA_SHAPE
    }
}

/// Activity levels of the pixel classes.
pub const ACTIVITY_LEVELS: usize = 8;
/// Directions of the pixel classes: none, across columns, across rows, and the two
/// diagonals.
pub const DIRECTIONS: usize = 5;
/// Pixel classes a classified plane's filters are chosen by.
pub const CLASSES: usize = ACTIVITY_LEVELS * DIRECTIONS;
/// Most filters one plane has.
pub const MAX_FILTERS: usize = 16;
/// The activity levels' lower bounds: a pixel's activity is its window's sum of
/// vertical and horizontal second differences, in plane units.
pub const ACTIVITY_BOUNDS: [f32; ACTIVITY_LEVELS - 1] = [0.03, 0.08, 0.18, 0.4, 0.85, 1.9, 4.0];
/// Half the side of the window the second differences are summed over, in coded pixels.
pub const WINDOW: usize = 2;

/// One colour plane's filters: one for every pixel, or one per pixel class.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlaneFilter {
    /// Each filter's taps in [`shape`]'s order (one to [`MAX_FILTERS`]).
    pub filters: Vec<Vec<i32>>,
    /// Per class ([`classify_rows`] of the unfiltered luma, for every plane): 0 for no
    /// filter, else one more than the index of the class's filter. `None`: the first
    /// filter for every pixel.
    pub classes: Option<[u8; CLASSES]>,
}

impl PlaneFilter {
    /// One filter for the whole plane.
    pub fn single(taps: Vec<i32>) -> Self {
        PlaneFilter {
            filters: vec![taps],
            classes: None,
        }
    }
}

/// The filters of a file's colour planes (`None` leaves a plane alone) and the colour
/// map after them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Restoration {
    /// Per colour plane (Y, or Y, C1, C2).
    pub planes: Vec<Option<PlaneFilter>>,
    /// The affine map of the filtered colour planes, if any.
    pub colour: Option<colour_map::ColourMap>,
    /// The luma's filters ([`LUMA_SHAPE`]) applied last, after the deringing, one or
    /// one per pixel class of the deringed luma, if any.
    pub last: Option<PlaneFilter>,
}

impl Restoration {
    /// Whether any plane is filtered or mapped.
    pub fn any(&self) -> bool {
        self.planes.iter().any(Option::is_some) || self.colour.is_some() || self.last.is_some()
    }

    /// Output rows the last filter reads either side of a row, at `spacing` coded
    /// pixels per output pixel: its offsets and the classes' windows of second
    /// differences, with a row more for bilinear sampling.
    pub fn last_reach(spacing: (f64, f64)) -> usize {
        let taps = (RADIUS as f64 / spacing.1).ceil() as usize;
        let classes = WINDOW + (1.0 / spacing.1).ceil() as usize;
        taps.max(classes).saturating_add(1)
    }

    /// Applies the last filter to rows `rows` of `window`, the luma of rows `y0..` of
    /// an output `h` rows high (`w` samples each, `spacing` coded pixels per output
    /// pixel), into `out`. The window holds every row the filter reads
    /// ([`Self::last_reach`]) that the image has, so reading it is reading the image.
    #[allow(clippy::too_many_arguments)]
    pub fn apply_last_rows(
        &self,
        window: &[f32],
        (w, h): (usize, usize),
        y0: usize,
        spacing: (f64, f64),
        rows: std::ops::Range<usize>,
        out: &mut [f32],
    ) {
        let Some(f) = &self.last else {
            out.copy_from_slice(&window[(rows.start - y0) * w..(rows.end - y0) * w]);
            return;
        };
        let held = window.len() / w.max(1);
        debug_assert!(y0 + held <= h && (y0 == 0 || y0 + Self::last_reach(spacing) <= rows.start));
        filter_rows(
            window,
            (window, None),
            (w, held),
            spacing,
            &LUMA_SHAPE,
            f,
            rows.start - y0..rows.end - y0,
            out,
        );
    }

    /// Applies the last filter to the whole luma plane `luma` (`w x h`, `spacing` coded
    /// pixels per output pixel), in place.
    pub fn apply_last(&self, luma: &mut Vec<f32>, (w, h): (usize, usize), spacing: (f64, f64)) {
        if let Some(f) = &self.last {
            let mut out = vec![0.0f32; w * h];
            filter_rows(
                luma,
                (luma, None),
                (w, h),
                spacing,
                &LUMA_SHAPE,
                f,
                0..h,
                &mut out,
            );
            *luma = out;
        }
    }

    /// Applies the filters to rows `rows` of `planes` (`w x h` samples each, output
    /// pixels `spacing` coded pixels apart), writing them into `out` (one slice per
    /// colour plane, `rows.len() * w` samples).
    pub fn apply_rows(
        &self,
        planes: &[&[f32]],
        (w, h): (usize, usize),
        spacing: (f64, f64),
        rows: std::ops::Range<usize>,
        out: &mut [&mut [f32]],
    ) {
        // The rows' classes once for every classified plane.
        let classified = self.planes.iter().flatten().any(|f| f.classes.is_some());
        let classes = classified.then(|| classify_rows(planes[0], (w, h), spacing, rows.clone()));
        for (c, (plane, out)) in planes.iter().zip(out.iter_mut()).enumerate() {
            let src = &plane[rows.start * w..rows.end * w];
            match self.planes.get(c).and_then(Option::as_ref) {
                Some(f) => filter_rows(
                    plane,
                    (planes[0], classes.as_deref()),
                    (w, h),
                    spacing,
                    shape(c),
                    f,
                    rows.clone(),
                    out,
                ),
                None => out.copy_from_slice(src),
            }
        }
        if let Some(m) = &self.colour {
            m.apply(out);
        }
    }

    /// Filters whole planes of `w x h` samples `spacing` coded pixels apart, in place.
    pub fn apply(&self, planes: &mut [Vec<f32>], (w, h): (usize, usize), spacing: (f64, f64)) {
        // Every plane's classes come from the unfiltered luma, so it is filtered last;
        // one plane's output at a time.
        let n = planes.len().min(self.planes.len());
        for c in (1..n).chain((n > 0).then_some(0)) {
            if let Some(f) = &self.planes[c] {
                let mut out = vec![0.0f32; w * h];
                filter_rows(
                    &planes[c],
                    (&planes[0], None),
                    (w, h),
                    spacing,
                    shape(c),
                    f,
                    0..h,
                    &mut out,
                );
                planes[c] = out;
            }
        }
        if let Some(m) = &self.colour {
            let mut parts: Vec<&mut [f32]> = planes
                .iter_mut()
                .take(m.planes())
                .map(|p| &mut p[..w * h])
                .collect();
            m.apply(&mut parts);
        }
    }
}

/// Bytes the filters of one range of rows hold at most beside their input and output,
/// on planes of `w x h` samples `spacing` coded pixels apart: a row of terms per
/// offset, and the rows interpolated off the coded size, the classifier's (with its
/// rows of differences) or, after it, the filter's.
pub fn filter_bytes((w, h): (usize, usize), (_, sy): (f64, f64)) -> u64 {
    let row = w as u64 * 4 + 32;
    let filter = interpolated_bytes(w, h, RADIUS as f64 / sy, KEPT_OFFSETS);
    let classifier =
        interpolated_bytes(w, h, 1.0 / sy, 3) + ((2 * WINDOW as u64 + 1) * 4 + 6) * row;
    filter.max(classifier).saturating_add(14 * row)
}

/// Taps as weights.
fn weights(taps: &[i32]) -> Vec<f32> {
    taps.iter()
        .map(|&t| t as f32 / (1u32 << TAP_LOG2) as f32)
        .collect()
}

/// The offsets of `shape` in output pixels, if every one is a whole number of them:
/// read directly, their samples are the interpolation's values exactly.
fn whole_offsets(
    shape: &[(i32, i32)],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
) -> Option<Vec<(i32, i32)>> {
    shape
        .iter()
        .map(|&(dx, dy)| {
            let (ox, oy) = (dx as f64 / sx, dy as f64 / sy);
            (ox.fract() == 0.0 && oy.fract() == 0.0 && ox.abs() <= w as f64 && oy.abs() <= h as f64)
                .then_some((ox as i32, oy as i32))
        })
        .collect()
}

/// One plane's filters over rows `rows` into `out`, its classes from the luma plane
/// `classes_of.0` (or, if known, `classes_of.1`: the classes of `rows`).
#[allow(clippy::too_many_arguments)]
fn filter_rows(
    plane: &[f32],
    classes_of: (&[f32], Option<&[u8]>),
    (w, h): (usize, usize),
    spacing: (f64, f64),
    shape: &[(i32, i32)],
    f: &PlaneFilter,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let whole = whole_offsets(shape, (w, h), spacing);
    let whole = whole.as_deref();
    let Some(map) = &f.classes else {
        let wt = weights(&f.filters[0]);
        if let Some(shape) = whole {
            native_rows(plane, (w, h), shape, &wt, rows, out);
        } else {
            let every = Weights::every(&wt);
            scaled_rows(plane, (w, h), spacing, shape, &every, rows, out);
        }
        return;
    };
    let wts: Vec<Vec<f32>> = f.filters.iter().map(|t| weights(t)).collect();
    let by_class: Vec<Option<&[f32]>> = map
        .iter()
        .map(|&m| {
            (m > 0)
                .then(|| wts.get(m as usize - 1).map(Vec::as_slice))
                .flatten()
        })
        .collect();
    let classes = |r: std::ops::Range<usize>| match classes_of {
        (_, Some(known)) => {
            std::borrow::Cow::Borrowed(&known[(r.start - rows.start) * w..(r.end - rows.start) * w])
        }
        (luma, None) => std::borrow::Cow::Owned(classify_rows(luma, (w, h), spacing, r)),
    };
    let Some(offsets) = whole else {
        // The classes of every row at once: off the coded size the classifier
        // interpolates the rows it reads, once for the whole range.
        let classes = classes(rows.clone());
        let each = Weights::Each(|i: usize| by_class[classes[i] as usize]);
        return scaled_rows(plane, (w, h), spacing, shape, &each, rows, out);
    };
    // At the coded size, a few rows at a time, while their samples are in cache.
    let mut start = rows.start;
    while start < rows.end {
        let end = (start + CLASS_CHUNK).min(rows.end);
        let o = &mut out[(start - rows.start) * w..(end - rows.start) * w];
        native_classified_rows(
            plane,
            (w, h),
            offsets,
            &classes(start..end),
            &by_class,
            start..end,
            o,
        );
        start = end;
    }
}

/// Rows the classified filter at the coded size handles at once.
const CLASS_CHUNK: usize = 32;

/// Row `y`'s terms `f(p + d) + f(p - d) - 2 f(p)` for offset `(dx, dy)` into `t`,
/// positions clamped to the plane.
fn offset_terms(
    plane: &[f32],
    (w, h): (usize, usize),
    y: usize,
    (dx, dy): (i32, i32),
    t: &mut [f32],
) {
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let centre = &plane[y * w..(y + 1) * w];
    let up = &plane[clamp(y as isize - dy as isize, h) * w..][..w];
    let down = &plane[clamp(y as isize + dy as isize, h) * w..][..w];
    let dxu = dx.unsigned_abs() as usize;
    // Columns `lo..hi` have both neighbours inside the row; the others clamp.
    let lo = dxu.min(w);
    let hi = w.saturating_sub(dxu).max(lo);
    for x in lo..hi {
        let (a, b) = if dx >= 0 {
            (down[x + dxu], up[x - dxu])
        } else {
            (down[x - dxu], up[x + dxu])
        };
        t[x] = a + b - 2.0 * centre[x];
    }
    for x in (0..lo).chain(hi..w) {
        let a = down[clamp(x as isize + dx as isize, w)];
        let b = up[clamp(x as isize - dx as isize, w)];
        t[x] = a + b - 2.0 * centre[x];
    }
}

/// The filter at the coded size: every offset is a whole pixel.
fn native_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    shape: &[(i32, i32)],
    wt: &[f32],
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let mut line = vec![0.0f32; w];
    let mut t = vec![0.0f32; w];
    for (j, y) in rows.clone().enumerate() {
        line.fill(0.0);
        for (&d, &k) in shape.iter().zip(wt) {
            offset_terms(plane, (w, h), y, d, &mut t);
            for (l, &v) in line.iter_mut().zip(&t) {
                *l += k * v;
            }
        }
        let centre = &plane[y * w..(y + 1) * w];
        for ((o, &c), &l) in out[j * w..(j + 1) * w].iter_mut().zip(centre).zip(&line) {
            *o = c + l;
        }
    }
}

/// The classified filter at the coded size: `classes` holds the class of each pixel of
/// the rows (counted from the first) and `by_class` each class's weights, if it is
/// filtered. Each row's terms `f(p + d) + f(p - d) - 2 f(p)` first, offset by offset,
/// then each pixel's sum.
fn native_classified_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    shape: &[(i32, i32)],
    classes: &[u8],
    by_class: &[Option<&[f32]>],
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let mut terms = vec![0.0f32; shape.len() * w];
    let weights = Weights::Each(|i: usize| by_class[classes[i] as usize]);
    for (j, y) in rows.clone().enumerate() {
        for (&d, t) in shape.iter().zip(terms.chunks_exact_mut(w)) {
            offset_terms(plane, (w, h), y, d, t);
        }
        let centre = &plane[y * w..(y + 1) * w];
        let o = &mut out[j * w..(j + 1) * w];
        filtered_row(centre, &terms, (&weights, j), o);
    }
}

/// The weights of a row's pixels: one filter's for every pixel, or each pixel's own
/// (by its class; `None` where it is not filtered).
pub(super) enum Weights<'a, F: Fn(usize) -> Option<&'a [f32]>> {
    /// The same weights for every pixel.
    Every(&'a [f32]),
    /// Pixel `i`'s weights (`i` counted from the first row's first pixel).
    Each(F),
}

impl<'a> Weights<'a, fn(usize) -> Option<&'a [f32]>> {
    /// The same weights `wt` for every pixel.
    pub(super) fn every(wt: &'a [f32]) -> Self {
        Weights::Every(wt)
    }
}

/// Row `j` (of the rows `weights` counts from) filtered from its terms
/// (`terms[k * w + x]`, offset `k`'s at pixel `x`): `c + sum_k wt[k] terms[k]` with
/// the pixel's weights taken in order, or the centre `c` where a pixel is not
/// filtered. With one filter for every pixel, each offset's products are added across
/// the row (in the same order for each pixel, so the same bits), vectorised for the
/// widest unit `pulp` finds.
fn filtered_row<'a, F: Fn(usize) -> Option<&'a [f32]>>(
    centre: &[f32],
    terms: &[f32],
    (weights, j): (&Weights<'a, F>, usize),
    out: &mut [f32],
) {
    let w = centre.len();
    let arch = pulp::Arch::new();
    match weights {
        Weights::Every(wt) => arch.dispatch(|| {
            out.fill(0.0);
            for (&wk, t) in wt.iter().zip(terms.chunks_exact(w)) {
                for (o, &t) in out.iter_mut().zip(t) {
                    *o += wk * t;
                }
            }
            for (o, &c) in out.iter_mut().zip(centre) {
                *o += c;
            }
        }),
        // Vectorised across the row, each pixel's weights would first be gathered
        // into rows: as slow as the sums themselves, which out-of-order execution
        // already overlaps from pixel to pixel.
        Weights::Each(pick) => {
            for (x, (o, &c)) in out.iter_mut().zip(centre).enumerate() {
                *o = match pick(j * w + x) {
                    Some(wt) => {
                        let mut acc = 0.0f32;
                        for (k, &wk) in wt.iter().enumerate() {
                            acc += wk * terms[k * w + x];
                        }
                        c + acc
                    }
                    None => c,
                };
            }
        }
    }
}

/// The output pixels per coded pixel along each axis, where both are whole numbers.
fn whole_pixels((px, py): (f64, f64)) -> Option<(usize, usize)> {
    let whole = |v: f64| (v.fract() == 0.0 && (1.0..=65536.0).contains(&v)).then_some(v as usize);
    Some((whole(px)?, whole(py)?))
}
