//! `caoen._caoen`, the native side of the `caoen` Python package: NumPy arrays to
//! `.cae` bytes and back through the same library calls as the `caoen` command line
//! (so the same input and options give the same bytes), with the GIL released while
//! the codec works and every error, a panic included, raised as `caoen.CaoenError`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use caoen_base::budget::{Limits, DEFAULT_BUDGET};
use caoen_base::metadata::{Metadata, MetadataPolicy};
use caoen_base::raster::{ChannelLayout, SampleFormat};
use caoen_decoder::{bitstream, DecodeOptions, Region, DEFAULT_MAX_PIXELS, MAX_SIDE};
use caoen_encoder::{EncodeRequest, PixelSource};
use caoen_io::transcode::DecodeToImage;
use caoen_io::{LoadLimits, PixelData, Pixels};
use numpy::{PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

// Named as the package exports it: tracebacks say `caoen.CaoenError`.
pyo3::create_exception!(
    caoen,
    CaoenError,
    PyValueError,
    "An image or file caoen cannot code, or options it refuses; the message is caoen's."
);

/// A `CaoenError` with `message`.
fn error(message: impl std::fmt::Display) -> PyErr {
    CaoenError::new_err(message.to_string())
}

/// Runs `work` without the GIL; a panic in it becomes a `CaoenError` rather than
/// unwinding into Python.
fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, String> + Send,
) -> PyResult<T> {
    py.detach(|| {
        catch_unwind(AssertUnwindSafe(work)).unwrap_or_else(|panic| {
            let what = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown");
            Err(format!(
                "internal error in caoen (please report it): {what}"
            ))
        })
    })
    .map_err(error)
}

/// The samples of a NumPy array `HxW`, `HxWx1..4` of uint8, uint16 or float32, copied
/// (any strides) into row-major interleaved order.
fn pixels_of(array: &Bound<'_, PyAny>) -> PyResult<Pixels> {
    let untyped = array.cast::<PyUntypedArray>().map_err(|_| {
        error(format!(
            "expected a NumPy array, got {}",
            array
                .get_type()
                .name()
                .map_or("?".into(), |n| n.to_string())
        ))
    })?;
    let shape = untyped.shape().to_vec();
    let (h, w, c) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, c] if (1..=4).contains(&c) => (h, w, c),
        _ => {
            return Err(error(format!(
                "expected an array of shape HxW, HxWx3 or HxWx4 (or HxWx1, HxWx2), got {shape:?}"
            )))
        }
    };
    if h == 0 || w == 0 || h > MAX_SIDE as usize || w > MAX_SIDE as usize {
        return Err(error(format!(
            "an image of {w}x{h} pixels: each side must be in 1..={MAX_SIDE}"
        )));
    }
    let layout = ChannelLayout::from_channels(c).expect("1..=4 channels");
    let data = if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        PixelData::U8(a.as_array().iter().copied().collect())
    } else if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'_, u16>>() {
        PixelData::U16(a.as_array().iter().copied().collect())
    } else if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'_, f32>>() {
        PixelData::F32(a.as_array().iter().copied().collect())
    } else {
        return Err(error(format!(
            "expected samples of uint8, uint16 or float32, got {}",
            untyped.dtype()
        )));
    };
    Ok(Pixels {
        width: w as u32,
        height: h as u32,
        layout,
        data,
    })
}

/// A NumPy array of `pixels`: `HxW` for grey, else `HxWxC`.
fn array_of<'py>(py: Python<'py>, pixels: Pixels) -> PyResult<Bound<'py, PyAny>> {
    let (h, w, c) = (
        pixels.height as usize,
        pixels.width as usize,
        pixels.layout.channels(),
    );
    let shape: Vec<usize> = if c == 1 { vec![h, w] } else { vec![h, w, c] };
    let array = match pixels.data {
        PixelData::U8(v) => numpy::PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        PixelData::U16(v) => numpy::PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        PixelData::F32(v) => numpy::PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
    };
    Ok(array)
}

/// The request of the Python options, as `caoen encode -q -e --target-size
/// --target-bpp` makes it (effort 5 when not given, the default budget).
fn request(
    quality: f32,
    effort: Option<i64>,
    target_size: Option<i64>,
    target_bpp: Option<f64>,
    metadata: Metadata,
) -> PyResult<EncodeRequest> {
    let effort = match effort {
        None => EncodeRequest::default().effort,
        Some(e) if (1..=9).contains(&e) => e as u8,
        Some(e) => return Err(error(format!("invalid parameter effort = {e}: 1..=9"))),
    };
    let target_size = match target_size {
        None => None,
        Some(n) if n > 0 => Some(n as u64),
        Some(n) => {
            return Err(error(format!(
                "invalid parameter target_size = {n}: must be positive"
            )))
        }
    };
    Ok(EncodeRequest {
        quality,
        effort,
        target_bpp,
        target_size,
        metadata,
        ..EncodeRequest::default()
    })
}

/// Encodes a NumPy image (`HxW`, `HxWx3`, `HxWx4`; uint8, uint16 or float32) into
/// `.cae` bytes.
#[pyfunction]
#[pyo3(signature = (array, quality=75.0, effort=None, target_size=None, target_bpp=None, icc=None, exif=None, xmp=None))]
#[allow(clippy::too_many_arguments)] // The Python signature.
fn encode<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    quality: f32,
    effort: Option<i64>,
    target_size: Option<i64>,
    target_bpp: Option<f64>,
    icc: Option<Vec<u8>>,
    exif: Option<Vec<u8>>,
    xmp: Option<Vec<u8>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let pixels = pixels_of(array)?;
    let metadata = Metadata { icc, exif, xmp };
    let request = request(quality, effort, target_size, target_bpp, metadata)?;
    let bytes = detached(py, move || {
        let source = pixels.into_source().map_err(|e| e.to_string())?;
        let opts = request
            .options(source.held_bytes())
            .map_err(|e| e.to_string())?;
        caoen_encoder::encode(&source, &opts).map_err(|e| e.to_string())
    })?;
    Ok(PyBytes::new(py, &bytes))
}

/// Encodes an image file (anything `caoen encode` reads) exactly as `caoen encode FILE`
/// with the same options does: upright by its EXIF orientation, with its metadata as
/// `metadata` ("all", "icc", "none") keeps it.
#[pyfunction]
#[pyo3(signature = (path, quality=75.0, effort=None, target_size=None, target_bpp=None, metadata="all"))]
fn encode_file<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    quality: f32,
    effort: Option<i64>,
    target_size: Option<i64>,
    target_bpp: Option<f64>,
    metadata: &str,
) -> PyResult<Bound<'py, PyBytes>> {
    let policy = match metadata {
        "all" => MetadataPolicy::All,
        "icc" => MetadataPolicy::Icc,
        "none" => MetadataPolicy::None,
        other => {
            return Err(error(format!(
                "metadata = {other:?}: expected \"all\", \"icc\" or \"none\""
            )))
        }
    };
    let mut request = request(
        quality,
        effort,
        target_size,
        target_bpp,
        Metadata::default(),
    )?;
    let bytes = detached(py, move || {
        let limits = LoadLimits {
            max_pixels: DEFAULT_MAX_PIXELS,
            ..LoadLimits::within(&Limits::new(request.budget))
        };
        let (source, meta) =
            caoen_io::load_for_encoding(&path, &limits).map_err(|e| e.to_string())?;
        request.metadata = meta.filtered(policy);
        let opts = request
            .options(source.held_bytes())
            .map_err(|e| e.to_string())?;
        caoen_encoder::encode(&source, &opts).map_err(|e| format!("{}: {e}", path.display()))
    })?;
    Ok(PyBytes::new(py, &bytes))
}

/// Decodes `.cae` bytes to a NumPy array of the file's sample type, at the image's
/// size or at `size = (width, height)`; `region = (x0, y0, x1, y1)` decodes that
/// rectangle of the image (its own pixel coordinates) at its own size or at `size`.
#[pyfunction]
#[pyo3(signature = (data, size=None, region=None))]
fn decode<'py>(
    py: Python<'py>,
    data: &[u8],
    size: Option<(i64, i64)>,
    region: Option<(f64, f64, f64, f64)>,
) -> PyResult<Bound<'py, PyAny>> {
    let size = match size {
        None => None,
        Some((w, h))
            if (1..=i64::from(MAX_SIDE)).contains(&w) && (1..=i64::from(MAX_SIDE)).contains(&h) =>
        {
            Some((w as u32, h as u32))
        }
        Some((w, h)) => {
            return Err(error(format!(
                "size = ({w}, {h}): each side must be in 1..={MAX_SIDE}"
            )))
        }
    };
    let opts = DecodeToImage {
        decode: DecodeOptions {
            size,
            limits: Limits::new(DEFAULT_BUDGET),
            region: region.map(|(x0, y0, x1, y1)| Region { x0, y0, x1, y1 }),
            ..DecodeOptions::default()
        },
        ..DecodeToImage::default()
    };
    let data = data.to_vec();
    let pixels = detached(py, move || {
        caoen_io::decode_to_pixels(&data, Path::new("<bytes>"), &opts)
            .map(|(pixels, _)| pixels)
            .map_err(|e| e.to_string())
    })?;
    array_of(py, pixels)
}

/// Reads an image file (PNG, JPEG, EXR, anything `caoen encode` reads) upright, as a
/// NumPy array of its own sample type, with its metadata.
#[pyfunction]
fn load<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let (pixels, meta) = detached(py, move || {
        let limits = LoadLimits {
            max_pixels: DEFAULT_MAX_PIXELS,
            ..LoadLimits::within(&Limits::new(DEFAULT_BUDGET))
        };
        caoen_io::load_pixels(&path, &limits).map_err(|e| e.to_string())
    })?;
    Ok((array_of(py, pixels)?, metadata_dict(py, &meta)?))
}

/// The metadata items as a dict of bytes (or None).
fn metadata_dict<'py>(py: Python<'py>, meta: &Metadata) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (key, item) in [("icc", &meta.icc), ("exif", &meta.exif), ("xmp", &meta.xmp)] {
        d.set_item(key, item.as_deref().map(|b| PyBytes::new(py, b)))?;
    }
    Ok(d)
}

/// The NumPy name of a sample format.
fn dtype_name(format: SampleFormat) -> &'static str {
    match format {
        SampleFormat::U8 => "uint8",
        SampleFormat::U16 => "uint16",
        SampleFormat::F32 => "float32",
    }
}

/// What a `.cae` file holds, without decoding it: size, channels, sample type, coded
/// size, key points, tiles, bits per pixel, and its ICC profile, EXIF and XMP.
#[pyfunction]
fn info<'py>(py: Python<'py>, data: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    let parsed = caoen_decoder::inspect(data).map_err(error)?;
    let h = &parsed.header;
    let (w, ht) = h.display_size();
    let d = PyDict::new(py);
    d.set_item("width", w)?;
    d.set_item("height", ht)?;
    d.set_item("channels", h.layout.channels())?;
    d.set_item("alpha", h.layout.has_alpha())?;
    d.set_item("dtype", dtype_name(h.format))?;
    d.set_item("coded_width", h.width)?;
    d.set_item("coded_height", h.height)?;
    d.set_item("luma_keypoints", h.luma_count)?;
    d.set_item("chroma_keypoints", h.chroma_count)?;
    d.set_item("tiles", h.tiling().count())?;
    d.set_item("bytes", data.len())?;
    d.set_item(
        "bpp",
        data.len() as f64 * 8.0 / (f64::from(w) * f64::from(ht)),
    )?;
    d.set_item("version", bitstream::VERSION)?;
    d.update(metadata_dict(py, &parsed.metadata())?.as_mapping())?;
    Ok(d)
}

/// Whether `caoen encode DIR` takes a file by its name (PNG, JPEG, EXR, ...).
#[pyfunction]
fn is_image_name(path: std::path::PathBuf) -> bool {
    caoen_io::is_image_name(&path)
}

/// The native module.
#[pymodule]
fn _caoen(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CaoenError", m.py().get_type::<CaoenError>())?;
    m.add("FORMAT_VERSION", bitstream::VERSION)?;
    m.add_function(wrap_pyfunction!(encode, m)?)?;
    m.add_function(wrap_pyfunction!(encode_file, m)?)?;
    m.add_function(wrap_pyfunction!(decode, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(is_image_name, m)?)?;
    Ok(())
}
