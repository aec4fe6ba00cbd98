//! Codec errors, sorted by who is at fault, carrying the offending values.

use thiserror::Error;

/// A section tag as messages show it: the letter for a printable tag, the byte's value
/// otherwise (a corrupt tag must not put control characters on a terminal).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tag(pub u8);

impl std::fmt::Display for Tag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_ascii_graphic() {
            write!(f, "'{}'", self.0 as char)
        } else {
            write!(f, "{:#04x}", self.0)
        }
    }
}

/// Why encoding or decoding failed.
#[derive(Debug, Error)]
pub enum CodecError {
    // --- The file's fault -----------------------------------------------------------
    /// The file does not start with the caoen magic bytes.
    #[error("not a caoen file: magic bytes {found:02x?}, expected \"CAOE\"")]
    WrongMagic {
        /// The first bytes of the file.
        found: Vec<u8>,
    },
    /// The file ends before its structure does.
    #[error("invalid caoen file: truncated: {what} at byte {offset} needs {need} bytes, {available} remain")]
    Truncated {
        /// What was being read.
        what: &'static str,
        /// Where it starts.
        offset: u64,
        /// Bytes it needs.
        need: u64,
        /// Bytes left in the file.
        available: u64,
    },
    /// A section's CRC does not match its contents.
    #[error("invalid caoen file: CRC mismatch in section {tag} at byte {offset}: stored {stored:08x}, computed {computed:08x}")]
    CrcMismatch {
        /// The section's tag.
        tag: Tag,
        /// Where the section starts.
        offset: u64,
        /// The CRC the file carries.
        stored: u32,
        /// The CRC of the bytes it covers.
        computed: u32,
    },
    /// A coded number lies outside the range the format allows.
    #[error("invalid caoen file: {what} = {value} is outside {lo}..={hi}")]
    OutOfRange {
        /// Which number.
        what: &'static str,
        /// Its value.
        value: f64,
        /// Smallest allowed.
        lo: f64,
        /// Largest allowed.
        hi: f64,
    },
    /// The file is malformed in some other way (section order, syntax, counts).
    #[error("invalid caoen file: {0}")]
    Format(String),

    // --- Not implemented here -------------------------------------------------------
    /// The file is of a format version this decoder does not read.
    #[error("unsupported caoen format version {found} (this decoder reads version {supported}; re-encode the image)")]
    UnsupportedVersion {
        /// The file's version.
        found: u8,
        /// The version this decoder reads.
        supported: u8,
    },
    /// The file is valid but uses something this decoder does not implement.
    #[error("unsupported: {0}")]
    Unsupported(String),

    // --- The caller's fault ---------------------------------------------------------
    /// A caller-supplied parameter is out of range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    Parameter {
        /// Which parameter.
        name: &'static str,
        /// Its value, formatted.
        value: String,
        /// The valid range.
        reason: &'static str,
    },
    /// The input image cannot be encoded (empty, non-finite samples).
    #[error("invalid image: {0}")]
    Image(#[from] crate::raster::RasterError),
    /// The surface core rejected the model.
    #[error("model: {0}")]
    Surface(#[from] crate::surface::SurfaceError),

    // --- Limits ---------------------------------------------------------------------
    /// Decoding would exceed a size limit.
    #[error("limit exceeded: {what} is {value}, limit {limit}")]
    Limit {
        /// What was measured.
        what: &'static str,
        /// The measured value.
        value: u64,
        /// The limit.
        limit: u64,
    },
    /// The work would exceed the memory budget.
    #[error(transparent)]
    Memory(#[from] crate::budget::OverBudget),
}

impl CodecError {
    /// An out-of-range coded number.
    pub(crate) fn range(what: &'static str, value: impl Into<f64>, lo: f64, hi: f64) -> Self {
        CodecError::OutOfRange {
            what,
            value: value.into(),
            lo,
            hi,
        }
    }
}
