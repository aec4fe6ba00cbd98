//! Image metadata carried through the codec beside the pixels: the ICC colour profile,
//! EXIF and XMP, stored verbatim in their own container sections (`docs/format.md`).
//!
//! `exif` reads EXIF only as far as its orientation: a bounded walker over the TIFF
//! structure that never follows an offset outside the block, never allocates by a
//! declared count, and stops a directory chain that loops; `container` finds the items
//! in JPEG, PNG and WebP files, `xmp_ext` joins a JPEG's extended XMP into its main
//! packet, `png` writes them as PNG chunks.

mod container;
mod exif;
mod fit;
mod png;
mod xmp_ext;

pub use container::{read_container, read_container_lenient};
pub use exif::{ifd_chain, orientation, reset_orientation, with_orientation_one};
pub use fit::{icc_colour_space, xmp_with_orientation_one, Dropped};
pub use png::{insert_png_chunks, png_chunks};

use thiserror::Error;

/// Largest metadata item (one ICC profile, EXIF block or XMP packet) read or stored.
pub const MAX_ITEM_BYTES: usize = 16 << 20;

/// Longest chain of TIFF directories (IFD0, IFD1, ...) followed; cameras write two.
pub const MAX_IFDS: usize = 64;

/// The TIFF tag of the EXIF orientation.
pub const ORIENTATION_TAG: u16 = 0x0112;

/// The TIFF field type SHORT (an unsigned 16-bit value), the orientation's type.
pub const TYPE_SHORT: u16 = 3;

/// The metadata of one image, each item as the bytes its own standard defines.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Metadata {
    /// ICC colour profile.
    pub icc: Option<Vec<u8>>,
    /// EXIF, as the TIFF structure (starting with `II*\0` or `MM\0*`).
    pub exif: Option<Vec<u8>>,
    /// XMP packet (UTF-8 XML).
    pub xmp: Option<Vec<u8>>,
}

impl Metadata {
    /// Bytes of the items together.
    pub fn bytes(&self) -> u64 {
        [&self.icc, &self.exif, &self.xmp]
            .iter()
            .map(|m| m.as_ref().map_or(0, |b| b.len() as u64))
            .sum()
    }

    /// Whether no item is present.
    pub fn is_empty(&self) -> bool {
        self.icc.is_none() && self.exif.is_none() && self.xmp.is_none()
    }

    /// The items a policy keeps.
    pub fn filtered(&self, policy: MetadataPolicy) -> Metadata {
        match policy {
            MetadataPolicy::None => Metadata::default(),
            MetadataPolicy::Icc => Metadata {
                icc: self.icc.clone(),
                ..Metadata::default()
            },
            MetadataPolicy::All => self.clone(),
        }
    }

    /// Rejects an item over [`MAX_ITEM_BYTES`].
    pub fn check_sizes(&self) -> Result<(), MetadataError> {
        for (item, bytes) in [
            (Item::Icc, &self.icc),
            (Item::Exif, &self.exif),
            (Item::Xmp, &self.xmp),
        ] {
            if let Some(b) = bytes {
                check_size(item, b.len() as u64)?;
            }
        }
        Ok(())
    }

    /// The EXIF orientation (1 to 8), if the EXIF has a valid one.
    pub fn orientation(&self) -> Result<Option<u16>, MetadataError> {
        self.exif.as_deref().map_or(Ok(None), orientation)
    }
}

/// Which metadata items are kept (`--metadata none|icc|all`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum MetadataPolicy {
    /// None: the pixels alone.
    None,
    /// The colour profile alone, which the pixels need to mean the right colours.
    Icc,
    /// ICC, EXIF and XMP.
    #[default]
    All,
}

impl MetadataPolicy {
    /// Whether the policy keeps items of this kind.
    pub fn keeps(self, item: Item) -> bool {
        match self {
            MetadataPolicy::None => false,
            MetadataPolicy::Icc => item == Item::Icc,
            MetadataPolicy::All => true,
        }
    }

    /// Parses `none`, `icc` or `all`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "none" => Some(MetadataPolicy::None),
            "icc" => Some(MetadataPolicy::Icc),
            "all" => Some(MetadataPolicy::All),
            _ => None,
        }
    }
}

/// One kind of metadata item, for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Item {
    /// The ICC profile.
    Icc,
    /// The EXIF block.
    Exif,
    /// The XMP packet.
    Xmp,
    /// The extension of a JPEG's XMP packet (`xmpNote:HasExtendedXMP`), joined into it.
    XmpExtension,
}

impl std::fmt::Display for Item {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Item::Icc => "ICC profile",
            Item::Exif => "EXIF",
            Item::Xmp => "XMP packet",
            Item::XmpExtension => "extended XMP",
        })
    }
}

/// Why a metadata item could not be read.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MetadataError {
    /// The item (as declared, or as read) is over [`MAX_ITEM_BYTES`].
    #[error("{item} of {bytes} bytes is over the limit of {max} bytes")]
    TooLarge {
        /// Which item.
        item: Item,
        /// Its declared or actual size.
        bytes: u64,
        /// The limit.
        max: usize,
    },
    /// A compressed item inflates past [`MAX_ITEM_BYTES`].
    #[error("{item} inflates past the limit of {max} bytes")]
    InflatesTooLarge {
        /// Which item.
        item: Item,
        /// The limit.
        max: usize,
    },
    /// The EXIF block does not start with a TIFF header.
    #[error("EXIF does not start with a TIFF header (II*\\0 or MM\\0*) but with {start:02x?}")]
    NotTiff {
        /// Its first bytes (up to 4).
        start: Vec<u8>,
    },
    /// An EXIF offset or directory reaches past the end of the block.
    #[error("EXIF {what} at offset {offset} needs {need} bytes, the block has {len}")]
    OutOfBounds {
        /// What was being read.
        what: &'static str,
        /// Where it starts.
        offset: u64,
        /// Bytes it needs from there.
        need: u64,
        /// The block's length.
        len: usize,
    },
    /// The EXIF directory chain comes back to a directory already read.
    #[error("EXIF directory chain loops back to offset {offset}")]
    IfdLoop {
        /// The directory met twice.
        offset: u64,
    },
    /// The EXIF directory chain is longer than [`MAX_IFDS`].
    #[error("EXIF directory chain is longer than {max} directories")]
    TooManyIfds {
        /// The limit.
        max: usize,
    },
    /// The file's container around the item is damaged.
    #[error("{item}: {reason}")]
    Corrupt {
        /// Which item, or the container.
        item: &'static str,
        /// What is wrong, with the offending values.
        reason: String,
    },
}

/// Rejects an item size over [`MAX_ITEM_BYTES`].
pub fn check_size(item: Item, bytes: u64) -> Result<(), MetadataError> {
    if bytes > MAX_ITEM_BYTES as u64 {
        return Err(MetadataError::TooLarge {
            item,
            bytes,
            max: MAX_ITEM_BYTES,
        });
    }
    Ok(())
}

/// The error for a metadata item that is damaged, with what is wrong with it.
pub fn corrupt(item: &'static str, reason: String) -> MetadataError {
    MetadataError::Corrupt { item, reason }
}

/// EXIF blocks some writers start with the JPEG APP1 prefix even outside JPEG.
pub fn strip_exif_prefix(b: &[u8]) -> &[u8] {
    b.strip_prefix(b"Exif\0\0").unwrap_or(b)
}

#[cfg(test)]
mod tests {
    use super::container::PNG_SIGNATURE;
    use super::png::png_chunk;
    use super::*;

    /// A TIFF block with IFD0 holding `entries` (tag, type, count, value) and linking
    /// to `next`.
    fn tiff(little: bool, entries: &[(u16, u16, u32, u32)], next: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let u16b = |v: u16| {
            if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        let u32b = |v: u32| {
            if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        out.extend_from_slice(if little { b"II*\0" } else { b"MM\0*" });
        out.extend_from_slice(&u32b(8));
        out.extend_from_slice(&u16b(entries.len() as u16));
        for &(tag, kind, count, value) in entries {
            out.extend_from_slice(&u16b(tag));
            out.extend_from_slice(&u16b(kind));
            out.extend_from_slice(&u32b(count));
            if kind == TYPE_SHORT && count == 1 {
                // A SHORT sits in the first two bytes of the value field.
                out.extend_from_slice(&u16b(value as u16));
                out.extend_from_slice(&[0, 0]);
            } else {
                out.extend_from_slice(&u32b(value));
            }
        }
        out.extend_from_slice(&u32b(next));
        out
    }

    #[test]
    fn orientation_in_both_byte_orders() {
        for little in [true, false] {
            let exif = tiff(
                little,
                &[(0x010f, 2, 4, 0), (ORIENTATION_TAG, TYPE_SHORT, 1, 6)],
                0,
            );
            assert_eq!(orientation(&exif), Ok(Some(6)), "little endian: {little}");
            let reset = with_orientation_one(&exif);
            assert_eq!(orientation(&reset), Ok(Some(1)));
            assert_eq!(reset.len(), exif.len());
            let changed = exif.iter().zip(&reset).filter(|(a, b)| a != b).count();
            assert_eq!(changed, 1, "only the value's low byte changes");
        }
    }

    #[test]
    fn absent_or_odd_orientation_is_none() {
        let none = tiff(true, &[(0x010f, 2, 4, 0)], 0);
        assert_eq!(orientation(&none), Ok(None));
        let long = tiff(true, &[(ORIENTATION_TAG, 4, 1, 6)], 0);
        assert_eq!(orientation(&long), Ok(None));
        let nine = tiff(false, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 9)], 0);
        assert_eq!(orientation(&nine), Ok(None));
        let mut same = none.clone();
        assert_eq!(reset_orientation(&mut same), Ok(None));
        assert_eq!(same, none);
    }

    #[test]
    fn cyclic_chain_is_an_error_and_orientation_still_reads() {
        // IFD0 at 8 links to itself.
        let exif = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 3)], 8);
        assert_eq!(ifd_chain(&exif), Err(MetadataError::IfdLoop { offset: 8 }));
        assert_eq!(orientation(&exif), Ok(Some(3)));
        // Two directories linking to each other.
        let mut two = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 3)], 26);
        two.extend_from_slice(&[0, 0, 8, 0, 0, 0]);
        assert_eq!(two.len(), 32);
        assert_eq!(ifd_chain(&two), Err(MetadataError::IfdLoop { offset: 8 }));
        let chain = ifd_chain(&tiff(true, &[], 0)).expect("one directory");
        assert_eq!(chain, vec![8]);
    }

    #[test]
    fn long_chain_stops_at_the_limit() {
        // Directories of no entries, each linking to the next, MAX_IFDS + 1 of them.
        let mut exif = b"II*\0".to_vec();
        exif.extend_from_slice(&8u32.to_le_bytes());
        for i in 0..=MAX_IFDS as u32 {
            exif.extend_from_slice(&0u16.to_le_bytes());
            exif.extend_from_slice(&(8 + 6 * (i + 1)).to_le_bytes());
        }
        exif.extend_from_slice(&[0; 6]);
        assert_eq!(
            ifd_chain(&exif),
            Err(MetadataError::TooManyIfds { max: MAX_IFDS })
        );
    }

    #[test]
    fn truncated_and_huge_counts_are_errors() {
        let exif = tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 6)], 0);
        for cut in 0..exif.len() - 4 {
            let r = orientation(&exif[..cut]);
            assert!(r.is_err(), "cut at {cut}: {r:?}");
        }
        // The link may be missing: the chain ends there.
        assert_eq!(orientation(&exif[..exif.len() - 4]), Ok(Some(6)));
        // 65535 entries declared in a 26-byte block.
        let mut huge = exif.clone();
        huge[8..10].copy_from_slice(&u16::MAX.to_le_bytes());
        assert!(matches!(
            orientation(&huge),
            Err(MetadataError::OutOfBounds { need: 786_422, .. })
        ));
        assert!(ifd_chain(&huge).is_err());
        // IFD0 far past the end, and at the very top of the offset range.
        for off in [1000u32, u32::MAX] {
            let mut far = exif.clone();
            far[4..8].copy_from_slice(&off.to_le_bytes());
            assert!(matches!(
                orientation(&far),
                Err(MetadataError::OutOfBounds { .. })
            ));
        }
        assert!(matches!(
            orientation(b"JFIF"),
            Err(MetadataError::NotTiff { .. })
        ));
        assert!(matches!(
            orientation(b""),
            Err(MetadataError::NotTiff { .. })
        ));
    }

    #[test]
    fn filtering_keeps_what_the_policy_names() {
        let all = Metadata {
            icc: Some(vec![1]),
            exif: Some(vec![2]),
            xmp: Some(vec![3]),
        };
        assert!(all.filtered(MetadataPolicy::None).is_empty());
        let icc = all.filtered(MetadataPolicy::Icc);
        assert_eq!(
            (icc.icc.as_deref(), icc.exif, icc.xmp),
            (Some(&[1u8][..]), None, None)
        );
        assert_eq!(all.filtered(MetadataPolicy::All), all);
        assert_eq!(MetadataPolicy::parse("icc"), Some(MetadataPolicy::Icc));
        assert_eq!(MetadataPolicy::parse("ICC"), None);
        let big = Metadata {
            xmp: Some(vec![0; MAX_ITEM_BYTES + 1]),
            ..Metadata::default()
        };
        assert!(matches!(
            big.check_sizes(),
            Err(MetadataError::TooLarge {
                item: Item::Xmp,
                ..
            })
        ));
    }

    fn jpeg_with(segments: &[(u8, Vec<u8>)]) -> Vec<u8> {
        let mut out = vec![0xff, 0xd8];
        for (marker, payload) in segments {
            out.extend_from_slice(&[0xff, *marker]);
            out.extend_from_slice(&(payload.len() as u16 + 2).to_be_bytes());
            out.extend_from_slice(payload);
        }
        out.extend_from_slice(&[0xff, 0xd9]);
        out
    }

    fn icc_chunk(seq: u8, count: u8, data: &[u8]) -> (u8, Vec<u8>) {
        let mut p = b"ICC_PROFILE\0".to_vec();
        p.extend_from_slice(&[seq, count]);
        p.extend_from_slice(data);
        (0xe2, p)
    }

    #[test]
    fn jpeg_icc_chunks_join_in_sequence_order() {
        let mut profile = vec![0u8; 300];
        profile[..4].copy_from_slice(&300u32.to_be_bytes());
        profile
            .iter_mut()
            .skip(4)
            .enumerate()
            .for_each(|(i, b)| *b = i as u8);
        let (a, b) = profile.split_at(100);
        let jpeg = jpeg_with(&[icc_chunk(2, 2, b), icc_chunk(1, 2, a)]);
        let meta = read_container(&jpeg).unwrap();
        assert_eq!(meta.icc, Some(profile.clone()));
        // A chunk missing, or counts that disagree.
        for bad in [
            jpeg_with(&[icc_chunk(1, 2, a)]),
            jpeg_with(&[icc_chunk(1, 2, a), icc_chunk(2, 3, b)]),
            jpeg_with(&[icc_chunk(1, 2, a), icc_chunk(1, 2, a)]),
        ] {
            assert!(
                matches!(
                    read_container(&bad),
                    Err(MetadataError::Corrupt {
                        item: "ICC profile",
                        ..
                    })
                ),
                "{:?}",
                read_container(&bad)
            );
        }
    }

    #[test]
    fn jpeg_exif_and_xmp_segments() {
        let exif = tiff(false, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 8)], 0);
        let xmp = b"<x:xmpmeta/>".to_vec();
        let jpeg = jpeg_with(&[
            (0xe0, b"JFIF\0\x01\x02".to_vec()),
            (0xe1, [b"Exif\0\0".as_slice(), &exif].concat()),
            (
                0xe1,
                [b"http://ns.adobe.com/xap/1.0/\0".as_slice(), &xmp].concat(),
            ),
        ]);
        let meta = read_container(&jpeg).unwrap();
        assert_eq!(meta.exif, Some(exif));
        assert_eq!(meta.xmp, Some(xmp));
        assert_eq!(meta.icc, None);
        assert_eq!(meta.orientation(), Ok(Some(8)));
        // Every prefix of the file is read without a panic.
        for cut in 0..jpeg.len() {
            let _ = read_container(&jpeg[..cut]);
        }
    }

    #[test]
    fn webp_chunks_with_padding() {
        let mut riff = b"RIFF\0\0\0\0WEBP".to_vec();
        for (kind, data) in [
            (b"VP8X", vec![0u8; 10]),
            (b"ICCP", vec![1, 2, 3]),
            (
                b"EXIF",
                [b"Exif\0\0".as_slice(), b"MM\0*\0\0\0\x08\0\0"].concat(),
            ),
            (b"XMP ", b"<x/>".to_vec()),
        ] {
            riff.extend_from_slice(kind);
            riff.extend_from_slice(&(data.len() as u32).to_le_bytes());
            riff.extend_from_slice(&data);
            if data.len() % 2 == 1 {
                riff.push(0);
            }
        }
        let meta = read_container(&riff).unwrap();
        assert_eq!(meta.icc, Some(vec![1, 2, 3]));
        assert_eq!(meta.exif.as_deref(), Some(&b"MM\0*\0\0\0\x08\0\0"[..]));
        assert_eq!(meta.xmp, Some(b"<x/>".to_vec()));
        let mut lying = riff.clone();
        lying[16..20].copy_from_slice(&1000u32.to_le_bytes());
        assert!(matches!(
            read_container(&lying),
            Err(MetadataError::Corrupt { item: "WebP", .. })
        ));
        let mut huge = riff[..12].to_vec();
        huge.extend_from_slice(b"ICCP");
        huge.extend_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            read_container(&huge),
            Err(MetadataError::TooLarge {
                item: Item::Icc,
                bytes: 4_294_967_295,
                ..
            })
        ));
    }

    #[test]
    fn png_chunks_read_back() {
        let meta = Metadata {
            icc: Some(vec![
                0, 0, 0, 20, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
            ]),
            exif: Some(tiff(true, &[(ORIENTATION_TAG, TYPE_SHORT, 1, 1)], 0)),
            xmp: Some(b"<x/>".to_vec()),
        };
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"IEND", &[]);
        insert_png_chunks(&mut png, &meta).unwrap();
        assert_eq!(read_container(&png).unwrap(), meta);
        for cut in 0..png.len() {
            let _ = read_container(&png[..cut]);
        }
        // A compressed XMP packet is inflated.
        let mut data = b"XML:com.adobe.xmp\0\x01\0\0\0".to_vec();
        data.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(
            b"<x:packed/>",
            6,
        ));
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"iTXt", &data);
        assert_eq!(
            read_container(&png).unwrap().xmp,
            Some(b"<x:packed/>".to_vec())
        );
    }

    /// A JPEG, a PNG and a WebP each carrying all three items.
    fn samples() -> [Vec<u8>; 3] {
        let exif = tiff(
            true,
            &[(0x010f, 2, 4, 0), (ORIENTATION_TAG, TYPE_SHORT, 1, 6)],
            0,
        );
        let jpeg = jpeg_with(&[
            (0xe1, [b"Exif\0\0".as_slice(), &exif].concat()),
            (0xe1, b"http://ns.adobe.com/xap/1.0/\0<x/>".to_vec()),
            icc_chunk(1, 1, &[0, 0, 0, 8, 1, 2, 3, 4]),
        ]);
        let meta = Metadata {
            icc: Some(vec![0, 0, 0, 8, 1, 2, 3, 4]),
            exif: Some(exif.clone()),
            xmp: Some(b"<x/>".to_vec()),
        };
        let mut png = PNG_SIGNATURE.to_vec();
        png_chunk(&mut png, b"IHDR", &[0; 13]);
        png_chunk(&mut png, b"IEND", &[]);
        insert_png_chunks(&mut png, &meta).unwrap();
        let mut webp = b"RIFF\0\0\0\0WEBP".to_vec();
        for (kind, data) in [
            (b"ICCP", &meta.icc),
            (b"EXIF", &meta.exif),
            (b"XMP ", &meta.xmp),
        ] {
            let data = data.as_ref().unwrap();
            webp.extend_from_slice(kind);
            webp.extend_from_slice(&(data.len() as u32).to_le_bytes());
            webp.extend_from_slice(data);
        }
        [jpeg, png, webp]
    }

    fn exercise(bytes: &[u8]) {
        if let Ok(meta) = read_container(bytes) {
            assert!(meta.check_sizes().is_ok());
            if let Some(mut exif) = meta.exif {
                let before = orientation(&exif);
                let _ = ifd_chain(&exif);
                let reset = reset_orientation(&mut exif);
                assert_eq!(before.is_ok(), reset.is_ok());
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]

        #[test]
        fn damaged_containers_never_panic(
            which in 0usize..3,
            flips in proptest::collection::vec((0usize..4096, proptest::prelude::any::<u8>()), 1..6),
            cut in 0usize..4096,
        ) {
            let mut b = samples()[which].clone();
            for (at, v) in flips {
                let n = b.len();
                b[at % n] = v;
            }
            b.truncate(cut.max(2));
            exercise(&b);
        }

        #[test]
        fn any_exif_block_is_walked_safely(
            little in proptest::prelude::any::<bool>(),
            body in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
        ) {
            let mut exif = if little { b"II*\0".to_vec() } else { b"MM\0*".to_vec() };
            exif.extend_from_slice(&body);
            let o = orientation(&exif);
            let _ = ifd_chain(&exif);
            let mut copy = exif.clone();
            let old = reset_orientation(&mut copy);
            if let (Ok(Some(v)), Ok(Some(w))) = (o, old) {
                proptest::prop_assert_eq!(v, w);
            }
        }
    }
}
