//! The orthonormal 8x8 DCT-II of the detail layer, and its cosine series as a function
//! defined everywhere in a block.
//!
//! Block coefficients `C[v][u]` (row `v`, column `u`) stand for the continuous function
//! `r(x, y) = sum_v sum_u C[v][u] b_v(y) b_u(x)` over the block, with `x, y` in pixels
//! from the block's top-left corner and `b_u(t) = a_u cos(pi u t / 8)`, `a_0 = sqrt(1/8)`,
//! `a_u = 1/2` otherwise. At pixel centres (`t = i + 0.5`) this is exactly the inverse
//! DCT-II; between them it interpolates, which is what lets a resized or warped decode
//! sample the detail layer at any position. The transform is orthonormal, so squared
//! errors are the same on coefficients and on pixels.

/// Block side in pixels.
pub const N: usize = 8;
/// Coefficients per block.
pub const COEFFS: usize = N * N;

/// Zig-zag scan: the `k`-th coded coefficient is `ZIGZAG[k]` in row-major order. Scan
/// position grows with the anti-diagonal `u + v`, so the higher-frequency neighbours
/// `(v, u+1)` and `(v+1, u)` of a coefficient come later in the scan.
pub const ZIGZAG: [u8; COEFFS] = {
    let mut z = [0u8; COEFFS];
    let mut k = 0;
    let mut d = 0;
    while d < 2 * N - 1 {
        // Even diagonals run up and to the right (row falls), odd ones down and left.
        let mut i = 0;
        while i <= d {
            let (v, u) = if d % 2 == 0 { (d - i, i) } else { (i, d - i) };
            if v < N && u < N {
                z[k] = (v * N + u) as u8;
                k += 1;
            }
            i += 1;
        }
        d += 1;
    }
    z
};

/// The cosine basis `b_u(t)` for `u = 0..8` at position `t` (pixels from the block's
/// left or top edge).
#[inline]
pub fn basis_at(t: f64) -> [f32; N] {
    let mut b = [0f32; N];
    let w = std::f64::consts::PI * t / N as f64;
    for (u, o) in b.iter_mut().enumerate() {
        let a = if u == 0 { (1.0 / N as f64).sqrt() } else { 0.5 };
        *o = (a * (u as f64 * w).cos()) as f32;
    }
    b
}

/// The basis at the eight pixel centres: `TABLE[i][u] = b_u(i + 0.5)`.
fn table() -> [[f64; N]; N] {
    let mut t = [[0.0; N]; N];
    for (i, row) in t.iter_mut().enumerate() {
        let w = std::f64::consts::PI * (i as f64 + 0.5) / N as f64;
        for (u, o) in row.iter_mut().enumerate() {
            let a = if u == 0 { (1.0 / N as f64).sqrt() } else { 0.5 };
            *o = a * (u as f64 * w).cos();
        }
    }
    t
}

/// Forward transform of a row-major block of samples into row-major coefficients.
pub fn forward(block: &[f64; COEFFS]) -> [f64; COEFFS] {
    let t = table();
    let mut rows = [0.0; COEFFS];
    for y in 0..N {
        for u in 0..N {
            rows[y * N + u] = (0..N).map(|x| block[y * N + x] * t[x][u]).sum();
        }
    }
    let mut out = [0.0; COEFFS];
    for v in 0..N {
        for u in 0..N {
            out[v * N + u] = (0..N).map(|y| rows[y * N + u] * t[y][v]).sum();
        }
    }
    out
}

/// Inverse transform at the pixel centres (the reference for the evaluator's sums).
pub fn inverse(coeffs: &[f64; COEFFS]) -> [f64; COEFFS] {
    let t = table();
    let mut cols = [0.0; COEFFS];
    for y in 0..N {
        for u in 0..N {
            cols[y * N + u] = (0..N).map(|v| coeffs[v * N + u] * t[y][v]).sum();
        }
    }
    let mut out = [0.0; COEFFS];
    for y in 0..N {
        for x in 0..N {
            out[y * N + x] = (0..N).map(|u| cols[y * N + u] * t[x][u]).sum();
        }
    }
    out
}

/// The orthonormal `n`-point DCT-II basis at the `n` pixel centres:
/// `T[i][u] = a_u cos(pi u (i + 0.5) / n)`, `a_0 = sqrt(1/n)`, `a_u = sqrt(2/n)`.
fn table_n(n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| {
            let w = std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
            (0..n)
                .map(|u| {
                    let a = if u == 0 {
                        (1.0 / n as f64).sqrt()
                    } else {
                        (2.0 / n as f64).sqrt()
                    };
                    a * (u as f64 * w).cos()
                })
                .collect()
        })
        .collect()
}

/// The tables of the 16- and 32-point transforms.
fn group_tables() -> &'static [Vec<Vec<f64>>; 2] {
    static TABLES: std::sync::OnceLock<[Vec<Vec<f64>>; 2]> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| std::array::from_fn(|k| table_n(N << (k + 1))))
}

/// Forward transform of a merged group of level `g` (`8 2^g` pixels square, its
/// samples row-major): the lowest 8x8 coefficients (row-major, as one block's) and the
/// energy of the rest (the samples' energy less theirs: the transform is orthonormal).
pub fn forward_group(group: &[f64], g: usize) -> ([f64; COEFFS], f64) {
    let n = N << g;
    debug_assert_eq!(group.len(), n * n);
    let t = &group_tables()[g - 1];
    // Only the lowest eight frequencies along x, then along y. Each sum runs in the
    // samples' order from -0.0, as `Iterator::sum` does, with the eight frequencies
    // side by side so that they vectorise.
    let mut rows = vec![[0.0; N]; n];
    for (y, out) in rows.iter_mut().enumerate() {
        let samples = &group[y * n..y * n + n];
        let mut acc = [-0.0; N];
        for (&s, basis) in samples.iter().zip(t) {
            for (a, &b) in acc.iter_mut().zip(&basis[..N]) {
                *a += s * b;
            }
        }
        *out = acc;
    }
    let mut low = [-0.0; COEFFS];
    for (row, basis) in rows.iter().zip(t) {
        for v in 0..N {
            for (a, &r) in low[v * N..v * N + N].iter_mut().zip(row) {
                *a += r * basis[v];
            }
        }
    }
    let energy: f64 = group.iter().map(|s| s * s).sum();
    let kept: f64 = low.iter().map(|c| c * c).sum();
    (low, (energy - kept).max(0.0))
}

/// The maps from a level-`g` group's coefficients to its parts' 8-point ones:
/// `PARTS[g - 1][h][k][u] = sum_i b_k(i + 0.5) B_u(8 h + i + 0.5)` (`b` the 8-point
/// basis, `B` the group's `8 2^g`-point one, `h` the part along the axis), the 8-point
/// DCT-II of a group basis function's samples in part `h`.
type PartMaps = Vec<[[f64; N]; N]>;

fn parts(g: usize) -> &'static PartMaps {
    static PARTS: std::sync::OnceLock<[PartMaps; 2]> = std::sync::OnceLock::new();
    &PARTS.get_or_init(|| {
        let t8 = table();
        std::array::from_fn(|k| {
            let n = N << (k + 1);
            let tn = &group_tables()[k];
            (0..n / N)
                .map(|h| {
                    std::array::from_fn(|k| {
                        std::array::from_fn(|u| (0..N).map(|i| t8[i][k] * tn[N * h + i][u]).sum())
                    })
                })
                .collect()
        })
    })[g - 1]
}

/// The 8x8 coefficients of part `(px, py)` (in blocks) of a level-`g` merged group
/// whose lowest 8x8 coefficients are `c` (row-major): the 8x8 DCT-II of the group's
/// inverse at the part's pixel centres, `H_py C H_px^T`.
pub fn part(c: &[f64; COEFFS], g: usize, px: usize, py: usize) -> [f64; COEFFS] {
    let maps = parts(g);
    let (hx, hy) = (&maps[px], &maps[py]);
    // Along x first: rows[v][k] = sum_u c[v][u] hx[k][u].
    let mut rows = [0.0; COEFFS];
    for v in 0..N {
        if c[v * N..v * N + N].iter().all(|&x| x == 0.0) {
            continue;
        }
        for k in 0..N {
            rows[v * N + k] = (0..N).map(|u| c[v * N + u] * hx[k][u]).sum();
        }
    }
    let mut out = [0.0; COEFFS];
    for j in 0..N {
        for k in 0..N {
            out[j * N + k] = (0..N).map(|v| hy[j][v] * rows[v * N + k]).sum();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zigzag_is_a_permutation_ordered_by_diagonal() {
        let mut seen = [false; COEFFS];
        let mut last_diag = 0;
        for &z in &ZIGZAG {
            assert!(!seen[z as usize]);
            seen[z as usize] = true;
            let d = z as usize / N + z as usize % N;
            assert!(d >= last_diag);
            last_diag = d;
        }
        assert_eq!(&ZIGZAG[..6], &[0, 1, 8, 16, 9, 2]);
    }

    #[test]
    fn round_trip_and_parseval() {
        let mut block = [0.0; COEFFS];
        for (i, v) in block.iter_mut().enumerate() {
            *v = ((i * 37 % 11) as f64 - 5.0) * 0.1;
        }
        let c = forward(&block);
        let back = inverse(&c);
        for i in 0..COEFFS {
            assert!((back[i] - block[i]).abs() < 1e-12);
        }
        let e1: f64 = block.iter().map(|v| v * v).sum();
        let e2: f64 = c.iter().map(|v| v * v).sum();
        assert!((e1 - e2).abs() < 1e-12);
    }

    #[test]
    fn a_constant_block_is_its_dc_alone() {
        let c = forward(&[0.25; COEFFS]);
        assert!((c[0] - 0.25 * 8.0).abs() < 1e-12);
        assert!(c[1..].iter().all(|v| v.abs() < 1e-12));
    }

    /// The group transform's sums, written as the definition's sums over the samples,
    /// bit for bit: the encoder's choices must not depend on how they vectorise.
    #[test]
    fn the_group_transform_equals_its_definition_bit_for_bit() {
        let mut rng = caoen_base::rng::Lcg::new(5);
        for g in 1..=2 {
            let n = N << g;
            let t = &group_tables()[g - 1];
            let group: Vec<f64> = (0..n * n).map(|_| rng.unit() - 0.5).collect();
            let rows: Vec<f64> = (0..n * N)
                .map(|i| (0..n).map(|x| group[(i / N) * n + x] * t[x][i % N]).sum())
                .collect();
            let want: Vec<f64> = (0..COEFFS)
                .map(|i| (0..n).map(|y| rows[y * N + i % N] * t[y][i / N]).sum())
                .collect();
            let (low, _) = forward_group(&group, g);
            assert!(
                low.iter()
                    .zip(&want)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "level {g}"
            );
        }
    }

    #[test]
    fn a_merged_group_s_parts_hold_its_inverse_at_their_pixel_centres() {
        for g in 1..=2 {
            let n = N << g;
            let group: Vec<f64> = (0..n * n)
                .map(|i| {
                    let (x, y) = ((i % n) as f64, (i / n) as f64);
                    (0.3 * x * 16.0 / n as f64).sin() + 0.05 * x * y * 256.0 / (n * n) as f64
                        - 0.2 * (0.5 * y).cos()
                })
                .collect();
            let (low, high) = forward_group(&group, g);
            // Parseval: the low coefficients and the rest hold the group's energy.
            let energy: f64 = group.iter().map(|v| v * v).sum();
            let kept: f64 = low.iter().map(|v| v * v).sum();
            assert!((energy - kept - high).abs() < 1e-9 * energy);
            assert!(
                high < 0.05 * energy,
                "a smooth group is mostly its lowest frequencies ({g})"
            );
            // The group's inverse from the low coefficients, by the basis's definition.
            let basis = |u: usize, t: f64| {
                let a = if u == 0 {
                    (1.0 / n as f64).sqrt()
                } else {
                    (2.0 / n as f64).sqrt()
                };
                a * (std::f64::consts::PI * u as f64 * t / n as f64).cos()
            };
            let inverse_group = |x: usize, y: usize| -> f64 {
                (0..COEFFS)
                    .map(|z| low[z] * basis(z / N, y as f64 + 0.5) * basis(z % N, x as f64 + 0.5))
                    .sum()
            };
            for py in 0..1 << g {
                for px in 0..1 << g {
                    let pixels = inverse(&part(&low, g, px, py));
                    for y in 0..N {
                        for x in 0..N {
                            let expected = inverse_group(N * px + x, N * py + y);
                            assert!(
                                (pixels[y * N + x] - expected).abs() < 1e-12,
                                "{g}: ({px}, {py}) at ({x}, {y})"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_continuous_basis_meets_the_transform_at_pixel_centres() {
        let t = table();
        for (i, row) in t.iter().enumerate() {
            let b = basis_at(i as f64 + 0.5);
            for (&bu, &tu) in b.iter().zip(row) {
                assert!((bu as f64 - tu).abs() < 1e-6);
            }
        }
    }
}
