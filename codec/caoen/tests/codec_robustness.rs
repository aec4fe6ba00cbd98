//! Bad input: every prefix and every single-bit flip of a valid file decodes to a clean
//! error or a bounded image, never a panic, hang or huge allocation; wrong magic,
//! future versions and absurd headers give clear messages.

mod common;

use caoen::codec::bitstream::{self, VERSION};
use caoen::codec::{decode, encode, CodecError, DecodeOptions, EncodeOptions};
use caoen::raster::{ChannelLayout, Raster, SampleFormat};

fn small_file() -> Vec<u8> {
    let (w, h) = (21u32, 13u32);
    let n = (w * h) as usize;
    let samples: Vec<f32> = (0..4 * n)
        .map(|i| ((i * 37) % 101) as f32 / 100.0)
        .collect();
    let img = Raster::new(w, h, ChannelLayout::Rgba, SampleFormat::U8, samples).unwrap();
    encode(&img, &common::at_quality(60.0)).unwrap()
}

#[test]
fn every_prefix_is_a_clean_error() {
    let file = small_file();
    for len in 0..file.len() {
        let r = decode(&file[..len], &DecodeOptions::default());
        assert!(r.is_err(), "prefix of {len}/{} bytes decoded", file.len());
    }
    assert!(decode(&file, &DecodeOptions::default()).is_ok());
}

#[test]
fn every_single_bit_flip_is_caught_or_bounded() {
    let file = small_file();
    let mut decoded = 0;
    for i in 0..file.len() {
        for bit in 0..8 {
            let mut f = file.clone();
            f[i] ^= 1 << bit;
            match decode(&f, &DecodeOptions::default()) {
                Err(_) => {}
                // A flip the CRC cannot see (none expected) must still stay bounded.
                Ok(img) => {
                    decoded += 1;
                    assert!(img.pixel_count() <= 21 * 13);
                }
            }
        }
    }
    assert_eq!(decoded, 0, "CRC-32 catches every single-bit flip");
}

#[test]
fn bad_headers_have_clear_messages() {
    let file = small_file();
    let msg = |f: &[u8]| {
        decode(f, &DecodeOptions::default())
            .unwrap_err()
            .to_string()
    };
    let mut wrong = file.clone();
    wrong[0] = b'X';
    assert!(msg(&wrong).contains("magic"), "{}", msg(&wrong));
    let e = decode(&wrong, &DecodeOptions::default()).unwrap_err();
    assert!(
        matches!(&e, CodecError::WrongMagic { found } if found == b"XAOE"),
        "{e}"
    );
    let mut future = file.clone();
    future[4] = VERSION + 1;
    let e = decode(&future, &DecodeOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            CodecError::UnsupportedVersion {
                found,
                supported: VERSION
            } if found == VERSION + 1
        ) && e.to_string().contains(&format!("version {}", VERSION + 1)),
        "{e}"
    );
    // Files of earlier versions are refused, with the way out.
    for version in 2..VERSION {
        let mut old = file.clone();
        old[4] = version;
        let e = decode(&old, &DecodeOptions::default()).unwrap_err();
        assert!(
            matches!(e, CodecError::UnsupportedVersion { found, supported: VERSION } if found == version)
                && e.to_string().contains("re-encode"),
            "{e}"
        );
    }
    // The header section: tag at byte 5, its length as one LEB128 byte at 6, the
    // payload from 7. The payload: width, height (one LEB128 byte each here), channel
    // byte, levels, footprint (2), exponent, flags at 7, the luma, chroma and alpha
    // steps (2 each), key point counts (1 each here), tile side, the detail steps (2
    // each), deblocking (2) at 21, step factors (3) and region side at 23, lapping
    // weight at 27, tilts (2): 30 bytes.
    assert_eq!(file[5], b'H');
    let hl = file[6] as usize;
    assert_eq!(
        hl, 30,
        "the small file's detail layer is deblocked and lapped, its steps adapt and tilt"
    );
    let payload = file[7..7 + hl].to_vec();
    // The file with another header payload, its length and CRC made to match.
    let with_payload = |p: &[u8]| {
        let mut f = file[..5].to_vec();
        bitstream::push_section(&mut f, bitstream::tag::HEADER, p);
        [&f[..], &file[7 + hl + 4..]].concat()
    };
    assert_eq!(with_payload(&payload), file);
    // Absurd size with a valid CRC: width 2^31, five LEB128 bytes.
    let absurd = with_payload(&[&[128, 128, 128, 128, 8], &payload[1..]].concat());
    let e = decode(&absurd, &DecodeOptions::default()).unwrap_err();
    assert!(
        matches!(e, CodecError::OutOfRange { what: "width", value, hi, .. } if value == 2147483648.0 && hi == 16384.0),
        "{e}"
    );
    // A width in more bytes than it needs is refused: one form per value.
    let e = decode(
        &with_payload(&[&[21 | 128, 0], &payload[1..]].concat()),
        &DecodeOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            CodecError::Varint {
                what: "the width",
                offset: 7
            }
        ),
        "{e}"
    );
    // A wrong CRC names both values.
    let mut flipped = file.clone();
    flipped[7] ^= 1;
    let stored = u32::from_le_bytes(file[7 + hl..7 + hl + 4].try_into().unwrap());
    let e = decode(&flipped, &DecodeOptions::default()).unwrap_err();
    assert!(
        matches!(e, CodecError::CrcMismatch { offset: 5, stored: s, computed, .. } if s == stored && computed != stored),
        "{e}"
    );
    // Deblocking parameters, step factors or the lapping weight out of range, or any
    // of them without the detail layer.
    let with_header = |edit: &dyn Fn(&mut [u8])| {
        let mut p = payload.clone();
        edit(&mut p);
        decode(&with_payload(&p), &DecodeOptions::default()).unwrap_err()
    };
    for (at, value) in [(21, 0u8), (22, 0), (22, 17)] {
        let e = with_header(&|h: &mut [u8]| h[at] = value);
        assert!(
            matches!(e, CodecError::Deblock { strength, radius } if [strength, radius][at - 21] == value),
            "{e}"
        );
    }
    for at in 23..26 {
        let e = with_header(&|h: &mut [u8]| h[at] = 0);
        assert!(
            matches!(e, CodecError::AdaptiveSteps { factors, .. } if factors[at - 23] == 0),
            "{e}"
        );
    }
    for value in [1u8, 2, 8, 255] {
        let e = with_header(&|h: &mut [u8]| h[26] = value);
        assert!(
            matches!(e, CodecError::AdaptiveSteps { field_log2, .. } if field_log2 == value),
            "{e}"
        );
    }
    for value in [0u8, 128, 255] {
        let e = with_header(&|h: &mut [u8]| h[27] = value);
        assert!(
            matches!(e, CodecError::OutOfRange { what: "lapping weight", value: v, lo, hi } if v == value as f64 && (lo, hi) == (1.0, 127.0)),
            "{e}"
        );
    }
    let e = with_header(&|h: &mut [u8]| h[7] &= !2);
    assert!(
        matches!(e, CodecError::Flags { flags } if flags & 156 == 156),
        "{e}"
    );
    // Without their flags the factors, the lapping weight and the tilts are bytes the
    // header does not have room for.
    for (flag, expected) in [(8u8, 26u64), (16, 29), (128, 28)] {
        let e = with_header(&|h: &mut [u8]| h[7] &= !flag);
        assert!(
            matches!(e, CodecError::HeaderLength { found: 30, expected: x } if x == expected),
            "flag {flag}: {e}"
        );
    }
    // The channel byte's top bit is reserved.
    let e = with_header(&|h: &mut [u8]| h[2] |= 128);
    assert!(matches!(e, CodecError::OutOfRange { .. }), "{e}");
    // The luma basis (bit 5) is the encoder's choice for colour; it needs three colour
    // channels, so a grey file that claims it is refused.
    assert_ne!(
        payload[7] & 32,
        0,
        "an RGBA file is coded in the luma basis"
    );
    let e = with_header(&|h: &mut [u8]| h[2] = 2);
    assert!(
        matches!(e, CodecError::Flags { flags } if flags & 32 == 32)
            && e.to_string().contains("bit 5 luma basis"),
        "{e}"
    );
    // A cut file says where and how much is missing.
    let e = decode(&file[..file.len() - 3], &DecodeOptions::default()).unwrap_err();
    assert!(matches!(e, CodecError::Truncated { .. }), "{e}");
    // Within the format but over the caller's pixel limit.
    let e = decode(
        &file,
        &DecodeOptions {
            max_pixels: 100,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, CodecError::Limit { .. }), "{e}");
    assert!(matches!(
        decode(b"", &DecodeOptions::default()),
        Err(CodecError::Truncated {
            need: 4,
            available: 0,
            ..
        })
    ));
    assert!(matches!(
        decode(
            &[file.as_slice(), b"junk"].concat(),
            &DecodeOptions::default()
        ),
        Err(CodecError::TrailingData { bytes: 4 })
    ));
}

#[test]
fn empty_and_non_finite_images_are_rejected_before_encoding() {
    assert!(Raster::new(0, 5, ChannelLayout::Grey, SampleFormat::U8, vec![]).is_err());
    assert!(Raster::new(1, 1, ChannelLayout::Grey, SampleFormat::F32, vec![f32::NAN]).is_err());
    let img = Raster::new(2, 2, ChannelLayout::Grey, SampleFormat::U8, vec![0.5; 4]).unwrap();
    for bad in [
        EncodeOptions {
            quality: 101.0,
            ..Default::default()
        },
        EncodeOptions {
            effort: 0,
            ..Default::default()
        },
        EncodeOptions {
            keypoints: Some(0),
            ..Default::default()
        },
        EncodeOptions {
            target: Some(caoen::codec::RateTarget::BitsPerPixel(f64::NAN)),
            ..Default::default()
        },
    ] {
        assert!(
            matches!(encode(&img, &bad), Err(CodecError::Parameter { .. })),
            "{bad:?}"
        );
    }
}
