//! The encoder's side: each plane's normal equations against the source, their
//! least-squares taps quantised, and whether those pay for their bits.
//!
//! With `r_d(p) = f(p + d) + f(p - d) - 2 f(p)` and `e(p)` the source minus the decoded
//! colour, the squared error after filtering with weights `w` is
//! `sum e^2 - 2 w.b + w^T A w` for `A = sum r r^T` and `b = sum r e`: the sums decide
//! every candidate's error without another pass over the pixels. The sums are kept
//! per pixel class, so any grouping of the classes has its sums by addition: the
//! classes are merged greedily into the filters that pay best for their bits.

use nalgebra::{DMatrix, DVector};

use caoen_decoder::restoration::syntax::{classified_bits, plane_bits, tap_bits};
use caoen_decoder::restoration::{
    shape, PlaneFilter, CHROMA_SHAPE, CLASSES, LUMA_SHAPE, MAX_FILTERS, MAX_TAP, TAP_LOG2,
};

/// One plane's normal equations over the pixels seen.
#[derive(Debug, Clone, PartialEq)]
pub struct Stats {
    k: usize,
    /// `A`, row-major, upper triangle filled.
    a: Vec<f64>,
    b: Vec<f64>,
    /// The squared error before filtering, `sum e^2`.
    pub error: f64,
    /// Pixels seen.
    pub samples: u64,
}

impl Stats {
    /// Empty sums for colour plane `c`'s shape.
    pub fn new(c: usize) -> Self {
        Self::new_k(shape(c).len())
    }

    /// Empty sums for `k` regressors.
    fn new_k(k: usize) -> Self {
        Stats {
            k,
            a: vec![0.0; k * k],
            b: vec![0.0; k],
            error: 0.0,
            samples: 0,
        }
    }

    /// Adds `other`'s sums.
    pub fn add(&mut self, other: &Stats) {
        for (x, y) in self.a.iter_mut().zip(&other.a) {
            *x += y;
        }
        for (x, y) in self.b.iter_mut().zip(&other.b) {
            *x += y;
        }
        self.error += other.error;
        self.samples += other.samples;
    }

    /// `A` with its lower triangle filled.
    fn matrix(&self) -> DMatrix<f64> {
        let k = self.k;
        DMatrix::from_fn(k, k, |i, j| self.a[i.min(j) * k + i.max(j)])
    }

    /// How much the taps `taps` lower the squared error over the pixels seen.
    pub fn gain(&self, taps: &[i32]) -> f64 {
        let s = (1u32 << TAP_LOG2) as f64;
        let w: Vec<f64> = taps.iter().map(|&t| t as f64 / s).collect();
        let k = self.k;
        let mut quad = 0.0;
        for i in 0..k {
            quad += self.a[i * k + i] * w[i] * w[i];
            for j in i + 1..k {
                quad += 2.0 * self.a[i * k + j] * w[i] * w[j];
            }
        }
        let lin: f64 = w.iter().zip(&self.b).map(|(w, b)| w * b).sum();
        2.0 * lin - quad
    }
}

/// One plane's normal equations per pixel class.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassStats {
    /// Per class, in [`classify_rows`](caoen_decoder::restoration::classify_rows)'s numbering.
    pub classes: Vec<Stats>,
}

impl ClassStats {
    /// Empty sums for colour plane `c`'s shape.
    pub fn new(c: usize) -> Self {
        ClassStats {
            classes: (0..CLASSES).map(|_| Stats::new(c)).collect(),
        }
    }

    /// Adds `other`'s sums.
    pub fn add(&mut self, other: &ClassStats) {
        for (a, b) in self.classes.iter_mut().zip(&other.classes) {
            a.add(b);
        }
    }

    /// The sums over every class.
    pub fn total(&self) -> Stats {
        self.sum_of(0..CLASSES)
    }

    /// The sums over the classes `classes`, added in their order.
    pub fn sum_of(&self, classes: impl IntoIterator<Item = usize>) -> Stats {
        let mut t = Stats::new_k(self.classes[0].k);
        for c in classes {
            t.add(&self.classes[c]);
        }
        t
    }

    /// Adds rows `rows` of colour plane `c`: `decoded` is the whole decoded plane
    /// (`w x h`, the coded size), `classes` the class of each pixel of the rows
    /// ([`classify_rows`](caoen_decoder::restoration::classify_rows) of the decoded luma) and `source` the source's rows `rows` of
    /// the same plane.
    pub fn accumulate(
        &mut self,
        c: usize,
        decoded: &[f32],
        classes: &[u8],
        source: &[f64],
        size: (usize, usize),
        rows: std::ops::Range<usize>,
    ) {
        if c == 0 {
            self.accumulate_k::<12>(&LUMA_SHAPE, decoded, classes, source, size, rows);
        } else {
            self.accumulate_k::<6>(&CHROMA_SHAPE, decoded, classes, source, size, rows);
        }
    }

    /// [`ClassStats::accumulate`] for a shape of `K` offsets, a row at a time: the
    /// row's regressors first, then each pixel's products into its class's sums.
    fn accumulate_k<const K: usize>(
        &mut self,
        shape: &[(i32, i32); K],
        decoded: &[f32],
        classes: &[u8],
        source: &[f64],
        (w, h): (usize, usize),
        rows: std::ops::Range<usize>,
    ) {
        let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
        let mut r = vec![[0.0f64; K]; w];
        for (j, y) in rows.clone().enumerate() {
            let src = &source[(y - rows.start) * w..][..w];
            let centre = &decoded[y * w..][..w];
            for (k, &(dx, dy)) in shape.iter().enumerate() {
                let down = &decoded[clamp(y as isize + dy as isize, h) * w..][..w];
                let up = &decoded[clamp(y as isize - dy as isize, h) * w..][..w];
                let term = |a: f32, b: f32, c: f32| a as f64 + b as f64 - 2.0 * c as f64;
                // Columns `lo..hi` have both neighbours inside the row; the others clamp.
                let d = dx.unsigned_abs() as usize;
                let (lo, hi) = (d.min(w), w.saturating_sub(d).max(d.min(w)));
                if hi > lo {
                    let (a, b) = if dx >= 0 {
                        (&down[2 * d..], up)
                    } else {
                        (down, &up[2 * d..])
                    };
                    for (i, x) in (lo..hi).enumerate() {
                        r[x][k] = term(a[i], b[i], centre[x]);
                    }
                }
                for x in (0..lo).chain(hi..w) {
                    r[x][k] = term(
                        down[clamp(x as isize + dx as isize, w)],
                        up[clamp(x as isize - dx as isize, w)],
                        centre[x],
                    );
                }
            }
            for x in 0..w {
                let s = &mut self.classes[classes[j * w + x] as usize];
                let e = src[x] - centre[x] as f64;
                let rx = &r[x];
                s.error += e * e;
                s.samples += 1;
                for i in 0..K {
                    s.b[i] += rx[i] * e;
                    let row = &mut s.a[i * K..(i + 1) * K];
                    for jj in i..K {
                        row[jj] += rx[i] * rx[jj];
                    }
                }
            }
        }
    }
}

/// The ridge added to the normal equations' diagonal, relative to its mean.
const RIDGE: f64 = 1e-4;

/// The taps that lower `-gain * scale + bit_cost * bits` most: least squares,
/// quantised, then each tap moved a unit either way while that lowers it (`scale`
/// takes the pixels seen to the whole plane; `bit_cost` is in squared error per bit).
/// With that cost, or `None` where the equations have no solution.
fn fit_taps(stats: &Stats, scale: f64, bit_cost: f64) -> Option<(Vec<i32>, f64)> {
    if stats.samples == 0 {
        return None;
    }
    let k = stats.k;
    let mut a = stats.matrix();
    // A little ridge keeps flat planes (A near singular) from taps that fit noise.
    let ridge = RIDGE * a.trace() / k as f64 + 1e-12;
    for i in 0..k {
        a[(i, i)] += ridge;
    }
    let w = a.cholesky()?.solve(&DVector::from_column_slice(&stats.b));
    let s = (1u32 << TAP_LOG2) as f64;
    let mut taps: Vec<i32> = w
        .iter()
        .map(|&v| (v * s).round().clamp(-MAX_TAP as f64, MAX_TAP as f64) as i32)
        .collect();
    let cost = |t: &[i32]| {
        -stats.gain(t) * scale + bit_cost * t.iter().map(|&v| tap_bits(v) as f64).sum::<f64>()
    };
    let mut best = cost(&taps);
    for _ in 0..2 {
        let mut moved = false;
        for i in 0..k {
            for m in [-1, 1] {
                let mut trial = taps.clone();
                trial[i] = (trial[i] + m).clamp(-MAX_TAP, MAX_TAP);
                let c = cost(&trial);
                if c < best {
                    (best, taps) = (c, trial);
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
    }
    // Taps at the end of their range are a fit to noise on a plane with next to no
    // texture.
    taps.iter()
        .all(|t| t.abs() < MAX_TAP)
        .then_some((taps, best))
}

/// The plane's taps, if any pay: `fit_taps`, kept when the best taps gain more than
/// their bits and the plane's bit in the section's mask cost.
pub fn fit(stats: &Stats, scale: f64, bit_cost: f64) -> Option<Vec<i32>> {
    fit_taps(stats, scale, bit_cost)
        .and_then(|(taps, cost)| (cost + bit_cost < 0.0).then_some(taps))
}

/// A plane's best filters and what they are worth, `gain * scale` less their bits at
/// `bit_cost` (the plane's mask bit too): one filter for the whole plane, or the
/// classes merged greedily, the pair whose merge costs least at each step, into the
/// grouping that pays best. A filter is kept only if it lowers the error in both
/// `halves` of the pixels seen, so it follows the picture rather than the sums' noise.
/// `None` when nothing pays.
pub fn fit_plane(
    stats: &ClassStats,
    halves: [&ClassStats; 2],
    scale: f64,
    bit_cost: f64,
) -> Option<(PlaneFilter, f64)> {
    let holds = |classes: &[usize], taps: &[i32]| {
        halves.iter().all(|h| {
            let t = h.sum_of(classes.iter().copied());
            t.samples == 0 || t.gain(taps) > 0.0
        })
    };
    let worth = |f: &PlaneFilter, classes: &[Vec<usize>]| -> f64 {
        let gain: f64 = f
            .filters
            .iter()
            .zip(classes)
            .map(|(taps, cs)| stats.sum_of(cs.iter().copied()).gain(taps))
            .sum();
        gain * scale - bit_cost * (plane_bits(f) + 1) as f64
    };
    let all: Vec<usize> = (0..CLASSES).collect();
    let single = fit(&stats.total(), scale, bit_cost)
        .filter(|taps| holds(&all, taps))
        .map(|taps| {
            let f = PlaneFilter::single(taps);
            let w = worth(&f, std::slice::from_ref(&all));
            (f, w)
        });
    // Groups of classes with their sums and the cost of their best filter (0 where no
    // filter pays: the group goes unfiltered).
    struct Group {
        classes: Vec<usize>,
        stats: Stats,
        cost: f64,
    }
    let cost_of = |s: &Stats| fit_taps(s, scale, bit_cost).map_or(0.0, |(_, c)| c.min(0.0));
    let mut groups: Vec<Group> = (0..CLASSES)
        .filter(|&c| stats.classes[c].samples > 0)
        .map(|c| Group {
            classes: vec![c],
            stats: stats.classes[c].clone(),
            cost: cost_of(&stats.classes[c]),
        })
        .collect();
    let merged = |a: &Group, b: &Group| {
        let mut s = a.stats.clone();
        s.add(&b.stats);
        let c = cost_of(&s);
        (s, c)
    };
    // The cost of merging each pair, kept until either group changes.
    let mut pair: Vec<Vec<Option<(Stats, f64)>>> = (0..groups.len())
        .map(|i| {
            (0..groups.len())
                .map(|j| (j > i).then(|| merged(&groups[i], &groups[j])))
                .collect()
        })
        .collect();
    let total = |groups: &[Group]| {
        let on = groups.iter().filter(|g| g.cost < 0.0).count();
        (on > 0 && on <= MAX_FILTERS).then(|| {
            groups.iter().map(|g| g.cost).sum::<f64>() + bit_cost * classified_bits(on) as f64
        })
    };
    let mut best: Option<(f64, Vec<Vec<usize>>)> = None;
    loop {
        if let Some(t) = total(&groups) {
            if best.as_ref().is_none_or(|(b, _)| t < *b) {
                best = Some((
                    t,
                    groups
                        .iter()
                        .filter(|g| g.cost < 0.0)
                        .map(|g| g.classes.clone())
                        .collect(),
                ));
            }
        }
        if groups.len() < 2 {
            break;
        }
        let (mut bi, mut bj, mut bd) = (0, 1, f64::INFINITY);
        for i in 0..groups.len() {
            for j in i + 1..groups.len() {
                let d = pair[i][j].as_ref().expect("pairs are kept").1
                    - groups[i].cost
                    - groups[j].cost;
                if d < bd {
                    (bi, bj, bd) = (i, j, d);
                }
            }
        }
        let (s, c) = pair[bi][bj].take().expect("pairs are kept");
        let b = groups.remove(bj);
        pair.remove(bj);
        for row in pair.iter_mut() {
            row.remove(bj);
        }
        let a = &mut groups[bi];
        a.classes.extend(b.classes);
        a.classes.sort_unstable();
        (a.stats, a.cost) = (s, c);
        for j in 0..groups.len() {
            if j != bi {
                let (lo, hi) = (bi.min(j), bi.max(j));
                pair[lo][hi] = Some(merged(&groups[lo], &groups[hi]));
            }
        }
    }
    let classified = best.and_then(|(_, groups)| {
        let mut filters = Vec::new();
        let mut kept = Vec::new();
        let mut map = [0u8; CLASSES];
        for g in groups {
            let Some((taps, cost)) = fit_taps(&stats.sum_of(g.iter().copied()), scale, bit_cost)
            else {
                continue;
            };
            if cost >= 0.0 || !holds(&g, &taps) {
                continue;
            }
            filters.push(taps);
            for &c in &g {
                map[c] = filters.len() as u8;
            }
            kept.push(g);
        }
        (!filters.is_empty()).then(|| {
            let f = PlaneFilter {
                filters,
                classes: Some(map),
            };
            let w = worth(&f, &kept);
            (f, w)
        })
    });
    [single, classified]
        .into_iter()
        .flatten()
        .filter(|(_, w)| *w > 0.0)
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_base::rng::Lcg;
    use caoen_decoder::restoration::{classify_rows, Restoration};

    fn noise(n: usize, rng: &mut Lcg) -> Vec<f64> {
        rng.noise(n).into_iter().map(f64::from).collect()
    }

    /// Plane `c`'s class sums over the whole of `decoded` against `source`.
    fn stats_of(c: usize, decoded: &[f32], source: &[f64], (w, h): (usize, usize)) -> ClassStats {
        let mut stats = ClassStats::new(c);
        let classes = classify_rows(decoded, (w, h), (1.0, 1.0), 0..h);
        stats.accumulate(c, decoded, &classes, source, (w, h), 0..h);
        stats
    }

    /// A smooth picture with noise added: the filter that smooths it back must lower
    /// the error by what the sums predict.
    #[test]
    fn the_fitted_filter_lowers_the_error_by_its_predicted_gain() {
        let (w, h) = (64, 48);
        let mut seed = Lcg::new(3);
        let source: Vec<f64> = (0..w * h)
            .map(|i| ((i % w) as f64 * 0.2).sin() * 0.3 + ((i / w) as f64 * 0.15).cos() * 0.2)
            .collect();
        let decoded: Vec<f32> = source
            .iter()
            .zip(noise(w * h, &mut seed))
            .map(|(s, n)| (s + 0.05 * n) as f32)
            .collect();
        for c in [0, 1] {
            let classes = stats_of(c, &decoded, &source, (w, h));
            let stats = classes.total();
            let taps = fit(&stats, 1.0, 1e-6).expect("smoothing noise pays");
            let err = |p: &[f32]| {
                p.iter()
                    .zip(&source)
                    .map(|(&d, s)| (d as f64 - s).powi(2))
                    .sum::<f64>()
            };
            let before = err(&decoded);
            let mut planes = vec![decoded.clone()];
            let r = Restoration {
                planes: vec![Some(PlaneFilter::single(taps.clone()))],
                colour: None,
                last: None,
            };
            // Plane 0 takes the luma shape; chroma's is checked through plane 1.
            let after = if c == 0 {
                r.apply(&mut planes, (w, h), (1.0, 1.0));
                err(&planes[0])
            } else {
                let mut two = vec![decoded.clone(), decoded.clone()];
                Restoration {
                    planes: vec![None, Some(PlaneFilter::single(taps.clone()))],
                    colour: None,
                    last: None,
                }
                .apply(&mut two, (w, h), (1.0, 1.0));
                err(&two[1])
            };
            assert!(after < 0.8 * before, "plane {c}: {before} -> {after}");
            let predicted = stats.gain(&taps);
            assert!(
                (before - after - predicted).abs() < 1e-3 * before,
                "{} vs {predicted}",
                before - after
            );
        }
    }

    #[test]
    fn the_sums_are_those_of_the_definition_on_planes_of_every_shape() {
        let mut seed = Lcg::new(17);
        for &(w, h) in &[(1, 1), (1, 6), (2, 5), (5, 2), (6, 7), (9, 4), (23, 11)] {
            let decoded: Vec<f32> = noise(w * h, &mut seed).iter().map(|&v| v as f32).collect();
            let source = noise(w * h, &mut seed);
            for c in [0, 1] {
                let classes = stats_of(c, &decoded, &source, (w, h));
                let get = |x: isize, y: isize| {
                    decoded[y.clamp(0, h as isize - 1) as usize * w
                        + x.clamp(0, w as isize - 1) as usize] as f64
                };
                let k = shape(c).len();
                let class = classify_rows(&decoded, (w, h), (1.0, 1.0), 0..h);
                // Each class's sums, then every pixel's.
                for (n, stats) in classes
                    .classes
                    .iter()
                    .chain(std::iter::once(&classes.total()))
                    .enumerate()
                {
                    let (mut a, mut b, mut count) = (vec![0.0; k * k], vec![0.0; k], 0);
                    for y in 0..h as isize {
                        for x in 0..w as isize {
                            if n < CLASSES && class[y as usize * w + x as usize] as usize != n {
                                continue;
                            }
                            count += 1;
                            let f = get(x, y);
                            let r: Vec<f64> = shape(c)
                                .iter()
                                .map(|&(dx, dy)| {
                                    get(x + dx as isize, y + dy as isize)
                                        + get(x - dx as isize, y - dy as isize)
                                        - 2.0 * f
                                })
                                .collect();
                            let e = source[y as usize * w + x as usize] - f;
                            for i in 0..k {
                                b[i] += r[i] * e;
                                for j in i..k {
                                    a[i * k + j] += r[i] * r[j];
                                }
                            }
                        }
                    }
                    for (x, y) in stats.a.iter().zip(&a).chain(stats.b.iter().zip(&b)) {
                        assert!(
                            (x - y).abs() <= 1e-9 * (1.0 + y.abs()),
                            "{w}x{h} plane {c} class {n}: {x} vs {y}"
                        );
                    }
                    assert_eq!(stats.samples, count);
                }
                assert_eq!(classes.total().samples, (w * h) as u64);
            }
        }
    }

    #[test]
    fn exact_pictures_and_dear_bits_get_no_filter() {
        let (w, h) = (16, 16);
        let source: Vec<f64> = (0..w * h).map(|i| (i % 7) as f64 * 0.1).collect();
        let decoded: Vec<f32> = source.iter().map(|&v| v as f32).collect();
        let stats = stats_of(0, &decoded, &source, (w, h));
        assert_eq!(fit(&stats.total(), 1.0, 1e-9), None);
        assert_eq!(fit_plane(&stats, [&stats, &stats], 1.0, 1e-9), None);
        let mut seed = Lcg::new(5);
        let noisy: Vec<f32> = source
            .iter()
            .zip(noise(w * h, &mut seed))
            .map(|(s, n)| (s + 0.01 * n) as f32)
            .collect();
        let stats = stats_of(0, &noisy, &source, (w, h));
        assert_eq!(fit(&stats.total(), 1.0, 1e3), None);
        assert_eq!(fit_plane(&stats, [&stats, &stats], 1.0, 1e3), None);
    }

    /// Noise on a smooth left half wants smoothing; a blurred sharp right half wants
    /// sharpening. One filter cannot do both, the classes can: the classified filters
    /// are chosen, and lower the error by what the sums predict.
    #[test]
    fn classes_that_want_different_filters_get_them() {
        let (w, h) = (96, 64);
        let mut seed = Lcg::new(9);
        let n = noise(w * h, &mut seed);
        let mut source = vec![0.0; w * h];
        let mut decoded = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if x < w / 2 {
                    source[i] = 0.4 + 0.1 * (x as f64 * 0.05).sin();
                    decoded[i] = (source[i] + 0.02 * n[i]) as f32;
                } else {
                    source[i] = 0.5 + 0.3 * n[i];
                }
            }
        }
        // The right half blurred: each pixel the mean of its row neighbours.
        for y in 0..h {
            for x in w / 2..w {
                let at = |x: usize| source[y * w + x.clamp(w / 2, w - 1)];
                decoded[y * w + x] = (0.25 * at(x - 1) + 0.5 * at(x) + 0.25 * at(x + 1)) as f32;
            }
        }
        let stats = stats_of(0, &decoded, &source, (w, h));
        let (f, worth) = fit_plane(&stats, [&stats, &stats], 1.0, 1e-7).expect("filters pay");
        assert!(f.classes.is_some() && f.filters.len() >= 2, "{f:?}");
        let single = fit(&stats.total(), 1.0, 1e-7).expect("one filter pays too");
        assert!(
            worth > stats.total().gain(&single),
            "{worth} vs one filter's {}",
            stats.total().gain(&single)
        );
        let err = |p: &[f32]| {
            p.iter()
                .zip(&source)
                .map(|(&d, s)| (d as f64 - s).powi(2))
                .sum::<f64>()
        };
        let mut planes = vec![decoded.clone()];
        Restoration {
            planes: vec![Some(f.clone())],
            colour: None,
            last: None,
        }
        .apply(&mut planes, (w, h), (1.0, 1.0));
        let gain = err(&decoded) - err(&planes[0]);
        let bits = 1e-7 * (plane_bits(&f) + 1) as f64;
        assert!(
            (gain - bits - worth).abs() < 1e-3 * gain,
            "{gain} - {bits} vs {worth}"
        );
    }
}
