//! Restoration filters through the whole codec: the encoder fits them where they pay,
//! the decoder's every path applies them alike, and they lower the error they were
//! fitted to; damaged restoration sections are errors.

mod common;
use common::corpus;

use caoen::codec::bitstream::{self, tag, TilePayload, TileStreams};
use caoen::codec::restoration::{PlaneFilter, Restoration};
use caoen::codec::{decode, encode, inspect, CodecError, DecodeOptions, EncodeOptions, Resampling};
use caoen::metrics::psnr;
use caoen::raster::Raster;

fn natural(w: u32, h: u32, seed: u64) -> Raster {
    corpus(caoen_corpus::Class::Natural, w, h, seed)
}

/// `bytes` rewritten with `f` applied to its header.
fn rewrite(bytes: &[u8], f: impl FnOnce(&mut bitstream::Header)) -> Vec<u8> {
    let parsed = bitstream::parse(bytes, u64::MAX).unwrap();
    let mut header = parsed.header.clone();
    f(&mut header);
    let tiles: Vec<TileStreams> = parsed.tiles.iter().map(TilePayload::to_streams).collect();
    bitstream::write(&header, &parsed.metadata(), &tiles)
}

#[test]
fn the_encoder_restores_where_it_pays_and_the_filter_lowers_the_error() {
    let img = natural(200, 150, 4);
    let mut restored_any = false;
    for q in [20.0, 45.0, 70.0] {
        let opts = EncodeOptions {
            quality: q,
            ..EncodeOptions::default()
        };
        let bytes = encode(&img, &opts).unwrap();
        let header = inspect(&bytes).unwrap().header;
        let Some(r) = header.restoration else {
            continue;
        };
        restored_any = true;
        let with = decode(&bytes, &DecodeOptions::default()).unwrap();
        let without = decode(
            &rewrite(&bytes, |h| h.restoration = None),
            &DecodeOptions::default(),
        )
        .unwrap();
        let (p_with, p_without) = (psnr(&img, &with).unwrap(), psnr(&img, &without).unwrap());
        assert!(
            p_with > p_without,
            "q{q}: {p_with:.4} dB restored, {p_without:.4} dB without ({r:?})"
        );
    }
    assert!(restored_any, "no quality restored a noisy natural image");
}

/// How many of `images` at `qualities` the encoder gave the restoration stage that
/// `has` finds, each checked to decode closer to its image than the same file with
/// the stage taken out by `drop`, or no more than `slack` dB further.
fn kept_stages_lower_the_error(
    images: &[(String, Raster)],
    qualities: &[f32],
    slack: f64,
    has: impl Fn(&Restoration) -> bool,
    drop: impl Fn(&mut Restoration),
) -> usize {
    let mut kept = 0;
    for (name, img) in images {
        for &q in qualities {
            let opts = EncodeOptions {
                quality: q,
                resampling: Resampling::Off,
                ..EncodeOptions::default()
            };
            let bytes = encode(img, &opts).unwrap();
            let header = inspect(&bytes).unwrap().header;
            let Some(r) = header.restoration.filter(|r| has(r)) else {
                continue;
            };
            kept += 1;
            let with = decode(&bytes, &DecodeOptions::default()).unwrap();
            let without = rewrite(&bytes, |h| {
                let r = h.restoration.as_mut().unwrap();
                drop(r);
                if !r.any() {
                    h.restoration = None;
                }
            });
            let without = decode(&without, &DecodeOptions::default()).unwrap();
            let (p_with, p_without) = (psnr(img, &with).unwrap(), psnr(img, &without).unwrap());
            assert!(
                p_with > p_without - slack,
                "{name} q{q}: {p_with:.4} dB with the stage, {p_without:.4} dB without ({r:?})"
            );
        }
    }
    kept
}

#[test]
fn the_encoders_colour_map_lowers_the_error_where_it_is_kept() {
    let images: Vec<(String, Raster)> = [1, 4, 9]
        .map(|seed| (format!("natural {seed}"), natural(240, 160, seed)))
        .into();
    let has = |r: &Restoration| {
        r.colour.as_ref().is_some_and(|m| {
            assert!(m.is_valid() && m.planes() == 3, "{m:?}");
            true
        })
    };
    let mapped =
        kept_stages_lower_the_error(&images, &[15.0, 30.0, 50.0], 0.0, has, |r| r.colour = None);
    assert!(
        mapped > 0,
        "no natural image at any quality took a colour map"
    );
}

#[test]
fn the_encoders_last_filter_lowers_the_error_where_it_is_kept() {
    use caoen_corpus::Class;
    let images: Vec<(String, Raster)> = [
        (Class::Scene, 1),
        (Class::Scene, 2),
        (Class::FlatEdges, 3),
        (Class::Natural, 4),
    ]
    .map(|(class, seed)| (format!("{class:?} {seed}"), corpus(class, 320, 240, seed)))
    .into();
    // The encoder keeps the last filters by their gain on the fit's groups, checked on
    // both halves of them; on the whole decode a kept stage can fall short of that by
    // thousandths of a dB (Natural 4 at q70: -0.003 dB); a hundredth is allowed.
    let kept = kept_stages_lower_the_error(
        &images,
        &[15.0, 30.0, 50.0, 70.0],
        0.01,
        |r| r.last.is_some(),
        |r| r.last = None,
    );
    assert!(kept > 0, "no corpus image at any quality took last filters");
}

#[test]
fn a_resized_decode_restores_like_the_coded_size() {
    // At twice the size each offset spans two output pixels: what the filter changes
    // there, averaged back over 2x2 pixels, is what it changes at the coded size.
    let (w, h) = (160u32, 120u32);
    let img = natural(w, h, 9);
    let opts = EncodeOptions {
        quality: 25.0,
        // Coded at the image's size, which the test compares with twice it.
        resampling: Resampling::Off,
        ..EncodeOptions::default()
    };
    let plain = encode(&img, &opts).unwrap();
    let plain = rewrite(&plain, |h| h.restoration = None);
    // A smoothing luma filter and a sharpening chroma one; then luma by pixel class,
    // smoothing the flat classes and sharpening the busy ones.
    let smoothing = vec![30, 8, 2, 0, 6, 20, 6, 0, 0, 4, 0, 1];
    let sharpening = vec![-12, -3, 0, 0, -3, -12, -3, 0, 0, -2, 0, 0];
    let lumas = [
        PlaneFilter::single(smoothing.clone()),
        PlaneFilter {
            filters: vec![smoothing, sharpening],
            classes: Some(std::array::from_fn(|k| 1 + (k >= 15) as u8)),
        },
    ];
    let mut last = Vec::new();
    for luma in lumas {
        let bytes = rewrite(&plain, |h| {
            h.restoration = Some(Restoration {
                colour: None,
                last: None,
                planes: vec![
                    Some(luma),
                    Some(PlaneFilter::single(vec![-20, -4, -5, -20, -5, -4])),
                    None,
                ],
            })
        });
        let at = |b: &[u8], size| {
            decode(
                b,
                &DecodeOptions {
                    size: Some(size),
                    ..DecodeOptions::default()
                },
            )
            .unwrap()
        };
        let change = |size: (u32, u32)| -> Vec<f64> {
            let (a, b) = (at(&bytes, size), at(&plain, size));
            a.samples()
                .iter()
                .zip(b.samples())
                .map(|(&x, &y)| (x - y) as f64)
                .collect()
        };
        let native = change((w, h));
        let double = change((2 * w, 2 * h));
        let (wu, hu) = (w as usize, h as usize);
        let mut averaged = vec![0.0; native.len()];
        for c in 0..3 {
            for y in 0..hu {
                for x in 0..wu {
                    let at2 = |dx: usize, dy: usize| {
                        double[c * 4 * wu * hu + (2 * y + dy) * 2 * wu + 2 * x + dx]
                    };
                    averaged[c * wu * hu + y * wu + x] =
                        (at2(0, 0) + at2(1, 0) + at2(0, 1) + at2(1, 1)) / 4.0;
                }
            }
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let corr =
            dot(&native, &averaged) / (dot(&native, &native) * dot(&averaged, &averaged)).sqrt();
        assert!(
            dot(&native, &native) > 0.0,
            "the filter changes the coded-size decode"
        );
        assert!(
            corr > 0.6,
            "correlation {corr:.3} of the filter's changes at 1x and 2x"
        );
        last = bytes;
    }
    let bytes = last;
    // Forward mapping with supersampling applies it on its lattice: at the coded size
    // it is the identity path's image.
    let forward = decode(
        &bytes,
        &DecodeOptions {
            supersample: Some(2),
            ..DecodeOptions::default()
        },
    )
    .unwrap();
    assert_eq!(
        forward.samples(),
        decode(&bytes, &DecodeOptions::default()).unwrap().samples()
    );
}

#[test]
fn damaged_restoration_sections_are_errors() {
    let img = natural(64, 48, 2);
    let bytes = encode(&img, &common::at_quality(30.0)).unwrap();
    let sections = inspect(&bytes).unwrap().sections;
    let header = sections[0].offset;
    // A section with the given tag and payload, CRC and all.
    let section = |t: u8, payload: &[u8]| {
        let mut out = Vec::new();
        bitstream::push_section(&mut out, t, payload);
        out
    };
    let unrestored = rewrite(&bytes, |h| h.restoration = None);
    let end_of = |b: &[u8]| {
        inspect(b)
            .unwrap()
            .sections
            .iter()
            .find(|s| s.tag == tag::END)
            .unwrap()
            .offset
    };
    let e = end_of(&unrestored);
    let with = |payload: &[u8]| {
        [
            &unrestored[..e],
            &section(tag::RESTORATION, payload),
            &unrestored[e..],
        ]
        .concat()
    };
    for payload in [
        &[][..],
        &[0][..],
        &[8, 0][..],
        &[1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0][..],
    ] {
        match decode(&with(payload), &DecodeOptions::default()) {
            Err(CodecError::Restoration { .. }) => {}
            other => panic!("{payload:?}: {other:?}"),
        }
    }
    // Before the tiles it is out of order.
    let h_end = header + sections[0].file_bytes();
    let early = [
        &unrestored[..h_end],
        &section(tag::RESTORATION, &[1, 0x80, 0x80]),
        &unrestored[h_end..],
    ]
    .concat();
    assert!(matches!(
        decode(&early, &DecodeOptions::default()),
        Err(CodecError::SectionOrder { .. })
    ));
}
