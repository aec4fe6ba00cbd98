//! Codec round trips over the corpus and the edge cases, quality monotonicity, the two
//! decoder paths, determinism across thread counts, and rate targets.

mod common;
use common::{at_quality, corpus, decode_at, raster_of, with_threads};

use caoen::codec::{decode, encode, DecodeOptions, EncodeOptions, RateTarget};
use caoen::raster::{ChannelLayout, Raster, SampleFormat};

/// PSNR over all channels; float (HDR) images are compared after the tone map
/// `v / (1 + v)`, since a peak of 1.0 means nothing for them.
fn psnr(a: &Raster, b: &Raster) -> f64 {
    assert_eq!(
        (a.width(), a.height(), a.layout()),
        (b.width(), b.height(), b.layout())
    );
    let tone = |v: f32| {
        if a.format() == SampleFormat::F32 {
            (v.max(0.0) / (1.0 + v.max(0.0))) as f64
        } else {
            v as f64
        }
    };
    let mse = common::mse_by(a, b, tone);
    10.0 * (1.0 / mse.max(1e-20)).log10()
}

#[test]
fn every_corpus_class_and_edge_case_round_trips() {
    for spec in caoen_corpus::test_subset() {
        let img = raster_of(&spec);
        let bytes =
            encode(&img, &at_quality(80.0)).unwrap_or_else(|e| panic!("{}: {e}", spec.file_name()));
        let out = decode(&bytes, &DecodeOptions::default()).unwrap();
        assert_eq!(
            (out.width(), out.height(), out.layout(), out.format()),
            (img.width(), img.height(), img.layout(), img.format())
        );
        let p = psnr(&img, &out);
        // Pure noise is incompressible; everything else is reproduced recognisably.
        let floor = if spec.class == caoen_corpus::Class::EdgeCases {
            8.0
        } else {
            18.0
        };
        assert!(p > floor, "{}: PSNR {p:.2}", spec.file_name());
    }
}

#[test]
fn psnr_rises_with_quality_on_photo_like_images() {
    for seed in [0, 1] {
        let img = corpus(caoen_corpus::Class::Scene, 160, 112, seed);
        let mut last = 0.0;
        let mut last_size = 0;
        for quality in [10.0, 30.0, 50.0, 70.0, 90.0] {
            let bytes = encode(&img, &at_quality(quality)).unwrap();
            let p = psnr(&img, &decode(&bytes, &DecodeOptions::default()).unwrap());
            assert!(
                p > last,
                "seed {seed} quality {quality}: PSNR {p:.2} <= {last:.2}"
            );
            assert!(
                bytes.len() >= last_size,
                "seed {seed} quality {quality}: size fell"
            );
            last = p;
            last_size = bytes.len();
        }
    }
}

#[test]
fn formats_and_layouts_round_trip() {
    let (w, h) = (37u32, 23u32);
    let n = (w * h) as usize;
    let ramp = |c: usize| {
        (0..n).map(move |i| {
            let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
            0.5 + 0.4 * ((x * 0.21 + y * 0.13 + c as f32).sin() * (y * 0.17 - c as f32).cos())
        })
    };
    for (layout, format) in [
        (ChannelLayout::Grey, SampleFormat::U8),
        (ChannelLayout::GreyAlpha, SampleFormat::U16),
        (ChannelLayout::Rgb, SampleFormat::U16),
        (ChannelLayout::Rgba, SampleFormat::U8),
    ] {
        let samples: Vec<f32> = (0..layout.channels()).flat_map(ramp).collect();
        let img = Raster::new(w, h, layout, format, samples).unwrap();
        let out = decode(
            &encode(&img, &at_quality(95.0)).unwrap(),
            &DecodeOptions::default(),
        )
        .unwrap();
        assert_eq!((out.layout(), out.format()), (layout, format));
        // Alpha is coded, not dropped: its plane comes back close to the original.
        if layout.has_alpha() {
            let c = layout.channels() - 1;
            let err = img
                .plane(c)
                .iter()
                .zip(out.plane(c))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(err < 0.25, "{layout:?} alpha max error {err}");
        }
        assert!(
            psnr(&img, &out) > 30.0,
            "{layout:?} {format:?}: {:.2}",
            psnr(&img, &out)
        );
    }
}

#[test]
fn hdr_float_images_stay_float_with_their_range() {
    let (w, h) = (48u32, 32u32);
    let n = (w * h) as usize;
    // A 1e4:1 range: a dim gradient with a bright sun.
    let samples: Vec<f32> = (0..3)
        .flat_map(|_| {
            (0..n).map(|i| {
                let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
                let d2 = (x - 30.0).powi(2) + (y - 10.0).powi(2);
                0.01 + 0.2 * x / w as f32 + if d2 < 16.0 { 100.0 } else { 0.0 }
            })
        })
        .collect();
    let img = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::F32, samples).unwrap();
    let out = decode(
        &encode(&img, &at_quality(90.0)).unwrap(),
        &DecodeOptions::default(),
    )
    .unwrap();
    assert_eq!(out.format(), SampleFormat::F32);
    let max = out.samples().iter().copied().fold(0.0f32, f32::max);
    assert!(max > 50.0, "the bright sun survives unclamped: max {max}");
    // Relative error in the dim region stays small (the asinh curve spends bits evenly).
    let (a, b) = (img.samples()[5], out.samples()[5]);
    assert!((a - b).abs() < 0.2 * a.abs() + 0.01, "dim pixel {a} -> {b}");
}

#[test]
fn identity_and_forward_mapping_paths_agree() {
    let img = corpus(caoen_corpus::Class::Scene, 192, 128, 2);
    let bytes = encode(&img, &at_quality(70.0)).unwrap();
    let id = decode(&bytes, &DecodeOptions::default()).unwrap();
    for s in 1..=4 {
        let fwd = decode(
            &bytes,
            &DecodeOptions {
                supersample: Some(s),
                ..Default::default()
            },
        )
        .unwrap();
        // Same model, two evaluators (fast path vs core network): only rounding differs.
        let p = psnr(&id, &fwd);
        assert!(p > 50.0, "S={s}: forward mapping vs identity {p:.1} dB");
        eprintln!("forward mapping S={s} vs identity: {p:.1} dB");
    }
}

#[test]
fn decoding_at_other_sizes_evaluates_the_continuous_network() {
    let img = corpus(caoen_corpus::Class::Smooth, 64, 48, 0);
    let bytes = encode(&img, &at_quality(80.0)).unwrap();
    let up = decode_at(&bytes, 128, 96);
    let down = decode(
        &bytes,
        &DecodeOptions {
            size: Some((32, 24)),
            supersample: Some(2),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(
        (up.width(), up.height(), down.width(), down.height()),
        (128, 96, 32, 24)
    );
    // A smooth image upsampled 2x and sampled back at the original centres matches.
    let back: Vec<f32> = (0..3)
        .flat_map(|c| {
            let up = &up;
            (0..48).flat_map(move |y| {
                (0..64).map(move |x| {
                    let p = up.plane(c);
                    (p[(2 * y) * 128 + 2 * x]
                        + p[(2 * y) * 128 + 2 * x + 1]
                        + p[(2 * y + 1) * 128 + 2 * x]
                        + p[(2 * y + 1) * 128 + 2 * x + 1])
                        / 4.0
                })
            })
        })
        .collect();
    let back = Raster::new(64, 48, img.layout(), img.format(), back).unwrap();
    assert!(psnr(&img, &back) > 30.0, "{:.2}", psnr(&img, &back));
    assert!(decode(
        &bytes,
        &DecodeOptions {
            size: Some((0, 5)),
            ..Default::default()
        }
    )
    .is_err());
    assert!(decode(
        &bytes,
        &DecodeOptions {
            size: Some((9000, 9000)),
            max_pixels: 1 << 20,
            ..Default::default()
        }
    )
    .is_err());
}

#[test]
fn output_is_identical_for_one_and_two_threads() {
    let img = corpus(caoen_corpus::Class::Natural, 96, 80, 1);
    let run = |threads| with_threads(threads, || encode(&img, &at_quality(75.0)).unwrap());
    assert_eq!(run(1), run(2));
}

#[test]
fn decoded_samples_are_identical_for_any_thread_count() {
    let img = corpus(caoen_corpus::Class::Scene, 150, 97, 2);
    let bytes = encode(&img, &at_quality(80.0)).unwrap();
    for opts in [
        DecodeOptions::default(),
        DecodeOptions {
            size: Some((301, 77)),
            ..Default::default()
        },
        DecodeOptions {
            supersample: Some(2),
            ..Default::default()
        },
    ] {
        let run = |threads| with_threads(threads, || decode(&bytes, &opts).unwrap());
        let one = run(1);
        for threads in [2, 3] {
            let bits = |r: &caoen::raster::Raster| -> Vec<u32> {
                r.samples().iter().map(|v| v.to_bits()).collect()
            };
            assert_eq!(
                bits(&one),
                bits(&run(threads)),
                "{threads} threads, {opts:?}"
            );
        }
    }
}

#[test]
fn target_bpp_lands_within_three_percent_on_scenes() {
    for seed in [0, 3] {
        let img = corpus(caoen_corpus::Class::Scene, 256, 192, seed);
        for target in [0.25, 0.6] {
            let bytes = encode(
                &img,
                &EncodeOptions {
                    target: Some(RateTarget::BitsPerPixel(target)),
                    ..Default::default()
                },
            )
            .unwrap();
            let bpp = bytes.len() as f64 * 8.0 / img.pixel_count() as f64;
            assert!(
                (bpp / target - 1.0).abs() <= 0.03,
                "seed {seed}: target {target} got {bpp:.4}"
            );
        }
    }
}

#[test]
fn keypoint_budget_is_met() {
    let img = corpus(caoen_corpus::Class::Scene, 128, 96, 1);
    let (bytes, stats) = caoen::codec::encode_with_progress(
        &img,
        &EncodeOptions {
            keypoints: Some(600),
            ..Default::default()
        },
        |_, _| {},
    )
    .unwrap();
    assert!(
        (600..600 + 3 * 200).contains(&stats.luma_keypoints),
        "{}",
        stats.luma_keypoints
    );
    assert!(decode(&bytes, &DecodeOptions::default()).is_ok());
}
