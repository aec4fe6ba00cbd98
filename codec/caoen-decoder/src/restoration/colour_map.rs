//! The colour map: an affine map of the colour planes, applied after the filters.
//!
//! The filters act on differences, so they pass a flat region unchanged and cannot
//! restore what the quantisers take from a plane as a whole: contrast lost to the dead
//! zones, a cast where coarse chroma steps round one way. The map, fitted by least
//! squares over the image, takes colour plane `c` to
//!
//! `g_c = f_c + sum_k m_ck f_k / 2^MATRIX_LOG2 + o_c / 2^OFFSET_LOG2`
//!
//! at every pixel, whatever the decode's size.

/// Precision of the matrix's coefficients: units of `2^-MATRIX_LOG2`.
pub const MATRIX_LOG2: u32 = 9;
/// Precision of the offsets: units of `2^-OFFSET_LOG2` of a plane's range.
pub const OFFSET_LOG2: u32 = 10;
/// Largest coefficient magnitude, matrix and offsets alike.
pub const MAX_COEFFICIENT: i32 = 2047;

/// An affine map of `n` colour planes: per plane its `n` matrix coefficients (the
/// change from the identity) and its offset.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColourMap {
    /// Per colour plane, `n + 1` integers: the row of the matrix's change from the
    /// identity, in units of `2^-MATRIX_LOG2`, then the offset in units of
    /// `2^-OFFSET_LOG2`.
    pub rows: Vec<Vec<i32>>,
}

impl ColourMap {
    /// Colour planes the map takes.
    pub fn planes(&self) -> usize {
        self.rows.len()
    }

    /// Whether every row has one coefficient per plane and the offset, each in range.
    pub fn is_valid(&self) -> bool {
        let n = self.rows.len();
        n > 0
            && self
                .rows
                .iter()
                .all(|r| r.len() == n + 1 && r.iter().all(|v| v.abs() <= MAX_COEFFICIENT))
    }

    /// The coefficients as real numbers, each row `n` matrix terms and the offset.
    pub fn real(&self) -> Vec<Vec<f64>> {
        let n = self.rows.len();
        self.rows
            .iter()
            .map(|r| {
                r.iter()
                    .enumerate()
                    .map(|(k, &v)| {
                        v as f64 / f64::from(1u32 << if k < n { MATRIX_LOG2 } else { OFFSET_LOG2 })
                    })
                    .collect()
            })
            .collect()
    }

    /// Maps the pixels of `planes` (one slice per colour plane, all of one length) in
    /// place.
    pub fn apply(&self, planes: &mut [&mut [f32]]) {
        let n = self.rows.len();
        debug_assert_eq!(planes.len(), n);
        let real: Vec<Vec<f32>> = self
            .real()
            .into_iter()
            .map(|r| r.into_iter().map(|v| v as f32).collect())
            .collect();
        let len = planes.first().map_or(0, |p| p.len());
        let mut x = [0.0f32; 3];
        for i in 0..len {
            for (k, p) in planes.iter().enumerate() {
                x[k] = p[i];
            }
            for (c, (p, r)) in planes.iter_mut().zip(&real).enumerate() {
                let mut v = x[c] + r[n];
                for k in 0..n {
                    v += r[k] * x[k];
                }
                p[i] = v;
            }
        }
    }
}

/// The normal equations of a colour map: each plane's decoded values and a constant
/// against the change the map should make (the source less the decoded value).
#[derive(Debug, Clone, PartialEq)]
pub struct ColourSums {
    /// Colour planes.
    pub n: usize,
    /// `X^T X`, `(n + 1)^2`, `X` the decoded planes and a column of ones.
    pub xx: Vec<f64>,
    /// `X^T D`, `(n + 1) x n` by plane of `D` (source less decoded) in the columns.
    pub xd: Vec<f64>,
    /// Pixels summed.
    pub samples: u64,
}

impl ColourSums {
    /// Empty sums for `n` colour planes.
    pub fn new(n: usize) -> Self {
        ColourSums {
            n,
            xx: vec![0.0; (n + 1) * (n + 1)],
            xd: vec![0.0; (n + 1) * n],
            samples: 0,
        }
    }

    /// Adds the pixels of `decoded` (one slice per colour plane) against `source`
    /// (the same pixels' source values, plane by plane).
    pub fn accumulate(&mut self, decoded: &[&[f32]], source: &[&[f64]]) {
        let n = self.n;
        let m = n + 1;
        let len = decoded.first().map_or(0, |p| p.len());
        let mut x = [1.0f64; 4];
        for i in 0..len {
            for k in 0..n {
                x[k] = f64::from(decoded[k][i]);
            }
            x[n] = 1.0;
            for a in 0..m {
                for b in a..m {
                    self.xx[a * m + b] += x[a] * x[b];
                }
                for c in 0..n {
                    self.xd[a * n + c] += x[a] * (source[c][i] - x[c]);
                }
            }
        }
        self.samples += len as u64;
    }

    /// Adds another set of sums.
    pub fn add(&mut self, other: &ColourSums) {
        for (a, b) in self.xx.iter_mut().zip(&other.xx) {
            *a += b;
        }
        for (a, b) in self.xd.iter_mut().zip(&other.xd) {
            *a += b;
        }
        self.samples += other.samples;
    }

    /// `X^T X` in full (the sums keep its upper triangle).
    fn gram(&self) -> Vec<f64> {
        let m = self.n + 1;
        let mut g = self.xx.clone();
        for a in 0..m {
            for b in 0..a {
                g[a * m + b] = self.xx[b * m + a];
            }
        }
        g
    }

    /// The squared error `map` takes off the summed pixels (negative: it adds error).
    pub fn gain(&self, map: &ColourMap) -> f64 {
        let (n, m) = (self.n, self.n + 1);
        let g = self.gram();
        map.real()
            .iter()
            .enumerate()
            .map(|(c, a)| {
                let linear: f64 = (0..m).map(|k| a[k] * self.xd[k * n + c]).sum();
                let quadratic: f64 = (0..m)
                    .map(|j| (0..m).map(|k| a[j] * g[j * m + k] * a[k]).sum::<f64>())
                    .sum();
                2.0 * linear - quadratic
            })
            .sum()
    }
}

/// Bits of a map's coefficients in the restoration section.
pub fn map_bits(map: &ColourMap) -> u32 {
    map.rows
        .iter()
        .flatten()
        .map(|&v| super::syntax::signed_bits(v, MAP_ORDER))
        .sum()
}

/// Exp-Golomb order of the map's coefficients.
pub const MAP_ORDER: u32 = 0;

/// The colour map for the sums `total` where it pays: least squares (with a small
/// ridge), rounded, each coefficient then moved a unit either way while that lowers
/// `-gain * scale + bit_cost * bits`; kept only if it lowers the error in both
/// `halves` of the sampled rows and its worth (gain times `scale`, less its bits at
/// `bit_cost` each) is positive. Returns the map and its worth.
pub fn fit(
    total: &ColourSums,
    halves: [&ColourSums; 2],
    scale: f64,
    bit_cost: f64,
) -> Option<(ColourMap, f64)> {
    let (n, m) = (total.n, total.n + 1);
    if total.samples == 0 {
        return None;
    }
    let mut g = total.gram();
    let ridge = 1e-6 * (0..m).map(|k| g[k * m + k]).sum::<f64>() / m as f64;
    for k in 0..m {
        g[k * m + k] += ridge;
    }
    let units = |k: usize| f64::from(1u32 << if k < n { MATRIX_LOG2 } else { OFFSET_LOG2 });
    let mut rows = Vec::with_capacity(n);
    for c in 0..n {
        let rhs: Vec<f64> = (0..m).map(|k| total.xd[k * n + c]).collect();
        let a = solve(&g, &rhs, m)?;
        rows.push(
            a.iter()
                .enumerate()
                .map(|(k, v)| {
                    ((v * units(k)).round() as i64)
                        .clamp(-(MAX_COEFFICIENT as i64), MAX_COEFFICIENT as i64)
                        as i32
                })
                .collect::<Vec<i32>>(),
        );
    }
    let mut map = ColourMap { rows };
    let cost = |map: &ColourMap| -total.gain(map) * scale + bit_cost * f64::from(map_bits(map));
    let mut best = cost(&map);
    // Coordinate moves to the nearest better integer: each pass tries every
    // coefficient a unit either way and towards zero.
    for _ in 0..64 {
        let mut moved = false;
        for c in 0..n {
            for k in 0..m {
                let v = map.rows[c][k];
                for t in [v - 1, v + 1, 0] {
                    if t == v || t.abs() > MAX_COEFFICIENT {
                        continue;
                    }
                    map.rows[c][k] = t;
                    let e = cost(&map);
                    if e < best {
                        best = e;
                        moved = true;
                    } else {
                        map.rows[c][k] = v;
                    }
                    if map.rows[c][k] != v {
                        break;
                    }
                }
            }
        }
        if !moved {
            break;
        }
    }
    let worth = -best;
    let helps_both = halves.iter().all(|h| h.gain(&map) > 0.0);
    (worth > 0.0 && helps_both && map.rows.iter().flatten().any(|&v| v != 0))
        .then_some((map, worth))
}

/// Solves the symmetric positive system `a x = b` (`m x m`) by Cholesky.
fn solve(a: &[f64], b: &[f64], m: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..=i {
            let s: f64 = a[i * m + j] - (0..j).map(|k| l[i * m + k] * l[j * m + k]).sum::<f64>();
            if i == j {
                if s <= 0.0 {
                    return None;
                }
                l[i * m + i] = s.sqrt();
            } else {
                l[i * m + j] = s / l[j * m + j];
            }
        }
    }
    let mut y = vec![0.0; m];
    for i in 0..m {
        y[i] = (b[i] - (0..i).map(|k| l[i * m + k] * y[k]).sum::<f64>()) / l[i * m + i];
    }
    let mut x = vec![0.0; m];
    for i in (0..m).rev() {
        x[i] = (y[i] - (i + 1..m).map(|k| l[k * m + i] * x[k]).sum::<f64>()) / l[i * m + i];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three planes of a smooth pseudo-random picture.
    fn picture(len: usize) -> Vec<Vec<f64>> {
        (0..3)
            .map(|c| {
                (0..len)
                    .map(|i| {
                        0.5 + 0.3
                            * ((i as f64 * (0.013 + 0.007 * c as f64)).sin()
                                * (i as f64 * 0.0011).cos())
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_decode_that_lost_contrast_and_took_a_cast_is_mapped_back() {
        let len = 20_000;
        let source = picture(len);
        // The decode: plane 0 at 0.9 of its contrast, plane 2 with a cast from plane 1
        // and an offset, plus a little noise that no map removes.
        let noise = |i: usize| 0.002 * (((i * 7919) % 101) as f64 / 50.0 - 1.0);
        let decoded: Vec<Vec<f32>> = vec![
            (0..len)
                .map(|i| (0.9 * source[0][i] + 0.05 + noise(i)) as f32)
                .collect(),
            (0..len)
                .map(|i| (source[1][i] + noise(i + 3)) as f32)
                .collect(),
            (0..len)
                .map(|i| (source[2][i] + 0.04 * source[1][i] - 0.01 + noise(i + 5)) as f32)
                .collect(),
        ];
        let mut sums = ColourSums::new(3);
        let mut halves = [ColourSums::new(3), ColourSums::new(3)];
        let dec: Vec<&[f32]> = decoded.iter().map(Vec::as_slice).collect();
        let src: Vec<&[f64]> = source.iter().map(Vec::as_slice).collect();
        sums.accumulate(&dec, &src);
        for (h, half) in halves.iter_mut().enumerate() {
            let r = h * len / 2..(h + 1) * len / 2;
            let d: Vec<&[f32]> = dec.iter().map(|p| &p[r.clone()]).collect();
            let s: Vec<&[f64]> = src.iter().map(|p| &p[r.clone()]).collect();
            half.accumulate(&d, &s);
        }
        let error = |planes: &[Vec<f32>]| -> f64 {
            planes
                .iter()
                .zip(&source)
                .map(|(p, s)| {
                    p.iter()
                        .zip(s)
                        .map(|(&a, b)| (f64::from(a) - b).powi(2))
                        .sum::<f64>()
                })
                .sum()
        };
        let before = error(&decoded);
        let (map, worth) = fit(&sums, [&halves[0], &halves[1]], 1.0, 1e-9).expect("the map pays");
        // The inverse of the decode's map, to the coefficients' precision.
        let real = map.real();
        assert!((real[0][0] - (1.0 / 0.9 - 1.0)).abs() < 0.01, "{real:?}");
        assert!((real[2][1] + 0.04).abs() < 0.01, "{real:?}");
        assert!(real[1].iter().all(|v| v.abs() < 0.01), "{real:?}");
        let mut mapped = decoded.clone();
        let mut parts: Vec<&mut [f32]> = mapped.iter_mut().map(Vec::as_mut_slice).collect();
        map.apply(&mut parts);
        let after = error(&mapped);
        // Only the noise is left, and the sums' gain is what applying the map took off.
        assert!(after < 0.05 * before, "{before} -> {after}");
        assert!(
            ((before - after) - sums.gain(&map)).abs() < 1e-3 * before,
            "{} vs {}",
            before - after,
            sums.gain(&map)
        );
        assert!(worth > 0.0);
    }

    #[test]
    fn a_decode_without_a_cast_takes_no_map() {
        let len = 10_000;
        let source = picture(len);
        let noise = |i: usize| 0.01 * (((i * 7919) % 101) as f64 / 50.0 - 1.0);
        let decoded: Vec<Vec<f32>> = (0..3)
            .map(|c| {
                (0..len)
                    .map(|i| (source[c][i] + noise(i + c)) as f32)
                    .collect()
            })
            .collect();
        let mut sums = ColourSums::new(3);
        let dec: Vec<&[f32]> = decoded.iter().map(Vec::as_slice).collect();
        let src: Vec<&[f64]> = source.iter().map(Vec::as_slice).collect();
        sums.accumulate(&dec, &src);
        // At the price of a bit a photograph's curve puts on it, nothing pays.
        let error: f64 = (0..len).map(|i| 3.0 * noise(i).powi(2)).sum();
        let bit_cost = 1.1 * error / (8.0 * 2000.0);
        assert_eq!(fit(&sums, [&sums, &sums], 1.0, bit_cost), None);
    }

    #[test]
    fn one_plane_maps_with_a_gain_and_an_offset() {
        let map = ColourMap {
            rows: vec![vec![-(1 << MATRIX_LOG2) / 2, 1 << (OFFSET_LOG2 - 2)]],
        };
        assert!(map.is_valid());
        let mut plane = vec![0.0f32, 0.5, 1.0];
        map.apply(&mut [plane.as_mut_slice()]);
        assert_eq!(plane, vec![0.25, 0.5, 0.75]);
        assert!(!ColourMap {
            rows: vec![vec![0; 3]]
        }
        .is_valid());
        assert!(!ColourMap {
            rows: vec![vec![MAX_COEFFICIENT + 1, 0]]
        }
        .is_valid());
    }
}
