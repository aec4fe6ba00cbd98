//! POV-Ray 3.7's solid noise (`Noise`, `DNoise`: the portable implementation, the one
//! its optimised ones are checked against): a lattice noise hashed through a shuffled
//! table of 4096 entries into 267 random coefficients. Bump patterns have to land on
//! the same hills and dents as POV-Ray's, so the tables, the hash and the order of the
//! sums are POV-Ray's, and the default noise generator 2 (range-corrected) is used.

use std::sync::OnceLock;

/// POV-Ray's random coefficients (`RTable`'s even entries; each odd one is half the
/// even one before it).
const R: [f64; 267] = [
    -1.0,
    0.604974,
    -0.937102,
    0.414115,
    0.576226,
    -0.0161593,
    0.432334,
    0.103685,
    0.590539,
    0.0286412,
    0.46981,
    -0.84622,
    -0.0734112,
    -0.304097,
    -0.40206,
    -0.210132,
    -0.919127,
    0.652033,
    -0.83151,
    -0.183948,
    -0.671107,
    0.852476,
    0.043595,
    -0.404532,
    0.75494,
    -0.335653,
    0.618433,
    0.605707,
    0.708583,
    -0.477195,
    0.899474,
    0.490623,
    0.221729,
    -0.400381,
    -0.853727,
    -0.932586,
    0.659113,
    0.961303,
    0.325948,
    -0.750851,
    0.842466,
    0.734401,
    -0.649866,
    0.394491,
    -0.466056,
    -0.434073,
    0.109026,
    0.0847028,
    -0.738857,
    0.241505,
    0.16228,
    -0.71426,
    -0.883665,
    -0.150408,
    -0.90396,
    -0.686549,
    -0.785214,
    0.488548,
    0.0246433,
    0.142473,
    -0.602136,
    0.375845,
    -0.00779736,
    0.498955,
    -0.268147,
    0.856382,
    -0.386007,
    -0.596094,
    -0.867735,
    -0.570977,
    -0.914366,
    0.28896,
    0.672206,
    -0.233783,
    0.94815,
    0.895262,
    0.343252,
    -0.173388,
    -0.767971,
    -0.314748,
    0.824308,
    -0.342092,
    0.721431,
    -0.24004,
    -0.63653,
    0.553277,
    0.376272,
    0.158984,
    -0.452659,
    0.396323,
    -0.420676,
    -0.454154,
    0.122179,
    0.295857,
    0.0664225,
    -0.202075,
    -0.724788,
    0.453513,
    0.224567,
    -0.908812,
    0.176349,
    -0.320516,
    -0.697139,
    0.742702,
    -0.900786,
    0.471489,
    -0.133532,
    0.119127,
    -0.889769,
    -0.23183,
    -0.669673,
    -0.046891,
    -0.803433,
    -0.966735,
    0.475578,
    -0.652644,
    0.0112459,
    -0.730007,
    0.128283,
    0.145647,
    -0.619318,
    0.272023,
    0.392966,
    0.646418,
    -0.0207675,
    -0.315908,
    0.480797,
    0.535668,
    -0.250172,
    -0.83093,
    -0.653773,
    -0.443809,
    0.119982,
    -0.897642,
    0.89453,
    0.165789,
    0.633875,
    -0.886839,
    0.930877,
    -0.537194,
    0.587732,
    0.722011,
    -0.209461,
    -0.0424659,
    -0.814267,
    -0.919432,
    0.280262,
    -0.66302,
    -0.558099,
    -0.537469,
    -0.598779,
    0.929656,
    -0.170794,
    -0.537163,
    0.312581,
    0.959442,
    0.722652,
    0.499931,
    0.175616,
    -0.534874,
    -0.685115,
    0.444999,
    0.17171,
    0.108202,
    -0.768704,
    -0.463828,
    0.254231,
    0.546014,
    0.869474,
    0.875212,
    -0.944427,
    0.130724,
    -0.110185,
    0.312184,
    -0.33138,
    -0.629206,
    0.0606546,
    0.722866,
    -0.0979477,
    0.821561,
    0.0931258,
    -0.972808,
    0.0318151,
    -0.867033,
    -0.387228,
    0.280995,
    -0.218189,
    -0.539178,
    -0.427359,
    -0.602075,
    0.311971,
    0.277974,
    0.773159,
    0.592493,
    -0.0331884,
    -0.630854,
    -0.269947,
    0.339132,
    0.581079,
    0.209461,
    -0.317433,
    -0.284993,
    0.181323,
    0.341634,
    0.804959,
    -0.229572,
    -0.758907,
    -0.336721,
    0.605463,
    -0.991272,
    -0.0188754,
    -0.300191,
    0.368307,
    -0.176135,
    -0.3832,
    -0.749569,
    0.62356,
    -0.573938,
    0.278309,
    -0.971313,
    0.839994,
    -0.830686,
    0.439078,
    0.66128,
    0.694514,
    0.0565042,
    0.54342,
    -0.438804,
    -0.0228428,
    -0.687068,
    0.857267,
    0.301991,
    -0.494255,
    -0.941039,
    0.775509,
    0.410575,
    -0.362081,
    -0.671534,
    -0.348379,
    0.932433,
    0.886442,
    0.868681,
    -0.225666,
    -0.062211,
    -0.0976425,
    -0.641444,
    -0.848112,
    0.724697,
    0.473503,
    0.998749,
    0.174701,
    0.559625,
    -0.029099,
    -0.337392,
    -0.958129,
    -0.659785,
    0.236042,
    -0.246937,
    0.659449,
    -0.027512,
    0.821897,
    -0.226215,
    0.0181735,
    0.500481,
    -0.420127,
    -0.427878,
    0.566186,
];

/// POV-Ray's `EPSILON`, used when flooring negative coordinates.
const EPSILON: f64 = 1.0e-10;
/// POV-Ray's `NOISE_MINX` (and y, z): the lattice offset before masking to 12 bits.
const NOISE_MIN: i64 = -10000;

struct Tables {
    /// `RTable` as POV-Ray fills it: `r[2i] = R[i]`, `r[2i + 1] = R[i] / 2`.
    r: [f64; 534],
    /// `hashTable`: a permutation of 0..4096, repeated.
    hash: [u16; 8192],
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let mut r = [0.0; 534];
        for (i, v) in R.iter().enumerate() {
            r[2 * i] = *v;
            r[2 * i + 1] = *v * 0.5;
        }
        let mut hash = [0u16; 8192];
        for (i, h) in hash.iter_mut().take(4096).enumerate() {
            *h = i as u16;
        }
        // POV-Ray's C `int` arithmetic: the product wraps to 32 bits.
        let mut next: i32 = 0;
        for i in (0..4096).rev() {
            next = (i64::from(next) * 1_812_433_253 + 12_345) as i32;
            let j = ((next >> 16) & 0x7FFF) as usize % 4096;
            hash.swap(i, j);
        }
        for i in 0..4096 {
            hash[4096 + i] = hash[i];
        }
        Tables { r, hash }
    })
}

/// One coordinate's lattice cell (masked to 12 bits) and the offset within it, as
/// POV-Ray's "JB fix" computes them (C's truncating casts; a coordinate beyond an
/// `int` is clamped first, where POV-Ray's cast is undefined).
fn cell(v: f64) -> (usize, f64) {
    let v = v.clamp(-2.0e9, 2.0e9);
    let tmp = if v >= 0.0 {
        v as i64
    } else {
        (v - (1.0 - EPSILON)) as i64
    };
    (((tmp - NOISE_MIN) & 0xFFF) as usize, v - tmp as f64)
}

/// The S-curve `3t^2 - 2t^3`.
fn s_curve(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// The eight corners' shared set-up: hashes, offsets and weights.
struct Corners {
    /// `Hash2d` of (ix, iy), (ix + 1, iy), (ix, iy + 1), (ix + 1, iy + 1).
    h: [usize; 4],
    iz: usize,
    /// Offsets from the lower and upper corners per axis.
    lo: [f64; 3],
    hi: [f64; 3],
    /// The S-curve weights and their complements.
    s: [f64; 3],
    t: [f64; 3],
}

fn corners(p: [f64; 3]) -> Corners {
    let tb = tables();
    let (ix, fx) = cell(p[0]);
    let (iy, fy) = cell(p[1]);
    let (iz, fz) = cell(p[2]);
    let hash2 = |a: usize, b: usize| tb.hash[(tb.hash[a] as usize) ^ b] as usize;
    let s = [s_curve(fx), s_curve(fy), s_curve(fz)];
    Corners {
        h: [
            hash2(ix, iy),
            hash2(ix + 1, iy),
            hash2(ix, iy + 1),
            hash2(ix + 1, iy + 1),
        ],
        iz,
        lo: [fx, fy, fz],
        hi: [fx - 1.0, fy - 1.0, fz - 1.0],
        s,
        t: [1.0 - s[0], 1.0 - s[1], 1.0 - s[2]],
    }
}

/// `Hash1dRTableIndex`: where a corner's coefficients start in `RTable`.
fn rindex(hash: usize, z: usize) -> usize {
    ((tables().hash[hash ^ z] & 0xFF) as usize) * 2
}

/// POV-Ray's `INCRSUMP`: the corner's linear function at offset `(x, y, z)`, weighted.
fn incr(at: usize, s: f64, x: f64, y: f64, z: f64) -> f64 {
    let r = &tables().r;
    s * (r[at + 1] + r[at + 2] * x + r[at + 4] * y + r[at + 6] * z)
}

/// POV-Ray's `Noise` with noise generator 2 (range-corrected), in [0, 1].
pub fn noise(p: [f64; 3]) -> f64 {
    let c = corners(p);
    let ([x0, y0, z0], [x1, y1, z1]) = (c.lo, c.hi);
    let ([sx, sy, sz], [tx, ty, tz]) = (c.s, c.t);
    let (txty, sxty, txsy, sxsy) = (tx * ty, sx * ty, tx * sy, sx * sy);
    let [h00, h10, h01, h11] = c.h;
    let iz = c.iz;
    let mut sum = incr(rindex(h00, iz), txty * tz, x0, y0, z0);
    sum += incr(rindex(h10, iz), sxty * tz, x1, y0, z0);
    sum += incr(rindex(h01, iz), txsy * tz, x0, y1, z0);
    sum += incr(rindex(h11, iz), sxsy * tz, x1, y1, z0);
    sum += incr(rindex(h00, iz + 1), txty * sz, x0, y0, z1);
    sum += incr(rindex(h10, iz + 1), sxty * sz, x1, y0, z1);
    sum += incr(rindex(h01, iz + 1), txsy * sz, x0, y1, z1);
    sum += incr(rindex(h11, iz + 1), sxsy * sz, x1, y1, z1);
    sum += 1.05242;
    sum *= 0.48985582;
    sum.clamp(0.0, 1.0)
}

/// POV-Ray's `DNoise`: a smooth random vector field (each component about [-1, 1]).
pub fn dnoise(p: [f64; 3]) -> [f64; 3] {
    let c = corners(p);
    let ([x0, y0, z0], [x1, y1, z1]) = (c.lo, c.hi);
    let ([sx, sy, sz], [tx, ty, tz]) = (c.s, c.t);
    let (txty, sxty, txsy, sxsy) = (tx * ty, sx * ty, tx * sy, sx * sy);
    let [h00, h10, h01, h11] = c.h;
    let iz = c.iz;
    // POV-Ray's order of the corners, so the sums round as its do.
    let terms = [
        (h00, iz, txty * tz, x0, y0, z0),
        (h10, iz, sxty * tz, x1, y0, z0),
        (h11, iz, sxsy * tz, x1, y1, z0),
        (h01, iz, txsy * tz, x0, y1, z0),
        (h01, iz + 1, txsy * sz, x0, y1, z1),
        (h11, iz + 1, sxsy * sz, x1, y1, z1),
        (h10, iz + 1, sxty * sz, x1, y0, z1),
        (h00, iz + 1, txty * sz, x0, y0, z1),
    ];
    let mut out = [0.0; 3];
    for (h, z, s, x, y, zz) in terms {
        let at = rindex(h, z);
        for (k, o) in out.iter_mut().enumerate() {
            *o += incr(at + 8 * k, s, x, y, zz);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values printed by POV-Ray's portable `Noise` (generator 2) and `DNoise`,
    /// transcribed to C with its tables and compiled: point, noise, dnoise.
    // The digits are C's `%.17g`, kept as printed.
    #[allow(clippy::excessive_precision)]
    const GOLDEN: [([f64; 3], f64, [f64; 3]); 7] = [
        (
            [0.5, 0.25, 0.125],
            0.39718753246498234,
            [
                -0.24159461781921387,
                -0.29977857340240477,
                -0.30524941456298837,
            ],
        ),
        (
            [1.3, -2.7000000000000002, 4.0999999999999996],
            0.44779328813853331,
            [
                -0.13828716773410324,
                0.29061703350762003,
                -0.061013350437683106,
            ],
        ),
        (
            [-0.34999999999999998, 0.80000000000000004, -7.25],
            0.51675831954799067,
            [
                0.002499220002307536,
                0.17183643461889375,
                0.045568932000951586,
            ],
        ),
        (
            [123.456, -78.900000000000006, 0.001],
            0.46838544976348978,
            [
                -0.096249978862985072,
                -0.085132224444966084,
                0.32905526927836259,
            ],
        ),
        (
            [-1000.5, 2000.25, -3000.125],
            0.68913459589021764,
            [
                0.35439108145294196,
                -0.024113469116210977,
                -0.49306166560516362,
            ],
        ),
        (
            [0.0, 0.0, 0.0],
            0.29832243930790991,
            [
                -0.44341950000000002,
                0.36100549999999998,
                -0.45971600000000001,
            ],
        ),
        (
            [2.0, 3.0, -1.0],
            0.46423121712788995,
            [-0.1047305, 0.14013100000000001, -0.29938949999999998],
        ),
    ];

    #[test]
    fn noise_matches_pov_ray() {
        for (p, n, d) in GOLDEN {
            assert!(
                (noise(p) - n).abs() < 1e-12,
                "noise {p:?}: {} vs {n}",
                noise(p)
            );
            let got = dnoise(p);
            for k in 0..3 {
                assert!(
                    (got[k] - d[k]).abs() < 1e-12,
                    "dnoise {p:?}: {got:?} vs {d:?}"
                );
            }
        }
        assert_eq!(tables().hash[..2], [2291, 2574]);
        assert_eq!(tables().hash[4095], 3088);
    }

    #[test]
    fn noise_is_smooth_and_bounded() {
        let (a, b) = (dnoise([0.3, 0.4, 0.5]), dnoise([0.3 + 1e-7, 0.4, 0.5]));
        assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-5));
        for i in 0..1000 {
            let v = noise([i as f64 * 0.37, -(i as f64) * 0.11, 1e9]);
            assert!((0.0..=1.0).contains(&v));
        }
    }
}
