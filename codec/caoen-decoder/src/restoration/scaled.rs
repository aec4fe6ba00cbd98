//! The filters at another size than the coded one: offsets of `d / spacing` output
//! pixels, sampled by bilinear interpolation between pixel centres.

/// The filter at another size: offsets of `d / spacing` output pixels, sampled by
/// bilinear interpolation, positions clamped to the image, with the pixels' `weights`.
///
/// Offset by offset along whole rows rather than pixel by pixel. A bilinear sample is
/// the vertical blend of two rows each interpolated along x, and a row interpolated at
/// a column offset `dx / sx` serves every offset with that `dx`, on this output row and
/// the next ones: [`Interpolated`] keeps them, so each is made once rather than twice
/// per offset and row. Each pixel's sum takes its terms in the same order with the same
/// operations as [`scaled_rows_reference`], so the two agree bit for bit.
pub(super) fn scaled_rows<'a, F: Fn(usize) -> Option<&'a [f32]>>(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
    weights: &super::Weights<'a, F>,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let mut rows_at = Interpolated::for_shape((w, h), (sx, sy), shape);
    let offsets: Vec<(i32, f64)> = shape.iter().map(|&(dx, dy)| (dx, dy as f64 / sy)).collect();
    // Each offset's terms `f(p + d) + f(p - d) - 2 f(p)` along the row, then each
    // pixel's weighted sum of them, as at the coded size.
    let mut terms = vec![0.0f32; offsets.len() * w];
    let arch = pulp::Arch::new();
    for (j, y) in rows.enumerate() {
        let py = y as f64;
        let centre = &plane[y * w..(y + 1) * w];
        for (&(dx, oy), t) in offsets.iter().zip(terms.chunks_exact_mut(w)) {
            let (u0, u1, fu) = lerp_taps(py + oy, h);
            let (d0, d1, fd) = lerp_taps(py - oy, h);
            let [ua, ub, da, db] = rows_at.rows(plane, [(dx, u0), (dx, u1), (-dx, d0), (-dx, d1)]);
            let rows = ua.iter().zip(ub).zip(da.iter().zip(db));
            arch.dispatch(|| {
                for ((t, &c), ((&ua, &ub), (&da, &db))) in t.iter_mut().zip(centre).zip(rows) {
                    let u = ua * (1.0 - fu) + ub * fu;
                    let d = da * (1.0 - fd) + db * fd;
                    *t = u + d - 2.0 * c;
                }
            });
        }
        let o = &mut out[j * w..(j + 1) * w];
        super::filtered_row(centre, &terms, (weights, j), o);
    }
}

/// Most column offsets [`Interpolated`] keeps rows of: `-3..=3` coded pixels.
pub(super) const KEPT_OFFSETS: usize = 7;

/// Rows [`Interpolated`] keeps of each column offset for output rows that read `reach`
/// output rows up and down, in an image `h` rows high: every row an output row reads
/// (`floor(y - reach) ..= floor(y + reach) + 1`) and one more, so that a row is made
/// once on a pass down the image; never more than the image's rows.
fn kept_rows(reach: f64, h: usize) -> usize {
    let span = 2 * (reach.max(0.0).ceil().min(h as f64) as usize) + 4;
    span.min(h.max(1))
}

/// Bytes an [`Interpolated`] of `offsets` column offsets holds for rows `w` long in an
/// image `h` rows high, whose output rows read `reach` output rows up and down.
pub fn interpolated_bytes(w: usize, h: usize, reach: f64, offsets: usize) -> u64 {
    (kept_rows(reach, h) as u64 * offsets as u64 + 1).saturating_mul(w as u64 * 4 + 32)
}

/// Rows of a plane interpolated along x at whole coded-pixel column offsets `dx`
/// (`dx / sx` output pixels): row `r` at `dx` is the upper (or lower) half of every
/// bilinear sample of that column offset between rows `r` and `r + 1`, made once while
/// the rows near the current one need it: an output row's offsets read rows up to the
/// filter's reach away, which the output rows within that reach read again. Row `r`
/// lives in slot `r % slots` of a ring of [`kept_rows`] slots: on a pass down the
/// image a row gives way only once no later output row reads it, and the rows of one
/// call never share a slot.
pub(super) struct Interpolated {
    w: usize,
    by_dx: Vec<Kept>,
}

/// One column offset's kept rows.
struct Kept {
    dx: i32,
    taps: Table,
    /// The row each slot holds (`usize::MAX` none).
    rows: Vec<usize>,
    samples: Vec<f32>,
}

impl Interpolated {
    /// The rows the filter of `shape` reads at spacing `(sx, sy)` on rows `w` long of
    /// an image `h` rows high.
    pub(super) fn for_shape(
        (w, h): (usize, usize),
        (sx, sy): (f64, f64),
        shape: &[(i32, i32)],
    ) -> Self {
        let reach = shape
            .iter()
            .map(|&(_, dy)| dy.unsigned_abs())
            .max()
            .unwrap_or(0);
        let dxs = shape.iter().flat_map(|&(dx, _)| [dx, -dx]);
        Interpolated::new((w, h), sx, dxs, f64::from(reach) / sy)
    }

    /// Rows `w` long of an image `h` rows high at the column offsets `dxs` (repeats
    /// ignored), spacing `sx`, for output rows that read `reach` output pixels up and
    /// down.
    pub(super) fn new(
        (w, h): (usize, usize),
        sx: f64,
        dxs: impl Iterator<Item = i32>,
        reach: f64,
    ) -> Self {
        let mut keys: Vec<i32> = dxs.collect();
        keys.sort_unstable();
        keys.dedup();
        debug_assert!(keys.len() <= KEPT_OFFSETS);
        let slots = kept_rows(reach, h);
        let by_dx = keys
            .into_iter()
            .map(|dx| Kept {
                dx,
                taps: table(w, dx as f64 / sx),
                rows: vec![usize::MAX; slots],
                samples: vec![0.0f32; slots * w],
            })
            .collect();
        Interpolated { w, by_dx }
    }

    /// Rows `r` of `plane` interpolated at column offsets `dx` (each one of those
    /// given to [`Interpolated::new`]); the rows are within the reach given there of
    /// one output row.
    pub(super) fn rows(&mut self, plane: &[f32], wants: [(i32, usize); 4]) -> [&[f32]; 4] {
        let w = self.w;
        let kept = |by_dx: &[Kept], dx: i32| {
            by_dx
                .iter()
                .position(|k| k.dx == dx)
                .expect("a column offset given to `new`")
        };
        let mut at = [(0usize, 0usize); 4];
        for (&(dx, r), a) in wants.iter().zip(&mut at) {
            let i = kept(&self.by_dx, dx);
            let k = &mut self.by_dx[i];
            let s = r % k.rows.len();
            if k.rows[s] != r {
                interpolate_row(&plane[r * w..][..w], &k.taps, &mut k.samples[s * w..][..w]);
                k.rows[s] = r;
            }
            *a = (i, s);
        }
        std::array::from_fn(|j| {
            let (i, s) = at[j];
            &self.by_dx[i].samples[s * w..][..w]
        })
    }
}

/// The offsets of `shape` in output pixels (the same for every pixel) at spacing
/// `(sx, sy)`, and each one's column tables to either side.
#[cfg(test)]
fn offset_tables(
    w: usize,
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
) -> (Vec<(f64, f64)>, Vec<Table>, Vec<Table>) {
    let offsets: Vec<(f64, f64)> = shape
        .iter()
        .map(|&(dx, dy)| (dx as f64 / sx, dy as f64 / sy))
        .collect();
    let plus = offsets.iter().map(|&(ox, _)| table(w, ox)).collect();
    let minus = offsets.iter().map(|&(ox, _)| table(w, -ox)).collect();
    (offsets, plus, minus)
}

/// A [`lerp_table`], the columns `lo..hi` where it reads `x + d` and `x + d + 1`
/// (`(lo, hi, d)`, from [`run_of`]) and those columns' weights of `x + d + 1` apart,
/// so that the run reads them as a plain slice.
pub(super) struct Table {
    taps: Vec<(u32, u32, f32)>,
    run: (usize, usize, isize),
    weights: Vec<f32>,
}

/// The [`Table`] of a row of `n` samples at `x + offset`.
pub(super) fn table(n: usize, offset: f64) -> Table {
    let taps = lerp_table(n, offset);
    let run = run_of(&taps);
    let weights = taps[run.0..run.1].iter().map(|t| t.2).collect();
    Table { taps, run, weights }
}

/// The run of columns `lo..hi` around the middle where table `t` reads `x + d` and
/// `x + d + 1` (an empty run where the middle does not).
pub(super) fn run_of(t: &[(u32, u32, f32)]) -> (usize, usize, isize) {
    let n = t.len();
    if n == 0 {
        return (0, 0, 0);
    }
    let mid = n / 2;
    let d = t[mid].0 as isize - mid as isize;
    let fits = |x: usize| {
        let (a, b, _) = t[x];
        a as isize == x as isize + d && b == a + 1
    };
    if !fits(mid) {
        return (0, 0, 0);
    }
    let lo = (0..=mid)
        .rev()
        .take_while(|&x| fits(x))
        .last()
        .unwrap_or(mid);
    let hi = (mid..n)
        .take_while(|&x| fits(x))
        .last()
        .map_or(mid, |x| x + 1);
    (lo, hi, d)
}

/// `row` interpolated along x by table `t`: each value is the upper half of
/// [`lerp_at`], `row[x0] * (1 - fx) + row[x1] * fx`; the run where the taps are
/// `x + d`, `x + d + 1` as shifted slices (vectorised).
fn interpolate_row(row: &[f32], table: &Table, out: &mut [f32]) {
    let (lo, hi, d) = table.run;
    for x in (0..lo).chain(hi..row.len()) {
        let (a, b, f) = tap(table.taps[x]);
        out[x] = row[a] * (1.0 - f) + row[b] * f;
    }
    if lo >= hi {
        return;
    }
    let s = (lo as isize + d) as usize;
    let n = hi - lo;
    let (a, b) = (&row[s..s + n], &row[s + 1..s + n + 1]);
    pulp::Arch::new().dispatch(|| {
        for ((o, &f), (&a, &b)) in out[lo..hi]
            .iter_mut()
            .zip(&table.weights)
            .zip(a.iter().zip(b))
        {
            *o = a * (1.0 - f) + b * f;
        }
    });
}

/// One axis of the bilinear interpolation of `f` between output pixel centres at `v`
/// (clamped to the image): the two samples and the second one's weight.
#[inline]
pub(super) fn lerp_taps(v: f64, n: usize) -> (usize, usize, f32) {
    let v = v.clamp(0.0, (n - 1) as f64);
    let v0 = v.floor() as usize;
    (v0, (v0 + 1).min(n - 1), (v - v0 as f64) as f32)
}

/// [`lerp_taps`] at `x + offset` for every `x` in `0..n`: an axis's taps depend on
/// that axis alone, so rows of samples at a fixed offset share them. Stored in 12
/// bytes (sides are at most 16384), read back by [`tap`].
pub(super) fn lerp_table(n: usize, offset: f64) -> Vec<(u32, u32, f32)> {
    (0..n)
        .map(|x| {
            let (a, b, f) = lerp_taps(x as f64 + offset, n);
            (a as u32, b as u32, f)
        })
        .collect()
}

/// A [`lerp_table`] entry as [`lerp_taps`] gives it.
#[inline]
pub(super) fn tap((a, b, f): (u32, u32, f32)) -> (usize, usize, f32) {
    (a as usize, b as usize, f)
}

/// `f` at the point whose two axes' taps are given: bilinear.
#[cfg(test)]
#[inline]
pub(super) fn lerp_at(
    plane: &[f32],
    w: usize,
    (x0, x1, fx): (usize, usize, f32),
    (y0, y1, fy): (usize, usize, f32),
) -> f32 {
    let top = plane[y0 * w + x0] * (1.0 - fx) + plane[y0 * w + x1] * fx;
    let bottom = plane[y1 * w + x0] * (1.0 - fx) + plane[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// [`scaled_rows`] pixel by pixel, as its definition reads: the reference the fast
/// path is tested equal to, bit for bit.
#[cfg(test)]
pub(super) fn scaled_rows_reference<'a>(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
    pick: &dyn Fn(usize) -> Option<&'a [f32]>,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let (offsets, plus, minus) = offset_tables(w, (sx, sy), shape);
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
                    * (lerp_at(plane, w, tap(plus[k].taps[x]), up)
                        + lerp_at(plane, w, tap(minus[k].taps[x]), down)
                        - 2.0 * c);
            }
            out[j * w + x] = c + acc;
        }
    }
}
