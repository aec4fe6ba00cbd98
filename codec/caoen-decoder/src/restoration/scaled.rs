//! The filters at another size than the coded one: offsets of `d / spacing` output
//! pixels, sampled by bilinear interpolation between pixel centres.

/// The filter at another size: offsets of `d / spacing` output pixels, sampled by
/// bilinear interpolation, positions clamped to the image; `pick(i)` gives the
/// weights of pixel `i` of the rows, if it is filtered. Each offset's column taps are
/// tabulated once and its row taps once per row.
///
/// Offset by offset along whole rows rather than pixel by pixel: away from the image's
/// sides an offset's column taps are `x + d` and `x + d + 1`, so its samples are four
/// shifted slices of two rows, which the compiler vectorises. Each pixel's sum takes
/// its terms in the same order with the same operations as
/// [`scaled_rows_reference`], so the two agree bit for bit.
pub(super) fn scaled_rows<'a>(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    shape: &[(i32, i32)],
    pick: &dyn Fn(usize) -> Option<&'a [f32]>,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let (offsets, plus, minus) = offset_tables(w, (sx, sy), shape);
    let mut picks: Vec<Option<&[f32]>> = vec![None; w];
    let (mut acc, mut wk) = (vec![0.0f32; w], vec![0.0f32; w]);
    let (mut up, mut down) = (vec![0.0f32; w], vec![0.0f32; w]);
    for (j, y) in rows.enumerate() {
        let py = y as f64;
        let centre = &plane[y * w..(y + 1) * w];
        for (x, p) in picks.iter_mut().enumerate() {
            *p = pick(j * w + x);
        }
        acc.fill(0.0);
        for (k, &(_, oy)) in offsets.iter().enumerate() {
            if !picks.iter().any(|p| p.is_some_and(|t| k < t.len())) {
                continue;
            }
            for (v, p) in wk.iter_mut().zip(&picks) {
                *v = p.and_then(|t| t.get(k)).copied().unwrap_or(0.0);
            }
            lerp_row(plane, w, &plus[k], lerp_taps(py + oy, h), &mut up);
            lerp_row(plane, w, &minus[k], lerp_taps(py - oy, h), &mut down);
            for ((((a, &wx), &u), &d), &c) in
                acc.iter_mut().zip(&wk).zip(&up).zip(&down).zip(centre)
            {
                *a += wx * (u + d - 2.0 * c);
            }
        }
        for (x, o) in out[j * w..(j + 1) * w].iter_mut().enumerate() {
            *o = if picks[x].is_some() {
                centre[x] + acc[x]
            } else {
                centre[x]
            };
        }
    }
}

/// The offsets of `shape` in output pixels (the same for every pixel) at spacing
/// `(sx, sy)`, and each one's column tables to either side.
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

/// A [`lerp_table`] and the columns `lo..hi` where it reads `x + d` and `x + d + 1`:
/// `(lo, hi, d)`, from [`run_of`].
pub(super) type Table = (Vec<(u32, u32, f32)>, (usize, usize, isize));

/// The [`Table`] of a row of `n` samples at `x + offset`.
pub(super) fn table(n: usize, offset: f64) -> Table {
    let t = lerp_table(n, offset);
    let run = run_of(&t);
    (t, run)
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

/// `out[x] = lerp_at(plane, w, tap(t[x]), ys)` for every column of a row of `w`: the
/// run where the taps are `x + d`, `x + d + 1` as shifted slices (vectorised), the
/// rest one by one; the same operations in the same order, so the same values.
pub(super) fn lerp_row(
    plane: &[f32],
    w: usize,
    (t, (lo, hi, d)): &Table,
    ys: (usize, usize, f32),
    out: &mut [f32],
) {
    for x in (0..*lo).chain(*hi..w) {
        out[x] = lerp_at(plane, w, tap(t[x]), ys);
    }
    if lo >= hi {
        return;
    }
    let (y0, y1, fy) = ys;
    let n = hi - lo;
    let at = |y: usize| {
        let s = ((y * w + lo) as isize + d) as usize;
        (&plane[s..s + n], &plane[s + 1..s + n + 1])
    };
    let ((a0, b0), (a1, b1)) = (at(y0), at(y1));
    for (i, o) in out[*lo..*hi].iter_mut().enumerate() {
        let fx = t[lo + i].2;
        let top = a0[i] * (1.0 - fx) + b0[i] * fx;
        let bottom = a1[i] * (1.0 - fx) + b1[i] * fx;
        *o = top * (1.0 - fy) + bottom * fy;
    }
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
                    * (lerp_at(plane, w, tap(plus[k].0[x]), up)
                        + lerp_at(plane, w, tap(minus[k].0[x]), down)
                        - 2.0 * c);
            }
            out[j * w + x] = c + acc;
        }
    }
}
