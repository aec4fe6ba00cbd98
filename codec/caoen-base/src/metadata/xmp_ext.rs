//! Extended XMP in JPEG (XMP specification part 3, 1.1.3.1): a packet too large for one
//! APP1 segment is split into a main packet, which names the rest by
//! `xmpNote:HasExtendedXMP="<GUID>"`, and an extension carried in APP1 segments of
//! namespace `http://ns.adobe.com/xmp/extension/`, each holding the 32-character GUID
//! (the MD5 of the whole extension, in upper-case hex), the extension's full length and
//! the chunk's offset (both 32-bit big-endian), then the chunk.
//!
//! The chunks are joined by offset and the extension's `rdf:Description`s are moved
//! into the main packet, without the pointer: the packet kept is self-contained, the
//! form PNG, OpenEXR and `.cae` carry (and what exiftool writes to a PNG).

#[cfg(any(feature = "xmp-digest", test))]
use md5::{Digest, Md5};

use super::{check_size, corrupt, Item, MetadataError};

/// The namespace that starts each APP1 segment of an extension, NUL included.
pub const EXTENSION_NAMESPACE: &[u8] = b"http://ns.adobe.com/xmp/extension/\0";

/// GUID, full length, offset: the header of each extension chunk.
const CHUNK_HEADER: usize = 32 + 4 + 4;

/// The name the damaged extension's errors and warnings carry.
const WHAT: &str = "extended XMP";

/// The main XMP packet `main` of a JPEG with its extension, from the payloads (after
/// [`EXTENSION_NAMESPACE`]) of the file's extension segments, merged into one packet.
/// An error if the extension is missing, damaged or does not match the main packet.
pub fn join_extended(
    main: Option<Vec<u8>>,
    chunks: &[&[u8]],
) -> Result<Option<Vec<u8>>, MetadataError> {
    let pointer = main.as_deref().and_then(extended_pointer);
    let Some((guid, at)) = pointer else {
        if chunks.is_empty() {
            return Ok(main);
        }
        return Err(corrupt(
            WHAT,
            format!(
                "{} extension segment(s) but no xmpNote:HasExtendedXMP in the main packet",
                chunks.len()
            ),
        ));
    };
    let main = main.expect("a pointer was found in it");
    let extension = assemble(&guid, chunks)?;
    let merged = merge(&main, at, &extension)?;
    check_size(Item::XmpExtension, merged.len() as u64)?;
    Ok(Some(merged))
}

/// The main packet without its pointer to an extension that is left out: a reader
/// must not look for what is not there.
pub fn without_pointer(main: Option<Vec<u8>>) -> Option<Vec<u8>> {
    let at = main.as_deref().and_then(extended_pointer).map(|p| p.1);
    match (main, at) {
        // `extended_pointer` found the range in UTF-8 text.
        (Some(m), Some(at)) => Some(without(std::str::from_utf8(&m).ok()?, at).into_bytes()),
        (main, _) => main,
    }
}

/// The GUID `xmpNote:HasExtendedXMP` names (attribute or element form), and the byte
/// range of the property to cut out of the packet.
fn extended_pointer(xmp: &[u8]) -> Option<(String, std::ops::Range<usize>)> {
    let text = std::str::from_utf8(xmp).ok()?;
    let name = text.find(":HasExtendedXMP")?;
    // The character before the prefix may be several bytes long.
    let prefix_start = text[..name]
        .char_indices()
        .rev()
        .find(|&(_, c)| !(c.is_alphanumeric() || c == '_' || c == '-' || c == '.'))
        .map_or(0, |(i, c)| i + c.len_utf8());
    let after = name + ":HasExtendedXMP".len();
    let rest = &text[after..];
    let trimmed = rest.trim_start();
    if let Some(value) = trimmed.strip_prefix('=') {
        // Attribute form: cut the whitespace before the name too.
        let value = value.trim_start();
        let quote = value.chars().next().filter(|q| *q == '"' || *q == '\'')?;
        let len = value[1..].find(quote)?;
        let guid = value[1..1 + len].trim().to_string();
        let end = text.len() - value.len() + 1 + len + 1;
        let start = text[..prefix_start].trim_end().len();
        Some((guid, start..end))
    } else if text[..prefix_start].ends_with('<') {
        // Element form: `<p:HasExtendedXMP>GUID</p:HasExtendedXMP>`.
        let open_end = after + rest.find('>')? + 1;
        let close = format!("</{}", &text[prefix_start..after]);
        let close_at = open_end + text[open_end..].find(&close)?;
        let end = close_at + text[close_at..].find('>')? + 1;
        let guid = text[open_end..close_at].trim().to_string();
        Some((guid, prefix_start - 1..end))
    } else {
        None
    }
}

/// `text` with `range` cut out.
fn without(text: &str, range: std::ops::Range<usize>) -> String {
    [&text[..range.start], &text[range.end..]].concat()
}

/// The extension's bytes: the chunks of GUID `guid` joined by offset, each length and
/// offset checked before anything is allocated, and the digest checked against the GUID.
fn assemble(guid: &str, chunks: &[&[u8]]) -> Result<Vec<u8>, MetadataError> {
    let bad = |reason: String| Err(corrupt(WHAT, reason));
    let mut parts: Vec<(u32, &[u8])> = Vec::new();
    let mut full: Option<u32> = None;
    let mut others: Vec<String> = Vec::new();
    for (i, c) in chunks.iter().enumerate() {
        if c.len() < CHUNK_HEADER {
            return bad(format!(
                "extension segment {i} has {} bytes, less than its {CHUNK_HEADER}-byte header",
                c.len()
            ));
        }
        let id = String::from_utf8_lossy(&c[..32]);
        // Segments of another GUID are left from an earlier edit: readers skip them.
        if !id.eq_ignore_ascii_case(guid) {
            others.push(id.into_owned());
            continue;
        }
        let length = u32::from_be_bytes([c[32], c[33], c[34], c[35]]);
        let offset = u32::from_be_bytes([c[36], c[37], c[38], c[39]]);
        match full {
            Some(f) if f != length => {
                return bad(format!(
                    "extension chunks declare full lengths {f} and {length}"
                ))
            }
            _ => full = Some(length),
        }
        parts.push((offset, &c[CHUNK_HEADER..]));
    }
    let Some(full) = full else {
        return bad(format!(
            "the main packet names extension {}, no segment carries it (found {others:?})",
            crate::printable(guid)
        ));
    };
    check_size(Item::XmpExtension, full.into())?;
    let available: u64 = parts.iter().map(|p| p.1.len() as u64).sum();
    if available < u64::from(full) {
        return bad(format!(
            "extension of {full} bytes, its chunks hold {available}: a chunk is missing"
        ));
    }
    parts.sort_by_key(|p| p.0);
    let mut next = 0u64;
    for &(offset, data) in &parts {
        let (offset, end) = (u64::from(offset), u64::from(offset) + data.len() as u64);
        if offset < next {
            return bad(format!(
                "extension chunk at offset {offset} overlaps the one before, which ends at {next}"
            ));
        }
        if offset > next {
            return bad(format!("extension bytes {next}..{offset} are missing"));
        }
        if end > u64::from(full) {
            return bad(format!(
                "extension chunk at offset {offset} ends at {end}, past the full length {full}"
            ));
        }
        next = end;
    }
    if next != u64::from(full) {
        return bad(format!("extension bytes {next}..{full} are missing"));
    }
    let mut out = Vec::with_capacity(full as usize);
    for (_, data) in parts {
        out.extend_from_slice(data);
    }
    #[cfg(any(feature = "xmp-digest", test))]
    {
        let digest: String = Md5::digest(&out)
            .iter()
            .map(|b| format!("{b:02X}"))
            .collect();
        if !digest.eq_ignore_ascii_case(guid) {
            return bad(format!(
                "the extension's MD5 is {digest}, the main packet names {guid}: it was changed"
            ));
        }
    }
    Ok(out)
}

/// The main packet, its pointer at `at` cut out, with the extension's descriptions (and
/// the namespaces its outer elements declare) inside its `rdf:RDF`.
fn merge(
    main: &[u8],
    at: std::ops::Range<usize>,
    extension: &[u8],
) -> Result<Vec<u8>, MetadataError> {
    let not_utf8 = |what: &str| corrupt(WHAT, format!("the {what} is not UTF-8"));
    let main = std::str::from_utf8(main).map_err(|_| not_utf8("main packet"))?;
    let ext = std::str::from_utf8(extension).map_err(|_| not_utf8("extension"))?;
    let no_rdf = |what: &str| corrupt(WHAT, format!("the {what} has no rdf:RDF element"));
    let ext_open = ext.find("<rdf:RDF").ok_or_else(|| no_rdf("extension"))?;
    let body_start = ext_open
        + ext[ext_open..]
            .find('>')
            .ok_or_else(|| no_rdf("extension"))?
        + 1;
    let body_end = ext
        .rfind("</rdf:RDF")
        .filter(|&e| e >= body_start)
        .ok_or_else(|| no_rdf("extension"))?;
    let body = &ext[body_start..body_end];
    let mut main = without(main, at);
    let main_open = main.find("<rdf:RDF").ok_or_else(|| no_rdf("main packet"))?;
    let open_end = main_open
        + main[main_open..]
            .find('>')
            .ok_or_else(|| no_rdf("main packet"))?;
    let close = main
        .rfind("</rdf:RDF")
        .filter(|&c| c > open_end)
        .ok_or_else(|| no_rdf("main packet"))?;
    main.insert_str(close, body);
    // Namespaces declared above the descriptions would otherwise be lost with the
    // extension's wrapper.
    // Those the main packet declares on the way down to its rdf:RDF are in scope.
    let declared = &main[..open_end];
    let missing: String = namespaces(&ext[..body_start])
        .filter(|ns| {
            let name = ns.split('=').next().unwrap_or(ns);
            !declared.contains(&format!("{name}="))
        })
        .map(|ns| format!(" {ns}"))
        .collect();
    let open_end = if main[..open_end].ends_with('/') {
        open_end - 1
    } else {
        open_end
    };
    main.insert_str(open_end, &missing);
    Ok(main.into_bytes())
}

/// The `xmlns:p="..."` declarations in `tags`, as written.
fn namespaces(tags: &str) -> impl Iterator<Item = &str> {
    tags.match_indices("xmlns:").filter_map(move |(at, _)| {
        let rest = &tags[at..];
        let eq = rest.find('=')?;
        let quote = rest[eq + 1..]
            .chars()
            .next()
            .filter(|q| *q == '"' || *q == '\'')?;
        let len = rest[eq + 2..].find(quote)?;
        Some(&rest[..eq + 2 + len + 1])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXT: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="" xmlns:GDepth="http://ns.google.com/photos/1.0/depthmap/" GDepth:Format="RangeInverse" GDepth:Data="QUJDREVGR0hJSktMTU5PUFFSU1RVVldYWVo="/></rdf:RDF></x:xmpmeta>"#;

    fn guid(ext: &[u8]) -> String {
        Md5::digest(ext)
            .iter()
            .map(|b| format!("{b:02X}"))
            .collect()
    }

    fn main_packet(guid: &str) -> Vec<u8> {
        format!(r#"<?xpacket begin="" id="W5M0MpCehiHzreSzNTczkc9d"?><x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="" xmlns:xmpNote="http://ns.adobe.com/xmp/note/" xmpNote:HasExtendedXMP="{guid}"/></rdf:RDF></x:xmpmeta><?xpacket end="w"?>"#).into_bytes()
    }

    /// The payload of one extension segment.
    fn chunk(guid: &str, full: u32, offset: u32, data: &[u8]) -> Vec<u8> {
        [
            guid.as_bytes(),
            &full.to_be_bytes(),
            &offset.to_be_bytes(),
            data,
        ]
        .concat()
    }

    /// The extension split into chunks at `cuts`.
    fn split(guid: &str, ext: &[u8], cuts: &[usize]) -> Vec<Vec<u8>> {
        let mut bounds = vec![0];
        bounds.extend_from_slice(cuts);
        bounds.push(ext.len());
        bounds
            .windows(2)
            .map(|w| chunk(guid, ext.len() as u32, w[0] as u32, &ext[w[0]..w[1]]))
            .collect()
    }

    fn join(main: &[u8], chunks: &[Vec<u8>]) -> Result<Option<Vec<u8>>, MetadataError> {
        let refs: Vec<&[u8]> = chunks.iter().map(Vec::as_slice).collect();
        join_extended(Some(main.to_vec()), &refs)
    }

    fn reason(r: Result<Option<Vec<u8>>, MetadataError>) -> String {
        match r {
            Err(MetadataError::Corrupt { item: WHAT, reason }) => reason,
            other => panic!("not a damaged extension: {other:?}"),
        }
    }

    #[test]
    fn chunks_in_any_order_join_into_one_packet() {
        let ext = EXT.as_bytes();
        let g = guid(ext);
        let mut chunks = split(&g, ext, &[100, 200]);
        chunks.reverse();
        let merged = String::from_utf8(join(&main_packet(&g), &chunks).unwrap().unwrap()).unwrap();
        assert!(
            merged.contains(r#"GDepth:Format="RangeInverse""#),
            "{merged}"
        );
        assert!(!merged.contains("HasExtendedXMP"), "{merged}");
        assert!(
            merged.ends_with(r#"</rdf:RDF></x:xmpmeta><?xpacket end="w"?>"#),
            "{merged}"
        );
        assert_eq!(merged.matches("<rdf:RDF").count(), 1, "{merged}");
        // A packet with no extension is kept as it is.
        let plain = b"<x:xmpmeta/>".to_vec();
        assert_eq!(join_extended(Some(plain.clone()), &[]), Ok(Some(plain)));
        assert_eq!(join_extended(None, &[]), Ok(None));
    }

    #[test]
    fn the_element_form_and_outer_namespaces_are_handled() {
        let ext = EXT.replace(
            r#"<rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">"#,
            r#"<rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#" xmlns:cam="http://example.com/cam/">"#,
        );
        let g = guid(ext.as_bytes());
        let main = format!(
            r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="" xmlns:xmpNote="http://ns.adobe.com/xmp/note/"><xmpNote:HasExtendedXMP>{g}</xmpNote:HasExtendedXMP></rdf:Description></rdf:RDF></x:xmpmeta>"#
        );
        let merged = join(main.as_bytes(), &split(&g, ext.as_bytes(), &[50]))
            .unwrap()
            .unwrap();
        let merged = String::from_utf8(merged).unwrap();
        assert!(!merged.contains("HasExtendedXMP"), "{merged}");
        assert!(
            merged.contains(r#"xmlns:cam="http://example.com/cam/""#),
            "{merged}"
        );
        assert!(merged.contains("GDepth:Data="), "{merged}");
        assert_eq!(merged.matches("xmlns:rdf=").count(), 1, "{merged}");
        assert_eq!(merged.matches("xmlns:x=").count(), 1, "{merged}");
    }

    #[test]
    fn a_wrong_guid_or_changed_bytes_are_refused() {
        let ext = EXT.as_bytes();
        let g = guid(ext);
        let other = "0123456789ABCDEF0123456789ABCDEF";
        let r = reason(join(&main_packet(&g), &split(other, ext, &[100])));
        assert!(r.contains("no segment carries it"), "{r}");
        // The GUID matches, the bytes do not hash to it.
        let mut changed = ext.to_vec();
        changed[60] ^= 1;
        let r = reason(join(&main_packet(&g), &split(&g, &changed, &[100])));
        assert!(r.contains("MD5"), "{r}");
        // Segments but no pointer.
        let r = reason(join(b"<x:xmpmeta/>", &split(&g, ext, &[])));
        assert!(r.contains("no xmpNote:HasExtendedXMP"), "{r}");
    }

    #[test]
    fn missing_overlapping_and_out_of_range_chunks_are_refused() {
        let ext = EXT.as_bytes();
        let g = guid(ext);
        let main = main_packet(&g);
        let chunks = split(&g, ext, &[100, 200]);
        // Each chunk left out in turn.
        for gone in 0..3 {
            let mut c = chunks.clone();
            c.remove(gone);
            let r = reason(join(&main, &c));
            assert!(r.contains("missing"), "{gone}: {r}");
        }
        // The middle chunk twice, and one moved back over its neighbour.
        let r = reason(join(
            &main,
            &[chunks.clone(), vec![chunks[1].clone()]].concat(),
        ));
        assert!(r.contains("overlaps"), "{r}");
        let mut moved = chunks.clone();
        moved[2][36..40].copy_from_slice(&150u32.to_be_bytes());
        let r = reason(join(&main, &moved));
        assert!(r.contains("overlaps"), "{r}");
        // A chunk past the declared end, and full lengths that disagree.
        let mut past = chunks.clone();
        past.push(chunk(&g, ext.len() as u32, ext.len() as u32 - 2, b"abcd"));
        let r = reason(join(&main, &past));
        assert!(
            r.contains("overlaps") || r.contains("past the full length"),
            "{r}"
        );
        let mut longer = chunks.clone();
        longer[1][32..36].copy_from_slice(&(ext.len() as u32 + 1).to_be_bytes());
        assert!(reason(join(&main, &longer)).contains("full lengths"));
        // Too short to hold a header.
        let r = reason(join(&main, &[g.as_bytes().to_vec()]));
        assert!(r.contains("header"), "{r}");
    }

    #[test]
    fn a_huge_declared_length_is_refused_before_allocating() {
        let g = guid(EXT.as_bytes());
        let main = main_packet(&g);
        let r = join(&main, &[chunk(&g, u32::MAX, 0, b"x")]);
        assert!(
            matches!(
                r,
                Err(MetadataError::TooLarge {
                    item: Item::XmpExtension,
                    bytes: 4_294_967_295,
                    ..
                })
            ),
            "{r:?}"
        );
        // Under the cap but more than the segments hold.
        let r = reason(join(&main, &[chunk(&g, 1 << 20, 0, b"x")]));
        assert!(r.contains("a chunk is missing"), "{r}");
    }

    #[test]
    fn the_pointer_is_cut_when_the_extension_is_left_out() {
        let main = without_pointer(Some(main_packet("63F8F9A6F6F2F2468AA5CEE4014C3062"))).unwrap();
        let main = String::from_utf8(main).unwrap();
        assert!(!main.contains("HasExtendedXMP"), "{main}");
        assert!(
            main.contains(r#"xmlns:xmpNote="http://ns.adobe.com/xmp/note/"/>"#),
            "{main}"
        );
        assert_eq!(without_pointer(None), None);
        // Any text around the name is read without a panic.
        for text in [
            "é:HasExtendedXMP=\"G\"",
            "<é:HasExtendedXMP>G</é:HasExtendedXMP>",
            "…:HasExtendedXMP",
            ":HasExtendedXMP='",
        ] {
            let _ = without_pointer(Some(text.as_bytes().to_vec()));
            let _ = join_extended(Some(text.as_bytes().to_vec()), &[]);
        }
        let cut = without_pointer(Some("«xmpNote:HasExtendedXMP=\"G\"»".as_bytes().to_vec()));
        assert_eq!(cut.as_deref(), Some("«»".as_bytes()));
        assert_eq!(
            without_pointer(Some(b"\xff".to_vec())),
            Some(b"\xff".to_vec())
        );
    }

    /// A JPEG of an XMP segment holding `main` and one extension segment per chunk.
    fn jpeg(main: &[u8], chunks: &[Vec<u8>]) -> Vec<u8> {
        let mut out = vec![0xff, 0xd8];
        let xmp = [b"http://ns.adobe.com/xap/1.0/\0".as_slice(), main].concat();
        let ext = chunks.iter().map(|c| [EXTENSION_NAMESPACE, c].concat());
        for payload in std::iter::once(xmp).chain(ext) {
            out.extend_from_slice(&[0xff, 0xe1]);
            out.extend_from_slice(&(payload.len() as u16 + 2).to_be_bytes());
            out.extend_from_slice(&payload);
        }
        out.extend_from_slice(&[0xff, 0xd9]);
        out
    }

    #[test]
    fn a_damaged_extension_is_dropped_and_the_main_packet_kept() {
        use crate::metadata::{read_container, read_container_lenient};
        let ext = EXT.as_bytes();
        let g = guid(ext);
        let chunks = split(&g, ext, &[120]);
        let whole = jpeg(&main_packet(&g), &chunks);
        let xmp = read_container(&whole).unwrap().xmp.unwrap();
        assert!(String::from_utf8(xmp).unwrap().contains("GDepth:Format"));
        let (meta, dropped) = read_container_lenient(&whole).unwrap();
        assert!(dropped.is_empty(), "{dropped:?}");
        assert!(meta.xmp.is_some());
        let damaged = jpeg(&main_packet(&g), &chunks[..1]);
        assert!(read_container(&damaged).is_err());
        let (meta, dropped) = read_container_lenient(&damaged).unwrap();
        assert_eq!(dropped.len(), 1, "{dropped:?}");
        assert_eq!(dropped[0].item, Item::XmpExtension);
        assert!(dropped[0]
            .to_string()
            .starts_with("extended XMP left out: "));
        let kept = String::from_utf8(meta.xmp.unwrap()).unwrap();
        assert!(
            kept.contains("rdf:Description") && !kept.contains("HasExtendedXMP"),
            "{kept}"
        );
        // Every prefix of the file is read without a panic.
        for cut in 0..whole.len() {
            let _ = read_container_lenient(&whole[..cut]);
        }
    }

    proptest::proptest! {
        #[test]
        fn any_chunks_are_joined_or_refused_without_a_panic(
            raw in proptest::collection::vec(proptest::collection::vec(proptest::prelude::any::<u8>(), 0..80), 0..4),
            headers in proptest::collection::vec((0u32..400, 0u32..400), 0..4),
        ) {
            let g = guid(EXT.as_bytes());
            let chunks: Vec<Vec<u8>> = raw
                .iter()
                .zip(headers.iter().chain(std::iter::repeat(&(0, 0))))
                .map(|(d, &(full, off))| chunk(&g, full, off, d))
                .collect();
            let _ = join(&main_packet(&g), &chunks);
            let _ = join(&main_packet(&g), &raw);
        }

        #[test]
        fn any_text_around_the_pointer_is_read_without_a_panic(
            text in "[<«a-z:=\"' >/é]{0,20}HasExtendedXMP[<«a-z:=\"' >/é0-9A-F]{0,40}",
        ) {
            let _ = without_pointer(Some(text.clone().into_bytes()));
            let _ = join_extended(Some(text.into_bytes()), &[b"x"]);
        }
    }
}
