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
    /// A length or count is not a LEB128 number of at most 32 bits in its shortest form.
    #[error("invalid caoen file: {what} at byte {offset} is not a LEB128 number of at most 32 bits in its shortest form")]
    Varint {
        /// What was being read.
        what: &'static str,
        /// Where it starts.
        offset: u64,
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
    /// The header section is longer than the fields its flags call for.
    #[error("invalid caoen file: header is {found} bytes, its fields take {expected}")]
    HeaderLength {
        /// The section's length.
        found: u64,
        /// The bytes the header's fields take.
        expected: u64,
    },
    /// The header's flags ask for deblocking, adaptive steps, lapping or frequency
    /// weights without the detail layer, or the luma basis without three colour
    /// channels.
    #[error("invalid caoen file: header flags {flags:#04x} (bit 0 pruned chroma, bit 1 detail layer, bit 2 deblocking, bit 3 adaptive steps, bit 4 lapping and bit 7 frequency weights, which need bit 1, bit 5 luma basis, which needs three colour channels, bit 6 steps by cell level)")]
    Flags {
        /// The flags byte.
        flags: u8,
    },
    /// The header's deblocking parameters are out of their ranges.
    #[error("invalid caoen file: deblocking strength {strength} (1..=255) or radius {radius} (1..=16 quarter pixels) out of range")]
    Deblock {
        /// Threshold in hundredths of the quantiser step.
        strength: u8,
        /// Ramp reach in quarter pixels.
        radius: u8,
    },
    /// The header's adaptive step factors include a zero, or its activity field's
    /// region side is out of range.
    #[error(
        "invalid caoen file: adaptive detail step factors {factors:?} (each 1..=255), activity field region log2 {field_log2} (0 for none, else 3..=7)"
    )]
    AdaptiveSteps {
        /// The factor bytes by cell-size class.
        factors: [u8; 3],
        /// The activity field's region side, log2 pixels.
        field_log2: u8,
    },
    /// The header's tile side is not a multiple of the side unit within the range.
    #[error("invalid caoen file: tile side {side} is not a multiple of {unit} in {unit}..={max}")]
    TileSide {
        /// The coded side.
        side: u32,
        /// The unit every side is a multiple of.
        unit: u32,
        /// The largest side.
        max: u32,
    },
    /// Chroma key points in a grey image, or none in a colour one.
    #[error("invalid caoen file: chroma key points present iff the image has colour ({what} has {chroma} chroma key points, the image has {channels} colour channels)")]
    ChromaPresence {
        /// The header or a tile.
        what: &'static str,
        /// Its chroma key point count.
        chroma: u32,
        /// The image's colour channels.
        channels: usize,
    },
    /// A tile carries detail blocks, but the header has no detail layer.
    #[error("invalid caoen file: a tile carries {bytes} bytes of detail blocks, but the header has no detail layer")]
    DetailWithoutLayer {
        /// Bytes of detail blocks in the tile.
        bytes: u64,
    },
    /// The end section has a payload.
    #[error("invalid caoen file: the end section at byte {offset} carries {len} bytes; it must be empty")]
    EndNotEmpty {
        /// Where the end section starts.
        offset: u64,
        /// Its payload's length.
        len: u64,
    },
    /// Bytes follow the end section.
    #[error("invalid caoen file: {bytes} bytes of trailing data after the end section")]
    TrailingData {
        /// How many.
        bytes: u64,
    },
    /// The first section is not the header.
    #[error("invalid caoen file: the first section must be the header, found {}", first.map_or("none".to_string(), |t| t.to_string()))]
    HeaderNotFirst {
        /// The first section's tag, if there is a section.
        first: Option<Tag>,
    },
    /// The sections are not in the order the format prescribes.
    #[error("invalid caoen file: sections {:?}: expected the header, optional metadata (I, X, M in this order), {tiles} tile sections (G), optional restoration (R) and the end (E)", String::from_utf8_lossy(tags))]
    SectionOrder {
        /// The sections' tags in file order.
        tags: Vec<u8>,
        /// The number of tile sections the header's size calls for.
        tiles: usize,
    },
    /// A count in the file disagrees with the count its header declares.
    #[error("invalid caoen file: {what}: {found} {unit}, {declared} declared")]
    CountMismatch {
        /// What holds them (a tile's tree, a tile's chroma tree, the tiles).
        what: &'static str,
        /// What is counted.
        unit: &'static str,
        /// How many the file holds.
        found: u64,
        /// How many the header declares.
        declared: u64,
    },
    /// An entropy-coded payload's length is not a whole number of coder words.
    #[error("invalid caoen file: entropy-coded payload of {bytes} bytes is not whole words")]
    PayloadNotWords {
        /// The payload's length.
        bytes: u64,
    },
    /// An entropy-coded payload does not hold a valid coder state.
    #[error("invalid caoen file: entropy-coded payload is malformed")]
    PayloadMalformed,
    /// A payload's syntax asks for more symbols than the payload may hold.
    #[error("invalid caoen file: entropy-coded payload runs past its syntax")]
    PayloadOverrun,
    /// A payload holds data past the end of its syntax.
    #[error("invalid caoen file: {stream} does not end where its syntax does")]
    PayloadLeftover {
        /// Which stream (tree, values, detail blocks).
        stream: &'static str,
    },
    /// The decoded samples do not make a raster.
    #[error("invalid caoen file: decoded raster: {0}")]
    DecodedRaster(#[source] caoen_base::raster::RasterError),
    /// The restoration section is malformed.
    #[error("invalid caoen file: restoration section: {reason}")]
    Restoration {
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The header's deringing strengths are not a valid filter.
    #[error("invalid caoen file: {what} strengths: primary {primary}, secondary {secondary}, cutoff {cutoff} (a filter with a strength needs a cutoff of 1..=255, one without is all zero, and at least one plane is filtered)")]
    Deringing {
        /// Which plane kind's.
        what: &'static str,
        /// The stored primary strength.
        primary: u8,
        /// The stored secondary strength.
        secondary: u8,
        /// The stored cutoff.
        cutoff: u8,
    },
    /// The key points evaluate to NaN or infinity somewhere.
    #[error("invalid caoen file: the key points evaluate to a non-finite colour")]
    NonFinite,

    // --- Not implemented here -------------------------------------------------------
    /// The file is of a format version this decoder does not read.
    #[error("unsupported caoen format version {found} (this decoder reads version {supported}; re-encode the image)")]
    UnsupportedVersion {
        /// The file's version.
        found: u8,
        /// The version this decoder reads.
        supported: u8,
    },

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
    /// A region to decode is not a rectangle inside the image.
    #[error("invalid region {x0},{y0},{x1},{y1} of a {width}x{height} image: {reason}")]
    Region {
        /// Left edge.
        x0: f64,
        /// Top edge.
        y0: f64,
        /// Right edge.
        x1: f64,
        /// Bottom edge.
        y1: f64,
        /// The image's width.
        width: u32,
        /// The image's height.
        height: u32,
        /// What is wrong.
        reason: &'static str,
    },
    /// The input image cannot be encoded (empty, non-finite samples).
    #[error("invalid image: {0}")]
    Image(#[from] caoen_base::raster::RasterError),

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
    Memory(#[from] caoen_base::budget::OverBudget),
}

impl CodecError {
    /// `found` of `unit` in `what` where the header declares `declared`; `Ok` when
    /// they agree.
    pub fn check_count(
        what: &'static str,
        unit: &'static str,
        found: u64,
        declared: u64,
    ) -> Result<(), Self> {
        if found == declared {
            return Ok(());
        }
        Err(CodecError::CountMismatch {
            what,
            unit,
            found,
            declared,
        })
    }

    /// An out-of-range coded number.
    pub fn range(what: &'static str, value: impl Into<f64>, lo: f64, hi: f64) -> Self {
        CodecError::OutOfRange {
            what,
            value: value.into(),
            lo,
            hi,
        }
    }
}
