//! The `image` crate reads `.cae` files after `caoen::register_image_hooks()`: by
//! extension (`image::open`), by magic bytes (format guessing), with the stored
//! metadata, and to the same samples as `caoen::decode`.

use std::io::Cursor;

use caoen::{ChannelLayout, DecodeOptions, EncodeOptions, Metadata, Raster, SampleFormat};
use image::{ColorType, ImageDecoder, ImageReader};

fn wave(w: u32, h: u32, layout: ChannelLayout, format: SampleFormat) -> Raster {
    let n = (w * h) as usize;
    let max = match format {
        SampleFormat::U8 => 255.0,
        SampleFormat::U16 => 65535.0,
        SampleFormat::F32 => 1.0,
    };
    let samples = (0..n * layout.channels())
        .map(|i| {
            let (p, c) = (i % n, (i / n) as f32);
            let (x, y) = ((p as u32 % w) as f32, (p as u32 / w) as f32);
            let v = 0.5 + 0.4 * (x * 0.17 + c).sin() * (y * 0.11 - c).cos();
            if format == SampleFormat::F32 {
                v * 4.0
            } else {
                (v * max).round() / max
            }
        })
        .collect();
    Raster::new(w, h, layout, format, samples).unwrap()
}

/// Interleaves a raster as the `image` crate's buffers hold it (grey floats into RGB).
fn interleaved_f32(r: &Raster) -> Vec<f32> {
    let sources: &[usize] = match r.layout() {
        ChannelLayout::Grey => &[0, 0, 0],
        ChannelLayout::GreyAlpha => &[0, 0, 0, 1],
        ChannelLayout::Rgb => &[0, 1, 2],
        ChannelLayout::Rgba => &[0, 1, 2, 3],
    };
    (0..r.pixel_count())
        .flat_map(|i| sources.iter().map(move |&c| r.plane(c)[i]))
        .collect()
}

#[test]
fn image_open_reads_cae_files_as_caoen_decodes_them() {
    caoen::register_image_hooks();
    // A second call changes nothing.
    assert!(!caoen::register_image_hooks());
    let dir = std::env::temp_dir().join(format!("caoen-image-hooks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (layout, format, colour) in [
        (ChannelLayout::Rgb, SampleFormat::U8, ColorType::Rgb8),
        (ChannelLayout::Grey, SampleFormat::U8, ColorType::L8),
        (ChannelLayout::Rgba, SampleFormat::U16, ColorType::Rgba16),
        (ChannelLayout::Rgb, SampleFormat::F32, ColorType::Rgb32F),
        (ChannelLayout::Grey, SampleFormat::F32, ColorType::Rgb32F),
    ] {
        let name = format!("{layout:?}-{format:?}");
        // Encode a PNG (or EXR) file with caoen, as a user would.
        let ext = if format == SampleFormat::F32 {
            "exr"
        } else {
            "png"
        };
        let input = dir.join(format!("{name}.{ext}"));
        caoen::save(&wave(53, 38, layout, format), &input).unwrap();
        let image = caoen::load(&input).unwrap();
        let bytes = caoen::encode(&image, &EncodeOptions::default()).unwrap();
        let cae = dir.join(format!("{name}.cae"));
        std::fs::write(&cae, &bytes).unwrap();
        let reference = caoen::decode(&bytes, &DecodeOptions::default()).unwrap();

        let opened = image::open(&cae).unwrap();
        assert_eq!(opened.color(), colour, "{name}");
        assert_eq!((opened.width(), opened.height()), (53, 38), "{name}");
        match format {
            SampleFormat::F32 => {
                assert_eq!(
                    opened.as_bytes().len(),
                    53 * 38 * 4 * colour.channel_count() as usize
                );
                let got: Vec<f32> = opened
                    .as_bytes()
                    .chunks_exact(4)
                    .map(|b| f32::from_ne_bytes(b.try_into().unwrap()))
                    .collect();
                assert_eq!(got, interleaved_f32(&reference), "{name}");
            }
            _ => {
                // The same samples `caoen decode` writes to PNG.
                let png = caoen::image_io::encode(
                    &reference,
                    caoen::image_io::OutputFormat::natural(format),
                )
                .unwrap();
                let expected = image::load_from_memory(&png).unwrap();
                assert!(opened == expected, "{name}");
            }
        }

        // By the magic bytes alone, whatever the name says.
        let guessed = ImageReader::new(Cursor::new(&bytes))
            .with_guessed_format()
            .unwrap()
            .decode()
            .unwrap();
        assert!(guessed == opened, "{name} guessed by its magic bytes");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_decoder_gives_the_stored_metadata() {
    let image = wave(16, 16, ChannelLayout::Rgb, SampleFormat::U8);
    let metadata = Metadata {
        icc: Some(b"not really a profile".to_vec()),
        exif: None,
        xmp: Some(b"<x:xmpmeta/>".to_vec()),
    };
    let options = EncodeOptions {
        metadata: metadata.clone(),
        ..EncodeOptions::default()
    };
    let bytes = caoen::encode(&image, &options).unwrap();
    let mut decoder = caoen::CaeDecoder::new(Cursor::new(bytes)).unwrap();
    assert_eq!(decoder.icc_profile().unwrap(), metadata.icc);
    assert_eq!(decoder.exif_metadata().unwrap(), None);
    assert_eq!(decoder.xmp_metadata().unwrap(), metadata.xmp);
}

#[test]
fn a_broken_file_is_an_image_error_not_a_panic() {
    let image = wave(16, 16, ChannelLayout::Rgb, SampleFormat::U8);
    let mut bytes = caoen::encode(&image, &EncodeOptions::default()).unwrap();
    let last = bytes.len() - 20;
    bytes[last] ^= 0x55;
    let e = caoen::CaeDecoder::new(Cursor::new(bytes)).unwrap_err();
    assert!(matches!(e, image::ImageError::Decoding(_)), "{e:?}");
}
