//! What an image file may carry: an item that would make the file one that caoen or
//! another reader refuses is left out, and named with the reason, so that every file
//! caoen writes is one that readers read.

use super::{orientation, Item, Metadata};

/// Smallest ICC profile: its 128-byte header.
const ICC_HEADER: usize = 128;

/// A metadata item left out of a file, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Dropped {
    /// Which item.
    pub item: Item,
    /// Why it does not fit, with the offending values.
    pub reason: String,
}

impl std::fmt::Display for Dropped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} left out: {}", self.item, self.reason)
    }
}

/// The colour space an ICC profile declares for its data (header bytes 16..20), if
/// the bytes are a profile at all.
pub fn icc_colour_space(icc: &[u8]) -> Result<[u8; 4], String> {
    if icc.len() < ICC_HEADER {
        return Err(format!(
            "{} bytes are shorter than a profile's {ICC_HEADER}-byte header",
            icc.len()
        ));
    }
    // A PNG reader checks this size before inflating the profile: one declaring more
    // than an item may hold would not read back from the PNG it is written to.
    let declared = u32::from_be_bytes([icc[0], icc[1], icc[2], icc[3]]);
    if declared as usize > super::MAX_ITEM_BYTES {
        return Err(format!(
            "its header declares {declared} bytes, over the limit of {}",
            super::MAX_ITEM_BYTES
        ));
    }
    if &icc[36..40] != b"acsp" {
        return Err(format!(
            "no profile signature `acsp` at byte 36 (found {:02x?})",
            &icc[36..40]
        ));
    }
    Ok([icc[16], icc[17], icc[18], icc[19]])
}

/// An XMP packet whose `tiff:Orientation` (attribute `tiff:Orientation="6"` or element
/// `<tiff:Orientation>6</tiff:Orientation>`) says 1: the pixels were turned upright, and
/// a reader that trusts XMP over EXIF must not turn them again. `None` when there is
/// nothing to change (or the packet is not UTF-8).
pub fn xmp_with_orientation_one(xmp: &[u8]) -> Option<Vec<u8>> {
    let text = std::str::from_utf8(xmp).ok()?;
    let (a, double) = orientation_values_one(text, "tiff:Orientation=\"", '"')?;
    let (b, single) = orientation_values_one(&a, "tiff:Orientation='", '\'')?;
    let (c, element) = orientation_values_one(&b, "<tiff:Orientation>", '<')?;
    (double || single || element).then(|| c.into_bytes())
}

/// `text` with every value between `open` and `close` set to 1, and whether any was
/// another; `None` if a value is not closed.
fn orientation_values_one(text: &str, open: &str, close: char) -> Option<(String, bool)> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    let mut changed = false;
    while let Some(at) = rest.find(open) {
        let start = at + open.len();
        let len = rest[start..].find(close)?;
        out.push_str(&rest[..start]);
        changed |= rest[start..start + len].trim() != "1";
        out.push('1');
        rest = &rest[start + len..];
    }
    out.push_str(rest);
    Some((out, changed))
}

impl Metadata {
    /// The items an image with `colour_channels` colour channels (1 grey, 3 colour)
    /// can carry, and those left out: an ICC profile of another colour space (a CMYK
    /// profile beside RGB pixels) or that is not a profile, an EXIF block that is not a
    /// readable TIFF structure, an XMP packet that is not UTF-8.
    pub fn fitted(&self, colour_channels: usize) -> (Metadata, Vec<Dropped>) {
        let mut kept = self.clone();
        let mut dropped = Vec::new();
        let mut drop = |item: Item, reason: String| dropped.push(Dropped { item, reason });
        if let Some(icc) = &self.icc {
            let want: &[u8; 4] = if colour_channels >= 3 {
                b"RGB "
            } else {
                b"GRAY"
            };
            match icc_colour_space(icc) {
                Ok(space) if &space == want => {}
                Ok(space) => {
                    kept.icc = None;
                    drop(
                        Item::Icc,
                        format!(
                            "its colour space is `{}`, the pixels' is `{}`",
                            crate::printable(String::from_utf8_lossy(&space).trim_end()),
                            String::from_utf8_lossy(want).trim_end()
                        ),
                    );
                }
                Err(reason) => {
                    kept.icc = None;
                    drop(Item::Icc, reason);
                }
            }
        }
        if let Some(exif) = &self.exif {
            if let Err(e) = orientation(exif) {
                kept.exif = None;
                drop(Item::Exif, e.to_string());
            }
        }
        if let Some(xmp) = &self.xmp {
            if let Err(e) = std::str::from_utf8(xmp) {
                kept.xmp = None;
                drop(
                    Item::Xmp,
                    format!("not UTF-8 (invalid byte at {})", e.valid_up_to()),
                );
            }
        }
        (kept, dropped)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A profile header of colour space `space` (the rest zero).
    fn profile(space: &[u8; 4]) -> Vec<u8> {
        let mut p = vec![0u8; ICC_HEADER];
        p[16..20].copy_from_slice(space);
        p[36..40].copy_from_slice(b"acsp");
        p
    }

    #[test]
    fn profiles_fit_pixels_of_their_colour_space_only() {
        let rgb = Metadata {
            icc: Some(profile(b"RGB ")),
            ..Metadata::default()
        };
        assert_eq!(rgb.fitted(3), (rgb.clone(), vec![]));
        let (kept, dropped) = rgb.fitted(1);
        assert_eq!(kept.icc, None);
        assert_eq!(
            dropped[0].to_string(),
            "ICC profile left out: its colour space is `RGB`, the pixels' is `GRAY`"
        );
        let cmyk = Metadata {
            icc: Some(profile(b"CMYK")),
            ..Metadata::default()
        };
        assert_eq!(cmyk.fitted(3).0.icc, None);
        let grey = Metadata {
            icc: Some(profile(b"GRAY")),
            ..Metadata::default()
        };
        assert_eq!(grey.fitted(1).1, vec![]);
        let junk = Metadata {
            icc: Some(b"JUNK".to_vec()),
            ..Metadata::default()
        };
        assert!(junk.fitted(3).1[0].reason.contains("shorter than"));
    }

    #[test]
    fn unreadable_exif_and_non_utf8_xmp_are_left_out() {
        let meta = Metadata {
            icc: None,
            exif: Some(b"JUNK".to_vec()),
            xmp: Some(b"<x:xmpmeta \xff/>".to_vec()),
        };
        let (kept, dropped) = meta.fitted(3);
        assert!(kept.is_empty());
        assert_eq!(dropped.len(), 2);
        assert!(dropped[0].reason.contains("TIFF header"), "{}", dropped[0]);
        assert_eq!(dropped[1].reason, "not UTF-8 (invalid byte at 11)");
        // A readable EXIF and UTF-8 XMP are kept as they are.
        let mut exif = b"II*\0".to_vec();
        exif.extend_from_slice(&8u32.to_le_bytes());
        exif.extend_from_slice(&[0, 0, 0, 0, 0, 0]);
        let ok = Metadata {
            icc: None,
            exif: Some(exif),
            xmp: Some("<x:xmpmeta/> é".as_bytes().to_vec()),
        };
        assert_eq!(ok.fitted(1), (ok.clone(), vec![]));
    }

    #[test]
    fn the_xmp_orientation_is_set_upright_in_each_form() {
        let attr = br#"<rdf:Description tiff:Orientation="6" dc:x="6"/>"#;
        assert_eq!(
            xmp_with_orientation_one(attr).unwrap(),
            br#"<rdf:Description tiff:Orientation="1" dc:x="6"/>"#
        );
        let single = b"<d tiff:Orientation='8'/>";
        assert_eq!(
            xmp_with_orientation_one(single).unwrap(),
            b"<d tiff:Orientation='1'/>"
        );
        let element = b"<tiff:Orientation> 3 </tiff:Orientation>";
        assert_eq!(
            xmp_with_orientation_one(element).unwrap(),
            b"<tiff:Orientation>1</tiff:Orientation>"
        );
        assert_eq!(xmp_with_orientation_one(br#"tiff:Orientation="1""#), None);
        assert_eq!(xmp_with_orientation_one(b"<x/>"), None);
        assert_eq!(xmp_with_orientation_one(br#"tiff:Orientation="6"#), None);
    }
}
