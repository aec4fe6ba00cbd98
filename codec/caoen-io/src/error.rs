//! [`ImageIoError`], sorted by who is at fault, and the sorting of third-party decoders'
//! errors and panics into it.

use std::path::{Path, PathBuf};

use thiserror::Error;

/// Why an image could not be read or written, sorted by who is at fault.
#[derive(Debug, Error)]
pub enum ImageIoError {
    // --- The file's fault -----------------------------------------------------------
    /// The file is damaged or not what its format says.
    #[error("{}: corrupt image: {reason}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The file ends before the image does.
    #[error("{}: truncated image: {reason}", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The header declares a zero width or height.
    #[error("{}: empty image ({width}x{height})", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
    },
    /// A float sample is NaN or infinite; the codec only codes finite values.
    #[error(
        "{}: sample {value} in channel {channel} at pixel ({x}, {y}) is not finite",
        path.display()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Channel name as stored in the file (e.g. `R`).
        channel: String,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The offending value.
        value: f32,
    },
    /// The format or its pixel type is not one we read.
    #[error("{}: unsupported image: {reason}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is missing.
        reason: String,
    },
    /// The header declares an image larger than the limits allow.
    #[error(
        "{}: image is {width}x{height}, over the limit ({max_side} per side, {max_pixels} pixels)",
        path.display()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// Side limit in force.
        max_side: u32,
        /// Pixel limit in force.
        max_pixels: u64,
    },

    /// Decoding the image would exceed the memory budget.
    #[error("{}: {source}", path.display())]
    Memory {
        /// The file.
        path: PathBuf,
        /// The need and the budget.
        source: caoen_base::budget::OverBudget,
    },

    /// A metadata item (ICC profile, EXIF, XMP) is damaged or over its size limit.
    #[error("{}: {source}", path.display())]
    Metadata {
        /// The file.
        path: PathBuf,
        /// What is wrong with the item.
        source: caoen_base::metadata::MetadataError,
    },

    // --- The caller's fault ---------------------------------------------------------
    /// The output path's extension names no format we write.
    #[error("{}: cannot write this format (use .png or .exr)", path.display())]
    UnknownOutputFormat {
        /// The requested output.
        path: PathBuf,
    },

    // --- The environment's fault ----------------------------------------------------
    /// Reading or writing the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// The name errors of in-memory images carry until a caller names them.
pub const IN_MEMORY: &str = "<memory>";

impl ImageIoError {
    /// The error with `path` in place of `<memory>`: an image made in memory for a
    /// file is named after that file.
    pub fn named(mut self, path: &Path) -> Self {
        let slot = match &mut self {
            ImageIoError::Corrupt { path, .. }
            | ImageIoError::Truncated { path, .. }
            | ImageIoError::Empty { path, .. }
            | ImageIoError::NonFinite { path, .. }
            | ImageIoError::Unsupported { path, .. }
            | ImageIoError::TooLarge { path, .. }
            | ImageIoError::Memory { path, .. }
            | ImageIoError::Metadata { path, .. }
            | ImageIoError::UnknownOutputFormat { path }
            | ImageIoError::Io { path, .. } => path,
        };
        if slot.as_os_str() == IN_MEMORY {
            *slot = path.to_path_buf();
        }
        self
    }
}

/// Runs a third-party decoder, turning a panic inside it into [`ImageIoError::Corrupt`]:
/// a bad file must never bring the program down.
pub(super) fn guarded<T>(
    path: &Path,
    f: impl FnOnce() -> Result<T, ImageIoError>,
) -> Result<T, ImageIoError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        Err(tidy(ImageIoError::Corrupt {
            path: path.to_path_buf(),
            reason: format!("the decoder failed: {what}"),
        }))
    })
}

/// Sorts an `image` crate error by fault.
/// A third-party decoder's words as one printable line: trimmed, control characters
/// escaped.
pub(super) fn tidy(e: ImageIoError) -> ImageIoError {
    let line = |r: String| caoen_base::printable(r.trim());
    match e {
        ImageIoError::Truncated { path, reason } => ImageIoError::Truncated {
            path,
            reason: line(reason),
        },
        ImageIoError::Corrupt { path, reason } => ImageIoError::Corrupt {
            path,
            reason: line(reason),
        },
        ImageIoError::Unsupported { path, reason } => ImageIoError::Unsupported {
            path,
            reason: line(reason),
        },
        other => other,
    }
}

pub(super) fn image_error(path: &Path, e: image::ImageError) -> ImageIoError {
    tidy(image_error_words(path, e))
}

fn image_error_words(path: &Path, e: image::ImageError) -> ImageIoError {
    use image::error::{ImageError as E, LimitErrorKind};
    let path = path.to_path_buf();
    match e {
        E::IoError(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => {
            ImageIoError::Truncated {
                path,
                reason: source.to_string(),
            }
        }
        E::IoError(source) => ImageIoError::Io { path, source },
        E::Unsupported(u) => ImageIoError::Unsupported {
            path,
            reason: u.to_string(),
        },
        E::Limits(l) if matches!(l.kind(), LimitErrorKind::DimensionError) => {
            ImageIoError::Corrupt {
                path,
                reason: format!("image dimensions rejected: {l}"),
            }
        }
        E::Limits(l) => ImageIoError::Corrupt {
            path,
            reason: format!("decoding needs more memory than the limits allow: {l}"),
        },
        other => {
            let reason = other.to_string();
            // Decoders report a short file in their own words.
            let lower = reason.to_ascii_lowercase();
            if lower.contains("eof") || lower.contains("end of file") || lower.contains("truncat") {
                ImageIoError::Truncated { path, reason }
            } else {
                ImageIoError::Corrupt { path, reason }
            }
        }
    }
}
