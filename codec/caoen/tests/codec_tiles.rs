//! Tiled coding: a large image is cut into tiles that are coded independently, yet
//! decodes as one network and one detail layer: tile edges no worse than the edges
//! inside tiles, the same bytes for any number of workers or threads and for a compact
//! 8-bit source, the memory limit per call, and files that lie about their tiles.

use caoen::codec::bitstream::{self, tag};
use caoen::codec::tiling::Tiling;
use caoen::codec::{
    decode, encode, encode_memory, inspect, CodecError, DecodeOptions, EncodeOptions, Limits,
    Resampling, Scale,
};
use caoen::image_io::{self, EncodeSource};
use caoen::raster::Raster;

/// A photo-like corpus image large enough for several tiles, as the image crate holds
/// it (8-bit RGB).
fn natural(w: u32, h: u32) -> image::DynamicImage {
    caoen_corpus::generate(caoen_corpus::Class::Natural, w, h, 3).to_dynamic_image()
}

/// Mean squared error per pixel (all channels, 8-bit units) of two rasters.
fn squared_errors(a: &Raster, b: &Raster) -> Vec<f64> {
    let n = a.pixel_count();
    let mut se = vec![0.0; n];
    for c in 0..a.layout().channels() {
        for (i, (x, y)) in a.plane(c).iter().zip(b.plane(c)).enumerate() {
            se[i] += ((x - y) as f64 * 255.0).powi(2);
        }
    }
    se
}

/// Mean of `se` over the pixels on either side of every vertical and horizontal line
/// at multiples of `period` that `keep` accepts.
fn edge_mean(se: &[f64], w: usize, h: usize, period: usize, keep: impl Fn(usize) -> bool) -> f64 {
    let on = |v: usize, n: usize| -> bool {
        let t = if v % period == period - 1 { v + 1 } else { v };
        t % period == 0 && t > 0 && t < n && keep(t)
    };
    let (mut sum, mut count) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            if on(x, w) || on(y, h) {
                sum += se[y * w + x];
                count += 1;
            }
        }
    }
    sum / count as f64
}

#[test]
fn tile_edges_are_no_worse_than_the_edges_inside_tiles() {
    let (w, h) = (1280u32, 1088u32);
    let img = image_io::from_dynamic(natural(w, h)).unwrap();
    let tiling = Tiling::choose(w, h);
    assert!(tiling.count() >= 6, "{tiling:?}");
    let side = tiling.side as usize;
    for quality in [20.0, 75.0, 95.0] {
        let opts = EncodeOptions {
            quality,
            // At its own size, so the file has the tiles whose edges are measured.
            resampling: Resampling::Off,
            ..EncodeOptions::default()
        };
        let bytes = encode(&img, &opts).unwrap();
        assert_eq!(inspect(&bytes).unwrap().tiles.len(), tiling.count());
        let out = decode(&bytes, &DecodeOptions::default()).unwrap();
        let se = squared_errors(&img, &out);
        let (w, h) = (w as usize, h as usize);
        let mean = se.iter().sum::<f64>() / se.len() as f64;
        let tiles = edge_mean(&se, w, h, side, |_| true);
        // Root edges (every 32 px) that are not tile edges: what any block edge costs.
        let roots = edge_mean(&se, w, h, 32, |t| t % side != 0);
        assert!(
            tiles <= 1.1 * roots,
            "q{quality}: tile edges {tiles:.3}, root edges inside tiles {roots:.3}, image {mean:.3}"
        );
        assert!(
            tiles <= 1.25 * mean,
            "q{quality}: tile edges {tiles:.3}, image {mean:.3}"
        );
    }
}

/// Lapping moves the detail blocks' quantisation error off their edges: the pixels on
/// either side of every 8-pixel block edge come to the image's mean error, where the
/// same settings without lapping leave them above it at the higher qualities (both
/// without restoration filters).
#[test]
fn lapping_brings_the_error_at_block_edges_to_the_image_mean() {
    use caoen::codec::{encoder, rate_control};
    let (w, h) = (512u32, 384u32);
    let img = image_io::from_dynamic(natural(w, h)).unwrap();
    for quality in [50.0, 75.0, 90.0] {
        let ratio = |lapped: bool| {
            let mut s = rate_control::settings(quality, 5, None);
            assert!(s.lapping.is_some(), "the encoder laps by default");
            // The restoration filters smooth block edges too; this measures lapping.
            s.restoration = false;
            if !lapped {
                s.lapping = None;
            }
            let (bytes, _) =
                encoder::encode_with(&img, &s, &Default::default(), 2, |_, _| {}).unwrap();
            let se = squared_errors(&img, &decode(&bytes, &DecodeOptions::default()).unwrap());
            let mean = se.iter().sum::<f64>() / se.len() as f64;
            edge_mean(&se, w as usize, h as usize, 8, |_| true) / mean
        };
        let (plain, lapped) = (ratio(false), ratio(true));
        // Below q75 deblocking already keeps the edges at the mean; above, lapping is
        // what does.
        assert!(
            lapped <= 1.05 && lapped < plain && (quality < 75.0 || plain - lapped >= 0.05),
            "q{quality}: block edges / image {lapped:.3} lapped, {plain:.3} not"
        );
    }
}

#[test]
fn bytes_do_not_depend_on_workers_threads_or_the_source_form() {
    let (w, h) = (1100u32, 700u32);
    let dynamic = natural(w, h);
    let raster = image_io::from_dynamic(dynamic.clone()).unwrap();
    let compact = EncodeSource::Compact(dynamic);
    let opts = EncodeOptions::default();
    let reference = encode(&raster, &opts).unwrap();
    assert!(inspect(&reference).unwrap().tiles.len() > 1);
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        assert_eq!(
            pool.install(|| encode(&raster, &opts).unwrap()),
            reference,
            "{threads} threads"
        );
        assert_eq!(
            pool.install(|| encode(&compact, &opts).unwrap()),
            reference,
            "compact source, {threads} threads"
        );
    }
    // A budget for exactly one tile at a time: the same file.
    let one = encode_memory(w, h, opts.quality);
    let limited = EncodeOptions {
        limits: Limits::new(one.need(1) + (64 << 20)),
        ..opts.clone()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    assert_eq!(
        pool.install(|| encode(&raster, &limited).unwrap()),
        reference
    );
}

#[test]
fn a_budget_too_small_for_one_tile_is_refused_before_any_work() {
    let img = image_io::from_dynamic(natural(600, 600)).unwrap();
    let opts = EncodeOptions {
        limits: Limits::new(1 << 20),
        ..EncodeOptions::default()
    };
    match encode(&img, &opts) {
        Err(CodecError::Memory(e)) => {
            assert_eq!(e.budget, 1 << 20);
            assert!(e.need > e.budget);
            assert!(e.what.contains("600x600"), "{}", e.what);
        }
        other => panic!("{other:?}"),
    }
    let d = DecodeOptions {
        limits: Limits::new(1000),
        ..DecodeOptions::default()
    };
    let bytes = encode(&img, &EncodeOptions::default()).unwrap();
    assert!(matches!(decode(&bytes, &d), Err(CodecError::Memory(_))));
}

#[test]
fn the_encode_estimate_stays_bounded_per_pixel_for_large_images() {
    // A tile's working set does not grow with the image: at camera sizes the estimate
    // is a few bytes per pixel beyond the tiles in progress, or the restoration fit's
    // decode of the file (13 bytes per pixel) and its sampled rows (a few hundred rows
    // of 28 bytes per pixel: the decoded planes, the sums and the restored copies the
    // deringing is chosen on).
    for (w, h) in [(4032u32, 3024u32), (8064, 6048), (16384, 16384)] {
        let m = encode_memory(w, h, 75.0);
        let px = w as u64 * h as u64;
        assert!(m.fixed <= 3 * px + (16 << 20), "{w}x{h}: {m:?}");
        assert_eq!(m.per_tile, encode_memory(4032, 3024, 75.0).per_tile);
        assert!(m.after <= 13 * px + 28 * 500 * w as u64, "{w}x{h}: {m:?}");
        assert!(m.need(2) < 24 * px, "{w}x{h}: {m:?}");
    }
}

/// Rewrites the sections of a file (tag, payload) with fresh CRCs.
fn rebuild(sections: &[(u8, Vec<u8>)]) -> Vec<u8> {
    let mut out = bitstream::MAGIC.to_vec();
    out.push(bitstream::VERSION);
    for (t, p) in sections {
        bitstream::push_section(&mut out, *t, p);
    }
    out
}

#[test]
fn files_that_lie_about_their_tiles_are_refused() {
    let img = image_io::from_dynamic(natural(1100, 600)).unwrap();
    let bytes = encode(&img, &EncodeOptions::default()).unwrap();
    let parsed = inspect(&bytes).unwrap();
    let sections: Vec<(u8, Vec<u8>)> = parsed
        .sections
        .iter()
        .map(|s| (s.tag, s.payload.to_vec()))
        .collect();
    let first_tile = sections.iter().position(|s| s.0 == tag::TILE).unwrap();
    let expect_err = |s: &[(u8, Vec<u8>)], what: &str, is: fn(&CodecError) -> bool| {
        let file = rebuild(s);
        let e = decode(&file, &DecodeOptions::default()).unwrap_err();
        assert!(is(&e), "{what}: {e:?}");
    };
    // A tile missing.
    let mut s = sections.clone();
    s.remove(first_tile);
    expect_err(&s, "a tile missing", |e| {
        matches!(e, CodecError::SectionOrder { .. })
    });
    // The file written again with a changed header or tile.
    let tiles: Vec<_> = parsed.tiles.iter().map(|t| t.to_streams()).collect();
    let written = |edit: &dyn Fn(&mut bitstream::Header, &mut [bitstream::TileStreams])| {
        let (mut h, mut t) = (parsed.header.clone(), tiles.clone());
        edit(&mut h, &mut t);
        decode(
            &bitstream::write(&h, &parsed.metadata(), &t),
            &DecodeOptions::default(),
        )
        .unwrap_err()
    };
    assert_eq!(
        bitstream::write(&parsed.header, &parsed.metadata(), &tiles),
        bytes
    );
    // A tile's key-point count that disagrees with the header's total (one fewer: a
    // tile split down to its smallest cells has no room for one more).
    let e = written(&|_, t| t[0].luma_count -= 1);
    assert!(
        matches!(e, CodecError::CountMismatch { unit: "key points", found, declared, .. }
            if found + 1 == declared),
        "a key-point count: {e:?}"
    );
    // More key points than the tile has cells.
    let e = written(&|_, t| t[0].luma_count = 1 << 30);
    assert!(
        matches!(
            e,
            CodecError::OutOfRange {
                what: "a tile's luma key point count",
                ..
            }
        ),
        "a count past the tile's cells: {e:?}"
    );
    // A stream length past the tile's payload: the tile's fields by hand.
    let t = &parsed.tiles[0];
    let mut payload = Vec::new();
    for v in [
        t.luma_count,
        t.chroma_count,
        u32::MAX,
        t.luma.len() as u32,
        t.chroma.len() as u32,
    ] {
        caoen::codec::varint::push(&mut payload, v);
    }
    let mut s = sections.clone();
    s[first_tile].1 = [&payload[..], t.tree, t.luma, t.chroma, t.detail].concat();
    expect_err(&s, "a stream past the payload", |e| {
        matches!(
            e,
            CodecError::Truncated {
                what: "a tile's streams",
                ..
            }
        )
    });
    // A tile side of no multiple of 128.
    let e = written(&|h, _| h.tile_side = 0);
    assert!(
        matches!(
            e,
            CodecError::TileSide {
                side: 0,
                unit: 128,
                ..
            }
        ),
        "a tile side: {e:?}"
    );
    // A metadata item out of order.
    let mut s = sections.clone();
    s.insert(first_tile, (tag::EXIF, b"II*\0".to_vec()));
    s.insert(first_tile, (tag::XMP, b"<x/>".to_vec()));
    expect_err(&s, "metadata out of order", |e| {
        matches!(e, CodecError::SectionOrder { .. })
    });
}

#[test]
fn images_of_several_tiles_get_restoration_filters_that_lower_their_error() {
    let img = image_io::from_dynamic(natural(1100, 600)).unwrap();
    assert!(Tiling::choose(1100, 600).count() > 1);
    let opts = EncodeOptions {
        quality: 50.0,
        resampling: Resampling::Off,
        ..EncodeOptions::default()
    };
    let bytes = encode(&img, &opts).unwrap();
    let parsed = inspect(&bytes).unwrap();
    assert!(parsed.header.restoration.is_some());
    let without: Vec<(u8, Vec<u8>)> = parsed
        .sections
        .iter()
        .filter(|s| s.tag != tag::RESTORATION)
        .map(|s| (s.tag, s.payload.to_vec()))
        .collect();
    assert!(without.len() < parsed.sections.len());
    let error = |file: &[u8]| -> f64 {
        let d = decode(file, &DecodeOptions::default()).unwrap();
        squared_errors(&img, &d).iter().sum()
    };
    let (restored, plain) = (error(&bytes), error(&rebuild(&without)));
    // The planks' seams lie on rows by the edges of the fit's groups of bands (every
    // 48 rows): a fit that leaves those rows out smooths the seams and gains nothing
    // overall (it measured 0.14% here); with them the filters take 9% off.
    assert!(restored < 0.95 * plain, "{restored} against {plain}");
}

#[test]
fn deringing_is_chosen_where_it_lowers_the_error_at_the_coded_size_and_at_twice_it() {
    let img = image_io::from_dynamic(natural(1100, 600)).unwrap();
    // At full size, and coded at half size to be decoded at twice that (its taps and
    // blocks scaled by 2).
    for (quality, resampling) in [(30.0, Resampling::Off), (20.0, Resampling::At(Scale::HALF))] {
        let opts = EncodeOptions {
            quality,
            resampling,
            ..EncodeOptions::default()
        };
        let bytes = encode(&img, &opts).unwrap();
        let parsed = inspect(&bytes).unwrap();
        let deringing = parsed
            .header
            .deringing
            .expect("a photograph-like image is deringed");
        assert!(deringing.luma.is_on(), "{deringing:?}");
        let mut header = parsed.header.clone();
        header.deringing = None;
        let tiles: Vec<bitstream::TileStreams> =
            parsed.tiles.iter().map(|t| t.to_streams()).collect();
        let plain = bitstream::write(&header, &parsed.metadata(), &tiles);
        assert_eq!(plain.len() + 6, bytes.len(), "three bytes per plane kind");
        let error = |file: &[u8]| -> f64 {
            let d = decode(file, &DecodeOptions::default()).unwrap();
            squared_errors(&img, &d).iter().sum()
        };
        let (deringed, without) = (error(&bytes), error(&plain));
        // 0.9% at q30 and 1.2% at twice the size at q20 when written.
        assert!(
            deringed < 0.997 * without,
            "q{quality}: {deringed} against {without} ({deringing:?})"
        );
        if resampling == Resampling::Off {
            assert_eq!((header.width, header.height), (1100, 600));
        } else {
            assert_eq!(
                (header.width, header.height),
                (550, 300),
                "coded at half size"
            );
        }
    }
}

#[test]
fn metadata_items_travel_through_the_file_untouched() {
    let img = image_io::from_dynamic(natural(200, 120)).unwrap();
    let metadata = caoen::metadata::Metadata {
        icc: Some((0..=255u8).collect()),
        exif: Some(b"MM\0*\0\0\0\x08\0\0".to_vec()),
        xmp: None,
    };
    let opts = EncodeOptions {
        metadata: metadata.clone(),
        ..EncodeOptions::default()
    };
    let bytes = encode(&img, &opts).unwrap();
    let parsed = inspect(&bytes).unwrap();
    assert_eq!(parsed.metadata(), metadata);
    // The pixels do not depend on it.
    let plain = encode(&img, &EncodeOptions::default()).unwrap();
    assert_eq!(
        decode(&bytes, &DecodeOptions::default()).unwrap(),
        decode(&plain, &DecodeOptions::default()).unwrap()
    );
    let too_big = EncodeOptions {
        metadata: caoen::metadata::Metadata {
            xmp: Some(vec![b' '; caoen::metadata::MAX_ITEM_BYTES + 1]),
            ..Default::default()
        },
        ..EncodeOptions::default()
    };
    assert!(matches!(
        encode(&img, &too_big),
        Err(CodecError::Parameter {
            name: "metadata",
            ..
        })
    ));
}

#[test]
fn the_luma_basis_moves_error_out_of_luma() {
    use caoen::codec::ColourBasis;
    use caoen::codec::{encoder, rate_control};
    use caoen::metrics::{psnr, psnr_y};
    let img = image_io::from_dynamic(natural(384, 256)).unwrap();
    let share = |basis: ColourBasis| {
        let mut s = rate_control::settings(50.0, 5, None);
        s.colour_basis = basis;
        // The basis's own effect on the quantisers' error: the post filters and the
        // colour map, fitted to RGB error, mix it between the planes again.
        (s.restoration, s.deringing) = (false, false);
        let (bytes, _) = encoder::encode_with(&img, &s, &Default::default(), 2, |_, _| {}).unwrap();
        let header = bitstream::parse(&bytes, u64::MAX).unwrap().header;
        assert_eq!(header.basis, basis, "the header records the basis");
        let out = decode(&bytes, &DecodeOptions::default()).unwrap();
        let (rgb, y) = (psnr(&img, &out).unwrap(), psnr_y(&img, &out).unwrap());
        assert!(rgb > 28.0, "{basis:?}: {rgb:.2} dB");
        // Luma's share of the error, in dB: the higher, the less of it is in luma.
        y - rgb
    };
    let (grey, luma) = (share(ColourBasis::Grey), share(ColourBasis::Luma));
    assert!(
        luma > grey + 0.15,
        "luma PSNR over RGB PSNR: {luma:.2} dB luma basis, {grey:.2} grey"
    );
}

#[test]
fn the_detail_layer_is_counted_in_the_decode_budget() {
    // Fine grain coded at q100: nearly every detail block holds most of its 64 levels,
    // about 24 bytes per pixel of levels and coefficients beyond the header's estimate.
    let (w, h) = (640u32, 480u32);
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        let k =
            (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)).wrapping_mul(2_654_435_761);
        let g = (k >> 24) as u8 / 4;
        image::Rgb([100 + g, 90 + g, 80 + g])
    });
    let raster = image_io::from_dynamic(image::DynamicImage::ImageRgb8(img)).unwrap();
    let opts = EncodeOptions {
        quality: 100.0,
        ..EncodeOptions::default()
    };
    let bytes = encode(&raster, &opts).unwrap();
    let header = inspect(&bytes).unwrap().header;
    let base = caoen::codec::decoder::decode_memory(&header, (w, h), None, 4);
    let whole = DecodeOptions::default();
    let reference = decode(&bytes, &whole).unwrap();
    let largest = whole.limits.largest_checked();
    assert!(
        largest >= base + 8 * u64::from(w * h),
        "the layer's levels and coefficients counted: {largest} against {base}"
    );
    // A budget the header's estimate fits but the layer does not: refused, naming it.
    let tight = DecodeOptions {
        limits: Limits::new(base + u64::from(w * h)),
        ..DecodeOptions::default()
    };
    match decode(&bytes, &tight) {
        Err(CodecError::Memory(e)) => {
            assert!(e.what.contains("with its detail layer"), "{}", e.what);
            assert!(e.need > e.budget, "{e}");
        }
        other => panic!("{other:?}"),
    }
    // Exactly the largest need checked: decodes, the same samples.
    let exact = DecodeOptions {
        limits: Limits::new(largest),
        ..DecodeOptions::default()
    };
    assert_eq!(decode(&bytes, &exact).unwrap(), reference);
}
