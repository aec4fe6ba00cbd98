//! Coding at a smaller size: the header's display size, decoding at the image's size,
//! the encoder's choice by rate and distortion, and the bounds a decoder enforces.

mod common;
use common::corpus;

use caoen::codec::bitstream;
use caoen::codec::{
    decode, encode, encode_with_progress, DecodeOptions, EncodeOptions, Resampling, Scale,
    RESAMPLE_BELOW, RESAMPLE_SCALES,
};
use caoen::raster::Raster;

fn scene(w: u32, h: u32, seed: u64) -> Raster {
    corpus(caoen_corpus::Class::Scene, w, h, seed)
}

fn opts(quality: f32, resampling: Resampling) -> EncodeOptions {
    EncodeOptions {
        quality,
        resampling,
        ..Default::default()
    }
}

fn squared_error(a: &Raster, b: &Raster) -> f64 {
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    a.samples()
        .iter()
        .zip(b.samples())
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum()
}

#[test]
fn a_half_size_file_decodes_at_the_image_size() {
    let img = scene(161, 97, 3);
    let (bytes, stats) =
        encode_with_progress(&img, &opts(60.0, Resampling::At(Scale::HALF)), |_, _| {}).unwrap();
    assert_eq!(stats.coded_size, (81, 49));
    let h = bitstream::parse(&bytes, u64::MAX).unwrap().header;
    assert_eq!((h.width, h.height, h.display), (81, 49, Some((161, 97))));
    let out = decode(&bytes, &DecodeOptions::default()).unwrap();
    assert_eq!(
        (out.width(), out.height(), out.layout()),
        (161, 97, img.layout())
    );
    let mse = squared_error(&img, &out) / img.samples().len() as f64;
    let psnr = -10.0 * mse.log10();
    assert!(psnr > 22.0, "PSNR {psnr:.2}");
    // Other sizes still decode, by the same continuous network.
    let small = common::decode_at(&bytes, 81, 49);
    assert_eq!((small.width(), small.height()), (81, 49));
}

/// A half-size file's steps tilt by the image's frequencies (half the tilt per coded
/// frequency of a file at the image's size) and carry the asked quality's activity
/// field: none at q30, though the quality it is coded at (about q46) has one.
#[test]
fn a_half_size_file_is_shaped_by_the_image_and_the_asked_quality() {
    let img = scene(192, 128, 2);
    let header = |q: f32, resampling: Resampling| {
        let bytes = encode(&img, &opts(q, resampling)).unwrap();
        bitstream::parse(&bytes, u64::MAX).unwrap().header
    };
    let field = |h: &bitstream::Header| h.adaptive.and_then(|a| a.field());
    for q in [30.0, 50.0] {
        let (full, half) = (
            header(q, Resampling::Off),
            header(q, Resampling::At(Scale::HALF)),
        );
        assert_eq!(half.display, Some((192, 128)));
        let tilts = full.weights.expect("tilted steps").tilts;
        assert_eq!(
            half.weights.map(|w| w.tilts),
            Some(tilts.map(|t| t / 2)),
            "q{q}"
        );
        assert_eq!(field(&half), field(&full), "q{q}");
    }
    assert_eq!(field(&header(30.0, Resampling::At(Scale::HALF))), None);
    assert!(field(&header(50.0, Resampling::At(Scale::HALF))).is_some());
}

#[test]
fn a_file_at_seven_tenths_decodes_at_the_image_size() {
    let img = scene(161, 97, 3);
    let seven = Scale::new(7).unwrap();
    let (bytes, stats) =
        encode_with_progress(&img, &opts(50.0, Resampling::At(seven)), |_, _| {}).unwrap();
    // Each side rounded up: 112.7 and 67.9.
    assert_eq!(stats.coded_size, (113, 68));
    let h = bitstream::parse(&bytes, u64::MAX).unwrap().header;
    assert_eq!((h.width, h.height, h.display), (113, 68, Some((161, 97))));
    let out = decode(&bytes, &DecodeOptions::default()).unwrap();
    assert_eq!((out.width(), out.height()), (161, 97));
    let psnr = -10.0 * (squared_error(&img, &out) / img.samples().len() as f64).log10();
    assert!(psnr > 22.0, "PSNR {psnr:.2}");
    assert_eq!(Scale::new(0), None);
    assert_eq!(Scale::new(11), None);
}

#[test]
fn auto_keeps_the_best_of_the_sizes_by_its_rule() {
    // The rule: each smaller size tried at the quality scores its PSNR change plus 2
    // dB per doubling of the rate it saves against the full-size file; the best
    // positive score is kept, else the full-size file. Check it against files coded
    // at every size.
    let mut chosen = Vec::new();
    for (seed, quality) in [(1, 20.0), (5, 40.0), (4, 50.0), (2, 58.0)] {
        let img = scene(192, 128, seed);
        let full = encode(&img, &opts(quality, Resampling::Off)).unwrap();
        let auto = encode(&img, &opts(quality, Resampling::Auto)).unwrap();
        let error = |b: &[u8]| squared_error(&img, &decode(b, &DecodeOptions::default()).unwrap());
        let e_full = error(&full);
        let mut want = (0.0, full.clone(), 10);
        for r in RESAMPLE_SCALES.iter().filter(|r| quality < r.below) {
            let small = encode(&img, &opts(quality, Resampling::At(r.scale))).unwrap();
            let gain = 10.0 * (e_full / error(&small)).log10();
            let doublings = (full.len() as f64 / small.len() as f64).log2();
            let score = gain + 2.0 * doublings;
            if score > want.0 {
                want = (score, small, r.scale.tenths());
            }
        }
        assert!(
            auto == want.1,
            "seed {seed} q {quality}: want tenths {}",
            want.2
        );
        chosen.push(want.2);
    }
    // The cases reach the image's size and a smaller one.
    assert!(
        chosen.contains(&10) && chosen.iter().any(|&t| t < 10),
        "{chosen:?}"
    );
}

#[test]
fn auto_codes_at_full_size_from_its_quality_bound_at_low_effort_and_on_small_images() {
    let img = scene(192, 128, 5);
    for quality in [RESAMPLE_BELOW, 75.0] {
        assert_eq!(
            encode(&img, &opts(quality, Resampling::Auto)).unwrap(),
            encode(&img, &opts(quality, Resampling::Off)).unwrap()
        );
    }
    // Efforts 1 and 2 keep the image's size, even where effort 5 halves it
    // (`half_size_pays_at_low_rates_on_flat_regions`).
    let flat = corpus(caoen_corpus::Class::FlatEdges, 256, 192, 7);
    let fast = |resampling| EncodeOptions {
        effort: 2,
        ..opts(5.0, resampling)
    };
    assert_eq!(
        encode(&flat, &fast(Resampling::Auto)).unwrap(),
        encode(&flat, &fast(Resampling::Off)).unwrap()
    );
    let tiny = scene(200, 40, 6);
    assert_eq!(
        encode(&tiny, &opts(10.0, Resampling::Auto)).unwrap(),
        encode(&tiny, &opts(10.0, Resampling::Off)).unwrap()
    );
}

#[test]
fn half_size_pays_at_low_rates_on_flat_regions() {
    // Flat regions lose little over a 2x upscale, and at low quality half size
    // saves much of the rate: the encoder takes it.
    let img = corpus(caoen_corpus::Class::FlatEdges, 256, 192, 7);
    let (bytes, stats) =
        encode_with_progress(&img, &opts(5.0, Resampling::Auto), |_, _| {}).unwrap();
    let full = encode(&img, &opts(5.0, Resampling::Off)).unwrap();
    assert_eq!(stats.coded_size, (128, 96));
    assert!(
        bytes.len() < full.len(),
        "{} against {}",
        bytes.len(),
        full.len()
    );
}

#[test]
fn half_size_of_a_line_or_a_pixel() {
    // One side of 1 stays 1; a 1x1 image is coded at its size.
    for (w, h, coded) in [(9u32, 1u32, (5u32, 1u32)), (1, 1, (1, 1)), (1, 4, (1, 2))] {
        let samples: Vec<f32> = (0..w * h * 3).map(|i| (i % 7) as f32 / 7.0).collect();
        let img = Raster::new(
            w,
            h,
            caoen::raster::ChannelLayout::Rgb,
            caoen::raster::SampleFormat::U8,
            samples,
        )
        .unwrap();
        let (bytes, stats) =
            encode_with_progress(&img, &opts(30.0, Resampling::At(Scale::HALF)), |_, _| {})
                .unwrap();
        assert_eq!(stats.coded_size, coded);
        let out = decode(&bytes, &DecodeOptions::default()).unwrap();
        assert_eq!((out.width(), out.height()), (w, h));
    }
}

#[test]
fn the_decoder_checks_the_display_size() {
    let img = scene(96, 80, 8);
    let bytes = encode(&img, &opts(60.0, Resampling::At(Scale::HALF))).unwrap();
    let parsed = bitstream::parse(&bytes, u64::MAX).unwrap();
    let h0 = parsed.header.clone();
    // The file again with another display size: the header's own checks, behind a
    // right CRC.
    let tiles: Vec<_> = parsed.tiles.iter().map(|t| t.to_streams()).collect();
    let with_display = |dw: u32, dh: u32| {
        let mut h = h0.clone();
        h.display = Some((dw, dh));
        bitstream::write(&h, &parsed.metadata(), &tiles)
    };
    assert_eq!(with_display(96, 80), bytes);
    // The unchanged rewrite parses; smaller than coded, equal, or past the side limit fail.
    assert_eq!(
        bitstream::parse(&with_display(96, 80), u64::MAX)
            .unwrap()
            .header,
        h0
    );
    for (dw, dh) in [(47, 80), (96, 39), (48, 40), (16385, 80)] {
        let e = bitstream::parse(&with_display(dw, dh), u64::MAX).unwrap_err();
        assert!(e.to_string().contains("display"), "{dw}x{dh}: {e}");
    }
    // The pixel limit counts the display size.
    let e = decode(
        &bytes,
        &DecodeOptions {
            max_pixels: 96 * 80 - 1,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("pixels"), "{e}");
}

#[test]
fn rate_targets_land_where_the_size_changes() {
    // The rate jumps where the choice of size changes with the quality; the search
    // runs at each size on its own and lands on the target either way.
    use caoen::codec::RateTarget;
    let img = corpus(caoen_corpus::Class::FlatEdges, 256, 192, 7);
    let mut sizes = Vec::new();
    // Targets the image can reach: its smallest file, at half size and quality 0, is
    // 532 bytes (0.087 bpp).
    for bpp in [0.1, 0.15, 0.3] {
        let o = EncodeOptions {
            target: Some(RateTarget::BitsPerPixel(bpp)),
            ..opts(75.0, Resampling::Auto)
        };
        let (bytes, stats) = encode_with_progress(&img, &o, |_, _| {}).unwrap();
        let got = bytes.len() as f64 * 8.0 / (256.0 * 192.0);
        assert!(
            (got / bpp - 1.0).abs() <= 0.03,
            "target {bpp}: {got:.4} bpp"
        );
        sizes.push(stats.coded_size);
    }
    // The targets reach the image's size and a smaller one.
    assert!(
        sizes.contains(&(256, 192)) && sizes.iter().any(|&(w, _)| w < 256),
        "{sizes:?}"
    );
}

#[test]
fn the_quality_bound_is_the_last_size_tried() {
    let last = RESAMPLE_SCALES
        .iter()
        .map(|r| r.below)
        .fold(0.0f32, f32::max);
    assert_eq!(RESAMPLE_BELOW, last);
    // Coarsest first, each size smaller than the image's.
    assert!(RESAMPLE_SCALES
        .windows(2)
        .all(|p| p[0].scale.tenths() < p[1].scale.tenths()));
    assert!(RESAMPLE_SCALES.iter().all(|r| r.scale.tenths() < 10));
}

#[test]
fn sizes_between_are_chosen_where_they_pay_and_only_from_effort_5() {
    // A scene at q50: half size is too coarse there, a size between pays.
    let img = scene(192, 128, 4);
    let (_, stats) = encode_with_progress(&img, &opts(50.0, Resampling::Auto), |_, _| {}).unwrap();
    assert!(
        [(135, 90), (154, 103)].contains(&stats.coded_size),
        "{:?}",
        stats.coded_size
    );
    // Effort 4 tries half size alone.
    let four = EncodeOptions {
        effort: 4,
        ..opts(50.0, Resampling::Auto)
    };
    let (_, stats) = encode_with_progress(&img, &four, |_, _| {}).unwrap();
    assert!(
        [(96, 64), (192, 128)].contains(&stats.coded_size),
        "{:?}",
        stats.coded_size
    );
}

#[test]
fn a_rate_target_keeps_the_size_asked_for() {
    use caoen::codec::RateTarget;
    let img = corpus(caoen_corpus::Class::FlatEdges, 256, 192, 7);
    for (resampling, size) in [
        (Resampling::Off, (256, 192)),
        (Resampling::At(Scale::new(7).unwrap()), (180, 135)),
    ] {
        let o = EncodeOptions {
            target: Some(RateTarget::BitsPerPixel(0.15)),
            ..opts(75.0, resampling)
        };
        let mut last = (0, 1);
        let (_, stats) = encode_with_progress(&img, &o, |d, t| {
            assert!(d <= t, "{d} of {t}");
            last = (d, t);
        })
        .unwrap();
        assert_eq!(stats.coded_size, size, "{resampling:?}");
        assert_eq!(last.0, last.1, "progress ends at its total");
    }
}
