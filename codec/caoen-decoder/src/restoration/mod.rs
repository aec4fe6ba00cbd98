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

pub mod colour_map;
pub mod syntax;

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

/// Taps as weights.
fn weights(taps: &[i32]) -> Vec<f32> {
    taps.iter()
        .map(|&t| t as f32 / (1u32 << TAP_LOG2) as f32)
        .collect()
}

/// Rows the classified filter handles at once: its class and difference buffers are
/// this many rows and the window's, whatever the band.
const CLASS_CHUNK: usize = 32;

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
            scaled_rows(
                plane,
                (w, h),
                spacing,
                shape,
                &|_| Some(wt.as_slice()),
                rows,
                out,
            );
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
    let mut start = rows.start;
    while start < rows.end {
        let end = (start + CLASS_CHUNK).min(rows.end);
        let classes = match classes_of {
            (_, Some(known)) => {
                std::borrow::Cow::Borrowed(&known[(start - rows.start) * w..(end - rows.start) * w])
            }
            (luma, None) => {
                std::borrow::Cow::Owned(classify_rows(luma, (w, h), spacing, start..end))
            }
        };
        let pick = |i: usize| by_class[classes[i] as usize];
        let o = &mut out[(start - rows.start) * w..(end - rows.start) * w];
        if let Some(shape) = whole {
            native_classified_rows(plane, (w, h), shape, &classes, &by_class, start..end, o);
        } else {
            scaled_rows(plane, (w, h), spacing, shape, &pick, start..end, o);
        }
        start = end;
    }
}

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
    for (j, y) in rows.clone().enumerate() {
        for (&d, t) in shape.iter().zip(terms.chunks_exact_mut(w)) {
            offset_terms(plane, (w, h), y, d, t);
        }
        let centre = &plane[y * w..(y + 1) * w];
        for x in 0..w {
            let c = centre[x];
            out[j * w + x] = match by_class[classes[j * w + x] as usize] {
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

/// The output pixels per coded pixel along each axis, where both are whole numbers.
fn whole_pixels((px, py): (f64, f64)) -> Option<(usize, usize)> {
    let whole = |v: f64| (v.fract() == 0.0 && (1.0..=65536.0).contains(&v)).then_some(v as usize);
    Some((whole(px)?, whole(py)?))
}

/// One axis of the bilinear interpolation of `f` between output pixel centres at `v`
/// (clamped to the image): the two samples and the second one's weight.
#[inline]
fn lerp_taps(v: f64, n: usize) -> (usize, usize, f32) {
    let v = v.clamp(0.0, (n - 1) as f64);
    let v0 = v.floor() as usize;
    (v0, (v0 + 1).min(n - 1), (v - v0 as f64) as f32)
}

/// [`lerp_taps`] at `x + offset` for every `x` in `0..n`: an axis's taps depend on
/// that axis alone, so rows of samples at a fixed offset share them. Stored in 12
/// bytes (sides are at most 16384), read back by [`tap`].
fn lerp_table(n: usize, offset: f64) -> Vec<(u32, u32, f32)> {
    (0..n)
        .map(|x| {
            let (a, b, f) = lerp_taps(x as f64 + offset, n);
            (a as u32, b as u32, f)
        })
        .collect()
}

/// A [`lerp_table`] entry as [`lerp_taps`] gives it.
#[inline]
fn tap((a, b, f): (u32, u32, f32)) -> (usize, usize, f32) {
    (a as usize, b as usize, f)
}

/// `f` at the point whose two axes' taps are given: bilinear.
#[inline]
fn lerp_at(
    plane: &[f32],
    w: usize,
    (x0, x1, fx): (usize, usize, f32),
    (y0, y1, fy): (usize, usize, f32),
) -> f32 {
    let top = plane[y0 * w + x0] * (1.0 - fx) + plane[y0 * w + x1] * fx;
    let bottom = plane[y1 * w + x0] * (1.0 - fx) + plane[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// The filter at another size: offsets of `d / spacing` output pixels, sampled by
/// bilinear interpolation, positions clamped to the image; `pick(i)` gives the
/// weights of pixel `i` of the rows, if it is filtered. Each offset's column taps are
/// tabulated once and its row taps once per row.
fn scaled_rows<'a>(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
    pick: &dyn Fn(usize) -> Option<&'a [f32]>,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    // The offsets in output pixels, the same for every pixel.
    let offsets: Vec<(f64, f64)> = shape
        .iter()
        .map(|&(dx, dy)| (dx as f64 / sx, dy as f64 / sy))
        .collect();
    let plus: Vec<_> = offsets.iter().map(|&(ox, _)| lerp_table(w, ox)).collect();
    let minus: Vec<_> = offsets.iter().map(|&(ox, _)| lerp_table(w, -ox)).collect();
    for (j, y) in rows.enumerate() {
        let py = y as f64;
        let ys: Vec<_> = offsets
            .iter()
            .map(|&(_, oy)| (lerp_taps(py + oy, h), lerp_taps(py - oy, h)))
            .collect();
        for x in 0..w {
            let c = plane[y * w + x];
            let Some(wt) = pick(j * w + x) else {
                out[j * w + x] = c;
                continue;
            };
            let mut acc = 0.0f32;
            for (k, &wk) in wt.iter().enumerate() {
                let (up, down) = ys[k];
                acc += wk
                    * (lerp_at(plane, w, tap(plus[k][x]), up)
                        + lerp_at(plane, w, tap(minus[k][x]), down)
                        - 2.0 * c);
            }
            out[j * w + x] = c + acc;
        }
    }
}

/// The class of each pixel of rows `rows` (`rows.len() * w` entries, in `0..CLASSES`)
/// of a plane of `w x h` samples `spacing` coded pixels apart.
///
/// At each pixel the absolute second differences across columns (`h`), rows (`v`)
/// and the two diagonals (`d1` down-right, `d2` down-left) are taken one coded pixel
/// either side, sampled as the filter samples. Each is summed over the window of 5x5
/// pixels at offsets `(round(i / sx), round(j / sy))` output pixels, `i, j` from
/// `-WINDOW` to `WINDOW` coded pixels (at the coded size, the 5x5 pixels around it),
/// positions clamped to the image: down each column, then across. The activity level is
/// the number of [`ACTIVITY_BOUNDS`] at or below `v + h`. The direction is taken from
/// the pair `h, v` where `max(h, v) min(d1, d2) > max(d1, d2) min(h, v)` (its larger
/// sum over its smaller is the greater), else from `d1, d2`, if the pair's larger is
/// more than twice its smaller: 1 where `h > v`, 2 for `v`, 3 where `d1 > d2`, 4 for
/// `d2`; else 0. The class is `5 * level + direction`.
pub fn classify_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    rows: std::ops::Range<usize>,
) -> Vec<u8> {
    // Where a coded pixel is a whole number of output pixels the samples fall on pixels:
    // read directly, they are the interpolation's values exactly.
    classify_sampled(
        plane,
        (w, h),
        (sx, sy),
        rows,
        whole_pixels((1.0 / sx, 1.0 / sy)),
    )
}

/// [`classify_rows`], its samples read directly `whole` output pixels apart (else
/// interpolated).
fn classify_sampled(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    rows: std::ops::Range<usize>,
    whole: Option<(usize, usize)>,
) -> Vec<u8> {
    let native = whole.is_some();
    let window = |s: f64| -> Vec<isize> {
        (-(WINDOW as isize)..=WINDOW as isize)
            .map(|i| (i as f64 / s).round() as isize)
            .collect()
    };
    let (ox, oy) = (window(sx), window(sy));
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    // The sample pairs of h, v, d1, d2, in coded pixels across and down; off the coded
    // size their column taps, at -1, 0 and 1 coded pixel, are tabulated once.
    const PAIRS: [((i32, i32), (i32, i32)); 4] = [
        ((1, 0), (-1, 0)),
        ((0, 1), (0, -1)),
        ((1, 1), (-1, -1)),
        ((-1, 1), (1, -1)),
    ];
    let xs: Vec<Vec<(u32, u32, f32)>> = if native {
        Vec::new()
    } else {
        [-1.0, 0.0, 1.0]
            .iter()
            .map(|&a| lerp_table(w, a / sx))
            .collect()
    };
    // The second differences of one row: h, v, d1, d2, each `w` long.
    let diffs = |y: usize| -> [Vec<f32>; 4] {
        let mut d: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w]);
        if let Some((mx, my)) = whole {
            let row = |y: isize| &plane[clamp(y, h) * w..][..w];
            let (up, mid, down) = (
                row(y as isize - my as isize),
                row(y as isize),
                row(y as isize + my as isize),
            );
            let [dh, dv, d1, d2] = &mut d;
            for x in 0..w {
                let (l, r) = (x.saturating_sub(mx), (x + mx).min(w - 1));
                let c = 2.0 * mid[x];
                dh[x] = (c - mid[r] - mid[l]).abs();
                dv[x] = (c - down[x] - up[x]).abs();
                d1[x] = (c - down[r] - up[l]).abs();
                d2[x] = (c - down[l] - up[r]).abs();
            }
            return d;
        }
        let py = y as f64;
        let ys = [-1.0, 0.0, 1.0].map(|a| lerp_taps(py + a / sy, h));
        for x in 0..w {
            let c = 2.0 * plane[y * w + x];
            for (k, ((ax, ay), (bx, by))) in PAIRS.into_iter().enumerate() {
                let a = lerp_at(
                    plane,
                    w,
                    tap(xs[(ax + 1) as usize][x]),
                    ys[(ay + 1) as usize],
                );
                let b = lerp_at(
                    plane,
                    w,
                    tap(xs[(bx + 1) as usize][x]),
                    ys[(by + 1) as usize],
                );
                d[k][x] = (c - a - b).abs();
            }
        }
        d
    };
    // The rows the window reaches from one output row, kept for the next: at most
    // 2 WINDOW + 1 rows of differences, whatever the scale.
    let mut kept: Vec<(usize, [Vec<f32>; 4])> = Vec::new();
    let pad = ox.iter().map(|o| o.unsigned_abs()).max().unwrap_or(0);
    let mut out = Vec::with_capacity(rows.len() * w);
    // Each difference's column sums, padded by `pad` clamped copies at either end, and
    // its window sums: added in the window's order, so every pixel's sum is the same
    // however its rows are banded.
    let mut column: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w + 2 * pad]);
    let mut sums: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w]);
    for y in rows {
        let reach: Vec<usize> = oy.iter().map(|&o| clamp(y as isize + o, h)).collect();
        kept.retain(|(r, _)| reach.contains(r));
        for &r in &reach {
            if !kept.iter().any(|(k, _)| *k == r) {
                kept.push((r, diffs(r)));
            }
        }
        let line = |r: usize| &kept.iter().find(|(k, _)| *k == r).expect("kept above").1;
        for (k, col) in column.iter_mut().enumerate() {
            let inner = &mut col[pad..pad + w];
            inner.fill(0.0);
            for &r in &reach {
                for (s, v) in inner.iter_mut().zip(&line(r)[k]) {
                    *s += v;
                }
            }
            let (left, right) = (col[pad], col[pad + w - 1]);
            col[..pad].fill(left);
            col[pad + w..].fill(right);
        }
        for (sum, col) in sums.iter_mut().zip(&column) {
            sum.fill(0.0);
            for &o in &ox {
                let start = (pad as isize + o) as usize;
                for (s, v) in sum.iter_mut().zip(&col[start..start + w]) {
                    *s += v;
                }
            }
        }
        let [sh, sv, s1, s2] = &sums;
        for (((&gh, &gv), &g1), &g2) in sh.iter().zip(sv).zip(s1).zip(s2) {
            let level = ACTIVITY_BOUNDS.iter().filter(|&&b| gh + gv >= b).count();
            let (hi_hv, lo_hv) = (gh.max(gv), gh.min(gv));
            let (hi_d, lo_d) = (g1.max(g2), g1.min(g2));
            let direction = if hi_hv * lo_d > hi_d * lo_hv {
                if hi_hv > 2.0 * lo_hv {
                    if gh > gv {
                        1
                    } else {
                        2
                    }
                } else {
                    0
                }
            } else if hi_d > 2.0 * lo_d {
                if g1 > g2 {
                    3
                } else {
                    4
                }
            } else {
                0
            };
            out.push((DIRECTIONS * level + direction) as u8);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition, pixel by pixel.
    fn reference(plane: &[f32], (w, h): (usize, usize), c: usize, taps: &[i32]) -> Vec<f32> {
        let get = |x: isize, y: isize| {
            plane[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
        };
        let wt = weights(taps);
        let mut out = vec![0.0; w * h];
        for y in 0..h as isize {
            for x in 0..w as isize {
                let f = get(x, y);
                let mut acc = 0.0f32;
                for (&(dx, dy), &k) in shape(c).iter().zip(&wt) {
                    acc += k
                        * (get(x + dx as isize, y + dy as isize)
                            + get(x - dx as isize, y - dy as isize)
                            - 2.0 * f);
                }
                out[y as usize * w + x as usize] = f + acc;
            }
        }
        out
    }

    fn noise(n: usize, seed: &mut u64) -> Vec<f32> {
        (0..n)
            .map(|_| {
                *seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (*seed >> 40) as f32 / (1u64 << 24) as f32
            })
            .collect()
    }

    #[test]
    fn the_native_filter_is_the_definition_at_every_pixel_and_size() {
        let mut seed = 7;
        for &(w, h) in &[(1, 1), (2, 5), (5, 2), (6, 7), (7, 6), (13, 9), (40, 3)] {
            let plane = noise(w * h, &mut seed);
            for c in [0, 1] {
                let taps: Vec<i32> = (0..shape(c).len())
                    .map(|k| (k as i32 * 37 % 61) - 30)
                    .collect();
                let mut out = vec![0.0; w * h];
                let f = PlaneFilter::single(taps.clone());
                filter_rows(
                    &plane,
                    (&plane, None),
                    (w, h),
                    (1.0, 1.0),
                    shape(c),
                    &f,
                    0..h,
                    &mut out,
                );
                assert_eq!(
                    out,
                    reference(&plane, (w, h), c, &taps),
                    "{w}x{h} plane {c}"
                );
                // A band of rows is the same rows of the whole.
                if h > 2 {
                    let mut band = vec![0.0; w];
                    filter_rows(
                        &plane,
                        (&plane, None),
                        (w, h),
                        (1.0, 1.0),
                        shape(c),
                        &f,
                        1..2,
                        &mut band,
                    );
                    assert_eq!(band, out[w..2 * w]);
                }
            }
        }
    }

    #[test]
    fn scaled_sampling_at_unit_spacing_equals_the_native_filter() {
        let mut seed = 11;
        let (w, h) = (17, 11);
        let plane = noise(w * h, &mut seed);
        let taps: Vec<i32> = (0..12).map(|k| 20 - 3 * k).collect();
        let mut native = vec![0.0; w * h];
        native_rows(
            &plane,
            (w, h),
            &LUMA_SHAPE,
            &weights(&taps),
            0..h,
            &mut native,
        );
        let mut scaled = vec![0.0; w * h];
        let wt = weights(&taps);
        scaled_rows(
            &plane,
            (w, h),
            (1.0, 1.0),
            &LUMA_SHAPE,
            &|_| Some(wt.as_slice()),
            0..h,
            &mut scaled,
        );
        for (a, b) in native.iter().zip(&scaled) {
            assert!((a - b).abs() < 1e-5, "{a} {b}");
        }
    }

    #[test]
    fn whole_pixel_offsets_read_directly_equal_the_interpolated_samples() {
        let mut seed = 29;
        let (w, h) = (37, 45);
        let plane: Vec<f32> = noise(w * h, &mut seed)
            .iter()
            .enumerate()
            .map(|(i, v)| v * [0.002, 0.02, 0.1, 0.5][(i / w / 3) % 4])
            .collect();
        let classified = PlaneFilter {
            filters: vec![
                (0..12).map(|k| 40 - 7 * k).collect(),
                (0..12).map(|k| 3 * k - 9).collect(),
            ],
            classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
        };
        let single = PlaneFilter::single((0..12).map(|k| 25 - 4 * k).collect());
        for spacing in [(0.5, 0.5), (0.25, 0.5), (1.0, 0.5), (1.0 / 3.0, 0.5)] {
            let whole = whole_offsets(&LUMA_SHAPE, (w, h), spacing);
            if spacing.0 != 1.0 / 3.0 {
                assert!(whole.is_some(), "{spacing:?}");
            }
            let steps = whole_pixels((1.0 / spacing.0, 1.0 / spacing.1));
            assert_eq!(
                classify_sampled(&plane, (w, h), spacing, 0..h, steps),
                classify_sampled(&plane, (w, h), spacing, 0..h, None),
                "{spacing:?}"
            );
            // The interpolating path: every pixel's class, then its filter sampled
            // between pixels.
            let classes = classify_sampled(&plane, (w, h), spacing, 0..h, None);
            for f in [&classified, &single] {
                let mut direct = vec![0.0; w * h];
                filter_rows(
                    &plane,
                    (&plane, None),
                    (w, h),
                    spacing,
                    &LUMA_SHAPE,
                    f,
                    0..h,
                    &mut direct,
                );
                let wts: Vec<Vec<f32>> = f.filters.iter().map(|t| weights(t)).collect();
                let pick = |i: usize| match &f.classes {
                    None => Some(wts[0].as_slice()),
                    Some(map) => match map[classes[i] as usize] {
                        0 => None,
                        m => Some(wts[m as usize - 1].as_slice()),
                    },
                };
                let mut lerped = vec![0.0; w * h];
                scaled_rows(
                    &plane,
                    (w, h),
                    spacing,
                    &LUMA_SHAPE,
                    &pick,
                    0..h,
                    &mut lerped,
                );
                assert_eq!(direct, lerped, "{spacing:?}");
            }
        }
    }

    #[test]
    fn a_flat_plane_passes_unchanged_whatever_the_taps() {
        let (w, h) = (9, 8);
        let plane = vec![0.37f32; w * h];
        let r = Restoration {
            planes: vec![
                Some(PlaneFilter::single(vec![MAX_TAP; 12])),
                Some(PlaneFilter {
                    filters: vec![vec![-MAX_TAP; 6], vec![MAX_TAP; 6]],
                    classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
                }),
                None,
            ],
            colour: None,
            last: None,
        };
        for spacing in [(1.0, 1.0), (0.5, 0.7), (3.0, 2.0)] {
            let mut planes = vec![plane.clone(); 3];
            r.apply(&mut planes, (w, h), spacing);
            for p in &planes {
                assert!(p.iter().all(|&v| (v - 0.37).abs() < 1e-5));
            }
        }
    }

    #[test]
    fn the_colour_map_follows_the_filters_in_bands_as_on_whole_planes() {
        let (w, h) = (23, 19);
        let planes: Vec<Vec<f32>> = (0..3)
            .map(|c| {
                (0..w * h)
                    .map(|i| (((i * (7 + c)) % 13) as f32 / 13.0) * 0.8 + 0.1 * c as f32)
                    .collect()
            })
            .collect();
        let map = colour_map::ColourMap {
            rows: vec![vec![40, -7, 3, 12], vec![0, -25, 9, -30], vec![5, 0, 60, 0]],
        };
        let r = Restoration {
            planes: vec![
                Some(PlaneFilter::single((0..12).map(|k| 20 - 3 * k).collect())),
                None,
                Some(PlaneFilter::single(vec![9, -4, 6, 1, 0, 2])),
            ],
            colour: Some(map.clone()),
            last: None,
        };
        for spacing in [(1.0, 1.0), (0.5, 0.7)] {
            let mut whole = planes.clone();
            r.apply(&mut whole, (w, h), spacing);
            // The filters alone, then the map by its definition at every pixel.
            let mut filtered = planes.clone();
            Restoration {
                colour: None,
                ..r.clone()
            }
            .apply(&mut filtered, (w, h), spacing);
            let m = map.real();
            for i in 0..w * h {
                for c in 0..3 {
                    let want = filtered[c][i] as f64
                        + (0..3).map(|k| m[c][k] * filtered[k][i] as f64).sum::<f64>()
                        + m[c][3];
                    assert!(
                        (whole[c][i] as f64 - want).abs() < 1e-5,
                        "pixel {i} plane {c}"
                    );
                }
            }
            let src: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
            for rows in [0..5, 5..19] {
                let mut band: Vec<Vec<f32>> = vec![vec![0.0; rows.len() * w]; 3];
                let mut out: Vec<&mut [f32]> = band.iter_mut().map(Vec::as_mut_slice).collect();
                r.apply_rows(&src, (w, h), spacing, rows.clone(), &mut out);
                for c in 0..3 {
                    assert_eq!(band[c], whole[c][rows.start * w..rows.end * w]);
                }
            }
        }
    }

    #[test]
    fn the_last_filter_in_windows_is_the_filter_on_the_whole_plane() {
        let (w, h) = (21, 40);
        let plane: Vec<f32> = (0..w * h)
            .map(|i| (((i * 37) % 17) as f32 / 17.0) + 0.02 * (i / w) as f32)
            .collect();
        let r = Restoration {
            planes: vec![None],
            colour: None,
            last: Some(PlaneFilter {
                filters: vec![
                    (0..12).map(|k| 30 - 7 * k).collect(),
                    (0..12).map(|k| 5 * k - 20).collect(),
                ],
                classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
            }),
        };
        for spacing in [(1.0, 1.0), (0.5, 0.7), (2.0, 2.0), (1.0, 0.3)] {
            let mut whole = plane.clone();
            r.apply_last(&mut whole, (w, h), spacing);
            assert_ne!(whole, plane);
            let reach = Restoration::last_reach(spacing);
            for rows in [0..7usize, 7..19, 19..40, 13..14] {
                let window = rows.start.saturating_sub(reach)..(rows.end + reach).min(h);
                let mut out = vec![0.0f32; rows.len() * w];
                r.apply_last_rows(
                    &plane[window.start * w..window.end * w],
                    (w, h),
                    window.start,
                    spacing,
                    rows.clone(),
                    &mut out,
                );
                assert_eq!(
                    out,
                    whole[rows.start * w..rows.end * w],
                    "rows {rows:?} at {spacing:?}"
                );
            }
        }
    }

    /// The classes by their definition, pixel by pixel, at the coded size.
    fn reference_classes(plane: &[f32], (w, h): (usize, usize)) -> Vec<u8> {
        let get = |x: isize, y: isize| {
            plane[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
        };
        let second = |x: isize, y: isize, dx: isize, dy: isize| {
            (2.0 * get(x, y) - get(x + dx, y + dy) - get(x - dx, y - dy)).abs()
        };
        let mut out = Vec::new();
        for y in 0..h as isize {
            for x in 0..w as isize {
                let mut g = [0.0f32; 4];
                for j in -(WINDOW as isize)..=WINDOW as isize {
                    for i in -(WINDOW as isize)..=WINDOW as isize {
                        let (px, py) = (
                            (x + i).clamp(0, w as isize - 1),
                            (y + j).clamp(0, h as isize - 1),
                        );
                        g[0] += second(px, py, 1, 0);
                        g[1] += second(px, py, 0, 1);
                        g[2] += second(px, py, 1, 1);
                        g[3] += second(px, py, -1, 1);
                    }
                }
                let [gh, gv, g1, g2] = g;
                let level = ACTIVITY_BOUNDS.iter().filter(|&&b| gh + gv >= b).count();
                // The larger pair's ratio, cross-multiplied so that zeros compare.
                let direction = if gh.max(gv) * g1.min(g2) > g1.max(g2) * gh.min(gv) {
                    if gh.max(gv) > 2.0 * gh.min(gv) {
                        if gh > gv {
                            1
                        } else {
                            2
                        }
                    } else {
                        0
                    }
                } else if g1.max(g2) > 2.0 * g1.min(g2) {
                    if g1 > g2 {
                        3
                    } else {
                        4
                    }
                } else {
                    0
                };
                out.push((DIRECTIONS * level + direction) as u8);
            }
        }
        out
    }

    #[test]
    fn pixel_classes_are_their_definition_in_any_band() {
        let mut seed = 23;
        for &(w, h) in &[(1, 1), (3, 2), (9, 7), (31, 40)] {
            // Noise at several amplitudes: every activity level.
            let plane: Vec<f32> = noise(w * h, &mut seed)
                .iter()
                .enumerate()
                .map(|(i, v)| v * [0.001, 0.01, 0.05, 0.3][(i / w) % 4])
                .collect();
            let whole = classify_rows(&plane, (w, h), (1.0, 1.0), 0..h);
            assert_eq!(whole, reference_classes(&plane, (w, h)), "{w}x{h}");
            for start in 0..h {
                let band = classify_rows(&plane, (w, h), (1.0, 1.0), start..(start + 5).min(h));
                assert_eq!(
                    band,
                    whole[start * w..(start + 5).min(h) * w],
                    "{w}x{h} from {start}"
                );
            }
        }
    }

    #[test]
    fn stripes_take_their_direction_and_flat_planes_the_first_class() {
        let (w, h) = (24, 24);
        let at = |f: &dyn Fn(usize, usize) -> f32| {
            (0..w * h).map(|i| f(i % w, i / w)).collect::<Vec<f32>>()
        };
        let centre = |p: &[f32]| classify_rows(p, (w, h), (1.0, 1.0), 12..13)[12];
        let flat = at(&|_, _| 0.5);
        assert_eq!(centre(&flat), 0);
        // Columns alternate: the second differences across columns are large.
        let columns = at(&|x, _| (x % 2) as f32 * 0.2);
        assert_eq!(centre(&columns) as usize % DIRECTIONS, 1);
        assert_eq!(centre(&columns) as usize / DIRECTIONS, ACTIVITY_LEVELS - 1);
        let rows = at(&|_, y| (y % 2) as f32 * 0.2);
        assert_eq!(centre(&rows) as usize % DIRECTIONS, 2);
        // Diagonal stripes along the down-left diagonal: across them is down-right.
        let diagonal = at(&|x, y| ((x + y) % 4 / 2) as f32 * 0.1);
        assert_eq!(centre(&diagonal) as usize % DIRECTIONS, 3);
        let anti = at(&|x, y| ((x + h - y) % 4 / 2) as f32 * 0.1);
        assert_eq!(centre(&anti) as usize % DIRECTIONS, 4);
    }

    #[test]
    fn the_classified_filter_is_each_pixels_class_filter_in_any_band() {
        let mut seed = 31;
        let (w, h) = (37, 45);
        let plane: Vec<f32> = noise(w * h, &mut seed)
            .iter()
            .enumerate()
            .map(|(i, v)| v * [0.002, 0.02, 0.2][(i / 7) % 3])
            .collect();
        let filters: Vec<Vec<i32>> = (0..3)
            .map(|f| (0..12).map(|k| (k * 13 + f * 29) % 41 - 20).collect())
            .collect();
        let map: [u8; CLASSES] = std::array::from_fn(|k| (k * 7 % 4) as u8);
        let pf = PlaneFilter {
            filters: filters.clone(),
            classes: Some(map),
        };
        let mut out = vec![0.0; w * h];
        filter_rows(
            &plane,
            (&plane, None),
            (w, h),
            (1.0, 1.0),
            &LUMA_SHAPE,
            &pf,
            0..h,
            &mut out,
        );
        let classes = reference_classes(&plane, (w, h));
        let each: Vec<Vec<f32>> = filters
            .iter()
            .map(|t| reference(&plane, (w, h), 0, t))
            .collect();
        for i in 0..w * h {
            let want = match map[classes[i] as usize] {
                0 => plane[i],
                m => each[m as usize - 1][i],
            };
            assert!(
                (out[i] - want).abs() < 1e-6,
                "pixel {i}: {} vs {want}",
                out[i]
            );
        }
        // Bands of any height give the same rows, at the coded size and scaled.
        for spacing in [(1.0, 1.0), (0.5, 0.75), (2.0, 1.5)] {
            let mut whole = vec![0.0; w * h];
            filter_rows(
                &plane,
                (&plane, None),
                (w, h),
                spacing,
                &LUMA_SHAPE,
                &pf,
                0..h,
                &mut whole,
            );
            for start in (0..h).step_by(11) {
                let end = (start + 11).min(h);
                let mut band = vec![0.0; (end - start) * w];
                filter_rows(
                    &plane,
                    (&plane, None),
                    (w, h),
                    spacing,
                    &LUMA_SHAPE,
                    &pf,
                    start..end,
                    &mut band,
                );
                assert_eq!(band, whole[start * w..end * w], "{spacing:?} from {start}");
            }
        }
    }
}
