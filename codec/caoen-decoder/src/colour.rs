//! Colour decorrelation and the HDR transfer curve.
//!
//! RGB goes to one of two opponent spaces ([`ColourBasis`]). Both send grey to the
//! first channel alone, and each channel's unit error is a unit RGB error, so the fit
//! and the split decisions measure RGB error per channel, while most energy lands in
//! the first channel and the chroma channels can be coded coarser. The grey basis is
//! orthonormal (`Y = (R+G+B)/sqrt 3`, `C1 = (R-B)/sqrt 2`, `C2 = (R-2G+B)/sqrt 6`); in the
//! luma basis the first channel weighs the primaries halfway between grey and BT.601
//! luma, and the chroma channels move colours at a constant value of that weighting,
//! so much less of the chroma quantisation lands in luma, which the eye and the
//! structural metrics weigh. Float images are first mapped by `asinh(v / v0)`, linear near 0
//! and logarithmic above, so a uniform quantiser spends bits evenly across a high
//! dynamic range.

use crate::par::*;

use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};

const S3: f64 = 1.732_050_807_568_877_2;
const S2: f64 = std::f64::consts::SQRT_2;
const S6: f64 = 2.449_489_742_783_178;

/// How three colour channels map to coding channels (`docs/format.md`, "Colour").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourBasis {
    /// The orthonormal opponent space whose first axis is grey.
    #[default]
    Grey,
    /// First channel along the luma weights `L = ((0.299, 0.587, 0.114) + (1, 1, 1)/3)/2`
    /// (halfway from grey to BT.601 luma); chroma along directions of constant `L`
    /// (the matrices of `docs/format.md`, "Colour").
    Luma,
}

/// The luma basis, RGB to coding channels: [`LUMA_INVERSE`]'s inverse (first row
/// `sqrt 3 L`; the chroma rows give grey no chroma).
pub const LUMA_FORWARD: [[f64; 3]; 3] = [
    [0.5476167303263599, 0.7970320466162781, 0.3874020306262389],
    [0.7113255265031773, 0.0, -0.7113255265031773],
    [-0.40195366069358995, 0.845533411521981, -0.4435797508283911],
];

/// The luma basis, coding channels to RGB: columns grey `(1, 1, 1)/sqrt 3`, the unit
/// vector `u` along `(1, 0, -1)` minus its part along `L`, and `L/|L| x u` (both
/// chroma columns have zero `L`).
pub const LUMA_INVERSE: [[f64; 3]; 3] = [
    [0.5773502691896258, 0.6538175784015039, -0.5442323867939828],
    [0.5773502691896258, -0.0837002871421824, 0.6384529883468708],
    [0.5773502691896258, -0.7520085345961902, -0.5442323867939828],
];

/// Linear scale below which the HDR curve is linear.
pub const HDR_V0: f64 = 1.0 / 64.0;

/// Image planes in coding space: colour channels (1 or 3) and optional alpha. The
/// encoder works in `f64`; the decoder's fast path produces `f32`.
#[derive(Debug, Clone)]
pub struct CodingPlanes<T = f64> {
    /// Y, or Y, C1, C2.
    pub colour: Vec<Vec<T>>,
    /// Alpha in [0, 1], if present.
    pub alpha: Option<Vec<T>>,
}

fn to_coding(v: f32, format: SampleFormat) -> f64 {
    match format {
        SampleFormat::F32 => (v as f64 / HDR_V0).asinh(),
        _ => v as f64,
    }
}

fn from_coding(v: f64, format: SampleFormat) -> f32 {
    match format {
        // A damaged file can carry values whose sinh overflows: keep samples finite.
        SampleFormat::F32 => (HDR_V0 * v.sinh()).clamp(-(f32::MAX as f64), f32::MAX as f64) as f32,
        _ => v as f32,
    }
}

/// Splits a raster into coding planes in `basis`.
pub fn forward(img: &Raster, basis: ColourBasis) -> CodingPlanes {
    let f = img.format();
    let plane = |c: usize| {
        img.plane(c)
            .iter()
            .map(|&v| to_coding(v, f))
            .collect::<Vec<f64>>()
    };
    let layout = img.layout();
    let colour = if layout.colour_channels() == 3 {
        let (r, g, b) = (plane(0), plane(1), plane(2));
        let mut y = vec![0.0; r.len()];
        let mut c1 = vec![0.0; r.len()];
        let mut c2 = vec![0.0; r.len()];
        match basis {
            ColourBasis::Grey => {
                for i in 0..r.len() {
                    y[i] = (r[i] + g[i] + b[i]) / S3;
                    c1[i] = (r[i] - b[i]) / S2;
                    c2[i] = (r[i] - 2.0 * g[i] + b[i]) / S6;
                }
            }
            ColourBasis::Luma => {
                let m = LUMA_FORWARD;
                for i in 0..r.len() {
                    y[i] = m[0][0] * r[i] + m[0][1] * g[i] + m[0][2] * b[i];
                    c1[i] = m[1][0] * r[i] + m[1][1] * g[i] + m[1][2] * b[i];
                    c2[i] = m[2][0] * r[i] + m[2][1] * g[i] + m[2][2] * b[i];
                }
            }
        }
        vec![y, c1, c2]
    } else {
        vec![plane(0)]
    };
    let alpha = layout.has_alpha().then(|| {
        img.plane(layout.channels() - 1)
            .iter()
            .map(|&v| v as f64)
            .collect()
    });
    CodingPlanes { colour, alpha }
}

/// A coding-plane value: `f64` in the encoder, `f32` from the decoder's fast path.
pub trait CodingValue: Copy + Send + Sync {
    /// The value in double precision.
    fn to_f64(self) -> f64;
    /// The value in single precision.
    fn to_f32(self) -> f32;
}

impl CodingValue for f64 {
    fn to_f64(self) -> f64 {
        self
    }
    fn to_f32(self) -> f32 {
        self as f32
    }
}

impl CodingValue for f32 {
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn to_f32(self) -> f32 {
        self
    }
}

/// Pixels per parallel task of [`inverse`].
const CHUNK: usize = 1 << 14;

/// Converts one span of pixels from coding planes in `basis` to raster samples:
/// `colour` (Y, or Y, C1, C2) and optional `alpha` into `out`, the raster's planes over
/// the same span (colour channels, then alpha). Integer formats are clamped to [0, 1]
/// here, at output, and alpha always; float colour is not.
pub fn inverse_span<T: CodingValue>(
    colour: &[&[T]],
    alpha: Option<&[T]>,
    out: &mut [&mut [f32]],
    format: SampleFormat,
    basis: ColourBasis,
) {
    let nc = colour.len();
    debug_assert_eq!(out.len(), nc + usize::from(alpha.is_some()));
    // Integer formats need only single precision before their clamp; float ones keep
    // double precision through the HDR curve.
    let hdr = format == SampleFormat::F32;
    if let [y, c1, c2] = colour {
        let [r, g, b, ..] = out else {
            unreachable!("three colour planes out")
        };
        let m = r
            .len()
            .min(g.len())
            .min(b.len())
            .min(y.len())
            .min(c1.len())
            .min(c2.len());
        let (r, g, b) = (&mut r[..m], &mut g[..m], &mut b[..m]);
        let (y, c1, c2) = (&y[..m], &c1[..m], &c2[..m]);
        if basis == ColourBasis::Luma {
            let m = LUMA_INVERSE;
            if hdr {
                for i in 0..r.len() {
                    let (y, c1, c2) = (y[i].to_f64(), c1[i].to_f64(), c2[i].to_f64());
                    r[i] = from_coding(m[0][0] * y + m[0][1] * c1 + m[0][2] * c2, format);
                    g[i] = from_coding(m[1][0] * y + m[1][1] * c1 + m[1][2] * c2, format);
                    b[i] = from_coding(m[2][0] * y + m[2][1] * c1 + m[2][2] * c2, format);
                }
            } else {
                let m = m.map(|row| row.map(|v| v as f32));
                for i in 0..r.len() {
                    let (y, c1, c2) = (y[i].to_f32(), c1[i].to_f32(), c2[i].to_f32());
                    r[i] = (m[0][0] * y + m[0][1] * c1 + m[0][2] * c2).clamp(0.0, 1.0);
                    g[i] = (m[1][0] * y + m[1][1] * c1 + m[1][2] * c2).clamp(0.0, 1.0);
                    b[i] = (m[2][0] * y + m[2][1] * c1 + m[2][2] * c2).clamp(0.0, 1.0);
                }
            }
        } else if hdr {
            let (ky, k1, k2) = (1.0 / S3, 1.0 / S2, 1.0 / S6);
            for i in 0..m {
                let (y, c1, c2) = (y[i].to_f64() * ky, c1[i].to_f64() * k1, c2[i].to_f64() * k2);
                r[i] = from_coding(y + c1 + c2, format);
                g[i] = from_coding(y - 2.0 * c2, format);
                b[i] = from_coding(y - c1 + c2, format);
            }
        } else {
            let (ky, k1, k2) = ((1.0 / S3) as f32, (1.0 / S2) as f32, (1.0 / S6) as f32);
            for i in 0..m {
                let (y, c1, c2) = (y[i].to_f32() * ky, c1[i].to_f32() * k1, c2[i].to_f32() * k2);
                r[i] = (y + c1 + c2).clamp(0.0, 1.0);
                g[i] = (y - 2.0 * c2).clamp(0.0, 1.0);
                b[i] = (y - c1 + c2).clamp(0.0, 1.0);
            }
        }
    } else {
        for (o, &v) in out[0].iter_mut().zip(colour[0]) {
            *o = if hdr {
                from_coding(v.to_f64(), format)
            } else {
                v.to_f32().clamp(0.0, 1.0)
            };
        }
    }
    if let Some(a) = alpha {
        for (o, &v) in out[nc].iter_mut().zip(a) {
            *o = v.to_f32().clamp(0.0, 1.0);
        }
    }
}

/// Reassembles raster samples (planar) from coding planes in `basis`, in parallel
/// spans (see [`inverse_span`]).
pub fn inverse<T: CodingValue>(
    planes: &CodingPlanes<T>,
    width: u32,
    height: u32,
    format: SampleFormat,
    basis: ColourBasis,
) -> Vec<f32> {
    let n = width as usize * height as usize;
    let nc = planes.colour.len();
    let mut out = vec![0.0f32; n * (nc + usize::from(planes.alpha.is_some()))];
    // Each span's part of every output plane, handed to one task.
    let mut spans: Vec<Vec<&mut [f32]>> = (0..n.div_ceil(CHUNK)).map(|_| Vec::new()).collect();
    for plane in out.chunks_mut(n.max(1)) {
        for (k, part) in plane.chunks_mut(CHUNK).enumerate() {
            spans[k].push(part);
        }
    }
    spans.into_par_iter().enumerate().for_each(|(k, mut out)| {
        let range = k * CHUNK..(k * CHUNK + CHUNK).min(n);
        let colour: Vec<&[T]> = planes.colour.iter().map(|p| &p[range.clone()]).collect();
        let alpha = planes.alpha.as_ref().map(|a| &a[range.clone()]);
        inverse_span(&colour, alpha, &mut out, format, basis);
    });
    out
}

/// The layout with `colour` colour channels and optional alpha.
pub fn layout_of(colour: usize, alpha: bool) -> ChannelLayout {
    match (colour, alpha) {
        (3, false) => ChannelLayout::Rgb,
        (3, true) => ChannelLayout::Rgba,
        (_, false) => ChannelLayout::Grey,
        (_, true) => ChannelLayout::GreyAlpha,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opponent_transform_is_orthonormal_and_inverts() {
        let px = vec![0.1f32, 0.9, 0.5, 0.3, 0.7, 0.2, 0.6, 0.8, 0.4];
        let img = Raster::new(3, 1, ChannelLayout::Rgb, SampleFormat::U8, px.clone()).unwrap();
        let cp = forward(&img, ColourBasis::Grey);
        for i in 0..3 {
            let rgb2: f64 = (0..3).map(|c| (px[c * 3 + i] as f64).powi(2)).sum();
            let opp2: f64 = (0..3).map(|c| cp.colour[c][i].powi(2)).sum();
            assert!((rgb2 - opp2).abs() < 1e-12);
        }
        let back = inverse(&cp, 3, 1, SampleFormat::U8, ColourBasis::Grey);
        assert!(back.iter().zip(&px).all(|(a, b)| (a - b).abs() < 1e-6));
    }

    fn columns_of(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
        [0, 1, 2].map(|c| [m[0][c], m[1][c], m[2][c]])
    }

    #[test]
    fn the_luma_basis_is_its_construction_and_halves_the_chroma_in_luma() {
        let bt601 = [0.299, 0.587, 0.114];
        let luma = bt601.map(|v| 0.5 * v + 1.0 / 6.0);
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        // The inverse's columns from the construction in the docs.
        let lh = luma.map(|v| v / norm(luma));
        let v = [1.0, 0.0, -1.0];
        let u = {
            let d = dot(v, lh);
            let u = [0, 1, 2].map(|k| v[k] - d * lh[k]);
            u.map(|x| x / norm(u))
        };
        let w = [
            lh[1] * u[2] - lh[2] * u[1],
            lh[2] * u[0] - lh[0] * u[2],
            lh[0] * u[1] - lh[1] * u[0],
        ];
        let columns = [[1.0 / S3; 3], u, w];
        for (c, col) in columns.iter().enumerate() {
            for k in 0..3 {
                assert!(
                    (LUMA_INVERSE[k][c] - col[k]).abs() < 1e-15,
                    "column {c} row {k}"
                );
            }
            // Unit columns: a unit error in any channel is a unit RGB error.
            assert!((norm(*col) - 1.0).abs() < 1e-15);
        }
        // The chroma columns have no luma; the forward matrix inverts the inverse, its
        // first row is sqrt 3 luma and its chroma rows give grey no chroma.
        assert!(dot(luma, u).abs() < 1e-15 && dot(luma, w).abs() < 1e-15);
        for (i, row) in LUMA_FORWARD.iter().enumerate() {
            for (j, col) in columns_of(LUMA_INVERSE).iter().enumerate() {
                let p = dot(*row, *col);
                assert!(
                    (p - f64::from(u8::from(i == j))).abs() < 1e-14,
                    "{i} {j}: {p}"
                );
            }
            assert!((LUMA_FORWARD[0][i] - S3 * luma[i]).abs() < 1e-14);
        }
        assert!(LUMA_FORWARD[1..]
            .iter()
            .all(|r| (r[0] + r[1] + r[2]).abs() < 1e-14));
        // Round trip through the planes, in both precisions of the decoder.
        let px = vec![0.1f32, 0.9, 0.5, 0.3, 0.7, 0.2, 0.6, 0.8, 0.4];
        for format in [SampleFormat::U8, SampleFormat::F32] {
            let img = Raster::new(3, 1, ChannelLayout::Rgb, format, px.clone()).unwrap();
            let cp = forward(&img, ColourBasis::Luma);
            let back = inverse(&cp, 3, 1, format, ColourBasis::Luma);
            assert!(
                back.iter().zip(&px).all(|(a, b)| (a - b).abs() < 1e-6),
                "{format:?}"
            );
        }
        // A unit chroma error moves BT.601 luma by at most 0.16 (0.31 in the grey
        // basis), and `L` not at all.
        let moved = |basis, c: usize| {
            let img = Raster::new(
                1,
                1,
                ChannelLayout::Rgb,
                SampleFormat::U8,
                vec![0.4, 0.5, 0.6],
            )
            .unwrap();
            let mut cp = forward(&img, basis);
            cp.colour[c][0] += 0.1;
            let back = inverse(&cp, 1, 1, SampleFormat::U8, basis);
            let rgb = [0, 1, 2].map(|k| f64::from(back[k]) - [0.4, 0.5, 0.6][k]);
            (dot(bt601, rgb) / 0.1, dot(luma, rgb) / 0.1)
        };
        for c in 1..3 {
            let (y, l) = moved(ColourBasis::Luma, c);
            assert!(y.abs() < 0.16 && l.abs() < 1e-5, "C{c}: {y} {l}");
        }
        assert!(moved(ColourBasis::Grey, 2).0.abs() > 0.3);
    }

    #[test]
    fn hdr_curve_inverts_over_a_wide_range() {
        for v in [0.0f32, 1e-4, 0.5, 3.0, 1000.0, 6e4, -0.25] {
            let back = from_coding(to_coding(v, SampleFormat::F32), SampleFormat::F32);
            assert!((back - v).abs() <= 1e-6 * v.abs().max(1.0), "{v} -> {back}");
        }
    }
}
