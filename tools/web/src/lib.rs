//! The caoen decoder for JavaScript (`tools/web/build.sh` builds it into `pkg/caoen.js`):
//! `info`, `decode` and `decodeRegion` on the bytes of a `.cae` file, pixels as 8-bit
//! RGBA for a canvas. Every input is checked, so a bad file or argument throws an
//! `Error` with caoen's message rather than aborting the module.
#![forbid(unsafe_code)]

use caoen_decoder::bitstream::{self, Parsed};
use caoen_decoder::decoder::{self, Depth, Samples};
use caoen_decoder::{CodecError, DecodeOptions, Limits, Region, MAX_SIDE};
use js_sys::{Object, Reflect, Uint8Array, Uint8ClampedArray};
use wasm_bindgen::prelude::*;

pub mod rgba;

/// Most output pixels one call makes (16 megapixels: 64 MiB of RGBA), so a page cannot
/// make the tab allocate without bound.
pub const MAX_PIXELS: u64 = 1 << 24;
/// Memory budget of one call.
pub const MAX_MEMORY: u64 = 1 << 30;

/// The header and metadata of a file: `{width, height, channels, bits, bytes,
/// metadata: {icc, exif, xmp}}` (`bits` per sample as coded: 8, 16 or 32 for float).
#[wasm_bindgen]
pub fn info(bytes: &[u8]) -> Result<JsValue, JsError> {
    let parsed = bitstream::parse(bytes, u64::MAX).map_err(error)?;
    let h = &parsed.header;
    let (w, ht) = h.display_size();
    let out = Object::new();
    set(&out, "width", w.into())?;
    set(&out, "height", ht.into())?;
    set(&out, "channels", (h.layout.channels() as u32).into())?;
    set(&out, "bits", rgba::bits(h.format).into())?;
    set(&out, "bytes", (bytes.len() as f64).into())?;
    let meta = parsed.metadata();
    let m = Object::new();
    let blob = |b: &Option<Vec<u8>>| {
        b.as_deref()
            .map_or(JsValue::NULL, |b| Uint8Array::from(b).into())
    };
    set(&m, "icc", blob(&meta.icc))?;
    set(&m, "exif", blob(&meta.exif))?;
    let xmp = meta.xmp.as_deref().map_or(JsValue::NULL, |x| {
        String::from_utf8_lossy(x).into_owned().into()
    });
    set(&m, "xmp", xmp)?;
    set(&out, "metadata", m.into())?;
    Ok(out.into())
}

/// Decodes the whole image, at `width x height` if given (else its own size):
/// `{width, height, data}`, `data` RGBA samples in a `Uint8ClampedArray`.
#[wasm_bindgen]
pub fn decode(bytes: &[u8], width: Option<f64>, height: Option<f64>) -> Result<JsValue, JsError> {
    let size = match (width, height) {
        (None, None) => None,
        (Some(w), Some(h)) => Some((side("width", w)?, side("height", h)?)),
        _ => {
            return Err(JsError::new(
                "decode: give both width and height, or neither",
            ))
        }
    };
    run(bytes, size, None)
}

/// Decodes the rectangle `[x0, x1) x [y0, y1)` of the image (its own pixel
/// coordinates, fractions allowed) at `width x height`: `{width, height, data}`.
#[wasm_bindgen(js_name = decodeRegion)]
pub fn decode_region(
    bytes: &[u8],
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    width: f64,
    height: f64,
) -> Result<JsValue, JsError> {
    let size = (side("width", width)?, side("height", height)?);
    run(bytes, Some(size), Some(Region { x0, y0, x1, y1 }))
}

/// A side given by the page: a whole number of pixels in `1..=16384`.
fn side(name: &str, v: f64) -> Result<u32, JsError> {
    if v.fract() == 0.0 && (1.0..=f64::from(MAX_SIDE)).contains(&v) {
        Ok(v as u32)
    } else {
        Err(JsError::new(&format!(
            "invalid parameter {name} = {v}: a whole number in 1..={MAX_SIDE}"
        )))
    }
}

fn run(bytes: &[u8], size: Option<(u32, u32)>, region: Option<Region>) -> Result<JsValue, JsError> {
    let opts = DecodeOptions {
        size,
        supersample: None,
        max_pixels: MAX_PIXELS,
        limits: Limits::new(MAX_MEMORY),
        region,
    };
    let parsed: Parsed<'_> = bitstream::parse(bytes, MAX_PIXELS).map_err(error)?;
    let img = decoder::decode_interleaved_parsed(&parsed, &opts, Depth::Eight).map_err(error)?;
    let Samples::U8(samples) = &img.samples else {
        return Err(JsError::new("8-bit samples expected"));
    };
    let data = rgba::expand(samples, img.layout);
    let out = Object::new();
    set(&out, "width", img.width.into())?;
    set(&out, "height", img.height.into())?;
    set(&out, "data", Uint8ClampedArray::from(&data[..]).into())?;
    Ok(out.into())
}

fn error(e: CodecError) -> JsError {
    JsError::new(&e.to_string())
}

fn set(o: &Object, key: &str, v: JsValue) -> Result<(), JsError> {
    Reflect::set(o, &key.into(), &v)
        .map(|_| ())
        .map_err(|_| JsError::new("cannot build the result object"))
}
