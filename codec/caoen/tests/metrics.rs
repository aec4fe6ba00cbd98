//! Golden tests of the quality metrics: identical images, known errors with exact
//! PSNR, SSIM against closed forms and a direct (non-separable) evaluation of the
//! definition, the HDR log scale.

use caoen::metrics::{self, MetricError, Scale};
use caoen::raster::ChannelLayout::{self, Grey, Rgb, Rgba};
use caoen::raster::Raster;
use caoen::raster::SampleFormat::{self, F32, U16, U8};
use caoen_corpus::{generate, Class};

fn flat(w: u32, h: u32, layout: ChannelLayout, format: SampleFormat, v: &[f32]) -> Raster {
    let n = (w * h) as usize;
    let samples = v.iter().flat_map(|&x| std::iter::repeat_n(x, n)).collect();
    Raster::new(w, h, layout, format, samples).unwrap()
}

fn corpus(class: Class, w: u32, h: u32, seed: u64) -> Raster {
    caoen::image_io::from_dynamic(generate(class, w, h, seed).to_dynamic_image()).unwrap()
}

/// A deterministic pseudo-random plane in [0, 1].
fn noise(n: usize, seed: u64) -> Vec<f32> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

#[test]
fn identical_images_are_perfect() {
    for (class, seed) in [
        (Class::Scene, 0),
        (Class::Texture, 0),
        (Class::EdgeCases, 3),
    ] {
        let a = corpus(class, 40, 32, seed);
        let c = metrics::compare(&a, &a).unwrap();
        assert_eq!(c.psnr, f64::INFINITY);
        assert_eq!(c.psnr_y, f64::INFINITY);
        assert_eq!((c.mse, c.mse_y), (0.0, 0.0));
        assert!((c.ssim - 1.0).abs() < 1e-12, "{}", c.ssim);
        let s2 = c.ssimulacra2.unwrap();
        assert!((s2 - 100.0).abs() < 1e-6, "{s2}");
    }
}

#[test]
fn known_mse_gives_exact_psnr() {
    // Every sample off by 1/8 (exact in binary): MSE = 1/64, PSNR = 10 log10 64.
    let a = flat(5, 3, Rgb, U8, &[0.5, 0.25, 0.0]);
    let b = flat(5, 3, Rgb, U8, &[0.625, 0.375, 0.125]);
    let c = metrics::compare(&a, &b).unwrap();
    assert_eq!(c.mse, 1.0 / 64.0);
    assert!((c.psnr - 10.0 * 64f64.log10()).abs() < 1e-12);
    // Luma moves by 0.125 too (the weights sum to 1).
    assert!(
        (c.psnr_y - 10.0 * 64f64.log10()).abs() < 1e-5,
        "{}",
        c.psnr_y
    );

    // Only red off by 1/4: RGB MSE = (1/16) / 3; luma error 0.299 / 4 (BT.601).
    let b = flat(5, 3, Rgb, U8, &[0.75, 0.25, 0.0]);
    let c = metrics::compare(&a, &b).unwrap();
    assert!((c.mse - 1.0 / 48.0).abs() < 1e-15);
    assert!((c.psnr - 10.0 * 48f64.log10()).abs() < 1e-12);
    let dy: f64 = 0.299 * 0.25;
    assert!((c.mse_y - dy * dy).abs() < 1e-9, "{}", c.mse_y);

    // Half of a grey image's pixels off by 1/2: MSE = 1/8.
    let a = Raster::new(2, 2, Grey, U16, vec![0.0; 4]).unwrap();
    let b = Raster::new(2, 2, Grey, U8, vec![0.5, 0.0, 0.0, 0.5]).unwrap();
    assert!((metrics::psnr(&a, &b).unwrap() - 10.0 * 8f64.log10()).abs() < 1e-12);
    assert_eq!(
        metrics::psnr_y(&a, &b).unwrap(),
        metrics::psnr(&a, &b).unwrap()
    );
}

#[test]
fn alpha_is_measured_separately() {
    let a = flat(4, 4, Rgba, U8, &[0.5, 0.5, 0.5, 1.0]);
    let b = flat(4, 4, Rgba, U8, &[0.5, 0.5, 0.5, 0.75]);
    let c = metrics::compare(&a, &b).unwrap();
    assert_eq!(c.psnr, f64::INFINITY);
    assert!((c.psnr_alpha.unwrap() - 10.0 * 16f64.log10()).abs() < 1e-12);
}

#[test]
fn ssim_of_flat_images_is_the_luminance_term() {
    // No variance, no covariance: SSIM = (2ab + C1) / (a^2 + b^2 + C1) everywhere.
    for (w, h) in [(16, 16), (3, 20), (1, 1)] {
        let a = flat(w, h, Grey, U8, &[0.5]);
        let b = flat(w, h, Grey, U8, &[0.625]);
        let want = (2.0 * 0.5 * 0.625 + metrics::SSIM_C1) / (0.25 + 0.390_625 + metrics::SSIM_C1);
        let got = metrics::ssim(&a, &b).unwrap();
        assert!((got - want).abs() < 1e-12, "{w}x{h}: {got} vs {want}");
    }
}

/// SSIM straight from the definition: a 2-D Gaussian-weighted sum at every valid
/// window position, no separable filtering.
fn ssim_direct(a: &[f32], b: &[f32], w: usize, h: usize) -> f64 {
    let k = 11;
    let g: Vec<f64> = (0..k)
        .map(|i| (-((i as f64 - 5.0).powi(2)) / (2.0 * 1.5 * 1.5)).exp())
        .collect();
    let norm: f64 = g.iter().sum::<f64>().powi(2);
    let mut total = 0.0;
    let mut count = 0;
    for y0 in 0..=h - k {
        for x0 in 0..=w - k {
            let (mut ma, mut mb, mut aa, mut bb, mut ab) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for dy in 0..k {
                for dx in 0..k {
                    let wgt = g[dx] * g[dy] / norm;
                    let i = (y0 + dy) * w + x0 + dx;
                    let (x, y) = (f64::from(a[i]), f64::from(b[i]));
                    ma += wgt * x;
                    mb += wgt * y;
                    aa += wgt * x * x;
                    bb += wgt * y * y;
                    ab += wgt * x * y;
                }
            }
            let (va, vb, cov) = (aa - ma * ma, bb - mb * mb, ab - ma * mb);
            let (c1, c2) = (1e-4, 9e-4);
            total += (2.0 * ma * mb + c1) * (2.0 * cov + c2)
                / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            count += 1;
        }
    }
    total / count as f64
}

#[test]
fn ssim_matches_the_definition() {
    for (w, h, seed) in [(11, 11, 1), (23, 17, 2), (40, 12, 3)] {
        let n = w * h;
        let a = noise(n, seed);
        // A noisy, contrast-reduced, shifted copy: SSIM well inside (0, 1).
        let b: Vec<f32> = a
            .iter()
            .zip(noise(n, seed + 100))
            .map(|(&x, e)| 0.7 * x + 0.1 + 0.2 * e)
            .collect();
        let got = metrics::ssim_planes(&a, &b, w as u32, h as u32);
        let want = ssim_direct(&a, &b, w, h);
        assert!((got - want).abs() < 1e-12, "{w}x{h}: {got} vs {want}");
        assert!(got > 0.1 && got < 0.95, "{got}");
        // Symmetric.
        let back = metrics::ssim_planes(&b, &a, w as u32, h as u32);
        assert!((got - back).abs() < 1e-12);
    }
}

#[test]
fn ssim_reference_value() {
    // One 11x11 window, a = a horizontal ramp x/10, b = the ramp plus 0.05 on the even
    // columns. By hand with the normalised 1-D Gaussian g (sigma 1.5) and the ramp's
    // symmetry about the centre column: mu_a = 0.5, var_a = sum_i g_i (i-5)^2 / 100,
    // and b adds a +0.05 square wave whose mean is 0.05 * sum of g over even columns.
    let (w, h) = (11usize, 11usize);
    let a: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 / 10.0).collect();
    let b: Vec<f32> = (0..w * h)
        .map(|i| a[i] + if (i % w) % 2 == 0 { 0.05 } else { 0.0 })
        .collect();
    let g: Vec<f64> = (0..11)
        .map(|i| (-((i as f64 - 5.0).powi(2)) / 4.5).exp())
        .collect();
    let s: f64 = g.iter().sum();
    let g: Vec<f64> = g.iter().map(|v| v / s).collect();
    let x = |i: usize| f64::from(a[i]);
    let y = |i: usize| f64::from(b[i]);
    let ma: f64 = (0..11).map(|i| g[i] * x(i)).sum();
    let mb: f64 = (0..11).map(|i| g[i] * y(i)).sum();
    let va: f64 = (0..11).map(|i| g[i] * (x(i) - ma).powi(2)).sum();
    let vb: f64 = (0..11).map(|i| g[i] * (y(i) - mb).powi(2)).sum();
    let cov: f64 = (0..11).map(|i| g[i] * (x(i) - ma) * (y(i) - mb)).sum();
    let (c1, c2) = (metrics::SSIM_C1, metrics::SSIM_C2);
    let want =
        (2.0 * ma * mb + c1) * (2.0 * cov + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
    let got = metrics::ssim_planes(&a, &b, w as u32, h as u32);
    assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    // The value itself, worked out by hand in f64 from the exact ramp: mu_a = 0.5,
    // mu_b = 0.5250035, var_a = cov = 0.0224349, var_b = 0.0230599, giving
    // 0.98535552; the f32 samples move it by under 1e-8. A change in the window,
    // sigma or constants shows up here.
    assert!((got - 0.985_355_5).abs() < 1e-7, "{got}");
}

#[test]
fn ssim_falls_with_noise() {
    let a = corpus(Class::Natural, 64, 64, 0);
    let mut last = 1.0;
    for amp in [0.02f32, 0.05, 0.1, 0.2] {
        let e = noise(a.samples().len(), 7);
        let samples = a
            .samples()
            .iter()
            .zip(e)
            .map(|(&v, e)| (v + amp * (e - 0.5)).clamp(0.0, 1.0))
            .collect();
        let b = Raster::new(64, 64, a.layout(), a.format(), samples).unwrap();
        let c = metrics::compare(&a, &b).unwrap();
        assert!(c.ssim < last, "{amp}: {} !< {last}", c.ssim);
        last = c.ssim;
        assert!(c.ssimulacra2.unwrap() < 100.0);
    }
}

#[test]
fn hdr_uses_the_log_scale() {
    // One stop (a factor of 2) everywhere is ~1/32 on the log scale: ~30.1 dB.
    let a = flat(8, 8, Rgb, F32, &[1.0, 10.0, 1000.0]);
    let b = flat(8, 8, Rgb, F32, &[2.0, 20.0, 2000.0]);
    let c = metrics::compare(&a, &b).unwrap();
    assert_eq!(c.scale, Scale::LogHdr);
    assert!((c.psnr - 10.0 * 1024f64.log10()).abs() < 1e-3, "{}", c.psnr);
    assert!(c.ssimulacra2.is_none());
    assert_eq!(metrics::log_encode(0.0), 0.0);
    assert_eq!(metrics::log_encode(1e9), 1.0);
    assert!((metrics::log_encode(1.0) - 14.0 / 32.0).abs() < 1e-4);
    // A 10% error is less than a stop's.
    let d = flat(8, 8, Rgb, F32, &[1.0, 10.0, 1000.0]);
    let e = flat(8, 8, Rgb, F32, &[1.1, 11.0, 1100.0]);
    let c2 = metrics::compare(&d, &e).unwrap();
    assert!(c2.psnr > c.psnr);
}

#[test]
fn mismatches_are_errors() {
    let a = flat(4, 4, Rgb, U8, &[0.0, 0.0, 0.0]);
    let b = flat(4, 5, Rgb, U8, &[0.0, 0.0, 0.0]);
    assert!(matches!(
        metrics::compare(&a, &b),
        Err(MetricError::Size { b_height: 5, .. })
    ));
    let g = flat(4, 4, Grey, U8, &[0.0]);
    assert_eq!(
        metrics::compare(&a, &g),
        Err(MetricError::Channels { a: 3, b: 1 })
    );
    // Alpha does not count as a colour channel: RGB vs RGBA compares.
    let ra = flat(4, 4, Rgba, U8, &[0.0, 0.0, 0.0, 1.0]);
    assert_eq!(metrics::psnr(&a, &ra).unwrap(), f64::INFINITY);
}

#[test]
fn tiny_images_work() {
    let a = flat(1, 1, Rgb, U8, &[0.5, 0.5, 0.5]);
    let b = flat(1, 1, Rgb, U8, &[0.25, 0.5, 0.5]);
    let c = metrics::compare(&a, &b).unwrap();
    assert!(c.psnr.is_finite() && c.ssim < 1.0);
    assert!(c.ssimulacra2.is_none());
}
