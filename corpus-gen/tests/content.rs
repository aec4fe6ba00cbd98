//! Each class's content is measured, not assumed.

mod common;

use caoen_corpus::{generate, Class, SampleFormat};
use common::*;

#[test]
fn zone_plate_sweeps_to_nyquist() {
    for seed in [0u64, 4] {
        let img = generate(Class::Texture, 256, 192, seed);
        assert_eq!(img.channels(), 1);
        let (w, h) = (256usize, 192usize);
        let p = img.plane(0);
        // Centre row: dy = 0.5, horizontal chirp from 0 at the centre to Nyquist at the sides.
        let row: Vec<f64> = p[(h / 2) * w..(h / 2 + 1) * w].to_vec();
        let edge = local_frequency(&row[w - 10..]);
        let edge_l = local_frequency(&row[..10]);
        let centre = local_frequency(&row[w / 2 - 4..w / 2 + 6]);
        assert!(
            edge > 0.46 && edge <= 0.5,
            "seed {seed}: right-edge frequency {edge}"
        );
        assert!(
            edge_l > 0.46 && edge_l <= 0.5,
            "seed {seed}: left-edge frequency {edge_l}"
        );
        assert!(centre < 0.05, "seed {seed}: centre frequency {centre}");
        // Mid-way the frequency is about half of that (linear sweep).
        let mid = local_frequency(&row[w * 3 / 4 - 5..w * 3 / 4 + 5]);
        assert!(
            (mid - 0.25).abs() < 0.04,
            "seed {seed}: frequency at 3/4 width {mid}"
        );
        // Centre column: the same sweep vertically.
        let col: Vec<f64> = (0..h).map(|y| p[y * w + w / 2]).collect();
        let vedge = local_frequency(&col[h - 10..]);
        assert!(vedge > 0.46, "seed {seed}: bottom-edge frequency {vedge}");
        // DFT of the centre row: the top band [0.4, 0.5] holds a real share of the energy
        // (a linear chirp spreads it evenly over 0..0.5).
        let ps = spectrum(&row, false);
        let total: f64 = ps.iter().skip(1).sum();
        let top: f64 = ps
            .iter()
            .enumerate()
            .filter(|(k, _)| *k as f64 / w as f64 >= 0.4)
            .map(|(_, e)| e)
            .sum();
        assert!(
            top / total > 0.1,
            "seed {seed}: energy share in [0.4, 0.5] c/px = {}",
            top / total
        );
    }
}

#[test]
fn smooth_class_has_no_high_frequencies() {
    // Summed over the colour channels (a channel that hardly varies is all
    // quantisation noise on its own). 8-bit seeds 0..4, 16-bit seeds 4..8.
    for seed in 0..8 {
        let img = generate(Class::Smooth, 128, 96, seed);
        let (mut hi, mut total) = (0.0, 0.0);
        for c in 0..img.channels() {
            let (h, t) = highfreq_energy(&img.plane(c), 128, 96, 1.0 / 16.0);
            hi += h;
            total += t;
        }
        let limit = if img.bit_depth() == 16 { 1e-5 } else { 1e-3 };
        assert!(
            hi / total < limit,
            "smooth seed {seed}: energy share above 1/16 c/px = {:.2e}",
            hi / total
        );
    }
    // The measure discriminates: hard edges and texture have plenty.
    let img = generate(Class::FlatEdges, 128, 96, 0);
    let f = highfreq_fraction(&img.luma_plane(), 128, 96, 1.0 / 16.0);
    assert!(f > 1e-2, "flat-edges high-frequency share {f}");
}

#[test]
fn natural_class_has_fractal_spectrum() {
    // fBm-based variants (terrain, clouds, marble): energy falls off octave by
    // octave (power-law spectrum) but reaches the finest octave.
    let edges = [
        1.0 / 64.0,
        1.0 / 32.0,
        1.0 / 16.0,
        1.0 / 8.0,
        1.0 / 4.0,
        0.5001,
    ];
    for seed in [0u64, 1, 2, 4, 5] {
        let img = generate(Class::Natural, 128, 128, seed);
        let e = band_energies(&img.luma_plane(), 128, 128, &edges);
        // Per-frequency density: divide by band width (each band is twice the previous).
        let d: Vec<f64> = e
            .iter()
            .enumerate()
            .map(|(i, v)| v / (1u64 << i) as f64)
            .collect();
        for i in 1..d.len() {
            assert!(
                d[i] < d[i - 1],
                "natural seed {seed}: spectral density not decreasing: {d:?}"
            );
        }
        assert!(
            d[4] > 0.0,
            "natural seed {seed}: nothing in the finest octave"
        );
    }
    // Wood: rings and grain, far from white noise.
    let img = generate(Class::Natural, 128, 128, 3);
    let f = highfreq_fraction(&img.luma_plane(), 128, 128, 0.25);
    assert!(f < 0.3, "wood: energy share above 1/4 c/px {f}");
    let noise = generate(Class::EdgeCases, 128, 128, 1);
    assert!(highfreq_fraction(&noise.luma_plane(), 128, 128, 0.25) > 0.4);
}

#[test]
fn flat_edges_is_mostly_exactly_flat_with_antialiased_edges() {
    for seed in 0..8 {
        let img = generate(Class::FlatEdges, 384, 288, seed);
        let share = flat_share(&img);
        // The text page and the user interface are the busiest variants.
        let min = if seed % 4 >= 2 { 0.45 } else { 0.65 };
        assert!(share > min, "flat-edges seed {seed}: flat share {share}");
        // Anti-aliasing: some pixels lie strictly between their left and right neighbours.
        let l = img.luma_plane();
        let mut between = 0;
        for y in 0..288 {
            for x in 1..383 {
                let (a, b, c) = (l[y * 384 + x - 1], l[y * 384 + x], l[y * 384 + x + 1]);
                if (a < b && b < c) || (a > b && b > c) {
                    between += 1;
                }
            }
        }
        assert!(
            between > 50,
            "flat-edges seed {seed}: only {between} intermediate edge pixels"
        );
    }
    // For contrast: the natural and scene classes are not flat.
    assert!(flat_share(&generate(Class::Natural, 128, 96, 0)) < 0.3);
    assert!(flat_share(&generate(Class::Scene, 128, 96, 0)) < 0.3);
}

#[test]
fn texture_has_exact_nyquist_patterns() {
    // Stripes: the top-left tile is pixel-aligned 2-px-period vertical lines.
    let img = generate(Class::Texture, 120, 80, 1);
    for x in 2..30 {
        for c in 0..3 {
            assert_eq!(img.sample(x, 10, c), img.sample(x - 2, 10, c));
        }
        assert_ne!(img.sample(x, 10, 0), img.sample(x - 1, 10, 0));
    }
    // Checkerboard: the top-left board has 1-px cells.
    let img = generate(Class::Texture, 128, 100, 2);
    for y in 1..20 {
        for x in 1..20 {
            let (v, l, u) = (
                img.sample(x, y, 0),
                img.sample(x - 1, y, 0),
                img.sample(x, y - 1, 0),
            );
            assert_ne!(v, l);
            assert_ne!(v, u);
        }
    }
}

#[test]
fn hdr_dynamic_range_exceeds_1000_to_1() {
    for seed in 0..3 {
        let img = generate(Class::Hdr, 128, 96, seed);
        assert_eq!(img.sample_format(), SampleFormat::F32);
        let l = img.luma_plane();
        assert!(
            l.iter().all(|v| v.is_finite() && *v > 0.0),
            "hdr seed {seed}: non-positive radiance"
        );
        let (lo, hi) = (quantile(&l, 0.0), quantile(&l, 1.0));
        let (p_lo, p_hi) = (quantile(&l, 0.001), quantile(&l, 0.999));
        assert!(hi / lo > 1000.0, "hdr seed {seed}: max/min {}", hi / lo);
        assert!(
            p_hi / p_lo > 1000.0,
            "hdr seed {seed}: p99.9/p0.1 {}",
            p_hi / p_lo
        );
    }
}

#[test]
fn pure_noise_is_uncorrelated_and_uniform() {
    let img = generate(Class::EdgeCases, 256, 256, 1);
    assert_eq!((img.width(), img.height(), img.channels()), (256, 256, 3));
    for c in 0..3 {
        let p = img.plane(c);
        let (mut a, mut b, mut d) = (Vec::new(), Vec::new(), Vec::new());
        for y in 0..255 {
            for x in 0..255 {
                a.push(p[y * 256 + x]);
                b.push(p[y * 256 + x + 1]);
                d.push(p[(y + 1) * 256 + x]);
            }
        }
        assert!(
            correlation(&a, &b).abs() < 0.02,
            "horizontal correlation {}",
            correlation(&a, &b)
        );
        assert!(
            correlation(&a, &d).abs() < 0.02,
            "vertical correlation {}",
            correlation(&a, &d)
        );
    }
    // Histogram of all bytes is flat: chi-square with 255 d.o.f. well below 400.
    let bytes = img.pixel_bytes();
    let mut hist = [0f64; 256];
    for b in &bytes {
        hist[*b as usize] += 1.0;
    }
    let e = bytes.len() as f64 / 256.0;
    let chi2: f64 = hist.iter().map(|o| (o - e) * (o - e) / e).sum();
    assert!(chi2 < 400.0, "chi-square {chi2}");
    // Incompressible: the PNG is no smaller than the raw samples.
    let dir = TempDir::new("noise");
    let path = dir.path().join("n.png");
    img.save(&path).unwrap();
    let size = std::fs::metadata(&path).unwrap().len() as f64;
    assert!(
        size > 0.99 * bytes.len() as f64,
        "PNG {size} bytes for {} raw",
        bytes.len()
    );
    // The 16-bit gray noise too.
    let img = generate(Class::EdgeCases, 128, 128, 4);
    let p = img.plane(0);
    let a: Vec<f64> = (0..127 * 128).map(|i| p[i]).collect();
    let b: Vec<f64> = (0..127 * 128).map(|i| p[i + 128]).collect();
    assert!(correlation(&a, &b).abs() < 0.03);
}

#[test]
fn edge_case_sizes_and_formats_are_exact() {
    let specs = caoen_corpus::corpus(512, &[Class::EdgeCases], Some(8));
    let dims: Vec<(u32, u32)> = specs.iter().map(|s| (s.width, s.height)).collect();
    assert_eq!(
        dims,
        vec![
            (512, 512),
            (512, 512),
            (1023, 7),
            (1, 1),
            (1, 512),
            (512, 1),
            (1, 1),
            (341, 517)
        ]
    );
    let expect = [
        (3, SampleFormat::U8),
        (3, SampleFormat::U8),
        (1, SampleFormat::U8),
        (4, SampleFormat::U8),
        (1, SampleFormat::U16),
        (2, SampleFormat::U8),
        (1, SampleFormat::U16),
        (4, SampleFormat::U16),
    ];
    for (spec, (ch, fmt)) in specs.iter().zip(expect) {
        let img = spec.generate();
        assert_eq!(
            (img.width(), img.height()),
            (spec.width, spec.height),
            "{spec}"
        );
        assert_eq!((img.channels(), img.sample_format()), (ch, fmt), "{spec}");
        assert_eq!(
            img.pixel_bytes().len(),
            (spec.width * spec.height) as usize * ch as usize * (fmt.bit_depth() as usize / 8)
        );
    }
    // Flat variants are exactly flat, at any size.
    for (w, h, seed) in [(64, 48, 0), (1, 1, 0), (17, 3, 6), (1, 9, 6)] {
        let img = generate(Class::EdgeCases, w, h, seed);
        let first: Vec<f32> = (0..img.channels()).map(|c| img.sample(0, 0, c)).collect();
        for y in 0..h {
            for x in 0..w {
                for c in 0..img.channels() {
                    assert_eq!(img.sample(x, y, c), first[c as usize]);
                }
            }
        }
    }
    // Alpha variants really use alpha.
    let img = generate(Class::EdgeCases, 48, 48, 3);
    let a = img.plane(3);
    assert!(a.contains(&0.0) && a.iter().any(|&v| v > 0.3));
}

#[test]
fn every_class_handles_degenerate_sizes() {
    for class in Class::ALL {
        for seed in 0..class.variant_count() * 2 {
            for (w, h) in [(1, 1), (1, 5), (5, 1), (2, 2), (7, 3), (1023, 7)] {
                let img = generate(class, w, h, seed);
                assert_eq!((img.width(), img.height()), (w, h), "{class} seed {seed}");
                assert_eq!((img.channels(), img.sample_format()), class.format(seed));
            }
        }
    }
    assert!(caoen_corpus::try_generate(Class::Smooth, 0, 5, 0).is_err());
    assert!(caoen_corpus::try_generate(Class::Smooth, 5, caoen_corpus::MAX_SIDE + 1, 0).is_err());
}

#[test]
fn scenes_mix_flat_and_detailed_areas() {
    for seed in 0..4 {
        let img = generate(Class::Scene, 192, 128, seed);
        let l = img.luma_plane();
        // Local activity per 8x8 block: both smooth and busy blocks exist.
        let mut acts = Vec::new();
        for by in 0..16 {
            for bx in 0..24 {
                let mut a = 0.0;
                for y in by * 8..by * 8 + 8 {
                    for x in bx * 8..bx * 8 + 7 {
                        a += (l[y * 192 + x + 1] - l[y * 192 + x]).abs();
                    }
                }
                acts.push(a / 56.0);
            }
        }
        let (q10, q90) = (quantile(&acts, 0.1), quantile(&acts, 0.9));
        assert!(
            q90 > 4.0 * q10.max(1e-4),
            "scene seed {seed}: activity p10 {q10} p90 {q90}"
        );
        assert!(
            q90 > 0.02,
            "scene seed {seed}: no detailed areas (p90 {q90})"
        );
    }
}
