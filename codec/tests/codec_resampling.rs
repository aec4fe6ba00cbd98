//! Coding at half size: the header's display size, decoding at the image's size, the
//! encoder's choice by rate and distortion, and the bounds a decoder enforces.

use caoen::codec::bitstream;
use caoen::codec::{
    decode, encode, encode_with_progress, DecodeOptions, EncodeOptions, Resampling, RESAMPLE_BELOW,
};
use caoen::image_io;
use caoen::raster::Raster;

fn scene(w: u32, h: u32, seed: u64) -> Raster {
    of_class(caoen_corpus::Class::Scene, w, h, seed)
}

fn of_class(class: caoen_corpus::Class, w: u32, h: u32, seed: u64) -> Raster {
    let img = caoen_corpus::Spec {
        class,
        width: w,
        height: h,
        seed,
    }
    .generate();
    image_io::from_dynamic(img.to_dynamic_image()).expect("corpus image converts")
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
        encode_with_progress(&img, &opts(60.0, Resampling::Half), |_, _| {}).unwrap();
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
    let small = decode(
        &bytes,
        &DecodeOptions {
            size: Some((81, 49)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((small.width(), small.height()), (81, 49));
}

/// A half-size file's steps tilt by the image's frequencies (half the tilt per coded
/// frequency of a file at the image's size) and carry the asked quality's activity
/// field: none at q30, though the quality it is coded at (about q47) has one.
#[test]
fn a_half_size_file_is_shaped_by_the_image_and_the_asked_quality() {
    let img = scene(192, 128, 2);
    let header = |q: f32, resampling: Resampling| {
        let bytes = encode(&img, &opts(q, resampling)).unwrap();
        bitstream::parse(&bytes, u64::MAX).unwrap().header
    };
    let field = |h: &bitstream::Header| h.adaptive.and_then(|a| a.field());
    for q in [30.0, 50.0] {
        let (full, half) = (header(q, Resampling::Off), header(q, Resampling::Half));
        assert_eq!(half.display, Some((192, 128)));
        let tilts = full.weights.expect("tilted steps").tilts;
        assert_eq!(
            half.weights.map(|w| w.tilts),
            Some(tilts.map(|t| t / 2)),
            "q{q}"
        );
        assert_eq!(field(&half), field(&full), "q{q}");
    }
    assert_eq!(field(&header(30.0, Resampling::Half)), None);
    assert!(field(&header(50.0, Resampling::Half)).is_some());
}

#[test]
fn auto_keeps_the_cheaper_of_the_two_by_its_rule() {
    // The rule: half size when its PSNR change plus 1.5 dB per doubling of the rate
    // it saves is positive. Check it against files coded both ways.
    let mut chosen = Vec::new();
    for (seed, quality) in [(1, 20.0), (5, 40.0), (4, 50.0)] {
        let img = scene(192, 128, seed);
        let full = encode(&img, &opts(quality, Resampling::Off)).unwrap();
        let auto = encode(&img, &opts(quality, Resampling::Auto)).unwrap();
        let chose_half = bitstream::parse(&auto, u64::MAX)
            .unwrap()
            .header
            .display
            .is_some();
        let error = |b: &[u8]| squared_error(&img, &decode(b, &DecodeOptions::default()).unwrap());
        let half = encode(&img, &opts(quality, Resampling::Half)).unwrap();
        let gain = 10.0 * (error(&full) / error(&half)).log10();
        let doublings = (full.len() as f64 / half.len() as f64).log2();
        let want_half = gain + 1.5 * doublings > 0.0;
        assert_eq!(
            chose_half, want_half,
            "seed {seed} q {quality}: gain {gain:.3} dB, {doublings:.3} doublings"
        );
        assert_eq!(auto, if want_half { half } else { full });
        chosen.push(want_half);
    }
    // The cases reach both sides of the rule.
    assert!(
        chosen.contains(&true) && chosen.contains(&false),
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
    let flat = of_class(caoen_corpus::Class::FlatEdges, 256, 192, 7);
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
    let img = of_class(caoen_corpus::Class::FlatEdges, 256, 192, 7);
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
            encode_with_progress(&img, &opts(30.0, Resampling::Half), |_, _| {}).unwrap();
        assert_eq!(stats.coded_size, coded);
        let out = decode(&bytes, &DecodeOptions::default()).unwrap();
        assert_eq!((out.width(), out.height()), (w, h));
    }
}

#[test]
fn the_decoder_checks_the_display_size() {
    let img = scene(96, 80, 8);
    let bytes = encode(&img, &opts(60.0, Resampling::Half)).unwrap();
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
    let img = of_class(caoen_corpus::Class::FlatEdges, 256, 192, 7);
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
    // The targets reach both sizes.
    assert!(
        sizes.contains(&(128, 96)) && sizes.contains(&(256, 192)),
        "{sizes:?}"
    );
}
