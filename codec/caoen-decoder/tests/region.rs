//! Region decodes: a rectangle of the image at any scale equals the same rectangle of
//! the whole image decoded at that scale, bad rectangles are refused with the values
//! in the message, and the work follows the output, not the virtual whole decode.

use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};
use caoen_decoder::bitstream::{self, TilePayload, TileStreams};
use caoen_decoder::decoder::{self, Depth, Samples};
use caoen_decoder::deringing::{Deringing, Strengths};
use caoen_decoder::restoration::{shape, PlaneFilter, Restoration};
use caoen_decoder::{decode, CodecError, DecodeOptions, Limits, Region};
use caoen_encoder::{encode, EncodeOptions};

/// A picture with smooth shading, edges and texture, so every layer and filter shows.
fn picture(w: u32, h: u32, layout: ChannelLayout) -> Raster {
    let n = (w * h) as usize;
    let samples = (0..layout.channels())
        .flat_map(|c| {
            (0..n).map(move |i| {
                let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
                let edge = if (x - 0.6 * y) > 20.0 { 0.3 } else { 0.0 };
                let v = 0.4
                    + 0.3 * ((x * 0.21 + c as f32).sin() * (y * 0.17 - c as f32).cos())
                    + edge
                    + 0.05 * ((x * 1.7).sin() * (y * 2.3).sin());
                v.clamp(0.0, 1.0)
            })
        })
        .collect();
    Raster::new(w, h, layout, SampleFormat::U8, samples).unwrap()
}

/// `bytes` with strong restoration filters and deringing in its header, so the
/// region's margins matter.
fn filtered(bytes: &[u8], colour_channels: usize) -> Vec<u8> {
    let parsed = bitstream::parse(bytes, u64::MAX).unwrap();
    let mut header = parsed.header.clone();
    header.restoration = Some(Restoration {
        planes: (0..colour_channels)
            .map(|c| {
                let taps = (0..shape(c).len() as i32).map(|k| 40 - 9 * k).collect();
                Some(PlaneFilter {
                    filters: vec![taps, vec![-12; shape(c).len()]],
                    classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
                })
            })
            .collect(),
        colour: None,
        last: Some(PlaneFilter::single((0..12).map(|k| 25 - 6 * k).collect())),
    });
    // Strong deringing of luma and chroma, so that every plane's filter shows.
    let [luma, chroma] = [200u8, 90].map(|primary| Strengths {
        primary,
        secondary: primary / 3,
        cutoff: 60,
    });
    let chroma = if colour_channels == 3 {
        chroma
    } else {
        Strengths::OFF
    };
    header.deringing = Some(Deringing { luma, chroma });
    let tiles: Vec<TileStreams> = parsed.tiles.iter().map(TilePayload::to_streams).collect();
    bitstream::write(&header, &parsed.metadata(), &tiles)
}

/// The test files: a plain encode and the same with strong filters, grey and colour.
fn files() -> Vec<(String, Vec<u8>, (u32, u32))> {
    let (w, h) = (70, 50);
    let mut out = Vec::new();
    for layout in [ChannelLayout::Rgb, ChannelLayout::Grey] {
        let opts = EncodeOptions {
            quality: 60.0,
            ..EncodeOptions::default()
        };
        let plain = encode(&picture(w, h, layout), &opts).unwrap();
        let strong = filtered(&plain, layout.colour_channels());
        out.push((format!("{layout:?}"), plain, (w, h)));
        out.push((format!("{layout:?} filtered"), strong, (w, h)));
    }
    out
}

fn region_opts(r: (f64, f64, f64, f64), size: Option<(u32, u32)>) -> DecodeOptions {
    DecodeOptions {
        size,
        region: Some(Region {
            x0: r.0,
            y0: r.1,
            x1: r.2,
            y1: r.3,
        }),
        ..DecodeOptions::default()
    }
}

/// Rows `y..y + h`, columns `x..x + w` of every plane of `img`.
/// The whole image decoded at `size`.
fn decode_at(bytes: &[u8], size: (u32, u32)) -> Raster {
    let opts = DecodeOptions {
        size: Some(size),
        ..DecodeOptions::default()
    };
    decode(bytes, &opts).unwrap()
}

fn crop(img: &Raster, (x, y, w, h): (usize, usize, usize, usize)) -> Vec<f32> {
    let iw = img.width() as usize;
    (0..img.layout().channels())
        .flat_map(|c| {
            let plane = img.plane(c);
            (y..y + h).flat_map(move |r| plane[r * iw + x..r * iw + x + w].to_vec())
        })
        .collect()
}

#[test]
fn the_whole_image_as_a_region_is_the_plain_decode() {
    for (name, bytes, (w, h)) in files() {
        let plain = decode(&bytes, &DecodeOptions::default()).unwrap();
        let region = decode(&bytes, &region_opts((0.0, 0.0, w as f64, h as f64), None)).unwrap();
        assert_eq!(region.samples(), plain.samples(), "{name}");
        // Straight to 8-bit samples as well.
        let parsed = bitstream::parse(&bytes, u64::MAX).unwrap();
        let a =
            decoder::decode_interleaved_parsed(&parsed, &DecodeOptions::default(), Depth::Eight)
                .unwrap();
        let b = decoder::decode_interleaved_parsed(
            &parsed,
            &region_opts((0.0, 0.0, w as f64, h as f64), Some((w, h))),
            Depth::Eight,
        )
        .unwrap();
        assert_eq!(a, b, "{name}");
    }
}

#[test]
fn a_region_at_k_times_is_the_crop_of_the_whole_decode_at_k_times() {
    for (name, bytes, (w, h)) in files() {
        for k in [1u32, 2, 3, 4] {
            let full = decode_at(&bytes, (k * w, k * h));
            // Inside, against the top-left corner, against the bottom-right corner.
            for (x0, y0, rw, rh) in [(13, 9, 31, 22), (0, 0, 17, 11), (w - 24, h - 20, 24, 20)] {
                let r = (x0 as f64, y0 as f64, (x0 + rw) as f64, (y0 + rh) as f64);
                let region = decode(&bytes, &region_opts(r, Some((k * rw, k * rh)))).unwrap();
                let want = crop(
                    &full,
                    (
                        (k * x0) as usize,
                        (k * y0) as usize,
                        (k * rw) as usize,
                        (k * rh) as usize,
                    ),
                );
                if k == 3 {
                    // Positions k x apart are not exact in binary: the window's and the
                    // whole decode's differ in their last bits.
                    let worst = region
                        .samples()
                        .iter()
                        .zip(&want)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0f32, f32::max);
                    assert!(worst < 1e-4, "{name}, {k}x, region {r:?}: {worst}");
                } else {
                    assert_eq!(region.samples(), &want[..], "{name}, {k}x, region {r:?}");
                }
            }
            // A region whose edges fall on the k x decode's pixel edges, not the image's.
            if k == 4 {
                let r = (10.25, 5.5, 30.75, 20.0);
                let region = decode(&bytes, &region_opts(r, Some((82, 58)))).unwrap();
                assert_eq!(
                    region.samples(),
                    &crop(&full, (41, 22, 82, 58))[..],
                    "{name}"
                );
            }
        }
    }
}

#[test]
fn a_region_between_pixel_edges_is_the_same_picture() {
    // Off the whole decode's grid the region samples the same continuous image at
    // other centres: close to the whole decode at the nearest centres, not equal.
    let (name, bytes, (w, h)) = files().swap_remove(1);
    let k = 4;
    let full = decode_at(&bytes, (k * w, k * h));
    let region = decode(
        &bytes,
        &region_opts((10.1, 5.1, 30.1, 25.1), Some((80, 80))),
    )
    .unwrap();
    let want = crop(&full, (40, 20, 80, 80));
    let mean = region
        .samples()
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs() as f64)
        .sum::<f64>()
        / want.len() as f64;
    assert!(mean < 0.02, "{name}: mean difference {mean}");
}

#[test]
fn bad_regions_are_refused_with_their_values() {
    let (_, bytes, _) = files().swap_remove(0);
    for (r, size, says) in [
        ((f64::NAN, 0.0, 10.0, 10.0), None, "finite"),
        ((0.0, 0.0, f64::INFINITY, 10.0), None, "finite"),
        ((10.0, 0.0, 10.0, 10.0), None, "x0 < x1"),
        ((0.0, 12.0, 10.0, 3.0), None, "x0 < x1"),
        ((-1.0, 0.0, 10.0, 10.0), None, "within the image"),
        ((0.0, 0.0, 70.5, 10.0), None, "within the image"),
        ((0.0, 0.0, 1e-6, 1e-6), Some((100, 100)), "4096"),
        ((0.0, 0.0, 10.0, 10.0), Some((0, 10)), "output size"),
        ((0.0, 0.0, 10.0, 10.0), Some((20000, 10)), "output size"),
    ] {
        let e = decode(&bytes, &region_opts(r, size)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(says), "{r:?} {size:?}: {msg}");
        if matches!(e, CodecError::Region { .. }) {
            assert!(msg.contains("of a 70x50 image"), "{msg}");
        }
    }
    // A region with supersampling is refused, not ignored.
    let opts = DecodeOptions {
        supersample: Some(2),
        ..region_opts((0.0, 0.0, 10.0, 10.0), None)
    };
    assert!(decode(&bytes, &opts).is_err());
}

#[test]
fn a_deep_zoom_works_in_the_output_s_memory() {
    let (name, bytes, _) = files().swap_remove(1);
    // 64x of the whole 70x50 image would be 4480x3200 pixels: over 340 MB of float
    // planes and samples. The region's 256x256 output needs a 1729x2241 window (its
    // filters' whole blocks at 64x are 512 pixels): with the post-filters' tasks on two
    // workers it fits in 320 MB.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool of two threads");
    let budget = Limits::new(320 << 20);
    let opts = DecodeOptions {
        limits: budget.clone(),
        ..region_opts((30.0, 20.0, 34.0, 24.0), Some((256, 256)))
    };
    let img = pool.install(|| decode(&bytes, &opts)).unwrap();
    assert_eq!((img.width(), img.height()), (256, 256), "{name}");
    let whole = DecodeOptions {
        size: Some((4480, 3200)),
        limits: budget,
        ..DecodeOptions::default()
    };
    assert!(matches!(
        pool.install(|| decode(&bytes, &whole)),
        Err(CodecError::Memory(_))
    ));
    // A pixel limit counts the window the region needs, checked before any work.
    let tight = DecodeOptions {
        max_pixels: 100_000,
        ..region_opts((30.0, 20.0, 34.0, 24.0), Some((256, 256)))
    };
    assert!(matches!(
        decode(&bytes, &tight),
        Err(CodecError::Limit { .. })
    ));
    // 16-bit samples as well as 8: the same crop.
    let parsed = bitstream::parse(&bytes, u64::MAX).unwrap();
    let small = region_opts((30.0, 20.0, 34.0, 24.0), Some((64, 64)));
    let deep = decoder::decode_interleaved_parsed(&parsed, &small, Depth::Sixteen).unwrap();
    let float = decode(&bytes, &small).unwrap();
    let Samples::U16(s) = deep.samples else {
        panic!("16-bit samples")
    };
    let n = 64 * 64;
    for (i, v) in s.iter().enumerate() {
        let (p, c) = (i / 3, i % 3);
        let want = caoen_base::raster::quantise(float.samples()[c * n + p], 65535.0) as u16;
        assert_eq!(*v, want);
    }
}
