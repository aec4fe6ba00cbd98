//! The image and metadata targets: `image` (pixels and metadata through the loader),
//! and the metadata readers and writers on their own.

use super::*;
use caoen::metadata as md;

/// The image's metadata and its upright pixels: items within their size limit, the kept
/// EXIF saying orientation 1 (or none), and as many pixels as the image stores.
fn image_metadata(data: &[u8]) {
    let Ok((upright, meta)) = image_io::load_from_memory_with_metadata(data, &image_limits())
    else {
        return;
    };
    assert!(meta.check_sizes().is_ok(), "metadata over its size limit");
    if let Some(exif) = &meta.exif {
        let o = md::orientation(exif);
        assert!(
            matches!(o, Ok(Some(1) | None)),
            "kept EXIF orientation {o:?}"
        );
    }
    if let Ok(stored) = image_io::load_from_memory(data, &image_limits()) {
        assert_eq!(
            upright.pixel_count(),
            stored.pixel_count(),
            "upright and stored pixel counts"
        );
    }
}

/// Limits of the image target: small, so a run takes milliseconds; the limit checks are
/// the same code at any size.
fn image_limits() -> LoadLimits {
    LoadLimits {
        max_side: 1024,
        max_pixels: 1 << 16,
        ..LoadLimits::default()
    }
}

/// Largest loaded image also encoded and decoded again.
const ENCODE_MAX_PIXELS: usize = 256;

/// Loads an image from memory (any format `image_io` reads) within small limits, and
/// for tiny images encodes it at the lowest effort and decodes the result, which must
/// have the image's size, layout and format.
pub fn image(data: &[u8]) -> Outcome {
    image_metadata(data);
    let img = image_io::load_from_memory(data, &image_limits()).map_err(message)?;
    assert!(
        img.width() <= image_limits().max_side
            && img.height() <= image_limits().max_side
            && img.pixel_count() as u64 <= image_limits().max_pixels,
        "loaded {}x{}, over the limits",
        img.width(),
        img.height()
    );
    if img.pixel_count() <= ENCODE_MAX_PIXELS {
        let opts = EncodeOptions {
            quality: 50.0,
            effort: 1,
            ..EncodeOptions::default()
        };
        let bytes = codec::encode(&img, &opts).map_err(message)?;
        let back = codec::decode(&bytes, &DecodeOptions::default())
            .unwrap_or_else(|e| panic!("a file the encoder wrote does not decode: {e}"));
        assert_eq!(
            (back.width(), back.height(), back.layout(), back.format()),
            (img.width(), img.height(), img.layout(), img.format()),
            "encoded and decoded image"
        );
    }
    Ok(())
}

/// The metadata of a JPEG, PNG or WebP file (`jpeg_meta` and `png_meta` differ only in
/// their seeds): the strict and the lenient reader, then the items fitted to RGB pixels,
/// as every command keeps them, written into a PNG, which must read back with the
/// same items. A strict read that succeeds must leave the lenient one nothing to drop;
/// every error and every dropped item's reason is one printable line.
pub fn meta_container(data: &[u8]) -> Outcome {
    let strict = md::read_container(data).map_err(message);
    let (meta, dropped) = md::read_container_lenient(data).map_err(message)?;
    for d in &dropped {
        message(d);
    }
    meta.check_sizes()
        .unwrap_or_else(|e| panic!("read an item over its limit: {e}"));
    if let Ok(strict) = &strict {
        assert!(
            dropped.is_empty() && strict == &meta,
            "the strict read succeeded but the lenient one dropped {dropped:?}"
        );
    }
    assert_written_reads_back(&meta);
    strict.map(|_| ())
}

/// Fits `meta` to RGB pixels as the loader does (EXIF orientation reset to 1), writes
/// it into a 1x1 PNG, and reads that PNG's metadata and pixels back: a file caoen
/// writes is one caoen reads, with the same items.
fn assert_written_reads_back(meta: &Metadata) {
    let mut meta = meta.clone();
    if let Some(exif) = meta.exif.as_mut() {
        let _ = md::reset_orientation(exif);
    }
    let (fitted, unfit) = meta.fitted(3);
    for d in &unfit {
        message(d);
    }
    if fitted.check_sizes().is_err() {
        let pixel = Raster::new(1, 1, ChannelLayout::Rgb, SampleFormat::U8, vec![0.5; 3]);
        let written = image_io::encode_with_metadata(
            &pixel.expect("a 1x1 raster"),
            image_io::OutputFormat::Png8,
            image_io::PngCompression::Fast,
            &fitted,
        );
        assert!(written.is_err(), "an item over its limit was written");
        return;
    }
    let pixel = Raster::new(1, 1, ChannelLayout::Rgb, SampleFormat::U8, vec![0.5; 3])
        .expect("a 1x1 raster");
    let png = image_io::encode_with_metadata(
        &pixel,
        image_io::OutputFormat::Png8,
        image_io::PngCompression::Fast,
        &fitted,
    )
    .unwrap_or_else(|e| panic!("fitted metadata could not be written to a PNG: {e}"));
    let back = md::read_container(&png)
        .unwrap_or_else(|e| panic!("caoen does not read the PNG it wrote: {e}"));
    assert!(back == fitted, "the PNG's metadata reads back changed");
    let (_, again) = image_io::load_from_memory_with_metadata(&png, &image_limits())
        .unwrap_or_else(|e| panic!("caoen does not load the PNG it wrote: {e}"));
    assert!(again == fitted, "the loaded PNG's metadata changed");
}

/// An EXIF block on its own (the TIFF structure): the directory chain, the orientation
/// read, reset and read again (1 whenever the tag is there), and the block fitted and
/// written as the loader keeps it.
pub fn exif(data: &[u8]) -> Outcome {
    let chain = md::ifd_chain(data).map_err(message);
    let found = md::orientation(data).map_err(message)?;
    let mut reset = data.to_vec();
    let old = md::reset_orientation(&mut reset)
        .unwrap_or_else(|e| panic!("orientation {found:?} read, but not reset: {e}"));
    let slot_value_ok = old.is_none() || found.is_none() || old == found;
    assert!(
        slot_value_ok,
        "read orientation {found:?}, reset found {old:?}"
    );
    let now =
        md::orientation(&reset).unwrap_or_else(|e| panic!("the reset block does not read: {e}"));
    assert!(
        now.is_none() || now == Some(1),
        "orientation after the reset: {now:?}"
    );
    assert_eq!(
        md::with_orientation_one(data),
        reset,
        "the two ways of resetting differ"
    );
    assert_written_reads_back(&Metadata {
        exif: Some(data.to_vec()),
        ..Metadata::default()
    });
    chain.map(|_| ())
}

/// An ICC profile on its own: its declared colour space, and the profile kept or left
/// out as the pixels' colour space asks, then written and read back.
pub fn icc(data: &[u8]) -> Outcome {
    let space = md::icc_colour_space(data);
    let meta = Metadata {
        icc: Some(data.to_vec()),
        ..Metadata::default()
    };
    for channels in [1, 3] {
        let (kept, dropped) = meta.fitted(channels);
        let want: &[u8; 4] = if channels == 3 { b"RGB " } else { b"GRAY" };
        let fits = space.as_ref().is_ok_and(|s| s == want);
        assert_eq!(
            kept.icc.is_some(),
            fits,
            "profile kept for {channels} channels"
        );
        assert_eq!(dropped.len(), usize::from(!fits), "dropped {dropped:?}");
        for d in &dropped {
            message(d);
        }
    }
    assert_written_reads_back(&meta);
    space.map(|_| ()).map_err(message)
}

/// An XMP packet and the chunks of its JPEG extension (the input split at each `0xff`
/// byte: the main packet first, then each chunk as the payload after the extension's
/// namespace), put into a JPEG's APP1 segments and read as a JPEG's metadata: joined
/// by offset, checked against the GUID, merged, or the extension left out with the
/// pointer cut; the orientation set to 1 as the loader does; what is kept is written
/// and read back.
pub fn xmp(data: &[u8]) -> Outcome {
    const XMP: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";
    const EXTENSION: &[u8] = b"http://ns.adobe.com/xmp/extension/\0";
    let mut parts = data.split(|&b| b == 0xff);
    let main = parts.next().unwrap_or_default();
    if let Some(upright) = md::xmp_with_orientation_one(main) {
        assert!(
            md::xmp_with_orientation_one(&upright).is_none(),
            "setting the XMP orientation to 1 twice changed the packet again"
        );
    }
    let mut jpeg = vec![0xff, 0xd8];
    for (namespace, payload) in std::iter::once((XMP, main)).chain(parts.map(|c| (EXTENSION, c))) {
        // A segment's length field counts itself: at most 65,533 bytes after it.
        let len = namespace.len() + payload.len() + 2;
        let Ok(len) = u16::try_from(len) else {
            return Err("a segment longer than a JPEG segment can be".into());
        };
        jpeg.extend_from_slice(&[0xff, 0xe1]);
        jpeg.extend_from_slice(&len.to_be_bytes());
        jpeg.extend_from_slice(namespace);
        jpeg.extend_from_slice(payload);
    }
    jpeg.extend_from_slice(&[0xff, 0xd9]);
    let (meta, dropped) = md::read_container_lenient(&jpeg).map_err(message)?;
    for d in &dropped {
        message(d);
    }
    if let Some(x) = &meta.xmp {
        assert!(
            x.len() <= main.len() || dropped.is_empty(),
            "the packet grew though its extension was left out"
        );
        meta.check_sizes()
            .unwrap_or_else(|e| panic!("joined packet over the limit: {e}"));
    }
    assert_written_reads_back(&meta);
    Ok(())
}
