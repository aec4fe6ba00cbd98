//! OpenEXR in and out through the `exr` crate: float channels by name, metadata as
//! attributes.

use std::io::{Cursor, Seek};
use std::path::Path;

use super::convert::raster_or_error;
use super::error::{guarded, tidy};
use super::{ImageIoError, LoadLimits};
use caoen_base::metadata::Metadata;
use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};
use exr::prelude::traits::*;
use exr::prelude::{
    AnyChannel, AnyChannels, ChannelDescription, Encoding, FlatSamples, Image, Layer,
    LayerAttributes, MetaData, SmallVec, Text, Vec2,
};

/// Which file channel feeds each raster channel.
struct Plan {
    layout: ChannelLayout,
    /// Index into the layer's (sorted) channel list per raster channel.
    sources: Vec<usize>,
    names: Vec<String>,
}

/// A channel's short name: `diffuse.R` is `R`.
fn short(name: &Text) -> String {
    let s = name.to_string();
    s.rsplit('.').next().unwrap_or(&s).to_string()
}

fn plan(channels: &[ChannelDescription], path: &Path) -> Result<Plan, ImageIoError> {
    let find = |want: &str| channels.iter().position(|c| short(&c.name) == want);
    let (r, g, b, y, a) = (find("R"), find("G"), find("B"), find("Y"), find("A"));
    let (layout, sources) = match (r, g, b, y) {
        (Some(r), Some(g), Some(b), _) => match a {
            Some(a) => (ChannelLayout::Rgba, vec![r, g, b, a]),
            None => (ChannelLayout::Rgb, vec![r, g, b]),
        },
        (_, _, _, Some(y)) => match a {
            Some(a) => (ChannelLayout::GreyAlpha, vec![y, a]),
            None => (ChannelLayout::Grey, vec![y]),
        },
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(ImageIoError::Unsupported {
                path: path.to_path_buf(),
                reason: format!("OpenEXR channels {names:?} have no R, G, B or Y"),
            });
        }
    };
    for &i in &sources {
        if channels[i].sampling != Vec2(1, 1) {
            return Err(ImageIoError::Unsupported {
                path: path.to_path_buf(),
                reason: format!("subsampled OpenEXR channel {}", channels[i].name),
            });
        }
    }
    let names = sources
        .iter()
        .map(|&i| channels[i].name.to_string())
        .collect();
    Ok(Plan {
        layout,
        sources,
        names,
    })
}

fn corrupt(path: &Path, e: exr::error::Error) -> ImageIoError {
    tidy(corrupt_words(path, e))
}

fn corrupt_words(path: &Path, e: exr::error::Error) -> ImageIoError {
    let path = path.to_path_buf();
    match e {
        exr::error::Error::Io(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => {
            ImageIoError::Truncated {
                path,
                reason: source.to_string(),
            }
        }
        exr::error::Error::Io(source) => ImageIoError::Io { path, source },
        exr::error::Error::NotSupported(what) => ImageIoError::Unsupported {
            path,
            reason: format!("OpenEXR feature: {what}"),
        },
        // The exr crate reports a short file as a chunk pointing past the end.
        other if other.to_string().contains("missing bytes") => ImageIoError::Truncated {
            path,
            reason: other.to_string(),
        },
        other => ImageIoError::Corrupt {
            path,
            reason: other.to_string(),
        },
    }
}

pub(super) fn read_exr<R: std::io::BufRead + Seek>(
    mut reader: R,
    path: &Path,
    limits: &LoadLimits,
) -> Result<Raster, ImageIoError> {
    // The header alone first: check every layer's size before any pixel block is read.
    let meta = guarded(path, || {
        MetaData::read_from_buffered(&mut reader, false).map_err(|e| corrupt(path, e))
    })?;
    let header = meta.headers.first().ok_or_else(|| ImageIoError::Corrupt {
        path: path.to_path_buf(),
        reason: "OpenEXR file has no layers".into(),
    })?;
    for h in meta.headers.iter() {
        let size = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        limits.check(path, size.0, size.1)?;
        let channels = h.channels.list.len() as u64;
        // Up to 4 bytes a sample as read, and the raster's 4 bytes for each of up
        // to 4 kept channels.
        limits.check_memory(path, size, 4 * channels, channels.min(4))?;
        if h.deep {
            return Err(ImageIoError::Unsupported {
                path: path.to_path_buf(),
                reason: "deep OpenEXR data".into(),
            });
        }
    }
    let plan = plan(&header.channels.list, path)?;
    reader.rewind().map_err(|source| ImageIoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let image = guarded(path, || {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(reader)
            .map_err(|e| corrupt(path, e))
    })?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let list = &layer.channel_data.list;
    // The reader sorts channels by name just like the header lists them, but match
    // by name rather than rely on it.
    let mut samples = Vec::with_capacity(w * h * plan.sources.len());
    for name in &plan.names {
        let ch = list
            .iter()
            .find(|c| c.name.to_string() == *name)
            .ok_or_else(|| ImageIoError::Corrupt {
                path: path.to_path_buf(),
                reason: format!("channel {name} missing from the pixel data"),
            })?;
        let before = samples.len();
        match &ch.sample_data {
            FlatSamples::F16(v) => samples.extend(v.iter().map(|s| s.to_f32())),
            FlatSamples::F32(v) => samples.extend_from_slice(v),
            FlatSamples::U32(v) => samples.extend(v.iter().map(|&s| s as f32)),
        }
        if samples.len() - before != w * h {
            return Err(ImageIoError::Corrupt {
                path: path.to_path_buf(),
                reason: format!("channel {name} holds the wrong number of samples"),
            });
        }
    }
    let names: Vec<&str> = plan.names.iter().map(String::as_str).collect();
    raster_or_error(
        w as u32,
        h as u32,
        plan.layout,
        SampleFormat::F32,
        samples,
        path,
        &names,
    )
}

pub(super) fn write_exr(raster: &Raster, path: &Path) -> Result<Vec<u8>, ImageIoError> {
    write_exr_with(raster, path, &Metadata::default())
}

/// The layer attributes that carry metadata: untyped bytes with a MIME type hint.
fn metadata_attributes(meta: &Metadata) -> LayerAttributes {
    use exr::meta::attribute::AttributeValue;
    let mut attributes = LayerAttributes::default();
    for (name, hint, item) in [
        ("iccProfile", "application/vnd.iccprofile", &meta.icc),
        ("exif", "image/tiff", &meta.exif),
        ("xmp", "application/rdf+xml", &meta.xmp),
    ] {
        if let Some(bytes) = item {
            attributes.other.insert(
                Text::new_or_panic(name),
                AttributeValue::Bytes {
                    type_hint: Text::new_or_panic(hint),
                    bytes: bytes.as_slice().into(),
                },
            );
        }
    }
    attributes
}

/// The metadata attributes of the first layer's header.
pub(super) fn read_metadata(bytes: &[u8], path: &Path) -> Result<Metadata, ImageIoError> {
    use exr::meta::attribute::AttributeValue;
    let meta = guarded(path, || {
        MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| corrupt(path, e))
    })?;
    let mut out = Metadata::default();
    let Some(header) = meta.headers.first() else {
        return Ok(out);
    };
    let other = &header.own_attributes.other;
    for (name, item) in [
        ("iccProfile", &mut out.icc),
        ("exif", &mut out.exif),
        ("xmp", &mut out.xmp),
    ] {
        if let Some(AttributeValue::Bytes { bytes, .. }) = other.get(&Text::new_or_panic(name)) {
            *item = Some(bytes.to_vec());
        }
    }
    out.check_sizes().map_err(|source| ImageIoError::Metadata {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(out)
}

pub(super) fn write_exr_with(
    raster: &Raster,
    path: &Path,
    meta: &Metadata,
) -> Result<Vec<u8>, ImageIoError> {
    meta.check_sizes()
        .map_err(|source| ImageIoError::Metadata {
            path: path.to_path_buf(),
            source,
        })?;
    let names: &[&str] = match raster.layout() {
        ChannelLayout::Grey => &["Y"],
        ChannelLayout::GreyAlpha => &["Y", "A"],
        ChannelLayout::Rgb => &["R", "G", "B"],
        ChannelLayout::Rgba => &["R", "G", "B", "A"],
    };
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
        .iter()
        .enumerate()
        .map(|(c, name)| AnyChannel::new(*name, FlatSamples::F32(raster.plane(c).to_vec())))
        .collect();
    let layer = Layer::new(
        (raster.width() as usize, raster.height() as usize),
        metadata_attributes(meta),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut out = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| corrupt(path, e))?;
    Ok(out.into_inner())
}
